//! The irradiance-rig harness (`lobefit plot rigs`): rigs on a car-sized box (Yuan et al. 2012, §1, Figure 1).
//!
//! Scene: the box [−2.25, 2.25] × [−0.9, 0.9] × [−0.75, 0.75] m (length x, width y,
//! height z), lit by two point lights, a sphere light and two disk lights
//! ([`scene_lights`]). Receivers: points on the box's five upper faces (not the
//! underside) with the faces' outward normals. Each rig ([`rig_configs`]) is fitted to
//! the per-point SH irradiance of all lights, either from point samples
//! (`Rig::fit_sampled`: lattice nodes, centre values, central-difference gradients) or
//! by least squares over SH samples at 600 seeded surface points, then evaluated at 800
//! other seeded surface points. Errors of the reconstructed irradiance
//! E = Σ l_i(p) y_i(N) against (a) the per-point order-3 SH evaluation (what the rig
//! approximates) and (b) the exact irradiance ∫ L max(N·ω, 0) dω (closed form for point
//! lights, nested Gauss–Kronrod over the cap or the disk for the others).

use std::f64::consts::PI;

use lobefit_tables::disk_light::DiskLight;
use lobefit_tables::glam::DVec3;
use lobefit_tables::rigs::{select_direct, AxisModel, Light, Rig, RigBox, RigModel, COEFFS};
use lobefit_tables::sh::eval_basis;
use rayon::prelude::*;

use lobefit_core::quad::gauss_kronrod;

pub mod render;
use lobefit_core::rng::Rng;

/// Half extents of the car-sized box (m): 4.5 × 1.8 × 1.5.
pub const CAR_HALF: [f64; 3] = [2.25, 0.9, 0.75];
/// Least-squares fit samples.
pub const FIT_POINTS: usize = 600;
/// Test points.
pub const TEST_POINTS: usize = 800;
/// Tolerance of the exact-irradiance quadrature, relative to the light's scale.
const EXACT_REL_TOL: f64 = 1e-8;
/// Error-driven choices compared: lights whose own mixed-rig error exceeds this
/// fraction of the total field's RMS are evaluated per point (0.05 moves only the near
/// headlight, 0.02 also the three lights within ~5 m).
pub const DIRECT_TOLERANCES: [f64; 2] = [0.05, 0.02];
/// Ridge of every least-squares fit: surface samples never see a lattice's interior
/// nodes (see `Rig::fit_least_squares`).
pub const RIDGE: f64 = 1e-9;

/// The car's bounding box.
pub fn car_box() -> RigBox {
    RigBox::new(DVec3::ZERO, DVec3::from_array(CAR_HALF)).expect("valid box")
}

/// The scene's lights with names: a street at night — three lamps along the car's
/// length, a large area light (disk) overhead, a far fill, a wall panel, and one near
/// light (another car's headlight 1.25 m in front of the bumper), which the
/// error-driven choice should move out of the rig.
pub fn scene_lights() -> Vec<(&'static str, Light)> {
    let lamp = |x: f64| Light::Sphere {
        centre: DVec3::new(x, 4.0, 4.0),
        radius: 0.15,
        radiance: 300.0,
    };
    vec![
        ("street lamp at x = −6 m (sphere, r = 0.15 m)", lamp(-6.0)),
        ("street lamp at x = 0 m", lamp(0.0)),
        ("street lamp at x = +6 m", lamp(6.0)),
        (
            "overhead area light (disk, R = 2 m, 5.25 m above the roof)",
            Light::Disk {
                centre: DVec3::new(0.0, -2.0, 6.0),
                normal: DVec3::new(0.0, 0.3, -1.0),
                radius: 2.0,
                radiance: 2.0,
            },
        ),
        (
            "far fill (point)",
            Light::Point {
                position: DVec3::new(-20.0, -15.0, 30.0),
                intensity: 800.0,
            },
        ),
        (
            "wall panel (disk, R = 0.6 m, 2.6 m from the −y side)",
            Light::Disk {
                centre: DVec3::new(1.0, -3.5, 1.2),
                normal: DVec3::new(0.0, 1.0, 0.0),
                radius: 0.6,
                radiance: 5.0,
            },
        ),
        (
            "near headlight (point, 1.25 m in front)",
            Light::Point {
                position: DVec3::new(3.5, 0.5, 0.3),
                intensity: 3.0,
            },
        ),
    ]
}

