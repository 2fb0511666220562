//! Logistic mixing of adaptive bit predictions: the residual's value coder
//! (`haze-hash`'s context coder) predicts each bit from several contexts at once and
//! weighs them by how well each has predicted so far.
//!
//! - A [`Counter`] is the probability that the next bit under its context is 1, in
//!   `1/2^16`. It moves `1/(n + 1.5)` of the way towards each bit it sees, `n` the bits
//!   seen so far up to [`LIMIT`]: a running mean at first, then an exponentially decaying
//!   one over about the last `LIMIT` bits.
//! - The predictions are mixed in the logistic domain: `p = squash(Σᵢ wᵢ stretch(pᵢ))`,
//!   `stretch(p) = ln(p/(1 − p))`, `squash` its inverse, and after each bit every weight
//!   moves along the gradient of the bit's coding cost, `wᵢ += η (y − p) stretch(pᵢ)`
//!   (`y` the bit). A [`Mixer`] keeps one weight vector per selector context.
//!
//! Everything is integer arithmetic (logits in `1/256`, probabilities in `1/4096`,
//! weights in `1/65536`), so an encoder and a decoder on any machine compute the same
//! probabilities bit for bit: the coded stream never depends on floating point.
//!
//! Coders of separate streams run on separate threads at once, and each updates its
//! tables on every bit. Tables that shared a cache line with another thread's would make
//! the two cores pass that line back and forth on every write: two streams decoding at
//! once each ran 1.6× slower than alone. So every table is made by [`table`], which keeps
//! [`PAD`] bytes of its allocation unused after its entries: of two such tables, the one
//! lower in memory ends at least `PAD` bytes before the other begins, so they never share
//! a cache line.

use crate::adaptive::BitIo;

/// Bytes left unused after a table's entries ([`table`]): two cache lines (128 bytes, as
/// adjacent-line prefetchers fetch lines in pairs).
pub const PAD: usize = 128;

/// A table of `len` entries `value` whose allocation keeps at least [`PAD`] bytes unused
/// after them, so that it shares no cache line with another table made here or another
/// buffer padded the same way (module docs).
pub fn table<T: Clone>(len: usize, value: T) -> Vec<T> {
    let spare = PAD.div_ceil(std::mem::size_of::<T>().max(1));
    let mut t = Vec::with_capacity(len + spare);
    t.resize(len, value);
    t
}

/// A counter's rate stops falling after this many bits.
pub const LIMIT: u16 = 60;

/// Logits are clamped to `±2047/256` (probabilities `1/4096 … 4095/4096`).
const LOGIT_MAX: i32 = 2047;

/// `4096 / (1 + e^{−x/256})` at `x = 128 (i − 16)`, `i = 0..33`, rounded and kept within
/// `1..=4095`: the knots [`squash`] interpolates linearly.
const SQUASH_KNOTS: [i32; 33] = [
    1, 2, 4, 6, 10, 17, 27, 45, 74, 120, 194, 311, 488, 747, 1102, 1546, 2048, 2550, 2994, 3349,
    3608, 3785, 3902, 3976, 4022, 4051, 4069, 4079, 4086, 4090, 4092, 4094, 4095,
];

/// The probability (in `1/4096`, within `1..=4095`) of a logit `x` in `1/256`.
#[inline]
pub const fn squash(x: i32) -> i32 {
    let x = if x > LOGIT_MAX {
        LOGIT_MAX
    } else if x < -LOGIT_MAX {
        -LOGIT_MAX
    } else {
        x
    };
    let w = x & 127;
    let i = ((x >> 7) + 16) as usize;
    (SQUASH_KNOTS[i] * (128 - w) + SQUASH_KNOTS[i + 1] * w + 64) >> 7
}

/// [`squash`] at every logit in `±LOGIT_MAX`, `SQUASHED[x + LOGIT_MAX]`: the mix reads
/// it, a load where the interpolation takes two loads and two multiplications on the
/// path from one bit to the next.
const SQUASHED: [u16; 2 * LOGIT_MAX as usize + 1] = {
    let mut t = [0u16; 2 * LOGIT_MAX as usize + 1];
    let mut i = 0;
    while i < t.len() {
        t[i] = squash(i as i32 - LOGIT_MAX) as u16;
        i += 1;
    }
    t
};

