//! `lobefit render meunier`: the paper's Figure 13 scene (spheres over a plane, one
//! spherical light, diffuse) and a glossy Lafortune variant (Figure 14's kind),
//! rendered by the lobe pipeline and by a Monte Carlo reference with exact
//! visibility and light sampling, with the error images, the Figure 10 matrix, shadow
//! profiles and the error breakdown of docs/meunier.md.
//!
//! Only the shading is compared: primary visibility (which surface a pixel sees) is
//! ray traced exactly and shared. The reference samples the light's cap uniformly in
//! solid angle ([`MC_SEED`]-seeded per pixel, so it does not depend on the thread
//! count) and reports its own standard error.

use std::f64::consts::{PI, TAU};
use std::path::Path;

use lobefit_tables::geom::SphereLight;
use lobefit_tables::glam::DVec3;
use lobefit_tables::mask_weights::{build_mask, Cap, MaskCell, MaskMode, WeightSet};
use lobefit_tables::meunier::{LightModel, MaskSettings, Visibility};
use lobefit_tables::{CapExponent, Lobe, LobeProduct, MaskWeights, Meunier};
use rayon::prelude::*;

use super::light_fit;
use crate::estimate::{estimate, estimate_with, Estimate, Sampling};
use crate::image::{compare, masked, panel};
use crate::render::{shade_image, Frame, Reference, Strongest};
use crate::scene::{brdf_value, visible, Hit, Scene};
use crate::timing::timed;
use crate::{RenderOptions, Summary};
use lobefit_core::plot::{heatmaps, line_chart, LineChart, Series};

/// Seed of the reference's per-pixel light samples.
pub const MC_SEED: u64 = 0x5eed_0013;

/// Reference radiance at a hit: `n` light samples uniform in the light's cap, with
/// exact ray–sphere visibility through the scene's BVH.
pub fn reference(scene: &Scene, light: &SphereLight, h: &Hit, n: usize, seed: u64) -> Estimate {
    reference_with(scene, light, h, n, seed, true)
}

/// [`reference`], its visibility through the scene's BVH (`bvh`) or by testing every
/// sphere (the same answers, another cost).
pub fn reference_with(scene: &Scene, light: &SphereLight, h: &Hit, n: usize, seed: u64, bvh: bool) -> Estimate {
    reference_sampled(Sampling::Plain, scene, light, h, n, seed, bvh)
}

/// [`reference_with`] with the uniforms of `sampling` (dimension 0 the cap's cos θ,
/// dimension 1 its azimuth); `Plain` draws the very numbers [`reference_with`] did.
pub fn reference_sampled(
    sampling: Sampling,
    scene: &Scene,
    light: &SphereLight,
    h: &Hit,
    n: usize,
    seed: u64,
    bvh: bool,
) -> Estimate {
    let to = light.sphere.centre - h.x;
    let d = to.length();
    let w = to / d;
    let cos_a = (1.0 - (light.sphere.radius / d).powi(2)).sqrt();
    let omega = TAU * (1.0 - cos_a);
    let (u, v) = w.any_orthonormal_pair();
    let brdf = scene.brdf(h);
    let blockers = if bvh { Vec::new() } else { scene.blockers(h) };
    estimate_with(sampling, n, seed, |rng| {
        let mu = 1.0 - rng.uniform() * (1.0 - cos_a);
        let phi = rng.range(0.0, TAU);
        let st = (1.0 - mu * mu).max(0.0).sqrt();
        let dir = mu * w + st * (phi.cos() * u + phi.sin() * v);
        let c = h.n.dot(dir);
        let lit = || {
            if bvh {
                scene.light_visible(h, dir, &light.sphere)
            } else {
                visible(h.x, dir, &light.sphere, &blockers)
            }
        };
        if c > 0.0 && lit() {
            brdf_value(brdf, h, dir) * light.radiance * c * omega
        } else {
            0.0
        }
    })
}

/// The scene `name`: a built-in of the pipeline (`fig13`, `glossy`) or a scene file;
/// refused when it holds what the pipeline does not shade (a height field, distant
/// light).
pub fn scene(name: &str) -> Result<Scene, String> {
    super::PIPELINE.scene(name)
}

/// Whether `x` lies inside one of `blockers`: only a mesh's sphere set can bury a
/// visible point (the camera sees a sphere's surface before anything inside it), e.g.
/// a plane point under a covering sphere that reaches below the ground. The proxy is
/// a solid, so such a point is in its full shadow; the runtime refuses the point
/// instead (its domain is points outside every blocker), so the render answers 0.
fn buried(blockers: &[crate::scene::Sphere], x: DVec3) -> bool {
    blockers.iter().any(|b| (x - b.centre).length() <= b.radius)
}

