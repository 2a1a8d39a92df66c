//! Direct lighting with cosine lobes end to end (Meunier et al. 2009, §4.3, §5):
//! spherical lights as lobes, BRDFs as lobe sums, soft shadows from sphere-set
//! blockers through the visibility mask ([`crate::mask_weights`]), and the shading
//! integral eq. 22 in the order of §5.4 (docs/meunier.md).
//!
//! Per shading point x (normal n) and per light (centre p, radius r, radiance L):
//!
//! - **Light lobe** (§5.2): the light's cap (axis (p − x)/|p − x|, half-angle
//!   α = asin(r/|p − x|)) becomes s·Ψ(v; a, e_cap(α)) with the cap-exponent table's
//!   exponent. The paper's scale is L; lobefit scales it to L·Ω_cap(e + 1)/(2π), so that
//!   the lobe's integral is the cap's solid angle Ω_cap = 2π(1 − cos α) (an unoccluded
//!   light then delivers the right power; docs/meunier.md measures the difference).
//! - **Visibility** (§5.3, eq. 39): V = c_unit − Σ_i w_{d_i} c_i with c_unit = (1, n, 0),
//!   the hemisphere about n (erratum E6), and one lobe per shadow leaf of the mask.
//!   A blocker whose nearest point is farther than the light's centre is clipped (it
//!   lies behind the light); a blocker cap containing the whole light cap hides the
//!   light, which then contributes exactly 0.
//! - **Shading** (eq. 22, §5.4): ∫ (Σ BRDF)(Σ light)(Σ V)·max(n·v, 0) dω through
//!   [`LobeProduct::triple_product`]: BRDF × light first, then visibility, then the
//!   cosine, products with |∫| below the threshold t_i dropped. With the light's cap
//!   ([`LightModel::Cap`], the default) the light is uniform over the hemisphere, so
//!   each BRDF lobe × the cosine is formed once (the lit term's lobe) and each shadow
//!   leaf costs one product with it, not two.
//!
//! Cap half-angles below the cap-exponent table's 1 mrad take the small-cap limit
//! e_cap(β) = e_cap(1 mrad)·(1 mrad/β)² (e_cap·β² → 1.9226 as β → 0).
//!
//! Degenerate scenes are errors ([`MeunierError`]), never NaN: a point inside a light or
//! a blocker, a light inside a blocker, a radius ≤ 0, a non-finite input, a normal or
//! view direction that is not unit.

use glam::{DVec3, Vec3};
use thiserror::Error;

use crate::cap_exponent::{CapExponent, ALPHA_MIN};
use crate::error::LookupError;
use crate::lobe_product::{sharp_product_integral, Lobe, LobeProduct, Variant};
use crate::mask_weights::{check_depth, dist_of_cap, mask_leaves, Cap, MaskMode, MaskWeights, WeightSet, MAX_DEPTH};

use crate::geom::{Brdf, Sphere, Sphere32, SphereLight, SphereLight32};

impl Brdf {
    /// The BRDF as cosine lobes in world space at a point with unit normal `n` and
    /// unit tangent `t` (perpendicular to n), for the unit outgoing direction `wo`.
    pub fn lobes(&self, n: DVec3, t: DVec3, wo: DVec3) -> Result<Vec<Lobe>, MeunierError> {
        let n = unit("normal", n)?;
        let wo = unit("outgoing direction", wo)?;
        let albedo = match self {
            Brdf::Lambert { albedo } | Brdf::Lafortune { albedo, .. } => *albedo,
            Brdf::CookTorrance { .. } | Brdf::BlinnPhong { .. } => return Err(MeunierError::NotLobes),
        };
        nonneg("albedo", albedo)?;
        let mut out = vec![Lobe {
            scale: albedo / std::f64::consts::PI,
            axis: n,
            exponent: 0.0,
        }];
        if let Brdf::Lafortune { lobes, .. } = self {
            let t = unit("tangent", t - t.dot(n) * n)?;
            let b = n.cross(t);
            let local = DVec3::new(wo.dot(t), wo.dot(b), wo.dot(n));
            for l in lobes {
                for x in l.c.to_array() {
                    finite("Lafortune coefficient", x)?;
                }
                nonneg("Lafortune scale", l.rho)?;
                nonneg("Lafortune exponent", l.exponent)?;
                let m = l.c * local;
                let len = m.length();
                if len == 0.0 || l.rho == 0.0 {
                    continue;
                }
                let axis = (m.x * t + m.y * b + m.z * n) / len;
                out.push(Lobe {
                    scale: check_result("Lafortune lobe scale", l.rho * len.powf(l.exponent))?,
                    axis,
                    exponent: l.exponent,
                });
            }
        }
        Ok(out)
    }
}

