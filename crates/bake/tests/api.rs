//! The bake through its library API: frames as an iterator, an interrupted bake resumed to
//! the very same asset, and a frame reconstructed within the error asked for.

use haze_bake::{
    Bake, BakeOptions, Count, Event, read_frame, read_rbfs, reconstruct_frame, reconstruct_frames,
};
use haze_fit::{FitOptions, SequenceOptions};
use haze_hash::QuantOptions;
use haze_volume::ImportOptions;
use haze_volume::import::{self, FrameRange};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

fn plume() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/plume-a/vdb")
}

fn options(out: &Path, resume: bool) -> BakeOptions {
    BakeOptions {
        input: plume(),
        out: out.to_path_buf(),
        range: "23..25".parse::<FrameRange>().unwrap(),
        import: ImportOptions::default(),
        count: Count::Fixed(40),
        fit: SequenceOptions {
            fit: FitOptions {
                teleport: false,
                max_iterations: 60,
                ..FitOptions::default()
            },
            ..SequenceOptions::default()
        },
        quant: QuantOptions {
            error: 0.01,
            bits: 8,
        },
        brick: 4,
        volume_bytes: haze_hash::tile::VOLUME_BYTES,
        resume,
        warm_up: 0,
        baseline: None,
        choices: Default::default(),
    }
}

#[test]
fn frames_stream_out_and_an_interrupted_bake_resumes_to_the_same_asset() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.haze");
    let events = Arc::new(Mutex::new(Vec::new()));
    let log = events.clone();
    let mut bake = Bake::new(options(&whole, false), move |e: Event<'_>| {
        log.lock().unwrap().push(format!("{e:?}"))
    })
    .unwrap();
    assert_eq!(
        (bake.sequence().len(), bake.finished(), bake.rbfs()),
        (3, 0, 40)
    );
    let frames: Vec<i64> = bake.by_ref().map(|f| f.unwrap().frame).collect();
    assert_eq!(frames, vec![23, 24, 25]);
    let baked = bake.finish().unwrap();
    assert_eq!(baked.records.len(), 3);
    // The last frame closed the hash volume: every record has its share.
    assert!(baked.records.iter().all(|r| r.residual.hash_bytes > 0.0));
    let log = events.lock().unwrap();
    assert!(log.iter().filter(|e| e.starts_with("Fitting")).count() == 3);
    assert!(log.iter().any(|e| e == "Hashing"));
    drop(log);
    let report = baked.report(&plume());
    assert_eq!(report["totals"]["frames"], 3);

    // Interrupted after one frame (the journal keeps it), then resumed.
    let cut = dir.path().join("cut.haze");
    let mut first = Bake::new(options(&cut, false), |_: Event<'_>| {}).unwrap();
    first.next().unwrap().unwrap();
    drop(first);
    assert!(!cut.exists());
    let resumed = Bake::new(options(&cut, true), |_: Event<'_>| {}).unwrap();
    assert_eq!(resumed.finished(), 1);
    resumed.finish().unwrap();
    // Identical assets but for the header's timings, which are per run: compare blocks.
    let (a, b) = (
        haze_asset::Asset::open(&whole).unwrap(),
        haze_asset::Asset::open(&cut).unwrap(),
    );
    assert_eq!(a.entries().len(), b.entries().len());
    for i in 0..a.entries().len() {
        assert_eq!(
            a.block(i).unwrap().bytes,
            b.block(i).unwrap().bytes,
            "block {i}"
        );
    }

    // Frame 24 reconstructed within 1 % of its peak everywhere.
    let r = reconstruct_frame(&whole, 24).unwrap();
    let v = import::import(
        &plume().join("fluid_data_0024.vdb"),
        &ImportOptions::default(),
    )
    .unwrap();
    assert_eq!(r.dims, v.dims());
    let peak = v.data().iter().fold(0.0f32, |m, &d| m.max(d));
    let worst = r
        .data
        .iter()
        .zip(v.data())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    // The error asked for plus f32 rounding of D̃ + R̂ (6e-8 of the peak).
    assert!(
        worst <= 0.01 * peak * (1.0 + 1e-5),
        "worst {worst}, peak {peak}"
    );
    assert!(reconstruct_frame(&whole, 99).is_err());
}

/// Hash volumes closed by size rather than by count: with room for one frame each, the
/// three frames take three residual blocks, and every frame reconstructs exactly as from
/// one volume of three (the residual is quantized per frame; only its coding differs).
#[test]
fn volumes_closed_by_their_size_hold_the_same_frames() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one.haze");
    Bake::new(options(&one, false), |_: Event<'_>| {})
        .unwrap()
        .finish()
        .unwrap();
    let small = dir.path().join("small.haze");
    let tiny = BakeOptions {
        volume_bytes: 1,
        ..options(&small, false)
    };
    Bake::new(tiny, |_: Event<'_>| {})
        .unwrap()
        .finish()
        .unwrap();
    let residual_blocks = |p: &Path| {
        haze_asset::Asset::open(p)
            .unwrap()
            .entries()
            .iter()
            .filter(|e| e.kind == haze_asset::BlockKind::ResidualHash)
            .count()
    };
    assert_eq!((residual_blocks(&one), residual_blocks(&small)), (1, 3));
    for frame in 23..=25 {
        let (a, b) = (
            reconstruct_frame(&one, frame).unwrap(),
            reconstruct_frame(&small, frame).unwrap(),
        );
        assert_eq!(a.data, b.data, "frame {frame}");
    }
    // Several frames at once (a volume decoded frame after frame), in the asset's order or
    // not, a frame twice: each as one frame at a time gives it.
    for asset in [&one, &small] {
        for numbers in [
            &[23, 24, 25][..],
            &[24, 25],
            &[23, 25],
            &[25, 23, 24],
            &[24, 24],
        ] {
            let mut got = Vec::new();
            reconstruct_frames(asset, numbers, |n, r| {
                got.push((n, r.data));
                Ok(())
            })
            .unwrap();
            let want: Vec<(i64, Vec<f32>)> = numbers
                .iter()
                .map(|&n| (n, reconstruct_frame(asset, n).unwrap().data))
                .collect();
            assert_eq!(got, want, "{numbers:?}");
        }
    }
    assert!(reconstruct_frames(&one, &[23, 99], |_, _| Ok(())).is_err());
    // The RBFs alone, the residual not decoded: those of the whole frame.
    for frame in [Some(23), Some(25), None] {
        let want = read_frame(&small, frame).unwrap().rbfs;
        assert_eq!(read_rbfs(&small, frame).unwrap(), want, "{frame:?}");
        assert!(!want.is_empty());
    }
    let e = read_rbfs(&small, Some(99)).unwrap_err().to_string();
    assert!(e.contains("frame 99"), "{e}");
    let mut seen = 0;
    let stop = reconstruct_frames(&one, &[23, 24, 25], |_, _| {
        seen += 1;
        anyhow::ensure!(seen < 2, "the consumer's error");
        Ok(())
    });
    assert_eq!(
        (stop.unwrap_err().to_string(), seen),
        ("the consumer's error".into(), 2)
    );
}
