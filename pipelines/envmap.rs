//! Environment maps: an equirectangular HDR image (OpenEXR, half or float RGB; Radiance
//! `.hdr`) as the distant light, its fit by RGB spherical Gaussians (`lobefit
//! fit-env`), and the measures the fit is held to against spherical harmonics of the
//! same map.
//!
//! **The convention**, used everywhere a map is read: z up; row 0 at the zenith, row
//! `H − 1` at the nadir; column u at azimuth φ = 2π(u + ½)/W from +x towards +y; each
//! texel's radiance constant over its solid angle, ΔΩ = (2π/W)(cos θ_v − cos θ_{v+1})
//! with θ_v = π v/H (exact, so the texels' solid angles sum to 4π).
//!
//! **Negative texels** (resampling ringing around a sun in the public maps) are set to
//! 0 per channel, and the energy so removed (its share of the map's absolute energy) is
//! reported: radiance is never negative.
//!
//! **The fit** ([`fit`]): K SGs with RGB amplitudes sharing each lobe's axis and
//! sharpness, amplitudes ≥ 0.
//! 1. A **sun** — a compact region holding a large share of the energy — becomes its own
//!    SG, energy-matched: its axis the region's energy-weighted mean direction, its
//!    sharpness from the region's spread (E[1 − μ·ω] = 1/λ for an SG of λ ≫ 1), each
//!    channel's amplitude so that the SG's integral is the region's energy. It is kept
//!    whatever its sharpness: the sun is the shadow.
//! 2. The rest of the map (the sun's texels replaced by their surroundings' mean) is
//!    box-filtered to [`FIT_WIDTH`] × [`FIT_WIDTH`]/2 (each coarse texel the
//!    solid-angle-weighted mean of the fine ones): its high frequencies, which K lobes
//!    cannot hold, are left out of what they are fitted to.
//! 3. A greedy start: each lobe at the residual's brightest texel, then the lobe
//!    subtracted.
//! 4. Levenberg–Marquardt on every lobe's axis (two angles), log-sharpness and three
//!    amplitudes against the filtered map, residuals weighted by √ΔΩ (radiance L2 over
//!    the sphere); amplitudes held ≥ 0.
//! 5. Energy preserved: each channel's lobes scaled so that their integrals sum to the
//!    residual map's energy in that channel.

use std::path::Path;

use lobefit_tables::glam::DVec3;
use lobefit_tables::Sg;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Longest map file read (bytes).
pub const MAX_MAP_BYTES: u64 = 256 << 20;
/// Most texels a map may hold.
pub const MAX_MAP_TEXELS: usize = 1 << 24;
/// Width of the filtered map the non-sun lobes are fitted to.
pub const FIT_WIDTH: usize = 64;
/// Most Levenberg–Marquardt iterations.
pub const LM_ITERATIONS: usize = 150;
/// Most lobes a fit may ask for.
pub const MAX_FIT_SGS: usize = 64;
/// Sharpness bounds of a fitted lobe (the sun's upper bound is [`MAX_SUN_SHARPNESS`]).
pub const SHARPNESS_RANGE: (f64, f64) = (0.1, 2000.0);
/// Largest sharpness a sun SG is given (a sun of 0.5° is about 5e4).
pub const MAX_SUN_SHARPNESS: f64 = 1e5;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// An equirectangular environment map in linear RGB radiance.
#[derive(Debug, Clone)]
pub struct EnvMap {
    /// Columns.
    pub width: usize,
    /// Rows (zenith first).
    pub height: usize,
    /// Row-major texels.
    pub rgb: Vec<[f64; 3]>,
    /// Share of the map's absolute energy (solid-angle weighted, summed over the
    /// channels) its negative texels held before they were set to 0.
    pub negative: f64,
}

impl EnvMap {
    /// From row-major texels; negative values set to 0 (and measured), non-finite
    /// ones refused.
    pub fn new(width: usize, height: usize, mut rgb: Vec<[f64; 3]>) -> Result<EnvMap, String> {
        if width < 2 || height < 1 || width.checked_mul(height) != Some(rgb.len()) || rgb.len() > MAX_MAP_TEXELS {
            return Err(format!(
                "a map of {width} × {height} texels ({} given; at most {MAX_MAP_TEXELS}, width ≥ 2)",
                rgb.len()
            ));
        }
        if let Some(k) = rgb.iter().position(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(format!(
                "texel ({}, {}) is {:?}: a map's radiance must be finite",
                k % width,
                k / width,
                rgb[k]
            ));
        }
        let mut map = EnvMap {
            width,
            height,
            rgb: Vec::new(),
            negative: 0.0,
        };
        let (mut neg, mut all) = (0.0, 0.0);
        for (k, c) in rgb.iter_mut().enumerate() {
            let dw = map.solid_angle(k / width);
            for v in c.iter_mut() {
                all += v.abs() * dw;
                if *v < 0.0 {
                    neg += -*v * dw;
                    *v = 0.0;
                }
            }
        }
        map.rgb = rgb;
        map.negative = if all > 0.0 { neg / all } else { 0.0 };
        Ok(map)
    }

    /// Reads a map by its extension: `.exr` (the first layer's R, G and B channels,
    /// half or float) or `.hdr` (Radiance RGBE); a regular file of at most
    /// [`MAX_MAP_BYTES`]. Errors name the file.
    pub fn load(path: &Path) -> Result<EnvMap, String> {
        let bytes =
            lobefit_core::io::read_bytes(path, MAX_MAP_BYTES, "MAX_MAP_BYTES").map_err(|e| format!("map: {e}"))?;
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let err = |e: String| format!("map {}: {e}", path.display());
        match ext.as_deref() {
            Some("exr") => EnvMap::from_exr_bytes(&bytes).map_err(err),
            Some("hdr") => EnvMap::from_hdr_bytes(&bytes).map_err(err),
            _ => Err(err("not a map: .exr or .hdr".into())),
        }
    }

