// lobefit shader library: products of two cosine lobes (needs common.wgsl).
// max(a1.v, 0)^e1 max(a2.v, 0)^e2 ~ p max(a.v, 0)^e_r: the product lobe's peak p,
// exponent e_r, and its axis a on the arc from a1 to a2 at fraction t of the angle
// alpha between them. Both variants (energy-conserving `lobe-product`, L2-optimal
// `lobe-product-l2`) read the same two textures:
// - the main table: 3D (alpha fastest, e2, e1), channels c = ln(integral / M),
//   rho = ln((1 + e_r)/(1 + e_m)) [, kappa = ln(peak factor), l2 only]; f16 exports
//   store each channel compressed, which `LfTex.decode` undoes;
// - `<kind>-lnw`: 1D, r(E) = ln W(E) - 1/2 ln(2 pi / (E + 3/2)) on log(1 + E).
// M is the closed-form model the table corrects (fits/lobe_product/gpu.rs states it).

// Exponents beyond this are looked up at it (the table's range).
const LF_LOBE_E_MAX: f32 = 1e5;
// ln 0 stand-in: exp() of it (or of twice it) is 0 in f32.
const LF_LN_ZERO: f32 = -1e38;

// asin(x) to a few f32 ulps: a Taylor series up to x^21 for |x| <= 1/2 (truncation
// < 2e-9 relative), pi/2 - 2 asin(sqrt((1 - |x|)/2)) above (1 - |x| exact there).
// Drivers' asin may be far coarser (Mesa's lowering: ~1e-4 absolute, which the peak
// angle's division by alpha and the sharp lobes' e beta^2 amplify to percents).
fn lf_asin_series(z: f32) -> f32 {
    let z2 = z * z;
    var acc = 0.0;
    // (2k)! / (4^k (k!)^2 (2k + 1)), k = 10 down to 1.
    let c = array<f32, 10>(0.16666667, 0.075, 0.044642857, 0.030381944, 0.022372159,
        0.017352764, 0.01396484, 0.011551800, 0.0097616095, 0.0083903358);
    for (var k = 9; k >= 0; k--) {
        acc = (acc + c[k]) * z2;
    }
    return z + z * acc;
}

fn lf_asin(x: f32) -> f32 {
    let a = abs(x);
    if a <= 0.5 {
        return lf_asin_series(x);
    }
    return sign(x) * (0.5 * LF_PI - 2.0 * lf_asin_series(sqrt(0.5 * (1.0 - min(a, 1.0)))));
}

// atanh(q) for q in [0, 1): a series below 1/8 (relative accuracy at small q, where
// the log form would cancel), 1/2 ln((1 + q)/(1 - q)) above.
fn lf_atanh(q: f32) -> f32 {
    if q < 0.125 {
        let q2 = q * q;
        return q * (1.0 + q2 * (1.0 / 3.0 + q2 * (0.2 + q2 * (1.0 / 7.0 + q2 * (1.0 / 9.0 + q2 / 11.0)))));
    }
    return 0.5 * log((1.0 + q) / (1.0 - q));
}

// ln max(cos x, 0)^e as -2 e atanh(tan^2(x/2)) (exact for small x in f32, where
// 1 - cos x would cancel); 0 for e = 0, LF_LN_ZERO from pi/2 on.
fn lf_lobe_ln(e: f32, x: f32) -> f32 {
    if e == 0.0 {
        return 0.0;
    }
    if abs(x) >= 0.5 * LF_PI {
        return LF_LN_ZERO;
    }
    let t = lf_sin(0.5 * x) / lf_cos(0.5 * x);
    return -2.0 * e * lf_atanh(t * t);
}

// The product's peak angle from a1 for exponents (e1, e2) at separation alpha
// (s = sin alpha): 1/2 (alpha + asin((e2 - e1)/(e1 + e2) s)), clamped to [0, alpha].
fn lf_lobe_peak_angle(e1: f32, e2: f32, alpha: f32, s: f32) -> f32 {
    let sum = e1 + e2;
    var c = 0.0;
    if sum > 0.0 {
        c = (e2 - e1) / sum;
    }
    return clamp(0.5 * (alpha + lf_asin(clamp(c * s, -1.0, 1.0))), 0.0, alpha);
}

// The product of max(a1.v, 0)^e1 and max(a2.v, 0)^e2, alpha the angle between a1, a2.
struct LfLobeProduct {
    // Peak value of the fitted product lobe.
    p: f32,
    // Its axis's position on the arc a1 -> a2, as a fraction of alpha.
    t: f32,
    // Its exponent.
    e_r: f32,
    // The product's integral over the sphere (sr).
    integral: f32,
}

