//! real spherical harmonics (SH) for renderers: basis evaluation, zonal (ZH)
//! rotation, rotation about z and general rotation, for orders 1..=8.
//!
//! # Conventions (docs/math.md §1; stated once, used by every SH routine in lobefit)
//!
//! - Real SH, orthonormal on the unit sphere (∫ y_i y_j dω = δ_ij), with the
//!   Condon–Shortley phase folded in (Sloan's "Stupid SH Tricks", the thesis eq. 3.36):
//!   y_0^0 = 1/(2√π), y_1^{-1} = −√(3/4π) y, y_1^0 = √(3/4π) z, y_1^1 = −√(3/4π) x.
//!   In general, with K_l^m = √((2l+1)/(4π) (l−|m|)!/(l+|m|)!) and P_l^m the associated
//!   Legendre function *including* the (−1)^m phase:
//!   y_l^m = √2 K_l^m P_l^m(cosθ) cos(mφ) (m > 0), K_l^0 P_l(cosθ) (m = 0),
//!   √2 K_l^|m| P_l^|m|(cosθ) sin(|m|φ) (m < 0).
//! - Direction v = (sinθ cosφ, sinθ sinφ, cosθ): θ from +z, φ from +x towards +y.
//! - Single index i = l(l+1) + m ([`index`]); "order n" = bands l = 0..n−1, n²
//!   coefficients ([`coeff_count`]); every routine works for 1 ≤ n ≤ [`MAX_ORDER`].
//! - Zonal harmonics: z_l = ∫ f y_l^0 dω for f symmetric about +z. A ZH lobe turned
//!   to axis d has SH coefficients f_l^m = √(4π/(2l+1)) z_l y_l^m(d) ([`zh_to_sh`]).
//! - Rotation: a 3×3 rotation matrix `r` (row-major, `r[i][j]`) maps direction d to
//!   r·d. Rotating a function by r means f'(v) = f(rᵀ v), i.e. the lobe that pointed
//!   along d points along r·d afterwards. [`Rotation`] maps the coefficients of f to
//!   those of f'.
//!
//! Two evaluation paths, tested against each other: hard-coded polynomials for
//! orders ≤ 4 (`eval_basis_hardcoded`) and the associated-Legendre recurrence in
//! Cartesian form for any order (`eval_basis_recurrence`); [`eval_basis`] picks the
//! fast one. f32 twins exist for the renderer-facing functions.
//!
//! General rotation uses the exact recurrences of Ivanic & Ruedenberg (J. Phys. Chem.
//! 1996, 100, 6342; errata 1998, 102, 9099), as in google/spherical-harmonics: band l
//! of the rotation is built from band l−1 and band 1 (which is the rotation matrix
//! itself, permuted), so it is exact to rounding for any rotation.

use std::f64::consts::PI;

use crate::error::{finite, finite_results, narrow_all, LookupError};
use glam::{DVec3, Vec3};

/// Largest supported order (bands l = 0..7).
pub const MAX_ORDER: usize = 8;
/// Coefficients of an order-[`MAX_ORDER`] vector.
pub const MAX_COEFFS: usize = MAX_ORDER * MAX_ORDER;
/// Clamped-cosine (Lambertian irradiance) convolution weights per band, l ≤ 2:
/// π·(1, 2/3, 1/4), the Funk–Hecke eigenvalues of max(cos θ, 0).
pub const CLAMPED_COSINE: [f64; 3] = [PI, 2.0 * PI / 3.0, PI / 4.0];
/// Largest order evaluated by the hard-coded polynomials.
pub(crate) const HARDCODED_MAX_ORDER: usize = 4;
/// How far rᵀr may be from the identity (max entry) for `r` to count as a rotation:
/// loose enough for matrices built in f32 and converted, tight enough to catch scaling.
pub const ROTATION_ORTHONORMALITY_TOL: f64 = 1e-5;

