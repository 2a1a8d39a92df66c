//! lobefit-gpu: the shader library and exported textures on a real Vulkan device.
//!
//! `lobefit-gpu gpu-check --export DIR` runs every shader function at the checker's
//! seeded off-grid samples and compares with the CPU emulation and the references.

mod budget;
mod conformance;
mod cost;
mod device;
mod isg;
mod kernel;
mod meunier;
mod render;
mod rigs;
mod shexp;
mod world;

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// `println!` that returns an error instead of panicking when stdout is a closed pipe
/// or a full disk (inside functions returning `Result<_, String>`).
macro_rules! out {
    ($($t:tt)*) => {
        writeln!(std::io::stdout(), $($t)*).map_err(|e| format!("cannot write the output: {e}"))?
    };
}

#[derive(Parser)]
#[command(name = "lobefit-gpu", about = "lobefit's shader library on a Vulkan device (wgpu)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run every shader function on the GPU against the CPU emulation of the export and
    /// the independent references; exit 1 on a miss.
    GpuCheck {
        /// A `lobefit export` directory (manifest.json and the textures).
        #[arg(long, value_name = "DIR")]
        export: PathBuf,
    },
    /// Render a small image with the shader library (a sphere and a floor lit by a disk
    /// light's SH irradiance, cosine-lobe lights on the glossy sphere through the lobe
    /// product) to a PNG and compare it with the CPU image; exit 1 when
    /// the RMS difference exceeds 1e-4 of the peak.
    Render {
        /// A `lobefit export` directory with the disk-light texture.
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
    },
    /// Iwasaki et al.'s ISG pipeline per pixel on the GPU (the exported isg-best and
    /// sg-fit textures) against the CPU pipeline's image (docs/isg-render.md).
    RenderIsg {
        /// A `lobefit export` directory with isg-best and sg-fit.
        #[arg(long, value_name = "DIR")]
        export: PathBuf,
        /// A built-in ISG scene (fig12, fig12-diffuse) or a scene file.
        #[arg(long, default_value = "fig12")]
        scene: String,
        /// Image width (height 3/4 of it).
        #[arg(long, default_value_t = isg::WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
        width: u32,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
    },
    /// The SH-exponentiation pipeline per pixel on the GPU (the exported wedge and
    /// shexp textures; hits and horizon angles from the CPU) against the CPU
    /// pipeline's image at its default settings (docs/shexp-render.md).
    RenderShexp {
        /// A `lobefit export` directory with wedge and shexp.
        #[arg(long, value_name = "DIR")]
        export: PathBuf,
        /// A built-in shexp scene (whale, whale-diffuse, wrecking) or a scene file.
        #[arg(long, default_value = "whale")]
        scene: String,
        /// Image width (height 3/4 of it).
        #[arg(long, default_value_t = shexp::WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
        width: u32,
        /// The sphere blockers' log: the ε-floored closed form or Ren's (the shexp-n4
        /// texture); default: the CPU pipeline's default.
        #[arg(long, value_parser = ["eps", "ren"])]
        blocker_log: Option<String>,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
    },
    /// Meunier et al.'s direct lighting per pixel on the GPU (mask quad-tree, leaf
    /// lobes, eq. 22 on the exported lobe-product, cap-exponent and mask-weights
    /// textures) against the CPU pipeline's image (docs/meunier.md); exit 1 when the
    /// RMS difference exceeds 1e-4 of the CPU image's peak.
    RenderMeunier {
        /// A `lobefit export` directory with lobe-product, cap-exponent and mask-weights.
        #[arg(long, value_name = "DIR")]
        export: PathBuf,
        /// A built-in Meunier scene (fig13, glossy) or a scene file.
        #[arg(long, default_value = "fig13")]
        scene: String,
        /// Image width (height 3/4 of it).
        #[arg(long, default_value_t = meunier::WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
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
    },
    /// The irradiance-rig pipeline per pixel on the GPU (the library's rig
    /// reconstruction and wrap shading; points, normals and the least-squares rigs of
    /// Figure 1 from the CPU) against the CPU's `shade_wrapped` (docs/rigs.md); exit 1
    /// when a rig's RMS difference exceeds 1e-4 of its CPU image's peak. No export: the
    /// rigs need no texture.
    RenderRigs {
        /// Image width (height 3/4 of it).
        #[arg(long, default_value_t = rigs::WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
        width: u32,
        /// Only this wrap parameter a in [0, 1]; default: a = 0 (Lambert) and the CPU
        /// pipeline's WRAP_A.
        #[arg(long, value_name = "A")]
        wrap: Option<f64>,
        /// Output PNG (a row of panels per wrap, a column per rig).
        #[arg(long)]
        out: PathBuf,
    },
    /// Per shader function: SPIR-V instructions of its kernel (naga) and GPU
    /// evaluations per second on this device.
    Cost {
        /// A `lobefit export` directory.
        #[arg(long, value_name = "DIR")]
        export: PathBuf,
    },
}

