//! SH exponentiation and the two SH logarithms (Ren et al. 2006 as
//! used in the thesis §3.7; docs/math.md, shexp).
//!
//! exp* variants: [`exp_taylor`] (the reference, run to
//! convergence), DC isolation ([`exp_star`]), scaling and squaring
//! ([`exp_scaling_squaring`]), OL and HYB (in the runtime crate,
//! [`lobefit_tables::shexp::ol`] / [`lobefit_tables::shexp::hyb_with`], re-exported here,
//! because renderers run them per pixel).
//!
//! Logs of a visibility vector g: naive ε-clamped projection (log-zh,
//! [`lobefit_tables::log_zh::blocker`] for caps) and Ren's [`ren_log`]: f = log(M_g)·1
//! with M_g the SH product matrix (M_g x = g ∗ x), from its symmetric
//! eigen-decomposition with eigenvalues clamped below at [`REN_CLAMP`] × the largest
//! *inside q* (see `log_coefficients` for what that means where the clamp acts).
//! Written as f = R q(D) Rᵀ (g − 1), q(x) = ln(x)/(x − 1), so that small blockers
//! (g ≈ 1) keep full relative accuracy: M_g = I + M_{g−1}, and the eigenvalues are
//! λ = 1 + μ with μ those of M_{g−1} (computed directly, no 1 + tiny rounding).

use std::f64::consts::PI;

use lobefit_tables::sh::{self as rt, index};

use lobefit_core::eigen::{sym_eigen, SymEigen};
use lobefit_core::sh::{exp_star, exp_taylor, ExpResult, Gaunt, SphereRule};

pub use lobefit_tables::shexp::{ab_of_pair, hyb_with, ol};

/// Ren's eigenvalue clamp: eigenvalues of M_g below this fraction of the largest are
/// raised to it (thesis §3.7.1; docs/math.md, shexp).
pub const REN_CLAMP: f64 = 0.02;

/// q(1 + μ) = ln(1 + μ)/μ, with q = 1 at μ = 0 (series for |μ| < [`Q_SERIES`]:
/// no 0/0, no NaN for any μ > −1).
pub fn q_log(mu: f64) -> f64 {
    if mu.abs() < Q_SERIES {
        // 1 − μ/2 + μ²/3 − μ³/4 + μ⁴/5: the next term is < 1e-3⁵/6 ≈ 2e-16.
        1.0 - mu * (0.5 - mu * (1.0 / 3.0 - mu * (0.25 - mu * 0.2)))
    } else {
        mu.ln_1p() / mu
    }
}

/// |μ| below which [`q_log`] uses its series (the series' truncation error there is
/// below f64 rounding; ln_1p(μ)/μ loses nothing above it).
pub const Q_SERIES: f64 = 1e-3;

/// A Ren log: the log vector and what the clamp did.
#[derive(Debug, Clone, PartialEq)]
pub struct RenLog {
    /// f = log(M_g)·1, same length as g.
    pub f: Vec<f64>,
    /// Eigenvalues raised by the clamp (of block 0 for the zonal versions: the only
    /// block the log of a zonal g depends on).
    pub clamped: usize,
    /// The m-block holding the largest eigenvalue (zonal versions; 0 otherwise).
    pub max_block: usize,
    /// Smallest and largest eigenvalue of M_g (before clamping).
    pub lambda: (f64, f64),
}

/// Coefficients c_k of f = Σ_k c_k r_k in the eigenbasis {r_k} of M_{g−1}:
/// q(max(λ_k, λ_c))(r_k·h), h = g − 1, λ_k = 1 + μ_k, λ_c = [`REN_CLAMP`] λ_max.
///
/// The clamp sits inside q and (r_k·h) = μ_k (r_k·1) keeps the unclamped eigenvalue: the
/// q-form f = R q(D) Rᵀ (g − 1) of docs/math.md, shexp read literally, which is what public
/// implementations of Ren's log compute (`docs/shexp.md` compares one). Unclamped it is
/// ln(λ_k)(r_k·1), the log of M_g applied to 1; for a clamped λ_k it is
/// ln(λ_c) μ_k/(λ_c − 1) (r_k·1), not ln(λ_c)(r_k·1) (the log of the *clamped* matrix):
/// the two conventions differ only where the clamp acts, and this one round-trips
/// through exp* slightly better there (`docs/shexp.md`).
fn log_coefficients(e: &SymEigen, h: &[f64], lambda_max: f64) -> (Vec<f64>, usize) {
    let n = e.n;
    let floor = REN_CLAMP * lambda_max;
    let mut clamped = 0;
    let c = (0..n)
        .map(|k| {
            let mu = e.values[k];
            let q = if 1.0 + mu < floor {
                clamped += 1;
                q_log(floor - 1.0)
            } else {
                q_log(mu)
            };
            q * (0..n).map(|i| e.vector(k, i) * h[i]).sum::<f64>()
        })
        .collect();
    (c, clamped)
}

