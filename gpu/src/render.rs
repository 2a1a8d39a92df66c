//! `lobefit-gpu render library`: a small headless image through the shader library — a
//! diffuse sphere on a floor lit by a one-sided disk light, shaded by the disk's order-3
//! SH irradiance (`lf_disk_irradiance` on the exported disk-light texture), plus a
//! glossy term on the sphere: two cosine-lobe lights through a Phong lobe about the
//! mirror direction, each ∫ BRDF lobe × light lobe from `lf_lobe_product` (the exported
//! lobe-product texture and its ln W texture, a second pass) — written as a PNG, and
//! the same image computed on the CPU with the runtime crate (`DiskLight::irradiance`,
//! `LobeProduct::params`, f64, the committed tables), compared pixel by pixel
//! (`lobefit-gpu render library`); with `--scene`, a scene's spherical lights'
//! unshadowed irradiance through the disk-light texture.
//!
//! Also the skeleton every render runs ([`open`], [`report`], [`check_out`],
//! [`compare_and_write`]) and [`VerifiedExport`].

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use glam::DVec3;
use lobefit::export::layout::Filter;
use lobefit_tables::disk_light::DiskLight;
use lobefit_tables::lobe_product::LobeProduct;

use lobefit::export::manifest::TextureEntry;
use lobefit::export::Texture;

use crate::conformance::Export;
use crate::device::{wgsl_texture_type, Gpu};

/// The families `render` reads, and how to export them.
pub const FAMILIES: (&[&str], &str) = (
    &[
        lobefit_tables::disk_light::KIND,
        lobefit_tables::lobe_product::KIND_ENERGY,
    ],
    "disk-light,lobe-product",
);

/// The families `render library --scene` reads, and how to export them.
pub const SCENE_FAMILIES: (&[&str], &str) = (&[lobefit_tables::disk_light::KIND], "disk-light");
use crate::kernel::{kernel, kernel_with, lf_tex};

/// `lobefit-gpu render library`'s options.
#[derive(clap::Parser)]
pub struct Args {
    /// A `lobefit export` directory with the disk-light texture (and lobe-product,
    /// without --scene).
    #[arg(long, value_name = "DIR")]
    export: PathBuf,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// A scene (a built-in name, e.g. meunier-fig13, or a scene file): its
    /// spherical lights' unshadowed irradiance through the disk-light texture,
    /// against the CPU. Without it: the fixed test scene (disk light + glossy pass).
    #[arg(long, value_name = "NAME|FILE")]
    scene: Option<String>,
}

/// `render library`.
pub const RENDER: Render = Render {
    name: LIBRARY,
    about: "the shader library's test image (a sphere and a floor lit by a disk light's SH irradiance, \
            cosine-lobe lights through the lobe product), or a scene's lights through the disk-light texture",
    options: <Args as clap::CommandFactory>::command,
    run: |m| run(parse(m)?),
    bench: None,
};

fn run(a: Args) -> Result<ExitCode, String> {
    check_out(&a.out)?;
    let Some(scene) = a.scene else {
        let (ex, gpu) = open(&a.export, FAMILIES, |_| Ok(()))?;
        let (max, rms, gloss_max) = render(&gpu, &ex, &a.out)?;
        out!(
            "render library: {0}x{0} on {1}; GPU against CPU, relative to the peak: max {max:.2e}, RMS {rms:.2e} \
             (limit {2:.0e} RMS); glossy (lobe-product) pass alone, relative to its peak: max {gloss_max:.2e}",
            SIZE,
            gpu.info.name,
            RMS_LIMIT
        );
        return verdict("render library", rms <= RMS_LIMIT, &a.out);
    };
    let sc = lobefit::pipelines::load_scene(&scene)?;
    let (ex, gpu) = open(&a.export, SCENE_FAMILIES, |_| Ok(()))?;
    let r = render_scene(&gpu, &ex, &sc, &a.out)?;
    out!(
        "render library {scene}: {}x{} ({} pixels see geometry) on {}; GPU against CPU, relative to the peak: \
         max {:.2e}, RMS {:.2e} (limit {:.0e} RMS); CPU (order-3 disk SH) against the exact unshadowed \
         irradiance where every light is above the horizon: max rel {:.2e} at {} pixels",
        SCENE_WIDTH,
        SCENE_WIDTH * 3 / 4,
        r.pixels,
        gpu.info.name,
        r.max,
        r.rms,
        RMS_LIMIT,
        r.vs_exact.0,
        r.vs_exact.1
    );
    verdict("render library", r.rms <= RMS_LIMIT, &a.out)
}

