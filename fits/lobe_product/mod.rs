//! lobe-product tables (Meunier et al. 2009, §4.1), variants `energy` and `l2`.
//!
//! The fast fit (default) is one-dimensional: the axis is the closed-form peak
//! ([`lobefit_tables::lobe_product::peak_angle`], the paper's Nelder–Mead step solved
//! exactly), p_r follows from e_r in closed form (variable projection for `l2`, the
//! integral constraint for `energy`), and e_r minimises the L2 residual by Brent in
//! ln(1 + e). Every integral is W(E)·(1-D in-plane integral) (module docs of the
//! runtime), the in-plane part by a tanh-sinh rule split at the common peak and
//! truncated where log-concavity bounds the integrand below e^{−50}.
//!
//! The checker's reference ([`reference`]) shares none of this: it integrates with the
//! Gauss–Kronrod rule of `core/quad.rs` (W(E) included, no Γ function), finds peaks by
//! bisection, and minimises by golden-section search. The separation of variables
//! itself is verified against a plain 2-D quadrature in spherical coordinates (tests).

pub mod gpu;
pub mod paper;

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::brent::BrentOpt;

use lobefit_tables::format::Threshold;
use lobefit_tables::glam::DVec3;
use lobefit_tables::lobe_product::{self as rt, ln_model, ln_w, lobe_ln, peak_angle, LobeProduct, Variant, E_MAX};
use lobefit_tables::{Channel, LoadError, Lobe, LookupError, Table};
use rayon::prelude::*;

use crate::Method;
use lobefit_core::family::{Checked, Extra, Fit, Fitted, Lookup, View};
use lobefit_core::quad::gauss_kronrod;
use lobefit_core::rng::Rng;
use lobefit_tables::error::short;

/// Nodes per exponent axis (uniform in ln(1 + e) on [0, 10⁵]).
pub const N_E: u32 = 48;
/// Nodes on the α axis (see `lobefit_tables::lobe_product::axes`).
pub const N_ALPHA: u32 = 96;
/// Tanh-sinh step and half-range: 2·(3.2·16) + 1 nodes per half-interval gave
/// agreement with adaptive Gauss–Kronrod to 1e-11 relative (test below).
const TS_H: f64 = 1.0 / 16.0;
const TS_T: f64 = 3.2;
/// Truncation of the in-plane integral at K/√E from the peak: log-concavity bounds
/// the integrand by exp(−E x²/2) = e^{−K²/2} there.
const TRUNC_K: f64 = 10.0;
/// Brent tolerance on x = ln(1 + e_r): 1e-7 moves e_r by 1e-7 relative, far below the
/// interpolation error (~1e-4) and near the f32 storage step (6e-8).
const BRENT_TOL: f64 = 1e-7;
const MAX_ITERS: u64 = 200;
/// Half-width (in ln(1 + e_r)) of the fit's second, local Brent search.
const POLISH: f64 = 0.1;

/// Fraction of min(∫Ψ1, ∫Ψ2) below which a product is negligible for the checker
/// (docs/math.md, lobe-product: accuracy is promised where ∫Ψ1Ψ2 ≥ 1e-6·min(∫Ψ1, ∫Ψ2)).
pub const RELEVANCE: f64 = 1e-6;
/// Products below this fraction of min(∫Ψ1, ∫Ψ2) may keep an e_r on the search bound:
/// the family's own relevance limit.
const NEGLIGIBLE: f64 = RELEVANCE;
/// Relative L2 residuals below 0.1 % of the product's norm count as equal in the
/// checker: near α = 0 the optimum tends to 0 and any ratio to it is meaningless.
pub const RESIDUAL_FLOOR: f64 = 1e-3;

/// Off-grid promise of both variants: the looked-up lobe's relative L2 residual is
/// within 5 % of the reference optimum's (above [`RESIDUAL_FLOOR`]).
pub const L2_RESIDUAL_MAX_REL: f64 = 0.05;
/// At grid nodes the stored lobe is the fit itself: its residual is within 0.1 % of
/// the reference optimum's (measured: 1.2e-5), so a changed exponent or amplitude
/// shows long before it costs the off-grid promise.
pub const NODE_RESIDUAL_MAX_REL: f64 = 1e-3;
/// At grid nodes the stored integral is within 1e-4 relative of quadrature (measured:
/// 6e-8, the f32 step of the stored logarithm), a hundredth of the off-grid median
/// promise.
pub const NODE_INTEGRAL_MAX_REL: f64 = 1e-4;

/// Tanh-sinh nodes and weights on [0, 1] (clustered at both ends).
fn ts_rule() -> &'static [(f64, f64)] {
    static RULE: std::sync::OnceLock<Vec<(f64, f64)>> = std::sync::OnceLock::new();
    RULE.get_or_init(|| {
        let n = (TS_T / TS_H).round() as i32;
        (-n..=n)
            .filter_map(|k| {
                let t = k as f64 * TS_H;
                let u = FRAC_PI_2 * t.sinh();
                // x = (1 + tanh u)/2 and 1 − x, both without cancellation.
                let em = (-2.0 * u).exp();
                let x = 1.0 / (1.0 + em);
                let w = TS_H * FRAC_PI_2 * t.cosh() / (2.0 * u.cosh().powi(2));
                (x > 0.0 && x < 1.0 && w > 0.0).then_some((x, w))
            })
            .collect()
    })
}

/// The in-plane integrals of one node: nodes on the lune, ln of the product relative
/// to its peak, ln cos of the angle to the product axis.
struct InPlane {
    /// Σ e_k ln cos(s − s_k) − g(β) at each node (≤ 0).
    ln_p: Vec<f64>,
    /// ln cos(s − β) at each node (the product axis at β).
    ln_r: Vec<f64>,
    /// Weights (with the Jacobian).
    w: Vec<f64>,
    /// E = e1 + e2.
    e_sum: f64,
}

impl InPlane {
    fn new(e1: f64, e2: f64, alpha: f64) -> InPlane {
        let beta = peak_angle(e1, e2, alpha);
        let (lo, hi) = (alpha - FRAC_PI_2, FRAC_PI_2);
        let e_sum = e1 + e2;
        let reach = if e_sum > 0.0 {
            TRUNC_K / e_sum.sqrt()
        } else {
            f64::INFINITY
        };
        let g = |s: f64| lobe_ln(e1, s.cos()) + lobe_ln(e2, (alpha - s).cos());
        let g0 = g(beta);
        let mut ip = InPlane {
            ln_p: Vec::new(),
            ln_r: Vec::new(),
            w: Vec::new(),
            e_sum,
        };
        // Left piece [max(lo, β − reach), β] and right piece [β, min(hi, β + reach)].
        for (a, b) in [((beta - reach).max(lo), beta), (beta, (beta + reach).min(hi))] {
            let len = b - a;
            if len <= 0.0 {
                continue;
            }
            for &(x, w) in ts_rule() {
                let s = a + len * x;
                let v = g(s) - g0;
                if v > -700.0 {
                    ip.ln_p.push(v.min(0.0));
                    ip.ln_r.push((s - beta).cos().max(0.0).ln());
                    ip.w.push(w * len);
                }
            }
        }
        ip
    }

