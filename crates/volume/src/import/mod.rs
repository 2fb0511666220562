//! Bringing density volumes in: single files of any supported format, numbered sequences
//! of them, and the validation every imported frame passes.

pub mod adaptive_domain;
mod guard;
pub mod npy;
pub mod raw;
pub mod samples;
pub mod sequence;
pub mod vdb;

pub use sequence::{FrameFile, FrameRange, Sequence};

use crate::error::{ImportError, Problem};
use crate::volume::Volume;
use std::path::Path;

/// File formats haze imports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// OpenVDB (`.vdb`).
    Vdb,
    /// Raw little-endian samples (`float32` unless the sidecar says otherwise) with a JSON
    /// sidecar (`.f32`, `.raw`).
    Raw,
    /// NumPy (`.npy`).
    Npy,
}

impl Format {
    /// The format of a file, by its extension.
    pub fn of(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "vdb" => Some(Format::Vdb),
            "f32" | "raw" => Some(Format::Raw),
            "npy" => Some(Format::Npy),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Format::Vdb => "vdb",
            Format::Raw => "raw",
            Format::Npy => "npy",
        }
    }
}

/// How to import.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ImportOptions {
    /// Grid to read from VDB files.
    pub grid: String,
    /// Clamp negative densities to zero instead of refusing them.
    pub clamp_negative: bool,
    /// Added to the world coordinates of VDB grids (their transforms are often local to
    /// the simulation domain, as Blender's are).
    pub domain_offset: [f64; 3],
    /// Where a VDB grid's transform puts a voxel's index, over what the file says
    /// ([`vdb::VdbGridInfo::index_at`]); `None` takes the file's.
    #[serde(default)]
    pub vdb_index: Option<IndexAt>,
}

/// The point of a voxel that an OpenVDB grid's transform maps the voxel's index to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum IndexAt {
    /// OpenVDB's own convention (Houdini, EmberGen, haze's exports): voxel `i` is centred
    /// on `T(i)` and spans `T(i ± ½)`.
    Centre,
    /// Blender's fluid caches: voxel `i` spans `T(i)..T(i + 1)` (Mantaflow's cell `i` of a
    /// domain whose local origin is its min corner).
    Corner,
}

impl IndexAt {
    /// Voxel `i`'s min corner, in voxels from `T(i)`: `−½` for a centred index.
    pub fn corner_offset(self) -> f64 {
        match self {
            IndexAt::Centre => -0.5,
            IndexAt::Corner => 0.0,
        }
    }

    /// The name `--vdb-index` takes and `inspect` shows.
    pub fn name(self) -> &'static str {
        match self {
            IndexAt::Centre => "centre",
            IndexAt::Corner => "corner",
        }
    }
}

impl std::fmt::Display for IndexAt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for IndexAt {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "centre" | "center" => Ok(IndexAt::Centre),
            "corner" => Ok(IndexAt::Corner),
            _ => Err(format!(
                "'{s}': expected centre (OpenVDB's convention) or corner (Blender's fluid caches)"
            )),
        }
    }
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            grid: "density".to_string(),
            clamp_negative: false,
            domain_offset: [0.0; 3],
            vdb_index: None,
        }
    }
}

/// Imports and validates one file. VDB grids are read into their default box (see
/// [`vdb`]).
pub fn import(path: &Path, opts: &ImportOptions) -> Result<Volume, ImportError> {
    let mut v = read_unchecked(path, opts, None)?;
    validate(path, &mut v, opts.clamp_negative)?;
    Ok(v)
}

/// The sample type of a raw or NumPy volume file (`None` for OpenVDB, whose grids say
/// their own type, and for a type the import refuses).
pub fn samples_of(path: &Path) -> Result<Option<samples::SampleType>, ImportError> {
    match format_of(path)? {
        Format::Vdb => Ok(None),
        Format::Raw => Ok(Some(raw::sample_type(&raw::read_sidecar(path)?))),
        Format::Npy => npy::samples(path),
    }
}

