//! Integral spherical Gaussian (docs/math.md, isg, errata E1–E3): the definition, the checker's
//! reference and a fast, accurate evaluation used by the fits.
//!
//! Parameterisation (docs/math.md, isg, erratum E1): Ω(θ, φ) = (sinθ cosφ, cosθ, sinθ sinφ),
//! θ ∈ [0, π] measured from +y, φ ∈ [0, π] the azimuth about +y measured from +x
//! towards +z. The square [0, π]² covers the hemisphere z ≥ 0; the SG axis +z sits at
//! (π/2, π/2).
//!
//!   S(θ, φ; γ) = ∫_0^θ ∫_0^φ exp(γ (Ω(θ',φ')·z − 1)) sinθ' dφ' dθ',   Ω·z = sinθ' sinφ',
//!   Ŝ = S / S(π, π),   S(π, π) = 2π/γ (1 − e^{−γ}).
//!
//! Two evaluations that share no code:
//! - [`s_hat_reference`]: nested adaptive Gauss–Kronrod (the checker's rule, `quad.rs`)
//!   on the definition, with break points at π/2 ± k·(SG width) in both angles.
//! - [`s_hat_fast`]: a 1-D reduction. In polar coordinates (α, β) about the SG axis the
//!   integrand depends on α only, and the region {z ≥ 0} ∩ {x sinφ − z cosφ ≥ 0} ∩
//!   {y ≥ cosθ} (the lune φ' ≤ φ and the cap θ' ≤ θ) cuts the circle of polar angle α in
//!   the intersection of two arcs with closed-form half-widths
//!   a = acos(cotα cotφ) (centred on β = 0) and b = acos(cosθ / sinα) (centred on β = π/2).
//!   With t = 1 − cosα, S = ∫_0^1 e^{−γt} L(t) dt, L the arc-intersection length. L is
//!   piecewise smooth with kinks only where the circle is tangent to a boundary
//!   (t = 1 − sinθ, t = 1 − sinφ: square-root behaviour) or passes through the corner
//!   Ω(θ, φ) (t = 1 − sinθ sinφ). Panels end at those kinks and at k/γ; each panel is
//!   mapped by t = t0 + h(1 − cos πw)/2 (panels grow geometrically away from each kink), which removes square-root end singularities,
//!   and integrated by 16-point Gauss–Legendre.

use std::cell::Cell;
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

use lobefit_core::quad::gauss_kronrod;
use lobefit_tables::error::short;

/// The ISG domain and normaliser, defined once in the runtime crate.
pub use lobefit_tables::isg::{normaliser, GAMMA_MAX, GAMMA_MIN};
/// Absolute tolerance on Ŝ of the reference quadrature: far below any model error
/// (≥ 1e-3) and above the f64 rounding of the nested sums.
pub const REFERENCE_TOL: f64 = 1.0e-11;
/// Subdivision limit of each reference quadrature.
const REF_MAX_INTERVALS: usize = 4000;
/// Beyond t = SG_TAIL/γ the SG weight e^{−γt} is below e^{−45}: truncating the fast
/// integral there changes Ŝ by < 1e-19/(1 − e^{−γ}).
const SG_TAIL: f64 = 45.0;
/// Growth factor of the panels above a kink of the arc length (see `s_hat_fast`).
const KINK_RATIO: f64 = 2.0;
/// Gauss–Legendre points per panel of the fast evaluation.
const GL_POINTS: usize = 16;

/// 1 − sinθ sinφ = 1 − cos a cos b (a = θ − π/2, b = φ − π/2) without cancellation:
/// 2 sin²(a/2) + cos a · 2 sin²(b/2).
pub fn one_minus_dot(theta: f64, phi: f64) -> f64 {
    let (a, b) = (theta - FRAC_PI_2, phi - FRAC_PI_2);
    let (sa, sb) = ((0.5 * a).sin(), (0.5 * b).sin());
    2.0 * sa * sa + a.cos() * 2.0 * sb * sb
}

