//! SH vectors on a regular grid of nodes, trilinear between them: the storage of a
//! spatially varying spherical function `E_lm(x)` computed at a few nodes and looked up
//! anywhere (the transmitted environment of [`crate::render::env_pass`], and of the
//! scenes' smoke in `haze-scene`).
//!
//! Node `(i, j, k)` sits at `min + (i·cell_x, j·cell_y, k·cell_z)`; an axis of one node
//! has cell 0 and is constant. Coefficients are stored node-major (x fastest), then
//! coefficient, then channel: `coeffs[3·(node·n² + j) + c]`.

use super::basis::count;

/// RGB SH vectors of one order at the nodes of a box grid.
#[derive(Clone, Debug, PartialEq)]
pub struct ShGrid {
    /// The first node (the grid's lower corner).
    pub min: [f64; 3],
    /// Distance between nodes per axis (0 on an axis of one node).
    pub cell: [f64; 3],
    /// Nodes per axis (each ≥ 1).
    pub nodes: [usize; 3],
    /// SH order (`order²` coefficients per channel).
    pub order: usize,
    /// The coefficients (module docs), `3·order²` per node.
    pub coeffs: Vec<f32>,
}

impl ShGrid {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.iter().product()
    }

    /// True without nodes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The world position of node `(i, j, k)`.
    pub fn node(&self, i: [usize; 3]) -> [f64; 3] {
        [0, 1, 2].map(|a| self.min[a] + i[a] as f64 * self.cell[a])
    }

    /// The trilinear stencil at `x` (clamped to the grid's box): the lower node per axis
    /// and the fraction towards the next, `0` on an axis of one node.
    pub fn stencil(&self, x: [f64; 3]) -> ([usize; 3], [f64; 3]) {
        let mut i0 = [0usize; 3];
        let mut f = [0.0; 3];
        for a in 0..3 {
            (i0[a], f[a]) = self.axis_stencil(a, x[a]);
        }
        (i0, f)
    }

    /// [`ShGrid::stencil`] along axis `a` at coordinate `x`.
    pub fn axis_stencil(&self, a: usize, x: f64) -> (usize, f64) {
        let n = self.nodes[a];
        if n < 2 || self.cell[a].is_nan() || self.cell[a] <= 0.0 {
            return (0, 0.0);
        }
        let u = ((x - self.min[a]) / self.cell[a]).clamp(0.0, (n - 1) as f64);
        let u = if u.is_nan() { 0.0 } else { u };
        let i0 = (u as usize).min(n - 2);
        (i0, u - i0 as f64)
    }

    /// `E_lm(x)` trilinear between the nodes (clamped to the box), into `out`
    /// (`3·order²` entries, channel fastest; the rest untouched).
    pub fn at(&self, x: [f64; 3], out: &mut [f64]) {
        let k3 = 3 * count(self.order);
        self.at_first(x, &mut out[..k3]);
    }

    /// The first `out.len()` entries of [`ShGrid::at`] (at most `3·order²`: the lowest
    /// bands, channel fastest), the same sums, the others not interpolated.
    pub fn at_first(&self, x: [f64; 3], out: &mut [f64]) {
        let k3 = 3 * count(self.order);
        let n = out.len().min(k3);
        let out = &mut out[..n];
        out.fill(0.0);
        if self.is_empty() {
            return;
        }
        let (i0, f) = self.stencil(x);
        let [nx, ny, _] = self.nodes;
        for corner in 0..8 {
            let d = [corner & 1, (corner >> 1) & 1, corner >> 2];
            let mut w = 1.0;
            let mut idx = [0usize; 3];
            for a in 0..3 {
                if d[a] == 1 && self.nodes[a] < 2 {
                    w = 0.0;
                    break;
                }
                idx[a] = i0[a] + d[a];
                w *= if d[a] == 1 { f[a] } else { 1.0 - f[a] };
            }
            if w == 0.0 {
                continue;
            }
            let node = idx[0] + nx * (idx[1] + ny * idx[2]);
            let src = &self.coeffs[node * k3..(node + 1) * k3];
            for (o, v) in out.iter_mut().zip(src) {
                *o += w * f64::from(*v);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trilinear_functions_are_reproduced_exactly() {
        // One coefficient per channel, E = a + b·x + c·y·z (trilinear) at the nodes.
        let g0 = ShGrid {
            min: [-1.0, 0.5, 2.0],
            cell: [0.5, 0.25, 1.0],
            nodes: [4, 3, 2],
            order: 1,
            coeffs: Vec::new(),
        };
        let f = |p: [f64; 3]| [1.0 + p[0], 2.0 * p[1] * p[2], p[0] * p[1] * p[2]];
        let mut coeffs = Vec::new();
        for k in 0..2 {
            for j in 0..3 {
                for i in 0..4 {
                    coeffs.extend(f(g0.node([i, j, k])).map(|v| v as f32));
                }
            }
        }
        let g = ShGrid { coeffs, ..g0 };
        let mut out = [0.0; 3];
        for p in [
            [-0.8, 0.6, 2.3],
            [0.4, 0.99, 2.9],
            [-1.0, 0.5, 2.0],
            [0.5, 1.0, 3.0],
        ] {
            g.at(p, &mut out);
            let want = f(p);
            for c in 0..3 {
                assert!(
                    (out[c] - want[c]).abs() < 1e-5,
                    "{p:?} {c}: {out:?} {want:?}"
                );
            }
        }
        // Outside the box: clamped to the nearest face.
        g.at([5.0, 0.6, 2.3], &mut out);
        assert!((out[0] - f([0.5, 0.6, 2.3])[0]).abs() < 1e-5);
    }

    #[test]
    fn single_node_axes_are_constant() {
        let g = ShGrid {
            min: [0.0; 3],
            cell: [0.0, 1.0, 0.0],
            nodes: [1, 2, 1],
            order: 1,
            coeffs: vec![1.0, 2.0, 3.0, 3.0, 4.0, 5.0],
        };
        let mut out = [0.0; 3];
        g.at([7.0, 0.5, -3.0], &mut out);
        assert_eq!(out, [2.0, 3.0, 4.0]);
    }
}
