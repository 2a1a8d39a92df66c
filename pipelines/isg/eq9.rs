//! The ISG's specular term under a map, three ways (docs/environment.md, "Eq. 9 with
//! Γ_L"): the product of every fitted lobe with the BRDF's SG (the pipeline's
//! default), the paper's eq. 9 with ∫ L G_b from the fitted lobes, and eq. 9 with
//! ∫ L G_b from the map's prefiltered table Γ_L, each against a Monte Carlo reference
//! on the map itself, and timed; and issue 58's image measure under a map, the error
//! over each pixel's unoccluded radiance ([`unoccluded_errors`]).

use std::sync::Arc;

use rayon::prelude::*;

use super::render::shade_hit;
use super::shade::{Phong, Settings, Specular, Tables};
use crate::scene::Scene;

/// The reference at pixel `p`'s hit: `spp` samples on the scene's light (the map
/// itself under a map), seeded by the pixel; an error if not finite.
fn reference_at(
    scene: &Scene,
    brdf: &Phong,
    hit: &crate::scene::Hit,
    spp: usize,
    p: usize,
) -> Result<crate::estimate::Estimate, String> {
    let seed = 0x005e_ede9 ^ p as u64;
    crate::sky::scene_reference(scene, brdf, |v| scene.occluded(hit, v), hit, spp, seed)
        .finite(|| format!("the reference at pixel {p}"))
}

