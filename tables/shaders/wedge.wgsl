// lobefit shader library: height-field wedge visibility in log-SH space (needs
// common.wgsl). The exported `wedge` texture (3D, R: x = column < 16, y = row < 64,
// z = log2(W) - 2 for W in {4, 8, 16, 32, 64}) holds the order-8 operator M_lin;
// the order-n operator is rows < n^2, columns j and 8 + j for j < n.

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