    /// An OpenEXR file's first layer: its R, G and B channels (any sample type).
    pub fn from_exr_bytes(bytes: &[u8]) -> Result<EnvMap, String> {
        use exr::prelude::*;
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(bytes))
            .map_err(|e| format!("not a readable OpenEXR file: {e}"))?;
        let layer = &image.layer_data;
        let (w, h) = (layer.size.width(), layer.size.height());
        if w.checked_mul(h).is_none_or(|n| n > MAX_MAP_TEXELS) {
            return Err(format!("{w} × {h} texels, more than {MAX_MAP_TEXELS} (MAX_MAP_TEXELS)"));
        }
        let channel = |name: &str| -> std::result::Result<Vec<f64>, String> {
            let c = layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name.eq(name))
                .ok_or_else(|| format!("no {name} channel (an environment map is RGB)"))?;
            Ok(c.sample_data.values_as_f32().map(f64::from).collect())
        };
        let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
        EnvMap::new(w, h, (0..w * h).map(|k| [r[k], g[k], b[k]]).collect())
    }

    /// A Radiance `.hdr` (RGBE) file, through the `image` crate's decoder.
    pub fn from_hdr_bytes(bytes: &[u8]) -> Result<EnvMap, String> {
        let d = image::codecs::hdr::HdrDecoder::new(std::io::Cursor::new(bytes))
            .map_err(|e| format!("not a readable Radiance HDR file: {e}"))?;
        let m = d.metadata();
        let (w, h) = (m.width as usize, m.height as usize);
        if w.checked_mul(h).is_none_or(|n| n > MAX_MAP_TEXELS) {
            return Err(format!("{w} × {h} texels, more than {MAX_MAP_TEXELS} (MAX_MAP_TEXELS)"));
        }
        let px = d
            .read_image_hdr()
            .map_err(|e| format!("not a readable Radiance HDR file: {e}"))?;
        EnvMap::new(w, h, px.into_iter().map(|p| p.0.map(f64::from)).collect())
    }

    /// The solid angle of a texel of row `v` (sr).
    pub fn solid_angle(&self, v: usize) -> f64 {
        let (a, b) = (
            std::f64::consts::PI * v as f64 / self.height as f64,
            std::f64::consts::PI * (v + 1) as f64 / self.height as f64,
        );
        std::f64::consts::TAU / self.width as f64 * (a.cos() - b.cos())
    }

    /// The direction of texel (`u`, `v`)'s centre.
    pub fn direction(&self, u: usize, v: usize) -> DVec3 {
        let theta = std::f64::consts::PI * (v as f64 + 0.5) / self.height as f64;
        let phi = std::f64::consts::TAU * (u as f64 + 0.5) / self.width as f64;
        DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    /// The texel holding direction `d` (unit): (u, v).
    pub fn texel_of(&self, d: DVec3) -> (usize, usize) {
        let theta = d.z.clamp(-1.0, 1.0).acos();
        let phi = d.y.atan2(d.x).rem_euclid(std::f64::consts::TAU);
        let v = ((theta / std::f64::consts::PI * self.height as f64) as usize).min(self.height - 1);
        let u = ((phi / std::f64::consts::TAU * self.width as f64) as usize).min(self.width - 1);
        (u, v)
    }

    /// The radiance towards `d` (unit): its texel's.
    pub fn radiance(&self, d: DVec3) -> [f64; 3] {
        let (u, v) = self.texel_of(d);
        self.rgb[v * self.width + u]
    }

    /// (direction, solid angle, radiance) of every texel, row-major.
    pub fn texels(&self) -> impl Iterator<Item = (DVec3, f64, [f64; 3])> + '_ {
        (0..self.height).flat_map(move |v| {
            let dw = self.solid_angle(v);
            (0..self.width).map(move |u| (self.direction(u, v), dw, self.rgb[v * self.width + u]))
        })
    }

    /// ∫ L dω per channel (W·sr⁻¹·m⁻²·sr: the map's total radiant energy per area).
    pub fn energy(&self) -> [f64; 3] {
        let mut e = [0.0; 3];
        for (_, dw, c) in self.texels() {
            for k in 0..3 {
                e[k] += c[k] * dw;
            }
        }
        e
    }

    /// The map box-filtered to `width` × `width`/2: each coarse texel the
    /// solid-angle-weighted mean of the fine texels whose centres fall in it (energy
    /// preserved where the grids nest).
    pub fn filtered(&self, width: usize) -> EnvMap {
        let (w, h) = (width.max(2), (width / 2).max(1));
        let mut acc = vec![([0.0; 3], 0.0); w * h];
        for v in 0..self.height {
            let dw = self.solid_angle(v);
            let cv = v * h / self.height;
            for u in 0..self.width {
                let cu = u * w / self.width;
                let a = &mut acc[cv * w + cu];
                for k in 0..3 {
                    a.0[k] += self.rgb[v * self.width + u][k] * dw;
                }
                a.1 += dw;
            }
        }
        EnvMap {
            width: w,
            height: h,
            rgb: acc
                .into_iter()
                .map(|(c, dw)| if dw > 0.0 { c.map(|x| x / dw) } else { [0.0; 3] })
                .collect(),
            negative: self.negative,
        }
    }
}

/// A map as a scene's distant light (`"environment": {"map": FILE, "sgs": K}`): the
/// map itself, which the references integrate (its luminance, texel by texel), the K
/// lobes fitted to it, which the pipelines shade, and a sampler of directions in
/// proportion to the map's luminance (the references' light strategy).
#[derive(Debug)]
pub struct LightMap {
    /// The file, as the scene names it.
    pub file: String,
    /// The map (linear RGB, negative texels cleared).
    pub map: EnvMap,
    /// The fitted lobes ([`fit`]), the sun's first if it has one.
    pub lobes: Vec<RgbSg>,
    /// Each texel's luminance.
    lum: Vec<f64>,
    /// Running sums of luminance × solid angle over the row-major texels.
    cdf: Vec<f64>,
}

