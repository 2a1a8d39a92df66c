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
