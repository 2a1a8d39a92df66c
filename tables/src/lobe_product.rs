//! the product of two cosine lobes as one lobe (Meunier et al. 2009, §4.1), and
//! the lobe-sum algebra built on it (§4.3, §5.4).
//!
//! Ψ(v; a1, e1)·Ψ(v; a2, e2) ≈ p_r·Ψ(v; a_r, e_r), with Ψ(v; a, e) = max(a·v, 0)^e,
//! e1, e2 ∈ [0, 10⁵], α = angle(a1, a2) ∈ [0, π]. The axis a_r lies on the arc from a1
//! to a2 at the fraction t = β/α.
//!
//! # Why the tables store what they store
//!
//! Put a1, a2 in the xz-plane and write v = (cos u sin s, sin u, cos u cos s): then
//! a·v = cos u · cos(s − s_a) for any in-plane axis, dω = cos u du ds, and every product
//! of lobes with in-plane axes separates,
//! ∫Π Ψ_k = W(E)·∫ Π max(cos(s − s_k), 0)^{e_k} ds, E = Σ e_k,
//! W(E) = ∫cos^{E+1}u du = √π Γ(E/2 + 1)/Γ(E/2 + 3/2) (`ln_w`).
//! The in-plane factor peaks where e1 tan β = e2 tan(α − β), which has the closed form
//! β = (α + asin((e2 − e1)/(e1 + e2)·sin α))/2 (`peak_angle`): that is the paper's
//! axis (its Nelder–Mead step) and the axis of both tables, computed exactly at run
//! time. The integral ∫Ψ1Ψ2 spans hundreds of orders of magnitude (it vanishes like
//! exp(−e1e2 α²/(2(e1+e2))) for sharp lobes and like (π − α)^{E+1} at α → π), so the
//! tables store it relative to the closed-form model
//! M = W(E)·P*·(G/2π + 1/(π − α)²)^{−1/2}, P* = cos^{e1}β′ cos^{e2}(α − β′), β′ the peak
//! for exponents e1 + 1, e2 + 1 (never pinned to a hemisphere's edge) (`ln_model`):
//! c = ln(∫Ψ1Ψ2 / M) is smooth and O(1) wherever products matter (it reaches −10 only
//! where they are negligible), and finite up to α = π, where
//! both vanish like (π − α)^{E+1}; G is the in-plane curvature of the log-product
//! (`exponent_model`). The exponent is stored as ln((1 + e_r)/(1 + e_m)) with the
//! model e_m = √(E·G): zero at α = 0, where e_r = e1 + e2 exactly, and O(α⁴) for
//! sharp lobes, so the sphere's curvature (e_r ≈ E(1 + α²/8) for equal lobes) is not
//! left to linear interpolation.
//!
//! Two variants (docs/math.md, lobe-product), one table each:
//! - `energy` ([`KIND_ENERGY`], the default): p_r makes ∫p_rΨ_r = ∫Ψ1Ψ2 exactly,
//!   p_r = (e_r + 1)/(2π)·∫Ψ1Ψ2; e_r minimises the L2 residual under that constraint.
//! - `l2` ([`KIND_L2`]): the paper's unconstrained L2 fit; a third channel stores
//!   k = ln(∫p_rΨ_r / ∫Ψ1Ψ2).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::{DVec3, Vec3};

use crate::error::{finite, finite_result, first_failure, in_range, narrow, same_length, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::table::Table;

/// Table kind of the `energy` variant (integral-conserving; the default).
pub const KIND_ENERGY: &str = "lobe-product";
/// Table kind of the `l2` variant (the paper's objective).
pub const KIND_L2: &str = "lobe-product-l2";
/// Family version this runtime reads (both variants).
pub const VERSION: u32 = 1;
/// Largest supported exponent.
pub const E_MAX: f64 = 1.0e5;
/// Channel: c = ln(∫Ψ1Ψ2 / M).
pub const CHANNEL_C: &str = "ln_integral_over_model";
/// Channel: ln((1 + e_r)/(1 + e_m)), e_m = `exponent_model`.
pub const CHANNEL_E: &str = "ln_exponent_ratio";
/// Channel (l2 only): ln(∫p_rΨ_r / ∫Ψ1Ψ2).
pub const CHANNEL_K: &str = "ln_integral_ratio";

/// Plausible range of each stored channel (name, lo, hi), dimensionless (all are
/// logs of ratios), for both variants:
/// - c = ln(∫Ψ1Ψ2 / M): O(0.1) wherever products matter, down to −10.5 in the corner
///   where they are negligible (α → π with wide lobes); range [−30, 5], so
///   ∫Ψ1Ψ2 = M·e^c stays below e^5 times the model, itself at most 2π.
/// - q = ln((1 + e_r)/(1 + e_m)): the fit searches e_r ∈ [0, 64E + 1000] (E = e1 + e2),
///   and e_m = √(E·G) lies in [E, √2·E] (G ∈ [E, 2E]), so q ∈ [−ln(1 + √2·2·10⁵),
///   ln 1001] = [−12.55, 6.91]; range [−13, 7].
/// - k = ln(∫p_rΨ_r / ∫Ψ1Ψ2) (l2 only): the L2 fit trades integral for shape,
///   measured −2.54 to 0.019; range [−10, 2].
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[
    (CHANNEL_C, -30.0, 5.0),
    (CHANNEL_E, -13.0, 7.0),
    (CHANNEL_K, -10.0, 2.0),
];

/// Product variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// Integral-conserving fit (default).
    Energy,
    /// The paper's unconstrained L2 fit.
    L2,
}

