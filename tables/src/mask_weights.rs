//! The visibility mask of Meunier et al. 2009 (§5.3, eq. 39) and its per-depth lobe
//! weights (table `mask-weights`; docs/math.md, mask-weights; docs/meunier.md).
//!
//! **Mask.** Seen from a shading point, a spherical light is a cap (axis a, half-angle
//! α) and every spherical blocker a cap (axis b_j, half-angle θ_j). A square S_unit of
//! side 1 is placed perpendicular to a at the distance `dist` = 1/(2 tan α), so that it
//! just circumscribes the light's cone; blockers whose caps miss the light's cap are
//! clipped. S_unit is split as a quad-tree: a cell (a spherical quadrilateral, since
//! straight lines of the plane are great circles) is *full* when one blocker cap
//! contains it, *empty* when no cap meets it or it misses the light's cone, and
//! *partial* otherwise; partial cells are subdivided down to the maximal depth D
//! (depth 0 is S_unit itself, a depth-d cell has side 2^−d). At depth D a partial cell
//! is dropped (*aggressive*, the paper's choice) or kept as a shadow leaf
//! (*conservative*). Every test is exact (cap against the quadrilateral's corners and
//! great-circle edges), so the mask is a function of the caps alone.
//!
//! **Leaf lobes.** A shadow leaf becomes the cap bounding its cell (axis through the
//! cell's corner sum, half-angle to the farthest corner) and so a cosine lobe of the
//! cap-exponent table. Visibility is then eq. 39:
//! V(v) = c_unit(v) − Σ_i w_{d_i}(dist) Ψ(v; a_i, e_cap(β_i)), where c_unit is the
//! hemisphere about the normal (erratum E6) and w_d the weight of depth d.
//!
//! **Weights.** Overlapping bounding caps over-darken; the weights undo it. The paper
//! tunes them by hand; the table holds weights *fitted* by least squares against the
//! exact mask visibility (the union of the caps) in L2 over the light's cone, and the
//! paper's procedure made automatic (coarse to fine, each depth's weight chosen with
//! the finer ones at 0), per maximal depth D ∈ 1..=5, per mode, on 16 `dist` nodes
//! uniform in ln dist over [0.25, 10], interpolated linearly in ln dist (outside that
//! range the end weights are held). [`WeightSet::Ones`] (every weight 1) needs no table.

use std::sync::OnceLock;

use glam::DVec3;

use crate::error::{finite, narrow_all, LoadError, LookupError};
use crate::format::{Axis, Encoding, Mapping, Placement};
use crate::table::Table;

/// Table kind.
pub const KIND: &str = "mask-weights";
/// Family version this runtime reads.
pub const VERSION: u32 = 1;
/// Deepest quad-tree the mask builds (the paper: "practically limited to 4 or 5").
pub const MAX_DEPTH: u32 = 5;
/// Smallest tabulated `dist` (a light of half-angle atan 2 ≈ 63.4°).
pub const DIST_MIN: f64 = 0.25;
/// Largest tabulated `dist` (a light of half-angle atan 0.05 ≈ 2.9°).
pub const DIST_MAX: f64 = 10.0;
/// Nodes of the `dist` axis.
#[cfg(feature = "writer")]
pub const DIST_NODES: u32 = 16;

/// What happens to cells still partially covered at the maximal depth (Figure 10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MaskMode {
    /// Dropped: fewer lobes, lighter penumbrae (the paper's choice).
    Aggressive,
    /// Kept as shadow leaves: darker penumbrae.
    Conservative,
}

impl MaskMode {
    /// Both modes, in channel order.
    pub const ALL: [MaskMode; 2] = [MaskMode::Aggressive, MaskMode::Conservative];

    /// `aggressive` or `conservative` (command-line name).
    pub fn name(self) -> &'static str {
        match self {
            MaskMode::Aggressive => "aggressive",
            MaskMode::Conservative => "conservative",
        }
    }

    fn short(self) -> &'static str {
        match self {
            MaskMode::Aggressive => "agg",
            MaskMode::Conservative => "con",
        }
    }
}

/// Which per-depth weights eq. 39 uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WeightSet {
    /// Least squares against the exact mask visibility (the default).
    Fitted,
    /// The paper's manual procedure made automatic (coarse to fine, one weight at a time).
    Paper,
    /// Every weight 1 (no correction of overlaps).
    Ones,
}

