//! The skeleton every `lobefit render` pipeline fills in. A render of one scene is:
//! a [`Frame`] (image size, primary hits, output directory), the Monte Carlo
//! [`Reference`] over it, the pipeline's own images and statistics, the error
//! breakdown on [`Frame::picks`] (against a [`Subset`] reference where the pipeline
//! has one), the comparison images ([`Frame::write_images`]) and the summary with its
//! headline ([`Frame::finish`]). The pipelines own only what differs: their
//! shading, their variants, their breakdown rows and their extra panels.
//!
//! Every statistic is relative to the reference's mean over the lit pixels (those
//! that see geometry). `render rigs` does not use it: its truth is the exact
//! irradiance on a box built in code (no scene file, no Monte Carlo reference).

use std::path::Path;

use crate::estimate::Estimate;
use crate::image::{mean_over, write_comparison};
use crate::scene::{Hit, Scene};
use crate::timing::EqualError;
use crate::{Bound, Headline, Pipeline, RenderOptions, Summary};

/// One scene's render: its size, its primary hits and where its files go.
pub struct Frame<'a> {
    /// The pipeline (its name prefixes the scene's files and headline).
    pub pipeline: &'a Pipeline,
    /// The scene rendered.
    pub scene: &'a Scene,
    /// The command line's options.
    pub opts: &'a RenderOptions,
    /// Output directory (created by [`Frame::new`]).
    pub dir: &'a Path,
    /// The scene's name without the `<pipeline>-` prefix: the first word of every
    /// summary line.
    pub tag: String,
    /// Image width and height (pixels; the height is 3/4 of the width).
    pub w: usize,
    /// See [`Frame::w`].
    pub h: usize,
    /// Row-major primary hits, `None` where the pixel sees the background.
    pub hits: Vec<Option<Hit>>,
    /// Row-major: the pixel sees geometry.
    pub lit: Vec<bool>,
    /// How many pixels are lit.
    pub pixels: usize,
}

impl<'a> Frame<'a> {
    /// Checks the render's work against the limits ([`Pipeline::check_work`]), runs
    /// the pipeline's `setup` (its tables, its light: what may fail before any file is
    /// written), traces the primary hits and creates `dir`; returns the frame and what
    /// `setup` returned.
    pub fn new<T>(
        pipeline: &'a Pipeline,
        scene: &'a Scene,
        opts: &'a RenderOptions,
        dir: &'a Path,
        setup: impl FnOnce() -> Result<T, String>,
    ) -> Result<(Self, T), String> {
        let tag = scene
            .name
            .strip_prefix(&format!("{}-", pipeline.name))
            .unwrap_or(&scene.name)
            .to_string();
        let (w, h) = (opts.width.max(4), (opts.width * 3 / 4).max(3));
        pipeline.check_frames(scene, opts, 1)?;
        let prepared = setup()?;
        let (hits, lit) = scene.primary_hits(w, h)?;
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let pixels = lit.iter().filter(|&&l| l).count();
        let frame = Self {
            pipeline,
            scene,
            opts,
            dir,
            tag,
            w,
            h,
            hits,
            lit,
            pixels,
        };
        Ok((frame, prepared))
    }

    /// `<pipeline>-<tag>`: the stem of the scene's files.
    pub fn stem(&self) -> String {
        format!("{}-{}", self.pipeline.name, self.tag)
    }

    /// The breakdown's stride (`--breakdown-stride`, at least 1).
    pub fn stride(&self) -> usize {
        self.opts.breakdown_stride.max(1)
    }

    /// The lit pixels of every [`Frame::stride`]-th row and column (row-major
    /// indices): the error breakdown's subset.
    pub fn picks(&self) -> Vec<usize> {
        let (w, stride) = (self.w, self.stride());
        (0..self.h)
            .step_by(stride)
            .flat_map(|j| (0..w).step_by(stride).map(move |i| j * w + i))
            .filter(|&p| self.lit[p])
            .collect()
    }

    /// The PNG panels (method, reference, error), the beauty image and the float
    /// images of `method` against `reference` ([`write_comparison`]), recorded in
    /// `sum`; `titles` are the two panels' titles, `short` the method's file name.
    pub fn write_images(
        &self,
        sum: &mut Summary,
        titles: [&str; 2],
        short: &str,
        method: &[f64],
        reference: &Reference,
    ) -> Result<(), String> {
        let (files, _) = write_comparison(
            self.dir,
            &self.stem(),
            titles,
            short,
            (self.w, self.h),
            method,
            &reference.img,
            &self.lit,
            reference.mean,
        )?;
        sum.files.extend(files);
        Ok(())
    }

