//! log-ZH vectors of BRDFs and blockers (Giraud & Nowrouzezahrai 2015, §4.5.2, §4.6).
//!
//! The log projection of a zonal function f (symmetric about +z) is
//! z_l = ∫ log(max(f, ε)) y_l^0 dω (natural log, docs/math.md, erratum E4), l < n ≤ 8. The runtime
//! evaluates exact closed forms (f64, ~1e-14), for any real r and ε:
//!
//! - **Phong** f(θ) = (r+1)/(2π) cos^r θ above the horizon, log ε below. With
//!   t_ε = (2πε/(r+1))^{1/r} (the cosine where f = ε), log max(f, ε) =
//!   log ε + r·max(0, log(s/t_ε)) for s = cosθ > 0, so
//!   z_l = C_l [2 δ_{l0} log ε + r G_l(t_ε)], C_l = √(π(2l+1)),
//!   G_l(t) = ∫_t^1 log(s/t) P_l(s) ds = Σ_k a_{lk} (t^{k+1} − 1 − (k+1) ln t)/(k+1)²
//!   (P_l = Σ a_{lk} s^k), and G_l = 0 when t_ε ≥ 1 (f ≤ ε everywhere).
//! - **Diffuse** f = max(cosθ, 0)/π is Phong with r = 1.
//! - **Blocker**: log ε inside the cap s > cos θ_b, 0 outside:
//!   z_l = C_l log ε ∫_{cosθ_b}^1 P_l = √(π/(2l+1)) log ε (P_{l−1} − P_{l+1})(cosθ_b) (l ≥ 1),
//!   √π log ε (1 − cosθ_b) (l = 0).
//!
//! The table file `log-zh` holds the Phong vectors on a grid (r = 1..128 integer rows,
//! ε on 128 nodes uniform in ln ε) for renderers that upload a texture; [`LogZh::table_lookup`]
//! interpolates it bilinearly. Use the closed forms ([`phong`], [`diffuse`],
//! [`blocker`]) when accuracy matters: they are what [`LogZh::lookup`] returns.
//! Each value is stored as an f32 pair (hi + lo), so stored nodes carry the f64
//! closed form to ~1e-15 relative.
//! [`to_world`] turns a ZH vector to any axis (f_l^m = √(4π/(2l+1)) z_l y_l^m(d)).

use std::f64::consts::PI;

use crate::error::{finite, in_range, narrow_all, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::sh::{self, MAX_ORDER};
use crate::table::Table;
use glam::DVec3;

/// Table kind.
pub const KIND: &str = "log-zh";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Smallest ε of the table and of the closed forms' documented domain.
pub const EPS_MIN: f64 = 0.01;
/// Largest ε.
pub const EPS_MAX: f64 = 0.99;
/// Smallest Phong exponent.
pub const R_MIN: f64 = 1.0;
/// Largest tabulated Phong exponent (integer rows 1..=128).
pub const R_TABLE_MAX: f64 = 128.0;
/// Largest Phong exponent the closed form accepts (it is exact for any real r; this
/// bounds the domain that is tested).
pub const R_MAX: f64 = 4096.0;
/// ε nodes of the table, uniform in ln ε (z is smooth in ln ε: it is
/// C_l[2δ_l0 ln ε + r G_l(t_ε)] with ln t_ε linear in ln ε).
pub(crate) const EPS_NODES: u32 = 128;
/// Output names z0..z7.
pub const CHANNELS: [&str; MAX_ORDER] = ["z0", "z1", "z2", "z3", "z4", "z5", "z6", "z7"];
/// Stored channels: each z_l as an f32 pair, z_l = hi + lo (~1e-15 relative).
pub const STORED_CHANNELS: [&str; 2 * MAX_ORDER] = [
    "z0_hi", "z0_lo", "z1_hi", "z1_lo", "z2_hi", "z2_lo", "z3_hi", "z3_lo", "z4_hi", "z4_lo", "z5_hi", "z5_lo",
    "z6_hi", "z6_lo", "z7_hi", "z7_lo",
];

/// Bound on |z_l| (hi channels): |ln max(f, ε)| ≤ max(|ln ε|, ln max f) ≤ ln 100 = 4.61
/// (ε ≥ 0.01; max f = (r+1)/(2π) ≤ 20.5 for r ≤ 128, ln 3.02), and ∫|y_l^0| dω ≤ √(4π)
/// (Cauchy–Schwarz), so |z_l| ≤ 4.61·√(4π) = 16.3; with margin, 20.
const Z_BOUND: f64 = 20.0;
/// Bound on the lo half of a pair: half an f32 ulp of a hi value below [`Z_BOUND`]
/// (2⁻²⁰ ≈ 9.5e-7 for |hi| < 32).
const Z_LO_BOUND: f64 = 1e-6;

/// Plausible range of each stored channel (name, lo, hi), in the unit of z_l (that of
/// the log of the BRDF value): ±`Z_BOUND` for the hi halves, ±`Z_LO_BOUND` for
/// the lo halves.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[
    ("z0_hi", -Z_BOUND, Z_BOUND),
    ("z0_lo", -Z_LO_BOUND, Z_LO_BOUND),
    ("z1_hi", -Z_BOUND, Z_BOUND),
    ("z1_lo", -Z_LO_BOUND, Z_LO_BOUND),
    ("z2_hi", -Z_BOUND, Z_BOUND),
    ("z2_lo", -Z_LO_BOUND, Z_LO_BOUND),
    ("z3_hi", -Z_BOUND, Z_BOUND),
    ("z3_lo", -Z_LO_BOUND, Z_LO_BOUND),
    ("z4_hi", -Z_BOUND, Z_BOUND),
    ("z4_lo", -Z_LO_BOUND, Z_LO_BOUND),
    ("z5_hi", -Z_BOUND, Z_BOUND),
    ("z5_lo", -Z_LO_BOUND, Z_LO_BOUND),
    ("z6_hi", -Z_BOUND, Z_BOUND),
    ("z6_lo", -Z_LO_BOUND, Z_LO_BOUND),
    ("z7_hi", -Z_BOUND, Z_BOUND),
    ("z7_lo", -Z_LO_BOUND, Z_LO_BOUND),
];

