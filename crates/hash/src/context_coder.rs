//! Context-mixed range coding of a residual group's quantized values (the residual
//! block's on-disk form, layouts 5 to 7).
//!
//! The quantized residual is mostly noise around the RBFs' misfit, but not white: a value
//! is large where its neighbours are large, and shares their sign. So each value `v` is
//! coded bit by bit, each bit predicted from its causal neighbourhood in the frame,
//! `a = v(x−1, y, z)`, `b = v(x, y−1, z)`, `c = v(x, y, z−1)` and six further neighbours
//! ([`WIDE`]; 0 where nothing is stored or not yet coded), and from the frame before:
//!
//! - the *scale* `k`, a half-octave bucket of `m = |a| + |b| + |c|` (`m` itself up to 3,
//!   then `2⌊log₂ m⌋ + ` the bit below the leading one, at most 15);
//! - the *shape*, `(min(|a|, 3), min(|b|, 3), min(|c|, 3))`: which neighbour is large;
//! - the *wide scale*, the same bucket of the six further neighbours' summed magnitude;
//! - the *past* `t`, the class of the value at the same voxel in the frame before (the
//!   group's slot `j − 1`; 0 in a group's first frame): `|v'|` 0, 1, 2–3 or ≥ 4 — where the
//!   RBFs missed the smoke in one frame they often miss it in the next.
//!
//! **Layout 7** ([`Binarization::Pivot`]) codes the value's class `c = 1 + ⌊log₂|v|⌋`
//! (0 for `v = 0`) as answers to `c > g?` from the pivot `c₀ = ⌊(k − 1)/2⌋`, the class of
//! a value whose three neighbours are about its size (`m ≈ 3|v|`, so `k ≈ 2 log₂ 3|v|`):
//! `c > c₀ − 1?`, then up or down one class at a time until the answer turns. Each answer
//! has three adaptive predictions, under `(t, k)`, `(t, shape)` and `(t, k, wide scale)`,
//! each with `g`, mixed by weights chosen by `(k, g)`. Then the sign (below), then the bit of
//! `|v|` below its leading one under the mantissa's two models, and the rest of `|v|`'s
//! bits as equally likely: they hold almost a bit each, and a model's bit costs a mix. On
//! held-out turbulent smoke a value takes 3.8 mixed bits instead of 6.4, for the same
//! bytes within 0.2 % (BENCHMARKS.md, "Range decoding without a division").
//!
//! **Layouts 5 and 6** ([`Binarization::Gamma`]) code the bits `v = 0?`, then the sign,
//! then `n = |v| ≥ 1` as an Elias-gamma code (`e = ⌊log₂ n⌋` in unary, then the `e` bits
//! of `n` below its leading one). Each bit of
//! `v = 0?` and of the unary `e` has three adaptive predictions, under `(t, k)`,
//! `(t, shape)` and `(t, k, wide scale)` (and the bit's index), mixed in the logistic
//! domain by weights chosen by `(t, k)` for `v = 0?` and by `(k, index)` for `e`
//! ([`haze_core::mixing`]). The sign has two, under the sign of `a + b + c` and under the
//! signs of `a`, `b`, `c` apart (both with a coarse `k`: 0, 1–3, ≥ 4); a mantissa bit two,
//! under `(e, index)` and `(e, index, k)`. On held-out frames this codes the values in
//! 3–5 % fewer bytes than one context per bit (BENCHMARKS.md, "Against established
//! compressors").
//!
//! The mixed probabilities go through [`haze_core::adaptive`]'s range coder. Values are
//! visited brick by brick in the block's list order (frame by frame, bricks ascending
//! `z, y, x`) and inside a brick `x` fastest, so every neighbour used is decoded before the
//! voxel or counts as 0 on both sides. Lossless (`f32`) frames are not coded here.

use haze_core::adaptive::{BitIo, BitReader, BitWriter};
use haze_core::mixing::{Counter, Mixer, PAD, table};

