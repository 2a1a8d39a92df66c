//! the disk-light SH table (Yuan, Nowrouzezahrai & Sloan 2012 §2): fit,
//! checker reference, exact irradiance, and `lobefit plot disk-light`.
//!
//! Canonical frame and table layout: `lobefit_tables::disk_light` (d = 1 below).
//!
//! **Fit** (directions, one closed-form integral). Seen from the receiver the disk lies
//! in the plane at height h = cos τ along p = −n = (−sin τ, 0, cos τ); the foot point of
//! the receiver on that plane sits at in-plane offset sin τ from the disk's centre.
//! In spherical coordinates (α, φ) about p, with φ measured from e1 = (cos τ, 0, sin τ)
//! (towards the centre) and e2 = y, the ray at azimuth φ hits the disk for in-plane
//! distances s ∈ [s1(φ), s2(φ)] from the foot point (a circle–ray intersection;
//! s1 = 0 when the foot point is inside the disk), i.e. α ∈ [atan(s1/h), atan(s2/h)].
//! The order-2 moments of ω over that α range have closed forms (∫ sin α · {1, sin α,
//! cos α, sin²α, sin α cos α, cos²α} dα), so each coefficient is a 1-D integral over
//! φ, taken by composite 10-point Gauss–Legendre on a substituted variable that removes
//! the square-root end point when the foot point is outside (φ = φ_t(1 − (1 − w)²)),
//! doubling the panels until two successive rules agree. Values stored: c_00 and
//! c_lm/c_00. Residual: that agreement, relative to c_00.
//!
//! **Reference** (checker; independent parameterisation and rule): the area integral
//! ∫_disk y_lm(x̂) cos τ / |x|³ dA in polar coordinates (ρ, ψ) about the disk's *centre*,
//! nested adaptive Gauss–Kronrod (ρ inner, break at the foot point ρ = sin τ; ψ outer,
//! break at ψ = π where the foot point lies), basis from the runtime's `eval_basis`.

pub mod gpu;

use std::f64::consts::{FRAC_PI_2, PI};

use lobefit_tables::disk_light::{
    self as rt, form_factor_irradiance, r_from_rim_coordinate, DiskLight, CANONICAL_INDEX, CHANNELS, OUTPUTS, R_MAX,
    R_MIN, TAU_MAX, TAU_NODES, V_NODES,
};
use lobefit_tables::format::Threshold;
use lobefit_tables::glam::DVec3;
use lobefit_tables::sh::eval_basis;
use lobefit_tables::{Axis, Channel, Encoding, LoadError, LookupError, Table};

use lobefit_core::eigen::solve;
use lobefit_core::family::{Checked, Extra, Fit, Fitted, Lookup, View};
use lobefit_core::quad::gauss_kronrod_vec;
use lobefit_core::rng::Rng;
use lobefit_tables::error::short;

/// Gauss–Legendre points per panel of the fit.
const GL_POINTS: usize = 10;
/// First panel count of the fit's doubling.
const FIRST_PANELS: usize = 4;
/// Most panels before a node counts as unconverged.
const MAX_PANELS: usize = 4096;
/// Fit convergence: successive rules agree to this, relative to c_00.
const FIT_TOL: f64 = 1e-11;
/// Largest residual for a node to be written (f32 storage is ~6e-8).
const MAX_RESIDUAL: f64 = 1e-9;
/// Checker reference tolerance relative to c_00 (1e-7 or tighter).
pub const REFERENCE_REL_TOL: f64 = 1e-9;
/// Tolerance (relative to a scale estimate) of the reference's first pass for the solid
/// angle, which only sets the absolute tolerance of the coefficients' integrals.
const SCALE_REL_TOL: f64 = 1e-6;
/// Tolerance (relative to the small-disk solid angle) of the exact-irradiance
/// reference of the error maps: far below the errors they show (≥ 1e-5).
const IRRADIANCE_REL_TOL: f64 = 1e-9;
/// Relative accuracy floor of each nested GK level: next to the plane (cos τ ~ 1e-4)
/// the inner integrals reach ~1/cos τ, where an absolute 1e-10 is below f64 rounding.
const GK_REL_FLOOR: f64 = 1e-12;
/// Tolerance of [`reference_canonical_directions`], relative to the solid angle's
/// scale estimate.
const DIRECTION_REL_TOL: f64 = 1e-11;
/// Acceptance: median relative error of c_00 off-grid.
pub const DC_MEDIAN_REL: f64 = 1e-3;
/// Acceptance: relative L2 error of the 9-coefficient vector, everywhere.
pub const L2_MAX: f64 = 1e-2;
/// At grid nodes only f32 storage and the rim-coordinate round trip remain.
pub const L2_GRID_MAX: f64 = 1e-5;
/// Largest τ of the acceptance domain (and of the checker's off-grid sample).
pub const TAU_ACCEPT: f64 = 0.98 * FRAC_PI_2;

