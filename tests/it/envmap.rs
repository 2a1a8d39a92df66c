//! `lobefit fit-env`: an HDR map fitted with RGB SGs, measured against the map and SH,
//! its output pasted into a scene.

use crate::common::run_text;

/// The sunny map at K = 8: the output holds 8 lobes, the first the sun; the lobes'
/// energy is the map's (per channel, to 1e-9); their irradiance error (median over
/// 1 000 normals, against the map's texels) is below SH order 3's, and its max within
/// 10 %; the list pastes into a scene's environment (RGB amplitudes shaded as their
/// luminance).
#[test]
fn fit_env_writes_lobes_a_scene_takes() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("sky.json");
    let (code, stdout, stderr) = run_text(
        &[
            "fit-env",
            "--map",
            "assets/envmaps/sky.exr",
            "--sgs",
            "8",
            "--out",
            out.to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("the first a sun"), "{stdout}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let sgs = v["sgs"].as_array().unwrap();
    assert_eq!(sgs.len(), 8);
    let r = &v["report"];
    for q in 0..3 {
        let (map, fit) = (r["energy"][0][q].as_f64().unwrap(), r["energy"][1][q].as_f64().unwrap());
        assert!((fit - map).abs() < 1e-9 * map, "channel {q}: {map} vs {fit}");
    }
    let irr = |k: usize, at: usize| r["irradiance"][k][at].as_f64().unwrap();
    assert!(
        irr(0, 0) < irr(1, 0),
        "SG median {} against SH 3's {}",
        irr(0, 0),
        irr(1, 0)
    );
    assert!(irr(0, 1) <= 0.10, "max {}", irr(0, 1));
    let scene = serde_json::json!({
        "version": 1,
        "environment": {"sgs": sgs},
        "spheres": [{"centre": [0, 0, 1], "radius": 1, "material": {"lambert": {"albedo": 0.5}}}],
        "planes": [{"normal": [0, 0, 1], "offset": 0, "tangent": [1, 0, 0], "half_extent": 4,
                    "material": {"lambert": {"albedo": 0.5}}}]
    });
    let s = lobefit::pipelines::scene::parse("sky", &scene.to_string()).unwrap();
    assert_eq!(s.environment.len(), 8);
    // Bad input: an unknown extension, a count out of range, a missing map.
    let o = out.to_str().unwrap();
    let (code, _, err) = run_text(&["fit-env", "--map", "README.md", "--sgs", "8", "--out", o], "");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains(".exr or .hdr"), "{err}");
    let (code, _, _) = run_text(
        &["fit-env", "--map", "assets/envmaps/sky.exr", "--sgs", "0", "--out", o],
        "",
    );
    assert_eq!(code, Some(2));
    let (code, _, err) = run_text(&["fit-env", "--map", "/nonexistent.exr", "--sgs", "4", "--out", o], "");
    assert_eq!(code, Some(1), "{err}");
}