/// Which zonal function is log-projected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// max(cosθ, 0)/π (= Phong r = 1).
    Diffuse,
    /// Normalised Phong lobe (r+1)/(2π) cos^r θ, log ε below the horizon.
    Phong,
    /// Spherical blocker: log ε inside a cap of half-angle θ_b about +z, 0 outside.
    Blocker,
}

impl Kind {
    /// Name used on the command line (`--kind`).
    pub fn name(self) -> &'static str {
        match self {
            Kind::Diffuse => "diffuse",
            Kind::Phong => "phong",
            Kind::Blocker => "blocker",
        }
    }
}

/// The table's axes, slowest first: `r` (integer rows 1..=128), `eps` (0.01..0.99,
/// 128 nodes uniform in ln ε).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axes() -> Vec<Axis> {
    vec![
        Axis {
            name: "r".into(),
            unit: "1".into(),
            lo: R_MIN,
            hi: R_TABLE_MAX,
            mapping: Mapping::Linear,
            count: R_TABLE_MAX as u32,
            placement: Placement::Endpoints,
        },
        Axis {
            name: "eps".into(),
            unit: "1".into(),
            lo: EPS_MIN,
            hi: EPS_MAX,
            mapping: Mapping::Log,
            count: EPS_NODES,
            placement: Placement::Endpoints,
        },
    ]
}

/// Monomial coefficients of P_l, l < 8 (a[l][k] multiplies s^k).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn legendre_coeffs() -> [[f64; MAX_ORDER]; MAX_ORDER] {
    let mut a = [[0.0; MAX_ORDER]; MAX_ORDER];
    a[0][0] = 1.0;
    a[1][1] = 1.0;
    for l in 2..MAX_ORDER {
        // l P_l = (2l−1) s P_{l−1} − (l−1) P_{l−2}
        for k in 0..MAX_ORDER {
            let up = if k > 0 { a[l - 1][k - 1] } else { 0.0 };
            a[l][k] = ((2 * l - 1) as f64 * up - (l - 1) as f64 * a[l - 2][k]) / l as f64;
        }
    }
    a
}

/// e^x − 1 − x without cancellation for small |x|.
fn exp_m1_minus_x(x: f64) -> f64 {
    if x.abs() < 0.5 {
        // Taylor: terms fall by |x|/k; 25 terms reach 1e-17 relative at |x| = 0.5.
        let (mut term, mut sum) = (x * x / 2.0, 0.0);
        for k in 3..28 {
            sum += term;
            term *= x / k as f64;
        }
        sum
    } else {
        x.exp_m1() - x
    }
}

