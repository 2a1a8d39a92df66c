//! mask-weights (Meunier et al. 2009 §5.3, eq. 39; docs/math.md, mask-weights;
//! docs/meunier.md): the per-depth weights of the visibility mask's leaf lobes,
//! fitted by least squares against the exact mask visibility, with the paper's manual
//! procedure made automatic as a baseline. The pipeline that reads these weights
//! (`eval direct-light`, `render meunier`) is `lobefit_pipelines::meunier`.
//!
//! **Definition.** For a light cap of half-angle α (the node's `dist` = 1/(2 tan α))
//! and a blocker configuration (caps b_j), the mask of maximal depth D in a mode gives
//! shadow leaves i of depth d_i with lobes c_i = Ψ(·; a_i, e_cap(β_i)). Over the light's
//! cone C the visibility error of weights w is
//! V_lobes − V_exact = U − Σ_d w_d Φ_d, U the indicator of the union of the caps and
//! Φ_d = Σ_{d_i = d} c_i. The weights minimise Σ_configs ∫_C (U − Σ_d w_d Φ_d)² dω over
//! [`TRAIN_CONFIGS`] seeded configurations (the same at every node, in units of α) —
//! linear least squares, the normal equations G w = g with a ridge of [`RIDGE`]·tr G/n
//! pulling towards 1 (a depth that never holds a leaf keeps weight 1). The paper's
//! procedure made automatic: coarse to fine, each w_d chosen by the same least
//! squares with the coarser weights fixed and the finer ones 0 ("the first level so
//! that the umbra is dark, each further level without sharpening the shadow").
//!
//! **Fit and reference.** The fit integrates over C with a midpoint rule
//! ([`FIT_RULE`]); the checker's reference solves the same least squares with an
//! independent Gauss–Legendre × trapezoid rule ([`REF_RULE`]), and measures the
//! visibility error of the fitted, paper and all-ones weights on held-out
//! configurations at random `dist` with it.

pub mod gpu;

use std::f64::consts::{FRAC_PI_2, TAU};
use std::sync::OnceLock;

use lobefit_tables::format::Threshold;
use lobefit_tables::glam::DVec3;
use lobefit_tables::mask_weights::{
    self as rt, build_mask, channel_name, channel_names, Cap, Mask, MaskMode, MaskWeights, WeightSet, DIST_MAX,
    DIST_MIN, DIST_NODES, MAX_DEPTH, WEIGHT_RANGE,
};
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};
use rayon::prelude::*;

use crate::cap_exponent::objective_slope;
use lobefit_core::eigen;
use lobefit_core::family::{Checked, Extra, Fit, Fitted, Lookup, View};
use lobefit_core::quad::illinois;
use lobefit_core::rng::Rng;

/// Training configurations per node.
pub const TRAIN_CONFIGS: usize = 48;
/// Seed of the training configurations.
pub const TRAIN_SEED: u64 = 0x3a5c_0f13;
/// Seed offset of the checker's held-out configurations (never used by the fit).
pub const HELDOUT_SEED: u64 = 0x4e1d_0a7e;
/// The fit's rule over the light cone: midpoint in cos θ × midpoint in φ.
pub const FIT_RULE: (usize, usize) = (40, 80);
/// The checker's rule: Gauss–Legendre in θ × trapezoid in φ, finer than the fit's.
pub const REF_RULE: (usize, usize) = (48, 96);
/// Ridge weight (relative to tr G / n) pulling weights towards 1.
pub const RIDGE: f64 = 1e-6;
/// Lobe values below this are skipped (their share of any integral is below it).
const LOBE_CUT: f64 = 1e-9;
/// Largest |stored − reference| weight at a node: the two rules' least-squares
/// solutions differ by quadrature error of a discontinuous integrand (measured
/// 5.1e-3, docs/meunier.md); the limit leaves headroom.
pub const NODE_ABS: f64 = 0.05;
/// Held-out relative L2 visibility error of the fitted weights (aggressive, depth 5):
/// median limit (docs/meunier.md gives the measured value).
pub const HELDOUT_MEDIAN: f64 = 0.35;

/// The fitted family.
#[derive(Debug, Clone, Copy, Default)]
pub struct MaskWeightsFamily;

