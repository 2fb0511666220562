//! The coarse grid of the diffusion: the volume pass's density `D = D̃ + R` averaged over
//! blocks of `f × f × f` voxels.

use haze_volume::Volume;

/// A block-averaged copy of a density grid. Cell `c` covers the fine voxels
/// `[f·c, min(f·c + f, n))` per axis; its density is their mean, its size `h = f·voxel`.
#[derive(Clone, Debug)]
pub struct CoarseGrid {
    pub dims: [usize; 3],
    /// Blocking factor `f ≥ 1`.
    pub factor: usize,
    /// Cell sides (world units).
    pub h: [f64; 3],
    /// World position of cell `[0, 0, 0]`'s low corner.
    pub origin: [f64; 3],
    /// Mean density per cell, x fastest.
    pub density: Vec<f64>,
}

impl CoarseGrid {
    /// Averages `fine` over blocks of `factor³` voxels (`factor` is clamped to ≥ 1).
    /// Negative or non-finite densities count as 0.
    pub fn new(fine: &Volume, factor: usize) -> CoarseGrid {
        let f = factor.max(1);
        let n = fine.dims();
        let dims = n.map(|a| a.div_ceil(f));
        let vs = fine.voxel_size();
        let mut sum = vec![0.0f64; dims.iter().product()];
        let mut count = vec![0u32; sum.len()];
        for z in 0..n[2] {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    let c = x / f + dims[0] * (y / f + dims[1] * (z / f));
                    let d = f64::from(fine.get(x, y, z));
                    if d.is_finite() && d > 0.0 {
                        sum[c] += d;
                    }
                    count[c] += 1;
                }
            }
        }
        let density = sum
            .iter()
            .zip(&count)
            .map(|(s, &k)| if k > 0 { s / f64::from(k) } else { 0.0 })
            .collect();
        CoarseGrid {
            dims,
            factor: f,
            h: vs.map(|v| v * f as f64),
            origin: fine.bbox().min,
            density,
        }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.density.len()
    }

    /// No cells.
    pub fn is_empty(&self) -> bool {
        self.density.is_empty()
    }

    /// Linear index of cell `[x, y, z]`.
    pub fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// The cells with smoke (`D > 0`): how many, and the lowest and highest cell
    /// coordinates among them (`None` without smoke).
    pub fn smoke_cells(&self) -> Option<(usize, [usize; 3], [usize; 3])> {
        let (mut lo, mut hi, mut cells) = ([usize::MAX; 3], [0usize; 3], 0usize);
        for (i, &d) in self.density.iter().enumerate() {
            if d > 0.0 {
                cells += 1;
                let c = self.coords(i);
                for a in 0..3 {
                    lo[a] = lo[a].min(c[a]);
                    hi[a] = hi[a].max(c[a]);
                }
            }
        }
        (cells > 0).then_some((cells, lo, hi))
    }

    /// Cell coordinates of linear index `i`.
    pub fn coords(&self, i: usize) -> [usize; 3] {
        let (x, r) = (i % self.dims[0], i / self.dims[0]);
        [x, r % self.dims[1], r / self.dims[1]]
    }

    /// World position of the center of cell `c`.
    pub fn center(&self, c: [usize; 3]) -> [f64; 3] {
        [0, 1, 2].map(|a| self.origin[a] + (c[a] as f64 + 0.5) * self.h[a])
    }

    /// Cell volume.
    pub fn volume(&self) -> f64 {
        self.h[0] * self.h[1] * self.h[2]
    }

    /// The eight cells around world point `p` and their trilinear weights between cell
    /// centers (the outer half cells take their own value), or `None` outside the box.
    pub fn corners(&self, p: [f64; 3]) -> Option<[(usize, f64); 8]> {
        self.corners_at([0, 1, 2].map(|a| (p[a] - self.origin[a]) / self.h[a] - 0.5))
    }

    /// [`CoarseGrid::corners`] of the point at cell coordinates `c` (cell `k`'s center at
    /// `c = k`, the box from `−½` to `dims − ½`): a march steps these from its start
    /// instead of dividing each point's world position.
    pub fn corners_at(&self, c: [f64; 3]) -> Option<[(usize, f64); 8]> {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        let mut t = [0.0f64; 3];
        for a in 0..3 {
            if !(c[a] >= -0.5 && c[a] <= self.dims[a] as f64 - 0.5) {
                return None;
            }
            let c = c[a].clamp(0.0, (self.dims[a] - 1) as f64);
            lo[a] = (c as usize).min(self.dims[a].saturating_sub(2));
            hi[a] = (lo[a] + 1).min(self.dims[a] - 1);
            t[a] = c - lo[a] as f64;
        }
        let (sx, sy) = (self.dims[0], self.dims[0] * self.dims[1]);
        let x = [(lo[0], 1.0 - t[0]), (hi[0], t[0])];
        let y = [(lo[1] * sx, 1.0 - t[1]), (hi[1] * sx, t[1])];
        let z = [(lo[2] * sy, 1.0 - t[2]), (hi[2] * sy, t[2])];
        Some(std::array::from_fn(|corner| {
            let (i, wx) = x[corner & 1];
            let (j, wy) = y[corner >> 1 & 1];
            let (k, wz) = z[corner >> 2 & 1];
            (i + j + k, wx * wy * wz)
        }))
    }

    /// The distance from `x` inside the box along `d` to the box's face (∞ for `d = 0`).
    pub fn exit_distance(&self, x: [f64; 3], d: [f64; 3]) -> f64 {
        let mut len = f64::INFINITY;
        for a in 0..3 {
            let size = self.h[a] * self.dims[a] as f64;
            if d[a] > 0.0 {
                len = len.min((self.origin[a] + size - x[a]) / d[a]);
            } else if d[a] < 0.0 {
                len = len.min((self.origin[a] - x[a]) / d[a]);
            }
        }
        len
    }
}
