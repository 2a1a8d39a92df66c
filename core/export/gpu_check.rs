//! The GPU conformance's checks, described without a GPU: the kernels a family's
//! shader functions run in ([`Kernel`]), what a check sees ([`Context`]) and runs them
//! through ([`Runner`], implemented by the `lobefit-gpu` crate on a Vulkan device), and
//! the report's rows with their limits and difference metrics ([`Row`]). A family's
//! own checks live in `fits/<family>/gpu.rs` beside its textures; the GPU crate runs
//! whatever the entries list and names no family.

use crate::check::offgrid_metrics;
use crate::export::layout::{Filter, Sampler};
use crate::export::manifest::{FamilyEntry, TextureEntry};
use crate::export::Storage;
use crate::family::Checked;
use crate::rng::Rng;

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

/// A family's outputs at one point under the emulation (`mid`) and the least and
/// greatest over the hardware filter's weight roundings ([`Context::envelope`]).
#[derive(Debug, Clone)]
pub struct Envelope {
    /// The emulation's outputs.
    pub mid: Vec<f32>,
    /// Per output, the least over the roundings.
    pub lo: Vec<f32>,
    /// Per output, the greatest.
    pub hi: Vec<f32>,
}

impl Envelope {
    /// The span of `mid` (the emulation's outputs) and `others` (the same outputs
    /// under other emulations).
    pub fn of(mid: Vec<f32>, others: impl IntoIterator<Item = Vec<f32>>) -> Envelope {
        let (mut lo, mut hi) = (mid.clone(), mid.clone());
        for o in others {
            for (k, v) in o.into_iter().enumerate() {
                lo[k] = lo[k].min(v);
                hi[k] = hi[k].max(v);
            }
        }
        Envelope { mid, lo, hi }
    }

    /// How far `g` lies outside output `k`'s span (0 inside it).
    pub fn outside(&self, k: usize, g: f64) -> f64 {
        (f64::from(self.lo[k]) - g).max(g - f64::from(self.hi[k])).max(0.0)
    }
}

