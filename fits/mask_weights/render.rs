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
use std::path::{Path, PathBuf};
use std::time::Instant;

use lobefit_tables::glam::DVec3;
use lobefit_tables::mask_weights::{build_mask, Cap, MaskMode, WeightSet};
use lobefit_tables::meunier::{Brdf, LafortuneLobe, MaskSettings, Sphere, SphereLight};
use lobefit_tables::{CapExponent, Lobe, LobeProduct, MaskWeights, Meunier};
use rayon::prelude::*;

use super::direct_light::{ray_sphere, visible};
use super::gauss_legendre;
use crate::plot::{heatmaps, line_chart, Heatmap, LineChart, Series};
use crate::rng::Rng;

/// Seed of the reference's per-pixel light samples.
pub const MC_SEED: u64 = 0x5eed_0013;

/// Which scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneKind {
    /// Figure 13: five spheres over a plane, diffuse.
    Fig13,
    /// The same geometry with a glossy Lafortune plane (Figure 14's kind).
    Glossy,
}

impl SceneKind {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Fig13 => "fig13",
            SceneKind::Glossy => "glossy",
        }
    }
}

/// A scene: the plane z = 0, sphere blockers (also visible, diffuse), one light,
/// a pinhole camera.
#[derive(Debug, Clone)]
pub struct Scene {
    /// BRDF of the plane.
    pub plane: Brdf,
    /// BRDF of the spheres.
    pub sphere_brdf: Brdf,
    /// Spheres.
    pub spheres: Vec<Sphere>,
    /// The light.
    pub light: SphereLight,
    /// Camera position.
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Vertical field of view (rad).
    pub fov: f64,
}

/// The scenes of docs/meunier.md.
pub fn scene(kind: SceneKind) -> Scene {
    let s = |x: f64, y: f64, z: f64, r: f64| Sphere {
        centre: DVec3::new(x, y, z),
        radius: r,
    };
    let plane = match kind {
        SceneKind::Fig13 => Brdf::Lambert { albedo: 0.8 },
        SceneKind::Glossy => Brdf::Lafortune {
            albedo: 0.3,
            // Phong-like lobe about the mirror direction, normalised: (n + 2)/(2π)·k_s.
            lobes: vec![LafortuneLobe {
                c: DVec3::new(-1.0, -1.0, 1.0),
                rho: 0.5 * (20.0 + 2.0) / TAU,
                exponent: 20.0,
            }],
        },
    };
    Scene {
        plane,
        sphere_brdf: Brdf::Lambert { albedo: 0.6 },
        spheres: vec![
            s(-1.2, 0.0, 0.9, 0.5),
            s(0.2, -0.6, 0.7, 0.35),
            s(1.1, 0.6, 1.0, 0.45),
            s(-0.3, 1.2, 0.6, 0.3),
            s(0.6, -1.6, 0.5, 0.25),
        ],
        light: SphereLight {
            sphere: s(0.8, 0.6, 4.0, 0.7),
            radiance: 4.0,
        },
        eye: DVec3::new(0.0, -6.5, 4.5),
        target: DVec3::new(0.0, 0.0, 0.3),
        fov: 0.75,
    }
}

/// What a pixel sees.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Surface point.
    pub x: DVec3,
    /// Unit normal.
    pub n: DVec3,
    /// Unit tangent.
    pub t: DVec3,
    /// Unit direction to the eye.
    pub wo: DVec3,
    /// Index of the sphere hit, `None` for the plane.
    pub sphere: Option<usize>,
}

impl Scene {
    /// Primary ray of pixel (i, j) of a w × h image (row 0 at the top).
    pub fn primary(&self, i: usize, j: usize, w: usize, h: usize) -> Option<Hit> {
        let f = (self.target - self.eye).normalize();
        let r = f.cross(DVec3::Z).normalize();
        let u = r.cross(f);
        let k = (0.5 * self.fov).tan();
        let sx = ((i as f64 + 0.5) / w as f64 * 2.0 - 1.0) * k * w as f64 / h as f64;
        let sy = (1.0 - (j as f64 + 0.5) / h as f64 * 2.0) * k;
        let d = (f + sx * r + sy * u).normalize();
        let mut best: Option<(f64, Hit)> = None;
        for (idx, s) in self.spheres.iter().enumerate() {
            if let Some(t) = ray_sphere(self.eye, d, s) {
                if best.as_ref().is_none_or(|b| t < b.0) {
                    let x = self.eye + t * d;
                    let n = (x - s.centre).normalize();
                    best = Some((
                        t,
                        Hit {
                            x,
                            n,
                            t: n.any_orthonormal_vector(),
                            wo: -d,
                            sphere: Some(idx),
                        },
                    ));
                }
            }
        }
        if d.z < 0.0 {
            let t = -self.eye.z / d.z;
            if best.as_ref().is_none_or(|b| t < b.0) {
                let x = self.eye + t * d;
                // Only a finite floor is drawn, so the background stays out of the metrics.
                if x.x.abs() <= 4.0 && x.y.abs() <= 4.0 {
                    best = Some((
                        t,
                        Hit {
                            x,
                            n: DVec3::Z,
                            t: DVec3::X,
                            wo: -d,
                            sphere: None,
                        },
                    ));
                }
            }
        }
        best.map(|b| b.1)
    }

