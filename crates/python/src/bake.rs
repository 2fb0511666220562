//! `haze.inspect` and `haze.bake`: `haze_bake`'s report (or an environment map's,
//! `haze_render::map_report`) and its bake, frame by frame, with a Python callback
//! between frames.

use crate::{to_py, warnings};
use haze_bake::{Bake, BakeOptions, Count};
use haze_render::output::Outputs;
use haze_volume::ImportOptions;
use haze_volume::import::FrameRange;
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use std::path::PathBuf;

/// `frames` as a range: `None` (every frame) or `"A..B"`, `"A.."`, `"..B"`, `"A"`.
fn range(frames: Option<&str>) -> PyResult<FrameRange> {
    match frames {
        None => Ok(FrameRange::default()),
        Some(s) => s
            .parse()
            .map_err(|e| to_py(anyhow::anyhow!("frames={s:?}: {e}"))),
    }
}

/// `json.loads(text)`.
fn from_json<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// What `haze inspect --json PATH [--grid GRID] [--env-layout …]` prints, as a JSON
/// string.
#[pyfunction]
#[pyo3(signature = (
    path, frames=None, grid=None, env_layout="haze".to_string(), env_rotate=0.0,
    env_strength=1.0
))]
pub fn inspect(
    py: Python<'_>,
    path: PathBuf,
    frames: Option<&str>,
    grid: Option<String>,
    env_layout: String,
    env_rotate: f64,
    env_strength: f64,
) -> PyResult<Py<PyAny>> {
    let range = range(frames)?;
    let placement = crate::render::placement(&env_layout, env_rotate, env_strength)?;
    let mut import = ImportOptions::default();
    if let Some(name) = grid {
        import.grid = name;
    }
    let text = py.detach(|| {
        if haze_render::map_report::is_map(&path) {
            let report = haze_render::map_report::inspect_map(&path, placement)?;
            return Ok(serde_json::to_string(&report)?);
        }
        placement.only_for_maps(&path)?;
        let report = haze_bake::inspect::inspect(&path, range, &import, &mut |_, _, _| {})?;
        Ok(serde_json::to_string(&report)?)
    });
    warnings::flush(py)?;
    let text = text.map_err(to_py)?;
    Ok(from_json(py, &text)?.unbind())
}

/// `(number, bytes)` of every frame of `src` in `frames`: each frame's file size on disk,
/// a cheap measure of how much smoke it holds (an OpenVDB file stores only the active
/// voxels), which a cluster bake balances its chunks by.
#[pyfunction]
#[pyo3(signature = (src, frames=None))]
pub fn frame_sizes(
    py: Python<'_>,
    src: PathBuf,
    frames: Option<&str>,
) -> PyResult<Vec<(i64, u64)>> {
    let range = range(frames)?;
    let sizes = py.detach(|| {
        let seq = haze_bake::source::Frames::open(&src, &ImportOptions::default(), range)?;
        (0..seq.len())
            .map(|i| {
                let path = seq.path(i);
                let bytes = std::fs::metadata(path)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
                    .len();
                Ok((seq.number(i), bytes))
            })
            .collect::<anyhow::Result<Vec<_>>>()
    });
    warnings::flush(py)?;
    sizes.map_err(to_py)
}

/// The first-frame figures `(rel_l2, radius, gain, rbfs, support)` a bake of `src`'s
/// `frames` (its OpenVDB `grid`) with `rbfs` RBFs holds its frames to (`haze_bake::baseline`: one frame's fit).
#[pyfunction]
#[pyo3(signature = (src, frames=None, rbfs=None, grid=None))]
pub fn baseline(
    py: Python<'_>,
    src: PathBuf,
    frames: Option<&str>,
    rbfs: Option<usize>,
    grid: Option<String>,
) -> PyResult<(f64, f64, f64, usize, usize)> {
    let mut options = BakeOptions::new(&src, "");
    if let Some(name) = grid {
        options.import.grid = name;
    }
    options.range = range(frames)?;
    if let Some(n) = rbfs {
        options.count = Count::Fixed(n);
    }
    let b = py.detach(|| haze_bake::baseline(&options));
    warnings::flush(py)?;
    let b = b.map_err(to_py)?;
    Ok((b.rel_l2, b.radius, b.gain, b.rbfs, b.support))
}

/// Joins chunks of one sequence baked separately into `out` (`haze merge`); returns the
/// merged asset's frame numbers.
#[pyfunction]
pub fn merge(py: Python<'_>, chunks: Vec<PathBuf>, out: PathBuf) -> PyResult<Vec<i64>> {
    chunks
        .iter()
        .fold(Outputs::new(), |o, c| o.input(c))
        .asset("out", &out)
        .check()
        .map_err(to_py)?;
    let merged = py.detach(|| haze_bake::merge(&chunks, &out));
    warnings::flush(py)?;
    let merged = merged.map_err(to_py)?;
    Ok(merged.frames)
}

