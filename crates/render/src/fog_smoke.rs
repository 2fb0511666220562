//! A baked smoke asset placed in a wavelet fog's world and rendered as a layer the fog
//! composites by depth (`haze fog wavelet --smoke`, `haze view --fog --smoke`).
//!
//! Placement: the fog's world is the terrain's, Z up, the ground at `z = 0`. A point `p`
//! of the asset's own world box goes to `s·p + offset` (`--smoke-scale s`,
//! `--smoke-offset`): the box, the RBF centres and radii are scaled and moved, the
//! densities stay, and the extinction cross-section becomes `σt/s` per world unit, so a
//! scaled smoke looks the same, only larger. With the defaults (scale 1, offset 0) an
//! asset whose box stands on `z = 0` around the origin stands in the middle of a default
//! fog (whose map is centred on 0,0).
//!
//! Lighting: the smoke's source radiance at its RBF centres (single scattering of
//! `haze_view`'s default sky and multiple scattering, paper A §5.3–5.4) is computed once;
//! per camera, the volume pass (radiance towards the eye), then the view pass as a layer
//! (`crm::view_layer`: radiance, transmittance, opacity-weighted depth per pixel), each
//! ray ending where it meets the ground.

use anyhow::{Result, anyhow, bail};
use haze_view::lighting::single::RgbSh;
use haze_view::render::crm::{self, SmokeSample};
use haze_view::render::{CrmOptions, crm_sources, lights_pass, slice_thickness};
use haze_view::{Camera, Environment, Medium, Sky};
use haze_volume::{Bbox, Rbf};
use std::path::PathBuf;

/// The smoke shown with the fog: the asset, its frame, where it goes and its medium.
#[derive(Clone, Debug)]
pub struct SmokePlacement {
    /// A baked smoke asset (.haze), composited by depth; `None`: no smoke.
    pub smoke: Option<PathBuf>,
    /// The asset's frame number to show (`None`: its first).
    pub smoke_frame: Option<i64>,
    /// A point p of the asset's world lands at scale·p + offset.
    pub smoke_offset: [f64; 3],
    /// Uniform scale of the smoke about the asset's world origin.
    pub smoke_scale: f64,
    /// The smoke's extinction cross-section per asset unit: κt = σt · density.
    pub smoke_sigma_t: f64,
    /// The smoke's single-scattering albedo, 0..1.
    pub smoke_albedo: f64,
    /// The smoke's Henyey–Greenstein asymmetry, −1..1.
    pub smoke_g: f64,
}

/// A smoke frame placed in the fog's world, its source radiance computed.
#[derive(Debug)]
pub struct Smoke {
    rbfs: Vec<Rbf>,
    residual: Vec<f32>,
    dims: [usize; 3],
    bbox: Bbox,
    medium: Medium,
    env: Environment,
    sources: Vec<RgbSh>,
    opts: CrmOptions,
    /// What was loaded, for messages.
    pub label: String,
}

impl SmokePlacement {
    /// The smoke asked for, loaded, placed and lit; `None` without `--smoke`.
    pub fn load(&self) -> Result<Option<Smoke>> {
        let Some(path) = &self.smoke else {
            return Ok(None);
        };
        if !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("haze"))
        {
            bail!(
                "{}: --smoke takes a baked asset (.haze; `haze bake` makes one)",
                path.display()
            );
        }
        let s = self.smoke_scale;
        if !(s.is_finite() && s > 0.0) {
            bail!("--smoke-scale {s}: must be a positive number");
        }
        let medium = Medium::new(self.smoke_sigma_t / s, self.smoke_albedo, self.smoke_g)
            .map_err(|e| anyhow!("--smoke-sigma-t, --smoke-albedo, --smoke-g: {e}"))?;
        let frame = crate::frame::load_asset(path, self.smoke_frame)?;
        let off = self.smoke_offset;
        let place = |p: [f64; 3]| [0, 1, 2].map(|a| s * p[a] + off[a]);
        let rbfs: Vec<Rbf> = frame
            .rbfs
            .iter()
            .map(|r| Rbf::new(place(r.center), s * r.radius, r.weight))
            .collect();
        let b = frame.density.bbox();
        let bbox = Bbox::new(place(b.min), place(b.max));
        let env = Environment::sky(Sky::default());
        let opts = CrmOptions::default();
        let (sources, _) = crm_sources(&rbfs, &medium, &env, &opts);
        Ok(Some(Smoke {
            rbfs,
            residual: frame.residual,
            dims: frame.density.dims(),
            bbox,
            medium,
            env,
            sources,
            opts,
            label: frame.label,
        }))
    }
}

impl Smoke {
    /// The smoke's layer seen by `camera`: per pixel (row 0 on top) its radiance,
    /// transmittance and depth, each ray ending at the ground `z = 0`.
    pub fn layer(&self, camera: &Camera) -> Vec<SmokeSample> {
        let eye = camera.eye;
        let mut grids = crm::volume_pass(
            &self.rbfs,
            &self.sources,
            self.opts.order,
            self.dims,
            &self.bbox,
            Some(&self.residual),
            eye,
        );
        lights_pass::lights_pass(&mut grids, &self.env, &self.medium, eye);
        let du = slice_thickness(self.dims, &self.bbox, &self.opts);
        let end =
            |d: [f64; 3]| haze_wavelet::render::ground_distance(eye, d).unwrap_or(f64::INFINITY);
        crm::view_layer(&grids, &self.medium, &self.env.points, camera, du, &end)
    }
}
