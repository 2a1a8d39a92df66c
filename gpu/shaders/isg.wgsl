// lobefit-gpu render isg: the kernel's own functions (prefixed isg_), then its body.
// The kernel's constants and accessors (NS, NE, sph, env: the data after the N.x
// pixels' inputs) and its per-row cap intervals (the placeholder line below, unrolled
// over the 20 rows a grid may have) from gpu/src/isg.rs; the formulas shared with renderers are the shader library's
// (lf_isg_best, lf_lobe_to_sg, lf_sg_product, lf_sg_clamped_cosine, lf_isg_cone, ...).
// Not exported: only lobefit-gpu runs it.

// The columns j < k of a row whose centres lo + (j + 1/2) / inv lie in [a0, a1], as
// bits.
fn isg_columns(a0: f32, a1: f32, lo: f32, inv: f32, k: u32) -> u32 {
    let j0 = i32(clamp(ceil((a0 - lo) * inv - 0.5), 0.0, 32.0));
    let j1 = i32(clamp(floor((a1 - lo) * inv - 0.5), -1.0, f32(k) - 1.0));
    if j0 > j1 {
        return 0u;
    }
    return ((2u << u32(j1)) - 1u) & ~((1u << u32(j0)) - 1u);
}

// acos(q / r) for |q| < r, to ~1e-7: Abramowitz & Stegun 4.4.46 (a degree-7 polynomial
// times sqrt(1 - x), error <= 2e-8 on [0, 1]) with 1 - |x| formed as (r - |q|) / r, exact
// near the ends. The drivers' acos loses the half-width there (fig12-diffuse: RMS
// 9.8e-5 of the peak against the CPU with acos on llvmpipe); their atan2, which is
// exact enough, took 30 % of the kernel's time on llvmpipe.
fn isg_acos_ratio(q: f32, r: f32) -> f32 {
    let x = abs(q) / r;
    let p = ((((((-0.0012624911 * x + 0.0066700901) * x - 0.0170881256) * x + 0.0308918810) * x
        - 0.0501743046) * x + 0.0889789874) * x - 0.2145988016) * x + 1.5707963050;
    let a = sqrt(max((r - abs(q)) / r, 0.0)) * p;
    return select(a, LF_PI - a, q < 0.0);
}