    /// The BRDF at a hit.
    pub fn brdf(&self, h: &Hit) -> &Brdf {
        if h.sphere.is_some() {
            &self.sphere_brdf
        } else {
            &self.plane
        }
    }

    /// Blockers seen from a hit: every sphere but the one it lies on (a sphere hides
    /// exactly the lower hemisphere of its own surface points, which the cosine
    /// already removes).
    pub fn blockers(&self, h: &Hit) -> Vec<Sphere> {
        self.spheres
            .iter()
            .enumerate()
            .filter(|(i, _)| Some(*i) != h.sphere)
            .map(|(_, s)| *s)
            .collect()
    }
}

/// The BRDF's value f_r(v, wo) from its definition (independent of the lobe form).
pub fn brdf_value(b: &Brdf, h: &Hit, v: DVec3) -> f64 {
    if h.n.dot(v) <= 0.0 {
        return 0.0;
    }
    match b {
        Brdf::Lambert { albedo } => albedo / PI,
        Brdf::Lafortune { albedo, lobes } => {
            let t = (h.t - h.t.dot(h.n) * h.n).normalize();
            let bt = h.n.cross(t);
            let loc = |d: DVec3| DVec3::new(d.dot(t), d.dot(bt), d.dot(h.n));
            let (a, o) = (loc(v), loc(h.wo));
            albedo / PI
                + lobes
                    .iter()
                    .map(|l| {
                        let s = l.c.x * a.x * o.x + l.c.y * a.y * o.y + l.c.z * a.z * o.z;
                        if s > 0.0 {
                            l.rho * s.powf(l.exponent)
                        } else {
                            0.0
                        }
                    })
                    .sum::<f64>()
        }
    }
}

/// Reference radiance at a hit: `n` light samples uniform in the light's cap;
/// (mean, standard error of the mean).
pub fn reference(scene: &Scene, h: &Hit, n: usize, seed: u64) -> (f64, f64) {
    let light = &scene.light;
    let to = light.sphere.centre - h.x;
    let d = to.length();
    let w = to / d;
    let cos_a = (1.0 - (light.sphere.radius / d).powi(2)).sqrt();
    let omega = TAU * (1.0 - cos_a);
    let (u, v) = w.any_orthonormal_pair();
    let blockers = scene.blockers(h);
    let brdf = scene.brdf(h);
    let mut rng = Rng::new(seed);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let mu = 1.0 - rng.uniform() * (1.0 - cos_a);
        let phi = rng.range(0.0, TAU);
        let st = (1.0 - mu * mu).max(0.0).sqrt();
        let dir = mu * w + st * (phi.cos() * u + phi.sin() * v);
        let c = h.n.dot(dir);
        let f = if c > 0.0 && visible(h.x, dir, &light.sphere, &blockers) {
            brdf_value(brdf, h, dir) * light.radiance * c * omega
        } else {
            0.0
        };
        s += f;
        s2 += f * f;
    }
    let mean = s / n as f64;
    let var = (s2 / n as f64 - mean * mean).max(0.0) * n as f64 / (n as f64 - 1.0).max(1.0);
    (mean, (var / n as f64).sqrt())
}

/// Options of a render.
#[derive(Debug, Clone, Copy)]
pub struct RenderOptions {
    /// Image width (pixels); the height is 3/4 of it.
    pub width: usize,
    /// Reference samples per pixel.
    pub spp: usize,
    /// Every `breakdown_stride`-th pixel (in x and y) gets the error breakdown.
    pub breakdown_stride: usize,
}