    /// ln ∫ exp(m·ln_p + e·ln_r) ds (m = 1 or 2).
    fn ln_int(&self, m: f64, e: f64) -> f64 {
        let mut sum = 0.0;
        for ((&lp, &lr), &w) in self.ln_p.iter().zip(&self.ln_r).zip(&self.w) {
            let x = m * lp + if e == 0.0 { 0.0 } else { e * lr };
            sum += w * x.exp();
        }
        sum.ln()
    }
}

/// The 1-D objective of one node: relative L2 residuals as functions of e_r.
struct Node {
    ip: InPlane,
    /// ln ∫P − g(β) (the peak factor cancels from every ratio below).
    ln_a: f64,
    /// ln ∫P² − 2g(β).
    ln_c: f64,
}

impl Node {
    fn new(e1: f64, e2: f64, alpha: f64) -> Node {
        let ip = InPlane::new(e1, e2, alpha);
        let e = ip.e_sum;
        let ln_a = ln_w(e) + ip.ln_int(1.0, 0.0);
        let ln_c = ln_w(2.0 * e) + ip.ln_int(2.0, 0.0);
        Node { ip, ln_a, ln_c }
    }

    /// ln ∫P Ψ_r − g(β) for exponent e.
    fn ln_b(&self, e: f64) -> f64 {
        ln_w(self.ip.e_sum + e) + self.ip.ln_int(1.0, e)
    }

    /// Squared relative L2 residual ‖P − pΨ_e‖²/‖P‖² at the optimal p, and ln p − g(β).
    fn l2(&self, e: f64) -> (f64, f64) {
        let ln_d = (TAU / (2.0 * e + 1.0)).ln();
        let ln_b = self.ln_b(e);
        let r = 1.0 - (2.0 * ln_b - self.ln_c - ln_d).exp();
        (r, ln_b - ln_d)
    }

    /// The same with p fixed by ∫pΨ_e = ∫P.
    fn energy(&self, e: f64) -> (f64, f64) {
        let ln_d = (TAU / (2.0 * e + 1.0)).ln();
        let ln_p = ((e + 1.0) / TAU).ln() + self.ln_a;
        let ln_b = self.ln_b(e);
        let r = 1.0 - 2.0 * (ln_p + ln_b - self.ln_c).exp() + (2.0 * ln_p + ln_d - self.ln_c).exp();
        (r, ln_p)
    }

    fn residual(&self, variant: Variant, e: f64) -> (f64, f64) {
        match variant {
            Variant::Energy => self.energy(e),
            Variant::L2 => self.l2(e),
        }
    }
}

struct Cost<'a> {
    node: &'a Node,
    variant: Variant,
}

impl CostFunction for Cost<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, x: &f64) -> Result<f64, Error> {
        Ok(self.node.residual(self.variant, x.exp_m1()).0)
    }
}

/// Upper end of the e_r search, in x = ln(1 + e). Relevant optima stay below
/// 4(e1 + e2) + 400 except for the `l2` fit of a sharp lobe clipped by a wide lobe's
/// horizon (a sliver), whose optimum runs to ~20(e1 + e2); 64(e1 + e2) + 1000 covers
/// both, and a relevant optimum on the bound fails the build.
fn x_hi(e_sum: f64) -> f64 {
    (64.0 * e_sum + 1000.0).ln_1p()
}

/// Result of the fast fit at one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FastFit {
    /// ln(∫Ψ1Ψ2 / M).
    pub c: f64,
    /// e_r.
    pub e_r: f64,
    /// ln(∫p_rΨ_r / ∫Ψ1Ψ2) (0 for `energy`).
    pub k: f64,
    /// Relative L2 residual ‖P − p_rΨ_r‖/‖P‖.
    pub residual: f64,
    /// Brent iterations.
    pub iterations: u32,
    /// Whether Brent converged strictly inside the search interval.
    pub converged: bool,
}

/// The fast fit of the product at (e1, e2, α).
pub fn fit_fast(variant: Variant, e1: f64, e2: f64, alpha: f64) -> FastFit {
    // α = π: the lobes are antipodal and the product is 0; nothing to fit. The model
    // and the fit's c both tend to a finite limit; store the value just inside.
    let alpha = alpha.min(PI * (1.0 - 1e-9));
    let node = Node::new(e1, e2, alpha);
    let c = node.ln_a + peak_ln(e1, e2, alpha) - ln_model(e1, e2, alpha);
    if e1 == 0.0 && e2 == 0.0 && alpha == 0.0 {
        // Two hemisphere indicators on the same axis: exactly the hemisphere, e_r = 0.
        return FastFit {
            c,
            e_r: 0.0,
            k: 0.0,
            residual: 0.0,
            iterations: 0,
            converged: true,
        };
    }
    let hi = x_hi(node.ip.e_sum);
    let solver = BrentOpt::new(0.0, hi).set_tolerance(BRENT_TOL, 1e-12);
    let (x, iters, ok) = match Executor::new(Cost { node: &node, variant }, solver)
        .configure(|s| s.max_iters(MAX_ITERS))
        .run()
    {
        Ok(res) => {
            let st = res.state();
            (
                st.get_best_param().copied().unwrap_or(f64::NAN),
                st.get_iter() as u32,
                st.get_termination_status().terminated(),
            )
        }
        Err(_) => (f64::NAN, MAX_ITERS as u32, false),
    };
    // Brent over the whole range may settle beside a narrow minimum (measured: the
    // l2 fit at e1 = 2.44, e2 = 10⁵, α = 1.547 stopped 1.1e-3 away in x, its residual
    // 1.6e-3 above the optimum's): a second Brent on ±0.1 around it, kept only where it
    // lowers the residual by more than rounding.
    let x = if x.is_finite() && x > 0.0 {
        let (lo, up) = ((x - POLISH).max(0.0), (x + POLISH).min(hi));
        let polish = BrentOpt::new(lo, up).set_tolerance(BRENT_TOL, 1e-12);
        match Executor::new(Cost { node: &node, variant }, polish)
            .configure(|s| s.max_iters(MAX_ITERS))
            .run()
        {
            Ok(res) => {
                let y = res.state().get_best_param().copied().unwrap_or(f64::NAN);
                let (fx, fy) = (
                    node.residual(variant, x.exp_m1()).0,
                    node.residual(variant, y.exp_m1()).0,
                );
                if fy < fx - 1e-9 * fx.abs() {
                    y
                } else {
                    x
                }
            }
            Err(_) => x,
        }
    } else {
        x
    };
    let e_r = x.exp_m1();
    let (r2, ln_p) = node.residual(variant, e_r);
    // ln(∫pΨ/∫P) = ln p + ln(2π/(e+1)) − ln ∫P (peak factors cancel).
    let k = match variant {
        Variant::Energy => 0.0,
        Variant::L2 => ln_p + (TAU / (e_r + 1.0)).ln() - node.ln_a,
    };
    let inside = x.is_finite() && x < hi * (1.0 - 1e-6);
    // Where the product is negligible (e.g. the far tail of a lobe clipped by a
    // hemisphere: a thin sliver no isotropic lobe fits), the L2 optimum may sit on the
    // search bound; that constrained optimum is stored. Anywhere a renderer could see
    // the product, an optimum on the bound is a failure.
    let ln_i = node.ln_a + peak_ln(e1, e2, alpha);
    let ln_min = (TAU / (1.0 + e1.max(e2))).ln();
    let negligible = ln_i - ln_min < NEGLIGIBLE.ln();
    FastFit {
        c,
        e_r,
        k,
        residual: r2.max(0.0).sqrt(),
        iterations: iters,
        converged: ok && (inside || negligible) && r2.is_finite(),
    }
}

