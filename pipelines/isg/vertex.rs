//! Per-vertex shading, the paper's default (docs/meshes.md, "Per-vertex shading"):
//! every vertex of a scene's meshes shaded once by the ISG pipeline, at its position
//! with its area-weighted normal, and a mesh pixel given the barycentric blend of its
//! triangle's three values (Gouraud). Measured against per-pixel shading with the
//! same interpolated normal (Phong shading), so the difference is the interpolation's
//! alone, and timed beside it.

use lobefit_tables::glam::DVec3;
use rayon::prelude::*;

use super::render::shade_hit;
use super::shade::{Settings, Tables};
use crate::mesh::Mesh;
use crate::scene::{Hit, Scene};

/// Unit vertex normals: the sum of the incident triangles' normals weighted by their
/// areas (the unnormalised cross products), normalised; outward for a mesh wound
/// counter-clockwise from outside. A vertex no triangle uses (or whose triangles
/// cancel) gets +z, never NaN.
pub fn vertex_normals(mesh: &Mesh) -> Vec<DVec3> {
    let mut n = vec![DVec3::ZERO; mesh.vertices.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        let g = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += g;
        }
    }
    n.into_iter().map(|v| v.try_normalize().unwrap_or(DVec3::Z)).collect()
}

/// Barycentric weights of `x` (on or near the plane of `a`, `b`, `c`) in that triangle,
/// from the areas of the sub-triangles projected on its normal.
pub fn barycentric(x: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let n = (b - a).cross(c - a);
    let area = n.length_squared();
    if area == 0.0 {
        return [1.0 / 3.0; 3];
    }
    let u = (c - b).cross(x - b).dot(n) / area;
    let v = (a - c).cross(x - c).dot(n) / area;
    [u, v, 1.0 - u - v]
}

/// One mesh's vertices as hits: each at its position with its normal from
/// [`vertex_normals`], the direction to the eye, and one incident triangle (for the
/// self-shadowing rule); `None` for a vertex no triangle uses.
pub fn vertex_hits(scene: &Scene, mesh: usize, normals: &[DVec3]) -> Vec<Option<Hit>> {
    let m = &scene.meshes[mesh];
    let mut tri = vec![usize::MAX; m.mesh.vertices.len()];
    for (k, t) in m.mesh.triangles.iter().enumerate() {
        for &i in t {
            if tri[i as usize] == usize::MAX {
                tri[i as usize] = k;
            }
        }
    }
    (0..m.mesh.vertices.len())
        .map(|i| {
            (tri[i] != usize::MAX).then(|| {
                let x = m.mesh.vertices[i];
                let n = normals[i];
                Hit {
                    x,
                    n,
                    t: n.any_orthonormal_vector(),
                    wo: (scene.camera.eye - x).try_normalize().unwrap_or(n),
                    sphere: None,
                    mesh: Some((mesh, tri[i])),
                    material: m.material,
                }
            })
        })
        .collect()
}

/// The Gouraud value of a mesh hit: the barycentric blend of its triangle's vertex
/// values (`values[mesh][vertex]`); `None` for a hit on no mesh.
pub fn blend(scene: &Scene, values: &[Vec<f64>], h: &Hit) -> Option<f64> {
    let (mi, k) = h.mesh?;
    let mesh = &scene.meshes[mi].mesh;
    let t = mesh.triangles[k];
    let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
    let w = barycentric(h.x, a, b, c);
    Some((0..3).map(|j| w[j] * values[mi][t[j] as usize]).sum())
}

/// One mesh's shading per vertex: its [`vertex_hits`] shaded by `shade`. A vertex no
/// triangle uses gets 0.
pub fn shade_vertices(
    scene: &Scene,
    mesh: usize,
    normals: &[DVec3],
    shade: impl Fn(&Hit) -> Result<f64, String> + Sync,
) -> Result<Vec<f64>, String> {
    vertex_hits(scene, mesh, normals)
        .into_par_iter()
        .map(|h| h.map_or(Ok(0.0), |h| shade(&h)))
        .collect()
}

