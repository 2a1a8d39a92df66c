//! The papers' rendering pipelines, beside the table families of `fits/`: a table
//! answers one query; a pipeline combines several tables into pictures of a scene and
//! measures them against a Monte Carlo reference with exact visibility.
//!
//! What every pipeline shares lives here, once:
//!
//! - [`scene`]: geometry (spheres, planes; rays; a BVH over spheres), the pinhole
//!   camera, materials, lights, and the JSON scene file every pipeline reads
//!   (`pipelines/scenes/*.json`, documented in docs/pipelines.md);
//! - [`estimate`]: the Monte Carlo estimator, which always reports its standard error;
//! - [`image`]: image statistics against a reference (relative RMSE, p99, max, error
//!   maps) and image output (PNG panels and a PFM float image generic tools read);
//! - [`timing`]: the cost of the reference at the pipeline's error (equal-error timing).
//!
//! Each pipeline is one module ([`meunier`], [`isg`], [`shexp`], [`rigs`]) and one entry of [`registry`],
//! which `lobefit render NAME` lists.

pub mod baselines;
pub mod estimate;
pub mod heightfield;
pub mod image;
pub mod isg;
pub mod meunier;
pub mod rigs;
pub mod scene;
pub mod shexp;
pub mod sky;
pub mod timing;

use std::path::{Path, PathBuf};

use lobefit_core::family::{EvalFlags, View};
use lobefit_fits::PlotFn;

/// Most Monte Carlo samples (pixels × samples per pixel) one image may take: 14 times
/// the default 160 × 120 × 1024 (a render scales linearly in it).
pub const MAX_SAMPLES: u64 = 1 << 28;

/// Options every `lobefit render` takes.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    /// Image width (pixels); the height is 3/4 of it.
    pub width: usize,
    /// Reference samples per pixel.
    pub spp: usize,
    /// Every `breakdown_stride`-th pixel (in x and y) gets the pipeline's error
    /// breakdown, where it has one.
    pub breakdown_stride: usize,
}

/// Measured results of one rendered scene.
#[derive(Debug, Clone, Default)]
pub struct Summary {
    /// Lines of text (also written to the scene's `*-summary.txt`).
    pub lines: Vec<String>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Relative RMSE of the pipeline's default settings against the reference, over
    /// the pixels that see geometry.
    pub rel_rmse: f64,
    /// Mean relative standard error of the reference.
    pub ref_rel_se: f64,
}

impl Summary {
    /// Writes the lines to `dir/<stem>-summary.txt` (atomically) and records the file.
    pub fn write(&mut self, dir: &Path, stem: &str) -> Result<(), String> {
        let text: String = self.lines.iter().map(|l| format!("{l}\n")).collect();
        let path = dir.join(format!("{stem}-summary.txt"));
        lobefit_core::io::write_atomic(&path, text.as_bytes()).map_err(|e| format!("{}: {e}", path.display()))?;
        self.files.push(path);
        Ok(())
    }
}

/// Renders one scene (a [`Pipeline::scenes`] name or a scene file's path) into a
/// directory; `progress` is called once per finished image row of the reference.
pub type RenderFn = fn(&str, &RenderOptions, &Path, &(dyn Fn() + Sync)) -> Result<Summary, String>;

/// One pipeline: everything the CLI knows of it (`lobefit render NAME`, its `eval`
/// views, its `plot` figure sets) is in this entry, and [`registry`] is the one list
/// of them.
#[derive(Debug, Clone, Copy)]
pub struct Pipeline {
    /// Command-line name.
    pub name: &'static str,
    /// One line for `--help`.
    pub about: &'static str,
    /// Its built-in scenes (`--scene all` renders each).
    pub scenes: &'static [&'static str],
    /// The renderer.
    pub render: RenderFn,
    /// Its `lobefit eval` views (the pipeline without images).
    pub eval: &'static [EvalView],
    /// Its `lobefit plot` figure sets.
    pub plots: &'static [(&'static str, PlotFn)],
}

impl Pipeline {
    /// The scene `name`: the built-in `<pipeline>-<name>`, else a scene file (its load
    /// error then also lists the built-ins). The pipeline's own checks are the caller's.
    pub fn scene(&self, name: &str) -> Result<scene::Scene, String> {
        match scene::builtin(&format!("{}-{name}", self.name)) {
            Some(s) => s,
            None => scene::load(name).map_err(|e| {
                format!(
                    "{e} (not a built-in scene of {} either: {})",
                    self.name,
                    self.scenes.join(", ")
                )
            }),
        }
    }
}

/// A pipeline's query for `lobefit eval NAME [flags]` (the pipeline without images).
pub type EvalFn = fn(&EvalFlags) -> Result<Box<dyn View>, String>;

/// A pipeline's `lobefit eval` name, its paragraph of `eval --help`, its query.
pub type EvalView = (&'static str, &'static str, EvalFn);

/// The `lobefit eval` names the pipelines add to the families', from [`registry`].
pub fn eval_views() -> Vec<EvalView> {
    registry().iter().flat_map(|p| p.eval.iter().copied()).collect()
}

/// The `lobefit plot` figure sets of the pipelines, from [`registry`].
pub fn plots() -> Vec<(&'static str, PlotFn)> {
    registry().iter().flat_map(|p| p.plots.iter().copied()).collect()
}

/// Every pipeline: the only list.
pub fn registry() -> Vec<Pipeline> {
    vec![
        meunier::PIPELINE,
        isg::PIPELINE,
        shexp::PIPELINE,
        rigs::render::PIPELINE,
    ]
}

/// The pipeline called `name`.
pub fn by_name(name: &str) -> Option<Pipeline> {
    registry().into_iter().find(|p| p.name == name)
}
