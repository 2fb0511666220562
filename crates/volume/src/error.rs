//! Import errors: every one names the file and says what is wrong with it, on one line.

use std::fmt;
use std::path::{Path, PathBuf};

/// An input file that could not be imported, and why.
#[derive(Debug)]
pub struct ImportError {
    pub path: PathBuf,
    pub problem: Problem,
}

impl ImportError {
    pub fn new(path: impl AsRef<Path>, problem: Problem) -> Self {
        Self {
            path: path.as_ref().to_path_buf(),
            problem,
        }
    }
}

impl fmt::Display for ImportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.problem)
    }
}

/// The message already includes the underlying cause, so no `source` is chained (error
/// reports stay one line).
impl std::error::Error for ImportError {}

/// The grids a file holds, for an error that did not find the one asked for.
fn grid_choice(available: &[String]) -> String {
    if available.is_empty() {
        "the file holds no grids".to_string()
    } else {
        format!(
            "grids in the file: {}; --grid chooses one",
            available.join(", ")
        )
    }
}

/// What is wrong with an input file.
#[derive(Debug, thiserror::Error)]
pub enum Problem {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("not a readable OpenVDB file: {0}")]
    Vdb(String),
    #[error("no grid named '{name}' ({})", grid_choice(available))]
    MissingGrid {
        name: String,
        available: Vec<String>,
    },
    #[error("grid '{name}' is unsupported: {why}")]
    UnsupportedGrid { name: String, why: String },
    #[error(
        "voxel ({}, {}, {}) centred at world ({}, {}, {}) is {value}: {rule}",
        voxel[0], voxel[1], voxel[2], at[0], at[1], at[2]
    )]
    BadVoxel {
        voxel: [usize; 3],
        /// The voxel's centre in world space (inside the voxel whichever point of it the
        /// file's transform maps the index to).
        at: [f32; 3],
        value: f32,
        /// The rule the value breaks, and what to do.
        rule: &'static str,
    },
    #[error("sidecar {sidecar}: {why}")]
    Sidecar { sidecar: PathBuf, why: String },
    #[error("{0}")]
    Format(String),
    #[error("dense box of {dims:?} voxels is too large ({voxels} voxels, the limit is {limit})")]
    TooLarge {
        dims: [usize; 3],
        voxels: u128,
        limit: u64,
    },
    #[error("{0}")]
    Sequence(String),
}
