//! End-to-end: an interrupted bake resumed from its journal, and chunks baked separately
//! then merged — on the bundled plume-a frames 21..28.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn plume() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/plume-a/vdb")
        .display()
        .to_string()
}

fn haze(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haze"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> Output {
    let out = haze(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Fails with exactly one `error:` line naming `file`.
fn fails(args: &[&str], file: &Path) -> String {
    let out = haze(args);
    assert_eq!(out.status.code(), Some(1), "{args:?}");
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains(&file.display().to_string()), "{err}");
    err
}

/// Finished frames in a bake journal, counted from its record headers (see src/journal.rs:
/// magic, then `tag u32 | json_len u32 | bin_len u32 | crc u32 | json | bin`).
fn journal_frames(path: &Path) -> usize {
    let Ok(b) = std::fs::read(path) else { return 0 };
    let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap()) as usize;
    let (mut pos, mut frames) = (8, 0);
    while pos + 16 <= b.len() {
        let end = pos + 16 + u32_at(pos + 4) + u32_at(pos + 8);
        if end > b.len() {
            break;
        }
        frames += usize::from(u32_at(pos) == 2);
        pos = end;
    }
    frames
}

fn tmp(dir: &tempfile::TempDir, name: &str) -> PathBuf {
    dir.path().join(name)
}

#[test]
fn a_killed_bake_resumes_to_the_same_asset() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, cut) = (tmp(&dir, "whole.haze"), tmp(&dir, "cut.haze"));
    let s = |p: &Path| p.display().to_string();
    ok(&["bake", &plume(), "--out", &s(&whole)]);

    let journal = tmp(&dir, "cut.haze.partial");
    let mut child = Command::new(env!("CARGO_BIN_EXE_haze"))
        .args(["bake", &plume(), "--out", &s(&cut), "-q"])
        .spawn()
        .unwrap();
    let t = Instant::now();
    while journal_frames(&journal) < 3 {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the bake ended before it could be interrupted"
        );
        assert!(t.elapsed() < Duration::from_secs(120), "no progress");
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL: no chance to clean up
    child.wait().unwrap();
    let finished = journal_frames(&journal);
    assert!((3..8).contains(&finished), "{finished} frames finished");
    assert!(!cut.exists(), "an interrupted bake left an asset");

    let out = ok(&["bake", &plume(), "--out", &s(&cut), "--resume"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("resuming after"), "{err}");
    assert!(!journal.exists(), "the journal outlived the bake");
    // Same fitter state, same residuals, same hash volumes: the very same file.
    assert!(
        std::fs::read(&whole).unwrap() == std::fs::read(&cut).unwrap(),
        "the resumed asset differs from the uninterrupted one"
    );
}

