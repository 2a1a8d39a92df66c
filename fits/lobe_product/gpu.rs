//! The lobe products on the GPU. The table's 3D grid (e1, e2, α) as a 3D texture, and
//! the closed-form model the table's channels correct, evaluated in the shader; its one
//! term shaders cannot compute, ln W(E) (two ln Γ), comes from a 1D texture of its
//! residual from the asymptotic form ½ ln(2π/(E + 3/2)).

use std::f32::consts::{PI, TAU};

use lobefit_tables::format::{Axis, Mapping, Placement};
use lobefit_tables::lobe_product::{ln_w, E_MAX};
use lobefit_tables::Table;

use lobefit_core::export::families::{Baked, GpuFamily, Kernels};
use lobefit_core::export::layout::{grid_of_table, grid_of_values, ChannelSpec, Grid, Sampler};
use lobefit_core::export::Storage;

/// Largest E = e1 + e2 the ln W texture covers (both exponents at the table's limit).
const E_SUM_MAX: f64 = 2.0 * E_MAX;
/// Nodes of the ln W residual texture (uniform in ln(1 + E)).
const LNW_NODES: u32 = 512;

const SHADER: &str = "channels (c, ρ[, κ]) at (min(e1, 1e5), min(e2, 1e5), α) from the 3D texture \
     (f16: each sampled v → sign(v) · 0.5 · (exp(|v|) − 1)); E = e1 + e2; \
     ln W = r(E) + ½ ln(2π / (E + 1.5)) with r from the 1D texture; s = sin α, h = 2 sin(α/2); \
     G = E + e1 e2 / E · h²; β = ½(α + asin((e2 − e1)/(E + 2) · s)); \
     ln M = ln W − 2 e1 atanh(tan²(β/2)) − 2 e2 atanh(tan²((α − β)/2)) − ½ ln(G / 2π + 1/(π − α)²) \
     (−∞ where β or α − β ≥ π/2); ∫ = exp(ln M + c); e_m = √(E G); e_r = max((1 + e_m) exp(ρ) − 1, 0); \
     p = exp(κ) ∫ (e_r + 1) / 2π (κ = 0 for the energy variant); t = (α + asin((e2 − e1)/E · s)) / 2α \
     (e2/E at α = 0)";

/// The export of lobe-product (energy-conserving).
pub const ENERGY: GpuFamily = GpuFamily {
    kind: lobefit_tables::lobe_product::KIND_ENERGY,
    grids,
    eval,
    shader: SHADER,
    extra: None,
    kernels: Kernels::One {
        textures: &[0, 1],
        body: "    let r = lf_lobe_product(T, S, P, T2, P2, x0, x1, x2);\n    Y[o] = r.p;\n    Y[o + 1u] = r.t;\n    Y[o + 2u] = r.e_r;",
        n_out: 3,
    },
    exact_fetch: false,
    checks: &[],
    timed: None,
    plot_export: false,
    baked: &[
        Baked { wrapper: "lf_lobe_product_baked", function: "lf_lobe_product", textures: &["lobe-product", "lobe-product-lnw"], fixed: &[] },
    ],
};

/// The export of lobe-product-l2.
pub const L2: GpuFamily = GpuFamily {
    kind: lobefit_tables::lobe_product::KIND_L2,
    grids,
    eval,
    shader: SHADER,
    extra: None,
    kernels: Kernels::One {
        textures: &[0, 1],
        body: "    let r = lf_lobe_product_l2(T, S, P, T2, P2, x0, x1, x2);\n    Y[o] = r.p;\n    Y[o + 1u] = r.t;\n    Y[o + 2u] = r.e_r;",
        n_out: 3,
    },
    exact_fetch: false,
    checks: &[],
    timed: None,
    plot_export: false,
    baked: &[
        Baked { wrapper: "lf_lobe_product_l2_baked", function: "lf_lobe_product_l2", textures: &["lobe-product-l2", "lobe-product-l2-lnw"], fixed: &[] },
    ],
};

/// The table's grid, and the ln W residual texture `<kind>-lnw`.
fn grids(kind: &str, table: &Table, storage: Storage, scale: f64) -> Result<Vec<Grid>, String> {
    let main = match storage {
        Storage::F32 => grid_of_table(kind, table, storage, scale)?,
        Storage::F16 => compressed(kind, table, scale)?,
    };
    let axis = Axis {
        name: "E".into(),
        unit: "1".into(),
        lo: 0.0,
        hi: E_SUM_MAX,
        mapping: Mapping::Log1p { scale: 1.0 },
        count: ((LNW_NODES - 1) as f64 * scale).round().max(1.0) as u32 + 1,
        placement: Placement::Endpoints,
    };
    let values: Vec<f64> = (0..axis.count)
        .map(|i| {
            let e = axis.node(i).clamp(0.0, E_SUM_MAX);
            ln_w(e) - 0.5 * (std::f64::consts::TAU / (e + 1.5)).ln()
        })
        .collect();
    let spec = ChannelSpec {
        name: "lnw_residual".into(),
        meaning: "ln W(E) − ½ ln(2π/(E + 3/2)), W(E) = √π Γ(E/2 + 1)/Γ(E/2 + 3/2)".into(),
        log: false,
    };
    let lnw = grid_of_values(&format!("{kind}-lnw"), &[axis], &[spec], &values, storage)?;
    Ok(vec![main, lnw])
}

