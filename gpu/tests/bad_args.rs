//! `lobefit-gpu render meunier` refuses bad settings with a specific error before it
//! needs a device or an export: exit 2, one `error:` line naming the setting.

use std::process::{Command, Stdio};

fn run(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lobefit-gpu"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("spawn lobefit-gpu");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// A name that is no render (no pipeline of the registry, not `library`) is refused
/// with exit 2, naming the renders there are.
#[test]
fn render_refuses_a_name_not_in_the_list() {
    let (code, err) = run(&["render", "nope", "--out", "/tmp/unused.png"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("nope") && err.contains("isg") && err.contains("library"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn render_meunier_bad_settings_are_specific_errors() {
    let base = [
        "render",
        "meunier",
        "--export",
        "/nonexistent-lobefit-export",
        "--out",
        "/tmp/unused.png",
    ];
    for (extra, what) in [
        (&["--threshold", "nan"][..], "--threshold NaN"),
        (&["--threshold", "inf"][..], "--threshold inf"),
        (&["--threshold=-1"][..], "--threshold -1"),
        (&["--depth", "0"][..], "--depth"),
        (&["--depth", "6"][..], "--depth"),
        (&["--light", "disk"][..], "--light"),
        (&["--weights", "two"][..], "--weights"),
        (&["--mask", "partial"][..], "--mask"),
        (&["--width", "2"][..], "--width"),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra.iter().copied()).collect();
        let (code, err) = run(&args);
        assert_eq!(code, Some(2), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{extra:?}: {err}");
        assert!(err.contains(what), "{extra:?} should name {what}: {err}");
    }
    // Good settings get as far as the export, which is named.
    let (code, err) = run(&base);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("nonexistent-lobefit-export"), "{err}");
}

/// Every render refuses an output it could not write before it reads the export or
/// needs a device: a missing directory (never created), an existing directory, a
/// directory that is a dangling symbolic link.
#[test]
fn renders_refuse_unwritable_outputs_first() {
    let tmp = std::env::temp_dir().join(format!("lobefit-gpu-bad-out-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let dangling = tmp.join("dangling");
    let _ = std::fs::remove_file(&dangling);
    std::os::unix::fs::symlink(tmp.join("nowhere"), &dangling).unwrap();
    let missing = tmp.join("missing");
    let tmp_s = tmp.to_str().unwrap().to_string();
    let missing_png = format!("{}/x.png", missing.display());
    let dangling_png = format!("{}/x.png", dangling.display());
    let commands: [&[&str]; 6] = [
        &["render", "library", "--export", "/nonexistent-lobefit-export"],
        &[
            "render",
            "library",
            "--export",
            "/nonexistent-lobefit-export",
            "--scene",
            "meunier-fig13",
        ],
        &["render", "isg", "--export", "/nonexistent-lobefit-export"],
        &["render", "shexp", "--export", "/nonexistent-lobefit-export"],
        &["render", "meunier", "--export", "/nonexistent-lobefit-export"],
        &["render", "rigs"],
    ];
    for cmd in commands {
        for (out, what) in [
            (missing_png.as_str(), "the directory must exist"),
            (tmp_s.as_str(), "is a directory"),
            (dangling_png.as_str(), "dangling symbolic link"),
        ] {
            let args: Vec<&str> = cmd.iter().copied().chain(["--out", out]).collect();
            let (code, err) = run(&args);
            assert_eq!(code, Some(2), "{args:?}: {err}");
            assert!(
                err.contains(what) && err.contains("--out"),
                "{args:?} should say {what:?}: {err}"
            );
            assert!(
                !err.contains("nonexistent-lobefit-export"),
                "{args:?}: --out is checked first: {err}"
            );
        }
        assert!(!missing.exists(), "{cmd:?} created {}", missing.display());
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

/// A scene whose pixels may need more loop iterations than llvmpipe runs is refused
/// before the export is read or a device is needed, the limit named: render isg with
/// 100 SGs, render shexp with 700 spheres, render isg --looped on fig12 (the GPU's
/// blocker loop counted); and render isg with more spheres than its kernel takes, or
/// SG products sharper than its table.
#[test]
fn scenes_over_the_loop_budget_are_refused_before_dispatch() {
    let tmp = std::env::temp_dir().join(format!("lobefit-gpu-budget-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let read = |name: &str| -> serde_json::Value {
        let (p, scene) = name.split_once('-').unwrap();
        let path = format!("{}/../pipelines/{p}/scenes/{scene}.json", env!("CARGO_MANIFEST_DIR"));
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    };
    let mut isg = read("isg-fig12");
    let sg = isg["environment"]["sgs"][1].clone();
    isg["environment"]["sgs"] = serde_json::Value::Array(vec![sg; 100]);
    let mut shexp = read("shexp-wrecking");
    let spheres = shexp["spheres"].as_array().unwrap().clone();
    let more: Vec<serde_json::Value> = (0..700)
        .map(|k| {
            let mut s = spheres[k % spheres.len()].clone();
            s["centre"][0] = serde_json::json!(50.0 + k as f64);
            s
        })
        .collect();
    shexp["spheres"] = serde_json::Value::Array(more.clone());
    // 300 spheres: more than the kernel once unrolled (256); the scene is data now, and
    // the loops stay within the budget, so it passes to the export (absent here).
    let mut isg_big = read("isg-fig12");
    isg_big["spheres"] = serde_json::Value::Array(more[..300].to_vec());
    // Phong lobes sharper than the ISG table's γ ≤ 1e4 (the kernel clamped γ: negative).
    let mut isg_sharp = read("isg-fig12");
    for s in isg_sharp["spheres"].as_array_mut().unwrap() {
        if let Some(lobes) = s["material"]["lafortune"]["lobes"].as_array_mut() {
            lobes.iter_mut().for_each(|l| l["exponent"] = serde_json::json!(1e5));
        }
    }
    for (name, scene, what) in [
        ("isg", isg_sharp, "γ ≤"),
        ("isg", isg, "100 SGs"),
        ("shexp", shexp, "700 spheres"),
        ("isg", isg_big, "no such export directory"),
    ] {
        let cmd = format!("render {name}");
        let file = tmp.join(format!("{name}-{what}.json").replace(['≤', ' '], "_"));
        std::fs::write(&file, scene.to_string()).unwrap();
        let out = tmp.join("x.png");
        let args = [
            "render",
            name,
            "--export",
            "/nonexistent-lobefit-export",
            "--scene",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        let (code, err) = run(&args);
        assert_eq!(code, Some(2), "{cmd}: {err}");
        let named = err.contains(&cmd) || what == "no such export directory";
        assert!(err.contains(what) && named, "{cmd}: {err}");
        if what == "100 SGs" || what == "700 spheres" {
            assert!(err.contains("65535") && err.contains("loop iterations"), "{cmd}: {err}");
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

/// `render isg --per-vertex` on a scene with no mesh is refused by name before the
/// export is read (there is no vertex to shade).
#[test]
fn per_vertex_needs_a_mesh() {
    let out = std::env::temp_dir().join(format!("lobefit-gpu-pv-{}.png", std::process::id()));
    let args = [
        "render",
        "isg",
        "--export",
        "/nonexistent-lobefit-export",
        "--scene",
        "fig12",
        "--per-vertex",
        "--out",
        out.to_str().unwrap(),
    ];
    let (code, err) = run(&args);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--per-vertex") && err.contains("has no mesh"), "{err}");
    assert!(!err.contains("nonexistent-lobefit-export"), "{err}");
    assert!(!out.exists());
}

/// `--cut` outside its degrees is a usage error naming the range, before anything is
/// read: render isg takes [0, 90], render shexp (0, 90] (0 is its flat set).
#[test]
fn cut_angles_outside_their_range_are_refused() {
    let out = std::env::temp_dir().join(format!("lobefit-gpu-cut-{}.png", std::process::id()));
    for (name, value, range) in [
        ("isg", "-1", "[0, 90]"),
        ("isg", "91", "[0, 90]"),
        ("isg", "NaN", "[0, 90]"),
        ("shexp", "0", "(0, 90]"),
        ("shexp", "inf", "(0, 90]"),
    ] {
        let args = [
            "render",
            name,
            "--export",
            "/nonexistent-lobefit-export",
            &format!("--cut={value}"),
            "--out",
            out.to_str().unwrap(),
        ];
        let (code, err) = run(&args);
        assert_eq!(code, Some(2), "{name} --cut {value}: {err}");
        assert!(
            err.contains("--cut") && err.contains(range),
            "{name} --cut {value}: {err}"
        );
        assert!(!out.exists());
    }
}
