//! The container end to end: round trips, and every way a file can be damaged.

use haze_asset::{
    Asset, AssetError, AssetWriter, BlockKind, FORMAT_VERSION, GridInfo, Header, Scope, SourceInfo,
    decode_raw_volume, encode_raw_volume,
};
use haze_volume::{Bbox, Volume};
use std::path::Path;

fn header(frames: u32) -> Header {
    Header {
        generator: "haze test".into(),
        frame_count: frames,
        grid: GridInfo {
            dims: [3, 2, 2],
            bbox_min: [0.0; 3],
            bbox_max: [1.5, 1.0, 1.0],
        },
        source: SourceInfo {
            path: "synthetic".into(),
            grid: "density".into(),
            frame_numbers: (1..=i64::from(frames)).collect(),
        },
        settings: Default::default(),
        extra: Default::default(),
    }
}

fn frame_volume(k: usize) -> Volume {
    let b = Bbox::new([0.0; 3], [1.5, 1.0, 1.0]);
    Volume::new(
        [3, 2, 2],
        b,
        (0..12).map(|i| (i * (k + 1)) as f32 * 0.125).collect(),
    )
    .unwrap()
}

/// Three frames of raw volumes, one unknown per-frame-pair block and one asset-wide block.
fn write_sample(path: &Path) {
    let mut w = AssetWriter::create(path).unwrap();
    for k in 0..3 {
        w.write_block(
            BlockKind::RawVolume,
            Scope::frame(k),
            &encode_raw_volume(&frame_volume(k as usize)),
        )
        .unwrap();
    }
    w.write_block(
        BlockKind::Unknown(77),
        Scope::Frames { first: 1, count: 2 },
        b"future data",
    )
    .unwrap();
    w.write_block(BlockKind::Unknown(78), Scope::Asset, &[])
        .unwrap();
    w.finish(&header(3)).unwrap();
}

#[test]
fn round_trip_with_streaming_api() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.haze");
    write_sample(&p);
    let a = Asset::open(&p).unwrap();
    assert_eq!(a.frame_count(), 3);
    assert_eq!(a.header(), &header(3));
    assert_eq!(a.entries().len(), 5);
    for e in a.entries() {
        assert_eq!(e.offset % 64, 0);
    }
    for k in 0..3 {
        let f = a.frame(k).unwrap();
        let raw = f.find(BlockKind::RawVolume).unwrap();
        let v = decode_raw_volume(raw.bytes).unwrap();
        assert!(
            matches!(v.data, std::borrow::Cow::Borrowed(_)),
            "mapped data is not copied"
        );
        assert_eq!(
            v.to_volume(*frame_volume(k).bbox()).unwrap(),
            frame_volume(k)
        );
        assert_eq!(f.blocks.len(), if k == 0 { 1 } else { 2 });
    }
    assert_eq!(a.asset_blocks().unwrap().len(), 1);
    a.verify_all().unwrap();
    let e = a.frame(3).unwrap_err().to_string();
    assert!(
        e.contains("frame 3 does not exist (the asset has 3 frames)"),
        "{e}"
    );
    // Nothing but the asset is left in the directory.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["a.haze"]);
}

#[test]
fn an_unfinished_writer_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("never.haze");
    {
        let mut w = AssetWriter::create(&p).unwrap();
        w.write_block(BlockKind::RawVolume, Scope::frame(0), &[1, 2, 3])
            .unwrap();
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn finish_refuses_blocks_outside_the_frames() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.haze");
    let mut w = AssetWriter::create(&p).unwrap();
    w.write_block(BlockKind::RawVolume, Scope::frame(5), &[])
        .unwrap();
    assert!(matches!(
        w.finish(&header(3)),
        Err(AssetError::Invalid { .. })
    ));
    assert!(!p.exists());
}

#[test]
fn every_truncation_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.haze");
    write_sample(&p);
    let bytes = std::fs::read(&p).unwrap();
    for cut in 0..bytes.len() {
        let e = match Asset::from_bytes(&p, &bytes[..cut]) {
            Ok(_) => panic!("cut at {cut} opened"),
            Err(e) => e,
        };
        assert!(
            matches!(
                e,
                AssetError::Truncated { .. } | AssetError::BadMagic { .. }
            ),
            "cut at {cut}: {e}"
        );
        if cut >= 8 {
            assert!(
                matches!(e, AssetError::Truncated { .. }),
                "cut at {cut}: {e}"
            );
        }
    }
}

