// lobefit-gpu render shexp: the kernel's own functions (shexp_term, shexp_lit), then
// its body. The kernel's constants (N_IN, NW, W_INDEX, TERRAIN_ABOVE_TANGENT,
// ATTENUATION, EPS_*: the settings'; COEFFS: whether it also writes the integrand)
// come from gpu/src/shexp.rs; the scene follows the pixels' inputs in X
// (shexp_scene), so one compiled kernel serves every scene, frame and image size.
// gpu/src/shexp.rs also puts in the body the count of per-pixel inputs before
// the horizon angles (HIT_INPUTS_) and the sphere blockers' log (BLOCKER_LOG_: the
// library's lf_log_zh_blocker or Ren's lf_shexp); the formulas shared with renderers are
// the shader library's. Outputs per pixel: the radiance (clamped at 0), the budget
// flag; with COEFFS also the unclamped radiance and the integrand's 16 SH coefficients.
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

// One BRDF term: exp* (HYB) of the log visibility f plus the term's log-ZH lobe z
// about `axis`: the term's band-limited visibility × BRDF × cosine.
fn shexp_term(f: array<f32, 16>, z: array<f32, 8>, axis: vec3<f32>) -> array<f32, 16> {
    let t = lf_zh_to_sh(4u, z, axis);
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
    // in its full shadow, as on the CPU (`Scene::buried`): radiance 0.
    var buried = false;
    for (var b = 0u; b < ns; b++) {
        let s = sph(b);
        if !own_proxy(b, own, length(s.xyz - p), s.w) && length(s.xyz - p) <= s.w {
            buried = true;
        }
    }
    var f: array<f32, 16>;
    if X[shexp_scene() + 1u] != 0.0 {
        var sigma: array<f32, 64>;
        for (var k = 0u; k < NW; k++) {
            sigma[k] = X[i * N_IN + HIT_INPUTS_u + k];
        }
        var v: array<f32, 64>;
        if TERRAIN_ABOVE_TANGENT {
            // The tangent plane's elevation per azimuth (n.d = 0).
            var lower: array<f32, 64>;
            for (var k = 0u; k < NW; k++) {
                let phi = 2.0 * LF_PI * f32(k) / f32(NW);
                lower[k] = clamp(atan2(-(n.x * cos(phi) + n.y * sin(phi)), n.z), -0.5 * LF_PI, 0.5 * LF_PI);
            }
            v = lf_wedge_compose_between(T, P, W_INDEX, 4u, EPS_TERRAIN, lower, sigma);
        } else {
            v = lf_wedge_compose(T, P, W_INDEX, 4u, EPS_TERRAIN, sigma);
        }
        for (var k = 0u; k < 16u; k++) {
            f[k] = v[k];
        }
    }
    for (var b = 0u; b < ns; b++) {
        let s = sph(b);
        let w = s.xyz - p;
        let d = length(w);
        let dir = w / d;
        // sin theta_b; a cap wholly below the tangent plane cannot shadow the point.
        let sb = s.w / d;
        if own_proxy(b, own, d, s.w) || dot(n, dir) < -sb {
            continue;
        }
        let theta = lf_asin(sb);
        var zh = BLOCKER_LOG_;
        if ATTENUATION {
            for (var l = 0u; l < 4u; l++) {
                zh[l] *= sb;
            }
        }
        let t = lf_zh_to_sh(4u, zh, dir);
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
    var budget_flag = 0.0;
