//! The smoke room (`haze view FILE.haze`): plays a baked asset, lit and rendered as it
//! plays by compensated ray marching (paper A §5–6), with an orbit camera and live knobs.
//!
//! - [`playback`]: the clock — which frame is due, what was shown on time, what dropped;
//! - [`frame`]: one frame's render (the light on the CPU or the GPU, the view pass on the
//!   GPU), reusing what did not change;
//! - [`worker`]: the render thread (frame stream, GPU context, renderer);
//! - [`player`]: the clock driving the render thread, shared by the window and
//!   `--no-window`;
//! - [`detail`]: the lighting's detail while playing, lowered while the lighting holds
//!   playback back;
//! - [`app`]: the room's panel, keys and picture in the window;
//! - [`budget`]: the starting knobs chosen for a time budget or an error target;
//! - [`thick`]: the grid each frame is lit on, finer where its voxels are optically thick;
//! - [`lamps`]: whether a point light sits in the smoke, where the picture near it is
//!   approximate.

mod app;
pub mod budget;
mod detail;
pub mod frame;
mod lamps;
pub(crate) mod playback;
mod player;
#[cfg(test)]
mod testing;
mod thick;
mod worker;

use crate::orbit::Orbit;
use anyhow::{Result, anyhow, bail};
pub use haze_core::ToneMap;
use haze_gpu::GpuContext;
use haze_view::gpu::renderer::LightingOn;
use haze_view::render::env_pass::{EnvGridOptions, EnvSource};
use haze_view::render::{CrmOptions, MsDiffusion};
use haze_view::stream::FrameStream;
use haze_view::{Environment, Medium};
use playback::Playback;
use player::{Player, View};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use worker::{FrameCursor, Scene, Worker};

/// Frames the background reader decodes ahead of the renderer.
const READ_AHEAD: usize = 4;

/// Everything `haze view` was asked to do.
#[derive(Debug)]
pub struct ViewArgs {
    pub input: PathBuf,
    /// Frames per second; 0: as fast as they render.
    pub fps: f64,
    /// Render resolution.
    pub width: usize,
    pub height: usize,
    /// Vertical field of view, degrees.
    pub fov: f64,
    pub env: haze_render::lights::Lights,
    /// The starting values of the window's knobs.
    pub knobs: Knobs,
    /// Play this many seconds from the first picture, print the figures, exit.
    pub play_for: Option<f64>,
    /// Play without a window (with `play_for`).
    pub window: bool,
    /// Without a window: turn the camera on the first frame, paused, instead of playing.
    pub orbit: bool,
    /// Where a frame's light (every stage before the view pass) is computed.
    pub lighting: LightingOn,
    /// How much finer than the asset's voxels each frame is lit (`thick` module).
    pub supersample: haze_render::smoke::Supersample,
    /// Whether a ground shows under the smoke, at the floor of the asset's box.
    pub ground: haze_render::lights::GroundChoice,
    /// Start with the knobs a tradeoff sweep's front gives for this budget or target.
    pub goal: Option<haze_tradeoff::pareto::Goal>,
    /// The sweep for `goal`; a quick sweep of the asset when absent.
    pub tradeoff: Option<PathBuf>,
}

/// The knobs of the window, with their values from the command line.
#[derive(Clone, Debug, PartialEq)]
pub struct Knobs {
    pub sigma_t: f64,
    pub albedo: f64,
    pub g: f64,
    pub sh_order: usize,
    pub slices: f64,
    pub multiple: bool,
    pub residual: bool,
    /// The sky's single scattering per voxel by the environment pass (else at the RBF
    /// centers, paper A §5.3).
    pub sky_per_voxel: bool,
    /// Multiple scattering by the explicit orders on a coarse grid (with the sky per
    /// voxel, which lights them; `haze render --diffusion orders`), else by paper A's
    /// diffusion at the RBF centers.
    pub orders: bool,
    /// The explicit orders' cells and count ([`MsDiffusion::DEFAULT`] unless a budget's
    /// choice named others).
    pub orders_model: MsDiffusion,
    pub exposure: f64,
    /// The picture's tone curve (the panel's "filmic tone map").
    pub tone: ToneMap,
    /// The ground under the smoke (the panel's "ground"), set from
    /// [`ViewArgs::ground`] and the asset's box.
    pub ground: Option<haze_view::ground::Ground>,
}

