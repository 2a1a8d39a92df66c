//! Reliability round 4: the attack's findings, each as a regression test that failed
//! before its fix (the behaviour before is in each test's comment). Inputs that took
//! the machine down or hung it, `--out` replacing what is not a regular file, exports
//! left broken, the black cliff beside a surface, unbounded renders, accepted bad
//! input, exit codes and messages.

use std::path::Path;

use crate::common::{mkfifo, run_bounded, run_text};

/// A closed cube [0, 1]³ as OBJ (12 triangles, wound outwards).
const UNIT_CUBE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Two nodes listing each other 200 times as children: before, `spheres` allocated
/// 15.9 GB and aborted (signal 6) after 29 s; now an error naming the repeated child,
/// at once. A cycle whose nodes have one parent each is refused too (a scene's root
/// is a child), and one the scene does not reach is never walked.
#[test]
fn gltf_node_fan_out_and_cycles_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("s.json");
    let cases = [
        (
            serde_json::json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
                "nodes": [{"children": vec![1; 200]}, {"children": vec![0; 200]}]}),
            "nodes[0].children lists node 1 twice",
        ),
        (
            serde_json::json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
                "nodes": [{"children": [1]}, {"children": [0]}]}),
            "a scene lists root nodes",
        ),
        (
            serde_json::json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
                "nodes": [{"children": [1]}, {}, {"children": [1]}]}),
            "node 1 is a child of nodes 0 and 2",
        ),
        (
            serde_json::json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [2]}],
                "nodes": [{"children": [1]}, {"children": [0]}, {}]}),
            "no triangles",
        ),
    ];
    for (k, (doc, want)) in cases.iter().enumerate() {
        let f = d.path().join(format!("n{k}.gltf"));
        std::fs::write(&f, doc.to_string()).unwrap();
        let (code, _, err) = run_bounded(&["spheres", "--mesh", s(&f), "--count", "4", "--out", s(&out)]);
        assert_eq!(code, Some(1), "{err}");
        assert!(err.contains(want), "case {k}: {err}");
    }
}

