//! `lobefit eval shexp-shade --scene FILE [--order N] [--exact]`: the SH-exponentiation
//! pipeline at given points (no image). The scene file gives the distant light
//! (`environment` SGs or `sh_environment`), the blockers (spheres and an optional
//! height field) and the top-level `brdf`.

use lobefit_tables::{LoadError, LookupError, ShExp, Table};

use super::shade::{radiance, Settings, Tables};
use crate::scene::Scene;
use crate::sky::{exact_estimate_noted, hit_on_scene, Phong, POINT_INPUTS};
use lobefit_core::family::{EvalError, EvalFlag, EvalFlags, Lookup, View};

/// The flags `eval shexp-shade` takes.
pub const FLAGS: &[EvalFlag] = &[
    EvalFlag {
        name: "scene",
        help: "FILE (required: a distant light, spheres, top-level brdf)",
        count: false,
    },
    EvalFlag {
        name: "order",
        help: "3..=8 (bands 0..N-1; default 4)",
        count: true,
    },
];

/// `eval --help`'s paragraph.
pub const EVAL_HELP: &str = "
shexp-shade  (a pipeline: Ren / Giraud's SH-exponentiation shading of points, docs/shexp-render.md)
  flags    --scene FILE (required: environment SGs or sh_environment, spheres and/or heightfield, top-level
           brdf), --order N (SH order 3..=8, default 4)
  in   `px`,`py`,`pz`  the point (scene units); `nx`,`ny`,`nz` its unit normal; `vx`,`vy`,`vz` the unit
                       direction towards the viewer
  out  `radiance`      outgoing radiance (the light's units): the light times the BRDF (k_d/π + k_s (n+2)/(2π)
                       max(r·ω,0)^n) and the clamped cosine, visible where no sphere and no terrain blocks;
                       --exact: Monte Carlo with exact visibility (ray-sphere, and the bilinear height field
                       exactly per cell), run until its standard error is at most 1e-3 of the estimate (at
                       most 2^24 samples; a row stopped short keeps its estimate, with a warning naming it).
                       A point within 1e-5 of a surface's scale (either side: f32 positions) is moved onto it
";

/// The `eval shexp-shade` view.
#[derive(Clone)]
pub struct ShExpShadeView {
    settings: Settings,
    scene: Scene,
    brdf: Phong,
    light: Vec<f64>,
}

impl ShExpShadeView {
    /// From `eval`'s flags (`--scene` required, `--order`).
    pub fn from_flags(flags: &EvalFlags) -> Result<Self, EvalError> {
        flags.only("shexp-shade", FLAGS)?;
        let path = flags.text("scene").ok_or("shexp-shade needs --scene FILE")?;
        // The render's rule, but planes: they are only seen (not blockers), and eval
        // shades given points, so they change nothing here. Meshes are seen through
        // their sphere sets, as in the render.
        let accepts = crate::scene::Accepts {
            planes: true,
            ..super::ACCEPTS
        };
        let scene = crate::scene::load_for_eval(
            &crate::scene_text(&path).map_err(lobefit_core::family::EvalError::Input)?,
            &accepts,
        )?;
        if scene.environment.is_empty() && scene.sh_environment.is_none() {
            return Err(format!(
                "scene {}: shexp-shade needs a distant light (environment or sh_environment)",
                scene.name
            )
            .into());
        }
        let brdf = scene
            .brdf
            .as_ref()
            .ok_or_else(|| format!("scene {}: shexp-shade needs the top-level brdf", scene.name))?;
        let brdf = Phong::of(brdf).map_err(|e| format!("scene {}: brdf: {e}", scene.name))?;
        let settings = Settings {
            order: flags.count("order")?.unwrap_or(Settings::default().order),
            ..Settings::default()
        };
        settings.validate().map_err(|e| format!("--order: {e}"))?;
        let light = super::light_sh(&scene, settings.order)?;
        if let Some(w) = super::truncation_warning(&scene, settings.order) {
            eprintln!("{w}");
        }
        Ok(ShExpShadeView {
            settings,
            scene,
            brdf,
            light,
        })
    }
}

struct ShadeLookup {
    view: ShExpShadeView,
    tables: Tables,
}

impl Lookup for ShadeLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let h = hit_on_scene(x, &self.view.scene, terrain(&self.view.scene))?;
        let v = &self.view;
        radiance(&self.tables, &v.settings, &v.light, &v.brdf, &v.scene, &h)
            .map(|r| vec![r])
            .map_err(|e| LookupError::Refused {
                reason: format!("radiance: {e}"),
            })
    }
}

impl View for ShExpShadeView {
    fn kind(&self) -> &'static str {
        lobefit_tables::shexp::KIND
    }
    fn inputs(&self) -> &'static [&'static str] {
        &POINT_INPUTS
    }
    fn outputs(&self) -> &'static [&'static str] {
        &["radiance"]
    }
    fn embedded(&self) -> &'static [u8] {
        lobefit_tables::embedded::SHEXP
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        let mut tables = Tables::embedded().map_err(LoadError::BadMetadata)?;
        tables.shexp = ShExp::from_table(table)?;
        Ok(Box::new(ShadeLookup {
            view: self.clone(),
            tables,
        }))
    }
    fn caveat(&self, x: &[f64]) -> Option<&'static str> {
        crate::sky::buried_caveat(x, &self.scene, terrain(&self.scene))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        match self.exact_noted(x)? {
            (y, None) => Ok(y),
            (_, Some(note)) => Err(note),
        }
    }
    fn exact_noted(&self, x: &[f64]) -> Result<(Vec<f64>, Option<String>), String> {
        let h = hit_on_scene(x, &self.scene, terrain(&self.scene)).map_err(|e| e.to_string())?;
        // Seeded by the row, so the same row gives the same answer.
        let seed = x.iter().fold(0x5eed_5e40_u64, |s, v| s.rotate_left(7) ^ v.to_bits());
        let scene = &self.scene;
        exact_estimate_noted(|n| super::reference(scene, |w| super::light(scene, w), &self.brdf, &h, n, seed))
            .map(|(m, note)| (vec![m], note))
    }
}

/// The scene's height field, if any.
fn terrain(scene: &Scene) -> Option<&crate::heightfield::HeightField> {
    scene.heightfield.as_ref().map(|(hf, _)| hf)
}

/// The pipeline's entry for `lobefit eval` ([`crate::Pipeline::eval`]): the view its
/// flags configure.
pub fn view(flags: &EvalFlags) -> Result<Box<dyn View>, EvalError> {
    Ok(Box::new(ShExpShadeView::from_flags(flags)?))
}
