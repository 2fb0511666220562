//! Numbered frame sequences: a directory, a glob, or a single file.
//!
//! Frames are ordered by the last run of digits in their file name (Blender writes
//! `fluid_data_0001.vdb`; sequences may start anywhere, e.g. at 1001, and may have gaps,
//! which are reported). Every frame must share the first frame's grid (dims and world box)
//! or loading names the first frame that differs. VDB frames are read into the union of
//! their recorded boxes, so sparse grids whose active region moves still share one grid;
//! an empty frame is a valid all-zero frame of the sequence's grid.

use super::adaptive_domain::{self, cells};
use super::vdb::{self, IndexBox};
use super::{Format, ImportOptions, format_of, read_unchecked, validate};
use crate::error::{ImportError, Problem};
use crate::volume::{Bbox, Volume};
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// One file of a sequence.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct FrameFile {
    /// The frame number from the file name (0 for a lone file without one).
    pub number: i64,
    pub path: PathBuf,
}

/// An inclusive range of frame numbers, `A..B`, `A..`, `..B` or `A`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameRange {
    pub first: Option<i64>,
    pub last: Option<i64>,
}

impl FrameRange {
    pub fn contains(&self, n: i64) -> bool {
        self.first.is_none_or(|f| n >= f) && self.last.is_none_or(|l| n <= l)
    }
}

/// `A..B`, `A..`, `..B`, `A` (one frame) or `..` (every frame): the syntax it parses from.
impl std::fmt::Display for FrameRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.first, self.last) {
            (Some(a), Some(b)) if a == b => write!(f, "{a}"),
            (a, b) => {
                if let Some(a) = a {
                    write!(f, "{a}")?;
                }
                f.write_str("..")?;
                if let Some(b) = b {
                    write!(f, "{b}")?;
                }
                Ok(())
            }
        }
    }
}

impl FromStr for FrameRange {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let num = |t: &str| -> Result<Option<i64>, String> {
            let t = t.trim();
            if t.is_empty() {
                Ok(None)
            } else {
                t.parse()
                    .map(Some)
                    .map_err(|_| format!("'{t}' is not a frame number"))
            }
        };
        let r = match s.split_once("..") {
            Some((a, b)) => FrameRange {
                first: num(a)?,
                last: num(b.strip_prefix('=').unwrap_or(b))?,
            },
            None => {
                let n = num(s)?.ok_or("empty frame range")?;
                FrameRange {
                    first: Some(n),
                    last: Some(n),
                }
            }
        };
        if let (Some(a), Some(b)) = (r.first, r.last)
            && a > b
        {
            return Err(format!("frame range {s} is empty (first {a} > last {b})"));
        }
        Ok(r)
    }
}

/// The frame number in a file name: its last run of ASCII digits ([`digit_runs`]).
pub fn frame_number(path: &Path) -> Option<i64> {
    digit_runs(path)?.last().copied()
}

/// The runs of ASCII digits in a file name's stem, left to right, leaving out a second
/// extension that names the sample type (`smoke.f32.npy`, `density.u16.raw`:
/// [`is_type_tag`]). `None`: a stem that is not UTF-8, or a run too long for an `i64`.
fn digit_runs(path: &Path) -> Option<Vec<i64>> {
    let mut stem = path.file_stem()?.to_str()?;
    if let Some((rest, tag)) = stem.rsplit_once('.')
        && is_type_tag(tag)
    {
        stem = rest;
    }
    stem.split(|c: char| !c.is_ascii_digit())
        .filter(|run| !run.is_empty())
        .map(|run| run.parse().ok())
        .collect()
}

/// Whether a second extension names a sample type rather than a frame: `f16`, `f32`, `f64`,
/// `i8` … `u64`, `float32`, `int16`, `uint8` and the like, in any case.
fn is_type_tag(token: &str) -> bool {
    let lower = token.to_ascii_lowercase();
    ["float", "uint", "int", "f", "u", "i"].iter().any(|kind| {
        lower
            .strip_prefix(kind)
            .is_some_and(|bits| ["8", "16", "32", "64"].contains(&bits))
    })
}

