//! shexp on the GPU: per order n = 3..8 a 1D texture over θ_b of f_0..f_{n−1} and ‖f̂‖
//! divided by 1 − cos θ_b, ln ‖f̂‖/(1 − cos θ_b), ln a, ln b (hi + lo merged) and where in its interval a clamp kink
//! sits. Linear filtering, except in an interval holding a kink, where the shader
//! extrapolates from the two nodes on the query's side (as the runtime's stencil does:
//! interpolating across the slope break costs ~h·Δslope/4, ten times the target);
//! the shader multiplies by 2 sin²(θ_b/2).
//!
//! HYB needs a, b at the ‖f̂‖ of a *sum* of blockers' log-ZH vectors, which no θ_b
//! names: per order a second 1D texture holds ln a, ln b on an axis uniform in ‖f̂‖
//! over [0, T_n], T_n the order's OL threshold (HYB halves f̂ until ‖f̂‖ ≤ T_n, so it
//! never asks beyond). Its values are the runtime's `ab_for_norm`; its error is measured
//! against the reference (a, b) of caps, looked up at the reference ‖f̂‖.

use lobefit_tables::format::{Mapping, Placement};
use lobefit_tables::shexp::{one_minus_cos, ShExp, OL_THRESHOLD, ORDER_MAX, ORDER_MIN};
use lobefit_tables::{Axis, Table};

use lobefit_core::export::families::{Baked, ExtraError, GpuFamily, Kernels};
use lobefit_core::export::gpu_check::{scaled_diff, Context, Kernel, Row, Runner};
use lobefit_core::export::layout::{grid_of_values, ChannelSpec, Grid, Sampler, MAX_SCALE};
use lobefit_core::export::manifest::TextureEntry;
use lobefit_core::export::{Storage, MAX_1D_2D_EXTENT};

/// The export of shexp.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::shexp::KIND,
    grids,
    eval,
    shader: "per order n (texture shexp-n<n>): t = θ_b coordinate in texels, i = min(floor(t), count − 2), \
             κ = channel kink of texel i (texelFetch); κ < 0 (none, stored −1): v = linear sample at θ_b; \
             t − i ≤ κ: v = v_i + (t − i)(v_i − v_{i−1}), else v = v_{i+1} + (t − i − 1)(v_{i+2} − v_{i+1}) \
             (texelFetch, f32; norm, a, b are stored as ln: exp per texel); then s = 2 sin²(θ_b/2), f_l = s · v.f<l> (l < n), ‖f̂‖ = s · v.norm, \
             a = v.a, b = v.b. \
             HYB (texture shexp-hyb-n<n>, axis ‖f̂‖ uniform on [0, T_n], T_n = the texture's upper end = \
             the OL threshold 0.75, 0.125, 0.0625, 0.0625, 0.03125, 0.015625 for n = 3..8): halve f̂ k times \
             until s = ‖f̂‖/2^k ≤ T_n; (a, b) = exp of the linear sample at s; OL: y₀₀ → a √(4π), \
             the rest × b/2^k; square k times (SH products); × exp(f_0/√(4π))",
    extra: Some(hyb_errors),
    kernels: Kernels::Own(|textures| (ORDER_MIN..=ORDER_MAX).map(|n| order_kernel(textures, n)).collect()),
    exact_fetch: false,
    checks: &[hyb_check],
    timed: Some(|textures, points| {
        let norms: Vec<Vec<f64>> = (0..points.len())
            .map(|i| vec![OL_THRESHOLD[ORDER_MAX - ORDER_MIN] * i as f64 / (points.len() - 1).max(1) as f64])
            .collect();
        Ok(vec![
            (order_kernel(textures, ORDER_MAX)?, points.to_vec()),
            (hyb_kernel(textures, ORDER_MAX)?, norms),
        ])
    }),
    plot_export: false,
    baked: &[
        Baked { wrapper: "lf_shexp_n3_baked", function: "lf_shexp", textures: &["shexp-n3"], fixed: &[("n", "3u")] },
        Baked { wrapper: "lf_shexp_n4_baked", function: "lf_shexp", textures: &["shexp-n4"], fixed: &[("n", "4u")] },
        Baked { wrapper: "lf_shexp_n5_baked", function: "lf_shexp", textures: &["shexp-n5"], fixed: &[("n", "5u")] },
        Baked { wrapper: "lf_shexp_n6_baked", function: "lf_shexp", textures: &["shexp-n6"], fixed: &[("n", "6u")] },
        Baked { wrapper: "lf_shexp_n7_baked", function: "lf_shexp", textures: &["shexp-n7"], fixed: &[("n", "7u")] },
        Baked { wrapper: "lf_shexp_n8_baked", function: "lf_shexp", textures: &["shexp-n8"], fixed: &[("n", "8u")] },
        Baked { wrapper: "lf_shexp_hyb_ab_n3_baked", function: "lf_shexp_hyb_ab", textures: &["shexp-hyb-n3"], fixed: &[] },
        Baked { wrapper: "lf_shexp_hyb_ab_n4_baked", function: "lf_shexp_hyb_ab", textures: &["shexp-hyb-n4"], fixed: &[] },
        Baked { wrapper: "lf_shexp_hyb_ab_n5_baked", function: "lf_shexp_hyb_ab", textures: &["shexp-hyb-n5"], fixed: &[] },
        Baked { wrapper: "lf_shexp_hyb_ab_n6_baked", function: "lf_shexp_hyb_ab", textures: &["shexp-hyb-n6"], fixed: &[] },
        Baked { wrapper: "lf_shexp_hyb_ab_n7_baked", function: "lf_shexp_hyb_ab", textures: &["shexp-hyb-n7"], fixed: &[] },
        Baked { wrapper: "lf_shexp_hyb_ab_n8_baked", function: "lf_shexp_hyb_ab", textures: &["shexp-hyb-n8"], fixed: &[] },
    ],
};

