//! wrap lighting (Yuan, Nowrouzezahrai & Sloan 2012 §3): the λ̂_l(a) table
//! (kind `wrap`, for texture upload) and `lobefit eval wrap --order N`.
//!
//! The runtime computes λ̂_l(a) = 2 ∫_{max(−a,−1)}^1 ((t+a)/(1+a))^{1+a} P_l(t) dt in
//! closed form for every band (`lobefit_tables::wrap::lambda_hat`, derivation there),
//! so no table is *needed*; the file exists for GPU upload and so the family can be
//! built, checked and evaluated like the others. Fit of a node: the definition by the
//! fit's adaptive Simpson; the residual is its distance to the closed form. Reference
//! (checker): the definition by adaptive Gauss–Kronrod, valid for any a ≥ 0 (so it
//! also shows erratum E5: the published form is wrong for a > 1).

pub mod gpu;

use lobefit_tables::format::Threshold;
use lobefit_tables::sh::MAX_ORDER;
use lobefit_tables::wrap::{self as rt, Wrap, A_MAX, A_MIN, A_NODES, CHANNELS};
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};

use lobefit_core::family::{Checked, Fit, Fitted, Lookup, View};
use lobefit_core::quad::{adaptive_simpson, gauss_kronrod};
use lobefit_core::rng::Rng;
// P_l by the three-term recurrence (not the runtime's monomial expansion).
use lobefit_core::sh::legendre;

/// Absolute tolerance of the fit's adaptive Simpson per band.
const FIT_TOL: f64 = 1e-13;
/// Largest |Simpson − closed form| for a node to be written.
const MAX_RESIDUAL: f64 = 1e-10;
/// Absolute tolerance of the checker's Gauss–Kronrod reference (|λ̂| ≤ 1.34).
pub const REFERENCE_TOL: f64 = 1e-15;
/// Acceptance: published closed form (l ≤ 2) vs quadrature.
pub const CLOSED_LOW_ABS: f64 = 1e-12;
/// Acceptance: higher bands (3 ≤ l < 8) vs an independent quadrature.
pub const CLOSED_HIGH_ABS: f64 = 1e-10;
/// Linear interpolation of the 129-node f32 table between nodes (absolute; h²/8·|λ̂''|
/// with h = 1/128 plus f32 rounding; measured by the checker, see docs/rigs.md).
pub const TABLE_INTERP_ABS: f64 = 2e-5;
/// Stored f32 nodes vs the reference (f32 rounding of values ≤ 1.34).
pub const TABLE_NODE_ABS: f64 = 2e-7;

/// Checked quantities: closed form l0..l7 and the interpolated table t0..t7.
const CHECKED: [&str; 2 * MAX_ORDER] = [
    "l0", "l1", "l2", "l3", "l4", "l5", "l6", "l7", "t0", "t1", "t2", "t3", "t4", "t5", "t6", "t7",
];
/// Second lookup coordinate selecting the stored table (checker only).
const TABLE_MODE: f64 = 1.0;
/// Second lookup coordinate selecting the closed form at order 8 (checker only).
const CLOSED_MODE: f64 = 2.0;

/// Default SH order of `lobefit eval wrap` (docs/math.md §1).
pub const DEFAULT_ORDER: usize = 4;

/// The wrap family; `order` selects the eval view (the registry's instance is order 8).
#[derive(Debug, Clone, Copy)]
pub struct WrapFamily {
    /// SH order n (outputs l0..l(n−1)).
    pub order: usize,
}

impl Default for WrapFamily {
    fn default() -> Self {
        WrapFamily { order: MAX_ORDER }
    }
}

/// The wrap kernel f(t | a) (zero below t = −a).
pub fn kernel(t: f64, a: f64) -> f64 {
    if t <= -a {
        0.0
    } else {
        ((t + a) / (1.0 + a)).powf(1.0 + a)
    }
}