/// Ren's SH log of the SH vector `g` (n² coefficients, order n ≤ 8) through the
/// full n² × n² product matrix. Errors: wrong length, non-finite input, no positive
/// eigenvalue (g is nowhere positive: no log).
pub fn ren_log(gaunt: &Gaunt, g: &[f64]) -> Result<RenLog, String> {
    let nc = gaunt.order() * gaunt.order();
    if g.len() != nc {
        return Err(format!(
            "g has {} coefficients, order {} needs {nc}",
            g.len(),
            gaunt.order()
        ));
    }
    if g.iter().any(|v| !v.is_finite()) {
        return Err("g has a non-finite coefficient".into());
    }
    let mut h = g.to_vec();
    h[0] -= (4.0 * PI).sqrt();
    let e = sym_eigen(&gaunt.product_matrix(&h), nc)?;
    let lambda = (1.0 + e.values[0], 1.0 + e.values[nc - 1]);
    if lambda.1 <= 0.0 {
        return Err(format!("M_g has no positive eigenvalue (largest {:e})", lambda.1));
    }
    let (c, clamped) = log_coefficients(&e, &h, lambda.1);
    let f = (0..nc).map(|i| (0..nc).map(|k| e.vector(k, i) * c[k]).sum()).collect();
    Ok(RenLog {
        f,
        clamped,
        lambda,
        max_block: 0,
    })
}

/// The m-blocks of the product matrix of a zonal function (ZH vector `h`, about +z):
/// block m (0 ≤ m < n) couples (l, m) with (l', m), l, l' ≥ m; the −m block is equal.
/// Built from the Gaunt tensor.
pub fn zonal_blocks_gaunt(gaunt: &Gaunt, h: &[f64]) -> Vec<Vec<f64>> {
    let n = gaunt.order();
    let mut sh = vec![0.0; n * n];
    for (l, z) in h.iter().enumerate() {
        sh[index(l, 0)] = *z;
    }
    let m_full = gaunt.product_matrix(&sh);
    (0..n)
        .map(|m| {
            let d = n - m;
            let mut b = vec![0.0; d * d];
            for a in 0..d {
                for c in 0..d {
                    b[a * d + c] = m_full[index(a + m, m as i32) * n * n + index(c + m, m as i32)];
                }
            }
            b
        })
        .collect()
}

/// Ren's log of a zonal g given as the m-blocks of M_{g−1} and h = g − 1 (ZH): the
/// log is zonal and lives in block 0; the clamp uses the largest eigenvalue of all
/// blocks (= of the whole M_g).
pub fn ren_log_zonal_blocks(blocks: &[Vec<f64>], h: &[f64]) -> Result<RenLog, String> {
    let n = h.len();
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut e0 = None;
    let mut max_block = 0;
    for (m, b) in blocks.iter().enumerate() {
        let e = sym_eigen(b, n - m)?;
        lo = lo.min(1.0 + e.values[0]);
        if 1.0 + e.values[n - m - 1] > hi {
            hi = 1.0 + e.values[n - m - 1];
            max_block = m;
        }
        if m == 0 {
            e0 = Some(e);
        }
    }
    let e = e0.ok_or("no blocks")?;
    if hi <= 0.0 {
        return Err(format!("M_g has no positive eigenvalue (largest {hi:e})"));
    }
    let (c, clamped) = log_coefficients(&e, h, hi);
    let f = (0..n).map(|i| (0..n).map(|k| e.vector(k, i) * c[k]).sum()).collect();
    Ok(RenLog {
        f,
        clamped,
        lambda: (lo, hi),
        max_block,
    })
}

/// Ren's log of a zonal g (ZH vector, order n = `g.len()` ≤ 8), through the Gaunt
/// tensor's m-blocks (what the table build uses).
pub fn ren_log_zonal(gaunt: &Gaunt, g: &[f64]) -> Result<RenLog, String> {
    let mut h = g.to_vec();
    h[0] -= (4.0 * PI).sqrt();
    ren_log_zonal_blocks(&zonal_blocks_gaunt(gaunt, &h), &h)
}

