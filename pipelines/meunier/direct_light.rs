//! `lobefit eval direct-light`: the lobe pipeline without images (docs/meunier.md).
//!
//! Columns `px,py,pz,nx,ny,nz,lx,ly,lz,lr,bx,by,bz,br`: a point and its unit normal,
//! one spherical light of unit radiance (centre, radius), one spherical blocker
//! (centre, radius; `br = 0` means none). Output `irradiance` = ∫ L V max(n·ω, 0) dω
//! (W·m⁻² per unit radiance) through the lobe pipeline ([`lobefit_tables::Meunier`]);
//! `--exact` integrates the same by nested adaptive Gauss–Kronrod over the light's cap
//! with exact ray–sphere visibility ([`exact_irradiance`]).

use std::f64::consts::{FRAC_PI_2, TAU};

use lobefit_tables::geom::{Sphere, SphereLight};
use lobefit_tables::glam::DVec3;
use lobefit_tables::mask_weights::{MaskMode, MaskWeights, WeightSet, MAX_DEPTH};
use lobefit_tables::meunier::{check_scene, LightModel, MaskSettings};
use lobefit_tables::{CapExponent, LoadError, LobeProduct, LookupError, Meunier, MeunierError, Table};

use crate::scene::visible;
use lobefit_core::family::{EvalFlag, EvalFlags, Lookup, View};
use lobefit_core::quad::gauss_kronrod;
use lobefit_core::rng::Rng;
use lobefit_fits::mask_weights::MaskWeightsFamily;

/// Input columns.
pub const INPUTS: [&str; 14] = [
    "px", "py", "pz", "nx", "ny", "nz", "lx", "ly", "lz", "lr", "bx", "by", "bz", "br",
];

