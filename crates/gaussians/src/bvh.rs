//! A bounding-volume hierarchy over spheres (a Gaussian's centre and the radius beyond
//! which it is negligible): which spheres a segment crosses, which contain a point.
//! Median split on the longest axis of the centres' box, at most [`LEAF`] spheres a leaf;
//! nodes hold the box of their spheres. Queries are exact: a sphere is reported iff the
//! segment passes within its radius (the point lies inside).

use haze_core::vec3::{Vec3, axpy, dot, sub};

/// Most spheres in a leaf.
pub const LEAF: usize = 4;

#[derive(Clone, Copy, Debug)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Leaf: `first..first + count` in `order`; inner: children at `first`, `first + 1`.
    first: usize,
    count: usize,
}

/// The hierarchy; sphere `i` is `(centers[i], radii[i])` as given to [`SphereBvh::new`].
#[derive(Clone, Debug, Default)]
pub struct SphereBvh {
    centers: Vec<Vec3>,
    radii: Vec<f64>,
    order: Vec<usize>,
    nodes: Vec<Node>,
}

impl SphereBvh {
    /// Builds the hierarchy; spheres of radius `≤ 0` are never reported.
    pub fn new(centers: Vec<Vec3>, radii: Vec<f64>) -> SphereBvh {
        assert_eq!(centers.len(), radii.len());
        let mut order: Vec<usize> = (0..centers.len()).filter(|&i| radii[i] > 0.0).collect();
        let mut nodes = Vec::new();
        if !order.is_empty() {
            let n = order.len();
            nodes.push(Node {
                min: [0.0; 3],
                max: [0.0; 3],
                first: 0,
                count: n,
            });
            build(&centers, &radii, &mut order, &mut nodes, 0, 0, n);
        }
        SphereBvh {
            centers,
            radii,
            order,
            nodes,
        }
    }

    /// Calls `f(i)` for every sphere within its radius of the segment `o + t·d`,
    /// `t ∈ [0, len]` (unit `d`; `len` may be `∞`).
    pub fn segment(&self, o: Vec3, d: Vec3, len: f64, f: impl FnMut(usize)) {
        self.segment_within(o, d, len, 0.0, f);
    }

