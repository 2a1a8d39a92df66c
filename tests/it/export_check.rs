//! `check --export` holds every manifest field and every file of an export to what an
//! export of this lobefit's tables writes: one export (made once for these tests,
//! kept in memory), each test editing its own copy.

use crate::common;
use std::path::Path;
use std::sync::OnceLock;

use lobefit::export::manifest::{MANIFEST, MANIFEST_SCHEMA_FILE};
use lobefit::export::run::{check_export, export, ExportOptions};
use lobefit::export::{Format, Storage};
use serde_json::Value;

/// The files (name, bytes) of a raw f32 export of cap-exponent, exported once.
fn pristine() -> &'static [(String, Vec<u8>)] {
    static FILES: OnceLock<Vec<(String, Vec<u8>)>> = OnceLock::new();
    FILES.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let opts = ExportOptions {
            only: vec!["cap-exponent".into()],
            format: Format::Raw,
            storage: Storage::F32,
            scale: 1.0,
            allow_lossy: false,
        };
        export(&opts, dir.path()).unwrap();
        let mut files: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file())
            .map(|p| {
                let name = p.file_name().unwrap().to_string_lossy().into_owned();
                (name, std::fs::read(&p).unwrap())
            })
            .collect();
        files.sort();
        files
    })
}

/// A fresh copy of the export.
fn copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in pristine() {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}

