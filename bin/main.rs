//! `lobefit` command line: argument parsing and output formatting only; all
//! numerics live in the library.

use std::fmt::Write as _;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::builder::PossibleValuesParser;
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use lobefit::check::{self, CheckOptions};
use lobefit::export::layout::Filter;
use lobefit::export::run::ExportOptions;
use lobefit::export::{Format, Storage};
use lobefit::family::{EvalFlags, Fit};
use lobefit::fits::{self, Backend, FitOptions, Method};
use lobefit::tables::Table;

/// Default directory of the committed tables, relative to the repository root.
const DEFAULT_TABLES: &str = "tables/data";
/// File extension of table files.
const EXT: &str = "lobefit";

#[derive(Parser)]
#[command(
    name = "lobefit",
    version,
    about = "Fit, build, check and query lobe / SG / SH lookup tables"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum BackendArg {
    Argmin,
    Nlopt,
}

#[derive(Clone, Copy, ValueEnum)]
enum SphereMethodArg {
    Kmeans,
    KmeansMoment,
    Tree,
    Cover,
    Optimize,
}

#[derive(Clone, Copy, ValueEnum)]
enum MethodArg {
    Fast,
    Paper,
}

#[derive(clap::Args)]
struct FitArgs {
    /// Fitting method: the product's (fast) or the paper-faithful baseline (paper).
    #[arg(long, value_enum, default_value = "fast")]
    method: MethodArg,
    /// Optimizer backend for minimised families (nlopt needs the `nlopt` cargo feature).
    #[arg(long, value_enum, default_value = "argmin")]
    backend: BackendArg,
    /// Worker threads (default: all cores; at most 4 per core). Results do not depend on it.
    #[arg(long, value_parser = threads_arg)]
    threads: Option<usize>,
}

