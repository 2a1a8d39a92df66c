//! Sphere sets at the state of the art: a greedy coverage selection of inner balls
//! (`cover`) and a direct minimisation of the symmetric difference between the mesh
//! and the union of balls (`optimize`), with a guard on the one-sided Hausdorff
//! distance from the mesh to the balls and an optional bound on the balls' overlap.
//!
//! Both work on one set of samples ([`Samples`]): points uniform in the mesh's
//! bounding box grown by a tenth of its diagonal, each inside or outside the mesh
//! (equal volumes each), and points uniform on the surface.
//!
//! - `cover` (after Coverage Axis, Dou et al. 2022, and its ++ successor): candidate
//!   balls centred on interior samples with radii 1, 1.15 and 1.35 × their distance to
//!   the surface (inner balls, and slightly grown ones that reach past thin parts'
//!   boundaries); `count` of them chosen greedily, each the one adding the most covered
//!   inside volume minus covered outside volume.
//! - `optimize` (as Wang et al. 2006's variational sets minimise outside volume at a
//!   coverage, but on the symmetric difference itself): from `cover`'s set, Adam on the
//!   centres and log-radii of a smooth union — the soft maximum over balls of
//!   r − |p − c| (temperature τ) through a logistic of width β — of the volume inside
//!   the mesh left out plus the volume outside taken in, τ = β annealed from 0.5 % to
//!   0.05 % of the diagonal over 240 steps; plus, for each surface sample farther than
//!   [`HAUSDORFF_GUARD`] × the diagonal outside every ball, the squared excess (a fit
//!   free of it drops thin parts: the bunny's ear), and with a bound R on the overlap
//!   (Σ ball volumes ≤ R × the union's), its squared excess; `cover` then also charges
//!   each ball [`OVERLAP_COST`] for the inside volume it covers again.
//!
//! Deterministic for a seed whatever the thread count: gradients are summed over
//! fixed chunks of samples in order.

use lobefit_core::rng::Rng;
use lobefit_tables::geom::Sphere;
use lobefit_tables::glam::DVec3;
use rayon::prelude::*;

use crate::mesh::Mesh;

/// Points drawn in the grown box.
const BOX_SAMPLES: usize = 48_000;
/// Points drawn on the surface (the Hausdorff guard's).
const SURFACE_SAMPLES: usize = 10_000;
/// Interior samples tried as candidate centres (at most).
const CANDIDATE_CENTRES: usize = 3_000;
/// Candidate radii, × the centre's distance to the surface.
const CANDIDATE_SCALES: [f64; 3] = [1.0, 1.15, 1.35];
/// Adam iterations of `optimize`.
const ITERATIONS: usize = 240;
/// Samples per gradient chunk (the fixed order of the sums).
const CHUNK: usize = 1024;
/// The guard: surface points may lie this far outside the balls (× the diagonal)
/// before the fit pays for it.
pub const HAUSDORFF_GUARD: f64 = 0.01;
/// The guard's weight: × the mean squared excess (over the diagonal²) in the loss.
const GUARD_WEIGHT: f64 = 10_000.0;
/// The overlap bound's weight: × the squared excess of the ratio in the loss.
const OVERLAP_WEIGHT: f64 = 10.0;
/// `cover`'s cost of inside volume covered again, where the overlap is bounded.
pub const OVERLAP_COST: f64 = 0.5;

/// The samples a fit works on.
pub struct Samples {
    /// Box samples inside the mesh.
    pub inside: Vec<DVec3>,
    /// Box samples outside it.
    pub outside: Vec<DVec3>,
    /// Surface samples, uniform by area.
    pub surface: Vec<DVec3>,
    /// The mesh's bounding-box diagonal.
    pub diagonal: f64,
}

