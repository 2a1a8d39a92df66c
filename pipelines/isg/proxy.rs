//! The sphere proxy's error (docs/meshes.md): a mesh shaded by the ISG pipeline with
//! fitted sphere sets of several sizes and methods as its blockers, against the Monte
//! Carlo reference with the mesh's true triangles, next to the pipeline's own error
//! (the same sphere set with exact visibility).
//!
//! Per pixel, three images share the primary hits: the reference with the true
//! triangles (`mesh`), the reference with the sphere set's exact visibility
//! (`spheres`: the set but the hit's own mesh's, as the pipeline) and the ISG
//! pipeline (default settings). Both references draw the same directions (the same
//! seed per pixel), so their difference is the visibility's difference alone, its
//! noise far below either's.

use std::path::Path;

use rayon::prelude::*;

use super::shade::{Phong, Settings, Tables};
use crate::image::{mean_over, noise_free_rel_rmse};
use crate::scene::{ray_sphere, Scene};
use crate::spheres::{quality, Method, Quality};

/// One sphere set's row of the study.
#[derive(Debug, Clone)]
pub struct ProxyRow {
    /// Fit method.
    pub method: Method,
    /// Spheres.
    pub count: usize,
    /// Its fit quality, in scene units.
    pub quality: Quality,
    /// Relative RMSE of the sphere-set reference against the mesh reference (the
    /// proxy's error; same samples, so nearly noise-free).
    pub proxy: f64,
    /// [`ProxyRow::proxy`] over the pixels that see no mesh (the mesh's shadow on the
    /// plane).
    pub proxy_off_mesh: f64,
    /// [`ProxyRow::proxy`] over the pixels that see the mesh (its self-shadowing
    /// through its own set against the true triangles'), relative to their mean.
    pub proxy_on_mesh: f64,
    /// [`ProxyRow::pipeline`] over the pixels that see the mesh.
    pub pipeline_on_mesh: f64,
    /// Off-mesh pixels whose point lies inside a sphere of the set (a sphere reaching
    /// through the plane the mesh stands on).
    pub buried: usize,
    /// [`ProxyRow::proxy_off_mesh`] over the off-mesh pixels no sphere holds.
    pub proxy_clear: f64,
    /// Relative RMSE of the pipeline against the sphere-set reference, its noise
    /// taken out (the pipeline's own error).
    pub pipeline: f64,
    /// Relative RMSE of the pipeline against the mesh reference, its noise taken out.
    pub total: f64,
    /// The pipeline's shading time per lit pixel (µs, all threads; one run).
    pub us_per_pixel: f64,
}

/// The study's result.
#[derive(Debug, Clone)]
pub struct ProxyStudy {
    /// Image size.
    pub size: (usize, usize),
    /// Pixels that see geometry, and of them those on a mesh.
    pub pixels: (usize, usize),
    /// Reference samples per pixel.
    pub spp: usize,
    /// The mesh reference's mean standard error over its mean radiance.
    pub ref_rel_se: f64,
    /// Rows, method-major.
    pub rows: Vec<ProxyRow>,
}

/// The scene file `path` with every mesh's sphere set replaced by a fit of `count`
/// spheres with `method` and `seed`.
pub fn scene_with_fit(path: &Path, count: usize, method: Method, seed: u64) -> Result<Scene, String> {
    let text = lobefit_core::io::read_text(path, crate::scene::MAX_SCENE_LEN)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let mut v: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let meshes = v["meshes"]
        .as_array_mut()
        .ok_or_else(|| format!("{}: no meshes", path.display()))?;
    for m in meshes {
        m["spheres"] = serde_json::json!({"count": count, "method": method.name(), "seed": seed});
    }
    let stem = path
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    crate::scene::parse_in(&stem, &v.to_string(), folder)
}

/// Seed of the references' per-pixel samples.
pub const MC_SEED: u64 = 0x5eed_0041;

