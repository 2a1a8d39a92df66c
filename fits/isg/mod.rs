//! integral spherical Gaussian (Iwasaki et al. 2012 §4; docs/math.md, isg, errata E1–E3).
//!
//! Two tables, one family object per model:
//! - `isg-refit`: the paper's logistic model σ(g(θ − π/2)) σ(h(φ − π/2)) refitted per γ
//!   node by Levenberg–Marquardt least squares and a minimax polish on a (θ, φ) grid
//!   adapted to the SG width, then g(γ), h(γ) tabulated over ln γ (interpolated
//!   linearly in ln γ as ln g, ln h).
//! - `isg-best`: the rank-2 separable model A(θ)B(φ) + C(θ)D(φ) with the exact
//!   marginals A = Ŝ(·, π), B = Ŝ(π, ·) and C D the leading singular pair of Ŝ − A B,
//!   on a (ln γ, u) grid (u: `lobefit_tables::isg::warp`).
//!
//! The published model (`--model paper`) needs no table; its errors are measured in
//! the tests and by `lobefit plot isg`.
//!
//! The fits use the fast 1-D evaluation `crate::isg::reference::s_hat_fast`; the checker's
//! reference is the nested Gauss–Kronrod quadrature `crate::isg::reference::s_hat_reference`.

pub mod reference;

pub mod gpu;

use std::f64::consts::{FRAC_PI_2, PI};

use argmin::core::{CostFunction, Error as ArgminError, Executor, State, TerminationReason, TerminationStatus};
use argmin::solver::neldermead::NelderMead;
use lobefit_tables::format::Threshold;
use lobefit_tables::isg::{
    self as rt, gamma_axis, unwarp, warp_axis, BestIsg, IsgModel, PaperIsg, RefitIsg, GAMMA_MAX, GAMMA_MIN,
};
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};

use crate::isg::reference::{check_domain, normaliser, s_hat_fast, s_hat_reference};
use lobefit_core::family::{Checked, Fit, Fitted, Lookup, View};
use lobefit_core::rng::Rng;

/// γ nodes of the refit table (uniform in ln γ over [0.5, 10^4]).
pub const REFIT_NODES: u32 = 65;
/// γ nodes of the separable table.
pub const BEST_GAMMA_NODES: u32 = 65;
/// u nodes of the separable table.
pub const BEST_U_NODES: u32 = 129;
/// Lower end of the γ range where docs/math.md, isg sets the refit target (0.02); below it the
/// logistic shape cannot follow Ŝ (see `refit_error_below_three`).
pub const REFIT_TARGET_GAMMA_MIN: f64 = 3.0;
/// docs/math.md, isg target for the refitted logistic model, γ ∈ [3, 10^4]. Infeasible for
/// 3 ≤ γ < 3.25: there the minimax logistic itself errs by up to 0.0221 (at θ ≈ 2.78,
/// φ = π; test `refit_target_infeasible_just_above_three`); met from γ ≈ 3.25 on.
pub const REFIT_TARGET: f64 = 0.02;
/// The refit table's checker limit on [3, 10^4]: the minimax floor of the logistic
/// shape at γ = 3 (0.0221) plus interpolation in ln γ (the 0.02 target cannot be met there
/// by any (g, h); see [`REFIT_TARGET`]).
pub const REFIT_CHECK_LIMIT: f64 = 0.0225;
/// The refit table's promise below γ = 3 (γ ∈ [0.5, 3)), where no logistic pair
/// follows Ŝ to the target: max |Ŝ_refit − Ŝ| ≤ 0.07 (measured by `lobefit check`:
/// 0.062 at the grid points, 0.059 at random points).
pub const REFIT_LOW_GAMMA_LIMIT: f64 = 0.07;
/// docs/math.md, isg target for the better model, γ ∈ [0.5, 10^4].
pub const BEST_TARGET: f64 = 0.005;
/// The separable table's checker limit: it promises ten times the target (its
/// rank-2 form is within 1.4e-4 of Ŝ; measured by `lobefit check`), so a regression
/// towards the rank-1 product (3.9e-3) fails the check.
pub const BEST_CHECK_LIMIT: f64 = 5e-4;
/// Half-width, in SG widths 1/√γ, of the part of the fitting grid adapted to the lobe.
const GRID_WIDTHS: f64 = 6.0;
/// Points per axis of each half (uniform, width-adapted) of the fitting grid.
const GRID_HALF: usize = 41;
/// Initial simplex step of the minimax polish, in ln g and ln h.
const NM_STEP: f64 = 0.02;
/// Simplex standard-deviation tolerance of the minimax polish (max error units).
const NM_SD_TOL: f64 = 1e-12;
/// Iteration limit of the minimax polish.
const NM_MAX_ITERS: u64 = 500;
/// LM stops when the relative step in (ln g, ln h) is below this.
const LM_STEP_TOL: f64 = 1e-10;
/// LM also stops when an accepted step lowers the cost by less than this, relatively.
const LM_COST_TOL: f64 = 1e-12;
/// LM iteration limit per stage.
const LM_MAX_ITERS: u32 = 200;

/// One axis (θ or φ) of the fitting grid at γ: 21 points uniform on [0, π/2] and 21
/// within 6 SG widths below π/2, merged, then mirrored about π/2 (so exactly symmetric,
/// see [`s_hat_grid`]): about 41 + 41 points over [0, π].
pub fn fit_axis(gamma: f64) -> Vec<f64> {
    let n = (GRID_HALF / 2) as f64;
    let w = 1.0 / gamma.sqrt();
    // The half x ≤ π/2, then its mirror image π − x.
    let mut half: Vec<f64> = (0..=GRID_HALF / 2).map(|i| FRAC_PI_2 * i as f64 / n).collect();
    half.extend((0..=GRID_HALF / 2).map(|i| (FRAC_PI_2 - w * GRID_WIDTHS * i as f64 / n).max(0.0)));
    half.sort_by(f64::total_cmp);
    half.dedup();
    let mut v = half.clone();
    v.extend(half.iter().rev().skip(1).map(|&x| PI - x));
    v
}

