//! log-ZH on the GPU: the diffuse, Phong and blocker vectors in closed form (order 8),
//! no texture.

use lobefit_tables::log_zh::{self as rt, Kind};

use lobefit_core::export::families::ClosedForm;
use lobefit_core::export::gpu_check::{closed_row, write_array, Kernel};
use lobefit_core::family::Checked;
use lobefit_core::rng::Rng;

use super::LogZhFamily;

/// Each kind's report name and shader call (order 8).
const KINDS: [(Kind, &str, &str); 3] = [
    (Kind::Diffuse, "log-zh diffuse", "lf_log_zh_diffuse(x0, 8u)"),
    (Kind::Phong, "log-zh phong", "lf_log_zh_phong(x0, x1, 8u)"),
    (Kind::Blocker, "log-zh blocker", "lf_log_zh_blocker(x0, x1, 8u)"),
];

/// The closed forms and their conformance.
pub const CLOSED: ClosedForm = ClosedForm {
    kind: rt::KIND,
    formula:
        "diffuse, Phong and blocker log-ZH vectors in closed form (lobefit_tables::log_zh::{diffuse, phong, blocker})",
    checks: |runner, samples, seed| {
        KINDS
            .iter()
            .map(|&(kind, name, call)| {
                let cpu = move |x: &[f64]| {
                    let mut o = vec![0.0; 8];
                    let r = match kind {
                        Kind::Diffuse => rt::diffuse(x[0], 8, &mut o),
                        Kind::Phong => rt::phong(x[0], x[1], 8, &mut o),
                        Kind::Blocker => rt::blocker(x[0], x[1], 8, &mut o),
                    };
                    r.map(|_| o).unwrap_or(vec![f64::NAN; 8])
                };
                let family = LogZhFamily { kind, order: 8 };
                closed_row(runner, name, &family, &write_array(call, 8), &cpu, samples, seed)
            })
            .collect()
    },
    // Phong and blocker (diffuse is Phong at r = 1).
    timed: |count, seed| {
        KINDS[1..]
            .iter()
            .map(|&(kind, name, call)| {
                let mut rng = Rng::new(seed);
                let family = LogZhFamily { kind, order: 8 };
                let points = (0..count).map(|_| family.sample(&mut rng)).collect();
                (
                    Kernel::new(&format!("{name} (n 8)"), &[], &write_array(call, 8), 8),
                    points,
                )
            })
            .collect()
    },
};
