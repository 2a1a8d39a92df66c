//! `lobefit-gpu render meunier`: Meunier et al.'s direct lighting
//! (`lobefit_tables::meunier`, `lobefit render meunier`) as one compute kernel per
//! pixel on the exported lobe-product, cap-exponent and mask-weights textures, against
//! the CPU pipeline's image (docs/meunier.md, "On the GPU").
//!
//! The kernel is the runtime's `Meunier::radiance` in f32: the BRDF's lobes at the
//! pixel (Lambert + Lafortune, eq. 30), per light the blockers' caps (clipped behind
//! the light, a cap hiding the whole light skipping it), the visibility mask's
//! quad-tree walked depth first on a stack (cells tested exactly against the caps:
//! corners and great-circle edges), each shadow leaf's bounding cap as a lobe of the
//! cap-exponent texture weighted by eq. 39's weight of its depth (the mask-weights
//! texture), and the shading integral eq. 22 in the order of §5.4 through the
//! lobe-product textures — with the light's exact cap (`LightModel::Cap`: the sphere
//! light's irradiance in closed form, each leaf's share of the cap) or the paper's
//! light lobe. Every leaf is shaded as the walk reaches it, so the kernel keeps no
//! list of lobes.
//!
//! llvmpipe ends an invocation's loops after 65 535 iterations in all (loops of a
//! constant count are unrolled and do not count): the kernel counts its own
//! iterations and ends its walk before the limit, flagging the pixel, and its last
//! loop checks that no loop was cut short (`crate::budget`); it flags a pixel with
//! more blockers meeting a light than its cap array holds. A flagged pixel is an
//! error, never a silently wrong value.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use lobefit::export::layout::Filter;
use lobefit::export::{manifest::TextureEntry, Texture};
use lobefit::pipelines::scene::{Hit, Scene};
use lobefit_tables::geom::{Brdf, LafortuneLobe, Sphere, SphereLight};
use lobefit_tables::glam::DVec3;
use lobefit_tables::mask_weights::{MaskMode, WeightSet};
use lobefit_tables::meunier::{LightModel, MaskSettings, LIGHT_HALF_ANGLE_MIN};
use lobefit_tables::{CapExponent, LobeProduct, MaskWeights, Meunier};

use crate::budget;
use crate::device::Gpu;
use crate::kernel::{kernel_textures, lf_tex, split};
use crate::render::{compare_and_write, family_textures, SceneRender, VerifiedExport};
use crate::render::{parse, Render};

/// `lobefit-gpu render meunier`'s options.
#[derive(clap::Parser)]
pub struct Args {
    /// A `lobefit export` directory with lobe-product, cap-exponent and mask-weights.
    #[arg(long, value_name = "DIR")]
    export: PathBuf,
    /// A built-in Meunier scene (fig13, glossy) or a scene file.
    #[arg(long, default_value = "fig13")]
    scene: String,
    /// Image width (height 3/4 of it).
    #[arg(long, default_value_t = WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
    width: u32,
    /// How the light enters: its exact cap (the default) or the paper's lobe.
    #[arg(long, default_value = "cap", value_parser = ["cap", "lobe"])]
    light: String,
    /// Eq. 39's weights: fitted (the default), the paper's procedure, or all ones.
    #[arg(long, default_value = "fitted", value_parser = ["fitted", "paper", "one"])]
    weights: String,
    /// The mask's maximal quad-tree depth.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=5))]
    depth: u32,
    /// Partial cells at the maximal depth: dropped (aggressive, the paper's) or kept.
    #[arg(long, default_value = "aggressive", value_parser = ["aggressive", "conservative"])]
    mask: String,
    /// The threshold t_i (sr): lobe products with |∫| below it are dropped.
    #[arg(long, default_value_t = 0.0)]
    threshold: f64,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// Render an animated scene as N frames (times 0 to 1), each against the CPU
    /// pipeline; the frames go to OUT's stem with `-frame-KKK.png`.
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=240))]
    frames: Option<u32>,
}

