//! Equal-error measurement: a bench of pixels with a precise reference of two
//! independent runs (its noise estimated from their difference and removed from every
//! error measured against it), on which each Monte Carlo estimator's and each analytic
//! method's error and time per pixel are measured at the compared sample counts, and
//! the samples and time an estimator needs for a given error read off its measured
//! curve (never extrapolated). The baselines study ([`crate::baselines`]) and every
//! render's headline ([`at_method_error`]) are built on it.

use std::time::Instant;

use crate::estimate::{per_pixel, Estimate};
use crate::scene::{Hit, Scene};

/// An image's relative RMSE against the reference: noise-free, and as it is.
pub(crate) type Errors = (f64, f64);

/// Wall time per shaded pixel (µs) over repeated runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Median over the runs.
    pub median: f64,
    /// Fastest run.
    pub min: f64,
    /// Slowest run.
    pub max: f64,
}

impl Timing {
    /// The median, fastest and slowest of `runs` (not empty; NaN-free).
    pub fn of(runs: &[f64]) -> Timing {
        let mut s = runs.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        Timing {
            median,
            min: s[0],
            max: s[n - 1],
        }
    }
}

/// One estimator's measured error and time at `spp` samples per pixel.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    /// Samples per pixel.
    pub spp: usize,
    /// Relative RMSE over the lit pixels against the precise reference, its noise
    /// removed: √((E[(x − r)²] − E[noise_r²]) / E[r²]) (note: over the reference's RMS,
    /// not its mean as in the renders).
    pub rel_rmse: f64,
    /// The same against the reference as it is, its noise included.
    pub rel_rmse_raw: f64,
    /// Mean ꟻLIP (LDR, 67 pixels per degree) of the tone-mapped image against the
    /// tone-mapped reference ([`Bench::flip`]); `None` without the `flip` feature.
    pub flip: Option<f64>,
    /// Time per pixel.
    pub us: Timing,
}

/// A scene's pixels and its precise reference: what every estimator and the analytic
/// method are measured against, and how they are timed.
pub struct Bench {
    w: usize,
    hits: Vec<Option<Hit>>,
    refs: Vec<f64>,
    idx: Vec<usize>,
    mean_sq: f64,
    ref_var: f64,
    runs: usize,
}

/// An analytic method's image of given primary hits (0 where none).
pub type MethodImage<'a> = dyn Fn(&[Option<Hit>]) -> Result<Vec<f64>, String> + Sync + 'a;

/// Per-pixel shading: `(hit, samples, seed)` → estimate.
pub type Estimator<'a> = &'a (dyn Fn(&Hit, usize, u64) -> Result<Estimate, String> + Sync);

impl Bench {
    /// `scene` at `width` × ¾ width pixels; its reference the mean of two independent
    /// runs of `reference` at `ref_spp` samples per pixel (seeded apart from the
    /// compared runs), whose noise is estimated from their difference (E[(a − b)²]/4
    /// is the variance of their mean for any unbiased estimator, QMC's included);
    /// every time the median of `runs` runs after one warm-up run, on rayon's pool.
    pub fn new(
        scene: &Scene,
        width: usize,
        ref_spp: usize,
        runs: usize,
        reference: Estimator,
    ) -> Result<Bench, String> {
        let (w, h) = (width, width * 3 / 4);
        // The lit pixels are those with a hit.
        let (hits, _) = scene.primary_hits(w, h)?;
        Bench::on_hits(hits, w, ref_spp, runs, reference)
    }