impl Variant {
    /// Table kind of the variant.
    pub fn kind(self) -> &'static str {
        match self {
            Variant::Energy => KIND_ENERGY,
            Variant::L2 => KIND_L2,
        }
    }

    /// Channels (name, encoding) of the variant's table, in storage order.
    pub fn channels(self) -> &'static [(&'static str, Encoding)] {
        match self {
            Variant::Energy => &[(CHANNEL_C, Encoding::Linear), (CHANNEL_E, Encoding::Linear)],
            Variant::L2 => &[
                (CHANNEL_C, Encoding::Linear),
                (CHANNEL_E, Encoding::Linear),
                (CHANNEL_K, Encoding::Linear),
            ],
        }
    }
}

/// Scale of the exponent axes, u = ln(1 + e/E_SCALE): below ~1 the product changes
/// fast with e (an exponent-0 lobe is a hemisphere with a hard edge), so the nodes
/// are dense there.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const E_SCALE: f64 = 0.1;

/// Resolution of the α axis at π/2 (rad): where a sharp lobe crosses the horizon of a
/// wide one the product changes over ~1/√e ≥ 3e-3 rad.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const ALPHA_WIDTH: f64 = 2e-3;

/// The three axes, slowest first: `e1`, `e2` (nodes uniform in ln(1 + e)) and `alpha`
/// (nodes uniform in asinh((α − π/2)/[`ALPHA_WIDTH`]): dense at π/2, where a sharp
/// lobe crosses a wide lobe's horizon, and spaced ∝ distance from it elsewhere).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axes(n_e: u32, n_alpha: u32) -> [Axis; 3] {
    let e = |name: &str| Axis {
        name: name.into(),
        unit: "1".into(),
        lo: 0.0,
        hi: E_MAX,
        mapping: Mapping::Log1p { scale: E_SCALE },
        count: n_e,
        placement: Placement::Endpoints,
    };
    [
        e("e1"),
        e("e2"),
        Axis {
            name: "alpha".into(),
            unit: "rad".into(),
            lo: 0.0,
            hi: PI,
            mapping: Mapping::Asinh {
                centre: FRAC_PI_2,
                width: ALPHA_WIDTH,
            },
            count: n_alpha,
            placement: Placement::Endpoints,
        },
    ]
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9; relative error ~1e-15).
pub(crate) fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection keeps the series in its accurate range.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (TAU).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// ln W(E), W(E) = ∫_{−π/2}^{π/2} cos^{E+1}u du = √π Γ(E/2 + 1)/Γ(E/2 + 3/2): the
/// out-of-plane factor of any product of lobes whose axes share a plane (E ≥ 0).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn ln_w(e: f64) -> f64 {
    0.5 * PI.ln() + ln_gamma(0.5 * e + 1.0) - ln_gamma(0.5 * e + 1.5)
}

/// Angle β (rad) from a1 to the maximum of Ψ(·; a1, e1)Ψ(·; a2, e2) on the arc to a2:
/// the root of e1 tan β = e2 tan(α − β), i.e. sin(2β − α) = (e2 − e1)/(e1 + e2)·sin α.
/// At α = 0 returns 0; for e1 = e2 = 0 (a lune) the lune's centre α/2.
#[cfg(feature = "writer")]
pub fn peak_angle(e1: f64, e2: f64, alpha: f64) -> f64 {
    peak_angle_with(e1, e2, alpha, alpha.sin())
}

/// [`peak_angle`] given sin α (shared by the lookups' several closed-form terms).
#[inline]
fn peak_angle_with(e1: f64, e2: f64, alpha: f64, sin_alpha: f64) -> f64 {
    let sum = e1 + e2;
    let c = if sum > 0.0 { (e2 - e1) / sum } else { 0.0 };
    // Rounding can push the root an ulp outside the arc (e1 or e2 = 0).
    (0.5 * (alpha + (c * sin_alpha).clamp(-1.0, 1.0).asin())).clamp(0.0, alpha)
}

/// The fraction t = β/α of the arc from a1 at which the product peaks; at α = 0 its
/// limit e2/(e1 + e2) (1/2 when both are 0).
#[cfg(feature = "writer")]
pub fn peak_fraction(e1: f64, e2: f64, alpha: f64) -> f64 {
    peak_fraction_with(e1, e2, alpha, alpha.sin())
}

/// [`peak_fraction`] given sin α.
#[inline]
fn peak_fraction_with(e1: f64, e2: f64, alpha: f64, sin_alpha: f64) -> f64 {
    if alpha > 0.0 {
        (peak_angle_with(e1, e2, alpha, sin_alpha) / alpha).clamp(0.0, 1.0)
    } else if e1 + e2 > 0.0 {
        e2 / (e1 + e2)
    } else {
        0.5
    }
}

