//! `haze bake`: the bake with progress bars, a summary line and the report; its flags
//! and their conversion into `haze_bake`'s options are in [`args`].

mod args;

pub use args::*;

use anyhow::Result;
use haze_bake::{Bake, Baked, Event};
use haze_render::output::{self, Outputs};
use haze_render::progress;
use std::sync::{Arc, Mutex};

/// `haze bake`.
pub fn run(cli: BakeCli) -> Result<()> {
    let mut files = Outputs::new()
        .input(&cli.input)
        .asset("--out", &cli.out)
        .output("the bake journal", &haze_bake::journal::path_for(&cli.out));
    if let Some(report) = &cli.report {
        files = files.output("--report", report);
    }
    if let Some(tradeoff) = &cli.tradeoff {
        files = files.input(tradeoff);
    }
    files.check()?;
    bake(cli.into_args()?)
}

fn bake(args: BakeArgs) -> Result<()> {
    let input = args.options.input.clone();
    let out = args.options.out.clone();
    // The bar exists once the frame count is known; events before it use a spinner.
    let bar: Arc<Mutex<Option<indicatif::ProgressBar>>> = Arc::default();
    let spinner: Arc<Mutex<Option<indicatif::ProgressBar>>> = Arc::default();
    let (bar_e, spinner_e, out_e) = (bar.clone(), spinner.clone(), out.clone());
    let events = move |e: Event<'_>| match e {
        Event::Resumed { finished, total } => haze_render::say!(
            "{}: resuming after {} of {total}",
            out_e.display(),
            haze_bake::inspect::count(finished, "finished frame"),
        ),
        Event::Searching { frame, target } => {
            *spinner_e.lock().unwrap_or_else(|p| p.into_inner()) = Some(progress::spinner(
                &format!("choosing the RBF count for rel_l2 ≤ {target} on frame {frame}"),
            ));
        }
        Event::Searched(_) => {
            if let Some(s) = spinner_e.lock().unwrap_or_else(|p| p.into_inner()).take() {
                s.finish_and_clear();
            }
        }
        Event::Fitting { frame, .. } => {
            if let Some(s) = spinner_e.lock().unwrap_or_else(|p| p.into_inner()).take() {
                s.finish_and_clear();
            }
            if let Some(b) = bar_e.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
                b.set_message(format!("frame {frame}"));
            }
        }
        Event::WarmingUp { frame } => {
            *spinner_e.lock().unwrap_or_else(|p| p.into_inner()) = Some(progress::spinner(
                &format!("warming up on frame {frame} (fitted, not kept)"),
            ));
        }
        Event::Hashing => {
            if let Some(b) = bar_e.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
                b.set_message("hashing");
            }
        }
    };
    let grid = args.options.import.clone();
    let mut bake = Bake::new(args.options, events)?;
    let grid = bake.sequence().grid_name(&grid);
    let b = progress::frames(bake.sequence().len(), "fitting");
    b.set_position(bake.finished() as u64);
    *bar.lock().unwrap_or_else(|p| p.into_inner()) = Some(b.clone());
    let mut failed = None;
    for frame in bake.by_ref() {
        match frame {
            Ok(_) => b.inc(1),
            Err(e) => {
                failed = Some(e);
                break;
            }
        }
    }
    if let Some(e) = failed {
        b.finish_and_clear();
        return Err(bake.abandon(e));
    }
    b.finish_and_clear();
    let baked = bake.finish()?;
    haze_render::say!("{}", summary_line(&baked));
    let records = &baked.records;
    if !records.is_empty() && records.iter().all(|r| r.rbfs == 0) {
        tracing::warn!("{}", haze_bake::inspect::all_zero_warning(&input, &grid));
    }
    if let Some(path) = &args.report {
        output::write_json(path, &baked.report(&input))?;
    }
    Ok(())
}

fn summary_line(b: &Baked) -> String {
    let records = &b.records;
    let n = records.len().max(1) as f64;
    let mean = |f: fn(&haze_bake::FrameRecord) -> f64| records.iter().map(f).sum::<f64>() / n;
    let met = records
        .iter()
        .filter(|r| r.residual.rbfs_meet_error)
        .count();
    format!(
        "{}: {}, {:.0} RBFs/frame, mean rel_l2 {:.4}, mean rms/max {:.4}, residual {}/frame ({} met by the RBFs alone), {}, {:.1} s{}{}{}",
        b.out.display(),
        haze_bake::inspect::count(records.len(), "frame"),
        mean(|r| r.rbfs as f64),
        mean(|r| r.fit.rel_l2),
        mean(|r| r.fit.rms_over_max),
        haze_bake::inspect::bytes(mean(|r| r.residual.hash_bytes) as u64),
        met,
        haze_bake::inspect::bytes(b.bytes),
        b.seconds,
        haze_bake::inspect::all_zero_clause(records.iter().filter(|r| r.rbfs == 0).count()),
        coarse_first(records),
        over_threshold(records)
    )
}

/// The warm frames whose minimizations walked on the half-resolution grid first
/// (`--warm-coarse`: wide RBFs on a large grid), in one clause for the summary line;
/// empty when none did.
fn coarse_first(records: &[haze_bake::FrameRecord]) -> String {
    let warm = records.iter().filter(|r| r.fit.warm_started).count();
    let coarse = records
        .iter()
        .filter(|r| r.fit.warm_started && r.fit.coarse_iterations > 0)
        .count();
    if coarse == 0 {
        return String::new();
    }
    format!("; {coarse} of {warm} warm frames minimized on the half-resolution grid first")
}

/// The frames whose RBFs ended over the threshold ratio (each one logged at `-v`), in one clause
/// for the summary line: how many, the worst ratio, how many at the `--max-rbfs` ceiling;
/// empty when every frame held its ratio.
fn over_threshold(records: &[haze_bake::FrameRecord]) -> String {
    let over: Vec<_> = records
        .iter()
        .filter(|r| r.fit.insertion_capped || r.fit.insertion_stalled)
        .collect();
    if over.is_empty() {
        return String::new();
    }
    let worst = over.iter().map(|r| r.fit.error_ratio).fold(0.0, f64::max);
    let ceiling = over
        .iter()
        .filter(|r| r.fit.insertion_stop == Some(haze_fit::InsertionStop::Ceiling))
        .count();
    format!(
        "; {} over the threshold ratio (worst {worst:.3}; {ceiling} at the --max-rbfs ceiling): the residual holds their error",
        haze_bake::inspect::count(over.len(), "frame")
    )
}
