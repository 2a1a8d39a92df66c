//! Skinned glTF meshes: a glTF 2.0 skin (joints, inverse bind matrices, `JOINTS_0`
//! and `WEIGHTS_0`) posed by one of the file's animations (translation, rotation and
//! scale channels on any node, `LINEAR` or `STEP`), by linear blend skinning:
//!
//! v(t) = Σₖ wₖ · G_{jₖ}(t) · B_{jₖ} · v,
//!
//! with v the vertex as stored (the bind pose), G_j(t) the world transform of joint
//! j's node at t (its ancestors' animated local transforms composed) and B_j its
//! inverse bind matrix. As glTF 2.0 §3.7.3 says, the skinned mesh node's own
//! transform is ignored.
//!
//! A mesh's sphere set (fitted on the bind pose) is carried by the joints as the
//! engines' capsule shadows are: each sphere takes the mean of the weights of the
//! [`SPHERE_INFLUENCE_VERTICES`] bind-pose vertices nearest its centre and its centre
//! moves by the same blend (a sphere inside one bone's part moves rigidly with that
//! bone; one across a joint moves with both); its radius is kept.
//!
//! The scene's time τ in [0, 1] plays the animation once: its time is
//! start + τ (end − start), start and end its first and last key.
//!
//! `CUBICSPLINE` samplers and morph-target (`weights`) channels are refused by name;
//! so are weights that are not f32, do not sum to 1 within 1e-3, or name a joint the
//! skin does not have.

use std::path::Path;

use lobefit_tables::glam::{DMat4, DQuat, DVec3};

use crate::mesh::{check_accessor, gltf_document, gltf_mesh_of, gltf_nodes, Mesh, Transform};

/// Most joints a skin may have.
pub const MAX_JOINTS: usize = 1024;
/// Most channels an animation may have.
pub const MAX_CHANNELS: usize = 4096;
/// Most keys a sampler may have.
pub const MAX_SAMPLER_KEYS: usize = 1 << 16;
/// Most keys an animation's channels may hold together (channels may share one
/// sampler's accessor, so the file's size alone does not bound them).
pub const MAX_ANIMATION_KEYS: usize = 1 << 20;
/// How many nearest bind-pose vertices give a sphere its weights.
pub const SPHERE_INFLUENCE_VERTICES: usize = 8;
/// How far a vertex's weights may sum from 1 (glTF's exporters write f32 weights).
const WEIGHT_SUM_TOLERANCE: f64 = 1e-3;

/// What a channel animates.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Target {
    Translation,
    Rotation,
    Scale,
}

/// One animation channel: a node's translation, rotation or scale at keyed times.
#[derive(Debug, Clone)]
struct Channel {
    node: usize,
    path: Target,
    step: bool,
    /// (time, value) keys: xyz (translation, scale) or xyzw (rotation, normalised).
    keys: Vec<(f64, [f64; 4])>,
}

impl Channel {
    /// The value at `t`: the scene tracks' keying (`scene::keyed`: held before the
    /// first key and after the last), held between keys for `STEP`, slerped for
    /// rotations.
    fn at(&self, t: f64) -> [f64; 4] {
        crate::scene::keyed(&self.keys, t, |a, b, u| match (self.step, self.path) {
            (true, _) => a,
            (false, Target::Rotation) => DQuat::from_array(a).slerp(DQuat::from_array(b), u).to_array(),
            (false, _) => std::array::from_fn(|k| a[k] + (b[k] - a[k]) * u),
        })
    }
}

/// A glTF skin with one animation: what poses a skinned mesh at any time.
#[derive(Debug, Clone)]
pub struct Skin {
    /// Each node's parent (the scene's tree).
    parent: Vec<Option<usize>>,
    /// Nodes in an order that puts every parent before its children.
    order: Vec<usize>,
    /// Each node's rest (translation, rotation, scale).
    rest: Vec<(DVec3, DQuat, DVec3)>,
    /// The skin's joints (node indices) and their inverse bind matrices.
    joints: Vec<usize>,
    inverse_bind: Vec<DMat4>,
    /// Per vertex of the bind-pose mesh: (joint, weight) pairs, weights summing to 1.
    influences: Vec<Vec<(u16, f64)>>,
    channels: Vec<Channel>,
    /// The animation's first and last key time (s).
    span: (f64, f64),
    /// The animation's name (or `#index`).
    pub animation: String,
}

