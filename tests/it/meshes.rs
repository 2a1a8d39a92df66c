//! `lobefit spheres`: a sphere set fitted to a mesh, its file, its determinism and
//! its argument errors.

use crate::common::run_text;

/// A closed cube [0, 2]³ as OBJ (12 triangles, wound outwards).
const CUBE: &str = "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nv 0 0 2\nv 2 0 2\nv 2 2 2\nv 0 2 2\n\
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";

/// Eight spheres on a cube by each method: the file holds them and the measured
/// quality; a second run writes the same bytes; the covering spheres of the cube's
/// octants have radius √3/2·(1 − O(sample gaps)) and cover the corners' neighbourhood
/// only partly, so the volume error is between the inscribed (0.48) and 0 bounds.
#[test]
fn spheres_writes_a_deterministic_set() {
    let d = tempfile::tempdir().unwrap();
    let mesh = d.path().join("cube.obj");
    std::fs::write(&mesh, CUBE).unwrap();
    for method in ["kmeans", "tree"] {
        let mut bytes = Vec::new();
        for k in 0..2 {
            let out = d.path().join(format!("{method}{k}.json"));
            let (code, stdout, stderr) = run_text(
                &[
                    "spheres",
                    "--mesh",
                    mesh.to_str().unwrap(),
                    "--count",
                    "8",
                    "--method",
                    method,
                    "--seed",
                    "3",
                    "--samples",
                    "20000",
                    "--out",
                    out.to_str().unwrap(),
                ],
                "",
            );
            assert_eq!(code, Some(0), "{stdout}{stderr}");
            assert!(stdout.contains("volume error"), "{stdout}");
            bytes.push(std::fs::read(&out).unwrap());
        }
        assert_eq!(bytes[0], bytes[1], "{method}: two runs differ");
        let v: serde_json::Value = serde_json::from_slice(&bytes[0]).unwrap();
        let spheres = v["spheres"].as_array().unwrap();
        assert_eq!(spheres.len(), 8);
        for s in spheres {
            // Each covers an octant: radius near the octant's half diagonal √3/2.
            let r = s["radius"].as_f64().unwrap();
            assert!((0.75..=0.8661).contains(&r), "{method}: radius {r}");
        }
        let ve = v["quality"]["volume_error"].as_f64().unwrap();
        assert!(ve > 0.1 && ve < 2.0, "{method}: volume error {ve}");
    }
}

#[test]
fn spheres_argument_errors() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("s.json");
    let o = out.to_str().unwrap();
    let (code, _, err) = run_text(
        &["spheres", "--mesh", "/nonexistent/m.obj", "--count", "4", "--out", o],
        "",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("/nonexistent/m.obj"), "{err}");
    let (code, _, _) = run_text(&["spheres", "--mesh", "x.obj", "--count", "0", "--out", o], "");
    assert_eq!(code, Some(2));
    let (code, _, _) = run_text(
        &[
            "spheres", "--mesh", "x.obj", "--count", "4", "--method", "octopus", "--out", o,
        ],
        "",
    );
    assert_eq!(code, Some(2));
    let garbage = d.path().join("g.obj");
    std::fs::write(&garbage, b"\x00\xff not an obj \x01\nf 1 2 3\n").unwrap();
    let (code, _, err) = run_text(
        &[
            "spheres",
            "--mesh",
            garbage.to_str().unwrap(),
            "--count",
            "4",
            "--out",
            o,
        ],
        "",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("g.obj"), "{err}");
    let open = d.path().join("open.obj");
    std::fs::write(&open, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n").unwrap();
    let (code, _, err) = run_text(
        &["spheres", "--mesh", open.to_str().unwrap(), "--count", "4", "--out", o],
        "",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("open.obj") && err.contains("closed"), "{err}");
    assert!(!out.exists());
}