    /// A bench on given primary hits (`hits`, row-major at width `w`; the pixels
    /// where a hit is given are shaded): a render's own pixels, or a subset of them.
    /// Its reference as in [`Bench::new`].
    pub fn on_hits(
        hits: Vec<Option<Hit>>,
        w: usize,
        ref_spp: usize,
        runs: usize,
        reference: Estimator,
    ) -> Result<Bench, String> {
        let [a, b] = REF_SEEDS.map(|s| per_pixel(&hits, w, |hit, p| reference(hit, ref_spp, seed(s, p)), &|| ()));
        let (a, b) = (a?, b?);
        let refs: Vec<f64> = a.iter().zip(&b).map(|(a, b)| 0.5 * (a.mean + b.mean)).collect();
        let idx: Vec<usize> = (0..hits.len()).filter(|&p| hits[p].is_some()).collect();
        if idx.is_empty() {
            return Err("no pixel to measure".into());
        }
        let mean_sq = idx.iter().map(|&p| refs[p].powi(2)).sum::<f64>() / idx.len() as f64;
        let ref_var = idx.iter().map(|&p| 0.25 * (a[p].mean - b[p].mean).powi(2)).sum::<f64>() / idx.len() as f64;
        Ok(Bench {
            w,
            hits,
            refs,
            idx,
            mean_sq,
            ref_var,
            runs: runs.max(1),
        })
    }

    /// The analytic method's image `render(hits)` (0 where no hit): its errors and its
    /// time per shaded pixel, timed as the estimators are.
    pub fn analytic_image(&self, render: &MethodImage) -> Result<(Errors, Timing), String> {
        let (img, us) = self.timed_image(&|| {
            Ok(render(&self.hits)?
                .into_iter()
                .map(|mean| Estimate {
                    mean,
                    std_error: 0.0,
                    samples: 1,
                })
                .collect())
        })?;
        Ok((self.error(&img), us))
    }

    /// The reference's own relative RMS error (estimated), on the scale of the
    /// errors measured against it.
    pub fn reference_error(&self) -> f64 {
        (self.ref_var / self.mean_sq).sqrt()
    }

    /// The bench's primary hits (row-major; `None` where nothing is shaded).
    pub fn hits(&self) -> &[Option<Hit>] {
        &self.hits
    }

    /// Pixels shaded (those that see geometry).
    pub fn pixels(&self) -> usize {
        self.idx.len()
    }

    /// The relative RMSE of `img` against the reference: noise-free (the reference's
    /// own variance removed) and as it is.
    fn error(&self, img: &[Estimate]) -> Errors {
        let mse = self
            .idx
            .iter()
            .map(|&p| (img[p].mean - self.refs[p]).powi(2))
            .sum::<f64>()
            / self.idx.len() as f64;
        (
            ((mse - self.ref_var).max(0.0) / self.mean_sq).sqrt(),
            (mse / self.mean_sq).sqrt(),
        )
    }