/// A render's skeleton after its own checks: `fits` (the checks that depend on the
/// device's loop budget, [`Gpu::loop_budget`]) under llvmpipe's budget, the strictest;
/// then the export's textures of `families` verified ([`VerifiedExport::open`]), then
/// the device. A scene over llvmpipe's budget opens the device first, and is refused
/// there on a CPU adapter before the export is read; a scene within it reaches the
/// device only with a verified export.
pub fn open(
    export: &Path,
    families: (&[&str], &str),
    fits: impl Fn(Option<u64>) -> Result<(), String>,
) -> Result<(VerifiedExport, Gpu), String> {
    if fits(Some(crate::budget::LOOP_LIMIT)).is_err() {
        let gpu = Gpu::new()?;
        fits(gpu.loop_budget)?;
        return Ok((VerifiedExport::open(export, families)?, gpu));
    }
    let ex = VerifiedExport::open(export, families)?;
    Ok((ex, Gpu::new()?))
}

/// A render's last lines: its image, and `{command} FAILED` (exit 1) unless `pass`.
pub fn verdict(command: &str, pass: bool, out: &Path) -> Result<ExitCode, String> {
    out!("image: {}", out.display());
    if !pass {
        out!("{command} FAILED");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

/// Prints a pipeline render's comparison (`command` and what it rendered, `what`) and
/// its image; exit 1 when the RMS difference exceeds [`RMS_LIMIT`].
pub fn report(command: &str, what: &str, r: &SceneRender, gpu: &Gpu, out: &Path) -> Result<ExitCode, String> {
    out!(
        "{command} {what}: {} pixels see geometry, on {}; GPU against the CPU pipeline, relative to the peak: \
         max {:.2e}, RMS {:.2e} (limit {:.0e} RMS)",
        r.pixels,
        gpu.info.name,
        r.max,
        r.rms,
        RMS_LIMIT
    );
    verdict(command, r.rms <= RMS_LIMIT, out)
}

/// `render NAME --frames N`: the still of `sc` at each time k / (N − 1) rendered by
/// `one(still, out_k)` (out_k: `out` with `-frame-KKK` before its extension, every
/// frame compared with the CPU pipeline on that still), a line per frame with its
/// wall time (the whole render: the dispatch, the read-back and any kernel build — the
/// ISG kernel bakes the blockers, so it builds per frame; the Meunier and SH kernels
/// take the scene as data and build once), then the worst frame's verdict.
pub fn animate(
    command: &str,
    sc: &lobefit::pipelines::scene::Scene,
    frames: usize,
    gpu: &Gpu,
    out: &Path,
    mut one: impl FnMut(&lobefit::pipelines::scene::Scene, &Path) -> Result<SceneRender, String>,
) -> Result<ExitCode, String> {
    if !(2..=lobefit::pipelines::animate::MAX_FRAMES).contains(&frames) {
        return Err(format!(
            "{command} --frames {frames}: an animation has 2 to {} frames",
            lobefit::pipelines::animate::MAX_FRAMES
        ));
    }
    let stem = out
        .file_stem()
        .map_or("frame".into(), |s| s.to_string_lossy().into_owned());
    let (mut worst, mut worst_max) = (0.0f64, 0.0f64);
    // Kernels built by the frames after the first: none, when the scene is data.
    let mut rebuilt = 0;
    for k in 0..frames {
        let time = k as f64 / (frames - 1) as f64;
        let still = sc.at(time)?;
        let path = out.with_file_name(format!("{stem}-frame-{k:03}.png"));
        let t = std::time::Instant::now();
        let before = gpu.kernels_built();
        let r = one(&still, &path)?;
        let built = gpu.kernels_built() - before;
        if k > 0 {
            rebuilt += built;
        }
        out!(
            "{command} {} frame {k} (t = {time:.3}): {} pixels, GPU against the CPU relative to the peak: max {:.2e}, RMS {:.2e}; {:.0} ms (wall: dispatch, read-back, kernel builds: {built})",
            sc.name,
            r.pixels,
            r.max,
            r.rms,
            1e3 * t.elapsed().as_secs_f64()
        );
        worst = worst.max(r.rms);
        worst_max = worst_max.max(r.max);
    }
    if rebuilt > 0 {
        return Err(format!(
            "{command} {}: the frames after the first built {rebuilt} kernels (one compiled kernel should serve every frame)",
            sc.name
        ));
    }
    out!(
        "{command} {}: {frames} frames on {}; worst frame RMS {worst:.2e}, max {worst_max:.2e} (limit {RMS_LIMIT:.0e} RMS)",
        sc.name,
        gpu.info.name
    );
    verdict(
        command,
        worst <= RMS_LIMIT,
        &out.with_file_name(format!("{stem}-frame-000.png")),
    )
}

/// Image side (pixels).
pub const SIZE: usize = 256;
/// Limit on the RMS difference (relative to the image's peak) of the GPU image from
/// the CPU image (the acceptance).
pub const RMS_LIMIT: f64 = 1e-4;

const CENTRE: [f64; 3] = [1.5, 2.5, 1.5];
const RADIUS: f64 = 0.8;
const RADIANCE: f64 = 1.0;
/// The sphere's Phong exponent (lobe about the mirror direction) and glossy weight.
const GLOSS_EXPONENT: f64 = 50.0;
const GLOSS_WEIGHT: f64 = 4.0;
/// Cosine-lobe lights: (axis, not normalised; exponent; scale).
const LIGHTS: [([f64; 3], f64, f64); 2] = [([-1.0, 1.0, 1.0], 200.0, 1.0), ([1.0, 0.3, 2.0], 20.0, 0.3)];

/// The scene's hit point and normal for pixel (i, j), in f64 (the CPU side; the shader
/// repeats it in f32): orthographic rays along (0, −0.5, −1) onto the unit sphere at
/// the origin, else the floor y = −1 (within |x|, |z| ≤ 4).
fn hit(i: usize, j: usize) -> Option<(DVec3, DVec3)> {
    let u = (i as f64 + 0.5) / SIZE as f64 * 4.0 - 2.0;
    let v = 2.0 - (j as f64 + 0.5) / SIZE as f64 * 4.0;
    let o = DVec3::new(u, v + 2.5, 5.0);
    let d = DVec3::new(0.0, -0.5, -1.0).normalize();
    let b = o.dot(d);
    let c = o.dot(o) - 1.0;
    let disc = b * b - c;
    if disc >= 0.0 {
        let p = o + (-b - disc.sqrt()) * d;
        return Some((p, p.normalize()));
    }
    let t = (-1.0 - o.y) / d.y;
    let p = o + t * d;
    (t > 0.0 && p.x.abs() <= 4.0 && p.z.abs() <= 4.0).then_some((p, DVec3::Y))
}

const BODY: &str = "    let px = f32(i % 256u);
    let py = f32(i / 256u);
    let u = (px + 0.5) / 256.0 * 4.0 - 2.0;
    let v = 2.0 - (py + 0.5) / 256.0 * 4.0;
    let ro = vec3<f32>(u, v + 2.5, 5.0);
    let d = normalize(vec3<f32>(0.0, -0.5, -1.0));
    let b = dot(ro, d);
    let c = dot(ro, ro) - 1.0;
    let disc = b * b - c;
    var p = vec3<f32>(0.0);
    var n = vec3<f32>(0.0);
    var hit = false;
    if disc >= 0.0 {
        p = ro + (-b - sqrt(disc)) * d;
        n = normalize(p);
        hit = true;
    } else {
        let t = (-1.0 - ro.y) / d.y;
        p = ro + t * d;
        n = vec3<f32>(0.0, 1.0, 0.0);
        hit = t > 0.0 && abs(p.x) <= 4.0 && abs(p.z) <= 4.0;
    }
    var e = 0.0;
    if hit {
        let centre = vec3<f32>(1.5, 2.5, 1.5);
        e = lf_disk_irradiance(T, S, P, p, n, centre, -normalize(centre), 0.8, 1.0);
    }
    Y[o] = e;";

/// The glossy pass's kernel body (texture `T`: lobe-product, `T2`: its ln W): 0 off
/// the sphere.
fn glossy_body() -> String {
    let lights: String = LIGHTS
        .iter()
        .map(|(a, e, s)| {
            format!(
                "        g += {s:?} * lf_lobe_product(T, S, P, T2, P2, {GLOSS_EXPONENT:?}, {e:?}, \
                 lf_angle_between(r, normalize(vec3<f32>({:?}, {:?}, {:?})))).integral;\n",
                a[0], a[1], a[2]
            )
        })
        .collect();
    format!(
        "    let px = f32(i % 256u);
    let py = f32(i / 256u);
    let u = (px + 0.5) / 256.0 * 4.0 - 2.0;
    let v = 2.0 - (py + 0.5) / 256.0 * 4.0;
    let ro = vec3<f32>(u, v + 2.5, 5.0);
    let d = normalize(vec3<f32>(0.0, -0.5, -1.0));
    let b = dot(ro, d);
    let c = dot(ro, ro) - 1.0;
    let disc = b * b - c;
    var g = 0.0;
    if disc >= 0.0 {{
        let n = normalize(ro + (-b - sqrt(disc)) * d);
        let r = normalize(d - 2.0 * dot(d, n) * n);
{lights}    }}
    Y[o] = {GLOSS_WEIGHT:?} * g;"
    )
}

/// The glossy term on the CPU at pixel (i, j): f64 geometry, the runtime's integral.
fn glossy_cpu(lp: &LobeProduct, i: usize, j: usize) -> Result<f64, String> {
    let Some((p, n)) = hit(i, j) else { return Ok(0.0) };
    if n == DVec3::Y && (p.length() - 1.0).abs() > 1e-9 {
        return Ok(0.0);
    }
    let d = DVec3::new(0.0, -0.5, -1.0).normalize();
    let r = (d - 2.0 * d.dot(n) * n).normalize();
    let mut g = 0.0;
    for (a, e, s) in LIGHTS {
        let l = DVec3::from_array(a).normalize();
        let alpha = 2.0 * (r - l).length().atan2((r + l).length());
        g += s * lp
            .params(GLOSS_EXPONENT, e, alpha)
            .map_err(|e| format!("CPU lobe product at pixel ({i}, {j}): {e}"))?
            .integral;
    }
    Ok(GLOSS_WEIGHT * g)
}

/// Renders on the GPU and the CPU; writes `out` (PNG, 8-bit grey, E / peak, sRGB-ish
/// gamma 1/2.2). Returns (max, RMS) of |gpu − cpu| / peak over the pixels, and the
/// glossy pass's own max |gpu − cpu| / its peak.
pub fn render(gpu: &Gpu, export: &VerifiedExport, out: &Path) -> Result<(f64, f64, f64), String> {
    let m = &export.manifest;
    let (entry, tex) = disk_texture(export)?;
    let up = gpu.upload(tex, m.storage)?;
    let n = SIZE * SIZE;
    let src = kernel(wgsl_texture_type(tex), 0, 1, BODY);
    let mut img = gpu.run(&src, &lf_tex(entry, Filter::Manual)?, &up, &[], n, 1)?;
    let texs = family_textures(export, lobefit_tables::lobe_product::KIND_ENERGY)?;
    let [(e_main, t_main), (e_lnw, t_lnw)] = texs else {
        return Err("lobe-product: the export should hold its table and its ln W texture".into());
    };
    let (up_main, up_lnw) = (gpu.upload(t_main, m.storage)?, gpu.upload(t_lnw, m.storage)?);
    let src = kernel_with(
        wgsl_texture_type(t_main),
        Some(wgsl_texture_type(t_lnw)),
        0,
        1,
        &glossy_body(),
    );
    let lnw_params = lf_tex(e_lnw, Filter::Manual)?;
    let gloss = gpu.run_with(
        &src,
        &lf_tex(e_main, Filter::Manual)?,
        &up_main,
        Some((&lnw_params, &up_lnw)),
        &[],
        n,
        1,
    )?;
    for (a, g) in img.iter_mut().zip(&gloss) {
        *a += g;
    }
    let disk = DiskLight::embedded().map_err(|e| e.to_string())?;
    let lp = LobeProduct::embedded().map_err(|e| e.to_string())?;
    let centre = DVec3::from_array(CENTRE);
    let mut cpu = vec![0.0f64; n];
    let mut cpu_gloss = vec![0.0f64; n];
    for j in 0..SIZE {
        for i in 0..SIZE {
            if let Some((p, nrm)) = hit(i, j) {
                cpu[j * SIZE + i] = disk
                    .irradiance(p, nrm, centre, -centre.normalize(), RADIUS, RADIANCE)
                    .map_err(|e| format!("CPU irradiance at pixel ({i}, {j}): {e}"))?;
            }
            cpu_gloss[j * SIZE + i] = glossy_cpu(lp, i, j)?;
            cpu[j * SIZE + i] += cpu_gloss[j * SIZE + i];
        }
    }
    let peak = cpu.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let (mut max, mut sum) = (0.0f64, 0.0);
    for (g, c) in img.iter().zip(&cpu) {
        let d = (*g as f64 - c).abs() / peak;
        max = max.max(d);
        sum += d * d;
    }
    let rms = (sum / n as f64).sqrt();
    let gloss_peak = cpu_gloss.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let gloss_max = gloss
        .iter()
        .zip(&cpu_gloss)
        .map(|(g, c)| (*g as f64 - c).abs() / gloss_peak)
        .fold(0.0, f64::max);
    let pixels: Vec<u8> = img.iter().map(|&g| grey(g as f64 / peak)).collect();
    write_grey_png(out, SIZE, SIZE, &pixels)?;
    Ok((max, rms, gloss_max))
}

/// Scene renders: image width (height 3/4 of it).
pub const SCENE_WIDTH: usize = 128;

/// What [`render_scene`] measured.
pub struct SceneRender {
    /// Pixels that see geometry.
    pub pixels: usize,
    /// Largest and RMS |GPU − CPU| / the CPU image's peak.
    pub max: f64,
    /// See `max`.
    pub rms: f64,
    /// Largest |CPU / exact − 1| where every light is whole above the horizon (the
    /// disk table's order-3 SH against π L sin²α cos β), and at how many pixels.
    pub vs_exact: (f64, usize),
    /// The device's values at the pixels that see geometry, row by row.
    pub values: Vec<f64>,
}

/// A scene file (or built-in scene, `lobefit::pipelines::scene`) through the shader
/// library: camera, spheres and planes from the scene; each spherical light as the
/// disk of the same solid angle facing the point (radius R d / √(d² − R²)), its
/// unshadowed irradiance by `lf_disk_irradiance` on the exported disk-light texture.
/// Primary visibility is traced on the CPU (the scene layer's BVH); the GPU shades
/// every visible pixel; the CPU computes the same with `DiskLight::irradiance` (f64,
/// the committed table). Writes `out` (PNG, E / peak, gamma 1/2.2).
pub fn render_scene(
    gpu: &Gpu,
    export: &VerifiedExport,
    sc: &lobefit::pipelines::scene::Scene,
    out: &Path,
) -> Result<SceneRender, String> {
    let m = &export.manifest;
    let (entry, tex) = disk_texture(export)?;
    let up = gpu.upload(tex, m.storage)?;
    let (w, h) = (SCENE_WIDTH, SCENE_WIDTH * 3 / 4);
    let hits = primary_hits(sc, (w, h))?;
    let visible: Vec<&lobefit::pipelines::scene::Hit> = hits.iter().flatten().collect();
    let f = |v: f64| format!("{:e}", v as f32);
    let lights: String = sc
        .lights
        .iter()
        .map(|l| {
            let c = l.sphere.centre;
            format!(
                "    {{\n        let c = vec3<f32>({}, {}, {});\n        let to = c - p;\n        let d = length(to);\n        \
                 let r = {};\n        let rho = r * d / sqrt(max(d * d - r * r, 1e-30));\n        \
                 e += lf_disk_irradiance(T, S, P, p, n, c, -to / d, rho, {});\n    }}\n",
                f(c.x),
                f(c.y),
                f(c.z),
                f(l.sphere.radius),
                f(l.radiance)
            )
        })
        .collect();
    let body = format!(
        "    let p = vec3<f32>(x0, x1, x2);\n    let n = vec3<f32>(x3, x4, x5);\n    var e = 0.0;\n{lights}    Y[o] = e;"
    );
    let inputs: Vec<f32> = visible
        .iter()
        .flat_map(|h| [h.x.x, h.x.y, h.x.z, h.n.x, h.n.y, h.n.z].map(|v| v as f32))
        .collect();
    let src = kernel(wgsl_texture_type(tex), 6, 1, &body);
    let got = gpu.run(&src, &lf_tex(entry, Filter::Manual)?, &up, &inputs, visible.len(), 1)?;
    let disk = DiskLight::embedded().map_err(|e| e.to_string())?;
    let (mut cpu, mut worst_exact, mut exact_n) = (Vec::with_capacity(visible.len()), 0.0f64, 0);
    for h in &visible {
        // The same f32 inputs the GPU got.
        let p = h.x.as_vec3().as_dvec3();
        let n = h.n.as_vec3().as_dvec3();
        let mut e = 0.0;
        let mut exact = Some(0.0);
        for l in &sc.lights {
            let c = l.sphere.centre.as_vec3().as_dvec3();
            let r = f64::from(l.sphere.radius as f32);
            let to = c - p;
            let d = to.length();
            let rho = r * d / (d * d - r * r).max(1e-30).sqrt();
            e += disk
                .irradiance(p, n, c, -to / d, rho, f64::from(l.radiance as f32))
                .map_err(|err| format!("CPU disk irradiance: {err}"))?;
            exact = exact
                .zip(lobefit::pipelines::meunier::direct_light::unoccluded_closed_form(
                    p, n, l,
                ))
                .map(|(a, b)| a + b);
        }
        if let Some(x) = exact.filter(|&x| x > 0.0) {
            worst_exact = worst_exact.max((e / x - 1.0).abs());
            exact_n += 1;
        }
        cpu.push(e);
    }
    let r = compare_and_write(&got, &cpu, hits.iter().map(Option::is_some), (w, h), out)?;
    Ok(SceneRender {
        vs_exact: (worst_exact, exact_n),
        ..r
    })
}

/// The GPU's values `got` at the pixels that see geometry (`seen`, row by row over the
/// w × h image) against the CPU's `cpu` at the same pixels: (max, RMS) of |GPU − CPU| /
/// the CPU image's peak, a non-finite GPU value counting as infinitely wrong (NaN would
/// pass unseen); writes `out` (PNG, value / peak, gamma 1/2.2, background black).
/// `vs_exact` is left unmeasured (NaN).
/// The image size the renders and the Monte Carlo use for `width`: `width` × 3/4 of
/// it, at least 4 × 3.
pub(crate) fn image_size(width: usize) -> (usize, usize) {
    (width.max(4), (width * 3 / 4).max(3))
}

/// Each pixel's primary hit in the `w` × `h` image `sc`'s camera sees, or an error
/// when its camera is invalid or no pixel sees geometry.
pub(crate) fn primary_hits(
    sc: &lobefit::pipelines::scene::Scene,
    (w, h): (usize, usize),
) -> Result<Vec<Option<lobefit::pipelines::scene::Hit>>, String> {
    sc.check_camera()?;
    let hits: Vec<_> = (0..w * h).map(|p| sc.primary(p % w, p / w, w, h)).collect();
    if hits.iter().all(Option::is_none) {
        return Err(format!("{}: no pixel of the {w}×{h} image sees geometry", sc.name));
    }
    Ok(hits)
}

pub(crate) fn compare_and_write(
    got: &[f32],
    cpu: &[f64],
    seen: impl IntoIterator<Item = bool>,
    (w, h): (usize, usize),
    out: &Path,
) -> Result<SceneRender, String> {
    let peak = cpu.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(f64::MIN_POSITIVE);
    let (mut max, mut sum) = (0.0f64, 0.0);
    for (g, c) in got.iter().zip(cpu) {
        let d = if g.is_finite() {
            (f64::from(*g) - c).abs() / peak
        } else {
            f64::INFINITY
        };
        max = max.max(d);
        sum += d * d;
    }
    let rms = (sum / cpu.len().max(1) as f64).sqrt();
    let mut image = vec![0u8; w * h];
    let mut it = got.iter();
    for (px, s) in image.iter_mut().zip(seen) {
        if s {
            *px = grey(f64::from(*it.next().unwrap_or(&0.0)) / peak);
        }
    }
    write_grey_png(out, w, h, &image)?;
    Ok(SceneRender {
        pixels: cpu.len(),
        max,
        rms,
        vs_exact: (f64::NAN, 0),
        values: got.iter().map(|&v| f64::from(v)).collect(),
    })
}

/// An export whose textures of the families a render reads were verified texel for
/// texel (the one way the renders get at an export's textures).
pub struct VerifiedExport {
    export: Export,
    families: Vec<String>,
}

impl std::ops::Deref for VerifiedExport {
    type Target = Export;
    fn deref(&self) -> &Export {
        &self.export
    }
}

impl VerifiedExport {
    /// Reads the export at `dir` and verifies its textures of `families` (an error
    /// saying how to export them, `--only <only>`, where one is missing): each is
    /// rebuilt from this lobefit's tables at the manifest's storage and scale, as
    /// `lobefit check --export` does, and must equal the file in layout and every
    /// texel. An export that fails is refused with the texture and the count of
    /// texels that differ.
    pub fn open(dir: &Path, (families, only): (&[&str], &str)) -> Result<VerifiedExport, String> {
        let export = crate::conformance::read_export(dir)?;
        let m = &export.manifest;
        for &kind in families {
            let texs = export
                .manifest
                .families
                .iter()
                .position(|f| f.family == kind)
                .and_then(|k| export.textures.get(k))
                .filter(|t| !t.is_empty())
                .ok_or_else(|| {
                    format!(
                        "{}: the export has no {kind} texture (export it: --only {only})",
                        dir.display()
                    )
                })?;
            lobefit::export::run::verify_family_texels(dir, m, kind, texs)?;
        }
        Ok(VerifiedExport {
            export,
            families: families.iter().map(|f| f.to_string()).collect(),
        })
    }
}

/// The textures of family `kind` in `export` (at least one); `kind` must be one of the
/// families `export` was verified for.
pub(crate) fn family_textures<'a>(
    export: &'a VerifiedExport,
    kind: &str,
) -> Result<&'a [(TextureEntry, Texture)], String> {
    if !export.families.iter().any(|f| f == kind) {
        return Err(format!(
            "the render reads {kind}, which its export was not verified for"
        ));
    }
    export
        .manifest
        .families
        .iter()
        .position(|f| f.family == kind)
        .and_then(|k| export.textures.get(k))
        .filter(|t| !t.is_empty())
        .map(Vec::as_slice)
        .ok_or_else(|| format!("the export has no {kind} texture"))
}