/// How a spherical light enters the shading integral (docs/meunier.md, "A better
/// light").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightModel {
    /// The paper's (§5.2): one cosine lobe per light, multiplied with the visibility
    /// lobes V = c_unit − Σ w_i c_i.
    Lobe,
    /// The light's exact cap (docs/meunier.md, "A better light"): a uniform light is L
    /// inside its cap, so no lobe stands for it. The unoccluded light is the BRDF's
    /// constant term under the cap in closed form (a sphere light's irradiance, the
    /// horizon included, [`cap_irradiance`]) plus each other BRDF lobe × the cosine
    /// (one lobe, from the product table) integrated over the cap
    /// ([`lobe_fraction_in_cap`]); each shadow leaf darkens by L·w_i·g_i·c_i, g_i the
    /// share of its lobe inside the cap (the weights were fitted for lobes clipped to
    /// the light's cone; leaves wholly outside the light drop out).
    Cap,
}

impl LightModel {
    /// Both, the paper's first.
    pub const ALL: [LightModel; 2] = [LightModel::Lobe, LightModel::Cap];

    /// `lobe` or `cap`.
    pub fn name(self) -> &'static str {
        match self {
            LightModel::Lobe => "lobe",
            LightModel::Cap => "cap",
        }
    }
}

/// ∫_cap max(n·v, 0) dω (sr) for the cap of half-angle α = asin(`sin_alpha`) whose axis
/// makes the angle β = acos(`cos_beta`) with the normal n: π sin²α cos β while the cap
/// is above the horizon, 0 once it is below, and in between the closed form of the
/// cap clipped by the horizon (the classic sphere-light irradiance; its derivation
/// is in docs/math.md). `sin_alpha` in (0, 1), `cos_beta` in [−1, 1].
pub fn cap_irradiance(sin_alpha: f64, cos_beta: f64) -> f64 {
    let s2 = sin_alpha * sin_alpha;
    let cb = cos_beta.clamp(-1.0, 1.0);
    if cb * cb >= s2 {
        return if cb > 0.0 { std::f64::consts::PI * s2 * cb } else { 0.0 };
    }
    let sb = (1.0 - cb * cb).sqrt();
    // x = cot α; y = −x cot β: the horizon's crossing of the cap's circle.
    let x = (1.0 - s2).max(0.0).sqrt() / sin_alpha;
    let y = (-x * cb / sb).clamp(-1.0, 1.0);
    let q = sb * (1.0 - y * y).sqrt();
    ((cb * y.acos() - x * q) * s2 + q.atan2(x)).max(0.0)
}

/// The fraction of a unit cosine lobe max(a·v, 0)^e lying inside a cap of half-angle
/// `alpha` whose axis makes the angle `gamma` with a: the lobe taken as the isotropic
/// Gaussian exp(−(e + 1)θ²/2) of the tangent plane (its limit for narrow lobes) and the cap
/// as the disk of radius α, integrated exactly over the azimuth about the lobe's axis
/// (the midpoint rule, 24 points on [0, π] by symmetry): (1/2π)∫ [exp(−ρ₁²e/2) −
/// exp(−ρ₂²e/2)] dφ, ρ₁ < ρ₂ the distances to
/// the disk's rim along φ. 1 or 0 without the rule when the rim is more than 6
/// standard deviations away.
pub fn lobe_fraction_in_cap(gamma: f64, alpha: f64, e: f64) -> f64 {
    // Variance 1/(e + 1): the Gaussian then has the lobe's integral 2π/(e + 1).
    let e = e + 1.0;
    let sigma = 1.0 / e.sqrt();
    if gamma + 6.0 * sigma <= alpha {
        return 1.0;
    }
    if gamma - 6.0 * sigma >= alpha {
        return 0.0;
    }
    // The integrand is even in φ: the midpoint rule on [0, π], its nodes' sines and
    // cosines computed once (the same values as per call: a leaf lobe calls this).
    const N: usize = 24;
    static NODES: std::sync::OnceLock<[(f64, f64); N]> = std::sync::OnceLock::new();
    let nodes =
        NODES.get_or_init(|| std::array::from_fn(|k| (std::f64::consts::PI * (k as f64 + 0.5) / N as f64).sin_cos()));
    let n = N;
    let mut sum = 0.0;
    for &(sp, cp) in nodes {
        // Along the ray from the lobe's axis at azimuth φ (φ = 0 towards the cap's
        // centre): |γ − ρ cos φ, ρ sin φ| = α.
        let disc = alpha * alpha - gamma * gamma * sp * sp;
        if disc <= 0.0 {
            continue;
        }
        let root = disc.sqrt();
        let (r1, r2) = ((gamma * cp - root).max(0.0), (gamma * cp + root).max(0.0));
        // r1 = 0 wherever the lobe's axis lies inside the disk (most shadow leaves):
        // exp(−0) is exactly 1, so the call is skipped with the same bits.
        let near = if r1 == 0.0 { 1.0 } else { (-0.5 * e * r1 * r1).exp() };
        sum += near - (-0.5 * e * r2 * r2).exp();
    }
    (sum / n as f64).clamp(0.0, 1.0)
}

