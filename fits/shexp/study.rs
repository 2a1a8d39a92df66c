//! The SH exponentiation evaluation (docs/math.md, shexp): how well HYB (DC isolation +
//! halving + OL from the `shexp` table + truncated squaring) reproduces the Taylor
//! reference exp*, for single cap blockers and for random scenes of 2–400 blockers
//! accumulated in log space as a renderer does (each blocker's tabulated log-ZH turned
//! to its direction with the runtime's ZH→SH rotation and summed), and how both
//! compare with the SH projection of the exact product visibility. Also Ren's log
//! round trip exp*(log g) vs g, and the OL threshold per order chosen from the scenes.
//!
//! Errors are relative L2 over the whole SH vector: ‖x − ref‖/‖ref‖.

use std::f64::consts::PI;

use lobefit_tables::sh::zh_to_sh;
use lobefit_tables::shexp::{cap_visibility_zh, ShExp, ORDER_MAX, ORDER_MIN};

use crate::shexp::exp_log::{exact_visibility_sh, ren_log_zonal, zh_to_sh_z};
use lobefit_core::rng::Rng;
use lobefit_core::sh::{exp_star, Gaunt, SphereRule};

/// Fewest and most blockers of a random scene.
pub const SCENE_BLOCKERS: (usize, usize) = (2, 400);
/// Smallest blocker radius of a random scene (rad).
pub const SCENE_RADIUS_MIN: f64 = 0.005;
/// Largest blocker radius of a scene of K blockers: min(π/2, this/√K), so that the
/// blocked fraction stays O(1) as K grows (a cap of radius θ covers ≈ θ²/4 of the sphere).
pub const SCENE_RADIUS_SCALE: f64 = 1.5;
/// The exact visibility's projection rule: Gauss–Legendre × trapezoid, 640 × 1280
/// nodes. The visibility is discontinuous, so the rule converges only like its node
/// spacing: measured on 12 study scenes (orders 3 and 8), 160 × 320 and 320 × 640
/// differ from this rule by median 8.9e-4 / 3.5e-4 and max 2.5e-3 / 1.3e-3 relative,
/// so this rule's own error is about half the latter (≈ 2e-4 median, ≈ 6e-4 max).
pub const EXACT_RULE: (usize, usize) = (640, 1280);

/// ‖a − b‖ / ‖b‖.
pub fn rel_l2(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let n: f64 = b.iter().map(|y| y * y).sum();
    (d / n).sqrt()
}

/// One evaluated visibility.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// ‖f̂‖ of the accumulated log vector.
    pub norm: f64,
    /// Blockers in the scene.
    pub blockers: usize,
    /// HYB vs Taylor exp*.
    pub hyb_taylor: f64,
    /// Taylor exp* vs the projection of the exact visibility.
    pub taylor_exact: f64,
    /// HYB vs the projection of the exact visibility.
    pub hyb_exact: f64,
    /// Scaling and squaring with HYB's k (Taylor on f/2^k, k truncated squarings) vs
    /// Taylor: the part of HYB's error due to squaring with truncated products.
    pub ss_taylor: f64,
    /// Squarings HYB used.
    pub squarings: u32,
}

/// A random scene: blocker directions and radii.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Unit directions.
    pub dirs: Vec<[f64; 3]>,
    /// Angular radii (rad).
    pub radii: Vec<f64>,
    /// Order-8 SH projection of the exact visibility (lower orders: its prefix).
    pub exact: Vec<f64>,
}

/// `count` seeded random scenes (blocker count log-uniform in [`SCENE_BLOCKERS`],
/// directions uniform, radii log-uniform in [`SCENE_RADIUS_MIN`], min(π/2, 1.5/√K)]),
/// with the exact visibility projected by [`EXACT_RULE`].
pub fn scenes(count: usize, seed: u64) -> Vec<Scene> {
    let rule = SphereRule::new(EXACT_RULE.0, EXACT_RULE.1);
    let mut v = scene_geometry(count, seed);
    for s in &mut v {
        s.exact = exact_visibility_sh(&rule, ORDER_MAX, &s.dirs, &s.radii);
    }
    v
}

