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

use super::shade::{radiance, Blockers, Model, Patches, Phong, Settings, Specular, Tables};
use super::{reference, PIPELINE};
use crate::estimate::per_pixel;
use crate::image::{breakdown, compare, mean_over, noise_free_rel_rmse, write_comparison};
use crate::scene::{Hit, Scene};
use crate::timing::{timed, EqualError};
use crate::BASELINE_PLAIN;
use crate::{RenderOptions, Summary};

/// The breakdown subset's reference takes this many times the image's samples.
pub const PRECISE_FACTOR: usize = 64;

/// Seed of the reference's per-pixel samples.
pub const MC_SEED: u64 = 0x5eed_0012;

/// The scene `name`: built-in `isg-<name>`, else a scene file.
pub fn scene(name: &str) -> Result<Scene, String> {
    let scene = PIPELINE.scene(name)?;
    if scene.environment.is_empty() {
        return Err(format!(
            "scene {}: the ISG pipeline needs an environment (SGs)",
            scene.name
        ));
    }
    for m in &scene.materials {
        Phong::of(m).map_err(|e| format!("scene {}: {e}", scene.name))?;
    }
    Ok(scene)
}

/// The blockers of a hit: the scene's spheres and its meshes' sphere sets
/// ([`Scene::proxies`]) but the hit's own, through their BVH.
pub fn blockers_of<'a>(scene: &'a Scene, h: &Hit) -> Blockers<'a> {
    Blockers {
        spheres: &scene.proxies,
        bvh: Some(scene.proxy_bvh()),
        own: scene.own_proxies(h),
    }
}

/// The pipeline's radiance at every hit with `s` (0 for background).
fn image(t: &Tables, s: &Settings, scene: &Scene, hits: &[Option<Hit>]) -> Result<Vec<f64>, String> {
    hits.par_iter()
        .map(|h| match h {
            None => Ok(0.0),
            Some(h) => {
                let brdf = Phong::of(scene.brdf(h))?;
                radiance(t, s, &scene.environment, &brdf, &blockers_of(scene, h), h)
            }
        })
        .collect()
}

/// Sphere counts of the sweep (Table 1's range, 46 to 306 spheres).
pub const SWEEP: [usize; 4] = [46, 102, 204, 306];

