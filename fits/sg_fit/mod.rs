//! the L2-best single SG for a clamped cosine lobe (docs/math.md, sg-fit; not in the papers).
//!
//! With t = cos θ, s = 1 − t, dω = 2π dt and G₁ = exp(λ(t − 1)):
//!   ∫Ψ² = 2π/(2e+1),   ∫G₁² = 2π K(λ), K = (1 − e^{−4λ})/(2λ),
//!   ∫ΨG₁ = 2π J(e, λ),  J = ∫_0^1 (1 − s)^e e^{−λs} ds.
//! For fixed λ the best μ is linear least squares, μ* = J/K (variable projection), and
//! the residual is 2π[1/(2e+1) − J²/K]: the problem is one-dimensional in λ, whose
//! optimum maximises J²/K, i.e. solves the stationarity condition
//!   D(λ) = λ (2 J_λ/J − K_λ/K) = 0,   J_λ = −∫ s (1 − s)^e e^{−λs} ds,
//!   λ K_λ/K = 4λ/(e^{4λ} − 1) − 1,
//! made scale-free by the factor λ. Both integrands live on s ≲ k/(e + λ).
//!
//! Fit: argmin's Brent root finder on D over r = λ/(e+1) ∈ [0.25, 4], J and J_λ by
//! adaptive Simpson. Reference (checker): the same condition with J and J_λ by the
//! checker's Gauss–Kronrod quadrature and regula falsi (Illinois) — no shared
//! quadrature or root finder. e = 0 (hemisphere indicator) is an ordinary point:
//! (1 − s)^0 = 1.

pub mod gpu;

use argmin::core::{CostFunction, Error, Executor, State, TerminationReason, TerminationStatus};
use argmin::solver::brent::BrentRoot;

use lobefit_tables::format::Threshold;
use lobefit_tables::sg_fit::{self as rt, SgFit, E_MAX};
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};

use lobefit_core::family::{Checked, Fit, Fitted, Lookup, View};
use lobefit_core::quad::{adaptive_simpson, gauss_kronrod, illinois};
use lobefit_core::rng::Rng;
use lobefit_tables::error::short;

/// Grid nodes, uniform in ln(1 + e).
pub const NODES: u32 = 513;
/// Bracket of r = λ/(e + 1): r ≈ 1.2 at e = 0, 1.07 at e = 1, → 1 as e → ∞.
const R_LO: f64 = 0.25;
const R_HI: f64 = 4.0;
/// Relative tolerance of the fit's Simpson integrals.
const SIMPSON_REL_TOL: f64 = 1e-12;
/// Tolerance on r of the fit's root.
const ROOT_TOL: f64 = 1e-13;
/// Iteration limit of the root finders.
const MAX_ITERS: u64 = 200;
/// Relative tolerance of the reference's Gauss–Kronrod integrals.
const REF_QUAD_TOL: f64 = 1e-13;
/// Tolerance on r of the reference root.
const REF_ROOT_TOL: f64 = 1e-13;
/// Checker limit on the relative error of λ and μ through the runtime: interpolation
/// of ln λ, ln μ in ln(1 + e) plus f32 storage (measured max 1.4e-5 over 10 000
/// random e, grid nodes 4.7e-7; docs/math.md, sg-fit sets no target).
const REL_LIMIT: f64 = 3e-5;

/// Break points k/(e + λ) of the integrands in s.
fn breaks(e: f64, lambda: f64) -> Vec<f64> {
    [0.25, 1.0, 4.0, 16.0, 64.0, 256.0]
        .iter()
        .map(|k| k / (e + lambda))
        .filter(|&s| s < 1.0)
        .collect()
}

/// (1 − s)^e e^{−λs}, with ln(1 − s) from ln_1p (e up to 1e5).
fn weight(e: f64, lambda: f64, s: f64) -> f64 {
    if s >= 1.0 {
        return if e == 0.0 { (-lambda).exp() } else { 0.0 };
    }
    (e * (-s).ln_1p() - lambda * s).exp()
}

/// λ K_λ / K = 4λ/(e^{4λ} − 1) − 1.
fn lambda_log_dk(lambda: f64) -> f64 {
    4.0 * lambda / (4.0 * lambda).exp_m1() - 1.0
}

/// K(λ) = (1 − e^{−4λ})/(2λ).
fn k_of(lambda: f64) -> f64 {
    -(-4.0 * lambda).exp_m1() / (2.0 * lambda)
}

