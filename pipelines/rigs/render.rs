//! `lobefit render rigs`: Yuan et al. 2012's Figure 1 as images — the car-sized box of
//! the rig harness under its seven lights, shaded with the exact irradiance (the ground
//! truth), the per-point SH irradiance, and the constant, gradient, mixed and lattice
//! rigs (least-squares fits), with error maps and the cost of each (docs/rigs.md).
//!
//! Irradiance, not radiance: every panel is E(p, N) = ∫ L max(N·ω, 0) dω at the
//! surface point a pixel sees (the underside is never seen), unshadowed, as in the
//! paper's figure.

use std::path::Path;

use lobefit_tables::disk_light::DiskLight;
use lobefit_tables::glam::DVec3;
use lobefit_tables::rigs::{select_direct, Light, Rig, RigModel, COEFFS};
use lobefit_tables::wrap::rewrap_irradiance;
use rayon::prelude::*;

use super::{car_box, exact_wrapped, field, rig_configs, scene_lights, shade, surface_points, Receiver};
use super::{CAR_HALF, FIT_POINTS, RIDGE, TEST_POINTS};
use crate::image::{
    compare, error_panel, exposure_for, mean_over, panel, shared_scale, write_beauty, write_float_image,
};
use crate::scene::Camera;
use crate::timing::timed;
use crate::{Pipeline, RenderOptions, Summary};

/// `lobefit render rigs`.
pub const PIPELINE: Pipeline = Pipeline {
    name: "rigs",
    about: "Yuan et al. 2012, Figure 1: irradiance rigs on a car-sized box against exact irradiance (docs/rigs.md)",
    scenes: &["fig1", "drive"],
    // Its scenes are built in code (the truth is analytic): no scene file.
    files: &[],
    render,
    eval: &[],
    plots: &[("rigs", super::plot)],
    // Its scenes are built in code, its renders checked against exact irradiance.
    truth: crate::Truth::Analytic,
    animate: None,
    animations: &[],
    pareto: None,
};

/// The camera: a three-quarter view from above the car's front left.
pub const CAMERA: Camera = Camera {
    eye: DVec3::new(5.5, -6.5, 4.0),
    target: DVec3::new(0.0, 0.0, 0.0),
    fov: 0.62,
};

/// The rigs of Figure 1: indices into [`rig_configs`] (constant, gradient, mixed,
/// lattice 3 × 2 × 2).
pub const FIGURE_RIGS: [usize; 4] = [0, 1, 2, 4];

/// The wrap parameter of the second set of panels (the paper applies wrap shading on
/// top of the rigs).
pub const WRAP_A: f64 = 0.5;

/// The error-driven split's tolerance (a light whose own mixed-rig error exceeds this
/// fraction of the field's RMS is evaluated per point; the harness's first choice).
pub const SPLIT_TOLERANCE: f64 = 0.05;

/// Irradiance at normal `n` from an order-3 SH irradiance vector, with wrap `a`
/// (0: Lambert; the vector re-wrapped band by band, λ̂_l(a)/λ̂_l(0)).
pub fn shade_wrapped(l: &[f64; COEFFS], n: DVec3, a: f64) -> Result<f64, String> {
    let mut w = [0.0; COEFFS];
    rewrap_irradiance(l, a, &mut w).map_err(|e| e.to_string())?;
    Ok(shade(&w, n))
}

/// A label as a file-name part: lower-case alphanumerics, runs of anything else as
/// one '-', none at the ends.
fn slug(label: &str) -> String {
    let mut out = String::new();
    for c in label.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_matches('-').to_string()
}

/// The rigs of Figure 1 fitted by least squares to every light's SH irradiance at the
/// harness's fit points: (short label, rig, fit time in s).
pub fn figure_rigs(lights: &[Light], disks: &DiskLight) -> Result<Vec<(String, Rig, f64)>, String> {
    let fit = surface_points(FIT_POINTS, 0xf17);
    let configs = rig_configs();
    FIGURE_RIGS
        .iter()
        .map(|&k| {
            let (label, model) = configs[k];
            let (rig, t) = timed(|| fit_rig(model, lights, disks, &fit));
            let short = label.split(':').next().unwrap_or(label).trim().to_string();
            Ok((short, rig?, t))
        })
        .collect()
}