/// Exact cap exponent (the root of the closed-form ∂F/∂e, docs/math.md cap-exponent),
/// independent of the cap-exponent table; 0 for α ≥ π/2.
pub fn exact_e_cap(alpha: f64) -> f64 {
    if alpha >= FRAC_PI_2 {
        return 0.0;
    }
    // e_cap = q·m(α) with q ∈ [0.47, 0.97]: bracket generously.
    let c = alpha.cos();
    let s = (0.5 * alpha).sin();
    let m = c * (1.0 - c.ln()) / (2.0 * s * s);
    illinois(|e| objective_slope(alpha, e), 0.3 * m, 1.2 * m, 1e-12 * m, 200).map_or(f64::NAN, |r| r.0)
}

/// A quadrature rule over a cone of half-angle α about +z: directions and weights
/// (summing to the cone's solid angle).
pub struct ConeRule {
    /// Unit directions.
    pub dirs: Vec<DVec3>,
    /// Weights (sr).
    pub weights: Vec<f64>,
}

impl ConeRule {
    /// Midpoint rule in μ = cos θ ∈ [cos α, 1] and φ (the fit's).
    pub fn midpoint(alpha: f64, (nt, np): (usize, usize)) -> ConeRule {
        let c0 = alpha.cos();
        let mut r = ConeRule {
            dirs: Vec::with_capacity(nt * np),
            weights: Vec::with_capacity(nt * np),
        };
        let w = (1.0 - c0) * TAU / (nt * np) as f64;
        for i in 0..nt {
            let mu = c0 + (1.0 - c0) * (i as f64 + 0.5) / nt as f64;
            let st = (1.0 - mu * mu).max(0.0).sqrt();
            for j in 0..np {
                let phi = TAU * (j as f64 + 0.5) / np as f64;
                r.dirs.push(DVec3::new(st * phi.cos(), st * phi.sin(), mu));
                r.weights.push(w);
            }
        }
        r
    }

    /// Gauss–Legendre in θ ∈ [0, α] (weight sin θ) × trapezoid in φ (the checker's).
    pub fn gauss(alpha: f64, (nt, np): (usize, usize)) -> ConeRule {
        let (x, wx) = lobefit_core::sh::gauss_legendre(nt);
        let mut r = ConeRule {
            dirs: Vec::with_capacity(nt * np),
            weights: Vec::with_capacity(nt * np),
        };
        for (xi, wi) in x.iter().zip(&wx) {
            let th = 0.5 * alpha * (xi + 1.0);
            let w = 0.5 * alpha * wi * th.sin() * TAU / np as f64;
            for j in 0..np {
                let phi = TAU * (j as f64 + 0.25) / np as f64;
                r.dirs
                    .push(DVec3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos()));
                r.weights.push(w);
            }
        }
        r
    }
}

/// A random blocker configuration around a light cap of half-angle `alpha` about +z:
/// 1–3 caps of half-angle 0.2α…2.5α (below 1.45 rad) whose centres lie within the
/// sum of the two half-angles of the light's axis (so each overlaps the light);
/// configurations where one cap hides the whole light are redrawn.
pub fn random_config(rng: &mut Rng, alpha: f64) -> Vec<Cap> {
    loop {
        let n = 1 + (rng.next_u64() % 3) as usize;
        let caps: Vec<Cap> = (0..n)
            .map(|_| {
                let half = (alpha * (rng.range(0.2f64.ln(), 2.5f64.ln())).exp()).min(1.45);
                let off = rng.uniform().sqrt() * (alpha + half);
                let phi = rng.range(0.0, TAU);
                Cap {
                    axis: DVec3::new(off.sin() * phi.cos(), off.sin() * phi.sin(), off.cos()),
                    half_angle: half,
                }
            })
            .collect();
        if !caps
            .iter()
            .any(|c| c.axis.z.clamp(-1.0, 1.0).acos() + alpha <= c.half_angle)
        {
            return caps;
        }
    }
}

/// The configurations of a set (training or held-out): the same at every `dist` in
/// units of α (the draw is of ratios), so weights vary smoothly with `dist`.
pub fn configs(seed: u64, count: usize, alpha: f64) -> Vec<Vec<Cap>> {
    let mut rng = Rng::new(seed);
    (0..count).map(|_| random_config(&mut rng, alpha)).collect()
}

