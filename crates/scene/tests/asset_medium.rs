//! The `"asset"` medium of a scene against independent evaluations: its extinction at
//! voxel centers against the frame's RBFs and residual summed by brute force (every RBF
//! evaluated, the residual looked up in the hash volume), between centers against the
//! trilinear blend of those brute-force values, its optical depth against fine midpoint
//! quadrature of its own extinction; and bad assets as one-line errors.

use haze_scene::media::Heterogeneous;
use haze_scene::media::asset::AssetMedium;
use haze_view::stream::FrameDecoder;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes")
}

fn medium(json: &str) -> Result<AssetMedium, String> {
    let v: serde_json::Value = serde_json::from_str(json).unwrap();
    AssetMedium::from_json(&v, &scenes())
}

#[test]
fn extinction_is_the_rbfs_plus_the_residual() {
    let (sigma, offset, scale) = (2.5, [-1.5, -1.5, 0.2], 0.8);
    let m = medium(
        r#"{"type": "asset", "path": "plume.haze", "frame": 24, "sigma_t": 2.5,
            "albedo": 0.7, "g": 0.2, "offset": [-1.5, -1.5, 0.2], "scale": 0.8}"#,
    )
    .unwrap();
    assert_eq!((m.albedo(), m.g()), ([0.7; 3], 0.2));
    // Brute force from the file: frame 24 is the fourth of 21..28.
    let asset = haze_asset::Asset::open(&scenes().join("plume.haze")).unwrap();
    let grid = asset.header().grid.clone();
    let mut dec = FrameDecoder::new(Arc::new(asset));
    let f = dec.decode(3).unwrap();
    assert_eq!(f.number, 24);
    let dims = grid.dims.map(|d| d as usize);
    let vs: [f64; 3] = [0, 1, 2].map(|a| (grid.bbox_max[a] - grid.bbox_min[a]) / dims[a] as f64);
    let local = |i: [usize; 3]| [0, 1, 2].map(|a| grid.bbox_min[a] + (i[a] as f64 + 0.5) * vs[a]);
    let brute = |i: [usize; 3]| -> f64 {
        let p = local(i);
        let d: f64 = f.rbfs.iter().map(|r| r.eval(p)).sum();
        let r = f
            .residual
            .as_ref()
            .map_or(0.0, |s| f64::from(s.lookup(i.map(|c| c as u32))));
        sigma * (d + r).max(0.0)
    };
    let world = |p: [f64; 3]| [0, 1, 2].map(|a| offset[a] + scale * p[a]);
    let mut s = Pcg64::seed_from_u64(1);
    let (mut checked, mut nonzero) = (0, 0);
    while checked < 3000 {
        let i = [0, 1, 2].map(|a| ((s.random::<f64>() * dims[a] as f64) as usize).min(dims[a] - 2));
        let want = brute(i);
        let got = m.sigma_t(world(local(i)))[0];
        // f32 storage of D: 2⁻²⁴ relative, plus the f64 sums' rounding.
        assert!(
            (got - want).abs() <= 1e-6 * (1.0 + want),
            "voxel {i:?}: {got} vs {want}"
        );
        // Midway to the next voxel along each axis: the mean of the eight corners'
        // brute-force values (trilinear at the cell's center).
        let mut mean = 0.0;
        for c in 0..8 {
            mean += brute([0, 1, 2].map(|a| i[a] + (c >> a & 1))) / 8.0;
        }
        let mid = [0, 1, 2].map(|a| local(i)[a] + 0.5 * vs[a]);
        let got = m.sigma_t(world(mid))[0];
        assert!(
            (got - mean).abs() <= 1e-6 * (1.0 + mean),
            "cell {i:?}: {got} vs {mean}"
        );
        nonzero += usize::from(want > 0.0);
        checked += 1;
    }
    assert!(nonzero > 100, "only {nonzero} voxels with smoke");
    // Outside the asset's box: no extinction.
    assert_eq!(m.sigma_t(world([-0.1, 1.5, 2.0])), [0.0; 3]);
    assert_eq!(m.sigma_t(world([1.5, 1.5, 4.01])), [0.0; 3]);
}