/// A least-squares rig of `model` for `lights`, fitted at the receivers `fit` (on one
/// thread: its time is compared with per-point costs measured on one thread).
fn fit_rig(model: RigModel, lights: &[Light], disks: &DiskLight, fit: &[Receiver]) -> Result<Rig, String> {
    let samples: Vec<(DVec3, [f64; COEFFS])> = fit
        .iter()
        .map(|r| Ok((r.p, field(lights, disks, r.p)?)))
        .collect::<Result<_, String>>()?;
    Rig::fit_least_squares(model, car_box(), &samples, RIDGE).map_err(|e| e.to_string())
}

/// The mixed rig with the error-driven split: the lights whose own mixed-rig error
/// exceeds [`SPLIT_TOLERANCE`] of the field's RMS (`select_direct`, as the harness)
/// are evaluated per point, the rest through one rig.
pub struct Split {
    /// Indices of the lights evaluated per point.
    pub direct: Vec<usize>,
    direct_lights: Vec<Light>,
    rig: Rig,
    /// Time of the choice and the fit (s).
    pub fit_s: f64,
}

impl Split {
    /// Chooses and fits at the harness's fit and test points.
    pub fn new(lights: &[Light], disks: &DiskLight) -> Result<Split, String> {
        let fit = surface_points(FIT_POINTS, 0xf17);
        let fit_p: Vec<DVec3> = fit.iter().map(|r| r.p).collect();
        let test_p: Vec<DVec3> = surface_points(TEST_POINTS, 0x7e57).iter().map(|r| r.p).collect();
        let mixed = rig_configs()[FIGURE_RIGS[2]].1;
        let (split, fit_s) = timed(|| -> Result<(Vec<usize>, Rig), String> {
            let chosen = select_direct(mixed, car_box(), lights, disks, &fit_p, &test_p, SPLIT_TOLERANCE, RIDGE)
                .map_err(|e| e.to_string())?;
            let direct: Vec<usize> = chosen.iter().map(|c| c.0).collect();
            let rig_lights: Vec<Light> = (0..lights.len())
                .filter(|i| !direct.contains(i))
                .map(|i| lights[i])
                .collect();
            Ok((direct, fit_rig(mixed, &rig_lights, disks, &fit)?))
        });
        let (direct, rig) = split?;
        Ok(Split {
            direct_lights: direct.iter().map(|&i| lights[i]).collect(),
            direct,
            rig,
            fit_s,
        })
    }

    /// The SH irradiance at `p`: the rig plus the direct lights.
    pub fn eval(&self, p: DVec3, disks: &DiskLight) -> Result<[f64; COEFFS], String> {
        let mut v = self.rig.eval(p).map_err(|e| e.to_string())?;
        let d = field(&self.direct_lights, disks, p)?;
        v.iter_mut().zip(d).for_each(|(a, b)| *a += b);
        Ok(v)
    }
}

