//! A sphere hierarchy over a set, and a per-point cut by subtended angle: Iwasaki et
//! al.'s "hierarchical representation of spheres for scalability and level of detail"
//! (docs/meshes.md, "A sphere hierarchy").
//!
//! The tree is binary, built top-down: a node's spheres are split at the median of
//! their centres along the axis of largest spread. Every node holds the smallest
//! sphere enclosing its children's bounds (exact for two spheres), and a *stand-in*:
//! one sphere that replaces the whole subtree for a point far enough away. The
//! stand-in keeps the subtree's volume (radius ∛Σr³, overlaps not subtracted) at its
//! volume-weighted centroid: what a distant point sees of a cluster is about its
//! projected area, and a union of balls is nearer a ball of its volume than its
//! bounding ball (which over-shadows by its empty space).
//!
//! The cut from a point x with angle θ walks from the root: a node is replaced by its
//! stand-in when its bound subtends less than θ from x (R / |x − C| < sin θ) and x
//! lies outside its bound (with the own-sphere margin); otherwise its children are
//! visited. A leaf is the set's own sphere, kept unless `skip` says it is the point's
//! own ([`crate::scene::Own`]): any node holding a sphere that contains x (within the
//! margin) contains x, so it is opened, and own spheres are only ever met as leaves.
//! θ = 0 gives the flat set back exactly.

use lobefit_tables::geom::Sphere;
use lobefit_tables::glam::DVec3;

/// A node: its bound, its stand-in, its reach, and its children or its leaf.
#[derive(Debug, Clone)]
struct Node {
    bound: Sphere,
    stand_in: Sphere,
    /// A ball holding every sphere the cut can give from this subtree (the stand-ins
    /// too: Σr³ counts overlaps twice, so a stand-in may stick out of the bound).
    reach: Sphere,
    /// (left, right) node indices; `None` for a leaf.
    children: Option<(usize, usize)>,
    /// The leaf's sphere index in the set (leaves only).
    leaf: usize,
}

/// A binary sphere hierarchy over a set (module doc).
#[derive(Debug, Clone)]
pub struct SphereTree {
    nodes: Vec<Node>,
    spheres: Vec<Sphere>,
    /// Per node, the sphere the cut gives for it: a leaf's own, a node's stand-in.
    given: Vec<Sphere>,
}

/// The smallest sphere enclosing the spheres `a` and `b`.
pub fn enclosing(a: &Sphere, b: &Sphere) -> Sphere {
    let d = b.centre - a.centre;
    let l = d.length();
    if l + b.radius <= a.radius {
        return *a;
    }
    if l + a.radius <= b.radius {
        return *b;
    }
    let radius = 0.5 * (l + a.radius + b.radius);
    // From a's far side (a.centre − a.radius d̂) out by the new radius.
    let centre = a.centre + d * ((radius - a.radius) / l);
    Sphere { centre, radius }
}

impl SphereTree {
    /// The tree over `spheres` (none: an empty tree).
    pub fn new(spheres: &[Sphere]) -> SphereTree {
        let mut t = SphereTree {
            nodes: Vec::with_capacity(2 * spheres.len()),
            spheres: spheres.to_vec(),
            given: Vec::new(),
        };
        if !spheres.is_empty() {
            let mut idx: Vec<usize> = (0..spheres.len()).collect();
            t.build(&mut idx);
        }
        t.given = t.nodes.iter().map(|n| n.stand_in).collect();
        t
    }