/// The scenes of [`scenes`] without the (expensive) exact projection: `exact` is empty.
pub fn scene_geometry(count: usize, seed: u64) -> Vec<Scene> {
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|_| {
            let (lo, hi) = SCENE_BLOCKERS;
            let k = (rng.range((lo as f64).ln(), (hi as f64 + 1.0).ln()).exp() as usize).clamp(lo, hi);
            let rmax = (PI / 2.0).min(SCENE_RADIUS_SCALE / (k as f64).sqrt());
            let mut dirs = Vec::with_capacity(k);
            let mut radii = Vec::with_capacity(k);
            for _ in 0..k {
                let z = rng.range(-1.0, 1.0);
                let phi = rng.range(0.0, 2.0 * PI);
                let s = (1.0 - z * z).sqrt();
                dirs.push([s * phi.cos(), s * phi.sin(), z]);
                radii.push(rng.range(SCENE_RADIUS_MIN.ln(), rmax.ln()).exp());
            }
            Scene {
                dirs,
                radii,
                exact: Vec::new(),
            }
        })
        .collect()
}

/// The accumulated log vector of a scene at `order` (tabulated Ren log-ZH of every
/// blocker, turned to its direction and summed).
pub fn scene_log(rt: &ShExp, scene: &Scene, order: usize) -> Result<Vec<f64>, String> {
    let nc = order * order;
    let mut f = vec![0.0; nc];
    let mut zh = [0.0; 8];
    let mut sh = [0.0; 64];
    for (d, &r) in scene.dirs.iter().zip(&scene.radii) {
        rt.log_zh(r, order, &mut zh).map_err(|e| e.to_string())?;
        zh_to_sh(&zh[..order], *d, &mut sh).map_err(|e| e.to_string())?;
        f.iter_mut().zip(&sh).for_each(|(a, b)| *a += b);
    }
    Ok(f)
}

/// Evaluates HYB (threshold `t`) and Taylor on the log vector `f` against `exact`.
pub fn evaluate(
    rt: &ShExp,
    gaunt: &Gaunt,
    f: &[f64],
    exact: &[f64],
    t: f64,
    blockers: usize,
) -> Result<Sample, String> {
    let taylor = exp_star(gaunt, f);
    if !taylor.converged {
        return Err("Taylor exp* did not converge".into());
    }
    let mut hyb = vec![0.0; f.len()];
    let squarings = rt.hyb_threshold(f, t, &mut hyb).map_err(|e| e.to_string())?;
    let ss = crate::shexp::exp_log::exp_scaling_squaring(gaunt, f, squarings);
    Ok(Sample {
        ss_taylor: rel_l2(&ss.value, &taylor.value),
        norm: f[1..].iter().map(|v| v * v).sum::<f64>().sqrt(),
        blockers,
        hyb_taylor: rel_l2(&hyb, &taylor.value),
        taylor_exact: rel_l2(&taylor.value, exact),
        hyb_exact: rel_l2(&hyb, exact),
        squarings,
    })
}

/// Single caps at `order`: θ_b on `count` points of (0, π/2], their tabulated log-ZH,
/// exact visibility = the closed-form cap ZH.
pub fn single_caps(rt: &ShExp, order: usize, t: f64, count: usize) -> Result<Vec<Sample>, String> {
    let gaunt = Gaunt::cached(order).map_err(|e| e.to_string())?;
    (1..=count)
        .map(|i| {
            let theta = PI / 2.0 * i as f64 / count as f64;
            let mut zh = [0.0; 8];
            rt.log_zh(theta, order, &mut zh).map_err(|e| e.to_string())?;
            let f = zh_to_sh_z(&zh[..order]);
            let g = zh_to_sh_z(&cap_visibility_zh(theta, order).map_err(|e| e.to_string())?[..order]);
            evaluate(rt, gaunt, &f, &g, t, 1)
        })
        .collect()
}

/// The scenes evaluated at `order` with threshold `t`.
pub fn scene_samples(rt: &ShExp, scenes: &[Scene], order: usize, t: f64) -> Result<Vec<Sample>, String> {
    let gaunt = Gaunt::cached(order).map_err(|e| e.to_string())?;
    scenes
        .iter()
        .map(|s| {
            let f = scene_log(rt, s, order)?;
            evaluate(rt, gaunt, &f, &s.exact[..order * order], t, s.dirs.len())
        })
        .collect()
}

