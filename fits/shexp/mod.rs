//! SH exponentiation tables (Ren et al. 2006, thesis §3.7): Ren's log-ZH f of
//! spherical-cap blockers, ‖f̂‖ and the OL coefficients a, b, vs θ_b ∈ [0, π/2], for
//! orders 3..8 in one file (`shexp`), and the `eval shexp` views (`--order`, `--log`).
//!
//! Fit (per node, every order): g = the closed-form cap visibility ZH; Ren's log
//! through the Gaunt tensor's m-blocks of M_{g−1} and the q-form
//! ([`crate::shexp::exp_log::ren_log_zonal`]). Residual: distance to the independent
//! reference below (a node is written only when they agree).
//!
//! Reference (checker): product-matrix blocks by Gauss–Legendre quadrature of
//! h(θ) y_l^m y_l'^m (not the Gaunt tensor) and the log applied directly to the
//! eigenvalues, clamped ones as the q-form has them
//! ([`crate::shexp::exp_log::ren_log_zonal_reference`]); a, b and ‖f̂‖ from
//! their definitions. f is compared in units of ‖f‖ (its components cross zero as
//! θ_b grows, where a per-component relative error says nothing).

pub mod exp_log;
pub mod gpu;
pub mod study;

use std::f64::consts::PI;

use lobefit_tables::format::Threshold;
use lobefit_tables::log_zh::{EPS_MAX, EPS_MIN};
use lobefit_tables::shexp::{self as rt, ab_of_pair, cap_visibility_zh, one_minus_cos, ShExp, ORDER_MAX, ORDER_MIN};
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};

use crate::shexp::exp_log::{ren_log_zonal, ren_log_zonal_reference};
use lobefit_core::family::{Checked, EvalFlag, Extra, Fit, Fitted, Lookup, View};
use lobefit_core::rng::Rng;
use lobefit_core::sh::Gaunt;
use lobefit_tables::error::short;

/// Largest |fit − reference| / max(‖f‖, 1) for a node to be written: both are f64
/// computations of the same matrix function (measured ≤ 1e-13).
const MAX_RESIDUAL: f64 = 1e-11;
/// Stored entries vs the reference: f relative to ‖f‖; ‖f̂‖, a, b
/// relative.
pub const GRID_REL: f64 = 1e-9;
/// Off-grid θ_b through the runtime's interpolation, same units.
pub const OFFGRID_REL: f64 = 1e-4;
/// Default SH order of `lobefit eval` (docs/math.md §1).
pub const DEFAULT_ORDER: usize = 4;

/// Checked quantities of the whole table (every order).
const ALL: [&str; 51] = [
    "n3_f0", "n3_f1", "n3_f2", "n3_norm", "n3_a", "n3_b", "n4_f0", "n4_f1", "n4_f2", "n4_f3", "n4_norm", "n4_a",
    "n4_b", "n5_f0", "n5_f1", "n5_f2", "n5_f3", "n5_f4", "n5_norm", "n5_a", "n5_b", "n6_f0", "n6_f1", "n6_f2", "n6_f3",
    "n6_f4", "n6_f5", "n6_norm", "n6_a", "n6_b", "n7_f0", "n7_f1", "n7_f2", "n7_f3", "n7_f4", "n7_f5", "n7_f6",
    "n7_norm", "n7_a", "n7_b", "n8_f0", "n8_f1", "n8_f2", "n8_f3", "n8_f4", "n8_f5", "n8_f6", "n8_f7", "n8_norm",
    "n8_a", "n8_b",
];
/// Outputs of the eval view of order n: f0..f(n−1), norm, a, b.
const EVAL_OUT: [[&str; 11]; 9] = {
    const F: [&str; 8] = ["f0", "f1", "f2", "f3", "f4", "f5", "f6", "f7"];
    let mut t = [[""; 11]; 9];
    let mut n = 1;
    while n <= 8 {
        let mut l = 0;
        while l < n {
            t[n][l] = F[l];
            l += 1;
        }
        t[n][n] = "norm";
        t[n][n + 1] = "a";
        t[n][n + 2] = "b";
        n += 1;
    }
    t
};

/// Which SH log the eval view uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    /// Ren's eigenvalue-clamped matrix log (the table).
    Ren,
    /// Naive ε-clamped projection log ε·cap (log-zh closed form).
    Naive,
}

