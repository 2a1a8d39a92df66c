//! Helpers shared by the integration tests (each test file includes it with
//! `mod common;` and uses what it needs).
#![allow(dead_code)]

use std::io::Write;
use std::process::{Command, Output, Stdio};

/// The `lobefit` binary, run from the repository root.
pub fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lobefit"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// Runs `lobefit ARGS` with `stdin` piped in and returns its output.
pub fn run(args: &[&str], stdin: &str) -> Output {
    run_with_stdout(args, stdin, Stdio::piped())
}

/// [`run`] with stdout on `stdout` (a closed pipe, /dev/full, …).
pub fn run_with_stdout(args: &[&str], stdin: &str, stdout: Stdio) -> Output {
    let mut child = bin()
        .args(args)
        .stdin(Stdio::piped())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn lobefit");
    let mut pipe = child.stdin.take().expect("stdin");
    // A process that refuses its arguments exits without reading: a broken pipe here
    // is expected, and what it printed is what the test checks.
    let _ = pipe.write_all(stdin.as_bytes());
    drop(pipe);
    child.wait_with_output().expect("wait")
}

/// Bytes as (lossy) UTF-8 text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// `run`, as (exit code, stdout, stderr).
pub fn run_text(args: &[&str], stdin: &str) -> (Option<i32>, String, String) {
    let o = run(args, stdin);
    (o.status.code(), text(&o.stdout), text(&o.stderr))
}