/// Ŝ on the tensor grid `ax × ax` (row-major, θ outer) by the fast evaluation, for an
/// axis from [`fit_axis`]. Only the quadrant θ, φ ≤ π/2 and the marginals are
/// evaluated; the rest follows from the mirror symmetries of the integrand:
/// Ŝ(π − θ, φ) = B(φ) − Ŝ(θ, φ), Ŝ(θ, π − φ) = A(θ) − Ŝ(θ, φ).
pub fn s_hat_grid(ax: &[f64], gamma: f64) -> Vec<f64> {
    let n = ax.len();
    let m = n.div_ceil(2); // ax[m − 1] = π/2
    let a: Vec<f64> = ax[..m].iter().map(|&t| s_hat_fast(t, PI, gamma)).collect();
    let b: Vec<f64> = ax[..m].iter().map(|&p| s_hat_fast(PI, p, gamma)).collect();
    let mut q = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            q[i * m + j] = s_hat_fast(ax[i], ax[j], gamma);
        }
    }
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let (mi, fi) = if i < m { (i, false) } else { (n - 1 - i, true) };
            let (mj, fj) = if j < m { (j, false) } else { (n - 1 - j, true) };
            let v = q[mi * m + mj];
            out[i * n + j] = match (fi, fj) {
                (false, false) => v,
                (true, false) => b[mj] - v,
                (false, true) => a[mi] - v,
                // Ŝ(π−θ, π−φ) = A(π−θ) − Ŝ(π−θ, φ) = (1 − A(θ)) − (B(φ) − Ŝ(θ, φ)).
                (true, true) => 1.0 - a[mi] - b[mj] + v,
            };
        }
    }
    out
}

/// Result of a per-γ logistic fit.
#[derive(Debug, Clone, Copy)]
pub struct LogisticFit {
    /// Slope in θ (1/rad).
    pub g: f64,
    /// Slope in φ (1/rad).
    pub h: f64,
    /// Max |f − Ŝ| on the fitting grid.
    pub max_err: f64,
    /// LM iterations (both stages).
    pub iterations: u32,
    /// Whether both LM stages converged.
    pub converged: bool,
}

/// Max |σ(g δθ) σ(h δφ) − Ŝ| over the grid at x = (ln g, ln h).
fn max_residual(ax: &[f64], s: &[f64], x: &[f64]) -> f64 {
    let (g, h) = (x[0].exp(), x[1].exp());
    let sa: Vec<f64> = ax.iter().map(|&t| rt::sigmoid(g * (t - FRAC_PI_2))).collect();
    let sb: Vec<f64> = ax.iter().map(|&t| rt::sigmoid(h * (t - FRAC_PI_2))).collect();
    let mut worst: f64 = 0.0;
    for (i, a) in sa.iter().enumerate() {
        for (j, b) in sb.iter().enumerate() {
            worst = worst.max((a * b - s[i * ax.len() + j]).abs());
        }
    }
    worst
}

struct MaxResidual<'a> {
    ax: &'a [f64],
    s: &'a [f64],
}

impl CostFunction for MaxResidual<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, ArgminError> {
        Ok(max_residual(self.ax, self.s, x))
    }
}

/// Minimax polish of (ln g, ln h) from the least-squares fit: Nelder–Mead (argmin) on
/// the max residual (non-smooth, two parameters). The target is a max error, and the
/// minimax fit lowers it by ~10 % against least squares. Never worse than the start.
fn minimax(ax: &[f64], s: &[f64], x0: [f64; 2]) -> ([f64; 2], u32, bool) {
    let simplex = vec![x0.to_vec(), vec![x0[0] + NM_STEP, x0[1]], vec![x0[0], x0[1] + NM_STEP]];
    let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(NM_SD_TOL) else {
        return (x0, 0, false);
    };
    match Executor::new(MaxResidual { ax, s }, solver)
        .configure(|st| st.max_iters(NM_MAX_ITERS))
        .run()
    {
        Ok(res) => {
            let st = res.state();
            let ok = matches!(
                st.get_termination_status(),
                TerminationStatus::Terminated(TerminationReason::SolverConverged)
            );
            let best = st.get_best_param().cloned().unwrap_or_else(|| x0.to_vec());
            let x = if max_residual(ax, s, &best) <= max_residual(ax, s, &x0) {
                [best[0], best[1]]
            } else {
                x0
            };
            (x, st.get_iter() as u32, ok)
        }
        Err(_) => (x0, NM_MAX_ITERS as u32, false),
    }
}

/// Levenberg–Marquardt (least squares) on (ln g, ln h) over the grid, residuals
/// r_k = σ(g δθ) σ(h δφ) − Ŝ_k. Returns (ln g, ln h, iterations, converged).
fn lm(ax: &[f64], s: &[f64], start: [f64; 2]) -> ([f64; 2], u32, bool) {
    // Residuals and Jacobian rows of the transformed problem.
    let eval = |x: [f64; 2], jac: bool| {
        let (g, h) = (x[0].exp(), x[1].exp());
        let sa: Vec<(f64, f64)> = ax
            .iter()
            .map(|&t| {
                let y = rt::sigmoid(g * (t - FRAC_PI_2));
                (y, g * (t - FRAC_PI_2) * y * (1.0 - y))
            })
            .collect();
        let sb: Vec<(f64, f64)> = ax
            .iter()
            .map(|&t| {
                let y = rt::sigmoid(h * (t - FRAC_PI_2));
                (y, h * (t - FRAC_PI_2) * y * (1.0 - y))
            })
            .collect();
        let mut cost = 0.0;
        let (mut jtj, mut jtr) = ([[0.0; 2]; 2], [0.0; 2]);
        for (i, a) in sa.iter().enumerate() {
            for (j, b) in sb.iter().enumerate() {
                let r = a.0 * b.0 - s[i * ax.len() + j];
                cost += r * r;
                if jac {
                    let jr = [a.1 * b.0, a.0 * b.1];
                    for u in 0..2 {
                        jtr[u] += jr[u] * r;
                        for v in 0..2 {
                            jtj[u][v] += jr[u] * jr[v];
                        }
                    }
                }
            }
        }
        (cost, jtj, jtr)
    };
    let mut x = start;
    let mut mu = 1e-3;
    let (mut cost, mut jtj, mut jtr) = eval(x, true);
    for it in 1..=LM_MAX_ITERS {
        // Solve (JᵀJ + μ diag(JᵀJ)) δ = −Jᵀr (2×2).
        let a = [[jtj[0][0] * (1.0 + mu), jtj[0][1]], [jtj[1][0], jtj[1][1] * (1.0 + mu)]];
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        if det.abs() <= 0.0 || !det.is_finite() {
            return (x, it, false);
        }
        let d = [
            -(a[1][1] * jtr[0] - a[0][1] * jtr[1]) / det,
            -(a[0][0] * jtr[1] - a[1][0] * jtr[0]) / det,
        ];
        let xn = [x[0] + d[0], x[1] + d[1]];
        let (cn, _, _) = eval(xn, false);
        if cn <= cost {
            // Converged when the step or the relative decrease is negligible (the Σ|r|^p
            // cost is very flat near its minimum).
            let small = d[0].abs().max(d[1].abs()) < LM_STEP_TOL || cost - cn <= LM_COST_TOL * cost;
            x = xn;
            (cost, jtj, jtr) = eval(x, true);
            mu = (mu * 0.3).max(1e-12);
            if small {
                return (x, it, true);
            }
        } else {
            mu *= 10.0;
            if mu > 1e12 {
                // No descent direction left at this precision: a minimum.
                return (x, it, true);
            }
        }
    }
    (x, LM_MAX_ITERS, false)
}

