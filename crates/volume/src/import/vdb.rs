//! OpenVDB import through vdb-rs: one scalar float grid of a file, sparse tree → dense box.
//!
//! * **Which grid**: by name (`density` by default). Only scalar float grids
//!   (`Tree_float_5_4_3` or `Tree_double_5_4_3`, saved in full or half precision, 64-bit
//!   values rounded to `f32`) of class fog volume (or unknown class) are read; anything else is
//!   refused with the reason.
//! * **Which box**: the domain when the writer records one (`file_base_resolution`, as
//!   Blender's Mantaflow cache does: index box `[0, res)`; for a frame of an Adaptive
//!   Domain the whole domain, its block placed by the cache's configuration:
//!   [`super::adaptive_domain`]), joined with the file's
//!   `file_bbox_min/max` metadata; otherwise `file_bbox_min/max` alone; otherwise the
//!   bounding box of the stored voxels. A caller can impose a box (sequences use the union
//!   of their frames' boxes so that every frame has the same grid).
//! * **Which values**: every value the tree stores inside the box — leaf voxels, active or
//!   not, tile values of internal nodes and of the root (constant regions of 8³, 128³ and
//!   4096³ voxels) — over a background of 0 (fog volumes); a grid whose background is not
//!   0 (density everywhere outside its voxels) is refused.
//! * **Which transforms**: a scale (uniform or not), a translation, both, or an affine
//!   map that is one of those; a rotation, shear or perspective is refused naming it.
//! * **Where in the world**: index `i` maps through the grid's transform `T` to the
//!   voxel's *centre* (OpenVDB's own convention: Houdini, EmberGen, haze's exports) or, in
//!   Blender's fluid caches, to its *min corner* (Mantaflow's cell `i` of a domain whose
//!   local origin is its min corner), plus the caller's domain offset: with `c = −½` for a
//!   centre and `0` for a corner, `bbox.min = offset + T(i_min + c)`, `bbox.max = offset +
//!   T(i_max + 1 + c)`. Which one a grid uses: [`VdbGridInfo::index_at`]; a caller may
//!   impose either ([`ImportOptions::vdb_index`]).
//!
//! vdb-rs panics on some malformed or unsupported inputs (unknown transform maps, old file
//! versions, inconsistent node data); those panics are caught and reported as errors.

use super::adaptive_domain::{self, Placement};
use super::guard::catch_panic;
use super::{ImportOptions, IndexAt};
use crate::error::{ImportError, Problem};
use crate::volume::{Bbox, Volume, voxel_count};
use serde::Serialize;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;
use vdb_rs::{Grid, Map, MetadataValue, VdbReader};

/// OpenVDB's file magic, an int64 `0x56444220` ("VDB ") stored little-endian.
const MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
/// Oldest file version read: OpenVDB 3.0's (node mask compression, 2014).
const MIN_VERSION: u32 = 222;
/// The grid metadata in which a file says where its transform puts a voxel's index
/// (`centre` or `corner`, [`IndexAt`]): haze's exports write it.
pub const INDEX_KEY: &str = "haze_voxel_index";
/// Largest dense box allocated: 2³¹ voxels (8 GiB of f32).
pub const MAX_VOXELS: u64 = 1 << 31;

/// Inclusive box of voxel indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct IndexBox {
    pub min: [i64; 3],
    pub max: [i64; 3],
}

impl IndexBox {
    /// Smallest box holding both.
    pub fn union(&self, o: &IndexBox) -> IndexBox {
        IndexBox {
            min: [0, 1, 2].map(|a| self.min[a].min(o.min[a])),
            max: [0, 1, 2].map(|a| self.max[a].max(o.max[a])),
        }
    }

    /// The box moved by `by` voxels.
    pub fn shifted(&self, by: [i64; 3]) -> IndexBox {
        IndexBox {
            min: [0, 1, 2].map(|a| self.min[a] + by[a]),
            max: [0, 1, 2].map(|a| self.max[a] + by[a]),
        }
    }

    /// Voxels per axis.
    pub fn dims(&self) -> [i64; 3] {
        [0, 1, 2].map(|a| self.max[a] - self.min[a] + 1)
    }

