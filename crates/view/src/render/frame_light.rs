//! The light of one frame, split by what a camera move changes. [`FrameLight::new`]
//! computes what does not depend on the camera — the source radiance at the centers
//! ([`super::source_radiance`]), the environment pass's grid ([`env_pass::env_grid`]), the
//! lights' shadows ([`LightShadows`]) and the multiple scattering's cells
//! ([`grid_diffusion`]) — and returns the volume grids seen
//! from its eye; [`FrameLight::grids`] rebuilds them for another eye from what was kept:
//! the volume pass, then the environment's, the lights' and the multiple scattering's
//! light towards the eye, added in that order. The two together are [`super::crm_grids`].

use super::crm::{self, VolumeGrids};
use super::env_pass;
use super::grid_diffusion::{self, MediaRadiance};
use super::lights_pass::LightShadows;
use super::{CrmOptions, CrmStats, MsDiffusion, centers_single, source_radiance};
use crate::diffusion::{DiffusionSolver, Sources};
use crate::lighting::single::{RgbSh, ShKit, moments};
use crate::sh::ShGrid;
use crate::{Environment, Medium};
use haze_volume::{Bbox, Rbf};
use std::sync::Arc;
use std::time::Instant;

/// What lights a frame from every camera (module docs).
#[derive(Clone, Debug)]
pub struct FrameLight {
    /// RGB SH at every center, a function of the viewing direction.
    source: Vec<RgbSh>,
    /// The environment pass's grid and the environment's projection, with
    /// [`super::EnvSource::Grid`].
    env_grid: Option<(Arc<ShGrid>, RgbSh)>,
    /// The lights pass's shadows (none without lights).
    shadows: Option<LightShadows>,
    /// The multiple scattering on the coarse grid, with the grid's diffusions.
    ms: Option<MediaRadiance>,
}

/// What [`FrameLight::new`] takes from a caller that keeps it across frames.
#[derive(Clone, Debug)]
pub struct Kept<'a> {
    /// The SH tables of the order.
    pub kit: &'a ShKit,
    /// The environment projected at the order (`sh::project_env`).
    pub projected: &'a RgbSh,
    /// The environment pass's grid of this frame's density, σt, distant environment,
    /// order and grid options, when the caller has it.
    pub env_grid: Option<Arc<ShGrid>>,
}

/// A frame: RBFs over a `dims` grid on `bbox`, the residual per voxel (x fastest) when
/// given.
#[derive(Clone, Copy, Debug)]
pub struct FrameInput<'a> {
    pub rbfs: &'a [Rbf],
    pub residual: Option<&'a [f32]>,
    pub dims: [usize; 3],
    pub bbox: &'a Bbox,
}

