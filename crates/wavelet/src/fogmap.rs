//! Fogmaps: the finest-level scaling coefficients of a fog (paper E §4.1, figure 3).
//!
//! Inputs, chosen by extension:
//!
//! * `.png`: 8- or 16-bit greyscale, values scaled to `[0, 1]` (`v/255`, `v/65535`). An RGB
//!   or RGBA image is accepted only if every pixel is grey (`R = G = B`, alpha opaque);
//!   greyscale with alpha is refused (alpha has no meaning in a fogmap).
//! * `.exr`: the first layer's `Y` channel, or its only channel, or `R` when `R = G = B`
//!   everywhere; values as stored (linear extinction coefficients).
//! * `.npy`: a 2-D array, C order `[row, column]` or Fortran order, of float16, float32
//!   or float64, or of uint8 or uint16 scaled to `[0, 1]` as a PNG's are
//!   ([`haze_volume::import::samples`]).
//! * `.f32`: raw little-endian samples, rows of `width` values, with a JSON sidecar
//!   `NAME.json` holding `"dims": [width, height]` and optionally `"dtype"` (float32 when
//!   absent; the types and names of a raw volume's sidecar).
//!
//! In every format row 0 is the map's north (top) edge, as an image is shown: pixel
//! `(column i, row r)` becomes coefficient `(i, height − 1 − r)`, so `+y` is north. Values
//! must be finite and non-negative (extinction cannot be negative); an empty map is
//! refused. Every error names the file and the problem on one line.

use crate::mallat::Grid;
use haze_volume::import::samples::{SUPPORTED, SampleType};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Largest fogmap accepted, in pixels (a 8192 × 8192 map).
pub const MAX_PIXELS: usize = 1 << 26;

/// A fogmap that could not be read.
#[derive(Debug, Error)]
#[error("{}: {problem}", path.display())]
pub struct FogmapError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong, one line.
    pub problem: String,
}

/// A fogmap: `width × height` coefficients, x fastest, row 0 at the south edge.
#[derive(Clone, Debug, PartialEq)]
pub struct Fogmap {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Coefficients, x fastest, `values[j·width + i]` with `j = 0` the south row.
    pub values: Vec<f64>,
}

impl Fogmap {
    /// Builds a fogmap from rows listed top (north) first, validating the values;
    /// `source` names the data in errors.
    pub fn from_top_down(
        source: &Path,
        width: usize,
        height: usize,
        top_down: &[f64],
    ) -> Result<Fogmap, FogmapError> {
        let err = |problem: String| FogmapError {
            path: source.to_path_buf(),
            problem,
        };
        if width == 0 || height == 0 {
            return Err(err(format!("empty fogmap ({width} × {height} pixels)")));
        }
        if width.checked_mul(height).is_none_or(|n| n > MAX_PIXELS) {
            return Err(err(format!(
                "{width} × {height} pixels is more than the {MAX_PIXELS} a fogmap may have"
            )));
        }
        if top_down.len() != width * height {
            return Err(err(format!(
                "{} values for {width} × {height} pixels",
                top_down.len()
            )));
        }
        for (k, &v) in top_down.iter().enumerate() {
            if !v.is_finite() || v < 0.0 {
                let why = if v.is_finite() {
                    "negative; extinction cannot be negative"
                } else {
                    "not a finite number"
                };
                return Err(err(format!(
                    "pixel (column {}, row {}) is {v}: {why}",
                    k % width,
                    k / width
                )));
            }
        }
        let mut values = Vec::with_capacity(width * height);
        for r in (0..height).rev() {
            values.extend_from_slice(&top_down[r * width..(r + 1) * width]);
        }
        Ok(Fogmap {
            width,
            height,
            values,
        })
    }

