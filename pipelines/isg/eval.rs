//! `lobefit eval isg-shade --scene FILE [--model paper|refit|best] [--patches N]
//! [--exact]`: the ISG pipeline at given points (no image). The scene file gives the
//! environment, the spheres and meshes (every one occludes; the pipeline sees a mesh
//! through its sphere set, `--exact` through its triangles) and the top-level `brdf`.

use std::sync::Arc;

use lobefit_tables::glam::DVec3;
use lobefit_tables::{BestIsg, LoadError, LookupError, RefitIsg, Table};

use super::render::blockers_of;
use super::shade::{radiance, Model, Patches, Phong, Settings, Specular, Tables};
use crate::estimate::Sampling;
use crate::scene::Scene;
use crate::sky::{exact_estimate_noted, hit_on_scene, POINT_INPUTS};
use lobefit_core::family::{EvalError, EvalFlag, EvalFlags, Lookup, View};

/// The flags `eval isg-shade` takes.
pub const FLAGS: &[EvalFlag] = &[
    EvalFlag {
        name: "scene",
        help: "FILE (required: environment SGs, spheres or meshes, top-level brdf)",
        count: false,
    },
    EvalFlag {
        name: "model",
        help: "paper | refit | best (default best)",
        count: false,
    },
    EvalFlag {
        name: "patches",
        help: "N × N patches per product SG, 1..=64 (default adaptive)",
        count: true,
    },
];

