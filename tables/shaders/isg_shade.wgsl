// lobefit shader library: shading with the integrated SG (Iwasaki et al.'s pipeline;
// lobefit's pipelines/isg). Needs common, lobe, isg and lobe_product (lf_asin).

// The ISG frame's pole for an SG axis z: the unit vector of Pixar's orthonormal basis
// (Duff et al. 2017), as the CPU pipeline takes it.
fn lf_any_orthonormal(z: vec3<f32>) -> vec3<f32> {
    let s = select(-1.0, 1.0, z.z >= 0.0);
    let a = -1.0 / (s + z.z);
    let b = z.x * z.y * a;
    return vec3<f32>(b, s + z.y * z.y * a, -z.y);
}

// Limiting angle (rad) of an SG of sharpness lambda: where it falls to eps of its
// peak, at most pi/2: 1 - cos G = 2 sin^2(G/2) = -ln(eps) / lambda, so
// G = 2 asin(sqrt(-ln(eps) / (2 lambda))) (lf_asin: a GPU's acos near 1 errs by
// ~2e-5 rad, enough to move patch centres across a blocker's edge).
fn lf_isg_cone(lambda: f32, eps: f32) -> f32 {
    let h = -log(eps) / lambda;
    if h >= 1.0 {
        return 0.5 * LF_PI;
    }
    return 2.0 * lf_asin(sqrt(0.5 * h));
}

// exp(-z) I0(z) for z >= 0 (Abramowitz & Stegun 9.8.1-9.8.2, relative error < 2e-7).
fn lf_bessel_i0e(z: f32) -> f32 {
    if z < 3.75 {
        let t = (z / 3.75) * (z / 3.75);
        let i0 = 1.0 + t * (3.5156229 + t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768 + t * 0.0045813)))));
        return i0 * exp(-z);
    }
    let t = 3.75 / z;
    let p = 0.39894228 + t * (0.01328592 + t * (0.00225319 + t * (-0.00157565 + t * (0.00916281
        + t * (-0.02057706 + t * (0.02635537 + t * (-0.01647633 + t * 0.00392377)))))));
    return p / sqrt(z);
}

const LF_GL8_X = array<f32, 8>(-0.96028986, -0.79666648, -0.52553241, -0.18343464, 0.18343464, 0.52553241, 0.79666648, 0.96028986);
const LF_GL8_W = array<f32, 8>(0.10122854, 0.22238103, 0.31370665, 0.36268378, 0.36268378, 0.31370665, 0.22238103, 0.10122854);

// The integral (sr) of exp(lambda (mu.w - 1)) max(n.w, 0) over the sphere for the SG g
// (its amplitude ignored): the closed form (n.mu) 2 pi ((lambda - 1) + (lambda + 1)
// exp(-2 lambda)) / lambda^2 when the SG lies above the horizon, else
// 2 pi int_0^1 x exp(lambda (c x - 1)) I0(lambda s sqrt(1 - x^2)) dx by Gauss-Legendre
// on panels refined around x = c (c = n.mu, s = sqrt(1 - c^2)).
fn lf_sg_clamped_cosine(g: LfSg, n: vec3<f32>) -> f32 {
    let l = g.sharpness;
    let c = clamp(dot(n, g.axis), -1.0, 1.0);
    if acos(c) + lf_isg_cone(l, 1e-12) < 0.5 * LF_PI {
        return c * 2.0 * LF_PI * ((l - 1.0) + (l + 1.0) * exp(-2.0 * l)) / (l * l);
    }
    let s = sqrt(max(1.0 - c * c, 0.0));
    let w = max(s / sqrt(l), 1e-6);
    var cuts = array<f32, 15>(0.0, 1.0, c, c - 0.5 * w, c + 0.5 * w, c - w, c + w, c - 2.0 * w, c + 2.0 * w,
        c - 4.0 * w, c + 4.0 * w, c - 8.0 * w, c + 8.0 * w, c - 16.0 * w, c + 16.0 * w);
    for (var i = 0u; i < 15u; i++) {
        cuts[i] = clamp(cuts[i], 0.0, 1.0);
    }
    // Insertion sort; equal cuts make empty panels.
    for (var i = 1u; i < 15u; i++) {
        let v = cuts[i];
        var j = i;
        while j > 0u && cuts[j - 1u] > v {
            cuts[j] = cuts[j - 1u];
            j -= 1u;
        }
        cuts[j] = v;
    }
    var sum = 0.0;
    for (var k = 0u; k < 14u; k++) {
        let m = 0.5 * (cuts[k] + cuts[k + 1u]);
        let h = 0.5 * (cuts[k + 1u] - cuts[k]);
        if h <= 0.0 {
            continue;
        }
        var part = 0.0;
        for (var q = 0u; q < 8u; q++) {
            let x = m + h * LF_GL8_X[q];
            let z = l * s * sqrt(max(1.0 - x * x, 0.0));
            part += LF_GL8_W[q] * x * exp(l * (c * x - 1.0) + z) * lf_bessel_i0e(z);
        }
        sum += h * part;
    }
    return 2.0 * LF_PI * sum;
}
