//! Speed of the Meunier pipeline against its references, side by side:
//! `cargo bench --bench meunier`. One point in a penumbra (light of radius 1 at
//! distance 4, a blocker half-way, off-centre): the lobe pipeline at depths 2 and 5
//! (the light's cap) and at depth 5 with the paper's light lobe,
//! the mask alone, the quadrature reference, and 64 Monte Carlo light samples; and the
//! pipeline per pixel of the blocker-scaling scenes at 16 and 1024 spheres.
//! Wall-clock numbers live here (and in `lobefit render meunier`'s summary), never in
//! tests.

use divan::black_box;
use lobefit::pipelines::meunier::direct_light::exact_irradiance;
use lobefit::pipelines::scene::visible;
use lobefit::tables::geom::{Sphere, SphereLight};
use lobefit::tables::glam::DVec3;
use lobefit::tables::mask_weights::{build_mask, Cap};
use lobefit::tables::meunier::{LightModel, MaskSettings};
use lobefit::tables::Meunier;

fn main() {
    divan::main();
}

fn scene() -> (SphereLight, [Sphere; 1]) {
    let light = SphereLight {
        sphere: Sphere {
            centre: DVec3::new(0.0, 0.0, 4.0),
            radius: 1.0,
        },
        radiance: 1.0,
    };
    (
        light,
        [Sphere {
            centre: DVec3::new(0.35, 0.1, 2.0),
            radius: 0.3,
        }],
    )
}

#[divan::bench(args = [2, 5])]
fn lobes_irradiance(depth: u32) -> f64 {
    let m = Meunier::embedded().unwrap();
    let (l, b) = scene();
    let s = MaskSettings {
        depth,
        ..Default::default()
    };
    m.irradiance(black_box(DVec3::ZERO), DVec3::Z, &[l], &b, &s).unwrap()
}

/// Depth 5 with the paper's light lobe instead of the light's cap (the default).
#[divan::bench]
fn lobes_irradiance_paper_light() -> f64 {
    let m = Meunier::embedded().unwrap();
    let (l, b) = scene();
    let s = MaskSettings {
        light: LightModel::Lobe,
        ..Default::default()
    };
    m.irradiance(black_box(DVec3::ZERO), DVec3::Z, &[l], &b, &s).unwrap()
}

#[divan::bench]
fn mask_only_depth5() -> usize {
    let light = Cap {
        axis: DVec3::Z,
        half_angle: 0.2527,
    };
    let b = Cap {
        axis: DVec3::new(0.35, 0.1, 2.0).normalize(),
        half_angle: 0.1434,
    };
    build_mask(black_box(light), &[b], 5).unwrap().cells.len()
}

#[divan::bench]
fn exact_quadrature() -> f64 {
    let (l, b) = scene();
    exact_irradiance(black_box(DVec3::ZERO), DVec3::Z, &l, &b).unwrap()
}

#[divan::bench]
fn monte_carlo_64_samples() -> usize {
    let (l, b) = scene();
    let mut rng = lobefit::rng::Rng::new(1);
    let w = DVec3::Z;
    let cos_a = (1.0f64 - 1.0 / 16.0).sqrt();
    let (u, v) = w.any_orthonormal_pair();
    (0..64)
        .filter(|_| {
            let mu = 1.0 - rng.uniform() * (1.0 - cos_a);
            let phi = rng.range(0.0, std::f64::consts::TAU);
            let st = (1.0 - mu * mu).sqrt();
            let d = mu * w + st * (phi.cos() * u + phi.sin() * v);
            visible(black_box(DVec3::ZERO), d, &l.sphere, &b)
        })
        .count()
}

/// The lobe pipeline (default settings) at every lit pixel of the blocker-scaling
/// scenes (`lobefit plot meunier-scaling`) at 24 × 18, the blockers culled by the
/// light's cone through the BVH as the study does, one thread: the time per item is
/// µs per pixel (docs/meunier.md, "Blocker scaling"). 16 against 1024 spheres: how the
/// cost grows with the blockers.
#[divan::bench(args = ["cluster-16", "cluster-1024", "torus-16", "torus-1024"], sample_count = 20)]
fn pixel_scaling(bencher: divan::Bencher, name: &str) {
    use lobefit::pipelines::meunier::scaling::{cluster, culled, torus};
    let (kind, n) = name.split_once('-').unwrap();
    let n: usize = n.parse().unwrap();
    let scene = if kind == "cluster" { cluster(n) } else { torus(n) }.unwrap();
    let m = Meunier::embedded().unwrap();
    let s = MaskSettings::default();
    let light = scene.lights[0];
    let (hits, _) = scene.primary_hits(24, 18).unwrap();
    let hits: Vec<_> = hits.into_iter().flatten().collect();
    bencher
        .counter(divan::counter::ItemsCount::new(hits.len()))
        .bench_local(|| {
            hits.iter()
                .map(|h| {
                    let b = culled(&scene, &light, h);
                    m.radiance(h.x, h.n, h.t, h.wo, scene.brdf(h), &[light], &b, &s)
                        .unwrap()
                })
                .sum::<f64>()
        });
}