fn peak_ln(e1: f64, e2: f64, alpha: f64) -> f64 {
    let b = peak_angle(e1, e2, alpha);
    lobe_ln(e1, b.cos()) + lobe_ln(e2, (alpha - b).cos())
}

// ---------------------------------------------------------------------------
// The checker's reference: Gauss–Kronrod only.

/// Reference tolerance of every integral (relative).
const REF_TOL: f64 = 1e-10;
const REF_INTERVALS: usize = 2000;

/// ln ∫_{−π/2}^{π/2} cos^{m}u du by Gauss–Kronrod (m ≥ 1).
fn ref_ln_w(m: f64) -> Result<f64, String> {
    let w = 1.0 / m.sqrt();
    let breaks: Vec<f64> = [-8.0, -4.0, -2.0, -1.0, 0.0, 1.0, 2.0, 4.0, 8.0]
        .iter()
        .map(|k| k * w)
        .collect();
    let q = gauss_kronrod(
        |u: f64| u.cos().max(0.0).powf(m),
        -FRAC_PI_2,
        FRAC_PI_2,
        &breaks,
        0.0,
        REF_TOL,
        REF_INTERVALS,
    );
    if !q.converged {
        return Err(format!("reference W({m}) did not converge"));
    }
    Ok(q.value.ln())
}

/// ln ∫ Π_k max(cos(s − s_k), 0)^{e_k} ds over the lune, by Gauss–Kronrod with the peak
/// located by bisection on the (monotone) derivative of the log-integrand.
fn ref_ln_inplane(lobes: &[(f64, f64)]) -> Result<f64, String> {
    let lo = lobes.iter().map(|l| l.1).fold(f64::NEG_INFINITY, f64::max) - FRAC_PI_2;
    let hi = lobes.iter().map(|l| l.1).fold(f64::INFINITY, f64::min) + FRAC_PI_2;
    if hi <= lo {
        return Ok(f64::NEG_INFINITY);
    }
    let e_sum: f64 = lobes.iter().map(|l| l.0).sum();
    let g = |s: f64| lobes.iter().map(|&(e, sk)| lobe_ln(e, (s - sk).cos())).sum::<f64>();
    let dg = |s: f64| {
        lobes
            .iter()
            .map(|&(e, sk)| if e == 0.0 { 0.0 } else { -e * (s - sk).tan() })
            .sum::<f64>()
    };
    // g is concave on the lune: bisection on g' finds its maximum.
    let (mut a, mut b) = (lo, hi);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if dg(m) > 0.0 {
            a = m;
        } else {
            b = m;
        }
    }
    let peak = 0.5 * (a + b);
    let g0 = g(peak);
    let width = if e_sum > 0.0 { 1.0 / e_sum.sqrt() } else { 1.0 };
    let mut breaks: Vec<f64> = [-16.0, -8.0, -4.0, -2.0, -1.0, 1.0, 2.0, 4.0, 8.0, 16.0]
        .iter()
        .map(|k| peak + k * width)
        .collect();
    breaks.push(peak);
    let q = gauss_kronrod(
        |s: f64| if s <= lo || s >= hi { 0.0 } else { (g(s) - g0).exp() },
        lo,
        hi,
        &breaks,
        0.0,
        REF_TOL,
        REF_INTERVALS,
    );
    if !q.converged {
        return Err(format!("reference in-plane integral did not converge for {lobes:?}"));
    }
    Ok(g0 + q.value.ln())
}

/// ln ∫ Π_k Ψ(·; a_k, e_k) dω for coplanar axes at in-plane angles s_k (reference).
pub fn ref_ln_product(lobes: &[(f64, f64)]) -> Result<f64, String> {
    let e_sum: f64 = lobes.iter().map(|l| l.0).sum();
    Ok(ref_ln_w(e_sum + 1.0)? + ref_ln_inplane(lobes)?)
}

/// Reference ∫Ψ1Ψ2 dω (sr).
pub fn reference_integral(e1: f64, e2: f64, alpha: f64) -> Result<f64, String> {
    static MEMO: lobefit_core::memo::Memo<3, f64> = lobefit_core::memo::Memo::new();
    MEMO.get([e1, e2, alpha], || reference_integral_computed(e1, e2, alpha))
}

/// [`reference_integral`], computed.
fn reference_integral_computed(e1: f64, e2: f64, alpha: f64) -> Result<f64, String> {
    Ok(ref_ln_product(&[(e1, 0.0), (e2, alpha)])?.exp())
}

/// Reference relative L2 residual ‖Ψ1Ψ2 − pΨ(·; a_r, e)‖/‖Ψ1Ψ2‖ of the lobe with
/// axis at in-plane angle `s_r` (a1 at 0, a2 at α).
pub fn reference_residual(e1: f64, e2: f64, alpha: f64, p: f64, s_r: f64, e: f64) -> Result<f64, String> {
    let ln_c = ref_ln_product(&[(2.0 * e1, 0.0), (2.0 * e2, alpha)])?;
    let ln_b = ref_ln_product(&[(e1, 0.0), (e2, alpha), (e, s_r)])?;
    let d = TAU / (2.0 * e + 1.0);
    let r = 1.0 - 2.0 * p * (ln_b - ln_c).exp() + p * p * d * (-ln_c).exp();
    Ok(r.max(0.0).sqrt())
}

/// The reference optimum of a variant at (e1, e2, α) with the product axis at the
/// peak: golden-section search over ln(1 + e) on Gauss–Kronrod residuals.
/// Returns (relative residual, e_r).
pub fn reference_optimum(variant: Variant, e1: f64, e2: f64, alpha: f64) -> Result<(f64, f64), String> {
    static MEMO: lobefit_core::memo::Memo<4, (f64, f64)> = lobefit_core::memo::Memo::new();
    MEMO.get([f64::from(variant as u8), e1, e2, alpha], || {
        reference_optimum_computed(variant, e1, e2, alpha)
    })
}

