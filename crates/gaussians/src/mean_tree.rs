//! The average optical depth `T̄(p) = Σⱼ T̄ⱼ(p)` of many Gaussians at once (paper B §4.2,
//! eq. 26; one term is [`crate::average::gaussian_mean_depth`]), and its scattering part
//! `S̄(p) = Σⱼ αⱼT̄ⱼ(p)`, in `O(log n)` a point instead of `O(n)`: a Barnes–Hut tree.
//!
//! **Far field.** With `σⱼ² = 1/(2aⱼ²)` (the Gaussian's variance per axis) and `u =
//! σⱼ²/d²` at distance `d` from its centre, Dawson's asymptotic series gives
//! `T̄ⱼ = cⱼ𝒯(aⱼd)/aⱼ = wⱼ/d²·(1 + u + 3u² + 15u³ + …)`, `wⱼ = cⱼ√π/(4aⱼ³)`: the mass
//! `cⱼπ^{3/2}/aⱼ³` over `4πd²`, plus the spread's corrections. For the Gaussians of a node,
//! centres `bⱼ = X + δⱼ` about its weighted centre `X`, seen from `p = X + D` (`d = |D|`),
//! each kernel is expanded in `δⱼ`:
//!
//! * `1/|D − δ|² ≈ 1/d² + 2D·δ/d⁴ − |δ|²/d⁴ + 4(D·δ)²/d⁶` (second order),
//! * `σ²/|D − δ|⁴ ≈ σ²/d⁴ + 4σ²D·δ/d⁶` (first order),
//! * `3σ⁴/|D − δ|⁶ ≈ 3σ⁴/d⁶`,
//!
//! so a node keeps `W = Σw`, `M₁ = Σwδ`, `M₂ = Σwδδᵀ`, `Σwσ²`, `Σwσ²δ` and `Σ3wσ⁴`
//! ([`Moments`]) and the whole node costs one evaluation.
//!
//! **When.** A node is taken whole when every centre is within `R ≤ θ·d` of `X`
//! ([`OPENING`] `θ`) and every Gaussian is at least [`FAR_RHO`] radii away (`aₘᵢₙ(d − R) ≥
//! 6`, so `u ≤ 1/72`); otherwise its children are, and a leaf's Gaussians are summed
//! exactly. The first neglected terms, relative to the node's share: `1/|D − δ|²`'s third
//! order, at most `Σ_{k≥3}(k + 1)ε^k` (Gegenbauer's `|C_k¹| ≤ k + 1`, `ε = R/d ≤ θ`): 1.0 %
//! at `θ = 1/8`, all centres on one side along `D`; the spread's next terms `10uε²`,
//! `18u²ε`, `15u³`: below 0.1 %. Over a cloud the odd orders cancel and the error is far
//! smaller (the tests measure it against the direct sum).
//!
//! The tree's shape follows [`crate::bvh`]: median splits on the longest axis of the
//! centres' box, at most [`LEAF`] Gaussians a leaf, so its depth is `⌈log₂(n/LEAF)⌉ + 1`.

use crate::airlight::Blob;
use crate::average::gaussian_mean_depth;
use crate::bvh::Stack;
use haze_core::vec3::{Vec3, axpy, dot, sub};
use std::f64::consts::PI;

/// Most Gaussians in a leaf.
pub const LEAF: usize = 8;

/// The opening ratio `θ`: a node is taken whole beyond `R/θ` of its centre (module docs).
pub const OPENING: f64 = 0.125;

/// A node is taken whole only where each of its Gaussians is this many radii away.
pub const FAR_RHO: f64 = 6.0;

/// A node's moments of one weighting (module docs), about its centre `X`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Moments {
    /// `Σw`.
    w: f64,
    /// `Σwδ`.
    m1: Vec3,
    /// `Σwδδᵀ`: xx, yy, zz, xy, xz, yz.
    m2: [f64; 6],
    /// `Σwσ²`.
    s0: f64,
    /// `Σwσ²δ`.
    s1: Vec3,
    /// `Σ3wσ⁴`.
    q0: f64,
}