/// A mesh file that is a FIFO hung `spheres` and every scene naming it (the open
/// blocks); now refused from its metadata, naming what it is.
#[cfg(unix)]
#[test]
fn a_fifo_mesh_is_refused_without_blocking() {
    let d = tempfile::tempdir().unwrap();
    let fifo = d.path().join("m.obj");
    if !mkfifo(&fifo) {
        eprintln!("skipped: mkfifo is unavailable");
        return;
    }
    let out = d.path().join("s.json");
    let (code, _, err) = run_bounded(&["spheres", "--mesh", s(&fifo), "--count", "4", "--out", s(&out)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("is a FIFO, not a regular file"), "{err}");
    let scene = d.path().join("scene.json");
    std::fs::write(
        &scene,
        r#"{"version": 2, "environment": {"sgs": [{"axis": [0, 0, 1], "sharpness": 2, "amplitude": 1}]},
            "brdf": {"lambert": {"albedo": 0.5}},
            "meshes": [{"file": "m.obj", "material": {"lambert": {"albedo": 0.5}}, "spheres": {"count": 2}}]}"#,
    )
    .unwrap();
    let (code, _, err) = run_bounded(&["eval", "isg-shade", "--scene", s(&scene)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("is a FIFO, not a regular file"), "{err}");
}

/// `--out` onto a FIFO, a symbolic link or a character device: before, the atomic
/// write's rename replaced it with a regular file (as root `--out /dev/null` destroyed
/// the device); now every writing command refuses it before its work, naming what it
/// is, and leaves it as it was.
#[cfg(unix)]
#[test]
fn out_never_replaces_what_is_not_a_regular_file() {
    use std::os::unix::fs::FileTypeExt;
    let d = tempfile::tempdir().unwrap();
    let mesh = d.path().join("cube.obj");
    std::fs::write(&mesh, UNIT_CUBE).unwrap();
    let fifo = d.path().join("fifo");
    if !mkfifo(&fifo) {
        eprintln!("skipped: mkfifo is unavailable");
        return;
    }
    let target = d.path().join("target.txt");
    std::fs::write(&target, "keep").unwrap();
    let link = d.path().join("link");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let mut specials = vec![(fifo.clone(), "a FIFO"), (link.clone(), "a symbolic link")];
    // A character device of our own (the null device's numbers), where we may make one.
    let dev = d.path().join("null");
    let made = std::process::Command::new("mknod")
        .args([s(&dev), "c", "1", "3"])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if made {
        specials.push((dev.clone(), "a character device"));
    }
    for (p, what) in &specials {
        let o = s(p);
        for args in [
            vec![
                "spheres",
                "--mesh",
                s(&mesh),
                "--count",
                "2",
                "--samples",
                "1000",
                "--out",
                o,
            ],
            vec!["fit", "cap-exponent", "--out", o],
            vec!["check", "--quick", "--only", "lobe-integral", "--junit", o],
        ] {
            let (code, _, err) = run_bounded(&args);
            assert_eq!(code, Some(1), "{args:?}: {err}");
            assert!(
                err.contains(&format!(
                    "is {what}, not a regular file: lobefit replaces only regular files"
                )),
                "{args:?}: {err}"
            );
        }
        // Directory outputs: a non-directory is refused before any work.
        for args in [
            vec![
                "render", "isg", "--scene", "fig12", "--width", "8", "--spp", "4", "--out", o,
            ],
            vec!["plot", "log-zh", "--out", o],
            vec!["export", "--format", "ktx2", "--only", "cap-exponent", "--out", o],
        ] {
            let (code, _, err) = run_bounded(&args);
            assert_eq!(code, Some(1), "{args:?}: {err}");
            assert!(err.contains("not a directory"), "{args:?}: {err}");
        }
    }
    // build-tables into a directory where one table's name is a FIFO: refused before
    // fitting anything.
    let tables = d.path().join("tables");
    std::fs::create_dir(&tables).unwrap();
    assert!(mkfifo(&tables.join("lobe-integral.lobefit")));
    let (code, _, err) = run_bounded(&["build-tables", "--only", "lobe-integral", "--out", s(&tables)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("is a FIFO, not a regular file"), "{err}");
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
    if made {
        assert!(std::fs::symlink_metadata(&dev).unwrap().file_type().is_char_device());
    }
    assert!(std::fs::symlink_metadata(tables.join("lobe-integral.lobefit"))
        .unwrap()
        .file_type()
        .is_fifo());
}

/// `plot baselines --out FILE` ran its 274 s study, then failed with "File exists"
/// naming no path; now refused at once, naming it.
#[test]
fn plot_checks_its_out_first() {
    let d = tempfile::tempdir().unwrap();
    let f = d.path().join("file");
    std::fs::write(&f, "x").unwrap();
    let (code, _, err) = run_bounded(&["plot", "baselines", "--out", s(&f)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(&format!("--out {}: it is a regular file, not a directory", s(&f))),
        "{err}"
    );
}

/// An export into a directory holding other files, or over a larger export with
/// `--only`, exited 0 and left a directory `check --export` refused. Now a foreign file
/// is refused up front, and an earlier export is replaced whole: the result checks.
#[test]
fn export_leaves_a_checkable_directory_or_refuses() {
    let d = tempfile::tempdir().unwrap();
    let ex = d.path().join("ex");
    let e = s(&ex);
    let (code, _, err) = run_text(
        &[
            "export",
            "--format",
            "ktx2",
            "--only",
            "cap-exponent,sg-fit",
            "--out",
            e,
        ],
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    let before: Vec<_> = std::fs::read_dir(&ex)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    let (code, _, err) = run_text(
        &[
            "export",
            "--format",
            "ktx2",
            "--only",
            "cap-exponent",
            "--shaders",
            "wgsl",
            "--out",
            e,
        ],
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    let (code, out, err) = run_text(&["check", "--export", e], "");
    assert_eq!(code, Some(0), "{out}{err}");
    let after: Vec<_> = std::fs::read_dir(&ex)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(!after.iter().any(|n| n == "sg-fit.ktx2"), "{before:?} → {after:?}");
    // A file of someone else's: refused, nothing written.
    std::fs::write(ex.join("notes.txt"), "mine").unwrap();
    let (code, _, err) = run_text(&["export", "--format", "dds", "--only", "cap-exponent", "--out", e], "");
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("\"notes.txt\"") && err.contains("no lobefit export writes"),
        "{err}"
    );
    assert!(!ex.join("cap-exponent.dds").exists());
    // Another program's manifest.json (a web app's) is not an earlier export: it is
    // refused, not overwritten, and the files it lists are not removed.
    let web = d.path().join("web");
    std::fs::create_dir(&web).unwrap();
    let theirs = r#"{"name": "app", "families": [{"textures": [{"file": "index.html"}]}]}"#;
    std::fs::write(web.join("manifest.json"), theirs).unwrap();
    std::fs::write(web.join("index.html"), "<html>").unwrap();
    let (code, _, err) = run_text(
        &["export", "--format", "ktx2", "--only", "cap-exponent", "--out", s(&web)],
        "",
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("\"index.html\"") && err.contains("\"manifest.json\""),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(web.join("manifest.json")).unwrap(), theirs);
    assert!(web.join("index.html").exists());
}

/// `check --export` took a manifest whose keys repeat (last wins; a first-wins reader
/// sees the other value); now refused, naming the key. A version that is no integer
/// is named as such (it said "no version").
#[test]
fn export_manifest_keys_are_read_strictly() {
    let d = tempfile::tempdir().unwrap();
    let ex = d.path().join("ex");
    let (code, _, err) = run_text(
        &["export", "--format", "ktx2", "--only", "cap-exponent", "--out", s(&ex)],
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    let manifest = ex.join("manifest.json");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let storage = "\"storage\": \"f32\"";
    assert!(text.contains(storage), "{text}");
    std::fs::write(
        &manifest,
        text.replacen(storage, "\"storage\": \"f16\", \"storage\": \"f32\"", 1),
    )
    .unwrap();
    let (code, _, err) = run_text(&["check", "--export", s(&ex)], "");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("$.storage is given twice"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let version = format!("\"version\": {}", v["version"]);
    std::fs::write(&manifest, text.replacen(&version, "\"version\": \"4\"", 1)).unwrap();
    let (code, _, err) = run_text(&["check", "--export", s(&ex)], "");
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("manifest field `version` is \"4\": expected the integer"),
        "{err}"
    );
}

/// Writes `scene` (JSON) and the unit cube beside it; returns the scene's path.
fn cube_scene(dir: &Path, count: usize) -> std::path::PathBuf {
    std::fs::write(dir.join("cube.obj"), UNIT_CUBE).unwrap();
    let p = dir.join(format!("cube-{count}.json"));
    std::fs::write(
        &p,
        format!(
            r#"{{"version": 2, "environment": {{"sgs": [{{"axis": [0, 0, 1], "sharpness": 3, "amplitude": 1}},
                {{"axis": [0.6, 0, 0.8], "sharpness": 40, "amplitude": 3}}]}},
                "brdf": {{"lambert": {{"albedo": 0.8}}}},
                "meshes": [{{"file": "cube.obj", "material": {{"lambert": {{"albedo": 0.5}}}},
                             "spheres": {{"count": {count}, "method": "kmeans"}}}}]}}"#
        ),
    )
    .unwrap();
    p
}

