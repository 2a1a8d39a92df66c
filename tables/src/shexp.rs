//! SH exponentiation (Ren et al. 2006, thesis §3.7): the `shexp` table of
//! spherical-cap blockers and the per-pixel exp* that renderers run (OL and HYB).
//!
//! exp*(f) = 1 + f + f^{2∗}/2! + … with every product truncated to order n
//! (1 = (√(4π), 0, …)). Renderers accumulate log-space visibility f = Σ_k f_k
//! (each blocker's log-ZH rotated into place with [`crate::sh::zh_to_sh`]) and then
//! evaluate exp*(f) once:
//!
//! - **OL** (`ol`): exp*(f̂) ≈ a(‖f̂‖) 1 + b(‖f̂‖) f̂, f̂ = f without its DC term;
//! - **HYB** ([`ShExp::hyb`], `hyb_with`): exp*(f) = e^{f_0/√(4π)} exp*(f̂) (DC
//!   isolation), f̂ halved k times until ‖f̂‖/2^k ≤ the OL threshold, OL, then k
//!   truncated squarings.
//!
//! The table (`tables/data/shexp.lobefit`, one axis θ_b ∈ [0, π/2] rad, uniform) holds
//! per order n = 3..8, for the visibility g = 1 − cap of a cap of angular radius θ_b
//! about +z: the log-ZH f (Ren's log of the SH product matrix, f = R q(D) Rᵀ (g − 1),
//! q(x) = ln(x)/(x − 1), eigenvalues in q clamped below at 0.02 × the largest), ‖f̂‖ and the OL coefficients a = ĝ_0/√(4π), b = ĝ·f̂/(f̂·f̂),
//! ĝ = e^{−f_0/√(4π)} g. f and ‖f̂‖ are stored divided by 1 − cosθ_b (the cap's solid
//! angle over 2π), which tends to a finite limit at θ_b = 0 and keeps small blockers
//! accurate under linear interpolation. Every value is an f32 pair (hi + lo).
//!
//! ‖f̂‖ is not monotonic in θ_b at some orders. [`ShExp::ab_for_norm`] (what HYB looks
//! up) uses the **monotone branch**: θ_b from 0 up to the first node where ‖f̂‖ stops
//! increasing; [`ShExp::norm_max`] is the largest ‖f̂‖ on it, and the OL threshold
//! must not exceed it.

use std::f64::consts::PI;

