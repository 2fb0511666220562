//! Where a frame of a Blender Adaptive Domain sits in its domain.
//!
//! An Adaptive Domain simulates only the cells around the smoke: frame `n`'s grid is the
//! block `[res_min, res_min + res)` of the whole domain's `base_res` cells, and it changes
//! from frame to frame. Its OpenVDB file holds that block alone: `file_base_resolution`
//! is the block's `res` (times the noise scale for a noise cache) and the transform's
//! voxel size is the domain's largest side over `max(res)`, so neither says where the
//! block sits nor how large a cell is. Blender writes both to the cache's configuration,
//! `CACHE/config/config_NNNN.uni` beside `CACHE/data/` and `CACHE/noise/` (gzip, little
//! endian):
//!
//! | bytes | field | |
//! |---|---|---|
//! | 4 | `active_fields` | i32 |
//! | 12 | `res` | 3 × i32: this frame's block |
//! | 8 | `dx`, `dt` | 2 × f32 |
//! | 36 | `p0`, `p1`, `dp0` | 9 × f32 |
//! | 12 | `shift` | 3 × i32: cells the domain moved (a moving domain object) |
//! | 12 | `obj_shift_f` | 3 × f32 |
//! | 64 | `obmat` | 16 × f32 |
//! | 12 | `base_res` | 3 × i32: the whole domain |
//! | 12 | `res_min` | 3 × i32: the block's first cell |
//! | 12 | `res_max` | 3 × i32 |
//!
//! With `k = file_base_resolution / res` (1 for the data cache, the noise scale for the
//! noise cache, the same on every axis), a file index `i` is the domain's index
//! `i + k·res_min`, the domain has `k·base_res` cells, and a cell's side is the file's
//! voxel size times `max(file_base_resolution) / max(k·base_res)` (to `f32` precision:
//! the file's voxel size is rounded to it). A frame so placed reads
//! exactly as the same domain baked without Adaptive Domain does (checked voxel for voxel
//! on Mantaflow's own caches).

use crate::error::{ImportError, Problem};
use flate2::read::GzDecoder;
use serde::Serialize;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Bytes of the fields read, from the start of the decompressed file.
const FIELDS: usize = 4 + 12 + 8 + 36 + 12 + 12 + 64 + 12 + 12 + 12;
/// A configuration far larger than Blender's (about 200 bytes) is not one.
const MAX_BYTES: u64 = 1 << 16;

/// The fields of a frame's configuration that place its grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameConfig {
    pub res: [i64; 3],
    pub shift: [i64; 3],
    pub base_res: [i64; 3],
    pub res_min: [i64; 3],
}

/// How a frame's file indices and voxel size map into its whole domain.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Placement {
    /// Added to a file index to give the domain's index.
    pub offset: [i64; 3],
    /// The whole domain's cells (at the file's resolution: noise caches are finer).
    pub domain: [i64; 3],
    /// The block's cells (`file_base_resolution`).
    pub block: [i64; 3],
    /// The configuration it was read from.
    pub config: PathBuf,
}

/// `CACHE/config/config_NNNN.uni` for a cache file `CACHE/<folder>/<name>_NNNN.vdb`, `NNNN`
/// the file name's last digits; `None` when the name ends in no number.
pub fn config_path(vdb: &Path) -> Option<PathBuf> {
    let stem = vdb.file_stem()?.to_str()?;
    let digits = stem.len() - stem.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    if digits == 0 {
        return None;
    }
    let cache = vdb.parent()?.parent()?;
    Some(
        cache
            .join("config")
            .join(format!("config_{}.uni", &stem[stem.len() - digits..])),
    )
}

fn bad(path: &Path, why: impl Into<String>) -> ImportError {
    ImportError::new(
        path,
        Problem::Format(format!(
            "a Blender fluid cache configuration {}",
            why.into()
        )),
    )
}