/// The paragraph of `lobefit eval --help`.
pub const EVAL_HELP: &str = "\
direct-light  [--depth N] (1..5, default 5)  [--mask aggressive|conservative]
              [--weights fitted|paper|one]   (reads the mask-weights table)
  in   `px`, `py`, `pz`  shading point;  `nx`, `ny`, `nz`  its unit normal
       `lx`, `ly`, `lz`, `lr`  centre and radius of a spherical light of radiance 1
       `bx`, `by`, `bz`, `br`  centre and radius of a spherical blocker (br = 0: none)
  out  `irradiance`  ∫ L V max(n·ω, 0) dω through the lobe pipeline (docs/meunier.md);
                  --exact: by quadrature with exact ray–sphere visibility
  --scene FILE: the scene's spherical lights, its spheres and its meshes' sphere sets as blockers, and its
       top-level brdf, as `render meunier` shades a pixel
  in   `px`,`py`,`pz`  the point; `nx`,`ny`,`nz` its unit normal; `vx`,`vy`,`vz` the unit direction to the viewer
  out  `radiance`    Σ over the lights of ∫ L f_r V max(n·ω, 0) dω through the lobe pipeline (0 inside a
                  mesh's covering sphere, with a warning); --exact: Monte Carlo over each light's cap with exact
                  visibility (the spheres and the meshes' true triangles) to a standard error of 1e-3 of the
                  estimate (a row stopped short at 2^24 samples keeps its estimate, with a warning naming it).
                  A point within 1e-5 of a surface's scale (either side: f32 positions) is moved onto it
";

/// Relative tolerance of the reference's nested Gauss–Kronrod.
pub const EXACT_REL_TOL: f64 = 1e-8;

/// The flags `eval direct-light` takes.
pub const FLAGS: &[EvalFlag] = &[
    EvalFlag {
        name: "depth",
        help: "maximal visibility-mask depth, 1..=5 (default 5)",
        count: true,
    },
    EvalFlag {
        name: "mask",
        help: "aggressive | conservative (default aggressive)",
        count: false,
    },
    EvalFlag {
        name: "weights",
        help: "fitted | paper | one (default fitted)",
        count: false,
    },
    EvalFlag {
        name: "light",
        help: "lobe | cap, how the light enters (default cap)",
        count: false,
    },
    EvalFlag {
        name: "scene",
        help: "FILE: shade points of a scene (its lights, spheres and meshes' sphere sets, top-level brdf)",
        count: false,
    },
];

/// The `eval direct-light` view (reads the mask-weights table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectLightView {
    /// Mask settings (`--depth`, `--mask`, `--weights`).
    pub settings: MaskSettings,
}

impl DirectLightView {
    /// From `eval`'s flags: `--depth N` (1..=5, default 5), `--mask aggressive|conservative`
    /// (default aggressive), `--weights fitted|paper|one` (default fitted).
    pub fn from_flags(flags: &EvalFlags) -> Result<Self, String> {
        flags.only("direct-light", FLAGS)?;
        let depth = flags.count("depth")?.unwrap_or(MAX_DEPTH as usize);
        if !(1..=MAX_DEPTH as usize).contains(&depth) {
            return Err(format!("direct-light: --depth {depth} is outside 1..={MAX_DEPTH}"));
        }
        let mode = match flags.text("mask").as_deref() {
            None | Some("aggressive") => MaskMode::Aggressive,
            Some("conservative") => MaskMode::Conservative,
            Some(m) => return Err(format!("--mask {m}: expected aggressive or conservative")),
        };
        let weights = match flags.text("weights").as_deref() {
            None | Some("fitted") => WeightSet::Fitted,
            Some("paper") => WeightSet::Paper,
            Some("one") => WeightSet::Ones,
            Some(w) => return Err(format!("--weights {w}: expected fitted, paper or one")),
        };
        let light = match flags.text("light").as_deref() {
            None => MaskSettings::default().light,
            Some(l) => LightModel::ALL
                .into_iter()
                .find(|m| m.name() == l)
                .ok_or_else(|| format!("--light {l}: expected lobe or cap"))?,
        };
        Ok(DirectLightView {
            settings: MaskSettings {
                depth: depth as u32,
                mode,
                weights,
                threshold: 0.0,
                light,
                ..MaskSettings::default()
            },
        })
    }
}

/// A parsed row: point, normal, light, optional blocker.
pub struct Row {
    /// Shading point.
    pub x: DVec3,
    /// Normal (as given).
    pub n: DVec3,
    /// The light (unit radiance).
    pub light: SphereLight,
    /// The blocker, if `br ≠ 0`.
    pub blocker: Option<Sphere>,
}

/// Reads a row of [`INPUTS`]. `br = 0` is "no blocker"; every other radius is passed
/// on (so ≤ 0 is the pipeline's specific error). Every column must be finite, the
/// unused blocker columns of `br = 0` too.
pub fn row(x: &[f64]) -> Result<Row, LookupError> {
    if let Some((name, &value)) = INPUTS.iter().zip(x).find(|(_, v)| !v.is_finite()) {
        return Err(LookupError::NotFinite {
            name: (*name).into(),
            value,
        });
    }
    let v = |i: usize| DVec3::new(x[i], x[i + 1], x[i + 2]);
    Ok(Row {
        x: v(0),
        n: v(3),
        light: SphereLight {
            sphere: Sphere {
                centre: v(6),
                radius: x[9],
            },
            radiance: 1.0,
        },
        blocker: (x[13] != 0.0).then(|| Sphere {
            centre: v(10),
            radius: x[13],
        }),
    })
}

/// A [`MeunierError`] as the [`LookupError`] `eval` reports: a lookup error as it is,
/// the scene's own refusals (geometry) as the domain they leave (the message keeps
/// what is wrong).
pub fn to_lookup(e: MeunierError) -> LookupError {
    match e {
        MeunierError::Lookup(e) => e,
        MeunierError::BadRadius { what, radius } => LookupError::OutOfDomain {
            name: format!("{what} radius (must be > 0)"),
            value: radius,
            lo: f64::MIN_POSITIVE,
            hi: f64::INFINITY,
        },
        MeunierError::NotUnit { name, length } => LookupError::OutOfDomain {
            name: format!("|{name}| (must be a unit vector)"),
            value: length,
            lo: 1.0 - 1e-3,
            hi: 1.0 + 1e-3,
        },
        MeunierError::PointInsideLight { distance, radius, .. } => LookupError::OutOfDomain {
            name: "distance from the point to the light's centre over its radius (the point is inside the light)"
                .into(),
            value: distance / radius,
            lo: 1.0,
            hi: f64::INFINITY,
        },
        MeunierError::PointInsideBlocker { distance, radius, .. } => LookupError::OutOfDomain {
            name: "distance from the point to the blocker's centre over its radius (the point is inside the blocker)"
                .into(),
            value: distance / radius,
            lo: 1.0,
            hi: f64::INFINITY,
        },
        MeunierError::BatchItem { index, error } => LookupError::BatchItem {
            index,
            error: Box::new(to_lookup(*error)),
        },
        e @ MeunierError::NotLobes => LookupError::Refused { reason: e.to_string() },
        MeunierError::LightInsideBlocker { margin, .. } => LookupError::OutOfDomain {
            name: "the light lies inside the blocker: (distance between centres + light radius) − blocker radius"
                .into(),
            value: margin,
            lo: f64::MIN_POSITIVE,
            hi: f64::INFINITY,
        },
    }
}

struct DirectLookup {
    weights: MaskWeights,
    settings: MaskSettings,
}

impl DirectLookup {
    fn pipeline(&self) -> Result<Meunier<'_>, LookupError> {
        let bad = |e: LoadError| LookupError::NotFinite {
            name: format!("embedded table ({e})"),
            value: f64::NAN,
        };
        Ok(Meunier {
            products: LobeProduct::embedded().map_err(bad)?,
            caps: CapExponent::embedded().map_err(bad)?,
            weights: &self.weights,
        })
    }
}