/// Bytes appended after the block index (which ends the file) are in no checksum: the
/// reader names them instead of ignoring them.
#[test]
fn bytes_after_the_asset_are_trailing_data() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.haze");
    write_sample(&p);
    let bytes = std::fs::read(&p).unwrap();
    assert!(Asset::from_bytes(&p, &bytes).is_ok());
    for extra in [&b"\0"[..], b"appended", &[0u8; 64]] {
        let mut longer = bytes.clone();
        longer.extend_from_slice(extra);
        let e = Asset::from_bytes(&p, &longer).expect_err("trailing bytes opened");
        let msg = e.to_string();
        assert!(
            msg.contains(&format!(
                "trailing data: {} bytes after the block index",
                extra.len()
            )),
            "{msg}"
        );
    }
}

#[test]
fn every_bit_flip_is_detected_and_blocks_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("f.haze");
    write_sample(&p);
    let bytes = std::fs::read(&p).unwrap();
    let clean = Asset::from_bytes(&p, &bytes).unwrap();
    let block_of = |pos: usize| {
        clean
            .entries()
            .iter()
            .position(|e| (e.offset as usize..(e.offset + e.len) as usize).contains(&pos))
    };
    let mut named = 0;
    for pos in 0..bytes.len() {
        for bit in 0..8 {
            let mut b = bytes.clone();
            b[pos] ^= 1 << bit;
            let err = match Asset::from_bytes(&p, &b) {
                Err(e) => Some(e),
                Ok(a) => a.verify_all().err(),
            };
            match (err, block_of(pos)) {
                (Some(AssetError::Block { block, .. }), Some(i)) => {
                    assert_eq!(block.index, i);
                    named += 1;
                }
                (Some(e), Some(i)) => panic!("flip in block {i} at {pos}.{bit}: {e}"),
                (Some(_), None) => {}
                // Padding between blocks is not covered by any checksum.
                (None, None) => assert!(
                    is_padding(&bytes, &clean, pos),
                    "undetected flip at {pos}.{bit}"
                ),
                (None, Some(i)) => panic!("undetected flip in block {i} at {pos}.{bit}"),
            }
        }
    }
    assert!(named > 0);
}

/// Bytes no checksum covers: alignment padding and the reserved preamble tail. Everything
/// else is the preamble (0..60), a block, the header or the index.
fn is_padding(bytes: &[u8], a: &Asset, pos: usize) -> bool {
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().unwrap()) as usize;
    let mut used = vec![(0, 60), (u64_at(16), u64_at(16) + u64_at(24))];
    used.push((u64_at(32), u64_at(32) + 40 * u64_at(40)));
    used.extend(
        a.entries()
            .iter()
            .map(|e| (e.offset as usize, (e.offset + e.len) as usize)),
    );
    !used.iter().any(|&(s, e)| (s..e).contains(&pos))
}

#[test]
fn future_versions_and_foreign_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("v.haze");
    write_sample(&p);
    let mut b = std::fs::read(&p).unwrap();
    b[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    let crc = crc32fast::hash(&b[0..56]);
    b[56..60].copy_from_slice(&crc.to_le_bytes());
    let e = Asset::from_bytes(&p, &b).unwrap_err().to_string();
    assert!(
        e.contains(&format!(
            "format version {} is newer than this haze reads (up to {FORMAT_VERSION})",
            FORMAT_VERSION + 1
        )),
        "{e}"
    );
    let e = Asset::from_bytes(&p, b"OpenVDB and other things entirely").unwrap_err();
    assert!(matches!(e, AssetError::BadMagic { .. }));
    let e = Asset::open(&dir.path().join("missing.haze"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.haze"), "{e}");
}

#[test]
fn empty_asset_is_valid() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("e.haze");
    AssetWriter::create(&p).unwrap().finish(&header(0)).unwrap();
    let a = Asset::open(&p).unwrap();
    assert_eq!(a.frame_count(), 0);
    assert!(a.entries().is_empty());
    assert!(a.frame(0).is_err());
}
