//! End-to-end tests of `haze render` on the bundled plume-a data: a baked asset and a raw
//! volume, both renderers, and the one-line errors.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn data(p: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(p)
        .display()
        .to_string()
}

fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = haze().args(args).output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{args:?}: {err}");
    err
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

/// A flag's value refused as typed: clap's usage error (exit 2), on one line naming it.
fn refused_as_typed(args: &[&str], needle: &str) {
    let o = haze().args(args).output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.lines().count() == 1 && err.contains(needle), "{err}");
}

fn read_exr(path: &Path, w: usize, h: usize) -> Vec<[f32; 3]> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| vec![[0.0f32; 3]; res.width() * res.height()],
        move |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * w + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    assert_eq!(image.layer_data.size, Vec2(w, h));
    image.layer_data.channel_data.pixels
}

/// A `--gpu` image against the CPU's: f32 arithmetic (crates/view's gpu_volume_pass and
/// gpu_view_pass tests measure ≈ 1e-6 relative) and the march's early exit, which may stop
/// a slice apart and change a pixel by OPAQUE = 1e-4 times the brightest radiance (the
/// sky's sun, < 10).
fn assert_close(gpu: &[[f32; 3]], cpu: &[[f32; 3]]) {
    assert_eq!(gpu.len(), cpu.len());
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        for k in 0..3 {
            assert!(
                (g[k] - c[k]).abs() <= 1e-4 * c[k].abs() + 1e-3,
                "pixel {i}: GPU {g:?}, CPU {c:?}"
            );
        }
    }
}

fn tmp(dir: &tempfile::TempDir, name: &str) -> PathBuf {
    dir.path().join(name)
}

