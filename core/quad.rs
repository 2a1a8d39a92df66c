//! Quadrature. Two independent rules on purpose (ARCHITECTURE.md): the checker uses
//! [`gauss_kronrod`] (globally adaptive G7–K15, QUADPACK QAG style); fits use
//! [`adaptive_simpson`]. A fit can then never agree with its checker by sharing a bug.

use std::collections::BinaryHeap;

/// Result of an adaptive integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quad {
    /// Integral estimate.
    pub value: f64,
    /// Estimated absolute error.
    pub error: f64,
    /// Integrand evaluations.
    pub evals: u32,
    /// Whether the requested tolerance was met.
    pub converged: bool,
}

// Kronrod 15-point abscissae (positive half, descending) and weights; the Gauss
// 7-point rule uses the odd-indexed abscissae. Values from QUADPACK (dqk15), kept at
// their published precision.
#[allow(clippy::excessive_precision)]
const XGK: [f64; 8] = [
    0.991_455_371_120_812_639_206_854_697_526_329,
    0.949_107_912_342_758_524_526_189_684_047_851,
    0.864_864_423_359_769_072_789_712_788_640_926,
    0.741_531_185_599_394_439_863_864_773_280_788,
    0.586_087_235_467_691_130_294_144_845_693_013,
    0.405_845_151_377_397_166_906_606_412_076_961,
    0.207_784_955_007_898_467_600_689_403_773_245,
    0.0,
];
#[allow(clippy::excessive_precision)]
const WGK: [f64; 8] = [
    0.022_935_322_010_529_224_963_732_008_058_970,
    0.063_092_092_629_978_553_290_700_663_189_204,
    0.104_790_010_322_250_183_839_876_322_541_518,
    0.140_653_259_715_525_918_745_189_590_510_238,
    0.169_004_726_639_267_902_826_583_426_598_550,
    0.190_350_578_064_785_409_913_256_402_421_014,
    0.204_432_940_075_298_892_414_161_999_234_649,
    0.209_482_141_084_727_828_012_999_174_891_714,
];
#[allow(clippy::excessive_precision)]
const WG: [f64; 4] = [
    0.129_484_966_168_869_693_270_611_432_679_082,
    0.279_705_391_489_276_667_901_467_771_423_780,
    0.381_830_050_505_118_944_950_369_775_488_975,
    0.417_959_183_673_469_387_755_102_040_816_327,
];

/// `a`, the break points strictly inside `(a, b)`, and `b`, sorted and deduplicated:
/// the segments both rules integrate separately (only the splitting is shared).
fn segment_points(a: f64, b: f64, breaks: &[f64]) -> Vec<f64> {
    let mut pts: Vec<f64> = Vec::with_capacity(breaks.len() + 2);
    pts.push(a);
    pts.extend(breaks.iter().copied().filter(|&x| x > a && x < b));
    pts.push(b);
    pts.sort_by(f64::total_cmp);
    pts.dedup();
    pts
}

fn gk15<const N: usize, F: FnMut(f64) -> [f64; N]>(f: &mut F, a: f64, b: f64) -> ([f64; N], f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let fc = f(c);
    let mut k = fc.map(|v| WGK[7] * v);
    let mut g = fc.map(|v| WG[3] * v);
    for j in 0..7 {
        let x = h * XGK[j];
        let (lo, hi) = (f(c - x), f(c + x));
        for i in 0..N {
            let s = lo[i] + hi[i];
            k[i] += WGK[j] * s;
            if j % 2 == 1 {
                g[i] += WG[j / 2] * s;
            }
        }
    }
    // The error of a vector is its largest component's (max norm); a NaN stays NaN
    // so that the caller stops on it.
    let err = (0..N)
        .map(|i| ((k[i] - g[i]) * h).abs())
        .fold(0.0, |m: f64, e| if e.is_nan() || e > m { e } else { m });
    (k.map(|v| v * h), err)
}

/// Globally adaptive Gauss–Kronrod (7/15) integration of `f` over `[a, b]`.
///
/// `breaks` are interior points where `f` or its derivatives jump or where its
/// scale changes (lobe widths, cap edges); points outside `(a, b)` are ignored.
/// Stops when the summed error estimate is `<= max(abs_tol, rel_tol·|I|)` or after
/// `max_intervals` subdivisions (then `converged` is false). The error estimate is
/// the plain |K15 − G7|, conservative for smooth integrands.
pub fn gauss_kronrod<F: FnMut(f64) -> f64>(
    mut f: F,
    a: f64,
    b: f64,
    breaks: &[f64],
    abs_tol: f64,
    rel_tol: f64,
    max_intervals: usize,
) -> Quad {
    let (q, [value]) = gauss_kronrod_vec(|x| [f(x)], a, b, breaks, abs_tol, rel_tol, max_intervals);
    Quad { value, ..q }
}

