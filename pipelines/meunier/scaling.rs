//! `lobefit plot meunier-scaling`: the lobe pipeline against Monte Carlo with exact
//! visibility as the number of sphere blockers grows (docs/meunier.md, "Blocker
//! scaling"). Two scene kinds over the Figure 13 plane and light: a random cluster of
//! N non-overlapping spheres whose total cross-section stays fixed (radius ∝ N^(−1/2)),
//! and a sphere-set torus of N spheres (the paper's Fig. 17–18 kind: one object
//! sampled more finely). Per scene, one process: the lobe pipeline (default settings)
//! with every other sphere passed as a blocker, and with the blockers culled by the
//! light's cone through the BVH (the same image: the mask drops what misses the cone);
//! the reference with the BVH and with a scan of every sphere; the time per pixel of
//! each Monte Carlo at the lobes' error (its per-sample variance from the BVH run).

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

use lobefit_tables::meunier::MaskSettings;

use lobefit_tables::geom::{Sphere, SphereLight};
use lobefit_tables::Meunier;
use rayon::prelude::*;

use super::render::reference_with;
use crate::image::compare;
use crate::scene::{parse, Hit, Scene};
use crate::timing::{timed, EqualError};
use lobefit_core::plot::{line_chart, LineChart, Series};
use lobefit_core::rng::Rng;

/// Image width (height 3/4 of it).
pub const WIDTH: usize = 64;
/// Reference samples per pixel (with the BVH; its estimates set the error).
pub const SPP: usize = 2048;
/// Samples per pixel of the scan-every-sphere reference (timed only).
pub const SPP_SCAN: usize = 64;
/// Blocker counts per scene kind.
pub const COUNTS: [usize; 6] = [1, 4, 16, 64, 256, 1024];

/// The scene: Figure 13's camera, plane and light with `spheres` (centre, radius).
fn scene(name: &str, spheres: &[(f64, f64, f64, f64)]) -> Result<Scene, String> {
    let list: Vec<String> = spheres
        .iter()
        .map(|(x, y, z, r)| {
            format!(
                r#"{{ "centre": [{x}, {y}, {z}], "radius": {r}, "material": {{ "lambert": {{ "albedo": 0.6 }} }} }}"#
            )
        })
        .collect();
    let text = format!(
        r#"{{ "version": 1,
  "camera": {{ "eye": [0.0, -6.5, 4.5], "target": [0.0, 0.0, 0.3], "fov": 0.75 }},
  "planes": [ {{ "normal": [0.0, 0.0, 1.0], "offset": 0.0, "tangent": [1.0, 0.0, 0.0], "half_extent": 4.0,
      "material": {{ "lambert": {{ "albedo": 0.8 }} }} }} ],
  "spheres": [ {} ],
  "lights": [ {{ "sphere": {{ "centre": [0.8, 0.6, 4.0], "radius": 0.7, "radiance": 4.0 }} }} ] }}"#,
        list.join(",\n")
    );
    parse(name, &text)
}

/// `n` non-overlapping spheres (gap ≥ 10 % of the radius) seeded in [−2, 2]² × [0.4, 1.8],
/// radius 0.45/√n.
pub fn cluster(n: usize) -> Result<Scene, String> {
    let r = 0.45 / (n as f64).sqrt();
    let mut rng = Rng::new(0xc105_7e00 + n as u64);
    let mut out: Vec<(f64, f64, f64, f64)> = Vec::with_capacity(n);
    while out.len() < n {
        let c = (rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(0.4, 1.8));
        if out
            .iter()
            .all(|o| (o.0 - c.0).powi(2) + (o.1 - c.1).powi(2) + (o.2 - c.2).powi(2) > (2.2 * r).powi(2))
        {
            out.push((c.0, c.1, c.2, r));
        }
    }
    scene(&format!("cluster-{n}"), &out)
}

