//! `lobefit-gpu render`: a small headless image through the shader library — a
//! diffuse sphere on a floor lit by a one-sided disk light, shaded by the disk's order-3
//! SH irradiance (`lf_disk_irradiance` on the exported disk-light texture) — written
//! as a PNG, and the same image computed on the CPU with the runtime crate
//! (`DiskLight::irradiance`, f64, the committed table), compared pixel by pixel.

use std::path::Path;

use glam::DVec3;
use lobefit::export::layout::Filter;
use lobefit_tables::disk_light::DiskLight;

use crate::conformance::{kernel, lf_tex, Export};
use crate::device::{wgsl_texture_type, Gpu};

/// Image side (pixels).
pub const SIZE: usize = 256;
/// Limit on the RMS difference (relative to the image's peak) of the GPU image from
/// the CPU image (the acceptance).
pub const RMS_LIMIT: f64 = 1e-4;

const CENTRE: [f64; 3] = [1.5, 2.5, 1.5];
const RADIUS: f64 = 0.8;
const RADIANCE: f64 = 1.0;

/// The scene's hit point and normal for pixel (i, j), in f64 (the CPU side; the shader
/// repeats it in f32): orthographic rays along (0, −0.5, −1) onto the unit sphere at
/// the origin, else the floor y = −1 (within |x|, |z| ≤ 4).
fn hit(i: usize, j: usize) -> Option<(DVec3, DVec3)> {
    let u = (i as f64 + 0.5) / SIZE as f64 * 4.0 - 2.0;
    let v = 2.0 - (j as f64 + 0.5) / SIZE as f64 * 4.0;
    let o = DVec3::new(u, v + 2.5, 5.0);
    let d = DVec3::new(0.0, -0.5, -1.0).normalize();
    let b = o.dot(d);
    let c = o.dot(o) - 1.0;
    let disc = b * b - c;
    if disc >= 0.0 {
        let p = o + (-b - disc.sqrt()) * d;
        return Some((p, p.normalize()));
    }
    let t = (-1.0 - o.y) / d.y;
    let p = o + t * d;
    (t > 0.0 && p.x.abs() <= 4.0 && p.z.abs() <= 4.0).then_some((p, DVec3::Y))
}

const BODY: &str = "    let px = f32(i % 256u);
    let py = f32(i / 256u);
    let u = (px + 0.5) / 256.0 * 4.0 - 2.0;
    let v = 2.0 - (py + 0.5) / 256.0 * 4.0;
    let ro = vec3<f32>(u, v + 2.5, 5.0);
    let d = normalize(vec3<f32>(0.0, -0.5, -1.0));
    let b = dot(ro, d);
    let c = dot(ro, ro) - 1.0;
    let disc = b * b - c;
    var p = vec3<f32>(0.0);
    var n = vec3<f32>(0.0);
    var hit = false;
    if disc >= 0.0 {
        p = ro + (-b - sqrt(disc)) * d;
        n = normalize(p);
        hit = true;
    } else {
        let t = (-1.0 - ro.y) / d.y;
        p = ro + t * d;
        n = vec3<f32>(0.0, 1.0, 0.0);
        hit = t > 0.0 && abs(p.x) <= 4.0 && abs(p.z) <= 4.0;
    }
    var e = 0.0;
    if hit {
        let centre = vec3<f32>(1.5, 2.5, 1.5);
        e = lf_disk_irradiance(T, S, P, p, n, centre, -normalize(centre), 0.8, 1.0);
    }
    Y[o] = e;";

/// Renders on the GPU and the CPU; writes `out` (PNG, 8-bit grey, E / peak, sRGB-ish
/// gamma 1/2.2). Returns (max, RMS) of |gpu − cpu| / peak over the pixels.
pub fn render(gpu: &Gpu, export: &Export, out: &Path) -> Result<(f64, f64), String> {
    let m = &export.manifest;
    let k = m
        .families
        .iter()
        .position(|f| f.family == "disk-light")
        .ok_or("the export has no disk-light texture (export it: --only disk-light)")?;
    let (entry, tex) = &export.textures[k][0];
    let up = gpu.upload(tex, m.storage)?;
    let n = SIZE * SIZE;
    let src = kernel(wgsl_texture_type(tex), 0, 1, BODY);
    let img = gpu.run(&src, &lf_tex(entry, Filter::Manual), &up, &[], n, 1)?;
    let disk = DiskLight::embedded().map_err(|e| e.to_string())?;
    let centre = DVec3::from_array(CENTRE);
    let mut cpu = vec![0.0f64; n];
    for j in 0..SIZE {
        for i in 0..SIZE {
            if let Some((p, nrm)) = hit(i, j) {
                cpu[j * SIZE + i] = disk
                    .irradiance(p, nrm, centre, -centre.normalize(), RADIUS, RADIANCE)
                    .map_err(|e| format!("CPU irradiance at pixel ({i}, {j}): {e}"))?;
            }
        }
    }
    let peak = cpu.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let (mut max, mut sum) = (0.0f64, 0.0);
    for (g, c) in img.iter().zip(&cpu) {
        let d = (*g as f64 - c).abs() / peak;
        max = max.max(d);
        sum += d * d;
    }
    let rms = (sum / n as f64).sqrt();
    let pixels: Vec<u8> = img
        .iter()
        .map(|&g| ((g as f64 / peak).clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8)
        .collect();
    let file = std::fs::File::create(out).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), SIZE as u32, SIZE as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .and_then(|mut w| w.write_image_data(&pixels))
        .map_err(|e| format!("{}: {e}", out.display()))?;
    Ok((max, rms))
}
