//! Context-modelled range coding of a residual group's quantized values (the residual
//! block's on-disk form, layout 4).
//!
//! The quantized residual is mostly noise around the RBFs' misfit, but not white: a value
//! is large where its neighbours are large, and shares their sign. So each value `v` is
//! coded with binary adaptive models chosen by its causal neighbours in the frame,
//! `a = v(x−1, y, z)`, `b = v(x, y−1, z)`, `c = v(x, y, z−1)` (0 where nothing is stored):
//!
//! - the *scale* context `k`, a half-octave bucket of `m = |a| + |b| + |c|` (`m` itself up
//!   to 3, then `2⌊log₂ m⌋ + ` the bit below the leading one, at most 15);
//! - the *past* context `t`, the class of the value at the same voxel in the frame before
//!   (the group's slot `j − 1`; 0 in a group's first frame): `|v'|` 0, 1, 2–3 or ≥ 4 —
//!   where the RBFs missed the smoke in one frame they often miss it in the next;
//! - `v = 0?` under `(t, k)`;
//! - the sign under the sign of `a + b + c` and a coarse `k` (0, 1–3, ≥ 4);
//! - `n = |v| ≥ 1` as an Elias-gamma code: `e = ⌊log₂ n⌋` in unary, each bit under
//!   `(t, k, bit index)`, then the `e` bits of `n` below its leading one, each under
//!   `(e, bit index)`.
//!
//! Every model is a [`haze_core::adaptive::Bit`] and the bits go through its range coder.
//! Values are visited brick by brick in the block's list order (frame by frame, bricks
//! ascending `z, y, x`) and inside a brick `x` fastest, so the three neighbours of a voxel
//! are always already decoded. Lossless (`f32`) frames are not coded here.

use haze_core::adaptive::{Bit, BitIo, BitReader, BitWriter};
use std::collections::HashMap;

/// Scale contexts.
const SCALES: usize = 16;
/// Classes of the value at the voxel in the frame before (0, 1, 2–3, ≥ 4 in magnitude).
const PAST: usize = 4;
/// Largest `⌊log₂ |v|⌋`: `|v| ≤ 2¹⁵ − 1`.
const MAX_EXP: usize = 15;

/// The adaptive models of one block.
struct Models {
    zero: [[Bit; SCALES]; PAST],
    sign: [Bit; 9],
    exponent: [[[Bit; MAX_EXP]; SCALES]; PAST],
    mantissa: [[Bit; MAX_EXP]; MAX_EXP + 1],
}

impl Models {
    fn new() -> Self {
        Models {
            zero: [[Bit::default(); SCALES]; PAST],
            sign: [Bit::default(); 9],
            exponent: [[[Bit::default(); MAX_EXP]; SCALES]; PAST],
            mantissa: [[Bit::default(); MAX_EXP]; MAX_EXP + 1],
        }
    }

    /// Codes one value under its neighbours `(a, b, c)` and the value `before` at its voxel
    /// in the frame before; `limit` is the largest `|v|`.
    fn value<I: BitIo>(
        &mut self,
        io: &mut I,
        v: i32,
        [a, b, c]: [i32; 3],
        before: i32,
        limit: u32,
    ) -> Result<i32, String> {
        let m = a.unsigned_abs() + b.unsigned_abs() + c.unsigned_abs();
        let k = scale(m);
        let t = match before.unsigned_abs() {
            0 => 0,
            1 => 1,
            2..=3 => 2,
            _ => 3,
        };
        if !io.code(&mut self.zero[t][k], v != 0)? {
            return Ok(0);
        }
        let s = (a + b + c).signum() + 1;
        let coarse = match k {
            0 => 0,
            1..=3 => 1,
            _ => 2,
        };
        let negative = io.code(&mut self.sign[3 * coarse + s as usize], v < 0)?;
        let n = v.unsigned_abs();
        let e = if n == 0 { 0 } else { n.ilog2() as usize };
        let mut got = 0;
        while got < MAX_EXP && io.code(&mut self.exponent[t][k][got], got < e)? {
            got += 1;
        }
        let mut magnitude = 1u32;
        for i in (0..got).rev() {
            let bit = io.code(&mut self.mantissa[got][i], (n >> i) & 1 == 1)?;
            magnitude = magnitude << 1 | u32::from(bit);
        }
        if magnitude > limit {
            return Err(format!(
                "a value of magnitude {magnitude} exceeds the block's {limit}"
            ));
        }
        Ok(if negative {
            -(magnitude as i32)
        } else {
            magnitude as i32
        })
    }
}