/// [`reference_optimum`], computed.
fn reference_optimum_computed(variant: Variant, e1: f64, e2: f64, alpha: f64) -> Result<(f64, f64), String> {
    let s_r = peak_angle(e1, e2, alpha);
    let ln_a = ref_ln_product(&[(e1, 0.0), (e2, alpha)])?;
    let ln_c = ref_ln_product(&[(2.0 * e1, 0.0), (2.0 * e2, alpha)])?;
    let err = std::cell::RefCell::new(None);
    let f = |x: f64| -> f64 {
        let e = x.exp_m1();
        let d = TAU / (2.0 * e + 1.0);
        match ref_ln_product(&[(e1, 0.0), (e2, alpha), (e, s_r)]) {
            Ok(ln_b) => match variant {
                Variant::L2 => 1.0 - (2.0 * ln_b - ln_c).exp() / d,
                Variant::Energy => {
                    let p = (e + 1.0) / TAU * ln_a.exp();
                    1.0 - 2.0 * p * (ln_b - ln_c).exp() + p * p * d * (-ln_c).exp()
                }
            },
            Err(e) => {
                *err.borrow_mut() = Some(e);
                f64::NAN
            }
        }
    };
    let (mut a, mut b) = (0.0, x_hi(e1 + e2));
    let gr = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - gr * (b - a), a + gr * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    // 1e-5 in ln(1 + e) changes a residual near its minimum by ~1e-10: ample.
    while b - a > 1e-5 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - gr * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + gr * (b - a);
            fd = f(d);
        }
    }
    let x = 0.5 * (a + b);
    let r = f(x);
    if let Some(e) = err.into_inner() {
        return Err(e);
    }
    Ok((r.max(0.0).sqrt(), x.exp_m1()))
}

// ---------------------------------------------------------------------------
// Lobe-sum scenes (§4.3): BRDF × lighting × visibility × cosine, integrated.

/// A shading configuration of eq. 22: three lobe sums and the normal.
#[derive(Debug, Clone)]
pub struct Scene {
    /// BRDF lobes.
    pub brdf: Vec<Lobe>,
    /// Incoming-radiance lobes.
    pub lighting: Vec<Lobe>,
    /// Visibility lobes.
    pub visibility: Vec<Lobe>,
    /// Unit surface normal.
    pub normal: DVec3,
}

/// Largest exponent in random scenes: lobes down to ~0.06 rad wide, which the
/// reference's nested adaptive quadrature resolves reliably.
pub const SCENE_E_MAX: f64 = 300.0;