/// G_l(t) = ∫_t^1 log(s/t) P_l(s) ds for l < n, t ∈ (0, 1] (0 at t = 1).
pub(crate) fn g_integrals(order: usize, t: f64) -> [f64; MAX_ORDER] {
    let a = legendre_coeffs();
    let lt = t.ln();
    let mut m = [0.0; MAX_ORDER]; // ∫_t^1 s^k log(s/t) ds
    for (k, mk) in m.iter_mut().enumerate() {
        let kp = (k + 1) as f64;
        *mk = exp_m1_minus_x(kp * lt) / (kp * kp);
    }
    let mut g = [0.0; MAX_ORDER];
    for l in 0..order {
        g[l] = (0..=l).map(|k| a[l][k] * m[k]).sum();
    }
    g
}

fn check_eps(eps: f64) -> Result<f64, LookupError> {
    in_range("eps", eps, EPS_MIN, EPS_MAX)
}

/// C_l = 2π √((2l+1)/(4π)) = √(π(2l+1)): z_l = C_l ∫_{−1}^1 g(s) P_l(s) ds.
fn c_l(l: usize) -> f64 {
    (PI * (2 * l + 1) as f64).sqrt()
}

/// Log-ZH of the normalised Phong lobe of exponent `r` ∈ [1, 4096] (real), threshold
/// `eps` ∈ [0.01, 0.99], order n ∈ 1..=8: z_0..z_{n−1} in `out[..n]` (closed form).
pub fn phong(eps: f64, r: f64, order: usize, out: &mut [f64]) -> Result<(), LookupError> {
    let n = sh::check_order(order)?;
    let eps = check_eps(eps)?;
    let r = in_range("r", r, R_MIN, R_MAX)?;
    if out.len() < n {
        return Err(LookupError::Output {
            got: out.len(),
            needed: n,
            what: "ZH coefficients",
        });
    }
    // ln t_ε = (ln(2π ε) − ln(r+1))/r; t_ε ≥ 1 means f ≤ ε everywhere.
    let ln_t = ((2.0 * PI * eps).ln() - (r + 1.0).ln()) / r;
    let g = if ln_t < 0.0 {
        g_integrals(n, ln_t.exp())
    } else {
        [0.0; MAX_ORDER]
    };
    for l in 0..n {
        let dc = if l == 0 { 2.0 * eps.ln() } else { 0.0 };
        out[l] = c_l(l) * (dc + r * g[l]);
    }
    Ok(())
}

/// Log-ZH of the diffuse BRDF max(cosθ, 0)/π (= [`phong`] with r = 1).
pub fn diffuse(eps: f64, order: usize, out: &mut [f64]) -> Result<(), LookupError> {
    phong(eps, 1.0, order, out)
}

/// Log-ZH of a spherical blocker of angular radius `theta_b` ∈ [0, π] (rad) centred
/// on +z: log ε inside the cap, 0 outside (closed form).
pub fn blocker(eps: f64, theta_b: f64, order: usize, out: &mut [f64]) -> Result<(), LookupError> {
    let n = sh::check_order(order)?;
    let eps = check_eps(eps)?;
    let theta_b = in_range("theta_b", theta_b, 0.0, PI)?;
    if out.len() < n {
        return Err(LookupError::Output {
            got: out.len(),
            needed: n,
            what: "ZH coefficients",
        });
    }
    let cap = cap_zh(theta_b, n);
    for l in 0..n {
        out[l] = eps.ln() * cap[l];
    }
    Ok(())
}

/// ZH of the cap indicator (1 for cosθ > cosθ_b): √(π/(2l+1)) (P_{l−1} − P_{l+1})(cosθ_b)
/// for l ≥ 1, √π (1 − cosθ_b) for l = 0 (1 − cos computed as 2 sin²(θ_b/2)).
pub fn cap_zh(theta_b: f64, order: usize) -> [f64; MAX_ORDER] {
    let c = theta_b.cos();
    let mut p = [0.0; MAX_ORDER + 1];
    p[0] = 1.0;
    p[1] = c;
    for l in 2..=MAX_ORDER {
        p[l] = ((2 * l - 1) as f64 * c * p[l - 1] - (l - 1) as f64 * p[l - 2]) / l as f64;
    }
    let mut out = [0.0; MAX_ORDER];
    let s = (0.5 * theta_b).sin();
    out[0] = PI.sqrt() * 2.0 * s * s;
    for l in 1..order.min(MAX_ORDER) {
        out[l] = (PI / (2 * l + 1) as f64).sqrt() * (p[l - 1] - p[l + 1]);
    }
    out
}

