//! Iwasaki et al. 2012 end to end: spheres under an environment of spherical
//! Gaussians, diffuse and Phong BRDFs as SGs, shadows through the integrated SG over
//! occluded patches (docs/isg-render.md). [`shade`] is the pipeline at one point,
//! [`reference`] its Monte Carlo reference with exact visibility, `render` the images.

pub mod eval;
pub mod render;
pub mod shade;

use std::f64::consts::{PI, TAU};

use lobefit_tables::glam::DVec3;
use lobefit_tables::isg::Sg;

use super::estimate::{estimate, Estimate};
use super::scene::Hit;
use super::Pipeline;
use crate::rng::Rng;
use shade::Phong;

/// `lobefit render isg`.
pub const PIPELINE: Pipeline = Pipeline {
    name: "isg",
    about: "Iwasaki et al. 2012: spheres under an SG environment, ISG shadows (docs/isg-render.md)",
    scenes: &["fig12", "fig12-diffuse", "sweep"],
    render: render::render,
};

/// L(ω) of the environment (radiance).
pub fn environment(env: &[Sg], w: DVec3) -> f64 {
    env.iter().map(|g| g.eval(w)).sum()
}

/// A direction of the SG `g`'s normalised density G/∫G over the sphere, and that
/// density's value there is [`sg_pdf`].
fn sample_sg(g: &Sg, rng: &mut Rng) -> DVec3 {
    let l = g.sharpness;
    // cos θ = 1 + ln(1 − u (1 − e^{−2λ}))/λ, inverted from the CDF in cos θ.
    let u = rng.uniform();
    let c = (1.0 + (u * (-2.0 * l).exp_m1()).ln_1p() / l).clamp(-1.0, 1.0);
    let s = (1.0 - c * c).max(0.0).sqrt();
    let p = rng.range(0.0, TAU);
    let (a, b) = g.axis.any_orthonormal_pair();
    c * g.axis + s * (p.cos() * a + p.sin() * b)
}

/// The density (1/sr) of [`sample_sg`] at `w`.
fn sg_pdf(g: &Sg, w: DVec3) -> f64 {
    let l = g.sharpness;
    l * (l * (g.axis.dot(w) - 1.0)).exp() / (TAU * -(-2.0 * l).exp_m1())
}

