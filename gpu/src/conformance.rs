//! `lobefit-gpu gpu-check`: the shader library run on a real Vulkan device against
//! (a) the CPU emulation of the export (`lobefit::export`: f32 arithmetic, texel
//! centres, manual and 8-bit hardware filtering) or, for closed forms, the runtime's
//! f64 functions, and (b) the families' independent references, at the checker's
//! seeded off-grid samples.

use std::collections::HashMap;

use lobefit::check::rel_err;
use lobefit::export::families::GpuFamily;
use lobefit::export::layout::{Filter, Sampler};
use lobefit::export::run::{errors_of, family_of, offgrid_metrics, sample_points, TextureEntry};
use lobefit::export::{Storage, Texture};
use lobefit::family::{Lookup, Query};
use lobefit::rng::Rng;
use lobefit_tables::LookupError;

use crate::device::{wgsl_texture_type, Gpu, GpuTexture};
pub use crate::kernel::{kernel, kernel_with, lf_tex, LF_TEX_SIZE};
pub use crate::report::{scaled_diff, vector_diff, Row};

/// How far a GPU's error against the reference may exceed the manifest's promise:
/// the promise was measured on the CPU emulation, which a GPU matches to ~TOL_CPU
/// relative in the outputs; lossy entries (promise = the measured error) need that
/// room.
pub const PROMISE_SLACK: f64 = 0.02;
/// Closed forms in f32 against their f64 references: largest |gpu − reference| over a
/// sample's outputs, relative to its largest |reference| (the families' own limits,
/// 1e-9 to 1e-12, are f64 targets below f32 resolution; they are reported beside).
/// f32 sums of up to 8 terms with Legendre coefficients up to 43 give ~2e-5 at worst
/// (measured: 8e-6); a wrong term errs by 1e-3 or more.
/// Random inputs per world-space function (disk light with its quadrature
/// reference, ISG patches: four reference corners each).
pub const WORLD_SAMPLES: usize = 500;
/// See [`TOL_CLOSED`]'s use.
pub const TOL_CLOSED: f64 = 3e-5;

/// The kernel body of shexp's order n: f_0..f_{n−1}, ‖f̂‖, a, b at θ_b = x0.
pub fn shexp_body(n: usize) -> String {
    format!(
        "    let r = lf_shexp(T, S, P, {n}u, x0);\n    for (var l = 0u; l < {n}u; l++) {{\n        Y[o + l] = r.f[l];\n    }}\n    \
         Y[o + {n}u] = r.norm;\n    Y[o + {}u] = r.a;\n    Y[o + {}u] = r.b;",
        n + 1,
        n + 2
    )
}

/// The family's kernel body over its inputs (as `lobefit eval` orders them) and
/// outputs (the runtime lookup's), and its output count: the family's own
/// (`GpuFamily::kernel`, in `fits/<family>/gpu.rs`).
pub fn textured_body(kind: &str) -> Option<(&'static str, usize)> {
    lobefit::fits::gpu_family(kind).map(|f| f.kernel)
}

/// Looks up precomputed GPU outputs by the f32 bits of the input point.
struct Precomputed(HashMap<Vec<u32>, Vec<f64>>);

fn key(x: &[f64]) -> Vec<u32> {
    x.iter().map(|&v| (v as f32).to_bits()).collect()
}

impl Lookup for Precomputed {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        self.0.get(&key(x)).cloned().ok_or_else(|| LookupError::OutOfDomain {
            name: "input point not evaluated on the GPU".into(),
            value: x.first().copied().unwrap_or(f64::NAN),
            lo: f64::NAN,
            hi: f64::NAN,
        })
    }
}

pub use lobefit::export::run::{read_export, Export};

