//! `lobefit render isg`: a Figure 12 analogue (spheres over a plane under nine SGs,
//! one of them a sun) rendered by the ISG pipeline with each model and by the Monte
//! Carlo reference with exact visibility, with error images, the error breakdown and
//! the time at equal error (docs/isg-render.md).
//!
//! Only the shading is compared: which surface a pixel sees is ray traced exactly and
//! shared. The reference is seeded per pixel ([`MC_SEED`]), so it does not depend on
//! the thread count, and reports its standard error.

use std::path::Path;

use rayon::prelude::*;

use super::shade::{radiance, Blockers, MicrofacetLobe, Model, Patches, Phong, Settings, Specular, Tables};
use super::{reference, PIPELINE};
use crate::estimate::per_pixel;
use crate::image::{breakdown, compare, noise_free_rel_rmse, split_stage};
use crate::render::{column, shade_image, Frame, Reference, Strongest, Subset};
use crate::scene::{Hit, Scene};
use crate::timing::timed;
use crate::{RenderOptions, Summary};

/// The breakdown subset's reference takes this many times the image's samples.
pub const PRECISE_FACTOR: usize = 64;

/// Seed of the reference's per-pixel samples.
pub const MC_SEED: u64 = 0x5eed_0012;

/// The scene `name`: built-in `isg-<name>`, one of the sweep's (`sweep-N`, N in
/// [`SWEEP`]), else a scene file.
pub fn scene(name: &str) -> Result<Scene, String> {
    // One scene of the sweep by its name (`sweep-46`, …, `sweep-306`).
    if let Some(count) = name.strip_prefix("sweep-").and_then(|n| n.parse::<usize>().ok()) {
        if SWEEP.contains(&count) {
            return sweep_scene(count);
        }
    }
    let scene = PIPELINE.scene(name)?;
    if scene.environment.is_empty() {
        return Err(format!(
            "scene {}: the ISG pipeline needs an environment (SGs)",
            scene.name
        ));
    }
    for m in &scene.materials {
        Phong::of_any(m).map_err(|e| format!("scene {}: {e}", scene.name))?;
    }
    Ok(scene)
}

/// The blockers of a hit: the scene's spheres and its meshes' sphere sets
/// ([`Scene::proxies`]) but the hit's own, through their BVH.
pub fn blockers_of<'a>(scene: &'a Scene, h: &Hit) -> Blockers<'a> {
    Blockers {
        spheres: &scene.proxies,
        cull: super::shade::Cull::Bvh(scene.proxy_bvh()),
        own: scene.own_proxies(h),
    }
}

/// The pipeline's radiance at hit `h` with `s`: 0 where the point is buried in a
/// blocker ([`Scene::buried`]: a mesh's covering sphere; the proxy is a solid, as the
/// Meunier and SH renders take it).
pub fn shade_hit(t: &Tables, s: &Settings, scene: &Scene, h: &Hit) -> Result<f64, String> {
    if scene.buried(h) {
        return Ok(0.0);
    }
    let brdf = Phong::of_any(scene.brdf(h))?;
    radiance(t, s, &scene.environment, &brdf, &blockers_of(scene, h), h)
}

/// The pipeline's radiance at every hit with `s` (0 for background).
fn image(t: &Tables, s: &Settings, scene: &Scene, hits: &[Option<Hit>]) -> Result<Vec<f64>, String> {
    shade_image(hits, |_, h| shade_hit(t, s, scene, h))
}

/// Sphere counts of the sweep (Table 1's range, 46 to 306 spheres).
pub const SWEEP: [usize; 4] = [46, 102, 204, 306];

/// The Figure 12 analogue with `count` spheres: seeded, non-overlapping, radius 0.12
/// to 0.35, over the same plane (named `sweep-<count>`).
pub fn sweep_scene(count: usize) -> Result<Scene, String> {
    let text = super::PIPELINE.file("fig12").ok_or("isg-fig12 is not built in")?;
    let mut v: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let material = v["spheres"][0]["material"].clone();
    let mut rng = lobefit_core::rng::Rng::new(0x5eed_0306 ^ count as u64);
    let mut placed: Vec<([f64; 3], f64)> = Vec::new();
    let mut tries = 0;
    while placed.len() < count && tries < 1_000_000 {
        tries += 1;
        let r = rng.range(0.12, 0.35);
        let lift = if rng.uniform() < 0.4 { rng.range(0.1, 1.2) } else { 0.0 };
        let c = [rng.range(-4.0, 4.0), rng.range(-3.0, 4.0), r + lift];
        let apart = |(o, q): &([f64; 3], f64)| {
            let d = ((c[0] - o[0]).powi(2) + (c[1] - o[1]).powi(2) + (c[2] - o[2]).powi(2)).sqrt();
            d > r + q + 0.03
        };
        if placed.iter().all(apart) {
            placed.push((c, r));
        }
    }
    v["spheres"] = placed
        .iter()
        .map(|(c, r)| serde_json::json!({"centre": c, "radius": r, "material": material}))
        .collect();
    crate::scene::parse(&format!("sweep-{count}"), &v.to_string())
}

