//! `haze bench`: the GPU renderer timed on fixed synthetic workloads
//! (`haze_render::bench`), a table on stdout and optionally JSON.

use crate::light_args::LightingArg;
use anyhow::Result;
use haze_render::bench;
use haze_render::output::{self, Outputs};
use haze_render::progress;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct BenchCli {
    /// One small workload (100 RBFs, a 48-class grid, 320 × 240, SH 2): checks that the
    /// command and the adapter work, in seconds.
    #[arg(long, conflicts_with = "full")]
    quick: bool,
    /// The full set even on a CPU adapter (lavapipe), whose default is the set scaled
    /// down (grids and picture sides halved): many minutes there, and workloads whose
    /// buffers exceed the device's are skipped.
    #[arg(long)]
    full: bool,
    /// Frames of each kind per workload, medians reported [default: 3, 1 on a CPU
    /// adapter such as lavapipe].
    #[arg(long, value_name = "N")]
    repeat: Option<usize>,
    /// Where single scattering and the diffusion run.
    #[arg(long, value_enum, default_value_t = LightingArg::Auto)]
    lighting: LightingArg,
    /// Also write the figures (every pass's GPU time) as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// `haze bench`.
pub fn run(b: BenchCli) -> Result<()> {
    if let Some(json) = &b.json {
        Outputs::new().output("--json", json).check()?;
    }
    let set = if b.quick {
        bench::Set::Quick
    } else if b.full {
        bench::Set::Full
    } else {
        bench::Set::Auto
    };
    let bar = progress::settings_bar();
    let report = bench::run(set, b.repeat, b.lighting.into(), &mut |done, total, w| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        bar.set_message(format!(
            "{} RBFs, {}-class grid, {} × {}",
            w.rbfs, w.grid, w.width, w.height
        ));
    });
    bar.finish_and_clear();
    let report = report?;
    print!("{}", report.table());
    if let Some(json) = &b.json {
        output::write_json(json, &serde_json::to_value(&report)?)?;
    }
    Ok(())
}
