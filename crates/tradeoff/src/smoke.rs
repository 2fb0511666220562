//! The smoke sweep: a density frame fitted with RBFs (as `haze bake` fits a first frame),
//! its residual quantized (as the bake stores it), rendered by compensated ray marching
//! for every setting of the knobs — on the CPU (`haze render`'s default), or with every
//! stage on the GPU (`haze render --gpu`, the viewer's renderer) when the sweep times the
//! GPU. Thick smoke is lit as `haze render` lights it at voxel resolution: the
//! environment grid's nodes on the voxel centers (`CrmOptions::for_smoke`) and the
//! explicit orders' cells of one voxel where the automatic rule takes them, on the GPU
//! too (`CrmOptions::for_gpu_cells`), so both sweeps measure the same pictures; it is not
//! refined as `haze render --supersample` refines voxels over one optical depth (the
//! sweep warns).

use super::knobs::{Knob, KnobValue};
use crate::lab::{Lab, Sample};
use anyhow::{Result, anyhow};
use haze_bake::residual::as_stored;
use haze_fit::{FitOptions, SequenceFitter, SequenceOptions};
use haze_gpu::GpuContext;
use haze_hash::QuantOptions;
use haze_render::check::{self, ErrorEstimate};
use haze_view::diffusion::SolveOptions;
use haze_view::gpu::renderer::{GpuFrame, GpuRenderer, LightingOn};
use haze_view::gpu::volume_pass::Residual;
use haze_view::lighting::single::SourcePoints;
use haze_view::reference::{self, RefOptions};
use haze_view::render::env_pass::{EnvGridOptions, EnvSource};
use haze_view::render::{CrmOptions, MsDiffusion, crm_render, supersample};
use haze_view::sh::ExpMethod;
use haze_view::{Camera, Environment, Image, Medium};
use haze_volume::{Rbf, Volume, rbf};
use serde_json::json;
use std::collections::HashMap;
use std::time::Instant;

/// Where the camera looks from: given, or framing the smoke.
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub eye: Option<[f64; 3]>,
    pub target: Option<[f64; 3]>,
    pub up: [f64; 3],
    pub fov: f64,
    /// The full render size (the `size` knob scales it).
    pub width: usize,
    pub height: usize,
}

impl View {
    /// The camera at `scale` × the full size (at least 8 pixels a side).
    pub fn camera(&self, density: &Volume, scale: f64) -> Result<Camera> {
        let w = ((self.width as f64 * scale).round() as usize).max(8);
        let h = ((self.height as f64 * scale).round() as usize).max(8);
        match (self.eye, self.target) {
            (Some(e), Some(t)) => Camera::new(e, t, self.up, self.fov, w, h),
            (None, None) => {
                let b = haze_render::frame::smoke_bbox(density);
                Camera::framing(b.min, b.max, self.fov, w, h)
            }
            _ => {
                return Err(anyhow!(
                    "give both --eye and --target, or neither (to frame the smoke)"
                ));
            }
        }
        .map_err(|e| anyhow!("camera: {e}"))
    }
}

/// The knob values of a smoke sweep.
const RBFS: [usize; 5] = [50, 100, 200, 300, 600];
const RBFS_QUICK: [usize; 2] = [50, 100];
const RESIDUAL_ERROR: [f64; 4] = [0.0, 1.0 / 255.0, 4.0 / 255.0, 16.0 / 255.0];
const QUANT_BITS: [u8; 3] = [4, 8, 16];
const SH_ORDER: [usize; 6] = [1, 2, 3, 4, 5, 6];
const SH_ORDER_QUICK: [usize; 3] = [2, 4, 6];
const CG: [u32; 5] = [5, 10, 20, 50, 500];
const CG_QUICK: [u32; 2] = [10, 500];
const SLICES: [f64; 4] = [0.5, 1.0, 2.0, 4.0];
const SLICES_QUICK: [f64; 2] = [1.0, 2.0];
const SIZE: [f64; 4] = [0.25, 0.5, 0.75, 1.0];
const SIZE_QUICK: [f64; 2] = [0.5, 1.0];
/// The multiple-scattering models (`--diffusion`'s spelling), cheapest first: paper A's
/// diffusion at the centers, then the explicit orders from few orders on large cells to
/// the renderers' default ([`MsDiffusion::DEFAULT`], the most accurate).
const DIFFUSION: [&str; 4] = ["centers", "orders:4:2", "orders:3:3", "orders:auto:6"];
const DIFFUSION_QUICK: [&str; 3] = ["centers", "orders:4:2", "orders:auto:6"];
/// The knobs' positions in a setting ([`SmokeLab::decode`]'s order).
const SOURCE: usize = 6;
const MULTIPLE: usize = 10;
const DIFFUSION_KNOB: usize = 12;

