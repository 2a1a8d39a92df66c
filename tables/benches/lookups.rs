//! Every runtime lookup beside a bare interpolation gather of the same table at the
//! same (already mapped) node coordinates, and the batch APIs beside one-at-a-time
//! calls. `cargo bench -p lobefit-tables --bench lookups`; each bench runs a fixed,
//! seeded set of query points, so divan's items/s and time / N are per-call averages
//! over realistic inputs. Wall-clock numbers live here and in docs/performance.md,
//! never in tests.

use divan::counter::ItemsCount;
use divan::{black_box, Bencher};
use lobefit_tables::glam::{DVec3, Vec3};
use lobefit_tables::Table;

fn main() {
    divan::main();
}

/// Checked points per bench.
const N: usize = 1024;

/// splitmix64: a fixed, seeded stream of uniform numbers in [0, 1).
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    /// ln-uniform in [lo, hi] (lo > 0).
    fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.next()).exp().clamp(lo, hi)
    }
    fn unit(&mut self) -> DVec3 {
        let z = self.range(-1.0, 1.0);
        let p = self.range(0.0, std::f64::consts::TAU);
        let r = (1.0 - z * z).sqrt();
        DVec3::new(r * p.cos(), r * p.sin(), z)
    }
}

/// The bare gather: multilinear interpolation of a table's stored values at
/// fractional node coordinates `s` (node i at i, already mapped and clamped), every
/// channel into `out`. No mapping, no validation, no decoding: the floor any lookup
/// of the same table pays.
#[inline]
fn multilinear<const D: usize>(v: &[f32], counts: &[usize; D], s: &[f64; D], out: &mut [f64]) {
    let nc = out.len();
    let mut base = [0usize; D];
    let mut frac = [0f64; D];
    for d in 0..D {
        let i = (s[d] as usize).min(counts[d] - 2);
        base[d] = i;
        frac[d] = s[d] - i as f64;
    }
    out.iter_mut().for_each(|o| *o = 0.0);
    for corner in 0..(1usize << D) {
        let mut w = 1.0;
        let mut flat = 0usize;
        for d in 0..D {
            let hi = (corner >> (D - 1 - d)) & 1;
            w *= if hi == 1 { frac[d] } else { 1.0 - frac[d] };
            flat = flat * counts[d] + base[d] + hi;
        }
        for (c, o) in out.iter_mut().enumerate() {
            *o += w * v[flat * nc + c] as f64;
        }
    }
}

/// Node counts of a table with `D` axes.
fn counts<const D: usize>(t: &Table) -> [usize; D] {
    let mut c = [0; D];
    for (d, a) in t.meta().axes.iter().enumerate() {
        c[d] = a.count as usize;
    }
    c
}

/// Fractional node coordinates of the axis values `x` (clamped to the node range).
fn coords<const D: usize>(t: &Table, x: [f64; D]) -> [f64; D] {
    let mut s = [0.0; D];
    for (d, a) in t.meta().axes.iter().enumerate() {
        s[d] = a.node_coordinate(x[d]).clamp(0.0, (a.count - 1) as f64);
    }
    s
}

/// Bench a gather of `NC` channels at the precomputed coordinates `s` of table `t`.
fn bench_gather<const D: usize, const NC: usize>(b: Bencher, t: &Table, s: Vec<[f64; D]>) {
    let n = counts::<D>(t);
    let v = t.values();
    b.counter(ItemsCount::new(s.len())).bench_local(|| {
        let mut acc = 0.0;
        let mut out = [0.0; NC];
        for p in &s {
            multilinear(v, &n, black_box(p), &mut out);
            acc += out[0];
        }
        acc
    });
}

/// Bench `f` over the points `xs` (summing a result so nothing is optimised away).
fn bench_each<X, R>(b: Bencher, xs: &[X], f: impl Fn(&X) -> R)
where
    R: Copy,
{
    b.counter(ItemsCount::new(xs.len())).bench_local(|| {
        let mut last = None;
        for x in xs {
            last = Some(black_box(f(black_box(x))));
        }
        last
    });
}

mod cap_exponent {
    use super::*;
    use lobefit_tables::cap_exponent::{ALPHA_MIN, ALPHA_TABLE_MAX};
    use lobefit_tables::CapExponent;