/// ‖f̂‖ nodes of each order's HYB texture at scale 1: a, b are smooth in ‖f̂‖ on
/// [0, T_n] (linear at 0).
const HYB_NODES: u32 = 257;

/// Channels of order n's texture: f0..f(n−1), norm, a, b, kink.
fn specs(n: usize) -> Vec<ChannelSpec> {
    let mut v: Vec<ChannelSpec> = (0..n)
        .map(|l| ChannelSpec {
            name: format!("f{l}"),
            meaning: format!("Ren's log-ZH f_{l} / (1 − cos θ_b)"),
            log: false,
        })
        .collect();
    for (name, meaning) in [
        ("norm", "ln(‖f̂‖ / (1 − cos θ_b))"),
        ("a", "ln of the OL coefficient a"),
        ("b", "ln of the OL coefficient b"),
        (
            "kink",
            "where in [θ_i, θ_{i+1}] the clamp kink sits, in units of the interval (−1: none)",
        ),
    ] {
        v.push(ChannelSpec {
            name: name.into(),
            meaning: meaning.into(),
            // ln of ‖f̂‖, a, b (all positive): f16 then resolves them relatively.
            log: name != "kink",
        });
    }
    v
}

/// Decoded pairs (hi + lo) per node, in the table's channel order: 12 pairs (f0..f7,
/// norm, a, b, kink) per (order, θ_b) node.
const PAIRS: usize = 12;

/// One 1D texture per order. At `scale` 1 the table's nodes (2049); otherwise
/// round(2048 · scale) + 1 nodes valued by the runtime (its kink-aware cubic), so a
/// finer grid carries the runtime's accuracy to linear filtering.
/// θ_b nodes per table interval at scale 1: linear filtering on the table's own 2049
/// nodes missed the 1e-4 promise (‖f̂‖ of order 4: 1.15e-4); halving the spacing
/// meets every one (2.6e-5), the values coming from the runtime's cubic stencil.
const REFINE: f64 = 2.0;

