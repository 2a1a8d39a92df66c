//! sg-fit on the GPU: ln λ, ln μ on log(1 + e) as a 1D RG texture.

use lobefit_core::export::families::{table_grid, Baked, GpuFamily, Kernels};
use lobefit_core::export::layout::Sampler;

/// The export of sg-fit.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::sg_fit::KIND,
    grids: table_grid,
    eval,
    shader: "λ = exp(R), μ = exp(G) at e (log channels); a lobe of scale s maps to amplitude s μ",
    extra: None,
    kernels: Kernels::One {
        textures: &[0],
        body: "    let v = lf_sg_fit(T, S, P, x0);\n    Y[o] = v.x;\n    Y[o + 1u] = v.y;",
        n_out: 2,
    },
    exact_fetch: false,
    checks: &[],
    timed: None,
    plot_export: true,
    baked: &[
        Baked {
            wrapper: "lf_sg_fit_baked",
            function: "lf_sg_fit",
            textures: &["sg-fit"],
            fixed: &[],
        },
        Baked {
            wrapper: "lf_lobe_to_sg_baked",
            function: "lf_lobe_to_sg",
            textures: &["sg-fit"],
            fixed: &[],
        },
    ],
};

fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    s[0].sample(&[x[0]])
}
