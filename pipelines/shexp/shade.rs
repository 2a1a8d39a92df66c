//! Ren et al. 2006 / Giraud & Nowrouzezahrai 2015 shading of one point
//! (docs/shexp-render.md): log-SH visibility summed from the height field's wedges and
//! each sphere blocker's log-ZH vector, plus the log-ZH BRDF lobe, exponentiated once
//! (HYB) and dotted with the light's SH vector.
//!
//! Every approximation has an exact counterpart behind a [`Settings`] switch, so the
//! error breakdown can make them exact one at a time: the pyramid horizon (→ the exact
//! horizon), the wedge count, HYB (→ exp* by its Taylor series), the log-space BRDF
//! (→ the triple product of exp*(visibility) with the BRDF × cosine projected exactly).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use lobefit_tables::glam::DVec3;
use lobefit_tables::wedge::slice_log;
use lobefit_tables::{log_zh, sh as rt, ShExp, Wedge};

use crate::scene::{Hit, Scene};
use crate::sky::Phong;
use lobefit_core::sh::{Gaunt, SphereRule};

/// How the height field's horizon is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Horizon {
    /// Giraud's multi-resolution pyramid march (the thesis's choice).
    Pyramid,
    /// The exact horizon of the bilinear surface.
    Exact,
}

/// The log of a sphere blocker's visibility.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockerLog {
    /// The ε-floored projection (log-zh's closed form; Giraud eq. 4.24).
    Eps,
    /// Ren's product-matrix log (the shexp table's, independent of ε).
    Ren,
}

/// How the summed log vector is exponentiated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exp {
    /// HYB with the shexp table's a, b (the pipeline).
    Hyb,
    /// exp* by its Taylor series run to convergence (DC isolated).
    Exact,
}

/// Overlap weighting of the blockers' logs: each blocker's log vector divided by its
/// cap's mean coverage, 1 + Σ_j |cap_i ∩ cap_j| / |cap_i| over other blockers j kept at
/// the point ([`cap_overlap`]), so that where caps overlap their summed ln ε steps are
/// about one step deep, not one per cap.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Overlap {
    /// No weighting (Giraud).
    Off,
    /// Every other blocker's cap counts.
    Caps,
    /// Only blockers whose spheres intersect this one's in space count (one object
    /// built of overlapping spheres, as the whale is; caps that overlap only in
    /// projection, one sphere behind another, are left as they are).
    Touching,
}

/// How the BRDF enters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BrdfMode {
    /// Its log-ZH lobe added to the log visibility before exponentiating (Giraud §4.6):
    /// the diffuse lobe max(cos, 0)/π about the normal, the Phong lobe
    /// (r+1)/(2π) cos^r about the mirror direction times k_s (r+2)/(r+1) (n·r)₊ (the
    /// cosine factor taken at the lobe's axis).
    Log,
    /// The SH triple product of exp*(log visibility) with the exact BRDF × cosine
    /// projected at the point (a quadrature rule exact for the band limit).
    Triple,
}

/// The pipeline's switches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// SH order n (bands 0 … n−1), 3 ≤ n ≤ 8.
    pub order: usize,
    /// Azimuthal wedges W (4, 8, 16, 32 or 64).
    pub wedges: u32,
    /// Horizon search.
    pub horizon: Horizon,
    /// Floor ε of the sphere blockers' log visibility (with [`BlockerLog::Eps`]).
    pub eps_vis: f64,
    /// Floor ε of the height field's log visibility (the wedges).
    pub eps_terrain: f64,
    /// The height field blocks only between the point's tangent plane and its horizon
    /// in each azimuth (below the tangent plane the BRDF's own log lobe is already
    /// ln ε); off: everything below the horizon (Giraud).
    pub terrain_above_tangent: bool,
    /// Floor ε of the log-ZH BRDF lobes.
    pub eps_brdf: f64,
    /// Blocker logs.
    pub blocker_log: BlockerLog,
    /// Giraud's attenuation: each blocker's log vector times r/‖c − p‖.
    pub attenuation: bool,
    /// Overlap weighting (a candidate; off in the defaults).
    pub overlap: Overlap,
    /// Exponentiation.
    pub exp: Exp,
    /// BRDF.
    pub brdf: BrdfMode,
}

