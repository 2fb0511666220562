//! Merging: chunks of one sequence, baked separately (`haze bake --frames A..B`, one job
//! per chunk on a render farm), joined in frame order into one asset.
//!
//! The chunks must be compatible — same grid, same VDB grid, same settings except the RBF
//! count a `--target-error` search chose per chunk — and contiguous: each chunk starts at
//! the frame after the previous one's last, with no overlap. Blocks are copied verbatim
//! (each verified against its checksum first) with their frame scopes shifted; hash volumes
//! keep their frames, so a chunk's last partial group stays a shorter group.

use anyhow::{Result, bail};
use haze_asset::{Asset, AssetWriter, Header, Scope};
use haze_volume::Bbox;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// What a merge wrote.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The merged asset's frame numbers, in order.
    pub frames: Vec<i64>,
    /// Chunks joined.
    pub chunks: usize,
}

/// Joins `chunks` (in any order) into the asset `out`, written atomically.
pub fn merge(chunks: &[PathBuf], out: &Path) -> Result<Merged> {
    if chunks.is_empty() {
        bail!(
            "{}: no chunks to merge (give the assets `haze bake --frames A..B` wrote)",
            out.display()
        );
    }
    let mut assets = chunks
        .iter()
        .map(|p| {
            let a = Asset::open(p)?;
            a.verify_all()?;
            if a.header().source.frame_numbers.is_empty() {
                bail!("{}: the asset has no frames", p.display());
            }
            if a.header().source.frame_numbers.len() != a.frame_count() {
                bail!(
                    "{}: the header lists {} frame numbers for {} frames",
                    p.display(),
                    a.header().source.frame_numbers.len(),
                    a.frame_count()
                );
            }
            Ok(a)
        })
        .collect::<Result<Vec<_>>>()?;
    assets.sort_by_key(|a| a.header().source.frame_numbers[0]);
    for pair in assets.windows(2) {
        check_compatible(&pair[0], &pair[1])?;
        check_contiguous(&pair[0], &pair[1])?;
    }

    let mut header = assets[0].header().clone();
    let mut writer = AssetWriter::create(out)?;
    let mut offset = 0u32;
    let mut summaries = Vec::new();
    let mut chunk_notes = Vec::new();
    for a in &assets {
        for i in 0..a.entries().len() {
            let b = a.block(i)?;
            let scope = match b.id.scope {
                Scope::Frames { first, count } => Scope::Frames {
                    first: first + offset,
                    count,
                },
                Scope::Asset if offset == 0 => Scope::Asset,
                Scope::Asset => bail!(
                    "{}: block {i} is asset-wide; only per-frame blocks can be merged",
                    a.path().display()
                ),
            };
            writer.write_block(b.kind(), scope, b.bytes)?;
        }
        let h = a.header();
        let fit = h.settings.get("fit");
        if let Some(Value::Array(frames)) = fit.map(|f| &f["frames"]) {
            summaries.extend(frames.iter().cloned());
        }
        chunk_notes.push(json!({
            "path": a.path().display().to_string(),
            "frames": [h.source.frame_numbers[0], h.source.frame_numbers[h.source.frame_numbers.len() - 1]],
            "rbfs": fit.map(|f| f["settings"]["rbfs"].clone()),
            "search": fit.map(|f| f["settings"]["search"].clone()),
        }));
        offset += h.frame_count;
    }
    for a in &assets[1..] {
        header
            .source
            .frame_numbers
            .extend_from_slice(&a.header().source.frame_numbers);
    }
    header.frame_count = offset;
    if let Some(fit) = header.settings.get_mut("fit") {
        fit["frames"] = Value::Array(summaries);
    }
    header
        .settings
        .insert("merged".into(), Value::Array(chunk_notes));
    writer.finish(&header)?;
    Ok(Merged {
        frames: header.source.frame_numbers,
        chunks: assets.len(),
    })
}