/// What the primary ray from `eye` in direction `d` sees of the box: the nearest
/// face point with the face's outward normal (slab method); `None` for a miss or the
/// underside.
pub fn hit_box(eye: DVec3, d: DVec3) -> Option<Receiver> {
    let h = DVec3::from_array(CAR_HALF);
    let (mut t0, mut t1, mut axis) = (0.0f64, f64::INFINITY, None);
    for k in 0..3 {
        if d[k] == 0.0 {
            if eye[k].abs() > h[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((-h[k] - eye[k]) / d[k], (h[k] - eye[k]) / d[k]);
        let (near, far) = (a.min(b), a.max(b));
        if near > t0 {
            t0 = near;
            axis = Some(k);
        }
        t1 = t1.min(far);
    }
    let k = axis?;
    if t0 > t1 || t0 <= 0.0 {
        return None;
    }
    let mut n = DVec3::ZERO;
    n[k] = -d[k].signum();
    (n.z >= 0.0).then_some(Receiver { p: eye + t0 * d, n })
}

/// Renders Figure 1 into `dir`.
pub fn render(name: &str, opts: &RenderOptions, dir: &Path, progress: &(dyn Fn() + Sync)) -> Result<Summary, String> {
    match name {
        "fig1" => {}
        "drive" => return drive(dir, FRAMES, progress),
        _ => {
            return Err(format!(
                "render rigs: unknown scene {name} (fig1: Figure 1's panels; drive: the animated pass)"
            ))
        }
    }
    let (w, h) = (opts.width.max(4), (opts.width * 3 / 4).max(3));
    let disks = DiskLight::embedded().map_err(|e| e.to_string())?;
    let lights: Vec<Light> = scene_lights().iter().map(|l| l.1).collect();
    let hits: Vec<Option<Receiver>> = (0..w * h)
        .map(|p| hit_box(CAMERA.eye, CAMERA.ray(p % w, p / w, w, h)))
        .collect();
    let lit: Vec<bool> = hits.iter().map(Option::is_some).collect();
    let pixels = lit.iter().filter(|&&l| l).count();
    if pixels == 0 {
        return Err(format!("render rigs: no pixel of the {w}×{h} image sees the car"));
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut sum = Summary::default();
    let v = View {
        w,
        h,
        hits,
        lit,
        pixels,
        lights,
        dir,
    };
    let (panels, direct) = sh_panels(&v, disks)?;
    sum.lines.push(format!(
        "fig1: {w}×{h}, {pixels} pixels see the car ({} lights); error-driven split at {SPLIT_TOLERANCE}: {} per point ({})",
        v.lights.len(),
        direct.len(),
        direct.iter().map(|&i| scene_lights()[i].0).collect::<Vec<_>>().join("; ")
    ));
    let mut first = f64::NAN;
    let mut split_rmse = f64::NAN;
    for a in [0.0, WRAP_A] {
        for rmse in wrap_pass(&v, &panels, a, progress, &mut sum)? {
            if first.is_nan() {
                first = rmse;
            }
            if a == 0.0 {
                // The last panel (the split) is the headline's method.
                split_rmse = rmse;
            }
        }
    }
    sum.rel_rmse = first;
    // Per pixel with the fit shared over the image's pixels: the cost of shading this
    // view once (the fit is paid per frame, as in the animated pass).
    let per_px = |(_, _, t_fit, t): &Panel| 1e6 * (t_fit + t) / pixels as f64;
    if let (Some(sh), Some(split)) = (panels.first(), panels.last()) {
        sum.headline.push(
            crate::Headline {
                render: "rigs fig1".into(),
                scope: format!("{w}×{h}"),
                method: format!("{} (its {:.2} ms fit shared over the pixels)", split.0, 1e3 * split.2),
                error: format!("relative RMSE {split_rmse:.4} against exact irradiance on {pixels} pixels"),
                cost_us: per_px(split),
                unit: "px".into(),
                baseline: "every light per point (per-point SH)".into(),
                baseline_us: per_px(sh),
                spread: None,
                bound: crate::Bound::Measured,
            }
            .line(),
        );
    }
    sum.write(dir, "rigs-fig1")?;
    Ok(sum)
}

/// Figure 1's view: the image, what each pixel sees of the car, the lights and where
/// the files go.
struct View<'a> {
    /// Image width and height (pixels).
    w: usize,
    h: usize,
    /// Row-major: the box's point and normal a pixel sees, `None` for the background.
    hits: Vec<Option<Receiver>>,
    /// Row-major: the pixel sees the car.
    lit: Vec<bool>,
    /// How many pixels see the car.
    pixels: usize,
    /// The scene's lights.
    lights: Vec<Light>,
    /// Output directory.
    dir: &'a Path,
}

/// One panel's method: (label, SH irradiance vector per pixel, fit time s, per-pixel
/// evaluation time s over the image).
type Panel = (String, Vec<[f64; COEFFS]>, f64, f64);

/// Every panel's SH irradiance vector per pixel (order 3), with its time: the
/// per-point evaluation of every light, each rig's fit and reconstruction, and the
/// error-driven split (last). On one thread, as the animated pass's costs. Also the
/// split's per-point lights.
fn sh_panels(v: &View<'_>, disks: &DiskLight) -> Result<(Vec<Panel>, Vec<usize>), String> {
    let (hits, lights) = (&v.hits, &v.lights);
    let per_pixel = |f: &(dyn Fn(DVec3) -> Result<[f64; COEFFS], String> + Sync)| {
        timed(|| -> Result<Vec<[f64; COEFFS]>, String> {
            hits.iter()
                .map(|r| r.as_ref().map_or(Ok([0.0; COEFFS]), |r| f(r.p)))
                .collect()
        })
    };
    let mut panels: Vec<Panel> = Vec::new();
    let (sh, t) = per_pixel(&|p| field(lights, disks, p));
    panels.push(("per-point SH".into(), sh?, 0.0, t));
    for (label, rig, t_fit) in figure_rigs(lights, disks)? {
        let (sh, t) = per_pixel(&|p| rig.eval(p).map_err(|e| e.to_string()));
        panels.push((label, sh?, t_fit, t));
    }
    let split = Split::new(lights, disks)?;
    let direct = split.direct.clone();
    let (sh, t) = per_pixel(&|p| split.eval(p, disks));
    panels.push((
        format!("mixed + {} light(s) per point", direct.len()),
        sh?,
        split.fit_s,
        t,
    ));
    Ok((panels, direct))
}

/// One set of Figure 1's panels at wrap `a` (0: Lambert): the exact irradiance, each
/// panel's image against it and against per-point SH (a line each in `sum`), and the
/// images. Returns each panel's relative RMSE against exact.
fn wrap_pass(
    v: &View<'_>,
    panels: &[Panel],
    a: f64,
    progress: &(dyn Fn() + Sync),
    sum: &mut Summary,
) -> Result<Vec<f64>, String> {
    let (w, h, hits, lit) = (v.w, v.h, &v.hits, &v.lit);
    let tag = if a == 0.0 {
        "fig1".to_string()
    } else {
        format!("fig1, wrap a = {a}")
    };
    // Ground truth: the exact (wrapped) irradiance of every light (nested
    // Gauss–Kronrod for the sphere and disk lights), one image row at a time.
    let exact: Vec<f64> = (0..h)
        .into_par_iter()
        .map(|j| {
            let row = (0..w)
                .map(|i| match &hits[j * w + i] {
                    None => Ok(0.0),
                    Some(r) => v
                        .lights
                        .iter()
                        .map(|l| exact_wrapped(l, r, a))
                        .sum::<Result<f64, String>>(),
                })
                .collect::<Result<Vec<f64>, String>>();
            progress();
            row
        })
        .collect::<Result<Vec<_>, _>>()?
        .concat();
    let mean = mean_over(&exact, lit);
    sum.lines.push(format!("{tag}: mean exact irradiance {mean:.4}"));
    let mut images = vec![("exact".to_string(), exact.clone())];
    let mut rmses = Vec::new();
    for (label, sh, t_fit, t) in panels {
        let img: Vec<f64> = hits
            .iter()
            .zip(sh)
            .map(|(r, l)| r.as_ref().map_or(Ok(0.0), |r| shade_wrapped(l, r.n, a)))
            .collect::<Result<_, String>>()?;
        let vs_exact = compare(&img, &exact, lit);
        // images[1] is the per-point SH image once it exists (the first panel).
        let vs_sh = compare(&img, images.get(1).map_or(&img, |x| &x.1), lit);
        sum.lines.push(format!(
            "{tag}: {label:<28}: against exact relative RMSE {:.4}, p99 {:.4}, max {:.4}; against per-point SH {:.4}; fit {:.2} ms, per point {:.3} µs",
            vs_exact.rel_rmse,
            vs_exact.p99,
            vs_exact.max,
            vs_sh.rel_rmse,
            1e3 * t_fit,
            1e6 * t / v.pixels as f64
        ));
        rmses.push(vs_exact.rel_rmse);
        images.push((label.clone(), img));
    }
    let stem = if a == 0.0 { "rigs-fig1" } else { "rigs-fig1-wrap" };
    write_panels(v, &tag, stem, &images, mean, sum)?;
    Ok(rmses)
}

/// Writes one wrap's panels (`images`, exact first, the split last): the shared-scale
/// irradiance panels, the error maps, the beauty image (split | exact) and the float
/// images, all recorded in `sum`.
fn write_panels(
    v: &View<'_>,
    tag: &str,
    stem: &str,
    images: &[(String, Vec<f64>)],
    mean: f64,
    sum: &mut Summary,
) -> Result<(), String> {
    let (w, h, lit, dir) = (v.w, v.h, &v.lit, v.dir);
    let exact = &images[0].1;
    let masked = |x: &[f64]| crate::image::masked(x, lit);
    let shown: Vec<_> = images
        .iter()
        .map(|(label, x)| panel(format!("{tag}: {label}"), w, h, &masked(x), "irradiance"))
        .collect();
    sum.files.push(lobefit_core::plot::heatmaps(
        &dir.join(format!("{stem}-images.png")),
        &shared_scale(shown),
        4,
    )?);
    // Each error map on its own diverging scale (± its p99, in its label): the rigs'
    // errors differ tenfold, and one scale would leave the small ones white.
    let errors: Vec<_> = images[1..]
        .iter()
        .map(|(label, x)| {
            error_panel(
                format!("{tag}: ({label} − exact) / mean exact"),
                w,
                h,
                &crate::image::error_map(x, exact, lit, mean),
            )
        })
        .collect();
    sum.files.push(lobefit_core::plot::heatmaps(
        &dir.join(format!("{stem}-error.png")),
        &errors,
        4,
    )?);
    // The beauty image: the split (the harness's choice, the last panel) | exact.
    if let Some((_, split_img)) = images.last() {
        sum.files.push(write_beauty(
            &dir.join(format!("{stem}-beauty.png")),
            (w, h),
            &[split_img, exact],
            lit,
            exposure_for(mean),
        )?);
    }
    for (label, x) in images {
        let name = slug(label);
        sum.files
            .extend(write_float_image(dir, &format!("{stem}-{name}"), w, h, x)?);
    }
    Ok(())
}

/// Frames of the animated pass.
pub const FRAMES: usize = 24;
/// The car's x over the pass: from −`DRIVE_X` to +`DRIVE_X` m (past all three lamps).
pub const DRIVE_X: f64 = 9.0;

/// The scene's lights seen from a car whose centre is at `x` along the street: the
/// rig box stays at the origin, so the world moves by −x.
pub fn lights_at(x: f64) -> Vec<Light> {
    let shift = DVec3::new(-x, 0.0, 0.0);
    scene_lights()
        .into_iter()
        .map(|(_, l)| match l {
            Light::Point { position, intensity } => Light::Point {
                position: position + shift,
                intensity,
            },
            Light::Sphere {
                centre,
                radius,
                radiance,
            } => Light::Sphere {
                centre: centre + shift,
                radius,
                radiance,
            },
            Light::Disk {
                centre,
                normal,
                radius,
                radiance,
            } => Light::Disk {
                centre: centre + shift,
                normal,
                radius,
                radiance,
            },
        })
        .collect()
}

/// The animated pass: the car drives from x = −9 to +9 m past the lamps in
/// `frames` frames ([`FRAMES`] for `render rigs --scene drive`; ≥ 2: the first and last
/// at x = ∓9 m); per frame every Figure 1 rig is refitted and the error-driven
/// split re-chosen, each measured against the exact irradiance on the harness's 800
/// test points, and timed (fit per frame; per point: reconstruction, the split's
/// per-point lights, and every light per point).
pub fn drive(dir: &Path, frames: usize, progress: &(dyn Fn() + Sync)) -> Result<Summary, String> {
    if frames < 2 {
        return Err(format!(
            "render rigs drive: {frames} frames (at least 2: the pass's ends)"
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let disks = DiskLight::embedded().map_err(|e| e.to_string())?;
    let test = surface_points(TEST_POINTS, 0x7e57);
    let mut sum = Summary::default();
    let mut methods: Vec<Method> = Vec::new();
    for frame in 0..frames {
        let (runs, line) = drive_frame(frame, frames, &test, disks)?;
        for (k, (label, err, t_fit, t_point)) in runs.into_iter().enumerate() {
            if methods.len() <= k {
                methods.push((label, Vec::new(), 0.0, 0.0));
            }
            let m = &mut methods[k];
            m.1.push(err);
            m.2 += t_fit;
            m.3 += t_point;
        }
        sum.lines.push(line);
        progress();
    }
    drive_report(dir, frames, &methods, &mut sum)?;
    sum.rel_rmse = methods.get(3).map_or(f64::NAN, |m| {
        let mut s = m.1.clone();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    });
    // The headline: the split (the last method) against every light per point (the
    // first), per point with the fit shared over the frame's points, as printed above.
    let points = TEST_POINTS as f64 * frames as f64;
    if let (Some(sh), Some(split)) = (methods.first(), methods.last()) {
        let per_point = |m: &Method| 1e6 * (m.3 + m.2) / points;
        let mut errs = split.1.clone();
        errs.sort_by(f64::total_cmp);
        sum.headline.push(
            crate::Headline {
                render: "rigs drive".into(),
                scope: format!("{frames} frames × {TEST_POINTS} points"),
                method: split.0.clone(),
                error: format!(
                    "relative RMSE against exact irradiance {:.4} (median over the frames; max {:.4})",
                    errs[errs.len() / 2],
                    errs[errs.len() - 1]
                ),
                cost_us: per_point(split),
                unit: "point".into(),
                baseline: "every light per point (SH)".into(),
                baseline_us: per_point(sh),
                spread: None,
                bound: crate::Bound::Measured,
            }
            .line(),
        );
    }
    sum.write(dir, "rigs-drive")?;
    Ok(sum)
}

/// One method of the animated pass over the frames: (label, per-frame relative RMSE,
/// total fit s, total per-point s).
type Method = (String, Vec<f64>, f64, f64);

/// One frame of the animated pass (of `frames`): each method (every light per point,
/// the Figure 1 rigs, the split) against the exact irradiance at the `test` points, as
/// (label, relative RMSE, fit s, per-point s over the points), and the frame's line.
#[allow(clippy::type_complexity)]
fn drive_frame(
    frame: usize,
    frames: usize,
    test: &[Receiver],
    disks: &DiskLight,
) -> Result<(Vec<(String, f64, f64, f64)>, String), String> {
    let names: Vec<&str> = scene_lights().iter().map(|l| l.0).collect();
    let x = -DRIVE_X + 2.0 * DRIVE_X * frame as f64 / (frames - 1) as f64;
    let lights = lights_at(x);
    let exact: Vec<f64> = test
        .par_iter()
        .map(|r| {
            lights
                .iter()
                .map(|l| exact_wrapped(l, r, 0.0))
                .sum::<Result<f64, String>>()
        })
        .collect::<Result<_, String>>()?;
    let shade_all = |f: &(dyn Fn(DVec3) -> Result<[f64; COEFFS], String> + Sync)| {
        timed(|| -> Result<Vec<f64>, String> { test.iter().map(|r| Ok(shade(&f(r.p)?, r.n))).collect() })
    };
    let rel = |img: &[f64]| crate::image::compare(img, &exact, &vec![true; exact.len()]).rel_rmse;
    let mut runs = Vec::new();
    // Every light per point: the per-point SH baseline.
    let (img, t) = shade_all(&|p| field(&lights, disks, p));
    runs.push(("every light per point (SH)".to_string(), rel(&img?), 0.0, t));
    for (label, rig, t_fit) in figure_rigs(&lights, disks)? {
        let (img, t) = shade_all(&|p| rig.eval(p).map_err(|e| e.to_string()));
        runs.push((label, rel(&img?), t_fit, t));
    }
    let split = Split::new(&lights, disks)?;
    let direct = &split.direct;
    let (img, t) = shade_all(&|p| split.eval(p, disks));
    let err = rel(&img?);
    runs.push(("mixed + error-driven split".to_string(), err, split.fit_s, t));
    let line = format!(
        "drive: frame {frame:>2}, car at x = {x:+.2} m: per point: {}; mixed + split {err:.4}",
        if direct.is_empty() {
            "none".to_string()
        } else {
            direct.iter().map(|&i| names[i]).collect::<Vec<_>>().join("; ")
        }
    );
    Ok((runs, line))
}

/// The animated pass's statistics per method (lines in `sum`) and its two charts:
/// error per frame, and median error against cost.
fn drive_report(dir: &Path, frames: usize, methods: &[Method], sum: &mut Summary) -> Result<(), String> {
    let points = TEST_POINTS as f64 * frames as f64;
    sum.lines.push(format!(
        "drive: {frames} frames, {TEST_POINTS} points a frame; relative RMSE against exact irradiance over the frames (min, median, max), fit ms per frame, µs per point (one thread, one run, same process):"
    ));
    let mut series = Vec::new();
    let mut scatter = Vec::new();
    for (label, errs, t_fit, t_point) in methods {
        let mut sorted = errs.clone();
        sorted.sort_by(f64::total_cmp);
        let per_point = 1e6 * (t_point + t_fit) / points;
        sum.lines.push(format!(
            "drive:   {label:<30}: {:.4} {:.4} {:.4}; fit {:.2} ms/frame; {:.3} µs/point per frame (fit shared over {TEST_POINTS} points: {:.3} µs/point with it)",
            sorted[0],
            sorted[sorted.len() / 2],
            sorted[sorted.len() - 1],
            1e3 * t_fit / frames as f64,
            1e6 * t_point / points,
            per_point
        ));
        series.push(lobefit_core::plot::Series {
            name: label.clone(),
            points: errs.iter().enumerate().map(|(f, &e)| (f as f64, e)).collect(),
        });
        scatter.push(lobefit_core::plot::Series {
            name: label.clone(),
            points: vec![(per_point, sorted[sorted.len() / 2])],
        });
    }
    sum.files.push(lobefit_core::plot::line_chart(
        &dir.join("rigs-drive-error.png"),
        &lobefit_core::plot::LineChart {
            title: "irradiance rigs: error per frame as the car drives past the lamps".into(),
            x_label: "frame".into(),
            y_label: "relative RMSE against exact irradiance".into(),
            log_x: false,
            log_y: true,
            series,
        },
    )?);
    sum.files.push(lobefit_core::plot::line_chart(
        &dir.join("rigs-drive-cost.png"),
        &lobefit_core::plot::LineChart {
            title: "irradiance rigs: median error against cost (fit shared over the points)".into(),
            x_label: "µs per point per frame".into(),
            y_label: "median relative RMSE".into(),
            log_x: true,
            log_y: true,
            series: scatter,
        },
    )?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays by hand: straight down onto the roof, onto the +x bumper face, from below
    /// (the underside is not shaded), and past the box.
    #[test]
    fn hit_box_by_hand() {
        let r = hit_box(DVec3::new(0.3, 0.2, 5.0), -DVec3::Z).unwrap();
        assert_eq!((r.p, r.n), (DVec3::new(0.3, 0.2, 0.75), DVec3::Z));
        let r = hit_box(DVec3::new(10.0, 0.1, 0.2), -DVec3::X).unwrap();
        assert_eq!((r.p, r.n), (DVec3::new(2.25, 0.1, 0.2), DVec3::X));
        assert!(hit_box(DVec3::new(0.0, 0.0, -5.0), DVec3::Z).is_none());
        assert!(hit_box(DVec3::new(0.0, 3.0, 5.0), -DVec3::Z).is_none());
        // Inside the box: no hit (t0 ≤ 0).
        assert!(hit_box(DVec3::ZERO, DVec3::X).is_none());
    }

    /// The wrapped exact irradiance of a tiny sphere light is that of a point light of
    /// intensity L πr² (closed form), for normals facing it, grazing and behind within
    /// the wrap: the quadrature with the wrap kernel against a hand-written formula.
    #[test]
    fn wrapped_sphere_light_is_a_point_light_when_tiny() {
        let (c, radius, radiance) = (DVec3::new(0.0, 0.0, 5.0), 1e-3, 2.0e4);
        let sphere = Light::Sphere {
            centre: c,
            radius,
            radiance,
        };
        for (a, n) in [
            (0.0, DVec3::Z),
            (0.5, DVec3::Z),
            (0.5, DVec3::X),
            (0.5, DVec3::new(0.0, 0.9, -0.2).normalize()),
        ] {
            let r = Receiver { p: DVec3::ZERO, n };
            let t = n.dot(c.normalize());
            let kernel = if t > -a {
                ((t + a) / (1.0 + a)).powf(1.0 + a)
            } else {
                0.0
            };
            let want = radiance * std::f64::consts::PI * radius * radius * kernel / c.length_squared();
            let got = exact_wrapped(&sphere, &r, a).unwrap();
            assert!(
                (got - want).abs() <= 1e-4 * want.max(1e-6),
                "a {a}, n {n}: {got} vs {want}"
            );
        }
    }

    /// The pass's lights move with −x and keep everything else.
    #[test]
    fn lights_at_shifts_the_world() {
        let base = scene_lights();
        for (moved, (_, orig)) in lights_at(2.5).iter().zip(&base) {
            let pos = |l: &Light| match *l {
                Light::Point { position, .. } => position,
                Light::Sphere { centre, .. } | Light::Disk { centre, .. } => centre,
            };
            assert_eq!(pos(moved), pos(orig) - DVec3::new(2.5, 0.0, 0.0));
        }
        assert_eq!(lights_at(0.0), base.iter().map(|l| l.1).collect::<Vec<_>>());
    }
}
