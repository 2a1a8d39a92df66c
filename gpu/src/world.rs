//! Shader functions beyond the families' own lookups: SH basis, ZH → SH, order-3
//! rotation, SG algebra, the paper's ISG model, ISG patch integrals, and a disk
//! light's world-space radiance / irradiance. Each runs on the GPU at seeded random
//! inputs against the runtime's f64 functions (or the CPU emulation of the texture
//! plus f64 algebra) and, where the family has one, its independent reference.

use glam::DVec3;
use lobefit::export::layout::{Filter, Sampler};
use lobefit::export::run::TextureEntry;
use lobefit::export::Texture;
use lobefit::rng::Rng;
use lobefit_tables::isg::{IsgModel, PaperIsg, Sg};
use lobefit_tables::{sh, LookupError};

use crate::device::{wgsl_texture_type, Gpu, GpuTexture};
use crate::kernel::{kernel, lf_tex, LF_TEX_SIZE};
use crate::report::{scaled_diff, vector_diff, Row};

fn unit(rng: &mut Rng) -> DVec3 {
    loop {
        let v = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

/// f64 rounded to f32 and back: the inputs the GPU gets.
fn r32(v: f64) -> f64 {
    v as f32 as f64
}

fn run_rows(
    gpu: &Gpu,
    tex: &GpuTexture,
    params: &[u8],
    tex_type: &str,
    inputs: &[Vec<f64>],
    n_out: usize,
    body: &str,
) -> Result<Vec<Vec<f64>>, String> {
    let n_in = inputs[0].len();
    let flat: Vec<f32> = inputs.iter().flat_map(|x| x.iter().map(|&v| v as f32)).collect();
    let src = kernel(tex_type, n_in, n_out, body);
    let out = gpu.run(&src, params, tex, &flat, inputs.len(), n_out)?;
    Ok(out
        .chunks(n_out)
        .map(|c| c.iter().map(|&v| v as f64).collect())
        .collect())
}

fn row(function: &str, samples: usize, vs_cpu: f64, vs_ref: Vec<(String, f64, f64)>) -> Row {
    Row {
        function: function.into(),
        storage: "-".into(),
        filter: "-".into(),
        samples,
        vs_cpu,
        cpu_what: "runtime f64",
        vs_ref,
        info: Vec::new(),
    }
}

const NONE: [u8; LF_TEX_SIZE] = [0; LF_TEX_SIZE];
const WRITE64: &str = "    for (var k = 0u; k < 64u; k++) {\n        Y[o + k] = z[k];\n    }";
const WRITE9: &str = "    for (var k = 0u; k < 9u; k++) {\n        Y[o + k] = z[k];\n    }";

/// SH basis (order 8 and the order-3 polynomials), ZH → SH, order-3 rotation, SG
/// product / integrals / evaluation, and the paper's ISG model: GPU against f64.
pub fn check_closed_world(gpu: &Gpu, dummy: &GpuTexture, samples: usize, seed: u64) -> Result<Vec<Row>, String> {
    let t2 = "texture_2d<f32>";
    let mut rng = Rng::new(seed ^ 0x5a);
    let mut rows = Vec::new();
    let map = |e: LookupError| e.to_string();

    // Basis, order 8 and order 3.
    let dirs: Vec<Vec<f64>> = (0..samples)
        .map(|_| unit(&mut rng).to_array().map(r32).to_vec())
        .collect();
    let got = run_rows(
        gpu,
        dummy,
        &NONE,
        t2,
        &dirs,
        64,
        &format!("    let z = lf_sh_basis(8u, vec3<f32>(x0, x1, x2));\n{WRITE64}"),
    )?;
    let want: Vec<Vec<f64>> = dirs
        .iter()
        .map(|d| {
            let mut o = vec![0.0; 64];
            sh::eval_basis(8, DVec3::from_slice(d), &mut o).map(|_| o)
        })
        .collect::<Result<_, _>>()
        .map_err(map)?;
    rows.push(row("sh basis n8", samples, vector_diff(&got, &want), Vec::new()));
    let got = run_rows(
        gpu,
        dummy,
        &NONE,
        t2,
        &dirs,
        9,
        &format!("    let z = lf_sh9_basis(vec3<f32>(x0, x1, x2));\n{WRITE9}"),
    )?;
    let want9: Vec<Vec<f64>> = want.iter().map(|w| w[..9].to_vec()).collect();
    rows.push(row("sh9 basis", samples, vector_diff(&got, &want9), Vec::new()));

    // ZH → SH at order 8.
    let inputs: Vec<Vec<f64>> = dirs
        .iter()
        .map(|d| {
            let mut x = d.clone();
            x.extend((0..8).map(|_| r32(rng.range(-1.0, 1.0))));
            x
        })
        .collect();
    let body = format!(
        "    var zh: array<f32, 8>;\n    zh[0] = x3; zh[1] = x4; zh[2] = x5; zh[3] = x6; zh[4] = x7; zh[5] = x8; zh[6] = x9; zh[7] = x10;\n    let z = lf_zh_to_sh(8u, zh, vec3<f32>(x0, x1, x2));\n{WRITE64}"
    );
    let got = run_rows(gpu, dummy, &NONE, t2, &inputs, 64, &body)?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let mut o = vec![0.0; 64];
            sh::zh_to_sh(&x[3..11], DVec3::from_slice(&x[..3]), &mut o).map(|_| o)
        })
        .collect::<Result<_, _>>()
        .map_err(map)?;
    rows.push(row("zh to sh n8", samples, vector_diff(&got, &want), Vec::new()));

    // Order-3 rotation: R by axis and angle, passed as columns.
    let mut inputs = Vec::new();
    let mut mats = Vec::new();
    for _ in 0..samples {
        let r = sh::rotation_axis_angle(unit(&mut rng), rng.range(-3.2, 3.2)).map_err(map)?;
        let r = r.map(|row| row.map(r32));
        let mut x: Vec<f64> = (0..3)
            .flat_map(|c| (0..3).map(move |i| (i, c)))
            .map(|(i, c)| r[i][c])
            .collect();
        x.extend((0..9).map(|_| r32(rng.range(-1.0, 1.0))));
        inputs.push(x);
        mats.push(r);
    }
    let body = format!(
        "    let r = mat3x3<f32>(vec3<f32>(x0, x1, x2), vec3<f32>(x3, x4, x5), vec3<f32>(x6, x7, x8));\n    let c = array<f32, 9>(x9, x10, x11, x12, x13, x14, x15, x16, x17);\n    let z = lf_sh9_rotate(c, r);\n{WRITE9}"
    );
    let got = run_rows(gpu, dummy, &NONE, t2, &inputs, 9, &body)?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .zip(&mats)
        .map(|(x, r)| {
            let mut o = vec![0.0; 9];
            // The f32 matrix is orthonormal to ~1e-7 (the runtime accepts 1e-5).
            sh::Rotation::new(3, *r)
                .and_then(|rot| rot.apply(&x[9..18], &mut o))
                .map(|_| o)
        })
        .collect::<Result<_, _>>()
        .map_err(map)?;
    rows.push(row("sh9 rotate", samples, vector_diff(&got, &want), Vec::new()));

    // SG algebra: product, its integral, a lobe's hemisphere integral and value.
    let mut inputs = Vec::new();
    for _ in 0..samples {
        let mut x = Vec::new();
        for _ in 0..2 {
            x.extend(unit(&mut rng).to_array().map(r32));
            x.push(r32(rng.range(0.1f64.ln(), 1000f64.ln()).exp()));
            x.push(r32(rng.range(0.1, 10.0)));
        }
        x.extend(unit(&mut rng).to_array().map(r32));
        inputs.push(x);
    }
    let body = "    let g1 = LfSg(vec3<f32>(x0, x1, x2), x3, x4);\n    let g2 = LfSg(vec3<f32>(x5, x6, x7), x8, x9);\n    \
                let m = lf_sg_product(g1, g2);\n    Y[o] = m.axis.x;\n    Y[o + 1u] = m.axis.y;\n    Y[o + 2u] = m.axis.z;\n    \
                Y[o + 3u] = m.sharpness;\n    Y[o + 4u] = m.amplitude;\n    Y[o + 5u] = lf_sg_integral(m);\n    \
                Y[o + 6u] = lf_sg_hemisphere_integral(g1);\n    Y[o + 7u] = lf_sg_eval(g1, vec3<f32>(x10, x11, x12));";
    let got = run_rows(gpu, dummy, &NONE, t2, &inputs, 8, body)?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            // Axes as given (unit to f32 rounding), not re-normalised.
            let g1 = Sg {
                axis: DVec3::from_slice(&x[0..3]),
                sharpness: x[3],
                amplitude: x[4],
            };
            let g2 = Sg {
                axis: DVec3::from_slice(&x[5..8]),
                sharpness: x[8],
                amplitude: x[9],
            };
            let m = g1.product(&g2).map_err(|e| e.to_string())?;
            Ok(vec![
                m.axis.x,
                m.axis.y,
                m.axis.z,
                m.sharpness,
                m.amplitude,
                m.integral(),
                g1.hemisphere_integral(),
                g1.eval(DVec3::from_slice(&x[10..13])),
            ])
        })
        .collect::<Result<_, String>>()?;
    rows.push(row("sg algebra", samples, scaled_diff(&got, &want).0, Vec::new()));

    // The paper's ISG model (no texture).
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            vec![
                r32(rng.range(0.5f64.ln(), 1e4f64.ln()).exp()),
                r32(rng.range(0.0, std::f64::consts::PI)),
                r32(rng.range(0.0, std::f64::consts::PI)),
            ]
        })
        .collect();
    let got = run_rows(
        gpu,
        dummy,
        &NONE,
        t2,
        &inputs,
        2,
        "    let s = lf_isg_paper(x1, x2, x0);\n    Y[o] = s;\n    Y[o + 1u] = s * lf_isg_normaliser(x0);",
    )?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| Ok(vec![PaperIsg.s_hat(x[1], x[2], x[0])?, PaperIsg.s(x[1], x[2], x[0])?]))
        .collect::<Result<_, LookupError>>()
        .map_err(map)?;
    rows.push(row("isg paper", samples, scaled_diff(&got, &want).0, Vec::new()));

    // The lobe product's axis on the arc a1 -> a2 at fraction t, against the f64
    // slerp (sin((1 − t) α) a1 + sin(t α) a2) / sin α of the f32 inputs, normalised.
    // Half the pairs close (α log-uniform in [1e-4, 1]), half anywhere with α below
    // π − 1e-2 (the arc between near-antipodal axes is ill-conditioned).
    let mut inputs: Vec<Vec<f64>> = Vec::with_capacity(samples);
    while inputs.len() < samples {
        let a1 = unit(&mut rng);
        let a2 = if inputs.len().is_multiple_of(2) {
            let p = unit(&mut rng).cross(a1).normalize_or_zero();
            let ang = rng.range(1e-4f64.ln(), 0.0).exp();
            a1 * ang.cos() + p * ang.sin()
        } else {
            unit(&mut rng)
        };
        let t = rng.uniform();
        let x: Vec<f64> = [a1.to_array(), a2.to_array()]
            .concat()
            .into_iter()
            .chain([t])
            .map(r32)
            .collect();
        let (b1, b2) = (
            DVec3::from_slice(&x[0..3]).normalize(),
            DVec3::from_slice(&x[3..6]).normalize(),
        );
        if b1.dot(b2).clamp(-1.0, 1.0).acos() < std::f64::consts::PI - 1e-2 && b1 != b2 {
            inputs.push(x);
        }
    }
    let got = run_rows(
        gpu,
        dummy,
        &NONE,
        t2,
        &inputs,
        3,
        "    let a = lf_lobe_product_axis(vec3<f32>(x0, x1, x2), vec3<f32>(x3, x4, x5), x6);\n    \
         Y[o] = a.x;\n    Y[o + 1u] = a.y;\n    Y[o + 2u] = a.z;",
    )?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let (a1, a2) = (
                DVec3::from_slice(&x[0..3]).normalize(),
                DVec3::from_slice(&x[3..6]).normalize(),
            );
            let alpha = a1.dot(a2).clamp(-1.0, 1.0).acos();
            let v = (a1 * ((1.0 - x[6]) * alpha).sin() + a2 * (x[6] * alpha).sin()) / alpha.sin();
            v.to_array().to_vec()
        })
        .collect();
    rows.push(row(
        "lobe-product axis on the arc",
        samples,
        vector_diff(&got, &want),
        Vec::new(),
    ));
    Ok(rows)
}

