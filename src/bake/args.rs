//! `haze bake`'s flags, converted into `haze_bake`'s options.

use crate::import_args::ImportArgs;
use anyhow::Result;
use haze_bake::BakeOptions;
use haze_core::number::shown;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct BakeCli {
    /// File, directory or glob of numbered frames (a frame's number is the last run of
    /// digits that differs between the names), or a packed asset (`haze pack`).
    pub(crate) input: PathBuf,
    /// The asset to write (its name must end in .haze: the other commands know an asset by it).
    #[arg(long, short)]
    pub(crate) out: PathBuf,
    /// Frame range to bake, inclusive: A..B, A.., ..B or A. A chunk starts with a full
    /// first-frame fit (see --warm-up); `haze merge` joins chunks baked separately (on a
    /// render farm, say).
    #[arg(long, value_name = "A..B", allow_hyphen_values = true)]
    pub(crate) frames: Option<haze_volume::import::FrameRange>,
    /// With --frames A..B: first fit the K frames before A and drop them, so that frame A
    /// is fitted warm as in a bake of the whole sequence (chunks then join without a cold
    /// start at their boundary). Frames the input does not have are skipped.
    #[arg(long, value_name = "K", default_value_t = 0, requires = "frames")]
    pub(crate) warm_up: usize,
    /// Continue an interrupted bake of --out from its journal (OUT.partial, written as
    /// frames finish), with the same input and settings. Without it, a bake starts over.
    #[arg(long)]
    pub(crate) resume: bool,
    /// RBFs of the first frame (later frames vary by deletions and insertions).
    #[arg(long, value_name = "N", conflicts_with = "target_error")]
    pub(crate) rbfs: Option<usize>,
    /// Instead of --rbfs: the smallest RBF count whose first-frame fit reaches this
    /// rel_l2 (searched by doubling then bisection; each probe is a full fit).
    #[arg(long, value_name = "E")]
    pub(crate) target_error: Option<f64>,
    /// Most RBFs a frame may have: where later frames stop inserting and move RBFs
    /// instead [default: 8 × the first frame's count], and the --target-error search's
    /// ceiling [default: 4096].
    #[arg(long, value_name = "N")]
    pub(crate) max_rbfs: Option<usize>,
    /// Local minimizer.
    #[arg(long, value_enum, default_value_t = OptimizerArg::Lbfgsb)]
    pub(crate) optimizer: OptimizerArg,
    /// Smallest RBF radius, as a fraction of the grid's longest side; never below the
    /// grid's Nyquist radius 2h/π (h the voxel side), which 0 leaves as the floor.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) radius_min: f64,
    /// Largest RBF radius, as a fraction of the grid's longest side.
    #[arg(long, default_value_t = 0.09)]
    pub(crate) radius_max: f64,
    /// Fit first frames without teleportation (faster, usually a higher error).
    #[arg(long)]
    pub(crate) no_teleport: bool,
    /// Iteration budget of a first-frame fit.
    #[arg(long, default_value_t = 1000)]
    pub(crate) max_iterations: u64,
    /// Stop a minimization when an iteration lowers the error by less than this fraction
    /// (larger: faster, slightly less accurate; see BENCHMARKS.md).
    #[arg(long, default_value_t = 1e-6)]
    pub(crate) tolerance: f64,
    /// Iteration budget of each minimization of a warm-started frame (of its coarse stage
    /// where --warm-coarse applies; more: a few fewer RBFs on fast-moving smoke, slower;
    /// see BENCHMARKS.md).
    #[arg(long, default_value_t = haze_fit::sequence::WARM_ITERATIONS)]
    pub(crate) warm_iterations: u64,
    /// Stop a warm-started minimization when its last 10 iterations together lowered the
    /// error by less than this fraction (0: only --tolerance stops it; see BENCHMARKS.md).
    #[arg(long, default_value_t = haze_fit::sequence::WARM_WINDOW_GAIN, value_name = "F")]
    pub(crate) warm_tolerance: f64,
    /// Fit first frames on the half-resolution grid, then polish at full resolution:
    /// `auto` on grids of 64³ voxels or more.
    #[arg(long, value_enum, default_value_t = CoarseArg::Auto)]
    pub(crate) coarse_to_fine: CoarseArg,
    /// Minimize warm-started frames on the half-resolution grid first (up to
    /// --warm-iterations), then polish at full resolution (--warm-polish-iterations):
    /// `auto` on grids of 64³ voxels or more whose RBFs are mostly two voxels wide or wider
    /// (fast turbulent smoke: about half the time a frame; see BENCHMARKS.md).
    #[arg(long, value_enum, default_value_t = CoarseArg::Auto)]
    pub(crate) warm_coarse: CoarseArg,
    /// Iteration budget of the full-resolution polish after a warm frame's coarse
    /// minimization (at least 1).
    #[arg(long, default_value_t = haze_fit::sequence::WARM_POLISH_ITERATIONS, value_name = "N")]
    pub(crate) warm_polish_iterations: u64,
    /// RBFs deleted at the start of each later frame.
    #[arg(long, default_value_t = 3)]
    pub(crate) delete: usize,
    /// Most RBFs inserted in a later frame [default: as many as keep the previous frame's
    /// RBFs per voxel of smoke as the smoke grows or as its excess error asks for, at
    /// least an eighth of --rbfs and 16]. A frame that hits it moves its weakest RBFs to
    /// where they lower the error more; if still over --threshold, it is reported.
    #[arg(long, value_name = "M")]
    pub(crate) max_insert: Option<usize>,
    /// How later frames get RBFs where the smoke grew: `batch` sizes each round by the
    /// excess error; `single` inserts one at a time (paper A).
    #[arg(long, value_enum, default_value_t = InsertionArg::Batch)]
    pub(crate) insertion: InsertionArg,
    /// Insert RBFs while a frame's rel_l2 exceeds the first frame's by this ratio.
    #[arg(long, default_value_t = 1.1)]
    pub(crate) threshold: f64,
    /// Insert an RBF only where it is predicted to lower the squared error by at least
    /// this fraction of what the first frame's next RBFs would (its marginal gain); a
    /// frame whose proposals all fall short stops inserting and is reported (0: off).
    #[arg(long, default_value_t = haze_fit::sequence::MARGINAL_GAIN, value_name = "F")]
    pub(crate) marginal_gain: f64,
    /// Seed of the random teleports (same seed, same input: same asset).
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Largest error of the stored volume, as a fraction of each frame's peak density: the
    /// residual D − D̃ is quantized with a step of twice that, and nothing is stored where
    /// the RBFs alone are within it. 0 = lossless (the residual's f32 values); the default
    /// 1/255 is what 8-bit density storage promises. With --target-error and without this
    /// flag it is chosen: the largest of 0.5/255 … 16/255 that keeps the stored density
    /// within a quarter of the target (rel_l2, guaranteed by the quantizer's bound on the
    /// first frame), printed and stored in the asset header with why.
    #[arg(long, value_name = "E", value_parser = parse_error_fraction)]
    pub(crate) residual_error: Option<f64>,
    /// Widest stored residual value in bits (4..16); each brick takes the narrowest of 2, 4,
    /// 8, 16 bits that holds its values. If the largest residual needs more at
    /// --residual-error, the step widens (with a warning).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u8).range(4..=16))]
    pub(crate) quant_bits: u8,
    /// Side of the voxel bricks the residual is hashed by (1, 2, 4 or 8).
    #[arg(long, default_value_t = haze_hash::tile::DEFAULT_BRICK, value_parser = parse_brick)]
    pub(crate) residual_brick: u32,
    /// Largest decoded size of a residual hash volume, in MiB. A volume holds up to 27
    /// frames and closes early, with fewer, before another frame would take it past this:
    /// the bake holds one volume, and a single frame's render or export (or Python's
    /// reader) up to one, so this bounds the memory they need for the residual whatever
    /// the frames' size (turbulent smoke at 256³ takes about 10 MiB a frame); playback
    /// decodes frame after frame and holds frames, not volumes. Larger volumes code a
    /// little smaller: the coder adapts over more frames.
    #[arg(long, value_name = "MIB", default_value_t = (haze_hash::tile::VOLUME_BYTES >> 20) as f64, value_parser = parse_volume_mib)]
    pub(crate) volume_mib: f64,
    /// Also write a JSON report of every frame's fit.
    #[arg(long, value_name = "REPORT.json")]
    pub(crate) report: Option<PathBuf>,
    /// Choose the render knobs `haze view` starts with: the most accurate setting of the
    /// --tradeoff sweep's front that rendered within T ms; stored with why in the header.
    #[arg(long, value_name = "T", requires = "tradeoff")]
    pub(crate) view_budget_ms: Option<f64>,
    /// The sweep (`haze tradeoff`'s tradeoff.json) for --view-budget-ms.
    #[arg(long, value_name = "FILE", requires = "view_budget_ms")]
    pub(crate) tradeoff: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) import: ImportArgs,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub(crate) enum CoarseArg {
    Auto,
    On,
    Off,
}