impl Lookup for DirectLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let r = row(x)?;
        let blockers: Vec<Sphere> = r.blocker.into_iter().collect();
        let e = self
            .pipeline()?
            .irradiance(r.x, r.n, &[r.light], &blockers, &self.settings)
            .map_err(to_lookup)?;
        Ok(vec![e])
    }
}

/// Azimuths φ (about the frame's w, from u) where the circle of directions at angle
/// `half` from `axis` crosses the light's rim (θ = α) or is tangent to a great circle
/// through w: the kinks of the inner θ integral as a function of φ.
fn azimuth_breaks(axis: DVec3, half: f64, w: DVec3, u: DVec3, v: DVec3, alpha: f64, out: &mut Vec<f64>) {
    let gamma = axis.cross(w).length().atan2(axis.dot(w));
    let phi0 = axis.dot(v).atan2(axis.dot(u));
    let (sg, cg) = gamma.sin_cos();
    if sg > 1e-12 {
        let t = half.sin() / sg;
        if t < 1.0 {
            let d = t.asin();
            out.extend([
                phi0 + d,
                phi0 - d,
                phi0 + std::f64::consts::PI - d,
                phi0 - std::f64::consts::PI + d,
            ]);
        }
        let c = (half.cos() - alpha.cos() * cg) / (alpha.sin() * sg);
        if c.abs() < 1.0 {
            let d = c.acos();
            out.extend([phi0 + d, phi0 - d]);
        }
    }
}

/// Polar angles θ ∈ (0, α) on the arc at azimuth φ where it crosses the circle at
/// angle `half` from `axis`.
fn polar_breaks(axis: DVec3, half: f64, w: DVec3, d: DVec3, alpha: f64, out: &mut Vec<f64>) {
    let (a, b) = (axis.dot(w), axis.dot(d));
    let r = a.hypot(b);
    if r < 1e-300 {
        return;
    }
    let c = half.cos() / r;
    if c.abs() <= 1.0 {
        let t0 = b.atan2(a);
        let dt = c.acos();
        for t in [t0 - dt, t0 + dt, t0 - dt + TAU, t0 + dt - TAU] {
            if t > 0.0 && t < alpha {
                out.push(t);
            }
        }
    }
}