/// Which quadrature evaluates J and J_λ.
#[derive(Clone, Copy)]
enum Rule {
    /// The fit's adaptive Simpson.
    Simpson,
    /// The checker's Gauss–Kronrod.
    Kronrod,
}

/// (J, −J_λ, converged) at (e, λ).
fn moments(e: f64, lambda: f64, rule: Rule) -> (f64, f64, bool) {
    let b = breaks(e, lambda);
    let scale = 1.0 / (e + lambda + 1.0); // J's order of magnitude
    let j0 = |s: f64| weight(e, lambda, s);
    let j1 = |s: f64| s * weight(e, lambda, s);
    let (a, c) = match rule {
        Rule::Simpson => (
            adaptive_simpson(j0, 0.0, 1.0, &b, SIMPSON_REL_TOL * scale, 60),
            adaptive_simpson(j1, 0.0, 1.0, &b, SIMPSON_REL_TOL * scale * scale, 60),
        ),
        Rule::Kronrod => (
            gauss_kronrod(j0, 0.0, 1.0, &b, 0.0, REF_QUAD_TOL, 4000),
            gauss_kronrod(j1, 0.0, 1.0, &b, 0.0, REF_QUAD_TOL, 4000),
        ),
    };
    (a.value, c.value, a.converged && c.converged)
}

/// The scale-free stationarity condition D = λ(2J_λ/J − K_λ/K) at λ = r (e + 1).
fn stationarity(e: f64, r: f64, rule: Rule) -> (f64, bool) {
    let lambda = r * (e + 1.0);
    let (j, mj, ok) = moments(e, lambda, rule);
    (-2.0 * lambda * mj / j - lambda_log_dk(lambda), ok)
}

/// μ* = J/K and the relative L2 residual √(1 − (2e+1) J²/K) at (e, λ).
pub fn amplitude_and_residual(e: f64, lambda: f64) -> (f64, f64) {
    let (j, _, _) = moments(e, lambda, Rule::Kronrod);
    let k = k_of(lambda);
    (j / k, (1.0 - (2.0 * e + 1.0) * j * j / k).max(0.0).sqrt())
}

/// The L2 objective ∫(Ψ − μ G₁)² dω by Gauss–Kronrod in t = cos θ over the whole
/// sphere, straight from the definitions (for tests of the closed-form reduction).
pub fn objective_by_quadrature(e: f64, lambda: f64, mu: f64) -> f64 {
    let f = |t: f64| {
        let psi = if t > 0.0 { t.powf(e) } else { 0.0 };
        let d = psi - mu * (lambda * (t - 1.0)).exp();
        d * d
    };
    let mut b: Vec<f64> = breaks(e, lambda).iter().map(|s| 1.0 - s).collect();
    b.push(0.0);
    2.0 * std::f64::consts::PI * gauss_kronrod(f, -1.0, 1.0, &b, 0.0, 1e-13, 4000).value
}

/// Reference (λ, μ) at e by Gauss–Kronrod quadrature and regula falsi.
pub fn reference_fit(e: f64) -> Result<(f64, f64), String> {
    if !(0.0..=E_MAX).contains(&e) {
        return Err(format!("e = {e} is outside [0, {E_MAX}]", e = short(e)));
    }
    // Memoised by e's bits: the corruption sweep checks several copies of the table.
    static MEMO: lobefit_core::memo::Memo<1, (f64, f64)> = lobefit_core::memo::Memo::new();
    MEMO.get([e], || reference_fit_uncached(e))
}

fn reference_fit_uncached(e: f64) -> Result<(f64, f64), String> {
    let mut ok = true;
    let root = illinois(
        |r| {
            let (d, c) = stationarity(e, r, Rule::Kronrod);
            ok &= c;
            d
        },
        R_LO,
        R_HI,
        REF_ROOT_TOL,
        300,
    );
    match root {
        Some((r, _)) if ok => {
            let lambda = r * (e + 1.0);
            Ok((lambda, amplitude_and_residual(e, lambda).0))
        }
        Some(_) => Err(format!(
            "reference quadrature did not converge at e = {e}",
            e = short(e)
        )),
        None => Err(format!("reference root not bracketed at e = {e}", e = short(e))),
    }
}

struct Stationarity {
    e: f64,
}

