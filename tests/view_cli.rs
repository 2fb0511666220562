//! End-to-end tests of `haze view` on an asset baked from the bundled plume-a frames (and
//! `--scene` on the bundled room): the one-line errors, playback measured without a
//! window, and the real window on a virtual X display (Xvfb, which `scripts/test.sh` installs) with Mesa's lavapipe. A playback
//! that never ends fails its test after two minutes.
//!
//! The playback tests need a GPU adapter (lavapipe will do) and fail without one.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

fn data(p: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(p)
        .display()
        .to_string()
}

/// A baked asset of plume-a frames 21..23.
fn bake(dir: &Path) -> PathBuf {
    let out = dir.join("plume.haze");
    let o = haze()
        .args([
            "bake",
            &data("plume-a/vdb"),
            "--frames",
            "21..23",
            "-q",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

fn fails(args: &[&str], needle: &str) {
    let o = haze().args(args).output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(
        err.starts_with("error: ") && err.contains(needle),
        "{needle}: {err}"
    );
    assert!(o.stdout.is_empty());
}

/// The figures of a `--play-for` line: (seconds, shown, due, dropped, mean ms, max ms,
/// fps); the three timings NaN where fewer than two frames were shown.
fn figures(line: &str) -> (f64, u64, u64, u64, f64, f64, f64) {
    let num = |after: &str, before: &str| -> f64 {
        let start = line
            .find(after)
            .unwrap_or_else(|| panic!("{after}: {line}"))
            + after.len();
        let rest = &line[start..];
        let end = rest
            .find(before)
            .unwrap_or_else(|| panic!("{before}: {line}"));
        rest[..end]
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("{after}: {line}"))
    };
    // Fewer than two frames shown measure no frame time, and the line says so.
    let timed = !line.contains("no frame time (fewer than two frames shown");
    let timing = |after: &str, before: &str| {
        if timed { num(after, before) } else { f64::NAN }
    };
    (
        num("played ", " s "),
        num(": ", " frame") as u64,
        num("shown, ", " due") as u64,
        num("due, ", " dropped") as u64,
        timing("frame time mean ", " ms,"),
        timing("ms, max ", " ms;"),
        timing("ms; ", " fps;"),
    )
}

#[test]
fn bad_files_and_knobs_fail_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    fails(&["view", "missing.haze"], "missing.haze");
    let vdb = data("plume-a/vdb/fluid_data_0021.vdb");
    fails(&["view", &vdb], "fluid_data_0021.vdb: not a haze asset");
    fails(
        &["view", &data("plume-a/vdb")],
        "a directory, not a baked asset",
    );
    // A packed asset holds raw volumes, no RBFs: the viewer plays them as they were
    // packed (the stream's unit test checks the density bit for bit).
    let packed = dir.path().join("packed.haze");
    let o = haze()
        .args([
            "pack",
            &data("plume-a/vdb"),
            "--frames",
            "21..21",
            "-q",
            "--out",
        ])
        .arg(&packed)
        .output()
        .unwrap();
    assert!(o.status.success());
    let o = haze()
        .args(["view", packed.to_str().unwrap(), "--no-window"])
        .args(["--play-for", "0.1", "--size", "32x24"])
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && out.contains(" shown, "), "{out}");
    // A tenth of a second stops at the first picture on a software GPU: one frame shown,
    // no frame time (not zeros that read as measured).
    let (_, shown, _, _, mean, _, fps) = figures(out.trim());
    if shown < 2 {
        assert!(mean.is_nan() && fps.is_nan(), "{out}");
    } else {
        assert!(mean > 0.0 && fps > 0.0, "{out}");
    }
    // A truncated asset.
    let asset = bake(dir.path());
    let bytes = std::fs::read(&asset).unwrap();
    let cut = dir.path().join("cut.haze");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    fails(&["view", cut.to_str().unwrap()], "cut.haze");
    let a = asset.to_str().unwrap();
    fails(&["view", a, "--sh-order", "7"], "--sh-order 7");
    fails(&["view", a, "--slices", "0"], "--slices");
    fails(&["view", a, "--albedo", "2"], "albedo");
    fails(&["view", a, "--fps=-1"], "--fps -1");
    fails(&["view", a, "--play-for", "0"], "--play-for 0");
    fails(&["view", a, "--exposure", "0"], "--exposure");
    fails(&["view", a, "--env", "nowhere.exr"], "nowhere.exr");
    // clap's own refusals (usage errors, status 2).
    for args in [
        vec!["view", a, "--size", "0x10"],
        vec!["view", a, "--size", "640"],
        vec!["view", a, "--no-window"],
        vec!["view", a, "--orbit", "--play-for", "1"],
    ] {
        let o = haze().args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
    }
}

