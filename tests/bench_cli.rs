//! `haze bench` end to end: the quick workload on whatever adapter is here (lavapipe in
//! CI), its table and JSON; and the one-line error where no adapter exists.

use assert_cmd::Command;

fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

#[test]
fn the_quick_bench_times_every_kind_of_frame_and_writes_json() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("bench.json");
    let out = haze()
        .args(["bench", "--quick", "--repeat", "1", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8(out.stdout).unwrap();
    assert!(table.starts_with("adapter: "), "{table}");
    for kind in ["| frame |", "| playback |", "| orbit |"] {
        assert!(table.contains(kind), "{kind} missing: {table}");
    }
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert!(!j["adapter"].as_str().unwrap().is_empty());
    assert_eq!(j["repeat"], 1);
    let rows = j["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["workload"]["rbfs"], 100);
    for kind in ["frame", "playback", "orbit"] {
        let t = &rows[0][kind];
        let ms = t["frame_ms"].as_f64().unwrap();
        assert!(ms > 0.0, "{kind}: {t}");
        // fps is the frame time's inverse, and the lighting is the frame less its view pass.
        assert!(
            (t["fps"].as_f64().unwrap() * ms / 1e3 - 1.0).abs() < 1e-9,
            "{t}"
        );
        assert!(t["lighting_ms"].as_f64().unwrap() <= ms);
    }
}

#[test]
fn without_an_adapter_the_bench_says_so_in_one_line() {
    // wgpu's WGPU_BACKEND names a backend this build does not have: no adapter.
    let out = haze()
        .env("WGPU_BACKEND", "gl")
        .args(["bench", "--quick"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    let ours: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("error: no GPU"))
        .collect();
    assert_eq!(ours.len(), 1, "{err}");
    assert!(!err.contains("panicked"), "{err}");
}
