//! Sphere sets fitted to closed meshes (the blockers the analytic pipelines take for
//! a mesh), and their fit quality: volume error and one-sided Hausdorff distances by
//! sampling (docs/meshes.md).
//!
//! Both methods start from the same interior samples (uniform in the mesh's bounding
//! box, kept where [`Mesh::inside`]) and give each cluster of samples the sphere about
//! its mean that covers every sample of it:
//! - `kmeans`: Lloyd's iterations from a k-means++ start (Giraud ch. 4's k-means sphere
//!   sets, [WZS06]'s variational fit without its surface term);
//! - `kmeans-moment`: the same clusters, each sphere of the radius whose ball has the
//!   cluster's second moment about its mean (smaller than covering: it trades the
//!   covering spheres' excess volume for some missed volume);
//! - `tree`: a bounding-sphere tree cut at `count` leaves, split best first (the leaf
//!   with the largest sphere cut by the midplane of its samples' box across its
//!   longest axis, an octree's cut; [BO02]'s top-down construction).
//!
//! Deterministic: the same mesh, count, method and seed give the same bytes, whatever
//! the thread count.

use lobefit_core::rng::Rng;
use lobefit_tables::glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::mesh::Mesh;
use lobefit_tables::geom::Sphere;

pub mod optimize;
pub mod tree;

/// Most spheres a fit may ask for.
pub const MAX_FIT_SPHERES: usize = 4096;
/// Interior samples per sphere (at least [`MIN_SAMPLES`]).
pub const SAMPLES_PER_SPHERE: usize = 64;
/// Fewest interior samples a fit uses.
pub const MIN_SAMPLES: usize = 8192;
/// Lloyd iterations at most (they stop earlier once no sample changes cluster).
pub const MAX_LLOYD: usize = 60;

/// How a sphere set is fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Lloyd / k-means on interior samples.
    Kmeans,
    /// A bounding-sphere tree's `count` leaves, split best first.
    Tree,
    /// The k-means clusters with second-moment radii: r² = 5/3 of the mean squared
    /// distance of the cluster's samples to its centre (exact for a ball), not covering.
    #[serde(rename = "kmeans-moment")]
    KmeansMoment,
    /// A greedy coverage selection of inner balls ([`optimize::cover`]).
    Cover,
    /// `cover`'s balls refined by direct minimisation of the symmetric difference,
    /// with a Hausdorff guard ([`optimize::optimize`]).
    Optimize,
}

impl Method {
    /// Both, in the order tables list them.
    pub const ALL: [Method; 5] = [
        Method::Kmeans,
        Method::KmeansMoment,
        Method::Tree,
        Method::Cover,
        Method::Optimize,
    ];

    /// Its name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Method::Kmeans => "kmeans",
            Method::Tree => "tree",
            Method::KmeansMoment => "kmeans-moment",
            Method::Cover => "cover",
            Method::Optimize => "optimize",
        }
    }

    /// The method named `s`.
    pub fn parse(s: &str) -> Result<Method, String> {
        match s {
            "kmeans" => Ok(Method::Kmeans),
            "tree" => Ok(Method::Tree),
            "kmeans-moment" => Ok(Method::KmeansMoment),
            "cover" => Ok(Method::Cover),
            "optimize" => Ok(Method::Optimize),
            _ => Err(format!(
                "unknown sphere-fit method {s:?} (kmeans, kmeans-moment, tree, cover, optimize)"
            )),
        }
    }
}