fn grids(kind: &str, table: &Table, storage: Storage, scale: f64) -> Result<Vec<Grid>, String> {
    if !(scale > 0.0 && scale <= MAX_SCALE) {
        return Err(format!("--scale {scale}: must lie in (0, {MAX_SCALE}]"));
    }
    let meta = table.meta();
    let theta_axis = meta.axes[1].clone();
    let nodes = theta_axis.count as usize;
    let count = (((nodes - 1) as f64 * REFINE * scale).round() as u32).max(1) + 1;
    if count > MAX_1D_2D_EXTENT {
        return Err(format!(
            "shexp: --scale {scale} gives {count} θ_b nodes, over the 1D texture limit {MAX_1D_2D_EXTENT}"
        ));
    }
    let axis = Axis { count, ..theta_axis };
    let pair = |n: usize, i: usize, q: usize| {
        let at = ((n - ORDER_MIN) * nodes + i) * 2 * PAIRS + 2 * q;
        f64::from(table.values()[at]) + f64::from(table.values()[at + 1])
    };
    let h = axis.hi / (count - 1) as f64;
    let rt = ShExp::from_table(table.clone()).map_err(|e| format!("{kind}: {e}"))?;
    let mut out = Vec::new();
    for n in ORDER_MIN..=ORDER_MAX {
        // The table's kinks (θ_b, rad), placed in this grid's intervals.
        let mut kink = vec![-1.0; count as usize];
        for k in (0..nodes).map(|i| pair(n, i, 11)).filter(|&k| k >= 0.0) {
            let j = ((k / h).floor() as usize).min(count as usize - 2);
            kink[j] = (k / h - j as f64).clamp(0.0, 1.0);
        }
        let mut values = Vec::with_capacity(count as usize * (n + 4));
        for (i, &kink) in kink.iter().enumerate() {
            if count as usize == nodes || i == 0 {
                // The stored nodes; θ_b = 0 holds the limits (0/0 through the runtime).
                values.extend((0..n).map(|q| pair(n, i, q)));
                values.extend((8..11).map(|q| pair(n, i, q).ln()));
                values.push(kink);
                continue;
            }
            let theta = axis.node(i as u32).clamp(axis.lo, axis.hi);
            let s = one_minus_cos(theta);
            let mut f = [0.0; 8];
            rt.log_zh(theta, n, &mut f).map_err(|e| format!("{kind}: {e}"))?;
            let (norm, a, b) = rt.norm_ab(theta, n).map_err(|e| format!("{kind}: {e}"))?;
            values.extend(f[..n].iter().map(|v| v / s));
            values.extend([norm / s, a, b].map(f64::ln));
            values.push(kink);
        }
        out.push(grid_of_values(
            &format!("{kind}-n{n}"),
            std::slice::from_ref(&axis),
            &specs(n),
            &values,
            storage,
        )?);
    }
    for n in ORDER_MIN..=ORDER_MAX {
        out.push(hyb_grid(kind, &rt, n, storage, scale)?);
    }
    Ok(out)
}

/// Order n's HYB texture: ln a, ln b against ‖f̂‖ ∈ [0, T_n].
fn hyb_grid(kind: &str, rt: &ShExp, n: usize, storage: Storage, scale: f64) -> Result<Grid, String> {
    let axis = Axis {
        name: "norm".into(),
        unit: "1".into(),
        lo: 0.0,
        hi: OL_THRESHOLD[n - ORDER_MIN],
        mapping: Mapping::Linear,
        count: (((HYB_NODES - 1) as f64 * scale).round() as u32).max(1) + 1,
        placement: Placement::Endpoints,
    };
    let mut values = Vec::with_capacity(2 * axis.count as usize);
    for i in 0..axis.count {
        let x = axis.node(i).clamp(axis.lo, axis.hi);
        let (a, b) = rt.ab_for_norm(x, n).map_err(|e| format!("{kind}: {e}"))?;
        values.extend([a.ln(), b.ln()]);
    }
    let specs = [("a", "OL coefficient a"), ("b", "OL coefficient b")].map(|(name, what)| ChannelSpec {
        name: name.into(),
        meaning: format!("ln of the {what} at ‖f̂‖ (HYB)"),
        log: true,
    });
    grid_of_values(&format!("{kind}-hyb-n{n}"), &[axis], &specs, &values, storage)
}

