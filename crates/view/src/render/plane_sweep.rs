//! Sweeping a lattice's node planes along a ray direction: the order and the reads that
//! let a quantity accumulated along rays (here an optical depth) be built at
//! each node from the nodes nearer the face the rays leave by, instead of a march of its
//! own to that face ([`super::env_sweep`]).
//!
//! **Geometry.** Nodes sit at `min + i·cell`. For a ray direction `r`, take the axis `k`
//! whose node planes the ray crosses fastest (the largest `|r_k|/cell_k`). From node `x`
//! the ray `x + s·r` meets the node plane `stride` planes further towards the face it
//! leaves by at `s₁ = stride·cell_k/|r_k|`, at a point `p` within `stride` cells of `x`
//! on the other two axes; the quantity there is read bilinearly from that plane's four
//! nodes around `p`. Planes are visited from the face the rays leave by, so those nodes
//! are done first. The first `stride` planes, and the nodes whose `p` falls outside the
//! swept domain (the ray leaves it through a side), get no reads: they march.
//!
//! A plane's nodes read only the plane `stride` upstream, so [`Sweep::fill`] computes
//! `stride` consecutive planes' nodes together, in parallel (a quarter of the barriers of
//! one plane at a time at a stride of 4); the values are the same as node by node, to the
//! bit.
//!
//! Each bilinear read blurs what it reads sideways (a variance of up to a quarter of a
//! cell² per read), so a larger stride, with fewer reads over a ray, blurs less and costs
//! a longer segment.

use rayon::prelude::*;

/// Nodes at `min + i·cell`, `dims` per axis (node index `x` fastest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    pub min: [f64; 3],
    pub cell: [f64; 3],
    pub dims: [usize; 3],
}

impl Lattice {
    /// The flat index of node `i`.
    pub fn index(&self, i: [usize; 3]) -> usize {
        i[0] + self.dims[0] * (i[1] + self.dims[1] * i[2])
    }

    /// The position of node `i`.
    pub fn point(&self, i: [usize; 3]) -> [f64; 3] {
        [0, 1, 2].map(|a| self.min[a] + i[a] as f64 * self.cell[a])
    }
}

/// Node planes crossed per unit length along `r` on axis `a` of `domain` (0 on an axis
/// the domain is one node across).
fn rate(lattice: &Lattice, domain: [(usize, usize); 3], r: [f64; 3], a: usize) -> f64 {
    if domain[a].1 > domain[a].0 && lattice.cell[a] > 0.0 {
        r[a].abs() / lattice.cell[a]
    } else {
        0.0
    }
}

/// The sweep's axis for the ray direction `r` over `domain`: the one whose node planes
/// the ray crosses fastest (the first of equals; 0 where none is crossed).
pub fn axis(lattice: &Lattice, domain: [(usize, usize); 3], r: [f64; 3]) -> usize {
    (0..3).fold(0, |best, a| {
        if rate(lattice, domain, r, a) > rate(lattice, domain, r, best) {
            a
        } else {
            best
        }
    })
}

/// Four nodes of an upstream plane and their bilinear weights.
pub type Reads = [(usize, f64); 4];

/// One direction's sweep over `domain` (per axis the first and last node index) of a
/// lattice (module docs).
#[derive(Clone, Debug)]
pub struct Sweep {
    lattice: Lattice,
    domain: [(usize, usize); 3],
    r: [f64; 3],
    stride: usize,
    /// The sweep's axis and the other two.
    axes: [usize; 3],
    /// `None` without a plane to cross along the ray (every node marches).
    s1: Option<f64>,
}

impl Sweep {
    /// The sweep of `domain` along the unit ray direction `r`, reading `stride ≥ 1` planes
    /// on.
    pub fn new(lattice: Lattice, domain: [(usize, usize); 3], r: [f64; 3], stride: usize) -> Sweep {
        let k = axis(&lattice, domain, r);
        let rate = rate(&lattice, domain, r, k);
        let stride = stride.max(1);
        let s1 =
            (rate > 0.0 && rate.is_finite()).then(|| stride as f64 * lattice.cell[k] / r[k].abs());
        Sweep {
            lattice,
            domain,
            r,
            stride,
            axes: [k, (k + 1) % 3, (k + 2) % 3],
            s1,
        }
    }

    /// The length of the segment from a node to the point its reads are at (0 without
    /// a sweep).
    pub fn segment(&self) -> f64 {
        self.s1.unwrap_or(0.0)
    }

