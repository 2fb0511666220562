//! The playback clock: which frame is due when, and how many were shown on time.
//!
//! A *run* starts when playback starts (or restarts: play after a pause, a seek, a new
//! frame rate) at some frame of the asset. Its ticks `n = 0, 1, 2, …` show the frames
//! `first + n` (wrapping to frame 0 after the last: playback loops). Tick 0 is due when it
//! is shown — the clock starts with the first picture, not with the request — and tick
//! `n` at `origin + n/fps`; its *slot* is `[due(n), due(n + 1))`.
//!
//! A tick is *on time* when its frame reached the screen within its slot. A tick is
//! *dropped* when its slot ended without its frame on screen: skipped because rendering
//! fell behind, or shown only after the slot had passed. So `due = slots ended so far`,
//! `dropped = due − on time`, and a playback without a dropped frame showed every frame of
//! the sequence, each during its own slot. At `fps = 0` (as fast as possible) there is no
//! schedule: every frame is shown in turn as soon as it is rendered, and none is due
//! before it is shown or dropped.

use std::time::{Duration, Instant};

/// The highest frame rate a playback takes: beyond any display's refresh (a frame every
/// millisecond); 0 asks for frames as fast as they render.
pub const MAX_FPS: f64 = 1000.0;

/// One tick of one run, as handed to the renderer and back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tick {
    /// The run it belongs to (a seek or a restart makes a new run; old ticks are stale).
    pub run: u64,
    /// The tick number within the run.
    pub n: u64,
    /// The asset frame it shows.
    pub frame: usize,
}

/// Figures of the current run (see the module docs for the definitions).
#[derive(Clone, Debug, PartialEq)]
pub struct PlayReport {
    /// Frames shown (on time or late).
    pub shown: u64,
    /// Ticks whose slot has ended (at `fps = 0`: the frames shown).
    pub due: u64,
    /// Due ticks not on screen within their slot.
    pub dropped: u64,
    /// Mean and largest time between two frames shown, seconds (0 before the second).
    pub mean_frame_seconds: f64,
    pub max_frame_seconds: f64,
    /// New frames shown per second since the first: `(shown − 1) / (last − first)`.
    pub fps: f64,
    /// Seconds since the run's first frame was shown (0 before it).
    pub seconds: f64,
}

/// The clock of playback (module docs).
#[derive(Debug)]
pub struct Playback {
    frame_count: usize,
    /// Frames per second; 0: as fast as possible.
    fps: f64,
    playing: bool,
    /// The frame on screen, or to be shown next while nothing is.
    current: usize,
    /// Nothing was shown or paused on yet: playback starts at `current`, not after it.
    fresh: bool,
    run: u64,
    /// The asset frame of tick 0.
    first: usize,
    /// When tick 0 was shown.
    origin: Option<Instant>,
    /// The last tick handed to the renderer.
    requested: Option<u64>,
    shown: u64,
    /// Shown within their slot, for ticks `n` (counted against the slots once they end).
    on_time: Vec<u64>,
    last_shown: Option<Instant>,
    interval_sum: f64,
    interval_max: f64,
}

impl Playback {
    /// Playback of `frame_count` frames (at least 1) at `fps` frames per second (0: as
    /// fast as possible), playing from frame 0. Refuses a negative or non-finite `fps`.
    pub fn new(frame_count: usize, fps: f64) -> Result<Playback, String> {
        let mut p = Playback {
            frame_count: frame_count.max(1),
            fps: 0.0,
            playing: true,
            current: 0,
            fresh: true,
            run: 0,
            first: 0,
            origin: None,
            requested: None,
            shown: 0,
            on_time: Vec::new(),
            last_shown: None,
            interval_sum: 0.0,
            interval_max: 0.0,
        };
        p.set_fps(fps)?;
        Ok(p)
    }

    /// The frame rate (0: as fast as possible).
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// Changes the frame rate (0: as fast as possible, at most [`MAX_FPS`]); a playing run
    /// restarts at the frame after the one on screen.
    pub fn set_fps(&mut self, fps: f64) -> Result<(), String> {
        if !(0.0..=MAX_FPS).contains(&fps) {
            return Err(format!(
                "--fps {} must be a frame rate from 0 to {MAX_FPS} (0: as fast as possible)",
                haze_core::number::shown(fps)
            ));
        }
        self.fps = fps;
        if self.playing {
            self.restart(self.next_frame());
        }
        Ok(())
    }

    pub fn frame_count(&self) -> usize {
        self.frame_count
    }

