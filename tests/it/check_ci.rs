//! `check --baseline` and `check --junit`, as a downstream CI uses them: save a report,
//! then compare later checks with it.

use crate::common::run_text;
use lobefit_tables::{format, Table};

/// A copy of the committed cap-exponent table with one node's q moved by 1e-6
/// relative: 20× the committed table's grid error, 100× inside the 1e-4 promise.
fn degraded(dir: &std::path::Path) {
    let bytes = std::fs::read("tables/data/cap-exponent.lobefit").unwrap();
    let table = Table::from_bytes(&bytes).unwrap();
    let mut v = table.values().to_vec();
    v[500] *= 1.0 + 1e-6;
    std::fs::write(
        dir.join("cap-exponent.lobefit"),
        format::encode(table.meta(), &v).unwrap(),
    )
    .unwrap();
}

#[test]
fn a_degraded_table_passes_its_thresholds_but_fails_the_baseline() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("baseline.json");
    let tables = dir.path().join("tables");
    std::fs::create_dir(&tables).unwrap();
    degraded(&tables);
    let args = ["check", "--quick", "--only", "cap-exponent,lobe-integral"];

    // Save a report of the committed tables.
    let (code, json, err) = run_text(&[&args[..], &["--json"]].concat(), "");
    assert_eq!(code, Some(0), "{err}");
    std::fs::write(&base, &json).unwrap();
    std::fs::copy(
        "tables/data/lobe-integral.lobefit",
        tables.join("lobe-integral.lobefit"),
    )
    .unwrap();
    let t = tables.to_str().unwrap();
    let b = base.to_str().unwrap();

    // The committed tables against their own report: every metric equal.
    let junit_ok = dir.path().join("ok.xml");
    let (code, _, err) = run_text(
        &[&args[..], &["--baseline", b, "--junit", junit_ok.to_str().unwrap()]].concat(),
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("0 worse than 1.5×"), "{err}");
    let xml = std::fs::read_to_string(&junit_ok).unwrap();
    assert!(
        xml.starts_with("<?xml") && xml.contains("failures=\"0\"") && xml.contains("baseline ("),
        "{xml}"
    );

    // The degraded table passes its thresholds ...
    let (code, out, err) = run_text(&[&args[..], &["--tables", t]].concat(), "");
    assert_eq!(code, Some(0), "{out}{err}");

    // ... and fails the baseline, naming family, quantity and metric.
    let junit = dir.path().join("junit.xml");
    let (code, _, err) = run_text(
        &[
            &args[..],
            &["--tables", t, "--baseline", b, "--junit", junit.to_str().unwrap()],
        ]
        .concat(),
        "",
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("FAIL cap-exponent e_cap.grid.max_rel"), "{err}");
    assert!(!err.contains("FAIL lobe-integral"), "{err}");
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains("<testsuite name=\"cap-exponent\""), "{xml}");
    assert!(xml.contains("<failure message=\"e_cap.grid.max_rel"), "{xml}");

    // A looser factor lets it through; a factor below 1 is refused.
    let (code, _, err) = run_text(
        &[&args[..], &["--tables", t, "--baseline", b, "--baseline-factor", "100"]].concat(),
        "",
    );
    assert_eq!(code, Some(0), "{err}");
    let (code, _, err) = run_text(
        &[&args[..], &["--baseline", b, "--baseline-factor", "0.5"]].concat(),
        "",
    );
    // Refused by the argument parser, before the check runs: a usage error.
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("'0.5' for '--baseline-factor"), "{err}");
}

