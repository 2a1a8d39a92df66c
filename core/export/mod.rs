//! `lobefit export`: the tables as GPU textures (KTX2, DDS, a C header, raw texels
//! with a JSON sidecar), in f32 or f16, with a manifest saying how a shader maps a
//! query to texture coordinates.

pub mod families;
pub mod formats;
pub mod gpu_check;
pub mod layout;
pub mod manifest;
pub mod shaders;

use std::fmt;

/// Texel storage precision of an exported texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Storage {
    /// IEEE binary32 per channel.
    F32,
    /// IEEE binary16 per channel (round to nearest even; the `half` crate).
    F16,
}

impl Storage {
    /// Bytes per channel.
    pub fn bytes(self) -> usize {
        match self {
            Storage::F32 => 4,
            Storage::F16 => 2,
        }
    }
    /// CLI/manifest name.
    pub fn name(self) -> &'static str {
        match self {
            Storage::F32 => "f32",
            Storage::F16 => "f16",
        }
    }
    /// Significand bits after the binary point: 23 (f32), 10 (f16).
    pub fn fraction_bits(self) -> i32 {
        match self {
            Storage::F32 => 23,
            Storage::F16 => 10,
        }
    }
    /// The unit in the last place of `x` in this storage's precision,
    /// 2^(⌊log₂|x|⌋ − [`fraction_bits`](Self::fraction_bits)) (exponent range aside: the
    /// packing's offset and scale keep texels in range); 0 for `x` = 0 or not finite.
    pub fn ulp(self, x: f64) -> f64 {
        let a = x.abs();
        if a == 0.0 || !a.is_finite() {
            return 0.0;
        }
        (a.log2().floor() - f64::from(self.fraction_bits())).exp2()
    }
    /// The rounding floor of a channel stored in this storage: what a texture of this
    /// storage can hold of its value at all, [`FLOOR_ULPS`] ulps of the stored value's
    /// scale — `|scale|` × the ulp (this storage's) of the largest |texel| `max_texel`,
    /// plus the f32 ulp of the largest |value| `max_value` the shader decodes
    /// (trend + offset + scale · texel, in f32). In the channel's units: ln units, that
    /// is relative error, for a log channel. For f32 with scale 1 and no offset this is
    /// 4 f32 ulps of the channel's largest |value| (×2: texel and decode); for f16 it is
    /// 4 f16 ulps of the texel range after offset, scale and trend, times the scale.
    /// Half an ulp is the texel's own rounding; the rest covers the interpolation.
    pub fn channel_floor(self, scale: f64, max_texel: f64, max_value: f64) -> f64 {
        FLOOR_ULPS * (scale.abs() * self.ulp(max_texel) + Storage::F32.ulp(max_value))
    }
}

/// Ulps of a channel's stored scale its storage is allowed beyond the family's own
/// limit (see [`Storage::channel_floor`]): 4, for f32 and f16 alike.
pub const FLOOR_ULPS: f64 = 4.0;

impl fmt::Display for Storage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Container format of an exported texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Khronos KTX 2.0 (Vulkan, wgpu, Bevy, Filament).
    Ktx2,
    /// DirectDraw Surface with the DX10 header (D3D tooling, Unreal, Unity).
    Dds,
    /// A C99/C++ header with the texels as an array.
    Inc,
    /// Little-endian texels plus a JSON sidecar.
    Raw,
}

impl Format {
    /// CLI/manifest name, also the file extension (`.ktx2`, `.dds`, `.inc`, `.bin` for raw).
    pub fn name(self) -> &'static str {
        match self {
            Format::Ktx2 => "ktx2",
            Format::Dds => "dds",
            Format::Inc => "inc",
            Format::Raw => "raw",
        }
    }
    /// File extension of the texture file.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Raw => "bin",
            other => other.name(),
        }
    }
    /// All formats.
    pub const ALL: [Format; 4] = [Format::Ktx2, Format::Dds, Format::Inc, Format::Raw];
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One texture: a 1D, 2D or 3D grid of texels (optionally an array of layers), each
/// of 1, 2 or 4 f32 channels. `data` is layer-major, then z, then y, then x, channels
/// fastest: texel (x, y, z, layer) channel c sits at
/// `((((layer * depth + z) * height + y) * width + x) * channels + c)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// File stem, e.g. `cap-exponent`.
    pub name: String,
    /// 1, 2 or 3.
    pub dimension: u8,
    /// Texels along x.
    pub width: u32,
    /// Texels along y (1 for 1D).
    pub height: u32,
    /// Texels along z (1 for 1D and 2D).
    pub depth: u32,
    /// Array layers (1: not an array texture).
    pub layers: u32,
    /// Channels per texel: 1 (R), 2 (RG) or 4 (RGBA).
    pub channels: u32,
    /// The texel values (see the type's docs for the order).
    pub data: Vec<f32>,
}

impl Texture {
    /// Number of f32 values `data` must hold.
    pub fn value_count(&self) -> usize {
        self.width as usize * self.height as usize * self.depth as usize * self.layers as usize * self.channels as usize
    }

    /// Checks the shape: dimension 1..=3 with unused extents 1, channels 1, 2 or 4,
    /// `data` of the right length and finite, extents within common API limits
    /// ([`MAX_1D_2D_EXTENT`], [`MAX_3D_EXTENT`], [`MAX_LAYERS`]).
    pub fn validate(&self) -> Result<(), String> {
        let n = &self.name;
        if !matches!(self.dimension, 1..=3) {
            return Err(format!("texture {n}: dimension {} is not 1, 2 or 3", self.dimension));
        }
        if (self.dimension < 2 && self.height != 1) || (self.dimension < 3 && self.depth != 1) {
            return Err(format!("texture {n}: a {}D texture has height/depth 1", self.dimension));
        }
        if !matches!(self.channels, 1 | 2 | 4) {
            return Err(format!("texture {n}: {} channels (1, 2 or 4 only)", self.channels));
        }
        if self.width == 0 || self.height == 0 || self.depth == 0 || self.layers == 0 {
            return Err(format!("texture {n}: an extent is 0"));
        }
        let limit = if self.dimension == 3 {
            MAX_3D_EXTENT
        } else {
            MAX_1D_2D_EXTENT
        };
        for (what, v) in [("width", self.width), ("height", self.height), ("depth", self.depth)] {
            if v > limit {
                return Err(format!(
                    "texture {n}: {what} {v} exceeds {limit}, the common API limit for {}D textures",
                    self.dimension
                ));
            }
        }
        if self.layers > MAX_LAYERS {
            return Err(format!("texture {n}: {} array layers exceed {MAX_LAYERS}", self.layers));
        }
        if self.data.len() != self.value_count() {
            return Err(format!(
                "texture {n}: {} values for {} texels × {} channels",
                self.data.len(),
                self.value_count() / self.channels as usize,
                self.channels
            ));
        }
        if let Some(i) = self.data.iter().position(|v| !v.is_finite()) {
            return Err(format!("texture {n}: value {i} is not finite ({})", self.data[i]));
        }
        Ok(())
    }
}

/// Largest width/height of a 1D or 2D texture the common APIs guarantee (D3D11+, Vulkan
/// on desktop GPUs: 16384).
pub const MAX_1D_2D_EXTENT: u32 = 16384;
/// Largest extent of a 3D texture the common APIs guarantee (2048).
pub const MAX_3D_EXTENT: u32 = 2048;
/// Largest number of array layers the common APIs guarantee (2048).
pub const MAX_LAYERS: u32 = 2048;
