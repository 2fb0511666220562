//! End-to-end tests of `haze fog wavelet` on the bundled fogmap.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn fogmap() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/fogmap/fogmap_128.png")
}

fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

/// Renders the bundled fogmap small into `out` with extra arguments; returns stderr.
fn render(out: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "fog".to_string(),
        "wavelet".to_string(),
        fogmap().display().to_string(),
        "--out".to_string(),
        out.display().to_string(),
        "--width".to_string(),
        "64".to_string(),
        "--height".to_string(),
        "48".to_string(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    let o = haze().args(&args).output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{args:?}: {err}");
    err
}

fn read_exr(path: &Path) -> Vec<[f32; 3]> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| vec![[0.0f32; 3]; res.width() * res.height()],
        |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * 64 + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    assert_eq!(image.layer_data.size, Vec2(64, 48));
    image.layer_data.channel_data.pixels
}

/// Runs haze expecting one-line failure naming `needle`.
fn fails(args: &[&str], needle: &str) -> String {
    let out = haze().args(args).output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{args:?}");
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(err.starts_with("error: ") && err.contains(needle), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn renders_png_and_exr_of_the_bundled_fogmap() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("fog.png");
    let summary = render(&png, &[]);
    assert!(
        summary.contains("64 × 48, linear fogmap 128 × 128"),
        "{summary}"
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (64, 48));
    // Top row: sky (blue dominates); the fog makes part of the ground whiter than the
    // clear ground at the image's far left and right.
    let top = img.get_pixel(32, 0);
    assert!(top[2] > top[0], "{top:?}");
    let exr = dir.path().join("fog.exr");
    render(&exr, &[]);
    let px = read_exr(&exr);
    assert!(
        px.iter()
            .flatten()
            .all(|v| v.is_finite() && (0.0..=1.0).contains(v))
    );
    let clear = dir.path().join("clear.exr");
    render(&clear, &["--density", "0"]);
    let bare = read_exr(&clear);
    // Fog adds L_fog where it is: some pixels change a lot, the sky row not at all.
    let changed = px
        .iter()
        .zip(&bare)
        .filter(|(a, b)| (a[1] - b[1]).abs() > 0.1)
        .count();
    assert!(changed > 100, "{changed} pixels changed");
    assert_eq!(px[..64], bare[..64]);
    // Nothing else was left in the directory (outputs are renamed temp files).
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");
}

#[test]
fn direct_and_deconstructed_levels_give_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("ref.exr");
    render(
        &reference,
        &["--basis", "quadratic", "--min-transmittance", "0"],
    );
    let want = read_exr(&reference);
    for extra in [
        &["--levels", "3"][..],
        &["--levels", "3", "--direct"][..],
        &["--levels", "2", "--mu", "1"][..],
    ] {
        let out = dir.path().join("lod.exr");
        let mut args = vec!["--basis", "quadratic", "--min-transmittance", "0"];
        args.extend_from_slice(extra);
        render(&out, &args);
        let got = read_exr(&out);
        let worst = got
            .iter()
            .flatten()
            .zip(want.iter().flatten())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{extra:?}: {worst}");
    }
    // µ = 0 keeps only the coarsest of 4 levels: visibly different, still finite.
    let coarse = dir.path().join("coarse.exr");
    render(
        &coarse,
        &["--basis", "quadratic", "--levels", "4", "--mu", "0"],
    );
    let got = read_exr(&coarse);
    let worst = got
        .iter()
        .flatten()
        .zip(want.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst > 0.01, "µ = 0 changed nothing: {worst}");
}

#[test]
fn gpu_renders_the_cpu_image() {
    let dir = tempfile::tempdir().unwrap();
    for (extra, tol) in [
        // Exact integrals: f32 rounding only.
        (
            &[
                "--basis",
                "quadratic",
                "--levels",
                "3",
                "--mu",
                "0.7",
                "--min-transmittance",
                "0",
            ][..],
            1e-4,
        ),
        // Early exit: a ray may stop a cell earlier or later on either side, with its
        // transmittance below the threshold (1/1024) either way.
        (
            &["--basis", "haar", "--levels", "2", "--density", "0.5"][..],
            2.0 / 1024.0 + 1e-4,
        ),
    ] {
        let cpu = dir.path().join("cpu.exr");
        let gpu = dir.path().join("gpu.exr");
        render(&cpu, extra);
        let mut args = extra.to_vec();
        args.push("--gpu");
        let summary = render(&gpu, &args);
        assert!(summary.contains("on the GPU ("), "{summary}");
        let (want, got) = (read_exr(&cpu), read_exr(&gpu));
        // A ground point within f32 rounding of a checker line may take the other tone
        // (the two differ by 0.05 at most): a few pixels, no more.
        let (mut off, mut worst) = (0, 0.0f32);
        for (a, b) in got.iter().zip(&want) {
            let e = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max);
            if e > tol {
                assert!(e < 0.05, "{extra:?}: {a:?} vs {b:?}");
                off += 1;
            } else {
                worst = worst.max(e);
            }
        }
        println!("{extra:?}: largest difference {worst:e}, {off} checker pixels");
        assert!(off <= want.len() / 200, "{extra:?}: {off} pixels differ");
    }
    fails(
        &[
            "fog",
            "wavelet",
            fogmap().to_str().unwrap(),
            "--out",
            dir.path().join("x.png").to_str().unwrap(),
            "--gpu",
            "--direct",
        ],
        "--direct is CPU only",
    );
}