/// Rigs compared: name, model.
pub fn rig_configs() -> Vec<(&'static str, RigModel)> {
    vec![
        ("constant (1)", RigModel::CONSTANT),
        ("gradient (4)", RigModel::Gradient),
        (
            "mixed: lattice 3 × gradient × constant (6)",
            RigModel::Tensor([AxisModel::Lattice(3), AxisModel::Gradient, AxisModel::Constant]),
        ),
        (
            "mixed, height and width swapped: lattice 3 × constant × gradient (6)",
            RigModel::Tensor([AxisModel::Lattice(3), AxisModel::Constant, AxisModel::Gradient]),
        ),
        ("lattice 3×2×2 (12)", RigModel::lattice(3, 2, 2)),
        ("lattice 2×3×2 (12)", RigModel::lattice(2, 3, 2)),
        ("lattice 2×2×3 (12)", RigModel::lattice(2, 2, 3)),
        ("lattice 8×4×2 (64)", RigModel::lattice(8, 4, 2)),
    ]
}

/// A receiver: point on the box surface and outward normal.
#[derive(Debug, Clone, Copy)]
pub struct Receiver {
    /// Position (m).
    pub p: DVec3,
    /// Outward unit normal.
    pub n: DVec3,
}

/// Seeded random points on the five upper faces, uniformly by area.
pub fn surface_points(count: usize, seed: u64) -> Vec<Receiver> {
    let h = CAR_HALF;
    // Faces: +x, −x, +y, −y, +z with areas.
    let faces: [(usize, f64, f64); 5] = [
        (0, 1.0, 4.0 * h[1] * h[2]),
        (0, -1.0, 4.0 * h[1] * h[2]),
        (1, 1.0, 4.0 * h[0] * h[2]),
        (1, -1.0, 4.0 * h[0] * h[2]),
        (2, 1.0, 4.0 * h[0] * h[1]),
    ];
    let total: f64 = faces.iter().map(|f| f.2).sum();
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|_| {
            let mut u = rng.uniform() * total;
            let mut face = faces[4];
            for f in faces {
                if u < f.2 {
                    face = f;
                    break;
                }
                u -= f.2;
            }
            let mut t = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)];
            t[face.0] = face.1;
            let mut n = DVec3::ZERO;
            n[face.0] = face.1;
            Receiver {
                p: DVec3::from_array([t[0] * h[0], t[1] * h[1], t[2] * h[2]]),
                n,
            }
        })
        .collect()
}

/// Irradiance from an SH irradiance vector at normal n.
pub fn shade(l: &[f64; COEFFS], n: DVec3) -> f64 {
    let mut y = [0.0; COEFFS];
    eval_basis(3, n.to_array(), &mut y).expect("unit normal");
    l.iter().zip(&y).map(|(a, b)| a * b).sum()
}

/// Per-point SH irradiance of all `lights` at p.
pub fn field(lights: &[Light], disks: &DiskLight, p: DVec3) -> Result<[f64; COEFFS], String> {
    let mut v = [0.0; COEFFS];
    for l in lights {
        let e = l.irradiance_sh(p, disks).map_err(|e| e.to_string())?;
        for i in 0..COEFFS {
            v[i] += e[i];
        }
    }
    Ok(v)
}

/// The exact irradiance of all `lights` at each receiver (sum of [`exact_irradiance`]).
fn exact_field(lights: &[Light], receivers: &[Receiver]) -> Result<Vec<f64>, String> {
    receivers
        .par_iter()
        .map(|r| {
            lights
                .iter()
                .map(|l| exact_irradiance(l, r))
                .sum::<Result<f64, String>>()
        })
        .collect()
}

/// Exact irradiance ∫ L max(N·ω, 0) dω of one light at receiver r.
pub fn exact_irradiance(light: &Light, r: &Receiver) -> Result<f64, String> {
    exact_with_kernel(light, r, |t| t.max(0.0))
}

/// Exact wrapped irradiance ∫ L f(N·ω | a) dω of one light at receiver r, with the wrap
/// kernel f(t | a) = ((t + a)/(1 + a))^{1+a} for t > −a (docs/math.md, wrap).
pub fn exact_wrapped(light: &Light, r: &Receiver, a: f64) -> Result<f64, String> {
    exact_with_kernel(light, r, |t| {
        if t > -a {
            ((t + a) / (1.0 + a)).powf(1.0 + a)
        } else {
            0.0
        }
    })
}