/// The frame numbers of a sequence's files: the last run of digits that differs between
/// their names (`s_0001_v2.npy`, `s_0002_v2.npy`: 1 and 2, not 2 and 2), where every
/// name has as many runs; otherwise, and where no run differs, each name's last run
/// ([`frame_number`]).
pub fn frame_numbers(paths: &[PathBuf]) -> Vec<Option<i64>> {
    let runs: Vec<Option<Vec<i64>>> = paths.iter().map(|p| digit_runs(p)).collect();
    let last = || runs.iter().map(|r| r.as_ref()?.last().copied()).collect();
    let Some(Some(first)) = runs.first() else {
        return last();
    };
    let k = first.len();
    if !runs
        .iter()
        .all(|r| r.as_ref().is_some_and(|r| r.len() == k))
    {
        return last();
    }
    let runs: Vec<&Vec<i64>> = runs.iter().flatten().collect();
    match (0..k)
        .rev()
        .find(|&j| runs.iter().any(|r| r[j] != first[j]))
    {
        Some(j) => runs.iter().map(|r| Some(r[j])).collect(),
        None => last(),
    }
}

fn seq_err(path: &Path, why: impl Into<String>) -> ImportError {
    ImportError::new(path, Problem::Sequence(why.into()))
}

fn is_glob(path: &Path) -> bool {
    path.to_str().is_some_and(|s| s.contains(['*', '?', '[']))
}

/// Lists the frames of a directory, glob or single file, ordered by frame number.
pub fn discover(path: &Path) -> Result<Vec<FrameFile>, ImportError> {
    // Files of a volume format haze does not read, for the error when nothing else is.
    let mut foreign: Vec<PathBuf> = Vec::new();
    let mut keep = |p: PathBuf| {
        if !p.is_file() {
            None
        } else if Format::of(&p).is_some() {
            Some(p)
        } else {
            if super::foreign_format(&p).is_some() {
                foreign.push(p);
            }
            None
        }
    };
    let files: Vec<PathBuf> = if is_glob(path) {
        let pattern = path.to_str().unwrap_or_default();
        let paths = glob::glob(pattern).map_err(|e| seq_err(path, format!("bad pattern: {e}")))?;
        paths.filter_map(Result::ok).filter_map(&mut keep).collect()
    } else if path.is_dir() {
        let rd = std::fs::read_dir(path).map_err(|e| ImportError::new(path, e.into()))?;
        let mut v = Vec::new();
        for entry in rd {
            let p = entry.map_err(|e| ImportError::new(path, e.into()))?.path();
            v.extend(keep(p));
        }
        v
    } else if path.is_file() {
        format_of(path)?;
        return Ok(vec![FrameFile {
            number: frame_number(path).unwrap_or(0),
            path: path.to_path_buf(),
        }]);
    } else {
        // Neither a file nor a folder: missing, unreadable, or something else (a device,
        // a pipe) — say which.
        let why = match std::fs::metadata(path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                "no such file or directory".to_string()
            }
            Err(e) => e.to_string(),
            Ok(_) => "not a regular file or a folder (a device, pipe or socket): give a volume file or a folder of them".to_string(),
        };
        return Err(ImportError::new(path, Problem::Format(why)));
    };
    if files.is_empty() {
        foreign.sort();
        let none = "no volume files (.vdb, .f32/.raw, .npy) found";
        let why = match foreign
            .first()
            .and_then(|f| Some((f, super::foreign_format(f)?)))
        {
            Some((f, (kind, how))) => format!(
                "{none}, but {} {} of {kind} ({}{}); haze reads OpenVDB: {how}",
                foreign.len(),
                if foreign.len() == 1 { "file" } else { "files" },
                f.file_name().unwrap_or_default().to_string_lossy(),
                if foreign.len() > 1 { ", …" } else { "" }
            ),
            None => none.to_string(),
        };
        return Err(seq_err(path, why));
    }
    let mut formats: Vec<&str> = files
        .iter()
        .filter_map(|p| Format::of(p))
        .map(Format::name)
        .collect();
    formats.sort_unstable();
    formats.dedup();
    if formats.len() > 1 {
        return Err(seq_err(
            path,
            format!(
                "holds frames of several formats ({}); select one with a glob such as '{}'",
                formats.join(", "),
                path.join(format!("*.{}", formats[0])).display()
            ),
        ));
    }
    let mut frames = Vec::with_capacity(files.len());
    for (number, p) in frame_numbers(&files).into_iter().zip(files) {
        let Some(number) = number else {
            return Err(seq_err(&p, "has no frame number in its name"));
        };
        frames.push(FrameFile { number, path: p });
    }
    frames.sort_by(|a, b| a.number.cmp(&b.number).then_with(|| a.path.cmp(&b.path)));
    for w in frames.windows(2) {
        if w[0].number == w[1].number {
            let n = w[0].number;
            let hint = match (sequence_glob(&w[0].path, n), sequence_glob(&w[1].path, n)) {
                (Some(a), Some(b)) if a != b => format!(
                    ": two sequences side by side? select one with a glob such as '{}'",
                    b.display()
                ),
                _ => String::new(),
            };
            return Err(seq_err(
                &w[1].path,
                format!(
                    "frame {} also comes from {}{hint}",
                    w[0].number,
                    w[0].path.display()
                ),
            ));
        }
    }
    Ok(frames)
}

