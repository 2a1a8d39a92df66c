//! The checker: every table, through the runtime crate's own lookup and in its stored
//! precision, against an independent reference — (a) at every grid node, (b) at
//! seeded random off-grid points over the whole domain the runtime serves — with the
//! thresholds stored in the file and those the family's code promises.
//!
//! Every node is verified in `--quick` too, so a single corrupted node cannot hide
//! between strided samples: by the family's pointwise check, or (where that costs too
//! much for every node) by cheaper, still independent per-node sections of
//! [`Checked::extra_checks`] (see [`Checked::nodes_in_extras`]).

use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Deserializer, Serialize};

use lobefit_tables::Table;

use crate::family::{Checked, Extra, F32Twin, Lookup};
use crate::rng::Rng;

/// Checker settings.
#[derive(Debug, Clone, Copy)]
pub struct CheckOptions {
    /// Random off-grid points per family.
    pub offgrid: usize,
    /// Seed of the off-grid sample (the same seed gives the same points).
    pub seed: u64,
    /// Grid nodes given the full pointwise check in families that verify every node
    /// in cheaper per-node sections ([`Checked::nodes_in_extras`]): an evenly strided
    /// subset of about this many. Every other family checks every node.
    pub grid_limit: usize,
    /// Run the whole-scene sections ([`Checked::extra_checks`]) of families that check
    /// every node pointwise. `false` is for sweeps that look only for failures at
    /// nodes (tests/it/check_corruption.rs): the sections are skipped there, and so are
    /// the thresholds on what they would have measured. Families that verify their
    /// nodes in those sections ([`Checked::nodes_in_extras`]) always run them.
    pub whole_scene: bool,
}

impl CheckOptions {
    /// Full check: 10 000 off-grid points.
    pub const FULL: CheckOptions = CheckOptions {
        offgrid: 10_000,
        seed: 0x010b_ef17,
        grid_limit: 20_000,
        whole_scene: true,
    };
    /// CI check: 2 000 off-grid points.
    pub const QUICK: CheckOptions = CheckOptions {
        offgrid: 2_000,
        seed: 0x010b_ef17,
        grid_limit: 2_000,
        whole_scene: true,
    };
}

/// A number of a saved JSON report: JSON has no NaN, so serde_json writes it as
/// `null` (an empty sample's statistics), and this reads `null` back as NaN.
fn nan_if_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Summary statistics of an error sample.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Stats {
    /// Sample size.
    pub count: usize,
    /// Mean.
    #[serde(deserialize_with = "nan_if_null")]
    pub mean: f64,
    /// Variance (population).
    #[serde(deserialize_with = "nan_if_null")]
    pub variance: f64,
    /// Median.
    #[serde(deserialize_with = "nan_if_null")]
    pub median: f64,
    /// 95th percentile.
    #[serde(deserialize_with = "nan_if_null")]
    pub p95: f64,
    /// 99th percentile.
    #[serde(deserialize_with = "nan_if_null")]
    pub p99: f64,
    /// Maximum.
    #[serde(deserialize_with = "nan_if_null")]
    pub max: f64,
}

impl Stats {
    /// Statistics of `v` (consumed; sorted in place).
    pub fn of(mut v: Vec<f64>) -> Stats {
        if v.is_empty() {
            // NaN statistics fail every threshold: an empty sample proves nothing.
            return Stats {
                count: 0,
                mean: f64::NAN,
                variance: f64::NAN,
                median: f64::NAN,
                p95: f64::NAN,
                p99: f64::NAN,
                max: f64::NAN,
            };
        }
        v.sort_by(f64::total_cmp);
        let q = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        Stats {
            count: v.len(),
            mean,
            variance: v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64,
            median: q(0.5),
            p95: q(0.95),
            p99: q(0.99),
            max: *v.last().expect("non-empty"),
        }
    }

