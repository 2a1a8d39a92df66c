//! the integral spherical Gaussian (Iwasaki et al. 2012, §4; docs/math.md, isg, errata
//! E1–E3), three models of it, and the SG algebra of docs/math.md §1.
//!
//! # Parameterisation
//!
//! In the SG's local frame (SG axis = +z):
//! Ω(θ, φ) = (sinθ cosφ, cosθ, sinθ sinφ), with **θ ∈ [0, π] measured from +y** and
//! **φ ∈ [0, π] the azimuth about +y measured from +x towards +z**. The square [0, π]²
//! covers the hemisphere z ≥ 0 and the SG axis sits at (θ, φ) = (π/2, π/2).
//!
//!   S(θ, φ; γ) = ∫_0^θ ∫_0^φ exp(γ (Ω(θ',φ')·z − 1)) sinθ' dφ' dθ'   \[sr\],
//!   Ŝ(θ, φ; γ) = S / S(π, π),   S(π, π) = 2π/γ (1 − e^{−γ})   (`normaliser`).
//!
//! A unit-amplitude SG of sharpness γ integrates over the patch
//! [θ1, θ2] × [φ1, φ2] to S(θ2,φ2) − S(θ1,φ2) − S(θ2,φ1) + S(θ1,φ1) ([`IsgModel::patch`]).
//!
//! # Models (all implement [`IsgModel`], γ ∈ [0.5, 10^4])
//!
//! - [`PaperIsg`]: the published fit, f = σ(g(γ)(θ − π/2)) · σ(h(γ)(φ − π/2)),
//!   σ(x) = 1/(1 + e^{−x}), g and h quartics in γ/100 (appendix of the paper). No table.
//! - [`RefitIsg`]: the same logistic model with g(γ), h(γ) refitted and tabulated
//!   over ln γ (table kind `isg-refit`).
//! - [`BestIsg`]: the rank-2 separable model Ŝ ≈ A(θ; γ) B(φ; γ) + C(θ; γ) D(φ; γ)
//!   with the exact marginals A(θ) = Ŝ(θ, π), B(φ) = Ŝ(π, φ) and C D the leading
//!   singular pair of Ŝ − A B (table kind `isg-best`). Exact whenever θ or φ is 0 or π
//!   (C and D vanish there). A(π − θ) = 1 − A(θ), C(π − θ) = −C(θ), B and D likewise,
//!   so only θ, φ ≤ π/2 are stored, on a warped coordinate u (see `warp`) that maps
//!   [0, π/2] to [1, 0] for every γ and is proportional to |θ − π/2|·√γ near the axis.

use std::f64::consts::{FRAC_PI_2, PI};

use crate::error::{
    angle_f32, finite, finite_result, first_failure, in_range, narrow, same_length, LoadError, LookupError,
};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::table::Table;
use glam::{DVec3, Vec3};

/// Table kind of the refitted logistic model.
pub const KIND_REFIT: &str = "isg-refit";
/// Table kind of the separable model.
pub const KIND_BEST: &str = "isg-best";
/// Family version of both tables.
pub const VERSION: u32 = 1;
/// Smallest SG sharpness covered.
pub const GAMMA_MIN: f64 = 0.5;
/// Largest SG sharpness covered.
pub const GAMMA_MAX: f64 = 1.0e4;
/// Channels of the refit table (both log-encoded: slopes are positive).
pub const REFIT_CHANNELS: [&str; 2] = ["g", "h"];
/// Channels of the separable table, for θ, φ ≤ π/2: the marginals A(θ), B(φ) and the
/// correction factors C(θ), D(φ).
pub const BEST_CHANNELS: [&str; 4] = ["a", "b", "c", "d"];

/// Plausible range of each stored channel of `isg-refit` (name, lo, hi), on the
/// stored ln g, ln h (g, h in 1/rad): the logistic slope follows the SG's angular
/// width 1/√γ, g ≈ k√γ with k between 1.7 (γ = 10⁴) and 3.5 (γ = 0.5), so g, h lie in
/// [1.2, 170] (ln in [0.7, 5.2]) over γ ∈ [0.5, 10⁴]. Range: ln g, ln h ∈ [−1.5, 7]
/// (slopes 0.22 to 1100 1/rad).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const REFIT_CHANNEL_RANGES: &[(&str, f64, f64)] =
    &[(REFIT_CHANNELS[0], -1.5, 7.0), (REFIT_CHANNELS[1], -1.5, 7.0)];

/// Plausible range of each stored channel of `isg-best` (name, lo, hi),
/// dimensionless: the marginals A(θ), B(φ) are fractions of the SG's integral, in
/// [0, 1/2] for the stored θ, φ ≤ π/2 (1/2 at the axis by symmetry); range
/// [−0.05, 0.55]. C·D approximates Ŝ − A·B, which lies in [−1/4, 1/4] there, and the
/// fit splits it evenly between the factors (C ≈ D, at most 0.0625 in the committed
/// table), so |C|, |D| ≤ 1/2.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const BEST_CHANNEL_RANGES: &[(&str, f64, f64)] = &[
    (BEST_CHANNELS[0], -0.05, 0.55),
    (BEST_CHANNELS[1], -0.05, 0.55),
    (BEST_CHANNELS[2], -0.5, 0.5),
    (BEST_CHANNELS[3], -0.5, 0.5),
];