#[derive(Subcommand)]
enum Command {
    /// Build every table (or those named by --only) into --out.
    BuildTables {
        /// Only these families (comma-separated).
        #[arg(long, value_delimiter = ',', value_parser = PossibleValuesParser::new(fits::names()))]
        only: Vec<String>,
        /// Output directory.
        #[arg(long, default_value = DEFAULT_TABLES)]
        out: PathBuf,
        #[command(flatten)]
        fit: FitArgs,
    },
    /// Fit one family and write its table.
    Fit {
        /// Family name.
        #[arg(value_parser = PossibleValuesParser::new(fits::names()))]
        family: String,
        /// Output file; or an existing directory (or a path ending in '/'), then
        /// FAMILY.lobefit inside it.
        #[arg(long, default_value = DEFAULT_TABLES)]
        out: PathBuf,
        #[command(flatten)]
        fit: FitArgs,
    },
    /// Check every table against independent quadrature / closed forms.
    Check {
        /// Fewer random off-grid points (CI).
        #[arg(long)]
        quick: bool,
        /// Print the report as JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Directory holding the tables.
        #[arg(long, default_value = DEFAULT_TABLES)]
        tables: PathBuf,
        /// Only these families (comma-separated).
        #[arg(long, value_delimiter = ',', value_parser = PossibleValuesParser::new(fits::names()))]
        only: Vec<String>,
        /// Number of random off-grid points (overrides --quick).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
        points: Option<u32>,
        /// Seed of the random off-grid points.
        #[arg(long)]
        seed: Option<u64>,
        /// Also compare every reported metric with this saved `check --json` report
        /// (same --quick/--points/--seed); fail when one grew past --baseline-factor.
        #[arg(long, value_name = "FILE.json")]
        baseline: Option<PathBuf>,
        /// How much a metric may grow against the baseline before the check fails.
        #[arg(long, default_value_t = lobefit::ci::DEFAULT_FACTOR, requires = "baseline", value_parser = factor_arg)]
        baseline_factor: f64,
        /// Also write the verdicts as JUnit XML to this file.
        #[arg(long, value_name = "FILE.xml")]
        junit: Option<PathBuf>,
        /// Check a `lobefit export` directory instead: read every texture back with
        /// independent readers, sample it as a GPU does (manual and 8-bit hardware
        /// filtering, f32 arithmetic) against the references, and compare with the
        /// errors its manifest promises.
        #[arg(long, value_name = "DIR", conflicts_with_all = ["baseline", "junit", "only", "points", "seed", "quick", "json", "tables"])]
        export: Option<PathBuf>,
    },
    /// Write the tables as GPU textures with a manifest (mappings, packing, measured error).
    Export {
        /// Only these families (comma-separated table kinds; default: every textured family).
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
        /// Container: ktx2, dds, inc (C/C++ header) or raw (texels + JSON sidecar).
        /// Optional with --shaders alone (shaders only, no textures).
        #[arg(long, value_parser = ["ktx2", "dds", "inc", "raw"], required_unless_present = "shaders")]
        format: Option<String>,
        /// Also write the shader library (comma-separated: wgsl, glsl, hlsl):
        /// lobefit.wgsl, lobefit.glsl + lobefit.es.glsl, lobefit.hlsl.
        #[arg(long, value_delimiter = ',', value_parser = ["wgsl", "glsl", "hlsl"])]
        shaders: Vec<String>,
        /// Texel precision.
        #[arg(long, value_parser = ["f32", "f16"], default_value = "f32")]
        storage: String,
        /// Output directory (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Export textures that miss their target (the larger of the family's limit and the
        /// storage's rounding floor: f16 beyond its floor, a coarse --scale); the manifest
        /// records the measured error.
        #[arg(long)]
        allow_lossy: bool,
        /// Resolution: nodes per axis relative to the table's (0.25: a quarter; values
        /// resampled through the table's interpolation).
        #[arg(long, default_value_t = 1.0)]
        scale: f64,
    },
    /// Describe a table file: header, axes, channels, fit settings, diagnostics.
    Inspect {
        /// Table file.
        file: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Evaluate a family on CSV rows from stdin (a header line naming the input columns, then numbers).
    #[command(after_help = lobefit::catalog::eval_help())]
    Eval {
        /// Family name.
        #[arg(value_parser = PossibleValuesParser::new(lobefit::catalog::eval_names()))]
        family: String,
        /// The family's or pipeline's own flags (built from their declarations: see
        /// [`eval_flag_args`]).
        #[arg(skip)]
        flags: EvalFlags,
        /// Directory holding the tables (default: the tables compiled into this binary).
        #[arg(long, conflicts_with = "table")]
        tables: Option<PathBuf>,
        /// A specific table file.
        #[arg(long)]
        table: Option<PathBuf>,
        /// Use the reference (closed form, quadrature or the optimizer at that point).
        #[arg(long, conflicts_with_all = ["table", "tables"])]
        exact: bool,
    },
    /// Render a scene with a lobe pipeline and its Monte Carlo reference (PNGs and a
    /// summary of the measured errors).
    Render {
        /// The pipeline (`lobefit render --help` lists them; docs/pipelines.md).
        #[arg(value_parser = PossibleValuesParser::new(lobefit::pipelines::registry().iter().map(|p| p.name)))]
        name: String,
        /// Scene: one of the pipeline's built-in scenes (meunier: fig13, glossy; isg:
        /// fig12, fig12-diffuse, sweep; shexp: whale, whale-diffuse, wrecking; rigs: fig1,
        /// drive), all of them, or the path of a scene file (docs/pipelines.md).
        #[arg(long, default_value = "all")]
        scene: String,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Image width in pixels (height 3/4 of it).
        #[arg(long, default_value_t = 160, value_parser = clap::value_parser!(u32).range(4..=2048))]
        width: u32,
        /// Reference light samples per pixel.
        #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(2..=1_000_000))]
        spp: u32,
        /// The error breakdown at every Nth pixel in x and y.
        #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
        breakdown_stride: u32,
        /// Worker threads (default: all cores). Results do not depend on it.
        #[arg(long, value_parser = threads_arg)]
        threads: Option<usize>,
        /// Render an animated scene as N frames (times 0 to 1): per frame the method, its
        /// reference and the strongest Monte Carlo at the method's time, with the temporal
        /// error (isg, meunier; docs/meshes.md, Motion). `--scene all`: the pipeline's animations.
        #[arg(long, value_parser = clap::value_parser!(u32).range(2..=240))]
        frames: Option<u32>,
        /// After each scene's render, measure its Pareto chart at WIDTH pixels: every
        /// analytic configuration and every Monte Carlo estimator (plain, QMC, control
        /// variates, adaptive, hybrid) against a 2^17-sample reference, times as medians
        /// of 5 runs; writes <pipeline>-<scene>-pareto.png and -summary.json in --out
        /// (isg, shexp, meunier; minutes a scene at 24, growing with the pixels;
        /// docs/pipelines.md, Stronger baselines).
        #[arg(long, value_name = "WIDTH", conflicts_with = "frames",
              value_parser = clap::value_parser!(u32).range(4..=160))]
        pareto: Option<u32>,
    },
    /// Fit a sphere set to a closed triangle mesh (OBJ, glTF, GLB) and report its fit quality:
    /// volume error and one-sided Hausdorff distances, by sampling (docs/meshes.md).
    Spheres {
        /// The mesh (.obj, .gltf or .glb; closed, or nearly: the inside test takes the majority of
        /// three rays' parities).
        #[arg(long)]
        mesh: PathBuf,
        /// Number of spheres.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
        count: u32,
        /// optimize (the default: the best measured, docs/meshes.md): cover's balls
        /// refined by direct minimisation of the symmetric difference, with a
        /// Hausdorff guard; cover: inner balls chosen greedily for covered inside
        /// minus outside volume; kmeans: Lloyd iterations on interior samples,
        /// covering spheres; kmeans-moment: the same clusters, second-moment radii;
        /// tree: a bounding-sphere tree's leaves, split best first.
        #[arg(long, value_enum, default_value = "optimize")]
        method: SphereMethodArg,
        /// Seed of the samples (and of k-means++'s start).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Points drawn to measure the fit's quality.
        #[arg(long, default_value_t = 200_000, value_parser = clap::value_parser!(u32).range(1000..=100_000_000))]
        samples: u32,
        /// With --method optimize: bound the balls' overlap, Σ ball volumes ≤ R × the
        /// union's volume (SH exponentiation sums the balls' logs, so it wants little).
        #[arg(long, value_name = "R", value_parser = overlap_arg)]
        max_overlap: Option<f64>,
        /// The sphere-set file to write (JSON, in the mesh's coordinates).
        #[arg(long)]
        out: PathBuf,
    },
    /// Fit an HDR environment map (equirectangular OpenEXR or Radiance .hdr; z up, row
    /// 0 the zenith, docs/environment.md) with K RGB spherical Gaussians, and measure
    /// them against the map and against SH of orders 3 and 5.
    FitEnv {
        /// The map (.exr or .hdr).
        #[arg(long)]
        map: PathBuf,
        /// Number of SGs (a sun, if the map has one, is the first).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
        sgs: u32,
        /// The SG list to write (JSON: `{"sgs": [...], ...}`, pastes into a scene's
        /// `environment`).
        #[arg(long)]
        out: PathBuf,
    },
    /// Prefilter an HDR environment map with spherical Gaussians of sharpness 1 to
    /// 8192 (Γ_L, docs/environment.md) into a lobefit table, and check it against
    /// quadrature at random (direction, sharpness).
    Prefilter {
        /// The map (.exr or .hdr).
        #[arg(long)]
        map: PathBuf,
        /// The table to write (`.lobefit`).
        #[arg(long)]
        out: PathBuf,
        /// Points of the check against quadrature (0: none).
        #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(0..=100_000))]
        check: u32,
        /// Also write the table as a KTX2 2D array texture for the shader library's
        /// `lf_prefiltered` (docs/environment.md, "Γ_L on the GPU").
        #[arg(long)]
        texture: Option<PathBuf>,
        /// The texture's texel precision.
        #[arg(long, value_parser = ["f32", "f16"], default_value = "f32", requires = "texture")]
        texture_storage: String,
    },
    /// Write a family's figures (PNG) into a directory.
    Plot {
        /// Figure set.
        #[arg(value_parser = PossibleValuesParser::new(lobefit::catalog::plots().into_iter().map(|(n, _)| n)))]
        name: String,
        /// Output directory.
        #[arg(long, default_value = "plots")]
        out: PathBuf,
    },
}