/// ln max(c, 0)^e for a lobe with exponent e at cosine c, with the lobe convention
/// 0·ln 0 = 0 (an exponent-0 lobe is the open hemisphere's indicator); −∞ outside.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn lobe_ln(e: f64, c: f64) -> f64 {
    if e == 0.0 {
        0.0
    } else {
        e * c.max(0.0).ln()
    }
}

/// ln M(e1, e2, α), the closed-form model of ∫Ψ1Ψ2 (see the module docs);
/// −∞ at α = π.
#[cfg(feature = "writer")]
pub fn ln_model(e1: f64, e2: f64, alpha: f64) -> f64 {
    ln_model_with(e1, e2, alpha, &Trig::new(alpha))
}

/// sin α and the chord 2 sin(α/2): each closed-form term of a lookup needs one of
/// them, computed once per lookup instead of once per term (same values, same bits).
struct Trig {
    sin_alpha: f64,
    chord: f64,
}

impl Trig {
    #[inline]
    fn new(alpha: f64) -> Trig {
        Trig {
            sin_alpha: alpha.sin(),
            chord: 2.0 * (0.5 * alpha).sin(),
        }
    }
}

/// [`ln_model`] given the shared trigonometry.
#[inline]
fn ln_model_with(e1: f64, e2: f64, alpha: f64, trig: &Trig) -> f64 {
    // The peak of the product with both exponents raised by 1: never pinned to a
    // hemisphere's edge, so the model stays smooth (no e·ln e) as an exponent → 0,
    // and still the true peak for sharp lobes.
    let beta = peak_angle_with(e1 + 1.0, e2 + 1.0, alpha, trig.sin_alpha);
    let lune = PI - alpha;
    let ln_peak = lobe_ln(e1, beta.cos().max(0.0)) + lobe_ln(e2, (alpha - beta).cos().max(0.0));
    ln_w(e1 + e2) + ln_peak - 0.5 * (curvature(e1, e2, trig.chord) / TAU + 1.0 / (lune * lune)).ln()
}

/// In-plane curvature of the log-product at its peak, G = E + 4κ sin²(α/2) with
/// κ = e1e2/(e1 + e2): the Gaussian limit E + κα², with the chord in place of α so it
/// stays bounded up to α = π.
/// `chord` = 2 sin(α/2).
#[inline]
fn curvature(e1: f64, e2: f64, chord: f64) -> f64 {
    let sum = e1 + e2;
    if sum == 0.0 {
        return 0.0;
    }
    sum + e1 * e2 / sum * chord * chord
}

/// Model exponent e_m = √(E·G): the geometric mean of the product's out-of-plane (E)
/// and in-plane (G) curvatures; e_r = e1 + e2 at α = 0, and e_r ≈ e_m(1 + O(α⁴)) for
/// two sharp lobes. The table stores ln((1 + e_r)/(1 + e_m)).
#[cfg(feature = "writer")]
pub fn exponent_model(e1: f64, e2: f64, alpha: f64) -> f64 {
    exponent_model_with(e1, e2, &Trig::new(alpha))
}

/// [`exponent_model`] given the shared trigonometry.
#[inline]
fn exponent_model_with(e1: f64, e2: f64, trig: &Trig) -> f64 {
    ((e1 + e2) * curvature(e1, e2, trig.chord)).sqrt()
}

/// ∫ max(a1·v, 0)^e1 max(a2·v, 0)^e2 dω (sr) for a sharp second lobe, by its
/// expansion about a2 (Funk–Hecke: the sharp lobe averages the broad one's spherical
/// harmonics with weights ⟨P_l(t)⟩, expanded in (1 − t)): with F = u^e1, u = a1·a2,
/// (2π/(e2 + 1))·[F + m1·ΔF/2 + m2·(Δ²F + 2ΔF)/16], m1 = 1/(e2 + 2),
/// m2 = 2/((e2 + 2)(e2 + 3)), Δ the sphere's Laplacian (Δu^e = e(e−1)u^(e−2) −
/// e(e+1)u^e). Each term is smaller than the one before by about
/// ε = (e1² + e1 + 1)/(u²·e2) (ΔF/F grows as e1²/u² towards the broad lobe's horizon),
/// the first one left out about ε³/48 of F. `Some` only where ε ≤ 0.01 and e2 ≥ 1000,
/// which also keeps the sharp lobe at least 10 of its widths 1/√e2 inside the broad
/// one's horizon (u ≥ 10·√((e1² + e1 + 1)/e2)), where the expansion does not see the
/// clamp; there it is within 1e-7 of the integral, relative (test
/// `sharp_product_integral_matches_quadrature`, e1 ≤ 30, e2 to 1e8). `None` elsewhere,
/// for NaN, and for u ≤ 0: the caller's table answers. The axes are taken as unit
/// (not checked: the caller's lobes are); exponents ≥ 0.
pub fn sharp_product_integral(a1: DVec3, e1: f64, a2: DVec3, e2: f64) -> Option<f64> {
    let u = a1.dot(a2).clamp(-1.0, 1.0);
    let ok = e2 >= 1000.0 && u > 0.0 && e2 * u * u >= 100.0 * (e1 * e1 + e1 + 1.0);
    if !ok {
        return None;
    }
    // u^(e1 − 2) and u^(e1 − 4) from u^e1 (one power; their coefficients vanish where
    // e1 is 0 or 1, e.g. e1 = 1: e1(e1 − 1) = 0).
    let f = u.powf(e1);
    let f2 = f / (u * u);
    let f4 = f2 / (u * u);
    let lap = e1 * (e1 - 1.0) * f2 - e1 * (e1 + 1.0) * f;
    let lap_of = |e: f64, fe: f64, fe2: f64| e * (e - 1.0) * fe2 - e * (e + 1.0) * fe;
    // Δ²u^e1 = e1(e1−1)·Δu^(e1−2) − e1(e1+1)·Δu^e1.
    let lap2 = e1 * (e1 - 1.0) * lap_of(e1 - 2.0, f2, f4) - e1 * (e1 + 1.0) * lap;
    let m1 = 1.0 / (e2 + 2.0);
    let m2 = 2.0 / ((e2 + 2.0) * (e2 + 3.0));
    Some(TAU / (e2 + 1.0) * (f + 0.5 * m1 * lap + m2 * (lap2 + 2.0 * lap) / 16.0))
}

