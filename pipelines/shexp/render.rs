//! `lobefit render shexp`: a procedural terrain with a sphere "whale" (50 spheres) or a
//! "wrecking ball" (402) under an SG sky, rendered by the SH-exponentiation pipeline,
//! by the Monte Carlo reference with exact visibility and by the SH-ideal render (the
//! same estimator with the light projected to the pipeline's order: exact visibility,
//! BRDF and cosine, only the band limit), with error images, the error breakdown and
//! the time at equal error (docs/shexp-render.md).
//!
//! Only the shading is compared: which surface a pixel sees is ray traced exactly and
//! shared. Every estimate is seeded per pixel, so nothing depends on the thread count;
//! the reference and the SH-ideal render draw the same directions (same seeds), so
//! their difference — the band limit's error — is precise.

use std::path::Path;

use rayon::prelude::*;

use super::shade::{radiance, sh_value, BlockerLog, BrdfMode, ExactCaps, Exp, Horizon, Overlap, Settings, Tables};
use super::{light, light_sh, reference, PIPELINE};
use crate::estimate::{per_pixel, Estimate};
use crate::image::{breakdown, compare, noise_free_rel_rmse, split_stage};
use crate::render::{column, shade_image, Frame, Reference, Strongest, Subset};
use crate::scene::{Hit, Scene};
use crate::sky::Phong;
use crate::timing::timed;
use crate::{RenderOptions, Summary};

/// The breakdown subset's reference takes this many times the image's samples.
pub const PRECISE_FACTOR: usize = 64;

/// Orders besides the default the breakdown's pixels are also shaded at.
pub const HIGHER_ORDERS: [usize; 2] = [6, 8];

/// Seed of the reference's per-pixel samples.
pub const MC_SEED: u64 = 0x5eed_0025;

/// The scene `name`: built-in `shexp-<name>`, else a scene file.
pub fn scene(name: &str) -> Result<Scene, String> {
    let scene = PIPELINE.scene(name)?;
    if scene.environment.is_empty() && scene.sh_environment.is_none() {
        return Err(format!(
            "scene {}: the SH-exponentiation pipeline needs a distant light (environment or sh_environment)",
            scene.name
        ));
    }
    for m in &scene.materials {
        let p = Phong::of(m).map_err(|e| format!("scene {}: {e}", scene.name))?;
        if p.specular > 0.0 && !(1.0..=lobefit_tables::log_zh::R_MAX).contains(&p.exponent) {
            return Err(format!(
                "scene {}: Phong exponent {} outside the log-ZH lobes' [1, {}]",
                scene.name,
                p.exponent,
                lobefit_tables::log_zh::R_MAX
            ));
        }
    }
    Ok(scene)
}

/// The pipeline's radiance at every hit with `s` (0 for background).
fn image(t: &Tables, s: &Settings, light: &[f64], scene: &Scene, hits: &[Option<Hit>]) -> Result<Vec<f64>, String> {
    shade_image(hits, |p, h| {
        radiance(t, s, light, &Phong::of(scene.brdf(h))?, scene, h)
            .map_err(|e| format!("pixel {p} (row-major), point {:?}: {e}", h.x.to_array()))
    })
}

/// Per-pixel Monte Carlo estimates at `spp` samples under `light_of` (seeded per
/// pixel by `seed`).
fn estimates(
    scene: &Scene,
    hits: &[Option<Hit>],
    w: usize,
    spp: usize,
    seed: u64,
    light_of: &(dyn Fn(lobefit_tables::glam::DVec3) -> f64 + Sync),
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<Estimate>, String> {
    per_pixel(
        hits,
        w,
        |hit, p| {
            Ok(reference(
                scene,
                light_of,
                &Phong::of(scene.brdf(hit))?,
                hit,
                spp,
                seed ^ p as u64,
            ))
        },
        progress,
    )
}

/// Renders the animated scene `name` ([`crate::animate`]): the pipeline at its default
/// settings against the strongest estimator of the baselines study on its scenes
/// (under an SG sky the control variate with QMC and per-point SG selection,
/// `qmc-cv-mis`; under an SH sky Owen-scrambled Sobol, `qmc`), at `--spp` for the
/// reference and at the pipeline's time.
pub fn animate(
    name: &str,
    opts: &RenderOptions,
    frames: usize,
    dir: &Path,
    progress: &(dyn Fn() + Sync),
) -> Result<Summary, String> {
    use crate::animate::Methods;
    let scene = scene(name)?;
    let tables = Tables::embedded()?;
    let settings = Settings::default();
    let light_n = light_sh(&scene, settings.order)?;
    if let Some(w) = super::truncation_warning(&scene, settings.order) {
        eprintln!("{w}");
    }
    let shade = |s: &Scene, hits: &[Option<Hit>]| image(&tables, &settings, &light_n, s, hits);
    let methods = Methods {
        method: "SH exponentiation (default settings)",
        shade: &shade,
        strongest: strongest_name(&scene),
        estimate: &strongest_estimate,
    };
    crate::animate::animate(&PIPELINE, &scene, opts, frames, dir, progress, &methods)
}

/// The strongest Monte Carlo estimator on an SH-exponentiation scene (the baselines
/// study's): [`strongest_estimate`]'s name.
fn strongest_name(scene: &Scene) -> &'static str {
    if scene.sh_environment.is_none() {
        crate::sky::strongest_name(scene)
    } else {
        "qmc"
    }
}

