//! `lobefit render meunier` on a tiny image: the figures and the summary appear, the
//! numbers do not depend on the thread count, the reference states its error.

use crate::common;

fn run(dir: &std::path::Path, threads: &str) -> String {
    let out = dir.to_str().unwrap();
    let (code, stdout, err) = common::run_text(
        &[
            "render",
            "meunier",
            "--scene",
            "all",
            "--width",
            "12",
            "--spp",
            "64",
            "--breakdown-stride",
            "3",
            "--threads",
            threads,
            "--out",
            out,
        ],
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    stdout
}

/// The summary without its timing line and file list (timings are not results).
fn results(stdout: &str) -> Vec<String> {
    stdout
        .lines()
        .filter(|l| !l.contains("µs") && ![".png", ".txt", ".pfm", ".exr"].iter().any(|e| l.ends_with(e)))
        .map(str::to_string)
        .collect()
}

#[test]
fn tiny_render_writes_figures_and_is_thread_independent() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let one = run(a.path(), "1");
    let two = run(b.path(), "2");
    assert_eq!(results(&one), results(&two));
    // One summary line per scene; the output ends with the last scene's.
    assert_eq!(one.lines().filter(|l| l.starts_with("summary: meunier ")).count(), 2);
    common::assert_summary_last(&one, "meunier glossy 12×9");
    for scene in ["fig13", "glossy"] {
        // 2 × 12 px wide, upscaled ×22 (⌈512 / 24⌉), and the 4 px separator.
        common::assert_beauty_png(
            &a.path().join(format!("meunier-{scene}-beauty.png")),
            2 * 12 * 22 + 4,
            9 * 22,
        );
        for fig in ["images", "error", "figure10", "profile"] {
            let p = a.path().join(format!("meunier-{scene}-{fig}.png"));
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert_eq!(&bytes[..4], b"\x89PNG");
        }
        for img in ["lobes", "reference", "error"] {
            let bytes = std::fs::read(a.path().join(format!("meunier-{scene}-{img}.pfm"))).unwrap();
            // 12 × 9 pixels of f32 after the header.
            assert!(bytes.starts_with(b"Pf\n12 9\n-1.0\n") && bytes.len() == 13 + 12 * 9 * 4);
            common::assert_exr(&a.path().join(format!("meunier-{scene}-{img}.exr")));
        }
        let summary = std::fs::read_to_string(a.path().join(format!("meunier-{scene}-summary.txt"))).unwrap();
        assert!(summary.contains("standard error"), "{summary}");
        for set in ["fitted", "paper", "one"] {
            assert!(summary.contains(&format!("weights {set}")), "{summary}");
        }
        // Every reported error is a finite number.
        for l in summary.lines().filter(|l| l.contains("relative RMSE")) {
            let v: f64 = l
                .split("relative RMSE ")
                .nth(1)
                .unwrap()
                .split([',', ' '])
                .next()
                .unwrap()
                .parse()
                .unwrap();
            assert!(v.is_finite() && v >= 0.0, "{l}");
        }
    }
}

#[test]
fn bad_render_arguments_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().to_str().unwrap();
    for args in [
        &["render", "meunier", "--width", "2", "--out", out][..],
        &["render", "meunier", "--spp", "1", "--out", out],
        &["render", "other", "--out", out],
    ] {
        let (code, stdout, _) = common::run_text(args, "");
        assert_eq!(code, Some(2), "{args:?}");
        assert!(stdout.is_empty());
    }
}

