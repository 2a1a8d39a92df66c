//! Images of a pipeline against its reference: the error statistics every pipeline
//! reports, the error map, and image output (PNG panels through `lobefit_core::plot`, and
//! PFM, the float format image tools read: HDR viewers, ImageMagick, OpenCV).
//!
//! Images are row-major with row 0 at the top; a mask selects the pixels that see
//! geometry (background pixels take no part in any statistic).

use std::path::{Path, PathBuf};

use lobefit_core::plot::Heatmap;

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

/// What a render writes for an image against its reference: `<stem>-images.png` (the
/// two side by side), `<stem>-error.png` ((img − ref) / `mean_ref`) and the float
/// images `<stem>-<img_name>.pfm`, `<stem>-reference.pfm`, `<stem>-error.pfm`.
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
        &[
            panel(labels[0].into(), w, h, &masked(img, mask), "radiance"),
            panel(labels[1].into(), w, h, &masked(reference, mask), "radiance"),
        ],
        2,
    )?];
    let rel = error_map(img, reference, mask, mean_ref);
    let tag = stem.split_once('-').map_or(stem, |(_, t)| t);
    files.push(heatmaps(
        &dir.join(format!("{stem}-error.png")),
        &[panel(
            format!("{tag}: ({img_name} − reference) / mean reference"),
            w,
            h,
            &rel,
            "relative error",
        )],
        1,
    )?);
    for (what, v) in [(img_name, img), ("reference", reference), ("error", &rel)] {
        files.push(write_pfm(&dir.join(format!("{stem}-{what}.pfm")), w, h, v)?);
    }
    Ok((files, rel))
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