/// qmc-cv-mis under SGs, qmc-mis-map under a map; under an SH sky (no closed form for
/// a control variate) QMC.
fn strongest_estimate(s: &Scene, h: &Hit, n: usize, seed: u64) -> Result<Estimate, String> {
    use crate::estimate::Sampling;
    use crate::sky::reference_sampled;
    if s.sh_environment.is_none() {
        return crate::sky::qmc_cv_mis(s, h, n, seed);
    }
    let brdf = Phong::of(s.brdf(h))?;
    Ok(reference_sampled(
        Sampling::Qmc,
        &s.environment,
        |w| light(s, w),
        &brdf,
        |v| s.occluded(h, v),
        h,
        n,
        seed,
    ))
}

/// Renders one scene into `dir`.
pub fn render(name: &str, opts: &RenderOptions, dir: &Path, progress: &(dyn Fn() + Sync)) -> Result<Summary, String> {
    render_scene(&scene(name)?, opts, dir, progress)
}

/// Renders `scene` into `dir`: the skeleton ([`crate::render`]) filled in with the
/// SH-ideal render, the pipeline's variants and its breakdown.
fn render_scene(
    scene: &Scene,
    opts: &RenderOptions,
    dir: &Path,
    progress: &(dyn Fn() + Sync),
) -> Result<Summary, String> {
    let (f, (tables, light_n)) = Frame::new(&PIPELINE, scene, opts, dir, || {
        let tables = Tables::embedded()?;
        let light_n = light_sh(scene, Settings::default().order)?;
        if let Some(w) = super::truncation_warning(scene, Settings::default().order) {
            eprintln!("{w}");
        }
        Ok((tables, light_n))
    })?;
    let default = Settings::default();
    let mut sum = Summary::default();

    let full = |w: lobefit_tables::glam::DVec3| light(scene, w);
    let banded = |w: lobefit_tables::glam::DVec3| sh_value(&light_n, w);
    let (refs, t_ref) = timed(|| estimates(scene, &f.hits, f.w, opts.spp, MC_SEED, &full, progress));
    let r = Reference::new(&f, refs?, t_ref);
    // The SH-ideal render: the same directions (same seeds), the light band-limited.
    let ideal = Reference::new(
        &f,
        estimates(scene, &f.hits, f.w, opts.spp, MC_SEED, &banded, &|| ())?,
        0.0,
    );
    sum.lines.push(intro(&f, &r));
    let band = compare(&ideal.img, &r.img, &f.lit);
    sum.lines.push(format!(
        "{}: SH-ideal (exact visibility and BRDF, the light at order {}) against the reference: relative RMSE {:.4}, p99 {:.4}, max {:.4} (the band limit; the two share their samples)",
        f.tag, default.order, band.rel_rmse, band.p99, band.max
    ));
    let open = unoccluded(&f, scene, opts.spp)?;
    let refs = Refs {
        r: &r,
        ideal: &ideal,
        open: &open,
    };
    let (pipeline_img, t_pipe) = variants(&f, &tables, &light_n, &refs, &mut sum.lines)?;
    sum.lines.push(median_line(&f, "", &pipeline_img, &r, &ideal, &open));

    // The breakdown on a strided subset: each approximation made exact in turn.
    let picks = f.picks();
    let higher: Vec<(Settings, Vec<f64>)> = HIGHER_ORDERS
        .iter()
        .map(|&order| {
            let s = Settings { order, ..default };
            light_sh(scene, order).map(|l| (s, l))
        })
        .collect::<Result<_, _>>()?;
    let parts = breakdown_parts(&f, &tables, &light_n, &higher, &picks)?;
    let (rmse_pipe, mean_sub) = subset_lines(&f, &parts, &higher, &mut sum.lines);
    let mut names = vec![
        "pyramid horizon (→ the exact horizon)",
        "16 wedges (→ 64)",
        "HYB (→ exp* by its Taylor series)",
        "log-space BRDF (→ the triple product with the exactly projected BRDF × cosine)",
        "log visibility: ε floor, truncated exp*, wedge interpolation (→ SH-ideal)",
        "the band limit (→ the precise reference)",
    ];
    // The chain: the stages, SH-ideal, the precise reference; with meshes SH-ideal on
    // the sphere sets (the row's last value) before SH-ideal on the triangles.
    let chain: Vec<Vec<f64>> = if scene.meshes.is_empty() {
        parts.clone()
    } else {
        names[4] = "log visibility: ε floor, truncated exp*, wedge interpolation (→ SH-ideal on the sphere sets)";
        names.insert(5, "sphere sets → true meshes (SH-ideal on the triangles)");
        parts
            .iter()
            .map(|p| {
                let mut c = p[..STAGES].to_vec();
                c.extend([p[p.len() - 1], p[STAGES], p[STAGES + 1]]);
                c
            })
            .collect()
    };
    sum.lines
        .extend(breakdown(&f.tag, "the defaults", &names, &chain, mean_sub, f.stride()));
    if !scene.meshes.is_empty() {
        let on: Vec<bool> = picks
            .iter()
            .map(|&p| f.hits[p].is_some_and(|h| h.mesh.is_some()))
            .collect();
        sum.lines.push(split_stage(
            &f.tag,
            "sphere sets → true meshes",
            &chain,
            5,
            &on,
            mean_sub,
        ));
    }

    let eq = r.equal_error(&f, t_pipe, rmse_pipe);
    sum.lines.push(format!(
        "{}: time per pixel: pipeline {:.2} µs; reference {:.3} µs per sample, {:.0} samples for the pipeline's RMSE against the precise reference → {:.0} µs; ratio reference/pipeline {:.1} (one run, same process, the same BVH; plain Monte Carlo extrapolated σ²/ε², a weak baseline: docs/pipelines.md, Stronger baselines)",
        f.tag,
        1e6 * eq.pipeline_per_pixel,
        1e6 * eq.reference_per_sample,
        eq.samples,
        1e6 * eq.reference_per_pixel,
        eq.ratio
    ));

    let method = format!("SH exponentiation (order {})", default.order);
    let titles = [
        format!("{}: {method}", f.tag),
        format!("{}: Monte Carlo reference ({} spp)", f.tag, opts.spp),
    ];
    f.write_images(&mut sum, [&titles[0], &titles[1]], "shexp", &pipeline_img, &r)?;
    sum.files.extend(crate::image::write_float_image(
        dir,
        &format!("{}-sh-ideal", f.stem()),
        f.w,
        f.h,
        &ideal.img,
    )?);
    if let Some(map) = &scene.environment_map {
        // Each channel's lobes projected at the pipeline's order; the visibility is the
        // same for every channel, so a renderer would share it (here each channel is a
        // render of its own: the summary's time is the luminance's).
        let shade = |sc: &Scene, _: usize| image(&tables, &default, &light_sh(sc, default.order)?, sc, &f.hits);
        let colour = crate::render::Colour {
            method: &method,
            precise_factor: PRECISE_FACTOR,
            seed: MC_SEED,
            brdf: &|h: &Hit| Phong::of(scene.brdf(h)),
            image: &shade,
        };
        colour.write(&f, map, &r, &mut sum)?;
    }
    let error = format!(
        "relative RMSE {rmse_pipe:.4} against a {}-sample reference on {} pixels",
        opts.spp * PRECISE_FACTOR,
        picks.len()
    );
    let estimate = |h: &Hit, n: usize, seed: u64| strongest_estimate(scene, h, n, seed);
    let shade = |hits: &[Option<Hit>]| image(&tables, &default, &light_n, scene, hits);
    let strongest = Strongest {
        name: strongest_name(scene),
        estimate: &estimate,
        method: &shade,
    };
    f.finish(sum, &r, rmse_pipe, method, error, &strongest)
}

