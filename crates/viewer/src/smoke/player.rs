//! The player: the playback clock driving the render thread — what to render next, when a
//! finished picture goes on screen, and the figures of the run. The window and
//! `--no-window` both drive it, calling [`Player::update`] whenever anything may have
//! happened.
//!
//! Scheduling: one job at a time on the render thread, and at most one finished picture
//! waiting for its due time. While playing, the next tick is asked for as soon as the
//! thread is free — also while a finished picture waits for its slot, so the thread never
//! idles while its pictures take longer than a slot — aimed at the slot the render will
//! end in (the expected render time is a running mean of the last jobs), so a renderer
//! faster than the frame rate works a frame or two ahead and shows every frame on time, and
//! a slower one skips to the frames it can still show (`playback` module docs: what counts as dropped). While
//! paused, the frame on screen is rendered again only when the camera, the scene or the
//! exposure changed (a change of exposure alone is only tone-mapped again), or when it
//! was lit at a lower detail while playing (`detail` module: playback lowers the
//! lighting's detail while the lighting holds it back). Below full detail, and for a
//! still whose camera moved since the last one asked for, the view pass takes at most
//! [`PLAYING_SLICES`] slices per voxel; the frame is rendered again with the view's own
//! once playback pauses or the camera rests.

use super::detail::{DetailControl, FrameCost, PLAYING_REUSE, PLAYING_SLICES, fewer_slices};
use super::playback::{PlayReport, Playback};
use super::worker::{Done, Job, Picture, Scene, Worker};
use haze_view::Camera;
use std::time::{Duration, Instant};

/// What the user looks through: everything of a job but the frame.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    pub camera: Camera,
    pub scene: Scene,
    pub exposure: f64,
    pub tone: haze_core::ToneMap,
}

/// What [`Player::update`] did.
#[derive(Debug, Default)]
pub struct Update {
    /// A picture to put on screen now.
    pub shown: Option<Picture>,
    /// When to call `update` again at the latest (a picture will be due then); besides,
    /// call it when the render thread reports a finished job.
    pub wake_at: Option<Instant>,
}

/// Weight of the newest job in the running mean of render times.
const LEAD_WEIGHT: f64 = 0.3;

/// The playback clock and the render thread together (module docs).
#[derive(Debug)]
pub struct Player {
    pub playback: Playback,
    worker: Worker,
    /// A finished job taken from the thread while waiting, not handled yet.
    arrived: Option<Done>,
    /// A finished picture of a tick that is not due yet.
    pending: Option<Done>,
    /// The frame and view (its lighting detail applied) of the last job handed to the
    /// thread.
    submitted: Option<(usize, View)>,
    /// The lighting's detail for playback frames (`detail` module).
    pub detail: DetailControl,
    /// Playback's first frame was handed over to be lit at its floor, and has not come
    /// back yet (`Job::at_floor`).
    floor_started: bool,
    /// Expected seconds per job.
    lead: f64,
    /// Jobs that rendered (not only tone-mapped) and their seconds, for the report.
    renders: u64,
    render_seconds: f64,
    /// The latest stage times, and the latest job's error until a picture is shown.
    pub times: Option<super::frame::StageTimes>,
    /// The grid the picture on screen was lit on.
    pub grid: Option<super::thick::Grid>,
    /// Its point lights' share of first scattering near them (`lamps` module).
    pub lamps: super::lamps::Lamps,
    /// The point lights (their positions) the log has warned about.
    lamps_warned: Vec<[f64; 3]>,
    /// The lighting's detail of the picture on screen (`CrmOptions::detail`).
    pub shown_detail: f64,
    /// Whether a playback frame was rendered with fewer slices per voxel than the view's
    /// (`detail::PLAYING_SLICES`).
    fewer_slices: bool,
    /// Whether a still was, while its camera moved.
    moved_slices: bool,
    /// Whether a playback frame's view pass took pixels from their neighbours
    /// (`detail::PLAYING_REUSE`; the CPU's view pass only), and whether a moving
    /// camera's still did.
    reused_playing: bool,
    reused_moving: bool,
    pub error: Option<String>,
    /// Jobs that failed, and the first one's error.
    pub failures: u64,
    pub first_failure: Option<String>,
    created: Instant,
    /// From the player's creation to its first picture on screen.
    pub first_picture: Option<Duration>,
}

