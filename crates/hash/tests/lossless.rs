//! Exactness of the perfect spatial hash over every cell of its domain, and of the bricked
//! residual groups over every voxel of their frames.

use haze_hash::tile::{BRICK_SIDES, GROUP, GroupBuilder, ResidualGroup, tile_origin};
use haze_hash::{BuildOptions, HashError, PerfectHash, QuantOptions, quantize};
use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// A random set of `k` distinct cells of `domain` with random payloads.
fn random_cells(domain: [u32; 3], k: usize, seed: u64) -> Vec<([u32; 3], u32)> {
    let n = (domain[0] * domain[1] * domain[2]) as usize;
    let mut idx: Vec<usize> = (0..n).collect();
    let mut rng = Pcg64::seed_from_u64(seed);
    idx.shuffle(&mut rng);
    idx.truncate(k);
    idx.iter()
        .map(|&i| {
            let i = i as u32;
            let p = [
                i % domain[0],
                (i / domain[0]) % domain[1],
                i / (domain[0] * domain[1]),
            ];
            (p, rng.random::<u32>() >> 1)
        })
        .collect()
}

fn check_every_cell(domain: [u32; 3], cells: &[([u32; 3], u32)]) -> PerfectHash {
    let h = PerfectHash::build(domain, cells, BuildOptions::default()).unwrap();
    let mut dense = vec![None; (domain[0] * domain[1] * domain[2]) as usize];
    for (p, v) in cells {
        dense[(p[0] + domain[0] * (p[1] + domain[1] * p[2])) as usize] = Some(*v);
    }
    for z in 0..domain[2] {
        for y in 0..domain[1] {
            for x in 0..domain[0] {
                let want = dense[(x + domain[0] * (y + domain[1] * z)) as usize];
                assert_eq!(h.get([x, y, z]), want, "cell ({x}, {y}, {z}) of {domain:?}");
            }
        }
    }
    // Outside the domain: nothing.
    assert_eq!(h.get(domain), None);
    assert_eq!(h.get([u32::MAX, 0, 0]), None);
    assert_eq!(h.len(), cells.len());
    h
}

#[test]
fn every_cell_looks_up_its_value_or_zero() {
    for domain in [[16, 16, 16], [7, 31, 12], [1, 1, 50], [40, 3, 9]] {
        let n = (domain[0] * domain[1] * domain[2]) as usize;
        for (k, seed) in [(0, 1), (1, 2), (5, 3), (n / 2, 4), (n, 5)] {
            let cells = random_cells(domain, k, seed);
            let h = check_every_cell(domain, &cells);
            // The table is as small as a perfect hash can be: m̄³ ≥ K with m̄ minimal.
            assert!(u64::from(h.m).pow(3) >= k as u64);
            assert!(h.m == 1 || u64::from(h.m - 1).pow(3) < k as u64);
        }
    }
}