impl Moments {
    /// Adds a Gaussian of weight `w` and variance `var` at `delta` from the centre.
    fn add(&mut self, w: f64, var: f64, delta: Vec3) {
        let [x, y, z] = delta;
        self.w += w;
        self.s0 += w * var;
        self.q0 += 3.0 * w * var * var;
        self.m1 = axpy(self.m1, w, delta);
        self.s1 = axpy(self.s1, w * var, delta);
        for (m, v) in self
            .m2
            .iter_mut()
            .zip([x * x, y * y, z * z, x * y, x * z, y * z])
        {
            *m += w * v;
        }
    }

    /// The expansion's value at `D = p − X` (module docs).
    fn at(&self, d: Vec3) -> f64 {
        let i2 = 1.0 / dot(d, d);
        let (i4, i6) = (i2 * i2, i2 * i2 * i2);
        let m = &self.m2;
        let [x, y, z] = d;
        let dmd = m[0] * x * x
            + m[1] * y * y
            + m[2] * z * z
            + 2.0 * (m[3] * x * y + m[4] * x * z + m[5] * y * z);
        let trace = m[0] + m[1] + m[2];
        self.w * i2
            + (2.0 * dot(d, self.m1) - trace + self.s0) * i4
            + (4.0 * dmd + 4.0 * dot(d, self.s1) + self.q0) * i6
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    /// The centre `X` the moments are taken about.
    x: Vec3,
    /// The farthest centre from `X`.
    radius: f64,
    /// The smallest `aⱼ` (the widest Gaussian).
    a_min: f64,
    /// Of `T̄` and of `S̄`.
    depth: Moments,
    scatter: Moments,
    /// Leaf: `first..first + count` in `order`; inner: children at `first`, `first + 1`.
    first: usize,
    count: usize,
}

/// The tree over a set of Gaussians (module docs); Gaussian `j` is `blobs[j]` as given to
/// [`MeanDepthTree::new`].
#[derive(Clone, Debug, Default)]
pub struct MeanDepthTree {
    blobs: Vec<Blob>,
    order: Vec<usize>,
    nodes: Vec<Node>,
}

impl MeanDepthTree {
    /// Builds the tree; Gaussians of zero peak or radius add nothing and are left out.
    pub fn new(blobs: &[Blob]) -> MeanDepthTree {
        let mut order: Vec<usize> = (0..blobs.len())
            .filter(|&j| blobs[j].c > 0.0 && blobs[j].a > 0.0 && blobs[j].a.is_finite())
            .collect();
        let mut tree = MeanDepthTree {
            blobs: blobs.to_vec(),
            order: Vec::new(),
            nodes: Vec::new(),
        };
        if !order.is_empty() {
            let n = order.len();
            tree.nodes.push(tree.summary(&order));
            tree.build(&mut order, 0, 0, n);
        }
        tree.order = order;
        tree
    }

    /// Node `k` over `order[lo..hi]`: a leaf, or split with its two children appended
    /// side by side and built in turn.
    fn build(&mut self, order: &mut [usize], k: usize, lo: usize, hi: usize) {
        self.nodes[k].first = lo;
        self.nodes[k].count = hi - lo;
        if hi - lo <= LEAF {
            return;
        }
        // Median split on the longest axis of the centres' box.
        let (mut min, mut max) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &j in &order[lo..hi] {
            for a in 0..3 {
                min[a] = min[a].min(self.blobs[j].center[a]);
                max[a] = max[a].max(self.blobs[j].center[a]);
            }
        }
        let axis = (0..3)
            .max_by(|&p, &q| (max[p] - min[p]).total_cmp(&(max[q] - min[q])))
            .unwrap_or(0);
        let mid = (lo + hi) / 2;
        let blobs = &self.blobs;
        order[lo..hi].select_nth_unstable_by(mid - lo, |&p, &q| {
            blobs[p].center[axis].total_cmp(&blobs[q].center[axis])
        });
        let c = self.nodes.len();
        self.nodes.push(self.summary(&order[lo..mid]));
        self.nodes.push(self.summary(&order[mid..hi]));
        self.nodes[k].first = c;
        self.nodes[k].count = 0;
        self.build(order, c, lo, mid);
        self.build(order, c + 1, mid, hi);
    }