/// The lobes' radiance at `h` with `settings` (0 where [`buried`]).
fn lobes_at(
    m: &Meunier<'_>,
    scene: &Scene,
    light: &SphereLight,
    h: &Hit,
    settings: &MaskSettings,
) -> Result<f64, String> {
    let blockers = scene.blockers(h);
    if buried(&blockers, h.x) {
        return Ok(0.0);
    }
    m.radiance(h.x, h.n, h.t, h.wo, scene.brdf(h), &[*light], &blockers, settings)
        .map_err(|e| e.to_string())
}

/// The lobe pipeline over the whole image with `settings`; `None` for background.
fn lobe_image(
    m: &Meunier<'_>,
    scene: &Scene,
    light: &SphereLight,
    hits: &[Option<Hit>],
    settings: &MaskSettings,
) -> Result<Vec<f64>, String> {
    shade_image(hits, |_, h| lobes_at(m, scene, light, h, settings))
}

/// The scene's one light and the embedded tables; `command` and `what` (what takes
/// one light) name a scene with another number of lights in the error.
fn setup(scene: &Scene, command: &str, what: &str) -> Result<(SphereLight, Meunier<'static>), String> {
    let light = match scene.lights[..] {
        [l] => l,
        _ => {
            return Err(format!(
                "{command}: scene {} has {} lights; {what} takes one",
                scene.name,
                scene.lights.len()
            ))
        }
    };
    let m = Meunier {
        products: LobeProduct::embedded().map_err(|e| e.to_string())?,
        caps: CapExponent::embedded().map_err(|e| e.to_string())?,
        weights: MaskWeights::embedded().map_err(|e| e.to_string())?,
    };
    Ok((light, m))
}

/// Renders the animated scene `name` ([`crate::animate`]): the lobes with the default
/// settings against the reference sampling the light's cap with Owen-scrambled Sobol
/// points (`qmc`, the strongest estimator on Meunier's scenes in the baselines study),
/// at `--spp` for the reference and at the lobes' time.
pub fn animate(
    name: &str,
    opts: &RenderOptions,
    frames: usize,
    dir: &Path,
    progress: &(dyn Fn() + Sync),
) -> Result<Summary, String> {
    let scene = scene(name)?;
    let (light, m) = setup(&scene, "render meunier --frames", "an animation")?;
    let settings = MaskSettings::default();
    let shade = |s: &Scene, hits: &[Option<Hit>]| lobe_image(&m, s, &light, hits, &settings);
    let estimate =
        |s: &Scene, h: &Hit, n: usize, seed: u64| Ok(reference_sampled(Sampling::Qmc, s, &light, h, n, seed, true));
    let methods = crate::animate::Methods {
        method: "lobes (default settings)",
        shade: &shade,
        strongest: "qmc",
        estimate: &estimate,
    };
    crate::animate::animate(&super::PIPELINE, &scene, opts, frames, dir, progress, &methods)
}

/// The thresholds t_i (sr) `render meunier` sweeps; the paper's is 0.001.
pub const THRESHOLDS: [f64; 5] = [0.0, 1e-5, 1e-4, 1e-3, 1e-2];

/// How many lobe products survive the threshold at one hit: the final stage (× the
/// cosine) of eq. 22's triple products as [`Meunier::shade`] forms them.
fn products_kept(
    m: &Meunier<'_>,
    scene: &Scene,
    light: &SphereLight,
    h: &Hit,
    s: &MaskSettings,
) -> Result<usize, String> {
    let err = |e: lobefit_tables::LookupError| e.to_string();
    let brdf = scene.brdf(h).lobes(h.n, h.t, h.wo).map_err(|e| e.to_string())?;
    if scene.buried(h) {
        return Ok(0);
    }
    let blockers = scene.blockers(h);
    let vis = m.visibility(h.x, h.n, light, &blockers, s).map_err(|e| e.to_string())?;
    if vis.fully_blocked {
        return Ok(0);
    }
    let (lobe, _) = m.light_lobe(h.x, light).map_err(|e| e.to_string())?;
    let cosine = [Lobe {
        scale: 1.0,
        axis: h.n,
        exponent: 1.0,
    }];
    if s.light == LightModel::Cap {
        // Each BRDF lobe × the cosine (the unoccluded term, never thresholded), times
        // the radiance, then one product with each shadow leaf.
        let lit: Vec<Lobe> = m
            .products
            .product_sums(&brdf, &cosine, 0.0)
            .map_err(err)?
            .into_iter()
            .map(|p| Lobe {
                scale: light.radiance * p.scale,
                ..p
            })
            .filter(|p| p.integral().abs() >= s.threshold)
            .collect();
        let mut kept = 0;
        for p in &lit {
            for leaf in &vis.lobes {
                let v = m.leaf_product(p, leaf, s).map_err(|e| e.to_string())?;
                kept += usize::from(v != 0.0 && v.abs() >= s.threshold);
            }
        }
        return Ok(kept + brdf.len());
    }
    let bl = m.products.product_sums(&brdf, &[lobe], s.threshold).map_err(err)?;
    let blv = m.products.product_sums(&bl, &vis.lobes, s.threshold).map_err(err)?;
    Ok(m.products.product_sums(&blv, &cosine, s.threshold).map_err(err)?.len())
}

