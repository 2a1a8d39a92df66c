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
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exp {
    /// HYB with the shexp table's a, b (the pipeline).
    Hyb,
    /// exp* by its Taylor series run to convergence (DC isolated).
    Exact,
    /// HYB re-fitted on multi-blocker sums (a candidate, docs/shexp-render.md): the OL
    /// coefficients at the halved norm s times (e^{dc·s}, e^{hat·s}). After HYB's k
    /// squarings (s = ‖f̂‖/2^k) the first factor is about e^{dc·‖f̂‖} on the mean
    /// visibility, the second reweights the non-constant bands; (0, 0) is HYB bit for
    /// bit. The single-cap table's a, b were fitted to one cap's exp*; summed logs of
    /// many blockers are what the pipeline exponentiates.
    HybScaled {
        /// Exponent rate on a (per unit ‖f̂‖).
        dc: f64,
        /// Exponent rate on b (per unit ‖f̂‖).
        hat: f64,
    },
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

/// Blocker caps whose occlusion is projected exactly instead of through the log sum.
/// A group of caps that meets no other cap and lies above the height field's highest
/// sampled horizon hides a region disjoint from everything else's, so the visibility is
/// exactly V_rest − Σ_groups 1_group and ρ V = ρ V_rest − Σ_groups ρ 1_group: the first
/// term by the pipeline (exponentiation), each group's by a rule over its caps
/// ([`project_term_on_caps`]: the exact BRDF × cosine, each direction counted in the
/// first of the group's caps that holds it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExactCaps {
    /// Every blocker in the log sum (Giraud).
    Off,
    /// Lone caps (groups of one) apart.
    Lone,
    /// Every group of at most [`GROUP_MAX`] caps apart.
    Groups,
}

/// The most caps a group of [`ExactCaps::Groups`] may hold; larger groups stay in the
/// log sum (the rule's first-cap test costs the group's size squared: the wrecking
/// ball's shell, one group of up to 402 caps, took 4.3 ms a pixel).
pub const GROUP_MAX: usize = 16;

/// [`ExactCaps`] looks for groups only where at most this many caps are kept at the
/// point (the pairwise overlap test costs their number squared: 80 µs a pixel for the
/// wrecking ball's 402); beyond, every cap stays in the log sum.
pub const CAPS_MAX: usize = 64;

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
    /// Caps taken out of the log sum and projected exactly (a candidate; off in the
    /// defaults).
    pub exact_caps: ExactCaps,
    /// Per-band factors (≥ 0) on every sphere blocker's log-ZH vector in the log sum
    /// (band l's coefficient times `blocker_bands[l]`, after the attenuation and the
    /// overlap weighting; caps taken out by [`Settings::exact_caps`] have no log; bands
    /// from the order on are unused): the per-blocker log vectors fitted so that exp*
    /// of their sums matches the product of visibilities (a candidate,
    /// docs/shexp-render.md; all 1 in the defaults, which leaves the bits).
    pub blocker_bands: [f64; 8],
    /// Exponentiation.
    pub exp: Exp,
    /// BRDF.
    pub brdf: BrdfMode,
    /// The blockers through the sphere hierarchy's cut at this angle (rad;
    /// [`Scene::proxy_tree`]: a node whose bound subtends less from outside it is one
    /// stand-in sphere); 0, the flat set (the defaults).
    pub cut: f64,
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
            exact_caps: ExactCaps::Off,
            blocker_bands: [1.0; 8],
            exp: Exp::Hyb,
            brdf: BrdfMode::Log,
            cut: 0.0,
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
        if let Some((l, k)) = self
            .blocker_bands
            .iter()
            .enumerate()
            .find(|(_, k)| !(k.is_finite() && **k >= 0.0))
        {
            // A negative factor would turn a band of a blocker's shadow into light.
            return Err(format!("blocker band factor {k} of band {l} must be finite and ≥ 0"));
        }
        if let Exp::HybScaled { dc, hat } = self.exp {
            if !(dc.is_finite() && hat.is_finite()) {
                return Err(format!("HYB's re-fitted rates dc {dc}, hat {hat} must be finite"));
            }
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
    let all = Settings {
        exact_caps: ExactCaps::Off,
        ..*s
    };
    Ok(log_parts(t, &all, scene, h)?.rest)
}