/// Renders one scene into `dir`; `sweep` renders the sphere-count sweep.
pub fn render(name: &str, opts: &RenderOptions, dir: &Path, progress: &(dyn Fn() + Sync)) -> Result<Summary, String> {
    if name == "sweep" {
        let mut sum = Summary::default();
        for count in SWEEP {
            let s = render_scene(&sweep_scene(count)?, opts, dir, progress)?;
            sum.lines.extend(s.lines);
            sum.files.extend(s.files);
            sum.headline.extend(s.headline);
            sum.rel_rmse = sum.rel_rmse.max(s.rel_rmse);
            sum.ref_rel_se = sum.ref_rel_se.max(s.ref_rel_se);
        }
        return Ok(sum);
    }
    render_scene(&scene(name)?, opts, dir, progress)
}

/// Renders the animated scene `name` ([`crate::animate`]): the ISG with the best model
/// against the control variate with QMC and per-point SG selection (`qmc-cv-mis`, the
/// strongest estimator on the ISG scenes in the baselines study), at `--spp` for the
/// reference and at the ISG's time.
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
    let shade = |s: &Scene, hits: &[Option<Hit>]| image(&tables, &settings, s, hits);
    let estimate = |s: &Scene, h: &Hit, n: usize, seed: u64| crate::sky::qmc_cv_mis(s, h, n, seed);
    let methods = Methods {
        method: "ISG (best model)",
        shade: &shade,
        strongest: crate::sky::strongest_name(&scene),
        estimate: &estimate,
    };
    crate::animate::animate(&PIPELINE, &scene, opts, frames, dir, progress, &methods)
}

