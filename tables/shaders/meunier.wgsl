// lobefit shader library: direct lighting with cosine lobes, Meunier et al.'s pipeline
// (needs common.wgsl, lobe.wgsl, lobe_product.wgsl): the visibility mask's per-depth
// weights from the exported `mask-weights` texture, a sphere light's exact irradiance,
// and the share of a lobe inside a light's cap (the runtime's `meunier` module).

// Cap exponent for any half-angle beta in (0, pi/2) (rad): the `cap-exponent` texture
// from its first node (1 mrad) on, the small-cap limit e(1 mrad) (1 mrad / beta)^2
// below (e beta^2 tends to a constant as beta -> 0).
fn lf_cap_exponent_any(tex: texture_2d<f32>, smp: sampler, p: LfTex, beta: f32) -> f32 {
    if beta < 1e-3 {
        let r = 1e-3 / beta;
        return lf_cap_exponent(tex, smp, p, 1e-3) * r * r;
    }
    return lf_cap_exponent(tex, smp, p, beta);
}

// Row k of the `mask-weights` texture (2D, R: x on ln dist, y the table's channel k,
// 0..59) at dist, held at the table's ends outside [0.25, 10]; the row is read at its
// texel centre, so it never blends with the next.
fn lf_mask_weights_row(tex: texture_2d<f32>, smp: sampler, p: LfTex, k: u32, dist: f32) -> f32 {
    return lf_sample_2d(tex, smp, p, f32(k), clamp(dist, 0.25, 10.0)).x;
}

// The weight of the leaf lobes of level `level` (1..=depth) in eq. 39 for masks of
// maximal depth `depth` (1..=5), from the `mask-weights` texture. `weight_set`: 0 fitted, 1
// the paper's procedure, 2 every weight 1 (no texture read); `mode`: 0 aggressive, 1
// conservative. `dist` = 1 / (2 tan alpha) for a light of half-angle alpha.
fn lf_mask_weight(tex: texture_2d<f32>, smp: sampler, p: LfTex, weight_set: u32, mode: u32, depth: u32, level: u32, dist: f32) -> f32 {
    if weight_set >= 2u {
        return 1.0;
    }
    // Channel order: set, mode, maximal depth 1..=5, level 1..=depth (15 per mode).
    return lf_mask_weights_row(tex, smp, p, (weight_set * 2u + mode) * 15u + depth * (depth - 1u) / 2u + level - 1u, dist);
}

// ∫_cap max(n.v, 0) dω (sr) for a cap of half-angle asin(sin_alpha) whose axis makes
// the angle acos(cos_beta) with n: pi sin^2(alpha) cos(beta) while the cap is above
// the horizon, 0 below it, and the closed form of the cap clipped by the horizon in
// between (a sphere light's irradiance per unit radiance).
fn lf_sphere_cap_irradiance(sin_alpha: f32, cos_beta: f32) -> f32 {
    let s2 = sin_alpha * sin_alpha;
    let cb = clamp(cos_beta, -1.0, 1.0);
    if cb * cb >= s2 {
        return select(0.0, LF_PI * s2 * cb, cb > 0.0);
    }
    let sb = sqrt(1.0 - cb * cb);
    // x = cot alpha; y = -x cot beta: where the horizon crosses the cap's rim.
    let x = sqrt(max(1.0 - s2, 0.0)) / sin_alpha;
    let y = clamp(-x * cb / sb, -1.0, 1.0);
    let q = sb * sqrt(1.0 - y * y);
    // acos(y) as pi/2 - asin(y) and atan(q/x) as asin(q / |(q, x)|) (q >= 0, x > 0):
    // drivers' acos and atan may be coarse (through llvmpipe's atan2 this function erred
    // by 7e-5 of its largest value, 8e-6 with the series).
    return max((cb * (0.5 * LF_PI - lf_asin(y)) - x * q) * s2 + lf_asin(q / sqrt(q * q + x * x)), 0.0);
}

// The fraction of a unit lobe max(a.v, 0)^e inside a cap of half-angle alpha whose
// axis makes the angle gamma with a (rad): the lobe as the Gaussian
// exp(-(e + 1) theta^2 / 2) of the tangent plane, the cap as the disk of radius alpha,
// the azimuth about a integrated by the midpoint rule (24 points on [0, pi], four at a
// time); 1 or 0 when the rim lies more than 6 standard deviations away.
fn lf_lobe_fraction_in_cap(gamma: f32, alpha: f32, e_in: f32) -> f32 {
    let e = e_in + 1.0;
    let sigma = 1.0 / sqrt(e);
    if gamma + 6.0 * sigma <= alpha {
        return 1.0;
    }
    if gamma - 6.0 * sigma >= alpha {
        return 0.0;
    }
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 6u; k++) {
        let phi = (LF_PI / 24.0) * (vec4<f32>(f32(4u * k)) + vec4<f32>(0.5, 1.5, 2.5, 3.5));
        let sp = sin(phi);
        let cp = cos(phi);
        let disc = alpha * alpha - gamma * gamma * sp * sp;
        let root = sqrt(max(disc, vec4<f32>(0.0)));
        let r1 = max(gamma * cp - root, vec4<f32>(0.0));
        let r2 = max(gamma * cp + root, vec4<f32>(0.0));
        let term = exp(-0.5 * e * r1 * r1) - exp(-0.5 * e * r2 * r2);
        sum += select(vec4<f32>(0.0), term, disc > vec4<f32>(0.0));
    }
    return clamp((sum.x + sum.y + sum.z + sum.w) / 24.0, 0.0, 1.0);
}
