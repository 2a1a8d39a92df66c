//! The Monte Carlo estimator every pipeline's reference uses. It never returns a mean
//! without its standard error: a reference whose noise is not known cannot judge a
//! pipeline's error.

use lobefit_core::rng::Rng;

/// A Monte Carlo estimate of a mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Sample mean.
    pub mean: f64,
    /// Standard error of the mean: the unbiased sample standard deviation / √n
    /// (0 for fewer than two samples).
    pub std_error: f64,
    /// Number of samples.
    pub samples: usize,
}

impl Estimate {
    /// The variance of one sample (σ², from the standard error): what sets how many
    /// samples a target standard error needs.
    pub fn per_sample_variance(&self) -> f64 {
        self.std_error * self.std_error * self.samples as f64
    }

    /// The estimate, or an error naming `what` when its mean or standard error is not
    /// finite (samples too large to square, or a non-finite sample): no statistic
    /// built on it would mean anything.
    pub fn finite(self, what: impl FnOnce() -> String) -> Result<Estimate, String> {
        if self.mean.is_finite() && self.std_error.is_finite() {
            Ok(self)
        } else {
            Err(format!(
                "{}: the Monte Carlo estimate is not finite (mean {:e}, standard error {:e} over {} samples)",
                what(),
                self.mean,
                self.std_error,
                self.samples
            ))
        }
    }
}

/// Running mean and sum of squared deviations (Welford's update: no cancellation
/// when the variance is small next to the squared mean).
#[derive(Debug, Clone, Copy, Default)]
pub struct Accumulator {
    n: usize,
    mean: f64,
    m2: f64,
}

impl Accumulator {
    /// Adds one sample.
    pub fn push(&mut self, x: f64) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (x - self.mean);
    }

    /// The estimate so far.
    pub fn estimate(&self) -> Estimate {
        let var = if self.n > 1 { self.m2 / (self.n - 1) as f64 } else { 0.0 };
        Estimate {
            mean: self.mean,
            std_error: (var.max(0.0) / self.n.max(1) as f64).sqrt(),
            samples: self.n,
        }
    }
}

/// The mean of `sample` over `n` draws from an [`Rng`] seeded with `seed` (one seed
/// per pixel makes an image independent of the thread count).
pub fn estimate(n: usize, seed: u64, mut sample: impl FnMut(&mut Rng) -> f64) -> Estimate {
    let mut rng = Rng::new(seed);
    let mut acc = Accumulator::default();
    for _ in 0..n {
        acc.push(sample(&mut rng));
    }
    acc.estimate()
}

/// Where an estimator's uniform numbers come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sampling {
    /// Independent uniforms ([`Rng`]): the plain Monte Carlo estimator.
    Plain,
    /// Owen-scrambled Sobol points (Burley 2020, the `sobol_burley` crate), one scramble
    /// per seed: each sample is one point, each call of [`Uniforms::uniform`] within it
    /// the point's next dimension. Every point is uniform on the unit cube, so the
    /// estimator stays unbiased; the points are stratified, so its error falls faster
    /// than 1/√n for smooth integrands. Its [`Estimate::std_error`] is the i.i.d.
    /// formula and overstates the error: measure QMC's error over independent seeds.
    Qmc,
}

/// The uniforms of one sample: each call gives the next dimension.
pub trait Uniforms {
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64;
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
}

impl Uniforms for Rng {
    fn uniform(&mut self) -> f64 {
        Rng::uniform(self)
    }
}

/// The current Sobol point's dimensions in order.
struct SobolPoint {
    index: u32,
    dim: u32,
    seed: u32,
    /// Fills the bits below f32's 24 (so that e.g. a sharp SG's inverted CDF sees no
    /// lattice), and serves dimensions past the crate's 256.
    jitter: Rng,
}

impl Uniforms for SobolPoint {
    fn uniform(&mut self) -> f64 {
        let d = self.dim;
        self.dim += 1;
        if d >= sobol_burley::NUM_DIMENSIONS {
            return self.jitter.uniform();
        }
        let u = f64::from(sobol_burley::sample(self.index, d, self.seed)) + self.jitter.uniform() * f64::powi(2.0, -24);
        u.min(1.0 - f64::EPSILON / 2.0)
    }
}

/// Points per scramble `sobol_burley` supports; past them a new seed starts an
/// independent scramble (still unbiased).
const SOBOL_POINTS: usize = 1 << 16;

