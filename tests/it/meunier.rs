//! The Meunier pipeline (docs/meunier.md): the visibility mask against exact cap-union
//! visibility, the unoccluded light against its closed form, eq. 39 with known
//! weights, degenerate scenes, and the pipeline against exact ray–sphere visibility.

use std::f64::consts::{FRAC_PI_2, PI};

use lobefit::fits::mask_weights::random_config;
use lobefit::pipelines::meunier::direct_light::{exact_irradiance, study, unoccluded_closed_form};
use lobefit::rng::Rng;
use lobefit_tables::geom::{Sphere, Sphere32, SphereLight, SphereLight32};
use lobefit_tables::glam::{DVec3, Vec3};
use lobefit_tables::mask_weights::{build_mask, channel_names, Cap, MaskMode, MaskWeights, WeightSet};
use lobefit_tables::meunier::{LightModel, MaskSettings};
use lobefit_tables::{format, LookupError, Meunier, MeunierError, Table};

/// The paper's light model (one lobe per light), the default's other settings.
const LOBE: MaskSettings = MaskSettings {
    depth: 5,
    mode: MaskMode::Aggressive,
    weights: WeightSet::Fitted,
    threshold: 0.0,
    light: LightModel::Lobe,
    sharp_leaves: true,
};

fn pipeline() -> Meunier<'static> {
    *Meunier::embedded().expect("committed tables")
}

fn light(c: [f64; 3], r: f64) -> SphereLight {
    SphereLight {
        sphere: Sphere {
            centre: c.into(),
            radius: r,
        },
        radiance: 1.0,
    }
}

fn sphere(c: [f64; 3], r: f64) -> Sphere {
    Sphere {
        centre: c.into(),
        radius: r,
    }
}

/// Random unit direction inside the cap (uniform in solid angle).
fn in_cap(rng: &mut Rng, cap: &Cap) -> DVec3 {
    let mu = 1.0 - rng.uniform() * (1.0 - cap.half_angle.cos());
    let phi = rng.range(0.0, 2.0 * PI);
    let s = (1.0 - mu * mu).sqrt();
    let (u, v) = cap.axis.any_orthonormal_pair();
    (mu * cap.axis + s * (phi.cos() * u + phi.sin() * v)).normalize()
}

/// Full cells lie inside the union of the caps; every covered direction of the
/// light's cone lies in a full cell or (at the maximal depth) a partial one; no
/// uncovered direction lies in a full cell. One blocker, two disjoint blockers, and
/// random configurations; every depth.
#[test]
fn mask_matches_exact_cap_union() {
    let light = Cap {
        axis: DVec3::Z,
        half_angle: 0.3,
    };
    let tilt = |a: f64, phi: f64| DVec3::new(a.sin() * phi.cos(), a.sin() * phi.sin(), a.cos());
    let mut configs = vec![
        vec![Cap {
            axis: tilt(0.2, 0.4),
            half_angle: 0.15,
        }],
        vec![
            Cap {
                axis: tilt(0.18, 0.0),
                half_angle: 0.1,
            },
            Cap {
                axis: tilt(0.18, PI),
                half_angle: 0.1,
            },
        ],
    ];
    let mut rng = Rng::new(7);
    configs.extend((0..10).map(|_| random_config(&mut rng, 0.3)));
    for caps in &configs {
        for depth in 1..=5 {
            let mask = build_mask(light, caps, depth).unwrap();
            assert!(!mask.fully_blocked);
            for c in mask.cells.iter().filter(|c| c.full) {
                for _ in 0..50 {
                    // A random point of the spherical quadrilateral (cone hull of its corners).
                    let w: Vec<f64> = (0..4).map(|_| rng.uniform()).collect();
                    let v = (0..4).map(|k| w[k] * c.corners[k]).sum::<DVec3>().normalize();
                    assert!(caps.iter().any(|b| b.contains(v)), "full cell not covered");
                }
            }
            for _ in 0..2000 {
                let v = in_cap(&mut rng, &light);
                let covered = caps.iter().any(|b| b.contains(v));
                let in_full = mask.leaves(depth, MaskMode::Aggressive).any(|c| c.contains(v));
                let in_cons = mask.leaves(depth, MaskMode::Conservative).any(|c| c.contains(v));
                if covered {
                    assert!(in_cons, "covered direction outside every conservative leaf");
                } else {
                    assert!(!in_full, "uncovered direction inside a full cell");
                }
                if in_full {
                    assert!(in_cons);
                }
            }
        }
    }
}