/// `render meunier`.
pub const RENDER: Render = Render {
    name: "meunier",
    about: "Meunier et al.'s direct lighting per pixel on the GPU (mask quad-tree, leaf lobes, eq. 22 on the \
            exported lobe-product, cap-exponent and mask-weights textures) against the CPU pipeline's image \
            (docs/meunier.md)",
    options: <Args as clap::CommandFactory>::command,
    run: |m| run(parse(m)?),
    bench: Some(crate::render::Bench {
        rank: 2,
        scene: "fig13",
        any_scene: true,
        families: Some(FAMILIES),
        kernel: bench_kernel,
    }),
};

/// `a`'s settings as the CPU parses them (`eval direct-light`'s flags), the threshold
/// rounded to the kernel's f32.
fn settings(a: &Args) -> Result<MaskSettings, String> {
    let threshold = a.threshold;
    if !(threshold.is_finite() && threshold >= 0.0) {
        return Err(format!("--threshold {threshold}: t_i must be finite and ≥ 0 (sr)"));
    }
    // The kernel's t_i is an f32: the CPU uses, and the report names, the same.
    let threshold = f64::from(threshold as f32);
    if !threshold.is_finite() {
        return Err(format!(
            "--threshold {threshold}: t_i overflows f32 (the kernel's type)"
        ));
    }
    let flags = lobefit::family::EvalFlags::default()
        .with_count("depth", a.depth as usize)
        .with("mask", a.mask.clone())
        .with("weights", a.weights.clone())
        .with("light", a.light.clone());
    Ok(MaskSettings {
        threshold,
        ..lobefit::pipelines::meunier::direct_light::DirectLightView::from_flags(&flags)?.settings
    })
}

/// The settings of `render meunier` without options (`lobefit-gpu bench`'s).
pub fn default_settings() -> Result<MaskSettings, String> {
    let flags = lobefit::family::EvalFlags::default()
        .with_count("depth", 5)
        .with("mask", "aggressive".to_string())
        .with("weights", "fitted".to_string())
        .with("light", "cap".to_string());
    Ok(MaskSettings {
        threshold: 0.0,
        ..lobefit::pipelines::meunier::direct_light::DirectLightView::from_flags(&flags)?.settings
    })
}

fn run(a: Args) -> Result<ExitCode, String> {
    let settings = settings(&a)?;
    crate::render::check_out(&a.out)?;
    let sc = lobefit::pipelines::meunier::render::scene(&a.scene)?;
    let (ex, gpu) = crate::render::open(&a.export, FAMILIES, |_| Ok(()))?;
    if let Some(n) = a.frames {
        return crate::render::animate("render meunier", &sc, n as usize, &gpu, &a.out, |still, path| {
            render_meunier(&gpu, &ex, still, a.width as usize, &settings, path)
        });
    }
    let r = render_meunier(&gpu, &ex, &sc, a.width as usize, &settings, &a.out)?;
    let what = format!(
        "{} (light {}, weights {}, depth {} {}, t_i {:e})",
        a.scene,
        a.light,
        a.weights,
        settings.depth,
        settings.mode.name(),
        settings.threshold
    );
    crate::render::report("render meunier", &what, &r, &gpu, &a.out)
}

/// Default image width (height 3/4 of it).
pub const WIDTH: u32 = 96;
/// Blockers meeting one light's cap the kernel holds.
pub const MAX_BLOCKERS: usize = 64;
/// Lafortune lobes per material the kernel holds (besides the Lambertian term).
pub const MAX_LOBES: usize = 3;
/// Loop iterations of its own at which the kernel ends its walk and flags the pixel
/// (below llvmpipe's [`budget::LOOP_LIMIT`], leaving room for the library's loops).
const ITERATION_BUDGET: u32 = 60_000;

/// The families render meunier reads, and how to export them.
pub const FAMILIES: (&[&str], &str) = (
    &[
        lobefit_tables::lobe_product::KIND_ENERGY,
        lobefit_tables::cap_exponent::KIND,
        lobefit_tables::mask_weights::KIND,
    ],
    "lobe-product,cap-exponent,mask-weights",
);

/// The `k`-th texture of family `kind` in the export.
fn texture<'a>(export: &'a VerifiedExport, kind: &str, k: usize) -> Result<(&'a TextureEntry, &'a Texture), String> {
    let (e, t) = family_textures(export, kind)?
        .get(k)
        .ok_or_else(|| format!("{kind}: the export lacks its texture {k}"))?;
    Ok((e, t))
}

