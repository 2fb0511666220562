//! The reports as text: a title line, then aligned `key: value` lines.

use super::Report;
use haze_volume::import::IndexAt;
use haze_volume::import::adaptive_domain::cells;

impl Report {
    /// The report as a title line and aligned `key: value` lines.
    pub fn text(&self) -> String {
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
                    if let Some(at) = r.index_at {
                        let what = match at {
                            IndexAt::Centre => "its voxel's centre (OpenVDB's convention)",
                            IndexAt::Corner => "its voxel's min corner (Blender's fluid caches)",
                        };
                        line(&mut out, "index at", what.to_string());
                    }
                    if !r.mirrored.is_empty() {
                        line(
                            &mut out,
                            "mirrored",
                            format!(
                                "along {} (a negative scale: read reversed there, each voxel where the transform puts it)",
                                r.mirrored.join(", ")
                            ),
                        );
                    }
                    let placed = r
                        .vdb
                        .as_ref()
                        .and_then(|v| v.grid(g))
                        .and_then(|gi| Some((gi.base_resolution?, gi.placement.as_ref()?)));
                    if let Some((block, p)) = placed {
                        line(
                            &mut out,
                            "placed",
                            format!(
                                "a block of {} cells at cell ({}, {}, {}) of an Adaptive Domain of {} (from {})",
                                cells(block),
                                p.offset[0],
                                p.offset[1],
                                p.offset[2],
                                cells(p.domain),
                                p.config.display()
                            ),
                        );
                    }
                }
                if let Some(s) = r.reading {
                    line(&mut out, "samples", s.to_string());
                }
                r.values.text(&mut out);
            }
            Report::Sequence(r) => {
                out.push_str(&format!(
                    "{}  ({} sequence, {})\n",
                    r.path,
                    r.format.name(),
                    count(r.frames, "frame")
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
                        count(r.frames, "frame")
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
                if let Some(m) = r.grid_moves {
                    line(
                        &mut out,
                        "grid moves",
                        format!(
                            "with the smoke: each frame placed by its own transform, up to ({}, {}, {}) voxels from frame {}'s",
                            m[0], m[1], m[2], r.first_frame
                        ),
                    );
                }
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
                        if k.decoded_bytes == k.bytes {
                            format!("{} × {kind}, {}", k.blocks, bytes(k.bytes))
                        } else {
                            format!(
                                "{} × {kind}, {} ({} decoded)",
                                k.blocks,
                                bytes(k.bytes),
                                bytes(k.decoded_bytes)
                            )
                        },
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

pub(super) fn line(out: &mut String, key: &str, value: String) {
    out.push_str(&format!("  {:<11} {value}\n", format!("{key}:")));
}

pub(super) fn vec3(v: [f64; 3]) -> String {
    format!("({}, {}, {})", v[0], v[1], v[2])
}

pub(super) fn gap_text(gaps: &[[i64; 2]]) -> String {
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

/// "21..28" (or "21" for one frame, "none" for no frame), from the first and last number.
pub fn span(numbers: &[i64]) -> String {
    match (numbers.first(), numbers.last()) {
        (Some(a), Some(b)) if a == b => a.to_string(),
        (Some(a), Some(b)) => format!("{a}..{b}"),
        _ => "none".into(),
    }
}

/// "; 2 frames all zero" for a summary line, empty when none was.
pub fn all_zero_clause(frames: usize) -> String {
    if frames == 0 {
        return String::new();
    }
    format!("; {} all zero", count(frames, "frame"))
}

/// The warning for an asset made from `input` whose every frame was all zero — often the
/// wrong OpenVDB grid (`grid`, "" for other input).
pub fn all_zero_warning(input: &std::path::Path, grid: &str) -> String {
    let which = if grid.is_empty() {
        String::new()
    } else {
        format!(" (OpenVDB grid '{grid}'; --grid picks another)")
    };
    format!(
        "{}: every frame is all zero{which}: the asset holds no smoke; `haze inspect {}` shows the values",
        input.display(),
        input.display()
    )
}

/// "1 frame", "2 frames".
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_clauses_and_warnings_read_as_sentences() {
        assert_eq!(span(&[21, 22, 28]), "21..28");
        assert_eq!(span(&[7]), "7");
        assert_eq!(span(&[]), "none");
        assert_eq!(all_zero_clause(0), "");
        assert_eq!(all_zero_clause(1), "; 1 frame all zero");
        assert_eq!(all_zero_clause(3), "; 3 frames all zero");
        let w = all_zero_warning(std::path::Path::new("cache/data"), "flame");
        assert_eq!(
            w,
            "cache/data: every frame is all zero (OpenVDB grid 'flame'; --grid picks another): \
             the asset holds no smoke; `haze inspect cache/data` shows the values"
        );
        assert!(!all_zero_warning(std::path::Path::new("v.npy"), "").contains("grid"));
    }
}
