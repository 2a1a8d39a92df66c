//! `lobefit-gpu gpu-check` runs `lobefit check --export` before it reads anything
//! else: a manifest naming a uniforms file outside the export (which gpu-check would
//! read) is refused, naming the field, before a device is opened.

use std::process::{Command, Stdio};

use lobefit::export::manifest::MANIFEST;
use lobefit::export::run::{export, ExportOptions};
use lobefit::export::{Format, Storage};

#[test]
fn a_manifest_pointing_outside_the_export_is_refused_first() {
    let dir = tempfile::tempdir().unwrap();
    let opts = ExportOptions {
        only: vec!["cap-exponent".into()],
        format: Format::Ktx2,
        storage: Storage::F32,
        scale: 1.0,
        allow_lossy: false,
    };
    export(&opts, dir.path()).unwrap();
    let path = dir.path().join(MANIFEST);
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    v["uniforms_wgsl"] = "/etc/passwd".into();
    std::fs::write(&path, v.to_string()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_lobefit-gpu"))
        .args(["gpu-check", "--export", dir.path().to_str().unwrap()])
        .stdin(Stdio::null())
        .output()
        .expect("spawn lobefit-gpu");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("uniforms_wgsl") && err.contains("/etc/passwd"), "{err}");
    assert!(!err.contains("device"), "refused before a device is opened: {err}");
}
