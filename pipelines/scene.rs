//! The scene layer every pipeline shares: rays against spheres and finite planes, a
//! BVH over spheres, a pinhole camera, materials evaluated from their definition (what
//! the Monte Carlo reference needs), lights, and the JSON scene file.
//!
//! Conventions: right-handed world space, +z up, lengths in scene units, angles in
//! radians; a ray is x + t·v with v unit and t > 0; normals are unit and face out of
//! spheres and up out of planes (planes are one-sided: seen from the side the normal
//! points to). Image pixel (i, j) has row j = 0 at the top.
//!
//! The scene file (JSON, `"version": 2`, version 1 still read; every field required
//! unless noted, unknown fields are errors) is documented in docs/pipelines.md; the
//! built-in scenes belong to their pipelines (`pipelines/<p>/scenes/`, compiled into
//! each registry entry) and reach the loaders as a [`SceneText`].
//! Version 2 adds `meshes` (docs/meshes.md): triangle meshes seen by primary rays and
//! blocking light with their true triangles in every exact visibility test, each with
//! the sphere set the analytic pipelines take as its blockers ([`Scene::proxies`]).
//! Version 2 also adds motion: a sphere or a mesh may carry `keys`, a keyframed
//! translation ([`Track`]); a parsed scene is the still at time 0 and [`Scene::at`]
//! gives the still at any time of the animation (docs/meshes.md, Motion).

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::Path;

pub use lobefit_tables::geom::{Brdf, LafortuneLobe, Sphere, SphereLight};
use lobefit_tables::glam::{DQuat, DVec3};
pub use lobefit_tables::isg::Sg;
use lobefit_tables::microfacet::{BlinnPhong, CookTorrance};

use crate::mesh::{Mesh, Transform};
use crate::spheres::{Method, SphereSetFile, MAX_FIT_SPHERES};
use serde::Deserialize;

pub use super::heightfield::HeightField;

/// The camera of a file without one: (eye, target, vertical field of view in rad).
pub const DEFAULT_CAMERA: ([f64; 3], [f64; 3], f64) = ([0.0, -8.0, 5.0], [0.0, 0.0, 0.5], 0.75);

/// Where shadow rays from a hit start, in units of the height field's extent: far
/// above the rounding of a hit on it (≈ 1e-16 of the extent), far below any feature.
pub const TERRAIN_T_MIN: f64 = 1e-9;

/// Newest version of the scene file format this build reads (it reads 1 too).
pub const SCENE_VERSION: u32 = 2;
/// Most meshes a scene may hold.
pub const MAX_MESHES: usize = 16;
/// Where shadow rays from a mesh hit start, in units of the mesh's bounding-box
/// diagonal (as [`TERRAIN_T_MIN`]; the hit's own triangle is skipped too).
pub const MESH_T_MIN: f64 = 1e-9;
/// Longest scene file read (bytes): far above any hand-written scene, and a bound on
/// what a mistaken path can make us read.
pub const MAX_SCENE_LEN: u64 = 64 << 20;

/// Largest |coordinate| of a point, radius, plane offset or half extent, height field
/// extent or height a scene file may give (scene units): squares of differences stay
/// about 1e13, far from overflow (at ~1e154 they overflowed and spheres vanished).
pub const MAX_COORD: f64 = 1e6;
/// Largest SG amplitude, sphere light radiance or |SH coefficient| a scene file may
/// give: a Monte Carlo sample's square stays finite for any material.
pub const MAX_RADIANCE: f64 = 1e12;
/// Most spheres a scene may hold (the built-ins hold ≤ 402, the blocker-scaling study
/// 1024).
pub const MAX_SPHERES: usize = 16384;
/// Most environment SGs a scene may hold (the built-ins hold 9): every reference
/// sample evaluates each one's density, and the ISG pipeline shades each one.
pub const MAX_SGS: usize = 256;
/// Most sphere lights a scene may hold (the built-ins hold 1).
pub const MAX_LIGHTS: usize = 64;
/// Most plane patches a scene may hold (the built-ins hold 1).
pub const MAX_PLANES: usize = 64;
/// Most keys one object's track (or bend) may hold.
pub const MAX_KEYS: usize = 1024;
/// Largest |angle| of a bend's key or of a rotation (rad): two turns (a larger
/// angle's sine and cosine keep few of its digits).
pub const MAX_BEND_ANGLE: f64 = 4.0 * PI;

/// What a pipeline shades, checked right after a scene file is parsed and before
/// anything expensive (a height field's quadtree and pyramid, the BVH) is built: a
/// scene holding another kind is refused by name ([`load_for`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Accepts {
    /// The pipeline, as errors name it ("the ISG pipeline").
    pub pipeline: &'static str,
    /// A `heightfield`.
    pub heightfield: bool,
    /// Sphere `lights`.
    pub sphere_lights: bool,
    /// An `environment` of SGs.
    pub sg_environment: bool,
    /// An `sh_environment`.
    pub sh_environment: bool,
    /// `planes`.
    pub planes: bool,
    /// `meshes` (version 2).
    pub meshes: bool,
}

impl Accepts {
    /// Every kind (what [`load`] reads).
    pub const ALL: Accepts = Accepts {
        pipeline: "",
        heightfield: true,
        sphere_lights: true,
        sg_environment: true,
        sh_environment: true,
        planes: true,
        meshes: true,
    };
}

/// Distance along the ray x + t·v (v unit) to the first intersection with `s`, if any
/// (t > 0).
pub fn ray_sphere(x: DVec3, v: DVec3, s: &Sphere) -> Option<f64> {
    let oc = x - s.centre;
    let b = oc.dot(v);
    let c = oc.length_squared() - s.radius * s.radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    // Stable roots: q = −b − sign(b)·sq, t1 = q, t2 = c/q.
    let q = -b - b.signum() * sq;
    let (t1, t2) = if q != 0.0 { (q, c / q) } else { (0.0, 0.0) };
    let (lo, hi) = (t1.min(t2), t1.max(t2));
    if lo > 0.0 {
        Some(lo)
    } else if hi > 0.0 {
        Some(hi)
    } else {
        None
    }
}

/// Whether the ray from `x` in direction `v` reaches `light` before any blocker.
pub fn visible(x: DVec3, v: DVec3, light: &Sphere, blockers: &[Sphere]) -> bool {
    let Some(tl) = ray_sphere(x, v, light) else {
        return false;
    };
    !blockers.iter().any(|b| ray_sphere(x, v, b).is_some_and(|t| t < tl))
}

/// A one-sided square patch of a plane: the points x with n·x = `offset` within
/// `half_extent` of n·offset along `tangent` and along n × tangent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Unit normal (the side it is seen from).
    pub normal: DVec3,
    /// n·x on the plane.
    pub offset: f64,
    /// Unit tangent, perpendicular to the normal (the BRDF's local x axis).
    pub tangent: DVec3,
    /// Half the side of the patch.
    pub half_extent: f64,
}

impl Plane {
    /// Distance along x + t·v to the patch, if the ray meets its front side (t > 0).
    pub fn intersect(&self, x: DVec3, v: DVec3) -> Option<f64> {
        let denom = self.normal.dot(v);
        if denom >= 0.0 {
            return None;
        }
        let t = (self.offset - self.normal.dot(x)) / denom;
        if t <= 0.0 {
            return None;
        }
        let p = x + t * v - self.offset * self.normal;
        let b = self.normal.cross(self.tangent);
        (p.dot(self.tangent).abs() <= self.half_extent && p.dot(b).abs() <= self.half_extent).then_some(t)
    }
}

/// A bounding-volume hierarchy over spheres (axis-aligned boxes, median splits on the
/// longest axis, up to [`Bvh::LEAF`] spheres a leaf). Its answers equal a linear scan's.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    /// Sphere indices, leaves' ranges into it.
    order: Vec<usize>,
}

/// A node of a [`Bvh`]: its box, and its spheres or children.
#[derive(Debug, Clone, Copy)]
pub struct BvhNode {
    /// The box's low corner (scene units): it holds every sphere of the node.
    pub lo: DVec3,
    /// The box's high corner.
    pub hi: DVec3,
    /// Leaf: `count > 0`, spheres `order[first..first + count]` ([`Bvh::order`]);
    /// inner: children `first` and `first + 1`.
    pub first: usize,
    /// The leaf's sphere count; 0 for an inner node.
    pub count: usize,
}

/// Whether a ball lies wholly outside a cone of unit `axis` and half-angle `cone` (rad)
/// from `x`: its centre's direction is off the axis by more than cone + asin(ρ/d). A
/// ball holding `x` is never outside. (Shared by the BVH and the sphere hierarchy.)
#[derive(Debug, Clone, Copy)]
pub struct ConeTest {
    x: DVec3,
    axis: DVec3,
    cone: f64,
    sin_cone: f64,
    cos_cone: f64,
    by_cosines: bool,
}

impl ConeTest {
    /// The test for the cone of unit `axis`, half-angle `cone`, from `x`.
    pub fn new(x: DVec3, axis: DVec3, cone: f64) -> ConeTest {
        let (sin_cone, cos_cone) = cone.sin_cos();
        ConeTest {
            x,
            axis,
            cone,
            sin_cone,
            cos_cone,
            by_cosines: (0.0..=FRAC_PI_2).contains(&cone),
        }
    }

    /// Whether the ball (`c`, `rho`) lies wholly outside the cone.
    pub fn outside(&self, c: DVec3, rho: f64) -> bool {
        // The test off > cone + asin(ρ/d), decided first by cosines where cone + asin(ρ/d)
        // ≤ π: cos(off) against cos(cone + δ) = cos cone cos δ − sin cone sin δ. Outside
        // a band of 1e-9 about it, far wider than either side's rounding, both agree;
        // inside it, and for a wider cone, the angles decide: the same nodes, without
        // an acos and an asin per node (the ISG pipeline calls this once per product SG).
        let w = c - self.x;
        let d = w.length();
        if d <= rho {
            return false;
        }
        let dot = (w / d).dot(self.axis);
        let sin_delta = rho / d;
        let bound = self.cos_cone * (1.0 - sin_delta * sin_delta).sqrt() - self.sin_cone * sin_delta;
        if self.by_cosines && (dot - bound).abs() > 1e-9 {
            dot < bound
        } else {
            dot.clamp(-1.0, 1.0).acos() > self.cone + sin_delta.asin()
        }
    }
}

impl Bvh {
    /// Spheres per leaf at most.
    pub const LEAF: usize = 4;

    /// The hierarchy over `spheres` (indices refer to this slice).
    pub fn new(spheres: &[Sphere]) -> Bvh {
        let mut bvh = Bvh {
            nodes: Vec::new(),
            order: (0..spheres.len()).collect(),
        };
        if !spheres.is_empty() {
            bvh.nodes.push(BvhNode {
                lo: DVec3::ZERO,
                hi: DVec3::ZERO,
                first: 0,
                count: 0,
            });
            bvh.split(spheres, 0, 0, spheres.len());
        }
        bvh
    }

    fn split(&mut self, spheres: &[Sphere], node: usize, start: usize, end: usize) {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        for &i in &self.order[start..end] {
            let s = &spheres[i];
            lo = lo.min(s.centre - s.radius);
            hi = hi.max(s.centre + s.radius);
            clo = clo.min(s.centre);
            chi = chi.max(s.centre);
        }
        self.nodes[node].lo = lo;
        self.nodes[node].hi = hi;
        if end - start <= Self::LEAF {
            self.nodes[node].first = start;
            self.nodes[node].count = end - start;
            return;
        }
        let ext = chi - clo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = (start + end) / 2;
        // Ties broken by index, so the tree does not depend on the sort's stability.
        self.order[start..end].sort_by(|&a, &b| {
            spheres[a].centre[axis]
                .total_cmp(&spheres[b].centre[axis])
                .then(a.cmp(&b))
        });
        let left = self.nodes.len();
        let empty = BvhNode {
            lo,
            hi,
            first: 0,
            count: 0,
        };
        self.nodes.push(empty);
        self.nodes.push(empty);
        self.nodes[node].first = left;
        self.split(spheres, left, start, mid);
        self.split(spheres, left + 1, mid, end);
    }

    /// The nodes, the root first (empty for no spheres): what a device traverses.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// The sphere indices the leaves' ranges refer to.
    pub fn order(&self) -> &[usize] {
        &self.order
    }

    /// The tree's depth: 1 for a root that is a leaf, 0 for no spheres.
    pub fn depth(&self) -> usize {
        fn below(nodes: &[BvhNode], k: usize) -> usize {
            let n = nodes[k];
            1 + if n.count == 0 {
                below(nodes, n.first).max(below(nodes, n.first + 1))
            } else {
                0
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            below(&self.nodes, 0)
        }
    }

    /// Whether x + t·v meets the box for some t in (0, t_max).
    fn hits_box(n: &BvhNode, x: DVec3, inv: DVec3, t_max: f64) -> bool {
        let a = (n.lo - x) * inv;
        let b = (n.hi - x) * inv;
        // NaN (0·∞ on a slab the ray lies in) must not cull: min/max ignore it.
        let t0 = a.min(b).max_element().max(0.0);
        let t1 = a.max(b).min_element().min(t_max);
        t0 <= t1
    }

    /// The nearest sphere along x + t·v (v unit) with t < `t_max`, as (t, index);
    /// the lower index on equal t, as a scan in index order would give.
    pub fn nearest(&self, spheres: &[Sphere], x: DVec3, v: DVec3, t_max: f64) -> Option<(f64, usize)> {
        let inv = v.recip();
        let mut best: Option<(f64, usize)> = None;
        let mut stack = Stack::new();
        while let Some(k) = stack.pop() {
            let Some(n) = self.nodes.get(k) else { continue };
            let limit = best.map_or(t_max, |b| b.0);
            if !Self::hits_box(n, x, inv, limit) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
                continue;
            }
            for &i in &self.order[n.first..n.first + n.count] {
                if let Some(t) = ray_sphere(x, v, &spheres[i]) {
                    let better = match best {
                        None => t < t_max,
                        Some((bt, bi)) => t < bt || (t == bt && i < bi),
                    };
                    if better {
                        best = Some((t, i));
                    }
                }
            }
        }
        best
    }

    /// Calls `visit` with every sphere whose node the cone of unit `axis` and half-angle
    /// `cone` (rad) from `x` may meet: a node is skipped when the sphere around its box,
    /// seen from `x`, lies wholly outside the cone (so every sphere in it does too).
    /// A superset of the spheres whose caps meet the cone; the caller tests each.
    pub fn in_cone(&self, x: DVec3, axis: DVec3, cone: f64, mut visit: impl FnMut(usize)) {
        let test = ConeTest::new(x, axis, cone);
        let mut stack = Stack::new();
        while let Some(k) = stack.pop() {
            let Some(n) = self.nodes.get(k) else { continue };
            if test.outside(0.5 * (n.lo + n.hi), 0.5 * (n.hi - n.lo).length()) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
                continue;
            }
            for &i in &self.order[n.first..n.first + n.count] {
                visit(i);
            }
        }
    }

    /// Whether some sphere other than `skip` meets x + t·v for t < `t_max`.
    pub fn occluded(&self, spheres: &[Sphere], x: DVec3, v: DVec3, t_max: f64, skip: Option<usize>) -> bool {
        self.occluded_skipping(spheres, x, v, t_max, |i| Some(i) == skip)
    }

    /// Whether some sphere whose index `skip` refuses meets x + t·v for t < `t_max`.
    pub fn occluded_skipping(
        &self,
        spheres: &[Sphere],
        x: DVec3,
        v: DVec3,
        t_max: f64,
        skip: impl Fn(usize) -> bool,
    ) -> bool {
        let inv = v.recip();
        let mut stack = Stack::new();
        while let Some(k) = stack.pop() {
            let Some(n) = self.nodes.get(k) else { continue };
            if !Self::hits_box(n, x, inv, t_max) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
                continue;
            }
            let hit = self.order[n.first..n.first + n.count]
                .iter()
                .any(|&i| !skip(i) && ray_sphere(x, v, &spheres[i]).is_some_and(|t| t < t_max));
            if hit {
                return true;
            }
        }
        false
    }
}

/// The traversal stack, on the stack: no allocation per ray. Median splits keep the
/// depth at ⌈log₂(n/LEAF)⌉ + 1, so 64 entries hold any scene that fits in memory.
struct Stack {
    items: [usize; 64],
    len: usize,
}

impl Stack {
    fn new() -> Self {
        Stack { items: [0; 64], len: 1 }
    }
    fn push(&mut self, k: usize) {
        self.items[self.len] = k;
        self.len += 1;
    }
    fn pop(&mut self) -> Option<usize> {
        self.len = self.len.checked_sub(1)?;
        Some(self.items[self.len])
    }
}

/// A pinhole camera with +z up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Position.
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Vertical field of view (rad).
    pub fov: f64,
}

impl Camera {
    /// Unit direction of the primary ray through the centre of pixel (i, j) of a
    /// w × h image (row 0 at the top).
    pub fn ray(&self, i: usize, j: usize, w: usize, h: usize) -> DVec3 {
        let f = (self.target - self.eye).normalize();
        let r = f.cross(DVec3::Z).normalize();
        let u = r.cross(f);
        let k = (0.5 * self.fov).tan();
        let sx = ((i as f64 + 0.5) / w as f64 * 2.0 - 1.0) * k * w as f64 / h as f64;
        let sy = (1.0 - (j as f64 + 0.5) / h as f64 * 2.0) * k;
        (f + sx * r + sy * u).normalize()
    }
}