/// `eval`'s `--NAME` arguments, one per flag the families and pipelines declare
/// (`lobefit::catalog::eval_flags`), its help the queries that take it and their values.
fn eval_flag_args() -> Vec<clap::Arg> {
    lobefit::catalog::eval_flags()
        .into_iter()
        .map(|(flag, takers)| {
            // Queries saying the same of the flag share one clause.
            let mut clauses: Vec<(Vec<&str>, &str)> = Vec::new();
            for (query, help) in takers {
                match clauses.iter_mut().find(|(_, h)| *h == help) {
                    Some((qs, _)) => qs.push(query),
                    None => clauses.push((vec![query], help)),
                }
            }
            let help: Vec<String> = clauses
                .iter()
                .map(|(qs, h)| format!("{}: {h}", qs.join(", ")))
                .collect();
            let arg = clap::Arg::new(flag.name).long(flag.name).help(help.join("; "));
            if flag.count {
                arg.value_name("N").value_parser(clap::value_parser!(usize))
            } else {
                arg.value_name("VALUE")
            }
        })
        .collect()
}

/// The declared flags given in `eval`'s matches.
fn eval_flags_of(m: &clap::ArgMatches) -> EvalFlags {
    let mut flags = EvalFlags::default();
    for (flag, _) in lobefit::catalog::eval_flags() {
        if flag.count {
            if let Some(n) = m.get_one::<usize>(flag.name) {
                flags = flags.with_count(flag.name, *n);
            }
        } else if let Some(v) = m.get_one::<String>(flag.name) {
            flags = flags.with(flag.name, v.clone());
        }
    }
    flags
}

fn backend(b: BackendArg) -> Result<Backend, String> {
    match b {
        BackendArg::Argmin => Ok(Backend::Argmin),
        BackendArg::Nlopt if cfg!(feature = "nlopt") => Ok(Backend::Nlopt),
        BackendArg::Nlopt => Err("--backend nlopt needs a build with `--features nlopt`".into()),
    }
}

fn fit_options(fit: &FitArgs) -> Result<FitOptions, String> {
    Ok(FitOptions {
        backend: backend(fit.backend)?,
        method: match fit.method {
            MethodArg::Fast => Method::Fast,
            MethodArg::Paper => Method::Paper,
        },
    })
}

/// Parses `--threads`: 1 to 4 × the available cores. More threads than that
/// only add stacks and scheduling (65535 of them ran for minutes on a small job).
fn threads_arg(s: &str) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = 4 * cores;
    match s.parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected a thread count from 1 to {max} (4 per available core, {cores} cores)"
        )),
    }
}

/// Parses `--max-overlap`: a finite number ≥ 1.
fn overlap_arg(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(r) if r.is_finite() && r >= 1.0 => Ok(r),
        _ => Err("expected a finite number ≥ 1 (Σ ball volumes / union volume)".into()),
    }
}

/// Parses `--baseline-factor`: a finite number ≥ 1 (refused before the check runs).
fn factor_arg(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(f) if f.is_finite() && f >= 1.0 => Ok(f),
        _ => Err("expected a finite number ≥ 1".into()),
    }
}

fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool, String> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        b = b.num_threads(n);
    }
    b.build().map_err(|e| e.to_string())
}

fn select(only: &[String], opts: FitOptions) -> Vec<Box<dyn Fit>> {
    fits::registry(opts)
        .into_iter()
        .filter(|f| only.is_empty() || only.iter().any(|o| o == f.kind()))
        .collect()
}

fn progress(len: u64, label: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{prefix:>15} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_prefix(label.to_string());
    pb
}

/// Builds the given families into `out_path(kind)`; prints a summary.
fn build(families: &[Box<dyn Fit>], threads: Option<usize>, out_path: &dyn Fn(&str) -> PathBuf) -> Result<(), String> {
    // Every output checked before minutes of fitting.
    for f in families {
        out_file("--out", &out_path(f.kind()))?;
    }
    let pool = pool(threads)?;
    let t_all = Instant::now();
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for f in families {
        let entries: u64 = f.axes().iter().map(|a| a.count as u64).product();
        let pb = progress(entries, f.kind());
        let t = Instant::now();
        let result = pool.install(|| lobefit::build::build(f.as_ref(), &|| pb.inc(1)));
        pb.finish_and_clear();
        match result {
            Ok(built) => {
                let path = out_path(f.kind());
                lobefit::io::write_atomic(&path, &built.bytes)
                    .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
                rows.push(format!(
                    "{:<15} {:>8} {:>9.2} {:>10}  {}",
                    f.kind(),
                    built.meta.diagnostics.entries,
                    t.elapsed().as_secs_f64(),
                    built.bytes.len(),
                    path.display()
                ));
            }
            Err(e) => failures.push(e.to_string()),
        }
    }
    // No accuracy column: each family's fit residual means something of its own (the
    // optimiser's objective, in the family's units), which compared with nothing reads
    // as a verdict. `lobefit check` holds every table to its family's targets.
    let mut summary = format!(
        "{:<15} {:>8} {:>9} {:>10}  file\n",
        "family", "entries", "wall s", "bytes"
    );
    for r in &rows {
        summary.push_str(r);
        summary.push('\n');
    }
    summary.push_str(&format!("total wall time {:.2} s\n", t_all.elapsed().as_secs_f64()));
    if failures.is_empty() {
        summary.push_str("accuracy: `lobefit check --quick` compares every table with its family's targets\n");
    }
    note(&summary);
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!("not written:\n  {}", failures.join("\n  ")))
    }
}

