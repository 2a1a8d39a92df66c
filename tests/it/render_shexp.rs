//! The SH-exponentiation pipeline end to end: `render shexp` on a tiny image (figures,
//! summary, thread independence), `eval shexp-shade` against its own `--exact` Monte
//! Carlo reference, and specific errors for bad scenes and flags.

use crate::common;

fn render(dir: &std::path::Path, threads: &str) -> String {
    let (code, stdout, err) = common::run_text(
        &[
            "render",
            "shexp",
            "--scene",
            "whale",
            "--width",
            "16",
            "--spp",
            "16",
            "--breakdown-stride",
            "4",
            "--threads",
            threads,
            "--out",
            dir.to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    stdout
}

#[test]
fn tiny_render_writes_figures_and_is_thread_independent() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let keep = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| !l.contains("µs") && !l.starts_with('/'))
            .map(str::to_string)
            .collect()
    };
    let one = render(a.path(), "1");
    assert_eq!(keep(&one), keep(&render(b.path(), "2")));
    common::assert_summary_last(&one, "shexp whale 16×12");
    for fig in ["images", "error"] {
        let bytes = std::fs::read(a.path().join(format!("shexp-whale-{fig}.png"))).unwrap();
        assert_eq!(&bytes[..4], b"\x89PNG");
    }
    common::assert_beauty_png(&a.path().join("shexp-whale-beauty.png"), 2 * 16 * 16 + 4, 12 * 16);
    for img in ["shexp", "reference", "error", "sh-ideal"] {
        let bytes = std::fs::read(a.path().join(format!("shexp-whale-{img}.pfm"))).unwrap();
        assert!(bytes.starts_with(b"Pf\n16 12\n-1.0\n") && bytes.len() == 14 + 16 * 12 * 4);
        common::assert_exr(&a.path().join(format!("shexp-whale-{img}.exr")));
    }
    let summary = std::fs::read_to_string(a.path().join("shexp-whale-summary.txt")).unwrap();
    for what in [
        "SH-ideal",
        "8 wedges",
        "exact horizon",
        "Ren's blocker log",
        "exact exp*",
        "BRDF triple product",
        "error breakdown",
        "the band limit",
        "ratio reference/pipeline",
    ] {
        assert!(summary.contains(what), "{what}: {summary}");
    }
    // The medians over the unoccluded radiance: all pixels and the shadowed ones,
    // each pipeline and SH-ideal figure a finite number in [0, 10]; the defaults' line
    // (no variant's label before it) and the candidates'.
    let medians: Vec<&str> = summary
        .lines()
        .filter(|l| l.contains("over each pixel's unoccluded radiance"))
        .collect();
    assert!(
        medians
            .iter()
            .any(|l| l.split(": ").nth(1).is_some_and(|x| x.starts_with("the median"))),
        "no defaults' median line: {summary}"
    );
    for label in ["lone caps exact: ", "cap groups exact: "] {
        assert!(
            medians.iter().any(|l| l.contains(label)),
            "no {label}median line: {summary}"
        );
    }
    for line in medians {
        check_medians(line);
    }
}

/// A median line's four figures: finite, in [0, 10].
fn check_medians(line: &str) {
    for part in ["all (", "shadowed ("] {
        let at = line.find(part).unwrap_or_else(|| panic!("{part}: {line}"));
        for what in ["pipeline ", "SH-ideal "] {
            let v: f64 = line[at..]
                .split(what)
                .nth(1)
                .unwrap()
                .split(',')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            assert!((0.0..=10.0).contains(&v), "{part}{what}{v}: {line}");
        }
    }
}

/// `render shexp --frames 2` on the built-in animation (the whale swimming over its
/// terrain): both frames' PNGs, the animated PNG (an acTL chunk of 2 frames), a CSV
/// row per frame with finite errors and times (no temporal error on frame 0), and the
/// summary line last; the sphere whale has moved between the frames, so the
/// pipeline's frame-to-frame change is not zero.
#[test]
fn animation_renders_the_swimming_whale() {
    let d = tempfile::tempdir().unwrap();
    let (code, stdout, err) = common::run_text(
        &[
            "render",
            "shexp",
            "--scene",
            "swim",
            "--frames",
            "2",
            "--width",
            "12",
            "--spp",
            "16",
            "--out",
            d.path().to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    common::assert_summary_last(&stdout, "shexp swim");
    for k in 0..2 {
        let png = std::fs::read(d.path().join(format!("shexp-swim-frame-{k:03}.png"))).unwrap();
        assert_eq!(&png[..4], b"\x89PNG");
    }
    let apng = std::fs::read(d.path().join("shexp-swim-animation.png")).unwrap();
    let at = apng.windows(4).position(|w| w == b"acTL").expect("an acTL chunk");
    assert_eq!(apng[at + 4..at + 8], 2u32.to_be_bytes());
    let (csv, rows) = crate::common::frames_csv(&d.path().join("shexp-swim-frames.csv"));
    assert_eq!(rows.len(), 2, "{csv}");
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r[4].is_nan(), k == 0, "{csv}");
        assert!(r
            .iter()
            .enumerate()
            .all(|(i, x)| x.is_finite() || (k == 0 && (i == 4 || i == 5))));
    }
    assert!(rows[1][4] > 0.0, "a temporal error on frame 1: {csv}");
}

