//! NumPy `.npy` volumes (through npyz).
//!
//! A 3-D array (axes of length 1 before or after the three are dropped: `[1, z, y, x]`,
//! `[z, y, x, 1]`) of any type of [`super::samples`] (`float32`; `float16` and `float64`
//! converted; `uint8` and `uint16` read as fractions of 255 / 65535) in either memory order:
//! a C-order array is indexed `[z, y, x]` and a Fortran-order array `[x, y, z]`, so that in
//! both cases x varies fastest in the file, as in every haze grid. The world box comes from
//! an optional JSON sidecar `NAME.json` (`world_bbox_min`, `world_bbox_max`, and `dims` if
//! given must match); without one the box is `[0, dims]` (unit voxels at the origin).

use super::raw::{read_sidecar, sidecar_path};
use super::samples::{SUPPORTED, SampleType, unorm8, unorm16};
use crate::error::{ImportError, Problem};
use crate::volume::{Bbox, Volume, voxel_count};
use npyz::{DType, NpyFile, Order, TypeChar};
use std::path::Path;

fn fmt_err(path: &Path, why: impl Into<String>) -> ImportError {
    ImportError::new(path, Problem::Format(why.into()))
}

/// Reads a `.npy` volume.
pub fn read(path: &Path) -> Result<Volume, ImportError> {
    let bytes = std::fs::read(path).map_err(|e| ImportError::new(path, e.into()))?;
    haze_core::npy_header::check(&bytes).map_err(|e| fmt_err(path, e))?;
    let npy = NpyFile::new(&bytes[..])
        .map_err(|e| fmt_err(path, format!("not a readable .npy file: {e}")))?;
    let dims = dims_of(path, npy.shape(), npy.order(), true)?;
    let n = voxel_count(dims).ok_or_else(|| fmt_err(path, "shape overflows"))?;
    let descr = npy.dtype().descr();
    let Some(ty) = sample_type(&npy.dtype()) else {
        return Err(fmt_err(
            path,
            format!("dtype {descr} is not supported: use {SUPPORTED}"),
        ));
    };
    let data: Result<Vec<f32>, _> = match ty {
        SampleType::F16 => npy
            .into_vec::<half::f16>()
            .map(|v| v.into_iter().map(f32::from).collect()),
        SampleType::F32 => npy.into_vec::<f32>(),
        SampleType::F64 => npy
            .into_vec::<f64>()
            .map(|v| v.into_iter().map(|x| x as f32).collect()),
        SampleType::U8 => npy
            .into_vec::<u8>()
            .map(|v| v.into_iter().map(unorm8).collect()),
        SampleType::U16 => npy
            .into_vec::<u16>()
            .map(|v| v.into_iter().map(unorm16).collect()),
    };
    let data = data.map_err(|e| fmt_err(path, format!("array data unreadable: {e}")))?;
    if data.len() != n {
        return Err(fmt_err(
            path,
            format!("header promises {n} values but {} were read", data.len()),
        ));
    }
    let bbox = bbox_of(path, dims)?;
    Volume::new(dims, bbox, data).map_err(|e| fmt_err(path, e.to_string()))
}

/// The grid of a `.npy` volume (its dims, x fastest, and world box) from its header and
/// sidecar alone, as [`read`] would give it: a sequence checks every frame's on opening.
pub fn grid(path: &Path) -> Result<([usize; 3], Bbox), ImportError> {
    let file = std::fs::File::open(path).map_err(|e| ImportError::new(path, e.into()))?;
    let npy = NpyFile::new(std::io::BufReader::new(file))
        .map_err(|e| fmt_err(path, format!("not a readable .npy file: {e}")))?;
    let dims = dims_of(path, npy.shape(), npy.order(), false)?;
    Ok((dims, bbox_of(path, dims)?))
}