    /// The mean ꟻLIP error (NVIDIA's LDR-ꟻLIP through the `nv-flip` crate, at its
    /// default 67 pixels per degree) between `img` and the reference, both tone-mapped
    /// as the renders' beauty images are (one exposure from the reference's mean, ACES,
    /// sRGB, 8-bit grey); `None` unless built with the `flip` feature (the crate
    /// compiles NVIDIA's C++, which the default build does not assume).
    pub fn flip(&self, img: &[Estimate]) -> Option<f64> {
        #[cfg(feature = "flip")]
        {
            let mean = self.idx.iter().map(|&p| self.refs[p]).sum::<f64>() / self.idx.len() as f64;
            let exposure = crate::image::exposure_for(mean);
            let rgb = |v: &mut dyn Iterator<Item = f64>| -> Vec<u8> {
                v.flat_map(|x| [crate::image::tone_map_8bit(x, exposure); 3]).collect()
            };
            let (w, h) = (self.w as u32, (self.hits.len() / self.w) as u32);
            let reference = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(&mut self.refs.iter().copied()));
            let test = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(&mut img.iter().map(|e| e.mean)));
            let map = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
            Some(f64::from(nv_flip::FlipPool::from_image(&map).mean()))
        }
        #[cfg(not(feature = "flip"))]
        {
            let _ = img;
            None
        }
    }

    /// The image `shade(hit, pixel)` gives (one warm-up run) and its time per pixel.
    fn timed(
        &self,
        shade: &(dyn Fn(&Hit, usize) -> Result<Estimate, String> + Sync),
    ) -> Result<(Vec<Estimate>, Timing), String> {
        self.timed_image(&|| per_pixel(&self.hits, self.w, shade, &|| ()))
    }

    /// The image `render` gives (one warm-up run) and its time per shaded pixel.
    fn timed_image(
        &self,
        render: &(dyn Fn() -> Result<Vec<Estimate>, String> + Sync),
    ) -> Result<(Vec<Estimate>, Timing), String> {
        let img = render()?;
        let us = (0..self.runs)
            .map(|_| {
                let t = Instant::now();
                render()?;
                Ok(1e6 * t.elapsed().as_secs_f64() / self.pixels() as f64)
            })
            .collect::<Result<Vec<f64>, String>>()?;
        Ok((img, Timing::of(&us)))
    }

    /// `estimator`'s error and time at each of `spps`.
    pub fn curve(&self, spps: &[usize], estimator: Estimator) -> Result<Vec<Point>, String> {
        spps.iter()
            .map(|&n| {
                let (img, us) = self.timed(&|hit, p| estimator(hit, n, seed(0x5eed_0000 + n as u64, p)))?;
                let (rel_rmse, rel_rmse_raw) = self.error(&img);
                Ok(Point {
                    spp: n,
                    rel_rmse,
                    rel_rmse_raw,
                    flip: self.flip(&img),
                    us,
                })
            })
            .collect()
    }

    /// `estimator` with a mean of `n` samples per pixel for each `n` of `spps`, spread
    /// over the pixels by a pilot (adaptive sampling, as production renderers do; see
    /// [`adaptive_image`]), both passes timed.
    pub fn adaptive_curve(&self, spps: &[usize], estimator: Estimator) -> Result<Vec<Point>, String> {
        spps.iter()
            .map(|&n| {
                let (img, us) =
                    self.timed_image(&|| adaptive_image(&self.hits, self.w, n, 0x5eed_0000 + n as u64, estimator))?;
                let (rel_rmse, rel_rmse_raw) = self.error(&img);
                Ok(Point {
                    spp: n,
                    rel_rmse,
                    rel_rmse_raw,
                    flip: self.flip(&img),
                    us,
                })
            })
            .collect()
    }

    /// The analytic method `shade(hit)`'s error, ꟻLIP and time per pixel, timed the
    /// same way.
    pub fn analytic(
        &self,
        shade: &(dyn Fn(&Hit) -> Result<f64, String> + Sync),
    ) -> Result<(Errors, Option<f64>, Timing), String> {
        let (img, us) = self.timed(&|hit, _| {
            Ok(Estimate {
                mean: shade(hit)?,
                std_error: 0.0,
                samples: 1,
            })
        })?;
        Ok((self.error(&img), self.flip(&img), us))
    }
}

