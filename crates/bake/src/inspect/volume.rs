//! A volume file's report (its grid and values, and for OpenVDB the file's grids), and a
//! sequence's (frames, gaps, ranges over the frames).

use super::Progress;
use super::text::{bytes, line, vec3};
use anyhow::Result;
use haze_volume::import::{self, FrameRange, Sequence, vdb};
use haze_volume::{ImportOptions, Volume, VolumeStats};
use serde::Serialize;
use std::path::Path;

/// The grid and values of one volume.
#[derive(Debug, Serialize)]
pub struct GridReport {
    pub dims: [usize; 3],
    pub voxels: usize,
    pub bbox_min: [f64; 3],
    pub bbox_max: [f64; 3],
    pub voxel_size: [f64; 3],
    pub value_min: f32,
    pub value_max: f32,
    pub value_sum: f64,
    pub active_voxels: usize,
    pub active_index_bbox: Option<[[usize; 3]; 2]>,
    pub memory_bytes: usize,
}

impl GridReport {
    /// The grid and values of `v`.
    pub fn of(v: &Volume) -> Self {
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

    /// The grid's lines of a report.
    pub(super) fn text(&self, out: &mut String) {
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
        if self.voxels == 0 {
            // An empty grid (a simulation's first frames, an array with an axis of length
            // 0) has no voxel size and no values; its box is a placeholder.
            line(out, "voxel size", "none (no voxels)".to_string());
            line(out, "values", "none (an empty frame)".to_string());
        } else {
            line(out, "voxel size", vec3(self.voxel_size));
            line(
                out,
                "values",
                format!(
                    "{} .. {} (sum {:.6})",
                    self.value_min, self.value_max, self.value_sum
                ),
            );
        }
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

#[derive(Debug, Serialize)]
pub struct FileReport {
    pub path: String,
    pub format: import::Format,
    pub file_bytes: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vdb: Option<vdb::VdbFileInfo>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid: Option<String>,
    /// Where the read grid's transform put a voxel's index (`--vdb-index`, else the
    /// file's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub index_at: Option<import::IndexAt>,
    /// The axes along which the read grid's transform mirrors it (a negative scale; read
    /// reversed there, each voxel where the transform puts it).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub mirrored: Vec<&'static str>,
    /// A raw or NumPy file's sample type (`float32`, `uint8`, …).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<&'static str>,
    /// How those samples become densities, in words.
    #[serde(skip)]
    pub reading: Option<&'static str>,
    #[serde(flatten)]
    pub values: GridReport,
}

pub(super) fn file_report(path: &Path, opts: &ImportOptions) -> Result<FileReport> {
    let format = import::format_of(path)?;
    let vdb_info = match format {
        import::Format::Vdb => Some(vdb::probe(path)?),
        _ => None,
    };
    let v = import::import(path, opts)?;
    let mirrored = match &vdb_info {
        Some(_) => {
            let t = vdb::grid_transform(path, &opts.grid)?;
            ["x", "y", "z"]
                .into_iter()
                .zip(t.mirrored)
                .filter_map(|(axis, m)| m.then_some(axis))
                .collect()
        }
        None => Vec::new(),
    };
    let samples = import::samples_of(path)?;
    Ok(FileReport {
        path: path.display().to_string(),
        format,
        file_bytes: std::fs::metadata(path)?.len(),
        grid: vdb_info.as_ref().map(|_| opts.grid.clone()),
        index_at: vdb_info
            .as_ref()
            .and_then(|i| i.grid(&opts.grid))
            .map(|g| opts.vdb_index.unwrap_or(g.index_at)),
        mirrored,
        samples: samples.map(|t| t.name()),
        reading: samples.map(|t| t.reading()),
        vdb: vdb_info,
        values: GridReport::of(&v),
    })
}

#[derive(Debug, Serialize)]
pub struct FrameSummary {
    pub frame: i64,
    pub path: String,
    pub value_min: f32,
    pub value_max: f32,
    pub active_voxels: usize,
}

#[derive(Debug, Serialize)]
pub struct SequenceReport {
    pub path: String,
    pub format: import::Format,
    pub frames: usize,
    pub first_frame: i64,
    pub last_frame: i64,
    /// Missing frame numbers as inclusive [first, last] ranges.
    pub gaps: Vec<[i64; 2]>,
    pub missing_frames: i64,
    pub dims: [usize; 3],
    pub bbox_min: [f64; 3],
    pub bbox_max: [f64; 3],
    pub voxel_size: [f64; 3],
    pub value_min: f32,
    pub value_max: f32,
    pub active_voxels_min: usize,
    pub active_voxels_max: usize,
    pub memory_bytes_per_frame: usize,
    pub memory_bytes_total: usize,
    /// For OpenVDB frames whose grid moves with the smoke (each placed by its own
    /// transform): the largest move from the first frame's grid along each axis, voxels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid_moves: Option<[i64; 3]>,
    pub per_frame: Vec<FrameSummary>,
}

pub(super) fn sequence_report(
    path: &Path,
    range: FrameRange,
    opts: &ImportOptions,
    progress: Progress<'_>,
) -> Result<SequenceReport> {
    let seq = Sequence::open(path, opts, range)?;
    let mut per_frame = Vec::with_capacity(seq.len());
    let mut voxel_size = [0.0; 3];
    for (i, f) in seq.frames().iter().enumerate() {
        progress("reading", i, seq.len());
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
    progress("reading", seq.len(), seq.len());
    let gaps: Vec<[i64; 2]> = seq.gaps().iter().map(|&(a, b)| [a, b]).collect();
    if !gaps.is_empty() {
        tracing::warn!(
            "{}: missing frames {}",
            path.display(),
            super::text::gap_text(&gaps)
        );
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
        grid_moves: seq.shifts().iter().any(|s| *s != [0; 3]).then(|| {
            std::array::from_fn(|a| seq.shifts().iter().map(|s| s[a].abs()).max().unwrap_or(0))
        }),
        per_frame,
    })
}
