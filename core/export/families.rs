//! What a family's GPU export is made of ([`GpuFamily`]): each family's lives in its
//! folder, `fits/<family>/gpu.rs` (its textures, the f32 formulas a shader applies to
//! the samples, the conformance kernel's body), and is listed by the family's entry
//! (`lobefit_fits::textured`, `lobefit_fits::closed_form`). This module names no family.

use lobefit_tables::{LookupError, Table};

use super::gpu_check::{ClosedCheck, Kernel, TexturedCheck};
use super::layout::{grid_of_table, Grid, Sampler};
use super::manifest::TextureEntry;
use super::Storage;
use crate::family::Lookup;

/// Builds a family's textures: (kind, table, storage, scale) → grids.
pub type GridsFn = fn(&str, &Table, Storage, f64) -> Result<Vec<Grid>, String>;

/// One measured error of a texture the family's own `check` does not reach.
#[derive(Debug, Clone, PartialEq)]
pub struct ExtraError {
    /// Quantity.
    pub output: String,
    /// Metric, e.g. `offgrid.max_rel`.
    pub metric: String,
    /// Measured.
    pub measured: f64,
    /// The limit it is held to.
    pub target: f64,
}

/// Measures textures outside the family's `check_point` comparison: (samplers in
/// `grids` order, samples, seed) → errors against the family's independent reference.
pub type ExtraFn = fn(&[Sampler], usize, u64) -> Result<Vec<ExtraError>, String>;

/// The lookup's kernels, given the export's textures (see [`GpuFamily::kernels`]).
pub type KernelsFn = fn(&[TextureEntry]) -> Result<Vec<Kernel>, String>;

/// A kernel with the inputs it is timed at.
pub type Timed = (Kernel, Vec<Vec<f64>>);

/// What `lobefit-gpu cost` times (see [`GpuFamily::timed`]).
pub type TimedFn = fn(&[TextureEntry], &[Vec<f64>]) -> Result<Vec<Timed>, String>;

/// The lookup's conformance kernels (see [`GpuFamily::kernels`]).
#[derive(Debug, Clone, Copy)]
pub enum Kernels {
    /// One kernel named after the family: `body` over the `textures` (indices in
    /// `grids` order), `n_out` outputs per point.
    One {
        /// Textures bound (`T, S, P`; a second as `T2, P2`).
        textures: &'static [usize],
        /// WGSL body (see [`Kernel`]).
        body: &'static str,
        /// Outputs per point.
        n_out: usize,
    },
    /// The family's own, given the export's textures (shexp: one kernel per order).
    Own(KernelsFn),
}

/// A library function an export bakes for one family: the export's shader
/// (`lobefit_baked.wgsl` and its translations) gains `<wrapper>(…)` (manual
/// filtering) and `<wrapper>_hw(…)` (hardware filtering), the function's
/// arguments without its `LfTex` ones, which become the export's constants for the
/// named textures. A renderer binds the texture and calls the wrapper.
#[derive(Debug, Clone, Copy)]
pub struct Baked {
    /// The wrapper's name (manual filtering; `_hw` appended for hardware filtering).
    pub wrapper: &'static str,
    /// The library function it calls.
    pub function: &'static str,
    /// The texture (file stem) of each `LfTex` argument of `function`, in order.
    pub textures: &'static [&'static str],
    /// Arguments the texture fixes (name, WGSL literal), left out of the wrapper
    /// (shexp's order `n` for texture `shexp-n<n>`).
    pub fixed: &'static [(&'static str, &'static str)],
}

/// A family's GPU export.
#[derive(Debug, Clone, Copy)]
pub struct GpuFamily {
    /// Table kind (the texture files' stem).
    pub kind: &'static str,
    /// The textures, built from the family's table: packing for the storage, nodes per
    /// axis × the scale (see [`grid_of_table`]).
    pub grids: GridsFn,
    /// The runtime lookup's outputs at the inputs `x` (f32, as `lobefit eval` orders
    /// them), from samplers of the textures (in `grids` order): what the shader computes.
    pub eval: fn(&[Sampler], &[f32]) -> Vec<f32>,
    /// The shader's formulas in words, for the manifest and docs/gpu.md.
    pub shader: &'static str,
    /// Errors of textures the family's pointwise check does not cover (shexp's HYB
    /// a, b against ‖f̂‖), measured per filter beside the family's own metrics.
    pub extra: Option<ExtraFn>,
    /// The lookup's conformance kernels: outputs concatenated per point in the
    /// lookup's order (one kernel for most families; shexp runs one per order).
    pub kernels: Kernels,
    /// Entries are exact fetches (no filter to vary): checked once, reported as `fetch`.
    pub exact_fetch: bool,
    /// Checks beyond the lookup, run per filter on the device (world-space functions,
    /// second textures): `fits/<family>/gpu.rs`.
    pub checks: &'static [TexturedCheck],
    /// What `lobefit-gpu cost` times, as (kernel, inputs), given the textures and the
    /// family's sample points; `None`: the lookup's kernels at those points.
    pub timed: Option<TimedFn>,
    /// Whether `lobefit plot export` covers it (single-texture families whose bytes
    /// scale with `--scale` alone).
    pub plot_export: bool,
    /// The functions the export's baked shader wraps for this family.
    pub baked: &'static [Baked],
}

/// A table a shader evaluates in closed form, with no texture.
#[derive(Clone, Copy)]
pub struct ClosedForm {
    /// Table kind.
    pub kind: &'static str,
    /// The shader's formula in words, for the manifest.
    pub formula: &'static str,
    /// Its GPU conformance rows.
    pub checks: ClosedCheck,
    /// What `lobefit-gpu cost` times: (points, seed) → (kernel, inputs).
    pub timed: fn(usize, u64) -> Vec<Timed>,
}

impl GpuFamily {
    /// The lookup's kernels for an export whose textures are `textures`.
    pub fn kernels(&self, textures: &[TextureEntry]) -> Result<Vec<Kernel>, String> {
        match self.kernels {
            Kernels::One {
                textures: t,
                body,
                n_out,
            } => Ok(vec![Kernel::new(self.kind, t, body, n_out)]),
            Kernels::Own(f) => f(textures),
        }
    }
}

/// The default textures: the table's grid as one texture.
pub fn table_grid(kind: &str, table: &Table, storage: Storage, scale: f64) -> Result<Vec<Grid>, String> {
    Ok(vec![grid_of_table(kind, table, storage, scale)?])
}

/// A family's runtime lookup as a GPU computes it from exported textures: the checker
/// runs the family's own comparison (`Checked::check_point`) through it.
pub struct Emulated<'a> {
    /// The family's GPU glue.
    pub family: GpuFamily,
    /// The textures as read back, with their filter.
    pub samplers: &'a [Sampler],
}

impl Lookup for Emulated<'_> {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        Ok((self.family.eval)(self.samplers, &x32)
            .into_iter()
            .map(f64::from)
            .collect())
    }
}