use crate::error::{finite, in_range, narrow, narrow_all, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::gaunt::Gaunt;
use crate::sh::{self, MAX_COEFFS};
use crate::table::Table;
use glam::{DVec3, Vec3};

/// Table kind.
pub const KIND: &str = "shexp";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Smallest tabulated order.
pub const ORDER_MIN: usize = 3;
/// Largest tabulated order.
pub const ORDER_MAX: usize = 8;
/// Largest blocker radius θ_b (rad): a hemisphere.
pub const THETA_MAX: f64 = PI / 2.0;
/// Nodes of the θ_b axis (uniform on [0, π/2]).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const THETA_NODES: u32 = 2049;
/// Squarings HYB allows before it calls ‖f̂‖ unreasonable (2^64 × the threshold).
pub const MAX_SQUARINGS: u32 = 64;

/// OL threshold per order 3..8 (largest ‖f̂‖ handed to OL before halving), chosen
/// from the evaluation in docs/shexp.md (`lobefit plot shexp`; Ren et al.: 4.8): the
/// largest candidate (1/64, 1/32, 1/16, 1/8, 0.25, 0.5, …) whose HYB error vs the
/// exact visibility stays within 25 % of exact exp*'s on random multi-blocker scenes
/// and single caps. Each is below the order's [`ShExp::norm_max`].
pub const OL_THRESHOLD: [f64; ORDER_MAX - ORDER_MIN + 1] = [0.75, 0.125, 0.0625, 0.0625, 0.03125, 0.015625];

/// Decoded channels (hi/lo pairs) per node: f_0..f_7 (f_l for l ≥ n is stored as 0),
/// ‖f̂‖, a, b, kink.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const PAIRS: usize = 12;
/// Pair index of ‖f̂‖ (scaled); a and b follow.
const NORM: usize = 8;
/// Pair index of `kink`: the θ_b (rad) in [θ_i, θ_{i+1}) where the eigenvalue clamp
/// switches (an eigenvalue of M_g's m = 0 block crosses 0.02 λ_max, or λ_max moves to
/// another block while the clamp is active): f, ‖f̂‖, a, b have a kink there. −1 when
/// the interval has none. Interpolation does not straddle a kink: it extrapolates
/// linearly from the two nodes on the query's side.
const KINK: usize = 11;

/// Bound on the stored f_l/(1 − cosθ_b) and ‖f̂‖/(1 − cosθ_b). The eigenvalues of M_g
/// lie in [min g, max g] = [0, 1] (Rayleigh quotients ∫g x² / ∫x²), the largest is at
/// least g_0/√(4π) ≥ 1/2 for θ_b ≤ π/2, so the clamped ones are ≥ 0.01 and
/// q(x) = ln x/(x − 1) ≤ q(0.01) = 4.65. With |cap_l| ≤ 2π(1 − cosθ_b)·√((2l+1)/(4π)),
/// ‖g − 1‖ ≤ √π n (1 − cosθ_b), so ‖f‖/(1 − cosθ_b) ≤ 4.65·8·√π = 66; with margin, 70.
const F_BOUND: f64 = 70.0;
/// Bound on a and b. a = e^{−f_0/√(4π)} g_0/√(4π) with g_0/√(4π) ∈ [1/2, 1] and
/// |f_0| ≤ ‖f‖ ≤ 4.65·‖cap‖ ≤ 4.65·√(2π) (Bessel), so 0 < a ≤ e^{3.3} = 27; b, the
/// least-squares slope of ĝ on f̂, is a weighted mean of the slope of exp over f̂'s
/// range, positive and of the same size. With margin, 30.
const AB_BOUND: f64 = 30.0;

/// Plausible range of each stored channel (name, lo, hi), dimensionless (kink in rad).
/// Hi halves: f_l ∈ ±70 and ‖f̂‖ ∈ [0, 70] (both divided by 1 − cosθ_b, see the bound
/// above), a and b in [0, 30], kink −1 (none) or θ_b ∈ [0, π/2], so [−1, 1.6]. Lo
/// halves: half an f32 ulp of the hi bound, with margin (4e-6 below 128, 1e-6 below 32,
/// 1e-7 below 2).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[
    ("f0_hi", -F_BOUND, F_BOUND),
    ("f0_lo", -4e-6, 4e-6),
    ("f1_hi", -F_BOUND, F_BOUND),
    ("f1_lo", -4e-6, 4e-6),
    ("f2_hi", -F_BOUND, F_BOUND),
    ("f2_lo", -4e-6, 4e-6),
    ("f3_hi", -F_BOUND, F_BOUND),
    ("f3_lo", -4e-6, 4e-6),
    ("f4_hi", -F_BOUND, F_BOUND),
    ("f4_lo", -4e-6, 4e-6),
    ("f5_hi", -F_BOUND, F_BOUND),
    ("f5_lo", -4e-6, 4e-6),
    ("f6_hi", -F_BOUND, F_BOUND),
    ("f6_lo", -4e-6, 4e-6),
    ("f7_hi", -F_BOUND, F_BOUND),
    ("f7_lo", -4e-6, 4e-6),
    ("norm_hi", 0.0, F_BOUND),
    ("norm_lo", -4e-6, 4e-6),
    ("a_hi", 0.0, AB_BOUND),
    ("a_lo", -1e-6, 1e-6),
    ("b_hi", 0.0, AB_BOUND),
    ("b_lo", -1e-6, 1e-6),
    ("kink_hi", -1.0, 1.6),
    ("kink_lo", -1e-7, 1e-7),
];

/// Names of the stored channels: `{f0..f7|norm|a|b}_{hi|lo}`.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn channel_names() -> Vec<String> {
    let mut q: Vec<String> = (0..8).map(|l| format!("f{l}")).collect();
    q.extend(["norm".to_string(), "a".into(), "b".into(), "kink".into()]);
    q.iter().flat_map(|n| [format!("{n}_hi"), format!("{n}_lo")]).collect()
}

