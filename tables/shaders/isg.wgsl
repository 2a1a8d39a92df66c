// lobefit shader library: the integrated spherical Gaussian (ISG) models (needs
// common.wgsl). S_hat(theta, phi; gamma) in [0, 1] is the fraction of a unit SG of
// sharpness gamma (axis on the equator at phi = pi/2) over the spherical rectangle
// [0, theta] x [0, phi]; S = S_hat * 2 pi (1 - exp(-gamma)) / gamma (sr). Angles in
// [0, pi] rad, gamma in [0.5, 1e4].

fn lf_sigmoid(t: f32) -> f32 {
    if t >= 0.0 {
        return 1.0 / (1.0 + exp(-t));
    }
    let e = exp(t);
    return e / (1.0 + e);
}

// 2 pi (1 - exp(-gamma)) / gamma (sr): S_hat to S.
fn lf_isg_normaliser(gamma: f32) -> f32 {
    return 2.0 * LF_PI * lf_one_minus_exp_neg(gamma) / gamma;
}

// The paper's published logistic model (no texture; meant for gamma in [100, 1000]):
// g, h quartics in gamma / 100.
fn lf_isg_paper_slopes(gamma: f32) -> vec2<f32> {
    let x = gamma / 100.0;
    let g = (((-2.6856e-6 * x + 7e-4) * x - 0.0571) * x + 3.9529) * x + 17.6028;
    let h = (((-2.6875e-6 * x + 7e-4) * x - 0.0592) * x + 3.9900) * x + 17.5003;
    return vec2<f32>(g, h);
}

fn lf_isg_logistic(theta: f32, phi: f32, gh: vec2<f32>) -> f32 {
    return lf_sigmoid(gh.x * (theta - 0.5 * LF_PI)) * lf_sigmoid(gh.y * (phi - 0.5 * LF_PI));
}

// S_hat of the paper's model.
fn lf_isg_paper(theta: f32, phi: f32, gamma: f32) -> f32 {
    return lf_isg_logistic(theta, phi, lf_isg_paper_slopes(gamma));
}

// S_hat of the refitted logistic model, from the exported `isg-refit` texture (1D, RG:
// ln g, ln h on log gamma).
fn lf_isg_refit(tex: texture_2d<f32>, smp: sampler, p: LfTex, theta: f32, phi: f32, gamma: f32) -> f32 {
    return lf_isg_logistic(theta, phi, exp(lf_sample_1d(tex, smp, p, gamma).xy));
}

// (marginal, correction) of the separable model for one angle x: the texel's
// channels (k, k + 2) at (gamma, u(x)), u the warp, mirrored for x > pi/2.
fn lf_isg_best_factor(tex: texture_2d<f32>, smp: sampler, p: LfTex, k: u32, x: f32, gamma: f32, e_gamma: f32) -> vec2<f32> {
    let d = x - 0.5 * LF_PI;
    let h = lf_sin(0.5 * d);
    // q = 2 h^2 = 1 - sin x, without the cancellation near the axis.
    let q = 2.0 * h * h;
    let u = min(sqrt(lf_one_minus_exp_neg(gamma * q) / e_gamma), 1.0);
    let t = lf_sample_2d(tex, smp, p, gamma, u);
    var f = vec2<f32>(t.y, t.w);
    if k == 0u {
        f = vec2<f32>(t.x, t.z);
    }
    if d > 0.0 {
        return vec2<f32>(1.0 - f.x, -f.y);
    }
    return f;
}

// S_hat of the separable model A(theta) B(phi) + C(theta) D(phi), from the exported
// `isg-best` texture (2D (log gamma, u), RGBA: a, b, c, d).
fn lf_isg_best(tex: texture_2d<f32>, smp: sampler, p: LfTex, theta: f32, phi: f32, gamma: f32) -> f32 {
    let e_gamma = lf_one_minus_exp_neg(gamma);
    let ac = lf_isg_best_factor(tex, smp, p, 0u, theta, gamma, e_gamma);
    let bd = lf_isg_best_factor(tex, smp, p, 1u, phi, gamma, e_gamma);
    return ac.x * bd.x + ac.y * bd.y;
}

// Patch integral (sr, unit-amplitude SG) over theta in [t1, t2], phi in [p1, p2] from
// the four corners of S: (S(t2,p2) - S(t1,p2) - S(t2,p1) + S(t1,p1)); model 0 = paper,
// 1 = refit, 2 = best (the texture is unused by the paper model).
fn lf_isg_patch(tex: texture_2d<f32>, smp: sampler, p: LfTex, model: u32, t1: f32, t2: f32, p1: f32, p2: f32, gamma: f32) -> f32 {
    var s: vec4<f32>;
    if model == 0u {
        s = vec4<f32>(lf_isg_paper(t2, p2, gamma), lf_isg_paper(t1, p2, gamma), lf_isg_paper(t2, p1, gamma), lf_isg_paper(t1, p1, gamma));
    } else if model == 1u {
        s = vec4<f32>(lf_isg_refit(tex, smp, p, t2, p2, gamma), lf_isg_refit(tex, smp, p, t1, p2, gamma), lf_isg_refit(tex, smp, p, t2, p1, gamma), lf_isg_refit(tex, smp, p, t1, p1, gamma));
    } else {
        s = vec4<f32>(lf_isg_best(tex, smp, p, t2, p2, gamma), lf_isg_best(tex, smp, p, t1, p2, gamma), lf_isg_best(tex, smp, p, t2, p1, gamma), lf_isg_best(tex, smp, p, t1, p1, gamma));
    }
    return (s.x - s.y - s.z + s.w) * lf_isg_normaliser(gamma);
}

