//! Triangle meshes: bounded OBJ loading (through `tobj`), a rigid transform, and a
//! bounding-volume hierarchy over the triangles for nearest hits, shadow rays, the
//! inside test and distances (what `--exact` references and `lobefit spheres` need).
//!
//! Conventions as in [`crate::scene`]: f64 scene units, rays x + t·v with v unit.
//! Triangles are two-sided for rays; a hit's normal is the geometric normal of the
//! triangle (counter-clockwise winding, turned to face the ray's origin by the caller).
//!
//! The hierarchy is hand-written rather than taken from a crate (`obvhs`, `bvh`): those
//! are f32, and the exact references here are f64 throughout (a shadow ray's rounding
//! must stay far below the 1e-9 scene offsets the scene layer uses); it is the scene
//! layer's sphere BVH with triangles in its leaves, tested against brute force.

use std::path::Path;

use lobefit_tables::glam::{DQuat, DVec3};

/// Longest mesh file read (bytes).
pub const MAX_MESH_BYTES: u64 = 64 << 20;
/// Most vertices a mesh may hold.
pub const MAX_MESH_VERTICES: usize = 1 << 21;
/// Most triangles a mesh may hold (after triangulating polygons).
pub const MAX_MESH_TRIANGLES: usize = 1 << 21;
/// Largest |coordinate| of a mesh vertex (after its transform), as the scene's
/// `MAX_COORD`.
pub const MAX_MESH_COORD: f64 = 1e6;
/// Largest fraction of a mesh's edges that may be open for [`Mesh::check_solid`].
pub const MAX_OPEN_EDGES: f64 = 0.05;
/// Triangles per leaf of the hierarchy.
const LEAF: usize = 4;

/// A rigid transform with uniform scale: x ↦ R (s x) + t (spheres stay spheres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Uniform scale s > 0.
    pub scale: f64,
    /// Rotation R (unit quaternion).
    pub rotation: DQuat,
    /// Translation t (scene units).
    pub translation: DVec3,
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Transform = Transform {
        scale: 1.0,
        rotation: DQuat::IDENTITY,
        translation: DVec3::ZERO,
    };

    /// The image of point `p`.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.rotation * (self.scale * p) + self.translation
    }
}

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first triangle in `order` and count (> 0); inner: first child, count 0.
    first: usize,
    count: usize,
}

/// A triangle mesh with its hierarchy.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Vertex positions (scene units).
    pub vertices: Vec<DVec3>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

/// Möller–Trumbore: distance along x + t·v to triangle (a, b, c), if t in (t_min, t_max).
fn ray_triangle(x: DVec3, v: DVec3, a: DVec3, b: DVec3, c: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
    let e1 = b - a;
    let e2 = c - a;
    let p = v.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = x - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let w = v.dot(q) * inv;
    if w < 0.0 || u + w > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some(t)
}

/// Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + d1 / (d1 - d3) * ab;
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + d2 / (d2 - d6) * ac;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Whether the ray x + t·v (inv = 1/v) meets the box before t_max.
fn hits_box(lo: DVec3, hi: DVec3, x: DVec3, inv: DVec3, t_max: f64) -> bool {
    let t1 = (lo - x) * inv;
    let t2 = (hi - x) * inv;
    // NaN (0·∞ on a face plane) is ignored by min/max: the slab then spans everything.
    let tn = t1.min(t2).max_element();
    let tf = t1.max(t2).min_element();
    tn <= tf && tf >= 0.0 && tn <= t_max
}

/// A mesh file's bytes: a regular file (a FIFO or a device would block or never end)
/// of at most [`MAX_MESH_BYTES`]; errors name the file.
fn read_mesh_file(path: &Path) -> Result<Vec<u8>, String> {
    lobefit_core::io::read_bytes(path, MAX_MESH_BYTES, "MAX_MESH_BYTES").map_err(|m| format!("mesh: {m}"))
}

/// The buffers of a glTF document: the binary chunk, or decoded `data:` URIs.
fn gltf_buffers(doc: &gltf::Gltf) -> Result<Vec<Vec<u8>>, String> {
    use base64::Engine as _;
    doc.buffers()
        .map(|b| {
            let data = match b.source() {
                gltf::buffer::Source::Bin => doc
                    .blob
                    .clone()
                    .ok_or_else(|| format!("buffer {}: no binary chunk", b.index()))?,
                gltf::buffer::Source::Uri(uri) => {
                    let Some((_, payload)) = uri.strip_prefix("data:").and_then(|u| u.split_once(";base64,")) else {
                        return Err(format!(
                            "buffer {} names {:.40?}: only embedded buffers (the binary chunk, base64 data: URIs) are read",
                            b.index(),
                            uri
                        ));
                    };
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| format!("buffer {}: {e}", b.index()))?
                }
            };
            if data.len() < b.length() {
                return Err(format!(
                    "buffer {} holds {} bytes, its byteLength says {}",
                    b.index(),
                    data.len(),
                    b.length()
                ));
            }
            Ok(data)
        })
        .collect()
}