/// The table's axes, slowest first: `order` (3..8, one node each) and θ_b ∈ [0, π/2]
/// rad (uniform, end-points).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axes() -> Vec<Axis> {
    vec![
        Axis {
            name: "order".into(),
            unit: "1".into(),
            lo: ORDER_MIN as f64,
            hi: ORDER_MAX as f64,
            mapping: Mapping::Linear,
            count: (ORDER_MAX - ORDER_MIN + 1) as u32,
            placement: Placement::Endpoints,
        },
        Axis {
            name: "theta_b".into(),
            unit: "rad".into(),
            lo: 0.0,
            hi: THETA_MAX,
            mapping: Mapping::Linear,
            count: THETA_NODES,
            placement: Placement::Endpoints,
        },
    ]
}

/// θ_b of node `i` (rad).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn node_theta(i: usize) -> f64 {
    THETA_MAX * i as f64 / (THETA_NODES - 1) as f64
}

/// 1 − cosθ, accurate for small θ.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn one_minus_cos(theta: f64) -> f64 {
    let s = (0.5 * theta).sin();
    2.0 * s * s
}

fn check_order(order: usize) -> Result<usize, LookupError> {
    if !(ORDER_MIN..=ORDER_MAX).contains(&order) {
        return Err(LookupError::OutOfDomain {
            name: "order".into(),
            value: order as f64,
            lo: ORDER_MIN as f64,
            hi: ORDER_MAX as f64,
        });
    }
    Ok(order)
}

/// The OL threshold of [`OL_THRESHOLD`] for `order` (3..=8).
pub fn ol_threshold(order: usize) -> Result<f64, LookupError> {
    Ok(OL_THRESHOLD[check_order(order)? - ORDER_MIN])
}

/// ZH of the visibility g = 1 − cap of a cap of angular radius `theta_b` (rad) about
/// +z, l < `order` ≤ 8 (closed form of docs/math.md, shexp: the cap term is
/// [`crate::log_zh::cap_zh`]); entries ≥ `order` are 0. Errors: θ_b not finite or
/// outside [0, π], order outside 1..=8.
pub fn cap_visibility_zh(theta_b: f64, order: usize) -> Result<[f64; sh::MAX_ORDER], LookupError> {
    in_range("theta_b", theta_b, 0.0, PI)?;
    sh::check_order(order)?;
    let cap = crate::log_zh::cap_zh(theta_b, order);
    let mut g = [0.0; sh::MAX_ORDER];
    for (gl, c) in g.iter_mut().zip(&cap).take(order) {
        *gl = -c;
    }
    g[0] += (4.0 * PI).sqrt();
    Ok(g)
}

/// (a, b, ‖f̂‖) of a pair (g, f) of a visibility and its log (ZH or SH vectors of the
/// same length; docs/math.md, shexp, thesis eq. 3.44–3.47): ĝ = e^{−f_0/√(4π)} g,
/// a = ĝ_0/√(4π), b = ĝ·f̂/(f̂·f̂) — the least-squares OL fit of ĝ on {1, f̂}.
/// b = 1 (its limit) when f̂ = 0. Errors: empty or unequal lengths, non-finite entries.
#[cfg(feature = "writer")]
pub fn ab_of_pair(g: &[f64], f: &[f64]) -> Result<(f64, f64, f64), LookupError> {
    if f.is_empty() {
        return Err(LookupError::Coefficients {
            name: "f",
            got: 0,
            expected: "at least 1".into(),
        });
    }
    if g.len() != f.len() {
        return Err(LookupError::Coefficients {
            name: "g",
            got: g.len(),
            expected: format!("{}, as many as f", f.len()),
        });
    }
    for v in g {
        finite("g", *v)?;
    }
    for v in f {
        finite("f", *v)?;
    }
    let s = (4.0 * PI).sqrt();
    let scale = (-f[0] / s).exp();
    let a = scale * g[0] / s;
    let ff: f64 = f[1..].iter().map(|v| v * v).sum();
    let gf: f64 = f[1..].iter().zip(&g[1..]).map(|(a, b)| a * b).sum();
    let b = if ff > 0.0 { scale * gf / ff } else { 1.0 };
    Ok((a, b, ff.sqrt()))
}