    /// Reads a fogmap file (module docs for the formats).
    pub fn load(path: &Path) -> Result<Fogmap, FogmapError> {
        let err = |problem: String| FogmapError {
            path: path.to_path_buf(),
            problem,
        };
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let (w, h, values) = match ext.as_str() {
            "png" => read_png(path).map_err(err)?,
            "exr" => read_exr(path).map_err(err)?,
            "npy" => read_npy(path).map_err(err)?,
            "f32" => read_raw(path).map_err(err)?,
            _ => {
                return Err(err(
                    "unknown fogmap format: expected .png, .exr, .npy or .f32 (with a .json sidecar)"
                        .to_string(),
                ));
            }
        };
        Fogmap::from_top_down(path, w, h, &values)
    }

    /// The coefficients as a grid over `[0, width) × [0, height)`.
    pub fn grid(&self) -> Grid {
        Grid {
            x0: 0,
            y0: 0,
            nx: self.width,
            ny: self.height,
            data: self.values.clone(),
        }
    }
}

type Pixels = (usize, usize, Vec<f64>);

fn read_png(path: &Path) -> Result<Pixels, String> {
    use image::DynamicImage as D;
    let img = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open: {e}"))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))?
        .decode()
        .map_err(|e| format!("not a readable PNG image: {e}"))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let grey = |px: &[f64], channels: usize, alpha: bool, max: f64| -> Result<Vec<f64>, String> {
        let mut out = Vec::with_capacity(w * h);
        for (k, p) in px.chunks_exact(channels).enumerate() {
            if p[1] != p[0] || p[2] != p[0] || (alpha && p[3] != max) {
                return Err(format!(
                    "colour image: pixel (column {}, row {}) is not grey ({:?}); a fogmap must be greyscale",
                    k % w,
                    k / w,
                    p
                ));
            }
            out.push(p[0] / max);
        }
        Ok(out)
    };
    let as_f64 = |v: &[u8]| v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
    let as_f64_16 = |v: &[u16]| v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
    let values = match &img {
        D::ImageLuma8(b) => b.as_raw().iter().map(|&v| f64::from(v) / 255.0).collect(),
        D::ImageLuma16(b) => b.as_raw().iter().map(|&v| f64::from(v) / 65535.0).collect(),
        D::ImageRgb8(b) => grey(&as_f64(b.as_raw()), 3, false, 255.0)?,
        D::ImageRgba8(b) => grey(&as_f64(b.as_raw()), 4, true, 255.0)?,
        D::ImageRgb16(b) => grey(&as_f64_16(b.as_raw()), 3, false, 65535.0)?,
        D::ImageRgba16(b) => grey(&as_f64_16(b.as_raw()), 4, true, 65535.0)?,
        D::ImageLumaA8(_) | D::ImageLumaA16(_) => {
            return Err(
                "greyscale image with an alpha channel; save the fogmap as plain greyscale"
                    .to_string(),
            );
        }
        other => return Err(format!("unsupported pixel type {:?}", other.color())),
    };
    Ok((w, h, values))
}

fn read_exr(path: &Path) -> Result<Pixels, String> {
    use exr::prelude::*;
    let image = read_first_flat_layer_from_file(path)
        .map_err(|e| format!("not a readable EXR image: {e}"))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let channels = &layer.channel_data.list;
    let find = |name: &str| channels.iter().find(|c| c.name.eq(name));
    let to_vec = |c: &AnyChannel<FlatSamples>| {
        c.sample_data
            .values_as_f32()
            .map(f64::from)
            .collect::<Vec<_>>()
    };
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    let values = if let Some(y) = find("Y") {
        to_vec(y)
    } else if channels.len() == 1 {
        to_vec(&channels[0])
    } else if let (Some(r), Some(g), Some(b)) = (find("R"), find("G"), find("B")) {
        let (r, g, b) = (to_vec(r), to_vec(g), to_vec(b));
        if let Some(k) = (0..r.len()).find(|&k| r[k] != g[k] || r[k] != b[k]) {
            return Err(format!(
                "colour image: pixel (column {}, row {}) has R, G, B = {}, {}, {}; a fogmap must be greyscale",
                k % w.max(1),
                k / w.max(1),
                r[k],
                g[k],
                b[k]
            ));
        }
        r
    } else {
        return Err(format!(
            "channels {names:?}: a fogmap needs a Y channel, a single channel, or equal R, G, B"
        ));
    };
    Ok((w, h, values))
}

