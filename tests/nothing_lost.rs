//! Nothing lost: no command overwrites one of its inputs or another of its outputs, an
//! output that cannot be written is refused before the work, and a failed run leaves
//! nothing behind (the classes "output = input", "report = asset", "failed bake
//! leaves OUT.partial", "report path fails after the whole bake", "a fogmap folder of
//! mixed sizes", a failed sweep's directory, and the images' mode). Every refusal is checked against the promise
//! (`support::refused`: exit 1 or 2, one line, no panic, the folder unchanged).

mod support;

use std::path::Path;
use support::*;

/// A folder with `v.npy` (16³), `v.f32` + `v.json`, a fogmap `f.png`, the bundled smoke
/// asset `a.haze` and the environment map `e.exr`.
fn inputs(d: &Path) {
    write_npy(&d.join("v.npy"), [16; 3], &blob(16));
    write_raw(&d.join("v"), 16, &blob(16));
    std::fs::copy(data("fogmap/fogmap_128.png"), d.join("f.png")).unwrap();
    std::fs::copy(data("scenes/plume.haze"), d.join("a.haze")).unwrap();
    std::fs::copy(data("scenes/glow_env.exr"), d.join("e.exr")).unwrap();
}

/// The 11 probes of "output = input destroys the input", and the same for every other
/// command and output kind: each refused before any work, naming the input.
#[test]
fn an_output_that_is_an_input_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    inputs(d);
    let p = |n: &str| d.join(n);
    let frames = p("frames");
    std::fs::create_dir(&frames).unwrap();
    for k in 1..=3 {
        write_npy(
            &frames.join(format!("fluid_data_{k:04}.npy")),
            [16; 3],
            &blob(16),
        );
    }
    std::fs::hard_link(p("v.npy"), p("hard.npy")).unwrap();
    std::os::unix::fs::symlink(p("v.npy"), p("soft.npy")).unwrap();
    let fogs = p("fogs");
    std::fs::create_dir(&fogs).unwrap();
    for k in 0..2 {
        std::fs::copy(p("f.png"), fogs.join(format!("x_{k:04}.png"))).unwrap();
    }
    let cases: Vec<Vec<String>> = vec![
        vec!["fog", "wavelet", s(&p("f.png")), "--out", s(&p("f.png"))],
        vec!["bake", s(&p("v.npy")), "--out", s(&p("v.npy"))],
        vec!["bake", s(&p("v.f32")), "--out", s(&p("v.json"))],
        vec!["bake", s(&p("v.f32")), "--out", s(&p("v.f32"))],
        vec![
            "pack",
            s(&frames),
            "--out",
            s(&frames.join("fluid_data_0002.npy")),
        ],
        vec![
            "bake",
            s(&p("v.npy")),
            "--out",
            s(&p("o.haze")),
            "--report",
            s(&p("v.npy")),
        ],
        vec!["bake", s(&p("v.npy")), "--out", s(&p("hard.npy"))],
        vec!["pack", s(&p("soft.npy")), "--out", s(&p("v.npy"))],
        vec![
            "export",
            s(&p("a.haze")),
            "--frame",
            "0",
            "--out",
            s(&p("a.haze")),
        ],
        vec!["merge", s(&p("a.haze")), "--out", s(&p("a.haze"))],
        vec![
            "render",
            s(&p("a.haze")),
            "--env",
            s(&p("e.exr")),
            "--out",
            s(&p("e.exr")),
        ],
        vec!["fog", "wavelet", s(&fogs), "--out", s(&fogs.join("x.png"))],
    ]
    .into_iter()
    .map(|v| v.into_iter().map(String::from).collect())
    .collect();
    for case in &cases {
        let args: Vec<&str> = case.iter().map(String::as_str).collect();
        let e = refused(d, &args);
        assert!(e.contains("is the input"), "{args:?}: {e}");
    }
    // tradeoff writes DIR/tradeoff.json: an input of that name is refused too.
    std::fs::copy(p("f.png"), p("pareto.png")).unwrap();
    let e = refused(d, &["tradeoff", s(&p("pareto.png")), "--out", s(d)]);
    assert!(e.contains("pareto.png: --out is the input"), "{e}");
}