    /// Fills `out` (one value a lattice node) over the domain in the sweep's order:
    /// `out[i] = value(x, reads, out)` at node `i` at `x`, `reads` the upstream nodes (all
    /// filled before) or `None` where the node must march. The nodes of one plane read
    /// only the plane `stride` upstream, so `stride` planes at a time are computed in
    /// parallel (`rayon`) and written when they are done.
    pub fn fill(
        &self,
        out: &mut [f32],
        value: impl Fn([f64; 3], Option<Reads>, &[f32]) -> f32 + Sync,
    ) {
        let [k, a, b] = self.axes;
        let d = self.domain;
        let mut planes: Vec<usize> = (d[k].0..=d[k].1).collect();
        if self.s1.is_some() && self.r[k] > 0.0 {
            // From the face the rays leave by.
            planes.reverse();
        }
        let row = d[a].1 + 1 - d[a].0;
        let nodes = row * (d[b].1 + 1 - d[b].0);
        let mut values = Vec::new();
        // A node reads only the plane `stride` steps before its own, so `stride`
        // consecutive planes read none of each other: they are computed together.
        for (batch, batch_planes) in planes.chunks(self.stride).enumerate() {
            let first = batch * self.stride;
            let read = &*out;
            (0..nodes * batch_planes.len())
                .into_par_iter()
                .with_min_len(row)
                .map(|j| {
                    let (p, j) = (j / nodes, j % nodes);
                    let (x, reads) = self.node(
                        first + p,
                        batch_planes[p],
                        d[a].0 + j % row,
                        d[b].0 + j / row,
                    );
                    value(x, reads, read)
                })
                .collect_into_vec(&mut values);
            for (j, v) in values.iter().enumerate() {
                let (p, j) = (j / nodes, j % nodes);
                let mut i = [0usize; 3];
                (i[k], i[a], i[b]) = (batch_planes[p], d[a].0 + j % row, d[b].0 + j / row);
                out[self.lattice.index(i)] = *v;
            }
        }
    }

    /// Node `(ia, ib)` of the `step`-th plane visited (`plane` its index on the sweep's
    /// axis): its position and reads.
    fn node(&self, step: usize, plane: usize, ia: usize, ib: usize) -> ([f64; 3], Option<Reads>) {
        let [k, a, b] = self.axes;
        let (d, l) = (self.domain, &self.lattice);
        let up = if self.r[k] > 0.0 {
            plane + self.stride
        } else {
            plane.wrapping_sub(self.stride)
        };
        let mut i = [0usize; 3];
        (i[k], i[a], i[b]) = (plane, ia, ib);
        let x = l.point(i);
        let reads = match self.s1 {
            Some(s1) if step >= self.stride => {
                let p = [0, 1, 2].map(|c| x[c] + s1 * self.r[c]);
                self.stencil(a, p[a])
                    .zip(self.stencil(b, p[b]))
                    .map(|((ja, fa), (jb, fb))| {
                        let at = |da: usize, db: usize, w: f64| {
                            let mut j = [0usize; 3];
                            j[k] = up;
                            j[a] = (ja + da).min(d[a].1);
                            j[b] = (jb + db).min(d[b].1);
                            (l.index(j), w)
                        };
                        [
                            at(0, 0, (1.0 - fa) * (1.0 - fb)),
                            at(1, 0, fa * (1.0 - fb)),
                            at(0, 1, (1.0 - fa) * fb),
                            at(1, 1, fa * fb),
                        ]
                    })
            }
            _ => None,
        };
        (x, reads)
    }

    /// Where `x` on axis `ax` falls among the domain's nodes: the lower node and the
    /// fraction towards the next; `None` outside the domain (or off its one node, on an
    /// axis of one).
    fn stencil(&self, ax: usize, x: f64) -> Option<(usize, f64)> {
        let (lo, hi) = self.domain[ax];
        let (min, cell) = (self.lattice.min[ax], self.lattice.cell[ax]);
        if hi == lo || cell <= 0.0 {
            // One node across: `x` must lie on it (a ray along the others' planes).
            let on = min + lo as f64 * cell;
            let slack = 1e-9 * self.lattice.cell.iter().fold(1.0, |m: f64, c| m.max(*c));
            return ((x - on).abs() <= slack).then_some((lo, 0.0));
        }
        let f = (x - min) / cell;
        // A hair of slack for rounding on the domain's edge.
        if !(lo as f64 - 1e-9..=hi as f64 + 1e-9).contains(&f) {
            return None;
        }
        let f = f.clamp(lo as f64, hi as f64);
        let i0 = (f.floor() as usize).min(hi - 1);
        Some((i0, f - i0 as f64))
    }
}