/// Single index i = l(l+1) + m of the coefficient (l, m), |m| ≤ l.
pub const fn index(l: usize, m: i32) -> usize {
    ((l * (l + 1)) as i32 + m) as usize
}

/// Number of coefficients n² of order n.
pub const fn coeff_count(order: usize) -> usize {
    order * order
}

/// (l, m) of single index i.
pub fn band_of(i: usize) -> (usize, i32) {
    let l = (i as f64).sqrt() as usize;
    // Guard against sqrt rounding for perfect squares.
    let l = if (l + 1) * (l + 1) <= i { l + 1 } else { l };
    (l, i as i32 - (l * (l + 1)) as i32)
}

/// Checks 1 ≤ order ≤ [`MAX_ORDER`].
pub fn check_order(order: usize) -> Result<usize, LookupError> {
    if (1..=MAX_ORDER).contains(&order) {
        Ok(order)
    } else {
        Err(LookupError::OutOfDomain {
            name: "SH order".into(),
            value: order as f64,
            lo: 1.0,
            hi: MAX_ORDER as f64,
        })
    }
}

fn check_len(len: usize, want: usize) -> Result<(), LookupError> {
    if len < want {
        Err(LookupError::Output {
            got: len,
            needed: want,
            what: "SH coefficients",
        })
    } else {
        Ok(())
    }
}

/// Unit vector along `d`; errors on non-finite or zero-length input.
pub fn normalize(d: impl Into<DVec3>) -> Result<DVec3, LookupError> {
    let d = d.into();
    for (k, &c) in d.to_array().iter().enumerate() {
        finite(["direction.x", "direction.y", "direction.z"][k], c)?;
    }
    let n = d.length();
    if !(n > 0.0 && n.is_finite()) {
        return Err(LookupError::OutOfDomain {
            name: "direction length".into(),
            value: n,
            lo: f64::MIN_POSITIVE,
            hi: f64::MAX,
        });
    }
    Ok(d / n)
}

/// Normalisation K_l^m = √((2l+1)/(4π) (l−m)!/(l+m)!) for 0 ≤ m ≤ l.
pub fn k_lm(l: usize, m: usize) -> f64 {
    let mut ratio = 1.0; // (l−m)!/(l+m)!
    for k in (l - m + 1)..=(l + m) {
        ratio /= k as f64;
    }
    ((2 * l + 1) as f64 / (4.0 * PI) * ratio).sqrt()
}

/// K_l^m for l, m < 8, computed once.
fn k_table() -> &'static [[f64; MAX_ORDER]; MAX_ORDER] {
    static K: std::sync::OnceLock<[[f64; MAX_ORDER]; MAX_ORDER]> = std::sync::OnceLock::new();
    K.get_or_init(|| {
        let mut k = [[0.0; MAX_ORDER]; MAX_ORDER];
        for (l, row) in k.iter_mut().enumerate() {
            for (m, v) in row.iter_mut().enumerate().take(l + 1) {
                *v = k_lm(l, m);
            }
        }
        k
    })
}

/// Basis values y_0 … y_{n²−1} at direction `d` (normalised here; need not be unit)
/// into `out[..n²]`. Uses the hard-coded path for n ≤ 4, the recurrence above.
pub fn eval_basis(order: usize, d: impl Into<DVec3>, out: &mut [f64]) -> Result<(), LookupError> {
    let d = d.into();
    if order <= HARDCODED_MAX_ORDER {
        eval_basis_hardcoded(order, d, out)
    } else {
        eval_basis_recurrence(order, d, out)
    }
}

/// [`eval_basis`] with an f32 interface (computed in f64, rounded once).
pub fn eval_basis_f32(order: usize, d: impl Into<Vec3>, out: &mut [f32]) -> Result<(), LookupError> {
    let n = coeff_count(check_order(order)?);
    check_len(out.len(), n)?;
    let mut tmp = [0.0f64; MAX_COEFFS];
    eval_basis(order, d.into().as_dvec3(), &mut tmp)?;
    for (o, t) in out.iter_mut().zip(&tmp[..n]) {
        *o = *t as f32;
    }
    Ok(())
}

