//! Ren et al. 2006 and Giraud & Nowrouzezahrai 2015 end to end: a height field and
//! sphere blockers under a distant light given as SGs or SH, soft shadows through SH
//! exponentiation (docs/shexp-render.md). [`shade`] is the pipeline at one point;
//! its reference is the shared Monte Carlo estimator with exact visibility
//! (`pipelines::sky`); `render` makes the images.

pub mod eval;
pub mod lighting;
pub mod render;
pub mod shade;

pub use lighting::{light, light_sh, reference, truncation_warning};

use super::Pipeline;

/// The scene kinds the pipeline shades (its renders and its `eval` views).
pub const ACCEPTS: super::scene::Accepts = super::scene::Accepts {
    pipeline: "the SH-exponentiation pipeline",
    heightfield: true,
    sphere_lights: false,
    sg_environment: true,
    sh_environment: true,
    planes: false,
    meshes: true,
};

/// `lobefit render shexp`.
pub const PIPELINE: Pipeline = Pipeline {
    name: "shexp",
    about: "Ren et al. 2006 / Giraud 2015: height field and spheres under an SH sky, SH-exponentiation shadows (docs/shexp-render.md)",
    scenes: &["whale", "whale-diffuse", "wrecking"],
    files: &[
        ("whale", include_str!("scenes/whale.json")),
        ("whale-diffuse", include_str!("scenes/whale-diffuse.json")),
        ("wrecking", include_str!("scenes/wrecking.json")),
        ("swim", include_str!("scenes/swim.json")),
    ],
    render: render::render,
    eval: &[super::EvalView {
        name: "shexp-shade",
        help: eval::EVAL_HELP,
        flags: eval::FLAGS,
        view: eval::view,
    }],
    plots: &[],
    truth: super::Truth::MonteCarlo(super::MonteCarlo {
        accepts: ACCEPTS,
        load: render::scene,
        // The reference and the SH-ideal render; in the breakdown those two and SH-ideal at
        // each higher order.
        references: (2, 2 + render::HIGHER_ORDERS.len() as u64),
        precise_factor: render::PRECISE_FACTOR as u64,
    }),
    animate: Some(render::animate),
    animations: &["swim"],
    pareto: Some(crate::baselines::SHEXP),
};

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use lobefit_tables::glam::DVec3;

    use lobefit_core::sh::legendre;

    use super::shade::{radiance, sh_value, Settings, Tables};
    use super::*;
    use crate::scene::{parse, Hit, Scene};
    use crate::sky::Phong;

    /// A scene with the whale's sky, `spheres` and `heightfield` (JSON), diffuse.
    fn scene_with(spheres: &str, heightfield: Option<&str>) -> Scene {
        let whale: serde_json::Value = serde_json::from_str(PIPELINE.file("whale").unwrap()).unwrap();
        let hf = heightfield.map_or(String::new(), |h| format!(",\"heightfield\":{h}"));
        let text = format!(
            "{{\"version\":1,\"environment\":{},\"spheres\":{spheres},\"brdf\":{{\"lambert\":{{\"albedo\":1.0}}}}{hf}}}",
            whale["environment"]
        );
        parse("test", &text).unwrap()
    }

    fn hit(x: DVec3, n: DVec3) -> Hit {
        Hit {
            x,
            n,
            t: n.any_orthonormal_vector(),
            wo: n,
            sphere: None,
            mesh: None,
            material: 0,
        }
    }

    /// ∫ L₄(ω) max(n·ω, 0)/π dω by Funk–Hecke, with 2π ∫₀¹ t P_l(t) dt by Simpson's rule
    /// (exact for these polynomials) and P_l by its recurrence
    /// ([`lobefit_core::sh::legendre`]): independent of the SH routines but for the
    /// light's coefficients.
    fn diffuse_closed_form(light: &[f64], n: DVec3) -> f64 {
        let order = (light.len() as f64).sqrt() as usize;
        let steps = 2000;
        let mut total = 0.0;
        for l in 0..order {
            let h = 1.0 / steps as f64;
            let f = |t: f64| t * legendre(l, t);
            let simpson: f64 = (0..steps)
                .map(|k| {
                    let a = k as f64 * h;
                    h / 6.0 * (f(a) + 4.0 * f(a + h / 2.0) + f(a + h))
                })
                .sum();
            let kernel = 2.0 * PI * simpson / PI;
            // The band's part of L₄ at n: Σ_m L_lm y_lm(n) = (L₄ restricted to band l)(n).
            let mut band = vec![0.0; light.len()];
            band[l * l..(l + 1) * (l + 1)].copy_from_slice(&light[l * l..(l + 1) * (l + 1)]);
            total += kernel * sh_value(&band, n);
        }
        total
    }

    /// The SH-ideal render (the shared estimator with the light at order 4) at an
    /// unoccluded Lambertian point equals the closed form within 4 standard errors.
    #[test]
    fn sh_ideal_matches_funk_hecke() {
        let scene = scene_with("[]", None);
        let light = light_sh(&scene, 4).unwrap();
        let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
        for n in [
            DVec3::Z,
            DVec3::new(0.6, 0.0, 0.8),
            DVec3::new(-0.3, 0.5, 0.81).normalize(),
        ] {
            let h = hit(DVec3::ZERO, n);
            let e = reference(&scene, |w| sh_value(&light, w), &brdf, &h, 40_000, 11);
            let want = diffuse_closed_form(&light, n);
            assert!(
                (e.mean - want).abs() < 4.0 * e.std_error && e.std_error < 0.01 * want,
                "n {n}: {e:?} vs {want}"
            );
        }
    }

    /// Without blockers the pipeline's only approximation is the log-space diffuse lobe
    /// (HYB of the ε-floored log of max(cos, 0)/π, ε = 0.01, turned to the normal):
    /// within 8 % of the closed form at order 4 (measured: −2.5 %, +0.7 %, −6.2 % at
    /// the three normals — the lobe's bands 2–3 are off, which a light away from the
    /// normal sees).
    #[test]
    fn unoccluded_pipeline_against_funk_hecke() {
        let scene = scene_with("[]", None);
        let light = light_sh(&scene, 4).unwrap();
        let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
        let t = Tables::embedded().unwrap();
        for n in [
            DVec3::Z,
            DVec3::new(0.6, 0.0, 0.8),
            DVec3::new(-0.3, 0.5, 0.81).normalize(),
        ] {
            let h = hit(DVec3::ZERO, n);
            let p = radiance(&t, &Settings::default(), &light, &brdf, &scene, &h).unwrap();
            let want = diffuse_closed_form(&light, n);
            assert!((p / want - 1.0).abs() < 0.08, "n {n}: {p} vs {want}");
        }
    }

    /// One SG at the normal, sharpness 1e2 … 1e6, Lambert albedo 1, no blocker, order 4,
    /// against the closed form (1/π) ∫ e^{λ(t−1)} t dω = 2 (1/λ − (1 − e^{−λ})/λ²). The
    /// SH-ideal shading of the projected light tends to the order-4 Lambert's point-light
    /// limit Σ_{l<4} Â_l (2l+1)/4π = (1 + 2 + 5/4 + 0)/4 = 1.0625 of it (measured 1.0588 at
    /// λ = 100, 1.0621–1.0625 above); the pipeline adds its log-space lobe's error
    /// (measured 1.149–1.158). A quadrature of the SG in t missed the peak: 1.5e-20
    /// instead of 4.0e-4 at λ = 5000.
    #[test]
    fn sharp_sgs_keep_their_energy() {
        let t = Tables::embedded().unwrap();
        for lambda in [1e2f64, 1e3, 5e3, 1e4, 1e5, 1e6] {
            let text = format!(
                "{{\"version\":1,\"environment\":{{\"sgs\":[{{\"axis\":[0,0,1],\"sharpness\":{lambda},\"amplitude\":1}}]}},\
                 \"spheres\":[],\"brdf\":{{\"lambert\":{{\"albedo\":1.0}}}}}}"
            );
            let scene = parse("sharp", &text).unwrap();
            let light = light_sh(&scene, 4).unwrap();
            let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
            let h = hit(DVec3::ZERO, DVec3::Z);
            let p = radiance(&t, &Settings::default(), &light, &brdf, &scene, &h).unwrap();
            let want = 2.0 * (1.0 / lambda - (-(-lambda).exp_m1()) / (lambda * lambda));
            let ideal = diffuse_closed_form(&light, DVec3::Z) / want;
            if lambda >= 1e3 {
                assert!((ideal - 1.0625).abs() < 1e-3, "λ {lambda}: SH-ideal/exact {ideal}");
            }
            assert!((1.0..1.2).contains(&(p / want)), "λ {lambda}: {p:e} vs {want:e}");
        }
    }

    /// The two-cap intersection's closed form against a one-dimensional quadrature of
    /// its own (cap a about +z, the azimuths inside cap b per polar angle, 200 000
    /// midpoints in cos θ): within 1e-6 of cap a's area, for crossing, containing
    /// and disjoint caps; symmetric in the caps.
    #[test]
    fn cap_overlap_matches_quadrature() {
        use super::shade::cap_overlap;
        let direct = |a: f64, b: f64, g: f64| {
            let m = 200_000;
            let (ca, (sg, cg)) = (a.cos(), g.sin_cos());
            (0..m)
                .map(|k| {
                    let z = ca + (1.0 - ca) * (k as f64 + 0.5) / m as f64;
                    let s = (1.0 - z * z).sqrt();
                    let c = if s * sg > 0.0 {
                        (b.cos() - z * cg) / (s * sg)
                    } else if z * cg >= b.cos() {
                        -1.0
                    } else {
                        1.0
                    };
                    2.0 * c.clamp(-1.0, 1.0).acos()
                })
                .sum::<f64>()
                * (1.0 - ca)
                / m as f64
        };
        for (a, b, g) in [
            (0.5, 0.5, 0.6),
            (0.3, 0.7, 0.5),
            (1.2, 0.4, 1.3),
            (0.2, 0.25, 0.1),
            (0.7, 0.2, 0.3),
            (0.4, 0.4, 0.81),
            (1.5, 1.5, 0.2),
            (0.05, 0.06, 0.02),
        ] {
            let area = std::f64::consts::TAU * (1.0 - f64::cos(a));
            let (want, got) = (direct(a, b, g), cap_overlap(a, b, g));
            assert!((got - want).abs() < 1e-6 * area, "{a} {b} {g}: {got} against {want}");
            assert!((cap_overlap(b, a, g) - got).abs() < 1e-12, "{a} {b} {g}: not symmetric");
        }
    }

    /// [`shade::project_term_on_caps`], the exact caps' rule: a cap about the normal
    /// (zonal: each band's m = 0 coefficient 2π ∫ f(z) Y_l0(z) dz over the cap, by
    /// adaptive quadrature; the others 0) within 1e-12 for the diffuse term and Phong
    /// 3 and 5 (polynomials: the rule is exact), and 1e-4 for Phong 2.5; tilted caps,
    /// one crossing the horizon, and the union of two overlapping caps against a fine
    /// rule over the whole sphere with the caps' indicator, within 2e-3 of the largest
    /// coefficient (measured 2.0e-4 to 1.0e-3: the fine rule's own error at the caps'
    /// edges, as the single tilted caps, where the caps' rule is exact, show).
    #[test]
    fn exact_caps_rule_matches_quadrature() {
        use super::shade::{project_term_on_caps, Term};
        use lobefit_core::quad::gauss_kronrod;
        use lobefit_core::sh::SphereRule;
        use std::f64::consts::TAU;
        let n = 4;
        let z = DVec3::Z;
        for term in [
            Term::Diffuse,
            Term::Specular(0.3, 3.0, z),
            Term::Specular(0.3, 5.0, z),
            Term::Specular(0.3, 2.5, z),
        ] {
            let tol = match term {
                Term::Specular(_, r, _) if r.fract() != 0.0 => 1e-4,
                _ => 1e-12,
            };
            for theta in [0.05, 0.4, 1.2] {
                let got = project_term_on_caps(term, z, &[(z, theta)], n);
                for l in 0..n {
                    let k = (2 * l + 1) as f64 / (4.0 * PI);
                    let q = gauss_kronrod(
                        |c| {
                            TAU * term.eval(z, DVec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c))
                                * k.sqrt()
                                * legendre(l, c)
                        },
                        theta.cos(),
                        1.0,
                        &[],
                        1e-15,
                        1e-13,
                        200,
                    );
                    for m in 0..2 * l + 1 {
                        let i = l * l + m;
                        let want = if m == l { q.value } else { 0.0 };
                        assert!(
                            (got[i] - want).abs() < tol * got[0].abs(),
                            "{term:?} θ {theta} ({l}, {m}): {} against {want}",
                            got[i]
                        );
                    }
                }
            }
        }
        let rule = SphereRule::new(400, 800);
        // The largest coefficient error against the fine rule over the sphere with the
        // union's indicator, over the fine rule's largest coefficient.
        let misfit = |term: Term, caps: &[(DVec3, f64)]| {
            let got = project_term_on_caps(term, z, caps, n);
            let want = rule.project(n, |w| {
                let w = DVec3::from_array(w);
                if caps.iter().any(|&(a, t)| a.dot(w) > t.cos()) {
                    term.eval(z, w)
                } else {
                    0.0
                }
            });
            let peak = want.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let worst = got.iter().zip(&want).map(|(g, w)| (g - w).abs()).fold(0.0, f64::max);
            (worst / peak, got, want)
        };
        let tilt = |a: f64| DVec3::new(a.sin(), 0.0, a.cos());
        let m = DVec3::new(-0.3, 0.2, 0.93).normalize();
        for (term, caps) in [
            (Term::Diffuse, vec![(tilt(0.7), 0.3)]),
            (Term::Diffuse, vec![(tilt(1.5), 0.3)]),
            (Term::Specular(0.3, 3.0, m), vec![(tilt(0.4), 0.25)]),
            (Term::Diffuse, vec![(tilt(0.6), 0.3), (tilt(0.9), 0.25)]),
            (Term::Specular(0.3, 3.0, m), vec![(tilt(-0.2), 0.3), (tilt(0.1), 0.2)]),
        ] {
            let (rel, got, want) = misfit(term, &caps);
            assert!(rel < 2e-3, "{term:?} {caps:?}: {got:?} against {want:?}");
        }
        // Random unions of 2–5 overlapping caps (arcs that run past the azimuth's 2π
        // among them) under each term, the log lobe's own function included, against
        // the fine rule: within 4e-3 of the peak (measured up to 2.5e-3, the fine
        // rule's own error at small caps' edges; with the wrapping arcs mishandled
        // four of the forty erred 6.8e-3 to 0.28). The cases come from this LCG, not
        // `lobefit_core::rng::Rng`: SplitMix's forty put one case at 3.9e-3 and only
        // one past the limit with the wrap mishandled.
        let mut rng = 0x5eed_u64;
        let mut next = || {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        for k in 0..40 {
            let centre = tilt(0.2 + 0.9 * next());
            let caps: Vec<(DVec3, f64)> = (0..2 + k % 4)
                .map(|_| {
                    let off = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 0.6;
                    ((centre + off).normalize(), 0.1 + 0.3 * next())
                })
                .collect();
            let term = match k % 3 {
                0 => Term::Diffuse,
                1 => Term::Specular(0.3, 3.0, m),
                _ => Term::Lobe(3.0, m),
            };
            let (rel, got, want) = misfit(term, &caps);
            assert!(rel < 4e-3, "{k}: {term:?} {caps:?}: {got:?} against {want:?}");
        }
    }

    /// The pipeline as the control variate leaves the estimate unbiased: a Phong point
    /// under the whale's sky with a blocker towards the sun, both BRDF modes (the log
    /// lobes, the Gaunt triple product): the hybrid's mean over 64 scrambles of 4096
    /// QMC samples lies within 4 standard errors of plain Monte Carlo's 4 000 000-sample
    /// mean, while the pipeline alone lies outside it; an integrand whose integral were
    /// 1 % off its value fails.
    #[test]
    fn hybrid_is_unbiased_where_the_pipeline_is_not() {
        use crate::estimate::Sampling;
        use crate::sky::reference_hybrid;
        let sun = DVec3::new(0.5, -0.35, 0.79).normalize() * 2.0;
        let scene = scene_with(
            &format!(
                "[{{\"centre\":[{},{},{}],\"radius\":0.5,\"material\":{{\"lambert\":{{\"albedo\":0.5}}}}}}]",
                sun.x + 0.3,
                sun.y,
                sun.z
            ),
            None,
        );
        let brdf = Phong {
            diffuse: 0.5,
            specular: 0.4,
            exponent: 20.0,
            microfacet: None,
        };
        let h = Hit {
            wo: DVec3::new(-0.4, 0.3, 0.866).normalize(),
            ..hit(DVec3::ZERO, DVec3::Z)
        };
        let l = |w| light(&scene, w);
        let want = reference(&scene, l, &brdf, &h, 4_000_000, 3);
        let t = Tables::embedded().unwrap();
        for mode in [shade::BrdfMode::Log, shade::BrdfMode::Triple] {
            let s = Settings {
                brdf: mode,
                ..Settings::default()
            };
            let sh = light_sh(&scene, s.order).unwrap();
            let a = shade::integrand(&t, &s, &sh, &brdf, &scene, &h).unwrap();
            let run = |offset: f64| {
                let v: Vec<f64> = (0..64)
                    .map(|k| {
                        reference_hybrid(
                            Sampling::Qmc,
                            &scene.environment,
                            l,
                            &brdf,
                            |v| scene.occluded(&h, v),
                            &h,
                            4096,
                            1000 + k,
                            a.value * offset,
                            |w| l(w) * a.eval(w),
                        )
                        .mean
                    })
                    .collect();
                let m = v.iter().sum::<f64>() / v.len() as f64;
                let se = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / ((v.len() - 1) * v.len()) as f64).sqrt();
                (m, 4.0 * (se * se + want.std_error * want.std_error).sqrt())
            };
            let (m, tol) = run(1.0);
            assert!(
                (m - want.mean).abs() < tol,
                "{mode:?}: hybrid {m} ± {tol} vs plain {want:?}"
            );
            assert!(
                (a.value - want.mean).abs() > tol,
                "{mode:?}: the pipeline {} is already within {tol} of {want:?}",
                a.value
            );
            let (m, tol) = run(1.01);
            assert!(
                (m - want.mean).abs() > tol,
                "{mode:?}: a 1 % offset passes: {m} ± {tol}"
            );
        }
    }

    /// N coincident copies of one blocker (the exact radiance does not depend on N):
    /// accepted while exp* stays in range, refused naming the mean visibility beyond it
    /// (order 4 from N = 30, orders 6 and 8 by N = 200), never an answer more than 1.5×
    /// off the exact one. Before: 36.2 at N = 200 and 5.7e9 at N = 1000 against 1.00.
    #[test]
    fn coincident_blockers_are_refused_beyond_exps_range() {
        let sun = DVec3::new(0.5, -0.35, 0.79).normalize() * 2.0;
        let one = format!(
            "{{\"centre\":[{},{},{}],\"radius\":0.8,\"material\":{{\"lambert\":{{\"albedo\":0.5}}}}}}",
            sun.x, sun.y, sun.z
        );
        let t = Tables::embedded().unwrap();
        let h = hit(DVec3::ZERO, DVec3::Z);
        let exact = {
            let scene = scene_with(&format!("[{one}]"), None);
            let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
            reference(&scene, |w| light(&scene, w), &brdf, &h, 40_000, 3)
        };
        for order in [4, 6, 8] {
            for n in [1, 3, 10, 30, 100, 200, 1000] {
                let scene = scene_with(&format!("[{}]", vec![one.as_str(); n].join(",")), None);
                let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
                let s = Settings {
                    order,
                    ..Settings::default()
                };
                let got = radiance(&t, &s, &light_sh(&scene, order).unwrap(), &brdf, &scene, &h);
                match got {
                    Ok(v) => {
                        assert!(n < 200 && (order > 4 || n < 30), "order {order} N {n}: accepted {v}");
                        assert!(
                            (v / exact.mean - 1.0).abs() < 0.5,
                            "order {order} N {n}: {v} vs {exact:?}"
                        );
                    }
                    Err(e) => {
                        assert!(n >= 30 && e.contains("mean visibility"), "order {order} N {n}: {e}");
                    }
                }
            }
        }
    }

    /// The fits-on-sums candidates: at their neutral values (rates 0, band factors 1)
    /// the very bits of the defaults at a shadowed point; other values change the
    /// answer; rates or factors that are not finite, or a negative factor, are refused
    /// by name, and a log vector of an order HYB has no threshold for is an error, not
    /// a panic.
    #[test]
    fn fits_on_sums_are_neutral_at_their_identity_and_checked() {
        use super::shade::{exponentiate, Exp};
        let sun = DVec3::new(0.5, -0.35, 0.79).normalize() * 2.0;
        let ball = |c: DVec3, r: f64| {
            format!(
                "{{\"centre\":[{},{},{}],\"radius\":{r},\"material\":{{\"lambert\":{{\"albedo\":0.5}}}}}}",
                c.x, c.y, c.z
            )
        };
        let scene = scene_with(
            &format!("[{},{}]", ball(sun, 0.5), ball(sun + DVec3::new(0.6, 0.2, 0.1), 0.4)),
            None,
        );
        let t = Tables::embedded().unwrap();
        let h = hit(DVec3::ZERO, DVec3::Z);
        let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
        let l = light_sh(&scene, 4).unwrap();
        let d = Settings::default();
        let at = |s: Settings| radiance(&t, &s, &l, &brdf, &scene, &h).unwrap();
        let base = at(d);
        let neutral = [
            Settings {
                exp: Exp::HybScaled { dc: 0.0, hat: 0.0 },
                ..d
            },
            Settings {
                blocker_bands: [1.0; 8],
                ..d
            },
        ];
        for s in neutral {
            assert_eq!(at(s).to_bits(), base.to_bits(), "{s:?}");
        }
        let moved = [
            Settings {
                exp: Exp::HybScaled { dc: 0.0, hat: -0.154 },
                ..d
            },
            Settings {
                blocker_bands: [2.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
                ..d
            },
        ];
        for s in moved {
            assert!((at(s) - base).abs() > 1e-6 * base, "{s:?}: {} vs {base}", at(s));
        }
        let mut bad = [1.0; 8];
        bad[2] = f64::NAN;
        let bad_settings = [
            (
                Settings {
                    blocker_bands: bad,
                    ..d
                },
                "band 2",
            ),
            (
                Settings {
                    blocker_bands: [1.0, -0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
                    ..d
                },
                "band 1",
            ),
            (
                Settings {
                    exp: Exp::HybScaled {
                        dc: f64::INFINITY,
                        hat: 0.0,
                    },
                    ..d
                },
                "rates",
            ),
        ];
        for (s, what) in bad_settings {
            let e = s.validate().unwrap_err();
            assert!(e.contains(what), "{e}");
        }
        let e = exponentiate(&t, Exp::HybScaled { dc: 0.0, hat: 0.0 }, &[0.1; 4]).unwrap_err();
        assert!(e.contains("order"), "{e}");
    }

    /// One sphere blocker (angular radius 23.6°) between the point and the sun: the
    /// pipeline at its defaults against the SH-ideal render (exact visibility) within
    /// 10 % of the unoccluded radiance (measured: 8.6 %, attenuation under-darkens a
    /// near blocker; mirrored 1.4 %), and the blocker on the sun's side at least 10 %
    /// darker than mirrored away from it (measured 13 %; the SH-ideal 23 %): a wrongly
    /// turned blocker fails.
    #[test]
    fn one_blocker_against_exact_visibility() {
        let sun = DVec3::new(0.5, -0.35, 0.79).normalize();
        let t = Tables::embedded().unwrap();
        let mut got = Vec::new();
        for side in [1.0, -1.0] {
            let c = DVec3::new(side * sun.x, side * sun.y, sun.z) * 2.0;
            let scene = scene_with(
                &format!(
                    "[{{\"centre\":[{},{},{}],\"radius\":0.8,\"material\":{{\"lambert\":{{\"albedo\":0.5}}}}}}]",
                    c.x, c.y, c.z
                ),
                None,
            );
            let light = light_sh(&scene, 4).unwrap();
            let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
            let h = hit(DVec3::ZERO, DVec3::Z);
            let p = radiance(&t, &Settings::default(), &light, &brdf, &scene, &h).unwrap();
            let e = reference(&scene, |w| sh_value(&light, w), &brdf, &h, 40_000, 5);
            got.push((p, e.mean));
        }
        let open = diffuse_closed_form(&light_sh(&scene_with("[]", None), 4).unwrap(), DVec3::Z);
        for (p, ideal) in &got {
            assert!((p - ideal).abs() < 0.10 * open, "{got:?}, open {open}");
        }
        assert!(got[1].0 - got[0].0 > 0.10 * open, "{got:?}, open {open}");
    }

    /// A height field with a wall on the sun's side (x > 0.5 rises to 3, a horizon of
    /// 80°), the pipeline at the foot of the wall with ε = 0.1 for the terrain (the
    /// default 0.5, chosen on the shipped gentle terrain, under-darkens a wall: 1.24 vs
    /// 0.79): against the SH-ideal render within 8 % of the unoccluded radiance
    /// (measured: 1.6 % on the sun's side, 6.0 % with the wall opposite), and the
    /// sun-side wall at least 25 % darker (measured 34 %): the wedges' frame.
    #[test]
    fn terrain_wall_against_exact_visibility() {
        let t = Tables::embedded().unwrap();
        let n = 33;
        let settings = Settings {
            eps_terrain: 0.1,
            ..Settings::default()
        };
        let mut got = Vec::new();
        for side in [1.0, -1.0] {
            let heights: Vec<String> = (0..n * n)
                .map(|k| {
                    let x = -4.0 + 8.0 * (k % n) as f64 / (n - 1) as f64;
                    format!("{}", if side * x > 0.5 { 3.0 } else { 0.0 })
                })
                .collect();
            let hf = format!(
                "{{\"size\":{n},\"extent\":8.0,\"heights\":[{}],\"material\":{{\"lambert\":{{\"albedo\":0.5}}}}}}",
                heights.join(",")
            );
            let scene = scene_with("[]", Some(&hf));
            let light = light_sh(&scene, 4).unwrap();
            let brdf = Phong::of(scene.brdf.as_ref().unwrap()).unwrap();
            let h = hit(DVec3::ZERO, DVec3::Z);
            let p = radiance(&t, &settings, &light, &brdf, &scene, &h).unwrap();
            let e = reference(&scene, |w| sh_value(&light, w), &brdf, &h, 40_000, 5);
            got.push((p, e.mean));
        }
        let open = diffuse_closed_form(&light_sh(&scene_with("[]", None), 4).unwrap(), DVec3::Z);
        for (p, ideal) in &got {
            assert!((p - ideal).abs() < 0.08 * open, "{got:?}, open {open}");
        }
        assert!(got[1].0 - got[0].0 > 0.25 * open, "{got:?}, open {open}");
    }

    /// A scene whose light is given as SH coefficients (`sh_environment`, the whale's
    /// sky projected to order 4) shades and references exactly as the SG scene's
    /// band-limited light: the same pipeline radiance, and the reference with the SH
    /// light equal to the SG scene's SH-ideal render sample for sample.
    #[test]
    fn an_sh_environment_is_the_projected_light() {
        let sgs = scene_with("[]", None);
        let light = light_sh(&sgs, 4).unwrap();
        let coefficients: Vec<String> = light.iter().map(|c| format!("{c:e}")).collect();
        let text = format!(
            "{{\"version\":1,\"sh_environment\":{{\"order\":4,\"coefficients\":[{}]}},\"brdf\":{{\"lambert\":{{\"albedo\":1.0}}}}}}",
            coefficients.join(",")
        );
        let sh = parse("sh", &text).unwrap();
        assert_eq!(light_sh(&sh, 4).unwrap(), light);
        let brdf = Phong::of(sh.brdf.as_ref().unwrap()).unwrap();
        let t = Tables::embedded().unwrap();
        let h = hit(DVec3::ZERO, DVec3::new(0.6, 0.0, 0.8));
        let a = radiance(&t, &Settings::default(), &light_sh(&sh, 4).unwrap(), &brdf, &sh, &h).unwrap();
        let b = radiance(&t, &Settings::default(), &light, &brdf, &sgs, &h).unwrap();
        assert_eq!(a, b);
        let ra = reference(&sh, |w| super::light(&sh, w), &brdf, &h, 2000, 3);
        let rb = crate::sky::reference_with(&[], |w| sh_value(&light, w), &brdf, |_| false, &h, 2000, 3);
        assert_eq!(ra.mean, rb.mean);
        // Truncated to order 3 and padded to 5.
        assert_eq!(light_sh(&sh, 3).unwrap(), light[..9].to_vec());
        assert_eq!(light_sh(&sh, 5).unwrap()[..16], light[..]);
        assert!(light_sh(&sh, 5).unwrap()[16..].iter().all(|&c| c == 0.0));
    }

    /// The sphere hierarchy in SH exponentiation (docs/meshes.md, "A sphere
    /// hierarchy"): `shade(hit, None)` with the flat set, `Some(theta)` through the cut.
    fn cut_shade<'a>(
        t: &'a Tables,
        scene: &'a Scene,
        light: &'a [f64],
    ) -> impl Fn(&Hit, Option<f64>) -> Result<f64, String> + Sync + 'a {
        move |h: &Hit, theta: Option<f64>| {
            let s = Settings {
                cut: theta.unwrap_or(0.0),
                ..Settings::default()
            };
            radiance(t, &s, light, &Phong::of(scene.brdf(h))?, scene, h)
        }
    }

    /// At an angle of 1e-9° the cut is the flat set: every pixel of the whale (50
    /// spheres) equals the flat pipeline's to 1e-12 of the mean (the blockers' order
    /// differs); at 10° it differs, by less than the pipeline's own error against the
    /// reference. At 90°, the documented limit, every pixel shades (a stand-in holding a
    /// terrain point is skipped there; it was an error) within the reference's range.
    #[test]
    fn the_cut_at_zero_is_the_flat_pipeline() {
        let scene = super::render::scene("whale").unwrap();
        let t = Tables::embedded().unwrap();
        let light = light_sh(&scene, Settings::default().order).unwrap();
        let shade = cut_shade(&t, &scene, &light);
        let s =
            crate::isg::lod::lod_study_with(&scene, 16, &[1e-9, 10.0, 90.0], 1, 256, 8, "SH exponentiation", &shade)
                .unwrap();
        assert!(s.rows[1].vs_flat.1 < 1e-12, "{}", s.table());
        assert!(s.rows[2].vs_flat.0 > 0.0, "{}", s.table());
        assert!(s.rows[2].vs_flat.0 < s.rows[0].vs_reference, "{}", s.table());
        assert!(
            s.rows[3].vs_flat.1.is_finite() && s.rows[3].vs_reference < 1.0,
            "{}",
            s.table()
        );
    }

    /// The study at full size (docs/meshes.md, "In SH exponentiation"): the bunny over
    /// the whale's terrain with 1 024 `optimize` spheres of overlap ≤ 1.2. `LF_WIDTH`
    /// (default 96), `LF_SPP` (default 4096).
    #[test]
    #[ignore = "study: minutes; docs/meshes.md"]
    fn cut_study_full() {
        let width = crate::env_or("LF_WIDTH", 96usize);
        let spp = crate::env_or("LF_SPP", 4096usize);
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/shexp-bunny.json");
        let text = std::fs::read_to_string(&path).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["meshes"][0]["spheres"] =
            serde_json::json!({"count": 1024, "method": "optimize", "seed": 1, "max_overlap": 1.2});
        let t0 = std::time::Instant::now();
        let scene = crate::scene::parse_in("shexp-bunny-1024", &v.to_string(), path.parent().unwrap()).unwrap();
        println!("scene and fit {:.1} s", t0.elapsed().as_secs_f64());
        let t = Tables::embedded().unwrap();
        let light = light_sh(&scene, Settings::default().order).unwrap();
        let shade = cut_shade(&t, &scene, &light);
        let s = crate::isg::lod::lod_study_with(
            &scene,
            width,
            &[1.0, 2.0, 5.0, 10.0, 20.0],
            3,
            spp,
            4,
            "SH exponentiation",
            &shade,
        )
        .unwrap();
        println!("{}", s.table());
    }
}
