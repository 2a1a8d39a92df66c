//! `lobefit-gpu cost`: per shader function, the SPIR-V size of its kernel (naga, after
//! removing what the kernel does not reach) and GPU evaluations per second.

use std::time::Instant;

use lobefit::export::layout::Filter;
use lobefit::export::run::{family_of, sample_points};
use lobefit::export::Storage;
use lobefit::family::Query;
use lobefit::fits::log_zh::LogZhFamily;
use lobefit::fits::wrap::WrapFamily;
use lobefit::rng::Rng;
use lobefit_tables::log_zh::Kind;

use crate::conformance::{dummy_texture, kernel, kernel_with, lf_tex, shexp_body, textured_body, Export};
use crate::device::{wgsl_texture_type, Gpu};

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
    tex: &crate::device::GpuTexture,
    second: Option<(&[u8], &crate::device::GpuTexture)>,
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

/// The costs of the textured families of `export` (manual filtering) and the closed forms.
pub fn costs(gpu: &Gpu, export: &Export) -> Result<Vec<Cost>, String> {
    let m = &export.manifest;
    let mut out = Vec::new();
    for (f, texs) in m.families.iter().zip(&export.textures) {
        let Some((body, n_out)) = textured_body(&f.family) else {
            continue;
        };
        let family = family_of(&f.family).ok_or_else(|| format!("unknown family {:?}", f.family))?;
        let points = sample_points(family.as_ref(), 2000, m.seed)?;
        let by_name = |name: &str| {
            texs.iter()
                .find(|(e, _)| e.file.split('.').next() == Some(name))
                .ok_or_else(|| format!("{}: the export lacks texture {name}", f.family))
        };
        if f.family == "shexp" {
            // Order 8, the largest: f_0..f_7, ‖f̂‖, a, b at θ_b.
            let (entry, tex) = by_name("shexp-n8")?;
            let up = gpu.upload(tex, m.storage)?;
            let src = kernel(wgsl_texture_type(tex), 1, 11, &shexp_body(8));
            out.push(Cost {
                function: format!("shexp order 8 ({})", m.storage),
                spirv: spirv_instructions(&src)?,
                per_second: time(gpu, &src, &lf_tex(entry, Filter::Manual), &up, None, &points, 11)?,
            });
            let (entry, tex) = by_name("shexp-hyb-n8")?;
            let up = gpu.upload(tex, m.storage)?;
            let src = kernel(
                wgsl_texture_type(tex),
                1,
                2,
                "    let ab = lf_shexp_hyb_ab(T, S, P, x0);\n    Y[o] = ab.x;\n    Y[o + 1u] = ab.y;",
            );
            let norms: Vec<Vec<f64>> = (0..2000).map(|i| vec![0.015625 * i as f64 / 1999.0]).collect();
            out.push(Cost {
                function: format!("shexp HYB a, b ({})", m.storage),
                spirv: spirv_instructions(&src)?,
                per_second: time(gpu, &src, &lf_tex(entry, Filter::Manual), &up, None, &norms, 2)?,
            });
            continue;
        }
        let (entry, tex) = &texs[0];
        let up = gpu.upload(tex, m.storage)?;
        // The lobe products' ln W texture rides along.
        let second = if f.family.starts_with("lobe-product") {
            let (e2, t2) = by_name(&format!("{}-lnw", f.family))?;
            Some((
                lf_tex(e2, Filter::Manual),
                gpu.upload(t2, m.storage)?,
                wgsl_texture_type(t2),
            ))
        } else {
            None
        };
        let src = kernel_with(
            wgsl_texture_type(tex),
            second.as_ref().map(|s| s.2),
            family.inputs().len(),
            n_out,
            body,
        );
        out.push(Cost {
            function: format!("{} ({})", f.family, m.storage),
            spirv: spirv_instructions(&src)?,
            per_second: time(
                gpu,
                &src,
                &lf_tex(entry, Filter::Manual),
                &up,
                second.as_ref().map(|s| (s.0.as_slice(), &s.1)),
                &points,
                n_out,
            )?,
        });
    }
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let eight = |call: &str| {
        format!("    let z = {call};\n    for (var k = 0u; k < 8u; k++) {{\n        Y[o + k] = z[k];\n    }}")
    };
    let li = family_of("lobe-integral").ok_or("lobe-integral: not in the registry")?;
    let closed: Vec<(&str, Box<dyn Query>, String, usize)> = vec![
        ("lobe-integral", li, "    Y[o] = lf_lobe_integral(x0);".into(), 1),
        (
            "wrap (8 bands)",
            Box::new(WrapFamily::default()),
            eight("lf_wrap_lambda_hat(8u, x0)"),
            8,
        ),
        (
            "log-zh phong (n 8)",
            Box::new(LogZhFamily {
                kind: Kind::Phong,
                order: 8,
            }),
            eight("lf_log_zh_phong(x0, x1, 8u)"),
            8,
        ),
        (
            "log-zh blocker (n 8)",
            Box::new(LogZhFamily {
                kind: Kind::Blocker,
                order: 8,
            }),
            eight("lf_log_zh_blocker(x0, x1, 8u)"),
            8,
        ),
    ];
    for (name, fam, body, n_out) in closed {
        let mut rng = Rng::new(m.seed);
        let points: Vec<Vec<f64>> = (0..2000).map(|_| fam.sample(&mut rng)).collect();
        let src = kernel("texture_2d<f32>", fam.inputs().len(), n_out, &body);
        out.push(Cost {
            function: name.into(),
            spirv: spirv_instructions(&src)?,
            per_second: time(
                gpu,
                &src,
                &[0u8; crate::kernel::LF_TEX_SIZE],
                &dummy,
                None,
                &points,
                n_out,
            )?,
        });
    }
    Ok(out)
}