/// Renders `scene` into `dir`: the skeleton ([`crate::render`]) filled in with the
/// ISG's models, its patch resolutions and its breakdown.
fn render_scene(
    scene: &Scene,
    opts: &RenderOptions,
    dir: &Path,
    progress: &(dyn Fn() + Sync),
) -> Result<Summary, String> {
    let (f, mut tables) = Frame::new(&PIPELINE, scene, opts, dir, Tables::embedded)?;
    tables.prefiltered = scene.prefiltered.clone();
    let mut sum = Summary::default();
    let r = image_reference(&f, progress)?;
    sum.lines.push(intro(&f, &r));
    let (model_imgs, t_best) = models(&f, &tables, &r, &mut sum.lines)?;
    let default = Settings::default();
    let (head, head_settings) = headline(&tables, model_imgs.len());
    for (label, patches) in [("100", Patches::Grid(10)), ("400", Patches::Grid(20))] {
        let s = Settings { patches, ..default };
        let img = image(&tables, &s, scene, &f.hits)?;
        let st = compare(&img, &r.img, &f.lit);
        sum.lines.push(format!(
            "{}: model best, {label} patches: relative RMSE {:.4} ({:.4} without the reference's noise), p99 {:.4}, max {:.4}",
            f.tag,
            st.rel_rmse,
            noise_free_rel_rmse(&img, &r.img, &r.se, &f.lit),
            st.p99,
            st.max
        ));
    }
    // The breakdown on a strided subset: each approximation made exact in turn.
    let picks = f.picks();
    let (parts, names) = breakdown_parts(&f, &tables, &picks)?;
    let at = names.len();
    let sub = Subset::new(column(&parts, at), column(&parts, at + 1));
    sum.lines.push(sub.header(&f));
    let mut rmse_best = f64::NAN;
    for (k, (label, img)) in model_imgs.iter().enumerate() {
        let v: Vec<f64> = picks.iter().map(|&p| img[p]).collect();
        let st = compare(&v, &sub.precise, &sub.mask);
        let nf = noise_free_rel_rmse(&v, &sub.precise, &sub.precise_se, &sub.mask);
        if k == head {
            // The raw RMSE: an upper bound of the error (the reference's noise in it),
            // so the equal-error ratio below is a lower bound.
            rmse_best = st.rel_rmse;
        }
        sum.lines.push(format!(
            "{}:   {label:<18}: relative RMSE {:.4} ({nf:.4} without the reference's noise), p99 {:.4}, max {:.4}",
            f.tag, st.rel_rmse, st.p99, st.max
        ));
    }
    sum.lines.extend(breakdown(
        &f.tag,
        "the paper's configuration (best model, binary, eq. 9)",
        &names,
        &parts,
        sub.mean,
        f.stride(),
    ));
    if !scene.meshes.is_empty() {
        let on: Vec<bool> = picks
            .iter()
            .map(|&p| f.hits[p].is_some_and(|h| h.mesh.is_some()))
            .collect();
        sum.lines.push(split_stage(
            &f.tag,
            "sphere sets → true meshes",
            &parts,
            names.len() - 1,
            &on,
            sub.mean,
        ));
    }

    let eq = r.equal_error(&f, t_best, rmse_best);
    sum.lines.push(format!(
        "{}: time per pixel: ISG (best) {:.2} µs; reference {:.3} µs per sample, {:.0} samples for the ISG's RMSE against the precise reference → {:.0} µs; ratio reference/ISG {:.0} (at least: that RMSE includes the precise reference's noise; one run, same process, the same BVH; plain Monte Carlo extrapolated σ²/ε², a weak baseline: docs/pipelines.md, Stronger baselines)",
        f.tag,
        1e6 * eq.pipeline_per_pixel,
        1e6 * eq.reference_per_sample,
        eq.samples,
        1e6 * eq.reference_per_pixel,
        eq.ratio
    ));
    let titles = [
        &format!("{}: ISG pipeline ({})", f.tag, headline_name(&tables)),
        &format!("{}: Monte Carlo reference ({} spp)", f.tag, opts.spp),
    ];
    f.write_images(&mut sum, titles.map(String::as_str), "isg", &model_imgs[head].1, &r)?;
    if let Some(map) = &scene.environment_map {
        // Under Γ_L each channel reads its own channel of the table.
        let shade = |sc: &Scene, c: usize| {
            let s = Settings {
                prefiltered_channel: Some(c),
                ..head_settings
            };
            image(&tables, &s, sc, &f.hits)
        };
        let colour = crate::render::Colour {
            method: &format!("ISG {}", headline_name(&tables)),
            precise_factor: PRECISE_FACTOR,
            seed: MC_SEED,
            brdf: &|h: &Hit| Phong::of_any(scene.brdf(h)),
            image: &shade,
        };
        colour.write(&f, map, &r, &mut sum)?;
    }
    let error = format!(
        "relative RMSE {rmse_best:.4} against a {}-sample reference on {} pixels",
        opts.spp * PRECISE_FACTOR,
        picks.len()
    );
    let estimate = |h: &Hit, n: usize, seed: u64| crate::sky::qmc_cv_mis(scene, h, n, seed);
    let method = |hits: &[Option<Hit>]| image(&tables, &head_settings, scene, hits);
    let strongest = Strongest {
        name: crate::sky::strongest_name(scene),
        estimate: &estimate,
        method: &method,
    };
    f.finish(
        sum,
        &r,
        rmse_best,
        format!("ISG ({})", headline_name(&tables)),
        error,
        &strongest,
    )
}

/// The image's Monte Carlo reference ([`MC_SEED`]-seeded per pixel), timed.
fn image_reference(f: &Frame<'_>, progress: &(dyn Fn() + Sync)) -> Result<Reference, String> {
    let scene = f.scene;
    let (refs, t_ref) = timed(|| {
        per_pixel(
            &f.hits,
            f.w,
            |hit, p| {
                let brdf = Phong::of_any(scene.brdf(hit))?;
                Ok(crate::sky::scene_reference(
                    scene,
                    &brdf,
                    |v| scene.occluded(hit, v),
                    hit,
                    f.opts.spp,
                    MC_SEED ^ p as u64,
                ))
            },
            progress,
        )
    });
    Ok(Reference::new(f, refs?, t_ref))
}

/// The summary's first line: the scene and its reference.
fn intro(f: &Frame<'_>, r: &Reference) -> String {
    let scene = f.scene;
    format!(
        "{}: {}×{}, {} lit pixels, {} spheres{}, {} lighting SGs; reference {} samples/pixel, standard error mean {:.2e} of the mean radiance {:.4}",
        f.tag,
        f.w,
        f.h,
        f.pixels,
        scene.spheres.len(),
        if scene.meshes.is_empty() {
            String::new()
        } else {
            format!(
                ", {} meshes ({} triangles, shaded with {} proxy spheres, the reference with the triangles)",
                scene.meshes.len(),
                scene.meshes.iter().map(|m| m.mesh.triangles.len()).sum::<usize>(),
                scene.proxies.len() - scene.spheres.len()
            )
        },
        scene.environment.len(),
        f.opts.spp,
        r.rel_se,
        r.mean
    )
}

