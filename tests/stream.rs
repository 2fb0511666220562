//! Streaming playback (`haze_view::stream`) on an asset baked from the bundled plume-a
//! frames: order, equality with a direct read, scrubbing, looping, bounded read-ahead and
//! damaged blocks.

use assert_cmd::Command;
use haze_asset::{Asset, BlockKind, decode_rbfs};
use haze_view::stream::{FrameDecoder, FrameStream};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

fn bake(dir: &Path) -> PathBuf {
    let out = dir.join("plume.haze");
    let plume = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/plume-a/vdb");
    let o = Command::cargo_bin("haze")
        .unwrap()
        .args([
            "bake",
            plume.to_str().unwrap(),
            "--frames",
            "21..26",
            "-q",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

#[test]
fn streams_frames_in_order_with_scrubbing_and_bounded_read_ahead() {
    let dir = tempfile::tempdir().unwrap();
    let path = bake(dir.path());
    let asset = Asset::open(&path).unwrap();
    let n = asset.frame_count();
    assert_eq!(n, 6);

    // Nothing consumed: the reader stops after `ahead` queued frames plus one in hand.
    let mut s = FrameStream::open(&path, 2, false).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    assert!(
        s.decoded() <= 3,
        "read ahead {} frames with a queue of 2",
        s.decoded()
    );

    // In order, each equal to a direct read of its blocks.
    let mut direct = FrameDecoder::new(Arc::new(Asset::open(&path).unwrap()));
    for k in 0..n {
        let f = s.next_frame().unwrap().unwrap();
        assert_eq!((f.index, f.number), (k, 21 + k as i64));
        let blocks = asset.frame(k).unwrap();
        let rbfs = decode_rbfs(blocks.find(BlockKind::Rbfs).unwrap().bytes).unwrap();
        assert_eq!(f.rbfs, rbfs);
        let mine = f.residual.as_ref().unwrap();
        let theirs = direct.decode(k).unwrap().residual.unwrap();
        assert_eq!(
            (mine.slot, mine.group.frames()),
            (0, 1),
            "a frame of its own"
        );
        assert_eq!(mine.dense(), theirs.dense());
        assert!(mine.dense().iter().any(|r| *r != 0.0));
    }
    assert!(s.next_frame().is_none(), "a non-looping stream ends");

    // A volume met without a decode ahead is decoded up to the frame asked for: the same
    // residual, the later frames not yet there; a later frame decodes the whole volume,
    // which then serves the earlier ones too. A prefetching decoder gives each frame as a
    // group of its own, decoded ahead in order on a thread of its own.
    let whole = direct.decode(n - 1).unwrap().residual.unwrap().group;
    assert_eq!(whole.frames(), n);
    let mut single = FrameDecoder::new(Arc::new(Asset::open(&path).unwrap()));
    let first = single.decode(2).unwrap().residual.unwrap();
    assert_eq!(first.group.frames(), 3);
    assert_eq!(first.dense(), whole.dense(2));
    let later = single.decode(4).unwrap().residual.unwrap();
    assert_eq!((later.group.frames(), later.dense()), (n, whole.dense(4)));
    let again = single.decode(1).unwrap().residual.unwrap();
    assert!(Arc::ptr_eq(&again.group, &later.group));
    // Frames it decodes, and those it passes over on a skip, are kept for a later round.
    let mut ahead = FrameDecoder::prefetching(Arc::new(Asset::open(&path).unwrap()), false);
    let mut seen: Vec<Option<Arc<_>>> = vec![None; n];
    for k in [1, 2, 4, 3, 3, 5, 0, 2] {
        let r = ahead.decode(k).unwrap().residual.unwrap();
        let got = (r.group.frames(), r.slot, r.dense());
        assert_eq!(got, (1, 0, whole.dense(k)), "frame {k}");
        assert!(ahead.decoding_ahead(), "frame {k}");
        if let Some(g) = &seen[k] {
            assert!(Arc::ptr_eq(g, &r.group), "frame {k} kept");
        }
        seen[k] = Some(r.group);
    }
    assert!(
        seen[3].is_some(),
        "frame 3 was passed over on the way to 4, then kept"
    );

    // Scrubbing back, then forward.
    s.seek(4);
    assert_eq!(s.next_frame().unwrap().unwrap().index, 4);
    s.seek(1);
    let a = s.next_frame().unwrap().unwrap();
    let b = s.next_frame().unwrap().unwrap();
    assert_eq!((a.index, b.index), (1, 2));
    assert_eq!(a.residual.unwrap().dense(), whole.dense(1));
    assert_eq!(b.residual.unwrap().dense(), whole.dense(2));
    s.seek(99);
    assert_eq!(s.next_frame().unwrap().unwrap().index, n - 1);

    // Looping wraps to the first frame.
    let mut l = FrameStream::open(&path, 3, true).unwrap();
    let idx: Vec<usize> = (0..n + 2)
        .map(|_| l.next_frame().unwrap().unwrap().index)
        .collect();
    assert_eq!(idx, [0, 1, 2, 3, 4, 5, 0, 1]);
}

#[test]
fn a_damaged_frame_is_reported_and_playback_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let path = bake(dir.path());
    let asset = Asset::open(&path).unwrap();
    let e = asset
        .entries()
        .iter()
        .filter(|e| e.kind == BlockKind::Rbfs)
        .nth(2)
        .copied()
        .unwrap();
    drop(asset);
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[e.offset as usize + 10] ^= 0xff;
    let bad = dir.path().join("bad.haze");
    std::fs::write(&bad, bytes).unwrap();

    let mut s = FrameStream::open(&bad, 2, false).unwrap();
    for k in 0..6 {
        let f = s.next_frame().unwrap();
        if k == 2 {
            let err = f.unwrap_err();
            assert!(
                err.contains("bad.haze") && err.lines().count() == 1,
                "{err}"
            );
        } else {
            assert_eq!(f.unwrap().index, k);
        }
    }

    // A damaged hash volume: each of its frames says so, and the stream ends as it would.
    let asset = Asset::open(&path).unwrap();
    let e = *asset
        .entries()
        .iter()
        .find(|e| e.kind == BlockKind::ResidualHash)
        .unwrap();
    drop(asset);
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[e.offset as usize + e.len as usize / 2] ^= 0xff;
    let bad = dir.path().join("bad-residual.haze");
    std::fs::write(&bad, bytes).unwrap();
    let mut s = FrameStream::open(&bad, 2, false).unwrap();
    for k in 0..6 {
        let err = s.next_frame().unwrap().unwrap_err();
        assert!(
            err.contains("bad-residual.haze") && err.lines().count() == 1,
            "frame {k}: {err}"
        );
    }
    assert!(s.next_frame().is_none());
}

#[test]
fn opening_a_missing_or_foreign_file_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let e = FrameStream::open(&dir.path().join("none.haze"), 2, false).unwrap_err();
    assert!(e.to_string().contains("none.haze"), "{e}");
    let junk = dir.path().join("junk.haze");
    std::fs::write(&junk, b"not an asset at all, clearly").unwrap();
    let e = FrameStream::open(&junk, 2, false).unwrap_err();
    assert!(e.to_string().contains("junk.haze"), "{e}");
}

/// A packed asset's frames stream as frames with no RBFs whose residual is the packed
/// density itself, bit for bit (negative and zero voxels included), compared with the
/// bundled frame's raw `f32` file.
#[test]
fn a_packed_frame_streams_as_its_exact_density() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = dir.path().join("packed.haze");
    let o = Command::cargo_bin("haze")
        .unwrap()
        .args(["pack", root.join("data/plume-a/vdb").to_str().unwrap()])
        .args(["--frames", "24..24", "-q", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let truth: Vec<f32> = std::fs::read(root.join("data/plume-a/dense/density_0024.f32"))
        .unwrap()
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let mut s = FrameStream::open(&out, 2, false).unwrap();
    let f = s.next_frame().unwrap().unwrap();
    assert_eq!(f.number, 24);
    assert!(f.rbfs.is_empty());
    let dense = f.residual.unwrap().dense();
    assert_eq!(dense.len(), truth.len());
    assert!(
        dense
            .iter()
            .zip(&truth)
            .all(|(a, b)| a.to_bits() == b.to_bits() || (*a == 0.0 && *b == 0.0)),
        "the streamed density differs from the packed one"
    );
    assert!(truth.iter().any(|v| *v > 0.0));
    assert!(s.next_frame().is_none());
}