/// Checked quantities: the six coefficients and the 9-vector relative L2 error e
/// (reported as 1 + e against 1, so both error columns of the report read e).
const CHECKED: [&str; 7] = ["y00", "y10", "y11", "y20", "y21", "y22", "l2"];

/// SH normalisation constants (real SH with the Condon–Shortley phase).
const K00: f64 = 0.282_094_791_773_878_14; // 1/(2√π)
const K1: f64 = 0.488_602_511_902_919_9; // √(3/4π)
const K20: f64 = 0.315_391_565_252_520_05; // √(5/16π)
const K21: f64 = 1.092_548_430_592_079_2; // √(15/4π)
const K22: f64 = 0.546_274_215_296_039_6; // √(15/16π)

/// (2α − sin 2α)/4 = ∫_0^α sin²: series for small α (no cancellation).
fn int_sin2(alpha: f64) -> f64 {
    let x = 2.0 * alpha;
    if x < 0.1 {
        let x2 = x * x;
        x * x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))) / 4.0
    } else {
        (x - x.sin()) / 4.0
    }
}

/// Closed-form α integrals over [α1, α2] of sin α × {1, sin α, cos α, sin²α,
/// sin α cos α, cos²α}, with u = 1 − cos α = 2 sin²(α/2) (no cancellation).
fn alpha_integrals(a1: f64, a2: f64) -> [f64; 6] {
    let u = |a: f64| 2.0 * (0.5 * a).sin().powi(2);
    let (u1, u2) = (u(a1), u(a2));
    let (s1, s2) = (a1.sin(), a2.sin());
    let g = |u: f64| u * u - u * u * u / 3.0;
    let h = |u: f64| u - u * u + u * u * u / 3.0;
    [
        u2 - u1,
        int_sin2(a2) - int_sin2(a1),
        0.5 * (s2 * s2 - s1 * s1),
        g(u2) - g(u1),
        (s2 * s2 * s2 - s1 * s1 * s1) / 3.0,
        h(u2) - h(u1),
    ]
}

/// The disk in the (α, φ) frame: how w ∈ [0, 1] maps to φ, and α1, α2 at φ.
struct DirFrame {
    st: f64,
    ct: f64,
    r: f64,
    inside: bool,
    phi_t: f64,
}

impl DirFrame {
    fn new(r: f64, tau: f64) -> DirFrame {
        let (st, ct) = tau.sin_cos();
        let inside = r >= st;
        let phi_t = if inside { PI } else { (r / st).asin() };
        DirFrame {
            st,
            ct,
            r,
            inside,
            phi_t,
        }
    }

    /// Local moments (1, a, c, a², b², c², ac) at w (weight dφ/dw included), with
    /// a = sin α cos φ, b = sin α sin φ, c = cos α; b-odd moments vanish by symmetry.
    fn moments(&self, w: f64) -> [f64; 7] {
        let (phi, jac) = if self.inside {
            (PI * w, PI)
        } else {
            let q = 1.0 - w;
            (self.phi_t * (1.0 - q * q), 2.0 * self.phi_t * q)
        };
        let (sp, cp) = phi.sin_cos();
        let b = self.st * cp;
        let disc = ((self.r - self.st * sp) * (self.r + self.st * sp)).max(0.0).sqrt();
        let k = (self.st - self.r) * (self.st + self.r); // s1 s2 = k (foot outside)
        let (s1, s2) = if self.inside {
            let s2 = if b >= 0.0 { b + disc } else { -k / (disc - b) };
            (0.0, s2)
        } else {
            let s2 = b + disc;
            (if s2 > 0.0 { k / s2 } else { 0.0 }, s2)
        };
        let (a1, a2) = (s1.atan2(self.ct), s2.atan2(self.ct));
        let i = alpha_integrals(a1, a2);
        [
            jac * i[0],
            jac * cp * i[1],
            jac * i[2],
            jac * cp * cp * i[3],
            jac * sp * sp * i[3],
            jac * i[5],
            jac * cp * i[4],
        ]
    }
}

/// Composite Gauss–Legendre over w ∈ [0, 1] with `panels` panels: the seven moments
/// over φ ∈ [0, φ_t] (half the disk).
fn moments_gl(f: &DirFrame, panels: usize, x: &[f64], wt: &[f64]) -> [f64; 7] {
    let mut m = [0.0; 7];
    let h = 1.0 / panels as f64;
    for p in 0..panels {
        let c = (p as f64 + 0.5) * h;
        for (xi, wi) in x.iter().zip(wt) {
            let v = f.moments(c + 0.5 * h * xi);
            for k in 0..7 {
                m[k] += 0.5 * h * wi * v[k];
            }
        }
    }
    m
}