/// A value as a WGSL f32 literal.
fn lit(v: f64) -> String {
    format!("{:e}", v as f32)
}

/// The kernel's functions and constants under `settings`: the scene (the blockers,
/// lights and materials) follows the pixels' inputs in the buffer X, so one compiled
/// kernel serves every scene, every frame of an animation and every image size.
fn source(settings: &MaskSettings) -> String {
    let set = match settings.weights {
        WeightSet::Fitted => 0,
        WeightSet::Paper => 1,
        WeightSet::Ones => 2,
    };
    let mode = u32::from(settings.mode == MaskMode::Conservative);
    format!(
        "const N_IN = {N_IN}u;\nconst MAT_SIZE = {}u;\nconst MAXB = {MAX_BLOCKERS}u;\nconst MAXL = {}u;\n\
         const DEPTH = {}u;\nconst MODE = {mode}u;\nconst WSET = {set}u;\nconst THRESH = {};\nconst CAP_LIGHT = {};\n\
         const BUDGET = {ITERATION_BUDGET}u;\nconst LIGHT_HALF_ANGLE_MIN = {};\nconst SHARP = {};\n{}{}",
        2 + 5 * MAX_LOBES,
        MAX_LOBES + 1,
        settings.depth,
        lit(settings.threshold),
        settings.light == LightModel::Cap,
        lit(LIGHT_HALF_ANGLE_MIN),
        settings.sharp_leaves,
        crate::render::own_proxy_wgsl(),
        split(SHADER).0,
    )
}

/// Inputs per pixel: point, normal, tangent, direction to the eye, material, the
/// blockers the point lies on or in (`Scene::own_proxies`: first, end).
const N_IN: usize = 15;

/// The kernel's functions and body (gpu/shaders/meunier.wgsl).
const SHADER: &str = include_str!("../shaders/meunier.wgsl");

/// The kernel's body (gpu/shaders/meunier.wgsl), then the loop budget's sentinel and
/// the flag.
fn body() -> String {
    format!("{}{}    Y[o + 1u] = budget_flag;", split(SHADER).1, budget::SENTINEL)
}

/// A material's kernel record: albedo, lobe count, then (C_x, C_y, C_z, ρ_s, n) per
/// Lafortune lobe, zero-padded to [`MAX_LOBES`].
fn material(b: &Brdf) -> Result<Vec<f32>, String> {
    let (albedo, lobes): (f64, &[LafortuneLobe]) = match b {
        Brdf::Lambert { albedo } => (*albedo, &[]),
        Brdf::Lafortune { albedo, lobes } => (*albedo, lobes),
        Brdf::CookTorrance { .. } | Brdf::BlinnPhong { .. } => {
            return Err(lobefit_tables::meunier::MeunierError::NotLobes.to_string())
        }
    };
    if lobes.len() > MAX_LOBES {
        return Err(format!(
            "a material has {} Lafortune lobes; render meunier's kernel holds {MAX_LOBES}",
            lobes.len()
        ));
    }
    let mut v = vec![albedo as f32, lobes.len() as f32];
    for l in lobes {
        v.extend([l.c.x, l.c.y, l.c.z, l.rho, l.exponent].map(|x| x as f32));
    }
    v.resize(2 + 5 * MAX_LOBES, 0.0);
    Ok(v)
}

/// `b` with every number rounded to f32 (what the kernel gets).
fn material32(b: &Brdf) -> Brdf {
    let r = |v: f64| f64::from(v as f32);
    match b {
        Brdf::Lambert { albedo } => Brdf::Lambert { albedo: r(*albedo) },
        // Refused by `material` before the kernel runs: kept as it is.
        Brdf::CookTorrance { .. } | Brdf::BlinnPhong { .. } => b.clone(),
        Brdf::Lafortune { albedo, lobes } => Brdf::Lafortune {
            albedo: r(*albedo),
            lobes: lobes
                .iter()
                .map(|l| LafortuneLobe {
                    c: l.c.as_vec3().as_dvec3(),
                    rho: r(l.rho),
                    exponent: r(l.exponent),
                })
                .collect(),
        },
    }
}

