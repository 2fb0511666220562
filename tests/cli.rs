//! End-to-end tests of the `haze` binary on the bundled sample in data/.

mod support;

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(rel)
}

fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

/// Runs `haze bake ARGS --out OUT --report REPORT`, expecting success: its stderr and the
/// report.
fn bake_with_report(args: &[&str], out: &Path, report: &Path) -> (String, serde_json::Value) {
    let run = haze()
        .arg("bake")
        .args(args)
        .args(["--out", out.to_str().unwrap()])
        .args(["--report", report.to_str().unwrap()])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stderr).to_string();
    assert!(run.status.success(), "{args:?}: {log}");
    let r = serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    (log, r)
}

/// Runs haze expecting failure; returns stderr after checking it is one line naming `file`,
/// with no panic or backtrace.
fn fails_with_one_line(args: &[&str], file: &Path) -> String {
    let out = haze().args(args).output().unwrap();
    assert!(!out.status.success(), "{args:?} succeeded");
    assert_eq!(out.status.code(), Some(1), "{args:?}");
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(
        err.contains(&file.display().to_string()),
        "file not named: {err}"
    );
    assert!(
        !err.contains("panicked") && !err.contains("RUST_BACKTRACE"),
        "{err}"
    );
    err
}

/// Writes a 2×2×2 raw frame `STEM.f32` with its sidecar over the unit cube.
fn write_cube(stem: &Path, v: &[f32; 8]) {
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(stem.with_extension("f32"), bytes).unwrap();
    std::fs::write(
        stem.with_extension("json"),
        r#"{"dims": [2, 2, 2], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1]}"#,
    )
    .unwrap();
}

/// `haze inspect PATH`'s text report, expecting success.
fn inspect_text(p: &Path) -> String {
    let out = support::succeeds(&["inspect", p.to_str().unwrap()]);
    String::from_utf8(out.stdout).unwrap()
}

fn json_of(args: &[&str]) -> serde_json::Value {
    let out = haze().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn inspect_vdb_reports_dims_range_and_grids() {
    let p = data("plume-a/vdb/fluid_data_0024.vdb");
    let j = json_of(&["inspect", p.to_str().unwrap(), "--json"]);
    assert_eq!(j["kind"], "file");
    assert_eq!(j["dims"], serde_json::json!([48, 48, 64]));
    assert_eq!(j["value_min"], 0.0);
    assert_eq!(j["value_max"], 1.0);
    assert_eq!(j["active_voxels"], 11593);
    assert_eq!(j["voxel_size"], serde_json::json!([0.0625, 0.0625, 0.0625]));
    assert_eq!(j["vdb"]["grids"].as_array().unwrap().len(), 5);
    assert_eq!(j["memory_bytes"], 48 * 48 * 64 * 4);
    assert!(
        j.get("samples").is_none(),
        "a VDB's grids say their own type"
    );
}

/// A mirrored grid (a negative scale) says so, in the text and the JSON; an unmirrored
/// one says nothing of it.
#[test]
fn inspect_says_a_grid_is_mirrored() {
    let p = data("synthetic/mirrored.vdb");
    let text = inspect_text(&p);
    assert!(
        text.contains("mirrored:   along x (a negative scale"),
        "{text}"
    );
    let j = json_of(&["inspect", p.to_str().unwrap(), "--json"]);
    assert_eq!(j["mirrored"], serde_json::json!(["x"]));
    let plain = data("synthetic/scale_map.vdb");
    assert!(!inspect_text(&plain).contains("mirrored"));
    let j = json_of(&["inspect", plain.to_str().unwrap(), "--json"]);
    assert!(j.get("mirrored").is_none(), "{j}");
}

/// A frame of a Blender Adaptive Domain is read over the whole domain, and `inspect`
/// says where its block sat; the cache bakes as one grid.
#[test]
fn an_adaptive_domain_is_read_over_the_whole_domain() {
    let frame = data("blender-adaptive/adaptive/data/fluid_data_0001.vdb");
    let text = inspect_text(&frame);
    assert!(
        text.contains("placed:     a block of 13 × 14 × 13 cells at cell (8, 7, 0) of an Adaptive Domain of 21 × 21 × 32")
            && text.contains("config_0001.uni")
            && text.contains("dims:       21 × 21 × 32"),
        "{text}"
    );
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("a.haze");
    let folder = data("blender-adaptive/adaptive/data");
    support::succeeds(&[
        "bake",
        folder.to_str().unwrap(),
        "--rbfs",
        "20",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]);
    let j = json_of(&["inspect", out.to_str().unwrap(), "--json"]);
    assert_eq!(
        j["header"]["grid"]["dims"],
        serde_json::json!([21, 21, 32]),
        "{j}"
    );
    assert_eq!(j["header"]["frame_count"], 2);
}

/// A volume format haze does not read (NanoVDB, Houdini geometry) is named, with how to
/// get OpenVDB from it, by `inspect` and `bake` alike.
#[test]
fn a_foreign_volume_format_says_how_to_convert_it() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, kind, how) in [
        ("smoke.nvdb", "NanoVDB", "nanovdb_convert"),
        ("smoke.bgeo.sc", "Houdini geometry", "Convert VDB"),
    ] {
        let file = tmp.path().join(name);
        std::fs::write(&file, b"not read").unwrap();
        let f = file.to_str().unwrap();
        let out = tmp.path().join("o.haze");
        for args in [
            vec!["inspect", f],
            vec!["bake", f, "-q", "--out", out.to_str().unwrap()],
        ] {
            let err = fails_with_one_line(&args, &file);
            assert!(err.contains(kind) && err.contains(how), "{args:?}: {err}");
        }
        assert!(!out.exists());
    }
}

