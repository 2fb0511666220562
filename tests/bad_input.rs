//! The standing bad-input suite: scene files, flags and assets mutated at random
//! (proptest), each run of the `haze` binary held to the promise of the README — it
//! succeeds with only finite values in what it wrote, or it fails with exit status 1 or 2
//! and one line on stderr, without a panic, its inputs untouched and nothing left behind.
//!
//! Cost: 3 properties × 32 cases of an 8 × 6 picture or an `inspect`, about 10 s on two
//! cores (`PROPTEST_CASES` raises the count for a longer hunt).

mod support;

use proptest::prelude::*;
use proptest::test_runner::Config;
use std::path::Path;
use support::*;

/// What a run must show: success with only finite values in the images it wrote, or
/// refusal by the promise.
fn holds_the_promise(dir: &Path, args: &[&str]) -> Result<(), TestCaseError> {
    let before = snapshot(dir);
    let run = haze().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&run.stderr).to_string();
    prop_assert!(
        !err.contains("panicked") && !err.contains("internal error"),
        "{args:?}: {err}"
    );
    let after = snapshot(dir);
    for (p, bytes) in &before {
        prop_assert_eq!(
            after.get(p),
            Some(bytes),
            "{:?}: input {:?} touched",
            args,
            p
        );
    }
    if run.status.success() {
        for o in after.keys().filter(|p| !before.contains_key(*p)) {
            if o.extension().is_some_and(|e| e == "exr") {
                for v in exr_values(o) {
                    prop_assert!(v.is_finite(), "{:?}: {:?} holds {}", args, o, v);
                }
            }
        }
    } else {
        prop_assert!(matches!(run.status.code(), Some(1 | 2)), "{args:?}: {err}");
        prop_assert_eq!(err.lines().count(), 1, "{:?}: {}", args, err);
        prop_assert!(
            !err.trim_end_matches('\n').chars().any(char::is_control),
            "{args:?}: a control character in {err:?}"
        );
        prop_assert!(err.starts_with("error: "), "{args:?}: {err}");
        let new: Vec<_> = after.keys().filter(|p| !before.contains_key(*p)).collect();
        prop_assert!(new.is_empty(), "{:?}: left behind {:?}", args, new);
    }
    Ok(())
}

/// Every value of an RGB(A) OpenEXR file.
fn exr_values(path: &Path) -> Vec<f32> {
    let img = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |_, _| Vec::new(),
        |px: &mut Vec<f32>, _, (r, g, b, a): (f32, f32, f32, f32)| px.extend([r, g, b, a]),
    )
    .unwrap();
    img.layer_data.channel_data.pixels
}

/// Values that break naive code: extremes, signs, non-numbers.
const NASTY: &[&str] = &[
    "1e308",
    "-1e308",
    "-1",
    "0",
    "1e-320",
    "1e6",
    "-0",
    "2",
    "null",
    "\"x\"",
    "[]",
    "[1, 2]",
    "99999999999999999999",
    "{}",
    "true",
];

/// One way to damage a JSON text.
#[derive(Debug, Clone)]
enum Mutation {
    /// The `k`-th number (mod their count) replaced.
    Number(usize, &'static str),
    /// Cut after a fraction of the text.
    Truncate(f64),
    /// A key repeated at the start of the `k`-th object.
    Duplicate(usize, &'static str),
    /// One byte replaced.
    Byte(f64, u8),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), prop::sample::select(NASTY)).prop_map(|(k, v)| Mutation::Number(k, v)),
        (0.0..1.0).prop_map(Mutation::Truncate),
        (
            any::<usize>(),
            prop::sample::select(&["\"sigma_t\": 2", "\"type\": \"point\"", "\"camera\": {}"][..])
        )
            .prop_map(|(k, v)| Mutation::Duplicate(k, v)),
        (0.0..1.0, any::<u8>()).prop_map(|(at, b)| Mutation::Byte(at, b)),
    ]
}