/// What a primary ray sees.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Surface point.
    pub x: DVec3,
    /// Unit normal.
    pub n: DVec3,
    /// Unit tangent (perpendicular to n: the BRDF's local x axis).
    pub t: DVec3,
    /// Unit direction to the eye.
    pub wo: DVec3,
    /// Index of the sphere hit, `None` for a plane.
    pub sphere: Option<usize>,
    /// (Index into [`Scene::meshes`], triangle) of a mesh hit.
    pub mesh: Option<(usize, usize)>,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

impl Hit {
    /// A point `x` of a horizontal surface (normal +z, tangent +x, no sphere or mesh,
    /// material 0) seen from `wo`: the shading point of tests and studies.
    pub fn ground(x: DVec3, wo: DVec3) -> Hit {
        Hit {
            x,
            n: DVec3::Z,
            t: DVec3::X,
            wo,
            sphere: None,
            mesh: None,
            material: 0,
        }
    }
}

/// The smallest Blinn-Phong exponent a scene takes: below it the ISG pipeline's one
/// warped SG misses the term by more than 7 % at normal view (measured against
/// `--exact`: +6.6 % at 100, +12 % at 50, +54 % at 1).
pub const BLINN_PHONG_MIN_EXPONENT: f64 = 100.0;

/// How far outside one of its mesh's spheres a mesh point may lie, relative to the
/// sphere's radius, and still count it as its own ([`Own`]).
pub const OWN_MARGIN: f64 = 0.05;

/// The proxies a hit is part of, which therefore do not block it — the rule by which a
/// mesh shadows itself through its sphere set:
///
/// - a point on a sphere: that sphere (it hides exactly the lower hemisphere of its own
///   surface points, which the cosine already removes);
/// - a point on a mesh: the spheres of the mesh's set that contain it, or whose surface
///   passes within [`OWN_MARGIN`] × their radius of it. Those stand for the surface
///   around the point: a sphere the point lies in would hide its whole sky, and one
///   whose boundary passes beside it covers about a half-space there, hiding what the
///   surface itself hides. Every other sphere of the set is a blocker, so one part of
///   the mesh shadows another (the knot's strands, the bunny's ear over its back).
///   Before, a mesh point skipped its whole set and the mesh never shadowed itself
///   (docs/meshes.md, "Self-shadowing through the set").
/// - anything else: none.
#[derive(Debug, Clone)]
pub struct Own<'a> {
    range: std::ops::Range<usize>,
    spheres: &'a [Sphere],
    x: DVec3,
}

impl Own<'_> {
    /// No own proxies (a point on a plane, the ground or in space).
    pub const NONE: Own<'static> = Own {
        range: 0..0,
        spheres: &[],
        x: DVec3::ZERO,
    };

    /// Whether proxy `i` is the hit's own (not a blocker).
    pub fn contains(&self, i: &usize) -> bool {
        self.range.contains(i) && {
            let s = &self.spheres[*i];
            (self.x - s.centre).length() <= s.radius * (1.0 + OWN_MARGIN)
        }
    }

    /// The proxies' index range the own ones are drawn from: the hit's sphere, or its
    /// mesh's set (the GPU kernels apply [`Own::contains`]'s test themselves).
    pub fn range(&self) -> std::ops::Range<usize> {
        self.range.clone()
    }
}

/// The BRDF's value f_r(v, wo) (sr⁻¹) at a hit from its definition (independent of
/// the lobe form the pipelines use); 0 below the surface.
pub fn brdf_value(b: &Brdf, h: &Hit, v: DVec3) -> f64 {
    if h.n.dot(v) <= 0.0 {
        return 0.0;
    }
    match b {
        Brdf::Lambert { albedo } => albedo / PI,
        Brdf::Lafortune { albedo, lobes } => {
            let t = (h.t - h.t.dot(h.n) * h.n).normalize();
            let bt = h.n.cross(t);
            let loc = |d: DVec3| DVec3::new(d.dot(t), d.dot(bt), d.dot(h.n));
            let (a, o) = (loc(v), loc(h.wo));
            albedo / PI
                + lobes
                    .iter()
                    .map(|l| {
                        let s = l.c.x * a.x * o.x + l.c.y * a.y * o.y + l.c.z * a.z * o.z;
                        if s > 0.0 {
                            l.rho * s.powf(l.exponent)
                        } else {
                            0.0
                        }
                    })
                    .sum::<f64>()
        }
        Brdf::CookTorrance { albedo, specular } => albedo / PI + specular.value(h.n, h.wo, v),
        Brdf::BlinnPhong { albedo, specular } => albedo / PI + specular.value(h.n, h.wo, v),
    }
}

/// A scene: spheres and plane patches with their materials, lights, a camera.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Name (the built-in's or the file's stem), used in output file names.
    pub name: String,
    /// Spheres (they are also blockers).
    pub spheres: Vec<Sphere>,
    /// Each sphere's index into `materials`.
    pub sphere_materials: Vec<usize>,
    /// Plane patches (visible, not blockers).
    pub planes: Vec<Plane>,
    /// Each plane's index into `materials`.
    pub plane_materials: Vec<usize>,
    /// Materials.
    pub materials: Vec<Brdf>,
    /// Spherical lights (not seen by primary rays).
    pub lights: Vec<SphereLight>,
    /// Distant lighting L(ω) = Σ a_k exp(λ_k (μ_k·ω − 1)) (radiance; not seen by
    /// primary rays): the file's `environment.sgs`, empty if it has none.
    pub environment: Vec<Sg>,
    /// The map the `environment` lobes were fitted to (`"environment": {"map": FILE,
    /// "sgs": K}`), the light the references integrate; `None` for a list of lobes.
    pub environment_map: Option<std::sync::Arc<crate::envmap::LightMap>>,
    /// That map's Γ_L table (`"environment": {..., "prefiltered": FILE}`, made by
    /// `lobefit prefilter`): `render isg` adds eq. 9 with it (docs/environment.md).
    pub prefiltered: Option<std::sync::Arc<lobefit_tables::Table>>,
    /// Distant lighting as an SH function L(ω) = Σ c_i y_i(ω) (radiance; the file's
    /// `sh_environment.coefficients`, n² of them for its order n), if given.
    pub sh_environment: Option<Vec<f64>>,
    /// A height field (visible and a blocker), with its index into `materials`.
    pub heightfield: Option<(HeightField, usize)>,
    /// The file's top-level `brdf`: the material of points `eval isg-shade` shades.
    pub brdf: Option<Brdf>,
    /// The camera.
    pub camera: Camera,
    /// Triangle meshes (visible and blockers with their true triangles).
    pub meshes: Vec<SceneMesh>,
    /// The analytic pipelines' blockers: [`Scene::spheres`] (same indices), then each
    /// mesh's sphere set ([`SceneMesh::proxy`]).
    pub proxies: Vec<Sphere>,
    /// The objects that move (empty: a still scene), each with its keys relative to
    /// its place in this still ([`Scene::at`]).
    pub tracks: Vec<Track>,
    bvh: Bvh,
    proxy_bvh: Bvh,
    /// The sphere hierarchy over [`Scene::proxies`], built on first use
    /// ([`Scene::proxy_tree`]).
    proxy_tree: std::sync::OnceLock<crate::spheres::tree::SphereTree>,
}

/// An object a [`Track`] moves: an index into [`Scene::spheres`] or [`Scene::meshes`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Moving {
    /// A sphere (and its proxy, the same index of [`Scene::proxies`]).
    Sphere(usize),
    /// A mesh, its true triangles and its sphere set together (a rigid motion).
    Mesh(usize),
}

/// A keyframed translation: (time, translation) keys, times strictly increasing in
/// [0, 1] (the animation's span), translations in scene units. Between keys the
/// translation is linear in time; before the first key it is the first's, after the
/// last the last's.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// What moves.
    pub object: Moving,
    /// The keys: (time, translation).
    pub keys: Vec<(f64, DVec3)>,
    /// The keys' rotations (a mesh's only; empty: it does not turn), at the keys'
    /// times: each turns the mesh about its rest pose's bounding-box centre, before the
    /// translation; interpolated by slerp.
    pub turns: Vec<(f64, DQuat)>,
}

impl Track {
    /// The rotation at `time` (slerp between the keys', held outside them; the
    /// identity when the track has none).
    pub fn turn(&self, time: f64) -> DQuat {
        if self.turns.is_empty() {
            return DQuat::IDENTITY;
        }
        keyed(&self.turns, time, |a, b, u| a.slerp(b, u))
    }

    /// The translation at `time` (piecewise linear through the keys, held constant
    /// outside them).
    pub fn at(&self, time: f64) -> DVec3 {
        keyed(&self.keys, time, |a, b, u| a.lerp(b, u))
    }
}

/// The value of (time, value) keys at `time`: `lerp(a, b, u)` between the keys around
/// it, the first key's value before them, the last's after.
pub(crate) fn keyed<T: Copy>(keys: &[(f64, T)], time: f64, lerp: impl Fn(T, T, f64) -> T) -> T {
    match keys.iter().position(|(t, _)| *t > time) {
        Some(0) => keys[0].1,
        None => keys[keys.len() - 1].1,
        Some(i) => {
            let ((t0, a), (t1, b)) = (keys[i - 1], keys[i]);
            lerp(a, b, (time - t0) / (t1 - t0))
        }
    }
}

/// A mesh deformed by two bones (linear blend skinning): a fixed bone, and a bone that
/// turns by a keyframed angle about `axis` through `pivot`. A point p's weight on the
/// turning bone is a smoothstep of s = (p − pivot)·`along` over [−width/2, width/2]
/// (0 below, 1 above); its skinned place is (1 − w) p + w (pivot + R (p − pivot)). The
/// mesh's sphere set is carried by the bones: each centre skinned the same way, its
/// radius kept (Meunier §5.3's skeleton-driven sets). Applied to the mesh in scene
/// coordinates (after its transform), before its track's translation.
#[derive(Debug, Clone, PartialEq)]
pub struct Bend {
    /// A point on the turning axis (scene units).
    pub pivot: DVec3,
    /// The turning axis (unit).
    pub axis: DVec3,
    /// The direction along which the weight rises from the fixed bone to the turning
    /// one (unit).
    pub along: DVec3,
    /// The width of the blend (scene units, > 0).
    pub width: f64,
    /// (time, angle in rad) keys, times as [`Track::keys`].
    pub keys: Vec<(f64, f64)>,
}

impl Bend {
    /// The angle at `time` (rad; as [`Track::at`]).
    pub fn angle(&self, time: f64) -> f64 {
        keyed(&self.keys, time, |a, b, u| a + (b - a) * u)
    }

    /// The turning bone's weight at `p`, in [0, 1].
    pub fn weight(&self, p: DVec3) -> f64 {
        let s = ((p - self.pivot).dot(self.along) / self.width + 0.5).clamp(0.0, 1.0);
        s * s * (3.0 - 2.0 * s)
    }

    /// `p` skinned with the turning bone at `angle` (rad).
    pub fn skin(&self, p: DVec3, angle: f64) -> DVec3 {
        let q = self.pivot + DQuat::from_axis_angle(self.axis, angle) * (p - self.pivot);
        p.lerp(q, self.weight(p))
    }
}

/// A mesh of a scene.
#[derive(Debug, Clone)]
pub struct SceneMesh {
    /// The triangles, transformed into the scene.
    pub mesh: crate::mesh::Mesh,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Its sphere set's range in [`Scene::proxies`].
    pub proxy: std::ops::Range<usize>,
    /// Where its shadow rays start ([`MESH_T_MIN`] × its diagonal).
    pub t_min: f64,
    /// Its rest pose, kept when it bends or turns ([`Pose`]).
    pub pose: Option<Pose>,
}

/// A mesh that bends or turns: rebuilt from its rest pose every frame.
#[derive(Debug, Clone)]
pub struct Pose {
    /// Its two-bone deformation, if it bends.
    pub bend: Option<Bend>,
    /// Its glTF skin and animation, if it is skinned (posed before any bend).
    pub skin: Option<std::sync::Arc<crate::skin::Skinned>>,
    /// The mesh as the file places it (unbent, unturned, untranslated).
    pub rest: crate::mesh::Mesh,
    /// Its sphere set at rest.
    pub rest_set: Vec<Sphere>,
    /// What its track's rotations turn about: the rest mesh's bounding-box centre.
    pub pivot: DVec3,
}

impl Scene {
    /// The distant light's radiance towards `w` (unit): the map's luminance where the
    /// environment is a map (what the references integrate), else the SGs' sum, else
    /// 0 (an SH environment is its pipeline's: `shexp::lighting`).
    pub fn light(&self, w: DVec3) -> f64 {
        match &self.environment_map {
            Some(m) => m.luminance(w),
            None => crate::sg::environment(&self.environment, w),
        }
    }

    /// The still at `time` of the animation (a parsed scene is the still at time 0): every tracked object moved by its track's translation
    /// at `time` less its translation at 0, the hierarchies rebuilt, no tracks. Errors
    /// only where a moved mesh cannot be rebuilt.
    pub fn at(&self, time: f64) -> Result<Scene, String> {
        let mut s = self.moved(time, Some(0.0))?;
        s.tracks.clear();
        for m in &mut s.meshes {
            m.pose = None;
        }
        Ok(s)
    }

    /// This scene at `time`: each tracked object moved by its translation at `time`
    /// less that at `base` (`None`: less nothing, from the file's places), each mesh
    /// with a [`Pose`] rebuilt from its rest pose at `time` (bent, turned about its
    /// pivot, then translated by its whole translation at `time`). Tracks and poses kept.
    fn moved(&self, time: f64, base: Option<f64>) -> Result<Scene, String> {
        let mut s = self.clone();
        let bent = |m: usize| self.meshes[m].pose.is_some();
        for tr in &self.tracks {
            let d = tr.at(time) - base.map_or(DVec3::ZERO, |b| tr.at(b));
            match tr.object {
                Moving::Mesh(m) if bent(m) => {}
                Moving::Sphere(i) => {
                    s.spheres[i].centre += d;
                    s.proxies[i].centre += d;
                }
                Moving::Mesh(m) => {
                    let sm = &mut s.meshes[m];
                    let shift = Transform {
                        translation: d,
                        ..Transform::IDENTITY
                    };
                    sm.mesh = sm
                        .mesh
                        .transformed(&shift)
                        .map_err(|e| format!("scene {}: meshes[{m}]: {e}", self.name))?;
                    for p in sm.proxy.clone() {
                        s.proxies[p].centre += d;
                    }
                }
            }
        }
        for (m, sm) in s.meshes.iter_mut().enumerate() {
            let Some(pose) = &sm.pose else {
                continue;
            };
            let track = self.tracks.iter().find(|tr| tr.object == Moving::Mesh(m));
            let shift = track.map_or(DVec3::ZERO, |tr| tr.at(time));
            let turn = track.map_or(DQuat::IDENTITY, |tr| tr.turn(time));
            let angle = pose.bend.as_ref().map_or(0.0, |b| b.angle(time));
            let place = |p: DVec3| {
                let bent = pose.bend.as_ref().map_or(p, |b| b.skin(p, angle));
                pose.pivot + turn * (bent - pose.pivot) + shift
            };
            let (vertices, centres) = match &pose.skin {
                Some(skinned) => skinned.at(time),
                None => (
                    pose.rest.vertices.clone(),
                    pose.rest_set.iter().map(|r| r.centre).collect(),
                ),
            };
            sm.mesh = crate::mesh::Mesh::new(vertices.into_iter().map(place).collect(), pose.rest.triangles.clone())
                .map_err(|e| format!("scene {}: meshes[{m}]: {e}", self.name))?;
            for (p, c) in sm.proxy.clone().zip(centres) {
                s.proxies[p].centre = place(c);
            }
        }
        s.bvh = Bvh::new(&s.spheres);
        s.proxy_bvh = Bvh::new(&s.proxies);
        s.proxy_tree = std::sync::OnceLock::new();
        Ok(s)
    }

