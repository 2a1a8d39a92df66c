//! GPU layouts: a table's grid as a texture (axes → texture x, y; channels → RGBA,
//! array layers beyond 4), the per-channel packing (offset and scale, so that f16
//! stores a bounded, well-scaled number), and the sampler a shader runs, emulated on
//! the CPU in f32 arithmetic: texel-centre coordinates, manual linear interpolation or
//! hardware linear filtering with 8-bit sub-texel weights.

use lobefit_tables::{Axis, Encoding, Mapping, Placement, Table};
use serde::{Deserialize, Serialize};

use super::{Storage, Texture};

/// How the sampled value between texels is formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Filter {
    /// The shader fetches the neighbouring texels (`textureLoad`/`texelFetch`) and
    /// interpolates in f32.
    Manual,
    /// The texture unit's linear filter: its sub-texel weight has 8 fractional bits
    /// on current GPUs (weight rounded to a multiple of 1/256), emulated as such.
    Hardware,
}

impl Filter {
    /// Both filters, manual first.
    pub const ALL: [Filter; 2] = [Filter::Manual, Filter::Hardware];
    /// Report name.
    pub fn name(self) -> &'static str {
        match self {
            Filter::Manual => "manual",
            Filter::Hardware => "hardware",
        }
    }
}

/// Sub-texel weight resolution of hardware linear filtering (8 bits).
pub const HARDWARE_WEIGHT_STEPS: f32 = 256.0;

/// One stored channel: stored texel value = (v − offset) / scale, where v is the
/// channel's quantity (its natural log when `log`). A shader reads
/// v = offset + scale · texel, then exp(v) when `log`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Channel {
    /// Channel name (the table's).
    pub name: String,
    /// What it holds (the table's description).
    pub meaning: String,
    /// Whether the texel holds the natural log of the quantity.
    pub log: bool,
    /// Added after scaling.
    pub offset: f64,
    /// Multiplies the texel.
    pub scale: f64,
    /// A polynomial trend added back (1D textures in f16; empty otherwise): the
    /// channel's value is trend(t) + offset + scale · texel with t = s / (count − 1) ∈
    /// [0, 1] and trend(t) = c0 + c1 t + … + c5 t⁵ (Horner in f32). Storing the
    /// residual from the trend leaves f16 a narrow range to resolve.
    #[serde(default)]
    pub trend: Vec<f64>,
    /// Width w of a compression: 0, the value is stored as is; w > 0, the texel holds
    /// v = sign(x) ln(1 + |x|/w), and x = sign(v) w (exp(|v|) − 1) after filtering and
    /// unpacking (lobe-product's f16 export).
    pub compression: f64,
    /// Array layer holding the channel.
    pub layer: u32,
    /// Component within the texel: 0 = R, 1 = G, 2 = B, 3 = A.
    pub component: u32,
}

/// One axis of the texture: the table axis it samples and the texture coordinate
/// convention. Texture coordinate u = (s + 0.5) / count with s = (map(x) − map(lo)) /
/// (map(hi) − map(lo)) · (count − 1): node i sits at the centre of texel i.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TexAxis {
    /// The table axis (name, range, mapping, node count).
    pub axis: Axis,
    /// map(lo), map(hi): the constants of the mapping to s.
    pub mapped_lo: f64,
    /// See `mapped_lo`.
    pub mapped_hi: f64,
    /// Texture axis: `x` (fastest) or `y`.
    pub texture_axis: String,
    /// The mapping's kind as shaders number it (`lobefit_tables::uniform::mapping_kind`:
    /// 0 linear, 1 log, 2 log1p, 3 logit, 4 asinh).
    pub mapping_kind: u32,
    /// Its two constants: log1p (scale, 0), logit (a, b), asinh (centre, width), else 0.
    pub mapping_constants: [f64; 2],
}