/// The scene's nodes in depth-first order with their world transforms (column-major
/// 4×4), after checking that the node graph is what glTF 2.0 requires (§3.5.3: a
/// disjoint union of strict trees): no node lists a child twice or is the child of
/// two parents, a scene's root is no node's child, and no cycle. The walk is an
/// explicit stack, so a deep chain costs memory in the node count, not a thread's
/// stack; every node is visited at most once.
pub(crate) fn gltf_nodes<'a>(
    doc: &'a gltf::Gltf,
    scene: &gltf::Scene<'a>,
) -> Result<Vec<(gltf::Node<'a>, lobefit_tables::glam::DMat4)>, String> {
    let n = doc.nodes().len();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for node in doc.nodes() {
        for c in node.children() {
            if c.index() == node.index() {
                return Err(format!("nodes[{}].children lists the node itself", node.index()));
            }
            match parent[c.index()] {
                Some(p) if p == node.index() => {
                    return Err(format!(
                        "nodes[{}].children lists node {} twice",
                        node.index(),
                        c.index()
                    ))
                }
                Some(p) => {
                    return Err(format!(
                        "node {} is a child of nodes {p} and {} (glTF nodes form trees: one parent each)",
                        c.index(),
                        node.index()
                    ))
                }
                None => parent[c.index()] = Some(node.index()),
            }
        }
    }
    let mut seen = vec![false; n];
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for root in scene.nodes() {
        if let Some(p) = parent[root.index()] {
            return Err(format!(
                "scenes[{}].nodes lists node {}, a child of node {p} (a scene lists root nodes)",
                scene.index(),
                root.index()
            ));
        }
        stack.push((root, lobefit_tables::glam::DMat4::IDENTITY));
    }
    while let Some((node, parent_world)) = stack.pop() {
        // One parent each and parentless roots: a node met twice is a root listed twice.
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(format!(
                "scenes[{}].nodes lists node {} twice",
                scene.index(),
                node.index()
            ));
        }
        let local = lobefit_tables::glam::Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
        let world = parent_world * local;
        stack.extend(node.children().map(|c| (c, world)));
        out.push((node, world));
    }
    Ok(out)
}

/// Checks an accessor against what lobefit reads from it (`want`: the component
/// types and dimensions it takes, named for the message) and the bytes it may span:
/// its elements inside its buffer view, the view inside its buffer, a sparse
/// accessor's index and value views likewise and every sparse index below its count.
/// The gltf crate's reader trusts all of these (it reads a u8 position as f32 bytes
/// and panics on a float index accessor), so they are checked first, naming the field.
pub(crate) fn check_accessor(
    a: &gltf::Accessor,
    what: &str,
    types: &[gltf::accessor::DataType],
    dims: gltf::accessor::Dimensions,
    buffers: &[Vec<u8>],
) -> Result<(), String> {
    let at = format!("accessors[{}] ({what})", a.index());
    if !types.contains(&a.data_type()) || a.dimensions() != dims || a.normalized() {
        return Err(format!(
            "{at}: componentType {:?}, type {:?}{}; {what} takes {} {:?}",
            a.data_type(),
            a.dimensions(),
            if a.normalized() { ", normalized" } else { "" },
            types.iter().map(|t| format!("{t:?}")).collect::<Vec<_>>().join(" or "),
            dims
        ));
    }
    if a.count() == 0 {
        return Err(format!("{at}: count 0"));
    }
    // A view's bytes lie inside its buffer (its byteLength, and the bytes held).
    let view_bytes = |v: &gltf::buffer::View, field: &str| -> Result<usize, String> {
        let end = v.offset().checked_add(v.length());
        let held = buffers
            .get(v.buffer().index())
            .map_or(0, Vec::len)
            .min(v.buffer().length());
        match end {
            Some(end) if end <= held => Ok(v.length()),
            _ => Err(format!(
                "{at}: {field} bufferViews[{}] spans bytes {}..{} of buffer {}, which has {held}",
                v.index(),
                v.offset(),
                v.offset() as u128 + v.length() as u128,
                v.buffer().index()
            )),
        }
    };
    // `count` elements of `size` bytes `stride` apart from `offset` lie inside the view.
    let span = |v: &gltf::buffer::View, offset: usize, count: usize, size: usize, field: &str| {
        let len = view_bytes(v, field)?;
        let stride = v.stride().unwrap_or(size);
        if stride < size {
            return Err(format!(
                "{at}: {field} bufferViews[{}].byteStride {stride} is below the element's {size} bytes",
                v.index()
            ));
        }
        let end = (count as u128 - 1) * stride as u128 + size as u128 + offset as u128;
        if end > len as u128 {
            return Err(format!(
                "{at}: {field} {count} elements of {size} bytes at byteOffset {offset} end at byte {end}, beyond bufferViews[{}].byteLength {len}",
                v.index()
            ));
        }
        Ok(())
    };
    if let Some(v) = a.view() {
        span(&v, a.offset(), a.count(), a.size(), "its")?;
    }
    if let Some(s) = a.sparse() {
        if s.count() == 0 || s.count() > a.count() {
            return Err(format!("{at}: sparse.count {} outside 1..={}", s.count(), a.count()));
        }
        let iv = s.indices().view();
        let isize = match s.indices().index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        if iv.stride().is_some() {
            return Err(format!(
                "{at}: sparse.indices' bufferViews[{}] has a byteStride",
                iv.index()
            ));
        }
        span(&iv, s.indices().offset(), s.count(), isize, "sparse.indices'")?;
        let vv = s.values().view();
        if vv.stride().is_some() {
            return Err(format!(
                "{at}: sparse.values' bufferViews[{}] has a byteStride",
                vv.index()
            ));
        }
        span(&vv, s.values().offset(), s.count(), a.size(), "sparse.values'")?;
        // Strictly increasing indices below count (glTF 2.0 §5.1.7.1).
        let base = iv.offset() + s.indices().offset();
        let bytes = &buffers[iv.buffer().index()][base..base + s.count() * isize];
        let mut last: Option<u64> = None;
        for (k, b) in bytes.chunks_exact(isize).enumerate() {
            let i = b.iter().rev().fold(0u64, |acc, &x| acc << 8 | u64::from(x));
            if i >= a.count() as u64 || last.is_some_and(|l| i <= l) {
                return Err(format!(
                    "{at}: sparse index {k} is {i}: sparse indices must increase and stay below count {}",
                    a.count()
                ));
            }
            last = Some(i);
        }
    }
    if a.view().is_none() && a.sparse().is_none() {
        return Err(format!("{at}: no bufferView and not sparse (all zeros)"));
    }
    Ok(())
}