/// [`scaled_diff`] against the span of each output over the emulations: the
/// distance outside it, scaled as there by the `mid` values.
pub fn scaled_outside(got: &[Vec<f64>], env: &[Envelope]) -> (f64, usize) {
    let n = env.first().map_or(0, |e| e.mid.len());
    let mut worst = (0.0f64, 0);
    for k in 0..n {
        let range = env
            .iter()
            .map(|e| f64::from(e.mid[k]).abs())
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        for (g, e) in got.iter().zip(env) {
            let (g, w) = (g[k], f64::from(e.mid[k]));
            if g.is_nan() && w.is_nan() {
                continue;
            }
            let d = e.outside(k, g) / w.abs().max(FLOOR * range).max(f64::MIN_POSITIVE);
            let d = if d.is_nan() { f64::INFINITY } else { d };
            if d > worst.0 {
                worst = (d, k);
            }
        }
    }
    worst
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

/// How far a GPU's error against the reference may exceed the manifest's promise:
/// the promise was measured on the CPU emulation, which a GPU matches to ~TOL_CPU
/// relative in the outputs; lossy entries (promise = the measured error) need that
/// room.
pub const PROMISE_SLACK: f64 = 0.02;

/// Random inputs per world-space check (disk light with its quadrature reference, ISG
/// patches: four reference corners each, the wedge mat-vec).
pub const WORLD_SAMPLES: usize = 500;

/// Closed forms in f32 against their f64 references: largest |gpu − reference| over a
/// sample's outputs, relative to its largest |reference| (the families' own limits,
/// 1e-9 to 1e-12, are f64 targets below f32 resolution; they are reported beside).
/// f32 sums of up to 8 terms with Legendre coefficients up to 43 give ~2e-5 at worst
/// (measured: 8e-6); a wrong term errs by 1e-3 or more.
pub const TOL_CLOSED: f64 = 3e-5;

/// One compute kernel of the conformance (see `lobefit-gpu`'s kernel wrapper): the
/// body reads the point's inputs `x0, x1, …` (f32), samples textures through the shader
/// library (`T, S, P`; a second texture `T2, P2`) and writes `Y[o + k]` for
/// `k < n_out`.
#[derive(Debug, Clone)]
pub struct Kernel {
    /// Name in reports.
    pub name: String,
    /// The family's textures it binds, as indices in `grids` order: none (closed
    /// forms), one (`T, S, P`) or two (`T2, P2` besides).
    pub textures: Vec<usize>,
    /// WGSL body.
    pub body: String,
    /// Outputs per point.
    pub n_out: usize,
}

impl Kernel {
    /// A kernel named `name` over the textures `textures`.
    pub fn new(name: &str, textures: &[usize], body: &str, n_out: usize) -> Kernel {
        Kernel {
            name: name.into(),
            textures: textures.to_vec(),
            body: body.into(),
            n_out,
        }
    }
}

/// Runs kernels on a device, with the family's textures bound and filtered as the
/// check at hand says.
pub trait Runner {
    /// `kernel` over `inputs` (each point's values rounded to f32): the outputs per
    /// point, widened to f64.
    fn run(&self, kernel: &Kernel, inputs: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, String>;
}

/// What a textured family's check sees: the family, its export and the filter.
pub struct Context<'a> {
    /// The family's queries and reference.
    pub family: &'a dyn Checked,
    /// Its manifest entry (the promises).
    pub entry: &'a FamilyEntry,
    /// Its textures as exported, in `grids` order.
    pub textures: &'a [TextureEntry],
    /// The CPU emulation of those textures under [`Context::emu_filter`].
    pub samplers: &'a [Sampler],
    /// The same with the hardware filter's weights rounded down or up per axis, every
    /// corner (8-bit hardware emulation; empty otherwise): a device's unit may round
    /// either way ([`crate::export::layout::WeightRounding`]), so it is held to the
    /// span.
    pub alternatives: &'a [Vec<Sampler>],
    /// The filter the device samples with.
    pub filter: Filter,
    /// The filter the emulation applies (the device's hardware filter as it weights).
    pub emu_filter: Filter,
    /// Texel storage.
    pub storage: Storage,
    /// The export's `--scale`.
    pub scale: f64,
    /// The manifest's off-grid sample count.
    pub samples: usize,
    /// The manifest's seed.
    pub seed: u64,
}

impl Context<'_> {
    /// `eval` at `x` under the emulation, and per output the least and greatest value
    /// over the emulation and its [`Context::alternatives`].
    pub fn envelope(&self, eval: fn(&[Sampler], &[f32]) -> Vec<f32>, x: &[f32]) -> Envelope {
        Envelope::of(eval(self.samplers, x), self.alternatives.iter().map(|alt| eval(alt, x)))
    }

    /// The index of the texture whose file stem is `stem`.
    pub fn texture(&self, stem: &str) -> Result<usize, String> {
        self.textures
            .iter()
            .position(|e| e.file.split('.').next() == Some(stem))
            .ok_or_else(|| format!("{}: the export lacks texture {stem}", self.entry.family))
    }
    /// The manifest's promise for `output` and `metric` under the device's filter.
    pub fn promise(&self, output: &str, metric: &str) -> Option<f64> {
        self.entry
            .error
            .iter()
            .find(|p| p.filter == self.filter && p.output == output && p.metric == metric)
            .map(|p| p.promise)
    }
    /// The family's largest off-grid limit of the outputs `output` starts with.
    pub fn offgrid_limit(&self, output: &str) -> Option<f64> {
        self.family
            .thresholds()
            .iter()
            .filter(|t| t.output.starts_with(output) && t.metric.starts_with("offgrid."))
            .map(|t| t.limit)
            .reduce(f64::max)
    }
}