/// The log visibility split for [`Settings::exact_caps`]: the caps apart in groups
/// (none with [`ExactCaps::Off`]), the rest summed.
#[derive(Debug, Clone)]
pub struct LogParts {
    /// The height field's wedges and every blocker not apart, summed.
    pub rest: Vec<f64>,
    /// The groups apart, each its caps: axis (unit, world) and angular radius (rad).
    pub groups: Vec<Vec<(DVec3, f64)>>,
}

/// [`log_visibility`]'s terms, the groups of [`Settings::exact_caps`] apart.
pub fn log_parts(t: &Tables, s: &Settings, scene: &Scene, h: &Hit) -> Result<LogParts, String> {
    let n = s.order;
    let nc = n * n;
    let mut f = vec![0.0; nc];
    // The highest horizon elevation over the wedges (rad; −π/2 without a height field):
    // a cap wholly above it meets no terrain shadow.
    let mut horizon_max = -FRAC_PI_2;
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
            horizon_max = horizon_max.max(sigma);
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
    // With a cut: its stand-ins and the leaves it reaches, the own ones skipped there.
    let mut cut = Vec::new();
    if s.cut > 0.0 {
        scene
            .proxy_tree()
            .cut(h.x, s.cut, crate::scene::OWN_MARGIN, |i| own.contains(&i), &mut cut);
    }
    let blockers = if s.cut > 0.0 { &cut[..] } else { &scene.proxies[..] };
    let mut caps = Vec::new();
    for (i, b) in blockers.iter().enumerate() {
        if s.cut <= 0.0 && own.contains(&i) {
            continue;
        }
        // A stand-in may reach past its node's bound and hold the point, which lies
        // outside every sphere of that node (else it would have been opened): it
        // shadows nothing there, as in the ISG pipeline and the GPU kernels.
        if s.cut > 0.0 && (h.x - b.centre).length() <= b.radius {
            continue;
        }
        let (dir, theta_b) = log_zh::sphere_cap(h.x, b.centre, b.radius).map_err(|e| e.to_string())?;
        if h.n.dot(dir) < -theta_b.sin() {
            continue;
        }
        caps.push((dir, theta_b, b));
    }
    // Each cap's group when it leaves the log sum (nothing to do with the switch off).
    let group_of = match s.exact_caps {
        ExactCaps::Off => Vec::new(),
        mode => {
            let axes: Vec<(DVec3, f64)> = caps.iter().map(|&(d, a, _)| (d, a)).collect();
            cap_groups(&axes, horizon_max, mode)
        }
    };
    let mut groups: Vec<Vec<(DVec3, f64)>> = Vec::new();
    for (i, &(dir, theta_b, b)) in caps.iter().enumerate() {
        if let Some(&Some(g)) = group_of.get(i) {
            if g == groups.len() {
                groups.push(Vec::new());
            }
            groups[g].push((dir, theta_b));
            continue;
        }
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
        zh[..n].iter_mut().zip(&s.blocker_bands).for_each(|(z, k)| *z *= k);
        rt::zh_to_sh(&zh[..n], dir, &mut turned[..nc]).map_err(|e| e.to_string())?;
        f.iter_mut().zip(&turned[..nc]).for_each(|(a, b)| *a += b);
    }
    Ok(LogParts { rest: f, groups })
}

