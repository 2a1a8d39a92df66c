//! The papers' rendering pipelines, beside the table families of `fits/`: a table
//! answers one query; a pipeline combines several tables into pictures of a scene and
//! measures them against a Monte Carlo reference with exact visibility.
//!
//! What every pipeline shares lives here, once:
//!
//! - [`scene`]: geometry (spheres, planes; rays; a BVH over spheres), the pinhole
//!   camera, materials, lights, and the JSON scene file every pipeline reads
//!   (documented in docs/pipelines.md; each pipeline's built-ins in
//!   `pipelines/<p>/scenes/`, compiled into its [`Pipeline::files`]);
//! - [`estimate`]: the Monte Carlo estimator, which always reports its standard error;
//! - [`image`]: image statistics against a reference (relative RMSE, p99, max, error
//!   maps) and image output (PNG panels and a PFM float image generic tools read);
//! - [`timing`]: the cost of the reference at the pipeline's error (equal-error timing).
//!
//! Each pipeline is one module ([`meunier`], [`isg`], [`shexp`], [`rigs`]) and one entry of [`registry`],
//! which `lobefit render NAME` lists.

pub mod animate;
pub mod baselines;
pub mod brdf_fit;
pub mod envmap;
pub mod estimate;
pub mod heightfield;
pub mod image;
pub mod isg;
pub mod measure;
pub mod mesh;
pub mod meunier;
pub mod prefilter;
pub mod render;
pub mod rigs;
pub mod scene;
pub mod sg;
pub mod shexp;
pub mod skin;
pub mod sky;
pub mod spheres;
pub mod timing;

use std::path::{Path, PathBuf};

use lobefit_core::family::{EvalFlag, EvalFlags, View};
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
    /// One [`Headline`] line per rendered scene: printed last (after the files), the
    /// line a person reads first; also the last line of `*-summary.txt`.
    pub headline: Vec<String>,
}

impl Summary {
    /// Writes the lines, then the headline, to `dir/<stem>-summary.txt` (atomically)
    /// and records the file.
    pub fn write(&mut self, dir: &Path, stem: &str) -> Result<(), String> {
        let text: String = self
            .lines
            .iter()
            .chain(&self.headline)
            .map(|l| format!("{l}\n"))
            .collect();
        let path = dir.join(format!("{stem}-summary.txt"));
        lobefit_core::io::write_atomic(&path, text.as_bytes()).map_err(|e| format!("{}: {e}", path.display()))?;
        self.files.push(path);
        Ok(())
    }
}

/// The one-line summary of a render, assembled from numbers the render already
/// printed: what it rendered, the method's error, its cost next to a baseline's and the
/// ratio. [`Headline::line`]:
///
/// `summary: isg fig12 32×24 — ISG (best model): relative RMSE 0.0158 against …;
/// 197 µs/px vs plain Monte Carlo at that error 2843 µs/px (14× less time)`
#[derive(Debug, Clone)]
pub struct Headline {
    /// The render: pipeline and scene, e.g. `isg fig12`.
    pub render: String,
    /// Its extent, e.g. `32×24` or `24 frames × 800 points`.
    pub scope: String,
    /// The method the numbers are of.
    pub method: String,
    /// Its error, with what it is measured against (`relative RMSE 0.0158 against …`).
    pub error: String,
    /// The method's time per unit (µs).
    pub cost_us: f64,
    /// The unit the costs are per (`px`, `point`).
    pub unit: String,
    /// What the method is timed against.
    pub baseline: String,
    /// The baseline's time per unit (µs).
    pub baseline_us: f64,
    /// The ratio's spread over the timed runs, (low, high), where measured.
    pub spread: Option<(f64, f64)>,
    /// Whether the baseline's time is measured at the method's error or only bounds
    /// it (the ratio is then a bound too, said so by `>` or `<`).
    pub bound: Bound,
}

/// How a [`Headline`]'s baseline time stands to the time at the method's error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// Measured there (interpolated between measured points around it).
    Measured,
    /// A lower bound: its last measured point had not reached the method's error.
    AtLeast,
    /// An upper bound: its first measured point was already below the method's error.
    AtMost,
}

