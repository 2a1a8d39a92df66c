//! The batch lookups: bit for bit the one-at-a-time values, and specific errors for
//! mismatched lengths and bad items.
#![cfg(feature = "embedded")]

use lobefit_tables::glam::DVec3;
use lobefit_tables::{
    BestIsg, CapExponent, IsgModel, Lobe, Lobe32, LobeIntegral, LobeProduct, LookupError, PaperIsg, RefitIsg,
    SeparableIsg,
};

/// A fixed stream of uniform numbers in [0, 1).
fn stream(seed: u64, n: usize) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

fn bad_item(r: Result<(), LookupError>, index: usize) {
    match r {
        Err(LookupError::BatchItem { index: i, error }) => {
            assert_eq!(i, index);
            assert!(
                matches!(*error, LookupError::NotFinite { .. } | LookupError::OutOfDomain { .. }),
                "{error:?}"
            );
        }
        r => panic!("{r:?}"),
    }
}

#[test]
fn cap_exponent_batch_is_bitwise_and_refuses_bad_items() {
    let t = CapExponent::embedded().unwrap();
    let mut xs: Vec<f64> = stream(1, 500).iter().map(|u| 1e-3 + u * 3.1).collect();
    xs.extend([1e-3, std::f64::consts::FRAC_PI_2, std::f64::consts::PI]);
    let mut out = vec![0.0; xs.len()];
    t.e_caps(&xs, &mut out).unwrap();
    for (x, o) in xs.iter().zip(&out) {
        assert_eq!(t.e_cap(*x).unwrap().to_bits(), o.to_bits(), "{x}");
    }
    let x32: Vec<f32> = xs
        .iter()
        .map(|&x| x as f32)
        .filter(|&x| x as f64 <= std::f64::consts::PI)
        .collect();
    let mut o32 = vec![0.0f32; x32.len()];
    t.e_caps_f32(&x32, &mut o32).unwrap();
    for (x, o) in x32.iter().zip(&o32) {
        assert_eq!(t.e_cap_f32(*x).unwrap().to_bits(), o.to_bits(), "{x}");
    }
    assert!(matches!(
        t.e_caps(&xs, &mut out[1..]),
        Err(LookupError::BatchLength {
            inputs: 503,
            outputs: 502
        })
    ));
    xs[7] = f64::NAN;
    xs[9] = 5.0;
    bad_item(t.e_caps(&xs, &mut out), 7);
    xs[7] = 0.5;
    bad_item(t.e_caps(&xs, &mut out), 9);
}

#[test]
fn lobe_integral_batch_is_bitwise_and_refuses_bad_items() {
    let t = LobeIntegral::embedded().unwrap();
    let mut xs: Vec<f64> = stream(2, 500).iter().map(|u| (u * 11.5).exp() - 1.0).collect();
    xs.extend([0.0, 1e5]);
    let mut out = vec![0.0; xs.len()];
    t.integrals(&xs, &mut out).unwrap();
    for (x, o) in xs.iter().zip(&out) {
        assert_eq!(t.integral(*x).unwrap().to_bits(), o.to_bits(), "{x}");
    }
    let x32: Vec<f32> = xs.iter().map(|&x| x as f32).collect();
    let mut o32 = vec![0.0f32; x32.len()];
    t.integrals_f32(&x32, &mut o32).unwrap();
    for (x, o) in x32.iter().zip(&o32) {
        assert_eq!(t.integral_f32(*x).unwrap().to_bits(), o.to_bits(), "{x}");
    }
    assert!(matches!(
        t.integrals(&xs, &mut []),
        Err(LookupError::BatchLength { .. })
    ));
    xs[3] = -1.0;
    bad_item(t.integrals(&xs, &mut out), 3);
    xs[3] = f64::INFINITY;
    bad_item(t.integrals(&xs, &mut out), 3);
}

#[test]
fn isg_batches_are_bitwise_and_refuse_bad_items() {
    let u = stream(3, 900);
    let pi = std::f64::consts::PI;
    let mut qs: Vec<[f64; 3]> = u
        .chunks(3)
        .map(|c| {
            [
                c[0] * pi,
                c[1] * pi,
                (0.5f64.ln() + c[2] * (2e4f64).ln()).exp().min(1e4),
            ]
        })
        .collect();
    let models: [&dyn IsgModel; 3] = [&PaperIsg, RefitIsg::embedded().unwrap(), BestIsg::embedded().unwrap()];
    for m in models {
        let mut out = vec![0.0; qs.len()];
        m.s_hats(&qs, &mut out).unwrap();
        for (q, o) in qs.iter().zip(&out) {
            assert_eq!(m.s_hat(q[0], q[1], q[2]).unwrap().to_bits(), o.to_bits(), "{q:?}");
        }
        let q32: Vec<[f32; 3]> = qs.iter().map(|q| q.map(|x| x as f32)).collect();
        let mut o32 = vec![0.0f32; q32.len()];
        m.s_hats_f32(&q32, &mut o32).unwrap();
        for (q, o) in q32.iter().zip(&o32) {
            assert_eq!(m.s_hat_f32(q[0], q[1], q[2]).unwrap().to_bits(), o.to_bits(), "{q:?}");
        }
        assert!(matches!(
            m.s_hats(&qs[1..], &mut out),
            Err(LookupError::BatchLength { .. })
        ));
    }
    let mut out = vec![0.0; qs.len()];
    qs[5][2] = 0.1; // γ below 0.5
    bad_item(BestIsg::embedded().unwrap().s_hats(&qs, &mut out), 5);
    qs[2][0] = f64::NAN;
    bad_item(PaperIsg.s_hats(&qs, &mut out), 2);
}

