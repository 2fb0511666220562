//! Triangle meshes and their bounding-volume hierarchy.
//!
//! A ray `o + t·d` meets a triangle `(p0, p1, p2)` where (Möller–Trumbore)
//! `o + t·d = p0 + u·e1 + v·e2`, `e1 = p1 − p0`, `e2 = p2 − p0`, solved by Cramer's rule:
//! `det = e1·(d × e2)`, `u = s·(d × e2)/det`, `v = d·(s × e1)/det`, `t = e2·(s × e1)/det`
//! with `s = o − p0`; a hit needs `u, v ≥ 0`, `u + v ≤ 1` and `t` in the ray's interval.
//! A ray in the triangle's plane (`det = 0`) does not meet it.
//!
//! The hierarchy splits triangles at the median centroid along the longest axis of their
//! centroids' box until at most [`LEAF_SIZE`] remain, stored depth first: an inner node's
//! first child follows it, its second child's index is stored. A ray visits a node when
//! it meets the node's box (slab test; boxes grown by 10⁻⁹ of the mesh's size and the far
//! distance widened by a few ulps, so rounding never culls a triangle the brute-force
//! loop would hit).

pub mod model;

use crate::vec3::{Vec3, cross, dot, normalize, sub};

/// At most this many triangles in a leaf.
pub const LEAF_SIZE: usize = 4;

/// One triangle: its corners and, when the model has them, the corners' unit normals
/// (interpolated for shading).
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle {
    pub p: [Vec3; 3],
    pub n: Option<[Vec3; 3]>,
}

impl Triangle {
    /// `(t, u, v)` where the ray `o + t·d` meets the triangle with `t ∈ (t_min, t_max)`,
    /// `u, v` the barycentric weights of corners 1 and 2.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<(f64, f64, f64)> {
        let e1 = sub(self.p[1], self.p[0]);
        let e2 = sub(self.p[2], self.p[0]);
        let pv = cross(d, e2);
        let det = dot(e1, pv);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = sub(o, self.p[0]);
        let u = dot(s, pv) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = cross(s, e1);
        let v = dot(d, q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = dot(e2, q) * inv;
        (t > t_min && t < t_max).then_some((t, u, v))
    }

    /// The unit normal of the triangle's plane, `e1 × e2` normalized; `None` when the
    /// triangle is degenerate: `|e1 × e2| ≤ 10⁻¹²·|e1|·|e2|` (its edges' angle below
    /// 10⁻¹² rad, or an edge of zero length), where the hit's `det` is rounding noise.
    pub fn face_normal(&self) -> Option<Vec3> {
        let (e1, e2) = (sub(self.p[1], self.p[0]), sub(self.p[2], self.p[0]));
        let c = cross(e1, e2);
        let scale = crate::vec3::norm(e1) * crate::vec3::norm(e2);
        if crate::vec3::norm(c) > 1e-12 * scale {
            normalize(c)
        } else {
            None
        }
    }

    /// The shading normal at barycentric `(u, v)`: the corners' normals interpolated,
    /// or the face normal.
    pub fn normal(&self, u: f64, v: f64) -> Vec3 {
        let face = self.face_normal().unwrap_or([0.0, 0.0, 1.0]);
        match self.n {
            None => face,
            Some(n) => {
                let w = 1.0 - u - v;
                let m = [0, 1, 2].map(|k| w * n[0][k] + u * n[1][k] + v * n[2][k]);
                normalize(m).unwrap_or(face)
            }
        }
    }