    fn t() -> &'static CapExponent {
        CapExponent::embedded().unwrap()
    }
    fn alphas() -> Vec<f64> {
        let mut r = Rng::new(1);
        (0..N).map(|_| r.log_range(ALPHA_MIN, ALPHA_TABLE_MAX)).collect()
    }

    #[divan::bench]
    fn gather(b: Bencher) {
        let s = alphas().iter().map(|&a| coords(t().table(), [a])).collect();
        bench_gather::<1, 1>(b, t().table(), s);
    }
    #[divan::bench]
    fn ratio(b: Bencher) {
        bench_each(b, &alphas(), |&a| t().ratio(a).unwrap());
    }
    #[divan::bench]
    fn e_cap(b: Bencher) {
        bench_each(b, &alphas(), |&a| t().e_cap(a).unwrap());
    }
    #[divan::bench]
    fn e_cap_f32(b: Bencher) {
        let xs: Vec<f32> = alphas().iter().map(|&a| a as f32).collect();
        bench_each(b, &xs, |&a| t().e_cap_f32(a).unwrap());
    }
    #[divan::bench]
    fn e_caps_batch(b: Bencher) {
        let xs = alphas();
        let mut out = vec![0.0; xs.len()];
        b.counter(ItemsCount::new(xs.len()))
            .bench_local(|| t().e_caps(black_box(&xs), &mut out).unwrap());
    }
    #[divan::bench]
    fn e_caps_f32_batch(b: Bencher) {
        let xs: Vec<f32> = alphas().iter().map(|&a| a as f32).collect();
        let mut out = vec![0.0; xs.len()];
        b.counter(ItemsCount::new(xs.len()))
            .bench_local(|| t().e_caps_f32(black_box(&xs), &mut out).unwrap());
    }
    /// The floor: the logit mapping's ln and the model's sin, cos and ln, no table.
    #[divan::bench]
    fn floor_transcendentals(b: Bencher) {
        bench_each(b, &alphas(), |&a| {
            (a / (std::f64::consts::FRAC_PI_2 - a)).ln() + lobefit_tables::cap_exponent::model(a)
        });
    }
}

mod lobe_integral {
    use super::*;
    use lobefit_tables::lobe_integral::E_MAX;
    use lobefit_tables::LobeIntegral;

    fn t() -> &'static LobeIntegral {
        LobeIntegral::embedded().unwrap()
    }
    fn es() -> Vec<f64> {
        let mut r = Rng::new(2);
        (0..N).map(|_| r.log_range(1.0, E_MAX + 1.0) - 1.0).collect()
    }

    #[divan::bench]
    fn gather(b: Bencher) {
        let s = es().iter().map(|&e| coords(t().table(), [e])).collect();
        bench_gather::<1, 1>(b, t().table(), s);
    }
    #[divan::bench]
    fn integral(b: Bencher) {
        bench_each(b, &es(), |&e| t().integral(e).unwrap());
    }
    #[divan::bench]
    fn integral_f32(b: Bencher) {
        let xs: Vec<f32> = es().iter().map(|&e| e as f32).collect();
        bench_each(b, &xs, |&e| t().integral_f32(e).unwrap());
    }
    #[divan::bench]
    fn integrals_batch(b: Bencher) {
        let xs = es();
        let mut out = vec![0.0; xs.len()];
        b.counter(ItemsCount::new(xs.len()))
            .bench_local(|| t().integrals(black_box(&xs), &mut out).unwrap());
    }
    /// The floor: the mapping's ln_1p and the decoding exp, no table.
    #[divan::bench]
    fn floor_transcendentals(b: Bencher) {
        bench_each(b, &es(), |&e| e.ln_1p().exp());
    }
}

mod sg_fit {
    use super::*;
    use lobefit_tables::sg_fit::E_MAX;
    use lobefit_tables::SgFit;