/// λ̂_l(a), l < `order`, by the checker's adaptive Gauss–Kronrod of the definition,
/// for any a ≥ 0 (support cut at t = −1 for a > 1).
pub fn reference_lambda(a: f64, order: usize) -> Result<Vec<f64>, String> {
    if !a.is_finite() || a < 0.0 {
        return Err(format!("a = {a} must be a finite number ≥ 0"));
    }
    if !(1..=MAX_ORDER).contains(&order) {
        return Err(format!("order {order} is outside 1..=8"));
    }
    let lo = (-a).max(-1.0);
    (0..order)
        .map(|l| {
            let q = gauss_kronrod(
                |t| kernel(t, a) * legendre(l, t),
                lo,
                1.0,
                &[],
                REFERENCE_TOL,
                0.0,
                2000,
            );
            if q.converged {
                Ok(2.0 * q.value)
            } else {
                Err(format!("reference quadrature did not converge at a = {a}, l = {l}"))
            }
        })
        .collect()
}

/// The fit's λ̂_l(a) (adaptive Simpson), l < 8, and the integrand evaluations.
fn simpson_lambda(a: f64) -> (Vec<f64>, u32, bool) {
    let mut evals = 0;
    let mut ok = true;
    let v = (0..MAX_ORDER)
        .map(|l| {
            let q = adaptive_simpson(|t| kernel(t, a) * legendre(l, t), -a, 1.0, &[], FIT_TOL, 40);
            evals += q.evals;
            ok &= q.converged;
            2.0 * q.value
        })
        .collect();
    (v, evals, ok)
}

struct WrapLookup {
    rt: Wrap,
    order: usize,
}

impl Lookup for WrapLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let mut out = [0.0; MAX_ORDER];
        match x.get(1) {
            Some(&TABLE_MODE) => {
                self.rt.table_lookup(MAX_ORDER, x[0], &mut out)?;
                Ok(out.to_vec())
            }
            Some(&CLOSED_MODE) => {
                self.rt.lookup(MAX_ORDER, x[0], &mut out)?;
                Ok(out.to_vec())
            }
            _ => {
                self.rt.lookup(self.order, x[0], &mut out)?;
                Ok(out[..self.order].to_vec())
            }
        }
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        let mut out = [0.0f32; MAX_ORDER];
        let a = x[0] as f32;
        let (r, n) = match x.get(1) {
            Some(&TABLE_MODE) => (self.rt.table_lookup_f32(MAX_ORDER, a, &mut out), MAX_ORDER),
            Some(&CLOSED_MODE) => (self.rt.lookup_f32(MAX_ORDER, a, &mut out), MAX_ORDER),
            _ => (self.rt.lookup_f32(self.order, a, &mut out), self.order),
        };
        Some(r.map(|()| out[..n].iter().map(|&v| v.into()).collect()))
    }
}

impl View for WrapFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["a"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &CHECKED[..self.order]
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::WRAP
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(WrapLookup {
            rt: Wrap::from_table(table)?,
            order: self.order,
        }))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        if !(A_MIN..=A_MAX).contains(&x[0]) {
            return Err(format!(
                "a = {} is outside [0, 1] (the closed forms' domain, docs/math.md, erratum E5)",
                x[0]
            ));
        }
        reference_lambda(x[0], self.order)
    }
    /// `eval wrap --exact`: the quadrature for any a ≥ 0 — for a > 1 the correct value
    /// (support cut at t = −1) that the closed forms refuse (E5).
    fn exact(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        reference_lambda(x[0], self.order)
    }
}