impl WeightSet {
    /// `fitted`, `paper` or `one` (command-line name).
    pub fn name(self) -> &'static str {
        match self {
            WeightSet::Fitted => "fitted",
            WeightSet::Paper => "paper",
            WeightSet::Ones => "one",
        }
    }

    fn short(self) -> Option<&'static str> {
        match self {
            WeightSet::Fitted => Some("fit"),
            WeightSet::Paper => Some("paper"),
            WeightSet::Ones => None,
        }
    }
}

/// `dist` of the paper for a light cap of half-angle `alpha` (rad, in (0, π/2)):
/// 1/(2 tan α), the distance at which a unit square circumscribes the cone.
pub fn dist_of_cap(alpha: f64) -> f64 {
    0.5 / alpha.tan()
}

/// Name of the stored channel holding the weight of depth `level` (1..=`depth`) for
/// masks of maximal depth `depth` (e.g. `fit_agg_d5_w2`); `None` for
/// [`WeightSet::Ones`]. Depth 0 (S_unit itself) never holds a shadow leaf: a cap
/// containing S_unit contains the light's cap, which hides the light.
pub fn channel_name(set: WeightSet, mode: MaskMode, depth: u32, level: u32) -> Option<String> {
    Some(format!("{}_{}_d{depth}_w{level}", set.short()?, mode.short()))
}

/// Every stored channel name, in storage order: set (fitted, paper) × mode (aggressive,
/// conservative) × maximal depth 1..=5 × level 1..=depth.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn channel_names() -> &'static [String] {
    static NAMES: OnceLock<Vec<String>> = OnceLock::new();
    NAMES.get_or_init(|| {
        let mut v = Vec::new();
        for set in [WeightSet::Fitted, WeightSet::Paper] {
            for mode in MaskMode::ALL {
                for d in 1..=MAX_DEPTH {
                    for l in 1..=d {
                        v.extend(channel_name(set, mode, d, l));
                    }
                }
            }
        }
        v
    })
}

/// Index of a channel in [`channel_names`].
fn channel_index(set: WeightSet, mode: MaskMode, depth: u32, level: u32) -> usize {
    let per_mode: u32 = (1..=MAX_DEPTH).sum();
    let s = match set {
        WeightSet::Paper => 1,
        _ => 0,
    };
    let m = match mode {
        MaskMode::Aggressive => 0,
        MaskMode::Conservative => 1,
    };
    let before: u32 = (1..depth).sum();
    ((s * 2 + m) * per_mode + before + level - 1) as usize
}

/// Plausible range of every stored weight: the fit is refused outside [−4, 4]
/// (fits/mask_weights), so a value beyond is corruption.
pub const WEIGHT_RANGE: (f64, f64) = (-4.0, 4.0);

/// The axis this runtime interprets: `dist` on [0.25, 10], nodes uniform in ln dist.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn axis(count: u32) -> Axis {
    Axis {
        name: "dist".into(),
        unit: "1".into(),
        lo: DIST_MIN,
        hi: DIST_MAX,
        mapping: Mapping::Log,
        count,
        placement: Placement::Endpoints,
    }
}

/// The mask-weights table.
#[derive(Debug, Clone)]
pub struct MaskWeights {
    table: Table,
}

crate::table_type::impl_table_type!(MaskWeights: KIND, VERSION);

impl MaskWeights {
    /// Wraps an already loaded table, checking its kind, version, layout and ranges.
    pub fn from_table(table: Table) -> Result<Self, LoadError> {
        table.expect_kind(KIND, VERSION)?;
        let channels: Vec<(&str, Encoding)> = channel_names().iter().map(|n| (n.as_str(), Encoding::Linear)).collect();
        table.expect_layout_1d(&axis(table.meta().axes.first().map_or(0, |a| a.count)), &channels)?;
        let ranges: Vec<(&str, f64, f64)> = channel_names()
            .iter()
            .map(|n| (n.as_str(), WEIGHT_RANGE.0, WEIGHT_RANGE.1))
            .collect();
        table.expect_channel_ranges(&ranges)?;
        Ok(Self { table })
    }

