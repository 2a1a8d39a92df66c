//! BRDFs that are not SGs as SG sums, fitted per view: the Ashikhmin–Shirley term's
//! f_s(ω, ω_o)·cos θ as J SGs in ω (Xu et al. 2013 fit it so: 7 SGs, 2.0 % L2). The fit
//! is the map fitter's (`envmap`): the function sampled on an equirectangular grid in
//! the local frame (z the normal, x the tangent; 0 below the surface), greedy starts at
//! its residual's peaks, then Levenberg–Marquardt on axes, sharpness and amplitudes
//! (≥ 0). Its error is measured by [`l2_error`], a finer quadrature of the term's own
//! definition, not by the fit's objective.

use std::f64::consts::{PI, TAU};

use lobefit_tables::glam::DVec3;
use lobefit_tables::isg::Sg;
use lobefit_tables::microfacet::AshikhminShirley;

use crate::envmap::{greedy, levenberg_marquardt, EnvMap, RgbSg};

/// f_s·cos of `brdf` towards local unit `wi` for the local view `wo`.
fn target(brdf: &AshikhminShirley, wo: DVec3, wi: DVec3) -> f64 {
    brdf.value_local(wo, wi) * wi.z.max(0.0)
}

/// `count` SGs (local frame) fitted to f_s·cos of `brdf` at the local unit view `wo`,
/// on a grid of 2`rows` × `rows` texels over the sphere. The grid's frame puts the
/// mirror direction on its equator: the fitter's axes are (θ, φ), singular at a pole,
/// where the normal view's lobe would sit (3.5 % L2 with 7 SGs there, 1.7 % so).
pub fn fit_view(brdf: &AshikhminShirley, wo: DVec3, count: usize, rows: usize) -> Result<Vec<Sg>, String> {
    let width = 2 * rows;
    let r = DVec3::new(-wo.x, -wo.y, wo.z).normalize();
    let (u, v) = r.any_orthonormal_pair();
    // Grid direction d → local r d.x + u d.y + v d.z (x, the grid's φ = 0 on its
    // equator, to r).
    let local = |d: DVec3| r * d.x + u * d.y + v * d.z;
    let mut rgb = Vec::with_capacity(width * rows);
    let probe = EnvMap::new(width, rows, vec![[0.0; 3]; width * rows])?;
    for row in 0..rows {
        for col in 0..width {
            rgb.push([target(brdf, wo, local(probe.direction(col, row))), 0.0, 0.0]);
        }
    }
    let map = EnvMap::new(width, rows, rgb)?;
    // Two starts, the better fit on the grid kept: every lobe at once from the greedy
    // peaks, and lobe by lobe (each count from the last one's fit plus a lobe at the
    // residual's peak). Each alone stalls in local minima at some views (7 SGs at
    // 75°, 90° from the tangent: 24 % at once, 11 % lobe by lobe).
    let (at_once, _, e_once) = levenberg_marquardt(&map, greedy(&map, count));
    let (mut by_lobe, mut e_lobe) = (Vec::<RgbSg>::new(), f64::INFINITY);
    for _ in 0..count {
        let mut residual = map.clone();
        for (k, c) in residual.rgb.iter_mut().enumerate() {
            let d = map.direction(k % width, k / width);
            c[0] -= by_lobe.iter().map(|l| l.value(d)[0]).sum::<f64>();
        }
        by_lobe.extend(greedy(&residual, 1));
        (by_lobe, _, e_lobe) = levenberg_marquardt(&map, by_lobe);
    }
    let lobes = if e_lobe < e_once { by_lobe } else { at_once };
    lobes
        .iter()
        .filter(|l| l.amplitude[0] > 0.0)
        .map(|l| Sg::new(local(DVec3::from(l.axis)), l.sharpness, l.amplitude[0]).map_err(|e| e.to_string()))
        .collect()
}

