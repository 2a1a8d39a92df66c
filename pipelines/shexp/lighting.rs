//! The SH-exponentiation scenes' distant light (SGs or SH) and its Monte Carlo
//! reference: what the pipeline, its renders, its `eval` view and the baselines
//! study share.

use lobefit_tables::glam::DVec3;

use super::shade;
use crate::estimate::Estimate;
use crate::estimate::Sampling;
use crate::scene::{Hit, Scene};
use crate::sky::{reference_map, reference_with, Phong};

/// The scene's distant light: its SGs, the map they were fitted to
/// ([`Scene::light`]), or its SH function.
pub fn light(scene: &Scene, w: DVec3) -> f64 {
    match &scene.sh_environment {
        Some(c) => shade::sh_value(c, w),
        None => scene.light(w),
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

/// The warning when the pipeline at `order` drops bands of the scene's
/// `sh_environment` (naming both orders); `None` when it keeps them all.
pub fn truncation_warning(scene: &Scene, order: usize) -> Option<String> {
    let given = (scene.sh_environment.as_ref()?.len() as f64).sqrt().round() as usize;
    (given > order).then(|| {
        format!(
            "warning: scene {}: sh_environment of order {given} truncated to the pipeline's order {order} (bands {order}..={} \
             dropped; the reference keeps them)",
            scene.name,
            given - 1
        )
    })
}

/// The Monte Carlo reference at `h` under `light(ω)` with exact visibility (spheres
/// and height field); the scene's map, if it has one, else its SGs, if any, are
/// sampled.
pub fn reference(scene: &Scene, light: impl Fn(DVec3) -> f64, brdf: &Phong, h: &Hit, n: usize, seed: u64) -> Estimate {
    let occluded = |v| scene.occluded(h, v);
    match &scene.environment_map {
        Some(m) => reference_map(Sampling::Plain, m, light, brdf, occluded, h, n, seed),
        None => reference_with(&scene.environment, light, brdf, occluded, h, n, seed),
    }
}
