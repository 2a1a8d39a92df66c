// lobefit-gpu render meunier: the kernel's own functions (prefixed mn_), then its body.
// The kernel's constants (N_IN, MAT_SIZE, MAXB, MAXL, DEPTH, MODE, WSET, THRESH,
// CAP_LIGHT, BUDGET, LIGHT_HALF_ANGLE_MIN, SHARP: the settings') come from gpu/src/meunier.rs;
// the scene follows the pixels' inputs in X (mn_scene), so one compiled kernel serves
// every scene, frame and image size;
// the formulas shared with renderers are the shader library's (tables/shaders/*.wgsl:
// lf_cap_exponent_any, lf_mask_weight, lf_sphere_cap_irradiance, lf_lobe_fraction_in_cap,
// lf_lobe_product). Not exported: only lobefit-gpu runs it.

struct MnLobe {
    s: f32,
    a: vec3<f32>,
    e: f32,
}

// The product of two lobes as one lobe (the lobe-product textures T, T2).
fn mn_product(l1: MnLobe, l2: MnLobe) -> MnLobe {
    let alpha = lf_angle_between(l1.a, l2.a);
    let q = lf_lobe_product(T, S, P, T2, P2, l1.e, l2.e, alpha);
    return MnLobe(l1.s * q.p * l2.s, lf_lobe_product_axis(l1.a, l2.a, q.t), q.e_r);
}

fn mn_integral(l: MnLobe) -> f32 {
    return l.s * 2.0 * LF_PI / (l.e + 1.0);
}

// Whether a product survives the threshold t_i (the runtime's product_sums).
fn mn_kept(l: MnLobe) -> bool {
    return l.s != 0.0 && abs(mn_integral(l)) >= THRESH;
}

// Where the scene starts in X: after the N.x pixels' inputs. There: the blocker
// count, the light count, the blockers (centre, radius), the lights (centre, radius,
// radiance), then the materials (MAT_SIZE each).
fn mn_scene() -> u32 {
    return N_IN * N.x;
}

fn mn_blockers() -> u32 {
    return u32(X[mn_scene()]);
}

fn mn_lights() -> u32 {
    return u32(X[mn_scene() + 1u]);
}

fn mn_sphere(b: u32) -> vec4<f32> {
    let k = mn_scene() + 2u + 4u * b;
    return vec4<f32>(X[k], X[k + 1u], X[k + 2u], X[k + 3u]);
}

// max over the spherical quadrilateral c0..c3 (great-circle edges) of a.x (the
// runtime's max_dot).
fn mn_max_dot(c0: vec3<f32>, c1: vec3<f32>, c2: vec3<f32>, c3: vec3<f32>, a: vec3<f32>) -> f32 {
    let c = array<vec3<f32>, 4>(c0, c1, c2, c3);
    let centre = c0 + c1 + c2 + c3;
    var inside = true;
    var best = -2.0;
    for (var k = 0u; k < 4u; k++) {
        let p = c[k];
        let q = c[(k + 1u) % 4u];
        let m0 = cross(p, q);
        let mlen = length(m0);
        best = max(best, max(dot(a, p), dot(a, q)));
        if mlen < 1e-30 {
            continue;
        }
        let m = m0 / mlen;
        let am = dot(a, m);
        if am * sign(dot(m, centre)) < 0.0 {
            inside = false;
        }
        let proj = a - am * m;
        let plen = length(proj);
        if plen > 1e-30 {
            let ph = proj / plen;
            if dot(cross(p, ph), m) >= 0.0 && dot(cross(ph, q), m) >= 0.0 {
                best = max(best, plen);
            }
        }
    }
    return select(best, 1.0, inside);
}