    fn t() -> &'static SgFit {
        SgFit::embedded().unwrap()
    }
    fn es() -> Vec<f64> {
        let mut r = Rng::new(3);
        (0..N).map(|_| r.log_range(1.0, E_MAX + 1.0) - 1.0).collect()
    }

    #[divan::bench]
    fn gather(b: Bencher) {
        let s = es().iter().map(|&e| coords(t().table(), [e])).collect();
        bench_gather::<1, 2>(b, t().table(), s);
    }
    #[divan::bench]
    fn fit(b: Bencher) {
        bench_each(b, &es(), |&e| t().fit(e).unwrap());
    }
    #[divan::bench]
    fn fit_f32(b: Bencher) {
        let xs: Vec<f32> = es().iter().map(|&e| e as f32).collect();
        bench_each(b, &xs, |&e| t().fit_f32(e).unwrap());
    }
    #[divan::bench]
    fn lobe_to_sg(b: Bencher) {
        bench_each(b, &es(), |&e| {
            t().lobe_to_sg([0.0, 0.0, 1.0], e, 1.0).unwrap().sharpness
        });
    }
}

mod isg {
    use super::*;
    use lobefit_tables::isg::{warp, GAMMA_MAX, GAMMA_MIN};
    use lobefit_tables::{BestIsg, IsgModel, PaperIsg, RefitIsg};
    use std::f64::consts::{FRAC_PI_2, PI};

    fn points() -> Vec<[f64; 3]> {
        let mut r = Rng::new(4);
        (0..N)
            .map(|_| [r.range(0.0, PI), r.range(0.0, PI), r.log_range(GAMMA_MIN, GAMMA_MAX)])
            .collect()
    }
    fn points_f32() -> Vec<[f32; 3]> {
        points().iter().map(|p| p.map(|x| x as f32)).collect()
    }
    fn refit() -> &'static RefitIsg {
        RefitIsg::embedded().unwrap()
    }
    fn best() -> &'static BestIsg {
        BestIsg::embedded().unwrap()
    }

    /// One 1-D gather (g, h) at γ per Ŝ.
    #[divan::bench]
    fn refit_gather(b: Bencher) {
        let s = points().iter().map(|p| coords(refit().table(), [p[2]])).collect();
        bench_gather::<1, 2>(b, refit().table(), s);
    }
    #[divan::bench]
    fn refit_s_hat(b: Bencher) {
        bench_each(b, &points(), |p| refit().s_hat(p[0], p[1], p[2]).unwrap());
    }
    #[divan::bench]
    fn refit_s_hat_f32(b: Bencher) {
        bench_each(b, &points_f32(), |p| refit().s_hat_f32(p[0], p[1], p[2]).unwrap());
    }
    #[divan::bench]
    fn refit_s_hats_batch(b: Bencher) {
        let xs = points();
        let mut out = vec![0.0; xs.len()];
        b.counter(ItemsCount::new(xs.len()))
            .bench_local(|| refit().s_hats(black_box(&xs), &mut out).unwrap());
    }
    /// The floor: ln γ (mapping), two exp (decoding ln g, ln h), two logistic exp.
    #[divan::bench]
    fn refit_floor_transcendentals(b: Bencher) {
        bench_each(b, &points(), |p| {
            let l = p[2].ln();
            (l.exp() * (p[0] - FRAC_PI_2)).exp() + (l.exp() * (p[1] - FRAC_PI_2)).exp()
        });
    }

    /// Two 2-D gathers (all four channels) per Ŝ: one at (γ, u(θ)), one at (γ, u(φ)).
    #[divan::bench]
    fn best_gather(b: Bencher) {
        let t = best().table();
        let fold = |x: f64| if x > FRAC_PI_2 { PI - x } else { x };
        let s: Vec<[[f64; 2]; 2]> = points()
            .iter()
            .map(|p| {
                [
                    coords(t, [p[2], warp(fold(p[0]), p[2])]),
                    coords(t, [p[2], warp(fold(p[1]), p[2])]),
                ]
            })
            .collect();
        let n = counts::<2>(t);
        let v = t.values();
        b.counter(ItemsCount::new(s.len())).bench_local(|| {
            let mut acc = 0.0;
            let (mut x, mut y) = ([0.0; 4], [0.0; 4]);
            for p in &s {
                let p = black_box(p);
                multilinear(v, &n, &p[0], &mut x);
                multilinear(v, &n, &p[1], &mut y);
                acc += x[0] * y[1] + x[2] * y[3];
            }
            acc
        });
    }
    #[divan::bench]
    fn best_s_hat(b: Bencher) {
        bench_each(b, &points(), |p| best().s_hat(p[0], p[1], p[2]).unwrap());
    }
    #[divan::bench]
    fn best_s_hat_f32(b: Bencher) {
        bench_each(b, &points_f32(), |p| best().s_hat_f32(p[0], p[1], p[2]).unwrap());
    }
    #[divan::bench]
    fn best_s_hats_batch(b: Bencher) {
        let xs = points();
        let mut out = vec![0.0; xs.len()];
        b.counter(ItemsCount::new(xs.len()))
            .bench_local(|| best().s_hats(black_box(&xs), &mut out).unwrap());
    }
    /// The floor: ln γ, e^{−γ} − 1 and the warp (sin, exp_m1, sqrt) of θ and of φ.
    #[divan::bench]
    fn best_floor_transcendentals(b: Bencher) {
        bench_each(b, &points(), |p| {
            p[2].ln() + warp(p[0].min(FRAC_PI_2), p[2]) + warp(p[1].min(FRAC_PI_2), p[2])
        });
    }
    /// The published model needs no table: for scale.
    #[divan::bench]
    fn paper_s_hat(b: Bencher) {
        bench_each(b, &points(), |p| PaperIsg.s_hat(p[0], p[1], p[2]).unwrap());
    }
}