    fn from_metadata(min: [i32; 3], max: [i32; 3]) -> Option<IndexBox> {
        let b = IndexBox {
            min: min.map(i64::from),
            max: max.map(i64::from),
        };
        (0..3).all(|a| b.min[a] <= b.max[a]).then_some(b)
    }
}

/// What a VDB file says about one of its grids without reading the tree.
#[derive(Clone, Debug, Serialize)]
pub struct VdbGridInfo {
    /// The grid's name as OpenVDB shows it: grids of the same name in one file are
    /// `name[0]`, `name[1]`, … (the file stores them as `name`, U+001E, the index).
    pub name: String,
    /// The name as the file stores it.
    #[serde(skip)]
    pub stored: String,
    pub grid_type: String,
    pub class: Option<String>,
    pub active_voxels: Option<i64>,
    /// `file_bbox_min/max` when present and non-empty (in the domain's indices when the
    /// grid is placed).
    pub file_bbox: Option<IndexBox>,
    /// `file_base_resolution` (Blender's simulation domain, or an Adaptive Domain's block
    /// of it), when present.
    pub base_resolution: Option<[i64; 3]>,
    /// Where an Adaptive Domain's block sits in the whole domain, from the cache's
    /// configuration.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub placement: Option<Placement>,
    pub half_float: bool,
    pub compression: String,
    /// Where the grid's transform puts a voxel's index: the file's own word (metadata
    /// `haze_voxel_index`, `centre` or `corner`, which haze's exports write), else a
    /// corner in a grid that records `file_base_resolution` (Blender's fluid caches, and
    /// haze's exports before they wrote the word), else a centre (OpenVDB's convention).
    pub index_at: IndexAt,
    /// The grid's `creator` metadata (`haze VERSION` in haze's exports), when present.
    #[serde(skip)]
    pub creator: Option<String>,
}

impl VdbGridInfo {
    /// The simulation domain's cells: the whole domain's for a placed block.
    pub fn domain_resolution(&self) -> Option<[i64; 3]> {
        self.placement
            .as_ref()
            .map(|p| p.domain)
            .or(self.base_resolution)
    }

    /// The dense box this grid is read into when the caller imposes none.
    pub fn default_box(&self) -> Option<IndexBox> {
        let domain = self.domain_resolution().and_then(|r| {
            (r.iter().all(|&n| n > 0)).then(|| IndexBox {
                min: [0; 3],
                max: r.map(|n| n - 1),
            })
        });
        match (domain, self.file_bbox) {
            (Some(d), Some(f)) => Some(d.union(&f)),
            (d, f) => d.or(f),
        }
    }

    /// Why haze cannot read this grid as density, if it cannot.
    fn unsupported(&self) -> Option<String> {
        let t = self.grid_type.as_str();
        if ![
            "Tree_float_5_4_3",
            "Tree_float_5_4_3_HalfFloat",
            DOUBLE,
            DOUBLE_HALF,
        ]
        .contains(&t)
        {
            return Some(format!(
                "its type is {t}; haze reads scalar float grids (Tree_float_5_4_3, or Tree_double_5_4_3 rounded to 32 bits; either saved as half floats too)"
            ));
        }
        match self.class.as_deref() {
            Some("level set") => Some(
                "it is a level set; haze reads fog volumes (density, background 0)".to_string(),
            ),
            _ => None,
        }
    }
}

/// The header of a VDB file: version and grids.
#[derive(Clone, Debug, Serialize)]
pub struct VdbFileInfo {
    pub file_version: u32,
    pub library_version: String,
    /// Grids sorted by name.
    pub grids: Vec<VdbGridInfo>,
}

impl VdbFileInfo {
    pub fn grid(&self, name: &str) -> Option<&VdbGridInfo> {
        self.grids.iter().find(|g| g.name == name)
    }

    fn require(&self, path: &Path, name: &str) -> Result<&VdbGridInfo, ImportError> {
        let g = self.grid(name).ok_or_else(|| {
            ImportError::new(
                path,
                Problem::MissingGrid {
                    name: name.to_string(),
                    available: self.grids.iter().map(|g| g.name.clone()).collect(),
                },
            )
        })?;
        if let Some(why) = g.unsupported() {
            return Err(ImportError::new(
                path,
                Problem::UnsupportedGrid {
                    name: name.to_string(),
                    why,
                },
            ));
        }
        Ok(g)
    }
}

