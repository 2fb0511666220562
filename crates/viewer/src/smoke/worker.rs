//! The viewer's render thread: it owns the asset's frame stream, the headless GPU context
//! and the [`FrameRenderer`], takes one [`Job`] at a time and hands back a tone-mapped
//! picture, so the window stays responsive while a frame renders.
//!
//! A job whose frame, camera and scene equal the previous job's is not rendered again:
//! the kept linear picture, still on the GPU, is only encoded again at the new exposure
//! (`FrameRenderer::encode`).

use super::detail;
use super::frame::{FrameImage, FrameRenderer, StageTimes};
use super::lamps::{LampCheck, Lamps};
use super::playback::Tick;
use super::thick::{FrameDensity, Grid, Refiner};
use haze_gpu::GpuContext;
use haze_render::smoke::Supersample;
use haze_view::gpu::GridBuffer;
use haze_view::gpu::renderer::LightingOn;
use haze_view::gpu::volume_pass::Residual;
use haze_view::render::CrmOptions;
use haze_view::stream::{FrameStream, StreamFrame};
use haze_view::{Camera, Environment, Medium};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What lights the frame and how: everything but the frame, the camera and the exposure.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub medium: Medium,
    pub env: Arc<Environment>,
    pub opts: CrmOptions,
}

/// One picture to make.
#[derive(Clone, Debug)]
pub struct Job {
    /// The playback tick it is for (`None`: a still, shown as soon as it is ready).
    pub tick: Option<Tick>,
    /// The asset frame (0-based).
    pub frame: usize,
    pub camera: Camera,
    pub scene: Scene,
    /// Linear radiance is multiplied by it before the tone curve and the sRGB encoding.
    pub exposure: f64,
    pub tone: haze_core::ToneMap,
    /// Light at the floor of the frame's thickness ([`detail::floor`]) rather than at
    /// `scene.opts.detail`, where that is lower: the first picture of playback where the
    /// lighting runs on the CPU, in about a third of a full-detail frame's time.
    pub at_floor: bool,
}

/// A finished picture: 8-bit sRGB, three bytes per pixel, row 0 at the top.
#[derive(Debug)]
pub struct Picture {
    /// The source frame number.
    pub number: i64,
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<u8>,
    /// The stages' times, `None` when the previous render was only tone-mapped again.
    pub times: Option<StageTimes>,
    /// The grid the frame was lit on (`thick` module).
    pub grid: Grid,
    /// Its point lights' share of first scattering near them (`lamps` module).
    pub lamps: Lamps,
    /// The lighting's detail it was lit at (`CrmOptions::detail`).
    pub detail: f64,
}

/// A job done, with how long it took on the render thread.
#[derive(Debug)]
pub struct Done {
    pub tick: Option<Tick>,
    pub seconds: f64,
    /// The lighting's detail the picture was lit at (`CrmOptions::detail`; the job's,
    /// where there is no picture).
    pub detail: f64,
    /// The picture, or why there is none (a damaged frame, a GPU error), on one line.
    pub picture: Result<Picture, String>,
}

/// Reads the frames a renderer asks for out of a looping [`FrameStream`]: the next ones by
/// taking them from its read-ahead queue (skipping a few on the way when playback skips
/// them), any other by seeking. The frame asked for last is kept.
#[derive(Debug)]
pub struct FrameCursor {
    stream: FrameStream,
    /// Skips up to this many frames by reading through them; farther jumps seek.
    ahead: usize,
    /// The frame the stream delivers next.
    next: usize,
    current: Option<StreamFrame>,
}

impl FrameCursor {
    /// A cursor over `stream`, which must be looping and at its start (frame 0); `ahead`
    /// is its read-ahead.
    pub fn new(stream: FrameStream, ahead: usize) -> FrameCursor {
        FrameCursor {
            stream,
            ahead,
            next: 0,
            current: None,
        }
    }

    pub fn stream(&self) -> &FrameStream {
        &self.stream
    }

    /// Frame `k` (0-based, below the frame count) or its one-line error.
    pub fn get(&mut self, k: usize) -> Result<&StreamFrame, String> {
        if self.current.as_ref().is_some_and(|f| f.index == k) {
            return Ok(self.current.as_ref().expect("checked above"));
        }
        let count = self.stream.frame_count();
        if (k + count - self.next) % count > self.ahead {
            self.stream.seek(k);
            self.next = k;
        }
        self.current = None;
        loop {
            let i = self.next;
            let frame = self.stream.next_frame().ok_or_else(|| {
                format!("{}: the frame reader stopped", self.stream.path().display())
            })?;
            self.next = (i + 1) % count;
            if i == k {
                return frame.map(|f| &*self.current.insert(f));
            }
        }
    }
}