    pub fn playing(&self) -> bool {
        self.playing
    }

    /// The frame on screen (or, before any, the one playback starts with).
    pub fn current(&self) -> usize {
        self.current
    }

    /// Starts playing at the frame after the one on screen (a new run).
    pub fn play(&mut self) {
        if !self.playing {
            self.playing = true;
            self.restart(self.next_frame());
        }
    }

    /// Stops the clock; the frame on screen stays.
    pub fn pause(&mut self) {
        self.playing = false;
        self.fresh = false;
        self.run += 1;
    }

    /// Moves to `frame` (clamped to the asset): playing, a new run starts there; paused,
    /// it becomes the frame to show.
    pub fn seek(&mut self, frame: usize) {
        let frame = frame.min(self.frame_count - 1);
        if self.playing {
            self.restart(frame);
        } else {
            self.current = frame;
        }
    }

    /// Pauses and moves `delta` frames from the one on screen, wrapping around.
    pub fn step(&mut self, delta: i64) {
        self.pause();
        let n = self.frame_count as i64;
        self.current = (self.current as i64 + delta).rem_euclid(n) as usize;
    }

    fn next_frame(&self) -> usize {
        if self.fresh {
            self.current
        } else {
            (self.current + 1) % self.frame_count
        }
    }

    fn restart(&mut self, frame: usize) {
        self.run += 1;
        self.first = frame;
        self.current = frame;
        self.origin = None;
        self.requested = None;
        self.shown = 0;
        self.on_time.clear();
        self.last_shown = None;
        self.interval_sum = 0.0;
        self.interval_max = 0.0;
    }

    fn tick(&self, n: u64) -> Tick {
        Tick {
            run: self.run,
            n,
            frame: (self.first + (n % self.frame_count as u64) as usize) % self.frame_count,
        }
    }

    /// When tick `n` of the current run is due (`None` before the run's first frame was
    /// shown, and at `fps = 0`).
    pub fn due_at(&self, n: u64) -> Option<Instant> {
        let origin = self.origin?;
        (self.fps > 0.0).then(|| origin + Duration::from_secs_f64(n as f64 / self.fps))
    }

    /// The tick whose slot holds `t` (0 before the origin).
    fn tick_at(&self, t: Instant) -> u64 {
        match self.origin {
            Some(origin) if self.fps > 0.0 => {
                (t.saturating_duration_since(origin).as_secs_f64() * self.fps).floor() as u64
            }
            _ => 0,
        }
    }

    /// The tick to render next, if playing: the first of a run; after it, at `fps = 0`
    /// the next in turn, else the tick whose slot will hold `now + lead` (`lead`: how
    /// long a render is expected to take), and never one already requested. `None` while
    /// paused, and while the run's first frame is requested but not shown yet. The tick
    /// counts as requested.
    pub fn next_request(&mut self, now: Instant, lead: Duration) -> Option<Tick> {
        if !self.playing {
            return None;
        }
        let n = match (self.requested, self.origin) {
            (None, _) => 0,
            (Some(_), None) => return None,
            (Some(r), Some(_)) if self.fps == 0.0 => r + 1,
            (Some(r), Some(_)) => self.tick_at(now + lead).max(r + 1),
        };
        self.requested = Some(n);
        Some(self.tick(n))
    }

    /// Whether `tick` belongs to the run being played (not to one before a seek, a pause
    /// or a restart).
    pub fn is_current(&self, tick: Tick) -> bool {
        self.playing && tick.run == self.run
    }

    /// Records that `tick`'s frame was put on screen at `now`; false (and nothing
    /// recorded) for a tick of an earlier run. The first tick shown starts the clock.
    pub fn present(&mut self, tick: Tick, now: Instant) -> bool {
        if !self.is_current(tick) {
            return false;
        }
        if self.origin.is_none() {
            self.origin = Some(now);
        }
        if let Some(slot_end) = self.due_at(tick.n + 1)
            && now < slot_end
        {
            self.on_time.push(tick.n);
        }
        if let Some(last) = self.last_shown {
            let dt = now.saturating_duration_since(last).as_secs_f64();
            self.interval_sum += dt;
            self.interval_max = self.interval_max.max(dt);
        }
        self.last_shown = Some(now);
        self.shown += 1;
        self.fresh = false;
        self.current = tick.frame;
        true
    }

    /// Records that `tick`'s frame could not be shown at all (its render failed): it is
    /// dropped like any tick not shown in its slot, and the first tick of a run starts
    /// the clock all the same.
    pub fn missed(&mut self, tick: Tick, now: Instant) {
        if self.is_current(tick) && self.origin.is_none() {
            self.origin = Some(now);
        }
    }

