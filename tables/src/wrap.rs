//! wrap lighting (Yuan, Nowrouzezahrai & Sloan 2012, §3).
//!
//! The wrapped-diffuse kernel, a function of cosθ = t between the surface normal and the
//! light direction, with wrap parameter a ≥ 0 (a = 0 is Lambert's clamped cosine):
//! f(t | a) = ((t + a)/(1 + a))^{1+a} for t > −a, 0 below. Its per-band SH scaling
//! (the Funk–Hecke eigenvalue divided by π) is
//! λ̂_l(a) = 2 ∫_{max(−a,−1)}^{1} f(t) P_l(t) dt, so that convolving a radiance SH
//! vector L with the kernel gives E_lm = π λ̂_l(a) L_lm ([`convolve`]); at a = 0,
//! π λ̂ = (π, 2π/3, π/4, …), the Lambertian irradiance convolution.
//!
//! **Closed form, every band** ([`lambda_hat`]). For a ∈ [0, 1] the support −a ≥ −1 lies
//! inside [−1, 1]; expanding P_l(t) = Σ_k d_k (t + a)^k about t = −a (Taylor
//! coefficients d_k = P_l^{(k)}(−a)/k!) gives
//! λ̂_l(a) = 2 Σ_k d_k (1 + a)^{k+1} / (2 + a + k),
//! exact for any real a ∈ [0, 1] and any l (here l < 8), ~40 flops per band: no table is
//! needed. For l ≤ 2 this is the published form (`published`):
//! [2(1+a)/(2+a), 4(1+a)/((2+a)(3+a)), 2(1+a)(3−2a+a²)/((2+a)(3+a)(4+a))].
//! For a > 1 the kernel's support is cut at t = −1 and both formulas are wrong
//! (erratum E5: at a = 2 the published l = 2 value is 0.15, the truth 0.1185), so
//! they refuse a > 1 with [`LookupError::OutOfDomain`].
//!
//! **Table** ([`Wrap`], kind `wrap`): λ̂_0…λ̂_7 on 129 nodes a ∈ [0, 1] (linear),
//! f32, for renderers that upload a 1-D texture; linear interpolation of it is good to
//! the checker's `TABLE_INTERP_ABS` (see `lobefit check --only wrap`). The closed form
//! is what [`Wrap::lookup`] returns.

use std::f64::consts::PI;

use crate::error::{finite_result, in_range, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::sh::{self, MAX_ORDER};
use crate::table::Table;

/// Table kind.
pub const KIND: &str = "wrap";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Smallest wrap parameter.
pub const A_MIN: f64 = 0.0;
/// Largest wrap parameter of the closed forms and the table (docs/math.md, erratum E5: the closed
/// form integrates down to t = −a, which leaves [−1, 1] for a > 1).
pub const A_MAX: f64 = 1.0;
/// Nodes of the table's `a` axis.
#[cfg(feature = "writer")]
pub const A_NODES: u32 = 129;
/// Stored channels λ̂_0 … λ̂_7.
pub const CHANNELS: [&str; MAX_ORDER] = ["l0", "l1", "l2", "l3", "l4", "l5", "l6", "l7"];
/// Lambertian (clamped-cosine) irradiance convolution weights π λ̂_l(0), l ≤ 2.
pub use crate::sh::CLAMPED_COSINE;

/// Plausible range of each stored channel (name, lo, hi), dimensionless:
/// λ̂_0(a) = 2(1 + a)/(2 + a) ∈ [1, 4/3], and since the kernel is ≥ 0 and |P_l| ≤ 1,
/// |λ̂_l| ≤ λ̂_0 ≤ 4/3 for every band; the ranges add about 0.5 %.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[
    ("l0", 0.99, 1.34),
    ("l1", -1.34, 1.34),
    ("l2", -1.34, 1.34),
    ("l3", -1.34, 1.34),
    ("l4", -1.34, 1.34),
    ("l5", -1.34, 1.34),
    ("l6", -1.34, 1.34),
    ("l7", -1.34, 1.34),
];

/// Name used in the out-of-domain error of the closed forms.
const A_NAME: &str = "wrap parameter a (closed forms exact only on [0, 1], docs/math.md, erratum E5)";