/// The render thread (module docs).
#[derive(Debug)]
pub struct Worker {
    jobs: Option<Sender<Job>>,
    done: Receiver<Done>,
    thread: Option<JoinHandle<()>>,
    busy: bool,
    /// The frames' lighting runs on the CPU (`LightingOn::Cpu`, as `Auto` resolves beside
    /// an adapter that is a CPU).
    lights_on_host: bool,
}

/// The previous render, kept to tone-map it again.
struct Kept {
    frame: usize,
    camera: Camera,
    scene: Scene,
    image: FrameImage,
    number: i64,
    grid: Grid,
    lamps: Lamps,
}

impl Worker {
    /// Compiles the GPU passes on `ctx` and starts the thread, which reads frames through
    /// `cursor`, lights each on the grid `supersample` asks for (`thick` module) and calls
    /// `wake` after every job (to repaint a window).
    pub fn spawn(
        mut cursor: FrameCursor,
        ctx: GpuContext,
        lighting: LightingOn,
        supersample: Supersample,
        wake: Box<dyn Fn() + Send>,
    ) -> anyhow::Result<Worker> {
        let lights_on_host = lighting.resolve(&ctx) == LightingOn::Cpu;
        let renderer =
            FrameRenderer::new(&ctx, lighting).map_err(|e| anyhow::anyhow!("GPU: {e}"))?;
        let mut refiner = Refiner::new(supersample, GridBuffer::max_voxels(&ctx));
        let mut lamps = LampCheck::default();
        let (jobs, inbox) = channel::<Job>();
        let (outbox, done) = channel();
        let thread = std::thread::Builder::new()
            .name("haze-render".into())
            .spawn(move || {
                let mut renderer = renderer;
                let mut kept = None;
                while let Ok(job) = inbox.recv() {
                    let t = Instant::now();
                    let picture = run_job(
                        &ctx,
                        &mut renderer,
                        (&mut refiner, &mut lamps),
                        &mut cursor,
                        &job,
                        &mut kept,
                    );
                    let done = Done {
                        tick: job.tick,
                        seconds: t.elapsed().as_secs_f64(),
                        detail: picture.as_ref().map_or(job.scene.opts.detail, |p| p.detail),
                        picture,
                    };
                    if outbox.send(done).is_err() {
                        return;
                    }
                    wake();
                }
            })
            .map_err(|e| anyhow::anyhow!("cannot start the render thread: {e}"))?;
        Ok(Worker {
            jobs: Some(jobs),
            done,
            thread: Some(thread),
            busy: false,
            lights_on_host,
        })
    }

    /// The frames' lighting runs on the CPU.
    pub fn lights_on_host(&self) -> bool {
        self.lights_on_host
    }

    /// A job is being worked on.
    pub fn busy(&self) -> bool {
        self.busy
    }

    /// Hands `job` to the thread (after the one in progress, if any).
    pub fn submit(&mut self, job: Job) {
        if let Some(jobs) = &self.jobs {
            self.busy = jobs.send(job).is_ok();
        }
    }

