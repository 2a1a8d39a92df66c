//! the cosine-lobe integral I(e) = ∫_{S²} max(a·v, 0)^e dω = 2π/(e+1) (sr).
//!
//! Meunier et al. (2009, §4.2) tabulate I(e) and interpolate it; erratum E7
//! notes the closed form makes the table unnecessary. Both are offered: the table
//! (what users of the paper expect) and [`exact`].
//!
//! Layout: one axis `e` on [0, 1e5] with nodes uniform in ln(1 + e) (641 nodes,
//! the paper's 5 × 128 budget), one channel stored as ln I. Since ln I = ln 2π −
//! ln(1 + e) is linear in that coordinate, interpolation adds no error beyond the
//! f32 rounding of the stored values; the paper's decade-linear layout with linear
//! interpolation is off by up to 1.2e-3 relative (measured in the `lobefit` tests).

use std::f64::consts::PI;

use crate::error::{first_failure, in_range, narrow, same_length, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::table::Table;

/// Table kind.
pub const KIND: &str = "lobe-integral";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Largest tabulated exponent.
pub const E_MAX: f64 = 1.0e5;

/// Name of the one stored channel (ln I, [`Encoding::Log`]).
pub const CHANNEL: &str = "integral";

/// Plausible range of each stored channel (name, lo, hi), on the stored value ln I
/// (ln sr): I = 2π/(e + 1) runs from 2π (ln 1.838) at e = 0 down to ln 2π − ln(10⁵ + 1)
/// = −9.675 at e = 10⁵; the range adds a margin of about 0.3 on each side.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[(CHANNEL, -10.0, 2.0)];

/// The axis this runtime interprets: `e` on [0, 1e5], nodes uniform in ln(1 + e).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axis(count: u32) -> Axis {
    Axis {
        name: "e".into(),
        unit: "1".into(),
        lo: 0.0,
        hi: E_MAX,
        mapping: Mapping::Log1p { scale: 1.0 },
        count,
        placement: Placement::Endpoints,
    }
}

/// Exact lobe integral 2π/(e + 1) in steradians, for any finite e ≥ 0.
pub fn exact(e: f64) -> Result<f64, LookupError> {
    let e = in_range("e", e, 0.0, f64::MAX)?;
    Ok(2.0 * PI / (e + 1.0))
}

/// The lobe-integral table.
#[derive(Debug, Clone)]
pub struct LobeIntegral {
    table: Table,
}

crate::table_type::impl_table_type!(LobeIntegral: KIND, VERSION);

impl LobeIntegral {
    /// Wraps an already loaded table, checking its kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        table.expect_layout_1d(
            &axis(table.meta().axes.first().map_or(0, |a| a.count)),
            &[(CHANNEL, Encoding::Log)],
        )?;
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        Ok(Self { table })
    }

    /// I(e) in steradians from the table, e ∈ [0, 1e5].
    pub fn integral(&self, e: f64) -> Result<f64, LookupError> {
        let mut out = [0.0];
        self.table.interpolate(&[e], &mut out)?;
        Ok(out[0])
    }

    /// [`LobeIntegral::integral`] with an f32 interface (computed in f64, rounded once).
    pub fn integral_f32(&self, e: f32) -> Result<f32, LookupError> {
        narrow("I", self.integral(e as f64)?)
    }

    /// Batch [`LobeIntegral::integral`]: `out[i]` = I(`es[i]`) in sr, each e in [0, 10⁵],
    /// bit for bit the one-at-a-time value; the slice is validated first, then
    /// computed in a plain loop. Errors: [`LookupError::BatchLength`] when the slices
    /// differ in length, [`LookupError::BatchItem`] for the first NaN, infinite or
    /// out-of-domain e.
    pub fn integrals(&self, es: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
        same_length(es.len(), out.len())?;
        let ok = es.iter().fold(true, |ok, &e| ok & (0.0..=E_MAX).contains(&e));
        if !ok {
            first_failure(es, |&e| self.integral(e))?;
        }
        for (o, &e) in out.iter_mut().zip(es) {
            let mut i = [0.0];
            self.table.interpolate_valid(&[e], &mut i);
            *o = i[0];
        }
        Ok(())
    }

    /// [`LobeIntegral::integrals`] in single precision (f64 inside, rounded once), bit
    /// for bit [`LobeIntegral::integral_f32`].
    pub fn integrals_f32(&self, es: &[f32], out: &mut [f32]) -> Result<(), LookupError> {
        same_length(es.len(), out.len())?;
        let ok = es.iter().fold(true, |ok, &e| ok & (0.0..=E_MAX).contains(&(e as f64)));
        if !ok {
            first_failure(es, |&e| self.integral_f32(e))?;
        }
        for (o, &e) in out.iter_mut().zip(es) {
            let mut i = [0.0];
            self.table.interpolate_valid(&[e as f64], &mut i);
            *o = i[0] as f32;
        }
        Ok(())
    }
}
