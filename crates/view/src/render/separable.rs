//! Trilinear interpolation of a coarse grid's nodes at every voxel center, one axis at a
//! time. The passes that add a coarse grid's light to the voxels towards the eye (the
//! environment grid's, [`super::env_pass::add_env_grid`]; the multiple scattering's cells,
//! [`super::grid_diffusion::add_to_grids`]) read dozens of numbers per node — an SH vector
//! per channel — at every lit voxel.
//!
//! **Why separable.** A voxel's trilinear weights are products `w_x(i)·w_y(j)·w_z(k)` of
//! one factor per axis, each a function of that axis's voxel index alone, so
//!
//! ```text
//! Σ_corners w_x w_y w_z V = Σ_x w_x · Σ_y w_y · (Σ_z w_z V)
//! ```
//!
//! A slice of voxels shares `w_z`: [`Separable::slice`] interpolates the node planes along z
//! once (a plane of nodes), [`Slice::row`] that plane along y once per row of voxels (a
//! row of nodes), and [`Slice::at`] a voxel along x from two nodes: `2·K` multiply-adds
//! a voxel for `K` numbers a node instead of `8·K`. The sums are the trilinear ones in
//! another order (rounding apart).

/// A voxel's stencil along one axis: the lower and upper node and the upper's weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stencil {
    pub lo: usize,
    pub hi: usize,
    pub t: f64,
}

impl Stencil {
    /// The stencil from lower node `lo` at fraction `t` on an axis of `nodes` nodes: the
    /// upper node is the next, or `lo` itself on the last node (an axis of one node).
    pub fn new(lo: usize, t: f64, nodes: usize) -> Stencil {
        Stencil {
            lo,
            hi: (lo + 1).min(nodes.saturating_sub(1)),
            t,
        }
    }
}

/// The numbers of a grid of nodes, `k` a node (x fastest, then y, then z), with each
/// voxel's stencil per axis.
#[derive(Debug)]
pub struct Separable<'a, T> {
    values: &'a [T],
    k: usize,
    nodes: [usize; 3],
    axes: [Vec<Stencil>; 3],
}

impl<'a, T: Copy + Into<f64>> Separable<'a, T> {
    /// `values` holds `k` numbers for each of `nodes`' nodes; `axes[a][v]` is voxel `v`'s
    /// stencil along axis `a` (every `lo`, `hi` below `nodes[a]`).
    pub fn new(values: &'a [T], k: usize, nodes: [usize; 3], axes: [Vec<Stencil>; 3]) -> Self {
        assert_eq!(values.len(), k * nodes.iter().product::<usize>());
        for a in 0..3 {
            assert!(axes[a].iter().all(|s| s.lo < nodes[a] && s.hi < nodes[a]));
        }
        Separable {
            values,
            k,
            nodes,
            axes,
        }
    }

    /// The node plane interpolated at voxel slice `z`.
    pub fn slice(&self, z: usize) -> Slice<'_, 'a, T> {
        let s = self.axes[2][z];
        let plane_len = self.nodes[0] * self.nodes[1] * self.k;
        let (lo, hi) = (
            &self.values[s.lo * plane_len..],
            &self.values[s.hi * plane_len..],
        );
        let plane = (0..plane_len)
            .map(|i| lerp(lo[i].into(), hi[i].into(), s.t))
            .collect();
        Slice {
            grid: self,
            plane,
            row: vec![0.0; self.nodes[0] * self.k],
        }
    }
}

/// One voxel slice's node plane (module docs), and the row last asked for.
#[derive(Debug)]
pub struct Slice<'g, 'a, T> {
    grid: &'g Separable<'a, T>,
    plane: Vec<f64>,
    row: Vec<f64>,
}

impl<T> Slice<'_, '_, T> {
    /// Interpolates the plane at voxel row `y` (for [`Slice::at`]).
    pub fn row(&mut self, y: usize) {
        let s = self.grid.axes[1][y];
        let len = self.row.len();
        let (lo, hi) = (&self.plane[s.lo * len..], &self.plane[s.hi * len..]);
        for (i, r) in self.row.iter_mut().enumerate() {
            *r = lerp(lo[i], hi[i], s.t);
        }
    }

    /// Voxel `x` of the last [`Slice::row`]'s row: its `k` numbers into `out`.
    pub fn at(&self, x: usize, out: &mut [f64]) {
        let s = self.grid.axes[0][x];
        let k = self.grid.k;
        let (lo, hi) = (&self.row[s.lo * k..], &self.row[s.hi * k..]);
        for (i, o) in out[..k].iter_mut().enumerate() {
            *o = lerp(lo[i], hi[i], s.t);
        }
    }
}

/// `a` to `b` at `t`, as the trilinear weights take it: `(1 − t)·a + t·b`.
#[inline]
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    (1.0 - t) * a + t * b
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the eight-corner sum at every voxel: random-ish node values, stencils with
    /// `t = 0`, `t` near 1, a clamped axis of one node (`lo = hi`).
    #[test]
    fn matches_the_eight_corner_sum() {
        let nodes = [4, 1, 3];
        let k = 5;
        let n: usize = nodes.iter().product();
        let values: Vec<f32> = (0..n * k)
            .map(|i| ((i * 37 % 101) as f32 - 50.0) * 0.1)
            .collect();
        let axis = |len: usize, nodes: usize| -> Vec<Stencil> {
            (0..len)
                .map(|v| {
                    let c = ((v as f64 + 0.5) / 2.0 - 0.5).clamp(0.0, (nodes - 1) as f64);
                    let lo = (c as usize).min(nodes.saturating_sub(2));
                    Stencil::new(lo, c - lo as f64, nodes)
                })
                .collect()
        };
        let axes = [axis(8, 4), axis(3, 1), axis(6, 3)];
        let grid = Separable::new(&values, k, nodes, axes.clone());
        let mut got = vec![0.0; k];
        for z in 0..6 {
            let mut slice = grid.slice(z);
            for y in 0..3 {
                slice.row(y);
                for x in 0..8 {
                    slice.at(x, &mut got);
                    let mut want = vec![0.0; k];
                    for corner in 0..8 {
                        let pick = |a: usize, v: usize| {
                            let s = axes[a][v];
                            if corner >> a & 1 == 1 {
                                (s.hi, s.t)
                            } else {
                                (s.lo, 1.0 - s.t)
                            }
                        };
                        let ((i, wx), (j, wy), (l, wz)) = (pick(0, x), pick(1, y), pick(2, z));
                        let node = i + nodes[0] * (j + nodes[1] * l);
                        for (c, w) in want.iter_mut().enumerate() {
                            *w += wx * wy * wz * f64::from(values[node * k + c]);
                        }
                    }
                    for c in 0..k {
                        assert!(
                            (got[c] - want[c]).abs() <= 1e-12 * (1.0 + want[c].abs()),
                            "voxel ({x}, {y}, {z}) number {c}: {} vs {}",
                            got[c],
                            want[c]
                        );
                    }
                }
            }
        }
    }
}