/// A horizontal torus (centre (0, 0, 1.1), radii 1.2 and 0.35) sampled by `n` spheres
/// on a u × v grid (u ≈ 3.4 v), radius 0.49 × the smallest spacing (no overlaps); for
/// n < 4 one sphere of the torus's tube radius on its rim.
pub fn torus(n: usize) -> Result<Scene, String> {
    let (big, small) = (1.2, 0.35);
    if n < 4 {
        return scene(&format!("torus-{n}"), &[(big, 0.0, 1.1, small)]);
    }
    let nv = ((n as f64 / 3.4).sqrt().round() as usize).max(1);
    let nu = n / nv;
    let mut out = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            let (u, v) = (
                TAU * i as f64 / nu as f64,
                TAU * (j as f64 + 0.5 * (i % 2) as f64) / nv as f64,
            );
            let rho = big + small * v.cos();
            out.push((rho * u.cos(), rho * u.sin(), 1.1 + small * v.sin()));
        }
    }
    let mut gap = f64::INFINITY;
    for (k, a) in out.iter().enumerate() {
        for b in &out[k + 1..] {
            gap = gap.min(((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2) + (a.2 - b.2).powi(2)).sqrt());
        }
    }
    let r = (0.49 * gap).min(small);
    let spheres: Vec<_> = out.into_iter().map(|(x, y, z)| (x, y, z, r)).collect();
    scene(&format!("torus-{}", spheres.len()), &spheres)
}

/// The blockers of `h` whose caps may meet the light's cone, through the BVH.
pub fn culled(scene: &Scene, light: &SphereLight, h: &Hit) -> Vec<Sphere> {
    let to = light.sphere.centre - h.x;
    let d = to.length();
    let mut out = Vec::new();
    scene.bvh().in_cone(h.x, to / d, (light.sphere.radius / d).asin(), |i| {
        if Some(i) != h.sphere {
            out.push(scene.spheres[i]);
        }
    });
    out
}

/// One row of the study.
#[derive(Debug, Clone)]
pub struct Row {
    /// Scene name.
    pub name: String,
    /// Spheres.
    pub spheres: usize,
    /// Lit pixels.
    pub pixels: usize,
    /// The lobes' relative RMSE against the reference.
    pub rmse: f64,
    /// The reference's mean relative standard error.
    pub ref_se: f64,
    /// µs per pixel: lobes with every sphere, lobes culled through the BVH.
    pub lobes_us: [f64; 2],
    /// Largest |difference| between the two lobe images, relative to the mean.
    pub cull_diff: f64,
    /// Monte Carlo µs per sample (BVH, scan) and samples for the lobes' RMSE.
    pub mc_sample_us: [f64; 2],
    /// Samples per pixel for the lobes' RMSE.
    pub samples: f64,
}