fn random_unit(rng: &mut Rng) -> DVec3 {
    let z = rng.range(-1.0, 1.0);
    let phi = rng.range(0.0, TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A random scene: 1–8 lobes per sum, exponents uniform in ln(1 + e) up to
/// [`SCENE_E_MAX`], scales in [0.2, 1], axes spread over the normal's side.
pub fn random_scene(rng: &mut Rng) -> Scene {
    let normal = DVec3::Z;
    let sum = |rng: &mut Rng| -> Vec<Lobe> {
        let n = 1 + (rng.uniform() * 8.0) as usize % 8;
        (0..n)
            .map(|_| Lobe {
                scale: rng.range(0.2, 1.0),
                axis: (normal + 1.2 * random_unit(rng)).normalize_or(normal),
                exponent: rng.range(0.0, SCENE_E_MAX.ln_1p()).exp_m1(),
            })
            .collect()
    };
    Scene {
        brdf: sum(rng),
        lighting: sum(rng),
        visibility: sum(rng),
        normal,
    }
}

/// ∫ B·L·V·max(n·v, 0) dω of a scene (relative tolerance 1e-7, far below the lobe
/// algebra's errors) by nested adaptive Gauss–Kronrod over the
/// hemisphere about n (θ outer, φ inner), with break points at every lobe's polar
/// angle ± multiples of its width and at its azimuth.
pub fn reference_scene(scene: &Scene) -> Result<f64, String> {
    let n = scene.normal.normalize();
    let t1 = n.any_orthonormal_vector();
    let t2 = n.cross(t1);
    let all: Vec<&Lobe> = scene
        .brdf
        .iter()
        .chain(&scene.lighting)
        .chain(&scene.visibility)
        .collect();
    let polar = |a: DVec3| {
        (
            a.dot(n).clamp(-1.0, 1.0).acos(),
            a.dot(t2).atan2(a.dot(t1)).rem_euclid(TAU),
        )
    };
    let mut th_breaks = Vec::new();
    let mut ph_breaks = Vec::new();
    for l in &all {
        let (th, ph) = polar(l.axis);
        let w = 1.0 / (l.exponent + 1.0).sqrt();
        for k in [-4.0, -2.0, -1.0, 0.0, 1.0, 2.0, 4.0] {
            th_breaks.push(th + k * w);
        }
        th_breaks.push(FRAC_PI_2 - th); // where a lobe's own horizon meets the pole
        ph_breaks.push(ph);
    }
    let sum = |ls: &[Lobe], v: DVec3| ls.iter().map(|l| l.eval(v)).sum::<f64>();
    let mut ok = true;
    let outer = gauss_kronrod(
        |th: f64| {
            let (st, ct) = th.sin_cos();
            let q = gauss_kronrod(
                |ph: f64| {
                    let (sp, cp) = ph.sin_cos();
                    let v = n * ct + (t1 * cp + t2 * sp) * st;
                    sum(&scene.brdf, v) * sum(&scene.lighting, v) * sum(&scene.visibility, v) * ct
                },
                0.0,
                TAU,
                &ph_breaks,
                1e-14,
                1e-8,
                4000,
            );
            ok &= q.converged;
            q.value * st
        },
        0.0,
        FRAC_PI_2,
        &th_breaks,
        1e-13,
        1e-7,
        4000,
    );
    if !(ok && outer.converged) {
        return Err("scene reference quadrature did not converge".into());
    }
    Ok(outer.value)
}

/// The paper's grid (docs/math.md, lobe-product): 16 linear samples per decade of e1 and e2 on
/// [0, 1], [1, 10], …, [10⁴, 10⁵] (81 values with the end point) × 64 uniform α on
/// [0, π].
pub fn paper_grid() -> Vec<[f64; 3]> {
    let mut e = Vec::new();
    for d in 0..5 {
        let (lo, hi) = if d == 0 {
            (0.0, 1.0)
        } else {
            (10f64.powi(d - 1), 10f64.powi(d))
        };
        for k in 0..16 {
            e.push(lo + (hi - lo) * k as f64 / 16.0);
        }
    }
    e.push(E_MAX);
    let mut g = Vec::with_capacity(e.len() * e.len() * 64);
    for &e1 in &e {
        for &e2 in &e {
            for k in 0..64 {
                g.push([e1, e2, PI * k as f64 / 63.0]);
            }
        }
    }
    g
}

/// Full checks (at least this many scene cases) also run the paper's grid.
const PAPER_GRID_MIN_CASES: usize = 50;

/// (∫p_rΨ_r from the table, ∫Ψ1Ψ2 by the reference) at every `stride`-th paper-grid
/// point.
fn paper_grid_errors(lp: &LobeProduct, stride: usize) -> Result<Vec<(f64, f64)>, String> {
    let pts: Vec<[f64; 3]> = paper_grid().into_iter().step_by(stride).collect();
    pts.par_iter()
        .map(|&[e1, e2, alpha]| {
            let q = lp.params(e1, e2, alpha).map_err(|e| e.to_string())?;
            Ok((q.p * TAU / (q.e_r + 1.0), reference_integral(e1, e2, alpha)?))
        })
        .collect()
}

// ---------------------------------------------------------------------------
// Figures (`lobefit plot lobe-product`).

/// Writes the error maps (the analogues of the paper's Figures 3 and 6) for the
/// committed tables into `dir`.
pub fn plot(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_core::plot::{heatmaps, ColourScale, Heatmap};
    let energy = LobeProduct::embedded().map_err(|e| e.to_string())?;
    let l2 = LobeProduct::embedded_l2().map_err(|e| e.to_string())?;
    const N: usize = 64;
    let u_max = E_MAX.log10();
    // Cell centres, so no cell sits on a table node.
    let e_of = |i: usize| 10f64.powf(u_max * (i as f64 + 0.5) / N as f64) - 1.0;
    let rel = |t: &LobeProduct, e1: f64, e2: f64, alpha: f64| -> f64 {
        let want = match reference_integral(e1, e2, alpha) {
            Ok(w) => w,
            Err(_) => return f64::NAN,
        };
        if want < RELEVANCE * TAU / (1.0 + e1.max(e2)) {
            return f64::NAN; // negligible: drawn grey
        }
        match t.params(e1, e2, alpha) {
            Ok(q) => ((q.p * TAU / (q.e_r + 1.0) - want).abs() / want).max(1e-9),
            Err(_) => f64::NAN,
        }
    };
    let grid = |f: &(dyn Fn(usize, usize) -> f64 + Sync)| -> Vec<f64> {
        (0..N * N).into_par_iter().map(|k| f(k % N, k / N)).collect()
    };
    let mut out = Vec::new();
    let e_label = |n: &str| format!("log10(1 + {n})");
    let mut panels = Vec::new();
    for (name, t) in [("energy", energy), ("l2", l2)] {
        for alpha in [0.5, FRAC_PI_2] {
            panels.push(Heatmap {
                title: format!("{name}: |∫Ψ1Ψ2 − ∫p_rΨ_r| / ∫Ψ1Ψ2 at α = {alpha:.3}"),
                x_label: e_label("e1"),
                y_label: e_label("e2"),
                x_range: (0.0, u_max),
                y_range: (0.0, u_max),
                nx: N,
                ny: N,
                values: grid(&|i, j| rel(t, e_of(i), e_of(j), alpha)),
                colour_label: "relative integral error".into(),
                log_colour: true,
                scale: ColourScale::Own,
            });
        }
    }
    out.push(heatmaps(&dir.join("lobe-product-error-e1-e2.png"), &panels, 2)?);
    let alpha_of = |j: usize| PI * (j as f64 + 0.5) / N as f64;
    let mut panels = Vec::new();
    for (name, t) in [("energy", energy), ("l2", l2)] {
        for (label, other) in [("e2 = e1", None), ("e2 = 0.5", Some(0.5))] {
            panels.push(Heatmap {
                title: format!("{name}: relative integral error, {label}"),
                x_label: e_label("e1"),
                y_label: "α (rad)".into(),
                x_range: (0.0, u_max),
                y_range: (0.0, PI),
                nx: N,
                ny: N,
                values: grid(&|i, j| {
                    let e1 = e_of(i);
                    rel(t, e1, other.unwrap_or(e1), alpha_of(j))
                }),
                colour_label: "relative integral error".into(),
                log_colour: true,
                scale: ColourScale::Own,
            });
        }
    }
    out.push(heatmaps(&dir.join("lobe-product-error-e-alpha.png"), &panels, 2)?);
    // Figure 6: e_r relative to max(e1, e2) (≥ 1: products sharpen).
    let panels: Vec<Heatmap> = [0.2, 1.0]
        .iter()
        .map(|&alpha| Heatmap {
            title: format!("energy: e_r / max(e1, e2) at α = {alpha}"),
            x_label: e_label("e1"),
            y_label: e_label("e2"),
            x_range: (0.0, u_max),
            y_range: (0.0, u_max),
            nx: N,
            ny: N,
            values: grid(&|i, j| {
                let (e1, e2) = (e_of(i), e_of(j));
                energy.params(e1, e2, alpha).map_or(f64::NAN, |q| q.e_r / e1.max(e2))
            }),
            colour_label: "e_r / max(e1, e2)".into(),
            log_colour: true,
            scale: ColourScale::Own,
        })
        .collect();
    out.push(heatmaps(&dir.join("lobe-product-exponent.png"), &panels, 2)?);
    Ok(out)
}

// ---------------------------------------------------------------------------
// The family.

/// A lobe-product family (one variant, one table).
#[derive(Debug, Clone, Copy)]
pub struct LobeProductFamily {
    /// Which variant this family fits.
    pub variant: Variant,
    /// The fast fit or the paper-faithful baseline
    /// ([`crate::lobe_product::paper::fit_paper`]; hours for the whole grid).
    pub method: Method,
}

struct Runtime(LobeProduct);

impl Lookup for Runtime {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let q = self.0.params(x[0], x[1], x[2])?;
        Ok(vec![q.p, q.t, q.e_r])
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        let q = self.0.params_f32(x[0] as f32, x[1] as f32, x[2] as f32);
        Some(q.map(|q| vec![q.p.into(), q.t.into(), q.e_r.into()]))
    }
}

impl View for LobeProductFamily {
    fn kind(&self) -> &'static str {
        self.variant.kind()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["e1", "e2", "alpha"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["p", "t", "e_r"]
    }
    fn embedded(&self) -> &'static [u8] {
        match self.variant {
            Variant::Energy => lobefit_tables::embedded::LOBE_PRODUCT,
            Variant::L2 => lobefit_tables::embedded::LOBE_PRODUCT_L2,
        }
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(Runtime(LobeProduct::from_table_as(table, self.variant)?)))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let (e1, e2, alpha) = domain(x)?;
        let (_, e_r) = reference_optimum(self.variant, e1, e2, alpha)?;
        let s_r = peak_angle(e1, e2, alpha);
        let t = rt::peak_fraction(e1, e2, alpha);
        let ln_a = ref_ln_product(&[(e1, 0.0), (e2, alpha)])?;
        let p = match self.variant {
            Variant::Energy => (e_r + 1.0) / TAU * ln_a.exp(),
            Variant::L2 => {
                let ln_b = ref_ln_product(&[(e1, 0.0), (e2, alpha), (e_r, s_r)])?;
                (ln_b - (TAU / (2.0 * e_r + 1.0)).ln()).exp()
            }
        };
        Ok(vec![p, t, e_r])
    }
    fn exact(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let (e1, e2, alpha) = domain(x)?;
        let f = fit_fast(self.variant, e1, e2, alpha);
        if !f.converged {
            return Err(format!(
                "fit did not converge at e1 = {e1}, e2 = {e2}, alpha = {alpha}",
                e1 = short(e1),
                e2 = short(e2),
                alpha = short(alpha)
            ));
        }
        let integral = (f.c + ln_model(e1, e2, alpha)).exp();
        let p = f.k.exp() * integral * (f.e_r + 1.0) / TAU;
        Ok(vec![p, rt::peak_fraction(e1, e2, alpha), f.e_r])
    }
}

