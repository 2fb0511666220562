//! The asset's error per frame along a sequence: bakes INPUT (default settings, the
//! residual at `--residual-error`) into a temporary asset, reconstructs every frame from
//! it (RBFs as stored plus the dequantized residual, `reconstruct_frame`) and compares
//! with the input volume itself. Prints per frame the RBF count, the RBFs' own rel_l2 and
//! error ratio, why insertion stopped, the reconstruction's rel_l2 and rms/max (RBF +
//! residual: what a renderer gets), its largest error over the peak and the frame's
//! residual bytes, with the fit's iterations, objective passes and seconds; the bake's
//! warnings (a capped frame among them) go to stderr.
//!
//! cargo run --release -p haze-bake --example total_error -- INPUT [--frames A..B]
//!     [--rbfs N] [--residual-error E] [--polish-iterations N]
//!
//! `--polish-iterations N` sets the first frame's full-resolution polish budget
//! (`FitOptions::polish`); a summary line ends the table.

use haze_bake::{Bake, BakeOptions, Count, reconstruct_frame};
use haze_fit::SequenceOptions;
use haze_hash::QuantOptions;
use haze_volume::ImportOptions;
use haze_volume::import::{FrameRange, Sequence};
use std::path::Path;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(2)
}

fn value<T: std::str::FromStr>(args: &[String], flag: &str) -> Option<T> {
    let i = args.iter().position(|a| a == flag)?;
    Some(
        args.get(i + 1)
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| fail(format!("{flag} needs a valid value"))),
    )
}

fn main() {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn,vdb_rs=error")),
        )
        .init();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(input) = args.first() else {
        fail(
            "usage: total_error INPUT [--frames A..B] [--rbfs N] [--residual-error E] [--polish-iterations N]",
        )
    };
    let range: FrameRange = value(&args, "--frames").unwrap_or_default();
    let quant = QuantOptions {
        error: value(&args, "--residual-error").unwrap_or(QuantOptions::default().error),
        ..QuantOptions::default()
    };
    let mut fit = SequenceOptions::default();
    if let Some(n) = value(&args, "--polish-iterations") {
        fit.fit.polish.max_iterations = n;
    }
    let threshold = fit.threshold;
    let dir = tempfile::tempdir().unwrap_or_else(|e| fail(format!("a temporary folder: {e}")));
    let out = dir.path().join("total_error.haze");
    let options = BakeOptions {
        input: input.into(),
        out: out.clone(),
        range,
        import: ImportOptions::default(),
        count: Count::Fixed(value(&args, "--rbfs").unwrap_or(300)),
        fit,
        quant,
        brick: haze_hash::tile::DEFAULT_BRICK,
        volume_bytes: haze_hash::tile::VOLUME_BYTES,
        resume: false,
        warm_up: 0,
        baseline: None,
        choices: Default::default(),
    };
    let bake = Bake::new(options, |_| {}).unwrap_or_else(|e| fail(format!("{e:#}")));
    let baked = bake.finish().unwrap_or_else(|e| fail(format!("{e:#}")));
    let seq = Sequence::open(Path::new(input), &ImportOptions::default(), range)
        .unwrap_or_else(|e| fail(format!("{input}: {e}")));
    println!(
        "{input}: {} frames, residual error {:.5} of the peak, asset {} bytes, {:.0} s",
        baked.records.len(),
        quant.error,
        baked.bytes,
        baked.seconds
    );
    println!(
        "| frame | RBFs | moved | RBF rel_l2 | RBF rms/max | ratio | stop | capped | iterations | passes | fit s | asset rel_l2 | asset rms/max | asset max/peak | residual bytes |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut worst_asset = 0.0f64;
    for (k, r) in baked.records.iter().enumerate() {
        let v = seq
            .load(k)
            .unwrap_or_else(|e| fail(format!("frame {}: {e}", r.frame)));
        let rec = reconstruct_frame(&out, r.frame).unwrap_or_else(|e| fail(format!("{e:#}")));
        let (mut e2, mut d2, mut worst, mut peak) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (&d, &m) in v.data().iter().zip(&rec.data) {
            let (d, m) = (f64::from(d), f64::from(m));
            e2 += (d - m) * (d - m);
            d2 += d * d;
            worst = worst.max((d - m).abs());
            peak = peak.max(d);
        }
        let n = v.data().len().max(1) as f64;
        let guard = |x: f64, y: f64| if y > 0.0 { x / y } else { 0.0 };
        worst_asset = worst_asset.max(guard(e2, d2).sqrt());
        println!(
            "| {} | {} | {} | {:.4} | {:.2} % | {:.3} | {} | {} | {} | {} | {:.2} | {:.4} | {:.3} % | {:.4} | {:.0} |",
            r.frame,
            r.rbfs,
            r.fit.exchanged,
            r.fit.rel_l2,
            100.0 * r.fit.rms_over_max,
            r.fit.error_ratio,
            r.fit.insertion_stop.map_or("", |s| s.as_str()),
            if r.fit.insertion_capped { "yes" } else { "" },
            r.fit.iterations,
            r.fit.passes,
            r.fit.fit_seconds,
            guard(e2, d2).sqrt(),
            100.0 * guard((e2 / n).sqrt(), peak),
            guard(worst, peak),
            r.residual.hash_bytes
        );
    }
    let warm: Vec<f64> = baked
        .records
        .iter()
        .filter(|r| r.fit.warm_started)
        .map(|r| r.fit.fit_seconds)
        .collect();
    let mut sorted = warm.clone();
    sorted.sort_by(f64::total_cmp);
    let over = baked
        .records
        .iter()
        .filter(|r| r.fit.error_ratio > threshold)
        .count();
    let worst = baked
        .records
        .iter()
        .map(|r| r.fit.error_ratio)
        .fold(0.0, f64::max);
    println!(
        "summary: {over} of {} warm frames over {threshold}, worst ratio {worst:.3}; warm fit median {:.2} s, max {:.2} s; {} iterations; worst asset rel_l2 {worst_asset:.4}",
        warm.len(),
        sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN),
        sorted.last().copied().unwrap_or(f64::NAN),
        baked.records.iter().map(|r| r.fit.iterations).sum::<u64>(),
    );
    println!("temporal: {}", baked.temporal);
}
