//! Fitting a sequence with temporal coherence (paper A §5.1): the first frame is fitted
//! from scratch with teleportation; every later frame starts from the previous frame's
//! RBFs, deletes the `k` with the smallest integrals, is minimized without teleportation,
//! and while its relative error exceeds the first frame's by more than the threshold ratio,
//! gets RBFs of fixed radius inserted at the largest errors and is minimized again. Few
//! RBFs move far between frames, so the fit does not flicker.
//!
//! Insertion ([`Insertion`]). The paper inserts one RBF at a time, each followed by a
//! whole minimization, up to `m = 8`: smoke that grows faster than 8 RBFs per frame drifts
//! away from the first frame's error, and each insertion costs a warm minimization.
//! [`Insertion::Batch`] sizes each round by how far the error is from its target: with
//! `rel_l2 ∝ n^(−α)` along the RBF-count curve, reaching `target` from `rel_l2` takes
//! `n·((rel_l2/target)^(1/α) − 1)` more RBFs (`α = 1/3`), placed by matching pursuit
//! on the residual ([`crate::init::matched`]: where a Gaussian of the insertion radius
//! lowers `ΣR²` most, rather than on the largest single voxel) and then minimized
//! with the RBFs whose supports overlap theirs, the rest frozen ([`crate::local`]; a
//! round of a few RBFs at 1200 costs a few dozen RBFs' passes instead of a whole frame's,
//! and the next frame's warm start minimizes all of them again). Rounds repeat until the ratio holds, or a round removes less
//! than [`MIN_ROUND_GAIN`] of the excess error (the error left is finer than an RBF can
//! reach: the residual's job).
//!
//! Marginal gain. Each RBF that matching pursuit proposes comes with its predicted
//! reduction of the error ([`crate::init::matched_with_gains`]), measured as `∫R² dV` in
//! world units (density² × volume, so frames of different peaks and boxes compare). The
//! first frame sets the price: the mean predicted gain of the [`insert_floor`] RBFs that
//! matching pursuit would add to its converged fit, the marginal gain of RBFs past its
//! count. A warm frame inserts only the RBFs predicted to gain at least
//! [`SequenceOptions::marginal_gain`] (default [`MARGINAL_GAIN`]) times that price, and
//! stops inserting after a round where some proposal fell short (the ones that paid are
//! in) or none paid: RBFs are spent only while they pay about as well as
//! the first frame's last ones, not on detail finer than a Gaussian of the insertion
//! radius resolves. Every warm frame records why insertion stopped ([`InsertionStop`]).
//!
//! The per-frame cap follows the smoke and the error: a frame may add as
//! many RBFs as keep the previous frame's RBFs per voxel of smoke ([`smoke_support`])
//! over its grown support, or as many as its excess error asks for ([`batch_size`] after
//! the warm minimization, [`excess_insert_cap`]), and at least an eighth of the first
//! frame's count (4.6× the paper's 8 at 300 RBFs); no frame grows
//! past [`SequenceOptions::max_rbfs`] (by default [`GROWTH_LIMIT`] times the first
//! frame's count). The ceiling bounds the cost of a frame (a pass costs in proportion to
//! the RBFs) where the smoke turns turbulent faster than its size grows: on
//! such smoke a fit from scratch with the same RBF count is no better (BENCHMARKS.md),
//! the first frame's error is out of reach of any RBF count a renderer would take, and
//! the residual stores the rest.
//!
//! Exchange ([`crate::exchange`]). A frame still over the threshold when insertion stops
//! (cap, ceiling, marginal gain, stall) does not give up: in rounds, the RBFs whose
//! removal would raise `ΣR²` least are moved to where matching pursuit predicts a larger
//! gain (at most a quarter of the RBFs a round, [`EXCHANGE_SHARE`]), followed by a
//! minimization of the moved RBFs and those whose supports overlap them where they were
//! or where they went, the rest frozen ([`crate::local`]); a round that does not lower the error is undone, and rounds stop when
//! the ratio holds or a round removes less than [`MIN_ROUND_GAIN`] of the excess. Smoke
//! that leaves one place for another (a moving emitter, old smoke thinning) keeps its
//! error at a constant count. A frame left over the threshold after all this is
//! reported and logged.
//!
//! Warm minimizations stop by the windowed test of [`Stop`]: a warm start sits near its
//! optimum, and the last iterations of a tight per-iteration test buy nothing visible.
//! Where the RBFs are narrow they run at full resolution: a warm start is already near
//! the fine optimum, and a detour through the coarse one costs more polish than it saves;
//! where they are wide (fast turbulent smoke, whose warm starts sit far from their
//! optimum) they run on the half-resolution grid first and polish briefly
//! ([`crate::warm`], BENCHMARKS.md).
//!
//! An all-zero frame has no RBFs; the next non-empty frame starts afresh as a first frame.

use crate::bounds::Bounds;
use crate::exchange::{paying_exchanges, removal_costs};
use crate::frame::{Coarse, FitOptions, FitStats, fit_first_frame, weakest};
use crate::grid::FitGrid;
use crate::init::{greedy, initial_radius, matched_with_gains};
use crate::local::overlapping;
use crate::objective::{self, PARAMS_PER_RBF};
use crate::optimize::Stop;
use crate::warm::WarmMinimizer;
use haze_volume::{Rbf, Volume};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Settings of a sequence fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceOptions {
    pub fit: FitOptions,
    /// RBFs of a first frame.
    pub rbfs: usize,
    /// RBFs deleted at the start of each later frame (paper: 3).
    pub delete: usize,
    /// Most RBFs inserted per later frame (paper: 8); `None`: the larger of
    /// [`auto_insert_cap`] (the smoke's growth, at least an eighth of the first frame's
    /// count) and [`excess_insert_cap`] (the error's excess).
    pub max_insert: Option<usize>,
    /// Most RBFs a later frame may have: insertion stops there (a frame over the
    /// threshold is then reported as capped); `None`: [`GROWTH_LIMIT`] times the first
    /// frame's count.
    #[serde(default)]
    pub max_rbfs: Option<usize>,
    /// Insert while rel_l2 / first frame's rel_l2 exceeds this (paper: 1.05–1.2).
    pub threshold: f64,
    /// How RBFs are inserted.
    pub insertion: Insertion,
    /// Stopping rule of each warm-started minimization (of all RBFs after the deletions,
    /// of the RBFs a round touches after it); on the half-resolution grid where
    /// [`SequenceOptions::warm_coarse`] applies, then polished at full resolution.
    pub warm: Stop,
    /// Whether warm minimizations run on the half-resolution grid first
    /// ([`crate::warm`]; `Auto`: on grids of 64³ voxels or more).
    #[serde(default)]
    pub warm_coarse: Coarse,
    /// Iteration budget of the full-resolution polish after a warm minimization's coarse
    /// stage (at least 1).
    #[serde(default = "default_warm_polish")]
    pub warm_polish: u64,
    /// Insert an RBF only where it is predicted to lower `∫R² dV` by at least this
    /// fraction of the first frame's marginal gain (see the module docs); 0: no such test.
    #[serde(default = "default_marginal_gain")]
    pub marginal_gain: f64,
}