/// A scene lit by a map (`"environment": {"map": "sky.exr", "sgs": 24}`, the committed
/// `assets/envmaps/isg-sky.json` with a Lambert `brdf`): the pipeline shades the 24
/// lobes fitted on load, `--exact` integrates the map itself. At the top of the big
/// sphere (normal +z, nothing above it) the map's exact radiance is a sum over the
/// upper rows' texels in closed form (each lies wholly above the horizon: L Δφ
/// (sin² θ₁ − sin² θ₀)/2 each); `--exact` agrees with it within 0.5 % (its own 1e-3
/// standard error; measured 0.04 %), and the ISG within 2 % (the fit's irradiance
/// error: 1.9 % at most on this map; measured 0.2 %). In the big sphere's
/// shadow on the ground (the sun's direction) both are dark next to the open ground.
/// The colour columns: the channels' luminance is the luminance column, each channel
/// of the ISG within 5 % of the map's at the open points. Bad `map` forms are refused
/// by name.
#[test]
fn a_map_lights_a_scene_and_the_reference_integrates_the_map() {
    use lobefit::pipelines::envmap::{luminance, EnvMap};
    use lobefit::pipelines::scene::{load_for, parse, Accepts};
    use lobefit_tables::glam::DVec3;
    use std::f64::consts::{PI, TAU};
    let d = tempfile::tempdir().unwrap();
    std::fs::copy("assets/envmaps/sky.exr", d.path().join("sky.exr")).unwrap();
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("assets/envmaps/isg-sky.json").unwrap()).unwrap();
    scene["brdf"] = serde_json::json!({"lambert": {"albedo": 0.7}});
    let path = d.path().join("sky-eval.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let path = path.to_str().unwrap();
    let loaded = load_for(path, &Accepts::ALL).unwrap();
    assert_eq!(loaded.environment.len(), 24);
    let light = loaded.environment_map.as_ref().expect("a map");
    // The map's own exact radiance at an upward normal, read independently.
    let map = EnvMap::load(std::path::Path::new("assets/envmaps/sky.exr")).unwrap();
    let (w, h) = (map.width, map.height);
    let mut e = 0.0;
    for v in 0..h / 2 {
        let (t0, t1) = (PI * v as f64 / h as f64, PI * (v + 1) as f64 / h as f64);
        let row = TAU / w as f64 * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
        e += (0..w).map(|u| luminance(map.rgb[v * w + u])).sum::<f64>() * row;
    }
    let want = 0.7 / PI * e;
    assert!((light.luminance(DVec3::Z) - luminance(map.radiance(DVec3::Z))).abs() < 1e-12);
    let sun = loaded
        .environment
        .iter()
        .max_by(|a, b| a.sharpness.total_cmp(&b.sharpness))
        .unwrap()
        .axis;
    assert!(sun.z > 0.0, "the sky's sun is above the horizon");
    // The big sphere: centre (0, 0, 0.8), radius 0.8; its shadow's centre on the ground.
    let shadow = DVec3::new(0.0, 0.0, 0.8) - sun * (0.8 / sun.z);
    let row = |p: DVec3| format!("{},{},{},0,0,1,0,0,1\n", p.x, p.y, p.z);
    let input = format!(
        "px,py,pz,nx,ny,nz,vx,vy,vz\n{}{}{}",
        row(DVec3::new(0.0, 0.0, 1.6)),
        row(shadow),
        row(DVec3::new(3.5, -3.5, 0.0))
    );
    // Each row: radiance (luminance), then linear R, G, B.
    let eval = |exact: bool| -> Vec<[f64; 4]> {
        let args = ["eval", "isg-shade", "--scene", path];
        let (code, stdout, stderr) = run_text(&[&args[..], if exact { &["--exact"] } else { &[] }].concat(), &input);
        assert_eq!(code, Some(0), "{stderr}");
        let mut lines = stdout.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(
            header[header.len() - 4..],
            ["radiance", "radiance_r", "radiance_g", "radiance_b"]
        );
        lines
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
                [v[v.len() - 4], v[v.len() - 3], v[v.len() - 2], v[v.len() - 1]]
            })
            .collect()
    };
    let (isg_rgb, exact_rgb) = (eval(false), eval(true));
    println!("top, shadow, open: isg {isg_rgb:?}, exact {exact_rgb:?}, closed form {want}");
    // The channels' Rec. 709 luminance is the luminance column (both sides are linear
    // in the light), and each channel of the ISG is within 5 % of the map's at the
    // open points; the channels differ (the map is coloured).
    for (a, b) in isg_rgb.iter().zip(&exact_rgb) {
        for r in [a, b] {
            assert!((luminance([r[1], r[2], r[3]]) - r[0]).abs() <= 1e-9 * r[0], "{r:?}");
        }
    }
    for k in [0, 2] {
        for c in 1..4 {
            assert!(
                (isg_rgb[k][c] / exact_rgb[k][c] - 1.0).abs() < 0.05,
                "{isg_rgb:?} {exact_rgb:?}"
            );
        }
    }
    assert!((exact_rgb[2][3] / exact_rgb[2][1] - 1.0).abs() > 0.05, "{exact_rgb:?}");
    let isg: Vec<f64> = isg_rgb.iter().map(|r| r[0]).collect();
    let exact: Vec<f64> = exact_rgb.iter().map(|r| r[0]).collect();
    assert!((exact[0] / want - 1.0).abs() < 0.005, "{exact:?} vs {want}");
    assert!((isg[0] / want - 1.0).abs() < 0.02, "{isg:?} vs {want}");
    assert!(exact[1] < 0.6 * exact[2] && isg[1] < 0.6 * isg[2], "{isg:?} {exact:?}");
    assert!((isg[1] - exact[1]).abs() < 0.05 * exact[2], "{isg:?} {exact:?}");
    // Bad forms: a count out of range, a list with a map, a map outside the folder, a
    // missing map, a scene given as text.
    for (env, says) in [
        (serde_json::json!({"map": "sky.exr", "sgs": 0}), "1..=64"),
        (serde_json::json!({"map": "sky.exr", "sgs": 65}), "1..=64"),
        (
            serde_json::json!({"map": "sky.exr", "sgs": [{"axis": [0, 0, 1], "sharpness": 1, "amplitude": 1}]}),
            "count",
        ),
        (serde_json::json!({"map": "../sky.exr", "sgs": 4}), "environment.map"),
        (serde_json::json!({"map": "none.exr", "sgs": 4}), "environment.map"),
    ] {
        scene["environment"] = env;
        std::fs::write(d.path().join("bad.json"), scene.to_string()).unwrap();
        let err = load_for(d.path().join("bad.json").to_str().unwrap(), &Accepts::ALL)
            .unwrap_err()
            .to_string();
        assert!(err.contains(says), "{err}");
    }
    scene["environment"] = serde_json::json!({"map": "sky.exr", "sgs": 4});
    let err = parse("text", &scene.to_string()).unwrap_err().to_string();
    assert!(err.contains("no folder"), "{err}");
}