/// The export's disk-light texture (the first of its family).
fn disk_texture(export: &VerifiedExport) -> Result<(&TextureEntry, &Texture), String> {
    let (entry, tex) = &family_textures(export, lobefit_tables::disk_light::KIND)?[0];
    Ok((entry, tex))
}

/// Refuses an output path the render could not write, before it renders: its parent
/// directory must exist (nothing is created), and the path must not be a directory.
/// A symlink at the path is replaced, never followed.
pub fn check_out(out: &Path) -> Result<(), String> {
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    match std::fs::metadata(parent) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => {
            return Err(format!(
                "--out {}: {} is not a directory",
                out.display(),
                parent.display()
            ))
        }
        Err(e) => {
            let dangling = std::fs::symlink_metadata(parent).is_ok_and(|m| m.file_type().is_symlink());
            return Err(format!(
                "--out {}: its directory {} {}",
                out.display(),
                parent.display(),
                if dangling {
                    "is a dangling symbolic link".to_string()
                } else {
                    format!("cannot be used ({e}); the directory must exist")
                }
            ));
        }
    }
    if out.file_name().is_none() {
        return Err(format!("--out {}: names no file", out.display()));
    }
    if std::fs::metadata(out).is_ok_and(|m| m.is_dir()) {
        return Err(format!("--out {}: is a directory; name the PNG file", out.display()));
    }
    Ok(())
}