/// ∫_{light cap} L·V(v)·max(n·v, 0) dω with exact ray–sphere visibility, by nested
/// adaptive Gauss–Kronrod in (φ, θ) about the light's axis, split at the blockers'
/// and the horizon's crossings. Inputs as [`Meunier::irradiance`] (the normal is
/// normalised after the same checks).
pub fn exact_irradiance(x: DVec3, n: DVec3, light: &SphereLight, blockers: &[Sphere]) -> Result<f64, MeunierError> {
    check_scene(x, std::slice::from_ref(light), blockers)?;
    let len = n.length();
    if !n.is_finite() || (len - 1.0).abs() > 1e-3 {
        return Err(MeunierError::NotUnit {
            name: "normal".into(),
            length: len,
        });
    }
    let n = n / len;
    // Irradiance depends on directions alone: the scene moved to the point and scaled
    // by the light's largest coordinate offset keeps every square finite (at 1e155 the
    // squares overflowed and the answer was 0).
    let m = (light.sphere.centre - x).abs().max_element();
    let at = |c: DVec3| (c - x) / m;
    let light = &SphereLight {
        sphere: Sphere {
            centre: at(light.sphere.centre),
            radius: light.sphere.radius / m,
        },
        radiance: light.radiance,
    };
    let blockers: &[Sphere] = &blockers
        .iter()
        .map(|b| Sphere {
            centre: at(b.centre),
            radius: b.radius / m,
        })
        .collect::<Vec<_>>();
    let x = DVec3::ZERO;
    let to = light.sphere.centre - x;
    let d = to.length();
    let w = to / d;
    let alpha = (light.sphere.radius / d).asin();
    let (u, v) = w.any_orthonormal_pair();
    let caps: Vec<(DVec3, f64)> = blockers
        .iter()
        .map(|b| {
            let t = b.centre - x;
            let l = t.length();
            (t / l, (b.radius / l).asin())
        })
        .chain(std::iter::once((n, FRAC_PI_2)))
        .collect();
    let mut phis = Vec::new();
    for &(a, h) in &caps {
        azimuth_breaks(a, h, w, u, v, alpha, &mut phis);
    }
    let phis: Vec<f64> = phis.into_iter().map(|p| p.rem_euclid(TAU)).collect();
    let mut ok = true;
    let outer = gauss_kronrod(
        |phi| {
            let dir = phi.cos() * u + phi.sin() * v;
            let mut thetas = Vec::new();
            for &(a, h) in &caps {
                polar_breaks(a, h, w, dir, alpha, &mut thetas);
            }
            let q = gauss_kronrod(
                |th| {
                    let (s, c) = th.sin_cos();
                    let r = c * w + s * dir;
                    let cos = n.dot(r);
                    if cos <= 0.0 || !visible(x, r, &light.sphere, blockers) {
                        0.0
                    } else {
                        cos * s
                    }
                },
                0.0,
                alpha,
                &thetas,
                1e-14,
                EXACT_REL_TOL,
                400,
            );
            ok &= q.converged;
            q.value
        },
        0.0,
        TAU,
        &phis,
        1e-13,
        EXACT_REL_TOL,
        400,
    );
    if !(ok && outer.converged && outer.value.is_finite()) {
        return Err(LookupError::NotFinite {
            name: "exact irradiance (quadrature did not converge)".into(),
            value: outer.value,
        }
        .into());
    }
    Ok(light.radiance * outer.value.max(0.0))
}

/// Irradiance of an unoccluded spherical light entirely above the horizon: π L sin²α
/// cos β (α the cap half-angle, β the angle between the normal and the light's axis);
/// `None` when part of the light is below the horizon.
pub fn unoccluded_closed_form(x: DVec3, n: DVec3, light: &SphereLight) -> Option<f64> {
    let to = light.sphere.centre - x;
    let d = to.length();
    let sin_a = light.sphere.radius / d;
    let cos_b = n.normalize().dot(to / d);
    let beta = cos_b.clamp(-1.0, 1.0).acos();
    (beta + sin_a.asin() <= FRAC_PI_2).then_some(std::f64::consts::PI * light.radiance * sin_a * sin_a * cos_b)
}

/// A seeded scene for the statistics of docs/meunier.md: the point at the origin with
/// a normal within 60° of +z, a light at distance 2–6 of radius 0.1–1.5 within 50° of
/// the normal, and (in 5 of 6 cases) a blocker on the way to the light, sized and
/// offset so that full, partial and no shadow all occur.
pub fn random_row(rng: &mut Rng) -> [f64; 14] {
    let dir = |rng: &mut Rng, max: f64| {
        let t = rng.range(0.0, max);
        let p = rng.range(0.0, TAU);
        (t, p)
    };
    let (tn, pn) = dir(rng, 1.05);
    let n = DVec3::new(tn.sin() * pn.cos(), tn.sin() * pn.sin(), tn.cos());
    let (tl, pl) = dir(rng, 0.87);
    let (a, b) = n.any_orthonormal_pair();
    let ldir = (tl.cos() * n + tl.sin() * (pl.cos() * a + pl.sin() * b)).normalize();
    let ld = rng.range(2.0, 6.0);
    let lr = rng.range(0.1, 1.5).min(0.6 * ld);
    let lc = ld * ldir;
    let mut out = [0.0; 14];
    out[3..6].copy_from_slice(&n.to_array());
    out[6..9].copy_from_slice(&lc.to_array());
    out[9] = lr;
    let kind = rng.next_u64() % 6;
    if kind != 0 {
        // Blocker at a fraction of the way, offset sideways: in one case of six
        // (kind 1) larger than the light's cone there and offset less than the
        // difference (full shadow), otherwise anywhere it may overlap the cone.
        let f = rng.range(0.2, 0.7);
        let bd = f * ld;
        let cone = bd * lr / ld;
        let (br, off) = if kind == 1 {
            let br = cone * rng.range(1.3, 2.5);
            (br, rng.uniform() * (br - cone) * 0.8)
        } else {
            let br = cone * rng.range(0.3, 2.5);
            (br, rng.uniform().sqrt() * (cone + br) * 1.2)
        };
        // Keep the point and the light outside the blocker.
        let br = br.min(0.8 * bd).min(0.9 * (ld - bd));
        let (p, q) = ldir.any_orthonormal_pair();
        let ph = rng.range(0.0, TAU);
        let bc = bd * ldir + off * (ph.cos() * p + ph.sin() * q);
        out[10..13].copy_from_slice(&bc.to_array());
        out[13] = br;
    }
    out
}

