//! The `_f32` twins' contract: f32 in and out, the f64 lookup's value rounded once
//! (their accuracy against the references is measured by `lobefit check`, rows
//! `<output> f32`), and `std::f32::consts::PI` accepted where an angle may reach π.
#![cfg(feature = "embedded")]

use lobefit_tables::glam::{DVec3, Vec3};
use lobefit_tables::log_zh::Kind;
use lobefit_tables::*;
use std::f32::consts::PI as PI32;

/// `got` is `want` rounded to f32.
#[track_caller]
fn rounded(got: f32, want: f64) {
    assert_eq!(got, want as f32, "{got} vs {want}");
}

#[test]
fn twins_round_the_f64_lookup_once() {
    let lp = LobeProduct::embedded().unwrap();
    let q = lp.params(12.5, 300.25, 0.75).unwrap();
    let q32 = lp.params_f32(12.5, 300.25, 0.75).unwrap();
    rounded(q32.p, q.p);
    rounded(q32.t, q.t);
    rounded(q32.e_r, q.e_r);
    rounded(q32.integral, q.integral);

    let lobe = |s: f32, a: Vec3, e: f32| Lobe32 {
        scale: s,
        axis: a.normalize(),
        exponent: e,
    };
    let brdf = [lobe(1.0, Vec3::Z, 1.0), lobe(0.5, Vec3::new(0.2, 0.0, 1.0), 40.0)];
    let light = [lobe(3.0, Vec3::new(0.0, 0.3, 1.0), 200.0)];
    let vis = [lobe(-0.5, Vec3::new(0.1, 0.3, 1.0), 500.0)];
    let wide = |l: &[Lobe32]| l.iter().map(Lobe32::to_lobe).collect::<Vec<_>>();
    let t = lp
        .triple_product(&wide(&brdf), &wide(&light), &wide(&vis), DVec3::Z, 1e-6)
        .unwrap();
    rounded(lp.triple_product_f32(&brdf, &light, &vis, Vec3::Z, 1e-6).unwrap(), t);
    let s = lp.product_sums(&wide(&brdf), &wide(&light), 0.0).unwrap();
    let s32 = lp.product_sums_f32(&brdf, &light, 0.0).unwrap();
    assert_eq!(s.len(), s32.len());
    for (a, b) in s.iter().zip(&s32) {
        rounded(b.scale, a.scale);
        rounded(b.exponent, a.exponent);
    }

    let dl = DiskLight::embedded().unwrap();
    let c = dl.canonical(0.75, 0.375).unwrap();
    for (a, b) in c.iter().zip(dl.canonical_f32(0.75, 0.375).unwrap()) {
        rounded(b, *a);
    }
    let (p, n, q, m) = (Vec3::ZERO, Vec3::Z, Vec3::new(0.3, 0.0, 2.0), Vec3::new(0.0, 0.2, -1.0));
    let e = dl
        .irradiance(p.as_dvec3(), n.as_dvec3(), q.as_dvec3(), m.as_dvec3(), 0.5, 2.0)
        .unwrap();
    rounded(dl.irradiance_f32(p, n, q, m, 0.5, 2.0).unwrap(), e);

    let lz = LogZh::embedded().unwrap();
    let (mut a, mut b) = ([0.0; 6], [0.0f32; 6]);
    lz.lookup(Kind::Phong, 6, 0.25, 7.5, &mut a).unwrap();
    lz.lookup_f32(Kind::Phong, 6, 0.25, 7.5, &mut b).unwrap();
    a.iter().zip(b).for_each(|(a, b)| rounded(b, *a));
    log_zh::diffuse(0.25, 6, &mut a).unwrap();
    log_zh::diffuse_f32(0.25, 6, &mut b).unwrap();
    a.iter().zip(b).for_each(|(a, b)| rounded(b, *a));

    let sg = SgFit::embedded().unwrap();
    let g = sg.lobe_to_sg(DVec3::Y, 30.0, 2.0).unwrap();
    let g32 = sg.lobe_to_sg_f32(Vec3::Y, 30.0, 2.0).unwrap();
    rounded(g32.sharpness, g.sharpness);
    rounded(g32.amplitude, g.amplitude);

    let se = ShExp::embedded().unwrap();
    let mut z = [0.0; 4];
    log_zh::blocker(0.1, 0.5, 4, &mut z).unwrap();
    let mut f = [0.0; 16];
    sh::zh_to_sh(&z, DVec3::new(0.0, 0.6, 0.8), &mut f).unwrap();
    let f32s: Vec<f32> = f.iter().map(|&v| v as f32).collect();
    let wide: Vec<f64> = f32s.iter().map(|&v| v as f64).collect();
    let (mut v, mut v32) = ([0.0; 16], [0.0f32; 16]);
    let k = se.hyb_threshold(&wide, 0.5, &mut v).unwrap();
    assert_eq!(se.hyb_threshold_f32(&f32s, 0.5, &mut v32).unwrap(), k);
    v.iter().zip(v32).for_each(|(a, b)| rounded(b, *a));
}

#[test]
fn f32_pi_is_pi() {
    // acos(-1.0f32) is f32 π = π + 8.7e-8: an angle twin must accept it as π.
    assert_eq!((-1.0f32).acos(), PI32);
    let lp = LobeProduct::embedded().unwrap();
    let q = lp.params(20.0, 20.0, std::f64::consts::PI).unwrap();
    let q32 = lp.params_f32(20.0, 20.0, PI32).unwrap();
    rounded(q32.p, q.p);
    assert!(
        lp.params(20.0, 20.0, PI32 as f64).is_err(),
        "the f64 lookup keeps its domain"
    );
    let dl = DiskLight::embedded().unwrap();
    assert_eq!(dl.canonical_f32(0.5, PI32).unwrap(), [0.0; 6]);
    let mut z = [0.0f32; 3];
    log_zh::blocker_f32(0.1, PI32, 3, &mut z).unwrap();
    LogZh::embedded()
        .unwrap()
        .lookup_f32(Kind::Blocker, 3, 0.1, PI32, &mut z)
        .unwrap();
    assert!(BestIsg::embedded().unwrap().s_hat_f32(PI32, PI32, 10.0).is_ok());
}

#[test]
fn twins_report_f32_overflow() {
    let lp = LobeProduct::embedded().unwrap();
    let big = Lobe32 {
        scale: 3e38,
        axis: Vec3::Z,
        exponent: 1.0,
    };
    assert!(matches!(
        lp.product_sums_f32(&[big], &[big], 0.0),
        Err(LookupError::Overflow { .. })
    ));
}