impl Skin {
    /// Reads a skinned mesh (`.gltf` or `.glb`, as [`Mesh::load`] reads files) and its
    /// animation `animation` (a name, or `None` for the first): the mesh in its bind
    /// pose and the skin. Errors name the file and the field.
    pub fn load(path: &Path, animation: Option<&str>) -> Result<(Mesh, Skin), String> {
        let err = |m: String| format!("mesh {}: {m}", path.display());
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("gltf" | "glb")) {
            return Err(err("a skinned mesh is a glTF file (.gltf or .glb)".into()));
        }
        let bytes = lobefit_core::io::read_bytes(path, crate::mesh::MAX_MESH_BYTES, "MAX_MESH_BYTES").map_err(&err)?;
        Skin::from_gltf_bytes(&bytes, animation).map_err(err)
    }

    /// [`Skin::load`] on a file's bytes; never panics.
    pub fn from_gltf_bytes(bytes: &[u8], animation: Option<&str>) -> Result<(Mesh, Skin), String> {
        std::panic::catch_unwind(|| skinned(bytes, animation))
            .map_err(|_| "the glTF reader failed on this file".to_string())?
    }

    /// The animation's time (s) at the scene's time `tau` (in [0, 1]).
    pub fn time(&self, tau: f64) -> f64 {
        self.span.0 + tau.clamp(0.0, 1.0) * (self.span.1 - self.span.0)
    }

    /// Each joint's skinning matrix G_j(t) B_j at the scene's time `tau`.
    pub fn joint_matrices(&self, tau: f64) -> Vec<DMat4> {
        let t = self.time(tau);
        let mut local = self.rest.clone();
        for c in &self.channels {
            let v = c.at(t);
            let l = &mut local[c.node];
            match c.path {
                Target::Translation => l.0 = DVec3::new(v[0], v[1], v[2]),
                Target::Rotation => l.1 = DQuat::from_array(v).normalize(),
                Target::Scale => l.2 = DVec3::new(v[0], v[1], v[2]),
            }
        }
        let mut world = vec![DMat4::IDENTITY; self.parent.len()];
        for &n in &self.order {
            let (tr, r, s) = local[n];
            let m = DMat4::from_scale_rotation_translation(s, r, tr);
            world[n] = self.parent[n].map_or(m, |p| world[p] * m);
        }
        self.joints
            .iter()
            .zip(&self.inverse_bind)
            .map(|(&j, b)| world[j] * *b)
            .collect()
    }

    /// The bind-pose vertex `v` with `influences`, skinned by `matrices`.
    fn blend(matrices: &[DMat4], influences: &[(u16, f64)], v: DVec3) -> DVec3 {
        influences
            .iter()
            .map(|&(j, w)| w * matrices[j as usize].transform_point3(v))
            .sum()
    }

    /// The bind-pose vertices `bind` (in the order read) skinned at `tau`.
    pub fn vertices(&self, bind: &[DVec3], tau: f64) -> Vec<DVec3> {
        Skin::blend_all(&self.joint_matrices(tau), bind, &self.influences)
    }

    /// `points` with their `influences`, skinned by `matrices`.
    fn blend_all(matrices: &[DMat4], points: &[DVec3], influences: &[Vec<(u16, f64)>]) -> Vec<DVec3> {
        points
            .iter()
            .zip(influences)
            .map(|(&p, inf)| Skin::blend(matrices, inf, p))
            .collect()
    }

    /// The weights of each of `centres` (bind pose, the mesh's units): the mean of the
    /// weights of the [`SPHERE_INFLUENCE_VERTICES`] vertices of `bind` nearest it.
    pub fn sphere_influences(&self, bind: &[DVec3], centres: &[DVec3]) -> Vec<Vec<(u16, f64)>> {
        use rayon::prelude::*;
        let k = SPHERE_INFLUENCE_VERTICES.min(bind.len());
        centres
            .par_iter()
            .map(|&c| {
                let mut near: Vec<(f64, usize)> = bind
                    .iter()
                    .enumerate()
                    .map(|(i, v)| (v.distance_squared(c), i))
                    .collect();
                near.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                let mut sum = vec![0.0; self.joints.len()];
                for &(_, i) in &near[..k] {
                    for &(j, w) in &self.influences[i] {
                        sum[j as usize] += w / k as f64;
                    }
                }
                sum.iter()
                    .enumerate()
                    .filter(|(_, &w)| w > 0.0)
                    .map(|(j, &w)| (j as u16, w))
                    .collect()
            })
            .collect()
    }

    /// Centres (bind pose) with their `influences` skinned at `tau`.
    pub fn centres(&self, centres: &[DVec3], influences: &[Vec<(u16, f64)>], tau: f64) -> Vec<DVec3> {
        Skin::blend_all(&self.joint_matrices(tau), centres, influences)
    }
}