/// What [`breakdown`] returns at one hit, each by the same product rule.
#[derive(Debug, Clone, Copy)]
struct Parts {
    /// The settings' light model with every lobe integrated exactly (E1).
    model: f64,
    /// The light's cap, with the leaf lobes (E2), the leaves' bounding caps (E3), the
    /// union of the leaf cells (E4), exact visibility of the blockers (E5: the spheres
    /// and the meshes' sphere sets), exact visibility of the true scene (E6: the
    /// meshes' triangles; equal to E5 without meshes).
    exact: [f64; 5],
    /// The studied fitted coaxial lobes (1..=3 per light) with the leaf lobes (0 unless
    /// the settings' light is the paper's lobe).
    fitted: [f64; light_fit::MAX_LOBES],
}

/// The error breakdown at one hit, switching one approximation to exact at a time:
/// the lobe algebra (E1: quadrature of the same lobe sums), the light (E2: the light's
/// cap instead, still with the leaf lobes), the leaf cap → lobe fit (E3: each leaf's
/// bounding cap itself, same weights), the weights (E4: the union of the leaf cells,
/// where no overlap needs correcting), the mask's depth and aggressive choice (E5:
/// exact ray–sphere visibility, the reference), all by one product rule
/// (Gauss–Legendre in θ split at the cap's edge, uniform in φ) about the light's axis.
fn breakdown(
    m: &Meunier<'_>,
    scene: &Scene,
    light: &SphereLight,
    h: &Hit,
    settings: &MaskSettings,
) -> Result<Parts, String> {
    let blockers = scene.blockers(h);
    let brdf = scene.brdf(h);
    let (llobe, lcap) = m.light_lobe(h.x, light).map_err(|e| e.to_string())?;
    let lobe_settings = MaskSettings {
        light: LightModel::Lobe,
        ..*settings
    };
    // A buried point: no mask (the runtime refuses it), every estimate but the true
    // scene's is 0 (as when fully blocked).
    let is_buried = scene.buried(h);
    let (blockers, vis, vis_model) = if is_buried {
        let none = || Visibility {
            lobes: Vec::new(),
            dist: 0.0,
            fully_blocked: true,
            leaves: 0,
        };
        (Vec::new(), none(), none())
    } else {
        let vis = m
            .visibility(h.x, h.n, light, &blockers, &lobe_settings)
            .map_err(|e| e.to_string())?;
        let vis_model = m
            .visibility(h.x, h.n, light, &blockers, settings)
            .map_err(|e| e.to_string())?;
        (blockers, vis, vis_model)
    };
    // The studied lobes are reported beside the paper's light only: fit them there.
    let fitted: Vec<Vec<(f64, f64)>> = if settings.light == LightModel::Lobe {
        (1..=light_fit::MAX_LOBES)
            .map(|k| light_fit::fit(m.caps, lcap.half_angle, k))
            .collect::<Result<_, _>>()?
    } else {
        Vec::new()
    };
    let (leaves, bounding) = leaf_caps(m, h, light, lcap, &blockers, settings)?;
    // Rule: Gauss–Legendre in θ on [0, α] and [α, θ_max] (θ_max where the light lobe
    // falls below 1e-9 of its peak), uniform in φ.
    let alpha = lcap.half_angle;
    let theta_max = ((1e-9f64).ln() / llobe.exponent.max(1e-3))
        .exp()
        .clamp(-1.0, 1.0)
        .acos()
        .max(alpha * 1.001)
        .min(PI / 2.0 + alpha);
    let (gx, gw) = lobefit_core::sh::gauss_legendre(48);
    let nphi = 160;
    let (u, v) = lcap.axis.any_orthonormal_pair();
    let mut out = Parts {
        model: 0.0,
        exact: [0.0; 5],
        fitted: [0.0; light_fit::MAX_LOBES],
    };
    let meshes = !scene.meshes.is_empty();
    // Fully blocked: every estimate but the exact ones sees no light (the runtime's
    // short cut) and the exact one on the blockers (E5) is 0 too; only the true
    // scene's (E6) may not be, where there are meshes.
    let blocked = vis.fully_blocked || is_buried;
    if blocked && !meshes {
        return Ok(out);
    }
    let big_l = light.radiance;
    for (lo, hi) in [(0.0, alpha), (alpha, theta_max)] {
        for (x, wx) in gx.iter().zip(&gw) {
            let th = lo + 0.5 * (hi - lo) * (x + 1.0);
            let (st, ct) = th.sin_cos();
            let wt = 0.5 * (hi - lo) * wx * st * TAU / nphi as f64;
            let inside = th <= alpha;
            let profiles: Vec<f64> = fitted.iter().map(|f| big_l * light_fit::eval(f, th)).collect();
            for k in 0..nphi {
                let phi = TAU * (k as f64 + 0.5) / nphi as f64;
                let dir = ct * lcap.axis + st * (phi.cos() * u + phi.sin() * v);
                let c = h.n.dot(dir);
                if c <= 0.0 {
                    continue;
                }
                let b = brdf_value(brdf, h, dir);
                let f = b * c * wt;
                if f == 0.0 {
                    continue;
                }
                if blocked {
                    if inside && scene.light_visible(h, dir, &light.sphere) {
                        out.exact[4] += f * big_l;
                    }
                    continue;
                }
                let v_lobes: f64 = vis.lobes.iter().map(|l: &Lobe| l.eval(dir)).sum();
                out.model += match settings.light {
                    LightModel::Lobe => f * llobe.eval(dir) * v_lobes,
                    LightModel::Cap => {
                        // The runtime's split: the unoccluded light is the cap, the
                        // leaves (their share inside the cap folded in) darken the
                        // uniform light.
                        let shadow: f64 = vis_model.lobes.iter().map(|l: &Lobe| l.eval(dir)).sum();
                        f * big_l * (f64::from(u8::from(inside)) + shadow)
                    }
                };
                for (o, p) in out.fitted.iter_mut().zip(&profiles) {
                    *o += f * p * v_lobes;
                }
                if inside {
                    let l = f * big_l;
                    out.exact[0] += l * v_lobes;
                    let v_caps: f64 = 1.0
                        - bounding
                            .iter()
                            .filter(|(a, c, _)| a.dot(dir) >= *c)
                            .map(|(_, _, wd)| wd)
                            .sum::<f64>();
                    out.exact[1] += l * v_caps;
                    if !leaves.iter().any(|c| c.contains(dir)) {
                        out.exact[2] += l;
                    }
                    let proxies = visible(h.x, dir, &light.sphere, &blockers);
                    if proxies {
                        out.exact[3] += l;
                    }
                    if (meshes && scene.light_visible(h, dir, &light.sphere)) || (!meshes && proxies) {
                        out.exact[4] += l;
                    }
                }
            }
        }
    }
    Ok(out)
}