impl LightMap {
    /// The light of `map` (named `file`) with the lobes `lobes` fitted to it; a black
    /// map is refused (nothing lights the scene).
    pub fn new(file: String, map: EnvMap, lobes: Vec<RgbSg>) -> Result<LightMap, String> {
        let lum: Vec<f64> = map.rgb.iter().map(|&c| luminance(c).max(0.0)).collect();
        let mut cdf = Vec::with_capacity(lum.len());
        let mut acc = 0.0;
        for (k, l) in lum.iter().enumerate() {
            acc += l * map.solid_angle(k / map.width);
            cdf.push(acc);
        }
        if !(acc > 0.0 && acc.is_finite()) {
            return Err(format!(
                "map {file}: its luminance integrates to {acc}: nothing to light a scene"
            ));
        }
        Ok(LightMap {
            file,
            map,
            lobes,
            lum,
            cdf,
        })
    }

    /// The map's luminance towards `d` (unit): its texel's (the texel constant over its
    /// solid angle).
    pub fn luminance(&self, d: DVec3) -> f64 {
        let (u, v) = self.map.texel_of(d);
        self.lum[v * self.map.width + u]
    }

    /// The map's channel `c` (0 red, 1 green, 2 blue) towards `d` (unit).
    pub fn channel(&self, d: DVec3, c: usize) -> f64 {
        self.map.radiance(d)[c]
    }

    /// The fitted lobes with channel `c`'s amplitudes (what the pipelines shade for
    /// that channel; the scene's `environment` holds their luminance).
    pub fn channel_sgs(&self, c: usize) -> Vec<Sg> {
        self.lobes
            .iter()
            .map(|l| Sg {
                axis: DVec3::from(l.axis).normalize(),
                sharpness: l.sharpness,
                amplitude: l.amplitude[c],
            })
            .collect()
    }

    /// ∫ luminance dω over the sphere.
    pub fn total(&self) -> f64 {
        *self.cdf.last().expect("a map has texels")
    }

    /// A direction drawn with density [`LightMap::pdf`] from three uniforms in [0, 1):
    /// a texel in proportion to its luminance × solid angle (`u0`), then uniformly
    /// within its solid angle (uniform in cos θ between the row's bounds, `u1`, and in
    /// φ across the column, `u2`).
    pub fn sample(&self, u0: f64, u1: f64, u2: f64) -> DVec3 {
        let x = u0 * self.total();
        let k = self.cdf.partition_point(|&c| c <= x).min(self.cdf.len() - 1);
        let (w, h) = (self.map.width as f64, self.map.height as f64);
        let (u, v) = ((k % self.map.width) as f64, (k / self.map.width) as f64);
        let (c0, c1) = (
            (std::f64::consts::PI * v / h).cos(),
            (std::f64::consts::PI * (v + 1.0) / h).cos(),
        );
        let c = (c0 + (c1 - c0) * u1).clamp(-1.0, 1.0);
        let s = (1.0 - c * c).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * (u + u2) / w;
        DVec3::new(s * phi.cos(), s * phi.sin(), c)
    }

    /// Each texel's luminance, row-major (what [`LightMap::luminance`] reads).
    pub fn texel_luminance(&self) -> &[f64] {
        &self.lum
    }

    /// Running sums of luminance × solid angle over the row-major texels, the last
    /// [`LightMap::total`] (what [`LightMap::sample`] searches).
    pub fn running_sums(&self) -> &[f64] {
        &self.cdf
    }

    /// The density (1/sr) of [`LightMap::sample`] at `d` (unit): the texel's luminance
    /// over the map's integral.
    pub fn pdf(&self, d: DVec3) -> f64 {
        self.luminance(d) / self.total()
    }
}

/// An SG with RGB amplitudes: `amplitude` × exp(λ(μ·ω − 1)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RgbSg {
    /// Unit axis μ.
    pub axis: [f64; 3],
    /// Sharpness λ.
    pub sharpness: f64,
    /// Linear RGB amplitudes (≥ 0).
    pub amplitude: [f64; 3],
}

impl RgbSg {
    /// Its value towards `d` (unit), per channel.
    pub fn value(&self, d: DVec3) -> [f64; 3] {
        let g = (self.sharpness * (DVec3::from(self.axis).dot(d) - 1.0)).exp();
        self.amplitude.map(|a| a * g)
    }

    /// ∫ over the sphere, per channel: amplitude × 2π/λ (1 − e^{−2λ}).
    pub fn integral(&self) -> [f64; 3] {
        let s = std::f64::consts::TAU / self.sharpness * -(-2.0 * self.sharpness).exp_m1();
        self.amplitude.map(|a| a * s)
    }

    /// The unit-amplitude scalar SG of channel-independent shape (the ISG library's).
    pub fn shape(&self) -> Sg {
        Sg {
            axis: DVec3::from(self.axis),
            sharpness: self.sharpness,
            amplitude: 1.0,
        }
    }
}

/// A fit's result: the lobes (the sun's first, if any) and what it did.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The lobes.
    pub sgs: Vec<RgbSg>,
    /// Whether the first lobe is a sun, extracted.
    pub sun: bool,
    /// The LM iterations run.
    pub iterations: usize,
    /// Relative radiance L2 on the filtered map at the end (the fit's own objective).
    pub objective: f64,
}