/// The groups of [`ExactCaps`] `mode` among the kept `caps` (axis unit, angular radius
/// in rad): per cap the index of its group, numbered in order of the groups' first
/// caps, or `None` where it stays in the log sum. A group is a connected component of
/// the caps under overlap (axes closer than the two half-angles, by cosines with 1e-12
/// of slack towards meeting); a component with a cap reaching below `horizon_max`, the
/// highest of the wedges' sampled horizons (rad; it bounds the terrain's log region:
/// the wedges interpolate between their samples; 1 mrad of slack for a cap resting on
/// flat ground), joins the terrain and stays, as do components larger than the mode
/// allows and every cap where more than [`CAPS_MAX`] are kept.
fn cap_groups(caps: &[(DVec3, f64)], horizon_max: f64, mode: ExactCaps) -> Vec<Option<usize>> {
    let m = caps.len();
    if mode == ExactCaps::Off || m > CAPS_MAX {
        return vec![None; m];
    }
    let mut parent: Vec<usize> = (0..=m).collect(); // m: the terrain
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let trig: Vec<(f64, f64)> = caps.iter().map(|&(_, a)| a.sin_cos()).collect();
    for (i, &(d, a)) in caps.iter().enumerate() {
        if d.z.clamp(-1.0, 1.0).asin() - a < horizon_max - 1e-3 {
            let (ri, rm) = (root(&mut parent, i), root(&mut parent, m));
            parent[ri] = rm;
        }
        for (j, &(e, b)) in caps.iter().enumerate().skip(i + 1) {
            // cos(a + b) = cos a cos b − sin a sin b.
            if a + b >= PI || d.dot(e) > trig[i].1 * trig[j].1 - trig[i].0 * trig[j].0 - 1e-12 {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                parent[ri] = rj;
            }
        }
    }
    let roots: Vec<usize> = (0..=m).map(|i| root(&mut parent, i)).collect();
    let mut size = vec![0usize; m + 1];
    roots[..m].iter().for_each(|&r| size[r] += 1);
    let most = if mode == ExactCaps::Lone { 1 } else { GROUP_MAX };
    let mut index = vec![usize::MAX; m + 1];
    let mut count = 0;
    roots[..m]
        .iter()
        .map(|&r| {
            (r != roots[m] && size[r] <= most).then(|| {
                if index[r] == usize::MAX {
                    index[r] = count;
                    count += 1;
                }
                index[r]
            })
        })
        .collect()
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
        Exp::HybScaled { dc, hat } => {
            use lobefit_tables::shexp::{hyb_with, ol_threshold};
            let n = rt::order_of_len(f.len()).map_err(|e| e.to_string())?;
            // HYB's own order check (3..=8) first: the threshold is per order.
            let threshold = ol_threshold(n).map_err(|e| e.to_string())?;
            let gaunt = Gaunt::cached(n).map_err(|e| e.to_string())?;
            let ab = |s: f64| {
                t.shexp
                    .ab_for_norm(s, n)
                    .map(|(a, b)| (a * (dc * s).exp(), b * (hat * s).exp()))
            };
            let mut out = vec![0.0; f.len()];
            hyb_with(gaunt, f, threshold, ab, &mut out).map_err(|e| e.to_string())?;
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

/// One BRDF × cosine term evaluated exactly (for [`BrdfMode::Triple`] and
/// [`ExactCaps`]).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Term {
    /// max(n·ω, 0)/π (times k_d, the term's weight).
    Diffuse,
    /// k_s (r+2)/(2π) max(m·ω, 0)^r max(n·ω, 0): (k_s, r, mirror direction).
    Specular(f64, f64, DVec3),
    /// (r+1)/(2π) max(m·ω, 0)^r: the Phong log lobe's own function, (r, its axis).
    Lobe(f64, DVec3),
}

impl Term {
    /// The term's value in the unit direction `w` at a point with unit normal `nrm`
    /// (sr⁻¹).
    pub(crate) fn eval(self, nrm: DVec3, w: DVec3) -> f64 {
        let c = nrm.dot(w).max(0.0);
        match self {
            Term::Diffuse => c / PI,
            Term::Specular(ks, r, m) => ks * (r + 2.0) / TAU * m.dot(w).max(0.0).powf(r) * c,
            Term::Lobe(r, m) => (r + 1.0) / TAU * m.dot(w).max(0.0).powf(r),
        }
    }
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
    let parts = log_parts(t, s, scene, h)?;
    let fv = &parts.rest;
    let vis = checked_visibility(t, s.exp, fv)?;
    let mut total = 0.0;
    let mut turned = vec![0.0; nc];
    let mut kept = Vec::new();
    for (weight, zh, axis, term) in terms(s, brdf, h)? {
        let (k, mut g, exact) = match s.brdf {
            BrdfMode::Log => {
                rt::zh_to_sh(&zh, axis, &mut turned).map_err(|e| e.to_string())?;
                let f: Vec<f64> = fv.iter().zip(&turned).map(|(a, b)| a + b).collect();
                // g stands for the log lobe's own function × V: the Phong lobe with
                // the cosine taken at its axis (in `weight`).
                let exact = match term {
                    Term::Specular(_, r, m) => Term::Lobe(r, m),
                    t => t,
                };
                (weight, exponentiate(t, s.exp, &f)?, exact)
            }
            BrdfMode::Triple => {
                let rho = project_term(term, h, n);
                let gaunt = Gaunt::cached(n).map_err(|e| e.to_string())?;
                let k = match term {
                    Term::Diffuse => brdf.diffuse,
                    _ => 1.0,
                };
                (k, gaunt.product(&vis, &rho), term)
            }
        };
        // ρ V = ρ V_rest − Σ_groups ρ 1_group (the groups hide disjoint regions), ρ the
        // function g stands for.
        for caps in &parts.groups {
            let p = project_term_on_caps(exact, h.n, caps, n);
            g.iter_mut().zip(&p).for_each(|(x, y)| *x -= y);
        }
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

/// The SH projection (order n) of one BRDF × cosine term times the indicator of the
/// union of `caps` (axis unit, angular radius in rad), at a point of unit normal `nrm`.
///
/// Each cap is integrated in its own polar coordinates (u = cos θ, φ) over the part
/// left by the regions where the integrand is not one polynomial: the earlier caps of
/// the union (so each direction counts once), the half-space below the tangent plane
/// and, for the Phong term, the one behind its lobe — all caps themselves (a half-space
/// is a cap of π/2). At each u those cut arcs out of the circle; the rest is
/// integrated by Gauss–Legendre nodes per arc, and u by Gauss–Legendre nodes between
/// the polar angles where a cut region's edge becomes tangent to the circle (the
/// arcs' ends move smoothly in between). Where nothing is cut the rule is exact for the
/// polynomial of degree D (the basis n − 1, plus 1 for the diffuse term, r + 1 for an
/// integer Phong exponent with the cosine, r for the log lobe's own function):
/// ⌈(D+1)/2⌉ nodes in u, D + 1 evenly spaced azimuths — at most 8 nodes in u, so
/// exact up to D = 15 (Phong exponents up to 11 at order 4); beyond, a close rule.
pub(crate) fn project_term_on_caps(term: Term, nrm: DVec3, caps: &[(DVec3, f64)], n: usize) -> Vec<f64> {
    /// Nodes per arc and per cut interval of u where regions are cut out.
    const CUT_NODES: usize = 8;
    let degree = n - 1
        + match term {
            Term::Diffuse => 1,
            Term::Specular(_, r, _) => r.ceil().min(14.0) as usize + 1,
            Term::Lobe(r, _) => r.ceil().min(14.0) as usize,
        };
    let (nu_full, nphi_full) = ((degree + 1).div_ceil(2).min(8), degree + 1);
    thread_local! {
        static GL: Vec<(Vec<f64>, Vec<f64>)> = (0..=8).map(lobefit_core::sh::gauss_legendre).collect();
    }
    let nc = n * n;
    let mut out = vec![0.0; nc];
    let mut y = [0.0; rt::MAX_COEFFS];
    // The half-spaces where a clamp zeroes the term.
    let base = match term {
        Term::Diffuse => vec![(-nrm, FRAC_PI_2)],
        Term::Specular(_, _, m) => vec![(-nrm, FRAC_PI_2), (-m, FRAC_PI_2)],
        Term::Lobe(_, m) => vec![(-m, FRAC_PI_2)],
    };
    GL.with(|rules| {
        let mut add = |d: DVec3, w: f64| {
            let f = term.eval(nrm, d);
            if f != 0.0 {
                rt::eval_basis(n, d, &mut y[..nc]).expect("order checked by the caller");
                out.iter_mut().zip(&y[..nc]).for_each(|(o, b)| *o += w * f * b);
            }
        };
        'cap: for (i, &(axis, theta)) in caps.iter().enumerate() {
            let (ua, ub) = axis.any_orthonormal_pair();
            // The cut regions meeting this cap: (cos γ, sin γ, azimuth of the axis,
            // cos β) for a region of half-angle β whose axis is γ from this cap's.
            let mut cuts = Vec::new();
            let mut breaks = vec![theta.cos(), 1.0];
            for &(e, beta) in base.iter().chain(&caps[..i]) {
                let ce = e.dot(axis).clamp(-1.0, 1.0);
                let gamma = ce.acos();
                if gamma >= theta + beta {
                    continue;
                }
                if gamma + theta <= beta {
                    continue 'cap; // wholly cut out
                }
                let se = (1.0 - ce * ce).max(0.0).sqrt();
                cuts.push((ce, se, e.dot(ub).atan2(e.dot(ua)), beta.cos()));
                for t in [(gamma - beta).abs(), gamma + beta] {
                    if t < theta {
                        breaks.push(t.cos());
                    }
                }
            }
            breaks.sort_by(f64::total_cmp);
            let nu = if cuts.is_empty() { nu_full } else { CUT_NODES };
            let (x, w) = &rules[nu];
            for span in breaks.windows(2) {
                let (u0, u1) = (span[0], span[1]);
                if u1 <= u0 {
                    continue;
                }
                for (xk, wk) in x.iter().zip(w) {
                    let u = u0 + (u1 - u0) * 0.5 * (xk + 1.0);
                    let st = (1.0 - u * u).max(0.0).sqrt();
                    let wu = (u1 - u0) * 0.5 * wk;
                    let dir = |phi: f64| {
                        let (sp, cp) = phi.sin_cos();
                        u * axis + st * (cp * ua + sp * ub)
                    };
                    // The arcs cut out at this u: cos(φ − φ_e) > c.
                    let mut arcs: Vec<(f64, f64)> = Vec::new();
                    let mut all = false;
                    for &(ce, se, pe, cb) in &cuts {
                        let den = st * se;
                        if den <= 1e-300 {
                            all |= u * ce > cb;
                            continue;
                        }
                        let c = (cb - u * ce) / den;
                        if c <= -1.0 {
                            all = true;
                        } else if c < 1.0 {
                            let h = c.acos();
                            arcs.push(((pe - h).rem_euclid(TAU), 2.0 * h));
                        }
                    }
                    if all {
                        continue;
                    }
                    if arcs.is_empty() {
                        for j in 0..nphi_full {
                            add(
                                dir(TAU * (j as f64 + 0.5) / nphi_full as f64),
                                wu * TAU / nphi_full as f64,
                            );
                        }
                        continue;
                    }
                    // The circle's complement of the arcs, from the first arc's start.
                    arcs.sort_by(|a, b| a.0.total_cmp(&b.0));
                    let start = arcs[0].0;
                    // An arc running past 2π covers the circle's start again: the
                    // first free interval begins after the farthest such reach too.
                    let mut reach = arcs
                        .iter()
                        .fold(start + arcs[0].1, |r, &(s0, len)| r.max(s0 + len - TAU));
                    let mut free = Vec::new();
                    for &(s0, len) in &arcs[1..] {
                        if s0 > reach {
                            free.push((reach, s0));
                        }
                        reach = reach.max(s0 + len);
                    }
                    if reach < start + TAU {
                        free.push((reach, start + TAU));
                    }
                    let (xp, wp) = &rules[CUT_NODES];
                    for (p0, p1) in free {
                        for (xj, wj) in xp.iter().zip(wp) {
                            add(dir(p0 + (p1 - p0) * 0.5 * (xj + 1.0)), wu * (p1 - p0) * 0.5 * wj);
                        }
                    }
                }
            }
        }
    });
    out
}

/// The exact SH projection (order n) of one BRDF × cosine term at `h`, by a product
/// rule with 64 Gauss–Legendre nodes in z and 128 in φ (the clamps make it converge
/// slowly; at r ≤ 5 it agrees with 128 × 256 nodes to about 1e-5).
fn project_term(term: Term, h: &Hit, n: usize) -> Vec<f64> {
    thread_local! {
        static RULE: SphereRule = SphereRule::new(64, 128);
    }
    let nrm = h.n;
    RULE.with(|rule| rule.project(n, |w| term.eval(nrm, DVec3::from_array(w))))
}