/// An export never replaces the frames its asset was baked from: exported into the
/// cache's folder by the cache's own names (every frame numbered, or one), it is refused.
#[test]
fn an_export_named_like_the_assets_source_frames_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let frames = d.join("cache");
    std::fs::create_dir(&frames).unwrap();
    for k in 1..=2 {
        write_npy(
            &frames.join(format!("fluid_data_{k:04}.npy")),
            [16; 3],
            &blob(16),
        );
    }
    let asset = d.join("a.haze");
    haze()
        .args(["pack", s(&frames), "--out", s(&asset)])
        .assert()
        .success();
    for out in ["fluid_data_.npy", "fluid_data.npy"] {
        let out = frames.join(out);
        let e = refused(d, &["export", s(&asset), "--out", s(&out)]);
        assert!(e.contains("fluid_data_0001.npy: --out is the input"), "{e}");
    }
    let one = frames.join("fluid_data_0002.npy");
    let e = refused(d, &["export", s(&asset), "--frame", "2", "--out", s(&one)]);
    assert!(e.contains("--out is the input"), "{e}");
    // Beside them under other names it is written.
    let beside = frames.join("check_.vdb");
    haze()
        .args(["export", s(&asset), "--out", s(&beside)])
        .assert()
        .success();
    assert!(frames.join("check_0001.vdb").is_file() && frames.join("check_0002.vdb").is_file());
}

/// A scene's own files (here its environment map) are inputs as much as the scene.
#[test]
fn a_scene_render_never_replaces_a_file_the_scene_names() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(data("scenes/glow.json"), d.join("glow.json")).unwrap();
    std::fs::copy(data("scenes/glow_env.exr"), d.join("glow_env.exr")).unwrap();
    let text = std::fs::read_to_string(d.join("glow.json")).unwrap();
    assert!(text.contains("glow_env.exr"), "the scene names its map");
    let e = refused(
        d,
        &[
            "render",
            "--scene",
            s(&d.join("glow.json")),
            "--out",
            s(&d.join("glow_env.exr")),
        ],
    );
    assert!(e.contains("is the input"), "{e}");
    // The viewer's edits are saved into a copy, never over the scene.
    let scene = d.join("glow.json");
    let e = refused(
        d,
        &["view", "--scene", s(&scene), "--save-edits", s(&scene)],
    );
    assert!(e.contains("--save-edits is the input"), "{e}");
}

/// "report = asset": two outputs on one file.
#[test]
fn two_outputs_on_one_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_npy(&d.join("v.npy"), [16; 3], &blob(16));
    let (v, o) = (d.join("v.npy"), d.join("o.haze"));
    let e = refused(d, &["bake", s(&v), "--out", s(&o), "--report", s(&o)]);
    assert!(e.contains("--report is the same file as --out"), "{e}");
    let partial = d.join("o.haze.partial");
    let e = refused(d, &["bake", s(&v), "--out", s(&o), "--report", s(&partial)]);
    assert!(e.contains("the same file as the bake journal"), "{e}");
}

/// "report path fails after the whole bake": the folder of every output is checked before
/// the work, and nothing (no journal) is created.
#[test]
fn an_output_that_cannot_be_written_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_npy(&d.join("v.npy"), [16; 3], &blob(16));
    let (v, o) = (d.join("v.npy"), d.join("o.haze"));
    let e = refused(
        d,
        &["bake", s(&v), "--out", s(&o), "--report", "/proc/r.json"],
    );
    assert!(
        e.contains("/proc/r.json: --report cannot be written in /proc"),
        "{e}"
    );
    let missing = d.join("missing/r.json");
    let e = refused(d, &["bake", s(&v), "--out", s(&o), "--report", s(&missing)]);
    assert!(
        e.contains("--report's folder") && e.contains("does not exist"),
        "{e}"
    );
    let e = refused(
        d,
        &[
            "fog",
            "wavelet",
            s(&data("fogmap/fogmap_128.png")),
            "--out",
            s(&d.join("no/f.png")),
        ],
    );
    assert!(e.contains("does not exist"), "{e}");
    let e = refused(d, &["bake", s(&v), "--out", s(d)]);
    assert!(e.contains("--out is a directory"), "{e}");
}