/// Plays without a window and checks the measurement line against its definitions: the
/// clock never shows frames faster than the rate, every due slot is either on time or
/// dropped, and at fps 0 every frame is due when shown.
#[test]
fn plays_without_a_window_and_reports_the_figures() {
    let dir = tempfile::tempdir().unwrap();
    let asset = bake(dir.path());
    let a = asset.to_str().unwrap();
    let run = |args: &[&str]| {
        let o = haze()
            .args(["view", a, "--no-window", "--size", "32x24"])
            .args(args)
            .timeout(std::time::Duration::from_secs(120))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8(o.stdout).unwrap();
        assert_eq!(out.lines().count(), 1, "{out}");
        out.trim().to_string()
    };
    // Long enough for several frames where the software GPU takes about a second for
    // one (the first frame also waits for the asset to open).
    // The clock is under test: the centers' diffusion keeps a new frame near a second on
    // lavapipe (the explicit orders, the default, take about three).
    let line = run(&["--fps", "5", "--play-for", "3", "--ms-at-centers"]);
    assert!(line.contains("at 5 fps, 32×24"), "{line}");
    let (secs, shown, due, dropped, mean, max, fps) = figures(&line);
    // It stops at the first frame after 3 s; one frame takes at most a few seconds.
    assert!((3.0..8.0).contains(&secs), "{line}");
    // Slots of 0.2 s: as many are due as have ended, give or take the slot under way.
    assert!(due.abs_diff((secs * 5.0).floor() as u64) <= 1, "{line}");
    assert!(dropped <= due && shown >= 2, "{line}");
    // Every due slot not dropped was on time: that many frames were shown.
    assert!(shown >= due - dropped, "{line}");
    assert!(fps <= 5.0 + 1e-6 && mean >= 199.0 && max >= mean, "{line}");

    let line = run(&["--fps", "0", "--play-for", "2", "--ms-at-centers"]);
    let (_, shown, due, dropped, ..) = figures(&line);
    assert!(line.contains("as fast as possible"), "{line}");
    assert!(shown >= 1 && due == shown && dropped == 0, "{line}");

    // Turning the camera on the paused first frame, with the default explicit orders
    // (gathered once, added to the voxels again per view): at least two pictures, timed.
    let line = run(&["--orbit", "--play-for", "1"]);
    let turned: usize = line
        .strip_prefix("turned ")
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(
        turned >= 2 && line.contains("32×24") && line.contains("median"),
        "{line}"
    );
}

/// A virtual X display of the test's own: `Xvfb -displayfd 1` picks a display number whose
/// sockets are all free (on Linux the filesystem one and the abstract one, which other
/// containers on the same network namespace can hold) and prints it only once the server
/// accepts connections, so no start-up race and no other server can answer the viewer. No
/// `-auth`: the server admits local clients, so no cookie file can mismatch.
#[cfg(target_os = "linux")]
struct VirtualDisplay {
    server: std::process::Child,
    number: String,
    log: PathBuf,
}