/// An 8-bit grey level of `v` in [0, 1] (clamped), gamma 1/2.2.
pub(crate) fn grey(v: f64) -> u8 {
    (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8
}

/// Writes a w × h 8-bit grey PNG atomically (a symlink planted at `out` is replaced,
/// never followed).
pub(crate) fn write_grey_png(out: &Path, w: usize, h: usize, pixels: &[u8]) -> Result<(), String> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, w as u32, h as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .and_then(|mut wr| wr.write_image_data(pixels))
        .map_err(|e| format!("{}: {e}", out.display()))?;
    lobefit::io::write_atomic(out, &bytes).map_err(|e| format!("cannot write {}: {e}", out.display()))
}

/// The WGSL of the own-proxy rule ([`lobefit::pipelines::scene::Own`]) the kernels
/// share: `own_proxy(b, own, d, r)` says whether blocker `b` (radius `r`, its centre `d`
/// from the point) is one of the point's own — in its range `[own.x, own.y)` (its
/// sphere, or its mesh's set) and containing the point or passing within
/// `OWN_MARGIN` × its radius of it — and so no blocker.
pub fn own_proxy_wgsl() -> String {
    format!(
        "const OWN_SCALE: f32 = {:e};\n\
         fn own_proxy(b: u32, own: vec2<i32>, d: f32, r: f32) -> bool {{\n    \
         return i32(b) >= own.x && i32(b) < own.y && d <= r * OWN_SCALE;\n}}\n",
        (1.0 + lobefit::pipelines::scene::OWN_MARGIN) as f32
    )
}