/// The shexp family. `view: None` is the registry's instance (the whole table,
/// every order); `Some((order, log))` is the `eval` view.
#[derive(Debug, Clone, Copy, Default)]
pub struct ShExpFamily {
    /// Eval view: order 3..=8 and log kind.
    pub view: Option<(usize, LogKind)>,
}

impl ShExpFamily {
    /// The eval view for `--order` (default 4) and `--log` (default ren).
    pub fn from_flags(order: Option<usize>, log: Option<&str>) -> Result<Self, String> {
        let log = match log.unwrap_or("ren") {
            "ren" => LogKind::Ren,
            "naive" => LogKind::Naive,
            other => return Err(format!("shexp: unknown --log {other} (ren|naive)")),
        };
        let order = order.unwrap_or(DEFAULT_ORDER);
        if !(ORDER_MIN..=ORDER_MAX).contains(&order) {
            return Err(format!("shexp: --order {order} is outside {ORDER_MIN}..={ORDER_MAX}"));
        }
        Ok(ShExpFamily {
            view: Some((order, log)),
        })
    }
}

/// (f, ‖f̂‖, a, b) of order n by the reference at θ_b.
pub fn reference_point(theta_b: f64, order: usize) -> Result<(Vec<f64>, f64, f64, f64), String> {
    static MEMO: lobefit_core::memo::Memo<2, (Vec<f64>, f64, f64, f64)> = lobefit_core::memo::Memo::new();
    MEMO.get([theta_b, order as f64], || reference_point_computed(theta_b, order))
}

/// [`reference_point`], computed.
fn reference_point_computed(theta_b: f64, order: usize) -> Result<(Vec<f64>, f64, f64, f64), String> {
    if !(0.0..=rt::THETA_MAX).contains(&theta_b) {
        return Err(format!(
            "theta_b = {theta_b} is outside [0, π/2]",
            theta_b = short(theta_b)
        ));
    }
    let g = cap_visibility_zh(theta_b, order).map_err(|e| e.to_string())?[..order].to_vec();
    let f = ren_log_zonal_reference(&g)?.f;
    let (a, b, norm) = ab_of_pair(&g, &f).map_err(|e| e.to_string())?;
    Ok((f, norm, a, b))
}

/// Naive log (ε-clamped projection) of the cap and its (‖f̂‖, a, b), closed form.
fn naive_point(theta_b: f64, eps: f64, order: usize) -> Result<Vec<f64>, LookupError> {
    let mut f = [0.0; 8];
    lobefit_tables::log_zh::blocker(eps, theta_b, order, &mut f)?;
    if theta_b > rt::THETA_MAX {
        return Err(LookupError::OutOfDomain {
            name: "theta_b".into(),
            value: theta_b,
            lo: 0.0,
            hi: rt::THETA_MAX,
        });
    }
    let g = cap_visibility_zh(theta_b, order)?;
    let (a, b, norm) = ab_of_pair(&g[..order], &f[..order])?;
    let mut v = f[..order].to_vec();
    v.extend([norm, a, b]);
    Ok(v)
}

struct ShExpLookup {
    rt: ShExp,
    view: Option<(usize, LogKind)>,
}

fn runtime_point(rt: &ShExp, theta_b: f64, n: usize) -> Result<Vec<f64>, LookupError> {
    let mut f = [0.0; 8];
    rt.log_zh(theta_b, n, &mut f)?;
    let (norm, a, b) = rt.norm_ab(theta_b, n)?;
    let mut v = f[..n].to_vec();
    v.extend([norm, a, b]);
    Ok(v)
}

impl Lookup for ShExpLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        match self.view {
            None => {
                let mut v = Vec::with_capacity(ALL.len());
                for n in ORDER_MIN..=ORDER_MAX {
                    v.extend(runtime_point(&self.rt, x[0], n)?);
                }
                Ok(v)
            }
            Some((n, LogKind::Ren)) => runtime_point(&self.rt, x[0], n),
            Some((n, LogKind::Naive)) => naive_point(x[0], x[1], n),
        }
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        let theta_b = x[0] as f32;
        let point = |n: usize| -> Result<Vec<f64>, LookupError> {
            let mut f = [0.0f32; 8];
            self.rt.log_zh_f32(theta_b, n, &mut f)?;
            let (norm, a, b) = self.rt.norm_ab_f32(theta_b, n)?;
            Ok(f[..n].iter().chain(&[norm, a, b]).map(|&v| v.into()).collect())
        };
        match self.view {
            None => Some(
                (ORDER_MIN..=ORDER_MAX)
                    .map(point)
                    .collect::<Result<Vec<_>, _>>()
                    .map(|v| v.concat()),
            ),
            Some((n, LogKind::Ren)) => Some(point(n)),
            Some((_, LogKind::Naive)) => None,
        }
    }
}