/// The whale scene with a small terrain (33², for debug speed) and `edit` applied.
fn scene_file(dir: &std::path::Path, edit: impl Fn(&mut serde_json::Value)) -> String {
    let text = lobefit::pipelines::shexp::PIPELINE.file("whale").unwrap();
    let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
    v["heightfield"]["size"] = 33.into();
    edit(&mut v);
    let p = dir.join("scene.json");
    std::fs::write(&p, v.to_string()).unwrap();
    p.to_str().unwrap().to_string()
}

/// Points on the terrain under and away from the whale: the pipeline within 20 % of
/// the Monte Carlo reference (exact visibility, standard error ≤ 1e-3 of the estimate;
/// independent code but for the light and BRDF definitions). The pipeline's own error
/// with the band limit is several per cent on average and up to tens of per cent at
/// single points (docs/shexp-render.md): measured here −11.0 %, −0.0 %, −14.3 % on this
/// coarse 33² terrain. A bound that catches a broken pipeline, not a promise.
#[test]
fn eval_shexp_shade_against_its_exact_reference() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(dir.path(), |_| {});
    let hf = lobefit::pipelines::scene::load(&scene).unwrap().heightfield.unwrap().0;
    let mut rows = String::from("px,py,pz,nx,ny,nz,vx,vy,vz\n");
    for (x, y) in [(-0.5, 0.1), (1.2, -0.4), (-2.5, 2.0)] {
        let (z, n) = (hf.height(x, y).unwrap(), hf.normal(x, y).unwrap());
        rows += &format!("{x},{y},{z},{},{},{},0,-0.6,0.8\n", n.x, n.y, n.z);
    }
    let col = common::last_column;
    let (c1, fast, e1) = common::run_text(&["eval", "shexp-shade", "--scene", &scene], &rows);
    let (c2, exact, e2) = common::run_text(&["eval", "shexp-shade", "--scene", &scene, "--exact"], &rows);
    assert_eq!((c1, c2), (Some(0), Some(0)), "{e1}{e2}");
    for (p, r) in col(&fast).into_iter().zip(col(&exact)) {
        assert!((p / r - 1.0).abs() < 0.20, "pipeline {p} vs reference {r}");
    }
}

/// Bad scenes name the key; bad flags and rows are specific errors.
#[test]
fn bad_scenes_flags_and_rows_are_specific_errors() {
    let dir = tempfile::tempdir().unwrap();
    let row = "px,py,pz,nx,ny,nz,vx,vy,vz\n0,0,3,0,0,1,0,0,1\n";
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(Edit, &str)> = vec![
        (Box::new(|v| v["heightfield"]["size"] = 1.into()), "heightfield"),
        (
            Box::new(|v| v["heightfield"]["heights"] = serde_json::json!([0.0, 1.0])),
            "exactly one of heights and procedural",
        ),
        (
            Box::new(|v| {
                v["heightfield"]["procedural"] = serde_json::Value::Null;
                v["heightfield"]["heights"] = serde_json::json!([0.0, 1.0, 2.0]);
            }),
            "heightfield",
        ),
        (
            Box::new(|v| v["heightfield"]["procedural"]["amplitude"] = (-1.0).into()),
            "amplitude",
        ),
        (Box::new(|v| v["heightfield"]["colour"] = 1.into()), "colour"),
        (
            Box::new(|v| v["sh_environment"] = serde_json::json!({"order": 2, "coefficients": [1.0, 0.0, 0.0, 0.0]})),
            "environment and sh_environment",
        ),
        (
            Box::new(|v| {
                v.as_object_mut().unwrap().remove("environment");
                v["sh_environment"] = serde_json::json!({"order": 2, "coefficients": [1.0, 0.0]});
            }),
            "sh_environment.coefficients has 2 values, order 2 needs 4",
        ),
        (
            Box::new(|v| {
                v.as_object_mut().unwrap().remove("environment");
                v["sh_environment"] = serde_json::json!({"order": 9, "coefficients": []});
            }),
            "sh_environment.order 9",
        ),
        (
            Box::new(|v| v["spheres"][3]["radius"] = (-0.2).into()),
            "spheres[3].radius",
        ),
    ];
    for (edit, want) in cases {
        let scene = scene_file(dir.path(), edit);
        let (code, _, err) = common::run_text(&["eval", "shexp-shade", "--scene", &scene], row);
        assert_eq!(code, Some(1), "{want}");
        assert!(err.contains(want), "{want}: {err}");
    }
    let scene = scene_file(dir.path(), |_| {});
    for (args, rows, want) in [
        (vec!["eval", "shexp-shade"], row, "needs --scene"),
        (
            vec!["eval", "shexp-shade", "--scene", &scene, "--order", "2"],
            row,
            "--order",
        ),
        (
            vec!["eval", "shexp-shade", "--scene", &scene, "--patches", "3"],
            row,
            "no --patches",
        ),
        (
            vec!["eval", "shexp-shade", "--scene", &scene],
            "px,py,pz,nx,ny,nz,vx,vy,vz\n0,0,3,0,0,2,0,0,1\n",
            "|n|",
        ),
        (
            vec!["eval", "shexp-shade", "--scene", &scene],
            "px,py,pz,nx,ny,nz,vx,vy,vz\nNaN,0,3,0,0,1,0,0,1\n",
            "px",
        ),
        (
            // Inside the whale's first sphere.
            vec!["eval", "shexp-shade", "--scene", &scene],
            "px,py,pz,nx,ny,nz,vx,vy,vz\n-1.8,0,3.1,0,0,1,0,0,1\n",
            "sphere 0",
        ),
    ] {
        let (code, _, err) = common::run_text(&args, rows);
        // Flags the family refuses are usage errors (exit 2); rows are not.
        let usage = ["needs --scene", "--order", "no --patches"].contains(&want);
        assert_eq!(code, Some(if usage { 2 } else { 1 }), "{want}");
        assert!(err.contains(want), "{want}: {err}");
    }
    // The ISG pipeline refuses a height field by name.
    let (code, _, err) = common::run_text(&["eval", "isg-shade", "--scene", &scene], row);
    assert_eq!(code, Some(2), "a usage error");
    assert!(err.contains("height field"), "{err}");
}