impl Headline {
    /// The line: `summary: <render> <scope> — <method>: <error>; <cost> µs/<unit> vs
    /// <baseline> <cost> µs/<unit> (<ratio>× less time [lo–hi] | <1/ratio>× more time
    /// [lo–hi])`; times to 3–4 significant figures, `> ` or `< ` before a ratio that is
    /// a bound ([`Bound`]).
    pub fn line(&self) -> String {
        let ratio = self.baseline_us / self.cost_us;
        // The ratio baseline/method bounded from below (AtLeast) or above (AtMost): "less
        // time" reads it as is, "more time" as its inverse, so the sign turns there.
        let (less, more) = match self.bound {
            Bound::Measured => ("", ""),
            Bound::AtLeast => ("> ", "< "),
            Bound::AtMost => ("< ", "> "),
        };
        let spread = self.spread.map_or(String::new(), |(lo, hi)| {
            if ratio >= 1.0 {
                format!(" [{}–{}]", short_number(lo), short_number(hi))
            } else {
                format!(" [{}–{}]", short_number(1.0 / hi), short_number(1.0 / lo))
            }
        });
        let times = if !ratio.is_finite() || ratio <= 0.0 {
            "no ratio".to_string()
        } else if ratio >= 1.0 {
            format!("{less}{}× less time{spread}", short_number(ratio))
        } else {
            format!("{more}{}× more time{spread}", short_number(1.0 / ratio))
        };
        format!(
            "summary: {} {} — {}: {}; {} µs/{} vs {} {} µs/{} ({times})",
            self.render,
            self.scope,
            self.method,
            self.error,
            short_number(self.cost_us),
            self.unit,
            self.baseline,
            short_number(self.baseline_us),
            self.unit
        )
    }
}

/// A positive number to 3 significant figures, or its integer part from 1000 on
/// (`0.0123`, `4.56`, `78.9`, `2843`); non-finite ones as Rust prints them.
pub(crate) fn short_number(x: f64) -> String {
    let a = x.abs();
    if !x.is_finite() {
        format!("{x}")
    } else if a >= 100.0 {
        format!("{x:.0}")
    } else if a >= 10.0 {
        format!("{x:.1}")
    } else if a >= 1.0 {
        format!("{x:.2}")
    } else if a == 0.0 {
        "0".into()
    } else {
        // 3 significant figures below 1: as many decimals as the leading zeros need.
        let decimals = (2.0 - a.log10().floor()) as usize;
        format!("{x:.decimals$}")
    }
}

/// A pipeline's scene loader ([`MonteCarlo::load`]): the scene by name, with its checks.
pub type LoadFn = fn(&str) -> Result<scene::Scene, String>;

/// Renders one scene (a [`Pipeline::scenes`] name or a scene file's path) into a
/// directory; `progress` is called once per finished image row of the reference.
pub type RenderFn = fn(&str, &RenderOptions, &Path, &(dyn Fn() + Sync)) -> Result<Summary, String>;

/// A pipeline's Pareto study (`lobefit render NAME --pareto WIDTH`; see [`baselines`]).
#[derive(Debug, Clone, Copy)]
pub struct ParetoStudy {
    /// Refuses a scene the study cannot take, before the render spends its time.
    pub takes: fn(&str) -> Result<(), String>,
    /// The study of one scene at a width (pixels) into a directory: the files written.
    pub run: fn(&str, usize, &Path) -> Result<Vec<PathBuf>, String>,
}

/// What a pipeline's renders are checked against.
#[derive(Debug, Clone, Copy)]
pub enum Truth {
    /// Monte Carlo on the scenes it reads (built-ins and files).
    MonteCarlo(MonteCarlo),
    /// A closed form on scenes built in code (the rigs: exact irradiance), so no scene
    /// file, no sample budget and no breakdown reference.
    Analytic,
}