/// OL: exp*(f̂) ≈ a 1 + b f̂ for a DC-free `fhat` (n² coefficients; `fhat[0]` is
/// ignored and treated as 0), into `out[..n²]`. Errors: empty `fhat`, `out` shorter
/// than `fhat`, non-finite a or b.
#[cfg(feature = "writer")]
pub fn ol(a: f64, b: f64, fhat: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
    finite("a", a)?;
    finite("b", b)?;
    if fhat.is_empty() {
        return Err(LookupError::Coefficients {
            name: "fhat",
            got: 0,
            expected: "at least 1".into(),
        });
    }
    if out.len() < fhat.len() {
        return Err(LookupError::Output {
            got: out.len(),
            needed: fhat.len(),
            what: "SH coefficients",
        });
    }
    for (o, v) in out.iter_mut().zip(fhat) {
        *o = b * v;
    }
    out[0] = a * (4.0 * PI).sqrt();
    Ok(())
}

/// HYB exp* of `f` (n² SH coefficients, the tensor's order) into `out[..n²]`, with
/// the OL coefficients from `ab(‖f̂‖/2^k)` and OL used once ‖f̂‖/2^k ≤ `threshold`.
/// Returns the number k of squarings. Errors: wrong lengths, non-finite input, a
/// threshold ≤ 0, more than [`MAX_SQUARINGS`] halvings, or an error of `ab`.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn hyb_with(
    gaunt: &Gaunt,
    f: &[f64],
    threshold: f64,
    ab: impl Fn(f64) -> Result<(f64, f64), LookupError>,
    out: &mut [f64],
) -> Result<u32, LookupError> {
    let nc = gaunt.order() * gaunt.order();
    if f.len() != nc {
        return Err(LookupError::Coefficients {
            name: "f",
            got: f.len(),
            expected: format!("{nc} (the Gaunt tensor's order {})", gaunt.order()),
        });
    }
    if out.len() < nc {
        return Err(LookupError::Output {
            got: out.len(),
            needed: nc,
            what: "SH coefficients",
        });
    }
    let t = finite("threshold", threshold)?;
    if t <= 0.0 {
        return Err(LookupError::OutOfDomain {
            name: "threshold".into(),
            value: t,
            lo: f64::MIN_POSITIVE,
            hi: f64::INFINITY,
        });
    }
    for v in f {
        finite("f", *v)?;
    }
    let sqrt4pi = (4.0 * PI).sqrt();
    let dc = f[0] / sqrt4pi;
    let norm = f[1..].iter().map(|v| v * v).sum::<f64>().sqrt();
    finite("|f_hat|", norm)?;
    let mut k = 0u32;
    let mut s = norm;
    while s > t {
        if k == MAX_SQUARINGS {
            return Err(LookupError::OutOfDomain {
                name: "|f_hat|".into(),
                value: norm,
                lo: 0.0,
                hi: t * 2f64.powi(MAX_SQUARINGS as i32),
            });
        }
        s *= 0.5;
        k += 1;
    }
    let (a, b) = ab(s)?;
    let scale = b / 2f64.powi(k as i32);
    let out = &mut out[..nc];
    for (o, v) in out.iter_mut().zip(f) {
        *o = scale * v;
    }
    out[0] = a * sqrt4pi;
    let mut tmp = [0.0; MAX_COEFFS];
    for _ in 0..k {
        tmp[..nc].copy_from_slice(out);
        gaunt.product_into(&tmp[..nc], &tmp[..nc], out);
    }
    let e = dc.exp();
    out.iter_mut().for_each(|o| *o *= e);
    // exp* of a large f_0 or ‖f̂‖ leaves f64 (e^{f_0/√(4π)} alone overflows above
    // f_0 ≈ 2.5e3): an error, never an Ok(inf/NaN).
    if let Some(v) = out.iter().find(|v| !v.is_finite()) {
        return Err(LookupError::NotFinite {
            name: "exp*(f) (overflow: f_0 or |f_hat| too large)".into(),
            value: *v,
        });
    }
    Ok(k)
}