impl Checked for WrapFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        let mut t = Vec::new();
        let mut add = |output: &str, metric: &str, limit: f64| {
            t.push(Threshold {
                output: output.into(),
                metric: metric.into(),
                limit,
            })
        };
        for (l, name) in CHECKED[..MAX_ORDER].iter().enumerate() {
            let lim = if l <= 2 { CLOSED_LOW_ABS } else { CLOSED_HIGH_ABS };
            add(name, "grid.max_abs", lim);
            add(name, "offgrid.max_abs", lim);
        }
        for name in &CHECKED[MAX_ORDER..] {
            add(name, "grid.max_abs", TABLE_NODE_ABS);
            add(name, "offgrid.max_abs", TABLE_INTERP_ABS);
        }
        t
    }
    fn checked(&self) -> &'static [&'static str] {
        &CHECKED
    }
    /// l*: the runtime's closed form; t*: the stored table, interpolated; both against
    /// the GK reference.
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let mut got = runtime
            .lookup(&[x[0], CLOSED_MODE])
            .map_err(|e| format!("lookup at {x:?}: {e}"))?;
        got.extend(
            runtime
                .lookup(&[x[0], TABLE_MODE])
                .map_err(|e| format!("table lookup at {x:?}: {e}"))?,
        );
        let mut want = reference_lambda(x[0], MAX_ORDER)?;
        want.extend(want.clone());
        Ok(Some((got, want)))
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        vec![rng.range(A_MIN, A_MAX)]
    }
}

impl Fit for WrapFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        "Wrap-lighting band scalings λ̂_l(a) = 2 ∫_{-a}^{1} ((t+a)/(1+a))^(1+a) P_l(t) dt, l < 8, for \
         a = 0..1 (129 linear nodes, f32), for texture upload. Convolution: E_lm = π λ̂_l(a) L_lm. The \
         runtime's closed form (lobefit_tables::wrap::lambda_hat, every band) is exact; use it on the CPU."
            .into()
    }
    fn axes(&self) -> Vec<Axis> {
        vec![rt::axis(A_NODES)]
    }
    fn channels(&self) -> Vec<Channel> {
        CHANNELS
            .iter()
            .enumerate()
            .map(|(l, n)| Channel {
                name: n.to_string(),
                unit: "1".into(),
                encoding: Encoding::Linear,
                description: format!("λ̂_{l}(a), Funk–Hecke eigenvalue of the wrap kernel divided by π"),
            })
            .collect()
    }
    fn method(&self) -> String {
        "adaptive Simpson of the definition, cross-checked against the closed form".into()
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("fit_tol".into(), format!("{FIT_TOL:e}")),
            ("max_residual".into(), format!("{MAX_RESIDUAL:e}")),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "max over l of |adaptive Simpson − closed form|"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let a = node[0];
        let (v, evals, ok) = simpson_lambda(a);
        let mut c = [0.0; MAX_ORDER];
        let closed = rt::lambda_hat(MAX_ORDER, a, &mut c);
        let residual = v.iter().zip(&c).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        Fitted {
            values: v,
            residual,
            iterations: evals,
            converged: ok && closed.is_ok() && residual <= MAX_RESIDUAL,
        }
    }
}

/// wrap in the list of families (`crate::entries`): `eval wrap --order N`;
/// a closed form on the GPU.
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| vec![Box::new(WrapFamily::default())],
    eval: Some(|_, flags, _| {
        let order = flags.count("order")?.unwrap_or(DEFAULT_ORDER);
        if !(1..=8).contains(&order) {
            return Err(format!("wrap: --order {order} is outside 1..=8"));
        }
        Ok(Box::new(WrapFamily { order }))
    }),
    eval_names: &[],
    eval_flags: &[(rt::KIND, &[crate::log_zh::ORDER_FLAG])],
    gpu: &[],
    closed_form: Some(gpu::CLOSED),
    plot: None,
    eval_help: "\
wrap  [--order N] (1..8, default 4)
  in   `a`        wrap parameter, [0, 1]
  out  `l0` … `l7`  (the first N) λ̂_l(a): the wrap kernel's Funk–Hecke eigenvalue
                  per band, divided by π
",
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_converges_at_ends() {
        for a in [0.0, 0.5, 1.0] {
            let f = WrapFamily::default().fit(&[a]);
            assert!(f.converged, "a={a}: {f:?}");
        }
    }
}