/// Measures one scene at `width` × 3/4 of it pixels, the reference at `spp` samples
/// per pixel with the BVH and [`SPP_SCAN`] without.
pub fn measure(scene: &Scene, width: usize, spp: usize) -> Result<Row, String> {
    let m = Meunier::embedded().map_err(|e| e.to_string())?;
    let light = scene.lights[0];
    let (w, h) = (width.max(4), (width * 3 / 4).max(3));
    let (hits, lit) = scene.primary_hits(w, h)?;
    let pixels = lit.iter().filter(|&&l| l).count();
    let settings = MaskSettings::default();
    let shade = |blockers: &(dyn Fn(&Hit) -> Vec<Sphere> + Sync)| -> Result<Vec<f64>, String> {
        hits.par_iter()
            .map(|o| match o {
                None => Ok(0.0),
                Some(hit) => m
                    .radiance(
                        hit.x,
                        hit.n,
                        hit.t,
                        hit.wo,
                        scene.brdf(hit),
                        &[light],
                        &blockers(hit),
                        &settings,
                    )
                    .map_err(|e| format!("{}: {e}", scene.name)),
            })
            .collect()
    };
    let (all, t_all) = timed(|| shade(&|hit: &Hit| scene.blockers(hit)));
    let (cull, t_cull) = timed(|| shade(&|hit: &Hit| culled(scene, &light, hit)));
    let (all, cull) = (all?, cull?);
    let mc = |spp: usize, bvh: bool| {
        timed(|| {
            hits.par_iter()
                .enumerate()
                .map(|(p, o)| match o {
                    None => crate::estimate::estimate(0, 0, |_| 0.0),
                    Some(hit) => reference_with(scene, &light, hit, spp, super::render::MC_SEED ^ p as u64, bvh),
                })
                .collect::<Vec<_>>()
        })
    };
    let (refs, t_bvh) = mc(spp, true);
    let (_, t_scan) = mc(SPP_SCAN, false);
    let reference: Vec<f64> = refs.iter().map(|e| e.mean).collect();
    let st = compare(&all, &reference, &lit);
    let mean = crate::image::mean_over(&reference, &lit);
    let se: Vec<f64> = refs.iter().map(|e| e.std_error).collect();
    let eq = EqualError::from_estimates(t_all, t_bvh, &refs, &lit, spp, st.rel_rmse * mean);
    let per_sample_scan = t_scan / (pixels.max(1) * SPP_SCAN) as f64;
    let cull_diff = all.iter().zip(&cull).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / mean;
    Ok(Row {
        name: scene.name.clone(),
        spheres: scene.spheres.len(),
        pixels,
        rmse: st.rel_rmse,
        ref_se: crate::image::mean_over(&se, &lit) / mean,
        lobes_us: [1e6 * t_all / pixels as f64, 1e6 * t_cull / pixels as f64],
        cull_diff,
        mc_sample_us: [1e6 * eq.reference_per_sample, 1e6 * per_sample_scan],
        samples: eq.samples,
    })
}

