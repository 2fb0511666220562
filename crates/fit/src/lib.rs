//! RBF decomposition of smoke density (paper A §5.1): each frame becomes a weighted sum of
//! Gaussian RBFs `B(x) = w·exp(−(|x − c|/r)²)`, cut off at `3r`, fitted by bound-constrained
//! L-BFGS-B with teleportation; sequences are fitted with temporal coherence.

pub mod grid;
pub mod objective;

pub use grid::FitGrid;
pub mod bounds;
pub mod optimize;

pub use bounds::Bounds;
pub use optimize::{Optimizer, Stop, minimize};
pub mod frame;
pub mod init;

pub use frame::{Coarse, FitOptions, FitStats, fit_first_frame};
pub mod exchange;
pub mod local;
pub mod sequence;
pub mod warm;

pub use sequence::{
    Baseline, FitterState, FrameFit, Insertion, InsertionStop, SequenceFitter, SequenceOptions,
};
pub mod search;

pub use search::{PLATEAU_GAIN, Search, rbfs_for_target};