/// Reads the placing fields of a configuration file.
pub fn read_config(path: &Path) -> Result<FrameConfig, ImportError> {
    let file = std::fs::File::open(path).map_err(|e| ImportError::new(path, Problem::Io(e)))?;
    let mut bytes = Vec::new();
    GzDecoder::new(file)
        .take(MAX_BYTES)
        .read_to_end(&mut bytes)
        .map_err(|e| bad(path, format!("that does not decompress: {e}")))?;
    if bytes.len() < FIELDS {
        return Err(bad(
            path,
            format!("of {} bytes (at least {FIELDS} expected)", bytes.len()),
        ));
    }
    let ints = |at: usize| -> [i64; 3] {
        [0, 1, 2].map(|a| {
            let o = at + 4 * a;
            i64::from(i32::from_le_bytes([
                bytes[o],
                bytes[o + 1],
                bytes[o + 2],
                bytes[o + 3],
            ]))
        })
    };
    let c = FrameConfig {
        res: ints(4),
        shift: ints(60),
        base_res: ints(148),
        res_min: ints(160),
    };
    let fits = (0..3).all(|a| {
        c.res[a] > 0
            && c.base_res[a] > 0
            && c.res_min[a] >= 0
            && c.res_min[a] + c.res[a] <= c.base_res[a]
    });
    if !fits {
        return Err(bad(
            path,
            format!(
                "whose grid does not fit its domain (res {:?} from cell {:?} of {:?})",
                c.res, c.res_min, c.base_res
            ),
        ));
    }
    Ok(c)
}

/// Where the grid of `vdb` (whose `file_base_resolution` is `file_res`) sits in its
/// domain: `None` unless the cache's configuration for the frame exists and says the
/// domain is adaptive (the frame's block smaller than the domain).
pub fn placement(vdb: &Path, file_res: [i64; 3]) -> Result<Option<Placement>, ImportError> {
    let Some(config) = config_path(vdb).filter(|p| p.is_file()) else {
        return Ok(None);
    };
    let c = read_config(&config)?;
    if c.res == c.base_res {
        return Ok(None);
    }
    let k = file_res[0] / c.res[0];
    if k < 1 || (0..3).any(|a| file_res[a] != k * c.res[a]) {
        return Err(ImportError::new(
            vdb,
            Problem::Format(format!(
                "its grid of {} cells is not its configuration's {} ({}) at any whole scale",
                cells(file_res),
                cells(c.res),
                config.display()
            )),
        ));
    }
    if c.shift != [0; 3] {
        return Err(ImportError::new(
            vdb,
            Problem::Format(format!(
                "an Adaptive Domain whose domain object moved {:?} cells during the simulation ({}): haze places an adaptive domain's frames in a domain that stays put",
                c.shift,
                config.display()
            )),
        ));
    }
    Ok(Some(Placement {
        offset: c.res_min.map(|n| n * k),
        domain: c.base_res.map(|n| n * k),
        block: file_res,
        config,
    }))
}

impl Placement {
    /// The domain's cell side, from the file's voxel size `v`: the domain's largest side
    /// `v·max(block)` over the domain's largest count. Blender rounds `v` to `f32`, so
    /// the cell is the domain's to about `10⁻⁷` (the same for every frame).
    pub fn cell(&self, v: f64) -> f64 {
        let most = |r: [i64; 3]| r.into_iter().max().unwrap_or(1) as f64;
        v * most(self.block) / most(self.domain)
    }
}