/// Basis by the associated-Legendre recurrence, any order 1..=8.
///
/// Cartesian form: (1−z²)^{m/2} (cos mφ, sin mφ) = (Re, Im)(x + iy)^m for unit d, and
/// P_l^m = (−1)^m (1−z²)^{m/2} Q_l^m(z) with Q_l^m = d^m P_l/dz^m, which obeys
/// Q_m^m = (2m−1)!!, (l−m) Q_l^m = (2l−1) z Q_{l−1}^m − (l+m−1) Q_{l−2}^m.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn eval_basis_recurrence(order: usize, d: impl Into<DVec3>, out: &mut [f64]) -> Result<(), LookupError> {
    let n = check_order(order)?;
    check_len(out.len(), n * n)?;
    let [x, y, z] = normalize(d)?.to_array();
    let (mut c, mut s) = (1.0, 0.0); // Re, Im of (x + iy)^m
    let mut dfact = 1.0; // (2m−1)!!
    for m in 0..n {
        if m > 0 {
            (c, s) = (c * x - s * y, c * y + s * x);
            dfact *= (2 * m - 1) as f64;
        }
        let sign = if m % 2 == 1 { -1.0 } else { 1.0 };
        let (mut q_prev, mut q) = (0.0, dfact); // Q_{l−1}^m, Q_l^m at l = m
        for l in m..n {
            if l > m {
                let q_next = ((2 * l - 1) as f64 * z * q - (l + m - 1) as f64 * q_prev) / (l - m) as f64;
                q_prev = q;
                q = q_next;
            }
            let k = k_table()[l][m];
            if m == 0 {
                out[index(l, 0)] = k * q;
            } else {
                let a = std::f64::consts::SQRT_2 * k * sign * q;
                out[index(l, m as i32)] = a * c;
                out[index(l, -(m as i32))] = a * s;
            }
        }
    }
    Ok(())
}

/// Basis by hard-coded polynomials in (x, y, z), orders 1..=4 (Sloan's table).
#[allow(clippy::excessive_precision)]
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn eval_basis_hardcoded(order: usize, d: impl Into<DVec3>, out: &mut [f64]) -> Result<(), LookupError> {
    let n = check_order(order)?;
    if n > HARDCODED_MAX_ORDER {
        return Err(LookupError::OutOfDomain {
            name: "hard-coded SH order".into(),
            value: n as f64,
            lo: 1.0,
            hi: HARDCODED_MAX_ORDER as f64,
        });
    }
    check_len(out.len(), n * n)?;
    let [x, y, z] = normalize(d)?.to_array();
    out[0] = 0.282_094_791_773_878_14; // 1/(2√π)
    if n == 1 {
        return Ok(());
    }
    const C1: f64 = 0.488_602_511_902_919_92; // √(3/4π)
    out[1] = -C1 * y;
    out[2] = C1 * z;
    out[3] = -C1 * x;
    if n == 2 {
        return Ok(());
    }
    const C2A: f64 = 1.092_548_430_592_079_2; // √(15/4π)
    const C2B: f64 = 0.315_391_565_252_520_05; // √(5/16π)
    const C2C: f64 = 0.546_274_215_296_039_6; // √(15/16π)
    out[4] = C2A * x * y;
    out[5] = -C2A * y * z;
    out[6] = C2B * (3.0 * z * z - 1.0);
    out[7] = -C2A * x * z;
    out[8] = C2C * (x * x - y * y);
    if n == 3 {
        return Ok(());
    }
    const C3A: f64 = 0.590_043_589_926_643_5; // √(35/32π)
    const C3B: f64 = 2.890_611_442_640_554; // √(105/4π)
    const C3C: f64 = 0.457_045_799_464_465_8; // √(21/32π)
    const C3D: f64 = 0.373_176_332_590_115_4; // √(7/16π)
    const C3E: f64 = 1.445_305_721_320_277; // √(105/16π)
    out[9] = -C3A * y * (3.0 * x * x - y * y);
    out[10] = C3B * x * y * z;
    out[11] = -C3C * y * (5.0 * z * z - 1.0);
    out[12] = C3D * z * (5.0 * z * z - 3.0);
    out[13] = -C3C * x * (5.0 * z * z - 1.0);
    out[14] = C3E * z * (x * x - y * y);
    out[15] = -C3A * x * (x * x - 3.0 * y * y);
    Ok(())
}