/// `eval isg-shade` on rows `pz` off the cube's top face (x = y = 0.5, normal +z):
/// (exit code, stdout, stderr).
fn shade_top(scene: &Path, zs: &[f64], exact: bool) -> (Option<i32>, String, String) {
    let mut rows = String::from("px,py,pz,nx,ny,nz,vx,vy,vz\n");
    for z in zs {
        rows.push_str(&format!("0.5,0.5,{z:e},0,0,1,0,0,1\n"));
    }
    let mut args = vec!["eval", "isg-shade", "--scene", s(scene)];
    if exact {
        args.push("--exact");
    }
    run_text(&args, &rows)
}

use crate::common::last_column as radiances;

/// The black cliff: a point 1e-7 or 1e-5 off a mesh face answered 0 (it lay inside the
/// mesh's own covering sphere, "on the mesh" meaning within 1e-9 of its diagonal), and
/// a point 6e-8 inside was refused. The rule now (docs/pipelines.md, the surface
/// tolerance): within 1e-5 of the surface's scale (here √3, the cube's diagonal), on
/// either side, a point is the surface's own and shades exactly as the surface point;
/// at twice that outside it is a point in space (inside the cube's one covering sphere:
/// 0, with a warning), inside it is refused.
#[test]
fn points_within_f32_precision_of_a_mesh_shade_as_its_surface() {
    let d = tempfile::tempdir().unwrap();
    let scene = cube_scene(d.path(), 1);
    let tol = 1e-5 * 3f64.sqrt();
    let zs = [
        1.0,
        1.0 + 1e-7,
        1.0 + 1e-5,
        1.0 - 6e-8,
        1.0 + 0.5 * tol,
        1.0 - 0.5 * tol,
        1.0 + 0.99 * tol,
    ];
    let (code, out, err) = shade_top(&scene, &zs, false);
    assert_eq!(code, Some(0), "{err}");
    let r = radiances(&out);
    assert!(r[0] > 0.1, "{out}");
    for (z, v) in zs.iter().zip(&r) {
        assert_eq!(v.to_bits(), r[0].to_bits(), "pz {z}: {v} against {} on the face", r[0]);
    }
    assert!(!err.contains("warning"), "{err}");
    // --exact on the triangles agrees within its standard error (1e-3 of the estimate).
    let (code, out, err) = shade_top(&scene, &[1.0 + 1e-7], true);
    assert_eq!(code, Some(0), "{err}");
    let e = radiances(&out)[0];
    assert!((e - r[0]).abs() < 0.02 * e, "exact {e} against {}", r[0]);
    // Twice the tolerance: outside, in space and buried in the covering sphere (0, the
    // warning says so); inside, refused.
    let (code, out, err) = shade_top(&scene, &[1.0 + 2.0 * tol], false);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(radiances(&out), [0.0]);
    assert!(
        err.contains("warning: 1 row (the first on line 2): the point lies in space"),
        "{err}"
    );
    let (code, _, err) = shade_top(&scene, &[1.0 - 2.0 * tol], false);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("line 2") && err.contains("inside it"), "{err}");
}