/// Light cap half-angle for `dist`.
pub fn alpha_of_dist(dist: f64) -> f64 {
    (0.5 / dist).atan()
}

/// Per-level sums of leaf lobes of one mask on a rule: `full[d][q]`, `part[d][q]`,
/// and the union indicator `u[q]`.
struct Features {
    full: Vec<Vec<f64>>,
    part: Vec<Vec<f64>>,
    u: Vec<f64>,
}

fn features(mask: &Mask, caps: &[Cap], rule: &ConeRule) -> Features {
    let nq = rule.dirs.len();
    let levels = MAX_DEPTH as usize + 1;
    let mut f = Features {
        full: vec![vec![0.0; nq]; levels],
        part: vec![vec![0.0; nq]; levels],
        u: vec![0.0; nq],
    };
    for c in &mask.cells {
        let e = exact_e_cap(c.half_angle);
        let cut = if e > 0.0 { (LOBE_CUT.ln() / e).exp() } else { 0.0 };
        let dst = if c.full {
            &mut f.full[c.depth as usize]
        } else {
            &mut f.part[c.depth as usize]
        };
        for (o, v) in dst.iter_mut().zip(&rule.dirs) {
            let t = c.axis.dot(*v);
            if t > cut {
                *o += (e * t.ln()).exp();
            }
        }
    }
    let cosines: Vec<(DVec3, f64)> = caps.iter().map(|c| (c.axis, c.half_angle.cos())).collect();
    for (o, v) in f.u.iter_mut().zip(&rule.dirs) {
        if cosines.iter().any(|&(a, cb)| a.dot(*v) >= cb) {
            *o = 1.0;
        }
    }
    f
}

/// The least-squares columns of maximal depth `depth` in `mode` at point q.
fn column(f: &Features, mode: MaskMode, depth: u32, level: u32, q: usize) -> f64 {
    let l = level as usize;
    let mut v = f.full[l][q];
    if mode == MaskMode::Conservative && level == depth {
        v += f.part[l][q];
    }
    v
}

/// Normal equations per (mode, depth): G (row-major), g, Σ w U².
#[derive(Clone)]
struct Normal {
    g: Vec<f64>,
    rhs: Vec<f64>,
    uu: f64,
}

/// Solution of the fit at one `dist` for every (set, mode, depth), in channel order,
/// and the fitted weights' relative L2 residual (aggressive, depth 5) on the training set.
pub struct Solution {
    /// Channel values.
    pub values: Vec<f64>,
    /// Relative L2 residual of the fitted weights, aggressive depth 5.
    pub residual: f64,
    /// Whether every system was solvable and every weight lies in range.
    pub ok: bool,
}

