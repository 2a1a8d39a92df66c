//! `lobefit render PIPELINE --scene S --frames N`: an animated scene (keyframed
//! spheres and meshes, [`crate::scene::Track`]) rendered frame by frame with the
//! pipeline's method, a reference, and the strongest Monte Carlo estimator given the
//! method's time (equal time, measured); per frame the error, the cost and the
//! **temporal error** of each (docs/meshes.md, Motion). The reference is that same
//! strongest estimator at `--spp` samples per pixel with its own seeds: the most
//! precise reference for its time, independent of the equal-time run.
//!
//! The temporal error of frame k ≥ 1 is the RMS over the pixels lit in frames k − 1
//! and k of (x_k − x_{k−1}) − (r_k − r_{k−1}), x the method's image and r the
//! reference's, relative to the references' mean radiance: how far the image's change
//! from one frame to the next is from the true change, which is what a viewer sees as
//! flicker. The reference draws the same samples at a pixel in every frame (one seed
//! per pixel), so where nothing changes its own noise cancels in r_k − r_{k−1}; the
//! equal-time Monte Carlo draws new samples every frame (one seed per pixel and frame),
//! as a real-time renderer without temporal accumulation does, so its noise flickers.

use std::path::{Path, PathBuf};

use crate::estimate::{per_pixel, Estimate};
use crate::image::{beauty, compare, encode_apng, encode_png, exposure_for, mean_over, Beauty};
use crate::scene::{Hit, Scene};
use crate::timing::timed;
use crate::{Headline, Pipeline, RenderOptions, Summary, MAX_RENDER_SAMPLES};

/// Most frames an animation may have.
pub const MAX_FRAMES: usize = 240;

/// Samples per pixel of the pilot that measures the strongest estimator's cost per
/// sample (on frame 0, its own seeds).
pub const PILOT_SPP: usize = 16;

/// Seed of the references' per-pixel samples (the same in every frame).
pub const REFERENCE_SEED: u64 = 0x5eed_a410;

/// Seed of the equal-time Monte Carlo's samples, hashed with the frame and the pixel
/// ([`seed_of`]).
pub const EQUAL_TIME_SEED: u64 = 0x5eed_a411;

/// A seed for (`base`, `a`, `b`) by the SplitMix64 finaliser: seeds of different
/// frames, pixels and runs share no samples (a plain XOR made frame 0's equal-time
/// seed at pixel p the reference's at pixel p ^ 1).
pub fn seed_of(base: u64, a: u64, b: u64) -> u64 {
    let mut z = base ^ a.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ b.wrapping_mul(0xd1b5_4a32_d192_ed03);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Playback rate of the animated PNG (frames per second).
pub const FPS: u16 = 12;

/// Renders the animated scene `name` with `frames` frames (a pipeline's
/// [`Pipeline::animate`]); `progress` is called once per finished reference row.
pub type AnimateFn = fn(&str, &RenderOptions, usize, &Path, &(dyn Fn() + Sync)) -> Result<Summary, String>;

/// A method's image of a still at its primary hits (0 on the background).
pub type ShadeFn<'a> = dyn Fn(&Scene, &[Option<Hit>]) -> Result<Vec<f64>, String> + Sync + 'a;

/// A Monte Carlo estimate of the radiance at a hit of a still: `n` samples, seeded.
pub type EstimateFn<'a> = dyn Fn(&Scene, &Hit, usize, u64) -> Result<Estimate, String> + Sync + 'a;

/// What a pipeline gives its animation.
pub struct Methods<'a> {
    /// The method's name (`ISG (best model)`).
    pub method: &'a str,
    /// The method's image of a still at its primary hits (0 on the background).
    pub shade: &'a ShadeFn<'a>,
    /// The strongest estimator's name (`qmc-cv-mis`): the one the baselines study found
    /// best on the pipeline's scenes.
    pub strongest: &'a str,
    /// Its estimate of the radiance at a hit of a still: `n` samples, seeded.
    pub estimate: &'a EstimateFn<'a>,
}