/// The logistic model refitted at one γ: LM least squares on the width-adapted grid,
/// then a minimax polish (Nelder–Mead on the max residual) started from it.
pub fn fit_logistic(gamma: f64) -> LogisticFit {
    let ax = fit_axis(gamma);
    let s = s_hat_grid(&ax, gamma);
    // Start: the logistic with the marginals' slope at the axis, σ'(0) = 1/4.
    let eps = 1e-3 / gamma.sqrt();
    let slope = |c: usize| {
        let f = |x: f64| {
            if c == 0 {
                s_hat_fast(x, PI, gamma)
            } else {
                s_hat_fast(PI, x, gamma)
            }
        };
        4.0 * (f(FRAC_PI_2 + eps) - f(FRAC_PI_2 - eps)) / (2.0 * eps)
    };
    let start = [slope(0).ln(), slope(1).ln()];
    let (x1, it1, ok1) = lm(&ax, &s, start);
    let (x2, it2, ok2) = minimax(&ax, &s, x1);
    let (g, h) = (x2[0].exp(), x2[1].exp());
    let mut max_err: f64 = 0.0;
    for (i, &t) in ax.iter().enumerate() {
        for (j, &p) in ax.iter().enumerate() {
            let f = rt::sigmoid(g * (t - FRAC_PI_2)) * rt::sigmoid(h * (p - FRAC_PI_2));
            max_err = max_err.max((f - s[i * ax.len() + j]).abs());
        }
    }
    LogisticFit {
        g,
        h,
        max_err,
        iterations: it1 + it2,
        converged: ok1 && ok2 && g.is_finite() && h.is_finite(),
    }
}

/// Max |model − Ŝ| over the width-adapted grid at γ (fast evaluation of Ŝ).
pub fn max_error_on_grid(model: &dyn Fn(f64, f64) -> f64, gamma: f64) -> (f64, f64, f64) {
    let ax = fit_axis(gamma);
    let mut worst = (0.0, 0.0, 0.0);
    for &t in &ax {
        for &p in &ax {
            let e = (model(t, p) - s_hat_fast(t, p, gamma)).abs();
            if e > worst.0 {
                worst = (e, t, p);
            }
        }
    }
    worst
}

/// Nodes per axis (uniform in u, quadrant x ≤ π/2) of the grid on which the rank-1
/// correction of the separable model is computed; the table's u nodes (129) are
/// reached by cubic interpolation (every 4th table node is a correction node).
pub const CORRECTION_NODES: usize = 33;
/// Power-iteration stop: relative change of the singular value.
const POWER_TOL: f64 = 1e-13;
/// Power-iteration limit.
const POWER_MAX_ITERS: u32 = 2000;

/// The rank-1 correction C(θ) D(φ) of the separable model at one γ.
#[derive(Debug, Clone)]
pub struct Rank2 {
    /// C at the correction nodes u_k = k/(n − 1) (angle unwarp(u_k) ≤ π/2).
    pub c: Vec<f64>,
    /// D at the same nodes.
    pub d: Vec<f64>,
    /// max |Ŝ − (A B + C D)| over the correction grid.
    pub max_residual: f64,
    /// Power iterations.
    pub iterations: u32,
    /// Whether the power iteration converged.
    pub converged: bool,
}

/// Leading singular pair of R = Ŝ − A B on the quadrant grid at γ. R is odd under
/// θ → π − θ and under φ → π − φ, so the quadrant determines the whole: the singular
/// vectors on [0, π] are the odd extensions of the quadrant's. Normalised so that
/// max |C| = max |D| and Σ C ≥ 0 (smooth across γ, so interpolation in γ is meaningful).
pub fn rank2_compute(gamma: f64) -> Rank2 {
    let n = CORRECTION_NODES;
    let x: Vec<f64> = (0..n).map(|k| unwarp(k as f64 / (n - 1) as f64, gamma)).collect();
    let a: Vec<f64> = x.iter().map(|&t| s_hat_fast(t, PI, gamma)).collect();
    let b: Vec<f64> = x.iter().map(|&p| s_hat_fast(PI, p, gamma)).collect();
    let mut r = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            r[i * n + j] = s_hat_fast(x[i], x[j], gamma) - a[i] * b[j];
        }
    }
    let (mut c, mut d) = (vec![0.0; n], vec![1.0; n]);
    let (mut sigma, mut converged, mut iterations) = (0.0f64, false, 0);
    for it in 1..=POWER_MAX_ITERS {
        let dd: f64 = d.iter().map(|v| v * v).sum();
        for i in 0..n {
            c[i] = (0..n).map(|j| r[i * n + j] * d[j]).sum::<f64>() / dd;
        }
        let cc: f64 = c.iter().map(|v| v * v).sum();
        if cc == 0.0 {
            // R ≡ 0 (exactly separable): no correction.
            converged = true;
            iterations = it;
            break;
        }
        for j in 0..n {
            d[j] = (0..n).map(|i| r[i * n + j] * c[i]).sum::<f64>() / cc;
        }
        let s = cc.sqrt() * d.iter().map(|v| v * v).sum::<f64>().sqrt();
        iterations = it;
        if (s - sigma).abs() <= POWER_TOL * s {
            converged = true;
            break;
        }
        sigma = s;
    }
    let (mc, md) = (
        c.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        d.iter().fold(0.0f64, |m, v| m.max(v.abs())),
    );
    if mc > 0.0 && md > 0.0 {
        let sign = if c.iter().sum::<f64>() >= 0.0 { 1.0 } else { -1.0 };
        let k = (md / mc).sqrt();
        c.iter_mut().for_each(|v| *v *= sign * k);
        d.iter_mut().for_each(|v| *v *= sign / k);
    }
    let mut max_residual: f64 = 0.0;
    for i in 0..n {
        for j in 0..n {
            max_residual = max_residual.max((r[i * n + j] - c[i] * d[j]).abs());
        }
    }
    Rank2 {
        c,
        d,
        max_residual,
        iterations,
        converged,
    }
}

