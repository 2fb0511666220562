//! How fast the streaming reader delivers frames, and whether it keeps up with playback.
//!
//! ```text
//! cargo run --release --example stream_rate -- ASSET.haze [--fps 24] [--ahead 4] [--loops 3]
//! ```
//!
//! First drains the asset as fast as the reader goes (frames per second, decode only),
//! then plays it `--loops` times at `--fps`, asking for each frame at its due time without
//! waiting: a frame that is not ready then is counted as late (a dropped frame of a
//! viewer whose rendering fits the frame budget).

use haze_view::stream::FrameStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};

fn main() {
    let mut args = std::env::args().skip(1);
    let mut path = None;
    let (mut fps, mut ahead, mut loops) = (24.0f64, 4usize, 3usize);
    while let Some(a) = args.next() {
        let mut value = || args.next().and_then(|v| v.parse::<f64>().ok());
        match a.as_str() {
            "--fps" => fps = value().unwrap_or(fps),
            "--ahead" => ahead = value().map_or(ahead, |v| v as usize),
            "--loops" => loops = value().map_or(loops, |v| v as usize),
            _ => path = Some(PathBuf::from(a)),
        }
    }
    let Some(path) = path else {
        eprintln!("usage: stream_rate ASSET.haze [--fps 24] [--ahead 4] [--loops 3]");
        std::process::exit(2);
    };
    let open = |looping| {
        FrameStream::open(&path, ahead, looping).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1)
        })
    };

    let mut s = open(false);
    let n = s.frame_count();
    let t = Instant::now();
    let mut rbfs = 0;
    while let Some(f) = s.next_frame() {
        let f = f.unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1)
        });
        rbfs += f.rbfs.len();
    }
    let dt = t.elapsed().as_secs_f64();
    say(format!(
        "{}: {n} frames, {:.0} RBFs/frame, drained in {:.1} ms: {:.0} frames/s",
        path.display(),
        rbfs as f64 / n as f64,
        dt * 1e3,
        n as f64 / dt
    ));

    // The drained stream's frames go before playback opens its own: a player holds one.
    drop(s);
    let mut s = open(true);
    let period = Duration::from_secs_f64(1.0 / fps);
    // A player shows its first frame when it is ready; the clock starts there.
    let first = Instant::now();
    s.next_frame();
    let startup = first.elapsed();
    let start = Instant::now();
    let (mut late, total) = (0usize, n * loops);
    let mut worst = Duration::ZERO;
    for i in 1..total {
        let due = start + period * i as u32;
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let asked = Instant::now();
        if s.try_next_frame().is_none() {
            late += 1;
            s.next_frame();
        }
        worst = worst.max(asked.elapsed());
    }
    say(format!(
        "playback at {fps} fps, {ahead} ahead, {total} frames: first after {:.2} ms, then {late} late, longest wait {:.3} ms",
        startup.as_secs_f64() * 1e3,
        worst.as_secs_f64() * 1e3
    ));
}

/// Prints a result line; a closed pipe (the output piped into `head`) ends the run
/// quietly instead of panicking.
fn say(line: String) {
    use std::io::Write;
    if writeln!(std::io::stdout(), "{line}").is_err() {
        std::process::exit(0);
    }
}