impl CostFunction for Stationarity {
    type Param = f64;
    type Output = f64;
    fn cost(&self, r: &f64) -> Result<f64, Error> {
        Ok(stationarity(self.e, *r, Rule::Simpson).0)
    }
}

/// The fit at e: (λ, iterations, converged) by Brent's root finder on D over r.
pub fn fit_lambda(e: f64) -> (f64, u32, bool) {
    let solver = BrentRoot::new(R_LO, R_HI, ROOT_TOL);
    match Executor::new(Stationarity { e }, solver)
        .configure(|s| s.param(1.0).max_iters(MAX_ITERS))
        .run()
    {
        Ok(res) => {
            let st = res.state();
            let r = st.get_best_param().copied().unwrap_or(f64::NAN);
            let ok = matches!(
                st.get_termination_status(),
                TerminationStatus::Terminated(
                    TerminationReason::SolverConverged | TerminationReason::TargetCostReached
                )
            );
            // The Simpson integrals must have converged at the root too.
            let quad_ok = stationarity(e, r, Rule::Simpson).1;
            let interior = r > R_LO * 1.001 && r < R_HI * 0.999;
            (r * (e + 1.0), st.get_iter() as u32, ok && quad_ok && interior)
        }
        Err(_) => (f64::NAN, MAX_ITERS as u32, false),
    }
}

/// The sg-fit family.
#[derive(Debug, Clone, Copy)]
pub struct SgFitFamily;

/// The runtime type as the checker's [`Lookup`] (a local type: the trait and
/// [`SgFit`] live in other crates).
struct SgFitLookup(SgFit);

impl Lookup for SgFitLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let (l, m) = self.0.fit(x[0])?;
        Ok(vec![l, m])
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        Some(self.0.fit_f32(x[0] as f32).map(|(l, m)| vec![l.into(), m.into()]))
    }
}

impl View for SgFitFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["e"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["lambda", "mu"]
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::SG_FIT
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(SgFitLookup(SgFit::from_table(table)?)))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let (l, m) = reference_fit(x[0])?;
        Ok(vec![l, m])
    }
    fn exact(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        // The fit itself at exactly this e.
        let e = x[0];
        if !(0.0..=E_MAX).contains(&e) {
            return Err(format!("e = {e} is outside [0, {E_MAX}]", e = short(e)));
        }
        let f = self.fit(&[e]);
        if !f.converged {
            return Err(format!("fit did not converge at e = {e}", e = short(e)));
        }
        Ok(f.values)
    }
}

impl Checked for SgFitFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        let mut v = Vec::new();
        for output in ["lambda", "mu"] {
            for metric in ["grid.max_rel", "offgrid.max_rel"] {
                v.push(Threshold {
                    output: output.into(),
                    metric: metric.into(),
                    limit: REL_LIMIT,
                });
            }
        }
        v
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        // Uniform in ln(1+e), and e = 0 (the hemisphere indicator) now and then.
        if rng.uniform() < 0.02 {
            return vec![0.0];
        }
        vec![rng.range(0.0, E_MAX.ln_1p()).exp_m1().clamp(0.0, E_MAX)]
    }
}

impl Fit for SgFitFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        "L2-best single SG mu exp(lambda (a.v - 1)) for the clamped cosine lobe max(a.v, 0)^e over the \
         sphere (docs/math.md, sg-fit), e in [0, 1e5] (e = 0: hemisphere indicator). Channels ln lambda, ln mu on nodes \
         uniform in ln(1+e); interpolate linearly in that coordinate, then exponentiate. A lobe of scale s \
         maps to amplitude s mu."
            .into()
    }
    fn axes(&self) -> Vec<Axis> {
        vec![rt::axis(NODES)]
    }
    fn channels(&self) -> Vec<Channel> {
        vec![
            Channel {
                name: rt::CHANNELS[0].into(),
                unit: "1".into(),
                encoding: Encoding::Log,
                description: "SG sharpness lambda(e)".into(),
            },
            Channel {
                name: rt::CHANNELS[1].into(),
                unit: "1".into(),
                encoding: Encoding::Log,
                description: "SG amplitude mu(e) for a unit-scale lobe".into(),
            },
        ]
    }
    fn method(&self) -> String {
        "variable projection (mu = J/K), Brent root (argmin) of the stationarity condition in lambda, \
         J and dJ/dlambda by adaptive Simpson"
            .into()
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("r_bracket".into(), format!("[{R_LO}, {R_HI}]")),
            ("simpson_rel_tol".into(), format!("{SIMPSON_REL_TOL:e}")),
            ("root_tol".into(), format!("{ROOT_TOL:e}")),
            ("max_iters".into(), MAX_ITERS.to_string()),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "relative L2 error of the fitted SG: sqrt(∫(Ψ − G)² / ∫Ψ²)"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let e = node[0];
        let (lambda, iterations, ok) = fit_lambda(e);
        // μ from the fit's own quadrature (Simpson).
        let (j, _, qok) = moments(e, lambda, Rule::Simpson);
        let k = k_of(lambda);
        let mu = j / k;
        let residual = (1.0 - (2.0 * e + 1.0) * j * j / k).max(0.0).sqrt();
        Fitted {
            values: vec![lambda, mu],
            residual,
            iterations,
            converged: ok && qok && lambda.is_finite() && mu.is_finite() && mu > 0.0,
        }
    }
}

