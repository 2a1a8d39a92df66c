//! height-field wedges (Giraud & Nowrouzezahrai 2015 §4.5.1): the M_lin
//! operator table (registry family `wedge`) and the slice-vector eval view
//! (`lobefit eval wedge --order N`: sigma, eps → v0…v(N−1)).
//!
//! Fit of \[M_lin\]_{i,j}: the integrand separates, y_i(θ, φ) = Θ_i(θ) Φ_i(φ) with
//! Φ ∈ {1, cos mφ, sin |m|φ}, so M = T · Q with T = ∫_0^π P̂_{j mod 8}(cosθ) Θ_i sinθ dθ
//! by Gauss–Legendre in θ (the integrand is an entire trigonometric polynomial; 48
//! and 64 points agree to rounding, which is the entry's residual) and
//! Q = ∫_0^{Δφ} I_j(φ) Φ_i(φ) dφ in closed form. Reference (checker): the same
//! separation, both factors by adaptive Gauss–Kronrod.

pub mod gpu;

use std::f64::consts::PI;

use lobefit_tables::format::Threshold;
use lobefit_tables::sh::{eval_basis, MAX_COEFFS, MAX_ORDER};
use lobefit_tables::wedge::{self as rt, Wedge, CHANNELS, COLS, ROWS, WEDGE_COUNTS};
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};

use lobefit_core::family::{Checked, Fit, Fitted, Lookup, View};
use lobefit_core::quad::gauss_kronrod;
use lobefit_core::rng::Rng;
use lobefit_tables::error::short;

/// Gauss–Legendre points in θ of the fit, and of its convergence cross-check.
const GL_POINTS: [usize; 2] = [48, 64];
/// Largest |GL48 − GL64| for an entry to be written.
const MAX_RESIDUAL: f64 = 1e-13;
/// Checked accuracy of every entry (absolute; entries are ≤ 1 in magnitude).
pub const ACCURACY_ABS: f64 = 1e-12;
/// Absolute tolerance of each factor of the checker's Gauss–Kronrod reference.
const REFERENCE_TOL: f64 = 1e-15;

/// The M_lin table family.
#[derive(Debug, Clone, Copy, Default)]
pub struct WedgeFamily;

/// Θ_i(θ) = y_l^{|m|}(θ, φ = 0) (so y_i = Θ_i Φ_i).
fn theta_part(i: usize, theta: f64) -> f64 {
    let (l, m) = lobefit_tables::sh::band_of(i);
    let mut y = [0.0; MAX_COEFFS];
    eval_basis(l + 1, [theta.sin(), 0.0, theta.cos()], &mut y).expect("valid direction");
    y[lobefit_tables::sh::index(l, m.abs())]
}

/// Φ_i(φ): 1, cos(mφ) (m > 0) or sin(|m|φ) (m < 0).
fn phi_part(i: usize, phi: f64) -> f64 {
    let (_, m) = lobefit_tables::sh::band_of(i);
    match m.cmp(&0) {
        std::cmp::Ordering::Equal => 1.0,
        std::cmp::Ordering::Greater => (m as f64 * phi).cos(),
        std::cmp::Ordering::Less => (-m as f64 * phi).sin(),
    }
}

/// P̂_l(t) = √((2l+1)/2) P_l(t).
pub fn nlp(l: usize, t: f64) -> f64 {
    ((2 * l + 1) as f64 / 2.0).sqrt() * lobefit_core::sh::legendre(l, t)
}

/// ∫_0^D w(φ) Φ_i(φ) dφ with w = 1 − φ/D (`second` false) or φ/D (true), closed form.
fn phi_integral(i: usize, d: f64, second: bool) -> f64 {
    let (_, m) = lobefit_tables::sh::band_of(i);
    let k = m.unsigned_abs() as f64;
    // (∫Φ, ∫φΦ) over [0, D].
    let (i0, i1) = match m.cmp(&0) {
        std::cmp::Ordering::Equal => (d, d * d / 2.0),
        std::cmp::Ordering::Greater => (
            (k * d).sin() / k,
            d * (k * d).sin() / k + ((k * d).cos() - 1.0) / (k * k),
        ),
        std::cmp::Ordering::Less => (
            (1.0 - (k * d).cos()) / k,
            -d * (k * d).cos() / k + (k * d).sin() / (k * k),
        ),
    };
    if second {
        i1 / d
    } else {
        i0 - i1 / d
    }
}

