//! What `lobefit check` gives a CI system: a comparison of every reported metric with
//! a saved report (`--baseline`), so that a table which stays under its thresholds but
//! loses accuracy is still caught, and JUnit XML (`--junit`), the format CI servers
//! display.

use std::fmt::Write as _;

use crate::check::{metric_value, FamilyReport, OutputReport, Stats};

/// Default of `--baseline-factor`: a metric may grow to 1.5× its saved value. Rebuilds
/// of unchanged tables reproduce every metric exactly (the checker is deterministic),
/// so any growth is a change of the tables or of the code; 1.5× leaves room for an
/// intended refit that trades a little accuracy in one metric for another.
pub const DEFAULT_FACTOR: f64 = 1.5;

/// Metrics at or below this absolute value are equal to zero for the comparison:
/// rounding-level errors (1e-16 where the baseline had 0) are no regression.
pub const FLOOR: f64 = 1e-14;

/// One metric compared with the baseline.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Table kind.
    pub kind: String,
    /// Output or measured distribution.
    pub output: String,
    /// `{grid|offgrid}.{stat}_{abs|rel}` for an output, `{stat}` for a distribution.
    pub metric: String,
    /// Saved value.
    pub baseline: f64,
    /// Value now.
    pub value: f64,
    /// Whether `value ≤ factor · baseline` (or both are below [`FLOOR`]).
    pub pass: bool,
}

/// The named statistics of an output report, as (metric name, value).
fn output_metrics(o: &OutputReport) -> Vec<(String, f64)> {
    let names = ["grid", "offgrid"]
        .iter()
        .flat_map(|set| ["abs", "rel"].map(|kind| (set, kind)))
        .flat_map(|(set, kind)| Stats::METRICS.map(|m| format!("{set}.{m}_{kind}")));
    names
        .map(|name| {
            let value = metric_value(o, &name).unwrap_or(f64::NAN);
            (name, value)
        })
        .collect()
}

/// Every metric of a report, as (output, metric, value).
fn all_metrics(r: &FamilyReport) -> Vec<(String, String, f64)> {
    let mut v = Vec::new();
    for o in &r.outputs {
        v.extend(output_metrics(o).into_iter().map(|(m, x)| (o.output.clone(), m, x)));
    }
    for d in &r.values {
        v.extend(Stats::METRICS.map(|m| (d.name.clone(), m.to_string(), d.stats.metric(m).unwrap_or(f64::NAN))));
    }
    v
}

/// Compares every metric of `reports` with `baseline` (the JSON of an earlier
/// `check --json` with the same seed and point count). Errors name what makes the two
/// incomparable: a family missing from the baseline, another seed or point count.
pub fn compare(reports: &[FamilyReport], baseline: &[FamilyReport], factor: f64) -> Result<Vec<Comparison>, String> {
    if !(factor.is_finite() && factor >= 1.0) {
        return Err(format!("baseline factor {factor} must be a finite number ≥ 1"));
    }
    let mut out = Vec::new();
    for r in reports {
        let b = baseline
            .iter()
            .find(|b| b.kind == r.kind)
            .ok_or_else(|| format!("the baseline has no report for {} (save a new one)", r.kind))?;
        if (b.seed, b.points_requested) != (r.seed, r.points_requested) {
            return Err(format!(
                "{}: the baseline was made with seed {} and {} random points, this check uses seed {} and {} \
                 (run both with the same --quick/--points/--seed)",
                r.kind, b.seed, b.points_requested, r.seed, r.points_requested
            ));
        }
        let now = all_metrics(r);
        for (output, metric, saved) in all_metrics(b) {
            let value = now
                .iter()
                .find(|(o, m, _)| *o == output && *m == metric)
                .map_or(f64::NAN, |x| x.2);
            let pass = if saved.is_nan() {
                true // the baseline measured nothing here
            } else {
                value.abs() <= FLOOR || value <= factor * saved
            };
            out.push(Comparison {
                kind: r.kind.clone(),
                output,
                metric,
                baseline: saved,
                value,
                pass,
            });
        }
    }
    Ok(out)
}

/// The failed comparisons as report lines.
pub fn render(comparisons: &[Comparison], factor: f64) -> String {
    let failed: Vec<&Comparison> = comparisons.iter().filter(|c| !c.pass).collect();
    let mut s = format!(
        "baseline: {} metrics compared, {} worse than {factor}× their saved value\n",
        comparisons.len(),
        failed.len()
    );
    for c in failed {
        let _ = writeln!(
            s,
            "  FAIL {} {}.{} = {:.3e}, baseline {:.3e} ({:.1}×)",
            c.kind,
            c.output,
            c.metric,
            c.value,
            c.baseline,
            c.value / c.baseline
        );
    }
    s
}

/// Text escaped for an XML attribute or element.
fn xml(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            // XML 1.0 has no other control characters.
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => o.push(' '),
            c => o.push(c),
        }
    }
    o
}

