//! `lobefit eval isg-shade --scene FILE [--model paper|refit|best] [--patches N]
//! [--exact]`: the ISG pipeline at given points (no image). The scene file gives the
//! environment, the spheres (every sphere occludes) and the top-level `brdf`.

use lobefit_tables::geom::Sphere;
use lobefit_tables::glam::DVec3;
use lobefit_tables::isg::Sg;
use lobefit_tables::{BestIsg, LoadError, LookupError, RefitIsg, Table};

use super::shade::{radiance, Blockers, Model, Patches, Phong, Settings, Tables};
use crate::scene::Bvh;
use crate::sky::{exact_estimate, hit_of_row, POINT_INPUTS};
use lobefit_core::family::{EvalFlag, EvalFlags, Lookup, View};

/// The flags `eval isg-shade` takes.
pub const FLAGS: &[EvalFlag] = &[
    EvalFlag {
        name: "scene",
        help: "FILE (required: environment SGs, spheres, top-level brdf)",
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
  flags    --scene FILE (required: environment SGs, spheres, top-level brdf), --model paper|refit|best
           (default best), --patches N (N × N patches per product SG, 1..=64; default adaptive, 10 to 20)
  in   `px`,`py`,`pz`  the point (scene units); `nx`,`ny`,`nz` its unit normal; `vx`,`vy`,`vz` the unit
                       direction towards the viewer
  out  `radiance`      outgoing radiance (the environment's units): the environment's SGs times the BRDF
                       (k_d/π + k_s (n+2)/(2π) max(r·ω,0)^n) and the clamped cosine, visible where no sphere
                       blocks; --exact: Monte Carlo with exact ray-sphere visibility, run until its standard
                       error is at most 1e-3 of the estimate (at most 2^24 samples, else an error)
";

/// The `eval isg-shade` view.
#[derive(Clone)]
pub struct IsgShadeView {
    settings: Settings,
    env: Vec<Sg>,
    brdf: Phong,
    spheres: Vec<Sphere>,
    bvh: Bvh,
}

impl IsgShadeView {
    /// From `eval`'s flags (`--scene` required, `--model`, `--patches`).
    pub fn from_flags(flags: &EvalFlags) -> Result<Self, String> {
        flags.only("isg-shade", FLAGS)?;
        let path = flags.text("scene").ok_or("isg-shade needs --scene FILE")?;
        // Meshes are the renders' so far: the view's rows carry no mesh to lie on.
        let accepts = crate::scene::Accepts {
            meshes: false,
            ..super::PIPELINE.accepts
        };
        let scene = crate::scene::load_for(&path, &accepts)?;
        if scene.environment.is_empty() {
            return Err(format!("scene {}: isg-shade needs an environment (SGs)", scene.name));
        }
        let brdf = scene
            .brdf
            .as_ref()
            .ok_or_else(|| format!("scene {}: isg-shade needs the top-level brdf", scene.name))?;
        let brdf = Phong::of(brdf).map_err(|e| format!("scene {}: brdf: {e}", scene.name))?;
        let model = flags.text("model").as_deref().map_or(Ok(Model::Best), Model::parse)?;
        let patches = match flags.count("patches")? {
            None => Patches::Adaptive,
            Some(n) if (1..=64).contains(&n) => Patches::Grid(n),
            Some(n) => return Err(format!("--patches {n} is outside 1..=64")),
        };
        Ok(IsgShadeView {
            settings: Settings {
                model,
                patches,
                ..Settings::default()
            },
            env: scene.environment.clone(),
            brdf,
            bvh: Bvh::new(&scene.spheres),
            spheres: scene.spheres,
        })
    }
}

struct ShadeLookup {
    view: IsgShadeView,
    tables: Tables,
}

impl Lookup for ShadeLookup {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        let h = hit_of_row(x, &self.view.spheres, None)?;
        let own = h.sphere.map_or(0..0, |i| i..i + 1);
        let blockers = Blockers {
            spheres: &self.view.spheres,
            bvh: Some(&self.view.bvh),
            own,
        };
        radiance(
            &self.tables,
            &self.view.settings,
            &self.view.env,
            &self.view.brdf,
            &blockers,
            &h,
        )
        .map(|r| vec![r])
        .map_err(|e| LookupError::Refused {
            reason: format!("radiance: {e}"),
        })
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
        &["radiance"]
    }
    fn embedded(&self) -> &'static [u8] {
        match self.settings.model {
            Model::Refit => lobefit_tables::embedded::ISG_REFIT,
            _ => lobefit_tables::embedded::ISG_BEST,
        }
    }
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError> {
        let mut tables = Tables::embedded().map_err(LoadError::BadMetadata)?;
        match self.settings.model {
            Model::Refit => tables.refit = RefitIsg::from_table(table)?,
            _ => tables.best = BestIsg::from_table(table)?,
        }
        Ok(Box::new(ShadeLookup {
            view: self.clone(),
            tables,
        }))
    }
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let h = hit_of_row(x, &self.spheres, None).map_err(|e| e.to_string())?;
        // Seeded by the row, so the same row gives the same answer.
        let seed = x.iter().fold(0x5eed_15c0_u64, |s, v| s.rotate_left(7) ^ v.to_bits());
        let occluded = |v: DVec3| self.bvh.occluded(&self.spheres, h.x, v, f64::INFINITY, h.sphere);
        exact_estimate(|n| super::reference(&self.env, &self.brdf, occluded, &h, n, seed)).map(|m| vec![m])
    }
}

/// The pipeline's entry for `lobefit eval` ([`crate::Pipeline::eval`]): the view its
/// flags configure.
pub fn view(flags: &EvalFlags) -> Result<Box<dyn View>, String> {
    Ok(Box::new(IsgShadeView::from_flags(flags)?))
}