/// [`rank2_compute`], memoised per γ (bit pattern): every table node at that γ needs
/// it. The memo only avoids recomputation; the result is a pure function of γ, so the
/// build stays deterministic whatever thread computes it first.
fn rank2_correction(gamma: f64) -> std::sync::Arc<Rank2> {
    use std::collections::HashMap;
    use std::sync::{Arc, Mutex, OnceLock};
    static MEMO: OnceLock<Mutex<HashMap<u64, Arc<Rank2>>>> = OnceLock::new();
    let memo = MEMO.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(r) = memo.lock().ok().and_then(|m| m.get(&gamma.to_bits()).cloned()) {
        return r;
    }
    let r = Arc::new(rank2_compute(gamma));
    if let Ok(mut m) = memo.lock() {
        m.insert(gamma.to_bits(), r.clone());
    }
    r
}

/// Cubic Lagrange interpolation of samples at 0, 1, …, n − 1 at t ∈ [0, n − 1]
/// (stencil of 4 nodes, shifted inwards at the ends).
pub fn cubic_at(v: &[f64], t: f64) -> f64 {
    let n = v.len();
    let i = (t.floor() as isize - 1).clamp(0, n as isize - 4) as usize;
    let mut out = 0.0;
    for k in 0..4 {
        let mut w = 1.0;
        for m in 0..4 {
            if m != k {
                w *= (t - (i + m) as f64) / (k as f64 - m as f64);
            }
        }
        out += w * v[i + k];
    }
    out
}

/// Which ISG model a family object serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IsgModelKind {
    /// The published quartics (no table of its own; see [`IsgFamily`]).
    Paper,
    /// The refitted logistic model (`isg-refit`).
    Refit,
    /// The separable model (`isg-best`).
    Best,
}

impl IsgModelKind {
    /// Name used by `eval isg --model`.
    pub fn name(self) -> &'static str {
        match self {
            IsgModelKind::Paper => "paper",
            IsgModelKind::Refit => "refit",
            IsgModelKind::Best => "best",
        }
    }

    /// Parses `paper|refit|best`.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "paper" => Ok(IsgModelKind::Paper),
            "refit" => Ok(IsgModelKind::Refit),
            "best" => Ok(IsgModelKind::Best),
            _ => Err(format!("unknown isg model '{s}' (expected paper, refit or best)")),
        }
    }
}

/// The ISG family object for one model. `Refit` and `Best` are the two tabulated
/// families of the registry; `Paper` is only an `eval` view: it is built and loaded
/// like `Refit` (so the CLI machinery is unchanged) but its lookup evaluates the
/// published polynomials and ignores the table.
#[derive(Debug, Clone, Copy)]
pub struct IsgFamily {
    /// The model.
    pub model: IsgModelKind,
}

/// The runtime view of a model, as the checker and `eval` use it.
struct ModelLookup<M: IsgModel + Sync>(M);

impl<M: IsgModel + Sync> Lookup for ModelLookup<M> {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let (gamma, theta, phi) = (x[0], x[1], x[2]);
        let s_hat = self.0.s_hat(theta, phi, gamma)?;
        Ok(vec![s_hat, s_hat * rt::normaliser(gamma)])
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        let (gamma, theta, phi) = (x[0] as f32, x[1] as f32, x[2] as f32);
        let r = (self.0.s_hat_f32(theta, phi, gamma)).and_then(|s_hat| Ok((s_hat, self.0.s_f32(theta, phi, gamma)?)));
        Some(r.map(|(s_hat, s)| vec![s_hat.into(), s.into()]))
    }
}

impl View for IsgFamily {
    fn kind(&self) -> &'static str {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => rt::KIND_REFIT,
            IsgModelKind::Best => rt::KIND_BEST,
        }
    }

    fn inputs(&self) -> &'static [&'static str] {
        &["gamma", "theta", "phi"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["s_hat", "s"]
    }
    fn embedded(&self) -> &'static [u8] {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => lobefit_tables::embedded::ISG_REFIT,
            IsgModelKind::Best => lobefit_tables::embedded::ISG_BEST,
        }
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        match self.model {
            IsgModelKind::Paper => Ok(Box::new(ModelLookup(PaperIsg))),
            IsgModelKind::Refit => Ok(Box::new(ModelLookup(RefitIsg::from_table(table)?))),
            IsgModelKind::Best => Ok(Box::new(ModelLookup(BestIsg::from_table(table)?))),
        }
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let (gamma, theta, phi) = (x[0], x[1], x[2]);
        let s_hat = s_hat_reference(theta, phi, gamma)?;
        Ok(vec![s_hat, s_hat * normaliser(gamma)])
    }
    fn exact(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let (gamma, theta, phi) = (x[0], x[1], x[2]);
        check_domain(theta, phi, gamma)?;
        let s_hat = s_hat_fast(theta, phi, gamma);
        Ok(vec![s_hat, s_hat * normaliser(gamma)])
    }
}