impl Player {
    /// A player of `playback` on `worker`; the time to the first picture counts from
    /// `created`.
    pub fn new(playback: Playback, worker: Worker, created: Instant) -> Player {
        Player {
            playback,
            worker,
            arrived: None,
            pending: None,
            submitted: None,
            detail: DetailControl::default(),
            floor_started: false,
            lead: 0.0,
            renders: 0,
            render_seconds: 0.0,
            times: None,
            grid: None,
            lamps: Default::default(),
            lamps_warned: Vec::new(),
            shown_detail: 1.0,
            fewer_slices: false,
            moved_slices: false,
            reused_playing: false,
            reused_moving: false,
            error: None,
            failures: 0,
            first_failure: None,
            created,
            first_picture: None,
        }
    }

    /// Waits at most `timeout` for the render thread to finish its job (for a loop
    /// without a window; the window is woken by the thread instead).
    pub fn wait(&mut self, timeout: Duration) {
        if self.arrived.is_none() {
            self.arrived = self.worker.wait(timeout);
        } else {
            // A finished job already waits behind the picture due next: nothing can
            // happen before `timeout` (the caller's next due time) but that.
            std::thread::sleep(timeout);
        }
    }

    /// Takes the finished job, shows what is due at `now`, and hands the next job to the
    /// render thread (module docs).
    pub fn update(&mut self, now: Instant, view: &View) -> Update {
        let mut out = Update::default();
        loop {
            if let Some(done) = self.pending.take() {
                let tick = done.tick.expect("only ticks wait");
                match self.playback.due_at(tick.n) {
                    Some(due) if due > now => {
                        out.wake_at = Some(due);
                        self.pending = Some(done);
                        // The next picture stays with the thread (or in `arrived`) until
                        // this one is shown.
                        break;
                    }
                    _ => {
                        if self.playback.present(tick, now) {
                            self.show(done, now, &mut out);
                        }
                    }
                }
            }
            if out.shown.is_some() {
                // One picture a call: a job finished since waits for the next one.
                out.wake_at = Some(now);
                break;
            }
            match self
                .arrived
                .take()
                .or_else(|| self.worker.wait(Duration::ZERO))
            {
                Some(done) => self.finished(done, now, &mut out),
                None => break,
            }
        }
        if !self.worker.busy() && self.arrived.is_none() {
            let lead = Duration::from_secs_f64(self.lead);
            let next = self.playback.next_request(now, lead);
            let frame = next.map_or(self.playback.current(), |t| t.frame);
            // Playback frames at the control's detail (and, below full, at most one
            // slice per voxel), without the thick smoke's cells of one voxel (the control
            // steps by about 3× the work; they cost tens of times the cells below them);
            // a still at the view's own.
            let mut view = view.clone();
            if next.is_some() {
                let opts = &mut view.scene.opts;
                opts.detail = self.detail.detail();
                opts.thick_cells = false;
                self.fewer_slices |= take_slices(opts, self.detail.slices(opts.slices_per_voxel));
                opts.pixel_reuse = self.detail.pixel_reuse(opts.pixel_reuse);
            } else if self
                .submitted
                .as_ref()
                .is_some_and(|(f, last)| *f == frame && last.camera != view.camera)
            {
                // A still whose camera moved since the last picture asked for (a drag, a
                // zoom) takes at most one slice per voxel, as playback below full detail
                // does; once the camera rests, the picture comes again with the view's.
                let opts = &mut view.scene.opts;
                self.moved_slices |= take_slices(opts, fewer_slices(opts.slices_per_voxel));
                opts.pixel_reuse = opts.pixel_reuse.max(PLAYING_REUSE);
            }
            let stale = self.submitted.as_ref() != Some(&(frame, view.clone()));
            if next.is_some() || (!self.playback.playing() && stale) {
                // Playback at a rate, lit on the CPU, starts at the floor's detail
                // (`detail` module docs).
                let at_floor = next.is_some()
                    && self.submitted.is_none()
                    && self.playback.fps() > 0.0
                    && self.worker.lights_on_host();
                self.floor_started |= at_floor;
                self.worker.submit(Job {
                    tick: next,
                    frame,
                    camera: view.camera.clone(),
                    scene: view.scene.clone(),
                    exposure: view.exposure,
                    tone: view.tone,
                    at_floor,
                });
                self.submitted = Some((frame, view));
            }
        }
        out
    }

