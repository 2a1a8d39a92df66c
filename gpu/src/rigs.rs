//! `lobefit-gpu render rigs`: the irradiance-rig pipeline's reconstruction and wrap
//! shading (`lobefit render rigs`, docs/rigs.md) as one compute kernel per pixel,
//! against the CPU at the same f32-rounded inputs.
//!
//! The CPU finds each pixel's point and normal on the car box (`hit_box`) and fits the
//! rigs of Figure 1 (`figure_rigs`: constant, gradient, mixed, lattice 3 × 2 × 2, least
//! squares); the kernel reconstructs every rig at every visible pixel from its vectors
//! (`lf_rig_terms`, the vectors gathered from the input buffer) and shades it with wrap
//! a (`lf_irradiance9_wrapped`), against the CPU's `shade_wrapped(rig.eval(p), n, a)`.
//! The rigs need no texture: the kernel binds the dummy texture, and the command takes
//! no export.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use lobefit::export::Storage;
use lobefit::pipelines::rigs::render::{figure_rigs, hit_box, shade_wrapped, CAMERA};
use lobefit::pipelines::rigs::{car_box, scene_lights, Receiver};
use lobefit_tables::disk_light::DiskLight;
use lobefit_tables::glam::DVec3;
use lobefit_tables::rigs::{AxisModel, Light, RigBox, RigModel, COEFFS};

use crate::conformance::dummy_texture;
use crate::device::Gpu;
use crate::kernel::{kernel, LF_TEX_SIZE};
use crate::render::{grey, write_grey_png, RMS_LIMIT};
use crate::render::{parse, Render};

/// `lobefit-gpu render rigs`'s options.
#[derive(clap::Parser)]
pub struct Args {
    /// Image width (height 3/4 of it).
    #[arg(long, default_value_t = WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
    width: u32,
    /// Only this wrap parameter a in [0, 1]; default: a = 0 (Lambert) and the CPU
    /// pipeline's WRAP_A.
    #[arg(long, value_name = "A")]
    wrap: Option<f64>,
    /// Output PNG (a row of panels per wrap, a column per rig).
    #[arg(long)]
    out: PathBuf,
}

/// `render rigs`.
pub const RENDER: Render = Render {
    name: "rigs",
    about: "the irradiance-rig pipeline per pixel on the GPU (the library's rig reconstruction and wrap \
            shading; points, normals and Figure 1's least-squares rigs from the CPU) against the CPU's \
            shade_wrapped (docs/rigs.md); no export: the rigs need no texture",
    options: <Args as clap::CommandFactory>::command,
    run: |m| run(parse(m)?),
    bench: Some(crate::render::Bench {
        rank: 3,
        scene: "fig1",
        any_scene: false,
        families: None,
        kernel: bench_kernel,
    }),
};

