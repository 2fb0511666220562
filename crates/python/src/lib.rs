//! `haze._haze`, the native half of the `haze` Python package (`python/haze`): the bake,
//! `inspect`, baked assets as NumPy arrays and renders, each a thin call into the
//! workspace's libraries (`haze_bake`, `haze_render`), with the GIL released while they
//! work. The Python half (`python/haze/__init__.py`) documents the API and converts
//! arguments; errors arrive as `haze.HazeError` with the command line's one-line message.

mod asset;
mod bake;
mod render;
mod warnings;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _haze,
    HazeError,
    PyException,
    "A haze operation failed: bad input, an unreadable file, a refused option. The message is the command line's one-line error."
);

/// `error` as a [`HazeError`], on one line as the command line prints it.
pub(crate) fn to_py(error: anyhow::Error) -> PyErr {
    HazeError::new_err(format!("{error:#}").replace('\n', " "))
}

/// The package's version (the workspace's).
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _haze(m: &Bound<'_, PyModule>) -> PyResult<()> {
    warnings::install();
    m.add("HazeError", m.py().get_type::<HazeError>())?;
    m.add("HazeWarning", m.py().get_type::<warnings::HazeWarning>())?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add_function(wrap_pyfunction!(bake::inspect, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake, m)?)?;
    m.add_function(wrap_pyfunction!(bake::merge, m)?)?;
    m.add_function(wrap_pyfunction!(bake::baseline, m)?)?;
    m.add_function(wrap_pyfunction!(bake::frame_sizes, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_scene, m)?)?;
    m.add_class::<asset::Asset>()?;
    Ok(())
}
