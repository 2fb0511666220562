//! The lighting's detail while playing (`CrmOptions::detail`): where a new frame's
//! lighting costs more than its view pass and the frame misses its slot at the playback
//! rate (playing as fast as possible has no slot, and keeps the detail), the player
//! lights the next frames at a lower detail — a coarser environment grid, larger cells
//! for the explicit orders and the suns' shadows walked along rays, about a third of the work a
//! step — down [`LEVELS`] to the one whose lighting would fit beside the view pass
//! (one step when the frame is a little over, several at once when its lighting is many
//! times the view pass, as a first frame's is on a CPU adapter), and raises it again
//! once the lighting costs less than [`RAISE_BELOW`] of the view pass (the step up costs
//! about three times as much). It never goes below [`floor`]: the environment grid's
//! cells stay within [`MAX_CELL_TAU`](haze_view::render::MAX_CELL_TAU) optical depths
//! across, where the lower details' error stayed small. Where the next level would pass the floor, the
//! last step goes to the floor itself (when that is at least [`MIN_STEP`] lower): smoke
//! whose floor is 0.38 plays at 0.38, not stuck at 0.5. Where the lighting runs on the
//! CPU (beside an adapter that is a CPU), playback starts at the floor of its first
//! frame's thickness rather than at full detail ([`DetailControl::start_at`]), and the
//! rules above go on from there (that first frame itself not weighed): the first picture comes in about a third of a
//! full-detail frame's time. Playback frames, full detail included, keep the explicit
//! orders' cells of 2³ voxels on thick smoke (`CrmOptions::thick_cells` off: one voxel
//! costs tens of times more, not the 3× a step assumes). Paused, a frame is lit at full
//! detail, thick smoke's cells of one voxel included: the picture a user stops on is the
//! one the renderer's figures are measured for, and the player renders it again when
//! playback stopped on a lower detail. Below
//! full detail the view pass also takes at most [`PLAYING_SLICES`] slices per voxel and,
//! on the CPU, takes smooth pixels from their neighbours ([`PLAYING_REUSE`]). What
//! each level costs in error against the full detail is in BENCHMARKS.md ("Viewer
//! playback: the lighting's detail").

use super::frame::StageTimes;
use haze_view::render::CrmOptions;

/// The details playback steps through, full first. Each step cuts a new frame's
/// lighting work to about a third (`(d₁/d₀)³` ≈ 0.3–0.42).
pub const LEVELS: [f64; 5] = [1.0, 0.75, 0.5, 0.35, 0.25];

/// The detail rises a step when the lighting costs less than this share of the view
/// pass: the finer step costs about 3× as much, so it still stays below the view pass.
pub const RAISE_BELOW: f64 = 0.25;

/// The lowest detail for smoke whose lit voxels are `tau` optical depths across (the
/// `thick` module's figure): the renderer's floor ([`CrmOptions::detail_floor`] of the grid
/// [`CrmOptions::for_smoke`] gives, the
/// environment grid's cells within [`MAX_CELL_TAU`](haze_view::render::MAX_CELL_TAU) optical depths across), not below
/// the last level (1 for a `tau` that is not a positive number).
pub fn floor(tau: f64) -> f64 {
    CrmOptions::default()
        .for_smoke(tau)
        .detail_floor(tau)
        .max(LEVELS[LEVELS.len() - 1])
}

/// The view pass's slices per voxel while playback lowers the lighting's detail (at
/// most; a view of fewer keeps its own): one, a march of half the default two's samples.
/// On held-out plume-d at 400 × 300 one slice is within 0.04 % (relative RMS over the
/// smoke, 0.3 % of the peak at most) of eight slices' picture where two are within
/// 0.01 % — far below what the lowered lighting detail itself changes (BENCHMARKS.md,
/// "Viewer playback: the lighting's detail"; decision 0073).
pub const PLAYING_SLICES: f64 = 1.0;

/// The share of the picture within which the CPU's view pass takes a pixel between its
/// even rows and columns from its neighbours (`CrmOptions::pixel_reuse`) in a picture
/// that will soon be replaced: a playback frame below full detail, a still while the
/// camera moves. At 800 × 600 and one slice per voxel, against marching every pixel:
/// held-out plume-d frame 30 (turbulent) 0.047 % relative RMS, the view pass 23 % faster;
/// plume-i frame 30 0.027 %, 50 % faster — about what one slice instead of two changes
/// (0.040 and 0.041 %) and far below what the lowered lighting detail does
/// (BENCHMARKS.md, "Viewer playback").
pub const PLAYING_REUSE: f64 = 0.002;