fn table_path(dir: &Path, kind: &str) -> PathBuf {
    dir.join(format!("{kind}.{EXT}"))
}

fn inspect(file: &Path, json: bool) -> Result<(), String> {
    let t = Table::from_path(file).map_err(|e| e.to_string())?;
    let (h, m) = (t.header(), t.meta());
    if json {
        let v = serde_json::json!({
            "file": file.display().to_string(),
            "format_version": format!("{}.{}", h.major, h.minor),
            "kind": h.kind,
            "meta_len": h.meta_len,
            "payload_offset": h.payload_offset,
            "payload_len": h.payload_len,
            "meta": m,
        });
        let text = serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?;
        return emit(&format!("{text}\n"));
    }
    // Formatting into a String cannot fail; the one write to stdout can.
    let mut s = String::new();
    let _ = writeln!(s, "file        {}", file.display());
    let _ = writeln!(s, "format      {}.{} (checksums ok)", h.major, h.minor);
    let _ = writeln!(s, "kind        {} (table version {})", m.kind, m.table_version);
    let _ = writeln!(s, "generator   {}", m.generator);
    let _ = writeln!(s, "about       {}", m.description);
    let _ = writeln!(
        s,
        "layout      metadata {} B at 64, payload {} B at {} (f32 LE, C order, channels fastest)",
        h.meta_len, h.payload_len, h.payload_offset
    );
    for (i, a) in m.axes.iter().enumerate() {
        let _ = writeln!(
            s,
            "axis {i}      {} [{}] in [{}, {}], {} nodes, {:?}, mapping {:?}",
            a.name, a.unit, a.lo, a.hi, a.count, a.placement, a.mapping
        );
    }
    for c in &m.channels {
        let _ = writeln!(
            s,
            "channel     {} [{}] {:?}: {}",
            c.name, c.unit, c.encoding, c.description
        );
    }
    let _ = writeln!(
        s,
        "fit         {} (settings hash {:016x})",
        m.fit.method, m.fit.settings_hash
    );
    for (k, v) in &m.fit.settings {
        let _ = writeln!(s, "  {k} = {v}");
    }
    let d = &m.diagnostics;
    let _ = writeln!(
        s,
        "diagnostics {}/{} converged; residual max {:.3e} mean {:.3e} ({}); max iterations {}",
        d.converged, d.entries, d.max_residual, d.mean_residual, d.residual_meaning, d.max_iterations
    );
    for th in &m.thresholds {
        let _ = writeln!(s, "threshold   {}.{} <= {:e}", th.output, th.metric, th.limit);
    }
    emit(&s)
}

/// Why a command failed: its arguments (exit 2, as clap's own usage errors: a value
/// clap cannot check, such as a family's `--model` or `--order` range, or `export
/// --only`/`--scale`), or anything else (exit 1).
enum Failure {
    Usage(String),
    Run(String),
}

impl From<String> for Failure {
    fn from(e: String) -> Self {
        Failure::Run(e)
    }
}

