//! Shader functions of the runtime beyond any table: SH basis, ZH → SH, order-3
//! rotation, rotation about z, the truncated SH product, the wedge slice vector, SG
//! algebra, the paper's ISG model, rig reconstruction and wrap shading; and Γ_L, the
//! lookup of a map's prefiltered texture (a small map built here, not an export's). Each runs on
//! the GPU at seeded random inputs against the runtime's f64 functions. (The families' world-space functions,
//! ISG patches, disk lights, the wedge mat-vec, are checked by their own
//! `fits/<family>/gpu.rs`.)

use glam::DVec3;
use lobefit::export::gpu_check::{r32, unit};
use lobefit::rng::Rng;
use lobefit_tables::isg::{IsgModel, PaperIsg, Sg};
use lobefit_tables::{sh, LookupError};

use crate::device::{Gpu, GpuTexture};
use crate::kernel::{kernel, LF_TEX_SIZE};
use lobefit::export::gpu_check::{scaled_diff, vector_diff, Row};

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
    let mut rng = Rng::new(seed ^ 0x5a);
    let mut rows = check_sh_basis(gpu, dummy, samples, &mut rng)?;
    rows.extend(check_sg(gpu, dummy, samples, &mut rng)?);
    rows.extend(check_lobe_product_axis(gpu, dummy, samples, &mut rng)?);
    rows.extend(check_sh_algebra(gpu, dummy, samples, &mut rng)?);
    rows.push(check_rigs(gpu, dummy, samples, &mut rng)?);
    rows.extend(check_meunier(gpu, dummy, samples, &mut rng)?);
    rows.extend(check_prefiltered(gpu, samples, &mut rng)?);
    Ok(rows)
}

/// A 64 × 32 map for Γ_L's rows: a sky gradient, a band of ripples and a bright 2 × 1
/// texel spot (a sun's share of the values' range).
fn prefilter_map() -> Result<lobefit::pipelines::envmap::EnvMap, String> {
    let (w, h) = (64usize, 32usize);
    let mut rgb = Vec::with_capacity(w * h);
    for v in 0..h {
        for u in 0..w {
            let base = 0.2 + 0.8 * (1.0 - v as f64 / h as f64);
            let ripple = 0.3 * (1.0 + (0.7 * u as f64).sin() * (0.9 * v as f64).cos());
            let spot = if (u == 13 || u == 14) && v == 9 { 60.0 } else { 0.0 };
            rgb.push([base + ripple + spot, 0.9 * base + 0.5 * spot, 1.1 * base + 0.5 * ripple]);
        }
    }
    lobefit::pipelines::envmap::EnvMap::new(w, h, rgb)
}

/// `lf_prefiltered` in f64 on the texture's own texels (`data`, already rounded to the
/// storage), the bilinear weights of each layer rounded down (`Some(false)`) or up
/// (`Some(true)`) to a step of `1/256` and one step further per axis, or exact (`None`), per axis in `(x, y)`: the
/// CPU side of the f16 and hardware rows. RGBA, before the clamp at 0.
fn prefiltered_twin(tex: &lobefit::export::Texture, a: DVec3, lambda: f64, round: [Option<bool>; 2]) -> [f64; 4] {
    let (w, h) = (tex.width as usize, tex.height as usize);
    let (theta, phi) = lobefit::pipelines::prefilter::angles(a);
    let sx = phi / std::f64::consts::TAU * (w - 1) as f64;
    let sy = theta / std::f64::consts::PI * (h - 1) as f64;
    let split = |s: f64, n: usize, r: Option<bool>| {
        let c = s.clamp(0.0, (n - 1) as f64);
        let i = c.floor().min((n - 2) as f64);
        let f = c - i;
        let f = match r {
            None => f,
            // A step past floor and ceil, as the conformance's span allows: a GPU may
            // quantize its coordinate before weighting (an H200's 1000-texel axis read
            // weights a step below nearest; Γ_L's axes are 257 and 129 texels).
            Some(false) => (((f * 256.0).floor() - 1.0) / 256.0).max(0.0),
            Some(true) => (((f * 256.0).ceil() + 1.0) / 256.0).min(1.0),
        };
        (i as usize, f)
    };
    let (i, fx) = split(sx, w, round[0]);
    let (j, fy) = split(sy, h, round[1]);
    let top = (tex.layers - 1) as f64;
    let t = (lambda.log2() * lobefit::pipelines::prefilter::PER_OCTAVE as f64).clamp(0.0, top);
    let j0 = (t.floor() - 1.0).clamp(0.0, top - 3.0);
    let u = t - j0;
    let lw = [
        -(u - 1.0) * (u - 2.0) * (u - 3.0) / 6.0,
        u * (u - 2.0) * (u - 3.0) / 2.0,
        -u * (u - 1.0) * (u - 3.0) / 2.0,
        u * (u - 1.0) * (u - 2.0) / 6.0,
    ];
    let at = |l: usize, x: usize, y: usize, c: usize| tex.data[((l * h + y) * w + x) * 4 + c] as f64;
    let mut out = [0.0; 4];
    for (k, wk) in lw.iter().enumerate() {
        let l = j0 as usize + k;
        for (c, o) in out.iter_mut().enumerate() {
            let lo = at(l, i, j, c) + fx * (at(l, i + 1, j, c) - at(l, i, j, c));
            let hi = at(l, i, j + 1, c) + fx * (at(l, i + 1, j + 1, c) - at(l, i, j + 1, c));
            *o += wk * (lo + fy * (hi - lo));
        }
    }
    out
}