/// Least-squares weights at `dist` over the training set on the given rule.
pub fn solve(dist: f64, rule_of: impl Fn(f64) -> ConeRule) -> Solution {
    let alpha = alpha_of_dist(dist);
    let rule = rule_of(alpha);
    let light = Cap {
        axis: DVec3::Z,
        half_angle: alpha,
    };
    let cfgs = configs(TRAIN_SEED, TRAIN_CONFIGS, alpha);
    let systems: Vec<(MaskMode, u32)> = MaskMode::ALL
        .iter()
        .flat_map(|&m| (1..=MAX_DEPTH).map(move |d| (m, d)))
        .collect();
    let mut normals: Vec<Normal> = systems
        .iter()
        .map(|&(_, d)| {
            let n = d as usize;
            Normal {
                g: vec![0.0; n * n],
                rhs: vec![0.0; n],
                uu: 0.0,
            }
        })
        .collect();
    let mut ok = true;
    for caps in &cfgs {
        let mask = match build_mask(light, caps, MAX_DEPTH) {
            Ok(m) => m,
            Err(_) => {
                ok = false;
                continue;
            }
        };
        let f = features(&mask, caps, &rule);
        for (ne, &(mode, depth)) in normals.iter_mut().zip(&systems) {
            let n = depth as usize;
            let mut col = vec![0.0; n];
            for (q, &wq) in rule.weights.iter().enumerate() {
                for (l, c) in col.iter_mut().enumerate() {
                    *c = column(&f, mode, depth, l as u32 + 1, q);
                }
                let u = f.u[q];
                ne.uu += wq * u * u;
                for i in 0..n {
                    if col[i] == 0.0 {
                        continue;
                    }
                    ne.rhs[i] += wq * col[i] * u;
                    for j in 0..n {
                        ne.g[i * n + j] += wq * col[i] * col[j];
                    }
                }
            }
        }
    }
    let mut values = vec![0.0; channel_names().len()];
    let mut residual = f64::NAN;
    for (ne, &(mode, depth)) in normals.iter().zip(&systems) {
        let n = depth as usize;
        let fitted = ridge_solve(&ne.g, &ne.rhs, n);
        let paper = greedy(&ne.g, &ne.rhs, n);
        for (set, w) in [(WeightSet::Fitted, &fitted), (WeightSet::Paper, &paper)] {
            match w {
                Some(w) => {
                    for (l, &x) in w.iter().enumerate() {
                        ok &= x.is_finite() && (WEIGHT_RANGE.0..=WEIGHT_RANGE.1).contains(&x);
                        let name = channel_name(set, mode, depth, l as u32 + 1).expect("stored set");
                        let k = channel_names().iter().position(|c| *c == name).expect("channel");
                        values[k] = x;
                    }
                }
                None => ok = false,
            }
        }
        if mode == MaskMode::Aggressive && depth == MAX_DEPTH {
            if let Some(w) = &fitted {
                residual = (quad_form(&ne.g, w, n) - 2.0 * dot(&ne.rhs, w) + ne.uu).max(0.0).sqrt() / ne.uu.sqrt();
            }
        }
    }
    Solution {
        values,
        residual,
        ok: ok && residual.is_finite(),
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn quad_form(g: &[f64], w: &[f64], n: usize) -> f64 {
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            s += w[i] * g[i * n + j] * w[j];
        }
    }
    s
}

/// (G + λI) w = g + λ·1, λ = RIDGE·tr G/n (plus a floor for an empty system), by
/// [`lobefit_core::eigen::solve`] (G + λI is symmetric positive definite).
fn ridge_solve(g: &[f64], rhs: &[f64], n: usize) -> Option<Vec<f64>> {
    let tr: f64 = (0..n).map(|i| g[i * n + i]).sum();
    let lambda = RIDGE * tr / n as f64 + 1e-300;
    let mut a: Vec<f64> = g.to_vec();
    let mut b: Vec<f64> = rhs.to_vec();
    for i in 0..n {
        a[i * n + i] += lambda;
        b[i] += lambda;
    }
    eigen::solve(&mut a, &mut b, n, 1)?;
    Some(b)
}

/// The paper's procedure made automatic: w_d, coarse to fine, by least squares with
/// the coarser weights fixed and the finer ones 0; 1 for a depth holding no leaf.
fn greedy(g: &[f64], rhs: &[f64], n: usize) -> Option<Vec<f64>> {
    let tr: f64 = (0..n).map(|i| g[i * n + i]).sum();
    let mut w = vec![0.0; n];
    for d in 0..n {
        let gdd = g[d * n + d];
        w[d] = if gdd > 1e-12 * tr {
            (rhs[d] - (0..d).map(|k| g[d * n + k] * w[k]).sum::<f64>()) / gdd
        } else {
            1.0
        };
    }
    w.iter().all(|v| v.is_finite()).then_some(w)
}

/// Relative L2 visibility error sqrt(∫_C (V_lobes − V_exact)²/Ω_C) of each weight
/// vector in `weights` (indexed by leaf depth) for one configuration, on `rule`.
pub fn visibility_errors(
    caps: &[Cap],
    alpha: f64,
    depth: u32,
    mode: MaskMode,
    weights: &[&[f64]],
    rule: &ConeRule,
) -> Result<Vec<f64>, String> {
    let light = Cap {
        axis: DVec3::Z,
        half_angle: alpha,
    };
    let mask = build_mask(light, caps, depth).map_err(|e| e.to_string())?;
    let f = features(&mask, caps, rule);
    let omega: f64 = rule.weights.iter().sum();
    Ok(weights
        .iter()
        .map(|w| {
            let mut s = 0.0;
            for (q, &wq) in rule.weights.iter().enumerate() {
                let approx: f64 = (1..=depth)
                    .map(|l| w[l as usize - 1] * column(&f, mode, depth, l, q))
                    .sum();
                s += wq * (approx - f.u[q]).powi(2);
            }
            (s / omega).sqrt()
        })
        .collect())
}