/// ZH of the visibility of a spherical-cap blocker of angular radius `theta_b` (rad)
/// about +z, l < `order` (the runtime's closed form as a vector). Errors as the
/// runtime's (θ_b outside [0, π], order outside 1..=8).
pub fn cap_visibility_zh(theta_b: f64, order: usize) -> Result<Vec<f64>, String> {
    let g = lobefit_tables::shexp::cap_visibility_zh(theta_b, order).map_err(|e| e.to_string())?;
    Ok(g[..order].to_vec())
}

/// Scaling and squaring: exp*(f) = exp*(f/2^k)^{2^k ∗} (Taylor on f/2^k with the DC
/// term factored out, then k truncated squarings).
pub fn exp_scaling_squaring(gaunt: &Gaunt, f: &[f64], k: u32) -> ExpResult {
    let scaled: Vec<f64> = f.iter().map(|v| v / 2f64.powi(k as i32)).collect();
    let mut r = exp_star(gaunt, &scaled);
    for _ in 0..k {
        r.value = gaunt.product(&r.value, &r.value);
    }
    r
}

/// exp* by plain Taylor (re-exported for symmetry with the other variants).
pub fn exp_reference(gaunt: &Gaunt, f: &[f64]) -> ExpResult {
    exp_taylor(gaunt, f)
}

/// Gauss–Legendre points of the reference's m-block quadrature: the integrand
/// h(θ) P_l^m P_l'^m is a polynomial of degree ≤ 3(n − 1) ≤ 21 in cosθ (times
/// sin^{2m}θ, also polynomial), exact with 11 points; 16 leave a margin.
const REF_GL_POINTS: usize = 16;

/// Independent reference of the m-blocks of M_{g−1} for a zonal h = g − 1: by
/// quadrature of h(θ) y_l^m y_l'^m (Gauss–Legendre in cosθ, the φ integral done
/// analytically: 2π for m = 0, π otherwise), not from the Gaunt tensor.
pub fn zonal_blocks_quadrature(h: &[f64]) -> Vec<Vec<f64>> {
    let n = h.len();
    let (xs, ws) = lobefit_core::sh::gauss_legendre(REF_GL_POINTS);
    let mut blocks: Vec<Vec<f64>> = (0..n).map(|m| vec![0.0; (n - m) * (n - m)]).collect();
    let mut y = [0.0; rt::MAX_COEFFS];
    for (&t, &w) in xs.iter().zip(&ws) {
        let s = (1.0 - t * t).sqrt();
        rt::eval_basis(n, [s, 0.0, t], &mut y).expect("unit vector");
        // h at this θ: Σ z_l y_l^0.
        let hv: f64 = (0..n).map(|l| h[l] * y[index(l, 0)]).sum();
        for (m, b) in blocks.iter_mut().enumerate() {
            let d = n - m;
            // At φ = 0 the m > 0 real SH is √2 K P cos(0) = its θ part; ∫cos² mφ dφ = π.
            let phi = if m == 0 { 2.0 * PI } else { PI };
            for a in 0..d {
                for c in 0..d {
                    b[a * d + c] += w * phi * hv * y[index(a + m, m as i32)] * y[index(c + m, m as i32)];
                }
            }
        }
    }
    blocks
}

