//! `haze merge`: chunks baked separately joined in frame order (`haze_bake::merge`).

use anyhow::Result;
use haze_render::output::Outputs;
use std::path::{Path, PathBuf};

pub fn run(chunks: &[PathBuf], out: &Path) -> Result<()> {
    chunks
        .iter()
        .fold(Outputs::new(), |o, c| o.input(c))
        .asset("--out", out)
        .check()?;
    let m = haze_bake::merge(chunks, out)?;
    let n = &m.frames;
    haze_render::say!(
        "{}: {} ({}..{}) from {}",
        out.display(),
        haze_bake::inspect::count(n.len(), "frame"),
        n[0],
        n[n.len() - 1],
        haze_bake::inspect::count(m.chunks, "chunk")
    );
    Ok(())
}