/// Renders the bunny scene `scene` with `pipeline` at `width` px, 16 spp and the
/// breakdown on every `stride`-th pixel; asserts success and returns stdout and the
/// RMS of each "sphere sets → true meshes" breakdown row.
fn proxy_rows(pipeline: &str, scene: &str, width: &str, stride: &str) -> (String, Vec<f64>) {
    let d = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = run_text(
        &[
            "render",
            pipeline,
            "--scene",
            scene,
            "--width",
            width,
            "--spp",
            "16",
            "--breakdown-stride",
            stride,
            "--out",
            d.path().to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    // Each proxy row is followed by its split on and off the meshes.
    let splits = stdout
        .lines()
        .filter(|l| l.contains("sphere sets → true meshes, split: on the meshes RMS "))
        .count();
    assert!(splits >= 1, "{stdout}");
    let rms = stdout
        .lines()
        .filter(|l| l.contains("sphere sets → true meshes") && !l.contains(", split:"))
        .map(|row| {
            let v = row.split("RMS ").nth(1).and_then(|r| r.split(',').next());
            v.and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("no RMS in {row}"))
        })
        .collect();
    (stdout, rms)
}

/// `render isg` on the bunny scene: the summary names the mesh and its proxy, and the
/// error breakdown has the sphere sets → true meshes row, not zero (the proxy's error
/// measured there is 0.03–0.11 of the mean at 160 px: docs/meshes.md).
#[test]
fn render_isg_breaks_down_the_proxy_error() {
    let (stdout, rows) = proxy_rows("isg", "assets/meshes/isg-bunny.json", "32", "2");
    assert!(
        stdout.contains("19048 triangles, shaded with 64 proxy spheres"),
        "{stdout}"
    );
    assert_eq!(rows.len(), 1, "{stdout}");
    assert!(rows[0] > 1e-3 && rows[0] < 0.5, "{stdout}");
}

/// `render meunier` on the bunny under Figure 13's light: the lobes on the bunny's
/// sphere set (plane points buried in a covering sphere are in its full shadow, not an
/// error), the breakdown's last stage the sphere set → the true triangles, not zero
/// (0.19 of the mean at 64 px: docs/meshes.md).
#[test]
fn render_meunier_breaks_down_the_proxy_error() {
    let (stdout, rows) = proxy_rows("meunier", "assets/meshes/meunier-bunny.json", "32", "3");
    assert_eq!(rows.len(), 2, "{stdout}");
    for rms in rows {
        assert!(rms > 1e-3 && rms < 1.0, "{stdout}");
    }
}

/// `render shexp` on the bunny under the whale's sky: the pipeline on the bunny's
/// sphere set, the breakdown's SH-ideal on the sets, then on the triangles (the proxy's
/// row, not zero: 0.031 of the mean at 48 px).
#[test]
fn render_shexp_breaks_down_the_proxy_error() {
    let (stdout, rows) = proxy_rows("shexp", "assets/meshes/shexp-bunny.json", "24", "2");
    assert_eq!(rows.len(), 1, "{stdout}");
    assert!(rows[0] > 1e-3 && rows[0] < 0.5, "{stdout}");
    assert!(stdout.contains("(→ SH-ideal on the sphere sets)"), "{stdout}");
}

/// `eval isg-shade` on a scene with a mesh: the pipeline sees the bunny through its
/// sphere set, `--exact` through its triangles. On the bunny's top (its own spheres
/// skipped: buried in them otherwise, and 0) and on the ground in its sun shadow (the
/// sun SG holds most of the light), the two agree within the proxy's error; far from
/// the bunny both give the unoccluded ground. A point inside the bunny is refused.
#[test]
fn eval_isg_shade_sees_meshes_through_their_sphere_sets() {
    use lobefit::pipelines::scene::{load_for, Accepts};
    use lobefit_tables::glam::DVec3;
    let d = tempfile::tempdir().unwrap();
    std::fs::copy("assets/meshes/bunny.obj", d.path().join("bunny.obj")).unwrap();
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("assets/meshes/isg-bunny.json").unwrap()).unwrap();
    scene["brdf"] = serde_json::json!({"lambert": {"albedo": 0.6}});
    scene["meshes"][0]["spheres"]["count"] = 16.into();
    let path = d.path().join("bunny-eval.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let path = path.to_str().unwrap();
    let loaded = load_for(path, &Accepts::ALL).unwrap();
    let mesh = &loaded.meshes[0].mesh;
    let (lo, hi) = mesh.bounds();
    // The triangle facing most nearly up, and the sun's axis (the sharpest SG).
    let top = (0..mesh.triangles.len())
        .max_by(|&a, &b| mesh.normal(a).z.total_cmp(&mesh.normal(b).z))
        .unwrap();
    let on_top = mesh.corners(top).iter().sum::<DVec3>() / 3.0;
    let n_top = mesh.normal(top);
    let sun = loaded
        .environment
        .iter()
        .max_by(|a, b| a.sharpness.total_cmp(&b.sharpness))
        .unwrap()
        .axis;
    let mid = 0.5 * (lo + hi);
    let shadow = mid - sun * (mid.z / sun.z);
    let far = DVec3::new(hi.x + 3.0, lo.y - 3.0, 0.0);
    let row = |p: DVec3, n: DVec3| {
        format!(
            "{},{},{},{},{},{},{},{},{}\n",
            p.x, p.y, p.z, n.x, n.y, n.z, n.x, n.y, n.z
        )
    };
    let input = format!(
        "px,py,pz,nx,ny,nz,vx,vy,vz\n{}{}{}",
        row(on_top, n_top),
        row(shadow, DVec3::Z),
        row(far, DVec3::Z)
    );
    let eval = |exact: bool| -> Vec<f64> {
        let args = ["eval", "isg-shade", "--scene", path];
        let (code, stdout, stderr) = run_text(&[&args[..], if exact { &["--exact"] } else { &[] }].concat(), &input);
        assert_eq!(code, Some(0), "{stderr}");
        crate::common::last_column(&stdout)
    };
    let (isg, exact) = (eval(false), eval(true));
    println!("top, shadow, far: isg {isg:?}, exact {exact:?}");
    let unoccluded = exact[2];
    assert!(
        unoccluded > 0.0 && (isg[2] - unoccluded).abs() < 0.01 * unoccluded,
        "{isg:?} {exact:?}"
    );
    assert!(
        isg[0] > 0.3 * unoccluded,
        "the top is lit, not buried in its own spheres: {isg:?}"
    );
    assert!((isg[0] - exact[0]).abs() < 0.1 * exact[0], "{isg:?} {exact:?}");
    assert!(
        exact[1] < 0.5 * unoccluded,
        "the shadow point is in the sun's shadow: {exact:?}"
    );
    assert!((isg[1] - exact[1]).abs() < 0.25 * unoccluded, "{isg:?} {exact:?}");
    // Inside the bunny (its bounding box's centre, checked inside first).
    assert!(mesh.inside(mid) && mesh.distance(mid) > 0.0);
    let (code, stdout, stderr) = run_text(
        &["eval", "isg-shade", "--scene", path],
        &format!("px,py,pz,nx,ny,nz,vx,vy,vz\n{}", row(mid, DVec3::Z)),
    );
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stderr.contains("inside it"), "{stderr}");
}

