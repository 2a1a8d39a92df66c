//! Cost of one Ŝ(θ, φ; γ) evaluation per ISG model, side by side, plus the
//! references, the lobe→SG lookup and the ISG pipeline's shading of a pixel.
//! `cargo bench --bench isg`. Inputs cycle through
//! a fixed set of (θ, φ, γ) so no model is timed on a single cached point.

use std::f64::consts::FRAC_PI_2;

use divan::black_box;
use lobefit::fits::isg::reference::{s_hat_fast, s_hat_reference};
use lobefit::tables::{BestIsg, IsgModel, PaperIsg, RefitIsg, SgFit, Table};

/// Largest query angle: π − 1e-5, so the f32 casts stay inside [0, π].
const ANGLE_MAX: f64 = std::f64::consts::PI - 1e-5;

/// Iterations per sample of the per-model benches: fixed, so the three models are
/// timed alike (divan's automatic choice fell to 1 for one of them, timer-noise bound).
const SAMPLE_SIZE: u32 = 1000;

fn main() {
    divan::main();
}

fn table(kind: &str) -> Table {
    Table::from_path(format!("{}/tables/data/{kind}.lobefit", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// 64 query points: γ log-spaced over [0.5, 1e4], angles within ±3 SG widths (kept
/// below π in f32 too).
fn points() -> Vec<(f64, f64, f64)> {
    (0..64)
        .map(|i| {
            let g = (0.5f64.ln() + (2e4f64).ln() * i as f64 / 63.0).exp();
            let w = 1.0 / g.sqrt();
            let t = (FRAC_PI_2 + w * (3.0 * ((i * 7 % 13) as f64 / 6.0 - 1.0))).clamp(0.0, ANGLE_MAX);
            let p = (FRAC_PI_2 + w * (3.0 * ((i * 5 % 11) as f64 / 5.0 - 1.0))).clamp(0.0, ANGLE_MAX);
            (t, p, g)
        })
        .collect()
}

fn bench_model(bencher: divan::Bencher, m: &dyn IsgModel) {
    let pts = points();
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) % pts.len();
        let (t, p, g) = pts[i];
        m.s_hat(black_box(t), black_box(p), black_box(g)).unwrap()
    });
}

#[divan::bench(sample_size = SAMPLE_SIZE)]
fn s_hat_paper(bencher: divan::Bencher) {
    bench_model(bencher, &PaperIsg);
}

#[divan::bench(sample_size = SAMPLE_SIZE)]
fn s_hat_refit(bencher: divan::Bencher) {
    let m = RefitIsg::from_table(table("isg-refit")).unwrap();
    bench_model(bencher, &m);
}

#[divan::bench(sample_size = SAMPLE_SIZE)]
fn s_hat_best(bencher: divan::Bencher) {
    let m = BestIsg::from_table(table("isg-best")).unwrap();
    bench_model(bencher, &m);
}

/// The f32 entry point of the separable model (what a shader-side port mirrors).
#[divan::bench(sample_size = SAMPLE_SIZE)]
fn s_hat_best_f32(bencher: divan::Bencher) {
    let m = BestIsg::from_table(table("isg-best")).unwrap();
    let pts: Vec<(f32, f32, f32)> = points()
        .iter()
        .map(|&(t, p, g)| (t as f32, p as f32, g as f32))
        .collect();
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) % pts.len();
        let (t, p, g) = pts[i];
        m.s_hat_f32(black_box(t), black_box(p), black_box(g)).unwrap()
    });
}

/// The fast 1-D reduction the fits use (exact to ~1e-10).
#[divan::bench]
fn s_hat_exact_fast(bencher: divan::Bencher) {
    let pts = points();
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) % pts.len();
        let (t, p, g) = pts[i];
        s_hat_fast(black_box(t), black_box(p), black_box(g))
    });
}

/// The checker's nested Gauss–Kronrod reference.
#[divan::bench(sample_count = 20)]
fn s_hat_exact_reference(bencher: divan::Bencher) {
    let pts = points();
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) % pts.len();
        let (t, p, g) = pts[i];
        s_hat_reference(black_box(t), black_box(p), black_box(g)).unwrap()
    });
}

#[divan::bench(sample_size = SAMPLE_SIZE)]
fn sg_fit_lookup(bencher: divan::Bencher) {
    let t = SgFit::from_table(table("sg-fit")).unwrap();
    let mut e = 0.0;
    bencher.bench_local(|| {
        e = if e > 9.0e4 { 0.0 } else { e * 1.01 + 0.1 };
        t.fit(black_box(e)).unwrap()
    });
}

/// The ISG pipeline (default settings) at every pixel of fig12 at 24 × 18 that sees
/// geometry (264, the baselines study's image), one thread: the time per item is µs
/// per pixel (docs/isg-render.md, "Per-pixel cost").
#[divan::bench(sample_count = 20)]
fn pixel_fig12(bencher: divan::Bencher) {
    use lobefit::pipelines::isg::render::{blockers_of, scene};
    use lobefit::pipelines::isg::shade::{radiance, Phong, Settings, Tables};
    let scene = scene("fig12").unwrap();
    let t = Tables::embedded().unwrap();
    let s = Settings::default();
    let (w, h) = (24, 18);
    let hits: Vec<_> = (0..w * h).filter_map(|p| scene.primary(p % w, p / w, w, h)).collect();
    bencher
        .counter(divan::counter::ItemsCount::new(hits.len()))
        .bench_local(|| {
            hits.iter()
                .map(|h| {
                    let brdf = Phong::of_any(scene.brdf(h)).unwrap();
                    radiance(&t, &s, &scene.environment, &brdf, &blockers_of(&scene, h), h).unwrap()
                })
                .sum::<f64>()
        });
}
