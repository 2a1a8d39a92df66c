// lobefit-gpu render isg: the kernel's own functions (prefixed isg_), then its body.
// The kernel's constants and accessors (NS, NW, NE, sph, env: the data after the
// N.x pixels' inputs) and its
// per-patch blocker tests (the placeholder line below, unrolled over the spheres) from
// gpu/src/isg.rs; the formulas shared with renderers are the shader library's
// (lf_isg_best, lf_lobe_to_sg, lf_sg_product, lf_sg_clamped_cosine, lf_isg_cone, ...).
// Not exported: only lobefit-gpu runs it.

// Whether the cap of sphere s (centre, radius) seen from x covers the direction d.
fn isg_covers(s: vec4<f32>, x: vec3<f32>, d: vec3<f32>) -> bool {
    let w = s.xyz - x;
    return dot(w, d) >= sqrt(max(dot(w, w) - s.w * s.w, 0.0));
}

// The visible integral of g: `total` minus g over the occluded patches of its cone;
// with `cosine`, each occluded patch weighted by max(n.d, 0) / cs(d) and patches below
// the horizon not counted (the CPU's visible_with).
fn isg_visible(g: LfSg, total: f32, cs: LfSg, cosine: bool, n: vec3<f32>, x: vec3<f32>, own: vec2<i32>) -> f32 {
    if g.amplitude == 0.0 {
        return 0.0;
    }
    let gamma = clamp(g.sharpness, 0.5, 1e4);
    let cone = lf_isg_cone(g.sharpness, 0.01);
    let z = g.axis;
    let y = lf_any_orthonormal(z);
    let xa = cross(y, z);
    // The blockers whose cap meets the cone, as a bit mask. (llvmpipe ends any loop
    // after 65 535 iterations of an invocation: a loop over these blockers inside the
    // patch loop went past that at busy pixels, so the test per patch is unrolled.)
    var mask = array<u32, NW>();
    for (var b = 0u; b < NS; b++) {
        let s = sph(b);
        let w = s.xyz - x;
        let d = length(w);
        if !own_proxy(b, own, d, s.w) && d > s.w {
            if lf_angle_between(w / d, z) <= cone + lf_asin(s.w / d) {
                mask[b / 32u] |= 1u << (b % 32u);
            }
        }
    }
    let k = u32(clamp(ceil(2.0 * cone * sqrt(gamma) * 3.0), 10.0, 20.0));
    let lo = 0.5 * LF_PI - cone;
    let step = 2.0 * cone / f32(k);
    let norm = lf_isg_normaliser(gamma);
    var hidden = 0.0;
    for (var i = 0u; i < k; i++) {
        let th = lo + (f32(i) + 0.5) * step;
        let st = sin(th);
        let ct = cos(th);
        for (var j = 0u; j < k; j++) {
            let ph = lo + (f32(j) + 0.5) * step;
            let d = xa * (st * cos(ph)) + y * ct + z * (st * sin(ph));
            let c = dot(n, d);
            var blocked = false;
BLOCKED_TESTS            var wgt = 0.0;
            if cosine {
                if c > 0.0 && blocked {
                    wgt = c / lf_sg_eval(cs, d);
                }
            } else if c <= 0.0 || blocked {
                wgt = 1.0;
            }
            if wgt != 0.0 {
                let t1 = clamp(lo + f32(i) * step, 0.0, LF_PI);
                let t2 = clamp(lo + f32(i + 1u) * step, 0.0, LF_PI);
                let p1 = clamp(lo + f32(j) * step, 0.0, LF_PI);
                let p2 = clamp(lo + f32(j + 1u) * step, 0.0, LF_PI);
                let sh = lf_isg_best(T, S, P, t2, p2, gamma) - lf_isg_best(T, S, P, t1, p2, gamma)
                    - lf_isg_best(T, S, P, t2, p1, gamma) + lf_isg_best(T, S, P, t1, p1, gamma);
                hidden += wgt * sh * norm;
            }
        }
    }
    return total - g.amplitude * hidden;
}
// ---- main: the kernel's body (the statements inside its entry point, kernel.rs)
    let p = vec3<f32>(x0, x1, x2);
    let n = vec3<f32>(x3, x4, x5);
    let wo = vec3<f32>(x6, x7, x8);
    // The point's own proxies are drawn from [x12, x13) (own_proxy: the CPU's scene::Own).
    let own = vec2<i32>(i32(x12), i32(x13));
    // A point inside a blocker (a mesh's covering sphere) is in its full shadow (the
    // CPU's Scene::buried): radiance 0.
    var buried = false;
    for (var b = 0u; b < NS; b++) {
        let s = sph(b);
        if !own_proxy(b, own, length(s.xyz - p), s.w) && length(s.xyz - p) <= s.w {
            buried = true;
        }
    }
    let cs = lf_lobe_to_sg(T2, S, P2, n, 1.0, 1.0);
    let r = normalize(2.0 * dot(n, wo) * n - wo);
    let lobe = lf_lobe_to_sg(T2, S, P2, r, x11, x10 * (x11 + 2.0) / (2.0 * LF_PI));
    var diffuse = 0.0;
    var specular = 0.0;
    for (var e = 0u; e < NE && !buried; e++) {
        let l = env(e);
        if x9 > 0.0 {
            let t = l.amplitude * lf_sg_clamped_cosine(l, n);
            diffuse += isg_visible(lf_sg_product(l, cs), t, cs, true, n, p, own);
        }
        if x10 > 0.0 {
            let g = lf_sg_product(l, lobe);
            specular += isg_visible(g, lf_sg_integral(g), lobe, false, n, p, own);
        }
    }
    // Radiance is never negative (the CPU pipeline clamps its sum too).
    Y[o] = max(x9 / LF_PI * diffuse + max(dot(n, r), 0.0) * specular, 0.0);
    var budget_flag = 0.0;