/// The errors relative to each pixel's unoccluded radiance (the same estimator with
/// nothing blocking, the same seeds): the medians of |pipeline − reference| /
/// unoccluded and |SH-ideal − reference| / unoccluded over the lit pixels, and over the
/// shadowed ones (reference below 0.9 × unoccluded: where the log/exp machinery acts),
/// and whether the pipeline's are within 2 × SH-ideal's + 0.01 (the band limit doubled
/// plus 1 % of the light, the target docs/shexp-render.md measures against).
fn median_line(
    f: &Frame<'_>,
    label: &str,
    pipeline: &[f64],
    r: &Reference,
    ideal: &Reference,
    open: &[Estimate],
) -> String {
    let median = |img: &[f64], shadowed: bool| {
        let mut v: Vec<f64> = (0..img.len())
            .filter(|&p| f.lit[p] && open[p].mean > 0.0 && (!shadowed || r.img[p] < 0.9 * open[p].mean))
            .map(|p| (img[p] - r.img[p]).abs() / open[p].mean)
            .collect();
        v.sort_by(f64::total_cmp);
        (v.get(v.len() / 2).copied().unwrap_or(0.0), v.len())
    };
    let part = |shadowed: bool| {
        let ((mp, n), (mi, _)) = (median(pipeline, shadowed), median(&ideal.img, shadowed));
        let bound = 2.0 * mi + 0.01;
        format!(
            "{} ({n} pixels) pipeline {mp:.4}, SH-ideal {mi:.4}, within 2 × SH-ideal's + 0.01 = {bound:.4}: {}",
            if shadowed { "shadowed" } else { "all" },
            if mp <= bound { "yes" } else { "no" }
        )
    };
    format!(
        "{}: {label}the median |image − reference| over each pixel's unoccluded radiance (the pipeline's carries the reference's noise; SH-ideal shares its samples): {}; {}",
        f.tag,
        part(false),
        part(true)
    )
}

