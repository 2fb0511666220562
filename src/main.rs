//! `haze`: bake smoke simulations into compact assets and inspect them.

mod bake;
mod bench;
mod camera_medium_args;
mod cli;
mod export;
mod fog;
mod import_args;
mod inspect;
mod light_args;
mod merge;
mod pack;
mod render;
mod size_arg;
mod tradeoff;
mod unused_flags;
mod view;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    quiet_device_select_without_a_session();
    // Any unexpected panic is reported on one line, never as a backtrace.
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".to_string());
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        eprintln!(
            "error: internal error: {}",
            printable(&format!("{msg}{at}"))
        );
    }));
    let cli = match cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.use_stderr() => {
            eprintln!("{}", usage_line(&e));
            return ExitCode::from(2);
        }
        // --help and --version.
        Err(e) => e.exit(),
    };
    init_logging(cli.verbose, cli.quiet);
    haze_render::progress::set_quiet(cli.quiet);
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", printable(&format!("{e:#}")));
            ExitCode::FAILURE
        }
    }
}

/// Mesa's Vulkan device-select layer (loaded with lavapipe and Mesa's GPU drivers) asks
/// Wayland for the display's GPU while the adapter is sought; without a desktop session
/// (`XDG_RUNTIME_DIR` unset or not an absolute path: a container, ssh, CI) libwayland
/// prints `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` twice on
/// stderr, ahead of haze's own output. There is no display to pick a GPU for then, so the
/// layer is turned off (`NODEVICE_SELECT=1`, its own switch) unless the user set it.
fn quiet_device_select_without_a_session() {
    let session = std::env::var_os("XDG_RUNTIME_DIR")
        .is_some_and(|dir| std::path::Path::new(&dir).is_absolute());
    if !session && std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: first thing in `main`, before any thread exists that could read the
        // environment at the same time.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// A usage error on one line, as every other error: clap's message up to its first blank
/// line (the flag and the value, or the list of missing arguments) joined into one line,
/// and where the options are listed, without its usage block.
fn usage_line(e: &clap::Error) -> String {
    one_line(&e.render().to_string())
}

/// [`usage_line`] of clap's rendered text.
fn one_line(text: &str) -> String {
    let message: Vec<&str> = text
        .lines()
        .map(str::trim)
        .take_while(|l| !l.is_empty())
        .collect();
    let message = if message.is_empty() {
        "error: bad arguments".to_string()
    } else {
        message.join(" ")
    };
    printable(&format!("{message} (--help lists the options)"))
}

/// `text` as one printable line: line breaks and tabs become spaces, and every other
/// control character (a damaged file's bytes or a typed value quoted in a message: a
/// vertical tab, a form feed, a terminal's escape) is written as its `\u{..}` escape, so
/// an error is one line and never drives the terminal.
fn printable(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\n' | '\r' | '\t' => out.push(' '),
            '\u{2028}' | '\u{2029}' => out.extend(c.escape_unicode()),
            c if c.is_control() => out.extend(c.escape_unicode()),
            c => out.push(c),
        }
    }
    out
}

/// Logs go to stderr: warnings by default, more with `-v`/`-vv`, `RUST_LOG` overrides.
fn init_logging(verbose: u8, quiet: bool) {
    use tracing_subscriber::EnvFilter;
    let level = match (quiet, verbose) {
        (true, _) => "error",
        (false, 0) => "warn",
        (false, 1) => "info",
        (false, 2) => "debug",
        _ => "trace",
    };
    // vdb-rs logs every metadata type it does not know (Blender writes several) as a warning;
    // the viewer window's libraries warn about harmless display quirks (X settings, a
    // software rasterizer) unless asked for more.
    let window = if verbose == 0 {
        ",winit=error,egui_wgpu=error"
    } else {
        ""
    };
    let filter = EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| EnvFilter::new(format!("{level},vdb_rs=error{window}")));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .without_time()
        .with_target(false)
        .init();
}

#[cfg(test)]
mod tests {
    use super::{one_line, printable};

    /// A damaged file's control bytes quoted in a message keep it on one line and out of
    /// the terminal's hands.
    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(
            printable("format `32-bit_rle_\u{fffd}g\u{b}e` at\nline\r\t2 \u{1b}[31mred\u{2028}"),
            "format `32-bit_rle_\u{fffd}g\\u{b}e` at line  2 \\u{1b}[31mred\\u{2028}"
        );
        assert_eq!(printable("plain ünïcode ≤ 1 %"), "plain ünïcode ≤ 1 %");
        assert_eq!(
            one_line("error: invalid value '\u{c}' for '--width <WIDTH>'\n"),
            "error: invalid value '\\u{c}' for '--width <WIDTH>' (--help lists the options)"
        );
    }

    /// The names of missing arguments, on the lines after clap's first, are kept.
    #[test]
    fn a_usage_error_keeps_its_message_and_drops_the_usage() {
        let missing = "error: the following required arguments were not provided:\n  --out <OUT>\n  <INPUT>\n\nUsage: haze render --out <OUT> [INPUT]\n\nFor more information, try '--help'.\n";
        assert_eq!(
            one_line(missing),
            "error: the following required arguments were not provided: --out <OUT> <INPUT> (--help lists the options)"
        );
        let bad = "error: invalid value 'x' for '--width <WIDTH>': invalid digit\n\nFor more information, try '--help'.\n";
        assert_eq!(
            one_line(bad),
            "error: invalid value 'x' for '--width <WIDTH>': invalid digit (--help lists the options)"
        );
        assert_eq!(
            one_line(""),
            "error: bad arguments (--help lists the options)"
        );
    }
}
