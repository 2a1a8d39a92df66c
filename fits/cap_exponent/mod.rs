//! spherical-cap exponent e_cap(α) (Meunier et al. §5.2).
//!
//! Objective, c = cos α ≥ 0, t_c = 1 − c = 2 sin²(α/2) (no cancellation):
//!   F(e) = 2π [ t_c − 2(1 − c^{e+1})/(e+1) + 1/(2e+1) ].
//! Fit: 1-D minimisation of F over q = e/m(α) ∈ [0.25, 1.25] (the stored, scale-free
//! variable; m(α) is `lobefit_tables::cap_exponent::model`) by Brent's method
//! (argmin), or NLopt's Nelder–Mead behind the `nlopt` feature, then polished on the
//! closed-form stationarity condition ∂F/∂e = 0 (see `polish`).
//! Reference (checker): the root of ∂F/∂e computed by Gauss–Kronrod quadrature of
//!   ∂F/∂e = 4π [ −∫_0^{t_c} (1 − w) w L dt + ∫_{t_c}^1 w² L dt ],
//!   w = (1−t)^e, L = ln(1 − t)   (t = 1 − cos θ, dω = 2π dt),
//! found by regula falsi — no closed form and no Brent shared with the fit.
//!
//! α ≥ π/2 ⇒ e_cap = 0. Proof: then the cap contains the whole lobe hemisphere, so
//! F(e) = 2π[(1 − c) − 2/(e+1) + 1/(2e+1)] and F'(e) = 4π[1/(e+1)² − 1/(2e+1)²] > 0
//! for e > 0 (2e+1 > e+1): F increases, its minimum on e ≥ 0 is at e = 0.

pub mod gpu;

use std::f64::consts::{FRAC_PI_2, PI};

use argmin::core::{CostFunction, Error, Executor, State, TerminationReason, TerminationStatus};
use argmin::solver::brent::{BrentOpt, BrentRoot};
use argmin::solver::neldermead::NelderMead;

use lobefit_tables::cap_exponent::{self as rt, model, CapExponent, ALPHA_MIN};
use lobefit_tables::format::Threshold;
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Mapping, Table};

use crate::{Backend, Method};
use lobefit_core::family::{Checked, Fit, Fitted, Lookup, View};
use lobefit_core::quad::{adaptive_simpson, gauss_kronrod, illinois};
use lobefit_core::rng::Rng;
use lobefit_tables::error::short;

/// Grid nodes (the paper's 1000).
pub const NODES: u32 = 1000;
/// Bracket of q = e/m(α); q ∈ [0.47, 0.97] over the whole domain.
const Q_LO: f64 = 0.25;
const Q_HI: f64 = 1.25;
/// Brent's relative tolerance: √ε, the best a minimiser of a smooth function can do.
const BRENT_EPS: f64 = 1.4901161193847656e-8;
const BRENT_ABS: f64 = 1e-12;
const MAX_ITERS: u64 = 200;
/// Half-width of the bracket in q searched by the polishing root finder.
const POLISH_WINDOW: f64 = 0.02;
/// Relative tolerance of the polishing root finder.
const ROOT_TOL: f64 = 1e-14;
/// NLopt's relative x tolerance.
#[cfg(feature = "nlopt")]
const NLOPT_XTOL: f64 = 1e-11;
/// The checker's quadrature tolerance (relative, per derivative evaluation).
const REF_QUAD_TOL: f64 = 1e-11;
/// Tolerance on q of the reference root.
const REF_ROOT_TOL: f64 = 1e-13;
/// Within this of π/2, `exact` returns the limit q = 1/2 (see `Checked::exact`).
const ASYMPTOTE_GAP: f64 = 1e-9;
/// Closest approach to π/2 of checked points: beyond it e_cap < 1e-9 and cos α itself
/// carries a relative error of ~1e-16/(π/2 − α) in f64.
const SAMPLE_GAP: f64 = 1e-10;