/// Whether \[M_lin\]_{row, col} is zero by symmetry: the θ factor ∫ P̂_j P_l^{|m|} dt
/// vanishes when l + |m| + j is odd (parity in t) and, for m = 0, when l ≠ j
/// (Legendre orthogonality), and for even m when j > l (P_l^{|m|} is then a polynomial of
/// degree l, orthogonal to P̂_j). Quadrature returns rounding noise (~1e-17) there, which
/// would make relative errors meaningless, so both fit and reference return exact 0.
/// Also zero: the φ factor of cos(mφ) rows when m Δφ is a multiple of 2π (m = W = 4).
pub fn structural_zero(w: u32, row: usize, col: usize) -> bool {
    let (l, m) = lobefit_tables::sh::band_of(row);
    let j = col % MAX_ORDER;
    !(l + m.unsigned_abs() as usize + j).is_multiple_of(2)
        || (m == 0 && l != j)
        || (m % 2 == 0 && j > l)
        || (m > 0 && (m as u32).is_multiple_of(w))
}

/// \[M_lin\]_{row, col} (order-8 layout: col < 8 first slice, col ≥ 8 second) by
/// `points`-point Gauss–Legendre in θ and the closed-form φ factor.
pub fn m_lin_gl(w: u32, row: usize, col: usize, points: usize) -> f64 {
    if structural_zero(w, row, col) {
        return 0.0;
    }
    let (x, wt) = lobefit_core::sh::gauss_legendre(points);
    let j = col % MAX_ORDER;
    let t: f64 = x
        .iter()
        .zip(&wt)
        .map(|(xi, wi)| {
            let theta = 0.5 * PI * (xi + 1.0);
            0.5 * PI * wi * nlp(j, theta.cos()) * theta_part(row, theta) * theta.sin()
        })
        .sum();
    t * phi_integral(row, 2.0 * PI / w as f64, col >= MAX_ORDER)
}

/// Checker reference for \[M_lin\]_{row, col}: both separated factors by adaptive GK.
pub fn reference_m_lin(w: u32, row: usize, col: usize) -> Result<f64, String> {
    if !WEDGE_COUNTS.contains(&w) || row >= ROWS as usize || col >= COLS as usize {
        return Err(format!("no M_lin entry W={w}, row={row}, col={col}"));
    }
    if structural_zero(w, row, col) {
        return Ok(0.0);
    }
    let j = col % MAX_ORDER;
    let d = 2.0 * PI / w as f64;
    let qt = gauss_kronrod(
        |th| nlp(j, th.cos()) * theta_part(row, th) * th.sin(),
        0.0,
        PI,
        &[PI / 2.0],
        REFERENCE_TOL,
        0.0,
        1000,
    );
    let second = col >= MAX_ORDER;
    let qp = gauss_kronrod(
        |ph| {
            let a = ph / d;
            (if second { a } else { 1.0 - a }) * phi_part(row, ph)
        },
        0.0,
        d,
        &[],
        REFERENCE_TOL,
        0.0,
        1000,
    );
    if !(qt.converged && qp.converged) {
        return Err(format!(
            "reference quadrature did not converge at W={w}, row={row}, col={col}"
        ));
    }
    Ok(qt.value * qp.value)
}

/// Checker reference of the slice vector: ln ε ∫_{π/2−σ}^{π} P̂_l(cosθ) sinθ dθ by GK.
pub fn reference_slice(sigma: f64, eps: f64, order: usize) -> Result<Vec<f64>, String> {
    if !(-PI / 2.0..=PI / 2.0).contains(&sigma) {
        return Err(format!("sigma = {sigma} is outside [-π/2, π/2]", sigma = short(sigma)));
    }
    if !(rt::EPS_MIN..=rt::EPS_MAX).contains(&eps) {
        return Err(format!(
            "eps = {eps} is outside [{}, {}]",
            rt::EPS_MIN,
            rt::EPS_MAX,
            eps = short(eps)
        ));
    }
    (0..order)
        .map(|l| {
            let q = gauss_kronrod(
                |th| nlp(l, th.cos()) * th.sin(),
                PI / 2.0 - sigma,
                PI,
                &[],
                1e-15,
                0.0,
                1000,
            );
            if q.converged {
                Ok(eps.ln() * q.value)
            } else {
                Err(format!("reference quadrature did not converge at sigma={sigma}"))
            }
        })
        .collect()
}

/// W of a node (the log-mapped axis gives 4·2^k up to rounding).
fn node_w(x: f64) -> u32 {
    x.round() as u32
}

