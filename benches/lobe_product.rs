//! Speed of the lobe-product fits, fast vs the paper-faithful baseline (two-step NM +
//! LM on a 2-D adaptive-Simpson objective) on the same grid points, and of runtime
//! lookups. `cargo bench --bench lobe_product`. Wall-clock numbers live here and in
//! scripts/, never in tests.

use divan::black_box;
use lobefit::fits::lobe_product::fit_fast;
use lobefit::fits::lobe_product::paper::{fit_paper, speed_sample};
use lobefit::rng::Rng;
use lobefit::tables::glam::DVec3;
use lobefit::tables::lobe_product::E_MAX;
use lobefit::tables::{Lobe, LobeProduct, Variant};

fn main() {
    divan::main();
}

const VARIANTS: [&str; 2] = ["energy", "l2"];
/// Indices into `speed_sample()` (8 points).
const POINTS: [usize; 8] = [0, 1, 2, 3, 4, 5, 6, 7];

fn variant(name: &str) -> Variant {
    if name == "l2" {
        Variant::L2
    } else {
        Variant::Energy
    }
}

/// All 8 sample points fitted once: fits per second = 8 / time.
#[divan::bench(args = VARIANTS)]
fn sample_fit_fast(name: &str) -> f64 {
    let v = variant(name);
    speed_sample()
        .iter()
        .map(|&[e1, e2, a]| fit_fast(v, black_box(e1), black_box(e2), black_box(a)).e_r)
        .sum()
}

/// The same 8 points by the paper's method (≈ 0.1 s per fit: few samples).
#[divan::bench(args = VARIANTS, sample_count = 5, sample_size = 1)]
fn sample_fit_paper(name: &str) -> f64 {
    let v = variant(name);
    speed_sample()
        .iter()
        .map(|&[e1, e2, a]| fit_paper(v, black_box(e1), black_box(e2), black_box(a)).e_r)
        .sum()
}

#[divan::bench(args = POINTS)]
fn point_fit_fast(i: usize) -> f64 {
    let [e1, e2, a] = speed_sample()[i];
    fit_fast(Variant::Energy, black_box(e1), black_box(e2), black_box(a)).e_r
}

#[divan::bench(args = POINTS, sample_count = 5, sample_size = 1)]
fn point_fit_paper(i: usize) -> f64 {
    let [e1, e2, a] = speed_sample()[i];
    fit_paper(Variant::Energy, black_box(e1), black_box(e2), black_box(a)).e_r
}

/// Random (e1, e2, α): exponents uniform in ln(1 + e) over [0, 10⁵], α uniform.
fn random_inputs(n: usize) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(0x10be);
    (0..n)
        .map(|_| {
            let e = |rng: &mut Rng| rng.range(0.0, E_MAX.ln_1p()).exp_m1().min(E_MAX);
            [e(&mut rng), e(&mut rng), rng.range(0.0, std::f64::consts::PI)]
        })
        .collect()
}

fn random_axis(rng: &mut Rng) -> DVec3 {
    let z = rng.range(-1.0, 1.0);
    let phi = rng.range(0.0, std::f64::consts::TAU);
    let s = (1.0 - z * z).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// One `params` lookup per iteration, cycling over 1024 random inputs.
#[divan::bench(args = VARIANTS)]
fn lookup_params(bencher: divan::Bencher, name: &str) {
    let lp = match variant(name) {
        Variant::L2 => LobeProduct::embedded_l2(),
        Variant::Energy => LobeProduct::embedded(),
    }
    .unwrap();
    let xs = random_inputs(1024);
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) & 1023;
        let [e1, e2, a] = xs[i];
        lp.params(black_box(e1), black_box(e2), black_box(a)).unwrap().p
    });
}

/// One `product` of two random lobes per iteration (random unit axes and exponents).
#[divan::bench]
fn lookup_product(bencher: divan::Bencher) {
    let lp = LobeProduct::embedded().unwrap();
    let mut rng = Rng::new(0x5eed);
    let lobes: Vec<(Lobe, Lobe)> = random_inputs(1024)
        .iter()
        .map(|&[e1, e2, _]| {
            let l1 = Lobe {
                scale: 1.0,
                axis: random_axis(&mut rng),
                exponent: e1,
            };
            let l2 = Lobe {
                scale: 1.0,
                axis: random_axis(&mut rng),
                exponent: e2,
            };
            (l1, l2)
        })
        .collect();
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) & 1023;
        let (l1, l2) = &lobes[i];
        lp.product(black_box(l1), black_box(l2)).unwrap().exponent
    });
}
