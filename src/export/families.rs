//! Which families export how: the textured ones (each family's GPU glue lives in its
//! folder, `fits/<family>/gpu.rs`: its textures and the f32 formulas a shader applies
//! to the samples), the ones a shader evaluates in closed form (no texture), and those
//! whose GPU layout is not built yet.

use lobefit_tables::{LookupError, Table};

use super::layout::{grid_of_table, Grid, Sampler};
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
}

/// The default textures: the table's grid as one texture.
pub fn table_grid(kind: &str, table: &Table, storage: Storage, scale: f64) -> Result<Vec<Grid>, String> {
    Ok(vec![grid_of_table(kind, table, storage, scale)?])
}

/// The families exported as textures.
pub fn textured() -> Vec<GpuFamily> {
    use crate::fits;
    vec![
        fits::cap_exponent::gpu::GPU,
        fits::sg_fit::gpu::GPU,
        fits::isg::gpu::REFIT,
        fits::isg::gpu::BEST,
        fits::disk_light::gpu::GPU,
        fits::lobe_product::gpu::ENERGY,
        fits::lobe_product::gpu::L2,
        fits::wedge::gpu::GPU,
        fits::shexp::gpu::GPU,
    ]
}

/// Families a shader evaluates in closed form, with no texture: (kind, formula).
pub const CLOSED_FORM: [(&str, &str); 3] = [
    ("lobe-integral", "∫ max(a·v, 0)^e dω = 2π / (e + 1)"),
    (
        "wrap",
        "λ̂_l(a) closed form (lobefit_tables::wrap::lambda_hat): polynomials in a per band, no texture",
    ),
    (
        "log-zh",
        "diffuse, Phong and blocker log-ZH vectors in closed form (lobefit_tables::log_zh::{diffuse, phong, blocker})",
    ),
];

/// The family by kind.
pub fn find(kind: &str) -> Option<GpuFamily> {
    textured().into_iter().find(|f| f.kind == kind)
}

/// A family's runtime lookup as a GPU computes it from exported textures: the checker
/// runs the family's own comparison (`Query::check_point`) through it.
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
