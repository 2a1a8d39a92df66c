//! Meunier et al. 2009, direct lighting from spherical lights with cosine-lobe
//! visibility masks (docs/meunier.md), end to end: `lobefit eval direct-light`
//! ([`direct_light`]: the pipeline without images, and its exact reference) and
//! `lobefit render meunier` ([`render`]). The tables it reads (lobe-product,
//! cap-exponent, mask-weights) are fitted in `fits/`.

pub mod direct_light;
pub mod light_fit;
pub mod render;
pub mod scaling;
pub mod scene_view;

use super::Pipeline;

/// The scene kinds the pipeline shades (its renders and its `eval` views).
pub const ACCEPTS: super::scene::Accepts = super::scene::Accepts {
    pipeline: "the Meunier pipeline",
    heightfield: false,
    sphere_lights: true,
    sg_environment: false,
    sh_environment: false,
    planes: true,
    meshes: true,
};

/// `lobefit render meunier`.
pub const PIPELINE: Pipeline = Pipeline {
    name: "meunier",
    about: "Meunier et al. 2009: spheres over a plane under a spherical light (docs/meunier.md)",
    scenes: &["fig13", "glossy"],
    files: &[
        ("fig13", include_str!("scenes/fig13.json")),
        ("glossy", include_str!("scenes/glossy.json")),
        ("orbit", include_str!("scenes/orbit.json")),
    ],
    render: render::render,
    eval: &[super::EvalView {
        name: "direct-light",
        help: direct_light::EVAL_HELP,
        flags: direct_light::FLAGS,
        view: scene_view::view,
    }],
    plots: &[("meunier", direct_light::plot), ("meunier-scaling", scaling::plot)],
    truth: super::Truth::MonteCarlo(super::MonteCarlo {
        accepts: ACCEPTS,
        load: render::scene,
        // The image's reference; the breakdown is quadrature.
        references: (1, 0),
        precise_factor: 0,
    }),
    animate: Some(render::animate),
    animations: &["orbit"],
    pareto: Some(crate::baselines::MEUNIER),
};
