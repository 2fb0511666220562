//! `haze fog`: fogmaps fitted and pictured; its flags and their conversion into
//! `haze_render::fog`'s options are in [`args`].

mod args;

pub use args::*;

use anyhow::Result;
use haze_render::fog::WaveletJob;

pub fn run(cmd: FogCommand) -> Result<()> {
    match cmd {
        FogCommand::Wavelet(a) => haze_render::fog::wavelet(WaveletJob {
            fogmap: a.fogmap,
            model: a.model.into(),
            smoke: a.smoke.into(),
            out: a.out,
            direct: a.direct,
            gpu: a.gpu,
            width: a.width,
            height: a.height,
            eye: a.eye,
            target: a.target,
            up: a.up,
            fov: a.fov,
            time: a.time,
            frames: a.frames,
            fps: a.fps,
        }),
    }
}