    /// The finished job, if there is one, waiting for it at most `timeout`. A render
    /// thread that has stopped (it cannot, short of a bug) gives one failed job and takes
    /// no more.
    pub fn wait(&mut self, timeout: Duration) -> Option<Done> {
        use std::sync::mpsc::RecvTimeoutError;
        let done = if timeout.is_zero() {
            self.done.try_recv().map_err(|e| match e {
                std::sync::mpsc::TryRecvError::Empty => RecvTimeoutError::Timeout,
                std::sync::mpsc::TryRecvError::Disconnected => RecvTimeoutError::Disconnected,
            })
        } else {
            self.done.recv_timeout(timeout)
        };
        match done {
            Ok(done) => {
                self.busy = false;
                Some(done)
            }
            Err(RecvTimeoutError::Timeout) => None,
            Err(RecvTimeoutError::Disconnected) => self.jobs.take().map(|_| {
                self.busy = false;
                Done {
                    tick: None,
                    seconds: 0.0,
                    detail: 1.0,
                    picture: Err("the render thread stopped".into()),
                }
            }),
        }
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing the job channel ends the thread after its current job.
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn run_job(
    ctx: &GpuContext,
    renderer: &mut FrameRenderer,
    (refiner, lamps): (&mut Refiner, &mut LampCheck),
    cursor: &mut FrameCursor,
    job: &Job,
    kept: &mut Option<Kept>,
) -> Result<Picture, String> {
    let (width, height) = (job.camera.width, job.camera.height);
    let same = |k: &Kept| k.frame == job.frame && k.camera == job.camera && k.scene == job.scene;
    let times = match kept.as_ref() {
        Some(k) if same(k) => None,
        _ => {
            *kept = None;
            let (dims, bbox) = cursor.stream().grid();
            let frame = cursor.get(job.frame)?;
            let sigma_t = job.scene.medium.sigma_t;
            // One evaluation of the frame's density serves both measures.
            let mut density = FrameDensity::new(frame, dims, bbox);
            let lit_by = lamps.check(&mut density, sigma_t, &job.scene.env.points)?;
            let (grid, fine) = refiner.prepare(&mut density, sigma_t)?;
            let mut scene = job.scene.clone();
            let tau = grid.tau / grid.n.max(1) as f64;
            if job.at_floor {
                let floor = detail::floor(tau);
                scene.opts.detail = scene.opts.detail.min(floor);
            }
            let residual = match fine {
                Some(values) => Some(Residual::Dense(values)),
                None => frame.residual.as_ref().map(Residual::Hash),
            };
            // The environment grid's nodes on the voxel centers and the orders' cells of
            // one voxel where the smoke is thick, as `haze render` lights it.
            let opts = {
                let density = &mut density;
                scene.opts.for_smoke(tau).for_gpu_cells(
                    grid.n,
                    tau,
                    renderer.orders_cells(ctx),
                    move || density.get().ok(),
                )
            };
            let (image, times) = renderer
                .render(
                    ctx,
                    &frame.rbfs,
                    residual,
                    haze_view::render::supersample::fine_dims(dims, grid.n),
                    &bbox,
                    &scene.medium,
                    &scene.env,
                    &job.camera,
                    &opts,
                )
                .map_err(|e| format!("frame {}: {e}", frame.number))?;
            let gpu: Vec<String> = times
                .gpu
                .iter()
                .map(|(pass, s)| format!("{pass} {:.1} ms", 1e3 * s))
                .collect();
            tracing::debug!(
                "frame {} (lighting detail {:.2}): {}; GPU: {}",
                frame.number,
                scene.opts.detail,
                times.crm,
                if gpu.is_empty() {
                    "no timestamps".to_string()
                } else {
                    gpu.join(", ")
                }
            );
            *kept = Some(Kept {
                frame: job.frame,
                camera: job.camera.clone(),
                scene,
                image,
                number: frame.number,
                grid,
                lamps: lit_by,
            });
            Some(times)
        }
    };
    let k = kept.as_ref().expect("rendered or kept above");
    Ok(Picture {
        number: k.number,
        width,
        height,
        rgb: renderer
            .encode(ctx, &k.image, job.exposure, job.tone)
            .map_err(|e| format!("frame {}: {e}", k.number))?,
        times,
        grid: k.grid,
        lamps: k.lamps.clone(),
        detail: k.scene.opts.detail,
    })
}

#[cfg(test)]
mod tests {
    use super::super::testing::write_asset;
    use super::*;
    use haze_view::stream::FrameDecoder;

    fn view_job(frame: usize, azimuth: f64, exposure: f64) -> Job {
        let b = super::super::testing::bbox();
        let c = [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a]));
        let eye = [
            c[0] + 6.0 * azimuth.cos(),
            c[1] + 6.0 * azimuth.sin(),
            c[2] + 1.5,
        ];
        Job {
            tick: None,
            frame,
            camera: Camera::new(eye, c, [0.0, 0.0, 1.0], 30.0, 24, 18).unwrap(),
            scene: Scene {
                medium: Medium::new(6.0, 0.85, 0.3).unwrap(),
                env: Arc::new(Environment::sky(haze_view::Sky::default())),
                opts: CrmOptions::default(),
            },
            exposure,
            tone: haze_core::ToneMap::Filmic,
            at_floor: false,
        }
    }

