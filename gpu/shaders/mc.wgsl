// lobefit-gpu's Monte Carlo kernel for the sky pipelines' scenes (spheres under an SG
// environment, Phong materials): per pixel, SPP samples of the CPU's one-sample
// mixture (pipelines/sky.rs `mis`: the cosine, the Phong lobe, the SGs; balance
// heuristic) with exact visibility of the spheres through the scene's hierarchy (the
// CPU's `Bvh`, flattened: mc_blocked) and, where the scene has one, of the height
// field through its min-max quadtree (mc_terrain), and of meshes' triangles through
// their hierarchies (mc_meshes). The kernel's constants (NS, NE, NODES, STACK, CV,
// HYB, QMC, HF and the height field's HF_*, NM, MSTACK), its accessors (sph, env) and
// where its data lie in X (BATCH: the batch index, SPP: the samples a dispatch, SPH0,
// ENV0, SOBOL0, NODE0, ORDER0, HF0, MESH0, MNODE0, MTRI0; private variables set from
// the pixel count N.x at the body's start) come from gpu/src/mc.rs. Uniforms
// (mc_point): a PCG hash of (pixel, sample, dimension), or with QMC Owen-scrambled
// Sobol points seeded per pixel, the sample index running on across batches (the CPU
// draws its own: the two agree in distribution, not sample by sample). Dimension 0 picks the strategy, 1 and 2 draw
// its direction, 3 the SG. CV = true: the control variate of the CPU's
// `reference_cv` (the unoccluded diffuse term in closed form, lf_sg_clamped_cosine;
// Monte Carlo of the occluded diffuse and the specular part) with the SGs picked by
// their contribution at the point (`Select::Contribution`). HYB = true: the CPU's
// `reference_hybrid` with the SH-exponentiation pipeline's integrand (its value and 16
// SH coefficients after the pixel's inputs) as the control variate, a tenth of the
// samples uniform on the sphere; HYB_ISG = true: the ISG pipeline's (mc_isg_a). MAP =
// true: the light is a map's texels (MAP0: their luminance and running sums; no SGs,
// NE = 0), one of the mixture's strategies draws them (mc_map_sample, the CPU's
// `reference_map`). Outputs per pixel: the sum and the sum of squares of
// the batch's SPP sample values, the closed form (0 without CV or HYB), then the
// budget flag (gpu/src/budget.rs).

