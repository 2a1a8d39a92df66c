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
        .filter(|l| !l.contains("shading time") && !l.ends_with(".png") && !l.ends_with(".txt"))
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
    for scene in ["fig13", "glossy"] {
        for fig in ["images", "error", "figure10", "profile"] {
            let p = a.path().join(format!("meunier-{scene}-{fig}.png"));
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert_eq!(&bytes[..4], b"\x89PNG");
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
                .split(',')
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
        &["render", "meunier", "--scene", "cornell", "--out", out],
        &["render", "meunier", "--spp", "1", "--out", out],
        &["render", "other", "--out", out],
    ] {
        let (code, stdout, _) = common::run_text(args, "");
        assert_eq!(code, Some(2), "{args:?}");
        assert!(stdout.is_empty());
    }
}
