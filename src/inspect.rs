//! `haze inspect`: what is in a volume file, a sequence or an asset.

use anyhow::Result;
use haze_asset::{Asset, BlockKind};
use haze_render::progress;
use haze_volume::import::{self, FrameRange, Sequence, vdb};
use haze_volume::{ImportOptions, Volume, VolumeStats};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

pub fn run(path: &Path, json: bool, range: FrameRange, opts: &ImportOptions) -> Result<()> {
    let report = if is_asset(path) {
        Report::Asset(asset_report(path)?)
    } else if path.is_file() {
        Report::File(file_report(path, opts)?)
    } else {
        Report::Sequence(sequence_report(path, range, opts)?)
    };
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.text());
    }
    Ok(())
}

fn is_asset(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"))
}

#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
enum Report {
    File(FileReport),
    Sequence(SequenceReport),
    Asset(AssetReport),
}

/// The grid and values of one volume.
#[derive(Serialize)]
struct GridReport {
    dims: [usize; 3],
    voxels: usize,
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
    voxel_size: [f64; 3],
    value_min: f32,
    value_max: f32,
    value_sum: f64,
    active_voxels: usize,
    active_index_bbox: Option<[[usize; 3]; 2]>,
    memory_bytes: usize,
}

impl GridReport {
    fn of(v: &Volume) -> Self {
        let s = VolumeStats::of(v);
        GridReport {
            dims: v.dims(),
            voxels: v.len(),
            bbox_min: v.bbox().min,
            bbox_max: v.bbox().max,
            voxel_size: v.voxel_size(),
            value_min: s.min,
            value_max: s.max,
            value_sum: s.sum,
            active_voxels: s.nonzero,
            active_index_bbox: s.nonzero_bbox,
            memory_bytes: v.memory_bytes(),
        }
    }

    fn text(&self, out: &mut String) {
        let d = self.dims;
        line(
            out,
            "dims",
            format!("{} × {} × {} ({} voxels)", d[0], d[1], d[2], self.voxels),
        );
        line(
            out,
            "world box",
            format!("{} .. {}", vec3(self.bbox_min), vec3(self.bbox_max)),
        );
        line(out, "voxel size", vec3(self.voxel_size));
        line(
            out,
            "values",
            format!(
                "{} .. {} (sum {:.6})",
                self.value_min, self.value_max, self.value_sum
            ),
        );
        let pct = 100.0 * self.active_voxels as f64 / self.voxels.max(1) as f64;
        let bx = match self.active_index_bbox {
            Some([lo, hi]) => format!(", index box {lo:?}..{hi:?}"),
            None => String::new(),
        };
        line(
            out,
            "active",
            format!("{} voxels ({pct:.2} %){bx}", self.active_voxels),
        );
        line(
            out,
            "memory",
            format!("{} dense f32", bytes(self.memory_bytes as u64)),
        );
    }
}

#[derive(Serialize)]
struct FileReport {
    path: String,
    format: import::Format,
    file_bytes: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    vdb: Option<vdb::VdbFileInfo>,
    #[serde(skip_serializing_if = "Option::is_none")]
    grid: Option<String>,
    #[serde(flatten)]
    values: GridReport,
}

fn file_report(path: &Path, opts: &ImportOptions) -> Result<FileReport> {
    let format = import::format_of(path)?;
    let vdb_info = match format {
        import::Format::Vdb => Some(vdb::probe(path)?),
        _ => None,
    };
    let v = import::import(path, opts)?;
    Ok(FileReport {
        path: path.display().to_string(),
        format,
        file_bytes: std::fs::metadata(path)?.len(),
        grid: vdb_info.as_ref().map(|_| opts.grid.clone()),
        vdb: vdb_info,
        values: GridReport::of(&v),
    })
}

#[derive(Serialize)]
struct FrameSummary {
    frame: i64,
    path: String,
    value_min: f32,
    value_max: f32,
    active_voxels: usize,
}

#[derive(Serialize)]
struct SequenceReport {
    path: String,
    format: import::Format,
    frames: usize,
    first_frame: i64,
    last_frame: i64,
    /// Missing frame numbers as inclusive [first, last] ranges.
    gaps: Vec<[i64; 2]>,
    missing_frames: i64,
    dims: [usize; 3],
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
    voxel_size: [f64; 3],
    value_min: f32,
    value_max: f32,
    active_voxels_min: usize,
    active_voxels_max: usize,
    memory_bytes_per_frame: usize,
    memory_bytes_total: usize,
    per_frame: Vec<FrameSummary>,
}