/// Normalised Legendre-based zonal basis y_l^0(cosθ) = √((2l+1)/4π) P_l(t), l < n, into `out`.
pub fn eval_zonal(order: usize, t: f64, out: &mut [f64]) -> Result<(), LookupError> {
    let n = check_order(order)?;
    check_len(out.len(), n)?;
    let t = crate::error::in_range("cos theta", t, -1.0, 1.0)?;
    let (mut p_prev, mut p) = (0.0, 1.0);
    for (l, o) in out.iter_mut().take(n).enumerate() {
        if l > 0 {
            let next = ((2 * l - 1) as f64 * t * p - (l - 1) as f64 * p_prev) / l as f64;
            p_prev = p;
            p = next;
        }
        *o = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * p;
    }
    Ok(())
}

/// Turns a ZH vector `zh` (z_0 … z_{n−1}, symmetric about +z) to axis `d`:
/// out[(l,m)] = √(4π/(2l+1)) z_l y_l^m(d) (Funk–Hecke), n = `zh.len()`, n² outputs.
pub fn zh_to_sh(zh: &[f64], d: impl Into<DVec3>, out: &mut [f64]) -> Result<(), LookupError> {
    let n = check_order(zh.len())?;
    check_len(out.len(), n * n)?;
    for &z in zh {
        finite("zh coefficient", z)?;
    }
    eval_basis(n, d, out)?;
    for (l, &z) in zh.iter().enumerate() {
        let s = (4.0 * PI / (2 * l + 1) as f64).sqrt() * z;
        for m in -(l as i32)..=(l as i32) {
            out[index(l, m)] *= s;
        }
    }
    // No overflow check: |out_lm| ≤ |z_l| since |y_l^m| ≤ √((2l+1)/(4π)).
    Ok(())
}

/// [`zh_to_sh`] with an f32 interface (computed in f64, rounded once).
pub fn zh_to_sh_f32(zh: &[f32], d: impl Into<Vec3>, out: &mut [f32]) -> Result<(), LookupError> {
    let n = check_order(zh.len())?;
    check_len(out.len(), n * n)?;
    let z: Vec<f64> = zh.iter().map(|&v| v as f64).collect();
    let mut tmp = [0.0f64; MAX_COEFFS];
    zh_to_sh(&z, d.into().as_dvec3(), &mut tmp)?;
    narrow_all("SH coefficient", &tmp[..n * n], out)
}

/// Order n of a coefficient vector of length n² (error unless a square in 1..=64).
pub fn order_of_len(len: usize) -> Result<usize, LookupError> {
    let n = (len as f64).sqrt().round() as usize;
    if n * n != len || !(1..=MAX_ORDER).contains(&n) {
        return Err(LookupError::ShLength {
            got: len,
            max_order: MAX_ORDER,
        });
    }
    Ok(n)
}

/// Rotation about +z by `alpha` (rad, counter-clockwise seen from +z): out = coefficients
/// of f'(θ, φ) = f(θ, φ − α). `coeffs.len()` = n²; `out` at least as long.
/// Per band and |m|: (a, b) = (f_{l,m}, f_{l,−m}) ↦ (a cos mα − b sin mα, a sin mα + b cos mα).
pub fn rotate_z(coeffs: &[f64], alpha: f64, out: &mut [f64]) -> Result<(), LookupError> {
    let n = order_of_len(coeffs.len())?;
    check_len(out.len(), n * n)?;
    finite("alpha", alpha)?;
    for &c in coeffs {
        finite("SH coefficient", c)?;
    }
    for l in 0..n {
        out[index(l, 0)] = coeffs[index(l, 0)];
        for m in 1..=l as i32 {
            let (s, c) = (m as f64 * alpha).sin_cos();
            let a = coeffs[index(l, m)];
            let b = coeffs[index(l, -m)];
            out[index(l, m)] = a * c - b * s;
            out[index(l, -m)] = a * s + b * c;
        }
    }
    // a cos − b sin of two huge coefficients can overflow (up to √2 × the larger).
    finite_results("rotated SH coefficient", &out[..n * n])
}

