//! wrap lighting: closed forms against the checker's independent quadrature,
//! erratum E5, the convolution, the committed table, and `lobefit eval wrap`.

use crate::common;
use std::f64::consts::PI;

use lobefit::fits::wrap::{reference_lambda, CLOSED_HIGH_ABS, CLOSED_LOW_ABS};
use lobefit::quad::gauss_kronrod;
use lobefit::tables::sh::eval_basis;
use lobefit::tables::wrap::{self, lambda_hat, published, Wrap};
use lobefit::tables::LookupError;

/// Acceptance: published form (l ≤ 2) ≤ 1e-12 and every band < 8 ≤ 1e-10 vs GK, on
/// 1001 points of a ∈ [0, 1] (ends included).
#[test]
fn closed_forms_match_quadrature() {
    let (mut low, mut high): (f64, f64) = (0.0, 0.0);
    for k in 0..=1000 {
        let a = k as f64 / 1000.0;
        let want = reference_lambda(a, 8).unwrap();
        let p = published(a).unwrap();
        let mut got = [0.0; 8];
        lambda_hat(8, a, &mut got).unwrap();
        for l in 0..3 {
            low = low.max((p[l] - want[l]).abs()).max((got[l] - want[l]).abs());
        }
        for l in 3..8 {
            high = high.max((got[l] - want[l]).abs());
        }
    }
    eprintln!("wrap: closed form l<=2 vs GK max abs {low:.2e}; bands 3..7 vs GK max abs {high:.2e}");
    assert!(low <= CLOSED_LOW_ABS && high <= CLOSED_HIGH_ABS);
}

/// docs/math.md, erratum E5: above a = 1 the published form is wrong (a = 2: 0.15 vs 0.1185) and the
/// runtime refuses it; the quadrature (support cut at t = −1) gives the truth.
#[test]
fn erratum_e5() {
    let a = 2.0;
    let truth = reference_lambda(a, 3).unwrap();
    let (b2, b3, b4) = (2.0 + a, 3.0 + a, 4.0 + a);
    let formula = 2.0 * (1.0 + a) * (3.0 - 2.0 * a + a * a) / (b2 * b3 * b4);
    assert!((formula - 0.15).abs() < 1e-12);
    assert!((truth[2] - 0.1185).abs() < 5e-5, "{}", truth[2]);
    assert!(matches!(published(a), Err(LookupError::OutOfDomain { .. })));
    let mut l = [0.0; 3];
    let err = lambda_hat(3, a, &mut l).unwrap_err();
    assert!(err.to_string().contains("E5"), "{err}");
    assert!(matches!(published(f64::NAN), Err(LookupError::NotFinite { .. })));
    assert!(reference_lambda(-1.0, 3).is_err() && reference_lambda(0.5, 9).is_err());
}

/// convolve() against the definition: for a band-limited radiance L(ω) = Σ c_i y_i(ω)
/// (order 3), the wrapped response at normal N, ∫ L(ω) f(N·ω | a) dω by nested GK,
/// equals Σ convolve(c)_i y_i(N).
#[test]
fn convolve_matches_direct_integral() {
    let c = [0.8, 0.3, -0.5, 0.2, 0.1, -0.25, 0.4, 0.05, -0.3];
    let a = 0.6;
    let mut e = [0.0; 9];
    wrap::convolve(&c, a, &mut e).unwrap();
    for n in [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [-0.48, 0.6, -0.64]] {
        let mut yn = [0.0; 9];
        eval_basis(3, n, &mut yn).unwrap();
        let via_sh: f64 = (0..9).map(|i| e[i] * yn[i]).sum();
        let direct = gauss_kronrod(
            |th| {
                gauss_kronrod(
                    |ph| {
                        let d = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                        let mut y = [0.0; 9];
                        eval_basis(3, d, &mut y).unwrap();
                        let l: f64 = (0..9).map(|i| c[i] * y[i]).sum();
                        let t = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                        let f = if t > -a {
                            ((t + a) / (1.0 + a)).powf(1.0 + a)
                        } else {
                            0.0
                        };
                        l * f * th.sin()
                    },
                    0.0,
                    2.0 * PI,
                    &[],
                    1e-11,
                    0.0,
                    500,
                )
                .value
            },
            0.0,
            PI,
            &[],
            1e-10,
            0.0,
            500,
        );
        // Funk–Hecke: ∫ L f dω = Σ (2π ∫ f P_l dt) L_lm y_lm(N) = Σ π λ̂_l L_lm y_lm(N).
        assert!(
            (via_sh - direct.value).abs() < 1e-8,
            "N={n:?}: {via_sh} vs {}",
            direct.value
        );
    }
}