/// Published coefficients (g4, g3, g2, g1, g0) of g(x), x = γ/100 (paper appendix).
pub(crate) const PAPER_G: [f64; 5] = [-2.6856e-6, 7e-4, -0.0571, 3.9529, 17.6028];
/// Published coefficients (h4, h3, h2, h1, h0) of h(x), x = γ/100 (paper appendix).
pub(crate) const PAPER_H: [f64; 5] = [-2.6875e-6, 7e-4, -0.0592, 3.9900, 17.5003];

/// S(π, π; γ) = 2π/γ (1 − e^{−γ}) sr: the integral of exp(γ(v·z − 1)) over z ≥ 0.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn normaliser(gamma: f64) -> f64 {
    2.0 * PI / gamma * -(-gamma).exp_m1()
}

/// The logistic function σ(x) = 1/(1 + e^{−x}), without overflow for large |x|.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn sigmoid(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

/// The published quartic in x = γ/100, evaluated as printed (Horner).
pub(crate) fn paper_poly(c: &[f64; 5], gamma: f64) -> f64 {
    let x = gamma / 100.0;
    (((c[0] * x + c[1]) * x + c[2]) * x + c[3]) * x + c[4]
}

/// The warped coordinate of the separable table: for an angle x ∈ [0, π/2] (θ or φ),
/// with q = 1 − sin x = 2 sin²((x − π/2)/2),
///   u = √((1 − e^{−γq}) / (1 − e^{−γ})) ∈ [0, 1],
/// so u = 1 at x = 0 for every γ, and u ≈ |x − π/2|·√(γ/2)/√(1 − e^{−γ}) near the axis
/// (linear in the SG's natural width, where the marginals vary).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn warp(x: f64, gamma: f64) -> f64 {
    let s = (0.5 * (x - FRAC_PI_2)).sin();
    let q = 2.0 * s * s;
    ((-gamma * q).exp_m1() / (-gamma).exp_m1()).sqrt().min(1.0)
}

/// Inverse of [`warp`]: the angle x ∈ [0, π/2] of a coordinate u ∈ [0, 1].
#[cfg(feature = "writer")]
pub fn unwarp(u: f64, gamma: f64) -> f64 {
    let q = (-(u * u * (-gamma).exp_m1()).ln_1p() / gamma).clamp(0.0, 1.0);
    (FRAC_PI_2 - 2.0 * (0.5 * q).sqrt().asin()).clamp(0.0, FRAC_PI_2)
}

/// The γ axis of both tables: ln γ uniform on [0.5, 10^4].
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn gamma_axis(count: u32) -> Axis {
    Axis {
        name: "gamma".into(),
        unit: "1".into(),
        lo: GAMMA_MIN,
        hi: GAMMA_MAX,
        mapping: Mapping::Log,
        count,
        placement: Placement::Endpoints,
    }
}

/// The warped-angle axis of the separable table (see [`warp`]).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn warp_axis(count: u32) -> Axis {
    Axis {
        name: "u".into(),
        unit: "1".into(),
        lo: 0.0,
        hi: 1.0,
        mapping: Mapping::Linear,
        count,
        placement: Placement::Endpoints,
    }
}

/// A model of the normalised ISG. Every method validates its inputs: angles in
/// [0, π] rad, γ ∈ [0.5, 10^4], ε ∈ (0, 1/2); NaN, infinities and out-of-domain values
/// are [`LookupError`]s naming the input.
pub trait IsgModel {
    /// Ŝ(θ, φ; γ) ∈ [0, 1] without input checks (inputs already validated).
    fn s_hat_unchecked(&self, theta: f64, phi: f64, gamma: f64) -> f64;

    /// Limiting angle Γ (rad) for threshold ε, without input checks.
    fn limiting_angle_unchecked(&self, gamma: f64, eps: f64) -> f64;

    /// Normalised ISG Ŝ(θ, φ; γ) (dimensionless, in [0, 1]).
    fn s_hat(&self, theta: f64, phi: f64, gamma: f64) -> Result<f64, LookupError> {
        check(theta, phi, gamma)?;
        // The models are bounded for every table the loaders accept; the check keeps
        // that a guarantee (never Ok(NaN)) rather than an assumption.
        finite_result("S_hat", self.s_hat_unchecked(theta, phi, gamma))
    }

    /// ISG S(θ, φ; γ) = Ŝ · 2π/γ (1 − e^{−γ}) in steradians (unit-amplitude SG).
    fn s(&self, theta: f64, phi: f64, gamma: f64) -> Result<f64, LookupError> {
        Ok(self.s_hat(theta, phi, gamma)? * normaliser(gamma))
    }

    /// Integral (sr) of the unit-amplitude SG of sharpness γ over the spherical
    /// rectangle θ ∈ [θ1, θ2], φ ∈ [φ1, φ2], from the four corners:
    /// S(θ2,φ2) − S(θ1,φ2) − S(θ2,φ1) + S(θ1,φ1). Reversed bounds flip the sign.
    fn patch(&self, theta1: f64, theta2: f64, phi1: f64, phi2: f64, gamma: f64) -> Result<f64, LookupError> {
        check(theta1, phi1, gamma)?;
        check(theta2, phi2, gamma)?;
        let s = |t, p| self.s_hat_unchecked(t, p, gamma);
        finite_result(
            "patch integral",
            (s(theta2, phi2) - s(theta1, phi2) - s(theta2, phi1) + s(theta1, phi1)) * normaliser(gamma),
        )
    }