#[test]
fn resume_refuses_other_settings_and_starts_over_without_a_journal() {
    let dir = tempfile::tempdir().unwrap();
    let out = tmp(&dir, "a.haze");
    let journal = tmp(&dir, "a.haze.partial");
    let o = out.display().to_string();
    // A journal from a bake of frames 21..22 with the default settings, interrupted just
    // before writing the asset: resuming with other settings is refused.
    ok(&[
        "bake",
        &plume(),
        "--frames",
        "21..22",
        "--rbfs",
        "40",
        "--out",
        &o,
    ]);
    let bytes = std::fs::read(&out).unwrap();
    std::fs::remove_file(&out).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_haze"))
        .args([
            "bake",
            &plume(),
            "--frames",
            "21..28",
            "--rbfs",
            "40",
            "--out",
            &o,
            "-q",
        ])
        .spawn()
        .unwrap();
    while journal_frames(&journal) < 1 {
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let err = fails(
        &[
            "bake",
            &plume(),
            "--frames",
            "21..28",
            "--rbfs",
            "41",
            "--out",
            &o,
            "--resume",
        ],
        &journal,
    );
    assert!(err.contains("RBF count"), "{err}");
    let err = fails(
        &[
            "bake",
            &plume(),
            "--frames",
            "21..27",
            "--rbfs",
            "40",
            "--out",
            &o,
            "--resume",
        ],
        &journal,
    );
    assert!(err.contains("input frames"), "{err}");
    assert!(journal.exists(), "a refused resume must keep the journal");
    // No journal: --resume bakes from the first frame.
    std::fs::remove_file(&journal).unwrap();
    ok(&[
        "bake",
        &plume(),
        "--frames",
        "21..22",
        "--rbfs",
        "40",
        "--out",
        &o,
        "--resume",
    ]);
    assert!(std::fs::read(&out).unwrap() == bytes);
}

#[test]
fn chunks_merge_in_frame_order_and_mismatches_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp(&dir, n).display().to_string();
    let bake = |frames: &str, out: &str, extra: &[&str]| {
        let (input, o) = (plume(), p(out));
        let mut a = vec![
            "bake", &input, "--frames", frames, "--rbfs", "60", "--out", &o,
        ];
        a.extend_from_slice(extra);
        ok(&a);
    };
    bake("21..23", "c1.haze", &[]);
    bake("24..28", "c2.haze", &[]);
    // Given out of order: merged by frame number.
    let out = ok(&["merge", &p("c2.haze"), &p("c1.haze"), "--out", &p("m.haze")]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("8 frames (21..28) from 2 chunks"));
    let j: serde_json::Value =
        serde_json::from_slice(&ok(&["inspect", &p("m.haze"), "--json"]).stdout).unwrap();
    assert_eq!(j["header"]["frame_count"], 8);
    assert_eq!(j["frames"].as_array().map(Vec::len), Some(8));
    // Every frame of the merged asset reconstructs exactly as in its chunk.
    for (frame, chunk) in [
        (21, "c1.haze"),
        (23, "c1.haze"),
        (24, "c2.haze"),
        (28, "c2.haze"),
    ] {
        let f = frame.to_string();
        ok(&["export", &p("m.haze"), "--frame", &f, "--out", &p("m.npy")]);
        ok(&["export", &p(chunk), "--frame", &f, "--out", &p("c.npy")]);
        assert!(
            std::fs::read(p("m.npy")).unwrap() == std::fs::read(p("c.npy")).unwrap(),
            "frame {frame} differs from its chunk"
        );
    }

    // A chunk warmed up on the frames before it is fitted as in one bake of the whole
    // sequence: the same RBFs, so the same reconstruction, frame for frame.
    bake("24..28", "w2.haze", &["--warm-up", "3"]);
    bake("21..28", "all.haze", &[]);
    ok(&[
        "merge",
        &p("c1.haze"),
        &p("w2.haze"),
        "--out",
        &p("mw.haze"),
    ]);
    for frame in [24, 26, 28] {
        let f = frame.to_string();
        ok(&["export", &p("mw.haze"), "--frame", &f, "--out", &p("w.npy")]);
        ok(&[
            "export",
            &p("all.haze"),
            "--frame",
            &f,
            "--out",
            &p("a.npy"),
        ]);
        ok(&["export", &p("m.haze"), "--frame", &f, "--out", &p("m.npy")]);
        let (w, a, m) = (
            std::fs::read(p("w.npy")).unwrap(),
            std::fs::read(p("a.npy")).unwrap(),
            std::fs::read(p("m.npy")).unwrap(),
        );
        assert!(
            w == a,
            "frame {frame}: the warmed chunk differs from one bake"
        );
        // Cold, the chunk's frames are fitted otherwise (so the test can tell).
        assert!(m != a, "frame {frame}: a cold chunk equals one bake");
    }

    bake("26..28", "c3.haze", &[]);
    let err = fails(
        &["merge", &p("c1.haze"), &p("c3.haze"), "--out", &p("x.haze")],
        &tmp(&dir, "c3.haze"),
    );
    assert!(err.contains("frames 24..25 are in no chunk"), "{err}");
    let err = fails(
        &[
            "merge",
            &p("c1.haze"),
            &p("c2.haze"),
            &p("c3.haze"),
            "--out",
            &p("x.haze"),
        ],
        &tmp(&dir, "c3.haze"),
    );
    assert!(err.contains("overlap"), "{err}");
    bake("24..28", "c4.haze", &["--quant-bits", "6"]);
    let err = fails(
        &["merge", &p("c1.haze"), &p("c4.haze"), "--out", &p("x.haze")],
        &tmp(&dir, "c4.haze"),
    );
    assert!(err.contains("quant_bits differs"), "{err}");
    // A damaged chunk is named with its block, and nothing is written.
    let mut bytes = std::fs::read(p("c2.haze")).unwrap();
    bytes[200] ^= 0x10;
    std::fs::write(p("bad.haze"), &bytes).unwrap();
    let err = fails(
        &[
            "merge",
            &p("c1.haze"),
            &p("bad.haze"),
            "--out",
            &p("x.haze"),
        ],
        &tmp(&dir, "bad.haze"),
    );
    assert!(
        err.contains("checksum mismatch") && err.contains("block 0"),
        "{err}"
    );
    assert!(!tmp(&dir, "x.haze").exists());
}

