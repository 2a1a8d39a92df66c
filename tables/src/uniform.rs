//! `LfTex`, the uniform every textured function of the shader library takes
//! (`tables/shaders/common.wgsl`): how a texture maps a query to texel coordinates
//! and texels back to values. A renderer fills one per texture from what the export's
//! manifest says of it (`lobefit export`), uploads [`LfTex::to_bytes`] (or the struct
//! itself, with the `bytemuck` feature) as a uniform buffer, and passes it with the
//! texture. Its layout is the WGSL struct's: 39 `vec4<f32>` then a `vec4<u32>`, 640
//! bytes, std140-compatible (a test checks it against the WGSL as naga lays it out).

use thiserror::Error;

use crate::format::Mapping;

/// Bytes of [`LfTex`].
pub const LF_TEX_SIZE: usize = 640;

/// Axis mapping kinds as `LfTex` (and the manifest) number them.
pub mod mapping_kind {
    /// `u = x`.
    pub const LINEAR: u32 = 0;
    /// `u = ln x`.
    pub const LOG: u32 = 1;
    /// `u = ln(1 + x / scale)`; constants (scale, 0).
    pub const LOG1P: u32 = 2;
    /// `u = ln((x − a) / (b − x))`; constants (a, b).
    pub const LOGIT: u32 = 3;
    /// `u = asinh((x − centre) / width)`; constants (centre, width).
    pub const ASINH: u32 = 4;
}

impl Mapping {
    /// The mapping of kind number `kind` ([`mapping_kind`]) with constants `c` (the
    /// inverse of [`Mapping::shader_code`]); `None` for an unknown kind.
    pub fn from_shader_code(kind: u32, c: [f64; 2]) -> Option<Mapping> {
        Some(match kind {
            mapping_kind::LINEAR => Mapping::Linear,
            mapping_kind::LOG => Mapping::Log,
            mapping_kind::LOG1P => Mapping::Log1p { scale: c[0] },
            mapping_kind::LOGIT => Mapping::Logit { a: c[0], b: c[1] },
            mapping_kind::ASINH => Mapping::Asinh {
                centre: c[0],
                width: c[1],
            },
            _ => return None,
        })
    }

    /// The mapping's kind number ([`mapping_kind`]) and its two constants, as shaders
    /// read them.
    pub fn shader_code(&self) -> (u32, [f64; 2]) {
        match *self {
            Mapping::Linear => (mapping_kind::LINEAR, [0.0; 2]),
            Mapping::Log => (mapping_kind::LOG, [0.0; 2]),
            Mapping::Log1p { scale } => (mapping_kind::LOG1P, [scale, 0.0]),
            Mapping::Logit { a, b } => (mapping_kind::LOGIT, [a, b]),
            Mapping::Asinh { centre, width } => (mapping_kind::ASINH, [centre, width]),
        }
    }
}

/// How a textured function filters (`LfTex.mode.x`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Filtering {
    /// Two (four, eight) `textureLoad`s interpolated in f32: exact weights; works with
    /// any texture format. Bind a non-filtering sampler (32-bit float textures do not
    /// filter on every device).
    Manual = 0,
    /// One `textureSampleLevel` through a linear, clamp-to-edge sampler (8-bit
    /// sub-texel weights on most GPUs; f32 textures need float32-filterable).
    Hardware = 1,
}

/// One texture axis, slowest first, as the manifest states it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformAxis {
    /// The mapping applied to the query value.
    pub mapping: Mapping,
    /// The mapping of the axis's first node value.
    pub mapped_lo: f64,
    /// The mapping of its last node value.
    pub mapped_hi: f64,
    /// Nodes (texels) along it.
    pub count: u32,
}

/// One channel of the texture, as the manifest states it: value = trend(t) + offset +
/// scale · texel, then the compression's inverse where `compression` > 0.
#[derive(Debug, Clone, PartialEq)]
pub struct UniformChannel {
    /// Array layer (0..3).
    pub layer: u32,
    /// Component within the texel (0 = R .. 3 = A).
    pub component: u32,
    /// Added after scaling.
    pub offset: f64,
    /// Multiplies the texel.
    pub scale: f64,
    /// Quintic trend coefficients c0..c5 in t = s / (count − 1) (empty: none).
    pub trend: Vec<f64>,
    /// Width w of the compression v = sign(x) ln(1 + |x|/w) (0: stored as is).
    pub compression: f64,
}

/// A texture that does not fit `LfTex`.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum UniformError {
    /// More axes, layers, components or trend coefficients than the struct holds, or
    /// a value that is not finite.
    #[error("the texture does not fit LfTex: {0}")]
    DoesNotFit(String),
    /// The manifest cannot be read, or does not describe the texture.
    #[error("{0}")]
    Manifest(String),
}