/// The relative L2 error of `sgs` against f_s·cos of `brdf` at view `wo` over the upper
/// hemisphere, √(∫ (Σ G − f)² dω / ∫ f² dω), by a midpoint rule of `nt` × 2`nt`
/// nodes in (θ, φ) about the normal.
pub fn l2_error(brdf: &AshikhminShirley, wo: DVec3, sgs: &[Sg], nt: usize) -> f64 {
    let np = 2 * nt;
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..nt {
        let th = PI / 2.0 * (i as f64 + 0.5) / nt as f64;
        let w = th.sin() * (PI / 2.0 / nt as f64) * (TAU / np as f64);
        for j in 0..np {
            let ph = TAU * (j as f64 + 0.5) / np as f64;
            let d = DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            let f = target(brdf, wo, d);
            let g: f64 = sgs.iter().map(|s| s.eval(d)).sum();
            num += (g - f) * (g - f) * w;
            den += f * f * w;
        }
    }
    (num / den.max(f64::MIN_POSITIVE)).sqrt()
}

/// The local view at elevation `theta` and azimuth `phi` (rad) from the tangent.
pub fn view(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An anisotropic term (n_u 100, n_v 10) at a 40° view, 45° from the tangent:
    /// seven SGs fit it far closer than one, measured by quadrature of the definition
    /// (1 600 × 3 200 nodes), and at Xu et al.'s 2.0 % on this small grid (measured:
    /// 1 SG 0.45, 7 SGs 0.016).
    #[test]
    fn seven_sgs_fit_an_anisotropic_term() {
        let brdf = AshikhminShirley::new(0.5, 100.0, 10.0).unwrap();
        let wo = view(40f64.to_radians(), 45f64.to_radians());
        let e1 = l2_error(&brdf, wo, &fit_view(&brdf, wo, 1, 64).unwrap(), 1600);
        let e7 = l2_error(&brdf, wo, &fit_view(&brdf, wo, 7, 64).unwrap(), 1600);
        println!("1 SG {e1:.4}, 7 SGs {e7:.4}");
        assert!(e7 < 0.02 && e7 < 0.1 * e1, "1 SG {e1}, 7 SGs {e7}");
    }

    /// Issue 58's measure: Ashikhmin–Shirley (n_u 100, n_v 10, R_s 0.5) with 1, 3, 5
    /// and 7 SGs per view, the relative L2 of f_s·cos over the upper hemisphere
    /// (quadrature of the definition) at views 0°, 30°, 60°, 75° in elevation and 0°,
    /// 45°, 90° from the tangent: per count the median and max over the views up to
    /// 60°, and the 75° views apart (docs/environment.md). `scripts/studies.sh`.
    #[test]
    #[ignore = "study (about 4 minutes): scripts/studies.sh"]
    fn ashikhmin_shirley_study() {
        let brdf = AshikhminShirley::new(0.5, 100.0, 10.0).unwrap();
        println!("Ashikhmin–Shirley n_u 100, n_v 10, R_s 0.5; relative L2 of f_s·cos by SG count");
        for count in [1, 3, 5, 7] {
            let (mut low, mut grazing) = (Vec::new(), Vec::new());
            for th in [0.0, 30.0, 60.0, 75.0f64] {
                for ph in [0.0, 45.0, 90.0f64] {
                    let wo = view(th.to_radians(), ph.to_radians());
                    let e = l2_error(&brdf, wo, &fit_view(&brdf, wo, count, 128).unwrap(), 1000);
                    if th < 70.0 {
                        low.push(e)
                    } else {
                        grazing.push(e)
                    }
                }
            }
            low.sort_by(f64::total_cmp);
            println!(
                "  {count} SGs: views 0-60°: median {:.4}, max {:.4}; 75°: {:?}",
                low[low.len() / 2],
                low[low.len() - 1],
                grazing.iter().map(|e| format!("{e:.4}")).collect::<Vec<_>>()
            );
        }
    }
}
