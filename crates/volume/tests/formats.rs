//! NumPy and raw imports on synthetic files, including every documented error.

use haze_volume::ImportOptions;
use haze_volume::import::samples::SampleType;
use haze_volume::import::{self, Sequence};
use npyz::WriterBuilder;
use std::path::Path;

fn write_npy<T: npyz::AutoSerialize + Copy>(
    path: &Path,
    shape: &[u64],
    order: npyz::Order,
    data: &[T],
) {
    let mut buf = Vec::new();
    let mut w = npyz::WriteOptions::new()
        .default_dtype()
        .shape(shape)
        .order(order)
        .writer(&mut buf)
        .begin_nd()
        .unwrap();
    w.extend(data.iter().copied()).unwrap();
    w.finish().unwrap();
    std::fs::write(path, buf).unwrap();
}

fn sidecar(path: &Path, body: &str) {
    std::fs::write(path.with_extension("json"), body).unwrap();
}

/// Value of voxel (x, y, z) in the synthetic volumes: distinct everywhere.
fn value(x: usize, y: usize, z: usize) -> f32 {
    (x + 10 * y + 100 * z) as f32 * 0.01
}

#[test]
fn npy_c_and_fortran_orders_both_give_x_fastest() {
    let tmp = tempfile::tempdir().unwrap();
    let (nx, ny, nz) = (4usize, 3usize, 2usize);
    // C order, shape (z, y, x): the last index (x) varies fastest.
    let mut c = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                c.push(value(x, y, z));
            }
        }
    }
    let pc = tmp.path().join("c.npy");
    write_npy(&pc, &[nz as u64, ny as u64, nx as u64], npyz::Order::C, &c);
    // Fortran order, shape (x, y, z): the first index (x) varies fastest, same bytes.
    let pf = tmp.path().join("f.npy");
    write_npy(
        &pf,
        &[nx as u64, ny as u64, nz as u64],
        npyz::Order::Fortran,
        &c,
    );
    // A batch axis before and a channel axis after: the same volume.
    let pb = tmp.path().join("batch.npy");
    let shape = [1, nz as u64, ny as u64, nx as u64, 1];
    write_npy(&pb, &shape, npyz::Order::C, &c);
    let pg = tmp.path().join("fortran_channel.npy");
    let shape = [1, nx as u64, ny as u64, nz as u64, 1, 1];
    write_npy(&pg, &shape, npyz::Order::Fortran, &c);
    for p in [&pc, &pf, &pb, &pg] {
        let v = import::import(p, &ImportOptions::default()).unwrap();
        assert_eq!(v.dims(), [4, 3, 2]);
        assert_eq!(v.get(3, 1, 0), value(3, 1, 0));
        assert_eq!(v.get(1, 2, 1), value(1, 2, 1));
        // No sidecar: unit voxels at the origin.
        assert_eq!(v.bbox().max, [4.0, 3.0, 2.0]);
    }
}

#[test]
fn npy_float64_and_sidecar_box() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("d.npy");
    let data: Vec<f64> = (0..24).map(|i| i as f64 / 8.0).collect();
    write_npy(&p, &[2, 3, 4], npyz::Order::C, &data);
    sidecar(
        &p,
        r#"{"dims": [4, 3, 2], "world_bbox_min": [-1, -1, 0], "world_bbox_max": [1, 0.5, 1], "note": "x"}"#,
    );
    let v = import::import(&p, &ImportOptions::default()).unwrap();
    assert_eq!(v.bbox().min, [-1.0, -1.0, 0.0]);
    assert_eq!(v.data()[23], 23.0 / 8.0);
    sidecar(
        &p,
        r#"{"dims": [2, 3, 4], "world_bbox_min": [0, 0, 0], "world_bbox_max": [1, 1, 1]}"#,
    );
    let e = import::import(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("disagree with the array's [4, 3, 2]"), "{e}");
}