/// An 8-bit raw volume is read as fractions of 255, and `inspect` says so.
#[test]
fn inspect_says_how_integer_samples_are_read() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("u8.raw");
    std::fs::write(&p, [0u8, 51, 102, 255]).unwrap();
    std::fs::write(
        p.with_extension("json"),
        r#"{"dims": [2, 2, 1], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1], "dtype": "uint8"}"#,
    )
    .unwrap();
    let j = json_of(&["inspect", p.to_str().unwrap(), "--json"]);
    assert_eq!(j["samples"], "uint8");
    assert_eq!(j["value_max"], 1.0);
    let text = inspect_text(&p);
    assert!(
        text.contains("samples:    uint8, read as fractions of 255"),
        "{text}"
    );
}

#[test]
fn inspect_text_output_is_readable() {
    let text = inspect_text(&data("plume-a/vdb/fluid_data_0024.vdb"));
    for needle in [
        "48 × 48 × 64",
        "values:",
        "11593 voxels",
        "grid:       velocity",
    ] {
        assert!(text.contains(needle), "missing {needle}: {text}");
    }
}

/// An empty grid (a simulation's first frames) has no voxel size and no values to show.
#[test]
fn inspect_of_an_empty_grid_says_it_is_empty() {
    let text = inspect_text(&data("synthetic/empty.vdb"));
    assert!(text.contains("(0 voxels)"), "{text}");
    assert!(text.contains("voxel size: none (no voxels)"), "{text}");
    assert!(text.contains("values:     none (an empty frame)"), "{text}");
}

#[test]
fn inspect_raw_with_sidecar_and_domain_offset() {
    let raw = data("plume-a/dense/density_0024.f32");
    let j = json_of(&["inspect", raw.to_str().unwrap(), "--json"]);
    assert_eq!(j["format"], "raw");
    assert_eq!(j["samples"], "float32");
    assert_eq!(j["bbox_min"], serde_json::json!([-1.5, -1.5, 0.0]));
    assert!((j["value_sum"].as_f64().unwrap() - 3606.951126572968).abs() < 1e-9);
    let vdb = data("plume-a/vdb/fluid_data_0024.vdb");
    let j = json_of(&[
        "inspect",
        vdb.to_str().unwrap(),
        "--json",
        "--domain-offset",
        "-1.5,-1.5,0",
    ]);
    assert_eq!(j["bbox_min"], serde_json::json!([-1.5, -1.5, 0.0]));
    assert_eq!(j["bbox_max"], serde_json::json!([1.5, 1.5, 4.0]));
    // The offset and the grid are OpenVDB's: asked of the raw file, refused, not ignored.
    let r = raw.to_str().unwrap();
    let e = fails_with_one_line(&["inspect", r, "--domain-offset", "1,0,0"], &raw);
    assert!(e.contains("a domain offset asked of a raw volume"), "{e}");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x.haze");
    let e = fails_with_one_line(
        &["bake", r, "--grid", "flame", "--out", out.to_str().unwrap()],
        &raw,
    );
    assert!(e.contains("grid 'flame' asked of a raw volume"), "{e}");
    // Nor of an asset, whose frames were read from their grid when it was made.
    let asset = data("scenes/plume.haze");
    let a = asset.to_str().unwrap();
    let e = fails_with_one_line(&["inspect", a, "--grid", "flame"], &asset);
    assert!(e.contains("grid 'flame' asked of a .haze asset"), "{e}");
    let png = tmp.path().join("o.png");
    let e = fails_with_one_line(
        &[
            "render",
            a,
            "--domain-offset",
            "0,0,1",
            "--out",
            png.to_str().unwrap(),
        ],
        &asset,
    );
    assert!(e.contains("a domain offset asked of a .haze asset"), "{e}");
}

