//! Small dense linear algebra: symmetric eigen-decomposition by the cyclic Jacobi
//! method (Golub & Van Loan §8.5), for the small (≤ 64 × 64) SH product matrices of
//! Ren's SH logarithm (docs/math.md, shexp), the fit side's one dense linear solver
//! ([`solve`]), and least-squares polynomials ([`polyfit`]).
//!
//! Jacobi is slow for large matrices but backward stable with high relative accuracy
//! of the eigenvectors' orthogonality, needs no tridiagonalisation and is a few dozen
//! lines: right for n ≤ 64.

/// Off-diagonal Frobenius norm, relative to the whole matrix's, at which the sweeps
/// stop: at rounding level for f64.
pub const JACOBI_TOL: f64 = 1e-16;
/// Sweeps allowed before giving up (Jacobi converges quadratically once the
/// off-diagonal is small, so this is a safety net, not a tuning knob).
pub const JACOBI_MAX_SWEEPS: usize = 60;

/// Eigenvalues and orthonormal eigenvectors of a symmetric matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct SymEigen {
    /// Dimension n.
    pub n: usize,
    /// Eigenvalues, ascending.
    pub values: Vec<f64>,
    /// Eigenvectors as the columns of an n × n row-major matrix R: A = R diag(values) Rᵀ.
    pub vectors: Vec<f64>,
    /// Sweeps used.
    pub sweeps: usize,
}

impl SymEigen {
    /// Component `i` of eigenvector `k`.
    pub fn vector(&self, k: usize, i: usize) -> f64 {
        self.vectors[i * self.n + k]
    }
}