/// One form's row: (name, relative RMSE, max relative error, µs per pixel).
pub type Eq9Row = (&'static str, f64, f64, f64);

/// The three forms on every `stride`-th lit pixel of `scene` (lit by a map) at
/// `width` × 3/4 `width`, against `spp`-sample references on the map; `gamma` is the
/// map's Γ_L table. Returns the rows and the reference's mean standard error over its
/// mean.
pub fn eq9_study(
    scene: &Scene,
    gamma: Arc<lobefit_tables::Table>,
    width: usize,
    spp: usize,
    stride: usize,
) -> Result<(Vec<Eq9Row>, f64), String> {
    if scene.environment_map.is_none() {
        return Err(format!(
            "scene {}: eq. 9 with Γ_L needs a scene lit by a map",
            scene.name
        ));
    }
    let (w, h) = (width.max(4), (width * 3 / 4).max(3));
    let (hits, lit) = scene.primary_hits(w, h)?;
    let picks: Vec<usize> = (0..hits.len()).filter(|&p| lit[p]).step_by(stride.max(1)).collect();
    let reference: Vec<(f64, f64)> = picks
        .par_iter()
        .map(|&p| {
            let hit = hits[p].expect("lit");
            let brdf = Phong::of_any(scene.brdf(&hit))?;
            let e = reference_at(scene, &brdf, &hit, spp, p)?;
            Ok((e.mean, e.std_error))
        })
        .collect::<Result<_, String>>()?;
    let n = picks.len().max(1) as f64;
    let mean = reference.iter().map(|r| r.0).sum::<f64>() / n;
    let se = reference.iter().map(|r| r.1).sum::<f64>() / n;
    let mut tables = Tables::embedded()?;
    tables.prefiltered = Some(gamma);
    let mut rows = Vec::new();
    for (name, specular) in [
        ("product of every lobe (default)", Specular::Product),
        ("eq. 9, ∫ L G from the lobes", Specular::Eq9),
        ("eq. 9, ∫ L G from Γ_L", Specular::Eq9Prefiltered),
    ] {
        let settings = Settings {
            specular,
            ..Settings::default()
        };
        let t0 = std::time::Instant::now();
        let v: Vec<f64> = picks
            .par_iter()
            .map(|&p| shade_hit(&tables, &settings, scene, &hits[p].expect("lit")))
            .collect::<Result<_, String>>()?;
        let us = 1e6 * t0.elapsed().as_secs_f64() / n;
        let d: Vec<f64> = v.iter().zip(&reference).map(|(a, r)| (a - r.0).abs() / mean).collect();
        let rmse = (d.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
        rows.push((name, rmse, d.iter().copied().fold(0.0, f64::max), us));
    }
    Ok((rows, se / mean))
}

/// The rows as a Markdown table.
pub fn table(scene: &str, pixels: usize, se: f64, rows: &[Eq9Row]) -> String {
    let mut s = format!(
        "{scene}: {pixels} pixels, reference standard error {se:.4} of its mean\n\n| specular term | relative RMSE | max | µs/pixel |\n|---|---:|---:|---:|\n"
    );
    for (name, rmse, max, us) in rows {
        s += &format!("| {name} | {rmse:.4} | {max:.4} | {us:.1} |\n");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The study (docs/environment.md): the map scenes with their five spheres made
    /// glossy (fig12's Phong lobe, exponent 1 000, specular 0.4); builds each map's Γ_L
    /// first (two minutes each). `LF_WIDTH` (default 48), `LF_SPP` (default 16 384).
    #[test]
    #[ignore = "study: minutes; docs/environment.md"]
    fn eq9_study_full() {
        let width = crate::env_or("LF_WIDTH", 48usize);
        let spp = crate::env_or("LF_SPP", 16384usize);
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/envmaps");
        for name in ["apartment", "sky"] {
            let text = std::fs::read_to_string(dir.join(format!("isg-{name}.json"))).unwrap();
            let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
            for s in v["spheres"].as_array_mut().unwrap() {
                s["material"] = serde_json::json!({"lafortune": {"albedo": 0.5, "lobes": [
                    {"c": [-1.0, -1.0, 1.0], "exponent": 1000.0, "specular": 0.4}]}});
            }
            let scene = crate::scene::parse_in(&format!("{name}-glossy"), &v.to_string(), &dir).unwrap();
            let map = crate::envmap::EnvMap::load(&dir.join(format!("{name}.exr"))).unwrap();
            let (gamma, _) = crate::prefilter::build(&map, name).unwrap();
            let (rows, se) = eq9_study(&scene, Arc::new(gamma), width, spp, 4).unwrap();
            let (hits, lit) = scene.primary_hits(width, width * 3 / 4).unwrap();
            let pixels = (0..hits.len()).filter(|&p| lit[p]).step_by(4).count();
            println!("{}", table(&scene.name, pixels, se, &rows));
        }
    }
}

/// Issue 58's image measure under a map (docs/environment.md, "Scenes lit by a map"):
/// on every `stride`-th lit pixel of a Lambert `scene` at `width`, |ISG − reference|
/// over the pixel's **unoccluded** radiance k_d/π ∫ L max(n·ω, 0) dω (the map's exact
/// irradiance, its texels summed), the reference at `spp` samples on the map. Returns
/// (pixels, median, p99, max, the reference's median standard error on the same scale).
pub fn unoccluded_errors(
    scene: &Scene,
    width: usize,
    spp: usize,
    stride: usize,
) -> Result<(usize, f64, f64, f64, f64), String> {
    let map = scene
        .environment_map
        .as_ref()
        .ok_or_else(|| format!("scene {}: not lit by a map", scene.name))?;
    let (w, h) = (width.max(4), (width * 3 / 4).max(3));
    let (hits, lit) = scene.primary_hits(w, h)?;
    let picks: Vec<usize> = (0..hits.len()).filter(|&p| lit[p]).step_by(stride.max(1)).collect();
    let texels: Vec<(lobefit_tables::glam::DVec3, f64)> = map
        .map
        .texels()
        .map(|(d, dw, c)| (d, dw * (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])))
        .collect();
    let tables = Tables::embedded()?;
    let rows: Vec<(f64, f64)> = picks
        .par_iter()
        .map(|&p| {
            let hit = hits[p].expect("lit");
            let brdf = Phong::of_any(scene.brdf(&hit))?;
            if brdf.specular > 0.0 {
                return Err(format!(
                    "scene {}: the unoccluded measure is for Lambert scenes",
                    scene.name
                ));
            }
            let e = reference_at(scene, &brdf, &hit, spp, p)?;
            let isg = shade_hit(&tables, &Settings::default(), scene, &hit)?;
            let open: f64 = texels.iter().map(|(d, y)| y * hit.n.dot(*d).max(0.0)).sum::<f64>() * brdf.diffuse
                / std::f64::consts::PI;
            Ok(((isg - e.mean).abs() / open, e.std_error / open))
        })
        .collect::<Result<_, String>>()?;
    let mut d: Vec<f64> = rows.iter().map(|r| r.0).collect();
    let mut se: Vec<f64> = rows.iter().map(|r| r.1).collect();
    d.sort_by(f64::total_cmp);
    se.sort_by(f64::total_cmp);
    let at = |v: &[f64], q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    Ok((d.len(), at(&d, 0.5), at(&d, 0.99), at(&d, 1.0), at(&se, 0.5)))
}

#[cfg(test)]
mod target {
    /// The three map scenes (Lambert) by [`super::unoccluded_errors`] at 48 × 36,
    /// every 4th lit pixel, 65 536 samples: issue 58's target is median ≤ 2 % and max
    /// ≤ 8 % of the unoccluded radiance.
    #[test]
    #[ignore = "study: a minute; docs/environment.md"]
    fn unoccluded_target_study() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/envmaps");
        for name in ["sky", "apartment", "sunset"] {
            let scene = crate::scene::load(dir.join(format!("isg-{name}.json")).to_str().unwrap()).unwrap();
            let (n, med, p99, max, se) = super::unoccluded_errors(&scene, 48, 65536, 4).unwrap();
            println!("| {name} | {n} | {med:.4} | {p99:.4} | {max:.4} | {se:.4} |");
        }
    }
}