impl Samples {
    /// [`BOX_SAMPLES`] uniform in the mesh's box grown by a tenth of its diagonal (each
    /// side), split by [`Mesh::inside`], and [`SURFACE_SAMPLES`] on the surface.
    pub fn new(mesh: &Mesh, seed: u64) -> Result<Samples, String> {
        let (lo, hi) = mesh.bounds();
        let diagonal = (hi - lo).length();
        let (lo, hi) = (lo - DVec3::splat(0.1 * diagonal), hi + DVec3::splat(0.1 * diagonal));
        let mut rng = Rng::new(seed ^ 0x0063_6f76_6572);
        let pts: Vec<DVec3> = (0..BOX_SAMPLES)
            .map(|_| lo + (hi - lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
            .collect();
        let inside: Vec<bool> = pts.par_iter().map(|&p| mesh.inside(p)).collect();
        let (mut i, mut o) = (Vec::new(), Vec::new());
        for (p, inn) in pts.into_iter().zip(inside) {
            if inn {
                i.push(p);
            } else {
                o.push(p);
            }
        }
        if i.len() < 64 {
            return Err(format!(
                "{} of {BOX_SAMPLES} points of the mesh's box lie inside it: too thin to fit balls to",
                i.len()
            ));
        }
        let surface = mesh.sample_surface(&mut rng, SURFACE_SAMPLES);
        Ok(Samples {
            inside: i,
            outside: o,
            surface,
            diagonal,
        })
    }
}

/// A uniform grid over points: the indices of those in each cell.
struct Grid {
    lo: DVec3,
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    fn new(pts: &[DVec3], cell: f64) -> Grid {
        let lo = pts.iter().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
        let hi = pts.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
        let dims = ((hi - lo) / cell)
            .to_array()
            .map(|d| (d.floor() as usize + 1).clamp(1, 256));
        let key = |p: &DVec3| {
            let c = ((*p - lo) / cell).to_array();
            let ix = |k: usize| (c[k].max(0.0) as usize).min(dims[k] - 1);
            (ix(2) * dims[1] + ix(1)) * dims[0] + ix(0)
        };
        let n = dims[0] * dims[1] * dims[2];
        let mut count = vec![0u32; n + 1];
        for p in pts {
            count[key(p) + 1] += 1;
        }
        for k in 0..n {
            count[k + 1] += count[k];
        }
        let mut fill = count.clone();
        let mut items = vec![0u32; pts.len()];
        for (i, p) in pts.iter().enumerate() {
            let k = key(p);
            items[fill[k] as usize] = i as u32;
            fill[k] += 1;
        }
        Grid {
            lo,
            cell,
            dims,
            start: count,
            items,
        }
    }

    /// The indices of `pts` (the grid's) within the ball (`c`, `r`).
    fn in_ball(&self, pts: &[DVec3], c: DVec3, r: f64) -> Vec<u32> {
        let cell = |v: f64, k: usize| ((v / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1);
        let (a, b) = ((c - r - self.lo).to_array(), (c + r - self.lo).to_array());
        let mut out = Vec::new();
        for z in cell(a[2], 2)..=cell(b[2], 2) {
            for y in cell(a[1], 1)..=cell(b[1], 1) {
                let row = (z * self.dims[1] + y) * self.dims[0];
                let (x0, x1) = (cell(a[0], 0), cell(b[0], 0));
                let (s, e) = (self.start[row + x0] as usize, self.start[row + x1 + 1] as usize);
                out.extend(
                    self.items[s..e]
                        .iter()
                        .filter(|&&i| (pts[i as usize] - c).length_squared() <= r * r),
                );
            }
        }
        out
    }
}

/// `count` balls chosen greedily from inner candidates (module doc), each adding the
/// most inside-minus-outside covered volume, less `overlap_cost` × the inside volume
/// it covers again (0, or [`OVERLAP_COST`] for a set whose overlap is bounded) (lazy
/// greedy: a candidate's gain is recomputed when it comes up and compared with the
/// next one's last known gain).
pub fn cover(mesh: &Mesh, count: usize, s: &Samples, overlap_cost: f64) -> Vec<Sphere> {
    let step = s.inside.len().div_ceil(CANDIDATE_CENTRES).max(1);
    let centres: Vec<DVec3> = s.inside.iter().step_by(step).copied().collect();
    let dist: Vec<f64> = centres.par_iter().map(|&c| mesh.distance(c)).collect();
    let mut cands: Vec<Sphere> = Vec::new();
    for (c, d) in centres.iter().zip(&dist) {
        if *d > 0.0 && d.is_finite() {
            cands.extend(CANDIDATE_SCALES.map(|k| Sphere {
                centre: *c,
                radius: k * d,
            }));
        }
    }
    let cell = (s.diagonal / 64.0).max(1e-12);
    let (gin, gout) = (Grid::new(&s.inside, cell), Grid::new(&s.outside, cell));
    let lists: Vec<(Vec<u32>, Vec<u32>)> = cands
        .par_iter()
        .map(|b| {
            (
                gin.in_ball(&s.inside, b.centre, b.radius),
                gout.in_ball(&s.outside, b.centre, b.radius),
            )
        })
        .collect();
    let (mut cov_in, mut cov_out) = (vec![false; s.inside.len()], vec![false; s.outside.len()]);
    let gain = |k: usize, cov_in: &[bool], cov_out: &[bool]| -> i64 {
        let (a, b) = &lists[k];
        let new_in = a.iter().filter(|&&i| !cov_in[i as usize]).count() as i64;
        let old_in = a.len() as i64 - new_in;
        new_in - b.iter().filter(|&&i| !cov_out[i as usize]).count() as i64 - (overlap_cost * old_in as f64) as i64
    };
    // A max-heap of (last known gain, -index): ties go to the lower index.
    let mut heap: std::collections::BinaryHeap<(i64, i64)> = (0..cands.len())
        .map(|k| (gain(k, &cov_in, &cov_out), -(k as i64)))
        .collect();
    let mut chosen = Vec::with_capacity(count);
    while chosen.len() < count {
        let Some((_, nk)) = heap.pop() else { break };
        let k = (-nk) as usize;
        let g = gain(k, &cov_in, &cov_out);
        if heap.peek().is_some_and(|&(next, _)| g < next) {
            heap.push((g, nk));
            continue;
        }
        for &i in &lists[k].0 {
            cov_in[i as usize] = true;
        }
        for &i in &lists[k].1 {
            cov_out[i as usize] = true;
        }
        chosen.push(cands[k]);
    }
    // Fewer candidates than balls asked for: repeat the last (never for a real mesh).
    while chosen.len() < count {
        chosen.push(chosen.last().copied().unwrap_or(Sphere {
            centre: s.inside[0],
            radius: 1e-3 * s.diagonal,
        }));
    }
    chosen
}

/// Adam's state for one parameter vector.
struct Adam {
    m: Vec<f64>,
    v: Vec<f64>,
    t: i32,
}

impl Adam {
    fn new(n: usize) -> Adam {
        Adam {
            m: vec![0.0; n],
            v: vec![0.0; n],
            t: 0,
        }
    }

    /// One step of `x` down the gradient `g` with rate `lr` (per coordinate).
    fn step(&mut self, x: &mut [f64], g: &[f64], lr: &[f64]) {
        const B1: f64 = 0.9;
        const B2: f64 = 0.999;
        self.t += 1;
        let (c1, c2) = (1.0 - B1.powi(self.t), 1.0 - B2.powi(self.t));
        for i in 0..x.len() {
            self.m[i] = B1 * self.m[i] + (1.0 - B1) * g[i];
            self.v[i] = B2 * self.v[i] + (1.0 - B2) * g[i] * g[i];
            x[i] -= lr[i] * (self.m[i] / c1) / ((self.v[i] / c2).sqrt() + 1e-12);
        }
    }
}

/// Refines `start` by direct minimisation of the symmetric difference (module doc);
/// `max_overlap`: the bound R on Σ ball volumes / the union's volume, if any.
pub fn optimize(start: &[Sphere], s: &Samples, max_overlap: Option<f64>) -> Vec<Sphere> {
    let k = start.len();
    let diag = s.diagonal;
    // Parameters: centre (3), ln radius (1) per ball.
    let mut x: Vec<f64> = start
        .iter()
        .flat_map(|b| [b.centre.x, b.centre.y, b.centre.z, b.radius.max(1e-6 * diag).ln()])
        .collect();
    let lr: Vec<f64> = (0..4 * k)
        .map(|i| if i % 4 == 3 { 0.02 } else { 0.004 * diag })
        .collect();
    let mut adam = Adam::new(4 * k);
    // Samples with their sign: +1 inside (wants covering), −1 outside.
    let pts: Vec<(DVec3, f64)> = s
        .inside
        .iter()
        .map(|&p| (p, 1.0))
        .chain(s.outside.iter().map(|&p| (p, -1.0)))
        .collect();
    let n_in = s.inside.len() as f64;
    let sample_volume = box_volume(s) / pts.len() as f64;
    let mut near: Vec<Vec<u32>> = Vec::new();
    for it in 0..ITERATIONS {
        let frac = it as f64 / (ITERATIONS - 1) as f64;
        // τ = β from 2 % to 0.2 % of the diagonal, geometrically.
        let beta = diag * 0.005 * (0.1f64).powf(frac);
        let tau = beta;
        let balls: Vec<(DVec3, f64)> = x
            .chunks_exact(4)
            .map(|p| (DVec3::new(p[0], p[1], p[2]), p[3].exp()))
            .collect();
        // Each sample's candidate balls (those within reach), refreshed every 8 steps.
        if it % 8 == 0 {
            let reach = 8.0 * beta + 0.02 * diag;
            near = pts
                .par_iter()
                .map(|(p, _)| {
                    balls
                        .iter()
                        .enumerate()
                        .filter(|(_, (c, r))| (*p - *c).length() - r < reach)
                        .map(|(i, _)| i as u32)
                        .collect()
                })
                .collect();
        }
        // The volume error's gradient, per fixed chunk, summed in order.
        let chunks: Vec<(Vec<f64>, f64)> = pts
            .par_chunks(CHUNK)
            .zip(near.par_chunks(CHUNK))
            .map(|(ps, ns)| {
                let mut g = vec![0.0; 4 * k];
                let mut occupied = 0.0;
                for ((p, sign), nb) in ps.iter().zip(ns) {
                    if nb.is_empty() {
                        continue;
                    }
                    let sv: Vec<f64> = nb
                        .iter()
                        .map(|&i| {
                            let (c, r) = balls[i as usize];
                            r - (*p - c).length()
                        })
                        .collect();
                    let top = sv.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                    let z: f64 = sv.iter().map(|v| ((v - top) / tau).exp()).sum();
                    let m = top + tau * z.ln();
                    let o = 1.0 / (1.0 + (-m / beta).exp());
                    occupied += o;
                    // Loss: inside (1 − o), outside o; dL/dm = −sign · o(1−o)/β.
                    let dm = -sign * o * (1.0 - o) / beta;
                    for (j, &i) in nb.iter().enumerate() {
                        let a = ((sv[j] - top) / tau).exp() / z;
                        let (c, r) = balls[i as usize];
                        let d = *p - c;
                        let len = d.length().max(1e-12);
                        let gs = dm * a;
                        // s = r − |p − c|: ∂s/∂c = (p − c)/|p − c|, ∂s/∂ln r = r.
                        let i = i as usize;
                        g[4 * i] += gs * d.x / len;
                        g[4 * i + 1] += gs * d.y / len;
                        g[4 * i + 2] += gs * d.z / len;
                        g[4 * i + 3] += gs * r;
                    }
                }
                (g, occupied)
            })
            .collect();
        let mut g = vec![0.0; 4 * k];
        let mut occupied = 0.0;
        for (c, o) in chunks {
            for (a, b) in g.iter_mut().zip(c) {
                *a += b;
            }
            occupied += o;
        }
        for v in &mut g {
            *v /= n_in;
        }
        // The Hausdorff guard: surface samples farther outside than the guard pull their
        // nearest ball (the squared excess, over the samples' count, × 100).
        let guard = HAUSDORFF_GUARD * diag;
        let pulls: Vec<(usize, f64, DVec3)> = s
            .surface
            .par_iter()
            .filter_map(|p| {
                let (i, u) = balls
                    .iter()
                    .enumerate()
                    .map(|(i, (c, r))| (i, (*p - *c).length() - r))
                    .min_by(|a, b| a.1.total_cmp(&b.1))?;
                (u > guard).then_some((i, u - guard, *p))
            })
            .collect();
        let weight = GUARD_WEIGHT / s.surface.len() as f64;
        for (i, excess, p) in pulls {
            let (c, r) = balls[i];
            let d = p - c;
            let len = d.length().max(1e-12);
            // u = |p − c| − r: ∂u/∂c = −(p − c)/|p − c|, ∂u/∂ln r = −r.
            let gu = 2.0 * weight * excess / diag;
            g[4 * i] -= gu * d.x / len;
            g[4 * i + 1] -= gu * d.y / len;
            g[4 * i + 2] -= gu * d.z / len;
            g[4 * i + 3] -= gu * r;
        }
        // The overlap bound: Σ V_i / U ≤ R, U the smooth union's volume (held fixed).
        if let Some(bound) = max_overlap {
            let union = (occupied * sample_volume).max(f64::MIN_POSITIVE);
            let sum: f64 = balls
                .iter()
                .map(|(_, r)| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
                .sum();
            let ratio = sum / union;
            if ratio > bound {
                let mu = 2.0 * OVERLAP_WEIGHT * (ratio - bound);
                for (i, (_, r)) in balls.iter().enumerate() {
                    // ∂(Σ V / U)/∂ln r_i = 4π r_i³ / U.
                    g[4 * i + 3] += mu * 4.0 * std::f64::consts::PI * r.powi(3) / union;
                }
            }
        }
        // The rate falls by 10× over the run.
        let decay = (0.1f64).powf(frac);
        let lr_now: Vec<f64> = lr.iter().map(|l| l * decay).collect();
        adam.step(&mut x, &g, &lr_now);
    }
    x.chunks_exact(4)
        .map(|p| Sphere {
            centre: DVec3::new(p[0], p[1], p[2]),
            radius: p[3].exp(),
        })
        .collect()
}

/// The volume of the box the samples were drawn in (their bounds: within sampling).
fn box_volume(s: &Samples) -> f64 {
    let all = s.inside.iter().chain(&s.outside);
    let lo = all.clone().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
    let hi = all.fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
    let e = hi - lo;
    e.x * e.y * e.z
}
