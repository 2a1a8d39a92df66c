//! disk-light on the GPU: ln c00 and c_lm / c00 on (rim coordinate, logit τ) as a 2D
//! texture of two RGBA layers; the shader computes the rim coordinate.

use lobefit_tables::disk_light::{R_MAX, R_MIN};
use lobefit_tables::glam::DVec3;
use lobefit_tables::sh;

use lobefit_core::export::families::{table_grid, Baked, GpuFamily, Kernels};
use lobefit_core::export::gpu_check::{
    r32, scaled_diff, unit, vector_diff, Context, Kernel, Row, Runner, WORLD_SAMPLES,
};
use lobefit_core::export::layout::Sampler;
use lobefit_core::export::Storage;
use lobefit_core::rng::Rng;

/// The lookup's kernel body: the canonical 6-vector.
const CANONICAL: &str = "    let c = lf_disk_canonical(T, S, P, x0, x1);\n    Y[o] = c[0].x;\n    Y[o + 1u] = c[0].y;\n    \
                         Y[o + 2u] = c[0].z;\n    Y[o + 3u] = c[0].w;\n    Y[o + 4u] = c[1].x;\n    Y[o + 5u] = c[1].y;";

/// The export of disk-light.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::disk_light::KIND,
    grids: table_grid,
    eval,
    shader: "axes: v = (g(R/d) − g(0.01)) / (g(10) − g(0.01)), g(r) = ln r + asinh((r − sin τ) / cos τ), and τ; \
             c00 = exp(layer 0 R); c_lm = c00 · (layer 0 G, B, A, layer 1 R, G) for (1,0), (1,1), (2,0), (2,1), (2,2)",
    extra: None,
    kernels: Kernels::One {
        textures: &[0],
        body: CANONICAL,
        n_out: 6,
    },
    exact_fetch: false,
    checks: &[world, extensions],
    timed: None,
    plot_export: true,
    baked: &[
        Baked {
            wrapper: "lf_disk_irradiance_baked",
            function: "lf_disk_irradiance",
            textures: &["disk-light"],
            fixed: &[],
        },
        Baked {
            wrapper: "lf_disk_irradiance_sh_baked",
            function: "lf_disk_irradiance_sh",
            textures: &["disk-light"],
            fixed: &[],
        },
        Baked {
            wrapper: "lf_disk_radiance_sh_baked",
            function: "lf_disk_radiance_sh",
            textures: &["disk-light"],
            fixed: &[],
        },
        Baked {
            wrapper: "lf_disk_canonical_baked",
            function: "lf_disk_canonical",
            textures: &["disk-light"],
            fixed: &[],
        },
    ],
};

fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let c = s[0].sample(&[rim_coordinate(x[0], x[1]), x[1]]);
    let c00 = c[0];
    vec![c00, c00 * c[1], c00 * c[2], c00 * c[3], c00 * c[4], c00 * c[5]]
}