/// [`rotate_z`] with an f32 interface (computed in f64, rounded once).
pub fn rotate_z_f32(coeffs: &[f32], alpha: f32, out: &mut [f32]) -> Result<(), LookupError> {
    let c: Vec<f64> = coeffs.iter().map(|&v| v as f64).collect();
    let mut tmp = [0.0f64; MAX_COEFFS];
    let n = order_of_len(c.len())?;
    rotate_z(&c, alpha as f64, &mut tmp[..n * n])?;
    check_len(out.len(), n * n)?;
    narrow_all("rotated SH coefficient", &tmp[..n * n], out)
}

/// Rotation matrix about +z by `alpha` (rad).
pub fn rotation_z(alpha: f64) -> [[f64; 3]; 3] {
    let (s, c) = alpha.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// Rotation matrix about unit `axis` by `angle` (rad), right-handed (Rodrigues).
pub fn rotation_axis_angle(axis: impl Into<DVec3>, angle: f64) -> Result<[[f64; 3]; 3], LookupError> {
    let [x, y, z] = normalize(axis)?.to_array();
    finite("angle", angle)?;
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    Ok([
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ])
}

/// The SH rotation matrices of one 3×3 rotation, bands 0..n−1 (block diagonal).
///
/// Built once per rotation (O(n⁴) work for the recurrence), applied many times
/// ([`Rotation::apply`], O(Σ(2l+1)²)).
#[derive(Debug, Clone, PartialEq)]
pub struct Rotation {
    order: usize,
    /// Band l's (2l+1)×(2l+1) matrix, row-major, rows/columns m = −l..l.
    bands: Vec<Vec<f64>>,
}

impl Rotation {
    /// [`Rotation::new`] for a glam matrix `m` (maps d to `m * d`).
    pub fn from_mat3(order: usize, m: glam::DMat3) -> Result<Rotation, LookupError> {
        // glam stores columns; `new` takes rows: row i = (m.x_axis[i], m.y_axis[i], m.z_axis[i]).
        Rotation::new(order, m.transpose().to_cols_array_2d())
    }

    /// SH rotation of order `order` for the rotation matrix `r` (row-major, maps d to
    /// r·d). Errors when `r` is not finite, not orthonormal within
    /// [`ROTATION_ORTHONORMALITY_TOL`], or a reflection (det < 0).
    pub fn new(order: usize, r: [[f64; 3]; 3]) -> Result<Rotation, LookupError> {
        let n = check_order(order)?;
        for row in &r {
            for &v in row {
                finite("rotation entry", v)?;
            }
        }
        let mut defect: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                defect = defect.max((dot - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
            + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
        if defect > ROTATION_ORTHONORMALITY_TOL || det < 0.0 {
            return Err(LookupError::OutOfDomain {
                name: "rotation matrix orthonormality defect (or reflection)".into(),
                value: if det < 0.0 { det } else { defect },
                lo: 0.0,
                hi: ROTATION_ORTHONORMALITY_TOL,
            });
        }
        Ok(Rotation {
            order: n,
            bands: ivanic_ruedenberg(n, &r),
        })
    }

    /// Rotation about +z by `alpha` (same result as [`rotate_z`]).
    pub fn about_z(order: usize, alpha: f64) -> Result<Rotation, LookupError> {
        finite("alpha", alpha)?;
        Rotation::new(order, rotation_z(alpha))
    }

    /// Order n of the rotation.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Band l's matrix (row-major, (2l+1)², rows and columns m = −l..l), l < n.
    pub fn band(&self, l: usize) -> &[f64] {
        &self.bands[l]
    }

    /// out = coefficients of the rotated function; `coeffs.len()` = m² with
    /// m ≤ the rotation's order (lower orders use the leading bands).
    pub fn apply(&self, coeffs: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
        let n = order_of_len(coeffs.len())?;
        if n > self.order {
            return Err(LookupError::Coefficients {
                name: "coeffs",
                got: coeffs.len(),
                expected: format!(
                    "at most {} (the rotation's order {})",
                    self.order * self.order,
                    self.order
                ),
            });
        }
        check_len(out.len(), n * n)?;
        for &c in coeffs {
            finite("SH coefficient", c)?;
        }
        for l in 0..n {
            let w = 2 * l + 1;
            let off = l * l;
            let b = &self.bands[l];
            for row in 0..w {
                out[off + row] = (0..w).map(|col| b[row * w + col] * coeffs[off + col]).sum();
            }
        }
        // Rotations preserve each band's norm, but one coefficient can grow up to
        // √(2l+1) × the band's largest: huge inputs overflow.
        finite_results("rotated SH coefficient", &out[..n * n])
    }

    /// [`Rotation::apply`] with an f32 interface (computed in f64, rounded once).
    pub fn apply_f32(&self, coeffs: &[f32], out: &mut [f32]) -> Result<(), LookupError> {
        let c: Vec<f64> = coeffs.iter().map(|&v| v as f64).collect();
        let n = order_of_len(c.len())?;
        let mut tmp = [0.0f64; MAX_COEFFS];
        self.apply(&c, &mut tmp[..n * n])?;
        check_len(out.len(), n * n)?;
        narrow_all("rotated SH coefficient", &tmp[..n * n], out)
    }
}

/// Ivanic–Ruedenberg recurrences. They are stated for real SH *without* the
/// Condon–Shortley phase; ours differ from those by (−1)^m on both ±m, so the band
/// matrices are computed in that basis and conjugated by diag((−1)^m) at the end.
fn ivanic_ruedenberg(n: usize, r: &[[f64; 3]; 3]) -> Vec<Vec<f64>> {
    let mut bands: Vec<Vec<f64>> = vec![vec![1.0]];
    if n == 1 {
        return bands;
    }
    // Band 1 (no CS phase): y_1^{−1,0,1} ∝ (y, z, x), so D1[m][m'] = r[p(m)][p(m')].
    let p = [1usize, 2, 0];
    let mut b1 = vec![0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            b1[i * 3 + j] = r[p[i]][p[j]];
        }
    }
    bands.push(b1);
    for l in 2..n {
        let prev = &bands[l - 1];
        let r1 = &bands[1];
        let lp = l as i32 - 1;
        let wp = 2 * l - 1;
        let g1 = |i: i32, j: i32| r1[((i + 1) * 3 + (j + 1)) as usize];
        let gp = |a: i32, b: i32| prev[((a + lp) as usize) * wp + (b + lp) as usize];
        let li = l as i32;
        let pf = |i: i32, a: i32, b: i32| -> f64 {
            if b == li {
                g1(i, 1) * gp(a, li - 1) - g1(i, -1) * gp(a, -li + 1)
            } else if b == -li {
                g1(i, 1) * gp(a, -li + 1) + g1(i, -1) * gp(a, li - 1)
            } else {
                g1(i, 0) * gp(a, b)
            }
        };
        let w = 2 * l + 1;
        let mut band = vec![0.0; w * w];
        for m in -li..=li {
            for k in -li..=li {
                let d0 = if m == 0 { 1.0 } else { 0.0 };
                let denom = if k.abs() == li {
                    (2 * li * (2 * li - 1)) as f64
                } else {
                    ((li + k) * (li - k)) as f64
                };
                let am = m.abs();
                let u = (((li + m) * (li - m)) as f64 / denom).sqrt();
                let v = 0.5 * ((1.0 + d0) * ((li + am - 1) * (li + am)) as f64 / denom).sqrt() * (1.0 - 2.0 * d0);
                let wc = -0.5 * (((li - am - 1) * (li - am)) as f64 / denom).sqrt() * (1.0 - d0);
                let mut val = 0.0;
                if u != 0.0 {
                    val += u * pf(0, m, k);
                }
                if v != 0.0 {
                    let vv = if m == 0 {
                        pf(1, 1, k) + pf(-1, -1, k)
                    } else if m > 0 {
                        let d1: f64 = if m == 1 { 1.0 } else { 0.0 };
                        pf(1, m - 1, k) * (1.0 + d1).sqrt() - pf(-1, -m + 1, k) * (1.0 - d1)
                    } else {
                        let d1: f64 = if m == -1 { 1.0 } else { 0.0 };
                        pf(1, m + 1, k) * (1.0 - d1) + pf(-1, -m - 1, k) * (1.0 + d1).sqrt()
                    };
                    val += v * vv;
                }
                if wc != 0.0 {
                    let ww = if m > 0 {
                        pf(1, m + 1, k) + pf(-1, -m - 1, k)
                    } else {
                        pf(1, m - 1, k) - pf(-1, -m + 1, k)
                    };
                    val += wc * ww;
                }
                band[((m + li) as usize) * w + (k + li) as usize] = val;
            }
        }
        bands.push(band);
    }
    // Condon–Shortley conjugation: D ↦ S D S, S = diag((−1)^m).
    for (l, band) in bands.iter_mut().enumerate() {
        let w = 2 * l + 1;
        for row in 0..w {
            for col in 0..w {
                let (m, k) = (row as i32 - l as i32, col as i32 - l as i32);
                if (m + k).rem_euclid(2) == 1 {
                    band[row * w + col] = -band[row * w + col];
                }
            }
        }
    }
    bands
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Agreement of two f64 evaluation paths of the same polynomial: a few ulps of O(1) values.
    const PATH_TOL: f64 = 1e-14;
    /// Rotation identities hold to rounding; 1e-12 leaves room for 8 bands of recurrence.
    const ROT_TOL: f64 = 1e-12;

    fn dirs() -> Vec<[f64; 3]> {
        let mut v = vec![[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
        let mut s = 0.1234f64;
        for _ in 0..60 {
            s = (s * 9301.0 + 0.4927).fract();
            let t = (s * 7.77).fract();
            let z = 2.0 * s - 1.0;
            let r = (1.0 - z * z).sqrt();
            let phi = 2.0 * PI * t;
            v.push([r * phi.cos(), r * phi.sin(), z]);
        }
        v
    }

    #[test]
    fn stated_low_band_convention() {
        let d = normalize([0.3, -0.5, 0.8]).unwrap();
        let mut y = [0.0; 64];
        eval_basis_recurrence(2, d, &mut y).unwrap();
        let c1 = (3.0 / (4.0 * PI)).sqrt();
        assert!((y[0] - 0.5 / PI.sqrt()).abs() < PATH_TOL);
        assert!((y[1] + c1 * d[1]).abs() < PATH_TOL);
        assert!((y[2] - c1 * d[2]).abs() < PATH_TOL);
        assert!((y[3] + c1 * d[0]).abs() < PATH_TOL);
    }

    #[test]
    fn hardcoded_matches_recurrence() {
        for d in dirs() {
            for n in 1..=4 {
                let (mut a, mut b) = ([0.0; 64], [0.0; 64]);
                eval_basis_hardcoded(n, d, &mut a).unwrap();
                eval_basis_recurrence(n, d, &mut b).unwrap();
                for i in 0..n * n {
                    assert!(
                        (a[i] - b[i]).abs() < PATH_TOL,
                        "n={n} i={i} {d:?}: {} vs {}",
                        a[i],
                        b[i]
                    );
                }
            }
        }
    }

    #[test]
    fn zonal_matches_m0_column() {
        for d in dirs() {
            let (mut y, mut z) = ([0.0; 64], [0.0; 8]);
            eval_basis(8, d, &mut y).unwrap();
            eval_zonal(8, d[2], &mut z).unwrap();
            for l in 0..8 {
                assert!((y[index(l, 0)] - z[l]).abs() < PATH_TOL);
            }
        }
    }

    /// y(r·d) = D(r) y(d) band by band: the defining identity of the SH rotation.
    #[test]
    fn rotation_maps_basis() {
        let rots = [
            rotation_axis_angle([1.0, 2.0, 3.0], 0.7).unwrap(),
            rotation_axis_angle([-0.3, 0.1, 0.2], 2.9).unwrap(),
            rotation_axis_angle([0.0, 0.0, 1.0], PI).unwrap(),
            rotation_axis_angle([1.0, 0.0, 0.0], PI / 2.0).unwrap(),
        ];
        for r in rots {
            let rot = Rotation::new(8, r).unwrap();
            for d in dirs().into_iter().take(20) {
                let rd = [0, 1, 2].map(|i| (0..3).map(|j| r[i][j] * d[j]).sum::<f64>());
                let (mut yd, mut yrd, mut dy) = ([0.0; 64], [0.0; 64], [0.0; 64]);
                eval_basis(8, d, &mut yd).unwrap();
                eval_basis(8, rd, &mut yrd).unwrap();
                rot.apply(&yd, &mut dy).unwrap();
                for i in 0..64 {
                    assert!((dy[i] - yrd[i]).abs() < ROT_TOL, "i={i}: {} vs {}", dy[i], yrd[i]);
                }
            }
        }
    }

    #[test]
    fn z_rotation_agrees_with_general() {
        let mut c = [0.0; 64];
        for (i, v) in c.iter_mut().enumerate() {
            *v = ((i * 37 % 11) as f64 - 5.0) / 7.0;
        }
        for &a in &[0.3, -1.7, 4.0] {
            let rot = Rotation::about_z(8, a).unwrap();
            let (mut x, mut y) = ([0.0; 64], [0.0; 64]);
            rot.apply(&c, &mut x).unwrap();
            rotate_z(&c, a, &mut y).unwrap();
            for i in 0..64 {
                assert!((x[i] - y[i]).abs() < ROT_TOL);
            }
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        let mut out = [0.0; 64];
        assert!(matches!(
            eval_basis(0, [0.0, 0.0, 1.0], &mut out),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            eval_basis(9, [0.0, 0.0, 1.0], &mut out),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            eval_basis(3, [0.0, 0.0, 0.0], &mut out),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            eval_basis(3, [f64::NAN, 0.0, 1.0], &mut out),
            Err(LookupError::NotFinite { .. })
        ));
        assert!(matches!(
            eval_basis(3, [0.0, 0.0, 1.0], &mut out[..4]),
            Err(LookupError::Output { .. })
        ));
        assert!(matches!(
            rotate_z(&out[..5], 0.1, &mut [0.0; 64]),
            Err(LookupError::ShLength { .. })
        ));
        let scaled = [[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(matches!(Rotation::new(4, scaled), Err(LookupError::OutOfDomain { .. })));
        let mirror = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(matches!(Rotation::new(4, mirror), Err(LookupError::OutOfDomain { .. })));
        assert!(Rotation::new(8, rotation_z(0.1))
            .unwrap()
            .apply(&[0.0; 81], &mut [0.0; 81])
            .is_err());
    }

    #[test]
    fn f32_twins_agree() {
        let d = [0.2f32, 0.4, -0.9];
        let mut a = [0f32; 64];
        let mut b = [0f64; 64];
        eval_basis_f32(8, d, &mut a).unwrap();
        eval_basis(8, d.map(f64::from), &mut b).unwrap();
        for i in 0..64 {
            assert!((a[i] as f64 - b[i]).abs() < 1e-6);
        }
    }
}