    fn finished(&mut self, done: Done, now: Instant, out: &mut Update) {
        self.lead = if self.lead == 0.0 {
            done.seconds
        } else {
            LEAD_WEIGHT * done.seconds + (1.0 - LEAD_WEIGHT) * self.lead
        };
        let from_floor = std::mem::take(&mut self.floor_started);
        if let Ok(Picture { times: Some(t), .. }) = &done.picture
            && t.crm.reused_pixels > 0
        {
            if done.tick.is_some() {
                self.reused_playing = true;
            } else {
                self.reused_moving = true;
            }
        }
        if let (Some(_), Ok(p @ Picture { times: Some(t), .. })) = (done.tick, &done.picture) {
            // The run's first frame only sets where the control starts: it is not
            // weighed (`DetailControl::start_at`).
            if from_floor {
                self.detail.start_at(done.detail);
            } else {
                let fps = self.playback.fps();
                self.detail.observe(
                    done.detail,
                    FrameCost::of(done.seconds, t),
                    (fps > 0.0).then(|| 1.0 / fps),
                    p.grid.tau / p.grid.n.max(1) as f64,
                );
            }
        }
        match (&done.picture, done.tick) {
            (Err(e), tick) => {
                if let Some(t) = tick {
                    self.playback.missed(t, now);
                }
                self.failures += 1;
                self.first_failure.get_or_insert_with(|| e.clone());
                self.error = Some(e.clone());
            }
            // A tick of an earlier run (a seek, a pause) is dropped.
            (Ok(_), Some(t)) if !self.playback.is_current(t) => {}
            (Ok(_), Some(_)) => self.pending = Some(done),
            (Ok(_), None) => self.show(done, now, out),
        }
    }

    fn show(&mut self, done: Done, now: Instant, out: &mut Update) {
        self.shown_detail = done.detail;
        let Ok(picture) = done.picture else { return };
        if let Some(t) = &picture.times {
            self.renders += 1;
            self.render_seconds += done.seconds;
            self.times = Some(t.clone());
        }
        if self.grid.is_none_or(|g| g != picture.grid)
            && let Some(w) = picture.grid.warning()
        {
            tracing::warn!("{w}");
        }
        self.grid = Some(picture.grid);
        // The log warns once a light (its share moves from frame to frame; the panel
        // shows it live).
        for (at, w) in picture.lamps.warnings() {
            if !self.lamps_warned.contains(&at) {
                tracing::warn!("{w}");
                self.lamps_warned.push(at);
            }
        }
        self.lamps = picture.lamps.clone();
        self.error = None;
        self.first_picture
            .get_or_insert_with(|| now.saturating_duration_since(self.created));
        out.shown = Some(picture);
    }

    /// "; 1 slice per voxel while the camera moves" once a moving camera's stills took
    /// fewer slices than the view's, with ", smooth pixels from their neighbours" where
    /// their view pass reused pixels too; else nothing.
    pub fn moving_words(&self) -> String {
        let mut words = Vec::new();
        if self.moved_slices {
            words.push(format!("{PLAYING_SLICES} slice per voxel"));
        }
        if self.reused_moving {
            words.push(REUSE_WORDS.to_string());
        }
        if words.is_empty() {
            String::new()
        } else {
            format!("; {} while the camera moves", words.join(", "))
        }
    }

    /// The current run's figures at `now`.
    pub fn report(&self, now: Instant) -> PlayReport {
        self.playback.report(now)
    }

    /// Mean seconds of the jobs that rendered (0 before any).
    pub fn mean_render_seconds(&self) -> f64 {
        if self.renders > 0 {
            self.render_seconds / self.renders as f64
        } else {
            0.0
        }
    }