fn sequence_report(path: &Path, range: FrameRange, opts: &ImportOptions) -> Result<SequenceReport> {
    let seq = Sequence::open(path, opts, range)?;
    let bar = progress::frames(seq.len(), "reading");
    let mut per_frame = Vec::with_capacity(seq.len());
    let mut voxel_size = [0.0; 3];
    for (i, f) in seq.frames().iter().enumerate() {
        bar.set_position(i as u64);
        let v = seq.load(i)?;
        voxel_size = v.voxel_size();
        let s = VolumeStats::of(&v);
        per_frame.push(FrameSummary {
            frame: f.number,
            path: f.path.display().to_string(),
            value_min: s.min,
            value_max: s.max,
            active_voxels: s.nonzero,
        });
    }
    bar.finish_and_clear();
    let gaps: Vec<[i64; 2]> = seq.gaps().iter().map(|&(a, b)| [a, b]).collect();
    if !gaps.is_empty() {
        tracing::warn!("{}: missing frames {}", path.display(), gap_text(&gaps));
    }
    let per = seq.dims().iter().product::<usize>() * 4;
    let fold = |init: f32, f: fn(f32, f32) -> f32, get: fn(&FrameSummary) -> f32| {
        per_frame.iter().map(get).fold(init, f)
    };
    Ok(SequenceReport {
        path: path.display().to_string(),
        format: seq.format(),
        frames: seq.len(),
        first_frame: seq.frames()[0].number,
        last_frame: seq.frames()[seq.len() - 1].number,
        missing_frames: gaps.iter().map(|g| g[1] - g[0] + 1).sum(),
        gaps,
        dims: seq.dims(),
        bbox_min: seq.bbox().min,
        bbox_max: seq.bbox().max,
        voxel_size,
        value_min: fold(f32::INFINITY, f32::min, |f| f.value_min),
        value_max: fold(f32::NEG_INFINITY, f32::max, |f| f.value_max),
        active_voxels_min: per_frame.iter().map(|f| f.active_voxels).min().unwrap_or(0),
        active_voxels_max: per_frame.iter().map(|f| f.active_voxels).max().unwrap_or(0),
        memory_bytes_per_frame: per,
        memory_bytes_total: per * seq.len(),
        per_frame,
    })
}

#[derive(Serialize)]
struct KindSummary {
    blocks: usize,
    bytes: u64,
}

#[derive(Serialize)]
struct AssetReport {
    path: String,
    format_version: u32,
    file_bytes: usize,
    header: haze_asset::Header,
    blocks: usize,
    blocks_by_kind: BTreeMap<String, KindSummary>,
    checksums_verified: bool,
    frames: Vec<AssetFrame>,
}

/// What an asset holds for one frame.
#[derive(Serialize)]
struct AssetFrame {
    frame: i64,
    rbfs: Option<usize>,
    rel_l2: Option<f64>,
    rms_over_max: Option<f64>,
    /// The frame's share of its residual hash volume, in bytes (0: none stored).
    hash_bytes: Option<f64>,
}

fn asset_report(path: &Path) -> Result<AssetReport> {
    let asset = Asset::open(path)?;
    let bar = progress::frames(asset.entries().len(), "verifying");
    let mut rbfs_per_frame = vec![None; asset.frame_count()];
    for i in 0..asset.entries().len() {
        bar.set_position(i as u64);
        let view = asset.block(i)?;
        match view.kind() {
            BlockKind::RawVolume => {
                haze_asset::decode_raw_volume(view.bytes)
                    .map_err(|e| asset.block_error(&view, e))?;
            }
            BlockKind::Rbfs => {
                let rbfs =
                    haze_asset::decode_rbfs(view.bytes).map_err(|e| asset.block_error(&view, e))?;
                if let haze_asset::Scope::Frames { first, .. } = view.id.scope {
                    rbfs_per_frame[first as usize] = Some(rbfs.len());
                }
            }
            BlockKind::ResidualHash => {
                haze_hash::block::decode(view.bytes).map_err(|e| asset.block_error(&view, e))?;
            }
            BlockKind::Unknown(_) => {}
        }
    }
    bar.finish_and_clear();
    let fits = asset
        .header()
        .settings
        .get("fit")
        .and_then(|f| f.get("frames"));
    let frames = (0..asset.frame_count())
        .map(|k| AssetFrame {
            frame: asset
                .header()
                .source
                .frame_numbers
                .get(k)
                .copied()
                .unwrap_or(k as i64),
            rbfs: rbfs_per_frame[k],
            rel_l2: fits
                .and_then(|f| f.get(k))
                .and_then(|f| f["rel_l2"].as_f64()),
            rms_over_max: fits
                .and_then(|f| f.get(k))
                .and_then(|f| f["rms_over_max"].as_f64()),
            hash_bytes: fits
                .and_then(|f| f.get(k))
                .and_then(|f| f["hash_bytes"].as_f64()),
        })
        .collect();
    let mut by_kind: BTreeMap<String, KindSummary> = BTreeMap::new();
    for e in asset.entries() {
        let k = by_kind.entry(e.kind.name()).or_insert(KindSummary {
            blocks: 0,
            bytes: 0,
        });
        k.blocks += 1;
        k.bytes += e.len;
    }
    Ok(AssetReport {
        path: path.display().to_string(),
        format_version: asset.format_version(),
        file_bytes: asset.file_len(),
        header: asset.header().clone(),
        blocks: asset.entries().len(),
        blocks_by_kind: by_kind,
        checksums_verified: true,
        frames,
    })
}