/// How the visibility mask is built and weighted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskSettings {
    /// Maximal quad-tree depth, 1..=5.
    pub depth: u32,
    /// Aggressive (the paper's) or conservative.
    pub mode: MaskMode,
    /// Weights of eq. 39.
    pub weights: WeightSet,
    /// Threshold t_i (sr): lobe products with |∫| below it are dropped (0 keeps all).
    pub threshold: f64,
    /// How the light enters.
    pub light: LightModel,
    /// Under [`LightModel::Cap`] with the `energy` products, a shadow leaf sharp beside
    /// the BRDF × cosine lobe gets its product's integral by
    /// [`crate::lobe_product::sharp_product_integral`] (its expansion about the leaf's
    /// axis, within 1e-7 of the integral, relative, where it answers; the table errs
    /// up to 5.5e-3) instead of the lobe-product table: on by default, the GPU kernel
    /// does the same (docs/meunier.md, "Sharp leaves in closed form").
    pub sharp_leaves: bool,
}

impl Default for MaskSettings {
    /// Depth 5, aggressive, fitted weights, t_i = 0, the light's cap, sharp leaves in
    /// closed form.
    fn default() -> Self {
        MaskSettings {
            depth: MAX_DEPTH,
            mode: MaskMode::Aggressive,
            weights: WeightSet::Fitted,
            threshold: 0.0,
            light: LightModel::Cap,
            sharp_leaves: true,
        }
    }
}

/// Why a direct-lighting query was refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MeunierError {
    /// A radius is zero or negative.
    #[error("{what} has radius {radius}; radii must be > 0")]
    BadRadius {
        /// `light` or `blocker i`.
        what: String,
        /// The radius.
        radius: f64,
    },
    /// A direction is not of unit length (within 1e-3) or is zero.
    #[error("{name} has length {length}, expected a unit vector")]
    NotUnit {
        /// What it is.
        name: String,
        /// Its length.
        length: f64,
    },
    /// The shading point lies inside (or on) a light sphere.
    #[error("the shading point is inside light {index} (distance {distance} to its centre ≤ radius {radius})")]
    PointInsideLight {
        /// Index of the light.
        index: usize,
        /// Distance from the point to its centre.
        distance: f64,
        /// Its radius.
        radius: f64,
    },
    /// The shading point lies inside (or on) a blocker sphere.
    #[error("the shading point is inside blocker {index} (distance {distance} to its centre ≤ radius {radius})")]
    PointInsideBlocker {
        /// Index of the blocker.
        index: usize,
        /// Distance from the point to its centre.
        distance: f64,
        /// Its radius.
        radius: f64,
    },
    /// A light sphere lies entirely inside a blocker sphere.
    #[error("light {light} lies inside blocker {blocker} ((distance between centres + light radius) − blocker radius = {margin:e} ≤ 0)")]
    LightInsideBlocker {
        /// Index of the light.
        light: usize,
        /// Index of the blocker.
        blocker: usize,
        /// (Distance between the centres + the light's radius) − the blocker's radius:
        /// how far inside (≤ 0).
        margin: f64,
    },
    /// The BRDF is not a sum of cosine lobes ([`Brdf::CookTorrance`], [`Brdf::BlinnPhong`]).
    #[error(
        "Meunier's shading takes BRDFs made of cosine lobes (Lambert, Lafortune); a Cook–Torrance or \
         Blinn-Phong material is shaded by the ISG pipeline"
    )]
    NotLobes,
    /// A value the query refuses as a table lookup would: not finite
    /// ([`LookupError::NotFinite`]), negative where it must be ≥ 0
    /// ([`LookupError::OutOfDomain`] with bounds 0 and ∞); or a table lookup that
    /// failed (depth out of range, an overflowing product, …).
    #[error(transparent)]
    Lookup(#[from] LookupError),
    /// Item `index` (0-based) of a batch was refused for the reason `error` (what the
    /// one-at-a-time call returns for it); the first such item is reported.
    #[error("batch item {index}: {error}")]
    BatchItem {
        /// Index of the item.
        index: usize,
        /// Its error.
        error: Box<MeunierError>,
    },
}