    /// The measurement line of `--play-for`: the run's figures at `now`, the mean render
    /// time and the time to the first picture.
    pub fn summary(&self, now: Instant, width: usize, height: usize) -> String {
        let r = self.report(now);
        let fps = self.playback.fps();
        let target = if fps > 0.0 {
            format!("at {} fps", haze_core::number::shown(fps))
        } else {
            "as fast as possible".to_string()
        };
        let shown = if r.shown == 1 { "frame" } else { "frames" };
        // A frame time is the interval between two frames shown: with fewer there is none,
        // and zeros would read as a measurement.
        let timing = if r.shown >= 2 {
            format!(
                "frame time mean {:.1} ms, max {:.1} ms; {:.2} fps",
                r.mean_frame_seconds * 1e3,
                r.max_frame_seconds * 1e3,
                r.fps
            )
        } else {
            "no frame time (fewer than two frames shown: play for longer)".to_string()
        };
        format!(
            "played {:.2} s {target}, {width}×{height}: {} {shown} shown, {} due, {} dropped; {timing}; render mean {:.1} ms; first picture after {:.2} s",
            r.seconds,
            r.shown,
            r.due,
            r.dropped,
            self.mean_render_seconds() * 1e3,
            self.first_picture.unwrap_or_default().as_secs_f64()
        ) + &self.detail_words()
    }

    /// "; lighting detail 0.50 while playing (lowest 0.35)" once playback lowered it,
    /// else nothing; ", 1 slice per voxel" after it where playback lowered the view's
    /// slices too.
    fn detail_words(&self) -> String {
        let (now, lowest) = (self.detail.detail(), self.detail.lowest());
        if lowest >= 1.0 {
            return String::new();
        }
        let mut fewer = if self.fewer_slices {
            format!(", {PLAYING_SLICES} slice per voxel")
        } else {
            String::new()
        };
        if self.reused_playing {
            fewer += &format!(", {REUSE_WORDS}");
        }
        format!("; lighting detail {now:.2} while playing (lowest {lowest:.2}){fewer}")
    }
}

/// How the player's lines say that the view pass took pixels from their neighbours.
const REUSE_WORDS: &str = "smooth pixels from their neighbours";

/// Sets the view pass's slices per voxel of `opts` to `slices`; whether that is fewer
/// than it had.
fn take_slices(opts: &mut haze_view::render::CrmOptions, slices: f64) -> bool {
    let fewer = slices < opts.slices_per_voxel;
    opts.slices_per_voxel = slices;
    fewer
}

#[cfg(test)]
mod tests {
    use super::super::testing::{bbox, write_asset};
    use super::super::worker::FrameCursor;
    use super::*;
    use haze_gpu::GpuContext;
    use haze_render::smoke::Supersample;
    use haze_view::gpu::renderer::LightingOn;
    use haze_view::render::CrmOptions;
    use haze_view::stream::FrameStream;
    use haze_view::{Environment, Medium, Sky};
    use std::sync::Arc;

