// lobefit shader library: common part (texture parameters, coordinate mappings,
// manual and hardware filtering, channel unpacking). Every other file of the library
// needs it; concatenate it first (lobefit_tables::shaders::library() does).
//
// Conventions (the export manifest, manifest.json, states them per texture):
// - Node i of an axis with n nodes sits at the centre of texel i: texture coordinate
//   u = (s + 0.5) / n, s = (map(x) - map(lo)) / (map(hi) - map(lo)) * (n - 1).
// - One-axis tables are 2D textures of height 1 (in the exported files too; GLSL ES
//   has no 1D textures); tables with more than 4 channels 2D array textures (RGBA per
//   layer).
// - A channel's value is trend(t) + offset + scale * texel (t = s / (n - 1); trend a
//   quintic, zero unless the manifest gives one), the compression's inverse where the
//   manifest gives a width, then exp() for log channels.
// - `LfTex` is lobefit_tables::uniform::LfTex (Rust), built from a manifest entry.
// - Angles in radians; directions unit vectors.

// One texture's parameters, filled from its manifest entry (at most 12 channels:
// 3 layers of RGBA).
struct LfTex {
    // Per texture axis, slowest first (manifest `axes`): (mapped_lo, mapped_hi,
    // node count, mapping kind: 0 linear, 1 log, 2 log1p, 3 logit, 4 asinh).
    axis: array<vec4<f32>, 3>,
    // The mapping's constants per axis: log1p (scale, -), logit (a, b), asinh
    // (centre, width).
    map: array<vec4<f32>, 3>,
    // Channel k's (k = 4 layer + component) offset and scale at [k / 4][k % 4] (f32
    // storage: 0 and 1).
    offset: array<vec4<f32>, 3>,
    scale: array<vec4<f32>, 3>,
    // Channel k's trend coefficients c0..c5 (a quintic in t; 1D f16 textures): (c0, c1,
    // c2, c3) at [2k], (c4, c5, -, -) at [2k + 1]; zero: none.
    trend: array<vec4<f32>, 24>,
    // Channel k's compression width w at [k / 4][k % 4]: 0, stored as is; w > 0, the
    // texel holds v = sign(x) ln(1 + |x| / w) and x = sign(v) w (exp(|v|) - 1) after
    // filtering and unpacking (the manifest channel's `compression`).
    decode: array<vec4<f32>, 3>,
    // .x: 0 = manual filtering (textureLoad, f32 interpolation), 1 = hardware
    // filtering (a linear, clamp-to-edge sampler; 32-bit float textures then need
    // float32-filterable support).
    mode: vec4<u32>,
}

// asinh(x) = sign(x) ln(|x| + sqrt(x^2 + 1)): odd by construction, so a large
// negative x does not cancel (some drivers' asinh lose all digits there).
fn lf_asinh(x: f32) -> f32 {
    let a = abs(x);
    return sign(x) * log(a + sqrt(a * a + 1.0));
}

// The mapping of axis k of `p` applied to x.
fn lf_map(p: LfTex, k: u32, x: f32) -> f32 {
    let kind = u32(p.axis[k].w);
    let c = p.map[k];
    if kind == 1u {
        return log(x);
    } else if kind == 2u {
        return log(1.0 + x / c.x);
    } else if kind == 3u {
        return log((x - c.x) / (c.y - x));
    } else if kind == 4u {
        return lf_asinh((x - c.x) / c.y);
    }
    return x;
}

// The node coordinate s (texel units, node i at s = i, not clamped) of x on axis k.
fn lf_node_coord(p: LfTex, k: u32, x: f32) -> f32 {
    let a = p.axis[k];
    return (lf_map(p, k, x) - a.x) / (a.y - a.x) * (a.z - 1.0);
}

// Lower texel index and weight of the upper one for manual filtering at s.
fn lf_split(s: f32, n: f32) -> vec2<f32> {
    let c = clamp(s, 0.0, n - 1.0);
    let i = min(floor(c), n - 2.0);
    return vec2<f32>(i, c - i);
}