/// A check of a textured family beyond its lookup, per filter: rows of the report
/// (none where it does not apply to this export).
pub type TexturedCheck = fn(&Context, &dyn Runner) -> Result<Vec<Row>, String>;

/// The checks of a table a shader evaluates in closed form: (runner with no texture,
/// samples, seed) → rows.
pub type ClosedCheck = fn(&dyn Runner, usize, u64) -> Result<Vec<Row>, String>;

/// A point on the unit sphere, uniform.
pub fn unit(rng: &mut Rng) -> lobefit_tables::glam::DVec3 {
    loop {
        let v = lobefit_tables::glam::DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

/// f64 rounded to f32 and back: the inputs the GPU gets.
pub fn r32(v: f64) -> f64 {
    v as f32 as f64
}

/// A closed form (no texture) on the GPU: `body` over the family's inputs, against
/// `cpu` (the runtime's f64 function) and the family's reference with its off-grid
/// thresholds (reported beside; the row holds [`TOL_CLOSED`]).
pub fn closed_row(
    runner: &dyn Runner,
    name: &str,
    family: &dyn Checked,
    body: &str,
    cpu: &dyn Fn(&[f64]) -> Vec<f64>,
    samples: usize,
    seed: u64,
) -> Result<Row, String> {
    let mut rng = Rng::new(seed);
    let points: Vec<Vec<f64>> = (0..samples)
        .map(|_| family.sample(&mut rng).iter().map(|&v| r32(v)).collect())
        .collect();
    let outputs = family.outputs();
    let got = runner.run(&Kernel::new(name, &[], body, outputs.len()), &points)?;
    let want_cpu: Vec<Vec<f64>> = points.iter().map(|x| cpu(x)).collect();
    let refs: Vec<Vec<f64>> = points
        .iter()
        .map(|x| family.reference(x))
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{name}: {e}"))?;
    let vs_ref = vec![(
        "max |error| / max |ref| of the vector".to_string(),
        vector_diff(&got, &refs),
        TOL_CLOSED,
    )];
    let mut info = Vec::new();
    for (k, o) in outputs.iter().enumerate() {
        let abs: Vec<f64> = got.iter().zip(&refs).map(|(g, w)| (g[k] - w[k]).abs()).collect();
        let rel: Vec<f64> = got
            .iter()
            .zip(&refs)
            .map(|(g, w)| crate::check::rel_err(g[k], w[k]))
            .collect();
        for (metric, v, limit) in offgrid_metrics(family, o, abs, rel) {
            info.push((format!("{o} {}", metric.trim_start_matches("offgrid.")), v, limit));
        }
    }
    Ok(Row {
        function: name.into(),
        storage: "-".into(),
        filter: "-".into(),
        samples: points.len(),
        vs_cpu: vector_diff(&got, &want_cpu),
        cpu_what: "runtime f64",
        vs_ref,
        info,
    })
}

/// A kernel body writing the `n` entries of the array `call` returns.
pub fn write_array(call: &str, n: usize) -> String {
    format!("    let z = {call};\n    for (var k = 0u; k < {n}u; k++) {{\n        Y[o + k] = z[k];\n    }}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The comparison metrics: relative above the floor, absolute (× range) below it.
    #[test]
    fn diff_metrics() {
        let want = vec![vec![1.0, 100.0], vec![0.0, 50.0]];
        let got = vec![vec![1.0 + 1e-5, 100.0], vec![1e-4, 50.0]];
        let (d, k) = scaled_diff(&got, &want);
        // Output 0: 1e-5 relative at 1.0; 1e-4 at 0.0 against the floor 1e-2 · 1.0.
        assert!((d - 1e-2).abs() < 1e-12 && k == 0, "{d} {k}");
        // Row 2: 1e-4 against its largest entry 50.
        assert!((vector_diff(&got, &want) - 2e-6).abs() < 1e-15);
    }
}
