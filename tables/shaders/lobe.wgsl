// lobefit shader library: cosine lobes and spherical Gaussians (needs common.wgsl).
// A cosine lobe is s * max(a.v, 0)^e (axis a, exponent e >= 0, scale s); an SG is
// mu * exp(lambda (a.v - 1)) (axis a, sharpness lambda > 0, amplitude mu).

// Integral of max(a.v, 0)^e over the sphere (sr), closed form: 2 pi / (e + 1).
fn lf_lobe_integral(e: f32) -> f32 {
    return 2.0 * LF_PI / (e + 1.0);
}

// Cap exponent e_cap(alpha) of a cap of half-angle alpha (rad) from the exported
// `cap-exponent` texture (1D, R: q on logit(alpha)); 0 for alpha >= pi/2.
fn lf_cap_exponent(tex: texture_2d<f32>, smp: sampler, p: LfTex, alpha: f32) -> f32 {
    if alpha >= 0.5 * LF_PI {
        return 0.0;
    }
    let q = lf_sample_1d(tex, smp, p, alpha).x;
    // m(alpha) = c (1 - ln c) / (2 sin^2(alpha/2)), stable form of 1 - cos alpha.
    let sh = lf_sin(0.5 * alpha);
    let c = max(lf_cos(alpha), 1e-30);
    return c * (1.0 - log(c)) / (2.0 * sh * sh) * q;
}

// (lambda, mu) of the SG fitted to max(a.v, 0)^e, from the exported `sg-fit` texture
// (1D, RG: ln lambda, ln mu on log(1 + e)); e in [0, 1e5].
fn lf_sg_fit(tex: texture_2d<f32>, smp: sampler, p: LfTex, e: f32) -> vec2<f32> {
    return exp(lf_sample_1d(tex, smp, p, e).xy);
}

// A spherical Gaussian: unit axis, sharpness lambda (>= 0), amplitude mu.
struct LfSg {
    axis: vec3<f32>,
    sharpness: f32,
    amplitude: f32,
}

// The SG approximating the lobe s * max(a.v, 0)^e: axis a, lambda(e), s * mu(e).
fn lf_lobe_to_sg(tex: texture_2d<f32>, smp: sampler, p: LfTex, axis: vec3<f32>, e: f32, s: f32) -> LfSg {
    let lm = lf_sg_fit(tex, smp, p, e);
    return LfSg(axis, lm.x, s * lm.y);
}

// G(v) for a unit direction v.
fn lf_sg_eval(g: LfSg, v: vec3<f32>) -> f32 {
    return g.amplitude * exp(g.sharpness * (dot(g.axis, v) - 1.0));
}

// The product of two SGs: lambda_m = |l1 a1 + l2 a2|, a_m = (l1 a1 + l2 a2) / lambda_m,
// mu_m = mu1 mu2 exp(lambda_m - l1 - l2); opposite equal lobes give sharpness 0 and
// the first axis.
fn lf_sg_product(g1: LfSg, g2: LfSg) -> LfSg {
    let m = g1.sharpness * g1.axis + g2.sharpness * g2.axis;
    let lm = length(m);
    var axis = g1.axis;
    if lm > 0.0 {
        axis = m / lm;
    }
    // lambda_m - l1 - l2 = -l1 l2 |a1 - a2|^2 / (lambda_m + l1 + l2) for unit axes: no
    // cancellation of large sharpnesses in f32.
    let d = g1.axis - g2.axis;
    let l12 = g1.sharpness + g2.sharpness;
    let e = -g1.sharpness * g2.sharpness * dot(d, d) / max(lm + l12, 1e-30);
    return LfSg(axis, lm, g1.amplitude * g2.amplitude * exp(e));
}

// 2 pi (1 - exp(-k lambda)) / lambda, with its limit 2 pi k at lambda = 0.
fn lf_sg_sphere_factor(lambda: f32, k: f32) -> f32 {
    if lambda == 0.0 {
        return 2.0 * LF_PI * k;
    }
    return 2.0 * LF_PI * lf_one_minus_exp_neg(k * lambda) / lambda;
}

// Integral of G over the sphere (sr times mu): mu 2 pi / lambda (1 - exp(-2 lambda)).
fn lf_sg_integral(g: LfSg) -> f32 {
    return g.amplitude * lf_sg_sphere_factor(g.sharpness, 2.0);
}

// Integral of G over the hemisphere centred on its axis: mu 2 pi / lambda (1 - exp(-lambda)).
fn lf_sg_hemisphere_integral(g: LfSg) -> f32 {
    return g.amplitude * lf_sg_sphere_factor(g.sharpness, 1.0);
}
