//! `lobefit-gpu render shexp`: the SH-exponentiation pipeline (`lobefit::pipelines::shexp`)
//! as one compute kernel per pixel, on the exported wedge and shexp textures, against
//! the CPU pipeline's image (docs/shexp-render.md).
//!
//! The CPU finds each pixel's hit and its W horizon elevations (the pyramid march or
//! the exact horizon, per `Settings::horizon`) and passes them in the input buffer with
//! the material's Phong parameters; the kernel does the rest of the CPU's
//! `shade::radiance` in f32: the height field's wedges (`lf_wedge_compose`), every
//! sphere blocker (the spheres and the meshes' sphere sets) but those the hit lies on
//! or in, 0 for a point buried in another (`lf_log_zh_blocker`, or Ren's log `lf_shexp`,
//! turned by `lf_zh_to_sh`), per BRDF term its log-ZH lobe (`lf_log_zh_diffuse`,
//! `lf_log_zh_phong`), HYB (`lf_shexp_hyb`) and the dot product with the light's SH
//! vector. The settings' values become the kernel's constants, read from
//! `Settings::default()` at run time. The scene (the blockers' count, whether a height
//! field is present, the spheres and the meshes' sphere sets, the light) follows the
//! pixels in the input buffer, so the kernel's source depends on the settings alone:
//! one compiled kernel serves every scene, every frame of an animation and every image
//! size (no build per frame). llvmpipe
//! ends an invocation's loops after 65 535 iterations in all: the loop over the
//! spheres is bounded before dispatch and the budget checked after it
//! (`crate::budget`).

use std::f64::consts::TAU;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use lobefit::export::layout::Filter;
use lobefit::export::{manifest::TextureEntry, Texture};
use lobefit::pipelines::scene::{Hit, Scene};
use lobefit::pipelines::shexp::light_sh;
use lobefit::pipelines::shexp::shade::{
    radiance, BlockerLog, BrdfMode, ExactCaps, Exp, Horizon, Overlap, Settings, Tables,
};
use lobefit::pipelines::sky::Phong;
use lobefit_tables::glam::DVec3;

use crate::budget;
use crate::device::Gpu;
use crate::kernel::{kernel_textures, lf_tex, split};
use crate::render::{compare_and_write, family_textures, SceneRender, VerifiedExport};
use crate::render::{parse, Render};

/// `lobefit-gpu render shexp`'s options.
#[derive(clap::Parser)]
pub struct Args {
    /// A `lobefit export` directory with wedge and shexp.
    #[arg(long, value_name = "DIR")]
    export: PathBuf,
    /// A built-in shexp scene (whale, whale-diffuse, wrecking) or a scene file.
    #[arg(long, default_value = "whale")]
    scene: String,
    /// Image width (height 3/4 of it).
    #[arg(long, default_value_t = WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
    width: u32,
    /// The sphere blockers' log: the ε-floored closed form or Ren's (the shexp-n4
    /// texture); default: the CPU pipeline's default.
    #[arg(long, value_parser = ["eps", "ren"])]
    blocker_log: Option<String>,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// Render an animated scene as N frames (times 0 to 1), each against the CPU
    /// pipeline; the frames go to OUT's stem with `-frame-KKK.png`.
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=240))]
    frames: Option<u32>,
    /// Take the blockers through the sphere hierarchy's cut at this angle (degrees, 0
    /// to 90; docs/meshes.md, "In SH exponentiation"), the CPU pipeline too
    /// (`Settings::cut`).
    #[arg(long, value_name = "DEGREES", value_parser = parse_cut)]
    cut: Option<f64>,
}

/// `--cut`: finite degrees in (0, 90].
fn parse_cut(v: &str) -> Result<f64, String> {
    match v.parse::<f64>() {
        Ok(d) if d > 0.0 && d <= 90.0 => Ok(d),
        _ => Err(format!("{v}: the cut angle is degrees in (0, 90]")),
    }
}