/// The cap-exponent family.
#[derive(Debug, Clone, Copy)]
pub struct CapExponentFamily {
    /// Optimizer backend (fast method).
    pub backend: Backend,
    /// Fast (closed form + polish) or the paper-faithful baseline.
    pub method: Method,
}

/// Relative tolerance of the baseline's quadrature objective.
const PAPER_QUAD_TOL: f64 = 1e-10;
/// Simplex standard-deviation tolerance of the baseline's Nelder–Mead (in ln e).
const PAPER_SD_TOL: f64 = 1e-10;

/// The L2 objective F(e)/(2π t_c) by adaptive Simpson quadrature in θ — how the
/// paper had to evaluate it without the closed form.
pub fn objective_by_quadrature(alpha: f64, e: f64) -> f64 {
    let (tc, _) = cap_terms(alpha);
    let w = 1.0 / (e + 1.0).sqrt();
    let mut breaks: Vec<f64> = [1.0, 2.0, 4.0, 8.0, 16.0].iter().map(|k| k * w).collect();
    breaks.push(alpha);
    let f = |t: f64| {
        let lobe = t.cos().max(0.0).powf(e);
        let cap = if t <= alpha { 1.0 } else { 0.0 };
        (cap - lobe).powi(2) * t.sin()
    };
    adaptive_simpson(f, 0.0, FRAC_PI_2, &breaks, PAPER_QUAD_TOL * tc, 50).value / tc
}

struct QuadratureObjective {
    alpha: f64,
}

impl CostFunction for QuadratureObjective {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        Ok(objective_by_quadrature(self.alpha, p[0].exp()))
    }
}

/// The paper-faithful baseline: Nelder–Mead (argmin) over ln e on the quadrature
/// objective, started from the small-cap asymptote. Returns (q, iterations, converged).
pub fn fit_paper(alpha: f64) -> (f64, u32, bool) {
    let e0 = (1.9226 / (alpha * alpha)).max(1e-3);
    let simplex = vec![vec![e0.ln()], vec![(0.5 * e0).ln()]];
    let solver = match NelderMead::new(simplex).with_sd_tolerance(PAPER_SD_TOL) {
        Ok(s) => s,
        Err(_) => return (f64::NAN, 0, false),
    };
    match Executor::new(QuadratureObjective { alpha }, solver)
        .configure(|s| s.max_iters(1000))
        .run()
    {
        Ok(res) => {
            let st = res.state();
            let e = st.get_best_param().map(|p| p[0].exp()).unwrap_or(f64::NAN);
            (e / model(alpha), st.get_iter() as u32, converged(st))
        }
        Err(_) => (f64::NAN, 1000, false),
    }
}

/// t_c = 1 − cos α and ln cos α, both without cancellation.
fn cap_terms(alpha: f64) -> (f64, f64) {
    let s = (0.5 * alpha).sin();
    let tc = 2.0 * s * s;
    (tc, (-tc).ln_1p())
}

/// Closed-form objective F(e)/(2π t_c): the squared relative L2 error of the lobe.
pub fn objective(alpha: f64, e: f64) -> f64 {
    let (tc, lc) = cap_terms(alpha);
    let one_minus_ce1 = -((e + 1.0) * lc).exp_m1();
    (tc - 2.0 * one_minus_ce1 / (e + 1.0) + 1.0 / (2.0 * e + 1.0)) / tc
}

/// Cancellation-free objective change [F(e) − F(0)]/(2π) (F(0)/(2π) = cos α).
///
/// Written as −2[c(1 − c^e) − e t_c]/(e+1) − 2e/(2e+1), every term is O(e), so the
/// minimiser can resolve the tiny exponents near α = π/2, where the plain form
/// cancels O(1) terms down to O(e²).
pub fn objective_change(alpha: f64, e: f64) -> f64 {
    let (tc, lc) = cap_terms(alpha);
    let c = 1.0 - tc;
    -2.0 * (c * -(e * lc).exp_m1() - e * tc) / (e + 1.0) - 2.0 * e / (2.0 * e + 1.0)
}

