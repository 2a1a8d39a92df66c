//! Regression tests of the committed tables through the runtime crate, against
//! references that do not involve the fitting code.

use std::f64::consts::{FRAC_PI_2, PI};

use lobefit::fits::cap_exponent::reference_e_cap;
use lobefit::tables::cap_exponent::ALPHA_TABLE_MAX;
use lobefit::tables::{CapExponent, LobeIntegral, Table};

fn load(kind: &str) -> Table {
    Table::from_path(format!("{}/tables/data/{kind}.lobefit", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// cap-exponent between the last node (π/2 − 1e-7) and π/2, where the table holds q
/// constant: the runtime against the checker's quadrature reference, down to
/// π/2 − 1.3e-11 (much closer, cos α itself is only known to ~1e-16/(π/2 − α) in f64).
#[test]
fn cap_exponent_sliver_next_to_half_pi() {
    let caps = CapExponent::from_table(load("cap-exponent")).unwrap();
    for k in 0..=25 {
        let delta = 1e-7 * 0.7f64.powi(k);
        let alpha = FRAC_PI_2 - delta;
        assert!(alpha >= ALPHA_TABLE_MAX);
        let want = reference_e_cap(alpha).unwrap();
        let got = caps.e_cap(alpha).unwrap();
        assert!(
            (got / want - 1.0).abs() < 1e-4,
            "alpha = π/2 − {delta:e}: {got:e} vs {want:e}"
        );
    }
    assert_eq!(caps.e_cap(FRAC_PI_2).unwrap(), 0.0);
}

/// cap-exponent at a few points against the checker's quadrature reference, in f32 too.
#[test]
fn cap_exponent_matches_quadrature_reference() {
    let caps = CapExponent::from_table(load("cap-exponent")).unwrap();
    for &alpha in &[0.001, 0.0123, 0.2, 0.777, 1.2345, 1.5] {
        let want = reference_e_cap(alpha).unwrap();
        assert!((caps.e_cap(alpha).unwrap() / want - 1.0).abs() < 1e-4, "{alpha}");
        let got32 = caps.e_cap_f32(alpha as f32).unwrap() as f64;
        let want32 = reference_e_cap(alpha as f32 as f64).unwrap();
        assert!((got32 / want32 - 1.0).abs() < 2e-4, "f32 {alpha}");
    }
}

/// lobe-integral on a dense sweep (every 1/7 of a node spacing) against 2π/(e+1).
#[test]
fn lobe_integral_dense_sweep() {
    let lobes = LobeIntegral::from_table(load("lobe-integral")).unwrap();
    let n = 640 * 7;
    let top = 1e5f64.ln_1p();
    for i in 0..=n {
        let e = (top * i as f64 / n as f64).exp_m1().min(1e5);
        let got = lobes.integral(e).unwrap();
        let want = 2.0 * PI / (e + 1.0);
        assert!((got / want - 1.0).abs() < 1e-6, "e = {e}: {got} vs {want}");
    }
}