fn finite(name: &str, value: f64) -> Result<f64, MeunierError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(LookupError::NotFinite {
            name: name.into(),
            value,
        }
        .into())
    }
}

fn nonneg(name: &str, value: f64) -> Result<f64, MeunierError> {
    if finite(name, value)? < 0.0 {
        return Err(LookupError::OutOfDomain {
            name: name.into(),
            value,
            lo: 0.0,
            hi: f64::INFINITY,
        }
        .into());
    }
    Ok(value)
}

fn check_result(name: &str, value: f64) -> Result<f64, MeunierError> {
    crate::error::finite_result(name, value).map_err(MeunierError::from)
}

fn point(name: &str, p: DVec3) -> Result<DVec3, MeunierError> {
    for x in p.to_array() {
        finite(name, x)?;
    }
    Ok(p)
}

fn unit(name: &str, d: DVec3) -> Result<DVec3, MeunierError> {
    point(name, d)?;
    let length = d.length();
    // NaN lengths fail too (the point check above rejects non-finite input).
    if (length - 1.0).abs() > 1e-3 || length.is_nan() {
        return Err(MeunierError::NotUnit {
            name: name.into(),
            length,
        });
    }
    Ok(d / length)
}

/// `what` names the sphere (`blocker 3`); it is formatted only for an error, since
/// scenes with many blockers check every one per point.
fn check_sphere(what: impl Fn() -> String, s: &Sphere) -> Result<(), MeunierError> {
    if s.centre.is_finite() && s.radius.is_finite() && s.radius > 0.0 {
        return Ok(());
    }
    let what = what();
    point(&format!("{what} centre"), s.centre)?;
    if finite(&format!("{what} radius"), s.radius)? <= 0.0 {
        return Err(MeunierError::BadRadius { what, radius: s.radius });
    }
    Ok(())
}

/// Validates a scene: every sphere well formed, the point outside every sphere, no
/// light inside a blocker.
pub fn check_scene(x: DVec3, lights: &[SphereLight], blockers: &[Sphere]) -> Result<(), MeunierError> {
    point("shading point", x)?;
    for (i, b) in blockers.iter().enumerate() {
        check_sphere(|| format!("blocker {i}"), b)?;
        let distance = dist(b.centre, x);
        if distance <= b.radius {
            return Err(MeunierError::PointInsideBlocker {
                index: i,
                distance,
                radius: b.radius,
            });
        }
    }
    for (i, l) in lights.iter().enumerate() {
        check_sphere(|| format!("light {i}"), &l.sphere)?;
        if !(l.radiance >= 0.0 && l.radiance.is_finite()) {
            nonneg(&format!("light {i} radiance"), l.radiance)?;
        }
        let distance = dist(l.sphere.centre, x);
        if distance <= l.sphere.radius {
            return Err(MeunierError::PointInsideLight {
                index: i,
                distance,
                radius: l.sphere.radius,
            });
        }
        for (j, b) in blockers.iter().enumerate() {
            let margin = dist(l.sphere.centre, b.centre) + l.sphere.radius - b.radius;
            if margin <= 0.0 {
                return Err(MeunierError::LightInsideBlocker {
                    light: i,
                    blocker: j,
                    margin,
                });
            }
        }
    }
    Ok(())
}

/// The cap of sphere `s` seen from `x` (outside it).
fn cap_of(x: DVec3, s: &Sphere) -> Cap {
    let to = s.centre - x;
    let d = dist(s.centre, x);
    Cap {
        axis: to / d,
        half_angle: (s.radius / d).asin(),
    }
}

/// |a − b| without overflowing the squares (scenes at coordinates beyond 1e154).
fn dist(a: DVec3, b: DVec3) -> f64 {
    let d = a - b;
    let m = d.abs().max_element();
    if m > 0.0 && m.is_finite() {
        m * (d / m).length()
    } else {
        d.length()
    }
}

/// The visibility lobes of one light at one point (eq. 39).
#[derive(Debug, Clone, PartialEq)]
pub struct Visibility {
    /// [`LightModel::Lobe`]: c_unit first, then −w_i·c_i per shadow leaf;
    /// [`LightModel::Cap`]: −w_i·f_i·c_i per shadow leaf inside the light (f_i > 0),
    /// no c_unit. Empty when the light is hidden.
    pub lobes: Vec<Lobe>,
    /// The paper's `dist` of the light (1/(2 tan α)).
    pub dist: f64,
    /// A blocker hides the whole light.
    pub fully_blocked: bool,
    /// Number of shadow leaves.
    pub leaves: usize,
}