#[test]
fn renders_a_baked_frame_and_a_volume() {
    let dir = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.display().to_string();
    let asset = tmp(&dir, "plume.haze");
    ok(&[
        "bake",
        &data("plume-a/vdb"),
        "--frames",
        "21..22",
        "--out",
        &s(&asset),
        "-q",
    ]);
    let exr = tmp(&dir, "frame.exr");
    let size = ["--width", "40", "--height", "30"];
    // The centers' diffusion, the GPU's (the CPU's default gathers orders on a grid).
    let mut args = vec!["render", asset.to_str().unwrap(), "--frame", "22"];
    args.extend(["--diffusion", "centers", "--out", exr.to_str().unwrap()]);
    // The size as `haze view` takes it (the GPU renders below take --width, --height).
    args.extend(["--size", "40x30"]);
    let err = ok(&args);
    assert!(
        err.contains("compensated ray marching") && err.contains("40×30"),
        "{err}"
    );
    let crm = read_exr(&exr, 40, 30);
    assert!(crm.iter().flatten().all(|c| c.is_finite() && *c >= 0.0));
    // On the GPU, the residual looked up in the asset's hash volume, the light computed
    // where `auto` puts it and on either side: the same image (`assert_close`).
    for lighting in ["auto", "cpu", "gpu"] {
        let gpu_exr = tmp(&dir, &format!("gpu-{lighting}.exr"));
        let mut args = vec!["render", asset.to_str().unwrap(), "--frame", "22", "--gpu"];
        args.extend(["--diffusion", "centers"]);
        args.extend(["--lighting", lighting, "--out", gpu_exr.to_str().unwrap()]);
        args.extend(size);
        let err = ok(&args);
        assert!(err.contains("on the GPU"), "{err}");
        if lighting != "auto" {
            let side = lighting.to_uppercase();
            assert!(err.contains(&format!("lighting on the {side}")), "{err}");
        }
        assert_close(&read_exr(&gpu_exr, 40, 30), &crm);
    }
    // The default on either side, the explicit orders (on the GPU: gpu::orders): the same
    // image within `assert_close`'s bound plus 1e-2 of the light the multiple scattering
    // adds (the orders' twin, crates/view's gpu_orders and gpu_renderer tests; its first
    // source reads the environment grid, which the GPU marches in f32).
    let mut orders = Vec::new();
    for extra in [&[][..], &["--gpu"], &["--no-multiple"]] {
        let exr = tmp(&dir, &format!("orders-{}.exr", orders.len()));
        let mut args = vec!["render", asset.to_str().unwrap(), "--frame", "22"];
        args.extend(["--out", exr.to_str().unwrap()]);
        args.extend(size);
        args.extend(extra);
        ok(&args);
        orders.push(read_exr(&exr, 40, 30));
    }
    let (cpu, gpu, single) = (&orders[0], &orders[1], &orders[2]);
    for (i, ((g, c), s)) in gpu.iter().zip(cpu).zip(single).enumerate() {
        for k in 0..3 {
            let ms = (c[k] - s[k]).abs();
            assert!(
                (g[k] - c[k]).abs() <= 1e-4 * c[k].abs() + 1e-3 + 1e-2 * ms,
                "pixel {i}: GPU {g:?}, CPU {c:?}, single scattering {s:?}"
            );
        }
    }
    assert!(mean(cpu) > 1.01 * mean(single), "the orders add light");
    // The smoke in the middle of the frame is not the sky behind it.
    let without = tmp(&dir, "sky.exr");
    let mut args = vec!["render", asset.to_str().unwrap(), "--sigma-t", "0", "--out"];
    args.push(without.to_str().unwrap());
    args.extend(size);
    ok(&args);
    let sky = read_exr(&without, 40, 30);
    let centre = 15 * 40 + 20;
    assert!(
        (crm[centre][2] - sky[centre][2]).abs() > 0.02,
        "{:?} vs {:?}",
        crm[centre],
        sky[centre]
    );

    // A raw volume is fitted on the fly; the reference renderer reads it directly.
    let png = tmp(&dir, "volume.png");
    let vol = data("plume-a/dense/density_0024.f32");
    let mut args = vec!["render", &vol, "--sh-order", "2", "--no-multiple", "--out"];
    args.push(png.to_str().unwrap());
    args.extend(size);
    ok(&args);
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // With --gpu the fitted volume's dense residual is uploaded: the same image again.
    let mut images = Vec::new();
    for gpu in [false, true] {
        let exr = tmp(&dir, &format!("volume-{gpu}.exr"));
        let mut args = vec!["render", &vol, "--sh-order", "2", "--no-multiple", "--out"];
        args.push(exr.to_str().unwrap());
        args.extend(size);
        if gpu {
            args.push("--gpu");
        }
        ok(&args);
        images.push(read_exr(&exr, 40, 30));
    }
    assert_close(&images[1], &images[0]);
    // Multiple scattering on the voxel grid adds light to single scattering.
    let grid = tmp(&dir, "grid.exr");
    let mut args = vec![
        "render",
        &vol,
        "--sh-order",
        "2",
        "--diffusion",
        "grid:3",
        "--out",
    ];
    args.push(grid.to_str().unwrap());
    args.extend(size);
    ok(&args);
    let with_grid = read_exr(&grid, 40, 30);
    assert!(with_grid.iter().flatten().all(|c| c.is_finite()));
    assert!(
        mean(&with_grid) > 1.01 * mean(&images[0]),
        "{} vs {}",
        mean(&with_grid),
        mean(&images[0])
    );
    // The default on the CPU, explicit orders on the grid: light added, and close to
    // the grid's diffusion (both estimate the same multiple scattering).
    let orders = tmp(&dir, "orders.exr");
    let mut args = vec!["render", &vol, "--sh-order", "2", "--out"];
    args.push(orders.to_str().unwrap());
    args.extend(size);
    ok(&args);
    let with_orders = read_exr(&orders, 40, 30);
    assert!(with_orders.iter().flatten().all(|c| c.is_finite()));
    let (single, ms) = (mean(&images[0]), mean(&with_orders));
    assert!(ms > 1.01 * single, "{ms} vs {single}");
    let (a, b) = (ms - single, mean(&with_grid) - single);
    assert!(
        (a - b).abs() < 0.5 * b,
        "multiple part {a} vs the grid's {b}"
    );
    let reference = tmp(&dir, "reference.exr");
    let mut args = vec!["render", &vol, "--reference", "--spp", "2", "--out"];
    args.push(reference.to_str().unwrap());
    args.extend(size);
    let err = ok(&args);
    assert!(
        err.contains("reference multiple scattering, 2 spp"),
        "{err}"
    );
    assert!(
        read_exr(&reference, 40, 30)
            .iter()
            .flatten()
            .all(|c| c.is_finite())
    );
}