/// The mask of the light's cap `lcap` under the blockers nearer than the light, at
/// `settings`' depth and mode: its leaf cells, and each leaf's bounding cap as (axis,
/// cos half-angle, weight) with the settings' weights.
#[allow(clippy::type_complexity)]
fn leaf_caps(
    m: &Meunier<'_>,
    h: &Hit,
    light: &SphereLight,
    lcap: Cap,
    blockers: &[crate::scene::Sphere],
    settings: &MaskSettings,
) -> Result<(Vec<MaskCell>, Vec<(DVec3, f64, f64)>), String> {
    let light_dist = (light.sphere.centre - h.x).length();
    let caps: Vec<Cap> = blockers
        .iter()
        .filter(|b| (b.centre - h.x).length() - b.radius < light_dist)
        .map(|b| {
            let to = b.centre - h.x;
            let d = to.length();
            Cap {
                axis: to / d,
                half_angle: (b.radius / d).asin(),
            }
        })
        .collect();
    let mask = build_mask(lcap, &caps, settings.depth).map_err(|e| e.to_string())?;
    let leaves: Vec<MaskCell> = mask.leaves(settings.depth, settings.mode).cloned().collect();
    let mut w = [0.0; lobefit_tables::mask_weights::MAX_DEPTH as usize];
    m.weights
        .weights(settings.weights, settings.mode, settings.depth, mask.dist, &mut w)
        .map_err(|e| e.to_string())?;
    // Each leaf's bounding cap as (axis, cos half-angle, weight).
    let bounding: Vec<(DVec3, f64, f64)> = leaves
        .iter()
        .map(|c| (c.axis, c.half_angle.cos(), w[c.depth.max(1) as usize - 1]))
        .collect();
    Ok((leaves, bounding))
}