// PCG-RXS-M-XS 32 (O'Neill): a well-mixed hash of one word.
fn mc_pcg(v: u32) -> u32 {
    let s = v * 747796405u + 2891336453u;
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

// A uniform in [0, 1) from the stream `key` (pixel, batch, sample) at dimension d.
fn mc_uniform(key: u32, d: u32) -> f32 {
    return f32(mc_pcg(key ^ mc_pcg(d + 0x9e3779b9u)) >> 8u) * (1.0 / 16777216.0);
}

// Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based Owen Scrambling"):
// the index shuffled by a nested uniform scramble, each of 4 dimensions scrambled with
// its own seed; the first 4 dimensions' direction numbers follow the scene in the
// input buffer (gpu/src/mc.rs).
fn mc_lk(x0: u32, seed: u32) -> u32 {
    var x = x0 + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

fn mc_nus(x: u32, seed: u32) -> u32 {
    return reverseBits(mc_lk(reverseBits(x), seed));
}

// The direction number of dimension `dim`, bit `b`: two 16-bit halves stored as exact
// f32 integers in the input buffer at SOBOL0 (uniform across the invocations: plain
// loads, where a private or constant array indexed at run time costs a copy per lane).
fn mc_direction(dim: u32, b: u32) -> u32 {
    let k = SOBOL0 + 2u * (dim * 32u + b);
    return u32(X[k]) | (u32(X[k + 1u]) << 16u);
}

// The 4 dimensions' Sobol values of `index` at once (one pass over its bits).
fn mc_sobol4(index: u32) -> vec4<u32> {
    var x = vec4<u32>(0u);
    var v = index;
    var b = 0u;
    while v != 0u {
        if (v & 1u) != 0u {
            x ^= vec4<u32>(mc_direction(0u, b), mc_direction(1u, b), mc_direction(2u, b), mc_direction(3u, b));
        }
        v >>= 1u;
        b += 1u;
    }
    return x;
}

// A uniform in [0, 1) from 32 random bits (their top 24).
fn mc_unit(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// The 4 uniforms of sample `index` of pixel `pixel`: Owen-scrambled Sobol (QMC) or
// the PCG hash.
fn mc_point(pixel: u32, index: u32) -> vec4<f32> {
    if QMC {
        let seed = mc_pcg(pixel ^ 0x2545f491u);
        let x = mc_sobol4(mc_nus(index, seed));
        return vec4<f32>(
            mc_unit(mc_nus(x.x, mc_pcg(seed ^ 0x9e3779b9u))),
            mc_unit(mc_nus(x.y, mc_pcg(seed ^ 0x3c6ef372u))),
            mc_unit(mc_nus(x.z, mc_pcg(seed ^ 0xdaa66d2bu))),
            mc_unit(mc_nus(x.w, mc_pcg(seed ^ 0x78dde6e4u))),
        );
    }
    let key = mc_pcg(pixel ^ mc_pcg(index + 0x68e31da4u));
    return vec4<f32>(mc_uniform(key, 0u), mc_uniform(key, 1u), mc_uniform(key, 2u), mc_uniform(key, 3u));
}

// ---- rays: what the hierarchies' walks (mc_blocked, mc_meshes) share.

// 1/v, components of |v| < 1e-30 taken as ±1e-30: finite slopes, so no 0 · ∞.
fn mc_inverse(v: vec3<f32>) -> vec3<f32> {
    let tiny = select(vec3<f32>(-1e-30), vec3<f32>(1e-30), v >= vec3<f32>(0.0));
    return 1.0 / select(v, tiny, abs(v) < vec3<f32>(1e-30));
}

// Whether the ray x + t v (inv = mc_inverse(v)) may meet the box at X[k] (lo, hi)
// for t in [0, t_max]; written so that a NaN culls nothing.
fn mc_meets_box(k: u32, x: vec3<f32>, inv: vec3<f32>, t_max: f32) -> bool {
    let a = (vec3<f32>(X[k], X[k + 1u], X[k + 2u]) - x) * inv;
    let b = (vec3<f32>(X[k + 3u], X[k + 4u], X[k + 5u]) - x) * inv;
    let lo = min(a, b);
    let hi = max(a, b);
    return !(max(max(max(lo.x, lo.y), lo.z), 0.0) > min(min(min(hi.x, hi.y), hi.z), t_max));
}

// Whether sphere s (centre, radius) blocks the ray x + t v: its far root > 0 (the
// sphere lies ahead or holds x) and the nearest root ahead < t_max (the CPU's
// ray_sphere).
fn mc_sphere_blocks(x: vec3<f32>, v: vec3<f32>, s: vec4<f32>, t_max: f32) -> bool {
    let oc = x - s.xyz;
    let bb = dot(oc, v);
    let disc = bb * bb - (dot(oc, oc) - s.w * s.w);
    if disc < 0.0 {
        return false;
    }
    let sq = sqrt(disc);
    let far = -bb + sq;
    let near = -bb - sq;
    return far > 0.0 && select(far, near, near > 0.0) < t_max;
}

// Whether the ray x + t v meets a sphere other than `own` before t_max
// (mc_sphere_blocks), through the hierarchy: nodes at NODE0 (lo, hi: boxes widened
// outward past f32 rounding; first, count as the CPU's BvhNode), sphere indices at
// ORDER0, a stack of STACK entries (the tree's depth + 1).
fn mc_blocked(x: vec3<f32>, v: vec3<f32>, own: i32, t_max: f32) -> bool {
    let inv = mc_inverse(v);
    var stack: array<u32, STACK>;
    // No spheres: no root.
    var top = select(0u, 1u, NODES > 0u);
    stack[0] = 0u;
    while top > 0u {
        top -= 1u;
        let k = NODE0 + 8u * stack[top];
        if !mc_meets_box(k, x, inv, t_max) {
            continue;
        }
        let first = u32(X[k + 6u]);
        let count = u32(X[k + 7u]);
        if count == 0u {
            stack[top] = first;
            stack[top + 1u] = first + 1u;
            top += 2u;
            continue;
        }
        for (var j = 0u; j < count; j++) {
            let bi = u32(X[ORDER0 + first + j]);
            if i32(bi) != own && mc_sphere_blocks(x, v, sph(bi), t_max) {
                return true;
            }
        }
    }
    return false;
}

// Whether the ray x + t v (0 < t < t_max) meets a sphere other than `own`, or (HF) the
// height field from t = HF_TMIN on (the CPU's TERRAIN_T_MIN, widened past f32 rounding
// of a point on the terrain), or a mesh's triangle other than triangle `own_tri` of
// mesh `own_mesh` (mc_meshes). The sky's rays are unbounded (t_max 3.4e38); the
// light's end at its near surface.
fn mc_occluded(x: vec3<f32>, v: vec3<f32>, own: i32, own_mesh: i32, own_tri: i32, t_max: f32) -> bool {
    return mc_blocked(x, v, own, t_max) || (HF && mc_terrain(x, v, HF_TMIN, t_max))
        || mc_meshes(x, v, own_mesh, own_tri, t_max);
}

// Whether the ray x + t v meets a triangle of one of the NM meshes for t in (the mesh's
// t_min, t_max), triangle `own_tri` of mesh `own_mesh` skipped: each mesh's hierarchy
// (the CPU's Mesh, flattened into one list: gpu/src/mc.rs mesh_inputs) walked on a
// stack of MSTACK entries, each triangle tested as the CPU's ray_triangle
// (Möller–Trumbore) in f32. At MESH0 per mesh its root node and t_min; nodes from
// MNODE0 (lo, hi: boxes widened past f32 rounding; first, count: a leaf's first
// triangle record, an inner node's first child); triangle records from MTRI0 (3
// corners, the mesh, the triangle's index in it).
fn mc_meshes(x: vec3<f32>, v: vec3<f32>, own_mesh: i32, own_tri: i32, t_max: f32) -> bool {
    let inv = mc_inverse(v);
    for (var m = 0u; m < NM; m++) {
        let t_min = X[MESH0 + 2u * m + 1u];
        var stack: array<u32, MSTACK>;
        stack[0] = u32(X[MESH0 + 2u * m]);
        var top = 1u;
        while top > 0u {
            top -= 1u;
            let k = MNODE0 + 8u * stack[top];
            if !mc_meets_box(k, x, inv, t_max) {
                continue;
            }
            let first = u32(X[k + 6u]);
            let count = u32(X[k + 7u]);
            if count == 0u {
                stack[top] = first;
                stack[top + 1u] = first + 1u;
                top += 2u;
                continue;
            }
            for (var j = 0u; j < count; j++) {
                let r = MTRI0 + 11u * (first + j);
                if i32(m) == own_mesh && i32(X[r + 10u]) == own_tri {
                    continue;
                }
                let p0 = vec3<f32>(X[r], X[r + 1u], X[r + 2u]);
                let e1 = vec3<f32>(X[r + 3u], X[r + 4u], X[r + 5u]) - p0;
                let e2 = vec3<f32>(X[r + 6u], X[r + 7u], X[r + 8u]) - p0;
                let p = cross(v, e2);
                let det = dot(e1, p);
                if det == 0.0 {
                    continue;
                }
                let id = 1.0 / det;
                let s = x - p0;
                let u = dot(s, p) * id;
                if u < 0.0 || u > 1.0 {
                    continue;
                }
                let q = cross(s, e1);
                let w = dot(v, q) * id;
                if w < 0.0 || u + w > 1.0 {
                    continue;
                }
                let t = dot(e2, q) * id;
                if t > t_min && t < t_max {
                    return true;
                }
            }
        }
    }
    return false;
}

// The height field (the CPU's HeightField, its min-max quadtree uploaded: gpu/src/mc.rs
// hf_inputs): HF_N × HF_N samples at spacing HF_SP from −HF_HALF, bilinear per cell;
// at HF0 the offsets of quadtree levels 1 … HF_L (from HF0), the heights from HF0 + 16.
// Quadtree level l's side over the HF_N − 1 cells.
fn mc_hf_side(l: u32) -> u32 {
    return (HF_N - 1u + (1u << l) - 1u) >> l;
}

// [min, max] of the surface over node (a, b) of level l (level 0: a cell's corners).
fn mc_hf_range(l: u32, a: u32, b: u32) -> vec2<f32> {
    if l == 0u {
        let k = HF0 + 16u + b * HF_N + a;
        let h00 = X[k];
        let h10 = X[k + 1u];
        let h01 = X[k + HF_N];
        let h11 = X[k + HF_N + 1u];
        return vec2<f32>(min(min(h00, h10), min(h01, h11)), max(max(h00, h10), max(h01, h11)));
    }
    let k = HF0 + u32(X[HF0 + l - 1u]) + 2u * (b * mc_hf_side(l) + a);
    return vec2<f32>(X[k], X[k + 1u]);
}

// The ray's t span over the grid box [lo, hi] (grid units), from grid point g along
// slope d (inv = 1/d, d never 0: see mc_terrain).
fn mc_hf_span(g: vec2<f32>, inv: vec2<f32>, lo: vec2<f32>, hi: vec2<f32>) -> vec2<f32> {
    let a = (lo - g) * inv;
    let b = (hi - g) * inv;
    let near = min(a, b);
    let far = max(a, b);
    return vec2<f32>(max(near.x, near.y), min(far.x, far.y));
}

// Whether the ray x + t v meets the height field for t in (t_min, t_max): the CPU's
// traversal (HeightField::occluded) in f32 — nodes whose box or height range the ray's
// span misses are skipped (ranges widened by HF_ZPAD past f32 rounding), each cell's
// bilinear patch solved as a quadratic in t with stable roots, a root counting within
// 1e-4 cell of its cell (the CPU: 1e-9). Any hit ends the walk, so the children need no
// order. A node on the stack: level, a, b packed in one word; its span beside it.
fn mc_terrain(x: vec3<f32>, v: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    let g = (x.xy + vec2<f32>(HF_HALF)) / HF_SP;
    var d = v.xy / HF_SP;
    // A slope of |d| < 1e-30 as ±1e-30: finite spans, no 0 · ∞.
    d = select(d, select(vec2<f32>(-1e-30), vec2<f32>(1e-30), d >= vec2<f32>(0.0)), abs(d) < vec2<f32>(1e-30));
    let inv = 1.0 / d;
    let pad = 1e-4 / max(abs(d.x), abs(d.y));
    let m = f32(HF_N - 1u);
    var nodes: array<u32, HF_STACK>;
    var spans: array<vec2<f32>, HF_STACK>;
    var top = 0u;
    // The root (level HF_L), if the ray's span and heights meet it.
    let root = mc_hf_span(g, inv, vec2<f32>(0.0), vec2<f32>(m));
    let r0 = max(root.x, t_min);
    let r1 = min(root.y, t_max);
    let rr = mc_hf_range(HF_L, 0u, 0u);
    let z0 = x.z + v.z * r0;
    let z1 = x.z + v.z * r1;
    if r0 <= r1 && min(z0, z1) <= rr.y + HF_ZPAD && max(z0, z1) >= rr.x - HF_ZPAD {
        nodes[0] = HF_L << 28u;
        spans[0] = root;
        top = 1u;
    }
    while top > 0u {
        top -= 1u;
        let node = nodes[top];
        let span = spans[top];
        let l = node >> 28u;
        let a = (node >> 14u) & 0x3fffu;
        let b = node & 0x3fffu;
        if l == 0u {
            // The cell's patch h = p0 + p1 u + p2 w + p3 u w, expanded about t = tr.
            let k = HF0 + 16u + b * HF_N + a;
            let h00 = X[k];
            let h10 = X[k + 1u];
            let h01 = X[k + HF_N];
            let h11 = X[k + HF_N + 1u];
            let p = vec4<f32>(h00, h10 - h00, h01 - h00, h00 - h10 - h01 + h11);
            let tr = max(span.x, t_min);
            let ua = g.x + d.x * tr - f32(a);
            let wa = g.y + d.y * tr - f32(b);
            let qa = p.w * d.x * d.y;
            let qb = p.y * d.x + p.z * d.y + p.w * (ua * d.y + wa * d.x) - v.z;
            let qc = p.x + p.y * ua + p.z * wa + p.w * ua * wa - (x.z + v.z * tr);
            var r = vec2<f32>(-1.0, -1.0);
            var valid = vec2<bool>(false, false);
            if qa == 0.0 {
                if qb != 0.0 {
                    r.x = -qc / qb;
                    valid.x = true;
                }
            } else {
                let disc = qb * qb - 4.0 * qa * qc;
                if disc >= 0.0 {
                    let q = -0.5 * (qb + select(-sqrt(disc), sqrt(disc), qb >= 0.0));
                    if q == 0.0 {
                        r.x = 0.0;
                        valid.x = true;
                    } else {
                        r = vec2<f32>(q / qa, qc / q);
                        valid = vec2<bool>(true, true);
                    }
                }
            }
            // Scalar conditions: the same test written as a chain of vec2<bool> `&`
            // answered no hit for every ray on lavapipe.
            let t = tr + r;
            let lo = max(t_min, span.x - pad);
            let hi = min(t_max, span.y + pad);
            if (valid.x && t.x > t_min && t.x >= lo && t.x <= hi && t.x < t_max)
                || (valid.y && t.y > t_min && t.y >= lo && t.y <= hi && t.y < t_max) {
                return true;
            }
            continue;
        }
        let lc = l - 1u;
        let s = mc_hf_side(lc);
        for (var c = 0u; c < 4u; c++) {
            let ca = 2u * a + (c & 1u);
            let cb = 2u * b + (c >> 1u);
            if ca >= s || cb >= s {
                continue;
            }
            let lo = vec2<f32>(f32(ca << lc), f32(cb << lc));
            let hi = vec2<f32>(f32(min((ca + 1u) << lc, HF_N - 1u)), f32(min((cb + 1u) << lc, HF_N - 1u)));
            let sp = mc_hf_span(g, inv, lo, hi);
            let t0 = max(sp.x, t_min);
            let t1 = min(sp.y, t_max);
            if t0 > t1 {
                continue;
            }
            let za = x.z + v.z * t0;
            let zb = x.z + v.z * t1;
            let rg = mc_hf_range(lc, ca, cb);
            if min(za, zb) > rg.y + HF_ZPAD || max(za, zb) < rg.x - HF_ZPAD {
                continue;
            }
            nodes[top] = (lc << 28u) | (ca << 14u) | cb;
            spans[top] = sp;
            top += 1u;
        }
    }
    return false;
}

// A direction of the SG g's normalised density (the CPU's sample_sg).
fn mc_sample_sg(g: LfSg, u1: f32, u2: f32) -> vec3<f32> {
    let l = g.sharpness;
    let c = clamp(1.0 + log(1.0 - u1 * (1.0 - exp(-2.0 * l))) / l, -1.0, 1.0);
    let s = sqrt(max(1.0 - c * c, 0.0));
    let p = 2.0 * LF_PI * u2;
    let a = lf_any_orthonormal(g.axis);
    let b = cross(g.axis, a);
    return c * g.axis + s * (cos(p) * a + sin(p) * b);
}

// The ISG pipeline's integrand a(ω) (radiance × BRDF × cosine per steradian) from
// its record at X[k0] (pipelines/isg/shade.rs `Integrand::pack`, read as its
// `eval_packed`): value, n, the open and hidden counts; per open product its SG,
// factor and cosine flag (7 words); per hidden grid its factor, frame x, y, z, G's
// sharpness, cull cosine, first edge, step, side k (15 words), then k² densities.
fn mc_isg_a(k0: u32, w: vec3<f32>) -> f32 {
    let c = max(dot(vec3<f32>(X[k0 + 1u], X[k0 + 2u], X[k0 + 3u]), w), 0.0);
    let no = u32(X[k0 + 4u]);
    let nh = u32(X[k0 + 5u]);
    var k = k0 + 6u;
    var a = 0.0;
    for (var e = 0u; e < no; e++) {
        let g = LfSg(vec3<f32>(X[k], X[k + 1u], X[k + 2u]), X[k + 3u], X[k + 4u]);
        var v = X[k + 5u] * lf_sg_eval(g, w);
        if X[k + 6u] != 0.0 {
            v *= c;
        }
        a += v;
        k += 7u;
    }
    for (var e = 0u; e < nh; e++) {
        let x = vec3<f32>(X[k + 1u], X[k + 2u], X[k + 3u]);
        let y = vec3<f32>(X[k + 4u], X[k + 5u], X[k + 6u]);
        let z = vec3<f32>(X[k + 7u], X[k + 8u], X[k + 9u]);
        let side = u32(X[k + 14u]);
        let zw = dot(z, w);
        if zw >= X[k + 11u] {
            let lo = X[k + 12u];
            let cell = X[k + 13u];
            let ti = floor((acos(clamp(dot(y, w), -1.0, 1.0)) - lo) / cell);
            let pj = floor((atan2(zw, dot(x, w)) - lo) / cell);
            let kk = f32(side);
            if ti >= 0.0 && ti < kk && pj >= 0.0 && pj < kk {
                a -= X[k] * X[k + 15u + u32(ti) * side + u32(pj)] * exp(X[k + 10u] * (zw - 1.0));
            }
        }
        k += 15u + side * side;
    }
    return a;
}

// The density (1/sr) of mc_sample_sg at w.
fn mc_sg_pdf(g: LfSg, w: vec3<f32>) -> f32 {
    let l = g.sharpness;
    return l * exp(l * (dot(g.axis, w) - 1.0)) / (2.0 * LF_PI * (1.0 - exp(-2.0 * l)));
}

// The SG g's weight in the mixture: its integral, or with CV its contribution at the
// point (the CPU's `contribution`).
fn mc_weight(g: LfSg, kd: f32, ks: f32, e: f32, n: vec3<f32>, r: vec3<f32>) -> f32 {
    if !CV {
        return lf_sg_integral(g);
    }
    let diffuse = kd / LF_PI * lf_sg_clamped_cosine(g, n);
    var specular = 0.0;
    if ks > 0.0 {
        let m = length(g.sharpness * g.axis + e * r);
        var shape = 1.0;
        if m > 1e-6 {
            shape = (1.0 - exp(-2.0 * m)) / (2.0 * m);
        }
        let overlap = 4.0 * LF_PI * exp(m - g.sharpness - e) * shape;
        specular = ks * (e + 2.0) / (2.0 * LF_PI) * max(dot(n, r), 0.0) * overlap;
    }
    return g.amplitude * (diffuse + specular);
}

// A map's texel holding the unit direction w (row 0 the zenith; column u from φ =
// 2πu/W, φ from +x towards +y), as the CPU's EnvMap::texel_of: its row-major index.
fn mc_map_texel(w: vec3<f32>) -> u32 {
    let theta = acos(clamp(w.z, -1.0, 1.0));
    var phi = atan2(w.y, w.x);
    if phi < 0.0 {
        phi += 2.0 * LF_PI;
    }
    let v = min(u32(theta / LF_PI * f32(MAP_H)), MAP_H - 1u);
    let u = min(u32(phi / (2.0 * LF_PI) * f32(MAP_W)), MAP_W - 1u);
    return v * MAP_W + u;
}

// The solid angle of a texel of row v.
fn mc_map_solid_angle(v: u32) -> f32 {
    let c0 = cos(LF_PI * f32(v) / f32(MAP_H));
    let c1 = cos(LF_PI * f32(v + 1u) / f32(MAP_H));
    return 2.0 * LF_PI / f32(MAP_W) * (c0 - c1);
}

// The density (1/sr) of mc_map_sample at w: its texel's probability (the difference
// of two running sums, exactly what the search draws with) over its solid angle.
fn mc_map_pdf(w: vec3<f32>) -> f32 {
    let k = mc_map_texel(w);
    let n = MAP_W * MAP_H;
    var below = 0.0;
    if k > 0u {
        below = X[MAP0 + n + k - 1u];
    }
    return max(X[MAP0 + n + k] - below, 0.0) / mc_map_solid_angle(k / MAP_W);
}

// A direction from the map: a texel by its luminance × solid angle (the first texel
// whose running sum exceeds u0), then uniform in its solid angle (cos θ by u1, φ by u2).
fn mc_map_sample(u0: f32, u1: f32, u2: f32) -> vec3<f32> {
    let n = MAP_W * MAP_H;
    var lo = 0u;
    var hi = n - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if X[MAP0 + n + mid] <= u0 {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let v = lo / MAP_W;
    let u = lo % MAP_W;
    let c0 = cos(LF_PI * f32(v) / f32(MAP_H));
    let c1 = cos(LF_PI * f32(v + 1u) / f32(MAP_H));
    let c = clamp(c0 + (c1 - c0) * u1, -1.0, 1.0);
    let s = sqrt(max(1.0 - c * c, 0.0));
    let phi = 2.0 * LF_PI * (f32(u) + u2) / f32(MAP_W);
    return vec3<f32>(s * cos(phi), s * sin(phi), c);
}

// ---- main: the kernel's body (the statements inside its entry point, kernel.rs)
    var budget_flag = 0.0;
    let x = vec3<f32>(x0, x1, x2);
    let n = normalize(vec3<f32>(x3, x4, x5));
    let wo = normalize(vec3<f32>(x6, x7, x8));
    let kd = x9;
    let ks = x10;
    let e = x11;
    let own = i32(x12);
    let own_mesh = i32(x13);
    let own_tri = i32(x14);
    let r = normalize(2.0 * dot(n, wo) * n - wo);
    let t = lf_any_orthonormal(n);
    let bt = cross(n, t);
    let rt = lf_any_orthonormal(r);
    let rb = cross(r, rt);
    let spec = ks > 0.0;
    var energy: array<f32, NE_ARR>;
    var total = 0.0;
    for (var k = 0u; k < NE; k++) {
        energy[k] = mc_weight(env(k), kd, ks, e, n, r);
        total += energy[k];
    }
    var p_cos = 0.5;
    var p_phong = 0.0;
    if spec {
        p_cos = 0.3;
        p_phong = 0.3;
    }
    // The hybrid's integrand a covers the sphere: a tenth of the samples uniform on it.
    var p_uni = 0.0;
    if HYB {
        p_uni = 0.1;
    }
    var p_env = 0.0;
    if total > 0.0 {
        p_env = 1.0 - p_cos - p_phong - p_uni;
    }
    // Under a map (no SGs here) the light's share draws the map's texels.
    var p_map = 0.0;
    if MAP {
        p_map = 1.0 - p_cos - p_phong - p_uni;
    }
    p_cos = 1.0 - p_phong - p_env - p_map - p_uni;
    let f_d = kd / LF_PI;
    // The control variate's closed form: the unoccluded diffuse radiance.
    var open = 0.0;
    if CV {
        for (var k = 0u; k < NE; k++) {
            let g = env(k);
            open += g.amplitude * lf_sg_clamped_cosine(g, n);
        }
        open *= f_d;
    }
    // The hybrid's control variate: the pipeline's value (its closed form here) and
    // its integrand's SH coefficients after the pixel's other inputs, or (HYB_ISG)
    // where the ISG pipeline's record starts (mc_isg_a).
    var hyb: array<f32, 16>;
    var isg_at = 0u;
    if HYB_ISG {
        isg_at = u32(X[i * N_IN + 15u]);
        open = X[isg_at];
    } else if HYB {
        open = X[i * N_IN + 15u];
        for (var k = 0u; k < 16u; k++) {
            hyb[k] = X[i * N_IN + 16u + k];
        }
    }
    let batch = u32(X[BATCH]);
    var sum = 0.0;
    var sum2 = 0.0;
    for (var j = 0u; j < SPP; j++) {
        let u4 = mc_point(i, batch * SPP + j);
        let pick = u4.x;
        var w: vec3<f32>;
        if pick >= 1.0 - p_uni {
            let z = 2.0 * u4.y - 1.0;
            let p = 2.0 * LF_PI * u4.z;
            let s = sqrt(max(1.0 - z * z, 0.0));
            w = s * (cos(p) * t + sin(p) * bt) + z * n;
        } else if pick < p_cos {
            let u1 = u4.y;
            let u2 = 2.0 * LF_PI * u4.z;
            let s = sqrt(u1);
            w = s * (cos(u2) * t + sin(u2) * bt) + sqrt(1.0 - u1) * n;
        } else if pick < p_cos + p_phong {
            let c = pow(u4.y, 1.0 / (e + 1.0));
            let s = sqrt(max(1.0 - c * c, 0.0));
            let p = 2.0 * LF_PI * u4.z;
            w = c * r + s * (cos(p) * rt + sin(p) * rb);
        } else if MAP {
            w = mc_map_sample(u4.w, u4.y, u4.z);
        } else {
            var u = u4.w * total;
            var k = 0u;
            while k + 1u < NE && u >= energy[k] {
                u -= energy[k];
                k += 1u;
            }
            w = mc_sample_sg(env(k), u4.y, u4.z);
        }
        w = normalize(w);
        let c = dot(n, w);
        var f = 0.0;
        // Below the horizon only the hybrid's integrand lives.
        if c > 0.0 || HYB {
            var pdf = p_cos * max(c, 0.0) / LF_PI + p_uni / (4.0 * LF_PI);
            let rw = max(dot(r, w), 0.0);
            if spec {
                pdf += p_phong * (e + 1.0) / (2.0 * LF_PI) * pow(rw, e);
            }
            var light = 0.0;
            var mix = 0.0;
            for (var k = 0u; k < NE; k++) {
                let g = env(k);
                light += lf_sg_eval(g, w);
                if p_env > 0.0 {
                    mix += energy[k] / total * mc_sg_pdf(g, w);
                }
            }
            // An SH environment (SHO > 0): Σ_k c_k y_k(ω), its SHN coefficients after
            // the SGs.
            if SHO > 0u {
                let y = lf_sh_basis(SHO, w);
                for (var k = 0u; k < SHN; k++) {
                    light += X[ENV0 + 5u * NE + k] * y[k];
                }
            }
            if MAP {
                light = X[MAP0 + mc_map_texel(w)];
                pdf += p_map * mc_map_pdf(w);
            }
            pdf += p_env * mix;
            if pdf > 0.0 {
                var f_s = 0.0;
                if spec {
                    f_s = ks * (e + 2.0) / (2.0 * LF_PI) * pow(rw, e);
                }
                if HYB {
                    // The CPU's reference_hybrid: (f − L a)/pdf, a = Σ_k c_k y_k.
                    var lit = 0.0;
                    if c > 0.0 && !mc_occluded(x, w, own, own_mesh, own_tri, 3.4e38) {
                        lit = light * (f_d + f_s) * c;
                    }
                    if HYB_ISG {
                        f = (lit - mc_isg_a(isg_at, w)) / pdf;
                    } else {
                        let y = lf_sh_basis(4u, w);
                        var a = 0.0;
                        for (var k = 0u; k < 16u; k++) {
                            a += hyb[k] * y[k];
                        }
                        f = (lit - light * a) / pdf;
                    }
                } else {
                    let blocked = mc_occluded(x, w, own, own_mesh, own_tri, 3.4e38);
                    if CV {
                        // The CPU's reference_cv: −(occluded diffuse), + unoccluded specular.
                        if blocked {
                            f = -light * f_d * c / pdf;
                        } else {
                            f = light * f_s * c / pdf;
                        }
                    } else if !blocked {
                        f = light * (f_d + f_s) * c / pdf;
                    }
                }
            }
        }
        sum += f;
        sum2 += f * f;
    }
    Y[o] = sum;
    Y[o + 1u] = sum2;
    Y[o + 2u] = open;
