//! `lobefit-gpu bench --export DIR --out OUT`: each analytic render kernel (`render
//! isg`, `shexp`, `meunier`, `rigs`) timed on this device per frame (median of the
//! timed frames after a warm-up, with min–max; timestamp queries where the device has
//! them, else wall clock), beside its image's error against the CPU pipeline (the
//! renders' own comparison) and its static SPIR-V counts (`cost::kernel_counts`);
//! writes `OUT/bench.json` and `OUT/bench.md`. On a CPU adapter (lavapipe) the times
//! say how a software rasteriser runs the kernels, nothing about a GPU.

use std::io::Write;
use std::path::{Path, PathBuf};

use std::process::ExitCode;

use serde_json::json;

use crate::cost::{kernel_counts, KernelCounts};
use crate::device::Gpu;
use crate::render::{Bench, VerifiedExport};

/// `lobefit-gpu bench`'s options.
#[derive(clap::Args)]
pub struct Args {
    /// A `lobefit export` directory with the textures of isg (isg-best, sg-fit),
    /// shexp (wedge, shexp) and meunier (lobe-product, cap-exponent, mask-weights).
    #[arg(long, value_name = "DIR")]
    pub export: PathBuf,
    /// A pipeline's scene as PIPELINE=SCENE (isg, shexp or meunier; a built-in scene
    /// or a scene file), repeatable; default: isg=fig12, shexp=whale, meunier=fig13
    /// (rigs: Figure 1's car, fixed).
    #[arg(long, value_name = "PIPELINE=SCENE")]
    pub scene: Vec<String>,
    /// Bench only these pipelines (comma-separated: isg, shexp, meunier, rigs);
    /// default: all four.
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub only: Vec<String>,
    /// Image width (height 3/4 of it).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(4..=2048))]
    pub width: u32,
    /// Timed frames per kernel, after one warm-up frame (the median needs ≥ 10 to
    /// mean much; CI runs 3).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub frames: u32,
    /// Time by the wall clock around submit + poll(wait) even where the adapter has
    /// timestamp queries (a check of the timestamps' scale: the wall clock includes
    /// submission and the wait, so it reads longer).
    #[arg(long)]
    pub wall_clock: bool,
    /// The device's Monte Carlo beside the ISG, SH-exponentiation (with the hybrid,
    /// the kernel as its control variate) and Meunier kernels at 1, 4, 16, …
    /// samples per pixel up to this many (several dispatches a frame past one
    /// dispatch's batch); 0: none (its CPU reference, 16 384 spp a pixel, takes minutes
    /// past a few thousand pixels).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(0..=1 << 20))]
    pub mc_spp_max: u32,
    /// Where the Monte Carlo's reference (16 384 spp a pixel) is computed: `cpu`, or
    /// `device` (the device's strongest estimator at every pixel, checked against the
    /// CPU's on 256 of them: what makes --width 640 and 1920 possible).
    #[arg(long, value_enum, default_value_t = crate::mc::ReferenceOn::Cpu)]
    pub reference: crate::mc::ReferenceOn,
    /// Output directory (created if missing): bench.json, bench.md and each
    /// kernel's image.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// The device renders the bench runs, by their [`Bench::rank`] (the report's order).
fn benched() -> Vec<(&'static str, &'static Bench)> {
    let mut v: Vec<(&'static str, &'static Bench)> = crate::renders::RENDERS
        .iter()
        .filter_map(|r| r.bench.as_ref().map(|b| (r.name, b)))
        .collect();
    v.sort_by_key(|(_, b)| b.rank);
    v
}

/// The bench's entry of pipeline `p`.
fn bench_of(p: &str) -> &'static Bench {
    benched()
        .into_iter()
        .find(|(q, _)| *q == p)
        .expect("a benched pipeline")
        .1
}

/// The benched pipelines' names, for messages.
fn names(f: impl Fn(&Bench) -> bool) -> String {
    benched()
        .into_iter()
        .filter(|(_, b)| f(b))
        .map(|(p, _)| p)
        .collect::<Vec<_>>()
        .join(", ")
}

