//! Progress bars for long work: shown on a terminal, silent otherwise.

use indicatif::{ProgressBar, ProgressStyle};

/// A bar over `len` frames with rate and ETA. Hidden when stderr is not a terminal (logs
/// and scripts get no control characters).
pub fn frames(len: usize, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{msg:>10} [{bar:30}] {pos}/{len} frames, {elapsed} elapsed, ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    // Redraw while a long frame is in progress, so the clock keeps moving.
    bar.enable_steady_tick(std::time::Duration::from_millis(500));
    bar
}

/// A spinner with elapsed time for work of unknown length.
pub fn spinner(what: &str) -> ProgressBar {
    let s = ProgressBar::new_spinner();
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
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template(
            "[{bar:30}] {pos}/{len} settings, {elapsed} elapsed, ETA {eta} {wide_msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(500));
    bar
}