/// The uniform (see the module doc). Fields as in common.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "bytemuck", derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct LfTex {
    /// Per axis: (mapped_lo, mapped_hi, node count, mapping kind).
    pub axis: [[f32; 4]; 3],
    /// Per axis: the mapping's two constants.
    pub map: [[f32; 4]; 3],
    /// Channel k = 4 layer + component: offset at `[layer][component]`.
    pub offset: [[f32; 4]; 3],
    /// Channel k: scale at `[layer][component]`.
    pub scale: [[f32; 4]; 3],
    /// Channel k: trend c0..c3 at `[2k]`, c4, c5 at `[2k + 1]`.
    pub trend: [[f32; 4]; 24],
    /// Channel k: compression width at `[layer][component]` (0: none).
    pub decode: [[f32; 4]; 3],
    /// `.x`: [`Filtering`].
    pub mode: [u32; 4],
}

impl LfTex {
    /// The uniform of a texture with `axes` (slowest first, at most 3) and `channels`
    /// (at most 3 layers of 4 components, trends of at most 6 coefficients), filtered
    /// as `filtering` says. Unused channels get offset 0 and scale 1.
    pub fn new(axes: &[UniformAxis], channels: &[UniformChannel], filtering: Filtering) -> Result<LfTex, UniformError> {
        let no = |what: String| Err(UniformError::DoesNotFit(what));
        if axes.len() > 3 {
            return no(format!("{} axes (at most 3)", axes.len()));
        }
        let mut u = LfTex {
            scale: [[1.0; 4]; 3],
            mode: [filtering as u32, 0, 0, 0],
            ..LfTex::default()
        };
        let f = |name: &str, v: f64| -> Result<f32, UniformError> {
            let x = v as f32;
            if x.is_finite() {
                Ok(x)
            } else {
                Err(UniformError::DoesNotFit(format!("{name} = {v} is not a finite f32")))
            }
        };
        for (k, a) in axes.iter().enumerate() {
            let (kind, c) = a.mapping.shader_code();
            u.axis[k] = [
                f("mapped_lo", a.mapped_lo)?,
                f("mapped_hi", a.mapped_hi)?,
                a.count as f32,
                kind as f32,
            ];
            u.map[k] = [f("mapping constant", c[0])?, f("mapping constant", c[1])?, 0.0, 0.0];
        }
        for ch in channels {
            let (l, c) = (ch.layer as usize, ch.component as usize);
            if l >= 3 || c >= 4 || ch.trend.len() > 6 {
                return no(format!(
                    "a channel at layer {l}, component {c}, with {} trend coefficients (3 layers of 4, quintic trends)",
                    ch.trend.len()
                ));
            }
            if ch.compression.is_nan() || ch.compression < 0.0 {
                return no(format!("compression width {}", ch.compression));
            }
            u.offset[l][c] = f("offset", ch.offset)?;
            u.scale[l][c] = f("scale", ch.scale)?;
            u.decode[l][c] = f("compression", ch.compression)?;
            let k = 4 * l + c;
            for (j, &coef) in ch.trend.iter().enumerate() {
                u.trend[2 * k + j / 4][j % 4] = f("trend coefficient", coef)?;
            }
        }
        Ok(u)
    }

    /// The uniform of texture `texture` (its file stem, e.g. `"cap-exponent"`) of an
    /// export whose `manifest.json` text is `manifest` (feature `manifest`).
    ///
    /// ```
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// # let manifest = r#"{"version": 4, "families": [{"textures": [{"file": "cap-exponent.ktx2",
    /// #   "axes": [{"axis": {"count": 1000}, "mapped_lo": -5.0, "mapped_hi": 5.0,
    /// #             "mapping_kind": 3, "mapping_constants": [-0.01, 1.58]}],
    /// #   "channels": [{"layer": 0, "component": 0, "offset": 0.0, "scale": 1.0,
    /// #                 "trend": [], "compression": 0.0}]}]}]}"#;
    /// use lobefit_tables::uniform::{Filtering, LfTex};
    /// // let manifest = std::fs::read_to_string("export/manifest.json")?;
    /// let u = LfTex::from_manifest(&manifest, "cap-exponent", Filtering::Manual)?;
    /// let bytes = u.to_bytes(); // the uniform buffer's contents
    /// # assert_eq!(u.axis[0][2], 1000.0);
    /// # Ok(()) }
    /// ```
    #[cfg(feature = "manifest")]
    pub fn from_manifest(manifest: &str, texture: &str, filtering: Filtering) -> Result<LfTex, UniformError> {
        manifest::lf_tex(manifest, texture, filtering)
    }

    /// The 640 bytes to upload (little-endian, the struct's layout).
    pub fn to_bytes(&self) -> [u8; LF_TEX_SIZE] {
        let mut out = [0u8; LF_TEX_SIZE];
        let rows = self
            .axis
            .iter()
            .chain(&self.map)
            .chain(&self.offset)
            .chain(&self.scale)
            .chain(&self.trend)
            .chain(&self.decode);
        let mut at = 0;
        for row in rows {
            for v in row {
                out[at..at + 4].copy_from_slice(&v.to_le_bytes());
                at += 4;
            }
        }
        for v in self.mode {
            out[at..at + 4].copy_from_slice(&v.to_le_bytes());
            at += 4;
        }
        out
    }
}