/// The slices per voxel of a picture that will soon be replaced (a playback frame below
/// full detail, a still while the camera moves) for a view that asks for `slices`: at
/// most [`PLAYING_SLICES`].
pub fn fewer_slices(slices: f64) -> f64 {
    slices.min(PLAYING_SLICES)
}

/// The smallest step down worth taking: a step to the floor is taken when the floor is
/// below this share of the current detail (at least `1 − 0.95³` ≈ 14 % less work).
pub const MIN_STEP: f64 = 0.95;

/// The player's choice of detail for playback (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetailControl {
    /// The detail the next frame is lit at: one of [`LEVELS`], or a floor between two.
    detail: f64,
    /// The lowest detail used, for the report.
    lowest: f64,
}

impl Default for DetailControl {
    fn default() -> DetailControl {
        DetailControl {
            detail: LEVELS[0],
            lowest: LEVELS[0],
        }
    }
}

/// Where a rendered frame's time went, as the control weighs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameCost {
    /// The view pass (GPU time where the device has timestamps).
    pub view_seconds: f64,
    /// The stages the detail steers: the lighting before the view pass.
    pub lighting_seconds: f64,
}

impl FrameCost {
    /// The cost of a job of `seconds` whose stages took `times`. The lighting: the
    /// host's lighting stages (single and multiple scattering, the volume, environment
    /// and lights passes) or the GPU's passes before the view pass, whichever took
    /// longer (each is the real cost where that side lights the frame, the other only
    /// submits or waits). The view pass: its GPU time from timestamps, else the job less
    /// the host's stages.
    pub fn of(seconds: f64, times: &StageTimes) -> FrameCost {
        let c = &times.crm;
        let host = c.single_seconds
            + c.multiple_seconds
            + c.volume_seconds
            + c.env_seconds
            + c.lights_seconds;
        // The view pass and the occupancy it skips by ("view pass occupancy").
        let is_view = |pass: &str| pass.starts_with("view pass");
        let gpu_lighting: f64 = times
            .gpu
            .iter()
            .filter(|(pass, _)| !is_view(pass))
            .map(|(_, s)| s)
            .sum();
        let view_seconds = if times.gpu.iter().any(|(pass, _)| *pass == "view pass") {
            times
                .gpu
                .iter()
                .filter(|(pass, _)| is_view(pass))
                .map(|(_, s)| s)
                .sum()
        } else {
            (seconds - c.setup_seconds - host).max(c.view_seconds)
        };
        FrameCost {
            view_seconds,
            lighting_seconds: host.max(gpu_lighting),
        }
    }
}

impl DetailControl {
    /// The detail the next playback frame is lit at.
    pub fn detail(&self) -> f64 {
        self.detail
    }

    /// The lowest detail playback has used so far.
    pub fn lowest(&self) -> f64 {
        self.lowest
    }

    /// The view pass's pixel reuse of the next playback frame of a view that asks for
    /// `reuse`: at least [`PLAYING_REUSE`] while the detail is below full, else `reuse`.
    pub fn pixel_reuse(&self, reuse: f64) -> f64 {
        if self.detail < 1.0 {
            reuse.max(PLAYING_REUSE)
        } else {
            reuse
        }
    }

    /// The slices per voxel of the next playback frame of a view that asks for `slices`:
    /// [`fewer_slices`] while the detail is below full, else `slices`.
    pub fn slices(&self, slices: f64) -> f64 {
        if self.detail < 1.0 {
            fewer_slices(slices)
        } else {
            slices
        }
    }

    /// Playback's first frame was lit at `detail` (the floor of its thickness, chosen
    /// where the frame was lit): the control goes on from there, as if it had chosen it.
    /// That frame itself is not weighed ([`DetailControl::observe`]): its view pass
    /// carries the run's one-time costs (on held-out plume-e at 800 × 600 on lavapipe
    /// 0.29 s, against 0.08–0.15 s for the frames after it), so its lighting looked cheap
    /// enough to raise the detail a step, and the frames after it, the plume growing,
    /// were lit at 1.1–1.3× their view pass until it came back down.
    pub fn start_at(&mut self, detail: f64) {
        self.detail = detail;
        self.lowest = self.lowest.min(detail);
    }