/// `--exact` with a point inside a sphere light answered 0 (exit 0) where the
/// pipeline refuses the row; now both refuse it, naming the line.
#[test]
fn exact_refuses_a_point_inside_a_light() {
    let d = tempfile::tempdir().unwrap();
    let scene = d.path().join("light.json");
    std::fs::write(
        &scene,
        r#"{"version": 1, "brdf": {"lambert": {"albedo": 0.5}},
            "lights": [{"sphere": {"centre": [0, 0, 3], "radius": 1, "radiance": 1}}]}"#,
    )
    .unwrap();
    let rows = "px,py,pz,nx,ny,nz,vx,vy,vz\n0,0,3.2,0,0,1,0,0,1\n";
    for exact in [false, true] {
        let mut args = vec!["eval", "direct-light", "--scene", s(&scene)];
        if exact {
            args.push("--exact");
        }
        let (code, _, err) = run_text(&args, rows);
        assert_eq!(code, Some(1), "--exact {exact}: {err}");
        assert!(
            err.contains("line 2") && err.contains("inside the light"),
            "--exact {exact}: {err}"
        );
    }
}

/// `render isg --scene all --frames 240 --width 2048` started (about 22 h); the
/// method's work (pixels × frames × light terms × blockers) is now bounded and refused
/// before any render, naming the limit (a usage error, as the sample limits).
#[test]
fn a_render_too_large_for_its_method_is_refused_up_front() {
    let d = tempfile::tempdir().unwrap();
    let (code, _, err) = run_bounded(&[
        "render",
        "isg",
        "--scene",
        "all",
        "--frames",
        "240",
        "--width",
        "2048",
        "--spp",
        "2",
        "--out",
        s(d.path()),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("MAX_SHADE_WORK") && err.contains("240 frames"), "{err}");
    assert!(std::fs::read_dir(d.path()).unwrap().next().is_none());
}

/// 12 289 spheres plus a mesh fitted with 4 096 were refused only after the fit (113 s
/// before "16 385 > 16 384"); the total is now checked before any mesh is read or
/// fitted. (An open mesh here: before, its fit's error came first.)
#[test]
fn the_sphere_total_is_checked_before_fitting() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("open.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let sphere = serde_json::json!({"centre": [0, 0, -10], "radius": 0.1, "material": {"lambert": {"albedo": 0.5}}});
    let scene = serde_json::json!({
        "version": 2,
        "environment": {"sgs": [{"axis": [0, 0, 1], "sharpness": 2, "amplitude": 1}]},
        "brdf": {"lambert": {"albedo": 0.5}},
        "spheres": vec![sphere; 12289],
        "meshes": [{"file": "open.obj", "material": {"lambert": {"albedo": 0.5}}, "spheres": {"count": 4096}}],
    });
    let p = d.path().join("many.json");
    std::fs::write(&p, scene.to_string()).unwrap();
    let (code, _, err) = run_bounded(&["eval", "isg-shade", "--scene", s(&p)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("hold 16385 spheres, more than 16384"), "{err}");
}

/// A mesh's `spheres` object ignored unknown keys (`"methd": "tree"` fitted k-means),
/// and a bad count said "data did not match any variant of untagged enum"; each is now
/// an error naming the field and what it takes.
#[test]
fn a_mesh_sphere_spec_names_its_bad_field() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("cube.obj"), UNIT_CUBE).unwrap();
    for (spec, want) in [
        (
            r#"{"count": 4, "methd": "tree"}"#,
            "meshes[0].spheres.methd: unknown field",
        ),
        (
            r#"{"count": -1}"#,
            "meshes[0].spheres.count is -1: expected an integer from 1 to 4096",
        ),
        (
            r#"{"count": 8.5}"#,
            "meshes[0].spheres.count is 8.5: expected an integer",
        ),
        (
            r#"{"count": "8"}"#,
            "meshes[0].spheres.count is \"8\": expected an integer",
        ),
        (r#"{"count": 1180591620717411303424}"#, "meshes[0].spheres.count is"),
        (r#"{"method": "tree"}"#, "meshes[0].spheres: no field `count`"),
        (r#"{"count": 4, "seed": -3}"#, "meshes[0].spheres.seed is -3"),
        ("7", "meshes[0].spheres is 7: expected a sphere-set file's name"),
    ] {
        let p = d.path().join("s.json");
        std::fs::write(
            &p,
            format!(
                r#"{{"version": 2, "environment": {{"sgs": [{{"axis": [0, 0, 1], "sharpness": 2, "amplitude": 1}}]}},
                    "brdf": {{"lambert": {{"albedo": 0.5}}}},
                    "meshes": [{{"file": "cube.obj", "material": {{"lambert": {{"albedo": 0.5}}}}, "spheres": {spec}}}]}}"#
            ),
        )
        .unwrap();
        let (code, _, err) = run_text(&["eval", "isg-shade", "--scene", s(&p)], "");
        assert_eq!(code, Some(1), "{spec}: {err}");
        assert!(err.contains(want), "{spec}: {err}");
        assert!(!err.contains("untagged"), "{spec}: {err}");
    }
}

/// Two triangles gave `volume error inf`, written as `null` into a set file no scene
/// could read; open meshes are now refused (nothing written). The bunny (0.8 % of its
/// edges open) still fits.
#[test]
fn spheres_refuses_open_meshes_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("s.json");
    let two = d.path().join("two.obj");
    std::fs::write(&two, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\n").unwrap();
    let (code, _, err) = run_bounded(&["spheres", "--mesh", s(&two), "--count", "2", "--out", s(&out)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("not closed"), "{err}");
    assert!(!out.exists());
}

/// The glTF reader took out-of-range and mistyped accessors (a sparse index beyond
/// the count, a buffer view beyond its buffer, `asset.version` 3.0, a u8 POSITION read
/// as f32) and printed the gltf crate's `unreachable!` panic text on a float index
/// accessor; each is now an error naming the field, and nothing panics.
#[test]
fn gltf_fields_are_checked_before_reading() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("s.json");
    // A triangle: 3 f32 positions (36 bytes), then 3 indices as f32 (12 bytes).
    let mut bin = Vec::new();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bin.extend(c.to_le_bytes());
        }
    }
    for i in [0f32, 1.0, 2.0] {
        bin.extend(i.to_le_bytes());
    }
    let uri = format!("data:application/octet-stream;base64,{}", base64(&bin));
    let doc = |version: &str, pos_type: u32, idx_type: u32, view0_len: usize| {
        serde_json::json!({
            "asset": {"version": version}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
            "buffers": [{"byteLength": 48, "uri": uri}],
            "bufferViews": [{"buffer": 0, "byteLength": view0_len}, {"buffer": 0, "byteOffset": 36, "byteLength": 12}],
            "accessors": [
                {"bufferView": 0, "componentType": pos_type, "count": 3, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": idx_type, "count": 3, "type": "SCALAR"}
            ]
        })
    };
    let sparse = {
        let mut v = doc("2.0", 5126, 5125, 36);
        v["accessors"][0]["sparse"] = serde_json::json!({"count": 2,
            "indices": {"bufferView": 1, "componentType": 5125}, "values": {"bufferView": 0}});
        // Index 1 is 0x3f800000 (the f32 1.0's bits), beyond the count 3.
        v["accessors"][1]["componentType"] = 5125.into();
        v
    };
    for (k, (v, want)) in [
        (doc("2.0", 5126, 5126, 36), "accessors[1] (indices): componentType F32"),
        (doc("3.0", 5126, 5125, 36), "asset.version \"3.0\""),
        (doc("2.0", 5121, 5125, 36), "accessors[0] (POSITION): componentType U8"),
        (
            doc("2.0", 5126, 5125, 400),
            "spans bytes 0..400 of buffer 0, which has 48",
        ),
        (sparse, "sparse index 1 is 1065353216"),
    ]
    .into_iter()
    .enumerate()
    {
        let f = d.path().join(format!("g{k}.gltf"));
        std::fs::write(&f, v.to_string()).unwrap();
        let (code, _, err) = run_bounded(&["spheres", "--mesh", s(&f), "--count", "2", "--out", s(&out)]);
        assert_eq!(code, Some(1), "case {k}: {err}");
        assert!(err.contains(want), "case {k}: {err}");
        assert!(
            !err.contains("panicked") && !err.contains("unreachable"),
            "case {k}: {err}"
        );
    }
}