    /// Needs a GPU adapter (lavapipe will do); fails without one.
    #[test]
    fn jobs_render_or_only_tone_map_again() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_asset(dir.path(), "a.haze", 3);
        let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
        let cursor = FrameCursor::new(FrameStream::open(&path, 2, true).unwrap(), 2);
        let mut w = Worker::spawn(
            cursor,
            ctx,
            LightingOn::Auto,
            Supersample::Auto,
            Box::new(|| {}),
        )
        .unwrap();
        let mut run = |job: Job| {
            w.submit(job);
            assert!(w.busy());
            let done = w.wait(Duration::from_secs(120)).expect("the job finishes");
            assert!(!w.busy());
            done.picture.unwrap()
        };
        let a = run(view_job(2, 0.3, 1.0));
        assert_eq!(
            (a.number, a.width, a.height, a.rgb.len()),
            (103, 24, 18, 24 * 18 * 3)
        );
        assert!(a.times.is_some());
        // The same view at another exposure: the kept pixels, tone-mapped again — the
        // encoding of a fresh render's pixels at that exposure.
        let b = run(view_job(2, 0.3, 4.0));
        assert!(b.times.is_none());
        let ctx = GpuContext::new().unwrap();
        let mut r = FrameRenderer::new(&ctx, LightingOn::Auto).unwrap();
        let mut d =
            haze_view::stream::FrameDecoder::new(Arc::new(haze_asset::Asset::open(&path).unwrap()));
        let f = d.decode(2).unwrap();
        let job = view_job(2, 0.3, 4.0);
        let (image, _) = r
            .render(
                &ctx,
                &f.rbfs,
                f.residual.as_ref().map(Residual::Hash),
                super::super::testing::DIMS,
                &super::super::testing::bbox(),
                &job.scene.medium,
                &job.scene.env,
                &job.camera,
                // The options the worker lit this frame with (`for_smoke` of its grid).
                &job.scene
                    .opts
                    .for_smoke(a.grid.tau / a.grid.n.max(1) as f64),
            )
            .unwrap();
        // The worker's picture, encoded on the GPU, byte for byte the host's encoding.
        let image = haze_view::Image {
            width: 24,
            height: 18,
            pixels: image.pixels(&ctx).unwrap(),
        };
        assert_eq!(b.rgb, image.to_srgb8(4.0, haze_core::ToneMap::Filmic));
        assert_ne!(a.rgb, b.rgb);
        // Another camera or frame renders again.
        assert!(run(view_job(2, 0.9, 4.0)).times.is_some());
        let c = run(view_job(0, 0.9, 4.0));
        assert_eq!(c.number, 101);
        assert!(c.times.is_some());
        assert!(c.lamps.lines().next().is_none(), "no point light");
        // A lamp at the densest RBF's center: the picture warns of it (`lamps` module),
        // and so does the same picture tone-mapped again.
        let mut lamp = view_job(0, 0.9, 4.0);
        let mut env = (*lamp.scene.env).clone();
        let center = super::super::testing::rbfs(0)[0].center;
        env.points.push(haze_view::PointLight {
            position: center,
            intensity: [2.0; 3],
        });
        lamp.scene.env = Arc::new(env);
        let warned = run(lamp.clone());
        assert!(warned.times.is_some());
        let w = warned.lamps.warnings();
        assert!(
            w.len() == 1 && w[0].1.contains("sits in the smoke"),
            "{w:?}"
        );
        lamp.exposure = 2.0;
        let again = run(lamp);
        assert!(again.times.is_none());
        assert_eq!(again.lamps, warned.lamps);
    }

    #[test]
    fn the_cursor_reads_forward_skips_seeks_and_wraps() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_asset(dir.path(), "a.haze", 9);
        let mut decoder = FrameDecoder::new(Arc::new(haze_asset::Asset::open(&path).unwrap()));
        let mut cursor = FrameCursor::new(FrameStream::open(&path, 2, true).unwrap(), 2);
        // In order, the same frame twice, skips within and beyond the read-ahead, back,
        // past the end (wrapping) and a jump back to the start.
        for k in [0, 1, 1, 2, 4, 8, 3, 3, 7, 8, 0, 2, 0] {
            let want = decoder.decode(k).unwrap();
            let got = cursor.get(k).unwrap();
            assert_eq!((got.index, got.number), (k, 101 + k as i64));
            assert_eq!(got.rbfs, want.rbfs, "frame {k}");
            let (g, w) = (
                got.residual.as_ref().unwrap(),
                want.residual.as_ref().unwrap(),
            );
            // Playback holds each frame as a group of its own.
            assert_eq!((g.slot, g.group.frames()), (0, 1), "frame {k}");
            assert_eq!(g.group.steps[g.slot], w.group.steps[w.slot]);
            assert_eq!(g.dense(), w.dense(), "frame {k}");
        }
    }

    /// Played in order across two hash volumes (and back to the first, and a seek), a
    /// prefetching decoder gives every frame as a plain one does, each as a group of its
    /// own, its thread going on from one volume into the next.
    #[test]
    fn playback_decodes_frames_ahead_across_hash_volumes() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_asset(dir.path(), "a.haze", 30);
        let asset = Arc::new(haze_asset::Asset::open(&path).unwrap());
        let mut plain = FrameDecoder::new(asset.clone());
        let mut ahead = FrameDecoder::prefetching(asset, true);
        for k in (0..30).chain([0, 29]) {
            let (a, b) = (ahead.decode(k).unwrap(), plain.decode(k).unwrap());
            let (ra, rb) = (a.residual.unwrap(), b.residual.unwrap());
            assert_eq!(ra.dense(), rb.dense(), "frame {k}");
            assert_eq!((ra.slot, ra.group.frames()), (0, 1), "frame {k}");
            assert!(ahead.decoding_ahead(), "frame {k}");
            assert!(!plain.decoding_ahead());
        }
    }
}