/// How a value's magnitude is turned into bits: the block's layout chooses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binarization {
    /// Layouts 5 and 6: `v = 0?`, then `e = ⌊log₂|v|⌋` in unary from 0, then every bit of
    /// `|v|` below its leading one under mixed models.
    Gamma,
    /// Layout 7: the class `c = 1 + ⌊log₂|v|⌋` (0 for `v = 0`) stepped to from the scale
    /// context's likeliest class, the highest bit below the leading one under mixed
    /// models, the others as equally likely bits (module docs).
    Pivot,
}

/// Scale contexts.
const SCALES: usize = 16;
/// Magnitude classes `c = 1 + ⌊log₂|v|⌋` (0 for `v = 0`): `|v| ≤ 2¹⁵ − 1` gives `c ≤ 15`.
/// Also the slots of a class step, the question `c > g` for `g` in `0..15` (with the
/// scale context, which fixes the pivot, `g` also tells whether the step is up or down).
const CLASSES: usize = 16;
/// Classes of the value at the voxel in the frame before (0, 1, 2–3, ≥ 4 in magnitude).
const PAST: usize = 4;
/// Largest `⌊log₂ |v|⌋`: `|v| ≤ 2¹⁵ − 1`.
const MAX_EXP: usize = 15;
/// Shapes of the three neighbours' magnitudes, each `min(|·|, 3)`.
const SHAPES: usize = 64;
/// The six further causal neighbours, offsets `(x, y, z)` from the voxel: the two beside
/// `b` along `x`, and four around `c`.
const WIDE: [[isize; 3]; 6] = [
    [-1, -1, 0],
    [1, -1, 0],
    [-1, 0, -1],
    [0, -1, -1],
    [1, 0, -1],
    [0, 1, -1],
];

/// A value's contexts, from its causal neighbourhood in the frame and the frame before.
#[derive(Clone, Copy, Debug)]
struct Context {
    /// The past class `t`.
    t: usize,
    /// The scale bucket `k` of `|a| + |b| + |c|`.
    k: usize,
    /// The shape `s` of `(|a|, |b|, |c|)`.
    shape: usize,
    /// The scale bucket `w` of the six further neighbours' summed magnitude.
    wide: usize,
    /// The sign of `a + b + c` (0, 1, 2 for −, 0, +) and the signs of `a`, `b`, `c` alone.
    sum_sign: usize,
    signs: usize,
}

impl Context {
    fn new([a, b, c]: [i32; 3], wide: u32, before: i32) -> Context {
        let m = a.unsigned_abs() + b.unsigned_abs() + c.unsigned_abs();
        let level = |v: i32| v.unsigned_abs().min(3) as usize;
        let sign = |v: i32| (v.signum() + 1) as usize;
        Context {
            t: match before.unsigned_abs() {
                0 => 0,
                1 => 1,
                2..=3 => 2,
                _ => 3,
            },
            k: scale(m),
            shape: level(a) + 4 * level(b) + 16 * level(c),
            wide: scale(wide),
            sum_sign: sign(a + b + c),
            signs: sign(a) + 3 * sign(b) + 9 * sign(c),
        }
    }

    /// The coarse scale the sign's models are chosen by.
    fn coarse(&self) -> usize {
        match self.k {
            0 => 0,
            1..=3 => 1,
            _ => 2,
        }
    }
}

/// The adaptive models of one block: three predictions of each magnitude bit (by the
/// past and the scale, by the past and the shape, by the past, the scale and the wide
/// scale), two of each sign and each mantissa bit, mixed per bit.
struct Models {
    binarization: Binarization,
    zero: [Vec<Counter>; 3],
    exponent: [Vec<Counter>; 3],
    magnitude_mix: Mixer<3>,
    class: [Vec<Counter>; 3],
    class_mix: Mixer<3>,
    sign: [Vec<Counter>; 2],
    sign_mix: Mixer<2>,
    mantissa: [Vec<Counter>; 2],
    mantissa_mix: Mixer<2>,
}