/// The scale context of `m = |a| + |b| + |c|`.
fn scale(m: u32) -> usize {
    if m < 4 {
        m as usize
    } else {
        let e = m.ilog2();
        ((2 * e + ((m >> (e - 1)) & 1)) as usize).min(SCALES - 1)
    }
}

/// Where the values of one frame's stored bricks live while they are coded: each brick's
/// first value in one flat list, by its place in the frame, so that a voxel's neighbours
/// are found in O(1). A map, not a table of the frame's bricks: its memory follows the
/// bricks a block holds, whatever dims a damaged block claims.
struct FrameBricks {
    /// Bricks per axis of the frame.
    nb: [u32; 3],
    brick: u32,
    /// The first value of each stored (and already coded) brick, by
    /// `bx + nb₀ (by + nb₁ bz)`.
    index: HashMap<u64, usize>,
}

impl FrameBricks {
    /// Room for a frame of `nb` bricks a side of `brick` voxels.
    fn new(nb: [u32; 3], brick: u32) -> Self {
        FrameBricks {
            nb,
            brick,
            index: HashMap::new(),
        }
    }

    /// Forgets every brick (the next frame begins).
    fn clear(&mut self) {
        self.index.clear();
    }

    fn slot(&self, b: [u32; 3]) -> u64 {
        let [x, y, z] = b.map(u64::from);
        x + u64::from(self.nb[0]) * (y + u64::from(self.nb[1]) * z)
    }

    /// Where the brick at brick position `p` starts in the frame's values, if it is
    /// stored (and already coded).
    fn first(&self, p: [u32; 3]) -> Option<usize> {
        self.index.get(&self.slot(p)).copied()
    }
}

/// One frame's coded bricks and their values.
struct Frame {
    bricks: FrameBricks,
    values: Vec<i32>,
}

impl Frame {
    fn clear(&mut self) {
        self.bricks.clear();
        self.values.clear();
    }
}

/// The coder's state: its models, the frame being coded and the frame before it.
struct Coding {
    models: Models,
    now: Frame,
    before: Frame,
    current: Option<usize>,
    limit: u32,
}

impl Coding {
    fn new(nb: [u32; 3], b: u32, limit: u32) -> Self {
        let frame = || Frame {
            bricks: FrameBricks::new(nb, b),
            values: Vec::new(),
        };
        Coding {
            models: Models::new(),
            now: frame(),
            before: frame(),
            current: None,
            limit,
        }
    }

    /// Codes (`given`) or decodes the values of the brick at brick position `at` of frame
    /// slot `j`; returns where its values start in the frame's list.
    fn brick<I: BitIo>(
        &mut self,
        io: &mut I,
        j: usize,
        at: [u32; 3],
        given: Option<&[i32]>,
    ) -> Result<usize, String> {
        if self.current != Some(j) {
            // The frame before is the one just coded only if it is slot j − 1.
            if self.current.is_some_and(|c| c + 1 == j) {
                std::mem::swap(&mut self.now, &mut self.before);
            } else {
                self.before.clear();
            }
            self.now.clear();
            self.current = Some(j);
        }
        let b = self.now.bricks.brick as usize;
        let (bb, per) = (b * b, b * b * b);
        let first = self.now.values.len();
        let slot = self.now.bricks.slot(at);
        self.now.bricks.index.insert(slot, first);
        self.now.values.resize(first + per, 0);
        // The bricks before this one along each axis, and this brick in the frame before.
        let side = |axis: usize| {
            let mut p = at;
            if p[axis] == 0 {
                return None;
            }
            p[axis] -= 1;
            self.now.bricks.first(p)
        };
        let sides = [side(0), side(1), side(2)];
        let past = self.before.bricks.first(at);
        let values = &mut self.now.values;
        for l in 0..per {
            let local = [l % b, (l / b) % b, l / bb];
            // A neighbour inside the brick, else in the brick before along its axis (at
            // the far face: b − 1 along that axis).
            let n = [(0, 1), (1, b), (2, bb)].map(|(axis, stride)| {
                if local[axis] > 0 {
                    values[first + l - stride]
                } else {
                    sides[axis].map_or(0, |f| values[f + l + stride * (b - 1)])
                }
            });
            let before = past.map_or(0, |f| self.before.values[f + l]);
            let v = given.map_or(0, |g| g[l]);
            values[first + l] = self.models.value(io, v, n, before, self.limit)?;
        }
        Ok(first)
    }
}