/// Fits `k` RGB SGs to `map` (module doc).
pub fn fit(map: &EnvMap, k: usize) -> Result<Fitted, String> {
    if !(1..=MAX_FIT_SGS).contains(&k) {
        return Err(format!("{k} SGs: a fit takes 1..={MAX_FIT_SGS}"));
    }
    let total = map.energy();
    if luminance(total) <= 0.0 {
        return Err("the map is black: nothing to fit".into());
    }
    let (sun, rest) = extract_sun(map);
    let mut sgs: Vec<RgbSg> = sun.iter().copied().collect();
    let n = k - sgs.len();
    let coarse = rest.filtered(FIT_WIDTH.min(rest.width));
    let (mut lobes, iterations, objective) = if n > 0 {
        let start = greedy(&coarse, n);
        levenberg_marquardt(&coarse, start)
    } else {
        (Vec::new(), 0, f64::NAN)
    };
    // Energy: each channel's non-sun lobes scaled to the residual map's energy.
    let want = rest.energy();
    let mut got = [0.0; 3];
    for l in &lobes {
        let i = l.integral();
        for c in 0..3 {
            got[c] += i[c];
        }
    }
    for l in &mut lobes {
        for c in 0..3 {
            if got[c] > 0.0 {
                l.amplitude[c] *= want[c] / got[c];
            }
        }
    }
    sgs.extend(lobes);
    Ok(Fitted {
        sun: sun.is_some(),
        sgs,
        iterations,
        objective,
    })
}

/// A sun: the brightest texel's region (texels within 0.15 rad of it brighter than 0.5 %
/// of its luminance), when it holds at least 5 % of the map's energy, as its
/// energy-matched SG; and the map with the region's texels replaced by the mean of a
/// ring around it. `(None, map)` without one.
pub fn extract_sun(map: &EnvMap) -> (Option<RgbSg>, EnvMap) {
    let lum: Vec<f64> = map.rgb.iter().map(|c| luminance(*c)).collect();
    let Some(peak) = (0..lum.len()).max_by(|&a, &b| lum[a].total_cmp(&lum[b])) else {
        return (None, map.clone());
    };
    let p = map.direction(peak % map.width, peak / map.width);
    let (near, ring) = (0.15f64.cos(), 0.25f64.cos());
    let mut region = Vec::new();
    let (mut ring_sum, mut ring_w) = ([0.0; 3], 0.0);
    for v in 0..map.height {
        let dw = map.solid_angle(v);
        for u in 0..map.width {
            let i = v * map.width + u;
            let c = map.direction(u, v).dot(p);
            if c >= near && lum[i] > 0.005 * lum[peak] {
                region.push(i);
            } else if c >= ring {
                for (r, x) in ring_sum.iter_mut().zip(map.rgb[i]) {
                    *r += x * dw;
                }
                ring_w += dw;
            }
        }
    }
    let background = if ring_w > 0.0 {
        ring_sum.map(|x| x / ring_w)
    } else {
        [0.0; 3]
    };
    // The region's energy above the background, and its direction moments.
    let (mut e, mut mean) = ([0.0; 3], DVec3::ZERO);
    for &i in &region {
        let dw = map.solid_angle(i / map.width);
        let d = map.direction(i % map.width, i / map.width);
        for q in 0..3 {
            e[q] += (map.rgb[i][q] - background[q]).max(0.0) * dw;
        }
        mean += d * luminance(map.rgb[i].map(|x| x.max(0.0))) * dw;
    }
    if luminance(e) < 0.05 * luminance(map.energy()) || mean.length() == 0.0 {
        return (None, map.clone());
    }
    let axis = mean.normalize();
    let (mut spread, mut w) = (0.0, 0.0);
    for &i in &region {
        let dw = map.solid_angle(i / map.width);
        let y = (luminance(map.rgb[i]) - luminance(background)).max(0.0) * dw;
        spread += (1.0 - map.direction(i % map.width, i / map.width).dot(axis)) * y;
        w += y;
    }
    // E[1 − μ·ω] = 1/λ for a sharp SG; a region within one texel gives no spread: the
    // texel's own width stands for it.
    let texel = std::f64::consts::PI / map.height as f64;
    let lambda = (w / spread.max(w * 0.25 * texel * texel)).min(MAX_SUN_SHARPNESS);
    let unit = std::f64::consts::TAU / lambda * -(-2.0 * lambda).exp_m1();
    let sun = RgbSg {
        axis: axis.to_array(),
        sharpness: lambda,
        amplitude: e.map(|x| x / unit),
    };
    let mut rest = map.clone();
    for &i in &region {
        rest.rgb[i] = background;
    }
    (Some(sun), rest)
}

/// `n` lobes at the residual's brightest texels in turn, each subtracted (its
/// sharpness from the coarse texel's width, its amplitude the texel's radiance).
pub(crate) fn greedy(coarse: &EnvMap, n: usize) -> Vec<RgbSg> {
    let mut residual = coarse.rgb.clone();
    let mut out = Vec::with_capacity(n);
    let lambda = (coarse.width as f64 / 8.0).max(1.0);
    for _ in 0..n {
        let Some(i) = (0..residual.len()).max_by(|&a, &b| luminance(residual[a]).total_cmp(&luminance(residual[b])))
        else {
            break;
        };
        let d = coarse.direction(i % coarse.width, i / coarse.width);
        let lobe = RgbSg {
            axis: d.to_array(),
            sharpness: lambda,
            amplitude: residual[i].map(|x| x.max(0.0)),
        };
        for (j, r) in residual.iter_mut().enumerate() {
            let g = lobe.value(coarse.direction(j % coarse.width, j / coarse.width));
            for c in 0..3 {
                r[c] -= g[c];
            }
        }
        out.push(lobe);
    }
    out
}

/// Parameters of one lobe in the LM: θ, φ of the axis, ln λ, three amplitudes.
fn params(l: &RgbSg) -> [f64; 6] {
    let a = DVec3::from(l.axis);
    [
        a.z.clamp(-1.0, 1.0).acos(),
        a.y.atan2(a.x),
        l.sharpness.ln(),
        l.amplitude[0],
        l.amplitude[1],
        l.amplitude[2],
    ]
}

