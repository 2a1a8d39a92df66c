//! The task helpers a renderer would otherwise write: a sphere blocker seen from a
//! point, HYB visibility of a set of sphere blockers in one call, and the ISG patch
//! integral of a rectangle given in world space.
#![cfg(feature = "embedded")]

use std::f64::consts::{FRAC_PI_2, PI};

use lobefit_tables::glam::{DVec3, Vec3};
use lobefit_tables::log_zh::sphere_cap;
use lobefit_tables::*;

#[test]
fn sphere_cap_direction_angle_and_errors() {
    let (d, t) = sphere_cap(DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, 2.0, 5.0), 1.0).unwrap();
    assert!((d - DVec3::Z).length() < 1e-15);
    assert!((t - PI / 6.0).abs() < 1e-15, "asin(1/2) = π/6, got {t}");
    // Inside, on the surface, non-positive or NaN radius, NaN position: specific errors.
    for (p, r) in [(DVec3::new(0.0, 0.0, 4.0), 2.0), (DVec3::new(0.0, 0.0, 4.0), 1.0)] {
        let e = sphere_cap(p, DVec3::new(0.0, 0.0, 5.0), r).unwrap_err();
        assert!(e.to_string().contains("blocker"), "{e}");
    }
    assert!(sphere_cap(DVec3::ZERO, DVec3::Z * 5.0, 0.0).is_err());
    assert!(sphere_cap(DVec3::ZERO, DVec3::Z * 5.0, f64::NAN).is_err());
    assert!(sphere_cap(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Z * 5.0, 1.0).is_err());
}

#[test]
fn hyb_spheres_is_the_manual_pipeline() {
    let se = ShExp::embedded().unwrap();
    let p = DVec3::new(0.2, -0.1, 0.0);
    let spheres = [(DVec3::new(0.0, 0.5, 2.0), 0.6), (DVec3::new(1.5, 0.0, 1.0), 0.3)];
    for n in 3..=8 {
        // What a renderer wrote before: per blocker, log-ZH → world SH → sum → HYB.
        let mut f = vec![0.0; n * n];
        for &(c, r) in &spheres {
            let (d, theta_b) = sphere_cap(p, c, r).unwrap();
            let mut z = vec![0.0; n];
            se.log_zh(theta_b, n, &mut z).unwrap();
            let mut t = vec![0.0; n * n];
            sh::zh_to_sh(&z, d, &mut t).unwrap();
            f.iter_mut().zip(&t).for_each(|(a, b)| *a += b);
        }
        let mut want = vec![0.0; n * n];
        let k = se.hyb(&f, &mut want).unwrap();
        let mut got = vec![0.0; n * n];
        assert_eq!(se.hyb_spheres(p, &spheres, n, &mut got).unwrap(), k);
        assert_eq!(got, want, "order {n}");
        // Fewer blockers see more.
        let mut one = vec![0.0; n * n];
        se.hyb_spheres(p, &spheres[..1], n, &mut one).unwrap();
        assert!(one[0] > got[0]);
        // The f32 twin rounds the same.
        let s32: Vec<(Vec3, f32)> = spheres.iter().map(|&(c, r)| (c.as_vec3(), r as f32)).collect();
        let wide: Vec<(DVec3, f64)> = s32.iter().map(|&(c, r)| (c.as_dvec3(), r as f64)).collect();
        let mut w = vec![0.0; n * n];
        se.hyb_spheres(p.as_vec3().as_dvec3(), &wide, n, &mut w).unwrap();
        let mut g32 = vec![0.0f32; n * n];
        se.hyb_spheres_f32(p.as_vec3(), &s32, n, &mut g32).unwrap();
        for (a, b) in w.iter().zip(&g32) {
            assert_eq!(*b, *a as f32);
        }
    }
    // No blockers: the unoccluded visibility, y00 = √(4π).
    let mut v = [0.0; 9];
    se.hyb_spheres(p, &[], 3, &mut v).unwrap();
    assert!(
        (v[0] - (4.0 * PI).sqrt()).abs() < 1e-12 && v[1..].iter().all(|x| x.abs() < 1e-12),
        "{v:?}"
    );
    // The point inside a blocker is an error naming it.
    let e = se
        .hyb_spheres(DVec3::new(0.0, 0.5, 2.0), &spheres, 3, &mut v)
        .unwrap_err();
    assert!(e.to_string().contains("blocker"), "{e}");
}