impl Checked for IsgFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        let t = |output: &str, metric: &str, limit: f64| Threshold {
            output: output.into(),
            metric: metric.into(),
            limit,
        };
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => vec![
                t("s_hat", "offgrid.max_abs", REFIT_CHECK_LIMIT),
                t("s_hat", "grid.max_abs", REFIT_CHECK_LIMIT),
                t("s_hat_low_gamma", "offgrid.max_abs", REFIT_LOW_GAMMA_LIMIT),
                t("s_hat_low_gamma", "grid.max_abs", REFIT_LOW_GAMMA_LIMIT),
            ],
            IsgModelKind::Best => vec![
                t("s_hat", "offgrid.max_abs", BEST_CHECK_LIMIT),
                t("s_hat", "grid.max_abs", BEST_CHECK_LIMIT),
            ],
        }
    }
    fn checked(&self) -> &'static [&'static str] {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => &["s_hat", "s", "s_hat_low_gamma"],
            IsgModelKind::Best => &["s_hat", "s"],
        }
    }
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let mut got = runtime.lookup(x).map_err(|e| format!("lookup at {x:?}: {e}"))?;
        let mut want = self.reference(x).map_err(|e| format!("reference at {x:?}: {e}"))?;
        if self.model != IsgModelKind::Best {
            // Two promises: `s_hat` on γ ≥ 3 (the refit target's range) and
            // `s_hat_low_gamma` below it, where no logistic follows Ŝ as closely.
            // Each quantity is NaN on both sides (no promise) in the other range.
            let (g, w) = (got[0], want[0]);
            let low = x[0] < REFIT_TARGET_GAMMA_MIN;
            let skip = |v: f64, keep: bool| if keep { v } else { f64::NAN };
            got[0] = skip(g, !low);
            want[0] = skip(w, !low);
            got.push(skip(g, low));
            want.push(skip(w, low));
        }
        Ok(Some((got, want)))
    }
    fn node_inputs(&self, node: &[f64]) -> Vec<Vec<f64>> {
        // The logistic tables hold two slopes per γ that reach every (θ, φ): a 5 × 5
        // set around the axis (where Ŝ varies) and at the far edge π (where the
        // logistic shape errs most). The separable table's node holds A, C at
        // θ = unwarp(u) and B, D at φ = unwarp(u): checked where they meet, on the
        // stored angle and its mirror.
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => {
                let w = 1.0 / node[0].sqrt();
                let angles = [-2.0, -0.5, 1.0, 3.0, 1e9].map(|k| (FRAC_PI_2 + k * w).clamp(0.0, PI));
                angles
                    .iter()
                    .flat_map(|&t| angles.iter().map(move |&p| vec![node[0], t, p]))
                    .collect()
            }
            IsgModelKind::Best => {
                // A(x), B(x) where the node's two angles meet (and the mirror), and the
                // rank-1 term C(x)·D(φ) (and D(x)·C(θ)) at three angles of the other
                // axis: D is odd about π/2, so at φ = x alone it may be near zero.
                let (g, x) = (node[0], unwarp(node[1], node[0]));
                let mut pts = vec![vec![g, x, PI - x], vec![g, x, x]];
                for u in [0.3, 0.6, 0.9] {
                    let y = unwarp(u, g);
                    pts.push(vec![g, x, y]);
                    pts.push(vec![g, y, x]);
                }
                pts
            }
        }
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        // γ log-uniform over the checked range; angles 45 % uniform on [0, π], 45 % within
        // ±5 SG widths of the axis, where Ŝ varies, 10 % on the edges 0, π/2, π (the
        // corners patch integrals use; the logistic models err most at θ or φ = π).
        // Every model over the whole range the runtime serves, γ ∈ [0.5, 10⁴]; the
        // logistic models' promise differs below γ = 3 (see `check_point`).
        let gamma = rng
            .range(GAMMA_MIN.ln(), GAMMA_MAX.ln())
            .exp()
            .clamp(GAMMA_MIN, GAMMA_MAX);
        let w = 1.0 / gamma.sqrt();
        let angle = |rng: &mut Rng| {
            let r = rng.uniform();
            if r < 0.45 {
                rng.range(0.0, PI)
            } else if r < 0.9 {
                (FRAC_PI_2 + w * rng.range(-5.0, 5.0)).clamp(0.0, PI)
            } else {
                [0.0, FRAC_PI_2, PI][(rng.next_u64() % 3) as usize]
            }
        };
        let theta = angle(rng);
        let phi = angle(rng);
        vec![gamma, theta, phi]
    }
}

