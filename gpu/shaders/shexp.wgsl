// lobefit-gpu render shexp: the kernel's own functions (shexp_slice, shexp_terrain,
// shexp_term, shexp_lit), then its body. The kernel's constants (N_IN, NW, W_INDEX,
// TERRAIN_ABOVE_TANGENT, ATTENUATION, EPS_*: the settings'; COEFFS: whether it also
// writes the integrand) come from gpu/src/shexp.rs; the scene follows the pixels'
// inputs in X (shexp_scene), so one compiled kernel serves every scene, frame and
// image size. gpu/src/shexp.rs also puts in the body the count of per-pixel inputs
// before the horizon angles (HIT_INPUTS_) and the sphere blockers' log (BLOCKER_LOG_:
// the library's lf_log_zh_blocker or Ren's lf_shexp). The formulas shared with
// renderers are the shader library's (its order-4 lf_zh_to_sh16 among them), but for
// the terrain's composition, laid out for the hardware in shexp_terrain (docs/gpu.md,
// "Kernel speed"). Outputs per pixel: the radiance (clamped at 0), the budget flag;
// with COEFFS also the unclamped radiance and the integrand's 16 SH coefficients.
// Not exported: only lobefit-gpu runs it.

// Where the scene starts in X: after the N.x pixels' inputs. There: the sphere
// count, whether a height field is present, the spheres (centre, radius), then the
// light's 16 SH coefficients.
fn shexp_scene() -> u32 {
    return N_IN * N.x;
}

fn shexp_spheres() -> u32 {
    return u32(X[shexp_scene()]);
}

fn sph(b: u32) -> vec4<f32> {
    let k = shexp_scene() + 2u + 4u * b;
    return vec4<f32>(X[k], X[k + 1u], X[k + 2u], X[k + 3u]);
}

// Node k's j-th vec4 of the sphere hierarchy (with CUT), after the light's 16
// coefficients: its reach, bound, the sphere the cut gives, (left, right) or (-1, leaf).
fn node(k: u32, j: u32) -> vec4<f32> {
    let i = shexp_scene() + 2u + 4u * shexp_spheres() + 16u + 16u * k + 4u * j;
    return vec4<f32>(X[i], X[i + 1u], X[i + 2u], X[i + 3u]);
}

// The terrain's slice k at order 4 (lf_wedge_slice; with TERRAIN_ABOVE_TANGENT the
// part above the tangent plane, as lf_wedge_compose_between takes it).
fn shexp_slice(sigma: f32, n: vec3<f32>, k: u32) -> array<f32, 8> {
    if !TERRAIN_ABOVE_TANGENT {
        return lf_wedge_slice(sigma, EPS_TERRAIN, 4u);
    }
    // The tangent plane's elevation in azimuth phi_k (n.d = 0).
    let phi = 2.0 * LF_PI * f32(k) / f32(NW);
    let lower = clamp(atan2(-(n.x * cos(phi) + n.y * sin(phi)), n.z), -0.5 * LF_PI, 0.5 * LF_PI);
    var v = lf_wedge_slice(max(sigma, lower), EPS_TERRAIN, 4u);
    let low = lf_wedge_slice(lower, EPS_TERRAIN, 4u);
    for (var j = 0u; j < 4u; j++) {
        v[j] -= low[j];
    }
    return v;
}

// The terrain's log-SH visibility at order 4 from the pixel's NW horizon elevations
// (inputs from `at` on): lf_wedge_compose(_between) of the shader library, with the
// wedge operator's 16 x 8 entries fetched once per pixel instead of once per wedge,
// and 16-entry vectors (on lavapipe the texel fetches were most of the terrain's cost).
fn shexp_terrain(n: vec3<f32>, at: u32) -> array<f32, 16> {
    var m: array<f32, 128>;
    for (var r = 0u; r < 16u; r++) {
        for (var j = 0u; j < 4u; j++) {
            m[8u * r + j] = lf_wedge_entry(T, P, W_INDEX, r, j);
            m[8u * r + 4u + j] = lf_wedge_entry(T, P, W_INDEX, r, 8u + j);
        }
    }
    var out: array<f32, 16>;
    var v_a = shexp_slice(X[at], n, 0u);
    for (var k = 0u; k < NW; k++) {
        let next = (k + 1u) % NW;
        let v_b = shexp_slice(X[at + next], n, next);
        var w: array<f32, 16>;
        for (var r = 0u; r < 16u; r++) {
            var sum = 0.0;
            for (var j = 0u; j < 4u; j++) {
                sum += m[8u * r + j] * v_a[j] + m[8u * r + 4u + j] * v_b[j];
            }
            w[r] = sum;
        }
        // Turned by phi_k about z (lf_sh_rotate_z): band l mixes (l, m) and (l, -m).
        let alpha = 2.0 * LF_PI * f32(k) / f32(NW);
        let c1 = lf_cos(alpha);
        let s1 = lf_sin(alpha);
        let c2 = c1 * c1 - s1 * s1;
        let s2 = 2.0 * s1 * c1;
        let c3 = c2 * c1 - s2 * s1;
        let s3 = s2 * c1 + c2 * s1;
        let cs = array<f32, 4>(1.0, c1, c2, c3);
        let sn = array<f32, 4>(0.0, s1, s2, s3);
        for (var l = 0u; l < 4u; l++) {
            let base = l * (l + 1u);
            out[base] += w[base];
            for (var q = 1u; q <= l; q++) {
                let a = w[base + q];
                let b = w[base - q];
                out[base + q] += a * cs[q] - b * sn[q];
                out[base - q] += a * sn[q] + b * cs[q];
            }
        }
        v_a = v_b;
    }
    return out;
}