/// `eval direct-light --scene` sees a mesh as `render meunier` does: through its
/// sphere set in the lobe pipeline, through its true triangles in `--exact`. Under the
/// bunny scene's sphere light: on the bunny's top (its own spheres skipped: buried in
/// them otherwise, and 0) the two agree closely; on the ground straight under the
/// bunny from the light (its umbra through the triangles) both are dark; far from
/// the bunny both give the unoccluded ground. A point inside the bunny is refused.
#[test]
fn eval_direct_light_sees_meshes_through_their_sphere_sets() {
    use lobefit::pipelines::scene::{load_for, Accepts};
    use lobefit_tables::glam::DVec3;
    let d = tempfile::tempdir().unwrap();
    std::fs::copy("assets/meshes/bunny.obj", d.path().join("bunny.obj")).unwrap();
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("assets/meshes/meunier-bunny.json").unwrap()).unwrap();
    scene["brdf"] = serde_json::json!({"lambert": {"albedo": 0.6}});
    scene["meshes"][0]["spheres"]["count"] = 16.into();
    let path = d.path().join("bunny-eval.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let path = path.to_str().unwrap();
    let loaded = load_for(path, &Accepts::ALL).unwrap();
    let mesh = &loaded.meshes[0].mesh;
    let (lo, hi) = mesh.bounds();
    let top = (0..mesh.triangles.len())
        .max_by(|&a, &b| mesh.normal(a).z.total_cmp(&mesh.normal(b).z))
        .unwrap();
    let on_top = mesh.corners(top).iter().sum::<DVec3>() / 3.0;
    let n_top = mesh.normal(top);
    let light = loaded.lights[0].sphere.centre;
    let mid = 0.5 * (lo + hi);
    // The ground point on the line from the light's centre through the bunny's middle.
    let shadow = light + (mid - light) * (light.z / (light.z - mid.z));
    let far = DVec3::new(hi.x + 3.0, lo.y - 3.0, 0.0);
    let row = |p: DVec3, n: DVec3| {
        format!(
            "{},{},{},{},{},{},{},{},{}\n",
            p.x, p.y, p.z, n.x, n.y, n.z, n.x, n.y, n.z
        )
    };
    let input = format!(
        "px,py,pz,nx,ny,nz,vx,vy,vz\n{}{}{}",
        row(on_top, n_top),
        row(shadow, DVec3::Z),
        row(far, DVec3::Z)
    );
    let eval = |exact: bool| -> Vec<f64> {
        let args = ["eval", "direct-light", "--scene", path];
        let (code, stdout, stderr) = run_text(&[&args[..], if exact { &["--exact"] } else { &[] }].concat(), &input);
        assert_eq!(code, Some(0), "{stderr}");
        assert!(stdout.starts_with("px,"), "{stdout}");
        crate::common::last_column(&stdout)
    };
    let (lobes, exact) = (eval(false), eval(true));
    println!("top, shadow, far: lobes {lobes:?}, exact {exact:?}");
    let unoccluded = exact[2];
    assert!(
        unoccluded > 0.0 && (lobes[2] - unoccluded).abs() < 0.01 * unoccluded,
        "{lobes:?} {exact:?}"
    );
    assert!(
        lobes[0] > 0.3 * unoccluded,
        "the top is lit, not buried in its own spheres: {lobes:?}"
    );
    assert!((lobes[0] - exact[0]).abs() < 0.1 * exact[0], "{lobes:?} {exact:?}");
    assert!(
        exact[1] < 0.2 * unoccluded && lobes[1] < 0.2 * unoccluded,
        "the point under the bunny is in its shadow: {lobes:?} {exact:?}"
    );
    assert!(mesh.inside(mid) && mesh.distance(mid) > 0.0);
    let (code, stdout, stderr) = run_text(
        &["eval", "direct-light", "--scene", path],
        &format!("px,py,pz,nx,ny,nz,vx,vy,vz\n{}", row(mid, DVec3::Z)),
    );
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stderr.contains("inside it"), "{stderr}");
    // A scene without the top-level brdf, or without a light, is refused by name (the
    // flags' view, exit 2; the scene file's loader, exit 1).
    for (edit, code_want, want) in [("brdf", 2, "needs the top-level brdf"), ("lights", 1, "no lights")] {
        let mut bad = scene.clone();
        bad.as_object_mut().unwrap().remove(edit);
        let p = d.path().join(format!("no-{edit}.json"));
        std::fs::write(&p, bad.to_string()).unwrap();
        let (code, _, stderr) = run_text(&["eval", "direct-light", "--scene", p.to_str().unwrap()], &input);
        assert_eq!(code, Some(code_want), "{edit}: {stderr}");
        assert!(stderr.contains(want), "{edit}: {stderr}");
    }
}