    /// The weights w_1 … w_depth (dimensionless) of eq. 39 for masks of maximal depth
    /// `depth` (1..=5) in `mode`, at the paper's `dist` (see [`dist_of_cap`]; values
    /// outside [0.25, 10] take the end weights), into `out[..depth]` (`out[d − 1]` is
    /// the weight of depth d).
    pub fn weights(
        &self,
        set: WeightSet,
        mode: MaskMode,
        depth: u32,
        dist: f64,
        out: &mut [f64],
    ) -> Result<(), LookupError> {
        let n = check_depth(depth)? as usize;
        let dist = finite("dist", dist)?;
        if out.len() < n {
            return Err(LookupError::Output {
                got: out.len(),
                needed: n,
                what: "weights",
            });
        }
        if set == WeightSet::Ones {
            out[..n].fill(1.0);
            return Ok(());
        }
        if dist <= 0.0 {
            return Err(LookupError::OutOfDomain {
                name: "dist".into(),
                value: dist,
                lo: f64::MIN_POSITIVE,
                hi: f64::INFINITY,
            });
        }
        let mut all = vec![0.0; channel_names().len()];
        self.table.interpolate(&[dist.clamp(DIST_MIN, DIST_MAX)], &mut all)?;
        let first = channel_index(set, mode, depth, 1);
        out[..n].copy_from_slice(&all[first..first + n]);
        Ok(())
    }

    /// [`MaskWeights::weights`] with an f32 interface (computed in f64, rounded once).
    pub fn weights_f32(
        &self,
        set: WeightSet,
        mode: MaskMode,
        depth: u32,
        dist: f32,
        out: &mut [f32],
    ) -> Result<(), LookupError> {
        let mut w = [0.0; MAX_DEPTH as usize];
        self.weights(set, mode, depth, dist as f64, &mut w)?;
        let n = depth as usize;
        narrow_all("weight", &w[..n], out)
    }
}

/// `depth` if it lies in 1..=[`MAX_DEPTH`], else [`LookupError::OutOfDomain`].
pub fn check_depth(depth: u32) -> Result<u32, LookupError> {
    if (1..=MAX_DEPTH).contains(&depth) {
        Ok(depth)
    } else {
        Err(LookupError::OutOfDomain {
            name: "mask depth".into(),
            value: depth as f64,
            lo: 1.0,
            hi: MAX_DEPTH as f64,
        })
    }
}

/// A spherical cap seen from a point: unit axis and half-angle (rad, in (0, π/2) for a
/// sphere seen from outside).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cap {
    /// Unit axis.
    pub axis: DVec3,
    /// Half-angle (rad).
    pub half_angle: f64,
}

impl Cap {
    /// Whether the unit direction `v` lies in the cap (boundary included).
    pub fn contains(&self, v: DVec3) -> bool {
        self.axis.dot(v) >= self.half_angle.cos()
    }
}

/// One quad-tree cell kept by the mask builder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskCell {
    /// Axis of the cap bounding the cell (through the sum of its corners).
    pub axis: DVec3,
    /// Half-angle of that bounding cap (rad).
    pub half_angle: f64,
    /// Depth (0 = S_unit).
    pub depth: u32,
    /// Fully covered by one blocker cap (a shadow leaf); `false`: partially covered.
    pub full: bool,
    /// The cell's corners (unit directions, in order around it; its edges are the
    /// great-circle arcs between consecutive corners).
    pub corners: [DVec3; 4],
}

impl MaskCell {
    /// Whether the unit direction `v` lies in the cell (the spherical quadrilateral).
    pub fn contains(&self, v: DVec3) -> bool {
        let c = &self.corners;
        let centre = c[0] + c[1] + c[2] + c[3];
        (0..4).all(|k| {
            let m = c[k].cross(c[(k + 1) % 4]);
            m.dot(v) * m.dot(centre).signum() >= 0.0
        }) && centre.dot(v) > 0.0
    }
}

/// A visibility mask: the quad-tree cells of one light seen from one point.
#[derive(Debug, Clone, PartialEq)]
pub struct Mask {
    /// The paper's `dist` for this light (1/(2 tan α)).
    pub dist: f64,
    /// One blocker cap contains the whole light cap: the light is hidden (no cells).
    pub fully_blocked: bool,
    /// Full cells at every depth, and every partial cell met (subdivided or, at the
    /// maximal depth, left as is).
    pub cells: Vec<MaskCell>,
}