/// [`phong`] with an f32 interface (computed in f64, rounded once).
pub fn phong_f32(eps: f32, r: f32, order: usize, out: &mut [f32]) -> Result<(), LookupError> {
    let mut tmp = [0.0; MAX_ORDER];
    phong(eps as f64, r as f64, order, &mut tmp)?;
    narrow_all("z", &tmp[..order], out)
}

/// [`diffuse`] with an f32 interface (computed in f64, rounded once).
pub fn diffuse_f32(eps: f32, order: usize, out: &mut [f32]) -> Result<(), LookupError> {
    phong_f32(eps, 1.0, order, out)
}

/// [`blocker`] with an f32 interface (computed in f64, rounded once).
pub fn blocker_f32(eps: f32, theta_b: f32, order: usize, out: &mut [f32]) -> Result<(), LookupError> {
    let mut tmp = [0.0; MAX_ORDER];
    blocker(eps as f64, crate::error::angle_f32(theta_b), order, &mut tmp)?;
    narrow_all("z", &tmp[..order], out)
}

/// Turns a log-ZH vector (about +z) to the world axis `d` (need not be unit):
/// `out[..n²]`, n = `zh.len()`. Same as [`sh::zh_to_sh`].
pub fn to_world(zh: &[f64], d: impl Into<glam::DVec3>, out: &mut [f64]) -> Result<(), LookupError> {
    sh::zh_to_sh(zh, d, out)
}

/// A spherical blocker (centre `centre`, radius `radius` > 0, same length unit)
/// seen from `point`: the unit direction to its centre and its angular radius
/// θ_b = asin(r/d) ∈ (0, π/2) (rad), d = |centre − point|. Errors name a non-finite
/// input, a radius ≤ 0, or a point inside or on the sphere (d ≤ r).
pub fn sphere_cap(point: impl Into<DVec3>, centre: impl Into<DVec3>, radius: f64) -> Result<(DVec3, f64), LookupError> {
    let (p, c) = (point.into(), centre.into());
    for (name, v) in [("point", p), ("blocker centre", c)] {
        for x in v.to_array() {
            finite(name, x)?;
        }
    }
    let r = in_range("blocker radius", radius, f64::MIN_POSITIVE, f64::MAX)?;
    let to = c - p;
    let d = to.length();
    // d ≤ r: the point is inside the blocker, which hides everything.
    if d.is_nan() || d <= r || !d.is_finite() {
        return Err(LookupError::OutOfDomain {
            name: "distance to the blocker's centre over its radius".into(),
            value: d / r,
            lo: 1.0,
            hi: f64::INFINITY,
        });
    }
    Ok((to / d, (r / d).asin()))
}

/// The log-ZH table (Phong rows r = 1..128, ε nodes 0.01..0.99, channels z0..z7).
#[derive(Debug, Clone)]
pub struct LogZh {
    table: Table,
}

crate::table_type::impl_table_type! {
    /// The underlying table (row-major \[r\]\[eps\]\[z0_hi, z0_lo, …, z7_lo\], f32), e.g. for
    /// GPU upload (a shader that is happy with f32 precision reads the hi channels only).
    LogZh: KIND, VERSION
}

