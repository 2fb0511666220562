//! One frame of compensated ray marching for the viewer: [`FrameRenderer`] is the one
//! seam between the viewer and the GPU pipeline, a thin layer over
//! [`haze_view::gpu::renderer::GpuRenderer`] (the view pass on the GPU, the stages before it
//! where [`LightingOn`] says) that takes a frame (RBFs and residual on a grid), a
//! medium, an environment, a camera and the [`CrmOptions`], and gives the linear picture
//! ([`FrameImage`]) and where the time went; [`FrameRenderer::encode`] turns it into the
//! 8-bit sRGB picture shown (on a GPU there, `haze_view::gpu::tone_pass`), any number of
//! times. Beside an adapter that is a CPU (lavapipe), with the lighting on the CPU, the
//! view pass runs on the CPU too ([`view_on_host`]): its shader there is emulated on the
//! same cores, about twice as slow as the CPU's own twin (BENCHMARKS.md "Viewer
//! playback").
//!
//! What carries between calls is the renderer's — the paper's reuse across frames: the
//! compiled passes, the SH tables of the order and the projected light (rebuilt when the
//! order or the environment changes), the diffusion solver (each solve starts from the
//! previous frame's solution), the sources at the centers (reused while the frame, the
//! medium, the light and the lighting options are unchanged: a camera move, the residual
//! toggle or the slice count re-run the passes only) and, with the isotropic phase
//! function, the volume-pass grids (a camera move re-runs the view pass only); the
//! environment pass's grid (the march towards the sky from every node) is kept while the
//! frame, the residual toggle, σt, the sky or map, the order and its settings hold — a
//! camera move, an albedo, `g` or light change only evaluate it again per voxel. A frame
//! is known by a hash of its RBFs, grid and residual.

use haze_gpu::{GpuContext, GpuError};
use haze_view::gpu::renderer::{GpuFrame, GpuRenderer, LightingOn, Reuse};
use haze_view::gpu::tone_pass::TonePass;
use haze_view::gpu::view_pass::ImageBuffer;
use haze_view::gpu::volume_pass::Residual;
use haze_view::render::{CrmOptions, CrmStats};
use haze_view::{Camera, Environment, Medium, Sky};
use haze_volume::{Bbox, Rbf};
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// Where the time of one [`FrameRenderer::render`] went.
#[derive(Clone, Debug, Default)]
pub struct StageTimes {
    /// Host seconds per stage (setup when the SH tables or the light were rebuilt, the
    /// passes' submission, a new frame's diffusion operators); CG iterations of the
    /// diffusion solve, read back with the image.
    pub crm: CrmStats,
    /// The sources at the centers were the previous call's (nothing they depend on
    /// changed).
    pub sources_reused: bool,
    /// The volume-pass grids were the previous call's too (view pass only).
    pub grids_reused: bool,
    /// GPU seconds per pass, from timestamp queries where the device has them.
    pub gpu: Vec<(&'static str, f64)>,
}

/// Renders frames on the GPU, reusing what did not change since the previous frame
/// (module docs).
#[derive(Debug)]
pub struct FrameRenderer {
    inner: GpuRenderer,
    tone: TonePass,
    /// The view pass runs on the host ([`view_on_host`]).
    on_host: bool,
}

/// Whether the view pass runs on the host: beside an adapter that is a CPU, with the
/// lighting on the CPU (module docs). `--lighting gpu` keeps the shaders.
pub fn view_on_host(ctx: &GpuContext, lighting: LightingOn) -> bool {
    ctx.is_cpu_adapter() && lighting.resolve(ctx) == LightingOn::Cpu
}

/// A frame's linear picture: on the GPU, or on the host ([`view_on_host`]).
#[derive(Debug)]
pub enum FrameImage {
    Gpu(ImageBuffer),
    Host(haze_core::Image),
}

impl FrameImage {
    /// The pixels (RGB, row 0 at the top), read back from the GPU where they are there.
    pub fn pixels(&self, ctx: &GpuContext) -> Result<Vec<[f32; 3]>, GpuError> {
        match self {
            FrameImage::Gpu(b) => b.read(ctx),
            FrameImage::Host(i) => Ok(i.pixels.clone()),
        }
    }
}

/// A key for the frame: equal for equal RBFs, grid and residual.
fn frame_key(rbfs: &[Rbf], residual: Option<Residual<'_>>, dims: [usize; 3], bbox: &Bbox) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for b in rbfs {
        for v in b.center.iter().chain([&b.radius, &b.weight]) {
            v.to_bits().hash(&mut h);
        }
    }
    dims.hash(&mut h);
    for v in bbox.min.iter().chain(&bbox.max) {
        v.to_bits().hash(&mut h);
    }
    match residual {
        None => 0u8.hash(&mut h),
        Some(Residual::Dense(r)) => {
            1u8.hash(&mut h);
            r.iter().for_each(|v| v.to_bits().hash(&mut h));
        }
        Some(Residual::Hash(slot)) => {
            2u8.hash(&mut h);
            (Arc::as_ptr(&slot.group) as usize).hash(&mut h);
            slot.slot.hash(&mut h);
        }
    }
    h.finish()
}