#[test]
fn inspect_sequence_counts_frames_and_gaps() {
    let dir = data("plume-a/vdb");
    let j = json_of(&["inspect", dir.to_str().unwrap(), "--json"]);
    assert_eq!(j["kind"], "sequence");
    assert_eq!(j["frames"], 8);
    assert_eq!(j["first_frame"], 21);
    assert_eq!(j["gaps"], serde_json::json!([]));
    assert_eq!(j["per_frame"][3]["active_voxels"], 11593);

    // A copy with frames 23 and 26..27 missing, selected by glob.
    let tmp = tempfile::tempdir().unwrap();
    for n in [21, 22, 24, 25, 28] {
        let name = format!("fluid_data_00{n}.vdb");
        std::fs::copy(dir.join(&name), tmp.path().join(&name)).unwrap();
    }
    let pattern = tmp.path().join("fluid_data_*.vdb");
    let j = json_of(&["inspect", pattern.to_str().unwrap(), "--json"]);
    assert_eq!(j["frames"], 5);
    assert_eq!(j["gaps"], serde_json::json!([[23, 23], [26, 27]]));
    assert_eq!(j["missing_frames"], 3);
    let j = json_of(&[
        "inspect",
        tmp.path().to_str().unwrap(),
        "--json",
        "--frames",
        "24..25",
    ]);
    assert_eq!(j["frames"], 2);
}

