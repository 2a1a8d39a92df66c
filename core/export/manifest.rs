//! The export manifest (`manifest.json`): what a renderer needs to sample the
//! textures, and the measured error of these very files. Plain data: the export
//! driver (`run`) writes it, readers and the GPU conformance read it.

use serde::{Deserialize, Serialize};

use lobefit_tables::uniform::{Filtering, LfTex, UniformAxis, UniformChannel};

use super::layout::{Channel, Filter, TexAxis};
use super::{Format, Storage};

/// Manifest file name in an export directory.
pub const MANIFEST: &str = "manifest.json";
/// The manifest's JSON Schema (draft 2020-12), written beside it by every export.
pub const MANIFEST_SCHEMA: &str = include_str!("manifest.schema.json");
/// Its file name in an export directory.
pub const MANIFEST_SCHEMA_FILE: &str = "manifest.schema.json";
/// Manifest layout version.
pub const MANIFEST_VERSION: u32 = 4;
/// The manifest: everything a renderer needs to sample the textures, and the
/// measured error of these very files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`MANIFEST_VERSION`].
    pub version: u32,
    /// Container format of every texture here.
    pub format: Format,
    /// Texel precision.
    pub storage: Storage,
    /// Nodes per axis relative to the tables' (`--scale`).
    pub scale: f64,
    /// The texture-coordinate convention, in words.
    pub convention: String,
    /// Off-grid samples (seeded) behind each measured error.
    pub samples: usize,
    /// Their seed.
    pub seed: u64,
    /// The C header (in this directory) declaring the uniform `LobefitLfTex` and each
    /// texture's initializers, for manual and hardware filtering.
    pub uniforms_header: String,
    /// The WGSL file (in this directory) of each texture's uniform as constant
    /// functions `lf_tex_<texture>_manual()` / `_hardware()`, to concatenate after
    /// the library.
    pub uniforms_wgsl: String,
    /// The baked shader (in this directory): the library with this export's
    /// constants and per family `<function>_baked` wrappers that take the texture
    /// and the query alone; WGSL, GLSL 450, GLSL ES 3.0, HLSL 5.1.
    pub baked_shaders: Vec<String>,
    /// One entry per exported family.
    pub families: Vec<FamilyEntry>,
    /// Families a shader evaluates in closed form: (kind, formula).
    pub closed_form: Vec<(String, String)>,
}

/// One exported family: its textures, the shader's formulas, the measured error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FamilyEntry {
    /// Table kind.
    pub family: String,
    /// The family's inputs (as `lobefit eval` names them).
    pub inputs: Vec<String>,
    /// What the shader computes from the samples.
    pub shader: String,
    /// The textures.
    pub textures: Vec<TextureEntry>,
    /// Measured error per filter, quantity and metric.
    pub error: Vec<ErrorEntry>,
}

/// One exported texture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureEntry {
    /// File name in the export directory.
    pub file: String,
    /// File size (bytes).
    pub bytes: u64,
    /// 1, 2 or 3.
    pub dimension: u8,
    /// Texels along x, y, z; array layers; channels per texel.
    pub extent: [u32; 5],
    /// The texture axes (slowest first) and their coordinate formulas.
    pub axes: Vec<TexAxis>,
    /// The formula of each axis's texture coordinate.
    pub axis_formulas: Vec<String>,
    /// Channel packing.
    pub channels: Vec<Channel>,
}

/// One measured error of an exported texture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorEntry {
    /// `manual` or `hardware`.
    pub filter: Filter,
    /// Quantity (the family's checked output).
    pub output: String,
    /// Metric, e.g. `offgrid.max_rel`.
    pub metric: String,
    /// Measured on this file.
    pub measured: f64,
    /// The family's own limit (its `check` threshold).
    pub target: f64,
    /// The storage's rounding floor for this quantity: what a texture of this storage
    /// can hold at all. For a quantity that is a channel's value (same name), with an
    /// `_abs` metric (or `_rel` of a log channel), the channel's floor
    /// ([`Storage::channel_floor`]); 0 (none stated) for other quantities. The
    /// export's target is the larger of `target` and `floor`
    /// ([`ErrorEntry::export_target`]).
    ///
    /// [`Storage::channel_floor`]: super::Storage::channel_floor
    pub floor: f64,
    /// What `check --export` (and the GPU conformance) holds the file to: the family's
    /// target where met, else the measured value (within the floor, or a lossy export).
    pub promise: f64,
}

impl ErrorEntry {
    /// The export's target: the larger of the family's limit and the storage's
    /// rounding floor.
    pub fn export_target(&self) -> f64 {
        self.target.max(self.floor)
    }
    /// Whether the measured error meets the export's target ([`Self::export_target`]).
    pub fn meets_target(&self) -> bool {
        self.measured <= self.export_target()
    }
}

impl TextureEntry {
    /// The uniform the shader library's textured functions take for this texture,
    /// filtered as `filter` says (`lobefit_tables::uniform::LfTex`).
    pub fn lf_tex(&self, filter: Filter) -> Result<LfTex, String> {
        let axes: Vec<UniformAxis> = self
            .axes
            .iter()
            .map(|a| UniformAxis {
                mapping: a.axis.mapping,
                mapped_lo: a.mapped_lo,
                mapped_hi: a.mapped_hi,
                count: a.axis.count,
            })
            .collect();
        let channels: Vec<UniformChannel> = self
            .channels
            .iter()
            .map(|c| UniformChannel {
                layer: c.layer,
                component: c.component,
                offset: c.offset,
                scale: c.scale,
                trend: c.trend.clone(),
                compression: c.compression,
            })
            .collect();
        let filtering = match filter {
            Filter::Manual => Filtering::Manual,
            Filter::Hardware => Filtering::Hardware,
        };
        LfTex::new(&axes, &channels, filtering).map_err(|e| format!("{}: {e}", self.file))
    }
}
