//! The sphere hierarchy's level of detail in the ISG pipeline (docs/meshes.md, "A
//! sphere hierarchy"): each pixel shaded with the flat set of blockers and with the
//! hierarchy's cut at several angles ([`crate::spheres::tree`]), their difference,
//! their time, and both against a Monte Carlo reference with exact visibility of the
//! flat set on a strided subset.

use rayon::prelude::*;

use super::shade::{radiance, Blockers, Phong, Settings, Tables};
use crate::image::mean_over;
use crate::scene::{Hit, Scene, OWN_MARGIN};
use crate::spheres::tree::SphereTree;

/// One angle's row.
#[derive(Debug, Clone)]
pub struct LodRow {
    /// The cut's angle (degrees; 0: the flat set through the scene's BVH).
    pub degrees: f64,
    /// The cut's size per lit pixel, mean (the flat set: every proxy). Both are then
    /// culled per product SG's cone, the set by its BVH, the cut by the tree.
    pub blockers: f64,
    /// Shading time per lit pixel (µs, all threads), the median of the runs, and the
    /// fastest and slowest.
    pub us: (f64, f64, f64),
    /// RMS and max of (this − flat) over the lit pixels, relative to the flat image's
    /// mean: what the level of detail adds.
    pub vs_flat: (f64, f64),
    /// Relative RMSE against the reference on the subset (its noise in it).
    pub vs_reference: f64,
}

/// The study's result.
#[derive(Debug, Clone)]
pub struct LodStudy {
    /// The pipeline shaded.
    pub method: String,
    /// The scene's name and its proxies.
    pub scene: (String, usize),
    /// Image size, lit pixels, the subset's pixels and its reference's samples.
    pub size: (usize, usize, usize, usize, usize),
    /// The reference's mean standard error over its mean on the subset.
    pub ref_rel_se: f64,
    /// Rows: the flat set first.
    pub rows: Vec<LodRow>,
}

/// The ISG's radiance at `h` with the cut of `tree` at `theta` (rad) as its blockers,
/// each product's cone culled through the tree ([`Blockers::cut`]), the hit's own
/// spheres skipped ([`crate::scene::Own`]).
pub fn shade_cut(
    t: &Tables,
    s: &Settings,
    scene: &Scene,
    tree: &SphereTree,
    theta: f64,
    h: &Hit,
) -> Result<f64, String> {
    if scene.buried(h) {
        return Ok(0.0);
    }
    let brdf = Phong::of_any(scene.brdf(h))?;
    radiance(
        t,
        s,
        &scene.environment,
        &brdf,
        &Blockers::cut(tree, theta, scene.own_proxies(h)),
        h,
    )
}

/// Runs the study on `scene` at `width` × 3/4 `width`: the flat set and the cut at each
/// of `degrees`, each timed `runs` times; the reference at `spp` samples on every
/// `stride`-th lit pixel.
pub fn lod_study(
    scene: &Scene,
    width: usize,
    degrees: &[f64],
    runs: usize,
    spp: usize,
    stride: usize,
) -> Result<LodStudy, String> {
    let tables = Tables::embedded()?;
    let settings = Settings::default();
    let tree = scene.proxy_tree();
    let shade = |hit: &Hit, theta: Option<f64>| match theta {
        None => super::render::shade_hit(&tables, &settings, scene, hit),
        Some(theta) => shade_cut(&tables, &settings, scene, tree, theta, hit),
    };
    lod_study_with(scene, width, degrees, runs, spp, stride, "ISG", &shade)
}

/// A pixel's shading with the flat set (`None`) or through the cut at an angle (rad).
pub type CutShade<'a> = dyn Fn(&Hit, Option<f64>) -> Result<f64, String> + Sync + 'a;