// One BRDF term: exp* (HYB) of the log visibility f plus the term's log-ZH lobe z
// about `axis`: the term's band-limited visibility × BRDF × cosine.
fn shexp_term(f: array<f32, 16>, z: array<f32, 8>, axis: vec3<f32>) -> array<f32, 16> {
    let t = lf_zh_to_sh16(z, axis);
    var g: array<f32, 16>;
    for (var i = 0u; i < 16u; i++) {
        g[i] = f[i] + t[i];
    }
    return lf_shexp_hyb(T2, S, P2, 4u, g);
}

// An SH vector dotted with the light's.
fn shexp_lit(e: array<f32, 16>) -> f32 {
    let light0 = shexp_scene() + 2u + 4u * shexp_spheres();
    var sum = 0.0;
    for (var i = 0u; i < 16u; i++) {
        sum += e[i] * X[light0 + i];
    }
    return sum;
}
// ---- main: the kernel's body (the statements inside its entry point, kernel.rs)
    let p = vec3<f32>(x0, x1, x2);
    let n = vec3<f32>(x3, x4, x5);
    let wo = vec3<f32>(x6, x7, x8);
    // The point's own proxies are drawn from [x12, x13) (own_proxy: the CPU's scene::Own).
    let own = vec2<i32>(i32(x12), i32(x13));
    let ns = shexp_spheres();
    // A point inside another blocker (a mesh's covering sphere below the ground) is
    // in its full shadow, as on the CPU (`Scene::buried`): radiance 0. Set in the
    // blockers' loop below.
    var buried = false;
    var f: array<f32, 16>;
    if X[shexp_scene() + 1u] != 0.0 {
        f = shexp_terrain(n, i * N_IN + HIT_INPUTS_u);
    }
    // The blockers: every sphere (b = 0 .. ns), or with CUT the sphere hierarchy's cut
    // from p (the CPU's Settings::cut: the stand-in of a node whose bound subtends
    // less than the cut angle from outside it, the leaves reached). The walk counts its
    // passes and each blocker's loops (shexp.rs's PER_SPHERE) against WALK_BUDGET and flags the
    // pixel past it (3).
    var stack = array<u32, 64>();
    var sp = 0u;
    if CUT {
        stack[0] = NN - 1u;
        sp = 1u;
    }
    var walk = 0u;
    var walk_flag = 0.0;
    var next = 0u;
    loop {
        var s = vec4<f32>(0.0);
        // The set index of a leaf (the own-sphere and buried tests); none for a stand-in.
        var b = 0xffffffffu;
        if CUT {
            // No cone: every cap above the tangent plane counts.
            let c = cut_next(&stack, &sp, &walk, WALK_BUDGET, p, SIN_CUT, n, 4.0, vec2<f32>(0.0));
            if c.state == 2u {
                walk_flag = 3.0;
            }
            if c.state != 0u {
                break;
            }
            s = c.s;
            b = c.b;
            walk += PER_SPHERE_u;
        } else {
            if next >= ns {
                break;
            }
            s = sph(next);
            b = next;
            next += 1u;
        }
        let w = s.xyz - p;
        let d = length(w);
        let dir = w / d;
        if own_proxy(b, own, d, s.w) {
            continue;
        }
        if d <= s.w {
            // A stand-in that reaches past its node's bound may hold p; no leaf of its
            // subtree does (the node would have been opened), so it is not buried.
            buried = buried || b != 0xffffffffu;
            continue;
        }
        // sin theta_b; a cap wholly below the tangent plane cannot shadow the point.
        let sb = s.w / d;
        if dot(n, dir) < -sb {
            continue;
        }
        let theta = lf_asin(sb);
        var zh = BLOCKER_LOG_;
        if ATTENUATION {
            for (var l = 0u; l < 4u; l++) {
                zh[l] *= sb;
            }
        }
        let t = lf_zh_to_sh16(zh, dir);
        for (var k = 0u; k < 16u; k++) {
            f[k] += t[k];
        }
    }
    var total = 0.0;
    // With COEFFS, the integrand's SH vector Σ_t w_t g_t (the hybrid estimator's
    // control variate, gpu/src/mc.rs).
    var coeffs: array<f32, 16>;
    if x9 > 0.0 && !buried {
        let e = shexp_term(f, lf_log_zh_diffuse(EPS_BRDF, 4u), n);
        total += x9 * shexp_lit(e);
        if COEFFS {
            for (var k = 0u; k < 16u; k++) {
                coeffs[k] += x9 * e[k];
            }
        }
    }
    if x10 > 0.0 && !buried {
        let m = normalize(2.0 * dot(n, wo) * n - wo);
        let weight = x10 * (x11 + 2.0) / (x11 + 1.0) * max(dot(n, m), 0.0);
        if weight > 0.0 {
            let e = shexp_term(f, lf_log_zh_phong(EPS_BRDF, x11, 4u), m);
            total += weight * shexp_lit(e);
            if COEFFS {
                for (var k = 0u; k < 16u; k++) {
                    coeffs[k] += weight * e[k];
                }
            }
        }
    }
    // A band-limited product rings below zero in dark places; radiance cannot (the
    // CPU's `radiance` clamps too). The integrand keeps its unclamped value.
    Y[o] = max(total, 0.0);
    if COEFFS {
        Y[o + 2u] = total;
        for (var k = 0u; k < 16u; k++) {
            Y[o + 3u + k] = coeffs[k];
        }
    }
    var budget_flag = walk_flag;