impl Default for Settings {
    /// The defaults `render shexp` and `eval shexp-shade` use (docs/shexp-render.md says
    /// why each).
    fn default() -> Self {
        Settings {
            order: 4,
            wedges: 16,
            horizon: Horizon::Pyramid,
            eps_vis: 0.1,
            eps_terrain: 0.5,
            terrain_above_tangent: false,
            eps_brdf: 0.01,
            blocker_log: BlockerLog::Eps,
            attenuation: true,
            overlap: Overlap::Off,
            exp: Exp::Hyb,
            brdf: BrdfMode::Log,
        }
    }
}

impl Settings {
    /// Checks the switches' domains.
    pub fn validate(&self) -> Result<(), String> {
        if !(3..=8).contains(&self.order) {
            return Err(format!("SH order {} must lie in 3..=8", self.order));
        }
        if !lobefit_tables::wedge::WEDGE_COUNTS.contains(&self.wedges) {
            return Err(format!(
                "wedge count {} must be one of {:?}",
                self.wedges,
                lobefit_tables::wedge::WEDGE_COUNTS
            ));
        }
        for (what, e) in [
            ("eps_vis", self.eps_vis),
            ("eps_terrain", self.eps_terrain),
            ("eps_brdf", self.eps_brdf),
        ] {
            if !(0.01..=0.99).contains(&e) {
                return Err(format!("{what} {e} must lie in [0.01, 0.99]"));
            }
        }
        Ok(())
    }
}

/// The tables the pipeline reads.
#[derive(Debug, Clone)]
pub struct Tables {
    /// HYB's a, b and Ren's blocker logs.
    pub shexp: ShExp,
    /// The wedge operators M_lin.
    pub wedge: Wedge,
}

impl Tables {
    /// The committed tables.
    pub fn embedded() -> Result<Tables, String> {
        Ok(Tables {
            shexp: ShExp::embedded().map_err(|e| e.to_string())?.clone(),
            wedge: Wedge::embedded().map_err(|e| e.to_string())?.clone(),
        })
    }
}

/// The SH vector (order n) of a distant light given as SGs, each projected exactly
/// (its ZH in closed form, [`lobefit_core::sh::sg_zh`], turned to its axis) for every
/// sharpness: a sharp SG keeps its energy in the low bands.
pub fn project_sgs(env: &[lobefit_tables::isg::Sg], order: usize) -> Result<Vec<f64>, String> {
    let nc = order * order;
    let mut out = vec![0.0; nc];
    let mut turned = vec![0.0; nc];
    for g in env {
        let mut zh = lobefit_core::sh::sg_zh(order, g.sharpness)?;
        zh.iter_mut().for_each(|z| *z *= g.amplitude);
        rt::zh_to_sh(&zh, g.axis, &mut turned).map_err(|e| e.to_string())?;
        out.iter_mut().zip(&turned).for_each(|(o, t)| *o += t);
    }
    Ok(out)
}

/// Σ_i c_i y_i(ω): an SH vector's value in direction `w` (unit).
pub fn sh_value(c: &[f64], w: DVec3) -> f64 {
    let mut y = [0.0; rt::MAX_COEFFS];
    let n = (c.len() as f64).sqrt() as usize;
    rt::eval_basis(n, w, &mut y[..c.len()]).expect("order checked by the caller");
    c.iter().zip(&y).map(|(a, b)| a * b).sum()
}