/// The mean of `sample` over `n` draws with `sampling` seeded by `seed` (one seed per
/// pixel: the image does not depend on the thread count, and pixels' QMC points are
/// decorrelated by their scrambles).
pub fn estimate_with(
    sampling: Sampling,
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut dyn Uniforms) -> f64,
) -> Estimate {
    match sampling {
        Sampling::Plain => estimate(n, seed, |r| sample(r)),
        Sampling::Qmc => {
            let mut acc = Accumulator::default();
            let mut p = SobolPoint {
                index: 0,
                dim: 0,
                seed: 0,
                jitter: Rng::new(seed ^ 0x51ab_01ee),
            };
            for k in 0..n {
                let block = (k / SOBOL_POINTS) as u64;
                p.seed = (seed ^ block.wrapping_mul(0x9e37_79b9_7f4a_7c15)) as u32 ^ (seed >> 32) as u32;
                p.index = (k % SOBOL_POINTS) as u32;
                p.dim = 0;
                acc.push(sample(&mut p));
            }
            acc.estimate()
        }
    }
}

/// Per-pixel estimates of a `w`-wide image, one row at a time in parallel: `sample(hit,
/// pixel)` for each pixel that sees geometry (an empty estimate elsewhere); `progress` is
/// called once per finished row. The pixel index lets callers seed per pixel, so the
/// result does not depend on the thread count.
pub fn per_pixel<H: Sync>(
    hits: &[Option<H>],
    w: usize,
    sample: impl Fn(&H, usize) -> Result<Estimate, String> + Sync,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<Estimate>, String> {
    use rayon::prelude::*;
    let rows: Vec<Result<Vec<Estimate>, String>> = (0..hits.len() / w)
        .into_par_iter()
        .map(|j| {
            let row = (j * w..(j + 1) * w)
                .map(|p| match &hits[p] {
                    None => Ok(estimate(0, 0, |_| 0.0)),
                    Some(hit) => sample(hit, p).and_then(|e| e.finite(|| format!("pixel ({}, {j})", p % w))),
                })
                .collect();
            progress();
            row
        })
        .collect();
    Ok(rows.into_iter().collect::<Result<Vec<_>, _>>()?.concat())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples whose squares overflow give a standard error of ∞: `per_pixel` refuses
    /// it naming the pixel, instead of handing it to statistics that print NaN.
    #[test]
    fn non_finite_estimates_are_errors() {
        let hits = vec![Some(()), Some(()), None, Some(())];
        let e = per_pixel(
            &hits,
            2,
            |_, p| Ok(estimate(64, p as u64, |r| 1e300 * r.uniform())),
            &|| (),
        )
        .unwrap_err();
        assert!(e.contains("pixel (0, 0)") && e.contains("standard error inf"), "{e}");
        let ok = per_pixel(
            &hits,
            2,
            |_, p| Ok(estimate(64, p as u64, |r| 1e100 * r.uniform())),
            &|| (),
        )
        .unwrap();
        assert_eq!(ok.len(), 4);
        assert!(estimate(4, 1, |_| f64::NAN).finite(|| "x".into()).is_err());
    }

    /// Against closed forms: U(0, 1) has mean 1/2 and variance 1/12; the reported
    /// standard error is within a few percent of √(1/12 n), and the mean within
    /// 4 standard errors.
    #[test]
    fn uniform_mean_and_standard_error() {
        let n = 100_000;
        let e = estimate(n, 3, |r| r.uniform());
        let se = (1.0 / 12.0 / n as f64).sqrt();
        assert!((e.std_error / se - 1.0).abs() < 0.02, "{e:?} vs {se}");
        assert!((e.mean - 0.5).abs() < 4.0 * se, "{e:?}");
        assert!((e.per_sample_variance() - 1.0 / 12.0).abs() < 2e-3);
        assert_eq!(e.samples, n);
    }

    /// The standard error is honest: over many independent estimates, the mean lies
    /// within one reported standard error of the truth about 68 % of the time.
    #[test]
    fn standard_error_has_its_coverage() {
        let runs = 2000;
        let inside = (0..runs)
            .filter(|&k| {
                // A Bernoulli(0.3) integrand: a visibility-like estimator.
                let e = estimate(200, 1000 + k, |r| f64::from(u8::from(r.uniform() < 0.3)));
                (e.mean - 0.3).abs() <= e.std_error
            })
            .count();
        let frac = inside as f64 / runs as f64;
        assert!((0.64..0.72).contains(&frac), "coverage {frac}");
    }

    /// A large constant offset does not spoil the variance (Welford).
    #[test]
    fn no_cancellation_on_a_large_mean() {
        let e = estimate(10_000, 5, |r| 1e9 + r.uniform());
        assert!((e.per_sample_variance() - 1.0 / 12.0).abs() < 5e-3, "{e:?}");
        let one = estimate(1, 5, |_| 2.0);
        assert_eq!((one.mean, one.std_error), (2.0, 0.0));
    }
}
