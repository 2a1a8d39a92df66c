//! Images of a pipeline against its reference: the error statistics every pipeline
//! reports, the error map, and image output: PNG panels through `lobefit_core::plot`
//! (heat maps with colour bars), a tone-mapped sRGB "beauty" image a person can look at
//! ([`write_beauty`]), and the float images as PFM (the format image tools read: HDR
//! viewers, ImageMagick, OpenCV) and OpenEXR ([`write_exr`]).
//!
//! Images are row-major with row 0 at the top; a mask selects the pixels that see
//! geometry (background pixels take no part in any statistic).

use std::path::{Path, PathBuf};

use lobefit_core::plot::{ColourScale, Heatmap};

/// A pipeline's error against a reference over the masked pixels, relative to the
/// reference's mean there (so a dark region's error is not hidden by its own scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorStats {
    /// √(mean (img − ref)²) / mean ref.
    pub rel_rmse: f64,
    /// 99th percentile of |img − ref| / mean ref (nearest rank).
    pub p99: f64,
    /// max |img − ref| / mean ref.
    pub max: f64,
    /// Mean of the reference over the mask.
    pub mean_ref: f64,
    /// Pixels in the mask.
    pub pixels: usize,
}

/// The mean of `v` over the pixels with `mask` (NaN for an empty mask).
pub fn mean_over(v: &[f64], mask: &[bool]) -> f64 {
    let (s, n) = v
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .fold((0.0, 0usize), |(s, n), (x, _)| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// [`ErrorStats`] of `img` against `reference` over `mask` (NaN statistics for an
/// empty mask).
pub fn compare(img: &[f64], reference: &[f64], mask: &[bool]) -> ErrorStats {
    let mean_ref = mean_over(reference, mask);
    let mut d: Vec<f64> = img
        .iter()
        .zip(reference)
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|((a, b), _)| (a - b).abs() / mean_ref)
        .collect();
    d.sort_by(f64::total_cmp);
    let pixels = d.len();
    if d.is_empty() {
        return ErrorStats {
            rel_rmse: f64::NAN,
            p99: f64::NAN,
            max: f64::NAN,
            mean_ref,
            pixels,
        };
    }
    let rel_rmse = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    let p99 = d[((d.len() - 1) as f64 * 0.99).round() as usize];
    ErrorStats {
        rel_rmse,
        p99,
        max: d[d.len() - 1],
        mean_ref,
        pixels,
    }
}

/// What a render writes for an image against its reference:
///
/// - `<stem>-images.png`: the two as heat maps side by side, on one colour scale (the
///   range of both over the mask);
/// - `<stem>-error.png`: (img − ref) / `mean_ref` on a diverging map centred on 0,
///   clipped at ± the p99 of |error| over the mask ([`error_limit`], stated in the colour
///   label);
/// - `<stem>-beauty.png`: img | reference tone-mapped at one exposure ([`write_beauty`],
///   exposure [`exposure_for`] `mean_ref`);
/// - the float images `<stem>-<img_name>`, `<stem>-reference`, `<stem>-error`, each as
///   `.pfm` and `.exr` ([`write_float_image`]).
///
/// `labels`: the two panels' titles. Returns the files and the error map.
#[allow(clippy::too_many_arguments)]
pub fn write_comparison(
    dir: &Path,
    stem: &str,
    labels: [&str; 2],
    img_name: &str,
    (w, h): (usize, usize),
    img: &[f64],
    reference: &[f64],
    mask: &[bool],
    mean_ref: f64,
) -> Result<(Vec<PathBuf>, Vec<f64>), String> {
    use lobefit_core::plot::heatmaps;
    let mut files = vec![heatmaps(
        &dir.join(format!("{stem}-images.png")),
        &shared_scale(vec![
            panel(labels[0].into(), w, h, &masked(img, mask), "radiance"),
            panel(labels[1].into(), w, h, &masked(reference, mask), "radiance"),
        ]),
        2,
    )?];
    let rel = error_map(img, reference, mask, mean_ref);
    let tag = stem.split_once('-').map_or(stem, |(_, t)| t);
    files.push(heatmaps(
        &dir.join(format!("{stem}-error.png")),
        &[error_panel(
            format!("{tag}: ({img_name} − reference) / mean reference"),
            w,
            h,
            &rel,
        )],
        1,
    )?);
    files.push(write_beauty(
        &dir.join(format!("{stem}-beauty.png")),
        (w, h),
        &[img, reference],
        mask,
        exposure_for(mean_ref),
    )?);
    for (what, v) in [(img_name, img), ("reference", reference), ("error", &rel)] {
        files.extend(write_float_image(dir, &format!("{stem}-{what}"), w, h, v)?);
    }
    Ok((files, rel))
}

/// `panels` with one [`ColourScale::Fixed`] range, that of all of them together (so a
/// colour is one value in each; unchanged when no value is finite).
pub fn shared_scale(mut panels: Vec<Heatmap>) -> Vec<Heatmap> {
    if let Some((lo, hi)) = lobefit_core::plot::shared_range(&panels) {
        for p in &mut panels {
            p.scale = ColourScale::Fixed { lo, hi };
        }
    }
    panels
}

/// The symmetric limit of an error map's diverging colours: the 99th percentile of
/// |error| over its finite pixels (nearest rank, as [`ErrorStats::p99`]), so that a few
/// hot pixels saturate instead of washing the rest of the map out to white. NaN when
/// no pixel is finite.
pub fn error_limit(error: &[f64]) -> f64 {
    let mut a: Vec<f64> = error.iter().filter(|v| v.is_finite()).map(|v| v.abs()).collect();
    if a.is_empty() {
        return f64::NAN;
    }
    a.sort_by(f64::total_cmp);
    a[((a.len() - 1) as f64 * 0.99).round() as usize]
}

/// A signed error panel of a w × h error map (NaN off the mask): diverging colours over
/// ± [`error_limit`], the limit stated in the colour label.
pub fn error_panel(title: String, w: usize, h: usize, error: &[f64]) -> Heatmap {
    let limit = error_limit(error);
    Heatmap {
        scale: ColourScale::Diverging { limit },
        ..panel(
            title,
            w,
            h,
            error,
            &format!(
                "relative error (colours clipped at ±{}, p99 of |error|)",
                limit_text(limit)
            ),
        )
    }
}

/// An error limit for a label: 3 significant figures, in exponent form below 0.001.
fn limit_text(limit: f64) -> String {
    if limit.is_finite() && limit > 0.0 && limit < 1e-3 {
        format!("{limit:.2e}")
    } else {
        crate::short_number(limit)
    }
}

/// Middle grey: the linear value the reference's mean is exposed to in a beauty image
/// (the photographic "18 % grey" key of Reinhard et al. 2002).
pub const MIDDLE_GREY: f64 = 0.18;

/// The background of a beauty image (pixels outside the mask), 8-bit sRGB: a fixed dark
/// grey, darker than any lit pixel of an exposed scene is likely to be, and not black,
/// so that a black (unlit, shadowed) surface stays distinguishable from "no surface".
pub const BEAUTY_BACKGROUND: u8 = 40;

/// The separator between the halves of a beauty image (8-bit sRGB: black) and its width
/// in output pixels.
pub const BEAUTY_SEPARATOR: (u8, usize) = (0, 4);

/// A beauty image is upscaled (nearest neighbour, by a whole factor) to at least this
/// many pixels wide in all.
pub const BEAUTY_MIN_WIDTH: usize = 512;

/// The exposure (a factor on radiance) that maps `mean_ref`, the reference's mean over
/// the mask, to [`MIDDLE_GREY`] before tone mapping: 0.18 / `mean_ref`. 1 when the mean
/// is not finite and > 0 (an all-black reference).
pub fn exposure_for(mean_ref: f64) -> f64 {
    if mean_ref.is_finite() && mean_ref > 0.0 {
        MIDDLE_GREY / mean_ref
    } else {
        1.0
    }
}

/// The ACES filmic tone curve as fitted by Narkowicz 2015 ("ACES Filmic Tone Mapping
/// Curve"): x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14) on exposed linear radiance
/// x, clamped to [0, 1] (negative and non-finite inputs — SH ringing, a NaN — give 0).
/// Used without the fit's optional 0.6 prescale: the exposure is the caller's.
pub fn aces_filmic(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    let y = if x <= 1.0 {
        (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
    } else {
        // The same ratio divided through by x²: no overflow to inf / inf for huge x
        // (an infinite x gives 2.51 / 2.43, clamped to 1).
        let r = 1.0 / x;
        (2.51 + 0.03 * r) / (2.43 + 0.59 * r + 0.14 * r * r)
    };
    y.clamp(0.0, 1.0)
}

/// The sRGB OETF (IEC 61966-2-1), linear [0, 1] to encoded [0, 1]: 12.92 l up to
/// l = 0.0031308, 1.055 l^(1/2.4) − 0.055 above (the exact piecewise curve, not a 2.2
/// gamma); the input clamped to [0, 1].
pub fn srgb_oetf(l: f64) -> f64 {
    let l = if l.is_finite() { l.clamp(0.0, 1.0) } else { 0.0 };
    if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// One radiance value to its 8-bit sRGB grey: exposed by `exposure`, tone-mapped by
/// [`aces_filmic`], encoded by [`srgb_oetf`], rounded to the nearest of 0..=255.
pub fn tone_map_8bit(radiance: f64, exposure: f64) -> u8 {
    (255.0 * srgb_oetf(aces_filmic(exposure * radiance))).round() as u8
}

/// A beauty image in memory: 8-bit sRGB, RGB interleaved, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Beauty {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// R, G, B per pixel, rows top to bottom (`3 × width × height` bytes).
    pub rgb: Vec<u8>,
}

/// Lays out w × h single-channel radiance images (row 0 at the top) left to right, each
/// pixel [`tone_map_8bit`] at the one `exposure` and written R = G = B; pixels off the
/// mask [`BEAUTY_BACKGROUND`]; [`BEAUTY_SEPARATOR`] between images; upscaled by the
/// smallest whole factor that makes the whole at least [`BEAUTY_MIN_WIDTH`] wide
/// (nearest neighbour: every rendered pixel stays a visible square).
pub fn beauty(w: usize, h: usize, images: &[&[f64]], mask: &[bool], exposure: f64) -> Result<Beauty, String> {
    let rgb: Vec<[&[f64]; 3]> = images.iter().map(|&i| [i, i, i]).collect();
    beauty_rgb(w, h, &rgb, mask, exposure)
}

/// [`beauty`] of linear RGB images, each given as its three channels (each channel
/// [`tone_map_8bit`] at the one `exposure`: a channel's clipping does not move the
/// others).
pub fn beauty_rgb(w: usize, h: usize, images: &[[&[f64]; 3]], mask: &[bool], exposure: f64) -> Result<Beauty, String> {
    if w == 0 || h == 0 || images.is_empty() {
        return Err(format!("a beauty image of {} images of {w}×{h}", images.len()));
    }
    if let Some(bad) = images
        .iter()
        .flat_map(|i| i.map(<[f64]>::len))
        .chain([mask.len()])
        .find(|&n| n != w * h)
    {
        return Err(format!("{bad} values for a {w}×{h} image"));
    }
    let n = images.len();
    let scale = BEAUTY_MIN_WIDTH.div_ceil(n * w).max(1);
    let (sep_value, sep) = BEAUTY_SEPARATOR;
    let width = n * w * scale + (n - 1) * sep;
    let height = h * scale;
    let mut row = Vec::with_capacity(3 * width);
    let mut rgb = Vec::with_capacity(3 * width * height);
    for j in 0..h {
        row.clear();
        for (k, img) in images.iter().enumerate() {
            if k > 0 {
                row.extend(std::iter::repeat_n(sep_value, 3 * sep));
            }
            for i in 0..w {
                let p = j * w + i;
                let v = if mask[p] {
                    img.map(|c| tone_map_8bit(c[p], exposure))
                } else {
                    [BEAUTY_BACKGROUND; 3]
                };
                for _ in 0..scale {
                    row.extend_from_slice(&v);
                }
            }
        }
        for _ in 0..scale {
            rgb.extend_from_slice(&row);
        }
    }
    Ok(Beauty { width, height, rgb })
}

/// Encodes a [`Beauty`] as an 8-bit RGB PNG in memory, marked sRGB (its sRGB chunk,
/// perceptual intent).
pub fn encode_png(b: &Beauty) -> Result<Vec<u8>, String> {
    let (w, h) = (
        u32::try_from(b.width).map_err(|e| e.to_string())?,
        u32::try_from(b.height).map_err(|e| e.to_string())?,
    );
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = enc.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(&b.rgb).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// Encodes equal-sized [`Beauty`] frames as an animated PNG (APNG) in memory, shown
/// at `fps` frames per second and looping forever; the first frame is also the image a
/// viewer without APNG support shows.
pub fn encode_apng(frames: &[Beauty], fps: u16) -> Result<Vec<u8>, String> {
    let first = frames.first().ok_or("an animation of no frames")?;
    if let Some(k) = frames
        .iter()
        .position(|f| (f.width, f.height) != (first.width, first.height))
    {
        return Err(format!(
            "animation frame {k} is {}×{}, frame 0 {}×{}",
            frames[k].width, frames[k].height, first.width, first.height
        ));
    }
    let e = |e: png::EncodingError| e.to_string();
    let (w, h) = (
        u32::try_from(first.width).map_err(|e| e.to_string())?,
        u32::try_from(first.height).map_err(|e| e.to_string())?,
    );
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    enc.set_animated(u32::try_from(frames.len()).map_err(|e| e.to_string())?, 0)
        .map_err(e)?;
    enc.set_frame_delay(1, fps.max(1)).map_err(e)?;
    let mut writer = enc.write_header().map_err(e)?;
    for f in frames {
        writer.write_image_data(&f.rgb).map_err(e)?;
    }
    writer.finish().map_err(e)?;
    Ok(bytes)
}

/// Writes the [`beauty`] image of `images` (the method's first, the reference last) to
/// `path` as a PNG, atomically (encoded in memory, then [`lobefit_core::io::write_atomic`]).
/// `exposure`: one factor for every image, chosen from the reference
/// ([`exposure_for`]).
pub fn write_beauty(
    path: &Path,
    (w, h): (usize, usize),
    images: &[&[f64]],
    mask: &[bool],
    exposure: f64,
) -> Result<PathBuf, String> {
    let rgb: Vec<[&[f64]; 3]> = images.iter().map(|&i| [i, i, i]).collect();
    write_beauty_rgb(path, (w, h), &rgb, mask, exposure)
}

/// [`write_beauty`] of linear RGB images ([`beauty_rgb`]).
pub fn write_beauty_rgb(
    path: &Path,
    (w, h): (usize, usize),
    images: &[[&[f64]; 3]],
    mask: &[bool],
    exposure: f64,
) -> Result<PathBuf, String> {
    let at = |e: String| format!("{}: {e}", path.display());
    let bytes = encode_png(&beauty_rgb(w, h, images, mask, exposure).map_err(at)?).map_err(at)?;
    lobefit_core::io::write_atomic(path, &bytes).map_err(|e| at(e.to_string()))?;
    Ok(path.to_path_buf())
}

/// Writes a w × h single-channel float image (row 0 at the top) as OpenEXR: one layer,
/// one f32 channel named "Y" (luminance, the name viewers show as grey), scan lines top
/// to bottom, ZIP-compressed (lossless), non-finite pixels (the background of an error
/// map) written as 0 as in [`write_pfm`]. Encoded in memory, then written atomically.
pub fn write_exr(path: &Path, w: usize, h: usize, values: &[f64]) -> Result<PathBuf, String> {
    use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, SmallVec, WritableImage};
    if values.len() != w * h || w == 0 || h == 0 {
        return Err(format!(
            "{}: {} values for a {w}×{h} image",
            path.display(),
            values.len()
        ));
    }
    let samples: Vec<f32> = values
        .iter()
        .map(|&v| if v.is_finite() { v as f32 } else { 0.0 })
        .collect();
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(
        "Y",
        FlatSamples::F32(samples),
    )]));
    let image = Image::from_encoded_channels((w, h), Encoding::SMALL_LOSSLESS, channels);
    let mut bytes = std::io::Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    lobefit_core::io::write_atomic(path, bytes.get_ref()).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path.to_path_buf())
}