#[test]
fn optical_depth_matches_fine_quadrature() {
    let m = medium(
        r#"{"type": "asset", "path": "plume.haze", "frame": 22, "sigma_t": [1, 2, 3],
            "offset": [-1.5, -1.5, 0]}"#,
    )
    .unwrap();
    let b = m.bounds().unwrap();
    let mut s = Pcg64::seed_from_u64(9);
    for _ in 0..12 {
        // From a random point outside the box through a random point inside.
        let inside = [0, 1, 2].map(|a| b.min[a] + s.random::<f64>() * (b.max[a] - b.min[a]));
        let dir = haze_scene::vec3::normalize([0, 1, 2].map(|_| s.random::<f64>() - 0.5)).unwrap();
        let o = haze_scene::vec3::axpy(inside, -6.0, dir);
        let len = 12.0;
        let tau = m.optical_depth(o, dir, len);
        // Midpoint rule on 2·10⁵ steps of ≤ 4·10⁻⁵ (< 10⁻³ voxel): the kinks of the
        // trilinear field at the voxel planes and its curvature give an error ≲ 10⁻⁷ of
        // the integral.
        // Over the part inside the box, where the field is continuous (the jumps at its
        // faces would cost O(h)).
        let (t0, t1) = b.clip(o, dir, 0.0, len).unwrap();
        let n = 200_000;
        let h = (t1 - t0) / n as f64;
        let q: f64 = (0..n)
            .map(|i| m.sigma_t(haze_scene::vec3::axpy(o, t0 + (i as f64 + 0.5) * h, dir))[0])
            .sum::<f64>()
            * h;
        assert!((tau[0] - q).abs() <= 1e-6 * (1.0 + q), "{tau:?} vs {q}");
        assert!((tau[2] - 3.0 * tau[0]).abs() <= 1e-12 * (1.0 + tau[2]));
        let inf = m.optical_depth(o, dir, f64::INFINITY);
        assert!((inf[0] - tau[0]).abs() <= 1e-12 * (1.0 + q));
    }
}

#[test]
fn bad_assets_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk.haze");
    std::fs::write(&junk, b"not an asset at all, just text").unwrap();
    let cases = [
        (
            r#"{"type": "asset", "path": "missing.haze"}"#.to_string(),
            "missing.haze",
        ),
        (
            format!(r#"{{"type": "asset", "path": "{}"}}"#, junk.display()),
            "junk.haze",
        ),
        (
            r#"{"type": "asset", "path": "plume.haze", "frame": 99}"#.to_string(),
            "frame 99 is not in the asset (frames 21..28)",
        ),
        (
            r#"{"type": "asset", "path": "plume.haze", "scale": 0}"#.to_string(),
            "scale 0 must be positive",
        ),
        (
            r#"{"type": "asset", "path": "plume.haze", "g": 1}"#.to_string(),
            "g 1 must be in (-1, 1)",
        ),
        (
            r#"{"type": "asset", "path": "plume.haze", "sigma_t": -1}"#.to_string(),
            "must not be negative",
        ),
        (
            r#"{"type": "asset", "path": "plume.haze", "density": 1}"#.to_string(),
            "unknown field `density`",
        ),
    ];
    for (json, needle) in cases {
        let e = medium(&json).unwrap_err();
        assert!(e.contains(needle) && !e.contains('\n'), "{json}: {e}");
    }
    // Through the scene file: the entry is named, the asset found next to the scene.
    let scene = |media: &str| {
        haze_scene::file::parse_in(
            &format!(
                r#"{{"camera": {{"eye": [0, -5, 1], "target": [0, 0, 1]}}, "media": [{media}]}}"#
            ),
            &scenes(),
        )
    };
    let e = scene(r#"{"type": "homogeneous", "sigma_t": 0.1}, {"type": "asset", "path": "plume.haze", "frame": 7}"#)
        .unwrap_err();
    assert!(
        e.starts_with("media[1]: ") && e.contains("plume.haze: frame 7"),
        "{e}"
    );
    let s = scene(r#"{"type": "asset", "path": "plume.haze"}"#).unwrap();
    assert_eq!(s.hetero.len(), 1);
    assert_eq!(s.hetero[0].name(), "asset plume.haze");
}
