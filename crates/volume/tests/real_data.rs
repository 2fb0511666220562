//! Import of the bundled Blender/Mantaflow sample against OpenVDB's own dense export.

use haze_volume::import::{self, FrameRange, IndexAt, Sequence, vdb};
use haze_volume::{ImportOptions, VolumeStats};
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(rel)
}

fn dense_truth() -> Vec<u32> {
    let bytes = std::fs::read(data("plume-a/dense/density_0024.f32")).unwrap();
    bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

fn bits(v: &haze_volume::Volume) -> Vec<u32> {
    v.data().iter().map(|f| f.to_bits()).collect()
}

#[test]
fn vdb_frame_24_reproduces_openvdb_dense_export_bit_for_bit() {
    let v = import::import(
        &data("plume-a/vdb/fluid_data_0024.vdb"),
        &ImportOptions::default(),
    )
    .unwrap();
    assert_eq!(v.dims(), [48, 48, 64]);
    assert_eq!(v.voxel_size(), [0.0625; 3]);
    // Domain-local transform: the box starts at the index origin.
    // Blender's cache (it records its domain, `file_base_resolution`): index i at the
    // min corner of the domain's cell i, so the box is the domain's, [0, 3]² × [0, 4].
    assert_eq!(v.bbox().min, [0.0; 3]);
    assert_eq!(v.bbox().max, [3.0, 3.0, 4.0]);
    let info = vdb::probe(&data("plume-a/vdb/fluid_data_0024.vdb")).unwrap();
    assert_eq!(info.grid("density").unwrap().index_at, IndexAt::Corner);
    assert!(
        bits(&v) == dense_truth(),
        "density differs from the dense export"
    );
    let s = VolumeStats::of(&v);
    assert_eq!(s.nonzero, 11593);
    assert_eq!(s.nonzero_bbox, Some([[10, 9, 1], [38, 37, 34]]));
}

#[test]
fn domain_offset_places_blender_domain_in_world() {
    let opts = ImportOptions {
        domain_offset: [-1.5, -1.5, 0.0],
        ..ImportOptions::default()
    };
    let v = import::import(&data("plume-a/vdb/fluid_data_0024.vdb"), &opts).unwrap();
    assert_eq!(v.bbox().min, [-1.5, -1.5, 0.0]);
    assert_eq!(v.bbox().max, [1.5, 1.5, 4.0]);
    assert_eq!(v.voxel_center(0, 0, 0), [-1.46875, -1.46875, 0.03125]);
}

#[test]
fn raw_sidecar_import_matches_the_file() {
    let v = import::import(
        &data("plume-a/dense/density_0024.f32"),
        &ImportOptions::default(),
    )
    .unwrap();
    assert_eq!(v.dims(), [48, 48, 64]);
    assert_eq!(v.bbox().min, [-1.5, -1.5, 0.0]);
    assert!(bits(&v) == dense_truth());
}

#[test]
fn blosc_resave_by_openvdb_equals_the_dense_export() {
    let v = import::import(
        &data("plume-a/blosc/fluid_data_0024_openvdb_blosc.vdb"),
        &ImportOptions::default(),
    )
    .unwrap();
    assert!(bits(&v) == dense_truth());
}

#[test]
fn blender_blosc_frame_1_equals_zip_frame_1_statistics() {
    // Same emitter, first frame: the density equals plume-a frame 1 (1472 active voxels).
    let v = import::import(
        &data("plume-a/blosc/fluid_data_0001_blender_blosc.vdb"),
        &ImportOptions::default(),
    )
    .unwrap();
    let s = VolumeStats::of(&v);
    assert_eq!(v.dims(), [48, 48, 64]);
    assert_eq!(s.nonzero, 1472);
    assert_eq!(s.nonzero_bbox, Some([[17, 17, 1], [30, 30, 14]]));
    assert_eq!(s.max, 1.0);
}

#[test]
fn probe_lists_grids_and_refuses_non_scalar_ones() {
    let p = data("plume-a/vdb/fluid_data_0024.vdb");
    let info = vdb::probe(&p).unwrap();
    let names: Vec<_> = info.grids.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(
        names,
        ["density", "flame", "shadow", "temperature", "velocity"]
    );
    let opts = ImportOptions {
        grid: "velocity".into(),
        ..ImportOptions::default()
    };
    let e = import::import(&p, &opts).unwrap_err().to_string();
    assert!(e.contains("Tree_vec3s_5_4_3"), "{e}");
    let opts = ImportOptions {
        grid: "smoke".into(),
        ..ImportOptions::default()
    };
    let e = import::import(&p, &opts).unwrap_err().to_string();
    assert!(
        e.contains("no grid named 'smoke'")
            && e.contains("density, flame")
            && e.ends_with("; --grid chooses one)"),
        "{e}"
    );
}

#[test]
fn empty_grid_is_a_valid_zero_frame() {
    let opts = ImportOptions {
        grid: "flame".into(),
        ..ImportOptions::default()
    };
    let v = import::import(&data("plume-a/vdb/fluid_data_0024.vdb"), &opts).unwrap();
    assert_eq!(v.dims(), [48, 48, 64]);
    assert!(v.data().iter().all(|&d| d == 0.0));
}

#[test]
fn negative_grid_needs_clamping() {
    // Blender's viewport `shadow` grid is a dense −1.
    let p = data("plume-a/vdb/fluid_data_0024.vdb");
    let mut opts = ImportOptions {
        grid: "shadow".into(),
        ..ImportOptions::default()
    };
    let e = import::import(&p, &opts).unwrap_err().to_string();
    assert!(e.contains("is -1") && e.contains("--clamp-negative"), "{e}");
    opts.clamp_negative = true;
    let v = import::import(&p, &opts).unwrap();
    assert!(v.data().iter().all(|&d| d == 0.0));
}

#[test]
fn sequence_of_bundled_frames() {
    let seq = Sequence::open(
        &data("plume-a/vdb"),
        &ImportOptions::default(),
        FrameRange::default(),
    )
    .unwrap();
    let numbers: Vec<i64> = seq.frames().iter().map(|f| f.number).collect();
    assert_eq!(numbers, (21..=28).collect::<Vec<_>>());
    assert!(seq.gaps().is_empty());
    assert_eq!(seq.dims(), [48, 48, 64]);
    let v = seq.load(3).unwrap();
    assert!(bits(&v) == dense_truth());
    let chunk = Sequence::open(
        &data("plume-a/vdb"),
        &ImportOptions::default(),
        "23..24".parse().unwrap(),
    )
    .unwrap();
    assert_eq!(chunk.len(), 2);
}

#[test]
fn truncated_vdb_is_an_error_not_a_panic() {
    let bytes = std::fs::read(data("plume-a/vdb/fluid_data_0024.vdb")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    // Cut at many places: in the header, the descriptors, the topology and the leaves.
    for cut in [
        0,
        5,
        11,
        40,
        200,
        600,
        1000,
        4000,
        20000,
        bytes.len() / 2,
        bytes.len() - 1,
    ] {
        let p = dir.path().join(format!("cut_{cut}.vdb"));
        std::fs::write(&p, &bytes[..cut]).unwrap();
        let e = match import::import(&p, &ImportOptions::default()) {
            Ok(_) => panic!("file cut at {cut} bytes imported"),
            Err(e) => e.to_string(),
        };
        assert!(e.starts_with(&p.display().to_string()), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn bit_flipped_vdb_never_panics() {
    let bytes = std::fs::read(data("plume-a/vdb/fluid_data_0021.vdb")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("flip.vdb");
    // Flip bytes across the whole file (about 1500 places, several patterns); each result
    // is either a clean import or an error, never a panic or an aborting allocation.
    let step = bytes.len() / 1499;
    for (k, pos) in (12..bytes.len()).step_by(step).enumerate() {
        let mut b = bytes.clone();
        b[pos] ^= [0x01, 0x80, 0xff, 0x5a][k % 4];
        std::fs::write(&p, &b).unwrap();
        let _ = import::import(&p, &ImportOptions::default());
    }
}

/// OpenVDB-written synthetic files (data/synthetic/make_vdb.py).
mod synthetic {
    use super::*;

    #[test]
    fn half_float_grid_with_translation_tiles_and_negative_indices() {
        let v =
            import::import(&data("synthetic/half_ball.vdb"), &ImportOptions::default()).unwrap();
        let meta: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(data("synthetic/half_ball_truth.json")).unwrap(),
        )
        .unwrap();
        let dims: Vec<usize> = serde_json::from_value(meta["dims"].clone()).unwrap();
        assert_eq!(v.dims().to_vec(), dims);
        let lo: Vec<f64> = serde_json::from_value(meta["index_min"].clone()).unwrap();
        // OpenVDB's convention (the file records no Blender domain): index i is the
        // voxel's centre, translation + 0.1·i, so the box starts half a voxel before the
        // first index; `--vdb-index corner` puts the index at the min corner instead.
        let t = [1.0, 2.0, -3.0];
        let info = vdb::probe(&data("synthetic/half_ball.vdb")).unwrap();
        assert_eq!(info.grid("density").unwrap().index_at, IndexAt::Centre);
        let corner = ImportOptions {
            vdb_index: Some(IndexAt::Corner),
            ..ImportOptions::default()
        };
        let c = import::import(&data("synthetic/half_ball.vdb"), &corner).unwrap();
        for a in 0..3 {
            assert!((v.bbox().min[a] - (t[a] + 0.1 * (lo[a] - 0.5))).abs() < 1e-12);
            assert!((c.bbox().min[a] - (t[a] + 0.1 * lo[a])).abs() < 1e-12);
            assert!((v.bbox().max[a] - c.bbox().max[a] + 0.05).abs() < 1e-12);
        }
        assert_eq!(bits(&c), bits(&v));
        let truth: Vec<u32> = std::fs::read(data("synthetic/half_ball_truth.bin"))
            .unwrap()
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        assert!(
            bits(&v) == truth,
            "half-float grid differs from numpy's f16 rounding"
        );
        // The 8³ constant tile reads as its value everywhere.
        assert_eq!(v.get(4, 2, 0), 0.625);
    }

    #[test]
    fn uncompressed_resave_equals_the_dense_export() {
        let v = import::import(
            &data("synthetic/uncompressed.vdb"),
            &ImportOptions::default(),
        )
        .unwrap();
        assert!(bits(&v) == dense_truth());
    }

    #[test]
    fn level_sets_are_refused() {
        let e = import::import(&data("synthetic/level_set.vdb"), &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("level set"), "{e}");
    }

    #[test]
    fn a_fog_over_a_background_is_refused_not_read_as_empty_space() {
        // Outside its voxels the file's density is 0.1 everywhere: a volume over a
        // background of 0 would drop that fog without a word.
        let e = import::import(
            &data("synthetic/fog_background.vdb"),
            &ImportOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("fog_background.vdb") && e.contains("its background is 0.1"),
            "{e}"
        );
    }

    #[test]
    fn a_rotated_grid_is_refused_with_what_to_do() {
        let e = import::import(&data("synthetic/rotated.vdb"), &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("rotated.vdb")
                && e.contains("AffineMap")
                && e.contains("resample it onto an axis-aligned grid"),
            "{e}"
        );
    }

    #[test]
    fn a_grid_of_unequal_voxel_sides_reads_with_them() {
        // OpenVDB stores voxels of 0.1 × 0.2 × 0.3 with no translation as a ScaleMap; the
        // 2³ block of 0.5 at indices 1..=2, each index its voxel's centre.
        let v =
            import::import(&data("synthetic/scale_map.vdb"), &ImportOptions::default()).unwrap();
        let h = [0.1, 0.2, 0.3];
        assert_eq!(v.dims(), [2, 2, 2]);
        let (size, b) = (v.voxel_size(), v.bbox());
        for (a, h) in h.iter().enumerate() {
            assert!((size[a] - h).abs() < 1e-12, "{size:?}");
            assert!((b.min[a] - 0.5 * h).abs() < 1e-12, "{b:?}");
            assert!((b.max[a] - 2.5 * h).abs() < 1e-12, "{b:?}");
        }
        assert!(v.data().iter().all(|&d| d == 0.5), "{:?}", v.data());
    }

    #[test]
    fn a_mirrored_grid_reads_where_its_transform_puts_each_voxel() {
        // Scale (−0.1, 0.2, 0.3), translation (1, 2, 3): file index (i, j, k) is centred at
        // world (1 − 0.1 i, 2 + 0.2 j, 3 + 0.3 k) and holds 0.01 (1 + i + 10 j + 100 k).
        // OpenVDB also stores the scale's magnitude as the "voxel size": read by it, the
        // grid sat at x 0.95..1.35 with its values in the wrong order along x.
        let v = import::import(&data("synthetic/mirrored.vdb"), &ImportOptions::default()).unwrap();
        assert_eq!(v.dims(), [4, 4, 4]);
        let (h, b) = (v.voxel_size(), v.bbox());
        let (want_h, want_min) = ([0.1, 0.2, 0.3], [0.65, 1.9, 2.85]);
        for a in 0..3 {
            assert!((h[a] - want_h[a]).abs() < 1e-12, "{h:?}");
            assert!((b.min[a] - want_min[a]).abs() < 1e-12, "{b:?}");
        }
        for z in 0..4 {
            for y in 0..4 {
                for x in 0..4 {
                    let wx = b.min[0] + (x as f64 + 0.5) * h[0];
                    let i = ((1.0 - wx) / 0.1).round() as usize;
                    let want = 0.01f32 * (1 + i + 10 * y + 100 * z) as f32;
                    let got = v.get(x, y, z);
                    assert!((got - want).abs() <= 1e-6, "({x}, {y}, {z}): {got} {want}");
                }
            }
        }
    }

    /// A sequence whose first frame is mirrored along x and whose second is not (its
    /// smoke written by haze's exporter, positive scales, two voxels further along x):
    /// one grid over both, each frame's voxels where its own transform puts them. The
    /// mirrored frame's indices run the other way, so the frames' lattices differ by the
    /// translations' difference and a voxel; taken as the translations' alone, the grid
    /// was a voxel too long and the second frame a voxel off.
    #[test]
    fn frames_mirrored_and_not_share_one_grid() {
        use haze_volume::{Bbox, Volume};
        let tmp = tempfile::tempdir().unwrap();
        std::fs::copy(data("synthetic/mirrored.vdb"), tmp.path().join("m_1.vdb")).unwrap();
        // mirrored.vdb spans (0.65, 1.9, 2.85)..(1.05, 2.7, 4.05) in voxels (0.1, 0.2, 0.3).
        let moved = Bbox::new([0.85, 1.9, 2.85], [1.25, 2.7, 4.05]);
        let second = Volume::new([4, 4, 4], moved, vec![0.25; 64]).unwrap();
        let bytes = haze_volume::export::vdb::to_bytes(&second).unwrap();
        std::fs::write(tmp.path().join("m_2.vdb"), bytes).unwrap();
        let seq =
            Sequence::open(tmp.path(), &ImportOptions::default(), Default::default()).unwrap();
        assert_eq!(seq.dims(), [6, 4, 4]);
        let want = Bbox::new([0.65, 1.9, 2.85], [1.25, 2.7, 4.05]);
        assert!(seq.bbox().approx_eq(&want, 1e-9), "{:?}", seq.bbox());
        let (a, b) = (seq.load(0).unwrap(), seq.load(1).unwrap());
        for z in 0..4 {
            for y in 0..4 {
                for x in 0..6 {
                    // Voxel x is centred at world 0.7 + 0.1 x; the mirrored file's index
                    // there is i = (1 − wx) / 0.1, its value 0.01 (1 + i + 10 y + 100 z).
                    let i = 3 - x as i64;
                    let want_a = if (0..4).contains(&i) {
                        0.01f32 * (1 + i + 10 * y + 100 * z) as f32
                    } else {
                        0.0
                    };
                    let want_b = if x >= 2 { 0.25 } else { 0.0 };
                    let (ga, gb) = (
                        a.get(x as usize, y as usize, z as usize),
                        b.get(x as usize, y as usize, z as usize),
                    );
                    assert!(
                        (ga - want_a).abs() <= 1e-6,
                        "frame 1 ({x}, {y}, {z}): {ga} {want_a}"
                    );
                    assert_eq!(gb, want_b, "frame 2 ({x}, {y}, {z})");
                }
            }
        }
    }

    #[test]
    fn a_grid_of_64_bit_values_reads_rounded_to_32() {
        // 0.1 + 0.01 (x + 10 y + 100 z) over indices 0..=3, a tile of 0.3 over 8..=15,
        // voxels of 0.25 centred on their indices: each value the f64 rounded to f32.
        let v = import::import(&data("synthetic/double.vdb"), &ImportOptions::default()).unwrap();
        assert_eq!(v.dims(), [16, 16, 16]);
        assert!((v.bbox().min[0] + 0.125).abs() < 1e-12, "{:?}", v.bbox());
        for z in 0..16 {
            for y in 0..16 {
                for x in 0..16 {
                    let want = if x < 4 && y < 4 && z < 4 {
                        (0.1 + 0.01 * (x + 10 * y + 100 * z) as f64) as f32
                    } else if [x, y, z].iter().all(|&i| i >= 8) {
                        0.3f64 as f32
                    } else {
                        0.0
                    };
                    assert_eq!(v.get(x, y, z), want, "({x}, {y}, {z})");
                }
            }
        }
    }

    /// `double.vdb` saved as half floats (`Tree_double_5_4_3_HalfFloat`; it was refused
    /// as an unknown type), with an inactive voxel of 0.7 at (5, 5, 5): every value within
    /// half a unit in the last place of a half float (`2⁻¹¹` relative, the values being
    /// normal halves) of the f64 it was written from, the tile's and the inactive voxel's
    /// too.
    #[test]
    fn a_grid_of_64_bit_values_saved_as_half_floats_reads() {
        let v = import::import(
            &data("synthetic/double_half.vdb"),
            &ImportOptions::default(),
        )
        .unwrap();
        assert_eq!(v.dims(), [16, 16, 16]);
        assert!((v.bbox().min[0] + 0.125).abs() < 1e-12, "{:?}", v.bbox());
        let mut rounded = 0;
        for z in 0..16 {
            for y in 0..16 {
                for x in 0..16 {
                    let want = if x < 4 && y < 4 && z < 4 {
                        0.1 + 0.01 * (x + 10 * y + 100 * z) as f64
                    } else if [x, y, z].iter().all(|&i| i >= 8) {
                        0.3
                    } else if [x, y, z] == [5, 5, 5] {
                        0.7
                    } else {
                        0.0
                    };
                    let got = f64::from(v.get(x, y, z));
                    assert!(
                        (got - want).abs() <= want * 2f64.powi(-11),
                        "({x}, {y}, {z}): {got} {want}"
                    );
                    rounded += usize::from(got != f64::from(want as f32));
                }
            }
        }
        // Read through halves, not as 64-bit values rounded to 32 bits.
        assert!(rounded > 32, "{rounded}");
    }

    #[test]
    fn grids_of_the_same_name_are_listed_and_read_as_openvdb_shows_them() {
        let path = data("synthetic/same_names.vdb");
        let info = vdb::probe(&path).unwrap();
        let names: Vec<&str> = info.grids.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(names, ["density[0]", "density[1]"]);
        // The default name matches neither, and the error lists what does.
        let e = import::import(&path, &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("grids in the file: density[0], density[1]"),
            "{e}"
        );
        for (name, value) in [("density[0]", 0.5), ("density[1]", 0.25)] {
            let opts = ImportOptions {
                grid: name.to_string(),
                ..ImportOptions::default()
            };
            let v = import::import(&path, &opts).unwrap();
            assert_eq!(v.dims(), [2, 2, 2], "{name}");
            assert!(
                v.data().iter().all(|&d| d == value),
                "{name}: {:?}",
                v.data()
            );
        }
    }

    #[test]
    fn root_tiles_read_as_their_value() {
        // A constant 0.25 over the root tile of indices 0..4095 (no node below the root
        // stores it) and one voxel of 0.75 at (-1, -1, -1), read through a box across
        // the tile's corner: the tile's voxels are 0.25, the voxel 0.75, the rest 0.
        let bx = vdb::IndexBox {
            min: [-2; 3],
            max: [1; 3],
        };
        let f = vdb::read(
            &data("synthetic/root_tile.vdb"),
            &ImportOptions::default(),
            Some(bx),
        )
        .unwrap();
        let v = &f.volume;
        assert_eq!(v.dims(), [4, 4, 4]);
        for z in 0..4 {
            for y in 0..4 {
                for x in 0..4 {
                    let want = if [x, y, z].iter().all(|&i| i >= 2) {
                        0.25
                    } else if [x, y, z] == [1, 1, 1] {
                        0.75
                    } else {
                        0.0
                    };
                    assert_eq!(v.get(x, y, z), want, "({x}, {y}, {z})");
                }
            }
        }
        // Without a box the file's own box is the whole tile: too large, and said so.
        let e = import::import(&data("synthetic/root_tile.vdb"), &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("too large"), "{e}");
    }

    #[test]
    fn an_empty_grid_is_an_empty_frame() {
        let v = import::import(&data("synthetic/empty.vdb"), &ImportOptions::default()).unwrap();
        assert!(v.is_empty());
        assert_eq!(VolumeStats::of(&v).nonzero, 0);
    }

    #[test]
    fn ball_128_imports_with_its_statistics() {
        let v = import::import(&data("synthetic/ball_128.vdb"), &ImportOptions::default()).unwrap();
        let s = VolumeStats::of(&v);
        // The ball r < 0.4 of a unit cube, sampled at 128³: about 4/3·π·0.4³·128³ voxels.
        let expected = 4.0 / 3.0 * std::f64::consts::PI * 0.4f64.powi(3) * 128f64.powi(3);
        assert!(
            (s.nonzero as f64 / expected - 1.0).abs() < 0.01,
            "{}",
            s.nonzero
        );
        assert!(s.max <= 1.0 && s.min == 0.0);
        assert!(
            v.dims().iter().all(|&d| (100..=104).contains(&d)),
            "{:?}",
            v.dims()
        );
    }
}

/// An Adaptive Domain's frames (`data/blender-adaptive/`) placed in the whole domain by
/// their configurations: frame 1 is bit for bit the same domain baked without Adaptive
/// Domain (both simulations have taken one step from the same emitter), and frame 6,
/// simulated on a block of the domain, within what the smaller block changes.
#[test]
fn adaptive_domain_frames_sit_where_the_full_domain_has_them() {
    let opts = ImportOptions::default();
    let adaptive = |n: u32| {
        data(&format!(
            "blender-adaptive/adaptive/data/fluid_data_{n:04}.vdb"
        ))
    };
    let fixed = |n: u32| {
        data(&format!(
            "blender-adaptive/fixed/data/fluid_data_{n:04}.vdb"
        ))
    };
    // The files themselves hold a block of the domain at a cell too large.
    let block = vdb::probe(&adaptive(6)).unwrap();
    let g = block.grid("density").unwrap();
    let p = g.placement.as_ref().expect("placed by its configuration");
    assert_ne!(g.base_resolution, Some([21, 21, 32]));
    assert_eq!(g.domain_resolution(), Some([21, 21, 32]));
    assert!(p.config.ends_with("config/config_0006.uni"));

    let a1 = import::import(&adaptive(1), &opts).unwrap();
    let f1 = import::import(&fixed(1), &opts).unwrap();
    assert_eq!(a1.dims(), [21, 21, 32]);
    assert_eq!(a1.dims(), f1.dims());
    // The same box to f32 precision: the file's voxel size is an f32 of its own grid.
    assert!(
        a1.bbox().approx_eq(f1.bbox(), 2e-7),
        "{:?} {:?}",
        a1.bbox(),
        f1.bbox()
    );
    assert!(
        bits(&a1) == bits(&f1),
        "frame 1 differs from the full domain's"
    );

    let seq = Sequence::open(
        &data("blender-adaptive/adaptive/data"),
        &opts,
        FrameRange::default(),
    )
    .unwrap();
    assert_eq!((seq.len(), seq.dims()), (2, [21, 21, 32]));
    let a6 = seq.load(1).unwrap();
    let f6 = import::import(&fixed(6), &opts).unwrap();
    assert_eq!(a6.bbox(), seq.bbox());
    let (sa, sf) = (VolumeStats::of(&a6), VolumeStats::of(&f6));
    assert_eq!(sa.nonzero_bbox, sf.nonzero_bbox);
    // Voxel for voxel the two simulations differ by a few per cent of the peak; a block
    // placed one cell off would differ by the density's own steps (half the peak).
    let worst = a6
        .data()
        .iter()
        .zip(f6.data())
        .map(|(a, f)| (a - f).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 0.05 * sf.max, "{worst} of {}", sf.max);
    let one_off = a6
        .data()
        .iter()
        .zip(&f6.data()[1..])
        .map(|(a, f)| (a - f).abs())
        .fold(0.0f32, f32::max);
    assert!(one_off > 0.3 * sf.max, "{one_off}");
}

/// Without its configuration an Adaptive Domain's frames cannot be placed: the sequence is
/// refused on one line naming the missing file and both ways out.
#[test]
fn adaptive_domain_frames_without_their_configuration_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("data");
    std::fs::create_dir(&frames).unwrap();
    for n in [1, 6] {
        let name = format!("fluid_data_{n:04}.vdb");
        std::fs::copy(
            data("blender-adaptive/adaptive/data").join(&name),
            frames.join(&name),
        )
        .unwrap();
    }
    let e = Sequence::open(&frames, &ImportOptions::default(), FrameRange::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("Adaptive Domain without its configuration")
            && e.contains("config_0006.uni")
            && e.contains("keep the cache's config folder")
            && !e.contains('\n'),
        "{e}"
    );
}