/// Renders `scene` (a built-in Meunier scene, fig13 or glossy, or a scene file) at
/// `width` with `settings` on the GPU and with the CPU pipeline (f64, the committed
/// tables, the same f32 inputs); writes `out` (PNG, radiance / peak, gamma 1/2.2).
pub fn render_meunier(
    gpu: &Gpu,
    export: &VerifiedExport,
    sc: &Scene,
    width: usize,
    settings: &MaskSettings,
    out: &Path,
) -> Result<SceneRender, String> {
    let m = &export.manifest;
    let (lp_e, lp_t) = texture(export, lobefit_tables::lobe_product::KIND_ENERGY, 0)?;
    let (lnw_e, lnw_t) = texture(export, lobefit_tables::lobe_product::KIND_ENERGY, 1)?;
    let (cap_e, cap_t) = texture(export, lobefit_tables::cap_exponent::KIND, 0)?;
    let (mw_e, mw_t) = texture(export, lobefit_tables::mask_weights::KIND, 0)?;
    let up = [lp_t, lnw_t, cap_t, mw_t]
        .iter()
        .map(|t| gpu.upload(t, m.storage))
        .collect::<Result<Vec<_>, _>>()?;
    let params = [lp_e, lnw_e, cap_e, mw_e]
        .iter()
        .map(|e| lf_tex(e, Filter::Manual))
        .collect::<Result<Vec<_>, _>>()?;
    let (w, h) = crate::render::image_size(width);
    let hits = crate::render::primary_hits(sc, (w, h))?;
    let visible: Vec<&Hit> = hits.iter().flatten().collect();
    let mut inputs = Vec::with_capacity(visible.len() * N_IN + 64);
    for hit in &visible {
        inputs.extend(
            [
                hit.x.x, hit.x.y, hit.x.z, hit.n.x, hit.n.y, hit.n.z, hit.t.x, hit.t.y, hit.t.z, hit.wo.x, hit.wo.y,
                hit.wo.z,
            ]
            .map(|v| v as f32),
        );
        inputs.extend([hit.material as f32]);
        inputs.extend(crate::render::own_range(sc, hit));
    }
    // The blockers: the spheres and the meshes' sphere sets (`Scene::proxies`).
    // The scene (the kernel's `mn_scene`): the blocker and light counts, then the
    // blockers, the lights and the materials.
    inputs.extend([sc.proxies.len() as f32, sc.lights.len() as f32]);
    let spheres32: Vec<Sphere> = sc
        .proxies
        .iter()
        .map(|s| Sphere {
            centre: s.centre.as_vec3().as_dvec3(),
            radius: f64::from(s.radius as f32),
        })
        .collect();
    let lights32: Vec<SphereLight> = sc
        .lights
        .iter()
        .map(|l| SphereLight {
            sphere: Sphere {
                centre: l.sphere.centre.as_vec3().as_dvec3(),
                radius: f64::from(l.sphere.radius as f32),
            },
            radiance: f64::from(l.radiance as f32),
        })
        .collect();
    for s in &spheres32 {
        inputs.extend([s.centre.x, s.centre.y, s.centre.z, s.radius].map(|v| v as f32));
    }
    for l in &lights32 {
        let c = l.sphere.centre;
        inputs.extend([c.x, c.y, c.z, l.sphere.radius, l.radiance].map(|v| v as f32));
    }
    for b in &sc.materials {
        inputs.extend(material(b)?);
    }
    let types = [lp_t, lnw_t, cap_t, mw_t].map(crate::device::wgsl_texture_type);
    let src = kernel_textures(&types, N_IN, 2, &body()) + &source(settings);
    let textures: Vec<(&[u8], &crate::device::GpuTexture)> = params.iter().map(Vec::as_slice).zip(up.iter()).collect();
    let got = gpu.run_textures(&src, &textures, &inputs, visible.len(), 2)?;
    budget::flags("render meunier", got.chunks(2).map(|c| c[1]), visible.len(), |_| {
        format!("more than {MAX_BLOCKERS} blockers meet the light's cap (the kernel's array)")
    })?;
    // The CPU pipeline (f64, the committed tables) at the same f32 inputs.
    let meunier = Meunier {
        products: LobeProduct::embedded().map_err(|e| e.to_string())?,
        caps: CapExponent::embedded().map_err(|e| e.to_string())?,
        weights: MaskWeights::embedded().map_err(|e| e.to_string())?,
    };
    let materials32: Vec<Brdf> = sc.materials.iter().map(material32).collect();
    let mut cpu = Vec::with_capacity(visible.len());
    for (k, hit) in visible.iter().enumerate() {
        let v = |i: usize| f64::from(inputs[N_IN * k + i]);
        let own = sc.own_proxies(hit);
        let blockers: Vec<Sphere> = spheres32
            .iter()
            .enumerate()
            .filter(|(i, _)| !own.contains(i))
            .map(|(_, s)| *s)
            .collect();
        let x = DVec3::new(v(0), v(1), v(2));
        // A point buried in a blocker is in its full shadow (the CPU render's rule).
        if blockers.iter().any(|b| (x - b.centre).length() <= b.radius) {
            cpu.push(0.0);
            continue;
        }
        cpu.push(
            meunier
                .radiance(
                    x,
                    DVec3::new(v(3), v(4), v(5)).normalize(),
                    DVec3::new(v(6), v(7), v(8)),
                    DVec3::new(v(9), v(10), v(11)).normalize(),
                    &materials32[hit.material],
                    &lights32,
                    &blockers,
                    settings,
                )
                .map_err(|e| format!("CPU pipeline at pixel {k}: {e}"))?,
        );
    }
    let values: Vec<f32> = got.chunks(2).map(|c| c[0]).collect();
    compare_and_write(&values, &cpu, hits.iter().map(Option::is_some), (w, h), out)
}