impl TexAxis {
    fn new(axis: &Axis, texture_axis: &str) -> Result<TexAxis, String> {
        if axis.placement != Placement::Endpoints {
            return Err(format!("axis {}: only node-on-endpoint axes export", axis.name));
        }
        let (mapping_kind, mapping_constants) = axis.mapping.shader_code();
        Ok(TexAxis {
            mapped_lo: axis.mapping.forward(axis.lo),
            mapped_hi: axis.mapping.forward(axis.hi),
            axis: axis.clone(),
            texture_axis: texture_axis.into(),
            mapping_kind,
            mapping_constants,
        })
    }

    /// s (texel units, node i at s = i) of the axis value `x`, computed in f32 as a
    /// shader does (the mapping by f32 `ln`, `asinh`; no `ln_1p`, which shading
    /// languages lack).
    pub fn texel_coordinate(&self, x: f32) -> f32 {
        let u = match self.axis.mapping {
            Mapping::Linear => x,
            Mapping::Log => x.ln(),
            Mapping::Log1p { scale } => (1.0 + x / scale as f32).ln(),
            Mapping::Logit { a, b } => ((x - a as f32) / (b as f32 - x)).ln(),
            Mapping::Asinh { centre, width } => ((x - centre as f32) / width as f32).asinh(),
        };
        let (u0, u1) = (self.mapped_lo as f32, self.mapped_hi as f32);
        (u - u0) / (u1 - u0) * (self.axis.count - 1) as f32
    }

    /// The shader's formula for the texture coordinate, for the manifest.
    pub fn formula(&self) -> String {
        let m = match self.axis.mapping {
            Mapping::Linear => "x".to_string(),
            Mapping::Log => "log(x)".to_string(),
            Mapping::Log1p { scale } => format!("log(1 + x / {scale:?})"),
            Mapping::Logit { a, b } => format!("log((x - {a:?}) / ({b:?} - x))"),
            Mapping::Asinh { centre, width } => format!("asinh((x - {centre:?}) / {width:?})"),
        };
        format!(
            "u = (s + 0.5) / {n}, s = clamp(({m} - {lo:?}) / ({hi:?} - {lo:?}) * {nm1}, 0, {nm1}) with x = {name}",
            n = self.axis.count,
            lo = self.mapped_lo,
            hi = self.mapped_hi,
            nm1 = self.axis.count - 1,
            name = self.axis.name
        )
    }
}

/// A table's grid as one texture: its axes, channel packing, and texels.
#[derive(Debug, Clone)]
pub struct Grid {
    /// Axes, slowest first (2D: y then x).
    pub axes: Vec<TexAxis>,
    /// Channels, in the table's order.
    pub channels: Vec<Channel>,
    /// The texture (values already packed).
    pub texture: Texture,
}

/// The texels of `table` as they are stored (log channels as ln), packed for
/// `storage`: f32 stores them as they are (offset 0, scale 1); f16 stores each
/// channel mapped onto [−1, 1] by its own offset and scale, where binary16 has its
/// finest absolute spacing relative to the channel's range. More than 4 channels go
/// to array layers of RGBA; 3 are padded to RGBA with zeros.
///
/// `scale` sets the resolution: each axis gets round((n − 1) · scale) + 1 nodes over
/// the same range and mapping, valued by the table's own interpolation there (1: the
/// table's nodes and values as they are).
pub fn grid_of_table(name: &str, table: &Table, storage: Storage, scale: f64) -> Result<Grid, String> {
    let meta = table.meta();
    check_scale(scale)?;
    let (table_axes, values) = resample(table, scale)?;
    let channels: Vec<ChannelSpec> = meta
        .channels
        .iter()
        .map(|c| ChannelSpec {
            name: c.name.clone(),
            meaning: c.description.clone(),
            log: c.encoding == Encoding::Log,
        })
        .collect();
    grid_of_values(name, &table_axes, &channels, &values, storage)
}

/// A channel of [`grid_of_values`]: name, meaning, and whether the values given are
/// the natural log of the quantity (the shader applies exp).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelSpec {
    /// Channel name.
    pub name: String,
    /// What it holds.
    pub meaning: String,
    /// Values are ln of the quantity.
    pub log: bool,
}