    /// The statistics a metric name can select, with their names.
    pub const METRICS: [&'static str; 5] = ["mean", "median", "p95", "p99", "max"];

    /// The statistic called `name` (one of [`Stats::METRICS`]).
    pub fn metric(&self, name: &str) -> Option<f64> {
        Some(match name {
            "mean" => self.mean,
            "median" => self.median,
            "p95" => self.p95,
            "p99" => self.p99,
            "max" => self.max,
            _ => return None,
        })
    }
}

/// Errors of one output quantity.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct OutputReport {
    /// Output column.
    pub output: String,
    /// Absolute error at the grid nodes.
    pub grid_abs: Stats,
    /// Relative error at the grid nodes.
    pub grid_rel: Stats,
    /// Absolute error at off-grid points.
    pub offgrid_abs: Stats,
    /// Relative error at off-grid points.
    pub offgrid_rel: Stats,
    /// Off-grid point with the largest relative error.
    pub worst_offgrid_input: Vec<f64>,
}

/// A measured distribution (see [`Extra::Values`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ValueReport {
    /// What was measured.
    pub name: String,
    /// Its statistics.
    pub stats: Stats,
}

/// One threshold and its measured value.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThresholdResult {
    /// Output column.
    pub output: String,
    /// Metric name, `{grid|offgrid}.{mean|median|p95|p99|max}_{abs|rel}` for an
    /// output, `{mean|median|p95|p99|max}` for a measured distribution.
    pub metric: String,
    /// Limit from the file.
    pub limit: f64,
    /// Measured value (NaN when the metric is unknown, which fails).
    #[serde(deserialize_with = "nan_if_null")]
    pub value: f64,
    /// Whether `value <= limit`.
    pub pass: bool,
}

/// The report of one family.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FamilyReport {
    /// Table kind.
    pub kind: String,
    /// File checked.
    pub file: String,
    /// Grid entries checked.
    pub grid_points: usize,
    /// Off-grid points checked.
    pub offgrid_points: usize,
    /// Seed of the off-grid sample (a baseline must be compared at the same seed).
    #[serde(default)]
    pub seed: u64,
    /// Off-grid points requested (`--points`, or the default of `--quick` / full).
    #[serde(default)]
    pub points_requested: usize,
    /// Per-output errors.
    pub outputs: Vec<OutputReport>,
    /// Threshold verdicts.
    pub thresholds: Vec<ThresholdResult>,
    /// Measured distributions reported without a threshold.
    pub values: Vec<ValueReport>,
    /// Problems that fail the check outright (load error, lookup error, bad fit flags).
    pub problems: Vec<String>,
    /// Overall verdict.
    pub pass: bool,
}

/// Runtime value and reference value of every checked quantity at one point (`None`
/// where the family promises nothing), or what went wrong.
type PointResult = Result<Option<(Vec<f64>, Vec<f64>)>, String>;

/// Suffix of the report rows of the runtime's f32 twins (`"<output> f32"`).
pub const F32_SUFFIX: &str = "f32";

/// What one rounding to f32 may add to an f32 twin's error (relative, with slack 2).
const F32_SLACK: f64 = 1.0 / (1u64 << 23) as f64;

/// The f32 twins are checked at every this-many-th off-grid sample: they differ from
/// the f64 lookup by one rounding, which needs no full sample to show.
const F32_STRIDE: usize = 4;

/// The input point `x` rounded to f32, as the f32 twins and shaders receive it, inside
/// the domain `runtime` serves: to nearest (f32(π) read as π, as the twins read an
/// angle), or towards zero where that leaves the domain (a bound not representable
/// in f32).
pub fn f32_point(runtime: &dyn Lookup, x: &[f64]) -> Vec<f64> {
    let near: Vec<f64> = x.iter().map(|&v| lobefit_tables::error::angle_f32(v as f32)).collect();
    if runtime.lookup(&near).is_ok() {
        near
    } else {
        x.iter().map(|&v| f32_toward_zero(v) as f64).collect()
    }
}

/// The f32 nearest to `v` whose magnitude does not exceed |v|.
fn f32_toward_zero(v: f64) -> f32 {
    let r = v as f32;
    if (r as f64).abs() > v.abs() {
        f32::from_bits(r.to_bits() - 1)
    } else {
        r
    }
}

/// |got − want| / |want| (0 where equal).
pub fn rel_err(got: f64, want: f64) -> f64 {
    let d = (got - want).abs();
    if d == 0.0 {
        0.0
    } else {
        d / want.abs().max(f64::MIN_POSITIVE)
    }
}

