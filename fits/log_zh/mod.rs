//! log-ZH vectors (Giraud & Nowrouzezahrai 2015 §4.5.2, §4.6): the table of
//! normalised-Phong log-ZH vectors over (r, ε), the diffuse and blocker views, and
//! the references the checker uses.
//!
//! Values: the runtime's closed forms (`lobefit_tables::log_zh`, derivation there),
//! evaluated in f64 at every node. Each entry's residual is its largest distance to
//! a composite Gauss–Legendre projection of log max(f, ε) (a fixed rule, see
//! `gl_log_zh`), so a wrong closed form cannot be written. Reference (checker): the checker's adaptive
//! Gauss–Kronrod projection of the definition, split at the horizon and at t_ε.

pub mod eps_study;
pub mod gpu;

use std::f64::consts::PI;

use lobefit_tables::format::Threshold;
use lobefit_tables::log_zh::{self as rt, Kind, LogZh, CHANNELS, EPS_MAX, EPS_MIN, R_TABLE_MAX, STORED_CHANNELS};
use lobefit_tables::sh::MAX_ORDER;
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};

use lobefit_core::family::{Checked, EvalFlag, Fit, Fitted, Lookup, View};
use lobefit_core::rng::Rng;
use lobefit_core::sh::legendre_seq;
use lobefit_tables::error::short;

/// Largest allowed |closed form − Gauss–Legendre| for an entry to be written.
const MAX_RESIDUAL: f64 = 1e-9;
/// Absolute tolerance of the checker's Gauss–Kronrod reference: 100× below the
/// checked threshold.
pub const REFERENCE_TOL: f64 = 1e-13;
/// Checked accuracy (absolute; |z| ≤ 17 so this is ≤ 1e-9 relative for |z| ≥ 1, and
/// the absolute reading the target allows where values are ~0).
pub const ACCURACY_ABS: f64 = 1e-9;

/// Checked quantities: the closed-form outputs z*, and t* = the stored table at the
/// nearest integer r (its rows), interpolated in ln ε.
const CHECKED: [&str; 2 * MAX_ORDER] = [
    "z0", "z1", "z2", "z3", "z4", "z5", "z6", "z7", "t0", "t1", "t2", "t3", "t4", "t5", "t6", "t7",
];
const TABLE_CHECKED: [&str; MAX_ORDER] = ["t0", "t1", "t2", "t3", "t4", "t5", "t6", "t7"];
/// Third lookup coordinate selecting the stored table instead of the closed form
/// (only the checker passes it; eval rows have two coordinates).
const TABLE_MODE: f64 = 1.0;
/// What interpolation of the stored grid in ln ε may cost between nodes, at integer r
/// (absolute; measured ≤ 3.5e-4, see tests/it/log_zh.rs and the checker).
pub const TABLE_INTERP_ABS: f64 = 1e-3;

/// Default SH order of `lobefit eval` (docs/math.md §1).
pub const DEFAULT_ORDER: usize = 4;

/// `eval log-zh|wedge|wrap --order N`.
pub const ORDER_FLAG: EvalFlag = EvalFlag {
    name: "order",
    help: "1..=8 (bands 0..N-1; default 4)",
    count: true,
};

/// The log-ZH family: `kind` and `order` select the `lobefit eval` view; the
/// registry's instance (Phong, order 8) builds and checks the table.
#[derive(Debug, Clone, Copy)]
pub struct LogZhFamily {
    /// Which function is log-projected.
    pub kind: Kind,
    /// SH order n (outputs z0..z(n−1)).
    pub order: usize,
}

impl Default for LogZhFamily {
    fn default() -> Self {
        LogZhFamily {
            kind: Kind::Phong,
            order: MAX_ORDER,
        }
    }
}

