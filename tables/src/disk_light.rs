//! SH response of a disk light (Yuan, Nowrouzezahrai & Sloan 2012, §2).
//!
//! **Canonical frame.** Receiver at the origin; a one-sided disk emitter of radius R with
//! centre (0, 0, d) and emitting normal n = (sin τ, 0, −cos τ): τ (rad) is the angle
//! between the disk's normal and the direction from the disk to the receiver
//! (τ = 0 faces the receiver; τ ≥ π/2 shows the receiver the disk's back: zero).
//! The order-3 SH projection (conventions of [`crate::sh`]) of the indicator of the
//! directions that hit the disk, c_lm = ∫_{dirs hitting the disk} y_lm(ω) dω
//! (= ∫_disk y_lm(x̂) |n·x̂| / |x|² dA), depends only on (R/d, τ) and, by the symmetry
//! about the xz-plane, only (l,m) ∈ {(0,0),(1,0),(1,1),(2,0),(2,1),(2,2)} are non-zero
//! ([`CANONICAL_INDEX`]). c_00 = Ω/(2√π) with Ω the disk's solid angle (sr).
//!
//! **Table** (kind `disk-light`). Axes: `v` ∈ [0, 1], a normalised coordinate along R/d
//! (`rim_coordinate`): v ∝ ln(R/d) + asinh((R/d − sin τ)/cos τ), which is uniform in
//! ln(R/d) for small disks and dense where the receiver's foot point on the disk's plane
//! crosses the rim (R/d = sin τ), where the response changes over a width ∝ cos τ near
//! grazing; and `tau` ∈ [0, [`TAU_MAX`]] with nodes uniform in ln((π/2 + τ)/(π/2 − τ)),
//! dense towards grazing. Channels: c_00 (stored as ln c_00, interpolated in the log) and
//! the ratios c_lm/c_00 of the five others (bounded: |c_lm/c_00| ≤ √(4π) max|y_lm|),
//! since c_00 spans eight decades over the domain. Bilinear interpolation.
//!
//! **Runtime.** [`DiskLight::canonical`] (the six coefficients), [`DiskLight::radiance_sh`]
//! (a world-space disk of uniform radiance as an order-3 SH radiance vector seen from a
//! receiver point: the canonical vector rotated by [`crate::sh::Rotation`]),
//! [`DiskLight::irradiance_sh`] (convolved with the clamped cosine π, 2π/3, π/4) and
//! [`DiskLight::irradiance`] (evaluated at a receiver normal), with f32 twins; and
//! `form_factor_irradiance`, the point-to-disk approximation of Wallace et al. (1989)
//! the paper compares with.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::{DVec3, Vec3};

