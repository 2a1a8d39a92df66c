// lobefit shader library: irradiance rigs (Yuan, Nowrouzezahrai & Sloan 2012) and wrap
// shading of order-3 SH irradiance vectors (needs sh.wgsl, wrap.wgsl). Conventions of
// lobefit_tables::rigs: a rig reconstructs an order-3 SH irradiance vector l(p) (9
// coefficients, the basis of sh.wgsl, already convolved with the clamped cosine: the
// irradiance at unit normal N is sum_i l_i y_i(N), in the lights' unit, e.g. W/m^2) at
// points p of an axis-aligned box (centre, half extents > 0, the lights' length unit)
// from K SH vectors c_k: l(p) = sum_k b_k(t) c_k, t = (p - centre) / half in [-1, 1]^3.
//
// The model, per axis (x, y, z) a kind and a node count:
//   LF_RIG_CONSTANT {1}; LF_RIG_GRADIENT {1, t}; LF_RIG_LATTICE hat functions on
//   `nodes` >= 2 equally spaced nodes t_j = -1 + 2 j / (nodes - 1) (nodes is read for
//   lattices only); the rig's basis is the tensor product, vector k of the basis
//   function (ix, iy, iz) at k = (ix * Ky + iy) * Kz + iz (x-major, the order of
//   RigModel::basis; K per axis: 1, 2 or nodes).
//   LF_RIG_AFFINE on the x axis (the other axes ignored): the paper's gradient rig,
//   RigModel::Gradient, b = {1, t_x, t_y, t_z} (4 vectors).
// E.g. constant (0, 0, 0); gradient (3, *, *); the paper's mixed rig lattice(3) x
// gradient x constant: kind (2, 1, 0), nodes (3, *, *); lattice 3x2x2: kind (2, 2, 2),
// nodes (3, 2, 2).
//
// A point outside the box is clamped onto it (the Rust runtime refuses points beyond
// 1e-9 box units).

const LF_RIG_CONSTANT: u32 = 0u;
const LF_RIG_GRADIENT: u32 = 1u;
const LF_RIG_LATTICE: u32 = 2u;
const LF_RIG_AFFINE: u32 = 3u;

// Most vectors lf_rig_eval takes (its array argument: vector k at [9k .. 9k + 8]).
const LF_RIG_MAX_VECTORS: u32 = 64u;

// At most 8 basis functions are non-zero at a point (2 per axis): their vector
// indices k and values b_k(t), the first `count` entries (the rest 0).
struct LfRigTerms {
    count: u32,
    index: array<u32, 8>,
    weight: array<f32, 8>,
}

// One axis's non-zero basis functions: local indices, values, count, and the axis's
// basis size K.
struct LfRigAxis {
    count: u32,
    size: u32,
    index: vec2<u32>,
    weight: vec2<f32>,
}

fn lf_rig_axis(kind: u32, nodes: u32, t: f32) -> LfRigAxis {
    if kind == LF_RIG_GRADIENT {
        return LfRigAxis(2u, 2u, vec2<u32>(0u, 1u), vec2<f32>(1.0, t));
    }
    if kind == LF_RIG_LATTICE {
        let n = max(nodes, 2u);
        let s = (t + 1.0) * 0.5 * f32(n - 1u);
        let j = min(u32(max(floor(s), 0.0)), n - 2u);
        let f = s - f32(j);
        return LfRigAxis(2u, n, vec2<u32>(j, j + 1u), vec2<f32>(1.0 - f, f));
    }
    return LfRigAxis(1u, 1u, vec2<u32>(0u, 0u), vec2<f32>(1.0, 0.0));
}

// Normalised box coordinates t = (p - centre) / half, clamped to [-1, 1]^3.
fn lf_rig_normalised(centre: vec3<f32>, half: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    return clamp((p - centre) / half, vec3<f32>(-1.0), vec3<f32>(1.0));
}

// The rig's number of vectors K for a model (kind, nodes as above).
fn lf_rig_vector_count(kind: vec3<u32>, nodes: vec3<u32>) -> u32 {
    if kind.x == LF_RIG_AFFINE {
        return 4u;
    }
    return lf_rig_axis(kind.x, nodes.x, 0.0).size * lf_rig_axis(kind.y, nodes.y, 0.0).size
        * lf_rig_axis(kind.z, nodes.z, 0.0).size;
}