/// `--pareto W` after a render: the scene's Pareto chart and its summary, with every
/// mask configuration's point and every estimator's measured curve, and the equal-error
/// rows between them; refused where a pipeline has no study or with `--frames`.
#[test]
fn pareto_writes_the_chart_and_its_summary() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().to_str().unwrap();
    let args = ["render", "meunier", "--scene", "fig13", "--width", "8", "--spp", "16"];
    let (code, stdout, err) = common::run_text(&[&args[..], &["--pareto", "4", "--out", out]].concat(), "");
    assert_eq!(code, Some(0), "{err}");
    let json = d.path().join("meunier-fig13-summary.json");
    let png = d.path().join("meunier-fig13-pareto.png");
    assert!(
        stdout.contains(json.to_str().unwrap()) && stdout.contains(png.to_str().unwrap()),
        "{stdout}"
    );
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let pixels = v["pixels"].as_u64().unwrap();
    assert!(
        (1..=12).contains(&pixels),
        "the 4 x 3 image's pixels that see geometry: {pixels}"
    );
    let methods = v["methods"].as_array().unwrap();
    assert!(methods[0]["name"].as_str().unwrap().starts_with("default"));
    // Against the reference as it is and with its noise removed: the second no larger.
    for m in methods {
        let (raw, free) = (
            m["rel_rmse"].as_f64().unwrap(),
            m["rel_rmse_noise_free"].as_f64().unwrap(),
        );
        assert!(free.is_finite() && free <= raw, "{m}");
    }
    let names: Vec<&str> = v["estimators"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["plain", "qmc", "adaptive"]);
    for e in v["estimators"].as_array().unwrap() {
        let spp: Vec<u64> = e["curve"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["spp"].as_u64().unwrap())
            .collect();
        assert!(spp.len() >= 4 && spp.windows(2).all(|w| w[1] == 4 * w[0]), "{spp:?}");
    }
    for (args, want) in [
        (
            &["render", "rigs", "--scene", "fig1", "--pareto", "8"][..],
            "render rigs --pareto: no Pareto study for this pipeline",
        ),
        (
            &["render", "isg", "--frames", "2", "--pareto", "8"],
            "cannot be used with",
        ),
        (&["render", "isg", "--pareto", "2"], "--pareto"),
        (&["render", "isg", "--pareto", "8"], "the sweep is a series of scenes"),
    ] {
        let (code, stdout, err) = common::run_text(&[args, &["--out", out]].concat(), "");
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(want) && stdout.is_empty(), "{args:?}: {err}");
    }
}

/// A scene file renders like the built-in it copies (same numbers, its own name);
/// a missing or malformed one is a specific error and writes nothing.
#[test]
fn scene_files_render_and_bad_ones_are_specific_errors() {
    let d = tempfile::tempdir().unwrap();
    let file = d.path().join("mine.json");
    std::fs::write(&file, lobefit::pipelines::meunier::PIPELINE.file("fig13").unwrap()).unwrap();
    let args = |scene: &str, out: &std::path::Path| -> Vec<String> {
        [
            "render",
            "meunier",
            "--scene",
            scene,
            "--width",
            "8",
            "--spp",
            "16",
            "--breakdown-stride",
            "4",
            "--out",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([out.to_str().unwrap().to_string()])
        .collect()
    };
    let run = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        common::run_text(&a, "")
    };
    let (code, mine, err) = run(args(file.to_str().unwrap(), &d.path().join("a")));
    assert_eq!(code, Some(0), "{err}");
    let (_, builtin, _) = run(args("fig13", &d.path().join("b")));
    let strip = |s: &str, tag: &str| -> Vec<String> { results(s).iter().map(|l| l.replacen(tag, "", 1)).collect() };
    assert_eq!(strip(&mine, "mine"), strip(&builtin, "fig13"));
    assert!(d.path().join("a/meunier-mine-summary.txt").exists());

    // A camera that sees nothing: an error, not NaN statistics.
    let away = lobefit::pipelines::meunier::PIPELINE
        .file("fig13")
        .unwrap()
        .replace("\"target\": [0.0, 0.0, 0.3]", "\"target\": [0.0, -13.0, 8.7]");
    let blind = d.path().join("blind.json");
    std::fs::write(&blind, away).unwrap();
    let out = d.path().join("blind");
    let (code, stdout, err) = run(args(blind.to_str().unwrap(), &out));
    assert_eq!(code, Some(1), "{err}");
    assert!(
        stdout.is_empty() && err.contains("no pixel of the 8×6 image sees geometry"),
        "{err}"
    );
    assert!(!out.exists());

    std::fs::write(&file, "{\"version\": 7}").unwrap();
    for (scene, want) in [
        (file.to_str().unwrap().to_string(), "version 7".to_string()),
        (
            "cornell".to_string(),
            "not a built-in scene of meunier either: fig13, glossy".to_string(),
        ),
    ] {
        let out = d.path().join("c");
        let (code, stdout, err) = run(args(&scene, &out));
        assert_eq!(code, Some(1), "{scene}: {err}");
        assert!(stdout.is_empty() && err.contains(&want), "{scene}: {err}");
        assert!(!out.exists(), "{scene}: wrote {}", out.display());
    }
}

