//! wedge on the GPU: M_lin as a 3D texture of one f32 (or f16) per entry, hi + lo
//! merged (a shader has no use for a pair it can only add in f32), fetched per entry.

use lobefit_tables::wedge::WEDGE_COUNTS;
use lobefit_tables::Table;

use crate::export::families::GpuFamily;
use crate::export::layout::{grid_of_values, ChannelSpec, Grid, Sampler};
use crate::export::Storage;

/// The export of wedge.
pub const GPU: GpuFamily = GpuFamily {
    kind: lobefit_tables::wedge::KIND,
    grids,
    eval,
    shader: "[M_lin]_{row,col} = texelFetch at (x = col, y = row, z = log2(W) − 2), W ∈ {4, 8, 16, 32, 64}, \
             no filtering; the order-n operator is rows < n², columns j and 8 + j for j < n; \
             V = M_lin [v_k; v_{k+1}] as a mat-vec in the shader",
    extra: None,
    kernel: (
        "    let w = u32(round(log2(x0))) - 2u;\n    Y[o] = lf_wedge_entry(T, P, w, u32(x1), u32(x2));",
        1,
    ),
    plot_export: false,
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
