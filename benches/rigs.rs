//! Speed of the wrap, disk-light and rig runtime: wrap scalings, disk-light lookups, rig fits and
//! reconstruction. `cargo bench --bench rigs`. Wall-clock numbers live here, never in tests.

use divan::black_box;
use lobefit::pipelines::rigs::{car_box, field, scene_lights, surface_points, FIT_POINTS, RIDGE};
use lobefit::tables::disk_light::DiskLight;
use lobefit::tables::glam::DVec3;
use lobefit::tables::rigs::{AxisModel, Light, Rig, RigModel, COEFFS};
use lobefit::tables::wrap;

fn main() {
    divan::main();
}

#[divan::bench]
fn wrap_lambda_hat_order8() -> f64 {
    let mut l = [0.0; 8];
    wrap::lambda_hat(8, black_box(0.37), &mut l).unwrap();
    l[7]
}

#[divan::bench]
fn disk_canonical() -> f64 {
    let d = DiskLight::embedded().unwrap();
    d.canonical(black_box(0.73), black_box(0.9)).unwrap()[5]
}

#[divan::bench]
fn disk_irradiance_sh() -> f64 {
    let d = DiskLight::embedded().unwrap();
    d.irradiance_sh(
        black_box(DVec3::new(0.1, 0.2, 0.3)),
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(-0.2, -0.5, -1.0),
        0.8,
        2.0,
    )
    .unwrap()[8]
}

fn samples() -> Vec<(DVec3, [f64; COEFFS])> {
    let d = DiskLight::embedded().unwrap();
    let lights: Vec<Light> = scene_lights().iter().map(|l| l.1).collect();
    surface_points(FIT_POINTS, 0xf17)
        .iter()
        .map(|r| (r.p, field(&lights, d, r.p).unwrap()))
        .collect()
}

const MIXED: RigModel = RigModel::Tensor([AxisModel::Lattice(3), AxisModel::Gradient, AxisModel::Constant]);

#[divan::bench(args = ["mixed", "lattice-8x4x2"])]
fn rig_fit_least_squares_600(bencher: divan::Bencher, which: &str) {
    let s = samples();
    let model = if which == "mixed" {
        MIXED
    } else {
        RigModel::lattice(8, 4, 2)
    };
    bencher.bench(|| Rig::fit_least_squares(model, car_box(), black_box(&s), RIDGE).unwrap());
}

#[divan::bench(args = ["mixed", "lattice-8x4x2"])]
fn rig_eval(bencher: divan::Bencher, which: &str) {
    let s = samples();
    let model = if which == "mixed" {
        MIXED
    } else {
        RigModel::lattice(8, 4, 2)
    };
    let rig = Rig::fit_least_squares(model, car_box(), &s, RIDGE).unwrap();
    bencher.bench(|| rig.eval(black_box(DVec3::new(0.3, -0.9, 0.2))).unwrap()[4]);
}

#[divan::bench]
fn light_sh_sphere() -> f64 {
    let d = DiskLight::embedded().unwrap();
    let l = Light::Sphere {
        centre: DVec3::new(0.0, 4.0, 4.0),
        radius: 0.15,
        radiance: 300.0,
    };
    l.irradiance_sh(black_box(DVec3::new(0.3, 0.9, 0.2)), d).unwrap()[6]
}

/// The checker's two disk-light references side by side (every node uses the
/// direction one, the off-grid sample the area one), at three (R/d, τ): small and
/// head-on, rim-crossing, near grazing.
const DISK_CASES: [(f64, f64); 3] = [(0.05, 0.3), (0.9, 1.2), (5.0, 1.5)];

#[divan::bench(args = DISK_CASES)]
fn disk_reference_area(case: (f64, f64)) -> f64 {
    lobefit::fits::disk_light::reference_canonical(black_box(case.0), black_box(case.1)).unwrap()[0]
}

#[divan::bench(args = DISK_CASES)]
fn disk_reference_directions(case: (f64, f64)) -> f64 {
    lobefit::fits::disk_light::reference_canonical_directions(black_box(case.0), black_box(case.1)).unwrap()[0]
}