    /// ∫ of the SG `sg` over a spherical rectangle given in world space (sr times the
    /// SG's amplitude): θ ∈ [θ1, θ2] = `theta` from the unit `pole`, φ ∈ [φ1, φ2] =
    /// `phi` (φ1 ≤ φ2, rad) about the pole, from `phi_zero` (its part ⟂ the pole)
    /// towards phi_zero × pole; that is, in the right-handed frame x = phi_zero, y =
    /// pole, z = x × y, the points Ω(θ, φ) = (sin θ cos φ, cos θ, sin θ sin φ).
    ///
    /// The models describe an SG whose axis lies on the frame's equator, so `sg.axis`
    /// must be ⟂ `pole` (|axis·pole| ≤ [`WORLD_AXIS_TOL`]); its azimuth φ_a is taken out
    /// exactly (a rotation about the pole), and the rectangle must lie in the
    /// hemisphere around the axis, φ_a − π/2 ≤ φ1 ≤ φ2 ≤ φ_a + π/2 (mod 2π). Each of
    /// these is a specific error otherwise.
    fn patch_world(
        &self,
        sg: &Sg,
        pole: DVec3,
        phi_zero: DVec3,
        theta: [f64; 2],
        phi: [f64; 2],
    ) -> Result<f64, LookupError> {
        let y = unit_axis(pole).map_err(|_| LookupError::OutOfDomain {
            name: "|pole| (unit, within 1e-3)".into(),
            value: pole.length(),
            lo: 1.0,
            hi: 1.0,
        })?;
        let x0 = phi_zero - phi_zero.dot(y) * y;
        if x0.length().is_nan() || x0.length() <= 1e-6 {
            return Err(LookupError::OutOfDomain {
                name: "length of phi_zero's part perpendicular to the pole".into(),
                value: x0.length(),
                lo: 1e-6,
                hi: f64::INFINITY,
            });
        }
        let x = x0.normalize();
        let z = x.cross(y);
        let tilt = sg.axis.dot(y);
        in_range("SG axis · pole (must be ~0)", tilt, -WORLD_AXIS_TOL, WORLD_AXIS_TOL)?;
        for v in phi {
            finite("phi", v)?;
        }
        if phi[0] > phi[1] {
            return Err(LookupError::OutOfDomain {
                name: "phi1 − phi2 (need phi1 ≤ phi2)".into(),
                value: phi[0] - phi[1],
                lo: f64::NEG_INFINITY,
                hi: 0.0,
            });
        }
        // Rotate about the pole so that the axis sits at φ = π/2.
        let phi_a = sg.axis.dot(z).atan2(sg.axis.dot(x));
        let p1 = (phi[0] - phi_a + FRAC_PI_2).rem_euclid(2.0 * PI);
        let p2 = p1 + (phi[1] - phi[0]);
        // Rounding in the shift may leave an end a few ulps outside [0, π].
        let slack = 1e-12;
        let p1 = if p1 > 2.0 * PI - slack { 0.0 } else { p1 };
        let p2 = if p2 > PI && p2 <= PI + slack { PI } else { p2 };
        in_range("phi2 relative to the SG axis's azimuth + π/2", p2, 0.0, PI)?;
        Ok(sg.amplitude * self.patch(theta[0], theta[1], p1, p2, sg.sharpness)?)
    }

    /// Limiting angle Γ ∈ [0, π/2] (rad) for the threshold ε ∈ [1e-8, 1/2) (paper §4.1,
    /// ε = 0.01 there): the model's marginal in θ and in φ is below ε at an angular
    /// distance Γ from the SG axis (θ or φ = π/2 − Γ), so patches beyond the cone of
    /// half-angle Γ about the axis can be skipped. Logistic models:
    /// Γ = ln(1/ε − 1)/min(g, h); separable model: the larger root of A(π/2 − Γ) = ε,
    /// B(π/2 − Γ) = ε. Capped at π/2.
    fn limiting_angle(&self, gamma: f64, eps: f64) -> Result<f64, LookupError> {
        in_range("gamma", gamma, GAMMA_MIN, GAMMA_MAX)?;
        let e = finite("eps", eps)?;
        if !(EPS_MIN..0.5).contains(&e) {
            return Err(LookupError::OutOfDomain {
                name: "eps".into(),
                value: e,
                lo: EPS_MIN,
                hi: 0.5,
            });
        }
        finite_result("limiting angle", self.limiting_angle_unchecked(gamma, e).min(FRAC_PI_2))
    }