// The shadow (or c_unit) lobe v times the kept BRDF x light products, then the cosine.
fn mn_shade_vis(bl: array<MnLobe, MAXL>, nbl: u32, v: MnLobe, n: vec3<f32>) -> f32 {
    var total = 0.0;
    let cosine = MnLobe(1.0, n, 1.0);
    for (var k = 0u; k < MAXL; k++) {
        if k < nbl {
            let blv = mn_product(bl[k], v);
            if mn_kept(blv) {
                let f = mn_product(blv, cosine);
                if mn_kept(f) {
                    total += mn_integral(f);
                }
            }
        }
    }
    return total;
}
// ∫ max(a1·v, 0)^e1 max(a2·v, 0)^e2 dω for a sharp l2 by its expansion about a2, or
// −1 where it does not apply (the runtime's sharp_product_integral, same conditions).
fn mn_sharp(l1: MnLobe, l2: MnLobe) -> f32 {
    let u = clamp(dot(l1.a, l2.a), -1.0, 1.0);
    let e1 = l1.e;
    let e2 = l2.e;
    if !(e2 >= 1000.0 && u > 0.0 && e2 * u * u >= 100.0 * (e1 * e1 + e1 + 1.0)) {
        return -1.0;
    }
    let f = pow(u, e1);
    let f2 = f / (u * u);
    let f4 = f2 / (u * u);
    let lap = e1 * (e1 - 1.0) * f2 - e1 * (e1 + 1.0) * f;
    let lap_low = (e1 - 2.0) * (e1 - 3.0) * f4 - (e1 - 2.0) * (e1 - 1.0) * f2;
    let lap2 = e1 * (e1 - 1.0) * lap_low - e1 * (e1 + 1.0) * lap;
    let m1 = 1.0 / (e2 + 2.0);
    let m2 = 2.0 / ((e2 + 2.0) * (e2 + 3.0));
    return 2.0 * LF_PI / (e2 + 1.0) * (f + 0.5 * m1 * lap + m2 * (lap2 + 2.0 * lap) / 16.0);
}