/// Standard base64 with padding (RFC 4648), for a glTF data URI.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n =
            (u32::from(c[0]) << 16) | (u32::from(*c.get(1).unwrap_or(&0)) << 8) | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A Lafortune lobe that creates energy (`c` 1e6: 8e58 from a radiance-1 light;
/// `specular` 1e6) was accepted, and so was a rotation of 1e300 rad; now refused,
/// naming the lobe or the rotation.
#[test]
fn materials_conserve_energy_and_rotations_are_bounded() {
    // Meunier's pipeline shades Lafortune lobes: before, it rendered these.
    let base = r#"{"version": 1, "camera": {"eye": [0, -5, 1], "target": [0, 0, 0], "fov": 0.8},
        "lights": [{"sphere": {"centre": [0, 0, 6], "radius": 1, "radiance": 1}}],
        "spheres": [{"centre": [0, 0, 1], "radius": 1, "material": MATERIAL}],
        "planes": [{"normal": [0, 0, 1], "offset": 0, "tangent": [1, 0, 0], "half_extent": 5,
                    "material": {"lambert": {"albedo": 0.5}}}]}"#;
    let d = tempfile::tempdir().unwrap();
    for (material, want) in [
        (
            r#"{"lafortune": {"albedo": 0.5, "lobes": [{"c": [1e6, 1e6, 1e6], "exponent": 10, "specular": 0.3}]}}"#,
            "lobes[0] makes the material reflect up to",
        ),
        (
            r#"{"lafortune": {"albedo": 0.5, "lobes": [{"c": [-1, -1, 1], "exponent": 10, "specular": 1e6}]}}"#,
            "lobes[0] makes the material reflect up to 1.0000e6",
        ),
        (
            r#"{"lafortune": {"albedo": 0.6, "lobes": [{"c": [-1, -1, 1], "exponent": 10, "specular": 0.5}]}}"#,
            "reflect up to 1.1000e0",
        ),
    ] {
        let p = d.path().join("m.json");
        std::fs::write(&p, base.replace("MATERIAL", material)).unwrap();
        let (code, _, err) = run_bounded(&[
            "render",
            "meunier",
            "--scene",
            s(&p),
            "--width",
            "8",
            "--spp",
            "4",
            "--out",
            s(d.path()),
        ]);
        assert_eq!(code, Some(1), "{material}: {err}");
        assert!(err.contains(want), "{material}: {err}");
    }
    // At the bound, 0.5 + 0.5: accepted.
    let ok = base.replace(
        "MATERIAL",
        r#"{"lafortune": {"albedo": 0.5, "lobes": [{"c": [-1, -1, 1], "exponent": 10, "specular": 0.5}]}}"#,
    );
    lobefit::pipelines::scene::parse("ok", &ok).unwrap();
    std::fs::write(d.path().join("cube.obj"), UNIT_CUBE).unwrap();
    let mesh = |angle: &str| {
        format!(
            r#"{{"version": 2, "environment": {{"sgs": [{{"axis": [0, 0, 1], "sharpness": 2, "amplitude": 1}}]}},
                "brdf": {{"lambert": {{"albedo": 0.5}}}},
                "meshes": [{{"file": "cube.obj", "material": {{"lambert": {{"albedo": 0.5}}}}, "spheres": {{"count": 1}},
                  "transform": {{"rotation": {{"axis": [0, 0, 1], "angle": {angle}}}}}}}]}}"#
        )
    };
    let e = lobefit::pipelines::scene::parse_in("r", &mesh("1e300"), d.path()).unwrap_err();
    assert!(
        e.contains("meshes[0].transform.rotation") && e.contains("MAX_BEND_ANGLE"),
        "{e}"
    );
    lobefit::pipelines::scene::parse_in("r", &mesh("12.5"), d.path()).unwrap();
    // A key's rotation goes through the same bound.
    let keyed = mesh("0").replace(
        r#""spheres": {"count": 1},"#,
        r#""spheres": {"count": 1}, "keys": [{"time": 0, "translation": [0, 0, 0],
            "rotation": {"axis": [0, 0, 1], "angle": -1e300}}],"#,
    );
    let e = lobefit::pipelines::scene::parse_in("r", &keyed, d.path()).unwrap_err();
    assert!(
        e.contains("meshes[0].keys[0].rotation") && e.contains("MAX_BEND_ANGLE"),
        "{e}"
    );
}

