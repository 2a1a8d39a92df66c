// lobefit shader library: uniform disk lights in order-3 SH (needs common.wgsl and
// sh.wgsl). A one-sided disk (centre, emitting normal n, radius R) seen from a
// receiver at distance d has, in its canonical frame (z' from the receiver to the
// centre, n = sin tau x' - cos tau z'), the radiance coefficients c_00, c_10, c_11,
// c_20, c_21, c_22 (others 0) per unit radiance; they depend on R/d and tau only.

// The table's R/d range and last tau row (lobefit_tables::disk_light::{R_MIN, R_MAX, TAU_MAX}).
const LF_DISK_R_MIN: f32 = 0.01;
const LF_DISK_R_MAX: f32 = 10.0;
const LF_DISK_TAU_MAX: f32 = 1.5692255;

// g(r) = ln r + asinh((r - sin tau) / cos tau).
fn lf_disk_rim_g(r: f32, sc: vec2<f32>) -> f32 {
    return log(r) + lf_asinh((r - sc.x) / sc.y);
}

// The texture's first axis: the rim coordinate v in [0, 1] of (R/d, tau).
fn lf_disk_rim(r: f32, tau: f32) -> f32 {
    let sc = vec2<f32>(lf_sin(tau), lf_cos(tau));
    let lo = lf_disk_rim_g(LF_DISK_R_MIN, sc);
    let hi = lf_disk_rim_g(LF_DISK_R_MAX, sc);
    return clamp((lf_disk_rim_g(r, sc) - lo) / (hi - lo), 0.0, 1.0);
}

// The canonical coefficients from the exported `disk-light` texture (2D array, 2
// layers RGBA on (v, logit tau): ln c00, c10/c00, c11/c00, c20/c00 | c21/c00,
// c22/c00) for R/d in [0.01, 10], tau in [0, 0.999 pi/2]: (c00, c10, c11, c20) and
// (c21, c22, 0, 0).
fn lf_disk_canonical_table(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, r: f32, tau: f32) -> array<vec4<f32>, 2> {
    let v = lf_disk_rim(r, tau);
    let a = lf_sample_2d_layer(tex, smp, p, 0u, v, tau);
    let b = lf_sample_2d_layer(tex, smp, p, 1u, v, tau);
    let c00 = exp(a.x);
    return array<vec4<f32>, 2>(vec4<f32>(c00, c00 * a.y, c00 * a.z, c00 * a.w), vec4<f32>(c00 * b.x, c00 * b.y, 0.0, 0.0));
}

// The canonical coefficients for any R/d > 0 and tau in [0, pi] as the runtime
// (DiskLight::canonical) extends the table: R/d < 0.01: c00 scaled by (R/d / 0.01)^2;
// R/d > 10: linear in d/R towards the infinite plane; tau beyond the last row: linear
// in cos tau towards the limit at the disk's plane; tau >= pi/2: zero (back side).
fn lf_disk_canonical(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, r: f32, tau: f32) -> array<vec4<f32>, 2> {
    if tau >= 0.5 * LF_PI {
        return array<vec4<f32>, 2>(vec4<f32>(0.0), vec4<f32>(0.0));
    }
    let sqrt_pi = 1.7724539;
    let z1 = 1.5349901; // sqrt(3 pi) / 2
    let rt = clamp(r, LF_DISK_R_MIN, LF_DISK_R_MAX);
    let tt = min(tau, LF_DISK_TAU_MAX);
    var c = lf_disk_canonical_table(tex, smp, p, rt, tt);
    if tau > LF_DISK_TAU_MAX {
        // The limit at the plane: the hemisphere about (-1, 0, 0) for R/d > 1, half of
        // it at R/d = 1, nothing below.
        var f = 0.0;
        if rt > 1.0 {
            f = 1.0;
        } else if rt == 1.0 {
            f = 0.5;
        }
        let lim = vec4<f32>(f * sqrt_pi, 0.0, f * z1, 0.0);
        let w = lf_cos(tau) / lf_cos(LF_DISK_TAU_MAX);
        c[0] = lim + w * (c[0] - lim);
        c[1] = w * c[1];
    }
    if r > LF_DISK_R_MAX {
        let lim = vec4<f32>(sqrt_pi, z1 * lf_cos(tau), z1 * lf_sin(tau), 0.0);
        let w = LF_DISK_R_MAX / r;
        c[0] = lim + w * (c[0] - lim);
        c[1] = w * c[1];
    }
    if r < LF_DISK_R_MIN {
        let k = (r / LF_DISK_R_MIN) * (r / LF_DISK_R_MIN);
        c[0] *= k;
        c[1] *= k;
    }
    return c;
}

