//! The ε study of the log-ZH BRDFs (Giraud's thesis Fig. 4.6, docs/math.md, log-zh): how far
//! exp*(log-ZH of the Phong lobe) lands from the lobe's true ZH vector, as a function
//! of the clamping threshold ε, and (beyond the thesis) the ε that minimises it.
//!
//! Error metric: the Euclidean distance of the order-n SH coefficient vectors, which
//! by orthonormality is the L2 distance on the sphere of the two band-limited
//! functions. Everything is zonal, so only the m = 0 entries are non-zero.
//! log-ZH: the runtime's closed form; true ZH: closed form
//! z_l = √(π(2l+1)) (r+1)/(2π) Σ_k a_{lk}/(r+k+1) (P_l = Σ a_{lk} s^k);
//! exp*: Taylor series with the DC term factored out ([`lobefit_core::sh::exp_star`]).
//! `tests/it/eps_study.rs` reproduces the numbers by an independent path.

use std::f64::consts::PI;

use lobefit_tables::log_zh;
use lobefit_tables::sh::{index, MAX_ORDER};

use lobefit_core::sh::{exp_star, Gaunt};

/// Default SH order of the study (docs/math.md §1 default; the thesis renders at order 4).
pub const STUDY_ORDER: usize = 4;
/// Phong exponents of the thesis figure.
pub const STUDY_R: [u32; 5] = [1, 2, 3, 4, 5];
/// ε resolution of the minimiser's final bracket.
const EPS_XTOL: f64 = 1e-7;

/// True ZH vector z_0..z_{n−1} of the normalised Phong lobe (r+1)/(2π) cos^r θ (0
/// below the horizon), r ≥ 0 real.
pub fn true_phong_zh(r: f64, order: usize) -> Vec<f64> {
    // P_l monomial coefficients (the runtime's, by the three-term recurrence).
    let a = lobefit_core::sh::legendre_coeffs();
    (0..order)
        .map(|l| {
            let s: f64 = (0..=l).map(|k| a[l][k] / (r + k as f64 + 1.0)).sum();
            (PI * (2 * l + 1) as f64).sqrt() * (r + 1.0) / (2.0 * PI) * s
        })
        .collect()
}

/// L2 error ‖exp*(log-ZH(ε, r)) − ZH_true(r)‖ at order n (`gaunt` of that order).
pub fn l2_error(gaunt: &Gaunt, eps: f64, r: f64) -> Result<f64, String> {
    let n = gaunt.order();
    let mut z = [0.0; MAX_ORDER];
    log_zh::phong(eps, r, n, &mut z).map_err(|e| e.to_string())?;
    let mut f = vec![0.0; n * n];
    for l in 0..n {
        f[index(l, 0)] = z[l];
    }
    let e = exp_star(gaunt, &f);
    if !e.converged {
        return Err(format!("exp* did not converge at eps={eps}, r={r}"));
    }
    let truth = true_phong_zh(r, n);
    let mut s = 0.0;
    for (i, v) in e.value.iter().enumerate() {
        let (l, m) = lobefit_tables::sh::band_of(i);
        let t = if m == 0 { truth[l] } else { 0.0 };
        s += (v - t) * (v - t);
    }
    Ok(s.sqrt())
}

/// The ε ∈ [0.01, 0.99] minimising [`l2_error`] for exponent r: a scan on 0.005 steps
/// picks the best bracket, golden-section search refines it to 1e-7. Returns (ε*, error).
pub fn optimal_eps(gaunt: &Gaunt, r: f64) -> Result<(f64, f64), String> {
    let (lo, hi) = (log_zh::EPS_MIN, log_zh::EPS_MAX);
    let steps = 196;
    let h = (hi - lo) / steps as f64;
    let mut best = (lo, f64::INFINITY);
    for k in 0..=steps {
        let e = lo + k as f64 * h;
        let v = l2_error(gaunt, e, r)?;
        if v < best.1 {
            best = (e, v);
        }
    }
    let (mut a, mut b) = ((best.0 - h).max(lo), (best.0 + h).min(hi));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (l2_error(gaunt, c, r)?, l2_error(gaunt, d, r)?);
    while b - a > EPS_XTOL {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = l2_error(gaunt, c, r)?;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = l2_error(gaunt, d, r)?;
        }
    }
    let e = 0.5 * (a + b);
    let v = l2_error(gaunt, e, r)?;
    // The bracket end may beat the interior (monotone curve): keep the scan's best then.
    Ok(if v <= best.1 { (e, v) } else { best })
}

/// Study curves: for each r, (ε, error) on `eps_grid`.
pub fn curves(gaunt: &Gaunt, rs: &[u32], eps_grid: &[f64]) -> Result<Vec<Vec<(f64, f64)>>, String> {
    rs.iter()
        .map(|&r| {
            eps_grid
                .iter()
                .map(|&e| Ok((e, l2_error(gaunt, e, r as f64)?)))
                .collect()
        })
        .collect()
}

/// ε grid of the published figure and table: 0.01, 0.02, …, 0.99.
pub fn eps_grid() -> Vec<f64> {
    (1..=99).map(|k| k as f64 / 100.0).collect()
}

/// `lobefit plot log-zh`: the Fig. 4.6 reproduction (PNG), the curves as CSV and the
/// optimal-ε table (CSV, orders 4 and 8, r = 1..5 and a few larger r).
pub fn plot(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_core::plot::{line_chart, LineChart, Series};
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut out = Vec::new();
    let grid = eps_grid();
    let mut csv = String::from("order,r,eps,l2_error\n");
    for order in [STUDY_ORDER, MAX_ORDER] {
        let gaunt = Gaunt::new(order);
        let cs = curves(&gaunt, &STUDY_R, &grid)?;
        for (r, c) in STUDY_R.iter().zip(&cs) {
            for (e, v) in c {
                csv.push_str(&format!("{order},{r},{e},{v:.6e}\n"));
            }
        }
        let chart = LineChart {
            title: format!("log-ZH Phong: ‖exp*(log-ZH) − ZH‖ vs ε (order {order}; thesis Fig. 4.6)"),
            x_label: "ε".into(),
            y_label: "L2 error".into(),
            log_x: false,
            log_y: false,
            series: STUDY_R
                .iter()
                .zip(cs)
                .map(|(r, points)| Series {
                    name: format!("r = {r}"),
                    points,
                })
                .collect(),
        };
        out.push(line_chart(
            &dir.join(format!("log-zh-eps-study-order{order}.png")),
            &chart,
        )?);
    }
    let p = dir.join("log-zh-eps-study.csv");
    std::fs::write(&p, csv).map_err(|e| format!("{}: {e}", p.display()))?;
    out.push(p);
    let mut opt = String::from("order,r,eps_opt,l2_error_at_opt,l2_error_at_0.2\n");
    for order in [STUDY_ORDER, MAX_ORDER] {
        let gaunt = Gaunt::new(order);
        for r in [1u32, 2, 3, 4, 5, 8, 16, 32, 64, 128] {
            let (e, v) = optimal_eps(&gaunt, r as f64)?;
            let at = l2_error(&gaunt, 0.2, r as f64)?;
            opt.push_str(&format!("{order},{r},{e:.6},{v:.6e},{at:.6e}\n"));
        }
    }
    let p = dir.join("log-zh-optimal-eps.csv");
    std::fs::write(&p, opt).map_err(|e| format!("{}: {e}", p.display()))?;
    out.push(p);
    Ok(out)
}
