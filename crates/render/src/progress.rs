//! What a command tells its user on stderr besides errors and logs: progress bars for
//! long work (shown on a terminal, silent otherwise), summary lines and plain warnings.
//! `haze -q` ("only errors") silences all of them through [`set_quiet`].

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::fmt::Display;
use std::sync::atomic::{AtomicBool, Ordering};

/// Whether this process was asked for errors only (`haze -q`).
static QUIET: AtomicBool = AtomicBool::new(false);

/// Asks for errors only: no bars, summary lines or warnings from here on.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether [`set_quiet`] asked for errors only.
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// A summary, status or warning line on stderr ("out.png: 640×480, …, 1.2 s"), unless
/// quiet; [`say!`](crate::say) formats it.
pub fn say(line: impl Display) {
    if !quiet() {
        eprintln!("{line}");
    }
}

/// `eprintln!` unless `haze -q` asked for errors only ([`progress::say`](say)).
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::progress::say(format_args!($($arg)*))
    };
}

/// A bar of `len` steps drawn by `template` (`[{bar:30}]` filled with `=> `), which
/// draws nothing when quiet (and, as every bar, nothing when stderr is not a terminal:
/// logs and scripts get no control characters).
fn bar(len: u64, template: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    if quiet() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(template)
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}

/// A bar over `len` frames with rate and ETA.
pub fn frames(len: usize, what: &str) -> ProgressBar {
    let bar = bar(
        len as u64,
        "{msg:>10} [{bar:30}] {pos}/{len} frames, {elapsed} elapsed, ETA {eta}",
    );
    bar.set_message(what.to_string());
    // Redraw while a long frame is in progress, so the clock keeps moving.
    bar.enable_steady_tick(std::time::Duration::from_millis(500));
    bar
}

/// A spinner with elapsed time for work of unknown length.
pub fn spinner(what: &str) -> ProgressBar {
    let s = ProgressBar::new_spinner();
    if quiet() {
        s.set_draw_target(ProgressDrawTarget::hidden());
    }
    s.set_style(
        ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    s.set_message(what.to_string());
    s.enable_steady_tick(std::time::Duration::from_millis(200));
    s
}

/// A bar over the settings of a sweep with ETA, the setting being measured as message.
pub fn settings_bar() -> ProgressBar {
    let bar = bar(
        0,
        "[{bar:30}] {pos}/{len} settings, {elapsed} elapsed, ETA {eta} {wide_msg}",
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(500));
    bar
}

/// A bar over an image's `rows` with ETA, `what` ("rendering", "marching") as message.
pub fn rows(rows: usize, what: &str) -> ProgressBar {
    let bar = bar(
        rows as u64,
        "{msg} [{bar:30}] {pos}/{len} rows, {elapsed} elapsed, ETA {eta}",
    );
    bar.set_message(what.to_string());
    bar
}