fn run(cli: Cli) -> Result<ExitCode, Failure> {
    match cli.command {
        Command::BuildTables { only, out, fit } => {
            let opts = fit_options(&fit).map_err(Failure::Usage)?;
            build(&select(&only, opts), fit.threads, &|k| table_path(&out, k))?;
        }
        Command::Fit { family, out, fit } => {
            let opts = fit_options(&fit).map_err(Failure::Usage)?;
            let f = select(&[family], opts);
            let is_file = !(out.is_dir() || out.as_os_str().to_string_lossy().ends_with('/'));
            build(&f, fit.threads, &|k| {
                if is_file {
                    out.clone()
                } else {
                    table_path(&out, k)
                }
            })?;
        }
        Command::Check {
            quick,
            json,
            tables,
            only,
            points,
            seed,
            baseline,
            baseline_factor,
            junit,
            export,
        } => {
            if let Some(dir) = export {
                return Ok(check_export(&dir)?);
            }
            if let Some(p) = &junit {
                out_file("--junit", p)?;
            }
            // Read the baseline first: a bad file fails before minutes of checking.
            let saved: Option<Vec<check::FamilyReport>> = match &baseline {
                None => None,
                Some(p) => {
                    let text = std::fs::read_to_string(p).map_err(|e| format!("--baseline {}: {e}", p.display()))?;
                    Some(
                        serde_json::from_str(&text).map_err(|e| {
                            format!("--baseline {}: not a `lobefit check --json` report: {e}", p.display())
                        })?,
                    )
                }
            };
            let mut opts = if quick { CheckOptions::QUICK } else { CheckOptions::FULL };
            if let Some(p) = points {
                opts.offgrid = p as usize;
            }
            if let Some(s) = seed {
                opts.seed = s;
            }
            let reports: Vec<_> = select(&only, FitOptions::default())
                .iter()
                .map(|f| check::check_family(f.as_ref(), &table_path(&tables, f.kind()), opts))
                .collect();
            let comparisons = match &saved {
                None => None,
                Some(b) => Some(lobefit::ci::compare(&reports, b, baseline_factor)?),
            };
            if json {
                let text = serde_json::to_string_pretty(&reports).map_err(|e| e.to_string())?;
                emit(&format!("{text}\n"))?;
            } else {
                emit(&check::render(&reports))?;
            }
            if let Some(c) = &comparisons {
                note(&lobefit::ci::render(c, baseline_factor));
            }
            if let Some(p) = &junit {
                lobefit::io::write_atomic(p, lobefit::ci::junit(&reports, comparisons.as_deref()).as_bytes())
                    .map_err(|e| format!("--junit {}: {e}", p.display()))?;
            }
            let regressed = comparisons.iter().flatten().any(|c| !c.pass);
            if reports.iter().any(|r| !r.pass) || regressed {
                note("check FAILED\n");
                return Ok(ExitCode::from(1));
            }
        }
        Command::Inspect { file, json } => inspect(&file, json)?,
        Command::Export {
            only,
            format,
            storage,
            out,
            allow_lossy,
            scale,
            shaders,
        } => {
            out_dir(&out)?;
            if format.is_some() {
                lobefit::export::run::check_dir(&out)?;
            }
            let mut s = String::new();
            if !shaders.is_empty() {
                let langs = shaders
                    .iter()
                    .map(|l| lobefit::export::shaders::ShaderLang::parse(l))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(Failure::Usage)?;
                for p in lobefit::export::shaders::write(&langs, &out)? {
                    let _ = writeln!(s, "shader library: {}", p.display());
                }
            }
            let Some(format) = format else {
                emit(&s)?;
                return Ok(ExitCode::SUCCESS);
            };
            let format = match format.as_str() {
                "ktx2" => Format::Ktx2,
                "dds" => Format::Dds,
                "inc" => Format::Inc,
                _ => Format::Raw,
            };
            let storage = if storage == "f16" { Storage::F16 } else { Storage::F32 };
            let opts = ExportOptions {
                only,
                format,
                storage,
                scale,
                allow_lossy,
            };
            lobefit::export::run::validate(&opts).map_err(Failure::Usage)?;
            let m = lobefit::export::run::export(&opts, &out)?;
            for f in &m.families {
                let files: Vec<&str> = f.textures.iter().map(|t| t.file.as_str()).collect();
                let bytes: u64 = f.textures.iter().map(|t| t.bytes).sum();
                let _ = writeln!(
                    s,
                    "{:<14} {:<22} {:>9} B  {}",
                    f.family,
                    files.join(","),
                    bytes,
                    worst_errors(&f.error)
                );
            }
            let _ = writeln!(
                s,
                "manifest: {}",
                out.join(lobefit::export::manifest::MANIFEST).display()
            );
            emit(&s)?;
        }
        Command::Eval {
            family,
            flags,
            tables,
            table,
            exact,
        } => {
            // The family and its flags: what clap cannot check (a flag the family does
            // not take, a value outside its range, a scene the family cannot shade) is
            // a usage error too; a scene file that cannot be read or parsed is the
            // file's error, as a table file's is.
            let f = lobefit::catalog::for_eval(&family, &flags, FitOptions::default()).map_err(|e| match e {
                lobefit::family::EvalError::Usage(e) => Failure::Usage(e),
                lobefit::family::EvalError::Input(e) => Failure::Run(e),
            })?;
            let runtime = if exact {
                None
            } else {
                let (t, source) = match (table, tables) {
                    (Some(p), _) => (Table::from_path(&p), p.display().to_string()),
                    (None, Some(dir)) => {
                        let p = table_path(&dir, f.kind());
                        (Table::from_path(&p), p.display().to_string())
                    }
                    (None, None) => (
                        Table::from_bytes(f.embedded()),
                        "the embedded default table".to_string(),
                    ),
                };
                let t = t.map_err(|e| e.to_string())?;
                Some(f.runtime(t).map_err(|e| format!("{source}: {e}"))?)
            };
            let stdout = std::io::stdout();
            let done = lobefit::eval::eval_csv(f.as_ref(), runtime.as_deref(), std::io::stdin().lock(), stdout.lock())
                .map_err(|e| e.to_string())?;
            // Per-row notes (an --exact estimate short of its target), the first 20.
            for (line, note) in done.notes.iter().take(20) {
                note_line(&format!("warning: line {line}: {note}"));
            }
            if done.notes.len() > 20 {
                note_line(&format!(
                    "warning: and {} rows more with such notes",
                    done.notes.len() - 20
                ));
            }
            for c in done.caveats {
                eprintln!(
                    "warning: {} row{} (the first on line {}): {}",
                    c.rows,
                    if c.rows == 1 { "" } else { "s" },
                    c.first_line,
                    c.what
                );
            }
        }
        Command::Render {
            name,
            scene,
            out,
            width,
            spp,
            breakdown_stride,
            threads,
            frames,
            pareto,
        } => {
            let pipeline = lobefit::pipelines::by_name(&name)
                .ok_or_else(|| Failure::Usage(format!("no pipeline named {name}")))?;

            let animate = match frames {
                None => None,
                Some(n) => Some((
                    n as usize,
                    pipeline.animate.ok_or_else(|| {
                        let some: Vec<&str> = lobefit::pipelines::registry()
                            .iter()
                            .filter(|p| p.animate.is_some())
                            .map(|p| p.name)
                            .collect();
                        Failure::Usage(format!(
                            "render {name} --frames: the pipeline renders no animations ({} do)",
                            some.join(", ")
                        ))
                    })?,
                )),
            };
            let scenes: Vec<&str> = if scene == "all" && animate.is_some() {
                pipeline.animations.to_vec()
            } else if scene == "all" {
                pipeline.scenes.to_vec()
            } else {
                vec![scene.as_str()]
            };
            let study = match pareto {
                None => None,
                Some(w) => {
                    let study = pipeline.pareto.ok_or_else(|| {
                        let with: Vec<&str> = lobefit::pipelines::registry()
                            .iter()
                            .filter(|p| p.pareto.is_some())
                            .map(|p| p.name)
                            .collect();
                        Failure::Usage(format!(
                            "render {name} --pareto: no Pareto study for this pipeline (it has one for {})",
                            with.join(", ")
                        ))
                    })?;
                    for scene in &scenes {
                        (study.takes)(scene).map_err(Failure::Usage)?;
                    }
                    Some((study, w as usize))
                }
            };
            let opts = lobefit::pipelines::RenderOptions {
                width: width as usize,
                spp: spp as usize,
                breakdown_stride: breakdown_stride as usize,
            };
            // Bounded work, and an output directory that takes files, before any of it.
            let samples = u64::from(width) * u64::from(width * 3 / 4) * u64::from(spp);
            if samples > lobefit::pipelines::MAX_SAMPLES {
                return Err(Failure::Usage(format!(
                    "--width {width} --spp {spp}: {samples} Monte Carlo samples per image, more than the {} \
                     a render may take; lower --width or --spp",
                    lobefit::pipelines::MAX_SAMPLES
                )));
            }
            // The work of each scene (read, not built), before any render starts.
            for scene in &scenes {
                if let Some(e) = pipeline.work_error(scene, &opts, animate.map_or(1, |(n, _)| n)) {
                    return Err(Failure::Usage(e));
                }
            }
            let total = pipeline.samples(&opts);
            if total > lobefit::pipelines::MAX_RENDER_SAMPLES {
                return Err(Failure::Usage(format!(
                    "--width {width} --spp {spp} --breakdown-stride {breakdown_stride}: {total} Monte Carlo samples \
                     over the image and the error breakdown of render {name}, more than the {} a render may take \
                     (MAX_RENDER_SAMPLES); lower --width or --spp, or raise --breakdown-stride",
                    lobefit::pipelines::MAX_RENDER_SAMPLES
                )));
            }
            out_dir(&out)?;
            let mut text = String::new();
            for &scene in &scenes {
                let rows = (opts.width * 3 / 4).max(3) as u64;
                let pb = progress(rows * animate.map_or(1, |(n, _)| n as u64), scene);
                let tick = || pb.inc(1);
                let s = pool(threads)?.install(|| match animate {
                    None => (pipeline.render)(scene, &opts, &out, &tick),
                    Some((n, run)) => run(scene, &opts, n, &out, &tick),
                })?;
                pb.finish_and_clear();
                for l in s.lines {
                    let _ = writeln!(text, "{l}");
                }
                for f in s.files {
                    let _ = writeln!(text, "{}", f.display());
                }
                // The one-line summary last: the line a person reads first.
                for l in s.headline {
                    let _ = writeln!(text, "{l}");
                }
            }
            emit(&text)?;
            // The renders' output first: a study takes minutes.
            if let Some((study, w)) = study {
                for scene in scenes {
                    let files = pool(threads)?.install(|| (study.run)(scene, w, &out))?;
                    let list: String = files.iter().map(|f| format!("{}\n", f.display())).collect();
                    emit(&list)?;
                }
            }
        }
        Command::Spheres {
            mesh,
            count,
            method,
            seed,
            samples,
            max_overlap,
            out,
        } => {
            if max_overlap.is_some() && !matches!(method, SphereMethodArg::Optimize) {
                return Err(Failure::Usage("--max-overlap needs --method optimize".into()));
            }
            spheres(&mesh, count as usize, method, seed, samples as usize, max_overlap, &out)?
        }
        Command::FitEnv { map, sgs, out } => fit_env(&map, sgs as usize, &out)?,
        Command::Prefilter {
            map,
            out,
            check,
            texture,
            texture_storage,
        } => {
            let storage = if texture_storage == "f16" {
                Storage::F16
            } else {
                Storage::F32
            };
            prefilter(&map, &out, check as usize, texture.as_deref().map(|t| (t, storage)))?
        }
        Command::Plot { name, out } => {
            let (_, plot) = lobefit::catalog::plots()
                .into_iter()
                .find(|(n, _)| *n == name)
                .ok_or_else(|| Failure::Usage(format!("no figures named {name}")))?;
            out_dir(&out)?;
            let listing: String = plot(&out)?.iter().map(|p| format!("{}\n", p.display())).collect();
            emit(&listing)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Checks an output directory before any work: where it exists it is a directory
/// (through links), else its nearest existing ancestor is one, and a file can be
/// created there (a missing `--out` is made only by a command that succeeds).
fn out_dir(out: &Path) -> Result<(), String> {
    out_dir_of("--out", out, out)
}

/// [`out_dir`] of `dir`, the directory of the `flag`'s value `given` (itself or its
/// parent), errors naming what was given.
fn out_dir_of(flag: &str, given: &Path, out: &Path) -> Result<(), String> {
    if let Ok(m) = std::fs::metadata(out) {
        if !m.is_dir() {
            let what = if m.is_file() {
                "a regular file"
            } else {
                lobefit::tables::table::file_type_name(m.file_type())
            };
            return Err(format!(
                "{flag} {}: {} is {what}, not a directory",
                given.display(),
                if given == out {
                    "it".to_string()
                } else {
                    out.display().to_string()
                }
            ));
        }
    }
    let existing = out.ancestors().find(|a| a.exists()).unwrap_or(Path::new("."));
    let probe = if existing.as_os_str().is_empty() {
        Path::new(".")
    } else {
        existing
    };
    if !probe.is_dir() {
        return Err(format!(
            "{flag} {}: {} is not a directory",
            given.display(),
            probe.display()
        ));
    }
    tempfile::tempfile_in(probe).map_err(|e| format!("{flag} {}: cannot write there: {e}", given.display()))?;
    Ok(())
}

/// Checks an output file before any work: nothing but a regular file is replaced
/// ([`lobefit::io::check_replaceable`]), and its directory takes files ([`out_dir`]).
fn out_file(flag: &str, out: &Path) -> Result<(), String> {
    lobefit::io::check_replaceable(out).map_err(|e| format!("{flag} {}: {e}", out.display()))?;
    let dir = out
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    out_dir(dir).map_err(|e| format!("{flag} {}: {e}", out.display()))
}

/// `lobefit spheres`: fit, measure, write, report.
#[allow(clippy::too_many_arguments)]
fn spheres(
    mesh_path: &Path,
    count: usize,
    method: SphereMethodArg,
    seed: u64,
    samples: usize,
    max_overlap: Option<f64>,
    out: &Path,
) -> Result<(), String> {
    use lobefit::pipelines::spheres::{fit_with, quality, FileSphere, Method, SphereSetFile};
    let method = match method {
        SphereMethodArg::Kmeans => Method::Kmeans,
        SphereMethodArg::Tree => Method::Tree,
        SphereMethodArg::KmeansMoment => Method::KmeansMoment,
        SphereMethodArg::Cover => Method::Cover,
        SphereMethodArg::Optimize => Method::Optimize,
    };
    out_file("--out", out)?;
    let pb = progress(3, "spheres");
    let t0 = Instant::now();
    let mesh = lobefit::pipelines::mesh::Mesh::load(mesh_path)?;
    pb.inc(1);
    let set =
        fit_with(&mesh, count, method, seed, max_overlap).map_err(|e| format!("mesh {}: {e}", mesh_path.display()))?;
    let t_fit = t0.elapsed().as_secs_f64();
    pb.inc(1);
    let q = quality(&mesh, &set, samples, seed);
    pb.finish_and_clear();
    if !q.is_finite() {
        return Err(format!(
            "mesh {}: the fit's measured quality is not finite ({q:?}); nothing written",
            mesh_path.display()
        ));
    }
    let file = SphereSetFile {
        version: 1,
        mesh: mesh_path.display().to_string(),
        method,
        seed,
        spheres: set
            .iter()
            .map(|s| FileSphere {
                centre: s.centre.to_array(),
                radius: s.radius,
            })
            .collect(),
        quality: Some(q),
    };
    let json = serde_json::to_string_pretty(&file).map_err(|e| e.to_string())?;
    lobefit::io::write_atomic(out, json.as_bytes()).map_err(|e| format!("{}: {e}", out.display()))?;
    emit(&format!(
        "{}: {} triangles, volume {:.6e}; {count} spheres ({}, seed {seed}) in {t_fit:.2} s\n\
         volume error {:.4} (excess {:.4}, missed {:.4}) of the mesh's volume; Hausdorff mesh → spheres {:.4e} ({:.4} of the diagonal), spheres → mesh {:.4e} ({:.4}); overlap {:.3}; {samples} samples\n\
         wrote {}\n",
        mesh_path.display(),
        mesh.triangles.len(),
        mesh.volume(),
        method.name(),
        q.volume_error,
        q.excess,
        q.missed,
        q.hausdorff_mesh_to_spheres,
        q.hausdorff_mesh_to_spheres / q.diagonal,
        q.hausdorff_spheres_to_mesh,
        q.hausdorff_spheres_to_mesh / q.diagonal,
        q.overlap,
        out.display()
    ))
}

/// `lobefit prefilter`: read, build, write (the table, and the texture if asked), check,
/// report.
fn prefilter(map_path: &Path, out: &Path, count: usize, texture: Option<(&Path, Storage)>) -> Result<(), String> {
    use lobefit::pipelines::envmap::EnvMap;
    use lobefit::pipelines::prefilter::{build, check, check_nodes, grid, summary, LAMBDA_MAX, LEVELS, PER_OCTAVE};
    out_file("--out", out)?;
    if let Some((t, _)) = texture {
        out_file("--texture", t)?;
        if t == out {
            return Err("--texture and --out name the same file".into());
        }
    }
    let map = EnvMap::load(map_path)?;
    let name = map_path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let t0 = Instant::now();
    let (table, times) = build(&map, &name).map_err(|e| format!("map {}: {e}", map_path.display()))?;
    let t_build = t0.elapsed().as_secs_f64();
    let bytes = lobefit_tables::format::encode(table.meta(), table.values())?;
    lobefit::io::write_atomic(out, &bytes).map_err(|e| format!("{}: {e}", out.display()))?;
    if let Some((path, storage)) = texture {
        let stem = path
            .file_stem()
            .map_or_else(|| "prefiltered".into(), |n| n.to_string_lossy().into_owned());
        let tex = lobefit::pipelines::prefilter::texture(&table, &stem)?;
        let ktx = lobefit::export::formats::encode(&tex, lobefit::export::Format::Ktx2, storage)?;
        lobefit::io::write_atomic(path, &ktx).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let (r, c) = grid(&map);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} × {} texels → {} levels (λ = 1 … {}, {} per doubling) × {} × {} nodes, {:.1} MB, in {t_build:.1} s (per level: {})",
        map_path.display(),
        map.width,
        map.height,
        LEVELS,
        LAMBDA_MAX,
        PER_OCTAVE,
        r + 1,
        c + 1,
        bytes.len() as f64 / 1e6,
        times.iter().map(|t| format!("{t:.2}")).collect::<Vec<_>>().join(" ")
    );
    if count > 0 {
        let t0 = Instant::now();
        let points = check(&map, &table, count, 0x5eed_9f17)?;
        let _ = writeln!(
            s,
            "check: {count} random (direction, λ), half drawn by the map's luminance, against Gauss–Legendre quadrature of every texel ({:.1} s); relative error of the luminance:",
            t0.elapsed().as_secs_f64()
        );
        let mut nodes: Vec<f64> = check_nodes(&map, &table, count, 0x5eed_90de)?
            .into_iter()
            .map(|p| p.1)
            .collect();
        nodes.sort_by(f64::total_cmp);
        let _ = writeln!(
            s,
            "  at {count} random nodes (the build alone): worst channel's relative error median {:.2e}, max {:.2e}",
            nodes[nodes.len() / 2],
            nodes[nodes.len() - 1]
        );
        let _ = writeln!(s, "  between nodes (the lookup):");
        for b in summary(&points) {
            let black = if b.black > 0 {
                format!(" ({} where the map is black, left out)", b.black)
            } else {
                String::new()
            };
            match (b.cubic, b.linear) {
                (Some(c), Some(l)) => writeln!(
                    s,
                    "  {:<14} {:>5} points{black}: cubic in λ: median {:.2e}, max {:.2e} (worst channel {:.2e}); linear in ln λ: median {:.2e}, max {:.2e}",
                    b.band, b.points, c.0, c.1, b.worst_channel, l.0, l.1
                ),
                _ => writeln!(s, "  {:<14} no points{black}", b.band),
            }
            .ok();
        }
    }
    let _ = writeln!(s, "{}", out.display());
    if let Some((t, _)) = texture {
        let _ = writeln!(s, "{}", t.display());
    }
    emit(&s)
}

/// `lobefit fit-env`: read, fit, measure, write, report.
fn fit_env(map_path: &Path, k: usize, out: &Path) -> Result<(), String> {
    use lobefit::pipelines::envmap::{evaluate, fit, EnvMap, GLOSSY};
    out_file("--out", out)?;
    let map = EnvMap::load(map_path)?;
    let t0 = Instant::now();
    let f = fit(&map, k).map_err(|e| format!("map {}: {e}", map_path.display()))?;
    let t_fit = t0.elapsed().as_secs_f64();
    let r = evaluate(&map, &f.sgs);
    let json = serde_json::json!({
        "sgs": f.sgs,
        "source": {
            "map": map_path.display().to_string(),
            "width": map.width,
            "height": map.height,
            "sun": f.sun,
            "iterations": f.iterations,
            "seconds": t_fit,
        },
        "report": r,
    });
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    lobefit::io::write_atomic(out, text.as_bytes()).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} × {} texels{}; {k} SGs{} in {t_fit:.2} s ({} LM iterations)",
        map_path.display(),
        map.width,
        map.height,
        if map.negative > 0.0 {
            format!(
                " (negative texels set to 0: {:.2e} of the absolute energy)",
                map.negative
            )
        } else {
            String::new()
        },
        if f.sun {
            format!(" (the first a sun, sharpness {:.0})", f.sgs[0].sharpness)
        } else {
            String::new()
        },
        f.iterations
    );
    let _ = writeln!(
        s,
        "{:<28} {:>10} {:>10} {:>10}",
        "luminance, relative", "SGs", "SH 3", "SH 5"
    );
    let row = |s: &mut String, what: &str, v: [String; 3]| {
        let _ = writeln!(s, "{what:<28} {:>10} {:>10} {:>10}", v[0], v[1], v[2]);
    };
    row(&mut s, "radiance L2", r.radiance.map(|x| format!("{x:.4}")));
    row(&mut s, "irradiance median", r.irradiance.map(|x| format!("{:.4}", x.0)));
    row(&mut s, "irradiance max", r.irradiance.map(|x| format!("{:.4}", x.1)));
    for (n, g) in GLOSSY.iter().zip(&r.glossy) {
        row(&mut s, &format!("Phong {n} median"), g.map(|x| format!("{:.4}", x.0)));
    }
    let _ = writeln!(s, "wrote {}", out.display());
    emit(&s)
}