/// A Ren log computed independently of [`ren_log_zonal`]'s numerics: product-matrix
/// blocks by quadrature ([`zonal_blocks_quadrature`]) and the log applied directly to
/// the eigenvalues, f = Σ_k ln(λ_k) r_k (r_k·1), with ln(λ_c) μ_k/(λ_c − 1) for a
/// clamped λ_k (the same convention as [`ren_log`], see `log_coefficients`).
pub fn ren_log_zonal_reference(g: &[f64]) -> Result<RenLog, String> {
    let n = g.len();
    let mut h = g.to_vec();
    h[0] -= (4.0 * PI).sqrt();
    let blocks = zonal_blocks_quadrature(&h);
    let eig: Vec<SymEigen> = blocks
        .iter()
        .enumerate()
        .map(|(m, b)| sym_eigen(b, n - m))
        .collect::<Result<_, _>>()?;
    let (max_block, hi) = eig
        .iter()
        .map(|e| 1.0 + e.values[e.n - 1])
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |b, (m, v)| if v > b.1 { (m, v) } else { b });
    let lo = eig.iter().map(|e| 1.0 + e.values[0]).fold(f64::INFINITY, f64::min);
    if hi <= 0.0 {
        return Err(format!("M_g has no positive eigenvalue (largest {hi:e})"));
    }
    let floor = REN_CLAMP * hi;
    let e = &eig[0];
    let s = (4.0 * PI).sqrt();
    let mut f = vec![0.0; n];
    let mut clamped = 0;
    for k in 0..n {
        let mu = e.values[k];
        // (Rᵀ(g − 1))_k = μ_k (Rᵀ1)_k, so the q-form's clamped term is ln(λ_c) μ_k/(λ_c − 1).
        let ln = if 1.0 + mu < floor {
            clamped += 1;
            floor.ln() * mu / (floor - 1.0)
        } else {
            mu.ln_1p()
        };
        // (Rᵀ 1)_k = r_k[0] √(4π).
        let w = ln * e.vector(k, 0) * s;
        for (i, fi) in f.iter_mut().enumerate() {
            *fi += w * e.vector(k, i);
        }
    }
    Ok(RenLog {
        f,
        clamped,
        lambda: (lo, hi),
        max_block,
    })
}

/// Iterations the Levenberg–Marquardt log may take.
pub const LM_MAX_ITER: usize = 200;
/// Relative residual ‖exp*(f) − g‖/‖g‖ at which [`lm_log`] stops: rounding level of
/// the Taylor exp* it inverts.
pub const LM_TOL: f64 = 1e-13;
/// Central-difference step of the Jacobian, relative to max(1, |f_j|): balances the
/// O(h²) truncation and the O(ε/h) rounding of exp* (ε ≈ 1e-16: h ≈ ε^{1/3}).
const LM_FD_STEP: f64 = 1e-5;

/// Result of [`lm_log`].
#[derive(Debug, Clone, PartialEq)]
pub struct LmLog {
    /// The log vector (same length as g).
    pub f: Vec<f64>,
    /// ‖exp*(f) − g‖/‖g‖ at the end.
    pub residual: f64,
    /// LM iterations used.
    pub iterations: usize,
    /// Whether the residual reached [`LM_TOL`] or stopped improving at a local minimum.
    pub converged: bool,
}

