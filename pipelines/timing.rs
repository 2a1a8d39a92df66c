//! Timing at equal error: what a pipeline's image costs next to what the Monte Carlo
//! reference costs for the same error. The reference's standard error falls as 1/√n,
//! so its per-sample variance σ² (from its own standard errors) gives the samples per
//! pixel n = σ²/ε² at which its noise equals the pipeline's RMS error ε; its time per
//! sample, measured in the same process on the same pixels, gives that cost.
//!
//! One run each, side by side: a ratio, not a benchmark (those live in `benches/`).

use std::time::Instant;

/// `f`'s result and its wall time (s).
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let r = f();
    (r, t.elapsed().as_secs_f64())
}

/// A pipeline's time per pixel and the reference's at the pipeline's error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EqualError {
    /// The pipeline's time per pixel (s).
    pub pipeline_per_pixel: f64,
    /// The reference's time per sample (s).
    pub reference_per_sample: f64,
    /// Samples per pixel at which the reference's standard error equals the
    /// pipeline's RMS error.
    pub samples: f64,
    /// The reference's time per pixel at that many samples (s).
    pub reference_per_pixel: f64,
    /// reference_per_pixel / pipeline_per_pixel: above 1 the pipeline is cheaper at
    /// its own error.
    pub ratio: f64,
}

impl EqualError {
    /// [`EqualError::new`] with σ² the mean per-sample variance of the reference's
    /// estimates over the `mask`ed pixels (`pixels` of them).
    pub fn from_estimates(
        pipeline_s: f64,
        reference_s: f64,
        refs: &[crate::estimate::Estimate],
        mask: &[bool],
        spp: usize,
        rmse: f64,
    ) -> Self {
        let var: Vec<f64> = refs.iter().map(|e| e.per_sample_variance()).collect();
        let pixels = mask.iter().filter(|&&m| m).count();
        Self::new(
            pipeline_s,
            reference_s,
            pixels,
            spp,
            crate::image::mean_over(&var, mask),
            rmse,
        )
    }

    /// From the measurements: the pipeline's time over `pixels` pixels, the
    /// reference's time over the same pixels at `spp` samples each, the reference's
    /// mean per-sample variance σ² and the pipeline's RMS error ε (absolute, in the
    /// image's units).
    pub fn new(
        pipeline_s: f64,
        reference_s: f64,
        pixels: usize,
        spp: usize,
        per_sample_variance: f64,
        rmse: f64,
    ) -> Self {
        let pixels = pixels.max(1) as f64;
        let pipeline_per_pixel = pipeline_s / pixels;
        let reference_per_sample = reference_s / (pixels * spp.max(1) as f64);
        let samples = per_sample_variance / (rmse * rmse);
        let reference_per_pixel = reference_per_sample * samples;
        EqualError {
            pipeline_per_pixel,
            reference_per_sample,
            samples,
            reference_per_pixel,
            ratio: reference_per_pixel / pipeline_per_pixel,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// By hand: 100 pixels in 1 ms (10 µs each); the reference 100 × 64 samples in
    /// 64 ms (10 µs a sample), σ² = 0.04, ε = 0.05 → 16 samples, 160 µs, ratio 16.
    #[test]
    fn by_hand() {
        let e = EqualError::new(1e-3, 64e-3, 100, 64, 0.04, 0.05);
        assert!((e.pipeline_per_pixel - 1e-5).abs() < 1e-18);
        assert!((e.reference_per_sample - 1e-5).abs() < 1e-18);
        assert!((e.samples - 16.0).abs() < 1e-12);
        assert!((e.ratio - 16.0).abs() < 1e-9);
    }
}