/// The lobe pipeline never answers a negative radiance: under a glossy Lafortune BRDF,
/// at a ground point beside the bunny (16 k-means spheres) where the shadow leaves'
/// lobes overshoot the unoccluded light, the sum was −1.15e-3 (the exact value there
/// is 0.0235); it is clamped to 0, and so is every point of a seeded sweep.
#[test]
fn eval_direct_light_never_answers_negative_radiance() {
    let d = tempfile::tempdir().unwrap();
    std::fs::copy("assets/meshes/bunny.obj", d.path().join("bunny.obj")).unwrap();
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("assets/meshes/meunier-bunny.json").unwrap()).unwrap();
    scene["brdf"] = serde_json::json!({"lafortune": {"albedo": 0.5, "lobes": [
        {"c": [-1.0, -1.0, 1.0], "exponent": 20.0, "specular": 0.5}]}});
    scene["meshes"][0]["spheres"]["count"] = 16.into();
    let path = d.path().join("glossy-bunny.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let mut rng = lobefit::rng::Rng::new(11);
    let mut input =
        String::from("px,py,pz,nx,ny,nz,vx,vy,vz\n-1.2032299283599617,-1.3283451947665181,0,0,0,1,0.6,0,0.8\n");
    for _ in 0..60 {
        let (x, y) = (rng.range(-2.5, 2.5), rng.range(-2.5, 2.5));
        input.push_str(&format!("{x},{y},0,0,0,1,0.6,0,0.8\n"));
    }
    let (code, stdout, stderr) = run_text(&["eval", "direct-light", "--scene", path.to_str().unwrap()], &input);
    assert_eq!(code, Some(0), "{stderr}");
    let v = crate::common::last_column(&stdout);
    assert_eq!(v.len(), 61);
    assert!(v.iter().all(|&r| r >= 0.0), "{v:?}");
    assert_eq!(v[0], 0.0, "the overshooting point clamps to 0");
}

