// lobefit shader library: wrap lighting (needs common.wgsl). lambda_hat_l(a) is the
// Funk-Hecke eigenvalue of the wrap kernel max((n.w + a) / (1 + a), 0) divided by pi,
// a in [0, 1]; a = 0 is the clamped cosine (lambda_hat = 1, 2/3, 1/4, ...).

// Monomial coefficients of the Legendre polynomials P_0 .. P_7: [l * 8 + k] multiplies t^k.
const LF_LEGENDRE: array<f32, 64> = array<f32, 64>(
    1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    -0.5, 0.0, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, -1.5, 0.0, 2.5, 0.0, 0.0, 0.0, 0.0,
    0.375, 0.0, -3.75, 0.0, 4.375, 0.0, 0.0, 0.0,
    0.0, 1.875, 0.0, -8.75, 0.0, 7.875, 0.0, 0.0,
    -0.3125, 0.0, 6.5625, 0.0, -19.6875, 0.0, 14.4375, 0.0,
    0.0, -2.1875, 0.0, 19.6875, 0.0, -43.3125, 0.0, 26.8125,
);

// 12-point Gauss-Legendre nodes and weights on [0, 1].
const LF_GL12_X: array<f32, 12> = array<f32, 12>(
    0.0092196829, 0.0479413718, 0.1150486629, 0.2063410229, 0.3160842505, 0.4373832957,
    0.5626167043, 0.6839157495, 0.7936589771, 0.8849513371, 0.9520586282, 0.9907803171,
);
const LF_GL12_W: array<f32, 12> = array<f32, 12>(
    0.0235876682, 0.0534696630, 0.0800391643, 0.1015837134, 0.1167462683, 0.1245735229,
    0.1245735229, 0.1167462683, 0.1015837134, 0.0800391643, 0.0534696630, 0.0235876682,
);

// lambda_hat_l(a) for l < order (order <= 8; later entries 0):
// lambda_hat_l = 2 int_{-a}^{1} ((t + a) / (1 + a))^(1 + a) P_l(t) dt
//              = 2 (1 + a) int_0^1 2 v^(3 + 2a) P_l((1 + a) v^2 - a) dv  (u = v^2),
// by 12-point Gauss-Legendre in v (the integrand is smooth; the closed form's
// alternating monomial sums lose 1e-3 to cancellation in f32 at l = 7).
fn lf_wrap_lambda_hat(order: u32, a: f32) -> array<f32, 8> {
    var xs = LF_GL12_X;
    var ws = LF_GL12_W;
    var out: array<f32, 8>;
    for (var i = 0u; i < 12u; i++) {
        let v = xs[i];
        let t = (1.0 + a) * v * v - a;
        let w = 2.0 * ws[i] * pow(v, 3.0 + 2.0 * a);
        var p_prev = 1.0;
        var p = t;
        out[0] += w;
        for (var l = 1u; l < order; l++) {
            out[l] += w * p;
            let next = (f32(2u * l + 1u) * t * p - f32(l) * p_prev) / f32(l + 1u);
            p_prev = p;
            p = next;
        }
    }
    for (var l = 0u; l < 8u; l++) {
        out[l] *= 2.0 * (1.0 + a);
    }
    return out;
}
