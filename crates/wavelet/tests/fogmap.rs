//! Fogmap files: every accepted format, row order, and every refusal with its message.

use haze_wavelet::Fogmap;
use std::path::{Path, PathBuf};

fn bundled() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/fogmap/fogmap_128.png")
}

fn error_of(path: &Path) -> String {
    let e = Fogmap::load(path).unwrap_err().to_string();
    assert!(
        e.starts_with(&path.display().to_string()),
        "file not named: {e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
    e
}

#[test]
fn bundled_fogmap_is_128_square_in_unit_range() {
    let f = Fogmap::load(&bundled()).unwrap();
    assert_eq!((f.width, f.height), (128, 128));
    assert!(f.values.iter().all(|v| (0.0..=1.0).contains(v)));
    // Clear gaps and dense banks both present.
    assert!(f.values.contains(&0.0) && f.values.contains(&1.0));
}

#[test]
fn png_greyscale_8_and_16_bit_rows_flipped_to_north_up() {
    let dir = tempfile::tempdir().unwrap();
    let p8 = dir.path().join("a.png");
    // 3 × 2, top row 0 10 20, bottom row 30 40 255.
    image::GrayImage::from_raw(3, 2, vec![0, 10, 20, 30, 40, 255])
        .unwrap()
        .save(&p8)
        .unwrap();
    let f = Fogmap::load(&p8).unwrap();
    assert_eq!((f.width, f.height), (3, 2));
    // Coefficient row 0 is the south (bottom) image row.
    let want = [30.0, 40.0, 255.0, 0.0, 10.0, 20.0].map(|v| v / 255.0);
    assert_eq!(f.values, want);
    let p16 = dir.path().join("b.png");
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(2, 1, vec![0u16, 65535])
        .unwrap()
        .save(&p16)
        .unwrap();
    assert_eq!(Fogmap::load(&p16).unwrap().values, [0.0, 1.0]);
}

#[test]
fn png_rgb_accepted_only_when_grey() {
    let dir = tempfile::tempdir().unwrap();
    let grey = dir.path().join("grey.png");
    image::RgbImage::from_raw(2, 1, vec![51, 51, 51, 0, 0, 0])
        .unwrap()
        .save(&grey)
        .unwrap();
    assert_eq!(Fogmap::load(&grey).unwrap().values, [0.2, 0.0]);
    let colour = dir.path().join("colour.png");
    image::RgbImage::from_raw(2, 1, vec![51, 51, 51, 0, 9, 0])
        .unwrap()
        .save(&colour)
        .unwrap();
    let e = error_of(&colour);
    assert!(e.contains("pixel (column 1, row 0) is not grey"), "{e}");
    let alpha = dir.path().join("alpha.png");
    image::GrayAlphaImage::from_raw(1, 1, vec![10, 128])
        .unwrap()
        .save(&alpha)
        .unwrap();
    assert!(error_of(&alpha).contains("alpha channel"));
}

fn write_exr(path: &Path, channels: &[(&str, Vec<f32>)], w: usize, h: usize) {
    use exr::prelude::*;
    let list: Vec<AnyChannel<FlatSamples>> = channels
        .iter()
        .map(|(name, v)| AnyChannel::new(*name, FlatSamples::F32(v.clone())))
        .collect();
    let layer = Layer::new(
        (w, h),
        LayerAttributes::named("fog"),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list.into()),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

#[test]
fn exr_y_single_or_grey_rgb_channels() {
    let dir = tempfile::tempdir().unwrap();
    let y = dir.path().join("y.exr");
    write_exr(&y, &[("Y", vec![0.5, 2.0, 0.0, 3.5])], 2, 2);
    assert_eq!(Fogmap::load(&y).unwrap().values, [0.0, 3.5, 0.5, 2.0]);
    let single = dir.path().join("density.exr");
    write_exr(&single, &[("density", vec![1.0, 0.25])], 2, 1);
    assert_eq!(Fogmap::load(&single).unwrap().values, [1.0, 0.25]);
    let rgb = dir.path().join("rgb.exr");
    let c = vec![0.1f32, 0.2];
    write_exr(&rgb, &[("R", c.clone()), ("G", c.clone()), ("B", c)], 2, 1);
    assert_eq!(
        Fogmap::load(&rgb).unwrap().values,
        [0.1f32 as f64, 0.2f32 as f64]
    );
    let colour = dir.path().join("colour.exr");
    write_exr(
        &colour,
        &[
            ("R", vec![0.1, 0.2]),
            ("G", vec![0.1, 0.3]),
            ("B", vec![0.1, 0.2]),
        ],
        2,
        1,
    );
    assert!(error_of(&colour).contains("must be greyscale"));
    let two = dir.path().join("two.exr");
    write_exr(&two, &[("A", vec![1.0]), ("Z", vec![1.0])], 1, 1);
    assert!(error_of(&two).contains("needs a Y channel"));
    let nan = dir.path().join("nan.exr");
    write_exr(&nan, &[("Y", vec![0.0, f32::NAN])], 2, 1);
    assert!(error_of(&nan).contains("(column 1, row 0) is NaN"));
}

fn write_npy<T: npyz::AutoSerialize + Copy>(path: &Path, shape: &[u64], data: &[T], fortran: bool) {
    use npyz::WriterBuilder;
    let mut out = Vec::new();
    let order = if fortran {
        npyz::Order::Fortran
    } else {
        npyz::Order::C
    };
    let mut w = npyz::WriteOptions::new()
        .default_dtype()
        .shape(shape)
        .order(order)
        .writer(&mut out)
        .begin_nd()
        .unwrap();
    w.extend(data.iter().copied()).unwrap();
    w.finish().unwrap();
    std::fs::write(path, out).unwrap();
}

#[test]
fn npy_c_and_fortran_order() {
    let dir = tempfile::tempdir().unwrap();
    let c = dir.path().join("c.npy");
    // [[1, 2, 3], [4, 5, 6]]: top row 1 2 3.
    write_npy(&c, &[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], false);
    let f = Fogmap::load(&c).unwrap();
    assert_eq!((f.width, f.height), (3, 2));
    assert_eq!(f.values, [4.0, 5.0, 6.0, 1.0, 2.0, 3.0]);
    let fo = dir.path().join("f.npy");
    write_npy(&fo, &[2, 3], &[1.0, 4.0, 2.0, 5.0, 3.0, 6.0], true);
    assert_eq!(Fogmap::load(&fo).unwrap(), f);
    let empty = dir.path().join("empty.npy");
    write_npy(&empty, &[0, 3], &[0f64; 0], false);
    assert!(error_of(&empty).contains("empty fogmap (3 × 0 pixels)"));
    let cube = dir.path().join("cube.npy");
    write_npy(&cube, &[2, 2, 2], &[1.0; 8], false);
    assert!(error_of(&cube).contains("needs 2 dimensions"));
    // A batch or channel axis of length 1 is dropped: the same fogmap.
    for (name, shape) in [("batch.npy", [1, 2, 3]), ("channel.npy", [2, 3, 1])] {
        let p = dir.path().join(name);
        write_npy(&p, &shape, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], false);
        assert_eq!(Fogmap::load(&p).unwrap(), f);
    }
}

/// 8- and 16-bit NumPy and raw fogmaps are scaled to `[0, 1]` as a PNG's are, and a
/// signed type is refused with its name.
#[test]
fn integer_fogmaps_scale_as_pngs_do() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("u8.npy");
    write_npy(&p, &[1, 3], &[0u8, 51, 255], false);
    let f = Fogmap::load(&p).unwrap();
    let want = [0.0, 51.0f32 / 255.0, 1.0].map(f64::from);
    assert_eq!(f.values, want);
    let p = dir.path().join("u16.f32");
    let bytes: Vec<u8> = [0u16, 13107, 65535]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(&p, bytes).unwrap();
    std::fs::write(
        p.with_extension("json"),
        r#"{"dims": [3, 1], "dtype": "uint16"}"#,
    )
    .unwrap();
    let want = [0.0, 13107.0f32 / 65535.0, 1.0].map(f64::from);
    assert_eq!(Fogmap::load(&p).unwrap().values, want);
    let p = dir.path().join("i4.npy");
    write_npy(&p, &[1, 2], &[1i32, 2], false);
    assert!(error_of(&p).contains("dtype '<i4' is not supported: use float16"));
}

