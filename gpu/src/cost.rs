//! `lobefit-gpu cost`: per shader function, the static counts of its kernel's SPIR-V
//! (naga, after removing what the kernel does not reach: [`kernel_counts`]) and GPU
//! evaluations per second. The counts serve `bench` too.

use std::time::Instant;

use lobefit::export::gpu_check::Kernel;
use lobefit::export::layout::Filter;
use lobefit::export::manifest::TextureEntry;
use lobefit::export::run::{family_of, sample_points};
use lobefit::export::Storage;

use crate::conformance::{dummy_texture, Export};
use crate::device::{Gpu, GpuTexture};
use crate::kernel::Bound;

/// Items per timed dispatch.
pub const ITEMS: usize = 1 << 18;

/// A loop's bound as the source states it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopBound {
    /// The loop's first statement breaks once a local variable reaches an integer
    /// constant from below (`k < N`: N; `k <= N`: N + 1): its iterations when the
    /// counter starts at 0 and steps by 1 (start and step are not checked).
    Constant(u64),
    /// Anything else: the bound is read from data (inputs, uniforms), or the loop
    /// counts down or breaks on another condition.
    DataDependent,
}

impl std::fmt::Display for LoopBound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoopBound::Constant(n) => write!(f, "{n}"),
            LoopBound::DataDependent => write!(f, "data"),
        }
    }
}

/// Static counts of a kernel's SPIR-V: parsed and validated by naga, compacted
/// (functions and types the entry point does not reach removed), written as SPIR-V 1.0.
/// Static: a function's loops and texture instructions count once however often it
/// is called, and a loop's body once however often it runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KernelCounts {
    /// SPIR-V instructions.
    pub instructions: usize,
    /// Texture instructions: OpImageSample*, OpImageFetch, OpImageGather,
    /// OpImageDrefGather, OpImageRead.
    pub texture_ops: usize,
    /// Loops (OpLoopMerge), each with its bound from naga's IR of the same module.
    pub loops: Vec<LoopBound>,
}

/// SPIR-V opcodes counted as texture instructions: OpImageSampleImplicitLod (87)
/// through OpImageSampleProjDrefExplicitLod (94), OpImageFetch (95), OpImageGather
/// (96), OpImageDrefGather (97), OpImageRead (98).
const TEXTURE_OPCODES: std::ops::RangeInclusive<u32> = 87..=98;
/// OpLoopMerge: one per structured loop.
const OP_LOOP_MERGE: u32 = 246;

/// The static counts of the WGSL kernel `src` ([`KernelCounts`]); an error where naga
/// cannot parse, validate or write it.
pub fn kernel_counts(src: &str) -> Result<KernelCounts, String> {
    let (mut module, _) = lobefit::export::shaders::module_of(src)?;
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| format!("naga validation: {e}"))?;
    let words = naga::back::spv::write_vec(&module, &info, &naga::back::spv::Options::default(), None)
        .map_err(|e| format!("SPIR-V writer: {e}"))?;
    // Header of 5 words, then instructions whose first word holds their word count
    // (high half) and opcode (low half).
    let (mut i, mut instructions, mut texture_ops, mut loop_merges) = (5, 0, 0, 0);
    while i < words.len() {
        let op = words[i] & 0xffff;
        texture_ops += usize::from(TEXTURE_OPCODES.contains(&op));
        loop_merges += usize::from(op == OP_LOOP_MERGE);
        i += (words[i] >> 16).max(1) as usize;
        instructions += 1;
    }
    let mut loops = Vec::new();
    for (_, f) in module.functions.iter() {
        loop_bounds(&module, f, &f.body, &mut loops);
    }
    for e in &module.entry_points {
        loop_bounds(&module, &e.function, &e.function.body, &mut loops);
    }
    // naga writes one OpLoopMerge per IR loop; a difference means the walk missed one.
    if loops.len() != loop_merges {
        return Err(format!(
            "kernel counts: {loop_merges} OpLoopMerge in the SPIR-V but {} loops in naga's IR",
            loops.len()
        ));
    }
    Ok(KernelCounts {
        instructions,
        texture_ops,
        loops,
    })
}

