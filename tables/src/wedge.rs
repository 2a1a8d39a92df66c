//! height-field wedge visibility in log-SH space (Giraud & Nowrouzezahrai 2015 §4.5.1).
//!
//! **Slice.** In azimuth φ a height field hides everything below its horizon
//! elevation σ (rad; σ = 0 is the tangent plane, σ > 0 above it, σ ∈ [−π/2, π/2]):
//! directions with θ > π/2 − σ are blocked. The slice's log-visibility in the
//! normalised-Legendre (NLP) basis P̂_l = √((2l+1)/2) P_l is
//! v^log_l(σ) = ∫_{π/2−σ}^{π} ln ε P̂_l(cosθ) sinθ dθ = ln ε ∫_{−1}^{sin σ} P̂_l(t) dt
//! = ln ε √((2l+1)/2) (P_{l+1} − P_{l−1})(sin σ)/(2l+1) (l ≥ 1), ln ε (sin σ + 1)/√2 (l = 0)
//! ([`slice_log`], closed form, any order ≤ 8; at order 4 it is the thesis's eq. 4.15 form).
//!
//! **Wedge.** W slices at φ_k = kΔφ, Δφ = 2π/W. Between two slices the slice
//! functions are interpolated linearly in φ, α = (φ − φ_k)/Δφ, and the log-visibility is
//! 0 (visibility 1) outside the wedge. Its SH projection is V_k = M_lin [v_k; v_{k+1}]
//! with the n² × 2n operator
//! \[M_lin\]_{i,j} = ∫_0^{Δφ} ∫_0^π \[I_lin\]_j P̂_{j mod n}(cosθ) y_i(θ, φ) sinθ dθ dφ,
//! I_lin = (1−α, …, 1−α, α, …, α) (n entries each), for the canonical wedge [0, Δφ].
//! The table stores M_lin of order 8 for W ∈ {4, 8, 16, 32, 64}; the order-n operator
//! is its sub-block (rows i < n², columns j mod 8 < n of each half), since entries do
//! not depend on n. Values are stored as f32 pairs (hi + lo) so the sum carries
//! ~1e-15 relative precision.
//!
//! **Composition** ([`Wedge::compose`]): V = Σ_k Rot_z(V_k, φ_k), the log-SH
//! visibility of the whole height field at a point, from its W horizon angles. It is
//! linear in the slices: V = Σ_k C_k v_k with C_k = Rot_z(φ_k) M_a + Rot_z(φ_{k−1}) M_b
//! (M_a, M_b the halves of M_lin), so the W operators C_k (n² × n each) are built once
//! per (W, n) and a composition is W small matrix–vector products, no trigonometry.
//! All SH conventions are those of [`crate::sh`].

use std::f64::consts::PI;

use crate::error::{finite, in_range, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::sh::{self, MAX_ORDER};
use crate::table::Table;

/// Table kind.
pub const KIND: &str = "wedge";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Tabulated wedge counts.
pub const WEDGE_COUNTS: [u32; 5] = [4, 8, 16, 32, 64];
/// Rows of the stored operator (order-8 SH coefficients).
pub const ROWS: u32 = 64;
/// Columns of the stored operator (2 × 8 NLP coefficients).
pub const COLS: u32 = 16;
/// Smallest ε accepted by [`slice_log`] (as for the log-ZH vectors).
pub const EPS_MIN: f64 = 0.01;
/// Largest ε accepted.
pub const EPS_MAX: f64 = 0.99;
/// Channels: the operator entry as an f32 pair, value = hi + lo.
pub const CHANNELS: [&str; 2] = ["m_hi", "m_lo"];

/// Bound on |M_lin| entries: by Cauchy–Schwarz over the wedge,
/// |∫ I_lin P̂_j y_i dω| ≤ (∫_wedge P̂_j²)^{1/2} (∫_wedge y_i²)^{1/2} ≤ √Δφ · 1 ≤ √(2π/4)
/// = 1.2533 (|I_lin| ≤ 1, P̂_j normalised on [−1, 1], W ≥ 4); with margin, 1.3.
const M_BOUND: f64 = 1.3;

/// Plausible range of each stored channel (name, lo, hi), dimensionless: ±1.3 for
/// `m_hi` (see the bound above), and half an f32 ulp of such a value (6e-8) with
/// margin, ±1e-7, for `m_lo`.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const CHANNEL_RANGES: &[(&str, f64, f64)] = &[(CHANNELS[0], -M_BOUND, M_BOUND), (CHANNELS[1], -1e-7, 1e-7)];

/// Axes, slowest first: `W` (5 nodes 4..64 uniform in ln W), `row` (0..63), `col` (0..15).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axes() -> Vec<Axis> {
    vec![
        Axis {
            name: "W".into(),
            unit: "1".into(),
            lo: 4.0,
            hi: 64.0,
            mapping: Mapping::Log,
            count: WEDGE_COUNTS.len() as u32,
            placement: Placement::Endpoints,
        },
        Axis {
            name: "row".into(),
            unit: "1".into(),
            lo: 0.0,
            hi: (ROWS - 1) as f64,
            mapping: Mapping::Linear,
            count: ROWS,
            placement: Placement::Endpoints,
        },
        Axis {
            name: "col".into(),
            unit: "1".into(),
            lo: 0.0,
            hi: (COLS - 1) as f64,
            mapping: Mapping::Linear,
            count: COLS,
            placement: Placement::Endpoints,
        },
    ]
}

