//! The bake: a sequence of density volumes → RBF fits (paper A §5.1) and the quantized,
//! hashed residual (§5.2) in a `.haze` asset, journaled frame by frame so that an
//! interrupted bake resumes.
//!
//! [`Bake::new`] opens the input (and the journal when resuming, or runs the RBF-count
//! search); the bake is then an iterator of finished frames; [`Bake::finish`] writes the
//! asset and returns the figures of the report.

use crate::journal::{self, Journal, Record, Tag};
use crate::residual::{HashVolume, ResidualRecord, ResidualStage};
use crate::source::Frames;
use anyhow::{Context, Result, bail};
use haze_asset::{AssetWriter, BlockKind, Scope, decode_rbfs, encode_rbfs};
use haze_fit::{
    FitGrid, FitterState, FrameFit, Search, SequenceFitter, SequenceOptions, rbfs_for_target,
};
use haze_volume::ImportOptions;
use haze_volume::import::FrameRange;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How many RBFs a first frame gets.
#[derive(Clone, Copy, Debug, Serialize)]
pub enum Count {
    Fixed(usize),
    /// Smallest count reaching this rel_l2, at most the cap.
    Target {
        rel_l2: f64,
        cap: usize,
    },
}

/// Everything a bake is asked to do.
#[derive(Clone, Debug)]
pub struct BakeOptions {
    /// A volume file, a directory or a glob of numbered frames.
    pub input: PathBuf,
    /// The asset to write (its journal is `OUT.partial`).
    pub out: PathBuf,
    pub range: FrameRange,
    pub import: ImportOptions,
    pub count: Count,
    pub fit: SequenceOptions,
    /// The residual's error (fraction of each frame's peak) and widest stored value.
    pub quant: haze_hash::QuantOptions,
    /// Brick side of the residual hash.
    pub brick: u32,
    /// A hash volume closes (with fewer than 27 frames) before its decoded tables would
    /// pass this many bytes: what playback and the bake hold of the residual at once.
    pub volume_bytes: usize,
    /// Continue the interrupted bake of `out` from its journal.
    pub resume: bool,
    /// Frames fitted before the range's first and dropped, so that its first frame is
    /// fitted warm, as in a bake of the whole sequence (a chunk of a bake spread over
    /// machines: no cold start, no flicker at the chunk's boundary). Only the frames the
    /// input has before the range are used; none on a resume (the journal holds the
    /// fitter's state).
    pub warm_up: usize,
    /// The whole sequence's first-frame figures, which a chunk baked apart holds its
    /// frames to ([`haze_fit::Baseline`], from [`baseline`]); none: the range's own first
    /// frame's. Not used on a resume (the journal holds them).
    pub baseline: Option<haze_fit::Baseline>,
    /// Automatic choices made for this bake and why (`choice`), stored in the header's
    /// `extra.choices` for every reader (`haze inspect`, `haze view`).
    pub choices: serde_json::Map<String, serde_json::Value>,
}

impl BakeOptions {
    /// The bake of `input` into `out` with every default of `haze bake INPUT --out OUT`:
    /// 300 RBFs a first frame, the fitter's defaults, the residual to
    /// [`haze_hash::DEFAULT_ERROR`] of each frame's peak in bricks of
    /// [`haze_hash::tile::DEFAULT_BRICK`] and volumes of at most
    /// [`haze_hash::tile::VOLUME_BYTES`], every frame, no resume.
    pub fn new(input: impl Into<PathBuf>, out: impl Into<PathBuf>) -> BakeOptions {
        BakeOptions {
            input: input.into(),
            out: out.into(),
            range: FrameRange::default(),
            import: ImportOptions::default(),
            count: Count::Fixed(300),
            fit: SequenceOptions::default(),
            quant: haze_hash::QuantOptions::default(),
            brick: haze_hash::tile::DEFAULT_BRICK,
            volume_bytes: haze_hash::tile::VOLUME_BYTES,
            resume: false,
            warm_up: 0,
            baseline: None,
            choices: serde_json::Map::new(),
        }
    }
}