/// The covered fraction of the light's cone from the mask's cells converges to the
/// exact one from both sides as the depth grows: aggressive below, conservative above.
#[test]
fn mask_area_brackets_the_union() {
    let light = Cap {
        axis: DVec3::Z,
        half_angle: 0.25,
    };
    let mut rng = Rng::new(11);
    for _ in 0..5 {
        let caps = random_config(&mut rng, 0.25);
        let samples: Vec<DVec3> = (0..20_000).map(|_| in_cap(&mut rng, &light)).collect();
        let frac = |f: &dyn Fn(DVec3) -> bool| samples.iter().filter(|v| f(**v)).count() as f64 / samples.len() as f64;
        let exact = frac(&|v| caps.iter().any(|b| b.contains(v)));
        let mut gaps = Vec::new();
        for depth in 1..=5 {
            let mask = build_mask(light, &caps, depth).unwrap();
            let agg = frac(&|v| mask.leaves(depth, MaskMode::Aggressive).any(|c| c.contains(v)));
            let con = frac(&|v| mask.leaves(depth, MaskMode::Conservative).any(|c| c.contains(v)));
            assert!(agg <= exact && exact <= con, "depth {depth}: {agg} {exact} {con}");
            gaps.push(con - agg);
        }
        assert!(gaps.windows(2).all(|w| w[1] <= w[0]), "{gaps:?}");
        // At depth 5 the undecided band is a few cells wide along the edges.
        assert!(gaps[4] < 0.12, "{gaps:?}");
    }
}

/// The reference quadrature against the closed form π L sin²α cos β (light wholly
/// above the horizon), and the lobe pipeline against it within the cap-lobe
/// approximation's error, which grows like α² (one lobe spreads the cap's solid angle
/// towards the horizon: measured −0.02 % at α = 0.02, −1.6 % at 0.25, −8.4 % to
/// −13.5 % at 0.73–0.85 rad, docs/meunier.md).
#[test]
fn unoccluded_light_matches_closed_form() {
    let lobe_rel = |alpha: f64| 0.3 * alpha * alpha + 1e-3;
    let m = pipeline();
    let x = DVec3::ZERO;
    for (dist, r) in [(4.0, 1.0), (10.0, 0.2), (3.0, 2.0), (50.0, 0.1), (2.0, 1.5), (6.0, 0.5)] {
        let alpha = f64::asin(r / dist);
        for beta in [0.0f64, 0.3, 0.6] {
            let n = DVec3::new(beta.sin(), 0.0, beta.cos());
            let l = light([0.0, 0.0, dist], r);
            let Some(closed) = unoccluded_closed_form(x, n, &l) else {
                continue;
            };
            let exact = exact_irradiance(x, n, &l, &[]).unwrap();
            assert!(
                (exact - closed).abs() < 1e-7 * closed,
                "{dist} {r} {beta}: {exact} vs {closed}"
            );
            let lobes = m.irradiance(x, n, &[l], &[], &LOBE).unwrap();
            assert!(
                (lobes - closed).abs() < lobe_rel(alpha) * closed,
                "{dist} {r} {beta}: {lobes} vs {closed}"
            );
            let cap = m.irradiance(x, n, &[l], &[], &MaskSettings::default()).unwrap();
            assert!(
                (cap - closed).abs() < 1e-12 * closed,
                "{dist} {r} {beta}: {cap} vs {closed}"
            );
        }
    }
}