impl Checked for LobeProductFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        let t = |output: &str, metric: &str, limit: f64| Threshold {
            output: output.into(),
            metric: metric.into(),
            limit,
        };
        let mut v = match self.variant {
            Variant::Energy => vec![
                // 10× better than the paper's mean 7.1379e-4 on its own grid.
                t("paper_grid_abs", "offgrid.mean_abs", 7e-5),
                t("integral", "offgrid.median_rel", 1e-3),
                t("integral", "offgrid.p99_rel", 1e-2),
            ],
            Variant::L2 => Vec::new(),
        };
        if self.variant == Variant::Energy {
            v.extend([t("p", "offgrid.max_rel", 5e-2), t("e_r", "offgrid.max_rel", 5e-2)]);
        }
        // Max-type promises, both variants: off-grid, the looked-up lobe's residual
        // within 5 % of the optimum's; at the nodes (every one, see `node_sections`)
        // the stored values are fits, so far tighter limits hold there.
        // The product lobe's parameters against the reference optimum (e_r as e_r + 1,
        // the lobe's normalisation). The energy variant's optimum is sharp: p99 and
        // max. The L2 variant's is flat in e_r at some pairs (the fit does not
        // determine e_r there; the residual, checked above, does not care), so its
        // promise is the 95th percentile: the 99th of a few hundred f32-twin points
        // measured 2.0e-2.
        let (stat, limit) = match self.variant {
            Variant::Energy => ("offgrid.p99_rel", 1e-2),
            Variant::L2 => ("offgrid.p95_rel", 1e-2),
        };
        v.extend([
            t("p", stat, limit),
            t("t", "offgrid.max_abs", 1e-5),
            t("e_r", stat, limit),
            t("l2_residual", "offgrid.max_rel", L2_RESIDUAL_MAX_REL),
            t("l2_residual", "grid.max_rel", NODE_RESIDUAL_MAX_REL),
            t("l2_residual_diagonal", "grid.max_rel", NODE_RESIDUAL_MAX_REL),
            t("integral_nodes", "grid.max_rel", NODE_INTEGRAL_MAX_REL),
        ]);
        for ch in self.channels() {
            v.push(t(&format!("symmetry_{}", ch.name), "max", 0.0));
        }
        v
    }
    fn checked(&self) -> &'static [&'static str] {
        &["integral", "l2_residual", "p", "t", "e_r"]
    }
    fn nodes_in_extras(&self) -> bool {
        // The full check (a golden-section optimum by quadrature) costs ~1.5 ms a node:
        // 221 184 nodes would take minutes. `node_sections` verifies every node.
        true
    }
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let (e1, e2, alpha) = domain(x)?;
        let want_i = reference_integral(e1, e2, alpha)?;
        if want_i < RELEVANCE * TAU / (1.0 + e1.max(e2)) {
            return Ok(None);
        }
        let got = runtime.lookup(x).map_err(|e| format!("lookup at {x:?}: {e}"))?;
        let (p, t, e_r) = (got[0], got[1], got[2]);
        let got_i = p * TAU / (e_r + 1.0);
        let got_r = reference_residual(e1, e2, alpha, p, t * alpha, e_r)?;
        let (want_r, _) = reference_optimum(self.variant, e1, e2, alpha)?;
        let want = self.reference(x)?;
        Ok(Some((
            vec![got_i, got_r.max(RESIDUAL_FLOOR), p, t, e_r + 1.0],
            vec![want_i, want_r.max(RESIDUAL_FLOOR), want[0], want[1], want[2] + 1.0],
        )))
    }
    fn extra_checks(&self, table: &Table, count: usize, seed: u64) -> Vec<(String, Result<Extra, String>)> {
        let lp = match LobeProduct::from_table_as(table.clone(), self.variant) {
            Ok(lp) => lp,
            Err(e) => return vec![("triple_product".into(), Err(e.to_string()))],
        };
        let mut out = self.node_sections(table, &lp);
        // Random lobe-sum scenes (eq. 22) through the runtime's algebra.
        let mut rng = Rng::new(seed ^ 0x7e1b);
        let scenes: Vec<Scene> = (0..count).map(|_| random_scene(&mut rng)).collect();
        let res: Result<Vec<(f64, f64)>, String> = scenes
            .par_iter()
            .map(|sc| {
                let got = lp
                    .triple_product(&sc.brdf, &sc.lighting, &sc.visibility, sc.normal, 0.0)
                    .map_err(|e| e.to_string())?;
                Ok((got, reference_scene(sc)?))
            })
            .collect();
        out.push(("triple_product".into(), res.map(Extra::Pairs)));
        // The fit's own relative L2 residual at random relevant points (reference
        // optimum): the floor no table can beat.
        let mut rng = Rng::new(seed ^ 0xf100);
        let pts: Vec<Vec<f64>> = (0..10 * count).map(|_| self.sample(&mut rng)).collect();
        let floor: Result<Vec<Option<f64>>, String> = pts
            .par_iter()
            .map(|x| {
                let (e1, e2, alpha) = (x[0], x[1], x[2]);
                if reference_integral(e1, e2, alpha)? < RELEVANCE * TAU / (1.0 + e1.max(e2)) {
                    return Ok(None);
                }
                Ok(Some(reference_optimum(self.variant, e1, e2, alpha)?.0))
            })
            .collect();
        out.push((
            "fit_residual_floor".into(),
            floor.map(|v| Extra::Values(v.into_iter().flatten().collect())),
        ));
        // The paper's own grid and metric, |∫Ψ1Ψ2 − ∫p_rΨ_r| (sr), in full checks.
        // The paper's grid and metric: every point in full checks, every 13th (13 is
        // coprime to the 64 α samples) in quick ones.
        let stride = if count >= PAPER_GRID_MIN_CASES { 1 } else { 13 };
        out.push((
            "paper_grid_abs".into(),
            paper_grid_errors(&lp, stride).map(Extra::Pairs),
        ));
        if count >= PAPER_GRID_MIN_CASES {
            // The same metric for the fit itself at those points (no table): what the
            // paper reports for its own entries, and the floor of the table's value.
            let variant = self.variant;
            let fits: Result<Vec<(f64, f64)>, String> = paper_grid()
                .par_iter()
                .map(|&[e1, e2, alpha]| {
                    let f = fit_fast(variant, e1, e2, alpha);
                    let got = (f.k + f.c + ln_model(e1, e2, alpha)).exp();
                    Ok((got, reference_integral(e1, e2, alpha)?))
                })
                .collect();
            out.push(("paper_grid_fit_abs".into(), fits.map(Extra::Pairs)));
        }
        out
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        // Uniform in ln(1 + e) (the axes' own coordinate) and, half the time, uniform
        // in α; otherwise α scaled by the product's width, where sharp products live.
        let e = |rng: &mut Rng| rng.range(0.0, E_MAX.ln_1p()).exp_m1().min(E_MAX);
        let (e1, e2) = (e(rng), e(rng));
        let alpha = if rng.uniform() < 0.5 {
            rng.range(0.0, PI)
        } else {
            let width = (1.0 / (e1 + 1.0) + 1.0 / (e2 + 1.0)).sqrt();
            (rng.range(0.0, 6.0) * width).min(PI)
        };
        vec![e1, e2, alpha]
    }
}

