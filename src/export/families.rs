//! Which families export how: the textured ones (their table's grid sampled through
//! shader-cheap mappings, and the f32 formulas a shader applies to the samples), the
//! ones a shader evaluates in closed form (no texture), and those whose GPU layout
//! is not built yet.

use std::f32::consts::{FRAC_PI_2, PI};

use lobefit_tables::disk_light::{R_MAX, R_MIN};
use lobefit_tables::LookupError;

use super::layout::Sampler;
use crate::family::Lookup;

/// A family exported as one texture of its table's grid.
#[derive(Debug, Clone, Copy)]
pub struct GpuFamily {
    /// Table kind (file stem).
    pub kind: &'static str,
    /// The family's inputs (f32, as `lobefit eval` orders them) → the texture's axis
    /// values, slowest axis first.
    pub axis_values: fn(&[f32]) -> Vec<f32>,
    /// (sampled channel values, inputs) → the runtime lookup's outputs, in f32.
    pub decode: fn(&[f32], &[f32]) -> Vec<f32>,
    /// What the shader computes, for the manifest and docs/gpu.md.
    pub shader: &'static str,
}

/// The families exported as textures.
pub fn textured() -> Vec<GpuFamily> {
    vec![
        GpuFamily {
            kind: "cap-exponent",
            axis_values: |x| vec![x[0]],
            // A cap of half-angle ≥ π/2 is no lobe: exponent 0, as the runtime answers.
            decode: |c, x| vec![if x[0] >= FRAC_PI_2 { 0.0 } else { cap_model(x[0]) * c[0] }],
            shader: "e_cap = 0 for α ≥ π/2, else q · m(α), q = the texel; m(α) = c (1 − ln c) / (2 sin²(α/2)), \
                     c = max(cos α, 1e-30)",
        },
        GpuFamily {
            kind: "sg-fit",
            axis_values: |x| vec![x[0]],
            decode: |c, _| vec![c[0], c[1]],
            shader: "λ = exp(R), μ = exp(G) (log channels); a lobe of scale s maps to amplitude s μ",
        },
        GpuFamily {
            kind: "isg-refit",
            axis_values: |x| vec![x[0]],
            decode: |c, x| {
                let (gamma, theta, phi) = (x[0], x[1], x[2]);
                let s_hat = sigmoid(c[0] * (theta - FRAC_PI_2)) * sigmoid(c[1] * (phi - FRAC_PI_2));
                vec![s_hat, s_hat * 2.0 * PI * -(-gamma).exp_m1() / gamma]
            },
            shader: "g = exp(R), h = exp(G) at γ; Ŝ = σ(g (θ − π/2)) σ(h (φ − π/2)), σ(t) = 1/(1 + exp(−t)); \
                     S = Ŝ · 2π (1 − exp(−γ)) / γ",
        },
        GpuFamily {
            kind: "disk-light",
            axis_values: |x| vec![rim_coordinate(x[0], x[1]), x[1]],
            decode: |c, _| {
                let c00 = c[0];
                vec![c00, c00 * c[1], c00 * c[2], c00 * c[3], c00 * c[4], c00 * c[5]]
            },
            shader: "axes: v = (g(R/d) − g(0.01)) / (g(10) − g(0.01)), g(r) = ln r + asinh((r − sin τ) / cos τ), and τ; \
                     c00 = exp(layer 0 R); c_lm = c00 · (layer 0 G, B, A, layer 1 R, G) for (1,0), (1,1), (2,0), (2,1), (2,2)",
        },
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

/// Families whose GPU layout is not built yet, with what it needs.
pub const PENDING: [(&str, &str); 5] = [
    (
        "lobe-product",
        "3D (e1, e2, α); the closed-form model needs ln Γ, which shaders lack: tabulate it",
    ),
    ("lobe-product-l2", "as lobe-product"),
    (
        "isg-best",
        "its u axis is a γ-dependent warp, and x > π/2 mirrors: both to express in the shader",
    ),
    (
        "shexp",
        "the kink-aware stencil and HYB's a, b against ‖f̂‖ (built at load time) need their own layout",
    ),
    (
        "wedge",
        "an operator matrix per W, applied in the shader as a mat-vec; f32 hi + lo pairs to merge",
    ),
];

/// The family by kind.
pub fn find(kind: &str) -> Option<GpuFamily> {
    textured().into_iter().find(|f| f.kind == kind)
}

/// The cap-exponent scale model in f32, in the stable form (2 sin²(α/2) for 1 − cos α;
/// cos α floored so that α rounded up to f32 π/2 stays finite).
fn cap_model(alpha: f32) -> f32 {
    let s = (0.5 * alpha).sin();
    let c = alpha.cos().max(1e-30);
    c * (1.0 - c.ln()) / (2.0 * s * s)
}

fn sigmoid(t: f32) -> f32 {
    1.0 / (1.0 + (-t).exp())
}

/// The disk-light rim coordinate in f32 (see `lobefit_tables::disk_light`).
fn rim_coordinate(r: f32, tau: f32) -> f32 {
    let (s, c) = tau.sin_cos();
    let g = |r: f32| r.ln() + ((r - s) / c).asinh();
    let (lo, hi) = (g(R_MIN as f32), g(R_MAX as f32));
    ((g(r) - lo) / (hi - lo)).clamp(0.0, 1.0)
}

/// A family's runtime lookup as a GPU computes it from an exported texture: the
/// checker runs the family's own comparison (`Family::check_point`) through it.
pub struct Emulated<'a> {
    /// The family's GPU glue.
    pub family: GpuFamily,
    /// The texture as read back, and its filter.
    pub sampler: &'a Sampler,
}

impl Lookup for Emulated<'_> {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let ch = self.sampler.sample(&(self.family.axis_values)(&x32));
        Ok((self.family.decode)(&ch, &x32).into_iter().map(f64::from).collect())
    }
}