impl Knobs {
    /// The rendering knobs in words ("SH order 2, 1 slice per voxel, single scattering,
    /// residual on"; multiple scattering names its model, `--diffusion`'s spelling, when
    /// it is not the default).
    pub fn describe(&self) -> String {
        format!(
            "SH order {}, {} slice{} per voxel, {}, residual {}",
            self.sh_order,
            self.slices,
            if self.slices == 1.0 { "" } else { "s" },
            if !self.multiple {
                "single scattering".to_string()
            } else if !(self.orders && self.sky_per_voxel) {
                "single + multiple scattering (centers)".to_string()
            } else if self.orders_model != MsDiffusion::DEFAULT {
                format!(
                    "single + multiple scattering ({})",
                    haze_render::smoke::diffusion_name(self.orders_model)
                )
            } else {
                "single + multiple scattering".to_string()
            },
            if self.residual { "on" } else { "off" }
        ) + if self.sky_per_voxel {
            ""
        } else {
            ", sky at the centers"
        }
    }

    /// The medium and the renderer's options of these knobs.
    fn scene(&self, env: Arc<Environment>) -> Result<Scene, String> {
        // The smoke above a ground does not see the lights below it (`haze_view::ground`).
        let env = match self.ground.and_then(|g| g.hiding(&env)) {
            Some((seen, _)) => Arc::new(seen),
            None => env,
        };
        Ok(Scene {
            medium: Medium::new(self.sigma_t, self.albedo, self.g)?,
            env,
            opts: CrmOptions {
                order: self.sh_order,
                multiple: self.multiple,
                residual: self.residual,
                slices_per_voxel: self.slices,
                env_source: if self.sky_per_voxel {
                    EnvSource::Grid(EnvGridOptions::default())
                } else {
                    EnvSource::Centers
                },
                // The explicit orders take the sky per voxel (on the GPU it lights them).
                diffusion: if self.orders && self.sky_per_voxel {
                    self.orders_model
                } else {
                    MsDiffusion::Centers
                },
                ground: self.ground,
                ..CrmOptions::default()
            },
        })
    }
}

