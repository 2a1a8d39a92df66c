//! mask-weights on the GPU: the table's 60 weight channels as one 2D R texture, x on
//! ln dist (the table's axis), y the channel index (one row per channel: a shader's
//! texture parameters hold at most three RGBA layers, the table has fifteen); the
//! shader reads row k at its texel centre, so the row never blends with its
//! neighbours, and holds dist at the table's ends.

use lobefit_tables::format::{Axis, Mapping, Placement};
use lobefit_tables::mask_weights::{channel_names, DIST_MAX, DIST_MIN};
use lobefit_tables::Table;

use crate::export::families::{Baked, GpuFamily, Kernels};
use crate::export::layout::{grid_of_table, grid_of_values, ChannelSpec, Grid, Sampler};
use crate::export::Storage;

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
    checks: &[],
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

fn eval(s: &[Sampler], x: &[f32]) -> Vec<f32> {
    let dist = x[0].clamp(DIST_MIN as f32, DIST_MAX as f32);
    (0..channel_names().len())
        .map(|k| s[0].sample(&[k as f32, dist])[0])
        .collect()
}