/// A texture of node values `values` (C order over `table_axes`, slowest first;
/// channels fastest; log channels as ln), packed for `storage` as
/// [`grid_of_table`] describes. For layouts that are not a table's own grid.
pub fn grid_of_values(
    name: &str,
    table_axes: &[Axis],
    specs: &[ChannelSpec],
    values: &[f64],
    storage: Storage,
) -> Result<Grid, String> {
    let naxes = table_axes.len();
    if !(1..=3).contains(&naxes) {
        return Err(format!("{name}: {naxes} axes (1 to 3 export as one texture)"));
    }
    let nodes: usize = table_axes.iter().map(|a| a.count as usize).product();
    if specs.is_empty() || values.len() != nodes * specs.len() {
        return Err(format!(
            "{name}: {} values for {nodes} nodes × {} channels",
            values.len(),
            specs.len()
        ));
    }
    let names = ["z", "y", "x"][3 - naxes..].to_vec();
    let axes = table_axes
        .iter()
        .zip(names)
        .map(|(a, t)| TexAxis::new(a, t))
        .collect::<Result<Vec<_>, _>>()?;
    let nch = specs.len();
    let per_texel = if nch > 4 { 4 } else { [1, 1, 2, 4, 4][nch] };
    let layers = nch.div_ceil(4) as u32;
    let texels = values.len() / nch;
    let mut channels = Vec::with_capacity(nch);
    let mut residuals: Vec<Vec<f64>> = Vec::with_capacity(nch);
    for (c, ch) in specs.iter().enumerate() {
        let raw: Vec<f64> = (0..texels).map(|i| values[i * nch + c]).collect();
        let trend = if storage == Storage::F16 && naxes == 1 {
            trend_fit(&raw)
        } else {
            Vec::new()
        };
        let resid: Vec<f64> = raw
            .iter()
            .enumerate()
            .map(|(i, v)| v - eval_trend(&trend, i as f64 / (texels - 1).max(1) as f64))
            .collect();
        let (offset, scale) = match storage {
            Storage::F32 => (0.0, 1.0),
            Storage::F16 => {
                let (lo, hi) = resid
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
                let half = 0.5 * (hi - lo);
                (0.5 * (hi + lo), if half > 0.0 { half } else { 1.0 })
            }
        };
        residuals.push(resid);
        channels.push(Channel {
            name: ch.name.clone(),
            meaning: ch.meaning.clone(),
            log: ch.log,
            offset,
            scale,
            trend,
            compression: 0.0,
            layer: (c / 4) as u32,
            component: (c % 4) as u32,
        });
    }
    let mut data = vec![0.0f32; layers as usize * texels * per_texel];
    for i in 0..texels {
        for (c, ch) in channels.iter().enumerate() {
            let packed = if storage == Storage::F32 {
                values[i * nch + c] as f32
            } else {
                ((residuals[c][i] - ch.offset) / ch.scale) as f32
            };
            data[(ch.layer as usize * texels + i) * per_texel + ch.component as usize] = packed;
        }
    }
    // Texture x = the fastest axis (the table's last), then y, then z.
    let count = |k: usize| table_axes.get(naxes.wrapping_sub(1 + k)).map_or(1, |a| a.count);
    let (width, height, depth) = (count(0), count(1), count(2));
    // A one-axis table is a 2D texture of height 1 in every file: what the shader
    // library binds (`texture_2d`), so a loader that follows the file's header binds it.
    let texture = Texture {
        name: name.to_string(),
        dimension: naxes.max(2) as u8,
        width,
        height,
        depth,
        layers,
        channels: per_texel as u32,
        data,
    };
    texture.validate()?;
    Ok(Grid {
        axes,
        channels,
        texture,
    })
}

/// Largest `--scale` (16× the nodes per axis; API limits bound it further).
pub const MAX_SCALE: f64 = 16.0;