/// [`lod_study`] for any pipeline: `shade(hit, None)` shades a pixel with the flat
/// set, `shade(hit, Some(theta))` through the cut at `theta` (rad); `method` names it
/// in the table.
#[allow(clippy::too_many_arguments)]
pub fn lod_study_with(
    scene: &Scene,
    width: usize,
    degrees: &[f64],
    runs: usize,
    spp: usize,
    stride: usize,
    method: &str,
    shade: &CutShade,
) -> Result<LodStudy, String> {
    let (w, h) = (width.max(4), (width * 3 / 4).max(3));
    let (hits, lit) = scene.primary_hits(w, h)?;
    let tree = scene.proxy_tree();
    let npx = lit.iter().filter(|&&l| l).count();
    let picks: Vec<usize> = (0..hits.len()).filter(|&p| lit[p]).step_by(stride.max(1)).collect();
    let reference: Vec<(f64, f64)> = picks
        .par_iter()
        .map(|&p| {
            let hit = hits[p].expect("lit");
            let e = crate::sky::qmc_cv_mis(scene, &hit, spp, 0x5eed_0105 ^ p as u64)?;
            Ok((e.mean, e.std_error))
        })
        .collect::<Result<_, String>>()?;
    let ref_mean = reference.iter().map(|r| r.0).sum::<f64>() / picks.len().max(1) as f64;
    let ref_se = reference.iter().map(|r| r.1).sum::<f64>() / picks.len().max(1) as f64;
    // One image: per pixel (radiance, blockers), timed.
    // (radiance per pixel, timing (median, min, max) µs per lit pixel).
    type Image = (Vec<f64>, (f64, f64, f64));
    let image = |theta: Option<f64>| -> Result<Image, String> {
        let mut times = Vec::new();
        let mut out = Vec::new();
        for _ in 0..runs.max(1) {
            let t0 = std::time::Instant::now();
            out = hits
                .par_iter()
                .map(|hit| hit.as_ref().map_or(Ok(0.0), |hit| shade(hit, theta)))
                .collect::<Result<_, String>>()?;
            times.push(1e6 * t0.elapsed().as_secs_f64() / npx.max(1) as f64);
        }
        let t = crate::measure::Timing::of(&times);
        Ok((out, (t.median, t.min, t.max)))
    };
    // The cut's size per lit pixel, mean (untimed): the spheres a renderer would
    // hand the pixel before any cone culling.
    let cut_size = |theta: f64| -> f64 {
        let mut cut = Vec::new();
        let total: usize = hits
            .iter()
            .flatten()
            .map(|h| {
                let own = scene.own_proxies(h);
                tree.cut(h.x, theta, OWN_MARGIN, |i| own.contains(&i), &mut cut);
                cut.len()
            })
            .sum();
        total as f64 / npx.max(1) as f64
    };
    let (flat, flat_us) = image(None)?;
    let flat_mean = mean_over(&flat, &lit);
    let vs_reference = |img: &[f64]| {
        let d2: f64 = picks.iter().zip(&reference).map(|(&p, r)| (img[p] - r.0).powi(2)).sum();
        (d2 / picks.len().max(1) as f64).sqrt() / ref_mean
    };
    let mut rows = vec![LodRow {
        degrees: 0.0,
        blockers: scene.proxies.len() as f64,
        us: flat_us,
        vs_flat: (0.0, 0.0),
        vs_reference: vs_reference(&flat),
    }];
    for &deg in degrees {
        let (img, us) = image(Some(deg.to_radians()))?;
        let blockers = cut_size(deg.to_radians());
        let d: Vec<f64> = img.iter().zip(&flat).map(|(a, b)| a - b).collect();
        let d2: Vec<f64> = d.iter().map(|x| x * x).collect();
        let max = d
            .iter()
            .zip(&lit)
            .filter(|(_, &l)| l)
            .map(|(x, _)| x.abs())
            .fold(0.0, f64::max);
        rows.push(LodRow {
            degrees: deg,
            blockers,
            us,
            vs_flat: (mean_over(&d2, &lit).sqrt() / flat_mean, max / flat_mean),
            vs_reference: vs_reference(&img),
        });
    }
    Ok(LodStudy {
        method: method.to_string(),
        scene: (scene.name.clone(), scene.proxies.len()),
        size: (w, h, npx, picks.len(), spp),
        ref_rel_se: ref_se / ref_mean,
        rows,
    })
}