/// The light's cap (the default) against the nested adaptive quadrature for lights
/// above, across and below the horizon up to α = 0.85 rad: the closed form is exact
/// (1e-7 of the light at normal incidence); the paper's lobe is printed beside it.
#[test]
fn cap_light_is_exact_across_the_horizon() {
    let m = pipeline();
    let x = DVec3::ZERO;
    for alpha in [0.05f64, 0.3, 0.55, 0.7, 0.85] {
        let dist = 4.0;
        let mut worst = [0.0f64; 2];
        for k in 0..=12 {
            let beta = (FRAC_PI_2 + alpha) * k as f64 / 12.5;
            let l = SphereLight {
                sphere: sphere([dist * beta.sin(), 0.0, dist * beta.cos()], dist * alpha.sin()),
                radiance: 1.0,
            };
            let exact = exact_irradiance(x, DVec3::Z, &l, &[]).unwrap();
            let normal = PI * alpha.sin().powi(2);
            let cap = m.irradiance(x, DVec3::Z, &[l], &[], &MaskSettings::default()).unwrap();
            assert!(
                (cap - exact).abs() < 1e-7 * normal,
                "α {alpha} β {beta}: {cap} vs {exact}"
            );
            let lobe = m.irradiance(x, DVec3::Z, &[l], &[], &LOBE).unwrap();
            let i = usize::from(beta + alpha > FRAC_PI_2);
            worst[i] = worst[i].max((lobe - exact).abs() / normal);
        }
        println!("α {alpha}: the paper's lobe errs up to {:.4} above the horizon, {:.4} across it (of the light at normal incidence)", worst[0], worst[1]);
    }
}

/// A blocker hiding the whole light gives exactly 0, in the pipeline and the reference.
#[test]
fn blocker_covering_the_light_gives_zero() {
    let m = pipeline();
    let l = light([0.0, 0.0, 4.0], 1.0);
    let b = sphere([0.0, 0.0, 2.0], 1.0);
    for settings in [
        MaskSettings::default(),
        MaskSettings {
            mode: MaskMode::Conservative,
            depth: 2,
            ..Default::default()
        },
    ] {
        assert_eq!(m.irradiance(DVec3::ZERO, DVec3::Z, &[l], &[b], &settings).unwrap(), 0.0);
    }
    assert_eq!(exact_irradiance(DVec3::ZERO, DVec3::Z, &l, &[b]).unwrap(), 0.0);
}

/// Eq. 39 with known weights: a table whose every weight is w gives leaf lobes of
/// scale −w, and the irradiance is affine in w (the lobe algebra is linear in the
/// visibility sum), so E(w) = E(0) + w (E(1) − E(0)).
#[test]
fn eq39_with_known_weights() {
    let real = MaskWeights::embedded().unwrap();
    let meta = real.table().meta().clone();
    let with = |w: f64| {
        let n = meta.axes[0].count as usize * channel_names().len();
        MaskWeights::from_table(Table::from_bytes(&format::encode(&meta, &vec![w as f32; n]).unwrap()).unwrap())
            .unwrap()
    };
    let tables: Vec<MaskWeights> = [0.0, 0.5, 1.0].iter().map(|&w| with(w)).collect();
    let x = DVec3::ZERO;
    let l = light([0.0, 0.0, 4.0], 1.0);
    let b = [sphere([0.3, 0.0, 2.0], 0.3), sphere([-0.4, 0.2, 2.5], 0.25)];
    let e: Vec<[f64; 2]> = tables
        .iter()
        .map(|t| {
            let m = Meunier {
                weights: t,
                ..pipeline()
            };
            let v = m.visibility(x, DVec3::Z, &l, &b, &LOBE).unwrap();
            assert!(v.leaves > 10);
            assert_eq!(v.lobes[0].scale, 1.0);
            assert_eq!(v.lobes[0].exponent, 0.0);
            [LOBE, MaskSettings::default()].map(|s| m.irradiance(x, DVec3::Z, &[l], &b, &s).unwrap())
        })
        .collect();
    let m = Meunier {
        weights: &tables[1],
        ..pipeline()
    };
    let v = m.visibility(x, DVec3::Z, &l, &b, &LOBE).unwrap();
    assert!(v.lobes[1..].iter().all(|c| c.scale == -0.5));
    assert_eq!(v.lobes.len(), v.leaves + 1);
    // The cap: no c_unit, each leaf −w·g_i with its share g_i ∈ (0, 1] inside the light.
    let v = m.visibility(x, DVec3::Z, &l, &b, &MaskSettings::default()).unwrap();
    assert!(!v.lobes.is_empty() && v.lobes.len() <= v.leaves);
    assert!(v.lobes.iter().all(|c| c.scale < 0.0 && c.scale >= -0.5));
    for (k, s) in [LOBE, MaskSettings::default()].iter().enumerate() {
        // w = 0: the unoccluded value; the affine relation to rounding.
        let unocc = pipeline().irradiance(x, DVec3::Z, &[l], &[], s).unwrap();
        assert!((e[0][k] - unocc).abs() < 1e-12 * unocc);
        assert!((e[1][k] - 0.5 * (e[0][k] + e[2][k])).abs() < 1e-9 * e[0][k], "{e:?}");
        // All-ones through the table's `Ones` set matches the table of ones.
        let ones = pipeline()
            .irradiance(
                x,
                DVec3::Z,
                &[l],
                &b,
                &MaskSettings {
                    weights: WeightSet::Ones,
                    ..*s
                },
            )
            .unwrap();
        assert!((ones - e[2][k]).abs() < 1e-12 * e[0][k]);
    }
}