/// The log-SH visibility at hit `h` (world frame, order `s.order`): the height field's
/// wedges about +z and every sphere but the hit's own. Spheres whose cap lies wholly
/// below the tangent plane are skipped (they cannot shadow the point; Giraud culls at
/// the cap's centre, which drops half-visible caps).
pub fn log_visibility(t: &Tables, s: &Settings, scene: &Scene, h: &Hit) -> Result<Vec<f64>, String> {
    let n = s.order;
    let nc = n * n;
    let mut f = vec![0.0; nc];
    if let Some((hf, _)) = &scene.heightfield {
        let w = s.wedges as usize;
        let mut slices = vec![0.0; w * n];
        let mut low = [0.0; 8];
        for (k, slice) in slices.chunks_exact_mut(n).enumerate() {
            let phi = TAU * k as f64 / w as f64;
            let sigma = match s.horizon {
                Horizon::Exact => hf.horizon_exact(h.x.x, h.x.y, h.x.z, phi),
                Horizon::Pyramid => hf.horizon_pyramid(h.x.x, h.x.y, h.x.z, phi),
            };
            if s.terrain_above_tangent {
                // The tangent plane's elevation in this azimuth: n·d = 0 for
                // d = (cos e cos φ, cos e sin φ, sin e).
                let (sp, cp) = phi.sin_cos();
                let beta = (-(h.n.x * cp + h.n.y * sp)).atan2(h.n.z).clamp(-FRAC_PI_2, FRAC_PI_2);
                slice_log(sigma.max(beta), s.eps_terrain, n, slice).map_err(|e| e.to_string())?;
                slice_log(beta, s.eps_terrain, n, &mut low).map_err(|e| e.to_string())?;
                slice.iter_mut().zip(&low).for_each(|(a, b)| *a -= b);
            } else {
                slice_log(sigma, s.eps_terrain, n, slice).map_err(|e| e.to_string())?;
            }
        }
        t.wedge.compose_slices(&slices, n, &mut f).map_err(|e| e.to_string())?;
    }
    let mut zh = [0.0; 8];
    let mut turned = [0.0; rt::MAX_COEFFS];
    // The blockers: the spheres and the meshes' sphere sets, but those the point lies
    // on or in.
    let own = scene.own_proxies(h);
    let mut caps = Vec::new();
    for (i, b) in scene.proxies.iter().enumerate() {
        if own.contains(&i) {
            continue;
        }
        let (dir, theta_b) = log_zh::sphere_cap(h.x, b.centre, b.radius).map_err(|e| e.to_string())?;
        if h.n.dot(dir) < -theta_b.sin() {
            continue;
        }
        caps.push((dir, theta_b, b));
    }
    for (i, &(dir, theta_b, b)) in caps.iter().enumerate() {
        match s.blocker_log {
            BlockerLog::Eps => log_zh::blocker(s.eps_vis, theta_b, n, &mut zh),
            BlockerLog::Ren => t.shexp.log_zh(theta_b, n, &mut zh),
        }
        .map_err(|e| e.to_string())?;
        if s.attenuation {
            let k = theta_b.sin();
            zh[..n].iter_mut().for_each(|z| *z *= k);
        }
        if s.overlap != Overlap::Off {
            let area = TAU * (1.0 - theta_b.cos());
            let counts = |o: &crate::scene::Sphere| {
                s.overlap == Overlap::Caps || (o.centre - b.centre).length() < o.radius + b.radius
            };
            let covered: f64 = caps
                .iter()
                .enumerate()
                .filter(|&(j, &(_, _, o))| j != i && counts(o))
                .map(|(_, &(d, t, _))| cap_overlap(theta_b, t, dir.dot(d).clamp(-1.0, 1.0).acos()))
                .sum();
            let k = 1.0 / (1.0 + covered / area);
            zh[..n].iter_mut().for_each(|z| *z *= k);
        }
        rt::zh_to_sh(&zh[..n], dir, &mut turned[..nc]).map_err(|e| e.to_string())?;
        f.iter_mut().zip(&turned[..nc]).for_each(|(a, b)| *a += b);
    }
    Ok(f)
}

/// The solid angle (sr) of the intersection of two spherical caps of angular radii
/// `a` and `b` (rad, each ≤ π/2) whose axes are `g` apart (Tovchigrechko and Vakser's
/// closed form: the lune's area from the spherical triangle at the caps' crossing
/// points); 0 apart, the smaller cap when one contains the other.
pub fn cap_overlap(a: f64, b: f64, g: f64) -> f64 {
    if g >= a + b {
        return 0.0;
    }
    if g <= (a - b).abs() {
        return TAU * (1.0 - a.min(b).cos());
    }
    let (sa, ca) = a.sin_cos();
    let (sb, cb) = b.sin_cos();
    let (sg, cg) = g.sin_cos();
    let acos = |x: f64| x.clamp(-1.0, 1.0).acos();
    let t1 = acos((cg - ca * cb) / (sa * sb));
    let t2 = acos((cb - cg * ca) / (sg * sa));
    let t3 = acos((ca - cg * cb) / (sg * sb));
    (2.0 * (PI - t1 - ca * t2 - cb * t3)).max(0.0)
}

/// Largest mean visibility (the fraction of the sphere seen, exp*(f)'s DC term over
/// √(4π)) a pixel may show before [`radiance`] refuses it. An exact visibility's mean
/// is at most 1 whatever its band limit (ringing does not move the DC term), so a mean
/// above 1 is exp* failing. The margin admits HYB's measured error on the built-in
/// scenes (whale: one pixel in 22 505 at 1.19, every other ≤ 1; wrecking ≤ 0.99).
pub const VIS_MEAN_MAX: f64 = 1.25;

