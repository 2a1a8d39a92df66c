//! The checker catches any single corrupted node: for every committed table and every
//! stored channel, seeded random nodes are changed by a few times the family's
//! promised accuracy (CRCs recomputed, so the loader accepts the file), and the check
//! must fail on a max-type threshold at the nodes, naming the family and the quantity.
//!
//! The corrupted copies are checked with `CheckOptions::QUICK`'s node pass alone (every
//! node is verified in `--quick`; no random off-grid points, no whole-scene sections),
//! so each corruption is caught at the nodes, and a failure here fails `--quick` too.
//! The control, the unchanged table checked the same way, shows no failure at its
//! nodes. (`check --quick` in .ci/run passes every committed table in full.)

use std::f64::consts::TAU;
use std::path::Path;

use lobefit::check::{check_family, CheckOptions, FamilyReport};
use lobefit::family::{Checked, View};
use lobefit::fits::lobe_product::{reference_integral, RELEVANCE};
use lobefit::fits::{registry, FitOptions};
use lobefit::rng::Rng;
use lobefit_tables::{format, Table};

const OPTS: CheckOptions = CheckOptions {
    offgrid: 200,
    ..CheckOptions::QUICK
};

/// [`OPTS`] without the whole-scene sections and the random off-grid points: the
/// corrupted copies are searched for node failures only, and skipping can only remove
/// failures, never add one (mask-weights' held-out scenes took most of the sweep's
/// time; the off-grid points' references a fifth of what remained).
const NODE_OPTS: CheckOptions = CheckOptions {
    whole_scene: false,
    offgrid: 0,
    ..OPTS
};

/// Size of the change to one stored value: a few times (2–5×) the family's promised
/// accuracy at the nodes, in the channel's stored units (a log-encoded channel's unit
/// is relative), and at least two f32 steps so the stored value changes.
fn delta(kind: &str, channel: &str, v: f32) -> f64 {
    let d = match kind {
        "lobe-integral" => 3e-6,               // ln I; 1e-6 relative
        "cap-exponent" => 3e-4 * f64::from(v), // q; 1e-4 relative on e_cap
        "isg-refit" => 0.15,                   // ln g, ln h; 0.0225 abs on Ŝ
        // A, B; 5e-4 abs on Ŝ (C and D: `rank_one_delta`).
        "isg-best" => 1.5e-3,
        "sg-fit" => 1e-4,       // ln λ, ln μ; 3e-5 relative
        "log-zh" => 3e-9,       // z hi/lo; 1e-9 abs
        "wedge" => 3e-12,       // M hi/lo; 1e-12 abs
        "wrap" => 6e-7,         // λ̂_l; table lookups 2e-7 abs at nodes
        "disk-light" => 5e-5,   // ln c00, ratios; 1e-5 rel L2
        "mask-weights" => 0.15, // weights; 0.05 abs at nodes (NODE_ABS)
        "lobe-product" | "lobe-product-l2" => match channel {
            "ln_integral_over_model" => 3e-4, // integral 1e-4 relative at nodes
            _ => 0.03,                        // e_r, p_r: residual 1e-3 relative at nodes
        },
        other => panic!("no corruption size for {other}"),
    };
    d.max(two_steps(v))
}

/// Two f32 steps at `v`: the smallest change certain to alter the stored value.
fn two_steps(v: f32) -> f64 {
    2.0 * f64::from(f32::from_bits(v.abs().to_bits() + 1) - v.abs())
}

/// isg-best's C and D enter lookups as C(θ)·D(φ): a change δ of C at a node moves Ŝ
/// by up to δ·max|D| at that γ (and likewise for D). The change that moves it by three
/// times the promise (5e-4), or `None` where the partner is too small for any
/// plausible change (|C|, |D| ≤ 0.5) to do so.
fn rank_one_delta(table: &Table, node: usize, channel: usize) -> Option<f64> {
    let nc = table.meta().channels.len();
    let nu = table.meta().axes[1].count as usize;
    let partner = if channel == 2 { 3 } else { 2 };
    let row = node / nu * nu;
    let max = (row..row + nu)
        .map(|n| f64::from(table.values()[n * nc + partner]).abs())
        .fold(0.0, f64::max);
    let d = 1.5e-3 / max;
    (d < 0.2).then_some(d)
}

