//!: the committed `shexp` table through the runtime against the
//! independent reference (quadrature-built product matrices, direct log), HYB against
//! the Taylor reference, Ren's log round trip, `eval shexp`, and every bad input.

use crate::common;
use std::f64::consts::PI;

use lobefit::fits::shexp::exp_log::{exp_scaling_squaring, ren_log_zonal, zh_to_sh_z};
use lobefit::fits::shexp::reference_point;
use lobefit::fits::shexp::study::rel_l2;
use lobefit::sh::{exp_star, Gaunt};
use lobefit::tables::shexp::{self as rt, cap_visibility_zh, ShExp, ORDER_MAX, ORDER_MIN};
use lobefit::tables::{LoadError, LookupError};

/// Stored nodes vs the reference: f relative to ‖f‖; ‖f̂‖, a, b relative.
const GRID: f64 = 1e-9;
/// Off-grid θ_b through the runtime.
const OFFGRID: f64 = 1e-4;

fn table() -> &'static ShExp {
    ShExp::embedded().expect("committed table loads")
}

/// Errors of the runtime at θ_b against the reference, all orders: max over
/// (f in units of ‖f‖, ‖f̂‖ relative, a relative, b relative).
fn errors(t: &ShExp, theta: f64) -> [f64; 4] {
    let mut e = [0.0f64; 4];
    for n in ORDER_MIN..=ORDER_MAX {
        let (f, norm, a, b) = reference_point(theta, n).unwrap();
        let mut got = [0.0; 8];
        t.log_zh(theta, n, &mut got).unwrap();
        let fnorm = f.iter().map(|v| v * v).sum::<f64>().sqrt();
        for l in 0..n {
            let d = (got[l] - f[l]).abs();
            e[0] = e[0].max(if fnorm > 0.0 { d / fnorm } else { d });
        }
        let (gn, ga, gb) = t.norm_ab(theta, n).unwrap();
        let rel = |x: f64, y: f64| if y == 0.0 { (x - y).abs() } else { (x / y - 1.0).abs() };
        e[1] = e[1].max(rel(gn, norm));
        e[2] = e[2].max(rel(ga, a));
        e[3] = e[3].max(rel(gb, b));
    }
    e
}

#[test]
fn committed_table_matches_the_reference_on_and_off_the_grid() {
    let t = table();
    let mut on = [0.0f64; 4];
    // Every 16th node and the ends (the checker covers every node).
    for i in (0..rt::THETA_NODES as usize)
        .step_by(16)
        .chain([rt::THETA_NODES as usize - 1])
    {
        let e = errors(t, rt::node_theta(i));
        on.iter_mut().zip(e).for_each(|(a, b)| *a = a.max(b));
    }
    let mut off = [0.0f64; 4];
    let mut rng = lobefit::rng::Rng::new(11);
    for k in 0..400 {
        let theta = if k % 2 == 0 {
            rng.range(0.0, PI / 2.0)
        } else {
            rng.range((1e-4f64).ln(), (PI / 2.0).ln()).exp()
        };
        let e = errors(t, theta);
        off.iter_mut().zip(e).for_each(|(a, b)| *a = a.max(b));
    }
    eprintln!("shexp table vs reference [f/|f|, norm, a, b]: nodes {on:?}, off-grid {off:?}");
    assert!(on.iter().all(|e| *e <= GRID), "{on:?}");
    assert!(off.iter().all(|e| *e <= OFFGRID), "{off:?}");
}