/// Static output names (the stored channels).
fn output_names() -> &'static [&'static str] {
    static N: OnceLock<Vec<&'static str>> = OnceLock::new();
    N.get_or_init(|| {
        channel_names()
            .iter()
            .map(|s| &*Box::leak(s.clone().into_boxed_str()))
            .collect()
    })
}

struct WeightsLookup {
    rt: MaskWeights,
}

fn all_weights(rt: &MaskWeights, dist: f64) -> Result<Vec<f64>, LookupError> {
    let mut out = Vec::with_capacity(channel_names().len());
    let mut w = [0.0; MAX_DEPTH as usize];
    for set in [WeightSet::Fitted, WeightSet::Paper] {
        for mode in MaskMode::ALL {
            for d in 1..=MAX_DEPTH {
                rt.weights(set, mode, d, dist, &mut w)?;
                out.extend_from_slice(&w[..d as usize]);
            }
        }
    }
    Ok(out)
}

/// `eval mask-weights` serves the tabulated range only (the runtime holds the end
/// weights outside it, which is a renderer's convenience, not a table value).
fn dist_in_range(dist: f64) -> Result<f64, LookupError> {
    if !dist.is_finite() {
        return Err(LookupError::NotFinite {
            name: "dist".into(),
            value: dist,
        });
    }
    if !(DIST_MIN..=DIST_MAX).contains(&dist) {
        return Err(LookupError::OutOfDomain {
            name: "dist".into(),
            value: dist,
            lo: DIST_MIN,
            hi: DIST_MAX,
        });
    }
    Ok(dist)
}

impl Lookup for WeightsLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        dist_in_range(x[0])?;
        all_weights(&self.rt, x[0])
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        if let Err(e) = dist_in_range(x[0]) {
            return Some(Err(e));
        }
        let mut out = Vec::with_capacity(channel_names().len());
        let mut w = [0.0f32; MAX_DEPTH as usize];
        for set in [WeightSet::Fitted, WeightSet::Paper] {
            for mode in MaskMode::ALL {
                for d in 1..=MAX_DEPTH {
                    if let Err(e) = self.rt.weights_f32(set, mode, d, x[0] as f32, &mut w) {
                        return Some(Err(e));
                    }
                    out.extend(w[..d as usize].iter().map(|&v| f64::from(v)));
                }
            }
        }
        Some(Ok(out))
    }
}

/// Marker coordinate of the checker's grid points (off-grid points carry a number in
/// [0, 1) that seeds one held-out configuration).
const AT_NODE: f64 = -1.0;
/// The checker's rule for the visible fraction at random points (cheap: one
/// configuration per point).
pub const POINT_RULE: (usize, usize) = (24, 48);
/// Largest |visible fraction through the lobes − exact| of the light's cone at random
/// points (fitted weights, aggressive, depth 5); measured max 0.159 over 10 000 points (docs/meunier.md).
pub const VISIBLE_MAX_ABS: f64 = 0.3;
/// Median of the same.
pub const VISIBLE_MEDIAN_ABS: f64 = 0.05;

/// Visible fraction of the light's cone, through the mask with weights `w` (fitted,
/// aggressive, depth 5) and exactly, for one configuration, on `rule`.
pub fn visible_fractions(caps: &[Cap], alpha: f64, w: &[f64], rule: &ConeRule) -> Result<(f64, f64), String> {
    let light = Cap {
        axis: DVec3::Z,
        half_angle: alpha,
    };
    let mask = build_mask(light, caps, MAX_DEPTH).map_err(|e| e.to_string())?;
    let f = features(&mask, caps, rule);
    let omega: f64 = rule.weights.iter().sum();
    let (mut lobes, mut exact) = (0.0, 0.0);
    for (q, &wq) in rule.weights.iter().enumerate() {
        let shadow: f64 = (1..=MAX_DEPTH)
            .map(|l| w[l as usize - 1] * column(&f, MaskMode::Aggressive, MAX_DEPTH, l, q))
            .sum();
        lobes += wq * (1.0 - shadow);
        exact += wq * (1.0 - f.u[q]);
    }
    Ok((lobes / omega, exact / omega))
}

