//! End-to-end tests of the bundled smoke scene (`data/scenes/smoke.json`: the plume asset
//! over a ground plane, a point light and a sun): `haze render --scene` on the CPU is the
//! library's march, converges to its `--reference` (the march at a quarter of the step),
//! and the smoke casts a shadow on the ground; `haze view --scene` renders it on the GPU.

use assert_cmd::Command;
use haze_scene::march::march_options;
use haze_scene::paper_c::airlight::Limits;
use std::path::{Path, PathBuf};

fn smoke() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes/smoke.json")
}

fn read_exr(path: &Path) -> (usize, usize, Vec<[f32; 3]>) {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![[0.0f32; 3]; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    let size = image.layer_data.size;
    (size.0, size.1, image.layer_data.channel_data.pixels.1)
}

fn render(extra: &[&str], out: &Path) -> String {
    let o = Command::cargo_bin("haze")
        .unwrap()
        .args(["render", "--scene"])
        .arg(smoke())
        .args(["--width", "48", "--height", "36", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{err}");
    err
}

/// The scene at 48 × 36, with the asset's `sigma_t` replaced by `sigma` if given.
fn scene(sigma: Option<&str>) -> haze_scene::Scene {
    let mut text = std::fs::read_to_string(smoke()).unwrap();
    if let Some(sigma) = sigma {
        let i = text.find("\"sigma_t\": ").unwrap() + "\"sigma_t\": ".len();
        let j = i + text[i..].find(',').unwrap();
        text = format!("{}{sigma}{}", &text[..i], &text[j..]);
    }
    let mut s = haze_scene::file::parse_in(&text, smoke().parent().unwrap()).unwrap();
    s.camera = s.camera.with_size(48, 36).unwrap();
    s
}

#[test]
fn renders_the_smoke_scene_with_its_shadow() {
    let dir = tempfile::tempdir().unwrap();
    let (a, r) = (dir.path().join("a.exr"), dir.path().join("r.exr"));
    let err = render(&[], &a);
    assert!(
        err.contains("48×36") && err.contains("march") && err.contains("plume.haze"),
        "{err}"
    );
    render(&["--reference"], &r);
    let (w, h, pa) = read_exr(&a);
    let (_, _, pr) = read_exr(&r);
    assert_eq!((w, h), (48, 36));
    // The CLI writes the library's march.
    let s = scene(None);
    let lib = haze_scene::march::render(&s, &Limits::default(), &march_options(&s, false), &|_| {});
    for (x, y) in pa.iter().zip(&lib.pixels) {
        for c in 0..3 {
            assert!(
                (x[c] - y[c]).abs() <= 1e-6 * (1.0 + y[c].abs()),
                "{x:?} vs {y:?}"
            );
        }
    }
    // Against the reference (a quarter of the step): the midpoint rule's error, measured
    // 4·10⁻⁵ relative RMS.
    let image = |p: Vec<[f32; 3]>| haze_scene::render::Image {
        width: w,
        height: h,
        pixels: p,
    };
    let e = image(pa.clone()).rel_rms(&image(pr));
    println!("march vs reference: {e:.2e} rel RMS");
    assert!(e < 0.01, "{e}");
    // The shadow: ground pixels whose camera ray misses the smoke's box, darker than the
    // same scene without smoke by more than a fifth.
    let clear = scene(Some("0"));
    let clear = haze_scene::march::render(
        &clear,
        &Limits::default(),
        &march_options(&clear, false),
        &|_| {},
    );
    let bounds = s.hetero[0].bounds().unwrap();
    let mut shadowed = 0;
    for y in 0..h {
        for x in 0..w {
            let dir = s.camera.pixel_ray(x, y);
            let ground = s.intersect(s.camera.eye, dir, 0.0, f64::INFINITY).is_some();
            let through = bounds.clip(s.camera.eye, dir, 0.0, f64::INFINITY).is_some();
            let i = y * w + x;
            if ground && !through && pa[i][1] < 0.8 * clear.pixels[i][1] {
                shadowed += 1;
            }
        }
    }
    println!("{shadowed} ground pixels in the smoke's shadow");
    assert!(shadowed >= 10, "{shadowed}");
}

/// `haze view --scene` without a window: the smoke scene renders on the GPU (the march)
/// while the camera turns.
#[test]
fn views_the_smoke_scene_without_a_window() {
    let o = Command::cargo_bin("haze")
        .unwrap()
        .args(["view", "--scene"])
        .arg(smoke())
        .args(["--size", "32x24", "--no-window", "--play-for", "0.3"])
        .output()
        .unwrap();
    let out = String::from_utf8(o.stdout).unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{err}");
    // One picture or more: the whole march of one may take longer than 0.3 s on a
    // loaded 2-core machine (lavapipe marches it in chunks, gpu::march::chunks).
    assert!(out.contains(" of 32×24"), "{out}");
    assert!(out.contains("with ray-traced surfaces"), "{out}");
}