impl View for DirectLightView {
    fn kind(&self) -> &'static str {
        MaskWeightsFamily.kind()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &INPUTS
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["irradiance"]
    }
    fn embedded(&self) -> &'static [u8] {
        MaskWeightsFamily.embedded()
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(DirectLookup {
            weights: MaskWeights::from_table(table)?,
            settings: self.settings,
        }))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let r = row(x).map_err(|e| e.to_string())?;
        let blockers: Vec<Sphere> = r.blocker.into_iter().collect();
        exact_irradiance(r.x, r.n, &r.light, &blockers)
            .map(|e| vec![e])
            .map_err(|e| to_lookup(e).to_string())
    }
    fn caveat(&self, x: &[f64]) -> Option<&'static str> {
        // The light's cap is exact unoccluded at any size and tilt; the lobe is not.
        if self.settings.light != LightModel::Lobe {
            return None;
        }
        let r = row(x).ok()?;
        let to = r.light.sphere.centre - r.x;
        let d = to.length();
        let n = r.n.length();
        if !(d > r.light.sphere.radius && n > 0.0) {
            return None;
        }
        let alpha = (r.light.sphere.radius / d).asin();
        let beta = (r.n.dot(to) / (n * d)).clamp(-1.0, 1.0).acos();
        if beta + alpha > FRAC_PI_2 {
            Some(LIGHT_ACROSS_HORIZON)
        } else if alpha > LIGHT_ALPHA_MEASURED {
            Some(LIGHT_TOO_LARGE)
        } else {
            None
        }
    }
}

/// Largest light half-angle (rad) the light lobe's error was measured at (docs/meunier.md).
pub const LIGHT_ALPHA_MEASURED: f64 = 0.85;
/// [`Checked::caveat`] of a light that crosses the point's horizon.
pub const LIGHT_ACROSS_HORIZON: &str = "the light crosses the horizon: its single cosine lobe is least accurate \
     there (a light tilted 1 rad from the normal: unoccluded irradiance 15 % low at a half-angle of 0.55 rad, \
     28 % at 0.85; docs/meunier.md)";
/// [`Checked::caveat`] of a light wider than the measured range.
pub const LIGHT_TOO_LARGE: &str = "the light's half-angle exceeds 0.85 rad, beyond the range the light lobe's \
     error was measured on (8 to 13.5 % low at 0.73 to 0.85 rad; docs/meunier.md)";

/// One row of [`study`]: the pipeline's and the reference's irradiance and the
/// unoccluded reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudyRow {
    /// Lobe pipeline.
    pub lobes: f64,
    /// Reference (exact visibility).
    pub exact: f64,
    /// Reference without the blocker.
    pub unoccluded: f64,
}

impl StudyRow {
    /// |E − E_exact| / E_unoccluded.
    pub fn error(&self) -> f64 {
        (self.lobes - self.exact).abs() / self.unoccluded
    }
    /// E_exact / E_unoccluded: 0 full shadow, 1 none.
    pub fn lit_fraction(&self) -> f64 {
        self.exact / self.unoccluded
    }
}