/// Prints a pipeline render's comparison (`command` and what it rendered, `what`) and
/// its image; exit 1 when the RMS difference exceeds [`render::RMS_LIMIT`].
fn report(
    command: &str,
    what: &str,
    r: &render::SceneRender,
    gpu: &device::Gpu,
    out: &std::path::Path,
) -> Result<ExitCode, String> {
    out!(
        "{command} {what}: {} pixels see geometry, on {}; GPU against the CPU pipeline, relative to the peak: \
         max {:.2e}, RMS {:.2e} (limit {:.0e} RMS)",
        r.pixels,
        gpu.info.name,
        r.max,
        r.rms,
        render::RMS_LIMIT
    );
    out!("image: {}", out.display());
    if r.rms > render::RMS_LIMIT {
        out!("{command} FAILED");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

fn run(cli: Cli) -> Result<ExitCode, String> {
    match cli.command {
        Command::Render {
            export,
            out,
            scene: Some(scene),
        } => {
            render::check_out(&out)?;
            let sc = lobefit::pipelines::scene::load(&scene)?;
            let ex = render::VerifiedExport::open(&export, render::SCENE_FAMILIES)?;
            let gpu = device::Gpu::new()?;
            let r = render::render_scene(&gpu, &ex, &sc, &out)?;
            out!(
                "render {scene}: {}x{} ({} pixels see geometry) on {}; GPU against CPU, relative to the peak: \
                 max {:.2e}, RMS {:.2e} (limit {:.0e} RMS); CPU (order-3 disk SH) against the exact unshadowed \
                 irradiance where every light is above the horizon: max rel {:.2e} at {} pixels",
                render::SCENE_WIDTH,
                render::SCENE_WIDTH * 3 / 4,
                r.pixels,
                gpu.info.name,
                r.max,
                r.rms,
                render::RMS_LIMIT,
                r.vs_exact.0,
                r.vs_exact.1
            );
            out!("image: {}", out.display());
            if r.rms > render::RMS_LIMIT {
                out!("render FAILED");
                return Ok(ExitCode::from(1));
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Render {
            export,
            out,
            scene: None,
        } => {
            render::check_out(&out)?;
            let ex = render::VerifiedExport::open(&export, render::FAMILIES)?;
            let gpu = device::Gpu::new()?;
            let (max, rms, gloss_max) = render::render(&gpu, &ex, &out)?;
            out!(
                "render: {0}x{0} on {1}; GPU against CPU, relative to the peak: max {max:.2e}, RMS {rms:.2e} (limit {2:.0e} RMS); \
                 glossy (lobe-product) pass alone, relative to its peak: max {gloss_max:.2e}",
                render::SIZE,
                gpu.info.name,
                render::RMS_LIMIT
            );
            out!("image: {}", out.display());
            if rms > render::RMS_LIMIT {
                out!("render FAILED");
                return Ok(ExitCode::from(1));
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::RenderIsg {
            export,
            scene,
            width,
            out,
        } => {
            render::check_out(&out)?;
            let sc = lobefit::pipelines::isg::render::scene(&scene)?;
            isg::check_spheres(&sc)?;
            budget::refuse_over(
                "render-isg",
                isg::iterations(sc.spheres.len(), sc.environment.len()),
                &format!("{} SGs, {} spheres", sc.environment.len(), sc.spheres.len()),
            )?;
            let ex = render::VerifiedExport::open(&export, isg::FAMILIES)?;
            let gpu = device::Gpu::new()?;
            let r = isg::render_isg(&gpu, &ex, &sc, width as usize, &out)?;
            report("render-isg", &scene, &r, &gpu, &out)
        }
        Command::RenderShexp {
            export,
            scene,
            width,
            blocker_log,
            out,
        } => {
            use lobefit::pipelines::shexp::shade::{BlockerLog, Settings};
            let mut settings = Settings::default();
            match blocker_log.as_deref() {
                Some("eps") => settings.blocker_log = BlockerLog::Eps,
                Some("ren") => settings.blocker_log = BlockerLog::Ren,
                _ => {}
            }
            render::check_out(&out)?;
            let sc = lobefit::pipelines::shexp::render::scene(&scene)?;
            budget::refuse_over(
                "render-shexp",
                shexp::iterations(sc.spheres.len()),
                &format!("{} spheres", sc.spheres.len()),
            )?;
            let ex = render::VerifiedExport::open(&export, shexp::FAMILIES)?;
            let gpu = device::Gpu::new()?;
            let r = shexp::render_shexp(&gpu, &ex, &sc, width as usize, &settings, &out)?;
            report(
                "render-shexp",
                &format!("{scene} ({:?} blocker log)", settings.blocker_log),
                &r,
                &gpu,
                &out,
            )
        }
        Command::RenderMeunier {
            export,
            scene,
            width,
            light,
            weights,
            depth,
            mask,
            threshold,
            out,
        } => {
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
            // The CPU's own parse of these settings (`eval direct-light`'s flags).
            let flags = lobefit::family::EvalFlags {
                depth: Some(depth as usize),
                mask: Some(mask.clone()),
                weights: Some(weights.clone()),
                light: Some(light.clone()),
                ..Default::default()
            };
            let settings = lobefit_tables::meunier::MaskSettings {
                threshold,
                ..lobefit::pipelines::meunier::direct_light::DirectLightView::from_flags(&flags)?.settings
            };
            render::check_out(&out)?;
            let sc = lobefit::pipelines::meunier::render::scene(&scene)?;
            let ex = render::VerifiedExport::open(&export, meunier::FAMILIES)?;
            let gpu = device::Gpu::new()?;
            let r = meunier::render_meunier(&gpu, &ex, &sc, width as usize, &settings, &out)?;
            report(
                "render-meunier",
                &format!(
                    "{scene} (light {light}, weights {weights}, depth {} {}, t_i {threshold:e})",
                    settings.depth,
                    settings.mode.name()
                ),
                &r,
                &gpu,
                &out,
            )
        }
        Command::RenderRigs { width, wrap, out } => {
            let wraps = match wrap {
                Some(a) if (0.0..=1.0).contains(&a) => vec![a],
                Some(a) => return Err(format!("--wrap {a}: the wrap parameter lies in [0, 1]")),
                None => vec![0.0, lobefit::pipelines::rigs::render::WRAP_A],
            };
            // The kernel's wrap is an f32: the CPU uses, and the report names, the same.
            let wraps: Vec<f64> = wraps.into_iter().map(|a| f64::from(a as f32)).collect();
            render::check_out(&out)?;
            let gpu = device::Gpu::new()?;
            let (pixels, rows) = rigs::render_rigs(&gpu, width as usize, &wraps, &out)?;
            out!(
                "render-rigs: {}x{} ({pixels} pixels see the car) on {}; GPU against the CPU, relative to each \
                 image's peak (limit {:.0e} RMS):",
                width,
                (width * 3 / 4).max(3),
                gpu.info.name,
                render::RMS_LIMIT
            );
            let mut failed = 0;
            for r in &rows {
                let pass = r.rms <= render::RMS_LIMIT;
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
            out!("image: {}", out.display());
            if failed > 0 {
                out!("render-rigs FAILED: {failed} of {} rows", rows.len());
                return Ok(ExitCode::from(1));
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Cost { export } => {
            let ex = conformance::read_export(&export)?;
            let gpu = device::Gpu::new()?;
            out!(
                "device: {} ({:?}, driver {})",
                gpu.info.name,
                gpu.info.backend,
                gpu.info.driver_info
            );
            out!("{:<28} {:>16} {:>14}", "function", "SPIR-V instr.", "evals/s");
            for c in cost::costs(&gpu, &ex)? {
                out!("{:<28} {:>16} {:>14.3e}", c.function, c.spirv, c.per_second);
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::GpuCheck { export } => {
            // The manifest's promises become this check's limits: they are verified
            // first (`lobefit check --export`: texels rebuilt, errors re-measured).
            let failed: Vec<String> = lobefit::export::run::check_export(&export)?
                .into_iter()
                .filter(|c| !c.pass)
                .map(|c| format!("{} {} {}", c.family, c.entry.output, c.entry.metric))
                .collect();
            if !failed.is_empty() {
                return Err(format!(
                    "{}: the export fails `lobefit check --export` ({}); its promises are no limits",
                    export.display(),
                    failed.join("; ")
                ));
            }
            let ex = conformance::read_export(&export)?;
            let gpu = device::Gpu::new()?;
            out!(
                "device: {} ({:?}, driver {} {}), float32-filterable: {}",
                gpu.info.name,
                gpu.info.backend,
                gpu.info.driver,
                gpu.info.driver_info,
                gpu.float32_filterable
            );
            out!(
                "export: {} ({} {}, {} samples, seed {:#x})",
                export.display(),
                ex.manifest.format,
                ex.manifest.storage,
                ex.manifest.samples,
                ex.manifest.seed
            );
            let bits = conformance::probe_weight_bits(&gpu)?;
            out!(
                "hardware linear filter: {bits} fractional weight bits (probe){}",
                if bits >= 12 {
                    "; emulated with exact weights"
                } else {
                    "; emulated with 8-bit weights"
                }
            );
            let baked_path = export.join(
                ex.manifest
                    .baked_shaders
                    .first()
                    .ok_or("the manifest lists no baked shader")?,
            );
            let baked = lobefit::io::read_text(&baked_path, 64 << 20)?;
            let mut rows = conformance::check_textured(&gpu, &ex, bits, &baked)?;
            rows.extend(conformance::check_baked(&gpu, &export, &ex)?);
            rows.extend(conformance::check_closed(&gpu, ex.manifest.samples, ex.manifest.seed)?);
            let dummy = gpu.upload(&conformance::dummy_texture(), lobefit::export::Storage::F32)?;
            rows.extend(world::check_closed_world(
                &gpu,
                &dummy,
                ex.manifest.samples,
                ex.manifest.seed,
            )?);
            rows.extend(conformance::check_glslang(&export, &ex.manifest.baked_shaders)?);
            let mut failed = 0;
            out!(
                "{:<16} {:<4} {:<8} {:>5} {:>9} {:<14} | vs reference: quantity metric measured (limit)",
                "function",
                "stor",
                "filter",
                "n",
                "vs CPU",
                "(CPU side)"
            );
            for r in &rows {
                let mut refs: Vec<String> = r
                    .vs_ref
                    .iter()
                    .map(|(q, m, l)| format!("{q} {m:.2e} ({l:.1e})"))
                    .collect();
                if !r.info.is_empty() {
                    let info: Vec<String> = r
                        .info
                        .iter()
                        .map(|(q, m, l)| format!("{q} {m:.1e} [f64 {l:.0e}]"))
                        .collect();
                    refs.push(format!("beside: {}", info.join(", ")));
                }
                let pass = r.pass();
                if !pass {
                    failed += 1;
                }
                out!(
                    "{:<16} {:<4} {:<8} {:>5} {:>9.2e} {:<14} | {}{}",
                    r.function,
                    r.storage,
                    r.filter,
                    r.samples,
                    r.vs_cpu,
                    r.cpu_what,
                    refs.join(", "),
                    if pass { "" } else { "  MISS" }
                );
            }
            if failed > 0 {
                out!("gpu-check FAILED: {failed} of {} rows miss their limits", rows.len());
                return Ok(ExitCode::from(1));
            }
            out!("gpu-check passed: {} rows", rows.len());
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
