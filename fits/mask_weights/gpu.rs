//! mask-weights on the GPU: the table's 60 weight channels as one 2D R texture, x on
//! ln dist (the table's axis), y the channel index (one row per channel: a shader's
//! texture parameters hold at most three RGBA layers, the table has fifteen); the
//! shader reads row k at its texel centre, so the row never blends with its
//! neighbours, and holds dist at the table's ends.

use lobefit_tables::format::{Axis, Mapping, Placement};
use lobefit_tables::mask_weights::{channel_names, MaskMode, MaskWeights, WeightSet, DIST_MAX, DIST_MIN, MAX_DEPTH};
use lobefit_tables::Table;

use lobefit_core::export::families::{Baked, GpuFamily, Kernels};
use lobefit_core::export::gpu_check::{r32, Context, Kernel, Row, Runner};
use lobefit_core::export::layout::{grid_of_table, grid_of_values, ChannelSpec, Grid, Sampler};
use lobefit_core::export::Storage;
use lobefit_core::rng::Rng;

/// The export of mask-weights.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::mask_weights::KIND,
    grids,
    eval,
    shader: "w = R at (row k, clamp(dist, 0.25, 10)), k = (2 set + mode) · 15 + D (D − 1)/2 + level − 1 \
             (set 0 fitted, 1 paper; mode 0 aggressive, 1 conservative; maximal depth D, level 1..D), \
             the rows in the table's channel order; the all-ones set reads nothing",
    extra: None,
    kernels: Kernels::One {
        textures: &[0],
        body: "    for (var k = 0u; k < 60u; k++) {
        Y[o + k] = lf_mask_weights_row(T, S, P, k, x0);
    }",
        n_out: 60,
    },
    exact_fetch: false,
    checks: &[|ctx, runner| weight(ctx, runner).map(|r| vec![r])],
    timed: None,
    plot_export: true,
    baked: &[
        Baked {
            wrapper: "lf_mask_weights_row_baked",
            function: "lf_mask_weights_row",
            textures: &["mask-weights"],
            fixed: &[],
        },
        Baked {
            wrapper: "lf_mask_weight_baked",
            function: "lf_mask_weight",
            textures: &["mask-weights"],
            fixed: &[],
        },
    ],
};

/// The table's channels as rows of one R texture (the `dist` axis resampled by
/// `scale`, the channel axis kept whole).
fn grids(kind: &str, table: &Table, storage: Storage, scale: f64) -> Result<Vec<Grid>, String> {
    let g = grid_of_table(kind, table, Storage::F32, scale)?;
    let dist = g.axes[0].axis.clone();
    let n = dist.count as usize;
    let per = g.texture.channels as usize;
    let rows = channel_names().len();
    let mut values = Vec::with_capacity(rows * n);
    for ch in &g.channels {
        for i in 0..n {
            values.push(f64::from(
                g.texture.data[(ch.layer as usize * n + i) * per + ch.component as usize],
            ));
        }
    }
    let channel = Axis {
        name: "channel".into(),
        unit: "1".into(),
        lo: 0.0,
        hi: (rows - 1) as f64,
        mapping: Mapping::Linear,
        count: rows as u32,
        placement: Placement::Endpoints,
    };
    let spec = ChannelSpec {
        name: "weight".into(),
        meaning: format!(
            "w_level of eq. 39; row k is the table's channel k ({} … {})",
            channel_names()[0],
            channel_names()[rows - 1]
        ),
        log: false,
    };
    Ok(vec![grid_of_values(kind, &[channel, dist], &[spec], &values, storage)?])
}

/// The texture row of (set 0 fitted / 1 paper, mode 0 aggressive / 1 conservative,
/// maximal depth, level): the shader's `lf_mask_weight` index, written again here for
/// the emulation (the checks hold both to the runtime's channels by name).
fn row(set: u32, mode: u32, depth: u32, level: u32) -> usize {
    ((set * 2 + mode) * 15 + depth * (depth - 1) / 2 + level - 1) as usize
}

fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let dist = x[0].clamp(DIST_MIN as f32, DIST_MAX as f32);
    (0..channel_names().len())
        .map(|k| s[0].sample(&[k as f32, dist])[0])
        .collect()
}