/// `lobefit spheres --method optimize` (the default) on the bunny at 64 spheres meets
/// the fit's targets against the sampled quality (its own, independent samples):
/// volume error ≤ 0.10 with the mesh → spheres Hausdorff distance ≤ 0.05 of the
/// diagonal; with `--max-overlap 1.2` the overlap stays within 1.2 (to the sampling's
/// 1 %) at a volume error ≤ 0.15. Measured: 0.084 / 0.027; 0.136 at overlap 1.19
/// (kmeans: 0.41).
#[test]
fn optimize_fits_the_bunny_at_the_targets() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("s.json");
    let o = out.to_str().unwrap();
    for (extra, max_error, max_overlap) in [
        (&[][..], 0.10, f64::INFINITY),
        (&["--max-overlap", "1.2"][..], 0.15, 1.21),
    ] {
        let mut args = vec![
            "spheres",
            "--mesh",
            "assets/meshes/bunny.obj",
            "--count",
            "64",
            "--out",
            o,
        ];
        args.extend_from_slice(extra);
        let (code, stdout, stderr) = run_text(&args, "");
        assert_eq!(code, Some(0), "{stderr}");
        assert!(stdout.contains("(optimize, seed 0)"), "{stdout}");
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
        let q = &v["quality"];
        let f = |k: &str| q[k].as_f64().unwrap();
        assert!(f("volume_error") <= max_error, "{extra:?}: {q}");
        assert!(f("hausdorff_mesh_to_spheres") <= 0.05 * f("diagonal"), "{extra:?}: {q}");
        assert!(f("overlap") <= max_overlap, "{extra:?}: {q}");
    }
    let (code, _, err) = run_text(
        &[
            "spheres",
            "--mesh",
            "assets/meshes/bunny.obj",
            "--count",
            "8",
            "--method",
            "kmeans",
            "--max-overlap",
            "1.2",
            "--out",
            o,
        ],
        "",
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--max-overlap needs --method optimize"), "{err}");
}