/// The visibility exp*(f) of the log visibility `f` with `mode` (the triple-product
/// BRDF mode reuses it), refused when its mean exp*(f)_0/√(4π) is above
/// [`VIS_MEAN_MAX`]: overlapping blockers count once per sphere in log space, and
/// beyond the norms HYB was fitted on (docs/shexp.md: random scenes reach ‖f̂‖ of
/// 1.6–4.2) truncated exp* amplifies the log's ringing exponentially. N copies of one
/// blocker at order 4: mean 0.99 at N = 10, 1.39 at N = 30, 6.1 at N = 100, 1.5e10 at
/// N = 1000 (the radiance 5.7e9 times the exact one), exact exp* no better.
pub fn checked_visibility(t: &Tables, mode: Exp, f: &[f64]) -> Result<Vec<f64>, String> {
    let v = exponentiate(t, mode, f)?;
    let mean = v[0] / (4.0 * PI).sqrt();
    if mean <= VIS_MEAN_MAX {
        return Ok(v);
    }
    let norm = f[1..].iter().map(|v| v * v).sum::<f64>().sqrt();
    Err(format!(
        "mean visibility {mean:.3e} above {VIS_MEAN_MAX} (|f_hat| = {norm:.1}): SH exponentiation left its \
         range here (too many overlapping blockers)"
    ))
}

/// exp*(f) by `mode`.
pub fn exponentiate(t: &Tables, mode: Exp, f: &[f64]) -> Result<Vec<f64>, String> {
    match mode {
        Exp::Hyb => {
            let mut out = vec![0.0; f.len()];
            t.shexp.hyb(f, &mut out).map_err(|e| e.to_string())?;
            Ok(out)
        }
        Exp::Exact => {
            let n = rt::order_of_len(f.len()).map_err(|e| e.to_string())?;
            let r = lobefit_core::sh::exp_star(Gaunt::cached(n).map_err(|e| e.to_string())?, f);
            if !r.converged {
                return Err("exp* of the log visibility did not converge".into());
            }
            Ok(r.value)
        }
    }
}

/// The mirror direction of the view about the normal.
pub fn mirror(h: &Hit) -> DVec3 {
    (2.0 * h.n.dot(h.wo) * h.n - h.wo).normalize()
}

/// One BRDF × cosine term: its weight, log-ZH lobe and lobe axis, and the term itself
/// for the triple product.
type LobeTerm = (f64, Vec<f64>, DVec3, Term);

/// The BRDF × cosine terms of `brdf` at `h`.
fn terms(s: &Settings, brdf: &Phong, h: &Hit) -> Result<Vec<LobeTerm>, String> {
    let n = s.order;
    let mut out = Vec::new();
    if brdf.diffuse > 0.0 {
        let mut z = vec![0.0; n];
        log_zh::diffuse(s.eps_brdf, n, &mut z).map_err(|e| e.to_string())?;
        out.push((brdf.diffuse, z, h.n, Term::Diffuse));
    }
    if brdf.specular > 0.0 {
        let r = brdf.exponent;
        if !(1.0..=log_zh::R_MAX).contains(&r) {
            return Err(format!(
                "Phong exponent {r} outside the log-ZH lobes' [1, {}]",
                log_zh::R_MAX
            ));
        }
        let m = mirror(h);
        let mut z = vec![0.0; n];
        log_zh::phong(s.eps_brdf, r, n, &mut z).map_err(|e| e.to_string())?;
        let w = brdf.specular * (r + 2.0) / (r + 1.0) * h.n.dot(m).max(0.0);
        out.push((w, z, m, Term::Specular(brdf.specular, r, m)));
    }
    Ok(out)
}

/// One BRDF × cosine term evaluated exactly (for [`BrdfMode::Triple`]).
#[derive(Debug, Clone, Copy)]
enum Term {
    /// max(n·ω, 0)/π (times k_d, the term's weight).
    Diffuse,
    /// k_s (r+2)/(2π) max(m·ω, 0)^r max(n·ω, 0): (k_s, r, mirror direction).
    Specular(f64, f64, DVec3),
}

/// Outgoing radiance at hit `h` with the pipeline `s`, the light's SH vector `light`
/// (order `s.order`).
pub fn radiance(t: &Tables, s: &Settings, light: &[f64], brdf: &Phong, scene: &Scene, h: &Hit) -> Result<f64, String> {
    // A band-limited product rings below zero in dark places; radiance cannot.
    Ok(integrand(t, s, light, brdf, scene, h)?.value.max(0.0))
}