fn vdb_err(path: &Path, msg: impl Into<String>) -> ImportError {
    ImportError::new(path, Problem::Vdb(msg.into()))
}

/// Checks the magic and version bytes before vdb-rs sees the file.
fn check_preamble(path: &Path) -> Result<(), ImportError> {
    let mut head = [0u8; 12];
    let mut f = File::open(path).map_err(|e| ImportError::new(path, e.into()))?;
    let mut got = 0;
    while got < head.len() {
        match f.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) => return Err(ImportError::new(path, e.into())),
        }
    }
    if got < head.len() {
        return Err(vdb_err(path, format!("file is only {got} bytes long")));
    }
    if head[..8] != MAGIC {
        return Err(vdb_err(path, "missing the OpenVDB magic number"));
    }
    let version = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
    if version < MIN_VERSION {
        return Err(vdb_err(
            path,
            format!(
                "file version {version} predates OpenVDB 3 (version {MIN_VERSION}); re-save it with a current OpenVDB"
            ),
        ));
    }
    Ok(())
}

fn open_reader(path: &Path) -> Result<VdbReader<BufReader<File>>, ImportError> {
    check_preamble(path)?;
    let file = File::open(path).map_err(|e| ImportError::new(path, e.into()))?;
    let len = file
        .metadata()
        .map_err(|e| ImportError::new(path, e.into()))?
        .len();
    let reader = match catch_panic(|| VdbReader::new(BufReader::new(file))) {
        Ok(Ok(r)) => r,
        Ok(Err(e)) => return Err(vdb_err(path, describe(&e))),
        Err(panic) => return Err(vdb_err(path, panic)),
    };
    // vdb-rs seeks to each grid; a grid past the end reads as empty instead of failing.
    for gd in reader.grid_descriptors.values() {
        let furthest = gd.grid_pos.max(gd.block_pos).max(gd.end_pos);
        if furthest > len {
            return Err(vdb_err(
                path,
                format!(
                    "file ends early (truncated?): grid '{}' extends to byte {furthest} but the file has {len} bytes",
                    gd.name
                ),
            ));
        }
    }
    Ok(reader)
}

/// A vdb-rs error in words a user can act on.
fn describe(e: &vdb_rs::ParseError) -> String {
    match e {
        vdb_rs::ParseError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "file ends early (truncated?)".to_string()
        }
        other => other.to_string(),
    }
}

/// OpenVDB's display form of a stored grid name: a name made unique in the file by a
/// record separator (U+001E) and an index shows as `name[index]`.
fn shown_name(stored: &str) -> String {
    match stored.split_once('\u{1e}') {
        Some((base, index)) => format!("{base}[{index}]"),
        None => stored.to_string(),
    }
}

fn vec3i(v: Option<&MetadataValue>) -> Option<[i32; 3]> {
    match v {
        Some(MetadataValue::Vec3i(v)) => Some([v.x, v.y, v.z]),
        _ => None,
    }
}

fn info_of(reader: &VdbReader<BufReader<File>>) -> VdbFileInfo {
    let mut grids: Vec<VdbGridInfo> = reader
        .grid_descriptors
        .values()
        .map(|gd| {
            let m = &gd.meta_data.0;
            let string = |k: &str| match m.get(k) {
                Some(MetadataValue::String(s)) => Some(s.clone()),
                _ => None,
            };
            let file_bbox = match (vec3i(m.get("file_bbox_min")), vec3i(m.get("file_bbox_max"))) {
                (Some(lo), Some(hi)) => IndexBox::from_metadata(lo, hi),
                _ => None,
            };
            VdbGridInfo {
                name: shown_name(&gd.name),
                stored: gd.name.clone(),
                grid_type: gd.grid_type.clone(),
                class: string("class"),
                active_voxels: match m.get("file_voxel_count") {
                    Some(MetadataValue::I64(n)) => Some(*n),
                    _ => None,
                },
                file_bbox,
                base_resolution: vec3i(m.get("file_base_resolution")).map(|r| r.map(i64::from)),
                placement: None,
                half_float: gd.meta_data.is_half_float(),
                compression: string("file_compression")
                    .unwrap_or_else(|| format!("{:?}", gd.compression)),
                index_at: match string(INDEX_KEY).and_then(|s| s.parse().ok()) {
                    Some(at) => at,
                    None if m.contains_key("file_base_resolution") => IndexAt::Corner,
                    None => IndexAt::Centre,
                },
                creator: string("creator"),
            }
        })
        .collect();
    grids.sort_by(|a, b| a.name.cmp(&b.name));
    VdbFileInfo {
        file_version: reader.header.file_version,
        library_version: format!(
            "{}.{}",
            reader.header.library_version_major, reader.header.library_version_minor
        ),
        grids,
    }
}