mod log_zh {
    use super::*;
    use lobefit_tables::log_zh::{Kind, EPS_MAX, EPS_MIN, R_MIN, R_TABLE_MAX};
    use lobefit_tables::LogZh;

    fn t() -> &'static LogZh {
        LogZh::embedded().unwrap()
    }
    /// (ε, r) with r inside the table's range.
    fn points() -> Vec<[f64; 2]> {
        let mut r = Rng::new(5);
        (0..N)
            .map(|_| [r.log_range(EPS_MIN, EPS_MAX), r.log_range(R_MIN, R_TABLE_MAX)])
            .collect()
    }

    /// All 16 stored channels (8 hi/lo pairs) at (r, ε).
    #[divan::bench]
    fn gather(b: Bencher) {
        let s = points().iter().map(|p| coords(t().table(), [p[1], p[0]])).collect();
        bench_gather::<2, 16>(b, t().table(), s);
    }
    #[divan::bench]
    fn table_lookup_order8(b: Bencher) {
        bench_each(b, &points(), |p| {
            let mut z = [0.0; 8];
            t().table_lookup(8, p[0], p[1], &mut z).unwrap();
            z[0]
        });
    }
    /// The closed form (reads no table).
    #[divan::bench]
    fn lookup_phong_order8(b: Bencher) {
        bench_each(b, &points(), |p| {
            let mut z = [0.0; 8];
            t().lookup(Kind::Phong, 8, p[0], p[1], &mut z).unwrap();
            z[0]
        });
    }
    #[divan::bench]
    fn lookup_blocker_order8(b: Bencher) {
        bench_each(b, &points(), |p| {
            let mut z = [0.0; 8];
            t().lookup(Kind::Blocker, 8, p[0], p[1] / R_TABLE_MAX * 1.5, &mut z)
                .unwrap();
            z[0]
        });
    }
}

mod wedge {
    use super::*;
    use lobefit_tables::wedge::{slice_log, COLS, ROWS};
    use lobefit_tables::Wedge;

