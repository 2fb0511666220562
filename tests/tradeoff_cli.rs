//! End-to-end tests of `haze tradeoff` (quick sweeps of a tiny puff and of the bundled
//! fogmap) and of `haze render --budget-ms/--target-error` choosing from a sweep.

use assert_cmd::Command;
use serde_json::Value;
use std::path::Path;

fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

fn ok(args: &[&str]) -> (String, String) {
    let o = haze().args(args).output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{args:?}: {err}");
    (String::from_utf8(o.stdout).unwrap(), err)
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
}

/// A 14³ Gaussian puff (σ = 0.35 of the half-side) as a raw volume with its sidecar.
fn puff(dir: &Path) -> String {
    let n = 14;
    let mut bytes = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let c = |i: usize| -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let r2 = c(x) * c(x) + c(y) * c(y) + c(z) * c(z);
                bytes.extend_from_slice(&((-r2 / 0.245).exp() as f32).to_le_bytes());
            }
        }
    }
    let raw = dir.join("puff.f32");
    std::fs::write(&raw, bytes).unwrap();
    std::fs::write(
        dir.join("puff.json"),
        r#"{"dims": [14, 14, 14], "world_bbox_min": [-1, -1, -1], "world_bbox_max": [1, 1, 1]}"#,
    )
    .unwrap();
    raw.display().to_string()
}

fn entries<'a>(doc: &'a Value, key: &str) -> &'a Vec<Value> {
    doc[key].as_array().unwrap()
}

fn point(e: &Value) -> (f64, f64) {
    (
        e["ms"]["render"].as_f64().unwrap(),
        e["error"].as_f64().unwrap(),
    )
}

/// The front of the file against its definition, recomputed from `settings`.
fn check_front(doc: &Value) {
    let settings: Vec<(f64, f64)> = entries(doc, "settings").iter().map(point).collect();
    let front: Vec<(f64, f64)> = entries(doc, "pareto").iter().map(point).collect();
    assert!(!front.is_empty());
    for w in front.windows(2) {
        assert!(
            w[0].0 <= w[1].0 && w[0].1 > w[1].1,
            "front not ordered: {w:?}"
        );
    }
    for f in &front {
        assert!(settings.contains(f));
        // Nothing measured is at least as fast and strictly more accurate, or faster and
        // as accurate.
        for s in &settings {
            assert!(
                !((s.0 <= f.0 && s.1 < f.1) || (s.0 < f.0 && s.1 <= f.1)),
                "{s:?} beats {f:?}"
            );
        }
    }
}

#[test]
fn a_quick_smoke_sweep_writes_its_front_and_plots_and_render_chooses_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let vol = puff(dir.path());
    let out = dir.path().join("sweep");
    let o = out.to_str().unwrap();
    let (stdout, _) = ok(&[
        "tradeoff",
        &vol,
        "--out",
        o,
        "--quick",
        "--width",
        "32",
        "--height",
        "24",
        "--knobs",
        "rbfs,sh_order,slices,multiple,residual",
        "--reference",
        "--spp",
        "4",
    ]);
    assert!(stdout.contains("on the front"), "{stdout}");
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tradeoff.json")).unwrap()).unwrap();
    assert_eq!(doc["kind"], "smoke");
    let settings = entries(&doc, "settings");
    // best + default + one at a time: rbfs 1, SH order 2, slices 1, multiple 1, residual 1.
    assert!(settings.len() >= 8, "{}", settings.len());
    let best = settings.iter().find(|s| s["why"] == "best").unwrap();
    assert_eq!(best["error"].as_f64().unwrap(), 0.0);
    // Single scattering alone loses light: a visible error against the best.
    let single = settings
        .iter()
        .find(|s| s["changed"] == "multiple=false")
        .unwrap();
    assert!(single["error"].as_f64().unwrap() > 1e-3);
    for s in settings {
        let ms = &s["ms"];
        assert!(ms["render"].as_f64().unwrap() > 0.0 && ms["bake"].as_f64().unwrap() > 0.0);
        assert!(s["error"].as_f64().unwrap().is_finite());
        // --reference: every setting also against the path tracer.
        let r = s["error_reference"].as_f64().unwrap();
        assert!(r.is_finite() && r > 0.0, "{r}");
    }
    check_front(&doc);
    for stem in ["pareto", "knob-sh_order", "knob-multiple"] {
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        assert!(svg.starts_with("<svg"), "{stem}");
        let png = std::fs::read(out.join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[1..4], b"PNG", "{stem}");
    }
    // Knobs not asked for were not swept.
    assert!(!out.join("knob-exp.svg").exists());

    // Choices: a huge budget takes the most accurate front entry, a zero-error target the
    // best setting, an impossible budget is refused on one line.
    let file = out.join("tradeoff.json");
    let f = file.to_str().unwrap();
    let img = dir.path().join("chosen.png");
    let i = img.to_str().unwrap();
    let (_, err) = ok(&[
        "render",
        &vol,
        "--out",
        i,
        "--width",
        "32",
        "--height",
        "24",
        "--budget-ms",
        "1e9",
        "--tradeoff",
        f,
    ]);
    assert!(
        err.contains("choice from") && err.contains("0.00 %"),
        "{err}"
    );
    let (_, err) = ok(&[
        "render",
        &vol,
        "--out",
        i,
        "--width",
        "32",
        "--height",
        "24",
        "--target-error",
        "1",
        "--tradeoff",
        f,
    ]);
    let fastest = point(&entries(&doc, "pareto")[0]);
    assert!(err.contains(&format!("{:.1} ms", fastest.0)), "{err}");
    fails(
        &[
            "render",
            &vol,
            "--out",
            i,
            "--budget-ms",
            "1e-6",
            "--tradeoff",
            f,
        ],
        "no setting renders within",
    );
    fails(
        &[
            "render",
            &vol,
            "--out",
            i,
            "--budget-ms",
            "0",
            "--tradeoff",
            f,
        ],
        "must be a positive",
    );
    fails(
        &["tradeoff", &vol, "--out", o, "--knobs", "sh_order,bogus"],
        "no knob 'bogus'",
    );
}