/// The header of `path`, each Blender grid placed in its domain where the cache's
/// configuration says it is an Adaptive Domain's block.
fn placed_info(
    path: &Path,
    reader: &VdbReader<BufReader<File>>,
) -> Result<VdbFileInfo, ImportError> {
    let mut info = info_of(reader);
    for g in &mut info.grids {
        let Some(res) = g.base_resolution else {
            continue;
        };
        if let Some(p) = adaptive_domain::placement(path, res)? {
            g.file_bbox = g.file_bbox.map(|b| b.shifted(p.offset));
            g.placement = Some(p);
        }
    }
    Ok(info)
}

/// Reads the header and grid descriptors only (cheap: no tree data).
pub fn probe(path: &Path) -> Result<VdbFileInfo, ImportError> {
    placed_info(path, &open_reader(path)?)
}

/// What haze says of a transform it cannot read: axis-aligned grids only.
const AXIS_ALIGNED: &str = "haze reads axis-aligned grids (a scale and a translation): resample it onto an axis-aligned grid first";

/// A grid's index→world map as haze reads it: `world = translation + voxel · j`, with
/// `j` the file's index `i` along an axis whose scale is positive and `−i` along a
/// mirrored one (a negative scale, as OpenVDB writes for a grid flipped in Houdini): the
/// same points, so a mirrored grid is read over positive voxel sizes with its indices
/// (its boxes, its tree's voxels) reversed along that axis ([`GridTransform::index_box`],
/// [`GridTransform::index`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridTransform {
    /// World size of a voxel (positive).
    pub voxel: [f64; 3],
    pub translation: [f64; 3],
    /// The axes along which the file's scale is negative.
    pub mirrored: [bool; 3],
}

impl GridTransform {
    /// The corner of the cube of `side` voxels at file index `o` (its lowest index on each
    /// axis) in haze's indices.
    pub fn index(&self, o: [i64; 3], side: i64) -> [i64; 3] {
        std::array::from_fn(|a| {
            if self.mirrored[a] {
                -(o[a] + side - 1)
            } else {
                o[a]
            }
        })
    }

    /// A box of the file's indices in haze's.
    pub fn index_box(&self, b: IndexBox) -> IndexBox {
        let max = self.index(b.max, 1);
        let min = self.index(b.min, 1);
        IndexBox {
            min: std::array::from_fn(|a| min[a].min(max[a])),
            max: std::array::from_fn(|a| min[a].max(max[a])),
        }
    }

    /// Voxel `j`'s min corner, in voxels from haze's index `j` along each axis
    /// ([`IndexAt::corner_offset`]) for a file whose index sits at `at`: along a mirrored
    /// axis a file's corner index is at the voxel's max corner (`−1`), a centre stays
    /// `−½`.
    pub(crate) fn corner_offsets(&self, at: IndexAt) -> [f64; 3] {
        let off = at.corner_offset();
        self.mirrored.map(|m| if m { -1.0 - off } else { off })
    }
}

