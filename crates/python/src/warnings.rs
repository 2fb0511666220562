//! haze's warnings as Python warnings: what the command line prints as `WARN …` lines (a
//! model outside its validity, frames missing from a sequence, an all-zero input) reaches
//! Python as `haze.HazeWarning` through `warnings.warn`, so `warnings.filterwarnings`,
//! `pytest.warns` and notebooks show or catch it.
//!
//! The libraries log warnings through `tracing`; a layer installed when the module loads
//! keeps every warning of haze's own crates (`haze*` targets), from any thread (rayon's
//! workers too), and each API call hands the ones its work raised to Python when it
//! returns. Summary lines and progress bars (the command line's `say!`) are off: a call
//! returns its result instead.

use pyo3::create_exception;
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;
use std::ffi::CString;
use std::fmt::Write;
use std::sync::Mutex;
use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, Layer, SubscriberExt};

create_exception!(
    _haze,
    HazeWarning,
    PyUserWarning,
    "A haze warning: the command line's WARN line (a model used outside where it holds, frames missing from a sequence, an input of zeros)."
);

/// Warnings raised since the last call handed them to Python.
static PENDING: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// The text of a warning: its message, then any other fields as `name=value`.
#[derive(Default)]
struct Text(String);

impl Visit for Text {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        let sep = if self.0.is_empty() { "" } else { " " };
        if field.name() == "message" {
            self.0 = format!("{value:?}{sep}{}", self.0);
        } else {
            let _ = write!(self.0, "{sep}{}={value:?}", field.name());
        }
    }

    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.record_debug(field, &format_args!("{value}"));
        } else {
            self.record_debug(field, &value);
        }
    }
}

/// Keeps the warnings (and errors) of haze's crates.
struct Keep;

impl<S: Subscriber> Layer<S> for Keep {
    fn on_event(&self, event: &Event<'_>, _: Context<'_, S>) {
        let m = event.metadata();
        if *m.level() > Level::WARN || !m.target().starts_with("haze") {
            return;
        }
        let mut text = Text::default();
        event.record(&mut text);
        if let Ok(mut pending) = PENDING.lock() {
            pending.push(text.0);
        }
    }
}

/// Installs the layer (once; a process that already has a `tracing` subscriber keeps
/// it) and turns the summary lines off.
pub fn install() {
    let _ = tracing::subscriber::set_global_default(tracing_subscriber::registry().with(Keep));
    haze_render::progress::set_quiet(true);
}

/// Hands the warnings raised since the last call to Python's `warnings.warn`, as
/// [`HazeWarning`]s attributed to the caller's line (an `error` filter turns the first
/// into an exception).
pub fn flush(py: Python<'_>) -> PyResult<()> {
    let pending = std::mem::take(&mut *PENDING.lock().unwrap_or_else(|e| e.into_inner()));
    if pending.is_empty() {
        return Ok(());
    }
    let category = py.get_type::<HazeWarning>();
    let level = caller_level(py)?;
    for text in pending {
        let text = CString::new(text.replace('\0', " ")).unwrap_or_default();
        PyErr::warn(py, &category, &text, level)?;
    }
    Ok(())
}

/// `warnings.warn`'s `stacklevel` of the first frame outside the `haze` package (the
/// user's line, past the package's wrappers): 1 is the Python frame that called into
/// the native module.
fn caller_level(py: Python<'_>) -> PyResult<i32> {
    let file = py.import("haze")?.getattr("__file__")?;
    let package = py
        .import("os.path")?
        .call_method1("dirname", (file,))?
        .extract::<String>()?
        + std::path::MAIN_SEPARATOR_STR;
    let mut frame = py.import("sys")?.call_method1("_getframe", (0,))?;
    let mut level = 1;
    loop {
        let name: String = frame.getattr("f_code")?.getattr("co_filename")?.extract()?;
        let back = frame.getattr("f_back")?;
        if !name.starts_with(&package) || back.is_none() {
            return Ok(level);
        }
        frame = back;
        level += 1;
    }
}