impl Report {
    fn text(&self) -> String {
        let mut out = String::new();
        match self {
            Report::File(r) => {
                let what = match &r.vdb {
                    Some(v) => format!(
                        "OpenVDB, file version {}, library {}",
                        v.file_version, v.library_version
                    ),
                    None => format!("{} volume", r.format.name()),
                };
                out.push_str(&format!("{}  ({what}, {})\n", r.path, bytes(r.file_bytes)));
                if let Some(v) = &r.vdb {
                    for g in &v.grids {
                        let class = g.class.as_deref().unwrap_or("unknown class");
                        let active = g
                            .active_voxels
                            .map(|n| format!(", {n} active"))
                            .unwrap_or_default();
                        let half = if g.half_float { ", half" } else { "" };
                        line(
                            &mut out,
                            "grid",
                            format!("{} ({}, {class}{active}{half})", g.name, g.grid_type),
                        );
                    }
                }
                if let Some(g) = &r.grid {
                    line(&mut out, "read", g.clone());
                }
                r.values.text(&mut out);
            }
            Report::Sequence(r) => {
                out.push_str(&format!(
                    "{}  ({} sequence, {})\n",
                    r.path,
                    r.format.name(),
                    progress::count(r.frames, "frame")
                ));
                let gaps = if r.gaps.is_empty() {
                    "no gaps".to_string()
                } else {
                    format!("{} missing: {}", r.missing_frames, gap_text(&r.gaps))
                };
                line(
                    &mut out,
                    "frames",
                    format!(
                        "{}..{}, {}, {gaps}",
                        r.first_frame,
                        r.last_frame,
                        progress::count(r.frames, "frame")
                    ),
                );
                let d = r.dims;
                line(&mut out, "dims", format!("{} × {} × {}", d[0], d[1], d[2]));
                line(
                    &mut out,
                    "world box",
                    format!("{} .. {}", vec3(r.bbox_min), vec3(r.bbox_max)),
                );
                line(&mut out, "voxel size", vec3(r.voxel_size));
                line(
                    &mut out,
                    "values",
                    format!("{} .. {}", r.value_min, r.value_max),
                );
                line(
                    &mut out,
                    "active",
                    format!(
                        "{} .. {} voxels per frame",
                        r.active_voxels_min, r.active_voxels_max
                    ),
                );
                line(
                    &mut out,
                    "memory",
                    format!(
                        "{} per frame, {} in all (dense f32)",
                        bytes(r.memory_bytes_per_frame as u64),
                        bytes(r.memory_bytes_total as u64)
                    ),
                );
            }
            Report::Asset(r) => {
                out.push_str(&format!(
                    "{}  (haze asset, format {}, {}, written by {})\n",
                    r.path,
                    r.format_version,
                    bytes(r.file_bytes as u64),
                    r.header.generator
                ));
                let g = &r.header.grid;
                line(&mut out, "frames", r.header.frame_count.to_string());
                line(
                    &mut out,
                    "dims",
                    format!("{} × {} × {}", g.dims[0], g.dims[1], g.dims[2]),
                );
                line(
                    &mut out,
                    "world box",
                    format!("{} .. {}", vec3(g.bbox_min), vec3(g.bbox_max)),
                );
                let src = &r.header.source;
                line(
                    &mut out,
                    "source",
                    format!("{} (grid '{}')", src.path, src.grid),
                );
                for (kind, k) in &r.blocks_by_kind {
                    line(
                        &mut out,
                        "blocks",
                        format!("{} × {kind}, {}", k.blocks, bytes(k.bytes)),
                    );
                }
                line(&mut out, "checksums", "all blocks verified".to_string());
                for f in &r.frames {
                    if let (Some(n), Some(e), Some(m)) = (f.rbfs, f.rel_l2, f.rms_over_max) {
                        let residual = f
                            .hash_bytes
                            .map_or(String::new(), |b| format!(", residual {}", bytes(b as u64)));
                        line(
                            &mut out,
                            &format!("frame {}", f.frame),
                            format!("{n} RBFs, rel_l2 {e:.4}, rms/max {m:.4}{residual}"),
                        );
                    }
                }
            }
        }
        out
    }
}

fn line(out: &mut String, key: &str, value: String) {
    out.push_str(&format!("  {:<11} {value}\n", format!("{key}:")));
}

fn vec3(v: [f64; 3]) -> String {
    format!("({}, {}, {})", v[0], v[1], v[2])
}

fn gap_text(gaps: &[[i64; 2]]) -> String {
    gaps.iter()
        .map(|g| {
            if g[0] == g[1] {
                g[0].to_string()
            } else {
                format!("{}..{}", g[0], g[1])
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Human-readable byte count.
pub fn bytes(n: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = n as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{n} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}
