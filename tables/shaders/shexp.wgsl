// lobefit shader library: shexp, the log-ZH vector of a cap blocker and the OL
// coefficients of its SH exponential, and HYB's SH exponential (needs common.wgsl and
// sh.wgsl).
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
    let h = lf_sin(0.5 * theta_b);
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

// HYB's SH exponential exp*(f) of an SH vector f of order n in {3, 4} (n^2 coefficients,
// the rest ignored; outputs from n^2 on: 0), with texture shexp-hyb-n<n> (T_n its upper
// end), as lobefit_tables::shexp::ShExp::hyb: the DC term isolated (f^ = f without
// f_0), f^ halved k times until s = ||f^|| / 2^k <= T_n, OL at s (a 1 + b f^ / 2^k with
// (a, b) = lf_shexp_hyb_ab at s), k truncated SH squarings (lf_sh_product), times
// e^(f_0 / sqrt(4 pi)). At most 64 halvings (the runtime's MAX_SQUARINGS; a norm
// beyond T_n 2^64 is not finite in f32 anyway).
fn lf_shexp_hyb(tex: texture_2d<f32>, smp: sampler, p: LfTex, order: u32, f: array<f32, 16>) -> array<f32, 16> {
    let n2 = order * order;
    let sqrt4pi = sqrt(4.0 * LF_PI);
    var g = f;
    var norm2 = 0.0;
    for (var i = 1u; i < n2; i++) {
        norm2 += g[i] * g[i];
    }
    let t = p.axis[0].y;
    var s = sqrt(norm2);
    var k = 0u;
    // 2^-k, exactly (GLSL ES 3.0 has no ldexp; exp2 need not be exact).
    var half_k = 1.0;
    while s > t && k < 64u {
        s *= 0.5;
        half_k *= 0.5;
        k++;
    }
    let ab = lf_shexp_hyb_ab(tex, smp, p, s);
    let scale = ab.y * half_k;
    var out: array<f32, 16>;
    for (var i = 1u; i < n2; i++) {
        out[i] = scale * g[i];
    }
    out[0] = ab.x * sqrt4pi;
    for (var r = 0u; r < k; r++) {
        out = lf_sh_product(order, out, out);
    }
    let e = exp(g[0] / sqrt4pi);
    for (var i = 0u; i < n2; i++) {
        out[i] *= e;
    }
    return out;
}