/// Names the checker compares: every stored weight (at the nodes) and the visible
/// fraction (at random points).
fn checked_names() -> &'static [&'static str] {
    static N: OnceLock<Vec<&'static str>> = OnceLock::new();
    N.get_or_init(|| {
        let mut v = output_names().to_vec();
        v.push("visible_fraction");
        v
    })
}

/// Held-out systems reported: (mode, depth).
pub const HELDOUT_SYSTEMS: [(MaskMode, u32); 4] = [
    (MaskMode::Aggressive, 5),
    (MaskMode::Conservative, 5),
    (MaskMode::Aggressive, 3),
    (MaskMode::Aggressive, 2),
];

fn system_tag(mode: MaskMode, depth: u32) -> String {
    format!("{}_d{depth}", &mode.name()[..3])
}

impl View for MaskWeightsFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["dist"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        output_names()
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::MASK_WEIGHTS
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(WeightsLookup {
            rt: MaskWeights::from_table(table)?,
        }))
    }
    /// The same least squares solved with the checker's Gauss–Legendre rule.
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let dist = x[0];
        if !(DIST_MIN..=DIST_MAX).contains(&dist) {
            return Err(format!("dist = {dist} is outside [{DIST_MIN}, {DIST_MAX}]"));
        }
        // A pure function of dist, costly (a least squares over the training set).
        static MEMO: lobefit_core::memo::Memo<1, Vec<f64>> = lobefit_core::memo::Memo::new();
        MEMO.get([dist], || {
            let s = solve(dist, |a| ConeRule::gauss(a, REF_RULE));
            if !s.ok {
                return Err(format!("reference least squares failed at dist = {dist}"));
            }
            Ok(s.values)
        })
    }
}

