//! Thick voxels in the viewer: the grid each frame is lit on, as `haze render` picks it.
//!
//! Compensated ray marching lights a voxel once, at its center; a voxel of optical depth
//! `τ_v = σt·D₉₉·h` well above 1 comes out too dark
//! ([`haze_view::render::supersample`]). The viewer measures `D₉₉·h` once per frame (the
//! density the asset reconstructs: RBFs plus residual), so `τ_v` follows the σt slider at
//! no cost, and lights the frame on the grid `n` times finer that
//! [`supersample::factor_for`] picks (`--supersample auto`, the default) or that the
//! command line fixed: the RBFs evaluated at the fine centers, the residual resampled by
//! the trilinear field. The panel and `--play-for`'s line say which grid, and warn when
//! its voxels stay too thick.

use haze_render::smoke::Supersample;
use haze_view::render::supersample;
use haze_view::stream::StreamFrame;
use haze_volume::Bbox;
use std::collections::HashMap;

/// The grid one picture was lit on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Refinement per axis (1: the asset's own voxels).
    pub n: usize,
    /// Optical depth across one of the asset's voxels at the picture's σt.
    pub tau: f64,
}

impl Grid {
    /// The lit voxels are thin enough for the renderer ([`supersample::thin_enough`]).
    pub fn thin_enough(&self) -> bool {
        supersample::thin_enough(self.tau / self.n as f64)
    }

    /// "voxels 0.4 optical depths thick" or "voxels 4.0 optical depths thick, lit on a
    /// 4× finer grid (1.0)".
    pub fn describe(&self) -> String {
        let depth = |t: f64| haze_core::number::rounded(t, 1);
        let mut s = format!("voxels {} optical depths thick", depth(self.tau));
        if self.n > 1 {
            s += &format!(
                ", lit on a {}× finer grid ({})",
                self.n,
                depth(self.tau / self.n as f64)
            );
        }
        s
    }

    /// The warning for a picture whose lit voxels are too thick, `None` when they are not.
    pub fn warning(&self) -> Option<String> {
        (!self.thin_enough()).then(|| {
            format!(
                "{}: each voxel is lit at its center, so the smoke comes out too dark (about 12 % at 4 optical depths); a lower σt or a finer grid (--supersample) lights it right",
                self.describe()
            )
        })
    }
}

/// Picks and builds the grid of each frame (module docs); owned by the render thread.
#[derive(Debug)]
pub struct Refiner {
    choice: Supersample,
    /// The most voxels a grid may have on the device.
    budget: usize,
    /// `D₉₉·h` of each frame measured so far, by its index in the asset.
    depth: HashMap<usize, f64>,
    /// The last refined residual: the frame's index, the factor, the fine values.
    refined: Option<(usize, usize, Vec<f32>)>,
}

impl Refiner {
    /// A refiner for `choice` on a device whose grids hold at most `budget` voxels.
    pub fn new(choice: Supersample, budget: usize) -> Refiner {
        Refiner {
            choice,
            budget,
            depth: HashMap::new(),
            refined: None,
        }
    }

    /// Whether `dims` can be refined as `choice` asks on a device of `budget` voxels: an
    /// explicit factor over it is the same one-line error as `haze render`'s.
    pub fn check(choice: Supersample, dims: [usize; 3], budget: usize) -> Result<(), String> {
        match choice {
            Supersample::Times(n) if !supersample::fits(dims, n, budget) => Err(format!(
                "--supersample {n}: the asset's {} × {} × {} voxels refined {n}× exceed the {:.1} M voxels this GPU's grids hold",
                dims[0],
                dims[1],
                dims[2],
                supersample::MAX_FINE_VOXELS.min(budget) as f64 / 1048576.0
            )),
            _ => Ok(()),
        }
    }

    /// The grid `frame` (on a `dims` grid over `bbox`) is lit on at `sigma_t`, and the
    /// residual to light it with: the frame's own (`None`: its hash, as stored) or
    /// resampled to the finer grid. Errors: a damaged frame.
    pub fn prepare(
        &mut self,
        density: &mut FrameDensity<'_>,
        sigma_t: f64,
    ) -> Result<(Grid, Option<&[f32]>), String> {
        let (frame, dims, bbox) = (density.frame, density.dims, density.bbox);
        let depth = match self.depth.get(&frame.index) {
            Some(d) => *d,
            None => {
                let d = supersample::tau_per_voxel(density.get()?, 1.0);
                self.depth.insert(frame.index, d);
                d
            }
        };
        // No smoke is no thickness, whatever σt (0 × ∞ would be NaN).
        let tau = if depth > 0.0 { sigma_t * depth } else { 0.0 };
        let n = match self.choice {
            Supersample::Auto => supersample::factor_for(tau, dims, self.budget).0,
            Supersample::Times(n) => n,
        };
        let grid = Grid { n, tau };
        if n == 1 {
            return Ok((grid, None));
        }
        let fresh = matches!(&self.refined, Some((i, m, _)) if *i == frame.index && *m == n);
        if !fresh {
            // The residual alone: the RBFs are evaluated at the fine centers on the GPU.
            let residual = match &frame.residual {
                Some(slot) => slot.dense(),
                None => vec![0.0; dims.iter().product()],
            };
            let fine = supersample::refine(&residual, dims, &bbox, n);
            self.refined = Some((frame.index, n, fine));
        }
        let fine = self.refined.as_ref().map(|(_, _, v)| v.as_slice());
        Ok((grid, fine))
    }
}