/// Grid `name`'s index→world map: a scale (uniform or not), a translation, both, or an
/// affine map whose linear part is diagonal (to `10⁻⁹` of its largest scale); one that
/// rotates or shears the grid is refused. Scales are the file's signed ones (OpenVDB's
/// maps also store a voxel size, which is their magnitude: a mirrored grid read by it
/// would be silently unmirrored).
fn transform_of(path: &Path, name: &str, map: &Map) -> Result<GridTransform, ImportError> {
    let (scale, translation) = match map {
        Map::UniformScaleMap {
            scale_values: v, ..
        }
        | Map::ScaleMap {
            scale_values: v, ..
        } => ([v.x, v.y, v.z], [0.0; 3]),
        Map::TranslationMap { translation: t } => ([1.0; 3], [t.x, t.y, t.z]),
        Map::ScaleTranslateMap {
            scale_values: v,
            translation: t,
            ..
        } => ([v.x, v.y, v.z], [t.x, t.y, t.z]),
        Map::AffineMap { matrix: m } => {
            let largest = [m[0], m[5], m[10]]
                .iter()
                .fold(0.0f64, |a, d| a.max(d.abs()));
            let off = [m[1], m[2], m[4], m[6], m[8], m[9]];
            let axis_aligned = off.iter().all(|x| x.abs() <= 1e-9 * largest)
                && [m[3], m[7], m[11], m[15]] == [0.0, 0.0, 0.0, 1.0];
            if !axis_aligned {
                return Err(ImportError::new(
                    path,
                    Problem::UnsupportedGrid {
                        name: name.to_string(),
                        why: format!(
                            "its transform (an AffineMap) rotates or shears the grid; {AXIS_ALIGNED}"
                        ),
                    },
                ));
            }
            ([m[0], m[5], m[10]], [m[12], m[13], m[14]])
        }
    };
    if !scale.iter().all(|s| s.is_finite() && *s != 0.0)
        || !translation.iter().all(|t| t.is_finite())
    {
        return Err(vdb_err(
            path,
            format!("invalid transform (voxel size {scale:?}, translation {translation:?})"),
        ));
    }
    Ok(GridTransform {
        voxel: scale.map(f64::abs),
        translation,
        mirrored: scale.map(|s| s < 0.0),
    })
}

/// vdb-rs's panic reading grid `name` as an error: an unknown transform named (vdb-rs
/// reads the maps [`transform_of`] takes, and panics on others), else its text.
fn panicked(path: &Path, name: &str, panic: &str) -> ImportError {
    match panic.strip_prefix("Not supported ") {
        Some(map) => ImportError::new(
            path,
            Problem::UnsupportedGrid {
                name: name.to_string(),
                why: format!(
                    "its transform is a {map}, which haze does not read (one in perspective, or of a kind OpenVDB added later); {AXIS_ALIGNED}"
                ),
            },
        ),
        None => vdb_err(path, format!("grid '{name}': {panic}")),
    }
}

/// Grid `name`'s index→world map in `path` (as [`transform_of`]), read without the
/// grid's tree.
pub fn grid_transform(path: &Path, name: &str) -> Result<GridTransform, ImportError> {
    let mut reader = open_reader(path)?;
    let info = info_of(&reader);
    let stored = info.require(path, name)?.stored.clone();
    let map = match catch_panic(|| reader.read_transform_of(&stored)) {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => return Err(vdb_err(path, format!("grid '{name}': {}", describe(&e)))),
        Err(panic) => return Err(panicked(path, name, &panic)),
    };
    transform_of(path, name, &map)
}

/// A grid read from a VDB file into a dense box.
#[derive(Debug)]
pub struct VdbFrame {
    pub volume: Volume,
    /// The index box the volume covers (`None` for an empty grid with no box).
    pub index_box: Option<IndexBox>,
    /// World size of a voxel, from the transform.
    pub voxel_size: [f64; 3],
    /// World position of index 0's voxel's min corner (transform translation + domain
    /// offset, less half a voxel where the index is at the voxel's centre).
    pub origin: [f64; 3],
}