/// `lobefit plot meunier-scaling`: the table (meunier-scaling.txt) and µs per pixel
/// against N (meunier-scaling.png).
pub fn plot(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let mut text = format!(
        "Lobe pipeline (light cap, depth 5, fitted) against Monte Carlo at equal error, {WIDTH}×{} pixels; reference {SPP} spp with the BVH, scan timed at {SPP_SCAN} spp (one process, one run each)\n\
         scene          spheres  lobes RMSE  (ref se)  lobes µs/px (all / culled)  MC µs/sample (BVH / scan)  samples  MC µs/px at equal error (BVH / scan)  ratio MC/lobes (BVH / scan)\n",
        WIDTH * 3 / 4
    );
    let mut series: Vec<Series> = ["lobes (culled)", "MC with BVH", "MC scan"]
        .iter()
        .flat_map(|s| {
            ["cluster", "torus"].map(|k| Series {
                name: format!("{k}: {s}"),
                points: Vec::new(),
            })
        })
        .collect();
    for k in 0..2 {
        for n in COUNTS {
            let s = if k == 0 { cluster(n)? } else { torus(n)? };
            let r = measure(&s, WIDTH, SPP)?;
            let mc = [r.mc_sample_us[0] * r.samples, r.mc_sample_us[1] * r.samples];
            let lobes = r.lobes_us[1];
            text.push_str(&format!(
                "{:<14} {:>7}  {:>10.4}  ({:.4})  {:>10.2} / {:>7.2}  {:>12.3} / {:>7.3}  {:>8.1}  {:>14.2} / {:>9.2}  {:>12.2} / {:>7.2}{}\n",
                r.name,
                r.spheres,
                r.rmse,
                r.ref_se,
                r.lobes_us[0],
                r.lobes_us[1],
                r.mc_sample_us[0],
                r.mc_sample_us[1],
                r.samples,
                mc[0],
                mc[1],
                mc[0] / lobes,
                mc[1] / lobes,
                if r.cull_diff > 1e-9 { format!("  (culled image differs by {:.1e})", r.cull_diff) } else { String::new() }
            ));
            let x = r.spheres as f64;
            series[k].points.push((x, lobes));
            series[2 + k].points.push((x, mc[0]));
            series[4 + k].points.push((x, mc[1]));
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let txt = dir.join("meunier-scaling.txt");
    lobefit_core::io::write_atomic(&txt, text.as_bytes()).map_err(|e| format!("{}: {e}", txt.display()))?;
    let png = line_chart(
        &dir.join("meunier-scaling.png"),
        &LineChart {
            title: "µs per pixel at the lobes' error against the number of sphere blockers".into(),
            x_label: "spheres".into(),
            y_label: "µs per pixel".into(),
            log_x: true,
            log_y: true,
            series,
        },
    )?;
    Ok(vec![txt, png])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env_or;

    /// The lobes' cost per pixel at N blockers, one thread (run with --ignored;
    /// docs/meunier.md, "Blocker scaling"): per scene (cluster and torus at
    /// `LF_COUNTS`, default 1,16,64,256,1024; `LF_KINDS`, default cluster,torus) at
    /// `LF_WIDTH` px (64), t_i = `LF_THRESHOLD` (0), sharp leaves in closed form unless
    /// `LF_SHARP=false` ([`MaskSettings::sharp_leaves`]), the culled lobe image shaded
    /// serially `LF_RUNS` (5) times (µs per lit pixel: median, min, max), its relative
    /// RMSE against the study's reference ([`SPP`] spp with the BVH) and a hash of its
    /// bytes (equal hashes: the same image, bit for bit). Checks nothing.
    #[test]
    #[ignore]
    fn study_meunier_lobes_scaling() {
        let width: usize = env_or("LF_WIDTH", WIDTH);
        let runs: usize = env_or("LF_RUNS", 5);
        let counts: String = env_or("LF_COUNTS", "1,16,64,256,1024".to_string());
        let kinds: String = env_or("LF_KINDS", "cluster,torus".to_string());
        let m = Meunier::embedded().unwrap();
        let settings = MaskSettings {
            threshold: env_or("LF_THRESHOLD", 0.0),
            sharp_leaves: env_or("LF_SHARP", true),
            ..MaskSettings::default()
        };
        println!(
            "scene          spheres  pixels  µs/px median [min, max] ({runs} runs, one thread)  rel RMSE  image hash"
        );
        for kind in kinds.split(',').map(str::trim) {
            for n in counts.split(',').map(|s| s.trim().parse::<usize>().unwrap()) {
                let scene = match kind {
                    "cluster" => cluster(n),
                    "torus" => torus(n),
                    k => panic!("LF_KINDS: no scene kind {k} (cluster, torus)"),
                }
                .unwrap();
                let light = scene.lights[0];
                let (hits, lit) = scene.primary_hits(width, width * 3 / 4).unwrap();
                let pixels = lit.iter().filter(|&&l| l).count();
                let shade = || -> Vec<f64> {
                    hits.iter()
                        .map(|o| match o {
                            None => 0.0,
                            Some(hit) => m
                                .radiance(
                                    hit.x,
                                    hit.n,
                                    hit.t,
                                    hit.wo,
                                    scene.brdf(hit),
                                    &[light],
                                    &culled(&scene, &light, hit),
                                    &settings,
                                )
                                .unwrap(),
                        })
                        .collect()
                };
                let img = shade();
                let mut t: Vec<f64> = (0..runs).map(|_| 1e6 * timed(shade).1 / pixels as f64).collect();
                t.sort_by(f64::total_cmp);
                let refs: Vec<f64> = hits
                    .par_iter()
                    .enumerate()
                    .map(|(p, o)| match o {
                        None => 0.0,
                        Some(hit) => {
                            reference_with(&scene, &light, hit, SPP, super::super::render::MC_SEED ^ p as u64, true)
                                .mean
                        }
                    })
                    .collect();
                let st = compare(&img, &refs, &lit);
                let mut hash = 0xcbf2_9ce4_8422_2325_u64;
                for b in img.iter().flat_map(|v| v.to_le_bytes()) {
                    hash = (hash ^ b as u64).wrapping_mul(0x100_0000_01b3);
                }
                println!(
                    "{:<14} {:>7}  {:>6}  {:>8.2} [{:.2}, {:.2}]  {:>8.4}  {hash:016x}",
                    scene.name,
                    scene.spheres.len(),
                    pixels,
                    t[runs / 2],
                    t[0],
                    t[runs - 1],
                    st.rel_rmse
                );
            }
        }
    }
}