fn apply(text: &str, m: &Mutation) -> Vec<u8> {
    let bytes = text.as_bytes();
    match *m {
        Mutation::Number(k, v) => {
            // Spans of numbers: a digit run with its sign, point and exponent.
            let mut spans = Vec::new();
            let mut i = 0;
            while i < bytes.len() {
                if bytes[i].is_ascii_digit() {
                    let start = if i > 0 && bytes[i - 1] == b'-' {
                        i - 1
                    } else {
                        i
                    };
                    let mut j = i;
                    while j < bytes.len() && (bytes[j].is_ascii_alphanumeric() || bytes[j] == b'.')
                    {
                        j += 1;
                    }
                    spans.push((start, j));
                    i = j;
                } else {
                    i += 1;
                }
            }
            let (a, b) = spans[k % spans.len()];
            [&bytes[..a], v.as_bytes(), &bytes[b..]].concat()
        }
        Mutation::Truncate(f) => bytes[..(f * bytes.len() as f64) as usize].to_vec(),
        Mutation::Duplicate(k, key) => {
            let opens: Vec<usize> = (0..bytes.len()).filter(|&i| bytes[i] == b'{').collect();
            let at = opens[k % opens.len()] + 1;
            [&bytes[..at], key.as_bytes(), b", ", &bytes[at..]].concat()
        }
        Mutation::Byte(f, b) => {
            let mut v = bytes.to_vec();
            let at = ((f * v.len() as f64) as usize).min(v.len() - 1);
            v[at] = b;
            v
        }
    }
}

/// 32 cases per property, or `PROPTEST_CASES`.
fn config() -> Config {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(32);
    Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// A damaged scene file (analytic fog, a homogeneous medium and a Gaussian one in
    /// turn) renders to finite values or is refused by the promise.
    #[test]
    fn a_damaged_scene_file_renders_finite_or_is_refused(m in mutation(), which in 0..3usize) {
        let medium = match which {
            0 => analytic("0.3", "0.1"),
            1 => r#"{"type": "homogeneous", "sigma_t": 0.2, "albedo": 0.8}"#.to_string(),
            _ => r#"{"type": "gaussians", "sigma_t": 2, "gaussians": [{"center": [0, 0, 1], "radius": 0.5, "weight": 1}]}"#.to_string(),
        };
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let scene = d.join("s.json");
        std::fs::write(&scene, apply(&fog_scene(&medium), &m)).unwrap();
        let out = d.join("o.exr");
        holds_the_promise(
            d,
            &["render", "--scene", s(&scene), "--out", s(&out), "--width", "8", "--height", "6"],
        )?;
    }

    /// `haze fog wavelet` with one flag set to an extreme or malformed value.
    #[test]
    fn an_extreme_fog_flag_renders_finite_or_is_refused(
        flag in prop::sample::select(&[
            "--mu", "--density", "--levels", "--cell", "--falloff", "--bottom", "--top",
            "--min-transmittance", "--fov", "--time", "--fps", "--width", "--height",
            "--eye", "--wind", "--origin", "--fog-color", "--frames",
        ][..]),
        value in prop::sample::select(&[
            "-1", "0", "1e308", "-1e308", "nan", "inf", "1e-308", "3", "abc", "",
            "1,2", "0,0,1e308", "-1,-1,-1", "1e9,1e9", "2",
        ][..]),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let fogmap = d.join("f.png");
        std::fs::copy(data("fogmap/fogmap_128.png"), &fogmap).unwrap();
        let out = d.join("o.exr");
        let mut args = vec!["fog", "wavelet", s(&fogmap), "--out", s(&out)];
        if flag != "--width" {
            args.extend(["--width", "8"]);
        }
        if flag != "--height" {
            args.extend(["--height", "6"]);
        }
        args.extend([flag, value]);
        holds_the_promise(d, &args)?;
    }

    /// An asset with a byte flipped, cut short or extended is inspected or refused.
    #[test]
    fn a_damaged_asset_is_inspected_or_refused(at in 0.0..1.0f64, byte in any::<u8>(), how in 0..3usize) {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let asset = d.join("a.haze");
        let mut bytes = std::fs::read(data("scenes/plume.haze")).unwrap();
        let k = ((at * bytes.len() as f64) as usize).min(bytes.len() - 1);
        match how {
            0 => bytes[k] ^= byte.max(1),
            1 => bytes.truncate(k),
            _ => bytes.extend(std::iter::repeat_n(byte, k % 97 + 1)),
        }
        std::fs::write(&asset, &bytes).unwrap();
        holds_the_promise(d, &["inspect", s(&asset)])?;
    }
}