    /// Batch [`IsgModel::s_hat`]: `out[i]` = Ŝ(θ, φ; γ) for `queries[i]` = [θ, φ, γ]
    /// (rad, rad, dimensionless; same domain), bit for bit the one-at-a-time value.
    /// The slice is validated first, then computed in a plain loop with no per-item
    /// `Result`. Errors: [`LookupError::BatchLength`] when the slices differ in
    /// length, [`LookupError::BatchItem`] (index and the one-at-a-time error) for the
    /// first bad query.
    fn s_hats(&self, queries: &[[f64; 3]], out: &mut [f64]) -> Result<(), LookupError> {
        same_length(queries.len(), out.len())?;
        if !queries.iter().fold(true, |ok, q| ok & valid(q)) {
            first_failure(queries, |q| self.s_hat(q[0], q[1], q[2]))?;
        }
        for (o, q) in out.iter_mut().zip(queries) {
            *o = self.s_hat_unchecked(q[0], q[1], q[2]);
        }
        // The models are bounded (see s_hat); checked, never assumed.
        if !out.iter().all(|v| v.is_finite()) {
            first_failure(queries, |q| self.s_hat(q[0], q[1], q[2]))?;
        }
        Ok(())
    }

    /// [`IsgModel::s_hats`] in single precision (f64 inside, rounded once; π as f32
    /// taken as π), bit for bit [`IsgModel::s_hat_f32`].
    fn s_hats_f32(&self, queries: &[[f32; 3]], out: &mut [f32]) -> Result<(), LookupError> {
        same_length(queries.len(), out.len())?;
        let wide = |q: &[f32; 3]| [angle_f32(q[0]), angle_f32(q[1]), q[2] as f64];
        if !queries.iter().fold(true, |ok, q| ok & valid(&wide(q))) {
            first_failure(queries, |q| self.s_hat_f32(q[0], q[1], q[2]))?;
        }
        for (o, q) in out.iter_mut().zip(queries) {
            let [t, p, g] = wide(q);
            *o = self.s_hat_unchecked(t, p, g) as f32;
        }
        if !out.iter().all(|v| v.is_finite()) {
            first_failure(queries, |q| self.s_hat_f32(q[0], q[1], q[2]))?;
        }
        Ok(())
    }

    /// [`IsgModel::s_hat`] with an f32 interface (computed in f64, rounded once).
    fn s_hat_f32(&self, theta: f32, phi: f32, gamma: f32) -> Result<f32, LookupError> {
        narrow("S_hat", self.s_hat(angle_f32(theta), angle_f32(phi), gamma as f64)?)
    }

    /// [`IsgModel::s`] with an f32 interface (computed in f64, rounded once).
    fn s_f32(&self, theta: f32, phi: f32, gamma: f32) -> Result<f32, LookupError> {
        narrow("S", self.s(angle_f32(theta), angle_f32(phi), gamma as f64)?)
    }

    /// [`IsgModel::patch`] with an f32 interface (computed in f64, rounded once).
    fn patch_f32(&self, theta1: f32, theta2: f32, phi1: f32, phi2: f32, gamma: f32) -> Result<f32, LookupError> {
        let a = angle_f32;
        narrow(
            "patch integral",
            self.patch(a(theta1), a(theta2), a(phi1), a(phi2), gamma as f64)?,
        )
    }

    /// [`IsgModel::limiting_angle`] with an f32 interface (computed in f64, rounded once).
    fn limiting_angle_f32(&self, gamma: f32, eps: f32) -> Result<f32, LookupError> {
        narrow("limiting angle", self.limiting_angle(gamma as f64, eps as f64)?)
    }
}

/// Smallest threshold ε of [`IsgModel::limiting_angle`]: below ~1e-10 the best
/// model's warped marginals saturate and the root would be too small.
pub const EPS_MIN: f64 = 1e-8;

/// Validates (θ, φ, γ).
fn check(theta: f64, phi: f64, gamma: f64) -> Result<(), LookupError> {
    in_range("theta", theta, 0.0, PI)?;
    in_range("phi", phi, 0.0, PI)?;
    in_range("gamma", gamma, GAMMA_MIN, GAMMA_MAX)?;
    Ok(())
}

/// Whether (θ, φ, γ) passes [`check`], without branches (NaN fails).
#[inline]
fn valid(q: &[f64; 3]) -> bool {
    (q[0] >= 0.0) & (q[0] <= PI) & (q[1] >= 0.0) & (q[1] <= PI) & (q[2] >= GAMMA_MIN) & (q[2] <= GAMMA_MAX)
}

/// The paper's published model (no table). Valid only near γ ∈ [100, 1000] (docs/math.md, erratum E3).
#[derive(Debug, Clone, Copy, Default)]
pub struct PaperIsg;

impl IsgModel for PaperIsg {
    fn s_hat_unchecked(&self, theta: f64, phi: f64, gamma: f64) -> f64 {
        let at = self.at_gamma_unchecked(gamma);
        Self::combine(
            self.factors_unchecked(&at, 0, theta),
            self.factors_unchecked(&at, 1, phi),
        )
    }
    fn limiting_angle_unchecked(&self, gamma: f64, eps: f64) -> f64 {
        let s = paper_poly(&PAPER_G, gamma).min(paper_poly(&PAPER_H, gamma));
        (1.0 / eps - 1.0).ln() / s
    }
}

/// The refitted logistic model: g(γ), h(γ) interpolated linearly in ln γ (stored as
/// ln g, ln h).
#[derive(Debug, Clone)]
pub struct RefitIsg {
    table: Table,
}

crate::table_type::impl_table_type!(RefitIsg: KIND_REFIT, VERSION);