/// Issue 37 (item 4): a point under the terrain is refused naming the row and the
/// height field (it was shaded: 0.771 against a reference of 0.0257), while a point on
/// the surface is shaded; an order-8 `sh_environment` truncated to the pipeline's order
/// 4 is warned about on stderr, naming both orders.
#[test]
fn points_below_the_terrain_are_refused_and_sh_truncation_is_warned() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(dir.path(), |_| {});
    let hf = lobefit::pipelines::scene::load(&scene).unwrap().heightfield.unwrap().0;
    let (x, y) = (0.5, 0.5);
    let z = hf.height(x, y).unwrap();
    let below = format!(
        "px,py,pz,nx,ny,nz,vx,vy,vz\n{x},{y},{z},0,0,1,0,0,1\n{x},{y},{},0,0,1,0,0,1\n",
        z - 0.5
    );
    for exact in [false, true] {
        let mut args = vec!["eval", "shexp-shade", "--scene", &scene];
        if exact {
            args.push("--exact");
        }
        let (code, _, err) = common::run_text(&args, &below);
        assert_eq!(code, Some(1), "{err}");
        assert!(
            err.contains("line 3") && err.contains("below the height field"),
            "{err}"
        );
    }
    let on = format!("px,py,pz,nx,ny,nz,vx,vy,vz\n{x},{y},{z},0,0,1,0,0,1\n");
    let (code, _, err) = common::run_text(&["eval", "shexp-shade", "--scene", &scene], &on);
    assert_eq!(code, Some(0), "{err}");

    let sh = |order: usize| {
        scene_file(dir.path(), move |v| {
            v.as_object_mut().unwrap().remove("environment");
            let mut c = vec![0.0; order * order];
            c[0] = 1.0;
            v["sh_environment"] = serde_json::json!({"order": order, "coefficients": c});
        })
    };
    let row = format!("px,py,pz,nx,ny,nz,vx,vy,vz\n{x},{y},{},0,0,1,0,0,1\n", z + 0.01);
    let (code, _, err) = common::run_text(&["eval", "shexp-shade", "--scene", &sh(8)], &row);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("sh_environment of order 8 truncated to the pipeline's order 4"),
        "{err}"
    );
    let (code, _, err) = common::run_text(&["eval", "shexp-shade", "--scene", &sh(8), "--order", "8"], &row);
    assert_eq!(code, Some(0), "{err}");
    assert!(!err.contains("truncated"), "{err}");
}

/// Issue 37: sphere lights and planes, which the pipeline cannot shade, are refused
/// by `eval shexp-shade` as by `render shexp` (one rule, the pipeline's entry).
#[test]
fn eval_refuses_what_render_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(dir.path(), |v| {
        v["lights"] = serde_json::json!([{"sphere": {"centre": [0, 0, 6], "radius": 0.5, "radiance": 3}}]);
    });
    let row = "px,py,pz,nx,ny,nz,vx,vy,vz\n0,0,3,0,0,1,0,0,1\n";
    let (code, _, err) = common::run_text(&["eval", "shexp-shade", "--scene", &scene], row);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("the SH-exponentiation pipeline cannot shade sphere lights"),
        "{err}"
    );
}
