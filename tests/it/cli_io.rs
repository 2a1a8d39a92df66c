//! End-to-end tests of the binary's I/O edges: a closed or full stdout, table
//! paths that are not regular files or are too large, resource bounds, and numbers
//! in error messages.

use crate::common;
use std::process::{Output, Stdio};

use crate::common::{mkfifo, run_bounded, run_with_stdout, text};

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

#[test]
fn inspect_refuses_an_oversized_file_from_its_size() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("big.lobefit");
    let len = lobefit::tables::format::MAX_FILE_LEN * 6 / 5;
    std::fs::File::create(&p).unwrap().set_len(len).unwrap();
    let (code, _, err) = run_bounded(&["inspect", p.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(&format!("is {len} bytes, over the format's limit of 1073741824 bytes")),
        "{err}"
    );
}

#[cfg(unix)]
#[test]
fn inspect_refuses_a_device() {
    let (code, _, err) = run_bounded(&["inspect", "/dev/zero"]);
    assert_eq!(code, Some(1), "{err}");
    assert_eq!(
        err,
        "error: cannot read table file /dev/zero: it is a character device, not a regular file\n"
    );
}

#[cfg(unix)]
#[test]
fn inspect_check_and_eval_refuse_a_fifo_without_blocking() {
    let d = tempfile::tempdir().unwrap();
    let fifo = d.path().join("lobe-integral.lobefit");
    if !mkfifo(&fifo) {
        eprintln!("skipped: mkfifo is unavailable");
        return;
    }
    let needle = "it is a FIFO, not a regular file";
    let (code, _, err) = run_bounded(&["inspect", fifo.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains(needle), "{err}");
    let dir = d.path().to_str().unwrap();
    let (code, out, _) = run_bounded(&["check", "--quick", "--only", "lobe-integral", "--tables", dir]);
    assert_eq!(code, Some(1), "{out}");
    assert!(out.contains(needle), "{out}");
    let (code, _, err) = run_bounded(&["eval", "lobe-integral", "--table", fifo.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains(needle), "{err}");
}

/// `--threads` is bounded by 4 × the available cores (the child sees the same
/// cores as this test); the error names the bound.
#[test]
fn thread_count_above_four_per_core_is_refused() {
    let max = 4 * std::thread::available_parallelism().unwrap().get();
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().to_str().unwrap();
    for threads in [(max + 1).to_string(), "65535".to_string(), "0".to_string()] {
        for sub in [
            &["build-tables", "--only", "lobe-integral", "--out", dir][..],
            &["fit", "lobe-integral", "--out", dir],
        ] {
            let mut args = sub.to_vec();
            args.extend(["--threads", &threads]);
            let (code, _, err) = run_bounded(&args);
            assert_eq!(code, Some(2), "{args:?}: {err}");
            assert!(
                err.contains(&format!("from 1 to {max} (4 per available core")),
                "{args:?}: {err}"
            );
        }
    }
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0, "nothing is written");
}

/// An input line is never buffered past `eval::MAX_LINE_LEN` bytes.
#[test]
fn eval_refuses_an_overlong_line() {
    let long = format!("alpha\n0.1\n{}\n", "1".repeat(lobefit::eval::MAX_LINE_LEN as usize + 1));
    let (code, out, err) = common::run_text(&["eval", "cap-exponent"], &long);
    assert_eq!(code, Some(1), "{err}");
    assert!(out.is_empty(), "{out}");
    assert_eq!(err, "error: line 3: line longer than 1048576 bytes\n");
}

/// Out-of-domain values are echoed in short form (1e308 was a 382-character line),
/// through the runtime and through `--exact`.
#[test]
fn eval_errors_print_numbers_in_short_form() {
    for value in ["1e308", "5e-324", "-2.5e-300"] {
        for exact in [false, true] {
            let mut args = vec!["eval", "cap-exponent"];
            if exact {
                args.push("--exact");
            }
            let (code, out, err) = common::run_text(&args, &format!("alpha\n{value}\n"));
            assert_eq!(code, Some(1), "{err}");
            assert!(out.is_empty(), "{out}");
            assert!(
                err.starts_with(&format!("error: line 2: alpha = {value} is outside ")),
                "{err}"
            );
            assert!(err.len() < 100, "{} characters: {err}", err.len());
        }
    }
}