/// Reads grid `opts.grid` of `path` into a dense volume over `index_box` (or the grid's
/// default box, see the module docs), shifted by `opts.domain_offset` in world space, its
/// index placed as `opts.vdb_index` says (else as the grid does).
pub fn read(
    path: &Path,
    opts: &ImportOptions,
    index_box: Option<IndexBox>,
) -> Result<VdbFrame, ImportError> {
    let name = opts.grid.as_str();
    let mut reader = open_reader(path)?;
    let info = placed_info(path, &reader)?;
    let gi = info.require(path, name)?.clone();
    let stored = gi.stored.as_str();
    if !reader.grid_descriptors[stored].instance_parent.is_empty() {
        return Err(ImportError::new(
            path,
            Problem::UnsupportedGrid {
                name: name.to_string(),
                why: "it is an instance of another grid; re-save the file with instancing off"
                    .to_string(),
            },
        ));
    }
    let read = catch_panic(|| {
        if gi.grid_type == DOUBLE || gi.grid_type == DOUBLE_HALF {
            reader.read_grid::<f64>(stored).map(Scalars::F64)
        } else {
            reader.read_grid::<f32>(stored).map(Scalars::F32)
        }
    });
    let grid = match read {
        Ok(Ok(g)) => g,
        Ok(Err(e)) => return Err(vdb_err(path, format!("grid '{name}': {}", describe(&e)))),
        Err(panic) => return Err(panicked(path, name, &panic)),
    };
    let background = grid.background();
    if background != 0.0 {
        return Err(ImportError::new(
            path,
            Problem::UnsupportedGrid {
                name: name.to_string(),
                why: format!(
                    "its background is {background} (the density of all space outside its voxels); haze reads fog volumes over a background of 0"
                ),
            },
        ));
    }
    let t = transform_of(path, name, grid.transform())?;
    // An Adaptive Domain's block: its file indices shifted into the domain's, whose cells
    // are smaller than the block's transform says.
    let (offset, voxel_size) = match &gi.placement {
        Some(p) => (p.offset, t.voxel.map(|v| p.cell(v))),
        None => ([0; 3], t.voxel),
    };
    let at = t.corner_offsets(opts.vdb_index.unwrap_or(gi.index_at));
    let origin =
        [0, 1, 2].map(|a| t.translation[a] + opts.domain_offset[a] + at[a] * voxel_size[a]);
    let bx = match index_box.or_else(|| gi.default_box().map(|b| t.index_box(b))) {
        Some(b) => Some(b),
        None => stored_bbox(path, &grid, &t)?.map(|b| b.shifted(offset)),
    };
    let Some(bx) = bx else {
        // An empty grid with no recorded box: a valid empty frame one voxel wide.
        let bbox = Bbox::new(origin, [0, 1, 2].map(|a| origin[a] + voxel_size[a]));
        let volume = Volume::zeros([0, 0, 0], bbox).map_err(|e| vdb_err(path, e.to_string()))?;
        return Ok(VdbFrame {
            volume,
            index_box: None,
            voxel_size,
            origin,
        });
    };
    let d = bx.dims();
    let voxels = (d[0] as u128) * (d[1] as u128) * (d[2] as u128);
    if voxels > MAX_VOXELS as u128 {
        return Err(ImportError::new(
            path,
            Problem::TooLarge {
                dims: d.map(|n| n as usize),
                voxels,
                limit: MAX_VOXELS,
            },
        ));
    }
    let dims = d.map(|n| n as usize);
    let mut data = vec![0.0f32; voxel_count(dims).unwrap_or(0)];
    let dense = Dense {
        lo: [0, 1, 2].map(|a| bx.min[a] - offset[a]),
        dims,
        data: &mut data,
    };
    fill(path, &grid, &t, dense)?;
    let bbox = Bbox::new(
        [0, 1, 2].map(|a| origin[a] + bx.min[a] as f64 * voxel_size[a]),
        [0, 1, 2].map(|a| origin[a] + (bx.max[a] + 1) as f64 * voxel_size[a]),
    );
    let volume = Volume::new(dims, bbox, data).map_err(|e| vdb_err(path, e.to_string()))?;
    Ok(VdbFrame {
        volume,
        index_box: Some(bx),
        voxel_size,
        origin,
    })
}

/// Destination box for the tree walk.
struct Dense<'a> {
    lo: [i64; 3],
    dims: [usize; 3],
    data: &'a mut [f32],
}

impl Dense<'_> {
    /// Writes `value` over the cube `[o, o + side)` clipped to the box.
    fn fill_cube(&mut self, o: [i64; 3], side: i64, value: f32) {
        if value.to_bits() == 0 {
            return; // the box starts at +0.0
        }
        let mut r = [(0usize, 0usize); 3];
        for a in 0..3 {
            let lo = (o[a] - self.lo[a]).max(0);
            let hi = (o[a] + side - self.lo[a]).min(self.dims[a] as i64);
            if lo >= hi {
                return;
            }
            r[a] = (lo as usize, hi as usize);
        }
        for z in r[2].0..r[2].1 {
            for y in r[1].0..r[1].1 {
                let row = self.dims[0] * (y + self.dims[1] * z);
                self.data[row + r[0].0..row + r[0].1].fill(value);
            }
        }
    }
}