/// A mesh hit with its normal replaced by the interpolated vertex normal (turned to
/// the hit's side), and the hit's barycentric weights in its triangle.
fn smooth(scene: &Scene, normals: &[Vec<DVec3>], h: &Hit) -> Option<(Hit, [f64; 3], [u32; 3])> {
    let (mi, k) = h.mesh?;
    let mesh = &scene.meshes[mi].mesh;
    let t = mesh.triangles[k];
    let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
    let w = barycentric(h.x, a, b, c);
    let nv = t.map(|i| normals[mi][i as usize]);
    let n = (w[0] * nv[0] + w[1] * nv[1] + w[2] * nv[2])
        .try_normalize()
        .unwrap_or(h.n);
    let n = if n.dot(h.n) < 0.0 { -n } else { n };
    Some((
        Hit {
            n,
            t: n.any_orthonormal_vector(),
            ..*h
        },
        w,
        t,
    ))
}

/// The study's result at one image size.
#[derive(Debug, Clone)]
pub struct VertexRow {
    /// Image width and height.
    pub size: (usize, usize),
    /// Pixels that see a mesh.
    pub mesh_pixels: usize,
    /// Per-pixel shading of the mesh pixels (interpolated normal), ms: median, min, max.
    pub per_pixel_ms: (f64, f64, f64),
    /// Per-vertex: every vertex shaded, then the pixels blended, ms: median, min, max.
    pub per_vertex_ms: (f64, f64, f64),
    /// (per-vertex − per-pixel) over the mesh pixels, relative to the per-pixel mean:
    /// RMS, median of |·|, p99, max.
    pub error: (f64, f64, f64, f64),
    /// The same for per-pixel shading with the flat (triangle) normal against the
    /// interpolated one: what smoothing the normal itself changes.
    pub flat_vs_smooth: (f64, f64, f64, f64),
}

/// The study: `scene`'s meshes shaded per vertex and per pixel at each width (height
/// 3/4 of it), each timed `runs` times in this process.
pub fn vertex_study(scene: &Scene, widths: &[usize], runs: usize) -> Result<(usize, Vec<VertexRow>), String> {
    if scene.meshes.is_empty() {
        return Err(format!("scene {}: no mesh to shade per vertex", scene.name));
    }
    let tables = Tables::embedded()?;
    let settings = Settings::default();
    let shade = |h: &Hit| shade_hit(&tables, &settings, scene, h);
    let normals: Vec<Vec<DVec3>> = scene.meshes.iter().map(|m| vertex_normals(&m.mesh)).collect();
    let vertices: usize = scene.meshes.iter().map(|m| m.mesh.vertices.len()).sum();
    let timing = |times: &[f64]| {
        let t = crate::measure::Timing::of(times);
        (t.median, t.min, t.max)
    };
    let mut rows = Vec::new();
    for &width in widths {
        let (w, h) = (width.max(4), (width * 3 / 4).max(3));
        let (hits, _) = scene.primary_hits(w, h)?;
        // Per mesh pixel: (the smooth hit, its weights, its triangle, its mesh, the flat hit).
        type MeshPixel = (Hit, [f64; 3], [u32; 3], usize, Hit);
        let on: Vec<MeshPixel> = hits
            .iter()
            .flatten()
            .filter_map(|hit| smooth(scene, &normals, hit).map(|(s, b, t)| (s, b, t, hit.mesh.expect("mesh").0, *hit)))
            .collect();
        if on.is_empty() {
            return Err(format!("scene {}: no pixel of {w}×{h} sees a mesh", scene.name));
        }
        let (mut pp, mut pv) = (Vec::new(), Vec::new());
        let (mut per_pixel, mut per_vertex) = (Vec::new(), Vec::new());
        for _ in 0..runs.max(1) {
            let t0 = std::time::Instant::now();
            per_pixel = on
                .par_iter()
                .map(|(s, ..)| shade(s))
                .collect::<Result<Vec<f64>, String>>()?;
            pp.push(1e3 * t0.elapsed().as_secs_f64());
            let t0 = std::time::Instant::now();
            let values = (0..scene.meshes.len())
                .map(|mi| shade_vertices(scene, mi, &normals[mi], shade))
                .collect::<Result<Vec<_>, String>>()?;
            per_vertex = on
                .iter()
                .map(|(_, b, t, mi, _)| (0..3).map(|k| b[k] * values[*mi][t[k] as usize]).sum::<f64>())
                .collect();
            pv.push(1e3 * t0.elapsed().as_secs_f64());
        }
        let flat = on
            .par_iter()
            .map(|(.., h)| shade(h))
            .collect::<Result<Vec<f64>, String>>()?;
        rows.push(VertexRow {
            size: (w, h),
            mesh_pixels: on.len(),
            per_pixel_ms: timing(&pp),
            per_vertex_ms: timing(&pv),
            error: stats(&per_vertex, &per_pixel),
            flat_vs_smooth: stats(&flat, &per_pixel),
        });
    }
    Ok((vertices, rows))
}

