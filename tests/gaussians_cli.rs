//! End-to-end tests of `haze render --scene` on the bundled Gaussian scene (paper B): the
//! CPU render and the march reference on a tiny image, and one-line errors.

use assert_cmd::Command;
use std::path::Path;

fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/scenes/gaussians.json")
        .display()
        .to_string()
}

fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

fn read_exr(path: &Path) -> Vec<[f32; 3]> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![[0.0f32; 3]; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    image.layer_data.channel_data.pixels.1
}

fn render(args: &[&str]) -> String {
    let o = haze().arg("render").args(args).output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{args:?}: {err}");
    err
}

#[test]
fn renders_the_bundled_gaussians_and_their_reference() {
    let dir = tempfile::tempdir().unwrap();
    let (a, r) = (dir.path().join("a.exr"), dir.path().join("r.exr"));
    let s = scene();
    let size = ["--width", "16", "--height", "12"];
    let err = render(&[&["--scene", &s, "--out", a.to_str().unwrap()], &size[..]].concat());
    assert!(
        err.contains("16×12") && err.contains("paper B, 150 gaussians"),
        "{err}"
    );
    // The pairs over the factorization's error bound, counted on the summary line and
    // listed with -v (the bundled cloud's peak optical depth 0.12 and its lights a few
    // radii from the nearest Gaussians flag some of its 300 pairs).
    let counted = err
        .split(", ")
        .find_map(|part| {
            part.split(" light–gaussian pairs integrated")
                .nth(1)
                .map(|_| part)
        })
        .and_then(|part| part.split(" light–gaussian").next())
        .unwrap_or_else(|| panic!("no pair count: {err}"));
    let k: usize = counted.split(" of ").next().unwrap().parse().unwrap();
    assert!(counted.ends_with(" of 300") && k > 0, "{counted}");
    let verbose = render(
        &[
            &["-v", "--scene", &s, "--out", a.to_str().unwrap()][..],
            &size[..],
        ]
        .concat(),
    );
    assert_eq!(verbose.matches("paper B: light ").count(), k, "{verbose}");
    let err = render(
        &[
            &["--scene", &s, "--reference", "--out", r.to_str().unwrap()],
            &size[..],
        ]
        .concat(),
    );
    assert!(err.contains("march"), "{err}");
    let (pa, pr) = (read_exr(&a), read_exr(&r));
    assert_eq!((pa.len(), pr.len()), (16 * 12, 16 * 12));
    assert!(
        pa.iter()
            .chain(&pr)
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
    // The two differ by the factorization, the noise and the light the medium scatters
    // onto surfaces (which the march leaves out); overall they agree within 30 %.
    let mean = |p: &[[f32; 3]]| p.iter().flatten().map(|&v| f64::from(v)).sum::<f64>();
    let ratio = mean(&pa) / mean(&pr);
    println!("paper B / reference brightness: {ratio:.3}");
    assert!((0.7..1.3).contains(&ratio), "{ratio}");
}

#[test]
fn bad_gaussian_media_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    let text = std::fs::read_to_string(scene()).unwrap();
    for (from, to, needle) in [
        (
            "\"radius\": 0.2461",
            "\"radius\": -1",
            "gaussians[0].radius -1 must be positive",
        ),
        ("\"gain\": 1.5", "\"gain\": -2", "noise.gain -2"),
        (
            "\"albedo\": 0.9",
            "\"albedo\": 0.9, \"g\": 0.5",
            "isotropically",
        ),
    ] {
        std::fs::write(&bad, text.replacen(from, to, 1)).unwrap();
        let o = haze()
            .args(["render", "--scene", bad.to_str().unwrap(), "--out"])
            .arg(dir.path().join("x.exr"))
            .output()
            .unwrap();
        let err = String::from_utf8(o.stderr).unwrap();
        assert!(!o.status.success());
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(
            err.contains("bad.json") && err.contains("media[0]") && err.contains(needle),
            "{err}"
        );
    }
}