/// Γ_L (`lf_prefiltered`, `lf_prefiltered_hw`) on a small map's table at random axes and
/// λ log-uniform over the ladder: f32 by textureLoad against the CPU's lookup
/// (`prefilter::lookup`, the table's own interpolation), f16 by textureLoad against its
/// texels in f64, and f16 by the hardware's filter against the span of its weights
/// rounded to 1/256 and a step beyond, the texels 2 f16 ulps wide (the conformance's
/// span: a GPU's 8-bit sub-texel weights, or exact ones, lie inside).
fn check_prefiltered(gpu: &Gpu, samples: usize, rng: &mut Rng) -> Result<Vec<Row>, String> {
    use lobefit::export::Storage;
    use lobefit::pipelines::prefilter;
    let (table, _) = prefilter::build(&prefilter_map()?, "gpu-check")?;
    let tex = prefilter::texture(&table, "gamma-l")?;
    let top = prefilter::LAMBDA_MAX.ln();
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            let mut x = unit(rng).to_array().map(r32).to_vec();
            x.push(r32(rng.range(0.0, top).exp()));
            x
        })
        .collect();
    let arr = "texture_2d_array<f32>";
    let write4 = "    Y[o] = v.x;\n    Y[o + 1u] = v.y;\n    Y[o + 2u] = v.z;\n    Y[o + 3u] = v.w;";
    let manual = format!("    let v = lf_prefiltered(T, vec3<f32>(x0, x1, x2), x3);\n{write4}");
    let hardware = format!("    let v = lf_prefiltered_hw(T, S, vec3<f32>(x0, x1, x2), x3);\n{write4}");
    let lum = |c: [f64; 3]| vec![c[0], c[1], c[2], 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]];
    let mut rows = Vec::new();

    // f32, textureLoad: against the table's interpolation on the CPU.
    let up = gpu.upload(&tex, Storage::F32)?;
    let got = run_rows(gpu, &up, &NONE, arr, &inputs, 4, &manual)?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| prefilter::lookup(&table, DVec3::from_slice(&x[..3]), x[3]).map(lum))
        .collect::<Result<_, _>>()?;
    rows.push(prefiltered_row(
        samples,
        scaled_diff(&got, &want).0,
        ("f32", "manual"),
        "the table's lookup",
        None,
    ));

    // f16, textureLoad: against the f16 texels in f64; the storage's cost beside.
    let mut half = tex.clone();
    for v in &mut half.data {
        *v = half::f16::from_f32(*v).to_f32();
    }
    let up = gpu.upload(&tex, Storage::F16)?;
    let got = run_rows(gpu, &up, &NONE, arr, &inputs, 4, &manual)?;
    let twin: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            prefiltered_twin(&half, DVec3::from_slice(&x[..3]), x[3], [None, None])
                .map(|v| v.max(0.0))
                .to_vec()
        })
        .collect();
    let vs_f32 = Some(scaled_diff(&got, &want).0);
    rows.push(prefiltered_row(
        samples,
        scaled_diff(&got, &twin).0,
        ("f16", "manual"),
        "f16 texels, f64",
        vs_f32,
    ));

    // f16, the hardware's filter: outside the span of the weights' roundings, relative.
    let got = run_rows(gpu, &up, &NONE, arr, &inputs, 4, &hardware)?;
    let mut outside = Vec::with_capacity(samples);
    let mut mid = Vec::with_capacity(samples);
    for (g, x) in got.iter().zip(&inputs) {
        let a = DVec3::from_slice(&x[..3]);
        let ends: Vec<[f64; 4]> = [[false, false], [false, true], [true, false], [true, true]]
            .iter()
            .map(|&[rx, ry]| prefiltered_twin(&half, a, x[3], [Some(rx), Some(ry)]))
            .collect();
        let m = prefiltered_twin(&half, a, x[3], [None, None]);
        let mut o = vec![0.0; 4];
        // A unit may filter f16 texels at f16 precision: the span's ends moved 2 binary16
        // ulps outwards (the conformance's rule for f16 textures).
        let ulps = |v: f64| 2.0 * (v.abs().max(6.1e-5).log2().floor() - 10.0).exp2();
        for c in 0..4 {
            let lo = ends.iter().map(|e| e[c]).fold(f64::INFINITY, f64::min);
            let hi = ends.iter().map(|e| e[c]).fold(f64::NEG_INFINITY, f64::max);
            let (lo, hi) = ((lo - ulps(lo)).max(0.0), (hi + ulps(hi)).max(0.0));
            // Inside the span: the twin's own value; outside: the nearer end plus the excess.
            o[c] = m[c].max(0.0) + (g[c] - g[c].clamp(lo, hi));
        }
        outside.push(o);
        mid.push(m.map(|v| v.max(0.0)).to_vec());
    }
    let vs_f32 = Some(scaled_diff(&got, &want).0);
    rows.push(prefiltered_row(
        samples,
        scaled_diff(&outside, &mid).0,
        ("f16", "hardware"),
        "8-bit span",
        vs_f32,
    ));
    Ok(rows)
}