/// A pipeline checked against Monte Carlo: the scenes it reads and what its
/// references cost.
#[derive(Debug, Clone, Copy)]
pub struct MonteCarlo {
    /// The scene kinds it shades: one rule for its renders and its `eval` views,
    /// checked before anything expensive is built.
    pub accepts: scene::Accepts,
    /// Its scene by name with its own checks (what its render and its device kernels
    /// load: a built-in or a file it can shade).
    pub load: LoadFn,
    /// Monte Carlo references per pixel of the image (an upper bound on its samples:
    /// pixels × spp × this), and per pixel of the error breakdown's subset (each of
    /// `spp` × [`MonteCarlo::precise_factor`] samples).
    pub references: (u64, u64),
    /// The breakdown's references take this many times `spp`.
    pub precise_factor: u64,
}

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
    /// Its built-in scene files, stills and animations: (name, JSON text), the files
    /// of `pipelines/<p>/scenes/` compiled in; each is also `<pipeline>-<name>`
    /// everywhere a scene is named ([`scene_text`]).
    pub files: &'static [(&'static str, &'static str)],
    /// The renderer.
    pub render: RenderFn,
    /// What its renders are checked against, and what that decides.
    pub truth: Truth,
    /// Its `lobefit eval` views (the pipeline without images).
    pub eval: &'static [EvalView],
    /// Its `lobefit plot` figure sets.
    pub plots: &'static [(&'static str, PlotFn)],
    /// Its animation renderer (`lobefit render NAME --frames N`), if it has one.
    pub animate: Option<animate::AnimateFn>,
    /// Its built-in animated scenes (`--frames N --scene all` renders each).
    pub animations: &'static [&'static str],
    /// Its Pareto study against every Monte Carlo estimator, if it has one.
    pub pareto: Option<ParetoStudy>,
}

impl Pipeline {
    /// Its Monte Carlo contract, where its truth is Monte Carlo.
    pub fn monte_carlo(&self) -> Option<&MonteCarlo> {
        match &self.truth {
            Truth::MonteCarlo(m) => Some(m),
            Truth::Analytic => None,
        }
    }

    /// The scene `name`: the built-in `<pipeline>-<name>`, else a scene file (its load
    /// error then also lists the built-ins). The pipeline's own checks are the caller's;
    /// a pipeline whose scenes are built in code reads none.
    pub fn scene(&self, name: &str) -> Result<scene::Scene, String> {
        let accepts = &self
            .monte_carlo()
            .ok_or_else(|| {
                format!(
                    "the {} pipeline's scenes are built in code: {}",
                    self.name,
                    self.scenes.join(", ")
                )
            })?
            .accepts;
        match self.file(name) {
            Some(text) => scene::load_text_for(
                &scene::SceneText::builtin(&format!("{}-{name}", self.name), text),
                accepts,
            ),
            None => scene_text(name)
                .and_then(|t| scene::load_text_for(&t, accepts))
                .map_err(|e| {
                    format!(
                        "{e} (not a built-in scene of {} either: {})",
                        self.name,
                        self.scenes.join(", ")
                    )
                }),
        }
    }

    /// Most Monte Carlo samples a render with `opts` takes (every reference: the
    /// image's, and the breakdown's on every `breakdown_stride`-th pixel in x and y, as
    /// if every pixel saw geometry).
    pub fn samples(&self, opts: &RenderOptions) -> u64 {
        let (w, h) = (opts.width.max(4) as u64, (opts.width * 3 / 4).max(3) as u64);
        let stride = opts.breakdown_stride.max(1) as u64;
        let picks = w.div_ceil(stride) * h.div_ceil(stride);
        let spp = opts.spp as u64;
        let (image, breakdown, factor) = self
            .monte_carlo()
            .map_or((0, 0, 0), |m| (m.references.0, m.references.1, m.precise_factor));
        // The headline's measurement too, where the pipeline has a Monte Carlo reference.
        let headline = if image > 0 { measure::HEADLINE_SAMPLES } else { 0 };
        (w * h * spp * image)
            .saturating_add(picks * spp * factor * breakdown)
            .saturating_add(headline)
    }