/// Closed-form ∂F/∂e /(2π) = 2(1 − c^{e+1})/(e+1)² + 2 c^{e+1} ln c/(e+1) − 2/(2e+1)².
pub fn objective_slope(alpha: f64, e: f64) -> f64 {
    let (_, lc) = cap_terms(alpha);
    let ce1 = ((e + 1.0) * lc).exp();
    let one_minus = -((e + 1.0) * lc).exp_m1();
    2.0 * one_minus / (e + 1.0).powi(2) + 2.0 * ce1 * lc / (e + 1.0) - 2.0 / (2.0 * e + 1.0).powi(2)
}

struct Objective {
    alpha: f64,
    m: f64,
}

impl CostFunction for Objective {
    type Param = f64;
    type Output = f64;
    fn cost(&self, q: &f64) -> Result<f64, Error> {
        Ok(objective_change(self.alpha, q * self.m) / self.m)
    }
}

struct Slope {
    alpha: f64,
    m: f64,
}

impl CostFunction for Slope {
    type Param = f64;
    type Output = f64;
    fn cost(&self, q: &f64) -> Result<f64, Error> {
        Ok(objective_slope(self.alpha, q * self.m))
    }
}

fn converged<S: State>(st: &S) -> bool {
    matches!(
        st.get_termination_status(),
        TerminationStatus::Terminated(TerminationReason::SolverConverged | TerminationReason::TargetCostReached)
    )
}

/// Polishes a minimiser's q on the stationarity condition ∂F/∂e = 0 with argmin's
/// Brent root finder in a small bracket around it. A minimiser resolves q only to
/// about √ε of the objective, far too coarse for the tiny e near π/2; the root is
/// resolved to ~1e-14. Returns (q, iterations, converged); fails when the minimiser's
/// q and the root disagree by more than `POLISH_WINDOW` (then the minimiser is wrong).
fn polish(alpha: f64, q0: f64) -> (f64, u32, bool) {
    let m = model(alpha);
    let (lo, hi) = ((q0 - POLISH_WINDOW).max(Q_LO), (q0 + POLISH_WINDOW).min(Q_HI));
    let solver = BrentRoot::new(lo, hi, ROOT_TOL);
    match Executor::new(Slope { alpha, m }, solver)
        .configure(|s| s.param(q0).max_iters(MAX_ITERS))
        .run()
    {
        Ok(res) => {
            let st = res.state();
            let q = st.get_best_param().copied().unwrap_or(f64::NAN);
            (q, st.get_iter() as u32, converged(st))
        }
        Err(_) => (f64::NAN, MAX_ITERS as u32, false),
    }
}

/// argmin's Brent minimiser alone (before [`polish`]): (q, iterations, converged).
fn minimise_argmin(alpha: f64) -> (f64, u32, bool) {
    let problem = Objective { alpha, m: model(alpha) };
    let solver = BrentOpt::new(Q_LO, Q_HI).set_tolerance(BRENT_EPS, BRENT_ABS);
    match Executor::new(problem, solver)
        .configure(|s| s.max_iters(MAX_ITERS))
        .run()
    {
        Ok(res) => {
            let st = res.state();
            let q = st.get_best_param().copied().unwrap_or(f64::NAN);
            (q, st.get_iter() as u32, converged(st))
        }
        Err(_) => (f64::NAN, MAX_ITERS as u32, false),
    }
}

/// The chosen backend's minimiser alone, before polishing: (q, iterations, converged).
/// Exposed so tests can compare the two optimizers themselves.
pub fn minimise(alpha: f64, backend: Backend) -> (f64, u32, bool) {
    match backend {
        Backend::Argmin => minimise_argmin(alpha),
        Backend::Nlopt => minimise_nlopt(alpha),
    }
}