/// One rendered frame.
struct Rendered {
    time: f64,
    lit: Vec<bool>,
    method: Vec<f64>,
    method_s: f64,
    reference: Vec<f64>,
    reference_se: f64,
    mc: Vec<f64>,
    mc_s: f64,
    pixels: usize,
}

/// The frame's time in [0, 1]: k / (frames − 1).
fn time_of(k: usize, frames: usize) -> f64 {
    k as f64 / (frames - 1) as f64
}

/// The temporal error of `x` against the reference `r` from frame `a` to frame `b`
/// (module docs), relative to `mean`; NaN when no pixel is lit in both frames (left
/// out of the means).
pub fn temporal_error(x: [&[f64]; 2], r: [&[f64]; 2], lit: [&[bool]; 2], mean: f64) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for p in 0..x[0].len() {
        if lit[0][p] && lit[1][p] {
            let d = (x[1][p] - x[0][p]) - (r[1][p] - r[0][p]);
            sum += d * d;
            n += 1;
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        (sum / n as f64).sqrt() / mean
    }
}

/// Refuses an animation whose frame count or Monte Carlo work is out of bounds.
fn check(pipeline: &Pipeline, scene: &Scene, opts: &RenderOptions, frames: usize) -> Result<(), String> {
    if !(2..=MAX_FRAMES).contains(&frames) {
        return Err(format!(
            "render {} --frames {frames}: an animation has 2 to {MAX_FRAMES} frames (MAX_FRAMES)",
            pipeline.name
        ));
    }
    if scene.tracks.is_empty() && scene.meshes.iter().all(|m| m.pose.is_none()) {
        return Err(format!(
            "render {} --frames: scene {} does not move (no `keys` and no `bend`: docs/meshes.md, Motion)",
            pipeline.name, scene.name
        ));
    }
    pipeline.check_frames(scene, opts, frames)?;
    // Per frame: the reference (spp) and the equal-time estimator (≤ spp); once: the
    // pilots (3 runs each at PILOT_SPP / 2, 2 PILOT_SPP and the first guess ≤ spp).
    let (w, h) = (opts.width.max(4) as u64, (opts.width * 3 / 4).max(3) as u64);
    let spp = opts.spp as u64;
    let pilots = 3 * (PILOT_SPP as u64 / 2 + 2 * PILOT_SPP as u64 + spp) * w * h;
    let samples = (frames as u64).saturating_mul(2 * w * h * spp).saturating_add(pilots);
    if samples > MAX_RENDER_SAMPLES {
        return Err(format!(
            "render {} --frames {frames} --width {} --spp {}: up to {samples} Monte Carlo samples, more than the \
             {MAX_RENDER_SAMPLES} a render may take (MAX_RENDER_SAMPLES); lower --frames, --width or --spp",
            pipeline.name, opts.width, opts.spp
        ));
    }
    Ok(())
}