#[cfg(target_os = "linux")]
impl VirtualDisplay {
    fn start(dir: &Path, attempt: usize) -> Result<Self, String> {
        use std::io::BufRead;
        use std::os::unix::fs::PermissionsExt;
        // Xvfb only creates the socket directory as root; elsewhere it would listen on
        // the abstract socket alone.
        let sockets = Path::new("/tmp/.X11-unix");
        if !sockets.exists() && std::fs::create_dir(sockets).is_ok() {
            let _ = std::fs::set_permissions(sockets, std::fs::Permissions::from_mode(0o1777));
        }
        let log = dir.join(format!("xvfb-{attempt}.log"));
        let mut server = std::process::Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "1024x768x24"])
            .args(["-nolisten", "tcp"])
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::piped())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .map_err(|e| format!("Xvfb: {e} (install xvfb; scripts/test.sh does)"))?;
        let stdout = server.stdout.take().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = std::io::BufReader::new(stdout).read_line(&mut line);
            let _ = tx.send(line);
        });
        let number = rx
            .recv_timeout(std::time::Duration::from_secs(60))
            .unwrap_or_default()
            .trim()
            .to_string();
        let display = Self {
            server,
            number,
            log,
        };
        if display.number.is_empty() {
            return Err(format!("Xvfb did not start: {}", display.log()));
        }
        Ok(display)
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

#[cfg(target_os = "linux")]
impl Drop for VirtualDisplay {
    fn drop(&mut self) {
        let _ = self.server.kill();
        let _ = self.server.wait();
    }
}

/// The window itself, on a virtual display: opens, plays, and `--play-for` closes it
/// with the measurement line.
#[cfg(target_os = "linux")]
#[test]
fn the_window_plays_on_a_virtual_display() {
    let dir = tempfile::tempdir().unwrap();
    let asset = bake(dir.path());
    for (fps, target) in [("4", "at 4 fps"), ("0", "as fast as possible")] {
        // A server that does not come up, or a connection it refuses, is tried again on a
        // fresh server (three times in all); what each attempt printed is in the failure.
        let mut failures = Vec::new();
        let out = (0..3).find_map(|attempt| {
            let display = match VirtualDisplay::start(dir.path(), attempt) {
                Ok(d) => d,
                Err(e) => {
                    failures.push(e);
                    return None;
                }
            };
            // A window that never closes fails the test instead of hanging it.
            let o = haze()
                .args(["view", asset.to_str().unwrap(), "--size", "64x48"])
                .args(["--fps", fps, "--play-for", "3", "--ms-at-centers"])
                .env("DISPLAY", format!(":{}", display.number))
                .env_remove("XAUTHORITY")
                .env_remove("WAYLAND_DISPLAY")
                .timeout(std::time::Duration::from_secs(120))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr).to_string();
            if o.status.success() {
                return Some(String::from_utf8(o.stdout).unwrap());
            }
            // Only the X connection is retried: any other failure is the viewer's.
            assert!(err.contains("cannot open the viewer window"), "{err}");
            failures.push(format!(
                "{err}\nXvfb :{} said: {}",
                display.number,
                display.log()
            ));
            None
        });
        let out = out.unwrap_or_else(|| panic!("{}", failures.join("\n---\n")));
        let (secs, shown, due, dropped, ..) = figures(out.trim());
        assert!(out.contains(&format!("s {target}, 64×48")), "{out}");
        assert!((3.0..4.5).contains(&secs) && shown >= 2, "{out}");
        assert!(dropped <= due && shown >= due - dropped, "{out}");
    }
}

/// Runs `haze ARGS` on a fresh virtual display and gives its stdout. A server that does
/// not come up, or a connection it refuses, is tried again on a fresh server (three times
/// in all); what each attempt printed is in the failure. A window that never closes fails
/// the test instead of hanging it.
#[cfg(target_os = "linux")]
fn on_virtual_display(dir: &Path, args: &[&str]) -> String {
    let mut failures = Vec::new();
    let out = (0..3).find_map(|attempt| {
        let display = match VirtualDisplay::start(dir, attempt) {
            Ok(d) => d,
            Err(e) => {
                failures.push(e);
                return None;
            }
        };
        let o = haze()
            .args(args)
            .env("DISPLAY", format!(":{}", display.number))
            .env_remove("XAUTHORITY")
            .env_remove("WAYLAND_DISPLAY")
            .timeout(std::time::Duration::from_secs(120))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        if o.status.success() {
            return Some(String::from_utf8(o.stdout).unwrap());
        }
        // Only the X connection is retried: any other failure is the viewer's.
        assert!(err.contains("cannot open the viewer window"), "{err}");
        failures.push(format!(
            "{err}\nXvfb :{} said: {}",
            display.number,
            display.log()
        ));
        None
    });
    out.unwrap_or_else(|| panic!("{}", failures.join("\n---\n")))
}