#[test]
fn a_quick_fogmap_sweep_measures_every_combination() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fog");
    let o = out.to_str().unwrap();
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/fogmap/fogmap_128.png");
    ok(&[
        "tradeoff",
        map.to_str().unwrap(),
        "--out",
        o,
        "--quick",
        "--width",
        "32",
        "--height",
        "24",
    ]);
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tradeoff.json")).unwrap()).unwrap();
    assert_eq!(doc["kind"], "fogmap");
    // 3 bases × (levels 0 at µ 1, levels 1 and 2 at µ 1 and 0.5) = 15; the best and the
    // defaults are among them.
    assert_eq!(entries(&doc, "settings").len(), 15);
    check_front(&doc);
    assert!(out.join("knob-mu.png").exists() && out.join("pareto.svg").exists());
    // A fogmap's sweep cannot choose smoke knobs.
    let img = dir.path().join("x.png");
    fails(
        &[
            "render",
            map.to_str().unwrap(),
            "--out",
            img.to_str().unwrap(),
            "--budget-ms",
            "10",
            "--tradeoff",
            out.join("tradeoff.json").to_str().unwrap(),
        ],
        "fogmap",
    );
}

#[test]
fn bad_inputs_fail_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("x");
    fails(
        &[
            "tradeoff",
            "/nonexistent/vol.vdb",
            "--out",
            o.to_str().unwrap(),
        ],
        "/nonexistent",
    );
    fails(
        &[
            "tradeoff",
            "/nonexistent/fog.png",
            "--out",
            o.to_str().unwrap(),
        ],
        "/nonexistent",
    );
    fails(
        &[
            "tradeoff",
            "x.vdb",
            "--out",
            o.to_str().unwrap(),
            "--width",
            "0",
        ],
        "--width 0",
    );
}

/// `haze bake --target-error` also chooses the residual error, prints why and stores it
/// in the asset header; an explicit --residual-error is kept.
#[test]
fn bake_target_error_chooses_the_residual_error_and_stores_why() {
    let dir = tempfile::tempdir().unwrap();
    let vol = puff(dir.path());
    let out = dir.path().join("p.haze");
    let o = out.to_str().unwrap();
    let (_, err) = ok(&[
        "bake",
        &vol,
        "--out",
        o,
        "--target-error",
        "0.5",
        "--max-rbfs",
        "8",
        "--no-teleport",
    ]);
    assert!(
        err.contains("residual error chosen: target error 0.5"),
        "{err}"
    );
    let asset = haze_asset::Asset::open(&out).unwrap();
    let c = &asset.header().extra["choices"]["residual_error"];
    let chosen = c["residual_error"].as_f64().unwrap();
    assert!(c["bound"].as_f64().unwrap() <= 0.25 * 0.5);
    assert!(c["why"].as_str().unwrap().contains("/255"));
    let stored = &asset.header().settings["fit"]["settings"]["residual_error"];
    assert_eq!(stored.as_f64().unwrap(), chosen);
    let (_, err) = ok(&[
        "bake",
        &vol,
        "--out",
        o,
        "--target-error",
        "0.5",
        "--max-rbfs",
        "8",
        "--no-teleport",
        "--residual-error",
        "0.01",
    ]);
    assert!(!err.contains("residual error chosen"), "{err}");
    let asset = haze_asset::Asset::open(&out).unwrap();
    assert!(asset.header().extra.get("choices").is_none());
}

/// `haze bake --view-budget-ms T --tradeoff FILE` stores the viewer's knobs with why, and
/// `haze view` starts with them.
#[test]
fn a_view_budget_is_stored_in_the_asset_and_the_viewer_starts_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let vol = puff(dir.path());
    let sweep = dir.path().join("sweep");
    let s = sweep.to_str().unwrap();
    ok(&[
        "tradeoff", &vol, "--out", s, "--quick", "--width", "32", "--height", "24", "--knobs",
        "multiple",
    ]);
    let file = sweep.join("tradeoff.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    // The fastest front entry is single scattering alone (multiple scattering costs time).
    let fastest = &entries(&doc, "pareto")[0];
    let budget = format!("{}", fastest["ms"]["render"].as_f64().unwrap() * 1.0001);
    let out = dir.path().join("p.haze");
    let o = out.to_str().unwrap();
    let (_, err) = ok(&[
        "bake",
        &vol,
        "--out",
        o,
        "--rbfs",
        "8",
        "--no-teleport",
        "--view-budget-ms",
        &budget,
        "--tradeoff",
        file.to_str().unwrap(),
    ]);
    assert!(err.contains("view settings chosen: budget"), "{err}");
    let asset = haze_asset::Asset::open(&out).unwrap();
    let stored = &asset.header().extra["choices"]["view"];
    assert_eq!(stored["knobs"], fastest["knobs"]);
    let (stdout, err) = ok(&[
        "view",
        o,
        "--no-window",
        "--play-for",
        "0.2",
        "--lighting",
        "cpu",
    ]);
    if fastest["knobs"]["multiple"] == Value::Bool(false) {
        assert!(
            err.contains("starting with the asset's choice (no multiple scattering)"),
            "{err}"
        );
    }
    assert!(!stdout.is_empty());
    fails(
        &[
            "bake",
            &vol,
            "--out",
            o,
            "--view-budget-ms",
            "0",
            "--tradeoff",
            file.to_str().unwrap(),
        ],
        "must be a positive",
    );
}