/// `render shexp`.
pub const RENDER: Render = Render {
    name: "shexp",
    about: "the SH-exponentiation pipeline per pixel on the GPU (the exported wedge and shexp textures; hits \
            and horizon angles from the CPU) against the CPU pipeline's image at its default settings \
            (docs/shexp-render.md)",
    options: <Args as clap::CommandFactory>::command,
    run: |m| run(parse(m)?),
    bench: Some(crate::render::Bench {
        rank: 1,
        scene: "whale",
        any_scene: true,
        families: Some(FAMILIES),
        kernel: bench_kernel,
    }),
};

fn run(a: Args) -> Result<ExitCode, String> {
    let mut settings = Settings::default();
    match a.blocker_log.as_deref() {
        Some("eps") => settings.blocker_log = BlockerLog::Eps,
        Some("ren") => settings.blocker_log = BlockerLog::Ren,
        _ => {}
    }
    if let Some(d) = a.cut {
        settings.cut = d.to_radians();
    }
    crate::render::check_out(&a.out)?;
    let sc = lobefit::pipelines::shexp::render::scene(&a.scene)?;
    let (ex, gpu) = crate::render::open(&a.export, FAMILIES, |budget| {
        check_budget(budget, &sc, "render shexp", settings.cut > 0.0)
    })?;
    if let Some(n) = a.frames {
        return crate::render::animate("render shexp", &sc, n as usize, &gpu, &a.out, |still, path| {
            render_shexp(&gpu, &ex, still, a.width as usize, &settings, path)
        });
    }
    let r = render_shexp(&gpu, &ex, &sc, a.width as usize, &settings, &a.out)?;
    let what = format!("{} ({:?} blocker log)", a.scene, settings.blocker_log);
    crate::render::report("render shexp", &what, &r, &gpu, &a.out)
}

/// Default image width (height 3/4 of it).
pub const WIDTH: u32 = 64;

/// The SH order the kernel supports (the library's SH product is order ≤ 4).
const ORDER: usize = 4;

/// Per pixel before the horizon angles: point, normal, view, k_d, k_s, Phong
/// exponent, the blockers the point lies on or in (`Scene::own_proxies`: first, end).
const HIT_INPUTS: usize = 14;

/// The families render shexp reads, and how to export them.
pub const FAMILIES: (&[&str], &str) = (
    &[lobefit_tables::wedge::KIND, lobefit_tables::shexp::KIND],
    "wedge,shexp",
);

/// Loop iterations per sphere blocker, at most: the sphere loop's own and its body's
/// loops (`lf_asin`'s series, the blocker's log-ZH, the attenuation, the sum).
/// Measured on llvmpipe (Mesa 22.3) when the body also evaluated `lf_zh_to_sh`'s
/// recurrence (now the library's `lf_zh_to_sh16`, no loop): a scene of 600 spheres ran
/// within the budget, one of 650 spent it (so ≤ 109 per sphere then; an upper bound
/// now).
const PER_SPHERE: u64 = 112;

/// Loop iterations per pixel besides the spheres', at most: the wedge operator's
/// 16 × 4 × 2 entries read (80), then per wedge (W ≤ 64, and the loop's exit) its
/// slice's two Legendre recurrences and difference, the operator's 16 × 4
/// products, the rotation's bands (101 with every loop counted as if not unrolled);
/// per BRDF term its log-ZH lobe, HYB (≤ 64 halvings and squarings) and the sums;
/// with the integrand written, its sums and stores.
const PER_PIXEL: u64 = 80 + 65 * 101 + 5 + 2 * (150 + 25 + 17 + 3 * 16 + 2 * 65 + 17) + 3 * 17;

/// Refuses a scene whose pixels may need more loop iterations than `budget` (a
/// device's [`Gpu::loop_budget`]: llvmpipe's; a GPU has none).
pub fn check_budget(budget: Option<u64>, scene: &Scene, command: &str, cut: bool) -> Result<(), String> {
    if cut {
        // The walk takes what the rest leaves (`walk_budget`), and stops itself.
        return match walk_budget(budget) {
            w if w >= PER_SPHERE * 8 => Ok(()),
            w => Err(format!(
                "{command}: the pixel's other loops leave the hierarchy's walk {w} iterations"
            )),
        };
    }
    budget::refuse_over(
        budget,
        command,
        iterations(scene.proxies.len()),
        &format!("{} spheres", scene.proxies.len()),
    )
}