/// Renders every frame of `scene` (its tracks at times 0, 1/(N−1), …, 1) into `dir`:
/// `<stem>-frame-KKK.png` (method | reference | equal-time Monte Carlo, one exposure
/// for the whole animation), `<stem>-animation.png` (the same frames as an animated
/// PNG at [`FPS`]), `<stem>-frames.csv` and the summary.
pub fn animate(
    pipeline: &Pipeline,
    scene: &Scene,
    opts: &RenderOptions,
    frames: usize,
    dir: &Path,
    progress: &(dyn Fn() + Sync),
    m: &Methods<'_>,
) -> Result<Summary, String> {
    check(pipeline, scene, opts, frames)?;
    let tag = scene
        .name
        .strip_prefix(&format!("{}-", pipeline.name))
        .unwrap_or(&scene.name)
        .to_string();
    let stem = format!("{}-{tag}", pipeline.name);
    let (w, h) = (opts.width.max(4), (opts.width * 3 / 4).max(3));
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut shots = Vec::with_capacity(frames);
    let mut all_hits = Vec::with_capacity(frames);
    for k in 0..frames {
        let still = scene.at(time_of(k, frames))?;
        let (hits, lit) = still.primary_hits(w, h)?;
        let (method, method_s) = timed(|| (m.shade)(&still, &hits));
        let (refs, _) = timed(|| {
            per_pixel(
                &hits,
                w,
                |hit, p| (m.estimate)(&still, hit, opts.spp, seed_of(REFERENCE_SEED, 0, p as u64)),
                progress,
            )
        });
        let refs = refs?;
        let reference: Vec<f64> = refs.iter().map(|e| e.mean).collect();
        let se: Vec<f64> = refs.iter().map(|e| e.std_error).collect();
        let pixels = lit.iter().filter(|&&l| l).count();
        shots.push(Rendered {
            time: time_of(k, frames),
            reference_se: mean_over(&se, &lit) / mean_over(&reference, &lit),
            lit,
            method: method?,
            method_s,
            reference,
            mc: Vec::new(),
            mc_s: 0.0,
            pixels,
        });
        all_hits.push(hits);
    }
    let spp = equal_time_spp(scene, &all_hits[0], &shots, w, opts.spp, m)?;
    for (k, (shot, hits)) in shots.iter_mut().zip(&all_hits).enumerate() {
        let still = scene.at(shot.time)?;
        let (mc, mc_s) = timed(|| {
            per_pixel(
                hits,
                w,
                |hit, p| (m.estimate)(&still, hit, spp, seed_of(EQUAL_TIME_SEED, k as u64 + 1, p as u64)),
                &|| (),
            )
        });
        // Unclamped, as the reference: the beauty images show negatives as black.
        shot.mc = mc?.iter().map(|e| e.mean).collect();
        shot.mc_s = mc_s;
    }
    // The headline's comparison at the method's error, on frame 0 (as a still's).
    let still = scene.at(shots[0].time)?;
    let estimate = |h: &Hit, n: usize, seed: u64| (m.estimate)(&still, h, n, seed);
    let shade = |hits: &[Option<Hit>]| (m.shade)(&still, hits);
    let at = crate::measure::at_method_error(&all_hits[0], w, m.strongest, &estimate, &shade)?;
    report(pipeline, &tag, &stem, (w, h), spp, &shots, dir, m, &at)
}

/// The equal-time estimator's samples per pixel: its time per lit pixel is modelled as
/// a + b n (a fixed cost per pixel, b per sample), a and b measured by two pilots on
/// frame 0 (at [`PILOT_SPP`] / 2 and 2 × [`PILOT_SPP`], their own seeds); n solves
/// a + b n = the method's mean time per lit pixel over the frames; then one run at
/// that n corrects it by (method − its time) / b (within a factor 2), which absorbs
/// what the pilots' short runs mismeasure. Each pilot time is the median of 3 runs.
/// Rounded, in 1..=`max`.
fn equal_time_spp(
    scene: &Scene,
    hits: &[Option<Hit>],
    shots: &[Rendered],
    w: usize,
    max: usize,
    m: &Methods<'_>,
) -> Result<usize, String> {
    let still = scene.at(0.0)?;
    let pixels = shots[0].pixels.max(1) as f64;
    // Each pilot's time: the median of 3 runs (short runs on a busy machine jitter).
    let pilot = |n: usize| -> Result<f64, String> {
        let mut t = [0.0; 3];
        for t in &mut t {
            let (r, s) = timed(|| {
                per_pixel(
                    hits,
                    w,
                    |hit, p| (m.estimate)(&still, hit, n, seed_of(EQUAL_TIME_SEED, 0, p as u64)),
                    &|| (),
                )
            });
            r?;
            *t = s / pixels;
        }
        t.sort_by(f64::total_cmp);
        Ok(t[1])
    };
    let (lo, hi) = (PILOT_SPP / 2, 2 * PILOT_SPP);
    let (t_lo, t_hi) = (pilot(lo)?, pilot(hi)?);
    // Timer noise can make the longer pilot no slower: then no fixed cost, b from the
    // longer pilot alone.
    let (a, b) = if t_hi > t_lo {
        let b = (t_hi - t_lo) / (hi - lo) as f64;
        ((t_lo - b * lo as f64).max(0.0), b)
    } else {
        (0.0, (t_hi / hi as f64).max(1e-12))
    };
    let method_per_pixel =
        shots.iter().map(|s| s.method_s).sum::<f64>() / shots.iter().map(|s| s.pixels).sum::<usize>().max(1) as f64;
    let clamp = |n: f64| (n.round().max(1.0) as usize).min(max);
    let n = clamp((method_per_pixel - a) / b);
    let t_n = pilot(n)?;
    let corrected = (n as f64 + (method_per_pixel - t_n) / b).clamp(n as f64 / 2.0, 2.0 * n as f64);
    Ok(clamp(corrected))
}

