//! The build driver: fits every node of a family's grid (in parallel; the order of
//! evaluation never changes the bytes), checks convergence, encodes the file.

use lobefit_tables::format::{self, Diagnostics, EntryDiagnostics, FitInfo, Meta, Storage};
use lobefit_tables::Encoding;
use rayon::prelude::*;

use crate::family::{Fit, Fitted};

/// Generator string stored in every file: crate and version, no timestamp, no
/// commit hash (either would make rebuilds of unchanged tables differ).
pub const GENERATOR: &str = concat!("lobefit ", env!("CARGO_PKG_VERSION"));

/// Per-entry diagnostics are stored in full up to this many entries.
const PER_ENTRY_LIMIT: u64 = 1 << 16;

/// A built table.
#[derive(Debug, Clone)]
pub struct Built {
    /// The encoded file.
    pub bytes: Vec<u8>,
    /// Its description.
    pub meta: Meta,
}

/// Why a build produced no file.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// Some grid entries did not converge; nothing was written.
    #[error("{kind}: {count} of {total} fits did not converge, e.g. at {examples}")]
    NotConverged {
        kind: String,
        count: usize,
        total: usize,
        examples: String,
    },
    /// A value cannot be stored (non-finite, or non-positive under log encoding).
    #[error("{kind}: entry {index} channel '{channel}' has unstorable value {value}")]
    Unstorable {
        kind: String,
        index: usize,
        channel: String,
        value: f64,
    },
    /// The description is inconsistent (a bug in the family).
    #[error("{0}")]
    Format(String),
}

/// Axis coordinates of every grid node, in payload order.
pub fn grid_nodes(axes: &[lobefit_tables::Axis]) -> Vec<Vec<f64>> {
    let total: usize = axes.iter().map(|a| a.count as usize).product();
    let per_axis: Vec<Vec<f64>> = axes.iter().map(|a| (0..a.count).map(|i| a.node(i)).collect()).collect();
    (0..total)
        .map(|mut flat| {
            let mut x = vec![0.0; axes.len()];
            for d in (0..axes.len()).rev() {
                let n = axes[d].count as usize;
                x[d] = per_axis[d][flat % n];
                flat /= n;
            }
            x
        })
        .collect()
}

/// Fits every node of `family` on the current rayon pool, calling `tick` after each.
pub fn build(family: &dyn Fit, tick: &(dyn Fn() + Sync)) -> Result<Built, BuildError> {
    let kind = family.kind().to_string();
    let axes = family.axes();
    let channels = family.channels();
    let nodes = grid_nodes(&axes);
    // Nodes with a mirror reuse its fit (bit for bit: the fit is deterministic).
    let source: Vec<Option<usize>> = {
        let index: std::collections::HashMap<Vec<u64>, usize> = nodes
            .iter()
            .enumerate()
            .map(|(i, x)| (x.iter().map(|v| v.to_bits()).collect(), i))
            .collect();
        nodes
            .iter()
            .map(|x| {
                let m = family.mirror(x)?;
                index.get(&m.iter().map(|v| v.to_bits()).collect::<Vec<_>>()).copied()
            })
            .collect()
    };
    let own: Vec<Option<Fitted>> = nodes
        .par_iter()
        .zip(&source)
        .map(|(x, src)| {
            let f = src.is_none().then(|| family.fit(x));
            tick();
            f
        })
        .collect();
    let fits: Vec<Fitted> = (0..nodes.len())
        .map(|i| match (&own[i], source[i]) {
            (Some(f), _) => f.clone(),
            (None, Some(j)) => own[j].clone().unwrap_or_else(|| family.fit(&nodes[i])),
            (None, None) => unreachable!("a node without a mirror is fitted"),
        })
        .collect();
    let bad: Vec<usize> = (0..fits.len()).filter(|&i| !fits[i].converged).collect();
    if !bad.is_empty() {
        let examples = bad
            .iter()
            .take(5)
            .map(|&i| format!("{:?} (residual {:.3e})", nodes[i], fits[i].residual))
            .collect::<Vec<_>>()
            .join(", ");
        return Err(BuildError::NotConverged {
            kind,
            count: bad.len(),
            total: fits.len(),
            examples,
        });
    }
    let mut payload = Vec::with_capacity(fits.len() * channels.len());
    for (index, f) in fits.iter().enumerate() {
        for (ch, &v) in channels.iter().zip(&f.values) {
            let stored = match ch.encoding {
                Encoding::Linear => v,
                Encoding::Log => v.ln(),
            };
            let s32 = stored as f32;
            if !s32.is_finite() || (ch.encoding == Encoding::Log && v <= 0.0) {
                return Err(BuildError::Unstorable {
                    kind,
                    index,
                    channel: ch.name.clone(),
                    value: v,
                });
            }
            payload.push(s32);
        }
    }
    let n = fits.len() as u64;
    let per_entry = (n <= PER_ENTRY_LIMIT).then(|| EntryDiagnostics {
        residual: fits.iter().map(|f| f.residual as f32).collect(),
        iterations: fits.iter().map(|f| f.iterations).collect(),
        converged: fits.iter().map(|f| f.converged).collect(),
    });
    let method = family.method();
    let settings = family.settings();
    let meta = Meta {
        kind: kind.clone(),
        table_version: family.version(),
        generator: GENERATOR.to_string(),
        description: family.description(),
        axes,
        channels,
        storage: Storage::F32,
        fit: FitInfo {
            settings_hash: format::settings_hash(&method, &settings),
            method,
            settings,
        },
        diagnostics: Diagnostics {
            residual_meaning: family.residual_meaning().to_string(),
            entries: n,
            converged: n,
            max_residual: fits.iter().map(|f| f.residual).fold(0.0, f64::max),
            mean_residual: fits.iter().map(|f| f.residual).sum::<f64>() / n as f64,
            max_iterations: fits.iter().map(|f| f.iterations).max().unwrap_or(0),
            per_entry,
        },
        thresholds: family.thresholds(),
    };
    let bytes = format::encode(&meta, &payload).map_err(BuildError::Format)?;
    Ok(Built { bytes, meta })
}