/// The dims (x fastest) of an array of `shape` in `order` ([`squeeze_to`]); `say` logs
/// the axes of length 1 dropped.
fn dims_of(path: &Path, shape: &[u64], order: Order, say: bool) -> Result<[usize; 3], ImportError> {
    let squeezed = squeeze_to(shape, 3).ok_or_else(|| {
        fmt_err(
            path,
            format!(
                "array has shape {shape:?}; a volume needs 3 dimensions (axes of length 1 before or after them are dropped)"
            ),
        )
    })?;
    if say && squeezed.len() < shape.len() {
        tracing::info!(
            "{}: array of shape {shape:?} read as {squeezed:?} (axes of length 1 dropped)",
            path.display(),
        );
    }
    let s = squeezed.map_or_usize(path)?;
    Ok(match order {
        Order::C => [s[2], s[1], s[0]],
        Order::Fortran => s,
    })
}

/// The world box of a `.npy` volume of `dims`: its sidecar's (whose `dims` must agree), or
/// unit voxels at the origin without one.
fn bbox_of(path: &Path, dims: [usize; 3]) -> Result<Bbox, ImportError> {
    if sidecar_path(path).exists() {
        let sc = read_sidecar(path)?;
        if sc.dims != dims {
            return Err(ImportError::new(
                path,
                Problem::Sidecar {
                    sidecar: sidecar_path(path),
                    why: format!("dims {:?} disagree with the array's {:?}", sc.dims, dims),
                },
            ));
        }
        Ok(Bbox::new(sc.world_bbox_min, sc.world_bbox_max))
    } else {
        tracing::debug!("{}: no sidecar, unit voxels at the origin", path.display());
        Ok(Bbox::new([0.0; 3], dims.map(|d| d.max(1) as f64)))
    }
}

/// The array's `n` data axes: its shape less the axes of length 1 before or after them
/// (a batch or channel axis, `[1, z, y, x]` or `[z, y, x, 1]`; dropping an axis of length
/// 1 leaves the values' order as it is, in either memory order). `None`: fewer than `n`
/// axes, or more than `n` once those are dropped.
pub fn squeeze_to(shape: &[u64], n: usize) -> Option<Vec<u64>> {
    let mut axes = shape;
    while axes.len() > n && axes.first() == Some(&1) {
        axes = &axes[1..];
    }
    while axes.len() > n && axes.last() == Some(&1) {
        axes = &axes[..axes.len() - 1];
    }
    (axes.len() == n).then(|| axes.to_vec())
}

/// The sample type of a NumPy dtype, if supported (also the fogmaps').
pub fn sample_type(dtype: &DType) -> Option<SampleType> {
    match dtype {
        DType::Plain(ts) => match (ts.type_char(), ts.size_field()) {
            (TypeChar::Float, 2) => Some(SampleType::F16),
            (TypeChar::Float, 4) => Some(SampleType::F32),
            (TypeChar::Float, 8) => Some(SampleType::F64),
            (TypeChar::Uint, 1) => Some(SampleType::U8),
            (TypeChar::Uint, 2) => Some(SampleType::U16),
            _ => None,
        },
        _ => None,
    }
}

/// The sample type of a `.npy` file, from its header alone (`None`: not supported).
pub fn samples(path: &Path) -> Result<Option<SampleType>, ImportError> {
    let file = std::fs::File::open(path).map_err(|e| ImportError::new(path, e.into()))?;
    let npy = NpyFile::new(std::io::BufReader::new(file))
        .map_err(|e| fmt_err(path, format!("not a readable .npy file: {e}")))?;
    Ok(sample_type(&npy.dtype()))
}

trait ShapeExt {
    fn map_or_usize(&self, path: &Path) -> Result<[usize; 3], ImportError>;
}

impl ShapeExt for Vec<u64> {
    fn map_or_usize(&self, path: &Path) -> Result<[usize; 3], ImportError> {
        let mut out = [0usize; 3];
        for (o, &v) in out.iter_mut().zip(self) {
            *o = usize::try_from(v).map_err(|_| fmt_err(path, "shape too large"))?;
        }
        Ok(out)
    }
}