/// `lobefit prefilter` on a hand-written 16 × 8 Radiance map of one colour (1, 0.5,
/// 0.25): the table it writes loads as kind `env-prefilter`, and its lookup gives the
/// colour back at any direction and λ on the ladder (a constant map is its own
/// prefilter; to 2e-3), and refuses λ off the ladder; `--texture` writes its nodes as a
/// KTX2 array texture. Bad input: a missing map, `--out` onto a directory and
/// `--texture` onto `--out` exit 1 and write nothing; `--texture-storage` alone is a
/// usage error.
#[test]
fn prefilter_writes_a_table_and_texture_that_give_a_constant_map_back() {
    let d = tempfile::tempdir().unwrap();
    let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n".to_vec();
    for _ in 0..16 * 8 {
        f.extend([128u8, 64, 32, 129]);
    }
    let map = d.path().join("flat.hdr");
    std::fs::write(&map, &f).unwrap();
    let out = d.path().join("flat.lobefit");
    let (m, o) = (map.to_str().unwrap(), out.to_str().unwrap());
    let tex_path = d.path().join("flat.ktx2");
    let t = tex_path.to_str().unwrap();
    let args = [
        "prefilter",
        "--map",
        m,
        "--out",
        o,
        "--check",
        "16",
        "--texture",
        t,
        "--texture-storage",
        "f16",
    ];
    let (code, stdout, stderr) = run_text(&args, "");
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stdout.contains("27 levels") && stdout.contains("cubic in λ") && stdout.contains("flat.ktx2"),
        "{stdout}"
    );
    let table = lobefit_tables::Table::from_path(&out).unwrap();
    // The texture, read back by the ktx2 crate: the table's nodes (φ across, θ down, a
    // layer per level), f16, and their luminance in A.
    let (tex, storage) = lobefit::export::formats::read(&tex_path, lobefit::export::Format::Ktx2).unwrap();
    assert_eq!(storage, lobefit::export::Storage::F16);
    assert_eq!((tex.width, tex.height, tex.layers, tex.channels), (17, 9, 27, 4));
    for (texel, node) in tex.data.chunks_exact(4).zip(table.values().chunks_exact(3)) {
        for c in 0..3 {
            assert_eq!(texel[c], half::f16::from_f32(node[c]).to_f32());
        }
        let y = 0.2126 * node[0] + 0.7152 * node[1] + 0.0722 * node[2];
        assert_eq!(texel[3], half::f16::from_f32(y).to_f32());
    }
    let (code, _, err) = run_text(&["prefilter", "--map", m, "--out", o, "--texture", o], "");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("the same file"), "{err}");
    let (code, _, err) = run_text(&["prefilter", "--map", m, "--out", o, "--texture-storage", "f16"], "");
    assert_eq!(code, Some(2), "{err}");
    use lobefit::pipelines::prefilter::lookup;
    use lobefit_tables::glam::DVec3;
    for (a, lambda) in [
        (DVec3::Z, 1.0),
        (DVec3::new(0.6, 0.0, -0.8), 3.3),
        (DVec3::new(-0.3, 0.9, 0.3).normalize(), 700.0),
        (-DVec3::Z, 8192.0),
    ] {
        let g = lookup(&table, a, lambda).unwrap();
        for (c, want) in [1.0, 0.5, 0.25].iter().enumerate() {
            assert!((g[c] / want - 1.0).abs() < 2e-3, "λ {lambda} at {a}: {g:?}");
        }
    }
    assert!(lookup(&table, DVec3::Z, 0.9).is_err());
    assert!(lookup(&table, DVec3::Z, f64::NAN).is_err());
    let (code, _, err) = run_text(&["prefilter", "--map", "/nonexistent.hdr", "--out", o], "");
    assert_eq!(code, Some(1), "{err}");
    let (code, _, err) = run_text(&["prefilter", "--map", m, "--out", d.path().to_str().unwrap()], "");
    assert_eq!(code, Some(1), "{err}");
}