/// Plays the asset `a` names: in the window, or without one for `--play-for`.
pub fn run(mut a: ViewArgs) -> Result<()> {
    if a.input.is_dir() {
        bail!(
            "{}: a directory, not a baked asset (haze bake makes a .haze file of it)",
            a.input.display()
        );
    }
    if let Some(goal) = a.goal {
        budget::choose_knobs(&mut a, goal)?;
    }
    // The viewer's own start (a choice's sweep is not part of its first picture).
    let started = Instant::now();
    // Every knob is checked before anything opens.
    let mut knobs = a.knobs;
    haze_render::smoke::check_knobs(knobs.sh_order, knobs.slices)?;
    Medium::new(knobs.sigma_t, knobs.albedo, knobs.g).map_err(|e| anyhow!("{e}"))?;
    if let Some(w) = haze_view::sh::phase_cut_warning(knobs.g, knobs.sh_order) {
        tracing::warn!("{w}");
    }
    if !(knobs.exposure > 0.0 && knobs.exposure.is_finite()) {
        bail!(
            "--exposure {} must be positive",
            haze_core::number::shown(knobs.exposure)
        );
    }
    if let Some(s) = a.play_for
        && !(s > 0.0 && s.is_finite())
    {
        bail!("--play-for {s} must be a positive number of seconds");
    }
    if !a.window && a.play_for.is_none() {
        bail!("--no-window plays only for a while: give --play-for SECONDS");
    }
    // A map is read once: the panel's "map turn" slider turns it live.
    let map = a.env.turnable()?;
    let env = Arc::new(match &map {
        Some(m) => m.as_given()?,
        None => a.env.environment()?,
    });

    // The asset: its first frame is read now, so a file that is not a baked asset is
    // refused before any window opens; it also places the camera.
    let stream = FrameStream::open(&a.input, READ_AHEAD, true)?;
    let numbers = stream.frame_numbers().to_vec();
    let playback = Playback::new(stream.frame_count(), a.fps).map_err(|e| anyhow!(e))?;
    let (dims, bbox) = stream.grid();
    knobs.ground = a.ground.ground(&a.env, bbox.min[2]);
    if let Some(g) = knobs.ground {
        for line in g.hidden(&env) {
            tracing::warn!("{line}");
        }
    }
    let mut cursor = FrameCursor::new(stream, READ_AHEAD);
    let first = cursor.get(0).map_err(|e| anyhow!(e))?;
    let residual = first.residual.as_ref().map(|s| (&*s.group, s.slot));
    let (density, _) = haze_bake::export::frame_density(dims, bbox, &first.rbfs, residual)?;
    if density.data().iter().all(|&d| d <= 0.0) {
        tracing::warn!(
            "{}: its first frame ({}) holds no smoke, so the camera frames the whole grid{}",
            a.input.display(),
            numbers.first().copied().unwrap_or_default(),
            if numbers.len() > 1 {
                ""
            } else {
                " and the picture shows none"
            }
        );
    }
    let smoke = haze_render::frame::smoke_bbox(&density);
    let orbit = Orbit::framing(&smoke, a.fov, a.width, a.height)
        .map_err(|e| anyhow!("{}: cannot frame the smoke: {e}", a.input.display()))?;

    let ctx = GpuContext::new().map_err(|e| anyhow!("GPU: {e}"))?;
    thick::Refiner::check(
        a.supersample,
        dims,
        haze_view::gpu::GridBuffer::max_voxels(&ctx),
    )
    .map_err(|e| anyhow!("{}: {e}", a.input.display()))?;
    let adapter = format!(
        "{} ({}); {} on the {}",
        ctx.adapter_name(),
        ctx.backend(),
        if frame::view_on_host(&ctx, a.lighting) {
            "lighting and view pass"
        } else {
            "lighting"
        },
        match a.lighting.resolve(&ctx) {
            LightingOn::Cpu => "CPU",
            _ => "GPU",
        }
    );
    tracing::info!("GPU: {adapter}");
    // The first view (also the proof that the window's camera and scene are valid).
    let initial = View {
        camera: orbit
            .camera(a.width, a.height)
            .map_err(|e| anyhow!("camera: {e}"))?,
        scene: knobs.scene(env.clone()).map_err(|e| anyhow!(e))?,
        exposure: knobs.exposure,
        tone: knobs.tone,
    };

    if !a.window {
        let play_for = a.play_for.unwrap_or_default();
        let worker = Worker::spawn(cursor, ctx, a.lighting, a.supersample, Box::new(|| {}))?;
        let mut player = Player::new(playback, worker, started);
        let line = if a.orbit {
            turn_without_window(&mut player, orbit, initial, play_for)?
        } else {
            play_without_window(&mut player, &initial, play_for)?
        };
        let grid = player.grid.map(|g| format!("; {}", g.describe()));
        println!("{line}; {}{}", knobs.describe(), grid.unwrap_or_default());
        return Ok(());
    }
    app::run_window(app::Setup {
        title: format!("haze view — {}", a.input.display()),
        cursor,
        ctx,
        lighting: a.lighting,
        supersample: a.supersample,
        playback,
        started,
        settings: app::Settings {
            adapter,
            numbers,
            orbit,
            knobs,
            env,
            map,
            floor: haze_view::ground::Ground::at(bbox.min[2]),
            size: (a.width, a.height),
            play_for: a.play_for,
        },
    })
}

/// Plays for `seconds` from the first picture with the view fixed, without a window, and
/// gives the measurement line.
fn play_without_window(player: &mut Player, view: &View, seconds: f64) -> Result<String> {
    let (w, h) = (view.camera.width, view.camera.height);
    loop {
        let now = Instant::now();
        let update = player.update(now, view);
        if let Some(e) = &player.first_failure {
            bail!("{e}");
        }
        let left = match player.first_picture {
            Some(_) => seconds - player.report(now).seconds,
            None => seconds,
        };
        if player.first_picture.is_some() && left <= 0.0 {
            return Ok(player.summary(now, w, h));
        }
        let mut wait = Duration::from_secs_f64(left.clamp(0.0, 0.05));
        if let Some(at) = update.wake_at {
            wait = wait.min(at.saturating_duration_since(now));
        }
        player.wait(wait);
    }
}