/// `haze view --scene`'s window on a virtual display: opens, shows the room, and
/// `--play-for` closes it with the measurement line.
#[cfg(target_os = "linux")]
#[test]
fn the_scene_window_shows_on_a_virtual_display() {
    let dir = tempfile::tempdir().unwrap();
    let room = data("scenes/room.json");
    let out = on_virtual_display(
        dir.path(),
        &[
            "view",
            "--scene",
            &room,
            "--size",
            "64x48",
            "--play-for",
            "2",
        ],
    );
    assert!(
        out.contains("of 64×48 in") && out.contains("median"),
        "{out}"
    );
    assert_eq!(out.lines().count(), 1, "{out}");
}

/// `haze view --scene`'s window on the bundled Gaussian medium with one scripted paint
/// stroke: opens, shows the edited medium through paper B, and `--play-for` closes it with
/// the measurement line.
#[cfg(target_os = "linux")]
#[test]
fn the_scene_window_shows_a_painted_gaussian_medium() {
    let dir = tempfile::tempdir().unwrap();
    let scene = data("scenes/gaussians.json");
    let out = on_virtual_display(
        dir.path(),
        &[
            "view",
            "--scene",
            &scene,
            "--size",
            "64x48",
            "--stroke",
            "paint:10,40:50,40",
            "--play-for",
            "2",
        ],
    );
    assert!(
        out.contains("of 64×48 in") && out.contains("paper B's Gaussians"),
        "{out}"
    );
    assert_eq!(out.lines().count(), 1, "{out}");
}

/// `haze view --fog`'s window on a virtual display: opens on the bundled fogmap with the
/// wind blowing, and `--play-for` closes it after a second with the measurement line.
#[cfg(target_os = "linux")]
#[test]
fn the_fog_window_shows_on_a_virtual_display() {
    let dir = tempfile::tempdir().unwrap();
    let fogmap = data("fogmap/fogmap_128.png");
    let out = on_virtual_display(
        dir.path(),
        &[
            "view",
            "--fog",
            &fogmap,
            "--size",
            "64x48",
            "--wind",
            "2,1",
            "--play-for",
            "1",
        ],
    );
    let (pictures, seconds) = pictures(out.trim(), "64×48");
    assert!(pictures >= 1 && (1.0..3.0).contains(&seconds), "{out}");
    assert_eq!(out.lines().count(), 1, "{out}");
}

/// `haze view --fog` without a window: flies for two seconds over the bundled fogmap (at
/// three levels, the wind blowing) and prints one line: the pictures rendered, their
/// size, the time and the device.
#[test]
fn the_fog_flies_without_a_window() {
    let o = haze()
        .args(["view", "--fog", &data("fogmap/fogmap_128.png")])
        .args([
            "--levels", "3", "--mu", "0.7", "--wind", "3,1", "--size", "64x48",
        ])
        .args(["--no-window", "--play-for", "2"])
        .timeout(std::time::Duration::from_secs(120))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let out = String::from_utf8(o.stdout).unwrap();
    assert_eq!(out.lines().count(), 1, "{out}");
    let (pictures, seconds) = pictures(out.trim(), "64×48");
    assert!(pictures >= 2 && (2.0..4.0).contains(&seconds), "{out}");
    assert!(out.contains("(GPU render, read back, sRGB) on "), "{out}");
}