/// Eigen-decomposition of the symmetric n × n row-major matrix `a` (only symmetric
/// input is meaningful; the lower triangle is assumed equal to the upper one).
/// Errors: a length that is not n², a non-finite entry, or no convergence.
pub fn sym_eigen(a: &[f64], n: usize) -> Result<SymEigen, String> {
    if a.len() != n * n {
        return Err(format!("matrix has {} entries, expected {n}² = {}", a.len(), n * n));
    }
    if a.iter().any(|v| !v.is_finite()) {
        return Err("matrix has a non-finite entry".into());
    }
    let mut m = a.to_vec();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    let total: f64 = m.iter().map(|x| x * x).sum::<f64>().sqrt();
    let off = |m: &[f64]| -> f64 {
        let mut s = 0.0;
        for i in 0..n {
            for j in i + 1..n {
                s += 2.0 * m[i * n + j] * m[i * n + j];
            }
        }
        s.sqrt()
    };
    let mut sweeps = 0;
    while off(&m) > JACOBI_TOL * total && total > 0.0 {
        if sweeps == JACOBI_MAX_SWEEPS {
            return Err(format!("Jacobi did not converge in {JACOBI_MAX_SWEEPS} sweeps"));
        }
        sweeps += 1;
        for p in 0..n {
            for q in p + 1..n {
                let apq = m[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                // Rotation zeroing a_pq (G&VL Algorithm 8.5.1, the small-angle root).
                let tau = (m[q * n + q] - m[p * n + p]) / (2.0 * apq);
                let t = tau.signum() / (tau.abs() + (1.0 + tau * tau).sqrt());
                let t = if tau == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (m[k * n + p], m[k * n + q]);
                    m[k * n + p] = c * akp - s * akq;
                    m[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (m[p * n + k], m[q * n + k]);
                    m[p * n + k] = c * apk - s * aqk;
                    m[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| m[i * n + i].total_cmp(&m[j * n + j]));
    let values = order.iter().map(|&i| m[i * n + i]).collect();
    let mut vectors = vec![0.0; n * n];
    for (k, &src) in order.iter().enumerate() {
        for i in 0..n {
            vectors[i * n + k] = v[i * n + src];
        }
    }
    Ok(SymEigen {
        n,
        values,
        vectors,
        sweeps,
    })
}

/// Solves A X = B in place by Gaussian elimination with partial pivoting: the one
/// dense linear solver of the fit side (mask-weights' ridge least squares, disk-light's
/// canonical polynomials, [`polyfit`], Meunier's light-lobe fit).
///
/// Conventions: `a` is the n × n matrix A, row-major (`a[i * n + j]` = A_ij); `b` is
/// the n × `nrhs` matrix B of right-hand sides, row-major (`b[i * nrhs + c]` is row i
/// of right-hand side c; with `nrhs` = 1 simply the vector b). On success `b` holds the
/// solution X in the same layout; `a` is left holding the row-permuted upper
/// triangular factor. `None` when a pivot is exactly zero (singular) or the solution
/// is not finite (nearly singular, or non-finite input); `a` and `b` then hold
/// partial results. Panics when `a` or `b` has the wrong length.
///
/// The operation order is fixed, and part of the contract (the committed tables and
/// export layouts depend on its bits): for each column k, the pivot is the row
/// p ≥ k of largest |A_pk| (the last such row on a tie), rows p and k of A and B are
/// swapped whole, and each row i > k has f = A_ik / A_kk times row k subtracted from
/// its entries j ≥ k and from all of B's; then back substitution from the last row,
/// x_i = (b_i − Σ_{j>i} A_ij x_j) / A_ii with the sum taken in increasing j, for
/// each right-hand side.
///
/// The one other dense solver is the runtime's Householder QR in
/// `lobefit_tables::rigs` (`householder_solve`): least squares on an overdetermined,
/// column-major system for the rig fits, in the runtime crate, which cannot depend on
/// this one.
pub fn solve(a: &mut [f64], b: &mut [f64], n: usize, nrhs: usize) -> Option<()> {
    assert_eq!(a.len(), n * n, "solve: matrix has {} entries, expected {n}²", a.len());
    assert_eq!(
        b.len(),
        n * nrhs,
        "solve: right-hand sides have {} entries, expected {n} × {nrhs}",
        b.len()
    );
    for k in 0..n {
        let p = (k..n).max_by(|&i, &j| a[i * n + k].abs().total_cmp(&a[j * n + k].abs()))?;
        if a[p * n + k] == 0.0 {
            return None;
        }
        if p != k {
            for j in 0..n {
                a.swap(k * n + j, p * n + j);
            }
            for c in 0..nrhs {
                b.swap(k * nrhs + c, p * nrhs + c);
            }
        }
        for i in k + 1..n {
            let f = a[i * n + k] / a[k * n + k];
            for j in k..n {
                a[i * n + j] -= f * a[k * n + j];
            }
            for c in 0..nrhs {
                b[i * nrhs + c] -= f * b[k * nrhs + c];
            }
        }
    }
    for i in (0..n).rev() {
        for c in 0..nrhs {
            let s: f64 = (i + 1..n).map(|j| a[i * n + j] * b[j * nrhs + c]).sum();
            b[i * nrhs + c] = (b[i * nrhs + c] - s) / a[i * n + i];
        }
    }
    b.iter().all(|v| v.is_finite()).then_some(())
}

/// Least-squares polynomial c0 + c1 x + … + c_d x^d of degree `degree` through the
/// points (`x[i]`, `y[i]`), by the normal equations on the monomials and [`solve`]:
/// meant for low degrees on x scaled to about [0, 1], where the normal equations are
/// well conditioned. `None` for fewer points than coefficients, mismatched lengths,
/// or a singular system or non-finite solution.
pub fn polyfit(x: &[f64], y: &[f64], degree: usize) -> Option<Vec<f64>> {
    let m = degree + 1;
    if x.len() != y.len() || x.len() < m {
        return None;
    }
    let mut a = vec![0.0f64; m * m];
    let mut b = vec![0.0f64; m];
    let mut p = vec![1.0f64; m];
    for (&t, &v) in x.iter().zip(y) {
        for j in 1..m {
            p[j] = p[j - 1] * t;
        }
        for r in 0..m {
            b[r] += p[r] * v;
            for c in 0..m {
                a[r * m + c] += p[r] * p[c];
            }
        }
    }
    solve(&mut a, &mut b, m, 1)?;
    Some(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The tridiagonal Toeplitz matrix (2, −1) has eigenvalues 2 − 2 cos(kπ/(n+1)).
    #[test]
    fn toeplitz_closed_form() {
        for n in [1usize, 2, 7, 64] {
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                a[i * n + i] = 2.0;
                if i + 1 < n {
                    a[i * n + i + 1] = -1.0;
                    a[(i + 1) * n + i] = -1.0;
                }
            }
            let e = sym_eigen(&a, n).unwrap();
            for (k, v) in e.values.iter().enumerate() {
                let want = 2.0 - 2.0 * ((k + 1) as f64 * PI / (n + 1) as f64).cos();
                assert!((v - want).abs() < 1e-13, "n={n} k={k}: {v} vs {want}");
            }
        }
    }

    /// A dense random symmetric matrix: R D Rᵀ = A and RᵀR = I to rounding.
    #[test]
    fn reconstructs_random_matrix() {
        let n = 40;
        let mut rng = crate::rng::Rng::new(7);
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in i..n {
                let x = rng.range(-1.0, 1.0);
                a[i * n + j] = x;
                a[j * n + i] = x;
            }
        }
        let e = sym_eigen(&a, n).unwrap();
        let (mut rec, mut orth): (f64, f64) = (0.0, 0.0);
        for i in 0..n {
            for j in 0..n {
                let r: f64 = (0..n).map(|k| e.vector(k, i) * e.values[k] * e.vector(k, j)).sum();
                rec = rec.max((r - a[i * n + j]).abs());
                let o: f64 = (0..n).map(|k| e.vector(i, k) * e.vector(j, k)).sum();
                orth = orth.max((o - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        assert!(
            rec < 1e-13 && orth < 1e-13,
            "reconstruction {rec:e}, orthogonality {orth:e}"
        );
        assert!(e.values.windows(2).all(|w| w[0] <= w[1]));
    }

    /// A 3 × 3 system solved by hand (x = (2, 3, −1)), and a second right-hand side
    /// with x = (1, −1, 2): B = A X worked out entry by entry.
    #[test]
    fn solve_three_by_three_two_right_hand_sides() {
        let mut a = vec![2.0, 1.0, -1.0, -3.0, -1.0, 2.0, -2.0, 1.0, 2.0];
        // Row i: (A·(2, 3, −1))_i, (A·(1, −1, 2))_i.
        let mut b = vec![8.0, -1.0, -11.0, 2.0, -3.0, 1.0];
        solve(&mut a, &mut b, 3, 2).unwrap();
        let want = [2.0, 1.0, 3.0, -1.0, -1.0, 2.0];
        for (got, want) in b.iter().zip(want) {
            assert!((got - want).abs() < 1e-14, "{b:?}");
        }
    }

    /// A zero first pivot needs the row swap; on a tie |A_0k| = |A_1k| the last row is
    /// the pivot: [[1, 2], [−1, 3]] x = (3, 2) pivots on row 1, leaving the factor
    /// [[−1, 3], [0, 5]] (row 0 + row 1 → (0, 5)) and x = (1, 1), all exact.
    #[test]
    fn solve_pivoting() {
        let mut a = vec![0.0, 1.0, 1.0, 0.0];
        let mut b = vec![3.0, 5.0];
        solve(&mut a, &mut b, 2, 1).unwrap();
        assert_eq!(b, [5.0, 3.0]);
        let mut a = vec![1.0, 2.0, -1.0, 3.0];
        let mut b = vec![3.0, 2.0];
        solve(&mut a, &mut b, 2, 1).unwrap();
        assert_eq!(a, [-1.0, 3.0, 0.0, 5.0]);
        assert_eq!(b, [1.0, 1.0]);
    }

    /// Singular systems are `None`: rank 1 (row 1 = 2 × row 0, eliminated exactly to a
    /// zero row), the zero matrix, and a non-finite entry; the empty system is solved.
    #[test]
    fn solve_singular() {
        let mut b = vec![1.0, 2.0];
        assert_eq!(solve(&mut [1.0, 2.0, 2.0, 4.0], &mut b, 2, 1), None);
        assert_eq!(solve(&mut [0.0; 9], &mut [1.0; 3], 3, 1), None);
        assert_eq!(solve(&mut [1.0, 0.0, 0.0, f64::NAN], &mut [1.0, 1.0], 2, 1), None);
        assert_eq!(solve(&mut [], &mut [], 0, 3), Some(()));
    }

    /// Points on 1 + 2x − 3x² give back its coefficients; too few points give `None`.
    #[test]
    fn polyfit_exact_quadratic() {
        let x: Vec<f64> = (0..7).map(|i| i as f64 / 6.0).collect();
        let y: Vec<f64> = x.iter().map(|t| 1.0 + 2.0 * t - 3.0 * t * t).collect();
        let c = polyfit(&x, &y, 2).unwrap();
        for (got, want) in c.iter().zip([1.0, 2.0, -3.0]) {
            assert!((got - want).abs() < 1e-12, "{c:?}");
        }
        assert_eq!(polyfit(&x[..2], &y[..2], 2), None);
    }

    #[test]
    fn bad_input() {
        assert!(sym_eigen(&[1.0, 2.0, 3.0], 2).unwrap_err().contains("expected"));
        assert!(sym_eigen(&[f64::NAN], 1).unwrap_err().contains("non-finite"));
        assert_eq!(sym_eigen(&[0.0; 4], 2).unwrap().values, vec![0.0, 0.0]);
    }
}