/// Largest channel difference between two images.
fn worst(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn wind_moves_the_fog_over_numbered_frames() {
    let dir = tempfile::tempdir().unwrap();
    // A fixed camera (the default one frames the fog at rest, wherever --origin puts it).
    let cam = ["--eye", "0,-90,20", "--target", "0,10,0", "--levels", "2"];
    let anim = dir.path().join("anim.exr");
    let mut args = cam.to_vec();
    args.extend(["--wind", "8,-4", "--frames", "3", "--fps", "2"]);
    let summary = render(&anim, &args);
    assert!(summary.contains("3 frames"), "{summary}");
    let frame = |k: usize| read_exr(&dir.path().join(format!("anim_{k:04}.exr")));
    assert!(!anim.exists());
    // Frame 0 is the fog at rest; frame 2 (t = 1 s) the fog placed 8, −4 units over: the
    // bundled map is 128 × 128 cells of 1, centred on 0,0 by default.
    let rest = dir.path().join("rest.exr");
    render(&rest, &cam);
    assert!(worst(&frame(0), &read_exr(&rest)) <= 1e-6);
    let placed = dir.path().join("placed.exr");
    let mut args = cam.to_vec();
    args.extend(["--origin", "-56,-68"]);
    render(&placed, &args);
    let want = read_exr(&placed);
    assert!(worst(&frame(2), &want) <= 1e-5);
    assert!(worst(&frame(1), &frame(0)) > 0.01, "the fog did not move");
    // --time alone, and on the GPU (uploaded once, moved per frame).
    let at = dir.path().join("at.exr");
    let mut args = cam.to_vec();
    args.extend([
        "--wind",
        "8,-4",
        "--time",
        "1",
        "--gpu",
        "--min-transmittance",
        "0",
    ]);
    render(&at, &args);
    let got = read_exr(&at);
    let off = got
        .iter()
        .zip(&want)
        .filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 2.0 / 1024.0))
        .count();
    assert!(off <= want.len() / 200, "{off} pixels differ");
    fails(
        &[
            "fog",
            "wavelet",
            fogmap().to_str().unwrap(),
            "--out",
            anim.to_str().unwrap(),
            "--fps",
            "0",
        ],
        "the rate positive",
    );
}