/// NLopt's Nelder–Mead (bounded) alone: (q, evaluations, converged).
#[cfg(feature = "nlopt")]
fn minimise_nlopt(alpha: f64) -> (f64, u32, bool) {
    use nlopt::{Algorithm, Nlopt, SuccessState, Target};
    let m = model(alpha);
    let evals = std::cell::Cell::new(0u32);
    let f = |x: &[f64], _g: Option<&mut [f64]>, _: &mut ()| {
        evals.set(evals.get() + 1);
        objective_change(alpha, x[0] * m) / m
    };
    let mut opt = Nlopt::new(Algorithm::Neldermead, 1, f, Target::Minimize, ());
    let setup = opt.set_lower_bound(Q_LO).is_ok()
        && opt.set_upper_bound(Q_HI).is_ok()
        && opt.set_xtol_rel(NLOPT_XTOL).is_ok()
        && opt.set_initial_step1(0.05).is_ok()
        && opt.set_maxeval(2000).is_ok();
    let mut x = [0.75];
    let ok = setup
        && matches!(
            opt.optimize(&mut x),
            Ok((
                SuccessState::XtolReached | SuccessState::FtolReached | SuccessState::Success,
                _
            ))
        );
    (x[0], evals.get(), ok)
}

#[cfg(not(feature = "nlopt"))]
fn minimise_nlopt(_alpha: f64) -> (f64, u32, bool) {
    // Unreachable from the CLI (it refuses `--backend nlopt` without the feature);
    // an unconverged result keeps a library caller from writing a table.
    (f64::NAN, 0, false)
}

/// ∂F/∂e at (α, e) by Gauss–Kronrod quadrature (the checker's independent path).
///
/// The part inside the cap is integrated in t = 1 − cos θ (accurate for small caps),
/// the part outside in s = cos θ = 1 − t, so the log singularity of ln s at s = 0
/// (reached when α → π/2) sits where doubles are dense:
///   ∂F/∂e = 4π [ −∫_0^{t_c} (1 − w) w ln(1−t) dt + ∫_0^{c} s^{2e} ln s ds ],  w = (1−t)^e,
/// with 1 − w from `exp_m1`: near π/2, e·ln(1−t) is ~1e-10 and 1 − w would cancel.
pub fn objective_derivative_by_quadrature(alpha: f64, e: f64) -> (f64, bool) {
    let (tc, _) = cap_terms(alpha);
    let c = alpha.cos();
    // Break points where the lobe's scale changes (t ~ k/(e+1)).
    let scales: Vec<f64> = [0.25, 1.0, 4.0, 16.0, 64.0].iter().map(|k| k / (e + 1.0)).collect();
    let inner = gauss_kronrod(
        |t| {
            let l = (-t).ln_1p();
            let el = (e * l).exp_m1(); // w − 1 without cancellation when e·l is tiny
            el * (1.0 + el) * l
        },
        0.0,
        tc,
        &scales,
        0.0,
        REF_QUAD_TOL,
        2000,
    );
    let s_breaks: Vec<f64> = scales.iter().map(|k| 1.0 - k).collect();
    let outer = gauss_kronrod(
        |s: f64| (2.0 * e * s.ln()).exp() * s.ln(),
        0.0,
        c,
        &s_breaks,
        0.0,
        REF_QUAD_TOL,
        2000,
    );
    (
        4.0 * PI * (inner.value + outer.value),
        inner.converged && outer.converged,
    )
}

/// Reference e_cap(α) by quadrature and root finding, for α ∈ [1e-3, π].
pub fn reference_e_cap(alpha: f64) -> Result<f64, String> {
    if !(ALPHA_MIN..=PI).contains(&alpha) {
        return Err(format!(
            "alpha = {alpha} is outside [{ALPHA_MIN}, π]",
            alpha = short(alpha)
        ));
    }
    if alpha >= FRAC_PI_2 {
        return Ok(0.0);
    }
    let m = model(alpha);
    let mut all_converged = true;
    let root = illinois(
        |q| {
            let (d, ok) = objective_derivative_by_quadrature(alpha, q * m);
            all_converged &= ok;
            d
        },
        Q_LO,
        Q_HI,
        REF_ROOT_TOL,
        200,
    );
    match root {
        Some((q, _)) if all_converged => Ok(q * m),
        Some(_) => Err(format!(
            "reference quadrature did not converge at alpha = {alpha}",
            alpha = short(alpha)
        )),
        None => Err(format!(
            "reference root not bracketed at alpha = {alpha}",
            alpha = short(alpha)
        )),
    }
}