/// The glob of the sequence a file numbered `number` belongs to: the last run of digits
/// of its name that reads `number` (where [`frame_numbers`] found it; a sample-type tag
/// such as `.f32` in `smoke_0001.f32.npy` is no frame number) as `*`, the rest escaped
/// (`None` for a name without such a run).
fn sequence_glob(path: &Path, number: i64) -> Option<PathBuf> {
    let name = path.file_name()?.to_str()?;
    let mut stem = path.file_stem()?.to_str()?;
    if let Some((rest, tag)) = stem.rsplit_once('.')
        && is_type_tag(tag)
    {
        stem = rest;
    }
    let mut runs = Vec::new();
    let mut start = None;
    for (i, c) in stem.char_indices().chain([(stem.len(), '.')]) {
        match (c.is_ascii_digit(), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                runs.push(s..i);
                start = None;
            }
            _ => {}
        }
    }
    let run = runs
        .into_iter()
        .rev()
        .find(|r| stem[r.clone()].parse::<i64>().ok() == Some(number))?;
    let pattern = format!(
        "{}*{}",
        glob::Pattern::escape(&name[..run.start]),
        glob::Pattern::escape(&name[run.end..])
    );
    Some(path.with_file_name(pattern))
}

/// Missing frame numbers between consecutive frames, as inclusive ranges.
pub fn gaps(frames: &[FrameFile]) -> Vec<(i64, i64)> {
    frames
        .windows(2)
        .filter(|w| w[1].number > w[0].number + 1)
        .map(|w| (w[0].number + 1, w[1].number - 1))
        .collect()
}

/// An opened sequence: its frames, and the grid they all share.
#[derive(Debug)]
pub struct Sequence {
    source: PathBuf,
    format: Format,
    frames: Vec<FrameFile>,
    gaps: Vec<(i64, i64)>,
    opts: ImportOptions,
    vdb_box: Option<IndexBox>,
    /// Where each frame's grid indices sit in the first frame's (grids that move).
    shifts: Vec<[i64; 3]>,
    dims: [usize; 3],
    bbox: Bbox,
}