#[test]
fn an_incomparable_baseline_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("baseline.json");
    let (code, json, _) = run_text(&["check", "--quick", "--only", "lobe-integral", "--json"], "");
    assert_eq!(code, Some(0));
    std::fs::write(&base, &json).unwrap();
    let b = base.to_str().unwrap();
    // Another seed, another family, a file that is no report.
    let (code, _, err) = run_text(
        &[
            "check",
            "--quick",
            "--only",
            "lobe-integral",
            "--seed",
            "7",
            "--baseline",
            b,
        ],
        "",
    );
    assert_eq!(code, Some(1));
    assert!(
        err.contains("seed") && err.contains("same --quick/--points/--seed"),
        "{err}"
    );
    let (code, _, err) = run_text(&["check", "--quick", "--only", "wrap", "--baseline", b], "");
    assert_eq!(code, Some(1));
    assert!(err.contains("no report for wrap"), "{err}");
    std::fs::write(&base, "{}").unwrap();
    let (code, _, err) = run_text(&["check", "--quick", "--only", "wrap", "--baseline", b], "");
    assert_eq!(code, Some(1));
    assert!(err.contains("not a `lobefit check --json` report"), "{err}");
}

/// The corruptions an attack on the checker found, each of which `check` passed:
/// now `check --quick` fails on every one, naming the quantity.
#[test]
#[ignore = "heavy (seconds to tens of seconds each): .ci/run runs the ignored tests"]
fn the_corruptions_that_once_passed_fail_the_quick_check() {
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().to_str().unwrap();
    let write = |kind: &str, change: &dyn Fn(&Table, &mut Vec<f32>)| {
        let table = Table::from_bytes(&std::fs::read(format!("tables/data/{kind}.lobefit")).unwrap()).unwrap();
        let mut v = table.values().to_vec();
        change(&table, &mut v);
        std::fs::write(
            dir.path().join(format!("{kind}.lobefit")),
            format::encode(table.meta(), &v).unwrap(),
        )
        .unwrap();
    };
    // lobe-product: +1 on the integral channel of node 94082 (median/p99 thresholds
    // only, strided nodes: it passed).
    write("lobe-product", &|_, v| v[94082 * 2] += 1.0);
    // isg-refit: the node nearest γ = 0.58 (the random sample began at γ = 3).
    write("isg-refit", &|t, v| {
        let axis = &t.meta().axes[0];
        let n = (0..axis.count)
            .min_by(|&a, &b| (axis.node(a) - 0.58).abs().total_cmp(&(axis.node(b) - 0.58).abs()))
            .unwrap() as usize;
        v[n * 2] += 0.5;
    });
    // log-zh: z6's hi part at a node the strided --quick never visited.
    write("log-zh", &|_, v| v[1001 * 16 + 12] += 1e-6);
    // lobe-product-l2: value 0 set to f32::MAX (a single threshold did not see it).
    write("lobe-product-l2", &|_, v| v[0] = f32::MAX);
    for (kind, expect) in [
        ("lobe-product", "FAIL integral_nodes.grid.max_rel"),
        ("isg-refit", "FAIL s_hat_low_gamma.grid.max_abs"),
        ("log-zh", "FAIL t6.grid.max_abs"),
        ("lobe-product-l2", "outside its plausible range"),
    ] {
        let (code, out, err) = run_text(&["check", "--quick", "--only", kind, "--tables", t], "");
        assert_eq!(code, Some(1), "{kind}: {out}{err}");
        assert!(out.contains(expect), "{kind}: expected '{expect}' in\n{out}");
    }
}

/// Bad `--junit` / `--baseline-factor` arguments are specific errors.
#[test]
fn bad_ci_arguments_are_specific_errors() {
    let (code, _, err) = run_text(
        &[
            "check",
            "--quick",
            "--only",
            "lobe-integral",
            "--junit",
            "/proc/no/such/dir/check.xml",
        ],
        "",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("--junit /proc/no/such/dir/check.xml"), "{err}");
    let (code, _, err) = run_text(
        &["check", "--quick", "--only", "lobe-integral", "--baseline-factor", "2"],
        "",
    );
    assert_eq!(code, Some(2), "the factor without a baseline is a usage error");
    assert!(err.contains("--baseline"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.json");
    let (code, _, err) = run_text(
        &[
            "check",
            "--only",
            "lobe-integral",
            "--baseline",
            missing.to_str().unwrap(),
        ],
        "",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("--baseline") && err.contains("none.json"), "{err}");
}