/// Writes a float image as `dir/<name>.pfm` ([`write_pfm`]) and `dir/<name>.exr`
/// ([`write_exr`]); returns both paths.
pub fn write_float_image(dir: &Path, name: &str, w: usize, h: usize, values: &[f64]) -> Result<[PathBuf; 2], String> {
    Ok([
        write_pfm(&dir.join(format!("{name}.pfm")), w, h, values)?,
        write_exr(&dir.join(format!("{name}.exr")), w, h, values)?,
    ])
}

/// The relative RMSE with the reference's own noise taken out: a pixel's squared
/// difference from a Monte Carlo reference has expectation e² + σ² (e the image's
/// error, σ the reference's standard error `se`), so
/// √(max(0, mean (img − ref)² − mean σ²)) / mean ref estimates the error against
/// the noise-free reference. NaN for an empty mask.
pub fn noise_free_rel_rmse(img: &[f64], reference: &[f64], se: &[f64], mask: &[bool]) -> f64 {
    let mean_ref = mean_over(reference, mask);
    let d2: Vec<f64> = img.iter().zip(reference).map(|(a, b)| (a - b) * (a - b)).collect();
    let s2: Vec<f64> = se.iter().map(|s| s * s).collect();
    (mean_over(&d2, mask) - mean_over(&s2, mask)).max(0.0).sqrt() / mean_ref
}

