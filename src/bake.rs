//! `haze bake`: a sequence of density volumes → RBF fits in a .haze asset (+ a report).

use crate::output;
use crate::progress;
use crate::residual::{ResidualRecord, ResidualStage};
use anyhow::{Context, Result, bail};
use haze_asset::{AssetWriter, BlockKind, Scope, encode_rbfs};
use haze_fit::{FitGrid, FrameFit, Search, SequenceFitter, SequenceOptions, rbfs_for_target};
use haze_volume::ImportOptions;
use haze_volume::import::{FrameRange, Sequence};
use serde::Serialize;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How many RBFs a first frame gets.
#[derive(Clone, Copy, Debug)]
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
    /// Bits of the quantized residual.
    pub quant_bits: u8,
}

/// One frame's line in the report and in the asset header.
#[derive(Serialize)]
struct FrameRecord {
    frame: i64,
    rbfs: usize,
    #[serde(flatten)]
    fit: FrameFit,
    #[serde(flatten)]
    residual: ResidualRecord,
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
    let mut opts = args.fit.clone();
    let search = match args.count {
        Count::Fixed(n) => {
            opts.rbfs = n;
            None
        }
        Count::Target { rel_l2, cap } => {
            let s = choose_count(&seq, rel_l2, cap, &opts)?;
            opts.rbfs = s.rbfs;
            Some(s)
        }
    };
    let mut fitter = SequenceFitter::new(opts.clone());
    let mut residuals = ResidualStage::new(args.quant_bits, seq.dims())?;
    let mut writer = AssetWriter::create(&args.out)?;
    let bar = progress::frames(seq.len(), "fitting");
    let mut records = Vec::with_capacity(seq.len());
    for (i, f) in seq.frames().iter().enumerate() {
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
        writer.write_block(
            BlockKind::Rbfs,
            Scope::frame(i as u32),
            &encode_rbfs(&fit.rbfs),
        )?;
        let residual = residuals.push(&v, &fit.rbfs)?;
        records.push(FrameRecord {
            frame: f.number,
            rbfs: fit.rbfs.len(),
            fit,
            residual,
        });
        if residuals.full() || i + 1 == seq.len() {
            let mut shares: Vec<ResidualRecord> =
                records.iter().map(|r| r.residual.clone()).collect();
            residuals.flush(&mut writer, &mut shares)?;
            for (r, s) in records.iter_mut().zip(shares) {
                r.residual = s;
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();

    let settings = json!({
        "rbfs": opts.rbfs,
        "options": opts,
        "search": search,
        "quant_bits": args.quant_bits,
    });
    let mut header = crate::asset_header::for_sequence(&seq, &args.input, &args.import)?;
    let summary: Vec<_> = records
        .iter()
        .map(|r| {
            json!({"frame": r.frame, "rbfs": r.rbfs, "rel_l2": r.fit.rel_l2,
                   "rms_over_max": r.fit.rms_over_max,
                   "residual_nonzero": r.residual.residual_nonzero,
                   "hash_bytes": r.residual.hash_bytes,
                   "quant_step": r.residual.quant_step})
        })
        .collect();
    header.settings.insert(
        "fit".into(),
        json!({"settings": settings, "frames": summary}),
    );
    writer.finish(&header)?;
    let bytes = std::fs::metadata(&args.out)
        .with_context(|| format!("{}: written but unreadable", args.out.display()))?
        .len();
    let seconds = start.elapsed().as_secs_f64();
    eprintln!("{}", summary_line(&args.out, &records, bytes, seconds));
    if let Some(path) = &args.report {
        let doc = json!({
            "input": args.input.display().to_string(),
            "output": args.out.display().to_string(),
            "settings": settings,
            "frames": records,
            "temporal": temporal(&records, opts.threshold),
            "totals": {"seconds": seconds, "bytes": bytes, "frames": records.len()},
        });
        output::write_json(path, &doc)?;
    }
    Ok(())
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
    format!(
        "{}: {}, {:.0} RBFs/frame, mean rel_l2 {:.4}, mean rms/max {:.4}, {}, {:.1} s",
        out.display(),
        progress::count(records.len(), "frame"),
        mean(|r| r.rbfs as f64),
        mean(|r| r.fit.rel_l2),
        mean(|r| r.fit.rms_over_max),
        crate::inspect::bytes(bytes),
        seconds
    )
}