fn run(a: Args) -> Result<ExitCode, String> {
    let wraps = match a.wrap {
        Some(w) if (0.0..=1.0).contains(&w) => vec![w],
        Some(w) => return Err(format!("--wrap {w}: the wrap parameter lies in [0, 1]")),
        None => vec![0.0, lobefit::pipelines::rigs::render::WRAP_A],
    };
    // The kernel's wrap is an f32: the CPU uses, and the report names, the same.
    let wraps: Vec<f64> = wraps.into_iter().map(|w| f64::from(w as f32)).collect();
    crate::render::check_out(&a.out)?;
    let gpu = Gpu::new()?;
    let (pixels, rows) = render_rigs(&gpu, a.width as usize, &wraps, &a.out)?;
    out!(
        "render rigs: {}x{} ({pixels} pixels see the car) on {}; GPU against the CPU, relative to each \
         image's peak (limit {RMS_LIMIT:.0e} RMS):",
        a.width,
        (a.width * 3 / 4).max(3),
        gpu.info.name,
    );
    let mut failed = 0;
    for r in &rows {
        let pass = r.rms <= RMS_LIMIT;
        failed += usize::from(!pass);
        out!(
            "  {:<20} {:>3} vectors  wrap a = {:<4}  max {:.2e}  RMS {:.2e}{}",
            r.label,
            r.vectors,
            r.wrap,
            r.max,
            r.rms,
            if pass { "" } else { "  FAIL" }
        );
    }
    out!("image: {}", a.out.display());
    if failed > 0 {
        out!("render rigs FAILED: {failed} of {} rows", rows.len());
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

/// Default image width (height 3/4 of it).
pub const WIDTH: u32 = 64;

/// Per pixel: point, normal.
const N_IN: usize = 6;

/// A rig model as the library's (kind, nodes) per axis (rigs.wgsl: 0 constant,
/// 1 gradient, 2 lattice of `nodes`; 3 on x: the 4-vector gradient rig).
pub fn model_code(m: RigModel) -> ([u32; 3], [u32; 3]) {
    match m {
        RigModel::Gradient => ([3, 0, 0], [0; 3]),
        RigModel::Tensor(axes) => {
            let code = |a: AxisModel| match a {
                AxisModel::Constant => (0, 0),
                AxisModel::Gradient => (1, 0),
                AxisModel::Lattice(n) => (2, n),
            };
            let c = axes.map(code);
            (c.map(|c| c.0), c.map(|c| c.1))
        }
    }
}

/// `p` rounded to f32, nudged toward the box's centre (by f32 ulps) until the runtime
/// accepts it (a face point may round outside by more than its 1e-9 slack).
pub fn inside32(bbox: &RigBox, p: DVec3) -> DVec3 {
    let mut q = p.to_array().map(|v| v as f32);
    for (k, qk) in q.iter_mut().enumerate() {
        let (c, h) = (bbox.centre[k], bbox.half[k]);
        for _ in 0..8 {
            let v = f64::from(*qk);
            if ((v - c) / h).abs() <= 1.0 {
                break;
            }
            *qk = if v > c { qk.next_down() } else { qk.next_up() };
        }
    }
    DVec3::from_array(q.map(f64::from))
}

/// A vec3<f32> literal.
fn vec3(v: [f64; 3]) -> String {
    format!("vec3<f32>({:e}, {:e}, {:e})", v[0] as f32, v[1] as f32, v[2] as f32)
}

/// The kernel's functions (gpu/shaders/rigs.wgsl).
const FUNCTIONS: &str = include_str!("../shaders/rigs.wgsl");

/// The kernel over `count` pixels for rigs of `models` (their vectors after the
/// pixels, in order) in `bbox`, shaded at each wrap of `wraps`: output (rig r, wrap w)
/// at r · |wraps| + w.
fn source(models: &[RigModel], bbox: &RigBox, wraps: &[f64], count: usize) -> Result<String, String> {
    let n_out = models.len() * wraps.len();
    let mut offset = N_IN * count;
    let mut body = String::from("    let p = vec3<f32>(x0, x1, x2);\n    let n = vec3<f32>(x3, x4, x5);\n");
    for (r, m) in models.iter().enumerate() {
        let (kind, nodes) = model_code(*m);
        body += &format!(
            "    let l{r} = rig_at(vec3<u32>({}u, {}u, {}u), vec3<u32>({}u, {}u, {}u), {offset}u, p);\n",
            kind[0], kind[1], kind[2], nodes[0], nodes[1], nodes[2]
        );
        for (w, a) in wraps.iter().enumerate() {
            body += &format!(
                "    Y[o + {}u] = lf_irradiance9_wrapped(l{r}, n, {:e});\n",
                r * wraps.len() + w,
                *a as f32
            );
        }
        offset += COEFFS * m.parameter_count().map_err(|e| e.to_string())?;
    }
    let functions = format!(
        "\nconst CENTRE = {};\nconst HALF = {};\n{FUNCTIONS}",
        vec3(bbox.centre.to_array()),
        vec3(bbox.half.to_array())
    );
    Ok(kernel("texture_2d<f32>", N_IN, n_out, &body) + &functions)
}

/// One rig's comparison at one wrap.
pub struct RigRow {
    /// The rig's label (`figure_rigs`).
    pub label: String,
    /// Its number of vectors.
    pub vectors: usize,
    /// Wrap parameter a.
    pub wrap: f64,
    /// GPU against CPU relative to the CPU image's peak: max, RMS.
    pub max: f64,
    /// See `max`.
    pub rms: f64,
}

/// Renders the rigs of Figure 1 at `width` (height 3/4 of it) per wrap of `wraps` on
/// the GPU and the CPU; writes `out` (PNG: a row of panels per wrap, a column per rig,
/// irradiance / the row's CPU peak, gamma 1/2.2). Returns the visible pixels and the
/// rows.
pub fn render_rigs(gpu: &Gpu, width: usize, wraps: &[f64], out: &Path) -> Result<(usize, Vec<RigRow>), String> {
    let (w, h) = crate::render::image_size(width);
    let hits: Vec<Option<Receiver>> = (0..w * h)
        .map(|p| hit_box(CAMERA.eye, CAMERA.ray(p % w, p / w, w, h)))
        .collect();
    let bbox = car_box();
    // The GPU's inputs, rounded to f32; the CPU shades the same rounded point.
    let visible: Vec<(DVec3, DVec3)> = hits.iter().flatten().map(|r| (inside32(&bbox, r.p), r.n)).collect();
    if visible.is_empty() {
        return Err(format!("render rigs: no pixel of the {w}×{h} image sees the car"));
    }
    let disks = DiskLight::embedded().map_err(|e| e.to_string())?;
    let lights: Vec<Light> = scene_lights().iter().map(|l| l.1).collect();
    let rigs = figure_rigs(&lights, disks)?;
    let mut inputs: Vec<f32> = Vec::new();
    for (p, n) in &visible {
        inputs.extend(p.to_array().into_iter().chain(n.to_array()).map(|v| v as f32));
    }
    for (_, rig, _) in &rigs {
        inputs.extend(rig.vectors().iter().flatten().map(|&v| v as f32));
    }
    let models: Vec<RigModel> = rigs.iter().map(|r| r.1.model()).collect();
    let src = source(&models, &bbox, wraps, visible.len())?;
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let n_out = models.len() * wraps.len();
    let got = gpu.run(&src, &[0u8; LF_TEX_SIZE], &dummy, &inputs, visible.len(), n_out)?;

    let mut rows = Vec::new();
    let mut image = vec![0u8; w * models.len() * h * wraps.len()];
    let stride = w * models.len();
    for (wi, &a) in wraps.iter().enumerate() {
        // The CPU image of every rig at this wrap; the row's panels share its peak.
        let mut cpus = Vec::new();
        for (_, rig, _) in &rigs {
            let cpu: Vec<f64> = visible
                .iter()
                .map(|(p, n)| shade_wrapped(&rig.eval(*p).map_err(|e| e.to_string())?, *n, a))
                .collect::<Result<_, String>>()?;
            cpus.push(cpu);
        }
        let row_peak = cpus
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        for (r, ((label, rig, _), cpu)) in rigs.iter().zip(&cpus).enumerate() {
            let peak = cpu.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(f64::MIN_POSITIVE);
            let c = r * wraps.len() + wi;
            let (mut max, mut sum) = (0.0f64, 0.0);
            for (k, want) in cpu.iter().enumerate() {
                let g = got[k * n_out + c];
                // A non-finite GPU value fails the comparison (NaN would pass unseen).
                let d = if g.is_finite() {
                    (f64::from(g) - want).abs() / peak
                } else {
                    f64::INFINITY
                };
                max = max.max(d);
                sum += d * d;
            }
            rows.push(RigRow {
                label: label.clone(),
                vectors: rig.vectors().len(),
                wrap: a,
                max,
                rms: (sum / cpu.len() as f64).sqrt(),
            });
            let mut k = 0;
            for (px, hit) in hits.iter().enumerate() {
                if hit.is_some() {
                    let (i, j) = (px % w, px / w);
                    let g = f64::from(got[k * n_out + c]);
                    image[(wi * h + j) * stride + r * w + i] = grey(g / row_peak);
                    k += 1;
                }
            }
        }
    }
    write_grey_png(out, stride, h * wraps.len(), &image)?;
    Ok((visible.len(), rows))
}

/// `bench`'s kernel: Figure 1's rigs at two wraps (the scene is fixed).
fn bench_kernel(
    gpu: &Gpu,
    _: Option<&crate::render::VerifiedExport>,
    _: &str,
    width: usize,
    png: &Path,
) -> Result<crate::render::Benched, String> {
    let wraps = [0.0, f64::from(lobefit::pipelines::rigs::render::WRAP_A as f32)];
    let mut nrigs = 0;
    let t = crate::bench::timed(gpu, "rigs", || {
        let (_, r) = render_rigs(gpu, width, &wraps, png)?;
        nrigs = r.len() / wraps.len();
        // The worst of its images (a rig at a wrap each).
        Ok(r.iter().map(|r| r.rms).fold(0.0, f64::max))
    })?;
    Ok(crate::render::Benched {
        method: format!("Figure 1's {nrigs} rigs × {} wraps per pixel", wraps.len()),
        timed: t,
        image: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel of Figure 1's rig models (and the other models' codes) parses and
    /// validates (naga); the model codes follow rigs.wgsl.
    #[test]
    fn kernel_validates_and_models_are_coded() {
        let models = [
            RigModel::CONSTANT,
            RigModel::Gradient,
            RigModel::Tensor([AxisModel::Lattice(3), AxisModel::Gradient, AxisModel::Constant]),
            RigModel::lattice(3, 2, 2),
        ];
        let src = source(&models, &car_box(), &[0.0, 0.5], 7).unwrap();
        if let Err(e) = lobefit::export::shaders::module_of(&src) {
            panic!("{e}");
        }
        assert_eq!(model_code(models[0]), ([0, 0, 0], [0, 0, 0]));
        assert_eq!(model_code(models[1]).0[0], 3);
        assert_eq!(model_code(models[2]), ([2, 1, 0], [3, 0, 0]));
        assert_eq!(model_code(models[3]), ([2, 2, 2], [3, 2, 2]));
    }

    /// Rounding to f32 keeps a face point inside the box the runtime accepts.
    #[test]
    fn rounded_points_stay_in_the_box() {
        let b = car_box();
        for p in [
            DVec3::new(2.25 + 1e-12, 0.9 + 1e-12, -0.75 - 1e-12),
            DVec3::new(-2.2499999999, 0.899999999, 0.0),
        ] {
            let q = inside32(&b, p);
            assert!(b.normalised(q).is_ok(), "{q:?}");
            assert_eq!(q.to_array().map(|v| v as f32 as f64), q.to_array());
        }
    }
}