/// Settings that must agree between chunks: everything but the per-frame summaries, and
/// the RBF count when each chunk searched for its own.
fn comparable(h: &Header) -> Value {
    let mut s = Value::Object(h.settings.clone());
    if let Some(fit) = s.get_mut("fit").and_then(Value::as_object_mut) {
        fit.remove("frames");
        // How many frames a chunk warmed up on is its own (its first chunk has none
        // before it).
        if let Some(settings) = fit.get_mut("settings").and_then(Value::as_object_mut) {
            settings.remove("warm_up");
        }
        if let Some(settings) = fit.get_mut("settings").and_then(Value::as_object_mut)
            && !settings.get("search").is_none_or(Value::is_null)
        {
            settings.remove("rbfs");
            settings.insert("search".into(), json!("per chunk"));
            if let Some(o) = settings.get_mut("options").and_then(Value::as_object_mut) {
                o.remove("rbfs");
            }
        }
    }
    s.as_object_mut().map(|o| o.remove("merged"));
    s
}

/// Chunks whose boxes agree to this fraction of the longest side share one grid, as the
/// frames of one sequence do (each chunk's box comes from its own first frame's transform,
/// which differs by rounding where the sequence's grid moves).
const SAME_BOX: f64 = 1e-6;

fn check_compatible(a: &Asset, b: &Asset) -> Result<()> {
    let (ha, hb) = (a.header(), b.header());
    let (pa, pb) = (a.path().display(), b.path().display());
    let (ba, bb) = (
        Bbox::new(ha.grid.bbox_min, ha.grid.bbox_max),
        Bbox::new(hb.grid.bbox_min, hb.grid.bbox_max),
    );
    if ha.grid.dims != hb.grid.dims || !ba.approx_eq(&bb, SAME_BOX) {
        bail!(
            "{pb}: grid {:?} over {:?}..{:?} differs from {pa}'s {:?} over {:?}..{:?}",
            hb.grid.dims,
            hb.grid.bbox_min,
            hb.grid.bbox_max,
            ha.grid.dims,
            ha.grid.bbox_min,
            ha.grid.bbox_max
        );
    }
    if ha.source.grid != hb.source.grid {
        bail!(
            "{pb}: baked from grid '{}', {pa} from '{}'",
            hb.source.grid,
            ha.source.grid
        );
    }
    let (sa, sb) = (comparable(ha), comparable(hb));
    if sa != sb {
        let key = differing_key(&sa, &sb, String::new());
        bail!("{pb}: baked with other settings than {pa} ({key} differs)");
    }
    Ok(())
}

/// The path of the first differing key of two JSON values, e.g. `fit.settings.quant_bits`.
fn differing_key(a: &Value, b: &Value, at: String) -> String {
    if let (Value::Object(x), Value::Object(y)) = (a, b) {
        let keys = x.keys().chain(y.keys());
        for k in keys {
            if x.get(k) != y.get(k) {
                let next = if at.is_empty() {
                    k.clone()
                } else {
                    format!("{at}.{k}")
                };
                return match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => differing_key(u, v, next),
                    _ => next,
                };
            }
        }
    }
    if at.is_empty() { "settings".into() } else { at }
}

fn check_contiguous(a: &Asset, b: &Asset) -> Result<()> {
    let (na, nb) = (
        &a.header().source.frame_numbers,
        &b.header().source.frame_numbers,
    );
    let (last, first) = (na[na.len() - 1], nb[0]);
    let (pa, pb) = (a.path().display(), b.path().display());
    if first <= last {
        bail!(
            "{pb}: frames {first}..{} overlap {pa}'s {}..{last}",
            nb[nb.len() - 1],
            na[0]
        );
    }
    if first != last + 1 {
        let missing = if first == last + 2 {
            format!("frame {} is", last + 1)
        } else {
            format!("frames {}..{} are", last + 1, first - 1)
        };
        bail!("{pb} starts at frame {first} but {pa} ends at {last}: {missing} in no chunk");
    }
    Ok(())
}