/// A sphere hierarchy's nodes as the ISG and SH kernels read them (`node(k, j)`: 16 f32
/// a node, root last): its reach, its bound, the sphere the cut gives for it, and (left, right), or
/// (−1, the leaf's sphere index in the set).
pub fn tree_inputs(tree: &lobefit::pipelines::spheres::tree::SphereTree) -> Vec<f32> {
    let mut v = Vec::new();
    for (reach, bound, given, kids) in tree.node_data() {
        for s in [reach, bound, given] {
            v.extend([s.centre.x, s.centre.y, s.centre.z, s.radius].map(|x| x as f32));
        }
        let (a, b) = match kids {
            Ok((a, b)) => (a as f32, b as f32),
            Err(leaf) => (-1.0, leaf as f32),
        };
        v.extend([a, b, 0.0, 0.0]);
    }
    v
}

/// The sphere hierarchy's walk the ISG and SH kernels share (`render isg --cut`,
/// `render shexp --cut`): `cut_next` pops the kernel's stack until the cut gives a
/// sphere, as the CPU's `SphereTree::cut` (and `cut_in_cone`, given a cone) does. The
/// kernel defines `node(k, j)` ([`tree_inputs`]' layout) and takes
/// [`own_proxy_wgsl`]'s `OWN_SCALE`.
pub fn cut_walk_wgsl() -> &'static str {
    "// What the walk gives: a sphere (state 0: the leaf's set index in b, 0xffffffff for a
