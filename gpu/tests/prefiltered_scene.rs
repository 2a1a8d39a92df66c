//! `lobefit-gpu render isg` on a scene that names its map's Γ_L: the kernel shades the
//! specular term by eq. 9 from the prefiltered texture (`lf_prefiltered`) and matches
//! the CPU pipeline's eq. 9 from the table (`Specular::Eq9Prefiltered`) within the
//! render's limit; needs a Vulkan device (lavapipe in CI).

use std::process::{Command, Stdio};

use lobefit::export::run::{export, ExportOptions};
use lobefit::export::{Format, Storage};

#[test]
fn a_scene_with_its_maps_gamma_l_renders_by_eq9_on_the_device() {
    let d = tempfile::tempdir().unwrap();
    // A 16 × 8 Radiance map: one colour and a brighter texel (a small sun).
    let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n".to_vec();
    for k in 0..16 * 8 {
        f.extend(if k == 21 {
            [160u8, 120, 80, 133]
        } else {
            [128u8, 64, 32, 129]
        });
    }
    let map = d.path().join("spot.hdr");
    std::fs::write(&map, &f).unwrap();
    let env = lobefit::pipelines::envmap::EnvMap::load(&map).unwrap();
    let (table, _) = lobefit::pipelines::prefilter::build(&env, "spot.hdr").unwrap();
    let bytes = lobefit_tables::format::encode(table.meta(), table.values()).unwrap();
    std::fs::write(d.path().join("spot.lobefit"), bytes).unwrap();
    let scene = serde_json::json!({
        "version": 1,
        "camera": {"eye": [0.0, -5.0, 3.0], "target": [0.0, 0.0, 0.5], "fov": 0.7},
        "environment": {"map": "spot.hdr", "sgs": 4, "prefiltered": "spot.lobefit"},
        "spheres": [{"centre": [0, 0, 0.8], "radius": 0.8, "material": {"lafortune": {"albedo": 0.5,
            "lobes": [{"c": [-1.0, -1.0, 1.0], "exponent": 100.0, "specular": 0.4}]}}}],
        "planes": [{"normal": [0, 0, 1], "offset": 0.0, "tangent": [1, 0, 0], "half_extent": 3.0,
            "material": {"lambert": {"albedo": 0.7}}}]
    });
    let path = d.path().join("glossy.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let ex = d.path().join("export");
    let opts = ExportOptions {
        only: vec!["isg-best".into(), "sg-fit".into()],
        format: Format::Ktx2,
        storage: Storage::F32,
        scale: 1.0,
        allow_lossy: false,
    };
    export(&opts, &ex).unwrap();
    let png = d.path().join("glossy.png");
    let out = Command::new(env!("CARGO_BIN_EXE_lobefit-gpu"))
        .args([
            "render",
            "isg",
            "--export",
            ex.to_str().unwrap(),
            "--scene",
            path.to_str().unwrap(),
        ])
        .args(["--width", "16", "--out", png.to_str().unwrap()])
        .stdin(Stdio::null())
        .output()
        .expect("spawn lobefit-gpu");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("eq. 9 from the scene's Γ_L") && stdout.contains("RMS"),
        "{stdout}"
    );
    assert!(png.is_file());
}