/// The runtime type as the checker's [`Lookup`] (a local type: the trait and
/// [`CapExponent`] live in other crates).
struct CapExponentLookup(CapExponent);

impl Lookup for CapExponentLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        Ok(vec![self.0.e_cap(x[0])?])
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        Some(self.0.e_cap_f32(x[0] as f32).map(|v| vec![v.into()]))
    }
}

impl CapExponentFamily {
    /// Minimise with the backend, then polish: (q, iterations, converged).
    fn solve(&self, alpha: f64) -> (f64, u32, bool) {
        if self.method == Method::Paper {
            return fit_paper(alpha);
        }
        let (q0, it0, ok0) = minimise(alpha, self.backend);
        if !ok0 || !q0.is_finite() {
            return (q0, it0, false);
        }
        let (q, it, ok) = polish(alpha, q0);
        (q, it0 + it, ok)
    }
}

impl View for CapExponentFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["alpha"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["e_cap"]
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::CAP_EXPONENT
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(CapExponentLookup(CapExponent::from_table(table)?)))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        Ok(vec![reference_e_cap(x[0])?])
    }
    fn exact(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        // The optimizer itself, run at exactly this α.
        let alpha = x[0];
        if !(ALPHA_MIN..=PI).contains(&alpha) {
            return Err(format!(
                "alpha = {alpha} is outside [{ALPHA_MIN}, π]",
                alpha = short(alpha)
            ));
        }
        if alpha >= FRAC_PI_2 {
            return Ok(vec![0.0]);
        }
        if alpha > FRAC_PI_2 - ASYMPTOTE_GAP {
            // e_cap < 1e-8 here and no optimizer resolves it in f64; q → 1/2 with an
            // error below 2e-7 (test `exact_path_uses_the_limit_next_to_half_pi`).
            return Ok(vec![0.5 * model(alpha)]);
        }
        let f = self.fit(&[alpha]);
        if !f.converged {
            return Err(format!("fit did not converge at alpha = {alpha}", alpha = short(alpha)));
        }
        Ok(vec![f.values[0] * model(alpha)])
    }
}

impl Checked for CapExponentFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        vec![
            Threshold {
                output: "e_cap".into(),
                metric: "grid.max_rel".into(),
                limit: 1e-4,
            },
            Threshold {
                output: "e_cap".into(),
                metric: "offgrid.max_rel".into(),
                limit: 1e-4,
            },
        ]
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        // Half uniform in α, half uniform in the logit coordinate up to π/2 − 1e-10:
        // dense at both ends, including the sliver beyond the last node where the
        // runtime holds q constant.
        if rng.uniform() < 0.5 {
            vec![rng.range(ALPHA_MIN, FRAC_PI_2)]
        } else {
            let m = Mapping::Logit { a: 0.0, b: FRAC_PI_2 };
            let u = rng.range(m.forward(ALPHA_MIN), m.forward(FRAC_PI_2 - SAMPLE_GAP));
            vec![m.inverse(u).clamp(ALPHA_MIN, FRAC_PI_2 - SAMPLE_GAP)]
        }
    }
}