/// A mesh shadows itself through its sphere set: points on the torus knot's tube
/// (assets/meshes/knot.obj, 64 optimized spheres) under a sky of broad SGs, the ISG
/// pipeline against `--exact` on the true triangles. Before, a mesh point skipped its
/// whole set: every point came out unshadowed (26 % median error on the knot under
/// fig12's sky). Now every point is within 15 % of its unoccluded radiance and the
/// median within 3 % (the targets), with several points well in shadow.
#[test]
#[ignore = "heavy: --exact on the triangles at 16 points (30 s); .ci/run's heavy tests run it"]
fn a_mesh_shadows_itself_through_its_set() {
    use lobefit::pipelines::mesh::Mesh;
    let d = tempfile::tempdir().unwrap();
    std::fs::copy("assets/meshes/knot.obj", d.path().join("knot.obj")).unwrap();
    let sky = serde_json::json!({"sgs": [
        {"axis": [0.3, 0.2, 0.93], "sharpness": 6, "amplitude": 2},
        {"axis": [-0.6, 0.3, 0.74], "sharpness": 3, "amplitude": 1},
        {"axis": [0, 0, 1], "sharpness": 1, "amplitude": 0.5}]});
    let scene = |meshes: serde_json::Value| serde_json::json!({"version": 2, "environment": sky, "brdf": {"lambert": {"albedo": 0.8}}, "meshes": meshes});
    let with = d.path().join("knot.json");
    let knot =
        serde_json::json!([{"file": "knot.obj", "material": {"lambert": {"albedo": 0.8}}, "spheres": {"count": 64}}]);
    std::fs::write(&with, scene(knot).to_string()).unwrap();
    let open = d.path().join("open.json");
    let mut o = scene(serde_json::json!([]));
    o["version"] = 1.into();
    o.as_object_mut().unwrap().remove("meshes");
    std::fs::write(&open, o.to_string()).unwrap();
    // 16 triangles' centroids, evenly through the file, facing up a little at least.
    let mesh = Mesh::load(std::path::Path::new("assets/meshes/knot.obj")).unwrap();
    let mut rows = String::from("px,py,pz,nx,ny,nz,vx,vy,vz\n");
    let mut k = 0;
    let mut taken = 0;
    while taken < 16 {
        let [a, b, c] = mesh.corners(k);
        let n = mesh.normal(k);
        k += 467;
        k %= mesh.triangles.len();
        if n.z < 0.2 {
            continue;
        }
        let p = (a + b + c) / 3.0;
        rows.push_str(&format!(
            "{},{},{},{},{},{},{},{},{}\n",
            p.x, p.y, p.z, n.x, n.y, n.z, n.x, n.y, n.z
        ));
        taken += 1;
    }
    let eval = |scene: &std::path::Path, exact: bool| {
        let mut args = vec!["eval", "isg-shade", "--scene", scene.to_str().unwrap()];
        if exact {
            args.push("--exact");
        }
        let (code, stdout, stderr) = run_text(&args, &rows);
        assert_eq!(code, Some(0), "{stderr}");
        crate::common::last_column(&stdout)
    };
    let (isg, exact, unoccluded) = (eval(&with, false), eval(&with, true), eval(&open, false));
    let mut err: Vec<f64> = isg
        .iter()
        .zip(&exact)
        .zip(&unoccluded)
        .map(|((a, b), u)| (a - b).abs() / u)
        .collect();
    let shadowed = exact.iter().zip(&unoccluded).filter(|(e, u)| **e < 0.8 * **u).count();
    println!("isg {isg:?}\nexact {exact:?}\nunoccluded {unoccluded:?}");
    err.sort_by(f64::total_cmp);
    assert!(shadowed >= 4, "{shadowed} points in shadow");
    assert!(
        err[err.len() - 1] <= 0.15 && err[err.len() / 2] <= 0.03,
        "errors / unoccluded {err:?}"
    );
}

