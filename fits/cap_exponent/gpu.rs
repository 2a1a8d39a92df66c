//! cap-exponent on the GPU: the table's q on logit(α) as a 1D texture; the shader
//! multiplies by the scale model m(α).

use std::f32::consts::FRAC_PI_2;

use lobefit_core::export::families::{table_grid, Baked, GpuFamily, Kernels};
use lobefit_core::export::layout::Sampler;

/// The export of cap-exponent.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::cap_exponent::KIND,
    grids: table_grid,
    eval,
    shader: "e_cap = 0 for α ≥ π/2, else q · m(α), q = the texel at α; m(α) = c (1 − ln c) / (2 sin²(α/2)), \
             c = max(cos α, 1e-30)",
    extra: None,
    kernels: Kernels::One {
        textures: &[0],
        body: "    Y[o] = lf_cap_exponent(T, S, P, x0);",
        n_out: 1,
    },
    exact_fetch: false,
    checks: &[],
    timed: None,
    plot_export: true,
    baked: &[Baked {
        wrapper: "lf_cap_exponent_baked",
        function: "lf_cap_exponent",
        textures: &["cap-exponent"],
        fixed: &[],
    }],
};

fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let alpha = x[0];
    // A cap of half-angle ≥ π/2 is no lobe: exponent 0, as the runtime answers.
    if alpha >= FRAC_PI_2 {
        return vec![0.0];
    }
    vec![model(alpha) * s[0].sample(&[alpha])[0]]
}

/// The scale model in f32, in the stable form (2 sin²(α/2) for 1 − cos α; cos α floored
/// so that α rounded up to f32 π/2 stays finite).
fn model(alpha: f32) -> f32 {
    let s = (0.5 * alpha).sin();
    let c = alpha.cos().max(1e-30);
    c * (1.0 - c.ln()) / (2.0 * s * s)
}