    fn centroid(&self) -> Vec3 {
        [0, 1, 2].map(|k| (self.p[0][k] + self.p[1][k] + self.p[2][k]) / 3.0)
    }
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: [f64::INFINITY; 3],
        max: [f64::NEG_INFINITY; 3],
    };

    fn grow(&mut self, p: Vec3) {
        for (k, x) in p.into_iter().enumerate() {
            self.min[k] = self.min[k].min(x);
            self.max[k] = self.max[k].max(x);
        }
    }

    /// Whether the ray `o + t·d` (`inv = 1/d` per axis) meets the box for some
    /// `t ∈ [t_min, t_max]`. Along an axis where `d` is zero the ray meets the slab
    /// everywhere or nowhere: whether `o` lies in it, boundaries included (the slab
    /// distances would be `0·∞`).
    fn hit(&self, o: Vec3, inv: Vec3, t_min: f64, t_max: f64) -> bool {
        let (mut lo, mut hi) = (t_min, t_max);
        for k in 0..3 {
            if inv[k].is_infinite() {
                if o[k] < self.min[k] || o[k] > self.max[k] {
                    return false;
                }
                continue;
            }
            let a = (self.min[k] - o[k]) * inv[k];
            let b = (self.max[k] - o[k]) * inv[k];
            lo = lo.max(a.min(b));
            hi = hi.min(a.max(b) * (1.0 + 4.0 * f64::EPSILON));
        }
        lo <= hi
    }
}

/// A node of the hierarchy: its box; a leaf holds `count > 0` triangles from `first`
/// in [`Mesh::triangles`], an inner node (`count = 0`) has its children at its own index
/// + 1 and at `first`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub bounds: Aabb,
    pub first: u32,
    pub count: u32,
}

/// A triangle mesh in world space with its hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// The triangles, ordered so that every leaf's are contiguous.
    pub triangles: Vec<Triangle>,
    pub nodes: Vec<Node>,
}

/// Where a ray meets a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshHit {
    pub t: f64,
    pub triangle: usize,
    pub u: f64,
    pub v: f64,
}

impl Mesh {
    /// Builds the hierarchy over `triangles` (at least one).
    pub fn new(triangles: Vec<Triangle>) -> Mesh {
        assert!(!triangles.is_empty(), "a mesh needs triangles");
        let mut items: Vec<(Vec3, Triangle)> =
            triangles.into_iter().map(|t| (t.centroid(), t)).collect();
        let mut nodes = Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1);
        build(&mut items, 0, &mut nodes);
        // Boxes grown by 10⁻⁹ of the mesh's size: a hit's `t` carries rounding of a few
        // ulps of the triangle's coordinates, which may place it just outside the exact
        // box of its corners.
        let root = nodes[0].bounds;
        let pad = 1e-9 * crate::vec3::norm(sub(root.max, root.min)).max(f64::MIN_POSITIVE);
        for n in &mut nodes {
            n.bounds.min = n.bounds.min.map(|x| x - pad);
            n.bounds.max = n.bounds.max.map(|x| x + pad);
        }
        Mesh {
            triangles: items.into_iter().map(|(_, t)| t).collect(),
            nodes,
        }
    }

    /// The nearest triangle along `o + t·d` with `t ∈ (t_min, t_max)`.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<MeshHit> {
        let inv = d.map(|x| 1.0 / x);
        let mut best: Option<MeshHit> = None;
        // Median splits halve the triangles: depth ≤ log₂(count) + 1 < 64.
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            let hi = best.map_or(t_max, |b| b.t);
            if !node.bounds.hit(o, inv, t_min, hi) {
                continue;
            }
            if node.count > 0 {
                let first = node.first as usize;
                for i in first..first + node.count as usize {
                    let hi = best.map_or(t_max, |b| b.t);
                    if let Some((t, u, v)) = self.triangles[i].intersect(o, d, t_min, hi) {
                        best = Some(MeshHit {
                            t,
                            triangle: i,
                            u,
                            v,
                        });
                    }
                }
            } else {
                stack[top] = node.first;
                stack[top + 1] = index + 1;
                top += 2;
            }
        }
        best
    }
}

