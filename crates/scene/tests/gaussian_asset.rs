//! A baked smoke frame as a Gaussian medium: `{"type": "gaussians", "asset": ..., "frame":
//! n, "offset": [...]}` reads the frame's RBFs as Gaussians, checked against the RBFs
//! written; bad frames and files are one-line errors.

use haze_asset::{AssetWriter, BlockKind, GridInfo, Header, Scope, SourceInfo, encode_rbfs};
use haze_scene::file;
use haze_scene::media::HeteroMedium;
use haze_volume::Rbf;
use std::path::Path;

fn rbfs(k: usize) -> Vec<Rbf> {
    (0..5)
        .map(|i| {
            let t = i as f64 + 0.3 * k as f64;
            Rbf::new(
                [t.sin(), t.cos(), 0.2 * t],
                0.1 + 0.02 * i as f64,
                0.5 + 0.1 * i as f64,
            )
        })
        .collect()
}

fn write_asset(path: &Path) {
    let mut w = AssetWriter::create(path).unwrap();
    for k in 0..2 {
        w.write_block(
            BlockKind::Rbfs,
            Scope::frame(k as u32),
            &encode_rbfs(&rbfs(k)),
        )
        .unwrap();
    }
    w.finish(&Header {
        generator: "haze-scene tests".into(),
        frame_count: 2,
        grid: GridInfo {
            dims: [8, 8, 8],
            bbox_min: [-2.0; 3],
            bbox_max: [2.0; 3],
        },
        source: SourceInfo {
            path: "synthetic".into(),
            grid: String::new(),
            frame_numbers: vec![40, 41],
        },
        settings: Default::default(),
        extra: Default::default(),
    })
    .unwrap();
}

fn scene(medium: &str) -> String {
    format!(
        r#"{{"camera": {{"eye": [0, -5, 0], "target": [0, 0, 0], "width": 8, "height": 6}},
            "media": [{medium}]}}"#
    )
}

#[test]
fn an_asset_frame_is_a_gaussian_medium() {
    let dir = tempfile::tempdir().unwrap();
    write_asset(&dir.path().join("smoke.haze"));
    let text = scene(
        r#"{"type": "gaussians", "sigma_t": 3, "albedo": 0.8, "asset": "smoke.haze",
            "frame": 41, "offset": [1, 0, -0.5],
            "gaussians": [{"center": [0, 0, 0], "radius": 0.3, "weight": 0.2}]}"#,
    );
    let s = file::parse_in(&text, dir.path()).unwrap();
    let HeteroMedium::Gaussians(m) = &s.hetero[0] else {
        panic!("not a Gaussian medium")
    };
    let gs = m.medium.gaussians();
    assert_eq!(gs.len(), 6);
    // The frame's RBFs (stored as f32), moved by the offset, after the listed Gaussian.
    let stored = haze_asset::decode_rbfs(&encode_rbfs(&rbfs(1))).unwrap();
    for (g, r) in gs[1..].iter().zip(&stored) {
        assert_eq!(g.radius, r.radius);
        assert_eq!(g.weight, r.weight);
        assert_eq!(
            g.center,
            [r.center[0] + 1.0, r.center[1], r.center[2] - 0.5]
        );
    }
    // The extinction is σt times the RBF sum there (no 3r cut-off; the medium drops only
    // what adds less than 10⁻¹⁰ of optical depth to any line).
    let x = [
        gs[2].center[0] + 0.05,
        gs[2].center[1],
        gs[2].center[2] - 0.04,
    ];
    let want: f64 = 3.0
        * gs.iter()
            .map(|g| {
                let d2: f64 = (0..3).map(|a| (x[a] - g.center[a]).powi(2)).sum();
                g.weight * (-d2 / (g.radius * g.radius)).exp()
            })
            .sum::<f64>();
    let got = s.hetero[0].sigma_t(x)[0];
    assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
    // Without "frame": the first.
    let first = file::parse_in(
        &scene(r#"{"type": "gaussians", "sigma_t": 1, "asset": "smoke.haze"}"#),
        dir.path(),
    )
    .unwrap();
    let HeteroMedium::Gaussians(m) = &first.hetero[0] else {
        panic!("not a Gaussian medium")
    };
    let g0 = m.medium.gaussians()[0];
    assert_eq!(
        g0.center,
        haze_asset::decode_rbfs(&encode_rbfs(&rbfs(0))).unwrap()[0].center
    );
}

#[test]
fn bad_asset_media_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_asset(&dir.path().join("smoke.haze"));
    for (medium, want) in [
        (
            r#"{"type": "gaussians", "sigma_t": 1, "asset": "smoke.haze", "frame": 7}"#,
            "frame 7 is not in the asset",
        ),
        (
            r#"{"type": "gaussians", "sigma_t": 1, "asset": "missing.haze"}"#,
            "missing.haze",
        ),
        (
            r#"{"type": "gaussians", "sigma_t": 1, "frame": 40}"#,
            "\"frame\" needs \"asset\"",
        ),
    ] {
        let e = file::parse_in(&scene(medium), dir.path()).unwrap_err();
        assert!(e.starts_with("media[0]: ") && e.contains(want), "{e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