    /// An error naming the limit when a render of `scene` with `opts` would take more
    /// than [`MAX_RENDER_SAMPLES`] Monte Carlo samples, or more than [`MAX_WORK`]
    /// samples × light terms (SGs + sphere lights, at least 1) × blockers (spheres and
    /// the meshes' sphere sets, plus 1 for a height field, at least 1).
    pub fn check_work(&self, scene: &scene::Scene, opts: &RenderOptions) -> Result<(), String> {
        let (lights, blockers) = terms(scene);
        self.limits(&scene.name, lights, blockers, opts, None)
    }

    /// The limits of [`Pipeline::check_work`] and, with `frames`, of
    /// [`Pipeline::check_frames`], for a scene of `lights` light terms and `blockers`
    /// blockers.
    fn limits(
        &self,
        scene: &str,
        lights: u64,
        blockers: u64,
        opts: &RenderOptions,
        frames: Option<usize>,
    ) -> Result<(), String> {
        let samples = self.samples(opts);
        let flags = format!(
            "--width {} --spp {} --breakdown-stride {}",
            opts.width, opts.spp, opts.breakdown_stride
        );
        if samples > MAX_RENDER_SAMPLES {
            return Err(format!(
                "render {}: {flags}: {samples} Monte Carlo samples over the image and the error breakdown, more \
                 than the {MAX_RENDER_SAMPLES} a render may take (MAX_RENDER_SAMPLES); lower --width or --spp, or \
                 raise --breakdown-stride",
                self.name
            ));
        }
        let work = samples.saturating_mul(lights).saturating_mul(blockers);
        if work > MAX_WORK {
            return Err(format!(
                "render {}: scene {scene}: {flags}: {samples} samples × {lights} light terms × {blockers} blockers = \
                 {:.3e} work units, more than the {MAX_WORK:.0e} a render may take (MAX_WORK); lower --width or \
                 --spp, raise --breakdown-stride, or use fewer SGs, lights or spheres",
                self.name, work as f64
            ));
        }
        let Some(frames) = frames else {
            return Ok(());
        };
        let (w, h) = (opts.width.max(4) as u64, (opts.width * 3 / 4).max(3) as u64);
        let work = (w * h)
            .saturating_mul(frames as u64)
            .saturating_mul(lights)
            .saturating_mul(blockers);
        if work > MAX_SHADE_WORK {
            return Err(format!(
                "render {}: scene {scene}: --width {}{}: {w}×{h} pixels × {frames} frame{} × {lights} light terms × \
                 {blockers} blockers = {:.3e} shading work units, more than the {MAX_SHADE_WORK:.0e} a render may \
                 take (MAX_SHADE_WORK); lower --width or --frames, or use fewer SGs, lights or spheres",
                self.name,
                opts.width,
                if frames > 1 {
                    format!(" --frames {frames}")
                } else {
                    String::new()
                },
                if frames == 1 { "" } else { "s" },
                work as f64
            ));
        }
        Ok(())
    }

    /// [`Pipeline::check_work`], and the method's own work over `frames` frames: an error
    /// naming the limit when pixels × frames × light terms × blockers (an upper bound on
    /// the light–blocker products the analytic shading forms) passes [`MAX_SHADE_WORK`].
    /// Called before a render or an animation spends any time.
    pub fn check_frames(&self, scene: &scene::Scene, opts: &RenderOptions, frames: usize) -> Result<(), String> {
        let (lights, blockers) = terms(scene);
        self.limits(&scene.name, lights, blockers, opts, Some(frames))
    }

    /// The limits of [`Pipeline::check_frames`] for the scene `name` (a built-in of
    /// this pipeline or a scene file) read without building it: the command line's
    /// check before any render starts (its refusal is a usage error). `None` where the
    /// scene is within them, or cannot be read here (the render reports that).
    pub fn work_error(&self, name: &str, opts: &RenderOptions, frames: usize) -> Option<String> {
        let t = match self.file(name) {
            Some(text) => scene::SceneText::builtin(&format!("{}-{name}", self.name), text),
            None => scene_text(name).ok()?,
        };
        let (lights, blockers) = scene::terms_of(&t).map(|(l, b)| (l.max(1), b.max(1)))?;
        let shown = if t.dir.is_none() {
            t.name.clone()
        } else {
            name.to_string()
        };
        self.limits(&shown, lights, blockers, opts, Some(frames)).err()
    }