/// `eval --help`'s paragraph.
pub const EVAL_HELP: &str = "
isg-shade  (a pipeline: Iwasaki et al.'s shading of points, docs/isg-render.md)
  flags    --scene FILE (required: environment SGs, spheres or meshes, top-level brdf), --model paper|refit|best
           (default best), --patches N (N × N patches per product SG, 1..=64; default adaptive, 10 to 20)
  in   `px`,`py`,`pz`  the point (scene units); `nx`,`ny`,`nz` its unit normal; `vx`,`vy`,`vz` the unit
                       direction towards the viewer
  out  `radiance`      outgoing radiance (the environment's units; under a map its Rec. 709 luminance, and
                       `radiance_r`, `radiance_g`, `radiance_b` its linear RGB, each channel's lobes shaded; --exact
                       each channel of the map at the luminance's sample count): the environment's SGs times the BRDF
                       (k_d/π + k_s (n+2)/(2π) max(r·ω,0)^n) and the clamped cosine, visible where no sphere
                       blocks (a mesh: its sphere set; 0 inside another blocker's sphere); --exact: Monte Carlo
                       with exact visibility (spheres, a mesh's triangles), run until its standard error is at
                       most 1e-3 of the estimate (at most 2^24 samples; a row stopped short keeps its estimate,
                       with a warning naming it). A point within 1e-5 of a surface's scale (either side: f32
                       positions) is moved onto it; on a mesh it sees past its own sphere set; a point inside a
                       mesh is refused; one in space inside a mesh's covering sphere is 0, with a warning
";

/// The `eval isg-shade` view.
#[derive(Clone)]
pub struct IsgShadeView {
    settings: Settings,
    brdf: Phong,
    scene: Arc<Scene>,
    /// Under a map: each channel's lobes (the `radiance_r/g/b` columns).
    channels: Option<Arc<[Vec<lobefit_tables::Sg>; 3]>>,
}

/// The columns under SGs, and under a map (luminance, then linear R, G, B).
const OUT: [&str; 1] = ["radiance"];
const OUT_RGB: [&str; 4] = ["radiance", "radiance_r", "radiance_g", "radiance_b"];

impl IsgShadeView {
    /// From `eval`'s flags (`--scene` required, `--model`, `--patches`).
    pub fn from_flags(flags: &EvalFlags) -> Result<Self, EvalError> {
        flags.only("isg-shade", FLAGS)?;
        let path = flags.text("scene").ok_or("isg-shade needs --scene FILE")?;
        let scene = crate::scene::load_for_eval(
            &crate::scene_text(&path).map_err(lobefit_core::family::EvalError::Input)?,
            &super::ACCEPTS,
        )?;
        if scene.environment.is_empty() {
            return Err(format!("scene {}: isg-shade needs an environment (SGs)", scene.name).into());
        }
        let brdf = scene
            .brdf
            .as_ref()
            .ok_or_else(|| format!("scene {}: isg-shade needs the top-level brdf", scene.name))?;
        let brdf = Phong::of_any(brdf).map_err(|e| format!("scene {}: brdf: {e}", scene.name))?;
        let model = flags.text("model").as_deref().map_or(Ok(Model::Best), Model::parse)?;
        let patches = match flags.count("patches")? {
            None => Patches::Adaptive,
            Some(n) if (1..=64).contains(&n) => Patches::Grid(n),
            Some(n) => return Err(format!("--patches {n} is outside 1..=64").into()),
        };
        let channels = scene
            .environment_map
            .as_ref()
            .map(|m| Arc::new([0, 1, 2].map(|c| m.channel_sgs(c))));
        // A scene that names its map's Γ_L gets eq. 9 from it (docs/environment.md:
        // 10 × lower error on glossy spheres than the lobes' forms).
        let specular = if scene.prefiltered.is_some() {
            Specular::Eq9Prefiltered
        } else {
            Settings::default().specular
        };
        Ok(IsgShadeView {
            settings: Settings {
                model,
                patches,
                specular,
                ..Settings::default()
            },
            brdf,
            scene: Arc::new(scene),
            channels,
        })
    }
}

/// Cosine of the view angle (70°) past which `eval isg-shade` warns on a glossy term.
const GRAZING_COS: f64 = 0.342;

/// The warning for a glossy term at a grazing view: the BRDF's SG about the mirror
/// direction straddles the horizon, which clips it (measured against --exact on fig12's
/// ground, 75° view: Phong 1 000 −15 %, Phong 50 −33 %, Cook–Torrance α 0.3 −21 % and
/// α 0.02 −72 %, Blinn-Phong 200 −60 %; 88°: −20 to −84 %; views up to 60° within 5 %).
const GRAZING: &str = "the view is more than 70° from the normal: the glossy term's SG straddles the horizon \
                       and the pipeline underestimates it (by 15 to 72 % at 75°; docs/environment.md)";

struct ShadeLookup {
    view: IsgShadeView,
    tables: Tables,
}

impl Lookup for ShadeLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let scene = &*self.view.scene;
        let h = hit_on_scene(x, scene, None)?;
        let columns = self.view.outputs().len();
        if scene.buried(&h) {
            // Inside a mesh's covering sphere: the proxy is a solid (`Scene::buried`).
            return Ok(vec![0.0; columns]);
        }
        let blockers = blockers_of(scene, &h);
        // Each channel's lobes, and with Γ_L that channel of it.
        let shade = |env: &[lobefit_tables::Sg], channel: Option<usize>| {
            let s = Settings {
                prefiltered_channel: channel,
                ..self.view.settings
            };
            radiance(&self.tables, &s, env, &self.view.brdf, &blockers, &h).map_err(|e| LookupError::Refused {
                reason: format!("radiance: {e}"),
            })
        };
        let mut out = vec![shade(&scene.environment, None)?];
        if let Some(ch) = &self.view.channels {
            for (c, env) in ch.iter().enumerate() {
                out.push(shade(env, Some(c))?);
            }
        }
        Ok(out)
    }
}

impl View for IsgShadeView {
    fn kind(&self) -> &'static str {
        match self.settings.model {
            Model::Refit => lobefit_tables::isg::KIND_REFIT,
            _ => lobefit_tables::isg::KIND_BEST,
        }
    }
    fn inputs(&self) -> &'static [&'static str] {
        &POINT_INPUTS
    }
    fn outputs(&self) -> &'static [&'static str] {
        if self.channels.is_some() {
            &OUT_RGB
        } else {
            &OUT
        }
    }
    fn embedded(&self) -> &'static [u8] {
        match self.settings.model {
            Model::Refit => lobefit_tables::embedded::ISG_REFIT,
            _ => lobefit_tables::embedded::ISG_BEST,
        }
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        let mut tables = Tables::embedded().map_err(LoadError::BadMetadata)?;
        tables.prefiltered = self.scene.prefiltered.clone();
        match self.settings.model {
            Model::Refit => tables.refit = RefitIsg::from_table(table)?,
            _ => tables.best = BestIsg::from_table(table)?,
        }
        Ok(Box::new(ShadeLookup {
            view: self.clone(),
            tables,
        }))
    }
    fn caveat(&self, x: &[f64]) -> Option<&'static str> {
        crate::sky::buried_caveat(x, &self.scene, None).or_else(|| {
            // Columns px..nz, vx..vz: a glossy term seen at a grazing view.
            let cos = x[3] * x[6] + x[4] * x[7] + x[5] * x[8];
            (self.brdf.specular > 0.0 && cos < GRAZING_COS).then_some(GRAZING)
        })
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        match self.exact_noted(x)? {
            (y, None) => Ok(y),
            (_, Some(note)) => Err(note),
        }
    }
    fn exact_noted(&self, x: &[f64]) -> Result<(Vec<f64>, Option<String>), String> {
        let scene = &*self.scene;
        let h = hit_on_scene(x, scene, None).map_err(|e| e.to_string())?;
        // Seeded by the row, so the same row gives the same answer.
        let seed = x.iter().fold(0x5eed_15c0_u64, |s, v| s.rotate_left(7) ^ v.to_bits());
        let occluded = |v: DVec3| scene.occluded(&h, v);
        let mut samples = 0;
        let (m, note) = exact_estimate_noted(|n| {
            samples = n;
            crate::sky::scene_reference(scene, &self.brdf, occluded, &h, n, seed)
        })?;
        let mut out = vec![m];
        if let Some(map) = &scene.environment_map {
            // Each channel at the luminance's sample count, with its directions (the
            // same seed): the luminance decides when to stop.
            for c in 0..3 {
                let light = |w| map.channel(w, c);
                let e = crate::sky::reference_map(Sampling::Plain, map, light, &self.brdf, occluded, &h, samples, seed);
                out.push(e.finite(|| format!("the reference's channel {c}"))?.mean);
            }
        }
        Ok((out, note))
    }
}

/// The pipeline's entry for `lobefit eval` ([`crate::Pipeline::eval`]): the view its
/// flags configure.
pub fn view(flags: &EvalFlags) -> Result<Box<dyn View>, EvalError> {
    Ok(Box::new(IsgShadeView::from_flags(flags)?))
}
