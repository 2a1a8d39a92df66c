// lobefit shader library: real spherical harmonics (needs common.wgsl). Conventions
// of lobefit_tables::sh: y_lm with the Condon-Shortley phase, index l (l + 1) + m,
// orthonormal on the sphere; order n holds bands l < n (n^2 coefficients, n <= 8).

// K_l^m = sqrt((2l + 1) / (4 pi) (l - m)! / (l + m)!).
fn lf_sh_k(l: u32, m: u32) -> f32 {
    var ratio = 1.0;
    for (var k = l - m + 1u; k <= l + m; k++) {
        ratio /= f32(k);
    }
    return sqrt(f32(2u * l + 1u) / (4.0 * LF_PI) * ratio);
}

// The basis y_0 .. y_{n^2 - 1} at the unit direction d (entries from n^2 on: 0), by
// the associated-Legendre recurrence in Cartesian form.
fn lf_sh_basis(order: u32, d: vec3<f32>) -> array<f32, 64> {
    var out: array<f32, 64>;
    var c = 1.0; // Re (x + iy)^m
    var s = 0.0; // Im (x + iy)^m
    var dfact = 1.0; // (2m - 1)!!
    for (var m = 0u; m < order; m++) {
        if m > 0u {
            let c2 = c * d.x - s * d.y;
            s = c * d.y + s * d.x;
            c = c2;
            dfact *= f32(2u * m - 1u);
        }
        var sign = 1.0;
        if (m & 1u) == 1u {
            sign = -1.0;
        }
        var q_prev = 0.0;
        var q = dfact;
        for (var l = m; l < order; l++) {
            if l > m {
                let q_next = (f32(2u * l - 1u) * d.z * q - f32(l + m - 1u) * q_prev) / f32(l - m);
                q_prev = q;
                q = q_next;
            }
            let k = lf_sh_k(l, m);
            let base = l * (l + 1u);
            if m == 0u {
                out[base] = k * q;
            } else {
                let a = 1.4142135 * k * sign * q;
                out[base + m] = a * c;
                out[base - m] = a * s;
            }
        }
    }
    return out;
}

// Order 3 (9 coefficients) by its polynomials: the SH lighting workhorse.
fn lf_sh9_basis(d: vec3<f32>) -> array<f32, 9> {
    let c1 = 0.48860251;
    let c2a = 1.0925484;
    let c2b = 0.31539157;
    let c2c = 0.54627422;
    return array<f32, 9>(
        0.28209479,
        -c1 * d.y, c1 * d.z, -c1 * d.x,
        c2a * d.x * d.y, -c2a * d.y * d.z, c2b * (3.0 * d.z * d.z - 1.0), -c2a * d.x * d.z, c2c * (d.x * d.x - d.y * d.y),
    );
}

// A ZH vector zh[0..n) (symmetric about +z) turned to the unit axis d:
// out_lm = sqrt(4 pi / (2l + 1)) zh_l y_lm(d) (Funk-Hecke), n^2 outputs.
fn lf_zh_to_sh(order: u32, zh: array<f32, 8>, d: vec3<f32>) -> array<f32, 64> {
    var out = lf_sh_basis(order, d);
    for (var l = 0u; l < order; l++) {
        let s = sqrt(4.0 * LF_PI / f32(2u * l + 1u)) * zh[l];
        for (var i = l * l; i < (l + 1u) * (l + 1u); i++) {
            out[i] *= s;
        }
    }
    return out;
}

// lf_zh_to_sh(4u, zh, d) by the bands' polynomials (zh[4..8) unused): 16 outputs,
// sqrt(4 pi / (2l + 1)) zh_l y_lm(d), without the recurrence's normalisations (a
// factorial loop and a square root per coefficient) or a 64-entry array. For kernels
// at order 4 (lobefit's SH exponentiation): on lavapipe it took a kernel rotating a ZH
// vector per blocker from 103 to 50 us a pixel.
fn lf_zh_to_sh16(zh: array<f32, 8>, d: vec3<f32>) -> array<f32, 16> {
    let x = d.x;
    let y = d.y;
    let z = d.z;
    // sqrt(4 pi / (2l + 1)) K_l^m, times sqrt(2) for m != 0: sqrt(3), 1/2 and sqrt(3)/2
    // in band 2; sqrt(5/8), sqrt(15), sqrt(3/8), 1/2 and sqrt(15)/2 in band 3.
    let a = 1.7320508 * zh[2];
    let b = 0.7905694 * zh[3];
    let c = 0.6123724 * zh[3] * (5.0 * z * z - 1.0);
    return array<f32, 16>(
        zh[0],
        -zh[1] * y, zh[1] * z, -zh[1] * x,
        a * x * y, -a * y * z, 0.5 * zh[2] * (3.0 * z * z - 1.0), -a * x * z, 0.8660254 * zh[2] * (x * x - y * y),
        -b * y * (3.0 * x * x - y * y), 3.8729833 * zh[3] * x * y * z, -c * y, 0.5 * zh[3] * z * (5.0 * z * z - 3.0),
        -c * x, 1.9364917 * zh[3] * z * (x * x - y * y), -b * x * (x * x - 3.0 * y * y),
    );
}