    /// The text of its built-in scene file `name` (without the pipeline's prefix).
    pub fn file(&self, name: &str) -> Option<&'static str> {
        self.files.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
    }
}

/// A scene's text by name: a built-in `<pipeline>-<scene>` of any pipeline in the
/// [`registry`], else the scene file at that path.
pub fn scene_text(name_or_path: &str) -> Result<scene::SceneText, String> {
    for p in registry() {
        let Some(rest) = name_or_path.strip_prefix(p.name).and_then(|r| r.strip_prefix('-')) else {
            continue;
        };
        if let Some(text) = p.file(rest) {
            return Ok(scene::SceneText::builtin(name_or_path, text));
        }
    }
    scene::SceneText::file(name_or_path)
}

/// The scene `name` as the first pipeline of the [`registry`] that shades it loads it
/// ([`MonteCarlo::load`]); the error lists each pipeline's refusal.
pub fn load_for_any(name: &str) -> Result<scene::Scene, String> {
    let mut refusals = Vec::new();
    for p in registry() {
        match p.monte_carlo().map(|m| (m.load)(name)) {
            Some(Ok(s)) => return Ok(s),
            Some(Err(e)) => refusals.push(format!("{}: {e}", p.name)),
            None => {}
        }
    }
    Err(refusals.join("; "))
}

/// The scene `name_or_path` ([`scene_text`]), every kind accepted.
pub fn load_scene(name_or_path: &str) -> Result<scene::Scene, String> {
    scene::load_text_for(&scene_text(name_or_path)?, &scene::Accepts::ALL)
}

/// (light terms, blockers) of a scene, each at least 1: the SGs and sphere lights (an
/// SH environment counts 1), and the spheres, the meshes' sphere sets and the height
/// field: what a pixel's shading and a sample's visibility scale with.
fn terms(scene: &scene::Scene) -> (u64, u64) {
    let lights = scene.environment.len() + scene.lights.len() + usize::from(scene.sh_environment.is_some());
    let blockers = scene.proxies.len().max(scene.spheres.len()) + usize::from(scene.heightfield.is_some());
    (lights.max(1) as u64, blockers.max(1) as u64)
}

/// Most shading work one render of one scene may take: pixels × frames × light terms
/// × blockers ([`Pipeline::check_frames`]), an upper bound on the products the analytic
/// pipelines form (their culling makes the real count smaller). A default `render isg
/// --scene fig12` (160 × 120, 9 SGs, 50 spheres) is 8.6e6 of them, the falling spheres
/// at `--frames 24 --width 640` 3.3e9; `render isg --scene all --frames 240 --width
/// 2048` (3.4e11 on the falling spheres: about a day of one core) is refused.
pub const MAX_SHADE_WORK: u64 = 20_000_000_000;

/// Most Monte Carlo samples one render of one scene may take over all its references
/// (the image's, the SH-ideal render's, the error breakdown's precise ones): 16 ×
/// [`MAX_SAMPLES`], 12 times a default `render shexp` (3.5e8) and 44 times a default
/// `render isg` (9.8e7).
pub const MAX_RENDER_SAMPLES: u64 = 16 * MAX_SAMPLES;

/// Most work one render of one scene may take: samples × light terms × blockers (a
/// bound on the visibility tests a reference scanning every blocker makes). A default
/// `render shexp --scene wrecking` is 5.7e11, `render isg --scene sweep`'s largest
/// scene 2.7e11.
pub const MAX_WORK: u64 = 10_000_000_000_000;

/// A pipeline's query for `lobefit eval NAME [flags]` (the pipeline without images).
pub type EvalFn = fn(&EvalFlags) -> Result<Box<dyn View>, lobefit_core::family::EvalError>;

/// A pipeline's `lobefit eval` query.
#[derive(Debug, Clone, Copy)]
pub struct EvalView {
    /// Its `eval` name (`isg-shade`).
    pub name: &'static str,
    /// Its paragraph of `eval --help`.
    pub help: &'static str,
    /// The flags it takes; the command line refuses every other before [`Self::view`].
    pub flags: &'static [EvalFlag],
    /// The view its flags configure.
    pub view: EvalFn,
}

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