/// Samplers of a family's textures for the CPU emulation.
pub fn samplers(texs: &[(TextureEntry, Texture)], filter: Filter) -> Vec<Sampler> {
    texs.iter()
        .map(|(e, t)| Sampler {
            axes: e.axes.clone(),
            channels: e.channels.clone(),
            texture: t.clone(),
            filter,
        })
        .collect()
}

/// The ISG patch integral of a textured model (`lf_isg_patch`, model 1 refit or 2
/// best): GPU against the same four corners through the CPU emulation, and against the
/// family's reference Ŝ at the corners (limit: 4 × the family's Ŝ limit, in units of
/// the normaliser 2π(1 − e^{−γ})/γ).
#[allow(clippy::too_many_arguments)]
pub fn check_patch(
    gpu: &Gpu,
    kind: &str,
    family: &dyn lobefit::family::Query,
    eval: fn(&[Sampler], &[f32]) -> Vec<f32>,
    texs: &[(TextureEntry, Texture)],
    tex: &GpuTexture,
    filter: Filter,
    emu_filter: Filter,
    s_hat_limit: f64,
    samples: usize,
    seed: u64,
) -> Result<Row, String> {
    let model = if kind == "isg-refit" { 1 } else { 2 };
    let mut rng = Rng::new(seed ^ 0x9a7c);
    let pi = std::f64::consts::PI;
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            let g = rng.range(0.5f64.ln(), 1e4f64.ln()).exp();
            let (a, b) = (rng.range(0.0, pi), rng.range(0.0, pi));
            let (c, d) = (rng.range(0.0, pi), rng.range(0.0, pi));
            vec![g, a.min(b), a.max(b), c.min(d), c.max(d)]
                .into_iter()
                .map(r32)
                .collect()
        })
        .collect();
    let body = format!("    Y[o] = lf_isg_patch(T, S, P, {model}u, x1, x2, x3, x4, x0) / lf_isg_normaliser(x0);");
    let got = run_rows(
        gpu,
        tex,
        &lf_tex(&texs[0].0, filter),
        wgsl_texture_type(&texs[0].1),
        &inputs,
        1,
        &body,
    )?;
    let smp = samplers(texs, emu_filter);
    let corners = |x: &[f64], f: &dyn Fn(f64, f64, f64) -> Result<f64, String>| -> Result<f64, String> {
        Ok(f(x[0], x[2], x[4])? - f(x[0], x[1], x[4])? - f(x[0], x[2], x[3])? + f(x[0], x[1], x[3])?)
    };
    let emu: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| corners(x, &|g, t, p| Ok(eval(&smp, &[g as f32, t as f32, p as f32])[0] as f64)).map(|v| vec![v]))
        .collect::<Result<_, _>>()?;
    let refs: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| corners(x, &|g, t, p| Ok(family.reference(&[g, t, p])?[0])).map(|v| vec![v]))
        .collect::<Result<_, _>>()?;
    let err = got
        .iter()
        .zip(&refs)
        .map(|(g, w)| (g[0] - w[0]).abs())
        .fold(0.0, f64::max);
    // Absolute, in units of the normaliser: the values lie in [−1, 1].
    let vs_cpu = got
        .iter()
        .zip(&emu)
        .map(|(g, w)| (g[0] - w[0]).abs())
        .fold(0.0, f64::max);
    Ok(Row {
        function: format!("{kind} patch"),
        storage: String::new(),
        filter: filter.name().into(),
        samples,
        vs_cpu,
        cpu_what: "emulation (abs)",
        vs_ref: vec![("patch / normaliser max_abs".into(), err, 4.0 * s_hat_limit)],
        info: Vec::new(),
    })
}