/// The first-frame figures a bake of `options` holds its frames to: its range's first
/// frame fitted cold with `options.count`'s fixed count (one frame's fit). What chunks of
/// the sequence baked apart are given ([`BakeOptions::baseline`]).
pub fn baseline(options: &BakeOptions) -> Result<haze_fit::Baseline> {
    let seq = Frames::open(&options.input, &options.import, options.range)?;
    let rbfs = match options.count {
        Count::Fixed(n) => n,
        Count::Target { .. } => bail!(
            "{}: a baseline needs a fixed RBF count, not a target error",
            options.input.display()
        ),
    };
    let mut fitter = SequenceFitter::new(SequenceOptions {
        rbfs,
        ..options.fit.clone()
    });
    let v = seq.load(0)?;
    fitter
        .fit(&v)
        .map_err(|e| anyhow::anyhow!("{}: {e}", seq.label(0)))?;
    fitter.baseline().ok_or_else(|| {
        anyhow::anyhow!(
            "{}: the first frame is empty: no baseline to hold the others to",
            seq.label(0)
        )
    })
}

/// Fits the [`BakeOptions::warm_up`] frames of the input just before its range with
/// `fitter`, dropping them: the range's first frame is then fitted warm.
fn warm_up(
    args: &BakeOptions,
    fitter: &mut SequenceFitter,
    events: &mut impl FnMut(Event<'_>),
) -> Result<()> {
    let Some(first) = args.range.first else {
        return Ok(());
    };
    if args.warm_up == 0 {
        return Ok(());
    }
    // The frames before the range, the last `warm_up` of them that exist.
    let before = FrameRange {
        first: None,
        last: Some(first.saturating_sub(1)),
    };
    let all = match Frames::open(&args.input, &args.import, before) {
        Ok(f) => f,
        // No frame before the range (its first is the input's first): nothing to warm.
        Err(_) => return Ok(()),
    };
    let skip = all.len().saturating_sub(args.warm_up);
    for i in skip..all.len() {
        events(Event::WarmingUp {
            frame: all.number(i),
        });
        let v = all.load(i)?;
        fitter
            .fit(&v)
            .map_err(|e| anyhow::anyhow!("{}: {e}", all.label(i)))?;
    }
    Ok(())
}

/// One frame's line in the report and in the asset header.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameRecord {
    /// The frame's number in the input.
    pub frame: i64,
    pub rbfs: usize,
    #[serde(flatten)]
    pub fit: FrameFit,
    /// The residual's figures; its hash volume's share (bytes, seconds, bricks) is filled
    /// in when the volume is built, so only the records of [`Baked`] have all of them.
    #[serde(flatten)]
    pub residual: ResidualRecord,
}

/// What happens during a bake, for progress displays.
#[derive(Debug)]
pub enum Event<'a> {
    /// Resuming an interrupted bake after `finished` of `total` frames.
    Resumed { finished: usize, total: usize },
    /// The RBF-count search of `--target-error` starts on frame `frame` (a long step).
    Searching { frame: i64, target: f64 },
    /// The search is over.
    Searched(&'a Search),
    /// Frame `frame` (asset index `index`) is being fitted.
    Fitting { index: usize, frame: i64 },
    /// Frame `frame`, before the range, is being fitted to warm the fitter
    /// ([`BakeOptions::warm_up`]) and will be dropped.
    WarmingUp { frame: i64 },
    /// A hash volume is being built.
    Hashing,
}

/// A finished bake: the asset written and the figures of its report.
#[derive(Debug)]
pub struct Baked {
    pub out: PathBuf,
    /// The asset's size.
    pub bytes: u64,
    pub seconds: f64,
    pub records: Vec<FrameRecord>,
    /// The settings stored in the asset's header.
    pub settings: serde_json::Value,
    /// Flicker measures over the sequence.
    pub temporal: serde_json::Value,
}

impl Baked {
    /// The JSON report (`haze bake --report`): `input`, `output`, `settings`, `frames`,
    /// `temporal`, `totals`.
    pub fn report(&self, input: &Path) -> serde_json::Value {
        json!({
            "input": input.display().to_string(),
            "output": self.out.display().to_string(),
            "settings": self.settings,
            "frames": self.records,
            "temporal": self.temporal,
            "totals": {"seconds": self.seconds, "bytes": self.bytes, "frames": self.records.len()},
        })
    }
}

/// A bake in progress: an iterator of finished frames.
pub struct Bake {
    options: BakeOptions,
    seq: Frames,
    journal: Journal,
    done: Done,
    /// The sequence options with the chosen RBF count.
    opts: SequenceOptions,
    fitter: SequenceFitter,
    residuals: ResidualStage,
    /// Asset index of the next frame to fit.
    next: usize,
    failed: bool,
    start: Instant,
    events: Box<dyn FnMut(Event<'_>) + Send>,
}

impl std::fmt::Debug for Bake {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bake")
            .field("options", &self.options)
            .field("next", &self.next)
            .field("frames", &self.seq.len())
            .finish_non_exhaustive()
    }
}