/// ∫ over θ ∈ theta from `pole`, φ ∈ phi of the SG, by composite Simpson in (θ, φ)
/// directly in world coordinates (independent of the models and of the frame code
/// under test, apart from the definition of the rectangle).
fn world_quadrature(sg: &Sg, pole: DVec3, phi_zero: DVec3, theta: [f64; 2], phi: [f64; 2]) -> f64 {
    let y = pole.normalize();
    let x = (phi_zero - phi_zero.dot(y) * y).normalize();
    let z = x.cross(y);
    let n = 400;
    let simpson = |a: f64, b: f64, f: &dyn Fn(f64) -> f64| {
        let h = (b - a) / n as f64;
        (0..=n)
            .map(|i| {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * f(a + i as f64 * h)
            })
            .sum::<f64>()
            * h
            / 3.0
    };
    simpson(theta[0], theta[1], &|t: f64| {
        simpson(phi[0], phi[1], &|p: f64| {
            let v = t.sin() * p.cos() * x + t.cos() * y + t.sin() * p.sin() * z;
            sg.eval(v)
        }) * t.sin()
    })
}

#[test]
fn patch_world_against_quadrature_and_frames() {
    let best = BestIsg::embedded().unwrap();
    // A world frame: pole tilted, phi_zero not ⟂ the pole (only its ⟂ part counts).
    let pole = DVec3::new(0.3, 0.9, -0.2).normalize();
    let phi_zero = DVec3::new(1.0, 0.1, 0.4);
    let x = (phi_zero - phi_zero.dot(pole) * pole).normalize();
    let z = x.cross(pole);
    // SG axis on the equator at azimuth 1.1 rad.
    let phi_a: f64 = 1.1;
    let axis = phi_a.cos() * x + phi_a.sin() * z;
    let sg = Sg::new(axis, 12.0, 2.5).unwrap();
    let theta = [1.2, 1.9];
    let phi = [phi_a - 0.3, phi_a + 0.45];
    let got = best.patch_world(&sg, pole, phi_zero, theta, phi).unwrap();
    let want = world_quadrature(&sg, pole, phi_zero, theta, phi);
    // isg-best promises |ΔŜ| ≤ 5e-4 at each of the four corners.
    let tol = 4.0 * 5e-4 * sg.amplitude * 2.0 * PI / 12.0;
    assert!((got - want).abs() < tol, "{got} vs {want} (tol {tol})");
    // The same rectangle in the model's own frame: identical.
    let canon = sg.amplitude
        * best
            .patch(
                theta[0],
                theta[1],
                phi[0] - phi_a + FRAC_PI_2,
                phi[1] - phi_a + FRAC_PI_2,
                12.0,
            )
            .unwrap();
    assert!((got - canon).abs() < 1e-12 * canon.abs(), "{got} vs {canon}");
    // φ given 2π higher: the same rectangle.
    let wrapped = best
        .patch_world(&sg, pole, phi_zero, theta, [phi[0] + 2.0 * PI, phi[1] + 2.0 * PI])
        .unwrap();
    assert!((wrapped - got).abs() < 1e-12 * got.abs());
}

#[test]
fn patch_world_errors() {
    let m = PaperIsg;
    let sg = Sg::new(DVec3::Z, 200.0, 1.0).unwrap();
    let (pole, x) = (DVec3::Y, DVec3::X);
    assert!(m.patch_world(&sg, pole, x, [1.0, 2.0], [1.0, 2.0]).is_ok());
    // Axis not ⟂ the pole.
    let tilted = Sg::new(DVec3::new(0.0, 0.1, 1.0).normalize(), 200.0, 1.0).unwrap();
    let e = m.patch_world(&tilted, pole, x, [1.0, 2.0], [1.0, 2.0]).unwrap_err();
    assert!(e.to_string().contains("pole"), "{e}");
    // Rectangle leaving the hemisphere around the axis; reversed φ; phi_zero ∥ pole.
    assert!(m.patch_world(&sg, pole, x, [1.0, 2.0], [2.0, 3.5]).is_err());
    assert!(m.patch_world(&sg, pole, x, [1.0, 2.0], [2.0, 1.0]).is_err());
    assert!(m.patch_world(&sg, pole, pole, [1.0, 2.0], [1.0, 2.0]).is_err());
    assert!(m.patch_world(&sg, DVec3::ZERO, x, [1.0, 2.0], [1.0, 2.0]).is_err());
}