/// Each pixel's unoccluded radiance: the reference's estimator with nothing blocking,
/// the same seeds (0 where the pixel sees no geometry).
fn unoccluded(f: &Frame<'_>, scene: &Scene, spp: usize) -> Result<Vec<Estimate>, String> {
    let full = |w: lobefit_tables::glam::DVec3| light(scene, w);
    per_pixel(
        &f.hits,
        f.w,
        |hit, p| {
            let brdf = Phong::of(scene.brdf(hit))?;
            Ok(crate::sky::reference_with(
                &scene.environment,
                full,
                &brdf,
                |_| false,
                hit,
                spp,
                MC_SEED ^ p as u64,
            ))
        },
        &|| (),
    )
}

/// The summary's first line: the scene and its reference.
fn intro(f: &Frame<'_>, r: &Reference) -> String {
    let scene = f.scene;
    format!(
        "{}: {}×{}, {} lit pixels, {} spheres, height field {}, light {}; SH order {}; reference {} samples/pixel, standard error mean {:.2e} of the mean radiance {:.4}",
        f.tag,
        f.w,
        f.h,
        f.pixels,
        scene.spheres.len(),
        scene.heightfield.as_ref().map_or("none".to_string(), |(hf, _)| format!("{0}×{0}", hf.n())),
        if scene.sh_environment.is_some() { "SH".to_string() } else { format!("{} SGs", scene.environment.len()) },
        Settings::default().order,
        f.opts.spp,
        r.rel_se,
        r.mean
    )
}