/// `n` points uniform in the mesh's interior (rejection in its bounding box).
pub fn interior_samples(mesh: &Mesh, n: usize, seed: u64) -> Result<Vec<DVec3>, String> {
    let (lo, hi) = mesh.bounds();
    let mut out = Vec::with_capacity(n);
    let mut rng = Rng::new(seed);
    // Candidates drawn serially (the stream is the seed's), tested in parallel.
    let mut tried = 0usize;
    while out.len() < n {
        let batch: Vec<DVec3> = (0..4096)
            .map(|_| lo + (hi - lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
            .collect();
        let keep: Vec<bool> = batch.par_iter().map(|&p| mesh.inside(p)).collect();
        out.extend(batch.iter().zip(&keep).filter(|(_, &k)| k).map(|(p, _)| *p));
        tried += batch.len();
        if tried >= 64 * 4096 && out.len() * 1000 < tried {
            return Err(format!(
                "fewer than 1 in 1000 points of the mesh's bounding box lie inside it ({} of {tried}): is it closed?",
                out.len()
            ));
        }
    }
    out.truncate(n);
    Ok(out)
}

/// The sphere about the mean of `pts` covering every one of them.
fn cover(pts: &[DVec3]) -> Sphere {
    let c = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
    let r = pts.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
    Sphere {
        centre: c,
        radius: r.max(1e-12),
    }
}

/// Fits `count` spheres to the closed mesh with `method`, seeded by `seed`.
pub fn fit(mesh: &Mesh, count: usize, method: Method, seed: u64) -> Result<Vec<Sphere>, String> {
    fit_with(mesh, count, method, seed, None)
}

/// [`fit`] with a bound on the balls' overlap (Σ ball volumes ≤ `max_overlap` × the
/// union's volume), which `optimize` alone takes; an error for another method.
pub fn fit_with(
    mesh: &Mesh,
    count: usize,
    method: Method,
    seed: u64,
    max_overlap: Option<f64>,
) -> Result<Vec<Sphere>, String> {
    if !(1..=MAX_FIT_SPHERES).contains(&count) {
        return Err(format!("sphere count {count} must lie in 1..={MAX_FIT_SPHERES}"));
    }
    if let Some(r) = max_overlap {
        if method != Method::Optimize {
            return Err(format!("a bound on the overlap ({r}) needs the method optimize"));
        }
        if !(r.is_finite() && r >= 1.0) {
            return Err(format!("the overlap bound {r} must be finite and ≥ 1"));
        }
    }
    mesh.check_solid()?;
    let interior = || interior_samples(mesh, (SAMPLES_PER_SPHERE * count).max(MIN_SAMPLES), seed);
    Ok(match method {
        Method::Kmeans => kmeans(&interior()?, count, seed, cover),
        Method::KmeansMoment => kmeans(&interior()?, count, seed, moment),
        Method::Tree => tree(&interior()?, count),
        Method::Cover => optimize::cover(mesh, count, &optimize::Samples::new(mesh, seed)?, 0.0),
        Method::Optimize => {
            let s = optimize::Samples::new(mesh, seed)?;
            let cost = if max_overlap.is_some() {
                optimize::OVERLAP_COST
            } else {
                0.0
            };
            optimize::optimize(&optimize::cover(mesh, count, &s, cost), &s, max_overlap)
        }
    })
}

/// The sphere about the mean of `pts` with their second moment: r² = 5/3 · mean
/// |p − c|² (a uniform ball's samples give its radius).
fn moment(pts: &[DVec3]) -> Sphere {
    let c = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
    let m2 = pts.iter().map(|p| (*p - c).length_squared()).sum::<f64>() / pts.len() as f64;
    Sphere {
        centre: c,
        radius: (5.0 / 3.0 * m2).sqrt().max(1e-12),
    }
}

fn nearest(p: DVec3, centres: &[DVec3]) -> (usize, f64) {
    let mut best = (0, f64::INFINITY);
    for (k, c) in centres.iter().enumerate() {
        let d = (p - *c).length_squared();
        if d < best.1 {
            best = (k, d);
        }
    }
    best
}

fn kmeans(pts: &[DVec3], count: usize, seed: u64, size: fn(&[DVec3]) -> Sphere) -> Vec<Sphere> {
    let mut rng = Rng::new(seed ^ 0x6b6d_6561_6e73);
    // k-means++: each next centre drawn with probability ∝ squared distance.
    let mut centres = vec![pts[(rng.next_u64() % pts.len() as u64) as usize]];
    let mut d2: Vec<f64> = pts.iter().map(|p| (*p - centres[0]).length_squared()).collect();
    while centres.len() < count {
        let total: f64 = d2.iter().sum();
        let mut u = rng.uniform() * total;
        let mut pick = pts.len() - 1;
        for (k, d) in d2.iter().enumerate() {
            if u < *d {
                pick = k;
                break;
            }
            u -= d;
        }
        let c = pts[pick];
        centres.push(c);
        d2.par_iter_mut()
            .zip(pts)
            .for_each(|(d, p)| *d = d.min((*p - c).length_squared()));
    }
    let mut assign = vec![usize::MAX; pts.len()];
    for _ in 0..MAX_LLOYD {
        let next: Vec<usize> = pts.par_iter().map(|p| nearest(*p, &centres).0).collect();
        if next == assign {
            break;
        }
        assign = next;
        let mut sum = vec![(DVec3::ZERO, 0usize); count];
        for (p, &a) in pts.iter().zip(&assign) {
            sum[a].0 += *p;
            sum[a].1 += 1;
        }
        for (k, (s, m)) in sum.iter().enumerate() {
            if *m > 0 {
                centres[k] = *s / *m as f64;
            }
        }
        // An empty cluster restarts at the sample farthest from its centre.
        for k in 0..count {
            if sum[k].1 == 0 {
                let far = (0..pts.len())
                    .max_by(|&a, &b| {
                        let da = (pts[a] - centres[assign[a]]).length_squared();
                        let db = (pts[b] - centres[assign[b]]).length_squared();
                        da.total_cmp(&db).then(b.cmp(&a))
                    })
                    .unwrap_or(0);
                centres[k] = pts[far];
                assign[far] = k;
            }
        }
    }
    let mut groups = vec![Vec::new(); count];
    for (p, &a) in pts.iter().zip(&assign) {
        groups[a].push(*p);
    }
    groups
        .iter()
        .zip(&centres)
        .map(|(g, c)| {
            if g.is_empty() {
                Sphere {
                    centre: *c,
                    radius: 1e-12,
                }
            } else {
                size(g)
            }
        })
        .collect()
}

fn tree(pts: &[DVec3], count: usize) -> Vec<Sphere> {
    let mut leaves: Vec<(Vec<DVec3>, Sphere)> = vec![(pts.to_vec(), cover(pts))];
    while leaves.len() < count {
        // The leaf with the largest sphere (ties: the first) that can still split.
        let Some(k) = (0..leaves.len())
            .filter(|&k| leaves[k].0.len() >= 2)
            .max_by(|&a, &b| leaves[a].1.radius.total_cmp(&leaves[b].1.radius).then(b.cmp(&a)))
        else {
            break;
        };
        let (mut g, _) = leaves.swap_remove(k);
        let (lo, hi) = g.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), p| {
            (l.min(*p), h.max(*p))
        });
        let e = hi - lo;
        let axis = if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        };
        // The box's midplane (an octree's cut), the median where it leaves a side empty.
        let cut = 0.5 * (lo[axis] + hi[axis]);
        let (mut left, mut right): (Vec<DVec3>, Vec<DVec3>) = g.iter().partition(|p| p[axis] < cut);
        if left.is_empty() || right.is_empty() {
            let mid = g.len() / 2;
            g.select_nth_unstable_by(mid, |a, b| a[axis].total_cmp(&b[axis]));
            right = g.split_off(mid);
            left = g;
        }
        let g = left;
        let (sl, sr) = (cover(&g), cover(&right));
        // swap_remove moved the last leaf to k: re-insert both halves at the end,
        // which keeps the order a function of the inputs alone.
        leaves.push((g, sl));
        leaves.push((right, sr));
    }
    leaves.into_iter().map(|(_, s)| s).collect()
}

