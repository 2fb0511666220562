//! `haze.Asset`: a baked `.haze` asset's frames — their RBFs and their reconstructed
//! density — as NumPy arrays.

use crate::to_py;
use anyhow::Context;
use haze_bake::export::{frame_density, read_frame, read_raw_frame, read_rbfs};
use haze_render::output::{Outputs, write_atomic};
use haze_view::stream::FrameDecoder;
use haze_volume::Volume;
use haze_volume::export::vdb;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// A baked or packed `.haze` asset, opened for reading. Reading frames keeps the hash
/// volume last decoded (at most the bake's `--volume-mib`, 128 MiB by default), so a
/// sequence read frame by frame, in either order, decodes each volume at most twice.
#[derive(Debug)]
#[pyclass(frozen, module = "haze._haze")]
pub struct Asset {
    path: PathBuf,
    /// The source frame numbers, in asset order.
    numbers: Vec<i64>,
    dims: [usize; 3],
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
    /// The input the asset was baked from, as recorded (an export never replaces it).
    source: PathBuf,
    /// The frames' decoder, made at the first frame read: it holds the hash volume last
    /// decoded (up to the frame asked for, whole when a later frame of it is asked for),
    /// so that a sequence read frame after frame, in either order (Blender's "Load as
    /// Volume"), decodes a volume at most twice instead of its earlier frames again for
    /// every frame.
    decoder: Mutex<Option<FrameDecoder>>,
}

/// A frame's RBFs as arrays: centers `(N, 3)`, radii `(N,)`, weights `(N,)`.
type Rbfs<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// `v` (x fastest) as a `(z, y, x)` array, moved into NumPy without a copy.
fn zyx(py: Python<'_>, dims: [usize; 3], v: Vec<f32>) -> PyResult<Bound<'_, PyArray3<f32>>> {
    let a = Array3::from_shape_vec((dims[2], dims[1], dims[0]), v)
        .map_err(|e| to_py(anyhow::anyhow!("volume shape: {e}")))?;
    Ok(a.into_pyarray(py))
}

#[pymethods]
impl Asset {
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<Asset> {
        let opened = py
            .detach(|| haze_asset::Asset::open(&path))
            .map_err(|e| to_py(anyhow::anyhow!(e)))?;
        let h = opened.header();
        Ok(Asset {
            numbers: h.source.frame_numbers.clone(),
            dims: h.grid.dims.map(|d| d as usize),
            bbox_min: h.grid.bbox_min,
            bbox_max: h.grid.bbox_max,
            source: PathBuf::from(&h.source.path),
            path,
            decoder: Mutex::new(None),
        })
    }

    /// The asset's path.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The source frame numbers, in order.
    #[getter]
    fn frames(&self) -> Vec<i64> {
        self.numbers.clone()
    }

    /// The grid's voxel counts `(nx, ny, nz)`; a frame's array is shaped `(nz, ny, nx)`.
    #[getter]
    fn dims(&self) -> (usize, usize, usize) {
        (self.dims[0], self.dims[1], self.dims[2])
    }

    /// The grid's world box: `((x0, y0, z0), (x1, y1, z1))`.
    #[getter]
    fn bbox(&self) -> ([f64; 3], [f64; 3]) {
        (self.bbox_min, self.bbox_max)
    }

    fn __len__(&self) -> usize {
        self.numbers.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "haze.Asset({:?}: {} frames, {} × {} × {})",
            self.path.display().to_string(),
            self.numbers.len(),
            self.dims[0],
            self.dims[1],
            self.dims[2]
        )
    }

    /// Frame `number`'s RBFs: `(centers (N, 3), radii (N,), weights (N,))`, float64, world
    /// units; `D̃(x) = Σ wᵢ·exp(−|x − cᵢ|²/rᵢ²)`.
    fn rbfs<'py>(&self, py: Python<'py>, number: i64) -> PyResult<Rbfs<'py>> {
        let rbfs = py
            .detach(|| read_rbfs(&self.path, Some(number)))
            .map_err(to_py)?;
        let n = rbfs.len();
        let centers: Vec<f64> = rbfs.iter().flat_map(|r| r.center).collect();
        let centers = Array2::from_shape_vec((n, 3), centers)
            .map_err(|e| to_py(anyhow::anyhow!("RBF centers: {e}")))?;
        let radii: Vec<f64> = rbfs.iter().map(|r| r.radius).collect();
        let weights: Vec<f64> = rbfs.iter().map(|r| r.weight).collect();
        Ok((
            centers.into_pyarray(py),
            radii.into_pyarray(py),
            weights.into_pyarray(py),
        ))
    }

    /// Frame `number`'s density, float32 shaped `(nz, ny, nx)`: the RBFs plus the
    /// dequantized residual, negatives clamped to 0 (`haze export`), or a packed frame's
    /// volume as packed.
    fn frame<'py>(&self, py: Python<'py>, number: i64) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let v = py.detach(|| self.density(number)).map_err(to_py)?;
        zyx(py, v.dims(), v.into_data())
    }

    /// Writes frame `number`'s density (as `frame` gives it) to `out`, an OpenVDB file of
    /// one float grid, `density`, placed where the asset's box lies (`haze export --frame
    /// NUMBER --out OUT.vdb`); `out` is written whole or not at all and never replaces the
    /// asset or a file it was baked from. Returns `out`.
    fn write_vdb(&self, py: Python<'_>, number: i64, out: PathBuf) -> PyResult<PathBuf> {
        py.detach(|| -> anyhow::Result<()> {
            let is_vdb = out
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("vdb"));
            if !is_vdb {
                anyhow::bail!(
                    "{}: write_vdb writes OpenVDB: name the file .vdb",
                    out.display()
                );
            }
            Outputs::new()
                .input(&self.path)
                .input(&self.source)
                .output("out", &out)
                .check()?;
            let v = self.density(number)?;
            let bytes =
                vdb::to_bytes(&v).with_context(|| format!("{}: frame {number}", out.display()))?;
            write_atomic(&out, &bytes)
        })
        .map_err(to_py)?;
        Ok(out)
    }
}

impl Asset {
    /// Frame `number`'s density over the asset's box: a packed frame as packed, a baked
    /// one reconstructed.
    fn density(&self, number: i64) -> anyhow::Result<Volume> {
        if let Some((_, v)) = read_raw_frame(&self.path, Some(number))? {
            return Ok(v);
        }
        let Some(k) = self.numbers.iter().position(|&n| n == number) else {
            // Not in the asset: its one-line error.
            return Ok(read_frame(&self.path, Some(number))?.density()?.0);
        };
        let mut decoder = self.decoder.lock().unwrap_or_else(|e| e.into_inner());
        if decoder.is_none() {
            let asset = Arc::new(haze_asset::Asset::open(&self.path)?);
            *decoder = Some(FrameDecoder::new(asset));
        }
        let f = decoder.as_mut().expect("set above").decode(k)?;
        let bbox = haze_volume::Bbox::new(self.bbox_min, self.bbox_max);
        let residual = f.residual.as_ref().map(|r| (&*r.group, r.slot));
        Ok(frame_density(self.dims, bbox, &f.rbfs, residual)?.0)
    }
}