/// The table's one axis: `a` on [0, 1], linear, end-point nodes.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axis(count: u32) -> Axis {
    Axis {
        name: "a".into(),
        unit: "1".into(),
        lo: A_MIN,
        hi: A_MAX,
        mapping: Mapping::Linear,
        count,
        placement: Placement::Endpoints,
    }
}

/// Monomial coefficients of the Legendre polynomials P_0 … P_7 (`[l][k]` is the
/// coefficient of t^k; the log-ZH closed forms' table), computed once.
fn legendre_monomials() -> &'static [[f64; MAX_ORDER]; MAX_ORDER] {
    static P: std::sync::OnceLock<[[f64; MAX_ORDER]; MAX_ORDER]> = std::sync::OnceLock::new();
    P.get_or_init(crate::log_zh::legendre_coeffs)
}

/// The published closed form (λ̂_0, λ̂_1, λ̂_2)(a), a ∈ [0, 1] (errors above 1, E5).
#[cfg(feature = "writer")]
pub fn published(a: f64) -> Result<[f64; 3], LookupError> {
    let a = in_range(A_NAME, a, A_MIN, A_MAX)?;
    let (b2, b3, b4) = (2.0 + a, 3.0 + a, 4.0 + a);
    Ok([
        2.0 * (1.0 + a) / b2,
        4.0 * (1.0 + a) / (b2 * b3),
        2.0 * (1.0 + a) * (3.0 - 2.0 * a + a * a) / (b2 * b3 * b4),
    ])
}

/// λ̂_l(a) for l < `order` (1..=8) into `out[..order]`, closed form, a ∈ [0, 1]
/// (dimensionless; the Funk–Hecke eigenvalue of the wrap kernel divided by π).
pub fn lambda_hat(order: usize, a: f64, out: &mut [f64]) -> Result<(), LookupError> {
    let n = sh::check_order(order)?;
    let a = in_range(A_NAME, a, A_MIN, A_MAX)?;
    if out.len() < n {
        return Err(LookupError::Output {
            got: out.len(),
            needed: n,
            what: "eigenvalues",
        });
    }
    let p = legendre_monomials();
    let s = 1.0 + a;
    for (l, o) in out.iter_mut().take(n).enumerate() {
        // d_k = Σ_{j ≥ k} p_j C(j, k) (−a)^{j−k}; term_k = d_k s^{k+1}/(2 + a + k).
        let mut sum = 0.0;
        let mut sk = s; // s^{k+1}
        for k in 0..=l {
            let mut d = 0.0;
            let mut binom = 1.0; // C(j, k), j = k first
            let mut pw = 1.0; // (−a)^{j−k}
            for (j, &pj) in p[l].iter().enumerate().take(l + 1).skip(k) {
                d += pj * binom * pw;
                binom = binom * (j + 1) as f64 / (j + 1 - k) as f64;
                pw *= -a;
            }
            sum += d * sk / (2.0 + a + k as f64);
            sk *= s;
        }
        *o = 2.0 * sum;
    }
    Ok(())
}

/// [`lambda_hat`] with an f32 interface (computed in f64, rounded once).
pub fn lambda_hat_f32(order: usize, a: f32, out: &mut [f32]) -> Result<(), LookupError> {
    let mut tmp = [0.0; MAX_ORDER];
    lambda_hat(order, a as f64, &mut tmp)?;
    crate::error::narrow_all("lambda_hat", &tmp[..order], out)
}

/// Wrap-lighting convolution of an SH vector (n² coefficients, n ≤ 8, conventions of
/// [`crate::sh`]): out_lm = π λ̂_l(a) sh_lm. For a radiance vector this is the
/// wrapped "irradiance" vector, evaluated at a normal N as Σ out_lm y_lm(N);
/// a = 0 gives the Lambertian irradiance (weights π, 2π/3, π/4, …).
pub fn convolve(coeffs: &[f64], a: f64, out: &mut [f64]) -> Result<(), LookupError> {
    let n = sh::order_of_len(coeffs.len())?;
    if out.len() < n * n {
        return Err(LookupError::Output {
            got: out.len(),
            needed: n * n,
            what: "SH coefficients",
        });
    }
    let mut lam = [0.0; MAX_ORDER];
    lambda_hat(n, a, &mut lam)?;
    for (l, &lam_l) in lam.iter().enumerate().take(n) {
        for i in l * l..(l + 1) * (l + 1) {
            // A huge finite coefficient times π λ̂_l can overflow.
            out[i] = finite_result(
                "convolved SH coefficient",
                PI * lam_l * crate::error::finite("SH coefficient", coeffs[i])?,
            )?;
        }
    }
    Ok(())
}

