//! `lobefit eval direct-light --scene FILE [--exact]`: the lobe pipeline at given
//! points of a scene (no image), as `render meunier` shades its pixels: the scene
//! file's spherical lights, its spheres and its meshes' sphere sets as blockers
//! ([`Scene::proxies`]), its top-level `brdf`. `--exact` is Monte Carlo over each
//! light's cap with exact visibility: the spheres and the meshes' **true triangles**,
//! so the difference is the lobes' error plus the sphere proxy's (docs/meshes.md).

use std::sync::Arc;

use lobefit_tables::geom::Brdf;
use lobefit_tables::{CapExponent, LoadError, LobeProduct, LookupError, MaskWeights, Meunier, Table};

use super::direct_light::DirectLightView;
use super::render::reference_sampled;
use crate::estimate::{Estimate, Sampling};
use crate::scene::{Hit, Scene};
use crate::sky::{exact_estimate_noted, hit_on_scene, POINT_INPUTS};
use lobefit_core::family::{EvalFlags, Lookup, View};
use lobefit_fits::mask_weights::MaskWeightsFamily;

/// `eval direct-light` with `--scene`: the view over the scene file.
#[derive(Clone)]
pub struct SceneView {
    /// The mask settings (`--depth`, `--mask`, `--weights`, `--light`).
    view: DirectLightView,
    scene: Arc<Scene>,
    brdf: Brdf,
    /// The top-level `brdf`'s index in the scene's materials (the reference's).
    material: usize,
}

impl SceneView {
    /// From `eval`'s flags: `--scene FILE` and [`DirectLightView::from_flags`]'s.
    pub fn from_flags(flags: &EvalFlags, path: &str) -> Result<Self, lobefit_core::family::EvalError> {
        let view = DirectLightView::from_flags(flags)?;
        let mut scene = crate::scene::load_for_eval(
            &crate::scene_text(path).map_err(lobefit_core::family::EvalError::Input)?,
            &super::ACCEPTS,
        )?;
        if scene.lights.is_empty() {
            return Err(format!("scene {}: direct-light needs a spherical light", scene.name).into());
        }
        let brdf = scene
            .brdf
            .clone()
            .ok_or_else(|| format!("scene {}: direct-light --scene needs the top-level brdf", scene.name))?;
        // The reference shades a row's hit with the scene's material of the hit: the
        // top-level brdf, added to the materials once.
        scene.materials.push(brdf.clone());
        let material = scene.materials.len() - 1;
        Ok(SceneView {
            view,
            scene: Arc::new(scene),
            brdf,
            material,
        })
    }
}

struct SceneLookup {
    view: SceneView,
    weights: MaskWeights,
}

impl Lookup for SceneLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let v = &self.view;
        let h = hit_on_scene(x, &v.scene, None)?;
        if v.scene.buried(&h) {
            // Inside a mesh's covering sphere: the proxy is a solid (`Scene::buried`).
            return Ok(vec![0.0]);
        }
        let bad = |e: LoadError| LookupError::NotFinite {
            name: format!("embedded table ({e})"),
            value: f64::NAN,
        };
        let m = Meunier {
            products: LobeProduct::embedded().map_err(bad)?,
            caps: CapExponent::embedded().map_err(bad)?,
            weights: &self.weights,
        };
        m.radiance(
            h.x,
            h.n,
            h.t,
            h.wo,
            &v.brdf,
            &v.scene.lights,
            &v.scene.blockers(&h),
            &v.view.settings,
        )
        .map(|r| vec![r])
        .map_err(super::direct_light::to_lookup)
    }
}

impl View for SceneView {
    fn kind(&self) -> &'static str {
        MaskWeightsFamily.kind()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &POINT_INPUTS
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["radiance"]
    }
    fn embedded(&self) -> &'static [u8] {
        MaskWeightsFamily.embedded()
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        Ok(Box::new(SceneLookup {
            view: self.clone(),
            weights: MaskWeights::from_table(table)?,
        }))
    }
    fn caveat(&self, x: &[f64]) -> Option<&'static str> {
        crate::sky::buried_caveat(x, &self.scene, None)
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        match self.exact_noted(x)? {
            (y, None) => Ok(y),
            (_, Some(note)) => Err(note),
        }
    }
    fn exact_noted(&self, x: &[f64]) -> Result<(Vec<f64>, Option<String>), String> {
        let h = Hit {
            material: self.material,
            ..hit_on_scene(x, &self.scene, None).map_err(|e| e.to_string())?
        };
        let scene = &*self.scene;
        // A point inside a light is refused, as the pipeline refuses it (its answer
        // there is undefined: the light surrounds it).
        if let Some((k, l)) = scene
            .lights
            .iter()
            .enumerate()
            .find(|(_, l)| (h.x - l.sphere.centre).length() <= l.sphere.radius)
        {
            return Err(
                super::direct_light::to_lookup(lobefit_tables::MeunierError::PointInsideLight {
                    index: k,
                    distance: (h.x - l.sphere.centre).length(),
                    radius: l.sphere.radius,
                })
                .to_string(),
            );
        }
        // Seeded by the row, so the same row gives the same answer.
        let seed = x.iter().fold(0x5eed_d11e_u64, |s, v| s.rotate_left(7) ^ v.to_bits());
        exact_estimate_noted(|n| {
            // Each light's cap sampled with n samples; the sum of independent means.
            let parts: Vec<Estimate> = scene
                .lights
                .iter()
                .enumerate()
                .map(|(k, l)| reference_sampled(Sampling::Plain, scene, l, &h, n, seed ^ k as u64, true))
                .collect();
            Estimate {
                mean: parts.iter().map(|e| e.mean).sum(),
                std_error: parts.iter().map(|e| e.std_error * e.std_error).sum::<f64>().sqrt(),
                samples: n,
            }
        })
        .map(|(m, note)| (vec![m], note))
    }
}

/// The pipeline's entry for `lobefit eval direct-light` ([`crate::Pipeline::eval`]):
/// with `--scene`, a scene's points ([`SceneView`]); without, the rows' own light and
/// blocker ([`DirectLightView`]).
pub fn view(flags: &EvalFlags) -> Result<Box<dyn View>, lobefit_core::family::EvalError> {
    if let Some(path) = flags.text("scene") {
        return Ok(Box::new(SceneView::from_flags(flags, &path)?));
    }
    Ok(Box::new(DirectLightView::from_flags(flags)?))
}