/// Width w of the f16 compression (see [`compressed`]).
pub const WIDTH: f64 = 0.5;

/// The f16 main texture: every channel x stored as v = sign(x) ln(1 + |x|/w), w =
/// [`WIDTH`]; the shader inverts it after filtering, x = sign(v) w (exp(|v|) − 1).
/// c spans [−10.5, 0.07] (large only where the model fails: α near π, unequal
/// exponents) and the L2 variant's ρ [0, 6.9], κ [−2.5, 0.02]; packed linearly, f16
/// resolves c to 1.3e-3 everywhere, which raised sharp products' L2 residual by 43 %
/// (54 % for the L2 variant) over the optimum's. Compressed, values near 0 — where
/// those residuals are small — get w e^{|v|} times finer steps: measured 2.3e-2 and
/// 1.8e-2 (target 5e-2). w = 0.25 and 1 measured worse for one variant or the other.
fn compressed(kind: &str, table: &Table, scale: f64) -> Result<Grid, String> {
    let g = grid_of_table(kind, table, Storage::F32, scale)?;
    let axes: Vec<Axis> = g.axes.iter().map(|a| a.axis.clone()).collect();
    let per = g.texture.channels as usize;
    let texels = g.texture.data.len() / per / g.texture.layers as usize;
    let mut values = Vec::with_capacity(texels * g.channels.len());
    for i in 0..texels {
        for ch in &g.channels {
            let x = f64::from(g.texture.data[(ch.layer as usize * texels + i) * per + ch.component as usize]);
            values.push(x.signum() * (x.abs() / WIDTH).ln_1p());
        }
    }
    let specs: Vec<ChannelSpec> = g
        .channels
        .iter()
        .map(|ch| ChannelSpec {
            name: ch.name.clone(),
            meaning: format!(
                "v = sign(x) ln(1 + |x| / {WIDTH:?}) of x = {}; after filtering x = sign(v) · {WIDTH:?} · (exp(|v|) − 1)",
                ch.meaning
            ),
            log: ch.log,
        })
        .collect();
    let mut grid = grid_of_values(kind, &axes, &specs, &values, Storage::F16)?;
    for ch in &mut grid.channels {
        ch.compression = WIDTH;
    }
    Ok(grid)
}

/// ln max(cos x, 0)^e in a form exact for small x in f32: ln cos x = −2 atanh(tan²(x/2))
/// (1 − cos x would cancel); 0 for e = 0, −∞ beyond π/2.
fn lobe_ln(e: f32, x: f32) -> f32 {
    if e == 0.0 {
        0.0
    } else if x.abs() >= PI / 2.0 {
        f32::NEG_INFINITY
    } else {
        let t = (0.5 * x).tan();
        -2.0 * e * (t * t).atanh()
    }
}

/// The peak angle from a1 of the product of exponents (e1, e2) at separation α.
fn peak_angle(e1: f32, e2: f32, alpha: f32, s: f32) -> f32 {
    let sum = e1 + e2;
    let c = if sum > 0.0 { (e2 - e1) / sum } else { 0.0 };
    (0.5 * (alpha + (c * s).clamp(-1.0, 1.0).asin())).clamp(0.0, alpha)
}

fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let (e1, e2, alpha) = (x[0], x[1], x[2].min(PI));
    let emax = E_MAX as f32;
    // (The sampler inverts the f16 compression: `Channel::compression`.)
    let ch = s[0].sample(&[e1.min(emax), e2.min(emax), alpha]);
    let e = e1 + e2;
    let lnw = s[1].sample(&[e])[0] + 0.5 * (TAU / (e + 1.5)).ln();
    let (sin_a, chord) = (alpha.sin(), 2.0 * (0.5 * alpha).sin());
    let g = if e > 0.0 { e + e1 * e2 / e * chord * chord } else { 0.0 };
    let beta = peak_angle(e1 + 1.0, e2 + 1.0, alpha, sin_a);
    let lune = PI - alpha;
    let ln_model = lnw + lobe_ln(e1, beta) + lobe_ln(e2, alpha - beta) - 0.5 * (g / TAU + 1.0 / (lune * lune)).ln();
    let integral = (ln_model + ch[0]).exp();
    let e_m = (e * g).sqrt();
    let e_r = ((1.0 + e_m) * ch[1].exp() - 1.0).max(0.0);
    let k = if ch.len() > 2 { ch[2].exp() } else { 1.0 };
    let p = k * integral * (e_r + 1.0) / TAU;
    let t = if alpha > 0.0 {
        (peak_angle(e1, e2, alpha, sin_a) / alpha).clamp(0.0, 1.0)
    } else if e > 0.0 {
        e2 / e
    } else {
        0.5
    };
    vec![p, t, e_r]
}