    fn t() -> &'static Wedge {
        Wedge::embedded().unwrap()
    }
    const ORDERS: [usize; 2] = [4, 8];
    /// Slice log vectors (v_a, v_b) of random horizons.
    fn slices(n: usize) -> Vec<([f64; 8], [f64; 8])> {
        let mut r = Rng::new(6);
        (0..N)
            .map(|_| {
                let (mut a, mut b) = ([0.0; 8], [0.0; 8]);
                slice_log(r.range(-1.5, 1.5), 0.1, n, &mut a).unwrap();
                slice_log(r.range(-1.5, 1.5), 0.1, n, &mut b).unwrap();
                (a, b)
            })
            .collect()
    }

    /// The bare operator: V = M [v_a; v_b] from the stored (hi + lo) values of W = 16.
    #[divan::bench(args = ORDERS)]
    fn gather(b: Bencher, n: usize) {
        let v = t().table().values();
        let xs = slices(n);
        let w = 2; // W = 16
        b.counter(ItemsCount::new(xs.len())).bench_local(|| {
            let mut out = [0.0; 64];
            for (va, vb) in &xs {
                let (va, vb) = black_box((va, vb));
                for (row, o) in out.iter_mut().take(n * n).enumerate() {
                    let base = (w * ROWS as usize + row) * COLS as usize;
                    let mut s = 0.0;
                    for j in 0..n {
                        let m = |c: usize| v[2 * (base + c)] as f64 + v[2 * (base + c) + 1] as f64;
                        s += m(j) * va[j] + m(8 + j) * vb[j];
                    }
                    *o = s;
                }
                black_box(&out);
            }
            out[0]
        });
    }
    #[divan::bench(args = ORDERS)]
    fn wedge(b: Bencher, n: usize) {
        bench_each(b, &slices(n), |(va, vb)| {
            let mut out = [0.0; 64];
            t().wedge(16, &va[..n], &vb[..n], &mut out).unwrap();
            out[0]
        });
    }
}

mod wrap {
    use super::*;
    use lobefit_tables::Wrap;

    fn t() -> &'static Wrap {
        Wrap::embedded().unwrap()
    }
    fn xs() -> Vec<f64> {
        let mut r = Rng::new(7);
        (0..N).map(|_| r.next()).collect()
    }

    #[divan::bench]
    fn gather(b: Bencher) {
        let s = xs().iter().map(|&a| coords(t().table(), [a])).collect();
        bench_gather::<1, 8>(b, t().table(), s);
    }
    #[divan::bench]
    fn table_lookup_order8(b: Bencher) {
        bench_each(b, &xs(), |&a| {
            let mut l = [0.0; 8];
            t().table_lookup(8, a, &mut l).unwrap();
            l[0]
        });
    }
    /// The closed form (reads no table).
    #[divan::bench]
    fn lookup_order8(b: Bencher) {
        bench_each(b, &xs(), |&a| {
            let mut l = [0.0; 8];
            t().lookup(8, a, &mut l).unwrap();
            l[0]
        });
    }
}

mod disk_light {
    use super::*;
    use lobefit_tables::disk_light::{rim_coordinate, R_MAX, R_MIN, TAU_MAX};
    use lobefit_tables::DiskLight;

    fn t() -> &'static DiskLight {
        DiskLight::embedded().unwrap()
    }
    /// (R/d, τ) inside the table.
    fn points() -> Vec<[f64; 2]> {
        let mut r = Rng::new(8);
        (0..N)
            .map(|_| [r.log_range(R_MIN, R_MAX), r.range(0.0, TAU_MAX)])
            .collect()
    }
    /// (receiver, centre, normal, radius) with the disk facing the receiver.
    fn scenes() -> Vec<(DVec3, DVec3, DVec3, f64)> {
        let mut r = Rng::new(9);
        (0..N)
            .map(|_| {
                let c = r.unit() * r.range(1.0, 5.0);
                let mut n = r.unit();
                if n.dot(c) > 0.0 {
                    n = -n;
                }
                (DVec3::ZERO, c, n, r.range(0.05, 2.0))
            })
            .collect()
    }

    #[divan::bench]
    fn gather(b: Bencher) {
        let s = points()
            .iter()
            .map(|p| coords(t().table(), [rim_coordinate(p[0], p[1]), p[1]]))
            .collect();
        bench_gather::<2, 6>(b, t().table(), s);
    }
    #[divan::bench]
    fn canonical(b: Bencher) {
        bench_each(b, &points(), |p| t().canonical(p[0], p[1]).unwrap()[0]);
    }
    #[divan::bench]
    fn irradiance_sh(b: Bencher) {
        bench_each(b, &scenes(), |&(p, c, n, r)| {
            t().irradiance_sh(p, c, n, r, 1.0).unwrap()[0]
        });
    }
    #[divan::bench]
    fn irradiance_sh_f32(b: Bencher) {
        let xs: Vec<(Vec3, Vec3, Vec3, f32)> = scenes()
            .iter()
            .map(|&(p, c, n, r)| (p.as_vec3(), c.as_vec3(), n.as_vec3(), r as f32))
            .collect();
        bench_each(b, &xs, |&(p, c, n, r)| {
            t().irradiance_sh_f32(p, c, n, r, 1.0).unwrap()[0]
        });
    }
}

