//! The ISG models on the GPU. isg-refit: ln g, ln h on log γ as a 1D RG texture and the
//! logistic product in the shader. isg-best: the table's (γ, u) grid as a 2D RGBA
//! texture (a, b, c, d), sampled twice (at θ's and at φ's warped coordinate), with the
//! warp and the mirror about π/2 in the shader.

use std::f32::consts::{FRAC_PI_2, PI};

use lobefit_core::export::families::{table_grid, Baked, GpuFamily, Kernels};
use lobefit_core::export::gpu_check::{r32, Context, Kernel, Row, Runner};
use lobefit_core::export::layout::Sampler;
use lobefit_core::rng::Rng;

/// The export of isg-refit.
pub const REFIT: GpuFamily = GpuFamily {
    kind: lobefit_tables::isg::KIND_REFIT,
    grids: table_grid,
    eval: refit,
    shader: "g = exp(R), h = exp(G) at γ; Ŝ = σ(g (θ − π/2)) σ(h (φ − π/2)), σ(t) = 1/(1 + exp(−t)); \
             S = Ŝ · 2π (1 − exp(−γ)) / γ",
    extra: None,
    kernels: Kernels::One {
        textures: &[0],
        body:
            "    let s = lf_isg_refit(T, S, P, x1, x2, x0);\n    Y[o] = s;\n    Y[o + 1u] = s * lf_isg_normaliser(x0);",
        n_out: 2,
    },
    exact_fetch: false,
    checks: &[|ctx, runner| patch(ctx, runner, 1, refit).map(|r| vec![r])],
    timed: None,
    plot_export: true,
    baked: &[Baked {
        wrapper: "lf_isg_refit_baked",
        function: "lf_isg_refit",
        textures: &["isg-refit"],
        fixed: &[],
    }],
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

/// The export of isg-best.
pub const BEST: GpuFamily = GpuFamily {
    kind: lobefit_tables::isg::KIND_BEST,
    grids: table_grid,
    eval: best,
    shader: "E(y) = 1 − exp(−y), as y (1 − y/2 (1 − y/3 (1 − y/4 (1 − y/5)))) for y < 1/16 \
             (1 − exp(−y) cancels there); per angle x ∈ {θ, φ}: d = x − π/2, h = sin(d/2), \
             q = 2h² (= 1 − sin x, without the cancellation near the axis), \
             u = min(sqrt(E(γq) / E(γ)), 1); at (γ, u_θ): A = .r, C = .b of the texel; at (γ, u_φ): \
             B = .g, D = .a; mirror where x > π/2 (d > 0): A → 1 − A, C → −C (B, D likewise \
             for φ); Ŝ = A·B + C·D; S = Ŝ · 2π E(γ) / γ",
    extra: None,
    kernels: Kernels::One {
        textures: &[0],
        body:
            "    let s = lf_isg_best(T, S, P, x1, x2, x0);\n    Y[o] = s;\n    Y[o + 1u] = s * lf_isg_normaliser(x0);",
        n_out: 2,
    },
    exact_fetch: false,
    checks: &[|ctx, runner| patch(ctx, runner, 2, best).map(|r| vec![r])],
    timed: None,
    plot_export: true,
    baked: &[Baked {
        wrapper: "lf_isg_best_baked",
        function: "lf_isg_best",
        textures: &["isg-best"],
        fixed: &[],
    }],
};

/// Texture rows are (a, b, c, d): θ's factors (A, C) are channels 0 and 2, φ's (B, D)
/// channels 1 and 3.
fn best(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let (gamma, theta, phi) = (x[0], x[1], x[2]);
    let e_gamma = one_minus_exp_neg(gamma);
    let (a, c) = best_factor(&s[0], 0, theta, gamma, e_gamma);
    let (b, d) = best_factor(&s[0], 1, phi, gamma, e_gamma);
    let s_hat = a * b + c * d;
    vec![s_hat, s_hat * 2.0 * PI * e_gamma / gamma]
}

/// (marginal, correction) of axis `k` at the angle x ∈ [0, π], as the runtime's
/// `BestIsg` forms them. q is even about π/2, so it is taken from d = x − π/2 directly
/// (exact in f32 for x ≥ π/4) rather than from the mirrored angle π − x: f32 π and π/2
/// would add their two rounding errors. The mirror then only flips the factors.
fn best_factor(s: &Sampler, k: usize, x: f32, gamma: f32, e_gamma: f32) -> (f32, f32) {
    let d = x - FRAC_PI_2;
    let h = (0.5 * d).sin();
    let q = 2.0 * h * h;
    let u = (one_minus_exp_neg(gamma * q) / e_gamma).sqrt().min(1.0);
    let t = s.sample(&[gamma, u]);
    let (m, c) = (t[k], t[k + 2]);
    if d > 0.0 {
        (1.0 - m, -c)
    } else {
        (m, c)
    }
}

/// 1 − e^{−y} for y ≥ 0 in f32 with only `exp`: near the SG axis γq is tiny and
/// 1 − exp(−y) loses its digits (exp(−y) rounds to 1 for y below 3e-8: u snaps to 0
/// from up to 3e-4, where the marginals are steepest), so small y takes the Taylor
/// series (truncated, y⁵/720 < 2e-9 relative for y < 1/16; beyond, the cancellation
/// costs about 2⁻²⁴/y ≤ 1e-6 relative).
fn one_minus_exp_neg(y: f32) -> f32 {
    if y < 0.0625 {
        y * (1.0 - 0.5 * y * (1.0 - y / 3.0 * (1.0 - 0.25 * y * (1.0 - 0.2 * y))))
    } else {
        1.0 - (-y).exp()
    }
}

/// The ISG patch integral of a textured model (`lf_isg_patch`, `model` 1 refit or 2
/// best, `eval` its CPU emulation) at random patches: GPU against the same four
/// corners through the CPU emulation, and against the family's reference Ŝ at the
/// corners (limit: 4 × the family's Ŝ limit, in units of the normaliser
/// 2π(1 − e^{−γ})/γ).
fn patch(
    ctx: &Context,
    runner: &dyn Runner,
    model: u32,
    eval: fn(&[Sampler], &[f32]) -> Vec<f32>,
) -> Result<Row, String> {
    let samples = lobefit_core::export::gpu_check::WORLD_SAMPLES;
    let mut rng = Rng::new(ctx.seed ^ 0x9a7c);
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            let g = rng.range(0.5f64.ln(), 1e4f64.ln()).exp();
            let pi = std::f64::consts::PI;
            let (a, b) = (rng.range(0.0, pi), rng.range(0.0, pi));
            let (c, d) = (rng.range(0.0, pi), rng.range(0.0, pi));
            vec![g, a.min(b), a.max(b), c.min(d), c.max(d)]
                .into_iter()
                .map(r32)
                .collect()
        })
        .collect();
    let body = format!("    Y[o] = lf_isg_patch(T, S, P, {model}u, x1, x2, x3, x4, x0) / lf_isg_normaliser(x0);");
    let kind = ctx.family.kind();
    let got = runner.run(&Kernel::new(&format!("{kind} patch"), &[0], &body, 1), &inputs)?;
    let corners = |x: &[f64], f: &dyn Fn(f64, f64, f64) -> Result<f64, String>| -> Result<f64, String> {
        Ok(f(x[0], x[2], x[4])? - f(x[0], x[1], x[4])? - f(x[0], x[2], x[3])? + f(x[0], x[1], x[3])?)
    };
    // Per patch, the span of its four lookups' emulations (each over the hardware
    // filter's weight roundings, on a device independent per lookup): the signed
    // sum's least and greatest values.
    let span = |x: &[f64]| {
        let terms = [
            (x[2], x[4], 1.0),
            (x[1], x[4], -1.0),
            (x[2], x[3], -1.0),
            (x[1], x[3], 1.0),
        ];
        terms.iter().fold((0.0f64, 0.0f64), |(lo, hi), &(t, p, sign)| {
            let e = ctx.envelope(eval, &[x[0] as f32, t as f32, p as f32]);
            let (a, b) = (f64::from(e.lo[0]), f64::from(e.hi[0]));
            if sign > 0.0 {
                (lo + a, hi + b)
            } else {
                (lo - b, hi - a)
            }
        })
    };
    let vs_emu = got
        .iter()
        .zip(&inputs)
        .map(|(g, x)| {
            let (lo, hi) = span(x);
            (lo - g[0]).max(g[0] - hi).max(0.0)
        })
        .fold(0.0, f64::max);
    let refs: Vec<f64> = inputs
        .iter()
        .map(|x| corners(x, &|g, t, p| Ok(ctx.family.reference(&[g, t, p])?[0])))
        .collect::<Result<_, _>>()?;
    let max_abs = |want: &[f64]| got.iter().zip(want).map(|(g, w)| (g[0] - w).abs()).fold(0.0, f64::max);
    let limit = 4.0 * ctx.offgrid_limit("s_hat").unwrap_or(0.0);
    // Absolute, in units of the normaliser: the values lie in [−1, 1].
    Ok(Row {
        function: format!("{kind} patch"),
        storage: ctx.storage.to_string(),
        filter: ctx.filter.name().into(),
        samples,
        vs_cpu: vs_emu,
        cpu_what: "emulation (abs)",
        vs_ref: vec![("patch / normaliser max_abs".into(), max_abs(&refs), limit)],
        info: Vec::new(),
    })
}