fn lobe(p: &[f64]) -> RgbSg {
    let (st, ct) = p[0].sin_cos();
    let (sp, cp) = p[1].sin_cos();
    RgbSg {
        axis: [st * cp, st * sp, ct],
        sharpness: p[2].exp().clamp(SHARPNESS_RANGE.0, SHARPNESS_RANGE.1),
        amplitude: [p[3].max(0.0), p[4].max(0.0), p[5].max(0.0)],
    }
}

/// Levenberg–Marquardt on the lobes against `coarse` (residuals √ΔΩ (Σ lobes − L) per
/// texel and channel): (lobes, iterations, relative L2 at the end).
pub(crate) fn levenberg_marquardt(coarse: &EnvMap, start: Vec<RgbSg>) -> (Vec<RgbSg>, usize, f64) {
    let n = start.len();
    let np = 6 * n;
    let texels: Vec<(DVec3, f64, [f64; 3])> = coarse.texels().map(|(d, dw, c)| (d, dw.sqrt(), c)).collect();
    let norm: f64 = texels
        .iter()
        .map(|(_, s, c)| c.iter().map(|v| (v * s).powi(2)).sum::<f64>())
        .sum();
    let mut x: Vec<f64> = start.iter().flat_map(params).collect();
    let cost = |x: &[f64]| -> f64 {
        let lobes: Vec<RgbSg> = x.chunks_exact(6).map(lobe).collect();
        texels
            .par_iter()
            .map(|(d, s, c)| {
                let mut f = [0.0; 3];
                for l in &lobes {
                    let g = l.value(*d);
                    for q in 0..3 {
                        f[q] += g[q];
                    }
                }
                (0..3).map(|q| ((f[q] - c[q]) * s).powi(2)).sum::<f64>()
            })
            .sum()
    };
    let mut current = cost(&x);
    let mut mu = 1e-3;
    let mut it = 0;
    while it < LM_ITERATIONS {
        it += 1;
        // J^T J and J^T r, accumulated per texel (rows for the three channels).
        let lobes: Vec<RgbSg> = x.chunks_exact(6).map(lobe).collect();
        let (jtj, jtr) = texels
            .par_chunks(256)
            .map(|chunk| {
                let mut jtj = vec![0.0; np * np];
                let mut jtr = vec![0.0; np];
                let mut rows = vec![[0.0; 3]; np];
                let mut nz = Vec::with_capacity(np);
                for (d, s, c) in chunk {
                    let mut f = [0.0; 3];
                    nz.clear();
                    for (k, l) in lobes.iter().enumerate() {
                        let p = &x[6 * k..6 * k + 6];
                        let mu_ = DVec3::from(l.axis);
                        let cosv = mu_.dot(*d);
                        let g = (l.sharpness * (cosv - 1.0)).exp();
                        if g < 1e-12 {
                            continue;
                        }
                        // ∂μ/∂θ, ∂μ/∂φ.
                        let (st, ct) = p[0].sin_cos();
                        let (sp, cp) = p[1].sin_cos();
                        let dth = DVec3::new(ct * cp, ct * sp, -st);
                        let dph = DVec3::new(-st * sp, st * cp, 0.0);
                        let lam = l.sharpness;
                        let a = l.amplitude;
                        for q in 0..3 {
                            f[q] += a[q] * g;
                            // ∂(a g)/∂θ = a g λ (∂μ/∂θ · d); ∂/∂ln λ = a g λ (cos − 1).
                            rows[6 * k][q] = a[q] * g * lam * dth.dot(*d) * s;
                            rows[6 * k + 1][q] = a[q] * g * lam * dph.dot(*d) * s;
                            rows[6 * k + 2][q] = a[q] * g * lam * (cosv - 1.0) * s;
                        }
                        for q in 0..3 {
                            rows[6 * k + 3 + q] = [0.0; 3];
                            rows[6 * k + 3 + q][q] = g * s;
                        }
                        nz.extend(6 * k..6 * k + 6);
                    }
                    let r = [(f[0] - c[0]) * s, (f[1] - c[1]) * s, (f[2] - c[2]) * s];
                    for (ai, &i) in nz.iter().enumerate() {
                        for q in 0..3 {
                            jtr[i] += rows[i][q] * r[q];
                        }
                        for &j in &nz[ai..] {
                            let v = rows[i][0] * rows[j][0] + rows[i][1] * rows[j][1] + rows[i][2] * rows[j][2];
                            jtj[i * np + j] += v;
                        }
                    }
                }
                (jtj, jtr)
            })
            .reduce(
                || (vec![0.0; np * np], vec![0.0; np]),
                |mut a, b| {
                    for (x, y) in a.0.iter_mut().zip(&b.0) {
                        *x += y;
                    }
                    for (x, y) in a.1.iter_mut().zip(&b.1) {
                        *x += y;
                    }
                    a
                },
            );
        // Symmetric from the upper triangle.
        let mut a = jtj;
        for i in 0..np {
            for j in 0..i {
                a[i * np + j] = a[j * np + i];
            }
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut m = a.clone();
            for i in 0..np {
                m[i * np + i] += mu * m[i * np + i].max(1e-12);
            }
            let Some(step) = cholesky_solve(&m, &jtr, np) else {
                mu *= 10.0;
                continue;
            };
            let trial: Vec<f64> = x.iter().zip(&step).map(|(a, b)| a - b).collect();
            let c = cost(&trial);
            if c < current {
                x = trial;
                // Amplitudes stay ≥ 0 and the sharpness in range.
                for p in x.chunks_exact_mut(6) {
                    p[2] = p[2].clamp(SHARPNESS_RANGE.0.ln(), SHARPNESS_RANGE.1.ln());
                    for a in &mut p[3..] {
                        *a = a.max(0.0);
                    }
                }
                current = c;
                mu = (mu / 3.0).max(1e-9);
                improved = true;
                break;
            }
            mu *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let lobes = x.chunks_exact(6).map(lobe).collect();
    (lobes, it, (current / norm.max(f64::MIN_POSITIVE)).sqrt())
}

/// Solves `m` x = `b` (`m` n × n, symmetric positive definite) by Cholesky; `None`
/// when `m` is not positive definite.
fn cholesky_solve(m: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = m[i * n + j];
            for k in 0..j {
                s -= l[i * n + k] * l[j * n + k];
            }
            if i == j {
                if s.is_nan() || s <= 0.0 {
                    return None;
                }
                l[i * n + i] = s.sqrt();
            } else {
                l[i * n + j] = s / l[j * n + j];
            }
        }
    }
    let mut y = vec![0.0; n];
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * y[k];
        }
        y[i] = s / l[i * n + i];
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= l[k * n + i] * x[k];
        }
        x[i] = s / l[i * n + i];
    }
    Some(x)
}