impl View for ShExpFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        match self.view {
            Some((_, LogKind::Naive)) => &["theta_b", "eps"],
            _ => &["theta_b"],
        }
    }
    fn outputs(&self) -> &'static [&'static str] {
        match self.view {
            None => &ALL,
            Some((n, _)) => &EVAL_OUT[n][..n + 3],
        }
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::SHEXP
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(ShExpLookup {
            rt: ShExp::from_table(table)?,
            view: self.view,
        }))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        match self.view {
            None => {
                let mut v = Vec::with_capacity(ALL.len());
                for n in ORDER_MIN..=ORDER_MAX {
                    let (f, norm, a, b) = reference_point(x[0], n)?;
                    v.extend(f);
                    v.extend([norm, a, b]);
                }
                Ok(v)
            }
            Some((n, LogKind::Ren)) => {
                let (mut f, norm, a, b) = reference_point(x[0], n)?;
                f.extend([norm, a, b]);
                Ok(f)
            }
            Some((n, LogKind::Naive)) => naive_reference(x[0], x[1], n),
        }
    }
}

impl Checked for ShExpFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        ALL.iter()
            .flat_map(|o| {
                // f is compared in units of ‖f‖ (see `check_point`): its abs metric is
                // the relative error of the vector.
                let kind = if o.contains("_f") { "abs" } else { "rel" };
                [("grid", GRID_REL), ("offgrid", OFFGRID_REL)].map(|(m, l)| Threshold {
                    output: o.to_string(),
                    metric: format!("{m}.max_{kind}"),
                    limit: l,
                })
            })
            .chain((self.view.is_none()).then(|| Threshold {
                output: "intervals".into(),
                metric: "offgrid.max_abs".into(),
                limit: OFFGRID_REL,
            }))
            .collect()
    }
    /// Grid nodes are (order, θ_b); the whole-table view takes θ_b only and returns
    /// every order, so a node maps to its θ_b.
    fn node_inputs(&self, node: &[f64]) -> Vec<Vec<f64>> {
        vec![vec![node[1]]]
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        // Half uniform, half log-uniform down to 1e-4 rad (small blockers).
        let t = if rng.uniform() < 0.5 {
            rng.range(0.0, rt::THETA_MAX)
        } else {
            rng.range((1e-4f64).ln(), rt::THETA_MAX.ln()).exp()
        };
        match self.view {
            Some((_, LogKind::Naive)) => vec![t, rng.range(EPS_MIN, EPS_MAX)],
            _ => vec![t],
        }
    }
    /// Measured distributions (no threshold), whole-table view only, per order:
    /// HYB (default threshold) vs Taylor exp* on `count` random 2–400-blocker scenes
    /// accumulated from this table, and Ren's round trip ‖exp*(log g) − g‖/‖g‖ on
    /// `count` caps.
    fn extra_checks(&self, table: &Table, count: usize, seed: u64) -> Vec<(String, Result<Extra, String>)> {
        if self.view.is_some() {
            return Vec::new();
        }
        let rt = match ShExp::from_table(table.clone()) {
            Ok(t) => t,
            Err(e) => return vec![("hyb".into(), Err(e.to_string()))],
        };
        let scenes = crate::shexp::study::scene_geometry(count, seed);
        let mut out = vec![("intervals".to_string(), self.interval_check(table))];
        for n in ORDER_MIN..=ORDER_MAX {
            let gaunt = Gaunt::cached(n).expect("order in 3..=8");
            let hyb = scenes
                .iter()
                .map(|s| {
                    let f = crate::shexp::study::scene_log(&rt, s, n)?;
                    let mut h = vec![0.0; n * n];
                    rt.hyb(&f, &mut h).map_err(|e| e.to_string())?;
                    Ok(crate::shexp::study::rel_l2(
                        &h,
                        &lobefit_core::sh::exp_star(gaunt, &f).value,
                    ))
                })
                .collect::<Result<Vec<f64>, String>>();
            out.push((format!("n{n}_hyb_vs_taylor_scenes"), hyb.map(Extra::Values)));
            let trip = (1..=count)
                .map(|i| {
                    let theta = rt::THETA_MAX * i as f64 / count as f64;
                    let g = cap_visibility_zh(theta, n).map_err(|e| e.to_string())?[..n].to_vec();
                    let f = ren_log_zonal(gaunt, &g)?.f;
                    let back = lobefit_core::sh::exp_star(gaunt, &crate::shexp::exp_log::zh_to_sh_z(&f)).value;
                    Ok(crate::shexp::study::rel_l2(
                        &back,
                        &crate::shexp::exp_log::zh_to_sh_z(&g),
                    ))
                })
                .collect::<Result<Vec<f64>, String>>();
            out.push((format!("n{n}_ren_round_trip_caps"), trip.map(Extra::Values)));
        }
        out
    }
    /// f in units of the reference's ‖f‖ (per order); ‖f̂‖, a, b as they are.
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let mut got = runtime.lookup(x).map_err(|e| format!("lookup at {x:?}: {e}"))?;
        let mut want = self.reference(x).map_err(|e| format!("reference at {x:?}: {e}"))?;
        let orders: Vec<usize> = match self.view {
            None => (ORDER_MIN..=ORDER_MAX).collect(),
            Some((n, _)) => vec![n],
        };
        let mut off = 0;
        for n in orders {
            let norm = want[off..off + n].iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm > 0.0 {
                for k in off..off + n {
                    got[k] /= norm;
                    want[k] /= norm;
                }
            }
            off += n + 3;
        }
        Ok(Some((got, want)))
    }
}

