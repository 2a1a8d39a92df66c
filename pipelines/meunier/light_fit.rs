//! A candidate light model studied, not shipped (docs/meunier.md, "A better light"):
//! K cosine lobes on the light's axis, Σ_j s_j·max(a·v, 0)^{e_j}, fitted to the light's
//! cap with a cosine-weighted objective. Exponents e_j = 1.77·e_cap(α)·1.3^j (the
//! ratios a search picked at α = 0.05–0.5); scales by linear least squares against
//! (i) the cap's indicator in L2 over the sphere, relative to the cap's solid angle,
//! and (ii) the cap's clamped-cosine irradiance ∫_cap max(n·v, 0) dω at 25 tilts of
//! the normal from 0 to π/2, relative to the cap's irradiance at normal incidence.
//! `render meunier` measures it by quadrature in its breakdown.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use lobefit_tables::meunier::cap_irradiance;
use lobefit_tables::CapExponent;

use lobefit_core::eigen::solve;
use lobefit_core::sh::gauss_legendre;

/// Lobes per light the study tries.
pub const MAX_LOBES: usize = 3;

/// Mean of max(n·v, 0) over the azimuth of v about the light's axis a, for v at polar
/// angle `theta` from a and n at angle `beta` from a.
pub fn clamped_cosine_mean(theta: f64, beta: f64) -> f64 {
    let a = beta.cos() * theta.cos();
    let b = beta.sin() * theta.sin();
    if a >= b {
        a
    } else if a <= -b {
        0.0
    } else {
        let p0 = (-a / b).acos();
        (a * p0 + b * p0.sin()) / PI
    }
}

/// ∫ g(θ)·2π sin θ dθ over [lo, hi] for g times the clamped cosine's azimuthal mean at
/// tilt `beta`: split at that mean's kink |π/2 − β|, each side by 8 panels of 24-point
/// Gauss–Legendre.
fn polar_integral(lo: f64, hi: f64, beta: f64, g: impl Fn(f64) -> f64) -> f64 {
    let kink = (FRAC_PI_2 - beta).abs();
    if kink > lo && kink < hi {
        return panels(lo, kink, &g) + panels(kink, hi, &g);
    }
    panels(lo, hi, &g)
}

fn panels(lo: f64, hi: f64, g: &dyn Fn(f64) -> f64) -> f64 {
    let (x, w) = gauss_legendre(24);
    let panels = 8;
    let h = (hi - lo) / panels as f64;
    let mut s = 0.0;
    for k in 0..panels {
        let a = lo + k as f64 * h;
        for (xi, wi) in x.iter().zip(&w) {
            let t = a + 0.5 * h * (xi + 1.0);
            s += wi * 0.5 * h * g(t) * TAU * t.sin();
        }
    }
    s
}

/// The K-lobe fit for a cap of half-angle `alpha` (rad): (exponent, scale) per lobe,
/// scales for a light of unit radiance.
pub fn fit(caps: &CapExponent, alpha: f64, k: usize) -> Result<Vec<(f64, f64)>, String> {
    let e0 = 1.77 * caps.e_cap(alpha).map_err(|e| e.to_string())?;
    let es: Vec<f64> = (0..k).map(|j| e0 * 1.3f64.powi(j as i32)).collect();
    let mut g = vec![0.0; k * k];
    let mut rhs = vec![0.0; k];
    let mut add = |row: &[f64], target: f64, w: f64| {
        for i in 0..k {
            for j in 0..k {
                g[i * k + j] += w * row[i] * row[j];
            }
            rhs[i] += w * row[i] * target;
        }
    };
    let cap_area = TAU * (1.0 - alpha.cos());
    let (x, w) = gauss_legendre(24);
    for (lo, hi) in [(0.0, alpha), (alpha, FRAC_PI_2)] {
        let panels = 16;
        let h = (hi - lo) / panels as f64;
        for p in 0..panels {
            for (xi, wi) in x.iter().zip(&w) {
                let t = lo + (p as f64 + 0.5 * (xi + 1.0)) * h;
                let row: Vec<f64> = es.iter().map(|e| t.cos().powf(*e)).collect();
                add(
                    &row,
                    f64::from(u8::from(t < alpha)),
                    wi * 0.5 * h * TAU * t.sin() / cap_area,
                );
            }
        }
    }
    let tilts = 24;
    let e_normal = PI * alpha.sin().powi(2);
    for i in 0..=tilts {
        let beta = FRAC_PI_2 * i as f64 / tilts as f64;
        let row: Vec<f64> = es
            .iter()
            .map(|e| {
                polar_integral(0.0, FRAC_PI_2, beta, |t| {
                    t.cos().powf(*e) * clamped_cosine_mean(t, beta)
                })
            })
            .collect();
        add(
            &row,
            cap_irradiance(alpha.sin(), beta.cos()),
            1.0 / (e_normal * e_normal * tilts as f64),
        );
    }
    solve(&mut g, &mut rhs, k, 1).ok_or_else(|| format!("light-lobe fit at α = {alpha}: singular"))?;
    Ok(es.into_iter().zip(rhs).collect())
}

/// Value of the fitted lobes at polar angle `theta` from the light's axis.
pub fn eval(lobes: &[(f64, f64)], theta: f64) -> f64 {
    let c = theta.cos();
    if c <= 0.0 {
        return 0.0;
    }
    lobes.iter().map(|(e, s)| s * c.powf(*e)).sum()
}

/// Unoccluded irradiance of the fitted lobes (unit radiance) for a normal at `beta`
/// from the light's axis, by quadrature.
pub fn irradiance(lobes: &[(f64, f64)], beta: f64) -> f64 {
    polar_integral(0.0, FRAC_PI_2, beta, |t| eval(lobes, t) * clamped_cosine_mean(t, beta))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The azimuthal mean against a direct sum over φ.
    #[test]
    fn clamped_cosine_mean_matches_a_sum() {
        for &(t, b) in &[(0.3f64, 0.2f64), (1.0, 1.2), (0.5, 1.4), (1.4, 1.5), (0.2, 2.0)] {
            let n = 20000;
            let sum: f64 = (0..n)
                .map(|k| {
                    let phi = TAU * (k as f64 + 0.5) / n as f64;
                    (b.cos() * t.cos() + b.sin() * t.sin() * phi.cos()).max(0.0)
                })
                .sum::<f64>()
                / n as f64;
            assert!((sum - clamped_cosine_mean(t, b)).abs() < 1e-7, "{t} {b}");
        }
    }

    /// Integrating the cap's indicator with the same rule gives the closed form.
    #[test]
    fn the_rule_reproduces_the_cap_irradiance() {
        for &(a, b) in &[(0.2f64, 0.1f64), (0.85, 1.0), (0.5, 1.3), (0.3, 1.8)] {
            let q = polar_integral(0.0, a, b, |t| clamped_cosine_mean(t, b));
            assert!((q - cap_irradiance(a.sin(), b.cos())).abs() < 1e-9, "{a} {b}: {q}");
        }
    }
}
