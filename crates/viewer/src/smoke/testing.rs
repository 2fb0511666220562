//! A small baked asset for the viewer's tests, written the way `haze bake` writes one
//! (an RBF block per frame, the residuals in hash volumes of 27 frames) without the
//! fitting: a
//! cluster of RBFs drifting along +X from frame to frame, and per frame a rippled residual
//! of both signs, quantized to 8 bits. And the viewer's default knobs.

use haze_asset::{AssetWriter, BlockKind, GridInfo, Header, Scope, SourceInfo, encode_rbfs};
use haze_hash::tile::{GROUP, ResidualGroup};
use haze_hash::{BuildOptions, QuantOptions, quantize};
use haze_volume::{Bbox, Rbf, rbf};
use std::path::{Path, PathBuf};

/// The test grid: 20 × 18 × 24 voxels over a box away from the origin.
pub const DIMS: [usize; 3] = [20, 18, 24];

pub fn bbox() -> Bbox {
    Bbox::new([-1.0, 2.0, 0.5], [1.0, 3.8, 2.9])
}

/// The RBFs of frame `k`: seven Gaussians, moved by `0.02·k` along X, the last one's
/// weight changing with `k` too.
pub fn rbfs(k: usize) -> Vec<Rbf> {
    let b = bbox();
    let s = b.size();
    [
        ([0.50, 0.50, 0.40], 0.14, 1.0),
        ([0.62, 0.45, 0.55], 0.10, 0.8),
        ([0.40, 0.58, 0.60], 0.11, 0.7),
        ([0.52, 0.50, 0.75], 0.08, 0.9),
        ([0.35, 0.40, 0.45], 0.07, 1.2),
        ([0.66, 0.62, 0.35], 0.09, 0.6),
        ([0.45, 0.45, 0.30], 0.10, 0.5 + 0.1 * k as f64),
    ]
    .into_iter()
    .map(|(c, r, w)| {
        let c =
            [0, 1, 2].map(|a| b.min[a] + c[a] * s[a] + if a == 0 { 0.02 * k as f64 } else { 0.0 });
        Rbf::new(c, r * s[0].min(s[1]).min(s[2]), w)
    })
    .collect()
}

/// Writes an asset of `frames` frames (numbered from 101) to `dir/name`.
pub fn write_asset(dir: &Path, name: &str, frames: usize) -> PathBuf {
    let path = dir.join(name);
    let b = bbox();
    let mut w = AssetWriter::create(&path).unwrap();
    let mut quantized = Vec::new();
    for k in 0..frames {
        let stored = haze_asset::decode_rbfs(&encode_rbfs(&rbfs(k))).unwrap();
        let approx = rbf::evaluate_on_grid(DIMS, &b, &stored);
        let r: Vec<f32> = approx
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let x = [
                    i % DIMS[0],
                    (i / DIMS[0]) % DIMS[1],
                    i / (DIMS[0] * DIMS[1]),
                ];
                let ripple =
                    (0.7 * x[0] as f64 + 0.5 * x[1] as f64 - 0.3 * x[2] as f64 + k as f64).sin();
                (a * 0.3 * ripple + 0.02 * ripple) as f32
            })
            .collect();
        quantized.push(quantize(&r, 1.0, QuantOptions::default()).unwrap());
        w.write_block(
            BlockKind::Rbfs,
            Scope::frame(k as u32),
            &encode_rbfs(&stored),
        )
        .unwrap();
    }
    // Hash volumes of up to 27 frames, as `haze bake` writes them.
    for (v, chunk) in quantized.chunks(GROUP).enumerate() {
        let group = ResidualGroup::build(DIMS.map(|n| n as u32), 4, chunk, BuildOptions::default())
            .unwrap();
        w.write_block(
            BlockKind::ResidualHash,
            Scope::Frames {
                first: (v * GROUP) as u32,
                count: chunk.len() as u32,
            },
            &haze_hash::block::encode(&group).unwrap(),
        )
        .unwrap();
    }
    w.finish(&Header {
        generator: "haze viewer tests".into(),
        frame_count: frames as u32,
        grid: GridInfo {
            dims: DIMS.map(|n| n as u32),
            bbox_min: b.min,
            bbox_max: b.max,
        },
        source: SourceInfo {
            path: "synthetic".into(),
            grid: String::new(),
            frame_numbers: (0..frames as i64).map(|k| 101 + k).collect(),
        },
        settings: Default::default(),
        extra: Default::default(),
    })
    .unwrap();
    path
}

/// The knobs `haze view` starts with by default (no ground).
pub fn default_knobs() -> super::Knobs {
    super::Knobs {
        sigma_t: 4.0,
        albedo: 0.8,
        g: 0.3,
        sh_order: 4,
        slices: 2.0,
        multiple: true,
        residual: true,
        sky_per_voxel: true,
        orders: true,
        orders_model: haze_view::render::MsDiffusion::DEFAULT,
        exposure: 1.0,
        tone: haze_core::ToneMap::Filmic,
        ground: None,
    }
}