/// ∫ L k(N·ω) dω of one light at receiver r for a kernel k of the cosine (closed form
/// for point lights, nested Gauss–Kronrod over the cap or the disk otherwise).
fn exact_with_kernel(light: &Light, r: &Receiver, k: impl Fn(f64) -> f64) -> Result<f64, String> {
    match *light {
        Light::Point { position, intensity } => {
            let d = position - r.p;
            Ok(intensity * k(r.n.dot(d) / d.length()) / d.length_squared())
        }
        Light::Sphere {
            centre,
            radius,
            radiance,
        } => {
            // Cap about w = direction to the centre, half-angle θ_b.
            let d = centre - r.p;
            let dist = d.length();
            let w = d / dist;
            let u = w.any_orthonormal_vector();
            let v = w.cross(u);
            let tb = (radius / dist).asin();
            let scale = PI * tb * tb;
            let q = nested(0.0, tb, 0.0, 2.0 * PI, EXACT_REL_TOL * scale, |th, ph| {
                let dir = th.cos() * w + th.sin() * (ph.cos() * u + ph.sin() * v);
                k(r.n.dot(dir)) * th.sin()
            })?;
            Ok(radiance * q)
        }
        Light::Disk {
            centre,
            normal,
            radius,
            radiance,
        } => {
            let n = normal.normalize();
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let dist = (centre - r.p).length();
            let scale = PI * radius * radius / (dist * dist);
            let q = nested(0.0, radius, 0.0, 2.0 * PI, EXACT_REL_TOL * scale, |rho, ph| {
                let x = centre + rho * (ph.cos() * u + ph.sin() * v) - r.p;
                let l = x.length();
                let emit = (-n.dot(x) / l).max(0.0);
                k(r.n.dot(x / l)) * emit * rho / (l * l)
            })?;
            Ok(radiance * q)
        }
    }
}

/// ∫_{a0}^{a1} ∫_{b0}^{b1} f(a, b) db da by nested GK (absolute tolerance `tol`).
fn nested(a0: f64, a1: f64, b0: f64, b1: f64, tol: f64, f: impl Fn(f64, f64) -> f64) -> Result<f64, String> {
    let mut ok = true;
    let q = gauss_kronrod(
        |a| {
            let qi = gauss_kronrod(|b| f(a, b), b0, b1, &[], tol / 4.0, 0.0, 4000);
            ok &= qi.converged;
            qi.value
        },
        a0,
        a1,
        &[],
        tol / 4.0,
        0.0,
        4000,
    );
    if ok && q.converged {
        Ok(q.value)
    } else {
        Err("exact irradiance quadrature did not converge".into())
    }
}

/// Error of reconstructed irradiance values against references: (relative RMS,
/// max |ΔE| / mean E_ref).
pub fn errors(got: &[f64], want: &[f64]) -> (f64, f64) {
    let n = want.len() as f64;
    let rms = (got.iter().zip(want).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / n).sqrt();
    let ref_rms = (want.iter().map(|b| b * b).sum::<f64>() / n).sqrt();
    let mean = want.iter().sum::<f64>() / n;
    let max = got.iter().zip(want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    (rms / ref_rms, max / mean)
}

/// One row of the comparison.
#[derive(Debug, Clone)]
pub struct Row {
    /// Rig and fit.
    pub name: String,
    /// SH vectors stored.
    pub vectors: usize,
    /// All lights through the rig, against the per-point SH irradiance: relative RMS,
    /// max |ΔE| / mean E.
    pub all_vs_sh: (f64, f64),
    /// Error-driven split (chosen lights per point, the rest through the rig), against
    /// the per-point SH irradiance.
    pub split_vs_sh: (f64, f64),
    /// The split against the exact irradiance.
    pub split_vs_exact: (f64, f64),
}

/// Everything the comparison measures.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Rows: per-point SH (no rig), then each rig × fit.
    pub rows: Vec<Row>,
    /// Every light's own mixed-rig RMS error relative to the total field's RMS, largest
    /// first, and whether the error-driven choice evaluates it per point.
    pub light_errors: Vec<(String, f64, bool)>,
    /// Per-point SH vs exact over the test points (the order-3 floor).
    pub sh_vs_exact: (f64, f64),
    /// The error-driven choice's tolerance.
    pub tolerance: f64,
}