// The non-zero terms of l(p) = sum_k b_k(t) c_k at p (the accessor convention for
// vectors kept elsewhere, e.g. a storage buffer: l_i(p) = sum_{j < count}
// weight[j] * c[index[j]][i]).
fn lf_rig_terms(kind: vec3<u32>, nodes: vec3<u32>, centre: vec3<f32>, half: vec3<f32>, p: vec3<f32>) -> LfRigTerms {
    let t = lf_rig_normalised(centre, half, p);
    var r: LfRigTerms;
    if kind.x == LF_RIG_AFFINE {
        r.count = 4u;
        r.index[0] = 0u;
        r.index[1] = 1u;
        r.index[2] = 2u;
        r.index[3] = 3u;
        r.weight[0] = 1.0;
        r.weight[1] = t.x;
        r.weight[2] = t.y;
        r.weight[3] = t.z;
        return r;
    }
    let ax = lf_rig_axis(kind.x, nodes.x, t.x);
    let ay = lf_rig_axis(kind.y, nodes.y, t.y);
    let az = lf_rig_axis(kind.z, nodes.z, t.z);
    for (var a = 0u; a < ax.count; a++) {
        for (var b = 0u; b < ay.count; b++) {
            for (var c = 0u; c < az.count; c++) {
                r.index[r.count] = (ax.index[a] * ay.size + ay.index[b]) * az.size + az.index[c];
                r.weight[r.count] = ax.weight[a] * ay.weight[b] * az.weight[c];
                r.count += 1u;
            }
        }
    }
    return r;
}

// The rig's SH irradiance vector l(p) (9 coefficients, the vectors' unit) from at most
// LF_RIG_MAX_VECTORS vectors, c_k at (*vectors)[9k .. 9k + 8] (entries past K unread).
// The vectors are passed by pointer: a by-value array<f32, 576> is copied into the
// callee, which costs a GPU 2.3 KB of scratch per invocation and took llvmpipe 23 s of
// compile time more than this form (measured).
fn lf_rig_eval(
    kind: vec3<u32>,
    nodes: vec3<u32>,
    centre: vec3<f32>,
    half: vec3<f32>,
    p: vec3<f32>,
    vectors: ptr<function, array<f32, 576>>,
) -> array<f32, 9> {
    let r = lf_rig_terms(kind, nodes, centre, half, p);
    var out: array<f32, 9>;
    for (var j = 0u; j < r.count; j++) {
        let k = min(r.index[j], LF_RIG_MAX_VECTORS - 1u);
        for (var i = 0u; i < 9u; i++) {
            out[i] += r.weight[j] * (*vectors)[9u * k + i];
        }
    }
    return out;
}

// An order-3 SH irradiance vector re-wrapped to wrap parameter a in [0, 1]
// (dimensionless): band l scaled by lambda_hat_l(a) / lambda_hat_l(0), lambda_hat_l(0)
// = 1, 2/3, 1/4 (wrap.wgsl; lobefit_tables::wrap::rewrap_irradiance). a = 0 returns
// the vector (to f32 rounding).
fn lf_rewrap_irradiance9(l: array<f32, 9>, a: f32) -> array<f32, 9> {
    let lam = lf_wrap_lambda_hat(3u, a);
    let s = vec3<f32>(lam[0], 1.5 * lam[1], 4.0 * lam[2]);
    var out = l;
    out[0] *= s.x;
    for (var i = 1u; i < 4u; i++) {
        out[i] *= s.y;
    }
    for (var i = 4u; i < 9u; i++) {
        out[i] *= s.z;
    }
    return out;
}

// Wrapped irradiance at unit normal n from an order-3 SH irradiance vector l: the
// re-wrapped vector (lf_rewrap_irradiance9) evaluated at n (lf_sh9_basis), the
// vector's unit; a = 0 is Lambertian irradiance.
fn lf_irradiance9_wrapped(l: array<f32, 9>, n: vec3<f32>, a: f32) -> f32 {
    let w = lf_rewrap_irradiance9(l, a);
    let y = lf_sh9_basis(n);
    var e = 0.0;
    for (var i = 0u; i < 9u; i++) {
        e += w[i] * y[i];
    }
    return e;
}
