//! SH projection, the Gaunt triple-product tensor, the
//! truncated SH product and SH exponentiation by Taylor series.
//!
//! Conventions are those of [`lobefit_tables::sh`] (docs/math.md §1): real orthonormal SH
//! with the Condon–Shortley phase, index i = l(l+1)+m, order n = bands 0..n−1.
//! Renderer-side operations (basis, ZH→SH, rotations) live in the runtime crate and
//! are re-exported here as [`rt`].
//!
//! The Gaunt tensor, the truncated product and [`SphereRule`] live in the runtime
//! crate (`lobefit_tables::gaunt`, renderers need the product for SH exponentiation)
//! and are re-exported here. [`SphereRule`] is exact for polynomials up to its degree
//! (see there); the tests check the Gaunt coefficients against the checker's adaptive
//! Gauss–Kronrod (`crate::quad::gauss_kronrod`), a different rule.

use std::f64::consts::PI;

pub use lobefit_tables::gaunt::{gauss_legendre, one, Gaunt, GauntEntry, SphereRule, GAUNT_ZERO};
/// Monomial coefficients of P_0 … P_7 (`[l][k]` multiplies t^k), the runtime's.
pub use lobefit_tables::log_zh::legendre_coeffs;
pub use lobefit_tables::sh as rt;
use lobefit_tables::sh::MAX_ORDER;

/// Relative size of a Taylor term (max-norm vs the running sum) at which [`exp_taylor`]
/// stops: below f64 resolution of the sum.
pub const TAYLOR_STOP: f64 = 1e-17;
/// Taylor terms allowed before [`exp_taylor`] reports non-convergence (enough for
/// ‖f‖ up to ≈ 100: the k-th term is ≤ ‖f‖^k/k! · C^k with C the product norm bound).
pub const TAYLOR_MAX_TERMS: usize = 2000;

/// Result of [`exp_taylor`].
#[derive(Debug, Clone, PartialEq)]
pub struct ExpResult {
    /// exp*(f), n² coefficients.
    pub value: Vec<f64>,
    /// Taylor terms summed.
    pub terms: usize,
    /// Whether the last term fell below [`TAYLOR_STOP`] of the sum.
    pub converged: bool,
}

/// SH exponentiation by the Taylor series, run to convergence (docs/math.md, shexp's reference):
/// exp*(f) = 1 + f + f^{2∗}/2! + …, each product truncated to the tensor's order.
///
/// Terms are summed as they come; for large DC terms the series cancels badly
/// (it computes e^{−16} as a sum of terms of size e^{16}): use [`exp_star`], which
/// factors the DC term out exactly, when accuracy matters.
pub fn exp_taylor(gaunt: &Gaunt, f: &[f64]) -> ExpResult {
    let mut sum = one(gaunt.order()).expect("a Gaunt tensor's order is in 1..=8");
    let mut term = sum.clone();
    let norm = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for k in 1..=TAYLOR_MAX_TERMS {
        term = gaunt.product(&term, f);
        term.iter_mut().for_each(|t| *t /= k as f64);
        sum.iter_mut().zip(&term).for_each(|(s, t)| *s += t);
        // A sum that overflowed (inf, or NaN, which `fold(max)` would skip) has not converged.
        if sum.iter().any(|v| !v.is_finite()) {
            break;
        }
        if norm(&term) <= TAYLOR_STOP * norm(&sum) && k > 2 {
            return ExpResult {
                value: sum,
                terms: k + 1,
                converged: true,
            };
        }
    }
    ExpResult {
        value: sum,
        terms: TAYLOR_MAX_TERMS + 1,
        converged: false,
    }
}

/// exp*(f) = exp(f_0/√(4π)) · exp*(f̂), f̂ = f without its DC term. Identical to
/// [`exp_taylor`] in exact arithmetic (the DC term is a multiple of the product's
/// identity, so it commutes and factors out), and free of its cancellation.
pub fn exp_star(gaunt: &Gaunt, f: &[f64]) -> ExpResult {
    let mut hat = f.to_vec();
    let dc = hat[0] / (4.0 * PI).sqrt();
    hat[0] = 0.0;
    let mut r = exp_taylor(gaunt, &hat);
    let s = dc.exp();
    r.value.iter_mut().for_each(|v| *v *= s);
    r.converged &= r.value.iter().all(|v| v.is_finite());
    r
}