/// [`squash`] of a logit already within `±LOGIT_MAX`, from [`SQUASHED`].
#[inline]
fn squash_clamped(x: i32) -> i32 {
    i32::from(SQUASHED[(x + LOGIT_MAX) as usize])
}

/// [`squash`] inverted over its whole range: `STRETCH[p]` is the least logit whose
/// squash reaches `p`.
const STRETCH: [i16; 4096] = {
    let mut t = [0i16; 4096];
    let mut next = 0usize;
    let mut x = -LOGIT_MAX;
    while x <= LOGIT_MAX {
        let v = squash(x) as usize;
        while next <= v {
            t[next] = x as i16;
            next += 1;
        }
        x += 1;
    }
    while next < 4096 {
        t[next] = LOGIT_MAX as i16;
        next += 1;
    }
    t
};

/// The logit (in `1/256`) of a probability `p` in `1/4096`.
#[inline]
pub fn stretch(p: i32) -> i32 {
    i32::from(STRETCH[p.clamp(0, 4095) as usize])
}

/// `2^16 / (n + 1.5)`: a counter's step after `n` bits.
const STEP: [u32; LIMIT as usize + 1] = {
    let mut t = [0u32; LIMIT as usize + 1];
    let mut n = 0;
    while n <= LIMIT as usize {
        t[n] = (2 << 16) / (2 * n as u32 + 3);
        n += 1;
    }
    t
};

/// An adaptive probability of a 1 under one context (see the module's documentation).
#[derive(Clone, Copy, Debug)]
pub struct Counter {
    p: u16,
    n: u16,
}

impl Default for Counter {
    /// Both bits equally likely, nothing seen.
    fn default() -> Self {
        Counter { p: 1 << 15, n: 0 }
    }
}

impl Counter {
    /// The probability of a 1, in `1/4096`.
    #[inline]
    pub fn p(self) -> i32 {
        i32::from(self.p >> 4)
    }

    /// Moves towards `bit`.
    #[inline]
    pub fn update(&mut self, bit: bool) {
        let step = STEP[usize::from(self.n)];
        let p = u32::from(self.p);
        self.p = if bit {
            p + (((65535 - p) * step) >> 16)
        } else {
            p - ((p * step) >> 16)
        } as u16;
        self.n = (self.n + 1).min(LIMIT);
    }
}

/// A weight's start: `0.3` (in `1/65536`), so that three agreeing inputs start near
/// their own prediction.
const WEIGHT_START: i32 = 19_661;
/// The mixer's learning rate: `η = 5/4096` per unit of probability error (in `1/4096`)
/// times logit (in `1/256`), i.e. 0.02 in natural units.
const LEARN: i32 = 5;
/// A constant input (`0.3` as a logit) that lets each weight set learn a bias.
const BIAS: i32 = 77;

/// Weight vectors for `N` predictions and a bias, one per selector context.
#[derive(Clone, Debug)]
pub struct Mixer<const N: usize> {
    weights: Vec<[i32; N]>,
    bias: Vec<i32>,
}

impl<const N: usize> Mixer<N> {
    /// A mixer with `sets` selector contexts.
    pub fn new(sets: usize) -> Self {
        Mixer {
            weights: table(sets, [WEIGHT_START; N]),
            bias: table(sets, WEIGHT_START),
        }
    }

