//! The report of `lobefit-gpu`: one row per function, storage and filter, its
//! limits, and the difference metrics the rows hold.

/// GPU against the CPU emulation of the same texture and filter (or, for closed
/// forms, the runtime's f64 function): largest |gpu − cpu| / max(|cpu|, FLOOR · the
/// output's largest |cpu| over the samples). The GPU's exp, log, sin, asinh carry a
/// few f32 ulps (Vulkan allows 3 ulp and more), the mappings amplify them by the
/// axis's node count (an ulp of a coordinate in [0, n)); 1e-4 bounds that with
/// margin, while an indexing, packing or formula bug errs by 1e-3 or more.
pub const TOL_CPU: f64 = 1e-4;
/// Values below this fraction of an output's range count as that fraction: relative
/// differences of values near a zero crossing mean nothing (disk-light's c_22 crosses
/// zero where its texels change fast: an ulp of the GPU's log in the rim coordinate
/// moves it 1e-6 of its range, 1e-4 of a value at 1e-3 of the range).
pub const FLOOR: f64 = 1e-2;
/// One row of the report.
#[derive(Debug, Clone)]
pub struct Row {
    /// Family or function.
    pub function: String,
    /// Texel storage ("-" for closed forms).
    pub storage: String,
    /// Filter ("-" for closed forms and exact fetches).
    pub filter: String,
    /// Samples.
    pub samples: usize,
    /// GPU against the CPU emulation / f64 function (see [`TOL_CPU`]).
    pub vs_cpu: f64,
    /// What `vs_cpu` compares with.
    pub cpu_what: &'static str,
    /// GPU against the reference: (quantity metric, measured, limit).
    pub vs_ref: Vec<(String, f64, f64)>,
    /// Reported beside, not held: (quantity metric, measured, the family's f64 target).
    pub info: Vec<(String, f64, f64)>,
}

impl Row {
    /// Whether the row meets its limits.
    pub fn pass(&self) -> bool {
        self.vs_cpu <= TOL_CPU && self.vs_ref.iter().all(|(_, m, l)| *m <= *l)
    }
}

/// Largest scaled difference of `got` against `want` (rows of outputs), see [`TOL_CPU`],
/// and the output where it occurs.
pub fn scaled_diff(got: &[Vec<f64>], want: &[Vec<f64>]) -> (f64, usize) {
    let n = want.first().map_or(0, |w| w.len());
    let mut worst = (0.0f64, 0);
    for k in 0..n {
        let range = want
            .iter()
            .map(|w| w[k].abs())
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        for (g, w) in got.iter().zip(want) {
            let (g, w) = (g[k], w[k]);
            if g.is_nan() && w.is_nan() {
                continue;
            }
            let d = (g - w).abs() / w.abs().max(FLOOR * range).max(f64::MIN_POSITIVE);
            let d = if d.is_nan() { f64::INFINITY } else { d };
            if d > worst.0 {
                worst = (d, k);
            }
        }
    }
    worst
}

/// Largest |got − want| of a row relative to the row's largest |want| (vectors whose
/// entries share one scale: SH, ZH and eigenvalue vectors).
pub fn vector_diff(got: &[Vec<f64>], want: &[Vec<f64>]) -> f64 {
    let mut worst = 0.0f64;
    for (g, w) in got.iter().zip(want) {
        let scale = w.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(f64::MIN_POSITIVE);
        for (a, b) in g.iter().zip(w) {
            let d = (a - b).abs() / scale;
            worst = worst.max(if d.is_nan() { f64::INFINITY } else { d });
        }
    }
    worst
}