/// A quantity the family promises nothing about at this point: both values NaN (see
/// [`Checked::check_point`]). A NaN from the runtime alone is an error, never skipped.
fn no_promise(got: f64, want: f64) -> bool {
    got.is_nan() && want.is_nan()
}

fn gcd(mut a: usize, mut b: usize) -> usize {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Checks one family's table file.
pub fn check_family(family: &dyn Checked, path: &Path, opts: CheckOptions) -> FamilyReport {
    let mut report = FamilyReport {
        kind: family.kind().to_string(),
        file: path.display().to_string(),
        grid_points: 0,
        offgrid_points: 0,
        seed: opts.seed,
        points_requested: opts.offgrid,
        outputs: Vec::new(),
        thresholds: Vec::new(),
        values: Vec::new(),
        problems: Vec::new(),
        pass: false,
    };
    let table = match Table::from_path(path) {
        Ok(t) => t,
        Err(e) => {
            report.problems.push(e.to_string());
            return report;
        }
    };
    // The loader has already rejected files with unconverged entries.
    let meta = table.meta().clone();
    let table_copy = table.clone();
    let runtime = match family.runtime(table) {
        Ok(r) => r,
        Err(e) => {
            report.problems.push(e.to_string());
            return report;
        }
    };
    let all_nodes = crate::build::grid_nodes(&meta.axes);
    // Every node, unless the family verifies every node in cheaper sections of its
    // own; then an evenly strided subset gets the full check. The stride is coprime
    // to the fastest axis's count, so every node of that axis is visited (a stride of
    // 12 on 96 α nodes would only ever see 8 of them).
    let fastest = meta.axes.last().map_or(1, |a| a.count as usize);
    let mut stride = if family.nodes_in_extras() {
        all_nodes.len().div_ceil(opts.grid_limit.max(1)).max(1)
    } else {
        1
    };
    while stride > 1 && gcd(stride, fastest) != 1 {
        stride += 1;
    }
    let grid: Vec<Vec<f64>> = all_nodes
        .iter()
        .step_by(stride)
        .flat_map(|n| family.node_inputs(n))
        .collect();
    let mut rng = Rng::new(opts.seed);
    let offgrid: Vec<Vec<f64>> = (0..opts.offgrid).map(|_| family.sample(&mut rng)).collect();
    let eval = |pts: &[Vec<f64>]| -> Vec<PointResult> {
        pts.par_iter()
            .map(|x| family.check_point(runtime.as_ref(), x))
            .collect()
    };
    let grid_res = eval(&grid);
    let off_res = eval(&offgrid);
    // The f32 twins at every F32_STRIDE-th sample rounded to f32 (their inputs),
    // against the reference there. Rounding to nearest can leave the domain (a bound
    // not representable in f32); such a point is rounded towards zero instead.
    let offgrid32: Vec<Vec<f64>> = offgrid
        .iter()
        .step_by(F32_STRIDE)
        .map(|x| f32_point(runtime.as_ref(), x))
        .collect();
    let has_f32 = offgrid32.first().is_some_and(|x| runtime.lookup_f32(x).is_some());
    let off32_res: Vec<PointResult> = if has_f32 {
        let twin = F32Twin(runtime.as_ref());
        offgrid32.par_iter().map(|x| family.check_point(&twin, x)).collect()
    } else {
        Vec::new()
    };
    let promised = |res: &[PointResult]| res.iter().filter(|r| matches!(r, Ok(Some(_)))).count();
    report.grid_points = promised(&grid_res);
    report.offgrid_points = promised(&off_res);
    for r in grid_res.iter().chain(&off_res).chain(&off32_res) {
        if let Err(e) = r {
            if report.problems.len() < 10 {
                report.problems.push(e.clone());
            }
        }
    }
    let (mut f32_rows, mut f32_scale) = (Vec::new(), Vec::new());
    for (k, name) in family.checked().iter().enumerate() {
        let errs = |res: &[PointResult]| {
            let (mut abs, mut rel) = (Vec::new(), Vec::new());
            for (g, w) in res.iter().flatten().flatten() {
                if no_promise(g[k], w[k]) {
                    continue;
                }
                abs.push((g[k] - w[k]).abs());
                rel.push(rel_err(g[k], w[k]));
            }
            (abs, rel)
        };
        let (ga, gr) = errs(&grid_res);
        let (oa, or) = errs(&off_res);
        if has_f32 {
            let (a32, r32) = errs(&off32_res);
            f32_rows.push(OutputReport {
                output: format!("{name} {F32_SUFFIX}"),
                grid_abs: Stats::of(Vec::new()),
                grid_rel: Stats::of(Vec::new()),
                offgrid_abs: Stats::of(a32),
                offgrid_rel: Stats::of(r32),
                worst_offgrid_input: Vec::new(),
            });
            f32_scale.push(
                off32_res
                    .iter()
                    .flatten()
                    .flatten()
                    .map(|(g, _)| g[k].abs())
                    .filter(|v| v.is_finite())
                    .fold(0.0, f64::max),
            );
        }
        let worst_input = off_res
            .iter()
            .zip(&offgrid)
            .filter_map(|(r, x)| match r {
                Ok(Some((g, w))) if !no_promise(g[k], w[k]) => Some((rel_err(g[k], w[k]), x)),
                _ => None,
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, x)| x.clone())
            .unwrap_or_default();
        report.outputs.push(OutputReport {
            output: name.to_string(),
            grid_abs: Stats::of(ga),
            grid_rel: Stats::of(gr),
            offgrid_abs: Stats::of(oa),
            offgrid_rel: Stats::of(or),
            worst_offgrid_input: worst_input,
        });
    }
    report.outputs.extend(f32_rows);
    // Whole-scene sections: a handful of cases each (they are expensive to reference).
    let cases = (opts.offgrid / 100).max(10);
    let sections = opts.whole_scene || family.nodes_in_extras();
    let extras = if sections {
        family.extra_checks(&table_copy, cases, opts.seed)
    } else {
        Vec::new()
    };
    for (name, res) in extras {
        match res {
            Ok(Extra::Values(v)) => report.values.push(ValueReport {
                name,
                stats: Stats::of(v),
            }),
            Ok(Extra::Pairs(pairs)) => report.outputs.push(pair_report(name, &[], &pairs)),
            Ok(Extra::Nodes(pairs)) => report.outputs.push(pair_report(name, &pairs, &[])),
            Err(e) => report.problems.push(format!("{name}: {e}")),
        }
    }
    for t in &meta.thresholds {
        let measured =
            |o: &str| report.outputs.iter().any(|r| r.output == o) || report.values.iter().any(|v| v.name == o);
        if !sections && !measured(&t.output) {
            continue; // a skipped section's threshold (see `CheckOptions::whole_scene`)
        }
        let value = report
            .outputs
            .iter()
            .find(|o| o.output == t.output)
            .and_then(|o| metric_value(o, &t.metric))
            .or_else(|| {
                let v = report.values.iter().find(|v| v.name == t.output)?;
                v.stats.metric(&t.metric)
            })
            .unwrap_or(f64::NAN);
        report.thresholds.push(ThresholdResult {
            output: t.output.clone(),
            metric: t.metric.clone(),
            limit: t.limit,
            value,
            pass: value <= t.limit,
        });
    }
    // The f32 twins promise what the f64 lookup promises plus one rounding to f32:
    // |g32 − g64| ≤ 2⁻²⁴|g64|, so a relative limit widens by 2⁻²⁴(1 + limit) and an
    // absolute one by 2⁻²⁴ max|g64| (both taken at 2⁻²³ for slack). Off-grid metrics
    // only: the twins are sampled off the grid.
    for (t, scale) in meta.thresholds.iter().flat_map(|t| {
        let k = family.checked().iter().position(|&c| c == t.output)?;
        Some((t, *f32_scale.get(k)?))
    }) {
        if !t.metric.starts_with("offgrid.") {
            continue;
        }
        let output = format!("{} {F32_SUFFIX}", t.output);
        let slack = if t.metric.ends_with("_rel") {
            F32_SLACK * (1.0 + t.limit)
        } else {
            F32_SLACK * scale
        };
        let value = report
            .outputs
            .iter()
            .find(|o| o.output == output)
            .and_then(|o| metric_value(o, &t.metric))
            .unwrap_or(f64::NAN);
        report.thresholds.push(ThresholdResult {
            output,
            metric: t.metric.clone(),
            limit: t.limit + slack,
            value,
            pass: value <= t.limit + slack,
        });
    }
    // The file's thresholds are what the file promises; the family's are what this
    // code promises. A file must not weaken or drop any of the latter (a regressed or
    // forged table could otherwise switch off its own check).
    for want in family.thresholds() {
        let covered = meta
            .thresholds
            .iter()
            .any(|t| t.output == want.output && t.metric == want.metric && t.limit <= want.limit);
        if !covered {
            report.problems.push(format!(
                "the file lacks or loosens the threshold {}.{} <= {:e}",
                want.output, want.metric, want.limit
            ));
        }
    }
    report.pass = report.problems.is_empty() && report.thresholds.iter().all(|t| t.pass);
    report
}

/// The report of an extra section's (runtime, reference) pairs at grid nodes and at
/// off-grid points.
fn pair_report(output: String, grid: &[(f64, f64)], offgrid: &[(f64, f64)]) -> OutputReport {
    let abs = |p: &[(f64, f64)]| p.iter().map(|&(g, w)| (g - w).abs()).collect();
    let rel = |p: &[(f64, f64)]| p.iter().map(|&(g, w)| rel_err(g, w)).collect();
    OutputReport {
        output,
        grid_abs: Stats::of(abs(grid)),
        grid_rel: Stats::of(rel(grid)),
        offgrid_abs: Stats::of(abs(offgrid)),
        offgrid_rel: Stats::of(rel(offgrid)),
        worst_offgrid_input: Vec::new(),
    }
}

/// The family's off-grid threshold metrics of one output from its pointwise absolute
/// and relative errors: (metric, measured, limit) for each of `output`'s `offgrid.*`
/// thresholds, measured the way `lobefit check` measures them.
pub fn offgrid_metrics(family: &dyn Checked, output: &str, abs: Vec<f64>, rel: Vec<f64>) -> Vec<(String, f64, f64)> {
    let report = OutputReport {
        output: output.to_string(),
        grid_abs: Stats::of(Vec::new()),
        grid_rel: Stats::of(Vec::new()),
        offgrid_abs: Stats::of(abs),
        offgrid_rel: Stats::of(rel),
        worst_offgrid_input: Vec::new(),
    };
    family
        .thresholds()
        .into_iter()
        .filter(|t| t.output == output && t.metric.starts_with("offgrid."))
        .map(|t| {
            let measured = metric_value(&report, &t.metric).unwrap_or(f64::NAN);
            (t.metric, measured, t.limit)
        })
        .collect()
}

/// Value of a metric such as `offgrid.max_rel` in an output report.
pub fn metric_value(o: &OutputReport, metric: &str) -> Option<f64> {
    let (set, rest) = metric.split_once('.')?;
    let (stat, kind) = rest.rsplit_once('_')?;
    let stats = match (set, kind) {
        ("grid", "abs") => &o.grid_abs,
        ("grid", "rel") => &o.grid_rel,
        ("offgrid", "abs") => &o.offgrid_abs,
        ("offgrid", "rel") => &o.offgrid_rel,
        _ => return None,
    };
    stats.metric(stat)
}

/// Whether an output's errors read best as absolute values: the kind its thresholds
/// use, else absolute where relative errors exceed 1 (the quantity crosses 0, so a
/// ratio to it means nothing), else relative.
fn reads_absolute(r: &FamilyReport, o: &OutputReport) -> bool {
    match r.thresholds.iter().find(|t| t.output == o.output) {
        Some(t) => t.metric.ends_with("_abs"),
        None => {
            let rel = o.grid_rel.max.max(o.offgrid_rel.max);
            (rel.is_nan() || rel > 1.0) && o.offgrid_abs.count + o.grid_abs.count > 0
        }
    }
}

/// Renders reports as a fixed-width text table: each quantity in the kind of error it
/// promises (see `reads_absolute`), the other kind on the line below where it means
/// something.
pub fn render(reports: &[FamilyReport]) -> String {
    // A statistic of no points (e.g. grid errors of an off-grid-only row) prints as "-".
    let num = |x: f64| {
        if x.is_nan() {
            "-".to_string()
        } else {
            format!("{x:.3e}")
        }
    };
    let mut s = String::new();
    s.push_str(&format!(
        "{:<15} {:<22} {:>3} {:>6} {:>6} {:>10} {:>10} {:>10} {:>10} {:>10}\n",
        "family", "output", "err", "nodes", "random", "grid max", "rnd mean", "rnd median", "rnd p95", "rnd max"
    ));
    for r in reports {
        let mut other = String::new();
        for o in &r.outputs {
            let abs = reads_absolute(r, o);
            let (g, x) = if abs {
                (&o.grid_abs, &o.offgrid_abs)
            } else {
                (&o.grid_rel, &o.offgrid_rel)
            };
            s.push_str(&format!(
                "{:<15} {:<22} {:>3} {:>6} {:>6} {:>10} {:>10} {:>10} {:>10} {:>10}\n",
                r.kind,
                o.output,
                if abs { "abs" } else { "rel" },
                g.count,
                x.count,
                num(g.max),
                num(x.mean),
                num(x.median),
                num(x.p95),
                num(x.max)
            ));
            let (g, x, kind) = if abs {
                (&o.grid_rel, &o.offgrid_rel, "relative")
            } else {
                (&o.grid_abs, &o.offgrid_abs, "absolute")
            };
            // A relative error above 1 is a ratio to a value near 0: not shown.
            if !abs || g.max.max(x.max) <= 1.0 {
                other.push_str(&format!(
                    "  {} {kind}: grid max {}; random mean {} median {} p95 {} max {}\n",
                    o.output,
                    num(g.max),
                    num(x.mean),
                    num(x.median),
                    num(x.p95),
                    num(x.max)
                ));
            }
        }
        s.push_str(&other);
        for v in &r.values {
            let st = &v.stats;
            s.push_str(&format!(
                "  {} (n = {}): mean {:.3e} var {:.3e} median {:.3e} p95 {:.3e} max {:.3e}\n",
                v.name, st.count, st.mean, st.variance, st.median, st.p95, st.max
            ));
        }
        for t in &r.thresholds {
            s.push_str(&format!(
                "  {} {}.{} = {:.3e} (limit {:.1e})\n",
                if t.pass { "ok  " } else { "FAIL" },
                t.output,
                t.metric,
                t.value,
                t.limit
            ));
        }
        for p in &r.problems {
            s.push_str(&format!("  FAIL {p}\n"));
        }
    }
    s.push_str(
        "(err: the kind of error each quantity promises, abs or rel; nodes: points checked at grid nodes; \
         rnd = seeded random off-grid points through the runtime; -: no points of that kind; \
         `<output> f32`: the runtime's f32 twin at every 4th random point rounded to f32)\n",
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_samples_fail_every_threshold() {
        let s = Stats::of(Vec::new());
        assert_eq!(s.count, 0);
        assert!(s.max.is_nan() && s.median.is_nan());
        assert!(
            s.max.partial_cmp(&1e9).is_none(),
            "NaN is unordered, so `value <= limit` fails"
        );
    }

    #[test]
    fn stats_and_metric_names() {
        let s = Stats::of((1..=100).map(f64::from).collect());
        assert_eq!((s.median, s.p95, s.max, s.mean), (51.0, 95.0, 100.0, 50.5));
        let o = OutputReport {
            output: "x".into(),
            grid_abs: s,
            grid_rel: s,
            offgrid_abs: s,
            offgrid_rel: Stats::of(vec![0.5]),
            worst_offgrid_input: vec![],
        };
        assert_eq!(metric_value(&o, "offgrid.max_rel"), Some(0.5));
        assert_eq!(metric_value(&o, "grid.p95_abs"), Some(95.0));
        assert_eq!(metric_value(&o, "offgrid.max"), None);
        assert_eq!(metric_value(&o, "nonsense"), None);
    }
}