/// The canonical frame of a disk seen from `p` (f64, as the runtime builds it):
/// columns x', y', z' as a row-major matrix, d and τ.
fn disk_frame(p: DVec3, c: DVec3, n: DVec3) -> ([[f64; 3]; 3], f64, f64) {
    let n = n.normalize();
    let to = c - p;
    let d = to.length();
    let z = to / d;
    let cos_tau = (-n.dot(z)).clamp(-1.0, 1.0);
    let perp = n + cos_tau * z;
    let sin_tau = perp.length();
    let x = if sin_tau > 1e-8 {
        let x = perp / sin_tau;
        (x - x.dot(z) * z).normalize()
    } else {
        z.any_orthonormal_vector()
    };
    let y = z.cross(x);
    (
        [[x.x, y.x, z.x], [x.y, y.y, z.y], [x.z, y.z, z.z]],
        d,
        sin_tau.atan2(cos_tau),
    )
}

/// World radiance SH (9) and irradiance of canonical coefficients `c6` (f64 algebra).
fn disk_world(c6: &[f64], rot: [[f64; 3]; 3], radiance: f64, normal: DVec3) -> Result<Vec<f64>, String> {
    let mut canon = [0.0; 9];
    for (k, &i) in lobefit_tables::disk_light::CANONICAL_INDEX.iter().enumerate() {
        canon[i] = c6[k];
    }
    let mut out = [0.0; 9];
    sh::Rotation::new(3, rot)
        .and_then(|r| r.apply(&canon, &mut out))
        .map_err(|e| e.to_string())?;
    let mut y = [0.0; 9];
    sh::eval_basis(3, normal, &mut y).map_err(|e| e.to_string())?;
    let mut v: Vec<f64> = out.iter().map(|c| c * radiance).collect();
    let e: f64 = v
        .iter()
        .enumerate()
        .map(|(i, c)| c * sh::CLAMPED_COSINE[sh::band_of(i).0] * y[i])
        .sum();
    v.push(e);
    Ok(v)
}

