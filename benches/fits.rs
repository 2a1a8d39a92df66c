//! Speed of fits and lookups, side by side with the paper-faithful baseline.
//! `cargo bench --bench fits`. Wall-clock numbers live here and in
//! scripts/timing.sh, never in tests.

use divan::black_box;
use lobefit::family::Fit;
use lobefit::fits::cap_exponent::{fit_paper, CapExponentFamily};
use lobefit::fits::lobe_integral::LobeIntegralFamily;
use lobefit::fits::{Backend, Method};
use lobefit::tables::{CapExponent, LobeIntegral, Table};

fn main() {
    divan::main();
}

/// Cap half-angles where both methods converge (the baseline fails within 1.7e-6 rad of π/2).
const ALPHAS: [f64; 4] = [0.003, 0.1, 0.8, 1.5];

#[divan::bench(args = ALPHAS)]
fn cap_fit_fast(alpha: f64) -> f64 {
    let fam = CapExponentFamily {
        backend: Backend::Argmin,
        method: Method::Fast,
    };
    fam.fit(black_box(&[alpha])).values[0]
}

#[divan::bench(args = ALPHAS)]
fn cap_fit_paper_baseline(alpha: f64) -> f64 {
    fit_paper(black_box(alpha)).0
}

#[divan::bench(args = [0.0, 10.0, 1.0e4])]
fn lobe_integral_fit(e: f64) -> f64 {
    LobeIntegralFamily.fit(black_box(&[e])).values[0]
}

fn table(kind: &str) -> Table {
    Table::from_path(format!("{}/tables/data/{kind}.lobefit", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

#[divan::bench]
fn cap_lookup(bencher: divan::Bencher) {
    let caps = CapExponent::from_table(table("cap-exponent")).unwrap();
    let mut a = 0.001;
    bencher.bench_local(|| {
        a = if a > 1.5 { 0.001 } else { a + 0.0137 };
        caps.e_cap(black_box(a)).unwrap()
    });
}

#[divan::bench]
fn lobe_integral_lookup(bencher: divan::Bencher) {
    let lobes = LobeIntegral::from_table(table("lobe-integral")).unwrap();
    let mut e = 0.0;
    bencher.bench_local(|| {
        e = if e > 9.0e4 { 0.0 } else { e * 1.01 + 0.1 };
        lobes.integral(black_box(e)).unwrap()
    });
}