    /// Builds the subtree over `idx` (non-empty); returns its node index.
    fn build(&mut self, idx: &mut [usize]) -> usize {
        if let [i] = idx {
            let s = self.spheres[*i];
            self.nodes.push(Node {
                bound: s,
                stand_in: s,
                reach: s,
                children: None,
                leaf: *i,
            });
            return self.nodes.len() - 1;
        }
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &i in idx.iter() {
            lo = lo.min(self.spheres[i].centre);
            hi = hi.max(self.spheres[i].centre);
        }
        let axis = (hi - lo).max_position();
        let spheres = &self.spheres;
        // The median by centre along the axis; ties by index (deterministic).
        idx.sort_by(|&a, &b| {
            spheres[a].centre[axis]
                .total_cmp(&spheres[b].centre[axis])
                .then(a.cmp(&b))
        });
        let mid = idx.len() / 2;
        let (l, r) = idx.split_at_mut(mid);
        let left = self.build(l);
        let right = self.build(r);
        let bound = enclosing(&self.nodes[left].bound, &self.nodes[right].bound);
        // The stand-in: the subtree's volume at its volume-weighted centroid.
        let (mut v, mut m) = (0.0, DVec3::ZERO);
        for &i in l.iter().chain(r.iter()) {
            let s = &self.spheres[i];
            let vi = s.radius.powi(3);
            v += vi;
            m += vi * s.centre;
        }
        let stand_in = Sphere {
            centre: m / v,
            radius: v.cbrt(),
        };
        let reach = enclosing(&stand_in, &enclosing(&self.nodes[left].reach, &self.nodes[right].reach));
        self.nodes.push(Node {
            bound,
            stand_in,
            reach,
            children: Some((left, right)),
            leaf: usize::MAX,
        });
        self.nodes.len() - 1
    }