impl Sequence {
    /// Discovers the frames of `path` within `range` and establishes their common grid
    /// (for VDB, the union of the frames' recorded boxes; the first frame is read).
    pub fn open(path: &Path, opts: &ImportOptions, range: FrameRange) -> Result<Self, ImportError> {
        let all = discover(path)?;
        let numbers = match (all.first(), all.last()) {
            (Some(a), Some(b)) => format!(" (the files hold frames {}..{})", a.number, b.number),
            _ => String::new(),
        };
        let (frames, others): (Vec<FrameFile>, Vec<FrameFile>) =
            all.into_iter().partition(|f| range.contains(f.number));
        if frames.is_empty() {
            return Err(seq_err(
                path,
                format!("no frames in the range {range}{numbers}"),
            ));
        }
        let format = format_of(&frames[0].path)?;
        let lattice = if format == Format::Vdb {
            union_box(&frames, &others, opts)?
        } else {
            Lattice {
                union: None,
                shifts: vec![[0; 3]; frames.len()],
            }
        };
        let vdb_box = lattice.union;
        let own = vdb_box.map(|b| b.shifted(lattice.shifts[0].map(|s| -s)));
        let first = read_unchecked(&frames[0].path, opts, own)?;
        // A raw or NumPy frame of another grid is refused now, from its header or sidecar,
        // not when its turn comes after the frames before it were baked.
        if format != Format::Vdb {
            for f in &frames[1..] {
                let (dims, bbox) = match format {
                    Format::Npy => super::npy::grid(&f.path)?,
                    _ => {
                        let sc = super::raw::read_sidecar(&f.path)?;
                        (sc.dims, Bbox::new(sc.world_bbox_min, sc.world_bbox_max))
                    }
                };
                if dims != first.dims() || !bbox.approx_eq(first.bbox(), SAME_BOX) {
                    return Err(other_grid(
                        f,
                        dims,
                        &bbox,
                        &frames[0],
                        first.dims(),
                        first.bbox(),
                    ));
                }
            }
        }
        Ok(Self {
            source: path.to_path_buf(),
            format,
            gaps: gaps(&frames),
            frames,
            opts: opts.clone(),
            vdb_box,
            shifts: lattice.shifts,
            dims: first.dims(),
            bbox: *first.bbox(),
        })
    }

    pub fn source(&self) -> &Path {
        &self.source
    }

    pub fn format(&self) -> Format {
        self.format
    }

    pub fn frames(&self) -> &[FrameFile] {
        &self.frames
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Missing frame numbers, as inclusive ranges.
    pub fn gaps(&self) -> &[(i64, i64)] {
        &self.gaps
    }

    /// Where each frame's grid indices sit in the first frame's: non-zero for a grid that
    /// moves with the smoke ([`lattice_shift`]).
    pub fn shifts(&self) -> &[[i64; 3]] {
        &self.shifts
    }

    /// The grid every frame shares.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    pub fn bbox(&self) -> &Bbox {
        &self.bbox
    }

    /// Loads and validates frame `i` (0-based position in the sequence).
    pub fn load(&self, i: usize) -> Result<Volume, ImportError> {
        let f = self
            .frames
            .get(i)
            .ok_or_else(|| seq_err(&self.source, format!("no frame at position {i}")))?;
        let own = self.vdb_box.map(|b| b.shifted(self.shifts[i].map(|s| -s)));
        let mut v = read_unchecked(&f.path, &self.opts, own)?;
        if v.is_empty() && self.dims.iter().all(|&n| n > 0) {
            v = Volume::zeros(self.dims, self.bbox).map_err(|e| seq_err(&f.path, e.to_string()))?;
        }
        if v.dims() != self.dims || !v.bbox().approx_eq(&self.bbox, SAME_BOX) {
            return Err(other_grid(
                f,
                v.dims(),
                v.bbox(),
                &self.frames[0],
                self.dims,
                &self.bbox,
            ));
        }
        if v.bbox() != &self.bbox {
            // The same grid to f32 precision: every frame in the first frame's box.
            v = Volume::new(self.dims, self.bbox, v.into_data())
                .map_err(|e| seq_err(&f.path, e.to_string()))?;
        }
        validate(&f.path, &mut v, self.opts.clamp_negative)?;
        Ok(v)
    }
}