/// The lobe pipeline over the three tables it reads.
#[derive(Debug, Clone, Copy)]
pub struct Meunier<'a> {
    /// Lobe products (the `energy` variant is what the paper's eq. 14 wants).
    pub products: &'a LobeProduct,
    /// Cap exponents (lights and leaves).
    pub caps: &'a CapExponent,
    /// Eq. 39's weights.
    pub weights: &'a MaskWeights,
}

impl Meunier<'static> {
    /// The pipeline over the compiled-in tables (lobe-product `energy`, cap-exponent,
    /// mask-weights).
    #[cfg(all(
        feature = "embedded-lobe-product",
        feature = "embedded-cap-exponent",
        feature = "embedded-mask-weights"
    ))]
    pub fn embedded() -> Result<&'static Self, crate::LoadError> {
        static CELL: std::sync::OnceLock<Result<Meunier<'static>, crate::LoadError>> = std::sync::OnceLock::new();
        CELL.get_or_init(|| {
            Ok(Meunier {
                products: LobeProduct::embedded()?,
                caps: CapExponent::embedded()?,
                weights: MaskWeights::embedded()?,
            })
        })
        .as_ref()
        .map_err(Clone::clone)
    }
}

/// The smallest light half-angle (rad) whose own lobe exponent the pipeline uses (see
/// [`Meunier::light_lobe`]).
pub const LIGHT_HALF_ANGLE_MIN: f64 = 1e-4;