/// A CPU adapter's shader loops stop silently after 65535 iterations: a scene of more
/// Gaussians than its budget allows is refused up front under `--gpu` (the picture came out
/// dark), and the CPU renderer takes it. CI's adapter is lavapipe; on a real GPU the
/// `--gpu` render goes through.
#[test]
fn many_gaussians_on_a_cpu_adapter_are_refused_with_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 100 000 faint Gaussians (the count paper B's extremes ask for) on a grid of rows
    // 200 wide, one lamp: over one light's budget (24 000), under the CPU renderer's cap.
    let mut g = Vec::with_capacity(100_000);
    for k in 0..100_000 {
        let (x, y) = ((k % 200) as f64 * 0.03 - 3.0, (k / 200) as f64 * 0.04 - 3.0);
        g.push(format!(
            r#"{{"center": [{x}, {y}, 1], "radius": 0.02, "weight": 0.01}}"#
        ));
    }
    let scene = d.join("many.json");
    std::fs::write(
        &scene,
        format!(
            r#"{{"camera": {{"eye": [0, -8, 1.5], "target": [0, 0, 1], "fov": 50, "width": 8, "height": 6}},
"lights": [{{"type": "point", "position": [0, -3, 8], "intensity": [40, 40, 40]}}],
"media": [{{"type": "gaussians", "sigma_t": 0.6, "albedo": 0.9, "gaussians": [{}]}}]}}"#,
            g.join(",")
        ),
    )
    .unwrap();
    let s = scene.to_str().unwrap();
    let o = haze()
        .args(["render", "--scene", s, "--gpu", "--out"])
        .arg(d.join("g.exr"))
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    let cpu_adapter = err.contains("more than paper B's shader renders on a CPU adapter");
    if cpu_adapter {
        assert!(!o.status.success());
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(
            err.contains("many.json")
                && err.contains("100000 Gaussians with 1 light are")
                && err.contains("at most 24000 Gaussians with 1 light)")
                && err.contains("leave out --gpu"),
            "{err}"
        );
        assert!(!d.join("g.exr").exists());
    } else {
        assert!(o.status.success(), "{err}");
    }
    let c = d.join("c.exr");
    render(&["--scene", s, "--out", c.to_str().unwrap()]);
    assert!(
        read_exr(&c)
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
}

