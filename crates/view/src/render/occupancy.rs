//! Which blocks of a density grid hold density, so that the marches of the lighting pass
//! over the empty ones: the CPU twin of `shaders/occupancy.wgsl`.
//!
//! A block is [`BLOCK`]³ voxels; it is marked when a voxel with `D > 0` lies within one
//! voxel of it. The trilinear density at a point ([`crate::field::sample`]) reads the
//! voxels within one of the voxel that holds the point, so where that voxel's block is
//! not marked the sample is exactly zero and a march may skip it: the same steps at the
//! same points, the same sum, fewer samples taken. The occupied box (the voxels with
//! `D > 0` grown by one voxel) bounds the marches as before. Which of the box's faces
//! hold density on their outermost voxels is kept too (for
//! [`super::ray_planes::RayPlanes`], whose rays may cross such a face outside the box).

use haze_volume::{Bbox, Volume};
use rayon::prelude::*;

/// Voxels per block side.
pub const BLOCK: usize = 4;

/// The marked blocks of a density grid and its occupied box (module docs).
#[derive(Clone, Debug)]
pub struct Occupancy {
    bbox: Bbox,
    min: [f64; 3],
    /// `1/voxel` per axis, as [`crate::field::Sampler`] has it.
    inv_voxel: [f64; 3],
    dims: [usize; 3],
    blocks: [usize; 3],
    marked: Vec<bool>,
    /// Per axis, whether a voxel with `D > 0` lies on the low and the high face.
    smoky_faces: [[bool; 2]; 3],
}

impl Occupancy {
    /// The occupancy of `density`; `None` when no voxel has `D > 0`.
    pub fn new(density: &Volume) -> Option<Occupancy> {
        let cells = density.occupied_bbox(0.0)?;
        let bbox = super::lights_pass::grown_by_half_a_voxel(density, &cells);
        let dims = density.dims();
        let blocks = dims.map(|n| n.div_ceil(BLOCK));
        let (plane, layer) = (dims[0] * dims[1], blocks[0] * blocks[1]);
        let data = density.data();
        let mut marked = vec![false; blocks.iter().product()];
        // One layer of blocks at a time, in parallel: a block is marked by the voxels with
        // `D > 0` within one voxel of it, those of the layer's voxel planes and the plane on
        // either side.
        marked
            .par_chunks_mut(layer)
            .enumerate()
            .for_each(|(bz, out)| {
                let z0 = (bz * BLOCK).saturating_sub(1);
                let z1 = ((bz + 1) * BLOCK).min(dims[2] - 1);
                for (r, row) in data[z0 * plane..(z1 + 1) * plane]
                    .chunks_exact(dims[0])
                    .enumerate()
                {
                    let y = r % dims[1];
                    let (y0, y1) = (
                        y.saturating_sub(1) / BLOCK,
                        (y + 1).min(dims[1] - 1) / BLOCK,
                    );
                    for (x, &d) in row.iter().enumerate() {
                        // `D > 0` only (NaN and non-positive voxels are not density).
                        if d.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                            continue;
                        }
                        let (x0, x1) = (
                            x.saturating_sub(1) / BLOCK,
                            (x + 1).min(dims[0] - 1) / BLOCK,
                        );
                        for by in y0..=y1 {
                            out[x0 + blocks[0] * by..=x1 + blocks[0] * by].fill(true);
                        }
                    }
                }
            });
        Some(Occupancy {
            bbox,
            min: density.bbox().min,
            inv_voxel: density.voxel_size().map(|s| 1.0 / s),
            dims,
            blocks,
            marked,
            smoky_faces: smoky_faces(density, &cells),
        })
    }

    /// Whether a voxel with `D > 0` lies on the box's `high` (else low) face across
    /// axis `ax` (its outermost layer of voxels).
    pub fn smoky_face(&self, ax: usize, high: bool) -> bool {
        self.smoky_faces[ax][usize::from(high)]
    }

    /// The occupied box: outside it the trilinear density is zero.
    pub fn bbox(&self) -> &Bbox {
        &self.bbox
    }

    /// Whether the trilinear density at `p` may be non-zero; `false` only where it is
    /// exactly zero (module docs).
    pub fn may_hold(&self, p: [f64; 3]) -> bool {
        self.may_hold_coords(std::array::from_fn(|a| {
            (p[a] - self.min[a]) * self.inv_voxel[a]
        }))
    }

    /// [`Occupancy::may_hold`] at voxel coordinates `q = (p − min)·(1/voxel)` (as
    /// [`crate::field::Sampler::coords`] gives them).
    #[inline]
    pub fn may_hold_coords(&self, q: [f64; 3]) -> bool {
        // The voxel that holds q per axis (a negative or NaN coordinate casts to 0).
        self.may_hold_voxel(std::array::from_fn(|a| {
            (q[a] as usize).min(self.dims[a] - 1)
        }))
    }

    /// [`Occupancy::may_hold_coords`] at a point held by voxel `k` (each index below the
    /// grid's dimension on its axis).
    #[inline]
    pub fn may_hold_voxel(&self, k: [usize; 3]) -> bool {
        let block = k.map(|v| v / BLOCK);
        self.marked[block[0] + self.blocks[0] * (block[1] + self.blocks[1] * block[2])]
    }
}