/// Every degenerate scene is its own error, never NaN.
#[test]
fn degenerate_scenes_are_specific_errors() {
    let m = pipeline();
    let s = MaskSettings::default();
    let l = light([0.0, 0.0, 4.0], 1.0);
    let x = DVec3::ZERO;
    let irr = |x: DVec3, n: DVec3, l: SphereLight, b: &[Sphere]| m.irradiance(x, n, &[l], b, &s);
    assert!(matches!(
        irr(x, DVec3::Z, l, &[sphere([0.0, 0.0, 0.1], 0.5)]),
        Err(MeunierError::PointInsideBlocker { index: 0, .. })
    ));
    assert!(matches!(
        irr(DVec3::new(0.0, 0.0, 3.5), DVec3::Z, l, &[]),
        Err(MeunierError::PointInsideLight { index: 0, .. })
    ));
    assert!(matches!(
        irr(x, DVec3::Z, l, &[sphere([0.0, 0.0, 4.0], 2.0)]),
        Err(MeunierError::LightInsideBlocker { light: 0, blocker: 0, margin }) if margin < 0.0
    ));
    for r in [0.0, -1.0] {
        assert!(matches!(
            irr(x, DVec3::Z, light([0.0, 0.0, 4.0], r), &[]),
            Err(MeunierError::BadRadius { .. })
        ));
        assert!(matches!(
            irr(x, DVec3::Z, l, &[sphere([1.0, 0.0, 2.0], r)]),
            Err(MeunierError::BadRadius { .. })
        ));
    }
    assert!(matches!(
        irr(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Z, l, &[]),
        Err(MeunierError::Lookup(LookupError::NotFinite { .. }))
    ));
    assert!(matches!(
        irr(x, DVec3::Z, light([0.0, f64::INFINITY, 4.0], 1.0), &[]),
        Err(MeunierError::Lookup(LookupError::NotFinite { .. }))
    ));
    assert!(matches!(
        irr(x, DVec3::Z, light([0.0, 0.0, 4.0], f64::NAN), &[]),
        Err(MeunierError::Lookup(LookupError::NotFinite { .. }))
    ));
    assert!(matches!(
        irr(x, DVec3::new(0.0, 0.0, 2.0), l, &[]),
        Err(MeunierError::NotUnit { .. })
    ));
    assert!(matches!(irr(x, DVec3::ZERO, l, &[]), Err(MeunierError::NotUnit { .. })));
    let deep = MaskSettings { depth: 6, ..s };
    assert!(matches!(
        m.irradiance(x, DVec3::Z, &[l], &[], &deep),
        Err(MeunierError::Lookup(_))
    ));
    // The reference refuses the same scenes.
    assert!(exact_irradiance(x, DVec3::Z, &l, &[sphere([0.0, 0.0, 0.1], 0.5)]).is_err());
    assert!(exact_irradiance(DVec3::new(0.0, 0.0, 3.5), DVec3::Z, &l, &[]).is_err());
}