/// How well a sphere set matches a mesh, by sampling.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Quality {
    /// Volume of the symmetric difference of mesh and union of spheres, over the
    /// mesh's volume.
    pub volume_error: f64,
    /// Volume inside the spheres but outside the mesh, over the mesh's volume.
    pub excess: f64,
    /// Volume inside the mesh but outside every sphere, over the mesh's volume.
    pub missed: f64,
    /// One-sided Hausdorff distance from the mesh's surface to the union of the balls
    /// (scene units; 0 where a surface point lies in a ball).
    pub hausdorff_mesh_to_spheres: f64,
    /// One-sided Hausdorff distance from the union's boundary to the mesh solid
    /// (scene units; 0 where a boundary point lies inside the mesh).
    pub hausdorff_spheres_to_mesh: f64,
    /// The balls' summed volume over their union's (1: no overlap), by the same
    /// samples; 0 in files written before it was measured.
    #[serde(default)]
    pub overlap: f64,
    /// The mesh's bounding-box diagonal (what the distances are relative to).
    pub diagonal: f64,
    /// Points drawn for the volume (those for each distance: a quarter of it).
    pub samples: usize,
}

impl Quality {
    /// Every measure finite (what a sphere-set file must hold: JSON has no ∞ or NaN,
    /// and a file with `null` there is one no scene reads).
    pub fn is_finite(&self) -> bool {
        [
            self.volume_error,
            self.excess,
            self.missed,
            self.hausdorff_mesh_to_spheres,
            self.hausdorff_spheres_to_mesh,
            self.overlap,
            self.diagonal,
        ]
        .iter()
        .all(|v| v.is_finite())
    }
}