/// [`Mesh::from_gltf_bytes`] (may panic on hostile input: called under catch_unwind).
fn gltf_mesh(bytes: &[u8]) -> Result<Mesh, String> {
    let (doc, buffers) = gltf_document(bytes)?;
    gltf_mesh_of(&doc, &buffers)
}

/// A glTF 2.x file's document and its buffers' bytes, read once for the mesh and (a
/// skinned mesh) its skin.
pub(crate) fn gltf_document(bytes: &[u8]) -> Result<(gltf::Gltf, Vec<Vec<u8>>), String> {
    let doc = gltf::Gltf::from_slice(bytes).map_err(|e| format!("not a readable glTF file: {e}"))?;
    // glTF 2.x: a major version beyond 2 may change what every field means.
    let asset = &doc.as_json().asset;
    let major = |v: &str| v.split('.').next().and_then(|m| m.parse::<u64>().ok());
    if major(&asset.version) != Some(2) || asset.min_version.as_deref().is_some_and(|m| m != "2.0") {
        return Err(format!(
            "asset.version {:?}{}: only glTF 2.x (minVersion 2.0) is read",
            asset.version,
            asset
                .min_version
                .as_deref()
                .map_or(String::new(), |m| format!(", asset.minVersion {m:?}"))
        ));
    }
    let buffers = gltf_buffers(&doc)?;
    Ok((doc, buffers))
}

/// The mesh of a read glTF document: every triangle primitive of the default scene's
/// nodes, placed by their world transforms (a skinned node's in its bind pose).
pub(crate) fn gltf_mesh_of(doc: &gltf::Gltf, buffers: &[Vec<u8>]) -> Result<Mesh, String> {
    use gltf::accessor::{DataType, Dimensions};
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or("no scene")?;
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for (node, world) in gltf_nodes(doc, &scene)? {
        let Some(mesh) = node.mesh() else { continue };
        // A skinned mesh's vertices are its bind pose as stored: glTF 2.0 §3.7.3 has
        // its node's transform ignored (crate::skin poses it).
        let world = if node.skin().is_some() {
            lobefit_tables::glam::DMat4::IDENTITY
        } else {
            world
        };
        for p in mesh.primitives() {
            if p.mode() != gltf::mesh::Mode::Triangles {
                return Err(format!(
                    "mesh {}: primitive mode {:?}, triangles only",
                    mesh.index(),
                    p.mode()
                ));
            }
            let pos = p
                .get(&gltf::Semantic::Positions)
                .ok_or_else(|| format!("mesh {}: a primitive without positions", mesh.index()))?;
            check_accessor(&pos, "POSITION", &[DataType::F32], Dimensions::Vec3, buffers)?;
            if let Some(i) = p.indices() {
                let types = [DataType::U8, DataType::U16, DataType::U32];
                check_accessor(&i, "indices", &types, Dimensions::Scalar, buffers)?;
            }
            let count = pos.count();
            if vertices.len() + count > MAX_MESH_VERTICES {
                return Err(format!(
                    "more than the {MAX_MESH_VERTICES} vertices a mesh may hold (MAX_MESH_VERTICES)"
                ));
            }
            let reader = p.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let base = vertices.len() as u32;
            let positions = reader
                .read_positions()
                .ok_or_else(|| format!("mesh {}: a primitive without positions", mesh.index()))?;
            vertices.extend(positions.map(|q| world.transform_point3(DVec3::from(q.map(f64::from)))));
            let n = vertices.len() as u32 - base;
            // The index count bounded before the indices are read.
            let n_idx = p.indices().map_or(n as usize, |i| i.count());
            if triangles.len() + n_idx / 3 > MAX_MESH_TRIANGLES {
                return Err(format!(
                    "mesh {}: {n_idx} indices, more than the {MAX_MESH_TRIANGLES} triangles a mesh may hold in all \
                     (MAX_MESH_TRIANGLES)",
                    mesh.index()
                ));
            }
            let idx: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..n).collect(),
            };
            if !idx.len().is_multiple_of(3) || triangles.len() + idx.len() / 3 > MAX_MESH_TRIANGLES {
                return Err(format!(
                    "mesh {}: {} indices: not whole triangles, or more than {MAX_MESH_TRIANGLES} in all",
                    mesh.index(),
                    idx.len()
                ));
            }
            if let Some(&i) = idx.iter().find(|&&i| i >= n) {
                return Err(format!("mesh {}: index {i} beyond its {n} vertices", mesh.index()));
            }
            triangles.extend(idx.chunks_exact(3).map(|t| [base + t[0], base + t[1], base + t[2]]));
        }
    }
    Mesh::new(vertices, triangles)
}