/// Work and output are checked before the render starts: more samples than a render may
/// take, and an `--out` that cannot take files, are errors at once; the outputs are
/// written atomically (a symlink planted at an output name is replaced, not followed).
#[test]
fn bounds_and_outputs_are_checked_first() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let (code, _, err) = common::run_text(
        &["render", "meunier", "--width", "2048", "--spp", "1000000", "--out", out],
        "",
    );
    assert_eq!(code, Some(2), "a usage error: {err}");
    assert!(err.contains("Monte Carlo samples") && err.contains("--spp"), "{err}");
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let (code, _, err) = common::run_text(
        &[
            "render",
            "meunier",
            "--width",
            "8",
            "--spp",
            "4",
            "--out",
            file.to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("--out"), "{err}");
    // Neither started a render: no output was written.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "only a-file");
    #[cfg(unix)]
    {
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, b"keep").unwrap();
        let target = dir.path().join("meunier-fig13-summary.txt");
        std::os::unix::fs::symlink(&victim, &target).unwrap();
        let (code, _, err) = common::run_text(
            &[
                "render",
                "meunier",
                "--scene",
                "fig13",
                "--width",
                "8",
                "--spp",
                "4",
                "--breakdown-stride",
                "4",
                "--out",
                out,
            ],
            "",
        );
        // A planted link where an output goes is neither followed nor replaced: the
        // write refuses it by name (lobefit replaces only regular files).
        assert_eq!(code, Some(1), "{err}");
        assert!(
            err.contains("meunier-fig13-summary.txt is a symbolic link, not a regular file"),
            "{err}"
        );
        assert_eq!(
            std::fs::read(&victim).unwrap(),
            b"keep",
            "the symlink's target is untouched"
        );
        assert!(std::fs::symlink_metadata(&target).unwrap().file_type().is_symlink());
    }
}

/// The scaling study's scenes: the requested number of spheres, none overlapping (a hit
/// point inside another sphere would be refused), and the BVH-culled blockers give the
/// same lobe image as every sphere (the mask drops what misses the light's cone).
#[test]
fn scaling_scenes_are_valid_and_culling_changes_nothing() {
    use lobefit::pipelines::meunier::scaling::{cluster, torus};
    for s in [
        cluster(1).unwrap(),
        cluster(64).unwrap(),
        torus(1).unwrap(),
        torus(64).unwrap(),
    ] {
        assert!(!s.spheres.is_empty());
        for (i, a) in s.spheres.iter().enumerate() {
            for b in &s.spheres[i + 1..] {
                assert!((a.centre - b.centre).length() > a.radius + b.radius, "{}", s.name);
            }
        }
    }
    assert_eq!(cluster(64).unwrap().spheres.len(), 64);
    let r = lobefit::pipelines::meunier::scaling::measure(&cluster(16).unwrap(), 16, 64).unwrap();
    assert_eq!(r.cull_diff, 0.0);
    assert!(r.rmse.is_finite() && r.rmse > 0.0 && r.samples > 0.0);
}