/// The kernel's flag where the hierarchy's walk passed its budget.
const FLAG_WALK: f32 = 3.0;

/// The iterations the hierarchy's walk may take a pixel on a device with loop budget
/// `budget` (its passes, and [`PER_SPHERE`] for each blocker it gives): what the
/// pixel's other loops leave of llvmpipe's budget, less 64; unbounded on a GPU.
fn walk_budget(budget: Option<u64>) -> u64 {
    budget.map_or(u64::from(u32::MAX), |b| b.saturating_sub(iterations(0) + 64))
}

/// An upper bound on the loop iterations of one pixel's kernel (`crate::budget`):
/// the loop over the blockers (the buried test is in it; counted as a loop of its own
/// as it once was).
pub fn iterations(spheres: usize) -> u64 {
    PER_PIXEL + (spheres as u64 + 1) + PER_SPHERE * (spheres as u64 + 1) + 2
}

/// The export's texture of family `kind` whose file is `stem`.<extension>.
fn texture<'a>(export: &'a VerifiedExport, kind: &str, stem: &str) -> Result<(&'a TextureEntry, &'a Texture), String> {
    family_textures(export, kind)?
        .iter()
        .find(|(e, _)| e.file.split('.').next() == Some(stem))
        .map(|(e, t)| (e, t))
        .ok_or_else(|| format!("the export's {kind} family has no texture {stem}"))
}

/// What of `s` the kernel does not do, as an error.
fn supported(s: &Settings) -> Result<(), String> {
    s.validate()?;
    if s.order != ORDER {
        return Err(format!(
            "render shexp runs SH order {ORDER} only (the shader library's SH product); the settings ask for {}",
            s.order
        ));
    }
    if s.exp != Exp::Hyb {
        return Err(format!(
            "render shexp exponentiates by HYB with the table's a, b only; the settings ask for {:?}",
            s.exp
        ));
    }
    if s.overlap != Overlap::Off {
        return Err("render shexp runs without the overlap weighting; the settings ask for it".into());
    }
    if s.brdf != BrdfMode::Log {
        return Err("render shexp adds the BRDF as log-ZH lobes only; the settings ask for the triple product".into());
    }
    if s.blocker_bands[..ORDER] != [1.0; ORDER] {
        return Err(
            "render shexp takes the blockers' log-ZH vectors as they are; the settings ask for band factors".into(),
        );
    }
    if s.exact_caps != ExactCaps::Off {
        return Err("render shexp keeps every cap in the log sum; the settings ask for exact caps".into());
    }
    Ok(())
}

/// The kernel's functions and body (gpu/shaders/shexp.wgsl).
const SHADER: &str = include_str!("../shaders/shexp.wgsl");