// Both variants: `l2` says whether the main texture has the kappa channel.
fn lf_lobe_product_any(tex: texture_3d<f32>, smp: sampler, p: LfTex, lnw_tex: texture_2d<f32>, pw: LfTex, l2: bool, e1: f32, e2: f32, alpha_in: f32) -> LfLobeProduct {
    let alpha = min(alpha_in, LF_PI);
    let ch = lf_sample_3d(tex, smp, p, min(e1, LF_LOBE_E_MAX), min(e2, LF_LOBE_E_MAX), alpha);
    let e = e1 + e2;
    let lnw = lf_sample_1d(lnw_tex, smp, pw, e).x + 0.5 * log(2.0 * LF_PI / (e + 1.5));
    let sin_a = lf_sin(alpha);
    let chord = 2.0 * lf_sin(0.5 * alpha);
    var g = 0.0;
    if e > 0.0 {
        g = e + e1 * e2 / e * chord * chord;
    }
    let beta = lf_lobe_peak_angle(e1 + 1.0, e2 + 1.0, alpha, sin_a);
    let lune = LF_PI - alpha;
    let ln_model = lnw + lf_lobe_ln(e1, beta) + lf_lobe_ln(e2, alpha - beta) - 0.5 * log(g / (2.0 * LF_PI) + 1.0 / (lune * lune));
    let integral = exp(ln_model + ch.x);
    let e_m = sqrt(e * g);
    let e_r = max((1.0 + e_m) * exp(ch.y) - 1.0, 0.0);
    var k = 1.0;
    if l2 {
        k = exp(ch.z);
    }
    var t = 0.5;
    if alpha > 0.0 {
        t = clamp(lf_lobe_peak_angle(e1, e2, alpha, sin_a) / alpha, 0.0, 1.0);
    } else if e > 0.0 {
        t = e2 / e;
    }
    return LfLobeProduct(k * integral * (e_r + 1.0) / (2.0 * LF_PI), t, e_r, integral);
}

// The energy-conserving product (texture `lobe-product`, its `lobe-product-lnw`):
// the fitted lobe's integral equals the product's.
fn lf_lobe_product(tex: texture_3d<f32>, smp: sampler, p: LfTex, lnw_tex: texture_2d<f32>, pw: LfTex, e1: f32, e2: f32, alpha: f32) -> LfLobeProduct {
    return lf_lobe_product_any(tex, smp, p, lnw_tex, pw, false, e1, e2, alpha);
}

// The L2-optimal product (texture `lobe-product-l2`, its `lobe-product-l2-lnw`).
fn lf_lobe_product_l2(tex: texture_3d<f32>, smp: sampler, p: LfTex, lnw_tex: texture_2d<f32>, pw: LfTex, e1: f32, e2: f32, alpha: f32) -> LfLobeProduct {
    return lf_lobe_product_any(tex, smp, p, lnw_tex, pw, true, e1, e2, alpha);
}

// The angle between unit vectors a1, a2: 2 asin(|a1 - a2| / 2), or pi minus 2
// asin(|a1 + a2| / 2) past pi/2 (accurate at both ends, where acos of the dot product
// is not).
fn lf_angle_between(a1: vec3<f32>, a2: vec3<f32>) -> f32 {
    let d = length(a1 - a2);
    let s = length(a1 + a2);
    if d <= s {
        return 2.0 * lf_asin(0.5 * d);
    }
    return LF_PI - 2.0 * lf_asin(0.5 * s);
}

// The unit direction at fraction t of the great-circle arc from a1 to a2 (unit
// vectors). Antipodal a1, a2 span no unique arc: it then turns towards the axis
// closest to perpendicular to a1.
fn lf_lobe_product_axis(a1: vec3<f32>, a2: vec3<f32>, t: f32) -> vec3<f32> {
    let alpha = lf_angle_between(a1, a2);
    // a2's part perpendicular to a1: length sin alpha.
    var q = a2 - dot(a1, a2) * a1;
    let len = length(q);
    if len > 1e-7 {
        q = q / len;
    } else {
        var c = vec3<f32>(1.0, 0.0, 0.0);
        if abs(a1.x) > 0.5 {
            c = vec3<f32>(0.0, 1.0, 0.0);
        }
        q = normalize(c - dot(a1, c) * a1);
    }
    let b = t * alpha;
    return lf_cos(b) * a1 + lf_sin(b) * q;
}