impl LogZhFamily {
    /// The eval view for `--kind` (default phong) and `--order` (default 4, docs/math.md §1).
    pub fn from_flags(kind: Option<&str>, order: Option<usize>) -> Result<Self, String> {
        let kind = match kind.unwrap_or("phong") {
            "diffuse" => Kind::Diffuse,
            "phong" => Kind::Phong,
            "blocker" => Kind::Blocker,
            other => return Err(format!("log-zh: unknown --kind {other} (diffuse|phong|blocker)")),
        };
        let order = order.unwrap_or(DEFAULT_ORDER);
        if !(1..=MAX_ORDER).contains(&order) {
            return Err(format!("log-zh: --order {order} is outside 1..=8"));
        }
        Ok(LogZhFamily { kind, order })
    }
}

/// log max(f(s), ε) of the Phong lobe at s = cosθ (log ε below the horizon).
fn log_phong(eps: f64, r: f64, s: f64) -> f64 {
    if s <= 0.0 {
        eps.ln()
    } else {
        ((r + 1.0) / (2.0 * PI)).ln().max(f64::MIN) + r * s.ln()
    }
    .max(eps.ln())
}

/// t_ε clamped to [0, 1] (where the Phong lobe crosses ε).
fn t_eps(eps: f64, r: f64) -> f64 {
    (((2.0 * PI * eps).ln() - (r + 1.0).ln()) / r).exp().min(1.0)
}

/// The zonal integrand and its break points, for a kind at (ε, param).
fn zonal(kind: Kind, eps: f64, param: f64) -> (Box<dyn Fn(f64) -> f64>, Vec<f64>) {
    match kind {
        Kind::Diffuse | Kind::Phong => {
            let r = if kind == Kind::Diffuse { 1.0 } else { param };
            (Box::new(move |s| log_phong(eps, r, s)), vec![0.0, t_eps(eps, r)])
        }
        Kind::Blocker => {
            let c = param.cos();
            (Box::new(move |s| if s > c { eps.ln() } else { 0.0 }), vec![c])
        }
    }
}

/// Checker reference: z_l = 2π ∫ g(s) y_l^0(s) ds by adaptive Gauss–Kronrod.
pub fn reference_log_zh(kind: Kind, eps: f64, param: f64, order: usize) -> Result<Vec<f64>, String> {
    if !(EPS_MIN..=EPS_MAX).contains(&eps) {
        return Err(format!(
            "eps = {eps} is outside [{EPS_MIN}, {EPS_MAX}]",
            eps = short(eps)
        ));
    }
    match kind {
        Kind::Phong if !(rt::R_MIN..=rt::R_MAX).contains(&param) => {
            return Err(format!(
                "r = {param} is outside [{}, {}]",
                rt::R_MIN,
                rt::R_MAX,
                param = short(param)
            ))
        }
        Kind::Blocker if !(0.0..=PI).contains(&param) => {
            return Err(format!("theta_b = {param} is outside [0, π]", param = short(param)))
        }
        _ => {}
    }
    if matches!(kind, Kind::Diffuse | Kind::Phong) && t_eps(eps, if kind == Kind::Diffuse { 1.0 } else { param }) >= 1.0
    {
        // f ≤ eps everywhere: g ≡ ln eps, whose projection is exactly √(4π) ln eps δ_l0
        // by orthogonality. Quadrature would return rounding noise (~1e-17) for l ≥ 1,
        // against which the exact zeros of the runtime show a meaningless relative error 1.
        let mut z = vec![0.0; order];
        z[0] = (4.0 * PI).sqrt() * eps.ln();
        return Ok(z);
    }
    // A process checking several copies of a table (the corruption sweep) asks the
    // same nodes again: the quadrature is memoised by its inputs' bits.
    static MEMO: lobefit_core::memo::Memo<4, Vec<f64>> = lobefit_core::memo::Memo::new();
    let key = [kind as u8 as f64, eps, param, order as f64];
    MEMO.get(key, || {
        let (g, breaks) = zonal(kind, eps, param);
        let (z, ok) = lobefit_core::sh::zh_project_gk(order, g, &breaks, REFERENCE_TOL);
        if !ok {
            return Err(format!(
                "reference quadrature did not converge at eps={eps}, param={param}"
            ));
        }
        Ok(z)
    })
}

