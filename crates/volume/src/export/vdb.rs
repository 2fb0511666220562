//! OpenVDB export: a dense volume as one scalar float grid (`Tree_float_5_4_3`, class fog
//! volume, background 0), in the file layout OpenVDB 12 writes (file version 224,
//! zip-compressed nodes), which OpenVDB, Blender, Houdini and haze's own reader take.
//!
//! * **Where**: index `(i, j, k)` is the volume's voxel `(i, j, k)`, placed by OpenVDB's
//!   own convention: the transform maps index `i` to the voxel's *centre*, `bbox.min +
//!   (i + ½)·voxel_size` (a `UniformScaleTranslateMap`, or a `ScaleTranslateMap` when the
//!   voxels are not cubes), and the grid says so (`haze_voxel_index` = `centre`). The
//!   file therefore lies where the volume lay, in Blender, Houdini and every other tool
//!   that draws a voxel centred on its index, and `haze` reads it back over the same box.
//! * **What**: every non-zero sample is an active voxel holding its value (a NaN too);
//!   zeros are inactive background. Leaves (8³ voxels) holding no non-zero sample are not
//!   stored; every internal node's own values are inactive zeros.
//! * **Metadata**: `class` (`fog volume`), `name` (`density`), `creator` (`haze
//!   VERSION`), `haze_voxel_index` (`centre`: [`crate::import::vdb::INDEX_KEY`]), `file_base_resolution` (the volume's dims: the box the reader reads back,
//!   as Blender records its domain),
//!   `file_bbox_min/max` (the active voxels' index box, when there are any),
//!   `file_voxel_count`, `file_compression` (`zip + active values`),
//!   `is_saved_as_half_float` (false).
//! * **Bytes** (all little-endian): the header (magic, file version, library version 12.0,
//!   a grid-offsets flag, a 36-character UUID derived from the grid's bytes so that the same
//!   volume always gives the same file), the file's metadata (none), one grid descriptor
//!   (name, type, no instance parent, the grid's, its data blocks' and its end's offsets),
//!   then the grid: its compression flags (zip, active values only), metadata, transform, the tree's topology
//!   (root: background and children; each internal node: child mask, value mask, its values;
//!   each leaf: value mask) and the leaves' buffers (value mask, values). Node tables number
//!   a child at local `(x, y, z)` as `x·n² + y·n + z` (z fastest); each value block is an
//!   "active values only" flag byte (every inactive value is the background) and the
//!   node's active values, zlib-compressed behind their byte count (negated and stored raw
//!   when zlib would not shrink them): a leaf's non-zero samples, an internal node's none.

use crate::import::IndexAt;
use crate::volume::Volume;
use flate2::Compression;
use flate2::write::ZlibEncoder;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::io::Write;

/// OpenVDB's file magic: the int64 `0x56444220` ("VDB ").
const MAGIC: i64 = 0x5644_4220;
/// The file version written: OpenVDB 6 to 12 write 224.
pub const FILE_VERSION: u32 = 224;
/// The OpenVDB release whose files these are byte for byte (readers key quirks on it).
const LIBRARY_VERSION: [u32; 2] = [12, 0];
/// Per-grid compression flags: zip (`COMPRESS_ZIP`, 1) and active values only
/// (`COMPRESS_ACTIVE_MASK`, 2).
const COMPRESSION: u32 = 1 | 2;
/// A value block's flag byte: the active values alone, every inactive one the background
/// (`NO_MASK_OR_INACTIVE_VALS`).
const ACTIVE_ONLY: u8 = 0;
/// The grid type of a float grid of 5-4-3 trees.
pub const GRID_TYPE: &str = "Tree_float_5_4_3";

/// log₂ of a leaf's side in voxels (8).
const LEAF: u32 = 3;
/// log₂ of a lower internal node's side in children (16 leaves: 128 voxels).
const LOWER: u32 = 4;
/// log₂ of an upper internal node's side in children (32 lower nodes: 4096 voxels).
const UPPER: u32 = 5;