#[test]
fn npy_errors_are_clear() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("flat.npy");
    write_npy(&p, &[6], npyz::Order::C, &[0f32; 6]);
    let e = import::import(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("shape [6]; a volume needs 3 dimensions"), "{e}");
    let p = tmp.path().join("wide.npy");
    write_npy(&p, &[2, 1, 1, 1, 3], npyz::Order::C, &[0f32; 6]);
    let e = import::import(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("shape [2, 1, 1, 1, 3]; a volume needs 3"), "{e}");
    let p = tmp.path().join("int.npy");
    write_npy(&p, &[1, 1, 2], npyz::Order::C, &[1i32, 2]);
    let e = import::import(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("dtype '<i4' is not supported: use float16, float32, float64, uint8 or uint16"),
        "{e}"
    );
    let p = tmp.path().join("junk.npy");
    std::fs::write(&p, b"\x93NUMPY garbage").unwrap();
    let e = import::import(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&p.display().to_string()), "{e}");
    let p = tmp.path().join("nan.npy");
    write_npy(&p, &[1, 1, 3], npyz::Order::C, &[0.0f32, f32::NAN, 1.0]);
    let e = import::import(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("voxel (1, 0, 0) centred at world (") && e.contains(") is NaN"),
        "{e}"
    );
}

/// 8- and 16-bit unsigned samples come in as fractions of 255 / 65535 and half floats as
/// they are, from `.npy` and from raw files whose sidecar names the type, with the values
/// written here independently (the integers' ends and the half-float bit patterns of 0.5,
/// 1 and 2).
#[test]
fn integer_and_half_samples() {
    let tmp = tempfile::tempdir().unwrap();
    let want = [0.0f32, 0.2, 0.4, 1.0];
    let p = tmp.path().join("u8.npy");
    write_npy(&p, &[1, 2, 2], npyz::Order::C, &[0u8, 51, 102, 255]);
    assert_eq!(
        import::import(&p, &ImportOptions::default())
            .unwrap()
            .data(),
        &want
    );
    let p = tmp.path().join("u16.npy");
    write_npy(&p, &[1, 2, 2], npyz::Order::C, &[0u16, 13107, 26214, 65535]);
    assert_eq!(import::samples_of(&p).unwrap(), Some(SampleType::U16));
    assert_eq!(
        import::import(&p, &ImportOptions::default())
            .unwrap()
            .data(),
        &want
    );
    let halves = [0.5f32, 1.0, 2.0, 0.0].map(half::f16::from_f32);
    let p = tmp.path().join("f16.npy");
    write_npy(&p, &[2, 2, 1], npyz::Order::Fortran, &halves);
    assert_eq!(
        import::import(&p, &ImportOptions::default())
            .unwrap()
            .data(),
        &[0.5, 1.0, 2.0, 0.0]
    );
    let box_of = |dtype: &str| {
        format!(
            r#"{{"dims": [2, 2, 1], "world_bbox_min": [0,0,0], "world_bbox_max": [2,2,1], "dtype": "{dtype}"}}"#
        )
    };
    let p = tmp.path().join("r8.raw");
    std::fs::write(&p, [0u8, 51, 102, 255]).unwrap();
    sidecar(&p, &box_of("uint8"));
    assert_eq!(import::samples_of(&p).unwrap(), Some(SampleType::U8));
    assert_eq!(
        import::import(&p, &ImportOptions::default())
            .unwrap()
            .data(),
        &want
    );
    let p = tmp.path().join("r16.raw");
    std::fs::write(&p, [0u8, 0, 0x33, 0x33, 0x66, 0x66, 0xff, 0xff]).unwrap();
    sidecar(&p, &box_of("<u2"));
    assert_eq!(
        import::import(&p, &ImportOptions::default())
            .unwrap()
            .data(),
        &want
    );
    let p = tmp.path().join("rh.raw");
    std::fs::write(&p, [0x00, 0x38, 0x00, 0x3c, 0x00, 0x40, 0x00, 0x00]).unwrap();
    sidecar(&p, &box_of("float16"));
    assert_eq!(
        import::import(&p, &ImportOptions::default())
            .unwrap()
            .data(),
        &[0.5, 1.0, 2.0, 0.0]
    );
}