/// Renders the scene `name` (a built-in, [`super::PIPELINE`]'s `scenes`, or a scene
/// file's path) and writes its figures into `dir`. `progress` is called once per
/// finished image row of the reference. The skeleton ([`crate::render`]) filled in
/// with the light models × weight sets, the thresholds, Figure 10, the shadow profile
/// and the breakdown.
pub fn render(name: &str, opts: &RenderOptions, dir: &Path, progress: &(dyn Fn() + Sync)) -> Result<Summary, String> {
    let scene = scene(name)?;
    let (light, m) = setup(&scene, "render meunier", "the error breakdown")?;
    let (f, ()) = Frame::new(&super::PIPELINE, &scene, opts, dir, || Ok(()))?;
    let tag = f.tag.clone();
    let mut sum = Summary::default();
    let r = image_reference(&f, &light, progress)?;
    let max_se =
        r.se.iter()
            .zip(&f.lit)
            .filter(|(_, &l)| l)
            .map(|(s, _)| *s)
            .fold(0.0, f64::max)
            / r.mean;
    let default = MaskSettings::default();
    sum.lines.push(format!(
        "{tag}: {}×{}, {} lit pixels; reference {} light samples/pixel, standard error mean {:.2e}, max {:.2e} (of the mean radiance {:.4})",
        f.w, f.h, f.pixels, opts.spp, r.rel_se, max_se, r.mean
    ));
    let (lobes, t_lobe, rmse_default) = light_models(&f, &m, &light, &r, &mut sum.lines)?;
    let eq = r.equal_error(&f, t_lobe, rmse_default);
    sum.lines.push(format!(
        "{tag}: shading time per pixel (default light {}): lobes {:.2} µs; reference {:.3} µs per sample, {:.1} samples for the lobes' RMSE → {:.2} µs; ratio reference/lobes {:.2} (one run, same process; plain Monte Carlo extrapolated σ²/ε², a weak baseline: docs/pipelines.md, Stronger baselines)",
        default.light.name(),
        1e6 * eq.pipeline_per_pixel,
        1e6 * eq.reference_per_sample,
        eq.samples,
        1e6 * eq.reference_per_pixel,
        eq.ratio
    ));
    thresholds(&f, &m, &light, &r, &mut sum.lines)?;

    // Images: PNG panels, and the float images for other tools.
    let titles = [
        format!("{tag}: lobe pipeline (depth 5, fitted)"),
        format!("{tag}: Monte Carlo reference ({} spp)", opts.spp),
    ];
    f.write_images(&mut sum, [&titles[0], &titles[1]], "lobes", &lobes, &r)?;
    figure10(&f, &m, &light, &r, &mut sum)?;
    sum.files.push(profile(&f, &m, &light, &r, &lobes)?);
    breakdown_lines(&f, &m, &light, &r, &mut sum.lines)?;
    let error = format!(
        "relative RMSE {rmse_default:.4} against the {}-sample reference on {} pixels",
        opts.spp, f.pixels
    );
    let method = format!("lobes (light {}, depth 5, fitted weights)", default.light.name());
    let scene = f.scene;
    let estimate = |h: &Hit, n: usize, seed: u64| Ok(reference_sampled(Sampling::Qmc, scene, &light, h, n, seed, true));
    let shade = |hits: &[Option<Hit>]| lobe_image(&m, scene, &light, hits, &default);
    let strongest = Strongest {
        name: "qmc",
        estimate: &estimate,
        method: &shade,
    };
    f.finish(sum, &r, rmse_default, method, error, &strongest)
}

/// The image's reference (row by row for the progress bar), timed.
fn image_reference(f: &Frame<'_>, light: &SphereLight, progress: &(dyn Fn() + Sync)) -> Result<Reference, String> {
    let (w, h, hits, scene) = (f.w, f.h, &f.hits, f.scene);
    let (refs, t_ref) = timed(|| -> Vec<Estimate> {
        (0..h)
            .into_par_iter()
            .flat_map_iter(|j| {
                let row: Vec<Estimate> = (0..w)
                    .map(|i| match &hits[j * w + i] {
                        None => estimate(0, 0, |_| 0.0),
                        Some(hit) => reference(scene, light, hit, f.opts.spp, MC_SEED ^ (j * w + i) as u64),
                    })
                    .collect();
                progress();
                row
            })
            .collect()
    });
    for (p, r) in refs.iter().enumerate() {
        r.finite(|| format!("scene {}: the reference at pixel ({}, {})", scene.name, p % w, p / w))?;
    }
    Ok(Reference::new(f, refs, t_ref))
}