/// Every textured family of the export: GPU against the CPU emulation and against
/// the reference, per filter.
pub fn check_textured(gpu: &Gpu, export: &Export, weight_bits: u32) -> Result<Vec<Row>, String> {
    let m = &export.manifest;
    // The device's hardware filter is emulated as it weights: 8-bit emulation where it
    // rounds weights to 1/256, exact (f32) weights where the probe found ≥ 12 bits.
    let hw_emulation = if weight_bits >= 12 {
        Filter::Manual
    } else {
        Filter::Hardware
    };
    let mut rows = Vec::new();
    for (f, texs) in m.families.iter().zip(&export.textures) {
        let Some((body, n_out)) = textured_body(&f.family) else {
            eprintln!("note: {}: no shader function in this library yet; skipped", f.family);
            continue;
        };
        let family = family_of(&f.family).ok_or_else(|| format!("unknown family {:?}", f.family))?;
        let gpu_family: GpuFamily =
            lobefit::fits::gpu_family(&f.family).ok_or_else(|| format!("{}: no GPU layout", f.family))?;
        let (entry, tex) = &texs[0];
        let uploaded = gpu.upload(tex, m.storage)?;
        let points = sample_points(family.as_ref(), m.samples, m.seed)?;
        let n_in = family.inputs().len();
        let inputs: Vec<f32> = points.iter().flat_map(|x| x.iter().map(|&v| v as f32)).collect();
        // The lobe products' second texture: the ln W residual (`<kind>-lnw`).
        let second = if f.family.starts_with("lobe-product") {
            let (e2, t2) = texs
                .get(1)
                .ok_or_else(|| format!("{}: the export lacks its ln W texture", f.family))?;
            Some((e2, gpu.upload(t2, m.storage)?))
        } else {
            None
        };
        let src = kernel_with(
            wgsl_texture_type(tex),
            texs.get(1)
                .filter(|_| second.is_some())
                .map(|(_, t)| wgsl_texture_type(t)),
            n_in,
            n_out,
            body,
        );
        // wedge's entries are exact fetches: no filter to vary.
        let filters: &[Filter] = if f.family == "wedge" {
            &[Filter::Manual]
        } else {
            &Filter::ALL
        };
        for &filter in filters {
            if filter == Filter::Hardware && !gpu.float32_filterable && m.storage == Storage::F32 {
                eprintln!(
                    "note: the adapter cannot filter 32-bit float textures: {} f32 hardware skipped",
                    f.family
                );
                continue;
            }
            let got: Vec<Vec<f64>> = match f.family.as_str() {
                "shexp" => run_shexp(gpu, texs, m.storage, filter, &inputs, points.len())?,
                _ => {
                    let second = second.as_ref().map(|(e2, t2)| (lf_tex(e2, filter), t2));
                    let out = gpu.run_with(
                        &src,
                        &lf_tex(entry, filter),
                        &uploaded,
                        second.as_ref().map(|(p, t)| (p.as_slice(), *t)),
                        &inputs,
                        points.len(),
                        n_out,
                    )?;
                    out.chunks(n_out)
                        .map(|c| c.iter().map(|&v| v as f64).collect())
                        .collect()
                }
            };
            let emu_filter = if filter == Filter::Hardware {
                hw_emulation
            } else {
                filter
            };
            let samplers: Vec<Sampler> = texs
                .iter()
                .map(|(e, t)| Sampler {
                    axes: e.axes.clone(),
                    channels: e.channels.clone(),
                    texture: t.clone(),
                    filter: emu_filter,
                })
                .collect();
            let emu: Vec<Vec<f64>> = points
                .iter()
                .map(|x| {
                    let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
                    (gpu_family.eval)(&samplers, &x32).into_iter().map(f64::from).collect()
                })
                .collect();
            let lookup = Precomputed(points.iter().map(|x| key(x)).zip(got.iter().cloned()).collect());
            let errs = errors_of(family.as_ref(), &lookup, &points, filter)?;
            let vs_ref = errs
                .iter()
                .map(|e| {
                    let promise = f
                        .error
                        .iter()
                        .find(|p| p.filter == filter && p.output == e.output && p.metric == e.metric)
                        .map_or(e.target, |p| p.promise);
                    (
                        format!("{} {}", e.output, e.metric.trim_start_matches("offgrid.")),
                        e.measured,
                        promise * (1.0 + PROMISE_SLACK),
                    )
                })
                .collect();
            let (vs_cpu, worst) = scaled_diff(&got, &emu);
            let storage = m.storage.to_string();
            if f.family == "isg-refit" || f.family == "isg-best" {
                let limit = family
                    .thresholds()
                    .iter()
                    .filter(|t| t.output.starts_with("s_hat") && t.metric.starts_with("offgrid."))
                    .map(|t| t.limit)
                    .fold(0.0, f64::max);
                let mut r = crate::world::check_patch(
                    gpu,
                    &f.family,
                    family.as_ref(),
                    gpu_family.eval,
                    texs,
                    &uploaded,
                    filter,
                    emu_filter,
                    limit,
                    WORLD_SAMPLES,
                    m.seed,
                )?;
                r.storage = storage.clone();
                rows.push(r);
            }
            if f.family == "disk-light" {
                let limit = family
                    .thresholds()
                    .iter()
                    .find(|t| t.output == "l2" && t.metric.starts_with("offgrid."))
                    .map_or(1e-2, |t| t.limit);
                let mut r = crate::world::check_disk_world(
                    gpu,
                    family.as_ref(),
                    gpu_family.eval,
                    texs,
                    &uploaded,
                    filter,
                    emu_filter,
                    limit,
                    WORLD_SAMPLES,
                    m.seed,
                )?;
                r.storage = storage.clone();
                rows.push(r);
            }
            if f.family == "disk-light" && m.storage == Storage::F32 && m.scale == 1.0 {
                let mut r = crate::world::check_disk_extensions(gpu, texs, &uploaded, filter, WORLD_SAMPLES, m.seed)?;
                r.storage = storage.clone();
                rows.push(r);
            }
            if f.family == "shexp" {
                rows.push(check_shexp_hyb(
                    gpu, f, texs, m.storage, filter, emu_filter, m.samples, m.seed,
                )?);
            }
            if f.family == "wedge" {
                let mut r = crate::world::check_wedge_apply(gpu, texs, &uploaded, WORLD_SAMPLES, m.seed)?;
                r.storage = storage.clone();
                rows.push(r);
            }
            rows.push(Row {
                function: format!("{} ({})", f.family, family.outputs().get(worst).unwrap_or(&"?")),
                storage: m.storage.to_string(),
                filter: if f.family == "wedge" {
                    "fetch".into()
                } else {
                    filter.name().into()
                },
                samples: points.len(),
                vs_cpu,
                cpu_what: if filter == Filter::Hardware && emu_filter == Filter::Hardware {
                    "emulation 8-bit"
                } else {
                    "emulation"
                },
                vs_ref,
                info: Vec::new(),
            });
        }
    }
    Ok(rows)
}

