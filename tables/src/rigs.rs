//! irradiance rigs (Yuan, Nowrouzezahrai & Sloan 2012, §1).
//!
//! A rig reconstructs order-3 SH irradiance vectors l(p) ∈ R⁹ (conventions of
//! [`crate::sh`]; each vector is already convolved with the clamped cosine, so the
//! irradiance at a surface point with unit normal N is Σ_i l_i(p) y_i(N)) at points p of
//! an object's axis-aligned bounding box [`RigBox`], from a few SH vectors c_k:
//! l(p) = Σ_k b_k(t) c_k, t = (p − centre)/half ∈ [−1, 1]³ (per-axis normalised
//! coordinates). The models ([`RigModel`]):
//!
//! - **constant**: b = {1} (1 vector);
//! - **gradient**: b = {1, t_x, t_y, t_z} (l_c + p_x g_x + p_y g_y + p_z g_z in box units;
//!   4 vectors);
//! - **tensor** of per-axis models ([`AxisModel`]): constant {1}, gradient {1, t}, or a
//!   lattice of n ≥ 2 nodes t_j = −1 + 2j/(n−1) with hat functions (linear interpolation);
//!   a lattice on all three axes is the trilinear lattice rig (n_x n_y n_z vectors); the
//!   paper's *mixed* rig is lattice(3) × gradient × constant along (length, width,
//!   height): 6 vectors.
//!
//! Fitting: [`Rig::fit_least_squares`] (least squares over SH samples at arbitrary
//! points, Householder QR, one solve for all nine channels) or [`Rig::fit_sampled`]
//! (the traditional way: lattice nodes sampled, constants at the centre, gradients by
//! central differences at the centre).
//!
//! Lights ([`Light`]): point, sphere and disk sources, with their exact per-point SH
//! irradiance ([`Light::irradiance_sh`]); [`select_direct`] is the error-driven choice of
//! which lights a renderer should evaluate per point rather than through the rig.

use glam::DVec3;

use crate::disk_light::DiskLight;
use crate::error::{finite, LookupError};
use crate::sh;

/// SH coefficients per rig vector (order 3).
pub const COEFFS: usize = 9;
/// Largest number of rig vectors (basis functions) a model may have.
pub const MAX_PARAMS: usize = 4096;
/// Rank test of the least-squares solve: |R_kk| below this times max |R_ii| means the
/// samples do not determine the model (e.g. a lattice cell with no samples).
pub(crate) const RANK_TOL: f64 = 1e-10;
/// Points may lie this far (in normalised box units) outside [−1, 1]³ (rounding of
/// points placed on the box's faces).
pub(crate) const BOX_SLACK: f64 = 1e-9;
/// Central-difference half step (normalised box units) of [`Rig::fit_sampled`]'s
/// gradients: small against the light distances, large against f64 rounding.
pub(crate) const GRADIENT_STEP: f64 = 1e-4;

/// Why a rig could not be built or evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RigError {
    /// A lattice needs at least two nodes per axis.
    #[error("a lattice axis needs at least 2 nodes, got {0}")]
    LatticeTooSmall(u32),
    /// The model has more basis functions than [`MAX_PARAMS`].
    #[error("the rig model has {0} vectors, more than {MAX_PARAMS}")]
    TooManyParameters(usize),
    /// Fewer samples than parameters, or samples that do not determine the model.
    #[error("the {samples} samples do not determine the {params} rig vectors (rank-deficient at vector {column})")]
    Underdetermined {
        samples: usize,
        params: usize,
        column: usize,
    },
    /// A box with a non-positive or non-finite half extent.
    #[error("bounding box half extent {0:?} must be finite and positive")]
    BadBox([f64; 3]),
    /// A point or value query failed (outside the box, NaN, a light's own domain).
    #[error(transparent)]
    Lookup(#[from] LookupError),
}

/// The model along one axis of a tensor rig.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisModel {
    /// {1}.
    Constant,
    /// {1, t}.
    Gradient,
    /// Hat functions on n ≥ 2 equally spaced nodes spanning [−1, 1].
    Lattice(u32),
}

impl AxisModel {
    fn check(self) -> Result<usize, RigError> {
        match self {
            AxisModel::Constant => Ok(1),
            AxisModel::Gradient => Ok(2),
            AxisModel::Lattice(n) if n >= 2 => Ok(n as usize),
            AxisModel::Lattice(n) => Err(RigError::LatticeTooSmall(n)),
        }
    }

