//! Render jobs with typed options, one call each: a smoke frame ([`smoke::render`]), a
//! scene file ([`scene::render_scene`]), a wavelet fog with or without a smoke asset in it
//! ([`fog::wavelet`]); and what they share — the frame a render starts from
//! ([`frame`]), the lights ([`lights`]), files written atomically ([`output`]) and
//! progress bars ([`progress`]).
//!
//! * [`frame`]: an asset's frame (read by `haze_bake::export`) or a volume, fitted here.
//! * [`lights`]: the environment, suns and point lights.
//! * [`smoke`]: compensated ray marching (CPU or GPU) or the reference renderer.
//! * [`bench`](mod@bench): the GPU renderer timed on fixed synthetic workloads (`haze bench`).
//! * [`check`]: a render's estimate of its own error against the reference.
//! * [`scene`]: scene files (papers B, C, D, and the march).
//! * [`fog`]: the wavelet fog (paper E); [`fog_smoke`] places a smoke frame in it.

pub mod bench;
pub mod check;
pub mod fog;
pub mod fog_smoke;
pub mod frame;
pub mod lights;
pub mod map_report;
pub mod output;
pub mod progress;
pub mod scene;
pub mod smoke;