impl Mask {
    /// The shadow leaves of the mask truncated at `depth` (≤ the depth it was built
    /// with) in `mode`: full cells of depth ≤ `depth`, plus, when conservative, the
    /// partial cells of depth exactly `depth`.
    pub fn leaves(&self, depth: u32, mode: MaskMode) -> impl Iterator<Item = &MaskCell> {
        self.cells.iter().filter(move |c| {
            (c.full && c.depth <= depth) || (mode == MaskMode::Conservative && !c.full && c.depth == depth)
        })
    }
}

/// Builds the visibility mask of `light` (the light's cap) against the blocker caps,
/// down to `max_depth` (1..=5). Blocker caps that miss the light's cap are clipped;
/// the caller clips blockers behind the light. Caps must have unit axes and
/// half-angles in (0, π/2) (a light or blocker seen from outside).
pub fn build_mask(light: Cap, blockers: &[Cap], max_depth: u32) -> Result<Mask, LookupError> {
    let mut cells = Vec::new();
    let fully_blocked = walk_mask(
        light,
        blockers,
        max_depth,
        &mut |axis, min_cos, depth, full, corners| {
            cells.push(MaskCell {
                axis,
                half_angle: min_cos.acos(),
                depth,
                full,
                corners,
            })
        },
    )?;
    Ok(Mask {
        dist: dist_of_cap(light.half_angle),
        fully_blocked,
        cells,
    })
}

/// The shadow leaves of the mask [`build_mask`] would build, in its cells' order, as
/// (bounding cap, depth) — [`Mask::leaves`] at the built depth, bit for bit — without
/// storing the mask's other cells: what a renderer shading the leaves needs (the
/// partial cells' bounding caps cost an acos each, and most cells are partial).
/// `leaves` is cleared first (a buffer the caller may reuse). Returns whether one
/// blocker hides the whole light (then no leaves); the errors of [`build_mask`] (a
/// depth outside 1..=5, a cap whose axis is not unit or whose half-angle is outside
/// (0, π/2)), with `leaves` left empty.
pub fn mask_leaves(
    light: Cap,
    blockers: &[Cap],
    max_depth: u32,
    mode: MaskMode,
    leaves: &mut Vec<(Cap, u32)>,
) -> Result<bool, LookupError> {
    leaves.clear();
    let conservative = mode == MaskMode::Conservative;
    walk_mask(light, blockers, max_depth, &mut |axis, min_cos, depth, full, _| {
        if full || (conservative && depth == max_depth) {
            leaves.push((
                Cap {
                    axis,
                    half_angle: min_cos.acos(),
                },
                depth,
            ));
        }
    })
}

/// Walks the mask's quad-tree depth first, handing each kept cell to `cell` as (the
/// bounding cap's axis, the cosine of its half-angle, depth, full, corners). Returns
/// whether one blocker cap contains the whole light cap (then no cells).
fn walk_mask(
    light: Cap,
    blockers: &[Cap],
    max_depth: u32,
    cell: &mut dyn FnMut(DVec3, f64, u32, bool, [DVec3; 4]),
) -> Result<bool, LookupError> {
    check_depth(max_depth)?;
    check_cap("light cap", light)?;
    for b in blockers {
        check_cap("blocker cap", *b)?;
    }
    let alpha = light.half_angle;
    let w = light.axis;
    let mut relevant = Vec::with_capacity(blockers.len());
    for b in blockers {
        let gap = angle_between(w, b.axis);
        if gap + alpha <= b.half_angle {
            return Ok(true);
        }
        if gap < b.half_angle + alpha {
            let (sin, cos) = b.half_angle.sin_cos();
            relevant.push(Blocker { axis: b.axis, cos, sin });
        }
    }
    if relevant.is_empty() {
        return Ok(false);
    }
    let (u, v) = w.any_orthonormal_pair();
    let k = 2.0 * alpha.tan();
    let n = relevant.len();
    let mut b = Builder {
        w,
        u: u * k,
        v: v * k,
        candidates: (0..n as u32).collect(),
        caps: relevant,
        max_depth,
        cell,
    };
    let c = [b.dir(-0.5, -0.5), b.dir(0.5, -0.5), b.dir(0.5, 0.5), b.dir(-0.5, 0.5)];
    b.visit(-0.5, -0.5, 1.0, c, 0, 0..n);
    Ok(false)
}