#[test]
fn bad_render_requests_fail_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let vol = data("plume-a/dense/density_0024.f32");
    let out = tmp(&dir, "x.png");
    let out = out.to_str().unwrap();
    fails(&["render", &vol, "--out", "x.tiff"], "unknown image type");
    fails(
        &["render", &vol, "--out", out, "--sh-order", "9"],
        "--sh-order 9",
    );
    fails(
        &["render", &vol, "--out", out, "--env", "nowhere.exr"],
        "nowhere.exr",
    );
    // --size conflicts with --width and must be WxH: clap's one-line usage errors (exit 2).
    for (size, needle) in [
        (["--size", "40x30", "--width", "40"], "cannot be used with"),
        (["--size", "40", "--sh-order", "4"], "not a size WxH"),
    ] {
        let o = haze()
            .args(["render", &vol, "--out", out])
            .args(size)
            .output()
            .unwrap();
        let err = String::from_utf8(o.stderr).unwrap();
        assert_eq!(o.status.code(), Some(2), "{size:?}: {err}");
        assert!(err.lines().count() == 1 && err.contains(needle), "{err}");
    }
    // Maps that are not lat-long, or hold a bad texel.
    let bad_map = |name: &str, w: usize, h: usize, v: f32| {
        let p = tmp(&dir, name);
        exr::prelude::write_rgb_file(&p, w, h, |x, _| {
            if x == 1 {
                (v, 0.0, 0.0)
            } else {
                (1.0, 1.0, 1.0)
            }
        })
        .unwrap();
        p.to_str().unwrap().to_string()
    };
    let wide = bad_map("wide.exr", 30, 10, 1.0);
    fails(
        &["render", &vol, "--out", out, "--env", &wide],
        "not lat-long",
    );
    // `inspect` describes it as the image it is, not a map.
    let said = ok(&["-q", "inspect", &wide]);
    assert!(said.is_empty(), "{said}");
    let o = haze().args(["inspect", &wide]).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("image (OpenEXR), 30 × 10, not a lat-long environment map"),
        "{text}"
    );
    let nan = bad_map("nan.exr", 8, 4, f32::NAN);
    fails(
        &["render", &vol, "--out", out, "--env", &nan],
        "finite and non-negative",
    );
    fails(&["inspect", &nan], "finite and non-negative");
    let negative = bad_map("negative.exr", 8, 4, -1.0);
    fails(
        &["render", &vol, "--out", out, "--env", &negative],
        "finite and non-negative",
    );
    // A damaged .hdr header's bytes quoted in the error, escaped: one line, nothing
    // for the terminal to act on (a vertical tab broke the line).
    let garbled = dir.path().join("garbled.hdr");
    let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_\x0bgbe\n\n-Y 2 +X 4\n".to_vec();
    bytes.extend([100u8, 120, 140, 128].repeat(8));
    std::fs::write(&garbled, bytes).unwrap();
    let o = haze()
        .args(["inspect", garbled.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("garbled.hdr") && err.contains("\\u{b}"),
        "{err:?}"
    );
    assert!(!err.trim_end().chars().any(char::is_control), "{err:?}");
    fails(&["render", &vol, "--out", out, "--albedo", "1.5"], "albedo");
    // Extremes as typed, not 300 digits.
    for (flag, value, needle) in [
        ("--albedo", "1e300", "albedo 1e300 must be in [0, 1]"),
        ("--g", "-1e300", "g = -1e300 must be in"),
        (
            "--budget-ms",
            "-1e300",
            "--budget-ms -1e300 must be a positive",
        ),
        (
            "--lighting-detail",
            "1e300",
            "the lighting detail 1e300 must be",
        ),
    ] {
        fails(&["render", &vol, "--out", out, flag, value], needle);
    }
    // A grid spacing finer than a quarter voxel (it once allocated exabytes and aborted):
    // clap's one-line usage error (exit 2).
    let o = haze()
        .args(["render", &vol, "--out", out, "--env-grid-spacing", "1e-9"])
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.lines().count() == 1 && err.contains("at least 0.25"),
        "{err}"
    );
    fails(&["render", &vol, "--out", out, "--slices", "0"], "--slices");
    for reuse in ["-0.001", "0.5", "nan", "1e300"] {
        fails(
            &["render", &vol, "--out", out, "--pixel-reuse", reuse],
            "--pixel-reuse",
        );
    }
    fails(
        &[
            "render",
            &vol,
            "--out",
            out,
            "--gpu",
            "--pixel-reuse",
            "0.002",
        ],
        "CPU's fast view pass only",
    );
    for detail in ["0", "1.5", "-1", "nan"] {
        fails(
            &["render", &vol, "--out", out, "--lighting-detail", detail],
            "--lighting-detail",
        );
    }
    fails(
        &["render", &vol, "--out", out, "--eye", "1,2,3"],
        "--target",
    );
    fails(&["render", "missing.haze", "--out", out], "missing.haze");
    fails(
        &["render", &vol, "--out", out, "--diffusion", "grid:0"],
        "grid:0",
    );
    fails(
        &["render", &vol, "--out", out, "--gpu", "--diffusion", "grid"],
        "CPU only",
    );
    fails(
        &[
            "render",
            &vol,
            "--out",
            out,
            "--gpu",
            "--diffusion",
            "orders",
            "--source",
            "footprint",
        ],
        "--source grid",
    );
    fails(
        &["render", &vol, "--out", out, "--diffusion", "orders:2:9"],
        "orders:2:9",
    );
    assert!(!Path::new(out).exists(), "a failed render left an image");
}

