//! NumPy `.npy` volumes (through npyz).
//!
//! A 3-D array of `float32` (or `float64`, converted) in either memory order:
//! a C-order array is indexed `[z, y, x]` and a Fortran-order array `[x, y, z]`, so that in
//! both cases x varies fastest in the file, as in every haze grid. The world box comes from
//! an optional JSON sidecar `NAME.json` (`world_bbox_min`, `world_bbox_max`, and `dims` if
//! given must match); without one the box is `[0, dims]` (unit voxels at the origin).

use super::raw::{read_sidecar, sidecar_path};
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
    let shape = npy.shape().to_vec();
    if shape.len() != 3 {
        return Err(fmt_err(
            path,
            format!("array has shape {shape:?}; a volume needs 3 dimensions"),
        ));
    }
    let s = shape.map_or_usize(path)?;
    let dims = match npy.order() {
        Order::C => [s[2], s[1], s[0]],
        Order::Fortran => s,
    };
    let n = voxel_count(dims).ok_or_else(|| fmt_err(path, "shape overflows"))?;
    let (kind, size) = match npy.dtype() {
        DType::Plain(ts) => (ts.type_char(), ts.size_field()),
        other => {
            return Err(fmt_err(
                path,
                format!("dtype {} is not a float array", other.descr()),
            ));
        }
    };
    let data: Vec<f32> = match (kind, size) {
        (TypeChar::Float, 4) => npy.into_vec::<f32>(),
        (TypeChar::Float, 8) => npy
            .into_vec::<f64>()
            .map(|v| v.into_iter().map(|x| x as f32).collect()),
        _ => {
            return Err(fmt_err(
                path,
                format!("dtype {kind:?}{size} is not supported (float32 or float64)"),
            ));
        }
    }
    .map_err(|e| fmt_err(path, format!("array data unreadable: {e}")))?;
    if data.len() != n {
        return Err(fmt_err(
            path,
            format!("header promises {n} values but {} were read", data.len()),
        ));
    }
    let bbox = if sidecar_path(path).exists() {
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
        Bbox::new(sc.world_bbox_min, sc.world_bbox_max)
    } else {
        tracing::debug!("{}: no sidecar, unit voxels at the origin", path.display());
        Bbox::new([0.0; 3], dims.map(|d| d.max(1) as f64))
    };
    Volume::new(dims, bbox, data).map_err(|e| fmt_err(path, e.to_string()))
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