/// Log-visibility slice vector v^log(σ) in the NLP basis, l < n, into `out[..n]`
/// (closed form; `sigma` ∈ [−π/2, π/2] rad, `eps` ∈ [0.01, 0.99]).
pub fn slice_log(sigma: f64, eps: f64, order: usize, out: &mut [f64]) -> Result<(), LookupError> {
    let n = sh::check_order(order)?;
    let sigma = in_range("sigma", sigma, -PI / 2.0, PI / 2.0)?;
    let eps = in_range("eps", eps, EPS_MIN, EPS_MAX)?;
    if out.len() < n {
        return Err(LookupError::Output {
            got: out.len(),
            needed: n,
            what: "slice coefficients",
        });
    }
    let x = sigma.sin();
    let mut p = [0.0; MAX_ORDER + 1];
    p[0] = 1.0;
    p[1] = x;
    for l in 2..=MAX_ORDER {
        p[l] = ((2 * l - 1) as f64 * x * p[l - 1] - (l - 1) as f64 * p[l - 2]) / l as f64;
    }
    let le = eps.ln();
    // 1 + sin σ = 2 cos²(π/4 − σ/2), accurate near σ = −π/2.
    let c = (PI / 4.0 - sigma / 2.0).cos();
    out[0] = le * 2.0 * c * c / std::f64::consts::SQRT_2;
    for l in 1..n {
        out[l] = le * ((2 * l + 1) as f64 / 2.0).sqrt() * (p[l + 1] - p[l - 1]) / (2 * l + 1) as f64;
    }
    Ok(())
}

/// [`slice_log`] with an f32 interface (computed in f64, rounded once).
pub fn slice_log_f32(sigma: f32, eps: f32, order: usize, out: &mut [f32]) -> Result<(), LookupError> {
    let mut tmp = [0.0; MAX_ORDER];
    slice_log(sigma as f64, eps as f64, order, &mut tmp)?;
    crate::error::narrow_all("v_log", &tmp[..order], out)
}

/// The wedge operators M_lin (order 8) for W ∈ {4, 8, 16, 32, 64}.
#[derive(Debug, Clone)]
pub struct Wedge {
    table: Table,
    /// Decoded operators, [w][row][col] flattened, f64.
    m: Vec<f64>,
    /// The composition's per-slice operators C_k for each (W index, order − 1), built on
    /// first use: [k][row][j] flattened (W × n² × n).
    composed: [[std::sync::OnceLock<Vec<f64>>; MAX_ORDER]; WEDGE_COUNTS.len()],
}

crate::table_type::impl_table_type!(Wedge: KIND, VERSION);