#[test]
fn pack_then_inspect_asset_and_read_it_back() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("plume.haze");
    let dir = data("plume-a/vdb");
    haze()
        .args([
            "pack",
            dir.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--frames",
            "23..25",
        ])
        .assert()
        .success();
    let j = json_of(&["inspect", out.to_str().unwrap(), "--json"]);
    assert_eq!(j["kind"], "asset");
    assert_eq!(j["header"]["frame_count"], 3);
    assert_eq!(
        j["header"]["source"]["frame_numbers"],
        serde_json::json!([23, 24, 25])
    );
    assert_eq!(j["blocks_by_kind"]["raw-volume"]["blocks"], 3);
    assert_eq!(j["checksums_verified"], true);

    // Frame 24 in the asset is bit-identical to OpenVDB's dense export.
    let asset = haze_asset::Asset::open(&out).unwrap();
    let f = asset.frame(1).unwrap();
    let raw =
        haze_asset::decode_raw_volume(f.find(haze_asset::BlockKind::RawVolume).unwrap().bytes)
            .unwrap();
    let truth = std::fs::read(data("plume-a/dense/density_0024.f32")).unwrap();
    let got: Vec<u8> = raw.data.iter().flat_map(|v| v.to_le_bytes()).collect();
    assert!(got == truth);

    // Every command takes the packed asset: export gives the frame back bit for bit,
    // render fits it as it fits a volume file (300 RBFs), and the viewer plays it as
    // packed.
    let f32 = tmp.path().join("f24.f32");
    haze()
        .args(["export", out.to_str().unwrap(), "--frame", "24"])
        .args(["--out", f32.to_str().unwrap()])
        .assert()
        .success();
    assert!(std::fs::read(&f32).unwrap() == truth);
    // Without --frame every frame comes out, numbered: frame 24 the same bytes, the
    // sidecars beside them, and the sequence reads back as three frames 23..25.
    let seq = tmp.path().join("seq");
    std::fs::create_dir(&seq).unwrap();
    let o = haze()
        .args(["export", out.to_str().unwrap()])
        .args(["--out", seq.join("vol.f32").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("3 frames (23..25) written: "));
    assert!(std::fs::read(seq.join("vol_0024.f32")).unwrap() == truth);
    assert!(seq.join("vol_0025.json").is_file());
    let j = json_of(&["inspect", seq.to_str().unwrap(), "--json"]);
    assert_eq!(
        (&j["frames"], &j["first_frame"]),
        (&3.into(), &23.into()),
        "{j}"
    );
    let e = fails_with_one_line(
        &[
            "export",
            out.to_str().unwrap(),
            "--frames",
            "40..50",
            "--out",
            seq.join("none.npy").to_str().unwrap(),
        ],
        &out,
    );
    assert!(
        e.contains("no frame in 40..50 (the asset holds frames 23..25)"),
        "{e}"
    );
    let png = tmp.path().join("r.png");
    let o = haze()
        .args(["render", out.to_str().unwrap(), "--frame", "24"])
        .args([
            "--width",
            "16",
            "--height",
            "12",
            "--out",
            png.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(png.is_file());
    let o = haze()
        .args([
            "view",
            out.to_str().unwrap(),
            "--no-window",
            "--play-for",
            "0.1",
            "--size",
            "32x24",
        ])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(String::from_utf8_lossy(&o.stdout).contains(" shown, "));

    // `haze bake` takes the packed asset as it takes the files it was packed from: the
    // same frames baked either way reconstruct bit for bit alike; a baked asset is no
    // input, and the error says what to bake instead.
    let bake = |input: &Path, name: &str| {
        let asset = tmp.path().join(name);
        haze()
            .args([
                "bake",
                input.to_str().unwrap(),
                "--frames",
                "24..25",
                "--rbfs",
                "40",
            ])
            .args(["--out", asset.to_str().unwrap()])
            .assert()
            .success();
        let f = tmp.path().join(format!("{name}.f32"));
        haze()
            .args(["export", asset.to_str().unwrap(), "--frame", "25"])
            .args(["--out", f.to_str().unwrap()])
            .assert()
            .success();
        (asset, std::fs::read(&f).unwrap())
    };
    let (baked, from_packed) = bake(&out, "from_packed.haze");
    let (_, from_files) = bake(&dir, "from_files.haze");
    assert!(from_packed == from_files);
    let e = fails_with_one_line(
        &[
            "bake",
            baked.to_str().unwrap(),
            "--out",
            tmp.path().join("again.haze").to_str().unwrap(),
        ],
        &baked,
    );
    assert!(
        e.contains("has no raw volume") && e.contains("bake its source"),
        "{e}"
    );
}

#[test]
fn bad_inputs_fail_with_one_line_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let t = |name: &str| tmp.path().join(name);

    // A truncated VDB.
    let vdb = std::fs::read(data("plume-a/vdb/fluid_data_0024.vdb")).unwrap();
    std::fs::write(t("cut.vdb"), &vdb[..vdb.len() / 3]).unwrap();
    let e = fails_with_one_line(&["inspect", t("cut.vdb").to_str().unwrap()], &t("cut.vdb"));
    assert!(e.contains("truncated"), "{e}");

    // A VDB without the requested grid.
    let p = data("plume-a/vdb/fluid_data_0024.vdb");
    let e = fails_with_one_line(&["inspect", p.to_str().unwrap(), "--grid", "smoke"], &p);
    assert!(e.contains("no grid named 'smoke'"), "{e}");

    // A sidecar whose dims disagree with the file size.
    std::fs::write(t("d.f32"), vec![0u8; 4 * 10]).unwrap();
    std::fs::write(
        t("d.json"),
        r#"{"dims": [2, 2, 3], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1]}"#,
    )
    .unwrap();
    let e = fails_with_one_line(&["inspect", t("d.f32").to_str().unwrap()], &t("d.f32"));
    assert!(e.contains("need 48 bytes") && e.contains("40 bytes"), "{e}");

    // A raw file containing NaN.
    let mut nan = [0f32; 12];
    nan[7] = f32::NAN;
    std::fs::write(
        t("n.f32"),
        nan.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>(),
    )
    .unwrap();
    std::fs::write(
        t("n.json"),
        r#"{"dims": [2, 2, 3], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1]}"#,
    )
    .unwrap();
    let e = fails_with_one_line(&["inspect", t("n.f32").to_str().unwrap()], &t("n.f32"));
    // Where the voxel lies: its centre in the sidecar's box, (1.5, 1.5, 1.5)·(1/2, 1/2, 1/3).
    assert!(
        e.contains("voxel (1, 1, 1) centred at world (0.75, 0.75, 0.5) is NaN"),
        "{e}"
    );

    // A truncated and a bit-flipped .haze.
    let asset = t("a.haze");
    let o = haze()
        .args([
            "pack",
            data("plume-a/vdb").to_str().unwrap(),
            "--frames",
            "21..22",
        ])
        .args(["--out", asset.to_str().unwrap()])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success()
            && said.contains("a.haze: 2 frames (21..22) of 48 × 48 × 64 packed losslessly, ")
            && !said.contains("all zero"),
        "{said}"
    );
    let bytes = std::fs::read(&asset).unwrap();
    std::fs::write(t("cut.haze"), &bytes[..bytes.len() - 100]).unwrap();
    let e = fails_with_one_line(
        &["inspect", t("cut.haze").to_str().unwrap()],
        &t("cut.haze"),
    );
    assert!(e.contains("truncated"), "{e}");
    let mut flipped = bytes.clone();
    flipped[64 + 5000] ^= 0x10;
    std::fs::write(t("flip.haze"), &flipped).unwrap();
    let e = fails_with_one_line(
        &["inspect", t("flip.haze").to_str().unwrap()],
        &t("flip.haze"),
    );
    assert!(
        e.contains("block 0 (raw-volume, frame 0): checksum mismatch"),
        "{e}"
    );

    // A missing file, and an unknown file type.
    let e = fails_with_one_line(
        &["inspect", t("nope.vdb").to_str().unwrap()],
        &t("nope.vdb"),
    );
    assert!(e.contains("no such file"), "{e}");
    // Every kind says it alike (an asset said "No such file or directory (os error 2)").
    for name in ["nope.haze", "nope.exr"] {
        let e = fails_with_one_line(&["inspect", t(name).to_str().unwrap()], &t(name));
        assert!(e.ends_with(": no such file or directory\n"), "{e}");
    }
    std::fs::write(t("x.txt"), "hello").unwrap();
    let e = fails_with_one_line(&["inspect", t("x.txt").to_str().unwrap()], &t("x.txt"));
    assert!(
        e.contains("unknown file type") && e.contains(".haze assets") && e.contains(".hdr"),
        "{e}"
    );
}