/// A Γ_L row: `vs_cpu` against `cpu_what`, at (storage, filter); beside it, where given,
/// the row's error against the f32 lookup (what its storage costs).
fn prefiltered_row(
    samples: usize,
    vs_cpu: f64,
    (storage, filter): (&str, &str),
    cpu_what: &'static str,
    vs_f32: Option<f64>,
) -> Row {
    let mut r = row("prefiltered", samples, vs_cpu, Vec::new());
    r.storage = storage.into();
    r.filter = filter.into();
    r.cpu_what = cpu_what;
    r.info
        .extend(vs_f32.map(|v| ("rgb+lum rel vs f32 lookup".to_string(), v, 0.0)));
    r
}

/// The SH basis (order 8 and order 3), ZH → SH at order 8, the order-3 rotation.
fn check_sh_basis(gpu: &Gpu, dummy: &GpuTexture, samples: usize, rng: &mut Rng) -> Result<Vec<Row>, String> {
    let t2 = "texture_2d<f32>";
    let mut rows = Vec::new();
    let map = |e: LookupError| e.to_string();

    // Basis, order 8 and order 3.
    let dirs: Vec<Vec<f64>> = (0..samples).map(|_| unit(rng).to_array().map(r32).to_vec()).collect();
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

    // ZH → SH: each direction with 8 zh coefficients.
    let inputs: Vec<Vec<f64>> = dirs
        .iter()
        .map(|d| {
            let mut x = d.clone();
            x.extend((0..8).map(|_| r32(rng.range(-1.0, 1.0))));
            x
        })
        .collect();
    // ZH → SH at order 8 by the recurrence, and at order 4 by the polynomials (the same
    // inputs' first four zh).
    let zh_in = "    var zh: array<f32, 8>;\n    zh[0] = x3; zh[1] = x4; zh[2] = x5; zh[3] = x6; zh[4] = x7; zh[5] = x8; zh[6] = x9; zh[7] = x10;\n";
    for (name, order, call) in [
        ("zh to sh n8", 8, "lf_zh_to_sh(8u, zh, vec3<f32>(x0, x1, x2))"),
        (
            "zh to sh n4 (polynomials)",
            4,
            "lf_zh_to_sh16(zh, vec3<f32>(x0, x1, x2))",
        ),
    ] {
        let n = order * order;
        let body = format!(
            "{zh_in}    let z = {call};\n    for (var k = 0u; k < {n}u; k++) {{\n        Y[o + k] = z[k];\n    }}"
        );
        let got = run_rows(gpu, dummy, &NONE, t2, &inputs, n, &body)?;
        let want: Vec<Vec<f64>> = inputs
            .iter()
            .map(|x| {
                let mut o = vec![0.0; n];
                sh::zh_to_sh(&x[3..3 + order], DVec3::from_slice(&x[..3]), &mut o).map(|_| o)
            })
            .collect::<Result<_, _>>()
            .map_err(map)?;
        rows.push(row(name, samples, vector_diff(&got, &want), Vec::new()));
    }

    // Order-3 rotation: R by axis and angle, passed as columns.
    let mut inputs = Vec::new();
    let mut mats = Vec::new();
    for _ in 0..samples {
        let r = sh::rotation_axis_angle(unit(rng), rng.range(-3.2, 3.2)).map_err(map)?;
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
    Ok(rows)
}

/// SG algebra (product, integrals, value) and the paper's ISG model (no texture).
fn check_sg(gpu: &Gpu, dummy: &GpuTexture, samples: usize, rng: &mut Rng) -> Result<Vec<Row>, String> {
    let t2 = "texture_2d<f32>";
    let mut rows = Vec::new();
    let map = |e: LookupError| e.to_string();

    // SG algebra: product, its integral, a lobe's hemisphere integral and value.
    let mut inputs = Vec::new();
    for _ in 0..samples {
        let mut x = Vec::new();
        for _ in 0..2 {
            x.extend(unit(rng).to_array().map(r32));
            x.push(r32(rng.range(0.1f64.ln(), 1000f64.ln()).exp()));
            x.push(r32(rng.range(0.1, 10.0)));
        }
        x.extend(unit(rng).to_array().map(r32));
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
    Ok(rows)
}

/// The lobe product's axis on the arc (`lf_lobe_product_axis`) against the f64 slerp.
fn check_lobe_product_axis(gpu: &Gpu, dummy: &GpuTexture, samples: usize, rng: &mut Rng) -> Result<Vec<Row>, String> {
    let t2 = "texture_2d<f32>";
    let mut rows = Vec::new();

    // The lobe product's axis on the arc a1 -> a2 at fraction t, against the f64
    // slerp (sin((1 − t) α) a1 + sin(t α) a2) / sin α of the f32 inputs, normalised.
    // Half the pairs close (α log-uniform in [1e-4, 1]), half anywhere with α below
    // π − 1e-2 (the arc between near-antipodal axes is ill-conditioned).
    let mut inputs: Vec<Vec<f64>> = Vec::with_capacity(samples);
    while inputs.len() < samples {
        let a1 = unit(rng);
        let a2 = if inputs.len().is_multiple_of(2) {
            let p = unit(rng).cross(a1).normalize_or_zero();
            let ang = rng.range(1e-4f64.ln(), 0.0).exp();
            a1 * ang.cos() + p * ang.sin()
        } else {
            unit(rng)
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

/// The Meunier pipeline's closed forms: a sphere light's irradiance across the
/// horizon (`lf_sphere_cap_irradiance`, sin α in [0.01, 0.99], cos β in [−1, 1]) and a
/// lobe's share of a cap (`lf_lobe_fraction_in_cap`, e log-uniform in [1, 10⁵], α in
/// [1 mrad, 1.2], γ in [0, 3α]): GPU against the runtime's `cap_irradiance` and
/// `lobe_fraction_in_cap`, relative to each output's largest value.
fn check_meunier(gpu: &Gpu, dummy: &GpuTexture, samples: usize, rng: &mut Rng) -> Result<Vec<Row>, String> {
    use lobefit_tables::meunier::{cap_irradiance, lobe_fraction_in_cap};
    let t2 = "texture_2d<f32>";
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| vec![r32(rng.range(0.01, 0.99)), r32(rng.range(-1.0, 1.0))])
        .collect();
    let got = run_rows(
        gpu,
        dummy,
        &NONE,
        t2,
        &inputs,
        1,
        "    Y[o] = lf_sphere_cap_irradiance(x0, x1);",
    )?;
    let want: Vec<Vec<f64>> = inputs.iter().map(|x| vec![cap_irradiance(x[0], x[1])]).collect();
    let mut rows = vec![row(
        "sphere cap irradiance",
        samples,
        scaled_diff(&got, &want).0,
        Vec::new(),
    )];
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            let alpha = rng.range(1e-3f64.ln(), 1.2f64.ln()).exp();
            let e = rng.range(0.0, 1e5f64.ln()).exp();
            vec![r32(3.0 * alpha * rng.uniform()), r32(alpha), r32(e)]
        })
        .collect();
    let got = run_rows(
        gpu,
        dummy,
        &NONE,
        t2,
        &inputs,
        1,
        "    Y[o] = lf_lobe_fraction_in_cap(x0, x1, x2);",
    )?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| vec![lobe_fraction_in_cap(x[0], x[1], x[2])])
        .collect();
    rows.push(row(
        "lobe share of a cap",
        samples,
        scaled_diff(&got, &want).0,
        Vec::new(),
    ));
    Ok(rows)
}

/// Rig reconstruction (`lf_rig_eval`, every model kind, up to its 64 vectors), the
/// re-wrap (`lf_rewrap_irradiance9`) and wrapped shading (`lf_irradiance9_wrapped`) at
/// random points, normals and a in [0, 1]: GPU against the runtime's `Rig::eval`,
/// `wrap::rewrap_irradiance` and the rig pipeline's `shade_wrapped`. The rigs are
/// least-squares fits to random vectors at random points of random boxes.
fn check_rigs(gpu: &Gpu, dummy: &GpuTexture, samples: usize, rng: &mut Rng) -> Result<Row, String> {
    use lobefit_tables::rigs::{AxisModel, Rig, RigBox, RigModel, COEFFS};
    const MAX: usize = 64;
    let map = |e: lobefit_tables::rigs::RigError| e.to_string();
    let models = [
        RigModel::CONSTANT,
        RigModel::Gradient,
        RigModel::Tensor([AxisModel::Lattice(3), AxisModel::Gradient, AxisModel::Constant]),
        RigModel::lattice(3, 2, 2),
        RigModel::Tensor([AxisModel::Gradient, AxisModel::Lattice(5), AxisModel::Gradient]),
        RigModel::lattice(4, 4, 4),
    ];
    let mut rigs = Vec::new();
    for m in models {
        let bbox = RigBox::new(
            DVec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)),
            DVec3::new(rng.range(0.2, 3.0), rng.range(0.2, 3.0), rng.range(0.2, 3.0)),
        )
        .map_err(map)?;
        let fit: Vec<(DVec3, [f64; COEFFS])> = (0..400)
            .map(|_| {
                let t = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                (bbox.point(t), std::array::from_fn(|_| rng.range(-1.0, 1.0)))
            })
            .collect();
        rigs.push((Rig::fit_least_squares(m, bbox, &fit, 1e-6).map_err(map)?, bbox));
    }
    let mut inputs = Vec::with_capacity(samples);
    for s in 0..samples {
        let (rig, bbox) = &rigs[s % rigs.len()];
        let (kind, nodes) = crate::rigs::model_code(rig.model());
        let t = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let p = crate::rigs::inside32(bbox, bbox.point(t));
        let mut x: Vec<f64> = kind.into_iter().chain(nodes).map(f64::from).collect();
        x.extend(bbox.centre.to_array().into_iter().chain(bbox.half.to_array()).map(r32));
        x.extend(p.to_array());
        x.extend(unit(rng).to_array().map(r32));
        x.push(r32(rng.uniform()));
        let mut v: Vec<f64> = rig.vectors().iter().flatten().map(|&c| r32(c)).collect();
        v.resize(COEFFS * MAX, 0.0);
        x.extend(v);
        inputs.push(x);
    }
    let n_in = 19 + COEFFS * MAX;
    let body = format!(
        "    var c: array<f32, {}>;\n    for (var k = 0u; k < {}u; k++) {{\n        c[k] = X[i * {n_in}u + 19u + k];\n    }}\n    \
         let l = lf_rig_eval(vec3<u32>(u32(x0), u32(x1), u32(x2)), vec3<u32>(u32(x3), u32(x4), u32(x5)), \
         vec3<f32>(x6, x7, x8), vec3<f32>(x9, x10, x11), vec3<f32>(x12, x13, x14), &c);\n    \
         let w = lf_rewrap_irradiance9(l, x18);\n    for (var k = 0u; k < 9u; k++) {{\n        Y[o + k] = l[k];\n        \
         Y[o + 9u + k] = w[k];\n    }}\n    Y[o + 18u] = lf_irradiance9_wrapped(l, vec3<f32>(x15, x16, x17), x18);",
        COEFFS * MAX,
        COEFFS * MAX
    );
    let got = run_rows(gpu, dummy, &NONE, "texture_2d<f32>", &inputs, 19, &body)?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .enumerate()
        .map(|(s, x)| {
            let l = rigs[s % rigs.len()]
                .0
                .eval(DVec3::from_slice(&x[12..15]))
                .map_err(map)?;
            let mut w = [0.0; COEFFS];
            lobefit_tables::wrap::rewrap_irradiance(&l, x[18], &mut w).map_err(|e| e.to_string())?;
            let e = lobefit::pipelines::rigs::render::shade_wrapped(&l, DVec3::from_slice(&x[15..18]), x[18])?;
            Ok(l.into_iter().chain(w).chain([e]).collect())
        })
        .collect::<Result<_, String>>()?;
    Ok(row("rig eval, wrap", samples, vector_diff(&got, &want), Vec::new()))
}

