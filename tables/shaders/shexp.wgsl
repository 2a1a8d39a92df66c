// lobefit shader library: shexp, the log-ZH vector of a cap blocker and the OL
// coefficients of its SH exponential (needs common.wgsl).
// Per order n = 3..8 a 1D texture `shexp-n<n>` over theta_b (2D array, RGBA layers):
// channels f_0..f_{n-1} and ||f^|| divided by 1 - cos theta_b, ln ||f^|| / (1 - cos
// theta_b), ln a, ln b, and the position of a clamp kink within each interval (-1:
// none); and `shexp-hyb-n<n>`: ln a, ln b on ||f^|| uniform in [0, T_n] (HYB).

// The log-ZH part of shexp of order n at a cap blocker of half-angle theta_b (rad).
struct LfShexp {
    // f_0..f_{n-1} (the rest 0).
    f: array<f32, 8>,
    // ||f^||.
    norm: f32,
    // The OL coefficients a, b.
    a: f32,
    b: f32,
}

// The n + 3 channel values (f_l / (1 - cos theta_b) for l < n, ||f^|| / (1 - cos
// theta_b), a, b; ln channels exponentiated) at theta_b: linear filtering, except in
// an interval holding a kink, where the two texels on theta_b's side of it are
// extrapolated (interpolating across the slope break would blur it).
fn lf_shexp_channels(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, n: u32, theta_b: f32) -> array<vec4<f32>, 3> {
    let count = p.axis[0].z;
    let last = i32(count) - 1;
    let s = clamp(lf_node_coord(p, 0u, theta_b), 0.0, count - 1.0);
    let i = min(i32(floor(s)), last - 1);
    let kc = n + 3u;
    let kink = lf_fetch_1d_layer(tex, p, kc / 4u, i)[kc % 4u];
    let layers = (n + 7u) / 4u;
    var out: array<vec4<f32>, 3>;
    if kink < -0.5 {
        // No kink (stored -1): the ln channels interpolated, then exp.
        for (var l = 0u; l < layers; l++) {
            out[l] = lf_sample_1d_layer(tex, smp, p, l, theta_b);
        }
        for (var c = n; c < n + 3u; c++) {
            out[c / 4u][c % 4u] = exp(out[c / 4u][c % 4u]);
        }
        return out;
    }
    let w = s - f32(i);
    var j = i - 1;
    var x = w + 1.0;
    if !(w <= kink && i >= 1) && i + 2 <= last {
        j = i + 1;
        x = w - 1.0;
    }
    for (var l = 0u; l < layers; l++) {
        var a = lf_fetch_1d_layer(tex, p, l, j);
        var b = lf_fetch_1d_layer(tex, p, l, j + 1);
        for (var k = 0u; k < 4u; k++) {
            let c = 4u * l + k;
            if c >= n && c < n + 3u {
                a[k] = exp(a[k]);
                b[k] = exp(b[k]);
            }
        }
        out[l] = a + x * (b - a);
    }
    return out;
}

// f_0..f_{n-1}, ||f^||, a, b of order n (3..8) at theta_b, from texture shexp-n<n>.
fn lf_shexp(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, n: u32, theta_b: f32) -> LfShexp {
    let v = lf_shexp_channels(tex, smp, p, n, theta_b);
    let h = sin(0.5 * theta_b);
    let omc = 2.0 * h * h;
    var r: LfShexp;
    for (var l = 0u; l < 8u; l++) {
        r.f[l] = 0.0;
        if l < n {
            r.f[l] = omc * v[l / 4u][l % 4u];
        }
    }
    r.norm = omc * v[n / 4u][n % 4u];
    r.a = v[(n + 1u) / 4u][(n + 1u) % 4u];
    r.b = v[(n + 2u) / 4u][(n + 2u) % 4u];
    return r;
}

// HYB's OL coefficients (a, b) at a log-ZH vector's norm ||f^|| <= T_n, from texture
// shexp-hyb-n<n> (T_n = the texture's upper end; larger norms are looked up at T_n:
// HYB halves f^ until its norm is at most T_n before asking).
fn lf_shexp_hyb_ab(tex: texture_2d<f32>, smp: sampler, p: LfTex, norm: f32) -> vec2<f32> {
    return exp(lf_sample_1d(tex, smp, p, min(norm, p.axis[0].y)).xy);
}
