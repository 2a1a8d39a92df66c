//! disk-light on the GPU: ln c00 and c_lm / c00 on (rim coordinate, logit τ) as a 2D
//! texture of two RGBA layers; the shader computes the rim coordinate.

use lobefit_tables::disk_light::{R_MAX, R_MIN};

use crate::export::families::{table_grid, GpuFamily};
use crate::export::layout::Sampler;

/// The export of disk-light.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::disk_light::KIND,
    grids: table_grid,
    eval,
    shader: "axes: v = (g(R/d) − g(0.01)) / (g(10) − g(0.01)), g(r) = ln r + asinh((r − sin τ) / cos τ), and τ; \
             c00 = exp(layer 0 R); c_lm = c00 · (layer 0 G, B, A, layer 1 R, G) for (1,0), (1,1), (2,0), (2,1), (2,2)",
    extra: None,
    kernel: (
        "    let c = lf_disk_canonical(T, S, P, x0, x1);\n    Y[o] = c[0].x;\n    Y[o + 1u] = c[0].y;\n    \
         Y[o + 2u] = c[0].z;\n    Y[o + 3u] = c[0].w;\n    Y[o + 4u] = c[1].x;\n    Y[o + 5u] = c[1].y;",
        6,
    ),
    plot_export: true,
};

fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let c = s[0].sample(&[rim_coordinate(x[0], x[1]), x[1]]);
    let c00 = c[0];
    vec![c00, c00 * c[1], c00 * c[2], c00 * c[3], c00 * c[4], c00 * c[5]]
}

/// The rim coordinate in f32 (see `lobefit_tables::disk_light`).
fn rim_coordinate(r: f32, tau: f32) -> f32 {
    let (s, c) = tau.sin_cos();
    let g = |r: f32| r.ln() + ((r - s) / c).asinh();
    let (lo, hi) = (g(R_MIN as f32), g(R_MAX as f32));
    ((g(r) - lo) / (hi - lo)).clamp(0.0, 1.0)
}