/// One kernel's row.
struct Row {
    pipeline: &'static str,
    scene: String,
    method: String,
    width: usize,
    height: usize,
    /// Invocations per frame (the pixels that see geometry).
    pixels: usize,
    ms: Vec<f64>,
    rel_rmse: f64,
    counts: KernelCounts,
    /// Its image for the device's Monte Carlo beside it.
    image: Option<crate::render::AnalyticImage>,
}

/// The scene of each pipeline from `--scene` values (PIPELINE=SCENE); an unknown
/// pipeline, a repeated one, rigs, or a value without `=` is an error.
fn scenes(values: &[String]) -> Result<Vec<(&'static str, String)>, String> {
    let mut out: Vec<(&'static str, String)> = benched().iter().map(|(p, b)| (*p, b.scene.to_string())).collect();
    let mut seen = Vec::new();
    for v in values {
        let (p, s) = v
            .split_once('=')
            .filter(|(p, s)| !p.is_empty() && !s.is_empty())
            .ok_or_else(|| format!("--scene {v}: expected PIPELINE=SCENE (e.g. isg=fig12-diffuse)"))?;
        let slot = match out.iter_mut().find(|(q, _)| *q == p) {
            Some((q, s)) if !bench_of(q).any_scene => {
                return Err(format!("--scene {v}: the {q} render has one scene ({s})"))
            }
            Some(slot) => slot,
            None => return Err(format!("--scene {v}: no pipeline {p} ({})", names(|b| b.any_scene))),
        };
        if seen.contains(&p) {
            return Err(format!("--scene {v}: pipeline {p} named twice"));
        }
        seen.push(p);
        slot.1 = s.to_string();
    }
    Ok(out)
}

/// The pipelines `only` names (all when empty) of `scenes`; an unknown name, or a
/// `--scene` value (`values`) for a pipeline left out, is an error.
fn only(
    mut scenes: Vec<(&'static str, String)>,
    values: &[String],
    only: &[String],
) -> Result<Vec<(&'static str, String)>, String> {
    if let Some(p) = only.iter().find(|p| !benched().iter().any(|(q, _)| q == p)) {
        return Err(format!("--only {p}: no such pipeline ({})", names(|_| true)));
    }
    let kept = |p: &str| only.is_empty() || only.iter().any(|q| q == p);
    if let Some(v) = values.iter().find(|v| v.split_once('=').is_some_and(|(p, _)| !kept(p))) {
        return Err(format!("--scene {v}: --only leaves that pipeline out"));
    }
    scenes.retain(|(p, _)| kept(p));
    Ok(scenes)
}

/// Median, min and max of `v` (not empty).
pub(crate) fn spread(v: &[f64]) -> (f64, f64, f64) {
    let t = lobefit::pipelines::measure::Timing::of(v);
    (t.median, t.min, t.max)
}

/// A kernel's frames timed (ms), its pixel count, its RMS against the CPU's image
/// (of the peak) and its static SPIR-V counts.
pub(crate) type Timed = (Vec<f64>, usize, f64, KernelCounts);

/// Runs `render` with `gpu` in bench mode; its timed kernel (exactly one) becomes the
/// row's times and counts.
pub(crate) fn timed(gpu: &Gpu, what: &str, render: impl FnOnce() -> Result<f64, String>) -> Result<Timed, String> {
    gpu.take_dispatches();
    let rel_rmse = render()?;
    let d = gpu.take_dispatches();
    let [k] = d.as_slice() else {
        return Err(format!("bench {what}: {} kernels dispatched, expected one", d.len()));
    };
    Ok((k.ms.clone(), k.count, rel_rmse, kernel_counts(&k.source)?))
}

/// `bench`.
pub fn run(a: Args) -> Result<ExitCode, String> {
    let scenes = only(scenes(&a.scene)?, &a.scene, &a.only)?;
    if std::fs::metadata(&a.out).is_ok_and(|m| !m.is_dir()) {
        return Err(format!("--out {}: is a file; name a directory", a.out.display()));
    }
    // The export first: a missing or wrong one is an error before anything runs.
    let all = |e: String| {
        let families: Vec<&str> = benched().iter().filter_map(|(_, b)| b.families.map(|f| f.1)).collect();
        format!(
            "bench: {e}; bench reads the textures of {} (an export of every family has them: \
             lobefit export --format ktx2 --out DIR)",
            match families.split_last() {
                Some((last, [])) => last.to_string(),
                Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
                None => String::new(),
            }
        )
    };
    let mut exports = Exports::new();
    for (p, b) in benched() {
        if let Some(f) = b.families {
            exports.push((p, VerifiedExport::open(&a.export, f).map_err(all)?));
        }
    }
    std::fs::create_dir_all(&a.out).map_err(|e| format!("--out {}: {e}", a.out.display()))?;
    let mut gpu = Gpu::with_timestamps()?;
    if a.wall_clock {
        gpu.timestamps = false;
    }
    gpu.bench_frames(a.frames as usize);
    let width = a.width as usize;
    let (w, h) = crate::render::image_size(width);
    let mut rows = Vec::new();
    for (pipeline, scene) in &scenes {
        let png = a.out.join(format!("{pipeline}.png"));
        let b = bench_one(&gpu, &exports, pipeline, scene, width, &png)?;
        let (ms, pixels, rel_rmse, counts) = b.timed;
        rows.push(Row {
            pipeline,
            scene: scene.clone(),
            method: b.method,
            width: w,
            height: h,
            pixels,
            ms,
            rel_rmse,
            counts,
            image: b.image,
        });
    }
    let mc = monte_carlo(&gpu, &exports, &rows, width, a.mc_spp_max as usize, a.reference)?;
    let software = gpu.info.device_type == wgpu::DeviceType::Cpu;
    write_reports(&a.out, &gpu, software, a.frames, &rows, &mc)?;
    out!(
        "bench: {} kernels on {} ({}); {}",
        rows.len(),
        gpu.info.name,
        timing(&gpu),
        if software { SOFTWARE } else { "" }
    );
    for r in &rows {
        let (med, lo, hi) = spread(&r.ms);
        out!(
            "  {:<8} {:<8} {:>9.3} ms/frame ({lo:.3}–{hi:.3})  RMS/peak vs CPU {:.2e}  {} instr., {} tex, {} loops",
            r.pipeline,
            r.scene,
            med,
            r.rel_rmse,
            r.counts.instructions,
            r.counts.texture_ops,
            r.counts.loops.len()
        );
    }
    for m in &mc {
        out!("{}", mc_summary(m));
    }
    out!("report: {}", a.out.join("bench.md").display());
    Ok(ExitCode::SUCCESS)
}

/// The exports the benched kernels read, each verified for its families, by pipeline.
type Exports = Vec<(&'static str, VerifiedExport)>;

/// Pipeline `p`'s export, if its kernel reads one.
fn export_of<'a>(ex: &'a Exports, p: &str) -> Option<&'a VerifiedExport> {
    ex.iter().find(|(q, _)| *q == p).map(|(_, e)| e)
}

/// One kernel's bench: its method in words, and its frames timed (ms), pixels, RMS
/// against the CPU's image and static counts (see [`timed`]); its image into `png`.
fn bench_one(
    gpu: &Gpu,
    ex: &Exports,
    pipeline: &str,
    scene: &str,
    width: usize,
    png: &Path,
) -> Result<crate::render::Benched, String> {
    (bench_of(pipeline).kernel)(gpu, export_of(ex, pipeline), scene, width, png)
}

/// How the bench timed, and why so when by wall clock.
fn timing(gpu: &Gpu) -> String {
    let why = if gpu.timestamps {
        ""
    } else if gpu.has_timestamp_queries() {
        " (--wall-clock)"
    } else {
        " (the adapter has no TIMESTAMP_QUERY)"
    };
    format!("{}{why}", gpu.timing_source())
}

/// The note on a CPU adapter's numbers.
const SOFTWARE: &str = "software rasteriser, indicative only";

/// A loop list as text: constant bounds, then how many are data-dependent.
fn loops_text(c: &KernelCounts) -> String {
    let consts: Vec<String> = c
        .loops
        .iter()
        .filter(|b| matches!(b, crate::cost::LoopBound::Constant(_)))
        .map(|b| b.to_string())
        .collect();
    let data = c.loops.len() - consts.len();
    format!(
        "{} (constant bounds: {}; data-dependent: {data})",
        c.loops.len(),
        if consts.is_empty() {
            "none".into()
        } else {
            consts.join(", ")
        }
    )
}

/// Writes `out/bench.json` and `out/bench.md`.
fn write_reports(
    out: &Path,
    gpu: &Gpu,
    software: bool,
    frames: u32,
    rows: &[Row],
    mc: &[crate::mc::McBench],
) -> Result<(), String> {
    let kernels: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let (med, lo, hi) = spread(&r.ms);
            json!({
                "pipeline": r.pipeline,
                "scene": r.scene,
                "method": r.method,
                "width": r.width,
                "height": r.height,
                "pixels": r.pixels,
                "frames": r.ms.len(),
                "ms_per_frame": med,
                "ms_min": lo,
                "ms_max": hi,
                "rel_rmse_vs_cpu": r.rel_rmse,
                "spirv_instructions": r.counts.instructions,
                "texture_ops": r.counts.texture_ops,
                "loops": r.counts.loops.len(),
                "loop_bounds": r.counts.loops.iter().map(|b| match b {
                    crate::cost::LoopBound::Constant(n) => json!(n),
                    crate::cost::LoopBound::DataDependent => json!("data"),
                }).collect::<Vec<_>>(),
            })
        })
        .collect();
    let timing = timing(gpu);
    let doc = json!({
        "adapter": {
            "name": gpu.info.name,
            "driver": format!("{} {}", gpu.info.driver, gpu.info.driver_info),
            "backend": format!("{:?}", gpu.info.backend),
            "device_type": format!("{:?}", gpu.info.device_type),
            "timing_source": timing,
            "note": if software { SOFTWARE } else { "" },
        },
        "frames": frames,
        "rel_rmse_vs_cpu": "RMS of |GPU − CPU| over the pixels that see geometry, relative to the CPU image's peak",
        "kernels": kernels,
        "monte_carlo": mc.iter().map(mc_json).collect::<Vec<_>>(),
        "equal_error": mc.iter().flat_map(|m| m.estimators().into_iter().map(move |e| {
            let (spp, ms) = m.equal_error(e).unzip();
            json!({
                "pipeline": m.pipeline, "scene": m.scene, "method": "device kernel", "estimator": e.name(),
                "mc_spp": spp, "mc_ms_per_frame": ms, "ratio": ms.map(|ms| ms / m.analytic.1),
            })
        })).collect::<Vec<_>>(),
    });
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())? + "\n";
    lobefit::io::write_atomic(&out.join("bench.json"), text.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", out.join("bench.json").display()))?;
    let mut md = format!(
        "# lobefit-gpu bench\n\nAdapter: {} ({:?}, {:?}, driver {} {}){}\n\nTiming: {timing}; median of {frames} \
         frames after one warm-up frame, min–max beside it.\nError: RMS |GPU − CPU pipeline| over the pixels that \
         see geometry / the CPU image's peak.\nStatic counts: the kernel's SPIR-V (naga, compacted); a function's \
         loops and texture instructions count once however often it is called.\n\n\
         | pipeline | scene | method | size | pixels | ms/frame | min–max | RMS/peak vs CPU | SPIR-V instr. | \
         texture ops | loops |\n|---|---|---|---|---:|---:|---|---:|---:|---:|---|\n",
        gpu.info.name,
        gpu.info.backend,
        gpu.info.device_type,
        gpu.info.driver,
        gpu.info.driver_info,
        if software {
            format!(" — **{SOFTWARE}**")
        } else {
            String::new()
        }
    );
    for r in rows {
        let (med, lo, hi) = spread(&r.ms);
        md += &format!(
            "| {} | {} | {} | {}×{} | {} | {med:.3} | {lo:.3}–{hi:.3} | {:.2e} | {} | {} | {} |\n",
            r.pipeline,
            r.scene,
            r.method,
            r.width,
            r.height,
            r.pixels,
            r.rel_rmse,
            r.counts.instructions,
            r.counts.texture_ops,
            loops_text(&r.counts)
        );
    }
    for m in mc {
        md += &mc_markdown(m);
    }
    lobefit::io::write_atomic(&out.join("bench.md"), md.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", out.join("bench.md").display()))
}

/// The device's Monte Carlo beside each benched kernel that gives its image (in
/// [`Row::image`], from its timed frames): every estimator at
/// `mc::bench_spp(max_spp)` against the CPU reference; where the kernel gives its
/// integrands, also the hybrid, its control variate those integrands (its time per
/// frame the kernel's plus its own dispatches: a lower bound where the integrands come
/// from the CPU).
fn monte_carlo(
    gpu: &Gpu,
    ex: &Exports,
    rows: &[Row],
    width: usize,
    max_spp: usize,
    on: crate::mc::ReferenceOn,
) -> Result<Vec<crate::mc::McBench>, String> {
    let mut benches = Vec::new();
    if max_spp == 0 {
        return Ok(benches);
    }
    for row in rows {
        let (Some(img), Some(export)) = (&row.image, export_of(ex, row.pipeline)) else {
            continue;
        };
        gpu.take_dispatches();
        let sc = &img.scene;
        // The hybrid's control variate: the kernel's integrands, as its render gives
        // them (from the device, or from the CPU pipeline where the kernel writes none).
        let integrands = |hits: &[&lobefit::pipelines::scene::Hit]| {
            let v = (img.integrands.expect("checked"))(gpu, export, sc, hits);
            gpu.take_dispatches();
            v
        };
        let analytic = crate::mc::Analytic {
            pipeline: row.pipeline,
            values: &img.values,
            ms: spread(&row.ms).0,
            integrands: img.integrands.is_some().then_some(&integrands as crate::mc::Integrands),
        };
        benches.push(crate::mc::bench(gpu, sc, width, analytic, max_spp, on)?);
    }
    Ok(benches)
}

/// The Monte Carlo section of bench.json.
fn mc_json(m: &crate::mc::McBench) -> serde_json::Value {
    json!({
        "pipeline": m.pipeline,
        "scene": m.scene,
        "pixels": m.pixels,
        "reference": {"estimator": format!("{} {}", if m.reference_check.is_some() { "device" } else { "CPU" },
                                           m.reference.0.name()),
                      "spp": m.reference.1, "mean_rel_se": m.reference.2, "check": m.reference_check},
        "error": "relative RMSE against the reference, its noise removed",
        "analytic": {"method": "device kernel", "rel_rmse": m.analytic.0, "ms_per_frame": m.analytic.1},
        "rows": m.rows.iter().map(|r| {
            let (med, lo, hi) = spread(&r.ms);
            json!({"estimator": r.estimator.name(), "spp": r.spp, "ms_per_frame": med, "ms_min": lo,
                   "ms_max": hi, "rel_rmse": r.rel_rmse})
        }).collect::<Vec<_>>(),
    })
}

/// The Monte Carlo section of bench.md.
fn mc_markdown(m: &crate::mc::McBench) -> String {
    let mut md = format!(
        "\n## {} against Monte Carlo on this device ({}, {} pixels)\n\nError: relative RMSE against the {} \
         {} estimator at {} spp (mean relative standard error {:.1e}), its noise removed{}. \
         The {} kernel: {:.4} at {:.3} ms/frame.\n\n| estimator | spp | ms/frame | min–max | rel. RMSE |\n\
         |---|---:|---:|---|---:|\n",
        m.pipeline,
        m.scene,
        m.pixels,
        if m.reference_check.is_some() {
            "device's"
        } else {
            "CPU's"
        },
        m.reference.0.name(),
        m.reference.1,
        m.reference.2,
        m.reference_check.as_ref().map_or(String::new(), |c| format!(" ({c})")),
        m.pipeline,
        m.analytic.0,
        m.analytic.1
    );
    for r in &m.rows {
        let (med, lo, hi) = spread(&r.ms);
        md += &format!(
            "| {} | {} | {med:.3} | {lo:.3}–{hi:.3} | {:.4} |\n",
            r.estimator.name(),
            r.spp,
            r.rel_rmse
        );
    }
    md += &format!(
        "\n| estimator | spp at the {0} kernel's error | ms/frame there | × the {0} kernel's time |\n|---|---:|---:|---:|\n",
        m.pipeline
    );
    for e in m.estimators() {
        md += &match m.equal_error(e) {
            Some((spp, ms)) => format!("| {} | {spp:.0} | {ms:.3} | {:.2} |\n", e.name(), ms / m.analytic.1),
            None if m.unresolved() => format!(
                "| {} | not read: the kernel's error is below the reference's resolution | | |\n",
                e.name()
            ),
            None => format!("| {} | beyond the measured range | | |\n", e.name()),
        };
    }
    md
}

/// One line: where each estimator reaches the analytic kernel's error.
fn mc_summary(m: &crate::mc::McBench) -> String {
    let parts: Vec<String> = m
        .estimators()
        .into_iter()
        .map(|e| match m.equal_error(e) {
            Some((spp, ms)) => format!(
                "{} {spp:.0} spp, {ms:.3} ms/frame ({:.2}× the kernel's time)",
                e.name(),
                ms / m.analytic.1
            ),
            None if m.unresolved() => format!(
                "{} not read: the kernel's error is below the reference's resolution",
                e.name()
            ),
            None => format!("{} beyond {} spp", e.name(), m.rows.last().map_or(0, |r| r.spp)),
        })
        .collect();
    format!(
        "  Monte Carlo at the {} kernel's error ({:.4} against a {}-spp {} reference): {}",
        m.pipeline,
        m.analytic.0,
        m.reference.1,
        if m.reference_check.is_some() { "device" } else { "CPU" },
        parts.join("; ")
    ) + &m
        .reference_check
        .as_ref()
        .map_or(String::new(), |c| format!("\n  reference: {c}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--scene` values: defaults, an override, and each bad form with its error.
    #[test]
    fn scene_arguments() {
        let d = scenes(&[]).unwrap();
        assert_eq!(d[0], ("isg", "fig12".to_string()));
        let s = scenes(&["shexp=wrecking".into()]).unwrap();
        assert_eq!(s[1], ("shexp", "wrecking".to_string()));
        for (v, want) in [
            (vec!["whale"], "PIPELINE=SCENE"),
            (vec!["isg="], "PIPELINE=SCENE"),
            (vec!["nope=x"], "no pipeline nope"),
            (vec!["rigs=x"], "one scene"),
            (vec!["isg=fig12", "isg=fig12"], "named twice"),
        ] {
            let v: Vec<String> = v.into_iter().map(String::from).collect();
            let e = scenes(&v).unwrap_err();
            assert!(e.contains(want), "{v:?}: {e}");
        }
    }

    /// `--only`: a subset in the pipelines' order; an unknown name, and a `--scene`
    /// for a pipeline left out, are errors naming it.
    #[test]
    fn only_arguments() {
        let v = |x: &[&str]| x.iter().map(|s| s.to_string()).collect::<Vec<String>>();
        let s = only(scenes(&[]).unwrap(), &[], &v(&["rigs", "isg"])).unwrap();
        assert_eq!(s.iter().map(|(p, _)| *p).collect::<Vec<_>>(), ["isg", "rigs"]);
        assert_eq!(only(scenes(&[]).unwrap(), &[], &[]).unwrap().len(), 4);
        let e = only(scenes(&[]).unwrap(), &[], &v(&["isg", "nope"])).unwrap_err();
        assert!(e.contains("--only nope"), "{e}");
        let sc = v(&["shexp=wrecking"]);
        let e = only(scenes(&sc).unwrap(), &sc, &v(&["isg"])).unwrap_err();
        assert!(e.contains("shexp=wrecking") && e.contains("leaves"), "{e}");
        let s = only(scenes(&sc).unwrap(), &sc, &v(&["shexp"])).unwrap();
        assert_eq!(s, [("shexp", "wrecking".to_string())]);
    }

    #[test]
    fn spread_is_median_min_max() {
        assert_eq!(spread(&[3.0, 1.0, 2.0]), (2.0, 1.0, 3.0));
        assert_eq!(spread(&[4.0, 1.0, 2.0, 3.0]), (2.5, 1.0, 4.0));
    }
}