/// The kernel's constants and functions, and its body, for the settings `s`: the
/// scene is data (it follows the pixels' inputs), so one kernel serves every scene.
/// With `coeffs`, each pixel also writes its integrand ([`integrands`]).
fn source(s: &Settings, coeffs: bool, cut: Option<(usize, u64)>) -> String {
    let w = s.wedges as usize;
    let n_in = HIT_INPUTS + w;
    let f = |v: f64| format!("{:e}", v as f32);
    let blocker = match s.blocker_log {
        BlockerLog::Eps => "lf_log_zh_blocker(EPS_VIS, theta, 4u)",
        BlockerLog::Ren => "lf_shexp(T3, S, P3, 4u, theta).f",
    };
    let consts = format!(
        "const N_IN = {n_in}u;\nconst NW = {w}u;\nconst W_INDEX = {}u;\n\
         const TERRAIN_ABOVE_TANGENT = {};\nconst ATTENUATION = {};\nconst EPS_VIS: f32 = {};\n\
         const EPS_TERRAIN: f32 = {};\nconst EPS_BRDF: f32 = {};\nconst COEFFS = {coeffs};\n\
         const CUT = {};\nconst NN = {}u;\nconst SIN_CUT: f32 = {};\nconst WALK_BUDGET = {}u;\n{}",
        s.wedges.trailing_zeros() - 2,
        s.terrain_above_tangent,
        s.attenuation,
        f(s.eps_vis),
        f(s.eps_terrain),
        f(s.eps_brdf),
        cut.is_some(),
        cut.map_or(0, |c| c.0),
        f(s.cut.clamp(0.0, std::f64::consts::FRAC_PI_2).sin()),
        cut.map_or(0, |c| c.1),
        crate::render::own_proxy_wgsl() + crate::render::cut_walk_wgsl()
    );
    let (functions, body) = split(SHADER);
    let body = body
        .replacen("HIT_INPUTS_", &HIT_INPUTS.to_string(), 1)
        .replacen("BLOCKER_LOG_", blocker, 1)
        .replacen("PER_SPHERE_", &PER_SPHERE.to_string(), 1)
        + budget::SENTINEL
        + "    Y[o + 1u] = budget_flag;";
    // T: wedge, T2: shexp-hyb-n4, T3: shexp-n4 (Ren's log only).
    let mut textures = vec!["texture_3d<f32>", "texture_2d<f32>"];
    if s.blocker_log == BlockerLog::Ren {
        textures.push("texture_2d_array<f32>");
    }
    kernel_textures(&textures, n_in, outputs(coeffs), &body) + &consts + functions
}

/// Outputs per pixel: the radiance and the budget flag; with the integrand, its
/// unclamped value and 16 coefficients.
fn outputs(coeffs: bool) -> usize {
    if coeffs {
        19
    } else {
        2
    }
}

/// The W horizon elevations (rad) at `h` as the CPU pipeline finds them.
fn horizons(scene: &Scene, s: &Settings, h: &Hit) -> Vec<f64> {
    let Some((hf, _)) = &scene.heightfield else {
        return vec![0.0; s.wedges as usize];
    };
    (0..s.wedges)
        .map(|k| {
            let phi = TAU * k as f64 / s.wedges as f64;
            match s.horizon {
                Horizon::Exact => hf.horizon_exact(h.x.x, h.x.y, h.x.z, phi),
                Horizon::Pyramid => hf.horizon_pyramid(h.x.x, h.x.y, h.x.z, phi),
            }
        })
        .collect()
}

/// Renders `scene` (a built-in shexp scene or file) at `width` on the GPU and the CPU
/// with the pipeline's settings `s`; writes `out` (PNG, radiance / peak, gamma 1/2.2).
pub fn render_shexp(
    gpu: &Gpu,
    export: &VerifiedExport,
    sc: &Scene,
    width: usize,
    s: &Settings,
    out: &Path,
) -> Result<SceneRender, String> {
    let (w, h) = crate::render::image_size(width);
    let hits = crate::render::primary_hits(sc, (w, h))?;
    let visible: Vec<&Hit> = hits.iter().flatten().collect();
    let light = light_sh(sc, ORDER)?;
    let Dispatched {
        got, at_hits, brdfs, ..
    } = dispatch(gpu, export, sc, &visible, s, false)?;
    // The CPU pipeline (f64, the committed tables) at the same f32-rounded hits.
    let tables = Tables::embedded()?;
    let cpu: Vec<f64> = at_hits
        .iter()
        .zip(&brdfs)
        .map(|(at, b)| radiance(&tables, s, &light, b, sc, at))
        .collect::<Result<_, _>>()?;
    let values: Vec<f32> = got.chunks(2).map(|c| c[0]).collect();
    if s.cut > 0.0 {
        cut_against_flat(gpu, export, sc, &visible, s, &values)?;
    }
    compare_and_write(&values, &cpu, hits.iter().map(Option::is_some), (w, h), out)
}