/// The density a frame reconstructs, computed once when first asked for (by the thick
/// voxels' measure or the lamps' share: one evaluation a picture serves both).
pub struct FrameDensity<'a> {
    frame: &'a StreamFrame,
    dims: [usize; 3],
    bbox: Bbox,
    volume: Option<haze_volume::Volume>,
}

impl<'a> FrameDensity<'a> {
    /// `frame` on a `dims` grid over `bbox`, not evaluated yet.
    pub fn new(frame: &'a StreamFrame, dims: [usize; 3], bbox: Bbox) -> FrameDensity<'a> {
        FrameDensity {
            frame,
            dims,
            bbox,
            volume: None,
        }
    }

    /// The frame's index in the asset.
    pub fn index(&self) -> usize {
        self.frame.index
    }

    /// The density was evaluated.
    #[cfg(test)]
    pub fn evaluated(&self) -> bool {
        self.volume.is_some()
    }

    /// The density, evaluated the first time. Errors: a damaged frame.
    pub fn get(&mut self) -> Result<&haze_volume::Volume, String> {
        match &mut self.volume {
            Some(v) => Ok(v),
            slot => Ok(slot.insert(density(self.frame, self.dims, self.bbox)?)),
        }
    }
}

/// The density `frame` reconstructs (RBFs plus residual, negatives clamped).
fn density(
    frame: &StreamFrame,
    dims: [usize; 3],
    bbox: Bbox,
) -> Result<haze_volume::Volume, String> {
    let residual = frame.residual.as_ref().map(|s| (&*s.group, s.slot));
    haze_bake::export::frame_density(dims, bbox, &frame.rbfs, residual)
        .map(|(density, _)| density)
        .map_err(|e| format!("frame {}: {e}", frame.number))
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::Rbf;

    fn frame(weight: f64) -> StreamFrame {
        StreamFrame {
            index: 0,
            number: 7,
            rbfs: vec![Rbf {
                center: [0.5, 0.5, 0.5],
                radius: 0.25,
                weight,
            }],
            residual: None,
        }
    }

    fn unit() -> Bbox {
        Bbox::new([0.0; 3], [1.0; 3])
    }

    /// The optical depth per voxel is σt × the 99th percentile of the density × the
    /// voxel's side, measured once and scaled by σt; the factor is the smallest that
    /// brings a voxel to one optical depth, and the fine residual has its voxels.
    #[test]
    fn the_grid_follows_sigma_t_and_the_density() {
        let dims = [8, 8, 8];
        let f = frame(2.0);
        let d99 = supersample::tau_per_voxel(&density(&f, dims, unit()).unwrap(), 1.0);
        assert!(d99 > 0.0 && d99 < 2.0 / 8.0 + 1e-9, "{d99}");
        let mut r = Refiner::new(Supersample::Auto, usize::MAX);
        let (thin, fine) = r
            .prepare(&mut FrameDensity::new(&f, dims, unit()), 0.5 / d99)
            .unwrap();
        assert_eq!(thin.n, 1);
        assert!((thin.tau - 0.5).abs() < 1e-12);
        assert!(fine.is_none() && thin.thin_enough() && thin.warning().is_none());
        let (thick, fine) = r
            .prepare(&mut FrameDensity::new(&f, dims, unit()), 2.5 / d99)
            .unwrap();
        assert_eq!(thick.n, 3, "τ 2.5 needs 3× to reach 1.1");
        assert_eq!(fine.unwrap().len(), 24 * 24 * 24);
        assert!(thick.thin_enough());
        assert!(thick.describe().contains("3× finer grid (0.8)"));
    }

    /// A fixed factor is kept, and a voxel left too thick is warned about; a factor the
    /// device cannot hold is refused before anything renders.
    #[test]
    fn a_fixed_factor_is_kept_and_warned_about() {
        let dims = [8, 8, 8];
        let mut r = Refiner::new(Supersample::Times(1), usize::MAX);
        let (g, fine) = r
            .prepare(&mut FrameDensity::new(&frame(2.0), dims, unit()), 1e3)
            .unwrap();
        assert_eq!(g.n, 1);
        assert!(fine.is_none());
        assert!(g.warning().unwrap().contains("too dark"));
        assert!(Refiner::check(Supersample::Times(4), dims, 4096).is_err());
        assert!(Refiner::check(Supersample::Times(2), dims, 4096).is_ok());
        assert!(Refiner::check(Supersample::Auto, dims, 1).is_ok());
    }

    /// Extremes: no smoke, σt 0 and an infinite σt give finite choices.
    #[test]
    fn extremes_stay_finite() {
        let dims = [4, 4, 4];
        let mut r = Refiner::new(Supersample::Auto, usize::MAX);
        let (g, _) = r
            .prepare(&mut FrameDensity::new(&frame(0.0), dims, unit()), 4.0)
            .unwrap();
        assert_eq!((g.n, g.tau), (1, 0.0));
        let mut r = Refiner::new(Supersample::Auto, usize::MAX);
        let (g, _) = r
            .prepare(&mut FrameDensity::new(&frame(1.0), dims, unit()), 0.0)
            .unwrap();
        assert_eq!(g.n, 1);
        let (g, fine) = r
            .prepare(
                &mut FrameDensity::new(&frame(1.0), dims, unit()),
                f64::INFINITY,
            )
            .unwrap();
        assert_eq!(g.n, supersample::MAX_FACTOR);
        assert!(!g.thin_enough() && fine.is_some());
    }
}
