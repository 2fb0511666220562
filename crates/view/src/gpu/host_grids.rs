//! A frame's grids of light computed on the CPU and uploaded, for an adapter that is
//! itself a CPU (lavapipe). There the `f64` twins on every core are several times faster
//! than the shaders emulated on the same cores (on a 104 × 104 × 130 frame, 4.2 s of CPU
//! lighting against 19 s of environment grid, orders and volume pass on lavapipe,
//! `BENCHMARKS.md` "Viewer playback"), so everything but the view pass runs on the CPU:
//! [`FrameLight`] (the same code as [`crate::render::crm_grids`], so the grids are the CPU
//! renderer's), then [`GridBuffer::upload`] — or, for a view pass on the CPU too
//! ([`HostGrids::volume_grids`], the viewer's on a CPU adapter), kept on the host.
//!
//! **Reuse**, as on the GPU path: the frame's light ([`FrameLight`]: the sources at the
//! centers, the environment pass's grid, the multiple scattering's cells) is kept while
//! the frame, the lighting, the medium and the knobs hold, so a camera move rebuilds only
//! the grids seen from the new eye ([`FrameLight::grids`]); with `g = 0` the grids do not
//! depend on the eye and are kept too. The environment pass's grid is kept while the
//! density, σt, the distant environment, the order and its options hold, so a new
//! albedo, `g` or light reuses it. The centers' diffusion starts from the previous
//! frame's solution.

use super::GridBuffer;
use super::diffusion::DiffusionStats;
use super::renderer::{EnvGridKey, FrameStats, GpuFrame, Reuse, SourceKey};
use super::volume_pass::Residual;
use crate::diffusion::DiffusionSolver;
use crate::lighting::single::{RgbSh, ShKit};
use crate::render::crm::VolumeGrids;
use crate::render::frame_light::{FrameInput, FrameLight, Kept};
use crate::render::{CrmOptions, CrmStats, MsDiffusion};
use crate::sh::{self, ShGrid};
use crate::{Camera, Environment, Medium};
use haze_gpu::{GpuContext, GpuError};
use std::sync::Arc;
use std::time::Instant;

/// A frame's grids of light: their key, the eye they were seen from (`None`: any eye),
/// the grids, and their upload once asked for.
type SeenGrids = (SourceKey, Option<[f64; 3]>, VolumeGrids, Option<GridBuffer>);

/// The CPU's grids of light and what carries from one frame to the next (module docs).
#[derive(Debug, Default)]
pub struct HostGrids {
    /// The centers' diffusion's warm start.
    solver: DiffusionSolver,
    /// The light of the frame with this key and the frame's residual per voxel.
    light: Option<(SourceKey, FrameLight, Option<Vec<f32>>)>,
    /// The grids of that light seen from this eye (`None`: any eye, `g = 0`), and once
    /// asked for, their upload.
    grids: Option<SeenGrids>,
    /// How the last multiple-scattering solve ended.
    last_solve: Option<DiffusionStats>,
    /// The SH tables of an order, and the environment of a distant generation projected
    /// at it.
    sh: Option<(usize, u64, ShKit, RgbSh)>,
    /// The environment pass's grid, kept while its key holds (a new albedo, `g` or light
    /// computes the frame's light again on it).
    env_grid: Option<(EnvGridKey, Arc<ShGrid>)>,
    /// How many environment grids were computed.
    env_grid_builds: u64,
}

impl HostGrids {
    /// Forgets the previous frame: no reuse and no warm start for the next one.
    pub fn reset(&mut self) {
        self.solver.reset();
        self.light = None;
        self.grids = None;
        self.env_grid = None;
    }

    /// How the last multiple-scattering solve ended; `None` before the first.
    pub fn last_solve(&self) -> Option<DiffusionStats> {
        self.last_solve
    }

    /// How many environment-pass grids were computed on the CPU.
    pub fn env_grid_builds(&self) -> u64 {
        self.env_grid_builds
    }

    /// The grids of `frame` lit by `env` (whose generation is `lighting`, and its distant
    /// part's `distant`) seen from `camera`, uploaded, reusing what the last call computed
    /// where it still holds; the time of each stage run and what was reused go to `stats`.
    #[allow(clippy::too_many_arguments)]
    pub fn grids(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        env: &Environment,
        generations: (u64, u64),
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
        stats: &mut FrameStats,
    ) -> Result<&GridBuffer, GpuError> {
        // A grid the device cannot hold is refused before its light is computed.
        ctx.check_storage_size(
            "the volume (density and radiance)",
            GridBuffer::bytes(frame.dims),
        )?;
        self.light(frame, env, generations, medium, camera, opts, stats);
        let (_, _, grids, buffer) = self.grids.as_mut().expect("lit above");
        match buffer {
            Some(b) => Ok(b),
            None => Ok(buffer.insert(GridBuffer::upload(ctx, grids)?)),
        }
    }