    fn view(azimuth: f64, exposure: f64) -> View {
        let b = bbox();
        let c = [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a]));
        let eye = [
            c[0] + 6.0 * azimuth.cos(),
            c[1] + 6.0 * azimuth.sin(),
            c[2] + 1.5,
        ];
        View {
            camera: Camera::new(eye, c, [0.0, 0.0, 1.0], 30.0, 16, 12).unwrap(),
            scene: Scene {
                medium: Medium::new(6.0, 0.85, 0.3).unwrap(),
                env: Arc::new(Environment::sky(Sky::default())),
                opts: CrmOptions::default(),
            },
            exposure,
            tone: haze_core::ToneMap::Filmic,
        }
    }

    /// A render thread lighting on `lighting` over a 4-frame asset written in `dir`. Needs
    /// a GPU adapter (lavapipe will do).
    fn worker(dir: &std::path::Path, lighting: LightingOn) -> Worker {
        let path = write_asset(dir, "a.haze", 4);
        let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
        let cursor = FrameCursor::new(FrameStream::open(&path, 2, true).unwrap(), 2);
        Worker::spawn(cursor, ctx, lighting, Supersample::Auto, Box::new(|| {})).unwrap()
    }

    /// Updates until the render thread is idle and nothing waits; the pictures shown.
    fn settle(p: &mut Player, v: &View) -> Vec<Picture> {
        let mut shown = Vec::new();
        loop {
            let u = p.update(Instant::now(), v);
            shown.extend(u.shown);
            if !p.worker.busy() && p.pending.is_none() && p.arrived.is_none() {
                return shown;
            }
            p.wait(Duration::from_millis(100));
        }
    }

    /// Playback at a rate whose lighting runs on the CPU starts at the floor of its first
    /// frame's thickness, and the control goes on from there; paused, the frame is lit
    /// again at full detail. Needs a GPU adapter (lavapipe will do).
    #[test]
    fn playback_lit_on_the_cpu_starts_at_the_floor() {
        let dir = tempfile::tempdir().unwrap();
        let worker = worker(dir.path(), LightingOn::Cpu);
        assert!(worker.lights_on_host());
        let mut p = Player::new(Playback::new(4, 24.0).unwrap(), worker, Instant::now());
        // Thin smoke, whose floor is below full detail.
        let mut v = view(0.2, 1.0);
        v.scene.medium = Medium::new(0.5, 0.85, 0.3).unwrap();
        let first = loop {
            if let Some(x) = p.update(Instant::now(), &v).shown {
                break x;
            }
            p.wait(Duration::from_millis(100));
        };
        let floor = super::super::detail::floor(first.grid.tau / first.grid.n.max(1) as f64);
        assert!(floor < 1.0, "the test's smoke is thin: {floor}");
        assert_eq!((first.detail, p.shown_detail), (floor, floor));
        assert_eq!(p.detail.lowest(), floor);
        assert!(p.detail.detail() >= floor, "{:?}", p.detail);
        p.playback.pause();
        let still = settle(&mut p, &v);
        assert_eq!(p.shown_detail, 1.0);
        assert!(still.last().unwrap().times.is_some(), "lit again");
    }

    /// Needs a GPU adapter (lavapipe will do); fails without one.
    #[test]
    fn paused_it_renders_only_what_changed_and_playing_it_plays_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let worker = worker(dir.path(), LightingOn::Auto);
        let mut playback = Playback::new(4, 24.0).unwrap();
        playback.pause();
        let mut p = Player::new(playback, worker, Instant::now());
        let numbers = |pics: &[Picture]| pics.iter().map(|x| x.number).collect::<Vec<_>>();

        let v = view(0.2, 1.0);
        let first = settle(&mut p, &v);
        assert_eq!(numbers(&first), [101]);
        assert!(first[0].times.is_some() && p.first_picture.is_some());
        assert!(settle(&mut p, &v).is_empty(), "nothing changed");
        // Exposure: tone-mapped again, not rendered.
        let brighter = settle(&mut p, &view(0.2, 3.0));
        assert_eq!(numbers(&brighter), [101]);
        assert!(brighter[0].times.is_none());
        // The camera: the passes again, the sources kept — at one slice per voxel while
        // it moves, then at the view's own once it rests (the same camera asked again).
        assert!(p.moving_words().is_empty());
        let turned = settle(&mut p, &view(1.2, 3.0));
        assert_eq!(numbers(&turned), [101, 101]);
        assert!(p.times.as_ref().unwrap().sources_reused);
        assert_eq!(v.scene.opts.slices_per_voxel, 2.0);
        assert_eq!(
            p.submitted.as_ref().unwrap().1.scene.opts.slices_per_voxel,
            2.0
        );
        // Where the view pass runs on the host (a CPU adapter), smooth pixels come from
        // their neighbours too (`detail::PLAYING_REUSE`).
        let reuse = if p.worker.lights_on_host() {
            ", smooth pixels from their neighbours"
        } else {
            ""
        };
        assert_eq!(
            p.moving_words(),
            format!("; 1 slice per voxel{reuse} while the camera moves")
        );
        assert_eq!(
            p.submitted.as_ref().unwrap().1.scene.opts.pixel_reuse,
            0.0,
            "at rest every pixel is marched"
        );
        // A step: the next frame, lit anew.
        p.playback.step(1);
        let stepped = settle(&mut p, &view(1.2, 3.0));
        assert_eq!(numbers(&stepped), [102]);
        assert!(!p.times.as_ref().unwrap().sources_reused);

        // Playing as fast as possible: every frame in turn from the one after the frame
        // on screen, looping, none dropped.
        p.playback.set_fps(0.0).unwrap();
        p.playback.play();
        let v = view(1.2, 3.0);
        let mut shown = Vec::new();
        while shown.len() < 6 {
            shown.extend(p.update(Instant::now(), &v).shown);
            p.wait(Duration::from_millis(100));
        }
        assert_eq!(numbers(&shown), [103, 104, 101, 102, 103, 104]);
        let r = p.report(Instant::now());
        assert_eq!((r.shown, r.due, r.dropped), (6, 6, 0));
        assert_eq!(p.failures, 0);
        let line = p.summary(Instant::now(), 16, 12);
        assert!(
            line.contains("as fast as possible, 16×12: 6 frames shown, 6 due, 0 dropped"),
            "{line}"
        );
        assert!(!line.contains("detail"), "{line}");

        // At 4 frames a second each picture (milliseconds here) waits for its slot, and
        // meanwhile the thread renders the next one: the frames in turn, none dropped.
        p.playback.set_fps(4.0).unwrap();
        let (mut shown, mut overlapped) = (Vec::new(), false);
        while shown.len() < 4 {
            let now = Instant::now();
            let u = p.update(now, &v);
            shown.extend(u.shown);
            overlapped |= p.pending.is_some() && (p.worker.busy() || p.arrived.is_some());
            let wait = u.wake_at.map_or(Duration::from_millis(100), |at| {
                at.saturating_duration_since(now)
            });
            p.wait(wait.min(Duration::from_millis(100)));
        }
        assert!(overlapped, "the thread idled while a picture waited");
        let n = numbers(&shown);
        assert!(
            n.windows(2)
                .all(|w| w[1] == if w[0] == 104 { 101 } else { w[0] + 1 }),
            "{n:?}"
        );
        assert_eq!(p.report(Instant::now()).dropped, 0);
        p.playback.set_fps(0.0).unwrap();

        // Playback at a lower detail (as after late frames whose lighting outweighed the
        // view pass): the frames are lit at it; paused, the frame on screen is lit again
        // at full detail.
        p.detail.observe(
            1.0,
            super::super::detail::FrameCost {
                view_seconds: 1.0,
                lighting_seconds: 1.2,
            },
            Some(1.0 / 24.0),
            0.05,
        );
        assert_eq!(p.detail.detail(), 0.75);
        let mut low = Vec::new();
        while low.len() < 3 {
            if let Some(x) = p.update(Instant::now(), &v).shown {
                low.push((x.number, p.shown_detail));
            }
            p.wait(Duration::from_millis(100));
        }
        // The first may have been submitted before the step.
        assert!(low[1..].iter().all(|(_, d)| *d == 0.75), "{low:?}");
        // Below full detail the view pass takes one slice per voxel, the view two.
        assert_eq!(v.scene.opts.slices_per_voxel, 2.0);
        let playing = &p.submitted.as_ref().unwrap().1.scene.opts;
        assert_eq!((playing.detail, playing.slices_per_voxel), (0.75, 1.0));
        assert_eq!(playing.pixel_reuse, PLAYING_REUSE);
        assert!(
            !playing.thick_cells,
            "playback keeps the orders' cells of 2³"
        );
        p.playback.pause();
        let still = settle(&mut p, &v);
        assert_eq!(p.shown_detail, 1.0);
        assert!(still.last().unwrap().times.is_some(), "lit again");
        let paused = &p.submitted.as_ref().unwrap().1.scene.opts;
        assert_eq!(
            (paused.detail, paused.slices_per_voxel, paused.pixel_reuse),
            (1.0, 2.0, 0.0)
        );
        assert!(paused.thick_cells, "a still as haze render lights it");
        let line = p.summary(Instant::now(), 16, 12);
        assert!(
            line.ends_with(&format!(
                "; lighting detail 0.75 while playing (lowest 0.75), 1 slice per voxel{reuse}"
            )),
            "{line}"
        );
    }
}