/// Ŝ on a grid from [`SeparableIsg`]'s factors, each angle's computed once and the
/// corners combined from them, is the checked Ŝ bit for bit (what the ISG pipeline's
/// per-edge cache relies on): every model, γ over the tables' range, angles on both
/// sides of π/2 (the mirrored half) and at 0 and π.
#[test]
fn isg_separable_factors_give_s_hat_bitwise() {
    fn check<M: SeparableIsg>(m: &M) {
        let pi = std::f64::consts::PI;
        let mut angles: Vec<f64> = (0..=16).map(|i| i as f64 / 16.0 * pi).collect();
        angles.extend(stream(7, 24).iter().map(|u| u * pi));
        for u in stream(8, 12) {
            let gamma = (0.5f64.ln() + u * (2e4f64).ln()).exp().min(1e4);
            let at = m.at_gamma_unchecked(gamma);
            let f: Vec<[[f64; 2]; 2]> = angles
                .iter()
                .map(|&x| [m.factors_unchecked(&at, 0, x), m.factors_unchecked(&at, 1, x)])
                .collect();
            for (ft, &theta) in f.iter().zip(&angles) {
                for (fp, &phi) in f.iter().zip(&angles) {
                    let want = m.s_hat(theta, phi, gamma).unwrap();
                    assert_eq!(
                        M::combine(ft[0], fp[1]).to_bits(),
                        want.to_bits(),
                        "θ {theta} φ {phi} γ {gamma}"
                    );
                }
            }
        }
    }
    check(&PaperIsg);
    check(RefitIsg::embedded().unwrap());
    check(BestIsg::embedded().unwrap());
}

#[test]
fn lobe_product_batch_is_bitwise_and_refuses_bad_items() {
    let u = stream(4, 6000);
    let unit = |a: f64, b: f64| {
        let z = 2.0 * a - 1.0;
        let r = (1.0 - z * z).sqrt();
        let p = b * std::f64::consts::TAU;
        DVec3::new(r * p.cos(), r * p.sin(), z)
    };
    let mut pairs: Vec<(Lobe, Lobe)> = u
        .chunks(6)
        .map(|c| {
            let lobe = |s: f64, a: f64, b: f64, e: f64| Lobe {
                scale: 0.5 + s,
                axis: unit(a, b),
                exponent: (e * 11.5).exp() - 1.0,
            };
            (lobe(c[0], c[1], c[2], c[3]), lobe(c[4], c[5], c[0], c[2]))
        })
        .collect();
    // Parallel and antiparallel axes, exponent 0 and 10⁵.
    let z = |e: f64| Lobe {
        scale: 1.0,
        axis: DVec3::Z,
        exponent: e,
    };
    pairs.push((z(0.0), z(1e5)));
    pairs.push((
        z(3.0),
        Lobe {
            axis: -DVec3::Z,
            ..z(2.0)
        },
    ));
    for t in [LobeProduct::embedded().unwrap(), LobeProduct::embedded_l2().unwrap()] {
        let mut out = vec![z(0.0); pairs.len()];
        t.products(&pairs, &mut out).unwrap();
        for ((a, b), o) in pairs.iter().zip(&out) {
            let one = t.product(a, b).unwrap();
            assert_eq!(one.scale.to_bits(), o.scale.to_bits());
            assert_eq!(one.exponent.to_bits(), o.exponent.to_bits());
            assert_eq!(
                one.axis.to_array().map(f64::to_bits),
                o.axis.to_array().map(f64::to_bits)
            );
        }
        let narrow = |l: &Lobe| Lobe32 {
            scale: l.scale as f32,
            axis: l.axis.as_vec3(),
            exponent: l.exponent as f32,
        };
        let p32: Vec<(Lobe32, Lobe32)> = pairs.iter().map(|(a, b)| (narrow(a), narrow(b))).collect();
        let mut o32 = vec![narrow(&z(0.0)); p32.len()];
        t.products_f32(&p32, &mut o32).unwrap();
        for ((a, b), o) in p32.iter().zip(&o32) {
            assert_eq!(t.product_f32(a, b).unwrap(), *o);
        }
        assert!(matches!(
            t.products(&pairs, &mut out[2..]),
            Err(LookupError::BatchLength { .. })
        ));
    }
    let t = LobeProduct::embedded().unwrap();
    let mut out = vec![z(0.0); pairs.len()];
    pairs[4].1.exponent = 2e5;
    bad_item(t.products(&pairs, &mut out), 4);
    pairs[1].0.axis = DVec3::new(0.0, 0.0, 1.1);
    bad_item(t.products(&pairs, &mut out), 1);
    pairs[0].1.scale = f64::NAN;
    bad_item(t.products(&pairs, &mut out), 0);
    // An overflowing scale is the one-at-a-time ProductOverflow/Overflow error, by index.
    pairs[0].1.scale = 1.0;
    pairs[1].0.axis = DVec3::Z;
    pairs[4].1.exponent = 2.0;
    pairs[6] = (
        Lobe {
            scale: f64::MAX,
            ..z(3.0)
        },
        Lobe {
            scale: f64::MAX,
            ..z(3.0)
        },
    );
    let (a, b) = pairs[6];
    let want = t.product(&a, &b).unwrap_err();
    match t.products(&pairs, &mut out) {
        Err(LookupError::BatchItem { index: 6, error }) => assert_eq!(*error, want),
        r => panic!("{r:?}"),
    }
}