/// Pauses on the first frame and renders it for `seconds`, turning the camera by a
/// degree after each picture, without a window; gives the measurement line (the pictures'
/// median and mean time, from one picture on screen to the next).
fn turn_without_window(
    player: &mut Player,
    mut orbit: Orbit,
    mut view: View,
    seconds: f64,
) -> Result<String> {
    let (w, h) = (view.camera.width, view.camera.height);
    player.playback.pause();
    let mut last: Option<Instant> = None;
    let mut times = Vec::new();
    let start = Instant::now();
    loop {
        let now = Instant::now();
        let update = player.update(now, &view);
        if let Some(e) = &player.first_failure {
            bail!("{e}");
        }
        if update.shown.is_some() {
            if let Some(t) = last {
                times.push(now.duration_since(t).as_secs_f64());
            }
            last = Some(now);
            if start.elapsed().as_secs_f64() >= seconds && !times.is_empty() {
                break;
            }
            orbit.drag(1f64.to_radians() / crate::orbit::RADIANS_PER_PIXEL, 0.0);
            view.camera = orbit.camera(w, h).map_err(|e| anyhow!("camera: {e}"))?;
            continue;
        }
        player.wait(Duration::from_millis(50));
    }
    let mean = times.iter().sum::<f64>() / times.len() as f64;
    times.sort_by(f64::total_cmp);
    Ok(format!(
        "turned {} pictures of {w}×{h} on the first frame, paused: median {:.1} ms, mean {:.1} ms; render mean {:.1} ms",
        times.len() + 1,
        1e3 * times[times.len() / 2],
        1e3 * mean,
        1e3 * player.mean_render_seconds()
    ) + &player.moving_words())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The panel's sky switch picks the renderer's environment source, and the knobs'
    /// words say so only when it is off.
    #[test]
    fn the_sky_switch_picks_the_environment_source() {
        let on = super::testing::default_knobs();
        let off = Knobs {
            sky_per_voxel: false,
            ..on.clone()
        };
        let env = Arc::new(Environment::sky(haze_view::Sky::default()));
        let source = |k: &Knobs| k.scene(env.clone()).unwrap().opts.env_source;
        assert!(matches!(source(&on), EnvSource::Grid(_)));
        assert_eq!(source(&off), EnvSource::Centers);
        assert!(!on.describe().contains("sky"), "{}", on.describe());
        assert!(off.describe().ends_with(", sky at the centers"));
        assert!(
            on.describe()
                .contains("2 slices per voxel, single + multiple scattering, residual on"),
            "{}",
            on.describe()
        );
        assert!(
            off.describe()
                .contains("single + multiple scattering (centers)")
        );
        // The explicit orders need the sky per voxel; their switch picks the diffusion.
        let diffusion = |k: &Knobs| k.scene(env.clone()).unwrap().opts.diffusion;
        assert_eq!(diffusion(&on), MsDiffusion::DEFAULT);
        assert_eq!(diffusion(&off), MsDiffusion::Centers);
        let centers = Knobs {
            orders: false,
            ..on.clone()
        };
        assert_eq!(diffusion(&centers), MsDiffusion::Centers);
        let cheaper = MsDiffusion::Orders {
            factor: 3,
            orders: 3,
        };
        let chosen = Knobs {
            orders_model: cheaper,
            ..on.clone()
        };
        assert_eq!(diffusion(&chosen), cheaper);
        assert!(
            chosen
                .describe()
                .contains("multiple scattering (orders:3:3)")
        );
    }

    /// With the ground on, the scene's smoke does not see the sun once the slider takes
    /// it below the horizon (`haze_view::ground`); without it, the sun is kept.
    #[test]
    fn the_ground_hides_the_sun_below_the_horizon() {
        let mut knobs = Knobs {
            ground: Some(haze_view::ground::Ground::at(0.0)),
            ..super::testing::default_knobs()
        };
        let mut sky = Environment::sky(haze_view::Sky::default());
        sky.suns.push(haze_view::Sun {
            direction: [0.0, 0.6, 0.8],
            irradiance: [12.0, 10.8, 9.0],
            angle: 0.53f64.to_radians(),
        });
        let below = app::move_sun(&sky, 150.0, -5.0).expect("the sun moves");
        let seen = knobs.scene(Arc::new(below.clone())).unwrap().env;
        assert_eq!(seen.suns[0].irradiance, [0.0; 3]);
        assert_eq!(seen.distant, below.distant, "the sky is kept");
        let above = app::move_sun(&sky, 150.0, 5.0).expect("the sun moves");
        assert_eq!(*knobs.scene(Arc::new(above.clone())).unwrap().env, above);
        knobs.ground = None;
        assert_eq!(*knobs.scene(Arc::new(below.clone())).unwrap().env, below);
    }
}