/// The check as JUnit XML: one test suite per family, one test case per threshold, per
/// problem, and (with a baseline) per family's baseline comparison.
pub fn junit(reports: &[FamilyReport], comparisons: Option<&[Comparison]>) -> String {
    let mut suites = String::new();
    let (mut total, mut failures) = (0, 0);
    for r in reports {
        // (name, failure message or None)
        let mut cases: Vec<(String, Option<String>)> = r
            .thresholds
            .iter()
            .map(|t| {
                let name = format!("{}.{} <= {:e}", t.output, t.metric, t.limit);
                let fail =
                    (!t.pass).then(|| format!("{}.{} = {:e} exceeds {:e}", t.output, t.metric, t.value, t.limit));
                (name, fail)
            })
            .collect();
        cases.extend(r.problems.iter().map(|p| ("problem".to_string(), Some(p.clone()))));
        if let Some(cmp) = comparisons {
            let mine: Vec<&Comparison> = cmp.iter().filter(|c| c.kind == r.kind).collect();
            let failed: Vec<String> = mine
                .iter()
                .filter(|c| !c.pass)
                .map(|c| format!("{}.{} = {:e}, baseline {:e}", c.output, c.metric, c.value, c.baseline))
                .collect();
            let name = format!("baseline ({} metrics)", mine.len());
            cases.push((name, (!failed.is_empty()).then(|| failed.join("; "))));
        }
        let nfail = cases.iter().filter(|c| c.1.is_some()).count();
        total += cases.len();
        failures += nfail;
        let _ = writeln!(
            suites,
            "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{nfail}\">",
            xml(&r.kind),
            cases.len()
        );
        for (name, fail) in cases {
            match fail {
                None => {
                    let _ = writeln!(
                        suites,
                        "    <testcase classname=\"{}\" name=\"{}\"/>",
                        xml(&r.kind),
                        xml(&name)
                    );
                }
                Some(msg) => {
                    let _ = writeln!(
                        suites,
                        "    <testcase classname=\"{}\" name=\"{}\">\n      <failure message=\"{}\"/>\n    </testcase>",
                        xml(&r.kind),
                        xml(&name),
                        xml(&msg)
                    );
                }
            }
        }
        suites.push_str("  </testsuite>\n");
    }
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"lobefit check\" tests=\"{total}\" failures=\"{failures}\">\n{suites}</testsuites>\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::ValueReport;

    fn report(max: f64) -> FamilyReport {
        let s = Stats::of(vec![0.0, max]);
        FamilyReport {
            kind: "k".into(),
            file: "f".into(),
            grid_points: 2,
            offgrid_points: 2,
            seed: 1,
            points_requested: 2,
            outputs: vec![OutputReport {
                output: "o".into(),
                grid_abs: s,
                grid_rel: s,
                offgrid_abs: s,
                offgrid_rel: Stats::of(Vec::new()),
                worst_offgrid_input: vec![],
            }],
            thresholds: vec![],
            values: vec![ValueReport {
                name: "v".into(),
                stats: s,
            }],
            problems: vec![],
            pass: true,
        }
    }

    #[test]
    fn a_metric_worse_than_the_factor_fails_and_nan_round_trips() {
        let base = report(1e-6);
        let json = serde_json::to_string(&vec![base.clone()]).unwrap();
        let saved: Vec<FamilyReport> = serde_json::from_str(&json).expect("NaN statistics read back");
        assert!(saved[0].outputs[0].offgrid_rel.max.is_nan());
        let same = compare(&[base], &saved, 1.5).unwrap();
        assert!(same.iter().all(|c| c.pass));
        let worse = compare(&[report(2e-6)], &saved, 1.5).unwrap();
        let failed: Vec<_> = worse
            .iter()
            .filter(|c| !c.pass)
            .map(|c| (c.output.as_str(), c.metric.as_str()))
            .collect();
        assert!(
            failed.contains(&("o", "grid.max_abs")) && failed.contains(&("v", "max")),
            "{failed:?}"
        );
        assert!(compare(&[report(1.4e-6)], &saved, 1.5).unwrap().iter().all(|c| c.pass));
        let mut other_seed = report(1e-6);
        other_seed.seed = 2;
        assert!(compare(&[other_seed], &saved, 1.5).unwrap_err().contains("seed"));
        assert!(compare(&[report(1e-6)], &saved, 0.5).is_err());
    }

    #[test]
    fn junit_escapes_and_counts() {
        let mut r = report(1.0);
        r.problems.push("bad <value> & \"quote\"".into());
        let x = junit(&[r], None);
        assert!(x.contains("tests=\"1\" failures=\"1\""), "{x}");
        assert!(x.contains("bad &lt;value&gt; &amp; &quot;quote&quot;"), "{x}");
    }
}
