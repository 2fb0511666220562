//! `haze bench`: the GPU renderer timed on a fixed set of workloads, on whatever adapter
//! this machine has, so that figures from different machines compare.
//!
//! Every workload is synthetic and deterministic — a rising plume of `rbfs` Gaussian RBFs
//! over a grid of its class (`N × N × 4N/3` voxels) with a residual quantized at 1/255
//! of the peak inside the plume's envelope — so no file is needed and every machine
//! renders the same frames, lit by the built-in sky with the renderer's default multiple
//! scattering (the explicit orders, `MsDiffusion::DEFAULT`). Per workload: one warm-up
//! frame (pipelines, SH tables), then `repeat` frames of each kind, medians reported:
//!
//! - **frame**: a new density frame from scratch (lighting, volume pass, view pass; the
//!   renderer reset before it);
//! - **playback**: the next frame of an animation (the plume risen a little), the
//!   diffusion warm-started from the previous frame, as the viewer plays;
//! - **orbit**: the camera moved around the same frame (the lighting's grids reused).
//!
//! GPU time per pass comes from timestamp queries where the adapter has them; lighting
//! that runs on the CPU (`LightingOn::Auto` on a CPU adapter such as lavapipe) is host
//! time.

use anyhow::{Result, bail};
use haze_camera::Camera;
use haze_gpu::{GpuContext, GpuError};
use haze_hash::{BuildOptions, QuantOptions, tile::ResidualGroup};
use haze_view::gpu::renderer::{FrameStats, GpuFrame, GpuRenderer, LightingOn};
use haze_view::gpu::volume_pass::Residual;
use haze_view::render::{CrmOptions, MsDiffusion};
use haze_view::stream::ResidualSlot;
use haze_view::{Environment, Medium, Sky};
use haze_volume::{Bbox, Rbf};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// The cameras' vertical field of view, degrees.
const FOV: f64 = 40.0;

/// One configuration timed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Workload {
    /// RBFs of the frame.
    pub rbfs: usize,
    /// Grid class: `N × N × 4N/3` voxels.
    pub grid: usize,
    pub width: usize,
    pub height: usize,
    /// SH order (bands).
    pub order: usize,
    /// Multiple scattering on.
    pub multiple: bool,
}

impl Workload {
    /// Voxels per axis.
    pub fn dims(&self) -> [usize; 3] {
        [self.grid, self.grid, self.grid * 4 / 3]
    }
}

/// Which workloads [`run`] times.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Set {
    /// [`workloads`] on a GPU; [`scaled`] on a CPU adapter (lavapipe), where the full
    /// set takes many minutes and its 256-class grid exceeds the buffers.
    Auto,
    Full,
    Quick,
}

/// The full set: RBF count, grid class, picture size, SH order and multiple scattering
/// each varied from 1000 RBFs, 128-class, 800 × 600, SH 4, multiple scattering on.
pub fn workloads() -> Vec<Workload> {
    let base = Workload {
        rbfs: 1000,
        grid: 128,
        width: 800,
        height: 600,
        order: 4,
        multiple: true,
    };
    vec![
        Workload { rbfs: 100, ..base },
        base,
        Workload { rbfs: 4000, ..base },
        Workload { grid: 256, ..base },
        Workload {
            width: 1920,
            height: 1080,
            ..base
        },
        Workload { order: 2, ..base },
        Workload {
            multiple: false,
            ..base
        },
    ]
}

/// [`workloads`] with every grid class and picture side halved (64- and 128-class
/// grids, 400 × 300 and 960 × 540), RBF counts and SH orders kept: the set of a CPU
/// adapter.
pub fn scaled() -> Vec<Workload> {
    workloads()
        .into_iter()
        .map(|w| Workload {
            grid: w.grid / 2,
            width: w.width / 2,
            height: w.height / 2,
            ..w
        })
        .collect()
}

/// `--quick`: one small workload, to check that the command runs (seconds, even on a
/// CPU adapter).
pub fn quick() -> Vec<Workload> {
    vec![Workload {
        rbfs: 100,
        grid: 48,
        width: 320,
        height: 240,
        order: 2,
        multiple: true,
    }]
}