impl Fit for LobeProductFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        let what = match self.variant {
            Variant::Energy => "integral-conserving (p_r = (e_r+1)/(2π)·∫Ψ1Ψ2; e_r minimises the L2 residual)",
            Variant::L2 => "L2-optimal (the paper's objective; (p_r, e_r) minimise ‖Ψ1Ψ2 − p_rΨ_r‖)",
        };
        format!(
            "Product of two cosine lobes max(a1·v,0)^e1·max(a2·v,0)^e2 ≈ p_r·max(a_r·v,0)^e_r, {what}. \
             Axis a_r at the closed-form peak (not stored). Channels: c = ln(∫Ψ1Ψ2/M) with the \
             closed-form model M of lobefit_tables::lobe_product::ln_model, ln((1+e_r)/(1+e_m)) with \
             e_m of lobefit_tables::lobe_product::exponent_model{}.",
            if self.variant == Variant::L2 {
                ", ln(∫p_rΨ_r/∫Ψ1Ψ2)"
            } else {
                ""
            }
        )
    }
    fn axes(&self) -> Vec<lobefit_tables::Axis> {
        rt::axes(N_E, N_ALPHA).to_vec()
    }
    fn channels(&self) -> Vec<Channel> {
        self.variant
            .channels()
            .iter()
            .map(|&(name, encoding)| Channel {
                name: name.into(),
                unit: "1".into(),
                encoding,
                description: match name {
                    rt::CHANNEL_C => "ln(∫Ψ1Ψ2 dω / M(e1, e2, α)); ∫Ψ1Ψ2 = exp(c + ln_model)",
                    rt::CHANNEL_E => "ln((1 + e_r)/(1 + e_m)), e_m = exponent_model(e1, e2, α)",
                    _ => "ln(∫p_rΨ_r / ∫Ψ1Ψ2)",
                }
                .into(),
            })
            .collect()
    }
    fn method(&self) -> String {
        match self.method {
            Method::Fast => {
                "closed-form axis; Brent over ln(1+e_r) on W(E)·tanh-sinh in-plane integrals, then a local Brent \
                 around its optimum; p_r closed form"
                    .into()
            }
            Method::Paper => "paper: Nelder-Mead axis from the bisector, Levenberg-Marquardt (p_r, e_r) on \
                              2-D adaptive-Simpson integrals"
                .into(),
        }
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("variant".into(), self.variant.kind().into()),
            ("tanh_sinh_h".into(), TS_H.to_string()),
            ("tanh_sinh_t".into(), TS_T.to_string()),
            ("truncation_k".into(), TRUNC_K.to_string()),
            ("brent_tol".into(), BRENT_TOL.to_string()),
            ("e_r_search".into(), "[0, 64(e1+e2)+1000]".into()),
            (
                "polish".into(),
                format!("Brent within ±{POLISH} in ln(1+e_r), kept where the residual drops by > 1e-9 relative"),
            ),
            ("bound_allowed_below".into(), NEGLIGIBLE.to_string()),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "relative L2 residual ‖Ψ1Ψ2 − p_rΨ_r‖/‖Ψ1Ψ2‖ of the fit at the node"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        // Symmetric in (e1, e2): fit the ordered pair so both halves get identical bits.
        let (e1, e2) = (node[0].min(node[1]), node[0].max(node[1]));
        let f = match self.method {
            Method::Fast => fit_fast(self.variant, e1, e2, node[2]),
            Method::Paper => {
                let alpha = node[2];
                let q = crate::lobe_product::paper::fit_paper(self.variant, e1, e2, alpha);
                FastFit {
                    c: q.integral.ln() - ln_model(e1, e2, alpha),
                    e_r: q.e_r,
                    k: match self.variant {
                        Variant::Energy => 0.0,
                        Variant::L2 => (q.p * TAU / (q.e_r + 1.0) / q.integral).ln(),
                    },
                    residual: q.residual,
                    iterations: q.iterations,
                    converged: q.converged && q.integral > 0.0,
                }
            }
        };
        let ln_e = ((1.0 + f.e_r) / (1.0 + rt::exponent_model(e1, e2, node[2]))).ln();
        let mut values = vec![f.c, ln_e];
        if self.variant == Variant::L2 {
            values.push(f.k);
        }
        Fitted {
            values,
            residual: f.residual,
            iterations: f.iterations,
            converged: f.converged,
        }
    }
    fn mirror(&self, node: &[f64]) -> Option<Vec<f64>> {
        // Ψ1Ψ2 is symmetric in (e1, e2) with t ↔ 1 − t; the stored channels are
        // symmetric, so the upper triangle reuses the lower one.
        (node[0] > node[1]).then(|| vec![node[1], node[0], node[2]])
    }
}

impl LobeProductFamily {
    /// The every-node verification (see [`Checked::nodes_in_extras`]), each section
    /// independent of the fit:
    /// - `integral_nodes`: every relevant node's stored `ln_integral_over_model` plus
    ///   the closed-form model against the Gauss–Kronrod ∫Ψ1Ψ2, for e2 ≤ e1;
    /// - `symmetry_<channel>`: |v(e1, e2, α) − v(e2, e1, α)| over every off-diagonal
    ///   pair: Ψ1Ψ2 is symmetric under the swap (with t ↔ 1 − t), so are the stored
    ///   channels, and a changed node breaks the equality with its mirror;
    /// - `l2_residual_diagonal`: the full check (the residual of the looked-up lobe
    ///   against the reference optimum) at every relevant node with e1 = e2, which
    ///   have no mirror.
    ///
    /// A single changed node therefore fails `integral_nodes` (first channel), a
    /// symmetry section (off the diagonal) or `l2_residual_diagonal` (on it).
    fn node_sections(&self, table: &Table, lp: &LobeProduct) -> Vec<(String, Result<Extra, String>)> {
        let axes = &table.meta().axes;
        let nc = table.meta().channels.len();
        let nodes = lobefit_core::build::grid_nodes(axes);
        let values = table.values();
        let (n_e, n_a) = (axes[1].count as usize, axes[2].count as usize);
        let flat = |i: usize, j: usize, k: usize| (i * n_e + j) * n_a + k;
        let mut out = Vec::new();
        // The lower triangle e2 ≤ e1 (diagonal included): the symmetry sections carry
        // the check to the mirrored half.
        let lower: Vec<usize> = (0..n_e)
            .flat_map(|i| (0..=i).flat_map(move |j| (0..n_a).map(move |k| flat(i, j, k))))
            .collect();
        let integral: Result<Vec<Option<(f64, f64)>>, String> = lower
            .par_iter()
            .map(|&n| {
                let x = &nodes[n];
                let (e1, e2, alpha) = (x[0], x[1], x[2]);
                let want = reference_integral(e1, e2, alpha)?;
                if want < RELEVANCE * TAU / (1.0 + e1.max(e2)) {
                    return Ok(None);
                }
                let got = (f64::from(values[n * nc]) + ln_model(e1, e2, alpha)).exp();
                Ok(Some((got, want)))
            })
            .collect();
        out.push((
            "integral_nodes".to_string(),
            integral.map(|v| Extra::Nodes(v.into_iter().flatten().collect())),
        ));
        for (c, ch) in table.meta().channels.iter().enumerate() {
            let mut defects = Vec::new();
            for i in 0..n_e {
                for j in 0..i {
                    for k in 0..n_a {
                        let (a, b) = (values[flat(i, j, k) * nc + c], values[flat(j, i, k) * nc + c]);
                        defects.push((f64::from(a) - f64::from(b)).abs());
                    }
                }
            }
            out.push((format!("symmetry_{}", ch.name), Ok(Extra::Values(defects))));
        }
        let runtime = Runtime(lp.clone());
        let diagonal: Result<Vec<Option<(f64, f64)>>, String> = (0..n_e)
            .flat_map(|i| (0..n_a).map(move |k| flat(i, i, k)))
            .collect::<Vec<_>>()
            .par_iter()
            .map(|&n| {
                Ok(self
                    .check_point(&runtime, &nodes[n])?
                    .map(|(got, want)| (got[1], want[1])))
            })
            .collect();
        out.push((
            "l2_residual_diagonal".to_string(),
            diagonal.map(|v| Extra::Nodes(v.into_iter().flatten().collect())),
        ));
        out
    }
}

