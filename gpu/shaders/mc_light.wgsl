// lobefit-gpu's Monte Carlo kernel for Meunier's scenes (spheres, one spherical light,
// Lambert and Lafortune materials; a height field and meshes' triangles where the
// scene has them): per pixel, SPP directions uniform in the light's cap (the CPU's
// `meunier::render::reference`), each lit when nothing but the pixel's own sphere or
// triangle meets the ray before the light (the CPU's `Scene::light_visible`). The
// constants (NS, NL, N_IN, NODES, STACK, LIGHT, QMC, HF_*, NM, MSTACK), the accessor
// sph and the data's places in X (as mc.wgsl's) come from gpu/src/mc.rs; uniforms and
// visibility are mc.wgsl's functions (mc_point, mc_occluded), shared through the
// kernel's source. Inputs per pixel: the point, the normal, k_d/π, the own sphere,
// mesh and triangle (−1: none), then NL Lafortune lobes as (q, ρ, n) with the lobe's
// value ρ max(q·v, 0)^n (q = C ⊙ the view direction in the surface's frame, back in
// world space: exact). Outputs: Σ f, Σ f², 0, the budget flag.

// ---- main: the kernel's body (the statements inside its entry point, kernel.rs)
    var budget_flag = 0.0;
    let x = vec3<f32>(x0, x1, x2);
    let n = normalize(vec3<f32>(x3, x4, x5));
    let f_d = x6;
    let own = i32(x7);
    let own_mesh = i32(x8);
    let own_tri = i32(x9);
    let to = LIGHT.xyz - x;
    let d = length(to);
    let w = to / d;
    let cos_a = sqrt(max(1.0 - (LIGHT.w / d) * (LIGHT.w / d), 0.0));
    let omega = 2.0 * LF_PI * (1.0 - cos_a);
    let u = lf_any_orthonormal(w);
    let v = cross(w, u);
    let batch = u32(X[BATCH]);
    var sum = 0.0;
    var sum2 = 0.0;
    for (var j = 0u; j < SPP; j++) {
        let u4 = mc_point(i, batch * SPP + j);
        let mu = 1.0 - u4.x * (1.0 - cos_a);
        let phi = 2.0 * LF_PI * u4.y;
        let st = sqrt(max(1.0 - mu * mu, 0.0));
        let dir = normalize(mu * w + st * (cos(phi) * u + sin(phi) * v));
        let c = dot(n, dir);
        var f = 0.0;
        if c > 0.0 {
            // The light's near surface along dir.
            let oc = x - LIGHT.xyz;
            let bb = dot(oc, dir);
            let disc = max(bb * bb - (dot(oc, oc) - LIGHT.w * LIGHT.w), 0.0);
            let t_light = -bb - sqrt(disc);
            if !mc_occluded(x, dir, own, own_mesh, own_tri, t_light) {
                var brdf = f_d;
                for (var k = 0u; k < NL; k++) {
                    let lo = i * N_IN + 10u + 5u * k;
                    let q = vec3<f32>(X[lo], X[lo + 1u], X[lo + 2u]);
                    let s = dot(q, dir);
                    if s > 0.0 {
                        brdf += X[lo + 3u] * pow(s, X[lo + 4u]);
                    }
                }
                f = brdf * LIGHT_RADIANCE * c * omega;
            }
        }
        sum += f;
        sum2 += f * f;
    }
    Y[o] = sum;
    Y[o + 1u] = sum2;
    Y[o + 2u] = 0.0;