impl RefitIsg {
    /// Wraps a loaded table, checking kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND_REFIT, VERSION)?;
        let n = table.meta().axes.first().map_or(0, |a| a.count);
        table.expect_layout(
            &[gamma_axis(n)],
            &[(REFIT_CHANNELS[0], Encoding::Log), (REFIT_CHANNELS[1], Encoding::Log)],
        )?;
        table.expect_channel_ranges(REFIT_CHANNEL_RANGES)?;
        Ok(Self { table })
    }

    /// The slopes (g, h) (1/rad) at γ ∈ [0.5, 10^4].
    pub fn slopes(&self, gamma: f64) -> Result<(f64, f64), LookupError> {
        let mut out = [0.0; 2];
        self.table.interpolate(&[gamma], &mut out)?;
        Ok((out[0], out[1]))
    }

    fn slopes_unchecked(&self, gamma: f64) -> (f64, f64) {
        // γ was validated: no second range check.
        let mut out = [0.0; 2];
        self.table.interpolate_valid(&[gamma], &mut out);
        (out[0], out[1])
    }
}

impl IsgModel for RefitIsg {
    fn s_hat_unchecked(&self, theta: f64, phi: f64, gamma: f64) -> f64 {
        let at = self.at_gamma_unchecked(gamma);
        Self::combine(
            self.factors_unchecked(&at, 0, theta),
            self.factors_unchecked(&at, 1, phi),
        )
    }
    fn limiting_angle_unchecked(&self, gamma: f64, eps: f64) -> f64 {
        let (g, h) = self.slopes_unchecked(gamma);
        (1.0 / eps - 1.0).ln() / g.min(h)
    }
}

/// The rank-2 separable model Ŝ ≈ A(θ; γ) B(φ; γ) + C(θ; γ) D(φ; γ) (exact marginals
/// A, B; bilinear in (ln γ, u)).
#[derive(Debug, Clone)]
pub struct BestIsg {
    table: Table,
    /// Node counts (γ, u), cached for the direct bilinear path.
    n: (usize, usize),
}

crate::table_type::impl_table_type!(BestIsg: KIND_BEST, VERSION);

impl BestIsg {
    /// Wraps a loaded table, checking kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND_BEST, VERSION)?;
        let m = table.meta();
        let (n0, n1) = (
            m.axes.first().map_or(0, |a| a.count),
            m.axes.get(1).map_or(0, |a| a.count),
        );
        table.expect_layout(
            &[gamma_axis(n0), warp_axis(n1)],
            &[
                (BEST_CHANNELS[0], Encoding::Linear),
                (BEST_CHANNELS[1], Encoding::Linear),
                (BEST_CHANNELS[2], Encoding::Linear),
                (BEST_CHANNELS[3], Encoding::Linear),
            ],
        )?;
        table.expect_channel_ranges(BEST_CHANNEL_RANGES)?;
        Ok(Self {
            table,
            n: (n0 as usize, n1 as usize),
        })
    }

    /// Factors (marginal, correction) of axis `k` (0: (A, C) in θ, 1: (B, D) in φ) at
    /// an angle x ∈ [0, π], by the generic table interpolation.
    fn factor(&self, k: usize, x: f64, gamma: f64) -> (f64, f64) {
        let mut out = [0.0; 4];
        let (mirrored, y) = if x > FRAC_PI_2 { (true, PI - x) } else { (false, x) };
        // Inputs were validated, so the coordinates are in range.
        if self.table.interpolate(&[gamma, warp(y, gamma)], &mut out).is_err() {
            return (f64::NAN, f64::NAN);
        }
        if mirrored {
            (1.0 - out[k], -out[k + 2])
        } else {
            (out[k], out[k + 2])
        }
    }

    /// The marginals (A(θ), B(φ)) = (Ŝ(θ, π), Ŝ(π, φ)).
    pub fn marginals(&self, theta: f64, phi: f64, gamma: f64) -> Result<(f64, f64), LookupError> {
        check(theta, phi, gamma)?;
        Ok((self.factor(0, theta, gamma).0, self.factor(1, phi, gamma).0))
    }

    /// All four factors ((A(θ), C(θ)), (B(φ), D(φ))) by the generic table interpolation;
    /// Ŝ ≈ A B + C D.
    pub fn factors(&self, theta: f64, phi: f64, gamma: f64) -> Result<[(f64, f64); 2], LookupError> {
        check(theta, phi, gamma)?;
        Ok([self.factor(0, theta, gamma), self.factor(1, phi, gamma)])
    }
}