/// Six canonical coefficients from the half-disk local moments (doubled: the
/// φ < 0 half mirrors the φ > 0 one).
fn coefficients(m: &[f64; 7], tau: f64) -> [f64; 6] {
    let (st, ct) = tau.sin_cos();
    let [m1, ma, mc, maa, mbb, mcc, mac] = m.map(|v| 2.0 * v);
    // World x = a cos τ − c sin τ, y = b, z = a sin τ + c cos τ.
    let x = ma * ct - mc * st;
    let z = ma * st + mc * ct;
    let xx = maa * ct * ct - 2.0 * mac * st * ct + mcc * st * st;
    let zz = maa * st * st + 2.0 * mac * st * ct + mcc * ct * ct;
    let xz = maa * st * ct + mac * (ct * ct - st * st) - mcc * st * ct;
    let yy = mbb;
    [
        K00 * m1,
        K1 * z,
        -K1 * x,
        K20 * (3.0 * zz - m1),
        -K21 * xz,
        K22 * (xx - yy),
    ]
}

/// The fit at (R/d, τ): coefficients, residual (relative to c_00), evaluations.
pub fn fit_canonical(r: f64, tau: f64) -> ([f64; 6], f64, u32) {
    let f = DirFrame::new(r, tau);
    let (x, wt) = lobefit_core::sh::gauss_legendre(GL_POINTS);
    let mut panels = FIRST_PANELS;
    let mut prev = coefficients(&moments_gl(&f, panels, &x, &wt), tau);
    let mut evals = (panels * GL_POINTS) as u32;
    loop {
        panels *= 2;
        let next = coefficients(&moments_gl(&f, panels, &x, &wt), tau);
        evals += (panels * GL_POINTS) as u32;
        let diff = prev.iter().zip(&next).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / next[0].abs();
        if diff <= FIT_TOL || panels >= MAX_PANELS {
            return (next, diff, evals);
        }
        prev = next;
    }
}

/// Point on the disk at polar (ρ, ψ) about its centre (d = 1), canonical frame.
fn disk_point(rho: f64, psi: f64, st: f64, ct: f64) -> [f64; 3] {
    let (sp, cp) = psi.sin_cos();
    [rho * cp * ct, rho * sp, 1.0 + rho * cp * st]
}

/// ∫_disk g(x) cos τ / |x|³ dA by nested GK (ρ inner, ψ outer over [0, π], doubled:
/// `g` must be even in y), to absolute tolerance `tol`; every component of `g` on
/// one shared subdivision.
fn disk_integral<const N: usize>(
    r: f64,
    tau: f64,
    tol: f64,
    g: &dyn Fn([f64; 3]) -> [f64; N],
) -> Result<[f64; N], String> {
    let (st, ct) = tau.sin_cos();
    let mut ok = true;
    let inner_breaks = [st];
    let (q, v) = gauss_kronrod_vec(
        |psi| {
            let (qi, vi) = gauss_kronrod_vec(
                |rho| {
                    let x = disk_point(rho, psi, st, ct);
                    let r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
                    let w = ct * rho / (r2 * r2.sqrt());
                    g(x).map(|gx| gx * w)
                },
                0.0,
                r,
                &inner_breaks,
                tol / 4.0,
                GK_REL_FLOOR,
                2000,
            );
            ok &= qi.converged;
            vi
        },
        0.0,
        PI,
        &[],
        tol / 4.0,
        GK_REL_FLOOR,
        2000,
    );
    if ok && q.converged {
        Ok(v.map(|x| 2.0 * x))
    } else {
        Err(format!(
            "disk quadrature did not converge at R/d = {r}, tau = {tau}",
            r = short(r),
            tau = short(tau)
        ))
    }
}

/// Checker reference: the six canonical coefficients by nested GK over the disk.
/// τ ≥ π/2 gives zeros (back side).
pub fn reference_canonical(r: f64, tau: f64) -> Result<[f64; 6], String> {
    static MEMO: lobefit_core::memo::Memo<2, [f64; 6]> = lobefit_core::memo::Memo::new();
    MEMO.get([r, tau], || reference_canonical_computed(r, tau))
}

/// [`reference_canonical`], computed.
fn reference_canonical_computed(r: f64, tau: f64) -> Result<[f64; 6], String> {
    if !(r.is_finite() && r > 0.0) {
        return Err(format!("r_over_d = {r} must be a finite number > 0", r = short(r)));
    }
    if !(tau.is_finite() && (0.0..=PI).contains(&tau)) {
        return Err(format!("tau = {tau} is outside [0, π]", tau = short(tau)));
    }
    if tau >= FRAC_PI_2 {
        return Ok([0.0; 6]);
    }
    let basis = |x: [f64; 3]| {
        let mut y = [0.0; 9];
        eval_basis(3, x, &mut y).expect("non-zero point");
        y
    };
    // Solid angle first, loosely (it only sets the others' absolute tolerance), from a
    // scale estimate (the small-disk solid angle, which never overestimates much).
    let est = (PI * r * r * tau.cos() / (1.0 + r * r)).min(2.0 * PI);
    let [omega] = disk_integral(r, tau, SCALE_REL_TOL * est, &|_| [1.0])?;
    let tol = REFERENCE_REL_TOL * omega * K00;
    // The six coefficients in one pass on a shared subdivision (each component is
    // held to the same absolute tolerance as a pass of its own would be).
    disk_integral(r, tau, tol, &|x| {
        let y = basis(x);
        CANONICAL_INDEX.map(|i| y[i])
    })
}