    /// Weighs a playback frame lit at `detail` that took `cost` against its slot of
    /// `slot_seconds` (`None`: playing as fast as possible, with no slot to meet, which
    /// changes nothing), its smoke's lit voxels `tau` optical depths across: a step
    /// down when it was late and its lighting cost more than its view pass — to the level
    /// whose lighting would fit ([`step_down`]: the next of [`LEVELS`], or further when
    /// the lighting is several times over), or to [`floor`]`(tau)` where that level would
    /// pass it and the floor is at least [`MIN_STEP`] lower; one up (to the next level
    /// above) when the lighting cost less than [`RAISE_BELOW`] of the view pass; to the
    /// floor at once when the detail is below it (thicker smoke). A frame lit at another detail than the current
    /// one (submitted before the last step) changes nothing.
    pub fn observe(&mut self, detail: f64, cost: FrameCost, slot_seconds: Option<f64>, tau: f64) {
        let Some(slot) = slot_seconds else { return };
        if detail != self.detail {
            return;
        }
        let lowest = floor(tau);
        let late = cost.view_seconds + cost.lighting_seconds > slot;
        let down = step_down(self.detail, cost, slot)
            .map(|l| l.max(lowest))
            .filter(|d| *d <= MIN_STEP * self.detail);
        let up = LEVELS.iter().rev().find(|l| **l > self.detail);
        if self.detail < lowest {
            // Thicker smoke: up to its floor at once (a floor that differs a little from
            // frame to frame then settles on the highest, instead of leaving the floor).
            self.detail = lowest;
        } else if let (Some(d), true) = (down, late && cost.lighting_seconds > cost.view_seconds) {
            self.detail = d;
            self.lowest = self.lowest.min(d);
        } else if let (Some(u), true) =
            (up, cost.lighting_seconds < RAISE_BELOW * cost.view_seconds)
        {
            self.detail = *u;
        }
    }
}