#[test]
fn pack_failure_leaves_no_output() {
    let tmp = tempfile::tempdir().unwrap();
    // Frame 2 has NaN: packing stops there and writes nothing.
    for (n, bad) in [(1, false), (2, true)] {
        let mut v = [0.5f32; 8];
        if bad {
            v[3] = f32::INFINITY;
        }
        write_cube(&tmp.path().join(format!("f_{n}")), &v);
    }
    let out = tmp.path().join("out").join("s.haze");
    std::fs::create_dir(tmp.path().join("out")).unwrap();
    let pattern = tmp.path().join("*.f32");
    let e = fails_with_one_line(
        &[
            "pack",
            pattern.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &tmp.path().join("f_2.f32"),
    );
    assert!(e.contains("is inf"), "{e}");
    assert_eq!(
        std::fs::read_dir(tmp.path().join("out")).unwrap().count(),
        0
    );
    // An asset named other than .haze would be refused by every command that reads one:
    // it is refused before the work.
    let bin = tmp.path().join("out").join("s.bin");
    let e = fails_with_one_line(
        &[
            "pack",
            pattern.to_str().unwrap(),
            "--out",
            bin.to_str().unwrap(),
        ],
        &bin,
    );
    assert!(e.contains("--out must end in .haze"), "{e}");
}

#[test]
fn help_explains_commands() {
    let out = haze().arg("--help").output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("inspect") && text.contains("pack"));
    let out = haze().args(["inspect", "--help"]).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("--grid") && text.contains("--domain-offset") && text.contains("glob"));
}

#[test]
fn bake_writes_rbfs_report_and_inspectable_asset() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("plume.haze");
    let report = tmp.path().join("report.json");
    let dir = data("plume-a/vdb");
    haze()
        .args([
            "bake",
            dir.to_str().unwrap(),
            "--frames",
            "21..23",
            "--rbfs",
            "80",
        ])
        .args(["--max-iterations", "200", "--out", out.to_str().unwrap()])
        .args(["--report", report.to_str().unwrap()])
        .assert()
        .success();
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let frames = r["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    for f in frames {
        for key in [
            "frame",
            "rbfs",
            "rel_l2",
            "rms_over_max",
            "fit_seconds",
            "iterations",
            "teleports",
        ] {
            assert!(!f[key].is_null(), "report lacks {key}: {f}");
        }
        assert!(f["rel_l2"].as_f64().unwrap() > 0.0 && f["rel_l2"].as_f64().unwrap() < 0.5);
    }
    assert_eq!(frames[0]["rbfs"], 80);
    assert_eq!(frames[1]["deleted"], 3);
    // Why insertion stopped: none on a first frame, whose marginal gain sets the price.
    assert!(frames[0]["insertion_stop"].is_null());
    assert!(frames[0]["gain_floor"].as_f64().unwrap() > 0.0);
    let reasons = [
        "target-met",
        "marginal-gain",
        "stalled",
        "nowhere",
        "cap",
        "ceiling",
    ];
    for f in &frames[1..] {
        let stop = f["insertion_stop"].as_str().unwrap();
        assert!(reasons.contains(&stop), "{stop}");
        let over = f["error_ratio"].as_f64().unwrap() > 1.1;
        assert_eq!(stop != "target-met", over, "{f}");
    }
    assert!(r["temporal"]["frames_marginal_gain"].as_u64().is_some());
    assert!(r["totals"]["seconds"].as_f64().unwrap() > 0.0);
    assert_eq!(
        r["totals"]["bytes"].as_u64().unwrap(),
        std::fs::metadata(&out).unwrap().len()
    );
    assert!(r["temporal"]["mean_center_displacement"].as_f64().is_some());

    let j = json_of(&["inspect", out.to_str().unwrap(), "--json"]);
    assert_eq!(j["blocks_by_kind"]["rbfs"]["blocks"], 3);
    // Decoded, the RBFs take 32 bytes each on the GPU, more than their coded block.
    let rbfs: u64 = (0..3)
        .map(|k| j["frames"][k]["rbfs"].as_u64().unwrap())
        .sum();
    let kind = &j["blocks_by_kind"]["rbfs"];
    assert_eq!(kind["decoded_bytes"].as_u64().unwrap(), 32 * rbfs);
    assert!(kind["bytes"].as_u64().unwrap() < 32 * rbfs, "{kind}");
    assert_eq!(j["frames"][0]["rbfs"], 80);
    assert_eq!(j["frames"][2]["frame"], 23);
    let asset = haze_asset::Asset::open(&out).unwrap();
    let rbfs = haze_asset::decode_rbfs(
        asset
            .frame(0)
            .unwrap()
            .find(haze_asset::BlockKind::Rbfs)
            .unwrap()
            .bytes,
    )
    .unwrap();
    assert_eq!(rbfs.len(), 80);
    // Inside the grid's box, radii within the default bounds (0.015..0.09 of 4 world units).
    for b in &rbfs {
        assert!(
            b.center
                .iter()
                .zip([3.0, 3.0, 4.0])
                .all(|(c, hi)| *c >= 0.0 && *c <= hi)
        );
        assert!(b.radius >= 0.06 * (1.0 - 1e-6) && b.radius <= 0.36 * (1.0 + 1e-6));
    }
}