/// Local coordinates of linear offset `idx` in a node of side `2^log2` (z fastest, as
/// OpenVDB lays out node tables).
fn local(idx: usize, log2: u32) -> [i64; 3] {
    let m = (1usize << log2) - 1;
    [idx >> (2 * log2), (idx >> log2) & m, idx & m].map(|v| v as i64)
}

fn corrupt(path: &Path, what: &str) -> ImportError {
    vdb_err(path, format!("corrupt tree: {what}"))
}

/// Visits every value `grid` stores as `(min corner, side, value)`: the root's tiles
/// (side 4096), internal-node tiles (sides 128 and 8) and all 512 values of each leaf
/// (side 1).
fn walk<V: Copy>(
    path: &Path,
    grid: &Grid<V>,
    mut visit: impl FnMut([i64; 3], i64, V),
) -> Result<(), ImportError> {
    let at = |origin: [i32; 3], l: [i64; 3], shift: u32| {
        [0, 1, 2].map(|a| i64::from(origin[a]) + (l[a] << shift))
    };
    for (origin, value, _active) in &grid.tree.root_tiles {
        visit(at([origin.x, origin.y, origin.z], [0; 3], 0), 4096, *value);
    }
    for root in &grid.tree.root_nodes {
        for idx in 0..(1usize << 15) {
            let o = at(
                [root.origin.x, root.origin.y, root.origin.z],
                local(idx, 5),
                7,
            );
            if !root.child_mask.get(idx).is_some_and(|b| *b) {
                let v = *root
                    .data
                    .get(idx)
                    .ok_or_else(|| corrupt(path, "short root node table"))?;
                visit(o, 128, v);
                continue;
            }
            let n4 = root
                .nodes
                .get(&(idx as u32))
                .ok_or_else(|| corrupt(path, "missing internal node"))?;
            for j in 0..(1usize << 12) {
                let o4 = at([n4.origin.x, n4.origin.y, n4.origin.z], local(j, 4), 3);
                if !n4.child_mask.get(j).is_some_and(|b| *b) {
                    let v = *n4
                        .data
                        .get(j)
                        .ok_or_else(|| corrupt(path, "short internal node table"))?;
                    visit(o4, 8, v);
                    continue;
                }
                let leaf = n4
                    .nodes
                    .get(&(j as u32))
                    .ok_or_else(|| corrupt(path, "missing leaf node"))?;
                if leaf.buffer.len() != 512 {
                    return Err(corrupt(path, "leaf with a wrong value count"));
                }
                for (k, &v) in leaf.buffer.iter().enumerate() {
                    visit(
                        at(
                            [leaf.origin.x, leaf.origin.y, leaf.origin.z],
                            local(k, 3),
                            0,
                        ),
                        1,
                        v,
                    );
                }
            }
        }
    }
    Ok(())
}

/// Copies every stored value of `grid` inside the box (in haze's indices, `t`).
fn fill(
    path: &Path,
    grid: &Scalars,
    t: &GridTransform,
    mut dense: Dense<'_>,
) -> Result<(), ImportError> {
    grid.walk(path, |o, side, v| {
        dense.fill_cube(t.index(o, side), side, v)
    })
}

/// OpenVDB's type name of a tree of 64-bit scalars.
const DOUBLE: &str = "Tree_double_5_4_3";

/// The same tree saved as half floats (OpenVDB's `saveFloatAsHalf`): its leaves' and
/// internal nodes' values are 16-bit in the file, its background and root tiles 64-bit.
const DOUBLE_HALF: &str = "Tree_double_5_4_3_HalfFloat";

/// A scalar grid as stored: 32-bit values (full or half precision in the file), or 64-bit
/// ones, which haze reads rounded to `f32` (the densities haze stores and renders).
enum Scalars {
    F32(Grid<f32>),
    F64(Grid<f64>),
}

impl Scalars {
    fn background(&self) -> f64 {
        match self {
            Scalars::F32(g) => f64::from(g.tree.background),
            Scalars::F64(g) => g.tree.background,
        }
    }

    fn transform(&self) -> &Map {
        match self {
            Scalars::F32(g) => &g.transform,
            Scalars::F64(g) => &g.transform,
        }
    }