// The visible integral of g: `total` minus g over the occluded patches of its cone;
// with `cosine`, each occluded patch weighted by max(n.d, 0) / cs(d) and patches below
// the horizon not counted (the CPU's visible_with).
//
// Laid out for the hardware (and for llvmpipe's budget of 65 535 loop iterations an
// invocation): the blockers whose cap meets the cone are gathered once, and each one's
// cap written into per-row bit masks of the k x k patch grid in closed form (the
// placeholder line below, the rows unrolled from gpu/src/isg.rs: a cap covers the
// centres of row i where a cos(phi) + b sin(phi) >= cos(beta) - c, one interval of
// phi); the patch loop then
// reads a bit per patch, no loop over blockers inside it. The best model's separable
// factors are taken once per grid edge (2 (k + 1) lookups, not 8 per occluded patch):
// the CPU's per-edge factor cache.
fn isg_visible(g: LfSg, total: f32, cs: LfSg, cosine: bool, n: vec3<f32>, x: vec3<f32>, own: vec2<i32>) -> f32 {
    if g.amplitude == 0.0 {
        return 0.0;
    }
    let gamma = clamp(g.sharpness, 0.5, 1e4);
    let cone = lf_isg_cone(g.sharpness, 0.01);
    let z = g.axis;
    let y = lf_any_orthonormal(z);
    let xa = cross(y, z);
    let k = u32(clamp(ceil(2.0 * cone * sqrt(gamma) * 3.0), 10.0, 20.0));
    let lo = 0.5 * LF_PI - cone;
    let step = 2.0 * cone / f32(k);
    let inv = f32(k) / (2.0 * cone);
    // The rows' (sin, cos) of their centres' polar angle, taken once for every cap.
    var trig = array<vec2<f32>, 20>();
    for (var i = 0u; i < k; i++) {
        let th = lo + (f32(i) + 0.5) * step;
        trig[i] = vec2<f32>(sin(th), cos(th));
    }
    // Bit j of rows[i]: a blocker's cap covers the centre of patch (i, j).
    var rows = array<u32, 20>();
    var any = 0u;
    // The blockers: every sphere (b = 0 .. NS), or with CUT the sphere hierarchy's cut
    // from x culled against the cone (the CPU's Blockers::cut): the stand-in of a node
    // whose bound subtends less than the cut angle from outside it, the leaves reached,
    // subtrees whose reach lies outside the cone skipped.
    let cone_cs = vec2<f32>(lf_cos(cone), lf_sin(cone));
    var stack = array<u32, 64>();
    var sp = 0u;
    if CUT {
        stack[0] = NN - 1u;
        sp = 1u;
    }
    var next = 0u;
    // The pixel's walk passes so far (isg_walk: every product's walk counts).
    var walk = isg_walk;
    loop {
        if CUT {
            walk += 1u;
        }
        var s = vec4<f32>(0.0);
        // The set index of a leaf (the own-sphere test); none for a stand-in.
        var b = 0xffffffffu;
        if CUT {
            let c = cut_next(&stack, &sp, &walk, WALK_BUDGET, x, SIN_CUT, z, cone, cone_cs);
            if c.state == 2u {
                isg_flag = 3.0;
            }
            if c.state != 0u {
                break;
            }
            s = c.s;
            b = c.b;
        } else {
            if next >= NS {
                break;
            }
            s = sph(next);
            b = next;
            next += 1u;
        }
        let w = s.xyz - x;
        let d = length(w);
        if own_proxy(b, own, d, s.w) || d <= s.w {
            continue;
        }
        let u = w / d;
        if lf_angle_between(u, z) > cone + lf_asin(s.w / d) {
            continue;
        }
        // The patch centre d(th, ph) = xa sin th cos ph + y cos th + z sin th sin ph is
        // covered where dot(u, d) >= cos(beta), cos(beta) = sqrt(1 - (r/d)^2).
        let cb = sqrt(max(1.0 - (s.w / d) * (s.w / d), 0.0));
        // Row i's condition a cos(ph) + b sin(ph) >= q: (a, b) = sin(th_i) (ux, uz), of
        // length r = su sin(th_i) and azimuth ph0 (sin(th_i) > 0 on the grid).
        let ux = dot(u, xa);
        let uy = dot(u, y);
        let uz = dot(u, z);
        let su = sqrt(ux * ux + uz * uz);
        let ph0 = atan2(uz, ux);
    //#ISG_ROWS
    }
    isg_walk = walk;
    // Whether the tangent plane may hide a patch centre (the CPU's `horizon`): not with
    // the cosine (a direction below it weighs 0 there), nor where the grid lies wholly
    // above it (within acos(cos^2 cone) of the axis). Else only covered patches count.
    let cc = cos(cone);
    let horizon = !cosine && lf_angle_between(n, z) + acos(clamp(cc * cc, -1.0, 1.0)) >= 0.5 * LF_PI - 1e-6;
    // The separable factors at the grid's edges, once each.
    var ft = array<vec2<f32>, 21>();
    var fp = array<vec2<f32>, 21>();
    if any != 0u || horizon {
        let e_gamma = lf_one_minus_exp_neg(gamma);
        for (var e = 0u; e <= k; e++) {
            let a = clamp(lo + f32(e) * step, 0.0, LF_PI);
            ft[e] = lf_isg_best_factor(T, S, P, 0u, a, gamma, e_gamma);
            fp[e] = lf_isg_best_factor(T, S, P, 1u, a, gamma, e_gamma);
        }
    } else {
        return total;
    }
    let norm = lf_isg_normaliser(gamma);
    var hidden = 0.0;
    for (var i = 0u; i < k; i++) {
        let st = trig[i].x;
        let ct = trig[i].y;
        let row = rows[i];
        if row == 0u && !horizon {
            continue;
        }
        // Without the horizon only the covered patches count: their bits, lowest first.
        var left = row;
        if horizon {
            left = (2u << (k - 1u)) - 1u;
        }
        loop {
            if left == 0u {
                break;
            }
            let j = firstTrailingBit(left);
            left &= left - 1u;
            let blocked = ((row >> j) & 1u) != 0u;
            // Columns share the rows' centres: (sin, cos) of phi_j is trig[j].
            let d = xa * (st * trig[j].y) + y * ct + z * (st * trig[j].x);
            let c = dot(n, d);
            var wgt = 0.0;
            if cosine {
                if c > 0.0 {
                    wgt = c / lf_sg_eval(cs, d);
                }
            } else if c <= 0.0 || blocked {
                wgt = 1.0;
            }
            if wgt != 0.0 {
                let sh = dot(ft[i + 1u], fp[j + 1u]) - dot(ft[i], fp[j + 1u]) - dot(ft[i + 1u], fp[j]) + dot(ft[i], fp[j]);
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
        if x10 > 0.0 && !EQ9 {
            let g = lf_sg_product(l, lobe);
            specular += isg_visible(g, lf_sg_integral(g), lobe, false, n, p, own);
        }
    }
    // With the scene's Γ_L (EQ9), the specular term is Iwasaki et al.'s eq. 9: the
    // integral of L times the BRDF's SG, from Γ_L (T3) where its sharpness is on the
    // ladder, else from the lobes, times the SG's visible fraction (the CPU's
    // Specular::Eq9Prefiltered). The placeholder line below is that block, or nothing.
    //#ISG_EQ9
    // Radiance is never negative (the CPU pipeline clamps its sum too).
    Y[o] = max(x9 / LF_PI * diffuse + max(dot(n, r), 0.0) * specular, 0.0);
    var budget_flag = isg_flag;