/// Per-frame statistics, files and the summary.
#[allow(clippy::too_many_arguments)]
fn report(
    pipeline: &Pipeline,
    tag: &str,
    stem: &str,
    (w, h): (usize, usize),
    spp: usize,
    shots: &[Rendered],
    dir: &Path,
    m: &Methods<'_>,
    at: &crate::measure::AtMethodError,
) -> Result<Summary, String> {
    let mut sum = Summary::default();
    let exposure = exposure_for(mean_over(&shots[0].reference, &shots[0].lit));
    let mut csv = String::from(
        "frame,time,method_rel_rmse,mc_rel_rmse,method_temporal,mc_temporal,method_us_per_px,mc_us_per_px,reference_rel_se\n",
    );
    let mut images: Vec<Beauty> = Vec::with_capacity(shots.len());
    let (mut e_m, mut e_mc, mut us_m, mut us_mc) = (0.0, 0.0, 0.0, 0.0);
    // Temporal errors of the frame pairs with lit pixels in both (finite ones).
    let (mut temporal_m, mut temporal_mc) = (Vec::new(), Vec::new());
    for (k, s) in shots.iter().enumerate() {
        let mean = mean_over(&s.reference, &s.lit);
        let em = compare(&s.method, &s.reference, &s.lit).rel_rmse;
        let emc = compare(&s.mc, &s.reference, &s.lit).rel_rmse;
        let (tm, tmc) = match k.checked_sub(1).map(|j| &shots[j]) {
            None => (f64::NAN, f64::NAN),
            Some(p) => {
                let both = 0.5 * (mean + mean_over(&p.reference, &p.lit));
                let r = [&p.reference[..], &s.reference[..]];
                let lit = [&p.lit[..], &s.lit[..]];
                (
                    temporal_error([&p.method, &s.method], r, lit, both),
                    temporal_error([&p.mc, &s.mc], r, lit, both),
                )
            }
        };
        let px = s.pixels.max(1) as f64;
        let (um, umc) = (1e6 * s.method_s / px, 1e6 * s.mc_s / px);
        sum.lines.push(format!(
            "{tag}: frame {k} (t = {:.3}, {} lit pixels): {} relative RMSE {em:.4}, temporal {tm:.4}, {um:.2} µs/px; \
             {} at {spp} spp relative RMSE {emc:.4}, temporal {tmc:.4}, {umc:.2} µs/px; reference standard error {:.2e} (the i.i.d. formula: QMC's is smaller)",
            s.time, s.pixels, m.method, m.strongest, s.reference_se
        ));
        csv.push_str(&format!(
            "{k},{},{em},{emc},{tm},{tmc},{um},{umc},{}\n",
            s.time, s.reference_se
        ));
        let b = beauty(w, h, &[&s.method, &s.reference, &s.mc], &s.lit, exposure)?;
        let path = dir.join(format!("{stem}-frame-{k:03}.png"));
        sum.files.push(write_bytes(&path, &encode_png(&b)?)?);
        images.push(b);
        let n = shots.len() as f64;
        e_m += em / n;
        e_mc += emc / n;
        us_m += um / n;
        us_mc += umc / n;
        if tm.is_finite() && tmc.is_finite() {
            temporal_m.push(tm);
            temporal_mc.push(tmc);
        }
    }
    let mean_of = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (t_m, t_mc) = (mean_of(&temporal_m), mean_of(&temporal_mc));
    // The equal-time run's time is measured, not set: say so when it missed by 2×.
    let time_ratio = us_mc / us_m;
    if !(0.5..=2.0).contains(&time_ratio) {
        sum.lines.push(format!(
            "{tag}: warning: the equal-time Monte Carlo took {time_ratio:.2}× the method's time (its samples \
             came from pilots on a busy or noisy machine); compare the errors with that in mind"
        ));
    }
    sum.files.push(write_bytes(
        &dir.join(format!("{stem}-animation.png")),
        &encode_apng(&images, FPS)?,
    )?);
    sum.files
        .push(write_bytes(&dir.join(format!("{stem}-frames.csv")), csv.as_bytes())?);
    sum.lines.push(format!(
        "{tag}: {} frames of {w}×{h}, means over the frames: {} relative RMSE {e_m:.4}, temporal {t_m:.4}, {us_m:.2} \
         µs/px; {} at {spp} spp (the method's time, by pilots) relative RMSE {e_mc:.4}, temporal \
         {t_mc:.4}, {us_mc:.2} µs/px; temporal error ratio {} / method {:.1}",
        shots.len(),
        m.method,
        m.strongest,
        m.strongest,
        t_mc / t_m
    ));
    sum.rel_rmse = e_m;
    sum.lines.push(crate::render::at_error_line(tag, at));
    sum.headline.push(
        Headline {
            render: format!("{} {tag}", pipeline.name),
            scope: format!("{} frames × {w}×{h}", shots.len()),
            method: m.method.into(),
            error: format!(
                "relative RMSE {e_m:.4}, temporal {t_m:.4} (at equal time {}: {e_mc:.4}, temporal {t_mc:.4})",
                m.strongest
            ),
            ..crate::render::at_error_headline(at, "of frame 0")
        }
        .line(),
    );
    sum.write(dir, stem)?;
    Ok(sum)
}