/// (img − ref) / `scale` per pixel, NaN outside the mask: the signed error map.
pub fn error_map(img: &[f64], reference: &[f64], mask: &[bool], scale: f64) -> Vec<f64> {
    img.iter()
        .zip(reference)
        .zip(mask)
        .map(|((a, b), &m)| if m { (a - b) / scale } else { f64::NAN })
        .collect()
}

/// `v` with the pixels outside the mask set to NaN (drawn grey in a PNG panel).
pub fn masked(v: &[f64], mask: &[bool]) -> Vec<f64> {
    v.iter()
        .zip(mask)
        .map(|(x, &m)| if m { *x } else { f64::NAN })
        .collect()
}

/// A PNG panel of a w × h image (row 0 at the top; heat maps draw row 0 at the
/// bottom, so the rows are flipped here).
pub fn panel(title: String, w: usize, h: usize, values: &[f64], colour_label: &str) -> Heatmap {
    Heatmap {
        title,
        x_label: "pixel x".into(),
        y_label: "pixel y (up)".into(),
        x_range: (0.0, w as f64),
        y_range: (0.0, h as f64),
        nx: w,
        ny: h,
        values: (0..h).rev().flat_map(|j| values[j * w..(j + 1) * w].to_vec()).collect(),
        colour_label: colour_label.into(),
        log_colour: false,
        scale: ColourScale::Own,
    }
}

