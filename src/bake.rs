//! `haze bake`: a sequence of density volumes → RBF fits in a .haze asset (+ a report).

use crate::journal::{self, Journal, Record, Tag};
use crate::output;
use crate::progress;
use crate::residual::{HashVolume, ResidualRecord, ResidualStage};
use anyhow::{Context, Result, bail};
use haze_asset::{AssetWriter, BlockKind, Scope, decode_rbfs, encode_rbfs};
use haze_fit::{
    FitGrid, FitterState, FrameFit, Search, SequenceFitter, SequenceOptions, rbfs_for_target,
};
use haze_volume::ImportOptions;
use haze_volume::import::{FrameRange, Sequence};
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

/// Everything `haze bake` was asked to do.
#[derive(Debug)]
pub struct BakeArgs {
    pub input: PathBuf,
    pub out: PathBuf,
    pub range: FrameRange,
    pub import: ImportOptions,
    pub count: Count,
    pub fit: SequenceOptions,
    pub report: Option<PathBuf>,
    /// The residual's error (fraction of each frame's peak) and widest stored value.
    pub quant: haze_hash::QuantOptions,
    /// Brick side of the residual hash.
    pub brick: u32,
    /// Continue the interrupted bake of `out` from its journal.
    pub resume: bool,
}

/// One frame's line in the report and in the asset header.
#[derive(Serialize, Deserialize)]
struct FrameRecord {
    frame: i64,
    rbfs: usize,
    #[serde(flatten)]
    fit: FrameFit,
    #[serde(flatten)]
    residual: ResidualRecord,
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

pub fn run(args: BakeArgs) -> Result<()> {
    let start = Instant::now();
    let seq = Sequence::open(&args.input, &args.import, args.range)?;
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
    let (mut journal, mut done) = match previous {
        Some((j, records)) => {
            let done = restore(&journal_path, &inputs, records)?;
            eprintln!(
                "{}: resuming after {} of {}",
                args.out.display(),
                progress::count(done.records.len(), "finished frame"),
                seq.len()
            );
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
                    let s = choose_count(&seq, rel_l2, cap, &args.fit)?;
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
    let mut residuals = ResidualStage::new(args.quant, args.brick, seq.dims(), done.hashed)?;
    let bar = progress::frames(seq.len(), "fitting");
    // Frames finished but not yet hashed: their quantized residuals again (deterministic).
    for i in done.hashed..done.records.len() {
        bar.set_message(format!("frame {}", seq.frames()[i].number));
        let v = seq.load(i)?;
        let rbfs = frame_rbfs(&done, i)?;
        residuals.push(&v, &rbfs)?;
    }
    bar.set_position(done.records.len() as u64);
    for i in done.records.len()..seq.len() {
        let f = &seq.frames()[i];
        bar.set_message(format!("frame {}", f.number));
        let v = seq.load(i)?;
        let fit = fitter
            .fit(&v)
            .map_err(|e| anyhow::anyhow!("{}: {e}", f.path.display()))?;
        tracing::info!(
            "frame {}: {} RBFs, rel_l2 {:.4}, rms/max {:.4}, {} iterations, {:.2} s",
            f.number,
            fit.rbfs.len(),
            fit.rel_l2,
            fit.rms_over_max,
            fit.iterations,
            fit.fit_seconds
        );
        let rbf_block = encode_rbfs(&fit.rbfs);
        let residual = residuals.push(&v, &fit.rbfs)?;
        let record = FrameRecord {
            frame: f.number,
            rbfs: fit.rbfs.len(),
            fit,
            residual,
        };
        journal.append(
            Tag::Frame,
            &json!({"record": record, "state": fitter.state()}),
            &rbf_block,
        )?;
        done.blocks
            .push((BlockKind::Rbfs, Scope::frame(i as u32), rbf_block));
        done.records.push(record);
        if residuals.full() || i + 1 == seq.len() {
            bar.set_message("hashing");
            if let Some(h) = residuals.flush()? {
                let shares = json!({"first": h.first, "count": h.count, "shares": h.shares,
                                    "bricks": h.bricks});
                journal.append(Tag::Group, &shares, &h.bytes)?;
                apply(&mut done.records, &h);
                warn_widened(&done.records[h.first..h.first + h.count], seq.frames());
                if !h.bytes.is_empty() {
                    done.blocks
                        .push((BlockKind::ResidualHash, h.scope(), h.bytes));
                }
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();

    let settings = json!({
        "rbfs": opts.rbfs,
        "options": opts,
        "search": done.search,
        "quant_bits": args.quant.bits,
        "residual_error": args.quant.error,
        "residual_brick": args.brick,
    });
    let records = &done.records;
    let mut header = crate::asset_header::for_sequence(&seq, &args.input, &args.import)?;
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
    let mut writer = AssetWriter::create(&args.out)?;
    for (kind, scope, bytes) in &done.blocks {
        writer.write_block(*kind, *scope, bytes)?;
    }
    writer.finish(&header)?;
    journal.remove()?;
    let bytes = std::fs::metadata(&args.out)
        .with_context(|| format!("{}: written but unreadable", args.out.display()))?
        .len();
    let seconds = start.elapsed().as_secs_f64();
    eprintln!("{}", summary_line(&args.out, records, bytes, seconds));
    if let Some(path) = &args.report {
        let doc = json!({
            "input": args.input.display().to_string(),
            "output": args.out.display().to_string(),
            "settings": settings,
            "frames": records,
            "temporal": temporal(records, opts.threshold),
            "totals": {"seconds": seconds, "bytes": bytes, "frames": records.len()},
        });
        output::write_json(path, &doc)?;
    }
    Ok(())
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
fn inputs(seq: &Sequence, args: &BakeArgs) -> Result<serde_json::Value> {
    let frames = seq
        .frames()
        .iter()
        .map(|f| {
            let size = std::fs::metadata(&f.path)
                .with_context(|| format!("{}: cannot read", f.path.display()))?
                .len();
            Ok(json!([f.number, f.path.display().to_string(), size]))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(json!({
        "generator": env!("CARGO_PKG_VERSION"),
        "frames": frames,
        "import": args.import,
        "count": args.count,
        "fit": args.fit,
        "quant_bits": args.quant.bits,
        "residual_error": args.quant.error,
        "residual_brick": args.brick,
    }))
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
fn choose_count(seq: &Sequence, target: f64, cap: usize, opts: &SequenceOptions) -> Result<Search> {
    for i in 0..seq.len() {
        let v = seq.load(i)?;
        let grid = FitGrid::from_volume(&v)
            .map_err(|e| anyhow::anyhow!("{}: {e}", seq.frames()[i].path.display()))?;
        if grid.sum_sq <= 0.0 {
            continue;
        }
        let spinner = progress::spinner(&format!(
            "choosing the RBF count for rel_l2 ≤ {target} on frame {}",
            seq.frames()[i].number
        ));
        let s = rbfs_for_target(&grid, target, cap, &opts.fit);
        spinner.finish_and_clear();
        for p in &s.probes {
            tracing::info!(
                "  {} RBFs: rel_l2 {:.4} ({:.2} s)",
                p.rbfs,
                p.rel_l2,
                p.seconds
            );
        }
        if !s.reached {
            tracing::warn!(
                "rel_l2 {target} not reached with the cap of {cap} RBFs; baking with {}",
                s.rbfs
            );
        }
        return Ok(s);
    }
    Ok(Search {
        rbfs: 0,
        reached: true,
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
        "frames_over_threshold": records.iter().filter(|r| r.fit.insertion_capped).count(),
        "inserted": records.iter().map(|r| r.fit.inserted).sum::<usize>(),
        "deleted": records.iter().map(|r| r.fit.deleted).sum::<usize>(),
    })
}

fn summary_line(out: &Path, records: &[FrameRecord], bytes: u64, seconds: f64) -> String {
    let n = records.len().max(1) as f64;
    let mean = |f: fn(&FrameRecord) -> f64| records.iter().map(f).sum::<f64>() / n;
    let met = records
        .iter()
        .filter(|r| r.residual.rbfs_meet_error)
        .count();
    format!(
        "{}: {}, {:.0} RBFs/frame, mean rel_l2 {:.4}, mean rms/max {:.4}, residual {}/frame ({} met by the RBFs alone), {}, {:.1} s",
        out.display(),
        progress::count(records.len(), "frame"),
        mean(|r| r.rbfs as f64),
        mean(|r| r.fit.rel_l2),
        mean(|r| r.fit.rms_over_max),
        crate::inspect::bytes(mean(|r| r.residual.hash_bytes) as u64),
        met,
        crate::inspect::bytes(bytes),
        seconds
    )
}

/// Warns about the frames whose residual could not be stored at the error asked for.
fn warn_widened(records: &[FrameRecord], frames: &[haze_volume::import::FrameFile]) {
    let widened: Vec<i64> = records
        .iter()
        .filter(|r| r.residual.quant_widened)
        .map(|r| r.frame)
        .collect();
    if let (Some(first), Some(r)) = (
        widened.first(),
        records.iter().find(|r| r.residual.quant_widened),
    ) {
        let path = frames
            .iter()
            .find(|f| f.number == *first)
            .map_or(String::new(), |f| format!("{}: ", f.path.display()));
        tracing::warn!(
            "{path}frames {widened:?}: the residual's largest value ({:.3} of the peak) needs more than --quant-bits at the asked --residual-error; the step was widened (raise --quant-bits to keep the error)",
            r.residual.rbf_max_error
        );
    }
}