    /// Completes `sum`: the method's relative RMSE, the reference's relative standard
    /// error, the [`Headline`] and the `<stem>-summary.txt` file. The headline states
    /// the method's time against the strongest Monte Carlo's (`strongest`) at the
    /// method's error, both measured here on a sample of the frame's pixels
    /// ([`crate::measure::at_method_error`]); the plain estimator's extrapolation
    /// ([`Reference::equal_error`]) stays in the body's lines.
    pub fn finish(
        &self,
        mut sum: Summary,
        reference: &Reference,
        rel_rmse: f64,
        method: String,
        error: String,
        strongest: &Strongest<'_>,
    ) -> Result<Summary, String> {
        sum.rel_rmse = rel_rmse;
        sum.ref_rel_se = reference.rel_se;
        let m =
            crate::measure::at_method_error(&self.hits, self.w, strongest.name, strongest.estimate, strongest.method)?;
        sum.lines.push(at_error_line(&self.tag, &m));
        sum.headline.push(
            Headline {
                render: format!("{} {}", self.pipeline.name, self.tag),
                scope: format!("{}×{}", self.w, self.h),
                method,
                error,
                ..at_error_headline(&m, "")
            }
            .line(),
        );
        sum.write(self.dir, &self.stem())?;
        Ok(sum)
    }
}

/// The body's line of a headline measurement: the pixels, the reference, the method's
/// error and time, the estimator's samples and time there (with the runs' spread).
pub fn at_error_line(tag: &str, m: &crate::measure::AtMethodError) -> String {
    let (n_last, e_last, t_last) = m.last;
    format!(
        "{tag}: the strongest Monte Carlo at the method's error, measured on {} pixels (a reference of 2 × {} samples \
         of {}, its own error {:.1e}; medians of {} runs, [fastest–slowest]): the method {:.4} at {:.2} µs/px \
         [{:.2}–{:.2}]; {} {}",
        m.pixels,
        crate::measure::HEADLINE_REF_SPP,
        m.estimator,
        m.reference_error,
        crate::measure::HEADLINE_RUNS,
        m.method_error,
        m.method_us.median,
        m.method_us.min,
        m.method_us.max,
        m.estimator,
        match m.at {
            Some((n, t)) => format!(
                "needs {n:.0} spp there, {:.2} µs/px [{:.2}–{:.2}]",
                t.median, t.min, t.max
            ),
            None if m.first_meets => format!(
                "at its first point, {n_last} spp, already has error {e_last:.4}, {:.2} µs/px: it needs at most that",
                t_last.median
            ),
            None => format!(
                "at its last point, {n_last} spp, still has error {e_last:.4}, {:.2} µs/px: beyond the {} spp measured",
                t_last.median,
                crate::measure::HEADLINE_MAX_SPP
            ),
        }
    )
}

/// A [`Headline`]'s cost, baseline and ratio from a headline measurement (`render`,
/// `scope`, `method` and `error` left empty for the caller); `where_` qualifies the
/// pixels (`of frame 0`).
pub fn at_error_headline(m: &crate::measure::AtMethodError, where_: &str) -> Headline {
    let (n_last, _, t_last) = m.last;
    let (baseline_us, spread, bound, spp) = match (m.at, m.ratio()) {
        (Some((n, t)), Some((_, lo, hi))) => (t.median, Some((lo, hi)), Bound::Measured, format!("{n:.0} spp")),
        _ if m.first_meets => (t_last.median, None, Bound::AtMost, format!("at most {n_last} spp")),
        _ => (t_last.median, None, Bound::AtLeast, format!("more than {n_last} spp")),
    };
    let where_ = if where_.is_empty() {
        String::new()
    } else {
        format!(" {where_}")
    };
    Headline {
        render: String::new(),
        scope: String::new(),
        method: String::new(),
        error: String::new(),
        cost_us: m.method_us.median,
        unit: "px".into(),
        baseline: format!(
            "the strongest Monte Carlo, {}, at the method's error on {} of its pixels{where_} ({:.4}: {spp}, measured)",
            m.estimator, m.pixels, m.method_error
        ),
        baseline_us,
        spread,
        bound,
    }
}