/// A frame left over the threshold at the RBF ceiling is logged at `-v` naming the
/// ceiling, and the report marks it capped with `insertion_stop` "ceiling".
#[test]
fn bake_logs_and_reports_a_frame_capped_at_the_ceiling() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("plume.haze");
    let report = tmp.path().join("report.json");
    let dir = data("plume-a/vdb");
    // Threshold 1 and a ceiling at the first frame's count: a warm frame of the growing
    // plume over the first frame's error can only put back the 3 RBFs it deleted.
    let run = haze()
        .args(["bake", dir.to_str().unwrap(), "--frames", "21..23"])
        .args(["--rbfs", "40", "--max-rbfs", "40", "--threshold", "1"])
        .args(["--max-iterations", "100", "--out", out.to_str().unwrap()])
        .args(["--report", report.to_str().unwrap(), "-v"])
        .output()
        .unwrap();
    assert!(run.status.success());
    let log = String::from_utf8_lossy(&run.stderr);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let frames = r["frames"].as_array().unwrap();
    let over: Vec<_> = frames[1..]
        .iter()
        .filter(|f| f["error_ratio"].as_f64().unwrap() > 1.0)
        .collect();
    assert!(!over.is_empty(), "no frame over the threshold: {r}");
    for f in &over {
        assert_eq!(f["insertion_stop"], "ceiling", "{f}");
        assert_eq!(f["insertion_capped"], true, "{f}");
        assert_eq!(f["rbfs"], 40, "{f}");
        let line = format!("frame {}: error ratio", f["frame"]);
        assert!(
            log.lines().any(|l| l.contains("INFO")
                && l.contains(&line)
                && l.contains("at the ceiling of 40 RBFs")),
            "no ceiling detail for frame {}: {log}",
            f["frame"]
        );
    }
    assert_eq!(r["temporal"]["frames_capped"], over.len());
    // The last line counts them.
    let worst = over
        .iter()
        .map(|f| f["error_ratio"].as_f64().unwrap())
        .fold(0.0, f64::max);
    let n = over.len();
    let count = format!(
        "{n} frame{} over the threshold ratio",
        if n == 1 { "" } else { "s" }
    );
    let summary = log.lines().last().unwrap_or("");
    assert!(
        summary.contains(&count)
            && summary.contains(&format!("worst {worst:.3}; {n} at the --max-rbfs ceiling")),
        "{summary}"
    );
}

/// Warm frames of wide RBFs on a 64³ grid walk on the half-resolution grid first and the
/// summary line says so; `--warm-coarse off` keeps them at full resolution, and the
/// report counts the coarse iterations either way.
#[test]
fn bake_says_which_warm_frames_went_coarse_first() {
    let tmp = tempfile::tempdir().unwrap();
    let n = 64;
    // Two blobs of radius ~6 voxels, moving a voxel and a half between frames.
    for (k, shift) in [0.0f32, 1.5].into_iter().enumerate() {
        let mut v = Vec::with_capacity(n * n * n);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = [x, y, z].map(|i| i as f32);
                    let blob = |c: [f32; 3]| {
                        let d2: f32 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum();
                        (-d2 / 36.0).exp()
                    };
                    v.push(
                        blob([24.0 + shift, 30.0, 28.0]) + 0.6 * blob([40.0, 34.0 - shift, 36.0]),
                    );
                }
            }
        }
        support::write_npy(&tmp.path().join(format!("frame_{k}.npy")), [n; 3], &v);
    }
    let input = tmp.path().join("frame_*.npy");
    let bake = |coarse: &str| {
        let out = tmp.path().join(format!("{coarse}.haze"));
        let report = tmp.path().join(format!("{coarse}.json"));
        let (log, r) = bake_with_report(
            &[
                input.to_str().unwrap(),
                "--rbfs",
                "6",
                "--warm-coarse",
                coarse,
            ],
            &out,
            &report,
        );
        let summary = log.lines().last().unwrap_or("").to_string();
        (
            summary,
            r["frames"][1]["coarse_iterations"].as_u64().unwrap(),
        )
    };
    let (summary, iterations) = bake("auto");
    assert!(iterations > 0, "{summary}");
    assert!(
        summary.contains("1 of 1 warm frames minimized on the half-resolution grid first"),
        "{summary}"
    );
    let (summary, iterations) = bake("off");
    assert_eq!(iterations, 0, "{summary}");
    assert!(!summary.contains("half-resolution"), "{summary}");
}