/// The error of frame `f`, whose grid (`dims` over `bbox`) is not the first frame's.
fn other_grid(
    f: &FrameFile,
    dims: [usize; 3],
    bbox: &Bbox,
    first: &FrameFile,
    dims0: [usize; 3],
    bbox0: &Bbox,
) -> ImportError {
    seq_err(
        &f.path,
        format!(
            "frame {} has grid {:?} over {:?}..{:?} but frame {} ({}) has {:?} over {:?}..{:?}",
            f.number,
            dims,
            bbox.min,
            bbox.max,
            first.number,
            first.path.display(),
            dims0,
            bbox0.min,
            bbox0.max
        ),
    )
}

/// Frames whose boxes agree to this fraction of the longest side share one grid. Files
/// store their transforms in `f32`, and an Adaptive Domain's frames each derive the
/// domain's cell from their own (a cell of `side / max(res)` times `max(res) /
/// max(base_res)`), which agree to a few `f32` roundings (`≈ 10⁻⁷`).
const SAME_BOX: f64 = 1e-6;

/// Union of the frames' dense boxes in the first frame's indices, from their headers where
/// recorded, each frame's box moved by its grid's move ([`lattice_shift`]). An Adaptive
/// Domain's frames are placed in the whole domain by the cache's configuration
/// ([`super::adaptive_domain`]); frames whose domain resolution (`file_base_resolution`)
/// still differs from the first frame's are refused: an Adaptive Domain's cache without
/// its `config` folder, whose files record neither where each grid sits in the domain nor
/// the domain's cell size (each file's transform is scaled to its own grid).
///
/// The files of the sequence outside the frames asked for (`others`) join the union too,
/// so that every chunk of one sequence (`--frames A..B`, a farm's jobs) gets the same
/// grid and the chunks merge; one of them that cannot join (unreadable, another domain,
/// off the lattice) is left out, its problem for a bake that asks for it.
fn union_box(
    frames: &[FrameFile],
    others: &[FrameFile],
    opts: &ImportOptions,
) -> Result<Lattice, ImportError> {
    let mut acc: Option<IndexBox> = None;
    let mut state = UnionState::default();
    let mut shifts = Vec::with_capacity(frames.len());
    for f in frames {
        let (b, shift) = frame_box(f, opts, &mut state)?;
        shifts.push(shift);
        if let Some(b) = b {
            acc = Some(acc.map_or(b, |a| a.union(&b)));
        }
    }
    for f in others {
        if let Ok((Some(b), _)) = frame_box(f, opts, &mut state) {
            acc = Some(acc.map_or(b, |a| a.union(&b)));
        }
    }
    Ok(Lattice { union: acc, shifts })
}

/// A grid's index→world map ([`vdb::grid_transform`]).
type Transform = vdb::GridTransform;

/// What the union compares each frame with: the first frame's simulation domain and its
/// grid's placement.
#[derive(Default)]
struct UnionState<'a> {
    /// The first frame's number, its domain and whether haze wrote it (an export).
    first_domain: Option<(i64, [i64; 3], bool)>,
    first_placement: Option<(&'a FrameFile, Placement)>,
}

/// Where a frame's voxels sit: its grid's transform and each haze index's min corner in
/// voxels from the index ([`vdb::GridTransform::corner_offsets`]: `−½` for an index at
/// the voxel's centre, `0` or `−1` at a corner, by the axis's mirroring).
#[derive(Clone, Copy)]
struct Placement {
    transform: Transform,
    corner: [f64; 3],
}