/// SH exponentiation refused the bunny's 256-sphere k-means set (the overlaps push its
/// mean visibility past 1.25); the overlap-limited optimize set (`max_overlap` 1.2)
/// renders.
#[test]
#[ignore = "heavy: a 256-sphere fit and a render (10 s); .ci/run's heavy tests run it"]
fn shexp_renders_the_overlap_limited_bunny() {
    let d = tempfile::tempdir().unwrap();
    std::fs::copy("assets/meshes/bunny.obj", d.path().join("bunny.obj")).unwrap();
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("assets/meshes/shexp-bunny.json").unwrap()).unwrap();
    scene["meshes"][0]["spheres"] = serde_json::json!({"count": 256, "method": "optimize", "max_overlap": 1.2});
    let p = d.path().join("bunny256.json");
    std::fs::write(&p, scene.to_string()).unwrap();
    let out = d.path().join("out");
    let args = [
        "render",
        "shexp",
        "--scene",
        p.to_str().unwrap(),
        "--width",
        "16",
        "--spp",
        "16",
        "--out",
        out.to_str().unwrap(),
    ];
    let (code, stdout, stderr) = run_text(&args, "");
    assert_eq!(code, Some(0), "{stderr}");
    crate::common::assert_summary_last(&stdout, "shexp bunny256 16×12");
    scene["meshes"][0]["spheres"] = serde_json::json!({"count": 256, "method": "kmeans", "seed": 1});
    std::fs::write(&p, scene.to_string()).unwrap();
    let (code, _, stderr) = run_text(&args, "");
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("too many overlapping"), "{stderr}");
}

/// `render isg --frames 2` on the skinned, walking mannequin: both frames render (the
/// mesh posed by its glTF skin, its sphere set carried), the method's error against
/// the reference on the true triangles is finite and below 0.1 in both (0.005–0.008
/// measured at 64 px: docs/meshes.md), and the frames differ (the walk moves it). A
/// skin asked of an OBJ file, an animation the file does not have, or a key the skin
/// does not take is an error naming the field.
#[test]
fn render_isg_animates_the_skinned_walker() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().to_str().unwrap();
    let args = [
        "render",
        "isg",
        "--scene",
        "assets/meshes/isg-walker.json",
        "--frames",
        "2",
    ];
    let (code, stdout, err) = run_text(
        &[&args[..], &["--width", "16", "--spp", "64", "--out", out]].concat(),
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(
        stdout.contains("shaded with 64 proxy spheres") || stdout.contains("walker: frame 1"),
        "{stdout}"
    );
    let (csv, rows) = crate::common::frames_csv(&d.path().join("isg-walker-frames.csv"));
    assert_eq!(rows.len(), 2, "{csv}");
    assert!(rows.iter().all(|r| r[2].is_finite() && r[2] < 0.1), "{csv}");
    let frame = |k: usize| std::fs::read(d.path().join(format!("isg-walker-frame-{k:03}.png"))).unwrap();
    assert_ne!(frame(0), frame(1));
    let scene = std::fs::read_to_string("assets/meshes/isg-walker.json").unwrap();
    for (from, to, want) in [
        ("\"walker.gltf\"", "\"bunny.obj\"", "meshes[0].skin"),
        (
            "\"animation\": \"walk\"",
            "\"animation\": \"run\"",
            "no animation named \"run\"",
        ),
        (
            "\"animation\": \"walk\"",
            "\"animation\": \"walk\", \"speed\": 2",
            "unknown field `speed`",
        ),
    ] {
        let bad = d.path().join("bad.json");
        std::fs::write(&bad, scene.replace(from, to)).unwrap();
        for f in ["walker.gltf", "bunny.obj"] {
            std::fs::copy(format!("assets/meshes/{f}"), d.path().join(f)).unwrap();
        }
        let (code, _, err) = run_text(&["render", "isg", "--scene", bad.to_str().unwrap(), "--out", out], "");
        assert_eq!(code, Some(1), "{err}");
        assert!(err.contains(want), "{want}: {err}");
    }
}