#[test]
fn gpu_renders_the_bundled_gaussians_with_their_noise() {
    // The bundled scene, noise included, on the GPU and on the CPU: the same image within
    // crates/scene/tests/gpu_paper_b.rs's tolerance (2·10⁻⁴ relative, 10⁻⁴ of the mean;
    // there pixel by pixel, here through the EXR files). The viewer shows the scene
    // through paper B on the GPU too. These need a GPU adapter (lavapipe will do).
    let dir = tempfile::tempdir().unwrap();
    let (g, c) = (dir.path().join("g.exr"), dir.path().join("c.exr"));
    let s = scene();
    let size = ["--width", "16", "--height", "12"];
    let err = render(
        &[
            &["--scene", &s, "--gpu", "--out", g.to_str().unwrap()],
            &size[..],
        ]
        .concat(),
    );
    assert!(
        err.contains("paper B, 150 gaussians") && err.contains("on the GPU"),
        "{err}"
    );
    // The CPU with as many Gaussians exact per pair as the GPU device takes (4 on a CPU
    // device such as lavapipe), as its summary line says.
    let exact = err
        .split("(at most ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .unwrap_or_else(|| panic!("no exact count in {err}"))
        .to_string();
    let exact = exact.as_str();
    render(
        &[
            &[
                "--scene",
                &s,
                "--out",
                c.to_str().unwrap(),
                "--exact-per-pair",
                exact,
            ],
            &size[..],
        ]
        .concat(),
    );
    let (pg, pc) = (read_exr(&g), read_exr(&c));
    assert_eq!(pg.len(), pc.len());
    let mean = pc.iter().flatten().map(|&v| f64::from(v)).sum::<f64>() / (3 * pc.len()) as f64;
    let mut worst = 0.0f64;
    for (a, b) in pg.iter().zip(&pc) {
        for k in 0..3 {
            let (a, b) = (f64::from(a[k]), f64::from(b[k]));
            assert!(a.is_finite() && a >= 0.0, "{a}");
            // |a − b| ≤ 2·10⁻⁴·|b| + 10⁻⁴·mean, as a fraction of that bound.
            worst = worst.max((a - b).abs() / (2e-4 * b.abs() + 1e-4 * mean));
        }
    }
    println!("GPU vs CPU: worst {worst:.3} of the tolerance");
    assert!(worst <= 1.0, "{worst}");
    let o = haze()
        .args([
            "view",
            "--scene",
            &scene(),
            "--size",
            "64x48",
            "--no-window",
            "--play-for",
            "0.2",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{err}");
    let out = String::from_utf8(o.stdout).unwrap();
    // Paper B's shader on a GPU, its CPU renderer beside a CPU adapter (decision 0058).
    assert!(
        out.contains("(GPU render with paper B's Gaussians and ray-traced surfaces, read back")
            || out.contains(
                "(CPU render with paper B's Gaussians and ray-traced surfaces, sRGB) beside "
            ),
        "{out}"
    );
}

/// `haze view --scene` edits the bundled Gaussians from the command line and saves them:
/// a scripted paint stroke across the floor and an eraser stroke, then `--save-edits`; the
/// saved copy loads, holds the count the viewer reported, keeps the first Gaussians it did
/// not erase and adds the stroke's on the floor (`|z|` below the default jitter, half the
/// radius); a bad stroke or a scene without Gaussians is an error on its first line.
#[test]
fn view_scripts_strokes_and_saves_the_edited_medium() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("edited.json");
    let o = haze()
        .args(["view", "--scene", &scene(), "--size", "64x48"])
        .args(["--no-window", "--play-for", "0.1"])
        .args(["--stroke", "paint:10,40:30,42:50,40"])
        .args(["--stroke", "erase:32,12"])
        .args(["--save-edits", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{err}");
    let count = err
        .split_once("2 strokes: 150 → ")
        .and_then(|(_, r)| r.split_once(" Gaussians"))
        .and_then(|(n, _)| n.parse::<usize>().ok())
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        err.contains(&format!("saved {count} Gaussians to ")),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let edited = v["media"][0]["gaussians"].as_array().unwrap();
    assert_eq!(edited.len(), count);
    let first: serde_json::Value =
        serde_json::from_slice(&std::fs::read(scene()).unwrap()).unwrap();
    let first = first["media"][0]["gaussians"].as_array().unwrap();
    // The first Gaussians come first, each as it was or 0.05 lighter (one eraser dab);
    // the stroke's follow.
    let mut lowered = 0;
    let mut kept = 0;
    for (g, f) in edited.iter().zip(first) {
        if g["center"] != f["center"] {
            break;
        }
        kept += 1;
        let (w, w0) = (g["weight"].as_f64().unwrap(), f["weight"].as_f64().unwrap());
        if w != w0 {
            assert!((w - (w0 - 0.05)).abs() < 1e-12, "{g} from {f}");
            lowered += 1;
        }
    }
    assert!(lowered > 0 && kept > 100 && kept <= 150, "{lowered} {kept}");
    let added = &edited[kept..];
    assert!(!added.is_empty());
    for g in added {
        let (z, r) = (
            g["center"][2].as_f64().unwrap(),
            g["radius"].as_f64().unwrap(),
        );
        assert!(z.abs() < 0.5 * r, "{g}");
    }
    let fails = |args: &[&str], needle: &str| {
        let o = haze().args(args).output().unwrap();
        let err = String::from_utf8(o.stderr).unwrap();
        // 1 from haze, 2 from clap's parse of the arguments.
        assert!(matches!(o.status.code(), Some(1 | 2)), "{err}");
        assert!(err.lines().next().unwrap_or("").contains(needle), "{err}");
    };
    let play = ["--no-window", "--play-for", "0.1"];
    fails(
        &[
            &["view", "--scene", &scene(), "--stroke", "wipe:1,2"][..],
            &play,
        ]
        .concat(),
        "unknown tool 'wipe'",
    );
    fails(
        &[
            &["view", "--scene", &scene(), "--stroke", "paint:1"][..],
            &play,
        ]
        .concat(),
        "'1' is not a picture point X,Y",
    );
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes/room.json");
    fails(
        &[
            &[
                "view",
                "--scene",
                room.to_str().unwrap(),
                "--stroke",
                "paint:1,2",
            ][..],
            &play,
        ]
        .concat(),
        "room.json: --stroke and --save-edits edit a Gaussian medium, and the scene has none",
    );
}

#[test]
fn sky_scene_matches_its_reference_on_cpu_and_gpu() {
    // data/scenes/gaussians_sky.json: 100 Gaussians under the built-in sky and a sun,
    // a floor and a glossy sphere. Paper B lights the Gaussians and dims the surfaces by
    // the sky through the average optical depth (§4.2); `--reference` marches the exact
    // medium with the sky integrated over 128 directions at every sample and surface
    // point. Rel RMS measured 3.5 % at 12×9, which counts against paper B the light the
    // medium scatters onto surfaces (the march has none) and the sphere's shadow in the
    // sunlit medium (paper B has no volume shadows); within 5 %. The GPU twin matches
    // the CPU within 10⁻³, the surfaces' shadow on the sky read from the CPU's table
    // (measured 1.4·10⁻⁷).
    let dir = tempfile::tempdir().unwrap();
    let s = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/scenes/gaussians_sky.json")
        .display()
        .to_string();
    let size = ["--width", "12", "--height", "9"];
    let out = |name: &str, extra: &[&str]| {
        let p = dir.path().join(name);
        let err = render(
            &[
                &["--scene", &s, "--out", p.to_str().unwrap()],
                extra,
                &size[..],
            ]
            .concat(),
        );
        (read_exr(&p), err)
    };
    let (cpu, err) = out("c.exr", &[]);
    assert!(!err.contains("dense for the environment"), "{err}");
    let (reference, err) = out("r.exr", &["--reference"]);
    assert!(err.contains("the environment over 128 directions"), "{err}");
    let (gpu, err) = out("g.exr", &["--gpu"]);
    assert!(err.contains("on the GPU"), "{err}");
    // The surfaces under the average depth alone (paper B's form).
    let (mean, _) = out("m.exr", &["--sky-shadow", "mean"]);
    let rel = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        let (mut d, mut n) = (0.0, 0.0);
        for (x, y) in a.iter().zip(b) {
            for k in 0..3 {
                let (x, y) = (f64::from(x[k]), f64::from(y[k]));
                d += (x - y) * (x - y);
                n += y * y;
            }
        }
        (d / n).sqrt()
    };
    let e = rel(&cpu, &reference);
    let e_mean = rel(&mean, &reference);
    let g = rel(&gpu, &cpu);
    println!(
        "sky scene: paper B vs reference {e:.4} ({e_mean:.4} under the average depth), GPU vs CPU {g:.2e}"
    );
    assert!(e < 0.05 && e_mean < 0.05, "{e} {e_mean}");
    assert!(g < 1e-3, "{g}");
}

#[test]
fn dense_gaussians_under_a_sky_are_warned_about() {
    // The bundled sky scene with every Gaussian ten times as dense (peak depth 0.05 →
    // 0.5): the others' mean depth around each is then above VALID_MEAN_DEPTH, where
    // paper B's environment terms measured 5–6 % off (crates/scene/tests/paper_b.rs
    // holds the same cloud class at 6.9 %). The render still completes, and says so.
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes/gaussians_sky.json"),
    )
    .unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    for g in scene["media"][0]["gaussians"].as_array_mut().unwrap() {
        let w = g["weight"].as_f64().unwrap();
        g["weight"] = serde_json::json!(10.0 * w);
    }
    let path = dir.path().join("dense.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let out = dir.path().join("dense.exr");
    let err = render(&[
        "--scene",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "6",
    ]);
    assert!(
        err.contains("dense for the environment's light") && err.contains("--reference"),
        "{err}"
    );
    assert!(out.exists());
    // The viewer says it too (its panel shows the same lines).
    let o = haze()
        .args(["view", "--scene", path.to_str().unwrap(), "--size", "16x12"])
        .args(["--no-window", "--play-for", "0.01"])
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{err}");
    assert!(err.contains("dense for the environment's light"), "{err}");
}
