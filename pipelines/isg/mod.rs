//! Iwasaki et al. 2012 end to end: spheres under an environment of spherical
//! Gaussians, diffuse and Phong BRDFs as SGs, shadows through the integrated SG over
//! occluded patches (docs/isg-render.md). [`shade`] is the pipeline at one point,
//! [`reference`] (shared, `pipelines::sky`) its Monte Carlo reference with exact
//! visibility, `render` the images.

pub mod eq9;
pub mod eval;
pub mod lod;
pub mod proxy;
pub mod render;
pub mod shade;
pub mod vertex;

pub use super::sg::environment;
pub use super::sky::reference;
use super::Pipeline;

/// The scene kinds the pipeline shades (its renders and its `eval` views).
pub const ACCEPTS: super::scene::Accepts = super::scene::Accepts {
    pipeline: "the ISG pipeline",
    heightfield: false,
    sphere_lights: false,
    sg_environment: true,
    sh_environment: false,
    planes: true,
    meshes: true,
};

/// `lobefit render isg`.
pub const PIPELINE: Pipeline = Pipeline {
    name: "isg",
    about: "Iwasaki et al. 2012: spheres under an SG environment, ISG shadows (docs/isg-render.md)",
    scenes: &["fig12", "fig12-diffuse", "sweep"],
    files: &[
        ("fig12", include_str!("scenes/fig12.json")),
        ("fig12-diffuse", include_str!("scenes/fig12-diffuse.json")),
        ("falling", include_str!("scenes/falling.json")),
    ],
    render: render::render,
    eval: &[super::EvalView {
        name: "isg-shade",
        help: eval::EVAL_HELP,
        flags: eval::FLAGS,
        view: eval::view,
    }],
    plots: &[],
    truth: super::Truth::MonteCarlo(super::MonteCarlo {
        accepts: ACCEPTS,
        load: render::scene,
        references: (1, 1),
        precise_factor: render::PRECISE_FACTOR as u64,
    }),
    animate: Some(render::animate),
    animations: &["falling"],
    pareto: Some(crate::baselines::ISG),
};

#[cfg(test)]
mod unoccluded {
    use super::*;
    use crate::isg::shade::{radiance, Phong, Settings, Tables};
    use crate::scene::Hit;
    use lobefit_tables::glam::DVec3;

    /// A plane point under the Figure 12 analogue's nine SGs with no blocker: the
    /// pipeline (exact clamped cosine, Phong as one SG, eq. 9) against the reference
    /// (400 000 samples), diffuse and Phong 1000 from two view directions: within
    /// 4 standard errors plus 0.5 %.
    #[test]
    fn pipeline_against_the_reference_without_blockers() {
        let scene = PIPELINE.scene("fig12").unwrap();
        let t = Tables::embedded().unwrap();
        for (kd, ks) in [(1.0, 0.0), (0.0, 0.4)] {
            let brdf = Phong {
                diffuse: kd,
                specular: ks,
                exponent: 1000.0,
                microfacet: None,
            };
            for wo in [DVec3::new(0.0, -0.6, 0.8), DVec3::new(-0.5, 0.4, 0.77).normalize()] {
                let h = Hit::ground(DVec3::ZERO, wo);
                let p = radiance(
                    &t,
                    &Settings::default(),
                    &scene.environment,
                    &brdf,
                    &shade::Blockers::all(&[]),
                    &h,
                )
                .unwrap();
                let r = reference(&scene.environment, &brdf, |_| false, &h, 400_000, 3);
                assert!(
                    (p - r.mean).abs() < 4.0 * r.std_error + 5e-3 * r.mean,
                    "kd {kd} ks {ks} wo {wo}: {p} vs {r:?}"
                );
            }
        }
    }
}

#[cfg(test)]
mod bvh_cull {
    use crate::isg::shade::{radiance, Blockers, Cull, Phong, Settings, Tables};

    /// Culling the blockers against each product's cone through the BVH (§4.2) gives
    /// the very radiance the scan over every sphere gives, at every pixel of a small
    /// image of the 306-sphere sweep scene (both exclude the hit's own sphere).
    #[test]
    fn the_bvh_cull_equals_the_scan() {
        let scene = crate::isg::render::sweep_scene(306).unwrap();
        let t = Tables::embedded().unwrap();
        let (w, h) = (24, 18);
        let mut seen = 0;
        for p in 0..w * h {
            let Some(hit) = scene.primary(p % w, p / w, w, h) else {
                continue;
            };
            let brdf = Phong::of_any(scene.brdf(&hit)).unwrap();
            let scan = Blockers {
                cull: Cull::Scan,
                ..crate::isg::render::blockers_of(&scene, &hit)
            };
            let a = radiance(&t, &Settings::default(), &scene.environment, &brdf, &scan, &hit).unwrap();
            let b = radiance(
                &t,
                &Settings::default(),
                &scene.environment,
                &brdf,
                &crate::isg::render::blockers_of(&scene, &hit),
                &hit,
            )
            .unwrap();
            assert_eq!(a.to_bits(), b.to_bits(), "pixel {p}");
            seen += 1;
        }
        assert!(seen > 200, "{seen} pixels see geometry");
    }
}