/// The part of an export manifest (versions 2 to 4) the uniform needs.
#[cfg(feature = "manifest")]
mod manifest {
    use serde::Deserialize;

    use super::{Filtering, LfTex, Mapping, UniformAxis, UniformChannel, UniformError};

    #[derive(Deserialize)]
    struct Manifest {
        version: u32,
        families: Vec<Family>,
    }
    #[derive(Deserialize)]
    struct Family {
        textures: Vec<Texture>,
    }
    #[derive(Deserialize)]
    struct Texture {
        file: String,
        axes: Vec<Axis>,
        channels: Vec<Channel>,
    }
    #[derive(Deserialize)]
    struct Axis {
        axis: Count,
        mapped_lo: f64,
        mapped_hi: f64,
        mapping_kind: u32,
        mapping_constants: [f64; 2],
    }
    #[derive(Deserialize)]
    struct Count {
        count: u32,
    }
    #[derive(Deserialize)]
    struct Channel {
        layer: u32,
        component: u32,
        offset: f64,
        scale: f64,
        #[serde(default)]
        trend: Vec<f64>,
        compression: f64,
    }

    pub(super) fn lf_tex(text: &str, texture: &str, filtering: Filtering) -> Result<LfTex, UniformError> {
        let bad = |what: String| UniformError::Manifest(what);
        let m: Manifest = serde_json::from_str(text).map_err(|e| bad(format!("not an export manifest: {e}")))?;
        // Version 3 added the baked shaders' file names, 4 the errors' rounding floors;
        // the textures' part is as in 2.
        if !(2..=4).contains(&m.version) {
            return Err(bad(format!("manifest version {} (this reads 2 to 4)", m.version)));
        }
        let t = m
            .families
            .iter()
            .flat_map(|f| &f.textures)
            .find(|t| t.file.split('.').next() == Some(texture))
            .ok_or_else(|| bad(format!("no texture {texture:?} in the manifest")))?;
        let axes = t
            .axes
            .iter()
            .map(|a| {
                Ok(UniformAxis {
                    mapping: Mapping::from_shader_code(a.mapping_kind, a.mapping_constants)
                        .ok_or_else(|| bad(format!("unknown mapping kind {}", a.mapping_kind)))?,
                    mapped_lo: a.mapped_lo,
                    mapped_hi: a.mapped_hi,
                    count: a.axis.count,
                })
            })
            .collect::<Result<Vec<_>, UniformError>>()?;
        let channels: Vec<UniformChannel> = t
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
        LfTex::new(&axes, &channels, filtering)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn places_every_member_and_refuses_what_does_not_fit() {
        let axes = [UniformAxis {
            mapping: Mapping::Logit { a: -0.5, b: 2.0 },
            mapped_lo: -1.0,
            mapped_hi: 3.0,
            count: 1000,
        }];
        let ch = UniformChannel {
            layer: 1,
            component: 2,
            offset: 0.25,
            scale: 2.0,
            trend: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
            compression: 0.5,
        };
        let u = LfTex::new(&axes, std::slice::from_ref(&ch), Filtering::Hardware).unwrap();
        let b = u.to_bytes();
        let f = |vec4: usize, c: usize| f32::from_le_bytes(b[16 * vec4 + 4 * c..][..4].try_into().unwrap());
        assert_eq!([f(0, 0), f(0, 1), f(0, 2), f(0, 3)], [-1.0, 3.0, 1000.0, 3.0]);
        assert_eq!([f(3, 0), f(3, 1)], [-0.5, 2.0]);
        assert_eq!(f(6 + 1, 2), 0.25);
        assert_eq!(f(9 + 1, 2), 2.0);
        assert_eq!(f(9, 0), 1.0, "unused channels: scale 1");
        // k = 4·1 + 2 = 6: trend at vec4 12 + 2k (c0..c3) and 13 + 2k (c4, c5).
        assert_eq!([f(24, 0), f(24, 3), f(25, 0), f(25, 1)], [1.0, 4.0, 5.0, 6.0]);
        assert_eq!(f(36 + 1, 2), 0.5);
        assert_eq!(u32::from_le_bytes(b[624..628].try_into().unwrap()), 1);
        for bad in [
            UniformChannel { layer: 3, ..ch.clone() },
            UniformChannel {
                component: 4,
                ..ch.clone()
            },
            UniformChannel {
                trend: vec![0.0; 7],
                ..ch.clone()
            },
            UniformChannel {
                offset: f64::NAN,
                ..ch.clone()
            },
            UniformChannel {
                scale: 1e300,
                ..ch.clone()
            },
            UniformChannel {
                compression: -1.0,
                ..ch.clone()
            },
        ] {
            assert!(LfTex::new(&axes, &[bad], Filtering::Manual).is_err());
        }
        assert!(LfTex::new(&[axes[0]; 4], &[], Filtering::Manual).is_err());
    }
}
