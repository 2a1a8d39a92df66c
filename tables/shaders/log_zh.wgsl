// lobefit shader library: log-ZH vectors in closed form (needs common.wgsl and
// wrap.wgsl for LF_LEGENDRE and the Gauss-Legendre rule). The ZH coefficients z_0 .. z_{n-1} (about +z) of
// ln max(f, eps) for a normalised Phong lobe f, the diffuse BRDF, or a spherical
// blocker; eps in [0.01, 0.99]; turn them to a world axis with lf_zh_to_sh.

// e^x - 1 - x without cancellation for small |x|.
fn lf_exp_m1_minus_x(x: f32) -> f32 {
    if abs(x) < 0.5 {
        var term = 0.5 * x * x;
        var sum = 0.0;
        for (var k = 3; k < 14; k++) {
            sum += term;
            term *= x / f32(k);
        }
        return sum;
    }
    return exp(x) - 1.0 - x;
}

// Log-ZH of the normalised Phong lobe (r + 1)/(2 pi) max(cos, 0)^r, r in [1, 4096].
fn lf_log_zh_phong(eps: f32, r: f32, order: u32) -> array<f32, 8> {
    var p = LF_LEGENDRE;
    var out: array<f32, 8>;
    // ln t_eps = (ln(2 pi eps) - ln(r + 1)) / r; t_eps >= 1: f <= eps everywhere.
    let ln_t = (log(2.0 * LF_PI * eps) - log(r + 1.0)) / r;
    // G_l(t) = int_t^1 ln(s / t) P_l(s) ds: by its monomial moments for t <= 1/2, by
    // 12-point Gauss-Legendre on [t, 1] above (where the moments nearly agree and
    // their alternating Legendre sums cancel in f32).
    var g: array<f32, 8>;
    if ln_t < 0.0 {
        let t = exp(ln_t);
        if t > 0.5 {
            var xs = LF_GL12_X;
            var ws = LF_GL12_W;
            for (var i = 0u; i < 12u; i++) {
                let s = t + (1.0 - t) * xs[i];
                let w = (1.0 - t) * ws[i] * log(s / t);
                var q_prev = 1.0;
                var q = s;
                g[0] += w;
                for (var l = 1u; l < 8u; l++) {
                    g[l] += w * q;
                    let next = (f32(2u * l + 1u) * s * q - f32(l) * q_prev) / f32(l + 1u);
                    q_prev = q;
                    q = next;
                }
            }
        } else {
            var m: array<f32, 8>;
            for (var k = 0u; k < 8u; k++) {
                let kp = f32(k + 1u);
                m[k] = lf_exp_m1_minus_x(kp * ln_t) / (kp * kp);
            }
            for (var l = 0u; l < 8u; l++) {
                for (var k = 0u; k <= l; k++) {
                    g[l] += p[l * 8u + k] * m[k];
                }
            }
        }
    }
    for (var l = 0u; l < order; l++) {
        var dc = 0.0;
        if l == 0u {
            dc = 2.0 * log(eps);
        }
        out[l] = sqrt(LF_PI * f32(2u * l + 1u)) * (dc + r * g[l]);
    }
    return out;
}

// Log-ZH of the diffuse BRDF max(cos, 0) / pi (Phong with r = 1).
fn lf_log_zh_diffuse(eps: f32, order: u32) -> array<f32, 8> {
    return lf_log_zh_phong(eps, 1.0, order);
}

// Log-ZH of a spherical blocker of angular radius theta_b in [0, pi] on +z: ln eps
// times the cap's ZH, sqrt(pi) (1 - cos theta_b) and sqrt(pi / (2l + 1)) (P_{l-1} -
// P_{l+1})(cos theta_b), the latter as sqrt(pi / (2l + 1)) (2l + 1) / (l (l + 1))
// sin^2(theta_b) P'_l(cos theta_b) (no cancellation for small caps).
fn lf_log_zh_blocker(eps: f32, theta_b: f32, order: u32) -> array<f32, 8> {
    let c = lf_cos(theta_b);
    let s = lf_sin(theta_b);
    let le = log(eps);
    var out: array<f32, 8>;
    let sh = lf_sin(0.5 * theta_b);
    out[0] = le * sqrt(LF_PI) * 2.0 * sh * sh;
    // P_l and P'_l by their recurrences: P'_{l+1} = P'_{l-1} + (2l + 1) P_l.
    var p_prev = 1.0;
    var p = c;
    var dp_prev = 0.0;
    var dp = 1.0;
    for (var l = 1u; l < order; l++) {
        let fl = f32(l);
        out[l] = le * sqrt(LF_PI / (2.0 * fl + 1.0)) * (2.0 * fl + 1.0) / (fl * (fl + 1.0)) * s * s * dp;
        let p_next = ((2.0 * fl + 1.0) * c * p - fl * p_prev) / (fl + 1.0);
        let dp_next = dp_prev + (2.0 * fl + 1.0) * p;
        p_prev = p;
        p = p_next;
        dp_prev = dp;
        dp = dp_next;
    }
    return out;
}