impl FrameRenderer {
    /// The most cells its explicit orders hold (`GpuRenderer::orders_cells`).
    pub fn orders_cells(&self, ctx: &GpuContext) -> usize {
        self.inner.orders_cells(ctx)
    }

    /// Compiles the GPU passes on `ctx`, lighting the centers where `lighting` says,
    /// and turns on its per-pass GPU timing.
    pub fn new(ctx: &GpuContext, lighting: LightingOn) -> Result<FrameRenderer, GpuError> {
        ctx.time_stages(true);
        let mut inner = GpuRenderer::new(ctx, Environment::sky(Sky::default()))?;
        inner.set_lighting(lighting);
        Ok(FrameRenderer {
            inner,
            tone: TonePass::new(ctx)?,
            on_host: view_on_host(ctx, lighting),
        })
    }

    /// `image` (a [`FrameRenderer::render`]'s) at `exposure` under `tone` as 8-bit sRGB,
    /// three bytes a pixel: `haze_core::Image::to_srgb8` of its pixels. On a GPU it is
    /// encoded there and read back at 4 bytes a pixel instead of 16 (the same bytes:
    /// `crates/view/tests/gpu_tone_pass.rs`); on a CPU adapter (lavapipe), where the
    /// shader's table search costs more than the host's (54 against 36 ms a 1920 × 1080
    /// picture, BENCHMARKS.md "Viewer playback"), read back and encoded on the host.
    pub fn encode(
        &self,
        ctx: &GpuContext,
        image: &FrameImage,
        exposure: f64,
        tone: haze_core::ToneMap,
    ) -> Result<Vec<u8>, GpuError> {
        let image = match image {
            FrameImage::Host(i) => return Ok(i.to_srgb8(exposure, tone)),
            FrameImage::Gpu(b) => b,
        };
        if ctx.is_cpu_adapter() {
            let (width, height) = image.size();
            let pixels = image.read(ctx)?;
            return Ok(haze_core::Image {
                width,
                height,
                pixels,
            }
            .to_srgb8(exposure, tone));
        }
        self.tone.encode(ctx, image, exposure, tone)
    }

    /// How many environment-pass grids were computed so far: the grid is kept across
    /// camera moves and albedo, `g` or light changes, and rebuilt when the frame, σt, the
    /// sky or map, the order, the residual toggle or the grid's settings change
    /// ([`GpuRenderer::env_grid_builds`]).
    #[cfg(test)]
    pub fn env_grid_builds(&self) -> u64 {
        self.inner.env_grid_builds()
    }

    /// How many shadow volumes of the lights were computed so far
    /// ([`GpuRenderer::light_shadow_builds`]).
    #[cfg(test)]
    pub fn light_shadow_builds(&self) -> u64 {
        self.inner.light_shadow_builds()
    }