/// Appends the subtree over `items` (triangles from index `offset` of the final order)
/// to `nodes`, depth first.
fn build(items: &mut [(Vec3, Triangle)], offset: usize, nodes: &mut Vec<Node>) {
    let mut bounds = Aabb::EMPTY;
    let mut cbox = Aabb::EMPTY;
    for (c, t) in items.iter() {
        t.p.iter().for_each(|&p| bounds.grow(p));
        cbox.grow(*c);
    }
    let me = nodes.len();
    nodes.push(Node {
        bounds,
        first: offset as u32,
        count: items.len() as u32,
    });
    let extent = sub(cbox.max, cbox.min);
    let axis = (0..3)
        .max_by(|&a, &b| extent[a].total_cmp(&extent[b]))
        .unwrap_or(0);
    // Every centroid at one point: no split can separate them.
    if items.len() <= LEAF_SIZE || extent[axis] <= 0.0 {
        return;
    }
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
    let (left, right) = items.split_at_mut(mid);
    build(left, offset, nodes);
    let second = nodes.len();
    build(right, offset + mid, nodes);
    nodes[me].first = second as u32;
    nodes[me].count = 0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    /// The test rays' draws, from a seeded PCG.
    struct Rng(Pcg64);
    impl Rng {
        fn new(seed: u64) -> Rng {
            Rng(Pcg64::seed_from_u64(seed))
        }
        fn next(&mut self) -> f64 {
            self.0.random()
        }
        fn point(&mut self, r: f64) -> Vec3 {
            [0; 3].map(|_| r * (2.0 * self.next() - 1.0))
        }
    }

    /// A bumpy closed surface: a UV sphere of `n × 2n` quads with its radius perturbed,
    /// so triangles have many sizes and orientations and share edges and vertices.
    fn blob(n: usize) -> Vec<Triangle> {
        let vertex = |i: usize, j: usize| {
            let th = std::f64::consts::PI * i as f64 / n as f64;
            let ph = std::f64::consts::PI * j as f64 / n as f64;
            let r = 1.0 + 0.2 * (3.0 * th).sin() * (2.0 * ph).cos();
            [
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            ]
        };
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..2 * n {
                let (a, b, c, d) = (
                    vertex(i, j),
                    vertex(i + 1, j),
                    vertex(i + 1, j + 1),
                    vertex(i, j + 1),
                );
                for p in [[a, b, c], [a, c, d]] {
                    let t = Triangle { p, n: None };
                    if t.face_normal().is_some() {
                        tris.push(t);
                    }
                }
            }
        }
        tris
    }

    /// The hierarchy's depth below node `i` (a leaf alone: 1).
    fn depth(nodes: &[Node], i: usize) -> usize {
        let n = &nodes[i];
        if n.count > 0 {
            1
        } else {
            1 + depth(nodes, i + 1).max(depth(nodes, n.first as usize))
        }
    }

    fn brute(tris: &[Triangle], o: Vec3, d: Vec3, t_max: f64) -> Option<(f64, usize)> {
        let mut best: Option<(f64, usize)> = None;
        for (i, t) in tris.iter().enumerate() {
            if let Some((t, _, _)) = t.intersect(o, d, 0.0, best.map_or(t_max, |b| b.0)) {
                best = Some((t, i));
            }
        }
        best
    }

    #[test]
    fn the_hierarchy_finds_what_brute_force_finds() {
        let mesh = Mesh::new(blob(12));
        assert!(depth(&mesh.nodes, 0) < 64, "a stack of 64 is enough");
        let mut rng = Rng::new(7);
        let mut rays = Vec::new();
        // Random rays from outside and inside, in random directions and aimed at points
        // near the surface.
        for _ in 0..1500 {
            let o = rng.point(2.5);
            rays.push((o, normalize(rng.point(1.0)).unwrap()));
            rays.push((o, normalize(sub(rng.point(1.0), o)).unwrap()));
        }
        // Rays through vertices and along edges (from a vertex towards the next corner,
        // started outside on the edge's line) and axis-aligned rays (zero components).
        for t in mesh.triangles.iter().step_by(7) {
            let e = sub(t.p[1], t.p[0]);
            let d = normalize(e).unwrap();
            rays.push((crate::vec3::axpy(t.p[0], -3.0, d), d));
            let o = rng.point(2.5);
            rays.push((o, normalize(sub(t.p[2], o)).unwrap()));
            rays.push((o, [0.0, 0.0, -1.0]));
            rays.push(([t.p[0][0], t.p[0][1], 3.0], [0.0, 0.0, -1.0]));
        }
        let mut hits = 0;
        for (o, d) in rays {
            let want = brute(&mesh.triangles, o, d, f64::INFINITY);
            let got = mesh.intersect(o, d, 0.0, f64::INFINITY);
            match (want, got) {
                (None, None) => {}
                (Some((t, _)), Some(h)) => {
                    hits += 1;
                    // The same nearest distance (a ray through a shared edge or vertex
                    // may report either triangle).
                    assert_eq!(t, h.t, "ray {o:?} {d:?}");
                }
                _ => panic!("ray {o:?} {d:?}: brute {want:?}, hierarchy {got:?}"),
            }
        }
        assert!(hits > 1000, "{hits} hits: the rays must test something");
    }

    #[test]
    fn triangle_hits_match_the_plane_and_barycentric_test() {
        // The triangle (0,0,0), (2,0,0), (0,1,0) met by a ray down z at (x, y):
        // t = height, u = x/2, v = y, inside when u, v ≥ 0, u + v ≤ 1.
        let t = Triangle {
            p: [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            n: None,
        };
        let mut rng = Rng::new(3);
        for _ in 0..1000 {
            let (x, y) = (3.0 * rng.next() - 0.5, 1.5 * rng.next() - 0.25);
            let got = t.intersect([x, y, 2.5], [0.0, 0.0, -1.0], 0.0, 10.0);
            let (u, v) = (x / 2.0, y);
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 {
                let (tt, gu, gv) = got.expect("inside");
                assert!(
                    (tt - 2.5).abs() < 1e-15 && (gu - u).abs() < 1e-15 && (gv - v).abs() < 1e-15
                );
            } else {
                assert!(got.is_none());
            }
        }
        // In the plane, or behind the origin, or beyond t_max: no hit.
        assert!(
            t.intersect([-1.0, 0.2, 0.0], [1.0, 0.0, 0.0], 0.0, 10.0)
                .is_none()
        );
        assert!(
            t.intersect([0.2, 0.2, -1.0], [0.0, 0.0, -1.0], 0.0, 10.0)
                .is_none()
        );
        assert!(
            t.intersect([0.2, 0.2, 5.0], [0.0, 0.0, -1.0], 0.0, 4.0)
                .is_none()
        );
        // Interpolated normals; a degenerate triangle has no face normal.
        let n = Triangle {
            n: Some([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
            ..t.clone()
        };
        let m = n.normal(1.0 / 3.0, 1.0 / 3.0);
        assert!((m[0] - 3f64.sqrt().recip()).abs() < 1e-15);
        let flat = Triangle {
            p: [[0.0; 3], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]],
            n: None,
        };
        assert!(flat.face_normal().is_none());
        assert!(
            flat.intersect([0.5, 0.0, 0.5], [0.0, 1.0, 0.0], 0.0, 9.0)
                .is_none()
        );
    }

    #[test]
    fn a_single_triangle_and_flat_meshes_build() {
        // One leaf; and many triangles with one centroid (no split possible).
        let t = Triangle {
            p: [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            n: None,
        };
        let one = Mesh::new(vec![t.clone()]);
        assert_eq!(one.nodes.len(), 1);
        let same = Mesh::new(vec![t.clone(); 40]);
        assert_eq!(same.nodes.len(), 1);
        let h = same
            .intersect([0.2, 0.2, 1.0], [0.0, 0.0, -1.0], 0.0, 9.0)
            .unwrap();
        assert_eq!(h.t, 1.0);
        // A flat mesh (zero-thickness box) met by rays along and across its plane.
        let flat = Mesh::new(
            (0..20)
                .map(|i| Triangle {
                    p: [
                        [i as f64, 0.0, 0.0],
                        [i as f64 + 1.0, 0.0, 0.0],
                        [i as f64, 1.0, 0.0],
                    ],
                    n: None,
                })
                .collect(),
        );
        for x in [0.25, 7.5, 19.1] {
            let h = flat
                .intersect([x, 0.1, 2.0], [0.0, 0.0, -1.0], 0.0, 9.0)
                .unwrap();
            assert_eq!(h.t, 2.0);
        }
        assert!(
            flat.intersect([-1.0, 0.1, 0.0], [1.0, 0.0, 0.0], 0.0, 99.0)
                .is_none()
        );
    }
}