/// Measured results of one scene.
#[derive(Debug, Clone, Default)]
pub struct Summary {
    /// Lines of text (also written to `summary.txt`).
    pub lines: Vec<String>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Relative RMSE of the default pipeline (fitted weights) over lit pixels.
    pub rel_rmse: f64,
    /// Mean relative standard error of the reference.
    pub ref_rel_se: f64,
}

/// Error statistics of `img` against `reference` over pixels with `mask`: relative
/// RMSE, p99 and max of |img − ref|, all divided by the mean reference.
fn stats(img: &[f64], reference: &[f64], mask: &[bool]) -> (f64, f64, f64) {
    let mean = mean_over(reference, mask);
    let mut d: Vec<f64> = img
        .iter()
        .zip(reference)
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|((a, b), _)| (a - b).abs() / mean)
        .collect();
    d.sort_by(f64::total_cmp);
    if d.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let rmse = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    let p99 = d[((d.len() - 1) as f64 * 0.99).round() as usize];
    (rmse, p99, *d.last().expect("non-empty"))
}

fn mean_over(v: &[f64], mask: &[bool]) -> f64 {
    let (s, n) = v
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .fold((0.0, 0usize), |(s, n), (x, _)| (s + x, n + 1));
    s / n.max(1) as f64
}

/// The lobe pipeline over the whole image with `settings`; `None` for background.
fn lobe_image(
    m: &Meunier<'_>,
    scene: &Scene,
    hits: &[Option<Hit>],
    settings: &MaskSettings,
) -> Result<Vec<f64>, String> {
    hits.par_iter()
        .map(|h| match h {
            None => Ok(0.0),
            Some(h) => m
                .radiance(
                    h.x,
                    h.n,
                    h.t,
                    h.wo,
                    scene.brdf(h),
                    &[scene.light],
                    &scene.blockers(h),
                    settings,
                )
                .map_err(|e| e.to_string()),
        })
        .collect()
}

/// The error breakdown at one hit, switching one approximation to exact at a time:
/// the lobe algebra (E1: quadrature of the same lobe sums), the light lobe (E2: the
/// light's cap instead, still with the leaf lobes), the leaf cap → lobe fit (E3: each
/// leaf's bounding cap itself, same weights), the weights (E4: the union of the leaf
/// cells, where no overlap needs correcting), the mask's depth and aggressive choice
/// (E5: exact ray–sphere visibility, the reference), all by one product rule
/// (Gauss–Legendre in θ split at the cap's edge, uniform in φ) about the light's axis.
fn breakdown(m: &Meunier<'_>, scene: &Scene, h: &Hit, settings: &MaskSettings) -> Result<[f64; 5], String> {
    let light = &scene.light;
    let blockers = scene.blockers(h);
    let brdf = scene.brdf(h);
    let (llobe, lcap) = m.light_lobe(h.x, light).map_err(|e| e.to_string())?;
    let vis = m
        .visibility(h.x, h.n, light, &blockers, settings)
        .map_err(|e| e.to_string())?;
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
    let leaves: Vec<_> = mask.leaves(settings.depth, settings.mode).collect();
    let mut w = [0.0; lobefit_tables::mask_weights::MAX_DEPTH as usize];
    m.weights
        .weights(settings.weights, settings.mode, settings.depth, mask.dist, &mut w)
        .map_err(|e| e.to_string())?;
    // Each leaf's bounding cap as (axis, cos half-angle, weight).
    let bounding: Vec<(DVec3, f64, f64)> = leaves
        .iter()
        .map(|c| (c.axis, c.half_angle.cos(), w[c.depth.max(1) as usize - 1]))
        .collect();
    // Rule: Gauss–Legendre in θ on [0, α] and [α, θ_max] (θ_max where the light lobe
    // falls below 1e-9 of its peak), uniform in φ.
    let alpha = lcap.half_angle;
    let theta_max = ((1e-9f64).ln() / llobe.exponent.max(1e-3))
        .exp()
        .clamp(-1.0, 1.0)
        .acos()
        .max(alpha * 1.001)
        .min(PI / 2.0 + alpha);
    let (gx, gw) = gauss_legendre(48);
    let nphi = 160;
    let (u, v) = lcap.axis.any_orthonormal_pair();
    let mut out = [0.0; 5];
    for (lo, hi) in [(0.0, alpha), (alpha, theta_max)] {
        for (x, wx) in gx.iter().zip(&gw) {
            let th = lo + 0.5 * (hi - lo) * (x + 1.0);
            let (st, ct) = th.sin_cos();
            let wt = 0.5 * (hi - lo) * wx * st * TAU / nphi as f64;
            for k in 0..nphi {
                let phi = TAU * (k as f64 + 0.5) / nphi as f64;
                let dir = ct * lcap.axis + st * (phi.cos() * u + phi.sin() * v);
                let c = h.n.dot(dir);
                if c <= 0.0 {
                    continue;
                }
                let f = brdf_value(brdf, h, dir) * c * wt;
                if f == 0.0 {
                    continue;
                }
                let lv = llobe.eval(dir);
                if vis.fully_blocked {
                    // Every estimate but the exact one sees no light (the runtime's
                    // short cut); the exact one (E4) is 0 too.
                    continue;
                }
                let v_lobes: f64 = vis.lobes.iter().map(|l: &Lobe| l.eval(dir)).sum();
                out[0] += f * lv * v_lobes;
                if th <= alpha {
                    let l = f * light.radiance;
                    out[1] += l * v_lobes;
                    let v_caps: f64 = 1.0
                        - bounding
                            .iter()
                            .filter(|(a, c, _)| a.dot(dir) >= *c)
                            .map(|(_, _, wd)| wd)
                            .sum::<f64>();
                    out[2] += l * v_caps;
                    if !leaves.iter().any(|c| c.contains(dir)) {
                        out[3] += l;
                    }
                    if visible(h.x, dir, &light.sphere, &blockers) {
                        out[4] += l;
                    }
                }
            }
        }
    }
    Ok(out)
}