/// A disk light in world space (`lf_disk_radiance_sh`, `lf_disk_irradiance`): random
/// frames, R/d and τ from the family's sample; against the CPU emulation of the
/// texture with f64 rotation and convolution, and against the family's reference
/// canonical coefficients (quadrature) rotated in f64: the radiance 9-vector's relative
/// L2 error held to the family's limit.
#[allow(clippy::too_many_arguments)]
pub fn check_disk_world(
    gpu: &Gpu,
    family: &dyn lobefit::family::Query,
    eval: fn(&[Sampler], &[f32]) -> Vec<f32>,
    texs: &[(TextureEntry, Texture)],
    tex: &GpuTexture,
    filter: Filter,
    emu_filter: Filter,
    l2_limit: f64,
    samples: usize,
    seed: u64,
) -> Result<Row, String> {
    let mut rng = Rng::new(seed ^ 0xd15c);
    let mut inputs = Vec::new();
    for _ in 0..samples {
        let s = family.sample(&mut rng);
        let (ratio, tau) = (s[0], s[1]);
        let r = sh::rotation_axis_angle(unit(&mut rng), rng.range(-3.2, 3.2)).map_err(|e| e.to_string())?;
        let col = |k: usize| DVec3::new(r[0][k], r[1][k], r[2][k]);
        let p = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let d = rng.range(0.5, 2.0);
        let c = p + d * col(2);
        let n = tau.sin() * col(0) - tau.cos() * col(2);
        let rn = unit(&mut rng);
        let mut x: Vec<f64> = Vec::new();
        for v in [p, rn, c, n] {
            x.extend(v.to_array());
        }
        x.push(ratio * d);
        x.push(rng.range(0.5, 2.0));
        inputs.push(x.into_iter().map(r32).collect::<Vec<f64>>());
    }
    let v3 = |x: &[f64], k: usize| DVec3::new(x[k], x[k + 1], x[k + 2]);
    let body = "    let z = lf_disk_radiance_sh(T, S, P, vec3<f32>(x0, x1, x2), vec3<f32>(x6, x7, x8), vec3<f32>(x9, x10, x11), x12, x13);\n\
    for (var k = 0u; k < 9u; k++) {\n        Y[o + k] = z[k];\n    }\n\
    Y[o + 9u] = lf_disk_irradiance(T, S, P, vec3<f32>(x0, x1, x2), vec3<f32>(x3, x4, x5), vec3<f32>(x6, x7, x8), vec3<f32>(x9, x10, x11), x12, x13);";
    let got = run_rows(
        gpu,
        tex,
        &lf_tex(&texs[0].0, filter),
        wgsl_texture_type(&texs[0].1),
        &inputs,
        10,
        body,
    )?;
    let smp = samplers(texs, emu_filter);
    let mut emu = Vec::new();
    let mut refs = Vec::new();
    for x in &inputs {
        let (rot, d, tau) = disk_frame(v3(x, 0), v3(x, 6), v3(x, 9));
        let ratio = x[12] / d;
        let c6: Vec<f64> = eval(&smp, &[ratio as f32, tau as f32])
            .into_iter()
            .map(f64::from)
            .collect();
        emu.push(disk_world(&c6, rot, x[13], v3(x, 3))?);
        let rc = lobefit::fits::disk_light::reference_canonical(ratio, tau)?;
        refs.push(disk_world(&rc, rot, x[13], v3(x, 3))?);
    }
    let split = |v: &[Vec<f64>]| -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        (
            v.iter().map(|r| r[..9].to_vec()).collect(),
            v.iter().map(|r| r[9..].to_vec()).collect(),
        )
    };
    let (g9, ge) = split(&got);
    let (e9, ee) = split(&emu);
    let vs_cpu = vector_diff(&g9, &e9).max(scaled_diff(&ge, &ee).0);
    let l2 = g9
        .iter()
        .zip(&refs)
        .map(|(g, w)| {
            let num: f64 = g.iter().zip(w).map(|(a, b)| (a - b).powi(2)).sum();
            let den: f64 = w[..9].iter().map(|b| b * b).sum();
            (num / den).sqrt()
        })
        .fold(0.0, f64::max);
    Ok(Row {
        function: "disk-light world".into(),
        storage: String::new(),
        filter: filter.name().into(),
        samples,
        vs_cpu,
        cpu_what: "emulation",
        vs_ref: vec![("radiance SH rel L2 max".into(), l2, l2_limit)],
        info: Vec::new(),
    })
}