/// Reference outgoing radiance at hit `h`: `n` samples of a mixture of the cosine,
/// the Phong lobe and each lighting SG (in proportion to its integral), each sample
/// weighted by the mixture's density (one-sample multiple importance sampling,
/// balance heuristic), with exact ray–sphere visibility against `blockers`. Unbiased:
/// the cosine strategy covers the whole hemisphere.
pub fn reference(env: &[Sg], brdf: &Phong, occluded: impl Fn(DVec3) -> bool, h: &Hit, n: usize, seed: u64) -> Estimate {
    let nrm = h.n;
    let r = (2.0 * nrm.dot(h.wo) * nrm - h.wo).normalize();
    let (t, b) = nrm.any_orthonormal_pair();
    let (rt, rb) = r.any_orthonormal_pair();
    let spec = brdf.specular > 0.0;
    let energy: Vec<f64> = env.iter().map(Sg::integral).collect();
    let total: f64 = energy.iter().sum();
    // Strategy probabilities: cosine, Phong, the SGs.
    let (p_cos, p_phong) = if spec { (0.3, 0.3) } else { (0.5, 0.0) };
    let p_env = if total > 0.0 { 1.0 - p_cos - p_phong } else { 0.0 };
    let p_cos = 1.0 - p_phong - p_env;
    let e = brdf.exponent;
    let f_r = |w: DVec3| {
        let mut f = brdf.diffuse / PI;
        if spec {
            f += brdf.specular * (e + 2.0) / TAU * r.dot(w).max(0.0).powf(e);
        }
        f
    };
    estimate(n, seed, |rng| {
        let pick = rng.uniform();
        let w = if pick < p_cos {
            let (u1, u2) = (rng.uniform(), rng.range(0.0, TAU));
            let s = u1.sqrt();
            s * (u2.cos() * t + u2.sin() * b) + (1.0 - u1).sqrt() * nrm
        } else if pick < p_cos + p_phong {
            let c = rng.uniform().powf(1.0 / (e + 1.0));
            let s = (1.0 - c * c).max(0.0).sqrt();
            let p = rng.range(0.0, TAU);
            c * r + s * (p.cos() * rt + p.sin() * rb)
        } else {
            let mut x = rng.uniform() * total;
            let mut k = 0;
            while k + 1 < env.len() && x >= energy[k] {
                x -= energy[k];
                k += 1;
            }
            sample_sg(&env[k], rng)
        };
        let c = nrm.dot(w);
        if c <= 0.0 {
            return 0.0;
        }
        let mut pdf = p_cos * c / PI;
        if spec {
            pdf += p_phong * (e + 1.0) / TAU * r.dot(w).max(0.0).powf(e);
        }
        if p_env > 0.0 {
            pdf += p_env
                * env
                    .iter()
                    .zip(&energy)
                    .map(|(g, &en)| en / total * sg_pdf(g, w))
                    .sum::<f64>();
        }
        if pdf <= 0.0 || occluded(w) {
            return 0.0;
        }
        environment(env, w) * f_r(w) * c / pdf
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference against a closed form: a Lambertian point with no blocker under
    /// one SG of axis n radiates k_d/π μ ∫ e^{λ(c−1)} c dω over the hemisphere,
    /// = k_d/π μ 2π [1/λ − (1 − e^{−λ})/λ²].
    #[test]
    fn reference_matches_a_closed_form_within_its_standard_error() {
        let lambda = 30.0;
        let g = Sg::new(DVec3::Z, lambda, 2.0).unwrap();
        let want = 0.7 / PI * 2.0 * TAU * (1.0 / lambda - (-(-lambda).exp_m1()) / (lambda * lambda));
        let h = Hit {
            x: DVec3::ZERO,
            n: DVec3::Z,
            t: DVec3::X,
            wo: DVec3::new(0.6, 0.0, 0.8),
            sphere: None,
            material: 0,
        };
        let brdf = Phong {
            diffuse: 0.7,
            specular: 0.0,
            exponent: 0.0,
        };
        let est = reference(&[g], &brdf, |_| false, &h, 20_000, 7);
        assert!(
            (est.mean - want).abs() < 4.0 * est.std_error && est.std_error < 0.01 * want,
            "{est:?} vs {want}"
        );
    }
}

#[cfg(test)]
mod unoccluded {
    use super::*;
    use crate::pipelines::isg::shade::{radiance, Settings, Tables};

    /// A plane point under the Figure 12 analogue's nine SGs with no blocker: the
    /// pipeline (exact clamped cosine, Phong as one SG, eq. 9) against the reference
    /// (400 000 samples), diffuse and Phong 1000 from two view directions: within
    /// 4 standard errors plus 0.5 %.
    #[test]
    fn pipeline_against_the_reference_without_blockers() {
        let scene = crate::pipelines::scene::builtin("isg-fig12").unwrap().unwrap();
        let t = Tables::embedded().unwrap();
        for (kd, ks) in [(1.0, 0.0), (0.0, 0.4)] {
            let brdf = Phong {
                diffuse: kd,
                specular: ks,
                exponent: 1000.0,
            };
            for wo in [DVec3::new(0.0, -0.6, 0.8), DVec3::new(-0.5, 0.4, 0.77).normalize()] {
                let h = Hit {
                    x: DVec3::ZERO,
                    n: DVec3::Z,
                    t: DVec3::X,
                    wo,
                    sphere: None,
                    material: 0,
                };
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
    use super::*;
    use crate::pipelines::isg::shade::{radiance, Blockers, Settings, Tables};

    /// Culling the blockers against each product's cone through the BVH (§4.2) gives
    /// the very radiance the scan over every sphere gives, at every pixel of a small
    /// image of the 306-sphere sweep scene (both exclude the hit's own sphere).
    #[test]
    fn the_bvh_cull_equals_the_scan() {
        let scene = crate::pipelines::isg::render::sweep_scene(306).unwrap();
        let t = Tables::embedded().unwrap();
        let (w, h) = (24, 18);
        let mut seen = 0;
        for p in 0..w * h {
            let Some(hit) = scene.primary(p % w, p / w, w, h) else {
                continue;
            };
            let brdf = Phong::of(scene.brdf(&hit)).unwrap();
            let scan = Blockers {
                bvh: None,
                ..crate::pipelines::isg::render::blockers_of(&scene, &hit)
            };
            let a = radiance(&t, &Settings::default(), &scene.environment, &brdf, &scan, &hit).unwrap();
            let b = radiance(
                &t,
                &Settings::default(),
                &scene.environment,
                &brdf,
                &crate::pipelines::isg::render::blockers_of(&scene, &hit),
                &hit,
            )
            .unwrap();
            assert_eq!(a.to_bits(), b.to_bits(), "pixel {p}");
            seen += 1;
        }
        assert!(seen > 200, "{seen} pixels see geometry");
    }
}