fn default_marginal_gain() -> f64 {
    MARGINAL_GAIN
}

fn default_warm_polish() -> u64 {
    WARM_POLISH_ITERATIONS
}

/// The default share of the first frame's marginal gain that an inserted RBF must be
/// predicted to reach. Along the first frame's RBF-count curve (`rel_l2 ∝ n^(−α)`,
/// `α ≈ 0.26–0.33`) the gain of one more RBF falls as `n^(−1−2α)`: half of it is the
/// gain at about 1.5× the first frame's count.
pub const MARGINAL_GAIN: f64 = 0.5;

/// Why a warm frame stopped inserting RBFs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InsertionStop {
    /// The error ratio is within the threshold (with or without insertions or moved RBFs).
    TargetMet,
    /// A round's proposals, all or some, were predicted to gain less than the share of
    /// the first frame's marginal gain (those that paid were inserted).
    MarginalGain,
    /// A round removed less than [`MIN_ROUND_GAIN`] of the excess error.
    Stalled,
    /// Matching pursuit found no positive residual to place an RBF on.
    Nowhere,
    /// The frame inserted its per-frame cap (`--max-insert`, or the automatic one).
    Cap,
    /// The frame reached [`SequenceOptions::max_rbfs`].
    Ceiling,
}

impl InsertionStop {
    /// The reason in words, for logs and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            InsertionStop::TargetMet => "target met",
            InsertionStop::MarginalGain => "marginal gain",
            InsertionStop::Stalled => "stalled",
            InsertionStop::Nowhere => "nowhere to insert",
            InsertionStop::Cap => "cap",
            InsertionStop::Ceiling => "ceiling",
        }
    }
}

/// The default ceiling of a later frame's RBF count, in first frames' counts: a bound on
/// what a frame costs (a pass costs in proportion to the RBFs). Smoke whose detail
/// outgrows its size is not fitted better from scratch with more RBFs than a warm frame
/// has (BENCHMARKS.md, plume-d), and the residual stores what the RBFs miss. With the
/// local rounds and the cheaper pass, 8× holds every frame of plume-e (4×: 11 of 44 over
/// 1.1) for 34 % more bake time and lowers plume-d's worst ratio 1.86 → 1.66 for 42 %
/// more (BENCHMARKS.md, "The default ceiling"); sequences that stay within their first
/// frame's error below it never reach it.
pub const GROWTH_LIMIT: usize = 8;

/// The automatic insertion cap's floor, for frames with few RBFs.
pub const MIN_AUTO_INSERT: usize = 16;

/// The smallest automatic insertion cap: an eighth of the first frame's `rbfs`, at least
/// [`MIN_AUTO_INSERT`]. Also the number of RBFs whose mean predicted gain on the first
/// frame sets the marginal-gain price.
pub fn insert_floor(rbfs: usize) -> usize {
    (rbfs / 8).max(MIN_AUTO_INSERT)
}

/// Smoke is where the density exceeds this share of the frame's peak ([`smoke_support`]).
pub const SUPPORT_LEVEL: f64 = 0.01;

/// Voxels of smoke: the density above [`SUPPORT_LEVEL`] of the frame's peak. The measure of
/// the smoke's size that the automatic insertion cap follows; thin wisps below 1 % of the
/// peak barely change the fit's error.
pub fn smoke_support(grid: &FitGrid) -> usize {
    grid.nonzero
        .iter()
        .filter(|&&i| grid.density[i] > SUPPORT_LEVEL)
        .count()
}

/// The automatic per-frame insertion cap: the RBFs that keep `n_previous` RBFs per voxel
/// of smoke when its support grows from `support_previous` to `support` voxels, plus the
/// `deleted` ones, and at least an eighth of the first frame's `rbfs` (never below
/// [`MIN_AUTO_INSERT`]) for smoke that changes shape without growing.
pub fn auto_insert_cap(
    rbfs: usize,
    n_previous: usize,
    support_previous: usize,
    support: usize,
    deleted: usize,
) -> usize {
    let floor = insert_floor(rbfs);
    if support_previous == 0 || support <= support_previous {
        return floor;
    }
    // ⌈n·(s − s₀)/s₀⌉ in integers: exact where a float product rounds up a whole count.
    let grown = (n_previous as u128 * (support - support_previous) as u128)
        .div_ceil(support_previous as u128);
    let follow = usize::try_from(grown).unwrap_or(usize::MAX);
    follow.saturating_add(deleted).max(floor)
}

/// The per-frame cap grows with the error's excess: at least the RBFs that
/// [`batch_size`] asks for to bring `rel_l2` of `n` RBFs down to `target`, so that a frame
/// whose smoke turned more detailed than it grew gets its first round in full (the
/// marginal-gain test and [`SequenceOptions::max_rbfs`] still bound it).
pub fn excess_insert_cap(n: usize, rel_l2: f64, target: f64) -> usize {
    if rel_l2 > target {
        batch_size(n, rel_l2, target)
    } else {
        0
    }
}

/// At the ceiling an exchange round moves at most this share (1/4) of the frame's RBFs.
pub const EXCHANGE_SHARE: usize = 4;

/// An insertion round must remove at least this share of the excess error
/// (`rel_l2 − target`) for another round to follow; below it the frame is reported as
/// over the threshold (`insertion_stalled`). Exchange rounds stop by the same share. Close
/// to the target a round is a few RBFs ([`batch_size`]) and removes less of the excess
/// than the `n^(−1/3)` curve predicts: at a quarter, 9 of 25 frames of a held-out growing
/// plume stopped at 1.101–1.109 of the first frame's error; at a tenth 2 stayed over
/// (stopped by the cap and the marginal gain instead) at the same median seconds, and
/// none with today's [`WARM_ITERATIONS`] (BENCHMARKS.md).
pub const MIN_ROUND_GAIN: f64 = 0.1;

/// How a warm frame gets RBFs where its error is too high (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Insertion {
    /// Rounds sized by the excess error, each followed by a minimization of the new RBFs
    /// and those their supports overlap.
    #[default]
    Batch,
    /// The paper's: one RBF, then a joint minimization, per round.
    Single,
}