/// ‖f̂‖ is not monotonic in θ_b at some orders: the a/b-vs-‖f̂‖ lookup uses the
/// monotone branch, and agrees there with the θ_b lookup.
#[test]
fn ab_vs_norm_on_the_monotone_branch() {
    let t = table();
    for n in ORDER_MIN..=ORDER_MAX {
        let end = t.branch_end_theta(n).unwrap();
        assert!(end > 1.0, "order {n}: branch ends at {end}");
        assert!(t.norm_max(n).unwrap() > 4.8);
        for k in 1..50 {
            let theta = end * k as f64 / 50.0;
            let (norm, a, b) = t.norm_ab(theta, n).unwrap();
            let (a2, b2) = t.ab_for_norm(norm, n).unwrap();
            assert!(
                (a2 / a - 1.0).abs() < 1e-4 && (b2 / b - 1.0).abs() < 1e-4,
                "n={n} θ={theta}"
            );
        }
        assert_eq!(t.ab_for_norm(0.0, n).unwrap(), (1.0, 1.0));
    }
    // Orders 3 and 5..8 have an interior maximum; order 4 rises to π/2.
    for n in [3, 5, 6, 7, 8] {
        assert!(t.branch_end_theta(n).unwrap() < 1.5, "order {n}");
    }
    assert_eq!(t.branch_end_theta(4).unwrap(), PI / 2.0);
}

/// HYB through the runtime: exp of the DC exactly, OL below the threshold, and close
/// to the Taylor reference for a cap; the f32 twin matches.
#[test]
fn hyb_against_taylor() {
    let t = table();
    for n in [3usize, 4, 8] {
        let gaunt = Gaunt::new(n);
        let mut zh = [0.0; 8];
        t.log_zh(0.6, n, &mut zh).unwrap();
        let mut f = zh_to_sh_z(&zh[..n]);
        f[0] += 0.7;
        let want = exp_star(&gaunt, &f).value;
        let mut got = vec![0.0; n * n];
        let k = t.hyb(&f, &mut got).unwrap();
        assert!(k > 0);
        let e = rel_l2(&got, &want);
        // Measured 1.8e-3, 4.3e-4, 6.0e-3 at orders 3, 4, 8 (1, 4, 8 squarings); the
        // bound leaves room, the study (docs/shexp.md) has the distributions.
        eprintln!("order {n}: HYB vs Taylor {e:.2e} ({k} squarings)");
        assert!(e < 1e-2, "order {n}: {e:e}");
        // Scaling and squaring with the same k is what HYB approximates.
        let ss = exp_scaling_squaring(&gaunt, &f, k).value;
        assert!(rel_l2(&got, &ss) < 1e-2);
        let (nn, aa, bb) = t.norm_ab(0.6, n).unwrap();
        let (n32, a32, b32) = t.norm_ab_f32(0.6, n).unwrap();
        assert!((n32 as f64 / nn - 1.0).abs() < 1e-6 && (a32 as f64 / aa - 1.0).abs() < 1e-6);
        assert!((b32 as f64 / bb - 1.0).abs() < 1e-6);
        let (a2, _) = t.ab_for_norm_f32(nn as f32, n).unwrap();
        assert!((a2 as f64 / aa - 1.0).abs() < 1e-4);
        let mut z32 = [0.0f32; 8];
        t.log_zh_f32(0.6, n, &mut z32).unwrap();
        assert!((z32[0] as f64 - zh[0]).abs() < 1e-6 * zh[0].abs());
        let f32v: Vec<f32> = f.iter().map(|v| *v as f32).collect();
        let mut o32 = vec![0.0f32; n * n];
        t.hyb_f32(&f32v, &mut o32).unwrap();
        for (a, b) in o32.iter().zip(&got) {
            assert!((*a as f64 - b).abs() < 1e-5 * (1.0 + b.abs()));
        }
    }
}

/// exp*(Ren log g) = g for caps without clamping, to the truncation's
/// non-commutativity; the clamp's effect above the onset (measured in docs/shexp.md).
#[test]
fn ren_log_round_trip() {
    for n in ORDER_MIN..=ORDER_MAX {
        let gaunt = Gaunt::new(n);
        let mut worst = (0.0f64, 0.0f64);
        for k in 1..=40 {
            let theta = PI / 2.0 * k as f64 / 40.0;
            let g = cap_visibility_zh(theta, n).unwrap()[..n].to_vec();
            let r = ren_log_zonal(&gaunt, &g).unwrap();
            let e = rel_l2(&exp_star(&gaunt, &zh_to_sh_z(&r.f)).value, &zh_to_sh_z(&g));
            if r.clamped == 0 {
                worst.0 = worst.0.max(e);
            } else {
                worst.1 = worst.1.max(e);
            }
        }
        eprintln!(
            "order {n}: round trip max {:.2e} (no clamp), {:.2e} (clamped)",
            worst.0, worst.1
        );
        assert!(worst.0 < 1e-2 && worst.1 < 0.1, "{worst:?}");
    }
}

