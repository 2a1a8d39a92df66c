//! Equal-error comparisons of the Monte Carlo references' estimators (plain, scrambled
//! Sobol, scrambled Sobol with a control variate) with each other and with a
//! pipeline's analytic shading: each estimator's error and time per pixel measured at
//! each compared sample count (not extrapolated from one run's variance), the
//! analytic method's on the same pixels against the same reference. A study
//! (`scripts/studies.sh`), not a check: nothing here asserts a time. The bench and its
//! measurements are [`crate::measure`]'s.

use crate::estimate::{Estimate, Sampling};
use std::time::Instant;

use crate::measure::{spp_at, time_at, Bench, Estimator, Point, Timing};
use crate::scene::{Hit, Scene};
use crate::sky::{reference_cv, reference_cv_map, reference_hybrid, reference_map, reference_sampled, Phong, Select};

/// `println!` that ignores a closed stdout: the study's progress lines are for a person
/// watching; the files are its result.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($t)*);
    }};
}

/// An environment scene's estimators.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Plain,
    Qmc,
    /// QMC with the control variate, the SGs picked as the `Select` says (by their
    /// integral, or by their contribution at the point).
    QmcCv(Select),
    /// QMC with the ISG pipeline (default settings) as the control variate.
    HybridIsg,
    /// QMC with the SH-exponentiation pipeline (default settings) as the control
    /// variate.
    HybridSh,
}

/// `kind` at a hit of the environment scene `scene` (its SGs sampled, its light
/// through `shexp::light`: the SGs or its SH, visibility exact).
fn environment(
    scene: &Scene,
    kind: Kind,
) -> Result<impl Fn(&Hit, usize, u64) -> Result<Estimate, String> + Sync + '_, String> {
    let isg = match kind {
        Kind::HybridIsg => Some(crate::isg::shade::Tables::embedded().map_err(|e| e.to_string())?),
        _ => None,
    };
    let sh = match kind {
        Kind::HybridSh => {
            let s = crate::shexp::shade::Settings::default();
            let light = crate::shexp::lighting::light_sh(scene, s.order)?;
            Some((
                crate::shexp::shade::Tables::embedded().map_err(|e| e.to_string())?,
                s,
                light,
            ))
        }
        _ => None,
    };
    Ok(move |hit: &Hit, n: usize, seed: u64| {
        let brdf = Phong::of_any(scene.brdf(hit))?;
        let occluded = |v| scene.occluded(hit, v);
        let light = |v| crate::shexp::lighting::light(scene, v);
        // Under a map the light's strategy is the map's texels, and the control variate
        // the lobes fitted to it (the hybrids keep the lobes as strategies: unbiased
        // for any light).
        let map = scene.environment_map.as_deref();
        Ok(match (kind, map) {
            (Kind::Plain | Kind::Qmc, Some(m)) => {
                let sampling = if kind == Kind::Plain {
                    Sampling::Plain
                } else {
                    Sampling::Qmc
                };
                reference_map(sampling, m, light, &brdf, occluded, hit, n, seed)
            }
            (Kind::QmcCv(_), Some(m)) => {
                reference_cv_map(Sampling::Qmc, &scene.environment, m, &brdf, occluded, hit, n, seed)
            }
            (Kind::Plain, None) => reference_sampled(
                Sampling::Plain,
                &scene.environment,
                light,
                &brdf,
                occluded,
                hit,
                n,
                seed,
            ),
            (Kind::Qmc, None) => {
                reference_sampled(Sampling::Qmc, &scene.environment, light, &brdf, occluded, hit, n, seed)
            }
            (Kind::QmcCv(select), None) => {
                reference_cv(Sampling::Qmc, select, &scene.environment, &brdf, occluded, hit, n, seed)
            }
            (Kind::HybridIsg, _) => {
                let t = isg.as_ref().ok_or("the ISG tables")?;
                let blockers = crate::isg::render::blockers_of(scene, hit);
                let s = crate::isg::shade::Settings::default();
                let a = crate::isg::shade::integrand(t, &s, &scene.environment, &brdf, &blockers, hit)?;
                reference_hybrid(
                    Sampling::Qmc,
                    &scene.environment,
                    light,
                    &brdf,
                    occluded,
                    hit,
                    n,
                    seed,
                    a.value,
                    |w| a.eval(w),
                )
            }
            (Kind::HybridSh, _) => {
                let (t, s, l) = sh.as_ref().ok_or("the SH tables")?;
                let a = crate::shexp::shade::integrand(t, s, l, &brdf, scene, hit)?;
                reference_hybrid(
                    Sampling::Qmc,
                    &scene.environment,
                    light,
                    &brdf,
                    occluded,
                    hit,
                    n,
                    seed,
                    a.value,
                    |w| light(w) * a.eval(w),
                )
            }
        })
    })
}