mod shexp {
    use super::*;
    use lobefit_tables::gaunt::Gaunt;
    use lobefit_tables::sh::zh_to_sh;
    use lobefit_tables::ShExp;

    fn t() -> &'static ShExp {
        ShExp::embedded().unwrap()
    }
    const ORDERS: [usize; 6] = [3, 4, 5, 6, 7, 8];
    fn thetas() -> Vec<f64> {
        let mut r = Rng::new(10);
        (0..N).map(|_| r.range(0.0, 1.2)).collect()
    }
    /// Summed log-SH visibility of 1..4 random cap blockers at order n.
    fn fields(n: usize, count: usize) -> Vec<[f64; 64]> {
        let mut r = Rng::new(11);
        (0..count)
            .map(|_| {
                let mut f = [0.0; 64];
                for _ in 0..1 + (r.next() * 4.0) as usize {
                    let mut z = [0.0; 8];
                    t().log_zh(r.range(0.05, 0.5), n, &mut z).unwrap();
                    let mut s = [0.0; 64];
                    zh_to_sh(&z[..n], r.unit().to_array(), &mut s[..n * n]).unwrap();
                    f.iter_mut().zip(&s).for_each(|(a, b)| *a += b);
                }
                f
            })
            .collect()
    }

    /// The 8 f pairs (16 channels of the 24) at (order, θ_b), linearly.
    #[divan::bench(args = ORDERS)]
    fn gather(b: Bencher, n: usize) {
        let tab = t().table();
        let s: Vec<[f64; 2]> = thetas().iter().map(|&x| coords(tab, [n as f64, x])).collect();
        let c = counts::<2>(tab);
        let v = tab.values();
        b.counter(ItemsCount::new(s.len())).bench_local(|| {
            let mut acc = 0.0;
            let mut out = [0.0; 24];
            for p in &s {
                multilinear(v, &c, black_box(p), &mut out);
                acc += out[0];
            }
            acc
        });
    }
    /// Cubic, kink-aware interpolation of the 8 pairs.
    #[divan::bench(args = ORDERS)]
    fn log_zh(b: Bencher, n: usize) {
        bench_each(b, &thetas(), |&x| {
            let mut z = [0.0; 8];
            t().log_zh(x, n, &mut z).unwrap();
            z[0]
        });
    }
    /// The OL coefficients from ‖f̂‖ (binary search on the monotone branch).
    #[divan::bench(args = ORDERS)]
    fn ab_for_norm(b: Bencher, n: usize) {
        let top = t().norm_max(n).unwrap();
        let xs: Vec<f64> = thetas().iter().map(|x| x / 1.2 * top).collect();
        bench_each(b, &xs, |&x| t().ab_for_norm(x, n).unwrap().0);
    }
    #[divan::bench(args = ORDERS)]
    fn hyb(b: Bencher, n: usize) {
        let fs = fields(n, 256);
        bench_each(b, &fs, |f| {
            let mut out = [0.0; 64];
            t().hyb(&f[..n * n], &mut out).unwrap()
        });
    }
    /// One SH product of order n, HYB's unit of work (it squares k times).
    #[divan::bench(args = ORDERS)]
    fn gaunt_product(b: Bencher, n: usize) {
        let g = Gaunt::cached(n).unwrap();
        let fs = fields(n, 256);
        bench_each(b, &fs, |f| {
            let mut out = [0.0; 64];
            g.product_into(&f[..n * n], &f[..n * n], &mut out[..n * n]);
            out[0]
        });
    }
}

mod lobe_product {
    use super::*;
    use lobefit_tables::{Lobe, Lobe32, LobeProduct};
    use std::f64::consts::PI;