/// The every-node reference: the six canonical coefficients as integrals over the
/// directions that hit the disk, in polar coordinates (θ, ψ) about the direction to
/// the disk's centre (the canonical z axis). The cone over the disk's rim is the
/// quadric dᵀM d = 0 (below), so the boundary θ_b(ψ) is the root of a quadratic in
/// cot θ and the θ integrals of the l ≤ 2 monomials are closed forms; ψ goes to the
/// adaptive Gauss–Kronrod rule. 3–100× cheaper than [`reference_canonical`] (the more,
/// the nearer grazing; `cargo bench --bench rigs -- disk_reference`) and
/// independent of both it (directions instead of area) and of the fit (another frame,
/// boundary and outer rule; the basis from `eval_basis` by a linear solve). The two
/// references agree to 1e-11 (measured 5e-14; test
/// `direction_reference_matches_area_reference`).
pub fn reference_canonical_directions(r: f64, tau: f64) -> Result<[f64; 6], String> {
    static MEMO: lobefit_core::memo::Memo<2, [f64; 6]> = lobefit_core::memo::Memo::new();
    MEMO.get([r, tau], || reference_canonical_directions_computed(r, tau))
}

/// [`reference_canonical_directions`], computed.
fn reference_canonical_directions_computed(r: f64, tau: f64) -> Result<[f64; 6], String> {
    if !(r.is_finite() && r > 0.0) {
        return Err(format!("r_over_d = {r} must be a finite number > 0"));
    }
    if !(tau.is_finite() && (0.0..=PI).contains(&tau)) {
        return Err(format!("tau = {tau} is outside [0, π]"));
    }
    if tau >= FRAC_PI_2 {
        return Ok([0.0; 6]);
    }
    let (st, ct) = tau.sin_cos();
    // Disk: centre c = z, normal n = (sin τ, 0, −cos τ), radius r. A direction d hits
    // it iff |t d − c|² ≤ r² at t = h/(n·d), h = n·c; times (n·d)²:
    // h² − 2h (d·c)(n·d) + (1 − r²)(n·d)² ≤ 0. With d = (sin θ cos ψ, sin θ sin ψ, cos θ)
    // that is A cos²θ + 2B sin θ cos θ + C sin²θ ≤ 0 with, for e_ψ = (cos ψ, sin ψ, 0):
    // A = −r²h², B = −r²h (n·e_ψ), C = h² + (1 − r²)(n·e_ψ)². A < 0 (the centre is in).
    let h = -ct;
    let moments = |psi: f64| -> [f64; 6] {
        let (sp, cp) = psi.sin_cos();
        let ne = st * cp;
        let a = -r * r * h * h;
        let b = -r * r * h * ne;
        let c = h * h + (1.0 - r * r) * ne * ne;
        // Largest root of A s² + 2B s + C in s = cot θ (θ from 0 outwards), written
        // without cancellation for either sign of B.
        let disc = (b * b - a * c).max(0.0).sqrt();
        let s = if b >= 0.0 { (b + disc) / -a } else { c / (disc - b) };
        let q = (1.0 + s * s).sqrt();
        let (sn, cs) = (1.0 / q, s / q);
        let theta = sn.atan2(cs);
        let omc = if cs > 0.0 { sn * sn / (1.0 + cs) } else { 1.0 - cs }; // 1 − cos θ_b
        let i_s = int_sin2(theta); // ∫ sin²θ dθ
        let i_c = 0.5 * sn * sn; // ∫ cos θ sin θ dθ
        let i_cc = omc * (1.0 + cs + cs * cs) / 3.0; // ∫ cos²θ sin θ dθ
        let i_sc = sn * sn * sn / 3.0; // ∫ sin²θ cos θ dθ
        let i_ss = omc - i_cc; // ∫ sin³θ dθ = ∫ (1 − cos²θ) sin θ dθ
                               // ∫ {x, z, x², y², z², xz} dω over θ ∈ [0, θ_b] at ψ.
        [cp * i_s, i_c, cp * cp * i_ss, sp * sp * i_ss, i_cc, cp * i_sc]
    };
    let est = (PI * r * r * ct / (1.0 + r * r)).min(2.0 * PI);
    // The region is symmetric in y: ψ over [0, π], doubled.
    let (q, m) = gauss_kronrod_vec(moments, 0.0, PI, &[], DIRECTION_REL_TOL * est, GK_REL_FLOOR, 2000);
    if !q.converged {
        return Err(format!(
            "direction quadrature did not converge at R/d = {r}, tau = {tau}"
        ));
    }
    let mono = m.map(|v| 2.0 * v);
    // Each canonical basis function as a combination of {x, z, x², y², z², xz} (and
    // 1 = x² + y² + z²) on the sphere.
    Ok(canonical_polynomials().map(|p| p.iter().zip(&mono).map(|(a, b)| a * b).sum()))
}