/// θ_b where order n's reference ‖f̂‖ reaches its OL threshold T_n (monotone below
/// it: bisection to 2⁻⁴⁰ of the range): the caps HYB's a, b are measured on.
fn theta_at_threshold(n: usize) -> Result<f64, String> {
    let top = OL_THRESHOLD[n - ORDER_MIN];
    let (mut lo, mut hi) = (0.0, lobefit_tables::shexp::THETA_MAX);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if super::reference_point(mid, n)?.1 <= top {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(lo)
}

/// The HYB textures against the reference: per order, caps with ‖f̂‖ ≤ T_n (θ_b half
/// uniform, half log-uniform down to 1e-4 rad), each looked up at its reference ‖f̂‖
/// rounded to f32; max relative error of a and b, held to the family's a, b limit.
fn hyb_errors(s: &[Sampler], samples: usize, seed: u64) -> Result<Vec<ExtraError>, String> {
    use rayon::prelude::*;
    let orders = ORDER_MAX - ORDER_MIN + 1;
    let mut out = Vec::new();
    for n in ORDER_MIN..=ORDER_MAX {
        let sampler = &s[orders + n - ORDER_MIN];
        let top = OL_THRESHOLD[n - ORDER_MIN];
        let lo = theta_at_threshold(n)?;
        let mut rng = lobefit_core::rng::Rng::new(seed ^ (0x4879_6200 + n as u64));
        let thetas: Vec<f64> = (0..samples / orders)
            .map(|_| {
                if rng.uniform() < 0.5 {
                    rng.range(0.0, lo)
                } else {
                    rng.range(1e-4f64.ln(), lo.ln()).exp()
                }
            })
            .collect();
        let errs = thetas
            .par_iter()
            .map(|&t| {
                let (_, norm, a, b) = super::reference_point(t, n)?;
                let v = sampler.sample(&[(norm as f32).min(top as f32)]);
                Ok([
                    lobefit_core::check::rel_err(f64::from(v[0]), a),
                    lobefit_core::check::rel_err(f64::from(v[1]), b),
                ])
            })
            .collect::<Result<Vec<_>, String>>()?;
        for (k, q) in ["a", "b"].iter().enumerate() {
            out.push(ExtraError {
                output: format!("n{n}_{q}(norm)"),
                metric: "offgrid.max_rel".into(),
                measured: errs.iter().map(|e| e[k]).fold(0.0, f64::max),
                target: super::OFFGRID_REL,
            });
        }
    }
    Ok(out)
}

/// Every order's f_0..f_{n−1}, ‖f̂‖, a, b at θ_b (the whole-table lookup's order).
fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let theta = x[0];
    let h = (0.5 * theta).sin();
    let omc = 2.0 * h * h;
    let mut out = Vec::new();
    for n in ORDER_MIN..=ORDER_MAX {
        let c = sample(&s[n - ORDER_MIN], theta, n + 3);
        out.extend(c[..=n].iter().map(|v| v * omc));
        out.extend(&c[n + 1..n + 3]);
    }
    out
}

/// The first `k` channels at θ_b: the sampler's linear filter, or in an interval
/// holding a kink, linear extrapolation from the two texels on θ_b's side.
fn sample(s: &Sampler, theta: f32, k: usize) -> Vec<f32> {
    let axis = &s.axes[0];
    let last = axis.axis.count as usize - 1;
    let t = axis.texel_coordinate(theta).clamp(0.0, last as f32);
    let i = (t.floor() as usize).min(last - 1);
    let kink = s.fetch(&[i])[k];
    // Stored −1 where there is none (f16 leaves it within 1e-3 of that).
    if kink < -0.5 {
        return s.sample(&[theta])[..k].to_vec();
    }
    let w = t - i as f32;
    let (j, x) = if w <= kink && i >= 1 {
        (i - 1, w + 1.0)
    } else if i + 2 <= last {
        (i + 1, w - 1.0)
    } else {
        (i - 1, w + 1.0)
    };
    // The line through texels j, j + 1, at x texels from j.
    let (a, b) = (s.fetch(&[j]), s.fetch(&[j + 1]));
    (0..k).map(|c| a[c] + x * (b[c] - a[c])).collect()
}

/// The index of the texture with file stem `stem`.
fn texture(textures: &[TextureEntry], stem: &str) -> Result<usize, String> {
    textures
        .iter()
        .position(|e| e.file.split('.').next() == Some(stem))
        .ok_or_else(|| format!("shexp: the export lacks texture {stem}"))
}