/// One exit code for one kind of error: a scene's translation over the coordinate
/// limit (found when the file is checked) and a transformed vertex over it (found when
/// the mesh is built) both exit 1 (the file's error); before, the second exited 2. A
/// flag's error stays 2.
#[test]
fn scene_errors_exit_1_whenever_they_are_found() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("cube.obj"), UNIT_CUBE).unwrap();
    let scene = |transform: &str| {
        format!(
            r#"{{"version": 2, "environment": {{"sgs": [{{"axis": [0, 0, 1], "sharpness": 2, "amplitude": 1}}]}},
                "brdf": {{"lambert": {{"albedo": 0.5}}}},
                "meshes": [{{"file": "cube.obj", "material": {{"lambert": {{"albedo": 0.5}}}},
                  "spheres": {{"count": 1, "method": "kmeans"}}, "transform": {transform}}}]}}"#
        )
    };
    for (transform, want) in [
        (r#"{"translation": [2e6, 0, 0]}"#, "translation"),
        (
            r#"{"scale": 900000, "translation": [500000, 0, 0]}"#,
            "must be finite with every |coordinate|",
        ),
    ] {
        let p = d.path().join("t.json");
        std::fs::write(&p, scene(transform)).unwrap();
        let (code, _, err) = run_text(&["eval", "isg-shade", "--scene", s(&p)], "px,py,pz,nx,ny,nz,vx,vy,vz\n");
        assert_eq!(code, Some(1), "{transform}: {err}");
        assert!(err.contains(want), "{transform}: {err}");
        let (code, _, err) = run_text(&["eval", "isg-shade", "--scene", s(&p), "--model", "octopus"], "");
        assert_eq!(code, Some(1), "a file's error comes first: {err}");
    }
    let (code, _, err) = run_text(&["eval", "isg-shade", "--scene", "isg-fig12", "--model", "octopus"], "");
    assert_eq!(code, Some(2), "{err}");
}