/// Chunks of an OpenVDB sequence from another tool — no recorded domain, each frame's box
/// its own, the grid moving with the smoke — share the whole sequence's grid, so they
/// merge into the asset one bake of every frame makes (the same grid, the same frames).
#[test]
fn chunks_of_a_moving_grid_merge() {
    use haze_volume::{Bbox, Volume};
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    std::fs::create_dir(&src).unwrap();
    for n in 1..=4 {
        // A blob drifting +x in a 12 × 10 × 10 container that moves 2 voxels a frame.
        let (h, x0) = (0.1, 0.2 * f64::from(n));
        let bbox = Bbox::new([x0, 0.0, 0.0], [x0 + 1.2, 1.0, 1.0]);
        let data = (0..1200)
            .map(|i| {
                let (x, y, z) = ((i % 12) as f64, ((i / 12) % 10) as f64, (i / 120) as f64);
                let r2 =
                    (x - 5.0 - 0.3 * f64::from(n)).powi(2) + (y - 4.5).powi(2) + (z - 4.5).powi(2);
                let d = (-r2 / 6.0).exp() as f32;
                if d < 0.01 { 0.0 } else { d }
            })
            .collect();
        let v = Volume::new([12, 10, 10], bbox, data).unwrap();
        assert!((v.voxel_size()[0] - h).abs() < 1e-12);
        let bytes = haze_volume::export::vdb::to_bytes(&v).unwrap();
        std::fs::write(src.join(format!("blob_{n:03}.vdb")), bytes).unwrap();
    }
    let s = src.display().to_string();
    let (whole, a, b, merged) = (
        tmp(&dir, "whole.haze"),
        tmp(&dir, "a.haze"),
        tmp(&dir, "b.haze"),
        tmp(&dir, "merged.haze"),
    );
    let bake = |frames: &str, out: &Path| {
        ok(&[
            "bake",
            &s,
            "--frames",
            frames,
            "--rbfs",
            "20",
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
    };
    bake("1..4", &whole);
    bake("1..2", &a);
    bake("3..4", &b);
    ok(&[
        "merge",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    let (w, m) = (
        haze_asset::Asset::open(&whole).unwrap(),
        haze_asset::Asset::open(&merged).unwrap(),
    );
    let (gw, gm) = (&w.header().grid, &m.header().grid);
    // The container travels 6 voxels over the 12 a frame holds: 18 voxels along x.
    assert_eq!((gw.dims, gm.dims), ([18, 10, 10], [18, 10, 10]));
    let (bw, bm) = (
        Bbox::new(gw.bbox_min, gw.bbox_max),
        Bbox::new(gm.bbox_min, gm.bbox_max),
    );
    assert!(bw.approx_eq(&bm, 1e-12), "{bw:?} vs {bm:?}");
    assert_eq!((w.header().frame_count, m.header().frame_count), (4, 4));
}