impl IsgModel for BestIsg {
    fn s_hat_unchecked(&self, theta: f64, phi: f64, gamma: f64) -> f64 {
        let at = self.at_gamma_unchecked(gamma);
        Self::combine(
            self.factors_unchecked(&at, 0, theta),
            self.factors_unchecked(&at, 1, phi),
        )
    }
    fn limiting_angle_unchecked(&self, gamma: f64, eps: f64) -> f64 {
        // Bisection on each monotone marginal: A(π/2 − Γ) = ε.
        let root = |c: usize| {
            let (mut lo, mut hi) = (0.0, FRAC_PI_2); // Γ
            if self.factor(c, 0.0, gamma).0 >= eps {
                return FRAC_PI_2;
            }
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if self.factor(c, FRAC_PI_2 - mid, gamma).0 > eps {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        root(0).max(root(1))
    }
}

/// A model whose Ŝ is a sum of products of one-angle factors,
/// Ŝ(θ, φ; γ) = Σ_r a_r(θ; γ) b_r(φ; γ): rank 1 for the logistic models
/// (σ(g(θ − π/2)) · σ(h(φ − π/2))), rank 2 for [`BestIsg`] (A B + C D).
///
/// Where many Ŝ share their angles — the corners of an n × n grid of patches lie on
/// n + 1 angles per side — the factors at each angle, computed once, give every
/// corner by [`SeparableIsg::combine`]: 2(n + 1) factor evaluations instead of
/// 2(n + 1)². Bit for bit [`IsgModel::s_hat_unchecked`], which each model computes
/// as that very combination.
pub trait SeparableIsg: IsgModel {
    /// What the factors at one γ share: the slopes (g, h) of the logistic models; the
    /// γ cell, its weight and e^{−γ} − 1 of [`BestIsg`].
    type AtGamma: Copy + std::fmt::Debug;

    /// The shared part at γ ∈ [0.5, 10⁴], without input checks.
    fn at_gamma_unchecked(&self, gamma: f64) -> Self::AtGamma;

    /// The factors at the angle x ∈ [0, π] (rad) of the θ axis (`axis` 0: a₁, a₂) or
    /// of the φ axis (1: b₁, b₂), without input checks; rank-1 models return 0 as
    /// the second.
    fn factors_unchecked(&self, at: &Self::AtGamma, axis: usize, x: f64) -> [f64; 2];

    /// Ŝ from the θ axis's factors `a` and the φ axis's `b`.
    fn combine(a: [f64; 2], b: [f64; 2]) -> f64;
}

/// The logistic factors σ(g(θ − π/2)) (axis 0) and σ(h(φ − π/2)) (axis 1) of slopes
/// `(g, h)`.
#[inline]
fn logistic_factors((g, h): (f64, f64), axis: usize, x: f64) -> [f64; 2] {
    let slope = if axis == 0 { g } else { h };
    [sigmoid(slope * (x - FRAC_PI_2)), 0.0]
}

impl SeparableIsg for PaperIsg {
    type AtGamma = (f64, f64);
    #[inline]
    fn at_gamma_unchecked(&self, gamma: f64) -> (f64, f64) {
        (paper_poly(&PAPER_G, gamma), paper_poly(&PAPER_H, gamma))
    }
    #[inline]
    fn factors_unchecked(&self, at: &(f64, f64), axis: usize, x: f64) -> [f64; 2] {
        logistic_factors(*at, axis, x)
    }
    #[inline]
    fn combine(a: [f64; 2], b: [f64; 2]) -> f64 {
        a[0] * b[0]
    }
}

impl SeparableIsg for RefitIsg {
    type AtGamma = (f64, f64);
    #[inline]
    fn at_gamma_unchecked(&self, gamma: f64) -> (f64, f64) {
        self.slopes_unchecked(gamma)
    }
    #[inline]
    fn factors_unchecked(&self, at: &(f64, f64), axis: usize, x: f64) -> [f64; 2] {
        logistic_factors(*at, axis, x)
    }
    #[inline]
    fn combine(a: [f64; 2], b: [f64; 2]) -> f64 {
        a[0] * b[0]
    }
}

/// [`BestIsg`]'s part shared at one γ: the cell of ln γ and the weight in it, γ, and
/// e^{−γ} − 1 (the warp's denominator).
#[derive(Debug, Clone, Copy)]
pub struct BestAtGamma {
    cell: usize,
    weight: f64,
    gamma: f64,
    em: f64,
}

/// The direct bilinear path of [`IsgModel::s_hat`]: the same interpolation as
/// [`Table::interpolate`] (linear in ln γ and u, Endpoints nodes), with ln γ and
/// 1 − e^{−γ} shared by all factors (test `best_fast_path_matches_table_interpolation`).
impl SeparableIsg for BestIsg {
    type AtGamma = BestAtGamma;
    #[inline]
    fn at_gamma_unchecked(&self, gamma: f64) -> BestAtGamma {
        let n0 = self.n.0;
        let s0 = (gamma.ln() - GAMMA_MIN.ln()) / (GAMMA_MAX.ln() - GAMMA_MIN.ln()) * (n0 - 1) as f64;
        let s0 = s0.clamp(0.0, (n0 - 1) as f64);
        let cell = (s0 as usize).min(n0 - 2);
        BestAtGamma {
            cell,
            weight: s0 - cell as f64,
            gamma,
            em: (-gamma).exp_m1(),
        }
    }
    /// (marginal, correction) of axis k: channels k and k + 2.
    #[inline]
    fn factors_unchecked(&self, at: &BestAtGamma, k: usize, x: f64) -> [f64; 2] {
        let n1 = self.n.1;
        let v = self.table.values();
        let (i0, f0, gamma, em) = (at.cell, at.weight, at.gamma, at.em);
        let (mirrored, y) = if x > FRAC_PI_2 { (true, PI - x) } else { (false, x) };
        let h = (0.5 * (y - FRAC_PI_2)).sin();
        let u = ((-gamma * 2.0 * h * h).exp_m1() / em).sqrt().min(1.0);
        let s1 = u * (n1 - 1) as f64;
        let i1 = (s1 as usize).min(n1 - 2);
        let f1 = s1 - i1 as f64;
        let bilinear = |c: usize| {
            let at = |a: usize, b: usize| v[(a * n1 + b) * 4 + c] as f64;
            let lo = at(i0, i1) + f1 * (at(i0, i1 + 1) - at(i0, i1));
            let hi = at(i0 + 1, i1) + f1 * (at(i0 + 1, i1 + 1) - at(i0 + 1, i1));
            lo + f0 * (hi - lo)
        };
        let (m, c) = (bilinear(k), bilinear(k + 2));
        if mirrored {
            [1.0 - m, -c]
        } else {
            [m, c]
        }
    }
    #[inline]
    fn combine(a: [f64; 2], b: [f64; 2]) -> f64 {
        a[0] * b[0] + a[1] * b[1]
    }
}

/// How far from ⟂ the pole an SG axis may be in [`IsgModel::patch_world`] (|a·pole|).
pub const WORLD_AXIS_TOL: f64 = 1e-6;

/// A spherical Gaussian G(v) = μ exp(λ (a·v − 1)) (docs/math.md §1): unit axis `axis`,
/// sharpness λ > 0, amplitude μ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sg {
    /// Unit lobe axis.
    pub axis: DVec3,
    /// Sharpness λ (> 0).
    pub sharpness: f64,
    /// Amplitude μ (value at the axis).
    pub amplitude: f64,
}

impl Sg {
    /// A validated SG: `axis` of unit length (within 1e-3; normalised), sharpness
    /// λ ∈ (0, 1e6], finite amplitude.
    pub fn new(axis: impl Into<DVec3>, sharpness: f64, amplitude: f64) -> Result<Sg, LookupError> {
        let n = unit_axis(axis.into())?;
        let sharpness = in_range("sharpness", sharpness, f64::MIN_POSITIVE, 1e6)?;
        let amplitude = finite("amplitude", amplitude)?;
        Ok(Sg {
            axis: n,
            sharpness,
            amplitude,
        })
    }