fn lookup_err(e: String) -> lobefit_tables::LookupError {
    lobefit_tables::LookupError::OutOfDomain {
        name: e,
        value: f64::NAN,
        lo: 0.0,
        hi: 0.0,
    }
}

/// Runs the comparison with the error-driven choice at `tolerance` (see
/// `select_direct`; well under a second in release builds).
pub fn compare(tolerance: f64) -> Result<Comparison, String> {
    let disks = DiskLight::embedded().map_err(|e| e.to_string())?;
    let named = scene_lights();
    let lights: Vec<Light> = named.iter().map(|l| l.1).collect();
    let bbox = car_box();
    let fit = surface_points(FIT_POINTS, 0xf17);
    let test = surface_points(TEST_POINTS, 0x7e57);
    let fit_p: Vec<DVec3> = fit.iter().map(|r| r.p).collect();
    let test_p: Vec<DVec3> = test.iter().map(|r| r.p).collect();
    // The error-driven choice (made with the mixed rig), and every light's error.
    let mixed = rig_configs()[2].1;
    let all_errs =
        select_direct(mixed, bbox, &lights, disks, &fit_p, &test_p, 0.0, RIDGE).map_err(|e| e.to_string())?;
    let chosen =
        select_direct(mixed, bbox, &lights, disks, &fit_p, &test_p, tolerance, RIDGE).map_err(|e| e.to_string())?;
    let direct: Vec<usize> = chosen.iter().map(|c| c.0).collect();
    let rig_lights: Vec<Light> = (0..lights.len())
        .filter(|i| !direct.contains(i))
        .map(|i| lights[i])
        .collect();
    let direct_lights: Vec<Light> = direct.iter().map(|&i| lights[i]).collect();
    let f_all = |p: DVec3| field(&lights, disks, p);
    let f_rig = |p: DVec3| field(&rig_lights, disks, p);
    let truth_sh: Vec<f64> = test
        .iter()
        .map(|r| Ok(shade(&f_all(r.p)?, r.n)))
        .collect::<Result<_, String>>()?;
    let direct_part: Vec<[f64; COEFFS]> = test
        .iter()
        .map(|r| field(&direct_lights, disks, r.p))
        .collect::<Result<_, String>>()?;
    let exact = exact_field(&lights, &test)?;
    let norm = {
        let s: f64 = test_p
            .iter()
            .map(|&p| f_all(p).map(|v| v.iter().map(|x| x * x).sum::<f64>()))
            .sum::<Result<f64, String>>()?;
        (s / test_p.len() as f64).sqrt()
    };
    let sh_vs_exact = errors(&truth_sh, &exact);
    let mut rows = Vec::new();
    let shade_rig = |rig: &Rig, add: Option<&[[f64; COEFFS]]>| -> Result<Vec<f64>, String> {
        test.iter()
            .enumerate()
            .map(|(k, r)| {
                let mut v = rig.eval(r.p).map_err(|e| e.to_string())?;
                if let Some(d) = add {
                    for i in 0..COEFFS {
                        v[i] += d[k][i];
                    }
                }
                Ok(shade(&v, r.n))
            })
            .collect()
    };
    for (name, model) in rig_configs() {
        let k = model.parameter_count().map_err(|e| e.to_string())?;
        for how in ["point-sampled", "least squares"] {
            let fit_with = |f: &dyn Fn(DVec3) -> Result<[f64; COEFFS], String>| -> Result<Rig, String> {
                if how == "point-sampled" {
                    Rig::fit_sampled(model, bbox, |p| f(p).map_err(lookup_err)).map_err(|e| e.to_string())
                } else {
                    let samples: Vec<(DVec3, [f64; COEFFS])> =
                        fit_p.iter().map(|&p| Ok((p, f(p)?))).collect::<Result<_, String>>()?;
                    Rig::fit_least_squares(model, bbox, &samples, RIDGE).map_err(|e| e.to_string())
                }
            };
            let all = shade_rig(&fit_with(&f_all)?, None)?;
            let split = shade_rig(&fit_with(&f_rig)?, Some(&direct_part))?;
            rows.push(Row {
                name: format!("{name}, {how}"),
                vectors: k,
                all_vs_sh: errors(&all, &truth_sh),
                split_vs_sh: errors(&split, &truth_sh),
                split_vs_exact: errors(&split, &exact),
            });
        }
    }
    Ok(Comparison {
        rows,
        light_errors: all_errs
            .iter()
            .map(|&(i, e)| (named[i].0.to_string(), e / norm, direct.contains(&i)))
            .collect(),
        sh_vs_exact,
        tolerance,
    })
}