/// With `Settings::cut`: the kernel's time through the cut against the flat set's on
/// the same pixels (each kernel built before it is timed; the dispatch and read-back,
/// wall clock, medians of 3), and the cut's image against the flat one; where the flat
/// kernel does not fit the device's loop budget, says so.
fn cut_against_flat(
    gpu: &Gpu,
    export: &VerifiedExport,
    sc: &Scene,
    visible: &[&Hit],
    s: &Settings,
    values: &[f32],
) -> Result<(), String> {
    let median = |s: &Settings| -> Result<(f64, Vec<f32>), String> {
        let mut ms = Vec::new();
        let mut got = Vec::new();
        for _ in 0..3 {
            let d = dispatch(gpu, export, sc, visible, s, false)?;
            ms.push(d.ms);
            got = d.got;
        }
        ms.sort_by(f64::total_cmp);
        Ok((ms[1], got))
    };
    let (cut_ms, _) = median(s)?;
    let flat_s = Settings { cut: 0.0, ..*s };
    let worst = iterations(sc.proxies.len());
    let line = if gpu.loop_budget.is_some_and(|b| worst > b) {
        format!("the flat set does not fit llvmpipe's loop budget ({worst} iterations a pixel)")
    } else {
        dispatch(gpu, export, sc, visible, &flat_s, false)?;
        let (flat_ms, flat) = median(&flat_s)?;
        let flat: Vec<f64> = flat.chunks(2).map(|c| f64::from(c[0])).collect();
        let mean = flat.iter().sum::<f64>() / flat.len().max(1) as f64;
        let d: Vec<f64> = values
            .iter()
            .zip(&flat)
            .map(|(a, b)| (f64::from(*a) - b).abs() / mean)
            .collect();
        let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt();
        format!(
            "the flat set {flat_ms:.1} ms ({:.2}×); the cut's image against the flat one: RMS {rms:.5}, max {:.4} of the flat mean",
            cut_ms / flat_ms,
            d.iter().copied().fold(0.0, f64::max)
        )
    };
    out!(
        "render shexp {}: the cut at {:.1}° ({} nodes over {} spheres) {cut_ms:.1} ms (dispatch and read-back, wall \
         clock, medians of 3); {line}",
        sc.name,
        s.cut.to_degrees(),
        sc.proxy_tree().given().len(),
        sc.proxies.len()
    );
    Ok(())
}

/// What [`dispatch`] returns.
struct Dispatched {
    /// [`outputs`] per pixel.
    got: Vec<f32>,
    /// The f32-rounded hits and the materials the kernel shaded, for the CPU to shade
    /// the same.
    at_hits: Vec<Hit>,
    brdfs: Vec<Phong>,
    /// The kernel's dispatch and read-back (ms, wall clock; its build on a first call).
    ms: f64,
}