/// How far above the exact bound min(|s1|·|∫l2|, |s2|·|∫l1|) the table's product
/// integral may come ([`LobeProduct::product_integral_bound`]): the `energy` variant
/// errs at most 5.5e-3 of the exact integral on relevant products (docs/lobes.md); the
/// margin leaves room for the `l2` variant and the irrelevant ones.
pub const PRODUCT_BOUND_MARGIN: f64 = 1.1;

/// Fitted product parameters at (e1, e2, α).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProductParams {
    /// Partial scale p_r (0 where the product vanishes or underflows).
    pub p: f64,
    /// Fraction t ∈ [0, 1] of the arc from a1 to a2 at which the axis a_r lies.
    pub t: f64,
    /// Exponent e_r.
    pub e_r: f64,
    /// ∫Ψ1Ψ2 dω (sr) as the table gives it.
    pub integral: f64,
}

/// A scaled cosine lobe s·max(a·v, 0)^e.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lobe {
    /// Scale s.
    pub scale: f64,
    /// Unit axis a.
    pub axis: DVec3,
    /// Exponent e ≥ 0.
    pub exponent: f64,
}

impl Lobe {
    /// ∫ s·max(a·v, 0)^e dω = 2πs/(e + 1) (sr).
    pub fn integral(&self) -> f64 {
        self.scale * TAU / (self.exponent + 1.0)
    }

    /// Value at the unit direction `v`.
    pub fn eval(&self, v: impl Into<DVec3>) -> f64 {
        let c = self.axis.dot(v.into());
        if c <= 0.0 {
            0.0
        } else {
            self.scale * c.powf(self.exponent)
        }
    }
}

/// [`Lobe`] with an f32 interface (computed in f64, rounded once).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lobe32 {
    /// Scale s.
    pub scale: f32,
    /// Unit axis a.
    pub axis: Vec3,
    /// Exponent e ≥ 0.
    pub exponent: f32,
}

impl Lobe32 {
    /// The lobe in f64 (exact).
    pub fn to_lobe(&self) -> Lobe {
        Lobe {
            scale: self.scale as f64,
            axis: self.axis.as_dvec3(),
            exponent: self.exponent as f64,
        }
    }

    /// [`Lobe::integral`] (sr), rounded to f32.
    pub fn integral(&self) -> f32 {
        self.to_lobe().integral() as f32
    }

    /// [`Lobe::eval`] at the unit direction `v`, rounded to f32.
    pub fn eval(&self, v: Vec3) -> f32 {
        self.to_lobe().eval(v.as_dvec3()) as f32
    }

    /// `l` rounded to f32; an error where the scale or exponent overflows f32.
    pub fn from_lobe(l: &Lobe) -> Result<Lobe32, LookupError> {
        Ok(Lobe32 {
            scale: narrow("scale", l.scale)?,
            axis: l.axis.as_vec3(),
            exponent: narrow("exponent", l.exponent)?,
        })
    }
}

/// [`ProductParams`] in f32 (see [`LobeProduct::params_f32`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProductParams32 {
    /// Partial scale p_r.
    pub p: f32,
    /// Fraction t ∈ [0, 1] of the arc from a1 to a2 at which the axis a_r lies.
    pub t: f32,
    /// Exponent e_r.
    pub e_r: f32,
    /// ∫Ψ1Ψ2 dω (sr).
    pub integral: f32,
}

/// A lobe-product table (either variant).
#[derive(Debug, Clone)]
pub struct LobeProduct {
    table: Table,
    variant: Variant,
}

crate::table_type::impl_table_type!(LobeProduct: KIND_ENERGY, VERSION, kinds = [KIND_ENERGY, KIND_L2]);