fn in_union(p: DVec3, spheres: &[Sphere]) -> bool {
    spheres
        .iter()
        .any(|s| (p - s.centre).length_squared() <= s.radius * s.radius)
}

/// The fit quality of `spheres` for `mesh` from `samples` points seeded by `seed`.
pub fn quality(mesh: &Mesh, spheres: &[Sphere], samples: usize, seed: u64) -> Quality {
    let (mut lo, mut hi) = mesh.bounds();
    let diagonal = (hi - lo).length();
    for s in spheres {
        lo = lo.min(s.centre - s.radius);
        hi = hi.max(s.centre + s.radius);
    }
    let mut rng = Rng::new(seed ^ 0x7175_616c);
    let pts: Vec<DVec3> = (0..samples)
        .map(|_| lo + (hi - lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
        .collect();
    let (excess, missed, union) = pts
        .par_iter()
        .map(|&p| {
            let u = in_union(p, spheres);
            match (mesh.inside(p), u) {
                (false, true) => (1usize, 0usize, 1usize),
                (true, false) => (0, 1, 0),
                _ => (0, 0, usize::from(u)),
            }
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    let box_vol = (hi - lo).x * (hi - lo).y * (hi - lo).z;
    let balls: f64 = spheres
        .iter()
        .map(|s| 4.0 / 3.0 * std::f64::consts::PI * s.radius.powi(3))
        .sum();
    let overlap = balls / (union.max(1) as f64 / samples as f64 * box_vol);
    let vol = mesh.volume().abs();
    let frac = |k: usize| k as f64 / samples as f64 * box_vol / vol;
    let surf = mesh.sample_surface(&mut rng, samples / 4);
    let h1 = surf
        .par_iter()
        .map(|&p| {
            spheres
                .iter()
                .map(|s| (p - s.centre).length() - s.radius)
                .fold(f64::INFINITY, f64::min)
                .max(0.0)
        })
        .reduce(|| 0.0, f64::max);
    // Points on the union's boundary: on each sphere by area, kept where no other
    // sphere holds them.
    let areas: Vec<f64> = spheres.iter().map(|s| s.radius * s.radius).collect();
    let total: f64 = areas.iter().sum();
    let on: Vec<DVec3> = (0..samples / 4)
        .map(|_| {
            let mut u = rng.uniform() * total;
            let mut k = spheres.len() - 1;
            for (i, a) in areas.iter().enumerate() {
                if u < *a {
                    k = i;
                    break;
                }
                u -= a;
            }
            let z = rng.range(-1.0, 1.0);
            let phi = rng.range(0.0, std::f64::consts::TAU);
            let r = (1.0 - z * z).sqrt();
            spheres[k].centre + spheres[k].radius * DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect();
    let h2 = on
        .par_iter()
        .map(|&p| {
            let strictly_inside = spheres
                .iter()
                .any(|s| (p - s.centre).length() < s.radius * (1.0 - 1e-9));
            if strictly_inside || mesh.inside(p) {
                0.0
            } else {
                mesh.distance(p)
            }
        })
        .reduce(|| 0.0, f64::max);
    Quality {
        volume_error: frac(excess + missed),
        excess: frac(excess),
        missed: frac(missed),
        hausdorff_mesh_to_spheres: h1,
        hausdorff_spheres_to_mesh: h2,
        overlap,
        diagonal,
        samples,
    }
}

/// A sphere-set file (`lobefit spheres --out`), in the mesh file's coordinates.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSetFile {
    /// 1.
    pub version: u32,
    /// The mesh file it was fitted to, as given.
    pub mesh: String,
    /// The method.
    pub method: Method,
    /// The seed.
    pub seed: u64,
    /// The spheres.
    pub spheres: Vec<FileSphere>,
    /// Its fit quality, if measured.
    #[serde(default)]
    pub quality: Option<Quality>,
}

/// A sphere of a [`SphereSetFile`].
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileSphere {
    /// Centre (mesh units).
    pub centre: [f64; 3],
    /// Radius (mesh units, > 0).
    pub radius: f64,
}

impl SphereSetFile {
    /// The spheres, checked: finite centres, radii finite and > 0, 1..=[`MAX_FIT_SPHERES`].
    pub fn spheres(&self) -> Result<Vec<Sphere>, String> {
        if self.version != 1 {
            return Err(format!("sphere set version {} (this build reads 1)", self.version));
        }
        if !(1..=MAX_FIT_SPHERES).contains(&self.spheres.len()) {
            return Err(format!(
                "{} spheres: a sphere set holds 1..={MAX_FIT_SPHERES}",
                self.spheres.len()
            ));
        }
        self.spheres
            .iter()
            .enumerate()
            .map(|(k, s)| {
                if s.centre.iter().all(|c| c.is_finite() && c.abs() <= 1e6)
                    && s.radius.is_finite()
                    && s.radius > 0.0
                    && s.radius <= 1e6
                {
                    Ok(Sphere {
                        centre: DVec3::from_array(s.centre),
                        radius: s.radius,
                    })
                } else {
                    Err(format!(
                        "spheres[{k}]: centre {:?} radius {} out of range",
                        s.centre, s.radius
                    ))
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tests::ball;

    /// A ball's own mesh fitted with one sphere: the covering sphere is the ball
    /// (closed form: centre, radius 1 within the faceting and sampling), and its
    /// measured volume error and distances are small; every method is deterministic.
    #[test]
    fn one_sphere_fits_a_ball() {
        let c = DVec3::new(0.5, -1.0, 2.0);
        let m = ball(c, 1.0, 3);
        for method in Method::ALL {
            // cover's balls are centred on samples (3 000 in a unit ball: 0.1 apart)
            // with radii the distance to the surface: within that spacing only.
            let tol = if method == Method::Cover { 0.1 } else { 0.02 };
            let s = fit(&m, 1, method, 3).unwrap();
            assert!((s[0].centre - c).length() < tol, "{method:?} {s:?}");
            assert!((s[0].radius - 1.0).abs() < 1.5 * tol, "{method:?} {s:?}");
            let q = quality(&m, &s, 20_000, 1);
            assert!(q.volume_error < 4.0 * tol, "{q:?}");
            assert!(
                q.hausdorff_mesh_to_spheres < 1.5 * tol && q.hausdorff_spheres_to_mesh < 2.0 * tol,
                "{q:?}"
            );
            let again = fit(&m, 1, method, 3).unwrap();
            assert_eq!(format!("{s:?}"), format!("{again:?}"));
        }
    }

    /// Two balls apart fitted with two spheres: each method finds both (independent
    /// reference: the balls themselves), and the quality's volume error is measured
    /// against the closed-form symmetric difference of two concentric balls.
    #[test]
    fn two_spheres_find_two_balls() {
        let (a, b) = (
            ball(DVec3::new(-2.0, 0.0, 0.0), 1.0, 3),
            ball(DVec3::new(2.0, 0.0, 0.5), 0.7, 3),
        );
        let mut v = a.vertices.clone();
        let off = v.len() as u32;
        v.extend(&b.vertices);
        let mut t = a.triangles.clone();
        t.extend(b.triangles.iter().map(|x| x.map(|i| i + off)));
        let m = Mesh::new(v, t).unwrap();
        for method in Method::ALL {
            let tol = if method == Method::Cover { 0.12 } else { 0.03 };
            let mut s = fit(&m, 2, method, 5).unwrap();
            s.sort_by(|p, q| p.centre.x.total_cmp(&q.centre.x));
            assert!(
                (s[0].centre - DVec3::new(-2.0, 0.0, 0.0)).length() < tol,
                "{method:?} {s:?}"
            );
            assert!(
                (s[1].centre - DVec3::new(2.0, 0.0, 0.5)).length() < tol,
                "{method:?} {s:?}"
            );
            assert!(
                (s[0].radius - 1.0).abs() < tol && (s[1].radius - 0.7).abs() < tol,
                "{s:?}"
            );
        }
        // Spheres 10 % too large: excess (1.1³ − 1) of the volume (the faceted mesh
        // a little under its balls: within 0.05).
        let big = [
            Sphere {
                centre: DVec3::new(-2.0, 0.0, 0.0),
                radius: 1.1,
            },
            Sphere {
                centre: DVec3::new(2.0, 0.0, 0.5),
                radius: 0.77,
            },
        ];
        let q = quality(&m, &big, 40_000, 2);
        assert!((q.excess - (1.1f64.powi(3) - 1.0)).abs() < 0.05, "{q:?}");
        assert!(q.missed < 0.01, "{q:?}");
        assert!((q.hausdorff_spheres_to_mesh - 0.1).abs() < 0.02, "{q:?}");
    }

    /// `optimize` gives the same bytes on one thread and on two (its gradients are
    /// summed over fixed chunks in order).
    #[test]
    fn optimize_does_not_depend_on_the_thread_count() {
        let m = ball(DVec3::new(0.2, 0.1, -0.3), 1.0, 3);
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| fit(&m, 6, Method::Optimize, 9).unwrap())
        };
        let (a, b) = (on(1), on(2));
        let bits = |s: &[Sphere]| -> Vec<u64> {
            s.iter()
                .flat_map(|x| [x.centre.x, x.centre.y, x.centre.z, x.radius].map(f64::to_bits))
                .collect()
        };
        assert_eq!(bits(&a), bits(&b));
        // A bound on the overlap takes optimize alone, and ≥ 1.
        assert!(fit_with(&m, 6, Method::Kmeans, 9, Some(1.2))
            .unwrap_err()
            .contains("optimize"));
        assert!(fit_with(&m, 6, Method::Optimize, 9, Some(0.5))
            .unwrap_err()
            .contains("≥ 1"));
    }

    #[test]
    fn bad_counts_are_errors() {
        let m = ball(DVec3::ZERO, 1.0, 1);
        assert!(fit(&m, 0, Method::Kmeans, 1).unwrap_err().contains("sphere count 0"));
        assert!(fit(&m, MAX_FIT_SPHERES + 1, Method::Tree, 1).is_err());
        // An open mesh (one triangle) has no interior.
        let tri = Mesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 2]]).unwrap();
        assert!(fit(&tri, 4, Method::Kmeans, 1).unwrap_err().contains("closed"));
    }
}