use crate::error::{finite, finite_result, finite_results, in_range, narrow, narrow_all, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::sh::{self, Rotation};
use crate::table::Table;

/// Table kind.
pub const KIND: &str = "disk-light";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Smallest tabulated R/d. Smaller disks use the small-disk limit (see
/// [`DiskLight::canonical`]).
pub const R_MIN: f64 = 0.01;
/// Largest R/d.
pub const R_MAX: f64 = 10.0;
/// Largest tabulated τ (rad), 0.999·π/2 (cos τ ≈ 1.6e-3). Between it and π/2 the
/// receiver is within 0.16 % of d from the disk's plane and [`DiskLight::canonical`]
/// interpolates towards the plane limit (`grazing_limit`).
pub const TAU_MAX: f64 = 0.999 * FRAC_PI_2;
/// Nodes along `v`.
#[cfg(feature = "writer")]
pub const V_NODES: u32 = 192;
/// Nodes along `tau`.
#[cfg(feature = "writer")]
pub const TAU_NODES: u32 = 128;
/// Stored channels: c_00 (log-encoded) and c_lm / c_00 for the other five.
pub const CHANNELS: [&str; 6] = ["y00", "r10", "r11", "r20", "r21", "r22"];
/// Plausible range of each stored channel (name, lo, hi), dimensionless.
/// `y00` stores ln c_00, c_00 = Ω/(2√π) with Ω ∈ (0, 2π] the disk's solid angle: at most
/// ln √π = 0.572 (a hemisphere), at least ln(√π/2·(R/d)²·cos τ) = −15.79 (R/d = 0.01,
/// τ = 0.999·π/2); range [−18, 1]. The ratios obey |c_lm| ≤ Ω·max|y_lm|, so
/// |c_lm/c_00| ≤ 2√π max|y_lm|: √3 = 1.732 for l = 1, √5 = 2.236 for (2, 0), √15/2 =
/// 1.936 for (2, 1) and (2, 2); the committed table reaches the first two to 1e-5, so
/// the ranges add 1 %.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[
    ("y00", -18.0, 1.0),
    ("r10", -1.75, 1.75),
    ("r11", -1.75, 1.75),
    ("r20", -2.26, 2.26),
    ("r21", -1.96, 1.96),
    ("r22", -1.96, 1.96),
];

/// Output names of the six canonical coefficients (`y21` = l 2, m 1).
pub const OUTPUTS: [&str; 6] = ["y00", "y10", "y11", "y20", "y21", "y22"];
/// Single SH index l(l+1)+m of each canonical coefficient.
pub const CANONICAL_INDEX: [usize; 6] = [0, 2, 3, 6, 7, 8];
/// Lambertian irradiance convolution weights per band (clamped cosine).
pub use crate::sh::CLAMPED_COSINE;

/// The `tau` axis mapping: logit on (−π/2, π/2), symmetric about τ = 0 (where the
/// coefficients are even or odd in τ) and dense towards grazing.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const TAU_MAPPING: Mapping = Mapping::Logit {
    a: -FRAC_PI_2,
    b: FRAC_PI_2,
};

/// g(r, τ) = ln r + asinh((r − sin τ)/cos τ): increasing in r.
fn rim_g(r: f64, tau: f64) -> f64 {
    r.ln() + ((r - tau.sin()) / tau.cos()).asinh()
}

/// The `v` coordinate of (R/d, τ): (g(R/d) − g(R_MIN)) / (g(R_MAX) − g(R_MIN)) with
/// g(r) = ln r + asinh((r − sin τ)/cos τ). In [0, 1] for R/d ∈ [R_MIN, R_MAX], τ < π/2.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn rim_coordinate(r_over_d: f64, tau: f64) -> f64 {
    let (lo, hi) = (rim_g(R_MIN, tau), rim_g(R_MAX, tau));
    ((rim_g(r_over_d, tau) - lo) / (hi - lo)).clamp(0.0, 1.0)
}

/// Inverse of [`rim_coordinate`] in R/d (bisection in ln R/d to f64 resolution).
#[cfg(feature = "writer")]
pub fn r_from_rim_coordinate(v: f64, tau: f64) -> f64 {
    let (lo, hi) = (rim_g(R_MIN, tau), rim_g(R_MAX, tau));
    let target = lo + v * (hi - lo);
    let (mut a, mut b) = (R_MIN.ln(), R_MAX.ln());
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            break;
        }
        if rim_g(m.exp(), tau) < target {
            a = m;
        } else {
            b = m;
        }
    }
    (0.5 * (a + b)).exp().clamp(R_MIN, R_MAX)
}

/// Axes, slowest first: `v` (linear on [0, 1]) and `tau` (rad, [`TAU_MAPPING`]).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axes(v_nodes: u32, tau_nodes: u32) -> Vec<Axis> {
    vec![
        Axis {
            name: "v".into(),
            unit: "1 (rim coordinate of R/d, see lobefit_tables::disk_light::rim_coordinate)".into(),
            lo: 0.0,
            hi: 1.0,
            mapping: Mapping::Linear,
            count: v_nodes,
            placement: Placement::Endpoints,
        },
        Axis {
            name: "tau".into(),
            unit: "rad".into(),
            lo: 0.0,
            hi: TAU_MAX,
            mapping: TAU_MAPPING,
            count: tau_nodes,
            placement: Placement::Endpoints,
        },
    ]
}