/// The rim coordinate in f32 (see `lobefit_tables::disk_light`).
fn rim_coordinate(r: f32, tau: f32) -> f32 {
    let (s, c) = tau.sin_cos();
    let g = |r: f32| r.ln() + ((r - s) / c).asinh();
    let (lo, hi) = (g(R_MIN as f32), g(R_MAX as f32));
    ((g(r) - lo) / (hi - lo)).clamp(0.0, 1.0)
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
fn world(ctx: &Context, runner: &dyn Runner) -> Result<Vec<Row>, String> {
    let mut rng = Rng::new(ctx.seed ^ 0xd15c);
    let mut inputs = Vec::new();
    for _ in 0..WORLD_SAMPLES {
        let s = ctx.family.sample(&mut rng);
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
    let got = runner.run(&Kernel::new("disk-light world", &[0], body, 10), &inputs)?;
    let mut emu = Vec::new();
    let mut refs = Vec::new();
    // The world vectors under each emulation (the hardware filter's weight roundings
    // too): per sample, the device's is held to the closest of them.
    let mut alts: Vec<Vec<Vec<f64>>> = vec![Vec::new(); ctx.alternatives.len()];
    for x in &inputs {
        let (rot, d, tau) = disk_frame(v3(x, 0), v3(x, 6), v3(x, 9));
        let ratio = x[12] / d;
        let world = |smp: &[lobefit_core::export::layout::Sampler]| {
            let c6: Vec<f64> = eval(smp, &[ratio as f32, tau as f32])
                .into_iter()
                .map(f64::from)
                .collect();
            disk_world(&c6, rot, x[13], v3(x, 3))
        };
        emu.push(world(ctx.samplers)?);
        for (a, smp) in alts.iter_mut().zip(ctx.alternatives) {
            a.push(world(smp)?);
        }
        let rc = crate::disk_light::reference_canonical(ratio, tau)?;
        refs.push(disk_world(&rc, rot, x[13], v3(x, 3))?);
    }
    let split = |v: &[Vec<f64>]| -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        (
            v.iter().map(|r| r[..9].to_vec()).collect(),
            v.iter().map(|r| r[9..].to_vec()).collect(),
        )
    };
    let (g9, ge) = split(&got);
    let vs_cpu = if alts.is_empty() {
        let (e9, ee) = split(&emu);
        vector_diff(&g9, &e9).max(scaled_diff(&ge, &ee).0)
    } else {
        // Per sample and output, the distance outside the emulations' span, scaled as
        // `vector_diff` (the SH vector) and `scaled_diff` (the irradiance) scale.
        let sets: Vec<&Vec<Vec<f64>>> = std::iter::once(&emu).chain(&alts).collect();
        let range = emu.iter().map(|e| e[9].abs()).fold(0.0, f64::max);
        let mut worst = 0.0f64;
        for (i, g) in got.iter().enumerate() {
            let row = emu[i][..9]
                .iter()
                .fold(0.0f64, |a, v| a.max(v.abs()))
                .max(f64::MIN_POSITIVE);
            for k in 0..10 {
                let (lo, hi) = sets.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), e| {
                    (lo.min(e[i][k]), hi.max(e[i][k]))
                });
                let scale = if k < 9 {
                    row
                } else {
                    emu[i][9].abs().max(lobefit_core::export::gpu_check::FLOOR * range)
                };
                let d = (lo - g[k]).max(g[k] - hi).max(0.0) / scale;
                worst = worst.max(if d.is_nan() { f64::INFINITY } else { d });
            }
        }
        worst
    };
    let l2 = g9
        .iter()
        .zip(&refs)
        .map(|(g, w)| {
            let num: f64 = g.iter().zip(w).map(|(a, b)| (a - b).powi(2)).sum();
            let den: f64 = w[..9].iter().map(|b| b * b).sum();
            (num / den).sqrt()
        })
        .fold(0.0, f64::max);
    let limit = ctx
        .family
        .thresholds()
        .iter()
        .find(|t| t.output == "l2" && t.metric.starts_with("offgrid."))
        .map_or(1e-2, |t| t.limit);
    Ok(vec![Row {
        function: "disk-light world".into(),
        storage: ctx.storage.to_string(),
        filter: ctx.filter.name().into(),
        samples: WORLD_SAMPLES,
        vs_cpu,
        cpu_what: "emulation",
        vs_ref: vec![("radiance SH rel L2 max".into(), l2, limit)],
        info: Vec::new(),
    }])
}

/// `lf_disk_canonical` beyond the table, as the runtime extends it (R/d below 0.01 and
/// above 10, τ beyond the last row, the back side), against the runtime's
/// `DiskLight::canonical` (f64, the committed table): for f32 exports at scale 1 only,
/// whose texels are the table's values (elsewhere the texture differs from the table
/// by its storage or resampling, which the canonical row measures). Limit: the
/// canonical 6-vector's relative L2 difference, `TOL_CPU`.
fn extensions(ctx: &Context, runner: &dyn Runner) -> Result<Vec<Row>, String> {
    // Under an 8-bit hardware filter (alternatives given) the lookups the extensions
    // start from carry its rounded weights, which the canonical rows hold to their
    // span; the extensions' formulas are checked under the manual filter.
    if ctx.storage != Storage::F32 || ctx.scale != 1.0 || !ctx.alternatives.is_empty() {
        return Ok(Vec::new());
    }
    let mut rng = Rng::new(ctx.seed ^ 0xe87);
    let tau_max = lobefit_tables::disk_light::TAU_MAX;
    let inputs: Vec<Vec<f64>> = (0..WORLD_SAMPLES)
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
    let got = runner.run(&Kernel::new("disk-light extensions", &[0], CANONICAL, 6), &inputs)?;
    let disk = lobefit_tables::disk_light::DiskLight::embedded().map_err(|e| e.to_string())?;
    let mut worst = 0.0f64;
    for (g, x) in got.iter().zip(&inputs) {
        let w = disk.canonical(x[0], x[1]).map_err(|e| e.to_string())?;
        let num: f64 = g.iter().zip(&w).map(|(a, b)| (a - b).powi(2)).sum();
        let den: f64 = w.iter().map(|b| b * b).sum();
        let d = if den > 0.0 { (num / den).sqrt() } else { num.sqrt() };
        worst = worst.max(d);
    }
    Ok(vec![Row {
        function: "disk-light extensions".into(),
        storage: ctx.storage.to_string(),
        filter: ctx.filter.name().into(),
        samples: WORLD_SAMPLES,
        vs_cpu: worst,
        cpu_what: "runtime f64 (L2)",
        vs_ref: Vec::new(),
        info: Vec::new(),
    }])
}