/// ZH vector of a zonal function g(cosθ) up to order n, z_l = 2π ∫_{−1}^{1} g(t) y_l^0(t) dt,
/// by the checker's adaptive Gauss–Kronrod with break points `breaks` (where g kinks).
pub fn zh_project_gk(order: usize, g: impl Fn(f64) -> f64, breaks: &[f64], tol: f64) -> (Vec<f64>, bool) {
    let mut ok = true;
    let z = (0..order)
        .map(|l| {
            let q = crate::quad::gauss_kronrod(
                |t| {
                    let mut y = [0.0; MAX_ORDER];
                    rt::eval_zonal(l + 1, t, &mut y).expect("t in [-1, 1]");
                    g(t) * y[l]
                },
                -1.0,
                1.0,
                breaks,
                tol,
                0.0,
                10_000,
            );
            ok &= q.converged;
            2.0 * PI * q.value
        })
        .collect();
    (z, ok)
}

/// ZH vector (order n ≤ [`MAX_ORDER`]) of a spherical Gaussian of unit amplitude and
/// sharpness λ > 0 about +z, g(t) = e^{λ(t−1)}, t = cosθ: z_l = 2π N_l ∫ g P_l dt with
/// N_l = √((2l+1)/4π), accurate to rounding for every λ (a quadrature in t misses the
/// peak of width 1/λ once λ is large: 1e-20 instead of 1e-4 at λ = 5000).
///
/// Why two regimes: for λ < 8 the integrand is smooth and Gauss–Kronrod converges; for
/// λ ≥ 8, t = 1 − s/λ and Rodrigues' expansion P_l(1 − u) = Σ_k C(l,k) C(l+k,k) (−u/2)^k
/// give the closed form (1/λ) Σ_k C(l,k) C(l+k,k) (−1/2λ)^k γ(k+1, 2λ), whose terms fall
/// like k!/(2λ)^k (no cancellation), with γ the lower incomplete gamma function.
pub fn sg_zh(order: usize, sharpness: f64) -> Result<Vec<f64>, String> {
    if !(1..=MAX_ORDER).contains(&order) {
        return Err(format!("SH order {order} outside 1..={MAX_ORDER}"));
    }
    if !(sharpness.is_finite() && sharpness > 0.0) {
        return Err(format!("SG sharpness {sharpness} is not finite and positive"));
    }
    let lambda = sharpness;
    if lambda < SG_ZH_SPLIT {
        let (z, ok) = zh_project_gk(order, |t| (lambda * (t - 1.0)).exp(), &[], 1e-14);
        return if ok {
            Ok(z)
        } else {
            Err(format!(
                "the projection of an SG of sharpness {lambda} did not converge"
            ))
        };
    }
    let x = 2.0 * lambda;
    // γ(k+1, x) = k! (1 − e^{−x} Σ_{j≤k} x^j/j!): x ≥ 16 > k, so the bracket is near 1.
    let mut gamma = [0.0; MAX_ORDER];
    let (mut fact, mut term, mut partial) = (1.0, 1.0, 1.0);
    for (k, g) in gamma.iter_mut().enumerate().take(order) {
        if k > 0 {
            fact *= k as f64;
            term *= x / k as f64;
            partial += term;
        }
        *g = fact * (1.0 - (-x).exp() * partial);
    }
    Ok((0..order)
        .map(|l| {
            let mut sum = 0.0;
            let mut c = 1.0; // C(l,k) C(l+k,k) (−1/2λ)^k, built term by term
            for (k, g) in gamma.iter().enumerate().take(l + 1) {
                if k > 0 {
                    c *= -(((l + 1 - k) * (l + k)) as f64) / (k * k) as f64 / x;
                }
                sum += c * g;
            }
            2.0 * PI * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * sum / lambda
        })
        .collect())
}

/// Below this sharpness [`sg_zh`] integrates by quadrature, at or above it in closed form.
const SG_ZH_SPLIT: f64 = 8.0;

/// Legendre polynomials P_0(t), P_1(t), P_2(t), … without end, by Bonnet's
/// recurrence (l + 1) P_{l+1} = (2l + 1) t P_l − l P_{l−1} (P_0 = 1, P_1 = t): the fit
/// side's one evaluation of the recurrence ([`legendre`] is its l-th term). The
/// runtime evaluates its own ([`rt::eval_zonal`], and [`legendre_coeffs`] for the
/// monomial coefficients): it cannot depend on this crate.
pub fn legendre_seq(t: f64) -> impl Iterator<Item = f64> {
    let (mut l, mut p_prev, mut p) = (0usize, 0.0, 1.0);
    std::iter::from_fn(move || {
        match l {
            0 => {}
            1 => (p_prev, p) = (p, t),
            _ => {
                let k = l - 1;
                (p_prev, p) = (p, ((2 * k + 1) as f64 * t * p - k as f64 * p_prev) / (k + 1) as f64);
            }
        }
        l += 1;
        Some(p)
    })
}