/// Frame `f`'s dense box in the first frame's indices and its grid's move
/// ([`lattice_shift`]).
fn frame_box<'a>(
    f: &'a FrameFile,
    opts: &ImportOptions,
    state: &mut UnionState<'a>,
) -> Result<(Option<IndexBox>, [i64; 3]), ImportError> {
    let info = vdb::probe(&f.path)?;
    let gi = info.grid(&opts.grid).ok_or_else(|| {
        ImportError::new(
            &f.path,
            Problem::MissingGrid {
                name: opts.grid.clone(),
                available: info.grids.iter().map(|g| g.name.clone()).collect(),
            },
        )
    })?;
    if let Some(res) = gi.domain_resolution() {
        let export = gi.creator.as_deref().is_some_and(|c| c.starts_with("haze"));
        match state.first_domain {
            None => state.first_domain = Some((f.number, res, export)),
            Some((n, first, first_export)) if first != res && (export || first_export) => {
                return Err(seq_err(
                    &f.path,
                    format!(
                        "frame {}'s grid is {} cells but frame {n}'s is {}: exports of different grids (haze records an export's grid as its domain), which share no grid; bake each asset's exports apart",
                        f.number,
                        cells(res),
                        cells(first),
                    ),
                ));
            }
            Some((n, first, _)) if first != res => {
                return Err(seq_err(
                    &f.path,
                    format!(
                        "frame {}'s simulation domain is {} cells but frame {n}'s is {}: a Blender cache of an Adaptive Domain without its configuration ({}), which says where each frame's grid sits (keep the cache's config folder beside its data folder, or turn the domain's Adaptive Domain off and bake it again)",
                        f.number,
                        cells(res),
                        cells(first),
                        adaptive_domain::config_path(&f.path).map_or_else(
                            || "CACHE/config/config_NNNN.uni".to_string(),
                            |p| p.display().to_string()
                        )
                    ),
                ));
            }
            Some(_) => {}
        }
    }
    // An Adaptive Domain's block is placed by the cache's configuration instead.
    let t = match gi.placement {
        None => Some(vdb::grid_transform(&f.path, &opts.grid)?),
        Some(_) => None,
    };
    let placed = t.map(|transform| Placement {
        transform,
        corner: transform.corner_offsets(opts.vdb_index.unwrap_or(gi.index_at)),
    });
    let shift = match (placed, &state.first_placement) {
        (None, _) => [0; 3],
        (Some(p), None) => {
            state.first_placement = Some((f, p));
            [0; 3]
        }
        (Some(p), Some((first, p0))) => lattice_shift(first, p0, f, &p)?,
    };
    // The file's box in haze's indices (reversed along a mirrored axis).
    let b = match gi.default_box() {
        Some(b) => Some(t.map_or(b, |t| t.index_box(b))),
        None if gi.active_voxels == Some(0) => None,
        // No recorded box: read the grid to find where its data is.
        None => vdb::read(&f.path, opts, None)?.index_box,
    };
    Ok((b.map(|b| b.shifted(shift)), shift))
}

/// The frames' common box in the first frame's indices, and where each frame's indices
/// sit in them.
struct Lattice {
    union: Option<IndexBox>,
    /// Frame `k`'s index `j` is the first frame's index `j + shifts[k]`.
    shifts: Vec<[i64; 3]>,
}