/// Median milliseconds of one kind of frame.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Timing {
    /// Wall time from the call to the image finished on the device.
    pub frame_ms: f64,
    pub fps: f64,
    /// Everything but the view pass: lighting, sources, volume pass (wall − view).
    pub lighting_ms: f64,
    /// GPU time of each pass (timestamp queries; empty without them), by name.
    pub passes_ms: Vec<(String, f64)>,
}

/// One workload's figures.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub workload: Workload,
    /// `None` when the workload did not fit the device (see `skipped`).
    pub frame: Option<Timing>,
    pub playback: Option<Timing>,
    pub orbit: Option<Timing>,
    /// Why the workload was not timed: a buffer larger than the device allows.
    pub skipped: Option<String>,
}

/// What `haze bench` measured, and where.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub adapter: String,
    pub backend: String,
    /// The workloads: "full", "scaled" (a CPU adapter's) or "quick".
    pub set: String,
    /// Per-pass GPU times come from timestamp queries (else only wall times).
    pub timestamps: bool,
    /// Where single scattering and the diffusion ran: "CPU" or "GPU".
    pub lighting_on: String,
    pub repeat: usize,
    pub rows: Vec<Row>,
}

/// Frames of each kind per workload by default: 3, or 1 on a CPU adapter (lavapipe),
/// where a frame takes a second or more.
pub const REPEAT: usize = 3;

/// Times `workloads` on the first adapter found, `repeat` frames of each kind (by
/// default [`REPEAT`], 1 on a CPU adapter); `progress(done, total, workload)` hears
/// before each workload. A workload that needs larger buffers than the device allows is
/// skipped, with the reason in its row.
pub fn run(
    set: Set,
    repeat: Option<usize>,
    lighting: LightingOn,
    progress: &mut dyn FnMut(usize, usize, &Workload),
) -> Result<Report> {
    if repeat == Some(0) {
        bail!("--repeat must be at least 1");
    }
    let ctx = GpuContext::new()?;
    let timestamps = ctx.time_stages(true);
    let on = lighting.resolve(&ctx);
    let repeat = repeat.unwrap_or(if ctx.is_cpu_adapter() { 1 } else { REPEAT });
    let (name, workloads) = match set {
        Set::Quick => ("quick", quick()),
        Set::Full => ("full", workloads()),
        Set::Auto if ctx.is_cpu_adapter() => ("scaled", scaled()),
        Set::Auto => ("full", workloads()),
    };
    let mut rows = Vec::with_capacity(workloads.len());
    for (k, w) in workloads.iter().enumerate() {
        progress(k, workloads.len(), w);
        let row = match time_workload(&ctx, w, repeat, on) {
            Ok(row) => row,
            Err(e) => match e.downcast_ref::<GpuError>() {
                Some(too_large @ GpuError::TooLarge { .. }) => Row {
                    workload: *w,
                    frame: None,
                    playback: None,
                    orbit: None,
                    skipped: Some(too_large.to_string()),
                },
                _ => {
                    return Err(e.context(format!(
                        "{} RBFs, {}-class grid, {} × {}",
                        w.rbfs, w.grid, w.width, w.height
                    )));
                }
            },
        };
        rows.push(row);
    }
    Ok(Report {
        adapter: ctx.adapter_name().to_string(),
        backend: format!("{:?}", ctx.backend()),
        set: name.to_string(),
        timestamps,
        lighting_on: if on == LightingOn::Cpu { "CPU" } else { "GPU" }.to_string(),
        repeat,
        rows,
    })
}

/// The warm-up frame's grid and most RBFs: the pipelines a workload's frames use are
/// built on it, untimed.
const WARM_UP_DIMS: [usize; 3] = [16, 16, 21];
const WARM_UP_RBFS: usize = 50;