#[test]
fn bad_inputs_have_their_own_errors() {
    let t = table();
    let mut out = [0.0; 64];
    let nf = |r: Result<(), LookupError>| matches!(r, Err(LookupError::NotFinite { .. }));
    let od = |r: Result<(), LookupError>, what: &str| matches!(r, Err(LookupError::OutOfDomain { name, .. }) if name == what);
    assert!(nf(t.log_zh(f64::NAN, 4, &mut out)));
    assert!(od(t.log_zh(-0.1, 4, &mut out), "theta_b"));
    assert!(od(t.log_zh(1.6, 4, &mut out), "theta_b"));
    assert!(od(t.log_zh(0.5, 2, &mut out), "order"));
    assert!(od(t.log_zh(0.5, 9, &mut out), "order"));
    assert!(matches!(
        t.log_zh(0.5, 5, &mut out[..4]),
        Err(LookupError::Channels { .. })
    ));
    assert!(od(t.norm_ab(2.0, 4).map(|_| ()), "theta_b"));
    assert!(od(t.ab_for_norm(100.0, 4).map(|_| ()), "|f_hat|"));
    assert!(od(t.ab_for_norm(-1.0, 4).map(|_| ()), "|f_hat|"));
    assert!(nf(t.ab_for_norm(f64::NAN, 4).map(|_| ())));
    // HYB: vector length not n², order outside 3..8, NaN, bad threshold, huge norm.
    assert!(matches!(t.hyb(&[0.0; 10], &mut out), Err(LookupError::ShLength { .. })));
    assert!(od(t.hyb(&[0.0; 4], &mut out).map(|_| ()), "order"));
    let mut f = [0.0; 16];
    f[3] = f64::NAN;
    assert!(nf(t.hyb(&f, &mut out).map(|_| ())));
    assert!(od(t.hyb_threshold(&[0.0; 16], 0.0, &mut out).map(|_| ()), "threshold"));
    assert!(od(
        t.hyb_threshold(&[0.0; 16], 100.0, &mut out).map(|_| ()),
        "threshold"
    ));
    let mut big = [0.0; 16];
    big[2] = 1e30;
    assert!(od(t.hyb(&big, &mut out).map(|_| ()), "|f_hat|"));
    assert!(matches!(
        t.hyb(&[0.0; 16], &mut out[..8]),
        Err(LookupError::Output { .. })
    ));
    assert!(matches!(
        t.hyb_f32(&[0.0; 81], &mut [0.0; 81]),
        Err(LookupError::Arity { .. })
    ));
    assert!(od(rt::ol_threshold(2).map(|_| ()), "order"));
    // Overflow: exp* of a huge DC term, or of a large f̂, is an error, never Ok(inf/NaN).
    let mut hot = [0.0; 16];
    hot[0] = 3000.0;
    assert!(matches!(t.hyb(&hot, &mut out), Err(LookupError::NotFinite { .. })));
    let mut wide = [0.0; 16];
    wide[2] = 5e3;
    assert!(matches!(t.hyb(&wide, &mut out), Err(LookupError::NotFinite { .. })));
    let mut warm = [0.0; 16];
    warm[0] = 330.0; // e^{330/√(4π)} ≈ 1e40: finite in f64, not in f32
    let warm32 = warm.map(|v| v as f32);
    assert!(t.hyb(&warm, &mut out).is_ok());
    // Finite in f64, beyond f32: the twins' overflow error.
    assert!(matches!(
        t.hyb_f32(&warm32, &mut [0.0f32; 16]),
        Err(LookupError::Overflow { .. })
    ));
    f[3] = f64::INFINITY;
    assert!(nf(t.hyb(&f, &mut out).map(|_| ())));
    // The free helpers validate too.
    assert!(nf(rt::ol(f64::NAN, 1.0, &[0.0; 16], &mut out)));
    assert!(matches!(
        rt::ol(1.0, 1.0, &[], &mut out),
        Err(LookupError::Coefficients { .. })
    ));
    assert!(matches!(
        rt::ol(1.0, 1.0, &[0.0; 16], &mut out[..4]),
        Err(LookupError::Output { .. })
    ));
    assert!(matches!(
        rt::ab_of_pair(&[], &[]),
        Err(LookupError::Coefficients { .. })
    ));
    assert!(matches!(
        rt::ab_of_pair(&[1.0; 3], &[1.0; 4]),
        Err(LookupError::Coefficients { .. })
    ));
    assert!(nf(rt::ab_of_pair(&[1.0, f64::NAN], &[1.0, 2.0]).map(|_| ())));
    assert!(nf(cap_visibility_zh(f64::NAN, 4).map(|_| ())));
    assert!(od(cap_visibility_zh(4.0, 4).map(|_| ()), "theta_b"));
    assert!(od(cap_visibility_zh(0.5, 9).map(|_| ()), "SH order"));
    assert!(od(cap_visibility_zh(0.5, 0).map(|_| ()), "SH order"));
    // Loading another family's file is refused by kind.
    assert!(matches!(
        ShExp::from_bytes(lobefit::tables::embedded::LOG_ZH),
        Err(LoadError::WrongKind { .. })
    ));
}