impl Meunier<'_> {
    /// Cap exponent for any half-angle in (0, π): the table from 1 mrad on, the
    /// small-cap limit e ∝ 1/β² below.
    pub fn cap_exponent(&self, beta: f64) -> Result<f64, LookupError> {
        if beta > 0.0 && beta < ALPHA_MIN {
            let e0 = self.caps.e_cap(ALPHA_MIN)?;
            return crate::error::finite_result("e_cap", e0 * (ALPHA_MIN / beta).powi(2));
        }
        self.caps.e_cap(beta)
    }

    /// The lobe standing for `light` seen from `x` (outside it), scaled so that its
    /// integral is L·Ω_cap; and the light's cap. A light smaller than
    /// [`LIGHT_HALF_ANGLE_MIN`] gets that size's exponent (its integral stays L·Ω_cap):
    /// sharper lobes only lose digits in the products' closed forms (measured: 0.6 %
    /// at 1 µrad, wrong by orders of magnitude below 0.1 µrad), while a lobe of
    /// width ~1e-4 rad in place of a smaller light changes what it lights by O(1e-8).
    pub fn light_lobe(&self, x: DVec3, light: &SphereLight) -> Result<(Lobe, Cap), MeunierError> {
        check_scene(x, std::slice::from_ref(light), &[])?;
        let cap = cap_of(x, &light.sphere);
        let e = self.cap_exponent(cap.half_angle.max(LIGHT_HALF_ANGLE_MIN))?;
        let s = (0.5 * cap.half_angle).sin();
        let omega = 4.0 * std::f64::consts::PI * s * s;
        Ok((
            Lobe {
                scale: light.radiance * omega * (e + 1.0) / std::f64::consts::TAU,
                axis: cap.axis,
                exponent: e,
            },
            cap,
        ))
    }

    /// Eq. 39 for one light at the point `x` with unit normal `n`.
    pub fn visibility(
        &self,
        x: DVec3,
        n: DVec3,
        light: &SphereLight,
        blockers: &[Sphere],
        settings: &MaskSettings,
    ) -> Result<Visibility, MeunierError> {
        let n = unit("normal", n)?;
        check_scene(x, std::slice::from_ref(light), blockers)?;
        check_depth(settings.depth)?;
        let lcap = cap_of(x, &light.sphere);
        let light_dist = dist(light.sphere.centre, x);
        let caps: Vec<Cap> = blockers
            .iter()
            .filter(|b| dist(b.centre, x) - b.radius < light_dist)
            .map(|b| cap_of(x, b))
            .collect();
        let mask_dist = dist_of_cap(lcap.half_angle);
        let mut cells = Vec::new();
        if mask_leaves(lcap, &caps, settings.depth, settings.mode, &mut cells)? {
            return Ok(Visibility {
                lobes: Vec::new(),
                dist: mask_dist,
                fully_blocked: true,
                leaves: 0,
            });
        }
        let mut w = [0.0; MAX_DEPTH as usize];
        self.weights
            .weights(settings.weights, settings.mode, settings.depth, mask_dist, &mut w)?;
        let mut lobes = Vec::with_capacity(cells.len() + 1);
        if settings.light == LightModel::Lobe {
            lobes.push(Lobe {
                scale: 1.0,
                axis: n,
                exponent: 0.0,
            });
        }
        let leaves = cells.len();
        for (c, depth) in cells {
            // Depth 0 never holds a leaf (a cap containing S_unit hides the light).
            let mut wd = w[depth.max(1) as usize - 1];
            if wd == 0.0 {
                continue;
            }
            let exponent = self.cap_exponent(c.half_angle)?;
            if settings.light == LightModel::Cap {
                let gamma = c.axis.dot(lcap.axis).clamp(-1.0, 1.0).acos();
                wd *= lobe_fraction_in_cap(gamma, lcap.half_angle, exponent);
                if wd == 0.0 {
                    continue;
                }
            }
            lobes.push(Lobe {
                scale: -wd,
                axis: c.axis,
                exponent,
            });
        }
        Ok(Visibility {
            lobes,
            dist: mask_dist,
            fully_blocked: false,
            leaves,
        })
    }

    /// Outgoing radiance ∫ f_r L V max(n·v, 0) dω at `x` (unit normal `n`) for the BRDF
    /// lobes `brdf` (from [`Brdf::lobes`]), summed over `lights`, shadowed by
    /// `blockers` (eq. 22, §5.4 order). Never negative: the shadow leaves' lobes are
    /// subtracted from the unoccluded light, and where they overshoot (the mask's
    /// overlap weights are fitted, not exact) the sum would dip below 0, which no
    /// radiance does; it is clamped to 0 there.
    pub fn shade(
        &self,
        x: DVec3,
        n: DVec3,
        brdf: &[Lobe],
        lights: &[SphereLight],
        blockers: &[Sphere],
        settings: &MaskSettings,
    ) -> Result<f64, MeunierError> {
        let n = unit("normal", n)?;
        check_scene(x, lights, blockers)?;
        nonneg("threshold t_i", settings.threshold)?;
        let mut total = 0.0;
        for light in lights {
            let vis = self.visibility(x, n, light, blockers, settings)?;
            if vis.fully_blocked {
                continue;
            }
            let (lobe, cap) = self.light_lobe(x, light)?;
            total += match settings.light {
                LightModel::Lobe => self
                    .products
                    .triple_product(brdf, &[lobe], &vis.lobes, n, settings.threshold)?,
                LightModel::Cap => self.shade_cap(n, brdf, light, cap, &vis.lobes, settings)?,
            };
        }
        check_result("shaded radiance", total).map(|t| t.max(0.0))
    }

    /// One light's term of [`Meunier::shade`] under [`LightModel::Cap`]: the unoccluded
    /// light over the cap, plus the shadow leaves `shadow` (already −w_i·g_i·c_i) under
    /// the uniform radiance L, each leaf times each BRDF lobe × cosine.
    #[allow(clippy::too_many_arguments)]
    fn shade_cap(
        &self,
        n: DVec3,
        brdf: &[Lobe],
        light: &SphereLight,
        cap: Cap,
        shadow: &[Lobe],
        settings: &MaskSettings,
    ) -> Result<f64, MeunierError> {
        let threshold = settings.threshold;
        let cosine = Lobe {
            scale: 1.0,
            axis: n,
            exponent: 1.0,
        };
        let mut total = 0.0;
        for b in brdf {
            // The BRDF lobe × the cosine as one lobe (the product table): its part
            // inside the light's cap is the lit term, its products with the shadow
            // leaves the shadow's. One product a leaf: the radiance is uniform over
            // the hemisphere, and the hemisphere × the cosine is the cosine exactly.
            let p = self.products.product(b, &cosine)?;
            total += if b.exponent == 0.0 && b.axis.dot(n) >= 1.0 - 1e-12 {
                b.scale * light.radiance * cap_irradiance(cap.half_angle.sin(), cap.axis.dot(n))
            } else {
                let gamma = p.axis.dot(cap.axis).clamp(-1.0, 1.0).acos();
                light.radiance * p.integral() * lobe_fraction_in_cap(gamma, cap.half_angle, p.exponent)
            };
            let lit = Lobe {
                scale: light.radiance * p.scale,
                ..p
            };
            // t_i in the products' own units at both stages (the radiance included).
            if shadow.is_empty() || lit.scale == 0.0 || lit.integral().abs() < threshold {
                continue;
            }
            for leaf in shadow {
                // §5.4's t_i before the product: a product whose bound is below t_i
                // would be dropped by the comparison below.
                if threshold > 0.0 && LobeProduct::product_integral_bound(&lit, leaf) < threshold {
                    continue;
                }
                let v = self.leaf_product(&lit, leaf, settings)?;
                if v != 0.0 && v.abs() >= threshold {
                    total += v;
                }
            }
        }
        Ok(total)
    }

    /// The integral of the product of a light-cap term's lobe `lit` (a BRDF lobe × the
    /// cosine, radiance-scaled) and a shadow leaf's lobe `leaf` (sr × their scales):
    /// with [`MaskSettings::sharp_leaves`] and the `energy` products, the leaf's
    /// expansion ([`sharp_product_integral`]) where it answers, else the lobe-product
    /// table ([`LobeProduct::product_integral`]).
    pub fn leaf_product(&self, lit: &Lobe, leaf: &Lobe, settings: &MaskSettings) -> Result<f64, MeunierError> {
        let sharp = settings.sharp_leaves && self.products.variant() == Variant::Energy;
        match sharp
            .then(|| sharp_product_integral(lit.axis, lit.exponent, leaf.axis, leaf.exponent))
            .flatten()
        {
            Some(i) => check_result("leaf product", lit.scale * i * leaf.scale),
            None => Ok(self.products.product_integral(lit, leaf)?),
        }
    }

    /// Irradiance ∫ L V max(n·v, 0) dω (W·m⁻² for L in W·sr⁻¹·m⁻²) at `x`, unit normal
    /// `n`: [`Meunier::shade`] with the BRDF 1 on the upper hemisphere.
    pub fn irradiance(
        &self,
        x: DVec3,
        n: DVec3,
        lights: &[SphereLight],
        blockers: &[Sphere],
        settings: &MaskSettings,
    ) -> Result<f64, MeunierError> {
        let nn = unit("normal", n)?;
        let brdf = [Lobe {
            scale: 1.0,
            axis: nn,
            exponent: 0.0,
        }];
        self.shade(x, nn, &brdf, lights, blockers, settings)
    }

    /// Batch [`Meunier::irradiance`]: `out[i]` = the irradiance at `points[i]` with unit
    /// normal `normals[i]`, bit for bit the one-at-a-time value, for a renderer shading
    /// many points of one scene: each point through the one-at-a-time call (its
    /// validation costs nothing beside the mask and the lobe products, which are per
    /// point anyway). Errors: [`LookupError::BatchLength`]
    /// when the slices differ in length, [`MeunierError::BatchItem`] for the first
    /// point refused (inside a sphere, a normal that is not unit, …).
    pub fn irradiances(
        &self,
        points: &[DVec3],
        normals: &[DVec3],
        lights: &[SphereLight],
        blockers: &[Sphere],
        settings: &MaskSettings,
        out: &mut [f64],
    ) -> Result<(), MeunierError> {
        crate::error::same_length(points.len(), normals.len())?;
        crate::error::same_length(points.len(), out.len())?;
        check_depth(settings.depth)?;
        nonneg("threshold t_i", settings.threshold)?;
        for (i, ((x, n), o)) in points.iter().zip(normals).zip(out.iter_mut()).enumerate() {
            *o = self
                .irradiance(*x, *n, lights, blockers, settings)
                .map_err(|e| MeunierError::BatchItem {
                    index: i,
                    error: Box::new(e),
                })?;
        }
        Ok(())
    }

    /// [`Meunier::irradiances`] in single precision (f64 inside, rounded once), bit for
    /// bit [`Meunier::irradiance_f32`].
    pub fn irradiances_f32(
        &self,
        points: &[Vec3],
        normals: &[Vec3],
        lights: &[SphereLight32],
        blockers: &[Sphere32],
        settings: &MaskSettings,
        out: &mut [f32],
    ) -> Result<(), MeunierError> {
        crate::error::same_length(points.len(), normals.len())?;
        crate::error::same_length(points.len(), out.len())?;
        for (i, ((x, n), o)) in points.iter().zip(normals).zip(out.iter_mut()).enumerate() {
            *o = self
                .irradiance_f32(*x, *n, lights, blockers, settings)
                .map_err(|e| MeunierError::BatchItem {
                    index: i,
                    error: Box::new(e),
                })?;
        }
        Ok(())
    }

    /// [`Meunier::irradiance`] with an f32 interface (computed in f64, rounded once).
    pub fn irradiance_f32(
        &self,
        x: Vec3,
        n: Vec3,
        lights: &[SphereLight32],
        blockers: &[Sphere32],
        settings: &MaskSettings,
    ) -> Result<f32, MeunierError> {
        let l: Vec<SphereLight> = lights.iter().map(SphereLight32::wide).collect();
        let b: Vec<Sphere> = blockers.iter().map(Sphere32::wide).collect();
        let e = self.irradiance(x.as_dvec3(), n.as_dvec3(), &l, &b, settings)?;
        Ok(crate::error::narrow("irradiance", e)?)
    }

    /// Outgoing radiance towards the unit direction `wo` of a surface with `brdf`
    /// (unit normal `n`, unit tangent `t` for anisotropic Lafortune lobes).
    #[allow(clippy::too_many_arguments)]
    pub fn radiance(
        &self,
        x: DVec3,
        n: DVec3,
        t: DVec3,
        wo: DVec3,
        brdf: &Brdf,
        lights: &[SphereLight],
        blockers: &[Sphere],
        settings: &MaskSettings,
    ) -> Result<f64, MeunierError> {
        let lobes = brdf.lobes(n, t, wo)?;
        self.shade(x, n, &lobes, lights, blockers, settings)
    }

    /// [`Meunier::radiance`] with an f32 interface (computed in f64, rounded once).
    #[allow(clippy::too_many_arguments)]
    pub fn radiance_f32(
        &self,
        x: Vec3,
        n: Vec3,
        t: Vec3,
        wo: Vec3,
        brdf: &Brdf,
        lights: &[SphereLight32],
        blockers: &[Sphere32],
        settings: &MaskSettings,
    ) -> Result<f32, MeunierError> {
        let l: Vec<SphereLight> = lights.iter().map(SphereLight32::wide).collect();
        let b: Vec<Sphere> = blockers.iter().map(Sphere32::wide).collect();
        let v = self.radiance(
            x.as_dvec3(),
            n.as_dvec3(),
            t.as_dvec3(),
            wo.as_dvec3(),
            brdf,
            &l,
            &b,
            settings,
        )?;
        Ok(crate::error::narrow("radiance", v)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_cap f(v) dω over the cap of half-angle `alpha` about +z by the midpoint rule,
    /// 400 × 400 in θ and φ.
    fn cap_rule(alpha: f64, f: impl Fn(DVec3) -> f64) -> f64 {
        let (nt, np) = (400, 400);
        let mut s = 0.0;
        for i in 0..nt {
            let th = alpha * (i as f64 + 0.5) / nt as f64;
            for j in 0..np {
                let ph = std::f64::consts::TAU * (j as f64 + 0.5) / np as f64;
                s += f(DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())) * th.sin();
            }
        }
        s * (alpha / nt as f64) * (std::f64::consts::TAU / np as f64)
    }

    /// ∫_cap max(a·v, 0)^e dω / (2π/(e + 1)), the lobe exactly as defined.
    fn brute_fraction(gamma: f64, alpha: f64, e: f64) -> f64 {
        let a = DVec3::new(gamma.sin(), 0.0, gamma.cos());
        cap_rule(alpha, |v| a.dot(v).max(0.0).powf(e)) * (e + 1.0) / std::f64::consts::TAU
    }

    /// The Gaussian share of a lobe inside a cap against the lobe's own integral: within
    /// 0.01 for the narrow leaf lobes (e ≥ 200) the pipeline feeds it, within 0.04 for
    /// a Phong-like e = 21 (a BRDF lobe × the cosine).
    #[test]
    fn lobe_fraction_in_cap_matches_the_lobe() {
        for &(e, tol) in &[(2000.0, 0.01), (200.0, 0.01), (21.0, 0.04)] {
            let width = 1.0 / f64::sqrt(e + 1.0);
            for &alpha in &[0.5 * width, 2.0 * width, 5.0 * width] {
                for &g in &[0.0, 0.5, 1.0, 1.5] {
                    let gamma = g * alpha;
                    let got = lobe_fraction_in_cap(gamma, alpha, e);
                    let want = brute_fraction(gamma, alpha, e);
                    assert!((got - want).abs() < tol, "e {e} α {alpha} γ {gamma}: {got} vs {want}");
                }
            }
        }
        assert_eq!(lobe_fraction_in_cap(0.0, 1.0, 1e4), 1.0);
        assert_eq!(lobe_fraction_in_cap(1.0, 0.1, 1e4), 0.0);
    }

    /// The sphere light's irradiance against the same product rule over the cap with
    /// the clamped cosine (above, across and below the horizon).
    #[test]
    fn cap_irradiance_matches_a_product_rule() {
        for &alpha in &[0.1f64, 0.5, 0.85, 1.3] {
            for &beta in &[0.0f64, 0.7, 1.2, 1.6, 2.0, 2.6] {
                let n = DVec3::new(beta.sin(), 0.0, beta.cos());
                let brute = cap_rule(alpha, |v| n.dot(v).max(0.0));
                let got = cap_irradiance(alpha.sin(), beta.cos());
                assert!(
                    (got - brute).abs() < 2e-5 * alpha * alpha,
                    "α {alpha} β {beta}: {got} vs {brute}"
                );
            }
        }
    }
}