/// A skinned mesh of a scene: the skin, the bind pose in the file's units, the
/// scene's placement of the file, and its sphere set's bind-pose centres and weights.
#[derive(Debug, Clone)]
pub struct Skinned {
    /// The skin and its animation.
    pub skin: Skin,
    /// The mesh's vertices as stored (the bind pose, the file's units).
    pub bind: Vec<DVec3>,
    /// The scene's transform of the file (applied after skinning).
    pub transform: Transform,
    /// The sphere set's centres in the bind pose (the file's units).
    pub set_centres: Vec<DVec3>,
    /// Their weights ([`Skin::sphere_influences`]).
    pub set_influences: Vec<Vec<(u16, f64)>>,
}

impl Skinned {
    /// The skinned mesh `bind` with its sphere set's bind-pose centres, placed by
    /// `transform`.
    pub fn new(skin: Skin, bind: Vec<DVec3>, transform: Transform, set_centres: Vec<DVec3>) -> Skinned {
        let set_influences = skin.sphere_influences(&bind, &set_centres);
        Skinned {
            skin,
            bind,
            transform,
            set_centres,
            set_influences,
        }
    }

    /// The mesh's vertices and its sphere centres at the scene's time `tau`, in the
    /// scene's coordinates.
    pub fn at(&self, tau: f64) -> (Vec<DVec3>, Vec<DVec3>) {
        // One evaluation of the joints for the mesh and its set.
        let m = self.skin.joint_matrices(tau);
        let place = |v: Vec<DVec3>| v.into_iter().map(|p| self.transform.point(p)).collect();
        (
            place(Skin::blend_all(&m, &self.bind, &self.skin.influences)),
            place(Skin::blend_all(&m, &self.set_centres, &self.set_influences)),
        )
    }
}