/// `--exact` stopped a whole batch when one row (deep in a penumbra) missed its
/// standard-error target; a row stopped short now keeps its estimate, and `eval`
/// reports it by line with its standard error (the view's note), the other rows as
/// usual.
#[test]
fn exact_notes_a_row_short_of_its_target_and_goes_on() {
    use lobefit::family::{Lookup, View};
    struct Noted;
    impl View for Noted {
        fn kind(&self) -> &'static str {
            "noted"
        }
        fn inputs(&self) -> &'static [&'static str] {
            &["x"]
        }
        fn outputs(&self) -> &'static [&'static str] {
            &["y"]
        }
        fn embedded(&self) -> &'static [u8] {
            &[]
        }
        fn runtime(&self, _: lobefit::tables::Table) -> Result<Box<dyn Lookup>, lobefit::tables::LoadError> {
            unreachable!("--exact only")
        }
        fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
            self.exact_noted(x).map(|(y, _)| y)
        }
        fn exact_noted(&self, x: &[f64]) -> Result<(Vec<f64>, Option<String>), String> {
            let note = (x[0] > 1.0).then(|| format!("{} ± 0.1", 2.0 * x[0]));
            Ok((vec![2.0 * x[0]], note))
        }
    }
    let mut out = Vec::new();
    let done = lobefit::eval::eval_csv(&Noted, None, "x\n0.5\n3\n1\n7\n".as_bytes(), &mut out).unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), "x,y\n0.5,1e0\n3,6e0\n1,2e0\n7,1.4e1\n");
    assert_eq!(done.notes, [(3, "6 ± 0.1".to_string()), (5, "14 ± 0.1".to_string())]);
}