    /// Calls `f(i)` for every sphere within its radius plus `margin` (`≥ 0`) of the
    /// segment `o + t·d`, `t ∈ [0, len]` (unit `d`; `len` may be `∞`).
    pub fn segment_within(
        &self,
        o: Vec3,
        d: Vec3,
        len: f64,
        margin: f64,
        mut f: impl FnMut(usize),
    ) {
        if self.nodes.is_empty() || len.is_nan() || len < 0.0 || margin.is_nan() || margin < 0.0 {
            return;
        }
        let inv = d.map(|x| 1.0 / x);
        let mut stack = Stack::default();
        while let Some(k) = stack.pop() {
            let node = &self.nodes[k];
            if !slab(node, o, inv, len, margin) {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.first..node.first + node.count] {
                    let bp = sub(self.centers[i], o);
                    let t = dot(bp, d).clamp(0.0, len);
                    let x = axpy(bp, -t, d);
                    let r = self.radii[i] + margin;
                    if dot(x, x) <= r * r {
                        f(i);
                    }
                }
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
    }

    /// Calls `f(i)` for every sphere containing `x`.
    pub fn point(&self, x: Vec3, mut f: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = Stack::default();
        while let Some(k) = stack.pop() {
            let node = &self.nodes[k];
            if (0..3).any(|j| x[j] < node.min[j] || x[j] > node.max[j]) {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.first..node.first + node.count] {
                    let v = sub(x, self.centers[i]);
                    if dot(v, v) <= self.radii[i] * self.radii[i] {
                        f(i);
                    }
                }
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
    }
}

/// The nodes still to visit, on the stack of the caller (no allocation a query): median
/// splits keep the depth at `⌈log₂(n/LEAF)⌉ + 1`, and a depth-first walk holds at most one
/// node more than the depth, so 64 serve any count that fits in memory. Starts with the root.
pub(crate) struct Stack {
    nodes: [usize; 64],
    top: usize,
}

impl Default for Stack {
    fn default() -> Self {
        Stack {
            nodes: [0; 64],
            top: 1,
        }
    }
}

impl Stack {
    pub(crate) fn push(&mut self, k: usize) {
        self.nodes[self.top] = k;
        self.top += 1;
    }

    pub(crate) fn pop(&mut self) -> Option<usize> {
        self.top = self.top.checked_sub(1)?;
        Some(self.nodes[self.top])
    }
}

/// Whether the segment meets the node's box grown by `margin` (slab method; `inv` = `1/d`,
/// infinite for a zero component, where `0·∞` gives NaN and the origin's own slab decides).
fn slab(node: &Node, o: Vec3, inv: Vec3, len: f64, margin: f64) -> bool {
    let (mut t0, mut t1) = (0.0f64, len);
    for k in 0..3 {
        let (lo, hi) = (node.min[k] - margin, node.max[k] + margin);
        if inv[k].is_infinite() {
            if o[k] < lo || o[k] > hi {
                return false;
            }
            continue;
        }
        let a = (lo - o[k]) * inv[k];
        let b = (hi - o[k]) * inv[k];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// Fills node `k` over `order[lo..hi]` and its subtree.
fn build(
    centers: &[Vec3],
    radii: &[f64],
    order: &mut [usize],
    nodes: &mut Vec<Node>,
    k: usize,
    lo: usize,
    hi: usize,
) {
    let (mut min, mut max) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let (mut cmin, mut cmax) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for &i in &order[lo..hi] {
        for j in 0..3 {
            min[j] = min[j].min(centers[i][j] - radii[i]);
            max[j] = max[j].max(centers[i][j] + radii[i]);
            cmin[j] = cmin[j].min(centers[i][j]);
            cmax[j] = cmax[j].max(centers[i][j]);
        }
    }
    nodes[k].min = min;
    nodes[k].max = max;
    if hi - lo <= LEAF {
        nodes[k].first = lo;
        nodes[k].count = hi - lo;
        return;
    }
    let axis = (0..3)
        .max_by(|&a, &b| (cmax[a] - cmin[a]).total_cmp(&(cmax[b] - cmin[b])))
        .unwrap_or(0);
    let mid = lo + (hi - lo) / 2;
    order[lo..hi].select_nth_unstable_by(mid - lo, |&a, &b| {
        centers[a][axis].total_cmp(&centers[b][axis])
    });
    let child = nodes.len();
    for _ in 0..2 {
        nodes.push(Node {
            min: [0.0; 3],
            max: [0.0; 3],
            first: 0,
            count: 0,
        });
    }
    nodes[k].first = child;
    nodes[k].count = 0;
    build(centers, radii, order, nodes, child, lo, mid);
    build(centers, radii, order, nodes, child + 1, mid, hi);
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_core::vec3::normalize;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    #[test]
    fn queries_match_brute_force() {
        let mut s = Pcg64::seed_from_u64(7);
        let n = 500;
        let centers: Vec<Vec3> = (0..n)
            .map(|_| [0, 1, 2].map(|_| s.random::<f64>() * 10.0 - 5.0))
            .collect();
        let radii: Vec<f64> = (0..n)
            .map(|i| {
                if i % 50 == 0 {
                    0.0
                } else {
                    0.05 + s.random::<f64>()
                }
            })
            .collect();
        let bvh = SphereBvh::new(centers.clone(), radii.clone());
        for q in 0..200 {
            let o = [0, 1, 2].map(|_| s.random::<f64>() * 12.0 - 6.0);
            let mut d = normalize([0, 1, 2].map(|_| s.random::<f64>() - 0.5)).unwrap();
            if q % 10 == 0 {
                d = [0.0, 0.0, 1.0]; // axis-aligned: zero components
            }
            let len = if q % 7 == 0 {
                f64::INFINITY
            } else {
                s.random::<f64>() * 8.0
            };
            // Plain, and with every radius grown by a margin.
            for margin in [0.0, s.random::<f64>() * 0.7] {
                let mut got = Vec::new();
                if margin == 0.0 {
                    bvh.segment(o, d, len, |i| got.push(i));
                } else {
                    bvh.segment_within(o, d, len, margin, |i| got.push(i));
                }
                got.sort_unstable();
                let want: Vec<usize> = (0..n)
                    .filter(|&i| {
                        let bp = sub(centers[i], o);
                        let t = dot(bp, d).clamp(0.0, len);
                        let x = axpy(bp, -t, d);
                        let r = radii[i] + margin;
                        radii[i] > 0.0 && dot(x, x) <= r * r
                    })
                    .collect();
                assert_eq!(got, want, "segment within {margin} {o:?} {d:?} {len}");
            }
            let mut got = Vec::new();
            bvh.point(o, |i| got.push(i));
            got.sort_unstable();
            let want: Vec<usize> = (0..n)
                .filter(|&i| {
                    let v = sub(o, centers[i]);
                    radii[i] > 0.0 && dot(v, v) <= radii[i] * radii[i]
                })
                .collect();
            assert_eq!(got, want, "point {o:?}");
        }
        let empty = SphereBvh::new(Vec::new(), Vec::new());
        empty.segment([0.0; 3], [1.0, 0.0, 0.0], 1.0, |_| panic!());
    }
}