/// Which of [`models`]' images is the best model's (the one timed and written).
const BEST: usize = 2;

/// The headline's image among [`models`]' (`count` of them) and its settings: the best
/// model's default form, or, where the scene names its map's Γ_L, the best model with
/// eq. 9 from Γ_L (the last of [`models`]' rows), which shades the map itself where the
/// lobes hold only its low frequencies (docs/environment.md). The GPU kernel shades the
/// same form (eq. 9 from Γ_L's texture where the scene names it), and its conformance
/// run compares with that.
fn headline(tables: &Tables, count: usize) -> (usize, Settings) {
    match tables.prefiltered {
        Some(_) => (
            count - 1,
            Settings {
                specular: Specular::Eq9Prefiltered,
                ..Settings::default()
            },
        ),
        None => (BEST, Settings::default()),
    }
}

/// The headline's name ([`headline`]).
fn headline_name(tables: &Tables) -> &'static str {
    match tables.prefiltered {
        Some(_) => "best model, eq. 9 from Γ_L",
        None => "best model",
    }
}

/// A labelled image (row-major radiance).
type Labelled = (String, Vec<f64>);

/// Every model's image, then the best model's with eq. 9, each timed and compared
/// with the reference (a line each in `lines`): the labelled images and the best
/// model's time (s).
fn models(
    f: &Frame<'_>,
    tables: &Tables,
    r: &Reference,
    lines: &mut Vec<String>,
) -> Result<(Vec<Labelled>, f64), String> {
    let default = Settings::default();
    let mut variants: Vec<(String, Settings)> = Model::ALL
        .iter()
        .map(|&model| (format!("model {}", model.name()), Settings { model, ..default }))
        .collect();
    variants.push((
        "model best, eq. 9".into(),
        Settings {
            specular: Specular::Eq9,
            ..default
        },
    ));
    if f.scene
        .materials
        .iter()
        .any(|m| matches!(m, crate::scene::Brdf::CookTorrance { .. }))
    {
        // Wang et al.'s lobe as they give it, and the NDF as 1 to 3 SGs matched to the
        // term's albedo (one of them the default).
        let rows = [
            ("model best, Cook–Torrance: 1 SG at its axis", MicrofacetLobe::Axis),
            ("model best, Cook–Torrance: 1 SG matched", MicrofacetLobe::Matched(1)),
            ("model best, Cook–Torrance: 2 SGs matched", MicrofacetLobe::Matched(2)),
            ("model best, Cook–Torrance: 3 SGs matched", MicrofacetLobe::Matched(3)),
        ];
        for (label, microfacet) in rows {
            if microfacet != default.microfacet {
                variants.push((label.into(), Settings { microfacet, ..default }));
            }
        }
    }
    if tables.prefiltered.is_some() {
        // The scene names its map's Γ_L: eq. 9 with the map itself (docs/environment.md).
        variants.push((
            "model best, eq. 9, Γ_L".into(),
            Settings {
                specular: Specular::Eq9Prefiltered,
                ..default
            },
        ));
    }
    let mut t_best = 0.0;
    let mut model_imgs = Vec::new();
    for (k, (label, s)) in variants.iter().enumerate() {
        let (img, t) = timed(|| image(tables, s, f.scene, &f.hits));
        let img = img?;
        let st = compare(&img, &r.img, &f.lit);
        let nf = noise_free_rel_rmse(&img, &r.img, &r.se, &f.lit);
        lines.push(format!(
            "{}: {label:<18} (adaptive patches, ε = 0.01, binary): relative RMSE {:.4} ({nf:.4} without the reference's noise), p99 {:.4}, max {:.4}; {:.2} µs/pixel",
            f.tag,
            st.rel_rmse,
            st.p99,
            st.max,
            1e6 * t / f.pixels as f64
        ));
        model_imgs.push((label.clone(), img));
        if k == headline(tables, variants.len()).0 {
            t_best = t;
        }
    }
    Ok((model_imgs, t_best))
}