/// `lobefit ARGS` as (success, stdout, stderr).
fn eval(args: &[&str], stdin: &str) -> (bool, String, String) {
    let (code, out, err) = common::run_text(args, stdin);
    (code == Some(0), out, err)
}

#[test]
fn eval_shexp() {
    let (ok, out, err) = eval(&["eval", "shexp", "--order", "3"], "theta_b\n0.5\n");
    assert!(ok, "{err}");
    let mut lines = out.lines();
    assert_eq!(lines.next(), Some("theta_b,f0,f1,f2,norm,a,b"));
    let v: Vec<f64> = lines.next().unwrap().split(',').map(|x| x.parse().unwrap()).collect();
    let (f, norm, a, b) = reference_point(0.5, 3).unwrap();
    for l in 0..3 {
        assert!((v[1 + l] - f[l]).abs() < 1e-6);
    }
    assert!((v[4] / norm - 1.0).abs() < 1e-6 && (v[5] / a - 1.0).abs() < 1e-6 && (v[6] / b - 1.0).abs() < 1e-6);
    // Naive log: log ε · cap, closed form; --exact by quadrature.
    let (ok, out, err) = eval(
        &["eval", "shexp", "--log", "naive", "--exact"],
        "theta_b,eps\n0.5,0.1\n",
    );
    assert!(ok, "{err}");
    let row: Vec<f64> = out
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    let cap = lobefit::tables::log_zh::cap_zh(0.5, 4);
    for l in 0..4 {
        assert!((row[2 + l] - 0.1f64.ln() * cap[l]).abs() < 1e-9);
    }
    let (ok, _, err) = eval(&["eval", "shexp", "--kind", "phong"], "theta_b\n0.5\n");
    assert!(
        !ok && err.contains("shexp takes no --kind flag (only --order, --log)"),
        "{err}"
    );
    let (ok, _, err) = eval(&["eval", "shexp"], "theta_b\n1.7\n");
    assert!(!ok && err.contains("theta_b"), "{err}");
}