impl Checked for MaskWeightsFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        let mut t: Vec<Threshold> = channel_names()
            .iter()
            .map(|n| Threshold {
                output: n.clone(),
                metric: "grid.max_abs".into(),
                limit: NODE_ABS,
            })
            .collect();
        t.push(Threshold {
            output: "visible_fraction".into(),
            metric: "offgrid.max_abs".into(),
            limit: VISIBLE_MAX_ABS,
        });
        t.push(Threshold {
            output: "visible_fraction".into(),
            metric: "offgrid.median_abs".into(),
            limit: VISIBLE_MEDIAN_ABS,
        });
        let tag = system_tag(MaskMode::Aggressive, MAX_DEPTH);
        t.push(Threshold {
            output: format!("heldout_l2_fitted_{tag}"),
            metric: "median".into(),
            limit: HELDOUT_MEDIAN,
        });
        for s in HELDOUT_SYSTEMS {
            let tag = system_tag(s.0, s.1);
            // The fitted weights must do at least as well as either baseline, on average.
            for base in ["paper", "ones"] {
                t.push(Threshold {
                    output: format!("heldout_fitted_minus_{base}_{tag}"),
                    metric: "mean".into(),
                    limit: 0.0,
                });
            }
        }
        t
    }
    fn node_inputs(&self, node: &[f64]) -> Vec<Vec<f64>> {
        vec![vec![node[0], AT_NODE]]
    }
    fn checked(&self) -> &'static [&'static str] {
        checked_names()
    }
    /// At a node: every weight against the reference least squares. At a random
    /// point (dist, u): the visible fraction of the light's cone for the held-out
    /// configuration seeded by u, through the looked-up weights and exactly.
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let mut got = runtime.lookup(&x[..1]).map_err(|e| format!("lookup at {x:?}: {e}"))?;
        let n = got.len();
        if x.get(1) == Some(&AT_NODE) {
            let mut want = self.reference(&x[..1])?;
            got.push(f64::NAN);
            want.push(f64::NAN);
            return Ok(Some((got, want)));
        }
        let alpha = alpha_of_dist(x[0]);
        let mut rng = Rng::new(HELDOUT_SEED ^ x.get(1).copied().unwrap_or(0.0).to_bits());
        let caps = random_config(&mut rng, alpha);
        let k = channel_names()
            .iter()
            .position(|c| Some(c.clone()) == channel_name(WeightSet::Fitted, MaskMode::Aggressive, MAX_DEPTH, 1))
            .expect("channel");
        let (lobes, exact) = visible_fractions(
            &caps,
            alpha,
            &got[k..k + MAX_DEPTH as usize],
            &ConeRule::gauss(alpha, POINT_RULE),
        )?;
        let mut g = vec![f64::NAN; n + 1];
        let mut w = vec![f64::NAN; n + 1];
        g[n] = lobes;
        w[n] = exact;
        Ok(Some((g, w)))
    }
    fn extra_checks(&self, table: &Table, count: usize, seed: u64) -> Vec<(String, Result<Extra, String>)> {
        let weights = match MaskWeights::from_table(table.clone()) {
            Ok(w) => w,
            Err(e) => return vec![("heldout".into(), Err(e.to_string()))],
        };
        let n = (4 * count).clamp(40, 400);
        let mut rng = Rng::new(seed ^ HELDOUT_SEED);
        let cases: Vec<(f64, Vec<Cap>)> = (0..n)
            .map(|_| {
                let dist = (rng.range(DIST_MIN.ln(), DIST_MAX.ln())).exp();
                let alpha = alpha_of_dist(dist);
                (dist, random_config(&mut rng, alpha))
            })
            .collect();
        let mut out = Vec::new();
        for (mode, depth) in HELDOUT_SYSTEMS {
            let res: Result<Vec<[f64; 3]>, String> = cases
                .par_iter()
                .map(|(dist, caps)| {
                    let alpha = alpha_of_dist(*dist);
                    let mut wf = [0.0; MAX_DEPTH as usize];
                    let mut wp = [0.0; MAX_DEPTH as usize];
                    let ones = [1.0; MAX_DEPTH as usize];
                    weights
                        .weights(WeightSet::Fitted, mode, depth, *dist, &mut wf)
                        .map_err(|e| e.to_string())?;
                    weights
                        .weights(WeightSet::Paper, mode, depth, *dist, &mut wp)
                        .map_err(|e| e.to_string())?;
                    let rule = ConeRule::gauss(alpha, REF_RULE);
                    let e = visibility_errors(caps, alpha, depth, mode, &[&wf, &wp, &ones], &rule)?;
                    Ok([e[0], e[1], e[2]])
                })
                .collect();
            let tag = system_tag(mode, depth);
            match res {
                Ok(v) => {
                    for (k, name) in ["fitted", "paper", "ones"].iter().enumerate() {
                        out.push((
                            format!("heldout_l2_{name}_{tag}"),
                            Ok(Extra::Values(v.iter().map(|e| e[k]).collect())),
                        ));
                    }
                    for (k, base) in [(1, "paper"), (2, "ones")] {
                        out.push((
                            format!("heldout_fitted_minus_{base}_{tag}"),
                            Ok(Extra::Values(v.iter().map(|e| e[0] - e[k]).collect())),
                        ));
                    }
                }
                Err(e) => out.push((format!("heldout_{tag}"), Err(e))),
            }
        }
        out
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        vec![(rng.range(DIST_MIN.ln(), DIST_MAX.ln())).exp(), rng.uniform()]
    }
}