    /// G(v) for a unit direction v.
    pub fn eval(&self, v: impl Into<DVec3>) -> f64 {
        self.amplitude * (self.sharpness * (self.axis.dot(v.into()) - 1.0)).exp()
    }

    /// The product of two SGs, itself an SG: λ_m = ‖λ1 a1 + λ2 a2‖,
    /// a_m = (λ1 a1 + λ2 a2)/λ_m, μ_m = μ1 μ2 exp(λ_m − λ1 − λ2). When the lobes are
    /// exactly opposite with equal sharpness (λ_m = 0) the product is the constant
    /// μ1 μ2 e^{−2λ}; it is returned with axis `self.axis` and sharpness 0. Errors
    /// with [`LookupError::Overflow`] when μ_m overflows (|μ1 μ2| beyond f64).
    pub fn product(&self, other: &Sg) -> Result<Sg, LookupError> {
        let m = self.sharpness * self.axis + other.sharpness * other.axis;
        let lm = m.length();
        let axis = if lm > 0.0 { m / lm } else { self.axis };
        // exp(λ_m − λ1 − λ2) ≤ 1, so only μ1 μ2 can overflow.
        let amplitude = finite_result(
            "SG product amplitude",
            self.amplitude * other.amplitude * (lm - self.sharpness - other.sharpness).exp(),
        )?;
        Ok(Sg {
            axis,
            sharpness: lm,
            amplitude,
        })
    }

    /// ∫_{S²} G dω = μ 2π/λ (1 − e^{−2λ}) sr (4πμ in the limit λ → 0).
    pub fn integral(&self) -> f64 {
        self.amplitude * sphere_factor(self.sharpness, 2.0)
    }

    /// Integral over the hemisphere centred on the axis: μ 2π/λ (1 − e^{−λ}) sr.
    pub fn hemisphere_integral(&self) -> f64 {
        self.amplitude * sphere_factor(self.sharpness, 1.0)
    }
}

/// A finite axis of unit length within 1e-3, normalised.
pub(crate) fn unit_axis(a: DVec3) -> Result<DVec3, LookupError> {
    for x in a.to_array() {
        finite("axis", x)?;
    }
    let len = a.length();
    in_range("|axis|", len, 1.0 - 1e-3, 1.0 + 1e-3)?;
    Ok(a / len)
}

/// 2π (1 − e^{−kλ})/λ, with its limit 2πk at λ = 0.
fn sphere_factor(lambda: f64, k: f64) -> f64 {
    if lambda == 0.0 {
        2.0 * PI * k
    } else {
        2.0 * PI * -(-k * lambda).exp_m1() / lambda
    }
}

/// [`Sg`] with an f32 interface: f32 in and out, computed in f64 and rounded once
/// (the crate's convention for `_f32` twins; see the crate docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sg32 {
    /// Unit lobe axis.
    pub axis: Vec3,
    /// Sharpness λ (> 0).
    pub sharpness: f32,
    /// Amplitude μ.
    pub amplitude: f32,
}