fn check_cap(name: &str, c: Cap) -> Result<(), LookupError> {
    for x in c.axis.to_array() {
        finite(name, x)?;
    }
    let len = c.axis.length();
    if (len - 1.0).abs() > 1e-6 {
        return Err(LookupError::OutOfDomain {
            name: format!("|{name} axis|"),
            value: len,
            lo: 1.0 - 1e-6,
            hi: 1.0 + 1e-6,
        });
    }
    let h = finite(name, c.half_angle)?;
    if !(h > 0.0 && h < std::f64::consts::FRAC_PI_2) {
        return Err(LookupError::OutOfDomain {
            name: format!("{name} half-angle"),
            value: h,
            lo: 0.0,
            hi: std::f64::consts::FRAC_PI_2,
        });
    }
    Ok(())
}

/// Angle between unit vectors, accurate at both ends.
fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// A blocker cap as the builder tests it.
#[derive(Clone, Copy)]
struct Blocker {
    axis: DVec3,
    /// cos and sin of the half-angle.
    cos: f64,
    sin: f64,
}

struct Builder<'a> {
    w: DVec3,
    /// u and v scaled by 2 tan α: square coordinate s ∈ [−1/2, 1/2] ↦ w + s·u + t·v.
    u: DVec3,
    v: DVec3,
    /// Relevant blocker caps.
    caps: Vec<Blocker>,
    /// A stack of indices into `caps`: each cell on the current path owns one range,
    /// the caps that meet it (its children need test no others).
    candidates: Vec<u32>,
    max_depth: u32,
    /// Where each kept cell goes ([`walk_mask`]).
    cell: &'a mut dyn FnMut(DVec3, f64, u32, bool, [DVec3; 4]),
}

impl Builder<'_> {
    fn dir(&self, s: f64, t: f64) -> DVec3 {
        (self.w + s * self.u + t * self.v).normalize()
    }

    /// Classifies the cell against the caps `parent` (a range of `candidates`: those
    /// meeting the parent cell, all caps at the root). A cap missing the parent misses
    /// its children, and one containing the parent ends the descent there, so the
    /// classification is the one a test of every cap gives, at the cost of the caps
    /// near the cell: the cost follows the blockers in the penumbra, not their number.
    ///
    /// `c` are the cell's corners, (s0, t0), (s0 + h, t0), (s0 + h, t0 + h), (s0, t0 + h)
    /// through [`Builder::dir`]; children take theirs from it and five new points (the
    /// coordinates are dyadic, so every sum is exact and a shared corner is the very
    /// value its own call would give).
    fn visit(&mut self, s0: f64, t0: f64, h: f64, c: [DVec3; 4], depth: u32, parent: std::ops::Range<usize>) {
        let axis = (c[0] + c[1] + c[2] + c[3]).normalize();
        let min_cos = c.iter().map(|x| axis.dot(*x)).fold(1.0, f64::min).clamp(-1.0, 1.0);
        // The cell lies in the cap about `axis` of half-angle β = acos(min_cos) (a
        // quadrilateral smaller than a hemisphere lies in any cap holding its corners).
        let sin_beta = (1.0 - min_cos * min_cos).max(0.0).sqrt();
        let start = self.candidates.len();
        let mut full = false;
        for i in parent {
            let k = self.candidates[i];
            let Blocker { axis: a, cos, sin } = self.caps[k as usize];
            // A cap farther than its half-angle + β from the axis misses the cell: the
            // angles' sum by its cosine, 1e-6 below it (so far beyond the rounding of
            // either side), so that the exact test below would have said the same.
            if a.dot(axis) < cos * min_cos - sin * sin_beta - 1e-6 {
                continue;
            }
            let d = c.map(|x| a.dot(x));
            if d.iter().all(|&x| x >= cos) {
                full = true;
                break;
            }
            // A corner inside: max_dot (which takes the max over these very products)
            // would say the cap meets the cell.
            if d.iter().any(|&x| x >= cos) || max_dot(&c, a) >= cos {
                self.candidates.push(k);
            }
        }
        let end = self.candidates.len();
        if !full && end == start {
            return; // no blocker meets the cell
        }
        (self.cell)(axis, min_cos, depth, full, c);
        if !full && depth < self.max_depth {
            let g = 0.5 * h;
            let (bottom, right) = (self.dir(s0 + g, t0), self.dir(s0 + h, t0 + g));
            let (top, left) = (self.dir(s0 + g, t0 + h), self.dir(s0, t0 + g));
            let centre = self.dir(s0 + g, t0 + g);
            let children = [
                (0.0, 0.0, [c[0], bottom, centre, left]),
                (g, 0.0, [bottom, c[1], right, centre]),
                (g, g, [centre, right, c[2], top]),
                (0.0, g, [left, centre, top, c[3]]),
            ];
            for (ds, dt, corners) in children {
                self.visit(s0 + ds, t0 + dt, g, corners, depth + 1, start..end);
            }
        }
        self.candidates.truncate(start);
    }
}