/// Wallace et al. (1989) point-to-disk form-factor approximation as irradiance (W/m²
/// per unit radiance × `radiance`): E ≈ π L A cos θ_s cos θ_r / (π r² + A), A = π R²,
/// r = |c − p|, θ_s at the disk (normal `disk_normal`, emitting side), θ_r at the
/// receiver (normal `receiver_normal`); zero when either cosine is ≤ 0.
#[cfg(feature = "writer")]
pub fn form_factor_irradiance(
    receiver: DVec3,
    receiver_normal: DVec3,
    centre: DVec3,
    disk_normal: DVec3,
    radius: f64,
    radiance: f64,
) -> Result<f64, LookupError> {
    let g = Geometry::new(receiver, centre, disk_normal, radius)?;
    let nr = unit("receiver normal", receiver_normal)?;
    finite("radiance", radiance)?;
    let to_light = (centre - receiver) / g.d;
    let cos_r = nr.dot(to_light);
    if g.cos_tau <= 0.0 || cos_r <= 0.0 {
        return Ok(0.0);
    }
    let area = PI * radius * radius;
    // Huge radii, distances or radiances overflow (inf, or inf/inf).
    finite_result(
        "form-factor irradiance",
        PI * radiance * area * g.cos_tau * cos_r / (PI * g.d * g.d + area),
    )
}

fn unit(name: &str, v: DVec3) -> Result<DVec3, LookupError> {
    let d = sh::normalize(v).map_err(|e| match e {
        LookupError::NotFinite { value, .. } => LookupError::NotFinite {
            name: name.into(),
            value,
        },
        LookupError::OutOfDomain { value, lo, hi, .. } => LookupError::OutOfDomain {
            name: format!("{name} length"),
            value,
            lo,
            hi,
        },
        other => other,
    })?;
    Ok(d)
}

/// The canonical coefficients in the limit τ → π/2⁻ (receiver approaching the disk's
/// plane from the front, d fixed): 0 when R/d < 1 (the disk is seen edge-on), the
/// hemisphere about −n = (−1, 0, 0) when R/d > 1 (c_00 = √π, c_11 = √(3π)/2, others 0:
/// the receiver is at the disk's surface), and half of that at R/d = 1.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn grazing_limit(r_over_d: f64) -> [f64; 6] {
    let hemi = [PI.sqrt(), 0.0, (3.0 * PI).sqrt() / 2.0, 0.0, 0.0, 0.0];
    let f = match r_over_d.partial_cmp(&1.0) {
        Some(std::cmp::Ordering::Less) => 0.0,
        Some(std::cmp::Ordering::Equal) => 0.5,
        _ => 1.0,
    };
    hemi.map(|v| f * v)
}

/// The canonical coefficients of an infinite emitting plane (R/d → ∞): the hemisphere
/// about −n = (−sin τ, 0, cos τ), τ < π/2 (c_00 = √π, (c_10, c_11) = √(3π)/2 (cos τ, sin τ),
/// band 2 zero).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn plane_limit(tau: f64) -> [f64; 6] {
    let z1 = (3.0 * PI).sqrt() / 2.0;
    [PI.sqrt(), z1 * tau.cos(), z1 * tau.sin(), 0.0, 0.0, 0.0]
}

/// Below this sin τ the disk counts as facing the receiver head-on and the canonical x'
/// axis is arbitrary (the coefficients are rotation-invariant about z' to ~1e-8 there).
const AXIS_DEGENERATE_SIN: f64 = 1e-8;

/// A disk seen from a receiver: distance, τ and the canonical frame (world axes).
#[derive(Debug, Clone, Copy)]
struct Geometry {
    d: f64,
    cos_tau: f64,
    tau: f64,
    /// Canonical x', y', z' in world coordinates (z' from receiver to centre).
    frame: [DVec3; 3],
}