/// `lf_disk_canonical` beyond the table, as the runtime extends it (R/d below 0.01 and
/// above 10, τ beyond the last row, the back side), against the runtime's
/// `DiskLight::canonical` (f64, the committed table): for f32 exports at scale 1 only,
/// whose texels are the table's values (elsewhere the texture differs from the table
/// by its storage or resampling, which the canonical row measures). Limit: the
/// canonical 6-vector's relative L2 difference, [`crate::conformance::TOL_CPU`].
pub fn check_disk_extensions(
    gpu: &Gpu,
    texs: &[(TextureEntry, Texture)],
    tex: &GpuTexture,
    filter: Filter,
    samples: usize,
    seed: u64,
) -> Result<Row, String> {
    let mut rng = Rng::new(seed ^ 0xe87);
    let tau_max = lobefit_tables::disk_light::TAU_MAX;
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|k| {
            let (r, tau) = match k % 4 {
                0 => (rng.range(1e-4f64.ln(), 0.01f64.ln()).exp(), rng.range(0.0, tau_max)),
                1 => (rng.range(10f64.ln(), 1e3f64.ln()).exp(), rng.range(0.0, tau_max)),
                2 => (
                    rng.range(0.01f64.ln(), 10f64.ln()).exp(),
                    rng.range(tau_max, std::f64::consts::FRAC_PI_2),
                ),
                _ => (
                    rng.range(0.01f64.ln(), 10f64.ln()).exp(),
                    rng.range(std::f64::consts::FRAC_PI_2, 3.0),
                ),
            };
            vec![r32(r), r32(tau)]
        })
        .collect();
    let body = "    let c = lf_disk_canonical(T, S, P, x0, x1);\n    Y[o] = c[0].x;\n    Y[o + 1u] = c[0].y;\n    Y[o + 2u] = c[0].z;\n    \
                Y[o + 3u] = c[0].w;\n    Y[o + 4u] = c[1].x;\n    Y[o + 5u] = c[1].y;";
    let got = run_rows(
        gpu,
        tex,
        &lf_tex(&texs[0].0, filter),
        wgsl_texture_type(&texs[0].1),
        &inputs,
        6,
        body,
    )?;
    let disk = lobefit_tables::disk_light::DiskLight::embedded().map_err(|e| e.to_string())?;
    let mut worst = 0.0f64;
    for (g, x) in got.iter().zip(&inputs) {
        let w = disk.canonical(x[0], x[1]).map_err(|e| e.to_string())?;
        let num: f64 = g.iter().zip(&w).map(|(a, b)| (a - b).powi(2)).sum();
        let den: f64 = w.iter().map(|b| b * b).sum();
        let d = if den > 0.0 { (num / den).sqrt() } else { num.sqrt() };
        worst = worst.max(d);
    }
    Ok(Row {
        function: "disk-light extensions".into(),
        storage: String::new(),
        filter: filter.name().into(),
        samples,
        vs_cpu: worst,
        cpu_what: "runtime f64 (L2)",
        vs_ref: Vec::new(),
        info: Vec::new(),
    })
}

