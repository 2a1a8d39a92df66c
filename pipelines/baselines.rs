//! Equal-error comparisons of the environment reference's estimators (plain Monte
//! Carlo against scrambled Sobol), measured at each compared sample count, not
//! extrapolated from one run's variance. A study (`scripts/studies.sh`), not a check.

use crate::estimate::{per_pixel, Sampling};
use crate::scene::Scene;
use crate::sky::{reference_sampled, Phong};

/// One estimator's measured error at `spp` samples per pixel.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    /// Samples per pixel.
    pub spp: usize,
    /// Relative RMSE over the lit pixels against the precise reference, its noise
    /// removed (E[(x − r)²] − E[se_r²], over the reference's mean squared).
    pub rel_rmse: f64,
}

/// The errors of `sampling` at each of `spps` on `scene` at `width` pixels, against a
/// plain reference of `ref_spp` samples per pixel (seeded apart from the compared runs).
pub fn curve(
    scene: &Scene,
    width: usize,
    ref_spp: usize,
    spps: &[usize],
    sampling: Sampling,
) -> Result<Vec<Point>, String> {
    let (w, h) = (width, width * 3 / 4);
    let (hits, lit) = scene.primary_hits(w, h)?;
    let run = |s: Sampling, n: usize, seed: u64| {
        per_pixel(
            &hits,
            w,
            |hit, p| {
                let brdf = Phong::of(scene.brdf(hit))?;
                Ok(reference_sampled(
                    s,
                    &scene.environment,
                    |v| crate::sky::environment(&scene.environment, v),
                    &brdf,
                    |v| scene.occluded(hit, v),
                    hit,
                    n,
                    seed ^ (p as u64).wrapping_mul(0x9e37_79b9),
                ))
            },
            &|| (),
        )
    };
    let refs = run(Sampling::Plain, ref_spp, 0x00c0_ffee)?;
    let idx: Vec<usize> = (0..hits.len()).filter(|&p| lit[p]).collect();
    let mean_sq = idx.iter().map(|&p| refs[p].mean.powi(2)).sum::<f64>() / idx.len() as f64;
    let ref_var = idx.iter().map(|&p| refs[p].std_error.powi(2)).sum::<f64>() / idx.len() as f64;
    spps.iter()
        .map(|&n| {
            let est = run(sampling, n, 0x5eed_0000 + n as u64)?;
            let mse = idx.iter().map(|&p| (est[p].mean - refs[p].mean).powi(2)).sum::<f64>() / idx.len() as f64;
            Ok(Point {
                spp: n,
                rel_rmse: ((mse - ref_var).max(0.0) / mean_sq).sqrt(),
            })
        })
        .collect()
}

/// The samples `curve` (decreasing error) needs for `error`, by log–log interpolation
/// between its two measured points around it; `None` outside the measured range.
pub fn spp_at(curve: &[Point], error: f64) -> Option<f64> {
    curve.windows(2).find_map(|p| {
        let (a, b) = (p[0], p[1]);
        if !(b.rel_rmse <= error && error <= a.rel_rmse) || a.rel_rmse <= 0.0 || b.rel_rmse <= 0.0 {
            return None;
        }
        let t = (error.ln() - a.rel_rmse.ln()) / (b.rel_rmse.ln() - a.rel_rmse.ln());
        Some(((a.spp as f64).ln() + t * ((b.spp as f64).ln() - (a.spp as f64).ln())).exp())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Interpolation recovers n from a 1/√n curve exactly, and refuses to extrapolate.
    #[test]
    fn spp_at_interpolates_and_never_extrapolates() {
        let c: Vec<Point> = [4, 16, 64]
            .iter()
            .map(|&spp| Point {
                spp,
                rel_rmse: 1.0 / (spp as f64).sqrt(),
            })
            .collect();
        let n = spp_at(&c, 1.0 / 32f64.sqrt()).unwrap();
        assert!((n - 32.0).abs() < 1e-9, "{n}");
        assert!(spp_at(&c, 1.0).is_none() && spp_at(&c, 0.01).is_none());
    }

    /// The study: plain against QMC on fig12 and fig12-diffuse (run with --ignored;
    /// scripts/studies.sh). Prints each curve and QMC's sample factor at equal error.
    #[test]
    #[ignore]
    fn study_plain_vs_qmc() {
        let width: usize = std::env::var("LF_WIDTH")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(24);
        for name in ["fig12", "fig12-diffuse"] {
            let scene = crate::isg::PIPELINE.scene(name).unwrap();
            let plain = curve(&scene, width, 1 << 16, &[4, 16, 64, 256, 1024, 4096], Sampling::Plain).unwrap();
            let qmc = curve(&scene, width, 1 << 16, &[4, 16, 64, 256], Sampling::Qmc).unwrap();
            println!("{name} ({width} px wide): plain {plain:?}");
            println!("{name}: qmc {qmc:?}");
            for q in &qmc {
                match spp_at(&plain, q.rel_rmse) {
                    Some(n) => println!(
                        "  qmc {} spp = plain {n:.0} spp: {:.1}× fewer samples",
                        q.spp,
                        n / q.spp as f64
                    ),
                    None => println!(
                        "  qmc {} spp: rel RMSE {:.3e} outside plain's measured range",
                        q.spp, q.rel_rmse
                    ),
                }
            }
        }
    }
}