/// Coefficients of each canonical basis function (`CANONICAL_INDEX`) in the monomials
/// {x, z, x², y², z², xz}, solved from the basis's own values at six directions in
/// the xz half-space (the y-even functions are spanned by these six on the sphere).
fn canonical_polynomials() -> [[f64; 6]; 6] {
    static POLY: std::sync::OnceLock<[[f64; 6]; 6]> = std::sync::OnceLock::new();
    *POLY.get_or_init(|| {
        let dirs: [[f64; 3]; 6] = [
            [0.3, 0.2, 0.9],
            [-0.8, 0.5, 0.3],
            [0.6, -0.7, -0.4],
            [0.1, 0.9, -0.2],
            [-0.5, -0.1, 0.85],
            [0.7, 0.6, 0.1],
        ];
        // A (6 × 6) and the six right-hand sides B (6 × 6), row-major.
        let mut a = [0.0; 36];
        let mut rhs = [0.0; 36];
        for (row, d) in dirs.iter().enumerate() {
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let [x, y, z] = d.map(|v| v / l);
            a[row * 6..row * 6 + 6].copy_from_slice(&[x, z, x * x, y * y, z * z, x * z]);
            let mut yb = [0.0; 9];
            eval_basis(3, [x, y, z], &mut yb).expect("unit direction");
            for (k, &i) in CANONICAL_INDEX.iter().enumerate() {
                rhs[row * 6 + k] = yb[i];
            }
        }
        solve(&mut a, &mut rhs, 6, 6).expect("six independent directions");
        let mut out = [[0.0; 6]; 6];
        for (k, poly) in out.iter_mut().enumerate() {
            for (j, c) in poly.iter_mut().enumerate() {
                *c = rhs[j * 6 + k];
            }
        }
        out
    })
}

/// Exact irradiance (per unit radiance) at the origin with unit normal `n`
/// (canonical frame) from the disk (R/d = r, d = 1): ∫ max(n·ω, 0) dω over the disk.
pub fn reference_irradiance(r: f64, tau: f64, n: [f64; 3]) -> Result<f64, String> {
    if tau >= FRAC_PI_2 {
        return Ok(0.0);
    }
    let est = (PI * r * r * tau.cos() / (1.0 + r * r)).min(2.0 * PI);
    // n must be even in y for the doubled ψ range: the callers use n in the xz-plane.
    if n[1] != 0.0 {
        return Err("reference_irradiance takes normals in the xz-plane".into());
    }
    let [e] = disk_integral(r, tau, IRRADIANCE_REL_TOL * est, &|x| {
        let l = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
        [((n[0] * x[0] + n[2] * x[2]) / l).max(0.0)]
    })?;
    Ok(e)
}

/// Relative L2 distance ‖got − want‖/‖want‖ (shared with the SHExp study).
pub use crate::shexp::study::rel_l2;

struct DiskLookup(DiskLight);

impl Lookup for DiskLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        Ok(self.0.canonical(x[0], x[1])?.to_vec())
    }
    fn lookup_f32(&self, x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        Some(
            self.0
                .canonical_f32(x[0] as f32, x[1] as f32)
                .map(|c| c.map(f64::from).to_vec()),
        )
    }
}

/// The disk-light family.
#[derive(Debug, Clone, Copy, Default)]
pub struct DiskLightFamily;

impl View for DiskLightFamily {
    fn kind(&self) -> &'static str {
        rt::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["r_over_d", "tau"]
    }
    fn outputs(&self) -> &'static [&'static str] {
        &OUTPUTS
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::DISK_LIGHT
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(DiskLookup(DiskLight::from_table(table)?)))
    }
    /// Any R/d > 0 (the runtime's extensions below 0.01 and above 10 are checked
    /// against this) and τ ∈ [0, π].
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        Ok(reference_canonical(x[0], x[1])?.to_vec())
    }
}