#[test]
fn a_directory_of_fogmaps_is_an_animation_decomposed_when_the_map_changes() {
    let dir = tempfile::tempdir().unwrap();
    let maps = dir.path().join("maps");
    std::fs::create_dir(&maps).unwrap();
    // Three 24 × 16 maps, numbered out of order on disk: 7 and 9 are the same bank of
    // fog, 12 a different one.
    let bank = |shift: u32| {
        image::GrayImage::from_fn(24, 16, |x, y| {
            let v = if (x + shift) % 24 < 12 && y > 3 {
                200
            } else {
                20
            };
            image::Luma([v])
        })
    };
    bank(0).save(maps.join("fog_9.png")).unwrap();
    bank(0).save(maps.join("fog_7.png")).unwrap();
    bank(8).save(maps.join("fog_12.png")).unwrap();
    let cam = [
        "--eye", "0,-30,12", "--target", "0,5,0", "--cell", "2", "--levels", "2",
    ];
    let run = |fogmap: &Path, out: &Path, extra: &[&str]| {
        let mut args = vec![
            "fog".to_string(),
            "wavelet".to_string(),
            fogmap.display().to_string(),
            "--out".to_string(),
            out.display().to_string(),
            "--width".to_string(),
            "64".to_string(),
            "--height".to_string(),
            "48".to_string(),
        ];
        args.extend(cam.iter().chain(extra).map(|s| s.to_string()));
        let o = haze().args(&args).output().unwrap();
        let err = String::from_utf8(o.stderr).unwrap();
        assert!(o.status.success(), "{args:?}: {err}");
        err
    };
    let anim = dir.path().join("anim.exr");
    let summary = run(&maps, &anim, &[]);
    assert!(summary.contains("(3 fogmaps, 2 decomposed)"), "{summary}");
    for (k, name) in [(0, "fog_7.png"), (1, "fog_9.png"), (2, "fog_12.png")] {
        let single = dir.path().join("single.exr");
        run(&maps.join(name), &single, &[]);
        let got = read_exr(&dir.path().join(format!("anim_{k:04}.exr")));
        assert!(worst(&got, &read_exr(&single)) <= 1e-6, "frame {k}");
    }
    // On the GPU, looping over 4 frames: frame 3 is fog_7 again.
    let summary = run(&maps, &anim, &["--gpu", "--frames", "4"]);
    assert!(summary.contains("(3 fogmaps, 3 decomposed)"), "{summary}");
    let first = read_exr(&dir.path().join("anim_0000.exr"));
    let last = read_exr(&dir.path().join("anim_0003.exr"));
    assert!(worst(&first, &last) <= 1e-6);
    assert!(worst(&first, &read_exr(&dir.path().join("anim_0002.exr"))) > 0.01);
    // A map of another size is refused, naming it.
    image::GrayImage::new(8, 8)
        .save(maps.join("fog_20.png"))
        .unwrap();
    let out = anim.to_str().unwrap();
    fails(
        &["fog", "wavelet", maps.to_str().unwrap(), "--out", out],
        "fog_20.png: 8 × 8, but the sequence's first fogmap is 24 × 16",
    );
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    fails(
        &["fog", "wavelet", empty.to_str().unwrap(), "--out", out],
        "no fogmaps",
    );
}

#[test]
fn bad_inputs_fail_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let o = out.to_str().unwrap();
    let missing = dir.path().join("missing.png");
    fails(
        &["fog", "wavelet", missing.to_str().unwrap(), "--out", o],
        missing.to_str().unwrap(),
    );
    let colour = dir.path().join("colour.png");
    image::RgbImage::from_raw(1, 1, vec![255, 0, 0])
        .unwrap()
        .save(&colour)
        .unwrap();
    fails(
        &["fog", "wavelet", colour.to_str().unwrap(), "--out", o],
        "must be greyscale",
    );
    let nan = dir.path().join("nan.f32");
    std::fs::write(&nan, f32::NAN.to_le_bytes()).unwrap();
    std::fs::write(nan.with_extension("json"), r#"{"dims": [1, 1]}"#).unwrap();
    fails(
        &["fog", "wavelet", nan.to_str().unwrap(), "--out", o],
        "is NaN",
    );
    let fm = fogmap();
    let fm = fm.to_str().unwrap();
    let e = fails(
        &["fog", "wavelet", fm, "--out", o, "--levels", "9"],
        "at most 7",
    );
    assert!(e.contains("fogmap_128.png"), "{e}");
    fails(
        &["fog", "wavelet", fm, "--out", o, "--mu", "1.5"],
        "µ = 1.5",
    );
    fails(
        &["fog", "wavelet", fm, "--out", o, "--density", "1e305"],
        "density 1e305 is too large",
    );
    // Cell sizes and falloffs past the numbers' reach: named, not NaN pictures or a
    // camera's complaint alone.
    for (flag, value, needle) in [
        ("--cell", "1e300", "cell size 1e300 makes the fog's box"),
        ("--cell", "1e-300", "framed on the fog at cell size 1e-300"),
        (
            "--falloff",
            "1e300",
            "falloff 1e300 must be between 0 and 1e30",
        ),
    ] {
        fails(&["fog", "wavelet", fm, "--out", o, flag, value], needle);
    }
    // The steepest falloff accepted renders a finite picture at the default 800 × 600 (33
    // rays' ends rounded below the slab once overflowed h to ∞, and ∞ · 0 to NaN, which
    // the writer refuses).
    let steep = dir.path().join("steep.png");
    let o_ok = haze()
        .args(["fog", "wavelet", fm, "--falloff", "1e30", "--out"])
        .arg(&steep)
        .output()
        .unwrap();
    assert!(
        o_ok.status.success(),
        "{}",
        String::from_utf8_lossy(&o_ok.stderr)
    );
    assert!(steep.exists());
    fails(
        &["fog", "wavelet", fm, "--out", "x.jpg"],
        "must be a .exr or .png",
    );
    fails(
        &[
            "fog", "wavelet", fm, "--out", o, "--eye", "1,2,3", "--target", "1,2,3",
        ],
        "coincide",
    );
    fails(
        &["fog", "wavelet", fm, "--out", o, "--top", "-1"],
        "top above bottom",
    );
    assert!(!out.exists());
}