/// Appends the bound of every loop in `block` (nested ones included) to `out`.
fn loop_bounds(module: &naga::Module, f: &naga::Function, block: &naga::Block, out: &mut Vec<LoopBound>) {
    use naga::Statement as S;
    for s in block.iter() {
        match s {
            S::Loop { body, continuing, .. } => {
                out.push(bound_of(module, f, body));
                loop_bounds(module, f, body, out);
                loop_bounds(module, f, continuing, out);
            }
            S::Block(b) => loop_bounds(module, f, b, out),
            S::If { accept, reject, .. } => {
                loop_bounds(module, f, accept, out);
                loop_bounds(module, f, reject, out);
            }
            S::Switch { cases, .. } => {
                for c in cases {
                    loop_bounds(module, f, &c.body, out);
                }
            }
            _ => {}
        }
    }
}

/// The bound of a loop of `body`: its first `if` that only breaks, when its condition
/// compares a loaded local variable with an integer constant.
fn bound_of(module: &naga::Module, f: &naga::Function, body: &naga::Block) -> LoopBound {
    use naga::{BinaryOperator as B, Expression as E, Statement as S};
    let only_break = |b: &naga::Block| matches!(b.iter().collect::<Vec<_>>().as_slice(), [S::Break]);
    let Some(condition) = body.iter().find_map(|s| match s {
        S::If {
            condition,
            accept,
            reject,
        } if only_break(accept) || only_break(reject) => Some(*condition),
        S::Emit(_) => None,
        _ => None,
    }) else {
        return LoopBound::DataDependent;
    };
    let int = |h: naga::Handle<naga::Expression>| -> Option<u64> {
        let lit = match f.expressions[h] {
            E::Literal(l) => l,
            E::Constant(c) => match module.global_expressions[module.constants[c].init] {
                E::Literal(l) => l,
                _ => return None,
            },
            _ => return None,
        };
        match lit {
            naga::Literal::U32(v) => Some(u64::from(v)),
            naga::Literal::I32(v) => u64::try_from(v).ok(),
            naga::Literal::AbstractInt(v) => u64::try_from(v).ok(),
            _ => None,
        }
    };
    let is_counter = |h: naga::Handle<naga::Expression>| match f.expressions[h] {
        E::Load { pointer } => matches!(f.expressions[pointer], E::LocalVariable(_)),
        _ => false,
    };
    match f.expressions[condition] {
        E::Binary { op, left, right } => {
            let n = match op {
                B::Less | B::LessEqual if is_counter(left) => int(right),
                B::Greater | B::GreaterEqual if is_counter(right) => int(left),
                _ => None,
            };
            let inclusive = u64::from(matches!(op, B::LessEqual | B::GreaterEqual));
            n.map_or(LoopBound::DataDependent, |n| LoopBound::Constant(n + inclusive))
        }
        _ => LoopBound::DataDependent,
    }
}

/// One cost row: function, its kernel's static counts, evaluations per second (from
/// the best of 3 dispatches of [`ITEMS`] and of 4 × [`ITEMS`]: see `time`).
pub struct Cost {
    /// Function.
    pub function: String,
    /// Static counts of its kernel's SPIR-V.
    pub counts: KernelCounts,
    /// Evaluations per second.
    pub per_second: f64,
}

fn time(
    gpu: &Gpu,
    src: &str,
    params: &[u8],
    tex: &GpuTexture,
    second: Option<(&[u8], &GpuTexture)>,
    points: &[Vec<f64>],
    n_out: usize,
) -> Result<f64, String> {
    // Best of 3 at N and at 4N items: the difference cancels the fixed costs of a run
    // (shader compilation, pipeline and buffer creation); input upload and readback
    // scale with N and stay in.
    let best = |n: usize| -> Result<f64, String> {
        let inputs: Vec<f32> = points
            .iter()
            .cycle()
            .take(n)
            .flat_map(|x| x.iter().map(|&v| v as f32))
            .collect();
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t = Instant::now();
            gpu.run_with(src, params, tex, second, &inputs, n, n_out)?;
            best = best.min(t.elapsed().as_secs_f64());
        }
        Ok(best)
    };
    // The 4N run's largest buffer (inputs or outputs, f32) within the binding limit the
    // device was opened with (wgpu's default, 128 MiB): a kernel with many outputs (60
    // floats an item) times fewer items rather than fail to bind.
    let per_item = 4 * n_out.max(points.first().map_or(0, Vec::len)).max(1);
    let limit = wgpu::Limits::default().max_storage_buffer_binding_size as usize;
    let n = ITEMS.min(limit / (4 * per_item));
    let (t1, t4) = (best(n)?, best(4 * n)?);
    Ok(3.0 * n as f64 / (t4 - t1).max(1e-9))
}