/// A scene names its map's Γ_L (`"environment": {"map": ..., "sgs": K, "prefiltered":
/// FILE}`): `render isg` adds the row "model best, eq. 9, Γ_L" and makes it the
/// headline. A table made from
/// another map of the same size is refused at load, naming the file, and so are a
/// table without a map, a file that is not a table and a path out of the folder.
#[test]
fn a_scene_takes_its_maps_prefiltered_table() {
    use lobefit::pipelines::envmap::luminance;
    use std::f64::consts::{PI, TAU};
    let d = tempfile::tempdir().unwrap();
    let texel = |spot: bool| {
        if spot {
            [160u8, 120, 80, 133]
        } else {
            [128u8, 64, 32, 129]
        }
    };
    for (name, spot_at) in [("spot.hdr", Some(21usize)), ("flat.hdr", None)] {
        let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n".to_vec();
        for k in 0..16 * 8 {
            f.extend(texel(Some(k) == spot_at));
        }
        std::fs::write(d.path().join(name), &f).unwrap();
        let out = d.path().join(name.replace(".hdr", ".lobefit"));
        let m = d.path().join(name);
        let (code, _, err) = run_text(
            &[
                "prefilter",
                "--map",
                m.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--check",
                "0",
            ],
            "",
        );
        assert_eq!(code, Some(0), "{err}");
    }
    let scene = |table: &str, map: bool| {
        let mut env = serde_json::json!({"sgs": 4, "prefiltered": table});
        if map {
            env["map"] = "spot.hdr".into();
        } else {
            env["sgs"] = serde_json::json!([{"axis": [0, 0, 1], "sharpness": 2.0, "amplitude": 1.0}]);
        }
        serde_json::json!({
            "version": 1,
            "camera": {"eye": [0.0, -5.0, 3.0], "target": [0.0, 0.0, 0.5], "fov": 0.7},
            "environment": env,
            "spheres": [{"centre": [0, 0, 0.8], "radius": 0.8, "material": {"lafortune": {"albedo": 0.5,
                "lobes": [{"c": [-1.0, -1.0, 1.0], "exponent": 100.0, "specular": 0.4}]}}}],
            "planes": [{"normal": [0, 0, 1], "offset": 0.0, "tangent": [1, 0, 0], "half_extent": 3.0,
                "material": {"lambert": {"albedo": 0.7}}}]
        })
        .to_string()
    };
    let path = d.path().join("glossy.json");
    std::fs::write(&path, scene("spot.lobefit", true)).unwrap();
    let out = d.path().join("out");
    let render = |spp: &str| {
        let (p, o) = (path.to_str().unwrap(), out.to_str().unwrap());
        run_text(
            &[
                "render",
                "isg",
                "--scene",
                p,
                "--width",
                "12",
                "--spp",
                spp,
                "--breakdown-stride",
                "1",
                "--out",
                o,
            ],
            "",
        )
    };
    let (code, stdout, err) = render("64");
    assert_eq!(code, Some(0), "{err}");
    let summary = std::fs::read_to_string(out.join("isg-glossy-summary.txt")).unwrap_or_else(|_| stdout.clone());
    assert!(summary.contains("model best, eq. 9, Γ_L"), "{summary}");
    // The headline is eq. 9 from Γ_L: its error is that row's on the breakdown's
    // subset, not the default form's (which the glossy sphere under the spot moves).
    let subset = |row: &str| -> String {
        let line = summary
            .lines()
            .find(|l| l.contains(&format!("   {row}")) && l.contains(": relative RMSE"))
            .unwrap_or_else(|| panic!("{row}: {summary}"));
        let at = line.find(": relative RMSE ").unwrap() + ": relative RMSE ".len();
        line[at..].split_whitespace().next().unwrap().to_string()
    };
    let head = stdout
        .lines()
        .find(|l| l.starts_with("summary: "))
        .unwrap_or_else(|| panic!("{stdout}"));
    let want = format!(
        "ISG (best model, eq. 9 from Γ_L): relative RMSE {} against",
        subset("model best, eq. 9, Γ_L")
    );
    assert!(head.contains(&want), "{head}\n{summary}");
    assert_ne!(subset("model best, eq. 9, Γ_L"), subset("model best   "), "{summary}");
    // eval isg-shade reads Γ_L when the scene names it, each colour column from its
    // channel: a purely specular point whose mirror direction is the spot (colour
    // (20, 15, 10) on (1, 0.5, 0.25)) comes out red over green over blue, its
    // luminance the luminance column, and unlike the lobes' form. A Phong lobe sharper
    // than Γ_L's ladder takes the lobes' form instead of failing.
    let (th, ph) = (PI * 1.5 / 8.0, TAU * 5.5 / 16.0);
    let row = format!(
        "px,py,pz,nx,ny,nz,vx,vy,vz\n0,0,1.6,0,0,1,{},{},{}\n",
        -th.sin() * ph.cos(),
        -th.sin() * ph.sin(),
        th.cos()
    );
    let eval = |table: Option<&str>, exponent: f64| -> Vec<f64> {
        let mut v: serde_json::Value = serde_json::from_str(&scene("spot.lobefit", true)).unwrap();
        match table {
            Some(t) => v["environment"]["prefiltered"] = t.into(),
            None => v["environment"]
                .as_object_mut()
                .unwrap()
                .retain(|k, _| k != "prefiltered"),
        }
        v["brdf"] = serde_json::json!({"lafortune": {"albedo": 0.0,
            "lobes": [{"c": [-1.0, -1.0, 1.0], "exponent": exponent, "specular": 0.4}]}});
        std::fs::write(&path, v.to_string()).unwrap();
        let (code, stdout, err) = run_text(&["eval", "isg-shade", "--scene", path.to_str().unwrap()], &row);
        assert_eq!(code, Some(0), "{err}");
        let line = stdout.lines().nth(1).unwrap();
        line.split(',').skip(9).map(|x| x.parse().unwrap()).collect()
    };
    let (with, without) = (eval(Some("spot.lobefit"), 100.0), eval(None, 100.0));
    assert!(with[1] > with[2] && with[2] > with[3], "{with:?}");
    assert!(
        (luminance([with[1], with[2], with[3]]) - with[0]).abs() <= 1e-9 * with[0],
        "{with:?}"
    );
    assert!((with[0] / without[0] - 1.0).abs() > 0.01, "{with:?} {without:?}");
    let sharp = eval(Some("spot.lobefit"), 1e5);
    assert!(sharp.iter().all(|x| x.is_finite() && *x > 0.0), "{sharp:?}");
    for (table, map, says) in [
        ("flat.lobefit", true, "is not this map's Γ_L"),
        ("spot.lobefit", false, "belongs to a map"),
        ("spot.hdr", true, "spot.hdr: "),
        ("../spot.lobefit", true, "../spot.lobefit"),
    ] {
        std::fs::write(&path, scene(table, map)).unwrap();
        let (code, _, err) = render("16");
        assert_eq!(code, Some(1), "{table}: {err}");
        assert!(
            err.contains(says) && err.contains("environment.prefiltered"),
            "{table}: {err}"
        );
    }
}