/// Checks the ISG domain: θ, φ ∈ [0, π], γ ∈ [[`GAMMA_MIN`], [`GAMMA_MAX`]].
pub fn check_domain(theta: f64, phi: f64, gamma: f64) -> Result<(), String> {
    for (name, v, lo, hi) in [
        ("theta", theta, 0.0, PI),
        ("phi", phi, 0.0, PI),
        ("gamma", gamma, GAMMA_MIN, GAMMA_MAX),
    ] {
        if !v.is_finite() {
            return Err(format!("{name} = {v} is not finite", v = short(v)));
        }
        if !(lo..=hi).contains(&v) {
            return Err(format!("{name} = {v} is outside [{lo}, {hi}]", v = short(v)));
        }
    }
    Ok(())
}

/// Ŝ(θ, φ; γ) by nested adaptive Gauss–Kronrod on the definition (the checker's
/// reference), to absolute accuracy ~[`REFERENCE_TOL`]. Errors name an input outside
/// the domain or a quadrature that did not converge.
pub fn s_hat_reference(theta: f64, phi: f64, gamma: f64) -> Result<f64, String> {
    static MEMO: lobefit_core::memo::Memo<3, f64> = lobefit_core::memo::Memo::new();
    MEMO.get([theta, phi, gamma], || s_hat_reference_computed(theta, phi, gamma))
}

/// [`s_hat_reference`], computed.
fn s_hat_reference_computed(theta: f64, phi: f64, gamma: f64) -> Result<f64, String> {
    check_domain(theta, phi, gamma)?;
    reference_unchecked(theta, phi, gamma)
}

/// [`s_hat_reference`] without the domain check (any γ > 0; the tests use γ → 0).
fn reference_unchecked(theta: f64, phi: f64, gamma: f64) -> Result<f64, String> {
    Ok(rectangle_reference(0.0, theta, 0.0, phi, gamma)? / normaliser(gamma))
}

/// ∫_{θ1}^{θ2} ∫_{φ1}^{φ2} exp(γ (Ω·z − 1)) sinθ dφ dθ (sr) by nested adaptive
/// Gauss–Kronrod straight over the rectangle (no four-corner combination): the
/// checker's reference for patch integrals. Absolute accuracy ~[`REFERENCE_TOL`]·S(π, π).
pub fn patch_reference(theta1: f64, theta2: f64, phi1: f64, phi2: f64, gamma: f64) -> Result<f64, String> {
    check_domain(theta1, phi1, gamma)?;
    check_domain(theta2, phi2, gamma)?;
    rectangle_reference(theta1, theta2, phi1, phi2, gamma)
}

fn rectangle_reference(theta1: f64, theta2: f64, phi1: f64, phi2: f64, gamma: f64) -> Result<f64, String> {
    // Integrand divided by S(π, π), so tolerances are absolute in Ŝ.
    let n = normaliser(gamma);
    let ok = Cell::new(true);
    let outer_breaks = width_breaks(gamma);
    let inner = |t: f64| {
        let s = t.sin();
        if s <= 0.0 {
            return 0.0;
        }
        // Inner width 1/√(γ sinθ'); its error, integrated over ≤ π in θ', stays ≤ REFERENCE_TOL.
        let q = gauss_kronrod(
            |p: f64| (-gamma * one_minus_dot(t, p)).exp() / n,
            phi1,
            phi2,
            &width_breaks(gamma * s),
            REFERENCE_TOL / PI,
            0.0,
            REF_MAX_INTERVALS,
        );
        if !q.converged {
            ok.set(false);
        }
        q.value * s
    };
    let q = gauss_kronrod(
        inner,
        theta1,
        theta2,
        &outer_breaks,
        REFERENCE_TOL,
        0.0,
        REF_MAX_INTERVALS,
    );
    if !q.converged || !ok.get() {
        return Err(format!(
            "reference quadrature did not converge on [{theta1}, {theta2}] x [{phi1}, {phi2}], gamma = {gamma}"
        ));
    }
    Ok(q.value * n)
}