/// What a bake has finished so far: its frames' records, and the asset's blocks in order.
struct Done {
    search: Option<Search>,
    rbfs: usize,
    records: Vec<FrameRecord>,
    blocks: Vec<(BlockKind, Scope, Vec<u8>)>,
    /// Asset frames already in hash volumes.
    hashed: usize,
    state: FitterState,
}

/// The most RBFs a frame may have (`--rbfs`, `--max-rbfs`): each costs a minimization's
/// worth of work per frame, and the asset stores every one; larger counts are refused
/// rather than left to run for days.
pub const MAX_RBFS: usize = 65_536;

impl Bake {
    /// Opens the input and the journal of an interrupted bake when `options.resume` (else
    /// starts one, running the RBF-count search of `Count::Target` first); `events` hears
    /// of the long steps.
    pub fn new(
        options: BakeOptions,
        mut events: impl FnMut(Event<'_>) + Send + 'static,
    ) -> Result<Bake> {
        let args = options;
        let start = Instant::now();
        let seq = Frames::open(&args.input, &args.import, args.range)?;
        if seq.dims().contains(&0) {
            bail!(
                "{}: every frame is empty; nothing to bake",
                args.input.display()
            );
        }
        if !seq.gaps().is_empty() {
            tracing::warn!(
                "{}: missing frames {:?}; the asset's frames follow the files in order",
                args.input.display(),
                seq.gaps()
            );
        }
        let journal_path = journal::path_for(&args.out);
        let inputs = inputs(&seq, &args)?;
        let previous = if args.resume {
            Journal::open(&journal_path)?
        } else {
            None
        };
        let resumed = previous.is_some();
        let (journal, mut done) = match previous {
            Some((j, records)) => {
                let done = restore(&journal_path, &inputs, records)?;
                events(Event::Resumed {
                    finished: done.records.len(),
                    total: seq.len(),
                });
                (j, done)
            }
            None => {
                if args.resume {
                    tracing::warn!(
                        "{}: no interrupted bake to resume; starting from the first frame",
                        journal_path.display()
                    );
                } else if journal_path.exists() {
                    tracing::warn!(
                        "{}: replacing the journal of an interrupted bake (--resume continues one)",
                        journal_path.display()
                    );
                }
                let (rbfs, search) = match args.count {
                    Count::Fixed(n) => (n, None),
                    Count::Target { rel_l2, cap } => {
                        let s = choose_count(&seq, rel_l2, cap, &args.fit, &mut events)?;
                        (s.rbfs, Some(s))
                    }
                };
                let start = json!({"inputs": inputs, "rbfs": rbfs, "search": search});
                let j = Journal::create(&journal_path, &start)?;
                let done = Done {
                    search,
                    rbfs,
                    records: Vec::new(),
                    blocks: Vec::new(),
                    hashed: 0,
                    state: FitterState::default(),
                };
                (j, done)
            }
        };
        let opts = SequenceOptions {
            rbfs: done.rbfs,
            ..args.fit.clone()
        };
        let mut fitter = SequenceFitter::resume(opts.clone(), std::mem::take(&mut done.state));
        if !resumed {
            if let Some(b) = args.baseline {
                fitter.pin(b);
            }
            warm_up(&args, &mut fitter, &mut events)?;
        }
        let mut residuals = ResidualStage::new(
            args.quant,
            args.brick,
            args.volume_bytes,
            seq.dims(),
            done.hashed,
        )?;
        // Frames finished but not yet hashed: their quantized residuals again (deterministic).
        for i in done.hashed..done.records.len() {
            let v = seq.load(i)?;
            let rbfs = frame_rbfs(&done, i)?;
            residuals.push(&v, &rbfs)?;
        }
        Ok(Bake {
            next: done.records.len(),
            options: args,
            seq,
            journal,
            done,
            opts,
            fitter,
            residuals,
            failed: false,
            start,
            events: Box::new(events),
        })
    }

    /// The input frames.
    pub fn sequence(&self) -> &Frames {
        &self.seq
    }

    /// Frames finished so far (including those of a resumed journal).
    pub fn finished(&self) -> usize {
        self.done.records.len()
    }

    /// The RBF count of the first frame (fixed, or chosen by the search).
    pub fn rbfs(&self) -> usize {
        self.opts.rbfs
    }

    /// Fits frame `self.next`, journals it, and builds a hash volume when one is complete.
    fn step(&mut self) -> Result<FrameRecord> {
        let i = self.next;
        let seq = &self.seq;
        let number = seq.number(i);
        (self.events)(Event::Fitting {
            index: i,
            frame: number,
        });
        let v = seq.load(i)?;
        let fit = self
            .fitter
            .fit(&v)
            .map_err(|e| anyhow::anyhow!("{}: {e}", seq.label(i)))?;
        tracing::info!(
            "frame {}: {} RBFs (+{} −{}, {} moved), rel_l2 {:.4} (ratio {:.3}), rms/max {:.4}, {} iterations, {:.2} s",
            number,
            fit.rbfs.len(),
            fit.inserted,
            fit.deleted,
            fit.exchanged,
            fit.rel_l2,
            fit.error_ratio,
            fit.rms_over_max,
            fit.iterations,
            fit.fit_seconds
        );
        // A frame left over the threshold is the bake working as intended (the residual
        // stores what the RBFs miss): why, per frame, is detail; the caller sums them up.
        if fit.insertion_capped && fit.insertion_stop == Some(haze_fit::InsertionStop::Ceiling) {
            tracing::info!(
                "{}: error ratio {:.3} over --threshold {} at the ceiling of {} RBFs a frame (--max-rbfs; by default {}× the first frame's count) after inserting {} and moving {}: the ceiling bounds what a frame costs, and the residual stores what the RBFs miss (raise --max-rbfs to spend more RBFs)",
                seq.label(i),
                fit.error_ratio,
                self.opts.threshold,
                fit.rbfs.len(),
                haze_fit::sequence::GROWTH_LIMIT,
                fit.inserted,
                fit.exchanged
            );
        } else if fit.insertion_capped {
            tracing::info!(
                "{}: error ratio {:.3} over --threshold {} after inserting {} RBFs, the most this frame may insert (the smoke's growth or the error's excess, or --max-insert), and moving {}: its detail grows faster than its size, and the residual stores what the RBFs miss",
                seq.label(i),
                fit.error_ratio,
                self.opts.threshold,
                fit.inserted,
                fit.exchanged
            );
        } else if fit.insertion_stalled
            && fit.insertion_stop == Some(haze_fit::InsertionStop::MarginalGain)
        {
            tracing::info!(
                "{}: error ratio {:.3} over --threshold {}: insertion stopped by marginal gain after {} RBFs: the best RBF left out would lower ∫R² by {:.3e}, under the {:.3e} that --marginal-gain {} of the first frame's asks; the detail left is finer than RBFs pay for and goes to the residual (lower --marginal-gain to spend more RBFs on it)",
                seq.label(i),
                fit.error_ratio,
                self.opts.threshold,
                fit.inserted,
                fit.next_gain.unwrap_or(0.0),
                fit.gain_floor,
                self.opts.marginal_gain
            );
        } else if fit.insertion_stalled {
            tracing::info!(
                "{}: error ratio {:.3} over --threshold {}: inserting RBFs stopped lowering the error ({} inserted); the detail left is finer than the smallest radius and goes to the residual",
                seq.label(i),
                fit.error_ratio,
                self.opts.threshold,
                fit.inserted
            );
        }
        let rbf_block = encode_rbfs(&fit.rbfs);
        let residual = self.residuals.push(&v, &fit.rbfs)?;
        let record = FrameRecord {
            frame: number,
            rbfs: fit.rbfs.len(),
            fit,
            residual,
        };
        self.journal.append(
            Tag::Frame,
            &json!({"record": record, "state": self.fitter.state()}),
            &rbf_block,
        )?;
        let done = &mut self.done;
        done.blocks
            .push((BlockKind::Rbfs, Scope::frame(i as u32), rbf_block));
        done.records.push(record);
        if self.residuals.full() || i + 1 == seq.len() {
            (self.events)(Event::Hashing);
            if let Some(h) = self.residuals.flush()? {
                // Before 27 frames and before the sequence's end: closed by its size.
                if h.count < haze_hash::tile::GROUP && i + 1 < seq.len() {
                    tracing::info!(
                        "frames {}..{}: hash volume closed at {} frame{}, as another would take it past --volume-mib {}",
                        seq.number(h.first),
                        seq.number(h.first + h.count - 1),
                        h.count,
                        if h.count == 1 { "" } else { "s" },
                        (self.options.volume_bytes as f64 / 1_048_576.0 * 1e3).round() / 1e3
                    );
                }
                let shares = json!({"first": h.first, "count": h.count, "shares": h.shares,
                                    "bricks": h.bricks});
                self.journal.append(Tag::Group, &shares, &h.bytes)?;
                apply(&mut done.records, &h);
                warn_widened(&done.records[h.first..h.first + h.count], seq);
                if !h.bytes.is_empty() {
                    done.blocks
                        .push((BlockKind::ResidualHash, h.scope(), h.bytes));
                }
            }
        }
        self.next += 1;
        Ok(done.records[i].clone())
    }

    /// Gives the bake up after `error`: a journal that holds no finished frame is
    /// removed (nothing to resume, nothing left behind); one that holds some is kept for
    /// `--resume`, and the error says so.
    pub fn abandon(self, error: anyhow::Error) -> anyhow::Error {
        let path = journal::path_for(&self.options.out);
        let finished = self.done.records.len();
        if finished == 0 {
            if let Err(e) = self.journal.remove() {
                tracing::warn!("{e:#}");
            }
            return error;
        }
        anyhow::anyhow!(
            "{error:#} ({finished} finished frame{} kept in {} for --resume)",
            if finished == 1 { "" } else { "s" },
            path.display()
        )
    }

    /// Fits the frames not yet fitted, then writes the asset (atomically) and removes the
    /// journal.
    pub fn finish(mut self) -> Result<Baked> {
        for r in self.by_ref() {
            r?;
        }
        if self.failed {
            bail!(
                "{}: the bake failed; nothing written",
                self.options.out.display()
            );
        }
        let (args, seq, done, opts) = (&self.options, &self.seq, &self.done, &self.opts);
        let settings = json!({
            "rbfs": opts.rbfs,
            "options": opts,
            "search": done.search,
            "quant_bits": args.quant.bits,
            "residual_error": args.quant.error,
            "residual_brick": args.brick,
            "warm_up": args.warm_up,
        });
        let records = &done.records;
        let mut header = crate::header::for_sequence(seq, &args.input, &args.import)?;
        let summary: Vec<_> = records
            .iter()
            .map(|r| {
                json!({"frame": r.frame, "rbfs": r.rbfs, "rel_l2": r.fit.rel_l2,
                   "rms_over_max": r.fit.rms_over_max,
                   "residual_nonzero": r.residual.residual_nonzero,
                   "residual_bricks": r.residual.residual_bricks,
                   "rbf_max_error": r.residual.rbf_max_error,
                   "hash_bytes": r.residual.hash_bytes,
                   "quant_step": r.residual.quant_step})
            })
            .collect();
        header.settings.insert(
            "fit".into(),
            json!({"settings": settings, "frames": summary}),
        );
        if !args.choices.is_empty() {
            header
                .extra
                .insert("choices".into(), args.choices.clone().into());
        }
        let mut writer = AssetWriter::create(&args.out)?;
        for (kind, scope, bytes) in &done.blocks {
            writer.write_block(*kind, *scope, bytes)?;
        }
        writer.finish(&header)?;
        self.journal.remove()?;
        let bytes = std::fs::metadata(&args.out)
            .with_context(|| format!("{}: written but unreadable", args.out.display()))?
            .len();
        Ok(Baked {
            out: args.out.clone(),
            bytes,
            seconds: self.start.elapsed().as_secs_f64(),
            temporal: temporal(records, opts.threshold),
            records: done.records.clone(),
            settings,
        })
    }
}

impl Iterator for Bake {
    type Item = Result<FrameRecord>;

