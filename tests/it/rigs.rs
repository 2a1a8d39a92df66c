//! irradiance rigs: light SH against independent quadrature, the exact-irradiance
//! reference against a closed form, and the car comparison's qualitative results.

use std::f64::consts::PI;

use lobefit::pipelines::rigs::{compare, exact_irradiance, markdown, Receiver};
use lobefit::quad::gauss_kronrod;
use lobefit::tables::disk_light::DiskLight;
use lobefit::tables::glam::DVec3;
use lobefit::tables::rigs::Light;
use lobefit::tables::sh::eval_basis;
use lobefit::tables::LookupError;

/// A sphere light's SH irradiance vector against a nested-GK projection of its cap.
#[test]
fn sphere_light_sh_matches_quadrature() {
    let disks = DiskLight::embedded().unwrap();
    let light = Light::Sphere {
        centre: DVec3::new(1.0, -2.0, 1.5),
        radius: 0.7,
        radiance: 3.0,
    };
    let p = DVec3::new(0.2, 0.1, -0.3);
    let got = light.irradiance_sh(p, disks).unwrap();
    let d = DVec3::new(1.0, -2.0, 1.5) - p;
    let w = d.normalize();
    let u = w.any_orthonormal_vector();
    let v = w.cross(u);
    let tb = (0.7 / d.length()).asin();
    let a = [PI, 2.0 * PI / 3.0, PI / 4.0];
    for i in 0..9 {
        let q = gauss_kronrod(
            |th| {
                gauss_kronrod(
                    |ph| {
                        let dir = th.cos() * w + th.sin() * (ph.cos() * u + ph.sin() * v);
                        let mut y = [0.0; 9];
                        eval_basis(3, dir.to_array(), &mut y).unwrap();
                        y[i] * th.sin()
                    },
                    0.0,
                    2.0 * PI,
                    &[],
                    1e-14,
                    0.0,
                    200,
                )
                .value
            },
            0.0,
            tb,
            &[],
            1e-14,
            0.0,
            200,
        );
        let l = if i == 0 {
            0
        } else if i < 4 {
            1
        } else {
            2
        };
        let want = 3.0 * a[l] * q.value;
        assert!((got[i] - want).abs() < 1e-11, "i={i}: {} vs {want}", got[i]);
    }
    // Inside the sphere, at a point light: errors.
    assert!(matches!(
        light.irradiance_sh(DVec3::new(1.0, -2.0, 1.4), disks),
        Err(LookupError::OutOfDomain { .. })
    ));
    let pt = Light::Point {
        position: p,
        intensity: 1.0,
    };
    assert!(matches!(
        pt.irradiance_sh(p, disks),
        Err(LookupError::OutOfDomain { .. })
    ));
}

/// The exact irradiance of a sphere light wholly above the horizon is π L sin²θ_b cos β.
#[test]
fn exact_irradiance_closed_form_sphere() {
    let r = Receiver {
        p: DVec3::ZERO,
        n: DVec3::Z,
    };
    let c = DVec3::new(1.0, 0.5, 3.0);
    let light = Light::Sphere {
        centre: c,
        radius: 0.5,
        radiance: 2.0,
    };
    let got = exact_irradiance(&light, &r).unwrap();
    let s2 = 0.25 / c.length_squared();
    let want = PI * 2.0 * s2 * c.z / c.length();
    assert!((got / want - 1.0).abs() < 1e-7, "{got} vs {want}");
}

/// The car comparison (docs/rigs.md): the paper's qualitative ordering where it holds,
/// and the error-driven choice moving the near light out of the rig.
#[test]
fn car_comparison() {
    let c = compare(0.05).unwrap();
    eprintln!("{}", markdown(&c));
    let row = |needle: &str| c.rows.iter().find(|r| r.name.contains(needle)).unwrap().clone();
    let constant = row("constant (1), least squares");
    let mixed = row("mixed: lattice 3 × gradient × constant (6), least squares");
    let l12 = row("lattice 3×2×2 (12), least squares");
    let l64 = row("lattice 8×4×2 (64), least squares");
    // Spatially varying rigs beat the constant one, finer lattices beat coarser ones.
    assert!(mixed.all_vs_sh.0 < constant.all_vs_sh.0);
    assert!(l64.all_vs_sh.0 < l12.all_vs_sh.0 && l12.all_vs_sh.0 < mixed.all_vs_sh.0);
    // Moving the near light out of the rig reduces every rig's error, the finest
    // lattice's by far the most (what remains for it is far-field variation only).
    for r in &c.rows {
        assert!(r.split_vs_sh.0 < r.all_vs_sh.0, "{}", r.name);
    }
    assert!(l64.split_vs_sh.0 < 0.2 * l64.all_vs_sh.0);
    // The near headlight is the one light evaluated per point at tolerance 0.05.
    assert!(c.light_errors[0].0.contains("headlight") && c.light_errors[0].2);
    assert_eq!(c.light_errors.iter().filter(|l| l.2).count(), 1);
}

/// Bad light parameters and a bad tolerance: their specific errors.
#[test]
fn bad_light_inputs() {
    use lobefit::pipelines::rigs::car_box;
    use lobefit::tables::rigs::{select_direct, RigError, RigModel};
    let disks = DiskLight::embedded().unwrap();
    let p = DVec3::ZERO;
    let nan_point = Light::Point {
        position: DVec3::new(0.0, 0.0, 3.0),
        intensity: f64::NAN,
    };
    assert!(matches!(
        nan_point.irradiance_sh(p, disks),
        Err(LookupError::NotFinite { .. })
    ));
    let neg_sphere = Light::Sphere {
        centre: DVec3::new(0.0, 0.0, 3.0),
        radius: -0.5,
        radiance: 1.0,
    };
    assert!(matches!(
        neg_sphere.irradiance_sh(p, disks),
        Err(LookupError::OutOfDomain { .. })
    ));
    let disk = Light::Disk {
        centre: DVec3::new(0.0, 0.0, 3.0),
        normal: DVec3::ZERO,
        radius: 0.5,
        radiance: 1.0,
    };
    assert!(matches!(
        disk.irradiance_sh(p, disks),
        Err(LookupError::OutOfDomain { .. })
    ));
    let lights = [Light::Point {
        position: DVec3::new(0.0, 0.0, 3.0),
        intensity: 1.0,
    }];
    let pts = [DVec3::ZERO, DVec3::X, DVec3::Y];
    assert!(matches!(
        select_direct(RigModel::CONSTANT, car_box(), &lights, disks, &pts, &pts, f64::NAN, 0.0),
        Err(RigError::Lookup(LookupError::NotFinite { .. }))
    ));
    // A test point outside the rig's box.
    let far = [DVec3::new(10.0, 0.0, 0.0)];
    assert!(matches!(
        select_direct(RigModel::CONSTANT, car_box(), &lights, disks, &pts, &far, 0.1, 0.0),
        Err(RigError::Lookup(LookupError::OutOfDomain { .. }))
    ));
    // A flat box built without `RigBox::new` (public fields) is refused, not NaN.
    let flat = lobefit::tables::rigs::RigBox {
        centre: DVec3::ZERO,
        half: DVec3::new(1.0, 1.0, 0.0),
    };
    assert!(matches!(flat.normalised(DVec3::ZERO), Err(RigError::BadBox(_))));
    // A point light whose 1/r² overflows: an error, not Ok(inf).
    let hot = Light::Point {
        position: DVec3::new(0.0, 0.0, 1e-160),
        intensity: 1e10,
    };
    assert!(matches!(
        hot.irradiance_sh(p, disks),
        Err(LookupError::NotFinite { .. })
    ));
}