/// The Figure 12 analogue with `count` spheres: seeded, non-overlapping, radius 0.12
/// to 0.35, over the same plane (named `sweep-<count>`).
pub fn sweep_scene(count: usize) -> Result<Scene, String> {
    let text = crate::scene::BUILTIN
        .iter()
        .find(|(n, _)| *n == "isg-fig12")
        .map(|(_, t)| *t)
        .ok_or("isg-fig12 is not built in")?;
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

/// Renders `scene` into `dir`.
fn render_scene(
    scene: &Scene,
    opts: &RenderOptions,
    dir: &Path,
    progress: &(dyn Fn() + Sync),
) -> Result<Summary, String> {
    let tag = scene.name.strip_prefix("isg-").unwrap_or(&scene.name).to_string();
    let (w, h) = (opts.width.max(4), (opts.width * 3 / 4).max(3));
    PIPELINE.check_work(scene, opts)?;
    let tables = Tables::embedded()?;
    let (hits, lit) = scene.primary_hits(w, h)?;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut sum = Summary::default();

    let (refs, t_ref) = timed(|| {
        per_pixel(
            &hits,
            w,
            |hit, p| {
                let brdf = Phong::of(scene.brdf(hit))?;
                Ok(reference(
                    &scene.environment,
                    &brdf,
                    |v| scene.occluded(hit, v),
                    hit,
                    opts.spp,
                    MC_SEED ^ p as u64,
                ))
            },
            progress,
        )
    });
    let refs = refs?;
    let reference_img: Vec<f64> = refs.iter().map(|r| r.mean).collect();
    let se: Vec<f64> = refs.iter().map(|r| r.std_error).collect();
    let mean_ref = mean_over(&reference_img, &lit);
    let ref_rel_se = mean_over(&se, &lit) / mean_ref;
    let pixels = lit.iter().filter(|&&l| l).count();
    sum.lines.push(format!(
        "{tag}: {w}×{h}, {pixels} lit pixels, {} spheres{}, {} lighting SGs; reference {} samples/pixel, standard error mean {:.2e} of the mean radiance {:.4}",
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
        opts.spp,
        ref_rel_se,
        mean_ref
    ));
    let default = Settings::default();
    let mut best = (Vec::new(), 0.0, 0.0);
    let mut model_imgs = Vec::new();
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
    for (k, (label, s)) in variants.iter().enumerate() {
        let (img, t) = timed(|| image(&tables, s, scene, &hits));
        let img = img?;
        let st = compare(&img, &reference_img, &lit);
        let nf = noise_free_rel_rmse(&img, &reference_img, &se, &lit);
        sum.lines.push(format!(
            "{tag}: {label:<18} (adaptive patches, ε = 0.01, binary): relative RMSE {:.4} ({nf:.4} without the reference's noise), p99 {:.4}, max {:.4}; {:.2} µs/pixel",
            st.rel_rmse,
            st.p99,
            st.max,
            1e6 * t / pixels as f64
        ));
        model_imgs.push((label.clone(), img.clone()));
        if k == 2 {
            best = (img, t, nf);
        }
    }
    let (best_img, t_best, _) = best;
    for (label, patches) in [("100", Patches::Grid(10)), ("400", Patches::Grid(20))] {
        let s = Settings { patches, ..default };
        let img = image(&tables, &s, scene, &hits)?;
        let st = compare(&img, &reference_img, &lit);
        sum.lines.push(format!(
            "{tag}: model best, {label} patches: relative RMSE {:.4} ({:.4} without the reference's noise), p99 {:.4}, max {:.4}",
            st.rel_rmse,
            noise_free_rel_rmse(&img, &reference_img, &se, &lit),
            st.p99,
            st.max
        ));
    }
    // The breakdown on a strided subset: each approximation made exact in turn.
    let stride = opts.breakdown_stride.max(1);
    let picks: Vec<usize> = (0..h)
        .step_by(stride)
        .flat_map(|j| (0..w).step_by(stride).map(move |i| j * w + i))
        .filter(|&p| lit[p])
        .collect();
    // From the paper's configuration (best model, binary, eq. 9).
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
    let at = stages.len() + usize::from(meshes);
    let parts: Vec<Vec<f64>> = picks
        .par_iter()
        .map(|&p| {
            let hit = hits[p].expect("lit");
            let brdf = Phong::of(scene.brdf(&hit))?;
            let blockers = blockers_of(scene, &hit);
            let mut v = stages
                .iter()
                .map(|s| radiance(&tables, s, &scene.environment, &brdf, &blockers, &hit))
                .collect::<Result<Vec<f64>, String>>()?;
            // A reference with PRECISE_FACTOR × the samples: the subset's errors are
            // measured against it (its noise far below the pipeline's error).
            let precise = reference(
                &scene.environment,
                &brdf,
                |v| scene.occluded(&hit, v),
                &hit,
                opts.spp * PRECISE_FACTOR,
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
                    opts.spp * PRECISE_FACTOR,
                    MC_SEED ^ 0x9e37 ^ p as u64,
                )
                .finite(|| format!("the breakdown's sphere-set reference at pixel ({}, {})", p % w, p / w))?;
                v.push(on_spheres.mean);
            }
            v.extend([precise.mean, precise.std_error]);
            Ok(v)
        })
        .collect::<Result<_, String>>()?;
    // The subset against the precise reference, per model, its noise taken out.
    let sub_mask = vec![true; picks.len()];
    let precise: Vec<f64> = parts.iter().map(|p| p[at]).collect();
    let precise_se: Vec<f64> = parts.iter().map(|p| p[at + 1]).collect();
    let mean_sub = mean_over(&precise, &sub_mask);
    sum.lines.push(format!(
        "{tag}: on {} pixels (every {}th) against a reference of {} samples (standard error mean {:.2e} of the mean):",
        picks.len(),
        opts.breakdown_stride.max(1),
        opts.spp * PRECISE_FACTOR,
        mean_over(&precise_se, &sub_mask) / mean_sub
    ));
    let mut rmse_best = f64::NAN;
    for (k, (label, img)) in model_imgs.iter().enumerate() {
        let v: Vec<f64> = picks.iter().map(|&p| img[p]).collect();
        let st = compare(&v, &precise, &sub_mask);
        let nf = noise_free_rel_rmse(&v, &precise, &precise_se, &sub_mask);
        if k == 2 {
            // The raw RMSE: an upper bound of the error (the reference's noise in it),
            // so the equal-error ratio below is a lower bound.
            rmse_best = st.rel_rmse;
        }
        sum.lines.push(format!(
            "{tag}:   {label:<18}: relative RMSE {:.4} ({nf:.4} without the reference's noise), p99 {:.4}, max {:.4}",
            st.rel_rmse, st.p99, st.max
        ));
    }
    let mut names = vec![
        "ISG model best (→ Gauss–Legendre patch integrals)",
        "binary patch occlusion (→ the covered part of each patch, 8 × 8 nodes at exact visibility)",
        "eq. 9 (→ every lighting SG times the BRDF SG)",
        "Phong as one SG, the limiting cone, patch resolution (→ the precise Monte Carlo reference)",
    ];
    if meshes {
        names[3] =
            "Phong as one SG, the limiting cone, patch resolution (→ the precise reference on the meshes' sphere sets)";
        names.push("sphere sets → true meshes (→ the precise reference with the triangles, same samples)");
    }
    sum.lines.extend(breakdown(
        &tag,
        "the paper's configuration (best model, binary, eq. 9)",
        &names,
        &parts,
        mean_sub,
        stride,
    ));

    let eq = EqualError::from_estimates(t_best, t_ref, &refs, &lit, opts.spp, rmse_best * mean_ref);
    sum.lines.push(format!(
        "{tag}: time per pixel: ISG (best) {:.2} µs; reference {:.3} µs per sample, {:.0} samples for the ISG's RMSE against the precise reference → {:.0} µs; ratio reference/ISG {:.0} (at least: that RMSE includes the precise reference's noise; one run, same process, the same BVH; plain Monte Carlo extrapolated σ²/ε², a weak baseline: docs/pipelines.md, Stronger baselines)",
        1e6 * eq.pipeline_per_pixel,
        1e6 * eq.reference_per_sample,
        eq.samples,
        1e6 * eq.reference_per_pixel,
        eq.ratio
    ));

    let (files, _) = write_comparison(
        dir,
        &format!("isg-{tag}"),
        [
            &format!("{tag}: ISG pipeline (best model)"),
            &format!("{tag}: Monte Carlo reference ({} spp)", opts.spp),
        ],
        "isg",
        (w, h),
        &best_img,
        &reference_img,
        &lit,
        mean_ref,
    )?;
    sum.files.extend(files);
    sum.rel_rmse = rmse_best;
    sum.ref_rel_se = ref_rel_se;
    sum.headline.push(
        crate::Headline {
            render: format!("isg {tag}"),
            scope: format!("{w}×{h}"),
            method: "ISG (best model)".into(),
            error: format!(
                "relative RMSE {rmse_best:.4} against a {}-sample reference on {} pixels",
                opts.spp * PRECISE_FACTOR,
                picks.len()
            ),
            cost_us: 1e6 * eq.pipeline_per_pixel,
            unit: "px".into(),
            baseline: BASELINE_PLAIN.into(),
            baseline_us: 1e6 * eq.reference_per_pixel,
        }
        .line(),
    );
    sum.write(dir, &format!("isg-{tag}"))?;
    Ok(sum)
}