#[test]
fn raw_float32_with_sidecar_and_its_refusals() {
    let dir = tempfile::tempdir().unwrap();
    let raw = |name: &str, v: &[f32], json: Option<&str>| {
        let p = dir.path().join(format!("{name}.f32"));
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(&p, bytes).unwrap();
        if let Some(j) = json {
            std::fs::write(p.with_extension("json"), j).unwrap();
        }
        p
    };
    let ok = raw(
        "ok",
        &[0.0, 1.0, 2.0, 3.0],
        Some(r#"{"dims": [2, 2], "note": "x"}"#),
    );
    assert_eq!(Fogmap::load(&ok).unwrap().values, [2.0, 3.0, 0.0, 1.0]);
    let nan = raw("nan", &[0.0, f32::NAN], Some(r#"{"dims": [2, 1]}"#));
    assert!(error_of(&nan).contains("pixel (column 1, row 0) is NaN"));
    let neg = raw("neg", &[-0.5], Some(r#"{"dims": [1, 1]}"#));
    assert!(error_of(&neg).contains("negative"));
    let inf = raw("inf", &[f32::INFINITY], Some(r#"{"dims": [1, 1]}"#));
    assert!(error_of(&inf).contains("not a finite number"));
    let short = raw("short", &[1.0], Some(r#"{"dims": [2, 2]}"#));
    assert!(error_of(&short).contains("need 4 float32 values"));
    let int16 = raw(
        "int16",
        &[1.0],
        Some(r#"{"dims": [1, 1], "dtype": "int16"}"#),
    );
    assert!(error_of(&int16).contains("dtype 'int16' is not supported"));
    let empty = raw("empty", &[], Some(r#"{"dims": [0, 0]}"#));
    assert!(error_of(&empty).contains("empty fogmap"));
    let no_sidecar = raw("lonely", &[1.0], None);
    assert!(error_of(&no_sidecar).contains("sidecar"));
    let bad_dims = raw("bad", &[1.0], Some(r#"{"dims": [1, 1, 2]}"#));
    assert!(error_of(&bad_dims).contains("must be [width, height]"));
}

#[test]
fn unreadable_and_unknown_files() {
    let dir = tempfile::tempdir().unwrap();
    let fake = dir.path().join("fake.png");
    std::fs::write(&fake, "not an image").unwrap();
    assert!(error_of(&fake).contains("not a readable PNG"));
    let txt = dir.path().join("fog.txt");
    std::fs::write(&txt, "1 2 3").unwrap();
    assert!(error_of(&txt).contains("unknown fogmap format"));
    let missing = dir.path().join("missing.exr");
    assert!(error_of(&missing).contains("not a readable EXR"));
}