impl Fit for CapExponentFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        "Lobe exponent e_cap(α) best matching (L2 over the sphere) a spherical cap of half-angle α \
         (Meunier et al. 2009 §5.2). Stored: q = e_cap/m(α), m(α) = cos α (1 − ln cos α)/(1 − cos α), \
         on nodes uniform in ln(α/(π/2 − α)); e_cap = q·m(α). For α ≥ π/2, e_cap = 0; between the \
         last node and π/2 hold q constant."
            .into()
    }
    fn axes(&self) -> Vec<Axis> {
        vec![rt::axis(NODES)]
    }
    fn channels(&self) -> Vec<Channel> {
        vec![Channel {
            name: rt::CHANNEL.into(),
            unit: "1".into(),
            encoding: Encoding::Linear,
            description: "e_cap / m(alpha), m = cos a (1 - ln cos a) / (1 - cos a)".into(),
        }]
    }
    fn method(&self) -> String {
        if self.method == Method::Paper {
            return "paper baseline: Nelder-Mead (argmin) over ln e on the L2 objective by adaptive Simpson".into();
        }
        match self.backend {
            Backend::Argmin => {
                "Brent minimisation (argmin) of the closed-form L2 objective over q, polished on dF/de = 0".into()
            }
            Backend::Nlopt => {
                "Nelder-Mead (NLopt) of the closed-form L2 objective over q, polished on dF/de = 0".into()
            }
        }
    }
    fn settings(&self) -> Vec<(String, String)> {
        if self.method == Method::Paper {
            return vec![
                ("method".into(), "paper".into()),
                ("quad_rel_tol".into(), format!("{PAPER_QUAD_TOL:e}")),
                ("simplex_sd_tol".into(), format!("{PAPER_SD_TOL:e}")),
            ];
        }
        let mut s = vec![
            ("backend".to_string(), self.backend.name().to_string()),
            ("q_bracket".into(), format!("[{Q_LO}, {Q_HI}]")),
            (
                "polish".into(),
                format!("brent root of dF/de within +-{POLISH_WINDOW}, rel tol {ROOT_TOL:e}"),
            ),
        ];
        match self.backend {
            Backend::Argmin => {
                s.push(("brent_eps".into(), format!("{BRENT_EPS:e}")));
                s.push(("brent_abs".into(), format!("{BRENT_ABS:e}")));
                s.push(("max_iters".into(), MAX_ITERS.to_string()));
            }
            Backend::Nlopt => {
                #[cfg(feature = "nlopt")]
                s.push(("xtol_rel".into(), format!("{NLOPT_XTOL:e}")));
            }
        }
        s
    }
    fn residual_meaning(&self) -> &'static str {
        "relative L2 error of the fitted lobe: sqrt(∫(f_cap − Ψ)² / ∫f_cap²)"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let alpha = node[0];
        let (q, iterations, ok) = self.solve(alpha);
        // A minimiser stuck on the bracket has not found the interior minimum.
        let interior = q > Q_LO + 1e-6 && q < Q_HI - 1e-6;
        let e = q * model(alpha);
        Fitted {
            values: vec![q],
            residual: objective(alpha, e).max(0.0).sqrt(),
            iterations,
            converged: ok && interior && q.is_finite(),
        }
    }
}

/// cap-exponent in the list of families (`crate::entries`).
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |o| {
        vec![Box::new(CapExponentFamily {
            backend: o.backend,
            method: o.method,
        })]
    },
    eval: None,
    eval_names: &[],
    eval_flags: &[],
    gpu: &[gpu::GPU],
    closed_form: None,
    plot: None,
    eval_help: "\
cap-exponent
  in   `alpha`    half-angle of a spherical cap (rad), [1e-3, π]
  out  `e_cap`    exponent of the cosine lobe closest (L2 over the sphere) to the
                  cap's indicator; 0 for alpha ≥ π/2
",
};

#[cfg(test)]
mod tests {
    use super::*;

