//! Per-frame figures of a sequence fit (no residual, no asset): error, error ratio, RBFs
//! inserted and moved (after insertion stopped over the threshold), iterations (at half
//! and at full resolution), objective passes and seconds, where a warm frame's seconds
//! went (the minimizations after the deletions, insertion rounds and exchange rounds with
//! their passes; matching pursuit; removal costs), then a summary line (with how many
//! warm frames went coarse first, `--warm-coarse`). `--paper`
//! runs paper A's warm frames (one insertion at a time, at most 8, full resolution only, per-iteration convergence test) for a before/after.
//! `--cold-every K` also fits every K-th warm frame from scratch with the warm fit's RBF
//! count and prints the warm error over the cold one: above 1 is drift that the warm
//! start added, not the smoke's own growing complexity. `--cold-density K` fits every
//! K-th warm frame from scratch with the first frame's RBFs per voxel of smoke (its count
//! times the growth of [`smoke_support`](haze_fit::sequence::smoke_support)) and prints that
//! count, the cold error and the warm error over it: the error the first frame's RBF
//! density reaches on this frame, against which a warm frame's drift can be judged.
//!
//! cargo run --release -p haze-fit --example sequence -- INPUT [--frames A..B] [--rbfs N]
//!     [--paper] [--coarse auto|on|off] [--warm-coarse auto|on|off] [--warm-polish N]
//!     [--insertion batch|single] [--max-insert M] [--max-rbfs N]
//!     [--warm-gain F] [--warm-window W] [--warm-iterations N] [--tolerance F]
//!     [--polish-iterations N]
//!     [--threshold T] [--marginal-gain F] [--cold-every K] [--cold-density K] [--radius-min R]

use haze_fit::sequence::smoke_support;
use haze_fit::{
    Coarse, FitGrid, Insertion, InsertionStop, SequenceFitter, SequenceOptions, fit_first_frame,
};
use haze_volume::ImportOptions;
use haze_volume::import::{FrameRange, Sequence};
use std::path::Path;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(2)
}

fn value<T: std::str::FromStr>(args: &[String], i: usize) -> T {
    args.get(i + 1)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| fail(format!("{} needs a valid value", args[i])))
}