    /// The current run's figures at `now`.
    pub fn report(&self, now: Instant) -> PlayReport {
        let seconds = self
            .origin
            .map_or(0.0, |o| now.saturating_duration_since(o).as_secs_f64());
        let (due, dropped) = match self.origin {
            Some(_) if self.fps > 0.0 => {
                let due = self.tick_at(now);
                let kept = self.on_time.iter().filter(|&&n| n < due).count() as u64;
                (due, due - kept)
            }
            _ => (self.shown, 0),
        };
        let intervals = self.shown.saturating_sub(1);
        let span = match (self.origin, self.last_shown) {
            (Some(o), Some(l)) => l.saturating_duration_since(o).as_secs_f64(),
            _ => 0.0,
        };
        PlayReport {
            shown: self.shown,
            due,
            dropped,
            mean_frame_seconds: if intervals > 0 {
                self.interval_sum / intervals as f64
            } else {
                0.0
            },
            max_frame_seconds: self.interval_max,
            fps: if span > 0.0 {
                intervals as f64 / span
            } else {
                0.0
            },
            seconds,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t: u64) -> Duration {
        Duration::from_millis(t)
    }

    /// Plays `renders` (milliseconds each, one at a time, each frame shown when rendered
    /// or at its due time, whichever is later) at 10 fps and reports at `end` ms.
    fn simulate(renders: &[u64], end: u64) -> (Vec<Tick>, PlayReport) {
        let t0 = Instant::now();
        let mut p = Playback::new(4, 10.0).unwrap();
        let mut now = t0;
        let mut shown = Vec::new();
        for &r in renders {
            let tick = p.next_request(now, ms(r)).unwrap();
            now += ms(r);
            if let Some(due) = p.due_at(tick.n) {
                now = now.max(due);
            }
            assert!(p.present(tick, now));
            shown.push(tick);
        }
        (shown, p.report(t0 + ms(end)))
    }

    #[test]
    fn a_renderer_within_the_frame_time_shows_every_frame_on_time() {
        // 40 ms renders at 10 fps: ticks 0..6 shown at 40, 140, 240 … (clock from 40 ms).
        let (shown, r) = simulate(&[40; 6], 40 + 650);
        let ticks: Vec<u64> = shown.iter().map(|t| t.n).collect();
        assert_eq!(ticks, [0, 1, 2, 3, 4, 5]);
        let frames: Vec<usize> = shown.iter().map(|t| t.frame).collect();
        assert_eq!(frames, [0, 1, 2, 3, 0, 1], "loops over the 4 frames");
        assert_eq!((r.shown, r.due, r.dropped), (6, 6, 0));
        assert!((r.mean_frame_seconds - 0.1).abs() < 1e-9, "{r:?}");
        assert!((r.max_frame_seconds - 0.1).abs() < 1e-9);
        assert!((r.fps - 10.0).abs() < 1e-9);
        assert!((r.seconds - 0.65).abs() < 1e-9);
    }

    #[test]
    fn a_slow_renderer_drops_the_frames_it_skips_or_shows_late() {
        // 250 ms renders at 10 fps. Tick 0 is shown at 250 ms (the origin); the next
        // request, at the origin, aims at origin + 250 → tick 2 (slot 200–300 ms), shown
        // at origin + 250, on time; the third aims at origin + 500 → tick 5, on time.
        // Ticks 1, 3 and 4 are skipped.
        let (shown, r) = simulate(&[250, 250, 250], 250 + 650);
        let ticks: Vec<u64> = shown.iter().map(|t| t.n).collect();
        assert_eq!(ticks, [0, 2, 5]);
        // Slots ended by origin + 650 ms: ticks 0..5, of which 0, 2 and 5 were on time.
        assert_eq!((r.shown, r.due, r.dropped), (3, 6, 3));
        assert!((r.max_frame_seconds - 0.25).abs() < 1e-9, "{r:?}");
        assert!((r.fps - 4.0).abs() < 1e-9);
    }

    #[test]
    fn rates_outside_0_to_max_fps_are_refused_as_typed() {
        // 1e300 fps once counted 1.8·10¹⁹ frames due and printed 301 digits.
        for bad in [-1.0, 1e300, MAX_FPS * 1.001, f64::NAN, f64::INFINITY] {
            let e = Playback::new(10, bad).unwrap_err();
            assert!(e.contains("from 0 to 1000"), "{bad}: {e}");
            assert!(e.len() < 100, "{e}");
        }
        assert!(Playback::new(10, MAX_FPS).is_ok());
        assert!(Playback::new(10, 0.0).is_ok());
    }

    #[test]
    fn a_frame_shown_after_its_slot_is_dropped() {
        let t0 = Instant::now();
        let mut p = Playback::new(10, 10.0).unwrap();
        let a = p.next_request(t0, Duration::ZERO).unwrap();
        assert!(p.present(a, t0));
        // Tick 1 is requested for its slot but shown 50 ms after the slot ended.
        let b = p.next_request(t0, Duration::ZERO).unwrap();
        assert_eq!(b.n, 1);
        assert!(p.present(b, t0 + ms(250)));
        let r = p.report(t0 + ms(350));
        assert_eq!((r.shown, r.due, r.dropped), (2, 3, 2), "{r:?}");
    }

    #[test]
    fn a_failed_first_frame_starts_the_clock_and_is_dropped() {
        let t0 = Instant::now();
        let mut p = Playback::new(10, 10.0).unwrap();
        let a = p.next_request(t0, Duration::ZERO).unwrap();
        p.missed(a, t0 + ms(20));
        let b = p.next_request(t0 + ms(20), Duration::ZERO).unwrap();
        assert_eq!(b.n, 1);
        assert_eq!(p.due_at(1), Some(t0 + ms(120)));
        assert!(p.present(b, t0 + ms(120)));
        let r = p.report(t0 + ms(250));
        assert_eq!((r.shown, r.due, r.dropped), (1, 2, 1), "{r:?}");
    }

    #[test]
    fn as_fast_as_possible_has_no_schedule() {
        let t0 = Instant::now();
        let mut p = Playback::new(3, 0.0).unwrap();
        let mut now = t0;
        for n in 0..5 {
            let t = p.next_request(now, ms(500)).unwrap();
            assert_eq!((t.n, t.frame), (n, n as usize % 3));
            assert_eq!(p.due_at(t.n), None);
            now += ms(30);
            assert!(p.present(t, now));
        }
        let r = p.report(now + ms(1000));
        assert_eq!((r.shown, r.due, r.dropped), (5, 5, 0));
        assert!((r.fps - 1.0 / 0.03).abs() < 1e-6, "{r:?}");
    }

    #[test]
    fn the_first_frame_starts_the_clock_and_is_requested_once() {
        let t0 = Instant::now();
        let mut p = Playback::new(5, 24.0).unwrap();
        let first = p.next_request(t0, ms(10)).unwrap();
        assert_eq!((first.n, first.frame), (0, 0));
        assert_eq!(
            p.next_request(t0 + ms(900), ms(10)),
            None,
            "waits for tick 0"
        );
        assert_eq!(p.report(t0 + ms(900)).due, 0);
        assert!(p.present(first, t0 + ms(1000)));
        assert_eq!(p.due_at(0), Some(t0 + ms(1000)));
        assert_eq!(p.due_at(24), Some(t0 + ms(2000)));
    }

    #[test]
    fn seeking_pausing_and_stepping_start_new_runs() {
        let t0 = Instant::now();
        let mut p = Playback::new(8, 10.0).unwrap();
        let a = p.next_request(t0, ms(0)).unwrap();
        assert!(p.present(a, t0));
        let stale = p.next_request(t0, ms(0)).unwrap();
        p.seek(5);
        assert!(!p.present(stale, t0 + ms(50)), "a tick of the old run");
        let b = p.next_request(t0 + ms(60), ms(0)).unwrap();
        assert_eq!((b.n, b.frame), (0, 5));
        assert!(p.present(b, t0 + ms(60)));
        assert_eq!(p.report(t0 + ms(60)).shown, 1, "the new run's count");
        p.seek(99);
        assert_eq!(p.current(), 7, "clamped");
        p.step(1);
        assert!(!p.playing());
        assert_eq!(p.current(), 0, "wraps");
        p.step(-1);
        assert_eq!(p.current(), 7);
        assert_eq!(p.next_request(t0, ms(0)), None, "paused");
        p.seek(3);
        assert_eq!(p.current(), 3);
        p.play();
        let c = p.next_request(t0 + ms(100), ms(0)).unwrap();
        assert_eq!((c.n, c.frame), (0, 4), "resumes after the frame on screen");
        p.set_fps(0.0).unwrap();
        assert_eq!(p.fps(), 0.0);
        assert!(Playback::new(3, -1.0).is_err());
        assert!(Playback::new(3, f64::NAN).is_err());
    }
}