/// [`convolve`] with an f32 interface (computed in f64, rounded once).
pub fn convolve_f32(coeffs: &[f32], a: f32, out: &mut [f32]) -> Result<(), LookupError> {
    let c: Vec<f64> = coeffs.iter().map(|&v| v as f64).collect();
    let n = sh::order_of_len(c.len())?;
    let mut tmp = [0.0; sh::MAX_COEFFS];
    convolve(&c, a as f64, &mut tmp[..n * n])?;
    crate::error::narrow_all("convolved SH", &tmp[..n * n], out)
}

/// Re-wraps an order-n ≤ 3 *irradiance* vector (radiance already convolved with the
/// clamped cosine, e.g. a rig's output or `DiskLight::irradiance_sh`): out_lm =
/// irr_lm λ̂_l(a)/λ̂_l(0), i.e. the wrap convolution of the underlying radiance. Orders
/// above 3 are refused (λ̂_3(0) = 0: band 3 of an irradiance vector carries nothing to
/// rescale).
pub fn rewrap_irradiance(irr: &[f64], a: f64, out: &mut [f64]) -> Result<(), LookupError> {
    let n = sh::order_of_len(irr.len())?;
    if n > 3 {
        return Err(LookupError::OutOfDomain {
            name: "SH order of an irradiance vector to re-wrap".into(),
            value: n as f64,
            lo: 1.0,
            hi: 3.0,
        });
    }
    if out.len() < n * n {
        return Err(LookupError::Output {
            got: out.len(),
            needed: n * n,
            what: "SH coefficients",
        });
    }
    let mut lam = [0.0; 3];
    lambda_hat(n, a, &mut lam)?;
    let lam0 = [1.0, 2.0 / 3.0, 0.25];
    for l in 0..n {
        for i in l * l..(l + 1) * (l + 1) {
            // λ̂_l(a)/λ̂_l(0) reaches 4/3 (band 0): huge coefficients overflow.
            out[i] = finite_result(
                "re-wrapped SH coefficient",
                crate::error::finite("SH coefficient", irr[i])? * lam[l] / lam0[l],
            )?;
        }
    }
    Ok(())
}

/// [`rewrap_irradiance`] with an f32 interface (computed in f64, rounded once).
pub fn rewrap_irradiance_f32(irr: &[f32], a: f32, out: &mut [f32]) -> Result<(), LookupError> {
    let wide: Vec<f64> = irr.iter().map(|&v| v as f64).collect();
    let mut tmp = vec![0.0; wide.len()];
    rewrap_irradiance(&wide, a as f64, &mut tmp)?;
    crate::error::narrow_all("re-wrapped irradiance", &tmp, out)
}

/// The wrap table: λ̂_0 … λ̂_7 against a ∈ [0, 1] (for texture upload).
#[derive(Debug, Clone)]
pub struct Wrap {
    table: Table,
}

crate::table_type::impl_table_type!(Wrap: KIND, VERSION);