    /// Codes `bit` (a reader: returns the next bit) with the probability mixed from the
    /// `counters` under weight set `set`, then trains the weights and the counters.
    ///
    /// Always inlined: a value coder calls it for every bit, and as a call the range
    /// coder's state and the tables' addresses went through memory on every one (the
    /// residual's decode was 4–8 % slower).
    #[inline(always)]
    pub fn code<I: BitIo>(
        &mut self,
        io: &mut I,
        set: usize,
        counters: [&mut Counter; N],
        bit: bool,
    ) -> Result<bool, String> {
        let x: [i32; N] = std::array::from_fn(|i| stretch(counters[i].p()));
        let w = &mut self.weights[set];
        let dot = x
            .iter()
            .zip(w.iter())
            .map(|(&x, &w)| i64::from(x) * i64::from(w))
            .sum::<i64>()
            + i64::from(BIAS) * i64::from(self.bias[set]);
        let logit = (dot >> 16).clamp(-i64::from(LOGIT_MAX), i64::from(LOGIT_MAX)) as i32;
        let p = squash_clamped(logit);
        let bit = io.code_probability(p as u16, bit)?;
        let err = (i32::from(bit) << 12) - p;
        // |x · err · LEARN| < 2047 · 4095 · 5 fits 32 bits; the weights saturate rather
        // than wrap, whatever bits a damaged stream feeds them.
        for (w, &x) in w.iter_mut().zip(&x) {
            *w = w.saturating_add((x * err * LEARN) >> 12);
        }
        self.bias[set] = self.bias[set].saturating_add((BIAS * err * LEARN) >> 12);
        for c in counters {
            c.update(bit);
        }
        Ok(bit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adaptive::{BitReader, BitWriter};

    /// `squash` against the logistic function it approximates: linear interpolation over
    /// knots `h = 1/2` logit apart errs by at most `h²/8 · max|f″|` on each interval
    /// (`f = 4096 σ`), plus half a unit for the knots' rounding (one at the clamped ends)
    /// and half for the result's.
    /// `stretch` is its inverse within one step.
    #[test]
    fn squash_is_the_logistic_and_stretch_its_inverse() {
        let f = |x: f64| 4096.0 / (1.0 + (-x / 256.0).exp());
        let f2 = |x: f64| {
            let s = f(x) / 4096.0;
            4096.0 * s * (1.0 - s) * (1.0 - 2.0 * s)
        };
        for (i, k) in SQUASH_KNOTS.iter().enumerate() {
            let exact = f(128.0 * (i as f64 - 16.0));
            assert!(
                (f64::from(*k) - exact).abs() <= 1.0,
                "knot {i}: {k} against {exact}"
            );
        }
        for x in (-2047..=2047).step_by(7) {
            let x0 = (x >> 7) << 7;
            let curvature = (0..=64)
                .map(|k| f2(f64::from(x0 + 2 * k)).abs())
                .fold(0.0, f64::max);
            let bound = 0.25 / 8.0 * curvature + 2.0;
            let got = f64::from(squash(x));
            assert!(
                (got - f(f64::from(x))).abs() <= bound,
                "squash({x}) = {got}, logistic {:.2}, bound {bound:.2}",
                f(f64::from(x))
            );
            let back = squash(stretch(squash(x)));
            assert_eq!(back, squash(x), "stretch inverts squash at {x}");
        }
        // The mix's table is the function at every logit it can be asked, both ends too.
        for x in -LOGIT_MAX..=LOGIT_MAX {
            assert_eq!(squash_clamped(x), squash(x), "the table at {x}");
        }
        assert_eq!(squash(i32::MAX), squash(2047));
        assert_eq!(squash(i32::MIN + 1), squash(-2047));
        assert!(squash(-2047) >= 1 && squash(2047) <= 4095);
        assert_eq!(stretch(-5), stretch(0));
        assert_eq!(stretch(99_999), stretch(4095));
    }

    /// A counter's first steps are a running mean (1/1.5, then 1/2.5 of the way), and it
    /// never reaches either end.
    /// A table holds its entries and at least `PAD` spare bytes past them, whatever the
    /// entry's size (zero-sized entries included) and for no entries at all.
    #[test]
    fn tables_keep_their_spare_bytes() {
        fn spare<T: Clone + PartialEq + std::fmt::Debug>(len: usize, value: T) {
            let t = table(len, value.clone());
            assert_eq!(t.len(), len);
            assert!(t.iter().all(|v| *v == value));
            let size = std::mem::size_of::<T>();
            if size > 0 {
                assert!(
                    (t.capacity() - t.len()) * size >= PAD,
                    "{len} of {size} bytes"
                );
            }
        }
        spare(0, 1u8);
        spare(1, Counter::default().p());
        spare(37, [WEIGHT_START; 3]);
        spare(4096, 5i64);
        spare(3, ());
    }

    #[test]
    fn counters_average_then_decay() {
        let mut c = Counter::default();
        c.update(true);
        // 0.5 + 0.5 / 1.5
        assert!((f64::from(c.p) / 65536.0 - 0.8333).abs() < 1e-3);
        for _ in 0..10_000 {
            c.update(true);
        }
        assert!(c.p() < 4096 && c.p > 60_000);
        for _ in 0..10_000 {
            c.update(false);
        }
        assert!(c.p < 2000);
    }

    /// At the extremes: 200 000 equal bits cost almost nothing (each at most what a
    /// probability of 4095/4096 charges, plus the start), and 200 000 bits of a fixed
    /// pseudo-random pattern fed to a decoder reading garbage neither panic nor overflow.
    #[test]
    fn long_runs_and_garbage_stay_in_range() {
        let mut w = BitWriter::new();
        let (mut m, mut a, mut b) = (Mixer::<2>::new(1), Counter::default(), Counter::default());
        for _ in 0..200_000 {
            m.code(&mut w, 0, [&mut a, &mut b], true).unwrap();
        }
        let bytes = w.finish().unwrap();
        let floor = 200_000.0 * -(4095.0f64 / 4096.0).log2();
        assert!(
            ((8 * bytes.len()) as f64) < floor + 200.0,
            "{} bits against {floor:.0}",
            8 * bytes.len()
        );
        // A counter's last step rounds to 0 within 61.5 · 2⁻¹⁶ of 1: 4092/4096.
        assert_eq!(a.p(), 4092);
        assert!(m.weights[0].iter().all(|w| w.abs() < i32::MAX / 2));
        let garbage: Vec<u8> = (0..65_536u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        let mut r = BitReader::new(&garbage).unwrap();
        let mut m = Mixer::<3>::new(2);
        let mut c = [Counter::default(); 3];
        for i in 0..200_000usize {
            let [x, y, z] = &mut c;
            m.code(&mut r, i % 2, [x, y, z], false).unwrap();
        }
    }

    /// Bits round-trip through the mixer, and where one context predicts the bits and
    /// another does not, the mixed code costs less than coding under the weaker one
    /// alone and within 15 % of the source's entropy given the good context.
    #[test]
    fn mixing_learns_which_context_predicts() {
        // A bit that follows `s` (a cycle of period 7) with probability 0.95.
        let bits: Vec<(usize, bool)> = (0..20_000u32)
            .map(|i| {
                let s = (i % 7) as usize;
                let h = i.wrapping_mul(2_654_435_761) >> 16;
                let noisy = h % 100 < 5;
                (s, (s % 2 == 1) != noisy)
            })
            .collect();
        let mut w = BitWriter::new();
        let mut m = Mixer::<2>::new(1);
        let mut good = [Counter::default(); 7];
        let mut weak = Counter::default();
        for &(s, b) in &bits {
            m.code(&mut w, 0, [&mut good[s], &mut weak], b).unwrap();
        }
        let bytes = w.finish().unwrap();
        let mut r = BitReader::new(&bytes).unwrap();
        let mut m = Mixer::<2>::new(1);
        let mut good = [Counter::default(); 7];
        let mut weak = Counter::default();
        for &(s, b) in &bits {
            assert_eq!(
                m.code(&mut r, 0, [&mut good[s], &mut weak], false).unwrap(),
                b
            );
        }
        let n = bits.len() as f64;
        let h = |p: f64| -p * p.log2() - (1.0 - p) * (1.0 - p).log2();
        let given_good = n * h(0.05);
        let ones = bits.iter().filter(|b| b.1).count() as f64 / n;
        let weak_alone = n * h(ones);
        let coded = 8.0 * bytes.len() as f64;
        assert!(
            coded < 0.5 * weak_alone,
            "{coded} bits against {weak_alone}"
        );
        assert!(
            coded < 1.15 * given_good,
            "{coded} bits against {given_good}"
        );
    }
}