    /// [`walk`] with every value as `f32`.
    fn walk(
        &self,
        path: &Path,
        mut visit: impl FnMut([i64; 3], i64, f32),
    ) -> Result<(), ImportError> {
        match self {
            Scalars::F32(g) => walk(path, g, visit),
            Scalars::F64(g) => walk(path, g, |o, side, v| visit(o, side, v as f32)),
        }
    }
}

/// Bounding box of every non-zero stored value (in haze's indices, `t`), for grids that
/// record no box.
fn stored_bbox(
    path: &Path,
    grid: &Scalars,
    t: &GridTransform,
) -> Result<Option<IndexBox>, ImportError> {
    let mut b: Option<IndexBox> = None;
    grid.walk(path, |o, side, v| {
        if v != 0.0 {
            let o = t.index(o, side);
            let nb = IndexBox {
                min: o,
                max: o.map(|c| c + side - 1),
            };
            b = Some(b.map_or(nb, |x| x.union(&nb)));
        }
    })?;
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn affine(m: [f64; 16]) -> Result<([f64; 3], [f64; 3]), ImportError> {
        transform_of(Path::new("a.vdb"), "density", &Map::AffineMap { matrix: m })
            .map(|t| (t.voxel, t.translation))
    }

    /// A negative scale is a mirrored axis: read by its magnitude, the file's indices
    /// reversed there (a cube's lowest index becomes its highest), the points unchanged.
    /// (`synthetic/mirrored.vdb`, a `ScaleTranslateMap` as OpenVDB writes it, is read end
    /// to end in `tests/real_data.rs`.)
    #[test]
    fn a_negative_scale_mirrors_the_indices_not_the_points() {
        let m = [
            -0.1, 0.0, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.3, 0.0, 1.0, 2.0, 3.0, 1.0,
        ];
        let t = transform_of(Path::new("a.vdb"), "density", &Map::AffineMap { matrix: m }).unwrap();
        assert_eq!(t.voxel, [0.1, 0.2, 0.3]);
        assert_eq!(t.translation, [1.0, 2.0, 3.0]);
        assert_eq!(t.mirrored, [true, false, false]);
        // File index i along x is at 1 − 0.1 i; haze's j = −i at 1 + 0.1 j: the same point.
        assert_eq!(t.index([7, 4, 5], 1), [-7, 4, 5]);
        // An 8³ tile at file indices 8..=15 covers haze's −15..=−8 along x.
        assert_eq!(t.index([8, 8, 8], 8), [-15, 8, 8]);
        let b = t.index_box(IndexBox {
            min: [8, 0, -2],
            max: [15, 3, 2],
        });
        assert_eq!((b.min, b.max), ([-15, 0, -2], [-8, 3, 2]));
        // Voxel j's min corner: half a voxel below a centred index, a whole one below a
        // corner index along the mirrored axis (the file's corner is its max corner).
        assert_eq!(t.corner_offsets(IndexAt::Centre), [-0.5; 3]);
        assert_eq!(t.corner_offsets(IndexAt::Corner), [-1.0, 0.0, 0.0]);
        // A zero scale is no transform.
        let mut flat = m;
        flat[0] = 0.0;
        assert!(affine(flat).is_err());
    }

    #[test]
    fn an_affine_map_reads_when_it_is_a_scale_and_a_translation() {
        // Rows: the index axes' images, then the translation (OpenVDB's row vectors).
        let m = [
            0.1, 0.0, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.3, 0.0, 1.0, 2.0, -3.0, 1.0,
        ];
        assert_eq!(affine(m).unwrap(), ([0.1, 0.2, 0.3], [1.0, 2.0, -3.0]));
        // A rotation by π/2 and back leaves rounding (≈ 10⁻¹⁷) off the diagonal: read.
        let mut near = m;
        near[1] = 6e-18;
        assert!(affine(near).is_ok());
        // A rotation of 0.3 rad about z, and a perspective column, are refused by name.
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let mut rotated = m;
        [rotated[0], rotated[1], rotated[4], rotated[5]] = [0.1 * c, 0.1 * s, -0.1 * s, 0.1 * c];
        let e = affine(rotated).unwrap_err().to_string();
        assert!(
            e.starts_with("a.vdb: grid 'density' is unsupported: its transform (an AffineMap) rotates or shears the grid"),
            "{e}"
        );
        let mut perspective = m;
        perspective[3] = 0.5;
        assert!(affine(perspective).is_err());
    }
}