/// Refuses a `--scale` outside (0, [`MAX_SCALE`]] (NaN included).
pub fn check_scale(scale: f64) -> Result<(), String> {
    if scale > 0.0 && scale <= MAX_SCALE {
        Ok(())
    } else {
        Err(format!("--scale {scale}: must lie in (0, {MAX_SCALE}]"))
    }
}

/// The table's axes and stored values (log channels as ln), at `scale` × the nodes.
fn resample(table: &Table, scale: f64) -> Result<(Vec<Axis>, Vec<f64>), String> {
    let meta = table.meta();
    if scale == 1.0 {
        return Ok((meta.axes.clone(), table.values().iter().map(|&v| v as f64).collect()));
    }
    let axes: Vec<Axis> = meta
        .axes
        .iter()
        .map(|a| Axis {
            count: (((a.count - 1) as f64 * scale).round() as u32).max(1) + 1,
            ..a.clone()
        })
        .collect();
    let nch = meta.channels.len();
    // Every node in C order (the last axis fastest).
    let total: usize = axes.iter().map(|a| a.count as usize).product();
    let nodes: Vec<Vec<f64>> = (0..total)
        .map(|mut flat| {
            let mut x = vec![0.0; axes.len()];
            for (d, a) in axes.iter().enumerate().rev() {
                x[d] = a.node((flat % a.count as usize) as u32);
                flat /= a.count as usize;
            }
            x
        })
        .collect();
    let mut values = Vec::with_capacity(nodes.len() * nch);
    let mut out = vec![0.0; nch];
    for x in &nodes {
        // A node may fall an ulp outside the range through the mapping's round trip.
        let x: Vec<f64> = x.iter().zip(&axes).map(|(v, a)| v.clamp(a.lo, a.hi)).collect();
        table.interpolate(&x, &mut out).map_err(|e| e.to_string())?;
        for (v, ch) in out.iter().zip(&meta.channels) {
            values.push(if ch.encoding == Encoding::Log { v.ln() } else { *v });
        }
    }
    Ok((axes, values))
}

/// Degree of the 1D f16 trend. Quintic, not cubic: the cubic left shexp order 8's
/// f_6, f_7 at 1.04e-4 (target 1e-4) in f16; the quintic gives 5.2e-5 and lowers
/// every other 1D family's f16 error too (its f32 Horner evaluation is part of what
/// `check --export` measures).
const TREND_DEGREE: usize = 5;

/// Least-squares polynomial of degree [`TREND_DEGREE`] in t = i/(n − 1) through the
/// values (no trend when too few). Any trend is exact here — the texels store the
/// residual from it.
fn trend_fit(v: &[f64]) -> Vec<f64> {
    let n = v.len();
    let t: Vec<f64> = (0..n).map(|i| i as f64 / (n.max(2) - 1) as f64).collect();
    crate::eigen::polyfit(&t, v, TREND_DEGREE).unwrap_or_default()
}

/// c0 + c1 t + … (0 for no trend), in f64.
fn eval_trend(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * t + k)
}

/// The same in f32, as a shader evaluates it.
fn eval_trend32(c: &[f64], t: f32) -> f32 {
    c.iter().rev().fold(0.0f32, |acc, &k| acc * t + k as f32)
}

/// How an emulated hardware filter rounds its sub-texel weights to multiples of 1/256:
/// to nearest (the emulation's rule, and what NVIDIA's unit did on power-of-two axes),
/// or each axis one way. A device's unit may round either way: on a 1000-texel axis
/// NVIDIA's (H200, driver 580) read 274 of 4096 probed weights one step below nearest;
/// gpu-check holds a device to the span of nearest and every corner
/// ([`crate::export::gpu_check::Context::envelope`]: multilinear filtering takes its
/// extremes over the box of weights at its corners).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WeightRounding {
    /// To the nearest multiple of 1/256.
    #[default]
    Nearest,
    /// Axis k (slowest first) a step past up when bit k is set, else a step past
    /// down (the weight may leave [0, 1]: the neighbouring interval's value, which a
    /// coordinate quantized across a texel edge reads); the filtered texel
    /// then moved by this many binary16 ulps (f16 textures: a unit may filter them
    /// at f16 precision, as D3D's rules allow; 0 for f32).
    Corner(u8, i8),
}