#[test]
fn raw_sidecar_errors_are_clear() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("r.f32");
    std::fs::write(&p, vec![0u8; 32]).unwrap();
    let e = import::import(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("r.json"), "missing sidecar: {e}");
    for (body, needle) in [
        (r#"{"dims": [2, 2]}"#, "expected an array of length 3"),
        (
            r#"{"dims": [2, 2, 2], "world_bbox_min": [0,0,0], "world_bbox_max": [1,0,1]}"#,
            "not ordered",
        ),
        (
            r#"{"dims": [2, 2, 2], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1], "voxel_size": [0.1, 0.5, 0.5]}"#,
            "voxel_size",
        ),
        (
            r#"{"dims": [2, 2, 2], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1], "dtype": "int16"}"#,
            "dtype 'int16' is not supported: use little-endian float16, float32, float64, uint8",
        ),
        (
            r#"{"dims": [2, 2, 2], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1], "dtype": "float32 big-endian"}"#,
            "dtype 'float32 big-endian'",
        ),
        (
            r#"{"dims": [2, 2, 2], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1], "dtype": "uint16"}"#,
            "need 16 bytes of uint16 but the file has 32 bytes",
        ),
    ] {
        sidecar(&p, body);
        let e = import::import(&p, &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{body}: {e}");
        assert!(e.starts_with(&p.display().to_string()), "{e}");
    }
}

#[test]
fn sequences_must_share_one_grid() {
    let tmp = tempfile::tempdir().unwrap();
    // 1002 and 1004 agree with 1001 to f32 precision (5e-7 of the side, under SAME_BOX's
    // 1e-6); 1005 is 2e-5 off, 1006 twice as long.
    for (n, max) in [
        (1001, 1.0),
        (1002, 1.0000005),
        (1004, 1.0),
        (1005, 1.00002),
        (1006, 2.0),
    ] {
        let p = tmp.path().join(format!("s.{n}.f32"));
        std::fs::write(&p, vec![0u8; 32]).unwrap();
        sidecar(
            &p,
            &format!(
                r#"{{"dims": [2, 2, 2], "world_bbox_min": [0,0,0], "world_bbox_max": [{max},1,1]}}"#
            ),
        );
    }
    let range: haze_volume::import::FrameRange = "1001..1004".parse().unwrap();
    let seq = Sequence::open(tmp.path(), &ImportOptions::default(), range).unwrap();
    assert_eq!(seq.gaps(), &[(1003, 1003)]);
    // The same grid: read in the first frame's box.
    assert_eq!(seq.load(1).unwrap().bbox(), seq.bbox());
    // A frame of another grid is refused on opening (from its sidecar), before any frame
    // is baked.
    let open = || {
        Sequence::open(tmp.path(), &ImportOptions::default(), Default::default())
            .err()
            .unwrap()
            .to_string()
    };
    let e = open();
    assert!(
        e.contains("s.1005.f32") && e.contains("1.00002") && e.contains("frame 1001"),
        "{e}"
    );
    std::fs::remove_file(tmp.path().join("s.1005.f32")).unwrap();
    let e = open();
    assert!(
        e.contains("s.1006.f32") && e.contains("frame 1006") && e.contains("frame 1001"),
        "{e}"
    );
}

/// NumPy frames of another shape are refused on opening too, from their headers.
#[test]
fn npy_frames_of_another_shape_are_refused_on_opening() {
    let tmp = tempfile::tempdir().unwrap();
    for (n, nz) in [(1, 2), (2, 2), (3, 3)] {
        write_npy::<f32>(
            &tmp.path().join(format!("f_{n}.npy")),
            &[nz, 2, 2],
            npyz::Order::C,
            &vec![0.5; nz as usize * 4],
        );
    }
    let e = Sequence::open(tmp.path(), &ImportOptions::default(), Default::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("f_3.npy") && e.contains("frame 3 has grid [2, 2, 3]") && e.contains("frame 1"),
        "{e}"
    );
}

#[test]
fn sequences_refuse_ambiguity() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("a_1.npy"), b"").unwrap();
    std::fs::write(tmp.path().join("a_1.f32"), b"").unwrap();
    let e = Sequence::open(tmp.path(), &ImportOptions::default(), Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("several formats"), "{e}");
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("a_01.npy"), b"").unwrap();
    std::fs::write(tmp.path().join("b_1.npy"), b"").unwrap();
    let e = Sequence::open(tmp.path(), &ImportOptions::default(), Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("frame 1 also comes from"), "{e}");
    // Two sequences side by side: the error says how to pick one, and the glob it gives
    // opens that sequence alone.
    let hint = format!(
        "select one with a glob such as '{}'",
        tmp.path().join("b_*.npy").display()
    );
    assert!(e.contains(&hint), "{e}");
    let picked = haze_volume::import::sequence::discover(&tmp.path().join("b_*.npy")).unwrap();
    assert_eq!(picked.len(), 1);
    assert_eq!(picked[0].path, tmp.path().join("b_1.npy"));
    let empty = tempfile::tempdir().unwrap();
    let e = Sequence::open(empty.path(), &ImportOptions::default(), Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no volume files"), "{e}");
}