/// The runtime type as the checker's [`Lookup`] (a local type: the trait and
/// [`Wedge`] live in other crates).
struct WedgeLookup(Wedge);

impl Lookup for WedgeLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        Ok(vec![self.0.m_lin(
            node_w(x[0]),
            MAX_ORDER,
            x[1] as usize,
            x[2] as usize,
        )?])
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        let m = self.0.m_lin_f32(node_w(x[0]), MAX_ORDER, x[1] as usize, x[2] as usize);
        Some(m.map(|v| vec![v.into()]))
    }
}

impl View for WedgeFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["W", "row", "col"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["m"]
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::WEDGE
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(WedgeLookup(Wedge::from_table(table)?)))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        Ok(vec![reference_m_lin(node_w(x[0]), x[1] as usize, x[2] as usize)?])
    }
}

impl Checked for WedgeFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        ["grid.max_abs", "offgrid.max_abs"]
            .iter()
            .map(|m| Threshold {
                output: "m".into(),
                metric: m.to_string(),
                limit: ACCURACY_ABS,
            })
            .collect()
    }
    fn node_inputs(&self, node: &[f64]) -> Vec<Vec<f64>> {
        vec![vec![node_w(node[0]) as f64, node[1].round(), node[2].round()]]
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        // The table is a set of matrices: "off-grid" points are random entries.
        let w = WEDGE_COUNTS[(rng.uniform() * 5.0) as usize % 5];
        let row = (rng.uniform() * ROWS as f64) as u32 % ROWS;
        let col = (rng.uniform() * COLS as f64) as u32 % COLS;
        vec![w as f64, row as f64, col as f64]
    }
}

impl Fit for WedgeFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        "Height-field wedge operator M_lin (Giraud & Nowrouzezahrai 2015 eq. 4.19), order 8, for \
         W = 4, 8, 16, 32, 64 wedges: [M_lin]_{i,j} = ∫_0^{2π/W} ∫_0^π I_j(α) P̂_{j mod 8}(cos θ) \
         y_i(θ, φ) sin θ dθ dφ, I_j = 1 − α (j < 8) or α (j ≥ 8), α = φ W/(2π). Order-n operator = \
         rows i < n², columns j mod 8 < n. Value = m_hi + m_lo (f32 pair)."
            .into()
    }
    fn axes(&self) -> Vec<Axis> {
        rt::axes()
    }
    fn channels(&self) -> Vec<Channel> {
        vec![
            Channel {
                name: CHANNELS[0].into(),
                unit: "1".into(),
                encoding: Encoding::Linear,
                description: "f32 rounding of [M_lin]_{row,col}".into(),
            },
            Channel {
                name: CHANNELS[1].into(),
                unit: "1".into(),
                encoding: Encoding::Linear,
                description: "[M_lin]_{row,col} − m_hi, rounded to f32".into(),
            },
        ]
    }
    fn method(&self) -> String {
        "separable: Gauss-Legendre in theta, closed form in phi".into()
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("gl_points".into(), format!("{:?}", GL_POINTS)),
            ("max_residual".into(), format!("{MAX_RESIDUAL:e}")),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "|GL48 − GL64| of the entry"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let (w, row, col) = (node_w(node[0]), node[1] as usize, node[2] as usize);
        let a = m_lin_gl(w, row, col, GL_POINTS[0]);
        let b = m_lin_gl(w, row, col, GL_POINTS[1]);
        let hi = b as f32;
        let lo = (b - hi as f64) as f32;
        Fitted {
            values: vec![hi as f64, lo as f64],
            residual: (a - b).abs(),
            iterations: (GL_POINTS[0] + GL_POINTS[1]) as u32,
            converged: (a - b).abs() <= MAX_RESIDUAL,
        }
    }
}

/// Output columns v0..v7 of the slice view.
const SLICE_OUTPUTS: [&str; MAX_ORDER] = ["v0", "v1", "v2", "v3", "v4", "v5", "v6", "v7"];

/// `lobefit eval wedge --order N`: the slice vector v^log(σ) (closed form in the
/// runtime; `--exact` = GK quadrature). Shares the `wedge` table file (validated on
/// load) with [`WedgeFamily`].
#[derive(Debug, Clone, Copy)]
pub struct WedgeSliceView {
    /// SH order n.
    pub order: usize,
}

struct SliceLookup {
    order: usize,
}