impl LodStudy {
    /// The rows as a Markdown table.
    pub fn table(&self) -> String {
        let (w, h, npx, sub, spp) = self.size;
        let mut s = format!(
            "{}: {} proxy spheres, {w}×{h} ({npx} lit pixels); reference {} pixels × {spp} samples of {} (standard error {:.4} of its mean)\n\n\
             | cut angle | spheres in the cut (per pixel) | {} µs/pixel (median [min–max]) | vs flat: RMS | vs flat: max | vs reference: RMSE |\n|---|---:|---|---:|---:|---:|\n",
            self.scene.0, self.scene.1, sub, "qmc-cv-mis", self.ref_rel_se, self.method
        );
        for r in &self.rows {
            let angle = if r.degrees == 0.0 {
                "flat".to_string()
            } else {
                format!("{}°", r.degrees)
            };
            s += &format!(
                "| {angle} | {:.1} | {:.2} [{:.2}–{:.2}] | {:.5} | {:.4} | {:.4} |\n",
                r.blockers, r.us.0, r.us.1, r.us.2, r.vs_flat.0, r.vs_flat.1, r.vs_reference
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At angle 0 the cut is the flat set: every pixel of the sweep's 46-sphere scene
    /// equals the flat pipeline's to 1e-12 of the mean (the blockers' order differs,
    /// the covered patches do not). At 10° (a quarter of the blockers merged) it
    /// differs, by less than the pipeline's own error against the reference.
    #[test]
    fn the_cut_at_zero_is_the_flat_pipeline() {
        let scene = super::super::render::sweep_scene(46).unwrap();
        let s = lod_study(&scene, 16, &[1e-9, 10.0], 1, 256, 8).unwrap();
        assert!(s.rows[1].vs_flat.1 < 1e-12, "{}", s.table());
        assert!(s.rows[2].vs_flat.0 > 0.0, "{}", s.table());
        assert!(s.rows[2].vs_flat.0 < s.rows[0].vs_reference, "{}", s.table());
    }

    /// The study at full size (docs/meshes.md): the sweep's 306 spheres and the bunny
    /// with 256 and 1 024 `optimize` spheres; prints the tables. `LF_WIDTH` (default
    /// 96), `LF_SPP` (default 4096), `LF_LOD` (a comma list of sweep-306, bunny-256,
    /// bunny-1024; default all).
    #[test]
    #[ignore = "study: minutes; docs/meshes.md"]
    fn lod_study_full() {
        let width = crate::env_or("LF_WIDTH", 96usize);
        let spp = crate::env_or("LF_SPP", 4096usize);
        let only = crate::env_or("LF_LOD", "sweep-306,bunny-256,bunny-1024".to_string());
        let bunny = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/isg-bunny.json");
        for name in only.split(',') {
            let t0 = std::time::Instant::now();
            let scene = match name {
                "sweep-306" => super::super::render::sweep_scene(306).unwrap(),
                "bunny-256" => {
                    super::super::proxy::scene_with_fit(&bunny, 256, crate::spheres::Method::Optimize, 1).unwrap()
                }
                "bunny-1024" => {
                    super::super::proxy::scene_with_fit(&bunny, 1024, crate::spheres::Method::Optimize, 1).unwrap()
                }
                other => panic!("LF_LOD: no scene {other}"),
            };
            println!("{name}: scene and fit {:.1} s", t0.elapsed().as_secs_f64());
            let s = lod_study(&scene, width, &[1.0, 2.0, 5.0, 10.0, 20.0], 3, spp, 4).unwrap();
            println!("{}", s.table());
        }
    }
}