/// How well a lobe set stands for a map: on luminance, against the map itself (its
/// texels), next to SH of orders 3 and 5 projected exactly from the same texels.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Report {
    /// Relative radiance L2 over the sphere (√(∫ (Y_fit − Y)² dω / ∫ Y² dω)): the lobes,
    /// SH order 3, SH order 5.
    pub radiance: [f64; 3],
    /// Irradiance E(n) = ∫ Y max(n·ω, 0) dω at [`NORMALS`] random normals, |E_fit −
    /// E_map| / E_map: (median, max) for the lobes (exact clamped-cosine integrals),
    /// SH 3 and SH 5 (the clamped cosine's bands, exact).
    pub irradiance: [(f64, f64); 3],
    /// Glossy: ∫ Y (n+1)/(2π) max(r·ω, 0)^n dω at [`GLOSSY_DIRECTIONS`] random
    /// directions, relative error (median, max) per Phong exponent of [`GLOSSY`]:
    /// [exponent][lobes, SH 3, SH 5], each integrated on the map's texels.
    pub glossy: Vec<[(f64, f64); 3]>,
    /// Energy per channel: the map's, the lobes'.
    pub energy: [[f64; 3]; 2],
    /// The map's negative texels' share of its absolute energy (set to 0).
    pub negative: f64,
}

/// Random normals of the irradiance measure.
pub const NORMALS: usize = 1000;
/// Random directions of the glossy measure.
pub const GLOSSY_DIRECTIONS: usize = 200;
/// Phong exponents of the glossy measure.
pub const GLOSSY: [f64; 3] = [10.0, 100.0, 1000.0];

/// Luminance SH of `order` projected from the map's texels (exact per texel).
pub fn project_sh(map: &EnvMap, order: usize) -> Vec<f64> {
    let mut out = vec![0.0; order * order];
    let mut y = vec![0.0; order * order];
    for (d, dw, c) in map.texels() {
        lobefit_tables::sh::eval_basis(order, d, &mut y).expect("orders 1..=8");
        let l = luminance(c) * dw;
        for (o, b) in out.iter_mut().zip(&y) {
            *o += l * b;
        }
    }
    out
}

fn sh_value(coeffs: &[f64], order: usize, d: DVec3) -> f64 {
    let mut y = vec![0.0; order * order];
    lobefit_tables::sh::eval_basis(order, d, &mut y).expect("orders 1..=8");
    coeffs.iter().zip(&y).map(|(a, b)| a * b).sum()
}

/// Irradiance of luminance SH `coeffs` at normal `n`: Σ_l Â_l Σ_m L_lm Y_lm(n) with the
/// clamped cosine's bands Â = π, 2π/3, π/4, 0, −π/24.
fn sh_irradiance(coeffs: &[f64], order: usize, n: DVec3) -> f64 {
    use std::f64::consts::PI;
    let a = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0, -PI / 24.0];
    let mut y = vec![0.0; order * order];
    lobefit_tables::sh::eval_basis(order, n, &mut y).expect("orders 1..=8");
    let mut e = 0.0;
    for (l, al) in a.iter().enumerate().take(order) {
        for i in l * l..(l + 1) * (l + 1) {
            e += al * coeffs[i] * y[i];
        }
    }
    e
}