/// Order n's lookup: f_0..f_{n−1}, ‖f̂‖, a, b at θ_b = x0 from texture `shexp-n<n>`.
fn order_kernel(textures: &[TextureEntry], n: usize) -> Result<Kernel, String> {
    let body = format!(
        "    let r = lf_shexp(T, S, P, {n}u, x0);\n    for (var l = 0u; l < {n}u; l++) {{\n        Y[o + l] = r.f[l];\n    }}\n    \
         Y[o + {n}u] = r.norm;\n    Y[o + {}u] = r.a;\n    Y[o + {}u] = r.b;",
        n + 1,
        n + 2
    );
    let t = texture(textures, &format!("shexp-n{n}"))?;
    Ok(Kernel::new(&format!("shexp order {n}"), &[t], &body, n + 3))
}

/// Order n's HYB a, b at ‖f̂‖ = x0 from texture `shexp-hyb-n<n>`.
fn hyb_kernel(textures: &[TextureEntry], n: usize) -> Result<Kernel, String> {
    let t = texture(textures, &format!("shexp-hyb-n{n}"))?;
    Ok(Kernel::new(
        "shexp HYB a, b",
        &[t],
        "    let ab = lf_shexp_hyb_ab(T, S, P, x0);\n    Y[o] = ab.x;\n    Y[o + 1u] = ab.y;",
        2,
    ))
}

/// shexp's HYB textures on the GPU (`lf_shexp_hyb_ab`): per order, caps whose
/// reference ‖f̂‖ is at most T_n (θ_b half uniform, half log-uniform down to 1e-4 rad,
/// as the export measures them), looked up at the reference ‖f̂‖ rounded to f32;
/// against the CPU emulation of the texture and against the reference (a, b), held to
/// the manifest's promise for `n<n>_a(norm)`, `n<n>_b(norm)`.
fn hyb_check(ctx: &Context, runner: &dyn Runner) -> Result<Vec<Row>, String> {
    let per_order = ctx.samples / (ORDER_MAX - ORDER_MIN + 1);
    let (mut worst_cpu, mut vs_ref) = (0.0f64, Vec::new());
    for n in ORDER_MIN..=ORDER_MAX {
        let top = OL_THRESHOLD[n - ORDER_MIN];
        let lo = theta_at_threshold(n)?;
        let mut rng = lobefit_core::rng::Rng::new(ctx.seed ^ (0x4750_4859 + n as u64));
        let refs: Vec<(f64, f64, f64)> = (0..per_order)
            .map(|k| {
                let t = if k % 2 == 0 {
                    rng.range(0.0, lo)
                } else {
                    rng.range(1e-4f64.ln(), lo.ln()).exp()
                };
                super::reference_point(t, n).map(|(_, norm, a, b)| (norm, a, b))
            })
            .collect::<Result<_, _>>()?;
        let inputs: Vec<Vec<f64>> = refs
            .iter()
            .map(|r| vec![f64::from((r.0 as f32).min(top as f32))])
            .collect();
        let kernel = hyb_kernel(ctx.textures, n)?;
        let got = runner.run(&kernel, &inputs)?;
        let sampler = &ctx.samplers[kernel.textures[0]];
        let emu: Vec<Vec<f64>> = inputs
            .iter()
            .map(|x| sampler.sample(&[x[0] as f32]).iter().map(|&v| f64::from(v)).collect())
            .collect();
        worst_cpu = worst_cpu.max(scaled_diff(&got, &emu).0);
        for (k, q) in ["a", "b"].iter().enumerate() {
            let output = format!("n{n}_{q}(norm)");
            let measured = got
                .iter()
                .zip(&refs)
                .map(|(g, r)| lobefit_core::check::rel_err(g[k], if k == 0 { r.1 } else { r.2 }))
                .fold(0.0, f64::max);
            let promise = ctx.promise(&output, "offgrid.max_rel").unwrap_or(super::OFFGRID_REL);
            vs_ref.push((
                format!("{output} max_rel"),
                measured,
                promise * (1.0 + lobefit_core::export::gpu_check::PROMISE_SLACK),
            ));
        }
    }
    Ok(vec![Row {
        function: "shexp HYB a, b at |f|".into(),
        storage: ctx.storage.to_string(),
        filter: ctx.filter.name().into(),
        samples: per_order * (ORDER_MAX - ORDER_MIN + 1),
        vs_cpu: worst_cpu,
        cpu_what: "emulation",
        vs_ref,
        info: Vec::new(),
    }])
}