/// Encodes bricks into `io`: for each, its frame slot `j`, its brick position in that
/// frame and its `b³` values (`x` fastest), in coding order. `nb` is the frame's bricks
/// per axis and `limit` the largest magnitude a value may have.
pub fn encode(
    io: &mut BitWriter,
    nb: [u32; 3],
    b: u32,
    limit: u32,
    bricks: &[(usize, [u32; 3], &[i32])],
) -> Result<(), String> {
    let mut coding = Coding::new(nb, b, limit);
    for &(j, at, given) in bricks {
        coding.brick(io, j, at, Some(given))?;
    }
    Ok(())
}

/// Decodes from `io` what [`encode`] wrote for bricks at `(frame slot, brick position)`,
/// in the same order: each brick's `b³` values.
pub fn decode(
    io: &mut BitReader,
    nb: [u32; 3],
    b: u32,
    limit: u32,
    bricks: &[(usize, [u32; 3])],
) -> Result<Vec<Vec<i32>>, String> {
    let mut coding = Coding::new(nb, b, limit);
    let per = (b * b * b) as usize;
    let mut out = Vec::with_capacity(bricks.len());
    for &(j, at) in bricks {
        let first = coding.brick(io, j, at, None)?;
        out.push(coding.now.values[first..first + per].to_vec());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn coded(nb: [u32; 3], b: u32, limit: u32, list: &[(usize, [u32; 3], &[i32])]) -> Vec<u8> {
        let mut io = BitWriter::new();
        encode(&mut io, nb, b, limit, list).unwrap();
        io.finish().unwrap()
    }

    fn decoded(
        bytes: &[u8],
        nb: [u32; 3],
        b: u32,
        limit: u32,
        stored: &[(usize, [u32; 3])],
    ) -> Result<Vec<Vec<i32>>, String> {
        decode(&mut BitReader::new(bytes).unwrap(), nb, b, limit, stored)
    }

    /// Every brick of a frame of `nb` bricks a side `b`, in coding order, with the values
    /// `value(voxel)` at their voxels.
    fn every_brick(
        nb: [u32; 3],
        b: u32,
        value: impl Fn([u32; 3]) -> i32,
    ) -> (Vec<[u32; 3]>, Vec<Vec<i32>>) {
        let mut stored = Vec::new();
        let mut given = Vec::new();
        for bz in 0..nb[2] {
            for by in 0..nb[1] {
                for bx in 0..nb[0] {
                    let at = [bx, by, bz];
                    stored.push(at);
                    given.push(
                        (0..b * b * b)
                            .map(|l| {
                                let loc = [l % b, (l / b) % b, l / (b * b)];
                                value([0, 1, 2].map(|i| at[i] * b + loc[i]))
                            })
                            .collect(),
                    );
                }
            }
        }
        (stored, given)
    }

    /// A brick pattern with smooth and noisy parts, zeros, both signs and the extremes.
    fn values(b: u32, seed: i32, limit: u32) -> Vec<i32> {
        (0..(b * b * b) as i32)
            .map(|l| match (l + seed) % 7 {
                0 => 0,
                1 => limit as i32,
                2 => -(limit as i32),
                3 => (l * 37 + seed) % 9 - 4,
                _ => (l % 3) - 1,
            })
            .collect()
    }

    #[test]
    fn bricks_round_trip_over_frames() {
        let (nb, b, limit) = ([3, 2, 2], 4, 127);
        let stored = [
            (0, [0, 0, 0]),
            (0, [1, 0, 0]),
            (0, [0, 1, 0]),
            (0, [2, 1, 1]),
            (2, [1, 1, 0]),
            (2, [2, 1, 0]),
        ];
        let given: Vec<Vec<i32>> = (0..stored.len())
            .map(|i| values(b, i as i32, limit))
            .collect();
        let list: Vec<(usize, [u32; 3], &[i32])> = stored
            .iter()
            .zip(&given)
            .map(|(&(j, at), v)| (j, at, v.as_slice()))
            .collect();
        let bytes = coded(nb, b, limit, &list);
        assert_eq!(decoded(&bytes, nb, b, limit, &stored).unwrap(), given);
        // A limit below the largest value is caught on decode.
        assert!(
            decoded(&bytes, nb, b, 100, &stored)
                .unwrap_err()
                .contains("exceeds")
        );
    }

    #[test]
    fn the_widest_values_round_trip() {
        let limit = (1 << 15) - 1;
        let given = vec![vec![
            limit as i32,
            -(limit as i32),
            1,
            -1,
            0,
            32768 / 3,
            -5,
            2,
        ]];
        let list = [(0, [0, 0, 0], given[0].as_slice())];
        let bytes = coded([1, 1, 1], 2, limit, &list);
        assert_eq!(
            decoded(&bytes, [1, 1, 1], 2, limit, &[(0, [0, 0, 0])]).unwrap(),
            given
        );
    }

    #[test]
    fn correlated_values_cost_less_than_their_order_zero_entropy() {
        // A smooth field of large values (the neighbours predict the scale and the sign):
        // the coder must beat the values' order-0 entropy, computed here by counting.
        let (b, nb) = (4u32, [4u32, 4, 4]);
        let field = |p: [u32; 3]| {
            let s = (p[0] as f64 * 0.4).sin() + (p[1] as f64 * 0.3).cos() + p[2] as f64 * 0.05;
            (s * 30.0).round() as i32
        };
        let (at, given) = every_brick(nb, b, field);
        let stored: Vec<(usize, [u32; 3])> = at.into_iter().map(|at| (0, at)).collect();
        let list: Vec<_> = stored
            .iter()
            .zip(&given)
            .map(|(&(j, at), v)| (j, at, v.as_slice()))
            .collect();
        let bytes = coded(nb, b, 127, &list);
        assert_eq!(decoded(&bytes, nb, b, 127, &stored).unwrap(), given);
        let all: Vec<i32> = given.concat();
        let mut counts = std::collections::HashMap::new();
        for v in &all {
            *counts.entry(*v).or_insert(0usize) += 1;
        }
        let n = all.len() as f64;
        let h0: f64 = counts
            .values()
            .map(|&c| -(c as f64 / n) * (c as f64 / n).log2())
            .sum();
        let bits = 8.0 * bytes.len() as f64 / n;
        assert!(bits < h0, "{bits:.2} bits a value against H0 {h0:.2}");
    }

    /// A frame like the one before it codes smaller after it (slot j − 1) than after a
    /// frame two slots away, which gives it no past.
    #[test]
    fn the_frame_before_is_a_context() {
        let (nb, b, limit) = ([4, 4, 2], 4, 127);
        // Sparse values whose zeros and sizes the neighbours do not predict.
        let noise = |i: u32| {
            let h = i.wrapping_mul(2_654_435_761) >> 20;
            match h % 5 {
                0 | 1 => 0,
                2 => (h % 60) as i32 - 30,
                _ => (h % 3) as i32 - 1,
            }
        };
        let (stored, given) = every_brick(nb, b, |p| noise(p[0] + 16 * (p[1] + 16 * p[2])));
        let size = |second: usize| {
            let list: Vec<(usize, [u32; 3], &[i32])> = [0, second]
                .iter()
                .flat_map(|&j| {
                    stored
                        .iter()
                        .zip(&given)
                        .map(move |(&at, v)| (j, at, v.as_slice()))
                })
                .collect();
            let bytes = coded(nb, b, limit, &list);
            let where_: Vec<(usize, [u32; 3])> = list.iter().map(|&(j, at, _)| (j, at)).collect();
            let back = decoded(&bytes, nb, b, limit, &where_).unwrap();
            assert_eq!(
                back,
                list.iter().map(|(_, _, v)| v.to_vec()).collect::<Vec<_>>()
            );
            bytes.len()
        };
        let (next, apart) = (size(1), size(2));
        assert!(
            (next as f64) < 0.9 * apart as f64,
            "{next} bytes after the frame before, {apart} after a frame two slots away"
        );
    }

    #[test]
    fn scale_buckets_are_half_octaves() {
        let got: Vec<usize> = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 191, 192, 100_000]
            .iter()
            .map(|&m| scale(m))
            .collect();
        assert_eq!(got, [0, 1, 2, 3, 4, 4, 5, 5, 6, 7, 8, 14, 15, 15]);
    }
}