/// A smoke setting decoded from knob indices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmokeSetting {
    pub rbfs: usize,
    pub teleport: bool,
    pub residual_error: f64,
    pub quant_bits: u8,
    pub crm: CrmOptions,
    pub size: f64,
}

/// The renderer a sweep times.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Timing {
    /// `crm_render` on the CPU.
    Cpu,
    /// `GpuRenderer` (the view pass on the GPU, the stages before it where told),
    /// each render a new frame: no reuse and no warm start from the setting before.
    Gpu(LightingOn),
}

/// The GPU renderer of a GPU-timed sweep, and the key of the next frame.
#[derive(Debug)]
struct Gpu {
    ctx: GpuContext,
    renderer: GpuRenderer,
    lighting: LightingOn,
    next_key: u64,
}

/// One timed render: milliseconds, the picture, the host's stage times and the GPU's.
type Timed = (
    f64,
    Image,
    haze_view::render::CrmStats,
    Vec<(&'static str, f64)>,
);

/// The smoke lab: the density, its light and medium, and the fits made so far.
#[derive(Debug)]
pub struct SmokeLab {
    density: Volume,
    /// Its voxels' optical depth (`supersample::tau_per_voxel`) in the medium.
    tau: f64,
    env: Environment,
    medium: Medium,
    view: View,
    knobs: Vec<Knob>,
    repeats: usize,
    fits: HashMap<(usize, bool), (Vec<Rbf>, f64, f64)>,
    gpu: Option<Gpu>,
}

#[derive(Clone, Debug)]
struct Tables {
    rbfs: Vec<usize>,
    sh: Vec<usize>,
    cg: Vec<u32>,
    slices: Vec<f64>,
    size: Vec<f64>,
    diffusion: Vec<&'static str>,
}

fn index_of<T: PartialEq>(v: &[T], x: &T) -> usize {
    v.iter().position(|y| y == x).unwrap_or(0)
}

impl SmokeLab {
    /// A lab over `density`; `quick` sweeps fewer values of each knob; every render is
    /// timed `repeats` times (the fastest counts).
    pub fn new(
        density: Volume,
        env: Environment,
        medium: Medium,
        view: View,
        quick: bool,
        repeats: usize,
    ) -> SmokeLab {
        let tables = if quick {
            Tables {
                rbfs: RBFS_QUICK.to_vec(),
                sh: SH_ORDER_QUICK.to_vec(),
                cg: CG_QUICK.to_vec(),
                slices: SLICES_QUICK.to_vec(),
                size: SIZE_QUICK.to_vec(),
                diffusion: DIFFUSION_QUICK.to_vec(),
            }
        } else {
            Tables {
                rbfs: RBFS.to_vec(),
                sh: SH_ORDER.to_vec(),
                cg: CG.to_vec(),
                slices: SLICES.to_vec(),
                size: SIZE.to_vec(),
                diffusion: DIFFUSION.to_vec(),
            }
        };
        let d = CrmOptions::default();
        let last = |n: usize| n - 1;
        let knobs = vec![
            Knob::new(
                "rbfs",
                tables
                    .rbfs
                    .iter()
                    .map(|&x| KnobValue::Count(x as u64))
                    .collect(),
                if quick {
                    1
                } else {
                    index_of(&tables.rbfs, &300)
                },
                last(tables.rbfs.len()),
            ),
            Knob::new("teleport", KnobValue::flags(), 1, 1).render_neutral(),
            Knob::new(
                "residual_error",
                KnobValue::numbers(&RESIDUAL_ERROR),
                index_of(&RESIDUAL_ERROR, &haze_hash::DEFAULT_ERROR),
                0,
            )
            .render_neutral(),
            Knob::new("quant_bits", KnobValue::counts(&QUANT_BITS), 1, 2).render_neutral(),
            Knob::new(
                "sh_order",
                tables
                    .sh
                    .iter()
                    .map(|&x| KnobValue::Count(x as u64))
                    .collect(),
                index_of(&tables.sh, &d.order),
                last(tables.sh.len()),
            ),
            Knob::new("exp", KnobValue::names(&["square", "linear"]), 0, 0),
            Knob::new(
                "source",
                KnobValue::names(&["grid", "footprint", "center"]),
                0,
                0,
            ),
            Knob::new(
                "cg_iterations",
                KnobValue::counts(&tables.cg),
                index_of(&tables.cg, &d.solve.max_iterations),
                last(tables.cg.len()),
            ),
            Knob::new(
                "slices",
                KnobValue::numbers(&tables.slices),
                index_of(&tables.slices, &d.slices_per_voxel),
                last(tables.slices.len()),
            ),
            Knob::new(
                "size",
                KnobValue::numbers(&tables.size),
                last(tables.size.len()),
                last(tables.size.len()),
            ),
            Knob::new("multiple", KnobValue::flags(), 1, 1),
            Knob::new("residual", KnobValue::flags(), 1, 1),
            // The renderers' default model is the most accurate one swept.
            Knob::new(
                "diffusion",
                KnobValue::names(&tables.diffusion),
                last(tables.diffusion.len()),
                last(tables.diffusion.len()),
            ),
        ];
        let tau = supersample::tau_per_voxel(&density, medium.sigma_t);
        if !supersample::thin_enough(tau) {
            tracing::warn!(
                "the smoke is {tau:.1} optical depths a voxel: `haze render` lights it on a finer grid (--supersample), this sweep at its own voxels, so its errors are larger than the renders'"
            );
        }
        SmokeLab {
            density,
            tau,
            env,
            medium,
            view,
            knobs,
            repeats: repeats.max(1),
            fits: HashMap::new(),
            gpu: None,
        }
    }

    /// Times the renders with `timing`; a GPU is opened here (a machine without one is
    /// told at once).
    pub fn set_timing(&mut self, timing: Timing) -> Result<()> {
        self.gpu = match timing {
            Timing::Cpu => None,
            Timing::Gpu(on) => {
                let ctx = GpuContext::new().map_err(|e| anyhow!("--gpu: {e}"))?;
                ctx.time_stages(true);
                let mut renderer =
                    GpuRenderer::new(&ctx, self.env.clone()).map_err(|e| anyhow!("--gpu: {e}"))?;
                renderer.set_lighting(on);
                Some(Gpu {
                    ctx,
                    renderer,
                    lighting: on,
                    next_key: 0,
                })
            }
        };
        Ok(())
    }

    /// The adapter the renders are timed on, or `None` for the CPU.
    pub fn adapter(&self) -> Option<String> {
        self.gpu.as_ref().map(|g| {
            format!(
                "{} ({}), lighting on the {}",
                g.ctx.adapter_name(),
                g.ctx.backend(),
                match g.lighting.resolve(&g.ctx) {
                    LightingOn::Cpu => "CPU",
                    _ => "GPU",
                }
            )
        })
    }

    /// Renders these RBFs (an asset's own, as stored) instead of fitting: the `rbfs`
    /// knob has their count for its one value, and no fit is timed.
    pub fn use_rbfs(&mut self, rbfs: Vec<Rbf>) {
        let n = rbfs.len();
        self.knobs[0] = Knob::new("rbfs", vec![KnobValue::Count(n as u64)], 0, 0);
        for teleport in [false, true] {
            self.fits
                .insert((n, teleport), (rbfs.clone(), 0.0, f64::NAN));
        }
    }

    /// Keeps only the knobs named in `only` (the others stay at their defaults).
    pub fn restrict(&mut self, only: &[String]) {
        crate::lab::restrict(&mut self.knobs, only);
    }

    /// The setting of knob indices `s`.
    pub fn decode(&self, s: &[usize]) -> SmokeSetting {
        let v = |k: usize| self.knobs[k].values[s[k]];
        let f = |k: usize| v(k).number().unwrap_or(0.0);
        let b = |k: usize| v(k).flag().unwrap_or(true);
        SmokeSetting {
            rbfs: f(0) as usize,
            teleport: b(1),
            residual_error: f(2),
            quant_bits: f(3) as u8,
            crm: CrmOptions {
                order: f(4) as usize,
                exp: if v(5).name() == Some("linear") {
                    ExpMethod::OptimalLinear
                } else {
                    ExpMethod::ScaleSquareAuto
                },
                source_points: if v(6).name() == Some("center") {
                    SourcePoints::Center
                } else {
                    SourcePoints::Footprint
                },
                // "grid" is the environment pass; "footprint" and "center" are paper A's
                // sources at the centers.
                env_source: if v(6).name() == Some("grid") {
                    EnvSource::Grid(EnvGridOptions::default())
                } else {
                    EnvSource::Centers
                },
                solve: SolveOptions {
                    max_iterations: f(7) as u32,
                    ..SolveOptions::default()
                },
                slices_per_voxel: f(8),
                multiple: b(10),
                residual: b(11),
                diffusion: v(DIFFUSION_KNOB)
                    .name()
                    .and_then(|d| d.parse().ok())
                    .unwrap_or(MsDiffusion::DEFAULT),
                ..CrmOptions::default()
            }
            .for_smoke(self.tau),
            size: f(9),
        }
    }

    /// The setting that renders `s` with this lab's renderer ([`gpu_runnable`] on the
    /// GPU; every setting runs on the CPU).
    fn runnable(&self, s: &[usize]) -> std::result::Result<Vec<usize>, String> {
        match self.gpu {
            None => Ok(s.to_vec()),
            Some(_) => gpu_runnable(&self.knobs, s),
        }
    }

    /// The first-frame fit of `rbfs` RBFs (cached): the RBFs as stored, the seconds it
    /// took and its rel_l2.
    fn fit(&mut self, rbfs: usize, teleport: bool) -> Result<(Vec<Rbf>, f64, f64)> {
        if let Some(f) = self.fits.get(&(rbfs, teleport)) {
            return Ok(f.clone());
        }
        let t = Instant::now();
        let opts = SequenceOptions {
            rbfs,
            fit: FitOptions {
                teleport,
                ..FitOptions::default()
            },
            ..SequenceOptions::default()
        };
        let fit = SequenceFitter::new(opts)
            .fit(&self.density)
            .map_err(|e| anyhow!("fit of {rbfs} RBFs: {e}"))?;
        let stored = as_stored(&fit.rbfs)?;
        let out = (stored, t.elapsed().as_secs_f64(), fit.rel_l2);
        self.fits.insert((rbfs, teleport), out.clone());
        Ok(out)
    }
}

/// On the GPU the explicit orders are lit by the environment pass's grid: a setting with
/// multiple scattering by the orders and `source` footprint or center renders as `haze
/// render --gpu --source footprint` does, with the centers' diffusion (the setting
/// returned says so), or cannot run when the sweep has no `centers` value (`Err` says
/// why).
fn gpu_runnable(knobs: &[Knob], s: &[usize]) -> std::result::Result<Vec<usize>, String> {
    let value = |k: usize| knobs[k].values[s[k]];
    let orders = value(DIFFUSION_KNOB)
        .name()
        .is_some_and(|d| d.starts_with("orders"));
    let multiple = value(MULTIPLE).flag().unwrap_or(true);
    if !orders || !multiple || value(SOURCE).name() == Some("grid") {
        return Ok(s.to_vec());
    }
    match knobs[DIFFUSION_KNOB]
        .values
        .iter()
        .position(|v| v.name() == Some("centers"))
    {
        Some(c) => {
            let mut out = s.to_vec();
            out[DIFFUSION_KNOB] = c;
            Ok(out)
        }
        None => Err(format!(
            "source={}: the explicit orders on the GPU need source=grid",
            value(SOURCE).name().unwrap_or("?")
        )),
    }
}

/// The residual `D − D̃` quantized as the bake stores it and dequantized as every reader
/// gets it, with the seconds it took.
pub fn stored_residual(
    density: &Volume,
    rbfs: &[Rbf],
    opts: QuantOptions,
) -> Result<(Vec<f32>, f64)> {
    let t = Instant::now();
    let approx = rbf::evaluate_on_grid(density.dims(), density.bbox(), rbfs);
    let r: Vec<f32> = density
        .data()
        .iter()
        .zip(&approx)
        .map(|(d, a)| (f64::from(*d) - a) as f32)
        .collect();
    let peak = density.data().iter().fold(0.0f32, |m, &d| m.max(d));
    let q = haze_hash::quantize(&r, peak, opts).map_err(|e| anyhow!("residual: {e}"))?;
    let mut dense = vec![0.0f32; r.len()];
    for &(i, v) in &q.cells {
        dense[i as usize] = q.value(v);
    }
    Ok((dense, t.elapsed().as_secs_f64()))
}

impl Lab for SmokeLab {
    fn kind(&self) -> &'static str {
        "smoke"
    }

    fn knobs(&self) -> &[Knob] {
        &self.knobs
    }

    fn runnable(&self, s: &[usize]) -> std::result::Result<Vec<usize>, String> {
        SmokeLab::runnable(self, s)
    }

    fn measure(&mut self, s: &[usize]) -> Result<Sample> {
        let set = self.decode(s);
        let (rbfs, fit_s, rel_l2) = self.fit(set.rbfs, set.teleport)?;
        let (residual, quant_s) = stored_residual(
            &self.density,
            &rbfs,
            QuantOptions {
                error: set.residual_error,
                bits: set.quant_bits,
            },
        )?;
        let camera = self.view.camera(&self.density, set.size)?;
        let mut best: Option<Timed> = None;
        // On the GPU a first render is not timed: a new SH order builds its tables and
        // pipelines once (the viewer pays that when the knob changes, not per frame).
        let warm_up = usize::from(self.gpu.is_some());
        for run in 0..warm_up + self.repeats {
            let t = Instant::now();
            let (img, stats, gpu_stages) = match &mut self.gpu {
                None => {
                    let (img, stats) = crm_render(
                        &rbfs,
                        set.crm.residual.then_some(residual.as_slice()),
                        self.density.dims(),
                        self.density.bbox(),
                        &self.medium,
                        &self.env,
                        &camera,
                        &set.crm,
                    );
                    (img, stats, Vec::new())
                }
                Some(g) => {
                    // The residual is uploaded dense, as `haze render --gpu` does for a
                    // fitted volume; turned off, the view pass is told so by the options.
                    let gpu_err = |e| anyhow!("--gpu: {e}");
                    g.renderer.reset();
                    g.next_key += 1;
                    let frame = GpuFrame {
                        key: g.next_key,
                        rbfs: &rbfs,
                        residual: Some(Residual::Dense(&residual)),
                        dims: self.density.dims(),
                        bbox: *self.density.bbox(),
                    };
                    // The orders' cells of one voxel where the CPU takes them.
                    let crm =
                        set.crm
                            .for_gpu_cells(1, self.tau, g.renderer.orders_cells(&g.ctx), || {
                                Some(&self.density)
                            });
                    let (image, stats) = g
                        .renderer
                        .render(&g.ctx, &frame, &self.medium, &camera, &crm)
                        .map_err(gpu_err)?;
                    let pixels = image.read(&g.ctx).map_err(gpu_err)?;
                    let img = Image {
                        width: camera.width,
                        height: camera.height,
                        pixels,
                    };
                    (img, stats.crm, stats.gpu)
                }
            };
            let ms = t.elapsed().as_secs_f64() * 1e3;
            if run >= warm_up && best.as_ref().is_none_or(|(b, ..)| ms < *b) {
                best = Some((ms, img, stats, gpu_stages));
            }
        }
        let (render_ms, image, stats, gpu_stages) = best.ok_or_else(|| anyhow!("no render"))?;
        let mut ms = json!({
            "fit": fit_s * 1e3,
            "residual": quant_s * 1e3,
            "bake": (fit_s + quant_s) * 1e3,
            "render": render_ms,
            "setup": stats.setup_seconds * 1e3,
            "single": stats.single_seconds * 1e3,
            "multiple": stats.multiple_seconds * 1e3,
            "volume": stats.volume_seconds * 1e3,
            "lights": stats.lights_seconds * 1e3,
            "view": stats.view_seconds * 1e3,
        });
        // On the GPU the host stages only submit the passes: the device's own times (when
        // it has timestamp queries) are the passes' costs, and the view pass's is `view`.
        for (stage, s) in gpu_stages {
            ms[format!("gpu {stage}")] = json!(s * 1e3);
            if stage.contains("view") {
                ms["view"] = json!(s * 1e3);
            }
        }
        Ok(Sample {
            image,
            render_ms,
            ms,
            detail: json!({
                "fit_rel_l2": rel_l2,
                "cg_iterations": stats.cg_iterations,
                "cg_residual": stats.cg_residual,
            }),
        })
    }

    fn reference(&mut self, spp: u32) -> Result<Image> {
        let camera = self.view.camera(&self.density, 1.0)?;
        let opts = RefOptions {
            spp: spp.max(1),
            multiple: true,
            ..RefOptions::default()
        };
        Ok(reference::render(
            &self.density,
            &self.medium,
            &self.env,
            &camera,
            &opts,
        ))
    }

    fn check(&mut self, image: &Image, n: usize) -> Option<ErrorEstimate> {
        // The picture may be a fraction of the full size (the `size` knob).
        let scale = image.width as f64 / self.view.width.max(1) as f64;
        let camera = self.view.camera(&self.density, scale).ok()?;
        if (camera.width, camera.height) != (image.width, image.height) {
            return None;
        }
        check::estimate(
            image,
            &self.density,
            &self.medium,
            &self.env,
            None,
            &camera,
            true,
            n,
            check::CHECK_SAMPLES,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_view::Sky;
    use haze_view::render::env_pass::THICK_SPACING;
    use haze_volume::Bbox;

    fn lab(quick: bool) -> SmokeLab {
        lab_at(quick, 4.0)
    }

    /// The lab of a 2³ block of density 1 over the unit box (voxels of 1/2) at `sigma_t`:
    /// its voxels `sigma_t / 2` optical depths thick.
    fn lab_at(quick: bool, sigma_t: f64) -> SmokeLab {
        let density = Volume::new([2, 2, 2], Bbox::new([0.0; 3], [1.0; 3]), vec![1.0; 8]).unwrap();
        let view = View {
            eye: None,
            target: None,
            up: [0.0, 0.0, 1.0],
            fov: 40.0,
            width: 8,
            height: 8,
        };
        SmokeLab::new(
            density,
            Environment::sky(Sky::default()),
            Medium::new(sigma_t, 0.8, 0.3).unwrap(),
            view,
            quick,
            1,
        )
    }

    /// Every setting of thick smoke is lit as `haze render` lights it: the environment
    /// grid's nodes on the voxel centers past a third of an optical depth a voxel (the
    /// default spacing below it); paper A's sources at the centers keep no grid.
    #[test]
    fn thick_smoke_is_swept_as_haze_render_lights_it() {
        let spacing = |sigma_t: f64| {
            let lab = lab_at(true, sigma_t);
            let default = super::super::knobs::defaults(&lab.knobs);
            match lab.decode(&default).crm.env_source {
                EnvSource::Grid(g) => g.spacing,
                EnvSource::Centers => panic!("the default lights by the grid"),
            }
        };
        let wide = EnvGridOptions::default().spacing;
        assert!(wide > THICK_SPACING);
        // 0.25 optical depths a voxel: a cell of 1.5 voxels is 0.375 across.
        assert_eq!(spacing(0.5), wide);
        // 0.4 a voxel: 0.6 across, over `MAX_CELL_TAU`.
        assert_eq!(spacing(0.8), THICK_SPACING);
        assert_eq!(spacing(4.0), THICK_SPACING);
        let lab = lab_at(true, 4.0);
        let mut footprint = super::super::knobs::defaults(&lab.knobs);
        footprint[SOURCE] = 1;
        assert_eq!(lab.decode(&footprint).crm.env_source, EnvSource::Centers);
    }

    /// The `diffusion` knob's values decode to the renderers' models, its default and
    /// best being the renderers' default; on the GPU the orders with the sources at the
    /// centers render with the centers' diffusion, or are skipped when the sweep has no
    /// `centers` value; with the sky per voxel, or single scattering alone, nothing
    /// changes.
    #[test]
    fn the_diffusion_knob_decodes_and_maps_what_the_gpu_cannot_run() {
        let full = lab(false);
        let k = &full.knobs[DIFFUSION_KNOB];
        assert_eq!(k.name, "diffusion");
        assert_eq!(k.default, k.best);
        let default = super::super::knobs::defaults(&full.knobs);
        assert_eq!(full.decode(&default).crm.diffusion, MsDiffusion::DEFAULT);
        let with = |knob: usize, v: usize| {
            let mut s = default.clone();
            s[knob] = v;
            s
        };
        let models: Vec<MsDiffusion> = (0..k.values.len())
            .map(|v| full.decode(&with(DIFFUSION_KNOB, v)).crm.diffusion)
            .collect();
        assert_eq!(
            models,
            [
                MsDiffusion::Centers,
                MsDiffusion::Orders {
                    factor: 4,
                    orders: 2
                },
                MsDiffusion::Orders {
                    factor: 3,
                    orders: 3
                },
                MsDiffusion::DEFAULT,
            ]
        );
        let footprint = with(SOURCE, 1);
        assert_eq!(full.knobs[SOURCE].values[1], KnobValue::Name("footprint"));
        let mapped = gpu_runnable(&full.knobs, &footprint).unwrap();
        assert_eq!(
            mapped,
            with(SOURCE, 1)
                .iter()
                .enumerate()
                .map(|(i, &v)| if i == DIFFUSION_KNOB { 0 } else { v })
                .collect::<Vec<_>>()
        );
        assert_eq!(full.decode(&mapped).crm.diffusion, MsDiffusion::Centers);
        assert_eq!(gpu_runnable(&full.knobs, &default).unwrap(), default);
        let mut single = footprint.clone();
        single[MULTIPLE] = 0;
        assert_eq!(gpu_runnable(&full.knobs, &single).unwrap(), single);
        // Restricted to other knobs, the diffusion has its default alone: no centers.
        let mut only = lab(true);
        only.restrict(&["source".to_string()]);
        let e = gpu_runnable(&only.knobs, &[0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0]).unwrap_err();
        assert!(
            e.contains("source=footprint") && e.contains("source=grid"),
            "{e}"
        );
    }
}