/// `lf_wedge_apply` (order 8, every W) against the same mat-vec in f64 over the CPU's
/// fetch of the exported entries; vector-relative (see [`vector_diff`]).
pub fn check_wedge_apply(
    gpu: &Gpu,
    texs: &[(TextureEntry, Texture)],
    tex: &GpuTexture,
    samples: usize,
    seed: u64,
) -> Result<Row, String> {
    let mut rng = Rng::new(seed ^ 0x3ed6e);
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|k| {
            let mut x = vec![(k % 5) as f64];
            x.extend((0..16).map(|_| r32(rng.range(-5.0, 0.0))));
            x
        })
        .collect();
    let body = "    var va: array<f32, 8>;\n    var vb: array<f32, 8>;\n    for (var k = 0u; k < 8u; k++) {\n        \
                va[k] = X[i * 17u + 1u + k];\n        vb[k] = X[i * 17u + 9u + k];\n    }\n    \
                let z = lf_wedge_apply(T, P, u32(x0), 8u, va, vb);\n    for (var k = 0u; k < 64u; k++) {\n        Y[o + k] = z[k];\n    }";
    let got = run_rows(
        gpu,
        tex,
        &lf_tex(&texs[0].0, Filter::Manual),
        wgsl_texture_type(&texs[0].1),
        &inputs,
        64,
        body,
    )?;
    let smp = samplers(texs, Filter::Manual);
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let w = x[0] as usize;
            (0..64)
                .map(|row| {
                    (0..8)
                        .map(|j| {
                            smp[0].fetch(&[w, row, j])[0] as f64 * x[1 + j]
                                + smp[0].fetch(&[w, row, 8 + j])[0] as f64 * x[9 + j]
                        })
                        .sum()
                })
                .collect()
        })
        .collect();
    Ok(Row {
        function: "wedge apply n8".into(),
        storage: String::new(),
        filter: "fetch".into(),
        samples,
        vs_cpu: vector_diff(&got, &want),
        cpu_what: "emulation, f64",
        vs_ref: Vec::new(),
        info: Vec::new(),
    })
}