/// The settings [`variants`] renders: the defaults first, then each switch or
/// candidate changed alone (with its label).
fn variant_settings() -> Vec<(String, Settings)> {
    let default = Settings::default();
    let mut variants: Vec<(String, Settings)> = vec![("pipeline (defaults)".into(), default)];
    for wedges in [8, 32] {
        variants.push((format!("{wedges} wedges"), Settings { wedges, ..default }));
    }
    let one = |label: &str, s: Settings| (label.to_string(), s);
    variants.extend([
        one(
            "exact horizon",
            Settings {
                horizon: Horizon::Exact,
                ..default
            },
        ),
        one(
            "terrain above tangent",
            Settings {
                terrain_above_tangent: true,
                ..default
            },
        ),
        one(
            "no attenuation",
            Settings {
                attenuation: false,
                ..default
            },
        ),
        one(
            "Ren's blocker log",
            Settings {
                blocker_log: BlockerLog::Ren,
                ..default
            },
        ),
        one(
            "blocker ε = 0.01",
            Settings {
                eps_vis: 0.01,
                ..default
            },
        ),
        one(
            "blocker ε = 0.5",
            Settings {
                eps_vis: 0.5,
                ..default
            },
        ),
        one(
            "terrain ε = 0.01",
            Settings {
                eps_terrain: 0.01,
                ..default
            },
        ),
        one(
            "terrain ε = 0.9",
            Settings {
                eps_terrain: 0.9,
                ..default
            },
        ),
        one(
            "BRDF ε = 0.2",
            Settings {
                eps_brdf: 0.2,
                ..default
            },
        ),
        one(
            "exact exp*",
            Settings {
                exp: Exp::Exact,
                ..default
            },
        ),
        // Candidates: each blocker's log divided by its cap's mean coverage (with the
        // default floor, and with ε = 0.01); the exactly projected BRDF × cosine in a
        // Gaunt triple product instead of the log-space lobes (with HYB, and with exact
        // exp*).
        one(
            "overlap weighting",
            Settings {
                overlap: Overlap::Caps,
                ..default
            },
        ),
        one(
            "overlap, blocker ε = 0.01",
            Settings {
                overlap: Overlap::Caps,
                eps_vis: 0.01,
                ..default
            },
        ),
        one(
            "touching, blocker ε = 0.01",
            Settings {
                overlap: Overlap::Touching,
                eps_vis: 0.01,
                ..default
            },
        ),
        // Candidates: the caps apart from the log sum, projected exactly by a rule over
        // them (lone caps; every group not touching the terrain; that with the BRDF
        // triple product too).
        one(
            "lone caps exact",
            Settings {
                exact_caps: ExactCaps::Lone,
                ..default
            },
        ),
        one(
            "cap groups exact",
            Settings {
                exact_caps: ExactCaps::Groups,
                ..default
            },
        ),
        one(
            "cap groups exact, triple",
            Settings {
                exact_caps: ExactCaps::Groups,
                brdf: BrdfMode::Triple,
                ..default
            },
        ),
        one(
            "BRDF triple product",
            Settings {
                brdf: BrdfMode::Triple,
                ..default
            },
        ),
        one(
            "triple, exact exp*",
            Settings {
                brdf: BrdfMode::Triple,
                exp: Exp::Exact,
                ..default
            },
        ),
        one(
            "HYB re-fitted on sums",
            Settings {
                exp: HYB_REFIT,
                ..default
            },
        ),
        one(
            "blocker logs fitted on sums",
            Settings {
                blocker_bands: BLOCKER_BANDS_FIT,
                ..default
            },
        ),
        one(
            "the thesis's ε = 0.2",
            Settings {
                eps_vis: 0.2,
                eps_terrain: 0.2,
                eps_brdf: 0.2,
                ..default
            },
        ),
    ]);
    variants
}

/// The references a variant is compared with: the Monte Carlo reference, SH-ideal and
/// the unoccluded radiance.
struct Refs<'a> {
    r: &'a Reference,
    ideal: &'a Reference,
    open: &'a [Estimate],
}

/// HYB's rates re-fitted on the 12-sphere scenes' summed logs (`study_hyb_refit`,
/// docs/shexp-render.md): the mean's rate stays at the table's, the non-constant
/// bands' falls.
pub const HYB_REFIT: Exp = Exp::HybScaled {
    dc: -0.0004,
    hat: -0.154,
};

/// The blockers' log-ZH band factors fitted on the 12-sphere scenes' summed logs
/// (`study_blocker_bands`, docs/shexp-render.md): every band deepened.
pub const BLOCKER_BANDS_FIT: [f64; 8] = [2.24, 1.31, 2.02, 2.30, 1.0, 1.0, 1.0, 1.0];

/// The variants whose median line (the target's) is printed besides the defaults'.
const MEDIAN_VARIANTS: [&str; 6] = [
    "blocker ε = 0.01",
    "HYB re-fitted on sums",
    "blocker logs fitted on sums",
    "lone caps exact",
    "cap groups exact",
    "cap groups exact, triple",
];

/// The pipeline's variants, each timed and compared with the reference and with
/// SH-ideal (a line each in `lines`): the defaults' image and time (s).
fn variants(
    f: &Frame<'_>,
    tables: &Tables,
    light_n: &[f64],
    refs: &Refs<'_>,
    lines: &mut Vec<String>,
) -> Result<(Vec<f64>, f64), String> {
    let (r, ideal) = (refs.r, refs.ideal);
    let variants = variant_settings();
    let mut pipeline_img = Vec::new();
    let mut t_pipe = 0.0;
    for (k, (label, s)) in variants.iter().enumerate() {
        let (img, t) = timed(|| image(tables, s, light_n, f.scene, &f.hits));
        let img = img?;
        let st = compare(&img, &r.img, &f.lit);
        let nf = noise_free_rel_rmse(&img, &r.img, &r.se, &f.lit);
        let vs_ideal = noise_free_rel_rmse(&img, &ideal.img, &ideal.se, &f.lit);
        lines.push(format!(
            "{}: {label:<22}: against the reference relative RMSE {:.4} ({nf:.4} without its noise), p99 {:.4}, max {:.4}; against SH-ideal {vs_ideal:.4}; {:.2} µs/pixel",
            f.tag,
            st.rel_rmse,
            st.p99,
            st.max,
            1e6 * t / f.pixels as f64
        ));
        if MEDIAN_VARIANTS.contains(&label.as_str()) {
            lines.push(median_line(f, &format!("{label}: "), &img, r, ideal, refs.open));
        }
        if k == 0 {
            pipeline_img = img;
            t_pipe = t;
        }
    }
    Ok((pipeline_img, t_pipe))
}

