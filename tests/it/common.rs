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

/// Asserts that `path` is a render's beauty image: a PNG (signature, then the IHDR
/// chunk read by hand: big-endian width and height, bit depth 8, colour type 2 = RGB)
/// of `width` × `height` pixels.
pub fn assert_beauty_png(path: &std::path::Path, width: u32, height: u32) {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        b.starts_with(b"\x89PNG\r\n\x1a\n") && &b[12..16] == b"IHDR",
        "{}",
        path.display()
    );
    let be = |o: usize| u32::from_be_bytes(b[o..o + 4].try_into().unwrap());
    assert_eq!(
        (be(16), be(20), b[24], b[25]),
        (width, height, 8, 2),
        "{}",
        path.display()
    );
}

/// Asserts that `path` is an OpenEXR file (its magic number 0x762f3101, little-endian).
pub fn assert_exr(path: &std::path::Path) {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(b.starts_with(&[0x76, 0x2f, 0x31, 0x01]), "{}", path.display());
}

/// Asserts that the last line of a render's stdout is its summary line for `render`
/// (`summary: isg fig12 …`), with a relative RMSE and the time ratio against the
/// strongest Monte Carlo measured at the method's error, with its spread (or a bound):
/// never the extrapolated plain estimator. (rigs: against every light per point; its
/// truth is exact, it has no Monte Carlo.)
pub fn assert_summary_last(stdout: &str, render: &str) {
    let last = stdout.lines().last().unwrap_or_default();
    if render.starts_with("rigs ") {
        assert!(
            last.starts_with(&format!("summary: {render} "))
                && last.contains("relative RMSE")
                && last.contains("time)"),
            "{last}"
        );
        return;
    }
    assert!(
        last.starts_with(&format!("summary: {render} "))
            && last.contains("relative RMSE")
            && last.contains("vs the strongest Monte Carlo, ")
            && last.contains("at the method's error on ")
            && (last.ends_with("])") || last.contains("(> "))
            && !last.contains("plain"),
        "{last}"
    );
}

/// Generous bound on a command that must end promptly; only a regression reaches it.
pub const NO_HANG: std::time::Duration = std::time::Duration::from_secs(120);

/// Runs `lobefit ARGS` (no stdin); kills it and fails the test if it is still
/// running after [`NO_HANG`].
pub fn run_bounded(args: &[&str]) -> (Option<i32>, String, String) {
    let mut child = bin()
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn lobefit");
    let start = std::time::Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > NO_HANG {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?} still running after {NO_HANG:?}");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("wait");
    (out.status.code(), text(&out.stdout), text(&out.stderr))
}

/// `mkfifo PATH`; false when the tool is unavailable.
pub fn mkfifo(path: &std::path::Path) -> bool {
    std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .is_ok_and(|s| s.success())
}

/// The last column of `eval`'s CSV output, one number a data row (the header skipped).
pub fn last_column(stdout: &str) -> Vec<f64> {
    stdout
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect()
}

/// An animation's `*-frames.csv`: its text, and its rows after the header as numbers.
pub fn frames_csv(path: &std::path::Path) -> (String, Vec<Vec<f64>>) {
    let csv = std::fs::read_to_string(path).unwrap();
    let rows = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (csv, rows)
}