// An order-3 SH vector rotated: out(w) = c(R^T w), with R's columns the rotated frame's
// axes in world coordinates (R orthonormal). Band 1 turns as a vector, band 2 as the
// traceless quadratic form w^T Q w it represents.
fn lf_sh9_rotate(c: array<f32, 9>, r: mat3x3<f32>) -> array<f32, 9> {
    let c2a = 1.0925484;
    let c2b = 0.31539157;
    let c2c = 0.54627422;
    // Band 1: f = C1 w.v with v = (-c11, -c1-1, c10).
    let v = r * vec3<f32>(-c[3], -c[1], c[2]);
    // Band 2: Q from the five coefficients.
    let qxy = 0.5 * c2a * c[4];
    let qyz = -0.5 * c2a * c[5];
    let qxz = -0.5 * c2a * c[7];
    let qzz = 2.0 * c2b * c[6];
    let qxx = -c2b * c[6] + c2c * c[8];
    let qyy = -c2b * c[6] - c2c * c[8];
    let q = mat3x3<f32>(vec3<f32>(qxx, qxy, qxz), vec3<f32>(qxy, qyy, qyz), vec3<f32>(qxz, qyz, qzz));
    let w = r * q * transpose(r);
    return array<f32, 9>(
        c[0],
        -v.y, v.z, -v.x,
        2.0 * w[0][1] / c2a, -2.0 * w[1][2] / c2a, w[2][2] / (2.0 * c2b), -2.0 * w[0][2] / c2a, (w[0][0] - w[1][1]) / (2.0 * c2c),
    );
}

// An SH vector c (n^2 coefficients, n <= 8) rotated by alpha (rad) about +z,
// counter-clockwise seen from +z: out(theta, phi) = c(theta, phi - alpha), as
// lobefit_tables::sh::rotate_z. Band l's pair (m, -m)
// turns by m alpha: out_lm = c_lm cos(m alpha) - c_l-m sin(m alpha), out_l-m =
// c_lm sin(m alpha) + c_l-m cos(m alpha); cos, sin of m alpha by the angle-addition
// recurrence (no large arguments to cos, sin). Entries from n^2 on: 0.
fn lf_sh_rotate_z(order: u32, c: array<f32, 64>, alpha: f32) -> array<f32, 64> {
    var out: array<f32, 64>;
    var cs: array<f32, 8>;
    var sn: array<f32, 8>;
    cs[0] = 1.0;
    let c1 = lf_cos(alpha);
    let s1 = lf_sin(alpha);
    for (var m = 1u; m < order; m++) {
        cs[m] = cs[m - 1u] * c1 - sn[m - 1u] * s1;
        sn[m] = sn[m - 1u] * c1 + cs[m - 1u] * s1;
    }
    for (var l = 0u; l < order; l++) {
        let base = l * (l + 1u);
        out[base] = c[base];
        for (var m = 1u; m <= l; m++) {
            let a = c[base + m];
            let b = c[base - m];
            out[base + m] = a * cs[m] - b * sn[m];
            out[base - m] = a * sn[m] + b * cs[m];
        }
    }
    return out;
}

// The truncated SH product of order n <= 4: (f * g)_i = sum_jk Gamma_ijk f_j g_k for
// i < n^2 (f, g: n^2 coefficients, entries from n^2 on ignored; outputs from n^2 on:
// 0), the projection of the product of the two functions onto bands l < n. By the
// unique Gaunt entries of gaunt.wgsl, each applied to its distinct orderings (as
// lobefit_tables::gaunt::Gaunt::product).
fn lf_sh_product(order: u32, f: array<f32, 16>, g: array<f32, 16>) -> array<f32, 16> {
    var ijk = LF_GAUNT4_IJK;
    var val = LF_GAUNT4_VALUE;
    var counts = LF_GAUNT4_COUNT;
    var a = f;
    var b = g;
    var out: array<f32, 16>;
    let count = counts[min(order, 4u)];
    for (var e = 0u; e < count; e++) {
        let t = ijk[e];
        let i = t & 255u;
        let j = (t >> 8u) & 255u;
        let k = t >> 16u;
        let v = val[e];
        if i == j && j == k {
            out[i] += v * a[i] * b[i];
        } else if i == j {
            out[i] += v * (a[i] * b[k] + a[k] * b[i]);
            out[k] += v * a[i] * b[i];
        } else if j == k {
            out[i] += v * a[j] * b[j];
            out[j] += v * (a[i] * b[j] + a[j] * b[i]);
        } else {
            out[i] += v * (a[j] * b[k] + a[k] * b[j]);
            out[j] += v * (a[i] * b[k] + a[k] * b[i]);
            out[k] += v * (a[i] * b[j] + a[j] * b[i]);
        }
    }
    return out;
}
