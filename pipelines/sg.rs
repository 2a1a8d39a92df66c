//! Closed forms over spherical Gaussians that the scene substrate and the pipelines
//! share: an SG sum's radiance, the clamped-cosine integral ∫ G max(n·ω, 0) dω (the
//! unoccluded diffuse term of every SG sky), the cone outside which an SG is below ε
//! of its peak. They sit below `scene`, `sky`, `envmap` and the ISG pipeline, which all
//! use them, so that none of those imports another for them.

use std::f64::consts::FRAC_PI_2;

use lobefit_tables::glam::DVec3;
use lobefit_tables::isg::Sg;

/// L(ω) of the environment (radiance).
pub fn environment(env: &[Sg], w: DVec3) -> f64 {
    env.iter().map(|g| g.eval(w)).sum()
}

/// ∫ exp(λ(μ·ω − 1)) max(n·ω, 0) dω (sr) of the unit-amplitude SG `l` (its amplitude
/// ignored): the closed form (n·μ) 2π ((λ − 1) + (λ + 1) e^{−2λ})/λ² when the SG's
/// support (down to 1e-12 of its peak) lies above the horizon, else
/// 2π ∫_0^1 x exp(λ(c x − 1)) I₀(λ s √(1 − x²)) dx (c = n·μ, s = √(1 − c²)) by
/// Gauss–Legendre on panels refined around the peak x = c.
pub fn clamped_cosine_integral(l: &Sg, n: DVec3) -> f64 {
    clamped_cosine_at(l.sharpness, n.dot(l.axis).clamp(-1.0, 1.0))
}

/// [`clamped_cosine_integral`] of sharpness `lambda` at c = n·μ ∈ [−1, 1]: all it
/// depends on.
fn clamped_cosine_at(lambda: f64, c: f64) -> f64 {
    if c.acos() + cone_of(lambda, 1e-12) < FRAC_PI_2 {
        return c * std::f64::consts::TAU * ((lambda - 1.0) + (lambda + 1.0) * (-2.0 * lambda).exp())
            / (lambda * lambda);
    }
    let s = (1.0 - c * c).sqrt();
    let f = |x: f64| {
        let z = lambda * s * (1.0 - x * x).max(0.0).sqrt();
        x * (lambda * (c * x - 1.0) + z).exp() * bessel_i0e(z)
    };
    let w = (s / lambda.sqrt()).max(1e-6);
    // The panels' ends, sorted, repeats dropped (in an array: no allocation per call).
    let mut cuts = [0.0; 15];
    cuts[1] = 1.0;
    for (q, k) in [0.5, 1.0, 2.0, 4.0, 8.0, 16.0].into_iter().enumerate() {
        cuts[2 + 2 * q] = c - k * w;
        cuts[3 + 2 * q] = c + k * w;
    }
    cuts[14] = c;
    for x in &mut cuts {
        *x = x.clamp(0.0, 1.0);
    }
    cuts.sort_unstable_by(f64::total_cmp);
    let mut len = 1;
    for q in 1..cuts.len() {
        if cuts[q] != cuts[len - 1] {
            cuts[len] = cuts[q];
            len += 1;
        }
    }
    let mut sum = 0.0;
    for p in cuts[..len].windows(2) {
        let (m, h) = (0.5 * (p[0] + p[1]), 0.5 * (p[1] - p[0]));
        sum += h * GL8.iter().map(|&(a, wa)| wa * f(m + h * a)).sum::<f64>();
    }
    std::f64::consts::TAU * sum
}