impl Geometry {
    fn new(receiver: DVec3, centre: DVec3, normal: DVec3, radius: f64) -> Result<Geometry, LookupError> {
        for (name, v) in [("receiver", receiver), ("disk centre", centre)] {
            finite(&format!("{name}.x"), v.x)?;
            finite(&format!("{name}.y"), v.y)?;
            finite(&format!("{name}.z"), v.z)?;
        }
        let n = unit("disk normal", normal)?;
        in_range("disk radius", radius, f64::MIN_POSITIVE, f64::MAX)?;
        let to = centre - receiver;
        let d = to.length();
        if !(d > 0.0 && d.is_finite()) {
            return Err(LookupError::OutOfDomain {
                name: "receiver-to-disk-centre distance".into(),
                value: d,
                lo: f64::MIN_POSITIVE,
                hi: f64::MAX,
            });
        }
        let z = to / d;
        let cos_tau = (-n.dot(z)).clamp(-1.0, 1.0);
        // n = sin τ x' − cos τ z'  ⇒  x' = (n + cos τ z') / sin τ.
        let perp = n + cos_tau * z;
        let sin_tau = perp.length();
        let x = if sin_tau > AXIS_DEGENERATE_SIN {
            // Re-orthogonalised: for small sin τ, n + cos τ z' carries rounding along z'.
            let x = perp / sin_tau;
            (x - x.dot(z) * z).normalize()
        } else {
            z.any_orthonormal_vector()
        };
        let y = z.cross(x);
        Ok(Geometry {
            d,
            cos_tau,
            tau: sin_tau.atan2(cos_tau),
            frame: [x, y, z],
        })
    }

    /// The rotation taking canonical coordinates to world ones (columns x', y', z').
    fn rotation(&self) -> [[f64; 3]; 3] {
        let [x, y, z] = self.frame;
        [[x.x, y.x, z.x], [x.y, y.y, z.y], [x.z, y.z, z.z]]
    }
}

/// The disk-light table.
#[derive(Debug, Clone)]
pub struct DiskLight {
    table: Table,
}

crate::table_type::impl_table_type!(DiskLight: KIND, VERSION);