impl FrameLight {
    /// The light of `frame` in `medium` under `env` with `opts`, and its volume grids
    /// seen from `eye`, with the time of each stage. `kept` holds what a caller that
    /// renders many frames keeps: the tables of `opts.order`, the environment projected
    /// at it, and the environment pass's grid when it still holds (the frame's density,
    /// σt, the distant environment, the order and the grid's options unchanged: an
    /// [`env_pass::env_grid`] of them), else it is computed. The centers' diffusion
    /// (with [`MsDiffusion::Centers`]) starts from `solver`'s last solution.
    pub fn new(
        frame: &FrameInput<'_>,
        medium: &Medium,
        env: &Environment,
        eye: [f64; 3],
        opts: &CrmOptions,
        kept: Kept<'_>,
        solver: &mut DiffusionSolver,
    ) -> (FrameLight, VolumeGrids, CrmStats) {
        let Kept {
            kit,
            projected,
            env_grid: kept_grid,
        } = kept;
        let mut stats = CrmStats::default();
        let source = source_radiance(
            kit, frame.rbfs, medium, projected, env, opts, solver, &mut stats,
        );
        let t = Instant::now();
        let mut grids = volume(frame, &source, eye, opts);
        stats.volume_seconds = t.elapsed().as_secs_f64();
        let mut env_grid = None;
        if let Some(g) = &opts.env_grid() {
            let t = Instant::now();
            let grid = match kept_grid {
                Some(grid) => grid,
                None => Arc::new(env_pass::env_grid(
                    &grids.density,
                    medium.sigma_t,
                    env,
                    opts.order,
                    g,
                )),
            };
            env_pass::add_env_grid(
                &mut grids,
                &grid,
                projected,
                medium,
                eye,
                opts.order,
                &env.distant,
            );
            env_grid = Some((grid, projected.clone()));
            stats.env_seconds = t.elapsed().as_secs_f64();
        }
        let t = Instant::now();
        let shadows = LightShadows::new(&grids.density, env, medium, opts.detail);
        if let Some(shadows) = &shadows {
            shadows.add_to(&mut grids, env, medium, eye);
        }
        stats.lights_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let rbfs = frame.rbfs;
        let ms = match (opts.multiple, opts.diffusion) {
            (true, MsDiffusion::Grid { factor }) => Some(grid_diffusion::frame_media_radiance(
                &grids,
                rbfs,
                &moments(&centers_single(rbfs, medium, env, opts, source.clone())),
                env,
                medium,
                factor,
                &opts.grid_solve,
            )),
            (true, MsDiffusion::Orders { factor, orders }) => {
                // The environment pass's grid lights the cells; without it, the centers.
                let centers = match &env_grid {
                    Some(_) => Sources::zeros(rbfs.len()),
                    None => moments(&source),
                };
                Some(grid_diffusion::frame_explicit_media_radiance(
                    &grids,
                    rbfs,
                    &centers,
                    env_grid.as_ref().map(|(g, l)| (g.as_ref(), l)),
                    env,
                    medium,
                    factor,
                    orders,
                    (opts.detail, opts.thick_cells),
                    &opts.grid_solve,
                ))
            }
            _ => None,
        };
        if let Some(ms) = &ms {
            grid_diffusion::add_to_grids(&mut grids, ms, medium, eye);
            if let MsDiffusion::Orders { orders, .. } = opts.diffusion {
                stats.ms_factor = ms.grid.factor;
                stats.ms_orders = grid_diffusion::orders_at_detail(orders, opts.detail);
                stats.ms_work = grid_diffusion::gather_work(&ms.grid);
            }
            stats.cg_iterations = ms.iterations;
            stats.cg_residual = ms.residual;
            stats.multiple_seconds = t.elapsed().as_secs_f64();
        }
        let light = FrameLight {
            source,
            env_grid,
            shadows,
            ms,
        };
        (light, grids, stats)
    }

    /// The environment pass's grid of the frame (with [`env_pass::EnvSource::Grid`]).
    pub fn env_grid(&self) -> Option<&Arc<ShGrid>> {
        self.env_grid.as_ref().map(|(g, _)| g)
    }

    /// The volume grids of `frame` seen from `eye`, from the light kept: `frame`,
    /// `medium`, `env` and `opts` must be those given to [`FrameLight::new`] (the camera
    /// alone may differ); the stats hold the time of each stage run again.
    pub fn grids(
        &self,
        frame: &FrameInput<'_>,
        medium: &Medium,
        env: &Environment,
        eye: [f64; 3],
        opts: &CrmOptions,
    ) -> (VolumeGrids, CrmStats) {
        let mut stats = CrmStats::default();
        let t = Instant::now();
        let mut grids = volume(frame, &self.source, eye, opts);
        stats.volume_seconds = t.elapsed().as_secs_f64();
        if let Some((grid, light)) = &self.env_grid {
            let t = Instant::now();
            env_pass::add_env_grid(
                &mut grids,
                grid,
                light,
                medium,
                eye,
                opts.order,
                &env.distant,
            );
            stats.env_seconds = t.elapsed().as_secs_f64();
        }
        if let Some(shadows) = &self.shadows {
            let t = Instant::now();
            shadows.add_to(&mut grids, env, medium, eye);
            stats.lights_seconds = t.elapsed().as_secs_f64();
        }
        if let Some(ms) = &self.ms {
            let t = Instant::now();
            grid_diffusion::add_to_grids(&mut grids, ms, medium, eye);
            stats.multiple_seconds = t.elapsed().as_secs_f64();
        }
        (grids, stats)
    }
}

/// The volume pass of `frame` from `source` towards `eye`, the residual as `opts` says.
fn volume(
    frame: &FrameInput<'_>,
    source: &[RgbSh],
    eye: [f64; 3],
    opts: &CrmOptions,
) -> VolumeGrids {
    let residual = if opts.residual { frame.residual } else { None };
    crm::volume_pass(
        frame.rbfs, source, opts.order, frame.dims, frame.bbox, residual, eye,
    )
}
