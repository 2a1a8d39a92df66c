//! `lobefit-gpu cost`: per shader function, the SPIR-V size of its kernel (naga, after
//! removing what the kernel does not reach) and GPU evaluations per second.

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

/// SPIR-V instructions of a kernel: parsed and validated by naga, compacted (functions
/// and types the entry point does not reach removed), written as SPIR-V 1.0.
pub fn spirv_instructions(src: &str) -> Result<usize, String> {
    let (mut module, _) = lobefit::export::shaders::module_of(src)?;
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| format!("naga validation: {e}"))?;
    let words = naga::back::spv::write_vec(&module, &info, &naga::back::spv::Options::default(), None)
        .map_err(|e| format!("SPIR-V writer: {e}"))?;
    // Header of 5 words, then instructions whose first word holds their word count.
    let mut i = 5;
    let mut n = 0;
    while i < words.len() {
        i += (words[i] >> 16).max(1) as usize;
        n += 1;
    }
    Ok(n)
}

/// One cost row: function, SPIR-V instructions, evaluations per second (from the
/// best of 3 dispatches of [`ITEMS`] and of 4 × [`ITEMS`]: see `time`).
pub struct Cost {
    /// Function.
    pub function: String,
    /// SPIR-V instructions of its kernel.
    pub spirv: usize,
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
    let (t1, t4) = (best(ITEMS)?, best(4 * ITEMS)?);
    Ok(3.0 * ITEMS as f64 / (t4 - t1).max(1e-9))
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
        spirv: spirv_instructions(&p.source)?,
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