/// The kernel at `visible` (hits of `sc`) with the settings `s` (with `coeffs`, the
/// integrands too), its budget flags checked.
fn dispatch(
    gpu: &Gpu,
    export: &VerifiedExport,
    sc: &Scene,
    visible: &[&Hit],
    s: &Settings,
    coeffs: bool,
) -> Result<Dispatched, String> {
    supported(s)?;
    let m = &export.manifest;
    let storage = m.storage;
    let (wedge_e, wedge_t) = texture(export, lobefit_tables::wedge::KIND, "wedge")?;
    let (hyb_e, hyb_t) = texture(export, lobefit_tables::shexp::KIND, &format!("shexp-hyb-n{ORDER}"))?;
    let mut uploads = vec![
        (lf_tex(wedge_e, Filter::Manual)?, gpu.upload(wedge_t, storage)?),
        (lf_tex(hyb_e, Filter::Manual)?, gpu.upload(hyb_t, storage)?),
    ];
    if s.blocker_log == BlockerLog::Ren {
        let (e, t) = texture(export, lobefit_tables::shexp::KIND, &format!("shexp-n{ORDER}"))?;
        uploads.push((lf_tex(e, Filter::Manual)?, gpu.upload(t, storage)?));
    }
    let light = light_sh(sc, ORDER)?;
    // Inputs per pixel: point, normal, view, k_d, k_s, Phong exponent, own blockers
    // (first, end), the W horizon angles, as f32; the CPU shades the same rounded hit.
    let n_in = HIT_INPUTS + s.wedges as usize;
    let mut inputs = Vec::with_capacity(visible.len() * n_in + 4 * sc.proxies.len() + light.len());
    let mut at_hits = Vec::with_capacity(visible.len());
    let mut brdfs = Vec::with_capacity(visible.len());
    let r32 = |v: DVec3| DVec3::new(f64::from(v.x as f32), f64::from(v.y as f32), f64::from(v.z as f32));
    for hit in visible {
        let b = Phong::of(sc.brdf(hit))?;
        let at = Hit {
            x: r32(hit.x),
            n: r32(hit.n).normalize(),
            wo: r32(hit.wo).normalize(),
            ..**hit
        };
        inputs.extend(
            [
                at.x.x, at.x.y, at.x.z, at.n.x, at.n.y, at.n.z, at.wo.x, at.wo.y, at.wo.z, b.diffuse, b.specular,
                b.exponent,
            ]
            .map(|v| v as f32),
        );
        inputs.extend(crate::render::own_range(sc, hit));
        inputs.extend(horizons(sc, s, &at).into_iter().map(|v| v as f32));
        at_hits.push(at);
        brdfs.push(b);
    }
    // The scene (the kernel's `shexp_scene`): the blockers' count, whether a height
    // field is present, the blockers (the spheres and the meshes' sphere sets,
    // `Scene::proxies`), then the light.
    inputs.extend([sc.proxies.len() as f32, f32::from(u8::from(sc.heightfield.is_some()))]);
    for b in &sc.proxies {
        inputs.extend([b.centre.x, b.centre.y, b.centre.z, b.radius].map(|v| v as f32));
    }
    inputs.extend(light.iter().map(|&v| v as f32));
    // With Settings::cut, the hierarchy over the blockers after the light.
    let mut cut = None;
    if s.cut > 0.0 {
        let t = sc.proxy_tree();
        if t.depth() > 63 {
            return Err(format!(
                "render shexp: the sphere hierarchy is {} deep; the kernel's walk holds 63",
                t.depth()
            ));
        }
        inputs.extend(crate::render::tree_inputs(t));
        cut = Some((t.given().len(), walk_budget(gpu.loop_budget)));
    }
    let src = source(s, coeffs, cut);
    let textures: Vec<(&[u8], &crate::device::GpuTexture)> = uploads.iter().map(|(p, t)| (p.as_slice(), t)).collect();
    let k = outputs(coeffs);
    let t0 = std::time::Instant::now();
    let got = gpu.run_textures(&src, &textures, &inputs, visible.len(), k)?;
    let ms = 1e3 * t0.elapsed().as_secs_f64();
    budget::flags("render shexp", got.chunks(k).map(|c| c[1]), visible.len(), |f| {
        if f == FLAG_WALK {
            format!(
                "the sphere hierarchy's walk passed the {} iterations the kernel's other loops leave of llvmpipe's \
                 budget: its value would be wrong; use a larger --cut or fewer spheres",
                walk_budget(gpu.loop_budget)
            )
        } else {
            format!("unknown flag {f}")
        }
    })?;
    Ok(Dispatched {
        got,
        at_hits,
        brdfs,
        ms,
    })
}

/// The SH-exponentiation pipeline's integrand at a pixel (`shade::Integrand`, default
/// settings, order 4): its unclamped value (the pipeline's radiance), then the 16 SH
/// coefficients of Σ_t w_t g_t, so that a(ω) = L(ω) Σ_k c_k y_k(ω) integrates to the
/// value over the sphere.
pub type ShIntegrand = [f32; 17];

/// The SH-exponentiation pipeline's integrand at each of `hits` (of `sc`, default
/// settings), computed by the device's kernel: per pixel its unclamped value and the
/// 16 SH coefficients of Σ_t w_t g_t (`shade::Integrand`), what the device's `hybrid`
/// Monte Carlo takes as its control variate ([`ShIntegrand`]).
pub fn integrands(gpu: &Gpu, export: &VerifiedExport, sc: &Scene, hits: &[&Hit]) -> Result<Vec<ShIntegrand>, String> {
    let got = dispatch(gpu, export, sc, hits, &Settings::default(), true)?.got;
    Ok(got
        .chunks(outputs(true))
        .map(|c| std::array::from_fn(|k| c[2 + k]))
        .collect())
}