    /// Basis values at t ∈ [−1, 1] into `out[..count]`.
    fn basis(self, t: f64, out: &mut Vec<f64>) {
        out.clear();
        match self {
            AxisModel::Constant => out.push(1.0),
            AxisModel::Gradient => out.extend([1.0, t]),
            AxisModel::Lattice(n) => {
                let s = (t + 1.0) * 0.5 * (n - 1) as f64;
                out.extend((0..n).map(|j| (1.0 - (s - j as f64).abs()).max(0.0)));
            }
        }
    }

    /// Per basis function, the stencil (t, weight) whose weighted samples give its
    /// coefficient in the sampled fit: value at a node, or d/dt at 0.
    fn stencils(self) -> Vec<Vec<(f64, f64)>> {
        let h = GRADIENT_STEP;
        match self {
            AxisModel::Constant => vec![vec![(0.0, 1.0)]],
            AxisModel::Gradient => vec![vec![(0.0, 1.0)], vec![(h, 0.5 / h), (-h, -0.5 / h)]],
            AxisModel::Lattice(n) => (0..n)
                .map(|j| vec![(-1.0 + 2.0 * j as f64 / (n - 1) as f64, 1.0)])
                .collect(),
        }
    }
}

/// A rig model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RigModel {
    /// l_c + t_x g_x + t_y g_y + t_z g_z (the paper's gradient rig; 4 vectors).
    Gradient,
    /// Tensor product of per-axis models along (x, y, z) (constant = all constant).
    Tensor([AxisModel; 3]),
}

impl RigModel {
    /// The constant rig.
    pub const CONSTANT: RigModel = RigModel::Tensor([AxisModel::Constant; 3]);

    /// Trilinear lattice of nx × ny × nz nodes.
    pub fn lattice(nx: u32, ny: u32, nz: u32) -> RigModel {
        RigModel::Tensor([AxisModel::Lattice(nx), AxisModel::Lattice(ny), AxisModel::Lattice(nz)])
    }

    /// Number of SH vectors (basis functions).
    pub fn parameter_count(&self) -> Result<usize, RigError> {
        let k = match self {
            RigModel::Gradient => 4,
            RigModel::Tensor(axes) => {
                let mut k = 1usize;
                for a in axes {
                    k = k.saturating_mul(a.check()?);
                }
                k
            }
        };
        if k > MAX_PARAMS {
            return Err(RigError::TooManyParameters(k));
        }
        Ok(k)
    }

    /// Basis values b_k(t) at normalised coordinates t into `out` (length K).
    fn basis(&self, t: [f64; 3], out: &mut Vec<f64>) {
        out.clear();
        match self {
            RigModel::Gradient => out.extend([1.0, t[0], t[1], t[2]]),
            RigModel::Tensor(axes) => {
                let (mut bx, mut by, mut bz) = (Vec::new(), Vec::new(), Vec::new());
                axes[0].basis(t[0], &mut bx);
                axes[1].basis(t[1], &mut by);
                axes[2].basis(t[2], &mut bz);
                for &x in &bx {
                    for &y in &by {
                        for &z in &bz {
                            out.push(x * y * z);
                        }
                    }
                }
            }
        }
    }
}

/// An axis-aligned box in the object's frame (metres, or any length unit used
/// consistently with the lights).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigBox {
    /// Centre.
    pub centre: DVec3,
    /// Half extents along x, y, z (all > 0).
    pub half: DVec3,
}

impl RigBox {
    /// A box from its centre and half extents (errors unless finite and positive).
    pub fn new(centre: DVec3, half: DVec3) -> Result<RigBox, RigError> {
        let ok = centre.is_finite() && half.is_finite() && half.min_element() > 0.0;
        if !ok {
            return Err(RigError::BadBox(half.to_array()));
        }
        Ok(RigBox { centre, half })
    }

    /// Normalised coordinates t = (p − centre)/half of a point in the box.
    pub fn normalised(&self, p: DVec3) -> Result<[f64; 3], RigError> {
        // The fields are public: a box built without `new` is checked here too.
        if !(self.centre.is_finite() && self.half.is_finite() && self.half.min_element() > 0.0) {
            return Err(RigError::BadBox(self.half.to_array()));
        }
        let names = ["point.x", "point.y", "point.z"];
        let mut t = [0.0; 3];
        for k in 0..3 {
            finite(names[k], p[k])?;
            t[k] = (p[k] - self.centre[k]) / self.half[k];
            if t[k].abs() > 1.0 + BOX_SLACK {
                return Err(LookupError::OutOfDomain {
                    name: format!("{} in rig box units", names[k]),
                    value: t[k],
                    lo: -1.0,
                    hi: 1.0,
                }
                .into());
            }
        }
        Ok(t.map(|v| v.clamp(-1.0, 1.0)))
    }