fn coarse_arg(args: &[String], i: usize) -> Coarse {
    match args.get(i + 1).map(String::as_str) {
        Some("auto") => Coarse::Auto,
        Some("on") => Coarse::Always,
        Some("off") => Coarse::Never,
        _ => fail(format!("{} auto|on|off", args[i])),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(input) = args.first() else {
        fail(
            "usage: sequence INPUT [--frames A..B] [--rbfs N] [--paper] [--coarse auto|on|off] [--warm-coarse auto|on|off] [--warm-polish N] [--insertion batch|single] [--max-insert M] [--max-rbfs N] [--warm-gain F] [--warm-window W] [--warm-iterations N] [--tolerance F] [--polish-iterations N] [--threshold T] [--marginal-gain F] [--cold-every K] [--cold-density K] [--radius-min R]",
        )
    };
    let mut range = FrameRange::default();
    let mut opts = SequenceOptions::default();
    let (mut cold_every, mut cold_density) = (0usize, 0usize);
    let mut i = 1;
    while i < args.len() {
        match args[i].as_str() {
            "--frames" => range = value(&args, i),
            "--rbfs" => opts.rbfs = value(&args, i),
            "--threshold" => opts.threshold = value(&args, i),
            "--marginal-gain" => opts.marginal_gain = value(&args, i),
            "--cold-every" => cold_every = value(&args, i),
            "--cold-density" => cold_density = value(&args, i),
            "--max-insert" => opts.max_insert = Some(value(&args, i)),
            "--max-rbfs" => opts.max_rbfs = Some(value(&args, i)),
            "--warm-gain" => opts.warm.window_gain = value(&args, i),
            "--warm-window" => opts.warm.window = value(&args, i),
            "--warm-iterations" => opts.warm.max_iterations = value(&args, i),
            "--tolerance" => opts.fit.stop.relative_reduction = value(&args, i),
            "--polish-iterations" => opts.fit.polish.max_iterations = value(&args, i),
            "--radius-min" => opts.fit.bounds.radius.0 = value(&args, i),
            "--coarse" => opts.fit.coarse = coarse_arg(&args, i),
            "--warm-coarse" => opts.warm_coarse = coarse_arg(&args, i),
            "--warm-polish" => opts.warm_polish = value(&args, i),
            "--insertion" => {
                opts.insertion = match args.get(i + 1).map(String::as_str) {
                    Some("batch") => Insertion::Batch,
                    Some("single") => Insertion::Single,
                    _ => fail("--insertion batch|single"),
                }
            }
            "--paper" => {
                opts.insertion = Insertion::Single;
                opts.max_insert = Some(8);
                opts.fit.coarse = Coarse::Never;
                opts.warm_coarse = Coarse::Never;
                opts.warm.window = 0;
                i -= 1;
            }
            other => fail(format!("unknown argument {other}")),
        }
        i += 2;
    }
    let seq = Sequence::open(Path::new(input), &ImportOptions::default(), range)
        .unwrap_or_else(|e| fail(format!("{input}: {e}")));
    let d = seq.dims();
    println!(
        "{input}: {} frames of {} × {} × {}",
        seq.len(),
        d[0],
        d[1],
        d[2]
    );
    println!(
        "| frame | RBFs | +ins | moved | rel_l2 | rms/max | ratio | iterations (coarse) | passes | insert s | seconds | split s (passes): warm / insert / exchange min., pursuit, removal | stop | warm/cold | at first density: RBFs, cold rel_l2, warm/cold |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut fitter = SequenceFitter::new(opts.clone());
    let (mut warm_s, mut rms, mut first_s) = (Vec::new(), Vec::new(), Vec::new());
    let (mut over, mut worst, mut capped, mut moved) = (0, 0.0f64, 0, Vec::new());
    let mut warm_coarse = 0usize;
    let (mut marginal, mut iterations) = (0, 0u64);
    let (mut cold_ratio, mut density_ratio) = (Vec::new(), Vec::new());
    let mut first: Option<(usize, usize)> = None;
    for k in 0..seq.len() {
        let v = seq
            .load(k)
            .unwrap_or_else(|e| fail(format!("frame {k}: {e}")));
        let f = fitter
            .fit(&v)
            .unwrap_or_else(|e| fail(format!("frame {k}: {e}")));
        let g = FitGrid::from_volume(&v).unwrap_or_else(|e| fail(format!("frame {k}: {e}")));
        let support = smoke_support(&g);
        if !f.warm_started {
            first = Some((f.rbfs.len(), support));
        }
        let density = match first {
            Some((n0, s0)) if cold_density > 0 && f.warm_started && k % cold_density == 0 => {
                let n = (n0 as f64 * support as f64 / s0.max(1) as f64).round() as usize;
                let (p, _) = fit_first_frame(&g, n.max(1), &opts.fit);
                let (rel, _) = haze_fit::sequence::errors(&g, &p);
                density_ratio.push(f.rel_l2 / rel);
                format!("{n}, {rel:.4}, {:.3}", f.rel_l2 / rel)
            }
            _ => String::new(),
        };
        let cold = if cold_every > 0 && f.warm_started && k % cold_every == 0 {
            let (p, _) = fit_first_frame(&g, f.rbfs.len(), &opts.fit);
            let (rel, _) = haze_fit::sequence::errors(&g, &p);
            cold_ratio.push(f.rel_l2 / rel);
            format!("{:.3}", f.rel_l2 / rel)
        } else {
            String::new()
        };
        println!(
            "| {} | {} | {} | {} | {:.4} | {:.2} % | {:.3} | {} ({}) | {} | {:.2} | {:.2} | {:.2} ({}) / {:.2} ({}) / {:.2} ({}), {:.2}, {:.2} | {} | {cold} | {density} |",
            seq.frames()[k].number,
            f.rbfs.len(),
            f.inserted,
            f.exchanged,
            f.rel_l2,
            f.rms_over_max * 100.0,
            f.error_ratio,
            f.iterations,
            f.coarse_iterations,
            f.passes,
            f.insert_seconds,
            f.fit_seconds,
            f.split.warm_seconds,
            f.split.warm_passes,
            f.split.insert_seconds,
            f.split.insert_passes,
            f.split.exchange_seconds,
            f.split.exchange_passes,
            f.split.pursuit_seconds,
            f.split.removal_seconds,
            f.insertion_stop.map_or("", |s| s.as_str())
        );
        if f.rbfs.is_empty() {
            continue;
        }
        rms.push(f.rms_over_max);
        if f.warm_started {
            warm_s.push(f.fit_seconds);
            warm_coarse += usize::from(f.coarse_iterations > 0);
        } else {
            first_s.push(f.fit_seconds);
        }
        over += usize::from(f.error_ratio > opts.threshold);
        capped += usize::from(f.insertion_capped);
        marginal += usize::from(f.insertion_stop == Some(InsertionStop::MarginalGain));
        iterations += f.iterations;
        worst = worst.max(f.error_ratio);
        moved.extend(f.mean_center_displacement);
    }
    println!(
        "summary: first frame {:.2} s; warm frames median {:.2} s, max {:.2} s; median rms/max {:.2} %; {over} frames over the threshold ratio ({capped} capped, {marginal} stopped by marginal gain), worst ratio {worst:.3}; mean center displacement {:.4}; {iterations} iterations in all; {warm_coarse} of {} warm frames coarse first",
        first_s.first().copied().unwrap_or(f64::NAN),
        median(warm_s.clone()),
        warm_s.iter().copied().fold(f64::NAN, f64::max),
        median(rms) * 100.0,
        moved.iter().sum::<f64>() / moved.len().max(1) as f64,
        warm_s.len(),
    );
    if !density_ratio.is_empty() {
        println!(
            "warm over cold at the first frame's RBF density: median {:.3}, max {:.3} ({} frames)",
            median(density_ratio.clone()),
            density_ratio.iter().copied().fold(f64::NAN, f64::max),
            density_ratio.len()
        );
    }
    if !cold_ratio.is_empty() {
        println!(
            "warm over cold at the same RBF count: median {:.3}, max {:.3} ({} frames)",
            median(cold_ratio.clone()),
            cold_ratio.iter().copied().fold(f64::NAN, f64::max),
            cold_ratio.len()
        );
    }
}