/// Where frame `f`'s index lattice (placement `p`: voxel size `h`, translation `o`, the
/// corner offset `c` of its indices) sits in the first frame's (`p0`): haze's index `j`
/// has its min corner at `o + h·(j + c)`, so `j` is the first frame's `j + s` with
/// `s = (o − o0)/h + (c − c0)` — a whole number of voxels along each axis when the grid
/// moved with the smoke (a container that follows it), or when a frame is mirrored where
/// the first is not (its indices then run the other way, their corners a voxel over).
/// Voxels of another size, or a lattice off by a fraction of a voxel, are refused on
/// opening, naming both frames: the frames could share one grid only by resampling (and
/// a frame of other voxels would have stretched the union over indices of another grid,
/// and failed only when its turn came to be read).
fn lattice_shift(
    first: &FrameFile,
    p0: &Placement,
    f: &FrameFile,
    p: &Placement,
) -> Result<[i64; 3], ImportError> {
    let (h0, o0, h, o) = (
        p0.transform.voxel,
        p0.transform.translation,
        p.transform.voxel,
        p.transform.translation,
    );
    if (0..3).any(|a| (h[a] - h0[a]).abs() > 1e-6 * h0[a]) {
        return Err(seq_err(
            &f.path,
            format!(
                "frame {}'s voxels are {} but frame {}'s ({}) are {}: a sequence's frames share one grid, so resample them to one voxel size",
                f.number,
                sides(h),
                first.number,
                first.path.display(),
                sides(h0)
            ),
        ));
    }
    let steps: [f64; 3] =
        std::array::from_fn(|a| (o[a] - o0[a]) / h0[a] + (p.corner[a] - p0.corner[a]));
    if steps.iter().any(|s| (s - s.round()).abs() > 1e-3) {
        return Err(seq_err(
            &f.path,
            format!(
                "frame {}'s grid is moved by ({:.3}, {:.3}, {:.3}) voxels from frame {}'s ({}): not a whole number, so the frames share no grid without resampling (its transform's translation ({}, {}, {}) against ({}, {}, {}))",
                f.number,
                steps[0],
                steps[1],
                steps[2],
                first.number,
                first.path.display(),
                o[0],
                o[1],
                o[2],
                o0[0],
                o0[1],
                o0[2]
            ),
        ));
    }
    Ok(steps.map(|s| s.round() as i64))
}