impl Checked for DiskLightFamily {
    fn thresholds(&self) -> Vec<Threshold> {
        vec![
            Threshold {
                output: "y00".into(),
                metric: "offgrid.median_rel".into(),
                limit: DC_MEDIAN_REL,
            },
            Threshold {
                output: "l2".into(),
                metric: "offgrid.max_abs".into(),
                limit: L2_MAX,
            },
            Threshold {
                output: "l2".into(),
                metric: "grid.max_abs".into(),
                limit: L2_GRID_MAX,
            },
            Threshold {
                output: "l2_nodes".into(),
                metric: "grid.max_abs".into(),
                limit: L2_GRID_MAX,
            },
        ]
    }
    fn checked(&self) -> &'static [&'static str] {
        &CHECKED
    }
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let mut got = runtime.lookup(x).map_err(|e| format!("lookup at {x:?}: {e}"))?;
        let mut want = self.reference(x).map_err(|e| format!("reference at {x:?}: {e}"))?;
        // As 1 + e against 1: the checker's absolute and relative columns both read e.
        got.push(1.0 + rel_l2(&got, &want));
        want.push(1.0);
        Ok(Some((got, want)))
    }
    fn node_inputs(&self, node: &[f64]) -> Vec<Vec<f64>> {
        vec![vec![r_from_rim_coordinate(node[0], node[1]), node[1]]]
    }
    fn nodes_in_extras(&self) -> bool {
        // The area reference costs ~1.5 ms a point; `l2_nodes` checks all 24 576 nodes
        // against the direction reference at ~1/30 of that.
        true
    }
    fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        vec![rng.range(R_MIN.ln(), R_MAX.ln()).exp(), rng.range(0.0, TAU_ACCEPT)]
    }
    /// Beyond the acceptance domain (measured, no threshold): the 9-vector relative L2
    /// error for τ ∈ [0.98·π/2, 0.999·π/2] (the table's last rows) and for
    /// τ ∈ (0.999·π/2, π/2) (the runtime's interpolation towards the plane limit).
    fn extra_checks(&self, table: &Table, count: usize, seed: u64) -> Vec<(String, Result<Extra, String>)> {
        use rayon::prelude::*;
        let rt = match DiskLight::from_table(table.clone()) {
            Ok(t) => t,
            Err(e) => return vec![("disk-light".into(), Err(e.to_string()))],
        };
        // Every node: the looked-up 9-vector against the direction reference.
        let nodes = lobefit_core::build::grid_nodes(&table.meta().axes);
        let l2_nodes: Result<Vec<(f64, f64)>, String> = nodes
            .par_iter()
            .map(|n| {
                let x = [r_from_rim_coordinate(n[0], n[1]), n[1]];
                let got = rt.canonical(x[0], x[1]).map_err(|e| format!("lookup at {x:?}: {e}"))?;
                let want = reference_canonical_directions(x[0], x[1])?;
                Ok((1.0 + rel_l2(&got, &want), 1.0))
            })
            .collect();
        let mut out = vec![("l2_nodes".to_string(), l2_nodes.map(Extra::Nodes))];
        let mut rng = Rng::new(seed ^ 0xd15c);
        let pts: Vec<(f64, f64)> = (0..count)
            .map(|_| (rng.range(R_MIN.ln(), R_MAX.ln()).exp(), rng.range(TAU_ACCEPT, TAU_MAX)))
            .collect();
        // Relative L2 error of the runtime against the reference at each point.
        let errors = |pts: &[(f64, f64)]| {
            pts.par_iter()
                .map(|&(r, tau)| {
                    let got = rt.canonical(r, tau).map_err(|e| e.to_string())?;
                    let want = reference_canonical(r, tau)?;
                    Ok(rel_l2(&got, &want))
                })
                .collect::<Result<Vec<f64>, String>>()
                .map(Extra::Values)
        };
        let grazing = errors(&pts);
        let sliver: Vec<(f64, f64)> = (0..count)
            .map(|_| {
                let r = rng.range(R_MIN.ln(), R_MAX.ln()).exp();
                (r, FRAC_PI_2 - rng.range(0.1, 1.0) * (FRAC_PI_2 - TAU_MAX))
            })
            .collect();
        let beyond = errors(&sliver);
        out.push(("l2 error, tau in [0.98, 0.999]·π/2".into(), grazing));
        out.push((
            "l2 error, tau in (0.999, 1)·π/2 (interpolated towards the plane limit)".into(),
            beyond,
        ));
        out
    }
}