/// The format of `path`, or an error naming the supported extensions (or, for a volume
/// format haze does not read, how to get one it does: [`foreign_format`]).
pub fn format_of(path: &Path) -> Result<Format, ImportError> {
    Format::of(path).ok_or_else(|| {
        let why = match foreign_format(path) {
            Some((kind, how)) => format!("unknown file type: {kind}; haze reads OpenVDB: {how}"),
            None => "unknown file type (expected .vdb, .f32/.raw with a .json sidecar, or .npy)"
                .to_string(),
        };
        ImportError::new(path, Problem::Format(why))
    })
}

/// For a file of a volume format that haze does not read but the tools it takes smoke
/// from write (NanoVDB, Mantaflow's own cache, Houdini geometry): what it is, and how to
/// get OpenVDB from it; `None` for any other file.
pub fn foreign_format(path: &Path) -> Option<(&'static str, &'static str)> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    if name.ends_with(".nvdb") {
        Some((
            "NanoVDB",
            "convert it with OpenVDB's nanovdb_convert (nanovdb_convert FILE.nvdb FILE.vdb)",
        ))
    } else if name.ends_with(".uni") {
        Some((
            "Mantaflow's .uni cache",
            "set the Blender domain's Cache > Format Volumes to OpenVDB and bake it again",
        ))
    } else if [".bgeo", ".bgeo.sc", ".bgeo.gz", ".geo"]
        .iter()
        .any(|e| name.ends_with(e))
    {
        Some((
            "Houdini geometry",
            "convert the volume to VDB (Convert VDB) and write it to a .vdb file",
        ))
    } else {
        None
    }
}

/// Reads without validation; `vdb_box` imposes the dense box of VDB grids.
pub(crate) fn read_unchecked(
    path: &Path,
    opts: &ImportOptions,
    vdb_box: Option<vdb::IndexBox>,
) -> Result<Volume, ImportError> {
    let format = format_of(path)?;
    match format {
        Format::Npy => vdb_options_refused(path, VdbOptionsOf::Npy, opts)?,
        Format::Raw => vdb_options_refused(path, VdbOptionsOf::Raw, opts)?,
        Format::Vdb => {}
    }
    match format {
        Format::Vdb => Ok(vdb::read(path, opts, vdb_box)?.volume),
        Format::Raw => raw::read(path),
        Format::Npy => npy::read(path),
    }
}

/// What, other than an OpenVDB file, a grid or a domain offset may be asked of.
#[derive(Clone, Copy, Debug)]
pub enum VdbOptionsOf {
    Npy,
    Raw,
    /// A `.haze` asset, whose frames were read from their grid when baked or packed.
    Asset,
}

/// A grid other than `density`, or a domain offset, asked of a raw or NumPy volume (one
/// array, placed by its own box) or of an asset (placed as it was baked): refused rather
/// than ignored.
pub fn vdb_options_refused(
    path: &Path,
    of: VdbOptionsOf,
    opts: &ImportOptions,
) -> Result<(), ImportError> {
    let (what, one_array, own_box) = match of {
        VdbOptionsOf::Npy => (
            "a NumPy volume",
            "which holds one array",
            "placed by its own box",
        ),
        VdbOptionsOf::Raw => (
            "a raw volume",
            "which holds one array",
            "placed by its own box",
        ),
        VdbOptionsOf::Asset => (
            "a .haze asset",
            "whose frames were read from their grid when it was made",
            "placed as it was made",
        ),
    };
    let defaults = ImportOptions::default();
    let why = if opts.grid != defaults.grid {
        format!(
            "grid '{}' asked of {what}, {one_array} (grids are OpenVDB's)",
            opts.grid
        )
    } else if opts.domain_offset != defaults.domain_offset {
        format!(
            "a domain offset asked of {what}, which is {own_box} (the offset is for OpenVDB grids)"
        )
    } else if let Some(at) = opts.vdb_index {
        format!(
            "a VDB index convention ({at}) asked of {what}, which is {own_box} (it is for OpenVDB grids)"
        )
    } else {
        return Ok(());
    };
    Err(ImportError::new(path, Problem::Format(why)))
}

