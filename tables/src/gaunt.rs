//! The SH triple-product (Gaunt) tensor and the truncated SH product, shared by the
//! `lobefit` library (which builds tables with it) and renderers (SH exponentiation,
//! [`crate::shexp`]). Conventions of [`crate::sh`] (docs/math.md §1).
//!
//! Exactness: [`SphereRule`] is Gauss–Legendre in z = cosθ times the trapezoid rule
//! in φ. It integrates x^a y^b z^c exactly (to rounding) when the φ frequency
//! a+b < `n_phi` and the z-degree < 2 `n_z` (the φ-free factor (1−z²)^{(a+b)/2} is a
//! polynomial whenever the φ integral is non-zero). Products of three order-8 basis
//! functions have total degree ≤ 21, so [`SphereRule::exact_for_degree`]`(21)` gives
//! the Gaunt coefficients to rounding (checked against adaptive Gauss–Kronrod in the
//! `lobefit` crate's tests).

use std::f64::consts::PI;

use crate::error::LookupError;
use crate::sh::{self as rt, coeff_count, eval_basis, MAX_COEFFS, MAX_ORDER};
/// Gaunt entries below this magnitude are structural zeros: the smallest true non-zero
/// entry at order 8 is ~1e-3 (see tests), rounding noise of the exact rule is ~1e-17.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) const GAUNT_ZERO: f64 = 1e-10;

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_n, Golub-free and exact
/// to rounding for n ≤ a few hundred).
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Tricomi's initial guess, then Newton.
        let mut t = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, t);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * t * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if n == 0 { 1.0 } else { p1 };
            let pm1 = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (t * p - pm1) / (t * t - 1.0);
            let dt = p / dp;
            t -= dt;
            if dt.abs() < 1e-16 {
                break;
            }
        }
        x[i] = t;
        x[n - 1 - i] = -t;
        w[i] = 2.0 / ((1.0 - t * t) * dp * dp);
        w[n - 1 - i] = w[i];
    }
    if n % 2 == 1 {
        x[n / 2] = 0.0;
    }
    (x, w)
}

/// A product quadrature rule on the sphere (weights sum to 4π).
#[derive(Debug, Clone)]
pub struct SphereRule {
    /// Unit directions.
    pub points: Vec<[f64; 3]>,
    /// Solid-angle weights (sr).
    pub weights: Vec<f64>,
}

impl SphereRule {
    /// Gauss–Legendre (`n_z` nodes in cosθ) × trapezoid (`n_phi` nodes in φ).
    pub fn new(n_z: usize, n_phi: usize) -> SphereRule {
        let (zs, ws) = gauss_legendre(n_z);
        let mut points = Vec::with_capacity(n_z * n_phi);
        let mut weights = Vec::with_capacity(n_z * n_phi);
        for (&z, &w) in zs.iter().zip(&ws) {
            let s = (1.0 - z * z).sqrt();
            for k in 0..n_phi {
                let phi = 2.0 * PI * (k as f64 + 0.5) / n_phi as f64;
                points.push([s * phi.cos(), s * phi.sin(), z]);
                weights.push(w * 2.0 * PI / n_phi as f64);
            }
        }
        SphereRule { points, weights }
    }

    /// The smallest rule exact for polynomials in (x, y, z) of total degree ≤ `deg`.
    pub fn exact_for_degree(deg: usize) -> SphereRule {
        SphereRule::new(deg / 2 + 1, deg + 1)
    }

    /// ∫ f dω by the rule.
    pub fn integrate(&self, mut f: impl FnMut([f64; 3]) -> f64) -> f64 {
        self.points.iter().zip(&self.weights).map(|(&p, &w)| w * f(p)).sum()
    }

    /// SH projection ∫ f y_i dω, i < n², of `f` by the rule (exact when f is a
    /// polynomial of degree ≤ the rule's degree − (n−1)).
    pub fn project(&self, order: usize, mut f: impl FnMut([f64; 3]) -> f64) -> Vec<f64> {
        let nc = coeff_count(order);
        let mut out = vec![0.0; nc];
        let mut y = [0.0; MAX_COEFFS];
        for (&p, &w) in self.points.iter().zip(&self.weights) {
            eval_basis(order, p, &mut y).expect("rule points are unit vectors, order checked by caller");
            let fw = f(p) * w;
            for (o, yi) in out.iter_mut().zip(&y[..nc]) {
                *o += fw * yi;
            }
        }
        out
    }
}

/// One non-zero Gaunt coefficient Γ_ijk = ∫ y_i y_j y_k dω with i ≤ j ≤ k.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GauntEntry {
    /// Indices, i ≤ j ≤ k.
    pub ijk: [u16; 3],
    /// Value.
    pub value: f64,
}

/// The sparse, symmetric SH triple-product tensor of one order (all of i, j, k < n²).
#[derive(Debug, Clone)]
pub struct Gaunt {
    order: usize,
    /// Unique entries (i ≤ j ≤ k), sorted by (i, j, k).
    entries: Vec<GauntEntry>,
}

impl Gaunt {
    /// Γ of order `order` (1..=8), exact to rounding (see the module note).
    ///
    /// # Panics
    /// If `order` is outside 1..=8 (use [`Gaunt::try_new`] or [`Gaunt::cached`] to get
    /// an error instead).
    pub fn new(order: usize) -> Gaunt {
        Self::try_new(order).expect("Gaunt order must be 1..=8")
    }

