//! Cost of SH exponentiation per vector: the runtime's HYB (DC isolation,
//! halving, OL from the `shexp` table, truncated squarings) beside the Taylor
//! reference exp* (DC factored out, run to convergence), at orders 3, 4, 5 on an
//! accumulated vector of three blockers (‖f̂‖ = 0.84, 1.11, 1.51 at orders 3, 4, 5:
//! 1, 4, 5 squarings at the default thresholds, none at Ren's 4.8).
//! `cargo bench --bench shexp`.

use divan::black_box;
use lobefit::sh::{exp_star, Gaunt};
use lobefit::tables::sh::zh_to_sh;
use lobefit::tables::shexp::ShExp;

fn main() {
    divan::main();
}

/// Three caps turned to different directions and summed, as a renderer accumulates.
fn scene(order: usize) -> Vec<f64> {
    let t = ShExp::embedded().unwrap();
    let mut f = vec![0.0; order * order];
    let mut zh = [0.0; 8];
    let mut sh = [0.0; 64];
    for (theta, d) in [(0.5, [0.0, 0.0, 1.0]), (0.3, [0.6, 0.0, 0.8]), (0.4, [-0.3, 0.9, 0.3])] {
        t.log_zh(theta, order, &mut zh).unwrap();
        zh_to_sh(&zh[..order], d, &mut sh).unwrap();
        f.iter_mut().zip(&sh).for_each(|(a, b)| *a += b);
    }
    f
}

#[divan::bench(args = [3, 4, 5])]
fn hyb(bencher: divan::Bencher, order: usize) {
    let t = ShExp::embedded().unwrap();
    let f = scene(order);
    let mut out = vec![0.0; order * order];
    lobefit::tables::gaunt::Gaunt::cached(order).unwrap();
    bencher.bench_local(|| t.hyb(black_box(&f), &mut out).unwrap());
}

#[divan::bench(args = [3, 4, 5])]
fn hyb_at_ren_threshold(bencher: divan::Bencher, order: usize) {
    let t = ShExp::embedded().unwrap();
    let f = scene(order);
    let mut out = vec![0.0; order * order];
    bencher.bench_local(|| t.hyb_threshold(black_box(&f), 4.8, &mut out).unwrap());
}

#[divan::bench(args = [3, 4, 5])]
fn taylor(bencher: divan::Bencher, order: usize) {
    let g = Gaunt::new(order);
    let f = scene(order);
    bencher.bench_local(|| exp_star(&g, black_box(&f)));
}