impl WeightRounding {
    /// The corners of `axes` axes; for f16 textures each with the filtered texel
    /// moved 2 f16 ulps down and up.
    pub fn corners(axes: usize, f16: bool) -> impl Iterator<Item = WeightRounding> {
        let ulps: &'static [i8] = if f16 { &[-2, 2] } else { &[0] };
        (0..1u8 << axes).flat_map(move |c| ulps.iter().map(move |&u| WeightRounding::Corner(c, u)))
    }

    /// `v` (a filtered texel) moved by this variant's f16 ulps.
    fn nudge(self, v: f32) -> f32 {
        match self {
            WeightRounding::Corner(_, u) if u != 0 => {
                let e = v.abs().max(6.103_515_6e-5).log2().floor();
                v + f32::from(u) * (e - 10.0).exp2()
            }
            _ => v,
        }
    }
}

/// The sampler a shader runs on a texture read back from a file: `sample` gives the
/// unpacked channel values (exp applied to log channels) at axis values `x` (one per
/// axis, slowest first), in f32 arithmetic.
#[derive(Debug, Clone)]
pub struct Sampler {
    /// Axes, slowest first.
    pub axes: Vec<TexAxis>,
    /// Channel packing.
    pub channels: Vec<Channel>,
    /// The texels as read back (f16 widened exactly).
    pub texture: Texture,
    /// Filter.
    pub filter: Filter,
    /// The hardware filter's weight rounding (ignored by manual filtering).
    pub rounding: WeightRounding,
}