/// The three kinds of frame of one workload, after a warm-up on a small frame.
fn time_workload(ctx: &GpuContext, w: &Workload, repeat: usize, on: LightingOn) -> Result<Row> {
    let dims = w.dims();
    let bbox = Bbox::new([0.0; 3], [1.0, 1.0, 4.0 / 3.0]);
    let frames = [
        synthetic_frame(w.rbfs, dims, &bbox, 0.0)?,
        synthetic_frame(w.rbfs, dims, &bbox, 0.02)?,
        // The warm-up's: a small frame lit the same way, which builds the same pipelines
        // in a fraction of a full frame's time (on lavapipe a new frame of the 128-class
        // grid takes ~25 s, most of it lighting no pipeline needs).
        synthetic_frame(w.rbfs.min(WARM_UP_RBFS), WARM_UP_DIMS, &bbox, 0.0)?,
    ];
    let medium = Medium::new(8.0, 0.9, 0.2).map_err(anyhow::Error::msg)?;
    let camera =
        Camera::framing(bbox.min, bbox.max, FOV, w.width, w.height).map_err(anyhow::Error::msg)?;
    // Multiple scattering as `haze render` and `haze view` default to: explicit orders.
    let opts = CrmOptions {
        order: w.order,
        multiple: w.multiple,
        diffusion: MsDiffusion::DEFAULT,
        ..CrmOptions::default()
    };
    let mut r = GpuRenderer::new(ctx, Environment::sky(Sky::default()))?;
    r.set_lighting(on);
    // `fresh`: the renderer forgets the frames before (no reuse, no warm start).
    let mut render = |key: u64, f: usize, cam: &Camera, fresh: bool| -> Result<(f64, FrameStats)> {
        let (rbfs, slot) = &frames[f];
        if fresh {
            r.reset();
        }
        let input = GpuFrame {
            key,
            rbfs,
            residual: Some(Residual::Hash(slot)),
            dims: if f == 2 { WARM_UP_DIMS } else { dims },
            bbox,
        };
        let t = Instant::now();
        let (_image, stats) = r.render(ctx, &input, &medium, cam, &opts)?;
        ctx.finish("the frame")?;
        // Where a frame's host time went (the lighting on a CPU adapter): `-v`.
        tracing::info!(
            "{} RBFs, {}-class grid, {}×{}, SH {}: {}",
            w.rbfs,
            w.grid,
            w.width,
            w.height,
            w.order,
            stats.crm
        );
        Ok((t.elapsed().as_secs_f64(), stats))
    };
    render(0, 2, &camera, true)?;
    let mut key = 1;
    let mut frame = Vec::new();
    let mut playback = Vec::new();
    let mut orbit = Vec::new();
    for k in 0..repeat {
        // A density frame the renderer has not seen (a fresh key).
        frame.push(render(key, 0, &camera, true)?);
        // The animation's next frame after it: the diffusion warm-started.
        playback.push(render(key + 1, 1, &camera, false)?);
        // The camera moved around the frame just shown: the lighting's grids reused.
        let turned = orbit_camera(&camera, &bbox, 5.0 * (k + 1) as f64)?;
        orbit.push(render(key + 1, 1, &turned, false)?);
        key += 2;
    }
    Ok(Row {
        workload: *w,
        frame: Some(summarize(&frame)),
        playback: Some(summarize(&playback)),
        orbit: Some(summarize(&orbit)),
        skipped: None,
    })
}

/// `camera` turned by `degrees` about the box's vertical axis through its centre.
fn orbit_camera(camera: &Camera, bbox: &Bbox, degrees: f64) -> Result<Camera> {
    let c = [0, 1, 2].map(|a| 0.5 * (bbox.min[a] + bbox.max[a]));
    let (s, co) = degrees.to_radians().sin_cos();
    let d = [camera.eye[0] - c[0], camera.eye[1] - c[1]];
    let eye = [
        c[0] + co * d[0] - s * d[1],
        c[1] + s * d[0] + co * d[1],
        camera.eye[2],
    ];
    Camera::new(eye, c, [0.0, 0.0, 1.0], FOV, camera.width, camera.height)
        .map_err(anyhow::Error::msg)
}