/// shexp stores (hi, lo) pairs of f_0..f_7, ‖f̂‖, a, b (divided by 1 − cos θ_b) and
/// the kink position per (order, θ_b) node; the promise at nodes is 1e-9 relative (f
/// in units of ‖f‖). `None` where no change of that channel at that node can move a
/// lookup beyond the promise: f_l with l ≥ the node's order (stored as 0, never read),
/// and the kink position (test `a_moved_kink_stays_inside_the_promise`).
fn shexp_delta(table: &Table, node: usize, channel: usize) -> Option<f64> {
    let nc = table.meta().channels.len();
    let row = &table.values()[node * nc..(node + 1) * nc];
    let pair = channel / 2;
    let order = 3 + node / lobefit_tables::shexp::THETA_NODES as usize;
    let d = match pair {
        l @ 0..=7 if l < order => 5e-9 * f64::from(row[16]),
        0..=7 => return None,
        8..=10 => 5e-9 * f64::from(row[2 * pair]).abs(),
        // The kink position: see `a_moved_kink_stays_inside_the_promise`.
        _ => return None,
    };
    Some(d)
}

/// At a lobe-product diagonal node (no mirror) the exponent and amplitude channels
/// are promised through the looked-up lobe's residual, within 0.1 % of the reference
/// optimum's at the nodes: the smallest change 0.03 · 2^k (in the channel's log
/// units) that moves it past three times that promise, or `None` if none up to 1 does.
fn residual_delta(family: &dyn Checked, table: &Table, node: usize, channel: usize) -> Option<f64> {
    let nc = table.meta().channels.len();
    let x = lobefit::build::grid_nodes(&table.meta().axes).swap_remove(node);
    let mut d = 0.03;
    while d <= 1.0 {
        let t = Table::from_bytes(&corrupted(table, node * nc + channel, d)).unwrap();
        let runtime = family.runtime(t).unwrap();
        let (got, want) = family.check_point(runtime.as_ref(), &x).unwrap()?;
        if (got[1] - want[1]).abs() / want[1] > 3.0 * lobefit::fits::lobe_product::NODE_RESIDUAL_MAX_REL {
            return Some(d);
        }
        d *= 2.0;
    }
    None
}

/// The file with value `index` of the payload moved by `d`, CRCs valid.
fn corrupted(table: &Table, index: usize, d: f64) -> Vec<u8> {
    let mut values = table.values().to_vec();
    values[index] = (f64::from(values[index]) + d) as f32;
    format::encode(table.meta(), &values).expect("re-encode")
}

/// Max-type thresholds that failed at the nodes or in per-node or per-interval
/// sections. Off-grid metrics are left out: [`NODE_OPTS`] draws no random points, so
/// their samples are empty and their maxima NaN, which fails every such threshold,
/// corrupted or not (counting them made this sweep pass on any table).
fn node_failures(r: &FamilyReport) -> Vec<String> {
    max_failures(r, false)
}

/// Max-type thresholds that failed, with the off-grid ones where `offgrid` (a check
/// with random points: [`OPTS`]).
fn max_failures(r: &FamilyReport, offgrid: bool) -> Vec<String> {
    r.thresholds
        .iter()
        .filter(|t| !t.pass && t.metric.contains("max") && (offgrid || !t.metric.starts_with("offgrid")))
        .map(|t| format!("{}.{} = {:.3e} (limit {:.1e})", t.output, t.metric, t.value, t.limit))
        .collect()
}

/// A diagonal node (e1 = e2) of a lobe-product table where the product is relevant
/// (such nodes have no mirror, so their own check must catch them).
fn relevant_diagonal_node(table: &Table, rng: &mut Rng) -> usize {
    let axes = &table.meta().axes;
    let (n_e, n_a) = (axes[0].count, axes[2].count);
    loop {
        let (i, k) = (
            (rng.next_u64() % n_e as u64) as u32,
            (rng.next_u64() % n_a as u64) as u32,
        );
        let (e, alpha) = (axes[0].node(i), axes[2].node(k));
        if reference_integral(e, e, alpha).unwrap() >= RELEVANCE * TAU / (1.0 + e) {
            return ((i * n_e + i) * n_a + k) as usize;
        }
    }
}