    /// What the primary ray of pixel (i, j) of a w × h image sees, if anything.
    pub fn primary(&self, i: usize, j: usize, w: usize, h: usize) -> Option<Hit> {
        let eye = self.camera.eye;
        let d = self.camera.ray(i, j, w, h);
        let mut best: Option<(f64, Hit)> = None;
        if let Some((t, idx)) = self.bvh.nearest(&self.spheres, eye, d, f64::INFINITY) {
            let x = eye + t * d;
            let n = (x - self.spheres[idx].centre).normalize();
            best = Some((
                t,
                Hit {
                    x,
                    n,
                    t: n.any_orthonormal_vector(),
                    wo: -d,
                    sphere: Some(idx),
                    mesh: None,
                    material: self.sphere_materials[idx],
                },
            ));
        }
        for (mi, m) in self.meshes.iter().enumerate() {
            let limit = best.as_ref().map_or(f64::INFINITY, |b| b.0);
            if let Some((t, k)) = m.mesh.nearest(eye, d, 0.0, limit, None) {
                let g = m.mesh.normal(k);
                // Triangles are two-sided: the normal faces the eye.
                let n = if g.dot(d) > 0.0 { -g } else { g };
                best = Some((
                    t,
                    Hit {
                        x: eye + t * d,
                        n,
                        t: n.any_orthonormal_vector(),
                        wo: -d,
                        sphere: None,
                        mesh: Some((mi, k)),
                        material: m.material,
                    },
                ));
            }
        }
        for (p, &material) in self.planes.iter().zip(&self.plane_materials) {
            if let Some(t) = p.intersect(eye, d) {
                if best.as_ref().is_none_or(|b| t < b.0) {
                    best = Some((
                        t,
                        Hit {
                            x: eye + t * d,
                            n: p.normal,
                            t: p.tangent,
                            wo: -d,
                            sphere: None,
                            mesh: None,
                            material,
                        },
                    ));
                }
            }
        }
        if let Some((hf, material)) = &self.heightfield {
            let limit = best.as_ref().map_or(f64::INFINITY, |b| b.0);
            if let Some(t) = hf.intersect(eye, d, 0.0, limit) {
                let x = eye + t * d;
                if let Some(n) = hf.normal(x.x, x.y) {
                    best = Some((
                        t,
                        Hit {
                            x,
                            n,
                            t: n.any_orthonormal_vector(),
                            wo: -d,
                            sphere: None,
                            mesh: None,
                            material: *material,
                        },
                    ));
                }
            }
        }
        best.map(|b| b.1)
    }

    /// What every pixel of a w × h image sees, and the mask of those that see
    /// geometry; an error naming the scene when none does.
    pub fn primary_hits(&self, w: usize, h: usize) -> Result<(Vec<Option<Hit>>, Vec<bool>), String> {
        self.check_camera()?;
        let hits: Vec<Option<Hit>> = (0..w * h).map(|p| self.primary(p % w, p / w, w, h)).collect();
        let lit: Vec<bool> = hits.iter().map(Option::is_some).collect();
        if !lit.contains(&true) {
            return Err(format!(
                "scene {}: no pixel of the {w}×{h} image sees geometry",
                self.name
            ));
        }
        Ok((hits, lit))
    }

    /// An error naming the sphere the camera's eye lies in (or on), or the height
    /// field it lies below: primary rays from there see insides, which the pipelines
    /// would shade as lit outsides.
    pub fn check_camera(&self) -> Result<(), String> {
        let eye = self.camera.eye;
        if let Some(k) = self.spheres.iter().position(|s| (eye - s.centre).length() <= s.radius) {
            return Err(format!(
                "scene {}: camera.eye {:?} lies inside spheres[{k}] (centre {:?}, radius {})",
                self.name,
                eye.to_array(),
                self.spheres[k].centre.to_array(),
                self.spheres[k].radius
            ));
        }
        if let Some(k) = self.meshes.iter().position(|m| m.mesh.inside(eye)) {
            return Err(format!(
                "scene {}: camera.eye {:?} lies inside meshes[{k}]",
                self.name,
                eye.to_array()
            ));
        }
        if let Some((hf, _)) = &self.heightfield {
            if let Some(z) = hf.height(eye.x, eye.y) {
                if eye.z < z {
                    return Err(format!(
                        "scene {}: camera.eye {:?} lies below the heightfield (height {z} there)",
                        self.name,
                        eye.to_array()
                    ));
                }
            }
        }
        Ok(())
    }

    /// The BRDF at a hit.
    pub fn brdf(&self, h: &Hit) -> &Brdf {
        &self.materials[h.material]
    }

    /// Blockers seen from a hit, as the analytic pipelines take them: every sphere of
    /// [`Scene::proxies`] (the spheres, then the meshes' sphere sets) but the hit's own
    /// ([`Scene::own_proxies`]): so a mesh shadows itself through the rest of its set.
    pub fn blockers(&self, h: &Hit) -> Vec<Sphere> {
        let own = self.own_proxies(h);
        self.proxies
            .iter()
            .enumerate()
            .filter(|(i, _)| !own.contains(i))
            .map(|(_, s)| *s)
            .collect()
    }

    /// The hierarchy over [`Scene::spheres`].
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The hierarchy over [`Scene::proxies`].
    pub fn proxy_bvh(&self) -> &Bvh {
        &self.proxy_bvh
    }

    /// The sphere hierarchy over [`Scene::proxies`] (docs/meshes.md, "A sphere
    /// hierarchy"), built on first use and kept.
    pub fn proxy_tree(&self) -> &crate::spheres::tree::SphereTree {
        self.proxy_tree
            .get_or_init(|| crate::spheres::tree::SphereTree::new(&self.proxies))
    }

    /// The proxies a hit is part of ([`Own`]): its sphere, or the spheres of its mesh's
    /// set that stand for the surface where it lies.
    pub fn own_proxies(&self, h: &Hit) -> Own<'_> {
        let range = match (h.sphere, h.mesh) {
            (Some(i), _) => i..i + 1,
            (None, Some((m, _))) => self.meshes[m].proxy.clone(),
            (None, None) => 0..0,
        };
        Own {
            range,
            spheres: &self.proxies,
            x: h.x,
        }
    }

    /// Whether `h` lies inside a blocker sphere ([`Scene::blockers`]: a proxy other than
    /// its own). Only a mesh's sphere set can bury a visible point (the camera sees a
    /// sphere's surface before anything inside it), e.g. a ground point under a covering
    /// sphere that reaches below it; the analytic pipelines take the proxy as a solid,
    /// so such a point is in its full shadow.
    pub fn buried(&self, h: &Hit) -> bool {
        let own = self.own_proxies(h);
        self.proxies
            .iter()
            .enumerate()
            .any(|(i, b)| !own.contains(&i) && (h.x - b.centre).length() <= b.radius)
    }

    /// Whether a blocker sphere ([`Scene::blockers`]) or the height field meets the ray
    /// from `h` in direction `v` (unit): exact visibility of the analytic pipelines'
    /// blockers, the meshes' sphere sets in place of their triangles.
    pub fn proxies_occlude(&self, h: &Hit, v: DVec3) -> bool {
        let own = self.own_proxies(h);
        self.proxy_bvh
            .occluded_skipping(&self.proxies, h.x, v, f64::INFINITY, |i| own.contains(&i))
            || self.terrain_occludes(h, v, f64::INFINITY)
    }

    /// Whether a mesh's true triangles meet the ray from `h` in direction `v` before
    /// `t_max` (the hit's own triangle skipped, from its mesh's `t_min` on).
    fn meshes_occlude(&self, h: &Hit, v: DVec3, t_max: f64) -> bool {
        self.meshes.iter().enumerate().any(|(mi, m)| {
            let skip = h.mesh.filter(|&(hm, _)| hm == mi).map(|(_, k)| k);
            m.mesh.occluded(h.x, v, m.t_min, t_max, skip)
        })
    }

    /// Whether a sphere other than the one `h` lies on meets the ray from `h` in
    /// direction `v` (unit): exact visibility of a distant direction, through the BVH.
    pub fn occluded(&self, h: &Hit, v: DVec3) -> bool {
        self.bvh.occluded(&self.spheres, h.x, v, f64::INFINITY, h.sphere)
            || self.terrain_occludes(h, v, f64::INFINITY)
            || self.meshes_occlude(h, v, f64::INFINITY)
    }

    /// Whether the height field (if any) meets the ray from `h` in direction `v` before
    /// `t_max`; the ray starts [`TERRAIN_T_MIN`] × the field's extent away, so a point
    /// on the terrain does not shadow itself.
    fn terrain_occludes(&self, h: &Hit, v: DVec3, t_max: f64) -> bool {
        self.heightfield
            .as_ref()
            .is_some_and(|(hf, _)| hf.occluded(h.x, v, TERRAIN_T_MIN * hf.extent(), t_max))
    }

    /// Whether the ray from hit `h` in direction `v` reaches sphere light `light`
    /// before any sphere (the BVH; equal to [`visible`] with [`Scene::blockers`]).
    pub fn light_visible(&self, h: &Hit, v: DVec3, light: &Sphere) -> bool {
        let Some(tl) = ray_sphere(h.x, v, light) else {
            return false;
        };
        !self.bvh.occluded(&self.spheres, h.x, v, tl, h.sphere)
            && !self.terrain_occludes(h, v, tl)
            && !self.meshes_occlude(h, v, tl)
    }
}

/// A scene's JSON as the loaders read it: its name (a built-in's full name
/// `<pipeline>-<scene>`, else the file's stem), its text and the folder its files
/// resolve in (none for a built-in: it names no file). Built-ins belong to their
/// pipelines (each registry entry's `files`, from `pipelines/<p>/scenes/`); the crate
/// root's `scene_text` finds one by name, else reads a file.
#[derive(Debug, Clone)]
pub struct SceneText {
    /// The scene's name.
    pub name: String,
    /// The JSON text.
    pub text: String,
    /// The folder a file's relative paths (maps, meshes, sphere sets) resolve in.
    pub dir: Option<std::path::PathBuf>,
}

impl SceneText {
    /// A built-in scene: its full name and text.
    pub fn builtin(name: &str, text: &str) -> Self {
        SceneText {
            name: name.into(),
            text: text.into(),
            dir: None,
        }
    }

    /// The scene file at `path` (at most [`MAX_SCENE_LEN`] bytes).
    pub fn file(path: &str) -> Result<Self, String> {
        let p = Path::new(path);
        let text = lobefit_core::io::read_text(p, MAX_SCENE_LEN).map_err(|e| format!("scene {path}: {e}"))?;
        let name = p
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        let dir = p
            .parent()
            .map(|d| if d.as_os_str().is_empty() { Path::new(".") } else { d });
        Ok(SceneText {
            name,
            text,
            dir: dir.map(Path::to_path_buf),
        })
    }
}

/// The scene file at `path`.
pub fn load(path: &str) -> Result<Scene, String> {
    load_for(path, &Accepts::ALL)
}

/// [`load`], refusing (by name, before building the height field) a scene holding a
/// kind `accepts` does not.
pub fn load_for(path: &str, accepts: &Accepts) -> Result<Scene, String> {
    load_text_for(&SceneText::file(path)?, accepts)
}

/// [`load_for`] of a scene's text (a built-in's or a file's).
pub fn load_text_for(t: &SceneText, accepts: &Accepts) -> Result<Scene, String> {
    Ok(parse_inner(&t.name, &t.text, t.dir.as_deref(), accepts, true)?.expect("built"))
}

/// [`load_for`] for `lobefit eval`, its errors sorted as the command line reports
/// them: the file's own (cannot be read, parsed, or built: a mesh, a fit, the height
/// field) are [`EvalError::Input`]; a valid scene of a kind `accepts` refuses is the
/// query's usage ([`EvalError::Usage`]).
pub fn load_for_eval(t: &SceneText, accepts: &Accepts) -> Result<Scene, lobefit_core::family::EvalError> {
    use lobefit_core::family::EvalError;
    let (name, text, dir) = (&t.name, &t.text, t.dir.as_deref());
    parse_inner(name, text, dir, &Accepts::ALL, false).map_err(EvalError::Input)?;
    parse_inner(name, text, dir, accepts, false).map_err(EvalError::Usage)?;
    Ok(parse_inner(name, text, dir, accepts, true)
        .map_err(EvalError::Input)?
        .expect("built"))
}

/// (light terms, blockers) of the scene `name_or_path`, read without building it
/// (the meshes' sphere sets counted from their specifications and files): the SGs,
/// sphere lights and an SH environment (1); the spheres, the sets' spheres and a
/// height field (1). `None` when it cannot be read or parsed.
pub fn terms_of(t: &SceneText) -> Option<(u64, u64)> {
    let (name, text, dir) = (&t.name, &t.text, &t.dir);
    let f = read_file(name, text, &Accepts::ALL).ok()?;
    let lights =
        f.environment.as_ref().map_or(0, |e| e.count()) + f.lights.len() + usize::from(f.sh_environment.is_some());
    let mut blockers = f.spheres.len() + usize::from(f.heightfield.is_some());
    for m in &f.meshes {
        blockers += match &m.spheres {
            serde_json::Value::String(file) => dir
                .as_deref()
                .and_then(|d| inside_folder(d, file).ok())
                .and_then(|p| lobefit_core::io::read_text(&p, MAX_SCENE_LEN).ok())
                .and_then(|t| lobefit_core::json::from_str::<SphereSetFile>(&t).ok())
                .map_or(0, |set| set.spheres.len()),
            v => v["count"].as_u64().unwrap_or(0) as usize,
        };
    }
    Some((lights as u64, blockers as u64))
}

/// Whether [`load`] would succeed, without building anything expensive (the height
/// field): the same error, or Ok.
pub fn check_file(path: &str) -> Result<(), String> {
    let t = SceneText::file(path)?;
    parse_inner(&t.name, &t.text, t.dir.as_deref(), &Accepts::ALL, false).map(|_| ())
}

/// The light of the map at `path` (named `file` in the scene) with `k` lobes fitted
/// to it: the map is read and checked always, fitted only when `build` (`None`
/// otherwise). A fit is deterministic and takes about a second (docs/environment.md);
/// the process keeps each (map bytes, k) it fitted, so a scene loaded twice (a check,
/// then a render; every frame of an animation shares the first's) fits once. No file
/// is written.
fn map_light(
    path: &Path,
    file: &str,
    k: usize,
    build: bool,
) -> Result<Option<std::sync::Arc<crate::envmap::LightMap>>, String> {
    use std::hash::{Hash, Hasher};
    type Cache = Vec<((u64, usize, usize), std::sync::Arc<crate::envmap::LightMap>)>;
    static FITTED: std::sync::Mutex<Cache> = std::sync::Mutex::new(Vec::new());
    let bytes = lobefit_core::io::read_bytes(path, crate::envmap::MAX_MAP_BYTES, "MAX_MAP_BYTES")?;
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    bytes.hash(&mut hasher);
    let key = (hasher.finish(), bytes.len(), k);
    if let Some((_, light)) = FITTED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .iter()
        .find(|(kk, _)| *kk == key)
    {
        return Ok(build.then(|| light.clone()));
    }
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let map = match ext.as_deref() {
        Some("exr") => crate::envmap::EnvMap::from_exr_bytes(&bytes),
        Some("hdr") => crate::envmap::EnvMap::from_hdr_bytes(&bytes),
        _ => Err("not a map: .exr or .hdr".into()),
    }
    .map_err(|e| format!("{file}: {e}"))?;
    if !build {
        return Ok(None);
    }
    let fitted = crate::envmap::fit(&map, k).map_err(|e| format!("{file}: {e}"))?;
    let light = std::sync::Arc::new(crate::envmap::LightMap::new(file.into(), map, fitted.sgs)?);
    let mut cache = FITTED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // A handful of maps per process; the oldest goes first past eight.
    if cache.len() >= 8 {
        cache.remove(0);
    }
    cache.push((key, light.clone()));
    Ok(Some(light))
}

/// A scene's environment: its lobes, the map they were fitted to, that map's Γ_L.
type EnvironmentParts = (
    Vec<Sg>,
    Option<std::sync::Arc<crate::envmap::LightMap>>,
    Option<std::sync::Arc<lobefit_tables::Table>>,
);

/// Reads a Γ_L table (`environment.prefiltered`) and, given the scene's `map`, checks
/// that it was made from that map: the same texel count (its settings), and its values
/// at λ = 1 and 16 towards ±x, ±y, ±z (nodes of its grid) within 1 % of quadrature of
/// the map (a table of another map of the same size is refused there; about 30 ms for
/// a 512 × 256 map).
fn prefiltered_table(
    path: &Path,
    file: &str,
    map: Option<&crate::envmap::EnvMap>,
) -> Result<lobefit_tables::Table, String> {
    use crate::prefilter::{lookup, reference, KIND, VERSION};
    let t = lobefit_tables::Table::from_path(path).map_err(|e| format!("{file}: {e}"))?;
    t.expect_kind(KIND, VERSION).map_err(|e| format!("{file}: {e}"))?;
    let Some(map) = map else { return Ok(t) };
    let size = format!("{}x{}", map.width, map.height);
    let made = t
        .meta()
        .fit
        .settings
        .iter()
        .find(|(k, _)| k == "size")
        .map(|(_, v)| v.as_str());
    if made != Some(size.as_str()) {
        return Err(format!(
            "{file} was made from a map of {} texels, the scene's map has {size}",
            made.unwrap_or("unknown")
        ));
    }
    use lobefit_tables::glam::DVec3;
    for lambda in [1.0, 16.0] {
        for a in [DVec3::Z, -DVec3::Z, DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y] {
            let (g, r) = (lookup(&t, a, lambda)?, reference(map, a, lambda));
            if (0..3).any(|c| (g[c] - r[c]).abs() > 1e-2 * r[c].abs().max(1e-12)) {
                return Err(format!(
                    "{file} is not this map's Γ_L: towards {a} at λ = {lambda} it holds {g:?}, the map gives {r:?}"
                ));
            }
        }
    }
    Ok(t)
}

/// A mesh's sphere set, before it is read or fitted.
enum SetSpec {
    File(std::path::PathBuf),
    /// count, method, seed, the overlap bound (`optimize` only).
    Fit(usize, Method, u64, Option<f64>),
}