impl Fit for ShExpFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        format!(
            "SH exponentiation tables (Ren et al. 2006; docs/math.md, shexp) for a spherical-cap blocker of angular \
             radius theta_b about +z, orders {ORDER_MIN}..{ORDER_MAX}: Ren's log-ZH f (log of the SH product \
             matrix in the form f = R q(D) R^T (g - 1), q(x) = ln(x)/(x - 1), eigenvalues in q clamped below at \
             {} x the largest), |f_hat| (f without DC) and \
             the OL coefficients a, b of exp*(f_hat) ~ a 1 + b f_hat. f and |f_hat| are stored divided by \
             1 - cos(theta_b). Each value is an f32 hi/lo pair. HYB looks a, b up vs |f_hat| on the \
             monotone branch of |f_hat|(theta_b) (up to its first maximum).",
            crate::shexp::exp_log::REN_CLAMP
        )
    }
    fn axes(&self) -> Vec<Axis> {
        rt::axes()
    }
    fn channels(&self) -> Vec<Channel> {
        rt::channel_names()
            .into_iter()
            .map(|name| Channel {
                description: if name.ends_with("_hi") {
                    "f32 rounding of the value (f_l and norm divided by 1 - cos theta_b)".into()
                } else {
                    "value - hi, rounded to f32".into()
                },
                name,
                unit: "1".into(),
                encoding: Encoding::Linear,
            })
            .collect()
    }
    fn method(&self) -> String {
        "Ren's log via Gaunt m-blocks of M_(g-1), Jacobi eigen-decomposition, q-form; \
         cross-checked by quadrature-built blocks"
            .into()
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("ren_clamp".into(), crate::shexp::exp_log::REN_CLAMP.to_string()),
            (
                "ren_clamp_form".into(),
                "inside q: q(max(lambda, clamp)) (g - 1)".into(),
            ),
            ("max_residual".into(), format!("{MAX_RESIDUAL:e}")),
            ("jacobi_tol".into(), format!("{:e}", lobefit_core::eigen::JACOBI_TOL)),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "max over orders and l of |f (Gaunt blocks, q-form) - f (quadrature blocks, direct log)| / max(|f|, 1)"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let (n, theta) = (node[0].round() as usize, node[1]);
        let s = one_minus_cos(theta);
        let mut values = Vec::with_capacity(2 * rt::PAIRS);
        let mut push = |v: f64| {
            let hi = v as f32;
            values.push(hi as f64);
            values.push((v - hi as f64) as f32 as f64);
        };
        let mut stored = [0.0; rt::PAIRS];
        stored[11] = -1.0;
        let (mut residual, mut ok) = (0.0f64, true);
        if theta == 0.0 {
            // Limits: f → g − 1 = −cap, cap_l/(1 − cosθ) → √(π(2l+1)); a, b → 1.
            for (l, v) in stored.iter_mut().enumerate().take(n) {
                *v = -(PI * (2 * l + 1) as f64).sqrt();
            }
            stored[8] = (PI * (n * n - 1) as f64).sqrt();
            stored[9] = 1.0;
            stored[10] = 1.0;
        } else {
            let gaunt = Gaunt::cached(n).expect("order in 3..=8");
            let g = cap_visibility_zh(theta, n).expect("θ_b on the axis, order 3..=8")[..n].to_vec();
            match (ren_log_zonal(gaunt, &g), ren_log_zonal_reference(&g)) {
                (Ok(fit), Ok(reference)) => {
                    let scale = fit.f.iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0);
                    for (a, b) in fit.f.iter().zip(&reference.f) {
                        residual = residual.max((a - b).abs() / scale);
                    }
                    // A non-finite log marks the node unconverged (never written).
                    let (a, b, norm) = ab_of_pair(&g, &fit.f).unwrap_or_else(|_| {
                        ok = false;
                        (f64::NAN, f64::NAN, f64::NAN)
                    });
                    for (v, f) in stored.iter_mut().zip(&fit.f) {
                        *v = f / s;
                    }
                    stored[8] = norm / s;
                    stored[9] = a;
                    stored[10] = b;
                    match kink(gaunt, n, theta) {
                        Ok(Some(k)) => stored[11] = k,
                        Ok(None) => {}
                        Err(_) => ok = false,
                    }
                }
                _ => ok = false,
            }
        }
        stored.iter().for_each(|&v| push(v));
        Fitted {
            values,
            residual,
            iterations: 1,
            converged: ok && residual <= MAX_RESIDUAL,
        }
    }
}

