//! lobefit-gpu: the shader library and exported textures on a real Vulkan device.
//!
//! `lobefit-gpu gpu-check --export DIR` runs every shader function at the checker's
//! seeded off-grid samples and compares with the CPU emulation and the references;
//! `lobefit-gpu render NAME` renders a pipeline's scene on the device against the CPU
//! (`renders`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// `println!` that returns an error instead of panicking when stdout is a closed pipe
/// or a full disk (inside functions returning `Result<_, String>`).
macro_rules! out {
    ($($t:tt)*) => {
        writeln!(std::io::stdout(), $($t)*).map_err(|e| format!("cannot write the output: {e}"))?
    };
}

mod bench;
mod budget;
mod conformance;
mod cost;
mod device;
mod isg;
mod kernel;
mod mc;
mod meunier;
mod render;
mod renders;
mod rigs;
mod shexp;
mod world;

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
        /// Also print (stderr) the samples where the device errs most, per family and
        /// filter, and its linear filter's weights against rules for them: what to
        /// send with a report of a failing row.
        #[arg(long)]
        worst: bool,
        /// Emulate the hardware filter with 8-bit weights (rounded to nearest, down and
        /// up: the span a device is held to) whatever the probe finds: on a device with
        /// exact weights (lavapipe) every hardware row must then pass too, its weights
        /// lying between the rounded ones.
        #[arg(long)]
        eight_bit: bool,
    },
    /// Render NAME on the GPU against the CPU to a PNG: a pipeline of `lobefit render`
    /// (its registry's names) or `library`, the shader library's test image; exit 1 when
    /// the RMS difference exceeds 1e-4 of the CPU image's peak. Its subcommands come
    /// from the list of renders (`renders::RENDERS`).
    Render,
    /// Each analytic render kernel (isg, shexp, meunier, rigs) timed per frame on this
    /// device, its error against the CPU pipeline and its static SPIR-V counts:
    /// OUT/bench.json and OUT/bench.md.
    Bench(bench::Args),
    /// The device's Monte Carlo estimate of an ISG scene (spheres under an SG sky)
    /// against the CPU's with the same estimator and samples: exit 1 when they disagree
    /// beyond their standard errors.
    Mc(mc::Args),
    /// Per shader function: static counts of its kernel's SPIR-V (naga: instructions,
    /// texture instructions, loops) and GPU evaluations per second on this device.
    Cost {
        /// A `lobefit export` directory.
        #[arg(long, value_name = "DIR")]
        export: PathBuf,
    },
}

fn run(cli: Cli) -> Result<ExitCode, String> {
    match cli.command {
        // Dispatched in `main`, through the list of renders.
        Command::Render => Err("render: no render named (lobefit-gpu render --help lists them)".into()),
        Command::Cost { export } => cost(&export),
        Command::Bench(a) => bench::run(a),
        Command::Mc(a) => mc::run(a),
        Command::GpuCheck {
            export,
            worst,
            eight_bit,
        } => {
            conformance::WORST.store(worst, std::sync::atomic::Ordering::Relaxed);
            gpu_check(&export, eight_bit)
        }
    }
}

/// `cost --export DIR`.
fn cost(export: &Path) -> Result<ExitCode, String> {
    let ex = conformance::read_export(export)?;
    let gpu = device::Gpu::new()?;
    out!(
        "device: {} ({:?}, driver {})",
        gpu.info.name,
        gpu.info.backend,
        gpu.info.driver_info
    );
    out!(
        "{:<28} {:>14} {:>8} {:>6} {:>14}",
        "function",
        "SPIR-V instr.",
        "texture",
        "loops",
        "evals/s"
    );
    for c in cost::costs(&gpu, &ex)? {
        out!(
            "{:<28} {:>14} {:>8} {:>6} {:>14.3e}",
            c.function,
            c.counts.instructions,
            c.counts.texture_ops,
            c.counts.loops.len(),
            c.per_second
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// `gpu-check --export DIR`.
fn gpu_check(export: &Path, eight_bit: bool) -> Result<ExitCode, String> {
    // The manifest's promises become this check's limits: they are verified
    // first (`lobefit check --export`: texels rebuilt, errors re-measured).
    let failed: Vec<String> = lobefit::export::run::check_export(export)?
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
    let ex = conformance::read_export(export)?;
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
    let probed = conformance::probe_weight_bits(&gpu)?;
    let bits = if eight_bit { 8 } else { probed };
    out!(
        "hardware linear filter: {probed} fractional weight bits (probe){}{}",
        if eight_bit { ", --eight-bit" } else { "" },
        if bits >= 12 {
            "; emulated with exact weights"
        } else {
            "; emulated with 8-bit weights"
        }
    );
    if conformance::WORST.load(std::sync::atomic::Ordering::Relaxed) {
        for line in conformance::probe_filter_rules(&gpu)? {
            eprintln!("{line}");
        }
    }
    let baked_path = export.join(
        ex.manifest
            .baked_shaders
            .first()
            .ok_or("the manifest lists no baked shader")?,
    );
    let baked = lobefit::io::read_text(&baked_path, 64 << 20)?;
    let mut rows = conformance::check_textured(&gpu, &ex, bits, &baked)?;
    rows.extend(conformance::check_baked(&gpu, export, &ex)?);
    rows.extend(conformance::check_closed(&gpu, ex.manifest.samples, ex.manifest.seed)?);
    rows.push(conformance::check_trig(&gpu)?);
    let dummy = gpu.upload(&conformance::dummy_texture(), lobefit::export::Storage::F32)?;
    rows.extend(world::check_closed_world(
        &gpu,
        &dummy,
        ex.manifest.samples,
        ex.manifest.seed,
    )?);
    rows.extend(conformance::check_glslang(export, &ex.manifest.baked_shaders)?);
    let failed = print_rows(&rows)?;
    if failed > 0 {
        out!("gpu-check FAILED: {failed} of {} rows miss their limits", rows.len());
        return Ok(ExitCode::from(1));
    }
    out!("gpu-check passed: {} rows", rows.len());
    Ok(ExitCode::SUCCESS)
}

/// Prints gpu-check's table of rows; returns how many miss their limits.
fn print_rows(rows: &[conformance::Row]) -> Result<usize, String> {
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
    for r in rows {
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
    Ok(failed)
}

fn main() -> ExitCode {
    let matches = renders::with_renders(Cli::command()).get_matches();
    let result = match matches.subcommand() {
        Some(("render", m)) => match m.subcommand() {
            Some((name, options)) => renders::run(name, options),
            None => Err("render: no render named (lobefit-gpu render --help lists them)".into()),
        },
        _ => Cli::from_arg_matches(&matches).map_err(|e| e.to_string()).and_then(run),
    };
    match result {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