fn check_bytes(family: &dyn Checked, dir: &Path, bytes: &[u8], opts: CheckOptions) -> FamilyReport {
    let path = dir.join(format!("{}.lobefit", family.kind()));
    std::fs::write(&path, bytes).unwrap();
    check_family(family, &path, opts)
}

// The sweep is two tests (tables of even and odd build index) so that .ci/run's two
// test threads share it; both draw the same picks as one sweep would (the picks of
// every table are drawn, only the checks of the other half are skipped).
#[test]
#[ignore = "heavy (seconds to tens of seconds each): .ci/run runs the ignored tests"]
fn any_single_corrupted_node_fails_the_quick_check_even_tables() {
    corrupted_node_sweep(0);
}

#[test]
#[ignore = "heavy (seconds to tens of seconds each): .ci/run runs the ignored tests"]
fn any_single_corrupted_node_fails_the_quick_check_odd_tables() {
    corrupted_node_sweep(1);
}

/// One corrupted node per channel of each table whose build index has parity `half`
/// (and more where a channel needs them): the quick check fails on every one.
fn corrupted_node_sweep(half: usize) {
    let dir = tempfile::tempdir().unwrap();
    let mut tried = 0;
    let mut rng = Rng::new(0xc0_44_u64);
    for (index, family) in registry(FitOptions::default()).into_iter().enumerate() {
        let checked = index % 2 == half;
        let kind = family.kind();
        let started = std::time::Instant::now();
        let bytes = std::fs::read(format!("tables/data/{kind}.lobefit")).unwrap();
        let table = Table::from_bytes(&bytes).unwrap();
        if checked {
            // The control: the unchanged table, checked as its corrupted copies are,
            // shows no failure at its nodes.
            let control = check_bytes(family.as_ref(), dir.path(), &bytes, NODE_OPTS);
            assert!(
                control.problems.is_empty() && node_failures(&control).is_empty(),
                "{kind}: the unchanged table fails at its nodes: {:?} {:?}",
                control.problems,
                node_failures(&control)
            );
        }
        let nc = table.meta().channels.len();
        let nodes = table.values().len() / nc;
        for (c, channel) in table.meta().channels.iter().enumerate() {
            let mut picks = vec![(rng.next_u64() % nodes as u64) as usize];
            let mut diagonal = None;
            let special = |node: usize| match kind {
                "isg-best" if c >= 2 => Some(rank_one_delta(&table, node, c)),
                "shexp" => Some(shexp_delta(&table, node, c)),
                _ => None,
            };
            if kind == "shexp" && channel.name.starts_with("kink") {
                continue; // see `a_moved_kink_stays_inside_the_promise`
            }
            while special(picks[0]) == Some(None) {
                picks[0] = (rng.next_u64() % nodes as u64) as usize;
            }
            if kind.starts_with("lobe-product") {
                let mut node = relevant_diagonal_node(&table, &mut rng);
                if c > 0 {
                    // Exponent and amplitude: a diagonal node where some change
                    // breaks the residual promise (see `residual_delta`).
                    while residual_delta(family.as_ref(), &table, node, c).is_none() {
                        node = relevant_diagonal_node(&table, &mut rng);
                    }
                    diagonal = Some((node, residual_delta(family.as_ref(), &table, node, c).unwrap()));
                }
                picks.push(node);
            }
            if !checked {
                continue;
            }
            for node in picks {
                let index = node * nc + c;
                let v = table.values()[index];
                let d = match (special(node), diagonal) {
                    (Some(d), _) => d.expect("picked").max(two_steps(v)),
                    (None, Some((n, d))) if n == node => d,
                    (None, _) => delta(kind, &channel.name, v),
                };
                let report = check_bytes(family.as_ref(), dir.path(), &corrupted(&table, index, d), NODE_OPTS);
                let failed = node_failures(&report);
                println!(
                    "{kind:<16} {:<24} node {node:>6} {d:+.2e}: {}",
                    channel.name,
                    failed.join("; ")
                );
                assert_eq!(report.kind, kind);
                assert!(
                    !report.pass && !failed.is_empty(),
                    "{kind}: node {node} channel {} moved by {d:e} passes the node checks",
                    channel.name
                );
                tried += 1;
            }
        }
        // Where the sweep's time goes (run with --nocapture); not asserted.
        println!("{kind}: {:.1} s", started.elapsed().as_secs_f64());
    }
    println!("{tried} single-node corruptions, all caught");
}

