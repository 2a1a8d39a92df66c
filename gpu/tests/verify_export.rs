//! The GPU renders verify the export's textures they read before anything else needs
//! a device: one changed texel (a flipped isg-best bit, a lobe-product texel of 1e30)
//! is refused with the file named, while the intact export gets as far as the device.
//! Run with no Vulkan driver (`VK_ICD_FILENAMES` pointing nowhere), so the order is
//! what is tested.

use std::path::Path;
use std::process::{Command, Stdio};

fn export(dir: &Path, only: &[&str]) {
    let opts = lobefit::export::run::ExportOptions {
        only: only.iter().map(|s| s.to_string()).collect(),
        format: lobefit::export::Format::Raw,
        storage: lobefit::export::Storage::F32,
        scale: 1.0,
        allow_lossy: false,
    };
    lobefit::export::run::export(&opts, dir).unwrap();
}

/// `lobefit-gpu ARGS` without a Vulkan driver: (exit code, stderr).
fn run_without_device(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lobefit-gpu"))
        .args(args)
        .env("VK_ICD_FILENAMES", "/nonexistent-icd.json")
        .env("VK_DRIVER_FILES", "/nonexistent-icd.json")
        .stdin(Stdio::null())
        .output()
        .expect("spawn lobefit-gpu");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// A copy of `from` in `to` with texel `k` of `file` (raw f32) changed by `change`.
fn corrupt(from: &Path, to: &Path, file: &str, k: usize, change: impl Fn(f32) -> f32) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
    let path = to.join(file);
    let mut bytes = std::fs::read(&path).unwrap();
    let at = 4 * k;
    let v = f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    bytes[at..at + 4].copy_from_slice(&change(v).to_le_bytes());
    std::fs::write(&path, bytes).unwrap();
}

#[test]
fn renders_refuse_a_changed_texel_before_the_device() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x.png");
    let out = out.to_str().unwrap();
    for (only, file, k, change, command) in [
        (
            &["isg-best", "sg-fit"][..],
            "isg-best.bin",
            1000,
            (|v: f32| f32::from_bits(v.to_bits() ^ 1)) as fn(f32) -> f32,
            &["render", "isg", "--scene", "fig12"][..],
        ),
        (
            &["disk-light", "lobe-product"][..],
            "lobe-product.bin",
            777,
            |_| 1e30,
            &["render", "library"][..],
        ),
    ] {
        let good = tmp.path().join(format!("good-{file}"));
        export(&good, only);
        let bad = tmp.path().join(format!("bad-{file}"));
        corrupt(&good, &bad, file, k, change);
        for (dir, intact) in [(&bad, false), (&good, true)] {
            let args: Vec<&str> = command
                .iter()
                .copied()
                .chain(["--export", dir.to_str().unwrap(), "--out", out])
                .collect();
            let (code, err) = run_without_device(&args);
            assert_eq!(code, Some(2), "{args:?}: {err}");
            if intact {
                assert!(
                    err.contains("Vulkan"),
                    "{args:?}: the intact export reaches the device: {err}"
                );
            } else {
                assert!(
                    err.contains(&format!("{file} (1 texels) differs from a fresh export")),
                    "{args:?}: {err}"
                );
                assert!(!err.contains("Vulkan"), "{args:?}: verified before the device: {err}");
            }
        }
    }
    assert!(!Path::new(out).exists());
}