/// Gauss–Legendre points per piece of the fit's cross-check.
const GL_POINTS: usize = 24;

/// The fit's cross-check: the Phong projection by composite Gauss–Legendre (a fixed
/// rule, independent of the checker's adaptive Gauss–Kronrod). Exact on [−1, t_ε]
/// (a constant times P_l); on [t_ε, 1] the integrand ln(s/t_ε) P_l(s) is analytic
/// with its singularity at s = 0, so pieces [t, 2t], [2t, 4t], … keep it one piece
/// length away and 24 points converge to rounding.
fn gl_log_zh(eps: f64, r: f64, order: usize) -> (Vec<f64>, u32) {
    let (x, w) = lobefit_core::sh::gauss_legendre(GL_POINTS);
    let t = t_eps(eps, r);
    let mut pieces = vec![(-1.0, t)];
    let mut a = t;
    while a < 1.0 {
        let b = (2.0 * a).min(1.0);
        pieces.push((a, b));
        a = b;
    }
    let mut z = vec![0.0; order];
    let mut evals = 0;
    for (a, b) in pieces {
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        for (xi, wi) in x.iter().zip(&w) {
            let s = c + h * xi;
            let g = log_phong(eps, r, s);
            for (zl, p) in z.iter_mut().zip(legendre_seq(s)) {
                *zl += h * wi * g * p;
            }
            evals += 1;
        }
    }
    for (l, zl) in z.iter_mut().enumerate() {
        *zl *= (PI * (2 * l + 1) as f64).sqrt(); // 2π √((2l+1)/4π)
    }
    (z, evals)
}

/// Runtime view: the closed forms of the runtime crate, sliced to the order.
struct LogZhLookup {
    rt: LogZh,
    kind: Kind,
    order: usize,
}

impl Lookup for LogZhLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let mut out = [0.0; MAX_ORDER];
        if self.kind == Kind::Phong && x.len() == 3 && x[2] == TABLE_MODE {
            // The checker's view of the stored table (see `check_point`).
            self.rt.table_lookup(self.order, x[0], x[1], &mut out)?;
            return Ok(out[..self.order].to_vec());
        }
        let param = if self.kind == Kind::Diffuse { 1.0 } else { x[1] };
        self.rt.lookup(self.kind, self.order, x[0], param, &mut out)?;
        Ok(out[..self.order].to_vec())
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        let mut out = [0.0f32; MAX_ORDER];
        let r = if self.kind == Kind::Phong && x.len() == 3 && x[2] == TABLE_MODE {
            self.rt.table_lookup_f32(self.order, x[0] as f32, x[1] as f32, &mut out)
        } else {
            let param = if self.kind == Kind::Diffuse { 1.0 } else { x[1] as f32 };
            self.rt.lookup_f32(self.kind, self.order, x[0] as f32, param, &mut out)
        };
        Some(r.map(|()| out[..self.order].iter().map(|&v| v.into()).collect()))
    }
}

impl View for LogZhFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        match self.kind {
            Kind::Diffuse => &["eps"],
            Kind::Phong => &["eps", "r"],
            Kind::Blocker => &["eps", "theta_b"],
        }
    }
    fn outputs(&self) -> &'static [&'static str] {
        &CHANNELS[..self.order]
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::LOG_ZH
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(LogZhLookup {
            rt: LogZh::from_table(table)?,
            kind: self.kind,
            order: self.order,
        }))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let param = if self.kind == Kind::Diffuse { 1.0 } else { x[1] };
        reference_log_zh(self.kind, x[0], param, self.order)
    }
}