/// The monotone branch of ‖f̂‖(θ_b) of one order, decoded at the nodes.
#[derive(Debug, Clone)]
struct Branch {
    /// ‖f̂‖ at nodes 0..=last (strictly increasing).
    norm: Vec<f64>,
    /// a at those nodes.
    a: Vec<f64>,
    /// b at those nodes.
    b: Vec<f64>,
}

/// The shexp table (axes `order` × `theta_b`, `PAIRS` f32 pairs per node): per order
/// 3..8, f, ‖f̂‖, a, b of cap blockers vs θ_b, and the a/b lookup vs ‖f̂‖ that HYB uses.
#[derive(Debug, Clone)]
pub struct ShExp {
    table: Table,
    branches: Vec<Branch>,
}

crate::table_type::impl_table_type! {
    /// The underlying table (row-major \[order\]\[θ_b\], channels of `channel_names`), e.g.
    /// for GPU upload.
    ShExp: KIND, VERSION
}

impl ShExp {
    /// Wraps an already loaded table, checking its kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        let names = channel_names();
        let chans: Vec<(&str, Encoding)> = names.iter().map(|c| (c.as_str(), Encoding::Linear)).collect();
        table.expect_layout(&axes(), &chans)?;
        if table.meta().axes != axes() {
            return Err(LoadError::LayoutMismatch {
                kind: KIND.into(),
                detail: format!("expected {THETA_NODES} theta_b nodes"),
            });
        }
        // Before the branches are built from the values.
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        let mut t = ShExp {
            table,
            branches: Vec::new(),
        };
        for n in ORDER_MIN..=ORDER_MAX {
            let mut br = Branch {
                norm: vec![0.0],
                a: vec![t.pair(0, n, NORM + 1)],
                b: vec![t.pair(0, n, NORM + 2)],
            };
            for i in 1..THETA_NODES as usize {
                let norm = t.pair(i, n, NORM) * one_minus_cos(t.node_theta(i));
                if norm <= *br.norm.last().expect("non-empty") {
                    break;
                }
                br.norm.push(norm);
                br.a.push(t.pair(i, n, NORM + 1));
                br.b.push(t.pair(i, n, NORM + 2));
            }
            if br.norm.len() < 2 || *br.norm.last().expect("non-empty") < OL_THRESHOLD[n - ORDER_MIN] {
                return Err(LoadError::Invalid(format!(
                    "shexp order {n}: the monotone branch of |f_hat| ends below the OL threshold"
                )));
            }
            t.branches.push(br);
        }
        Ok(t)
    }

    fn node_theta(&self, i: usize) -> f64 {
        node_theta(i)
    }

    /// Decoded pair `q` of order `n` at θ_b node `i`.
    fn pair(&self, i: usize, n: usize, q: usize) -> f64 {
        let c = 2 * q;
        let row = &self.table.values()[((n - ORDER_MIN) * THETA_NODES as usize + i) * 2 * PAIRS..];
        row[c] as f64 + row[c + 1] as f64
    }

    /// Whether the interval [θ_j, θ_{j+1}) of order n holds a kink.
    fn has_kink(&self, j: usize, n: usize) -> bool {
        self.pair(j, n, KINK) >= 0.0
    }

    /// Cubic (4-point Lagrange) interpolation of the pairs q ∈ `qs` of order n at θ_b,
    /// on a stencil that never straddles a clamp kink (see [`KINK`]): nodes i−1..i+2
    /// around the interval [θ_i, θ_{i+1}] holding θ_b, cut at kinks, extended on the
    /// query's side to at least 3 nodes (extrapolating up to the kink), linear when
    /// kinks leave only 2.
    fn interp<const K: usize>(&self, theta_b: f64, n: usize, qs: [usize; K]) -> Result<[f64; K], LookupError> {
        let theta = in_range("theta_b", theta_b, 0.0, THETA_MAX)?;
        let last = THETA_NODES as usize - 1;
        let s = (theta / THETA_MAX * last as f64).clamp(0.0, last as f64);
        let i = (s.floor() as usize).min(last - 1);
        // The kink-free piece [lo, hi] of node indices on θ_b's side.
        let (mut lo, mut hi) = (i, i + 1);
        if self.has_kink(i, n) {
            if theta <= self.pair(i, n, KINK) {
                hi = i;
            } else {
                lo = i + 1;
            }
        }
        // Grow towards the centred stencil i−1..i+2, then to 3 nodes if needed.
        let (want_lo, want_hi) = (i.saturating_sub(1), (i + 2).min(last));
        while lo > want_lo && !self.has_kink(lo - 1, n) {
            lo -= 1;
        }
        while hi < want_hi && !self.has_kink(hi, n) {
            hi += 1;
        }
        while hi - lo < 2 {
            if lo > 0 && !self.has_kink(lo - 1, n) && (hi >= last || self.has_kink(hi, n) || theta < node_theta(lo)) {
                lo -= 1;
            } else if hi < last && !self.has_kink(hi, n) {
                hi += 1;
            } else {
                break;
            }
        }
        let x = s;
        let mut out = [0.0; K];
        for j in lo..=hi {
            // Lagrange basis in node-index units.
            let w: f64 = (lo..=hi)
                .filter(|&m| m != j)
                .map(|m| (x - m as f64) / (j as f64 - m as f64))
                .product();
            for (o, &q) in out.iter_mut().zip(&qs) {
                *o += w * self.pair(j, n, q);
            }
        }
        Ok(out)
    }

    /// Ren's log-ZH f_0..f_{n−1} of the visibility of a cap blocker of angular radius
    /// `theta_b` ∈ [0, π/2] (rad) about +z, order n ∈ 3..=8, into `out[..n]`. Turn it
    /// to the blocker's direction with [`crate::sh::zh_to_sh`] and sum over blockers.
    pub fn log_zh(&self, theta_b: f64, order: usize, out: &mut [f64]) -> Result<(), LookupError> {
        let n = check_order(order)?;
        if out.len() < n {
            return Err(LookupError::Channels {
                expected: n,
                got: out.len(),
            });
        }
        // Slots l ≥ n are stored as 0: interpolating all eight is harmless.
        let v = self.interp(theta_b, n, [0, 1, 2, 3, 4, 5, 6, 7])?;
        let s = one_minus_cos(theta_b);
        for (o, x) in out.iter_mut().zip(&v[..n]) {
            *o = x * s;
        }
        Ok(())
    }

    /// [`ShExp::log_zh`] with an f32 interface (computed in f64, rounded once).
    pub fn log_zh_f32(&self, theta_b: f32, order: usize, out: &mut [f32]) -> Result<(), LookupError> {
        let mut tmp = [0.0; 8];
        self.log_zh(crate::error::angle_f32(theta_b), order, &mut tmp)?;
        narrow_all("f", &tmp[..order], out)
    }

    /// [`ShExp::norm_ab`] with an f32 interface (computed in f64, rounded once).
    pub fn norm_ab_f32(&self, theta_b: f32, order: usize) -> Result<(f32, f32, f32), LookupError> {
        let (n, a, b) = self.norm_ab(crate::error::angle_f32(theta_b), order)?;
        Ok((narrow("|f_hat|", n)?, narrow("a", a)?, narrow("b", b)?))
    }

    /// [`ShExp::ab_for_norm`] with an f32 interface (computed in f64, rounded once).
    pub fn ab_for_norm_f32(&self, norm: f32, order: usize) -> Result<(f32, f32), LookupError> {
        let (a, b) = self.ab_for_norm(norm as f64, order)?;
        Ok((narrow("a", a)?, narrow("b", b)?))
    }

    /// ‖f̂‖ (the norm of the log-ZH without its DC term) and the OL coefficients
    /// (a, b) of the cap of radius `theta_b` ∈ [0, π/2] at order 3..=8.
    pub fn norm_ab(&self, theta_b: f64, order: usize) -> Result<(f64, f64, f64), LookupError> {
        let n = check_order(order)?;
        let [t, a, b] = self.interp(theta_b, n, [NORM, NORM + 1, NORM + 2])?;
        Ok((t * one_minus_cos(theta_b), a, b))
    }

    /// The largest ‖f̂‖ of the monotone branch of `order` (upper end of
    /// [`ShExp::ab_for_norm`]'s domain).
    pub fn norm_max(&self, order: usize) -> Result<f64, LookupError> {
        let br = &self.branches[check_order(order)? - ORDER_MIN];
        Ok(*br.norm.last().expect("validated on load"))
    }

    /// θ_b at the end of the monotone branch of `order` (rad).
    pub fn branch_end_theta(&self, order: usize) -> Result<f64, LookupError> {
        let br = &self.branches[check_order(order)? - ORDER_MIN];
        Ok(self.node_theta(br.norm.len() - 1))
    }

    /// OL coefficients (a, b) for ‖f̂‖ = `norm` ∈ [0, [`ShExp::norm_max`]] at order
    /// 3..=8: the cap on the monotone branch with that ‖f̂‖ (binary search, then linear
    /// in ‖f̂‖). (1, 1) at 0, the exact limit.
    pub fn ab_for_norm(&self, norm: f64, order: usize) -> Result<(f64, f64), LookupError> {
        let br = &self.branches[check_order(order)? - ORDER_MIN];
        let top = *br.norm.last().expect("validated on load");
        let x = in_range("|f_hat|", norm, 0.0, top)?;
        let j = br.norm.partition_point(|&v| v <= x).clamp(1, br.norm.len() - 1);
        let (x0, x1) = (br.norm[j - 1], br.norm[j]);
        let w = ((x - x0) / (x1 - x0)).clamp(0.0, 1.0);
        Ok((
            (1.0 - w) * br.a[j - 1] + w * br.a[j],
            (1.0 - w) * br.b[j - 1] + w * br.b[j],
        ))
    }

    /// HYB exp* of the SH vector `f` (n² coefficients, n ∈ 3..=8) into `out[..n²]`,
    /// with the order's default [`OL_THRESHOLD`]. Returns the number of squarings.
    pub fn hyb(&self, f: &[f64], out: &mut [f64]) -> Result<u32, LookupError> {
        let n = check_order(sh::order_of_len(f.len())?)?;
        self.hyb_threshold(f, OL_THRESHOLD[n - ORDER_MIN], out)
    }

    /// [`ShExp::hyb`] with an explicit OL threshold ∈ (0, [`ShExp::norm_max`]].
    pub fn hyb_threshold(&self, f: &[f64], threshold: f64, out: &mut [f64]) -> Result<u32, LookupError> {
        let n = check_order(sh::order_of_len(f.len())?)?;
        let top = self.norm_max(n)?;
        in_range("threshold", threshold, f64::MIN_POSITIVE, top)?;
        hyb_with(Gaunt::cached(n)?, f, threshold, |x| self.ab_for_norm(x, n), out)
    }

    /// SH visibility (order `order` ∈ 3..=8, n² coefficients into `out[..n²]`) at
    /// `point` of a set of spherical blockers `(centre, radius)`: each blocker's log-ZH
    /// ([`ShExp::log_zh`] of its [`crate::log_zh::sphere_cap`] angle) turned to its direction
    /// and summed, then exponentiated by HYB ([`ShExp::hyb`]). No blockers gives the
    /// unoccluded visibility (y₀₀ coefficient √(4π)). Returns HYB's number of squarings.
    pub fn hyb_spheres(
        &self,
        point: DVec3,
        spheres: &[(DVec3, f64)],
        order: usize,
        out: &mut [f64],
    ) -> Result<u32, LookupError> {
        let n = check_order(order)?;
        let nc = n * n;
        let (mut f, mut zh, mut turned) = ([0.0; MAX_COEFFS], [0.0; 8], [0.0; MAX_COEFFS]);
        for &(centre, radius) in spheres {
            let (dir, theta_b) = crate::log_zh::sphere_cap(point, centre, radius)?;
            self.log_zh(theta_b, n, &mut zh)?;
            sh::zh_to_sh(&zh[..n], dir, &mut turned[..nc])?;
            for (a, b) in f.iter_mut().zip(&turned[..nc]) {
                *a += b;
            }
        }
        self.hyb(&f[..nc], out)
    }

    /// [`ShExp::hyb_spheres`] with an f32 interface (computed in f64, rounded once).
    pub fn hyb_spheres_f32(
        &self,
        point: Vec3,
        spheres: &[(Vec3, f32)],
        order: usize,
        out: &mut [f32],
    ) -> Result<u32, LookupError> {
        let n = check_order(order)?;
        let wide: Vec<(DVec3, f64)> = spheres.iter().map(|&(c, r)| (c.as_dvec3(), r as f64)).collect();
        let mut tmp = [0.0; MAX_COEFFS];
        let k = self.hyb_spheres(point.as_dvec3(), &wide, n, &mut tmp)?;
        narrow_all("SH visibility", &tmp[..n * n], out)?;
        Ok(k)
    }

    /// [`ShExp::hyb`] with an f32 interface (computed in f64, rounded once).
    pub fn hyb_f32(&self, f: &[f32], out: &mut [f32]) -> Result<u32, LookupError> {
        widened(f, out, |a, b| self.hyb(a, b))
    }

    /// [`ShExp::hyb_threshold`] with an f32 interface (computed in f64, rounded once).
    pub fn hyb_threshold_f32(&self, f: &[f32], threshold: f32, out: &mut [f32]) -> Result<u32, LookupError> {
        widened(f, out, |a, b| self.hyb_threshold(a, threshold as f64, b))
    }
}