// The shadow lobe v times each kept (BRDF x cosine) x radiance lobe: the light's cap
// model, where the radiance is uniform over the hemisphere (one product a leaf).
fn mn_shade_leaf(pc: array<MnLobe, MAXL>, npc: u32, v: MnLobe) -> f32 {
    var total = 0.0;
    for (var k = 0u; k < MAXL; k++) {
        if k < npc {
            var c = -1.0;
            if SHARP {
                c = mn_sharp(pc[k], v);
            }
            if c >= 0.0 {
                let val = pc[k].s * c * v.s;
                if val != 0.0 && abs(val) >= THRESH {
                    total += val;
                }
            } else {
                let f = mn_product(pc[k], v);
                if mn_kept(f) {
                    total += mn_integral(f);
                }
            }
        }
    }
    return total;
}
// ---- main: the kernel's body (the statements inside its entry point, kernel.rs)
    let p = vec3<f32>(x0, x1, x2);
    let n = vec3<f32>(x3, x4, x5);
    // The point's own proxies are drawn from [x13, x14) (own_proxy: the CPU's scene::Own).
    let own = vec2<i32>(i32(x13), i32(x14));
    let ns = mn_blockers();
    let nl = mn_lights();
    let lgt0 = mn_scene() + 2u + 4u * ns;
    var iters = 0u;
    var budget_flag = 0.0;
    // A point inside another blocker (a mesh's covering sphere below the ground) is
    // in its full shadow, as on the CPU (`Scene::buried`): radiance 0.
    var buried = false;
    for (var b = 0u; b < ns; b++) {
        iters += 1u;
        let s = mn_sphere(b);
        if !own_proxy(b, own, length(s.xyz - p), s.w) && length(s.xyz - p) <= s.w {
            buried = true;
        }
    }
    // The BRDF's lobes: the Lambertian term, then each Lafortune lobe (eq. 30).
    var brdf: array<MnLobe, MAXL>;
    let m0 = lgt0 + 5u * nl + u32(x12) * MAT_SIZE;
    brdf[0] = MnLobe(X[m0] / LF_PI, n, 0.0);
    var nb = 1u;
    let t0 = vec3<f32>(x6, x7, x8);
    let tt = normalize(t0 - dot(t0, n) * n);
    let bt = cross(n, tt);
    let wo = vec3<f32>(x9, x10, x11);
    let local = vec3<f32>(dot(wo, tt), dot(wo, bt), dot(wo, n));
    for (var j = 0u; j < MAXL - 1u; j++) {
        if f32(j) < X[m0 + 1u] {
            let k = m0 + 2u + 5u * j;
            let m = vec3<f32>(X[k], X[k + 1u], X[k + 2u]) * local;
            let len = length(m);
            if len != 0.0 && X[k + 3u] != 0.0 {
                brdf[nb] = MnLobe(X[k + 3u] * pow(len, X[k + 4u]), (m.x * tt + m.y * bt + m.z * n) / len, X[k + 4u]);
                nb += 1u;
            }
        }
    }
    var total = 0.0;
    for (var l = 0u; l < nl && !buried; l++) {
        iters += 1u;
        let k = lgt0 + 5u * l;
        let lc = vec3<f32>(X[k], X[k + 1u], X[k + 2u]);
        let radiance = X[k + 4u];
        let to = lc - p;
        let ld = length(to);
        let la = to / ld;
        let sa = X[k + 3u] / ld;
        let ca = sqrt(max((1.0 - sa) * (1.0 + sa), 0.0));
        let alpha = lf_asin(sa);
        // Blocker caps meeting the light's (axis, cos half-angle); a cap containing
        // the light's hides it.
        var rel: array<vec4<f32>, MAXB>;
        var nrel = 0u;
        var hidden = false;
        for (var b = 0u; b < ns; b++) {
            iters += 1u;
            let s = mn_sphere(b);
            let w = s.xyz - p;
            let d = length(w);
            if own_proxy(b, own, d, s.w) {
                continue;
            }
            if d - s.w >= ld {
                continue;
            }
            let ba = w / d;
            let q = s.w / d;
            let th = lf_asin(q);
            let gap = lf_angle_between(la, ba);
            if gap + alpha <= th {
                hidden = true;
                break;
            }
            if gap < th + alpha {
                if nrel < MAXB {
                    rel[nrel] = vec4<f32>(ba, sqrt(max((1.0 - q) * (1.0 + q), 0.0)));
                    nrel += 1u;
                } else {
                    budget_flag = 1.0;
                }
            }
        }
        if hidden {
            continue;
        }
        // The BRDF x light products: the paper's light lobe, or the uniform radiance
        // over the hemisphere (the light's cap then enters through the leaves' shares).
        var light = MnLobe(radiance, n, 0.0);
        if !CAP_LIGHT {
            let e = lf_cap_exponent_any(T3, S, P3, max(alpha, LIGHT_HALF_ANGLE_MIN));
            let sh = sin(0.5 * alpha);
            light = MnLobe(radiance * 4.0 * LF_PI * sh * sh * (e + 1.0) / (2.0 * LF_PI), la, e);
        }
        var bl: array<MnLobe, MAXL>;
        var nbl = 0u;
        for (var j = 0u; j < MAXL; j++) {
            if !CAP_LIGHT && j < nb {
                let r = mn_product(brdf[j], light);
                if mn_kept(r) {
                    bl[nbl] = r;
                    nbl += 1u;
                }
            }
        }
        // Under the cap model: each BRDF lobe x the cosine, times the radiance (the
        // lit term's lobe, and the shadow leaves' partner).
        var pcs: array<MnLobe, MAXL>;
        var npc = 0u;
        if CAP_LIGHT {
            // The unoccluded light over its cap.
            for (var j = 0u; j < MAXL; j++) {
                if j < nb {
                    let b = brdf[j];
                    let pc = mn_product(b, MnLobe(1.0, n, 1.0));
                    if b.e == 0.0 && dot(b.a, n) >= 1.0 - 1e-6 {
                        total += b.s * radiance * lf_sphere_cap_irradiance(sa, dot(la, n));
                    } else {
                        total += radiance * mn_integral(pc)
                            * lf_lobe_fraction_in_cap(lf_angle_between(pc.a, la), alpha, pc.e);
                    }
                    let lit = MnLobe(radiance * pc.s, pc.a, pc.e);
                    if mn_kept(lit) {
                        pcs[npc] = lit;
                        npc += 1u;
                    }
                }
            }
        } else {
            total += mn_shade_vis(bl, nbl, MnLobe(1.0, n, 0.0), n);
        }
        if nrel == 0u {
            continue;
        }
        // Eq. 39's weights at this light's dist = 1 / (2 tan alpha).
        let dist = 0.5 * ca / sa;
        var wts: array<f32, 5>;
        for (var j = 0u; j < 5u; j++) {
            if j < DEPTH {
                wts[j] = lf_mask_weight(T4, S, P4, WSET, MODE, DEPTH, j + 1u, dist);
            }
        }
        // The square S_unit at distance dist: (s, t) in [-1/2, 1/2]^2 -> w + s u + t v.
        let sg = select(-1.0, 1.0, la.z >= 0.0);
        let ea = -1.0 / (sg + la.z);
        let eb = la.x * la.y * ea;
        let kk = 2.0 * sa / ca;
        let u = kk * vec3<f32>(1.0 + sg * la.x * la.x * ea, sg * eb, -sg * la.x);
        let v = kk * vec3<f32>(eb, sg + la.y * la.y * ea, -la.y);
        // Depth-first walk: (s0, t0, side, depth).
        var stack: array<vec4<f32>, 24>;
        stack[0] = vec4<f32>(-0.5, -0.5, 1.0, 0.0);
        var sp = 1u;
        loop {
            if sp == 0u || iters >= BUDGET {
                break;
            }
            iters += 1u;
            sp -= 1u;
            let cell = stack[sp];
            let h = cell.z;
            let c0 = normalize(la + cell.x * u + cell.y * v);
            let c1 = normalize(la + (cell.x + h) * u + cell.y * v);
            let c2 = normalize(la + (cell.x + h) * u + (cell.y + h) * v);
            let c3 = normalize(la + cell.x * u + (cell.y + h) * v);
            var full = false;
            for (var b = 0u; b < nrel; b++) {
                iters += 1u;
                let r = rel[b];
                if min(min(dot(r.xyz, c0), dot(r.xyz, c1)), min(dot(r.xyz, c2), dot(r.xyz, c3))) >= r.w {
                    full = true;
                    break;
                }
            }
            if !full {
                var meets = false;
                for (var b = 0u; b < nrel; b++) {
                    iters += 1u;
                    let r = rel[b];
                    if mn_max_dot(c0, c1, c2, c3, r.xyz) >= r.w {
                        meets = true;
                        break;
                    }
                }
                if !meets {
                    continue;
                }
            }
            let depth = u32(cell.w);
            let axis = normalize(c0 + c1 + c2 + c3);
            if full || (MODE == 1u && depth == DEPTH) {
                var wd = wts[max(depth, 1u) - 1u];
                if wd != 0.0 {
                    let beta = max(max(lf_angle_between(axis, c0), lf_angle_between(axis, c1)),
                                   max(lf_angle_between(axis, c2), lf_angle_between(axis, c3)));
                    let e = lf_cap_exponent_any(T3, S, P3, beta);
                    if CAP_LIGHT {
                        wd *= lf_lobe_fraction_in_cap(lf_angle_between(axis, la), alpha, e);
                    }
                    if wd != 0.0 {
                        if CAP_LIGHT {
                            total += mn_shade_leaf(pcs, npc, MnLobe(-wd, axis, e));
                        } else {
                            total += mn_shade_vis(bl, nbl, MnLobe(-wd, axis, e), n);
                        }
                    }
                }
            }
            if !full && depth < DEPTH {
                // Children pushed last-first: visited in the runtime's order.
                let g = 0.5 * h;
                let d1 = f32(depth + 1u);
                stack[sp] = vec4<f32>(cell.x, cell.y + g, g, d1);
                stack[sp + 1u] = vec4<f32>(cell.x + g, cell.y + g, g, d1);
                stack[sp + 2u] = vec4<f32>(cell.x + g, cell.y, g, d1);
                stack[sp + 3u] = vec4<f32>(cell.x, cell.y, g, d1);
                sp += 4u;
            }
        }
    }
    if iters >= BUDGET {
        budget_flag = 2.0;
    }
    // Never negative, as the CPU's Meunier::shade: overshooting shadow lobes clamp to 0.
    Y[o] = max(total, 0.0);