/// `bench`'s kernel: Meunier's lobes at the default settings on `scene`, its image
/// beside the device's Monte Carlo (no hybrid).
fn bench_kernel(
    gpu: &Gpu,
    ex: Option<&VerifiedExport>,
    scene: &str,
    width: usize,
    png: &Path,
) -> Result<crate::render::Benched, String> {
    let ex = ex.ok_or("bench meunier: no export")?;
    let sc = lobefit::pipelines::meunier::render::scene(scene)?;
    let s = default_settings()?;
    let method = format!(
        "mask depth {} {}, fitted weights, exact cap ({} spheres)",
        s.depth,
        s.mode.name(),
        sc.spheres.len()
    );
    let mut values = Vec::new();
    let timed = crate::bench::timed(gpu, "meunier", || {
        let r = render_meunier(gpu, ex, &sc, width, &s, png)?;
        values = r.values;
        Ok(r.rms)
    })?;
    let image = crate::render::AnalyticImage {
        scene: sc,
        values,
        integrands: None,
    };
    Ok(crate::render::Benched {
        method,
        timed,
        image: Some(image),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel parses and validates (naga) under both light models, conservative
    /// masks and a threshold.
    #[test]
    fn kernel_validates() {
        for light in LightModel::ALL {
            let s = MaskSettings {
                light,
                mode: MaskMode::Conservative,
                threshold: 1e-3,
                ..MaskSettings::default()
            };
            let src = kernel_textures(
                &[
                    "texture_3d<f32>",
                    "texture_2d<f32>",
                    "texture_2d<f32>",
                    "texture_2d<f32>",
                ],
                N_IN,
                2,
                &body(),
            ) + &source(&s);
            if let Err(e) = lobefit::export::shaders::module_of(&src) {
                panic!("light {}: {e}", light.name());
            }
        }
    }

    /// Materials beyond the kernel's lobe count are refused, not truncated.
    #[test]
    fn too_many_lobes_is_an_error() {
        let l = LafortuneLobe {
            c: DVec3::new(-1.0, -1.0, 1.0),
            rho: 1.0,
            exponent: 10.0,
        };
        let ok = Brdf::Lafortune {
            albedo: 0.5,
            lobes: vec![l; MAX_LOBES],
        };
        assert_eq!(material(&ok).unwrap().len(), 2 + 5 * MAX_LOBES);
        let bad = Brdf::Lafortune {
            albedo: 0.5,
            lobes: vec![l; MAX_LOBES + 1],
        };
        assert!(material(&bad).unwrap_err().contains("Lafortune lobes"));
    }
}