/// Uniform unit vectors from `seed`.
fn random_directions(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = lobefit_core::rng::Rng::new(seed);
    (0..n)
        .map(|_| {
            let z = rng.range(-1.0, 1.0);
            let phi = rng.range(0.0, std::f64::consts::TAU);
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// (median, max) of `v`.
fn median_max(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[v.len() - 1])
}

/// Measures `sgs` against `map` ([`Report`]).
pub fn evaluate(map: &EnvMap, sgs: &[RgbSg]) -> Report {
    let texels: Vec<(DVec3, f64, f64)> = map.texels().map(|(d, dw, c)| (d, dw, luminance(c))).collect();
    let (sh3, sh5) = (project_sh(map, 3), project_sh(map, 5));
    let fit_y = |d: DVec3| sgs.iter().map(|g| luminance(g.value(d))).sum::<f64>();
    // The three approximations' luminance at every texel.
    let approx: Vec<[f64; 3]> = texels
        .par_iter()
        .map(|(d, _, _)| [fit_y(*d), sh_value(&sh3, 3, *d), sh_value(&sh5, 5, *d)])
        .collect();
    let norm: f64 = texels.iter().map(|(_, dw, y)| y * y * dw).sum();
    let radiance = [0, 1, 2].map(|k| {
        let e: f64 = texels
            .iter()
            .zip(&approx)
            .map(|((_, dw, y), a)| (a[k] - y).powi(2) * dw)
            .sum();
        (e / norm).sqrt()
    });
    let normals = random_directions(NORMALS, 0x1e2e_c0de);
    let irr: Vec<[f64; 3]> = normals
        .par_iter()
        .map(|&n| {
            let e: f64 = texels.iter().map(|(d, dw, y)| y * dw * n.dot(*d).max(0.0)).sum();
            let fit: f64 = sgs
                .iter()
                .map(|g| luminance(g.amplitude) * crate::sg::clamped_cosine_integral(&g.shape(), n))
                .sum();
            let rel = |x: f64| (x - e).abs() / e.max(f64::MIN_POSITIVE);
            [rel(fit), rel(sh_irradiance(&sh3, 3, n)), rel(sh_irradiance(&sh5, 5, n))]
        })
        .collect();
    let irradiance = [0, 1, 2].map(|k| median_max(irr.iter().map(|r| r[k]).collect()));
    let dirs = random_directions(GLOSSY_DIRECTIONS, 0x0910_5557);
    let glossy = GLOSSY
        .iter()
        .map(|&n| {
            let rows: Vec<[f64; 3]> = dirs
                .par_iter()
                .map(|&r| {
                    let (mut m, mut a) = (0.0, [0.0; 3]);
                    for ((d, dw, y), ap) in texels.iter().zip(&approx) {
                        let c = r.dot(*d);
                        if c <= 0.0 {
                            continue;
                        }
                        let w = (n + 1.0) / std::f64::consts::TAU * c.powf(n) * dw;
                        m += y * w;
                        for k in 0..3 {
                            a[k] += ap[k] * w;
                        }
                    }
                    a.map(|x| (x - m).abs() / m.max(f64::MIN_POSITIVE))
                })
                .collect();
            [0, 1, 2].map(|k| median_max(rows.iter().map(|r| r[k]).collect()))
        })
        .collect();
    let mut fe = [0.0; 3];
    for g in sgs {
        let i = g.integral();
        for q in 0..3 {
            fe[q] += i[q];
        }
    }
    Report {
        radiance,
        irradiance,
        glossy,
        energy: [map.energy(), fe],
        negative: map.negative,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The light's sampler: its density integrates to 1 over the texels, and 200 000
    /// draws fall in each texel of an uneven 8 × 4 map (one black texel, one 50×) with
    /// the frequency its luminance × solid angle says, within 5 binomial standard
    /// deviations (and never in the black texel); each draw lies in the texel drawn
    /// (its φ and cos θ ranges), which the density assumes.
    #[test]
    fn the_light_map_samples_its_density() {
        let mut rgb = vec![[0.0; 3]; 32];
        for (k, c) in rgb.iter_mut().enumerate() {
            let l = 1.0 + (k % 5) as f64;
            *c = [l, 0.5 * l, 2.0 * l];
        }
        rgb[5] = [0.0; 3];
        rgb[17] = [50.0; 3];
        let map = EnvMap::new(8, 4, rgb).unwrap();
        let light = LightMap::new("t".into(), map.clone(), Vec::new()).unwrap();
        let mass: Vec<f64> = (0..32)
            .map(|k| light.pdf(map.direction(k % 8, k / 8)) * map.solid_angle(k / 8))
            .collect();
        assert!((mass.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let n = 200_000;
        let mut rng = lobefit_core::rng::Rng::new(7);
        let mut count = [0usize; 32];
        for _ in 0..n {
            let d = light.sample(rng.uniform(), rng.uniform(), rng.uniform());
            assert!((d.length() - 1.0).abs() < 1e-12);
            let (u, v) = map.texel_of(d);
            count[v * 8 + u] += 1;
        }
        assert_eq!(count[5], 0);
        for k in 0..32 {
            let want = n as f64 * mass[k];
            let sd = (n as f64 * mass[k] * (1.0 - mass[k])).sqrt();
            assert!(
                (count[k] as f64 - want).abs() <= 5.0 * sd.max(1.0),
                "texel {k}: {} draws, {want:.0} expected",
                count[k]
            );
        }
        // A black map lights nothing: refused.
        assert!(LightMap::new("b".into(), EnvMap::new(8, 4, vec![[0.0; 3]; 32]).unwrap(), Vec::new()).is_err());
    }

    /// The convention: texel centres' directions and back, solid angles summing to 4π.
    #[test]
    fn the_convention_round_trips() {
        let m = EnvMap::new(16, 8, vec![[1.0; 3]; 128]).unwrap();
        let total: f64 = (0..8).map(|v| 16.0 * m.solid_angle(v)).sum();
        assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-12, "{total}");
        for v in 0..8 {
            for u in 0..16 {
                assert_eq!(m.texel_of(m.direction(u, v)), (u, v));
            }
        }
        // Row 0 holds the zenith, column 0 starts at +x (φ = 2π · ½/16).
        assert!(m.direction(0, 0).z > 0.9 && m.direction(0, 7).z < -0.9);
        let d = m.direction(0, 4);
        assert!((d.y.atan2(d.x) - std::f64::consts::PI / 16.0).abs() < 1e-12);
        // A constant map's energy: 4π L.
        assert!((m.energy()[1] - 4.0 * std::f64::consts::PI).abs() < 1e-12);
    }

    /// Negative texels become 0, and their share of the absolute energy is measured.
    #[test]
    fn negative_texels_are_cleared_and_counted() {
        let mut rgb = vec![[1.0, 1.0, 1.0]; 32];
        rgb[5] = [-3.0, 1.0, 1.0];
        let m = EnvMap::new(8, 4, rgb).unwrap();
        assert_eq!(m.rgb[5], [0.0, 1.0, 1.0]);
        let dw = m.solid_angle(0);
        let all: f64 = (0..4).map(|v| 8.0 * 3.0 * m.solid_angle(v)).sum::<f64>() - dw + 3.0 * dw;
        assert!((m.negative - 3.0 * dw / all).abs() < 1e-15, "{}", m.negative);
        assert!(EnvMap::new(8, 4, vec![[f64::NAN; 3]; 32]).is_err());
        assert!(EnvMap::new(8, 4, vec![[1.0; 3]; 31]).is_err());
    }

    /// A map made of three RGB SGs (rendered into its texels) is fitted by three: the
    /// irradiance against the map within 0.2 % at the median, the energy exactly the
    /// map's, each lobe's axis within 2° of the one it stands for.
    #[test]
    fn three_sgs_are_found_again() {
        let truth = [
            RgbSg {
                axis: [0.0, 0.0, 1.0],
                sharpness: 4.0,
                amplitude: [1.0, 0.9, 0.8],
            },
            RgbSg {
                axis: [0.8, 0.0, 0.6],
                sharpness: 30.0,
                amplitude: [3.0, 2.0, 1.0],
            },
            RgbSg {
                axis: [-0.6, 0.64, -0.48],
                sharpness: 12.0,
                amplitude: [0.2, 0.5, 1.5],
            },
        ];
        let (w, h) = (256, 128);
        let probe = EnvMap::new(w, h, vec![[0.0; 3]; w * h]).unwrap();
        let rgb: Vec<[f64; 3]> = (0..w * h)
            .map(|k| {
                let d = probe.direction(k % w, k / w);
                truth.iter().fold([0.0; 3], |a, g| {
                    let v = g.value(d);
                    [a[0] + v[0], a[1] + v[1], a[2] + v[2]]
                })
            })
            .collect();
        let map = EnvMap::new(w, h, rgb).unwrap();
        let f = fit(&map, 3).unwrap();
        assert!(!f.sun, "no sun in a smooth map");
        let r = evaluate(&map, &f.sgs);
        assert!(r.irradiance[0].0 < 2e-3, "{r:?}");
        for q in 0..3 {
            assert!((r.energy[1][q] - r.energy[0][q]).abs() < 1e-9 * r.energy[0][q], "{r:?}");
        }
        for g in &truth {
            let best = f
                .sgs
                .iter()
                .map(|l| DVec3::from(l.axis).dot(DVec3::from(g.axis).normalize()))
                .fold(-1.0, f64::max);
            assert!(best > 2f64.to_radians().cos(), "{g:?} in {:?}", f.sgs);
        }
    }

    /// A sky with a sun: a constant sky of radiance 0.2 and an SG of sharpness 3 000
    /// (about 1.5° wide) holding most of the energy: the sun is extracted, its axis
    /// within half a texel, its sharpness within 30 %, its energy within 2 %.
    #[test]
    fn a_sun_becomes_its_own_lobe() {
        let sun = RgbSg {
            axis: [0.36, 0.48, 0.8],
            sharpness: 3000.0,
            amplitude: [4.0e3, 3.6e3, 3.0e3],
        };
        let (w, h) = (1024, 512);
        let probe = EnvMap::new(w, h, vec![[0.0; 3]; w * h]).unwrap();
        let rgb: Vec<[f64; 3]> = (0..w * h)
            .map(|k| {
                let v = sun.value(probe.direction(k % w, k / w));
                [0.2 + v[0], 0.2 + v[1], 0.2 + v[2]]
            })
            .collect();
        let map = EnvMap::new(w, h, rgb).unwrap();
        let (s, rest) = extract_sun(&map);
        let s = s.expect("a sun");
        let texel = std::f64::consts::PI / h as f64;
        assert!(
            DVec3::from(s.axis).angle_between(DVec3::from(sun.axis).normalize()) < 0.5 * texel,
            "{s:?}"
        );
        assert!((s.sharpness / sun.sharpness - 1.0).abs() < 0.3, "{s:?}");
        // Its energy is the sun's within 2 % (the region's quadrature; the tail below
        // 0.5 % of the peak stays in the rest), and the split keeps the map's energy.
        let e_sun = sun.integral()[0];
        assert!((s.integral()[0] / e_sun - 1.0).abs() < 0.02, "{s:?}");
        let total = map.energy()[0];
        assert!((s.integral()[0] + rest.energy()[0] - total).abs() < 0.01 * total);
    }

    /// SH order 3 is exact for a constant map (its irradiance π L at every normal), and
    /// the map's own texel sum agrees to its quadrature (1e-3).
    #[test]
    fn sh_baselines_are_exact_where_they_should_be() {
        let m = EnvMap::new(128, 64, vec![[0.5; 3]; 128 * 64]).unwrap();
        let r = evaluate(
            &m,
            &[RgbSg {
                axis: [0.0, 0.0, 1.0],
                sharpness: 1e-3,
                amplitude: [0.5; 3],
            }],
        );
        assert!(r.irradiance[1].1 < 1e-3 && r.irradiance[2].1 < 1e-3, "{r:?}");
    }

    /// The committed maps read: 512 × 256 texels, finite, as their README says.
    #[test]
    fn committed_maps_read() {
        for name in ["sky", "apartment", "sunset"] {
            let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../assets/envmaps/{name}.exr"));
            let m = EnvMap::load(&p).unwrap();
            assert_eq!((m.width, m.height), (512, 256), "{name}");
            assert!(luminance(m.energy()) > 0.0);
        }
        let bad = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/envmaps/README.md");
        assert!(EnvMap::load(&bad).unwrap_err().contains(".exr or .hdr"));
        assert!(EnvMap::from_exr_bytes(b"not an exr").is_err());
    }

    /// A Radiance RGBE file written by hand (flat scanlines): its texels read back.
    #[test]
    fn radiance_hdr_reads() {
        let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n".to_vec();
        // RGBE (128, 64, 32, 129): (128, 64, 32) × 2^(129 − 136) = (1, 0.5, 0.25).
        for _ in 0..8 {
            f.extend([128u8, 64, 32, 129]);
        }
        let m = EnvMap::from_hdr_bytes(&f).unwrap();
        assert_eq!((m.width, m.height), (4, 2));
        for c in &m.rgb {
            assert!(
                (c[0] - 1.0).abs() < 1e-6 && (c[1] - 0.5).abs() < 1e-6 && (c[2] - 0.25).abs() < 1e-6,
                "{c:?}"
            );
        }
    }
}