impl Fit for IsgFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        let common = "Normalised integral spherical Gaussian Ŝ(θ, φ; γ) = S/S(π,π) (Iwasaki et al. 2012 §4, \
             docs/math.md: isg, erratum E1): Ω(θ,φ) = (sinθ cosφ, cosθ, sinθ sinφ), θ ∈ [0,π] from +y, φ ∈ [0,π] azimuth \
             about +y from +x towards +z, SG axis +z at (π/2, π/2); S(π,π) = 2π/γ (1 − e^(−γ)). ";
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => format!(
                "{common}Refitted logistic model f = σ(g(γ)(θ − π/2)) σ(h(γ)(φ − π/2)): channels ln g, ln h \
                 on nodes uniform in ln γ, γ ∈ [0.5, 1e4]; interpolate linearly in ln γ. Checked on \
                 γ ∈ [3, 1e4] (the target's range); below γ = 3 the logistic shape errs by up to 0.062 (at γ = 0.5)."
            ),
            IsgModelKind::Best => format!(
                "{common}Rank-2 separable model Ŝ ≈ A(θ;γ) B(φ;γ) + C(θ;γ) D(φ;γ), A = Ŝ(θ,π), B = Ŝ(π,φ) \
                 (exact marginals), C D the leading singular pair of Ŝ − A B. Channels a, b, c, d for angles \
                 x ≤ π/2 on axes (γ: ln-uniform on [0.5, 1e4]; u = √((1 − e^{{−γq}})/(1 − e^{{−γ}})), \
                 q = 1 − sin x: uniform on [0, 1]); bilinear in (ln γ, u). For x > π/2 use \
                 A(x) = 1 − A(π − x), C(x) = −C(π − x), B and D likewise."
            ),
        }
    }
    fn axes(&self) -> Vec<Axis> {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => vec![gamma_axis(REFIT_NODES)],
            IsgModelKind::Best => vec![gamma_axis(BEST_GAMMA_NODES), warp_axis(BEST_U_NODES)],
        }
    }
    fn channels(&self) -> Vec<Channel> {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => vec![
                Channel {
                    name: rt::REFIT_CHANNELS[0].into(),
                    unit: "1/rad".into(),
                    encoding: Encoding::Log,
                    description: "logistic slope g(γ) in θ".into(),
                },
                Channel {
                    name: rt::REFIT_CHANNELS[1].into(),
                    unit: "1/rad".into(),
                    encoding: Encoding::Log,
                    description: "logistic slope h(γ) in φ".into(),
                },
            ],
            IsgModelKind::Best => vec![
                Channel {
                    name: rt::BEST_CHANNELS[0].into(),
                    unit: "1".into(),
                    encoding: Encoding::Linear,
                    description: "A(θ) = Ŝ(θ, π) at θ = unwarp(u) ≤ π/2".into(),
                },
                Channel {
                    name: rt::BEST_CHANNELS[1].into(),
                    unit: "1".into(),
                    encoding: Encoding::Linear,
                    description: "B(φ) = Ŝ(π, φ) at φ = unwarp(u) ≤ π/2".into(),
                },
                Channel {
                    name: rt::BEST_CHANNELS[2].into(),
                    unit: "1".into(),
                    encoding: Encoding::Linear,
                    description: "C(θ), rank-1 correction factor in θ (odd: C(π−θ) = −C(θ))".into(),
                },
                Channel {
                    name: rt::BEST_CHANNELS[3].into(),
                    unit: "1".into(),
                    encoding: Encoding::Linear,
                    description: "D(φ), rank-1 correction factor in φ (odd: D(π−φ) = −D(φ))".into(),
                },
            ],
        }
    }
    fn method(&self) -> String {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => format!(
                "per-γ Levenberg-Marquardt least squares on (ln g, ln h), then minimax polish (Nelder-Mead \
                 on the max residual), on a {GRID_HALF}+{GRID_HALF} point per axis grid (uniform + ±{GRID_WIDTHS} SG widths); \
                 Ŝ by the 1-D arc reduction with Gauss-Legendre panels"
            ),
            IsgModelKind::Best => format!(
                "exact marginals Ŝ(θ,π), Ŝ(π,φ) by the 1-D arc reduction with Gauss-Legendre panels; correction \
                 C D = leading singular pair (power iteration) of Ŝ − A B on a {CORRECTION_NODES}² quadrant grid \
                 uniform in u, cubic Lagrange interpolation to the table nodes"
            ),
        }
    }
    fn settings(&self) -> Vec<(String, String)> {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => vec![
                (
                    "grid".into(),
                    format!("{GRID_HALF} uniform + {GRID_HALF} within ±{GRID_WIDTHS}/√γ"),
                ),
                ("nm_step".into(), format!("{NM_STEP:e}")),
                ("nm_sd_tol".into(), format!("{NM_SD_TOL:e}")),
                ("nm_max_iters".into(), NM_MAX_ITERS.to_string()),
                ("lm_step_tol".into(), format!("{LM_STEP_TOL:e}")),
                ("lm_max_iters".into(), LM_MAX_ITERS.to_string()),
            ],
            IsgModelKind::Best => vec![(
                "fast_rule".into(),
                "16-point Gauss-Legendre, cosine-mapped panels".into(),
            )],
        }
    }
    fn residual_meaning(&self) -> &'static str {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => {
                "max |f − Ŝ| of the logistic fit on its fitting grid at that γ"
            }
            IsgModelKind::Best => "max |Ŝ − (A B + C D)| on the correction grid at that γ (before interpolation)",
        }
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        match self.model {
            IsgModelKind::Paper | IsgModelKind::Refit => {
                let f = fit_logistic(node[0]);
                Fitted {
                    values: vec![f.g, f.h],
                    residual: f.max_err,
                    iterations: f.iterations,
                    converged: f.converged,
                }
            }
            IsgModelKind::Best => {
                let (gamma, u) = (node[0], node[1]);
                let x = unwarp(u, gamma);
                let a = s_hat_fast(x, PI, gamma);
                let b = s_hat_fast(PI, x, gamma);
                let defect =
                    (a + s_hat_fast(PI - x, PI, gamma) - 1.0).abs() + (b + s_hat_fast(PI, PI - x, gamma) - 1.0).abs();
                let r2 = rank2_correction(gamma);
                let t = u * (CORRECTION_NODES - 1) as f64;
                let (c, d) = (cubic_at(&r2.c, t), cubic_at(&r2.d, t));
                Fitted {
                    values: vec![a, b, c, d],
                    residual: r2.max_residual,
                    iterations: r2.iterations,
                    converged: defect < SYMMETRY_TOL && r2.converged && [a, b, c, d].iter().all(|v| v.is_finite()),
                }
            }
        }
    }
}

/// Largest tolerated symmetry defect of a computed marginal pair: the fast rule is
/// good to ~1e-9, so a larger defect is a failed evaluation.
const SYMMETRY_TOL: f64 = 1e-8;

/// `eval isg --model`.
const MODEL_FLAG: lobefit_core::family::EvalFlag = lobefit_core::family::EvalFlag {
    name: "model",
    help: "paper | refit | best (default best)",
    count: false,
};

/// The family `lobefit eval isg --model paper|refit|best` queries (default `best`, the
/// most accurate); other flags are refused.
pub fn for_eval(flags: &lobefit_core::family::EvalFlags) -> Result<Box<dyn View>, String> {
    flags.only("isg", &[MODEL_FLAG])?;
    let model = IsgModelKind::parse(flags.text("model").as_deref().unwrap_or("best"))?;
    Ok(Box::new(IsgFamily { model }))
}

