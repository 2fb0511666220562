//! Command-line interface: arguments and dispatch.

use crate::import_args::ImportArgs;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// haze: smoke and fog toolkit.
///
/// Reads smoke simulations (OpenVDB from Blender, Houdini or EmberGen; raw f32 grids with a
/// JSON sidecar; NumPy .npy), single frames or numbered sequences, and packs them into
/// streamable .haze assets.
#[derive(Debug, Parser)]
#[command(name = "haze", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// More log output (-v info, -vv debug, -vvv trace); RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Only errors.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Describe a volume file, a frame sequence or a .haze asset.
    ///
    /// PATH may be a .vdb, .f32/.raw (with its .json sidecar) or .npy file; a directory or
    /// a quoted glob of numbered frames ("cache/fluid_data_*.vdb"); or a .haze asset.
    /// Reports dims, world box, voxel size, the grids in a VDB file, frame count and gaps,
    /// value range, active (non-zero) voxels and memory. For an asset, every block's
    /// checksum is verified.
    Inspect {
        /// File, directory, glob, or .haze asset.
        path: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Frame range of a sequence to inspect, inclusive: A..B, A.., ..B or A.
        #[arg(long, value_name = "A..B")]
        frames: Option<haze_volume::import::FrameRange>,
        #[command(flatten)]
        import: ImportArgs,
    },
    /// Pack volumes losslessly into a .haze asset (one raw-volume block per frame).
    ///
    /// The reference asset of a sequence: no fitting, no compression. The asset is written
    /// to a temporary file beside OUT and renamed when complete.
    Pack {
        /// File, directory or glob of numbered frames.
        input: PathBuf,
        /// The .haze file to write.
        #[arg(long, short)]
        out: PathBuf,
        /// Frame range to pack, inclusive: A..B, A.., ..B or A.
        #[arg(long, value_name = "A..B")]
        frames: Option<haze_volume::import::FrameRange>,
        #[command(flatten)]
        import: ImportArgs,
    },
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Inspect {
            path,
            json,
            frames,
            import,
        } => crate::inspect::run(&path, json, frames.unwrap_or_default(), &import.options()),
        Command::Pack {
            input,
            out,
            frames,
            import,
        } => crate::pack::run(&input, &out, frames.unwrap_or_default(), &import.options()),
    }
}