#[test]
fn help_explains_the_model() {
    let out = haze().args(["fog", "wavelet", "--help"]).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "fogmap",
        "--levels",
        "--mu",
        "µ^l",
        "haar",
        "quadratic",
        "--gpu",
        "--wind",
        "--frames",
        "Examples",
    ] {
        assert!(text.contains(needle), "{needle} missing from --help");
    }
}

/// A baked asset of plume-a frame 24.
fn bake(dir: &Path) -> PathBuf {
    let out = dir.join("plume.haze");
    let vdb = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/plume-a/vdb");
    let o = haze()
        .args([
            "bake",
            vdb.to_str().unwrap(),
            "--frames",
            "24..24",
            "-q",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// Smoke in the fog: the plume, scaled and placed in the middle of the map, rising
/// through the fog layer. Where the smoke is, the image changes; the GPU composites the
/// CPU's smoke layer into the same image as the CPU (as `gpu_renders_the_cpu_image`, no
/// early exit); bad smoke arguments fail on one line.
#[test]
fn smoke_rises_through_the_fog_composited_by_depth() {
    let dir = tempfile::tempdir().unwrap();
    let asset = bake(dir.path());
    let view = [
        "--eye",
        "0,-60,12",
        "--target",
        "0,0,6",
        "--min-transmittance",
        "0",
    ];
    let smoke = [
        "--smoke",
        asset.to_str().unwrap(),
        "--smoke-scale",
        "4",
        "--smoke-offset=-6,-6,0",
    ];
    let plain = dir.path().join("plain.exr");
    render(&plain, &view);
    let cpu = dir.path().join("cpu.exr");
    let summary = render(&cpu, &[&view[..], &smoke[..]].concat());
    assert!(
        summary.contains("frame 24 (smoke lit and rendered in"),
        "{summary}"
    );
    let gpu = dir.path().join("gpu.exr");
    render(&gpu, &[&view[..], &smoke[..], &["--gpu"]].concat());
    let (plain, cpu, gpu) = (read_exr(&plain), read_exr(&cpu), read_exr(&gpu));
    // The smoke covers a small part of the picture: the plume's box spans x ∈ [−6, 6] and
    // z up to 16, 60 units away (about 10 × 14 of the 64 × 48 pixels), the plume a part
    // of it, its foot hidden in the fog.
    let changed = plain
        .iter()
        .zip(&cpu)
        .filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 0.01))
        .count();
    assert!((10..=140).contains(&changed), "{changed} pixels show smoke");
    let (mut off, mut largest) = (0, 0.0f32);
    for (a, b) in gpu.iter().zip(&cpu) {
        let e = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max);
        if e > 1e-4 {
            // A checker-line pixel (see `gpu_renders_the_cpu_image`).
            assert!(e < 0.05, "{a:?} vs {b:?}");
            off += 1;
        } else {
            largest = largest.max(e);
        }
    }
    println!("smoke: {changed} pixels changed; GPU vs CPU {largest:e}, {off} checker pixels");
    assert!(off <= cpu.len() / 200, "{off} pixels differ");
    let out = dir.path().join("x.png");
    let o = out.to_str().unwrap();
    let fm = fogmap();
    let fm = fm.to_str().unwrap();
    fails(
        &["fog", "wavelet", fm, "--out", o, "--smoke", fm],
        "--smoke takes a baked asset",
    );
    let missing = dir.path().join("missing.haze");
    fails(
        &[
            "fog",
            "wavelet",
            fm,
            "--out",
            o,
            "--smoke",
            missing.to_str().unwrap(),
        ],
        "missing.haze",
    );
    let a = asset.to_str().unwrap();
    fails(
        &[
            "fog",
            "wavelet",
            fm,
            "--out",
            o,
            "--smoke",
            a,
            "--smoke-scale",
            "0",
        ],
        "--smoke-scale 0",
    );
    fails(
        &[
            "fog",
            "wavelet",
            fm,
            "--out",
            o,
            "--smoke",
            a,
            "--smoke-frame",
            "3",
        ],
        "frame 3 is not in the asset",
    );
    fails(
        &[
            "fog",
            "wavelet",
            fm,
            "--out",
            o,
            "--smoke",
            a,
            "--smoke-albedo",
            "2",
        ],
        "albedo 2",
    );
    assert!(!out.exists());
}