/// Renders `kind` and writes its figures into `dir`. `progress` is called once per
/// finished image row of the reference.
pub fn render(
    kind: SceneKind,
    opts: &RenderOptions,
    dir: &Path,
    progress: &(dyn Fn() + Sync),
) -> Result<Summary, String> {
    let (w, h) = (opts.width.max(4), (opts.width * 3 / 4).max(3));
    let scene = scene(kind);
    let weights = MaskWeights::embedded().map_err(|e| e.to_string())?;
    let m = Meunier {
        products: LobeProduct::embedded().map_err(|e| e.to_string())?,
        caps: CapExponent::embedded().map_err(|e| e.to_string())?,
        weights,
    };
    let hits: Vec<Option<Hit>> = (0..w * h).map(|p| scene.primary(p % w, p / w, w, h)).collect();
    let lit: Vec<bool> = hits.iter().map(Option::is_some).collect();
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let tag = kind.name();
    let mut sum = Summary::default();

    // Reference (row by row for the progress bar), timed.
    let t0 = Instant::now();
    let refs: Vec<(f64, f64)> = (0..h)
        .into_par_iter()
        .flat_map_iter(|j| {
            let row: Vec<(f64, f64)> = (0..w)
                .map(|i| match &hits[j * w + i] {
                    None => (0.0, 0.0),
                    Some(hit) => reference(&scene, hit, opts.spp, MC_SEED ^ (j * w + i) as u64),
                })
                .collect();
            progress();
            row
        })
        .collect();
    let t_ref = t0.elapsed().as_secs_f64();
    let reference_img: Vec<f64> = refs.iter().map(|r| r.0).collect();
    let se: Vec<f64> = refs.iter().map(|r| r.1).collect();
    let mean_ref = mean_over(&reference_img, &lit);
    let ref_rel_se = mean_over(&se, &lit) / mean_ref;
    let max_se = se
        .iter()
        .zip(&lit)
        .filter(|(_, &l)| l)
        .map(|(s, _)| *s)
        .fold(0.0, f64::max)
        / mean_ref;

    // Lobe pipeline, three weight sets, timed (default set).
    let default = MaskSettings::default();
    let t1 = Instant::now();
    let lobes = lobe_image(&m, &scene, &hits, &default)?;
    let t_lobe = t1.elapsed().as_secs_f64();
    let pixels = lit.iter().filter(|&&l| l).count().max(1) as f64;
    sum.lines.push(format!(
        "{tag}: {w}×{h}, {} lit pixels; reference {} light samples/pixel, standard error mean {:.2e}, max {:.2e} (of the mean radiance {:.4})",
        pixels, opts.spp, ref_rel_se, max_se, mean_ref
    ));
    let mut rmse_default = f64::NAN;
    for set in [WeightSet::Fitted, WeightSet::Paper, WeightSet::Ones] {
        let s = MaskSettings {
            weights: set,
            ..default
        };
        let img = if set == WeightSet::Fitted {
            lobes.clone()
        } else {
            lobe_image(&m, &scene, &hits, &s)?
        };
        let (rmse, p99, max) = stats(&img, &reference_img, &lit);
        if set == WeightSet::Fitted {
            rmse_default = rmse;
        }
        sum.lines.push(format!(
            "{tag}: weights {:<6} depth 5 aggressive: relative RMSE {rmse:.4}, p99 {p99:.4}, max {max:.4}",
            set.name()
        ));
    }
    // Time at equal error: the reference's per-sample spread gives the samples it
    // needs for a standard error equal to the pipeline's RMSE.
    let var_per_sample = mean_over(&se.iter().map(|s| s * s * opts.spp as f64).collect::<Vec<_>>(), &lit);
    let n_eq = var_per_sample / (rmse_default * mean_ref).powi(2);
    let t_sample = t_ref / (pixels * opts.spp as f64);
    let t_px_lobe = t_lobe / pixels;
    sum.lines.push(format!(
        "{tag}: shading time per pixel: lobes {:.2} µs; reference {:.3} µs per sample, {:.1} samples for the lobes' RMSE → {:.2} µs; ratio reference/lobes {:.2} (one run, same process)",
        1e6 * t_px_lobe,
        1e6 * t_sample,
        n_eq,
        1e6 * t_sample * n_eq,
        t_sample * n_eq / t_px_lobe
    ));

    // Images.
    let panel = |title: String, values: Vec<f64>, label: &str| Heatmap {
        title,
        x_label: "pixel x".into(),
        y_label: "pixel y (up)".into(),
        x_range: (0.0, w as f64),
        y_range: (0.0, h as f64),
        nx: w,
        ny: h,
        values,
        colour_label: label.into(),
        log_colour: false,
    };
    // Heat maps put row 0 at the bottom: flip.
    let flip = |v: &[f64]| -> Vec<f64> { (0..h).rev().flat_map(|j| v[j * w..(j + 1) * w].to_vec()).collect() };
    let masked = |v: &[f64]| -> Vec<f64> {
        v.iter()
            .zip(&lit)
            .map(|(x, &l)| if l { *x } else { f64::NAN })
            .collect()
    };
    sum.files.push(heatmaps(
        &dir.join(format!("meunier-{tag}-images.png")),
        &[
            panel(
                format!("{tag}: lobe pipeline (depth 5, fitted)"),
                flip(&masked(&lobes)),
                "radiance",
            ),
            panel(
                format!("{tag}: Monte Carlo reference ({} spp)", opts.spp),
                flip(&masked(&reference_img)),
                "radiance",
            ),
        ],
        2,
    )?);
    let rel: Vec<f64> = lobes
        .iter()
        .zip(&reference_img)
        .map(|(a, b)| (a - b) / mean_ref)
        .collect();
    sum.files.push(heatmaps(
        &dir.join(format!("meunier-{tag}-error.png")),
        &[panel(
            format!("{tag}: (lobes − reference) / mean reference"),
            flip(&masked(&rel)),
            "relative error",
        )],
        1,
    )?);
    // Figure 10: aggressive and conservative × depth 2, 3, 5.
    let mut fig10 = Vec::new();
    for mode in MaskMode::ALL {
        for depth in [2, 3, 5] {
            let s = MaskSettings { depth, mode, ..default };
            let img = lobe_image(&m, &scene, &hits, &s)?;
            let (rmse, _, _) = stats(&img, &reference_img, &lit);
            sum.lines.push(format!(
                "{tag}: Figure 10 {} depth {depth}: relative RMSE {rmse:.4}",
                mode.name()
            ));
            fig10.push(panel(
                format!("{} depth {depth}", mode.name()),
                flip(&masked(&img)),
                "radiance",
            ));
        }
    }
    sum.files
        .push(heatmaps(&dir.join(format!("meunier-{tag}-figure10.png")), &fig10, 3)?);
    // Shadow profile: the image row through the deepest shadow on the plane.
    let row = (0..h)
        .max_by(|&a, &b| {
            let shade = |j: usize| -> f64 {
                (0..w)
                    .filter(|&i| hits[j * w + i].is_some_and(|x| x.sphere.is_none()))
                    .map(|i| (lobes[j * w + i] - reference_img[j * w + i]).abs())
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
            points: line(&lobes),
        },
        Series {
            name: format!("reference ({} spp)", opts.spp),
            points: line(&reference_img),
        },
    ];
    for set in [WeightSet::Paper, WeightSet::Ones] {
        let s = MaskSettings {
            weights: set,
            ..default
        };
        let row_hits: Vec<Option<Hit>> = (0..w).map(|i| hits[row * w + i]).collect();
        let img = lobe_image(&m, &scene, &row_hits, &s)?;
        series.push(Series {
            name: format!("lobes, {}", set.name()),
            points: (0..w)
                .filter(|&i| row_hits[i].is_some())
                .map(|i| (i as f64, img[i]))
                .collect(),
        });
    }
    sum.files.push(line_chart(
        &dir.join(format!("meunier-{tag}-profile.png")),
        &LineChart {
            title: format!("{tag}: radiance along image row {row} (through the penumbrae)"),
            x_label: "pixel x".into(),
            y_label: "radiance".into(),
            log_x: false,
            log_y: false,
            series,
        },
    )?);

    // Breakdown on a strided subset of pixels.
    let stride = opts.breakdown_stride.max(1);
    let picks: Vec<usize> = (0..h)
        .step_by(stride)
        .flat_map(|j| (0..w).step_by(stride).map(move |i| j * w + i))
        .filter(|&p| lit[p])
        .collect();
    let parts: Vec<[f64; 6]> = picks
        .par_iter()
        .map(|&p| {
            let hit = hits[p].expect("lit");
            let b = breakdown(&m, &scene, &hit, &default)?;
            Ok([lobes[p], b[0], b[1], b[2], b[3], b[4]])
        })
        .collect::<Result<_, String>>()?;
    let names = [
        "lobe-product algebra (tables → quadrature of the lobe sums)",
        "light lobe (→ the light's cap)",
        "leaf cap → lobe fit (→ the leaves' bounding caps, same weights)",
        "weights / overlaps (weighted bounding caps → the leaf cells' union)",
        "mask depth / aggressive (→ exact visibility)",
    ];
    let total_rms =
        (parts.iter().map(|p| (p[0] - p[5]).powi(2)).sum::<f64>() / parts.len().max(1) as f64).sqrt() / mean_ref;
    sum.lines.push(format!(
        "{tag}: error breakdown over {} pixels (every {stride}th): total RMS {total_rms:.4} of the mean reference (quadrature, not MC); each switch to exact, in order:",
        parts.len()
    ));
    for (k, name) in names.iter().enumerate() {
        let d: Vec<f64> = parts.iter().map(|p| p[k] - p[k + 1]).collect();
        let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt() / mean_ref;
        let bias = d.iter().sum::<f64>() / d.len().max(1) as f64 / mean_ref;
        sum.lines
            .push(format!("{tag}:   {name}: RMS {rms:.4}, mean {bias:+.4}"));
    }
    // The mask's lobes under the light's exact cap (E2 − E5), for each weight set: what
    // the weights do once the light lobe's own error is out of the way.
    let rms_of = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt() / mean_ref;
    let mut per_set = vec![(
        WeightSet::Fitted,
        rms_of(&parts.iter().map(|p| p[2] - p[5]).collect::<Vec<_>>()),
    )];
    for set in [WeightSet::Paper, WeightSet::Ones] {
        let s = MaskSettings {
            weights: set,
            ..default
        };
        let d: Vec<f64> = picks
            .par_iter()
            .map(|&p| {
                let b = breakdown(&m, &scene, &hits[p].expect("lit"), &s)?;
                Ok(b[1] - b[4])
            })
            .collect::<Result<_, String>>()?;
        per_set.push((set, rms_of(&d)));
    }
    sum.lines.push(format!(
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
        .map(|(&p, q)| (q[5] - reference_img[p]).powi(2))
        .sum::<f64>()
        / parts.len().max(1) as f64)
        .sqrt()
        / mean_ref;
    sum.lines.push(format!(
        "{tag}:   (the breakdown's exact quadrature against the MC reference: RMS {quad_vs_mc:.4})"
    ));
    sum.rel_rmse = rmse_default;
    sum.ref_rel_se = ref_rel_se;
    let text: String = sum.lines.iter().map(|l| format!("{l}\n")).collect();
    let path = dir.join(format!("meunier-{tag}-summary.txt"));
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    sum.files.push(path);
    Ok(sum)
}