/// [`Skin::from_gltf_bytes`] (may panic on hostile input: called under catch_unwind).
fn skinned(bytes: &[u8], animation: Option<&str>) -> Result<(Mesh, Skin), String> {
    use gltf::accessor::{DataType, Dimensions};
    let (doc, buffers) = gltf_document(bytes)?;
    let mesh = gltf_mesh_of(&doc, &buffers)?;
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or("no scene")?;
    let walked = gltf_nodes(&doc, &scene)?;
    let n = doc.nodes().len();
    let mut parent = vec![None; n];
    for node in doc.nodes() {
        for c in node.children() {
            parent[c.index()] = Some(node.index());
        }
    }
    let order: Vec<usize> = walked.iter().map(|(node, _)| node.index()).collect();
    let mut in_scene = vec![false; n];
    for &i in &order {
        in_scene[i] = true;
    }
    let rest = doc
        .nodes()
        .map(|node| {
            let (t, r, s) = node.transform().decomposed();
            (
                DVec3::from(t.map(f64::from)),
                DQuat::from_array(r.map(f64::from)).normalize(),
                DVec3::from(s.map(f64::from)),
            )
        })
        .collect::<Vec<(DVec3, DQuat, DVec3)>>();
    if let Some(k) = rest
        .iter()
        .position(|(t, r, s)| !(t.is_finite() && r.is_finite() && s.is_finite()))
    {
        return Err(format!(
            "nodes[{k}]: a transform that is not finite (or a zero rotation)"
        ));
    }
    // The one skinned mesh node: the mesh's vertices are its primitives' (in order).
    let meshes: Vec<_> = walked.iter().filter(|(node, _)| node.mesh().is_some()).collect();
    let [(node, _)] = meshes.as_slice() else {
        return Err(format!(
            "{} nodes with a mesh: a skinned file has one (its mesh, skinned)",
            meshes.len()
        ));
    };
    let skin = node
        .skin()
        .ok_or_else(|| format!("node {} has a mesh but no skin", node.index()))?;
    let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
    if joints.is_empty() || joints.len() > MAX_JOINTS {
        return Err(format!(
            "skins[{}]: {} joints; a skin has 1 to {MAX_JOINTS} (MAX_JOINTS)",
            skin.index(),
            joints.len()
        ));
    }
    if let Some(j) = joints.iter().find(|&&j| !in_scene[j]) {
        return Err(format!("skins[{}]: joint node {j} is not in the scene", skin.index()));
    }
    let inverse_bind = match skin.inverse_bind_matrices() {
        None => vec![DMat4::IDENTITY; joints.len()],
        Some(a) => {
            check_accessor(&a, "inverseBindMatrices", &[DataType::F32], Dimensions::Mat4, &buffers)?;
            if a.count() < joints.len() {
                return Err(format!(
                    "skins[{}]: {} inverse bind matrices for {} joints",
                    skin.index(),
                    a.count(),
                    joints.len()
                ));
            }
            let reader = skin.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let m: Vec<DMat4> = reader
                .read_inverse_bind_matrices()
                .ok_or("no inverse bind matrices")?
                .take(joints.len())
                .map(|m| lobefit_tables::glam::Mat4::from_cols_array_2d(&m).as_dmat4())
                .collect();
            if let Some(k) = m.iter().position(|m| !m.is_finite()) {
                return Err(format!(
                    "skins[{}]: inverse bind matrix {k} is not finite",
                    skin.index()
                ));
            }
            m
        }
    };
    let mut influences = Vec::with_capacity(mesh.vertices.len());
    for p in node.mesh().expect("filtered").primitives() {
        let at = |what: &str| format!("mesh {}: {what}", p.index());
        let j = p
            .get(&gltf::Semantic::Joints(0))
            .ok_or_else(|| at("a primitive without JOINTS_0"))?;
        let w = p
            .get(&gltf::Semantic::Weights(0))
            .ok_or_else(|| at("a primitive without WEIGHTS_0"))?;
        check_accessor(
            &j,
            "JOINTS_0",
            &[DataType::U8, DataType::U16],
            Dimensions::Vec4,
            &buffers,
        )?;
        check_accessor(
            &w,
            "WEIGHTS_0 (f32 weights)",
            &[DataType::F32],
            Dimensions::Vec4,
            &buffers,
        )?;
        let count = p.get(&gltf::Semantic::Positions).map_or(0, |a| a.count());
        if j.count() != count || w.count() != count {
            return Err(at(&format!(
                "JOINTS_0 has {}, WEIGHTS_0 {} elements for {count} positions",
                j.count(),
                w.count()
            )));
        }
        let reader = p.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let js = reader
            .read_joints(0)
            .ok_or_else(|| at("JOINTS_0 unreadable"))?
            .into_u16();
        let ws = reader
            .read_weights(0)
            .ok_or_else(|| at("WEIGHTS_0 unreadable"))?
            .into_f32();
        for (k, (jv, wv)) in js.zip(ws).enumerate() {
            let wv = wv.map(f64::from);
            let sum: f64 = wv.iter().sum();
            if wv.iter().any(|w| !w.is_finite() || *w < 0.0) || (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE {
                return Err(at(&format!(
                    "vertex {k}: weights {wv:?} must be finite, ≥ 0 and sum to 1 (within {WEIGHT_SUM_TOLERANCE:e})"
                )));
            }
            let mut inf = Vec::new();
            for (&jj, &ww) in jv.iter().zip(&wv) {
                if ww == 0.0 {
                    continue;
                }
                if jj as usize >= joints.len() {
                    return Err(at(&format!(
                        "vertex {k}: joint {jj}, beyond the skin's {} joints",
                        joints.len()
                    )));
                }
                inf.push((jj, ww / sum));
            }
            influences.push(inf);
        }
    }
    if influences.len() != mesh.vertices.len() {
        return Err(format!(
            "{} weighted vertices for the mesh's {}",
            influences.len(),
            mesh.vertices.len()
        ));
    }
    let anim = match animation {
        None => doc.animations().next().ok_or("no animation to pose the skin")?,
        Some(name) => doc
            .animations()
            .find(|a| a.name() == Some(name))
            .ok_or_else(|| format!("no animation named {name:?}"))?,
    };
    let anim_name = anim.name().map_or(format!("#{}", anim.index()), str::to_string);
    let at = |what: String| format!("animations[{}]: {what}", anim.index());
    if anim.channels().count() > MAX_CHANNELS {
        return Err(at(format!("more than {MAX_CHANNELS} channels (MAX_CHANNELS)")));
    }
    let mut channels = Vec::new();
    let mut keys = 0usize;
    for (c, ch) in anim.channels().enumerate() {
        let target = ch.target();
        let node = target.node().index();
        if !in_scene[node] {
            return Err(at(format!("channels[{c}] animates node {node}, not in the scene")));
        }
        let (path, dims) = match target.property() {
            gltf::animation::Property::Translation => (Target::Translation, Dimensions::Vec3),
            gltf::animation::Property::Rotation => (Target::Rotation, Dimensions::Vec4),
            gltf::animation::Property::Scale => (Target::Scale, Dimensions::Vec3),
            gltf::animation::Property::MorphTargetWeights => {
                return Err(at(format!(
                    "channels[{c}] animates morph-target weights, which are not read"
                )))
            }
        };
        let sampler = ch.sampler();
        let step = match sampler.interpolation() {
            gltf::animation::Interpolation::Linear => false,
            gltf::animation::Interpolation::Step => true,
            gltf::animation::Interpolation::CubicSpline => {
                return Err(at(format!(
                    "channels[{c}]: CUBICSPLINE interpolation is not read (LINEAR or STEP)"
                )))
            }
        };
        let (input, output) = (sampler.input(), sampler.output());
        check_accessor(
            &input,
            "a sampler's input",
            &[DataType::F32],
            Dimensions::Scalar,
            &buffers,
        )?;
        check_accessor(&output, "a sampler's output (f32)", &[DataType::F32], dims, &buffers)?;
        if input.count() != output.count() || input.count() > MAX_SAMPLER_KEYS {
            return Err(at(format!(
                "channels[{c}]: {} input and {} output keys (equal, at most {MAX_SAMPLER_KEYS}: MAX_SAMPLER_KEYS)",
                input.count(),
                output.count()
            )));
        }
        keys += input.count();
        if keys > MAX_ANIMATION_KEYS {
            return Err(at(format!(
                "channels[..={c}] hold more than {MAX_ANIMATION_KEYS} keys together (MAX_ANIMATION_KEYS)"
            )));
        }
        let reader = ch.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let times: Vec<f64> = reader.read_inputs().ok_or("unreadable input")?.map(f64::from).collect();
        if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
            return Err(at(format!("channels[{c}]: key times must be finite and increase")));
        }
        let values: Vec<[f64; 4]> = match reader.read_outputs().ok_or("unreadable output")? {
            gltf::animation::util::ReadOutputs::Translations(v) | gltf::animation::util::ReadOutputs::Scales(v) => v
                .map(|x| [f64::from(x[0]), f64::from(x[1]), f64::from(x[2]), 0.0])
                .collect(),
            gltf::animation::util::ReadOutputs::Rotations(r) => r
                .into_f32()
                .map(|q| q.map(f64::from))
                .map(|q| DQuat::from_array(q).normalize().to_array())
                .collect(),
            gltf::animation::util::ReadOutputs::MorphTargetWeights(_) => unreachable!("refused above"),
        };
        if values.iter().any(|v| !v.iter().all(|x| x.is_finite())) {
            return Err(at(format!(
                "channels[{c}]: a key's value is not finite (or a rotation is zero)"
            )));
        }
        channels.push(Channel {
            node,
            path,
            step,
            keys: times.into_iter().zip(values).collect(),
        });
    }
    let lo = channels.iter().map(|c| c.keys[0].0).fold(f64::INFINITY, f64::min);
    let hi = channels
        .iter()
        .map(|c| c.keys[c.keys.len() - 1].0)
        .fold(f64::NEG_INFINITY, f64::max);
    let span = if channels.is_empty() { (0.0, 0.0) } else { (lo, hi) };
    Ok((
        mesh,
        Skin {
            parent,
            order,
            rest,
            joints,
            inverse_bind,
            influences,
            channels,
            span,
            animation: anim_name,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's 8 corners on the y axis' two bones: root at the origin, child
    /// at (0, 1, 0); the corners at y = 0 weigh (1, 0), those at y = 1 (0.25, 0.75).
    /// The animation "bend" (keys at 2 s and 4 s) turns the child about z by 0 then
    /// `angle` and moves the root by (0, 0, 0) then `shift`; `interp` its samplers'
    /// interpolation; `weights` overrides the upper corners' weights.
    fn two_bone(angle: f32, shift: [f32; 3], interp: &str, upper: [f32; 2]) -> Vec<u8> {
        use base64::Engine as _;
        let mut b: Vec<u8> = Vec::new();
        let corners: Vec<[f32; 3]> = (0..8)
            .map(|i| [(i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2 & 1) as f32])
            .collect();
        for c in &corners {
            c.iter().for_each(|x| b.extend(x.to_le_bytes()));
        }
        let idx: [u16; 36] = [
            0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5,
        ];
        idx.iter().for_each(|i| b.extend(i.to_le_bytes()));
        for c in &corners {
            b.extend([0u8, 1, 0, 0]);
            let w = if c[1] > 0.5 {
                [upper[0], upper[1], 0.0, 0.0]
            } else {
                [1.0, 0.0, 0.0, 0.0]
            };
            w.iter().for_each(|x| b.extend(x.to_le_bytes()));
        }
        // Inverse bind matrices: identity, and a translation by (0, -1, 0).
        let ibm: [[f32; 16]; 2] = [
            [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.],
            [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., -1., 0., 1.],
        ];
        ibm.iter().flatten().for_each(|x| b.extend(x.to_le_bytes()));
        [2.0f32, 4.0].iter().for_each(|x| b.extend(x.to_le_bytes()));
        let (s, c) = ((angle / 2.0).sin(), (angle / 2.0).cos());
        [0., 0., 0., 1., 0., 0., s, c]
            .iter()
            .for_each(|x: &f32| b.extend(x.to_le_bytes()));
        [0., 0., 0., shift[0], shift[1], shift[2]]
            .iter()
            .for_each(|x: &f32| b.extend(x.to_le_bytes()));
        // Offsets: positions 0 (96), indices 96 (72), then per vertex joints 4 + weights
        // 16 interleaved at 168 (160), matrices 328 (128), times 456 (8), rotations 464
        // (32), translations 496 (24).
        let uri = base64::engine::general_purpose::STANDARD.encode(&b);
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 2]}}],
              "nodes": [{{"children": [1]}}, {{"translation": [0, 1, 0]}}, {{"mesh": 0, "skin": 0, "translation": [5, 5, 5]}}],
              "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3}}, "indices": 1}}]}}],
              "skins": [{{"joints": [0, 1], "inverseBindMatrices": 4}}],
              "animations": [{{"name": "bend", "samplers": [
                  {{"input": 5, "output": 6, "interpolation": "{interp}"}},
                  {{"input": 5, "output": 7, "interpolation": "{interp}"}}],
                "channels": [{{"sampler": 0, "target": {{"node": 1, "path": "rotation"}}}},
                             {{"sampler": 1, "target": {{"node": 0, "path": "translation"}}}}]}}],
              "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{uri}"}}],
              "bufferViews": [{{"buffer": 0, "byteLength": 96}}, {{"buffer": 0, "byteOffset": 96, "byteLength": 72}},
                              {{"buffer": 0, "byteOffset": 168, "byteLength": 160, "byteStride": 20}},
                              {{"buffer": 0, "byteOffset": 328, "byteLength": 128}},
                              {{"buffer": 0, "byteOffset": 456, "byteLength": 64}}],
              "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]}},
                            {{"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}},
                            {{"bufferView": 2, "componentType": 5121, "count": 8, "type": "VEC4"}},
                            {{"bufferView": 2, "byteOffset": 4, "componentType": 5126, "count": 8, "type": "VEC4"}},
                            {{"bufferView": 3, "componentType": 5126, "count": 2, "type": "MAT4"}},
                            {{"bufferView": 4, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [2], "max": [4]}},
                            {{"bufferView": 4, "byteOffset": 8, "componentType": 5126, "count": 2, "type": "VEC4"}},
                            {{"bufferView": 4, "byteOffset": 40, "componentType": 5126, "count": 2, "type": "VEC3"}}]}}"#,
            b.len()
        )
        .into_bytes()
    }

    /// The corners posed by the formula, computed here by hand: at the scene's time
    /// 0.5 (the animation's 3 s, half way) the child has turned by angle/2 about z at
    /// (0, 1, 0) and everything moved by shift/2. A lower corner p moves by shift/2;
    /// an upper one to shift/2 + 0.25 p + 0.75 ((0, 1, 0) + Rz(angle/2) (p − (0, 1, 0))).
    /// The mesh node's own transform (a translation by 5) is ignored, as glTF says.
    #[test]
    fn a_two_bone_skin_poses_its_vertices_by_the_blend() {
        let (angle, shift) = (1.2f32, [0.5f32, 0.0, -0.25]);
        let (mesh, skin) = Skin::from_gltf_bytes(&two_bone(angle, shift, "LINEAR", [0.25, 0.75]), None).unwrap();
        assert_eq!(skin.animation, "bend");
        assert_eq!(
            mesh.bounds(),
            (DVec3::ZERO, DVec3::ONE),
            "the bind pose, not moved by the node"
        );
        let half = DVec3::new(0.25, 0.0, -0.125);
        let a = f64::from(angle) / 2.0;
        let posed = skin.vertices(&mesh.vertices, 0.5);
        for (p, q) in mesh.vertices.iter().zip(&posed) {
            let want = if p.y < 0.5 {
                *p + half
            } else {
                let d = *p - DVec3::Y;
                let turned = DVec3::Y + DVec3::new(a.cos() * d.x - a.sin() * d.y, a.sin() * d.x + a.cos() * d.y, d.z);
                half + 0.25 * *p + 0.75 * turned
            };
            assert!((want - *q).length() < 1e-6, "{p} → {q}, want {want}");
        }
        // Before the first key and after the last, the keys' values hold; τ = 0 is the
        // first key, τ = 1 the last.
        assert_eq!(skin.vertices(&mesh.vertices, 0.0), mesh.vertices);
        let end = skin.vertices(&mesh.vertices, 1.0);
        assert!((end[0] - DVec3::new(0.5, 0.0, -0.25)).length() < 1e-6, "{}", end[0]);
        // STEP holds the earlier key up to the next.
        let (_, step) = Skin::from_gltf_bytes(&two_bone(angle, shift, "STEP", [0.25, 0.75]), None).unwrap();
        assert_eq!(step.vertices(&mesh.vertices, 0.99), mesh.vertices);
    }

    /// A sphere's centre takes its nearest vertices' mean weights: the cube's centre
    /// is nearest all 8 corners (4 lower, 4 upper), so its weights are (0.625, 0.375),
    /// and it moves by that blend.
    #[test]
    fn a_sphere_moves_with_its_nearest_vertices_weights() {
        let (mesh, skin) = Skin::from_gltf_bytes(&two_bone(1.0, [0.0; 3], "LINEAR", [0.25, 0.75]), None).unwrap();
        let c = DVec3::splat(0.5);
        let inf = skin.sphere_influences(&mesh.vertices, &[c]);
        assert_eq!(inf[0].len(), 2);
        assert!(
            (inf[0][0].1 - 0.625).abs() < 1e-12 && (inf[0][1].1 - 0.375).abs() < 1e-12,
            "{inf:?}"
        );
        let m = skin.joint_matrices(1.0);
        let want = 0.625 * m[0].transform_point3(c) + 0.375 * m[1].transform_point3(c);
        assert!((skin.centres(&[c], &inf, 1.0)[0] - want).length() < 1e-12);
    }

    /// Inputs the skin cannot take are errors naming what is wrong; a byte string cut
    /// or changed anywhere never panics.
    #[test]
    fn bad_skins_are_errors_and_never_panics() {
        let bytes = |f: &dyn Fn(&str) -> String| {
            f(&String::from_utf8(two_bone(1.0, [0.0; 3], "LINEAR", [0.25, 0.75])).unwrap())
        };
        let cases: [(String, &str); 5] = [
            (bytes(&|s| s.replace("\"LINEAR\"", "\"CUBICSPLINE\"")), "CUBICSPLINE"),
            (
                bytes(&|s| s.replace("\"path\": \"rotation\"", "\"path\": \"weights\"")),
                "morph-target",
            ),
            (bytes(&|s| s.replace(", \"skin\": 0", "")), "no skin"),
            (
                bytes(&|s| s.replace("\"joints\": [0, 1]", "\"joints\": [0]")),
                "beyond the skin's 1 joints",
            ),
            (
                bytes(&|s| s[..s.find("\"animations\"").unwrap()].to_string() + &s[s.find("\"buffers\"").unwrap()..]),
                "no animation",
            ),
        ];
        for (text, want) in &cases {
            let e = Skin::from_gltf_bytes(text.as_bytes(), None).unwrap_err();
            assert!(e.contains(want), "{want}: {e}");
        }
        // A zero rest rotation (no rotation at all) on a joint.
        let e = Skin::from_gltf_bytes(
            bytes(&|s| {
                s.replace(
                    "{\"translation\": [0, 1, 0]}",
                    "{\"translation\": [0, 1, 0], \"rotation\": [0, 0, 0, 0]}",
                )
            })
            .as_bytes(),
            None,
        )
        .unwrap_err();
        assert!(e.contains("nodes[1]: a transform that is not finite"), "{e}");
        // Keys bounded across channels: 16 more channels share one sampler of
        // MAX_SAMPLER_KEYS keys (times 0, 1, 2, …; the translations alias the times),
        // 2 + 2 + 16 · 2¹⁶ keys in all, one channel past MAX_ANIMATION_KEYS.
        let mut doc: serde_json::Value =
            serde_json::from_slice(&two_bone(1.0, [0.0; 3], "LINEAR", [0.25, 0.75])).unwrap();
        let keys = MAX_SAMPLER_KEYS;
        let mut data: Vec<u8> = (0..keys).flat_map(|k| (k as f32).to_le_bytes()).collect();
        data.resize(12 * keys, 0);
        let push = |doc: &mut serde_json::Value, list: &str, v: serde_json::Value| {
            doc.pointer_mut(list).unwrap().as_array_mut().unwrap().push(v)
        };
        use base64::Engine as _;
        let uri = base64::engine::general_purpose::STANDARD.encode(&data);
        push(
            &mut doc,
            "/buffers",
            serde_json::json!({"byteLength": data.len(),
            "uri": format!("data:application/octet-stream;base64,{uri}")}),
        );
        push(
            &mut doc,
            "/bufferViews",
            serde_json::json!({"buffer": 1, "byteLength": data.len()}),
        );
        push(
            &mut doc,
            "/accessors",
            serde_json::json!({"bufferView": 5, "componentType": 5126,
            "count": keys, "type": "SCALAR", "min": [0], "max": [keys - 1]}),
        );
        push(
            &mut doc,
            "/accessors",
            serde_json::json!({"bufferView": 5, "componentType": 5126,
            "count": keys, "type": "VEC3"}),
        );
        push(
            &mut doc,
            "/animations/0/samplers",
            serde_json::json!({"input": 8, "output": 9}),
        );
        for _ in 0..16 {
            push(
                &mut doc,
                "/animations/0/channels",
                serde_json::json!({"sampler": 2, "target": {"node": 0, "path": "translation"}}),
            );
        }
        let e = Skin::from_gltf_bytes(doc.to_string().as_bytes(), None).unwrap_err();
        assert!(
            e.contains("channels[..=17] hold more than 1048576 keys together (MAX_ANIMATION_KEYS)"),
            "{e}"
        );
        let e = Skin::from_gltf_bytes(&two_bone(1.0, [0.0; 3], "LINEAR", [0.5, 0.75]), None).unwrap_err();
        assert!(e.contains("sum to 1"), "{e}");
        let e = Skin::from_gltf_bytes(&two_bone(1.0, [0.0; 3], "LINEAR", [0.25, 0.75]), Some("walk")).unwrap_err();
        assert!(e.contains("no animation named \"walk\""), "{e}");
        let good = two_bone(1.0, [0.0; 3], "LINEAR", [0.25, 0.75]);
        for k in (0..good.len()).step_by(7) {
            let _ = Skin::from_gltf_bytes(&good[..k], None);
            let mut b = good.clone();
            b[k] = b[k].wrapping_add(13);
            if let Ok((m, s)) = Skin::from_gltf_bytes(&b, None) {
                assert!(s.vertices(&m.vertices, 0.3).iter().all(|v| v.is_finite()));
            }
        }
    }

    /// The walking mannequin (assets/meshes/walker.gltf) carries its 64-sphere set
    /// with it: in every pose of the walk, the carried centres lie inside the posed
    /// mesh as they did in the bind pose (the inside test on the posed triangles,
    /// independent of the carrying rule), and no vertex leaves the walk's reach.
    #[test]
    fn the_walker_carries_its_sphere_set_inside_it() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/walker.gltf");
        let (mesh, skin) = Skin::load(&path, Some("walk")).unwrap();
        let set = crate::spheres::fit_with(&mesh, 64, crate::spheres::Method::Optimize, 1, None).unwrap();
        let centres: Vec<DVec3> = set.iter().map(|s| s.centre).collect();
        let inside_at_bind = centres.iter().filter(|&&c| mesh.inside(c)).count();
        let skinned = Skinned::new(skin, mesh.vertices.clone(), Transform::IDENTITY, centres);
        for tau in [0.0, 0.25, 0.5, 0.75] {
            let (v, c) = skinned.at(tau);
            let posed = Mesh::new(v, mesh.triangles.clone()).unwrap();
            let inside = c.iter().filter(|&&c| posed.inside(c)).count();
            assert_eq!(
                inside,
                inside_at_bind,
                "τ = {tau}: {inside} of {} centres inside",
                c.len()
            );
            let (lo, hi) = posed.bounds();
            assert!(lo.y > 0.0 && hi.y < 1.9 && hi.z - lo.z < 1.0, "τ = {tau}: {lo} – {hi}");
        }
    }
}