/// The studies' switches (ignored tests run by scripts/studies.sh): the environment
/// variable `var` parsed, `default` when unset or unparsable.
#[cfg(test)]
pub(crate) fn env_or<T: std::str::FromStr>(var: &str, default: T) -> T {
    std::env::var(var).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary line's layout and arithmetic: 2843 / 196.62 = 14.46 → "14.5× less
    /// time"; the inverse when the method is the slower (19.747 / 7.253 = 2.72); the
    /// figures' rounding.
    #[test]
    fn headline_line() {
        let mut h = Headline {
            render: "isg fig12".into(),
            scope: "32×24".into(),
            method: "ISG (best model)".into(),
            error: "relative RMSE 0.0158 against the reference".into(),
            cost_us: 196.62,
            unit: "px".into(),
            baseline: "plain Monte Carlo at that error".into(),
            baseline_us: 2843.0,
            spread: None,
            bound: Bound::Measured,
        };
        assert_eq!(
            h.line(),
            "summary: isg fig12 32×24 — ISG (best model): relative RMSE 0.0158 against the reference; \
             197 µs/px vs plain Monte Carlo at that error 2843 µs/px (14.5× less time)"
        );
        (h.cost_us, h.baseline_us) = (19.747, 7.253);
        assert!(
            h.line()
                .ends_with("; 19.7 µs/px vs plain Monte Carlo at that error 7.25 µs/px (2.72× more time)"),
            "{}",
            h.line()
        );
        // A measured spread, in either direction, and a lower bound.
        h.spread = Some((0.25, 0.5));
        assert!(h.line().ends_with("(2.72× more time [2.00–4.00])"), "{}", h.line());
        (h.cost_us, h.baseline_us, h.spread) = (39.4, 547.0, Some((11.2, 19.8)));
        assert!(h.line().ends_with("(13.9× less time [11.2–19.8])"), "{}", h.line());
        (h.spread, h.bound) = (None, Bound::AtLeast);
        assert!(h.line().ends_with("(> 13.9× less time)"), "{}", h.line());
        h.bound = Bound::AtMost;
        assert!(h.line().ends_with("(< 13.9× less time)"), "{}", h.line());
        // A bound on a ratio below 1 turns in "more time": at most 0.5× the time is at
        // least 2× more.
        h.baseline_us = 19.7;
        assert!(h.line().ends_with("(> 2.00× more time)"), "{}", h.line());
        h.bound = Bound::AtLeast;
        assert!(h.line().ends_with("(< 2.00× more time)"), "{}", h.line());
        h.baseline_us = f64::NAN;
        assert!(h.line().ends_with("(no ratio)"), "{}", h.line());
        assert_eq!(short_number(0.012345), "0.0123");
        assert_eq!(short_number(0.5), "0.500");
        assert_eq!(short_number(123456.7), "123457");
        assert_eq!(short_number(0.0), "0");
    }

    fn opts(width: usize, spp: usize, breakdown_stride: usize) -> RenderOptions {
        RenderOptions {
            width,
            spp,
            breakdown_stride,
        }
    }

    /// Every built-in scene (and the ISG sweep's largest) renders at the defaults within
    /// the work limits; the breakdown's references count (at stride 1 they took 46 ×
    /// [`MAX_SAMPLES`]), and so do SGs × spheres.
    #[test]
    fn render_work_is_bounded_above_every_builtin() {
        let defaults = opts(160, 1024, 4);
        for p in registry() {
            for name in p.scenes {
                let scene = match (p.name, *name) {
                    ("rigs", _) => continue,
                    ("isg", "sweep") => isg::render::sweep_scene(*isg::render::SWEEP.last().unwrap()).unwrap(),
                    _ => p.scene(name).unwrap(),
                };
                p.check_work(&scene, &defaults).unwrap();
            }
        }
        let isg = isg::PIPELINE;
        assert_eq!(
            isg.samples(&defaults),
            160 * 120 * 1024 + 40 * 30 * 1024 * 64 + measure::HEADLINE_SAMPLES
        );
        let fig12 = isg.scene("fig12").unwrap();
        let e = isg.check_work(&fig12, &opts(1024, 256, 1)).unwrap_err();
        assert!(e.contains("MAX_RENDER_SAMPLES"), "{e}");
        // The largest scene the file allows, at a modest render.
        let mut v: serde_json::Value = serde_json::from_str(isg::PIPELINE.file("fig12").unwrap()).unwrap();
        let g = v["environment"]["sgs"][0].clone();
        let s = v["spheres"][0].clone();
        v["environment"]["sgs"] = (0..scene::MAX_SGS).map(|_| g.clone()).collect();
        v["spheres"] = (0..1000).map(|_| s.clone()).collect();
        let big = scene::parse("big", &v.to_string()).unwrap();
        let e = isg.check_work(&big, &opts(160, 1024, 4)).unwrap_err();
        assert!(
            e.contains("MAX_WORK") && e.contains("256 light terms × 1000 blockers"),
            "{e}"
        );
        isg.check_work(&big, &opts(16, 16, 4)).unwrap();
    }

    /// Every pipeline's built-in files parse, light something and hold spheres; each
    /// is found by its full name; a name of no built-in reads a file.
    #[test]
    fn builtin_scenes_parse() {
        let mut count = 0;
        for p in registry() {
            for (name, _) in p.files {
                let s = p.scene(name).unwrap();
                let lit = !s.lights.is_empty() || !s.environment.is_empty();
                assert!(lit && !s.spheres.is_empty(), "{} {name}", p.name);
                let full = format!("{}-{name}", p.name);
                assert_eq!(load_scene(&full).unwrap().name, full);
                count += 1;
            }
        }
        assert_eq!(count, 10);
        let e = scene_text("isg-nothing").unwrap_err();
        assert!(e.contains("scene isg-nothing"), "{e}");
    }

    /// A scene by name through the pipelines that load scenes: each built-in reaches its
    /// own pipeline's checks; a name no pipeline shades lists each one's refusal.
    #[test]
    fn a_scene_loads_through_the_pipeline_that_shades_it() {
        for (name, full) in [
            ("fig12", "isg-fig12"),
            ("whale", "shexp-whale"),
            ("glossy", "meunier-glossy"),
        ] {
            assert_eq!(load_for_any(name).unwrap().name, full);
        }
        let e = load_for_any("no-such-scene").unwrap_err();
        assert!(
            ["meunier: ", "isg: ", "shexp: "].iter().all(|p| e.contains(p)) && !e.contains("rigs: "),
            "{e}"
        );
    }

    /// The method's own work is bounded too, over the frames: the built-in animations
    /// at 24 frames and 640 px pass (3.3e9 work units for the falling spheres, 9 SGs
    /// × 50 spheres), the 240-frame, 2048-px render of them is refused by name (3.4e11),
    /// and so is a still of the largest scene the file allows at 2048 px.
    #[test]
    fn shading_work_is_bounded_over_the_frames() {
        let isg = isg::PIPELINE;
        let falling = isg.scene("falling").unwrap();
        isg.check_frames(&falling, &opts(640, 2, 4), 24).unwrap();
        let e = isg.check_frames(&falling, &opts(2048, 2, 64), 240).unwrap_err();
        assert!(
            e.contains("MAX_SHADE_WORK") && e.contains("2048×1536 pixels × 240 frames × 9 light terms × 50 blockers"),
            "{e}"
        );
        for p in registry() {
            for name in p.animations {
                let scene = p.scene(name).unwrap();
                p.check_frames(&scene, &opts(640, 2, 4), 24).unwrap();
            }
        }
        let mut v: serde_json::Value = serde_json::from_str(isg::PIPELINE.file("fig12").unwrap()).unwrap();
        let g = v["environment"]["sgs"][0].clone();
        v["environment"]["sgs"] = (0..scene::MAX_SGS).map(|_| g.clone()).collect();
        let big = scene::parse("big", &v.to_string()).unwrap();
        let e = isg.check_frames(&big, &opts(2048, 2, 64), 1).unwrap_err();
        assert!(e.contains("MAX_SHADE_WORK"), "{e}");
    }
}
