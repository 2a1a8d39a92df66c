//! `lobefit-gpu gpu-check`: the shader library run on a real Vulkan device against
//! (a) the CPU emulation of the export (`lobefit::export`: f32 arithmetic, texel
//! centres, manual and 8-bit hardware filtering) or, for closed forms, the runtime's
//! f64 functions, and (b) the families' independent references, at the checker's
//! seeded off-grid samples.

use std::collections::HashMap;

use lobefit::export::families::{Baked, GpuFamily};
pub use lobefit::export::gpu_check::Row;
use lobefit::export::gpu_check::{scaled_diff, scaled_outside, Context, Envelope, Kernel, Runner, PROMISE_SLACK};
use lobefit::export::layout::{Filter, Sampler, WeightRounding};
use lobefit::export::manifest::TextureEntry;
use lobefit::export::run::{channel_floors, errors_of, family_of, sample_points};
use lobefit::export::{Storage, Texture};
use lobefit::family::Lookup;
use lobefit_tables::LookupError;

use crate::device::{Gpu, GpuTexture};
use crate::kernel::{kernel, Bound, LF_TEX_SIZE};

/// `gpu-check --worst`: print, per family and filter, the sample where the device
/// differs most from the emulation and, for each quantity whose reference metric
/// misses its limit, the samples of its largest absolute and relative errors.
pub static WORST: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// See [`WORST`].
fn print_worst(
    ctx: &Context,
    lookup: &Precomputed,
    points: &[Vec<f64>],
    got: &[Vec<f64>],
    emu: &[Vec<f64>],
    worst: usize,
    vs_ref: &[(String, f64, f64)],
) {
    let (family, filter) = (ctx.family, ctx.filter.name());
    let range = emu
        .iter()
        .map(|w| w[worst].abs())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let d = |g: f64, w: f64| (g - w).abs() / w.abs().max(lobefit::export::gpu_check::FLOOR * range);
    if let Some(p) =
        (0..points.len()).max_by(|&a, &b| d(got[a][worst], emu[a][worst]).total_cmp(&d(got[b][worst], emu[b][worst])))
    {
        eprintln!(
            "worst {} {filter} vs emulation: {} at x = {:?}: device {:e}, emulation {:e}",
            family.kind(),
            family.outputs().get(worst).unwrap_or(&"?"),
            points[p],
            got[p][worst],
            emu[p][worst],
        );
    }
    for (k, name) in family.checked().iter().enumerate() {
        if !vs_ref
            .iter()
            .any(|(q, m, l)| q.split(' ').next() == Some(name) && m > l)
        {
            continue;
        }
        let res: Vec<(usize, f64, f64)> = points
            .iter()
            .enumerate()
            .filter_map(|(p, x)| match family.check_point(lookup, x) {
                Ok(Some((g, w))) if !(g[k].is_nan() && w[k].is_nan()) => Some((p, g[k], w[k])),
                _ => None,
            })
            .collect();
        let abs = res
            .iter()
            .max_by(|a, b| (a.1 - a.2).abs().total_cmp(&(b.1 - b.2).abs()));
        let rel = res
            .iter()
            .max_by(|a, b| lobefit::check::rel_err(a.1, a.2).total_cmp(&lobefit::check::rel_err(b.1, b.2)));
        for (what, r) in [("abs", abs), ("rel", rel)] {
            if let Some(&(p, g, w)) = r {
                eprintln!(
                    "worst {} {filter} vs reference: {name} ({what}) at x = {:?}: device {g:e}, reference {w:e}",
                    family.kind(),
                    points[p]
                );
            }
        }
    }
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

/// Every textured family of the export, per filter: its lookup's kernels on the GPU
/// against the CPU emulation and against the reference, then the family's own checks
/// (`GpuFamily::checks`).
///
/// `baked`: the export's baked WGSL (`lobefit_baked.wgsl`); each kernel is run a
/// second time through its `_baked` wrapper from that file, and the row
/// `<family> baked` counts the output words that differ from the uniform path's.
pub fn check_textured(gpu: &Gpu, export: &Export, weight_bits: u32, baked: &str) -> Result<Vec<Row>, String> {
    let m = &export.manifest;
    // The device's hardware filter is emulated as it weights: 8-bit emulation where it
    // rounds weights to 1/256, exact (f32) weights where the probe found ≥ 12 bits.
    let hw_emulation = if weight_bits >= 12 {
        Filter::Manual
    } else {
        Filter::Hardware
    };
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let mut rows = Vec::new();
    for (f, texs) in m.families.iter().zip(&export.textures) {
        let family = family_of(&f.family).ok_or_else(|| format!("unknown family {:?}", f.family))?;
        let gpu_family: GpuFamily =
            lobefit::fits::gpu_family(&f.family).ok_or_else(|| format!("{}: no GPU layout", f.family))?;
        let entries: Vec<TextureEntry> = texs.iter().map(|(e, _)| e.clone()).collect();
        let kernels = gpu_family.kernels(&entries)?;
        let uploaded: Vec<GpuTexture> = texs
            .iter()
            .map(|(_, t)| gpu.upload(t, m.storage))
            .collect::<Result<_, _>>()?;
        let points = sample_points(family.as_ref(), m.samples, m.seed)?;
        let floors = channel_floors(texs.iter().map(|(e, t)| (e.channels.as_slice(), t)), m.storage);
        let filters: &[Filter] = if gpu_family.exact_fetch {
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
            let runner = Bound {
                gpu,
                entries: &entries,
                uploaded: &uploaded,
                dummy: &dummy,
                filter,
            };
            let (got, via, mut baked_row) = run_kernels(&runner, &kernels, &gpu_family, f, baked, &points)?;
            let emu_filter = if filter == Filter::Hardware {
                hw_emulation
            } else {
                filter
            };
            let samplers_of = |r| samplers(texs, emu_filter, r);
            let eight_bit = emu_filter == Filter::Hardware;
            let axes = texs.iter().map(|(e, _)| e.axes.len()).max().unwrap_or(1);
            let alternatives: Vec<Vec<Sampler>> = if eight_bit {
                WeightRounding::corners(axes, m.storage == Storage::F16)
                    .map(samplers_of)
                    .collect()
            } else {
                Vec::new()
            };
            let samplers = samplers_of(WeightRounding::Nearest);
            let ctx = Context {
                alternatives: &alternatives,
                family: family.as_ref(),
                entry: f,
                textures: &entries,
                samplers: &samplers,
                filter,
                emu_filter,
                storage: m.storage,
                scale: m.scale,
                samples: m.samples,
                seed: m.seed,
            };
            // Per point, the emulation's outputs and those under each alternative
            // rounding (evaluated once: the span and the alternatives' errors read them).
            let emulated: Vec<(Vec<f32>, Vec<Vec<f32>>)> = points
                .iter()
                .map(|x| {
                    let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
                    let alts = alternatives.iter().map(|a| (gpu_family.eval)(a, &x32)).collect();
                    ((gpu_family.eval)(&samplers, &x32), alts)
                })
                .collect();
            let alt_values: Vec<Outputs> = (0..alternatives.len())
                .map(|a| {
                    emulated
                        .iter()
                        .map(|(_, alts)| alts[a].iter().map(|&v| f64::from(v)).collect())
                        .collect()
                })
                .collect();
            let emulation = Emulation {
                env: emulated
                    .into_iter()
                    .map(|(mid, alts)| Envelope::of(mid, alts))
                    .collect(),
                alt_values,
            };
            let env = &emulation.env;
            if !alternatives.is_empty() {
                // The baked path's coordinates may round an ulp apart, and an 8-bit
                // filter's weight then a step apart: held to the span's width.
                let around: Vec<Envelope> = got
                    .iter()
                    .zip(env)
                    .map(|(g, e)| {
                        let w = |k: usize| e.hi[k] - e.lo[k];
                        Envelope {
                            mid: e.mid.clone(),
                            lo: g.iter().enumerate().map(|(k, &v)| v as f32 - w(k)).collect(),
                            hi: g.iter().enumerate().map(|(k, &v)| v as f32 + w(k)).collect(),
                        }
                    })
                    .collect();
                baked_row.vs_cpu = scaled_outside(&via, &around).0;
            }
            rows.push(Row {
                storage: m.storage.to_string(),
                ..baked_row
            });
            rows.extend(against_emulation_and_reference(
                &ctx,
                &runner,
                &gpu_family,
                &points,
                &got,
                &emulation,
                &floors,
            )?);
        }
    }
    Ok(rows)
}

/// Per sample point, the outputs of a family's kernels (in kernel order).
type Outputs = Vec<Vec<f64>>;

/// A family's emulation at the sample points: per point its span over the hardware
/// filter's alternative roundings, and each alternative's outputs.
struct Emulation {
    env: Vec<Envelope>,
    alt_values: Vec<Outputs>,
}

/// Every kernel of one family and filter on the device: the outputs per point (in
/// kernel order), the same through each kernel's `_baked` wrapper (a second run), and
/// the row `<family> baked` comparing the two (its storage left for the caller).
fn run_kernels(
    runner: &Bound,
    kernels: &[Kernel],
    gpu_family: &GpuFamily,
    f: &lobefit::export::manifest::FamilyEntry,
    baked: &str,
    points: &[Vec<f64>],
) -> Result<(Outputs, Outputs, Row), String> {
    let mut got = vec![Vec::new(); points.len()];
    let mut via_all = vec![Vec::new(); points.len()];
    // The baked constants let the shader compiler fold and contract the unpacking
    // (offset, scale, trend) differently: equal within rounding, not always bit for
    // bit (f16 exports).
    let (mut differing, mut words, mut worst, mut wrapped) = (0usize, 0usize, 0.0f64, Vec::new());
    for k in kernels {
        let out = runner.run(k, points)?;
        let Some((name, body)) = baked_call(k, gpu_family.baked, runner.entries, runner.filter) else {
            return Err(format!("{}: no baked wrapper covers kernel {}", f.family, k.name));
        };
        let via = run_baked(runner, k, &body, baked, points)?;
        for (a, b) in out.iter().flatten().zip(via.iter().flatten()) {
            differing += usize::from((*a as f32).to_bits() != (*b as f32).to_bits());
            words += 1;
        }
        worst = worst.max(scaled_diff(&via, &out).0);
        wrapped.push(name);
        for (g, out) in got.iter_mut().zip(out) {
            g.extend(out);
        }
        for (g, via) in via_all.iter_mut().zip(via) {
            g.extend(via);
        }
    }
    let row = Row {
        function: format!(
            "{} baked: {} ({differing} of {words} words not bit-equal)",
            f.family,
            match wrapped.as_slice() {
                [one] => one.clone(),
                [first, ..] => format!("{first} and {} more", wrapped.len() - 1),
                [] => "-".into(),
            }
        ),
        storage: String::new(),
        filter: runner.filter.name().into(),
        samples: points.len(),
        vs_cpu: worst,
        cpu_what: "uniform path",
        vs_ref: Vec::new(),
        info: Vec::new(),
    };
    Ok((got, via_all, row))
}

/// The device's outputs `got` at `points` against the CPU emulation of the export (its
/// span over the alternative roundings, [`Emulation`]) and
/// against the family's reference (held to the manifest's promises), then the
/// family's own checks (`GpuFamily::checks`): the rows of one family and filter.
fn against_emulation_and_reference(
    ctx: &Context,
    runner: &Bound,
    gpu_family: &GpuFamily,
    points: &[Vec<f64>],
    got: &[Vec<f64>],
    emulation: &Emulation,
    floors: &[lobefit::export::run::ChannelFloor],
) -> Result<Vec<Row>, String> {
    let (family, f, filter, emu_filter) = (ctx.family, ctx.entry, ctx.filter, ctx.emu_filter);
    let env = &emulation.env;
    let emu: Vec<Vec<f64>> = env
        .iter()
        .map(|e| e.mid.iter().map(|&v| f64::from(v)).collect())
        .collect();
    // Keyed by the lookup's inputs: a sample may carry more (mask-weights' seed of a
    // held-out configuration), which the family's check does not look up.
    let n_in = family.inputs().len();
    let lookup_of = |values: &[Vec<f64>]| {
        Precomputed(
            points
                .iter()
                .map(|x| key(&x[..n_in.min(x.len())]))
                .zip(values.iter().cloned())
                .collect(),
        )
    };
    let lookup = lookup_of(got);
    // What the emulation errs under the other weight roundings: a device that rounds
    // so is held to that (the promise is measured under rounding to nearest).
    let mut alternative_errs = Vec::new();
    for values in &emulation.alt_values {
        alternative_errs.extend(errors_of(family, &lookup_of(values), points, filter, floors)?);
    }
    let errs = errors_of(family, &lookup, points, filter, floors)?;
    let vs_ref: Vec<(String, f64, f64)> = errs
        .iter()
        .map(|e| {
            let promise = f
                .error
                .iter()
                .find(|p| p.filter == filter && p.output == e.output && p.metric == e.metric)
                .map_or(e.export_target(), |p| p.promise);
            let rounded = alternative_errs
                .iter()
                .filter(|a| a.output == e.output && a.metric == e.metric)
                .fold(promise, |m, a| m.max(a.measured));
            (
                format!("{} {}", e.output, e.metric.trim_start_matches("offgrid.")),
                e.measured,
                rounded * (1.0 + PROMISE_SLACK),
            )
        })
        .collect();
    let (vs_cpu, worst) = scaled_outside(got, env);
    if WORST.load(std::sync::atomic::Ordering::Relaxed) {
        print_worst(ctx, &lookup, points, got, &emu, worst, vs_ref.as_slice());
    }
    let mut rows = Vec::new();
    for check in gpu_family.checks {
        rows.extend(check(ctx, runner)?);
    }
    rows.push(Row {
        function: format!("{} ({})", f.family, family.outputs().get(worst).unwrap_or(&"?")),
        storage: ctx.storage.to_string(),
        filter: if gpu_family.exact_fetch {
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
    Ok(rows)
}

/// The call of kernel `k` rewritten to the export's baked wrapper (`GpuFamily::baked`):
/// the wrapper whose function `k` calls with the same textures; its `LfTex` arguments
/// (`P`, `P2`) and fixed arguments dropped, `_hw` for hardware filtering. Returns
/// (wrapper, body), or `None` when no wrapper covers the call.
pub fn baked_call(k: &Kernel, baked: &[Baked], entries: &[TextureEntry], filter: Filter) -> Option<(String, String)> {
    let stems: Vec<&str> = k
        .textures
        .iter()
        .map(|&i| {
            entries
                .get(i)
                .map_or("", |e| e.file.split('.').next().unwrap_or_default())
        })
        .collect();
    let b = baked
        .iter()
        .find(|b| b.textures == stems.as_slice() && k.body.contains(&format!("{}(", b.function)))?;
    for (from, to) in [
        ("T, S, P, T2, P2, ", "T, S, T2, "),
        ("T, S, P, ", "T, S, "),
        ("T, P, ", "T, "),
    ] {
        let call = format!("{}({from}", b.function);
        if k.body.contains(&call) {
            let hw = filter == Filter::Hardware && to.contains('S');
            let name = format!("{}{}", b.wrapper, if hw { "_hw" } else { "" });
            let mut new = format!("{name}({to}");
            let mut body = k.body.replace(&call, &new);
            for (_, value) in b.fixed {
                let with = format!("{new}{value}, ");
                body = body.replace(&with, &new);
                new = format!("{name}({to}");
            }
            return Some((name, body));
        }
    }
    None
}

/// Kernel `k` with body `body`, its library replaced by the baked shader `baked`.
fn run_baked(
    runner: &Bound,
    k: &Kernel,
    body: &str,
    baked: &str,
    points: &[Vec<f64>],
) -> Result<Vec<Vec<f64>>, String> {
    let n_in = points.first().map_or(0, |x| x.len());
    let with = Kernel::new(&k.name, &k.textures, body, k.n_out);
    let p = runner.prepare(&with, n_in)?;
    let lib = lobefit_tables::shaders::library();
    let rest = p
        .source
        .strip_prefix(lib.as_str())
        .ok_or("a kernel's source does not start with the library")?;
    runner.dispatch(&p, &format!("{baked}\n{rest}"), points, k.n_out)
}

/// Samplers of a family's textures for the CPU emulation.
pub fn samplers(texs: &[(TextureEntry, Texture)], filter: Filter, rounding: WeightRounding) -> Vec<Sampler> {
    texs.iter()
        .map(|(e, t)| Sampler {
            axes: e.axes.clone(),
            channels: e.channels.clone(),
            texture: t.clone(),
            filter,
            rounding,
        })
        .collect()
}

/// The export's baked uniforms (`lobefit_uniforms.wgsl`, the constant functions
/// `lf_tex_<texture>_manual()` / `_hardware()`) compiled for the device with the
/// library: every one of the 160 words each returns, read back on the GPU, against
/// the uniform the manifest gives (`TextureEntry::lf_tex`), bit for bit. The row's
/// "vs CPU" is the number of differing words.
pub fn check_baked(gpu: &Gpu, dir: &std::path::Path, export: &Export) -> Result<Vec<Row>, String> {
    let m = &export.manifest;
    let path = dir.join(&m.uniforms_wgsl);
    let baked = lobefit::io::read_text(&path, 16 << 20)?;
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let body = |f: &str| {
        format!(
            "    var u = {f}();\n\
             for (var k = 0u; k < 3u; k++) {{\n        for (var c = 0u; c < 4u; c++) {{\n\
                         Y[o + 4u * k + c] = u.axis[k][c];\n            Y[o + 12u + 4u * k + c] = u.map[k][c];\n\
                         Y[o + 24u + 4u * k + c] = u.offset[k][c];\n            Y[o + 36u + 4u * k + c] = u.scale[k][c];\n\
                         Y[o + 144u + 4u * k + c] = u.decode[k][c];\n        }}\n    }}\n\
             for (var k = 0u; k < 24u; k++) {{\n        for (var c = 0u; c < 4u; c++) {{\n\
                         Y[o + 48u + 4u * k + c] = u.trend[k][c];\n        }}\n    }}\n\
             for (var c = 0u; c < 4u; c++) {{\n        Y[o + 156u + c] = bitcast<f32>(u.mode[c]);\n    }}"
        )
    };
    let (mut differing, mut count) = (0usize, 0usize);
    for t in m.families.iter().flat_map(|f| &f.textures) {
        let id = lobefit::export::shaders::wgsl_identifier(t.file.split('.').next().unwrap_or_default());
        for (what, filter) in [("manual", Filter::Manual), ("hardware", Filter::Hardware)] {
            let src = kernel("texture_2d<f32>", 1, 160, &body(&format!("lf_tex_{id}_{what}"))) + &baked;
            let got = gpu.run(&src, &[0u8; LF_TEX_SIZE], &dummy, &[0.0], 1, 160)?;
            let want = t.lf_tex(filter)?.to_bytes();
            differing += got
                .iter()
                .zip(want.chunks(4))
                .filter(|(g, w)| g.to_bits() != u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
                .count();
            count += 1;
        }
    }
    Ok(vec![Row {
        function: "baked uniforms".into(),
        storage: m.storage.to_string(),
        filter: "-".into(),
        samples: count,
        vs_cpu: differing as f64,
        cpu_what: "manifest (bits)",
        vs_ref: Vec::new(),
        info: Vec::new(),
    }])
}

/// The closed forms (tables a shader evaluates with no texture): each entry's checks.
pub fn check_closed(gpu: &Gpu, samples: usize, seed: u64) -> Result<Vec<Row>, String> {
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let runner = Bound {
        gpu,
        entries: &[],
        uploaded: &[],
        dummy: &dummy,
        filter: Filter::Manual,
    };
    let mut rows = Vec::new();
    for c in lobefit::fits::closed_form() {
        rows.extend((c.checks)(&runner, samples, seed)?);
    }
    Ok(rows)
}

/// The library's `lf_sin` and `lf_cos` on the device against f64 sin and cos of the
/// same f32 arguments: relative error on [-pi, pi], where GPUs' own sin and cos are
/// accurate in absolute terms only (the reason for them), absolute beyond.
/// Arguments: log-spaced from 1e-30 to 1, just beside pi/2 and pi (where the results
/// are small), and uniform in [-4 pi, 4 pi]; results below 1e-30 (flushed on some
/// devices) skipped.
/// Limit 1e-6 (8 f32 ulps); a device's plain sin(1e-4) errs by 0.3 % on NVIDIA.
pub fn check_trig(gpu: &Gpu) -> Result<Row, String> {
    let mut xs: Vec<f32> = (0..400).map(|k| 10f32.powf(-30.0 + 30.0 * k as f32 / 399.0)).collect();
    let mut rng = lobefit::rng::Rng::new(0x7419);
    for m in 1..=2 {
        let c = m as f64 * std::f64::consts::FRAC_PI_2;
        for k in 0..40 {
            let d = 10f64.powf(-7.0 + 6.0 * k as f64 / 39.0);
            xs.extend([(c - d) as f32, (c + d) as f32, c as f32, -(c - d) as f32]);
        }
    }
    xs.extend((0..2000).map(|_| rng.range(-4.0 * std::f64::consts::PI, 4.0 * std::f64::consts::PI) as f32));
    let xs: Vec<f32> = xs.iter().flat_map(|&x| [x, -x]).collect();
    let src = kernel(
        "texture_2d<f32>",
        1,
        2,
        "    Y[o] = lf_sin(x0);\n    Y[o + 1u] = lf_cos(x0);",
    );
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let out = gpu.run(&src, &[0u8; LF_TEX_SIZE], &dummy, &xs, xs.len(), 2)?;
    let mut worst = 0.0f64;
    for (x, o) in xs.iter().zip(out.chunks(2)) {
        let x = f64::from(*x);
        for (got, want) in [(o[0], x.sin()), (o[1], x.cos())] {
            // Relative on [-pi, pi], absolute beyond (the reduction's rounding).
            let scale = if x.abs() <= std::f64::consts::PI {
                want.abs()
            } else {
                1.0
            };
            if want.abs() > 1e-30 {
                worst = worst.max((f64::from(got) - want).abs() / scale);
            }
        }
    }
    Ok(Row {
        function: "lf_sin, lf_cos".into(),
        storage: "-".into(),
        filter: "-".into(),
        samples: xs.len(),
        vs_cpu: worst,
        cpu_what: "f64 (rel)",
        vs_ref: vec![("sin, cos max_rel".into(), worst, 1e-6)],
        info: Vec::new(),
    })
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

/// `gpu-check --worst`: the device's linear-filter weights against rules for them.
/// On an n × 1 texture holding each texel's index, sampled at node coordinates t in
/// texel n / 2 (4096 steps), the weight is the sample minus that index; it is
/// compared with the fraction of t = u n − 0.5 (f32, as the emulation computes it)
/// rounded to 1/256 to nearest (the emulation's rule) and down. Lines of text.
pub fn probe_filter_rules(gpu: &Gpu) -> Result<Vec<String>, String> {
    let mut lines = Vec::new();
    for n in [2usize, 1000, 4096] {
        let mut t = dummy_texture();
        t.width = n as u32;
        t.data = (0..n).map(|i| i as f32).collect();
        let tex = gpu.upload(&t, Storage::F32)?;
        let i0 = (n / 2).min(n - 2);
        let xs: Vec<f32> = (0..4096).map(|k| i0 as f32 + k as f32 / 4096.0).collect();
        let src = kernel(
            "texture_2d<f32>",
            1,
            1,
            &format!("    Y[o] = textureSampleLevel(T, S, vec2<f32>((x0 + 0.5) / {n}.0, 0.5), 0.0).x;"),
        );
        let out = gpu.run(&src, &[0u8; LF_TEX_SIZE], &tex, &xs, xs.len(), 1)?;
        let (mut near, mut down, mut first) = (0, 0, Vec::new());
        for (x, g) in xs.iter().zip(&out) {
            let u = (x + 0.5) / n as f32;
            let tt = u * n as f32 - 0.5;
            let f = tt - tt.floor();
            let w = g - tt.floor();
            let rn = (f * 256.0).round() / 256.0;
            let rd = (f * 256.0).floor() / 256.0;
            near += usize::from(w == rn);
            down += usize::from(w == rd);
            if w != rn && first.len() < 4 {
                first.push(format!("t {tt} weight {w} (nearest {rn}, down {rd})"));
            }
        }
        lines.push(format!(
            "filter probe n = {n}: {near} of {} weights round to nearest 1/256, {down} down; first misses of nearest: {}",
            xs.len(),
            first.join("; ")
        ));
    }
    Ok(lines)
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
pub fn check_glslang(export: &std::path::Path, baked: &[String]) -> Result<Vec<Row>, String> {
    let dir = std::env::temp_dir().join(format!("lobefit-gpu-glslang-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut rows = Vec::new();
    let mut sources = vec![
        (
            "glsl 450 (glslang -V)".to_string(),
            false,
            lobefit::export::shaders::glsl(false)?,
        ),
        (
            "glsl es 300 (glslang)".to_string(),
            true,
            lobefit::export::shaders::glsl(true)?,
        ),
    ];
    // The export's baked GLSL files, as written.
    for f in baked.iter().filter(|f| f.ends_with(".glsl")) {
        let es = f.ends_with(".es.glsl");
        let text = lobefit::io::read_text(&export.join(f), 64 << 20)?;
        sources.push((format!("{f} (glslang{})", if es { "" } else { " -V" }), es, text));
    }
    for (name, es, lib) in sources {
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
            function: name,
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

    /// Bad export directories: missing, no manifest, a manifest of another version.
    #[test]
    fn bad_exports_have_specific_errors() {
        let e = read_export(std::path::Path::new("/nonexistent/lobefit-export"))
            .err()
            .unwrap();
        assert!(e.contains("no such export directory"), "{e}");
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("bad");
        std::fs::create_dir_all(&dir).unwrap();
        let e = read_export(&dir).err().unwrap();
        assert!(e.contains("cannot read") && e.contains("manifest.json"), "{e}");
        std::fs::write(dir.join(lobefit::export::manifest::MANIFEST), "{\"version\": 99}").unwrap();
        let e = read_export(&dir).err().unwrap();
        assert!(e.contains("manifest version 99"), "{e}");
        std::fs::write(dir.join(lobefit::export::manifest::MANIFEST), "[1, 2]").unwrap();
        let e = read_export(&dir).err().unwrap();
        assert!(e.contains("not a lobefit export manifest"), "{e}");
    }
}