impl LobeProduct {
    /// Wraps a loaded table of either variant (the kind says which), checking kind,
    /// version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        let variant = if table.meta().kind == KIND_L2 {
            Variant::L2
        } else {
            Variant::Energy
        };
        table.expect_kind(variant.kind(), VERSION)?;
        let counts: Vec<u32> = table.meta().axes.iter().map(|a| a.count).collect();
        let (n_e, n_a) = (
            counts.first().copied().unwrap_or(0),
            counts.get(2).copied().unwrap_or(0),
        );
        table.expect_layout(&axes(n_e, n_a), variant.channels())?;
        if table.meta().axes[1].count != n_e {
            return Err(LoadError::LayoutMismatch {
                kind: table.meta().kind.clone(),
                detail: "e1 and e2 axes differ in node count".into(),
            });
        }
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        Ok(Self { table, variant })
    }

    /// A table loaded as the given variant (fails on the other kind).
    pub fn from_table_as(table: Table, variant: Variant) -> Result<Self, LoadError> {
        table.expect_kind(variant.kind(), VERSION)?;
        Self::from_table(table)
    }

    /// Which variant this table holds.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// Product parameters for exponents e1, e2 ∈ [0, 10⁵] and angle α ∈ [0, π] (rad)
    /// between the axes.
    pub fn params(&self, e1: f64, e2: f64, alpha: f64) -> Result<ProductParams, LookupError> {
        let e1 = in_range("e1", e1, 0.0, E_MAX)?;
        let e2 = in_range("e2", e2, 0.0, E_MAX)?;
        let alpha = in_range("alpha", alpha, 0.0, PI)?;
        self.params_checked(e1, e2, alpha)
    }

    /// [`LobeProduct::params`] for validated inputs; exponents above 10⁵ (products of
    /// products in lobe sums) look the table up at 10⁵, where the stored corrections
    /// are ~1e-6, and let the closed-form models — exact in the sharp-lobe limit —
    /// carry the true exponents.
    fn params_checked(&self, e1: f64, e2: f64, alpha: f64) -> Result<ProductParams, LookupError> {
        self.params_trig(e1, e2, alpha, &Trig::new(alpha))
    }

    /// [`LobeProduct::params_checked`] given the shared trigonometry of α.
    #[inline]
    fn params_trig(&self, e1: f64, e2: f64, alpha: f64, trig: &Trig) -> Result<ProductParams, LookupError> {
        let mut ch = [0.0; 3];
        let n = self.variant.channels().len();
        self.table
            .interpolate(&[e1.min(E_MAX), e2.min(E_MAX), alpha], &mut ch[..n])?;
        let e_r = (1.0 + exponent_model_with(e1, e2, trig)) * ch[1].exp() - 1.0;
        let e_r = e_r.max(0.0);
        // exp of a very negative ln underflows to an exact 0: vanishing products are
        // exact zeros, never noise.
        let integral = (ln_model_with(e1, e2, alpha, trig) + ch[0]).exp();
        let k = if self.variant == Variant::L2 { ch[2].exp() } else { 1.0 };
        // Exponents beyond 10⁵ (lobe sums) can push e_r and p_r past f64.
        let e_r = finite_result("e_r", e_r)?;
        let integral = finite_result("product integral", integral)?;
        let p = finite_result("p_r", k * integral * (e_r + 1.0) / TAU)?;
        Ok(ProductParams {
            p,
            t: peak_fraction_with(e1, e2, alpha, trig.sin_alpha),
            e_r,
            integral,
        })
    }

    /// The product of the lobes (s1, a1, e1) and (s2, a2, e2) as one lobe: scale
    /// s1·s2·p_r, axis a_r (slerp from a1 to a2 at t), exponent e_r. Axes must be unit
    /// vectors (within 1e-3); exponents in [0, 10⁵]; a scale that overflows is an
    /// error.
    pub fn product(&self, l1: &Lobe, l2: &Lobe) -> Result<Lobe, LookupError> {
        in_range("e1", l1.exponent, 0.0, E_MAX)?;
        in_range("e2", l2.exponent, 0.0, E_MAX)?;
        self.product_any(l1, l2)
    }

    /// [`LobeProduct::product`] for any finite exponents ≥ 0 (see
    /// [`LobeProduct::params_checked`]): the lobe-sum algebra multiplies products.
    fn product_any(&self, l1: &Lobe, l2: &Lobe) -> Result<Lobe, LookupError> {
        let (a1, a2) = (unit("a1", l1.axis)?, unit("a2", l2.axis)?);
        finite("s1", l1.scale)?;
        finite("s2", l2.scale)?;
        let e1 = in_range("e1", l1.exponent, 0.0, f64::MAX)?;
        let e2 = in_range("e2", l2.exponent, 0.0, f64::MAX)?;
        let cos = a1.dot(a2).clamp(-1.0, 1.0);
        // atan2 of |a1×a2| and a1·a2 is accurate at both ends, unlike acos.
        let alpha = a1.cross(a2).length().atan2(cos);
        // Huge exponents overflow p or e_r: blame them, not the scales.
        let trig = Trig::new(alpha);
        let q = self.params_trig(e1, e2, alpha, &trig).map_err(|e| match e {
            LookupError::Overflow { .. } => LookupError::ProductOverflow { e1, e2 },
            e => e,
        })?;
        if !(q.p.is_finite() && q.e_r.is_finite()) {
            return Err(LookupError::ProductOverflow { e1, e2 });
        }
        // p first: a vanishing product stays 0 whatever the scales.
        let scale = finite_result("scale", l1.scale * q.p * l2.scale)?;
        Ok(Lobe {
            scale,
            axis: slerp(a1, a2, alpha, trig.sin_alpha, q.t),
            exponent: q.e_r,
        })
    }

    /// ∫ of the product of two lobes (sr, times their scales): the integral of
    /// [`LobeProduct::product`]'s lobe (the table's integral, times its L² scale
    /// correction for that variant) without forming the lobe's axis and exponent. For
    /// any finite exponents ≥ 0, as the lobe-sum algebra needs. Unlike
    /// [`LobeProduct::product`] it does not fail where only the product's exponent or
    /// peak scale would overflow f64: its integral is all it forms.
    pub fn product_integral(&self, l1: &Lobe, l2: &Lobe) -> Result<f64, LookupError> {
        let (a1, a2) = (unit("a1", l1.axis)?, unit("a2", l2.axis)?);
        finite("s1", l1.scale)?;
        finite("s2", l2.scale)?;
        let e1 = in_range("e1", l1.exponent, 0.0, f64::MAX)?;
        let e2 = in_range("e2", l2.exponent, 0.0, f64::MAX)?;
        let alpha = a1.cross(a2).length().atan2(a1.dot(a2).clamp(-1.0, 1.0));
        let trig = Trig::new(alpha);
        let mut ch = [0.0; 3];
        let n = self.variant.channels().len();
        self.table
            .interpolate(&[e1.min(E_MAX), e2.min(E_MAX), alpha], &mut ch[..n])?;
        let integral = (ln_model_with(e1, e2, alpha, &trig) + ch[0]).exp();
        let k = if self.variant == Variant::L2 { ch[2].exp() } else { 1.0 };
        let q = finite_result("product integral", k * integral).map_err(|_| LookupError::ProductOverflow { e1, e2 })?;
        // The factor first: a vanishing product stays 0 whatever the scales.
        if q == 0.0 {
            return Ok(0.0);
        }
        finite_result("product integral", l1.scale * q * l2.scale)
    }

    /// A bound (sr × s1·s2, the units of [`LobeProduct::product_integral`]) on
    /// |[`LobeProduct::product_integral`]| of lobes it accepts, from the two lobes
    /// alone, with no lookup: the exact |∫ l1 l2| is at most min(|s1|·|∫l2|,
    /// |s2|·|∫l1|) (a lobe never exceeds its scale), and the table's integral stays
    /// within [`PRODUCT_BOUND_MARGIN`] of the exact one (test
    /// `product_integral_stays_within_its_bound`, both variants, exponents to 1e8). A
    /// caller dropping products below a threshold t_i (§5.4) skips those whose bound
    /// is below it before computing them: the comparison would have dropped them (and
    /// such a product's lookup is not made, so it cannot fail either). Infinite where
    /// either lobe's terms are NaN (nothing is skipped on a bound that says nothing).
    pub fn product_integral_bound(l1: &Lobe, l2: &Lobe) -> f64 {
        let (b1, b2) = (
            l1.scale.abs() * l2.integral().abs(),
            l2.scale.abs() * l1.integral().abs(),
        );
        if b1.is_nan() || b2.is_nan() {
            return f64::INFINITY;
        }
        PRODUCT_BOUND_MARGIN * b1.min(b2)
    }

    /// [`LobeProduct::product_any`] for inputs that passed [`valid_pair`], with no
    /// `Result`: the same arithmetic in the same order (so the same bits when the
    /// result is finite); a non-finite scale or exponent marks an overflow, which the
    /// caller turns into the one-at-a-time error.
    #[inline]
    fn product_valid(&self, l1: &Lobe, l2: &Lobe) -> Lobe {
        let (a1, a2) = (l1.axis / l1.axis.length(), l2.axis / l2.axis.length());
        let (e1, e2) = (l1.exponent, l2.exponent);
        let cos = a1.dot(a2).clamp(-1.0, 1.0);
        let alpha = a1.cross(a2).length().atan2(cos);
        let trig = Trig::new(alpha);
        let mut ch = [0.0; 3];
        let n = self.variant.channels().len();
        self.table
            .interpolate_valid(&[e1.min(E_MAX), e2.min(E_MAX), alpha], &mut ch[..n]);
        let e_r = ((1.0 + exponent_model_with(e1, e2, &trig)) * ch[1].exp() - 1.0).max(0.0);
        let integral = (ln_model_with(e1, e2, alpha, &trig) + ch[0]).exp();
        let k = if self.variant == Variant::L2 { ch[2].exp() } else { 1.0 };
        let p = k * integral * (e_r + 1.0) / TAU;
        let t = peak_fraction_with(e1, e2, alpha, trig.sin_alpha);
        let ok = e_r.is_finite() & integral.is_finite() & p.is_finite();
        Lobe {
            // NaN flags an intermediate overflow even where the scales would hide it.
            scale: if ok { l1.scale * p * l2.scale } else { f64::NAN },
            axis: slerp(a1, a2, alpha, trig.sin_alpha, t),
            exponent: e_r,
        }
    }

    /// Batch [`LobeProduct::product`]: `out[i]` = the product of `pairs[i]` as one lobe,
    /// bit for bit the one-at-a-time value (same contract: unit axes within 1e-3,
    /// finite scales, exponents in [0, 10⁵]). The slice is validated first, then
    /// computed in a plain loop with no per-item `Result`. Errors:
    /// [`LookupError::BatchLength`] when the slices differ in length,
    /// [`LookupError::BatchItem`] (index and the one-at-a-time error) for the first bad
    /// pair or overflowing product.
    pub fn products(&self, pairs: &[(Lobe, Lobe)], out: &mut [Lobe]) -> Result<(), LookupError> {
        same_length(pairs.len(), out.len())?;
        let single = |(a, b): &(Lobe, Lobe)| self.product(a, b);
        if !pairs.iter().fold(true, |ok, (a, b)| ok & valid_lobe(a) & valid_lobe(b)) {
            first_failure(pairs, single)?;
        }
        for (o, (a, b)) in out.iter_mut().zip(pairs) {
            *o = self.product_valid(a, b);
        }
        if !out.iter().all(|l| l.scale.is_finite() & l.exponent.is_finite()) {
            first_failure(pairs, single)?;
        }
        Ok(())
    }

    /// [`LobeProduct::products`] in single precision (f64 inside, rounded once), bit for
    /// bit [`LobeProduct::product_f32`].
    pub fn products_f32(&self, pairs: &[(Lobe32, Lobe32)], out: &mut [Lobe32]) -> Result<(), LookupError> {
        same_length(pairs.len(), out.len())?;
        let single = |(a, b): &(Lobe32, Lobe32)| self.product_f32(a, b);
        if !pairs.iter().fold(true, |ok, (a, b)| {
            ok & valid_lobe(&a.to_lobe()) & valid_lobe(&b.to_lobe())
        }) {
            first_failure(pairs, single)?;
        }
        for (o, (a, b)) in out.iter_mut().zip(pairs) {
            let r = self.product_valid(&a.to_lobe(), &b.to_lobe());
            *o = Lobe32 {
                scale: r.scale as f32,
                axis: r.axis.as_vec3(),
                exponent: r.exponent as f32,
            };
        }
        if !out.iter().all(|l| l.scale.is_finite() & l.exponent.is_finite()) {
            first_failure(pairs, single)?;
        }
        Ok(())
    }

    /// [`LobeProduct::product`] with an f32 interface (computed in f64, rounded once).
    pub fn product_f32(&self, l1: &Lobe32, l2: &Lobe32) -> Result<Lobe32, LookupError> {
        Lobe32::from_lobe(&self.product(&l1.to_lobe(), &l2.to_lobe())?)
    }

    /// [`LobeProduct::params`] with an f32 interface (computed in f64, rounded once).
    pub fn params_f32(&self, e1: f32, e2: f32, alpha: f32) -> Result<ProductParams32, LookupError> {
        let q = self.params(e1 as f64, e2 as f64, crate::error::angle_f32(alpha))?;
        Ok(ProductParams32 {
            p: narrow("p_r", q.p)?,
            t: narrow("t", q.t)?,
            e_r: narrow("e_r", q.e_r)?,
            integral: narrow("integral", q.integral)?,
        })
    }

    /// [`LobeProduct::product_sums`] with an f32 interface (computed in f64, rounded once).
    pub fn product_sums_f32(&self, a: &[Lobe32], b: &[Lobe32], threshold: f32) -> Result<Vec<Lobe32>, LookupError> {
        let wide = |l: &[Lobe32]| l.iter().map(Lobe32::to_lobe).collect::<Vec<_>>();
        let r = self.product_sums(&wide(a), &wide(b), threshold as f64)?;
        r.iter().map(Lobe32::from_lobe).collect()
    }

    /// [`LobeProduct::triple_product`] with an f32 interface (computed in f64, rounded once).
    pub fn triple_product_f32(
        &self,
        brdf: &[Lobe32],
        lighting: &[Lobe32],
        visibility: &[Lobe32],
        normal: Vec3,
        threshold: f32,
    ) -> Result<f32, LookupError> {
        let wide = |l: &[Lobe32]| l.iter().map(Lobe32::to_lobe).collect::<Vec<_>>();
        let v = self.triple_product(
            &wide(brdf),
            &wide(lighting),
            &wide(visibility),
            normal.as_dvec3(),
            threshold as f64,
        )?;
        narrow("triple-product integral", v)
    }

    /// Product of two lobe sums (§4.3): every pairwise product whose integral is at
    /// least `threshold` (sr; the paper's t_i, 0 keeps all non-zero products).
    /// Exponents may exceed 10⁵ here (products of products; see
    /// [`LobeProduct::product`] for the rest of the contract).
    pub fn product_sums(&self, a: &[Lobe], b: &[Lobe], threshold: f64) -> Result<Vec<Lobe>, LookupError> {
        finite("threshold", threshold)?;
        let mut out = Vec::with_capacity(a.len() * b.len());
        for la in a {
            for lb in b {
                let r = self.product_any(la, lb)?;
                if r.scale != 0.0 && r.integral().abs() >= threshold {
                    out.push(r);
                }
            }
        }
        Ok(out)
    }

    /// ∫ (Σ BRDF lobes)(Σ lighting lobes)(Σ visibility lobes)·max(n·v, 0) dω (eq. 22),
    /// ordered as §5.4: BRDF × lighting first, then visibility, then the cosine lobe
    /// about the normal `n`; products with |integral| < `threshold` are dropped at
    /// every stage.
    pub fn triple_product(
        &self,
        brdf: &[Lobe],
        lighting: &[Lobe],
        visibility: &[Lobe],
        normal: DVec3,
        threshold: f64,
    ) -> Result<f64, LookupError> {
        let normal = unit("normal", normal)?;
        let bl = self.product_sums(brdf, lighting, threshold)?;
        let blv = self.product_sums(&bl, visibility, threshold)?;
        let cosine = [Lobe {
            scale: 1.0,
            axis: normal,
            exponent: 1.0,
        }];
        let all = self.product_sums(&blv, &cosine, threshold)?;
        finite_result("triple-product integral", lobe_sum_integral(&all))
    }
}