    /// The spheres the tree is over.
    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }

    /// Per node index, the sphere the cut gives for it (a leaf: its sphere of the set;
    /// a node: its stand-in): what [`SphereTree::cut_in_cone`]'s indices name.
    pub fn given(&self) -> &[Sphere] {
        &self.given
    }

    /// The nodes as data for a GPU walk, root last: per node its reach, its bound, the
    /// sphere the cut gives for it ([`SphereTree::given`]), and its children's node
    /// indices, or `None` and its sphere's index in the set for a leaf.
    pub fn node_data(&self) -> impl Iterator<Item = (Sphere, Sphere, Sphere, Result<(usize, usize), usize>)> + '_ {
        self.nodes
            .iter()
            .zip(&self.given)
            .map(|(n, g)| (n.reach, n.bound, *g, n.children.ok_or(n.leaf)))
    }

    /// The tree's depth (a leaf alone: 1; none: 0).
    pub fn depth(&self) -> usize {
        fn walk(t: &SphereTree, k: usize) -> usize {
            match t.nodes[k].children {
                None => 1,
                Some((a, b)) => 1 + walk(t, a).max(walk(t, b)),
            }
        }
        self.nodes.len().checked_sub(1).map_or(0, |root| walk(self, root))
    }

    /// The cut from `x` at `theta` (as [`SphereTree::cut`]) restricted to a cone: calls
    /// `visit` with the node index (into [`SphereTree::given`]) of every sphere of the
    /// cut that may meet the cone (`test`), skipping whole subtrees whose reach lies
    /// outside it. A superset of the cut's spheres whose caps meet the cone; the
    /// caller tests each, as it does the BVH's.
    pub fn cut_in_cone(
        &self,
        test: &crate::scene::ConeTest,
        x: DVec3,
        sin_theta: f64,
        margin: f64,
        skip: impl Fn(usize) -> bool,
        mut visit: impl FnMut(usize),
    ) {
        let Some(root) = self.nodes.len().checked_sub(1) else {
            return;
        };
        let mut stack = vec![root];
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k];
            if test.outside(n.reach.centre, n.reach.radius) {
                continue;
            }
            match n.children {
                None => {
                    if !skip(n.leaf) {
                        visit(k);
                    }
                }
                Some((a, b)) => {
                    let d = (x - n.bound.centre).length();
                    if d > n.bound.radius * (1.0 + margin) && n.bound.radius < sin_theta * d {
                        visit(k);
                    } else {
                        stack.push(b);
                        stack.push(a);
                    }
                }
            }
        }
    }

    /// The cut from `x` at angle `theta` (rad; 0: every leaf) into `out` (cleared
    /// first): stand-ins of the nodes that subtend less than `theta` from `x`, and the
    /// leaves reached, but those `skip(i)` names (sphere index `i` of the set). A node
    /// whose bound holds `x` within the relative margin `margin` is always opened.
    pub fn cut(&self, x: DVec3, theta: f64, margin: f64, skip: impl Fn(usize) -> bool, out: &mut Vec<Sphere>) {
        out.clear();
        let Some(root) = self.nodes.len().checked_sub(1) else {
            return;
        };
        let sin = theta.clamp(0.0, std::f64::consts::FRAC_PI_2).sin();
        let mut stack = vec![root];
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k];
            match n.children {
                None => {
                    if !skip(n.leaf) {
                        out.push(n.bound);
                    }
                }
                Some((a, b)) => {
                    let d = (x - n.bound.centre).length();
                    if d > n.bound.radius * (1.0 + margin) && n.bound.radius < sin * d {
                        out.push(n.stand_in);
                    } else {
                        stack.push(b);
                        stack.push(a);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(n: usize, seed: u64) -> Vec<Sphere> {
        let mut rng = lobefit_core::rng::Rng::new(seed);
        (0..n)
            .map(|_| Sphere {
                centre: DVec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(0.0, 2.0)),
                radius: rng.range(0.05, 0.4),
            })
            .collect()
    }

    /// Every node's bound encloses its children's (to 1e-12), the enclosing sphere of
    /// two is no larger than needed (it touches both far sides), and the stand-in keeps
    /// the subtree's volume Σr³.
    #[test]
    fn nodes_enclose_their_children_and_keep_the_volume() {
        let s = set(37, 3);
        let t = SphereTree::new(&s);
        assert_eq!(t.nodes.len(), 2 * 37 - 1);
        let mut leaves = vec![Vec::new(); t.nodes.len()];
        for (k, n) in t.nodes.iter().enumerate() {
            match n.children {
                None => leaves[k] = vec![n.leaf],
                Some((a, b)) => {
                    for c in [a, b] {
                        let ch = &t.nodes[c].bound;
                        let reach = (ch.centre - n.bound.centre).length() + ch.radius;
                        assert!(reach <= n.bound.radius * (1.0 + 1e-12), "{reach} > {}", n.bound.radius);
                    }
                    leaves[k] = [leaves[a].clone(), leaves[b].clone()].concat();
                    let v: f64 = leaves[k].iter().map(|&i| s[i].radius.powi(3)).sum();
                    assert!((n.stand_in.radius.powi(3) / v - 1.0).abs() < 1e-12);
                }
            }
        }
        let (a, b) = (s[0], s[1]);
        let e = enclosing(&a, &b);
        let d = (b.centre - a.centre).normalize();
        if (b.centre - a.centre).length() + b.radius.min(a.radius) > a.radius.max(b.radius) {
            let far_a = a.centre - a.radius * d;
            let far_b = b.centre + b.radius * d;
            assert!(((far_a - e.centre).length() - e.radius).abs() < 1e-12);
            assert!(((far_b - e.centre).length() - e.radius).abs() < 1e-12);
        }
    }

    /// θ = 0 gives the flat set back (every sphere but the skipped, each once); a
    /// wider θ gives fewer spheres from a far point, never more, and a point inside a
    /// sphere always meets that sphere as a leaf (so `skip` sees it).
    #[test]
    fn the_cut_is_the_set_at_zero_and_coarser_with_the_angle() {
        let s = set(64, 5);
        let t = SphereTree::new(&s);
        let mut out = Vec::new();
        t.cut(DVec3::new(0.0, 0.0, 1.0), 0.0, 0.05, |i| i == 7, &mut out);
        let mut got: Vec<(u64, u64)> = out.iter().map(|s| (s.centre.x.to_bits(), s.radius.to_bits())).collect();
        let mut want: Vec<(u64, u64)> = s
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 7)
            .map(|(_, s)| (s.centre.x.to_bits(), s.radius.to_bits()))
            .collect();
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want);
        let far = DVec3::new(40.0, 0.0, 1.0);
        let mut last = usize::MAX;
        for deg in [0.0, 1.0, 3.0, 10.0, 30.0] {
            t.cut(far, f64::to_radians(deg), 0.05, |_| false, &mut out);
            assert!(out.len() <= last, "{deg}°: {} > {last}", out.len());
            last = out.len();
        }
        assert_eq!(last, 1, "from 40 units at 30° the whole set is one stand-in");
        for (k, sp) in s.iter().enumerate() {
            let met = std::cell::Cell::new(false);
            let skip = |i: usize| {
                met.set(met.get() || i == k);
                false
            };
            t.cut(sp.centre, 0.5, 0.05, skip, &mut out);
            assert!(met.get(), "sphere {k} holds the point but was not met as a leaf");
        }
    }
}