    /// The shared tensor of `order`, built once per process on first use.
    pub fn cached(order: usize) -> Result<&'static Gaunt, LookupError> {
        static CELLS: [std::sync::OnceLock<Gaunt>; MAX_ORDER] = [const { std::sync::OnceLock::new() }; MAX_ORDER];
        let n = rt::check_order(order)?;
        Ok(CELLS[n - 1].get_or_init(|| Self::new(n)))
    }

    /// [`Gaunt::new`] with an error for an order outside 1..=8.
    pub fn try_new(order: usize) -> Result<Gaunt, LookupError> {
        let n = rt::check_order(order)?;
        let nc = n * n;
        let rule = SphereRule::exact_for_degree(3 * (n - 1));
        let ys: Vec<[f64; MAX_COEFFS]> = rule
            .points
            .iter()
            .map(|&p| {
                let mut y = [0.0; MAX_COEFFS];
                eval_basis(n, p, &mut y).expect("unit rule point");
                y
            })
            .collect();
        let lm: Vec<(usize, i32)> = (0..nc).map(rt::band_of).collect();
        let mut entries = Vec::new();
        for i in 0..nc {
            for j in i..nc {
                for k in j..nc {
                    let (l1, l2, l3) = (lm[i].0, lm[j].0, lm[k].0);
                    // Selection rules (parity and triangle) only skip work; the
                    // threshold below decides what is non-zero.
                    if (l1 + l2 + l3) % 2 == 1 || l3 > l1 + l2 || l1 + l3 < l2 || l2 + l3 < l1 {
                        continue;
                    }
                    let v: f64 = ys.iter().zip(&rule.weights).map(|(y, w)| w * y[i] * y[j] * y[k]).sum();
                    if v.abs() > GAUNT_ZERO {
                        entries.push(GauntEntry {
                            ijk: [i as u16, j as u16, k as u16],
                            value: v,
                        });
                    }
                }
            }
        }
        Ok(Gaunt { order: n, entries })
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Unique non-zero entries (i ≤ j ≤ k).
    pub fn entries(&self) -> &[GauntEntry] {
        &self.entries
    }

    /// Number of non-zero entries of the full tensor (all orderings of i, j, k).
    pub fn nonzero_full(&self) -> usize {
        self.entries
            .iter()
            .map(|e| {
                let [i, j, k] = e.ijk;
                if i == j && j == k {
                    1
                } else if i == j || j == k {
                    3
                } else {
                    6
                }
            })
            .sum()
    }

    /// Truncated SH product (f ∗ g)_i = Σ_jk Γ_ijk f_j g_k, i < n², for f, g of
    /// length n² (this tensor's order).
    ///
    /// # Panics
    /// If an operand does not have n² coefficients.
    pub fn product(&self, f: &[f64], g: &[f64]) -> Vec<f64> {
        let nc = self.order * self.order;
        assert!(
            f.len() == nc && g.len() == nc,
            "product operands must have n² = {nc} coefficients"
        );
        let mut out = vec![0.0; nc];
        self.product_into(f, g, &mut out);
        out
    }

    /// [`Gaunt::product`] into `out` (no allocation): `out[..n²]` is overwritten.
    /// Operands and `out` must hold at least n² coefficients (only the first n² are
    /// read); callers on a hot path check lengths once, outside their loop.
    ///
    /// # Panics
    /// If a slice is shorter than n².
    pub fn product_into(&self, f: &[f64], g: &[f64], out: &mut [f64]) {
        let nc = self.order * self.order;
        let (f, g, out) = (&f[..nc], &g[..nc], &mut out[..nc]);
        out.iter_mut().for_each(|o| *o = 0.0);
        for e in &self.entries {
            let [i, j, k] = e.ijk.map(usize::from);
            let v = e.value;
            // Every distinct ordering (a, b, c) of the triple contributes out[a] += v f[b] g[c].
            if i == j && j == k {
                out[i] += v * f[i] * g[i];
            } else if i == j {
                out[i] += v * (f[i] * g[k] + f[k] * g[i]);
                out[k] += v * f[i] * g[i];
            } else if j == k {
                out[i] += v * f[j] * g[j];
                out[j] += v * (f[i] * g[j] + f[j] * g[i]);
            } else {
                out[i] += v * (f[j] * g[k] + f[k] * g[j]);
                out[j] += v * (f[i] * g[k] + f[k] * g[i]);
                out[k] += v * (f[i] * g[j] + f[j] * g[i]);
            }
        }
    }
}

impl Gaunt {
    /// The product matrix M_g (n² × n², row-major, symmetric): M_g x = g ∗ x, i.e.
    /// \[M_g\]_{ik} = Σ_j Γ_ijk g_j. Ren et al.'s SH log is log(M_g)·1 (docs/math.md, shexp).
    pub fn product_matrix(&self, g: &[f64]) -> Vec<f64> {
        let nc = self.order * self.order;
        assert!(g.len() == nc, "operand must have n² = {nc} coefficients");
        let mut m = vec![0.0; nc * nc];
        for e in &self.entries {
            let [i, j, k] = e.ijk.map(usize::from);
            // Each distinct ordering (a, b, c): M[a][c] += Γ g[b].
            let mut perms = vec![(i, j, k), (i, k, j), (j, i, k), (j, k, i), (k, i, j), (k, j, i)];
            perms.sort_unstable();
            perms.dedup();
            for (a, b, c) in perms {
                m[a * nc + c] += e.value * g[b];
            }
        }
        m
    }
}

/// The SH vector of the constant 1, (√(4π), 0, …), with n² coefficients for an order
/// n in 1..=8 (an order outside it is an error naming the order).
pub fn one(order: usize) -> Result<Vec<f64>, LookupError> {
    let n = rt::check_order(order)?;
    let mut v = vec![0.0; coeff_count(n)];
    v[0] = (4.0 * PI).sqrt();
    Ok(v)
}