impl LogZh {
    /// Wraps an already loaded table, checking its kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        let chans: Vec<(&str, Encoding)> = STORED_CHANNELS.iter().map(|&c| (c, Encoding::Linear)).collect();
        table.expect_layout(&axes(), &chans)?;
        if table.meta().axes != axes() {
            return Err(LoadError::LayoutMismatch {
                kind: KIND.into(),
                detail: "expected 128 r nodes × 128 eps nodes".into(),
            });
        }
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        Ok(Self { table })
    }

    /// Bilinear interpolation (linear in r and in ln ε) of the stored Phong vectors at
    /// (ε, r), r ∈ [1, 128]: z_0..z_{n−1} into `out`. Exact to f32 rounding at the
    /// nodes; between them the error is up to 6e-4 absolute at integer r and 1.7e-2
    /// at real r (measured in the `lobefit` tests and the repository's docs/sh.md):
    /// prefer [`LogZh::lookup`] (closed form).
    pub fn table_lookup(&self, order: usize, eps: f64, r: f64, out: &mut [f64]) -> Result<(), LookupError> {
        let n = sh::check_order(order)?;
        finite("eps", eps)?;
        finite("r", r)?;
        if out.len() < n {
            return Err(LookupError::Channels {
                expected: n,
                got: out.len(),
            });
        }
        let mut all = [0.0; 2 * MAX_ORDER];
        self.table.interpolate(&[r, eps], &mut all)?;
        for (l, o) in out.iter_mut().take(n).enumerate() {
            *o = all[2 * l] + all[2 * l + 1];
        }
        Ok(())
    }

    /// The log-ZH vector of `kind` at ε and `param` (r for Phong, θ_b for the blocker,
    /// ignored for diffuse), by the exact closed form.
    pub fn lookup(&self, kind: Kind, order: usize, eps: f64, param: f64, out: &mut [f64]) -> Result<(), LookupError> {
        match kind {
            Kind::Diffuse => diffuse(eps, order, out),
            Kind::Phong => phong(eps, param, order, out),
            Kind::Blocker => blocker(eps, param, order, out),
        }
    }

    /// [`LogZh::lookup`] with an f32 interface (computed in f64, rounded once).
    pub fn lookup_f32(
        &self,
        kind: Kind,
        order: usize,
        eps: f32,
        param: f32,
        out: &mut [f32],
    ) -> Result<(), LookupError> {
        let mut tmp = [0.0; MAX_ORDER];
        let param = match kind {
            Kind::Blocker => crate::error::angle_f32(param),
            _ => param as f64,
        };
        self.lookup(kind, order, eps as f64, param, &mut tmp)?;
        narrow_all("z", &tmp[..order], out)
    }

    /// [`LogZh::table_lookup`] with an f32 interface (computed in f64, rounded once).
    pub fn table_lookup_f32(&self, order: usize, eps: f32, r: f32, out: &mut [f32]) -> Result<(), LookupError> {
        let mut tmp = [0.0; MAX_ORDER];
        self.table_lookup(order, eps as f64, r as f64, &mut tmp)?;
        narrow_all("z", &tmp[..order], out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legendre_coefficients_evaluate_p_l() {
        let a = legendre_coeffs();
        for &s in &[-0.9f64, -0.2, 0.3, 0.77, 1.0] {
            let (mut p0, mut p1) = (1.0, s);
            for (l, al) in a.iter().enumerate() {
                let p = if l == 0 { 1.0 } else { p1 };
                let mono: f64 = (0..=l).map(|k| al[k] * s.powi(k as i32)).sum();
                assert!((mono - p).abs() < 1e-14, "l={l} s={s}");
                if l >= 1 {
                    let next = ((2 * l + 1) as f64 * s * p1 - l as f64 * p0) / (l + 1) as f64;
                    p0 = p1;
                    p1 = next;
                }
            }
        }
    }

    /// The constant regime: ε above the lobe's maximum gives log ε · √(4π) δ_l0.
    #[test]
    fn above_maximum_is_constant() {
        let mut z = [0.0; 8];
        phong(0.9, 2.0, 8, &mut z).unwrap(); // max f = 3/(2π) = 0.477 < 0.9
        assert!((z[0] - 0.9f64.ln() * (4.0 * PI).sqrt()).abs() < 1e-14);
        assert!(z[1..].iter().all(|v| *v == 0.0));
    }

    #[test]
    fn bad_inputs() {
        let mut z = [0.0; 8];
        assert!(matches!(
            phong(0.0, 2.0, 4, &mut z),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            phong(0.5, f64::NAN, 4, &mut z),
            Err(LookupError::NotFinite { .. })
        ));
        assert!(matches!(
            phong(0.5, 0.5, 4, &mut z),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            phong(0.5, 2.0, 9, &mut z),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            phong(0.5, 2.0, 4, &mut z[..3]),
            Err(LookupError::Output { .. })
        ));
        assert!(matches!(
            blocker(0.5, -0.1, 4, &mut z),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            blocker(1.5, 0.1, 4, &mut z),
            Err(LookupError::OutOfDomain { .. })
        ));
    }
}