/// shexp's kink channel places the stencil switch inside an interval: a kink moved by
/// half an interval, the lookups within one interval of it against the reference
/// (largest error over that order's quantities, in their units).
fn moved_kink_error(table: &Table, node: usize, d: f64) -> f64 {
    use lobefit::fits::shexp::ShExpFamily;
    use lobefit_tables::shexp::{node_theta, THETA_NODES};
    let nc = table.meta().channels.len();
    let (order, i) = (3 + node / THETA_NODES as usize, node % THETA_NODES as usize);
    let h = node_theta(1);
    let family = ShExpFamily::default();
    let prefix = format!("n{order}_");
    let runtime = family
        .runtime(Table::from_bytes(&corrupted(table, node * nc + 22, d)).unwrap())
        .unwrap();
    let mut worst: f64 = 0.0;
    for k in -8..=16 {
        let (g, w) = family
            .check_point(runtime.as_ref(), &[node_theta(i) + h * f64::from(k) / 8.0])
            .unwrap()
            .unwrap();
        for (name, (a, b)) in family.checked().iter().zip(g.iter().zip(&w)) {
            if name.starts_with(&prefix) {
                let e = if name.contains("_f") {
                    (a - b).abs()
                } else {
                    (a - b).abs() / b.abs()
                };
                worst = worst.max(e);
            }
        }
    }
    worst
}

/// A kink moved by half an interval fails the quick check wherever the move breaks
/// the off-grid promise (lookups next to it off by more than 1e-4); where it does not,
/// nothing is promised to catch it.
#[test]
#[ignore = "heavy (seconds to tens of seconds each): .ci/run runs the ignored tests"]
fn a_moved_kink_that_breaks_the_promise_fails_the_quick_check() {
    use lobefit::fits::shexp::{ShExpFamily, OFFGRID_REL};
    let bytes = std::fs::read("tables/data/shexp.lobefit").unwrap();
    let table = Table::from_bytes(&bytes).unwrap();
    let nc = table.meta().channels.len();
    let kinks: Vec<usize> = (0..table.values().len() / nc)
        .filter(|&n| table.values()[n * nc + 22] >= 0.0)
        .collect();
    let h = lobefit_tables::shexp::node_theta(1);
    let dir = tempfile::tempdir().unwrap();
    let family = ShExpFamily::default();
    let mut rng = Rng::new(0x41_4b);
    let mut picks = vec![kinks[0]];
    picks.extend((0..3).map(|_| kinks[(rng.next_u64() % kinks.len() as u64) as usize]));
    let mut required = 0;
    for node in picks {
        let (clean, moved) = (
            moved_kink_error(&table, node, 0.0),
            moved_kink_error(&table, node, 0.5 * h),
        );
        let report = check_bytes(&family, dir.path(), &corrupted(&table, node * nc + 22, 0.5 * h), OPTS);
        // A kink's move shows between the nodes: at the off-grid points too.
        let failed = max_failures(&report, true);
        println!(
            "shexp kink at node {node}: lookups err {clean:.2e}, moved h/2 {moved:.2e}: {}",
            failed.join("; ")
        );
        if moved > OFFGRID_REL {
            required += 1;
            assert!(
                !report.pass && !failed.is_empty(),
                "kink at node {node} moved by h/2 passes"
            );
        }
    }
    assert!(required > 0, "at least one moved kink breaks the promise");
}