impl Fit for DiskLightFamily {
    fn version(&self) -> u32 {
        rt::VERSION
    }
    fn description(&self) -> String {
        "Order-3 SH projection of a one-sided disk light's solid-angle indicator in the canonical frame \
         (receiver at origin, disk centre (0,0,d), radius R, emitting normal (sin tau, 0, -cos tau)); \
         c_lm = ∫_disk y_lm dω for (l,m) = (0,0),(1,0),(1,1),(2,0),(2,1),(2,2). Axes: v = rim coordinate \
         of R/d in [0.01, 10] (lobefit_tables::disk_light::rim_coordinate), tau in [0, 0.999 π/2] (logit). \
         Channels: y00 (log-encoded) and r_lm = c_lm / c_00. Bilinear."
            .into()
    }
    fn axes(&self) -> Vec<Axis> {
        rt::axes(V_NODES, TAU_NODES)
    }
    fn channels(&self) -> Vec<Channel> {
        CHANNELS
            .iter()
            .enumerate()
            .map(|(k, n)| Channel {
                name: n.to_string(),
                unit: "1".into(),
                encoding: if k == 0 { Encoding::Log } else { Encoding::Linear },
                description: if k == 0 {
                    "c_00 = Ω/(2√π), Ω the disk's solid angle (sr)".into()
                } else {
                    let (l, m) = (&OUTPUTS[k][1..2], &OUTPUTS[k][2..3]);
                    format!("c_{l}{m} / c_00, canonical coefficient (l, m) = ({l}, {m}) over c_00")
                },
            })
            .collect()
    }
    fn method(&self) -> String {
        "closed-form polar-angle moments about the disk plane's normal, composite 10-point Gauss-Legendre \
         in azimuth with panel doubling"
            .into()
    }
    fn settings(&self) -> Vec<(String, String)> {
        vec![
            ("gl_points".into(), GL_POINTS.to_string()),
            ("panels".into(), format!("{FIRST_PANELS}..{MAX_PANELS} doubling")),
            ("fit_tol".into(), format!("{FIT_TOL:e}")),
            ("max_residual".into(), format!("{MAX_RESIDUAL:e}")),
        ]
    }
    fn residual_meaning(&self) -> &'static str {
        "max |difference of the last two panel-doubled rules| over the six coefficients, relative to c_00"
    }
    fn fit(&self, node: &[f64]) -> Fitted {
        let (v, tau) = (node[0], node[1]);
        let r = r_from_rim_coordinate(v, tau);
        let (c, residual, evals) = fit_canonical(r, tau);
        let mut values = vec![c[0]];
        values.extend(c[1..].iter().map(|x| x / c[0]));
        Fitted {
            values,
            residual,
            iterations: evals,
            converged: residual <= MAX_RESIDUAL && c[0] > 0.0,
        }
    }
}

/// Canonical-frame irradiance at the origin with unit normal `n` from the runtime's SH
/// vector (order 3, clamped-cosine convolved), per unit radiance.
pub fn sh_irradiance(rt: &DiskLight, r: f64, tau: f64, n: [f64; 3]) -> Result<f64, String> {
    Ok(sh_irradiance_of(&rt.canonical(r, tau).map_err(|e| e.to_string())?, n))
}

/// Wallace et al. (1989) in the canonical frame (d = 1), per unit radiance.
pub fn wallace_irradiance(r: f64, tau: f64, n: [f64; 3]) -> Result<f64, String> {
    form_factor_irradiance(
        DVec3::ZERO,
        DVec3::from_array(n),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(tau.sin(), 0.0, -tau.cos()),
        r,
        1.0,
    )
    .map_err(|e| e.to_string())
}