// stand-in), or nothing more (1), or it passed its budget (2).
struct CutNext {
    s: vec4<f32>,
    b: u32,
    state: u32,
}

// Whether the ball c (centre, radius) lies wholly outside the cone of axis z and
// half-angle cone (cos, sin in cs) from x: by cosines, 1e-5 inside the bound (f32's
// rounding), and never for a cone wider than pi / 2 (the CPU's ConeTest::outside, a
// little looser: a subtree it keeps is tested sphere by sphere after).
fn cut_outside(c: vec4<f32>, x: vec3<f32>, z: vec3<f32>, cone: f32, cs: vec2<f32>) -> bool {
    let w = c.xyz - x;
    let d = length(w);
    if d <= c.w || cone > 0.5 * LF_PI {
        return false;
    }
    let sd = c.w / d;
    return dot(w / d, z) < cs.x * sqrt(max(1.0 - sd * sd, 0.0)) - cs.y * sd - 1e-5;
}

// The cut's next sphere from x: a leaf, or the stand-in of a node whose bound subtends
// less than asin(sin_cut) from outside it (the own-sphere margin); a subtree whose reach
// lies outside the cone (z, cone, cs; a cone wider than pi / 2 culls nothing) skipped.
// Each pass adds 1 to *walk; past `budget` the walk stops (llvmpipe's loop budget).
fn cut_next(stack: ptr<function, array<u32, 64>>, sp: ptr<function, u32>, walk: ptr<function, u32>, budget: u32,
            x: vec3<f32>, sin_cut: f32, z: vec3<f32>, cone: f32, cs: vec2<f32>) -> CutNext {
    var out = CutNext(vec4<f32>(0.0), 0xffffffffu, 1u);
    loop {
        *walk += 1u;
        if *walk > budget {
            out.state = 2u;
            break;
        }
        if *sp == 0u {
            break;
        }
        *sp -= 1u;
        let kn = (*stack)[*sp];
        if cut_outside(node(kn, 0u), x, z, cone, cs) {
            continue;
        }
        let kids = node(kn, 3u);
        if kids.x < 0.0 {
            out = CutNext(node(kn, 2u), u32(kids.y), 0u);
            break;
        }
        let bd = node(kn, 1u);
        let dd = length(x - bd.xyz);
        if dd > bd.w * OWN_SCALE && bd.w < sin_cut * dd {
            out = CutNext(node(kn, 2u), 0xffffffffu, 0u);
            break;
        }
        (*stack)[*sp] = u32(kids.y);
        (*stack)[*sp + 1u] = u32(kids.x);
        *sp += 2u;
    }
    return out;
}
"
}