impl Default for SequenceOptions {
    fn default() -> Self {
        SequenceOptions {
            fit: FitOptions::default(),
            rbfs: 300,
            delete: 3,
            max_insert: None,
            max_rbfs: None,
            threshold: 1.1,
            insertion: Insertion::default(),
            warm: Stop {
                max_iterations: WARM_ITERATIONS,
                relative_reduction: 0.0,
                window: 10,
                window_gain: WARM_WINDOW_GAIN,
            },
            warm_coarse: Coarse::Auto,
            warm_polish: WARM_POLISH_ITERATIONS,
            marginal_gain: MARGINAL_GAIN,
        }
    }
}

/// The iteration budget of each warm minimization. A warm start far from its optimum
/// (fast turbulent smoke: centres moving a tenth of the box a frame) creeps down for
/// 100–160 iterations, gaining 1–2 % of rel_l2 in the last two thirds of them; stopped at
/// 80, insertion meets the threshold instead with 0–3.5 % more RBFs, the mean rel_l2 and
/// the residual's bytes within 2 %, and warm frames 15–35 % faster (BENCHMARKS.md, held-out
/// plumes).
pub const WARM_ITERATIONS: u64 = 80;

/// The iteration budget of the full-resolution polish after a warm minimization's
/// coarse stage ([`crate::warm`]). On a held-out turbulent plume (96 × 96 × 128, frames
/// 20..45, `haze bake`) the coarse stage at [`WARM_ITERATIONS`] and a polish of 20 take
/// the warm frames from 1.08 s to 0.61 s (median) and 1.79 s to 0.96 s (slowest), with
/// 2 % fewer RBFs and the same error; a polish of 10 is faster still but left two frames
/// of another plume over the threshold, one of 40 is slower for no fewer RBFs
/// (BENCHMARKS.md).
pub const WARM_POLISH_ITERATIONS: u64 = 20;

/// The windowed test of a warm minimization: stop when the last 10 iterations together
/// lowered `rel_l2²` by less than this share of it (0.02 % an iteration). Against 1e-3 it
/// ends warm frames with 17–29 % fewer iterations for < 1 % higher mean rel_l2
/// (BENCHMARKS.md, plume-b and plume-c).
pub const WARM_WINDOW_GAIN: f64 = 2e-3;

/// RBFs of one insertion round: the count that the RBF-count curve `rel_l2 ∝ n^(−1/3)`
/// needs to bring `rel_l2` down to `target` from `n` RBFs; at least 1.
pub fn batch_size(n: usize, rel_l2: f64, target: f64) -> usize {
    if !(target > 0.0 && rel_l2 > target) {
        return 1;
    }
    let more = n as f64 * ((rel_l2 / target).powi(3) - 1.0);
    (more.ceil() as usize).max(1)
}

/// The fit of one frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameFit {
    /// The RBFs in world coordinates and density units.
    #[serde(skip)]
    pub rbfs: Vec<Rbf>,
    /// `sqrt(Σ(D − D̃)² / ΣD²)` (0 for an all-zero frame).
    pub rel_l2: f64,
    /// `sqrt(mean((D − D̃)²)) / max D` (0 for an all-zero frame).
    pub rms_over_max: f64,
    pub fit_seconds: f64,
    /// Seconds spent inserting and exchanging (placing RBFs, the minimizations after each
    /// round).
    #[serde(default)]
    pub insert_seconds: f64,
    pub iterations: u64,
    /// Of which at half resolution (coarse to fine).
    #[serde(default)]
    pub coarse_iterations: u64,
    /// Objective passes in all (line searches included).
    #[serde(default)]
    pub passes: u64,
    pub teleports: u64,
    /// Started from the previous frame's RBFs.
    pub warm_started: bool,
    pub deleted: usize,
    pub inserted: usize,
    /// RBFs moved at the ceiling: removed where they lowered the error least and put
    /// where matching pursuit predicts a larger gain ([`crate::exchange`]).
    #[serde(default)]
    pub exchanged: usize,
    /// Insertion rounds.
    #[serde(default)]
    pub insert_rounds: usize,
    /// The most RBFs this frame could insert (`--max-insert`, or the larger of
    /// [`auto_insert_cap`] and [`excess_insert_cap`], within
    /// [`SequenceOptions::max_rbfs`]); 0 for a first frame.
    #[serde(default)]
    pub insert_cap: usize,
    /// rel_l2 over the first frame's rel_l2 (1 for a first frame).
    pub error_ratio: f64,
    /// The insertion cap was reached with the ratio still above the threshold.
    pub insertion_capped: bool,
    /// The ratio is above the threshold below the cap: insertion stopped paying (a round
    /// removed less than [`MIN_ROUND_GAIN`] of the excess error) or found nowhere to go.
    #[serde(default)]
    pub insertion_stalled: bool,
    /// Why insertion stopped (`None` for a first or empty frame).
    #[serde(default)]
    pub insertion_stop: Option<InsertionStop>,
    /// Predicted `∫R² dV` reduction (world units) of the best RBF the last round left
    /// out for falling short of `gain_floor`, or where it left none out, of its best
    /// proposal (`None`: no round, or matching pursuit proposed nothing).
    #[serde(default)]
    pub next_gain: Option<f64>,
    /// The smallest predicted gain an inserted RBF needed (the marginal-gain share of the
    /// first frame's; for a first frame, its own marginal gain); 0 without the test.
    #[serde(default)]
    pub gain_floor: f64,
    /// RBFs with a radius or weight on its bound.
    pub rbfs_at_bounds: usize,
    /// Mean world distance moved by RBF centers that persisted from the previous frame.
    pub mean_center_displacement: Option<f64>,
    /// Where a warm frame's seconds went (all zero for a first frame).
    #[serde(default)]
    pub split: TimeSplit,
}

/// Seconds of a warm frame by step: the minimizations (the first one after the
/// deletions, those after insertion rounds, those after exchange rounds) with their
/// passes, and the pricing between them (residual grids and matching pursuit, removal
/// costs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TimeSplit {
    /// The minimization after the deletions.
    pub warm_seconds: f64,
    pub warm_passes: u64,
    /// The minimizations after insertion rounds.
    pub insert_seconds: f64,
    pub insert_passes: u64,
    /// The minimizations after exchange rounds.
    pub exchange_seconds: f64,
    pub exchange_passes: u64,
    /// Residuals, residual grids and matching pursuit's proposals.
    pub pursuit_seconds: f64,
    /// Removal costs of exchange rounds.
    pub removal_seconds: f64,
}

/// A reduction of `ΣR²` on `grid` (normalized densities, summed over voxels) as
/// `∫R² dV` in world units: × (peak density)² × the world volume of a voxel.
pub fn world_gain(grid: &FitGrid, gain: f64) -> f64 {
    let voxel: f64 = grid.h.iter().map(|h| h * grid.unit).product();
    gain * grid.max_density * grid.max_density * voxel
}