    /// The point at normalised coordinates t.
    pub fn point(&self, t: impl Into<DVec3>) -> DVec3 {
        self.centre + self.half * t.into()
    }
}

/// A fitted rig: its model, box and K SH vectors.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    model: RigModel,
    bbox: RigBox,
    /// K × 9, row k = vector c_k.
    vectors: Vec<[f64; COEFFS]>,
}

impl Rig {
    /// The model.
    pub fn model(&self) -> RigModel {
        self.model
    }

    /// The fitted SH vectors c_k (each 9 coefficients).
    pub fn vectors(&self) -> &[[f64; COEFFS]] {
        &self.vectors
    }

    /// Least-squares fit: minimises Σ_s ‖l(p_s) − v_s‖² + ridge · m · Σ_k ‖c_k‖² over the
    /// rig vectors c_k, from SH irradiance samples (p_s, v_s) at points of the box
    /// (m = mean squared basis column norm, so `ridge` is dimensionless). With
    /// `ridge` = 0 samples that do not determine the model are an error; a small
    /// `ridge` (e.g. 1e-9) instead sets the vectors no sample sees to ~0 (e.g. a
    /// lattice's interior nodes when all samples lie on the object's surface, which
    /// those nodes never influence) and changes the others by ~`ridge` relative.
    pub fn fit_least_squares(
        model: RigModel,
        bbox: RigBox,
        samples: &[(DVec3, [f64; COEFFS])],
        ridge: f64,
    ) -> Result<Rig, RigError> {
        let k = model.parameter_count()?;
        let ridge = crate::error::in_range("ridge", ridge, 0.0, f64::MAX)?;
        let n0 = samples.len();
        let n = if ridge > 0.0 { n0 + k } else { n0 };
        if n < k {
            return Err(RigError::Underdetermined {
                samples: n0,
                params: k,
                column: n0,
            });
        }
        // Design matrix A (n × k, column-major) and right-hand sides B (n × 9).
        let mut a = vec![0.0; n * k];
        let mut b = vec![0.0; n * COEFFS];
        let mut row = Vec::with_capacity(k);
        for (s, (p, v)) in samples.iter().enumerate() {
            model.basis(bbox.normalised(*p)?, &mut row);
            for (j, &x) in row.iter().enumerate() {
                a[j * n + s] = x;
            }
            for (c, &x) in v.iter().enumerate() {
                b[c * n + s] = finite("SH sample", x)?;
            }
        }
        if ridge > 0.0 {
            let m = a.iter().map(|x| x * x).sum::<f64>() / k as f64;
            let w = (ridge * m).sqrt();
            for j in 0..k {
                a[j * n + n0 + j] = w;
            }
        }
        let x = householder_solve(&mut a, &mut b, n, k, COEFFS).map_err(|column| RigError::Underdetermined {
            samples: n0,
            params: k,
            column,
        })?;
        let vectors = (0..k)
            .map(|j| {
                let mut v = [0.0; COEFFS];
                for (c, o) in v.iter_mut().enumerate() {
                    *o = x[c * k + j];
                }
                v
            })
            .collect();
        Ok(Rig { model, bbox, vectors })
    }

    /// The traditional fit from point samples of the field `f` (SH irradiance at a
    /// point): lattice nodes sampled, constants at the centre, gradients by central
    /// differences (half step `GRADIENT_STEP` box units) at the centre.
    pub fn fit_sampled(
        model: RigModel,
        bbox: RigBox,
        mut f: impl FnMut(DVec3) -> Result<[f64; COEFFS], LookupError>,
    ) -> Result<Rig, RigError> {
        model.parameter_count()?;
        let axes: [Vec<Vec<(f64, f64)>>; 3] = match model {
            RigModel::Gradient => {
                // {1, t_x, t_y, t_z}: value and the three partial derivatives at 0.
                let c = f(bbox.point([0.0; 3]))?;
                let mut vectors = vec![c];
                for ax in 0..3 {
                    let mut tp = [0.0; 3];
                    tp[ax] = GRADIENT_STEP;
                    let mut tm = [0.0; 3];
                    tm[ax] = -GRADIENT_STEP;
                    let (vp, vm) = (f(bbox.point(tp))?, f(bbox.point(tm))?);
                    let mut g = [0.0; COEFFS];
                    for i in 0..COEFFS {
                        g[i] = (vp[i] - vm[i]) * 0.5 / GRADIENT_STEP;
                    }
                    vectors.push(g);
                }
                return Ok(Rig { model, bbox, vectors });
            }
            RigModel::Tensor(a) => [a[0].stencils(), a[1].stencils(), a[2].stencils()],
        };
        let mut vectors = Vec::new();
        for sx in &axes[0] {
            for sy in &axes[1] {
                for sz in &axes[2] {
                    let mut v = [0.0; COEFFS];
                    for &(tx, wx) in sx {
                        for &(ty, wy) in sy {
                            for &(tz, wz) in sz {
                                let s = f(bbox.point([tx, ty, tz]))?;
                                for i in 0..COEFFS {
                                    v[i] += wx * wy * wz * s[i];
                                }
                            }
                        }
                    }
                    vectors.push(v);
                }
            }
        }
        Ok(Rig { model, bbox, vectors })
    }