/// Both SG-sky pipelines render a map's scene in colour: under a 16 × 8 map whose one
/// half of the sky is red and the other blue, `render isg` (a plane and spheres) and
/// `render shexp` (the whale over its terrain) each write `<stem>-colour.png` and a
/// summary line with each channel's error against that channel of the map itself
/// (Monte Carlo on the texels, not the lobes). Each within 0.25 of its channel's mean
/// (measured 0.07–0.15); the channels' lobes swapped (R ↔ B) measured 0.41–0.92.
#[test]
fn the_isg_and_shexp_renders_under_a_map_are_in_colour() {
    let d = tempfile::tempdir().unwrap();
    let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n".to_vec();
    for _ in 0..8 {
        for u in 0..16 {
            f.extend(if u < 8 {
                [200u8, 20, 20, 129]
            } else {
                [20, 20, 200, 129]
            });
        }
    }
    std::fs::write(d.path().join("m.hdr"), &f).unwrap();
    for (pipeline, from) in [("isg", "isg-sky.json"), ("shexp", "shexp-whale-sky.json")] {
        let mut scene: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(format!("assets/envmaps/{from}")).unwrap()).unwrap();
        scene["environment"] = serde_json::json!({"map": "m.hdr", "sgs": 4});
        let path = d.path().join(format!("{pipeline}-two.json"));
        std::fs::write(&path, scene.to_string()).unwrap();
        let out = d.path().join(pipeline);
        let args = [
            "render",
            pipeline,
            "--scene",
            path.to_str().unwrap(),
            "--width",
            "16",
            "--spp",
            "64",
            "--breakdown-stride",
            "1",
            "--out",
            out.to_str().unwrap(),
        ];
        let (code, _, stderr) = run_text(&args, "");
        assert_eq!(code, Some(0), "{stderr}");
        let stem = format!("{pipeline}-two");
        assert!(out.join(format!("{stem}-colour.png")).is_file(), "{pipeline}");
        let summary = std::fs::read_to_string(out.join(format!("{stem}-summary.txt"))).unwrap();
        let line = summary
            .lines()
            .find(|l| l.contains(": colour (the map's R, G, B;"))
            .unwrap_or_else(|| panic!("{summary}"));
        let errors: Vec<f64> = ["R", "G", "B"]
            .iter()
            .map(|c| {
                let key = format!(" {c} relative RMSE ");
                let at = line.find(&key).unwrap() + key.len();
                line[at..].split_whitespace().next().unwrap().parse().unwrap()
            })
            .collect();
        println!("{pipeline}: R, G, B {errors:?}");
        assert!(errors.iter().all(|&e| e.is_finite() && e < 0.25), "{line}");
    }
}