impl Fit for MaskWeightsFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        "Visibility-mask leaf-lobe weights w_d(dist) of Meunier et al. 2009 eq. 39, V = c_unit − Σ w_{d_i} c_i, \
         per maximal quad-tree depth D = 1..5 and mode (aggressive | conservative), level d = 1..D; `fit_*`: least \
         squares against the exact cap-union visibility over the light's cone; `paper_*`: the paper's manual \
         procedure made automatic. dist = 1/(2 tan α) on [0.25, 10], nodes uniform in ln dist, linear."
            .into()
    }
    fn axes(&self) -> Vec<Axis> {
        vec![rt::axis(DIST_NODES)]
    }
    fn channels(&self) -> Vec<Channel> {
        channel_names()
            .iter()
            .map(|n| Channel {
                name: n.clone(),
                unit: "1".into(),
                encoding: Encoding::Linear,
                description: "weight of the leaf lobes of one depth (eq. 39)".into(),
            })
            .collect()
    }
    fn method(&self) -> String {
        format!(
            "linear least squares (ridge {RIDGE:e}·tr/n towards 1) of the weighted leaf-lobe sum against the \
             exact cap union, L2 over the light's cone (midpoint rule {}×{}), {TRAIN_CONFIGS} seeded \
             configurations; paper baseline: the same, one depth at a time, coarse to fine",
            FIT_RULE.0, FIT_RULE.1
        )
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("train_configs".into(), TRAIN_CONFIGS.to_string()),
            ("train_seed".into(), format!("{TRAIN_SEED:#x}")),
            ("rule".into(), format!("{}x{}", FIT_RULE.0, FIT_RULE.1)),
            ("ridge".into(), format!("{RIDGE:e}")),
            ("lobe_cut".into(), format!("{LOBE_CUT:e}")),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "relative L2 visibility error of the fitted weights (aggressive, depth 5) on the training set"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let s = solve(node[0], |a| ConeRule::midpoint(a, FIT_RULE));
        Fitted {
            values: s.values,
            residual: s.residual,
            iterations: TRAIN_CONFIGS as u32,
            converged: s.ok,
        }
    }
}

/// mask-weights in the list of families (`crate::entries`); the pipeline that
/// reads it is `lobefit_pipelines::meunier`.
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| vec![Box::new(MaskWeightsFamily)],
    eval: None,
    eval_names: &[],
    eval_flags: &[],
    gpu: &[gpu::GPU],
    closed_form: None,
    plot: None,
    eval_help: "\
mask-weights
  in   `dist`     the visibility mask's 1/(2 tan α) for a light of half-angle α,
                  [0.25, 10]
  out  weights w_l (level l = 1..D) of eq. 39 for masks of maximal depth D,
       fitted (`fit_`) or by the paper's procedure (`paper_`), aggressive (`agg`)
       or conservative (`con`):
       `fit_agg_d1_w1` `fit_agg_d2_w1` `fit_agg_d2_w2` `fit_agg_d3_w1` `fit_agg_d3_w2`
       `fit_agg_d3_w3` `fit_agg_d4_w1` `fit_agg_d4_w2` `fit_agg_d4_w3` `fit_agg_d4_w4`
       `fit_agg_d5_w1` `fit_agg_d5_w2` `fit_agg_d5_w3` `fit_agg_d5_w4` `fit_agg_d5_w5`
       `fit_con_d1_w1` `fit_con_d2_w1` `fit_con_d2_w2` `fit_con_d3_w1` `fit_con_d3_w2`
       `fit_con_d3_w3` `fit_con_d4_w1` `fit_con_d4_w2` `fit_con_d4_w3` `fit_con_d4_w4`
       `fit_con_d5_w1` `fit_con_d5_w2` `fit_con_d5_w3` `fit_con_d5_w4` `fit_con_d5_w5`
       `paper_agg_d1_w1` `paper_agg_d2_w1` `paper_agg_d2_w2` `paper_agg_d3_w1` `paper_agg_d3_w2`
       `paper_agg_d3_w3` `paper_agg_d4_w1` `paper_agg_d4_w2` `paper_agg_d4_w3` `paper_agg_d4_w4`
       `paper_agg_d5_w1` `paper_agg_d5_w2` `paper_agg_d5_w3` `paper_agg_d5_w4` `paper_agg_d5_w5`
       `paper_con_d1_w1` `paper_con_d2_w1` `paper_con_d2_w2` `paper_con_d3_w1` `paper_con_d3_w2`
       `paper_con_d3_w3` `paper_con_d4_w1` `paper_con_d4_w2` `paper_con_d4_w3` `paper_con_d4_w4`
       `paper_con_d5_w1` `paper_con_d5_w2` `paper_con_d5_w3` `paper_con_d5_w4` `paper_con_d5_w5`
",
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_e_cap_is_stationary() {
        for a in [1e-3, 0.01, 0.3, 1.0, 1.5] {
            let e = exact_e_cap(a);
            assert!(
                objective_slope(a, e).abs() < 1e-9 * objective_slope(a, 0.5 * e).abs(),
                "{a}"
            );
        }
        assert!((exact_e_cap(0.01) * 1e-4 - 1.9226).abs() < 2e-3);
    }
}
