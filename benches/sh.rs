//! Speed of the SH core and the log-ZH / wedge runtime. `cargo bench --bench sh`.
//! Wall-clock numbers live here, never in tests.

use divan::black_box;
use lobefit::sh::{exp_star, Gaunt};
use lobefit::tables::log_zh::{self, LogZh};
use lobefit::tables::sh::{self, Rotation};
use lobefit::tables::wedge::Wedge;
use lobefit::tables::Table;

fn main() {
    divan::main();
}

const DIR: [f64; 3] = [0.3, -0.5, 0.8];

/// Hard-coded polynomials (orders ≤ 4) vs the recurrence at the same order.
#[divan::bench(args = [2, 4])]
fn basis_hardcoded(order: usize) -> f64 {
    let mut y = [0.0; 64];
    sh::eval_basis_hardcoded(order, black_box(DIR), &mut y).unwrap();
    y[order * order - 1]
}

#[divan::bench(args = [2, 4, 8])]
fn basis_recurrence(order: usize) -> f64 {
    let mut y = [0.0; 64];
    sh::eval_basis_recurrence(order, black_box(DIR), &mut y).unwrap();
    y[order * order - 1]
}

#[divan::bench(args = [4, 8])]
fn rotation_build(order: usize) -> usize {
    let r = sh::rotation_axis_angle([1.0, 2.0, 3.0], 0.7).unwrap();
    Rotation::new(order, black_box(r)).unwrap().order()
}

#[divan::bench(args = [4, 8])]
fn rotation_apply(bencher: divan::Bencher, order: usize) {
    let rot = Rotation::new(order, sh::rotation_axis_angle([1.0, 2.0, 3.0], 0.7).unwrap()).unwrap();
    let c: Vec<f64> = (0..order * order).map(|i| i as f64 * 0.1).collect();
    let mut out = vec![0.0; order * order];
    bencher.bench_local(|| rot.apply(black_box(&c), &mut out).unwrap());
}

#[divan::bench(args = [4, 8])]
fn gaunt_product(bencher: divan::Bencher, order: usize) {
    let g = Gaunt::new(order);
    let f: Vec<f64> = (0..order * order).map(|i| (i as f64 * 0.37).sin()).collect();
    bencher.bench_local(|| g.product(black_box(&f), black_box(&f)));
}

#[divan::bench(args = [4, 8])]
fn exp_star_log_zh(bencher: divan::Bencher, order: usize) {
    let g = Gaunt::new(order);
    let mut z = [0.0; 8];
    log_zh::phong(0.05, 3.0, order, &mut z).unwrap();
    let mut f = vec![0.0; order * order];
    sh::zh_to_sh(&z[..order], DIR, &mut f).unwrap();
    bencher.bench_local(|| exp_star(&g, black_box(&f)).value[0]);
}

/// Closed form vs the table's bilinear lookup (order 8).
#[divan::bench]
fn log_zh_closed_form() -> f64 {
    let mut z = [0.0; 8];
    log_zh::phong(black_box(0.137), black_box(17.3), 8, &mut z).unwrap();
    z[7]
}

#[divan::bench]
fn log_zh_table_lookup(bencher: divan::Bencher) {
    let t = LogZh::from_table(table("log-zh")).unwrap();
    let mut z = [0.0; 8];
    bencher.bench_local(|| t.table_lookup(8, black_box(0.137), black_box(17.3), &mut z).unwrap());
}

#[divan::bench(args = [8, 32])]
fn wedge_compose_order4(bencher: divan::Bencher, w: u32) {
    let wd = Wedge::from_table(table("wedge")).unwrap();
    let sig: Vec<f64> = (0..w).map(|k| 0.3 * (k as f64).cos().abs()).collect();
    let mut v = [0.0; 16];
    bencher.bench_local(|| wd.compose(black_box(&sig), 0.1, 4, &mut v).unwrap());
}

fn table(kind: &str) -> Table {
    Table::from_path(format!("{}/tables/data/{kind}.lobefit", env!("CARGO_MANIFEST_DIR"))).unwrap()
}