#[test]
fn bake_with_target_error_picks_the_count() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("t.haze");
    let report = tmp.path().join("t.json");
    haze()
        .args([
            "bake",
            data("plume-a/vdb").to_str().unwrap(),
            "--frames",
            "21",
        ])
        .args([
            "--target-error",
            "0.3",
            "--no-teleport",
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--report", report.to_str().unwrap()])
        .assert()
        .success();
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let search = &r["settings"]["search"];
    assert_eq!(search["reached"], true);
    let chosen = search["rbfs"].as_u64().unwrap();
    // The chosen count reached the target; every smaller probe missed it.
    for p in search["probes"].as_array().unwrap() {
        let (n, e) = (p["rbfs"].as_u64().unwrap(), p["rel_l2"].as_f64().unwrap());
        if n == chosen {
            assert!(e <= 0.3);
        }
        if n < chosen {
            assert!(e > 0.3, "{n} RBFs reached {e}");
        }
    }
    assert_eq!(r["frames"][0]["rbfs"].as_u64().unwrap(), chosen);
}

#[test]
fn bake_refuses_bad_arguments_and_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x.haze");
    let dir = data("plume-a/vdb");
    for bad in [
        vec!["--rbfs", "0"],
        vec!["--target-error", "0"],
        vec!["--target-error", "1.5"],
        vec!["--threshold", "0.9"],
        vec!["--marginal-gain=-0.5"],
        vec!["--marginal-gain", "inf"],
        vec!["--tolerance", "0"],
        vec!["--radius-min", "0.2", "--radius-max", "0.1"],
    ] {
        let o = haze()
            .args([
                "bake",
                dir.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .args(&bad)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{bad:?}");
        let err = String::from_utf8(o.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{bad:?}: {err}");
    }
    let o = haze()
        .args([
            "bake",
            dir.to_str().unwrap(),
            "--rbfs",
            "3",
            "--target-error",
            "0.1",
        ])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!o.status.success(), "--rbfs with --target-error");
    assert!(!out.exists());
    // A NaN in the second frame: the bake stops there and writes nothing.
    let mut v = [0.25f32; 8];
    for n in [1, 2] {
        if n == 2 {
            v[5] = f32::NAN;
        }
        write_cube(&tmp.path().join(format!("s_{n}")), &v);
    }
    let pattern = tmp.path().join("s_*.f32");
    let e = fails_with_one_line(
        &[
            "bake",
            pattern.to_str().unwrap(),
            "--rbfs",
            "2",
            "--out",
            out.to_str().unwrap(),
        ],
        &tmp.path().join("s_2.f32"),
    );
    assert!(e.contains("NaN"), "{e}");
    assert!(!out.exists());
}

#[test]
fn bake_stores_the_residual_and_export_reconstructs_within_the_error() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("r.haze");
    let report = tmp.path().join("r.json");
    let error = 0.01;
    haze()
        .args([
            "bake",
            data("plume-a/vdb").to_str().unwrap(),
            "--frames",
            "23..24",
        ])
        .args(["--rbfs", "60", "--no-teleport", "--max-iterations", "100"])
        .args(["--residual-error", &error.to_string()])
        .args([
            "--out",
            out.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ])
        .assert()
        .success();
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let f24 = &r["frames"][1];
    for key in [
        "residual_nonzero",
        "residual_bricks",
        "residual_target",
        "rbf_max_error",
        "rbfs_meet_error",
        "rbf_share_within_error",
        "quant_widened",
        "hash_bytes",
        "hash_seconds",
        "quant_step",
    ] {
        assert!(!f24[key].is_null(), "report lacks {key}");
    }
    let target = f24["residual_target"].as_f64().unwrap();
    assert!(f24["residual_bricks"].as_u64().unwrap() > 0);
    let share = f24["rbf_share_within_error"].as_f64().unwrap();
    assert!(share > 0.0 && share < 1.0, "share {share}");
    let j = json_of(&["inspect", out.to_str().unwrap(), "--json"]);
    assert_eq!(j["blocks_by_kind"]["residual-hash"]["blocks"], 1);
    // Export frame 24 and compare with OpenVDB's dense export of the input.
    let exported = tmp.path().join("f24.f32");
    haze()
        .args(["export", out.to_str().unwrap(), "--frame", "24"])
        .args(["--out", exported.to_str().unwrap()])
        .assert()
        .success();
    let a = std::fs::read(&exported).unwrap();
    let b = std::fs::read(data("plume-a/dense/density_0024.f32")).unwrap();
    assert_eq!(a.len(), b.len());
    let f = |c: &[u8]| f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
    let worst = a
        .chunks_exact(4)
        .zip(b.chunks_exact(4))
        .map(|(x, y)| (f(x) - f(y)).abs())
        .fold(0.0, f64::max);
    let peak = b.chunks_exact(4).map(f).fold(0.0, f64::max);
    assert!(
        (target - error * peak).abs() <= 1e-9 * peak,
        "target {target}"
    );
    // The error asked for, plus the f32 rounding of D̃ + R̂ (6e-8 of the peak).
    assert!(worst <= target + 1e-6, "worst {worst}, target {target}");
    // No negative values (the density every renderer takes), so the export bakes again.
    assert!(a.chunks_exact(4).all(|c| f(c) >= 0.0));
    assert!(tmp.path().join("f24.json").exists());
    // .npy too, and a frame that is not there.
    let npy = tmp.path().join("f24.npy");
    haze()
        .args([
            "export",
            out.to_str().unwrap(),
            "--frame",
            "24",
            "--out",
            npy.to_str().unwrap(),
        ])
        .assert()
        .success();
    // .vdb: the same values, bit for bit, over the asset's box (read back by the importer).
    let vdb = tmp.path().join("f24.vdb");
    haze()
        .args(["export", out.to_str().unwrap(), "--frame", "24"])
        .args(["--out", vdb.to_str().unwrap()])
        .assert()
        .success();
    let back =
        haze_volume::import::vdb::read(&vdb, &haze_volume::ImportOptions::default(), None).unwrap();
    assert_eq!(back.volume.dims(), [48, 48, 64]);
    let want = haze_volume::Bbox::new([0.0; 3], [3.0, 3.0, 4.0]);
    assert!(back.volume.bbox().approx_eq(&want, 1e-12));
    let same = back
        .volume
        .data()
        .iter()
        .zip(a.chunks_exact(4))
        .all(|(v, c)| v.to_bits() == u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
    assert!(same, "the .vdb export differs from the .f32 one");
    let e = fails_with_one_line(
        &[
            "export",
            out.to_str().unwrap(),
            "--frame",
            "99",
            "--out",
            npy.to_str().unwrap(),
        ],
        &out,
    );
    assert!(
        e.contains("frame 99 is not in the asset (frames 23..24)"),
        "{e}"
    );
    // --quant-bits, --residual-error and --residual-brick out of range are refused by the
    // parser.
    for (flag, value) in [
        ("--quant-bits", "3"),
        ("--residual-error", "-0.1"),
        ("--residual-error", "nan"),
        ("--residual-brick", "3"),
    ] {
        let o = haze()
            .args(["bake", data("plume-a/vdb").to_str().unwrap(), flag, value])
            .args(["--out", out.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(!o.status.success(), "{flag} {value}");
    }
}

#[test]
fn frames_the_rbfs_alone_meet_store_no_residual() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("e.haze");
    let report = tmp.path().join("e.json");
    // An error of the whole peak: the RBFs alone meet it everywhere.
    haze()
        .args(["bake", data("plume-a/vdb").to_str().unwrap()])
        .args(["--frames", "23..24", "--rbfs", "40", "--no-teleport"])
        .args(["--max-iterations", "40", "--residual-error", "1"])
        .args(["--out", out.to_str().unwrap()])
        .args(["--report", report.to_str().unwrap()])
        .assert()
        .success();
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    for f in r["frames"].as_array().unwrap() {
        assert_eq!(f["rbfs_meet_error"], true);
        assert_eq!(f["residual_bricks"], 0);
        assert_eq!(f["rbf_share_within_error"], 1.0);
        assert!(f["rbf_max_error"].as_f64().unwrap() <= 1.0);
    }
    let j = json_of(&["inspect", out.to_str().unwrap(), "--json"]);
    assert!(j["blocks_by_kind"]["residual-hash"].is_null(), "{j}");
    // Export reconstructs D̃ alone.
    let exported = tmp.path().join("f24.f32");
    haze()
        .args(["export", out.to_str().unwrap(), "--frame", "24"])
        .args(["--out", exported.to_str().unwrap()])
        .assert()
        .success();
    assert!(exported.exists());
}

/// The CLI's defaults are the library's: a bake with no fitting flags records in its
/// report exactly `SequenceOptions::default()` (the first frame's and the warm frames'
/// stopping rules among them), so figures measured through the library hold for
/// `haze bake`.
#[test]
fn bake_defaults_are_the_librarys() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("d.haze");
    let report = tmp.path().join("d.json");
    let dir = data("plume-a/vdb");
    let (_, r) = bake_with_report(
        &[dir.to_str().unwrap(), "--frames", "21..22", "-q"],
        &out,
        &report,
    );
    let library = serde_json::to_value(haze_fit::SequenceOptions::default()).unwrap();
    assert_eq!(r["settings"]["options"], library);
}
