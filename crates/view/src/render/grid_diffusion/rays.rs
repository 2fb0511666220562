//! The later orders' rays kept from one gather to the next.
//!
//! The orders after the first gather along the same directions through the same grid (and
//! at a low lighting detail the first too, `super::first_theta`): only the records they
//! sum change (the last order's scattered light), not the rays.
//! Each ray's march ([`super::gather()`]) adds `share·w · record(cell)` for every corner
//! `cell` of every step, `share = T (1 − e^{−Δτ}) / D` and `w` the corner's trilinear
//! weight — both fixed by the density alone — and ends with the transmittance left. The
//! first gather along the rule keeps, per cell with smoke, each ray's corners and `share·w` in
//! the march's order and its final transmittance ([`CellRays`]); the next gathers sum
//! the new records over them in the same order, so they give the same sums to the bit
//! without a corner's coordinates or an exponential. A cell whose rays would take the
//! store past [`RAY_CACHE_BYTES`] is not kept and marches every order.

use std::sync::atomic::{AtomicUsize, Ordering};

/// The most bytes the kept rays of one grid take (12 a corner of a step, 12 a ray): at
/// 5³-voxel cells on a 96 × 96 × 128-class plume about a fifth of it.
pub const RAY_CACHE_BYTES: usize = 64 << 20;

/// The rays of one gather through a grid along one rule, per cell, for the later
/// gathers through the same grid and rule ([`super::gather::gather_kept`]).
#[derive(Debug)]
pub struct RayCache {
    /// Per cell its rays (`None`: not kept, marched again); empty until the first gather.
    pub(super) cells: Vec<Option<CellRays>>,
    /// The most bytes the kept rays may take.
    pub(super) budget: usize,
}

impl Default for RayCache {
    /// An empty store of [`RAY_CACHE_BYTES`].
    fn default() -> Self {
        RayCache::within(RAY_CACHE_BYTES)
    }
}

impl RayCache {
    /// An empty store that keeps at most `budget` bytes of rays.
    pub fn within(budget: usize) -> Self {
        RayCache {
            cells: Vec::new(),
            budget,
        }
    }

    /// Bytes the kept rays take.
    pub fn bytes(&self) -> usize {
        self.cells.iter().flatten().map(CellRays::bytes).sum()
    }

    /// Cells whose rays are kept.
    pub fn kept(&self) -> usize {
        self.cells.iter().flatten().count()
    }
}

/// One cell's rays, ray after ray in the rule's order: each step's corners (their cell
/// and `share·w`) in the march's order, where each ray ends, and its transmittance left.
#[derive(Debug, Default)]
pub struct CellRays {
    corners: Vec<u32>,
    weights: Vec<f64>,
    ends: Vec<u32>,
    escape: Vec<f64>,
}

impl CellRays {
    /// Adds a step's corner `cell` of weight `sw` to the ray being marched; `false` where
    /// the index or the count does not fit the store (the cell is then not kept).
    pub(super) fn push(&mut self, cell: usize, sw: f64) -> bool {
        match u32::try_from(cell) {
            Ok(c) if self.corners.len() < u32::MAX as usize => {
                self.corners.push(c);
                self.weights.push(sw);
                true
            }
            _ => false,
        }
    }

    /// Ends the ray being marched with transmittance `t` left.
    pub(super) fn end_ray(&mut self, t: f64) {
        self.ends.push(self.corners.len() as u32);
        self.escape.push(t);
    }

    /// Bytes the rays take.
    pub(super) fn bytes(&self) -> usize {
        12 * (self.corners.len() + self.ends.len())
    }

    /// Ray `d`'s sum of the records `rec` (`stride` values a cell: the density, then
    /// what the rays carry) into `acc` (zeroed first; `acc[0]` stays 0), in the march's
    /// order; returns its transmittance left.
    pub(super) fn replay(&self, d: usize, rec: &[f64], stride: usize, acc: &mut [f64]) -> f64 {
        acc.fill(0.0);
        let start = if d == 0 { 0 } else { self.ends[d - 1] as usize };
        let end = self.ends[d] as usize;
        for (&cell, &sw) in self.corners[start..end]
            .iter()
            .zip(&self.weights[start..end])
        {
            let at = cell as usize * stride;
            for (a, v) in acc[1..].iter_mut().zip(&rec[at + 1..at + stride]) {
                *a += sw * v;
            }
        }
        self.escape[d]
    }

    /// `self` where `left` (bytes) still holds it, taken from `left`; else `None`.
    pub(super) fn within(self, left: &AtomicUsize) -> Option<CellRays> {
        let b = self.bytes();
        left.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |l| l.checked_sub(b))
            .is_ok()
            .then_some(self)
    }
}