/// The level a late frame lit at `detail` steps down to: the lighting's work goes as the
/// detail cubed ([`LEVELS`]), so the detail whose lighting would take the view pass's
/// time (or the rest of the slot, where that is longer) is
/// `detail·(goal/lighting)^{1/3}`; the step goes to the highest level at or below it —
/// at least the next one, at most the last. A first frame whose lighting is ten times
/// its view pass goes from 1 to 0.35 at once instead of through 0.75 and 0.5, each of
/// which would take seconds on a CPU adapter. `None` at the last level.
fn step_down(detail: f64, cost: FrameCost, slot: f64) -> Option<f64> {
    let goal = cost.view_seconds.max(slot - cost.view_seconds);
    let wanted = if cost.lighting_seconds > 0.0 && goal.is_finite() {
        detail * (goal.max(0.0) / cost.lighting_seconds).cbrt()
    } else {
        detail
    };
    let below: Vec<f64> = LEVELS.iter().copied().filter(|l| *l < detail).collect();
    let last = *below.last()?;
    Some(below.into_iter().find(|l| *l <= wanted).unwrap_or(last))
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_view::render::CrmStats;

    /// Smoke thin enough for every level: cells of 6 voxels within 0.5 optical depths.
    const THIN: f64 = 0.05;

    fn cost(view: f64, lighting: f64) -> FrameCost {
        FrameCost {
            view_seconds: view,
            lighting_seconds: lighting,
        }
    }

    /// Late frames whose lighting outweighs the view pass step the detail down, one
    /// level a frame, to the last level; cheap lighting steps it back up; frames on time
    /// or lit at a stale detail leave it.
    /// Below full detail a view's slices are at most [`PLAYING_SLICES`] (fewer kept);
    /// at full detail they are the view's.
    #[test]
    fn playback_takes_fewer_slices_only_below_full_detail() {
        let mut c = DetailControl::default();
        assert_eq!((c.slices(2.0), c.slices(0.5)), (2.0, 0.5));
        c.start_at(0.75);
        assert_eq!(c.slices(2.0), PLAYING_SLICES);
        assert_eq!(c.slices(3.5), PLAYING_SLICES);
        assert_eq!(c.slices(0.5), 0.5);
    }

    /// Below full detail the CPU's view pass reuses pixels at [`PLAYING_REUSE`] at least;
    /// at full detail it takes the view's.
    #[test]
    fn playback_reuses_pixels_only_below_full_detail() {
        let mut c = DetailControl::default();
        assert_eq!((c.pixel_reuse(0.0), c.pixel_reuse(0.01)), (0.0, 0.01));
        c.start_at(0.5);
        assert_eq!(c.pixel_reuse(0.0), PLAYING_REUSE);
        assert_eq!(c.pixel_reuse(0.01), 0.01);
    }

    #[test]
    fn the_detail_steps_down_while_lighting_holds_playback_back() {
        let mut c = DetailControl::default();
        assert_eq!((c.detail(), c.lowest()), (1.0, 1.0));
        let slot = Some(1.0 / 24.0);
        // On time: nothing, however costly the lighting.
        c.observe(1.0, cost(0.01, 0.02), slot, THIN);
        assert_eq!(c.detail(), 1.0);
        // Late, but the view pass is the cost: nothing to gain from the lighting.
        c.observe(1.0, cost(1.0, 0.9), slot, THIN);
        assert_eq!(c.detail(), 1.0);
        // As fast as possible: no slot, nothing changes.
        c.observe(1.0, cost(1.0, 5.0), None, THIN);
        assert_eq!(c.detail(), 1.0);
        // Late and the lighting a little over the view pass: down a step per frame.
        for (k, want) in LEVELS.iter().enumerate().skip(1) {
            c.observe(LEVELS[k - 1], cost(1.0, 1.2), slot, THIN);
            assert_eq!(c.detail(), *want);
        }
        c.observe(0.25, cost(1.0, 1.2), slot, THIN);
        assert_eq!(
            (c.detail(), c.lowest()),
            (0.25, 0.25),
            "the last level holds"
        );
        // A frame lit at a stale detail changes nothing.
        c.observe(1.0, cost(1.0, 0.0), slot, THIN);
        assert_eq!(c.detail(), 0.25);
        // Between RAISE_BELOW and 1× the view pass: it stays.
        c.observe(0.25, cost(1.0, 0.5), slot, THIN);
        assert_eq!(c.detail(), 0.25);
        // Cheap lighting: back up, one step a frame; the lowest is remembered.
        c.observe(0.25, cost(1.0, 0.1), slot, THIN);
        assert_eq!(c.detail(), 0.35);
        c.observe(0.35, cost(1.0, 0.1), slot, THIN);
        assert_eq!((c.detail(), c.lowest()), (0.5, 0.25));
    }

    /// A frame whose lighting is many times its view pass steps down to the level whose
    /// lighting (the detail cubed) would fit beside the view pass, or the rest of a long
    /// slot: several levels at once, never below the floor or the last level.
    #[test]
    fn lighting_far_over_the_view_pass_steps_down_several_levels() {
        let slot = 1.0 / 24.0;
        // 10× the view pass: (1/10)^(1/3) = 0.46, so 0.35.
        assert_eq!(step_down(1.0, cost(0.4, 4.0), slot), Some(0.35));
        // 100×: below every level, so the last.
        assert_eq!(step_down(1.0, cost(0.1, 10.0), slot), Some(0.25));
        // 1.2×: the next level; from the last, none.
        assert_eq!(step_down(0.5, cost(1.0, 1.2), slot), Some(0.35));
        assert_eq!(step_down(0.25, cost(1.0, 100.0), slot), None);
        // A slot of a second with a view pass of 0.1 s leaves 0.9 s for lighting of 2 s:
        // (0.45)^(1/3) = 0.77, one step.
        assert_eq!(step_down(1.0, cost(0.1, 2.0), 1.0), Some(0.75));
        // No lighting time, or a zero view pass: one step, no division by zero.
        assert_eq!(step_down(1.0, cost(0.0, 0.0), slot), Some(0.75));
        assert_eq!(step_down(0.75, cost(0.0, 1.0), slot), Some(0.25));
        // Through the control: the floor holds (τ 0.13: 0.39), the lowest is kept.
        let mut c = DetailControl::default();
        c.observe(1.0, cost(0.4, 4.0), Some(slot), THIN);
        assert_eq!((c.detail(), c.lowest()), (0.35, 0.35));
        let mut c = DetailControl::default();
        c.observe(1.0, cost(0.4, 4.0), Some(slot), 0.13);
        assert!((c.detail() - floor(0.13)).abs() < 1e-12, "{}", c.detail());
    }

    /// The floor keeps the environment grid's cells within half an optical depth:
    /// thin smoke may go to the last level, thicker smoke stops higher, and a detail
    /// below the floor (the smoke thickened, σt rose) steps back up.
    #[test]
    fn thick_smoke_keeps_more_detail() {
        // 1.5 voxels × τ / detail ≤ 0.5.
        assert_eq!(floor(0.05), 0.25);
        assert!((floor(0.1) - 0.3).abs() < 1e-12);
        // Past τ = 1/3 the grid's nodes sit on the voxel centers (`for_smoke`): 1 voxel ×
        // τ / detail ≤ 0.5.
        assert!((floor(0.45) - 0.9).abs() < 1e-12);
        assert_eq!(floor(0.5), 1.0);
        for bad in [0.0, -1.0, f64::NAN] {
            assert_eq!(floor(bad), 1.0, "{bad}");
        }
        assert_eq!(floor(f64::INFINITY), 1.0);
        let slot = Some(1.0 / 24.0);
        // A little over: one step a frame.
        let late = cost(1.0, 1.2);
        // τ 0.2: floor 0.6, so one level (0.75), then the floor, and no further.
        let mut c = DetailControl::default();
        for d in [0.75, 0.6, 0.6] {
            c.observe(c.detail(), late, slot, 0.2);
            assert!((c.detail() - d).abs() < 1e-12, "{} for {d}", c.detail());
        }
        // τ 0.1: floor 0.3, down to 0.35, then to the floor itself (0.3 < 0.95 × 0.35).
        for d in [0.5, 0.35, 0.3, 0.3] {
            c.observe(c.detail(), late, slot, 0.1);
            assert!((c.detail() - d).abs() < 1e-12, "{} for {d}", c.detail());
        }
        assert_eq!(c.lowest(), c.detail());
        // The smoke thickens (τ 0.2): back up to its floor at once, however late, and
        // no lower.
        for d in [0.6, 0.6] {
            c.observe(c.detail(), late, slot, 0.2);
            assert!((c.detail() - d).abs() < 1e-12, "{} for {d}", c.detail());
        }
        // τ 0.13 (floor 0.39): from 0.5 to the floor, not the level below it; back up to
        // 0.5 once the lighting is cheap.
        let mut c = DetailControl::default();
        for _ in 0..4 {
            c.observe(c.detail(), late, slot, 0.13);
        }
        assert!((c.detail() - floor(0.13)).abs() < 1e-12, "{}", c.detail());
        // A frame whose floor is a little lower leaves it there; one a little higher
        // raises it to that floor, not a level.
        c.observe(c.detail(), late, slot, 0.128);
        assert!((c.detail() - floor(0.13)).abs() < 1e-12, "{}", c.detail());
        c.observe(c.detail(), late, slot, 0.132);
        assert!((c.detail() - floor(0.132)).abs() < 1e-12, "{}", c.detail());
        c.observe(c.detail(), cost(1.0, 0.1), slot, 0.13);
        assert_eq!(c.detail(), 0.5);
        // A floor within MIN_STEP of the level above is not worth a step: τ 0.16 (floor
        // 0.48) stays at 0.5.
        let mut c = DetailControl::default();
        for _ in 0..4 {
            c.observe(c.detail(), late, slot, 0.16);
        }
        assert_eq!(c.detail(), 0.5);
    }

    /// The view pass comes from the GPU's timestamps when there are some, else from the
    /// job less its host stages; the lighting is the larger of the host's lighting
    /// stages and the GPU's passes before the view pass.
    #[test]
    fn a_frame_cost_splits_the_job_at_the_view_pass() {
        let crm = CrmStats {
            setup_seconds: 0.5,
            multiple_seconds: 2.0,
            env_seconds: 1.5,
            lights_seconds: 0.5,
            volume_seconds: 0.25,
            view_seconds: 0.01,
            ..CrmStats::default()
        };
        // Lit on the host.
        let cpu = StageTimes {
            crm: crm.clone(),
            gpu: vec![("view pass occupancy", 0.25), ("view pass", 1.0)],
            ..StageTimes::default()
        };
        // The view pass with the occupancy it skips by.
        assert_eq!(FrameCost::of(6.0, &cpu), cost(1.25, 4.25));
        // Lit on the GPU: the host only submitted.
        let gpu = StageTimes {
            crm: CrmStats {
                multiple_seconds: 0.01,
                env_seconds: 0.02,
                ..CrmStats::default()
            },
            gpu: vec![
                ("environment grid", 0.1),
                ("orders gather", 0.05),
                ("view pass", 0.002),
            ],
            ..StageTimes::default()
        };
        let c = FrameCost::of(0.2, &gpu);
        assert_eq!(c.view_seconds, 0.002);
        assert!((c.lighting_seconds - 0.15).abs() < 1e-12, "{c:?}");
        // No timestamps: the view pass is the job less the host's stages, at least the
        // host's own count of it.
        let host_only = StageTimes {
            crm,
            ..StageTimes::default()
        };
        assert_eq!(FrameCost::of(6.0, &host_only), cost(1.25, 4.25));
        assert_eq!(FrameCost::of(1.0, &host_only), cost(0.01, 4.25));
    }
}