/// Rotation about z (order 8), the wedge slice vector (order 8) and the truncated SH
/// product (orders 4 and 3, the prefix of the Gaunt table): GPU against f64.
fn check_sh_algebra(gpu: &Gpu, dummy: &GpuTexture, samples: usize, rng: &mut Rng) -> Result<Vec<Row>, String> {
    let t2 = "texture_2d<f32>";
    let map = |e: LookupError| e.to_string();
    let mut rows = Vec::new();

    // Angles up to ±2π (the wedges' φ_k), 64 coefficients.
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            let mut x = vec![r32(rng.range(-std::f64::consts::TAU, std::f64::consts::TAU))];
            x.extend((0..64).map(|_| r32(rng.range(-1.0, 1.0))));
            x
        })
        .collect();
    let body = format!(
        "    var c: array<f32, 64>;\n    for (var k = 0u; k < 64u; k++) {{\n        c[k] = X[i * 65u + 1u + k];\n    }}\n    \
         let z = lf_sh_rotate_z(8u, c, x0);\n{WRITE64}"
    );
    let got = run_rows(gpu, dummy, &NONE, t2, &inputs, 64, &body)?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let mut o = vec![0.0; 64];
            sh::rotate_z(&x[1..], x[0], &mut o).map(|_| o)
        })
        .collect::<Result<_, _>>()
        .map_err(map)?;
    rows.push(row("sh rotate z n8", samples, vector_diff(&got, &want), Vec::new()));

    // Horizon elevations over [−π/2, π/2], floors over [0.01, 0.99].
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            let h = std::f64::consts::FRAC_PI_2;
            vec![r32(rng.range(-h, h)), r32(rng.range(0.01, 0.99))]
        })
        .collect();
    let got = run_rows(
        gpu,
        dummy,
        &NONE,
        t2,
        &inputs,
        8,
        "    let z = lf_wedge_slice(x0, x1, 8u);\n    for (var k = 0u; k < 8u; k++) {\n        Y[o + k] = z[k];\n    }",
    )?;
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let mut o = vec![0.0; 8];
            lobefit_tables::wedge::slice_log(x[0], x[1], 8, &mut o).map(|_| o)
        })
        .collect::<Result<_, _>>()
        .map_err(map)?;
    rows.push(row("wedge slice n8", samples, vector_diff(&got, &want), Vec::new()));

    // Two order-4 vectors; the order-3 product of their first 9 coefficients after.
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| (0..32).map(|_| r32(rng.range(-1.0, 1.0))).collect())
        .collect();
    let body = "    var f: array<f32, 16>;\n    var g: array<f32, 16>;\n    for (var k = 0u; k < 16u; k++) {\n        \
                f[k] = X[i * 32u + k];\n        g[k] = X[i * 32u + 16u + k];\n    }\n    let z4 = lf_sh_product(4u, f, g);\n    \
                let z3 = lf_sh_product(3u, f, g);\n    for (var k = 0u; k < 16u; k++) {\n        Y[o + k] = z4[k];\n        \
                Y[o + 16u + k] = z3[k];\n    }";
    let got = run_rows(gpu, dummy, &NONE, t2, &inputs, 32, body)?;
    let (g4, g3) = (
        lobefit_tables::gaunt::Gaunt::cached(4).map_err(map)?,
        lobefit_tables::gaunt::Gaunt::cached(3).map_err(map)?,
    );
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let mut o = g4.product(&x[..16], &x[16..]);
            o.extend(g3.product(&x[..9], &x[16..25]));
            o.resize(32, 0.0);
            o
        })
        .collect();
    rows.push(row("sh product n4, n3", samples, vector_diff(&got, &want), Vec::new()));
    Ok(rows)
}