/// The range of the point's own proxies, as a kernel's two f32 inputs (first, end).
pub fn own_range(sc: &lobefit::pipelines::scene::Scene, hit: &lobefit::pipelines::scene::Hit) -> [f32; 2] {
    let r = sc.own_proxies(hit).range();
    [r.start as f32, r.end as f32]
}

/// One device render.
#[derive(Debug)]
pub struct Render {
    /// `render NAME`'s name: a pipeline's registry name, or [`LIBRARY`].
    pub name: &'static str,
    /// One line for `lobefit-gpu render --help` and its own `--help`.
    pub about: &'static str,
    /// Its options, as a clap command (`<Args as clap::CommandFactory>::command`).
    pub options: fn() -> clap::Command,
    /// Runs it on its parsed options (read back with [`parse`]).
    pub run: fn(&clap::ArgMatches) -> Result<ExitCode, String>,
    /// What `lobefit-gpu bench` runs of it (`None`: not benched).
    pub bench: Option<Bench>,
}

/// A device render's part in `lobefit-gpu bench` (`crate::bench`): its kernel timed
/// on a scene, and its image beside the device's Monte Carlo.
#[derive(Debug)]
pub struct Bench {
    /// Its place in the bench's report: rows and Monte Carlo sections by rank.
    pub rank: u8,
    /// The scene benched when `--scene` names none for it.
    pub scene: &'static str,
    /// Whether `--scene` may name another scene (the rigs render has one).
    pub any_scene: bool,
    /// The export families its kernel reads, and how to export them (as
    /// [`open`] takes them; `None`: no texture).
    pub families: Option<(&'static [&'static str], &'static str)>,
    /// One kernel benched on `scene` at `width` (the export verified for
    /// [`Bench::families`], the image into `png`).
    pub kernel: BenchKernel,
}