/// The comparison as Markdown.
pub fn markdown(c: &Comparison) -> String {
    let mut s = String::from(
        "| rig, fit | SH vectors | all lights in the rig: rel. RMS vs per-point SH | max ΔE / mean E | error-driven split: rel. RMS vs per-point SH | max ΔE / mean E | split: rel. RMS vs exact | max ΔE / mean E |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    s += &format!(
        "| per-point SH, no rig | – | 0 | 0 | 0 | 0 | {:.2e} | {:.2e} |\n",
        c.sh_vs_exact.0, c.sh_vs_exact.1
    );
    for r in &c.rows {
        s += &format!(
            "| {} | {} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} |\n",
            r.name,
            r.vectors,
            r.all_vs_sh.0,
            r.all_vs_sh.1,
            r.split_vs_sh.0,
            r.split_vs_sh.1,
            r.split_vs_exact.0,
            r.split_vs_exact.1
        );
    }
    s += &format!(
        "\nEach light's own mixed-rig RMS error / the total field's RMS (tolerance {}; * = evaluated per point):\n",
        c.tolerance
    );
    for (n, e, d) in &c.light_errors {
        s += &format!("- {n}: {e:.4}{}\n", if *d { " *" } else { "" });
    }
    s
}

/// Rigs drawn in the figures: index into [`rig_configs`] and a short title.
const FIGURE_RIGS: [(usize, &str); 6] = [
    (0, "constant (1)"),
    (1, "gradient (4)"),
    (2, "mixed L3×G×C (6)"),
    (3, "mixed L3×C×G (6)"),
    (4, "lattice 3×2×2 (12)"),
    (7, "lattice 8×4×2 (64)"),
];

/// A heat-map panel of the car's side: (title, values, colour label, log colour).
type PanelFn<'a> = dyn Fn(String, Vec<f64>, &str, bool) -> lobefit_core::plot::Heatmap + 'a;

/// The relative error maps on the car's side (`side`, exact irradiance `exact`) of the
/// renderer's configuration: the error-driven split at the first tolerance (the near
/// light per point, the rest through each Figure rig fitted at `fit`), as `panel`s.
fn split_errors(
    lights: &[Light],
    disks: &DiskLight,
    fit: &[Receiver],
    side: &[Receiver],
    exact: &[f64],
    panel: &PanelFn<'_>,
) -> Result<Vec<lobefit_core::plot::Heatmap>, String> {
    let (configs, bbox) = (rig_configs(), car_box());
    let tol = DIRECT_TOLERANCES[0];
    let fit_p: Vec<DVec3> = fit.iter().map(|r| r.p).collect();
    let test_p: Vec<DVec3> = surface_points(TEST_POINTS, 0x7e57).iter().map(|r| r.p).collect();
    let direct: Vec<usize> = select_direct(rig_configs()[2].1, bbox, lights, disks, &fit_p, &test_p, tol, RIDGE)
        .map_err(|e| e.to_string())?
        .iter()
        .map(|c| c.0)
        .collect();
    let rig_lights: Vec<Light> = (0..lights.len())
        .filter(|i| !direct.contains(i))
        .map(|i| lights[i])
        .collect();
    let direct_lights: Vec<Light> = direct.iter().map(|&i| lights[i]).collect();
    let rig_samples: Vec<(DVec3, [f64; COEFFS])> = fit
        .iter()
        .map(|r| Ok((r.p, field(&rig_lights, disks, r.p)?)))
        .collect::<Result<_, String>>()?;
    let mut split_err = Vec::new();
    for &(k, name) in &FIGURE_RIGS {
        let model = configs[k].1;
        let rig = Rig::fit_least_squares(model, bbox, &rig_samples, RIDGE).map_err(|e| e.to_string())?;
        let e: Vec<f64> = side
            .iter()
            .map(|r| {
                let mut v = rig.eval(r.p).map_err(|e| e.to_string())?;
                let d = field(&direct_lights, disks, r.p)?;
                for i in 0..COEFFS {
                    v[i] += d[i];
                }
                Ok(shade(&v, r.n))
            })
            .collect::<Result<_, String>>()?;
        let rel: Vec<f64> = e
            .iter()
            .zip(exact)
            .map(|(a, b)| (a - b).abs() / b.abs().max(f64::MIN_POSITIVE))
            .collect();
        let (rms, _) = errors(&e, exact);
        split_err.push(panel(
            format!("{name}, near light direct: rel. RMS {rms:.1e}"),
            rel,
            "|E − exact| / exact",
            true,
        ));
    }
    Ok(split_err)
}