/// Medians of one kind of frame.
fn summarize(frames: &[(f64, FrameStats)]) -> Timing {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let wall = median(frames.iter().map(|f| f.0).collect());
    let mut names: Vec<&'static str> = Vec::new();
    for (_, s) in frames {
        for (n, _) in &s.gpu {
            if !names.contains(n) {
                names.push(n);
            }
        }
    }
    let pass = |name: &str| {
        median(
            frames
                .iter()
                .map(|(_, s)| {
                    s.gpu
                        .iter()
                        .filter(|(n, _)| *n == name)
                        .map(|(_, t)| t)
                        .sum()
                })
                .collect(),
        )
    };
    let passes_ms: Vec<(String, f64)> = names
        .iter()
        .map(|n| (n.to_string(), 1e3 * pass(n)))
        .collect();
    // The view pass and the occupancy it skips by.
    let view: f64 = passes_ms
        .iter()
        .filter(|(n, _)| n.starts_with("view pass"))
        .map(|p| p.1)
        .sum();
    Timing {
        frame_ms: 1e3 * wall,
        fps: if wall > 0.0 { 1.0 / wall } else { 0.0 },
        lighting_ms: (1e3 * wall - view).max(0.0),
        passes_ms,
    }
}

/// A rising plume of `n` RBFs in `bbox` (risen by `rise` of its height) and its residual:
/// values of ±1…±4 steps at 1/255 of the peak on a deterministic pattern over a third of
/// the voxels inside the plume's envelope. Deterministic (an LCG), the same everywhere.
fn synthetic_frame(
    n: usize,
    dims: [usize; 3],
    bbox: &Bbox,
    rise: f64,
) -> Result<(Vec<Rbf>, ResidualSlot)> {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let size = [0, 1, 2].map(|a| bbox.max[a] - bbox.min[a]);
    // The envelope's radius at height fraction t: widening as the plume rises.
    let envelope = |t: f64| 0.08 + 0.22 * t;
    let rbfs: Vec<Rbf> = (0..n)
        .map(|_| {
            let t = uniform();
            let (angle, r) = (
                std::f64::consts::TAU * uniform(),
                envelope(t) * uniform().sqrt(),
            );
            let z = (0.08 + 0.8 * t + rise).min(0.97);
            Rbf::new(
                [
                    bbox.min[0] + size[0] * (0.5 + r * angle.cos()),
                    bbox.min[1] + size[1] * (0.5 + r * angle.sin()),
                    bbox.min[2] + size[2] * z,
                ],
                size[0] * (0.02 + 0.05 * uniform()),
                0.2 + 0.8 * uniform(),
            )
        })
        .collect();
    let [nx, ny, nz] = dims;
    let mut residual = vec![0.0f32; nx * ny * nz];
    let step = 2.0 / 255.0;
    for z in 0..nz {
        let t = ((z as f64 + 0.5) / nz as f64 - 0.08 - rise) / 0.8;
        if !(0.0..=1.0).contains(&t) {
            continue;
        }
        let reach = envelope(t);
        for y in 0..ny {
            for x in 0..nx {
                let (u, v) = (
                    (x as f64 + 0.5) / nx as f64 - 0.5,
                    (y as f64 + 0.5) / ny as f64 - 0.5,
                );
                let i = x + nx * (y + ny * z);
                if u * u + v * v <= reach * reach && (i * 7 + z) % 3 == 0 {
                    let q = 1 + (i * 13 + y) % 4;
                    let sign = if (i / 3) % 2 == 0 { 1.0 } else { -1.0 };
                    residual[i] = (sign * step * q as f64) as f32;
                }
            }
        }
    }
    let quantized = haze_hash::quantize(
        &residual,
        1.0,
        QuantOptions {
            error: 1.0 / 255.0,
            bits: 8,
        },
    )
    .map_err(anyhow::Error::msg)?;
    let d = dims.map(|v| v as u32);
    let group = ResidualGroup::build(d, 4, &[quantized], BuildOptions::default())?;
    Ok((
        rbfs,
        ResidualSlot {
            group: Arc::new(group),
            slot: 0,
        },
    ))
}

