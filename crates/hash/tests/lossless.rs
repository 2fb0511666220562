//! Exactness of the perfect spatial hash over every cell of its domain, and the
//! quantization bound on a real baked frame.

use haze_hash::tile::{GROUP, ResidualGroup, tile_origin};
use haze_hash::{BuildOptions, HashError, PerfectHash, quantize};

/// Deterministic pseudo-random numbers.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
}

/// A random set of `k` distinct cells of `domain` with non-zero values.
fn random_cells(domain: [u32; 3], k: usize, seed: u64) -> Vec<([u32; 3], i16)> {
    let n = (domain[0] * domain[1] * domain[2]) as usize;
    let mut idx: Vec<usize> = (0..n).collect();
    let mut rng = Lcg(seed);
    for i in (1..n).rev() {
        idx.swap(i, (rng.next() as usize) % (i + 1));
    }
    idx.truncate(k);
    idx.iter()
        .map(|&i| {
            let i = i as u32;
            let p = [
                i % domain[0],
                (i / domain[0]) % domain[1],
                i / (domain[0] * domain[1]),
            ];
            let v = (rng.next() % 255) as i16 - 127;
            (p, if v == 0 { 1 } else { v })
        })
        .collect()
}

fn check_every_cell(domain: [u32; 3], cells: &[([u32; 3], i16)]) -> PerfectHash {
    let h = PerfectHash::build(domain, cells, BuildOptions::default()).unwrap();
    let mut dense = vec![0i16; (domain[0] * domain[1] * domain[2]) as usize];
    for (p, v) in cells {
        dense[(p[0] + domain[0] * (p[1] + domain[1] * p[2])) as usize] = *v;
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
    assert_eq!(h.get(domain), 0);
    assert_eq!(h.get([u32::MAX, 0, 0]), 0);
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
fn groups_tile_27_frames_and_look_each_up_exactly() {
    let dims = [6, 5, 4];
    let n = (dims[0] * dims[1] * dims[2]) as usize;
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
        frames.push(quantize(&r, 8).unwrap());
        truth.push(r);
    }
    let g = ResidualGroup::build(dims, &frames, BuildOptions::default()).unwrap();
    assert_eq!(tile_origin(26, dims), [12, 10, 8]);
    for (j, (f, r)) in frames.iter().zip(&truth).enumerate() {
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let i = (x + dims[0] * (y + dims[1] * z)) as usize;
                    let got = g.lookup(j, [x, y, z]);
                    assert!(
                        (got - r[i]).abs() <= 0.5 * f.step * 1.000001,
                        "frame {j} voxel {i}"
                    );
                }
            }
        }
    }
    assert_eq!(g.lookup(27, [0, 0, 0]), 0.0);
    assert_eq!(g.lookup(0, [6, 0, 0]), 0.0);
    // A partial group keeps the layout.
    let part = ResidualGroup::build(dims, &frames[..4], BuildOptions::default()).unwrap();
    assert_eq!(part.frames(), 4);
    assert!(ResidualGroup::build(dims, &[], BuildOptions::default()).is_err());
}