/// A voxel's sides as `0.1 × 0.1 × 0.2` (world units).
fn sides(h: [f64; 3]) -> String {
    format!("{} × {} × {}", h[0], h[1], h[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sequences_glob_stars_its_frame_digits_and_escapes_the_rest() {
        let g = |p: &str, n| sequence_glob(Path::new(p), n).map(|p| p.display().to_string());
        assert_eq!(g("c/smoke_0001.vdb", 1).as_deref(), Some("c/smoke_*.vdb"));
        assert_eq!(
            g("c/v2_fire.0042.vdb", 42).as_deref(),
            Some("c/v2_fire.*.vdb")
        );
        assert_eq!(g("0007.npy", 7).as_deref(), Some("*.npy"));
        assert_eq!(g("c/a[1]_3.f32", 3).as_deref(), Some("c/a[[]1[]]_*.f32"));
        assert_eq!(g("c/smoke.vdb", 1), None);
        // The frame's run, not the last one: a version after it, a sample-type tag.
        assert_eq!(g("c/s_0001_v2.npy", 1).as_deref(), Some("c/s_*_v2.npy"));
        assert_eq!(
            g("c/smoke_0007.f32.npy", 7).as_deref(),
            Some("c/smoke_*.f32.npy")
        );
        // It selects the file's sequence and not the one beside it.
        let p = glob::Pattern::new(&g("s_0001_v2.npy", 1).unwrap()).unwrap();
        assert!(p.matches("s_0002_v2.npy") && !p.matches("s_0001_v3.npy"));
    }

    /// Messages print a range as it is written on the command line, never as a Rust value.
    /// What is neither a file nor a folder is named as such: a missing path is missing,
    /// a device (Unix's `/dev/null`) is not a volume file.
    #[test]
    fn neither_file_nor_folder_says_which() {
        let missing = discover(Path::new("no/such/smoke_0001.vdb")).unwrap_err();
        assert!(
            missing.to_string().ends_with(": no such file or directory"),
            "{missing}"
        );
        let null = Path::new("/dev/null");
        if null.exists() {
            let e = discover(null).unwrap_err().to_string();
            assert!(e.contains("not a regular file or a folder"), "{e}");
        }
    }

    #[test]
    fn ranges_print_as_they_parse() {
        for s in ["3..7", "-3..2", "99..", "..5", "12", ".."] {
            let r: FrameRange = s.parse().unwrap();
            assert_eq!(r.to_string(), s);
        }
    }

    #[test]
    fn frame_numbers_from_names() {
        assert_eq!(frame_number(Path::new("a/fluid_data_0001.vdb")), Some(1));
        assert_eq!(frame_number(Path::new("smoke.1001.vdb")), Some(1001));
        assert_eq!(
            frame_number(Path::new("fluid_data_0024_openvdb_blosc.vdb")),
            Some(24)
        );
        assert_eq!(frame_number(Path::new("v2/density.npy")), None);
        // A sample type's tag is not a frame number.
        assert_eq!(frame_number(Path::new("smoke.f32.npy")), None);
        assert_eq!(frame_number(Path::new("smoke_0007.f32.npy")), Some(7));
        assert_eq!(frame_number(Path::new("density_12.U16.raw")), Some(12));
        assert_eq!(frame_number(Path::new("grid-0003.uint8.npy")), Some(3));
        // Only as the last extension: a frame named with a letter keeps its number.
        assert_eq!(frame_number(Path::new("smoke_f32.vdb")), Some(32));
        assert_eq!(frame_number(Path::new("smoke.0032.vdb")), Some(32));
        assert_eq!(frame_number(Path::new("smoke.f320.npy")), Some(320));
    }

    /// In a sequence the frame number is the last run of digits that differs between
    /// the names; a run that is the same in every name (a version, a level) is not it.
    #[test]
    fn a_sequence_numbers_its_frames_by_the_digits_that_differ() {
        let paths = |names: &[&str]| -> Vec<PathBuf> { names.iter().map(PathBuf::from).collect() };
        assert_eq!(
            frame_numbers(&paths(&["s_0001_v2.npy", "s_0002_v2.npy", "s_0010_v2.npy"])),
            vec![Some(1), Some(2), Some(10)]
        );
        // The last run differs: it, as before.
        assert_eq!(
            frame_numbers(&paths(&["v2/a_lod1_0007.vdb", "v2/a_lod1_0008.vdb"])),
            vec![Some(7), Some(8)]
        );
        // Two runs differ: the last of them.
        assert_eq!(
            frame_numbers(&paths(&["c3_0001_t9.npy", "c4_0002_t9.npy"])),
            vec![Some(1), Some(2)]
        );
        // Names with different counts of runs, or none differing: each name's last run.
        assert_eq!(
            frame_numbers(&paths(&["a_0001.npy", "a_v2_0002.npy"])),
            vec![Some(1), Some(2)]
        );
        assert_eq!(
            frame_numbers(&paths(&["a_1_2.npy", "b_3.npy"])),
            vec![Some(2), Some(3)]
        );
        assert_eq!(
            frame_numbers(&paths(&["a_v2.npy", "b_v2.npy"])),
            vec![Some(2), Some(2)]
        );
        assert_eq!(
            frame_numbers(&paths(&["x.npy", "x_3.npy"])),
            vec![None, Some(3)]
        );
        assert_eq!(frame_numbers(&[]), Vec::<Option<i64>>::new());
        // A run too long for an i64 is no number.
        assert_eq!(
            frame_numbers(&paths(&["f_99999999999999999999.npy"])),
            vec![None]
        );
    }

    #[test]
    fn frame_ranges_parse() {
        let r: FrameRange = "3..7".parse().unwrap();
        assert!(r.contains(3) && r.contains(7) && !r.contains(8) && !r.contains(2));
        let r: FrameRange = "1001..".parse().unwrap();
        assert!(r.contains(5000) && !r.contains(1000));
        let r: FrameRange = "..=4".parse().unwrap();
        assert!(r.contains(-3) && !r.contains(5));
        let r: FrameRange = "12".parse().unwrap();
        assert!(r.contains(12) && !r.contains(13));
        assert!("7..3".parse::<FrameRange>().is_err());
        assert!("a..3".parse::<FrameRange>().is_err());
    }

    #[test]
    fn gaps_are_inclusive_ranges() {
        let f = |n| FrameFile {
            number: n,
            path: PathBuf::new(),
        };
        assert_eq!(gaps(&[f(1), f(2), f(5), f(6), f(8)]), vec![(3, 4), (7, 7)]);
        assert!(gaps(&[f(1001), f(1002)]).is_empty());
    }
}