    /// E8 / docs/math.md, cap-exponent: for α ≥ π/2 the minimiser is e = 0. The objective is computed by
    /// Gauss–Kronrod over the whole sphere with the real cap (indicator up to α) and
    /// the real lobe; it must be smallest at e = 0 and increase with e, for every α.
    /// Then the product paths (fit's exact path and the reference) must return 0.
    #[test]
    fn wide_caps_have_zero_exponent() {
        let objective = |alpha: f64, e: f64| {
            let f = |t: f64| {
                let in_cap = t <= alpha;
                let d = if t < FRAC_PI_2 {
                    let lobe_minus_one = (e * t.cos().ln()).exp_m1(); // no cancellation for tiny e
                    if in_cap {
                        -lobe_minus_one
                    } else {
                        1.0 + lobe_minus_one
                    }
                } else if in_cap {
                    1.0
                } else {
                    0.0
                };
                d * d * t.sin()
            };
            let breaks = [alpha, FRAC_PI_2, 1.0 / (e + 1.0).sqrt()];
            let q = gauss_kronrod(f, 0.0, PI, &breaks, 0.0, 1e-10, 4000);
            assert!(q.converged, "alpha={alpha} e={e}");
            2.0 * PI * q.value
        };
        let fam = CapExponentFamily {
            backend: Backend::Argmin,
            method: Method::Fast,
        };
        for i in 0..=10 {
            let alpha = FRAC_PI_2 + (PI - FRAC_PI_2) * i as f64 / 10.0;
            let mut prev = objective(alpha, 0.0);
            for k in 0..60 {
                let e = 1e-6 * 1.5f64.powi(k);
                let f = objective(alpha, e);
                assert!(f > prev, "alpha={alpha}: F({e}) = {f} is not above the previous {prev}");
                prev = f;
            }
            assert_eq!(fam.exact(&[alpha]).unwrap(), vec![0.0]);
            assert_eq!(reference_e_cap(alpha).unwrap(), 0.0);
        }
        // Just below π/2 the minimiser is positive: the boundary is sharp, not a default.
        assert!(reference_e_cap(FRAC_PI_2 - 1e-3).unwrap() > 0.0);
    }

    /// The limit used by `exact` within 1e-9 of π/2, against the quadrature reference;
    /// and the optimizer path just outside that gap still converges.
    #[test]
    fn exact_path_uses_the_limit_next_to_half_pi() {
        let fam = CapExponentFamily {
            backend: Backend::Argmin,
            method: Method::Fast,
        };
        for delta in [9.9e-10, 5e-10, 2e-10, 1e-10] {
            let alpha = FRAC_PI_2 - delta;
            let e = fam.exact(&[alpha]).unwrap()[0];
            let r = reference_e_cap(alpha).unwrap();
            assert!((e / r - 1.0).abs() < 2e-7, "π/2 − {delta:e}: {e:e} vs {r:e}");
        }
        for delta in [1.01e-9, 1e-8] {
            let alpha = FRAC_PI_2 - delta;
            let f = fam.fit(&[alpha]);
            assert!(f.converged, "π/2 − {delta:e}");
            let r = reference_e_cap(alpha).unwrap();
            assert!((f.values[0] * model(alpha) / r - 1.0).abs() < 1e-6);
        }
        assert!(fam.exact(&[FRAC_PI_2 - 1e-15]).unwrap()[0] > 0.0);
    }

    /// Why not the paper's layout (1000 values uniform in α, linear in e): measured at
    /// cell midpoints against the quadrature reference it misses the 1e-4 target by
    /// orders of magnitude for small caps (e ~ 1.92/α² is far from linear in α).
    #[test]
    fn paper_layout_cannot_meet_the_target() {
        let n = 1000;
        let node = |i: usize| ALPHA_MIN + (FRAC_PI_2 - ALPHA_MIN) * i as f64 / (n - 1) as f64;
        let e: Vec<f64> = (0..n).map(|i| reference_e_cap(node(i)).unwrap()).collect();
        let mut worst: f64 = 0.0;
        for i in (0..n - 1).step_by(7) {
            let mid = 0.5 * (node(i) + node(i + 1));
            let interp = 0.5 * (e[i] + e[i + 1]);
            worst = worst.max((interp / reference_e_cap(mid).unwrap() - 1.0).abs());
        }
        eprintln!("paper layout: worst relative error of e_cap at sampled cell midpoints = {worst:.3e}");
        assert!(worst > 0.1, "{worst}");
    }