/// OpenVDB frames whose grid moves with the smoke (each file's indices from 0, its
/// transform's translation following the container, by whole voxels): one grid over
/// them all, each frame's voxels where its own transform puts them. A move by a fraction
/// of a voxel is refused on opening, naming both frames.
#[test]
fn vdb_frames_whose_grid_moves_share_one_grid() {
    use haze_volume::{Bbox, Volume};
    let tmp = tempfile::tempdir().unwrap();
    let frame = |n: u32, x0: f64, value: f32| {
        let bbox = Bbox::new([x0, 0.0, 0.0], [x0 + 0.4, 0.4, 0.4]);
        let v = Volume::new([4, 4, 4], bbox, vec![value; 64]).unwrap();
        let bytes = haze_volume::export::vdb::to_bytes(&v).unwrap();
        std::fs::write(tmp.path().join(format!("m_{n}.vdb")), bytes).unwrap();
    };
    frame(1, 0.0, 0.5);
    frame(2, 0.3, 0.25);
    let seq = Sequence::open(tmp.path(), &ImportOptions::default(), Default::default()).unwrap();
    assert_eq!(seq.dims(), [7, 4, 4]);
    assert_eq!(seq.shifts(), &[[0, 0, 0], [3, 0, 0]]);
    assert!(
        seq.bbox()
            .approx_eq(&Bbox::new([0.0; 3], [0.7, 0.4, 0.4]), 1e-12)
    );
    let (a, b) = (seq.load(0).unwrap(), seq.load(1).unwrap());
    for x in 0..7 {
        // Frame 1 covers x in [0, 0.4), frame 2 x in [0.3, 0.7): voxels 0..4 and 3..7.
        let want_a = if x < 4 { 0.5 } else { 0.0 };
        let want_b = if x >= 3 { 0.25 } else { 0.0 };
        assert_eq!(
            (a.get(x, 2, 1), b.get(x, 2, 1)),
            (want_a, want_b),
            "x = {x}"
        );
    }
    frame(3, 0.35, 0.25);
    let e = Sequence::open(tmp.path(), &ImportOptions::default(), Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("m_3.vdb")
            && e.contains("frame 3's grid is moved by (3.500, 0.000, 0.000) voxels from frame 1's")
            && e.contains("without resampling"),
        "{e}"
    );
}