/// Per axis, whether the voxels with `D > 0`, whose cells span `cells`, reach the low and
/// the high face of `density`'s box: their first (last) voxel is the box's, so the span's
/// end lies within half a voxel of the face (it is `min + i·voxel` for a whole `i`).
fn smoky_faces(density: &Volume, cells: &Bbox) -> [[bool; 2]; 3] {
    let (outer, vs) = (density.bbox(), density.voxel_size());
    std::array::from_fn(|a| {
        [
            cells.min[a] < outer.min[a] + 0.5 * vs[a],
            cells.max[a] > outer.max[a] - 0.5 * vs[a],
        ]
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field;
    use crate::render::lights_pass::{optical_depth, optical_depth_within};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    /// A sparse grid: a few lumps in a 23 × 17 × 30 box, zero elsewhere.
    fn lumps() -> Volume {
        let dims = [23, 17, 30];
        let mut v = Volume::zeros(dims, Bbox::new([-1.0, 0.5, 0.0], [1.3, 2.2, 3.0])).unwrap();
        for (c, r) in [
            ([4.0, 5.0, 6.0], 2.5),
            ([18.0, 12.0, 22.0], 3.0),
            ([0.0, 0.0, 29.0], 1.5),
        ] {
            for z in 0..dims[2] {
                for y in 0..dims[1] {
                    for x in 0..dims[0] {
                        let d2 = [x, y, z]
                            .iter()
                            .zip(c)
                            .map(|(&k, c)| (k as f64 - c).powi(2))
                            .sum::<f64>();
                        if d2 < r * r {
                            let i = v.index(x, y, z);
                            v.data_mut()[i] = (1.0 + 0.1 * (x + y) as f64 - d2 / (r * r)) as f32;
                        }
                    }
                }
            }
        }
        v
    }

    /// The blocks marked per voxel with `D > 0`: those of the voxels within one of it.
    fn marked_by_voxel(v: &Volume) -> Vec<bool> {
        let dims = v.dims();
        let blocks = dims.map(|n| n.div_ceil(BLOCK));
        let mut marked = vec![false; blocks.iter().product()];
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let d = v.data()[v.index(x, y, z)];
                    if d.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                        continue;
                    }
                    let k = [x, y, z];
                    let lo = k.map(|v| v.saturating_sub(1) / BLOCK);
                    let hi: [usize; 3] =
                        std::array::from_fn(|a| (k[a] + 1).min(dims[a] - 1) / BLOCK);
                    for bz in lo[2]..=hi[2] {
                        for by in lo[1]..=hi[1] {
                            for bx in lo[0]..=hi[0] {
                                marked[bx + blocks[0] * (by + blocks[1] * bz)] = true;
                            }
                        }
                    }
                }
            }
        }
        marked
    }

    /// The layers of blocks marked in parallel mark the blocks of the definition, voxel by
    /// voxel: on the lumps, on grids whose sides are and are not multiples of a block, on
    /// flat grids, and with density on every face and corner.
    #[test]
    fn the_blocks_marked_are_the_definitions() {
        let v = lumps();
        assert_eq!(Occupancy::new(&v).unwrap().marked, marked_by_voxel(&v));
        let mut rng = Pcg64::seed_from_u64(11);
        for dims in [
            [8, 8, 8],
            [9, 5, 13],
            [1, 7, 6],
            [5, 1, 1],
            [4, 4, 1],
            [1, 1, 1],
        ] {
            for every in [1.0, 0.1, 0.01] {
                let mut v = Volume::zeros(dims, Bbox::new([0.0; 3], [1.0; 3])).unwrap();
                for d in v.data_mut() {
                    if rng.random::<f64>() < every {
                        *d = rng.random::<f32>() + 0.01;
                    }
                }
                let last = v.data().len() - 1;
                v.data_mut()[last] = 1.0;
                let occ = Occupancy::new(&v).unwrap();
                assert_eq!(occ.marked, marked_by_voxel(&v), "{dims:?} {every}");
            }
        }
    }

    /// The faces told smoky are those with a voxel `D > 0` on their outermost layer,
    /// voxel by voxel: single voxels on, next to and away from every face of boxes whose
    /// corners and sizes do not round evenly, grids one voxel thick, and the lumps.
    #[test]
    fn the_smoky_faces_are_those_with_density_on_them() {
        let by_voxel = |v: &Volume, ax: usize, high: bool| {
            let d = v.dims();
            let layer = if high { d[ax] - 1 } else { 0 };
            (0..d[2]).any(|z| {
                (0..d[1]).any(|y| {
                    (0..d[0]).any(|x| [x, y, z][ax] == layer && v.data()[v.index(x, y, z)] > 0.0)
                })
            })
        };
        let check = |v: &Volume, what: &str| {
            let occ = Occupancy::new(v).unwrap();
            for ax in 0..3 {
                for high in [false, true] {
                    assert_eq!(
                        occ.smoky_face(ax, high),
                        by_voxel(v, ax, high),
                        "{what} {ax} {high}"
                    );
                }
            }
        };
        check(&lumps(), "lumps");
        let mut rng = Pcg64::seed_from_u64(5);
        for dims in [[7, 9, 11], [1, 6, 5], [3, 1, 1], [13, 2, 4]] {
            let bbox = Bbox::new([-0.37, 1.1, 1e3], [0.71, 1.93, 1e3 + 0.3]);
            for _ in 0..40 {
                let mut v = Volume::zeros(dims, bbox).unwrap();
                let k = dims.map(|n| rng.random_range(0..n));
                let i = v.index(k[0], k[1], k[2]);
                v.data_mut()[i] = 0.5;
                check(&v, &format!("{dims:?} {k:?}"));
            }
        }
    }

    #[test]
    fn an_unmarked_block_holds_exact_zeros() {
        let v = lumps();
        let occ = Occupancy::new(&v).unwrap();
        let (b, mut skipped) = (v.bbox(), 0);
        let mut rng = Pcg64::seed_from_u64(3);
        for _ in 0..20_000 {
            let p: [f64; 3] = std::array::from_fn(|a| {
                b.min[a] + (1.2 * rng.random::<f64>() - 0.1) * (b.max[a] - b.min[a])
            });
            if !occ.may_hold(p) {
                skipped += 1;
                assert_eq!(field::sample(&v, p), 0.0, "{p:?}");
            }
        }
        // Most of this box is empty: the test sees many skipped points.
        assert!(skipped > 5_000, "{skipped}");
        let empty = Volume::zeros([4, 4, 4], Bbox::new([0.0; 3], [1.0; 3])).unwrap();
        assert!(Occupancy::new(&empty).is_none());
    }

    #[test]
    fn marches_that_skip_empty_blocks_sum_the_same() {
        let v = lumps();
        let occ = Occupancy::new(&v).unwrap();
        let h0 = v.voxel_size().into_iter().fold(f64::INFINITY, f64::min);
        let b = *v.bbox();
        let mut nonzero = 0;
        let mut rng = Pcg64::seed_from_u64(7);
        for _ in 0..2_000 {
            let u: [f64; 3] =
                std::array::from_fn(|a| b.min[a] + rng.random::<f64>() * (b.max[a] - b.min[a]));
            let z = 2.0 * rng.random::<f64>() - 1.0;
            let phi = std::f64::consts::TAU * rng.random::<f64>();
            let r = (1.0 - z * z).sqrt();
            let s = [r * phi.cos(), r * phi.sin(), z];
            for max_len in [f64::MAX, 0.7] {
                let all = optical_depth(&v, 3.0, u, s, max_len, h0);
                let skipping = optical_depth_within(&v, 3.0, u, s, max_len, h0, &occ);
                assert_eq!(all, skipping, "from {u:?} along {s:?}");
                nonzero += usize::from(all > 0.0);
            }
        }
        assert!(nonzero > 200, "{nonzero}");
    }
}
