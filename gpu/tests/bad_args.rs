//! `lobefit-gpu render-meunier` refuses bad settings with a specific error before it
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

#[test]
fn render_meunier_bad_settings_are_specific_errors() {
    let base = [
        "render-meunier",
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