/// OpenVDB frames of different voxel sizes are refused on opening, naming both frames and
/// both sizes (the second frame's indices, of another grid, had stretched the union the
/// first frames were fitted over, and the bake failed only when the second frame's turn
/// came); a chunk of the frames that share one size opens over their own grid.
#[test]
fn vdb_frames_of_another_voxel_size_are_refused_on_opening() {
    use haze_volume::{Bbox, Volume};
    let tmp = tempfile::tempdir().unwrap();
    // Four voxels a side each (the exporter records the grid as its domain, which must
    // not change either), over 0.4 and then 0.2.
    let frame = |n: u32, side: f64| {
        let v = Volume::new([4; 3], Bbox::new([0.0; 3], [side; 3]), vec![0.5; 64]).unwrap();
        let bytes = haze_volume::export::vdb::to_bytes(&v).unwrap();
        std::fs::write(tmp.path().join(format!("s_{n}.vdb")), bytes).unwrap();
    };
    frame(1, 0.4);
    frame(2, 0.2);
    let e = Sequence::open(tmp.path(), &ImportOptions::default(), Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s_2.vdb")
            && e.contains("frame 2's voxels are 0.05 × 0.05 × 0.05 but frame 1's")
            && e.contains("are 0.1 × 0.1 × 0.1")
            && e.contains("resample"),
        "{e}"
    );
    let first: haze_volume::import::FrameRange = "1..1".parse().unwrap();
    let seq = Sequence::open(tmp.path(), &ImportOptions::default(), first).unwrap();
    assert_eq!(seq.dims(), [4, 4, 4]);
    assert!(seq.bbox().approx_eq(&Bbox::new([0.0; 3], [0.4; 3]), 1e-9));
}

/// Files of volume formats haze does not read but smoke tools write are named with the way
/// to OpenVDB: a NanoVDB file given alone, a folder holding only Mantaflow's `.uni` cache.
#[test]
fn foreign_volume_formats_say_how_to_get_openvdb() {
    let tmp = tempfile::tempdir().unwrap();
    let nvdb = tmp.path().join("smoke.nvdb");
    std::fs::write(&nvdb, b"NanoVDB0").unwrap();
    let e = haze_volume::import::import(&nvdb, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("smoke.nvdb: unknown file type: NanoVDB; haze reads OpenVDB")
            && e.contains("nanovdb_convert"),
        "{e}"
    );
    let uni = tmp.path().join("cache");
    std::fs::create_dir(&uni).unwrap();
    for n in [2, 1] {
        std::fs::write(uni.join(format!("density_{n:04}.uni")), b"MNT3").unwrap();
    }
    std::fs::write(uni.join("notes.txt"), b"").unwrap();
    let e = Sequence::open(&uni, &ImportOptions::default(), Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no volume files (.vdb, .f32/.raw, .npy) found, but 2 files of Mantaflow's .uni cache (density_0001.uni, …)")
            && e.contains("Format Volumes to OpenVDB"),
        "{e}"
    );
    // A folder of other files says only what it lacks.
    std::fs::remove_file(uni.join("density_0001.uni")).unwrap();
    std::fs::remove_file(uni.join("density_0002.uni")).unwrap();
    let e = Sequence::open(&uni, &ImportOptions::default(), Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with("no volume files (.vdb, .f32/.raw, .npy) found"),
        "{e}"
    );
}

/// haze's exports record their grid as their domain: a folder mixing the exports of two
/// assets of different grids is named as that, not as a Blender cache without its
/// configuration.
#[test]
fn exports_of_different_grids_are_named_as_exports() {
    use haze_volume::{Bbox, Volume};
    let tmp = tempfile::tempdir().unwrap();
    for (n, dims) in [(1, 4), (2, 8)] {
        let v = Volume::new(
            [dims; 3],
            Bbox::new([0.0; 3], [0.4; 3]),
            vec![0.5; dims * dims * dims],
        )
        .unwrap();
        let bytes = haze_volume::export::vdb::to_bytes(&v).unwrap();
        std::fs::write(tmp.path().join(format!("e_{n}.vdb")), bytes).unwrap();
    }
    let e = Sequence::open(tmp.path(), &ImportOptions::default(), Default::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("e_2.vdb: frame 2's grid is 8 × 8 × 8 cells but frame 1's is 4 × 4 × 4: exports of different grids")
            && !e.contains("Adaptive Domain"),
        "{e}"
    );
}
