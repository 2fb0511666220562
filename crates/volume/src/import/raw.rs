//! Raw little-endian grids with a JSON sidecar (`NAME.json` beside `NAME.f32`).
//!
//! The sidecar needs `dims` (x, y, z) and the world box `world_bbox_min` /
//! `world_bbox_max`; `voxel_size` is optional and checked when present; `dtype` is
//! optional, `float32` when absent, and may name any type of [`super::samples`]
//! (`uint8` and `uint16` read as fractions of 255 / 65535); any other key is ignored.
//! Samples are x fastest, then y, then z.

use super::samples::{SUPPORTED, SampleType};
use crate::error::{ImportError, Problem};
use crate::volume::{Bbox, Volume, voxel_count};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The keys haze reads from a sidecar.
#[derive(Debug, Deserialize)]
pub struct Sidecar {
    pub dims: [usize; 3],
    pub world_bbox_min: [f64; 3],
    pub world_bbox_max: [f64; 3],
    #[serde(default)]
    pub voxel_size: Option<[f64; 3]>,
    #[serde(default)]
    pub dtype: Option<String>,
}

/// The largest world coordinate of a sidecar's box: positions are `f32` in assets and on
/// the GPU, where 1e9 still resolves 64 units, and RBF radii and weights stay finite.
pub const MAX_COORDINATE: f64 = 1e9;

/// `NAME.json` beside `NAME.f32`.
pub fn sidecar_path(raw: &Path) -> PathBuf {
    raw.with_extension("json")
}

fn sidecar_err(raw: &Path, sidecar: &Path, why: impl Into<String>) -> ImportError {
    ImportError::new(
        raw,
        Problem::Sidecar {
            sidecar: sidecar.to_path_buf(),
            why: why.into(),
        },
    )
}

/// Reads and checks the sidecar of `raw` (dims, ordered finite box, consistent voxel size,
/// supported dtype).
pub fn read_sidecar(raw: &Path) -> Result<Sidecar, ImportError> {
    let sc = sidecar_path(raw);
    let text = std::fs::read_to_string(&sc).map_err(|e| sidecar_err(raw, &sc, e.to_string()))?;
    haze_core::json::unique_keys(&text).map_err(|e| sidecar_err(raw, &sc, e.to_string()))?;
    let s: Sidecar =
        serde_json::from_str(&text).map_err(|e| sidecar_err(raw, &sc, e.to_string()))?;
    if let Some(dt) = &s.dtype
        && SampleType::from_sidecar(dt).is_none()
    {
        return Err(sidecar_err(
            raw,
            &sc,
            format!("dtype '{dt}' is not supported: use little-endian {SUPPORTED}"),
        ));
    }
    let bbox = Bbox::new(s.world_bbox_min, s.world_bbox_max);
    let ordered = (0..3)
        .all(|a| bbox.min[a].is_finite() && bbox.max[a].is_finite() && bbox.max[a] > bbox.min[a]);
    let show = |v: [f64; 3]| format!("({}, {}, {})", v[0], v[1], v[2]);
    if !ordered {
        return Err(sidecar_err(
            raw,
            &sc,
            format!(
                "world box {}..{} is not ordered",
                show(bbox.min),
                show(bbox.max)
            ),
        ));
    }
    let inside = |v: [f64; 3]| v.iter().all(|x| x.abs() <= MAX_COORDINATE);
    if !(inside(bbox.min) && inside(bbox.max)) {
        return Err(sidecar_err(
            raw,
            &sc,
            format!(
                "world box {}..{} must lie within ±{MAX_COORDINATE:e} world units",
                show(bbox.min),
                show(bbox.max)
            ),
        ));
    }
    if let Some(vs) = s.voxel_size {
        let size = bbox.size();
        for a in 0..3 {
            let implied = size[a] / s.dims[a].max(1) as f64;
            if (implied - vs[a]).abs() > 1e-6 * implied.abs().max(vs[a].abs()) {
                return Err(sidecar_err(
                    raw,
                    &sc,
                    format!(
                        "voxel_size {:?} disagrees with the world box and dims (box / dims = {:?})",
                        vs,
                        [0, 1, 2].map(|a| size[a] / s.dims[a].max(1) as f64)
                    ),
                ));
            }
        }
    }
    Ok(s)
}

/// The sample type a checked sidecar names (`float32` when it names none).
pub fn sample_type(sc: &Sidecar) -> SampleType {
    sc.dtype
        .as_deref()
        .and_then(SampleType::from_sidecar)
        .unwrap_or(SampleType::F32)
}

/// Reads a raw volume and its sidecar.
pub fn read(path: &Path) -> Result<Volume, ImportError> {
    let sc = read_sidecar(path)?;
    let ty = sample_type(&sc);
    let n = voxel_count(sc.dims)
        .and_then(|n| n.checked_mul(ty.size()))
        .ok_or_else(|| sidecar_err(path, &sidecar_path(path), "dims overflow"))?;
    let len = std::fs::metadata(path)
        .map_err(|e| ImportError::new(path, e.into()))?
        .len();
    if len != n as u64 {
        return Err(sidecar_err(
            path,
            &sidecar_path(path),
            format!(
                "dims {}×{}×{} need {} bytes of {} but the file has {len} bytes",
                sc.dims[0],
                sc.dims[1],
                sc.dims[2],
                n,
                ty.name()
            ),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| ImportError::new(path, e.into()))?;
    let data = ty.decode_le(&bytes);
    Volume::new(
        sc.dims,
        Bbox::new(sc.world_bbox_min, sc.world_bbox_max),
        data,
    )
    .map_err(|e| ImportError::new(path, Problem::Format(e.to_string())))
}