/// The lobe pipeline: both light models × three weight sets, each light's default
/// weights timed (a line each in `lines`). Returns the default light's image, time (s)
/// and relative RMSE.
fn light_models(
    f: &Frame<'_>,
    m: &Meunier<'_>,
    light: &SphereLight,
    r: &Reference,
    lines: &mut Vec<String>,
) -> Result<(Vec<f64>, f64, f64), String> {
    let (tag, scene, hits) = (&f.tag, f.scene, &f.hits);
    let default = MaskSettings::default();
    let mut lobes = Vec::new();
    let mut t_lobe = 0.0;
    let mut rmse_default = f64::NAN;
    for light_model in LightModel::ALL {
        let base = MaskSettings {
            light: light_model,
            ..default
        };
        let (img, t) = timed(|| lobe_image(m, scene, light, hits, &base));
        let img = img?;
        let st = compare(&img, &r.img, &f.lit);
        let eq = r.equal_error(f, t, st.rel_rmse);
        lines.push(format!(
            "{tag}: light {}: shading time per pixel {:.2} µs; the reference reaches its RMSE with {:.1} samples → {:.2} µs; ratio reference/lobes {:.2} (one run, same process; plain Monte Carlo extrapolated σ²/ε², a weak baseline: docs/pipelines.md, Stronger baselines)",
            light_model.name(),
            1e6 * eq.pipeline_per_pixel,
            eq.samples,
            1e6 * eq.reference_per_pixel,
            eq.ratio
        ));
        for set in [WeightSet::Fitted, WeightSet::Paper, WeightSet::Ones] {
            let s = MaskSettings { weights: set, ..base };
            let other = if set == WeightSet::Fitted {
                None
            } else {
                Some(lobe_image(m, scene, light, hits, &s)?)
            };
            let st = compare(other.as_ref().unwrap_or(&img), &r.img, &f.lit);
            lines.push(format!(
                "{tag}: light {} weights {:<6} depth 5 aggressive: relative RMSE {:.4}, p99 {:.4}, max {:.4}",
                light_model.name(),
                set.name(),
                st.rel_rmse,
                st.p99,
                st.max
            ));
        }
        if light_model == default.light {
            rmse_default = st.rel_rmse;
            t_lobe = t;
            lobes = img;
        }
    }
    Ok((lobes, t_lobe, rmse_default))
}

/// The threshold t_i (§5.4): products kept, time and error, per light model (a line
/// each in `lines`).
fn thresholds(
    f: &Frame<'_>,
    m: &Meunier<'_>,
    light: &SphereLight,
    r: &Reference,
    lines: &mut Vec<String>,
) -> Result<(), String> {
    let (scene, hits) = (f.scene, &f.hits);
    for light_model in LightModel::ALL {
        for t in THRESHOLDS {
            let s = MaskSettings {
                light: light_model,
                threshold: t,
                ..MaskSettings::default()
            };
            let (img, secs) = timed(|| lobe_image(m, scene, light, hits, &s));
            let st = compare(&img?, &r.img, &f.lit);
            let kept: Vec<usize> = hits
                .par_iter()
                .flatten()
                .map(|h| products_kept(m, scene, light, h, &s))
                .collect::<Result<_, String>>()?;
            lines.push(format!(
                "{}: light {} t_i {t:.0e}: products kept per pixel {:.1}, shading {:.2} µs/pixel, relative RMSE {:.4}",
                f.tag,
                light_model.name(),
                kept.iter().sum::<usize>() as f64 / f.pixels as f64,
                1e6 * secs / f.pixels as f64,
                st.rel_rmse
            ));
        }
    }
    Ok(())
}