/// Runs the study on the scene file `path` at `width` × 3/4 `width` pixels with `spp`
/// reference samples per pixel, for every method and count; fit quality from
/// `quality_samples` points.
pub fn proxy_study(
    path: &Path,
    width: usize,
    spp: usize,
    methods: &[Method],
    counts: &[usize],
    quality_samples: usize,
) -> Result<ProxyStudy, String> {
    let (w, h) = (width.max(4), (width * 3 / 4).max(3));
    let base = scene_with_fit(path, 1, Method::Tree, 1)?;
    if base.meshes.is_empty() {
        return Err(format!("{}: the study needs a mesh", path.display()));
    }
    let (hits, lit) = base.primary_hits(w, h)?;
    let tables = Tables::embedded()?;
    // The mesh reference: exact visibility of the true triangles.
    let mesh_ref: Vec<(f64, f64)> = hits
        .par_iter()
        .enumerate()
        .map(|(p, hit)| match hit {
            None => Ok((0.0, 0.0)),
            Some(hit) => {
                let brdf = Phong::of_any(base.brdf(hit))?;
                let e =
                    crate::sky::scene_reference(&base, &brdf, |v| base.occluded(hit, v), hit, spp, MC_SEED ^ p as u64);
                Ok((e.mean, e.std_error))
            }
        })
        .collect::<Result<_, String>>()?;
    let (mref, mse): (Vec<f64>, Vec<f64>) = mesh_ref.into_iter().unzip();
    let mean_ref = mean_over(&mref, &lit);
    let mut rows = Vec::new();
    for &method in methods {
        for &count in counts {
            let scene = scene_with_fit(path, count, method, 1)?;
            let per: Vec<(f64, f64)> = hits
                .par_iter()
                .enumerate()
                .map(|(p, hit)| match hit {
                    None => Ok((0.0, 0.0)),
                    Some(hit) => {
                        let brdf = Phong::of_any(scene.brdf(hit))?;
                        let own = scene.own_proxies(hit);
                        let occluded = |v| {
                            scene
                                .proxies
                                .iter()
                                .enumerate()
                                .any(|(i, s)| !own.contains(&i) && ray_sphere(hit.x, v, s).is_some())
                        };
                        let e = crate::sky::scene_reference(&scene, &brdf, occluded, hit, spp, MC_SEED ^ p as u64);
                        Ok((e.mean, e.std_error))
                    }
                })
                .collect::<Result<_, String>>()?;
            let (sref, sse): (Vec<f64>, Vec<f64>) = per.into_iter().unzip();
            let t0 = std::time::Instant::now();
            let img: Vec<f64> = hits
                .par_iter()
                .map(|hit| match hit {
                    None => Ok(0.0),
                    Some(hit) => super::render::shade_hit(&tables, &Settings::default(), &scene, hit),
                })
                .collect::<Result<_, String>>()?;
            let t = t0.elapsed().as_secs_f64();
            let npx = lit.iter().filter(|&&l| l).count();
            let d2: Vec<f64> = sref.iter().zip(&mref).map(|(a, b)| (a - b) * (a - b)).collect();
            let m = &scene.meshes[0];
            let off_mesh: Vec<bool> = hits.iter().map(|h| h.is_some_and(|h| h.mesh.is_none())).collect();
            let on_mesh: Vec<bool> = hits.iter().map(|h| h.is_some_and(|h| h.mesh.is_some())).collect();
            let mean_off = mean_over(&mref, &off_mesh);
            let inside = |h: &crate::scene::Hit| {
                scene
                    .proxies
                    .iter()
                    .any(|s| (h.x - s.centre).length_squared() < s.radius * s.radius)
            };
            let clear: Vec<bool> = hits
                .iter()
                .map(|h| h.is_some_and(|h| h.mesh.is_none() && !inside(&h)))
                .collect();
            let buried = off_mesh.iter().zip(&clear).filter(|(o, c)| **o && !**c).count();
            rows.push(ProxyRow {
                method,
                count,
                quality: quality(&m.mesh, &scene.proxies[m.proxy.clone()], quality_samples, 1),
                proxy: mean_over(&d2, &lit).sqrt() / mean_ref,
                proxy_off_mesh: mean_over(&d2, &off_mesh).sqrt() / mean_off,
                proxy_on_mesh: mean_over(&d2, &on_mesh).sqrt() / mean_over(&mref, &on_mesh),
                pipeline_on_mesh: noise_free_rel_rmse(&img, &sref, &sse, &on_mesh),
                buried,
                proxy_clear: mean_over(&d2, &clear).sqrt() / mean_over(&mref, &clear),
                pipeline: noise_free_rel_rmse(&img, &sref, &sse, &lit),
                total: noise_free_rel_rmse(&img, &mref, &mse, &lit),
                us_per_pixel: 1e6 * t / npx as f64,
            });
        }
    }
    let on_mesh = hits.iter().filter(|h| h.is_some_and(|h| h.mesh.is_some())).count();
    Ok(ProxyStudy {
        size: (w, h),
        pixels: (lit.iter().filter(|&&l| l).count(), on_mesh),
        spp,
        ref_rel_se: mean_over(&mse, &lit) / mean_ref,
        rows,
    })
}