/// Bakes `src` into `out` (`haze bake`'s defaults for what is not given); calls
/// `progress(record)` after every frame with its report line as a dict; returns the
/// report (`haze bake --report`) as a dict.
#[pyfunction]
#[pyo3(signature = (src, out, frames=None, rbfs=None, residual_error=None, resume=false, progress=None, warm_up=0, domain_offset=None, baseline=None, grid=None, vdb_index=None))]
#[allow(clippy::too_many_arguments)]
pub fn bake(
    py: Python<'_>,
    src: PathBuf,
    out: PathBuf,
    frames: Option<&str>,
    rbfs: Option<usize>,
    residual_error: Option<f64>,
    resume: bool,
    progress: Option<Py<PyAny>>,
    warm_up: usize,
    domain_offset: Option<[f64; 3]>,
    baseline: Option<(f64, f64, f64, usize, usize)>,
    grid: Option<String>,
    vdb_index: Option<&str>,
) -> PyResult<Py<PyAny>> {
    let mut options = BakeOptions::new(&src, &out);
    if let Some(name) = grid {
        options.import.grid = name;
    }
    if let Some(at) = vdb_index {
        options.import.vdb_index = Some(
            at.parse()
                .map_err(|e: String| to_py(anyhow::anyhow!("vdb_index={e}")))?,
        );
    }
    if let Some((rel_l2, radius, gain, rbfs, support)) = baseline {
        let finite = [rel_l2, radius, gain]
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0);
        if !finite || rbfs == 0 || support == 0 {
            return Err(to_py(anyhow::anyhow!(
                "baseline={:?}: expected (rel_l2, radius, gain) finite and ≥ 0 and (rbfs, support) ≥ 1, as haze._haze.baseline returns",
                (rel_l2, radius, gain, rbfs, support)
            )));
        }
    }
    options.baseline = baseline.map(|(rel_l2, radius, gain, rbfs, support)| haze_fit::Baseline {
        rel_l2,
        radius,
        gain,
        rbfs,
        support,
    });
    if let Some(offset) = domain_offset {
        if offset.iter().any(|v| !v.is_finite()) {
            return Err(to_py(anyhow::anyhow!(
                "domain_offset={offset:?} must be finite"
            )));
        }
        options.import.domain_offset = offset;
    }
    options.range = range(frames)?;
    options.resume = resume;
    options.warm_up = warm_up;
    if let Some(n) = rbfs {
        if !(1..=haze_bake::MAX_RBFS).contains(&n) {
            return Err(to_py(anyhow::anyhow!(
                "rbfs={n} must be between 1 and {}",
                haze_bake::MAX_RBFS
            )));
        }
        options.count = Count::Fixed(n);
    }
    if let Some(e) = residual_error {
        if !(e.is_finite() && e >= 0.0) {
            return Err(to_py(anyhow::anyhow!(
                "residual_error={e} must be a fraction ≥ 0 of the peak density"
            )));
        }
        options.quant.error = e;
    }
    // Nothing lost: the asset and its journal never replace an input.
    Outputs::new()
        .input(&src)
        .asset("out", &out)
        .output("the bake journal", &haze_bake::journal::path_for(&out))
        .check()
        .map_err(to_py)?;
    let job = py.detach(|| Bake::new(options, |_| {}));
    warnings::flush(py)?;
    let mut job = job.map_err(to_py)?;
    loop {
        let next = py.detach(|| job.next());
        warnings::flush(py)?;
        let record = match next {
            None => break,
            Some(Ok(record)) => record,
            Some(Err(e)) => return Err(to_py(job.abandon(e))),
        };
        // Ctrl-C while a frame was fitting: stop, keeping the finished frames.
        if let Err(interrupt) = py.check_signals() {
            let kept = job.abandon(anyhow::anyhow!("{}: interrupted", out.display()));
            return Err(if interrupt.is_instance_of::<PyKeyboardInterrupt>(py) {
                PyKeyboardInterrupt::new_err(format!("{kept:#}"))
            } else {
                interrupt
            });
        }
        if let Some(callback) = &progress {
            let line = serde_json::to_string(&record).map_err(|e| to_py(e.into()))?;
            let called = from_json(py, &line).and_then(|r| callback.call1(py, (r,)));
            if let Err(raised) = called {
                // The callback's own exception stops the bake the same way.
                let kept = job.abandon(anyhow::anyhow!("{}: stopped by progress", out.display()));
                // Where the finished frames are kept, as a note on the exception (Python
                // 3.11 and later have notes).
                let _ = raised
                    .value(py)
                    .call_method1("add_note", (format!("{kept:#}"),));
                return Err(raised);
            }
        }
    }
    let baked = py.detach(|| job.finish());
    warnings::flush(py)?;
    let baked = baked.map_err(to_py)?;
    let report = serde_json::to_string(&baked.report(&src)).map_err(|e| to_py(e.into()))?;
    Ok(from_json(py, &report)?.unbind())
}