impl ShExpFamily {
    /// Every node interval, checked between its nodes: the lookup against the
    /// reference at each interval's midpoint and, where the table marks a clamp kink,
    /// just either side of the stored kink (1e-3 of an interval) and at every eighth
    /// of the interval. A kink flag or
    /// position that is wrong sends queries there to a stencil across the true kink,
    /// which the nodes alone never show. Reported as 1 + e against 1, e the largest
    /// error over all orders' quantities in their units (f in units of ‖f‖, the
    /// others relative).
    fn interval_check(&self, table: &Table) -> Result<Extra, String> {
        use rayon::prelude::*;
        let nodes = rt::THETA_NODES as usize;
        let nc = table.meta().channels.len();
        let h = rt::node_theta(1);
        let mut pts: Vec<f64> = (0..nodes - 1).map(|i| rt::node_theta(i) + 0.5 * h).collect();
        for row in 0..(ORDER_MAX - ORDER_MIN + 1) * nodes {
            let (hi, lo) = (table.values()[row * nc + nc - 2], table.values()[row * nc + nc - 1]);
            let kink = f64::from(hi) + f64::from(lo);
            if kink >= 0.0 {
                pts.extend([kink - 1e-3 * h, kink + 1e-3 * h].map(|t| t.clamp(0.0, rt::THETA_MAX)));
                // And every eighth of the interval: a kink stored h/8 or more from
                // the true one leaves one of these on the wrong stencil.
                let t0 = rt::node_theta(row % nodes);
                pts.extend((1..8).map(|k| (t0 + h * k as f64 / 8.0).min(rt::THETA_MAX)));
            }
        }
        let runtime = self.runtime(table.clone()).map_err(|e| e.to_string())?;
        let names = self.checked();
        let pairs: Result<Vec<(f64, f64)>, String> = pts
            .par_iter()
            .map(|&t| {
                let (got, want) = self.check_point(runtime.as_ref(), &[t])?.ok_or("no promise")?;
                let e = names
                    .iter()
                    .zip(got.iter().zip(&want))
                    .map(|(n, (g, w))| {
                        let d = (g - w).abs();
                        if n.contains("_f") {
                            d
                        } else {
                            d / w.abs().max(f64::MIN_POSITIVE)
                        }
                    })
                    .fold(0.0, f64::max);
                Ok((1.0 + e, 1.0))
            })
            .collect();
        pairs.map(Extra::Pairs)
    }
}

/// Bisection steps locating a clamp switch inside a node interval (h ≈ 7.7e-4 rad;
/// 60 halvings reach rounding).
const KINK_BISECTIONS: usize = 60;

/// The clamp state of Ren's log at θ_b: (clamped eigenvalues of block 0, block of
/// λ_max while any is clamped).
fn clamp_state(gaunt: &Gaunt, n: usize, theta: f64) -> Result<(usize, usize), String> {
    let g = cap_visibility_zh(theta, n).map_err(|e| e.to_string())?[..n].to_vec();
    let r = ren_log_zonal(gaunt, &g)?;
    Ok((r.clamped, if r.clamped > 0 { r.max_block } else { usize::MAX }))
}