    /// The reconstructed SH irradiance vector at a point of the box.
    pub fn eval(&self, p: DVec3) -> Result<[f64; COEFFS], RigError> {
        let t = self.bbox.normalised(p)?;
        let mut b = Vec::with_capacity(self.vectors.len());
        self.model.basis(t, &mut b);
        let mut out = [0.0; COEFFS];
        for (w, v) in b.iter().zip(&self.vectors) {
            for i in 0..COEFFS {
                out[i] += w * v[i];
            }
        }
        Ok(out)
    }
}

/// Least squares by Householder QR: A (n × k, column-major) X = B (n × m, column-major);
/// returns X (k × m, column-major), or the first rank-deficient column.
fn householder_solve(a: &mut [f64], b: &mut [f64], n: usize, k: usize, m: usize) -> Result<Vec<f64>, usize> {
    let mut diag = vec![0.0; k];
    for j in 0..k {
        let col = j * n;
        let norm = a[col + j..col + n].iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 {
            return Err(j);
        }
        let alpha = if a[col + j] > 0.0 { -norm } else { norm };
        // v = x − α e1, stored in place; R_jj = α.
        a[col + j] -= alpha;
        let vnorm2: f64 = a[col + j..col + n].iter().map(|x| x * x).sum();
        diag[j] = alpha;
        if vnorm2 > 0.0 {
            for jj in j + 1..k {
                let c2 = jj * n;
                let dot: f64 = (j..n).map(|i| a[col + i] * a[c2 + i]).sum();
                let f = 2.0 * dot / vnorm2;
                for i in j..n {
                    a[c2 + i] -= f * a[col + i];
                }
            }
            for c in 0..m {
                let c2 = c * n;
                let dot: f64 = (j..n).map(|i| a[col + i] * b[c2 + i]).sum();
                let f = 2.0 * dot / vnorm2;
                for i in j..n {
                    b[c2 + i] -= f * a[col + i];
                }
            }
        }
    }
    let scale = diag.iter().fold(0.0f64, |s, d| s.max(d.abs()));
    if let Some(j) = diag.iter().position(|d| d.abs() <= RANK_TOL * scale) {
        return Err(j);
    }
    let mut x = vec![0.0; k * m];
    for c in 0..m {
        for j in (0..k).rev() {
            let mut s = b[c * n + j];
            for jj in j + 1..k {
                s -= a[jj * n + j] * x[c * k + jj];
            }
            x[c * k + j] = s / diag[j];
        }
    }
    Ok(x)
}

/// A light source (positions in the rig's frame and length unit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// Isotropic point light of `intensity` (W/sr, or any unit): irradiance I cos/r².
    Point {
        /// Position.
        position: DVec3,
        /// Radiant intensity.
        intensity: f64,
    },
    /// Uniform spherical emitter of `radiance`.
    Sphere {
        /// Centre.
        centre: DVec3,
        /// Radius (> 0).
        radius: f64,
        /// Radiance.
        radiance: f64,
    },
    /// One-sided disk emitter of `radiance` (see [`crate::disk_light`]).
    Disk {
        /// Centre.
        centre: DVec3,
        /// Emitting normal (need not be unit).
        normal: DVec3,
        /// Radius (> 0).
        radius: f64,
        /// Radiance.
        radiance: f64,
    },
}

/// Clamped-cosine band weights (π, 2π/3, π/4).
const A: [f64; 3] = sh::CLAMPED_COSINE;