/// shexp on the GPU: one kernel per order n = 3..8 over texture `shexp-n<n>`, the
/// outputs concatenated per point in the family's order (n = 3 first: f_0..f_{n−1},
/// ‖f̂‖, a, b).
fn run_shexp(
    gpu: &Gpu,
    texs: &[(TextureEntry, Texture)],
    storage: Storage,
    filter: Filter,
    inputs: &[f32],
    count: usize,
) -> Result<Vec<Vec<f64>>, String> {
    let mut got = vec![Vec::new(); count];
    for n in 3..=8usize {
        let name = format!("shexp-n{n}");
        let (entry, tex) = texs
            .iter()
            .find(|(e, _)| e.file.split('.').next() == Some(name.as_str()))
            .ok_or_else(|| format!("shexp: the export lacks texture {name}"))?;
        let up = gpu.upload(tex, storage)?;
        let src = kernel(wgsl_texture_type(tex), 1, n + 3, &shexp_body(n));
        let out = gpu.run(&src, &lf_tex(entry, filter), &up, inputs, count, n + 3)?;
        for (g, c) in got.iter_mut().zip(out.chunks(n + 3)) {
            g.extend(c.iter().map(|&v| v as f64));
        }
    }
    Ok(got)
}

/// shexp's HYB textures on the GPU (`lf_shexp_hyb_ab`): per order, caps whose
/// reference ‖f̂‖ is at most T_n (θ_b half uniform, half log-uniform down to 1e-4 rad,
/// as the export measures them), looked up at the reference ‖f̂‖ rounded to f32;
/// against the CPU emulation of the texture and against the reference (a, b), held to
/// the manifest's promise for `n<n>_a(norm)`, `n<n>_b(norm)`.
#[allow(clippy::too_many_arguments)]
fn check_shexp_hyb(
    gpu: &Gpu,
    f: &lobefit::export::run::FamilyEntry,
    texs: &[(TextureEntry, Texture)],
    storage: Storage,
    filter: Filter,
    emu_filter: Filter,
    samples: usize,
    seed: u64,
) -> Result<Row, String> {
    use lobefit::fits::shexp::reference_point;
    use lobefit_tables::shexp::{OL_THRESHOLD, ORDER_MAX, ORDER_MIN, THETA_MAX};
    let per_order = samples / (ORDER_MAX - ORDER_MIN + 1);
    let (mut worst_cpu, mut vs_ref) = (0.0f64, Vec::new());
    for n in ORDER_MIN..=ORDER_MAX {
        let name = format!("shexp-hyb-n{n}");
        let (entry, tex) = texs
            .iter()
            .find(|(e, _)| e.file.split('.').next() == Some(name.as_str()))
            .ok_or_else(|| format!("shexp: the export lacks texture {name}"))?;
        let top = OL_THRESHOLD[n - ORDER_MIN];
        // θ_b where the reference ‖f̂‖ reaches T_n (monotone below it).
        let (mut lo, mut hi) = (0.0, THETA_MAX);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if reference_point(mid, n)?.1 <= top {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut rng = Rng::new(seed ^ (0x4750_4859 + n as u64));
        let refs: Vec<(f64, f64, f64)> = (0..per_order)
            .map(|k| {
                let t = if k % 2 == 0 {
                    rng.range(0.0, lo)
                } else {
                    rng.range(1e-4f64.ln(), lo.ln()).exp()
                };
                reference_point(t, n).map(|(_, norm, a, b)| (norm, a, b))
            })
            .collect::<Result<_, _>>()?;
        let inputs: Vec<f32> = refs.iter().map(|r| (r.0 as f32).min(top as f32)).collect();
        let up = gpu.upload(tex, storage)?;
        let src = kernel(
            wgsl_texture_type(tex),
            1,
            2,
            "    let ab = lf_shexp_hyb_ab(T, S, P, x0);\n    Y[o] = ab.x;\n    Y[o + 1u] = ab.y;",
        );
        let out = gpu.run(&src, &lf_tex(entry, filter), &up, &inputs, inputs.len(), 2)?;
        let got: Vec<Vec<f64>> = out.chunks(2).map(|c| vec![c[0] as f64, c[1] as f64]).collect();
        let sampler = Sampler {
            axes: entry.axes.clone(),
            channels: entry.channels.clone(),
            texture: tex.clone(),
            filter: emu_filter,
        };
        let emu: Vec<Vec<f64>> = inputs
            .iter()
            .map(|&x| sampler.sample(&[x]).iter().map(|&v| v as f64).collect())
            .collect();
        worst_cpu = worst_cpu.max(scaled_diff(&got, &emu).0);
        for (k, q) in ["a", "b"].iter().enumerate() {
            let output = format!("n{n}_{q}(norm)");
            let measured = got
                .iter()
                .zip(&refs)
                .map(|(g, r)| rel_err(g[k], if k == 0 { r.1 } else { r.2 }))
                .fold(0.0, f64::max);
            let promise = f
                .error
                .iter()
                .find(|p| p.filter == filter && p.output == output && p.metric == "offgrid.max_rel")
                .map_or(lobefit::fits::shexp::OFFGRID_REL, |p| p.promise);
            vs_ref.push((format!("{output} max_rel"), measured, promise * (1.0 + PROMISE_SLACK)));
        }
    }
    Ok(Row {
        function: "shexp HYB a, b at |f|".into(),
        storage: storage.to_string(),
        filter: filter.name().into(),
        samples: per_order * (ORDER_MAX - ORDER_MIN + 1),
        vs_cpu: worst_cpu,
        cpu_what: "emulation",
        vs_ref,
        info: Vec::new(),
    })
}

/// A closed form (no texture) on the GPU: `body` over the family's inputs, against
/// `cpu` (the runtime's f64 function) and the family's reference with its off-grid
/// thresholds.
#[allow(clippy::too_many_arguments)]
fn closed_row(
    gpu: &Gpu,
    dummy: &GpuTexture,
    name: &str,
    family: &dyn Query,
    body: &str,
    cpu: &dyn Fn(&[f64]) -> Vec<f64>,
    samples: usize,
    seed: u64,
) -> Result<Row, String> {
    let mut rng = Rng::new(seed);
    let points: Vec<Vec<f64>> = (0..samples)
        .map(|_| family.sample(&mut rng).iter().map(|&v| v as f32 as f64).collect())
        .collect();
    let outputs = family.outputs();
    let n_out = outputs.len();
    let inputs: Vec<f32> = points.iter().flat_map(|x| x.iter().map(|&v| v as f32)).collect();
    let src = kernel("texture_2d<f32>", family.inputs().len(), n_out, body);
    let out = gpu.run(&src, &[0u8; LF_TEX_SIZE], dummy, &inputs, points.len(), n_out)?;
    let got: Vec<Vec<f64>> = out
        .chunks(n_out)
        .map(|c| c.iter().map(|&v| v as f64).collect())
        .collect();
    let want_cpu: Vec<Vec<f64>> = points.iter().map(|x| cpu(x)).collect();
    let refs: Vec<Vec<f64>> = points
        .iter()
        .map(|x| family.reference(x))
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{name}: {e}"))?;
    let vec_rel = vector_diff(&got, &refs);
    let vs_ref = vec![("max |error| / max |ref| of the vector".to_string(), vec_rel, TOL_CLOSED)];
    let mut info = Vec::new();
    for (k, o) in outputs.iter().enumerate() {
        let abs: Vec<f64> = got.iter().zip(&refs).map(|(g, w)| (g[k] - w[k]).abs()).collect();
        let rel: Vec<f64> = got.iter().zip(&refs).map(|(g, w)| rel_err(g[k], w[k])).collect();
        for (metric, v, limit) in offgrid_metrics(family, o, abs, rel) {
            info.push((format!("{o} {}", metric.trim_start_matches("offgrid.")), v, limit));
        }
    }
    Ok(Row {
        function: name.into(),
        storage: "-".into(),
        filter: "-".into(),
        samples: points.len(),
        vs_cpu: vector_diff(&got, &want_cpu),
        cpu_what: "runtime f64",
        vs_ref,
        info,
    })
}

/// The closed forms: lobe integral, wrap λ̂_l, log-ZH diffuse / Phong / blocker.
pub fn check_closed(gpu: &Gpu, samples: usize, seed: u64) -> Result<Vec<Row>, String> {
    use lobefit::fits::log_zh::LogZhFamily;
    use lobefit::fits::wrap::WrapFamily;
    use lobefit_tables::log_zh::{self as lz, Kind};
    use lobefit_tables::{lobe_integral, wrap};
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let mut rows = Vec::new();
    let li = family_of("lobe-integral").ok_or("lobe-integral: not in the registry")?;
    rows.push(closed_row(
        gpu,
        &dummy,
        "lobe-integral",
        li.as_ref(),
        "    Y[o] = lf_lobe_integral(x0);",
        &|x| vec![lobe_integral::exact(x[0]).unwrap_or(f64::NAN)],
        samples,
        seed,
    )?);
    let wf = WrapFamily::default();
    let eight = |body: &str| {
        format!("    let z = {body};\n    for (var k = 0u; k < 8u; k++) {{\n        Y[o + k] = z[k];\n    }}")
    };
    rows.push(closed_row(
        gpu,
        &dummy,
        "wrap",
        &wf,
        &eight("lf_wrap_lambda_hat(8u, x0)"),
        &|x| {
            let mut o = vec![0.0; 8];
            wrap::lambda_hat(8, x[0], &mut o)
                .map(|_| o)
                .unwrap_or(vec![f64::NAN; 8])
        },
        samples,
        seed,
    )?);
    for (kind, name, call) in [
        (Kind::Diffuse, "log-zh diffuse", "lf_log_zh_diffuse(x0, 8u)"),
        (Kind::Phong, "log-zh phong", "lf_log_zh_phong(x0, x1, 8u)"),
        (Kind::Blocker, "log-zh blocker", "lf_log_zh_blocker(x0, x1, 8u)"),
    ] {
        let fam = LogZhFamily { kind, order: 8 };
        rows.push(closed_row(
            gpu,
            &dummy,
            name,
            &fam,
            &eight(call),
            &move |x| {
                let mut o = vec![0.0; 8];
                let r = match kind {
                    Kind::Diffuse => lz::diffuse(x[0], 8, &mut o),
                    Kind::Phong => lz::phong(x[0], x[1], 8, &mut o),
                    Kind::Blocker => lz::blocker(x[0], x[1], 8, &mut o),
                };
                r.map(|_| o).unwrap_or(vec![f64::NAN; 8])
            },
            samples,
            seed,
        )?);
    }
    Ok(rows)
}

/// Fractional bits of the device's linear-filter weights: a 2 × 1 texture (0, 1)
/// sampled at 65 537 evenly spaced sub-texel positions; the weight is the value read,
/// and the number of distinct values read gives the resolution (16 = as fine as
/// probed: exact to the probe).
pub fn probe_weight_bits(gpu: &Gpu) -> Result<u32, String> {
    let mut t = dummy_texture();
    t.data = vec![0.0, 1.0];
    let tex = gpu.upload(&t, Storage::F32)?;
    let n = 65_537usize;
    let xs: Vec<f32> = (0..n).map(|i| i as f32 / (n - 1) as f32).collect();
    let src = kernel(
        "texture_2d<f32>",
        1,
        1,
        "    Y[o] = textureSampleLevel(T, S, vec2<f32>((x0 + 0.5) / 2.0, 0.5), 0.0).x;",
    );
    let out = gpu.run(&src, &[0u8; LF_TEX_SIZE], &tex, &xs, n, 1)?;
    let mut v: Vec<u32> = out.iter().map(|x| x.to_bits()).collect();
    v.sort_unstable();
    v.dedup();
    Ok(((v.len().max(2) - 1) as f64).log2().round() as u32)
}

/// A 2 × 1 R32F texture for kernels that sample nothing.
pub fn dummy_texture() -> Texture {
    Texture {
        name: "dummy".into(),
        dimension: 1,
        width: 2,
        height: 1,
        depth: 1,
        layers: 1,
        channels: 1,
        data: vec![0.0, 0.0],
    }
}

/// The GLSL of `lobefit export --shaders glsl` compiled by glslangValidator: GLSL 450
/// (as Vulkan GLSL to SPIR-V, `-V`) and GLSL ES 3.0, each in a fragment shader that
/// includes the library. Rows pass when glslang accepts the source; a missing
/// glslangValidator is a miss (Debian package glslang-tools).
pub fn check_glslang() -> Result<Vec<Row>, String> {
    let dir = std::env::temp_dir().join(format!("lobefit-gpu-glslang-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut rows = Vec::new();
    for (name, es) in [("glsl 450 (glslang -V)", false), ("glsl es 300 (glslang)", true)] {
        let lib = lobefit::export::shaders::glsl(es)?;
        let src = if es {
            format!(
                "#version 300 es\n{lib}\nlayout(location = 0) out highp vec4 o;\nvoid main() {{ o = vec4(0.0); }}\n"
            )
        } else {
            format!("#version 450\n{lib}\nlayout(location = 0) out vec4 o;\nvoid main() {{ o = vec4(0.0); }}\n")
        };
        let file = dir.join(if es { "lib_es.frag" } else { "lib.frag" });
        std::fs::write(&file, src).map_err(|e| format!("{}: {e}", file.display()))?;
        let mut cmd = std::process::Command::new("glslangValidator");
        if !es {
            cmd.args(["-V", "-o"]).arg(dir.join("lib.spv"));
        }
        let (ok, msg) = match cmd.arg(&file).output() {
            Ok(o) => (o.status.success(), String::from_utf8_lossy(&o.stdout).into_owned()),
            Err(e) => (
                false,
                format!("cannot run glslangValidator ({e}); install glslang-tools"),
            ),
        };
        if !ok {
            eprintln!("{name}: {msg}");
        }
        rows.push(Row {
            function: name.into(),
            storage: "-".into(),
            filter: "-".into(),
            samples: 0,
            vs_cpu: 0.0,
            cpu_what: "compiles",
            vs_ref: vec![("rejected".into(), if ok { 0.0 } else { 1.0 }, 0.0)],
            info: Vec::new(),
        });
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `lf_tex` writes the bytes where the WGSL struct `LfTex` has its members (the
    /// struct's layout as naga lays it out for a uniform).
    #[test]
    fn lf_tex_matches_the_wgsl_struct() {
        let (module, _) = lobefit::export::shaders::module().unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (h, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some("LfTex"))
            .unwrap();
        assert_eq!(layouter[h].size as usize, LF_TEX_SIZE);
        let naga::TypeInner::Struct { members, .. } = &ty.inner else {
            panic!("LfTex is not a struct")
        };
        let offsets: Vec<(String, u32)> = members.iter().map(|m| (m.name.clone().unwrap(), m.offset)).collect();
        let want = [
            ("axis", 0),
            ("map", 48),
            ("offset", 96),
            ("scale", 144),
            ("trend", 192),
            ("decode", 576),
            ("mode", 624),
        ];
        for ((name, off), (wn, wo)) in offsets.iter().zip(want) {
            assert_eq!((name.as_str(), *off), (wn, wo));
        }
        // A texture entry's axis constants land in axis[0], its mode in `mode`.
        let dir = tempdir();
        let opts = lobefit::export::run::ExportOptions {
            only: vec!["cap-exponent".into()],
            format: lobefit::export::Format::Raw,
            storage: Storage::F32,
            scale: 1.0,
            allow_lossy: false,
        };
        let m = lobefit::export::run::export(&opts, &dir).unwrap();
        let t = &m.families[0].textures[0];
        let b = lf_tex(t, Filter::Hardware);
        assert_eq!(b.len(), LF_TEX_SIZE);
        let f = |off: usize| f32::from_le_bytes(b[off..off + 4].try_into().unwrap());
        assert_eq!(f(0), t.axes[0].mapped_lo as f32);
        assert_eq!(f(4), t.axes[0].mapped_hi as f32);
        assert_eq!(f(8), t.axes[0].axis.count as f32);
        assert_eq!(f(12), 3.0, "cap-exponent's axis is logit");
        assert_eq!(u32::from_le_bytes(b[624..628].try_into().unwrap()), 1);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// f16 lobe-product: every `*_compressed` channel gets the export's width in
    /// `decode` (vec4 36 + layer), the others 0; the 1D ln W texture's six trend
    /// coefficients land at vec4 12 + 2k (c0..c3) and 13 + 2k (c4, c5).
    #[test]
    fn lf_tex_carries_compression_and_quintic_trends() {
        let dir = tempdir().join("lp16");
        let opts = lobefit::export::run::ExportOptions {
            only: vec!["lobe-product-l2".into()],
            format: lobefit::export::Format::Raw,
            storage: Storage::F16,
            scale: 0.25,
            allow_lossy: true,
        };
        let m = lobefit::export::run::export(&opts, &dir).unwrap();
        let texs = &m.families[0].textures;
        let f = |b: &[u8], vec4: usize, c: usize| {
            let off = 16 * vec4 + 4 * c;
            f32::from_le_bytes(b[off..off + 4].try_into().unwrap())
        };
        let main = &texs[0];
        assert_eq!(main.channels.len(), 3, "c, ρ, κ");
        let b = lf_tex(main, Filter::Manual);
        for ch in &main.channels {
            assert!(ch.name.ends_with("_compressed"), "{}", ch.name);
            assert_eq!(f(&b, 36 + ch.layer as usize, ch.component as usize), 0.5);
        }
        assert_eq!(f(&b, 36, 3), 0.0, "an unused channel is not decoded");
        let lnw = &texs[1];
        let ch = &lnw.channels[0];
        assert_eq!(ch.trend.len(), 6, "f16 1D textures carry a quintic trend");
        let b = lf_tex(lnw, Filter::Manual);
        for (j, want) in ch.trend.iter().enumerate() {
            assert_eq!(f(&b, 12 + j / 4, j % 4), *want as f32, "coefficient {j}");
        }
        assert_eq!(f(&b, 36, 0), 0.0, "ln W is stored as is");
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn tempdir() -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!(
            "lobefit-gpu-test-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// Bad export directories: missing, no manifest, a manifest of another version.
    #[test]
    fn bad_exports_have_specific_errors() {
        let e = read_export(std::path::Path::new("/nonexistent/lobefit-export"))
            .err()
            .unwrap();
        assert!(e.contains("no such export directory"), "{e}");
        let dir = tempdir().join("bad");
        std::fs::create_dir_all(&dir).unwrap();
        let e = read_export(&dir).err().unwrap();
        assert!(e.contains("cannot read") && e.contains("manifest.json"), "{e}");
        std::fs::write(dir.join(lobefit::export::run::MANIFEST), "{\"version\": 99}").unwrap();
        let e = read_export(&dir).err().unwrap();
        assert!(e.contains("not a lobefit export manifest"), "{e}");
        let _ = std::fs::remove_dir_all(dir.parent().unwrap());
    }

    /// The comparison metrics: relative above the floor, absolute (× range) below it.
    #[test]
    fn diff_metrics() {
        let want = vec![vec![1.0, 100.0], vec![0.0, 50.0]];
        let got = vec![vec![1.0 + 1e-5, 100.0], vec![1e-4, 50.0]];
        let (d, k) = scaled_diff(&got, &want);
        // Output 0: 1e-5 relative at 1.0; 1e-4 at 0.0 against the floor 1e-2 · 1.0.
        assert!((d - 1e-2).abs() < 1e-12 && k == 0, "{d} {k}");
        // Row 2: 1e-4 against its largest entry 50.
        assert!((vector_diff(&got, &want) - 2e-6).abs() < 1e-15);
    }
}