/// RMS, median, p99 and max of |a − b| relative to the mean of `b`.
fn stats(a: &[f64], b: &[f64]) -> (f64, f64, f64, f64) {
    let mean = b.iter().sum::<f64>() / b.len() as f64;
    let mut d: Vec<f64> = a.iter().zip(b).map(|(x, y)| (x - y).abs() / mean).collect();
    d.sort_by(f64::total_cmp);
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    let p99 = d[((d.len() - 1) as f64 * 0.99).round() as usize];
    (rms, d[d.len() / 2], p99, d[d.len() - 1])
}

/// The rows as a Markdown table.
pub fn table(scene: &str, vertices: usize, rows: &[VertexRow]) -> String {
    let mut s = format!(
        "{scene}: {vertices} vertices\n\n| image | mesh pixels | per pixel ms (median [min–max]) | per vertex ms | per vertex / per pixel | RMS | median | p99 | max | flat normal vs smooth: RMS |\n|---|---:|---|---|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in rows {
        s += &format!(
            "| {}×{} | {} | {:.1} [{:.1}–{:.1}] | {:.1} [{:.1}–{:.1}] | {:.2} | {:.4} | {:.4} | {:.3} | {:.3} | {:.4} |\n",
            r.size.0,
            r.size.1,
            r.mesh_pixels,
            r.per_pixel_ms.0,
            r.per_pixel_ms.1,
            r.per_pixel_ms.2,
            r.per_vertex_ms.0,
            r.per_vertex_ms.1,
            r.per_vertex_ms.2,
            r.per_vertex_ms.0 / r.per_pixel_ms.0,
            r.error.0,
            r.error.1,
            r.error.2,
            r.error.3,
            r.flat_vs_smooth.0
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Barycentric weights give the point back and are (1, 0, 0) at a vertex; vertex
    /// normals of a closed, convex mesh (an octahedron) point out of it along the
    /// vertex directions.
    #[test]
    fn barycentric_weights_and_vertex_normals() {
        let (a, b, c) = (
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(2.0, 0.0, 1.0),
            DVec3::new(0.0, 3.0, 1.0),
        );
        let x = 0.2 * a + 0.5 * b + 0.3 * c;
        let w = barycentric(x, a, b, c);
        let back = w[0] * a + w[1] * b + w[2] * c;
        assert!((back - x).length() < 1e-12, "{w:?}");
        assert!((barycentric(a, a, b, c)[0] - 1.0).abs() < 1e-12);
        let v = vec![DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z];
        let mut t = Vec::new();
        for (i, j) in [(0u32, 2u32), (2, 1), (1, 3), (3, 0)] {
            t.push([i, j, 4]);
            t.push([j, i, 5]);
        }
        let mesh = Mesh::new(v.clone(), t).unwrap();
        for (n, p) in vertex_normals(&mesh).iter().zip(&v) {
            assert!((*n - *p).length() < 1e-12, "{n} for the vertex at {p}");
        }
    }

    /// On the bunny scene at a small size, shading per vertex differs from per pixel by
    /// a few per cent of the mean over the mesh pixels, not by nothing (the blend is not
    /// the per-pixel shading) and not by a whole shade (a wrong vertex or weight would
    /// move the mean by its size).
    #[test]
    fn per_vertex_is_near_per_pixel_on_the_bunny() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/isg-bunny.json");
        let scene = crate::scene::load(path.to_str().unwrap()).unwrap();
        let (vertices, rows) = vertex_study(&scene, &[32], 1).unwrap();
        let t = table(&scene.name, vertices, &rows);
        let e = rows[0].error;
        assert!(e.0 > 1e-4 && e.0 < 0.1, "{t}");
        assert!(e.1 < 0.05, "{t}");
    }

    /// The study at full size (docs/meshes.md): the bunny with 64 `optimize` spheres
    /// (the self-shadowing section's set) at 96 to 640 pixels wide.
    #[test]
    #[ignore = "study: minutes; docs/meshes.md"]
    fn vertex_study_full() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/isg-bunny.json");
        let scene = crate::isg::proxy::scene_with_fit(&path, 64, crate::spheres::Method::Optimize, 1).unwrap();
        let (vertices, rows) = vertex_study(&scene, &[96, 192, 384, 640], 3).unwrap();
        println!("{}", table(&scene.name, vertices, &rows));
    }
}