/// Writes `text` to stdout and flushes it. A closed pipe or a full disk becomes an
/// error (one line on stderr, exit 1) instead of `println!`'s panic.
fn emit(text: &str) -> Result<(), String> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(|e| format!("cannot write to stdout: {e}"))
}

/// [`note`] of one line.
fn note_line(text: &str) {
    note(&format!("{text}\n"));
}

/// Writes `text` to stderr. Ignores failure: stderr is where failures would be
/// reported, and `eprintln!` would panic instead.
fn note(text: &str) {
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}

/// Parses the command line. Help and version text go through [`emit`] (clap's own
/// printing ignores write errors) unless stdout is a terminal, where clap's styled
/// output is kept; usage errors exit 2 as clap does.
fn parse() -> Result<Cli, ExitCode> {
    use clap::error::ErrorKind;
    use clap::{CommandFactory, FromArgMatches};
    let parsed = Cli::command()
        .mut_subcommand("eval", |c| c.args(eval_flag_args()))
        .try_get_matches()
        .and_then(|m| {
            let mut cli = Cli::from_arg_matches(&m)?;
            if let (Command::Eval { flags, .. }, Some(("eval", em))) = (&mut cli.command, m.subcommand()) {
                *flags = eval_flags_of(em);
            }
            Ok(cli)
        });
    match parsed {
        Ok(cli) => Ok(cli),
        Err(e) if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) => {
            if std::io::stdout().is_terminal() {
                e.exit()
            }
            match emit(&e.render().to_string()) {
                Ok(()) => Err(ExitCode::SUCCESS),
                Err(m) => {
                    note(&format!("error: {m}\n"));
                    Err(ExitCode::from(1))
                }
            }
        }
        Err(e) => e.exit(),
    }
}