/// How many stages [`breakdown_parts`] shades before its references.
const STAGES: usize = 5;

/// The breakdown at each pick, from the defaults, each approximation made exact in
/// turn: per pick the [`STAGES`] stages, SH-ideal, the precise reference, its standard
/// error, SH-ideal's, then per higher order the pipeline, SH-ideal and its standard
/// error.
fn breakdown_parts(
    f: &Frame<'_>,
    tables: &Tables,
    light_n: &[f64],
    higher: &[(Settings, Vec<f64>)],
    picks: &[usize],
) -> Result<Vec<Vec<f64>>, String> {
    let (scene, w) = (f.scene, f.w);
    let default = Settings::default();
    let mut stages = vec![default];
    let exact_horizon = Settings {
        horizon: Horizon::Exact,
        ..default
    };
    stages.push(exact_horizon);
    let many_wedges = Settings {
        wedges: 64,
        ..exact_horizon
    };
    stages.push(many_wedges);
    let exact_exp = Settings {
        exp: Exp::Exact,
        ..many_wedges
    };
    stages.push(exact_exp);
    stages.push(Settings {
        brdf: BrdfMode::Triple,
        ..exact_exp
    });
    debug_assert_eq!(stages.len(), STAGES);
    let full = |w: lobefit_tables::glam::DVec3| light(scene, w);
    let banded = |w: lobefit_tables::glam::DVec3| sh_value(light_n, w);
    picks
        .par_iter()
        .map(|&p| {
            let hit = f.hits[p].expect("lit");
            let brdf = Phong::of(scene.brdf(&hit))?;
            let mut v = stages
                .iter()
                .map(|s| radiance(tables, s, light_n, &brdf, scene, &hit))
                .collect::<Result<Vec<f64>, String>>()?;
            let n = f.opts.spp * PRECISE_FACTOR;
            let seed = MC_SEED ^ 0x9e37 ^ p as u64;
            let at = || format!("the breakdown's reference at pixel ({}, {})", p % w, p / w);
            let ideal = reference(scene, banded, &brdf, &hit, n, seed).finite(at)?;
            let precise = reference(scene, full, &brdf, &hit, n, seed).finite(at)?;
            v.extend([ideal.mean, precise.mean, precise.std_error, ideal.std_error]);
            // With meshes, last: SH-ideal with the analytic pipeline's blockers (the
            // meshes' sphere sets), on the same samples as SH-ideal.
            let proxied = (!scene.meshes.is_empty())
                .then(|| {
                    let occluded = |v| scene.proxies_occlude(&hit, v);
                    crate::sky::reference_with(&scene.environment, banded, &brdf, occluded, &hit, n, seed).finite(at)
                })
                .transpose()?;
            // Higher orders: the pipeline (defaults) and SH-ideal at each.
            for (s, light) in higher {
                v.push(radiance(tables, s, light, &brdf, scene, &hit)?);
                let e = reference(scene, |w| sh_value(light, w), &brdf, &hit, n, seed).finite(at)?;
                v.extend([e.mean, e.std_error]);
            }
            v.extend(proxied.map(|e| e.mean));
            Ok(v)
        })
        .collect()
}

