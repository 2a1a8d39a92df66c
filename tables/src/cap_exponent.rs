//! the spherical-cap exponent (Meunier et al. 2009, §5.2).
//!
//! For a cap of half-angle α around axis a, e_cap(α) minimises
//! ∫_{S²} (f_cap − max(a·v, 0)^e)² dω. With c = cos α ≥ 0 the objective is
//! 2π[(1 − c) − 2(1 − c^{e+1})/(e+1) + 1/(2e+1)]; for α ≥ π/2 the minimiser is e = 0.
//!
//! Why the odd layout: e_cap ≈ 1.9226/α² as α → 0 and e_cap ≈ c(1 − ln c)/2 as
//! α → π/2, so neither e nor α is good to interpolate. The table stores the smooth,
//! bounded ratio q(α) = e_cap / m(α) with m(α) = c(1 − ln c)/(1 − c) (q is 0.9613 at
//! small α, dips to 0.472 near α ≈ 1.54 and tends to 1/2 at π/2), on nodes uniform in
//! u = ln(α/(π/2 − α)), which
//! are dense at both ends. Renderers evaluate e = q(α)·m(α) (`model`).

use std::f64::consts::{FRAC_PI_2, PI};

use crate::error::{first_failure, in_range, narrow, same_length, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::table::Table;

/// Table kind.
pub const KIND: &str = "cap-exponent";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Smallest supported cap half-angle (rad).
pub const ALPHA_MIN: f64 = 1.0e-3;
/// Largest tabulated half-angle (rad); between it and π/2 q is held at its end value
/// (0.4999945, 1.1e-5 from its limit 1/2), and from π/2 on e_cap = 0.
pub const ALPHA_TABLE_MAX: f64 = FRAC_PI_2 - 1.0e-7;

/// Name of the one stored channel (q, [`Encoding::Linear`]).
pub const CHANNEL: &str = "q";

/// Plausible range of each stored channel (name, lo, hi), dimensionless: the true
/// q(α) lies in [0.4718, 0.9613] (0.9613 as α → 0, minimum near α ≈ 1.54, 1/2 at
/// π/2); the range is the fit's search bracket [0.25, 1.25], so a fitted file can never
/// leave it and a value outside it is corrupt.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[(CHANNEL, 0.25, 1.25)];

/// The axis this runtime interprets: `alpha` on [1e-3, π/2 − 1e-7], nodes uniform in
/// ln(α/(π/2 − α)).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axis(count: u32) -> Axis {
    Axis {
        name: "alpha".into(),
        unit: "rad".into(),
        lo: ALPHA_MIN,
        hi: ALPHA_TABLE_MAX,
        mapping: Mapping::Logit { a: 0.0, b: FRAC_PI_2 },
        count,
        placement: Placement::Endpoints,
    }
}

/// The scale model m(α) = c(1 − ln c)/(1 − c), c = cos α, for α ∈ (0, π/2); e_cap = q·m.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn model(alpha: f64) -> f64 {
    let s = (0.5 * alpha).sin();
    let one_minus_c = 2.0 * s * s; // accurate for small α, unlike 1 − cos α
    let c = alpha.cos();
    c * (1.0 - c.ln()) / one_minus_c
}

/// The cap-exponent table.
#[derive(Debug, Clone)]
pub struct CapExponent {
    table: Table,
}

crate::table_type::impl_table_type!(CapExponent: KIND, VERSION);

impl CapExponent {
    /// Wraps an already loaded table, checking its kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        table.expect_layout_1d(
            &axis(table.meta().axes.first().map_or(0, |a| a.count)),
            &[(CHANNEL, Encoding::Linear)],
        )?;
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        Ok(Self { table })
    }

    /// The stored ratio q(α) = e_cap/m(α) for α ∈ [1e-3, π/2] (rad).
    pub fn ratio(&self, alpha: f64) -> Result<f64, LookupError> {
        let alpha = in_range("alpha", alpha, ALPHA_MIN, FRAC_PI_2)?;
        self.table_ratio(alpha)
    }

    /// q at an α already checked to lie in [1e-3, π/2]; past the last node q is held.
    fn table_ratio(&self, alpha: f64) -> Result<f64, LookupError> {
        let mut out = [0.0];
        self.table.interpolate(&[alpha.min(ALPHA_TABLE_MAX)], &mut out)?;
        Ok(out[0])
    }

    /// Best-fitting lobe exponent e_cap(α) (dimensionless) for a cap of half-angle
    /// α ∈ [1e-3, π] rad; 0 for α ≥ π/2.
    pub fn e_cap(&self, alpha: f64) -> Result<f64, LookupError> {
        let alpha = in_range("alpha", alpha, ALPHA_MIN, PI)?;
        if alpha >= FRAC_PI_2 {
            return Ok(0.0);
        }
        Ok(self.table_ratio(alpha)? * model(alpha))
    }

    /// [`CapExponent::e_cap`] with an f32 interface (computed in f64, rounded once).
    pub fn e_cap_f32(&self, alpha: f32) -> Result<f32, LookupError> {
        narrow("e_cap", self.e_cap(alpha as f64)?)
    }

    /// [`CapExponent::e_cap`] without input checks, for α already in [1e-3, π]: the
    /// same arithmetic, so the same bits.
    #[inline]
    fn e_cap_valid(&self, alpha: f64) -> f64 {
        if alpha >= FRAC_PI_2 {
            return 0.0;
        }
        let mut q = [0.0];
        self.table.interpolate_valid(&[alpha.min(ALPHA_TABLE_MAX)], &mut q);
        q[0] * model(alpha)
    }

    /// Batch [`CapExponent::e_cap`]: `out[i]` = e_cap(`alphas[i]`) (dimensionless; α in
    /// rad, each in [1e-3, π]), bit for bit the one-at-a-time value. The whole slice
    /// is validated first, then computed in a plain loop with no per-item `Result`.
    /// Errors: [`LookupError::BatchLength`] when the slices differ in length,
    /// [`LookupError::BatchItem`] (index and the one-at-a-time error) for the first
    /// NaN, infinite or out-of-domain α.
    pub fn e_caps(&self, alphas: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
        same_length(alphas.len(), out.len())?;
        // A branch-free fold over the slice; the slow search runs only on failure.
        let ok = alphas.iter().fold(true, |ok, &a| ok & (ALPHA_MIN..=PI).contains(&a));
        if !ok {
            first_failure(alphas, |&a| self.e_cap(a))?;
        }
        for (o, &a) in out.iter_mut().zip(alphas) {
            *o = self.e_cap_valid(a);
        }
        Ok(())
    }

    /// [`CapExponent::e_caps`] in single precision: each value computed in f64 and
    /// rounded once, bit for bit [`CapExponent::e_cap_f32`].
    pub fn e_caps_f32(&self, alphas: &[f32], out: &mut [f32]) -> Result<(), LookupError> {
        same_length(alphas.len(), out.len())?;
        let ok = alphas
            .iter()
            .fold(true, |ok, &a| ok & (ALPHA_MIN..=PI).contains(&(a as f64)));
        if !ok {
            first_failure(alphas, |&a| self.e_cap_f32(a))?;
        }
        for (o, &a) in out.iter_mut().zip(alphas) {
            *o = self.e_cap_valid(a as f64) as f32;
        }
        // e_cap ≤ 2·10⁶ on the domain, so this never fires; it keeps "no Ok(inf)" a check.
        if !out.iter().all(|v| v.is_finite()) {
            first_failure(alphas, |&a| self.e_cap_f32(a))?;
        }
        Ok(())
    }
}