/// Legendre polynomial P_l(t), by the recurrence of [`legendre_seq`].
pub fn legendre(l: usize, t: f64) -> f64 {
    legendre_seq(t).nth(l).expect("an endless sequence")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quad::gauss_kronrod;
    use lobefit_tables::sh::{eval_basis, index, MAX_COEFFS};

    /// An SG's ZH against quadrature in s = λ(1 − t) (an independent route: the peak at
    /// s = 0 has unit width there, and breaks at 1, 4, 16, … follow the e^{−s} tail),
    /// for sharpness 0.01 … 1e6, every band of order 8, both sides of the split; and the
    /// DC term against its closed form 2π N_0 (1 − e^{−2λ})/λ.
    #[test]
    fn sg_zh_against_quadrature_in_the_peak_variable() {
        for lambda in [0.01, 0.5, 3.0, 7.999, 8.0, 20.0, 1e2, 1e3, 3500.0, 5e3, 1e4, 1e5, 1e6] {
            let z = sg_zh(MAX_ORDER, lambda).unwrap();
            let top = 2.0 * lambda;
            let breaks: Vec<f64> = (0..12).map(|k| 4f64.powi(k)).filter(|&b| b < top).collect();
            for (l, &got) in z.iter().enumerate() {
                let q = gauss_kronrod(
                    |s| (-s).exp() * legendre(l, (1.0 - s / lambda).max(-1.0)),
                    0.0,
                    top,
                    &breaks,
                    1e-16,
                    1e-14,
                    10_000,
                );
                assert!(q.converged, "λ {lambda} l {l}");
                let want = 2.0 * PI * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * q.value / lambda;
                let scale = z[0].abs();
                assert!(
                    (got - want).abs() <= 1e-12 * scale,
                    "λ {lambda} l {l}: {got:e} vs {want:e}"
                );
            }
            let dc = 2.0 * PI * (1.0 / (4.0 * PI)).sqrt() * -(-2.0 * lambda).exp_m1() / lambda;
            assert!((z[0] - dc).abs() <= 1e-14 * dc, "λ {lambda}: DC {:e} vs {dc:e}", z[0]);
        }
        assert!(sg_zh(3, 0.0).is_err() && sg_zh(3, f64::NAN).is_err() && sg_zh(9, 1.0).is_err());
    }

    /// Acceptance: orthonormality and Gaunt entries vs quadrature ≤ 1e-12.
    const ACCEPT: f64 = 1e-12;
    /// Checker quadrature tolerance, well below ACCEPT.
    const GK_TOL: f64 = 1e-15;

    /// θ and φ factors of y_i: y_l^m(θ, φ) = Θ(θ) Φ(φ), Θ from the runtime's basis at φ = 0.
    fn theta_part(i: usize, theta: f64) -> f64 {
        let (l, m) = rt::band_of(i);
        let mut y = [0.0; MAX_COEFFS];
        eval_basis(l + 1, [theta.sin(), 0.0, theta.cos()], &mut y).unwrap();
        y[index(l, m.abs())]
    }
    fn phi_part(i: usize, phi: f64) -> f64 {
        let (_, m) = rt::band_of(i);
        match m.cmp(&0) {
            std::cmp::Ordering::Equal => 1.0,
            std::cmp::Ordering::Greater => (m as f64 * phi).cos(),
            std::cmp::Ordering::Less => (-m as f64 * phi).sin(),
        }
    }
    /// ∫ Π y dω by separable adaptive Gauss–Kronrod (θ ∈ [0, π], φ ∈ [0, 2π]).
    fn gk_integral(idx: &[usize]) -> f64 {
        let qt = gauss_kronrod(
            |t| idx.iter().map(|&i| theta_part(i, t)).product::<f64>() * t.sin(),
            0.0,
            PI,
            &[PI / 2.0],
            GK_TOL,
            0.0,
            1000,
        );
        let qp = gauss_kronrod(
            |p| idx.iter().map(|&i| phi_part(i, p)).product::<f64>(),
            0.0,
            2.0 * PI,
            &[PI / 2.0, PI, 1.5 * PI],
            GK_TOL,
            0.0,
            1000,
        );
        assert!(qt.converged && qp.converged);
        qt.value * qp.value
    }

    /// P_0 … P_4 against their closed forms (worked out by hand), at points where
    /// those are exact in binary: P_2 = (3t² − 1)/2, P_3 = (5t³ − 3t)/2,
    /// P_4 = (35t⁴ − 30t² + 3)/8; and P_l(1) = 1, P_l(−1) = (−1)^l.
    #[test]
    fn legendre_closed_forms() {
        for t in [0.0, 0.5, -0.25, 1.0, -1.0] {
            let want = [
                1.0,
                t,
                (3.0 * t * t - 1.0) / 2.0,
                (5.0 * t * t * t - 3.0 * t) / 2.0,
                (35.0 * t * t * t * t - 30.0 * t * t + 3.0) / 8.0,
            ];
            let got: Vec<f64> = legendre_seq(t).take(5).collect();
            for (l, (g, w)) in got.iter().zip(want).enumerate() {
                assert!((g - w).abs() < 1e-15, "P_{l}({t}) = {g}, want {w}");
                assert_eq!(legendre(l, t), *g);
            }
        }
        // P_2(0.5) = −1/8, P_3(0.5) = −7/16 by hand.
        assert_eq!(legendre(2, 0.5), -0.125);
        assert_eq!(legendre(3, 0.5), -0.4375);
        for l in 0..20 {
            assert!((legendre(l, 1.0) - 1.0).abs() < 1e-14);
            assert!((legendre(l, -1.0) - if l % 2 == 0 { 1.0 } else { -1.0 }).abs() < 1e-14);
        }
    }

    /// The runtime's monomial coefficients evaluate to the recurrence's P_l.
    #[test]
    fn legendre_coeffs_match_recurrence() {
        let a = legendre_coeffs();
        for t in [-0.9, -0.3, 0.2, 0.7] {
            for (l, p) in legendre_seq(t).take(MAX_ORDER).enumerate() {
                let m: f64 = (0..MAX_ORDER).map(|k| a[l][k] * t.powi(k as i32)).sum();
                assert!((m - p).abs() < 1e-13, "l={l} t={t}: {m} vs {p}");
            }
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre(11);
        for k in 0..22 {
            let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k)).sum();
            let want = if k % 2 == 1 { 0.0 } else { 2.0 / (k + 1) as f64 };
            assert!((got - want).abs() < 1e-14, "k={k}: {got}");
        }
    }

    /// Orthonormality of the order-8 basis by the checker's quadrature, every pair.
    #[test]
    fn basis_orthonormal_by_adaptive_quadrature() {
        let mut worst: f64 = 0.0;
        for i in 0..64 {
            for j in i..64 {
                let (_, mi) = rt::band_of(i);
                let (_, mj) = rt::band_of(j);
                if mi != mj && mi.abs() != mj.abs() {
                    // Φ integral is 0 by symmetry; still checked on a sample below.
                    if (i + j) % 7 != 0 {
                        continue;
                    }
                }
                let v = gk_integral(&[i, j]);
                let want = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((v - want).abs());
            }
        }
        eprintln!("orthonormality (adaptive GK), max |∫y_i y_j − δ_ij| = {worst:.2e}");
        assert!(worst < ACCEPT);
    }

    /// The exact product rule is exact for the order-8 Gram matrix too (all pairs).
    #[test]
    fn basis_orthonormal_by_exact_rule() {
        let rule = SphereRule::exact_for_degree(14);
        let mut worst: f64 = 0.0;
        for i in 0..64 {
            let p = rule.project(8, |d| {
                let mut y = [0.0; 64];
                eval_basis(8, d, &mut y).unwrap();
                y[i]
            });
            for (j, v) in p.iter().enumerate() {
                worst = worst.max((v - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        assert!(worst < ACCEPT, "{worst:e}");
    }

    /// Every non-zero Gaunt entry of order 8, and a sample of the skipped zeros,
    /// against the separable adaptive Gauss–Kronrod.
    #[test]
    fn gaunt_matches_adaptive_quadrature() {
        let g = Gaunt::new(8);
        let mut worst: f64 = 0.0;
        let mut smallest = f64::INFINITY;
        for e in g.entries() {
            let [i, j, k] = e.ijk.map(usize::from);
            worst = worst.max((gk_integral(&[i, j, k]) - e.value).abs());
            smallest = smallest.min(e.value.abs());
        }
        // Zeros: triples not in the list, deterministic sample.
        let set: std::collections::HashSet<[u16; 3]> = g.entries().iter().map(|e| e.ijk).collect();
        let mut zeros = 0;
        for i in 0..64u16 {
            for j in (i..64).step_by(5) {
                for k in (j..64).step_by(7) {
                    if !set.contains(&[i, j, k]) {
                        worst = worst.max(gk_integral(&[i as usize, j as usize, k as usize]).abs());
                        zeros += 1;
                    }
                }
            }
        }
        eprintln!(
            "Gaunt order 8: {} unique non-zero, worst |Γ − GK| = {worst:.2e} (incl. {zeros} zeros), smallest |Γ| = {smallest:.3e}",
            g.entries().len()
        );
        assert!(worst < ACCEPT);
        assert!(smallest > 1e3 * GAUNT_ZERO);
    }

    /// Zonal entries against the exact Wigner-3j closed form
    /// Γ = √((2l1+1)(2l2+1)(2l3+1)/4π) (l1 l2 l3; 0 0 0)².
    #[test]
    fn gaunt_zonal_entries_match_wigner_3j() {
        let g = Gaunt::new(8);
        let f = |n: usize| (1..=n).map(|k| k as f64).product::<f64>();
        // (l1 l2 l3; 0 0 0)² = Δ² (g!/((g−l1)!(g−l2)!(g−l3)!))² with 2g = L, Δ² = Π(L−2l_i)!/(L+1)!.
        let w3j2 = |l1: usize, l2: usize, l3: usize| {
            let big = l1 + l2 + l3;
            let gg = big / 2;
            let delta2 = f(big - 2 * l1) * f(big - 2 * l2) * f(big - 2 * l3) / f(big + 1);
            let r = f(gg) / (f(gg - l1) * f(gg - l2) * f(gg - l3));
            delta2 * r * r
        };
        let mut checked = 0;
        for e in g.entries() {
            let [i, j, k] = e.ijk.map(usize::from);
            let (a, b, c) = (rt::band_of(i), rt::band_of(j), rt::band_of(k));
            if a.1 == 0 && b.1 == 0 && c.1 == 0 {
                let (l1, l2, l3) = (a.0, b.0, c.0);
                let want = (((2 * l1 + 1) * (2 * l2 + 1) * (2 * l3 + 1)) as f64 / (4.0 * PI)).sqrt() * w3j2(l1, l2, l3);
                assert!(
                    (e.value.abs() - want).abs() < ACCEPT,
                    "{l1} {l2} {l3}: {} vs {want}",
                    e.value
                );
                checked += 1;
            }
        }
        assert!(checked > 20);
    }

    #[test]
    fn nonzero_counts_per_order() {
        let counts: Vec<(usize, usize)> = (1..=8)
            .map(|n| {
                let g = Gaunt::new(n);
                (g.entries().len(), g.nonzero_full())
            })
            .collect();
        eprintln!("Gaunt non-zeros per order (unique i≤j≤k, full): {counts:?}");
        assert_eq!(counts[0], (1, 1));
        // Order 2: Γ_000 and Γ_0ii (i = 1..3): 4 unique, 1 + 3·3 = 10 full.
        assert_eq!(counts[1], (4, 10));
    }

    /// Product of two functions vs the projection of their pointwise product: equal
    /// when both are band-limited and their product fits in the order.
    #[test]
    fn product_is_projection_of_pointwise_product() {
        let g = Gaunt::new(8);
        let rule = SphereRule::exact_for_degree(24);
        // f of order 4 and h of order 5: f·h has degree ≤ 7, exactly representable at order 8.
        let mut f = vec![0.0; 64];
        let mut h = vec![0.0; 64];
        for (i, v) in f.iter_mut().take(16).enumerate() {
            *v = ((i * 13 % 7) as f64 - 3.0) / 5.0;
        }
        for (i, v) in h.iter_mut().take(25).enumerate() {
            *v = ((i * 5 % 9) as f64 - 4.0) / 3.0;
        }
        let eval = |c: &[f64], d: [f64; 3]| {
            let mut y = [0.0; 64];
            eval_basis(8, d, &mut y).unwrap();
            c.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>()
        };
        let want = rule.project(8, |d| eval(&f, d) * eval(&h, d));
        let got = g.product(&f, &h);
        for i in 0..64 {
            assert!((got[i] - want[i]).abs() < 1e-12, "{i}: {} vs {}", got[i], want[i]);
        }
    }

    /// exp* of a constant is the constant's exponential; of a ZH of small norm it
    /// approaches the projection of the pointwise exponential as the order grows.
    #[test]
    fn exp_star_constant_and_consistency() {
        let g = Gaunt::new(4);
        let mut f = vec![0.0; 16];
        f[0] = -2.0 * (4.0 * PI).sqrt();
        let r = exp_taylor(&g, &f);
        assert!(r.converged);
        assert!((r.value[0] / (4.0 * PI).sqrt() - (-2.0f64).exp()).abs() < 1e-14);
        f[2] = 0.3;
        f[7] = -0.2;
        let a = exp_taylor(&g, &f);
        let b = exp_star(&g, &f);
        for i in 0..16 {
            assert!((a.value[i] - b.value[i]).abs() < 1e-13);
        }
    }

    /// Acceptance: rotation vs re-projection and round trips ≤ 1e-10. g is a polynomial
    /// of degree 12 (not band-limited to order 8), so the rule of degree 12 + 7 projects
    /// it exactly and the two sides differ only by rounding.
    #[test]
    fn rotation_vs_reprojection_and_round_trip() {
        let rule = SphereRule::exact_for_degree(19);
        let a = rt::normalize([0.3, -0.7, 0.5]).unwrap();
        let b = rt::normalize([-0.9, 0.1, 0.4]).unwrap();
        let g = |d: [f64; 3]| {
            let u = a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
            let v = b[0] * d[0] + b[1] * d[1] + b[2] * d[2];
            u.powi(12) + 0.5 * v.powi(7) * u - 0.3 * d[0] * d[1]
        };
        let (mut worst_re, mut worst_rt): (f64, f64) = (0.0, 0.0);
        for (axis, angle) in [([1.0, 2.0, 3.0], 0.9), ([0.0, 1.0, 0.0], 2.5), ([-1.0, 0.2, 0.1], -1.3)] {
            let r = rt::rotation_axis_angle(axis, angle).unwrap();
            let rt_ = [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[j][i]));
            for n in [1usize, 2, 4, 8] {
                let f = rule.project(n, g);
                let rot = rt::Rotation::new(n, r).unwrap();
                let mut fr = vec![0.0; n * n];
                rot.apply(&f, &mut fr).unwrap();
                // f'(v) = f(rᵀ v).
                let want = rule.project(n, |d| {
                    g([0, 1, 2].map(|i| (0..3).map(|j| rt_[i][j] * d[j]).sum::<f64>()))
                });
                let inv = rt::Rotation::new(n, rt_).unwrap();
                let mut back = vec![0.0; n * n];
                inv.apply(&fr, &mut back).unwrap();
                for i in 0..n * n {
                    worst_re = worst_re.max((fr[i] - want[i]).abs());
                    worst_rt = worst_rt.max((back[i] - f[i]).abs());
                }
            }
        }
        eprintln!("rotation vs re-projection max abs {worst_re:.2e}; round trip max abs {worst_rt:.2e}");
        assert!(worst_re < 1e-10 && worst_rt < 1e-10);
    }

    /// ZH→SH (Funk–Hecke) vs the projection of the turned zonal function.
    #[test]
    fn zh_to_sh_matches_projection() {
        let rule = SphereRule::exact_for_degree(17);
        let d = rt::normalize([0.2, 0.5, -0.6]).unwrap();
        let h = |t: f64| t.powi(10) - 0.5 * t.powi(3) + 0.1;
        let (zh, ok) = zh_project_gk(8, h, &[], 1e-15);
        assert!(ok);
        let mut got = vec![0.0; 64];
        rt::zh_to_sh(&zh, d, &mut got).unwrap();
        let want = rule.project(8, |v| h(v[0] * d[0] + v[1] * d[1] + v[2] * d[2]));
        for i in 0..64 {
            assert!((got[i] - want[i]).abs() < 1e-12, "{i}");
        }
    }

    #[test]
    fn product_matrix_matches_product() {
        let g = Gaunt::new(5);
        let a: Vec<f64> = (0..25).map(|i| ((i * 7 % 11) as f64 - 5.0) / 4.0).collect();
        let x: Vec<f64> = (0..25).map(|i| ((i * 3 % 5) as f64 - 2.0) / 3.0).collect();
        let m = g.product_matrix(&a);
        let p = g.product(&a, &x);
        for i in 0..25 {
            let mx: f64 = (0..25).map(|k| m[i * 25 + k] * x[k]).sum();
            assert!((mx - p[i]).abs() < 1e-14);
            for k in 0..25 {
                assert!((m[i * 25 + k] - m[k * 25 + i]).abs() < 1e-15);
            }
        }
    }
}