impl Light {
    /// The exact order-3 SH irradiance vector (clamped-cosine convolved) of the light at
    /// point `p` (the per-point "analytic" evaluation a rig approximates). Disks use the
    /// disk-light table `disks`. Errors when `p` is inside a sphere light or at a point
    /// light, or on the disk table's domain limits.
    pub fn irradiance_sh(&self, p: DVec3, disks: &DiskLight) -> Result<[f64; COEFFS], LookupError> {
        let mut out = [0.0; COEFFS];
        match *self {
            Light::Point { position, intensity } => {
                let d = position - p;
                let r2 = d.length_squared();
                if r2.is_nan() || r2 <= 0.0 {
                    return Err(LookupError::OutOfDomain {
                        name: "distance to the point light".into(),
                        value: r2.sqrt(),
                        lo: f64::MIN_POSITIVE,
                        hi: f64::MAX,
                    });
                }
                sh::eval_basis(3, d.to_array(), &mut out)?;
                let s = finite("point light intensity", intensity)? / r2;
                for (i, o) in out.iter_mut().enumerate() {
                    *o *= s * A[sh::band_of(i).0];
                }
            }
            Light::Sphere {
                centre,
                radius,
                radiance,
            } => {
                let d = centre - p;
                let r = d.length();
                if !(r > radius && radius > 0.0) {
                    return Err(LookupError::OutOfDomain {
                        name: "distance to the sphere light's centre (must exceed its radius)".into(),
                        value: r,
                        lo: radius,
                        hi: f64::MAX,
                    });
                }
                // Cap of half-angle θ_b, sin θ_b = radius / r: its indicator's ZH.
                let zh = crate::log_zh::cap_zh((radius / r).asin(), 3);
                sh::zh_to_sh(&zh[..3], d.to_array(), &mut out)?;
                let l = finite("sphere light radiance", radiance)?;
                for (i, o) in out.iter_mut().enumerate() {
                    *o *= l * A[sh::band_of(i).0];
                }
            }
            Light::Disk {
                centre,
                normal,
                radius,
                radiance,
            } => out = disks.irradiance_sh(p, centre, normal, radius, radiance)?,
        }
        // A near point light or a huge intensity can overflow: an error, not Ok(inf).
        for o in &out {
            finite("light SH irradiance (overflow)", *o)?;
        }
        Ok(out)
    }
}