/// Why a volume cannot be written.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ExportError {
    #[error("an empty volume (dims {0:?}) has no voxels to write")]
    Empty([usize; 3]),
    #[error("dims {0:?} do not fit OpenVDB's 32-bit voxel coordinates")]
    TooLarge([usize; 3]),
    #[error("voxel size {0:?} is not finite and positive")]
    BadVoxel([f64; 3]),
}

/// One stored leaf: its origin, its value mask (bit `x·64 + y·8 + z`) and its 512 values
/// in the same order.
struct Leaf {
    origin: [i32; 3],
    mask: [u64; 8],
    values: Vec<f32>,
}

/// The grid's name: what Blender's and Houdini's volume shaders read by default.
pub const GRID: &str = "density";
/// The grid's `creator` metadata.
const CREATOR: &str = concat!("haze ", env!("CARGO_PKG_VERSION"));

/// The file bytes of `volume` as the grid [`GRID`] (module docs).
pub fn to_bytes(volume: &Volume) -> Result<Vec<u8>, ExportError> {
    let dims = volume.dims();
    if dims.contains(&0) {
        return Err(ExportError::Empty(dims));
    }
    if dims.iter().any(|&n| n > i32::MAX as usize - 8) {
        return Err(ExportError::TooLarge(dims));
    }
    let voxel = volume.voxel_size();
    if !voxel.iter().all(|v| v.is_finite() && *v > 0.0) {
        return Err(ExportError::BadVoxel(voxel));
    }
    let leaves = leaves_of(volume);
    let (grid, blocks) = grid_bytes(volume, &leaves);

    let mut out = Vec::with_capacity(grid.len() + 256);
    out.extend_from_slice(&MAGIC.to_le_bytes());
    put_u32(&mut out, FILE_VERSION);
    put_u32(&mut out, LIBRARY_VERSION[0]);
    put_u32(&mut out, LIBRARY_VERSION[1]);
    out.push(1); // the grid descriptors carry their offsets
    out.extend_from_slice(uuid_of(&grid).as_bytes());
    put_u32(&mut out, 0); // no file metadata
    put_u32(&mut out, 1); // one grid
    put_string(&mut out, GRID);
    put_string(&mut out, GRID_TYPE);
    put_string(&mut out, ""); // not an instance of another grid
    // The grid's offset, its data blocks' (the leaves' buffers) and its end, in the file.
    let grid_pos = (out.len() + 24) as i64;
    out.extend_from_slice(&grid_pos.to_le_bytes());
    out.extend_from_slice(&(grid_pos + blocks as i64).to_le_bytes());
    out.extend_from_slice(&(grid_pos + grid.len() as i64).to_le_bytes());
    out.extend_from_slice(&grid);
    Ok(out)
}

/// The non-empty leaves of `volume`, in no particular order.
fn leaves_of(volume: &Volume) -> Vec<Leaf> {
    let d = volume.dims();
    let side = 1usize << LEAF;
    let counts = d.map(|n| n.div_ceil(side));
    (0..counts[0] * counts[1] * counts[2])
        .into_par_iter()
        .filter_map(|l| {
            let o = [
                (l % counts[0]) * side,
                (l / counts[0] % counts[1]) * side,
                (l / counts[0] / counts[1]) * side,
            ];
            let mut values = vec![0.0f32; 1 << (3 * LEAF)];
            let mut mask = [0u64; 8];
            for x in 0..side.min(d[0] - o[0]) {
                for y in 0..side.min(d[1] - o[1]) {
                    for z in 0..side.min(d[2] - o[2]) {
                        let v = volume.get(o[0] + x, o[1] + y, o[2] + z);
                        if v != 0.0 || v.is_nan() {
                            let n = (x << (2 * LEAF)) | (y << LEAF) | z;
                            values[n] = v;
                            mask[n >> 6] |= 1 << (n & 63);
                        }
                    }
                }
            }
            mask.iter().any(|&w| w != 0).then(|| Leaf {
                origin: o.map(|c| c as i32),
                mask,
                values,
            })
        })
        .collect()
}