/// An image of `estimator` at a mean of `n` samples per pixel that sees geometry,
/// spread by a pilot: every such pixel first takes a quarter of the budget (at least 4
/// samples, and all of it below 16), the rest goes to the pixels in proportion to the
/// pilot's sample standard deviation σ_p (the split of a fixed total that minimises
/// Σ σ_p²/n_p, the summed variance of independent samples; uniform where every σ_p is
/// 0), and each pixel's estimate is its two runs' sample-weighted mean. A pixel's share
/// depends on its own pilot, which biases it slightly: the bias is part of the error
/// the study measures against the reference.
pub fn adaptive_image(
    hits: &[Option<Hit>],
    w: usize,
    n: usize,
    base: u64,
    estimator: Estimator,
) -> Result<Vec<Estimate>, String> {
    let pilot_n = if n < 16 { n } else { (n / 4).max(4) };
    let pilot = per_pixel(hits, w, |hit, p| estimator(hit, pilot_n, seed(base, p)), &|| ())?;
    let shaded: Vec<usize> = (0..hits.len()).filter(|&p| hits[p].is_some()).collect();
    let rest = ((n - pilot_n) * shaded.len()) as f64;
    if rest == 0.0 {
        return Ok(pilot);
    }
    let sigma = |p: usize| pilot[p].std_error * (pilot[p].samples as f64).sqrt();
    let total: f64 = shaded.iter().map(|&p| sigma(p)).sum();
    let share = |p: usize| {
        let f = if total > 0.0 {
            sigma(p) / total
        } else {
            1.0 / shaded.len() as f64
        };
        (rest * f).round() as usize
    };
    per_pixel(
        hits,
        w,
        |hit, p| {
            let n1 = share(p);
            if n1 == 0 {
                return Ok(pilot[p]);
            }
            let (a, b) = (pilot[p], estimator(hit, n1, seed(base ^ 0xada9_7000, p))?);
            let (na, nb) = (a.samples as f64, b.samples as f64);
            let samples = a.samples + b.samples;
            Ok(Estimate {
                mean: (na * a.mean + nb * b.mean) / (na + nb),
                // Each run's variance of the mean, weighted as the means are.
                std_error: ((na * a.std_error).powi(2) + (nb * b.std_error).powi(2)).sqrt() / (na + nb),
                samples,
            })
        },
        &|| (),
    )
}

/// The reference's two runs' seeds.
pub(crate) const REF_SEEDS: [u64; 2] = [0x00c0_ffee, 0x0dec_af00];

/// Pixel `p`'s seed of a run seeded `base`.
pub(crate) fn seed(base: u64, p: usize) -> u64 {
    base ^ (p as u64).wrapping_mul(0x9e37_79b9)
}

/// `value` of `curve` (decreasing error) at `error`, by log–log interpolation between
/// its two measured points around it; `None` outside the measured range.
fn at(curve: &[Point], error: f64, value: impl Fn(&Point) -> f64) -> Option<f64> {
    curve.windows(2).find_map(|p| {
        let (a, b) = (&p[0], &p[1]);
        if !(b.rel_rmse <= error && error <= a.rel_rmse) || a.rel_rmse <= 0.0 || b.rel_rmse <= 0.0 {
            return None;
        }
        let t = if a.rel_rmse == b.rel_rmse {
            0.0
        } else {
            (error.ln() - a.rel_rmse.ln()) / (b.rel_rmse.ln() - a.rel_rmse.ln())
        };
        Some((value(a).ln() + t * (value(b).ln() - value(a).ln())).exp())
    })
}

/// The samples `curve` needs for `error` (log–log interpolation; `None` outside the
/// measured range).
pub fn spp_at(curve: &[Point], error: f64) -> Option<f64> {
    at(curve, error, |p| p.spp as f64)
}

/// The time per pixel `curve` needs for `error`: median, fastest and slowest each
/// interpolated like [`spp_at`].
pub fn time_at(curve: &[Point], error: f64) -> Option<Timing> {
    Some(Timing {
        median: at(curve, error, |p| p.us.median)?,
        min: at(curve, error, |p| p.us.min)?,
        max: at(curve, error, |p| p.us.max)?,
    })
}

/// The strongest Monte Carlo estimator of a render, measured at the method's error
/// ([`at_method_error`]): what a render's headline states.
#[derive(Debug, Clone)]
pub struct AtMethodError {
    /// The estimator's name (`qmc-cv-mis`, `qmc`).
    pub estimator: String,
    /// Pixels measured.
    pub pixels: usize,
    /// The method's relative RMSE on them, the reference's noise removed.
    pub method_error: f64,
    /// The method's time per pixel there.
    pub method_us: Timing,
    /// Samples per pixel and time per pixel the estimator needs for the method's
    /// error (log–log between its two measured neighbours); `None` when its curve did
    /// not reach the error within [`HEADLINE_MAX_SPP`] (then `last` bounds it).
    pub at: Option<(f64, Timing)>,
    /// The last point measured: (spp, error, time).
    pub last: (usize, f64, Timing),
    /// The first point measured (1 spp) already had the method's error or less: `last`
    /// is that point, and bounds the estimator's need from above.
    pub first_meets: bool,
    /// The reference's own relative error on these pixels.
    pub reference_error: f64,
}

