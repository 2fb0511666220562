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
        "rbfs,sh_order,slices,multiple,residual,diffusion",
        "--reference",
        "--spp",
        "4",
    ]);
    assert!(stdout.contains("on the front"), "{stdout}");
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tradeoff.json")).unwrap()).unwrap();
    assert_eq!(doc["kind"], "smoke");
    let settings = entries(&doc, "settings");
    // best + default + one at a time: rbfs 1, SH order 1 (order 6 alone is the best
    // setting), slices 1, multiple 1, residual 1, diffusion 1; the chains' steps depend
    // on timings.
    assert!(settings.len() >= 8, "{}", settings.len());
    let best = settings.iter().find(|s| s["why"] == "best").unwrap();
    assert_eq!(best["error"].as_f64().unwrap(), 0.0);
    // Single scattering alone loses light: a visible error against the best.
    let single = settings
        .iter()
        .find(|s| s["changed"] == "multiple=false")
        .unwrap();
    assert!(single["error"].as_f64().unwrap() > 1e-3);
    // The default (and most accurate) multiple scattering is the explicit orders; paper
    // A's diffusion at the centers is another picture.
    let diffusion = doc["knobs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|k| k["name"] == "diffusion")
        .unwrap();
    assert_eq!(diffusion["default"], "orders:auto:6");
    assert_eq!(diffusion["best"], "orders:auto:6");
    let centers = settings
        .iter()
        .find(|s| s["changed"] == "diffusion=centers")
        .unwrap();
    assert!(centers["error"].as_f64().unwrap() > 1e-3, "{centers}");
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
    // The most accurate setting renders with its model, the explicit orders.
    assert!(
        err.lines()
            .last()
            .unwrap()
            .contains("single + multiple scattering (orders:auto:6)"),
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
    // The fastest front setting, and a 100 % target needs no multiple scattering: it is
    // turned off (the time and error then estimated) unless the front's already was.
    let fastest = &entries(&doc, "pareto")[0];
    assert!(
        err.contains(&format!("{:.1} ms", point(fastest).0)) || err.contains("(estimated"),
        "{err}"
    );
    assert!(err.contains("(within the target 100.00 %): off"), "{err}");
    assert!(
        err.lines().last().unwrap().contains("single scattering"),
        "{err}"
    );
    fails(
        &[
            "render",
            &vol,
            "--out",
            i,
            "--width",
            "32",
            "--height",
            "24",
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
        "--reference",
    ]);
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tradeoff.json")).unwrap()).unwrap();
    assert_eq!(doc["kind"], "fogmap");
    // 3 bases × (levels 0 at µ 1, levels 1 and 2 at µ 1 and 0.5) = 15; the best and the
    // defaults are among them.
    let settings = entries(&doc, "settings");
    assert_eq!(settings.len(), 15);
    // --reference: the exact integral of the map. The map itself (0 levels, µ 1) differs
    // from it by the early exit alone; every setting's error against it is its error
    // against the best setting up to the best's own (the triangle inequality, the two
    // norms differing by at most that much).
    let reference = |s: &Value| s["error_reference"].as_f64().unwrap();
    let best = settings.iter().find(|s| s["why"] == "best").unwrap();
    let e_best = reference(best);
    for s in settings {
        let (e, r) = (s["error"].as_f64().unwrap(), reference(s));
        assert!(r.is_finite() && r >= 0.0, "{s}");
        assert!(
            (r - e).abs() <= e_best * (1.0 + e) + 1e-6,
            "{}: {r} against the reference, {e} against the best ({e_best})",
            s["changed"]
        );
        if s["knobs"]["levels"] == 0 && s["knobs"]["mu"] == 1.0 {
            assert!(r < 2e-3, "the map itself: {r}");
        }
    }
    // The coarsest setting is visibly off the reference.
    let worst = settings.iter().map(reference).fold(0.0, f64::max);
    assert!(worst > 10.0 * e_best.max(1e-4), "{worst} {e_best}");
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
    // Why, knob by knob, with the scene's albedo.
    let reasons = stored["reasons"].as_array().unwrap();
    assert!(
        reasons.iter().any(|r| r
            .as_str()
            .unwrap()
            .starts_with("albedo 0.8, σt 4: multiple scattering changes the image by")),
        "{reasons:?}"
    );
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
    // A stored choice of the cheaper explicit orders (a sweep whose every setting had
    // them): the viewer starts with that model.
    let mut cheaper = doc.clone();
    for e in cheaper["settings"].as_array_mut().unwrap() {
        e["knobs"]["diffusion"] = Value::from("orders:3:3");
        e["knobs"]["multiple"] = Value::Bool(true);
    }
    let file2 = dir.path().join("cheaper.json");
    std::fs::write(&file2, cheaper.to_string()).unwrap();
    ok(&[
        "bake",
        &vol,
        "--out",
        o,
        "--rbfs",
        "8",
        "--no-teleport",
        "--view-budget-ms",
        "1e9",
        "--tradeoff",
        file2.to_str().unwrap(),
    ]);
    let (_, err) = ok(&[
        "view",
        o,
        "--no-window",
        "--play-for",
        "0.2",
        "--lighting",
        "cpu",
    ]);
    assert!(
        err.contains("starting with the asset's choice (multiple scattering by orders:3:3)"),
        "{err}"
    );
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

/// A quick sweep of multiple scattering alone on a puff of low and of high albedo:
/// `--target-error 2 %` turns it off where it changes the picture by less (albedo 0.05)
/// and keeps it where it changes it by more (0.95), each saying so with the albedo and
/// the change measured (which, the defaults being the best here, is the error of the
/// setting without it).
#[test]
fn a_low_albedo_turns_multiple_scattering_off_and_a_high_one_keeps_it() {
    let dir = tempfile::tempdir().unwrap();
    let vol = puff(dir.path());
    for (albedo, off) in [("0.05", true), ("0.95", false)] {
        let out = dir.path().join(format!("sweep{albedo}"));
        let common = ["--width", "32", "--height", "24", "--albedo", albedo];
        let mut args = vec!["tradeoff", &vol, "--out", out.to_str().unwrap(), "--quick"];
        args.extend(["--knobs", "multiple"]);
        args.extend(common);
        ok(&args);
        let file = out.join("tradeoff.json");
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        assert_eq!(
            doc["medium"]["albedo"].as_f64().unwrap().to_string(),
            albedo
        );
        let change = doc["effects"]["multiple"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["value"] == false)
            .unwrap()["change"]
            .as_f64()
            .unwrap();
        let single = entries(&doc, "settings")
            .iter()
            .find(|s| s["changed"] == "multiple=false")
            .unwrap();
        assert!((single["error"].as_f64().unwrap() - change).abs() < 1e-12);
        assert_eq!(change < 0.02, off, "albedo {albedo}: {change}");
        // Without --reference the best setting is checked against the reference: an
        // estimate with its noise, on some of the puff's pixels.
        let best = &doc["best_estimated_error"];
        let (e, noise) = (
            best["error"].as_f64().unwrap(),
            best["noise"].as_f64().unwrap(),
        );
        assert!((0.0..1.0).contains(&e) && noise > 0.0, "{best}");
        assert!(best["pixels"].as_u64().unwrap() > 10, "{best}");
        let img = dir.path().join("x.png");
        let mut args = vec!["render", &vol, "--out", img.to_str().unwrap()];
        args.extend([
            "--target-error",
            "0.02",
            "--tradeoff",
            file.to_str().unwrap(),
        ]);
        args.extend(common);
        let (_, err) = ok(&args);
        let why = format!(
            "albedo {albedo}, σt 4: multiple scattering changes the image by {:.2} %",
            100.0 * change
        );
        let verdict = if off {
            "(within the target 2.00 %): off"
        } else {
            "(more than the target 2.00 %): on"
        };
        assert!(err.contains(&format!("{why} {verdict}")), "{err}");
        let done = err.lines().last().unwrap();
        assert_eq!(
            done.contains("single + multiple scattering"),
            !off,
            "{done}"
        );
    }
}

/// `haze view --budget-ms`: from a quick sweep measured on the viewer's GPU renderer at
/// its size (a huge budget: the most accurate viewer knobs), and from a sweep file
/// measured at another size (rescaled, warned about once); the knobs the choice names are
/// the ones the viewer plays with.
#[test]
fn the_viewer_chooses_its_knobs_for_a_budget() {
    let dir = tempfile::tempdir().unwrap();
    let vol = puff(dir.path());
    let asset = dir.path().join("p.haze");
    let a = asset.to_str().unwrap();
    ok(&["bake", &vol, "--out", a, "--rbfs", "8", "--no-teleport"]);
    let view = [
        "view",
        a,
        "--no-window",
        "--play-for",
        "0.2",
        "--lighting",
        "cpu",
    ];
    let mut args = view.to_vec();
    args.extend(["--size", "32x24", "--budget-ms", "1e9"]);
    let (stdout, err) = ok(&args);
    assert!(err.contains("measuring a quick sweep"), "{err}");
    assert!(err.contains("choice from a quick sweep"), "{err}");
    let knobs = "SH order 6, 2 slices per voxel, single + multiple scattering, residual on";
    assert!(
        err.contains(&format!("starting with {knobs}, 32×24")),
        "{err}"
    );
    assert!(stdout.contains(&format!("; {knobs}; voxels ")), "{stdout}");

    let sweep = dir.path().join("sweep");
    ok(&[
        "tradeoff",
        &vol,
        "--out",
        sweep.to_str().unwrap(),
        "--quick",
        "--width",
        "32",
        "--height",
        "24",
        "--knobs",
        "sh_order,multiple",
    ]);
    let file = sweep.join("tradeoff.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    // The fastest setting as the viewer sees the sweep: measured at 32×24, its view
    // pass's milliseconds scaled by the pixel count to 64×48 (4×), which can reorder
    // settings whose times are close and bring one that was off the 32×24 front onto the
    // 64×48 one, so every measured setting is a candidate (the fastest is always on it).
    let at_64x48 = |e: &Value| {
        let (render, view) = (
            e["ms"]["render"].as_f64().unwrap(),
            e["ms"]["view"].as_f64().unwrap(),
        );
        render - view + 4.0 * view
    };
    let fastest = entries(&doc, "settings")
        .iter()
        .min_by(|a, b| at_64x48(a).total_cmp(&at_64x48(b)))
        .unwrap();
    let mut args = view.to_vec();
    args.extend(["--size", "64x48", "--target-error", "1", "--tradeoff"]);
    args.push(file.to_str().unwrap());
    let (stdout, err) = ok(&args);
    let warnings: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("measured at 32×24"))
        .collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(warnings[0].starts_with("warning: ") && warnings[0].contains("64×48"));
    // The sweep timed the CPU's renderer, the viewer renders on the GPU: said once.
    assert_eq!(
        err.matches("the times are of the CPU renderer").count(),
        1,
        "{err}"
    );
    // The fastest front setting, with multiple scattering off (a 100 % target does not
    // need it); the residual was not swept, so it stays on.
    let sh = fastest["knobs"]["sh_order"].as_u64().unwrap();
    let knobs = format!("SH order {sh}, 2 slices per voxel, single scattering, residual on");
    assert!(
        stdout.contains(&format!("; {knobs}; voxels ")),
        "{stdout}\n{err}"
    );
    // Bad goals and files: an error line (after the warnings about the file, if any),
    // before any window or sweep.
    let f = file.to_str().unwrap();
    for (flags, needle) in [
        (
            vec!["--budget-ms", "0", "--tradeoff", f],
            "must be a positive",
        ),
        (
            vec!["--target-error", "0", "--tradeoff", f],
            "must be a positive",
        ),
        (
            vec!["--budget-ms", "1e-9", "--tradeoff", f],
            "no setting renders within",
        ),
        (
            vec!["--budget-ms", "10", "--tradeoff", "/nonexistent/t.json"],
            "/nonexistent/t.json",
        ),
    ] {
        let mut args = view.to_vec();
        args.extend(["--size", "32x24"]);
        args.extend(flags);
        let o = haze().args(&args).output().unwrap();
        let err = String::from_utf8(o.stderr).unwrap();
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        let last = err.lines().last().unwrap();
        assert!(
            last.starts_with("error: ") && last.contains(needle),
            "{err}"
        );
        assert!(err.lines().all(|l| l.starts_with("warning: ") || l == last));
        assert!(o.stdout.is_empty());
    }
}

/// `haze tradeoff --gpu` times the GPU renderer (lavapipe will do; without an adapter
/// the test fails): the file says so, and every setting's picture is the CPU's twin — its
/// error against the best setting matches the CPU sweep's within the f32 rounding of the
/// GPU passes.
#[test]
fn a_gpu_sweep_times_the_gpu_renderer_and_measures_the_same_errors() {
    let dir = tempfile::tempdir().unwrap();
    let vol = puff(dir.path());
    let mut docs = Vec::new();
    for gpu in [false, true] {
        let out = dir.path().join(format!("sweep{gpu}"));
        let mut args = vec!["tradeoff", &vol, "--out", out.to_str().unwrap(), "--quick"];
        args.extend([
            "--width",
            "32",
            "--height",
            "24",
            "--knobs",
            "sh_order,multiple",
        ]);
        if gpu {
            args.extend(["--gpu", "--lighting", "gpu"]);
        }
        let (stdout, _) = ok(&args);
        let doc: Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("tradeoff.json")).unwrap())
                .unwrap();
        let timing = doc["timing"].as_str().unwrap().to_string();
        assert_eq!(timing.starts_with("GPU: "), gpu, "{timing}");
        assert!(stdout.contains(&format!("({timing})")), "{stdout}");
        docs.push(doc);
    }
    let error_of = |doc: &Value, changed: &Value| {
        entries(doc, "settings")
            .iter()
            .find(|s| &s["changed"] == changed)
            .map(|s| s["error"].as_f64().unwrap())
    };
    let mut compared = 0;
    for s in entries(&docs[0], "settings") {
        if let Some(e_gpu) = error_of(&docs[1], &s["changed"]) {
            let e_cpu = s["error"].as_f64().unwrap();
            // The GPU's f32 passes against the CPU's: 1e-6 apart when measured.
            assert!(
                (e_gpu - e_cpu).abs() <= 1e-4 + 1e-3 * e_cpu,
                "{}: GPU {e_gpu}, CPU {e_cpu}",
                s["changed"]
            );
            compared += 1;
        }
    }
    // The best, the defaults, SH order 2 and single scattering at least.
    assert!(compared >= 4, "{compared}");
}