/// "failed bake leaves OUT.partial": a bad voxel in the first frame fails the bake and
/// removes the journal it had started; a bad voxel in a later frame keeps the finished
/// frames for `--resume` and says so.
#[test]
fn a_failed_bake_leaves_no_journal_that_holds_nothing() {
    for (value, word) in [
        (f32::NAN, "NaN"),
        (f32::INFINITY, "inf"),
        (-1.0, "negative"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut v = blob(8);
        v[100] = value;
        write_raw(&d.join("f_0001"), 8, &v);
        let e = refused(
            d,
            &[
                "bake",
                s(&d.join("f_0001.f32")),
                "--rbfs",
                "2",
                "--out",
                s(&d.join("o.haze")),
            ],
        );
        assert!(e.contains("f_0001.f32") && e.contains(word), "{e}");
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for k in 1..=3 {
        let mut v = blob(8);
        if k == 3 {
            v[100] = f32::NAN;
        }
        write_raw(&d.join(format!("f_{k:04}")), 8, &v);
    }
    let out = haze()
        .args([
            "bake",
            s(&d.join("*.f32")),
            "--rbfs",
            "2",
            "--out",
            s(&d.join("o.haze")),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("f_0003.f32") && err.contains("2 finished frames kept in"),
        "{err}"
    );
    assert!(d.join("o.haze.partial").exists() && !d.join("o.haze").exists());
}

/// "a fogmap folder of mixed sizes": the frames written before the failing one are
/// removed.
#[test]
fn a_failed_fog_sequence_removes_its_first_frames() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fogs = d.join("fogs");
    std::fs::create_dir(&fogs).unwrap();
    std::fs::copy(data("fogmap/fogmap_128.png"), fogs.join("x_0000.png")).unwrap();
    image::GrayImage::from_pixel(64, 64, image::Luma([100u8]))
        .save(fogs.join("x_0001.png"))
        .unwrap();
    let out = d.join("out");
    std::fs::create_dir(&out).unwrap();
    let e = refused(
        d,
        &[
            "fog",
            "wavelet",
            s(&fogs),
            "--width",
            "16",
            "--height",
            "12",
            "--out",
            s(&out.join("x.png")),
        ],
    );
    assert!(e.contains("x_0001.png") && e.contains("64 × 64"), "{e}");
}

/// A sweep whose input cannot be read removes the `--out` directory it made (and its
/// parents); one that writes into the input's directory of frames is refused.
#[test]
fn a_failed_sweep_leaves_no_directory_and_frames_keep_their_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("broken.vdb"), b"not a volume").unwrap();
    let out = d.join("sweeps/broken");
    let e = refused(d, &["tradeoff", s(&d.join("broken.vdb")), "--out", s(&out)]);
    assert!(e.contains("broken.vdb"), "{e}");
    assert!(!d.join("sweeps").exists());

    let frames = d.join("frames");
    std::fs::create_dir(&frames).unwrap();
    for n in 0..2 {
        write_npy(&frames.join(format!("v_{n:04}.npy")), [16; 3], &blob(16));
    }
    let e = refused(d, &["tradeoff", s(&frames), "--out", s(&frames)]);
    assert!(
        e.contains("--out is the input's directory of frames"),
        "{e}"
    );
}

/// Images are written 0644 less the umask, like every other output (they were 0600).
#[test]
fn images_have_the_mode_of_other_outputs() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.json"), fog_scene(&analytic("0.3", "0.1"))).unwrap();
    let img = d.join("o.png");
    succeeds(&["render", "--scene", s(&d.join("s.json")), "--out", s(&img)]);
    let json = d.join("r.json");
    std::fs::write(&json, "{}").unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    // A file created by the test itself has the mode the umask allows; the image has it.
    assert_eq!(mode(&img), mode(&json) & 0o644, "{:o}", mode(&img));
    assert_ne!(mode(&img) & 0o044, 0, "{:o}", mode(&img));
}