/// ∫ Σ lobes dω (sr): Σ 2π s_i/(e_i + 1).
pub fn lobe_sum_integral(lobes: &[Lobe]) -> f64 {
    lobes.iter().map(Lobe::integral).sum()
}

/// Whether [`LobeProduct::product`] accepts the lobe (finite scale and axis, axis
/// length within 1e-3 of 1, exponent in [0, 10⁵]), without branches (NaN fails).
#[inline]
fn valid_lobe(l: &Lobe) -> bool {
    let len = l.axis.length();
    l.scale.is_finite() & l.axis.is_finite() & ((len - 1.0).abs() <= 1e-3) & (l.exponent >= 0.0) & (l.exponent <= E_MAX)
}

fn unit(name: &str, a: DVec3) -> Result<DVec3, LookupError> {
    for x in a.to_array() {
        finite(name, x)?;
    }
    let len = a.length();
    if (len - 1.0).abs() > 1e-3 {
        return Err(LookupError::OutOfDomain {
            name: format!("|{name}|"),
            value: len,
            lo: 1.0 - 1e-3,
            hi: 1.0 + 1e-3,
        });
    }
    Ok(a / len)
}

/// The point at fraction t of the arc (angle α) from a1 to a2. For α = π the arc is
/// not unique; any perpendicular works since the product is 0 there.
/// `s` = sin α.
fn slerp(a1: DVec3, a2: DVec3, alpha: f64, s: f64, t: f64) -> DVec3 {
    if s < 1e-9 {
        // Parallel (the product axis is a1 = a2) or antiparallel (the product vanishes).
        return a1;
    }
    (a1 * ((1.0 - t) * alpha).sin() + a2 * (t * alpha).sin()) / s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_gamma_matches_known_values() {
        // Γ(1/2) = √π, Γ(n) = (n−1)!, and Γ(x + 1) = xΓ(x) far out.
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-14);
        let mut f = 1.0f64;
        for n in 1..30 {
            assert!(
                (ln_gamma(n as f64) - f.ln()).abs() < 1e-13 * f.ln().abs().max(1.0),
                "{n}"
            );
            f *= n as f64;
        }
        for x in [0.1, 3.7, 123.4, 5.0e4] {
            assert!((ln_gamma(x + 1.0) - ln_gamma(x) - f64::ln(x)).abs() < 1e-12 * ln_gamma(x).abs().max(1.0));
        }
    }

    #[test]
    fn peak_angle_solves_the_stationarity_condition() {
        for &(e1, e2) in &[(1.0, 1.0), (0.3, 70.0), (1e5, 2.0), (5.0, 0.0)] {
            for k in 1..40 {
                let alpha = k as f64 * PI / 40.0;
                let b = peak_angle(e1, e2, alpha);
                assert!((0.0..=alpha).contains(&b));
                let g = |s: f64| lobe_ln(e1, s.cos()) + lobe_ln(e2, (alpha - s).cos());
                // β maximises the in-plane product on the open lune.
                let lo = (alpha - PI / 2.0).max(0.0);
                let hi = alpha.min(PI / 2.0);
                for j in 1..200 {
                    let s = lo + (hi - lo) * j as f64 / 200.0;
                    assert!(g(s) <= g(b) + 1e-9 * g(b).abs().max(1.0), "{e1} {e2} {alpha} {s} {b}");
                }
            }
        }
        assert_eq!(peak_angle(3.0, 3.0, 1.0), 0.5);
        assert_eq!(peak_fraction(1.0, 3.0, 0.0), 0.75);
    }
}