    /// The image of a frame — `rbfs` and `residual` on a `dims` grid over `bbox` — lit by
    /// `env` through `medium`, seen by `camera` (RGB per pixel, row 0 at the top), as
    /// [`haze_view::render::crm_render`] computes it, left on the GPU or on the host
    /// ([`FrameImage::pixels`] brings it back, [`FrameRenderer::encode`] encodes it). The residual
    /// is left out when `opts.residual` is off. Errors are the GPU stages' (bad input,
    /// device limits, device errors).
    #[allow(clippy::too_many_arguments)]
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        rbfs: &[Rbf],
        residual: Option<Residual<'_>>,
        dims: [usize; 3],
        bbox: &Bbox,
        medium: &Medium,
        env: &Environment,
        camera: &Camera,
        opts: &CrmOptions,
    ) -> Result<(FrameImage, StageTimes), GpuError> {
        if self.inner.environment() != env {
            self.inner.set_environment(ctx, env.clone())?;
        }
        let frame = GpuFrame {
            key: frame_key(rbfs, residual, dims, bbox),
            rbfs,
            residual,
            dims,
            bbox: *bbox,
        };
        let (image, mut stats) = if self.on_host {
            let (pixels, stats) = self.inner.render_on_host(&frame, medium, camera, opts)?;
            let image = haze_core::Image {
                width: camera.width,
                height: camera.height,
                pixels,
            };
            (FrameImage::Host(image), stats)
        } else {
            let (image, stats) = self.inner.render(ctx, &frame, medium, camera, opts)?;
            (FrameImage::Gpu(image), stats)
        };
        self.inner.read_solve(ctx, &mut stats)?;
        Ok((
            image,
            StageTimes {
                crm: stats.crm,
                sources_reused: stats.reuse != Reuse::Nothing,
                grids_reused: stats.reuse == Reuse::Grids,
                gpu: stats.gpu,
            },
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{DIMS, bbox, write_asset};
    use super::*;
    use haze_view::Sky;
    use haze_view::render::crm_render;
    use haze_view::stream::{FrameDecoder, StreamFrame};
    use std::sync::Arc;

    /// These tests need a GPU adapter (lavapipe will do) and fail without one.
    fn context() -> GpuContext {
        GpuContext::new().unwrap_or_else(|e| panic!("{e}"))
    }

    fn frames(n: usize) -> (tempfile::TempDir, Vec<StreamFrame>) {
        let dir = tempfile::tempdir().unwrap();
        let path = write_asset(dir.path(), "a.haze", n);
        let mut d = FrameDecoder::new(Arc::new(haze_asset::Asset::open(&path).unwrap()));
        let frames = (0..n).map(|k| d.decode(k).unwrap()).collect();
        (dir, frames)
    }

    fn camera(azimuth: f64) -> Camera {
        let b = bbox();
        let c = [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a]));
        let eye = [
            c[0] + 6.0 * azimuth.cos(),
            c[1] + 6.0 * azimuth.sin(),
            c[2] + 1.5,
        ];
        Camera::new(eye, c, [0.0, 0.0, 1.0], 30.0, 40, 30).unwrap()
    }

    /// The GPU's image against the CPU's: `f32` arithmetic (≈ 1e-6 relative, see
    /// crates/view/tests/gpu_volume_pass.rs) and the march's early exit (a slice apart:
    /// OPAQUE = 1e-4 of the brightest radiance, the sky's sun < 10).
    fn assert_close(gpu: &[[f32; 3]], cpu: &[[f32; 3]]) {
        assert_eq!(gpu.len(), cpu.len());
        for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
            for k in 0..3 {
                assert!(
                    (g[k] - c[k]).abs() <= 1e-4 * c[k].abs() + 1e-3,
                    "pixel {i}: GPU {g:?}, CPU {c:?}"
                );
            }
        }
    }

    fn render(
        r: &mut FrameRenderer,
        ctx: &GpuContext,
        f: &StreamFrame,
        env: &Environment,
        camera: &Camera,
        opts: &CrmOptions,
    ) -> (Vec<[f32; 3]>, StageTimes) {
        let medium = Medium::new(6.0, 0.85, 0.3).unwrap();
        let residual = f.residual.as_ref().map(Residual::Hash);
        let (image, times) = r
            .render(
                ctx,
                &f.rbfs,
                residual,
                DIMS,
                &bbox(),
                &medium,
                env,
                camera,
                opts,
            )
            .unwrap();
        (image.pixels(ctx).unwrap(), times)
    }

    #[test]
    fn renders_what_crm_render_computes_and_reuses_the_sources() {
        let ctx = context();
        let (_dir, frames) = frames(2);
        let env = Environment::sky(Sky::default());
        let opts = CrmOptions::default();
        let medium = Medium::new(6.0, 0.85, 0.3).unwrap();
        let mut r = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        let f = &frames[0];
        let (a, t) = render(&mut r, &ctx, f, &env, &camera(-1.0), &opts);
        assert!(!t.sources_reused && t.crm.single_seconds > 0.0);
        assert!(t.crm.cg_iterations > 0 && t.crm.view_seconds > 0.0);
        let dense = f.residual.as_ref().unwrap().dense();
        let (cpu, _) = crm_render(
            &f.rbfs,
            Some(&dense),
            DIMS,
            &bbox(),
            &medium,
            &env,
            &camera(-1.0),
            &opts,
        );
        assert_close(&a, &cpu.pixels);
        if view_on_host(&ctx, LightingOn::Auto) {
            // Beside a CPU adapter the picture is the CPU renderer's own.
            assert_eq!(a, cpu.pixels);
        }
        // The smoke is in the picture: the middle differs from the empty sky's.
        let (sky, _) = crm_render(
            &[],
            None,
            DIMS,
            &bbox(),
            &medium,
            &env,
            &camera(-1.0),
            &opts,
        );
        let mid = 15 * 40 + 20;
        assert!((cpu.pixels[mid][2] - sky.pixels[mid][2]).abs() > 0.05);

        // Another camera, the same frame and light: the sources are the first render's,
        // so the image is a fresh renderer's to the bit.
        let (b, t) = render(&mut r, &ctx, f, &env, &camera(0.5), &opts);
        assert!(t.sources_reused);
        assert_eq!((t.crm.single_seconds, t.crm.cg_iterations), (0.0, 0));
        let mut fresh = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        assert_eq!(b, render(&mut fresh, &ctx, f, &env, &camera(0.5), &opts).0);
        assert_ne!(a, b);
        // Without the residual, or with other slices: the passes only, and the CPU's
        // image of those options.
        for o in [
            CrmOptions {
                residual: false,
                ..opts
            },
            CrmOptions {
                slices_per_voxel: 3.0,
                ..opts
            },
        ] {
            let (c, t) = render(&mut r, &ctx, f, &env, &camera(0.5), &o);
            // On a CPU adapter the light is the CPU's, whose every stage but the centers
            // reads the density: each of these toggles the residual against the render
            // before it, which computes that light again.
            let host = LightingOn::Auto.resolve(&ctx) == LightingOn::Cpu;
            assert_eq!(t.sources_reused, !host);
            let resid = o.residual.then_some(dense.as_slice());
            let medium = Medium::new(6.0, 0.85, 0.3).unwrap();
            let (cpu, _) = crm_render(
                &f.rbfs,
                resid,
                DIMS,
                &bbox(),
                &medium,
                &env,
                &camera(0.5),
                &o,
            );
            assert_close(&c, &cpu.pixels);
        }
    }

    /// The environment pass's grid is computed once per frame, σt, sky, order and
    /// residual toggle: a camera move, a new albedo or `g` and a new point light reuse it;
    /// the lights' shadow volume once per frame, σt and light position; every picture is
    /// a fresh renderer's to the bit (single scattering: no warm-started solve to tell
    /// them apart). Every stage on the GPU (the CPU's light keeps its environment grid
    /// alike: `crates/view/tests/gpu_renderer.rs`).
    #[test]
    fn the_environment_grid_is_rebuilt_exactly_when_what_it_depends_on_changes() {
        let ctx = context();
        let (_dir, frames) = frames(2);
        let opts = CrmOptions {
            multiple: false,
            ..CrmOptions::default()
        };
        assert!(matches!(
            opts.env_source,
            haze_view::render::env_pass::EnvSource::Grid(_)
        ));
        let sky = Environment::sky(Sky::default());
        let m = Medium::new(6.0, 0.85, 0.3).unwrap();
        let shot = |r: &mut FrameRenderer,
                    k: usize,
                    m: &Medium,
                    env: &Environment,
                    cam: &Camera,
                    o: &CrmOptions| {
            let f = &frames[k];
            let residual = f.residual.as_ref().map(Residual::Hash);
            let (image, times) = r
                .render(&ctx, &f.rbfs, residual, DIMS, &bbox(), m, env, cam, o)
                .unwrap();
            (image.pixels(&ctx).unwrap(), times)
        };
        // Each picture against a fresh renderer's, which builds its one grid.
        let fresh = |k: usize, m: &Medium, env: &Environment, cam: &Camera, o: &CrmOptions| {
            let mut f = FrameRenderer::new(&ctx, LightingOn::Gpu).unwrap();
            let (pixels, _) = shot(&mut f, k, m, env, cam, o);
            assert_eq!(f.env_grid_builds(), 1);
            pixels
        };
        let mut r = FrameRenderer::new(&ctx, LightingOn::Gpu).unwrap();
        let (first, t) = shot(&mut r, 0, &m, &sky, &camera(-1.0), &opts);
        assert_eq!(r.env_grid_builds(), 1);
        assert!(t.crm.env_seconds > 0.0);

        // A camera move (g ≠ 0: the volume grids are rebuilt, the environment's is not).
        let (moved, t) = shot(&mut r, 0, &m, &sky, &camera(0.5), &opts);
        assert!(t.sources_reused && !t.grids_reused);
        assert_eq!(r.env_grid_builds(), 1);
        assert_ne!(moved, first);
        assert_eq!(moved, fresh(0, &m, &sky, &camera(0.5), &opts));

        // Albedo and g enter per voxel only; a point light is the lights pass's.
        let other = Medium::new(6.0, 0.5, -0.4).unwrap();
        let (p, _) = shot(&mut r, 0, &other, &sky, &camera(0.5), &opts);
        assert_eq!(r.env_grid_builds(), 1);
        assert_eq!(p, fresh(0, &other, &sky, &camera(0.5), &opts));
        let b = bbox();
        let mut lit = sky.clone();
        lit.points.push(
            haze_view::PointLight::new([b.max[0] + 0.5, b.min[1], b.max[2]], [2.0; 3]).unwrap(),
        );
        shot(&mut r, 0, &other, &lit, &camera(0.5), &opts);
        assert_eq!((r.env_grid_builds(), r.light_shadow_builds()), (1, 1));
        // The lights' shadow volume is kept across a camera move and a brighter light,
        // and marched again for a moved light.
        let (p, _) = shot(&mut r, 0, &other, &lit, &camera(-1.0), &opts);
        assert_eq!((r.env_grid_builds(), r.light_shadow_builds()), (1, 1));
        assert_eq!(p, fresh(0, &other, &lit, &camera(-1.0), &opts));
        lit.points[0].intensity = [5.0; 3];
        shot(&mut r, 0, &other, &lit, &camera(-1.0), &opts);
        assert_eq!(r.light_shadow_builds(), 1);
        lit.points[0].position[2] -= 0.3;
        shot(&mut r, 0, &other, &lit, &camera(-1.0), &opts);
        assert_eq!((r.env_grid_builds(), r.light_shadow_builds()), (1, 2));

        // σt, the frame, the residual toggle, the order and the sky each rebuild it.
        let thick = Medium::new(9.0, 0.5, -0.4).unwrap();
        let (p, _) = shot(&mut r, 0, &thick, &sky, &camera(0.5), &opts);
        assert_eq!(r.env_grid_builds(), 2);
        assert_eq!(p, fresh(0, &thick, &sky, &camera(0.5), &opts));
        shot(&mut r, 1, &thick, &sky, &camera(0.5), &opts);
        assert_eq!(r.env_grid_builds(), 3);
        let no_residual = CrmOptions {
            residual: false,
            ..opts
        };
        shot(&mut r, 1, &thick, &sky, &camera(0.5), &no_residual);
        assert_eq!(r.env_grid_builds(), 4);
        let o2 = CrmOptions { order: 2, ..opts };
        shot(&mut r, 1, &thick, &sky, &camera(0.5), &o2);
        assert_eq!(r.env_grid_builds(), 5);
        let low_sun = Environment::sky(Sky {
            sun_direction: [0.6, -0.8, 0.0],
            ..Sky::default()
        });
        shot(&mut r, 1, &thick, &low_sun, &camera(0.5), &o2);
        assert_eq!(r.env_grid_builds(), 6);
        // And back to a camera move: kept again.
        let (p, _) = shot(&mut r, 1, &thick, &low_sun, &camera(-0.3), &o2);
        assert_eq!(r.env_grid_builds(), 6);
        assert_eq!(p, fresh(1, &thick, &low_sun, &camera(-0.3), &o2));
    }

    #[test]
    fn the_light_the_order_and_the_frame_are_recomputed_when_they_change() {
        let ctx = context();
        let (_dir, frames) = frames(2);
        let mut r = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        let cam = camera(-0.7);
        let opts = CrmOptions::default();
        let sky = Sky::default();
        render(
            &mut r,
            &ctx,
            &frames[0],
            &Environment::sky(sky.clone()),
            &cam,
            &opts,
        );
        // The sun moved: a new projection, new sources — a fresh renderer's image.
        let low_sun = Environment::sky(Sky {
            sun_direction: [0.6, -0.8, 0.0],
            ..sky.clone()
        });
        let (a, t) = render(&mut r, &ctx, &frames[0], &low_sun, &cam, &opts);
        assert!(!t.sources_reused && t.crm.single_seconds > 0.0);
        let mut fresh = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        assert_close(
            &a,
            &render(&mut fresh, &ctx, &frames[0], &low_sun, &cam, &opts).0,
        );
        // Order 2: new SH tables.
        let o2 = CrmOptions { order: 2, ..opts };
        let (b, t) = render(&mut r, &ctx, &frames[0], &low_sun, &cam, &o2);
        assert!(!t.sources_reused);
        let mut fresh = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        assert_close(
            &b,
            &render(&mut fresh, &ctx, &frames[0], &low_sun, &cam, &o2).0,
        );
        // The next frame: its diffusion starts from this one's solution and converges to
        // the same image.
        let (c, t) = render(&mut r, &ctx, &frames[1], &low_sun, &cam, &opts);
        assert!(!t.sources_reused);
        let mut fresh = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        assert_close(
            &c,
            &render(&mut fresh, &ctx, &frames[1], &low_sun, &cam, &opts).0,
        );
        // The warm start, seen through a solve cut short at two CG iterations: from the
        // previous frame's solution it gets much closer than from zero.
        let short = CrmOptions {
            solve: haze_view::SolveOptions {
                max_iterations: 2,
                tolerance: 1e-12,
            },
            ..opts
        };
        render(&mut r, &ctx, &frames[0], &low_sun, &cam, &short);
        let (_, warm) = render(&mut r, &ctx, &frames[1], &low_sun, &cam, &short);
        let mut fresh = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        let (_, cold) = render(&mut fresh, &ctx, &frames[1], &low_sun, &cam, &short);
        assert_eq!((warm.crm.cg_iterations, cold.crm.cg_iterations), (2, 2));
        assert!(
            warm.crm.cg_residual < 0.5 * cold.crm.cg_residual,
            "warm {:.2e} vs cold {:.2e}",
            warm.crm.cg_residual,
            cold.crm.cg_residual
        );
    }

    #[test]
    fn suns_and_point_lights_light_frames_and_the_panel_moves_the_sun() {
        // A --sun and a --light: the GPU lights pass and the diffusion's direct light give
        // the CPU's image; the panel's sliders move the sun (`app::move_sun`), which
        // recomputes the sources and gives the CPU's image of the moved sun.
        let ctx = context();
        let (_dir, frames) = frames(1);
        let f = &frames[0];
        let dense = f.residual.as_ref().unwrap().dense();
        let b = bbox();
        let c = [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a]));
        let mut env = Environment::sky(Sky::default());
        env.suns
            .push(haze_view::Sun::from_radiance([0.3, -0.4, 0.85], [5e4; 3], 0.53).unwrap());
        env.points.push(
            haze_view::PointLight::new([c[0] + 1.5, c[1] - 0.5, c[2]], [3.0, 2.5, 2.0]).unwrap(),
        );
        let opts = CrmOptions::default();
        let medium = Medium::new(6.0, 0.85, 0.3).unwrap();
        let cam = camera(-1.0);
        let cpu = |env: &Environment| {
            crm_render(&f.rbfs, Some(&dense), DIMS, &b, &medium, env, &cam, &opts)
                .0
                .pixels
        };
        let mut r = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        let (lit, t) = render(&mut r, &ctx, f, &env, &cam, &opts);
        assert!(t.crm.lights_seconds > 0.0);
        assert_close(&lit, &cpu(&env));
        let moved = super::super::app::move_sun(&env, 200.0, 25.0).unwrap();
        let (other, t) = render(&mut r, &ctx, f, &moved, &cam, &opts);
        assert!(!t.sources_reused, "a moved sun relights the centers");
        assert_close(&other, &cpu(&moved));
        let change = lit
            .iter()
            .zip(&other)
            .map(|(p, q)| (p[0] - q[0]).abs())
            .fold(0.0f32, f32::max);
        assert!(
            change > 0.05,
            "moving the sun changed the image by {change}"
        );
    }
}