/// The committed table through the runtime: nodes are the f32 rounding of the
/// reference, interpolation stays within the checker's threshold.
#[test]
fn committed_table() {
    let t = Wrap::embedded().unwrap();
    let mut worst: f64 = 0.0;
    for k in 0..=200 {
        let a = k as f64 / 200.0 + 0.0013 * (k % 3) as f64;
        let a = a.min(1.0);
        let want = reference_lambda(a, 8).unwrap();
        let mut got = [0.0; 8];
        t.table_lookup(8, a, &mut got).unwrap();
        for l in 0..8 {
            worst = worst.max((got[l] - want[l]).abs());
        }
    }
    eprintln!("wrap table interpolated vs GK: max abs {worst:.2e}");
    assert!(worst <= lobefit::fits::wrap::TABLE_INTERP_ABS);
    let mut o = [0.0; 8];
    assert!(matches!(
        t.table_lookup(8, 1.2, &mut o),
        Err(LookupError::OutOfDomain { .. })
    ));
    assert!(matches!(
        t.table_lookup(9, 0.5, &mut o),
        Err(LookupError::OutOfDomain { .. })
    ));
}

#[test]
fn eval_wrap() {
    let (code, out, err) = common::run_text(&["eval", "wrap", "--order", "3"], "a\n0\n1\n");
    assert_eq!(code, Some(0), "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "a,l0,l1,l2");
    let v: Vec<f64> = lines[1].split(',').map(|s| s.parse().unwrap()).collect();
    assert!((v[1] - 1.0).abs() < 1e-15 && (v[2] - 2.0 / 3.0).abs() < 1e-15 && (v[3] - 0.25).abs() < 1e-15);
    let (code, exact, _) = common::run_text(&["eval", "wrap", "--order", "3", "--exact"], "a\n0\n1\n");
    assert_eq!(code, Some(0));
    assert_eq!(exact.lines().count(), 3);
    // Out of the closed form's domain, wrong order, foreign flag: errors naming them.
    let (code, out, err) = common::run_text(&["eval", "wrap"], "a\n0.5\n1.5\n");
    assert_eq!(code, Some(1));
    assert!(out.is_empty() && err.contains("line 3") && err.contains("E5"), "{err}");
    // --exact gives the true value there (E5: 0.1185 at a = 2, l = 2).
    let (code, out, _) = common::run_text(&["eval", "wrap", "--order", "3", "--exact"], "a\n2\n");
    assert_eq!(code, Some(0));
    let v: Vec<f64> = out
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    assert!((v[3] - 0.1185).abs() < 5e-5, "{v:?}");
    let (code, _, err) = common::run_text(&["eval", "wrap", "--order", "9"], "a\n0.5\n");
    assert_eq!(code, Some(2)); // a usage error
    assert!(err.contains("wrap: --order 9 is outside 1..=8"), "{err}");
    let (code, _, err) = common::run_text(&["eval", "wrap", "--kind", "phong"], "a\n0.5\n");
    assert_eq!(code, Some(2), "a usage error");
    assert!(err.contains("wrap takes no --kind flag (only --order)"), "{err}");
}

/// The f32 twins agree with f64 to f32 rounding and report the same errors.
#[test]
fn f32_twins() {
    let mut l = [0.0f64; 8];
    let mut l32 = [0.0f32; 8];
    lambda_hat(8, 0.3, &mut l).unwrap();
    wrap::lambda_hat_f32(8, 0.3, &mut l32).unwrap();
    for k in 0..8 {
        assert!((l32[k] as f64 - l[k]).abs() < 1e-7);
    }
    let c = [1.0f32, 0.5, -0.25, 0.125];
    let mut o = [0.0f32; 4];
    wrap::convolve_f32(&c, 0.0, &mut o).unwrap();
    assert!((o[0] - std::f32::consts::PI).abs() < 1e-6 && (o[1] - std::f32::consts::PI / 3.0).abs() < 1e-6);
    assert!(matches!(
        wrap::lambda_hat_f32(8, 1.5, &mut l32),
        Err(LookupError::OutOfDomain { .. })
    ));
    assert!(matches!(
        wrap::convolve_f32(&c, 0.0, &mut o[..2]),
        Err(LookupError::Channels { .. })
    ));
}