impl ProxyStudy {
    /// The rows as a Markdown table.
    pub fn table(&self) -> String {
        let mut s = format!(
            "{}×{} pixels ({} see geometry, {} of them the mesh), {} samples/pixel (mesh reference's standard error {:.4} of its mean)\n\n\
             | method | spheres | volume error | Hausdorff mesh→spheres / diag | spheres→mesh / diag | proxy error (spheres ref. vs mesh ref.) | on the mesh | off the mesh | off-mesh pixels inside a sphere | off the mesh, outside every sphere | pipeline's own error (ISG vs spheres ref.) | on the mesh | ISG vs mesh ref. | ISG µs/pixel |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
            self.size.0, self.size.1, self.pixels.0, self.pixels.1, self.spp, self.ref_rel_se
        );
        for r in &self.rows {
            s += &format!(
                "| {} | {} | {:.3} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.1} |\n",
                r.method.name(),
                r.count,
                r.quality.volume_error,
                r.quality.hausdorff_mesh_to_spheres / r.quality.diagonal,
                r.quality.hausdorff_spheres_to_mesh / r.quality.diagonal,
                r.proxy,
                r.proxy_on_mesh,
                r.proxy_off_mesh,
                r.buried,
                r.proxy_clear,
                r.pipeline,
                r.pipeline_on_mesh,
                r.total,
                r.us_per_pixel
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bunny_scene() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/isg-bunny.json")
    }

    /// The study at full size (docs/meshes.md): prints its table; `LF_SPP` sets the
    /// references' samples per pixel (default 4096).
    #[test]
    #[ignore = "study: minutes; docs/meshes.md"]
    fn proxy_error_study() {
        let s = proxy_study(
            &bunny_scene(),
            160,
            // LF_SPP: samples per pixel of the references (docs/meshes.md's table: 4096).
            std::env::var("LF_SPP")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(4096),
            // LF_METHODS (comma-separated names), LF_COUNTS: the rows (default: all).
            &std::env::var("LF_METHODS").map_or(Method::ALL.to_vec(), |v| {
                v.split(',').map(|m| Method::parse(m).unwrap()).collect()
            }),
            &std::env::var("LF_COUNTS").map_or(vec![8, 16, 32, 64, 128, 256], |v| {
                v.split(',').map(|n| n.parse().unwrap()).collect()
            }),
            100_000,
        )
        .unwrap();
        println!("{}", s.table());
    }

    /// A tiny study: deterministic, every error finite, and the sphere set's error
    /// against the true mesh shrinks from 8 to 64 k-means spheres.
    #[test]
    fn tiny_proxy_study() {
        let run = || proxy_study(&bunny_scene(), 20, 32, &[Method::Kmeans], &[8, 64], 4000).unwrap();
        let (a, b) = (run(), run());
        assert!(a.pixels.1 > 10, "{:?}", a.pixels);
        for (x, y) in a.rows.iter().zip(&b.rows) {
            assert_eq!(
                (x.proxy.to_bits(), x.pipeline.to_bits(), x.total.to_bits()),
                (y.proxy.to_bits(), y.pipeline.to_bits(), y.total.to_bits())
            );
            assert!(x.proxy.is_finite() && x.pipeline.is_finite() && x.total.is_finite());
        }
        assert!(a.rows[1].proxy < a.rows[0].proxy, "{}", a.table());
    }
}