impl Wedge {
    /// Wraps an already loaded table, checking its kind, version and layout.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        let meta = table.meta();
        let chans_ok = meta.channels.len() == 2
            && meta
                .channels
                .iter()
                .zip(CHANNELS)
                .all(|(c, n)| c.name == n && c.encoding == Encoding::Linear);
        if meta.axes != axes() || !chans_ok {
            return Err(LoadError::LayoutMismatch {
                kind: KIND.into(),
                detail: "expected axes W (4..64, ln, 5) × row (0..63) × col (0..15) and channels m_hi, m_lo".into(),
            });
        }
        table.expect_channel_ranges(CHANNEL_RANGES)?;
        let m = table
            .values()
            .chunks_exact(2)
            .map(|c| c[0] as f64 + c[1] as f64)
            .collect();
        Ok(Self {
            table,
            m,
            composed: Default::default(),
        })
    }

    /// The per-slice operators C_k of the composition for W = `w` (index `wi`) at order
    /// `n`: C_k = Rot_z(φ_k) M_a + Rot_z(φ_{k−1}) M_b, [k][row][j] flattened.
    fn slice_operators(&self, wi: usize, w: usize, n: usize) -> Result<&[f64], LookupError> {
        if let Some(c) = self.composed[wi][n - 1].get() {
            return Ok(c);
        }
        let nc = n * n;
        let dphi = 2.0 * PI / w as f64;
        // Rot_z(φ) applied to a column of M_a or M_b.
        let mut built = vec![0.0; w * nc * n];
        let (mut col, mut turned) = ([0.0; sh::MAX_COEFFS], [0.0; sh::MAX_COEFFS]);
        for k in 0..w {
            for (half, wedge) in [(0, k), (MAX_ORDER, (k + w - 1) % w)] {
                for j in 0..n {
                    for (row, c) in col.iter_mut().take(nc).enumerate() {
                        *c = self.m[(wi * ROWS as usize + row) * COLS as usize + half + j];
                    }
                    sh::rotate_z(&col[..nc], wedge as f64 * dphi, &mut turned[..nc])?;
                    for row in 0..nc {
                        built[(k * nc + row) * n + j] += turned[row];
                    }
                }
            }
        }
        Ok(self.composed[wi][n - 1].get_or_init(|| built))
    }

    fn w_index(w: u32) -> Result<usize, LookupError> {
        WEDGE_COUNTS
            .iter()
            .position(|&c| c == w)
            .ok_or(LookupError::OutOfDomain {
                name: "wedge count W (one of 4, 8, 16, 32, 64)".into(),
                value: w as f64,
                lo: 4.0,
                hi: 64.0,
            })
    }

    /// \[M_lin\]_{row, col} of order n for W wedges: row < n², col < 2n (col < n weighs
    /// the wedge's first slice by 1−α, col ≥ n the second by α).
    pub fn m_lin(&self, w: u32, order: usize, row: usize, col: usize) -> Result<f64, LookupError> {
        let n = sh::check_order(order)?;
        let wi = Self::w_index(w)?;
        if row >= n * n || col >= 2 * n {
            return Err(LookupError::OutOfDomain {
                name: "M_lin index (row < n², col < 2n)".into(),
                value: (row.max(col)) as f64,
                lo: 0.0,
                hi: (n * n - 1) as f64,
            });
        }
        let stored_col = (col / n) * MAX_ORDER + col % n;
        Ok(self.m[(wi * ROWS as usize + row) * COLS as usize + stored_col])
    }

    /// [`Wedge::m_lin`] rounded to f32 (the stored hi + lo pair, summed in f64).
    pub fn m_lin_f32(&self, w: u32, order: usize, row: usize, col: usize) -> Result<f32, LookupError> {
        crate::error::narrow("M_lin", self.m_lin(w, order, row, col)?)
    }

    /// V = M_lin [v_a; v_b] for one canonical wedge [0, Δφ] (n² outputs into `out`).
    pub fn wedge(&self, w: u32, v_a: &[f64], v_b: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
        let n = sh::check_order(v_a.len())?;
        if v_b.len() != n {
            return Err(LookupError::Coefficients {
                name: "v_b",
                got: v_b.len(),
                expected: format!("{n}, as many as v_a"),
            });
        }
        if out.len() < n * n {
            return Err(LookupError::Output {
                got: out.len(),
                needed: n * n,
                what: "SH coefficients",
            });
        }
        let wi = Self::w_index(w)?;
        for (name, v) in [("v_a", v_a), ("v_b", v_b)] {
            for x in v {
                finite(name, *x)?;
            }
        }
        for (row, o) in out.iter_mut().take(n * n).enumerate() {
            let base = (wi * ROWS as usize + row) * COLS as usize;
            let mut s = 0.0;
            for j in 0..n {
                s += self.m[base + j] * v_a[j] + self.m[base + MAX_ORDER + j] * v_b[j];
            }
            // Huge finite slices can overflow the sum.
            *o = crate::error::finite_result("V (wedge SH coefficient)", s)?;
        }
        Ok(())
    }

    /// Log-SH visibility (order n, n² values into `out`) of a height-field point from
    /// its horizon elevations `sigma[k]` (rad) in the W = `sigma.len()` azimuths
    /// φ_k = 2πk/W (from +x towards +y, about the surface normal +z): wedge k between
    /// slices k and k+1 (mod W) by M_lin, turned to φ_k about z, summed.
    pub fn compose(&self, sigma: &[f64], eps: f64, order: usize, out: &mut [f64]) -> Result<(), LookupError> {
        let n = sh::check_order(order)?;
        let w = sigma.len() as u32;
        Self::w_index(w)?;
        if out.len() < n * n {
            return Err(LookupError::Output {
                got: out.len(),
                needed: n * n,
                what: "SH coefficients",
            });
        }
        let mut slices = [0.0; 64 * MAX_ORDER];
        for (k, &s) in sigma.iter().enumerate() {
            finite("sigma", s)?;
            slice_log(s, eps, n, &mut slices[k * n..(k + 1) * n])?;
        }
        self.compose_slices(&slices[..sigma.len() * n], n, out)
    }

    /// [`Wedge::compose`] from the W slice vectors themselves (`slices[k·n..(k+1)·n]` is
    /// slice k's NLP vector, W = `slices.len()`/n ∈ {4, …, 64}): any log-visibility
    /// that is a function of the elevation in each azimuth, e.g. [`slice_log`] of the
    /// horizon minus [`slice_log`] of a lower bound (blocked only between the two).
    pub fn compose_slices(&self, slices: &[f64], order: usize, out: &mut [f64]) -> Result<(), LookupError> {
        let n = sh::check_order(order)?;
        let w = slices.len() / n;
        let wi = Self::w_index(w as u32)?;
        if slices.len() != w * n {
            return Err(LookupError::Coefficients {
                name: "slices",
                got: slices.len(),
                expected: format!("W × {n} (W wedges, {n} per slice)"),
            });
        }
        if out.len() < n * n {
            return Err(LookupError::Output {
                got: out.len(),
                needed: n * n,
                what: "SH coefficients",
            });
        }
        for &v in slices {
            finite("slice coefficient", v)?;
        }
        let c = self.slice_operators(wi, w, n)?;
        let nc = n * n;
        out[..nc].iter_mut().for_each(|o| *o = 0.0);
        for (k, v) in slices.chunks_exact(n).enumerate() {
            let ck = &c[k * nc * n..(k + 1) * nc * n];
            for (row, o) in out.iter_mut().take(nc).enumerate() {
                *o += ck[row * n..(row + 1) * n]
                    .iter()
                    .zip(v)
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
            }
        }
        // Huge finite slices can overflow the sums.
        crate::error::finite_results("V (log-SH visibility)", &out[..nc])
    }

    /// [`Wedge::compose`] with an f32 interface (computed in f64, rounded once).
    pub fn compose_f32(&self, sigma: &[f32], eps: f32, order: usize, out: &mut [f32]) -> Result<(), LookupError> {
        let n = sh::check_order(order)?;
        let wide: Vec<f64> = sigma.iter().map(|&s| s as f64).collect();
        let mut tmp = [0.0; sh::MAX_COEFFS];
        self.compose(&wide, eps as f64, n, &mut tmp[..n * n])?;
        crate::error::narrow_all("log-SH visibility", &tmp[..n * n], out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thesis's order-4 closed form (eq. 4.15, with ln ε factored out).
    #[test]
    fn matches_thesis_order_4() {
        for &s in &[-1.2, -0.3, 0.0, 0.4, 1.1, PI / 2.0] {
            let mut v = [0.0; 4];
            slice_log(s, 0.1, 4, &mut v).unwrap();
            let (sn, c2) = (f64::sin(s), f64::cos(s).powi(2));
            let le = 0.1f64.ln();
            let thesis = [
                le * (sn + 1.0) / 2f64.sqrt(),
                le * -3.0 * c2 / (2.0 * 6f64.sqrt()),
                le * -5.0 * sn * c2 / (2.0 * 10f64.sqrt()),
                le * 7.0 * c2 * (-4.0 + 5.0 * c2) / (8.0 * 14f64.sqrt()),
            ];
            for l in 0..4 {
                assert!(
                    (v[l] - thesis[l]).abs() < 1e-14,
                    "σ={s} l={l}: {} vs {}",
                    v[l],
                    thesis[l]
                );
            }
        }
    }

    #[test]
    fn bad_inputs() {
        let mut v = [0.0; 8];
        assert!(matches!(
            slice_log(2.0, 0.1, 4, &mut v),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            slice_log(f64::NAN, 0.1, 4, &mut v),
            Err(LookupError::NotFinite { .. })
        ));
        assert!(matches!(
            slice_log(0.1, 0.0, 4, &mut v),
            Err(LookupError::OutOfDomain { .. })
        ));
        assert!(matches!(
            slice_log(0.1, 0.1, 0, &mut v),
            Err(LookupError::OutOfDomain { .. })
        ));
    }
}