impl Checked for LogZhFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        let mut t = Vec::new();
        let mut add = |output: &str, metric: &str, limit: f64| {
            t.push(Threshold {
                output: output.into(),
                metric: metric.into(),
                limit,
            })
        };
        for (z, s) in CHANNELS.iter().zip(TABLE_CHECKED) {
            add(z, "grid.max_abs", ACCURACY_ABS);
            add(z, "offgrid.max_abs", ACCURACY_ABS);
            add(s, "grid.max_abs", ACCURACY_ABS);
            add(s, "offgrid.max_abs", TABLE_INTERP_ABS);
        }
        t
    }
    fn checked(&self) -> &'static [&'static str] {
        &CHECKED
    }
    /// z*: the runtime's closed form; t*: the stored table, bilinearly interpolated
    /// (exactly the stored pair at grid nodes), both against the GK reference.
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let mut got = runtime.lookup(x).map_err(|e| format!("lookup at {x:?}: {e}"))?;
        let mut want = self.reference(x).map_err(|e| format!("reference at {x:?}: {e}"))?;
        // The table's rows are integer exponents: check it there (the node itself on
        // the grid), interpolated in ln ε only.
        let xi = [x[0], x[1].round()];
        let stored = runtime
            .lookup(&[xi[0], xi[1], TABLE_MODE])
            .map_err(|e| format!("table lookup at {xi:?}: {e}"))?;
        got.extend(stored);
        want.extend(self.reference(&xi).map_err(|e| format!("reference at {xi:?}: {e}"))?);
        Ok(Some((got, want)))
    }
    fn node_inputs(&self, node: &[f64]) -> Vec<Vec<f64>> {
        // Axes are (r, eps); inputs are (eps, r).
        vec![vec![node[1], node[0]]]
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        let eps = rng.range(EPS_MIN, EPS_MAX);
        match self.kind {
            Kind::Diffuse => vec![eps],
            // Log-uniform in r: small exponents (the interesting, wide lobes) get their share.
            Kind::Phong => vec![eps, rng.range(0.0, R_TABLE_MAX.ln()).exp()],
            Kind::Blocker => vec![eps, rng.range(0.0, PI)],
        }
    }
}

impl Fit for LogZhFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        "Log-ZH vectors z_l = ∫ ln(max(f, eps)) y_l^0 dω, l < 8, of the normalised Phong lobe \
         f = (r+1)/(2π) cos^r θ (ln eps below the horizon); r = 1 is the diffuse BRDF cos θ/π. \
         Rows r = 1..128 (integer), columns eps = 0.01..0.99 (128 nodes uniform in ln eps). The runtime's closed \
         forms (lobefit_tables::log_zh::phong, any real r and eps) are exact; this grid is for \
         texture upload."
            .into()
    }
    fn axes(&self) -> Vec<Axis> {
        rt::axes()
    }
    fn channels(&self) -> Vec<Channel> {
        STORED_CHANNELS
            .iter()
            .enumerate()
            .map(|(k, n)| Channel {
                name: n.to_string(),
                unit: "1".into(),
                encoding: Encoding::Linear,
                description: if k % 2 == 0 {
                    format!("f32 rounding of z_{} = ∫ ln(max(f, eps)) y_{}^0 dω", k / 2, k / 2)
                } else {
                    format!("z_{} − z{}_hi, rounded to f32", k / 2, k / 2)
                },
            })
            .collect()
    }
    fn method(&self) -> String {
        "closed form in t_eps = (2π eps/(r+1))^(1/r), cross-checked by composite Gauss-Legendre".into()
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("gl_points".into(), GL_POINTS.to_string()),
            ("max_residual".into(), format!("{MAX_RESIDUAL:e}")),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "max over l of |closed form − composite Gauss–Legendre projection|"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let (r, eps) = (node[0], node[1]);
        let mut z = [0.0; MAX_ORDER];
        let exact = rt::phong(eps, r, MAX_ORDER, &mut z);
        let (q, evals) = gl_log_zh(eps, r, MAX_ORDER);
        let residual = z.iter().zip(&q).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let values = z
            .iter()
            .flat_map(|&v| {
                let hi = v as f32;
                [hi as f64, (v - hi as f64) as f32 as f64]
            })
            .collect();
        Fitted {
            values,
            residual,
            iterations: evals,
            converged: exact.is_ok() && residual <= MAX_RESIDUAL,
        }
    }
}