/// A model Ŝ(θ, φ, γ) with its name.
type NamedModel = (&'static str, Box<dyn Fn(f64, f64, f64) -> f64>);

/// The three models as functions of (θ, φ) at γ, through the runtime (embedded tables).
fn runtime_models() -> Result<[NamedModel; 3], String> {
    let refit = RefitIsg::embedded().map_err(|e| e.to_string())?;
    let best = BestIsg::embedded().map_err(|e| e.to_string())?;
    Ok([
        ("paper", Box::new(|t, p, g| PaperIsg.s_hat_unchecked(t, p, g))),
        ("refit", Box::new(move |t, p, g| refit.s_hat_unchecked(t, p, g))),
        ("best", Box::new(move |t, p, g| best.s_hat_unchecked(t, p, g))),
    ])
}

/// Max |model − Ŝ| of each runtime model (paper, refit, best) at γ over the
/// width-adapted grid ([`fit_axis`]), Ŝ by the fast evaluation.
pub fn model_errors(gamma: f64) -> Result<[f64; 3], String> {
    let models = runtime_models()?;
    let ax = fit_axis(gamma);
    let s = s_hat_grid(&ax, gamma);
    let mut out = [0.0f64; 3];
    for (k, (_, m)) in models.iter().enumerate() {
        for (i, &t) in ax.iter().enumerate() {
            for (j, &p) in ax.iter().enumerate() {
                out[k] = out[k].max((m(t, p, gamma) - s[i * ax.len() + j]).abs());
            }
        }
    }
    Ok(out)
}

/// `lobefit plot isg`: the paper's Figure 3 (Ŝ, the model, their difference) at
/// γ = 100 and 1000 for the published model, with the refit and best differences
/// beside it, and max |f − Ŝ| against γ for the three models.
pub fn plot(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_core::plot::{heatmaps, line_chart, ColourScale, Heatmap, LineChart, Series};
    const N: usize = 121;
    let models = runtime_models()?;
    let mut files = Vec::new();
    for gamma in [100.0f64, 1000.0] {
        // ±6 SG widths around the axis: outside, Ŝ is flat (0, 1 or a marginal).
        let half = (GRID_WIDTHS / gamma.sqrt()).min(FRAC_PI_2);
        let (lo, hi) = (FRAC_PI_2 - half, FRAC_PI_2 + half);
        let at = |k: usize| lo + (hi - lo) * (k as f64 + 0.5) / N as f64;
        let mut exact = Vec::with_capacity(N * N);
        for iy in 0..N {
            for ix in 0..N {
                exact.push(s_hat_fast(at(iy), at(ix), gamma));
            }
        }
        let eval = |m: &dyn Fn(f64, f64, f64) -> f64| -> Vec<f64> {
            let mut v = Vec::with_capacity(N * N);
            for iy in 0..N {
                for ix in 0..N {
                    v.push(m(at(iy), at(ix), gamma));
                }
            }
            v
        };
        let panel = |title: String, values: Vec<f64>, colour_label: &str, log: bool| Heatmap {
            title,
            x_label: "φ (rad)".into(),
            y_label: "θ (rad)".into(),
            x_range: (lo, hi),
            y_range: (lo, hi),
            nx: N,
            ny: N,
            values,
            colour_label: colour_label.into(),
            log_colour: log,
            scale: ColourScale::Own,
        };
        let mut panels = vec![panel(format!("Ŝ, γ = {gamma}"), exact.clone(), "Ŝ", false)];
        let paper = eval(&*models[0].1);
        panels.push(panel(format!("paper model f, γ = {gamma}"), paper, "f", false));
        for (name, m) in &models {
            let diff: Vec<f64> = eval(&**m).iter().zip(&exact).map(|(f, e)| (f - e).abs()).collect();
            let max = diff.iter().copied().fold(0.0, f64::max);
            panels.push(panel(format!("|{name} − Ŝ|, max {max:.2e}"), diff, "|f − Ŝ|", false));
        }
        files.push(heatmaps(&dir.join(format!("isg-fig3-gamma{gamma}.png")), &panels, 3)?);
    }
    let gammas: Vec<f64> = (0..=48)
        .map(|i| (GAMMA_MIN.ln() + (GAMMA_MAX / GAMMA_MIN).ln() * i as f64 / 48.0).exp())
        .collect();
    let errs: Vec<[f64; 3]> = gammas.iter().map(|&g| model_errors(g)).collect::<Result<_, _>>()?;
    let series = models
        .iter()
        .enumerate()
        .map(|(k, (name, _))| Series {
            name: format!("{name} (max {:.2e})", errs.iter().map(|e| e[k]).fold(0.0, f64::max)),
            points: gammas.iter().zip(&errs).map(|(&g, e)| (g, e[k])).collect(),
        })
        .chain([
            Series {
                name: "refit target 0.02 (γ ≥ 3)".into(),
                points: vec![(REFIT_TARGET_GAMMA_MIN, REFIT_TARGET), (GAMMA_MAX, REFIT_TARGET)],
            },
            Series {
                name: "best-model target 0.005".into(),
                points: vec![(GAMMA_MIN, BEST_TARGET), (GAMMA_MAX, BEST_TARGET)],
            },
        ])
        .collect();
    files.push(line_chart(
        &dir.join("isg-max-error.png"),
        &LineChart {
            title: "ISG models: max |f − Ŝ| over (θ, φ) vs γ".into(),
            x_label: "γ".into(),
            y_label: "max |f − Ŝ|".into(),
            log_x: true,
            log_y: true,
            series,
        },
    )?);
    Ok(files)
}

/// isg-refit and isg-best in the list of families (`crate::entries`), and
/// `lobefit eval isg --model paper|refit|best`.
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| {
        vec![
            Box::new(IsgFamily {
                model: IsgModelKind::Refit,
            }),
            Box::new(IsgFamily {
                model: IsgModelKind::Best,
            }),
        ]
    },
    eval: Some(|name, flags, opts| match name {
        "isg" => for_eval(flags),
        _ => crate::without_flags(name, flags, opts),
    }),
    eval_names: &["isg"],
    eval_flags: &[("isg", &[MODEL_FLAG])],
    gpu: &[gpu::REFIT, gpu::BEST],
    closed_form: None,
    plot: Some(("isg", plot)),
    eval_help: "\
isg  [--model paper|refit|best] (default best); isg-refit, isg-best: that model
  in   `gamma`    SG sharpness, [0.5, 1e4]
       `theta`, `phi`  corner of the patch [0, theta] × [0, phi] (rad, each [0, π]):
                  theta from +y, phi the azimuth about +y from +x; SG axis +z
  out  `s_hat`    normalised integral S/S(π, π), in [0, 1]
       `s`        the integral S of exp(gamma (ω·z − 1)) over the patch (sr)
",
};