/// [`gauss_kronrod`] of a vector-valued integrand: every component on one shared
/// subdivision, refined where the largest component error is (max norm), so `N`
/// integrals of related integrands cost about one. The tolerance test uses the
/// largest component; `Quad::value` is the first component.
pub fn gauss_kronrod_vec<const N: usize, F: FnMut(f64) -> [f64; N]>(
    mut f: F,
    a: f64,
    b: f64,
    breaks: &[f64],
    abs_tol: f64,
    rel_tol: f64,
    max_intervals: usize,
) -> (Quad, [f64; N]) {
    if b < a {
        let (q, v) = gauss_kronrod_vec(f, b, a, breaks, abs_tol, rel_tol, max_intervals);
        return (Quad { value: -q.value, ..q }, v.map(|x| -x));
    }
    let norm = |v: &[f64; N]| v.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
    let pts = segment_points(a, b, breaks);
    let mut heap: BinaryHeap<Interval<N>> = BinaryHeap::new();
    let mut evals = 0u32;
    let (mut total, mut err) = ([0.0; N], 0.0);
    for w in pts.windows(2) {
        let (v, e) = gk15(&mut f, w[0], w[1]);
        evals += 15;
        (0..N).for_each(|i| total[i] += v[i]);
        err += e;
        heap.push(Interval {
            err: e,
            a: w[0],
            b: w[1],
            value: v,
        });
    }
    // Re-sum from the pieces: the running sums drift by rounding.
    let finish = |heap: &BinaryHeap<Interval<N>>, evals: u32, converged: bool| {
        let mut value = [0.0; N];
        for iv in heap.iter() {
            (0..N).for_each(|i| value[i] += iv.value[i]);
        }
        let error = heap.iter().map(|i| i.err).sum();
        let q = Quad {
            value: value.first().copied().unwrap_or(0.0),
            error,
            evals,
            converged,
        };
        (q, value)
    };
    loop {
        let target = abs_tol.max(rel_tol * norm(&total));
        let done = err <= target;
        if done || !err.is_finite() || heap.len() >= max_intervals {
            return finish(&heap, evals, done);
        }
        let worst = heap.pop().expect("non-empty");
        let mid = 0.5 * (worst.a + worst.b);
        if mid <= worst.a || mid >= worst.b {
            // The interval cannot be split further in f64.
            heap.push(worst);
            return finish(&heap, evals, false);
        }
        let (v1, e1) = gk15(&mut f, worst.a, mid);
        let (v2, e2) = gk15(&mut f, mid, worst.b);
        evals += 30;
        (0..N).for_each(|i| total[i] += v1[i] + v2[i] - worst.value[i]);
        err += e1 + e2 - worst.err;
        heap.push(Interval {
            err: e1,
            a: worst.a,
            b: mid,
            value: v1,
        });
        heap.push(Interval {
            err: e2,
            a: mid,
            b: worst.b,
            value: v2,
        });
    }
}

/// A subinterval, ordered by its error estimate (the heap pops the worst first).
#[derive(Debug, Clone, Copy)]
struct Interval<const N: usize> {
    err: f64,
    a: f64,
    b: f64,
    value: [f64; N],
}

impl<const N: usize> PartialEq for Interval<N> {
    fn eq(&self, other: &Self) -> bool {
        self.err.total_cmp(&other.err).is_eq()
    }
}
impl<const N: usize> Eq for Interval<N> {}
impl<const N: usize> PartialOrd for Interval<N> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<const N: usize> Ord for Interval<N> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.err.total_cmp(&other.err)
    }
}

/// Adaptive Simpson integration (recursive, with Richardson correction) of `f`
/// over `[a, b]`, to absolute tolerance `tol`, split first at `breaks`;
/// `converged` when the summed error estimate is within `tol`.
pub fn adaptive_simpson<F: FnMut(f64) -> f64>(
    mut f: F,
    a: f64,
    b: f64,
    breaks: &[f64],
    tol: f64,
    max_depth: u32,
) -> Quad {
    if b < a {
        let q = adaptive_simpson(f, b, a, breaks, tol, max_depth);
        return Quad { value: -q.value, ..q };
    }
    let pts = segment_points(a, b, breaks);
    let mut out = Quad {
        value: 0.0,
        error: 0.0,
        evals: 0,
        converged: true,
    };
    let piece_tol = tol / (pts.len() - 1) as f64;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (fa, fm, fb) = (f(a), f(0.5 * (a + b)), f(b));
        out.evals += 3;
        let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
        simpson_rec(&mut f, a, b, fa, fm, fb, whole, piece_tol, max_depth, &mut out);
    }
    // Judged on the summed error estimate: near an endpoint singularity such as
    // (π/2 − θ)^e the per-segment test may never pass while the total is tiny.
    out.converged = out.error <= tol;
    out
}

