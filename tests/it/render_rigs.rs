//! `render rigs` end to end on a tiny image: Figure 1's panels, their error maps and
//! float images, the wrap panels, a summary naming every rig; and a bad scene name.

use crate::common;

#[test]
fn tiny_fig1_writes_every_panel() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, err) = common::run_text(
        &[
            "render",
            "rigs",
            "--scene",
            "fig1",
            "--width",
            "16",
            "--out",
            dir.path().to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    for stem in ["rigs-fig1", "rigs-fig1-wrap"] {
        for fig in ["images", "error"] {
            let bytes = std::fs::read(dir.path().join(format!("{stem}-{fig}.png"))).unwrap();
            assert_eq!(&bytes[..4], b"\x89PNG");
        }
        for img in [
            "exact",
            "per-point-sh",
            "constant-1",
            "gradient-4",
            "mixed",
            "lattice-3-2-2-12",
        ] {
            let bytes = std::fs::read(dir.path().join(format!("{stem}-{img}.pfm"))).unwrap();
            assert!(bytes.starts_with(b"Pf\n16 12\n-1.0\n"), "{stem}-{img}");
        }
    }
    let summary = std::fs::read_to_string(dir.path().join("rigs-fig1-summary.txt")).unwrap();
    for what in [
        "per-point SH",
        "constant (1)",
        "gradient (4)",
        "mixed ",
        "lattice 3×2×2 (12)",
        "error-driven split",
        "wrap a = 0.5",
    ] {
        assert!(summary.contains(what), "{what}: {summary}");
    }
    let (code, _, err) = common::run_text(
        &[
            "render",
            "rigs",
            "--scene",
            "nope",
            "--out",
            dir.path().to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("unknown scene nope"), "{err}");
}

/// `render --help` names every pipeline and each of its built-in scenes.
#[test]
fn render_help_lists_every_pipeline_and_scene() {
    let (code, help, _) = common::run_text(&["render", "--help"], "");
    assert_eq!(code, Some(0));
    for p in lobefit::pipelines::registry() {
        assert!(help.contains(p.name), "{}", p.name);
        for s in p.scenes {
            assert!(help.contains(s), "{}: {s}: {help}", p.name);
        }
    }
}
