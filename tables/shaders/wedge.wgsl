// lobefit shader library: height-field wedge visibility in log-SH space (needs
// common.wgsl and sh.wgsl). The exported `wedge` texture (3D, R: x = column < 16,
// y = row < 64, z = log2(W) - 2 for W in {4, 8, 16, 32, 64}) holds the order-8
// operator M_lin; the order-n operator is rows < n^2, columns j and 8 + j for j < n.

// [M_lin]_{row, col} of the W-wedge operator, W index w = log2(W) - 2: an exact texel
// fetch (no filtering).
fn lf_wedge_entry(tex: texture_3d<f32>, p: LfTex, w: u32, row: u32, col: u32) -> f32 {
    return lf_fetch_3d(tex, p, i32(col), i32(row), i32(w)).x;
}

// V = M_lin [v_a; v_b]: the log-SH (n^2 coefficients) of the canonical wedge between
// two slices with NLP log-visibility v_a, v_b (n entries each, n = order <= 8).
fn lf_wedge_apply(tex: texture_3d<f32>, p: LfTex, w: u32, order: u32, v_a: array<f32, 8>, v_b: array<f32, 8>) -> array<f32, 64> {
    var out: array<f32, 64>;
    for (var i = 0u; i < order * order; i++) {
        var sum = 0.0;
        for (var j = 0u; j < order; j++) {
            sum += lf_wedge_entry(tex, p, w, i, j) * v_a[j] + lf_wedge_entry(tex, p, w, i, 8u + j) * v_b[j];
        }
        out[i] = sum;
    }
    return out;
}

// The log-visibility slice vector v^log(sigma) in the normalised-Legendre basis
// (sqrt((2l + 1) / 2) P_l), l < order <= 8 (later entries 0), of a height-field slice
// whose horizon lies at elevation sigma in [-pi/2, pi/2] (rad, 0: the tangent plane)
// with log-visibility ln eps below it, eps in [0.01, 0.99] (closed form,
// lobefit_tables::wedge::slice_log): v_0 = ln eps (1 + sin sigma) / sqrt(2), v_l =
// ln eps sqrt((2l + 1) / 2) (P_{l+1} - P_{l-1})(sin sigma) / (2l + 1), the latter as
// -ln eps sqrt((2l + 1) / 2) cos^2(sigma) P'_l(sin sigma) / (l (l + 1)) (no
// cancellation near sigma = +-pi/2), 1 + sin sigma as 2 cos^2(pi/4 - sigma/2).
fn lf_wedge_slice(sigma: f32, eps: f32, order: u32) -> array<f32, 8> {
    let x = lf_sin(sigma);
    let c = lf_cos(sigma);
    let le = log(eps);
    var out: array<f32, 8>;
    let h = lf_cos(0.25 * LF_PI - 0.5 * sigma);
    out[0] = le * 1.4142135 * h * h;
    // P_l and P'_l by their recurrences: P'_{l+1} = P'_{l-1} + (2l + 1) P_l.
    var p_prev = 1.0;
    var p = x;
    var dp_prev = 0.0;
    var dp = 1.0;
    for (var l = 1u; l < order; l++) {
        let fl = f32(l);
        out[l] = -le * sqrt(0.5 * (2.0 * fl + 1.0)) * c * c * dp / (fl * (fl + 1.0));
        let p_next = ((2.0 * fl + 1.0) * x * p - fl * p_prev) / (fl + 1.0);
        let dp_next = dp_prev + (2.0 * fl + 1.0) * p;
        p_prev = p;
        p = p_next;
        dp_prev = dp;
        dp = dp_next;
    }
    return out;
}

// The log-SH visibility (n^2 coefficients, order n <= 8, world frame about +z) of a
// height-field point from its W horizon elevations sigma_k (rad) at azimuths
// phi_k = 2 pi k / W (from +x towards +y), W in {4, 8, 16, 32, 64} with index
// w = log2(W) - 2, floor eps of the slices' log-visibility: wedge k between slices k
// and k + 1 (mod W) by M_lin, turned by phi_k about z, summed
// (lobefit_tables::wedge::Wedge::compose). Needs sh.wgsl (lf_sh_rotate_z).
fn lf_wedge_compose(tex: texture_3d<f32>, p: LfTex, w: u32, order: u32, eps: f32, sigma: array<f32, 64>) -> array<f32, 64> {
    let count = 4u << w;
    var out: array<f32, 64>;
    var v_a = lf_wedge_slice(sigma[0], eps, order);
    for (var k = 0u; k < count; k++) {
        let v_b = lf_wedge_slice(sigma[(k + 1u) % count], eps, order);
        let turned = lf_sh_rotate_z(order, lf_wedge_apply(tex, p, w, order, v_a, v_b), 2.0 * LF_PI * f32(k) / f32(count));
        for (var i = 0u; i < order * order; i++) {
            out[i] += turned[i];
        }
        v_a = v_b;
    }
    return out;
}

// lf_wedge_compose with the height field blocking only between the elevations
// lower_k and sigma_k in each azimuth (nothing where sigma_k <= lower_k): slice k is
// v^log(max(sigma_k, lower_k)) - v^log(lower_k). With lower_k the tangent plane's
// elevation in azimuth phi_k, atan2(-(n_x cos phi_k + n_y sin phi_k), n_z) for the
// normal n, the terrain blocks only above the tangent plane (lobefit's shexp setting
// terrain_above_tangent); lower_k = -pi/2 is lf_wedge_compose.
fn lf_wedge_compose_between(tex: texture_3d<f32>, p: LfTex, w: u32, order: u32, eps: f32, lower: array<f32, 64>, sigma: array<f32, 64>) -> array<f32, 64> {
    let count = 4u << w;
    var out: array<f32, 64>;
    var v_a = lf_wedge_slice(max(sigma[0], lower[0]), eps, order);
    let low_a = lf_wedge_slice(lower[0], eps, order);
    for (var j = 0u; j < order; j++) {
        v_a[j] -= low_a[j];
    }
    let first = v_a;
    for (var k = 0u; k < count; k++) {
        var v_b = first;
        if k + 1u < count {
            v_b = lf_wedge_slice(max(sigma[k + 1u], lower[k + 1u]), eps, order);
            let low_b = lf_wedge_slice(lower[k + 1u], eps, order);
            for (var j = 0u; j < order; j++) {
                v_b[j] -= low_b[j];
            }
        }
        let turned = lf_sh_rotate_z(order, lf_wedge_apply(tex, p, w, order, v_a, v_b), 2.0 * LF_PI * f32(k) / f32(count));
        for (var i = 0u; i < order * order; i++) {
            out[i] += turned[i];
        }
        v_a = v_b;
    }
    return out;
}