/// Runs an f64 SH → SH map `run` on f32 coefficients `f`, rounding its output into
/// `out[..f.len()]` once (an error where a value overflows f32).
fn widened(
    f: &[f32],
    out: &mut [f32],
    run: impl FnOnce(&[f64], &mut [f64]) -> Result<u32, LookupError>,
) -> Result<u32, LookupError> {
    let nc = f.len();
    if nc > MAX_COEFFS {
        return Err(LookupError::Arity {
            expected: MAX_COEFFS,
            got: nc,
        });
    }
    if out.len() < nc {
        return Err(LookupError::Channels {
            expected: nc,
            got: out.len(),
        });
    }
    let mut a = [0.0; MAX_COEFFS];
    let mut b = [0.0; MAX_COEFFS];
    for (x, v) in a.iter_mut().zip(f) {
        *x = *v as f64;
    }
    let k = run(&a[..nc], &mut b)?;
    narrow_all("exp*(f)", &b[..nc], &mut out[..nc])?;
    Ok(k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_constants() {
        assert_eq!(channel_names().len(), 2 * PAIRS);
        assert_eq!(channel_names()[2 * NORM], "norm_hi");
        assert_eq!(channel_names()[2 * KINK + 1], "kink_lo");
    }

    /// OL with (a, b) = (1, 1) is the first-order Taylor polynomial; HYB of a pure DC
    /// term is its exponential.
    #[test]
    fn hyb_of_constant_and_small_vector() {
        let g = Gaunt::new(3);
        let mut f = [0.0; 9];
        f[0] = -1.5 * (4.0 * PI).sqrt();
        let mut out = [0.0; 9];
        let k = hyb_with(&g, &f, 1.0, |_| Ok((1.0, 1.0)), &mut out).unwrap();
        assert_eq!(k, 0);
        assert!((out[0] / (4.0 * PI).sqrt() - (-1.5f64).exp()).abs() < 1e-15);
        assert!(out[1..].iter().all(|v| *v == 0.0));
    }

    #[test]
    fn hyb_bad_inputs() {
        let g = Gaunt::new(3);
        let mut out = [0.0; 9];
        let ok = |_| Ok((1.0, 1.0));
        assert!(matches!(
            hyb_with(&g, &[0.0; 4], 1.0, ok, &mut out),
            Err(LookupError::Coefficients { .. })
        ));
        assert!(matches!(
            hyb_with(&g, &[0.0; 9], 1.0, ok, &mut out[..4]),
            Err(LookupError::Output { .. })
        ));
        assert!(matches!(
            hyb_with(&g, &[f64::NAN; 9], 1.0, ok, &mut out),
            Err(LookupError::NotFinite { .. })
        ));
        assert!(matches!(
            hyb_with(&g, &[0.0; 9], 0.0, ok, &mut out),
            Err(LookupError::OutOfDomain { .. })
        ));
        let mut big = [0.0; 9];
        big[3] = 1e100;
        assert!(matches!(
            hyb_with(&g, &big, 1.0, ok, &mut out),
            Err(LookupError::OutOfDomain { .. })
        ));
    }
}