/// Rewrites the copy's manifest through `f`.
fn edit(d: &Path, f: impl Fn(&mut Value)) {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(d.join(MANIFEST)).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(d.join(MANIFEST), serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

/// The error of `check --export` on `d` (a test failure where it passes).
fn refused(d: &Path) -> String {
    match check_export(d) {
        Err(e) => e,
        Ok(rows) => panic!(
            "check --export returned rows ({} failing): {rows:?}",
            rows.iter().filter(|r| !r.pass).count()
        ),
    }
}

/// The outputs of the failing rows of `check --export` on `d`.
fn failing(d: &Path) -> Vec<String> {
    check_export(d)
        .unwrap()
        .into_iter()
        .filter(|c| !c.pass)
        .map(|c| c.entry.output)
        .collect()
}

#[test]
fn an_unedited_copy_passes() {
    let dir = copy();
    let rows = check_export(dir.path()).unwrap();
    assert!(!rows.is_empty() && rows.iter().all(|c| c.pass), "{rows:?}");
}

/// The uniforms files the manifest names are the fixed names the exporter writes: a
/// path outside the export (which `lobefit-gpu gpu-check` would read after the check)
/// is refused, naming the field.
#[test]
fn uniforms_paths_outside_the_export_are_refused() {
    for (field, value) in [
        ("uniforms_header", "/etc/passwd"),
        ("uniforms_header", "../../x.h"),
        ("uniforms_wgsl", "/etc/passwd"),
        ("uniforms_wgsl", "../lobefit_uniforms.wgsl"),
    ] {
        let dir = copy();
        edit(dir.path(), |v| v[field] = value.into());
        let e = refused(dir.path());
        assert!(e.contains(field) && e.contains(value), "{field} = {value}: {e}");
    }
}

/// Every descriptive field is recomputed from the tables and compared: an edited
/// one is refused, the error naming its path.
#[test]
fn edited_manifest_fields_are_refused_naming_the_field() {
    type Edit = fn(&mut Value);
    let cases: [(&str, Edit); 9] = [
        ("closed_form[0]", |v| v["closed_form"][0][1] = "1".into()),
        ("closed_form has", |v| {
            v["closed_form"].as_array_mut().unwrap().pop();
        }),
        ("families[0].shader", |v| v["families"][0]["shader"] = "anything".into()),
        ("families[0].inputs[0]", |v| {
            v["families"][0]["inputs"][0] = "beta".into()
        }),
        ("families[0].textures[0].bytes", |v| {
            v["families"][0]["textures"][0]["bytes"] = 1.into()
        }),
        ("families[0].textures[0].axis_formulas[0]", |v| {
            v["families"][0]["textures"][0]["axis_formulas"][0] = "u = x".into()
        }),
        ("families[0].textures[0].channels[0].meaning", |v| {
            v["families"][0]["textures"][0]["channels"][0]["meaning"] = "?".into()
        }),
        ("convention", |v| v["convention"] = "texel corners".into()),
        ("families[0].textures[0].axes[0].axis.name", |v| {
            v["families"][0]["textures"][0]["axes"][0]["axis"]["name"] = "beta".into()
        }),
    ];
    for (field, f) in cases {
        let dir = copy();
        edit(dir.path(), f);
        let e = refused(dir.path());
        assert!(e.contains(field), "{field}: {e}");
    }
}

/// Unknown keys, at the top and in nested objects (the runtime crate's axis too).
#[test]
fn unknown_manifest_fields_are_refused() {
    type Edit = fn(&mut Value);
    let cases: [(&str, Edit); 5] = [
        ("extra", |v| v["extra"] = 1.into()),
        ("family_note", |v| v["families"][0]["family_note"] = "x".into()),
        ("srgb", |v| v["families"][0]["textures"][0]["srgb"] = true.into()),
        ("wrap", |v| {
            v["families"][0]["textures"][0]["axes"][0]["axis"]["wrap"] = "repeat".into()
        }),
        ("note", |v| v["families"][0]["error"][0]["note"] = "x".into()),
    ];
    for (key, f) in cases {
        let dir = copy();
        edit(dir.path(), f);
        let e = refused(dir.path());
        assert!(e.contains("unknown field") && e.contains(key), "{key}: {e}");
    }
}

/// `manifest.schema.json` is the exporter's, byte for byte; a deleted one is an error.
#[test]
fn the_schema_file_is_the_exporters() {
    let dir = copy();
    let schema = dir.path().join(MANIFEST_SCHEMA_FILE);
    let text = std::fs::read_to_string(&schema).unwrap();
    std::fs::write(&schema, text.replacen("\"integer\"", "\"number\"", 1)).unwrap();
    assert!(failing(dir.path()).contains(&MANIFEST_SCHEMA_FILE.to_string()));
    std::fs::remove_file(&schema).unwrap();
    let e = refused(dir.path());
    assert!(e.contains(MANIFEST_SCHEMA_FILE), "{e}");
}

/// A raw texture's JSON sidecar is compared byte for byte too (a reader that parses
/// it would accept a reformatted one).
#[test]
fn the_raw_sidecar_is_compared_byte_for_byte() {
    let dir = copy();
    let sidecar = dir.path().join("cap-exponent.json");
    let text = std::fs::read_to_string(&sidecar).unwrap();
    std::fs::write(&sidecar, format!("{text}\n")).unwrap();
    assert!(failing(dir.path()).contains(&"cap-exponent.json".to_string()));
}

/// Files the export does not write are listed as an error (the export lock excepted).
#[test]
fn extra_files_in_the_export_are_refused() {
    for extra in ["notes.txt", "sg-fit.bin", ".hidden"] {
        let dir = copy();
        std::fs::write(dir.path().join(".lobefit-export.lock"), b"").unwrap();
        std::fs::write(dir.path().join(extra), b"x").unwrap();
        let e = refused(dir.path());
        assert!(e.contains(&format!("{extra:?}")) && !e.contains("lock"), "{extra}: {e}");
    }
    let dir = copy();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let e = refused(dir.path());
    assert!(e.contains("\"sub\""), "{e}");
}

/// Every file the check opens is a regular file in the export: a symlink is refused
/// even where it points at identical bytes outside the export.
#[cfg(unix)]
#[test]
fn symlinked_files_are_refused() {
    for name in [
        "lobefit_baked.wgsl",
        "lobefit_uniforms.h",
        "lobefit_uniforms.wgsl",
        MANIFEST_SCHEMA_FILE,
        MANIFEST,
        "cap-exponent.json",
    ] {
        let dir = copy();
        let outside = tempfile::tempdir().unwrap();
        let target = outside.path().join(name);
        std::fs::rename(dir.path().join(name), &target).unwrap();
        std::os::unix::fs::symlink(&target, dir.path().join(name)).unwrap();
        let e = refused(dir.path());
        assert!(e.contains(name) && e.contains("symbolic link"), "{name}: {e}");
    }
}

/// Measurements are recomputed too: an edited value (even one within its promise),
/// and an entry the export does not measure, fail.
#[test]
fn measurements_must_equal_the_remeasured_ones() {
    let dir = copy();
    edit(dir.path(), |v| {
        let e = &mut v["families"][0]["error"][0];
        e["measured"] = (e["measured"].as_f64().unwrap() / 2.0).into();
    });
    assert!(!failing(dir.path()).is_empty());
    let dir = copy();
    edit(dir.path(), |v| {
        let errors = v["families"][0]["error"].as_array_mut().unwrap();
        let last = errors.last().unwrap().clone();
        errors.push(last);
    });
    let f = failing(dir.path());
    assert!(f.iter().any(|o| o.starts_with("error:")), "{f:?}");
}

/// `lobefit check --export` on a manifest naming a header outside the export: exit
/// 1, the field named.
#[test]
fn cli_check_export_refuses_a_manifest_pointing_outside() {
    let dir = copy();
    edit(dir.path(), |v| v["uniforms_header"] = "/etc/passwd".into());
    let (code, _, stderr) = common::run_text(&["check", "--export", dir.path().to_str().unwrap()], "");
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("uniforms_header"), "{stderr}");
}