/// The subset's statistics against the precise reference (lines in `lines`): the
/// pipeline's, SH-ideal's, the pipeline's against SH-ideal, and at each higher order;
/// returns the pipeline's relative RMSE (raw: the reference's noise in it) and the
/// precise reference's mean.
fn subset_lines(
    f: &Frame<'_>,
    parts: &[Vec<f64>],
    higher: &[(Settings, Vec<f64>)],
    lines: &mut Vec<String>,
) -> (f64, f64) {
    let ns = STAGES;
    let tag = &f.tag;
    let sub = Subset::new(column(parts, ns + 1), column(parts, ns + 2));
    let (ideal_sub, ideal_sub_se) = (column(parts, ns), column(parts, ns + 3));
    let (precise, precise_se, sub_mask) = (&sub.precise, &sub.precise_se, &sub.mask);
    lines.push(sub.header(f));
    let pipe_sub = column(parts, 0);
    let st = compare(&pipe_sub, precise, sub_mask);
    let st_ideal = compare(&ideal_sub, precise, sub_mask);
    let vs_ideal = noise_free_rel_rmse(&pipe_sub, &ideal_sub, &ideal_sub_se, sub_mask);
    lines.push(format!(
        "{tag}:   pipeline against the reference: relative RMSE {:.4} ({:.4} without its noise), p99 {:.4}, max {:.4}",
        st.rel_rmse,
        noise_free_rel_rmse(&pipe_sub, precise, precise_se, sub_mask),
        st.p99,
        st.max
    ));
    lines.push(format!(
        "{tag}:   SH-ideal against the reference (the band limit): relative RMSE {:.4}, p99 {:.4}, max {:.4}",
        st_ideal.rel_rmse, st_ideal.p99, st_ideal.max
    ));
    lines.push(format!(
        "{tag}:   pipeline against SH-ideal (the log/exp machinery): relative RMSE {vs_ideal:.4} (its noise out) — target: ≤ the band limit's {:.4}: {}",
        st_ideal.rel_rmse,
        if vs_ideal <= st_ideal.rel_rmse { "met" } else { "not met" }
    ));
    for (k, (s, _)) in higher.iter().enumerate() {
        let base = ns + 4 + 3 * k;
        let (pipe, ideal, ideal_se) = (column(parts, base), column(parts, base + 1), column(parts, base + 2));
        let band = compare(&ideal, precise, sub_mask);
        lines.push(format!(
            "{tag}:   order {}: pipeline against the reference {:.4}, SH-ideal against the reference (band limit) {:.4}, pipeline against SH-ideal {:.4}",
            s.order,
            compare(&pipe, precise, sub_mask).rel_rmse,
            band.rel_rmse,
            noise_free_rel_rmse(&pipe, &ideal, &ideal_se, sub_mask)
        ));
    }
    (st.rel_rmse, sub.mean)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env_or;

    /// A scene of a fit against SH-ideal: its name, hits, light (order 4) and SH-ideal
    /// image (exact visibility and BRDF, the light at the pipeline's order: what the
    /// log/exp machinery stands for), at `LF_WIDTH` px (48) and `LF_SPP` samples
    /// (1024), the seeds of `render shexp`.
    struct Case {
        name: String,
        scene: Scene,
        hits: Vec<Option<Hit>>,
        light: Vec<f64>,
        ideal: Vec<f64>,
    }

    /// The scenes of `var` (comma-separated built-in names or `shexp-*` files of
    /// assets/scenes), `default` when unset.
    fn cases(var: &str, default: &str) -> Vec<Case> {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/scenes/");
        let width: usize = env_or("LF_WIDTH", 48);
        let spp: usize = env_or("LF_SPP", 1024);
        env_or(var, default.to_string())
            .split(',')
            .map(|s| {
                let s = s.trim();
                let name = if s.starts_with("shexp-") {
                    format!("{root}{s}.json")
                } else {
                    s.to_string()
                };
                let sc = scene(&name).unwrap();
                let (hits, _) = sc.primary_hits(width, width * 3 / 4).unwrap();
                let light = light_sh(&sc, Settings::default().order).unwrap();
                let banded = |w: lobefit_tables::glam::DVec3| sh_value(&light, w);
                let ideal = estimates(&sc, &hits, width, spp, MC_SEED, &banded, &|| ())
                    .unwrap()
                    .iter()
                    .map(|e| e.mean)
                    .collect();
                Case {
                    name: sc.name.clone(),
                    scene: sc,
                    hits,
                    light,
                    ideal,
                }
            })
            .collect()
    }

    /// The pipeline's relative RMSE against SH-ideal over the lit pixels with `s`;
    /// infinite where a pixel leaves the pipeline's range (checked_visibility refuses
    /// it): such settings are out of the fit.
    fn error(t: &Tables, c: &Case, s: &Settings) -> f64 {
        let Ok(img) = image(t, s, &c.light, &c.scene, &c.hits) else {
            return f64::INFINITY;
        };
        let lit: Vec<usize> = (0..c.hits.len()).filter(|&p| c.hits[p].is_some()).collect();
        let se: f64 = lit.iter().map(|&p| (img[p] - c.ideal[p]).powi(2)).sum();
        let mean: f64 = lit.iter().map(|&p| c.ideal[p]).sum::<f64>() / lit.len() as f64;
        (se / lit.len() as f64).sqrt() / mean
    }

    const TRAIN: &str = "shexp-spheres12-diffuse,shexp-spheres12-phong3";
    const TEST: &str = "shexp-spheres60-diffuse,shexp-spheres60-phong3,whale,whale-diffuse,wrecking";

    /// Each scene's error with the defaults and with `fitted`.
    fn report(t: &Tables, train: &[Case], fitted: &Settings) {
        println!("scene                  role   rel RMSE vs SH-ideal: defaults  fitted");
        for (role, cs) in [("train", train), ("test", &cases("LF_TEST", TEST)[..])] {
            for c in cs {
                println!(
                    "{:<22} {role:<6} {:>31.4} {:>7.4}",
                    c.name,
                    error(t, c, &Settings::default()),
                    error(t, c, fitted)
                );
            }
        }
    }

    /// HYB re-fitted on multi-blocker sums (run with --ignored; docs/shexp-render.md,
    /// "HYB re-fitted on sums"): the rates (dc, hat) of [`Exp::HybScaled`] that bring
    /// the pipeline closest to SH-ideal on the training scenes `LF_TRAIN` (default the
    /// two 12-sphere scenes), by a grid over [−0.4, 0.4]² refined three times about its
    /// best; then the fitted rates' error on the other scenes `LF_TEST` ([`cases`]).
    /// Checks nothing.
    #[test]
    #[ignore]
    fn study_hyb_refit() {
        let tables = Tables::embedded().unwrap();
        let train = cases("LF_TRAIN", TRAIN);
        let with = |dc: f64, hat: f64| Settings {
            exp: Exp::HybScaled { dc, hat },
            ..Settings::default()
        };
        let cost = |dc: f64, hat: f64| {
            train
                .iter()
                .map(|c| error(&tables, c, &with(dc, hat)).powi(2))
                .sum::<f64>()
        };
        let mut best = (0.0, 0.0, cost(0.0, 0.0));
        for (step, half) in [(0.05, 8), (0.01, 5), (0.002, 5), (0.0004, 5)] {
            let (c0, h0) = (best.0, best.1);
            for i in -half..=half {
                for j in -half..=half {
                    let (dc, hat) = (c0 + step * i as f64, h0 + step * j as f64);
                    let c = cost(dc, hat);
                    if c < best.2 {
                        best = (dc, hat, c);
                    }
                }
            }
        }
        let (dc, hat) = (best.0, best.1);
        println!(
            "fitted on {:?}: dc = {dc:.4}, hat = {hat:.4}",
            train.iter().map(|c| &c.name).collect::<Vec<_>>()
        );
        for k in [-0.01, -0.002, 0.002, 0.01] {
            println!(
                "training cost (the squared errors' sum) at the fit {:.6}; dc {k:+}: {:.6}; hat {k:+}: {:.6}",
                best.2,
                cost(dc + k, hat),
                cost(dc, hat + k)
            );
        }
        report(&tables, &train, &with(dc, hat));
    }

    /// The per-blocker log vectors fitted on multi-blocker sums (run with --ignored;
    /// docs/shexp-render.md, "Per-blocker logs fitted on sums"): per-band factors on
    /// every blocker's log-ZH vector ([`Settings::blocker_bands`], bands 0–3 at order
    /// 4) that bring exp* of the sums closest to SH-ideal on `LF_TRAIN`, by coordinate
    /// descent (each factor over a grid of [0.3, 3.0], step 0.05, then 0.01 about the
    /// best; six sweeps), then their error on `LF_TEST` ([`cases`]). Checks nothing.
    #[test]
    #[ignore]
    fn study_blocker_bands() {
        let tables = Tables::embedded().unwrap();
        let train = cases("LF_TRAIN", TRAIN);
        let with = |b: &[f64; 8]| Settings {
            blocker_bands: *b,
            ..Settings::default()
        };
        let cost = |b: &[f64; 8]| train.iter().map(|c| error(&tables, c, &with(b)).powi(2)).sum::<f64>();
        let mut bands = [1.0; 8];
        let mut best = cost(&bands);
        for sweep in 0..6 {
            for l in 0..4 {
                // The coarse grid, then the fine one about the coarse grid's best.
                for fine in [false, true] {
                    let (step, lo, hi) = if fine {
                        (0.01, bands[l] - 0.05, bands[l] + 0.05)
                    } else {
                        (0.05, 0.3, 3.0)
                    };
                    let mut x = lo;
                    while x <= hi + 1e-9 {
                        let mut b = bands;
                        b[l] = x;
                        let c = cost(&b);
                        if c < best {
                            (best, bands) = (c, b);
                        }
                        x += step;
                    }
                }
            }
            println!("sweep {sweep}: bands {:.2?}, training cost {best:.6}", &bands[..4]);
        }
        report(&tables, &train, &with(&bands));
    }
}