/// Index of a child at `origin` in a node of `log2` children a side whose children span
/// `2^child` voxels: `x·n² + y·n + z` of its local position.
fn slot(origin: [i32; 3], log2: u32, child: u32) -> usize {
    let local = origin.map(|c| ((c as usize) >> child) & ((1 << log2) - 1));
    (local[0] << (2 * log2)) | (local[1] << log2) | local[2]
}

/// The grid: compression flags, metadata, transform, topology and the leaves' buffers; and
/// where in it the buffers start.
fn grid_bytes(volume: &Volume, leaves: &[Leaf]) -> (Vec<u8>, usize) {
    // root child origin → lower slot → leaf slot → leaf
    let mut tree: BTreeMap<[i32; 3], BTreeMap<usize, BTreeMap<usize, &Leaf>>> = BTreeMap::new();
    let upper_span = LEAF + LOWER + UPPER;
    for leaf in leaves {
        let root = leaf.origin.map(|c| (c >> upper_span) << upper_span);
        tree.entry(root)
            .or_default()
            .entry(slot(leaf.origin, UPPER, LEAF + LOWER))
            .or_default()
            .insert(slot(leaf.origin, LOWER, LEAF), leaf);
    }
    let order: Vec<&Leaf> = tree
        .values()
        .flat_map(|u| u.values().flat_map(|l| l.values().copied()))
        .collect();
    let buffers: Vec<Vec<u8>> = order
        .par_iter()
        .map(|l| values_block(&active_values(l)))
        .collect();

    let mut g = Vec::new();
    put_u32(&mut g, COMPRESSION);
    put_metadata(&mut g, volume, leaves);
    put_transform(&mut g, volume);
    // Topology.
    put_u32(&mut g, 1); // one buffer per leaf
    g.extend_from_slice(&0.0f32.to_le_bytes()); // background
    put_u32(&mut g, 0); // no root tiles
    put_u32(&mut g, tree.len() as u32);
    // An internal node's values are all inactive background: none is stored.
    let no_values = values_block(&[]);
    for (origin, lowers) in &tree {
        for c in origin {
            g.extend_from_slice(&c.to_le_bytes());
        }
        put_mask(&mut g, UPPER, lowers.keys().copied());
        put_mask(&mut g, UPPER, std::iter::empty());
        g.extend_from_slice(&no_values);
        for leaves in lowers.values() {
            put_mask(&mut g, LOWER, leaves.keys().copied());
            put_mask(&mut g, LOWER, std::iter::empty());
            g.extend_from_slice(&no_values);
            for leaf in leaves.values() {
                put_words(&mut g, &leaf.mask);
            }
        }
    }
    let blocks = g.len();
    for (leaf, block) in order.iter().zip(&buffers) {
        put_words(&mut g, &leaf.mask);
        g.extend_from_slice(block);
    }
    (g, blocks)
}

/// The grid's metadata, in name order as OpenVDB stores it.
fn put_metadata(g: &mut Vec<u8>, volume: &Volume, leaves: &[Leaf]) {
    let dims = volume.dims().map(|n| n as i32);
    let (mut lo, mut hi, mut count) = ([i32::MAX; 3], [i32::MIN; 3], 0i64);
    for leaf in leaves {
        for (w, &word) in leaf.mask.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let n = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let local = [n >> (2 * LEAF), (n >> LEAF) & 7, n & 7];
                for a in 0..3 {
                    let c = leaf.origin[a] + local[a] as i32;
                    lo[a] = lo[a].min(c);
                    hi[a] = hi[a].max(c);
                }
                count += 1;
            }
        }
    }
    let vec3i = |v: [i32; 3]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
    let mut items: Vec<(&str, &str, Vec<u8>)> = vec![
        ("class", "string", b"fog volume".to_vec()),
        ("creator", "string", CREATOR.as_bytes().to_vec()),
        ("file_base_resolution", "vec3i", vec3i(dims)),
        (
            "file_compression",
            "string",
            b"zip + active values".to_vec(),
        ),
        ("file_voxel_count", "int64", count.to_le_bytes().to_vec()),
        (
            crate::import::vdb::INDEX_KEY,
            "string",
            IndexAt::Centre.name().as_bytes().to_vec(),
        ),
        ("is_saved_as_half_float", "bool", vec![0]),
        ("name", "string", GRID.as_bytes().to_vec()),
    ];
    if count > 0 {
        items.push(("file_bbox_max", "vec3i", vec3i(hi)));
        items.push(("file_bbox_min", "vec3i", vec3i(lo)));
    }
    items.sort_by(|a, b| a.0.cmp(b.0));
    put_u32(g, items.len() as u32);
    for (key, kind, value) in items {
        put_string(g, key);
        put_string(g, kind);
        put_u32(g, value.len() as u32);
        g.extend_from_slice(&value);
    }
}