/// [`Bench::kernel`]: gpu, export, scene, width, png.
pub type BenchKernel = fn(&Gpu, Option<&VerifiedExport>, &str, usize, &Path) -> Result<Benched, String>;

/// One kernel benched.
pub struct Benched {
    /// Its method in words.
    pub method: String,
    /// Its frames timed ([`crate::bench::timed`]).
    pub timed: crate::bench::Timed,
    /// Its image for the device's Monte Carlo beside it: `None` where the bench runs
    /// none beside it (or the scene is one the device's Monte Carlo does not trace).
    pub image: Option<AnalyticImage>,
}

/// A kernel's image of a scene, for the device's Monte Carlo beside it.
pub struct AnalyticImage {
    /// The scene.
    pub scene: lobefit::pipelines::scene::Scene,
    /// The image over the pixels that see geometry.
    pub values: Vec<f64>,
    /// Its integrands at hits, where the kernel serves as the hybrid's control
    /// variate (gpu, export, scene, hits).
    pub integrands: Option<BenchIntegrands>,
}

/// [`AnalyticImage::integrands`].
pub type BenchIntegrands = fn(
    &Gpu,
    &VerifiedExport,
    &lobefit::pipelines::scene::Scene,
    &[&lobefit::pipelines::scene::Hit],
) -> Result<crate::mc::ControlVariate, String>;

impl Render {
    /// `render NAME` as a clap subcommand.
    pub fn command(&self) -> clap::Command {
        (self.options)().name(self.name).about(self.about)
    }
}

/// The shader library's test image: the one render that is no pipeline of the registry.
pub const LIBRARY: &str = "library";

/// A render's options `A` from its `matches`.
pub fn parse<A: clap::FromArgMatches>(matches: &clap::ArgMatches) -> Result<A, String> {
    A::from_arg_matches(matches).map_err(|e| e.to_string())
}