/// a and b are the least-squares OL fit of ĝ = e^{−f_0/√(4π)} g on {1, f̂} (docs/math.md, shexp):
/// checked by the normal equations — the residual ĝ − a·1 − b·f̂ is orthogonal to 1 and
/// to f̂ — on random vectors, not against the formula `ab_of_pair` implements.
#[test]
fn ab_is_the_least_squares_ol_fit() {
    let mut rng = lobefit::rng::Rng::new(11);
    let s = (4.0 * PI).sqrt();
    for n in [4usize, 9, 16, 64] {
        let f: Vec<f64> = (0..n).map(|_| rng.range(-1.0, 1.0)).collect();
        let g: Vec<f64> = (0..n).map(|_| rng.range(-1.0, 1.0)).collect();
        let (a, b, norm) = rt::ab_of_pair(&g, &f).unwrap();
        let e = (-f[0] / s).exp();
        let resid: Vec<f64> = (0..n)
            .map(|i| e * g[i] - if i == 0 { a * s } else { b * f[i] })
            .collect();
        let along_one = resid[0] * s;
        let along_fhat: f64 = (1..n).map(|i| resid[i] * f[i]).sum();
        assert!(
            along_one.abs() < 1e-12 && along_fhat.abs() < 1e-12,
            "n={n}: {along_one} {along_fhat}"
        );
        let want_norm = f[1..].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((norm - want_norm).abs() < 1e-14);
        // OL reproduces a·1 + b·f̂.
        let mut out = vec![0.0; n];
        rt::ol(a, b, &f, &mut out).unwrap();
        assert!((out[0] - a * s).abs() < 1e-15 && (1..n).all(|i| out[i] == b * f[i]));
    }
}

/// The two readings of Ren's clamp (docs/shexp.md): the q-form with the clamp inside q
/// (the table's) and the log of the clamped matrix applied to 1. Prints the max round
/// trip exp*(log g) vs g over clamped caps for both; the q-form's must not be worse.
/// `cargo test --test it shexp::clamp_conventions -- --nocapture`.
#[test]
fn clamp_conventions_round_trip() {
    use lobefit::eigen::sym_eigen;
    use lobefit::sh::exp_taylor;
    for order in ORDER_MIN..=ORDER_MAX {
        let gaunt = Gaunt::new(order);
        let nc = order * order;
        let one = lobefit::sh::one(order).unwrap();
        let (mut worst_q, mut worst_m) = (0.0f64, 0.0f64);
        for i in 1..=200 {
            let g = zh_to_sh_z(&cap_visibility_zh(PI / 2.0 * i as f64 / 200.0, order).unwrap()[..order]);
            let mut h = g.clone();
            h[0] -= (4.0 * PI).sqrt();
            let e = sym_eigen(&gaunt.product_matrix(&h), nc).unwrap();
            let floor = 0.02 * (1.0 + e.values[nc - 1]);
            if 1.0 + e.values[0] >= floor {
                continue;
            }
            let (mut fq, mut fm) = (vec![0.0; nc], vec![0.0; nc]);
            for k in 0..nc {
                let lam = 1.0 + e.values[k];
                let ph: f64 = (0..nc).map(|j| e.vector(k, j) * h[j]).sum();
                let p1: f64 = (0..nc).map(|j| e.vector(k, j) * one[j]).sum();
                let (cq, cm) = if lam < floor {
                    (floor.ln() / (floor - 1.0) * ph, floor.ln() * p1)
                } else {
                    let c = lam.ln() / (lam - 1.0) * ph;
                    (c, c)
                };
                for j in 0..nc {
                    fq[j] += e.vector(k, j) * cq;
                    fm[j] += e.vector(k, j) * cm;
                }
            }
            worst_q = worst_q.max(rel_l2(&exp_taylor(&gaunt, &fq).value, &g));
            worst_m = worst_m.max(rel_l2(&exp_taylor(&gaunt, &fm).value, &g));
        }
        println!("order {order}: clamped round trip max, clamp inside q {worst_q:.2e}, clamped matrix {worst_m:.2e}");
        assert!(worst_q <= worst_m, "order {order}");
    }
}
