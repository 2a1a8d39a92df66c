//! Scene geometry and materials every pipeline shares: spheres (blockers and
//! spherical lights, f64 and their f32 twins) and BRDFs made of cosine lobes.
//! Units are the scene's (any length unit, used consistently); radiance in any unit
//! (results scale with it). The Meunier pipeline's operations on them (a BRDF's world-space
//! lobes, the light's cap) live in [`crate::meunier`].

use glam::{DVec3, Vec3};

/// A sphere: centre (scene units) and radius (same units, > 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub centre: DVec3,
    /// Radius (> 0).
    pub radius: f64,
}

/// A spherical light of uniform radiance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereLight {
    /// Its sphere.
    pub sphere: Sphere,
    /// Radiance L (W·sr⁻¹·m⁻², or any unit: results scale with it; finite, ≥ 0).
    pub radiance: f64,
}

/// [`Sphere`] in f32.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere32 {
    /// Centre.
    pub centre: Vec3,
    /// Radius (> 0).
    pub radius: f32,
}

/// [`SphereLight`] in f32.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereLight32 {
    /// Its sphere.
    pub sphere: Sphere32,
    /// Radiance.
    pub radiance: f32,
}

impl Sphere32 {
    pub(crate) fn wide(&self) -> Sphere {
        Sphere {
            centre: self.centre.as_dvec3(),
            radius: self.radius as f64,
        }
    }
}

impl SphereLight32 {
    pub(crate) fn wide(&self) -> SphereLight {
        SphereLight {
            sphere: self.sphere.wide(),
            radiance: self.radiance as f64,
        }
    }
}

/// One Lafortune lobe ρ_s·(C_x u_x v_x + C_y u_y v_y + C_z u_z v_z)^n in the local
/// frame (tangent, bitangent, normal) of the shading point (u incoming, v outgoing).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LafortuneLobe {
    /// Coefficients (C_x, C_y, C_z); (−1, −1, 1) is a Phong-like lobe about the mirror
    /// direction.
    pub c: DVec3,
    /// Scale ρ_s (sr⁻¹).
    pub rho: f64,
    /// Exponent n (≥ 0).
    pub exponent: f64,
}

/// A BRDF made of cosine lobes (§5.1).
#[derive(Debug, Clone, PartialEq)]
pub enum Brdf {
    /// Lambertian: albedo/π on the upper hemisphere (the lobe (albedo/π, n, 0)).
    Lambert {
        /// Albedo in [0, 1].
        albedo: f64,
    },
    /// Lafortune: a Lambertian term plus generalised cosine lobes. For an outgoing
    /// direction v_o each lobe is the cosine lobe of axis M v_o/|M v_o|, scale
    /// ρ_s |M v_o|^n and exponent n, M = diag(C) in the local frame (eq. 30).
    Lafortune {
        /// Albedo of the Lambertian term.
        albedo: f64,
        /// The lobes.
        lobes: Vec<LafortuneLobe>,
    },
    /// Cook–Torrance: a Lambertian term plus a GGX microfacet specular term
    /// ([`crate::microfacet::CookTorrance`]). Not a sum of cosine lobes: Meunier's
    /// shading refuses it; the ISG pipeline shades it as one warped SG.
    CookTorrance {
        /// Albedo of the Lambertian term.
        albedo: f64,
        /// The specular term.
        specular: crate::microfacet::CookTorrance,
    },
    /// Blinn-Phong: a Lambertian term plus k_s (s + 8)/(8π) (n·h)^s
    /// ([`crate::microfacet::BlinnPhong`]); shaded by the ISG pipeline as one warped SG.
    BlinnPhong {
        /// Albedo of the Lambertian term.
        albedo: f64,
        /// The specular term.
        specular: crate::microfacet::BlinnPhong,
    },
}
