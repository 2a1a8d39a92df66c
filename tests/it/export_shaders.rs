//! `lobefit export --shaders`: the shader library written as WGSL, GLSL and HLSL.

use crate::common;

#[test]
fn cli_writes_the_shader_library_in_every_language() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let (code, stdout, stderr) = common::run_text(&["export", "--shaders", "wgsl,glsl,hlsl", "--out", out], "");
    assert_eq!(code, Some(0), "{stderr}");
    for f in ["lobefit.wgsl", "lobefit.glsl", "lobefit.es.glsl", "lobefit.hlsl"] {
        assert!(stdout.contains(f), "{stdout}");
    }
    // Shaders only: no textures, no manifest.
    assert!(!dir.path().join("manifest.json").exists());
    let wgsl = std::fs::read_to_string(dir.path().join("lobefit.wgsl")).unwrap();
    assert!(wgsl.ends_with(&lobefit::tables::shaders::library()));
    lobefit::export::shaders::module_of(&wgsl).expect("the written WGSL parses and validates");
    for f in ["lobefit.glsl", "lobefit.es.glsl"] {
        let g = std::fs::read_to_string(dir.path().join(f)).unwrap();
        assert!(
            !g.lines().any(|l| l.starts_with("#version")) && !g.contains("void main()"),
            "{f}"
        );
        assert!(g.contains("float lf_cap_exponent("), "{f}");
    }
    let es = std::fs::read_to_string(dir.path().join("lobefit.es.glsl")).unwrap();
    assert!(es.contains("precision highp sampler2D;"));
    let h = std::fs::read_to_string(dir.path().join("lobefit.hlsl")).unwrap();
    assert!(h.contains("lf_wrap_lambda_hat(") && !h.contains("lf_library_stub"));
}

#[test]
fn bad_shader_requests_are_specific_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let (code, _, stderr) = common::run_text(&["export", "--shaders", "msl", "--out", out], "");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("msl"), "{stderr}");
    // Neither textures nor shaders requested.
    let (code, _, stderr) = common::run_text(&["export", "--out", out], "");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("--format"), "{stderr}");
}

/// `lobefit_tables::uniform::LfTex` is the WGSL struct `LfTex`, member for member: the
/// Rust field offsets (`repr(C)`) and size equal those naga lays out for the uniform.
#[test]
fn the_rust_uniform_has_the_wgsl_layout() {
    use lobefit_tables::uniform::{LfTex, LF_TEX_SIZE};
    use std::mem::{offset_of, size_of};
    let (module, _) = lobefit::export::shaders::module().unwrap();
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let (h, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some("LfTex"))
        .unwrap();
    assert_eq!(layouter[h].size as usize, LF_TEX_SIZE);
    assert_eq!(size_of::<LfTex>(), LF_TEX_SIZE);
    let naga::TypeInner::Struct { members, .. } = &ty.inner else {
        panic!("LfTex is not a struct")
    };
    let wgsl: Vec<(String, usize)> = members
        .iter()
        .map(|m| (m.name.clone().unwrap(), m.offset as usize))
        .collect();
    let rust = [
        ("axis", offset_of!(LfTex, axis)),
        ("map", offset_of!(LfTex, map)),
        ("offset", offset_of!(LfTex, offset)),
        ("scale", offset_of!(LfTex, scale)),
        ("trend", offset_of!(LfTex, trend)),
        ("decode", offset_of!(LfTex, decode)),
        ("mode", offset_of!(LfTex, mode)),
    ];
    assert_eq!(wgsl.len(), rust.len());
    for ((wn, wo), (rn, ro)) in wgsl.iter().zip(rust) {
        assert_eq!((wn.as_str(), *wo), (rn, ro));
    }
}