/// The breakdown at each pick, from the paper's configuration (best model, binary,
/// eq. 9), each approximation made exact in turn: one row per pick (the stages, then
/// the precise reference's mean and standard error), and the stages' names.
fn breakdown_parts(
    f: &Frame<'_>,
    tables: &Tables,
    picks: &[usize],
) -> Result<(Vec<Vec<f64>>, Vec<&'static str>), String> {
    let (scene, w, spp) = (f.scene, f.w, f.opts.spp);
    let default = Settings::default();
    let paper = Settings {
        specular: Specular::Eq9,
        ..default
    };
    let stages = [
        paper,
        Settings {
            model: Model::Quadrature,
            ..paper
        },
        Settings {
            model: Model::Quadrature,
            binary: false,
            ..paper
        },
        Settings {
            model: Model::Quadrature,
            binary: false,
            specular: Specular::Product,
            ..default
        },
    ];
    // With meshes, a last stage: the sphere sets → the true triangles.
    let meshes = !scene.meshes.is_empty();
    // With a map, a last stage: the fitted lobes → the map itself.
    let map = scene.environment_map.is_some();
    let parts: Vec<Vec<f64>> = picks
        .par_iter()
        .map(|&p| {
            let hit = f.hits[p].expect("lit");
            let brdf = Phong::of_any(scene.brdf(&hit))?;
            let mut v = stages
                .iter()
                .map(|s| shade_hit(tables, s, scene, &hit))
                .collect::<Result<Vec<f64>, String>>()?;
            // A reference with PRECISE_FACTOR × the samples: the subset's errors are
            // measured against it (its noise far below the pipeline's error).
            let precise = crate::sky::scene_reference(
                scene,
                &brdf,
                |v| scene.occluded(&hit, v),
                &hit,
                spp * PRECISE_FACTOR,
                MC_SEED ^ 0x9e37 ^ p as u64,
            )
            .finite(|| format!("the breakdown's reference at pixel ({}, {})", p % w, p / w))?;
            if meshes {
                // The precise reference on the sphere sets (their exact visibility, the
                // hit's own mesh's set left out as the pipeline does), with the same
                // samples as the one with the true triangles: their difference is the
                // proxy's alone.
                let own = scene.own_proxies(&hit);
                let on_spheres = reference(
                    &scene.environment,
                    &brdf,
                    |v| {
                        scene
                            .proxies
                            .iter()
                            .enumerate()
                            .any(|(i, s)| !own.contains(&i) && crate::scene::ray_sphere(hit.x, v, s).is_some())
                    },
                    &hit,
                    spp * PRECISE_FACTOR,
                    MC_SEED ^ 0x9e37 ^ p as u64,
                )
                .finite(|| format!("the breakdown's sphere-set reference at pixel ({}, {})", p % w, p / w))?;
                v.push(on_spheres.mean);
            }
            if map {
                // Under the lobes fitted to the map, exact visibility: what the SG fit
                // alone leaves out is the rest.
                let lobes = reference(
                    &scene.environment,
                    &brdf,
                    |v| scene.occluded(&hit, v),
                    &hit,
                    spp * PRECISE_FACTOR,
                    MC_SEED ^ 0x9e37 ^ p as u64,
                )
                .finite(|| {
                    format!(
                        "the breakdown's reference under the lobes at pixel ({}, {})",
                        p % w,
                        p / w
                    )
                })?;
                v.push(lobes.mean);
            }
            v.extend([precise.mean, precise.std_error]);
            Ok(v)
        })
        .collect::<Result<_, String>>()?;
    let mut names = vec![
        "ISG model best (→ Gauss–Legendre patch integrals)",
        "binary patch occlusion (→ the covered part of each patch, 8 × 8 nodes at exact visibility)",
        "eq. 9 (→ every lighting SG times the BRDF SG)",
        "the BRDF as SGs (Phong: one; Cook–Torrance: warped), the limiting cone, patch resolution (→ the precise Monte Carlo reference)",
    ];
    if meshes {
        names[3] =
            "the BRDF as SGs (Phong: one; Cook–Torrance: warped), the limiting cone, patch resolution (→ the precise reference on the meshes' sphere sets)";
        names.push("sphere sets → true meshes (→ the precise reference with the triangles, same samples)");
    }
    if map {
        let last = names.len() - 1;
        names[last] = if meshes {
            "sphere sets → true meshes (→ the precise reference with the triangles, same samples, under the fitted lobes)"
        } else {
            "the BRDF as SGs (Phong: one; Cook–Torrance: warped), the limiting cone, patch resolution (→ the precise reference under the fitted lobes)"
        };
        names.push("the fitted lobes → the map itself (→ the precise reference under the map's texels)");
    }
    Ok((parts, names))
}