/// Break points π/2 ± k/√κ (k = 1/2 … 16) and π/2, where a Gaussian of sharpness κ
/// centred on π/2 changes scale.
fn width_breaks(kappa: f64) -> Vec<f64> {
    let w = 1.0 / kappa.sqrt();
    let mut v = vec![FRAC_PI_2];
    for k in [0.5, 1.0, 2.0, 4.0, 8.0, 16.0] {
        v.push(FRAC_PI_2 - k * w);
        v.push(FRAC_PI_2 + k * w);
    }
    v
}

/// Gauss–Legendre nodes and weights on [0, 1] ([`lobefit_core::sh::gauss_legendre`] mapped,
/// computed once).
fn gauss_legendre() -> &'static [(f64, f64)] {
    static GL: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    GL.get_or_init(|| {
        let (x, w) = lobefit_core::sh::gauss_legendre(GL_POINTS);
        x.iter().zip(&w).map(|(x, w)| (0.5 * (1.0 + x), 0.5 * w)).collect()
    })
}

/// Length of the intersection of the arcs [−a, a] and [π/2 − b, π/2 + b] on the
/// circle (a, b ∈ [0, π]). The second arc, unrolled, also meets the first through its
/// copy shifted by −2π (only when a + b > 3π/2).
fn arc_overlap(a: f64, b: f64) -> f64 {
    let ov = |l1: f64, h1: f64, l2: f64, h2: f64| (h1.min(h2) - l1.max(l2)).max(0.0);
    ov(-a, a, FRAC_PI_2 - b, FRAC_PI_2 + b) + ov(-a, a, -1.5 * PI - b, -1.5 * PI + b)
}

