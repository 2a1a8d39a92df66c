//! `lobefit-gpu` on a closed stdout pipe: a clean error (exit 2, one `error:` line),
//! never a panic. Without a Vulkan adapter it stops earlier, also with exit 2.

use std::process::{Command, Stdio};

#[test]
fn closed_stdout_pipe_is_an_error_not_a_panic() {
    let dir = std::env::temp_dir().join(format!("lobefit-gpu-closed-pipe-{}", std::process::id()));
    let opts = lobefit::export::run::ExportOptions {
        only: vec!["cap-exponent".into()],
        format: lobefit::export::Format::Raw,
        storage: lobefit::export::Storage::F32,
        scale: 1.0,
        allow_lossy: false,
    };
    lobefit::export::run::export(&opts, &dir).unwrap();
    for cmd in ["gpu-check", "cost"] {
        let (reader, writer) = std::io::pipe().expect("pipe");
        drop(reader);
        let out = Command::new(env!("CARGO_BIN_EXE_lobefit-gpu"))
            .args([cmd, "--export", dir.to_str().unwrap()])
            .stdin(Stdio::null())
            .stdout(Stdio::from(writer))
            .stderr(Stdio::piped())
            .output()
            .expect("spawn lobefit-gpu");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {err}");
        assert!(!err.contains("panicked"), "{cmd}: {err}");
        let last = err.lines().last().unwrap_or("");
        assert!(last.starts_with("error: "), "{cmd}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