/// Error measures of `params` on `grid`.
pub fn errors(grid: &FitGrid, params: &[f64]) -> (f64, f64) {
    if grid.sum_sq <= 0.0 || grid.is_empty() {
        return (0.0, 0.0);
    }
    let r = objective::residual(grid, params);
    let e: f64 = r.iter().map(|v| v * v).sum();
    ((e / grid.sum_sq).sqrt(), (e / r.len() as f64).sqrt())
}

/// The measures of [`errors`] from the objective `f = ΣR²/ΣD²` that a minimization
/// returns with its parameters, without another pass over the grid.
fn errors_from_cost(grid: &FitGrid, f: f64) -> (f64, f64) {
    if grid.sum_sq <= 0.0 || grid.is_empty() {
        return (0.0, 0.0);
    }
    let f = f.max(0.0);
    (f.sqrt(), (f * grid.sum_sq / grid.len() as f64).sqrt())
}

/// Fits frames one after another, carrying RBFs from frame to frame.
#[derive(Debug)]
pub struct SequenceFitter {
    opts: SequenceOptions,
    previous: Option<Vec<Rbf>>,
    /// rel_l2 and insertion radius (world units) of the current run's first frame.
    first: Option<(f64, f64)>,
    /// [`smoke_support`] of the last fitted frame.
    support: Option<usize>,
    /// The current run's first frame's marginal gain (`∫R² dV`, world units).
    first_gain: Option<f64>,
    /// A first frame's figures that a cold start keeps instead of its own ([`Baseline`]).
    pinned: Option<Baseline>,
    /// The current run's first frame's RBF count and voxels of smoke.
    first_size: Option<(usize, usize)>,
}

/// What later frames of a sequence are held to: its first frame's rel_l2 and insertion
/// radius (the threshold ratio and insertion test), its marginal gain, and its RBFs per
/// voxel of smoke. A chunk of a sequence baked apart, pinned to the sequence's baseline,
/// starts cold with as many RBFs per voxel of smoke ([`smoke_support`]) as the sequence's
/// first frame had — the density the sequence's own insertion cap keeps — and inserts
/// towards the same error as one bake of the whole sequence would, instead of towards
/// its own cold start's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Baseline {
    pub rel_l2: f64,
    /// World units.
    pub radius: f64,
    pub gain: f64,
    /// The first frame's RBF count and its voxels of smoke.
    pub rbfs: usize,
    pub support: usize,
}

/// What a [`SequenceFitter`] carries from one frame to the next: enough to continue an
/// interrupted sequence exactly where it stopped.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FitterState {
    /// The last frame's RBFs (full precision).
    pub previous: Option<Vec<Rbf>>,
    /// rel_l2 and insertion radius (world units) of the current run's first frame.
    pub first: Option<(f64, f64)>,
    /// [`smoke_support`] of the last fitted frame (absent in journals of older bakes: the
    /// next frame's cap then takes the floor).
    #[serde(default)]
    pub support: Option<usize>,
    /// The first frame's marginal gain (absent in journals of older bakes: the resumed
    /// frames then insert without the marginal-gain test).
    #[serde(default)]
    pub first_gain: Option<f64>,
}

impl SequenceFitter {
    pub fn new(opts: SequenceOptions) -> Self {
        Self::resume(opts, FitterState::default())
    }

    /// A fitter that continues after the frame whose [`state`](Self::state) this is.
    pub fn resume(opts: SequenceOptions, state: FitterState) -> Self {
        SequenceFitter {
            opts,
            previous: state.previous,
            first: state.first,
            support: state.support,
            first_gain: state.first_gain,
            pinned: None,
            first_size: None,
        }
    }

    /// Holds every later frame to `baseline` (a cold start fits its frame as usual but
    /// keeps `baseline` as its first frame's figures).
    pub fn pin(&mut self, baseline: Baseline) {
        self.pinned = Some(baseline);
    }

    /// The current run's first frame's figures, once it has been fitted in this fitter.
    pub fn baseline(&self) -> Option<Baseline> {
        match (self.first, self.first_gain, self.first_size) {
            (Some((rel_l2, radius)), Some(gain), Some((rbfs, support))) => Some(Baseline {
                rel_l2,
                radius,
                gain,
                rbfs,
                support,
            }),
            _ => None,
        }
    }

    /// The RBFs of a cold start on `grid`: the options' count, or pinned, the baseline's
    /// RBFs per voxel of smoke (within 1 and the growth ceiling).
    fn cold_count(&self, grid: &FitGrid) -> usize {
        let o = &self.opts;
        match self.pinned {
            Some(b) if b.rbfs > 0 && b.support > 0 => {
                let ceiling = o.max_rbfs.unwrap_or(o.rbfs.saturating_mul(GROWTH_LIMIT));
                let n = b.rbfs as f64 * smoke_support(grid) as f64 / b.support as f64;
                (n.round() as usize).clamp(1, ceiling.max(1))
            }
            _ => o.rbfs,
        }
    }

    /// The state after the last fitted frame.
    pub fn state(&self) -> FitterState {
        FitterState {
            previous: self.previous.clone(),
            first: self.first,
            support: self.support,
            first_gain: self.first_gain,
        }
    }

    pub fn options(&self) -> &SequenceOptions {
        &self.opts
    }

    /// Fits the next frame; refuses non-finite or negative densities.
    pub fn fit(&mut self, volume: &Volume) -> Result<FrameFit, String> {
        let start = Instant::now();
        let grid = FitGrid::from_volume(volume)?;
        let mut out = if grid.sum_sq <= 0.0 {
            self.previous = None;
            self.first = None;
            self.first_gain = None;
            empty_fit()
        } else {
            match (self.previous.take(), self.first) {
                (Some(prev), Some(first)) if !prev.is_empty() => self.warm(&grid, &prev, first),
                _ => self.cold(&grid),
            }
        };
        out.fit_seconds = start.elapsed().as_secs_f64();
        self.previous = Some(out.rbfs.clone());
        self.support = Some(smoke_support(&grid));
        Ok(out)
    }

    fn cold(&mut self, grid: &FitGrid) -> FrameFit {
        let (params, stats) = fit_first_frame(grid, self.cold_count(grid), &self.opts.fit);
        let (rel_l2, rms) = errors(grid, &params);
        let n = (params.len() / PARAMS_PER_RBF).max(1);
        let radius = initial_radius(grid, n, &self.opts.fit.bounds) * grid.unit;
        self.first = Some((rel_l2, radius));
        // The marginal gain: what the next RBFs of the insertion radius would buy.
        let residual = grid.residual_grid(objective::residual(grid, &params));
        let (_, gains) = matched_with_gains(
            &residual,
            insert_floor(self.opts.rbfs),
            radius / grid.unit,
            &self.opts.fit.bounds,
        );
        let gain = if gains.is_empty() {
            0.0
        } else {
            world_gain(grid, gains.iter().sum::<f64>() / gains.len() as f64)
        };
        self.first_gain = Some(gain);
        self.first_size = Some((params.len() / PARAMS_PER_RBF, smoke_support(grid)));
        if let Some(b) = self.pinned {
            self.first = Some((b.rel_l2, b.radius));
            self.first_gain = Some(b.gain);
        }
        let mut f = finish(grid, &params, &self.opts, stats, rel_l2, rms);
        f.gain_floor = self.first_gain.unwrap_or(gain);
        f
    }

