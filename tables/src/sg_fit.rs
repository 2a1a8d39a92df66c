//! one spherical Gaussian fitted to a clamped cosine lobe (docs/math.md, sg-fit).
//!
//! For e ≥ 0, (λ(e), μ(e)) minimise ∫_{S²} (Ψ(v; a, e) − μ exp(λ(a·v − 1)))² dω with
//! Ψ(v; a, e) = max(a·v, 0)^e (e = 0: the indicator of the open hemisphere a·v > 0).
//! A lobe s·Ψ(·; a, e) is then approximated by the SG G(·; a, λ(e), s·μ(e)) (docs/math.md §1).
//! At e = 1, λ = 2.1438 and μ = 1.1766 (the L2 optimum, docs/isg.md); λ/e → 1 and μ → 1 as e → ∞.
//!
//! Layout: ln λ and ln μ on nodes uniform in ln(1 + e), e ∈ [0, 10^5]; both are smooth
//! in that coordinate (λ ~ e for large e), so linear interpolation of the logs is
//! accurate to a few 1e-6 (measured by `lobefit check`).

use crate::error::{in_range, narrow, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::isg::{Sg, Sg32};
use crate::table::Table;

/// Table kind.
pub const KIND: &str = "sg-fit";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Largest lobe exponent covered.
pub const E_MAX: f64 = 1.0e5;
/// Channels: λ and μ, both log-encoded.
pub const CHANNELS: [&str; 2] = ["lambda", "mu"];

/// Plausible range of each stored channel (name, lo, hi), on the stored logs:
/// ln λ: λ(0) ≈ 1.19 and λ/e → 1 as e → ∞, so λ ∈ [1, 1.1·10⁵] over e ∈ [0, 10⁵]
/// (ln λ ∈ [0.17, 11.51]); range [−1, 13] (λ up to 4.4·10⁵, inside the 10⁶ that
/// [`Sg::new`] accepts). ln μ: μ falls from 1.40 at e = 0 to 1 as e → ∞
/// (ln μ ∈ [0, 0.34]); range [−0.5, 1].
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[(CHANNELS[0], -1.0, 13.0), (CHANNELS[1], -0.5, 1.0)];

/// The axis this runtime interprets: `e` on [0, 10^5], nodes uniform in ln(1 + e).
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

/// The lobe → SG table.
#[derive(Debug, Clone)]
pub struct SgFit {
    table: Table,
}

crate::table_type::impl_table_type!(SgFit: KIND, VERSION);

impl SgFit {
    /// Wraps a loaded table, checking kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        table.expect_layout_1d(
            &axis(table.meta().axes.first().map_or(0, |a| a.count)),
            &[(CHANNELS[0], Encoding::Log), (CHANNELS[1], Encoding::Log)],
        )?;
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        Ok(Self { table })
    }

    /// (λ(e), μ(e)) for a lobe exponent e ∈ [0, 10^5]: sharpness and amplitude of the
    /// L2-best SG for the unit-scale lobe.
    pub fn fit(&self, e: f64) -> Result<(f64, f64), LookupError> {
        let e = in_range("e", e, 0.0, E_MAX)?;
        let mut out = [0.0; 2];
        self.table.interpolate(&[e], &mut out)?;
        Ok((out[0], out[1]))
    }

    /// [`SgFit::fit`] with an f32 interface (computed in f64, rounded once).
    pub fn fit_f32(&self, e: f32) -> Result<(f32, f32), LookupError> {
        let (l, m) = self.fit(e as f64)?;
        Ok((narrow("lambda", l)?, narrow("mu", m)?))
    }

    /// The SG approximating the lobe s·max(a·v, 0)^e: axis a (unit within 1e-3), λ(e),
    /// s·μ(e) (s finite).
    pub fn lobe_to_sg(&self, axis: impl Into<glam::DVec3>, e: f64, scale: f64) -> Result<Sg, LookupError> {
        let (lambda, mu) = self.fit(e)?;
        let scale = crate::error::finite("scale", scale)?;
        let amplitude = crate::error::finite_result("SG amplitude s·mu", scale * mu)?;
        Sg::new(axis, lambda, amplitude)
    }

    /// [`SgFit::lobe_to_sg`] with an f32 interface (computed in f64, rounded once).
    pub fn lobe_to_sg_f32(&self, axis: impl Into<glam::Vec3>, e: f32, scale: f32) -> Result<Sg32, LookupError> {
        Sg32::from_sg(&self.lobe_to_sg(axis.into().as_dvec3(), e as f64, scale as f64)?)
    }
}