#[cfg(test)]
mod tests {
    use super::*;

    /// docs/math.md, isg / E1: the published polynomials, evaluated as printed, reproduce the
    /// paper's quoted max errors 0.0966 (γ = 100) and 0.0251 (γ = 1000) within 10 %.
    /// The maximum over the width-adapted grid is confirmed with the checker's
    /// quadrature at the arg-max point.
    #[test]
    fn paper_errors_reproduced() {
        for (gamma, quoted) in [(100.0, 0.0966), (1000.0, 0.0251)] {
            let m = |t, p| PaperIsg.s_hat(t, p, gamma).unwrap();
            let (e, t, p) = max_error_on_grid(&m, gamma);
            let r = s_hat_reference(t, p, gamma).unwrap();
            let e_ref = (m(t, p) - r).abs();
            eprintln!("paper model at γ = {gamma}: max |f − Ŝ| = {e:.4} at ({t:.4}, {p:.4}); reference {e_ref:.4}; quoted {quoted}");
            assert!((e_ref - e).abs() < 1e-8);
            assert!((e / quoted - 1.0).abs() < 0.10, "{e} vs {quoted}");
        }
        // docs/math.md, erratum E3: far worse outside ≈ [100, 1000] — ≈ 0.59 at γ = 1, ≈ 0.17 at 10^4;
        // the worst γ of the range is its lower end, 0.5.
        for (gamma, spec) in [(0.5, 0.60), (1.0, 0.59), (1e4, 0.17)] {
            let m = |t, p| PaperIsg.s_hat(t, p, gamma).unwrap();
            let (e, _, _) = max_error_on_grid(&m, gamma);
            eprintln!("paper model at γ = {gamma}: max |f − Ŝ| = {e:.4}");
            assert!((e - spec).abs() < 0.01, "{gamma}: {e}");
        }
    }

    /// The symmetry-filled grid equals direct evaluation everywhere.
    #[test]
    fn grid_symmetry_fill_is_exact() {
        for &g in &[0.5, 40.0, 1e4] {
            let ax = fit_axis(g);
            assert!((ax[ax.len() / 2] - FRAC_PI_2).abs() < 1e-15 && ax[0] == 0.0 && ax[ax.len() - 1] == PI);
            let s = s_hat_grid(&ax, g);
            for (i, &t) in ax.iter().enumerate().step_by(7) {
                for (j, &p) in ax.iter().enumerate().step_by(5) {
                    let d = s_hat_fast(t, p, g);
                    assert!((s[i * ax.len() + j] - d).abs() < 1e-9, "{g} {t} {p}");
                }
            }
        }
    }

    /// Why g(γ), h(γ) are a table over ln γ and not the paper's quartic in γ/100: the
    /// least-squares quartic through the refitted slopes at the table's 65 nodes (a
    /// fair, better fit than the published one) still misses the 0.02 target by far
    /// at small γ, because g ~ 1.72√γ is not polynomial over four decades.
    #[test]
    fn quartic_in_gamma_cannot_meet_the_target() {
        let t = RefitIsg::embedded().unwrap();
        let ax = gamma_axis(REFIT_NODES);
        let nodes: Vec<f64> = (0..REFIT_NODES).map(|i| ax.node(i)).collect();
        // Least squares in x = γ/1e4 ∈ (0, 1] (scaled for conditioning; same polynomial).
        let x: Vec<f64> = nodes.iter().map(|g| g / 1e4).collect();
        let quartic = |k: usize| -> Vec<f64> {
            let y: Vec<f64> = nodes
                .iter()
                .map(|&g| {
                    let (gs, hs) = t.slopes(g).unwrap();
                    if k == 0 {
                        gs
                    } else {
                        hs
                    }
                })
                .collect();
            lobefit_core::eigen::polyfit(&x, &y, 4).unwrap()
        };
        let (cg, ch) = (quartic(0), quartic(1));
        let eval = |c: &[f64], g: f64| c.iter().rev().fold(0.0, |acc, k| acc * (g / 1e4) + k);
        let mut worst: f64 = 0.0;
        for gamma in [3.0, 10.0, 100.0, 1000.0, 1e4] {
            let (g, h) = (eval(&cg, gamma), eval(&ch, gamma));
            let m = |t: f64, p: f64| rt::sigmoid(g * (t - FRAC_PI_2)) * rt::sigmoid(h * (p - FRAC_PI_2));
            let (e, _, _) = max_error_on_grid(&m, gamma);
            eprintln!("least-squares quartic at γ = {gamma}: g = {g:.3}, h = {h:.3}, max |f − Ŝ| = {e:.4}");
            worst = worst.max(e);
        }
        assert!(worst > 0.1, "{worst}");
    }

    /// The logistic shape's own floor: the minimax (g, h) at γ = 3 still errs by more
    /// than the 0.02 target (at θ ≈ 2.78, φ = π, where σ cannot reach 1 fast enough), while
    /// from γ = 3.3 on it meets it; at large γ the floor is ≈ 0.0166 (the target's estimate: ≈ 0.017).
    /// The per-γ fit is checked against the reference at its worst grid point.
    #[test]
    fn refit_target_infeasible_just_above_three() {
        for (gamma, lo, hi) in [(3.0, 0.0215, 0.0225), (3.3, 0.018, 0.020), (1e4, 0.016, 0.0175)] {
            let f = fit_logistic(gamma);
            assert!(f.converged, "{gamma}");
            let m = |t: f64, p: f64| rt::sigmoid(f.g * (t - FRAC_PI_2)) * rt::sigmoid(f.h * (p - FRAC_PI_2));
            let (e, t, p) = max_error_on_grid(&m, gamma);
            let e_ref = (m(t, p) - s_hat_reference(t, p, gamma).unwrap()).abs();
            eprintln!(
                "γ = {gamma}: minimax logistic g = {:.4}, h = {:.4}, max error {e_ref:.4} at ({t:.3}, {p:.3})",
                f.g, f.h
            );
            assert!((e - e_ref).abs() < 1e-8 && (e - f.max_err).abs() < 1e-12);
            assert!((lo..hi).contains(&e_ref), "{gamma}: {e_ref}");
        }
    }
}