impl Report {
    /// The report as a Markdown table, one line per workload and kind of frame.
    pub fn table(&self) -> String {
        let mut out = format!(
            "adapter: {} ({}); {} set; per-pass GPU times {}; lighting on the {}; medians of {}\n\n",
            self.adapter,
            self.backend,
            self.set,
            if self.timestamps {
                "from timestamp queries"
            } else {
                "unavailable"
            },
            self.lighting_on,
            self.repeat
        );
        out.push_str("| RBFs | grid | size | SH | multiple | kind | frame ms | fps | lighting ms | volume pass ms | view pass ms |\n");
        out.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
        for r in &self.rows {
            let w = &r.workload;
            let dims = w.dims();
            let head = format!(
                "| {} | {}×{}×{} | {}×{} | {} | {} |",
                w.rbfs,
                dims[0],
                dims[1],
                dims[2],
                w.width,
                w.height,
                w.order,
                if w.multiple { "yes" } else { "no" },
            );
            if let Some(why) = &r.skipped {
                out.push_str(&format!("{head} skipped: {why} | | | | | |\n"));
                continue;
            }
            for (kind, t) in [
                ("frame", &r.frame),
                ("playback", &r.playback),
                ("orbit", &r.orbit),
            ] {
                let Some(t) = t else { continue };
                let pass = |name: &str| {
                    t.passes_ms
                        .iter()
                        .find(|(n, _)| n == name)
                        .map_or("–".to_string(), |p| format!("{:.1}", p.1))
                };
                out.push_str(&format!(
                    "{head} {kind} | {:.1} | {:.1} | {:.1} | {} | {} |\n",
                    t.frame_ms,
                    t.fps,
                    t.lighting_ms,
                    pass("volume pass"),
                    pass("view pass"),
                ));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The synthetic frames are the same on every call, inside the box, and their
    /// residual holds what was put in: every stored value a whole number of 1–4 steps of
    /// 2/255 (the quantization is exact there), on about a third of the envelope.
    #[test]
    fn synthetic_frames_are_deterministic_and_exact() {
        let bbox = Bbox::new([0.0; 3], [1.0, 1.0, 4.0 / 3.0]);
        let dims = [24, 24, 32];
        let (a, ra) = synthetic_frame(200, dims, &bbox, 0.0).unwrap();
        let (b, rb) = synthetic_frame(200, dims, &bbox, 0.0).unwrap();
        assert_eq!(a, b);
        assert_eq!(ra.dense(), rb.dense());
        for r in &a {
            assert!((0..3).all(|k| r.center[k] >= bbox.min[k] && r.center[k] <= bbox.max[k]));
            assert!(r.radius > 0.0 && r.weight > 0.0);
        }
        let (risen, _) = synthetic_frame(200, dims, &bbox, 0.02).unwrap();
        let mean_z = |v: &[Rbf]| v.iter().map(|r| r.center[2]).sum::<f64>() / v.len() as f64;
        assert!(mean_z(&risen) > mean_z(&a));
        let step = 2.0 / 255.0;
        let dense = ra.dense();
        let stored: Vec<f32> = dense.iter().copied().filter(|&v| v != 0.0).collect();
        assert!(stored.len() > dense.len() / 100, "{} stored", stored.len());
        for v in stored {
            let q = f64::from(v) / step;
            assert!(
                (q - q.round()).abs() < 1e-4 && (1.0..=4.0).contains(&q.round().abs()),
                "{v}"
            );
        }
    }

    #[test]
    fn every_workload_varies_one_thing_from_the_base() {
        let all = workloads();
        let base = all[1];
        for w in &all {
            let differs = [
                w.rbfs != base.rbfs,
                w.grid != base.grid,
                (w.width, w.height) != (base.width, base.height),
                w.order != base.order,
                w.multiple != base.multiple,
            ];
            assert!(differs.iter().filter(|&&d| d).count() <= 1, "{w:?}");
        }
        assert_eq!(base.dims(), [128, 128, 170]);
    }
}