/// The "inverse exp*" log (docs/math.md, shexp): f minimising ‖exp*(f) − g‖ by Levenberg–Marquardt
/// (Marquardt's diagonal scaling, central-difference Jacobian), from `start` (e.g. Ren's
/// log), over the coefficients `params` (indices; the others stay as in `start`, e.g.
/// only m = 0 for a zonal g). Where g is not exactly exp* of anything (a clamped
/// visibility), it ends at a local minimum and says so through `residual`.
pub fn lm_log(gaunt: &Gaunt, g: &[f64], start: &[f64], params: &[usize]) -> Result<LmLog, String> {
    let nc = gaunt.order() * gaunt.order();
    if g.len() != nc || start.len() != nc || params.iter().any(|&p| p >= nc) {
        return Err(format!("g and start need {nc} coefficients and params indices < {nc}"));
    }
    let gn = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    let resid = |f: &[f64]| -> Vec<f64> { exp_star(gaunt, f).value.iter().zip(g).map(|(a, b)| a - b).collect() };
    let norm = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>().sqrt();
    let np = params.len();
    let mut f = start.to_vec();
    let mut r = resid(&f);
    let mut cost = norm(&r);
    let mut lambda = 1e-3;
    for it in 0..LM_MAX_ITER {
        if cost <= LM_TOL * gn {
            return Ok(LmLog {
                f,
                residual: cost / gn,
                iterations: it,
                converged: true,
            });
        }
        // Jacobian columns by central differences.
        let mut jac = vec![0.0; nc * np];
        for (c, &p) in params.iter().enumerate() {
            let h = LM_FD_STEP * f[p].abs().max(1.0);
            let mut fp = f.clone();
            fp[p] += h;
            let rp = resid(&fp);
            fp[p] -= 2.0 * h;
            let rm = resid(&fp);
            for i in 0..nc {
                jac[i * np + c] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let mut jtj = vec![0.0; np * np];
        let mut jtr = vec![0.0; np];
        for i in 0..nc {
            for a in 0..np {
                jtr[a] += jac[i * np + a] * r[i];
                for b in 0..np {
                    jtj[a * np + b] += jac[i * np + a] * jac[i * np + b];
                }
            }
        }
        let mut improved = false;
        while lambda < 1e12 {
            let mut m = jtj.clone();
            for a in 0..np {
                m[a * np + a] += lambda * jtj[a * np + a].max(1e-300);
            }
            // Solve m δ = −Jᵀr through the symmetric eigen-decomposition (m is SPD).
            let e = sym_eigen(&m, np)?;
            let mut step = vec![0.0; np];
            for k in 0..np {
                if e.values[k] <= 0.0 {
                    continue;
                }
                let c: f64 = (0..np).map(|a| e.vector(k, a) * -jtr[a]).sum::<f64>() / e.values[k];
                for (a, s) in step.iter_mut().enumerate() {
                    *s += c * e.vector(k, a);
                }
            }
            let mut trial = f.clone();
            for (&p, s) in params.iter().zip(&step) {
                trial[p] += s;
            }
            let rt = resid(&trial);
            let ct = norm(&rt);
            if ct.is_finite() && ct < cost {
                f = trial;
                r = rt;
                cost = ct;
                lambda = (lambda * 0.2).max(1e-12);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            // A local minimum (no step along the damped Gauss–Newton path helps).
            return Ok(LmLog {
                f,
                residual: cost / gn,
                iterations: it + 1,
                converged: true,
            });
        }
    }
    Ok(LmLog {
        f,
        residual: cost / gn,
        iterations: LM_MAX_ITER,
        converged: false,
    })
}

/// [`lm_log`] for a zonal g (ZH vector about +z): starts from Ren's log and optimises
/// the m = 0 coefficients; returns the ZH log.
pub fn lm_log_zonal(gaunt: &Gaunt, g: &[f64]) -> Result<LmLog, String> {
    let start = zh_to_sh_z(&ren_log_zonal(gaunt, g)?.f);
    let params: Vec<usize> = (0..g.len()).map(|l| index(l, 0)).collect();
    let r = lm_log(gaunt, &zh_to_sh_z(g), &start, &params)?;
    Ok(LmLog {
        f: params.iter().map(|&p| r.f[p]).collect(),
        ..r
    })
}

/// Expands a ZH vector (about +z) to a full SH vector of the same order.
pub fn zh_to_sh_z(zh: &[f64]) -> Vec<f64> {
    let n = zh.len();
    let mut v = vec![0.0; n * n];
    for (l, z) in zh.iter().enumerate() {
        v[index(l, 0)] = *z;
    }
    v
}

/// SH projection of the exact visibility of a set of caps (axes `dirs`, unit, and
/// angular radii `radii`): ∫ Π_k (1 − cap_k) y_i dω by the product rule `rule`
/// (the visibility is discontinuous, so this is an approximation converging with
/// the rule's size; see the evaluation for the rule used).
pub fn exact_visibility_sh(rule: &SphereRule, order: usize, dirs: &[[f64; 3]], radii: &[f64]) -> Vec<f64> {
    let cos: Vec<f64> = radii.iter().map(|r| r.cos()).collect();
    rule.project(order, |p| {
        let blocked = dirs
            .iter()
            .zip(&cos)
            .any(|(d, c)| d[0] * p[0] + d[1] * p[1] + d[2] * p[2] > *c);
        if blocked {
            0.0
        } else {
            1.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cap-visibility closed form against the checker's adaptive quadrature.
    #[test]
    fn cap_visibility_matches_quadrature() {
        for &tb in &[1e-3, 0.3, 1.0, PI / 2.0, 2.5] {
            let c = f64::cos(tb);
            let (want, ok) = lobefit_core::sh::zh_project_gk(8, |t| if t > c { 0.0 } else { 1.0 }, &[c], 1e-14);
            assert!(ok);
            let got = cap_visibility_zh(tb, 8).unwrap();
            for l in 0..8 {
                assert!(
                    (got[l] - want[l]).abs() < 1e-12,
                    "θ_b={tb} l={l}: {} vs {}",
                    got[l],
                    want[l]
                );
            }
        }
    }

    /// Gaunt-built blocks equal the quadrature-built ones.
    #[test]
    fn zonal_blocks_agree() {
        for n in [3usize, 8] {
            let g = Gaunt::new(n);
            let h: Vec<f64> = cap_visibility_zh(0.9, n).unwrap();
            let a = zonal_blocks_gaunt(&g, &h);
            let b = zonal_blocks_quadrature(&h);
            for (x, y) in a.iter().zip(&b) {
                for (u, v) in x.iter().zip(y) {
                    assert!((u - v).abs() < 1e-13, "{u} vs {v}");
                }
            }
        }
    }

    /// Ren's log of a constant is the constant's log; of g = exp*(f0) it returns f0
    /// up to the truncation's non-commutativity (M_{exp*(f)} ≠ exp(M_f) once products
    /// are truncated: second order in f0, ≤ 3e-7 for this f0); the full-matrix, block
    /// and quadrature-reference versions agree to rounding.
    #[test]
    fn ren_log_inverts_exp() {
        let gaunt = Gaunt::new(4);
        let mut c = vec![0.0; 16];
        c[0] = 0.3 * (4.0 * PI).sqrt();
        let r = ren_log(&gaunt, &c).unwrap();
        assert!((r.f[0] - 0.3f64.ln() * (4.0 * PI).sqrt()).abs() < 1e-14);
        assert!(r.f[1..].iter().all(|v| v.abs() < 1e-14));
        let f0 = [
            0.1, -0.2, 0.3, 0.05, 0.02, -0.01, 0.04, 0.0, 0.1, 0.0, 0.0, 0.03, -0.05, 0.0, 0.0, 0.01,
        ];
        let g = exp_taylor(&gaunt, &f0).value;
        let r = ren_log(&gaunt, &g).unwrap();
        assert_eq!(r.clamped, 0);
        for (i, (a, b)) in r.f.iter().zip(&f0).enumerate() {
            assert!((a - b).abs() < 1e-5, "{i}: {a} vs {b}");
        }
        let gz = cap_visibility_zh(0.4, 4).unwrap();
        let full = ren_log(&gaunt, &zh_to_sh_z(&gz)).unwrap();
        let zonal = ren_log_zonal(&gaunt, &gz).unwrap();
        let refr = ren_log_zonal_reference(&gz).unwrap();
        for l in 0..4 {
            assert!((full.f[index(l, 0)] - zonal.f[l]).abs() < 1e-13);
            assert!((refr.f[l] - zonal.f[l]).abs() < 1e-13);
        }
        assert_eq!(full.lambda.1.to_bits() > 0, zonal.lambda.1 > 0.0);
        assert!((full.lambda.1 - zonal.lambda.1).abs() < 1e-13);
    }

    /// LM recovers f0 from g = exp*(f0) where Ren's log is off by the truncation's
    /// non-commutativity, and improves the round trip of a cap.
    #[test]
    fn lm_log_inverts_exp() {
        let gaunt = Gaunt::new(3);
        let f0 = [0.2, -0.3, 0.4, 0.1, 0.05, -0.02, 0.1, 0.0, 0.2];
        let g = exp_taylor(&gaunt, &f0).value;
        let start = ren_log(&gaunt, &g).unwrap().f;
        let all: Vec<usize> = (0..9).collect();
        let r = lm_log(&gaunt, &g, &start, &all).unwrap();
        assert!(r.converged && r.residual < 1e-12, "{r:?}");
        for (a, b) in r.f.iter().zip(&f0) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        let gz = cap_visibility_zh(0.6, 4).unwrap();
        let g4 = Gaunt::new(4);
        let ren = ren_log_zonal(&g4, &gz).unwrap();
        let ren_err = {
            let back = exp_star(&g4, &zh_to_sh_z(&ren.f)).value;
            let d: f64 = back.iter().zip(zh_to_sh_z(&gz)).map(|(a, b)| (a - b).powi(2)).sum();
            d.sqrt() / gz.iter().map(|v| v * v).sum::<f64>().sqrt()
        };
        let lm = lm_log_zonal(&g4, &gz).unwrap();
        assert!(lm.residual < 1e-3 * ren_err, "LM {} vs Ren {ren_err}", lm.residual);
        assert!(lm_log(&gaunt, &g, &start, &[9]).unwrap_err().contains("indices"));
    }

    #[test]
    fn ren_log_bad_input() {
        let gaunt = Gaunt::new(2);
        assert!(ren_log(&gaunt, &[1.0; 3]).unwrap_err().contains("coefficients"));
        assert!(ren_log(&gaunt, &[f64::NAN, 0.0, 0.0, 0.0])
            .unwrap_err()
            .contains("non-finite"));
        assert!(ren_log(&gaunt, &[-1.0, 0.0, 0.0, 0.0])
            .unwrap_err()
            .contains("positive"));
    }
}
