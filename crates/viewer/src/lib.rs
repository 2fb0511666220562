//! The viewer window (`haze view`): one [`shell`] runs the window's frame loop (the
//! controls panel beside the picture) for whichever room is shown; each mode is a room in
//! its own folder, holding its camera, tools and renderer.
//!
//! - [`smoke`]: a baked asset played and lit as it plays (paper A), with its player,
//!   playback clock, render thread and the knobs chosen for a budget;
//! - [`scene`]: a scene file (papers B, C, D) with its editing tools and wind panel;
//! - [`fog`]: a fogmap's wavelet fog (paper E) with its fly camera;
//! - [`shell`]: the one window and the [`shell::Room`] every mode implements;
//! - [`orbit`]: the orbit camera of the smoke and scene rooms.
//!
//! Every room also runs without a window (`--play-for S --no-window`), printing the same
//! measurement line.

pub mod fog;
mod orbit;
pub mod scene;
mod shell;
pub mod smoke;
