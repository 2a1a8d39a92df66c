//! End-to-end tests of the binary's I/O edges: a closed or full stdout, table
//! paths that are not regular files or are too large, and resource bounds.

mod common;

use std::io::Write;
use std::process::{Output, Stdio};

use common::{bin, text};

const TABLE: &str = "tables/data/lobe-product.lobefit";

/// Every subcommand (and help) that prints to stdout, with its stdin.
fn printing_commands(plots: &str) -> Vec<(Vec<&str>, &'static str)> {
    vec![
        (vec!["inspect", TABLE], ""),
        (vec!["inspect", "--json", TABLE], ""),
        (vec!["check", "--quick", "--only", "lobe-integral"], ""),
        (vec!["check", "--quick", "--json", "--only", "lobe-integral"], ""),
        (vec!["eval", "cap-exponent"], "alpha\n0.1\n0.2\n"),
        (vec!["plot", "log-zh", "--out", plots], ""),
        (vec!["--help"], ""),
        (vec!["--version"], ""),
    ]
}

/// Runs `lobefit ARGS` with stdout on `stdout`, feeding `stdin`.
fn run_with_stdout(args: &[&str], stdin: &str, stdout: Stdio) -> Output {
    let mut child = bin()
        .args(args)
        .stdin(Stdio::piped())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn lobefit");
    let mut pipe = child.stdin.take().expect("stdin");
    let _ = pipe.write_all(stdin.as_bytes());
    drop(pipe);
    child.wait_with_output().expect("wait")
}

/// Exit 1 and exactly one line on stderr, the error naming the failed write.
fn assert_clean_io_failure(args: &[&str], out: &Output, cause: &str) {
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    assert!(err.starts_with("error: ") && err.contains(cause), "{args:?}: {err}");
}

/// A pipe whose read end is already closed: the child's first write to it fails
/// with a broken pipe, whenever it comes.
fn closed_pipe() -> Stdio {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    Stdio::from(writer)
}

#[test]
fn closed_or_full_stdout_is_a_clean_error_for_every_printing_subcommand() {
    let plots = tempfile::tempdir().unwrap();
    for (args, stdin) in printing_commands(plots.path().to_str().unwrap()) {
        let out = run_with_stdout(&args, stdin, closed_pipe());
        assert_clean_io_failure(&args, &out, "Broken pipe");
        #[cfg(target_os = "linux")]
        {
            let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
            let out = run_with_stdout(&args, stdin, Stdio::from(full));
            assert_clean_io_failure(&args, &out, "No space left on device");
        }
    }
}