/// `lobefit plot rigs`: irradiance on the car's +y side, exact vs rigs
/// (least squares), and the error maps; prints the comparison table (Markdown).
pub fn plot(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    use lobefit_core::plot::{heatmaps, ColourScale, Heatmap};
    for tol in DIRECT_TOLERANCES {
        println!("{}", markdown(&compare(tol)?));
    }
    let disks = DiskLight::embedded().map_err(|e| e.to_string())?;
    let lights: Vec<Light> = scene_lights().iter().map(|l| l.1).collect();
    let bbox = car_box();
    let fit = surface_points(FIT_POINTS, 0xf17);
    // The figure shows the all-lights-in-the-rig case (the rigs' own spatial error).
    let samples: Vec<(DVec3, [f64; COEFFS])> = fit
        .iter()
        .map(|r| Ok((r.p, field(&lights, disks, r.p)?)))
        .collect::<Result<_, String>>()?;
    let configs = rig_configs();
    let rigs: Vec<(&str, Rig)> = FIGURE_RIGS
        .iter()
        .map(|&(k, short)| {
            Rig::fit_least_squares(configs[k].1, bbox, &samples, RIDGE)
                .map(|r| (short, r))
                .map_err(|e| e.to_string())
        })
        .collect::<Result<_, String>>()?;
    let (h, nx, ny) = (CAR_HALF, 90usize, 30usize);
    let mut files = Vec::new();
    // Side face y = +h_y (x along, z up).
    let side: Vec<Receiver> = (0..ny)
        .flat_map(|iy| {
            (0..nx).map(move |ix| Receiver {
                p: DVec3::new(
                    -h[0] + 2.0 * h[0] * (ix as f64 + 0.5) / nx as f64,
                    h[1],
                    -h[2] + 2.0 * h[2] * (iy as f64 + 0.5) / ny as f64,
                ),
                n: DVec3::Y,
            })
        })
        .collect();
    let exact = exact_field(&lights, &side)?;
    let panel = |title: String, values: Vec<f64>, label: &str, log: bool| Heatmap {
        title,
        x_label: "x along the car (m)".into(),
        y_label: "z (m)".into(),
        x_range: (-h[0], h[0]),
        y_range: (-h[2], h[2]),
        nx,
        ny,
        values,
        colour_label: label.into(),
        log_colour: log,
        scale: ColourScale::Own,
    };
    let mut irr = vec![panel(
        "exact irradiance, +y side (all lights)".into(),
        exact.clone(),
        "E",
        false,
    )];
    let mut err = Vec::new();
    for (name, rig) in &rigs {
        let e: Vec<f64> = side
            .iter()
            .map(|r| rig.eval(r.p).map(|l| shade(&l, r.n)).map_err(|e| e.to_string()))
            .collect::<Result<_, String>>()?;
        let rel: Vec<f64> = e
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).abs() / b.abs().max(f64::MIN_POSITIVE))
            .collect();
        let (rms, _) = errors(&e, &exact);
        irr.push(panel(name.to_string(), e, "E", false));
        err.push(panel(
            format!("{name}, all in rig: rel. RMS {rms:.1e}"),
            rel,
            "|E − exact| / exact",
            true,
        ));
    }
    files.push(heatmaps(&dir.join("rigs-car-side-irradiance.png"), &irr, 3)?);
    let split_err = split_errors(&lights, disks, &fit, &side, &exact, &panel)?;
    files.push(heatmaps(&dir.join("rigs-car-side-error-split.png"), &split_err, 2)?);
    files.push(heatmaps(&dir.join("rigs-car-side-error.png"), &err, 2)?);
    Ok(files)
}
