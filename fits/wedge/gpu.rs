//! wedge on the GPU: M_lin as a 3D texture of one f32 (or f16) per entry, hi + lo
//! merged (a shader has no use for a pair it can only add in f32), fetched per entry.

use lobefit_tables::wedge::WEDGE_COUNTS;
use lobefit_tables::Table;

use lobefit_core::export::families::{Baked, GpuFamily, Kernels};
use lobefit_core::export::gpu_check::{r32, vector_diff, Context, Kernel, Row, Runner, WORLD_SAMPLES};
use lobefit_core::export::layout::{grid_of_values, ChannelSpec, Grid, Sampler};
use lobefit_core::export::Storage;

/// The export of wedge.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::wedge::KIND,
    grids,
    eval,
    shader: "[M_lin]_{row,col} = texelFetch at (x = col, y = row, z = log2(W) − 2), W ∈ {4, 8, 16, 32, 64}, \
             no filtering; the order-n operator is rows < n², columns j and 8 + j for j < n; \
             V = M_lin [v_k; v_{k+1}] as a mat-vec in the shader",
    extra: None,
    kernels: Kernels::One {
        textures: &[0],
        body: "    let w = u32(round(log2(x0))) - 2u;\n    Y[o] = lf_wedge_entry(T, P, w, u32(x1), u32(x2));",
        n_out: 1,
    },
    exact_fetch: true,
    checks: &[apply],
    timed: None,
    plot_export: false,
    baked: &[
        Baked {
            wrapper: "lf_wedge_entry_baked",
            function: "lf_wedge_entry",
            textures: &["wedge"],
            fixed: &[],
        },
        Baked {
            wrapper: "lf_wedge_apply_baked",
            function: "lf_wedge_apply",
            textures: &["wedge"],
            fixed: &[],
        },
    ],
};

/// The table's axes (W, row, col) with one channel, m = hi + lo rounded once to the
/// storage. `scale` is ignored: between matrix entries there is nothing to resample.
fn grids(kind: &str, table: &Table, storage: Storage, _scale: f64) -> Result<Vec<Grid>, String> {
    let meta = table.meta();
    let nch = meta.channels.len();
    let values: Vec<f64> = table
        .values()
        .chunks_exact(nch)
        .map(|p| f64::from(p[0]) + f64::from(p[1]))
        .collect();
    let spec = ChannelSpec {
        name: "m".into(),
        meaning: "[M_lin]_{row,col} (order-8 layout: col < 8 weights slice k, col ≥ 8 slice k + 1)".into(),
        log: false,
    };
    Ok(vec![grid_of_values(kind, &meta.axes, &[spec], &values, storage)?])
}

/// The entry the runtime's lookup returns: W rounded to its node, row and col as
/// integers (order 8: the stored layout itself).
fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let w = x[0].round() as u32;
    match WEDGE_COUNTS.iter().position(|&c| c == w) {
        Some(k) => s[0].fetch(&[k, x[1] as usize, x[2] as usize]),
        // No such operator: the runtime answers an error, a shader has no entry.
        None => vec![f32::NAN],
    }
}

/// `lf_wedge_apply` (order 8, every W) against the same mat-vec in f64 over the CPU's
/// fetch of the exported entries; vector-relative (see [`vector_diff`]).
fn apply(ctx: &Context, runner: &dyn Runner) -> Result<Vec<Row>, String> {
    let mut rng = lobefit_core::rng::Rng::new(ctx.seed ^ 0x3ed6e);
    let inputs: Vec<Vec<f64>> = (0..WORLD_SAMPLES)
        .map(|k| {
            let mut x = vec![(k % 5) as f64];
            x.extend((0..16).map(|_| r32(rng.range(-5.0, 0.0))));
            x
        })
        .collect();
    let body = "    var va: array<f32, 8>;\n    var vb: array<f32, 8>;\n    for (var k = 0u; k < 8u; k++) {\n        \
                va[k] = X[i * 17u + 1u + k];\n        vb[k] = X[i * 17u + 9u + k];\n    }\n    \
                let z = lf_wedge_apply(T, P, u32(x0), 8u, va, vb);\n    for (var k = 0u; k < 64u; k++) {\n        Y[o + k] = z[k];\n    }";
    let got = runner.run(&Kernel::new("wedge apply n8", &[0], body, 64), &inputs)?;
    let smp = &ctx.samplers[0];
    let want: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let w = x[0] as usize;
            (0..64)
                .map(|row| {
                    (0..8)
                        .map(|j| {
                            smp.fetch(&[w, row, j])[0] as f64 * x[1 + j]
                                + smp.fetch(&[w, row, 8 + j])[0] as f64 * x[9 + j]
                        })
                        .sum()
                })
                .collect()
        })
        .collect();
    Ok(vec![Row {
        function: "wedge apply n8".into(),
        storage: ctx.storage.to_string(),
        filter: "fetch".into(),
        samples: WORLD_SAMPLES,
        vs_cpu: vector_diff(&got, &want),
        cpu_what: "emulation, f64",
        vs_ref: Vec::new(),
        info: Vec::new(),
    }])
}