fn read_npy(path: &Path) -> Result<Pixels, String> {
    use haze_volume::import::samples::{unorm8, unorm16};
    use npyz::{NpyFile, Order};
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    haze_core::npy_header::check(&bytes)?;
    let npy = NpyFile::new(&bytes[..]).map_err(|e| format!("not a readable .npy file: {e}"))?;
    let Some(shape) = haze_volume::import::npy::squeeze_to(npy.shape(), 2) else {
        return Err(format!(
            "array has shape {:?}; a fogmap needs 2 dimensions (axes of length 1 before or after them are dropped)",
            npy.shape()
        ));
    };
    let dim = |i: usize| usize::try_from(shape[i]).map_err(|_| "shape too large".to_string());
    let (rows, cols) = (dim(0)?, dim(1)?);
    let fortran = npy.order() == Order::Fortran;
    let Some(ty) = haze_volume::import::npy::sample_type(&npy.dtype()) else {
        return Err(format!(
            "dtype {} is not supported: use {SUPPORTED}",
            npy.dtype().descr()
        ));
    };
    let values: Vec<f64> = match ty {
        SampleType::F16 => npy
            .into_vec::<half::f16>()
            .map(|v| v.into_iter().map(f64::from).collect()),
        SampleType::F32 => npy
            .into_vec::<f32>()
            .map(|v| v.into_iter().map(f64::from).collect()),
        SampleType::F64 => npy.into_vec::<f64>(),
        SampleType::U8 => npy
            .into_vec::<u8>()
            .map(|v| v.into_iter().map(|x| f64::from(unorm8(x))).collect()),
        SampleType::U16 => npy
            .into_vec::<u16>()
            .map(|v| v.into_iter().map(|x| f64::from(unorm16(x))).collect()),
    }
    .map_err(|e| format!("array data unreadable: {e}"))?;
    if values.len() != rows * cols {
        return Err(format!(
            "header promises {} values but {} were read",
            rows * cols,
            values.len()
        ));
    }
    let values = if fortran {
        // Stored column by column: element [r, c] at c·rows + r.
        (0..rows * cols)
            .map(|k| values[(k % cols) * rows + k / cols])
            .collect()
    } else {
        values
    };
    Ok((cols, rows, values))
}

#[derive(serde::Deserialize)]
struct Sidecar {
    dims: Vec<usize>,
    #[serde(default)]
    dtype: Option<String>,
}

fn read_raw(path: &Path) -> Result<Pixels, String> {
    let sidecar = path.with_extension("json");
    let text = std::fs::read_to_string(&sidecar)
        .map_err(|e| format!("sidecar {}: {e}", sidecar.display()))?;
    haze_core::json::unique_keys(&text)
        .map_err(|e| format!("sidecar {}: {e}", sidecar.display()))?;
    let sc: Sidecar =
        serde_json::from_str(&text).map_err(|e| format!("sidecar {}: {e}", sidecar.display()))?;
    let [w, h] = match sc.dims[..] {
        [w, h] | [w, h, 1] => [w, h],
        _ => {
            return Err(format!(
                "sidecar {}: dims {:?} must be [width, height]",
                sidecar.display(),
                sc.dims
            ));
        }
    };
    let ty = match &sc.dtype {
        None => SampleType::F32,
        Some(dt) => SampleType::from_sidecar(dt).ok_or_else(|| {
            format!(
                "sidecar {}: dtype '{dt}' is not supported: use little-endian {SUPPORTED}",
                sidecar.display()
            )
        })?,
    };
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    let expected = w.checked_mul(h).and_then(|n| n.checked_mul(ty.size()));
    if expected != Some(bytes.len()) {
        return Err(format!(
            "{} bytes, but dims {w} × {h} need {} {} values",
            bytes.len(),
            w.saturating_mul(h),
            ty.name()
        ));
    }
    // float64 kept exact; the other types through the volumes' decoding.
    let values = match ty {
        SampleType::F64 => bytes
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
            .collect(),
        _ => ty.decode_le(&bytes).into_iter().map(f64::from).collect(),
    };
    Ok((w, h, values))
}