/// Ŝ(θ, φ; γ) by the 1-D arc reduction (see the module docs). Accurate to ~1e-10
/// absolute against [`s_hat_reference`] (test `fast_matches_reference`: worst 4e-10
/// over 400 random points); 200–600 integrand evaluations. Inputs are not checked (callers do).
pub fn s_hat_fast(theta: f64, phi: f64, gamma: f64) -> f64 {
    if theta <= 0.0 || phi <= 0.0 {
        return 0.0;
    }
    let ct = theta.cos();
    let (sp, cp) = phi.sin_cos();
    let full_lune = phi >= PI;
    let half_width_a = |ca: f64, sa: f64| {
        if full_lune {
            PI
        } else {
            (ca * cp / (sa * sp)).clamp(-1.0, 1.0).acos()
        }
    };
    let tail = (SG_TAIL / gamma).min(1.0);
    let half = |x: f64| {
        let s = (0.5 * (x - FRAC_PI_2)).sin();
        2.0 * s * s
    };
    let mut pts = vec![0.0, tail];
    for k in [0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0] {
        pts.push(k / gamma);
    }
    let kinks = [0.0, half(theta), half(phi), one_minus_dot(theta, phi)];
    pts.extend(kinks);
    pts.retain(|&t| (0.0..=tail).contains(&t));
    pts.sort_by(f64::total_cmp);
    pts.dedup();
    // Near a kink t_k the arc half-widths behave like acos(1 − c|t − t_k|) or, seen from
    // t = 0, like acos(√(t_k/t)): scale-free about the kink. A kink just outside a
    // panel (closer than half its length) would spoil the rule, so such panels are
    // split geometrically away from that kink: every piece is then no longer than
    // its distance to it. (A kink exactly at a panel end is removed by the cosine map.)
    let mut extra = Vec::new();
    for w in pts.windows(2) {
        let (l, r) = (w[0], w[1]);
        for &k in &kinks {
            let d = if k <= l {
                l - k
            } else if k >= r {
                k - r
            } else {
                continue;
            };
            if d <= 0.0 || d >= 0.5 * (r - l) {
                continue;
            }
            let mut x = KINK_RATIO * d;
            while x < d + (r - l) {
                extra.push(if k <= l { k + x } else { k - x });
                x *= KINK_RATIO;
            }
        }
    }
    pts.extend(extra);
    pts.sort_by(f64::total_cmp);
    pts.dedup();
    let gl = gauss_legendre();
    let mut sum = 0.0;
    for w in pts.windows(2) {
        let (t0, h) = (w[0], w[1] - w[0]);
        if h <= 0.0 {
            continue;
        }
        let mut panel = 0.0;
        for &(x, wt) in gl {
            let (s, c) = (PI * x).sin_cos();
            let t = t0 + h * 0.5 * (1.0 - c);
            let dt = h * 0.5 * PI * s;
            let ca = 1.0 - t;
            let sa = (t * (2.0 - t)).sqrt();
            if sa <= 0.0 {
                continue;
            }
            let a = half_width_a(ca, sa);
            let b = (ct / sa).clamp(-1.0, 1.0).acos();
            panel += wt * dt * (-gamma * t).exp() * arc_overlap(a, b);
        }
        sum += panel;
    }
    sum / normaliser(gamma)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lobefit_core::rng::Rng;

    /// Known values: Ŝ(π, π) = 1, and by the mirror symmetries θ → π − θ, φ → π − φ:
    /// Ŝ(π/2, π/2) = 1/4, Ŝ(π/2, π) = Ŝ(π, π/2) = 1/2, Ŝ(θ, φ) + Ŝ(π − θ, φ) = Ŝ(π, φ).
    #[test]
    fn reference_symmetries() {
        for &g in &[0.5, 7.0, 300.0, 1e4] {
            let r = |t, p| s_hat_reference(t, p, g).unwrap();
            assert!((r(PI, PI) - 1.0).abs() < 1e-10, "{g}");
            assert!((r(FRAC_PI_2, FRAC_PI_2) - 0.25).abs() < 1e-10, "{g}");
            assert!((r(FRAC_PI_2, PI) - 0.5).abs() < 1e-10, "{g}");
            assert!((r(PI, FRAC_PI_2) - 0.5).abs() < 1e-10, "{g}");
            let (t, p) = (1.3, 1.75);
            assert!((r(t, p) + r(PI - t, p) - r(PI, p)).abs() < 1e-10, "{g}");
        }
    }

    /// For γ → 0 the integrand is (1 − γ + γ sinθ' sinφ') sinθ' + O(γ²), whose integral
    /// is (1−γ)(1 − cosθ)φ + γ(θ/2 − sin2θ/4)(1 − cosφ): checked at γ = 1e-3.
    #[test]
    fn reference_small_gamma_limit() {
        let lin = |t: f64, p: f64, g: f64| {
            (1.0 - g) * (1.0 - t.cos()) * p + g * (t / 2.0 - (2.0 * t).sin() / 4.0) * (1.0 - p.cos())
        };
        let g = 1e-3;
        for &(t, p) in &[(0.4, 0.9), (1.2, 2.5), (2.9, 0.3), (PI, 1.0)] {
            let want = lin(t, p, g) / lin(PI, PI, g);
            let got = reference_unchecked(t, p, g).unwrap();
            assert!((got - want).abs() < 2e-6, "{t} {p}: {got} vs {want}");
            assert!((s_hat_fast(t, p, g) - want).abs() < 2e-6, "fast {t} {p}");
        }
    }

    #[test]
    fn fast_matches_reference() {
        let mut rng = Rng::new(11);
        let mut worst: f64 = 0.0;
        for i in 0..400 {
            let g = (GAMMA_MIN.ln() + (GAMMA_MAX / GAMMA_MIN).ln() * rng.uniform()).exp();
            // Half the points within a few SG widths of the axis, where Ŝ varies.
            let w = 1.0 / g.sqrt();
            let (t, p) = if i % 2 == 0 {
                (rng.range(0.0, PI), rng.range(0.0, PI))
            } else {
                (
                    (FRAC_PI_2 + w * rng.range(-4.0, 4.0)).clamp(0.0, PI),
                    (FRAC_PI_2 + w * rng.range(-4.0, 4.0)).clamp(0.0, PI),
                )
            };
            let r = s_hat_reference(t, p, g).unwrap();
            let f = s_hat_fast(t, p, g);
            worst = worst.max((r - f).abs());
            assert!((r - f).abs() < 1e-9, "theta {t} phi {p} gamma {g}: ref {r} fast {f}");
        }
        eprintln!("fast vs reference: worst |ΔŜ| = {worst:.3e}");
    }
}