/// What a render's headline measures against ([`Frame::finish`]): the strongest Monte
/// Carlo estimator on the pipeline's scenes (the baselines study's: qmc-cv-mis under
/// SGs, qmc on Meunier's lights) and the method's shading of a hit array.
pub struct Strongest<'s> {
    /// The estimator's name.
    pub name: &'static str,
    /// The estimator: (hit, samples, seed) → estimate.
    pub estimate: crate::measure::Estimator<'s>,
    /// The method's image of the given hits (0 where none).
    pub method: &'s crate::measure::MethodImage<'s>,
}

/// The Monte Carlo reference over a [`Frame`]: its per-pixel estimates and what every
/// pipeline derives from them.
pub struct Reference {
    /// Per-pixel estimates (empty ones on the background).
    pub refs: Vec<Estimate>,
    /// Its wall time (s).
    pub time: f64,
    /// The estimates' means (radiance).
    pub img: Vec<f64>,
    /// The estimates' standard errors.
    pub se: Vec<f64>,
    /// The mean radiance over the lit pixels: every relative statistic's denominator.
    pub mean: f64,
    /// The mean standard error over the lit pixels, relative to [`Reference::mean`].
    pub rel_se: f64,
}

impl Reference {
    /// From the estimates `refs` over `frame`, taken in `time` seconds.
    pub fn new(frame: &Frame<'_>, refs: Vec<Estimate>, time: f64) -> Self {
        let img: Vec<f64> = refs.iter().map(|r| r.mean).collect();
        let se: Vec<f64> = refs.iter().map(|r| r.std_error).collect();
        let mean = mean_over(&img, &frame.lit);
        let rel_se = mean_over(&se, &frame.lit) / mean;
        Self {
            refs,
            time,
            img,
            se,
            mean,
            rel_se,
        }
    }

    /// The reference's cost at a method's error: the method took `method_s` seconds
    /// over the frame and has relative RMSE `rel_rmse`.
    pub fn equal_error(&self, frame: &Frame<'_>, method_s: f64, rel_rmse: f64) -> EqualError {
        EqualError::from_estimates(
            method_s,
            self.time,
            &self.refs,
            &frame.lit,
            frame.opts.spp,
            rel_rmse * self.mean,
        )
    }
}

/// The breakdown subset's precise reference ([`Frame::picks`] at `spp` × the
/// pipeline's precise factor): the subset's errors are measured against it.
pub struct Subset {
    /// Its radiance per pick.
    pub precise: Vec<f64>,
    /// Its standard error per pick.
    pub precise_se: Vec<f64>,
    /// All true: every pick is lit.
    pub mask: Vec<bool>,
    /// Its mean over the picks: the subset's relative statistics' denominator.
    pub mean: f64,
}

impl Subset {
    /// From the precise reference's means and standard errors per pick.
    pub fn new(precise: Vec<f64>, precise_se: Vec<f64>) -> Self {
        let mask = vec![true; precise.len()];
        let mean = mean_over(&precise, &mask);
        Self {
            precise,
            precise_se,
            mask,
            mean,
        }
    }

    /// The line that opens the subset's statistics: how many pixels, the reference's
    /// samples and its relative standard error.
    pub fn header(&self, frame: &Frame<'_>) -> String {
        format!(
            "{}: on {} pixels (every {}th) against a reference of {} samples (standard error mean {:.2e} of the mean):",
            frame.tag,
            self.precise.len(),
            frame.stride(),
            frame.opts.spp * frame.pipeline.monte_carlo().map_or(0, |m| m.precise_factor) as usize,
            mean_over(&self.precise_se, &self.mask) / self.mean
        )
    }
}

/// A method's image: `shade(pixel, hit)` at every pixel that sees geometry (row-major
/// index), 0 on the background, in parallel (each pixel on its own, so the image does
/// not depend on the thread count).
pub fn shade_image(
    hits: &[Option<Hit>],
    shade: impl Fn(usize, &Hit) -> Result<f64, String> + Sync,
) -> Result<Vec<f64>, String> {
    use rayon::prelude::*;
    hits.par_iter()
        .enumerate()
        .map(|(p, h)| match h {
            None => Ok(0.0),
            Some(h) => shade(p, h),
        })
        .collect()
}

/// Column `k` of per-pick rows (one value per pick).
pub fn column(parts: &[Vec<f64>], k: usize) -> Vec<f64> {
    parts.iter().map(|p| p[k]).collect()
}

/// A pipeline's image of a frame's hits under a scene's `environment`, given which
/// channel (0, 1, 2: R, G, B) that environment is.
pub type ChannelImage<'a> = dyn Fn(&Scene, usize) -> Result<Vec<f64>, String> + 'a;