impl Mesh {
    /// A mesh from vertices and triangles; an error for an index out of range, a
    /// non-finite or too large coordinate, or too many of either.
    pub fn new(vertices: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh, String> {
        if vertices.len() > MAX_MESH_VERTICES {
            return Err(format!(
                "{} vertices, more than the {MAX_MESH_VERTICES} a mesh may hold (MAX_MESH_VERTICES)",
                vertices.len()
            ));
        }
        if triangles.len() > MAX_MESH_TRIANGLES {
            return Err(format!(
                "{} triangles, more than the {MAX_MESH_TRIANGLES} a mesh may hold (MAX_MESH_TRIANGLES)",
                triangles.len()
            ));
        }
        if triangles.is_empty() {
            return Err("no triangles".into());
        }
        if let Some(k) = vertices
            .iter()
            .position(|p| !p.is_finite() || p.abs().max_element() > MAX_MESH_COORD)
        {
            return Err(format!(
                "vertex {k} {:?} must be finite with every |coordinate| ≤ {MAX_MESH_COORD:e}",
                vertices[k].to_array()
            ));
        }
        if let Some(k) = triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= vertices.len()))
        {
            return Err(format!(
                "triangle {k} {:?} names a vertex beyond the {} given",
                triangles[k],
                vertices.len()
            ));
        }
        let mut m = Mesh {
            vertices,
            triangles,
            nodes: Vec::new(),
            order: Vec::new(),
        };
        m.build();
        Ok(m)
    }

    /// Reads an OBJ file (polygons triangulated; materials, normals and texture
    /// coordinates ignored), at most [`MAX_MESH_BYTES`] long; errors name the file.
    pub fn load_obj(path: &Path) -> Result<Mesh, String> {
        let bytes = read_mesh_file(path)?;
        Mesh::from_obj_bytes(&bytes).map_err(|m| format!("mesh {}: {m}", path.display()))
    }

    /// Reads a mesh file by its extension: `.obj` ([`Mesh::from_obj_bytes`]), `.gltf`
    /// or `.glb` ([`Mesh::from_gltf_bytes`]); at most [`MAX_MESH_BYTES`] long; errors
    /// name the file.
    pub fn load(path: &Path) -> Result<Mesh, String> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if ext.as_deref() == Some("obj") {
            return Mesh::load_obj(path);
        }
        let err = |m: String| format!("mesh {}: {m}", path.display());
        if !matches!(ext.as_deref(), Some("gltf" | "glb")) {
            return Err(err("not a mesh file: .obj, .gltf or .glb".into()));
        }
        let bytes = read_mesh_file(path)?;
        Mesh::from_gltf_bytes(&bytes).map_err(err)
    }

    /// Parses glTF 2.0 (JSON or binary): the triangles of every mesh the default scene
    /// (else the first) places, each in its node's world transform, in one mesh.
    /// Buffers are the binary chunk or base64 `data:` URIs; a buffer named by another
    /// URI is refused (a mesh file reads nothing beside itself). Triangle lists only
    /// (strips, fans, lines and points are refused).
    pub fn from_gltf_bytes(bytes: &[u8]) -> Result<Mesh, String> {
        // A parser panic on hostile input becomes an error, never a crash.
        std::panic::catch_unwind(|| gltf_mesh(bytes)).map_err(|_| "the glTF reader failed on this file".to_string())?
    }

    /// Parses OBJ text (see [`Mesh::load_obj`]); every object of the file in one mesh.
    pub fn from_obj_bytes(bytes: &[u8]) -> Result<Mesh, String> {
        // Counted before tobj allocates per element: vertices by their lines, triangles
        // by each face's vertex count (one line `f 1 2 3 4 …` may hold millions), with
        // tobj's own tokens (Unicode whitespace; `l` lines of 3 or more vertices are faces
        // to it too).
        let (mut nv, mut nt) = (0usize, 0usize);
        for (k, line) in bytes.split(|&b| b == b'\n').enumerate() {
            let line = String::from_utf8_lossy(line);
            let mut tokens = line.split_whitespace();
            match tokens.next() {
                Some("v") => nv += 1,
                Some(tag @ ("f" | "l")) => {
                    let corners = tokens.count();
                    if tag == "f" && corners < 3 {
                        return Err(format!(
                            "line {}: a face of {corners} vertices (a face has at least 3)",
                            k + 1
                        ));
                    }
                    nt += corners.saturating_sub(2);
                }
                _ => {}
            }
            if nv > MAX_MESH_VERTICES {
                return Err(format!(
                    "more than the {MAX_MESH_VERTICES} vertices a mesh may hold (MAX_MESH_VERTICES), by line {}",
                    k + 1
                ));
            }
            if nt > MAX_MESH_TRIANGLES {
                return Err(format!(
                    "faces of more than the {MAX_MESH_TRIANGLES} triangles a mesh may hold (MAX_MESH_TRIANGLES), \
                     by line {}",
                    k + 1
                ));
            }
        }
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        };
        let mut reader = std::io::BufReader::new(bytes);
        // A parser panic on hostile input becomes an error, never a crash.
        let loaded = std::panic::catch_unwind(move || {
            tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::MaterialParseError))
        })
        .map_err(|_| "the OBJ parser failed on this file".to_string())?;
        let (models, _) = loaded.map_err(|e| format!("not a readable OBJ file: {e}"))?;
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for m in models {
            let base = vertices.len();
            let p = &m.mesh.positions;
            if p.len() % 3 != 0 {
                return Err(format!("object {}: positions not a multiple of 3", m.name));
            }
            vertices.extend(p.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
            if m.mesh.indices.len() % 3 != 0 {
                return Err(format!("object {}: faces are not triangles", m.name));
            }
            for t in m.mesh.indices.chunks_exact(3) {
                let idx = [t[0], t[1], t[2]].map(|i| (base + i as usize).min(u32::MAX as usize) as u32);
                triangles.push(idx);
            }
            if vertices.len() > MAX_MESH_VERTICES || triangles.len() > MAX_MESH_TRIANGLES {
                break;
            }
        }
        Mesh::new(vertices, triangles)
    }

    /// This mesh under `t` (its hierarchy rebuilt).
    pub fn transformed(&self, t: &Transform) -> Result<Mesh, String> {
        Mesh::new(
            self.vertices.iter().map(|&p| t.point(p)).collect(),
            self.triangles.clone(),
        )
    }

    /// The corners of triangle `k`.
    pub fn corners(&self, k: usize) -> [DVec3; 3] {
        self.triangles[k].map(|i| self.vertices[i as usize])
    }

    /// Unit geometric normal of triangle `k` ((b − a) × (c − a), normalised).
    pub fn normal(&self, k: usize) -> DVec3 {
        let [a, b, c] = self.corners(k);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// The triangle hierarchy, node 0 the root: per node its box (min, max corner), its
    /// `first` and `count` — a leaf's triangles are `order()[first..first + count]`
    /// (count > 0), an inner node's children are nodes `first` and `first + 1` (count
    /// 0). (The device's Monte Carlo traverses the same tree.)
    pub fn hierarchy(&self) -> impl Iterator<Item = (DVec3, DVec3, usize, usize)> + '_ {
        self.nodes.iter().map(|n| (n.lo, n.hi, n.first, n.count))
    }

    /// The triangle indices the leaves' ranges refer to.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The hierarchy's depth (1: the root is a leaf).
    pub fn depth(&self) -> usize {
        let mut deepest = 0;
        let mut stack = vec![(0usize, 1usize)];
        while let Some((k, d)) = stack.pop() {
            deepest = deepest.max(d);
            let n = &self.nodes[k];
            if n.count == 0 {
                stack.extend([(n.first, d + 1), (n.first + 1, d + 1)]);
            }
        }
        deepest
    }

    /// Bounding box (min, max corner).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.nodes[0].lo, self.nodes[0].hi)
    }

    /// Signed volume Σ a·(b × c)/6 (positive for a closed mesh wound outwards).
    pub fn volume(&self) -> f64 {
        (0..self.triangles.len())
            .map(|k| {
                let [a, b, c] = self.corners(k);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// (edges that bound an odd number of triangles, all edges), with vertices at the
    /// same position taken as one (files split vertices at seams and hard edges): a
    /// closed mesh has no odd edge; a hole's rim bounds one triangle, a fin three.
    pub fn open_edges(&self) -> (usize, usize) {
        let mut at = std::collections::HashMap::<[u64; 3], u32>::with_capacity(self.vertices.len());
        let weld: Vec<u32> = self
            .vertices
            .iter()
            .enumerate()
            .map(|(i, p)| *at.entry(p.to_array().map(|c| (c + 0.0).to_bits())).or_insert(i as u32))
            .collect();
        let mut uses = std::collections::HashMap::<(u32, u32), u32>::with_capacity(3 * self.triangles.len() / 2);
        for t in &self.triangles {
            let t = t.map(|i| weld[i as usize]);
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        (uses.values().filter(|&&n| n % 2 == 1).count(), uses.len())
    }

    /// Whether the mesh bounds a solid well enough to fit spheres to it and measure
    /// the fit: at most [`MAX_OPEN_EDGES`] of its edges open (scanned meshes have
    /// small holes: the bunny 226 of 28 544, 0.8 %), and a volume that is finite and
    /// above 1e-9 of its bounding box's (the volume error divides by it). An error
    /// names what failed.
    pub fn check_solid(&self) -> Result<(), String> {
        let (open, all) = self.open_edges();
        if open as f64 > MAX_OPEN_EDGES * all as f64 {
            return Err(format!(
                "not closed: {open} of its {all} edges bound an odd number of triangles \
                 (more than {:.0} %; a mesh for a sphere set must enclose a volume)",
                100.0 * MAX_OPEN_EDGES
            ));
        }
        let (lo, hi) = self.bounds();
        let box_volume = (hi - lo).x * (hi - lo).y * (hi - lo).z;
        let v = self.volume().abs();
        if !(v.is_finite() && v > 1e-9 * box_volume && v > 0.0) {
            return Err(format!(
                "encloses no volume ({v:e} in a bounding box of {box_volume:e}): is it closed?"
            ));
        }
        Ok(())
    }

    /// The point of triangle `k` nearest to `p`.
    pub fn closest_on(&self, k: usize, p: DVec3) -> DVec3 {
        let [a, b, c] = self.corners(k);
        closest_on_triangle(p, a, b, c)
    }

    /// Total area.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|k| {
                let [a, b, c] = self.corners(k);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    fn build(&mut self) {
        let n = self.triangles.len();
        let cent: Vec<DVec3> = (0..n)
            .map(|k| {
                let [a, b, c] = self.corners(k);
                (a + b + c) / 3.0
            })
            .collect();
        self.order = (0..n as u32).collect();
        self.nodes = vec![Node {
            lo: DVec3::ZERO,
            hi: DVec3::ZERO,
            first: 0,
            count: n,
        }];
        let mut todo = vec![(0usize, 0usize, n)];
        while let Some((node, start, end)) = todo.pop() {
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for &k in &self.order[start..end] {
                for p in self.corners(k as usize) {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                clo = clo.min(cent[k as usize]);
                chi = chi.max(cent[k as usize]);
            }
            self.nodes[node].lo = lo;
            self.nodes[node].hi = hi;
            let ext = chi - clo;
            if end - start <= LEAF || ext.max_element() == 0.0 {
                self.nodes[node].first = start;
                self.nodes[node].count = end - start;
                continue;
            }
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = (start + end) / 2;
            // Ties broken by index: the hierarchy is a function of the mesh alone.
            self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
                cent[a as usize][axis]
                    .total_cmp(&cent[b as usize][axis])
                    .then(a.cmp(&b))
            });
            let first = self.nodes.len();
            self.nodes.push(self.nodes[node]);
            self.nodes.push(self.nodes[node]);
            self.nodes[node].first = first;
            self.nodes[node].count = 0;
            todo.push((first, start, mid));
            todo.push((first + 1, mid, end));
        }
    }

    /// Visits every triangle whose leaf box the ray meets before `t_max()` (read at
    /// each node, so a shrinking bound prunes).
    fn walk(&self, x: DVec3, v: DVec3, t_max: impl Fn() -> f64, mut visit: impl FnMut(usize) -> bool) {
        let inv = v.recip();
        let mut stack = Vec::with_capacity(64);
        stack.push(0usize);
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k];
            if !hits_box(n.lo, n.hi, x, inv, t_max()) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
                continue;
            }
            for &t in &self.order[n.first..n.first + n.count] {
                if visit(t as usize) {
                    return;
                }
            }
        }
    }

    /// Nearest hit (t, triangle) of x + t·v with t in (t_min, t_max), skipping
    /// triangle `skip`; ties broken by the lower triangle index.
    pub fn nearest(&self, x: DVec3, v: DVec3, t_min: f64, t_max: f64, skip: Option<usize>) -> Option<(f64, usize)> {
        let best = std::cell::Cell::new((t_max, usize::MAX));
        self.walk(
            x,
            v,
            || best.get().0,
            |k| {
                if Some(k) != skip {
                    let [a, b, c] = self.corners(k);
                    let (bt, bk) = best.get();
                    if let Some(t) = ray_triangle(x, v, a, b, c, t_min, f64::INFINITY) {
                        if t < bt || (t == bt && k < bk) {
                            best.set((t, k));
                        }
                    }
                }
                false
            },
        );
        let (t, k) = best.get();
        (k != usize::MAX).then_some((t, k))
    }

    /// Whether some triangle but `skip` meets x + t·v for t in (t_min, t_max).
    pub fn occluded(&self, x: DVec3, v: DVec3, t_min: f64, t_max: f64, skip: Option<usize>) -> bool {
        let mut hit = false;
        self.walk(
            x,
            v,
            || t_max,
            |k| {
                if Some(k) != skip {
                    let [a, b, c] = self.corners(k);
                    hit = ray_triangle(x, v, a, b, c, t_min, t_max).is_some();
                }
                hit
            },
        );
        hit
    }

    /// [`Mesh::nearest`] by a scan over every triangle (the tests' brute force).
    pub fn nearest_brute(&self, x: DVec3, v: DVec3, t_min: f64, t_max: f64) -> Option<(f64, usize)> {
        let mut best: Option<(f64, usize)> = None;
        for k in 0..self.triangles.len() {
            let [a, b, c] = self.corners(k);
            if let Some(t) = ray_triangle(x, v, a, b, c, t_min, t_max) {
                if best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, k));
                }
            }
        }
        best
    }

    /// Number of triangles the whole line's ray x + t·v, t > 0, crosses.
    fn crossings(&self, x: DVec3, v: DVec3) -> usize {
        let mut n = 0;
        self.walk(
            x,
            v,
            || f64::INFINITY,
            |k| {
                let [a, b, c] = self.corners(k);
                n += usize::from(ray_triangle(x, v, a, b, c, 0.0, f64::INFINITY).is_some());
                false
            },
        );
        n
    }

    /// Whether `p` lies inside: the majority of the crossing parities of three rays
    /// in fixed, irrational directions (exact for a closed mesh but on a set of measure
    /// zero; a small hole or a non-manifold edge flips at most one ray's parity for
    /// most points).
    pub fn inside(&self, p: DVec3) -> bool {
        const DIRS: [[f64; 3]; 3] = [
            [0.573_462_6, 0.352_173_3, 0.739_711_4],
            [-0.614_256_7, 0.711_364_8, -0.341_517_2],
            [0.262_111_4, -0.889_430_1, -0.374_424_3],
        ];
        let odd = DIRS
            .iter()
            .filter(|d| self.crossings(p, DVec3::from_array(**d).normalize()) % 2 == 1)
            .count();
        odd >= 2
    }

    /// Distance from `p` to the nearest point of the surface.
    pub fn distance(&self, p: DVec3) -> f64 {
        self.nearest_triangle(p).map_or(f64::INFINITY, |(d, _)| d)
    }

    /// The distance from `p` to the surface and a triangle at that distance (`None`
    /// for a mesh without triangles).
    pub fn nearest_triangle(&self, p: DVec3) -> Option<(f64, usize)> {
        let mut best = f64::INFINITY;
        let mut which = None;
        let mut stack = vec![0usize];
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k];
            let box_d2 = (n.lo - p).max(p - n.hi).max(DVec3::ZERO).length_squared();
            if box_d2 >= best * best {
                continue;
            }
            if n.count == 0 {
                // Nearer child last: popped first.
                let (a, b) = (&self.nodes[n.first], &self.nodes[n.first + 1]);
                let da = (a.lo - p).max(p - a.hi).max(DVec3::ZERO).length_squared();
                let db = (b.lo - p).max(p - b.hi).max(DVec3::ZERO).length_squared();
                if da < db {
                    stack.extend([n.first + 1, n.first]);
                } else {
                    stack.extend([n.first, n.first + 1]);
                }
                continue;
            }
            for &t in &self.order[n.first..n.first + n.count] {
                let [a, b, c] = self.corners(t as usize);
                let d = (closest_on_triangle(p, a, b, c) - p).length();
                if d < best {
                    (best, which) = (d, Some(t as usize));
                }
            }
        }
        which.map(|k| (best, k))
    }

    /// [`Mesh::distance`] by a scan over every triangle.
    pub fn distance_brute(&self, p: DVec3) -> f64 {
        (0..self.triangles.len())
            .map(|k| {
                let [a, b, c] = self.corners(k);
                (closest_on_triangle(p, a, b, c) - p).length()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// `n` points on the surface, uniform by area, from `rng`.
    pub fn sample_surface(&self, rng: &mut lobefit_core::rng::Rng, n: usize) -> Vec<DVec3> {
        let mut cdf = Vec::with_capacity(self.triangles.len());
        let mut acc = 0.0;
        for k in 0..self.triangles.len() {
            let [a, b, c] = self.corners(k);
            acc += 0.5 * (b - a).cross(c - a).length();
            cdf.push(acc);
        }
        (0..n)
            .map(|_| {
                let u = rng.uniform() * acc;
                let k = cdf.partition_point(|&c| c < u).min(cdf.len() - 1);
                let [a, b, c] = self.corners(k);
                let (mut s, mut t) = (rng.uniform(), rng.uniform());
                if s + t > 1.0 {
                    (s, t) = (1.0 - s, 1.0 - t);
                }
                a + s * (b - a) + t * (c - a)
            })
            .collect()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use lobefit_core::rng::Rng;

    /// A closed, outward-wound icosphere-like mesh: an octahedron subdivided `n` times
    /// and pushed onto the sphere of `radius` about `centre`.
    pub(crate) fn ball(centre: DVec3, radius: f64, n: usize) -> Mesh {
        let mut v = vec![DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z];
        let mut t: Vec<[u32; 3]> = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        for _ in 0..n {
            let mut next = Vec::new();
            for [a, b, c] in t {
                let mut mid = |i: u32, j: u32| {
                    v.push((v[i as usize] + v[j as usize]).normalize());
                    (v.len() - 1) as u32
                };
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            }
            t = next;
        }
        Mesh::new(v.into_iter().map(|p| centre + radius * p).collect(), t).unwrap()
    }

    fn random_dir(rng: &mut Rng) -> DVec3 {
        let z = rng.range(-1.0, 1.0);
        let phi = rng.range(0.0, std::f64::consts::TAU);
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// Nearest hits and shadow rays through the hierarchy equal a scan over every
    /// triangle on random rays (the bunny: 19 048 triangles).
    #[test]
    fn bvh_equals_brute_force() {
        let m = Mesh::load_obj(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/bunny.obj")).unwrap();
        let (lo, hi) = m.bounds();
        let mut rng = Rng::new(41);
        let mut hits = 0;
        for _ in 0..300 {
            let x = lo + (hi - lo) * DVec3::new(rng.range(-0.5, 1.5), rng.range(-0.5, 1.5), rng.range(-0.5, 1.5));
            // Half the rays aimed at a point in the box, half in random directions.
            let aim = lo + (hi - lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let v = if rng.uniform() < 0.5 {
                (aim - x).normalize()
            } else {
                random_dir(&mut rng)
            };
            let a = m.nearest(x, v, 0.0, f64::INFINITY, None);
            let b = m.nearest_brute(x, v, 0.0, f64::INFINITY);
            assert_eq!(a.map(|h| h.0.to_bits()), b.map(|h| h.0.to_bits()), "{x} {v}");
            let t_max = rng.range(0.0, 0.3);
            assert_eq!(
                m.occluded(x, v, 0.0, t_max, None),
                b.is_some_and(|h| h.0 < t_max),
                "{x} {v} {t_max}"
            );
            hits += usize::from(a.is_some());
            let p = x + 0.1 * v;
            assert_eq!(m.distance(p).to_bits(), m.distance_brute(p).to_bits());
        }
        assert!(hits > 80, "{hits} rays hit");
    }

    /// A subdivided octahedron's volume, area, inside test and distance against the
    /// closed forms of its ball (within its faceting).
    #[test]
    fn ball_volume_inside_and_distance() {
        let m = ball(DVec3::new(0.3, -0.2, 1.0), 2.0, 4);
        let ball_vol = 4.0 / 3.0 * std::f64::consts::PI * 8.0;
        assert!((m.volume() / ball_vol - 1.0).abs() < 0.02, "{}", m.volume());
        assert!((m.area() / (16.0 * std::f64::consts::PI) - 1.0).abs() < 0.02);
        let mut rng = Rng::new(7);
        for _ in 0..500 {
            let p = DVec3::new(0.3, -0.2, 1.0)
                + 3.0 * DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            let r = (p - DVec3::new(0.3, -0.2, 1.0)).length();
            if (r - 2.0).abs() > 0.02 {
                assert_eq!(m.inside(p), r < 2.0, "{p}");
                assert!((m.distance(p) - (r - 2.0).abs()).abs() < 0.02, "{p}");
            }
        }
    }

    /// Garbage, truncated and hostile OBJ text are errors, never panics.
    #[test]
    fn bad_obj_is_an_error() {
        let good = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        assert!(Mesh::from_obj_bytes(good).is_ok());
        for (bad, want) in [
            (&b""[..], "no triangles"),
            (b"\x00\xff\xfe garbage \x01\n", ""),
            (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", ""),
            (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9\n", ""),
            (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", ""),
            (b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", ""),
            (b"v 0 0 0\nv 1 0 1e300\nv 0 1 0\nf 1 2 3\n", "finite"),
            (b"v 0 0 0\nv 1 0 0\nv 0 1", ""),
            (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1 2/x 3\n", ""),
            (b"mtllib nothere.mtl\nusemtl a\nv 0 0\nf 1 1 1\n", ""),
        ] {
            let r = Mesh::from_obj_bytes(bad);
            assert!(r.is_err(), "{:?} loaded", String::from_utf8_lossy(bad));
            assert!(r.unwrap_err().contains(want));
        }
        // A face of fewer than 3 vertices names its line (tobj dropped it silently).
        let e = Mesh::from_obj_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2\n").unwrap_err();
        assert!(e.contains("line 6: a face of 2 vertices"), "{e}");
        // The pre-count counts a polygon's triangles, not its lines: one line of a
        // polygon of MAX_MESH_TRIANGLES + 3 vertices (before: 1 line passed and tobj
        // triangulated it, 1.05 GB for 56 MB of text).
        let mut long = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf".to_vec();
        for _ in 0..MAX_MESH_TRIANGLES + 3 {
            long.extend(b" 1");
        }
        long.push(b'\n');
        let e = Mesh::from_obj_bytes(&long).unwrap_err();
        assert!(e.contains("(MAX_MESH_TRIANGLES), by line 4"), "{e}");
        // The same polygon as an `l` line (tobj triangulates 3+ vertices there too), or
        // with vertical tabs between its indices (whitespace to tobj).
        let l = [&long[..24], b"l", &long[25..]].concat();
        assert!(Mesh::from_obj_bytes(&l).unwrap_err().contains("by line 4"));
        let vt: Vec<u8> = long.iter().map(|&b| if b == b' ' { 0x0b } else { b }).collect();
        assert!(Mesh::from_obj_bytes(&vt).unwrap_err().contains("by line 4"));
        let bunny = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/bunny.obj")).unwrap();
        for cut in [10, 1000, 100_000, 400_000, bunny.len() - 7] {
            // A cut file either loads its complete lines or is an error: no panic.
            let _ = Mesh::from_obj_bytes(&bunny[..cut]);
        }
    }

    /// A unit cube's 8 corners and 12 triangles (outward), as raw glTF buffer bytes:
    /// positions (f32 × 3) then u16 indices.
    fn cube_buffer() -> (Vec<u8>, usize) {
        let mut b = Vec::new();
        for k in 0..8u32 {
            for axis in 0..3 {
                b.extend(((k >> axis & 1) as f32).to_le_bytes());
            }
        }
        let pos_len = b.len();
        let tris: [[u16; 3]; 12] = [
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        for t in tris {
            for i in t {
                b.extend(i.to_le_bytes());
            }
        }
        (b, pos_len)
    }

    /// The glTF JSON of [`cube_buffer`] with buffer `uri` (None: the binary chunk) and
    /// the mesh's node translated by `t` and scaled by 2.
    fn cube_gltf(uri: Option<&str>, len: usize, pos_len: usize, t: [f64; 3]) -> String {
        let buffer = match uri {
            Some(u) => format!(r#"{{"byteLength": {len}, "uri": "{u}"}}"#),
            None => format!(r#"{{"byteLength": {len}}}"#),
        };
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
              "nodes": [{{"children": [1], "translation": [{}, {}, {}]}}, {{"mesh": 0, "scale": [2, 2, 2]}}],
              "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
              "buffers": [{buffer}],
              "bufferViews": [{{"buffer": 0, "byteLength": {pos_len}}},
                              {{"buffer": 0, "byteOffset": {pos_len}, "byteLength": {}}}],
              "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
                              "min": [0, 0, 0], "max": [1, 1, 1]}},
                            {{"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}}]}}"#,
            t[0],
            t[1],
            t[2],
            len - pos_len
        )
    }

    /// A GLB container of `json` and the binary chunk `bin`.
    fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
        let pad = |mut v: Vec<u8>, with: u8| {
            while !v.len().is_multiple_of(4) {
                v.push(with);
            }
            v
        };
        let (j, b) = (pad(json.as_bytes().to_vec(), b' '), pad(bin.to_vec(), 0));
        let mut out = Vec::new();
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend(((12 + 8 + j.len() + 8 + b.len()) as u32).to_le_bytes());
        out.extend((j.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(j);
        out.extend((b.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(b);
        out
    }

    /// A cube as glTF (a base64 data URI) and as GLB (the binary chunk) reads as the
    /// same mesh, placed by its nodes' transforms (a parent's translation, the mesh
    /// node's scale 2): volume 8, bounds [t, t + 2]; a buffer named by a file URI, a
    /// line primitive, an index out of range and garbage are errors, never panics.
    #[test]
    fn gltf_and_glb_read_the_same_mesh() {
        use base64::Engine as _;
        let (bin, pos_len) = cube_buffer();
        let t = [1.0, -2.0, 0.5];
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)
        );
        let a = Mesh::from_gltf_bytes(cube_gltf(Some(&uri), bin.len(), pos_len, t).as_bytes()).unwrap();
        let b = Mesh::from_gltf_bytes(&glb(&cube_gltf(None, bin.len(), pos_len, t), &bin)).unwrap();
        for m in [&a, &b] {
            assert_eq!(m.triangles.len(), 12);
            assert!((m.volume() - 8.0).abs() < 1e-12, "{}", m.volume());
            let (lo, hi) = m.bounds();
            assert!((lo - DVec3::from(t)).abs().max_element() < 1e-12, "{lo}");
            assert!(
                (hi - DVec3::from(t) - DVec3::splat(2.0)).abs().max_element() < 1e-12,
                "{hi}"
            );
        }
        assert_eq!(a.vertices, b.vertices);
        assert_eq!(a.triangles, b.triangles);
        let file = cube_gltf(Some("cube.bin"), bin.len(), pos_len, t);
        let e = Mesh::from_gltf_bytes(file.as_bytes()).unwrap_err();
        assert!(e.contains("only embedded buffers"), "{e}");
        let lines =
            cube_gltf(Some(&uri), bin.len(), pos_len, t).replace(r#""indices": 1}"#, r#""indices": 1, "mode": 1}"#);
        let e = Mesh::from_gltf_bytes(lines.as_bytes()).unwrap_err();
        assert!(e.contains("triangles only"), "{e}");
        let mut bad = bin.clone();
        bad[pos_len] = 9; // the first index: vertex 9 of 8
        let e = Mesh::from_gltf_bytes(&glb(&cube_gltf(None, bad.len(), pos_len, t), &bad)).unwrap_err();
        assert!(e.contains("index 9 beyond"), "{e}");
        let short = &bin[..bin.len() - 8];
        let e = Mesh::from_gltf_bytes(&glb(&cube_gltf(None, bin.len(), pos_len, t), short)).unwrap_err();
        assert!(!e.is_empty());
        for junk in [&b"glTF"[..], b"{}", b"", &[0xff; 64]] {
            assert!(Mesh::from_gltf_bytes(junk).is_err());
        }
    }
}