/// [`clamped_cosine_integral`] through a per-thread memo of its recent values, keyed
/// by the bits of all it depends on (λ and n·μ): they recur from pixel to pixel
/// wherever the normal does — every point of a plane, fig12's floor — and its
/// quadrature near the horizon (up to 112 nodes, an exp and a Bessel function each)
/// was an eighth of fig12's pixel. Bit for bit the function.
pub(crate) fn clamped_cosine_memo(l: &Sg, n: DVec3) -> f64 {
    const SLOTS: usize = 64;
    /// A slot: the bits of (λ, n·μ) and the integral.
    type Slot = Option<((u64, u64), f64)>;
    thread_local! {
        static MEMO: std::cell::RefCell<[Slot; SLOTS]> = const { std::cell::RefCell::new([None; SLOTS]) };
    }
    let (lambda, c) = (l.sharpness, n.dot(l.axis).clamp(-1.0, 1.0));
    let key = (lambda.to_bits(), c.to_bits());
    let slot = (key.0 ^ key.1.rotate_left(29)).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 58;
    MEMO.with(|m| {
        let e = &mut m.borrow_mut()[slot as usize % SLOTS];
        match *e {
            Some((k, v)) if k == key => v,
            _ => {
                let v = clamped_cosine_at(lambda, c);
                *e = Some((key, v));
                v
            }
        }
    })
}

/// e^{−z} I₀(z) for z ≥ 0 (Abramowitz & Stegun 9.8.1–9.8.2, relative error < 2e-7).
fn bessel_i0e(z: f64) -> f64 {
    if z < 3.75 {
        let t = (z / 3.75).powi(2);
        let i0 = 1.0
            + t * (3.515_622_9
                + t * (3.089_942_4 + t * (1.206_749_2 + t * (0.265_973_2 + t * (0.036_076_8 + t * 0.004_581_3)))));
        i0 * (-z).exp()
    } else {
        let t = 3.75 / z;
        let p = 0.398_942_28
            + t * (0.013_285_92
                + t * (0.002_253_19
                    + t * (-0.001_575_65
                        + t * (0.009_162_81
                            + t * (-0.020_577_06 + t * (0.026_355_37 + t * (-0.016_476_33 + t * 0.003_923_77)))))));
        p / z.sqrt()
    }
}

/// The limiting angle (rad): where the SG of sharpness `lambda` falls to `eps` of its
/// peak, exp(λ(cos Γ − 1)) = ε, at most π/2 (the ISG's hemisphere). The same cone
/// for every model: the models' own marginal thresholds (§4.1) cost a bisection per
/// product and differ by model.
pub fn cone_of(lambda: f64, eps: f64) -> f64 {
    // 1 − cos Γ = 2 sin²(Γ/2) = −ln ε / λ: the half-angle form, as the shader computes it.
    let h = -eps.ln() / lambda;
    if h >= 1.0 {
        FRAC_PI_2
    } else {
        2.0 * (0.5 * h).sqrt().asin()
    }
}

/// 8-point Gauss–Legendre nodes and weights on [−1, 1].
pub(crate) const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_48),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_48),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The clamped-cosine integral against a brute-force midpoint quadrature over the
    /// upper hemisphere (independent), for sharpnesses 0.5 to 1000 and axes from the
    /// normal to below the horizon.
    #[test]
    fn clamped_cosine_integral_against_brute_force() {
        for lambda in [0.5, 3.0, 40.0, 1000.0] {
            for elev in [1.4, 0.6, 0.05, -0.02, -0.3] {
                let axis = DVec3::new(f64::cos(elev), 0.0, f64::sin(elev));
                let l = Sg::new(axis, lambda, 1.0).unwrap();
                let (nt, np) = (2000, 2000);
                let mut want = 0.0;
                for i in 0..nt {
                    let th = (i as f64 + 0.5) / nt as f64 * FRAC_PI_2;
                    for j in 0..np {
                        let ph = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                        let w = DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                        want += l.eval(w) * th.cos() * th.sin();
                    }
                }
                want *= FRAC_PI_2 / nt as f64 * std::f64::consts::TAU / np as f64;
                let got = clamped_cosine_integral(&l, DVec3::Z);
                assert!(
                    (got - want).abs() <= 2e-3 * want.abs() + 1e-9,
                    "λ {lambda}, elevation {elev}: {got} vs {want}"
                );
            }
        }
    }
}