/// The pipeline against the reference on `n` seeded rows ([`random_row`]) whose
/// light is at least partly above the horizon (E_unoccluded > 0), in parallel
/// (same results for any thread count).
pub fn study(n: usize, seed: u64, settings: &MaskSettings, weights: &MaskWeights) -> Result<Vec<StudyRow>, String> {
    use rayon::prelude::*;
    let mut rng = Rng::new(seed);
    let rows: Vec<[f64; 14]> = (0..n).map(|_| random_row(&mut rng)).collect();
    let m = Meunier {
        products: LobeProduct::embedded().map_err(|e| e.to_string())?,
        caps: CapExponent::embedded().map_err(|e| e.to_string())?,
        weights,
    };
    rows.par_iter()
        .map(|x| {
            let r = row(x).map_err(|e| e.to_string())?;
            let blockers: Vec<Sphere> = r.blocker.into_iter().collect();
            let lobes = m
                .irradiance(r.x, r.n, &[r.light], &blockers, settings)
                .map_err(|e| e.to_string())?;
            let exact = exact_irradiance(r.x, r.n, &r.light, &blockers).map_err(|e| e.to_string())?;
            let unoccluded = exact_irradiance(r.x, r.n, &r.light, &[]).map_err(|e| e.to_string())?;
            Ok(StudyRow {
                lobes,
                exact,
                unoccluded,
            })
        })
        .filter(|r: &Result<StudyRow, String>| r.as_ref().map_or(true, |r| r.unoccluded > 0.0))
        .collect()
}

/// Rows of `lobefit plot meunier`'s study.
pub const STUDY_ROWS: usize = 600;
/// Seed of that study (the test `pipeline_against_exact_visibility` uses its first rows).
pub const STUDY_SEED: u64 = 16;

/// `lobefit plot meunier`: the pipeline against `--exact` on [`STUDY_ROWS`] seeded
/// scenes for each weight set, mode and depth: quantiles of |E − E_exact|/E_unoccluded
/// (all rows, and the partially shadowed ones) in `meunier-direct-light.txt`, and their
/// distributions as a chart.
pub fn plot(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_core::plot::{line_chart, LineChart, Series};
    let weights = MaskWeights::embedded().map_err(|e| e.to_string())?;
    let mut text = format!(
        "|E − E_exact| / E_unoccluded over {STUDY_ROWS} seeded scenes (seed {STUDY_SEED}; docs/meunier.md)\n\
         settings                               rows  full/partial/none   median     p90     max | partial: median     p90\n"
    );
    let mut series = Vec::new();
    let q = |v: &[f64], p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    for (light, mode, depth) in LightModel::ALL.into_iter().flat_map(|l| {
        [
            (l, MaskMode::Aggressive, 5),
            (l, MaskMode::Conservative, 5),
            (l, MaskMode::Aggressive, 3),
        ]
    }) {
        for set in [WeightSet::Fitted, WeightSet::Paper, WeightSet::Ones] {
            let s = MaskSettings {
                depth,
                mode,
                weights: set,
                light,
                ..MaskSettings::default()
            };
            let rows = study(STUDY_ROWS, STUDY_SEED, &s, weights)?;
            let partial: Vec<&StudyRow> = rows
                .iter()
                .filter(|r| r.lit_fraction() > 1e-9 && r.lit_fraction() < 1.0 - 1e-9)
                .collect();
            let full = rows.iter().filter(|r| r.lit_fraction() <= 1e-9).count();
            let mut e: Vec<f64> = rows.iter().map(StudyRow::error).collect();
            let mut ep: Vec<f64> = partial.iter().map(|r| r.error()).collect();
            e.sort_by(f64::total_cmp);
            ep.sort_by(f64::total_cmp);
            let name = format!("{} light, {} depth {depth}, {}", light.name(), mode.name(), set.name());
            text.push_str(&format!(
                "{name:<38} {:>5}  {:>4}/{:>4}/{:>4}   {:.4}  {:.4}  {:.4} |          {:.4}  {:.4}\n",
                e.len(),
                full,
                ep.len(),
                e.len() - full - ep.len(),
                q(&e, 0.5),
                q(&e, 0.9),
                q(&e, 1.0),
                q(&ep, 0.5),
                q(&ep, 0.9)
            ));
            series.push(Series {
                name,
                points: ep
                    .iter()
                    .enumerate()
                    .map(|(i, &x)| ((i as f64 + 0.5) / ep.len() as f64, x))
                    .collect(),
            });
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let txt = dir.join("meunier-direct-light.txt");
    lobefit_core::io::write_atomic(&txt, text.as_bytes()).map_err(|e| format!("{}: {e}", txt.display()))?;
    let png = line_chart(
        &dir.join("meunier-direct-light.png"),
        &LineChart {
            title: "eval direct-light vs --exact, partially shadowed scenes".into(),
            x_label: "fraction of scenes".into(),
            y_label: "|E − E_exact| / E_unoccluded".into(),
            log_x: false,
            log_y: false,
            series,
        },
    )?;
    Ok(vec![txt, png])
}