    /// [`HostGrids::grids`] left on the host, for a view pass on the CPU
    /// ([`crate::render::crm::view_pass`]).
    #[allow(clippy::too_many_arguments)]
    pub fn volume_grids(
        &mut self,
        frame: &GpuFrame<'_>,
        env: &Environment,
        generations: (u64, u64),
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
        stats: &mut FrameStats,
    ) -> &VolumeGrids {
        self.light(frame, env, generations, medium, camera, opts, stats);
        &self.grids.as_ref().expect("lit above").2
    }

    /// Makes `self.grids` the grids of `frame` ([`HostGrids::grids`]), not uploaded.
    #[allow(clippy::too_many_arguments)]
    fn light(
        &mut self,
        frame: &GpuFrame<'_>,
        env: &Environment,
        (lighting, distant): (u64, u64),
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
        stats: &mut FrameStats,
    ) {
        let key = SourceKey {
            frame: frame.key,
            lighting,
            medium: *medium,
            opts: CrmOptions {
                slices_per_voxel: 0.0,
                pixel_reuse: 0.0,
                ..*opts
            },
        };
        // The eye matters unless the phase function is isotropic (as on the GPU path).
        let eye = (medium.g != 0.0).then_some(camera.eye);
        if matches!(&self.grids, Some((k, e, _, _)) if *k == key && *e == eye) {
            stats.reuse = Reuse::Grids;
            return;
        }
        self.grids = None;
        let kept = matches!(&self.light, Some((k, _, _)) if *k == key);
        let grids = match &self.light {
            Some((_, light, residual)) if kept => {
                let input = input(frame, residual.as_deref());
                let (grids, crm) = light.grids(&input, medium, env, camera.eye, opts);
                stats.crm = crm;
                stats.reuse = Reuse::Sources;
                grids
            }
            _ => {
                self.light = None;
                let residual = match frame.residual {
                    Some(Residual::Dense(r)) => Some(r.to_vec()),
                    Some(Residual::Hash(slot)) => Some(slot.dense()),
                    None => None,
                };
                let input = input(frame, residual.as_deref());
                let t = Instant::now();
                let (_, _, kit, projected) = match self.sh.take() {
                    Some(s) if (s.0, s.1) == (opts.order, distant) => self.sh.insert(s),
                    _ => self.sh.insert((
                        opts.order,
                        distant,
                        ShKit::new(opts.order),
                        sh::project_env(env, opts.order),
                    )),
                };
                let setup_seconds = t.elapsed().as_secs_f64();
                let grid_key = opts.env_grid().map(|grid| EnvGridKey {
                    frame: frame.key,
                    residual: opts.residual,
                    sigma_t: medium.sigma_t,
                    distant,
                    order: opts.order,
                    grid,
                });
                let kept_grid = match (&self.env_grid, grid_key) {
                    (Some((k, g)), Some(key)) if *k == key => Some(g.clone()),
                    _ => None,
                };
                let kept = Kept {
                    kit,
                    projected,
                    env_grid: kept_grid.clone(),
                };
                let (light, grids, crm) = FrameLight::new(
                    &input,
                    medium,
                    env,
                    camera.eye,
                    opts,
                    kept,
                    &mut self.solver,
                );
                if let (None, Some(key), Some(grid)) = (kept_grid, grid_key, light.env_grid()) {
                    self.env_grid = Some((key, grid.clone()));
                    self.env_grid_builds += 1;
                }
                let crm = CrmStats {
                    setup_seconds,
                    ..crm
                };
                if opts.multiple && !frame.rbfs.is_empty() {
                    stats.solved = true;
                    let tolerance = match opts.diffusion {
                        MsDiffusion::Centers => opts.solve.tolerance,
                        _ => opts.grid_solve.tolerance,
                    };
                    self.last_solve = Some(DiffusionStats {
                        iterations: crm.cg_iterations,
                        residual: crm.cg_residual,
                        converged: crm.cg_residual <= tolerance,
                    });
                }
                stats.crm = crm;
                stats.reuse = Reuse::Nothing;
                self.light = Some((key, light, residual));
                grids
            }
        };
        self.grids = Some((key, eye, grids, None));
    }
}

fn input<'b>(frame: &'b GpuFrame<'_>, residual: Option<&'b [f32]>) -> FrameInput<'b> {
    FrameInput {
        rbfs: frame.rbfs,
        residual,
        dims: frame.dims,
        bbox: &frame.bbox,
    }
}