impl Sg32 {
    fn wide(&self) -> Sg {
        Sg {
            axis: self.axis.as_dvec3(),
            sharpness: self.sharpness as f64,
            amplitude: self.amplitude as f64,
        }
    }
    /// The f64 SG rounded to f32 (errors where a value overflows f32).
    pub fn from_sg(s: &Sg) -> Result<Sg32, LookupError> {
        Ok(Sg32 {
            axis: s.axis.as_vec3(),
            sharpness: narrow("SG sharpness", s.sharpness)?,
            amplitude: narrow("SG amplitude", s.amplitude)?,
        })
    }
    /// [`Sg::eval`].
    pub fn eval(&self, v: impl Into<Vec3>) -> f32 {
        self.wide().eval(v.into().as_dvec3()) as f32
    }
    /// [`Sg::product`]; also errors where the product's amplitude overflows f32.
    pub fn product(&self, other: &Sg32) -> Result<Sg32, LookupError> {
        Self::from_sg(&self.wide().product(&other.wide())?)
    }
    /// [`Sg::integral`].
    pub fn integral(&self) -> f32 {
        self.wide().integral() as f32
    }
    /// [`Sg::hemisphere_integral`].
    pub fn hemisphere_integral(&self) -> f32 {
        self.wide().hemisphere_integral() as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warp_round_trips_and_ends() {
        for &g in &[0.5, 3.0, 100.0, 1e4] {
            assert!((warp(0.0, g) - 1.0).abs() < 1e-15);
            assert_eq!(warp(FRAC_PI_2, g), 0.0);
            for i in 0..=50 {
                let x = FRAC_PI_2 * i as f64 / 50.0;
                let u = warp(x, g);
                if u > 1.0 - 1e-6 {
                    // Saturated (x → 0, or the SG below ~e^{-13} of its peak): u does not
                    // resolve x there, and need not.
                    continue;
                }
                let back = unwarp(u, g);
                assert!((back - x).abs() < 1e-7, "{g} {x} -> {back}");
            }
        }
    }

    #[test]
    fn sg_product_and_integrals() {
        let a = Sg {
            axis: DVec3::Z,
            sharpness: 3.0,
            amplitude: 2.0,
        };
        let s = 0.6f64;
        let b = Sg {
            axis: DVec3::new(s.sin(), 0.0, s.cos()),
            sharpness: 5.0,
            amplitude: 0.5,
        };
        let p = a.product(&b).unwrap();
        for v in [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -1.0, 0.0], [-0.48, 0.6, 0.64]] {
            assert!((p.eval(v) - a.eval(v) * b.eval(v)).abs() < 1e-14, "{v:?}");
        }
        // ∫ over the sphere of exp(λ(cosθ − 1)) = 2π ∫_{-1}^{1} e^{λ(t−1)} dt.
        assert!((a.integral() - 2.0 * 2.0 * PI * (1.0 - (-6.0f64).exp()) / 3.0).abs() < 1e-13);
        assert!((a.hemisphere_integral() - 2.0 * 2.0 * PI * (1.0 - (-3.0f64).exp()) / 3.0).abs() < 1e-13);
        let z = Sg {
            axis: DVec3::X,
            sharpness: 0.0,
            amplitude: 1.0,
        };
        assert!((z.integral() - 4.0 * PI).abs() < 1e-15);
        // μ1 μ2 beyond f64 is an error, not an infinite amplitude.
        let big = Sg::new(DVec3::Z, 1.0, 1e200).unwrap();
        assert!(matches!(big.product(&big), Err(LookupError::Overflow { .. })));
        let big32 = Sg32::from_sg(&Sg::new(DVec3::Z, 1.0, 1e30).unwrap()).unwrap();
        assert!(matches!(big32.product(&big32), Err(LookupError::Overflow { .. })));
    }

    #[test]
    fn paper_polynomials_as_printed() {
        // g(1) = g4 + g3 + g2 + g1 + g0 at γ = 100 (docs/math.md, erratum E3: g(γ=1) ≈ 17.6).
        let sum: f64 = PAPER_G.iter().sum();
        assert!((paper_poly(&PAPER_G, 100.0) - sum).abs() < 1e-12);
        assert!((paper_poly(&PAPER_G, 1.0) - 17.6).abs() < 0.05);
        assert_eq!(sigmoid(0.0), 0.5);
        assert!(sigmoid(-800.0) == 0.0 && sigmoid(800.0) == 1.0);
    }

    #[test]
    fn paper_model_rejects_bad_input() {
        let m = PaperIsg;
        assert!(matches!(
            m.s_hat(f64::NAN, 1.0, 10.0),
            Err(LookupError::NotFinite { .. })
        ));
        assert!(matches!(m.s_hat(1.0, 4.0, 10.0), Err(LookupError::OutOfDomain { .. })));
        assert!(matches!(m.s_hat(1.0, 1.0, 0.1), Err(LookupError::OutOfDomain { .. })));
        assert!(matches!(
            m.limiting_angle(10.0, 0.7),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            m.limiting_angle(10.0, f64::INFINITY),
            Err(LookupError::NotFinite { .. })
        ));
        // Γ: σ(−gΓ) = ε.
        let gam = m.limiting_angle(300.0, 0.01).unwrap();
        assert!((sigmoid(-paper_poly(&PAPER_G, 300.0).min(paper_poly(&PAPER_H, 300.0)) * gam) - 0.01).abs() < 1e-12);
    }
}