/// The f32 twin is the f64 result rounded once.
#[test]
fn f32_twin_rounds_the_f64_result() {
    let m = pipeline();
    let s = MaskSettings::default();
    let l32 = SphereLight32 {
        sphere: Sphere32 {
            centre: Vec3::new(0.5, 0.0, 4.0),
            radius: 1.0,
        },
        radiance: 2.0,
    };
    let b32 = Sphere32 {
        centre: Vec3::new(0.2, 0.1, 2.0),
        radius: 0.3,
    };
    let got = m.irradiance_f32(Vec3::ZERO, Vec3::Z, &[l32], &[b32], &s).unwrap();
    let l = SphereLight {
        sphere: sphere([0.5, 0.0, 4.0], 1.0),
        radiance: 2.0,
    };
    let want = m
        .irradiance(
            DVec3::ZERO,
            DVec3::Z,
            &[l],
            &[sphere([0.2f32 as f64, 0.1f32 as f64, 2.0], 0.3f32 as f64)],
            &s,
        )
        .unwrap();
    assert_eq!(got, want as f32);
}

/// The pipeline against exact ray–sphere visibility on seeded scenes with full,
/// partial and no shadow: |E − E_exact|/E_unoccluded, default settings (depth 5,
/// aggressive, fitted weights): the aim (median ≤ 5 %) and a p90 limit above
/// the measured 0.116 (docs/meunier.md). The paper and all-ones weights are reported,
/// not bounded: in irradiance they do better at p90 (0.058, 0.052), see
/// docs/meunier.md for why.
#[test]
fn pipeline_against_exact_visibility() {
    const MEDIAN_MAX: f64 = 0.05;
    const P90_MAX: f64 = 0.15;
    let w = MaskWeights::embedded().unwrap();
    let stats = |set: WeightSet, light: LightModel| {
        let s = MaskSettings {
            weights: set,
            light,
            ..Default::default()
        };
        let rows = study(120, 16, &s, w).unwrap();
        let kinds = [
            rows.iter().filter(|r| r.lit_fraction() < 1e-9).count(),
            rows.iter()
                .filter(|r| r.lit_fraction() > 1e-9 && r.lit_fraction() < 1.0 - 1e-9)
                .count(),
            rows.iter().filter(|r| r.lit_fraction() >= 1.0 - 1e-9).count(),
        ];
        let mut e: Vec<f64> = rows.iter().map(|r| r.error()).collect();
        e.sort_by(f64::total_cmp);
        let q = |p: f64| e[((e.len() - 1) as f64 * p).round() as usize];
        println!(
            "light {} weights {}: n = {} (full/partial/none {kinds:?}) median {:.4} p90 {:.4} max {:.4}",
            light.name(),
            set.name(),
            e.len(),
            q(0.5),
            q(0.9),
            q(1.0)
        );
        assert!(kinds.iter().all(|&k| k >= 5), "{kinds:?}");
        (q(0.5), q(0.9))
    };
    for light in LightModel::ALL {
        let fitted = stats(WeightSet::Fitted, light);
        let ones = stats(WeightSet::Ones, light);
        let paper = stats(WeightSet::Paper, light);
        assert!(fitted.0 <= MEDIAN_MAX && fitted.1 <= P90_MAX, "{fitted:?}");
        if light == LightModel::Cap {
            // With the light's cap, the fitted weights are the best set at p90.
            assert!(fitted.1 <= ones.1.min(paper.1), "{fitted:?} {ones:?} {paper:?}");
        }
    }
}

/// The Lafortune BRDF as cosine lobes (eq. 30) equals its definition
/// ρ_d/π + Σ ρ_s (C_x u_x v_x + C_y u_y v_y + C_z u_z v_z)^k at every direction of the
/// upper hemisphere (the renderer's reference evaluates the definition).
#[test]
fn lafortune_lobes_equal_the_definition() {
    use lobefit::pipelines::scene::{brdf_value, Hit};
    use lobefit_tables::geom::{Brdf, LafortuneLobe};
    let brdf = Brdf::Lafortune {
        albedo: 0.3,
        lobes: vec![
            LafortuneLobe {
                c: DVec3::new(-1.0, -1.0, 1.0),
                rho: 1.7,
                exponent: 20.0,
            },
            LafortuneLobe {
                c: DVec3::new(-0.8, -0.3, 0.9),
                rho: 0.4,
                exponent: 3.5,
            },
        ],
    };
    let mut rng = Rng::new(3);
    let n = DVec3::new(0.2, -0.1, 1.0).normalize();
    let t = n.any_orthonormal_vector();
    for _ in 0..20 {
        let wo = in_cap(
            &mut rng,
            &Cap {
                axis: n,
                half_angle: 1.5,
            },
        );
        let lobes = brdf.lobes(n, t, wo).unwrap();
        let hit = Hit {
            x: DVec3::ZERO,
            n,
            t,
            wo,
            sphere: None,
            mesh: None,
            material: 0,
        };
        for _ in 0..50 {
            let v = in_cap(
                &mut rng,
                &Cap {
                    axis: n,
                    half_angle: 1.55,
                },
            );
            let from_lobes: f64 = lobes.iter().map(|l| l.eval(v)).sum();
            let want = brdf_value(&brdf, &hit, v);
            assert!(
                (from_lobes - want).abs() <= 1e-12 * want.max(1.0),
                "{from_lobes} vs {want}"
            );
        }
    }
    // Bad BRDF inputs are specific errors.
    let lam = Brdf::Lambert { albedo: -0.1 };
    assert!(matches!(
        lam.lobes(n, t, n),
        Err(MeunierError::Lookup(LookupError::OutOfDomain { lo: 0.0, .. }))
    ));
    assert!(matches!(brdf.lobes(n, t, 2.0 * n), Err(MeunierError::NotUnit { .. })));
    assert!(
        matches!(brdf.lobes(n, n, n), Err(MeunierError::NotUnit { .. })),
        "tangent along the normal"
    );
}