/// Without a GPU adapter `--gpu` says so on one line, before any work (here the Vulkan
/// loader is pointed at no driver at all).
#[cfg(target_os = "linux")]
#[test]
fn gpu_without_an_adapter_fails_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let vol = data("plume-a/dense/density_0024.f32");
    let out = tmp(&dir, "x.exr");
    let o = haze()
        .args(["render", &vol, "--gpu", "--out", out.to_str().unwrap()])
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(
        err.starts_with("error: --gpu: no GPU adapter found")
            && err.contains("mesa-vulkan-drivers libvulkan1"),
        "{err}"
    );
    assert!(!out.exists());
    // The reference renderer has no GPU path.
    let o = haze()
        .args(["render", &vol, "--gpu", "--reference", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        String::from_utf8(o.stderr)
            .unwrap()
            .contains("cannot be used with")
    );
}

fn mean(px: &[[f32; 3]]) -> f64 {
    px.iter()
        .map(|p| f64::from(p[0] + p[1] + p[2]))
        .sum::<f64>()
        / (3 * px.len()) as f64
}

/// Suns and point lights from the command line, a map's sun split off (and kept whole
/// with --no-sun-extraction), the same map as a Radiance .hdr, and the reference's noise
/// in its summary line.
#[test]
fn suns_lights_and_a_maps_sun_reach_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let vol = data("plume-a/dense/density_0024.f32");
    let size = ["--width", "40", "--height", "30"];
    let render = |name: &str, extra: &[&str]| {
        let out = tmp(&dir, name);
        let mut args = vec!["-v", "render", vol.as_str(), "--out", out.to_str().unwrap()];
        args.extend_from_slice(&size);
        args.extend_from_slice(extra);
        let log = ok(&args);
        (read_exr(&out, 40, 30), log)
    };
    let (plain, _) = render("plain.exr", &[]);
    let (sun, _) = render("sun.exr", &["--sun", "0.3,-1,0.5,20000,19000,18000,3"]);
    let (light, _) = render("light.exr", &["--light", "-1,-1,1,40,40,40"]);
    assert!(
        mean(&sun) > 1.05 * mean(&plain),
        "{} vs {}",
        mean(&sun),
        mean(&plain)
    );
    assert!(mean(&light) > mean(&plain));
    // The brightest lights the flags take (`MAX_LIGHT`) render finite pictures on the
    // CPU and with the lighting on the GPU (f32); a brighter one is refused as typed,
    // before any rendering.
    let brightest = [
        "--sun",
        "0.3,-1,0.5,1e30,1e30,1e30,0",
        "--light",
        "-0.2,0.1,0.3,1e30,1e30,1e30",
    ];
    for extra in [&[][..], &["--gpu", "--lighting", "gpu"]] {
        let mut args = brightest.to_vec();
        args.extend_from_slice(extra);
        let (px, _) = render("brightest.exr", &args);
        assert!(px.iter().flatten().all(|c| c.is_finite()), "{extra:?}");
        assert!(mean(&px) > 1e20, "{extra:?}: {}", mean(&px));
    }
    for (flag, value, needle) in [
        ("--sun", "0,0,1,1,1e45,1", "sun radiance 1e45 is above 1e30"),
        (
            "--light",
            "0,0,1,2e30,1,1",
            "light intensity 2e30 is above 1e30",
        ),
    ] {
        refused_as_typed(&["render", vol.as_str(), flag, value], needle);
    }
    // A lat-long map, dim sky with a small bright sun.
    let (w, h) = (64usize, 32usize);
    let map = tmp(&dir, "env.exr");
    exr::prelude::write_rgb_file(&map, w, h, |x, y| {
        if (x, y) == (10, 8) || (x, y) == (11, 8) {
            (500.0f32, 480.0, 450.0)
        } else if (x, y) == (42, 12) {
            (300.0f32, 320.0, 400.0)
        } else {
            (0.3f32, 0.4, 0.6)
        }
    })
    .unwrap();
    let map = map.to_str().unwrap();
    let (split, log) = render("split.exr", &["--env", map]);
    assert!(log.contains("2 suns split off"), "{log}");
    assert!(log.contains("sun 2: elevation"), "{log}");
    // The GPU lights with the same suns and map: the same picture within 1 %.
    let (split_gpu, log) = render("split-gpu.exr", &["--env", map, "--gpu"]);
    assert!(log.contains("on the GPU"), "{log}");
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (g, c) in split_gpu.iter().zip(&split) {
        for k in 0..3 {
            diff += f64::from(g[k] - c[k]).powi(2);
            norm += f64::from(c[k]).powi(2);
        }
    }
    assert!(
        (diff / norm).sqrt() < 0.01,
        "GPU vs CPU: {}",
        (diff / norm).sqrt()
    );
    // The render's estimate of its own error, in the summary line.
    let (_, log) = render("checked.exr", &["--check", "32"]);
    assert!(log.contains("estimated error"), "{log}");
    assert!(log.contains("pixels × 128 reference samples"), "{log}");
    // A black map lights nothing, and says so.
    let black = tmp(&dir, "black.exr");
    exr::prelude::write_rgb_file(&black, 8, 4, |_, _| (0.0f32, 0.0, 0.0)).unwrap();
    let (_, log) = render("lit-by-black.exr", &["--env", black.to_str().unwrap()]);
    assert!(log.contains("the map is black"), "{log}");
    // A 1 × 1 map is accepted as a uniform sky, and says so.
    let uniform = tmp(&dir, "uniform.exr");
    exr::prelude::write_rgb_file(&uniform, 1, 1, |_, _| (0.5f32, 0.6, 0.7)).unwrap();
    let (_, log) = render("lit-by-uniform.exr", &["--env", uniform.to_str().unwrap()]);
    assert!(
        log.contains("the same radiance from every direction"),
        "{log}"
    );
    // The same sky as a Radiance .hdr (RGBE, values exact in both formats) lights the
    // smoke as its OpenEXR twin does, to the bit.
    let texel = |x: usize, y: usize| match (x, y) {
        (10 | 11, 8) => ([500.0f32, 480.0, 450.0], [250u8, 240, 225, 137]),
        (42, 12) => ([300.0, 320.0, 400.0], [150, 160, 200, 137]),
        _ => ([0.3125, 0.4375, 0.625], [80, 112, 160, 128]),
    };
    let twin = tmp(&dir, "twin.exr");
    exr::prelude::write_rgb_file(&twin, w, h, |x, y| {
        let [r, g, b] = texel(x, y).0;
        (r, g, b)
    })
    .unwrap();
    let hdr = tmp(&dir, "twin.hdr");
    let mut rgbe = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for y in 0..h {
        for x in 0..w {
            rgbe.extend(texel(x, y).1);
        }
    }
    std::fs::write(&hdr, rgbe).unwrap();
    let (from_exr, _) = render("from-exr.exr", &["--env", twin.to_str().unwrap()]);
    let (from_hdr, log) = render("from-hdr.exr", &["--env", hdr.to_str().unwrap()]);
    assert!(log.contains("2 suns split off"), "{log}");
    assert_eq!(from_exr, from_hdr);
    // `haze inspect` of the map says the same before any render.
    let o = haze()
        .args(["inspect", hdr.to_str().unwrap()])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("environment map (Radiance HDR), 64 × 32, lat-long")
            && said.contains("light: 2 suns split off"),
        "{said}"
    );
    // Of a rendered picture it says what it is, with its mean (the test's own sum).
    let picture = tmp(&dir, "plain.exr");
    let o = haze()
        .args(["inspect", "--json", picture.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let said: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(said["kind"], "image");
    assert_eq!(
        (said["width"].as_u64(), said["height"].as_u64()),
        (Some(40), Some(30))
    );
    let red = plain.iter().map(|p| f64::from(p[0])).sum::<f64>() / plain.len() as f64;
    let said_red = said["mean_rgb"][0].as_f64().unwrap();
    assert!((said_red / red - 1.0).abs() < 1e-9, "{said_red} vs {red}");
    fails(
        &[
            "inspect",
            picture.to_str().unwrap(),
            "--env-layout",
            "blender",
        ],
        "a 40×30 picture is not a lat-long map (twice as wide as it is tall), so --env-layout",
    );
    let (whole, log) = render("whole.exr", &["--env", map, "--no-sun-extraction"]);
    assert!(!log.contains("sun split off"), "{log}");
    assert!(
        log.contains("kept whole by --no-sun-extraction it is blurred"),
        "{log}"
    );
    // The same light either way: the images agree in the mean within the SH blur.
    let (a, b) = (mean(&split), mean(&whole));
    assert!((a / b - 1.0).abs() < 0.2, "{a} vs {b}");
    let out = tmp(&dir, "ref.exr");
    let log = ok(&[
        "render",
        &vol,
        "--out",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "12",
        "--reference",
        "--spp",
        "4",
        "--sun",
        "0.3,-1,0.5,20000,19000,18000",
    ]);
    assert!(log.contains("noise ≈"), "{log}");
}

/// A point light inside the smoke is named with the share of its first scattering the
/// grids smooth (`near_light`), one outside it is not.
#[test]
fn a_point_light_in_the_smoke_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let asset = data("scenes/plume.haze");
    let out = tmp(&dir, "lamp.exr");
    let render = |light: &str| {
        ok(&[
            "-v",
            "render",
            &asset,
            "--light",
            light,
            "--width",
            "16",
            "--height",
            "12",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    // In the stem of the bundled plume's first frame: 37 % within 1.5 voxels.
    let inside = render("1.5,1.5,1.2,20,20,20");
    let warned: Vec<&str> = inside.lines().filter(|l| l.contains("WARN")).collect();
    assert!(
        warned.len() == 1
            && warned[0].contains("point light 1 at (1.5, 1.5, 1.2) sits in the smoke: 37 %"),
        "{inside}"
    );
    // Beside the box: nothing near it, said at -v only.
    let outside = render("3.5,-1,2,20,20,20");
    assert!(!outside.contains("sits in the smoke"), "{outside}");
    assert!(
        outside.contains("point light 1 at (3.5, -1, 2): 0.0 % of its first scattering"),
        "{outside}"
    );
}

/// A sun below the horizon, over the ground under the smoke: the ground hides it, so the
/// smoke is lit as without it (the picture the same as with that sun dark), and the user
/// is told; without a ground it lights the smoke from below. The path tracer sees the
/// same scene.
#[test]
fn the_ground_hides_a_sun_below_the_horizon() {
    let dir = tempfile::tempdir().unwrap();
    let asset = data("scenes/plume.haze");
    let render = |name: &str, sun: &str, extra: &[&str]| {
        let out = tmp(&dir, name);
        let mut args = vec![
            "render",
            asset.as_str(),
            "--sun",
            sun,
            "--width",
            "24",
            "--height",
            "18",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let log = ok(&args);
        (read_exr(&out, 24, 18), log)
    };
    let below = "0.3,-0.9,-0.3,12,11,9,0";
    let (hidden, log) = render("hidden.exr", below, &[]);
    assert!(
        log.contains("sun 1 is below the horizon (elevation -17.5°): the ground hides it"),
        "{log}"
    );
    let (dark, quiet) = render("dark.exr", "0.3,-0.9,-0.3,0,0,0,0", &[]);
    assert!(!quiet.contains("WARN"), "{quiet}");
    assert_eq!(hidden, dark);
    let (lit, _) = render("lit.exr", below, &["--ground", "off"]);
    let (unlit, _) = render("unlit.exr", "0.3,-0.9,-0.3,0,0,0,0", &["--ground", "off"]);
    assert!(
        mean(&lit) > 1.05 * mean(&unlit),
        "{} vs {}",
        mean(&lit),
        mean(&unlit)
    );
    let (reference, _) = render("ref.exr", below, &["--reference", "--spp", "2"]);
    let (reference_dark, _) = render(
        "ref_dark.exr",
        "0.3,-0.9,-0.3,0,0,0,0",
        &["--reference", "--spp", "2"],
    );
    assert_eq!(reference, reference_dark);
}

/// `--env-layout blender` reads a map as Blender's World does: the picture is, to the
/// bit, the one lit by the map laid out in haze's convention by hand (column `x` of
/// Blender's at column `w/2 − 1 − x` of haze's); `--env-rotate` turns the map and its
/// split-off sun about +Z; `--env-strength` scales its radiance; a non-finite angle and
/// a negative strength are refused.
#[test]
fn a_map_is_read_in_blenders_layout_and_turned() {
    let dir = tempfile::tempdir().unwrap();
    let vol = data("plume-a/dense/density_0024.f32");
    let (w, h) = (64usize, 32usize);
    // A dim sky and a sun at column 5 (azimuth 30.9° in haze's layout), 20° up.
    let texel = |x: usize, y: usize| {
        if (x, y) == (5, 12) {
            (900.0f32, 850.0, 800.0)
        } else {
            (0.3f32, 0.4, 0.6)
        }
    };
    let blender = tmp(&dir, "blender.exr");
    exr::prelude::write_rgb_file(&blender, w, h, texel).unwrap();
    let by_hand = tmp(&dir, "by-hand.exr");
    exr::prelude::write_rgb_file(&by_hand, w, h, |x, y| texel((w / 2 + w - 1 - x) % w, y)).unwrap();
    let render = |name: &str, map: &Path, extra: &[&str]| {
        let out = tmp(&dir, name);
        let mut args = vec![
            "-v",
            "render",
            vol.as_str(),
            "--env",
            map.to_str().unwrap(),
            "--width",
            "20",
            "--height",
            "15",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let log = ok(&args);
        (read_exr(&out, 20, 15), log)
    };
    let (read, log) = render("read.exr", &blender, &["--env-layout", "blender"]);
    assert!(log.contains("azimuth 149.1°"), "{log}");
    let (laid, _) = render("laid.exr", &by_hand, &[]);
    assert_eq!(read, laid);
    let (plain, log) = render("plain.exr", &blender, &[]);
    assert!(log.contains("azimuth 30.9°"), "{log}");
    assert_ne!(plain, read, "the mirrored sky lights the smoke otherwise");
    // --env-strength multiplies the map's radiance: the map written twice as bright.
    let brighter = tmp(&dir, "brighter.exr");
    exr::prelude::write_rgb_file(&brighter, w, h, |x, y| {
        let (r, g, b) = texel(x, y);
        (2.0 * r, 2.0 * g, 2.0 * b)
    })
    .unwrap();
    let (doubled, _) = render("doubled.exr", &blender, &["--env-strength", "2"]);
    let (written, _) = render("written.exr", &brighter, &[]);
    assert_eq!(doubled, written);
    let (_, log) = render("turned.exr", &blender, &["--env-rotate", "-30.9"]);
    assert!(
        log.contains("azimuth 0.0°") || log.contains("azimuth 360.0°"),
        "{log}"
    );
    // `haze inspect` places the map as the render does: the same sun, the same azimuth.
    let inspect = |extra: &[&str]| {
        let mut args = vec!["inspect", "--json", blender.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = haze().args(&args).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let sun = &j["suns"][0];
        let f = |k: &str| sun[k].as_f64().unwrap();
        (
            f("azimuth_degrees"),
            f("elevation_degrees"),
            j["power"].as_f64().unwrap(),
        )
    };
    let (a0, e0, p0) = inspect(&[]);
    // Column 5's centre: 360°·5.5/64 in haze's layout, 180° less that in Blender's.
    assert!((a0 - 30.9375).abs() < 1e-9, "{a0}");
    let (a, e, p) = inspect(&["--env-layout", "blender"]);
    assert!(
        (a - 149.0625).abs() < 1e-9 && e == e0 && (p / p0 - 1.0).abs() < 1e-12,
        "{a} {e} {p} {p0}"
    );
    // Turned by four texels (22.5°); the columns summed in another order, so the power
    // to rounding.
    let (a, _, p) = inspect(&["--env-layout", "blender", "--env-rotate", "22.5"]);
    assert!(
        (a - 171.5625).abs() < 1e-9 && (p / p0 - 1.0).abs() < 1e-12,
        "{a} {p}"
    );
    let (_, _, p) = inspect(&["--env-strength", "2"]);
    assert_eq!(p, 2.0 * p0);
    fails(
        &["inspect", vol.as_str(), "--env-rotate", "10"],
        "not an environment map (.exr, .hdr), so --env-layout, --env-rotate and --env-strength do not apply",
    );
    for (flag, value, needle) in [
        (
            "--env-rotate",
            "nan",
            "'nan' is not a finite angle in degrees",
        ),
        (
            "--env-strength",
            "-1",
            "'-1' is not a finite factor of at least 0",
        ),
    ] {
        refused_as_typed(&["render", vol.as_str(), flag, value], needle);
    }
}