impl Models {
    fn new(binarization: Binarization) -> Self {
        let counters = |n: usize| table(n, Counter::default());
        let by_context = |per: usize| {
            [
                counters(PAST * SCALES * per),
                counters(PAST * SHAPES * per),
                counters(PAST * SCALES * SCALES * per),
            ]
        };
        // Only the chosen binarization's tables take room.
        let (gamma, pivot) = match binarization {
            Binarization::Gamma => (1, 0),
            Binarization::Pivot => (0, 1),
        };
        Models {
            binarization,
            zero: by_context(gamma),
            exponent: by_context(gamma * MAX_EXP),
            // One weight set per (past, scale) for `v = 0?`, then per (scale, bit index).
            magnitude_mix: Mixer::new(gamma * (PAST * SCALES + SCALES * MAX_EXP)),
            class: by_context(pivot * CLASSES),
            // One weight set per (scale, step).
            class_mix: Mixer::new(pivot * SCALES * CLASSES),
            sign: [counters(9), counters(3 * 27)],
            sign_mix: Mixer::new(3),
            mantissa: [
                counters((MAX_EXP + 1) * MAX_EXP),
                counters((MAX_EXP + 1) * MAX_EXP * SCALES),
            ],
            mantissa_mix: Mixer::new((MAX_EXP + 1) * MAX_EXP),
        }
    }

    /// Codes one magnitude bit: `v = 0?` (`bit_index` None) or the exponent's unary bit
    /// `g`, under the three contexts of `x`.
    fn magnitude<I: BitIo>(
        &mut self,
        io: &mut I,
        x: &Context,
        bit_index: Option<usize>,
        bit: bool,
    ) -> Result<bool, String> {
        let (per, g, set) = match bit_index {
            None => (1, 0, x.t * SCALES + x.k),
            Some(g) => (MAX_EXP, g, PAST * SCALES + x.k * MAX_EXP + g),
        };
        let slots = [
            (x.t * SCALES + x.k) * per + g,
            (x.t * SHAPES + x.shape) * per + g,
            ((x.t * SCALES + x.k) * SCALES + x.wide) * per + g,
        ];
        let tables = if bit_index.is_none() {
            &mut self.zero
        } else {
            &mut self.exponent
        };
        let [t0, t1, t2] = tables;
        self.magnitude_mix.code(
            io,
            set,
            [&mut t0[slots[0]], &mut t1[slots[1]], &mut t2[slots[2]]],
            bit,
        )
    }

    /// Codes one answer to `c > g` under the three contexts of `x`. Inlined, as
    /// [`Mixer::code`] is, into the loop over a brick's values.
    #[inline(always)]
    fn class_step<I: BitIo>(
        &mut self,
        io: &mut I,
        x: &Context,
        g: usize,
        answer: bool,
    ) -> Result<bool, String> {
        let [t0, t1, t2] = &mut self.class;
        self.class_mix.code(
            io,
            x.k * CLASSES + g,
            [
                &mut t0[(x.t * SCALES + x.k) * CLASSES + g],
                &mut t1[(x.t * SHAPES + x.shape) * CLASSES + g],
                &mut t2[((x.t * SCALES + x.k) * SCALES + x.wide) * CLASSES + g],
            ],
            answer,
        )
    }

    /// Codes the class `c` of a value (a reader: returns it) from the pivot `c₀` of its
    /// scale context: `c > c₀ − 1?` (not asked at `c₀ = 0`), then up, `c > c₀?`,
    /// `c > c₀ + 1?`, … until a no or `c = 15`; or down, `c > c₀ − 2?`, … until a yes or
    /// `c = 0`.
    fn class<I: BitIo>(&mut self, io: &mut I, x: &Context, c: usize) -> Result<usize, String> {
        let c0 = pivot(x.k);
        if c0 == 0 || self.class_step(io, x, c0 - 1, c >= c0)? {
            let mut g = c0;
            while g + 1 < CLASSES && self.class_step(io, x, g, c > g)? {
                g += 1;
            }
            Ok(g)
        } else {
            let mut g = c0 - 1;
            while g > 0 && !self.class_step(io, x, g - 1, c >= g)? {
                g -= 1;
            }
            Ok(g)
        }
    }

    /// Codes the sign of a non-zero value (true: negative) under its two contexts
    /// (inlined, as [`Models::class_step`]).
    #[inline(always)]
    fn sign<I: BitIo>(&mut self, io: &mut I, x: &Context, negative: bool) -> Result<bool, String> {
        let coarse = x.coarse();
        let [s0, s1] = &mut self.sign;
        self.sign_mix.code(
            io,
            coarse,
            [
                &mut s0[3 * coarse + x.sum_sign],
                &mut s1[27 * coarse + x.signs],
            ],
            negative,
        )
    }