/// The batch form equals the one-at-a-time calls bit for bit and names the first bad
/// point.
#[test]
fn batch_irradiance_matches_single_calls() {
    let m = pipeline();
    let s = MaskSettings::default();
    let l = [light([0.0, 0.0, 4.0], 1.0)];
    let b = [sphere([0.3, 0.0, 2.0], 0.3)];
    let points: Vec<DVec3> = (0..6).map(|i| DVec3::new(0.1 * i as f64, 0.05, 0.0)).collect();
    let normals = vec![DVec3::Z; 6];
    let mut out = vec![0.0; 6];
    m.irradiances(&points, &normals, &l, &b, &s, &mut out).unwrap();
    for i in 0..6 {
        assert_eq!(out[i], m.irradiance(points[i], normals[i], &l, &b, &s).unwrap());
    }
    let p32: Vec<Vec3> = points.iter().map(|p| p.as_vec3()).collect();
    let n32 = vec![Vec3::Z; 6];
    let l32 = [SphereLight32 {
        sphere: Sphere32 {
            centre: Vec3::new(0.0, 0.0, 4.0),
            radius: 1.0,
        },
        radiance: 1.0,
    }];
    let b32 = [Sphere32 {
        centre: Vec3::new(0.3, 0.0, 2.0),
        radius: 0.3,
    }];
    let mut o32 = vec![0.0f32; 6];
    m.irradiances_f32(&p32, &n32, &l32, &b32, &s, &mut o32).unwrap();
    for i in 0..6 {
        assert_eq!(o32[i], m.irradiance_f32(p32[i], n32[i], &l32, &b32, &s).unwrap());
    }
    let mut bad = points.clone();
    bad[4] = DVec3::new(0.3, 0.0, 2.1); // inside the blocker
    match m.irradiances(&bad, &normals, &l, &b, &s, &mut out) {
        Err(MeunierError::BatchItem { index: 4, error }) => {
            assert!(matches!(*error, MeunierError::PointInsideBlocker { .. }))
        }
        r => panic!("{r:?}"),
    }
    assert!(matches!(
        m.irradiances(&points, &normals[..5], &l, &b, &s, &mut out),
        Err(MeunierError::Lookup(lobefit_tables::LookupError::BatchLength { .. }))
    ));
}