/// Writes `bytes` to `path` atomically.
fn write_bytes(path: &Path, bytes: &[u8]) -> Result<PathBuf, String> {
    lobefit_core::io::write_atomic(path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The temporal error is 0 when the image changes as the reference does (whatever
    /// its own constant error), and the RMS of the difference otherwise, over the
    /// pixels lit in both frames only (NaN when there are none).
    #[test]
    fn temporal_error_measures_the_change_against_the_reference() {
        let r0 = [1.0, 2.0, 3.0, 4.0];
        let r1 = [1.5, 2.0, 2.0, 9.0];
        let offset: Vec<f64> = r0.iter().map(|x| x + 0.3).collect();
        let offset1: Vec<f64> = r1.iter().map(|x| x + 0.3).collect();
        let lit = [true, true, true, false];
        assert_eq!(temporal_error([&offset, &offset1], [&r0, &r1], [&lit, &lit], 1.0), 0.0);
        // A still image where the reference changes by 0.5, 0, −1 on the lit pixels.
        let e = temporal_error([&r0, &r0], [&r0, &r1], [&lit, &lit], 2.0);
        assert!((e - ((0.25 + 0.0 + 1.0) / 3.0f64).sqrt() / 2.0).abs() < 1e-15, "{e}");
        let none = [false; 4];
        assert!(temporal_error([&r0, &r1], [&r0, &r0], [&lit, &none], 1.0).is_nan());
    }

    /// Seeds of different frames and pixels differ, and none equals another run's
    /// (the reference's are frame 0's of its own base).
    #[test]
    fn seeds_do_not_collide() {
        let mut seen = std::collections::HashSet::new();
        for p in 0..256u64 {
            assert!(seen.insert(seed_of(REFERENCE_SEED, 0, p)));
            for k in 0..25u64 {
                assert!(seen.insert(seed_of(EQUAL_TIME_SEED, k, p)));
            }
        }
    }

    #[test]
    fn times_span_zero_to_one() {
        assert_eq!(time_of(0, 5), 0.0);
        assert_eq!(time_of(2, 5), 0.5);
        assert_eq!(time_of(4, 5), 1.0);
    }
}