/// The pipeline's shading at one point as a function of direction, without the light:
/// Σ_t w_t g_t(ω), each BRDF term's band-limited visibility × BRDF × cosine (the
/// exponentiated log sum, or the Gaunt product) with its weight. The pipeline's
/// radiance is Σ_t w_t ⟨g_t, light⟩ = ∫ L(ω) Σ_t w_t g_t(ω) dω exactly for the true
/// light L whose order-n projection `light` is (the SH are orthonormal, and g_t has no
/// higher bands), so a(ω) = L(ω) [`Integrand::eval`](ω) has the pipeline's value as
/// its exact integral: the `hybrid` estimator's control variate.
#[derive(Debug, Clone)]
pub struct Integrand {
    /// The pipeline's radiance, not clamped at 0.
    pub value: f64,
    /// (w_t, g_t's SH coefficients).
    terms: Vec<(f64, Vec<f64>)>,
}

impl Integrand {
    /// Σ_t w_t g_t(ω) at the unit direction `w` (per steradian, per unit radiance;
    /// any sign, non-zero below the horizon).
    pub fn eval(&self, w: DVec3) -> f64 {
        self.terms.iter().map(|(k, g)| k * sh_value(g, w)).sum()
    }

    /// Σ_t w_t g_t as one SH vector of order `order` (order² coefficients; a point in
    /// a blocker's full shadow has no terms: zeros).
    pub fn coefficients(&self, order: usize) -> Vec<f64> {
        let mut c = vec![0.0; order * order];
        for (k, g) in &self.terms {
            for (a, b) in c.iter_mut().zip(g) {
                *a += k * b;
            }
        }
        c
    }
}

/// The pipeline's [`Integrand`] at hit `h` (inputs as [`radiance`]).
pub fn integrand(
    t: &Tables,
    s: &Settings,
    light: &[f64],
    brdf: &Phong,
    scene: &Scene,
    h: &Hit,
) -> Result<Integrand, String> {
    let n = s.order;
    let nc = n * n;
    if light.len() != nc {
        return Err(format!(
            "light has {} SH coefficients, order {n} needs {nc}",
            light.len()
        ));
    }
    if scene.buried(h) {
        // Inside a blocker (a mesh's covering sphere): its full shadow.
        return Ok(Integrand {
            value: 0.0,
            terms: Vec::new(),
        });
    }
    let fv = log_visibility(t, s, scene, h)?;
    let vis = checked_visibility(t, s.exp, &fv)?;
    let mut total = 0.0;
    let mut turned = vec![0.0; nc];
    let mut kept = Vec::new();
    for (weight, zh, axis, term) in terms(s, brdf, h)? {
        let (k, g) = match s.brdf {
            BrdfMode::Log => {
                rt::zh_to_sh(&zh, axis, &mut turned).map_err(|e| e.to_string())?;
                let f: Vec<f64> = fv.iter().zip(&turned).map(|(a, b)| a + b).collect();
                (weight, exponentiate(t, s.exp, &f)?)
            }
            BrdfMode::Triple => {
                let rho = project_term(term, h, n);
                let gaunt = Gaunt::cached(n).map_err(|e| e.to_string())?;
                let k = match term {
                    Term::Diffuse => brdf.diffuse,
                    Term::Specular(..) => 1.0,
                };
                (k, gaunt.product(&vis, &rho))
            }
        };
        total += k * g.iter().zip(light).map(|(a, b)| a * b).sum::<f64>();
        kept.push((k, g));
    }
    if !total.is_finite() {
        return Err(format!("non-finite radiance at {:?}", h.x));
    }
    Ok(Integrand {
        value: total,
        terms: kept,
    })
}

/// The exact SH projection (order n) of one BRDF × cosine term at `h`, by a product
/// rule with 64 Gauss–Legendre nodes in z and 128 in φ (the clamps make it converge
/// slowly; at r ≤ 5 it agrees with 128 × 256 nodes to about 1e-5).
fn project_term(term: Term, h: &Hit, n: usize) -> Vec<f64> {
    thread_local! {
        static RULE: SphereRule = SphereRule::new(64, 128);
    }
    let nrm = h.n;
    RULE.with(|rule| {
        rule.project(n, |w| {
            let w = DVec3::from_array(w);
            let c = nrm.dot(w).max(0.0);
            match term {
                Term::Diffuse => c / PI,
                Term::Specular(ks, r, m) => ks * (r + 2.0) / TAU * m.dot(w).max(0.0).powf(r) * c,
            }
        })
    })
}