/// Tiny lights: the pipeline's unoccluded irradiance against the closed form
/// π L sin²α cos β for half-angles from 1e-12 to 1e-2 rad (and coordinates scaled by up
/// to 1e6), at several normals. Before, the light lobe's exponent (∝ 1/α²) broke the
/// products' closed forms below α ≈ 1e-6: 0.6 % off at 1e-6, 5.3e9 for 3.1e-20 at
/// 1e-10.
#[test]
fn tiny_lights_match_the_closed_form() {
    let m = pipeline();
    let mut worst = 0.0f64;
    for k in 0..=20 {
        let alpha = 10f64.powf(-12.0 + 0.5 * k as f64);
        for (scale, tilt) in [(1.0, 0.0f64), (1e3, 0.5), (1e-3, 1.0), (1e6, 0.3)] {
            let x = DVec3::new(0.2, -0.1, 0.05) * scale;
            let n = DVec3::new(tilt.sin(), 0.0, tilt.cos());
            let d = 2.0 * scale;
            let light = SphereLight {
                sphere: Sphere {
                    centre: x + d * DVec3::Z,
                    radius: d * alpha.sin(),
                },
                radiance: 1.5,
            };
            let want = unoccluded_closed_form(x, n, &light).unwrap();
            let got = m.irradiance(x, n, &[light], &[], &MaskSettings::default()).unwrap();
            worst = worst.max((got / want - 1.0).abs());
        }
    }
    // The pipeline's own error for small caps (the cap-exponent lobe): 1.6e-5 measured.
    assert!(worst < 1e-4, "worst relative error {worst:e}");
}

/// A scene at coordinates ≈ 1e155 (squares beyond f64) lights the point as the same
/// scene near the origin does, through the pipeline and through the exact reference
/// (before: the pipeline refused it and the reference returned 0).
#[test]
fn huge_coordinates_light_as_the_scene_near_the_origin() {
    let m = pipeline();
    let lit = |s: f64| {
        let x = DVec3::new(1.0, 1.0, 1.0) * s;
        let l = SphereLight {
            sphere: Sphere {
                centre: DVec3::new(1.0, 1.0, 2.0) * s,
                radius: 0.1 * s,
            },
            radiance: 1.0,
        };
        let b = Sphere {
            centre: DVec3::new(1.03, 1.0, 1.5) * s,
            radius: 0.05 * s,
        };
        (
            m.irradiance(x, DVec3::Z, &[l], &[b], &MaskSettings::default()).unwrap(),
            exact_irradiance(x, DVec3::Z, &l, &[b]).unwrap(),
        )
    };
    let (p1, e1) = lit(1.0);
    let (p, e) = lit(1e155);
    assert!(e1 > 0.0 && p1 > 0.0);
    assert!((p / p1 - 1.0).abs() < 1e-9, "pipeline {p} vs {p1}");
    assert!((e / e1 - 1.0).abs() < 1e-6, "exact {e} vs {e1}");
}

/// Sharp leaves in closed form (the default) against the lobe-product table for every
/// leaf, at points in the penumbrae of 40 small blockers under a sphere light: the
/// irradiance within 1e-5 of the unoccluded one at every point (measured 3.0e-7; the
/// closed form errs 1e-6 of a product where it answers, the table up to 5.5e-3), and
/// different at most points (the closed form is taken: a wrong sign or scale in its
/// wiring moves the shadows by their own size, far beyond 1e-5).
#[test]
fn sharp_leaves_agree_with_the_table() {
    let m = pipeline();
    let l = light([0.0, 0.0, 5.0], 1.0);
    let mut rng = Rng::new(0x5ba2);
    let blockers: Vec<Sphere> = (0..40)
        .map(|_| Sphere {
            centre: DVec3::new(rng.range(-1.2, 1.2), rng.range(-1.2, 1.2), rng.range(2.0, 3.5)),
            radius: rng.range(0.05, 0.15),
        })
        .collect();
    let table = MaskSettings {
        sharp_leaves: false,
        ..MaskSettings::default()
    };
    assert!(MaskSettings::default().sharp_leaves);
    let (mut differ, mut worst) = (0, 0.0f64);
    for k in 0..60 {
        let x = DVec3::new(rng.range(-1.5, 1.5), rng.range(-1.5, 1.5), 0.0);
        let open = m.irradiance(x, DVec3::Z, &[l], &[], &table).unwrap();
        let a = m
            .irradiance(x, DVec3::Z, &[l], &blockers, &MaskSettings::default())
            .unwrap();
        let b = m.irradiance(x, DVec3::Z, &[l], &blockers, &table).unwrap();
        let d = (a - b).abs() / open;
        worst = worst.max(d);
        assert!(d <= 1e-5, "point {k} {x:?}: {a} vs {b} (unoccluded {open})");
        differ += usize::from(a != b);
    }
    println!("{differ} of 60 points differ; largest difference {worst:.2e} of the unoccluded irradiance");
    assert!(differ >= 30, "{differ}");
}