/// Round trips per order, max of ‖exp*(log g) − g‖/‖g‖ over `count` caps θ_b ∈ (0, π/2].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundTrip {
    /// Ren's log, caps without clamping.
    pub ren_free: f64,
    /// Ren's log, caps with clamping.
    pub ren_clamped: f64,
    /// θ_b of the clamp onset (first clamped cap).
    pub onset: f64,
    /// The LM "inverse exp*" log (from Ren's), caps without clamping.
    pub lm_free: f64,
    /// The LM log, caps with clamping.
    pub lm_clamped: f64,
}

/// The LM log's round trip is measured on every 4th cap of [`round_trip`].
pub const LM_EVERY: usize = 4;

/// Round trip of Ren's log (every cap) and of the LM log (every [`LM_EVERY`]-th) per
/// order over `count` caps.
pub fn round_trip(order: usize, count: usize) -> Result<RoundTrip, String> {
    let gaunt = Gaunt::cached(order).map_err(|e| e.to_string())?;
    let mut rtp = RoundTrip {
        ren_free: 0.0,
        ren_clamped: 0.0,
        onset: f64::NAN,
        lm_free: 0.0,
        lm_clamped: 0.0,
    };
    for i in 1..=count {
        let theta = PI / 2.0 * i as f64 / count as f64;
        let g = cap_visibility_zh(theta, order).map_err(|e| e.to_string())?[..order].to_vec();
        let r = ren_log_zonal(gaunt, &g)?;
        let back = exp_star(gaunt, &zh_to_sh_z(&r.f)).value;
        let e = rel_l2(&back, &zh_to_sh_z(&g));
        // LM (slow where it ends in a local minimum) on every LM_EVERY-th cap.
        let lm = if i % LM_EVERY == 0 {
            crate::shexp::exp_log::lm_log_zonal(gaunt, &g)?.residual
        } else {
            0.0
        };
        if r.clamped == 0 {
            rtp.ren_free = rtp.ren_free.max(e);
            rtp.lm_free = rtp.lm_free.max(lm);
        } else {
            if rtp.onset.is_nan() {
                rtp.onset = theta;
            }
            rtp.ren_clamped = rtp.ren_clamped.max(e);
            rtp.lm_clamped = rtp.lm_clamped.max(lm);
        }
    }
    Ok(rtp)
}

/// Median and max of a sample (NaN when empty).
pub fn median_max(mut v: Vec<f64>) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[v.len() - 1])
}

/// Candidate OL thresholds at `order`: 1/64, 1/32, 1/16, 1/8, then 0.25, 0.5, 0.75, … up to the table's monotone-branch
/// end, and Ren et al.'s 4.8 when it fits.
pub fn candidates(rt: &ShExp, order: usize) -> Result<Vec<f64>, String> {
    let top = rt.norm_max(order).map_err(|e| e.to_string())?;
    let mut v: Vec<f64> = [1.0 / 64.0, 1.0 / 32.0, 1.0 / 16.0, 0.125]
        .into_iter()
        .chain((1..).map(|k| 0.25 * k as f64).take_while(|&t| t <= top))
        .collect();
    if 4.8 <= top && !v.contains(&4.8) {
        v.push(4.8);
        v.sort_by(f64::total_cmp);
    }
    Ok(v)
}

/// How much HYB may add to the error exp* itself makes: a threshold is acceptable
/// when the scenes' median HYB-vs-exact error, and the max of it over the scenes and
/// over the single caps, stay within 25 % of the Taylor-vs-exact ones (the floor no
/// exp* evaluation can beat: Taylor is exp* exactly). The caps' median is not used:
/// their Taylor-vs-exact floor is ~0 for small unclamped caps. Larger thresholds need
/// fewer squarings (one truncated product each).
pub const THRESHOLD_SLACK: f64 = 1.25;