/// Writes a w × h single-channel image (row 0 at the top) as a PFM file ("Pf",
/// little-endian f32, rows stored bottom to top as the format has them), atomically.
/// Non-finite pixels (the background of a masked image) are written as 0.
///
/// Hand-written: the format is a three-line header and raw floats, and no PFM writer
/// is among the dependencies.
pub fn write_pfm(path: &Path, w: usize, h: usize, values: &[f64]) -> Result<PathBuf, String> {
    if values.len() != w * h || w == 0 || h == 0 {
        return Err(format!(
            "{}: {} values for a {w}×{h} image",
            path.display(),
            values.len()
        ));
    }
    let mut bytes = format!("Pf\n{w} {h}\n-1.0\n").into_bytes();
    for j in (0..h).rev() {
        for &v in &values[j * w..(j + 1) * w] {
            let v = if v.is_finite() { v as f32 } else { 0.0 };
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    lobefit_core::io::write_atomic(path, &bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path.to_path_buf())
}

/// The error breakdown's lines: `parts` holds per pixel the values of successive
/// configurations, each with one approximation more made exact, the last column the
/// reference (`names.len()` + 1 columns used); each step's RMS and mean change over
/// `mean` (the reference's mean on those pixels), after a headline with the total.
pub fn breakdown(tag: &str, from: &str, names: &[&str], parts: &[Vec<f64>], mean: f64, stride: usize) -> Vec<String> {
    let n = parts.len().max(1) as f64;
    let rms_of = |d: &[f64]| (d.iter().map(|x| x * x).sum::<f64>() / n).sqrt() / mean;
    let total: Vec<f64> = parts.iter().map(|p| p[0] - p[names.len()]).collect();
    let mut lines = vec![format!(
        "{tag}: error breakdown over {} pixels (every {stride}th), from {from}: total RMS {:.4} of the mean reference; each switch to exact, in order:",
        parts.len(),
        rms_of(&total)
    )];
    for (k, name) in names.iter().enumerate() {
        let d: Vec<f64> = parts.iter().map(|p| p[k] - p[k + 1]).collect();
        let bias = d.iter().sum::<f64>() / n / mean;
        lines.push(format!("{tag}:   {name}: RMS {:.4}, mean {bias:+.4}", rms_of(&d)));
    }
    lines
}

/// A breakdown stage (`name`, stage `k` of `parts`: `parts[i][k] − parts[i][k + 1]`)
/// on the pixels that see a mesh (`on[i]`) and on those that do not, each its RMS
/// relative to the same `mean` as the whole breakdown: the sphere proxy's error on a
/// mesh (its self-shadowing) and off it (its shadow on the rest) apart.
pub fn split_stage(tag: &str, name: &str, parts: &[Vec<f64>], k: usize, on: &[bool], mean: f64) -> String {
    let rms = |want: bool| {
        let d: Vec<f64> = parts
            .iter()
            .zip(on)
            .filter(|(_, &o)| o == want)
            .map(|(p, _)| p[k] - p[k + 1])
            .collect();
        let r = (d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt() / mean;
        (r, d.len())
    };
    let ((a, na), (b, nb)) = (rms(true), rms(false));
    format!("{tag}:     {name}, split: on the meshes RMS {a:.4} ({na} pixels), off them {b:.4} ({nb} pixels)")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// By hand: differences 0.3 and 0.4 (mean square 0.125), standard errors 0.1 and
    /// 0.2 (mean square 0.025), mean reference 1: √0.1.
    #[test]
    fn noise_free_rmse_by_hand() {
        let r = noise_free_rel_rmse(&[1.3, 0.6], &[1.0, 1.0], &[0.1, 0.2], &[true, true]);
        assert!((r - 0.1f64.sqrt()).abs() < 1e-12, "{r}");
    }

    /// Against values worked by hand: reference mean 2 over the mask, errors 0, 1,
    /// 2 (relative 0, 0.5, 1), the unmasked pixel ignored.
    #[test]
    fn statistics_by_hand() {
        let reference = [1.0, 2.0, 3.0, 100.0];
        let img = [1.0, 3.0, 1.0, -50.0];
        let mask = [true, true, true, false];
        let s = compare(&img, &reference, &mask);
        assert_eq!(s.mean_ref, 2.0);
        assert_eq!(s.pixels, 3);
        assert!((s.rel_rmse - (1.25f64 / 3.0).sqrt()).abs() < 1e-15);
        assert_eq!((s.p99, s.max), (1.0, 1.0));
        let m = error_map(&img, &reference, &mask, 2.0);
        assert_eq!(&m[..3], &[0.0, 0.5, -1.0]);
        assert!(m[3].is_nan());
        assert!(compare(&img, &reference, &[false; 4]).rel_rmse.is_nan());
    }

    /// p99 is the nearest rank: 1000 pixels with errors 1..=1000 give 990 (rank
    /// round(999·0.99) = 989, zero-based).
    #[test]
    fn p99_nearest_rank() {
        let reference = vec![1.0; 1000];
        let img: Vec<f64> = (1..=1000).map(|k| 1.0 + k as f64).collect();
        let s = compare(&img, &reference, &[true; 1000]);
        assert_eq!((s.p99, s.max), (990.0, 1000.0));
    }

    /// The tone curve against Narkowicz's formula written out here, at 1 by hand
    /// (2.54 / 3.16), and its ends: 0 and below (and NaN) black, huge and infinite
    /// inputs white (the fit's limit 2.51 / 2.43 > 1, clamped), no overflow to NaN.
    #[test]
    fn aces_tone_curve() {
        let narkowicz = |x: f64| (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
        for x in [1e-4, 0.05, 0.18, 0.5, 0.9, 2.0, 7.5] {
            let want = narkowicz(x).min(1.0);
            assert!(
                (aces_filmic(x) - want).abs() < 1e-15,
                "{x}: {} vs {want}",
                aces_filmic(x)
            );
        }
        assert!((aces_filmic(1.0) - 2.54 / 3.16).abs() < 1e-15);
        assert_eq!(aces_filmic(0.0), 0.0);
        assert_eq!(aces_filmic(-3.0), 0.0);
        assert_eq!(aces_filmic(f64::NAN), 0.0);
        assert_eq!(aces_filmic(1e300), 1.0);
        assert_eq!(aces_filmic(f64::INFINITY), 1.0);
        // Monotone on a grid through the knee.
        let ys: Vec<f64> = (0..400).map(|k| aces_filmic(k as f64 * 0.05)).collect();
        assert!(ys.windows(2).all(|p| p[1] >= p[0]));
    }

    /// The sRGB OETF at its knee and ends (IEC 61966-2-1): 0 → 0; 0.0031308 → 12.92 ×
    /// 0.0031308 = 0.040449936, where the power branch meets it to 1e-7; 1 → 1; 18 %
    /// grey → 0.4613561 (its well-known encoding, 118 in 8 bits); clamped outside
    /// [0, 1].
    #[test]
    fn srgb_oetf_knee_and_ends() {
        assert_eq!(srgb_oetf(0.0), 0.0);
        assert!((srgb_oetf(0.003_130_8) - 0.040_449_936).abs() < 1e-12);
        let power = 1.055 * 0.003_130_8f64.powf(1.0 / 2.4) - 0.055;
        assert!((power - 0.040_449_936).abs() < 1e-7, "{power}");
        assert!((srgb_oetf(1.0) - 1.0).abs() < 1e-15);
        assert!((srgb_oetf(0.18) - 0.461_356_1).abs() < 1e-7);
        assert_eq!((255.0 * srgb_oetf(0.18)).round(), 118.0);
        assert_eq!(srgb_oetf(-1.0), 0.0);
        assert!((srgb_oetf(5.0) - 1.0).abs() < 1e-15);
        assert_eq!(srgb_oetf(f64::NAN), 0.0);
        // Not a 2.2 gamma: at 0.001 the linear segment gives 0.01292, a 2.2 power 0.0433.
        assert!((srgb_oetf(0.001) - 0.012_92).abs() < 1e-15);
    }

    /// The exposure maps the reference's mean to 18 % grey; an unusable mean gives 1.
    /// A pixel at the mean then lands at the tone curve and OETF of 0.18 (141 in 8 bits:
    /// ACES(0.18) = 0.26690, encoded 0.55346, × 255 = 141.13).
    #[test]
    fn exposure_and_8bit_grey() {
        assert!((exposure_for(0.36) - 0.5).abs() < 1e-15);
        assert_eq!(exposure_for(0.0), 1.0);
        assert_eq!(exposure_for(f64::NAN), 1.0);
        let k = exposure_for(2.0);
        assert_eq!(tone_map_8bit(2.0, k), 141);
        assert_eq!(tone_map_8bit(0.0, k), 0);
        assert_eq!(tone_map_8bit(1e9, k), 255);
    }

    /// The beauty image's layout, written and decoded back with the png crate: 2 × (4 × 3)
    /// images upscaled ×64 (the smallest whole factor reaching 512 px: 512 / 8), a 4 px
    /// black separator, RGB 8-bit, R = G = B, the method left, the reference right, the
    /// background grey off the mask; no temporary left behind.
    #[test]
    fn beauty_png_layout() {
        let (w, h) = (4, 3);
        let img: Vec<f64> = (0..12).map(|k| k as f64 * 0.1).collect();
        let reference = vec![0.5; 12];
        let mut mask = vec![true; 12];
        mask[5] = false; // pixel (1, 1)
        let k = exposure_for(0.5);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x-beauty.png");
        write_beauty(&path, (w, h), &[&img, &reference], &mask, k).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (2 * 4 * 64 + 4, 3 * 64));
        assert_eq!(
            (info.color_type, info.bit_depth),
            (png::ColorType::Rgb, png::BitDepth::Eight)
        );
        assert!(reader.info().srgb.is_some());
        let width = info.width as usize;
        let at = |x: usize, y: usize| {
            let o = 3 * (y * width + x);
            assert!(buf[o] == buf[o + 1] && buf[o + 1] == buf[o + 2], "grey at ({x}, {y})");
            buf[o]
        };
        // Every output pixel of source pixel (i, j) in each half.
        for j in 0..h {
            for i in 0..w {
                let p = j * w + i;
                for (half, v) in [(0, img[p]), (1, reference[p])] {
                    let want = if mask[p] {
                        tone_map_8bit(v, k)
                    } else {
                        BEAUTY_BACKGROUND
                    };
                    let x0 = half * (4 * 64 + 4) + i * 64;
                    for (dx, dy) in [(0, 0), (63, 0), (0, 63), (63, 63), (17, 40)] {
                        assert_eq!(at(x0 + dx, j * 64 + dy), want, "({i}, {j}) half {half}");
                    }
                }
            }
        }
        for y in [0, 100, 191] {
            for x in 256..260 {
                assert_eq!(at(x, y), 0, "separator");
            }
        }
        // The reference's mean (0.5, everywhere) is 18 % grey: 141.
        assert_eq!(at(300, 10), 141);
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        // Wrong sizes are errors naming the file.
        let e = write_beauty(&path, (w, h), &[&img[..11], &reference], &mask, k).unwrap_err();
        assert!(
            e.contains("x-beauty.png") && e.contains("11 values for a 4×3 image"),
            "{e}"
        );
        assert!(write_beauty(&path, (0, 3), &[], &[], k).is_err());
    }

    /// A wide image is not upscaled: 2 × 300 px wide is already ≥ 512.
    #[test]
    fn beauty_wide_is_not_upscaled() {
        let v = vec![1.0; 300 * 2];
        let b = beauty(300, 2, &[&v, &v], &vec![true; 600], 1.0).unwrap();
        assert_eq!((b.width, b.height, b.rgb.len()), (604, 2, 604 * 2 * 3));
    }

    /// The EXR file read back with the exr crate: one "Y" channel of f32 equal to the
    /// input rounded to f32, rows top to bottom, NaN written as 0; bad sizes are errors.
    #[test]
    fn exr_round_trip() {
        use exr::prelude::FlatSamples;
        let (w, h) = (5, 3);
        let mut v: Vec<f64> = (0..15).map(|k| (k as f64 - 4.0) * 0.123_456_789_01 + 1e-7).collect();
        v[7] = f64::NAN;
        v[8] = 3.0e30;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        write_exr(&path, w, h, &v).unwrap();
        let image = exr::prelude::read_first_flat_layer_from_file(&path).unwrap();
        let layer = &image.layer_data;
        assert_eq!((layer.size.0, layer.size.1), (w, h));
        let channels = &layer.channel_data.list;
        assert_eq!(channels.len(), 1);
        assert_eq!(channels[0].name.to_string(), "Y");
        let FlatSamples::F32(got) = &channels[0].sample_data else {
            panic!("not f32: {:?}", channels[0].sample_data)
        };
        let want: Vec<f32> = v.iter().map(|&x| if x.is_finite() { x as f32 } else { 0.0 }).collect();
        assert_eq!(got, &want);
        let e = write_exr(&path, 4, 4, &v).unwrap_err();
        assert!(e.contains("a.exr") && e.contains("15 values for a 4×4 image"), "{e}");
        // Both float formats through one call.
        let both = write_float_image(dir.path(), "b", w, h, &v).unwrap();
        assert!(both[0].ends_with("b.pfm") && both[1].ends_with("b.exr"));
        assert!(both.iter().all(|p| p.exists()));
    }

    /// The error map's colour limit is the p99 of |error| by nearest rank: two hot pixels
    /// among 200 at 0.01 (of either sign) leave it at 0.01, where the maximum would make
    /// it 1e6; NaN (off the mask) ignored; none finite gives NaN.
    #[test]
    fn error_limit_ignores_hot_pixels() {
        let mut e: Vec<f64> = (0..200).map(|k| if k % 2 == 0 { 0.01 } else { -0.01 }).collect();
        e.extend([1e6, -1e6, f64::NAN]);
        assert_eq!(error_limit(&e), 0.01);
        let ramp: Vec<f64> = (1..=1000).map(|k| -(k as f64)).collect();
        assert_eq!(error_limit(&ramp), 990.0);
        assert!(error_limit(&[f64::NAN]).is_nan());
        let p = error_panel("t".into(), 203, 1, &e);
        assert_eq!(p.scale, ColourScale::Diverging { limit: 0.01 });
        assert!(p.colour_label.contains("±0.0100"), "{}", p.colour_label);
        assert_eq!(limit_text(2.5e-5), "2.50e-5");
    }

    /// Panels compared side by side share the range of both.
    #[test]
    fn images_share_one_scale() {
        let a = panel("a".into(), 2, 1, &[0.5, f64::NAN], "r");
        let b = panel("b".into(), 2, 1, &[2.0, 1.0], "r");
        let s = shared_scale(vec![a, b]);
        assert!(s.iter().all(|p| p.scale == ColourScale::Fixed { lo: 0.5, hi: 2.0 }));
    }

    /// The PFM file: header, then rows bottom to top, read back by hand.
    #[test]
    fn pfm_layout() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.pfm");
        write_pfm(&p, 2, 2, &[1.0, 2.0, 3.0, f64::NAN]).unwrap();
        let b = std::fs::read(&p).unwrap();
        let head = b"Pf\n2 2\n-1.0\n";
        assert_eq!(&b[..head.len()], head);
        let px: Vec<f32> = b[head.len()..]
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(px, [3.0, 0.0, 1.0, 2.0]);
        assert!(write_pfm(&p, 3, 2, &[0.0; 4]).is_err());
    }
}