impl DiskLight {
    /// Wraps an already loaded table, checking its kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        let m = table.meta();
        let counts = (
            m.axes.first().map_or(0, |a| a.count),
            m.axes.get(1).map_or(0, |a| a.count),
        );
        let chans: Vec<(&str, Encoding)> = CHANNELS
            .iter()
            .enumerate()
            .map(|(k, &c)| (c, if k == 0 { Encoding::Log } else { Encoding::Linear }))
            .collect();
        table.expect_layout(&axes(counts.0, counts.1), &chans)?;
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        Ok(Self { table })
    }

    /// The six canonical coefficients (c_00, c_10, c_11, c_20, c_21, c_22) (sr-weighted,
    /// dimensionless) for a disk of radius ratio `r_over_d` = R/d and tilt `tau` (rad).
    /// R/d > 0: below 0.01 the small-disk limit is used (c_00 scaled by
    /// (R/d / 0.01)², ratios of R/d = 0.01; relative error O((R/d)²) ≤ 1e-4); above 10
    /// the value is interpolated linearly in d/R between R/d = 10 and the infinite
    /// plane (`plane_limit`); see docs/rigs.md for its measured error.
    /// τ ∈ [0, π]: zero from π/2 on (back side). Beyond the table, τ ∈ (0.999·π/2, π/2)
    /// (receiver within 0.0016·d of the disk's plane), the value is interpolated
    /// linearly in cos τ between the table's last row and the limit at the plane
    /// (`grazing_limit`); see docs/rigs.md for its measured error.
    pub fn canonical(&self, r_over_d: f64, tau: f64) -> Result<[f64; 6], LookupError> {
        let r = in_range("R/d", r_over_d, f64::MIN_POSITIVE, f64::MAX)?;
        let tau = in_range("tau", tau, 0.0, PI)?;
        if tau >= FRAC_PI_2 {
            return Ok([0.0; 6]);
        }
        if r > R_MAX {
            let edge = self.canonical(R_MAX, tau)?;
            let lim = plane_limit(tau);
            let w = R_MAX / r;
            let mut c = [0.0; 6];
            for k in 0..6 {
                c[k] = lim[k] + w * (edge[k] - lim[k]);
            }
            return Ok(c);
        }
        if tau > TAU_MAX {
            let edge = self.canonical(r, TAU_MAX)?;
            let lim = grazing_limit(r);
            let w = tau.cos() / TAU_MAX.cos();
            let mut c = [0.0; 6];
            for k in 0..6 {
                c[k] = lim[k] + w * (edge[k] - lim[k]);
            }
            return Ok(c);
        }
        let rt = r.max(R_MIN);
        let mut c = [0.0; 6];
        self.table.interpolate(&[rim_coordinate(rt, tau), tau], &mut c)?;
        if r < R_MIN {
            c[0] *= (r / R_MIN) * (r / R_MIN);
        }
        let dc = c[0];
        for v in c.iter_mut().skip(1) {
            *v *= dc;
        }
        Ok(c)
    }

    /// The full order-3 canonical vector (9 coefficients, zeros at m < 0).
    pub fn canonical9(&self, r_over_d: f64, tau: f64) -> Result<[f64; 9], LookupError> {
        let c = self.canonical(r_over_d, tau)?;
        let mut v = [0.0; 9];
        for (k, &i) in CANONICAL_INDEX.iter().enumerate() {
            v[i] = c[k];
        }
        Ok(v)
    }

    /// Order-3 SH radiance vector (world frame, conventions of [`crate::sh`]) of a
    /// one-sided disk of uniform `radiance` (any unit; the result carries it), centre
    /// `centre`, emitting normal `normal` (need not be unit) and `radius` (same length
    /// unit as the positions), seen from `receiver`: L(ω) = radiance where ω hits the
    /// disk's emitting side, 0 elsewhere.
    pub fn radiance_sh(
        &self,
        receiver: DVec3,
        centre: DVec3,
        normal: DVec3,
        radius: f64,
        radiance: f64,
    ) -> Result<[f64; 9], LookupError> {
        let g = Geometry::new(receiver, centre, normal, radius)?;
        finite("radiance", radiance)?;
        if g.cos_tau <= 0.0 {
            return Ok([0.0; 9]);
        }
        let canon = self.canonical9(radius / g.d, g.tau)?;
        let rot = Rotation::new(3, g.rotation())?;
        let mut out = [0.0; 9];
        rot.apply(&canon, &mut out)?;
        out.iter_mut().for_each(|v| *v *= radiance);
        // A huge finite radiance overflows the scaled coefficients.
        finite_results("radiance SH", &out)?;
        Ok(out)
    }

    /// Irradiance SH vector: [`DiskLight::radiance_sh`] convolved with the clamped
    /// cosine (band weights π, 2π/3, π/4). E(N) = Σ E_lm y_lm(N) for a receiver normal N.
    pub fn irradiance_sh(
        &self,
        receiver: DVec3,
        centre: DVec3,
        normal: DVec3,
        radius: f64,
        radiance: f64,
    ) -> Result<[f64; 9], LookupError> {
        let mut e = self.radiance_sh(receiver, centre, normal, radius, radiance)?;
        for (i, v) in e.iter_mut().enumerate() {
            *v *= CLAMPED_COSINE[sh::band_of(i).0];
        }
        finite_results("irradiance SH", &e)?;
        Ok(e)
    }

    /// Irradiance at `receiver` with surface normal `receiver_normal`, from the order-3
    /// SH irradiance vector (what an SH renderer shades with).
    pub fn irradiance(
        &self,
        receiver: DVec3,
        receiver_normal: DVec3,
        centre: DVec3,
        normal: DVec3,
        radius: f64,
        radiance: f64,
    ) -> Result<f64, LookupError> {
        let e = self.irradiance_sh(receiver, centre, normal, radius, radiance)?;
        let nr = unit("receiver normal", receiver_normal)?;
        let mut y = [0.0; 9];
        sh::eval_basis(3, nr, &mut y)?;
        finite_result("irradiance", e.iter().zip(&y).map(|(a, b)| a * b).sum())
    }

    /// [`DiskLight::radiance_sh`] with an f32 interface (computed in f64, rounded once).
    pub fn radiance_sh_f32(
        &self,
        receiver: Vec3,
        centre: Vec3,
        normal: Vec3,
        radius: f32,
        radiance: f32,
    ) -> Result<[f32; 9], LookupError> {
        let v = self.radiance_sh(
            receiver.as_dvec3(),
            centre.as_dvec3(),
            normal.as_dvec3(),
            radius as f64,
            radiance as f64,
        )?;
        let mut out = [0.0f32; 9];
        narrow_all("radiance SH", &v, &mut out)?;
        Ok(out)
    }

    /// [`DiskLight::irradiance_sh`] with an f32 interface (computed in f64, rounded once).
    pub fn irradiance_sh_f32(
        &self,
        receiver: Vec3,
        centre: Vec3,
        normal: Vec3,
        radius: f32,
        radiance: f32,
    ) -> Result<[f32; 9], LookupError> {
        let v = self.irradiance_sh(
            receiver.as_dvec3(),
            centre.as_dvec3(),
            normal.as_dvec3(),
            radius as f64,
            radiance as f64,
        )?;
        let mut out = [0.0f32; 9];
        narrow_all("irradiance SH", &v, &mut out)?;
        Ok(out)
    }

    /// [`DiskLight::canonical`] with an f32 interface (computed in f64, rounded once).
    pub fn canonical_f32(&self, r_over_d: f32, tau: f32) -> Result<[f32; 6], LookupError> {
        let v = self.canonical(r_over_d as f64, crate::error::angle_f32(tau))?;
        let mut out = [0.0f32; 6];
        narrow_all("canonical SH", &v, &mut out)?;
        Ok(out)
    }

    /// [`DiskLight::irradiance`] with an f32 interface (computed in f64, rounded once).
    pub fn irradiance_f32(
        &self,
        receiver: Vec3,
        receiver_normal: Vec3,
        centre: Vec3,
        normal: Vec3,
        radius: f32,
        radiance: f32,
    ) -> Result<f32, LookupError> {
        let e = self.irradiance(
            receiver.as_dvec3(),
            receiver_normal.as_dvec3(),
            centre.as_dvec3(),
            normal.as_dvec3(),
            radius as f64,
            radiance as f64,
        )?;
        narrow("irradiance", e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rim_coordinate_round_trips() {
        for &tau in &[0.0, 0.3, 1.2, 1.5, TAU_MAX] {
            for &r in &[0.01, 0.05, 0.5, 0.999, 1.0, 3.0, 10.0] {
                let v = rim_coordinate(r, tau);
                assert!((0.0..=1.0).contains(&v));
                let back = r_from_rim_coordinate(v, tau);
                assert!((back / r - 1.0).abs() < 1e-12, "tau={tau} r={r}: {back}");
            }
        }
    }

    #[test]
    fn geometry_frame_is_canonical() {
        // Receiver at origin, centre on +z at d = 2, normal tilted by τ = 0.4 about y.
        let tau: f64 = 0.4;
        let n = DVec3::new(tau.sin(), 0.0, -tau.cos());
        let g = Geometry::new(DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0), n, 1.0).unwrap();
        assert!((g.tau - tau).abs() < 1e-15 && (g.d - 2.0).abs() < 1e-15);
        let r = g.rotation();
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((r[i][j] - want).abs() < 1e-15, "{r:?}");
            }
        }
    }

    #[test]
    fn geometry_bad_inputs() {
        let z = DVec3::new(0.0, 0.0, 1.0);
        assert!(matches!(
            Geometry::new(DVec3::ZERO, z, DVec3::ZERO, 1.0),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            Geometry::new(DVec3::ZERO, DVec3::ZERO, -z, 1.0),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            Geometry::new(DVec3::new(f64::NAN, 0.0, 0.0), z, -z, 1.0),
            Err(LookupError::NotFinite { .. })
        ));
        assert!(matches!(
            Geometry::new(DVec3::ZERO, z, -z, -1.0),
            Err(LookupError::OutOfDomain { .. })
        ));
    }
}