/// The OL threshold of `order` chosen from the scenes and caps: the largest
/// acceptable candidate (see [`THRESHOLD_SLACK`]), or the smallest candidate when
/// none is. Returns (threshold, whether it is acceptable).
pub fn choose_threshold(rt: &ShExp, scenes: &[Scene], order: usize) -> Result<(f64, bool), String> {
    let cands = candidates(rt, order)?;
    let mut chosen = None;
    for &t in &cands {
        let s = scene_samples(rt, scenes, order, t)?;
        let c = single_caps(rt, order, t, STUDY_CAPS)?;
        let stats = |v: &[Sample]| {
            (
                median_max(v.iter().map(|x| x.hyb_exact).collect()),
                median_max(v.iter().map(|x| x.taylor_exact).collect()),
            )
        };
        let ((sh_m, sh_x), (st_m, st_x)) = stats(&s);
        let ((_, ch_x), (_, ct_x)) = stats(&c);
        let k = THRESHOLD_SLACK;
        if sh_m <= k * st_m && sh_x <= k * st_x && ch_x <= k * ct_x {
            chosen = Some(t);
        }
    }
    match chosen {
        Some(t) => Ok((t, true)),
        None => Ok((*cands.first().ok_or("no candidate threshold")?, false)),
    }
}

/// Scenes of the study (`lobefit plot shexp` and docs/shexp.md).
pub const STUDY_SCENES: usize = 200;
/// Seed of the study's scenes.
pub const STUDY_SEED: u64 = 0x5e_e4f9;
/// Single caps per order (θ_b uniform in (0, π/2]).
pub const STUDY_CAPS: usize = 400;

/// A chart polyline.
type Curve = Vec<(f64, f64)>;

/// Binned (median, max) of `y` vs `x` on log-spaced bins (for the charts).
fn binned(points: &[(f64, f64)], bins: usize) -> (Curve, Curve) {
    let pos: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.0 > 0.0).collect();
    let lo = pos.iter().map(|p| p.0).fold(f64::INFINITY, f64::min).ln();
    let hi = pos.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max).ln();
    let (mut med, mut max) = (Vec::new(), Vec::new());
    for b in 0..bins {
        let (a, c) = (
            lo + (hi - lo) * b as f64 / bins as f64,
            lo + (hi - lo) * (b + 1) as f64 / bins as f64,
        );
        let ys: Vec<f64> = pos
            .iter()
            .filter(|p| p.0.ln() >= a && (p.0.ln() < c || b + 1 == bins))
            .map(|p| p.1)
            .collect();
        if !ys.is_empty() {
            let x = (0.5 * (a + c)).exp();
            let (m, x_) = median_max(ys);
            med.push((x, m));
            max.push((x, x_));
        }
    }
    (med, max)
}