    /// Codes bit `i` of a magnitude whose leading one is bit `e`, under the mantissa's
    /// two models.
    fn mantissa_bit<I: BitIo>(
        &mut self,
        io: &mut I,
        x: &Context,
        e: usize,
        i: usize,
        bit: bool,
    ) -> Result<bool, String> {
        let slot = e * MAX_EXP + i;
        let [m0, m1] = &mut self.mantissa;
        self.mantissa_mix
            .code(io, slot, [&mut m0[slot], &mut m1[slot * SCALES + x.k]], bit)
    }

    /// Codes one value under its context `x`; `limit` is the largest `|v|`. Layout 7:
    /// its class, its sign, the bit of `|v|` below the leading one under mixed models
    /// and the rest as equally likely bits. Layouts 5 and 6: `v = 0?`, its sign, the
    /// exponent in unary, every bit below the leading one under mixed models.
    fn value<I: BitIo>(
        &mut self,
        io: &mut I,
        v: i32,
        x: &Context,
        limit: u32,
    ) -> Result<i32, String> {
        let n = v.unsigned_abs();
        let class = if n == 0 { 0 } else { 1 + n.ilog2() as usize };
        let (c, negative) = match self.binarization {
            Binarization::Pivot => {
                let c = self.class(io, x, class)?;
                if c == 0 {
                    return Ok(0);
                }
                (c, self.sign(io, x, v < 0)?)
            }
            Binarization::Gamma => {
                if !self.magnitude(io, x, None, v != 0)? {
                    return Ok(0);
                }
                let negative = self.sign(io, x, v < 0)?;
                let e = class.saturating_sub(1);
                let mut got = 0;
                while got < MAX_EXP && self.magnitude(io, x, Some(got), got < e)? {
                    got += 1;
                }
                (got + 1, negative)
            }
        };
        let e = c - 1;
        let modeled = match self.binarization {
            Binarization::Pivot => e.min(1),
            Binarization::Gamma => e,
        };
        let mut magnitude = 1u32;
        for i in (0..e).rev() {
            let bit = (n >> i) & 1 == 1;
            let bit = if i + modeled >= e {
                self.mantissa_bit(io, x, e, i, bit)?
            } else {
                io.code_probability(HALF, bit)?
            };
            magnitude = magnitude << 1 | u32::from(bit);
        }
        signed(magnitude, negative, limit)
    }
}

/// Values a frame's list keeps spare past its end: [`PAD`] bytes.
const SPARE_VALUES: usize = PAD / std::mem::size_of::<i32>();

/// An equally likely bit's probability, in `1/4096`.
const HALF: u16 = 2048;

/// The likeliest class of a value whose scale context is `k`: with neighbours of about
/// its size, `m ≈ 3|v|`, so `k ≈ 2 log₂ m ≈ 2 (log₂|v| + 1.58)` and
/// `c = 1 + ⌊log₂|v|⌋ ≈ ⌊(k − 1)/2⌋`.
fn pivot(k: usize) -> usize {
    k.saturating_sub(1) / 2
}