    #[test]
    fn small_caps_follow_the_asymptote() {
        // e α²/2 = x solves e^{-x}(1+x) = 3/4 as α → 0, x = 0.961278...
        let x = illinois(|x: f64| (-x).exp() * (1.0 + x) - 0.75, 0.1, 3.0, 1e-15, 200)
            .unwrap()
            .0;
        let alpha = 1e-3;
        let e = reference_e_cap(alpha).unwrap();
        assert!(
            (e * alpha * alpha / 2.0 / x - 1.0).abs() < 1e-5,
            "{e} vs {}",
            2.0 * x / alpha / alpha
        );
    }

    #[test]
    fn fit_agrees_with_independent_reference() {
        for &alpha in &[1e-3, 0.01, 0.3, 1.0, 1.5, 1.57, FRAC_PI_2 - 1e-6] {
            let f = CapExponentFamily {
                backend: Backend::Argmin,
                method: Method::Fast,
            }
            .fit(&[alpha]);
            assert!(f.converged, "{alpha}: {f:?}");
            let e = f.values[0] * model(alpha);
            let r = reference_e_cap(alpha).unwrap();
            assert!((e / r - 1.0).abs() < 1e-6, "alpha={alpha}: fit {e} ref {r}");
        }
    }
}

/// The NLopt backend (cargo feature `nlopt`) is an independent second optimizer: it
/// must reproduce the argmin-built cap-exponent table within the fit tolerance. (Unit
/// tests, so that CI's `nlopt` step builds one test binary: `cargo test --features
/// nlopt --lib nlopt_backend`.)
#[cfg(all(test, feature = "nlopt"))]
mod nlopt_backend {
    use super::*;
    use crate::{Backend, Method};
    use lobefit_core::build::build;
    use lobefit_core::family::Fit;

    /// Agreement required between the two backends' stored q (relative). Both are
    /// polished on dF/de = 0 to ~1e-14, so what remains is f32 rounding (6e-8).
    const BACKEND_AGREEMENT: f64 = 2e-7;

    #[test]
    fn nlopt_reproduces_the_argmin_table() {
        let built = build(
            &CapExponentFamily {
                backend: Backend::Nlopt,
                method: Method::Fast,
            },
            &|| {},
        )
        .expect("nlopt build converges");
        let nlopt = lobefit_tables::Table::from_bytes(&built.bytes).unwrap();
        // The committed table (compiled into the runtime crate: no path relative to
        // this crate's folder).
        let argmin = lobefit_tables::Table::from_bytes(lobefit_tables::embedded::CAP_EXPONENT).unwrap();
        assert_eq!(nlopt.values().len(), argmin.values().len());
        let worst = nlopt
            .values()
            .iter()
            .zip(argmin.values())
            .map(|(a, b)| (*a as f64 / *b as f64 - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(worst <= BACKEND_AGREEMENT, "backends differ by {worst:e} (relative)");
        eprintln!("nlopt vs argmin: worst relative difference of stored q = {worst:e}");
        // The backend is part of the recorded settings, so the files are told apart.
        assert_ne!(nlopt.meta().fit.settings_hash, argmin.meta().fit.settings_hash);
        assert!(nlopt.meta().fit.method.contains("NLopt"));
    }

    /// The minimisers themselves, before the shared polish: NLopt's Nelder–Mead and
    /// argmin's Brent must find the same minimum to within what a minimiser can resolve
    /// (√ε of a flat objective), at every grid node.
    #[test]
    fn minimisers_agree_before_polishing() {
        let fam = CapExponentFamily {
            backend: Backend::Argmin,
            method: Method::Fast,
        };
        let axis = &fam.axes()[0];
        let mut worst: f64 = 0.0;
        for i in 0..axis.count {
            let alpha = axis.node(i);
            let (qa, _, oka) = minimise(alpha, Backend::Argmin);
            let (qn, _, okn) = minimise(alpha, Backend::Nlopt);
            assert!(oka && okn, "alpha {alpha}");
            worst = worst.max((qa / qn - 1.0).abs());
        }
        eprintln!("before polishing: worst relative difference of q (Brent vs Nelder-Mead) = {worst:e}");
        assert!(worst < 1e-4, "{worst:e}");
    }
}