fn domain(x: &[f64]) -> Result<(f64, f64, f64), String> {
    let (e1, e2, alpha) = (x[0], x[1], x[2]);
    for (n, v, hi) in [("e1", e1, E_MAX), ("e2", e2, E_MAX), ("alpha", alpha, PI)] {
        if !(0.0..=hi).contains(&v) {
            return Err(format!("{n} = {v} is outside [0, {hi}]", v = short(v)));
        }
    }
    Ok((e1, e2, alpha))
}

/// lobe-product and lobe-product-l2 in the list of families
/// (`crate::entries`): `eval lobe-product --variant energy|l2`.
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |o| {
        vec![
            Box::new(LobeProductFamily {
                variant: Variant::Energy,
                method: o.method,
            }),
            Box::new(LobeProductFamily {
                variant: Variant::L2,
                method: o.method,
            }),
        ]
    },
    eval: Some(|name, flags, opts| {
        if name != lobefit_tables::lobe_product::KIND_ENERGY {
            return crate::without_flags(name, flags, opts);
        }
        let variant = match flags.text("variant").as_deref() {
            None | Some("energy") => Variant::Energy,
            Some("l2") => Variant::L2,
            Some(v) => return Err(format!("--variant {v}: expected energy or l2")),
        };
        Ok(Box::new(LobeProductFamily {
            variant,
            method: opts.method,
        }))
    }),
    eval_names: &[],
    eval_flags: &[(
        lobefit_tables::lobe_product::KIND_ENERGY,
        &[lobefit_core::family::EvalFlag {
            name: "variant",
            help: "energy | l2 (default energy)",
            count: false,
        }],
    )],
    gpu: &[gpu::ENERGY, gpu::L2],
    closed_form: None,
    plot: Some(("lobe-product", plot)),
    eval_help: "\
lobe-product  [--variant energy|l2]   (energy: the product's integral is kept);
lobe-product-l2: as --variant l2
  in   `e1`, `e2` exponents of the two lobes, [0, 1e5]
       `alpha`    angle between their axes (rad), [0, π]
  out  `p`        scale of the product lobe for unit-scale lobes (s1·s2·p in general)
       `t`        where its axis lies on the great arc from axis 1 to axis 2, as a
                  fraction of alpha (0 = axis 1, 1 = axis 2): the product's peak
       `e_r`      exponent of the product lobe
",
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_in_plane_integrals_match_gauss_kronrod() {
        let mut worst: f64 = 0.0;
        for &e1 in &[0.0, 0.01, 0.5, 1.0, 7.0, 300.0, 1e5] {
            for &e2 in &[0.0, 0.3, 2.0, 50.0, 4000.0, 1e5] {
                for k in 0..=12 {
                    let alpha = PI * k as f64 / 12.5;
                    let node = Node::new(e1, e2, alpha);
                    let fast = node.ln_a + peak_ln(e1, e2, alpha);
                    let want = ref_ln_product(&[(e1, 0.0), (e2, alpha)]).unwrap();
                    if want.is_finite() && want > -700.0 {
                        worst = worst.max((fast - want).abs());
                    }
                    for &e in &[0.0, 1.0, e1 + e2 + 1.0] {
                        let s_r = peak_angle(e1, e2, alpha);
                        let fast = node.ln_b(e) + peak_ln(e1, e2, alpha);
                        let want = ref_ln_product(&[(e1, 0.0), (e2, alpha), (e, s_r)]).unwrap();
                        if want > -700.0 {
                            worst = worst.max((fast - want).abs());
                        }
                    }
                }
            }
        }
        assert!(worst < 1e-9, "worst |Δ ln ∫| = {worst:e}");
    }

    #[test]
    fn closed_forms() {
        // α = 0: the product of lobes on one axis is the lobe e1 + e2 exactly.
        for &(e1, e2) in &[(0.0, 0.0), (1.0, 2.0), (100.0, 1e5)] {
            let i = reference_integral(e1, e2, 0.0).unwrap();
            assert!((i - TAU / (e1 + e2 + 1.0)).abs() < 1e-9 * i, "{e1} {e2}");
            let f = fit_fast(Variant::L2, e1, e2, 0.0);
            // The residual is quadratic in the exponent error, so a minimiser resolves
            // e_r only to ~√ε of the residual's scale: 1e-4 relative.
            assert!((f.e_r - (e1 + e2)).abs() < 1e-4 * (1.0 + e1 + e2), "{f:?}");
            assert!(f.residual < 1e-5, "{f:?}");
        }
        // Two hemispheres at angle α intersect in a lune of area 2(π − α).
        for &alpha in &[0.3, 1.5, 3.0] {
            let i = reference_integral(0.0, 0.0, alpha).unwrap();
            assert!((i - 2.0 * (PI - alpha)).abs() < 1e-9);
        }
    }

    #[test]
    fn separation_of_variables_matches_spherical_quadrature() {
        // Plain nested Gauss–Kronrod in (θ, φ) about a1, no change of variables.
        for &(e1, e2, alpha) in &[
            (1.0f64, 1.0f64, 1.2f64),
            (0.5, 7.0, 2.5),
            (20.0, 3.0, 0.4),
            (0.0, 2.0, 2.0),
        ] {
            let a2 = [alpha.sin(), 0.0, alpha.cos()];
            let inner = |th: f64| {
                let (st, ct) = (th.sin(), th.cos());
                let q = gauss_kronrod(
                    |ph: f64| {
                        let v = [st * ph.cos(), st * ph.sin(), ct];
                        let d2 = v[0] * a2[0] + v[2] * a2[2];
                        let p1 = if ct > 0.0 { ct.powf(e1) } else { 0.0 };
                        let p2 = if d2 > 0.0 { d2.powf(e2) } else { 0.0 };
                        p1 * p2
                    },
                    0.0,
                    TAU,
                    &[PI / 2.0, PI, 1.5 * PI],
                    0.0,
                    1e-12,
                    500,
                );
                q.value * st
            };
            let q = gauss_kronrod(inner, 0.0, FRAC_PI_2, &[alpha.min(1.5)], 0.0, 1e-11, 500);
            let want = q.value;
            let got = reference_integral(e1, e2, alpha).unwrap();
            assert!((got - want).abs() < 1e-8 * want, "{e1} {e2} {alpha}: {got} vs {want}");
        }
    }
}