impl Wrap {
    /// Wraps an already loaded table, checking its kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        let chans: Vec<(&str, Encoding)> = CHANNELS.iter().map(|&c| (c, Encoding::Linear)).collect();
        table.expect_layout_1d(&axis(table.meta().axes.first().map_or(0, |a| a.count)), &chans)?;
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        Ok(Self { table })
    }

    /// λ̂_l(a), l < `order`, from the closed form ([`lambda_hat`]; the accurate path).
    pub fn lookup(&self, order: usize, a: f64, out: &mut [f64]) -> Result<(), LookupError> {
        lambda_hat(order, a, out)
    }

    /// [`Wrap::lookup`] with an f32 interface (computed in f64, rounded once).
    pub fn lookup_f32(&self, order: usize, a: f32, out: &mut [f32]) -> Result<(), LookupError> {
        lambda_hat_f32(order, a, out)
    }

    /// [`Wrap::table_lookup`] with an f32 interface (computed in f64, rounded once).
    pub fn table_lookup_f32(&self, order: usize, a: f32, out: &mut [f32]) -> Result<(), LookupError> {
        let n = sh::check_order(order)?;
        let mut tmp = [0.0; MAX_ORDER];
        self.table_lookup(n, a as f64, &mut tmp)?;
        crate::error::narrow_all("lambda_hat", &tmp[..n], out)
    }

    /// λ̂_l(a), l < `order`, linearly interpolated from the stored f32 nodes (what a
    /// shader sampling the uploaded texture gets).
    pub fn table_lookup(&self, order: usize, a: f64, out: &mut [f64]) -> Result<(), LookupError> {
        let n = sh::check_order(order)?;
        if out.len() < n {
            return Err(LookupError::Channels {
                expected: n,
                got: out.len(),
            });
        }
        let mut all = [0.0; MAX_ORDER];
        self.table.interpolate(&[a], &mut all)?;
        out[..n].copy_from_slice(&all[..n]);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamped_cosine_at_zero() {
        let mut l = [0.0; 8];
        lambda_hat(8, 0.0, &mut l).unwrap();
        for k in 0..3 {
            assert!((PI * l[k] - CLAMPED_COSINE[k]).abs() < 1e-15);
        }
        // Known clamped-cosine values: λ̂_3 = 0, λ̂_4 = −1/24, λ̂_5 = 0, λ̂_6 = 1/64.
        assert!(l[3].abs() < 1e-15 && (l[4] + 1.0 / 24.0).abs() < 1e-15);
        assert!(l[5].abs() < 1e-15 && (l[6] - 1.0 / 64.0).abs() < 1e-15);
    }

    #[test]
    fn general_form_is_published_form() {
        for k in 0..=100 {
            let a = k as f64 / 100.0;
            let mut l = [0.0; 3];
            lambda_hat(3, a, &mut l).unwrap();
            let p = published(a).unwrap();
            for b in 0..3 {
                assert!((l[b] - p[b]).abs() < 1e-14, "a={a} l={b}");
            }
        }
    }

    /// Re-wrapping the Lambertian irradiance of a radiance vector equals convolving the
    /// radiance with the wrap kernel.
    #[test]
    fn rewrap_matches_convolve() {
        let rad = [0.9, -0.2, 0.4, 0.1, 0.3, -0.1, 0.2, 0.05, -0.15];
        let (mut irr, mut wrapped, mut direct) = ([0.0; 9], [0.0; 9], [0.0; 9]);
        convolve(&rad, 0.0, &mut irr).unwrap();
        rewrap_irradiance(&irr, 0.7, &mut wrapped).unwrap();
        convolve(&rad, 0.7, &mut direct).unwrap();
        for i in 0..9 {
            assert!((wrapped[i] - direct[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn bad_inputs() {
        let mut l = [0.0; 8];
        assert!(matches!(published(2.0), Err(LookupError::OutOfDomain { .. })));
        assert!(matches!(
            lambda_hat(3, 1.5, &mut l),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            lambda_hat(3, -0.1, &mut l),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            lambda_hat(3, f64::NAN, &mut l),
            Err(LookupError::NotFinite { .. })
        ));
        assert!(matches!(
            lambda_hat(9, 0.5, &mut l),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            lambda_hat(0, 0.5, &mut l),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            lambda_hat(8, 0.5, &mut l[..4]),
            Err(LookupError::Output { .. })
        ));
        let mut o = [0.0; 9];
        assert!(matches!(
            convolve(&[1.0; 8], 0.5, &mut o),
            Err(LookupError::ShLength { .. })
        ));
        assert!(matches!(
            convolve(&[1.0; 9], 1.5, &mut o),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            convolve(&[f64::NAN; 9], 0.5, &mut o),
            Err(LookupError::NotFinite { .. })
        ));
        let mut o16 = [0.0; 16];
        assert!(matches!(
            rewrap_irradiance(&[1.0; 16], 0.5, &mut o16),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            rewrap_irradiance(&[1.0; 9], 1.5, &mut o),
            Err(LookupError::OutOfDomain { .. })
        ));
    }
}