    /// The centre, reach, widest Gaussian and moments of the Gaussians `members`.
    fn summary(&self, members: &[usize]) -> Node {
        let (mut w, mut x) = (0.0, [0.0; 3]);
        let mut a_min = f64::INFINITY;
        for &j in members {
            let b = &self.blobs[j];
            let wj = weight(b);
            w += wj;
            x = axpy(x, wj, b.center);
            a_min = a_min.min(b.a);
        }
        // The weighted centre (M₁ = 0 for T̄); the first centre if the weights underflow.
        let x = if w > 0.0 && w.is_finite() {
            x.map(|v| v / w)
        } else {
            self.blobs[members[0]].center
        };
        let (mut depth, mut scatter) = (Moments::default(), Moments::default());
        let mut radius: f64 = 0.0;
        for &j in members {
            let b = &self.blobs[j];
            let delta = sub(b.center, x);
            radius = radius.max(dot(delta, delta).sqrt());
            let (wj, var) = (weight(b), 0.5 / (b.a * b.a));
            depth.add(wj, var, delta);
            scatter.add(b.albedo * wj, var, delta);
        }
        Node {
            x,
            radius,
            a_min,
            depth,
            scatter,
            first: 0,
            count: 0,
        }
    }

    /// `(T̄(p), S̄(p))` over every Gaussian but `skip` (module docs): `skip` is a Gaussian
    /// whose own term the caller leaves out, e.g. the one centred at `p`.
    pub fn at(&self, p: Vec3, skip: Option<usize>) -> (f64, f64) {
        let (mut t, mut s) = (0.0, 0.0);
        if self.nodes.is_empty() {
            return (t, s);
        }
        let mut stack = Stack::default();
        while let Some(k) = stack.pop() {
            let node = &self.nodes[k];
            let d = sub(p, node.x);
            let dist = dot(d, d).sqrt();
            if node.radius <= OPENING * dist && node.a_min * (dist - node.radius) >= FAR_RHO {
                t += node.depth.at(d);
                s += node.scatter.at(d);
            } else if node.count > 0 {
                for &j in &self.order[node.first..node.first + node.count] {
                    if Some(j) != skip {
                        let b = &self.blobs[j];
                        let v = gaussian_mean_depth(b.c, b.a, b.center, p);
                        t += v;
                        s += b.albedo * v;
                    }
                }
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
        (t, s)
    }
}

/// `wⱼ = cⱼ√π/(4aⱼ³)`: the far field's `T̄ⱼ ≈ wⱼ/d²` (module docs).
fn weight(b: &Blob) -> f64 {
    b.c * PI.sqrt() / (4.0 * b.a * b.a * b.a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud::{Uniform, ball};

    /// A cloud as the renderer sees it: `ball`'s Gaussians at `σt = 1`, albedos in
    /// `[0.5, 1)`.
    fn blobs(n: usize, seed: u64, spread: f64, radii: (f64, f64)) -> Vec<Blob> {
        let mut u = Uniform::new(seed ^ 0xA5);
        ball(n, seed, [0.3, -0.2, 1.2], spread, radii, 0.3, 1.0)
            .into_iter()
            .map(|g| Blob {
                center: g.center,
                a: 1.0 / g.radius,
                c: g.weight,
                albedo: 0.5 + 0.5 * u.sample(),
            })
            .collect()
    }

    /// The direct sum the tree replaces.
    fn direct(blobs: &[Blob], p: Vec3, skip: Option<usize>) -> (f64, f64) {
        let (mut t, mut s) = (0.0, 0.0);
        for (j, b) in blobs.iter().enumerate() {
            if Some(j) != skip {
                let v = gaussian_mean_depth(b.c, b.a, b.center, p);
                t += v;
                s += b.albedo * v;
            }
        }
        (t, s)
    }

    #[test]
    fn a_node_is_its_gaussians_to_second_order() {
        // Two unequal Gaussians, one node (n ≤ LEAF) evaluated through its moments at
        // growing distance d along an oblique direction: the expansion neglects the
        // third order, so its error falls as d⁻⁵ (the share itself as d⁻²). A wrong
        // first- or second-order term would leave d⁻³ or d⁻⁴.
        let pair = [
            Blob {
                center: [0.2, 0.0, 0.1],
                a: 8.0,
                c: 2.0,
                albedo: 0.9,
            },
            Blob {
                center: [-0.1, 0.15, 0.0],
                a: 5.0,
                c: 1.0,
                albedo: 0.4,
            },
        ];
        let tree = MeanDepthTree::new(&pair);
        let node = &tree.nodes[0];
        let dir = haze_core::vec3::normalize([0.6, -0.3, 0.74]).unwrap();
        let mut scaled = Vec::new();
        for d in [4.0, 8.0, 16.0, 32.0] {
            let p = [0, 1, 2].map(|k| node.x[k] + d * dir[k]);
            let (t, s) = direct(&pair, p, None);
            let dd = sub(p, node.x);
            let (te, se) = (node.depth.at(dd), node.scatter.at(dd));
            scaled.push(((te - t).abs() * d.powi(5), (se - s).abs() * d.powi(5)));
            // Far away the expansion is the sum to within its bound (module docs).
            assert!((te / t - 1.0).abs() < 0.02, "d {d}: {te} vs {t}");
        }
        // d⁻⁵: the scaled error settles (within 30 % between the last doublings).
        for k in 2..scaled.len() {
            for (a, b) in [
                (scaled[k].0, scaled[k - 1].0),
                (scaled[k].1, scaled[k - 1].1),
            ] {
                assert!((a / b - 1.0).abs() < 0.3, "{scaled:?}");
            }
        }
    }

    #[test]
    fn the_tree_is_the_direct_sum_within_its_bound() {
        // 3000 Gaussians in a ball of radius 1.4 (the timing room's cloud): points inside
        // the cloud, at centres (their own term left out), beside it and far away.
        let set = blobs(3000, 7, 1.4, (0.06, 0.2));
        let tree = MeanDepthTree::new(&set);
        let mut u = Uniform::new(3);
        let mut worst: f64 = 0.0;
        let mut points: Vec<(Vec3, Option<usize>)> = (0..300)
            .map(|_| ([0, 1, 2].map(|_| 6.0 * u.sample() - 3.0), None))
            .collect();
        points.extend((0..100).map(|k| (set[k * 29].center, Some(k * 29))));
        points.push(([40.0, -30.0, 2.0], None));
        points.push(([0.3, -0.2, -1.0], None));
        for (p, skip) in points {
            let (t, s) = direct(&set, p, skip);
            let (te, se) = tree.at(p, skip);
            // The bound of the module docs: 1.1 % of the far share, so of the sum.
            for (got, want) in [(te, t), (se, s)] {
                let e = (got / want - 1.0).abs();
                worst = worst.max(e);
                assert!(e <= 0.011, "{p:?}: {got} vs {want}");
            }
        }
        // Over a cloud the odd orders cancel: far inside the worst case.
        assert!(worst < 2e-3, "{worst}");
    }

    #[test]
    fn extremes() {
        // Nothing, or only Gaussians that add nothing: zero, no panic.
        assert_eq!(MeanDepthTree::new(&[]).at([0.0; 3], None), (0.0, 0.0));
        let empty = Blob {
            center: [0.0; 3],
            a: 1.0,
            c: 0.0,
            albedo: 1.0,
        };
        let flat = Blob {
            a: 0.0,
            c: 1.0,
            ..empty
        };
        let tree = MeanDepthTree::new(&[empty, flat]);
        assert_eq!(tree.at([0.5; 3], None), (0.0, 0.0));
        // One Gaussian, at its own centre and skipped there; far away finite and 1/d².
        let one = Blob { c: 2.0, ..empty };
        let tree = MeanDepthTree::new(&[one]);
        assert_eq!(tree.at([0.0; 3], Some(0)), (0.0, 0.0));
        let (t, _) = tree.at([0.0; 3], None);
        assert!((t - 2.0 * 0.5 * PI.sqrt()).abs() < 1e-14);
        let (t, s) = tree.at([1e150, 0.0, 0.0], None);
        assert!(
            t.is_finite() && s.is_finite() && t > 0.0 && t < 1e-290,
            "{t}"
        );
        // Many Gaussians at one point (a zero-size node): the leaves take them exactly.
        let stack = vec![one; 100];
        let tree = MeanDepthTree::new(&stack);
        let (t, _) = tree.at([0.3, 0.0, 0.0], None);
        let want = direct(&stack, [0.3, 0.0, 0.0], None).0;
        assert!((t / want - 1.0).abs() < 1e-12, "{t} vs {want}");
        // A wide node seen from far away is taken whole and stays finite.
        let (t, _) = tree.at([1e3, 0.0, 0.0], None);
        assert!((t / direct(&stack, [1e3, 0.0, 0.0], None).0 - 1.0).abs() < 1e-6);
    }
}