impl Lookup for SliceLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let mut v = [0.0; MAX_ORDER];
        rt::slice_log(x[0], x[1], self.order, &mut v)?;
        Ok(v[..self.order].to_vec())
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        let mut v = [0.0f32; MAX_ORDER];
        let r = rt::slice_log_f32(x[0] as f32, x[1] as f32, self.order, &mut v);
        Some(r.map(|()| v[..self.order].iter().map(|&c| c.into()).collect()))
    }
}

impl View for WedgeSliceView {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["sigma", "eps"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &SLICE_OUTPUTS[..self.order]
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::WEDGE
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Wedge::from_table(table)?;
        Ok(Box::new(SliceLookup { order: self.order }))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        reference_slice(x[0], x[1], self.order)
    }
}

/// wedge in the list of families (`crate::entries`): `eval wedge --order N`
/// reads one order's slice.
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| vec![Box::new(WedgeFamily)],
    eval: Some(|_, flags, _| {
        let order = flags.count("order")?.unwrap_or(crate::log_zh::DEFAULT_ORDER);
        if !(1..=8).contains(&order) {
            return Err(format!("wedge: --order {order} is outside 1..=8"));
        }
        Ok(Box::new(WedgeSliceView { order }))
    }),
    eval_names: &[],
    eval_flags: &[(rt::KIND, &[crate::log_zh::ORDER_FLAG])],
    gpu: &[gpu::GPU],
    closed_form: None,
    plot: None,
    eval_help: "\
wedge  [--order N] (1..8, default 4)
  in   `sigma`    horizon elevation of a height-field slice (rad), [−π/2, π/2]
       `eps`      log-visibility value ε of blocked directions, [0.01, 0.99]
  out  `v0` … `v7`  (the first N) the slice's log-visibility vector v_l^log(σ)
",
};

#[cfg(test)]
mod tests {
    use super::*;

    /// The structural zeros are zeros: GK of the θ factor without the shortcut.
    #[test]
    fn structural_zeros_vanish() {
        let mut n = 0;
        for row in 0..64 {
            for j in 0..8 {
                if structural_zero(64, row, j) {
                    let q = gauss_kronrod(
                        |th| nlp(j, th.cos()) * theta_part(row, th) * th.sin(),
                        0.0,
                        PI,
                        &[],
                        1e-16,
                        0.0,
                        1000,
                    );
                    assert!(q.value.abs() < 1e-15, "row={row} j={j}: {}", q.value);
                    n += 1;
                }
            }
        }
        assert!(n > 200);
        // The φ-factor zeros: cos(4φ) over a quarter turn, both weights.
        for second in [false, true] {
            let d = PI / 2.0;
            let q = gauss_kronrod(
                |p| (if second { p / d } else { 1.0 - p / d }) * (4.0 * p).cos(),
                0.0,
                d,
                &[],
                1e-17,
                0.0,
                100,
            );
            assert!(q.value.abs() < 1e-15);
        }
    }

    /// The closed-form φ factor against GK, every |m| and both halves.
    #[test]
    fn phi_factor_closed_form() {
        for &w in &WEDGE_COUNTS {
            let d = 2.0 * PI / w as f64;
            for i in 0..64 {
                for second in [false, true] {
                    let q = gauss_kronrod(
                        |p| (if second { p / d } else { 1.0 - p / d }) * phi_part(i, p),
                        0.0,
                        d,
                        &[],
                        1e-16,
                        0.0,
                        100,
                    );
                    assert!((q.value - phi_integral(i, d, second)).abs() < 1e-14, "W={w} i={i}");
                }
            }
        }
    }

    /// Slice closed form vs the GK reference at all orders (off-grid σ, ε).
    #[test]
    fn slice_closed_form_matches_quadrature_all_orders() {
        let mut worst: f64 = 0.0;
        let mut rng = Rng::new(8);
        for _ in 0..300 {
            let (s, e) = (rng.range(-PI / 2.0, PI / 2.0), rng.range(0.01, 0.99));
            let want = reference_slice(s, e, 8).unwrap();
            let mut got = [0.0; 8];
            rt::slice_log(s, e, 8, &mut got).unwrap();
            for l in 0..8 {
                worst = worst.max((got[l] - want[l]).abs() / want[l].abs().max(1e-3));
            }
        }
        eprintln!("wedge slice closed form vs GK: worst rel (abs below 1e-3) {worst:.2e}");
        assert!(worst < 1e-9);
    }
}