/// Figure 10: aggressive and conservative × depth 2, 3, 5 (a line each and the
/// panels' file in `sum`).
fn figure10(
    f: &Frame<'_>,
    m: &Meunier<'_>,
    light: &SphereLight,
    r: &Reference,
    sum: &mut Summary,
) -> Result<(), String> {
    let (w, h) = (f.w, f.h);
    let mut fig10 = Vec::new();
    for mode in MaskMode::ALL {
        for depth in [2, 3, 5] {
            let s = MaskSettings {
                depth,
                mode,
                ..MaskSettings::default()
            };
            let img = lobe_image(m, f.scene, light, &f.hits, &s)?;
            let st = compare(&img, &r.img, &f.lit);
            sum.lines.push(format!(
                "{}: Figure 10 {} depth {depth}: relative RMSE {:.4}",
                f.tag,
                mode.name(),
                st.rel_rmse
            ));
            fig10.push(panel(
                format!("{} depth {depth}", mode.name()),
                w,
                h,
                &masked(&img, &f.lit),
                "radiance",
            ));
        }
    }
    sum.files
        .push(heatmaps(&f.dir.join(format!("{}-figure10.png", f.stem())), &fig10, 3)?);
    Ok(())
}

/// The shadow profile: radiance along the image row through the deepest shadow on the
/// plane (the lobes' largest error there), for the lobes' weight sets and the
/// reference. Returns the chart's file.
fn profile(
    f: &Frame<'_>,
    m: &Meunier<'_>,
    light: &SphereLight,
    r: &Reference,
    lobes: &[f64],
) -> Result<std::path::PathBuf, String> {
    let (w, h, hits, tag) = (f.w, f.h, &f.hits, &f.tag);
    let row = (0..h)
        .max_by(|&a, &b| {
            let shade = |j: usize| -> f64 {
                (0..w)
                    .filter(|&i| hits[j * w + i].is_some_and(|x| x.sphere.is_none()))
                    .map(|i| (lobes[j * w + i] - r.img[j * w + i]).abs())
                    .sum()
            };
            shade(a).total_cmp(&shade(b))
        })
        .unwrap_or(0);
    let line = |v: &[f64]| -> Vec<(f64, f64)> {
        (0..w)
            .filter(|&i| hits[row * w + i].is_some())
            .map(|i| (i as f64, v[row * w + i]))
            .collect()
    };
    let mut series = vec![
        Series {
            name: "lobes, fitted".into(),
            points: line(lobes),
        },
        Series {
            name: format!("reference ({} spp)", f.opts.spp),
            points: line(&r.img),
        },
    ];
    for set in [WeightSet::Paper, WeightSet::Ones] {
        let s = MaskSettings {
            weights: set,
            ..MaskSettings::default()
        };
        let row_hits: Vec<Option<Hit>> = (0..w).map(|i| hits[row * w + i]).collect();
        let img = lobe_image(m, f.scene, light, &row_hits, &s)?;
        series.push(Series {
            name: format!("lobes, {}", set.name()),
            points: (0..w)
                .filter(|&i| row_hits[i].is_some())
                .map(|i| (i as f64, img[i]))
                .collect(),
        });
    }
    line_chart(
        &f.dir.join(format!("{}-profile.png", f.stem())),
        &LineChart {
            title: format!("{tag}: radiance along image row {row} (through the penumbrae)"),
            x_label: "pixel x".into(),
            y_label: "radiance".into(),
            log_x: false,
            log_y: false,
            series,
        },
    )
}