/// `lobefit plot shexp`: per order a chart of the errors vs ‖f̂‖ (HYB vs Taylor for
/// single caps and scenes, Taylor and HYB vs the exact visibility), the summary table
/// (Markdown, as in docs/shexp.md) and every sample as CSV.
pub fn plot(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_core::plot::{line_chart, LineChart, Series};
    let rt = ShExp::embedded().map_err(|e| e.to_string())?;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let sc = scenes(STUDY_SCENES, STUDY_SEED);
    let mut out = Vec::new();
    let mut csv = String::from("order,kind,blockers,norm,hyb_taylor,taylor_exact,hyb_exact,ss_taylor,squarings\n");
    let mut md = String::from(
        "| order | T (chosen; meets the criterion) | norm max (branch end θ_b) | round trip max: no clamp / clamp (onset θ_b) | LM log round trip max: no clamp / clamp | caps ‖f̂‖≤T HYB–Taylor median / max | scenes HYB–Taylor median / max | scenes ‖f̂‖≤T HYB–Taylor median / max (count) | scenes Taylor–exact median / max | scenes HYB–exact median / max | caps at T=4.8: HYB–Taylor median / max | scenes at T=4.8: HYB–exact median / max |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mm = |v: Vec<f64>| {
        let (m, x) = median_max(v);
        format!("{m:.2e} / {x:.2e}")
    };
    for n in orders() {
        let (t, acceptable) = choose_threshold(rt, &sc, n)?;
        let caps = single_caps(rt, n, t, STUDY_CAPS)?;
        let scn = scene_samples(rt, &sc, n, t)?;
        let ren = 4.8f64.min(rt.norm_max(n).map_err(|e| e.to_string())?);
        let caps48 = single_caps(rt, n, ren, STUDY_CAPS)?;
        let scn48 = scene_samples(rt, &sc, n, ren)?;
        let trip = round_trip(n, STUDY_CAPS)?;
        for (kind, v) in [("cap", &caps), ("scene", &scn)] {
            for x in v.iter() {
                csv.push_str(&format!(
                    "{n},{kind},{},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{}\n",
                    x.blockers, x.norm, x.hyb_taylor, x.taylor_exact, x.hyb_exact, x.ss_taylor, x.squarings
                ));
            }
        }
        let below: Vec<f64> = scn.iter().filter(|x| x.norm <= t).map(|x| x.hyb_taylor).collect();
        let nb = below.len();
        md.push_str(&format!(
            "| {n} | {t} ({}) | {:.3} ({:.3}) | {:.2e} / {:.2e} ({:.3}) | {:.2e} / {:.2e} | {} | {} | {} ({nb}) | {} | {} | {} | {} |\n",
            if acceptable { "yes" } else { "no: smallest candidate" },
            rt.norm_max(n).map_err(|e| e.to_string())?,
            rt.branch_end_theta(n).map_err(|e| e.to_string())?,
            trip.ren_free,
            trip.ren_clamped,
            trip.onset,
            trip.lm_free,
            trip.lm_clamped,
            mm(caps.iter().filter(|x| x.norm <= t).map(|x| x.hyb_taylor).collect()),
            mm(scn.iter().map(|x| x.hyb_taylor).collect()),
            mm(below),
            mm(scn.iter().map(|x| x.taylor_exact).collect()),
            mm(scn.iter().map(|x| x.hyb_exact).collect()),
            mm(caps48.iter().filter(|x| x.norm <= ren).map(|x| x.hyb_taylor).collect()),
            mm(scn48.iter().map(|x| x.hyb_exact).collect()),
        ));
        let mut cap_pts: Vec<(f64, f64)> = caps.iter().map(|x| (x.norm, x.hyb_taylor)).collect();
        cap_pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut cap48: Vec<(f64, f64)> = caps48.iter().map(|x| (x.norm, x.hyb_taylor)).collect();
        cap48.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (s_med, s_max) = binned(&scn.iter().map(|x| (x.norm, x.hyb_taylor)).collect::<Vec<_>>(), 12);
        let (e_med, _) = binned(&scn.iter().map(|x| (x.norm, x.taylor_exact)).collect::<Vec<_>>(), 12);
        let (h_med, _) = binned(&scn.iter().map(|x| (x.norm, x.hyb_exact)).collect::<Vec<_>>(), 12);
        let chart = LineChart {
            title: format!("shexp order {n}: relative L2 error vs ‖f̂‖ (HYB threshold T = {t})"),
            x_label: "‖f̂‖".into(),
            y_label: "relative L2 error".into(),
            log_x: true,
            log_y: true,
            series: vec![
                Series {
                    name: format!("single caps: HYB vs Taylor (T = {t})"),
                    points: cap_pts,
                },
                Series {
                    name: format!("single caps: HYB vs Taylor (T = {ren:.2})"),
                    points: cap48,
                },
                Series {
                    name: "scenes: HYB vs Taylor, median per bin".into(),
                    points: s_med,
                },
                Series {
                    name: "scenes: HYB vs Taylor, max per bin".into(),
                    points: s_max,
                },
                Series {
                    name: "scenes: Taylor vs exact visibility, median".into(),
                    points: e_med,
                },
                Series {
                    name: "scenes: HYB vs exact visibility, median".into(),
                    points: h_med,
                },
            ],
        };
        out.push(line_chart(&dir.join(format!("shexp-errors-order{n}.png")), &chart)?);
    }
    for (name, text) in [("shexp-samples.csv", csv), ("shexp-summary.md", md)] {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))?;
        out.push(p);
    }
    Ok(out)
}

/// Orders of the study.
pub fn orders() -> std::ops::RangeInclusive<usize> {
    ORDER_MIN..=ORDER_MAX
}