/// max over the spherical quadrilateral with corners `c` (in order, great-circle
/// edges, smaller than a hemisphere) of a·x, for the unit vector `a`.
fn max_dot(c: &[DVec3; 4], a: DVec3) -> f64 {
    let centre = c[0] + c[1] + c[2] + c[3];
    let mut inside = true;
    let mut best = f64::NEG_INFINITY;
    for k in 0..4 {
        let (p, q) = (c[k], c[(k + 1) % 4]);
        let m = p.cross(q);
        let mlen = m.length();
        best = best.max(a.dot(p)).max(a.dot(q));
        if mlen < 1e-300 {
            continue;
        }
        let m = m / mlen;
        let am = a.dot(m);
        if am * m.dot(centre).signum() < 0.0 {
            inside = false;
        }
        // Nearest point of the edge's great circle to a; on the arc, a·x = |a − (a·m)m|.
        let proj = a - am * m;
        let plen = proj.length();
        if plen > 1e-300 {
            let ph = proj / plen;
            if p.cross(ph).dot(m) >= 0.0 && ph.cross(q).dot(m) >= 0.0 {
                best = best.max(plen);
            }
        }
    }
    if inside {
        1.0
    } else {
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_index_matches_names() {
        for set in [WeightSet::Fitted, WeightSet::Paper] {
            for mode in MaskMode::ALL {
                for d in 1..=MAX_DEPTH {
                    for l in 1..=d {
                        let i = channel_index(set, mode, d, l);
                        assert_eq!(Some(channel_names()[i].clone()), channel_name(set, mode, d, l));
                    }
                }
            }
        }
        assert_eq!(channel_names().len(), 60);
    }

    /// The mask as it was built before the candidate lists: every relevant cap tested
    /// at every cell (the reference of `hierarchical_cells_equal_a_scan_of_every_cap`).
    fn scan_mask(light: Cap, blockers: &[Cap], max_depth: u32) -> Vec<MaskCell> {
        let (w, alpha) = (light.axis, light.half_angle);
        let caps: Vec<(DVec3, f64)> = blockers
            .iter()
            .filter(|b| angle_between(w, b.axis) < b.half_angle + alpha)
            .map(|b| (b.axis, b.half_angle.cos()))
            .collect();
        let (u, v) = w.any_orthonormal_pair();
        let k = 2.0 * alpha.tan();
        let (u, v) = (u * k, v * k);
        let dir = |s: f64, t: f64| (w + s * u + t * v).normalize();
        let mut cells = Vec::new();
        let mut stack = vec![(-0.5, -0.5, 1.0, 0)];
        while let Some((s0, t0, h, depth)) = stack.pop() {
            let c = [dir(s0, t0), dir(s0 + h, t0), dir(s0 + h, t0 + h), dir(s0, t0 + h)];
            let full = caps.iter().any(|&(a, cb)| c.iter().all(|x| a.dot(*x) >= cb));
            if !full && !caps.iter().any(|&(a, cb)| max_dot(&c, a) >= cb) {
                continue;
            }
            let axis = (c[0] + c[1] + c[2] + c[3]).normalize();
            let min_cos = c.iter().map(|x| axis.dot(*x)).fold(1.0, f64::min).clamp(-1.0, 1.0);
            cells.push(MaskCell {
                axis,
                half_angle: min_cos.acos(),
                depth,
                full,
                corners: c,
            });
            if !full && depth < max_depth {
                let g = 0.5 * h;
                // Pushed in reverse: popped in the builder's order.
                for (ds, dt) in [(0.0, g), (g, g), (g, 0.0), (0.0, 0.0)] {
                    stack.push((s0 + ds, t0 + dt, g, depth + 1));
                }
            }
        }
        cells
    }

    /// The quad-tree with per-cell candidate lists classifies every cell as a test of
    /// every cap does, bit for bit (same cells, same order), on light caps of 0.05 to
    /// 1.2 rad against 1 to 400 random blocker caps of sizes from a tenth of the light
    /// to larger than it, at depths 1 to 5; and [`mask_leaves`] gives that mask's
    /// leaves in both modes.
    #[test]
    fn hierarchical_cells_equal_a_scan_of_every_cap() {
        let mut rng = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut cells = 0;
        for trial in 0..60 {
            let alpha = 0.05 + 1.15 * next();
            let w = DVec3::new(next() - 0.5, next() - 0.5, 1.0).normalize();
            let light = Cap {
                axis: w,
                half_angle: alpha,
            };
            let n = [1, 3, 20, 100, 400][trial % 5];
            let (u, v) = w.any_orthonormal_pair();
            let blockers: Vec<Cap> = (0..n)
                .map(|_| {
                    let off = 1.5 * alpha * next();
                    let phi = std::f64::consts::TAU * next();
                    let axis = (w * off.cos() + off.sin() * (phi.cos() * u + phi.sin() * v)).normalize();
                    let half_angle = (alpha * (0.1 + 1.5 * next()) / (n as f64).sqrt()).min(1.5);
                    Cap { axis, half_angle }
                })
                .collect();
            let depth = 1 + (trial as u32 % MAX_DEPTH);
            let got = build_mask(light, &blockers, depth).unwrap();
            // The leaves-only walk the pipeline runs gives the mask's leaves, bit for
            // bit, in order, in both modes.
            for mode in MaskMode::ALL {
                let mut leaves = Vec::new();
                let hidden = mask_leaves(light, &blockers, depth, mode, &mut leaves).unwrap();
                assert_eq!(hidden, got.fully_blocked, "trial {trial}");
                let want: Vec<(Cap, u32)> = got
                    .leaves(depth, mode)
                    .map(|c| {
                        let cap = Cap {
                            axis: c.axis,
                            half_angle: c.half_angle,
                        };
                        (cap, c.depth)
                    })
                    .collect();
                assert_eq!(leaves, want, "trial {trial} {mode:?}");
            }
            if got.fully_blocked {
                continue;
            }
            let want = scan_mask(light, &blockers, depth);
            if got.cells != want {
                let i = got
                    .cells
                    .iter()
                    .zip(&want)
                    .position(|(a, b)| a != b)
                    .unwrap_or(got.cells.len().min(want.len()));
                panic!(
                    "trial {trial} α {alpha} n {n}: {} vs {} cells, first difference at {i}: {:?} vs {:?}",
                    got.cells.len(),
                    want.len(),
                    got.cells.get(i).map(|c| (c.depth, c.full, c.half_angle, c.axis)),
                    want.get(i).map(|c| (c.depth, c.full, c.half_angle, c.axis))
                );
            }
            cells += want.len();
        }
        // The trials reach deep partial cells, not only empty masks.
        assert!(cells > 5000, "{cells} cells");
    }

    /// max_dot against brute force over the quadrilateral (dense bilinear samples of
    /// the planar square, which map onto the spherical quadrilateral).
    #[test]
    fn max_dot_matches_brute_force() {
        let w = DVec3::new(0.1, -0.2, 1.0).normalize();
        let (u, v) = w.any_orthonormal_pair();
        let dir = |s: f64, t: f64| (w + 0.6 * (s * u + t * v)).normalize();
        let (s0, t0, h) = (-0.1, 0.2, 0.25);
        let c = [dir(s0, t0), dir(s0 + h, t0), dir(s0 + h, t0 + h), dir(s0, t0 + h)];
        let mut rng = 0x1234_5678_u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..200 {
            let a = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.2).normalize();
            let n = 200;
            let mut brute = f64::NEG_INFINITY;
            for i in 0..=n {
                for j in 0..=n {
                    let x = dir(s0 + h * i as f64 / n as f64, t0 + h * j as f64 / n as f64);
                    brute = brute.max(a.dot(x));
                }
            }
            let got = max_dot(&c, a);
            assert!(got >= brute - 1e-12, "{got} < {brute}");
            assert!(got <= brute + 1e-4, "{got} > {brute}");
        }
    }
}