/// The breakdown on [`Frame::picks`], for each light model, by quadrature (not Monte
/// Carlo): each approximation switched to exact in turn, the studied fitted lobes, the
/// weight sets under the light's exact cap, and the quadrature against the reference
/// (lines in `lines`).
fn breakdown_lines(
    f: &Frame<'_>,
    m: &Meunier<'_>,
    light: &SphereLight,
    r: &Reference,
    lines: &mut Vec<String>,
) -> Result<(), String> {
    let (tag, scene, hits, mean_ref) = (&f.tag, f.scene, &f.hits, r.mean);
    let default = MaskSettings::default();
    let picks = f.picks();
    let rms_of = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt() / mean_ref;
    let mut parts: Vec<Parts> = Vec::new();
    for light_model in LightModel::ALL {
        let run = light_breakdown(f, m, light, mean_ref, &picks, light_model, lines)?;
        if light_model == default.light {
            parts = run;
        }
    }
    // The mask's lobes under the light's exact cap (E2 − E5), for each weight set: what
    // the weights do once the light's own error is out of the way.
    let mut per_set = vec![(
        WeightSet::Fitted,
        rms_of(&parts.iter().map(|p| p.exact[0] - p.exact[3]).collect::<Vec<_>>()),
    )];
    for set in [WeightSet::Paper, WeightSet::Ones] {
        let s = MaskSettings {
            weights: set,
            ..default
        };
        let d: Vec<f64> = picks
            .par_iter()
            .map(|&p| {
                let b = breakdown(m, scene, light, &hits[p].expect("lit"), &s)?;
                Ok(b.exact[0] - b.exact[3])
            })
            .collect::<Result<_, String>>()?;
        per_set.push((set, rms_of(&d)));
    }
    lines.push(format!(
        "{tag}:   with the light's exact cap, the mask's lobes against exact visibility (RMS): {}",
        per_set
            .iter()
            .map(|(s, r)| format!("{} {r:.4}", s.name()))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    let quad_vs_mc = (picks
        .iter()
        .zip(&parts)
        .map(|(&p, q)| (q.exact[4] - r.img[p]).powi(2))
        .sum::<f64>()
        / parts.len().max(1) as f64)
        .sqrt()
        / mean_ref;
    lines.push(format!(
        "{tag}:   (the breakdown's exact quadrature against the MC reference: RMS {quad_vs_mc:.4})"
    ));
    Ok(())
}

/// One light model's breakdown on `picks` (lines in `lines`): the chain of
/// approximations switched to exact in turn, and with the paper's lobe light the
/// studied fitted lobes. Returns each pick's [`Parts`].
fn light_breakdown(
    f: &Frame<'_>,
    m: &Meunier<'_>,
    light: &SphereLight,
    mean_ref: f64,
    picks: &[usize],
    light_model: LightModel,
    lines: &mut Vec<String>,
) -> Result<Vec<Parts>, String> {
    let (tag, scene, hits, stride) = (&f.tag, f.scene, &f.hits, f.stride());
    let rms_of = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt() / mean_ref;
    let default = MaskSettings::default();
    let s = MaskSettings {
        light: light_model,
        ..default
    };
    let run: Vec<(f64, Parts)> = picks
        .par_iter()
        .map(|&p| {
            let hit = hits[p].expect("lit");
            let pipeline = lobes_at(m, scene, light, &hit, &s)?;
            Ok((pipeline, breakdown(m, scene, light, &hit, &s)?))
        })
        .collect::<Result<_, String>>()?;
    let chain: Vec<[f64; 7]> = run
        .iter()
        .map(|(p, q)| [*p, q.model, q.exact[0], q.exact[1], q.exact[2], q.exact[3], q.exact[4]])
        .collect();
    // With meshes a last stage: the sphere sets → the true triangles.
    let stages = if scene.meshes.is_empty() { 5 } else { 6 };
    let total_rms = rms_of(&chain.iter().map(|c| c[0] - c[stages]).collect::<Vec<_>>());
    lines.push(format!(
        "{tag}: light {}: error breakdown over {} pixels (every {stride}th): total RMS {total_rms:.4} of the mean reference (quadrature, not MC); each switch to exact, in order:",
        light_model.name(),
        chain.len()
    ));
    let names = [
        "lobe-product algebra (tables → quadrature of the same sums)",
        "light (→ the light's cap)",
        "leaf cap → lobe fit (→ the leaves' bounding caps, same weights)",
        "weights / overlaps (weighted bounding caps → the leaf cells' union)",
        "mask depth / aggressive (→ exact visibility)",
        "sphere sets → true meshes (exact visibility of the triangles)",
    ];
    for (k, name) in names.iter().enumerate().take(stages) {
        let d: Vec<f64> = chain.iter().map(|c| c[k] - c[k + 1]).collect();
        let bias = d.iter().sum::<f64>() / d.len().max(1) as f64 / mean_ref;
        lines.push(format!("{tag}:   {name}: RMS {:.4}, mean {bias:+.4}", rms_of(&d)));
    }
    if stages == 6 {
        let on: Vec<bool> = picks
            .iter()
            .map(|&p| hits[p].is_some_and(|h| h.mesh.is_some()))
            .collect();
        let parts: Vec<Vec<f64>> = chain.iter().map(|c| c.to_vec()).collect();
        lines.push(crate::image::split_stage(
            tag,
            "sphere sets → true meshes",
            &parts,
            5,
            &on,
            mean_ref,
        ));
    }
    if light_model == LightModel::Lobe {
        // The studied fitted coaxial lobes in place of the paper's, by the same rule.
        for k in 0..light_fit::MAX_LOBES {
            let term = rms_of(&run.iter().map(|(_, q)| q.fitted[k] - q.exact[0]).collect::<Vec<_>>());
            let total = rms_of(&run.iter().map(|(_, q)| q.fitted[k] - q.exact[4]).collect::<Vec<_>>());
            lines.push(format!(
                "{tag}:   studied: {} fitted coaxial lobe(s) per light: light term RMS {term:.4}, total (exact algebra) {total:.4}",
                k + 1
            ));
        }
    }
    Ok(run.into_iter().map(|(_, q)| q).collect())
}