    fn warm(
        &mut self,
        grid: &FitGrid,
        prev: &[Rbf],
        (first_rel, radius_world): (f64, f64),
    ) -> FrameFit {
        let o = &self.opts;
        let bounds = &o.fit.bounds;
        let mut params: Vec<f64> = Vec::with_capacity(prev.len() * PARAMS_PER_RBF);
        for rbf in prev {
            if let Some((c, r, w)) = grid.from_world(rbf) {
                let mut p = [c[0], c[1], c[2], r, w];
                bounds.clamp(grid, &mut p);
                params.extend_from_slice(&p);
            }
        }
        // Delete the k weakest; remember which survive to measure their motion.
        let mut alive: Vec<usize> = (0..prev.len()).collect();
        let mut deleted = 0;
        while deleted < o.delete && params.len() > PARAMS_PER_RBF {
            let Some(l) = weakest(&params) else { break };
            params.drain(l * PARAMS_PER_RBF..(l + 1) * PARAMS_PER_RBF);
            alive.remove(l);
            deleted += 1;
        }
        let mut stats = FitStats::default();
        let mut split = TimeSplit::default();
        let t = Instant::now();
        let warm = WarmMinimizer::new(
            grid,
            o.warm_coarse,
            &params,
            bounds,
            o.fit.optimizer,
            o.warm,
            o.warm_polish,
        );
        let m = warm.all(&mut params);
        (split.warm_seconds, split.warm_passes) = (t.elapsed().as_secs_f64(), m.passes());
        m.add_to(&mut stats);
        let (mut rel_l2, mut rms) = errors_from_cost(grid, m.cost());
        let ratio = |rel: f64| {
            if first_rel > 0.0 {
                rel / first_rel
            } else {
                1.0
            }
        };
        let target = first_rel * o.threshold;
        let radius = radius_world / grid.unit;
        let cap = o.max_insert.unwrap_or_else(|| {
            let support_previous = self.support.unwrap_or(0);
            auto_insert_cap(
                o.rbfs,
                prev.len(),
                support_previous,
                smoke_support(grid),
                deleted,
            )
            .max(excess_insert_cap(
                params.len() / PARAMS_PER_RBF,
                rel_l2,
                target,
            ))
        });
        let ceiling = o.max_rbfs.unwrap_or(o.rbfs.saturating_mul(GROWTH_LIMIT));
        let room = ceiling.saturating_sub(params.len() / PARAMS_PER_RBF);
        let (cap, full) = if room < cap {
            (room, InsertionStop::Ceiling)
        } else {
            (cap, InsertionStop::Cap)
        };
        let floor = o.marginal_gain.max(0.0) * self.first_gain.unwrap_or(0.0);
        let (mut inserted, mut rounds, mut next_gain) = (0, 0, None);
        let insert_start = Instant::now();
        let mut stop = loop {
            if ratio(rel_l2) <= o.threshold {
                break InsertionStop::TargetMet;
            }
            if inserted >= cap {
                break full;
            }
            let t = Instant::now();
            let residual = grid.residual_grid(objective::residual(grid, &params));
            let n = params.len() / PARAMS_PER_RBF;
            let m = match o.insertion {
                Insertion::Batch => batch_size(n, rel_l2, target).min(cap - inserted),
                Insertion::Single => 1,
            };
            let (mut new, gains) = match o.insertion {
                Insertion::Batch => matched_with_gains(&residual, m, radius, bounds),
                // The largest-voxel rule has no prediction; the RBF is judged by the one
                // matching pursuit would place.
                Insertion::Single => (
                    greedy(&residual, 1, radius, bounds),
                    matched_with_gains(&residual, 1, radius, bounds).1,
                ),
            };
            split.pursuit_seconds += t.elapsed().as_secs_f64();
            next_gain = gains.first().map(|&g| world_gain(grid, g));
            let proposed = new.len();
            if floor > 0.0 {
                let short = gains
                    .iter()
                    .map(|&g| world_gain(grid, g))
                    .filter(|&g| g < floor);
                next_gain = short.reduce(f64::max).or(next_gain);
                new = new
                    .chunks(PARAMS_PER_RBF)
                    .zip(&gains)
                    .filter(|&(_, &g)| world_gain(grid, g) >= floor)
                    .flat_map(|(p, _)| p.iter().copied())
                    .collect();
                if new.is_empty() && !gains.is_empty() {
                    break InsertionStop::MarginalGain;
                }
            }
            if new.is_empty() {
                break InsertionStop::Nowhere;
            }
            // Some proposals did not pay: those that did are in, the rest would not.
            let trimmed = new.len() < proposed;
            inserted += new.len() / PARAMS_PER_RBF;
            rounds += 1;
            params.extend_from_slice(&new);
            let t = Instant::now();
            let m = match o.insertion {
                Insertion::Batch => {
                    let free = overlapping(&params, &new);
                    warm.free(&mut params, &free)
                }
                // The paper minimizes all RBFs after each insertion.
                Insertion::Single => warm.all(&mut params),
            };
            split.insert_seconds += t.elapsed().as_secs_f64();
            split.insert_passes += m.passes();
            m.add_to(&mut stats);
            let before = rel_l2;
            (rel_l2, rms) = errors_from_cost(grid, m.cost());
            if ratio(rel_l2) <= o.threshold {
                continue;
            }
            if trimmed {
                break InsertionStop::MarginalGain;
            }
            if inserted < cap && before - rel_l2 < MIN_ROUND_GAIN * (before - target) {
                // The error left is not where RBFs can be added (smoke that thinned
                // under old RBFs, detail finer than the radius): more would only cost.
                break InsertionStop::Stalled;
            }
        };
        // A frame left over the threshold (at its cap or ceiling, or where more RBFs stop
        // paying) moves the RBFs that lower the error least to where new ones would lower
        // it more: its count stays, its error drops.
        let mut exchanged = 0;
        if ratio(rel_l2) > o.threshold && stop != InsertionStop::Nowhere {
            let round = ExchangeRound {
                target,
                radius,
                bounds,
            };
            let minimizer = |params: &mut Vec<f64>, touched: &[f64]| {
                let t = Instant::now();
                let free = overlapping(params, touched);
                let m = warm.free(params, &free);
                split.exchange_seconds += t.elapsed().as_secs_f64();
                split.exchange_passes += m.passes();
                m.add_to(&mut stats);
                m.cost()
            };
            let (cost, moved, priced) = round.run(grid, &mut params, &mut alive, rel_l2, minimizer);
            (split.pursuit_seconds, split.removal_seconds) = (
                split.pursuit_seconds + priced.0,
                split.removal_seconds + priced.1,
            );
            if moved > 0 {
                exchanged = moved;
                (rel_l2, rms) = errors_from_cost(grid, cost);
                if ratio(rel_l2) <= o.threshold {
                    stop = InsertionStop::TargetMet;
                }
            }
        }
        let mut f = finish(grid, &params, o, stats, rel_l2, rms);
        f.warm_started = true;
        f.exchanged = exchanged;
        f.split = split;
        f.deleted = deleted;
        f.inserted = inserted;
        f.insert_rounds = rounds;
        f.insert_cap = cap;
        f.insertion_stop = Some(stop);
        f.next_gain = next_gain;
        f.gain_floor = floor;
        if rounds > 0 || exchanged > 0 {
            f.insert_seconds = insert_start.elapsed().as_secs_f64();
        }
        f.error_ratio = ratio(rel_l2);
        let over = f.error_ratio > o.threshold;
        f.insertion_capped = over && matches!(stop, InsertionStop::Cap | InsertionStop::Ceiling);
        f.insertion_stalled = over && !f.insertion_capped;
        let moved: Vec<f64> = alive
            .iter()
            .zip(&f.rbfs)
            .map(|(&k, now)| {
                let was = prev[k].center;
                (0..3)
                    .map(|a| (now.center[a] - was[a]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .collect();
        if !moved.is_empty() {
            f.mean_center_displacement = Some(moved.iter().sum::<f64>() / moved.len() as f64);
        }
        f
    }
}

/// The exchange rounds of a warm frame left over its target (see the module docs and
/// [`crate::exchange`]).
struct ExchangeRound<'a> {
    /// rel_l2 to reach.
    target: f64,
    /// Radius of the RBFs put in (unit cube).
    radius: f64,
    bounds: &'a Bounds,
}

impl ExchangeRound<'_> {
    /// Rounds on `params` (at `rel_l2`): each moves the cheapest RBFs to matching pursuit's
    /// best proposals ([`removal_costs`], [`paying_exchanges`], at most a quarter of the
    /// RBFs, [`EXCHANGE_SHARE`]), then calls `minimize(params, touched)` (`touched`: the
    /// removed and the added RBFs' parameters), which minimizes the parameters in place
    /// and returns the objective `ΣR²/ΣD²`. A round whose minimization does not lower
    /// rel_l2 is undone: the parameters and `alive` (the previous frame's index of each
    /// of the first `alive.len()` RBFs) are put back as they were. Rounds stop at the
    /// target, at a round undone, at one that removes less than [`MIN_ROUND_GAIN`] of the
    /// excess, or where no exchange pays. Returns the objective of the rounds kept (that
    /// of `rel_l2` if none), the RBFs they moved and the seconds spent pricing (matching
    /// pursuit with its residual grids, removal costs).
    fn run(
        &self,
        grid: &FitGrid,
        params: &mut Vec<f64>,
        alive: &mut Vec<usize>,
        mut rel_l2: f64,
        mut minimize: impl FnMut(&mut Vec<f64>, &[f64]) -> f64,
    ) -> (f64, usize, (f64, f64)) {
        let (mut cost, mut exchanged, mut priced) = (rel_l2 * rel_l2, 0, (0.0, 0.0));
        while rel_l2 > self.target {
            let t = Instant::now();
            let residual = objective::residual(grid, params);
            let n = params.len() / PARAMS_PER_RBF;
            let m = batch_size(n, rel_l2, self.target).min((n / EXCHANGE_SHARE).max(1));
            let (new, gains) = matched_with_gains(
                &grid.residual_grid(residual.clone()),
                m,
                self.radius,
                self.bounds,
            );
            priced.0 += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let costs = removal_costs(grid, &residual, params);
            priced.1 += t.elapsed().as_secs_f64();
            let (add, remove) = paying_exchanges(&gains, &costs);
            if add.is_empty() {
                break;
            }
            let kept = (params.clone(), alive.clone());
            // The RBFs that the removed and the added ones change the residual under.
            let mut touched: Vec<f64> = remove
                .iter()
                .flat_map(|&l| params[l * PARAMS_PER_RBF..(l + 1) * PARAMS_PER_RBF].to_vec())
                .collect();
            for &l in remove.iter().rev() {
                params.drain(l * PARAMS_PER_RBF..(l + 1) * PARAMS_PER_RBF);
                if l < alive.len() {
                    alive.remove(l);
                }
            }
            for &a in &add {
                let p = &new[a * PARAMS_PER_RBF..(a + 1) * PARAMS_PER_RBF];
                params.extend_from_slice(p);
                touched.extend_from_slice(p);
            }
            let before = rel_l2;
            let f = minimize(params, &touched);
            let rel = f.max(0.0).sqrt();
            if rel >= before {
                // The minimization undid the predicted gain: keep the old RBFs.
                (*params, *alive) = kept;
                break;
            }
            (rel_l2, cost) = (rel, f);
            exchanged += add.len();
            if rel_l2 > self.target && before - rel_l2 < MIN_ROUND_GAIN * (before - self.target) {
                break;
            }
        }
        (cost, exchanged, priced)
    }
}

fn empty_fit() -> FrameFit {
    FrameFit {
        rbfs: Vec::new(),
        rel_l2: 0.0,
        rms_over_max: 0.0,
        fit_seconds: 0.0,
        insert_seconds: 0.0,
        iterations: 0,
        coarse_iterations: 0,
        passes: 0,
        teleports: 0,
        warm_started: false,
        deleted: 0,
        inserted: 0,
        exchanged: 0,
        insert_rounds: 0,
        insert_cap: 0,
        error_ratio: 1.0,
        insertion_capped: false,
        insertion_stalled: false,
        insertion_stop: None,
        next_gain: None,
        gain_floor: 0.0,
        rbfs_at_bounds: 0,
        mean_center_displacement: None,
        split: TimeSplit::default(),
    }
}

fn finish(
    grid: &FitGrid,
    params: &[f64],
    o: &SequenceOptions,
    stats: FitStats,
    rel_l2: f64,
    rms: f64,
) -> FrameFit {
    FrameFit {
        rbfs: params
            .chunks(PARAMS_PER_RBF)
            .map(|p| grid.to_world([p[0], p[1], p[2]], p[3], p[4]))
            .collect(),
        rel_l2,
        rms_over_max: rms,
        iterations: stats.iterations,
        coarse_iterations: stats.coarse_iterations,
        passes: stats.passes,
        teleports: stats.teleports,
        rbfs_at_bounds: o.fit.bounds.count_at_bounds(grid, params),
        ..empty_fit()
    }
}

#[cfg(test)]
mod tests {
    use super::{
        ExchangeRound, auto_insert_cap, batch_size, errors, errors_from_cost, excess_insert_cap,
        smoke_support,
    };
    use crate::bounds::Bounds;
    use crate::grid::FitGrid;
    use crate::objective::{self, PARAMS_PER_RBF};
    use crate::optimize::{Optimizer, Stop, minimize};
    use haze_volume::{Bbox, Rbf, Volume, rbf};

    /// Gaussian blobs of radius 1.8 voxels at `centers` on a `n³` cube of unit voxels.
    fn blobs(n: usize, centers: &[[f64; 3]]) -> FitGrid {
        let b = Bbox::new([0.0; 3], [n as f64; 3]);
        let rbfs: Vec<Rbf> = centers
            .iter()
            .enumerate()
            .map(|(k, &c)| Rbf::new(c, 1.8, 0.4 + 0.15 * (k % 4) as f64))
            .collect();
        let data = rbf::evaluate_on_grid([n; 3], &b, &rbfs)
            .iter()
            .map(|&v| v as f32)
            .collect();
        FitGrid::from_volume(&Volume::new([n; 3], b, data).unwrap()).unwrap()
    }

    /// A pinned fitter fits its cold frame as an unpinned one does, but holds the next
    /// frames to the pinned figures: its state and its baseline are the pin's.
    #[test]
    fn a_pinned_baseline_outlives_the_cold_start() {
        use super::{Baseline, SequenceFitter, SequenceOptions};
        let b = Bbox::new([0.0; 3], [16.0; 3]);
        let rbfs = [
            Rbf::new([6.0, 7.0, 8.0], 2.0, 0.8),
            Rbf::new([10.0, 9.0, 8.0], 1.5, 0.5),
        ];
        let data = rbf::evaluate_on_grid([16; 3], &b, &rbfs)
            .iter()
            .map(|&v| v as f32)
            .collect();
        let v = Volume::new([16; 3], b, data).unwrap();
        let opts = SequenceOptions {
            rbfs: 4,
            ..SequenceOptions::default()
        };
        let mut free = SequenceFitter::new(opts.clone());
        let own = free.fit(&v).unwrap();
        let theirs = free.baseline().unwrap();
        assert_eq!(theirs.rel_l2, own.rel_l2);
        assert_eq!(theirs.rbfs, own.rbfs.len());
        assert_eq!(
            theirs.support,
            super::smoke_support(&FitGrid::from_volume(&v).unwrap())
        );
        let pin = Baseline {
            rel_l2: 0.5 * theirs.rel_l2,
            radius: 2.0 * theirs.radius,
            gain: 3.0 * theirs.gain + 1.0,
            ..theirs
        };
        let mut pinned = SequenceFitter::new(opts.clone());
        pinned.pin(pin);
        let cold = pinned.fit(&v).unwrap();
        // The cold frame itself is fitted as before (the same RBFs per voxel of smoke)...
        assert_eq!(cold.rbfs, own.rbfs);
        // ...and the pin, not its figures, is what the next frames are held to.
        assert_eq!(pinned.baseline(), Some(pin));
        assert_eq!(pinned.state().first, Some((pin.rel_l2, pin.radius)));
        assert_eq!(cold.gain_floor, pin.gain);
        // A baseline of twice the RBFs per voxel of smoke starts with twice the RBFs.
        let mut denser = SequenceFitter::new(opts);
        denser.pin(Baseline {
            rbfs: 2 * theirs.rbfs,
            ..pin
        });
        assert_eq!(denser.fit(&v).unwrap().rbfs.len(), 2 * own.rbfs.len());
        // Before any frame there is no baseline.
        assert_eq!(
            SequenceFitter::new(SequenceOptions::default()).baseline(),
            None
        );
    }

    /// A warm frame of wide RBFs on a grid of 64³ voxels or more takes its long walk on
    /// the half-resolution grid (`warm_coarse` `Auto`) and ends no worse than the walk at
    /// full resolution (within 1 % of its error; here 10 % better), the frame within its
    /// threshold; `Never` keeps every iteration at full resolution.
    #[test]
    fn a_warm_frame_of_wide_rbfs_walks_on_the_coarse_grid() {
        use super::{Coarse, SequenceFitter, SequenceOptions};
        let dims = [72, 64, 64];
        let b = Bbox::new([0.0; 3], [72.0, 64.0, 64.0]);
        let frame = |shift: f64| {
            let rbfs = [
                Rbf::new([24.0 + shift, 30.0, 28.0], 6.0, 0.9),
                Rbf::new([46.0, 34.0 - shift, 36.0], 5.0, 0.6),
                Rbf::new([36.0, 22.0, 40.0 + shift], 7.0, 0.5),
            ];
            let data = rbf::evaluate_on_grid(dims, &b, &rbfs)
                .iter()
                .map(|&v| v as f32)
                .collect();
            Volume::new(dims, b, data).unwrap()
        };
        let (first, next) = (frame(0.0), frame(1.5));
        let fit = |warm_coarse| {
            let mut fitter = SequenceFitter::new(SequenceOptions {
                rbfs: 3,
                warm_coarse,
                ..SequenceOptions::default()
            });
            fitter.fit(&first).unwrap();
            fitter.fit(&next).unwrap()
        };
        let coarse = fit(Coarse::Auto);
        let fine = fit(Coarse::Never);
        assert!(
            coarse.warm_started && coarse.coarse_iterations > 0,
            "{coarse:?}"
        );
        assert_eq!(fine.coarse_iterations, 0);
        assert!(coarse.error_ratio <= 1.1 && fine.error_ratio <= 1.1);
        assert!(
            coarse.rel_l2 <= 1.01 * fine.rel_l2,
            "{} {}",
            coarse.rel_l2,
            fine.rel_l2
        );
    }

    /// The undo path of an exchange round: two of four blobs fitted, two RBFs on empty
    /// space, two blobs bare. A round moves the empty ones onto the bare blobs; where the
    /// minimization after it does not lower the error (here it shrinks every weight a
    /// hundredfold), the frame's RBFs and their bookkeeping are exactly the ones before
    /// the round; with a real minimization the move is kept and the moved RBFs leave
    /// the bookkeeping.
    #[test]
    fn an_exchange_round_that_does_not_pay_is_undone() {
        let centers = [
            [6.0, 6.0, 10.0],
            [16.0, 6.0, 10.0],
            [6.0, 16.0, 10.0],
            [16.0, 16.0, 10.0],
        ];
        let g = blobs(22, &centers);
        let bounds = Bounds::default();
        let r = 1.8 / 22.0;
        let at = |c: [f64; 3], w: f64| [c[0] / 22.0, c[1] / 22.0, c[2] / 22.0, r, w];
        let start: Vec<f64> = [
            at(centers[0], 0.4),
            at([11.0, 11.0, 3.0], 0.01),
            at(centers[1], 0.55),
            at([11.0, 11.0, 18.0], 0.01),
        ]
        .concat();
        let (rel, _) = errors(&g, &start);
        let round = ExchangeRound {
            target: 0.5 * rel,
            radius: r,
            bounds: &bounds,
        };
        let (mut params, mut alive) = (start.clone(), vec![7, 8, 9, 10]);
        let mut costs = Vec::new();
        let mut touched_rbfs = 0;
        let worse = |p: &mut Vec<f64>, touched: &[f64]| {
            touched_rbfs = touched.len() / PARAMS_PER_RBF;
            for q in p.chunks_mut(PARAMS_PER_RBF) {
                q[4] *= 0.01;
            }
            let f = objective::cost(&g, p);
            costs.push(f);
            f
        };
        let (cost, moved, _) = round.run(&g, &mut params, &mut alive, rel, worse);
        assert_eq!(costs.len(), 1, "one round, then undone");
        assert!(costs[0].sqrt() >= rel, "{} vs {rel}", costs[0].sqrt());
        assert_eq!(moved, 0);
        assert!((cost - rel * rel).abs() <= 1e-15, "{cost} vs {}", rel * rel);
        assert_eq!(params, start);
        assert_eq!(alive, vec![7, 8, 9, 10]);
        // Each move touches the RBF removed and the one added.
        assert!(touched_rbfs >= 2 && touched_rbfs % 2 == 0, "{touched_rbfs}");
        // The same round with the minimization kept: the empty RBFs (previous frame's 8
        // and 10) moved onto the bare blobs and are no longer followed.
        let real = |p: &mut Vec<f64>, _: &[f64]| {
            let stop = Stop {
                max_iterations: 100,
                ..Stop::default()
            };
            minimize(&g, p, &bounds, Optimizer::default(), stop).cost
        };
        let (cost, moved, _) = round.run(&g, &mut params, &mut alive, rel, real);
        let after = cost.sqrt();
        assert!(
            moved >= 2 && after < 0.5 * rel,
            "{moved} moved, {after} vs {rel}"
        );
        assert!((errors(&g, &params).0 - after).abs() < 1e-9);
        assert_eq!(params.len(), start.len());
        assert_eq!(alive, vec![7, 9]);
    }

    /// The measures from a cost equal those from a pass over the residual.
    #[test]
    fn errors_from_cost_match_a_residual_pass() {
        let b = Bbox::new([0.0; 3], [10.0, 8.0, 6.0]);
        let mut v = Volume::zeros([10, 8, 6], b).unwrap();
        for i in 0..v.len() {
            v.data_mut()[i] = ((i * 13) % 7) as f32;
        }
        let g = FitGrid::from_volume(&v).unwrap();
        let p = [0.4, 0.3, 0.2, 0.08, 0.6, 0.7, 0.5, 0.4, 0.05, 0.3];
        let (rel, rms) = errors(&g, &p);
        let (rel2, rms2) = errors_from_cost(&g, objective::cost(&g, &p));
        assert!((rel - rel2).abs() < 1e-12 && (rms - rms2).abs() < 1e-12);
        let empty = FitGrid::from_volume(&Volume::zeros([2, 2, 2], b).unwrap()).unwrap();
        assert_eq!(errors_from_cost(&empty, 0.5), (0.0, 0.0));
    }

    /// The automatic cap keeps the RBFs per voxel of smoke: support ×2 from 300 RBFs
    /// allows 300 more (+ the deleted); smoke that shrinks, keeps its size or had none
    /// gets the floor, an eighth of the first frame's count or 16.
    #[test]
    fn insertion_cap_follows_the_smoke() {
        assert_eq!(auto_insert_cap(300, 300, 1000, 2000, 3), 303);
        assert_eq!(auto_insert_cap(300, 600, 1000, 1100, 3), 63);
        assert_eq!(auto_insert_cap(300, 300, 1000, 1010, 3), 37);
        assert_eq!(auto_insert_cap(300, 300, 1000, 900, 3), 37);
        assert_eq!(auto_insert_cap(300, 300, 1000, 1000, 3), 37);
        assert_eq!(auto_insert_cap(300, 300, 0, 1000, 3), 37);
        assert_eq!(auto_insert_cap(40, 40, 100, 100, 0), 16);
    }

    /// The cap from the excess error is the first round's size: 0 within the target,
    /// `n·((e/t)³ − 1)` above it (300 RBFs at 1.2× the target: 219 more), so a frame
    /// whose detail outgrew its support is not held to the support's cap.
    #[test]
    fn insertion_cap_grows_with_the_excess_error() {
        assert_eq!(excess_insert_cap(300, 0.1, 0.11), 0);
        assert_eq!(excess_insert_cap(300, 0.11, 0.11), 0);
        assert_eq!(excess_insert_cap(300, 0.132, 0.11), 219);
        assert_eq!(excess_insert_cap(300, 0.2, 0.1), 2100);
        let support = auto_insert_cap(300, 300, 1000, 1000, 3);
        assert!(excess_insert_cap(300, 0.132, 0.11) > support);
    }

    /// The support counts voxels above 1 % of the peak, by brute force over the grid.
    #[test]
    fn support_counts_voxels_above_a_hundredth_of_the_peak() {
        let b = Bbox::new([0.0; 3], [4.0, 4.0, 4.0]);
        let mut v = Volume::zeros([4, 4, 4], b).unwrap();
        for (i, d) in v.data_mut().iter_mut().enumerate() {
            *d = 2.0 * (i as f32 / 63.0).powi(4);
        }
        let g = FitGrid::from_volume(&v).unwrap();
        let brute = v.data().iter().filter(|&&d| d / 2.0 > 0.01).count();
        assert_eq!(smoke_support(&g), brute);
        assert!(brute > 10 && brute < 64);
        let empty = FitGrid::from_volume(&Volume::zeros([2, 2, 2], b).unwrap()).unwrap();
        assert_eq!(smoke_support(&empty), 0);
    }

    /// The round size inverts `rel_l2 ∝ n^(−1/3)`: `n` RBFs at rel_l2 `e` reach `e/k`
    /// with `n·k³` RBFs.
    #[test]
    fn batch_size_follows_the_rbf_count_curve() {
        assert_eq!(batch_size(100, 0.2, 0.1), 700);
        assert_eq!(batch_size(300, 0.11, 0.1), 100);
        assert_eq!(batch_size(300, 0.1, 0.1), 1);
        assert_eq!(batch_size(300, 0.05, 0.1), 1);
        assert_eq!(batch_size(0, 0.2, 0.1), 1);
        assert_eq!(batch_size(10, 0.2, 0.0), 1);
    }
}