/// `±magnitude`, refused above the block's `limit`.
fn signed(magnitude: u32, negative: bool, limit: u32) -> Result<i32, String> {
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
/// first value in one flat list, by its place in the frame. A list of the stored bricks
/// in coding order (ascending place, which [`FrameBricks::add`] holds to), searched by
/// bisection, not a table of the frame's bricks: its memory follows the bricks a block
/// holds, whatever dims a damaged block claims.
struct FrameBricks {
    /// Bricks per axis of the frame.
    nb: [u32; 3],
    brick: u32,
    /// `(bx + nb₀ (by + nb₁ bz), first value)` of each stored (and already coded) brick,
    /// ascending.
    index: Vec<(u64, usize)>,
}

impl FrameBricks {
    /// Room for a frame of `nb` bricks a side of `brick` voxels.
    fn new(nb: [u32; 3], brick: u32) -> Self {
        FrameBricks {
            nb,
            brick,
            index: Vec::new(),
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

    /// Records that the brick at `p` starts at value `first`; bricks come in ascending
    /// place within a frame.
    fn add(&mut self, p: [u32; 3], first: usize) -> Result<(), String> {
        let slot = self.slot(p);
        if self.index.last().is_some_and(|&(last, _)| last >= slot) {
            return Err(format!("brick {p:?} comes out of order"));
        }
        self.index.push((slot, first));
        Ok(())
    }

    /// Where the brick at brick position `p` starts in the frame's values, if it is
    /// stored (and already coded).
    fn first(&self, p: [u32; 3]) -> Option<usize> {
        let slot = self.slot(p);
        self.index
            .binary_search_by_key(&slot, |&(s, _)| s)
            .ok()
            .map(|i| self.index[i].1)
    }

    /// [`FrameBricks::first`] of the bricks at `x − 1`, `x` and `x + 1` in the row of
    /// `p`: one search, as a row's bricks are consecutive in the list.
    fn row(&self, p: [u32; 3]) -> [Option<usize>; 3] {
        let mut i = self
            .index
            .partition_point(|&(s, _)| s < self.slot([p[0].saturating_sub(1), p[1], p[2]]));
        std::array::from_fn(|d| {
            let x = (p[0] + d as u32)
                .checked_sub(1)
                .filter(|&x| x < self.nb[0])?;
            let slot = self.slot([x, p[1], p[2]]);
            while self.index.get(i).is_some_and(|&(s, _)| s < slot) {
                i += 1;
            }
            self.index
                .get(i)
                .filter(|&&(s, _)| s == slot)
                .map(|&(_, first)| first)
        })
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

/// The coder's state: its models, the frame being coded and the frame before it. Every
/// buffer written value by value keeps [`PAD`] bytes spare at its end, as the models'
/// tables do, so that coders of streams on other threads never write to its cache lines
/// ([`haze_core::mixing`]).
struct Coding {
    models: Models,
    /// The brick being coded, with its causal halo.
    halo: Vec<i32>,
    now: Frame,
    before: Frame,
    current: Option<usize>,
    limit: u32,
}

impl Coding {
    fn new(nb: [u32; 3], b: u32, limit: u32, binarization: Binarization) -> Self {
        let frame = || Frame {
            bricks: FrameBricks::new(nb, b),
            values: Vec::new(),
        };
        let b = b as usize;
        Coding {
            models: Models::new(binarization),
            halo: table((b + 2) * (b + 2) * (b + 1), 0),
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
        self.now.bricks.add(at, first)?;
        self.now.values.reserve(per + SPARE_VALUES);
        self.now.values.resize(first + per, 0);
        // The 17 bricks around this one at its `z` and below (those stored and already
        // coded; this one's own slot stays empty), and this brick in the frame before.
        let mut around = [None; 18];
        for (r, row) in around.chunks_exact_mut(3).enumerate() {
            let (dy, dz) = (r % 3, r / 3);
            let (Some(y), Some(z)) = (
                (at[1] + dy as u32).checked_sub(1),
                (at[2] + dz as u32).checked_sub(1),
            ) else {
                continue;
            };
            // In this brick's plane, the rows from its own on are not coded before it.
            if y < self.now.bricks.nb[1] && (dz == 0 || dy == 0) {
                row.copy_from_slice(&self.now.bricks.row([at[0], y, z]));
            }
        }
        // Its own row: only the brick before it is coded.
        if at[0] > 0 {
            around[12] = self.now.bricks.first([at[0] - 1, at[1], at[2]]);
        }
        let past = self.before.bricks.first(at);
        // The brick with a causal halo: x and y from −1 to b, z from −1 to b − 1, the
        // neighbours' values where they are coded, 0 elsewhere and in this brick until
        // each value is coded.
        let (hx, hxy) = (b + 2, (b + 2) * (b + 2));
        let halo = &mut self.halo;
        halo.clear();
        halo.resize(hxy * (b + 1), 0);
        // Along one axis, the neighbour brick at offset `s` (0, 1, 2 for before, this,
        // after) covers `len` halo coordinates from `start`, its own from `from` (along `z`
        // the halo ends at this brick's last plane).
        let span = |s: usize| match s {
            0 => (0, 1, b - 1),
            1 => (1, b, 0),
            _ => (b + 1, 1, 0),
        };
        let values = &mut self.now.values;
        for (i, f) in around.iter().enumerate() {
            let (sx, sy, sz) = (i % 3, (i / 3) % 3, i / 9);
            let Some(f) = *f else { continue };
            let ((x0, nx, ix), (y0, ny, iy), (z0, nz, iz)) = (span(sx), span(sy), span(sz));
            for dz in 0..nz {
                for dy in 0..ny {
                    let from = f + ix + b * (iy + dy) + bb * (iz + dz);
                    let to = x0 + hx * (y0 + dy) + hxy * (z0 + dz);
                    halo[to..to + nx].copy_from_slice(&values[from..from + nx]);
                }
            }
        }
        let wide = WIDE.map(|[x, y, z]| x + hx as isize * y + hxy as isize * z);
        // The halo's place of each voxel, `x` fastest (no division by the brick's side).
        let places = (0..b).flat_map(|z| {
            (0..b).flat_map(move |y| (0..b).map(move |x| (x + 1) + hx * (y + 1) + hxy * (z + 1)))
        });
        for (l, h) in places.enumerate() {
            let n = [halo[h - 1], halo[h - hx], halo[h - hxy]];
            let wide = wide
                .iter()
                .map(|&d| halo[h.wrapping_add_signed(d)].unsigned_abs())
                .sum();
            let before = past.map_or(0, |f| self.before.values[f + l]);
            let x = Context::new(n, wide, before);
            let v = self
                .models
                .value(io, given.map_or(0, |g| g[l]), &x, self.limit)?;
            values[first + l] = v;
            halo[h] = v;
        }
        Ok(first)
    }
}

/// Encodes bricks into `io`: for each, its frame slot `j`, its brick position in that
/// frame and its `b³` values (`x` fastest), in coding order. `nb` is the frame's bricks
/// per axis and `limit` the largest magnitude a value may have. The bricks may come from
/// an iterator that unpacks each one as it is asked for, so that a hash volume's values
/// are never all held as `i32`.
pub fn encode<V: AsRef<[i32]>>(
    io: &mut BitWriter,
    nb: [u32; 3],
    b: u32,
    limit: u32,
    binarization: Binarization,
    bricks: impl IntoIterator<Item = (usize, [u32; 3], V)>,
) -> Result<(), String> {
    let mut coding = Coding::new(nb, b, limit, binarization);
    for (j, at, given) in bricks {
        coding.brick(io, j, at, Some(given.as_ref()))?;
    }
    Ok(())
}

/// Decodes what [`encode`] wrote, brick by brick in the same order, keeping only the
/// frame being decoded and the frame before it (a caller packs each brick as it comes,
/// so a hash volume's values are never all held as `i32`).
pub(crate) struct Decoder {
    coding: Coding,
}

impl Decoder {
    /// A decoder for frames of `nb` bricks a side of `b` voxels, values up to `limit`,
    /// binarized as `binarization`.
    pub fn new(nb: [u32; 3], b: u32, limit: u32, binarization: Binarization) -> Self {
        Decoder {
            coding: Coding::new(nb, b, limit, binarization),
        }
    }

    /// The `b³` values of the next brick, at frame slot `j` and brick position `at`.
    pub fn brick(
        &mut self,
        io: &mut BitReader<'_>,
        j: usize,
        at: [u32; 3],
    ) -> Result<&[i32], String> {
        let per = self.coding.now.bricks.brick.pow(3) as usize;
        let first = self.coding.brick(io, j, at, None)?;
        Ok(&self.coding.now.values[first..first + per])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOTH: [Binarization; 2] = [Binarization::Gamma, Binarization::Pivot];

    fn coded(
        how: Binarization,
        nb: [u32; 3],
        b: u32,
        limit: u32,
        list: &[(usize, [u32; 3], &[i32])],
    ) -> Vec<u8> {
        let mut io = BitWriter::new();
        encode(&mut io, nb, b, limit, how, list.iter().copied()).unwrap();
        io.finish().unwrap()
    }

    fn decoded(
        how: Binarization,
        bytes: &[u8],
        nb: [u32; 3],
        b: u32,
        limit: u32,
        stored: &[(usize, [u32; 3])],
    ) -> Result<Vec<Vec<i32>>, String> {
        let mut io = BitReader::new(bytes).unwrap();
        let mut decoder = Decoder::new(nb, b, limit, how);
        stored
            .iter()
            .map(|&(j, at)| decoder.brick(&mut io, j, at).map(<[i32]>::to_vec))
            .collect()
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
        for how in BOTH {
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
            let bytes = coded(how, nb, b, limit, &list);
            assert_eq!(decoded(how, &bytes, nb, b, limit, &stored).unwrap(), given);
            // A limit below the largest value is caught on decode.
            assert!(
                decoded(how, &bytes, nb, b, 100, &stored)
                    .unwrap_err()
                    .contains("exceeds")
            );
        }
    }

    /// A frame's bricks come in ascending place: one out of order (or twice) is refused,
    /// coding or decoding, where a map would have let it overwrite another's place.
    #[test]
    fn bricks_out_of_order_are_refused() {
        for how in BOTH {
            let v = values(2, 0, 7);
            let list = [(0, [1, 0, 0], v.as_slice()), (0, [0, 0, 0], v.as_slice())];
            let mut io = BitWriter::new();
            assert!(
                encode(&mut io, [2, 1, 1], 2, 7, how, list.iter().copied())
                    .unwrap_err()
                    .contains("out of order")
            );
            let twice = [(0, [0, 0, 0]), (0, [0, 0, 0])];
            let ok = coded(how, [2, 1, 1], 2, 7, &[(0, [0, 0, 0], v.as_slice())]);
            assert!(
                decoded(how, &ok, [2, 1, 1], 2, 7, &twice)
                    .unwrap_err()
                    .contains("out of order")
            );
        }
    }

    #[test]
    fn the_widest_values_round_trip() {
        for how in BOTH {
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
            let bytes = coded(how, [1, 1, 1], 2, limit, &list);
            assert_eq!(
                decoded(how, &bytes, [1, 1, 1], 2, limit, &[(0, [0, 0, 0])]).unwrap(),
                given
            );
        }
    }

    #[test]
    fn correlated_values_cost_less_than_their_order_zero_entropy() {
        for how in BOTH {
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
            let bytes = coded(how, nb, b, 127, &list);
            assert_eq!(decoded(how, &bytes, nb, b, 127, &stored).unwrap(), given);
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
    }

    /// A frame like the one before it codes smaller after it (slot j − 1) than after a
    /// frame two slots away, which gives it no past.
    #[test]
    fn the_frame_before_is_a_context() {
        for how in BOTH {
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
                let bytes = coded(how, nb, b, limit, &list);
                let where_: Vec<(usize, [u32; 3])> =
                    list.iter().map(|&(j, at, _)| (j, at)).collect();
                let back = decoded(how, &bytes, nb, b, limit, &where_).unwrap();
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
    }

    /// Every class round-trips from every pivot: up to 15 (where no step past it is
    /// asked) and down to 0; the pivots are `⌊(k − 1)/2⌋`.
    #[test]
    fn every_class_round_trips_from_every_pivot() {
        let pivots: Vec<usize> = (0..SCALES).map(pivot).collect();
        assert_eq!(pivots, [0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7]);
        let at = |k: usize| Context {
            t: k % PAST,
            k,
            shape: (7 * k) % SHAPES,
            wide: (3 * k) % SCALES,
            sum_sign: 1,
            signs: 13,
        };
        let all: Vec<(usize, usize)> = (0..SCALES)
            .flat_map(|k| (0..CLASSES).map(move |c| (k, c)))
            .collect();
        let mut w = BitWriter::new();
        let mut m = Models::new(Binarization::Pivot);
        for &(k, c) in &all {
            assert_eq!(m.class(&mut w, &at(k), c).unwrap(), c);
        }
        let bytes = w.finish().unwrap();
        let mut r = BitReader::new(&bytes).unwrap();
        let mut m = Models::new(Binarization::Pivot);
        for &(k, c) in &all {
            assert_eq!(m.class(&mut r, &at(k), 0).unwrap(), c, "class {c} at k {k}");
        }
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