/// The file's structure (docs/pipelines.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    /// Checked before the rest is parsed (see `parse`).
    #[serde(rename = "version")]
    _version: u32,
    /// Optional for `eval` (which has no image): default [`DEFAULT_CAMERA`].
    #[serde(default)]
    camera: Option<FileCamera>,
    /// The material of points `eval isg-shade` shades (optional).
    #[serde(default)]
    brdf: Option<FileMaterial>,
    #[serde(default)]
    spheres: Vec<FileSphere>,
    #[serde(default)]
    planes: Vec<FilePlane>,
    #[serde(default)]
    lights: Vec<FileLight>,
    /// Distant lighting as spherical Gaussians (optional; a scene needs lights, an
    /// environment or both).
    #[serde(default)]
    environment: Option<FileEnvironment>,
    /// Distant lighting as SH coefficients (optional; not with `environment`).
    #[serde(default)]
    sh_environment: Option<FileShEnvironment>,
    /// A height field (optional).
    #[serde(default)]
    heightfield: Option<FileHeightField>,
    /// Triangle meshes (version 2; optional).
    #[serde(default)]
    meshes: Vec<FileMesh>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileMesh {
    /// An OBJ file, relative to the scene file's folder and inside it.
    file: String,
    material: FileMaterial,
    /// A sphere-set file's name, or `{count, method, seed}` to fit on load: read by
    /// [`Checker::sphere_set`], which names the field of every error.
    spheres: serde_json::Value,
    #[serde(default)]
    transform: Option<FileTransform>,
    /// Keyframed translation after `transform` (optional).
    #[serde(default)]
    keys: Vec<FileKey>,
    /// A two-bone deformation (optional).
    #[serde(default)]
    bend: Option<FileBend>,
    /// Pose the glTF file's skin by its animation (optional).
    #[serde(default)]
    skin: Option<FileSkin>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSkin {
    /// The animation's name (default: the file's first).
    #[serde(default)]
    animation: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileBend {
    pivot: [f64; 3],
    axis: [f64; 3],
    along: [f64; 3],
    width: f64,
    keys: Vec<FileAngleKey>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileAngleKey {
    /// In [0, 1], the animation's span.
    time: f64,
    /// rad.
    angle: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileTransform {
    /// Uniform scale (default 1).
    #[serde(default)]
    scale: Option<f64>,
    /// Rotation about `axis` by `angle` (rad), after the scale.
    #[serde(default)]
    rotation: Option<FileRotation>,
    /// Translation, last (default 0).
    #[serde(default)]
    translation: Option<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileRotation {
    axis: [f64; 3],
    angle: f64,
}

/// `file` joined to the scene's folder `dir`, refused if it leaves it (absolute,
/// `..`, or a symbolic link anywhere that resolves outside).
pub fn inside_folder(dir: &Path, file: &str) -> Result<std::path::PathBuf, String> {
    let rel = Path::new(file);
    if rel.is_absolute()
        || rel
            .components()
            .any(|c| !matches!(c, std::path::Component::Normal(_) | std::path::Component::CurDir))
    {
        return Err(format!(
            "{file:?} must be a relative path inside the scene file's folder (no `..`, not absolute)"
        ));
    }
    let joined = dir.join(rel);
    let real = joined
        .canonicalize()
        .map_err(|e| format!("{}: {e}", joined.display()))?;
    let real_dir = dir.canonicalize().map_err(|e| format!("{}: {e}", dir.display()))?;
    if !real.starts_with(&real_dir) {
        return Err(format!(
            "{file:?} resolves to {}, outside the scene file's folder {} (a symbolic link)",
            real.display(),
            real_dir.display()
        ));
    }
    Ok(real)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileShEnvironment {
    order: usize,
    coefficients: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileHeightField {
    /// Samples per side.
    size: usize,
    /// Side of the square (centred on the origin).
    extent: f64,
    /// size² heights, row-major (y rows of x samples); or `procedural`.
    #[serde(default)]
    heights: Option<Vec<f64>>,
    #[serde(default)]
    procedural: Option<FileTerrain>,
    material: FileMaterial,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileTerrain {
    amplitude: f64,
    octaves: u32,
    seed: u64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileEnvironment {
    /// A list of lobes; with `map`, the count of lobes to fit to it.
    sgs: serde_json::Value,
    /// An equirectangular HDR map (inside the scene's folder; docs/environment.md).
    map: Option<String>,
    /// With `map`: its Γ_L table, made by `lobefit prefilter` (inside the folder).
    #[serde(default)]
    prefiltered: Option<String>,
}

impl FileEnvironment {
    /// How many lobes the scene's pipelines will shade: the list's length, or the count.
    fn count(&self) -> usize {
        match &self.sgs {
            serde_json::Value::Array(a) => a.len(),
            v => v.as_u64().map_or(0, |k| usize::try_from(k).unwrap_or(usize::MAX)),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSg {
    axis: [f64; 3],
    sharpness: f64,
    /// A radiance, or linear RGB `[r, g, b]` (`lobefit fit-env`'s lobes): the
    /// pipelines shade its Rec. 709 luminance.
    amplitude: serde_json::Value,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileCamera {
    eye: [f64; 3],
    target: [f64; 3],
    fov: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSphere {
    centre: [f64; 3],
    radius: f64,
    material: FileMaterial,
    /// Keyframed translation (version 2; optional).
    #[serde(default)]
    keys: Vec<FileKey>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileKey {
    /// In [0, 1], the animation's span.
    time: f64,
    /// Added to the object's place in the file (scene units).
    translation: [f64; 3],
    /// A mesh's rotation about its rest bounding-box centre (optional).
    #[serde(default)]
    rotation: Option<FileRotation>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePlane {
    normal: [f64; 3],
    offset: f64,
    tangent: [f64; 3],
    half_extent: f64,
    material: FileMaterial,
}

#[derive(Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
enum FileMaterial {
    Lambert {
        albedo: f64,
    },
    Lafortune {
        albedo: f64,
        lobes: Vec<FileLobe>,
    },
    /// Lambert plus a Cook–Torrance term (GGX roughness α, Schlick's f₀), weighted by
    /// `specular` (lobefit_tables::microfacet).
    #[serde(rename = "cook_torrance")]
    CookTorrance {
        albedo: f64,
        specular: f64,
        roughness: f64,
        f0: f64,
    },
    /// Lambert plus k_s (s + 8)/(8π) (n·h)^s (lobefit_tables::microfacet).
    #[serde(rename = "blinn_phong")]
    BlinnPhong {
        albedo: f64,
        specular: f64,
        exponent: f64,
    },
}

#[derive(Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
struct FileLobe {
    c: [f64; 3],
    exponent: f64,
    /// Specular reflectance k_s: ρ_s = k_s (n + 2)/(2π), the normalised Phong form.
    specular: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
enum FileLight {
    Sphere {
        centre: [f64; 3],
        radius: f64,
        radiance: f64,
    },
}

/// Parses and validates a scene file's text; errors name the scene and the field.
pub fn parse(name: &str, text: &str) -> Result<Scene, String> {
    Ok(parse_inner(name, text, None, &Accepts::ALL, true)?.expect("built"))
}

/// [`parse`] of a file's text whose relative paths (meshes, sphere sets) lie in `folder`.
pub fn parse_in(name: &str, text: &str, folder: &Path) -> Result<Scene, String> {
    Ok(parse_inner(name, text, Some(folder), &Accepts::ALL, true)?.expect("built"))
}

/// [`parse`] with the pipeline's kinds checked before anything expensive is built;
/// `build` false: validate only (the same errors but the camera's), `Ok(None)`. The
/// sections are checked in the file's order of cost (sizes and kinds first, the height
/// field and the meshes built last), each by its own helper.
fn parse_inner(
    name: &str,
    text: &str,
    folder: Option<&Path>,
    accepts: &Accepts,
    build: bool,
) -> Result<Option<Scene>, String> {
    let f = read_file(name, text, accepts)?;
    let mut c = Checker {
        name,
        materials: Vec::new(),
    };
    let (eye, target, fov) = c.camera(f.camera)?;
    let brdf = f.brdf.map(|m| c.material("brdf", m)).transpose()?;
    let tracks = c.tracks(&f.spheres, &f.meshes)?;
    let (spheres, sphere_materials) = c.spheres(f.spheres)?;
    let (planes, plane_materials) = c.planes(f.planes)?;
    let mesh_specs = c.mesh_specs(f.meshes, folder)?;
    if f.lights.is_empty()
        && f.environment.as_ref().is_none_or(|e| e.map.is_none() && e.count() == 0)
        && f.sh_environment.is_none()
    {
        return Err(c.err("no lights and no environment".into()));
    }
    if f.environment.is_some() && f.sh_environment.is_some() {
        return Err(c.err("environment and sh_environment: give one distant light, not both".into()));
    }
    let sh_environment = f.sh_environment.map(|e| c.sh_environment(e)).transpose()?;
    // The height field's parameters are checked here; it is built (O(n²) time and
    // memory) only once every other check has passed.
    let heightfield = f.heightfield.map(|h| c.heightfield(h)).transpose()?;
    let (environment, environment_map, prefiltered) = match f.environment {
        None => (Vec::new(), None, None),
        Some(e) => c.environment(e, folder, build)?,
    };
    let lights = c.lights(f.lights)?;
    let materials = brdfs(std::mem::take(&mut c.materials));
    let brdf = brdf.map(|i| materials[i].clone());
    if !build {
        return Ok(None);
    }
    let heightfield = heightfield.map(|h| c.build_heightfield(h)).transpose()?;
    let (mut meshes, proxies) = c.build_meshes(mesh_specs, &spheres)?;
    // A mesh whose track turns is rebuilt from its rest pose every frame, as a bent one.
    for tr in tracks.iter().filter(|tr| !tr.turns.is_empty()) {
        if let Moving::Mesh(m) = tr.object {
            let sm = &mut meshes[m];
            if sm.pose.is_none() {
                let (lo, hi) = sm.mesh.bounds();
                sm.pose = Some(Pose {
                    bend: None,
                    skin: None,
                    rest: sm.mesh.clone(),
                    rest_set: proxies[sm.proxy.clone()].to_vec(),
                    pivot: 0.5 * (lo + hi),
                });
            }
        }
    }
    let proxy_bvh = Bvh::new(&proxies);
    let bvh = Bvh::new(&spheres);
    let scene = Scene {
        name: name.into(),
        spheres,
        sphere_materials,
        planes,
        plane_materials,
        materials,
        lights,
        environment,
        environment_map,
        prefiltered,
        sh_environment,
        heightfield,
        brdf,
        camera: Camera { eye, target, fov },
        meshes,
        proxies,
        tracks,
        bvh,
        proxy_bvh,
        proxy_tree: std::sync::OnceLock::new(),
    };
    // The still at time 0: keys are translations added to the file's places, bends
    // applied to the rest pose.
    Ok(Some(
        if scene.tracks.is_empty() && scene.meshes.iter().all(|m| m.pose.is_none()) {
            scene
        } else {
            scene.moved(0.0, None)?
        },
    ))
}

/// The scene file's structure from `text`, its version, sizes and kinds checked:
/// the version first (a newer file's other fields are not this build's to judge), then
/// the sizes (what follows is linear in them), then the kinds `accepts` shades (before
/// the height field is built).
fn read_file(name: &str, text: &str, accepts: &Accepts) -> Result<File, String> {
    let err = |m: String| format!("scene {name}: {m}");
    // Strictly (a key given twice is an error), and the version first.
    let value = lobefit_core::json::value(text).map_err(&err)?;
    let version = match value.get("version") {
        None => {
            return Err(err(format!(
                "no field `version` (this build reads versions 1 to {SCENE_VERSION})"
            )))
        }
        Some(v) => match v.as_u64() {
            Some(n) if (1..=u64::from(SCENE_VERSION)).contains(&n) => n,
            _ => {
                return Err(err(format!(
                    "version {v} (this build reads versions 1 to {SCENE_VERSION}, an integer)"
                )))
            }
        },
    };
    // From the text, not the value: serde_json's errors then give a line and column.
    let f: File = serde_json::from_str(text).map_err(|e| err(e.to_string()))?;
    let sgs = f.environment.as_ref().map_or(0, FileEnvironment::count);
    for (what, count, max, limit) in [
        ("spheres", f.spheres.len(), MAX_SPHERES, "MAX_SPHERES"),
        ("environment.sgs", sgs, MAX_SGS, "MAX_SGS"),
        ("lights", f.lights.len(), MAX_LIGHTS, "MAX_LIGHTS"),
        ("planes", f.planes.len(), MAX_PLANES, "MAX_PLANES"),
        ("meshes", f.meshes.len(), MAX_MESHES, "MAX_MESHES"),
    ] {
        if count > max {
            return Err(err(format!(
                "{what} has {count} entries, more than the {max} a scene may hold ({limit}, docs/pipelines.md)"
            )));
        }
    }
    if !accepts.pipeline.is_empty() {
        let kinds = [
            (
                f.heightfield.is_some(),
                accepts.heightfield,
                "a height field (`heightfield`)",
            ),
            (!f.lights.is_empty(), accepts.sphere_lights, "sphere lights (`lights`)"),
            (sgs > 0, accepts.sg_environment, "an SG environment (`environment`)"),
            (
                f.sh_environment.is_some(),
                accepts.sh_environment,
                "an SH environment (`sh_environment`)",
            ),
            (!f.planes.is_empty(), accepts.planes, "planes (`planes`)"),
            (!f.meshes.is_empty(), accepts.meshes, "meshes (`meshes`)"),
        ];
        if let Some((_, _, kind)) = kinds.iter().find(|(has, ok, _)| *has && !*ok) {
            return Err(err(format!(
                "{} cannot shade {kind}, which the scene holds",
                accepts.pipeline
            )));
        }
    }
    if version < 2 && !f.meshes.is_empty() {
        return Err(err("meshes need \"version\": 2".into()));
    }
    if version < 2 && f.spheres.iter().any(|s| !s.keys.is_empty()) {
        return Err(err("keys (motion) need \"version\": 2".into()));
    }
    Ok(f)
}

/// A height field's checked parameters: (size, extent, heights, procedural terrain,
/// material index); built by [`Checker::build_heightfield`].
type HeightFieldSpec = (usize, f64, Option<Vec<f64>>, Option<FileTerrain>, usize);

/// A mesh's checked specification: (its field's name, OBJ path, transform, sphere set,
/// material index); read by [`Checker::build_meshes`].
/// A mesh entry read but not yet built: what, path, transform, sphere set, material,
/// bend, skin (its animation's name, if given).
type MeshSpec = (
    String,
    std::path::PathBuf,
    Transform,
    SetSpec,
    usize,
    Option<Bend>,
    Option<Option<String>>,
);

/// The scene file's checks, each naming the scene (`scene <name>: …`) and the field,
/// and the materials met so far (equal ones share an index: the material list is the
/// set of BRDFs).
struct Checker<'a> {
    name: &'a str,
    materials: Vec<FileMaterial>,
}

impl Checker<'_> {
    fn err(&self, m: String) -> String {
        format!("scene {}: {m}", self.name)
    }

    /// A point or vector: finite, every |coordinate| ≤ [`MAX_COORD`].
    fn vec3(&self, what: &str, v: [f64; 3]) -> Result<DVec3, String> {
        if v.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORD) {
            Ok(DVec3::from_array(v))
        } else {
            Err(self.err(format!(
                "{what} {v:?} must be finite with every |coordinate| ≤ {MAX_COORD:e} (MAX_COORD)"
            )))
        }
    }

    fn positive(&self, what: &str, x: f64) -> Result<f64, String> {
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(format!("{what} {x} must be finite and > 0")))
        }
    }

    /// A length (scene units): finite, > 0, ≤ [`MAX_COORD`].
    fn length(&self, what: &str, x: f64) -> Result<f64, String> {
        if x.is_finite() && x > 0.0 && x <= MAX_COORD {
            Ok(x)
        } else {
            Err(self.err(format!(
                "{what} {x:?} must be finite, > 0 and ≤ {MAX_COORD:e} (MAX_COORD)"
            )))
        }
    }

    /// A radiance: finite, in [0, [`MAX_RADIANCE`]].
    fn radiance(&self, what: &str, x: f64) -> Result<f64, String> {
        if x.is_finite() && (0.0..=MAX_RADIANCE).contains(&x) {
            Ok(x)
        } else {
            Err(self.err(format!(
                "{what} {x:?} must be finite, ≥ 0 and ≤ {MAX_RADIANCE:e} (MAX_RADIANCE)"
            )))
        }
    }

    /// A unit vector (to 1e-9).
    fn unit(&self, what: &str, v: [f64; 3]) -> Result<DVec3, String> {
        let d = self.vec3(what, v)?;
        if (d.length() - 1.0).abs() > 1e-9 {
            return Err(self.err(format!("{what} {v:?} is not a unit vector")));
        }
        Ok(d)
    }

    /// The camera (the default's when absent): eye, target, fov (rad).
    fn camera(&self, camera: Option<FileCamera>) -> Result<(DVec3, DVec3, f64), String> {
        let camera = camera.unwrap_or(FileCamera {
            eye: DEFAULT_CAMERA.0,
            target: DEFAULT_CAMERA.1,
            fov: DEFAULT_CAMERA.2,
        });
        let eye = self.vec3("camera.eye", camera.eye)?;
        let target = self.vec3("camera.target", camera.target)?;
        let dir = target - eye;
        if dir.length() == 0.0 || dir.normalize().cross(DVec3::Z).length() < 1e-6 {
            return Err(self.err("camera: eye and target must differ and not lie on one vertical line".into()));
        }
        if !(camera.fov > 0.0 && camera.fov < PI) {
            return Err(self.err(format!("camera.fov {} must lie in (0, π)", camera.fov)));
        }
        Ok((eye, target, camera.fov))
    }

    /// A material, checked: its index in the materials (equal ones share one).
    fn material(&mut self, what: &str, m: FileMaterial) -> Result<usize, String> {
        let (albedo, lobes) = match &m {
            FileMaterial::Lambert { albedo } => (*albedo, &[][..]),
            FileMaterial::Lafortune { albedo, lobes } => (*albedo, &lobes[..]),
            FileMaterial::CookTorrance { albedo, .. } | FileMaterial::BlinnPhong { albedo, .. } => (*albedo, &[][..]),
        };
        if !(0.0..=1.0).contains(&albedo) {
            return Err(self.err(format!("{what}: albedo {albedo} must lie in [0, 1]")));
        }
        if let FileMaterial::CookTorrance {
            specular,
            roughness,
            f0,
            ..
        } = m
        {
            CookTorrance::new(specular, roughness, f0).map_err(|e| self.err(format!("{what}: cook_torrance: {e}")))?;
            // The term reflects at most k_s of the light (F ≤ 1, and Smith's G₂ and the
            // normalised D keep ∫ f_s cos ≤ 1): with the diffuse albedo, at most 1.
            if albedo + specular > 1.0 + 1e-12 {
                return Err(self.err(format!(
                    "{what}: cook_torrance albedo {albedo} + specular {specular} must be ≤ 1 (energy conservation)"
                )));
            }
        }
        if let FileMaterial::BlinnPhong { specular, exponent, .. } = m {
            BlinnPhong::new(specular, exponent).map_err(|e| self.err(format!("{what}: blinn_phong: {e}")))?;
            // One warped SG follows the term only for a narrow lobe (measured against
            // --exact at normal view: +6.6 % at exponent 100, +12 % at 50, +54 % at 1).
            if exponent < BLINN_PHONG_MIN_EXPONENT {
                return Err(self.err(format!(
                    "{what}: blinn_phong exponent {exponent} is below {BLINN_PHONG_MIN_EXPONENT}: the ISG pipeline's \
                     one SG is {} % off there (a broad highlight: a lafortune lobe, which sg-fit fits per exponent)",
                    if exponent < 50.0 { "over 12" } else { "7 to 12" }
                )));
            }
            // The term's reflectance is at most about k_s (its normalisation): with the
            // diffuse albedo, at most 1.
            if albedo + specular > 1.0 + 1e-12 {
                return Err(self.err(format!(
                    "{what}: blinn_phong albedo {albedo} + specular {specular} must be ≤ 1 (energy conservation)"
                )));
            }
        }
        // Energy: a lobe's directional albedo is at most k_s · max|c_i|^n (the lobe is
        // |c ⊙ v|^n max(ω·d, 0)^n with ρ_s = k_s (n+2)/(2π), and ∫ max(ω·d,0)^n cos θ dω
        // ≤ 2π/(n+2), equality when d is the normal); with the diffuse albedo the sum must
        // not pass 1, or the surface reflects more light than it receives.
        let mut reflected = albedo;
        for (i, l) in lobes.iter().enumerate() {
            self.vec3(&format!("{what}: lobe c"), l.c)?;
            if !(l.exponent.is_finite() && l.exponent >= 0.0 && l.specular.is_finite() && l.specular >= 0.0) {
                return Err(self.err(format!(
                    "{what}: lobe exponent {} and specular {} must be finite and ≥ 0",
                    l.exponent, l.specular
                )));
            }
            let cmax = l.c.iter().fold(0.0f64, |m, c| m.max(c.abs()));
            reflected += l.specular * cmax.powf(l.exponent);
            if reflected.is_nan() || reflected > 1.0 + 1e-12 {
                return Err(self.err(format!(
                    "{what}: lobes[{i}] makes the material reflect up to {reflected:.4e} of the light it receives \
                     (albedo + Σ specular · max|c|^exponent must be ≤ 1: energy conservation)"
                )));
            }
        }
        Ok(match self.materials.iter().position(|x| *x == m) {
            Some(i) => i,
            None => {
                self.materials.push(m);
                self.materials.len() - 1
            }
        })
    }

    /// The tracks of the spheres and meshes that carry `keys`: at most [`MAX_KEYS`]
    /// each, times finite, strictly increasing and in [0, 1], translations as points.
    fn tracks(&self, spheres: &[FileSphere], meshes: &[FileMesh]) -> Result<Vec<Track>, String> {
        let keyed = spheres
            .iter()
            .enumerate()
            .map(|(k, s)| (format!("spheres[{k}]"), Moving::Sphere(k), &s.keys))
            .chain(
                meshes
                    .iter()
                    .enumerate()
                    .map(|(k, m)| (format!("meshes[{k}]"), Moving::Mesh(k), &m.keys)),
            )
            .filter(|(_, _, keys)| !keys.is_empty());
        let mut tracks = Vec::new();
        for (what, object, keys) in keyed {
            if keys.len() > MAX_KEYS {
                return Err(self.err(format!(
                    "{what}.keys has {} keys, more than {MAX_KEYS} (MAX_KEYS)",
                    keys.len()
                )));
            }
            let mut out: Vec<(f64, DVec3)> = Vec::with_capacity(keys.len());
            for (i, key) in keys.iter().enumerate() {
                let at = format!("{what}.keys[{i}]");
                self.key_time(&at, key.time, out.last().map(|k| k.0))?;
                out.push((key.time, self.vec3(&format!("{at}.translation"), key.translation)?));
            }
            let turns = if keys.iter().any(|k| k.rotation.is_some()) {
                if let Moving::Sphere(_) = object {
                    return Err(self.err(format!(
                        "{what}.keys: a rotation turns a sphere into itself; give one to meshes only"
                    )));
                }
                keys.iter()
                    .enumerate()
                    .map(|(i, k)| match &k.rotation {
                        None => Ok((k.time, DQuat::IDENTITY)),
                        Some(r) => Ok((k.time, self.rotation(&format!("{what}.keys[{i}].rotation"), r)?)),
                    })
                    .collect::<Result<Vec<_>, String>>()?
            } else {
                Vec::new()
            };
            tracks.push(Track {
                object,
                keys: out,
                turns,
            });
        }
        Ok(tracks)
    }

    /// A rotation `what`: a non-zero axis (normalised) and a finite angle (rad).
    fn rotation(&self, what: &str, r: &FileRotation) -> Result<DQuat, String> {
        let axis = self.vec3(&format!("{what}.axis"), r.axis)?;
        if axis.length() == 0.0 || !(r.angle.is_finite() && r.angle.abs() <= MAX_BEND_ANGLE) {
            return Err(self.err(format!(
                "{what}: axis {:?} must not be zero and angle {} finite with |angle| ≤ {MAX_BEND_ANGLE} rad \
                 (MAX_BEND_ANGLE: two turns)",
                r.axis, r.angle
            )));
        }
        Ok(DQuat::from_axis_angle(axis.normalize(), r.angle))
    }

    /// A key's time `at`: finite, in [0, 1], after the key before it (`last`).
    fn key_time(&self, at: &str, time: f64, last: Option<f64>) -> Result<(), String> {
        if !(time.is_finite() && (0.0..=1.0).contains(&time)) {
            return Err(self.err(format!("{at}.time {time} must lie in [0, 1]")));
        }
        if last.is_some_and(|t| time <= t) {
            return Err(self.err(format!("{at}.time {time} must be greater than the key before it")));
        }
        Ok(())
    }

    /// The mesh `what`'s bend: a pivot, non-zero axis and direction (normalised), a
    /// width in (0, [`MAX_COORD`]], 1..=[`MAX_KEYS`] keys with times as a track's and
    /// angles finite with |angle| ≤ [`MAX_BEND_ANGLE`].
    fn bend(&self, what: &str, b: FileBend) -> Result<Bend, String> {
        let at = format!("{what}.bend");
        let nonzero = |name: &str, v: [f64; 3]| -> Result<DVec3, String> {
            let d = self.vec3(&format!("{at}.{name}"), v)?;
            if d.length() == 0.0 {
                return Err(self.err(format!("{at}.{name} is the zero vector")));
            }
            Ok(d.normalize())
        };
        if !(1..=MAX_KEYS).contains(&b.keys.len()) {
            return Err(self.err(format!(
                "{at}.keys has {} keys; a bend has 1 to {MAX_KEYS} (MAX_KEYS)",
                b.keys.len()
            )));
        }
        let mut keys: Vec<(f64, f64)> = Vec::with_capacity(b.keys.len());
        for (i, k) in b.keys.iter().enumerate() {
            let ak = format!("{at}.keys[{i}]");
            self.key_time(&ak, k.time, keys.last().map(|k| k.0))?;
            if !(k.angle.is_finite() && k.angle.abs() <= MAX_BEND_ANGLE) {
                return Err(self.err(format!(
                    "{ak}.angle {} must be finite with |angle| ≤ {MAX_BEND_ANGLE} rad (MAX_BEND_ANGLE)",
                    k.angle
                )));
            }
            keys.push((k.time, k.angle));
        }
        Ok(Bend {
            pivot: self.vec3(&format!("{at}.pivot"), b.pivot)?,
            axis: nonzero("axis", b.axis)?,
            along: nonzero("along", b.along)?,
            width: self.length(&format!("{at}.width"), b.width)?,
            keys,
        })
    }

    /// The spheres and their material indices.
    fn spheres(&mut self, file: Vec<FileSphere>) -> Result<(Vec<Sphere>, Vec<usize>), String> {
        let mut spheres = Vec::new();
        let mut sphere_materials = Vec::new();
        for (k, s) in file.into_iter().enumerate() {
            let what = format!("spheres[{k}]");
            spheres.push(Sphere {
                centre: self.vec3(&format!("{what}.centre"), s.centre)?,
                radius: self.length(&format!("{what}.radius"), s.radius)?,
            });
            sphere_materials.push(self.material(&what, s.material)?);
        }
        Ok((spheres, sphere_materials))
    }

    /// The planes and their material indices.
    fn planes(&mut self, file: Vec<FilePlane>) -> Result<(Vec<Plane>, Vec<usize>), String> {
        let mut planes = Vec::new();
        let mut plane_materials = Vec::new();
        for (k, p) in file.into_iter().enumerate() {
            let what = format!("planes[{k}]");
            let normal = self.unit(&format!("{what}.normal"), p.normal)?;
            let tangent = self.unit(&format!("{what}.tangent"), p.tangent)?;
            if normal.dot(tangent).abs() > 1e-9 {
                return Err(self.err(format!("{what}: tangent is not perpendicular to the normal")));
            }
            if !(p.offset.is_finite() && p.offset.abs() <= MAX_COORD) {
                return Err(self.err(format!(
                    "{what}.offset {} must be finite with |offset| ≤ {MAX_COORD:e} (MAX_COORD)",
                    p.offset
                )));
            }
            planes.push(Plane {
                normal,
                offset: p.offset,
                tangent,
                half_extent: self.length(&format!("{what}.half_extent"), p.half_extent)?,
            });
            plane_materials.push(self.material(&what, p.material)?);
        }
        Ok((planes, plane_materials))
    }

    /// Meshes: paths (inside `folder`), transforms and sphere-set specifications now;
    /// the files are read (and sphere sets fitted) only once everything else has
    /// passed.
    fn mesh_specs(&mut self, file: Vec<FileMesh>, folder: Option<&Path>) -> Result<Vec<MeshSpec>, String> {
        let mut mesh_specs = Vec::new();
        for (k, m) in file.into_iter().enumerate() {
            let what = format!("meshes[{k}]");
            let dir = folder.ok_or_else(|| {
                self.err(format!(
                    "{what}: a scene given as text has no folder to read {:?} from",
                    m.file
                ))
            })?;
            let path = inside_folder(dir, &m.file).map_err(|e| self.err(format!("{what}.file: {e}")))?;
            let transform = match m.transform {
                None => Transform::IDENTITY,
                Some(t) => self.transform(&what, t)?,
            };
            let set = self.sphere_set(&what, m.spheres, dir)?;
            let material = self.material(&what, m.material)?;
            let bend = m.bend.map(|b| self.bend(&what, b)).transpose()?;
            let skin = m.skin.map(|s| s.animation);
            mesh_specs.push((what, path, transform, set, material, bend, skin));
        }
        Ok(mesh_specs)
    }

    /// The mesh `what`'s `spheres`: a sphere-set file's name (inside `dir`), or an
    /// object `{count, method, seed}` with `count` an integer in 1..=[`MAX_FIT_SPHERES`],
    /// `method` a fit method's name, `seed` an integer ≥ 0; any other key or type is an
    /// error naming the field and what it takes.
    fn sphere_set(&self, what: &str, v: serde_json::Value, dir: &Path) -> Result<SetSpec, String> {
        use serde_json::Value;
        let map = match v {
            Value::String(file) => {
                return Ok(SetSpec::File(
                    inside_folder(dir, &file).map_err(|e| self.err(format!("{what}.spheres: {e}")))?,
                ))
            }
            Value::Object(map) => map,
            other => {
                return Err(self.err(format!(
                    "{what}.spheres is {other}: expected a sphere-set file's name or {{\"count\": N, \"method\": M, \"seed\": S}}"
                )))
            }
        };
        if let Some(k) = map
            .keys()
            .find(|k| !["count", "method", "seed", "max_overlap"].contains(&k.as_str()))
        {
            return Err(self.err(format!(
                "{what}.spheres.{k}: unknown field (a fitted set takes count, method, seed and max_overlap)"
            )));
        }
        let count = match map.get("count") {
            None => return Err(self.err(format!("{what}.spheres: no field `count`"))),
            Some(c) => c
                .as_u64()
                .filter(|c| (1..=MAX_FIT_SPHERES as u64).contains(c))
                .ok_or_else(|| {
                    self.err(format!(
                        "{what}.spheres.count is {c}: expected an integer from 1 to {MAX_FIT_SPHERES}"
                    ))
                })? as usize,
        };
        let method = match map.get("method") {
            None => Method::Optimize,
            Some(Value::String(m)) => Method::parse(m).map_err(|e| self.err(format!("{what}.spheres.method: {e}")))?,
            Some(m) => {
                return Err(self.err(format!(
                "{what}.spheres.method is {m}: expected a method's name (optimize, cover, kmeans, kmeans-moment, tree)"
            )))
            }
        };
        let seed = match map.get("seed") {
            None => 0,
            Some(s) => s.as_u64().ok_or_else(|| {
                self.err(format!(
                    "{what}.spheres.seed is {s}: expected an integer from 0 to {}",
                    u64::MAX
                ))
            })?,
        };
        let max_overlap = match map.get("max_overlap") {
            None => None,
            Some(v) => match v.as_f64() {
                Some(r) if r.is_finite() && r >= 1.0 && method == Method::Optimize => Some(r),
                _ => {
                    return Err(self.err(format!(
                        "{what}.spheres.max_overlap is {v}: expected a number ≥ 1, with the method optimize"
                    )))
                }
            },
        };
        Ok(SetSpec::Fit(count, method, seed, max_overlap))
    }

    /// The mesh `what`'s transform: scale in (0, [`MAX_COORD`]], a rotation about a
    /// non-zero axis, a translation.
    fn transform(&self, what: &str, t: FileTransform) -> Result<Transform, String> {
        let scale = t.scale.unwrap_or(1.0);
        if !(scale.is_finite() && scale > 0.0 && scale <= MAX_COORD) {
            return Err(self.err(format!(
                "{what}.transform.scale {scale} must be finite, > 0 and ≤ {MAX_COORD:e}"
            )));
        }
        let rotation = match &t.rotation {
            None => DQuat::IDENTITY,
            Some(r) => self.rotation(&format!("{what}.transform.rotation"), r)?,
        };
        let translation = self.vec3(
            &format!("{what}.transform.translation"),
            t.translation.unwrap_or([0.0; 3]),
        )?;
        Ok(Transform {
            scale,
            rotation,
            translation,
        })
    }

    /// The SH environment's coefficients: order 1..=8, order² finite values.
    fn sh_environment(&self, e: FileShEnvironment) -> Result<Vec<f64>, String> {
        if !(1..=8).contains(&e.order) {
            return Err(self.err(format!("sh_environment.order {} must lie in 1..=8", e.order)));
        }
        if e.coefficients.len() != e.order * e.order {
            return Err(self.err(format!(
                "sh_environment.coefficients has {} values, order {} needs {}",
                e.coefficients.len(),
                e.order,
                e.order * e.order
            )));
        }
        if let Some(k) = e
            .coefficients
            .iter()
            .position(|c| !(c.is_finite() && c.abs() <= MAX_RADIANCE))
        {
            return Err(self.err(format!(
                "sh_environment.coefficients[{k}] {} must be finite with |c| ≤ {MAX_RADIANCE:e} (MAX_RADIANCE)",
                e.coefficients[k]
            )));
        }
        Ok(e.coefficients)
    }

    /// The height field's parameters, checked (it is built later).
    fn heightfield(&mut self, h: FileHeightField) -> Result<HeightFieldSpec, String> {
        let hf_err = |e: String| self.err(format!("heightfield: {e}"));
        if h.extent > MAX_COORD {
            return Err(hf_err(format!(
                "extent {} must be ≤ {MAX_COORD:e} (MAX_COORD)",
                h.extent
            )));
        }
        match (&h.heights, &h.procedural) {
            (Some(heights), None) => {
                crate::heightfield::check_heights(h.size, h.extent, heights).map_err(hf_err)?;
                if let Some(k) = heights.iter().position(|z| z.abs() > MAX_COORD) {
                    return Err(hf_err(format!(
                        "heights[{k}] = {} must have |height| ≤ {MAX_COORD:e} (MAX_COORD)",
                        heights[k]
                    )));
                }
            }
            (None, Some(p)) => {
                crate::heightfield::check_procedural(h.size, h.extent, p.amplitude, p.octaves).map_err(hf_err)?;
                if p.amplitude > MAX_COORD {
                    return Err(hf_err(format!(
                        "amplitude {} must be ≤ {MAX_COORD:e} (MAX_COORD)",
                        p.amplitude
                    )));
                }
            }
            _ => return Err(hf_err("give exactly one of heights and procedural".into())),
        }
        let m = self.material("heightfield", h.material)?;
        Ok((h.size, h.extent, h.heights, h.procedural, m))
    }

    /// The environment: its SGs (axes normalised), and the map they were fitted to
    /// when it names one (read, and fitted only when `build`: [`map_light`]).
    fn environment(&self, e: FileEnvironment, folder: Option<&Path>, build: bool) -> Result<EnvironmentParts, String> {
        let Some(file) = e.map else {
            if e.prefiltered.is_some() {
                return Err(self.err("environment.prefiltered: a Γ_L table belongs to a map; give `map` too".into()));
            }
            let sgs: Vec<FileSg> = serde_json::from_value(e.sgs).map_err(|err| {
                self.err(format!(
                    "environment.sgs: {err} (a list of lobes, or a count with `map`)"
                ))
            })?;
            return Ok((self.environment_sgs(sgs)?, None, None));
        };
        let k = e
            .sgs
            .as_u64()
            .and_then(|k| usize::try_from(k).ok())
            .filter(|k| (1..=crate::envmap::MAX_FIT_SGS).contains(k))
            .ok_or_else(|| {
                self.err(format!(
                    "environment.sgs is {}: with `map` it is the count of lobes to fit, an integer in 1..={} (MAX_FIT_SGS)",
                    e.sgs,
                    crate::envmap::MAX_FIT_SGS
                ))
            })?;
        let dir = folder.ok_or_else(|| {
            self.err(format!(
                "environment.map: a scene given as text has no folder to read {file:?} from"
            ))
        })?;
        let path = inside_folder(dir, &file).map_err(|err| self.err(format!("environment.map: {err}")))?;
        let light = map_light(&path, &file, k, build).map_err(|err| self.err(format!("environment.map: {err}")))?;
        let Some(light) = light else {
            if let Some(pf) = &e.prefiltered {
                // Checked for its path and its kind without building.
                let p = inside_folder(dir, pf).map_err(|err| self.err(format!("environment.prefiltered: {err}")))?;
                prefiltered_table(&p, pf, None).map_err(|err| self.err(format!("environment.prefiltered: {err}")))?;
            }
            return Ok((Vec::new(), None, None));
        };
        let prefiltered = match &e.prefiltered {
            None => None,
            Some(pf) => {
                let p = inside_folder(dir, pf).map_err(|err| self.err(format!("environment.prefiltered: {err}")))?;
                Some(std::sync::Arc::new(
                    prefiltered_table(&p, pf, Some(&light.map))
                        .map_err(|err| self.err(format!("environment.prefiltered: {err}")))?,
                ))
            }
        };
        let sgs = light
            .lobes
            .iter()
            .map(|l| FileSg {
                axis: l.axis,
                sharpness: l.sharpness,
                amplitude: serde_json::json!(l.amplitude),
            })
            .collect();
        Ok((self.environment_sgs(sgs)?, Some(light), prefiltered))
    }

    /// The environment's SGs (axes normalised).
    fn environment_sgs(&self, sgs: Vec<FileSg>) -> Result<Vec<Sg>, String> {
        let mut environment = Vec::new();
        for (k, g) in sgs.into_iter().enumerate() {
            let what = format!("environment.sgs[{k}]");
            let axis = self.vec3(&format!("{what}.axis"), g.axis)?;
            if axis.length() == 0.0 {
                return Err(self.err(format!("{what}.axis is the zero vector")));
            }
            let sharpness = self.positive(&format!("{what}.sharpness"), g.sharpness)?;
            let at = format!("{what}.amplitude");
            let amplitude = match &g.amplitude {
                serde_json::Value::Array(c) if c.len() == 3 => {
                    let mut rgb = [0.0; 3];
                    for (q, v) in c.iter().enumerate() {
                        let x = v.as_f64().ok_or_else(|| {
                            self.err(format!("{at}[{q}] is {v}: expected a number (linear RGB radiance)"))
                        })?;
                        rgb[q] = self.radiance(&format!("{at}[{q}]"), x)?;
                    }
                    crate::envmap::luminance(rgb)
                }
                v => {
                    let x = v.as_f64().ok_or_else(|| {
                        self.err(format!("{at} is {v}: expected a radiance or [r, g, b] (linear RGB)"))
                    })?;
                    self.radiance(&at, x)?
                }
            };
            environment
                .push(Sg::new(axis.normalize(), sharpness, amplitude).map_err(|e| self.err(format!("{what}: {e}")))?);
        }
        Ok(environment)
    }

    /// The sphere lights.
    fn lights(&self, file: Vec<FileLight>) -> Result<Vec<SphereLight>, String> {
        let mut lights = Vec::new();
        for (k, l) in file.into_iter().enumerate() {
            let FileLight::Sphere {
                centre,
                radius,
                radiance: value,
            } = l;
            let what = format!("lights[{k}]");
            let value = self.radiance(&format!("{what}.radiance"), value)?;
            lights.push(SphereLight {
                sphere: Sphere {
                    centre: self.vec3(&format!("{what}.centre"), centre)?,
                    radius: self.length(&format!("{what}.radius"), radius)?,
                },
                radiance: value,
            });
        }
        Ok(lights)
    }

    /// Builds the checked height field (O(n²) time and memory).
    fn build_heightfield(&self, spec: HeightFieldSpec) -> Result<(HeightField, usize), String> {
        let (n, extent, heights, procedural, m) = spec;
        let hf = match (heights, procedural) {
            (Some(heights), _) => HeightField::new(n, extent, heights),
            (None, Some(p)) => HeightField::procedural(n, extent, p.amplitude, p.octaves, p.seed),
            (None, None) => unreachable!("checked above"),
        }
        .map_err(|e| self.err(format!("heightfield: {e}")))?;
        Ok((hf, m))
    }

    /// Reads the meshes and their sphere sets (read or fitted), transformed into the
    /// scene: the meshes, and the proxies (`spheres`, then each mesh's set).
    fn build_meshes(&self, specs: Vec<MeshSpec>, spheres: &[Sphere]) -> Result<(Vec<SceneMesh>, Vec<Sphere>), String> {
        let err = |m: String| self.err(m);
        // The sphere total before any mesh is read or fitted (a fit takes minutes): the
        // files' sets read (small), the fitted ones counted.
        enum Set {
            Read(Vec<Sphere>),
            Fit(usize, Method, u64, Option<f64>),
        }
        let mut total = spheres.len();
        let mut sets = Vec::new();
        for (what, path, t, set, material, bend, skin) in specs {
            let set = match set {
                SetSpec::File(p) => {
                    let text = lobefit_core::io::read_text(&p, MAX_SCENE_LEN)
                        .map_err(|e| err(format!("{what}.spheres {}: {e}", p.display())))?;
                    let set = lobefit_core::json::from_str::<SphereSetFile>(&text)
                        .and_then(|f| f.spheres())
                        .map_err(|e| err(format!("{what}.spheres {}: {e}", p.display())))?;
                    total += set.len();
                    Set::Read(set)
                }
                SetSpec::Fit(count, method, seed, overlap) => {
                    total += count;
                    Set::Fit(count, method, seed, overlap)
                }
            };
            sets.push((what, path, t, set, material, bend, skin));
        }
        if total > MAX_SPHERES {
            return Err(err(format!(
                "spheres and the meshes' sphere sets hold {total} spheres, more than {MAX_SPHERES} (MAX_SPHERES)"
            )));
        }
        let mut meshes = Vec::new();
        let mut proxies = spheres.to_vec();
        for (what, path, t, set, material, bend, skin) in sets {
            let (local, skin) = match skin {
                None => (Mesh::load(&path).map_err(|e| err(format!("{what}: {e}")))?, None),
                Some(animation) => {
                    let (m, s) = crate::skin::Skin::load(&path, animation.as_deref())
                        .map_err(|e| err(format!("{what}.skin: {e}")))?;
                    (m, Some(s))
                }
            };
            let local_spheres = match set {
                Set::Read(set) => set,
                Set::Fit(count, method, seed, overlap) => {
                    crate::spheres::fit_with(&local, count, method, seed, overlap)
                        .map_err(|e| err(format!("{what}.spheres: {e}")))?
                }
            };
            let mesh = local.transformed(&t).map_err(|e| err(format!("{what}: {e}")))?;
            let start = proxies.len();
            proxies.extend(local_spheres.iter().map(|s| Sphere {
                centre: t.point(s.centre),
                radius: t.scale * s.radius,
            }));
            if proxies.len() > MAX_SPHERES {
                return Err(err(format!(
                    "spheres and the meshes' sphere sets hold {} spheres, more than {MAX_SPHERES} (MAX_SPHERES)",
                    proxies.len()
                )));
            }
            let (lo, hi) = mesh.bounds();
            let skin = skin.map(|s| {
                let centres = local_spheres.iter().map(|s| s.centre).collect();
                std::sync::Arc::new(crate::skin::Skinned::new(s, local.vertices.clone(), t, centres))
            });
            let pose = (bend.is_some() || skin.is_some()).then(|| Pose {
                bend,
                skin,
                rest: mesh.clone(),
                rest_set: proxies[start..].to_vec(),
                pivot: 0.5 * (lo + hi),
            });
            meshes.push(SceneMesh {
                t_min: MESH_T_MIN * (hi - lo).length(),
                mesh,
                material,
                proxy: start..proxies.len(),
                pose,
            });
        }
        Ok((meshes, proxies))
    }
}

/// The materials as BRDFs (a Lafortune lobe's specular factor ρ_s as its ρ =
/// ρ_s (n + 2) / 2π).
fn brdfs(materials: Vec<FileMaterial>) -> Vec<Brdf> {
    materials
        .into_iter()
        .map(|m| match m {
            FileMaterial::Lambert { albedo } => Brdf::Lambert { albedo },
            FileMaterial::CookTorrance {
                albedo,
                specular,
                roughness,
                f0,
            } => Brdf::CookTorrance {
                albedo,
                specular: CookTorrance::new(specular, roughness, f0).expect("checked on load"),
            },
            FileMaterial::BlinnPhong {
                albedo,
                specular,
                exponent,
            } => Brdf::BlinnPhong {
                albedo,
                specular: BlinnPhong::new(specular, exponent).expect("checked on load"),
            },
            FileMaterial::Lafortune { albedo, lobes } => Brdf::Lafortune {
                albedo,
                lobes: lobes
                    .into_iter()
                    .map(|l| LafortuneLobe {
                        c: DVec3::from_array(l.c),
                        rho: l.specular * (l.exponent + 2.0) / TAU,
                        exponent: l.exponent,
                    })
                    .collect(),
            },
        })
        .collect()
}

/// A scene file the tests edit (one spherical light and five blockers over a plane:
/// Meunier's Figure 13 analogue).
#[cfg(test)]
const TEST_SCENE: &str = include_str!("meunier/scenes/fig13.json");

#[cfg(test)]
mod tests {
    use super::*;
    use lobefit_core::rng::Rng;

    fn random_spheres(rng: &mut Rng, n: usize) -> Vec<Sphere> {
        (0..n)
            .map(|_| Sphere {
                centre: DVec3::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0), rng.range(-5.0, 5.0)),
                radius: rng.range(0.05, 1.0),
            })
            .collect()
    }

    fn random_dir(rng: &mut Rng) -> DVec3 {
        let z = rng.range(-1.0, 1.0);
        let phi = rng.range(0.0, TAU);
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// The BVH answers exactly what a linear scan answers (rays from inside and
    /// outside the spheres, axis-aligned rays whose slabs give 0·∞).
    #[test]
    fn bvh_equals_a_linear_scan() {
        let mut rng = Rng::new(7);
        for n in [0, 1, 3, 4, 5, 17, 200] {
            let spheres = random_spheres(&mut rng, n);
            let bvh = Bvh::new(&spheres);
            for k in 0..2000 {
                let x = DVec3::new(rng.range(-6.0, 6.0), rng.range(-6.0, 6.0), rng.range(-6.0, 6.0));
                let v = if k % 10 == 0 { DVec3::X } else { random_dir(&mut rng) };
                let t_max = if k % 3 == 0 { rng.range(0.5, 8.0) } else { f64::INFINITY };
                let scan = spheres
                    .iter()
                    .enumerate()
                    .filter_map(|(i, s)| ray_sphere(x, v, s).map(|t| (t, i)))
                    .filter(|&(t, _)| t < t_max)
                    .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                assert_eq!(bvh.nearest(&spheres, x, v, t_max), scan, "n {n} ray {k}");
                let skip = (n > 0).then(|| k % n);
                let any = spheres
                    .iter()
                    .enumerate()
                    .any(|(i, s)| Some(i) != skip && ray_sphere(x, v, s).is_some_and(|t| t < t_max));
                assert_eq!(bvh.occluded(&spheres, x, v, t_max, skip), any, "n {n} ray {k}");
            }
        }
    }

    #[test]
    fn ray_sphere_from_outside_inside_and_behind() {
        let s = Sphere {
            centre: DVec3::new(0.0, 0.0, 5.0),
            radius: 1.0,
        };
        assert_eq!(ray_sphere(DVec3::ZERO, DVec3::Z, &s), Some(4.0));
        assert_eq!(ray_sphere(DVec3::new(0.0, 0.0, 5.0), DVec3::Z, &s), Some(1.0));
        assert_eq!(ray_sphere(DVec3::ZERO, -DVec3::Z, &s), None);
        assert_eq!(ray_sphere(DVec3::new(2.0, 0.0, 0.0), DVec3::Z, &s), None);
    }

    #[test]
    fn plane_patch_is_one_sided_and_finite() {
        let p = Plane {
            normal: DVec3::Z,
            offset: 1.0,
            tangent: DVec3::X,
            half_extent: 2.0,
        };
        let down = -DVec3::Z;
        assert_eq!(p.intersect(DVec3::new(0.5, -1.5, 3.0), down), Some(2.0));
        assert_eq!(p.intersect(DVec3::new(2.5, 0.0, 3.0), down), None);
        assert_eq!(p.intersect(DVec3::new(0.0, 0.0, -1.0), DVec3::Z), None);
        assert_eq!(p.intersect(DVec3::new(0.0, 0.0, 0.5), down), None);
    }

    /// The fig13 scene with its spheres, lights and SGs replaced by `n` of each kind.
    fn with_counts(spheres: usize, lights: usize, sgs: usize) -> String {
        let mut v: serde_json::Value = serde_json::from_str(TEST_SCENE).unwrap();
        let s = v["spheres"][0].clone();
        let l = v["lights"][0].clone();
        v["spheres"] = (0..spheres).map(|_| s.clone()).collect();
        v["lights"] = (0..lights).map(|_| l.clone()).collect();
        let g = serde_json::json!({"axis": [0, 0, 1], "sharpness": 2, "amplitude": 1});
        v["environment"] = serde_json::json!({ "sgs": (0..sgs).map(|_| g.clone()).collect::<Vec<_>>() });
        v.to_string()
    }

    /// Sizes are bounded, with errors naming the limit; the largest allowed parse.
    #[test]
    fn scene_sizes_are_bounded() {
        for (text, want) in [
            (
                with_counts(MAX_SPHERES + 1, 1, 1),
                "spheres has 16385 entries, more than the 16384 a scene may hold (MAX_SPHERES",
            ),
            (
                with_counts(1, MAX_LIGHTS + 1, 1),
                "lights has 65 entries, more than the 64 a scene may hold (MAX_LIGHTS",
            ),
            (
                with_counts(1, 1, MAX_SGS + 1),
                "environment.sgs has 257 entries, more than the 256 a scene may hold (MAX_SGS",
            ),
        ] {
            let e = parse("t", &text).unwrap_err();
            assert!(e.contains(want), "{e} (want {want})");
        }
        let s = parse("t", &with_counts(MAX_SPHERES, MAX_LIGHTS, MAX_SGS)).unwrap();
        assert_eq!(
            (s.spheres.len(), s.lights.len(), s.environment.len()),
            (MAX_SPHERES, MAX_LIGHTS, MAX_SGS)
        );
    }

    /// A pipeline's kinds are checked before the height field is built: a 4097²
    /// procedural terrain (seconds and ~0.7 GB to build) is refused at once by a
    /// pipeline without height fields, and check_file validates it without building.
    #[test]
    fn kinds_are_refused_before_the_height_field_is_built() {
        let text = r#"{"version":1,"environment":{"sgs":[{"axis":[0,0,1],"sharpness":5,"amplitude":1}]},
            "heightfield":{"size":4097,"extent":8,"procedural":{"amplitude":1,"octaves":3,"seed":1},
            "material":{"lambert":{"albedo":0.5}}}}"#;
        let no_terrain = Accepts {
            pipeline: "the test pipeline",
            heightfield: false,
            ..Accepts::ALL
        };
        let t = std::time::Instant::now();
        let e = parse_inner("t", text, None, &no_terrain, true).unwrap_err();
        assert!(
            e.contains("the test pipeline cannot shade a height field (`heightfield`)"),
            "{e}"
        );
        assert!(parse_inner("t", text, None, &Accepts::ALL, false).unwrap().is_none());
        // Building it takes seconds; refusing it, microseconds.
        assert!(t.elapsed().as_secs_f64() < 0.5, "{:?}", t.elapsed());
        let lights = Accepts {
            sphere_lights: false,
            ..no_terrain
        };
        let e = parse_inner("t", TEST_SCENE, None, &lights, true).unwrap_err();
        assert!(e.contains("cannot shade sphere lights (`lights`)"), "{e}");
    }

    /// A camera inside a sphere or below the height field is refused at render start
    /// (primary_hits) naming it; before, the inside of the sphere was shaded as lit.
    #[test]
    fn a_camera_inside_a_sphere_or_below_the_terrain_is_refused() {
        let inside = TEST_SCENE.replace("\"eye\": [0.0, -6.5, 4.5]", "\"eye\": [-1.2, 0.1, 0.9]");
        assert_ne!(inside, TEST_SCENE);
        let e = parse("t", &inside).unwrap().primary_hits(8, 6).unwrap_err();
        assert!(e.contains("camera.eye [-1.2, 0.1, 0.9] lies inside spheres[0]"), "{e}");
        let text = r#"{"version":1,"environment":{"sgs":[{"axis":[0,0,1],"sharpness":5,"amplitude":1}]},
            "camera":{"eye":[0.5,0.5,0.2],"target":[0,3,0.5],"fov":0.8},
            "heightfield":{"size":3,"extent":4,"heights":[1,1,1,1,1,1,1,1,1],"material":{"lambert":{"albedo":0.5}}}}"#;
        let e = parse("t", text).unwrap().primary_hits(8, 6).unwrap_err();
        assert!(
            e.contains("camera.eye [0.5, 0.5, 0.2] lies below the heightfield"),
            "{e}"
        );
        assert!(parse("t", &text.replace("0.5,0.5,0.2", "0.5,0.5,1.2"))
            .unwrap()
            .primary_hits(8, 6)
            .is_ok());
        assert!(parse("t", TEST_SCENE).unwrap().primary_hits(8, 6).is_ok());
    }

    /// Bad scene files are specific errors naming the field.
    #[test]
    fn bad_scene_files_are_specific_errors() {
        let good = TEST_SCENE;
        let cases = [
            (good.replace("\"version\": 1", "\"version\": 3"), "version 3"),
            (
                good.replace("\"radius\": 0.5", "\"radius\": -0.5"),
                "spheres[0].radius -0.5",
            ),
            (good.replace("\"fov\": 0.75", "\"fov\": 4.0"), "camera.fov 4"),
            (
                good.replace("\"normal\": [0.0, 0.0, 1.0]", "\"normal\": [0.0, 0.0, 2.0]"),
                "planes[0].normal",
            ),
            (good.replace("\"albedo\": 0.8", "\"albedo\": 1.8"), "albedo 1.8"),
            (
                good.replace("\"version\": 1", "\"version\": 1, \"fog\": 1"),
                "unknown field `fog`",
            ),
            (
                good.replace("\"radiance\": 4.0", "\"radiance\": -4.0"),
                "lights[0].radiance",
            ),
            ("{".to_string(), "EOF"),
            // Squares of 1e154 overflowed in ray_sphere and the sphere vanished.
            (
                good.replace("\"centre\": [-1.2, 0.0, 0.9]", "\"centre\": [1e154, 0.0, 0.9]"),
                "spheres[0].centre [1e154, 0.0, 0.9] must be finite with every |coordinate| ≤ 1e6 (MAX_COORD)",
            ),
            (
                good.replace("\"radius\": 0.5", "\"radius\": 2e6"),
                "spheres[0].radius 2000000.0 must be finite, > 0 and ≤ 1e6",
            ),
            (
                good.replace("\"radiance\": 4.0", "\"radiance\": 1e300"),
                "lights[0].radiance 1e300 must be finite, ≥ 0 and ≤ 1e12 (MAX_RADIANCE)",
            ),
            (good.replace("\"offset\": 0.0", "\"offset\": 1e200"), "planes[0].offset"),
        ];
        for (text, want) in cases {
            assert_ne!(text, good, "case {want} did not change the file");
            let e = parse("t", &text).unwrap_err();
            assert!(e.starts_with("scene t: ") && e.contains(want), "{e} (want {want})");
        }
        // check_file gives load's errors without building anything.
        assert!(check_file("/nonexistent/scene.json")
            .unwrap_err()
            .contains("/nonexistent/scene.json"));
        assert!(load("/nonexistent/scene.json")
            .unwrap_err()
            .contains("/nonexistent/scene.json"));
        // A directory (or a FIFO) is refused before reading.
        let dir = tempfile::tempdir().unwrap();
        let e = load(dir.path().to_str().unwrap()).unwrap_err();
        assert!(e.contains("is a directory, not a regular file"), "{e}");
    }
}

#[cfg(test)]
mod mesh_tests {
    use super::*;
    use lobefit_core::rng::Rng;

    /// A lumpy closed mesh (an octahedron subdivided 3 times, 512 triangles, its
    /// vertices pushed to radius 1 ± 0.25 by a seeded bump) as OBJ text.
    pub(super) fn lumpy_obj() -> String {
        let m = crate::mesh::tests::ball(DVec3::ZERO, 1.0, 3);
        let mut s = String::new();
        for p in &m.vertices {
            let bump = 1.0 + 0.25 * (3.0 * p.x).sin() * (2.0 * p.y + 1.0).cos();
            let q = bump * *p;
            s += &format!("v {} {} {}\n", q.x, q.y, q.z);
        }
        for t in &m.triangles {
            s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
        }
        s
    }

    /// A version 2 scene: a plane, the lumpy mesh lifted to z = 1.6, a sphere light
    /// above it, an SG environment; the mesh's sphere set fitted on load.
    pub(super) fn scene_text(file: &str) -> String {
        format!(
            r#"{{"version": 2,
              "camera": {{"eye": [0, -6, 3], "target": [0, 0, 1], "fov": 0.8}},
              "planes": [{{"normal": [0,0,1], "offset": 0, "tangent": [1,0,0], "half_extent": 5,
                          "material": {{"lambert": {{"albedo": 0.7}}}}}}],
              "meshes": [{{"file": "{file}", "material": {{"lambert": {{"albedo": 0.5}}}},
                          "spheres": {{"count": 8, "method": "tree"}},
                          "transform": {{"scale": 1.2, "rotation": {{"axis": [1, 0, 0], "angle": 0.3}},
                                         "translation": [0, 0, 1.6]}}}}],
              "lights": [{{"sphere": {{"centre": [0.3, 0.2, 5.0], "radius": 0.8, "radiance": 10}}}}],
              "environment": {{"sgs": [{{"axis": [0,0,1], "sharpness": 2, "amplitude": 1}}]}}}}"#
        )
    }

    /// A point of the ground plane z = 0 at `x`, seen from straight above.
    fn plane_hit(x: DVec3) -> Hit {
        Hit {
            x,
            n: DVec3::Z,
            t: DVec3::X,
            wo: DVec3::Z,
            sphere: None,
            mesh: None,
            material: 0,
        }
    }

    fn write_scene() -> (tempfile::TempDir, std::path::PathBuf) {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("lumpy.obj"), lumpy_obj()).unwrap();
        let p = d.path().join("s.json");
        std::fs::write(&p, scene_text("lumpy.obj")).unwrap();
        (d, p)
    }

    /// Primary rays see the mesh where a scan over its triangles says, with the
    /// triangle's normal turned to the eye, and its sphere set is in `proxies`.
    #[test]
    fn primary_rays_see_the_mesh() {
        let (_d, p) = write_scene();
        let s = load(p.to_str().unwrap()).unwrap();
        assert_eq!(s.meshes.len(), 1);
        assert_eq!(s.proxies.len(), 8);
        assert_eq!(s.meshes[0].proxy, 0..8);
        let (w, h) = (32, 24);
        let mut on_mesh = 0;
        for px in 0..w * h {
            let hit = s.primary(px % w, px / w, w, h);
            let d = s.camera.ray(px % w, px / w, w, h);
            let brute = s.meshes[0].mesh.nearest_brute(s.camera.eye, d, 0.0, f64::INFINITY);
            let plane = s.planes[0].intersect(s.camera.eye, d);
            match (hit, brute) {
                (Some(hh), Some((t, k))) if plane.is_none_or(|tp| t < tp) => {
                    assert_eq!(hh.mesh, Some((0, k)), "pixel {px}");
                    assert!((hh.x - (s.camera.eye + t * d)).length() < 1e-12);
                    let g = s.meshes[0].mesh.normal(k);
                    assert!((hh.n.dot(g).abs() - 1.0).abs() < 1e-12 && hh.n.dot(d) < 0.0);
                    on_mesh += 1;
                }
                (hh, _) => assert!(hh.is_none_or(|x| x.mesh.is_none()), "pixel {px}"),
            }
        }
        assert!(on_mesh > 50, "{on_mesh}");
    }

    /// The analytic pipelines' view of a mesh: `blockers` are the proxies but the hit's
    /// own, `proxies_occlude` (the proxy BVH) equals a scan over `blockers`, and
    /// `buried` says whether one of them contains the point; a point on the mesh sees
    /// past the spheres of its set that hold it (and only those), a plane point under
    /// the set is blocked by it.
    #[test]
    fn proxies_are_the_blockers_the_analytic_pipelines_see() {
        let (_d, p) = write_scene();
        let s = load(p.to_str().unwrap()).unwrap();
        let mut rng = Rng::new(0x77);
        let (w, h) = (24, 18);
        let (mut on_mesh, mut blocked) = (0, 0);
        for px in 0..w * h {
            let Some(hit) = s.primary(px % w, px / w, w, h) else {
                continue;
            };
            let blockers = s.blockers(&hit);
            if hit.mesh.is_some() {
                // Its own: the set's spheres containing it or passing within OWN_MARGIN of
                // it, at least one (a covering set); the rest of the set blocks it.
                let own: Vec<&Sphere> = s
                    .proxies
                    .iter()
                    .filter(|b| (hit.x - b.centre).length() <= b.radius * (1.0 + OWN_MARGIN))
                    .collect();
                assert!(!own.is_empty(), "pixel {px}: no sphere of the set holds its point");
                assert_eq!(blockers.len() + own.len(), s.proxies.len(), "pixel {px}");
                assert!(blockers.iter().all(|b| !own.contains(&b)));
                on_mesh += 1;
            } else {
                assert_eq!(blockers.len(), s.proxies.len());
            }
            assert_eq!(
                s.buried(&hit),
                blockers.iter().any(|b| (hit.x - b.centre).length() <= b.radius)
            );
            for _ in 0..16 {
                let v = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(0.05, 1.0)).normalize();
                let scan = blockers.iter().any(|b| ray_sphere(hit.x, v, b).is_some());
                assert_eq!(s.proxies_occlude(&hit, v), scan, "pixel {px}, direction {v}");
                blocked += usize::from(scan);
            }
        }
        assert!(
            on_mesh > 10 && blocked > 10,
            "{on_mesh} mesh pixels, {blocked} blocked rays"
        );
        // A plane point straight under the set: the set blocks the zenith.
        let under = plane_hit(DVec3::ZERO);
        assert!(s.proxies_occlude(&under, DVec3::Z));
    }

    /// A point inside a mesh's covering sphere is in its full shadow in the ISG and SH
    /// renders (Meunier's uses the same `Scene::buried`): 0, where the same point
    /// outside every sphere is lit.
    #[test]
    fn a_buried_point_is_in_full_shadow() {
        let (_d, p) = write_scene();
        let s = load(p.to_str().unwrap()).unwrap();
        let at = plane_hit;
        let (inside, outside) = (at(s.proxies[0].centre), at(DVec3::new(4.0, 4.0, 0.0)));
        assert!(s.buried(&inside) && !s.buried(&outside));
        let t = crate::isg::shade::Tables::embedded().unwrap();
        let isg = |h: &Hit| crate::isg::render::shade_hit(&t, &Default::default(), &s, h).unwrap();
        assert_eq!(isg(&inside), 0.0);
        assert!(isg(&outside) > 0.0);
        let st = crate::shexp::shade::Tables::embedded().unwrap();
        let settings = crate::shexp::shade::Settings::default();
        let light = crate::shexp::shade::project_sgs(&s.environment, settings.order).unwrap();
        let brdf = crate::sky::Phong::of(&s.materials[0]).unwrap();
        let sh = |h: &Hit| crate::shexp::shade::radiance(&st, &settings, &light, &brdf, &s, h).unwrap();
        assert_eq!(sh(&inside), 0.0);
        assert!(sh(&outside) > 0.0);
    }

    /// The sphere light's irradiance at random plane points under the mesh: the
    /// scene's exact visibility (`light_visible`, the triangle BVH) on 128 × 128
    /// jittered directions of the light's cone against an independent quadrature
    /// (a 96 × 384 midpoint rule, every direction tested against every triangle):
    /// within 0.5 % of the unoccluded irradiance.
    #[test]
    fn exact_visibility_matches_a_brute_force_quadrature() {
        let (_d, p) = write_scene();
        let s = load(p.to_str().unwrap()).unwrap();
        let light = s.lights[0].sphere;
        let mesh = &s.meshes[0].mesh;
        let mut rng = Rng::new(0x41);
        let mut partly = 0;
        for _ in 0..6 {
            // Around the shadow's edge (the mesh spans about ±1.2 across).
            let (r, a) = (rng.range(0.8, 2.0), rng.range(0.0, TAU));
            let x = DVec3::new(r * a.cos(), r * a.sin(), 0.0);
            let hit = plane_hit(x);
            let axis = (light.centre - x).normalize();
            let dist = (light.centre - x).length();
            let cos_max = (1.0 - (light.radius / dist).powi(2)).sqrt();
            let (u_axis, v_axis) = axis.any_orthonormal_pair();
            let dir = |a: f64, b: f64| {
                let c = 1.0 - a * (1.0 - cos_max);
                let sn = (1.0 - c * c).max(0.0).sqrt();
                let phi = TAU * b;
                c * axis + sn * (phi.cos() * u_axis + phi.sin() * v_axis)
            };
            let omega = TAU * (1.0 - cos_max);
            let (n1, mut est, mut open) = (128, 0.0, 0.0);
            for i in 0..n1 {
                for j in 0..n1 {
                    let w = dir(
                        (i as f64 + rng.uniform()) / n1 as f64,
                        (j as f64 + rng.uniform()) / n1 as f64,
                    );
                    let c = w.z.max(0.0);
                    open += c;
                    if s.light_visible(&hit, w, &light) {
                        est += c;
                    }
                }
            }
            let (est, open) = (omega * est / (n1 * n1) as f64, omega * open / (n1 * n1) as f64);
            let (na, nb) = (96, 384);
            let mut refv = 0.0;
            for i in 0..na {
                for j in 0..nb {
                    let w = dir((i as f64 + 0.5) / na as f64, (j as f64 + 0.5) / nb as f64);
                    let blocked = (0..mesh.triangles.len()).any(|k| {
                        let [a, b, c] = mesh.corners(k);
                        let e1 = b - a;
                        let e2 = c - a;
                        // Plain barycentric solve (Cramer's rule), not the BVH's code.
                        let m = lobefit_tables::glam::DMat3::from_cols(-w, e1, e2);
                        let det = m.determinant();
                        if det.abs() < 1e-300 {
                            return false;
                        }
                        let sol = m.inverse() * (x - a);
                        sol.x > 0.0 && sol.y >= 0.0 && sol.z >= 0.0 && sol.y + sol.z <= 1.0
                    });
                    if !blocked {
                        refv += w.z.max(0.0);
                    }
                }
            }
            let refv = omega * refv / (na * nb) as f64;
            assert!(
                (est - refv).abs() < 5e-3 * open,
                "at {x}: BVH {est} vs brute force {refv} (unoccluded {open})"
            );
            partly += usize::from(refv > 0.02 * open && refv < 0.98 * open);
        }
        assert!(partly >= 2, "{partly} points partly shadowed");
    }

    /// Paths leaving the scene's folder, meshes in a version 1 file or in a scene
    /// without a folder, a missing file and bad sphere sets are specific errors.
    #[test]
    fn mesh_entries_are_checked() {
        let (d, p) = write_scene();
        let text = std::fs::read_to_string(&p).unwrap();
        let at = |t: String| {
            let q = d.path().join("t.json");
            std::fs::write(&q, t).unwrap();
            load(q.to_str().unwrap()).unwrap_err()
        };
        assert!(at(text.replace("lumpy.obj", "../lumpy.obj")).contains("no `..`"));
        assert!(at(text.replace("lumpy.obj", "/etc/passwd")).contains("not absolute"));
        assert!(at(text.replace("lumpy.obj", "missing.obj")).contains("missing.obj"));
        assert!(at(text.replace("\"version\": 2", "\"version\": 1")).contains("version\": 2"));
        assert!(at(text.replace("\"count\": 8", "\"count\": 0")).contains("count is 0: expected an integer from 1"));
        assert!(at(text.replace("\"tree\"", "\"octopus\"")).contains("octopus"));
        assert!(at(text.replace("\"scale\": 1.2", "\"scale\": -1")).contains("scale"));
        let outside = tempfile::tempdir().unwrap();
        std::fs::write(outside.path().join("o.obj"), lumpy_obj()).unwrap();
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(outside.path().join("o.obj"), d.path().join("link.obj")).unwrap();
            assert!(at(text.replace("lumpy.obj", "link.obj")).contains("symbolic link"));
        }
        std::fs::write(d.path().join("bad.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
        let e = at(text.replace("lumpy.obj", "bad.obj"));
        assert!(e.contains("bad.obj") && e.contains("vertex"), "{e}");
        assert!(parse("t", &text).unwrap_err().contains("no folder"));
        // Only the ISG pipeline takes meshes.
        let shexp = Accepts {
            meshes: false,
            pipeline: "the SH pipeline",
            ..Accepts::ALL
        };
        assert!(load_for(p.to_str().unwrap(), &shexp).unwrap_err().contains("meshes"));
    }
}

#[cfg(test)]
mod sphere_set_file_tests {
    use super::*;

    /// A sphere set read from a file lands in `proxies` under the mesh's transform
    /// (x ↦ R(s·x) + t, radius s·r, written out by hand here); a bad set is an error
    /// naming the file.
    #[test]
    fn a_sphere_set_file_is_transformed() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(
            d.path().join("m.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        )
        .unwrap();
        std::fs::write(
            d.path().join("set.json"),
            r#"{"version": 1, "mesh": "m.obj", "method": "tree", "seed": 0,
                "spheres": [{"centre": [1, 0, 0], "radius": 0.25}, {"centre": [0, 1, 0.5], "radius": 0.5}]}"#,
        )
        .unwrap();
        let text = r#"{"version": 2, "camera": {"eye": [0, -6, 3], "target": [0, 0, 0], "fov": 0.8},
            "meshes": [{"file": "m.obj", "material": {"lambert": {"albedo": 0.5}}, "spheres": "set.json",
                        "transform": {"scale": 2, "rotation": {"axis": [0, 0, 1], "angle": 1.5707963267948966},
                                      "translation": [1, 2, 3]}}],
            "environment": {"sgs": [{"axis": [0, 0, 1], "sharpness": 2, "amplitude": 1}]}}"#;
        let s = parse_in("t", text, d.path()).unwrap();
        // Rotation by π/2 about z: (x, y, z) ↦ (−y, x, z).
        let want = [(DVec3::new(1.0, 4.0, 3.0), 0.5), (DVec3::new(-1.0, 2.0, 4.0), 1.0)];
        for (p, (c, r)) in s.proxies.iter().zip(want) {
            assert!((p.centre - c).length() < 1e-12 && (p.radius - r).abs() < 1e-15, "{p:?}");
        }
        std::fs::write(
            d.path().join("set.json"),
            r#"{"version": 1, "mesh": "m.obj", "method": "tree", "seed": 0, "spheres": [{"centre": [1, 0, 0], "radius": -1}]}"#,
        )
        .unwrap();
        let e = parse_in("t", text, d.path()).unwrap_err();
        assert!(e.contains("set.json") && e.contains("spheres[0]"), "{e}");
    }
}

#[cfg(test)]
mod motion_tests {
    use super::mesh_tests::{lumpy_obj, scene_text};
    use super::*;

    /// The mesh scene with a keyed mesh (`mesh_keys`) and a keyed sphere.
    fn moving_scene(mesh_keys: &str) -> (tempfile::TempDir, Scene) {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("lumpy.obj"), lumpy_obj()).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&scene_text("lumpy.obj")).unwrap();
        v["meshes"][0]["keys"] = serde_json::from_str(mesh_keys).unwrap();
        v["spheres"] = serde_json::json!([{"centre": [2, 0, 0.5], "radius": 0.5,
            "material": {"lambert": {"albedo": 0.5}},
            "keys": [{"time": 0.5, "translation": [0, 0, 2]}, {"time": 1, "translation": [0, 0, 0]}]}]);
        let s = parse_in("t", &v.to_string(), d.path()).unwrap();
        (d, s)
    }

    /// Keys interpolate linearly and hold outside their span; the parsed scene is the
    /// still at time 0 (the first key's translation applied) and `at` moves the sphere,
    /// the mesh's triangles and its sphere set together, with the hierarchies rebuilt
    /// (primary hits equal a scan over the moved triangles).
    #[test]
    fn tracks_move_spheres_meshes_and_their_proxies() {
        let keys = r#"[{"time": 0, "translation": [-1, 0, 0]}, {"time": 0.25, "translation": [1, 0, 0]},
                       {"time": 0.75, "translation": [1, 0, 1]}]"#;
        let (_d, s0) = moving_scene(keys);
        let (_d2, rest) = moving_scene(r#"[{"time": 0, "translation": [0, 0, 0]}]"#);
        let tr = &s0.tracks[1];
        assert_eq!(tr.object, Moving::Mesh(0));
        assert_eq!(tr.at(0.125), DVec3::new(0.0, 0.0, 0.0));
        assert_eq!(tr.at(0.5), DVec3::new(1.0, 0.0, 0.5));
        assert_eq!(tr.at(0.9), DVec3::new(1.0, 0.0, 1.0));
        let sphere = &s0.tracks[0];
        assert_eq!(
            (sphere.object, sphere.at(0.0), sphere.at(0.75)),
            (Moving::Sphere(0), DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.0, 0.0, 1.0))
        );
        // Time 0: the sphere 2 up, the mesh 1 to −x of the file's places.
        assert_eq!(s0.spheres[0].centre, DVec3::new(2.0, 0.0, 2.5));
        let shift = |a: &Scene, b: &Scene| a.meshes[0].mesh.vertices[7] - b.meshes[0].mesh.vertices[7];
        assert!((shift(&s0, &rest) - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-12);
        let s = s0.at(0.5).unwrap();
        assert!(s.tracks.is_empty());
        assert_eq!(s.spheres[0].centre, DVec3::new(2.0, 0.0, 2.5));
        assert_eq!(s.proxies[0].centre, s.spheres[0].centre);
        assert!((shift(&s, &rest) - DVec3::new(1.0, 0.0, 0.5)).length() < 1e-12);
        for p in s.meshes[0].proxy.clone() {
            assert!((s.proxies[p].centre - rest.proxies[p].centre - DVec3::new(1.0, 0.0, 0.5)).length() < 1e-12);
        }
        let (w, h) = (24, 18);
        let mut on_mesh = 0;
        for px in 0..w * h {
            let d = s.camera.ray(px % w, px / w, w, h);
            let brute = s.meshes[0].mesh.nearest_brute(s.camera.eye, d, 0.0, f64::INFINITY);
            if let (Some(hit), Some((_, k))) = (s.primary(px % w, px / w, w, h), brute) {
                if hit.mesh.is_some() {
                    assert_eq!(hit.mesh, Some((0, k)), "pixel {px}");
                    on_mesh += 1;
                }
            }
        }
        assert!(on_mesh > 20, "{on_mesh}");
    }

    /// Bad keys are errors naming the key: times out of [0, 1] or not increasing, a
    /// non-finite translation, keys in a version 1 file.
    #[test]
    fn bad_keys_are_errors() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("lumpy.obj"), lumpy_obj()).unwrap();
        for (keys, want) in [
            (
                r#"[{"time": -0.1, "translation": [0, 0, 0]}]"#,
                "meshes[0].keys[0].time -0.1 must lie in [0, 1]",
            ),
            (
                r#"[{"time": 0.5, "translation": [0, 0, 0]}, {"time": 0.5, "translation": [0, 0, 0]}]"#,
                "meshes[0].keys[1].time 0.5 must be greater",
            ),
            (
                r#"[{"time": 0.5, "translation": [0, 0, 1e300]}]"#,
                "meshes[0].keys[0].translation",
            ),
            (r#"[{"time": 0.5}]"#, "missing field `translation`"),
        ] {
            let mut v: serde_json::Value = serde_json::from_str(&scene_text("lumpy.obj")).unwrap();
            v["meshes"][0]["keys"] = serde_json::from_str(keys).unwrap();
            let e = parse_in("t", &v.to_string(), d.path()).unwrap_err();
            assert!(e.contains(want), "{e} (want {want})");
        }
        let mut v: serde_json::Value = serde_json::from_str(TEST_SCENE).unwrap();
        v["version"] = 1.into();
        v["spheres"][0]["keys"] = serde_json::json!([{"time": 0, "translation": [0, 0, 1]}]);
        let e = parse("t", &v.to_string()).unwrap_err();
        assert!(e.contains("keys (motion) need \"version\": 2"), "{e}");
    }

    /// The lumpy mesh bent by two bones about the y axis through (0, 0, 1.6), the
    /// blend 0.8 wide along +z, up to `angle` at time 0.5.
    fn bent_scene(angle: f64) -> (tempfile::TempDir, Scene, Scene) {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("lumpy.obj"), lumpy_obj()).unwrap();
        let rest = parse_in("t", &scene_text("lumpy.obj"), d.path()).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&scene_text("lumpy.obj")).unwrap();
        v["meshes"][0]["bend"] = serde_json::json!({"pivot": [0, 0, 1.6], "axis": [0, 2, 0], "along": [0, 0, 1],
            "width": 0.8, "keys": [{"time": 0, "angle": 0}, {"time": 0.5, "angle": angle}, {"time": 1, "angle": 0}]});
        v["meshes"][0]["keys"] =
            serde_json::json!([{"time": 0, "translation": [0, 0, 0]}, {"time": 1, "translation": [1, 0, 0]}]);
        let bent = parse_in("t", &v.to_string(), d.path()).unwrap();
        (d, rest, bent)
    }

    /// A bend skins each vertex and each sphere centre of the rest pose by the formula
    /// written out here (smoothstep weight along +z, rotation about y through the
    /// pivot), then the track translates them; time 0 with angle 0 is the rest pose;
    /// primary hits on the bent mesh equal a scan over its triangles.
    #[test]
    fn a_bend_skins_the_mesh_and_carries_its_sphere_set() {
        let (_d, rest, bent) = bent_scene(0.7);
        let (a, b) = (&bent.meshes[0].mesh.vertices, &rest.meshes[0].mesh.vertices);
        assert!(
            a.iter().zip(b).all(|(p, q)| (*p - *q).length() < 1e-12),
            "time 0 is the rest pose"
        );
        let s = bent.at(0.5).unwrap();
        let (pivot, shift) = (DVec3::new(0.0, 0.0, 1.6), DVec3::new(0.5, 0.0, 0.0));
        let skin = |p: DVec3| {
            let u = ((p.z - 1.6) / 0.8 + 0.5).clamp(0.0, 1.0);
            let w = u * u * (3.0 - 2.0 * u);
            let (sn, cs) = 0.7f64.sin_cos();
            let r = p - pivot;
            // Rotation about +y: x' = x cos + z sin, z' = −x sin + z cos.
            let turned = pivot + DVec3::new(r.x * cs + r.z * sn, r.y, -r.x * sn + r.z * cs);
            (1.0 - w) * p + w * turned + shift
        };
        let (mut moved, mut kept) = (0, 0);
        for (a, b) in rest.meshes[0].mesh.vertices.iter().zip(&s.meshes[0].mesh.vertices) {
            assert!((skin(*a) - *b).length() < 1e-12, "{a} → {b}");
            if a.z < 1.2 {
                kept += usize::from((*b - *a - shift).length() < 1e-12);
            } else if a.z > 2.0 {
                moved += 1;
            }
        }
        assert!(moved > 10 && kept > 10, "{moved} turned, {kept} fixed");
        for p in rest.meshes[0].proxy.clone() {
            assert!((skin(rest.proxies[p].centre) - s.proxies[p].centre).length() < 1e-12);
            assert_eq!(rest.proxies[p].radius, s.proxies[p].radius);
        }
        let (w, h) = (24, 18);
        for px in 0..w * h {
            let d = s.camera.ray(px % w, px / w, w, h);
            let brute = s.meshes[0].mesh.nearest_brute(s.camera.eye, d, 0.0, f64::INFINITY);
            if let (Some(hit), Some((_, k))) = (s.primary(px % w, px / w, w, h), brute) {
                if hit.mesh.is_some() {
                    assert_eq!(hit.mesh, Some((0, k)), "pixel {px}");
                }
            }
        }
        let end = bent.at(1.0).unwrap();
        for (a, b) in rest.meshes[0].mesh.vertices.iter().zip(&end.meshes[0].mesh.vertices) {
            assert!((*b - *a - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        }
    }

    /// Bad bends are errors naming the field.
    #[test]
    fn bad_bends_are_errors() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("lumpy.obj"), lumpy_obj()).unwrap();
        let good = serde_json::json!({"pivot": [0, 0, 1], "axis": [0, 1, 0], "along": [0, 0, 1], "width": 0.5,
            "keys": [{"time": 0, "angle": 0.2}]});
        for (field, value, want) in [
            (
                "axis",
                serde_json::json!([0, 0, 0]),
                "meshes[0].bend.axis is the zero vector",
            ),
            ("width", serde_json::json!(0), "meshes[0].bend.width"),
            ("keys", serde_json::json!([]), "meshes[0].bend.keys has 0 keys"),
            (
                "keys",
                serde_json::json!([{"time": 0, "angle": 20}]),
                "meshes[0].bend.keys[0].angle 20",
            ),
            (
                "keys",
                serde_json::json!([{"time": 0.5, "angle": 0}, {"time": 0.2, "angle": 0}]),
                "meshes[0].bend.keys[1].time 0.2 must be greater",
            ),
        ] {
            let mut b = good.clone();
            b[field] = value;
            let mut v: serde_json::Value = serde_json::from_str(&scene_text("lumpy.obj")).unwrap();
            v["meshes"][0]["bend"] = b;
            let e = parse_in("t", &v.to_string(), d.path()).unwrap_err();
            assert!(e.contains(want), "{e} (want {want})");
        }
    }

    /// Rotation keys turn a mesh and its sphere set about the rest pose's bounding-box
    /// centre, before the translation: at a key, by exactly its rotation (checked against
    /// a quarter turn about z written out); between keys by slerp (half the angle
    /// halfway); a rotation on a sphere's keys is refused.
    #[test]
    fn rotation_keys_turn_a_mesh_about_its_centre() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("lumpy.obj"), lumpy_obj()).unwrap();
        let rest = parse_in("t", &scene_text("lumpy.obj"), d.path()).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&scene_text("lumpy.obj")).unwrap();
        v["meshes"][0]["keys"] = serde_json::json!([
            {"time": 0, "translation": [0, 0, 0]},
            {"time": 0.5, "translation": [1, 0, 0], "rotation": {"axis": [0, 0, 2], "angle": std::f64::consts::FRAC_PI_2}}]);
        let turning = parse_in("t", &v.to_string(), d.path()).unwrap();
        let (lo, hi) = rest.meshes[0].mesh.bounds();
        let c = 0.5 * (lo + hi);
        let quarter = |p: DVec3| c + DVec3::new(-(p.y - c.y), p.x - c.x, p.z - c.z) + DVec3::X;
        let s = turning.at(0.5).unwrap();
        for (a, b) in rest.meshes[0].mesh.vertices.iter().zip(&s.meshes[0].mesh.vertices) {
            assert!((quarter(*a) - *b).length() < 1e-12, "{a} → {b}");
        }
        for p in rest.meshes[0].proxy.clone() {
            assert!((quarter(rest.proxies[p].centre) - s.proxies[p].centre).length() < 1e-12);
        }
        // Halfway to the key: an eighth of a turn (slerp), half the translation.
        let h = turning.at(0.25).unwrap();
        let a = rest.meshes[0].mesh.vertices[5] - c;
        let (sn, cs) = std::f64::consts::FRAC_PI_4.sin_cos();
        let want = c + DVec3::new(a.x * cs - a.y * sn, a.x * sn + a.y * cs, a.z) + 0.5 * DVec3::X;
        assert!((h.meshes[0].mesh.vertices[5] - want).length() < 1e-12);
        let mut v: serde_json::Value = serde_json::from_str(TEST_SCENE).unwrap();
        v["version"] = 2.into();
        v["spheres"][0]["keys"] =
            serde_json::json!([{"time": 0, "translation": [0, 0, 1], "rotation": {"axis": [0, 0, 1], "angle": 1}}]);
        let e = parse("t", &v.to_string()).unwrap_err();
        assert!(
            e.contains("spheres[0].keys: a rotation turns a sphere into itself"),
            "{e}"
        );
    }
}