/// The largest measured error per filter of one texture, relative to its target.
fn worst_errors(errors: &[lobefit::export::manifest::ErrorEntry]) -> String {
    let mut parts = Vec::new();
    for f in Filter::ALL {
        if let Some(e) = errors
            .iter()
            .filter(|e| e.filter == f)
            .max_by(|a, b| (a.measured / a.target).total_cmp(&(b.measured / b.target)))
        {
            parts.push(format!(
                "{}: {} {} {:.2e} (target {:.1e})",
                f.name(),
                e.output,
                e.metric,
                e.measured,
                e.target
            ));
        }
    }
    parts.join("; ")
}

/// `check --export DIR`.
fn check_export(dir: &Path) -> Result<ExitCode, String> {
    let checks = lobefit::export::run::check_export(dir)?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<24} {:<8} {:<14} {:<18} {:>10} {:>10} {:>10} {:>10}",
        "family", "filter", "output", "metric", "measured", "promise", "target", "floor"
    );
    for c in &checks {
        let _ = writeln!(
            s,
            "{:<24} {:<8} {:<14} {:<18} {:>10.3e} {:>10.3e} {:>10.1e} {:>10.1e} {}",
            c.family,
            c.entry.filter.name(),
            c.entry.output,
            c.entry.metric,
            c.now,
            c.entry.promise,
            c.entry.target,
            c.entry.floor,
            if !c.pass {
                "FAIL"
            } else if c.entry.measured <= c.entry.target {
                "ok"
            } else if c.entry.meets_target() {
                "ok (within the storage's rounding floor)"
            } else {
                "ok (lossy: misses the target)"
            }
        );
    }
    emit(&s)?;
    if checks.iter().any(|c| !c.pass) {
        note("check --export FAILED\n");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

fn main() -> ExitCode {
    let cli = match parse() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    let (e, code) = match run(cli) {
        Ok(code) => return code,
        Err(Failure::Usage(e)) => (e, 2),
        Err(Failure::Run(e)) => (e, 1),
    };
    let _ = std::io::stdout().flush();
    note(&format!("error: {e}\n"));
    ExitCode::from(code)
}