// The 4 channels of layer `layer` unpacked (offset, scale, trend at t, then the
// compression's inverse where `decode` has a width), exp not applied.
fn lf_unpack(p: LfTex, layer: u32, texel: vec4<f32>, t: f32) -> vec4<f32> {
    var tr = vec4<f32>(0.0);
    for (var c = 0u; c < 4u; c++) {
        let k = 2u * (layer * 4u + c);
        let lo = p.trend[k];
        let hi = p.trend[k + 1u];
        tr[c] = ((((hi.y * t + hi.x) * t + lo.w) * t + lo.z) * t + lo.y) * t + lo.x;
    }
    let v = (tr + p.offset[layer]) + p.scale[layer] * texel;
    let w = p.decode[layer];
    return select(v, sign(v) * w * (exp(abs(v)) - 1.0), w > vec4<f32>(0.0));
}

// A 1D table (bound as a width x 1 texture) at axis value x: the 4 channels, unpacked.
fn lf_sample_1d(tex: texture_2d<f32>, smp: sampler, p: LfTex, x: f32) -> vec4<f32> {
    let n = p.axis[0].z;
    let s = lf_node_coord(p, 0u, x);
    let t = clamp(s, 0.0, n - 1.0) / max(n - 1.0, 1.0);
    var v: vec4<f32>;
    if p.mode.x == 1u {
        v = textureSampleLevel(tex, smp, vec2<f32>((s + 0.5) / n, 0.5), 0.0);
    } else {
        let iw = lf_split(s, n);
        let i = i32(iw.x);
        let a = textureLoad(tex, vec2<i32>(i, 0), 0);
        let b = textureLoad(tex, vec2<i32>(i + 1, 0), 0);
        v = a + iw.y * (b - a);
    }
    return lf_unpack(p, 0u, v, t);
}

// Layer `layer` of a 1D table with more than 4 channels (bound as a width x 1 2D
// array texture) at axis value x: 4 channels, unpacked.
fn lf_sample_1d_layer(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, layer: u32, x: f32) -> vec4<f32> {
    let n = p.axis[0].z;
    let s = lf_node_coord(p, 0u, x);
    let t = clamp(s, 0.0, n - 1.0) / max(n - 1.0, 1.0);
    var v: vec4<f32>;
    if p.mode.x == 1u {
        v = textureSampleLevel(tex, smp, vec2<f32>((s + 0.5) / n, 0.5), i32(layer), 0.0);
    } else {
        let iw = lf_split(s, n);
        let i = i32(iw.x);
        let a = textureLoad(tex, vec2<i32>(i, 0), i32(layer), 0);
        let b = textureLoad(tex, vec2<i32>(i + 1, 0), i32(layer), 0);
        v = a + iw.y * (b - a);
    }
    return lf_unpack(p, layer, v, t);
}

// Texel i of layer `layer` of a layered 1D table, unpacked (the trend at node i): no
// filtering.
fn lf_fetch_1d_layer(tex: texture_2d_array<f32>, p: LfTex, layer: u32, i: i32) -> vec4<f32> {
    let n = p.axis[0].z;
    let t = f32(i) / max(n - 1.0, 1.0);
    return lf_unpack(p, layer, textureLoad(tex, vec2<i32>(i, 0), i32(layer), 0), t);
}

// Trilinear manual filtering of a 3D texture at node coordinates (sx fastest, sz
// slowest).
fn lf_lerp_3d(tex: texture_3d<f32>, sx: f32, sy: f32, sz: f32, n: vec3<f32>) -> vec4<f32> {
    let ix = lf_split(sx, n.x);
    let iy = lf_split(sy, n.y);
    let iz = lf_split(sz, n.z);
    let i = i32(ix.x);
    let j = i32(iy.x);
    var plane: array<vec4<f32>, 2>;
    for (var d = 0; d < 2; d++) {
        let k = i32(iz.x) + d;
        let a = textureLoad(tex, vec3<i32>(i, j, k), 0);
        let b = textureLoad(tex, vec3<i32>(i + 1, j, k), 0);
        let c = textureLoad(tex, vec3<i32>(i, j + 1, k), 0);
        let e = textureLoad(tex, vec3<i32>(i + 1, j + 1, k), 0);
        let lo = a + ix.y * (b - a);
        let hi = c + ix.y * (e - c);
        plane[d] = lo + iy.y * (hi - lo);
    }
    return plane[0] + iz.y * (plane[1] - plane[0]);
}