impl AtMethodError {
    /// (ratio of the estimator's median time to the method's, [slowest-case spread:
    /// its fastest run over the method's slowest, its slowest over the method's
    /// fastest]); `None` without a measured crossing.
    pub fn ratio(&self) -> Option<(f64, f64, f64)> {
        let (_, t) = self.at?;
        let m = self.method_us;
        Some((t.median / m.median, t.min / m.max, t.max / m.min))
    }
}

/// Pixels [`at_method_error`] measures at most: an even sample of the lit pixels.
pub const HEADLINE_PIXELS: usize = 48;
/// Samples per pixel of each of the two runs of the measurement's reference.
pub const HEADLINE_REF_SPP: usize = 4096;
/// Most samples per pixel the estimator's curve runs to (×4 from 1).
pub const HEADLINE_MAX_SPP: usize = 4096;
/// Timed runs of each measured point (after a warm-up), their median taken.
pub const HEADLINE_RUNS: usize = 3;

/// Most Monte Carlo samples [`at_method_error`] takes: its reference's two runs and
/// the curve's points (1, 4, …, [`HEADLINE_MAX_SPP`]), each run [`HEADLINE_RUNS`] + 1
/// times, on [`HEADLINE_PIXELS`] pixels. Counted in a render's sample limit.
pub const HEADLINE_SAMPLES: u64 =
    HEADLINE_PIXELS as u64 * (2 * HEADLINE_REF_SPP as u64 + (HEADLINE_RUNS as u64 + 1) * 5461);

/// A render's headline measurement: on at most [`HEADLINE_PIXELS`] of its lit pixels
/// (`hits`, row-major at width `w`, taken evenly), the method (`method`, shading a hit
/// array) against a reference of two [`HEADLINE_REF_SPP`]-sample runs of `estimator`,
/// and `estimator` at 1, 4, 16, … samples per pixel until its error passes the
/// method's, each point timed as the median of [`HEADLINE_RUNS`] runs in this process
/// (the study's method, at a small size: docs/pipelines.md, "Stronger baselines").
pub fn at_method_error(
    hits: &[Option<Hit>],
    w: usize,
    name: &str,
    estimator: Estimator,
    method: &MethodImage,
) -> Result<AtMethodError, String> {
    let lit: Vec<usize> = (0..hits.len()).filter(|&p| hits[p].is_some()).collect();
    let step = lit.len().div_ceil(HEADLINE_PIXELS).max(1);
    let mut sub = vec![None; hits.len()];
    for &p in lit.iter().step_by(step) {
        sub[p] = hits[p];
    }
    let b = Bench::on_hits(sub, w, HEADLINE_REF_SPP, HEADLINE_RUNS, estimator)?;
    let ((method_error, _), method_us) = b.analytic_image(method)?;
    let mut curve: Vec<Point> = Vec::new();
    let mut n = 1;
    while n <= HEADLINE_MAX_SPP {
        curve.extend(b.curve(&[n], estimator)?);
        if curve.last().is_some_and(|p| p.rel_rmse <= method_error) {
            break;
        }
        n *= 4;
    }
    let last = curve.last().ok_or("no point measured")?;
    let at = match (spp_at(&curve, method_error), time_at(&curve, method_error)) {
        (Some(n), Some(t)) => Some((n, t)),
        _ => None,
    };
    Ok(AtMethodError {
        estimator: name.to_string(),
        pixels: b.pixels(),
        method_error,
        method_us,
        at,
        last: (last.spp, last.rel_rmse, last.us),
        first_meets: curve.len() == 1 && last.rel_rmse <= method_error,
        reference_error: b.reference_error(),
    })
}