/// Index `i` → world `bbox.min + (i + ½)·voxel_size`: a scale-and-translate map with its
/// derived terms (scale, voxel size, inverse scale, its square and half).
fn put_transform(g: &mut Vec<u8>, volume: &Volume) {
    let s = volume.voxel_size();
    let uniform = s[0] == s[1] && s[1] == s[2];
    put_string(
        g,
        if uniform {
            "UniformScaleTranslateMap"
        } else {
            "ScaleTranslateMap"
        },
    );
    let min = volume.bbox().min;
    let t: [f64; 3] = std::array::from_fn(|a| min[a] + 0.5 * s[a]);
    for v in [
        t,
        s,
        s,
        s.map(|x| 1.0 / x),
        s.map(|x| 1.0 / (x * x)),
        s.map(|x| 0.5 / x),
    ] {
        for c in v {
            g.extend_from_slice(&c.to_le_bytes());
        }
    }
}

/// A node mask of `2^(3·log2)` bits with the bits of `on` set.
fn put_mask(g: &mut Vec<u8>, log2: u32, on: impl Iterator<Item = usize>) {
    let mut words = vec![0u64; (1 << (3 * log2)) / 64];
    for n in on {
        words[n >> 6] |= 1 << (n & 63);
    }
    put_words(g, &words);
}

fn put_words(g: &mut Vec<u8>, words: &[u64]) {
    for w in words {
        g.extend_from_slice(&w.to_le_bytes());
    }
}

/// A leaf's active values, in its voxel order.
fn active_values(leaf: &Leaf) -> Vec<f32> {
    (0..leaf.values.len())
        .filter(|&n| leaf.mask[n >> 6] >> (n & 63) & 1 == 1)
        .map(|n| leaf.values[n])
        .collect()
}

/// A value block: the "active values only" flag byte, then the zlib stream of `values`
/// behind its byte count, or the raw values behind their negated byte count when zlib does
/// not shrink them (and for none: a count of 0).
fn values_block(values: &[f32]) -> Vec<u8> {
    let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let mut z = ZlibEncoder::new(Vec::new(), Compression::default());
    let zipped = z
        .write_all(&raw)
        .and_then(|_| z.finish())
        .expect("zlib into memory cannot fail");
    let mut out = vec![ACTIVE_ONLY];
    if zipped.len() < raw.len() {
        out.extend_from_slice(&(zipped.len() as i64).to_le_bytes());
        out.extend_from_slice(&zipped);
    } else {
        out.extend_from_slice(&(-(raw.len() as i64)).to_le_bytes());
        out.extend_from_slice(&raw);
    }
    out
}

fn put_u32(g: &mut Vec<u8>, v: u32) {
    g.extend_from_slice(&v.to_le_bytes());
}

/// OpenVDB's string: its byte count (u32), then its bytes.
fn put_string(g: &mut Vec<u8>, s: &str) {
    put_u32(g, s.len() as u32);
    g.extend_from_slice(s.as_bytes());
}

