// lobefit shader library: Γ_L, an environment map prefiltered by spherical Gaussians
// (Iwasaki et al.'s eq. 10), from the texture `lobefit prefilter --texture` writes.
// Needs common.wgsl (lf_lerp_2d_layer) and lobe_product.wgsl (lf_asin, lf_angle_between).
//
// The texture (a 2D array, one per map, not part of `lobefit export`): layer k is the
// map's mean radiance under G(w; a, l_k) = exp(l_k (a.w - 1)), l_k = 2^(k / 2)
// (k = 0 .. 26: l from 1 to 8192); x the azimuth nodes phi_i = 2 pi i / (W - 1), the
// last repeating the first; y the polar nodes theta_j = pi j / (H - 1); z up, phi from
// +x towards +y (the maps' convention). RGBA: the mean of R, G, B and their luminance
// (Rec. 709). Texel (i, j) is node (i, j) itself. The integral of L G over the sphere
// is that mean times lf_sg_sphere_integral(l).

// Layers per doubling of the sharpness.
const LF_PREFILTER_PER_OCTAVE: f32 = 2.0;

// Integral of exp(l (a.w - 1)) over the sphere, 2 pi (1 - e^(-2 l)) / l (l > 0).
fn lf_sg_sphere_integral(l: f32) -> f32 {
    return 2.0 * LF_PI * lf_one_minus_exp_neg(2.0 * l) / l;
}

// The texel coordinates (sx, sy) of unit `a` on the node grid of a W x H layer: phi in
// [0, 2 pi) and theta, both from lf_asin (a few ulps; drivers' atan2 and acos may be
// far coarser, and a sharp level's texels change by their whole value across one).
fn lf_prefilter_coord(a: vec3<f32>, w: f32, h: f32) -> vec2<f32> {
    let theta = lf_angle_between(a, vec3<f32>(0.0, 0.0, 1.0));
    let r = length(a.xy);
    var phi = 0.0;
    if r > 0.0 {
        if abs(a.x) >= abs(a.y) {
            // |phi - (0 or pi)| <= pi / 4.
            let b = lf_asin(a.y / r);
            phi = select(LF_PI - b, b, a.x > 0.0);
        } else {
            // |phi -+ pi / 2| < pi / 4.
            let b = lf_asin(a.x / r);
            phi = select(-0.5 * LF_PI + b, 0.5 * LF_PI - b, a.y > 0.0);
        }
        if phi < 0.0 {
            phi += 2.0 * LF_PI;
        }
    }
    return vec2<f32>(phi / (2.0 * LF_PI) * (w - 1.0), theta / LF_PI * (h - 1.0));
}

// The Lagrange weights of the four layers j0 .. j0 + 3 at u = t - j0 (cubic in log2 l).
fn lf_prefilter_weights(u: f32) -> vec4<f32> {
    let a = u;
    let b = u - 1.0;
    let c = u - 2.0;
    let d = u - 3.0;
    return vec4<f32>(-b * c * d / 6.0, a * c * d / 2.0, -a * b * d / 2.0, a * b * c / 6.0);
}

// The first of the four layers around t (in [0, layers - 4]) and t itself, for
// sharpness l clamped to the ladder.
fn lf_prefilter_layer(l: f32, layers: f32) -> vec2<f32> {
    let top = layers - 1.0;
    let t = clamp(log2(l) * LF_PREFILTER_PER_OCTAVE, 0.0, top);
    return vec2<f32>(clamp(floor(t) - 1.0, 0.0, top - 3.0), t);
}

// The map's mean radiance (RGB, luminance) under the SG of unit axis `a` and sharpness
// `l` in [1, 8192] (clamped to it): bilinear in (theta, phi) on the four layers around
// l by textureLoad and f32 weights, cubic (Lagrange) in log2 l between them, clamped
// at 0 — the CPU's lookup (lobefit_pipelines::prefilter::lookup). 16 texel loads.
fn lf_prefiltered(tex: texture_2d_array<f32>, a: vec3<f32>, l: f32) -> vec4<f32> {
    let dims = vec2<f32>(textureDimensions(tex));
    let s = lf_prefilter_coord(a, dims.x, dims.y);
    let jt = lf_prefilter_layer(l, f32(textureNumLayers(tex)));
    let w = lf_prefilter_weights(jt.y - jt.x);
    let j0 = i32(jt.x);
    let v = w.x * lf_lerp_2d_layer(tex, j0, s.x, s.y, dims.x, dims.y)
        + w.y * lf_lerp_2d_layer(tex, j0 + 1, s.x, s.y, dims.x, dims.y)
        + w.z * lf_lerp_2d_layer(tex, j0 + 2, s.x, s.y, dims.x, dims.y)
        + w.w * lf_lerp_2d_layer(tex, j0 + 3, s.x, s.y, dims.x, dims.y);
    return max(v, vec4<f32>(0.0));
}

// lf_prefiltered with the bilinear step by the hardware (`smp` linear, clamp to edge;
// an f16 texture, or f32 with float32-filterable): 4 samples, not 16 loads, at the
// hardware's 8-bit sub-texel weights (docs/environment.md, "Γ_L on the GPU", measures
// what that costs).
fn lf_prefiltered_hw(tex: texture_2d_array<f32>, smp: sampler, a: vec3<f32>, l: f32) -> vec4<f32> {
    let dims = vec2<f32>(textureDimensions(tex));
    let s = lf_prefilter_coord(a, dims.x, dims.y);
    let uv = (s + 0.5) / dims;
    let jt = lf_prefilter_layer(l, f32(textureNumLayers(tex)));
    let w = lf_prefilter_weights(jt.y - jt.x);
    let j0 = i32(jt.x);
    let v = w.x * textureSampleLevel(tex, smp, uv, j0, 0.0)
        + w.y * textureSampleLevel(tex, smp, uv, j0 + 1, 0.0)
        + w.z * textureSampleLevel(tex, smp, uv, j0 + 2, 0.0)
        + w.w * textureSampleLevel(tex, smp, uv, j0 + 3, 0.0);
    return max(v, vec4<f32>(0.0));
}