// A 3D table at axis values (z slowest, y, x fastest): 4 channels, unpacked.
fn lf_sample_3d(tex: texture_3d<f32>, smp: sampler, p: LfTex, z: f32, y: f32, x: f32) -> vec4<f32> {
    let n = vec3<f32>(p.axis[2].z, p.axis[1].z, p.axis[0].z);
    let sz = lf_node_coord(p, 0u, z);
    let sy = lf_node_coord(p, 1u, y);
    let sx = lf_node_coord(p, 2u, x);
    var v: vec4<f32>;
    if p.mode.x == 1u {
        v = textureSampleLevel(tex, smp, (vec3<f32>(sx, sy, sz) + 0.5) / n, 0.0);
    } else {
        v = lf_lerp_3d(tex, sx, sy, sz, n);
    }
    return lf_unpack(p, 0u, v, 0.0);
}

// Bilinear manual filtering of a 2D texture at node coordinates (sx, sy).
fn lf_lerp_2d(tex: texture_2d<f32>, sx: f32, sy: f32, nx: f32, ny: f32) -> vec4<f32> {
    let ix = lf_split(sx, nx);
    let iy = lf_split(sy, ny);
    let i = i32(ix.x);
    let j = i32(iy.x);
    let a = textureLoad(tex, vec2<i32>(i, j), 0);
    let b = textureLoad(tex, vec2<i32>(i + 1, j), 0);
    let c = textureLoad(tex, vec2<i32>(i, j + 1), 0);
    let d = textureLoad(tex, vec2<i32>(i + 1, j + 1), 0);
    let lo = a + ix.y * (b - a);
    let hi = c + ix.y * (d - c);
    return lo + iy.y * (hi - lo);
}

// A 2D table at axis values (y = the slower axis, x = the faster one): 4 channels, unpacked.
fn lf_sample_2d(tex: texture_2d<f32>, smp: sampler, p: LfTex, y: f32, x: f32) -> vec4<f32> {
    let ny = p.axis[0].z;
    let nx = p.axis[1].z;
    let sy = lf_node_coord(p, 0u, y);
    let sx = lf_node_coord(p, 1u, x);
    var v: vec4<f32>;
    if p.mode.x == 1u {
        v = textureSampleLevel(tex, smp, vec2<f32>((sx + 0.5) / nx, (sy + 0.5) / ny), 0.0);
    } else {
        v = lf_lerp_2d(tex, sx, sy, nx, ny);
    }
    return lf_unpack(p, 0u, v, 0.0);
}

// Bilinear manual filtering of layer `layer` of a 2D array texture at node
// coordinates (sx, sy).
fn lf_lerp_2d_layer(tex: texture_2d_array<f32>, layer: i32, sx: f32, sy: f32, nx: f32, ny: f32) -> vec4<f32> {
    let ix = lf_split(sx, nx);
    let iy = lf_split(sy, ny);
    let i = i32(ix.x);
    let j = i32(iy.x);
    let a = textureLoad(tex, vec2<i32>(i, j), layer, 0);
    let b = textureLoad(tex, vec2<i32>(i + 1, j), layer, 0);
    let c = textureLoad(tex, vec2<i32>(i, j + 1), layer, 0);
    let d = textureLoad(tex, vec2<i32>(i + 1, j + 1), layer, 0);
    let lo = a + ix.y * (b - a);
    let hi = c + ix.y * (d - c);
    return lo + iy.y * (hi - lo);
}