/// World position of voxel `i`'s centre (as `f32`: an error message's precision): inside
/// the voxel whichever point its file's transform maps the index to.
fn centre(v: &Volume, i: usize) -> [f32; 3] {
    let (b, d, c) = (v.bbox(), v.dims(), v.coords(i));
    std::array::from_fn(|a| {
        (b.min[a] + (c[a] as f64 + 0.5) * (b.max[a] - b.min[a]) / d[a].max(1) as f64) as f32
    })
}

/// Rejects NaN and ±Inf (naming the first voxel and where it is), and negative densities unless
/// `clamp_negative`, in which case they become 0. Returns how many voxels were clamped.
pub fn validate(path: &Path, v: &mut Volume, clamp_negative: bool) -> Result<usize, ImportError> {
    let mut clamped = 0;
    let mut first_negative = None;
    for (i, d) in v.data().iter().enumerate() {
        if !d.is_finite() {
            return Err(ImportError::new(
                path,
                Problem::BadVoxel {
                    voxel: v.coords(i),
                    at: centre(v, i),
                    value: *d,
                    rule: "densities must be finite",
                },
            ));
        }
        if *d < 0.0 && first_negative.is_none() {
            first_negative = Some(i);
        }
    }
    if let Some(i) = first_negative {
        if !clamp_negative {
            return Err(ImportError::new(
                path,
                Problem::BadVoxel {
                    voxel: v.coords(i),
                    at: centre(v, i),
                    value: v.data()[i],
                    rule: "densities must not be negative (pass --clamp-negative to clamp them to 0)",
                },
            ));
        }
        for d in v.data_mut() {
            if *d < 0.0 {
                *d = 0.0;
                clamped += 1;
            }
        }
        tracing::warn!("{}: clamped {clamped} negative voxels to 0", path.display());
    }
    Ok(clamped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::Bbox;

    fn vol(data: Vec<f32>) -> Volume {
        Volume::new([2, 2, 1], Bbox::new([0.0; 3], [1.0; 3]), data).unwrap()
    }

    #[test]
    fn validation_rejects_non_finite_with_the_voxel() {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut v = vol(vec![0.0, 0.0, bad, 1.0]);
            let e = validate(Path::new("x.f32"), &mut v, true).unwrap_err();
            let msg = e.to_string();
            assert!(
                msg.starts_with("x.f32: voxel (0, 1, 0) centred at world (0.25, 0.75, 0.5) is "),
                "{msg}"
            );
        }
    }

    #[test]
    fn validation_of_negatives() {
        let mut v = vol(vec![0.5, -0.25, -0.0, -1.0]);
        let e = validate(Path::new("n.npy"), &mut v, false).unwrap_err();
        // Voxel (1, 0, 0) of 2 × 2 × 1 over the unit cube: centred at (3/4, 1/4, 1/2).
        assert!(
            e.to_string()
                .contains("voxel (1, 0, 0) centred at world (0.75, 0.25, 0.5) is -0.25"),
            "{e}"
        );
        assert_eq!(validate(Path::new("n.npy"), &mut v, true).unwrap(), 2);
        assert_eq!(v.data(), &[0.5, 0.0, -0.0, 0.0]);
        let mut empty = Volume::zeros([0, 0, 0], Bbox::new([0.0; 3], [1.0; 3])).unwrap();
        assert_eq!(validate(Path::new("e"), &mut empty, false).unwrap(), 0);
    }

    #[test]
    fn formats_by_extension() {
        assert_eq!(Format::of(Path::new("a/fluid_0001.VDB")), Some(Format::Vdb));
        assert_eq!(Format::of(Path::new("d.f32")), Some(Format::Raw));
        assert_eq!(Format::of(Path::new("d.npy")), Some(Format::Npy));
        assert_eq!(Format::of(Path::new("d.json")), None);
        assert!(format_of(Path::new("d.txt")).is_err());
    }
}