    /// The next finished frame; after an error, `None`.
    fn next(&mut self) -> Option<Result<FrameRecord>> {
        if self.failed || self.next >= self.seq.len() {
            return None;
        }
        let r = self.step();
        self.failed = r.is_err();
        Some(r)
    }
}

fn apply(records: &mut [FrameRecord], h: &HashVolume) {
    let mut res: Vec<ResidualRecord> = records.iter().map(|r| r.residual.clone()).collect();
    h.share_into(&mut res);
    for (r, s) in records.iter_mut().zip(res) {
        r.residual = s;
    }
}

/// What a journal must match to be resumed: the inputs (names and sizes of the frame
/// files) and every setting that changes the result.
fn inputs(seq: &Frames, args: &BakeOptions) -> Result<serde_json::Value> {
    let frames = seq.identity()?;
    let mut inputs = json!({
        "generator": env!("CARGO_PKG_VERSION"),
        "frames": frames,
        "import": args.import,
        "count": args.count,
        "fit": args.fit,
        "quant_bits": args.quant.bits,
        "residual_error": args.quant.error,
        "residual_brick": args.brick,
    });
    // Named only when not the default, so that journals written before volumes had a
    // size limit (all at the default) still resume.
    if args.volume_bytes != haze_hash::tile::VOLUME_BYTES {
        inputs["residual_volume_bytes"] = json!(args.volume_bytes);
    }
    Ok(inputs)
}

/// The finished part of an interrupted bake, from its journal.
fn restore(path: &Path, inputs: &serde_json::Value, records: Vec<Record>) -> Result<Done> {
    let mut it = records.into_iter();
    let start = it.next().map(|r| r.json).unwrap_or_default();
    if start["inputs"] != *inputs {
        let what = [
            "frames",
            "import",
            "count",
            "fit",
            "quant_bits",
            "residual_error",
            "residual_brick",
            "residual_volume_bytes",
            "generator",
        ]
        .into_iter()
        .find(|k| start["inputs"][k] != inputs[k])
        .unwrap_or("settings");
        bail!(
            "{}: the interrupted bake had other {}; run without --resume to start over",
            path.display(),
            match what {
                "frames" => "input frames",
                "import" => "import options",
                "count" => "RBF count options",
                "fit" => "fit options",
                "quant_bits" => "--quant-bits",
                "residual_error" => "--residual-error",
                "residual_brick" => "--residual-brick",
                "residual_volume_bytes" => "--volume-mib",
                "generator" => "haze version",
                other => other,
            }
        );
    }
    let bad = |what: &str| anyhow::anyhow!("{}: damaged journal ({what})", path.display());
    let mut done = Done {
        search: serde_json::from_value(start["search"].clone()).map_err(|_| bad("search"))?,
        rbfs: serde_json::from_value(start["rbfs"].clone()).map_err(|_| bad("rbfs"))?,
        records: Vec::new(),
        blocks: Vec::new(),
        hashed: 0,
        state: FitterState::default(),
    };
    for r in it {
        match r.tag {
            Tag::Frame => {
                let record: FrameRecord =
                    serde_json::from_value(r.json["record"].clone()).map_err(|_| bad("frame"))?;
                done.state =
                    serde_json::from_value(r.json["state"].clone()).map_err(|_| bad("state"))?;
                let k = done.records.len() as u32;
                done.blocks.push((BlockKind::Rbfs, Scope::frame(k), r.bin));
                done.records.push(record);
            }
            Tag::Group => {
                let first: usize =
                    serde_json::from_value(r.json["first"].clone()).map_err(|_| bad("group"))?;
                let count: usize =
                    serde_json::from_value(r.json["count"].clone()).map_err(|_| bad("group"))?;
                let shares: Vec<(f64, f64)> =
                    serde_json::from_value(r.json["shares"].clone()).map_err(|_| bad("group"))?;
                let bricks: Vec<usize> =
                    serde_json::from_value(r.json["bricks"].clone()).map_err(|_| bad("group"))?;
                if first != done.hashed
                    || shares.len() != count
                    || bricks.len() != count
                    || first + count > done.records.len()
                {
                    return Err(bad("hash volumes out of order"));
                }
                let h = HashVolume {
                    first,
                    count,
                    bytes: r.bin,
                    shares,
                    bricks,
                };
                apply(&mut done.records, &h);
                if !h.bytes.is_empty() {
                    done.blocks
                        .push((BlockKind::ResidualHash, h.scope(), h.bytes));
                }
                done.hashed += count;
            }
            Tag::Start => return Err(bad("two start records")),
        }
    }
    Ok(done)
}

/// The stored RBFs of finished frame `k`.
fn frame_rbfs(done: &Done, k: usize) -> Result<Vec<haze_volume::Rbf>> {
    let block = done
        .blocks
        .iter()
        .find(|(kind, scope, _)| *kind == BlockKind::Rbfs && *scope == Scope::frame(k as u32))
        .ok_or_else(|| anyhow::anyhow!("journal: frame {k} has no RBF block"))?;
    decode_rbfs(&block.2).map_err(|e| anyhow::anyhow!("journal: frame {k}: {e}"))
}

/// Runs the RBF-count search on the first non-empty frame.
fn choose_count(
    seq: &Frames,
    target: f64,
    cap: usize,
    opts: &SequenceOptions,
    events: &mut impl FnMut(Event<'_>),
) -> Result<Search> {
    for i in 0..seq.len() {
        let v = seq.load(i)?;
        let grid =
            FitGrid::from_volume(&v).map_err(|e| anyhow::anyhow!("{}: {e}", seq.label(i)))?;
        if grid.sum_sq <= 0.0 {
            continue;
        }
        events(Event::Searching {
            frame: seq.number(i),
            target,
        });
        let s = rbfs_for_target(&grid, target, cap, &opts.fit);
        events(Event::Searched(&s));
        for p in &s.probes {
            tracing::info!(
                "  {} RBFs: rel_l2 {:.4} ({:.2} s)",
                p.rbfs,
                p.rel_l2,
                p.seconds
            );
        }
        if s.plateau
            && let [.., a, b] = s.probes.as_slice()
        {
            tracing::warn!(
                "rel_l2 {target} is out of reach of RBFs: {} → {} RBFs lowered rel_l2 only from {:.4} to {:.4}, as the finest detail is narrower than the smallest radius {:.5} allows (--radius-min, never below the grid's Nyquist radius 2h/π); baking with {} RBFs and leaving the rest to the residual (--residual-error)",
                a.fitted,
                b.fitted,
                a.rel_l2,
                b.rel_l2,
                opts.fit.bounds.radius_on(&grid).0,
                s.rbfs
            );
        } else if !s.reached {
            tracing::warn!(
                "rel_l2 {target} not reached with the cap of {cap} RBFs; baking with {} (raise --max-rbfs)",
                s.rbfs
            );
        }
        return Ok(s);
    }
    Ok(Search {
        rbfs: 0,
        reached: true,
        plateau: false,
        probes: Vec::new(),
    })
}

/// Flicker measures over the sequence.
fn temporal(records: &[FrameRecord], threshold: f64) -> serde_json::Value {
    let moves: Vec<f64> = records
        .iter()
        .filter_map(|r| r.fit.mean_center_displacement)
        .collect();
    let ratios: Vec<f64> = records.iter().map(|r| r.fit.error_ratio).collect();
    json!({
        "mean_center_displacement": if moves.is_empty() { None } else {
            Some(moves.iter().sum::<f64>() / moves.len() as f64) },
        "max_error_ratio": ratios.iter().copied().fold(0.0, f64::max),
        "error_ratio_threshold": threshold,
        "frames_over_threshold": records.iter().filter(|r| r.fit.error_ratio > threshold).count(),
        "frames_capped": records.iter().filter(|r| r.fit.insertion_capped).count(),
        "frames_stalled": records.iter().filter(|r| r.fit.insertion_stalled).count(),
        "frames_marginal_gain": records.iter().filter(|r| r.fit.insertion_stop == Some(haze_fit::InsertionStop::MarginalGain)).count(),
        "inserted": records.iter().map(|r| r.fit.inserted).sum::<usize>(),
        "exchanged": records.iter().map(|r| r.fit.exchanged).sum::<usize>(),
        "deleted": records.iter().map(|r| r.fit.deleted).sum::<usize>(),
    })
}

/// Warns about the frames whose residual could not be stored at the error asked for.
fn warn_widened(records: &[FrameRecord], frames: &Frames) {
    let widened: Vec<i64> = records
        .iter()
        .filter(|r| r.residual.quant_widened)
        .map(|r| r.frame)
        .collect();
    if let (Some(first), Some(r)) = (
        widened.first(),
        records.iter().find(|r| r.residual.quant_widened),
    ) {
        let place = (0..frames.len())
            .find(|&i| frames.number(i) == *first)
            .map_or(String::new(), |i| format!("{}: ", frames.label(i)));
        tracing::warn!(
            "{place}frames {widened:?}: the residual's largest value ({:.3} of the peak) needs more than --quant-bits at the asked --residual-error; the step was widened (raise --quant-bits to keep the error)",
            r.residual.rbf_max_error
        );
    }
}