#[allow(clippy::too_many_arguments)]
fn simpson_rec<F: FnMut(f64) -> f64>(
    f: &mut F,
    a: f64,
    b: f64,
    fa: f64,
    fm: f64,
    fb: f64,
    whole: f64,
    tol: f64,
    depth: u32,
    out: &mut Quad,
) {
    let m = 0.5 * (a + b);
    let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
    let (flm, frm) = (f(lm), f(rm));
    out.evals += 2;
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    // Halving the tolerance per level eventually asks for less than f64 rounding can
    // resolve; accept a segment once its correction is at the rounding floor.
    let tol = tol.max(8.0 * f64::EPSILON * (left + right).abs());
    if depth == 0 || delta.abs() <= 15.0 * tol {
        out.value += left + right + delta / 15.0;
        out.error += delta.abs() / 15.0;
        return;
    }
    simpson_rec(f, a, m, fa, flm, fm, left, 0.5 * tol, depth - 1, out);
    simpson_rec(f, m, b, fm, frm, fb, right, 0.5 * tol, depth - 1, out);
}

/// Root of `g` in `[lo, hi]` (which must bracket a sign change) by the Illinois
/// variant of regula falsi, to `|hi − lo| <= xtol`. Returns `None` without a bracket.
pub fn illinois<G: FnMut(f64) -> f64>(
    mut g: G,
    mut lo: f64,
    mut hi: f64,
    xtol: f64,
    max_iter: u32,
) -> Option<(f64, u32)> {
    let (mut glo, mut ghi) = (g(lo), g(hi));
    if glo == 0.0 {
        return Some((lo, 0));
    }
    if ghi == 0.0 {
        return Some((hi, 0));
    }
    if glo.signum() == ghi.signum() || !glo.is_finite() || !ghi.is_finite() {
        return None;
    }
    let mut side = 0i8;
    for it in 1..=max_iter {
        let mut x = (lo * ghi - hi * glo) / (ghi - glo);
        if !(x > lo && x < hi) {
            x = 0.5 * (lo + hi);
        }
        let gx = g(x);
        if gx == 0.0 {
            return Some((x, it));
        }
        if gx.signum() == glo.signum() {
            lo = x;
            glo = gx;
            if side == -1 {
                ghi *= 0.5;
            }
            side = -1;
        } else {
            hi = x;
            ghi = gx;
            if side == 1 {
                glo *= 0.5;
            }
            side = 1;
        }
        if (hi - lo).abs() <= xtol {
            return Some((0.5 * (lo + hi), it));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn gauss_kronrod_matches_closed_forms() {
        // Smooth, peaked and endpoint-singular integrands with known integrals.
        let q = gauss_kronrod(|x: f64| x.sin(), 0.0, PI, &[], 0.0, 1e-13, 500);
        assert!((q.value - 2.0).abs() < 1e-13, "{q:?}");
        let e = 1.0e4;
        let q = gauss_kronrod(
            |t: f64| (e * (-t).ln_1p()).exp(),
            0.0,
            1.0,
            &[1.0 / e, 10.0 / e, 100.0 / e],
            0.0,
            1e-13,
            500,
        );
        assert!((q.value / (1.0 / (e + 1.0)) - 1.0).abs() < 1e-12, "{q:?}");
        let q = gauss_kronrod(|x: f64| x.ln(), 0.0, 1.0, &[], 0.0, 1e-11, 2000);
        assert!((q.value + 1.0).abs() < 1e-10, "{q:?}");
        assert!(q.converged);
    }

    #[test]
    fn gauss_kronrod_reports_failure() {
        // 1/x on (0,1] diverges: the error estimate cannot be met.
        let q = gauss_kronrod(|x: f64| 1.0 / x, 0.0, 1.0, &[], 0.0, 1e-12, 50);
        assert!(!q.converged);
    }

    #[test]
    fn reversed_limits_change_the_sign() {
        let gk = gauss_kronrod(|x: f64| x, 1.0, 0.0, &[], 0.0, 1e-13, 100);
        let si = adaptive_simpson(|x: f64| x, 1.0, 0.0, &[0.5], 1e-13, 40);
        assert!(
            (gk.value + 0.5).abs() < 1e-15 && (si.value + 0.5).abs() < 1e-15,
            "{gk:?} {si:?}"
        );
    }

    #[test]
    fn simpson_matches_closed_forms() {
        let q = adaptive_simpson(|x: f64| x.exp(), 0.0, 1.0, &[], 1e-12, 40);
        assert!((q.value - (1f64.exp() - 1.0)).abs() < 1e-12, "{q:?}");
        assert!(q.converged);
    }

    #[test]
    fn illinois_finds_roots_and_rejects_non_brackets() {
        let (x, _) = illinois(|x: f64| x * x - 2.0, 0.0, 2.0, 1e-14, 200).unwrap();
        assert!((x - 2f64.sqrt()).abs() < 1e-13);
        assert!(illinois(|x: f64| x * x + 1.0, -1.0, 1.0, 1e-14, 200).is_none());
    }
}
