//! Ren et al. 2006 and Giraud & Nowrouzezahrai 2015 end to end: a height field and
//! sphere blockers under a distant light given as SGs or SH, soft shadows through SH
//! exponentiation (docs/shexp-render.md). [`shade`] is the pipeline at one point;
//! its reference is the shared Monte Carlo estimator with exact visibility
//! (`pipelines::sky`); `render` makes the images.

pub mod eval;
pub mod render;
pub mod shade;

use lobefit_tables::glam::DVec3;

use super::estimate::Estimate;
use super::scene::{Hit, Scene};
use super::sky::{environment, reference_with, Phong};
use super::Pipeline;

/// `lobefit render shexp`.
pub const PIPELINE: Pipeline = Pipeline {
    name: "shexp",
    about: "Ren et al. 2006 / Giraud 2015: height field and spheres under an SH sky, SH-exponentiation shadows (docs/shexp-render.md)",
    scenes: &["whale", "whale-diffuse", "wrecking"],
    render: render::render,
};

/// The scene's distant light: its SGs, or its SH function.
pub fn light(scene: &Scene, w: DVec3) -> f64 {
    match &scene.sh_environment {
        Some(c) => shade::sh_value(c, w),
        None => environment(&scene.environment, w),
    }
}

/// The light's SH vector at `order`: the SGs projected exactly, or the file's
/// coefficients truncated (or padded with zeros) to that order.
pub fn light_sh(scene: &Scene, order: usize) -> Result<Vec<f64>, String> {
    match &scene.sh_environment {
        Some(c) => {
            let mut out = vec![0.0; order * order];
            let k = out.len().min(c.len());
            out[..k].copy_from_slice(&c[..k]);
            Ok(out)
        }
        None => shade::project_sgs(&scene.environment, order),
    }
}

/// The Monte Carlo reference at `h` under `light(ω)` with exact visibility (spheres
/// and height field); the scene's SGs, if any, are sampled.
pub fn reference(scene: &Scene, light: impl Fn(DVec3) -> f64, brdf: &Phong, h: &Hit, n: usize, seed: u64) -> Estimate {
    reference_with(&scene.environment, light, brdf, |v| scene.occluded(h, v), h, n, seed)
}