/// `bench`'s kernel: SH exponentiation at its default settings on `scene`, its image
/// beside the device's Monte Carlo (where that traces the scene) with the hybrid's
/// integrands from the kernel.
fn bench_kernel(
    gpu: &Gpu,
    ex: Option<&VerifiedExport>,
    scene: &str,
    width: usize,
    png: &Path,
) -> Result<crate::render::Benched, String> {
    let ex = ex.ok_or("bench shexp: no export")?;
    let sc = lobefit::pipelines::shexp::render::scene(scene)?;
    check_budget(gpu.loop_budget, &sc, "bench shexp", false)?;
    let s = lobefit::pipelines::shexp::shade::Settings::default();
    let method = format!(
        "HYB order {}, {} wedges, {:?} blocker log ({} spheres)",
        s.order,
        s.wedges,
        s.blocker_log,
        sc.spheres.len()
    );
    let mut values = Vec::new();
    let timed = crate::bench::timed(gpu, "shexp", || {
        let r = render_shexp(gpu, ex, &sc, width, &s, png)?;
        values = r.values;
        Ok(r.rms)
    })?;
    let image = crate::mc::supported(&sc)
        .is_ok()
        .then_some(crate::render::AnalyticImage {
            scene: sc,
            values,
            integrands: Some(|gpu, ex, sc, hits| integrands(gpu, ex, sc, hits).map(crate::mc::ControlVariate::Sh)),
        });
    Ok(crate::render::Benched { method, timed, image })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel parses and validates (naga) with either blocker log and any wedge
    /// count; the settings it cannot run are errors naming them.
    #[test]
    fn kernel_validates_and_unsupported_settings_are_errors() {
        for (blocker_log, wedges, terrain_above_tangent) in [
            (BlockerLog::Eps, 16, false),
            (BlockerLog::Ren, 64, true),
            (BlockerLog::Eps, 4, true),
        ] {
            let s = Settings {
                blocker_log,
                wedges,
                terrain_above_tangent,
                ..Settings::default()
            };
            supported(&s).unwrap();
            let src = source(&s, blocker_log == BlockerLog::Eps, None);
            if let Err(e) = lobefit::export::shaders::module_of(&src) {
                panic!("{blocker_log:?}, {wedges} wedges: {e}");
            }
            // Through the sphere hierarchy's cut: its walk.
            let cut = Settings { cut: 0.1, ..s };
            let src = source(&cut, false, Some((511, 50_000)));
            assert!(src.contains("const CUT = true;") && src.contains("const NN = 511u;"));
            if let Err(e) = lobefit::export::shaders::module_of(&src) {
                panic!("{blocker_log:?}, {wedges} wedges, cut: {e}");
            }
        }
        let d = Settings::default();
        for (s, what) in [
            (Settings { order: 5, ..d }, "order 4 only"),
            (
                Settings { exp: Exp::Exact, ..d },
                "table's a, b only; the settings ask for Exact",
            ),
            (
                Settings {
                    exp: Exp::HybScaled { dc: 0.1, hat: 0.0 },
                    ..d
                },
                "ask for HybScaled",
            ),
            (
                Settings {
                    brdf: BrdfMode::Triple,
                    ..d
                },
                "log-ZH lobes only",
            ),
            (Settings { wedges: 5, ..d }, "wedge count 5"),
            (
                Settings {
                    overlap: Overlap::Touching,
                    ..d
                },
                "overlap weighting",
            ),
            (
                Settings {
                    exact_caps: ExactCaps::Groups,
                    ..d
                },
                "exact caps",
            ),
            (
                Settings {
                    blocker_bands: [1.0, 0.9, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
                    ..d
                },
                "band factors",
            ),
        ] {
            let e = supported(&s).unwrap_err();
            assert!(e.contains(what), "{e}");
        }
    }
}