// Layer `layer` of a 2D array table at axis values (y, x): 4 channels, unpacked.
fn lf_sample_2d_layer(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, layer: u32, y: f32, x: f32) -> vec4<f32> {
    let ny = p.axis[0].z;
    let nx = p.axis[1].z;
    let sy = lf_node_coord(p, 0u, y);
    let sx = lf_node_coord(p, 1u, x);
    var v: vec4<f32>;
    if p.mode.x == 1u {
        v = textureSampleLevel(tex, smp, vec2<f32>((sx + 0.5) / nx, (sy + 0.5) / ny), i32(layer), 0.0);
    } else {
        v = lf_lerp_2d_layer(tex, i32(layer), sx, sy, nx, ny);
    }
    return lf_unpack(p, layer, v, 0.0);
}

// The texel at integer indices (x, y, z) of a 3D table, unpacked: no filtering.
fn lf_fetch_3d(tex: texture_3d<f32>, p: LfTex, x: i32, y: i32, z: i32) -> vec4<f32> {
    return lf_unpack(p, 0u, textureLoad(tex, vec3<i32>(x, y, z), 0), 0.0);
}

// 1 - exp(-y) for y >= 0 without cancellation near 0 (a short series below 1/16).
fn lf_one_minus_exp_neg(y: f32) -> f32 {
    if y < 0.0625 {
        return y * (1.0 - 0.5 * y * (1.0 - y / 3.0 * (1.0 - 0.25 * y * (1.0 - 0.2 * y))));
    }
    return 1.0 - exp(-y);
}

const LF_PI: f32 = 3.14159265358979;

// sin and cos to a few f32 ulps relative on [-pi, pi], also near their zeros there
// (beyond, to a few ulps of the argument, absolute). A GPU's sin and cos are accurate
// in absolute terms only (Vulkan allows 2^-11 on [-pi, pi]; NVIDIA's err by ~5e-7),
// so sin(1e-4) or cos(pi/2 - 1e-4) lose ~0.5 % there, which formulas such as
// 1 - cos a = 2 sin^2(a/2) turn into errors of the table's size. The argument is
// reduced to [-pi, pi] (2 pi in two parts), folded to [-pi/2, pi/2] with pi in two
// parts (exact where the result is small), then an odd Taylor polynomial to x^15
// (truncation < 7e-12).
const LF_PI_HI: f32 = 3.1415927410125732;
const LF_PI_LO: f32 = -8.742278e-8;
const LF_HALF_PI_HI: f32 = 1.5707963705062866;

// The low parts of pi (-8.742278e-8) and pi/2 (-4.371139e-8) as run-time values:
// compilers (Mesa's NIR, NVIDIA's) rewrite (c1 - y) + c2 into (c1 + c2) - y when both
// are constants, which drops c2 entirely. The added bit is 0 for any |y| <= 1e30.
fn lf_pi_lo(y: f32) -> f32 {
    return bitcast<f32>(0xb3bbbd2eu + u32(abs(y) > 1e30));
}

fn lf_half_pi_lo(y: f32) -> f32 {
    return bitcast<f32>(0xb33bbd2eu + u32(abs(y) > 1e30));
}

// x reduced to [-pi, pi] (unchanged there).
fn lf_reduce_angle(x: f32) -> f32 {
    if abs(x) <= LF_PI_HI {
        return x;
    }
    let k = round(x / (2.0 * LF_PI));
    return (x - k * (2.0 * LF_PI_HI)) - k * (2.0 * LF_PI_LO);
}

fn lf_sin(x: f32) -> f32 {
    var y = lf_reduce_angle(x);
    if y > LF_HALF_PI_HI {
        y = (LF_PI_HI - y) + lf_pi_lo(y);
    } else if y < -LF_HALF_PI_HI {
        y = (-LF_PI_HI - y) - lf_pi_lo(y);
    }
    let z = y * y;
    let p = -1.0 / 6.0 + z * (1.0 / 120.0 + z * (-1.0 / 5040.0 + z * (1.0 / 362880.0
        + z * (-1.0 / 39916800.0 + z * (1.0 / 6227020800.0 + z * (-1.0 / 1307674368000.0))))));
    return y + y * z * p;
}

fn lf_cos(x: f32) -> f32 {
    let a = abs(lf_reduce_angle(x));
    return lf_sin((LF_HALF_PI_HI - a) + lf_half_pi_lo(a));
}