/// Sample points per timed function.
const POINTS: usize = 2000;

/// The costs of the textured families of `export` (manual filtering: what each family
/// times, `GpuFamily::timed`) and of the closed forms.
pub fn costs(gpu: &Gpu, export: &Export) -> Result<Vec<Cost>, String> {
    let m = &export.manifest;
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let mut out = Vec::new();
    for (f, texs) in m.families.iter().zip(&export.textures) {
        let gpu_family = lobefit::fits::gpu_family(&f.family).ok_or_else(|| format!("{}: no GPU layout", f.family))?;
        let family = family_of(&f.family).ok_or_else(|| format!("unknown family {:?}", f.family))?;
        let points = sample_points(family.as_ref(), POINTS, m.seed)?;
        let entries: Vec<TextureEntry> = texs.iter().map(|(e, _)| e.clone()).collect();
        let timed = match gpu_family.timed {
            Some(timed) => timed(&entries, &points)?,
            None => gpu_family
                .kernels(&entries)?
                .into_iter()
                .map(|k| (k, points.clone()))
                .collect(),
        };
        let uploaded: Vec<GpuTexture> = texs
            .iter()
            .map(|(_, t)| gpu.upload(t, m.storage))
            .collect::<Result<_, _>>()?;
        let bound = Bound {
            gpu,
            entries: &entries,
            uploaded: &uploaded,
            dummy: &dummy,
            filter: Filter::Manual,
        };
        for (k, inputs) in timed {
            out.push(cost(&bound, &k, &inputs, &format!("{} ({})", k.name, m.storage))?);
        }
    }
    let bound = Bound {
        gpu,
        entries: &[],
        uploaded: &[],
        dummy: &dummy,
        filter: Filter::Manual,
    };
    for c in lobefit::fits::closed_form() {
        for (k, inputs) in (c.timed)(POINTS, m.seed) {
            out.push(cost(&bound, &k, &inputs, &k.name)?);
        }
    }
    Ok(out)
}

/// The cost row of kernel `k` over `inputs`, its textures bound by `bound`.
fn cost(bound: &Bound, k: &Kernel, inputs: &[Vec<f64>], function: &str) -> Result<Cost, String> {
    let p = bound.prepare(k, inputs.first().map_or(1, |x| x.len()))?;
    Ok(Cost {
        function: function.into(),
        counts: kernel_counts(&p.source)?,
        per_second: time(
            bound.gpu,
            &p.source,
            &p.params,
            p.texture,
            p.second.as_ref().map(|(b, t)| (b.as_slice(), *t)),
            inputs,
            k.n_out,
        )?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-written kernel with known counts: two textureSampleLevel and one
    /// textureLoad (3 texture instructions), a loop of constant bound 8, a loop bounded
    /// by a uniform, and a third loop in a helper called twice (counted once).
    #[test]
    fn counts_of_a_known_kernel() {
        let src = "
@group(0) @binding(0) var T: texture_2d<f32>;
@group(0) @binding(1) var S: sampler;
@group(0) @binding(2) var<storage, read_write> Y: array<f32>;
@group(0) @binding(3) var<uniform> N: vec4<u32>;
fn helper(x: f32) -> f32 {
    var s = x;
    for (var j = 0u; j < 3u; j++) {
        s = s * 0.5;
    }
    return s;
}
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    var s = 0.0;
    for (var k = 0u; k < 8u; k++) {
        s += textureSampleLevel(T, S, vec2<f32>(f32(k), 0.5), 0.0).x;
    }
    for (var k = 0u; k < N.x; k++) {
        s += 1.0;
    }
    s += textureSampleLevel(T, S, vec2<f32>(0.5), 0.0).y + textureLoad(T, vec2<i32>(0), 0).z;
    Y[gid.x] = helper(s) + helper(1.0);
}
";
        let c = kernel_counts(src).unwrap();
        assert_eq!(c.texture_ops, 3);
        let mut loops = c.loops.clone();
        loops.sort_by_key(|b| match b {
            LoopBound::Constant(n) => *n,
            LoopBound::DataDependent => u64::MAX,
        });
        assert_eq!(
            loops,
            [LoopBound::Constant(3), LoopBound::Constant(8), LoopBound::DataDependent]
        );
        assert!(c.instructions > 50, "{c:?}");
        assert!(kernel_counts("fn f( {").unwrap_err().contains("WGSL"));
    }
}