/// The two receiver normals of the error maps (canonical frame): facing the disk's
/// centre, and facing the disk's plane (parallel to −n).
pub fn map_normals(tau: f64) -> [(&'static str, [f64; 3]); 2] {
    [
        ("N to centre", [0.0, 0.0, 1.0]),
        ("N = −n", [-tau.sin(), 0.0, tau.cos()]),
    ]
}

/// Order-3 SH irradiance (clamped-cosine convolved) at normal `n` from six canonical
/// coefficients.
fn sh_irradiance_of(c: &[f64; 6], n: [f64; 3]) -> f64 {
    let mut y = [0.0; 9];
    eval_basis(3, n, &mut y).expect("unit normal");
    CANONICAL_INDEX
        .iter()
        .enumerate()
        .map(|(k, &i)| c[k] * y[i] * rt::CLAMPED_COSINE[lobefit_tables::sh::band_of(i).0])
        .sum()
}

/// Relative errors on an `nx` × `ny` grid of (log10 R/d ∈ [−2, 1], τ ∈ [0, 0.98·π/2]),
/// for receiver normal `which` of [`map_normals`]: (table SH irradiance vs exact
/// irradiance, Wallace vs exact, table SH irradiance vs exact order-3 SH irradiance).
#[allow(clippy::type_complexity)]
pub fn error_maps(nx: usize, ny: usize, which: usize) -> Result<[Vec<f64>; 3], String> {
    use rayon::prelude::*;
    let rt = DiskLight::embedded().map_err(|e| e.to_string())?;
    let cells: Vec<(usize, usize)> = (0..ny).flat_map(|iy| (0..nx).map(move |ix| (ix, iy))).collect();
    let res: Vec<Result<[f64; 3], String>> = cells
        .par_iter()
        .map(|&(ix, iy)| {
            let r = 10f64.powf(-2.0 + 3.0 * (ix as f64 + 0.5) / nx as f64);
            let tau = TAU_ACCEPT * (iy as f64 + 0.5) / ny as f64;
            let n = map_normals(tau)[which].1;
            let exact = reference_irradiance(r, tau, n)?;
            let sh = sh_irradiance(rt, r, tau, n)?;
            let sh_exact = sh_irradiance_of(&reference_canonical(r, tau)?, n);
            let wal = wallace_irradiance(r, tau, n)?;
            Ok([
                (sh - exact).abs() / exact,
                (wal - exact).abs() / exact,
                (sh - sh_exact).abs() / sh_exact.abs(),
            ])
        })
        .collect();
    let mut out = [Vec::new(), Vec::new(), Vec::new()];
    for r in res {
        let v = r?;
        for k in 0..3 {
            out[k].push(v[k]);
        }
    }
    Ok(out)
}

/// (median, p95, max) of a sample.
pub fn summary(v: &[f64]) -> (f64, f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let q = |p: f64| s[((p * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)];
    (q(0.5), q(0.95), s[s.len() - 1])
}

/// `lobefit plot disk-light`: relative error of the order-3 SH irradiance (from the
/// table) and of the Wallace form-factor approximation against the exact irradiance,
/// and of the table against the exact order-3 SH irradiance, over (log10 R/d, τ), for
/// two receiver normals. Prints the summary statistics it draws.
pub fn plot(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_core::plot::{heatmaps, ColourScale, Heatmap};
    const NX: usize = 48;
    const NY: usize = 40;
    let mut panels = Vec::new();
    for which in 0..2 {
        let maps = error_maps(NX, NY, which)?;
        let name = map_normals(0.0)[which].0;
        let labels = [
            "SH-3 (table) vs exact E",
            "Wallace FF vs exact E",
            "table vs exact SH-3 E",
        ];
        for (label, v) in labels.iter().zip(maps) {
            let (med, p95, max) = summary(&v);
            eprintln!("disk-light {name}: {label}: median {med:.2e} p95 {p95:.2e} max {max:.2e}");
            panels.push(Heatmap {
                title: format!("{label}, {name}: med {med:.1e}, max {max:.1e}"),
                x_label: "log10 R/d".into(),
                y_label: "τ (rad)".into(),
                x_range: (-2.0, 1.0),
                y_range: (0.0, TAU_ACCEPT),
                nx: NX,
                ny: NY,
                values: v,
                colour_label: "relative error".into(),
                log_colour: true,
                scale: ColourScale::Own,
            });
        }
    }
    Ok(vec![heatmaps(
        &dir.join("disk-light-irradiance-error.png"),
        &panels,
        3,
    )?])
}

/// disk-light in the list of families (`crate::entries`).
pub const ENTRY: crate::Entry = crate::Entry {
    tables: |_| vec![Box::new(DiskLightFamily)],
    eval: None,
    eval_names: &[],
    eval_flags: &[],
    gpu: &[gpu::GPU],
    closed_form: None,
    plot: Some(("disk-light", plot)),
    eval_help: "\
disk-light
  in   `r_over_d` disk radius over the distance to its centre, > 0 (tabulated on
                  [0.01, 10])
       `tau`      angle between the disk's normal and the direction from the disk
                  to the receiver (rad), [0, π]; ≥ π/2 sees the back (zeros)
  out  `y00`, `y10`, `y11`, `y20`, `y21`, `y22`  the non-zero SH coefficients
                  ∫ y_lm dω over the disk (receiver at the origin, disk centre on +z,
                  normal in the xz-plane)
",
};

#[cfg(test)]
mod tests {
    #[test]
    fn direction_reference_matches_area_reference() {
        // Small, rim-crossing, large and grazing disks, both sides of R/d = sin τ.
        let mut worst: f64 = 0.0;
        for &r in &[0.01, 0.05, 0.5, 0.9, 1.0, 1.2, 5.0, 10.0] {
            for &tau in &[0.0, 0.3, 1.0, 1.4, 1.55, 0.98 * FRAC_PI_2, 0.999 * FRAC_PI_2] {
                let a = super::reference_canonical(r, tau).unwrap();
                let d = super::reference_canonical_directions(r, tau).unwrap();
                let e = rel_l2(&d, &a);
                worst = worst.max(e);
                assert!(e < 1e-11, "R/d = {r}, tau = {tau}: {d:?} vs {a:?} ({e:e})");
            }
        }
        println!("direction vs area reference: worst relative L2 {worst:.2e}");
    }

    use super::*;

    /// The fit against the independent reference at a spread of points, including
    /// near-rim and grazing ones.
    #[test]
    fn fit_matches_reference() {
        let mut worst: f64 = 0.0;
        for &(r, tau) in &[
            (0.01, 0.0),
            (0.01, 1.5),
            (0.3, 0.7),
            (1.0, 0.0),
            (1.0, 1.5),
            (0.999, 1.53),
            (1.001, 1.53),
            (3.0, 1.2),
            (10.0, 1.5),
            (10.0, 0.3),
        ] {
            let (c, res, _) = fit_canonical(r, tau);
            assert!(res < MAX_RESIDUAL, "r={r} tau={tau}: residual {res}");
            let want = reference_canonical(r, tau).unwrap();
            let e = c.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / want[0];
            worst = worst.max(e);
            assert!(e < 1e-8, "r={r} tau={tau}: {c:?} vs {want:?}");
        }
        eprintln!("disk fit vs GK reference: max abs/c00 {worst:.2e}");
    }
}
