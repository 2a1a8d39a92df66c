//! The committed lobe-product tables through the runtime API a renderer calls,
//! against the checker's independent Gauss–Kronrod reference.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use lobefit::fits::lobe_product::{reference_integral, reference_scene, Scene};
use lobefit::rng::Rng;
use lobefit::tables::glam::{DVec3, Vec3};
use lobefit::tables::lobe_product::{lobe_sum_integral, peak_angle, LobeProduct, Variant, KIND_L2};
use lobefit::tables::{format, LoadError, Lobe, Lobe32, LookupError};

fn energy() -> &'static LobeProduct {
    LobeProduct::embedded().expect("committed energy table")
}

fn l2() -> &'static LobeProduct {
    LobeProduct::embedded_l2().expect("committed l2 table")
}

fn unit(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

fn lobe(scale: f64, axis: DVec3, exponent: f64) -> Lobe {
    Lobe { scale, axis, exponent }
}

#[test]
fn variants_load_as_themselves_only() {
    assert_eq!(energy().variant(), Variant::Energy);
    assert_eq!(l2().variant(), Variant::L2);
    let t = energy().table().clone();
    assert!(matches!(
        LobeProduct::from_table_as(t, Variant::L2),
        Err(LoadError::WrongKind { .. })
    ));
    // A file of the right kind but another layout (the e2 axis dropped) is refused.
    let src = l2().table();
    let mut meta = src.meta().clone();
    assert_eq!(meta.kind, KIND_L2);
    let n_e = meta.axes[0].count as usize;
    meta.axes.remove(1);
    meta.diagnostics.entries = (n_e * meta.axes[1].count as usize) as u64;
    meta.diagnostics.converged = meta.diagnostics.entries;
    let per = meta.channels.len() * meta.axes[1].count as usize;
    let values: Vec<f32> = src.values()[..n_e * per].to_vec();
    let bytes = format::encode(&meta, &values).unwrap();
    assert!(matches!(
        LobeProduct::from_bytes(&bytes),
        Err(LoadError::LayoutMismatch { .. })
    ));
}

#[test]
fn bad_queries_name_the_input() {
    let t = energy();
    fn name<T: std::fmt::Debug>(r: Result<T, LookupError>) -> String {
        match r {
            Err(LookupError::NotFinite { name, .. }) | Err(LookupError::OutOfDomain { name, .. }) => name,
            other => panic!("expected an error, got {other:?}"),
        }
    }
    assert_eq!(name(t.params(f64::NAN, 1.0, 0.5)), "e1");
    assert_eq!(name(t.params(1.0, -1e-9, 0.5)), "e2");
    assert_eq!(name(t.params(1.0, 2e5, 0.5)), "e2");
    assert_eq!(name(t.params(1.0, 1.0, 3.2)), "alpha");
    assert_eq!(name(t.params(1.0, 1.0, f64::INFINITY)), "alpha");
    let good = lobe(1.0, DVec3::Z, 3.0);
    assert_eq!(
        name(t.product(&lobe(1.0, DVec3::new(0.0, 0.0, 2.0), 1.0), &good)),
        "|a1|"
    );
    assert_eq!(
        name(t.product(&good, &lobe(1.0, DVec3::new(f64::NAN, 0.0, 1.0), 1.0))),
        "a2"
    );
    assert_eq!(name(t.product(&lobe(f64::NAN, DVec3::Z, 1.0), &good)), "s1");
    assert_eq!(name(t.product(&good, &lobe(1.0, DVec3::X, -2.0))), "e2");
    assert_eq!(name(t.product_sums(&[good], &[good], f64::NAN)), "threshold");
}

#[test]
fn products_of_random_lobes_keep_their_integral() {
    // Random axes in 3-D (not the table's canonical frame), through `product`.
    let mut rng = Rng::new(7);
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for _ in 0..300 {
        let e1 = rng.range(0.0, 1e5f64.ln_1p()).exp_m1();
        let e2 = rng.range(0.0, 1e5f64.ln_1p()).exp_m1();
        let a1 = unit(rng.range(0.0, PI), rng.range(0.0, TAU));
        // Angles up to a few product widths, so most products matter.
        let width = (1.0 / (e1 + 1.0) + 1.0 / (e2 + 1.0)).sqrt();
        let alpha = (rng.range(0.0, 4.0) * width).min(PI);
        let perp = a1.any_orthonormal_vector();
        let a2 = a1 * alpha.cos() + perp * alpha.sin();
        let (s1, s2) = (rng.range(0.5, 2.0), rng.range(0.5, 2.0));
        let r = energy().product(&lobe(s1, a1, e1), &lobe(s2, a2, e2)).unwrap();
        let want = s1 * s2 * reference_integral(e1, e2, alpha).unwrap();
        if want < 1e-6 * s1 * s2 * TAU / (1.0 + e1.max(e2)) {
            continue;
        }
        checked += 1;
        worst = worst.max((r.integral() - want).abs() / want);
        // The axis is the product's peak: in the plane of a1, a2 at angle β from a1.
        let beta = peak_angle(e1, e2, alpha);
        assert!((r.axis.length() - 1.0).abs() < 1e-12);
        assert!(
            (r.axis.dot(a1).clamp(-1.0, 1.0).acos() - beta).abs() < 1e-6,
            "{e1} {e2} {alpha}"
        );
        assert!(r.axis.dot(a1.cross(a2)).abs() < 1e-9);
        assert!(
            r.exponent >= e1.max(e2) * (1.0 - 1e-3),
            "e_r grows: {} vs {e1}, {e2}",
            r.exponent
        );
    }
    assert!(checked > 150, "{checked}");
    // docs/math.md, lobe-product: p99 ≤ 1e-2 over random points; every one of these is within 2 %.
    assert!(worst < 2e-2, "worst relative integral error {worst:e}");
}

#[test]
fn exact_cases() {
    let t = energy();
    // α = 0: the product of lobes on one axis is the lobe e1 + e2 with p = 1.
    for &(e1, e2) in &[(0.0, 0.0), (1.0, 2.5), (300.0, 1e5)] {
        let q = t.params(e1, e2, 0.0).unwrap();
        assert!((q.e_r - (e1 + e2)).abs() <= 1e-5 * (1.0 + e1 + e2), "{q:?}");
        // (e1, e2) off the nodes: p carries the table's interpolation error.
        assert!((q.p - 1.0).abs() < 1e-4, "{q:?}");
    }
    // Antipodal lobes, and sharp lobes far apart, give exact zeros (not noise).
    for &(e1, e2, alpha) in &[(1.0, 1.0, PI), (0.0, 0.0, PI), (1e5, 1e5, 1.0), (1e4, 50.0, 2.0)] {
        let q = t.params(e1, e2, alpha).unwrap();
        assert_eq!(q.p, 0.0, "{e1} {e2} {alpha}: {q:?}");
        assert!(q.e_r.is_finite() && q.t.is_finite());
    }
    // Symmetry: swapping the lobes gives the same lobe.
    let (a, b) = (lobe(0.7, unit(0.3, 0.2), 12.0), lobe(1.3, unit(1.1, 2.0), 3.5));
    let (ab, ba) = (t.product(&a, &b).unwrap(), t.product(&b, &a).unwrap());
    assert!((ab.scale - ba.scale).abs() < 1e-6 * ab.scale);
    assert!((ab.exponent - ba.exponent).abs() < 1e-6 * ab.exponent);
    assert!((ab.axis - ba.axis).length() < 1e-9);
}

#[test]
fn single_precision_agrees() {
    let t = energy();
    let (a, b) = (lobe(0.7, unit(0.3, 0.2), 12.0), lobe(1.3, unit(0.9, 2.0), 3.5));
    let narrow = |l: &Lobe| Lobe32 {
        scale: l.scale as f32,
        axis: Vec3::new(l.axis.x as f32, l.axis.y as f32, l.axis.z as f32),
        exponent: l.exponent as f32,
    };
    let r = t.product(&a, &b).unwrap();
    let r32 = t.product_f32(&narrow(&a), &narrow(&b)).unwrap();
    assert!((r32.scale as f64 - r.scale).abs() < 1e-4 * r.scale);
    assert!((r32.exponent as f64 - r.exponent).abs() < 1e-4 * r.exponent);
    assert!((r32.axis.as_dvec3() - r.axis).length() < 1e-5);
}

#[test]
fn lobe_sums_and_the_threshold() {
    let t = energy();
    let a = [lobe(1.0, DVec3::Z, 10.0), lobe(0.5, unit(0.4, 0.0), 2.0)];
    let b = [lobe(2.0, unit(0.2, 1.0), 30.0), lobe(1.0, -DVec3::Z, 100.0)];
    let all = t.product_sums(&a, &b, 0.0).unwrap();
    // The antipodal pair (e 10 at +z, e 100 at −z) vanishes and is dropped.
    assert_eq!(all.len(), 3);
    let direct: f64 = a
        .iter()
        .flat_map(|x| b.iter().map(move |y| (x, y)))
        .map(|(x, y)| t.product(x, y).unwrap().integral())
        .sum();
    assert!((lobe_sum_integral(&all) - direct).abs() < 1e-12 * direct);
    // A threshold above the smallest product's integral drops it.
    let smallest = all.iter().map(|l| l.integral()).fold(f64::INFINITY, f64::min);
    assert_eq!(t.product_sums(&a, &b, smallest * 1.0001).unwrap().len(), 2);
    assert_eq!(lobe_sum_integral(&[lobe(3.0, DVec3::X, 2.0)]), 3.0 * TAU / 3.0);
}

/// `product_integral` is the product lobe's integral without the lobe (both variants,
/// sharp, broad, antipodal and beyond-the-table exponents); it refuses an axis that is
/// not unit and a non-finite scale, and a vanishing product is 0 even with scales
/// near f64's largest.
#[test]
fn product_integral_is_the_product_lobes_integral() {
    let pairs = [
        (lobe(0.7, unit(0.3, 0.2), 12.0), lobe(1.3, unit(0.9, 2.0), 3.5)),
        (lobe(1.0, DVec3::Z, 0.0), lobe(-0.4, unit(1.2, 0.5), 1.0)),
        (lobe(2.0, DVec3::Z, 500.0), lobe(1.0, unit(0.05, 1.0), 2.0e4)),
        (lobe(1.0, DVec3::Z, 10.0), lobe(1.0, -DVec3::Z, 100.0)),
        (lobe(1.0, DVec3::Z, 3.0e5), lobe(1.0, unit(0.001, 0.0), 2.0e5)),
    ];
    for t in [energy(), l2()] {
        for (a, b) in &pairs {
            let want = t.product_sums(&[*a], &[*b], 0.0).unwrap();
            let want: f64 = lobe_sum_integral(&want);
            let got = t.product_integral(a, b).unwrap();
            assert!(
                (got - want).abs() <= 1e-12 * want.abs(),
                "{:?} {a:?} {b:?}: {got} vs {want}",
                t.variant()
            );
        }
    }
    let bad = lobe(1.0, DVec3::new(0.0, 0.0, 2.0), 1.0);
    assert!(energy().product_integral(&bad, &pairs[0].0).is_err());
    assert!(energy()
        .product_integral(&lobe(f64::NAN, DVec3::Z, 1.0), &pairs[0].0)
        .is_err());
    let huge = |a: DVec3, e: f64| lobe(f64::MAX / 2.0, a, e);
    assert_eq!(
        energy().product_integral(&huge(DVec3::Z, 10.0), &huge(-DVec3::Z, 100.0)),
        Ok(0.0)
    );
}

#[test]
fn a_triple_product_matches_quadrature() {
    // BRDF lobe around the mirror direction, one light, a visibility lobe: eq. 22.
    let scene = Scene {
        brdf: vec![lobe(1.0, unit(0.35, 0.0), 40.0), lobe(0.3, DVec3::Z, 1.0)],
        lighting: vec![lobe(2.0, unit(0.5, 0.3), 60.0)],
        visibility: vec![lobe(1.0, DVec3::Z, 0.5), lobe(0.4, unit(0.6, 0.2), 8.0)],
        normal: DVec3::Z,
    };
    let want = reference_scene(&scene).unwrap();
    for t in [energy(), l2()] {
        let got = t
            .triple_product(&scene.brdf, &scene.lighting, &scene.visibility, scene.normal, 0.0)
            .unwrap();
        // Composing three approximate products: a few percent (see the checker's
        // triple_product section for the distribution over random scenes).
        assert!((got - want).abs() < 0.05 * want, "{:?}: {got} vs {want}", t.variant());
    }
}

/// Why the product axis is not refined jointly with e_r (docs/math.md, lobe-product calls it optional):
/// moving the axis off the closed-form peak lowers the optimal L2 residual by a
/// median 1e-4 (relative), and by more only where one lobe fits the product poorly
/// anyway. A study, not a check, and slow (minutes), so `.ci/run` skips it:
/// `cargo test --release --test it axis_refinement_gains_little -- --ignored`.
#[test]
#[ignore]
fn axis_refinement_gains_little() {
    use lobefit::family::Checked;
    use lobefit::fits::lobe_product::{ref_ln_product, LobeProductFamily};
    let opt_at = |e1: f64, e2: f64, a: f64, s: f64| -> f64 {
        let ln_c = ref_ln_product(&[(2.0 * e1, 0.0), (2.0 * e2, a)]).unwrap();
        let f = |x: f64| {
            let e = x.exp_m1();
            let lb = ref_ln_product(&[(e1, 0.0), (e2, a), (e, s)]).unwrap();
            1.0 - (2.0 * lb - ln_c).exp() * (2.0 * e + 1.0) / TAU
        };
        let (mut lo, mut hi) = (0.0, (64.0 * (e1 + e2) + 1000.0f64).ln_1p());
        let g = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..60 {
            let (c, d) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if f(c) < f(d) {
                hi = d
            } else {
                lo = c
            }
        }
        f(0.5 * (lo + hi)).max(0.0).sqrt()
    };
    let fam = LobeProductFamily {
        variant: Variant::L2,
        method: lobefit::fits::Method::Fast,
    };
    let mut rng = Rng::new(99);
    let mut gains = Vec::new();
    for _ in 0..300 {
        let x = fam.sample(&mut rng);
        let (e1, e2, a) = (x[0], x[1], x[2]);
        if reference_integral(e1, e2, a).unwrap() < 1e-6 * TAU / (1.0 + e1.max(e2)) || a < 1e-3 {
            continue;
        }
        let b = peak_angle(e1, e2, a);
        let r0 = opt_at(e1, e2, a, b);
        let w = (0.3 * a).min(0.3);
        let (mut lo, mut hi) = (b - w, b + w);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..40 {
            let (c, d) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if opt_at(e1, e2, a, c) < opt_at(e1, e2, a, d) {
                hi = d
            } else {
                lo = c
            }
        }
        let r1 = opt_at(e1, e2, a, 0.5 * (lo + hi));
        gains.push((r0 - r1) / r0.max(1e-12));
    }
    gains.sort_by(f64::total_cmp);
    let n = gains.len();
    let (median, p95) = (gains[n / 2], gains[n * 95 / 100]);
    eprintln!("axis refinement, {n} points: relative residual gain median {median:.3e}, p95 {p95:.3e}");
    assert!(median < 1e-3, "{median}");
}

#[test]
fn lobe_sums_go_beyond_the_table_exponent_range() {
    // Products of sharp lobes exceed e = 1e5; the sum algebra continues with the
    // closed-form models (corrections held at their e = 1e5 values, ~1e-6).
    let t = energy();
    let a = lobe(1.0, DVec3::Z, 6e4);
    let b = lobe(1.0, unit(0.002, 0.0), 6e4);
    assert!(t.product(&a, &b).is_ok());
    let ab = t.product_sums(&[a], &[b], 0.0).unwrap();
    assert!(ab[0].exponent > 1.1e5, "{:?}", ab[0]);
    let want = reference_integral(6e4, 6e4, 0.002).unwrap();
    assert!(
        (ab[0].integral() / want - 1.0).abs() < 1e-3,
        "{} vs {want}",
        ab[0].integral()
    );
    // A second stage with a lobe on the product axis: exponents 1.2e5 and 1e5.
    let c = lobe(1.0, ab[0].axis, 1e5);
    let abc = t.product_sums(&ab, &[c], 0.0).unwrap();
    let want = ab[0].scale * reference_integral(ab[0].exponent, 1e5, 0.0).unwrap();
    assert!(
        (abc[0].integral() / want - 1.0).abs() < 1e-3,
        "{} vs {want}",
        abc[0].integral()
    );
    // The strict per-product API still refuses exponents beyond the table.
    assert!(matches!(
        t.product(&ab[0], &c),
        Err(LookupError::OutOfDomain { name, .. }) if name == "e1"
    ));
}

#[test]
fn overflowing_scales_and_bad_normals_are_errors() {
    let t = energy();
    let big = lobe(1e200, DVec3::Z, 2.0);
    assert!(matches!(
        t.product(&big, &big),
        Err(LookupError::Overflow { name, .. }) if name == "scale"
    ));
    // A vanishing product stays an exact 0 whatever the scales.
    let far = lobe(1e200, -DVec3::Z, 1e4);
    assert_eq!(t.product(&lobe(1e200, DVec3::Z, 1e4), &far).unwrap().scale, 0.0);
    let l = [lobe(1.0, DVec3::Z, 3.0)];
    assert!(matches!(
        t.triple_product(&l, &l, &[], DVec3::new(f64::NAN, 0.0, 1.0), 0.0),
        Err(LookupError::NotFinite { name, .. }) if name == "normal"
    ));
}

/// `product_integral_bound` holds: over random pairs (exponents log-uniform in
/// [0.01, 1e8) and exactly 0, axes at any angle, scales of either sign) and a broad
/// lobe against aligned and nearly aligned sharp ones (e2 to 1e8, the range a small
/// shadow leaf's cap exponent reaches), both variants, |product_integral| never
/// exceeds it — so a caller skipping products whose bound is below t_i drops only
/// products the comparison with t_i would drop. The bound's exact part is checked
/// against quadrature too (the reference integral never exceeds it). Fails when the
/// margin is taken away (the table's integral sits a little above the exact one at
/// some points). A NaN scale gives an infinite bound (nothing skipped).
#[test]
fn product_integral_stays_within_its_bound() {
    let mut rng = Rng::new(0x7b0d);
    let e = |rng: &mut Rng| {
        if rng.uniform() < 0.1 {
            0.0
        } else {
            10f64.powf(rng.range(-2.0, 8.0))
        }
    };
    let mut worst: f64 = 0.0;
    let mut worst_exact: f64 = 0.0;
    let mut pairs: Vec<(Lobe, Lobe, bool)> = Vec::new();
    for e1 in [0.0, 1.0, 3.0, 30.0] {
        for e2 in [1e3, 1e5, 1e6, 1e7, 1e8] {
            for theta in [0.0, 1e-4, 0.3, 1.2] {
                pairs.push((lobe(1.0, DVec3::Z, e1), lobe(-0.7, unit(theta, 0.4), e2), false));
            }
        }
    }
    for k in 0..4000 {
        let a = lobe(
            rng.range(-3.0, 3.0),
            unit(rng.range(0.0, PI), rng.range(0.0, TAU)),
            e(&mut rng),
        );
        let b = lobe(
            rng.range(-3.0, 3.0),
            unit(rng.range(0.0, PI), rng.range(0.0, TAU)),
            e(&mut rng),
        );
        pairs.push((a, b, k % 40 == 0));
    }
    for (a, b, quadrature) in pairs {
        let bound = LobeProduct::product_integral_bound(&a, &b);
        let exact_bound = bound / lobefit::tables::lobe_product::PRODUCT_BOUND_MARGIN;
        for t in [energy(), l2()] {
            let v = t.product_integral(&a, &b).unwrap();
            assert!(
                v.abs() <= bound,
                "{:?} {a:?} {b:?}: {v} above the bound {bound}",
                t.variant()
            );
            if exact_bound > 0.0 {
                worst = worst.max(v.abs() / exact_bound);
            }
        }
        if quadrature && a.exponent.max(b.exponent) < 2e3 {
            let alpha = a.axis.angle_between(b.axis);
            let r = reference_integral(a.exponent, b.exponent, alpha).unwrap() * (a.scale * b.scale).abs();
            assert!(
                r <= exact_bound * (1.0 + 1e-9) + 1e-300,
                "{a:?} {b:?}: {r} above {exact_bound}"
            );
            worst_exact = worst_exact.max(r / exact_bound);
        }
    }
    println!("largest |table| / exact bound {worst:.4}; largest quadrature / exact bound {worst_exact:.4}");
    let nan = lobe(f64::NAN, DVec3::Z, 1.0);
    assert_eq!(
        LobeProduct::product_integral_bound(&nan, &lobe(1.0, DVec3::Z, 2.0)),
        f64::INFINITY
    );
}

/// `sharp_product_integral` against a quadrature of its own: the product integrated in
/// the sharp lobe's polar frame (Gauss–Legendre over θ ∈ [0, 14/√e2] in 8 pieces of 24
/// nodes, the azimuth by 512 equal steps, spectrally accurate for the periodic
/// integrand), over broad exponents 0–30, sharp ones 1e3–1e8, angles up to the horizon
/// and two sharp axes (+z and a tilted one): within 1e-7 of the integral wherever it
/// answers, and it answers where its conditions say (the count is pinned). Fails when
/// the second-order term's 2ΔF is left out (2.5e-7 at e1 = 0.5, e2 = 1e3).
#[test]
fn sharp_product_integral_matches_quadrature() {
    use lobefit::tables::lobe_product::sharp_product_integral;
    let (x, w) = lobefit::sh::gauss_legendre(24);
    let quad = |a1: DVec3, e1: f64, e2: f64| {
        let top = (14.0 / e2.sqrt()).min(FRAC_PI_2);
        let pieces = 8;
        let mut sum = 0.0;
        for k in 0..pieces {
            let (lo, hi) = (top * k as f64 / pieces as f64, top * (k + 1) as f64 / pieces as f64);
            for (xi, wi) in x.iter().zip(&w) {
                let th = 0.5 * (lo + hi) + 0.5 * (hi - lo) * xi;
                let mut ring = 0.0;
                for j in 0..512 {
                    let ph = TAU * j as f64 / 512.0;
                    let v = unit(th, ph);
                    ring += a1.dot(v).max(0.0).powf(e1);
                }
                sum += 0.5 * (hi - lo) * wi * th.sin() * th.cos().powf(e2) * ring * TAU / 512.0;
            }
        }
        sum
    };
    // The sharp lobe about a2: the broad one's axis at the polar angle α from it.
    let tilted = unit(0.9, 2.1);
    let (tu, tv) = tilted.any_orthonormal_pair();
    let (mut answered, mut total, mut worst) = (0, 0, 0.0f64);
    for a2 in [DVec3::Z, tilted] {
        for e1 in [0.0, 0.5, 1.0, 2.5, 3.0, 10.0, 30.0] {
            for e2 in [1e3, 1e4, 1e5, 1e6, 1e8] {
                for alpha in [0.0, 0.05, 0.3, 0.8, 1.2, 1.45, 1.55] {
                    total += 1;
                    let a1 = if a2 == DVec3::Z {
                        unit(alpha, 0.7)
                    } else {
                        alpha.cos() * tilted + alpha.sin() * (0.6 * tu + 0.8 * tv)
                    };
                    if let Some(v) = sharp_product_integral(a1, e1, a2, e2) {
                        answered += 1;
                        // The quadrature in a2's frame: a1 seen from it.
                        let local = if a2 == DVec3::Z { a1 } else { unit(alpha, 0.9273) };
                        let q = quad(local, e1, e2);
                        let rel = (v - q).abs() / q;
                        worst = worst.max(rel);
                        assert!(
                            rel <= 1e-7,
                            "a2 {a2:?} e1 {e1} e2 {e2} α {alpha}: {v} vs {q} ({rel:.2e})"
                        );
                    }
                }
            }
        }
    }
    println!("answered {answered} of {total}; largest relative error {worst:.2e}");
    assert_eq!((answered, total), (340, 490), "{answered} of {total}");
}