/// "11 × 11 × 16".
pub fn cells(r: [i64; 3]) -> String {
    format!("{} × {} × {}", r[0], r[1], r[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::Compression;
    use flate2::write::GzEncoder;
    use std::io::Write;

    /// A configuration as Blender lays it out (the fields not read are filled with
    /// markers that must not leak into the ones read).
    fn write_config(path: &Path, res: [i32; 3], shift: [i32; 3], base: [i32; 3], min: [i32; 3]) {
        let mut b: Vec<u8> = Vec::new();
        let mut put = |v: &[i32]| v.iter().for_each(|x| b.extend(x.to_le_bytes()));
        put(&[11]);
        put(&res);
        put(&[-7; 2 + 9]);
        put(&shift);
        put(&[-7; 3 + 16]);
        put(&base);
        put(&min);
        put(&[-7; 3 + 3 + 1 + 1]);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        let mut gz = GzEncoder::new(std::fs::File::create(path).unwrap(), Compression::fast());
        gz.write_all(&b).unwrap();
        gz.finish().unwrap();
    }

    #[test]
    fn the_config_of_a_cache_file_is_found_by_its_frame_number() {
        let p = config_path(Path::new("/c/data/fluid_data_0012.vdb")).unwrap();
        assert_eq!(p, Path::new("/c/config/config_0012.uni"));
        let p = config_path(Path::new("/c/noise/fluid_noise_0003.vdb")).unwrap();
        assert_eq!(p, Path::new("/c/config/config_0003.uni"));
        assert_eq!(config_path(Path::new("/c/data/density.vdb")), None);
    }

    #[test]
    fn an_adaptive_frame_is_placed_at_its_block() {
        let dir = tempfile::tempdir().unwrap();
        let vdb = dir.path().join("data").join("fluid_data_0001.vdb");
        let cfg = dir.path().join("config").join("config_0001.uni");
        write_config(&cfg, [17, 17, 14], [0; 3], [21, 21, 32], [4, 0, 0]);
        let p = placement(&vdb, [17, 17, 14]).unwrap().unwrap();
        assert_eq!(p.offset, [4, 0, 0]);
        assert_eq!(p.domain, [21, 21, 32]);
        // The file's voxel is side/17 rounded to f32, the domain's cell side/32.
        let cell = p.cell(f64::from(3.0f32 / 17.0));
        assert!((cell / (3.0 / 32.0) - 1.0).abs() < 1e-7, "{cell}");
        // A noise cache at twice the resolution.
        let noise = dir.path().join("noise").join("fluid_noise_0001.vdb");
        let p = placement(&noise, [34, 34, 28]).unwrap().unwrap();
        assert_eq!((p.offset, p.domain), ([8, 0, 0], [42, 42, 64]));
        let cell = p.cell(f64::from(3.0f32 / 34.0));
        assert!((cell / (3.0 / 64.0) - 1.0).abs() < 1e-7, "{cell}");
    }

    #[test]
    fn a_full_domain_or_no_config_is_not_moved() {
        let dir = tempfile::tempdir().unwrap();
        let vdb = dir.path().join("data").join("fluid_data_0002.vdb");
        assert_eq!(placement(&vdb, [8, 8, 8]).unwrap(), None);
        write_config(&config_path(&vdb).unwrap(), [8; 3], [0; 3], [8; 3], [0; 3]);
        assert_eq!(placement(&vdb, [8, 8, 8]).unwrap(), None);
    }

    #[test]
    fn configurations_that_cannot_place_the_grid_are_one_line_errors() {
        let dir = tempfile::tempdir().unwrap();
        let vdb = dir.path().join("data").join("fluid_data_0003.vdb");
        let cfg = config_path(&vdb).unwrap();
        let err = |file_res| placement(&vdb, file_res).unwrap_err().to_string();
        write_config(&cfg, [10, 10, 10], [0; 3], [20, 20, 20], [0; 3]);
        assert!(err([10, 10, 11]).contains("not its configuration's 10 × 10 × 10"));
        assert!(err([5, 5, 5]).contains("at any whole scale"));
        write_config(&cfg, [10, 10, 10], [0, 2, 0], [20, 20, 20], [0; 3]);
        assert!(err([10, 10, 10]).contains("moved [0, 2, 0] cells"));
        write_config(&cfg, [10, 10, 10], [0; 3], [20, 20, 20], [11, 0, 0]);
        assert!(err([10, 10, 10]).contains("does not fit its domain"));
        std::fs::write(&cfg, b"not gzip").unwrap();
        assert!(err([10, 10, 10]).contains("does not decompress"));
        let mut gz = GzEncoder::new(std::fs::File::create(&cfg).unwrap(), Compression::fast());
        gz.write_all(&[0u8; 40]).unwrap();
        gz.finish().unwrap();
        let e = err([10, 10, 10]);
        assert!(
            e.contains("config_0003.uni") && e.contains("of 40 bytes"),
            "{e}"
        );
    }
}
