//! The NLopt backend (cargo feature `nlopt`) is an independent second optimizer: it
//! must reproduce the argmin-built cap-exponent table within the fit tolerance.
#![cfg(feature = "nlopt")]

use lobefit::build::build;
use lobefit::fits::cap_exponent::CapExponentFamily;
use lobefit::fits::{Backend, Method};
use lobefit::tables::Table;

/// Agreement required between the two backends' stored q (relative). Both are
/// polished on dF/de = 0 to ~1e-14, so what remains is f32 rounding (6e-8).
const BACKEND_AGREEMENT: f64 = 2e-7;

#[test]
fn nlopt_reproduces_the_argmin_table() {
    let built = build(
        &CapExponentFamily {
            backend: Backend::Nlopt,
            method: Method::Fast,
        },
        &|| {},
    )
    .expect("nlopt build converges");
    let nlopt = Table::from_bytes(&built.bytes).unwrap();
    let argmin = Table::from_path(concat!(env!("CARGO_MANIFEST_DIR"), "/tables/data/cap-exponent.lobefit")).unwrap();
    assert_eq!(nlopt.values().len(), argmin.values().len());
    let worst = nlopt
        .values()
        .iter()
        .zip(argmin.values())
        .map(|(a, b)| (*a as f64 / *b as f64 - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(worst <= BACKEND_AGREEMENT, "backends differ by {worst:e} (relative)");
    eprintln!("nlopt vs argmin: worst relative difference of stored q = {worst:e}");
    // The backend is part of the recorded settings, so the files are told apart.
    assert_ne!(nlopt.meta().fit.settings_hash, argmin.meta().fit.settings_hash);
    assert!(nlopt.meta().fit.method.contains("NLopt"));
}

/// The minimisers themselves, before the shared polish: NLopt's Nelder–Mead and
/// argmin's Brent must find the same minimum to within what a minimiser can resolve
/// (√ε of a flat objective), at every grid node.
#[test]
fn minimisers_agree_before_polishing() {
    use lobefit::family::Fit;
    use lobefit::fits::cap_exponent::minimise;
    let fam = CapExponentFamily {
        backend: Backend::Argmin,
        method: Method::Fast,
    };
    let axis = &fam.axes()[0];
    let mut worst: f64 = 0.0;
    for i in 0..axis.count {
        let alpha = axis.node(i);
        let (qa, _, oka) = minimise(alpha, Backend::Argmin);
        let (qn, _, okn) = minimise(alpha, Backend::Nlopt);
        assert!(oka && okn, "alpha {alpha}");
        worst = worst.max((qa / qn - 1.0).abs());
    }
    eprintln!("before polishing: worst relative difference of q (Brent vs Nelder-Mead) = {worst:e}");
    assert!(worst < 1e-4, "{worst:e}");
}