/// sg-fit in the list of families (`crate::entries`).
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| vec![Box::new(SgFitFamily)],
    eval: None,
    eval_names: &[],
    eval_flags: &[],
    gpu: &[gpu::GPU],
    closed_form: None,
    plot: None,
    eval_help: "\
sg-fit
  in   `e`        lobe exponent, [0, 1e5]
  out  `lambda`   sharpness and `mu` amplitude of the spherical Gaussian
                  mu·exp(lambda (a·v − 1)) closest (L2) to the unit-scale lobe
",
};

#[cfg(test)]
mod tests {
    use super::*;

    /// The known fit at e = 1 (docs/math.md, sg-fit: λ ≈ 2.133, μ ≈ 1.17, the values quoted in the
    /// SG literature), and λ/e → 1, μ → 1. The exact L2 optimum over the sphere is
    /// λ = 2.1438, μ = 1.1766 (0.5 % from the quoted pair, which must come from a
    /// slightly different fit; `reduction_matches_direct_objective` shows ours is the
    /// minimum of the defining objective).
    #[test]
    fn known_values_and_asymptotes() {
        let (l, m) = reference_fit(1.0).unwrap();
        eprintln!("e = 1: lambda = {l:.6}, mu = {m:.6}");
        assert!(
            (l / 2.133 - 1.0).abs() < 0.01 && (m / 1.17 - 1.0).abs() < 0.01,
            "{l} {m}"
        );
        assert!((l - 2.1438).abs() < 1e-4 && (m - 1.1766).abs() < 1e-4, "{l} {m}");
        let (l, m) = reference_fit(1e5).unwrap();
        assert!((l / 1e5 - 1.0).abs() < 1e-3 && (m - 1.0).abs() < 1e-3, "{l} {m}");
    }

    /// The closed-form reduction against the L2 objective integrated straight from
    /// the definitions: at the reference (λ, μ) the objective equals the reduced
    /// residual and is smallest against perturbed λ and μ; e = 0 included.
    #[test]
    fn reduction_matches_direct_objective() {
        for &e in &[0.0, 0.5, 1.0, 7.0, 300.0] {
            let (l, m) = reference_fit(e).unwrap();
            let (_, rel) = amplitude_and_residual(e, l);
            let psi2 = 2.0 * std::f64::consts::PI / (2.0 * e + 1.0);
            let f0 = objective_by_quadrature(e, l, m);
            assert!(
                (f0 / psi2 - rel * rel).abs() < 1e-9,
                "e={e}: {f0} vs {}",
                rel * rel * psi2
            );
            for (dl, dm) in [(1.001, 1.0), (0.999, 1.0), (1.0, 1.001), (1.0, 0.999)] {
                assert!(objective_by_quadrature(e, l * dl, m * dm) > f0, "e={e} {dl} {dm}");
            }
        }
    }

    #[test]
    fn fit_agrees_with_reference() {
        for &e in &[0.0, 0.01, 1.0, 42.0, 9999.0, 1e5] {
            let f = SgFitFamily.fit(&[e]);
            assert!(f.converged, "{e}: {f:?}");
            let (l, m) = reference_fit(e).unwrap();
            assert!((f.values[0] / l - 1.0).abs() < 1e-9, "e={e}: {} vs {l}", f.values[0]);
            assert!((f.values[1] / m - 1.0).abs() < 1e-9, "e={e}: {} vs {m}", f.values[1]);
        }
    }
}