/// One analytic configuration's measured error and time.
struct Method {
    name: String,
    /// Noise-free, and against the reference as it is (see [`Point`]).
    rel_rmse: f64,
    rel_rmse_raw: f64,
    flip: Option<f64>,
    us: Timing,
}

/// Prints the curves and each estimator's samples and time at the default
/// configuration's error (`methods[0]`) and at a quarter of it, with the factors
/// against plain and against the analytic time; writes
/// `<out>/<tag>-summary.json` and the Pareto chart `<out>/<tag>-pareto.png`.
fn report(
    tag: &str,
    out: &std::path::Path,
    b: &Bench,
    methods: &[Method],
    curves: &[(&str, Vec<Point>)],
) -> Result<Vec<std::path::PathBuf>, String> {
    print_points(tag, b, methods, curves);
    let equal = equal_error(methods, curves);
    let summary = serde_json::json!({
        "scene": tag,
        "pixels": b.pixels(),
        "threads": rayon::current_num_threads(),
        "reference_rel_rmse": b.reference_error(),
        "methods": methods.iter().map(|m| serde_json::json!({
            "name": m.name, "rel_rmse": m.rel_rmse_raw, "rel_rmse_noise_free": m.rel_rmse, "flip": m.flip,
            "us_per_pixel": m.us.median, "us_min": m.us.min, "us_max": m.us.max,
        })).collect::<Vec<_>>(),
        "estimators": curves.iter().map(|(l, c)| serde_json::json!({
            "name": l,
            "curve": c.iter().map(|p| serde_json::json!({
                "spp": p.spp, "rel_rmse": p.rel_rmse_raw, "rel_rmse_noise_free": p.rel_rmse, "flip": p.flip,
                "us_per_pixel": p.us.median, "us_min": p.us.min, "us_max": p.us.max,
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "equal_error": equal,
    });
    std::fs::create_dir_all(out).map_err(|e| e.to_string())?;
    let json = out.join(format!("{tag}-summary.json"));
    lobefit_core::io::write_atomic(
        &json,
        serde_json::to_string_pretty(&summary)
            .map_err(|e| e.to_string())?
            .as_bytes(),
    )
    .map_err(|e| e.to_string())?;
    let mut series: Vec<lobefit_core::plot::Series> = curves
        .iter()
        .map(|(l, c)| lobefit_core::plot::Series {
            name: format!("{l} (4 … {} spp)", c.last().map_or(0, |p| p.spp)),
            points: c.iter().map(|p| (p.us.median, p.rel_rmse)).collect(),
        })
        .collect();
    series.extend(methods.iter().map(|m| lobefit_core::plot::Series {
        name: m.name.clone(),
        points: vec![(m.us.median, m.rel_rmse)],
    }));
    let png = lobefit_core::plot::line_chart(
        &out.join(format!("{tag}-pareto.png")),
        &lobefit_core::plot::LineChart {
            title: format!(
                "{tag}: error vs time per pixel ({} px, {} threads)",
                b.pixels(),
                rayon::current_num_threads()
            ),
            x_label: "µs per pixel (median)".into(),
            y_label: "relative RMSE (reference noise removed)".into(),
            log_x: true,
            log_y: true,
            series,
        },
    )?;
    say!("  wrote {} and {}", json.display(), png.display());
    Ok(vec![json, png])
}

/// The measured points, printed: the analytic configurations', then each estimator's.
fn print_points(tag: &str, b: &Bench, methods: &[Method], curves: &[(&str, Vec<Point>)]) {
    say!(
        "{tag}: {} px shaded, {} threads; reference error {:.1e}",
        b.pixels(),
        rayon::current_num_threads(),
        b.reference_error(),
    );
    let flip = |f: Option<f64>| f.map_or(String::new(), |f| format!(", ꟻLIP {f:.4}"));
    for m in methods {
        say!(
            "  method {:<22} rel RMSE {:.4}{}, {:.2} µs/px [{:.2}–{:.2}]",
            m.name,
            m.rel_rmse,
            flip(m.flip),
            m.us.median,
            m.us.min,
            m.us.max
        );
    }
    for (label, c) in curves {
        let pts: Vec<String> = c
            .iter()
            .map(|p| {
                format!(
                    "{} spp {:.4}{} {:.1} µs [{:.1}–{:.1}]",
                    p.spp,
                    p.rel_rmse,
                    flip(p.flip),
                    p.us.median,
                    p.us.min,
                    p.us.max
                )
            })
            .collect();
        say!("  {label:<7} {}", pts.join("; "));
    }
}

/// Each estimator at the default configuration's error and at a quarter of it
/// (interpolated between measured points only): printed, and the summary's
/// `equal_error` entries.
fn equal_error(methods: &[Method], curves: &[(&str, Vec<Point>)]) -> Vec<serde_json::Value> {
    let (err, ta) = (methods[0].rel_rmse, methods[0].us);
    let mut equal = Vec::new();
    for (what, target) in [("the analytic error", err), ("a quarter of it", err / 4.0)] {
        // Plain at the target, or (beyond its measured range, below its last
        // error) its last point: a lower bound of its samples and time.
        let plain = curves.iter().find(|(l, _)| *l == "plain").and_then(|(_, c)| {
            let last = c.last()?;
            match (spp_at(c, target), time_at(c, target)) {
                (Some(n), Some(t)) => Some((n, t.median, "")),
                _ if target < last.rel_rmse => Some((last.spp as f64, last.us.median, "> ")),
                _ => None,
            }
        });
        for (label, c) in curves {
            match (spp_at(c, target), time_at(c, target)) {
                (Some(n), Some(t)) => {
                    let vs_plain = match plain {
                        Some((pn, pt, bound)) => format!(
                            "{bound}{:.1}× fewer samples, {bound}{:.1}× less time than plain",
                            pn / n,
                            pt / t.median
                        ),
                        None => "plain beyond measured range".into(),
                    };
                    say!(
                        "  at {what} ({target:.4}), {label:<7}: {n:.0} spp, {:.1} µs/px [{:.1}–{:.1}]; {vs_plain}; {:.2}× the analytic time [{:.2}–{:.2}]",
                        t.median,
                        t.min,
                        t.max,
                        t.median / ta.median,
                        t.min / ta.max,
                        t.max / ta.min
                    );
                    equal.push(serde_json::json!({
                        "method": methods[0].name, "target": target, "estimator": label,
                        "spp": n, "us_per_pixel": t.median, "us_min": t.min, "us_max": t.max,
                        "ratio": t.median / ta.median,
                    }));
                }
                _ => say!(
                    "  at {what} ({target:.4}), {label:<7}: beyond measured range (last: {} spp, {:.4})",
                    c.last().map_or(0, |p| p.spp),
                    c.last().map_or(f64::NAN, |p| p.rel_rmse)
                ),
            }
        }
    }
    equal
}

/// `lobefit plot baselines --out DIR`: the study at full size (several minutes on 2
/// cores), as `scripts/studies.sh` runs it: fig12, fig12-diffuse, whale and fig13 at
/// 24 px wide, wrecking at 16, Meunier's blocker-scaling scenes at 24; per scene
/// `<pipeline>-<scene>-summary.json` and `-pareto.png` in DIR (docs/pipelines.md,
/// "Stronger baselines").
pub fn plot(out: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    let mut written = Vec::new();
    for (width, scenes) in [
        (24, "fig12,fig12-diffuse,whale,fig13"),
        (16, "wrecking"),
        (
            24,
            "cluster-1,cluster-16,cluster-256,cluster-1024,torus-1,torus-16,torus-252,torus-1020",
        ),
    ] {
        written.extend(study(&Study {
            width,
            scenes: scenes.into(),
            out: out.to_path_buf(),
            ..Study::default()
        })?);
    }
    Ok(written)
}

/// The ISG pipeline's study ([`crate::ParetoStudy`]): one scene, so not the `sweep`
/// series (which `--scene all` includes).
pub const ISG: crate::ParetoStudy = crate::ParetoStudy {
    takes: |scene| {
        if scene == "sweep" {
            return Err(format!(
                "render isg --scene {scene} --pareto: the sweep is a series of scenes; the study takes one \
                 (fig12, fig12-diffuse or a scene file)"
            ));
        }
        Ok(())
    },
    run: |scene, width, out| study_sky(&one_scene(scene, width, out), scene, true),
};

/// The SH-exponentiation pipeline's study.
pub const SHEXP: crate::ParetoStudy = crate::ParetoStudy {
    takes: |_| Ok(()),
    run: |scene, width, out| study_sky(&one_scene(scene, width, out), scene, false),
};

/// Meunier's study: its scenes, and the blocker-scaling `cluster-N`, `torus-N`.
pub const MEUNIER: crate::ParetoStudy = crate::ParetoStudy {
    takes: |_| Ok(()),
    run: |scene, width, out| study_meunier_named(&one_scene(scene, width, out), scene),
};

/// `lobefit render NAME --scene S --pareto WIDTH`'s knobs: the study of one scene (a
/// built-in scene or a scene file) at `width` pixels, with the full study's reference,
/// sample ranges and timing runs, writing `<pipeline>-<scene>-summary.json` and
/// `-pareto.png` in `out`. Minutes per scene at 24 px (docs/pipelines.md, "Stronger
/// baselines"); the time grows with the pixels.
fn one_scene(scene: &str, width: usize, out: &std::path::Path) -> Study {
    Study {
        width,
        scenes: scene.into(),
        out: out.to_path_buf(),
        ..Study::default()
    }
}

/// A scene's name as part of a file name: a scene file's path keeps its stem.
fn tag(name: &str) -> String {
    let stem = std::path::Path::new(name)
        .file_stem()
        .map_or(name.into(), |s| s.to_string_lossy());
    stem.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect()
}

/// The study's knobs.
struct Study {
    width: usize,
    runs: usize,
    scenes: String,
    ref_spp: usize,
    plain_max: usize,
    qmc_max: usize,
    out: std::path::PathBuf,
}

impl Default for Study {
    /// The full-size study's knobs (the `LF_*` defaults of the ignored test).
    fn default() -> Self {
        Study {
            width: 24,
            runs: 5,
            scenes: "fig12,fig12-diffuse,whale,wrecking,fig13".into(),
            ref_spp: 1 << 17,
            plain_max: 1 << 16,
            qmc_max: 1 << 14,
            out: "target/baselines".into(),
        }
    }
}

/// Each scene of `cfg.scenes` measured (see [`plot`]); the files written.
fn study(cfg: &Study) -> Result<Vec<std::path::PathBuf>, String> {
    let mut written = Vec::new();
    for name in cfg.scenes.split(',') {
        let t0 = Instant::now();
        // Meunier: fig13, or a blocker-scaling scene (`cluster-N`, `torus-N`).
        let meunier = name == "fig13" || name.starts_with("cluster-") || name.starts_with("torus-");
        written.extend(if meunier {
            study_meunier_named(cfg, name)?
        } else {
            study_sky(cfg, name, name.starts_with("fig12"))?
        });
        say!("  ({} px wide, {:.0} s)", cfg.width, t0.elapsed().as_secs_f64());
    }
    Ok(written)
}

/// An estimator's curve at 4, 16, 64, … samples per pixel, until past `target` (from
/// 256 on) or at `max`; `adaptive`: the samples spread by a pilot (`adaptive_image`).
fn curve_until(b: &Bench, target: f64, max: usize, est: Estimator, adaptive: bool) -> Result<Vec<Point>, String> {
    let mut c: Vec<Point> = Vec::new();
    for n in (1..).map(|k| 1usize << (2 * k)).take_while(|&n| n <= max) {
        c.extend(if adaptive {
            b.adaptive_curve(&[n], est)
        } else {
            b.curve(&[n], est)
        }?);
        if n >= 256 && c[c.len() - 1].rel_rmse < target {
            break;
        }
    }
    Ok(c)
}

/// The analytic configurations' points: each shaded by `shade` against the bench's
/// reference.
fn methods<S: Sync>(
    b: &Bench,
    configs: &[(String, S)],
    shade: impl Fn(&S, &Hit) -> Result<f64, String> + Sync,
) -> Result<Vec<Method>, String> {
    configs
        .iter()
        .map(|(label, s)| {
            let ((rel_rmse, rel_rmse_raw), flip, us) = b.analytic(&|h| shade(s, h))?;
            Ok(Method {
                name: label.clone(),
                rel_rmse,
                rel_rmse_raw,
                flip,
                us,
            })
        })
        .collect()
}

/// A Meunier scene by name: a blocker-scaling scene (`cluster-N`, `torus-N`), or one
/// the pipeline's renders take (built-in or a file).
fn study_meunier_named(cfg: &Study, name: &str) -> Result<Vec<std::path::PathBuf>, String> {
    let scaling = |kind: &str| name.strip_prefix(kind).and_then(|n| n.parse::<usize>().ok());
    let scene = match (scaling("cluster-"), scaling("torus-")) {
        (Some(n), _) => crate::meunier::scaling::cluster(n)?,
        (_, Some(n)) => crate::meunier::scaling::torus(n)?,
        _ => crate::meunier::render::scene(name)?,
    };
    study_meunier(cfg, name, scene)
}

/// A Meunier scene (fig13 or a blocker-scaling scene): its mask configurations against
/// plain, QMC and adaptive Monte Carlo of the light.
fn study_meunier(cfg: &Study, name: &str, scene: Scene) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_tables::meunier::{LightModel, MaskSettings};
    let light = scene.lights[0];
    let m = lobefit_tables::Meunier {
        products: lobefit_tables::LobeProduct::embedded().map_err(|e| e.to_string())?,
        caps: lobefit_tables::CapExponent::embedded().map_err(|e| e.to_string())?,
        weights: lobefit_tables::MaskWeights::embedded().map_err(|e| e.to_string())?,
    };
    let est = |s: Sampling| {
        let scene = &scene;
        move |hit: &Hit, n: usize, seed: u64| {
            Ok(crate::meunier::render::reference_sampled(
                s, scene, &light, hit, n, seed, true,
            ))
        }
    };
    // The reference: QMC (no control variate here), two runs.
    let b = Bench::new(&scene, cfg.width, cfg.ref_spp, cfg.runs, &est(Sampling::Qmc))?;
    let d = MaskSettings::default();
    let mut configs = vec![("default (depth 5, cap light)".to_string(), d)];
    for depth in [3, 4] {
        configs.push((format!("depth {depth}"), MaskSettings { depth, ..d }));
    }
    configs.push((
        "lobe light (paper)".into(),
        MaskSettings {
            light: LightModel::Lobe,
            ..d
        },
    ));
    configs.push(("t_i = 1e-3".into(), MaskSettings { threshold: 1e-3, ..d }));
    let methods = methods(&b, &configs, |settings, h| {
        m.radiance(
            h.x,
            h.n,
            h.t,
            h.wo,
            scene.brdf(h),
            &[light],
            // The blockers culled by the light's cone through the BVH: the same image
            // as every sphere, faster.
            &crate::meunier::scaling::culled(&scene, &light, h),
            settings,
        )
        .map_err(|e| e.to_string())
    })?;
    // Curves run past a quarter of the default configuration's error.
    let target = methods[0].rel_rmse / 4.0;
    let curves = [
        (
            "plain",
            curve_until(&b, target, cfg.plain_max, &est(Sampling::Plain), false)?,
        ),
        ("qmc", curve_until(&b, target, cfg.qmc_max, &est(Sampling::Qmc), false)?),
        (
            "adaptive",
            curve_until(&b, target, cfg.qmc_max, &est(Sampling::Qmc), true)?,
        ),
    ];
    report(&format!("meunier-{}", tag(name)), &cfg.out, &b, &methods, &curves)
}

/// An ISG (fig12…) or SH-exponentiation scene under its sky: its analytic
/// configurations against plain, QMC, the control variates, adaptive and the hybrid.
fn study_sky(cfg: &Study, name: &str, isg: bool) -> Result<Vec<std::path::PathBuf>, String> {
    let scene = if isg {
        crate::isg::render::scene(name)?
    } else {
        crate::shexp::render::scene(name)?
    };
    // The reference: QMC with the control variate (an SG light), two runs; under a map
    // or SH, QMC (under a map its texels sampled: the strongest there).
    let map = scene.environment_map.is_some();
    let kind = if scene.sh_environment.is_none() && !map {
        Kind::QmcCv(Select::Contribution)
    } else {
        Kind::Qmc
    };
    let b = Bench::new(&scene, cfg.width, cfg.ref_spp, cfg.runs, &environment(&scene, kind)?)?;
    let methods = if isg {
        isg_methods(&b, &scene)?
    } else {
        shexp_methods(&b, &scene)?
    };
    // Curves run past a quarter of the default configuration's error (the hybrid's
    // and the strongest estimators' regime).
    let target = methods[0].rel_rmse / 4.0;
    let measure =
        |kind: Kind, max: usize, adaptive: bool| curve_until(&b, target, max, &environment(&scene, kind)?, adaptive);
    let mut curves = vec![
        ("plain", measure(Kind::Plain, cfg.plain_max, false)?),
        (
            if map { "qmc-mis-map" } else { "qmc" },
            measure(Kind::Qmc, cfg.qmc_max, false)?,
        ),
    ];
    if map {
        // The lobes fitted to the map as the control variate (`reference_cv_map`).
        curves.push(("qmc-cv", measure(Kind::QmcCv(Select::Integral), cfg.qmc_max, false)?));
    } else if scene.sh_environment.is_none() {
        curves.push(("qmc-cv", measure(Kind::QmcCv(Select::Integral), cfg.qmc_max, false)?));
        curves.push((
            "qmc-cv-mis",
            measure(Kind::QmcCv(Select::Contribution), cfg.qmc_max, false)?,
        ));
    }
    curves.push(("adaptive", measure(kind, cfg.qmc_max, true)?));
    let hybrid = if isg { Kind::HybridIsg } else { Kind::HybridSh };
    curves.push(("hybrid", measure(hybrid, cfg.qmc_max, false)?));
    let pipeline = if isg { "isg" } else { "shexp" };
    report(&format!("{pipeline}-{}", tag(name)), &cfg.out, &b, &methods, &curves)
}

/// The ISG's configurations: the default, and each model with 10×10 and 20×20 patches.
fn isg_methods(b: &Bench, scene: &Scene) -> Result<Vec<Method>, String> {
    use crate::isg::shade::{radiance, Model, Patches, Settings, Tables};
    let t = Tables::embedded()?;
    let mut configs = vec![("default (best, adaptive)".to_string(), Settings::default())];
    for model in Model::ALL {
        for (pl, patches) in [("10×10", Patches::Grid(10)), ("20×20", Patches::Grid(20))] {
            configs.push((
                format!("{} {pl}", model.name()),
                Settings {
                    model,
                    patches,
                    ..Settings::default()
                },
            ));
        }
    }
    methods(b, &configs, |s, h| {
        let brdf = Phong::of_any(scene.brdf(h))?;
        radiance(
            &t,
            s,
            &scene.environment,
            &brdf,
            &crate::isg::render::blockers_of(scene, h),
            h,
        )
    })
}

/// SH exponentiation's configurations: orders 3–6, the BRDF by the exact triple
/// product instead of its log lobe, Ren's blocker log, the exact-caps candidate
/// (docs/shexp-render.md).
fn shexp_methods(b: &Bench, scene: &Scene) -> Result<Vec<Method>, String> {
    use crate::shexp::shade::{radiance, BlockerLog, BrdfMode, ExactCaps, Settings, Tables};
    let t = Tables::embedded()?;
    let d = Settings::default();
    let mut configs: Vec<(String, Settings)> = [4, 3, 5, 6]
        .into_iter()
        .map(|order| {
            let name = if order == 4 {
                "default (order 4)".into()
            } else {
                format!("order {order}")
            };
            (name, Settings { order, ..d })
        })
        .collect();
    for order in [4, 6] {
        configs.push((
            format!("order {order}, triple-product BRDF"),
            Settings {
                order,
                brdf: BrdfMode::Triple,
                ..d
            },
        ));
    }
    configs.push((
        "order 4, Ren's blocker log".into(),
        Settings {
            blocker_log: BlockerLog::Ren,
            ..d
        },
    ));
    configs.push((
        "order 4, cap groups exact".into(),
        Settings {
            exact_caps: ExactCaps::Groups,
            ..d
        },
    ));
    // Each configuration's light projected at its own order.
    let lights = configs
        .iter()
        .map(|(_, s)| crate::shexp::lighting::light_sh(scene, s.order))
        .collect::<Result<Vec<_>, String>>()?;
    let configs: Vec<(String, (Settings, Vec<f64>))> = configs
        .into_iter()
        .zip(lights)
        .map(|((name, s), light)| (name, (s, light)))
        .collect();
    methods(b, &configs, |(s, light), h| {
        radiance(&t, s, light, &Phong::of(scene.brdf(h))?, scene, h)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env_or;
    use crate::estimate::per_pixel;
    use crate::measure::*;

    fn point(spp: usize, rel_rmse: f64, us: f64) -> Point {
        Point {
            spp,
            rel_rmse,
            rel_rmse_raw: rel_rmse,
            flip: None,
            us: Timing {
                median: us,
                min: 0.5 * us,
                max: 2.0 * us,
            },
        }
    }

    /// Adaptive sampling on an image whose noise sits in a few pixels: at the same
    /// mean budget it beats the uniform split (measured against the exact values, not
    /// the estimator's own), spends that budget, and its pixels stay unbiased within
    /// their errors.
    #[test]
    fn adaptive_sampling_spends_the_budget_where_the_noise_is() {
        // Pixel p's estimand is p, its samples uniform about p with standard deviation
        // σ_p = 10 on every 8th pixel and 0.1 elsewhere.
        let scene = crate::isg::PIPELINE.scene("fig12-diffuse").unwrap();
        let (hits, _) = scene.primary_hits(8, 8).unwrap();
        let w = 8;
        let hit_px: Vec<usize> = (0..64).filter(|&p| hits[p].is_some()).collect();
        assert!(hit_px.len() > 16, "{} pixels see geometry", hit_px.len());
        let pixel_of = |hit: &Hit| {
            hits.iter()
                .position(|h| h.as_ref().map(|h| h.x) == Some(hit.x))
                .unwrap()
        };
        let used = std::sync::atomic::AtomicUsize::new(0);
        let est = |hit: &Hit, n: usize, seed: u64| -> Result<Estimate, String> {
            let p = pixel_of(hit);
            let sigma = if p % 8 == 0 { 10.0 } else { 0.1 };
            used.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
            Ok(crate::estimate::estimate(n, seed, |rng| {
                p as f64 + sigma * rng.range(-1.0, 1.0) * 3f64.sqrt()
            }))
        };
        let rmse = |img: &[Estimate]| {
            (hit_px.iter().map(|&p| (img[p].mean - p as f64).powi(2)).sum::<f64>() / hit_px.len() as f64).sqrt()
        };
        let n = 64;
        let (mut uniform, mut adapt) = (0.0, 0.0);
        for rep in 0..8u64 {
            let u = per_pixel(&hits, w, |hit, p| est(hit, n, seed(0x1000 + rep, p)), &|| ()).unwrap();
            uniform += rmse(&u).powi(2);
            used.store(0, std::sync::atomic::Ordering::Relaxed);
            let a = adaptive_image(&hits, w, n, 0x2000 + rep, &est).unwrap();
            let spent = used.load(std::sync::atomic::Ordering::Relaxed) as f64;
            let budget = (n * hit_px.len()) as f64;
            assert!((spent / budget - 1.0).abs() < 0.02, "spent {spent} of {budget}");
            adapt += rmse(&a).powi(2);
            for &p in &hit_px {
                assert!(
                    (a[p].mean - p as f64).abs() < 5.0 * a[p].std_error.max(1e-9),
                    "pixel {p}: {:?}",
                    a[p]
                );
            }
        }
        // Optimal split: RMSE ∝ Σσ_p/N against √(N Σσ_p²)/N uniform, ≈ 2.6× here.
        assert!(adapt < 0.5 * uniform, "adaptive MSE {adapt} against uniform {uniform}");
    }

    /// ꟻLIP is 0 for the reference itself and grows with a darkening of the image
    /// (`--features flip`).
    #[cfg(feature = "flip")]
    #[test]
    fn flip_is_zero_on_the_reference_and_grows_with_the_error() {
        let scene = crate::isg::PIPELINE.scene("fig12-diffuse").unwrap();
        let b = Bench::new(&scene, 16, 16, 1, &environment(&scene, Kind::Plain).unwrap()).unwrap();
        let img = |scale: f64| -> Vec<Estimate> {
            b.refs
                .iter()
                .map(|&r| Estimate {
                    mean: r * scale,
                    std_error: 0.0,
                    samples: 1,
                })
                .collect()
        };
        assert_eq!(b.flip(&img(1.0)), Some(0.0));
        let (a, c) = (b.flip(&img(0.9)).unwrap(), b.flip(&img(0.5)).unwrap());
        assert!(0.0 < a && a < c && c < 1.0, "ꟻLIP {a} at 0.9, {c} at 0.5");
    }

    /// Interpolation recovers n and its time from a 1/√n curve exactly, and refuses to
    /// extrapolate.
    #[test]
    fn spp_at_interpolates_and_never_extrapolates() {
        let c: Vec<Point> = [4, 16, 64]
            .iter()
            .map(|&spp| point(spp, 1.0 / (spp as f64).sqrt(), 0.1 * spp as f64))
            .collect();
        let n = spp_at(&c, 1.0 / 32f64.sqrt()).unwrap();
        assert!((n - 32.0).abs() < 1e-9, "{n}");
        let t = time_at(&c, 1.0 / 32f64.sqrt()).unwrap();
        assert!(
            (t.median - 3.2).abs() < 1e-9 && (t.min - 1.6).abs() < 1e-9 && (t.max - 6.4).abs() < 1e-9,
            "{t:?}"
        );
        assert!(spp_at(&c, 1.0).is_none() && spp_at(&c, 0.01).is_none() && time_at(&c, 0.01).is_none());
    }

    /// On a tiny image: the reference measured against itself (same seeds) has no
    /// error once its own noise is taken out, and a curve has one point per count.
    #[test]
    fn bench_measures_against_its_reference() {
        let scene = crate::isg::PIPELINE.scene("fig12-diffuse").unwrap();
        let est = environment(&scene, Kind::Plain).unwrap();
        let b = Bench::new(&scene, 8, 64, 1, &est).unwrap();
        let same = |hit: &Hit| -> Result<f64, String> {
            let p = b
                .hits()
                .iter()
                .position(|h| h.as_ref().map(|h| h.x) == Some(hit.x))
                .unwrap();
            let [a, b] = REF_SEEDS.map(|s| est(hit, 64, seed(s, p)).unwrap().mean);
            Ok(0.5 * (a + b))
        };
        let (e, _, t) = b.analytic(&same).unwrap();
        assert_eq!(e, (0.0, 0.0), "the reference itself: no error, either way");
        assert!(t.min <= t.median && t.median <= t.max);
        let c = b.curve(&[4, 16], &est).unwrap();
        assert!(
            c.len() == 2 && c.iter().all(|p| p.rel_rmse.is_finite() && p.rel_rmse > 0.0),
            "{c:?}"
        );
    }

    /// The study (run with --ignored; scripts/studies.sh): on each scene of `LF_SCENES`
    /// (default all: fig12, fig12-diffuse, whale, wrecking, fig13; also Meunier's
    /// blocker-scaling scenes `cluster-N`, `torus-N`) at `LF_WIDTH` px
    /// (default 24; × ¾ rows) against a reference of two runs of `LF_REF_SPP` (2¹⁷)
    /// spp each (QMC with the control variate under SGs, QMC on fig13), each
    /// pipeline's configurations (ISG models × patches, SH orders, Meunier depths,
    /// light models and t_i) and the estimators' curves at 4, 16, 64, … spp until past
    /// a quarter of the default configuration's error (plain to `LF_PLAIN_MAX`, 2¹⁶;
    /// the others to `LF_QMC_MAX`, 2¹⁴); each time the median of `LF_RUNS` (5) runs
    /// after a warm-up on rayon's pool; summaries and Pareto charts into `LF_OUT`
    /// (target/baselines).
    #[test]
    #[ignore]
    fn study_baselines() {
        let d = Study::default();
        study(&Study {
            width: env_or("LF_WIDTH", d.width),
            runs: env_or("LF_RUNS", d.runs),
            scenes: env_or("LF_SCENES", d.scenes),
            ref_spp: env_or("LF_REF_SPP", d.ref_spp),
            plain_max: env_or("LF_PLAIN_MAX", d.plain_max),
            qmc_max: env_or("LF_QMC_MAX", d.qmc_max),
            out: std::path::PathBuf::from(env_or("LF_OUT", "target/baselines".to_string())),
        })
        .unwrap();
    }

    /// The study's code at a tiny size (every scene, 8 px wide, a 256-sample
    /// reference, curves to 16 spp): each scene's summary reads back with its
    /// methods, estimators (the hybrid on the environment scenes) and finite errors,
    /// and its chart is a PNG.
    #[test]
    fn study_writes_summaries_and_charts() {
        let dir = tempfile::tempdir().unwrap();
        study(&Study {
            width: 8,
            runs: 1,
            scenes: "fig12,whale,fig13".into(),
            ref_spp: 256,
            plain_max: 16,
            qmc_max: 16,
            out: dir.path().to_path_buf(),
        })
        .unwrap();
        for (tag, estimators) in [("isg-fig12", 6), ("shexp-whale", 6), ("meunier-fig13", 3)] {
            let s: serde_json::Value =
                serde_json::from_slice(&std::fs::read(dir.path().join(format!("{tag}-summary.json"))).unwrap())
                    .unwrap();
            let est = s["estimators"].as_array().unwrap();
            assert_eq!(est.len(), estimators, "{tag}");
            assert!(s["methods"].as_array().unwrap().len() >= 4, "{tag}");
            assert!(
                est.iter()
                    .flat_map(|e| e["curve"].as_array().unwrap())
                    .all(|p| p["rel_rmse_noise_free"].as_f64().unwrap().is_finite()),
                "{tag}"
            );
            let png = std::fs::read(dir.path().join(format!("{tag}-pareto.png"))).unwrap();
            assert!(png.starts_with(b"\x89PNG"), "{tag}");
        }
    }
}