/// `lf_mask_weight` (the shader's channel index from weight set, mode, maximal depth
/// and level) at random (dist, set, mode, D, level), dist log-uniform over [0.1, 20]
/// (beyond the table's range, where the weights are held): GPU against the CPU
/// emulation of the same row, and against the runtime's `MaskWeights::weights` on the
/// committed table (which indexes the table's channels by name, not by the shader's
/// formula): a row mixed up errs by a weight's difference between depths or sets.
/// Limit: 1e-5 for f32 textures, 1e-3 for f16 (one channel holds every weight, so f16
/// steps are those of its whole span; measured 1.4e-4).
fn weight(ctx: &Context, runner: &dyn Runner) -> Result<Row, String> {
    let samples = lobefit_core::export::gpu_check::WORLD_SAMPLES;
    let mut rng = Rng::new(ctx.seed ^ 0x3a5c);
    let inputs: Vec<Vec<f64>> = (0..samples)
        .map(|_| {
            let dist = r32(rng.range(0.1f64.ln(), 20f64.ln()).exp());
            let set = (rng.uniform() * 3.0).floor().min(2.0);
            let mode = (rng.uniform() * 2.0).floor().min(1.0);
            let depth = (rng.uniform() * MAX_DEPTH as f64).floor().min(MAX_DEPTH as f64 - 1.0) + 1.0;
            let level = (rng.uniform() * depth).floor().min(depth - 1.0) + 1.0;
            vec![dist, set, mode, depth, level]
        })
        .collect();
    let body = "    Y[o] = lf_mask_weight(T, S, P, u32(x1), u32(x2), u32(x3), u32(x4), x0);";
    let got = runner.run(&Kernel::new("mask-weights lf_mask_weight", &[0], body, 1), &inputs)?;
    let rt = MaskWeights::embedded().map_err(|e| e.to_string())?;
    // The emulation's own distance from the runtime under the hardware filter's
    // weight roundings widens the limit: 8-bit weights are not the runtime's exact ones.
    let (mut vs_emu, mut vs_rt, mut emu_rt) = (0.0f64, 0.0f64, 0.0f64);
    for (x, g) in inputs.iter().zip(&got) {
        let (set, mode, depth, level) = (x[1] as u32, x[2] as u32, x[3] as u32, x[4] as u32);
        let mut w = [0.0; MAX_DEPTH as usize];
        let sets = [WeightSet::Fitted, WeightSet::Paper, WeightSet::Ones];
        rt.weights(sets[set as usize], MaskMode::ALL[mode as usize], depth, x[0], &mut w)
            .map_err(|e| e.to_string())?;
        let want = w[level as usize - 1];
        if set == 2 {
            vs_emu = vs_emu.max((g[0] - 1.0).abs());
        } else {
            let k = row(set, mode, depth, level);
            let env = ctx.envelope(eval, &[x[0] as f32]);
            vs_emu = vs_emu.max(env.outside(k, g[0]));
            emu_rt = emu_rt
                .max((f64::from(env.lo[k]) - want).abs())
                .max((f64::from(env.hi[k]) - want).abs());
        }
        vs_rt = vs_rt.max((g[0] - want).abs());
    }
    let limit = match ctx.storage {
        Storage::F32 => 1e-5,
        Storage::F16 => 1e-3,
    } + if ctx.alternatives.is_empty() { 0.0 } else { emu_rt };
    Ok(Row {
        function: "mask-weights lf_mask_weight (set, mode, D, level)".into(),
        storage: ctx.storage.to_string(),
        filter: ctx.filter.name().into(),
        samples,
        vs_cpu: vs_emu,
        cpu_what: "emulation (abs)",
        vs_ref: vec![("weight vs runtime, max abs".into(), vs_rt, limit)],
        info: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use lobefit_core::export::layout::Filter;

    /// The texture's rows are the runtime's weights: every (set, mode, D, level) at
    /// nodes, between nodes and beyond the table's range, through the emulated sampler
    /// of the f32 texture at scale 1 (row k by the shader's index formula) against
    /// `MaskWeights::weights` (the table's channels by name).
    #[test]
    fn rows_are_the_runtime_weights() {
        let table = Table::from_bytes(lobefit_tables::embedded::MASK_WEIGHTS).unwrap();
        let g = grids(GPU.kind, &table, Storage::F32, 1.0).unwrap().remove(0);
        let s = [Sampler {
            axes: g.axes,
            channels: g.channels,
            texture: g.texture,
            filter: Filter::Manual,
            rounding: Default::default(),
        }];
        let rt = MaskWeights::embedded().unwrap();
        let mut w = [0.0; MAX_DEPTH as usize];
        for dist in [0.1, 0.25, 0.3, 1.0, 2.7, 9.99, 10.0, 30.0] {
            let rows = eval(&s, &[dist as f32]);
            for (si, set) in [WeightSet::Fitted, WeightSet::Paper].into_iter().enumerate() {
                for (mi, mode) in MaskMode::ALL.into_iter().enumerate() {
                    for depth in 1..=MAX_DEPTH {
                        rt.weights(set, mode, depth, f64::from(dist as f32), &mut w).unwrap();
                        for level in 1..=depth {
                            let got = f64::from(rows[row(si as u32, mi as u32, depth, level)]);
                            let want = w[level as usize - 1];
                            assert!(
                                (got - want).abs() < 1e-6,
                                "dist {dist} {set:?} {mode:?} D{depth} w{level}: {got} vs {want}"
                            );
                        }
                    }
                }
            }
        }
    }
}