impl CoarseArg {
    fn coarse(self) -> haze_fit::Coarse {
        match self {
            CoarseArg::Auto => haze_fit::Coarse::Auto,
            CoarseArg::On => haze_fit::Coarse::Always,
            CoarseArg::Off => haze_fit::Coarse::Never,
        }
    }
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub(crate) enum InsertionArg {
    /// Rounds sized by the excess error, placed where they lower the error most.
    Batch,
    /// One RBF and a joint minimization per round (paper A).
    Single,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub(crate) enum OptimizerArg {
    /// L-BFGS-B with exact bounds (paper A).
    Lbfgsb,
    /// L-BFGS on a smooth (logistic) reparameterization of the bounds.
    LbfgsReparam,
}

impl BakeCli {
    pub(crate) fn into_args(self) -> Result<BakeArgs> {
        use anyhow::bail;
        use haze_fit::{Bounds, FitOptions, Insertion, Optimizer, SequenceOptions, Stop};
        let bounds = Bounds {
            radius: (self.radius_min, self.radius_max),
            ..Bounds::default()
        };
        bounds.validate().map_err(anyhow::Error::msg)?;
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            bail!("--tolerance {} must be in (0, 1)", shown(self.tolerance));
        }
        if !(self.warm_tolerance >= 0.0 && self.warm_tolerance < 1.0) {
            bail!(
                "--warm-tolerance {} must be in [0, 1)",
                shown(self.warm_tolerance)
            );
        }
        if self.max_insert == Some(0) {
            bail!("--max-insert must be at least 1 (--threshold 1e9 turns insertion off)");
        }
        if self.threshold.is_nan() || self.threshold < 1.0 {
            bail!("--threshold {} must be at least 1", shown(self.threshold));
        }
        if !(self.marginal_gain.is_finite() && self.marginal_gain >= 0.0) {
            bail!(
                "--marginal-gain {} must be a finite number ≥ 0 (0 turns the test off)",
                shown(self.marginal_gain)
            );
        }
        let max = haze_bake::MAX_RBFS;
        for (flag, n) in [("--rbfs", self.rbfs), ("--max-rbfs", self.max_rbfs)] {
            if let Some(n) = n
                && !(1..=max).contains(&n)
            {
                bail!("{flag} {n} must be between 1 and {max}");
            }
        }
        if let (Some(n), Some(m)) = (self.rbfs, self.max_rbfs)
            && m < n
        {
            bail!("--max-rbfs {m} is below --rbfs {n}: a frame may hold at most --max-rbfs RBFs");
        }
        let count = match (self.rbfs, self.target_error) {
            (Some(n), _) => haze_bake::Count::Fixed(n),
            (None, Some(e)) if e > 0.0 && e <= 1.0 => haze_bake::Count::Target {
                rel_l2: e,
                cap: self.max_rbfs.unwrap_or(4096).max(1),
            },
            (None, Some(e)) => bail!("--target-error {} must be in (0, 1]", shown(e)),
            (None, None) => haze_bake::Count::Fixed(300),
        };
        let fit = FitOptions {
            bounds,
            optimizer: match self.optimizer {
                OptimizerArg::Lbfgsb => Optimizer::Lbfgsb,
                OptimizerArg::LbfgsReparam => Optimizer::LbfgsReparam,
            },
            teleport: !self.no_teleport,
            max_iterations: self.max_iterations,
            stop: Stop {
                relative_reduction: self.tolerance,
                ..Stop::default()
            },
            seed: self.seed,
            coarse: self.coarse_to_fine.coarse(),
            ..FitOptions::default()
        };
        let defaults = SequenceOptions::default();
        let mut choices = serde_json::Map::new();
        let residual_error = match (self.residual_error, &count) {
            (Some(e), _) => e,
            (None, haze_bake::Count::Target { rel_l2, .. }) => {
                let import = self.import.options();
                let range = self.frames.unwrap_or_default();
                let seq = haze_bake::source::Frames::open(&self.input, &import, range)?;
                let first = seq.load(0)?;
                match haze_bake::choice::residual_error_for(&first, *rel_l2) {
                    Some(c) => {
                        haze_render::say!("residual error chosen: {}", c.why);
                        choices.insert("residual_error".into(), serde_json::to_value(&c)?);
                        c.residual_error
                    }
                    None => haze_hash::DEFAULT_ERROR,
                }
            }
            (None, _) => haze_hash::DEFAULT_ERROR,
        };
        if let (Some(t), Some(file)) = (self.view_budget_ms, &self.tradeoff) {
            let c = haze_tradeoff::choice::for_view(file, t)?;
            haze_render::say!("view settings chosen: {}", c.reason);
            choices.insert("view".into(), c.to_json());
        }
        Ok(BakeArgs {
            report: self.report,
            options: haze_bake::BakeOptions {
                input: self.input,
                out: self.out,
                range: self.frames.unwrap_or_default(),
                import: self.import.options(),
                count,
                fit: SequenceOptions {
                    fit,
                    delete: self.delete,
                    max_insert: self.max_insert,
                    max_rbfs: self.max_rbfs.map(|n| n.max(1)),
                    threshold: self.threshold,
                    marginal_gain: self.marginal_gain,
                    insertion: match self.insertion {
                        InsertionArg::Batch => Insertion::Batch,
                        InsertionArg::Single => Insertion::Single,
                    },
                    warm: Stop {
                        max_iterations: self.warm_iterations,
                        // The windowed test replaces the per-iteration one, as in the
                        // library's defaults; without it, --tolerance stops a warm frame.
                        relative_reduction: if self.warm_tolerance > 0.0 {
                            defaults.warm.relative_reduction
                        } else {
                            self.tolerance
                        },
                        window: if self.warm_tolerance > 0.0 {
                            defaults.warm.window
                        } else {
                            0
                        },
                        window_gain: self.warm_tolerance,
                    },
                    warm_coarse: self.warm_coarse.coarse(),
                    warm_polish: self.warm_polish_iterations.max(1),
                    ..defaults
                },
                quant: haze_hash::QuantOptions {
                    error: residual_error,
                    bits: self.quant_bits,
                },
                brick: self.residual_brick,
                volume_bytes: (self.volume_mib * 1_048_576.0).round() as usize,
                resume: self.resume,
                warm_up: self.warm_up,
                baseline: None,
                choices,
            },
        })
    }
}

/// `--residual-error`: a finite fraction ≥ 0.
fn parse_error_fraction(s: &str) -> Result<f64, String> {
    let e: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if e.is_finite() && e >= 0.0 {
        Ok(e)
    } else {
        Err(format!("{s} is not a fraction ≥ 0 of the peak density"))
    }
}

/// `--residual-brick`: one of the supported sides.
fn parse_brick(s: &str) -> Result<u32, String> {
    s.parse()
        .ok()
        .filter(|b| haze_hash::tile::BRICK_SIDES.contains(b))
        .ok_or_else(|| format!("'{s}' is not one of {:?}", haze_hash::tile::BRICK_SIDES))
}

/// A volume size in MiB, from a thousandth to 2048 (a block indexes at most 2²⁹ packed
/// words, 2 GiB).
fn parse_volume_mib(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|v| (0.001..=2048.0).contains(v))
        .ok_or_else(|| format!("'{s}' is not a size in MiB from 0.001 to 2048"))
}

/// Everything `haze bake` was asked to do.
#[derive(Debug)]
pub(crate) struct BakeArgs {
    pub(crate) options: BakeOptions,
    /// Where to write the JSON report, if anywhere.
    pub(crate) report: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Flags {
        #[command(flatten)]
        bake: BakeCli,
    }

    /// `haze bake` without flags bakes as `BakeOptions::new` does (the Python package's
    /// `haze.bake` defaults), knob for knob.
    #[test]
    fn the_command_lines_defaults_are_the_librarys() {
        let cli = Flags::try_parse_from(["bake", "cache/", "--out", "smoke.haze"])
            .unwrap()
            .bake;
        let from_cli = cli.into_args().unwrap().options;
        let library = BakeOptions::new("cache/", "smoke.haze");
        assert_eq!(format!("{from_cli:?}"), format!("{library:?}"));
    }
}