#[test]
fn too_dense_inputs_fail_cleanly_within_the_budget() {
    let domain = [40, 40, 40];
    let cells = random_cells(domain, 8000, 9);
    let tight = BuildOptions {
        max_attempts: 2,
        tries_per_bucket: 1,
    };
    let Err(e) = PerfectHash::build(domain, &cells, tight) else {
        panic!("a full table with one try per bucket was built");
    };
    assert!(
        matches!(
            e,
            HashError::TooDense {
                cells: 8000,
                attempts: 2,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("too dense to hash"));
    // The default budget builds it.
    assert!(PerfectHash::build(domain, &cells, BuildOptions::default()).is_ok());
    // Bad inputs.
    assert!(PerfectHash::build(domain, &[([40, 0, 0], 1)], BuildOptions::default()).is_err());
    assert!(PerfectHash::build([4096, 4096, 4096], &[], BuildOptions::default()).is_err());
}

#[test]
fn groups_tile_27_frames_and_look_each_voxel_up_within_the_error() {
    // Odd sizes: bricks of 2, 4 and 8 reach past the frame's edge on some axes.
    let dims = [6, 5, 9];
    let n = (dims[0] * dims[1] * dims[2]) as usize;
    let error = 0.01;
    let mut frames = Vec::new();
    let mut truth = Vec::new();
    for j in 0..GROUP {
        let r: Vec<f32> = (0..n)
            .map(|i| {
                if (i * 7 + j) % 5 == 0 {
                    ((i + j) as f32 * 0.1).sin()
                } else {
                    0.0
                }
            })
            .collect();
        // Every third frame lossless, to mix widths in one block.
        let e = if j % 3 == 2 { 0.0 } else { error };
        frames.push(quantize(&r, 1.0, QuantOptions { error: e, bits: 8 }).unwrap());
        truth.push(r);
    }
    assert_eq!(tile_origin(26, dims), [12, 10, 18]);
    for brick in BRICK_SIDES {
        let g = ResidualGroup::build(dims, brick, &frames, BuildOptions::default()).unwrap();
        let g = haze_hash::block::decode(&haze_hash::block::encode(&g).unwrap()).unwrap();
        // A frame past the group's: zeros, as `lookup` gives.
        assert!(g.dense(frames.len()).iter().all(|v| *v == 0.0));
        for (j, (f, r)) in frames.iter().zip(&truth).enumerate() {
            let dense = g.dense(j);
            assert_eq!(dense.len(), r.len());
            for z in 0..dims[2] {
                for y in 0..dims[1] {
                    for x in 0..dims[0] {
                        let i = (x + dims[0] * (y + dims[1] * z)) as usize;
                        let got = g.lookup(j, [x, y, z]);
                        assert_eq!(got.to_bits(), dense[i].to_bits(), "dense, voxel {i}");
                        if f.lossless {
                            assert_eq!(got, r[i], "brick {brick} frame {j} voxel {i}");
                        } else {
                            // The error asked for; f32(q)·step is rounded once (6e-8 relative).
                            assert!(
                                f64::from((got - r[i]).abs()) <= error + 1e-7,
                                "brick {brick} frame {j} voxel {i}"
                            );
                        }
                    }
                }
            }
        }
        assert_eq!(g.lookup(27, [0, 0, 0]), 0.0);
        assert_eq!(g.lookup(0, [6, 0, 0]), 0.0);
    }
    // A partial group keeps the layout.
    let part = ResidualGroup::build(dims, 4, &frames[..4], BuildOptions::default()).unwrap();
    assert_eq!(part.frames(), 4);
    assert!(ResidualGroup::build(dims, 4, &[], BuildOptions::default()).is_err());
    assert!(ResidualGroup::build(dims, 3, &frames[..1], BuildOptions::default()).is_err());
}

#[test]
fn one_voxel_and_empty_frames_cost_what_they_hold() {
    let dims = [9, 9, 9];
    let mut r = vec![0.0f32; 729];
    let opts = QuantOptions {
        error: 1.0 / 255.0,
        bits: 8,
    };
    let empty = quantize(&r, 1.0, opts).unwrap();
    // One non-zero voxel in the last (partial) brick, on the domain's far corner.
    r[728] = 0.5;
    let one = quantize(&r, 1.0, opts).unwrap();
    let g = ResidualGroup::build(dims, 4, &[empty.clone(), one], BuildOptions::default()).unwrap();
    assert_eq!((g.bricks_of(0), g.bricks_of(1)), (0, 1));
    // 64 values of 8 bits (0.5 / (2/255) = 64 steps): 16 words, all in frame 1.
    assert_eq!((g.words_of(0), g.words_of(1), g.data.len()), (0, 16, 16));
    assert!((g.lookup(1, [8, 8, 8]) - 0.5).abs() <= 1.0 / 255.0);
    assert_eq!(g.lookup(1, [7, 8, 8]), 0.0);
    assert_eq!(g.lookup(0, [8, 8, 8]), 0.0);
    let none = ResidualGroup::build(dims, 4, &[empty], BuildOptions::default()).unwrap();
    assert_eq!(none.data.len(), 0);
}

/// A volume filled a frame at a time (as a bake fills it, letting each frame's cells go)
/// counts its frames and whether any brick is stored, and refuses a 28th frame, frames
/// of other widths, an empty finish and frames it cannot tile, with a message.
#[test]
fn a_volume_filled_frame_by_frame_refuses_what_it_cannot_hold() {
    let dims = [9, 9, 9];
    let opts = |bits| QuantOptions {
        error: 1.0 / 255.0,
        bits,
    };
    let mut r = vec![0.0f32; 729];
    let empty = quantize(&r, 1.0, opts(8)).unwrap();
    r[3] = 0.5;
    let one = quantize(&r, 1.0, opts(8)).unwrap();
    let wider = quantize(&r, 1.0, opts(12)).unwrap();

    let mut b = GroupBuilder::new(dims, 4).unwrap();
    assert!(b.is_empty() && b.frames() == 0);
    b.push(&empty).unwrap();
    assert!(b.is_empty() && b.frames() == 1);
    b.push(&one).unwrap();
    assert!(!b.is_empty());
    for _ in 2..GROUP {
        b.push(&empty).unwrap();
    }
    assert_eq!(b.frames(), GROUP);
    let err = b.push(&empty).unwrap_err().to_string();
    assert!(err.contains("1 to 27 frames, not 28"), "{err}");
    let g = b.finish(BuildOptions::default()).unwrap();
    assert_eq!((g.frames(), g.bricks_of(1), g.words_of(1)), (GROUP, 1, 16));
    assert!((g.lookup(1, [3, 0, 0]) - 0.5).abs() <= 1.0 / 255.0);

    let mut b = GroupBuilder::new(dims, 4).unwrap();
    b.push(&one).unwrap();
    let err = b.push(&wider).unwrap_err().to_string();
    assert!(err.contains("differ in bits"), "{err}");
    let err = GroupBuilder::new(dims, 4)
        .unwrap()
        .finish(BuildOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("not 0"), "{err}");
    assert!(GroupBuilder::new(dims, 3).is_err());
    assert!(GroupBuilder::new([0, 9, 9], 4).is_err());
    assert!(GroupBuilder::new([u32::MAX, 9, 9], 4).is_err());
}

/// A filling volume's decoded size, as the bake closes volumes by it: never above the
/// built volume's tables and within the offset table's share (at most a fifth of a word a
/// brick more, as the build may widen it) below; room for another frame while one more of
/// the mean size fits the limit and fewer than 27 frames are held, always for a first.
#[test]
fn a_filling_volume_knows_its_decoded_size() {
    let dims = [24, 20, 28];
    let n = (dims[0] * dims[1] * dims[2]) as usize;
    let opts = QuantOptions {
        error: 1.0 / 255.0,
        bits: 8,
    };
    let mut rng = Pcg64::seed_from_u64(7);
    let mut b = GroupBuilder::new(dims, 4).unwrap();
    assert!(b.has_room(0));
    let mut frames = Vec::new();
    for _ in 0..5 {
        let r: Vec<f32> = (0..n)
            .map(|_| {
                let u: f64 = rng.random();
                if u < 0.3 { (u * 2.0) as f32 } else { 0.0 }
            })
            .collect();
        let q = quantize(&r, 1.0, opts).unwrap();
        b.push(&q).unwrap();
        frames.push(q);
    }
    let estimate = b.decoded_bytes();
    let mean = estimate / 5;
    assert!(b.has_room(estimate + mean) && !b.has_room(estimate + mean - 1));
    let g = b.finish(BuildOptions::default()).unwrap();
    let bricks = g.hash.keys.iter().filter(|&&k| k != 0).count();
    let actual = g.bytes();
    assert!(
        estimate <= actual && actual - estimate <= 4 * bricks,
        "estimate {estimate}, built {actual}, {bricks} bricks"
    );
    let mut full = GroupBuilder::new(dims, 4).unwrap();
    for _ in 0..GROUP {
        full.push(&frames[0]).unwrap();
    }
    assert!(!full.has_room(usize::MAX));
}