/// `haze view --fog --smoke` without a window: the baked plume stands in the fog, its
/// layer rendered again for every picture (the camera turns); `--smoke` without `--fog`
/// is refused on one line.
#[test]
fn smoke_flies_in_the_fog_without_a_window() {
    let dir = tempfile::tempdir().unwrap();
    let asset = bake(dir.path());
    let a = asset.to_str().unwrap();
    let o = haze()
        .args(["view", "--fog", &data("fogmap/fogmap_128.png")])
        .args(["--smoke", a, "--smoke-frame", "22", "--smoke-scale", "4"])
        .args(["--size", "64x48", "--no-window", "--play-for", "1"])
        .timeout(std::time::Duration::from_secs(120))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let out = String::from_utf8(o.stdout).unwrap();
    let (pictures, _) = pictures(out.trim(), "64×48");
    assert!(pictures >= 1, "{out}");
    assert!(
        out.contains("plume.haze frame 22 (smoke layer on the CPU)"),
        "{out}"
    );
    fails(&["view", a, "--smoke", a], "give --fog FOGMAP too");
}

/// A fogmap that cannot be read, a sequence that cannot play, or knobs its fog refuses:
/// one line naming the file and the problem, exit 1, before any device or window.
#[test]
fn a_bad_fogmap_fails_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let broken = dir.path().join("broken.png");
    std::fs::write(&broken, b"not a PNG").unwrap();
    let broken = broken.to_str().unwrap();
    let fogmap = data("fogmap/fogmap_128.png");
    let fog = |extra: &[&str], path: &str, needle: &str| {
        let mut args = vec!["view", "--fog", path, "--no-window", "--play-for", "1"];
        args.extend_from_slice(extra);
        fails(&args, needle);
    };
    fog(&[], broken, "broken.png");
    fog(
        &[],
        &data("scenes/room.json"),
        "room.json: unknown fogmap format",
    );
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    fog(&[], empty.to_str().unwrap(), "empty: no fogmaps");
    // A sequence of fogmaps of two sizes, and one without a rate.
    let seq = dir.path().join("seq");
    std::fs::create_dir(&seq).unwrap();
    std::fs::copy(&fogmap, seq.join("fog_0001.png")).unwrap();
    std::fs::write(seq.join("fog_0002.f32"), [0u8; 16]).unwrap();
    std::fs::write(seq.join("fog_0002.json"), r#"{"dims": [2, 2]}"#).unwrap();
    let seq = seq.to_str().unwrap();
    fog(
        &[],
        seq,
        "fog_0002.f32: 2 × 2, but the sequence's first fogmap is 128 × 128",
    );
    fog(
        &["--fps", "0"],
        seq,
        "--fps 0: a sequence of fogmaps needs a rate above 0, at most 1000",
    );
    fog(&["--levels", "9"], &fogmap, "fogmap_128.png: 9 levels");
    fog(&["--mu", "1.5"], &fogmap, "µ = 1.5 must be in [0, 1]");
}

/// The figures of a `haze view --scene/--fog` line: (pictures, seconds), checking the size.
fn pictures(line: &str, size: &str) -> (u64, f64) {
    let (n, rest) = line
        .split_once(" picture")
        .unwrap_or_else(|| panic!("{line}"));
    let rest = rest
        .split_once(&format!(" of {size} in "))
        .unwrap_or_else(|| panic!("{size}: {line}"))
        .1;
    let secs = rest.split_once(" s,").unwrap_or_else(|| panic!("{line}")).0;
    (n.parse().unwrap(), secs.parse().unwrap())
}

/// Without a GPU adapter the viewer says so on one line, before opening a window (here
/// the Vulkan loader is pointed at no driver at all).
#[cfg(target_os = "linux")]
#[test]
fn without_an_adapter_it_fails_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let asset = bake(dir.path());
    let o = haze()
        .args([
            "view",
            asset.to_str().unwrap(),
            "--play-for",
            "1",
            "--no-window",
        ])
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(err.starts_with("error: GPU: no GPU adapter found"), "{err}");
}

/// No X or Wayland display: one line that says so and how to play without a window.
#[test]
fn without_a_display_it_says_how_to_play_without_one() {
    let dir = tempfile::tempdir().unwrap();
    let asset = bake(dir.path());
    let o = haze()
        .args(["view", asset.to_str().unwrap()])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .timeout(std::time::Duration::from_secs(120))
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(
        err.starts_with("error: cannot open the viewer window") && err.contains("--no-window"),
        "{err}"
    );
}