/// Where in [θ_i, θ_{i+1}) the clamp state changes, if it does (θ_i = `theta`).
fn kink(gaunt: &Gaunt, n: usize, theta: f64) -> Result<Option<f64>, String> {
    let i = (theta / rt::THETA_MAX * (rt::THETA_NODES - 1) as f64).round() as usize;
    if i + 1 >= rt::THETA_NODES as usize {
        return Ok(None);
    }
    let (mut lo, mut hi) = (rt::node_theta(i), rt::node_theta(i + 1));
    let s_lo = clamp_state(gaunt, n, lo)?;
    if s_lo == clamp_state(gaunt, n, hi)? {
        return Ok(None);
    }
    for _ in 0..KINK_BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if clamp_state(gaunt, n, mid)? == s_lo {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(Some(hi))
}

/// Naive log's reference: the log projection of the blocker and g by the checker's
/// adaptive Gauss–Kronrod.
fn naive_reference(theta_b: f64, eps: f64, order: usize) -> Result<Vec<f64>, String> {
    if !(0.0..=rt::THETA_MAX).contains(&theta_b) {
        return Err(format!(
            "theta_b = {theta_b} is outside [0, π/2]",
            theta_b = short(theta_b)
        ));
    }
    let f = crate::log_zh::reference_log_zh(lobefit_tables::log_zh::Kind::Blocker, eps, theta_b, order)?;
    let c = theta_b.cos();
    let (g, ok) = lobefit_core::sh::zh_project_gk(order, |t| if t > c { 0.0 } else { 1.0 }, &[c], 1e-14);
    if !ok {
        return Err(format!(
            "visibility quadrature did not converge at theta_b = {theta_b}",
            theta_b = short(theta_b)
        ));
    }
    let (a, b, norm) = ab_of_pair(&g, &f).map_err(|e| e.to_string())?;
    let mut v = f;
    v.extend([norm, a, b]);
    Ok(v)
}

/// shexp in the list of families (`crate::entries`): `eval shexp --order N
/// --log ren|naive`.
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| vec![Box::new(ShExpFamily::default())],
    eval: Some(|_, flags, _| {
        Ok(Box::new(ShExpFamily::from_flags(
            flags.count("order")?,
            flags.text("log").as_deref(),
        )?))
    }),
    eval_names: &[],
    eval_flags: &[(
        lobefit_tables::shexp::KIND,
        &[
            EvalFlag {
                name: "order",
                help: "3..=8 (bands 0..N-1; default 4)",
                count: true,
            },
            EvalFlag {
                name: "log",
                help: "ren | naive (default ren)",
                count: false,
            },
        ],
    )],
    gpu: &[gpu::GPU],
    closed_form: None,
    plot: Some(("shexp", study::plot)),
    eval_help: "\
shexp  [--order N] (3..8, default 4)  [--log ren|naive] (default ren)
  in   `theta_b`  angular radius of a spherical-cap blocker about +z (rad), [0, π/2]
       `eps`      (naive) clamp ε of the projected log
  out  `f0` … `f7`  (the first N) the log-ZH vector f of the cap's visibility
       `norm`     ‖f̂‖, f without its DC term
       `a`, `b`   optimal-linear coefficients of exp*(f̂) ≈ a·1 + b·f̂
",
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_agrees_with_reference_at_nodes() {
        let fam = ShExpFamily::default();
        for n in ORDER_MIN..=ORDER_MAX {
            for &t in &[0.0, 1e-3, 0.5, 1.2, rt::THETA_MAX] {
                let fit = fam.fit(&[n as f64, t]);
                assert!(fit.converged, "n = {n}, θ_b = {t}: residual {:e}", fit.residual);
                assert_eq!(fit.values.len(), 2 * rt::PAIRS);
            }
        }
    }

    #[test]
    fn flags() {
        assert!(ShExpFamily::from_flags(Some(2), None).unwrap_err().contains("outside"));
        assert!(ShExpFamily::from_flags(None, Some("log10"))
            .unwrap_err()
            .contains("unknown --log"));
        let f = ShExpFamily::from_flags(Some(5), Some("naive")).unwrap();
        assert_eq!(f.outputs(), &["f0", "f1", "f2", "f3", "f4", "norm", "a", "b"]);
        assert_eq!(f.inputs(), &["theta_b", "eps"]);
    }
}