    fn energy() -> &'static LobeProduct {
        LobeProduct::embedded().unwrap()
    }
    fn l2() -> &'static LobeProduct {
        LobeProduct::embedded_l2().unwrap()
    }
    /// (e1, e2, α): exponents ln-uniform in [0.1, 10⁴], α uniform in [0, π].
    fn points() -> Vec<[f64; 3]> {
        let mut r = Rng::new(12);
        (0..N)
            .map(|_| [r.log_range(0.1, 1e4), r.log_range(0.1, 1e4), r.range(0.0, PI)])
            .collect()
    }
    fn lobes() -> Vec<(Lobe, Lobe)> {
        let mut r = Rng::new(13);
        (0..N)
            .map(|_| {
                let mut l = || Lobe {
                    scale: r.range(0.5, 2.0),
                    axis: r.unit(),
                    exponent: r.log_range(0.1, 1e4),
                };
                (l(), l())
            })
            .collect()
    }

    /// Both channels (3 for l2) at (e1, e2, α): 8 corners.
    #[divan::bench]
    fn gather(b: Bencher) {
        let s = points().iter().map(|p| coords(energy().table(), *p)).collect();
        bench_gather::<3, 2>(b, energy().table(), s);
    }
    #[divan::bench]
    fn params(b: Bencher) {
        bench_each(b, &points(), |p| energy().params(p[0], p[1], p[2]).unwrap().e_r);
    }
    #[divan::bench]
    fn params_l2(b: Bencher) {
        bench_each(b, &points(), |p| l2().params(p[0], p[1], p[2]).unwrap().e_r);
    }
    #[divan::bench]
    fn product(b: Bencher) {
        bench_each(b, &lobes(), |(a, c)| energy().product(a, c).unwrap().exponent);
    }
    #[divan::bench]
    fn product_f32(b: Bencher) {
        let xs: Vec<(Lobe32, Lobe32)> = lobes()
            .iter()
            .map(|(a, c)| {
                let n = |l: &Lobe| Lobe32 {
                    scale: l.scale as f32,
                    axis: l.axis.as_vec3(),
                    exponent: l.exponent as f32,
                };
                (n(a), n(c))
            })
            .collect();
        bench_each(b, &xs, |(a, c)| energy().product_f32(a, c).unwrap().exponent);
    }
    #[divan::bench]
    fn products_batch(b: Bencher) {
        let xs = lobes();
        let mut out = vec![xs[0].0; xs.len()];
        b.counter(ItemsCount::new(xs.len()))
            .bench_local(|| energy().products(black_box(&xs), &mut out).unwrap());
    }
    /// The floor of `params` without the table: the closed-form terms it must add to
    /// the stored corrections (mapping ln_1p ×2 and asinh, the model exponent, ln M
    /// with its two ln Γ, the peak fraction).
    #[divan::bench]
    fn floor_closed_form(b: Bencher) {
        use lobefit_tables::lobe_product::{exponent_model, ln_model, peak_fraction};
        bench_each(b, &points(), |p| {
            let m =
                (10.0 * p[0]).ln_1p() + (10.0 * p[1]).ln_1p() + ((p[2] - std::f64::consts::FRAC_PI_2) / 2e-3).asinh();
            m + exponent_model(p[0], p[1], p[2]) + ln_model(p[0], p[1], p[2]) + peak_fraction(p[0], p[1], p[2])
        });
    }
    /// ln W(E) (two Lanczos ln Γ), one term of ln M.
    #[divan::bench]
    fn ln_w(b: Bencher) {
        bench_each(b, &points(), |p| lobefit_tables::lobe_product::ln_w(p[0] + p[1]));
    }
    /// A cheaper alternative tried for ln W(E): the asymptotic series of
    /// ln Γ(x + ½) − ln Γ(x), x = E/2 + 1 (one ln and a polynomial in 1/x²; for E ≥ 30).
    /// Not adopted: it differs from the Lanczos path by up to ~1e-11 at E ~ 10⁴–10⁵
    /// (that path's own rounding), above the bit-identical bar.
    #[divan::bench]
    fn ln_w_asymptotic(b: Bencher) {
        bench_each(b, &points(), |p| {
            let x = 0.5 * (p[0] + p[1]) + 1.0;
            let y = 1.0 / (x * x);
            let s = (1.0 / 8.0) - y * (1.0 / 192.0 - y * (1.0 / 640.0 - y * (17.0 / 14336.0)));
            0.5 * (std::f64::consts::PI.ln() - x.ln()) + s / x
        });
    }
}