/// The error-driven choice: for each light alone, fit `model` by least squares to its
/// SH samples at `fit_points` and measure the rig's RMS error ‖l_rig − l‖ over
/// `test_points`; returns (light index, that error) for the lights whose error exceeds
/// `tolerance` × the RMS norm of the *total* field (`ridge`: see [`Rig::fit_least_squares`]) over `test_points`, largest first.
/// Evaluating those lights per point and the others through one rig keeps the total
/// rig error below (number of rig lights) × tolerance × the field's RMS (triangle
/// inequality), and usually far below.
#[allow(clippy::too_many_arguments)]
pub fn select_direct(
    model: RigModel,
    bbox: RigBox,
    lights: &[Light],
    disks: &DiskLight,
    fit_points: &[DVec3],
    test_points: &[DVec3],
    tolerance: f64,
    ridge: f64,
) -> Result<Vec<(usize, f64)>, RigError> {
    finite("tolerance", tolerance)?;
    let mut total = vec![[0.0; COEFFS]; test_points.len()];
    let mut errs = Vec::with_capacity(lights.len());
    for light in lights {
        let samples = fit_points
            .iter()
            .map(|&p| Ok((p, light.irradiance_sh(p, disks)?)))
            .collect::<Result<Vec<_>, LookupError>>()?;
        let rig = Rig::fit_least_squares(model, bbox, &samples, ridge)?;
        let mut e2 = 0.0;
        for (t, &p) in total.iter_mut().zip(test_points) {
            let want = light.irradiance_sh(p, disks)?;
            let got = rig.eval(p)?;
            for i in 0..COEFFS {
                e2 += (got[i] - want[i]).powi(2);
                t[i] += want[i];
            }
        }
        errs.push((e2 / test_points.len().max(1) as f64).sqrt());
    }
    let norm =
        (total.iter().flat_map(|v| v.iter()).map(|x| x * x).sum::<f64>() / test_points.len().max(1) as f64).sqrt();
    let mut chosen: Vec<(usize, f64)> = errs
        .into_iter()
        .enumerate()
        .filter(|&(_, e)| e > tolerance * norm)
        .collect();
    chosen.sort_by(|a, b| b.1.total_cmp(&a.1));
    Ok(chosen)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> RigBox {
        RigBox::new(DVec3::ZERO, DVec3::new(2.0, 1.0, 0.5)).unwrap()
    }

    /// A field inside the model's span is reproduced exactly by both fits.
    #[test]
    fn exact_on_model_span() {
        let bbox = unit_box();
        // In the span of lattice(3) × gradient × constant: {1, t_x, |t_x|} ⊗ {1, t_y}.
        let field2 = |p: DVec3| {
            let t = bbox.normalised(p).unwrap();
            let mut v = [0.0; COEFFS];
            for (i, o) in v.iter_mut().enumerate() {
                let f = i as f64;
                *o = 1.0 + f + 0.3 * t[1] * (f - 4.0) - 0.2 * t[0].abs() + 0.1 * f * t[0] + 0.05 * t[0] * t[1]
                    - 0.07 * f * t[0].abs() * t[1];
            }
            v
        };
        let model = RigModel::Tensor([AxisModel::Lattice(3), AxisModel::Gradient, AxisModel::Constant]);
        let mut samples = Vec::new();
        for k in 0..200 {
            let t = [
                ((k * 37) % 101) as f64 / 50.0 - 1.0,
                ((k * 53) % 97) as f64 / 48.0 - 1.0,
                ((k * 11) % 89) as f64 / 44.0 - 1.0,
            ];
            let p = bbox.point(t);
            samples.push((p, field2(p)));
        }
        let ls = Rig::fit_least_squares(model, bbox, &samples, 0.0).unwrap();
        let sampled = Rig::fit_sampled(model, bbox, |p| Ok(field2(p))).unwrap();
        for &(p, v) in samples.iter().take(50) {
            let (a, b) = (ls.eval(p).unwrap(), sampled.eval(p).unwrap());
            for i in 0..COEFFS {
                assert!((a[i] - v[i]).abs() < 1e-10, "{a:?} vs {v:?}");
                assert!((b[i] - v[i]).abs() < 1e-7, "{b:?} vs {v:?}");
            }
        }
        assert_eq!(ls.vectors().len(), 6);
    }

    #[test]
    fn bad_inputs() {
        let bbox = unit_box();
        assert_eq!(
            RigModel::lattice(1, 2, 2).parameter_count(),
            Err(RigError::LatticeTooSmall(1))
        );
        assert!(matches!(
            RigModel::lattice(64, 64, 2).parameter_count(),
            Err(RigError::TooManyParameters(8192))
        ));
        assert!(matches!(
            RigBox::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0)),
            Err(RigError::BadBox(_))
        ));
        let few = vec![(DVec3::ZERO, [1.0; COEFFS]); 3];
        assert!(matches!(
            Rig::fit_least_squares(RigModel::Gradient, bbox, &few, 0.0),
            Err(RigError::Underdetermined { .. })
        ));
        // Enough samples, all at one point: rank-deficient.
        let same = vec![(DVec3::ZERO, [1.0; COEFFS]); 10];
        assert!(matches!(
            Rig::fit_least_squares(RigModel::Gradient, bbox, &same, 0.0),
            Err(RigError::Underdetermined { .. })
        ));
        let rig = Rig::fit_sampled(RigModel::CONSTANT, bbox, |_| Ok([1.0; COEFFS])).unwrap();
        assert!(matches!(
            Rig::fit_least_squares(RigModel::CONSTANT, bbox, &same, -1.0),
            Err(RigError::Lookup(LookupError::OutOfDomain { .. }))
        ));
        // With a ridge the same samples give the minimum-norm-like answer.
        let r = Rig::fit_least_squares(RigModel::Gradient, bbox, &same, 1e-9).unwrap();
        assert!((r.eval(DVec3::ZERO).unwrap()[0] - 1.0).abs() < 1e-6);
        assert!(matches!(
            rig.eval(DVec3::new(3.0, 0.0, 0.0)),
            Err(RigError::Lookup(LookupError::OutOfDomain { .. }))
        ));
        assert!(matches!(
            rig.eval(DVec3::new(f64::NAN, 0.0, 0.0)),
            Err(RigError::Lookup(LookupError::NotFinite { .. }))
        ));
        let nan = vec![(DVec3::ZERO, [f64::NAN; COEFFS]); 10];
        assert!(matches!(
            Rig::fit_least_squares(RigModel::CONSTANT, bbox, &nan, 0.0),
            Err(RigError::Lookup(LookupError::NotFinite { .. }))
        ));
    }
}