/// A UUID (version 8: defined by its writer) from four CRC-32s of `bytes`, so that the same
/// grid always gives the same file.
fn uuid_of(bytes: &[u8]) -> String {
    let mut h = [0u32; 4];
    for (seed, word) in h.iter_mut().enumerate() {
        let mut c =
            crc32fast::Hasher::new_with_initial(0x9e37_79b9u32.wrapping_mul(seed as u32 + 1));
        c.update(bytes);
        *word = c.finalize();
    }
    let mut b = [0u8; 16];
    for (i, w) in h.iter().enumerate() {
        b[4 * i..4 * i + 4].copy_from_slice(&w.to_be_bytes());
    }
    b[6] = (b[6] & 0x0f) | 0x80; // version 8
    b[8] = (b[8] & 0x3f) | 0x80; // RFC 9562 variant
    let hex: String = b.iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::vdb::{self as reader, IndexBox};
    use crate::volume::Bbox;

    /// A small deterministic generator (xorshift) for test volumes.
    fn noise(seed: u64) -> impl FnMut() -> u32 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 16) as u32
        }
    }

    /// Writes `v` and reads it back through the importer (vdb-rs: an independent parser).
    fn round_trip(v: &Volume) -> (reader::VdbFrame, reader::VdbFileInfo) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.vdb");
        std::fs::write(&path, to_bytes(v).unwrap()).unwrap();
        let info = reader::probe(&path).unwrap();
        let frame = reader::read(&path, &crate::ImportOptions::default(), None).unwrap();
        (frame, info)
    }

    /// The active voxels' inclusive index box and count, by brute force.
    fn active_box(v: &Volume) -> (Option<IndexBox>, i64) {
        let d = v.dims();
        let (mut lo, mut hi, mut n) = ([i64::MAX; 3], [i64::MIN; 3], 0);
        for z in 0..d[2] {
            for y in 0..d[1] {
                for x in 0..d[0] {
                    if v.get(x, y, z) != 0.0 {
                        let c = [x as i64, y as i64, z as i64];
                        for a in 0..3 {
                            lo[a] = lo[a].min(c[a]);
                            hi[a] = hi[a].max(c[a]);
                        }
                        n += 1;
                    }
                }
            }
        }
        ((n > 0).then_some(IndexBox { min: lo, max: hi }), n)
    }

    #[test]
    fn a_sparse_volume_reads_back_bit_for_bit_over_its_box() {
        // Dims no multiple of a leaf, voxels of three sizes, the box off the origin.
        let dims = [19, 13, 27];
        let bbox = Bbox::new(
            [-1.5, 2.0, 0.25],
            [-1.5 + 19.0 * 0.1, 2.0 + 13.0 * 0.3, 0.25 + 27.0 * 0.05],
        );
        let mut r = noise(7);
        let data: Vec<f32> = (0..19 * 13 * 27)
            .map(|_| {
                let u = r();
                if u.is_multiple_of(3) {
                    (u % 1000) as f32 / 997.0 + 1e-3
                } else {
                    0.0
                }
            })
            .collect();
        let v = Volume::new(dims, bbox, data).unwrap();
        let (frame, info) = round_trip(&v);
        assert_eq!(frame.volume.dims(), dims);
        assert!(
            frame.volume.bbox().approx_eq(&bbox, 1e-12),
            "{:?}",
            frame.volume.bbox()
        );
        let same = frame
            .volume
            .data()
            .iter()
            .zip(v.data())
            .all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(same);
        let g = info.grid("density").unwrap();
        let (want_box, want_count) = active_box(&v);
        assert_eq!(g.grid_type, GRID_TYPE);
        assert_eq!(g.class.as_deref(), Some("fog volume"));
        assert_eq!(g.file_bbox, want_box);
        assert_eq!(g.active_voxels, Some(want_count));
        assert_eq!(g.base_resolution, Some([19, 13, 27]));
        assert!(!g.half_float);
    }

    #[test]
    fn voxels_across_internal_nodes_and_root_children_keep_their_places() {
        // 4100 voxels along x: two upper nodes (4096 voxels each), leaves at both sides of
        // a lower node's edge (128) and at the last voxel.
        let dims = [4100, 2, 3];
        let bbox = Bbox::new([0.0; 3], [41.0, 0.02, 0.03]);
        let mut v = Volume::zeros(dims, bbox).unwrap();
        let marks = [
            (0, 0, 0),
            (127, 1, 2),
            (128, 0, 1),
            (4095, 1, 0),
            (4096, 0, 2),
            (4099, 1, 2),
        ];
        for (k, &(x, y, z)) in marks.iter().enumerate() {
            let i = v.index(x, y, z);
            v.data_mut()[i] = k as f32 + 0.5;
        }
        let (frame, info) = round_trip(&v);
        assert_eq!(frame.volume.data(), v.data());
        let g = info.grid("density").unwrap();
        assert_eq!(g.active_voxels, Some(marks.len() as i64));
        assert_eq!(
            g.file_bbox,
            Some(IndexBox {
                min: [0, 0, 0],
                max: [4099, 1, 2]
            })
        );
    }

    #[test]
    fn incompressible_leaves_are_stored_raw_and_read_back() {
        // Every voxel a random finite non-zero bit pattern: zlib cannot shrink a leaf.
        let dims = [8, 8, 16];
        let mut r = noise(11);
        let data: Vec<f32> = (0..8 * 8 * 16)
            .map(|_| {
                loop {
                    let f = f32::from_bits(r() ^ (r() << 16));
                    if f.is_finite() && f != 0.0 {
                        break f;
                    }
                }
            })
            .collect();
        let leaf = values_block(&data[..512]);
        let stored = i64::from_le_bytes(leaf[1..9].try_into().unwrap());
        assert_eq!(stored, -2048, "a raw block's count is negated");
        let v = Volume::new(dims, Bbox::new([0.0; 3], [1.0, 1.0, 2.0]), data).unwrap();
        let (frame, _) = round_trip(&v);
        assert!(
            frame
                .volume
                .data()
                .iter()
                .zip(v.data())
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
    }

    #[test]
    fn an_all_zero_volume_keeps_its_box_and_an_empty_one_is_refused() {
        let bbox = Bbox::new([1.0, 2.0, 3.0], [2.0, 4.0, 6.0]);
        let v = Volume::zeros([4, 5, 6], bbox).unwrap();
        let (frame, info) = round_trip(&v);
        assert_eq!(frame.volume.dims(), [4, 5, 6]);
        assert!(frame.volume.bbox().approx_eq(&bbox, 1e-12));
        assert!(frame.volume.data().iter().all(|&x| x == 0.0));
        assert_eq!(info.grid("density").unwrap().file_bbox, None);
        // A box too large for f64 has no finite voxel: refused, not written as inf.
        let huge = Volume::zeros([2, 2, 2], Bbox::new([-1e308; 3], [1e308; 3])).unwrap();
        assert!(matches!(to_bytes(&huge), Err(ExportError::BadVoxel(_))));
        let empty = Volume::zeros([0, 5, 6], bbox).unwrap();
        assert_eq!(to_bytes(&empty), Err(ExportError::Empty([0, 5, 6])));
    }

    #[test]
    fn the_same_volume_gives_the_same_file_and_another_a_different_uuid() {
        let bbox = Bbox::new([0.0; 3], [1.0; 3]);
        let mut v = Volume::zeros([9, 9, 9], bbox).unwrap();
        v.data_mut()[100] = 0.25;
        let a = to_bytes(&v).unwrap();
        assert_eq!(a, to_bytes(&v).unwrap());
        v.data_mut()[101] = 0.5;
        let b = to_bytes(&v).unwrap();
        // magic 8, versions 12, flag 1: the UUID's 36 characters follow.
        let uuid = |f: &[u8]| String::from_utf8(f[21..57].to_vec()).unwrap();
        assert_ne!(uuid(&a), uuid(&b));
        let u = uuid(&a);
        assert_eq!(u.len(), 36);
        assert_eq!(&u[14..15], "8", "version 8: {u}");
        assert_eq!(u.matches('-').count(), 4);
        assert_eq!(&a[..8], &[0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0]);
    }
}