/// log-zh in the list of families (`crate::entries`): `eval log-zh --kind K
/// --order N`; closed forms on the GPU.
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| vec![Box::new(LogZhFamily::default())],
    eval: Some(|_, flags, _| {
        Ok(Box::new(LogZhFamily::from_flags(
            flags.text("kind").as_deref(),
            flags.count("order")?,
        )?))
    }),
    eval_names: &[],
    eval_flags: &[(
        rt::KIND,
        &[
            EvalFlag {
                name: "kind",
                help: "diffuse | phong | blocker (default phong)",
                count: false,
            },
            ORDER_FLAG,
        ],
    )],
    gpu: &[],
    closed_form: Some(gpu::CLOSED),
    plot: Some(("log-zh", eps_study::plot)),
    eval_help: "\
log-zh  [--kind diffuse|phong|blocker] (default phong)  [--order N] (1..8, default 4)
  in   `eps`      clamp ε of the log, [0.01, 0.99]
       `r`        (phong) normalised Phong exponent, ≥ 1
       `theta_b`  (blocker) angular radius of a spherical blocker (rad)
  out  `z0` … `z7`  (the first N) zonal coefficients ∫ ln(max(f, ε)) y_l^0 dω of
                  the clamped function's log, axis +z
",
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms vs the checker's quadrature at off-grid points of every kind.
    #[test]
    fn closed_forms_match_quadrature() {
        let mut worst: f64 = 0.0;
        for &eps in &[0.01, 0.0437, 0.2, 0.3184, 0.5, 0.9, 0.99] {
            for &(kind, p) in &[
                (Kind::Diffuse, 1.0),
                (Kind::Phong, 1.0),
                (Kind::Phong, 2.0),
                (Kind::Phong, 3.7),
                (Kind::Phong, 64.0),
                (Kind::Phong, 128.0),
                (Kind::Phong, 1000.0),
                (Kind::Blocker, 0.01),
                (Kind::Blocker, 0.7),
                (Kind::Blocker, 1.5706),
                (Kind::Blocker, 2.9),
            ] {
                let want = reference_log_zh(kind, eps, p, 8).unwrap();
                let mut got = [0.0; 8];
                closed_form(kind, eps, p, &mut got);
                for l in 0..8 {
                    let e = (got[l] - want[l]).abs();
                    worst = worst.max(e);
                    assert!(
                        e < ACCURACY_ABS && e <= 1e-9 * want[l].abs().max(1e-3),
                        "{kind:?} eps={eps} p={p} l={l}: {} vs {}",
                        got[l],
                        want[l]
                    );
                }
            }
        }
        eprintln!("log-zh closed forms vs GK: max abs {worst:.2e}");
    }

    fn closed_form(kind: Kind, eps: f64, p: f64, out: &mut [f64]) {
        match kind {
            Kind::Diffuse => rt::diffuse(eps, 8, out),
            Kind::Phong => rt::phong(eps, p, 8, out),
            Kind::Blocker => rt::blocker(eps, p, 8, out),
        }
        .unwrap()
    }

    #[test]
    fn fit_converges_at_corners() {
        let f = LogZhFamily::default();
        for node in [[1.0, 0.01], [1.0, 0.99], [128.0, 0.01], [128.0, 0.99], [5.0, 0.5]] {
            let fit = f.fit(&node);
            assert!(fit.converged, "{node:?}: {fit:?}");
        }
    }
}
