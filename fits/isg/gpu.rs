//! The ISG models on the GPU. isg-refit: ln g, ln h on log γ as a 1D RG texture and the
//! logistic product in the shader.

use std::f32::consts::{FRAC_PI_2, PI};

use crate::export::families::{table_grid, GpuFamily};
use crate::export::layout::Sampler;

/// The export of isg-refit.
pub const REFIT: GpuFamily = GpuFamily {
    kind: "isg-refit",
    grids: table_grid,
    eval: refit,
    shader: "g = exp(R), h = exp(G) at γ; Ŝ = σ(g (θ − π/2)) σ(h (φ − π/2)), σ(t) = 1/(1 + exp(−t)); \
             S = Ŝ · 2π (1 − exp(−γ)) / γ",
};

fn refit(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let (gamma, theta, phi) = (x[0], x[1], x[2]);
    let c = s[0].sample(&[gamma]);
    let s_hat = sigmoid(c[0] * (theta - FRAC_PI_2)) * sigmoid(c[1] * (phi - FRAC_PI_2));
    vec![s_hat, s_hat * 2.0 * PI * -(-gamma).exp_m1() / gamma]
}

fn sigmoid(t: f32) -> f32 {
    1.0 / (1.0 + (-t).exp())
}