// The canonical frame of a disk seen from a receiver: `rot`'s columns are x', y', z'
// in world coordinates; d the distance to the centre, tau the tilt (rad).
struct LfDiskFrame {
    rot: mat3x3<f32>,
    d: f32,
    tau: f32,
    cos_tau: f32,
}

fn lf_disk_frame(receiver: vec3<f32>, centre: vec3<f32>, normal: vec3<f32>) -> LfDiskFrame {
    let n = normalize(normal);
    let to = centre - receiver;
    let d = length(to);
    let z = to / d;
    let cos_tau = clamp(-dot(n, z), -1.0, 1.0);
    let perp = n + cos_tau * z;
    let sin_tau = length(perp);
    var x: vec3<f32>;
    if sin_tau > 1e-6 {
        x = perp / sin_tau;
        x = normalize(x - dot(x, z) * z);
    } else {
        // Head-on: any x' perpendicular to z' (the coefficients do not depend on it).
        var a = vec3<f32>(1.0, 0.0, 0.0);
        if abs(z.x) > 0.9 {
            a = vec3<f32>(0.0, 1.0, 0.0);
        }
        x = normalize(a - dot(a, z) * z);
    }
    let y = cross(z, x);
    return LfDiskFrame(mat3x3<f32>(x, y, z), d, atan2(sin_tau, cos_tau), cos_tau);
}

// Order-3 radiance SH vector (world frame) of a one-sided disk of uniform `radiance`,
// seen from `receiver` (positions and radius in one length unit).
fn lf_disk_radiance_sh(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, receiver: vec3<f32>, centre: vec3<f32>, normal: vec3<f32>, radius: f32, radiance: f32) -> array<f32, 9> {
    var out: array<f32, 9>;
    let g = lf_disk_frame(receiver, centre, normal);
    if g.cos_tau <= 0.0 {
        return out;
    }
    let c = lf_disk_canonical(tex, smp, p, radius / g.d, g.tau);
    // Canonical 9-vector: indices 0, 2, 3, 6, 7, 8 (m >= 0).
    let canon = array<f32, 9>(c[0].x, 0.0, c[0].y, c[0].z, 0.0, 0.0, c[0].w, c[1].x, c[1].y);
    out = lf_sh9_rotate(canon, g.rot);
    for (var i = 0u; i < 9u; i++) {
        out[i] *= radiance;
    }
    return out;
}

// The irradiance SH vector: the radiance vector convolved with the clamped cosine
// (band weights pi, 2 pi / 3, pi / 4); E(N) = sum E_lm y_lm(N).
fn lf_disk_irradiance_sh(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, receiver: vec3<f32>, centre: vec3<f32>, normal: vec3<f32>, radius: f32, radiance: f32) -> array<f32, 9> {
    var e = lf_disk_radiance_sh(tex, smp, p, receiver, centre, normal, radius, radiance);
    e[0] *= LF_PI;
    for (var i = 1u; i < 4u; i++) {
        e[i] *= 2.0 * LF_PI / 3.0;
    }
    for (var i = 4u; i < 9u; i++) {
        e[i] *= 0.25 * LF_PI;
    }
    return e;
}

// Irradiance at `receiver` with unit surface normal `receiver_normal` (radiance x sr).
fn lf_disk_irradiance(tex: texture_2d_array<f32>, smp: sampler, p: LfTex, receiver: vec3<f32>, receiver_normal: vec3<f32>, centre: vec3<f32>, normal: vec3<f32>, radius: f32, radiance: f32) -> f32 {
    let e = lf_disk_irradiance_sh(tex, smp, p, receiver, centre, normal, radius, radiance);
    let y = lf_sh9_basis(receiver_normal);
    var sum = 0.0;
    for (var i = 0u; i < 9u; i++) {
        sum += e[i] * y[i];
    }
    return sum;
}