impl Sampler {
    /// Corner index and weight of the upper neighbour along axis `k` (slowest first).
    fn split(&self, k: usize, x: f32) -> (usize, f32) {
        let axis = &self.axes[k];
        let n = axis.axis.count as usize;
        let s = axis.texel_coordinate(x);
        match self.filter {
            Filter::Manual => {
                let s = s.clamp(0.0, (n - 1) as f32);
                let i = (s.floor() as usize).min(n - 2);
                (i, s - i as f32)
            }
            Filter::Hardware => {
                // The shader passes u = (s + 0.5)/n; the unit recovers t = u·n − 0.5,
                // clamps to the edge texels, and weights with 8 fractional bits.
                let u = (s + 0.5) / n as f32;
                let t = (u * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
                let i = (t.floor() as usize).min(n - 2);
                let steps = (t - i as f32) * HARDWARE_WEIGHT_STEPS;
                let w = match self.rounding {
                    WeightRounding::Nearest => steps.round(),
                    // One step past floor and ceil: NVIDIA's unit quantizes the
                    // coordinate before weighting, which moved probed weights a step
                    // below nearest, and across a texel edge that is one below floor.
                    WeightRounding::Corner(bits, _) if bits >> k & 1 == 1 => steps.ceil() + 1.0,
                    WeightRounding::Corner(..) => steps.floor() - 1.0,
                } / HARDWARE_WEIGHT_STEPS;
                (i, w)
            }
        }
    }

    /// A filtered texel as the hardware variant [`Sampler::rounding`] moves it.
    fn nudge(&self, v: f32) -> f32 {
        match self.filter {
            Filter::Hardware => self.rounding.nudge(v),
            Filter::Manual => v,
        }
    }

    /// The channel values at `x` (axis values, slowest first), unpacked, in f32.
    pub fn sample(&self, x: &[f32]) -> Vec<f32> {
        let t = &self.texture;
        let pt = t.channels as usize;
        let texels = (t.width * t.height * t.depth) as usize;
        let fetch =
            |flat: usize, ch: &Channel| t.data[(ch.layer as usize * texels + flat) * pt + ch.component as usize];
        let mut out = Vec::with_capacity(self.channels.len());
        match self.axes.len() {
            1 => {
                let (i, w) = self.split(0, x[0]);
                let n = self.axes[0].axis.count;
                // The trend's t: the coordinate the shader samples at, unrounded (a
                // shader cannot know the filter's rounded weight; manual: = i + w).
                let s_exact = self.axes[0].texel_coordinate(x[0]).clamp(0.0, (n - 1) as f32);
                let t = s_exact / (n - 1) as f32;
                for ch in &self.channels {
                    let v = fetch(i, ch) + w * (fetch(i + 1, ch) - fetch(i, ch));
                    out.push(unpack(ch, self.nudge(v), eval_trend32(&ch.trend, t)));
                }
            }
            2 => {
                let (j, wy) = self.split(0, x[0]);
                let (i, wx) = self.split(1, x[1]);
                let wdt = t.width as usize;
                for ch in &self.channels {
                    let f = |jj: usize, ii: usize| fetch(jj * wdt + ii, ch);
                    let lo = f(j, i) + wx * (f(j, i + 1) - f(j, i));
                    let hi = f(j + 1, i) + wx * (f(j + 1, i + 1) - f(j + 1, i));
                    out.push(unpack(ch, self.nudge(lo + wy * (hi - lo)), 0.0));
                }
            }
            _ => {
                let (k, wz) = self.split(0, x[0]);
                let (j, wy) = self.split(1, x[1]);
                let (i, wx) = self.split(2, x[2]);
                let (wdt, hgt) = (t.width as usize, t.height as usize);
                for ch in &self.channels {
                    let f = |kk: usize, jj: usize, ii: usize| fetch((kk * hgt + jj) * wdt + ii, ch);
                    let plane = |kk: usize| {
                        let lo = f(kk, j, i) + wx * (f(kk, j, i + 1) - f(kk, j, i));
                        let hi = f(kk, j + 1, i) + wx * (f(kk, j + 1, i + 1) - f(kk, j + 1, i));
                        lo + wy * (hi - lo)
                    };
                    let (p0, p1) = (plane(k), plane(k + 1));
                    out.push(unpack(ch, self.nudge(p0 + wz * (p1 - p0)), 0.0));
                }
            }
        }
        out
    }
}

impl Sampler {
    /// The channel values of the texel at integer indices `idx` (slowest first),
    /// unpacked, in f32: a shader's `texelFetch`/`textureLoad`, no filtering. For
    /// tables indexed by integers (matrices), where a sampled coordinate computed in
    /// f32 may land an ulp off the node and blend in a neighbour.
    pub fn fetch(&self, idx: &[usize]) -> Vec<f32> {
        let t = &self.texture;
        let pt = t.channels as usize;
        let texels = (t.width * t.height * t.depth) as usize;
        let flat = self.axes.iter().zip(idx).fold(0, |acc, (a, &i)| {
            acc * a.axis.count as usize + i.min(a.axis.count as usize - 1)
        });
        // The 1D f16 trend's t at that node.
        let tt = match self.axes.as_slice() {
            [a] => flat as f32 / (a.axis.count - 1).max(1) as f32,
            _ => 0.0,
        };
        self.channels
            .iter()
            .map(|ch| {
                let v = t.data[(ch.layer as usize * texels + flat) * pt + ch.component as usize];
                unpack(ch, v, eval_trend32(&ch.trend, tt))
            })
            .collect()
    }
}

/// trend + offset + scale · texel, the compression's inverse, then exp for log
/// channels (f32, as the shader).
fn unpack(ch: &Channel, texel: f32, trend: f32) -> f32 {
    let v = if ch.offset == 0.0 && ch.scale == 1.0 && ch.trend.is_empty() {
        texel
    } else {
        trend + ch.offset as f32 + ch.scale as f32 * texel
    };
    let v = if ch.compression > 0.0 {
        v.signum() * ch.compression as f32 * v.abs().exp_m1()
    } else {
        v
    };
    if ch.log {
        v.exp()
    } else {
        v
    }
}