/// Under a map, a frame in colour: the pipeline's image with each channel's lobes
/// ([`crate::envmap::LightMap::channel_sgs`] as the scene's `environment`) against a
/// reference on that channel of the map itself. What a pipeline gives: its name for
/// the summary, its breakdown's sample factor and seed, its BRDF at a hit and its image
/// of a scene (the frame's hits, shaded under that scene's lobes).
pub struct Colour<'a> {
    /// The method's name in the summary line.
    pub method: &'a str,
    /// The breakdown subset's reference takes this many times the image's samples.
    pub precise_factor: usize,
    /// The image reference's seed (the pipeline's own: the same draws as its
    /// luminance reference).
    pub seed: u64,
    /// The BRDF the references sample at a hit.
    pub brdf: &'a (dyn Fn(&Hit) -> Result<crate::sky::Phong, String> + Sync),
    /// The pipeline's image of the frame's hits under a scene's `environment` (that
    /// of channel `c`, the second argument: 0, 1, 2 for R, G, B).
    pub image: &'a ChannelImage<'a>,
}

impl Colour<'_> {
    /// Each channel's error, measured as the luminance's is: on the breakdown's subset
    /// ([`Frame::picks`]) against a reference with `precise_factor` × the samples
    /// (relative RMSE, with and without that reference's noise, and max, over the
    /// channel's mean), one summary line. `<stem>-colour.png` shows the pipeline and the
    /// image's reference side by side at the luminance beauty's exposure. Every
    /// channel's reference draws as the luminance's does (same seeds, the texels
    /// sampled by luminance: unbiased for each channel).
    pub fn write(
        &self,
        f: &Frame<'_>,
        map: &crate::envmap::LightMap,
        r: &Reference,
        sum: &mut Summary,
    ) -> Result<(), String> {
        use rayon::prelude::*;
        let scene = f.scene;
        let picks = f.picks();
        let sub_lit = vec![true; picks.len()];
        let (brdf, seed, factor) = (self.brdf, self.seed, self.precise_factor);
        let reference = |hit: &Hit, c: usize, spp: usize, seed: u64| -> Result<Estimate, String> {
            Ok(crate::sky::reference_map(
                crate::estimate::Sampling::Plain,
                map,
                |w| map.channel(w, c),
                &brdf(hit)?,
                |v| scene.occluded(hit, v),
                hit,
                spp,
                seed,
            ))
        };
        let (mut method, mut refs) = (Vec::new(), Vec::new());
        let mut line = format!(
            "{}: colour (the map's R, G, B; {} against each channel's {}-sample reference on {} pixels):",
            f.tag,
            self.method,
            f.opts.spp * self.precise_factor,
            picks.len()
        );
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            let mut sc = scene.clone();
            sc.environment = map.channel_sgs(c);
            let img = (self.image)(&sc, c)?;
            let est = crate::estimate::per_pixel(
                &f.hits,
                f.w,
                |hit, p| reference(hit, c, f.opts.spp, seed ^ p as u64),
                &|| {},
            )?;
            refs.push(Reference::new(f, est, 0.0).img);
            let precise: Vec<Estimate> = picks
                .par_iter()
                .map(|&p| {
                    let hit = f.hits[p].as_ref().expect("picks are lit");
                    reference(hit, c, f.opts.spp * factor, seed ^ 0x9e37_79b9 ^ p as u64)
                })
                .collect::<Result<_, String>>()?;
            let mean: Vec<f64> = precise.iter().map(|e| e.mean).collect();
            let se: Vec<f64> = precise.iter().map(|e| e.std_error).collect();
            let v: Vec<f64> = picks.iter().map(|&p| img[p]).collect();
            let st = crate::image::compare(&v, &mean, &sub_lit);
            line += &format!(
                " {name} relative RMSE {:.4} ({:.4} without the reference's noise), max {:.4};",
                st.rel_rmse,
                crate::image::noise_free_rel_rmse(&v, &mean, &se, &sub_lit),
                st.max
            );
            method.push(img);
        }
        sum.lines.push(line.trim_end_matches(';').to_string());
        let path = f.dir.join(format!("{}-colour.png", f.stem()));
        sum.files.push(crate::image::write_beauty_rgb(
            &path,
            (f.w, f.h),
            &[[&method[0], &method[1], &method[2]], [&refs[0], &refs[1], &refs[2]]],
            &f.lit,
            crate::image::exposure_for(r.mean),
        )?);
        Ok(())
    }
}
