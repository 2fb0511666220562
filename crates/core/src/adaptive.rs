//! Binary adaptive models and the range coder they drive: the entropy coding of the
//! asset's residual values (`haze-hash`'s context coder) and RBF channels (`haze-asset`).
//!
//! A [`Bit`] is the probability that the next bit under it is 0, in `1/2^12`; after each
//! bit it codes it moves `1/32` of the way towards that bit (an exponentially decaying
//! count of about the last 32 bits). Its steps vanish within 31/4096 of either end, so
//! no bit is ever impossible and a bit costs at most `log₂(4096/31) ≈ 7.05` bits. The bits go through
//! `constriction`'s range coder (32-bit words, 64-bit state): [`BitWriter`] and
//! [`BitReader`] implement [`BitIo`], so one function that codes a value bit by bit both
//! writes and reads it, and the two can never disagree.

use constriction::stream::Encode;
use constriction::stream::model::{EncoderModel, EntropyModel};
use constriction::stream::queue::DefaultRangeEncoder;
use std::num::NonZeroU16;

/// Bits of a model's probability.
const PRECISION: usize = 12;
const ONE: u16 = 1 << PRECISION;
/// A model moves `1/2^RATE` of the way towards each coded bit.
const RATE: u16 = 5;

/// The least a bit coded under a [`Bit`] costs: `−log₂(4065/4096)` bits, the model's
/// probability of either bit never exceeding 4065/4096. A stream of `n` coded bytes holds
/// at most `(8n + 64) / LEAST_BITS` bits (a range coder's output is never shorter than the
/// information it codes, less its last words), so readers bound what a damaged header
/// claims by the bytes it brings.
pub const LEAST_BITS: f64 = 0.010_96;

/// A binary adaptive model (the probability of a 0).
#[derive(Clone, Copy, Debug)]
pub struct Bit {
    p: u16,
}

impl Default for Bit {
    /// Both bits equally likely.
    fn default() -> Self {
        Bit { p: ONE / 2 }
    }
}

impl Bit {
    #[inline]
    fn update(&mut self, bit: bool) {
        if bit {
            self.p -= self.p >> RATE;
        } else {
            self.p += (ONE - self.p) >> RATE;
        }
    }

    #[inline]
    fn nonzero(p: u16) -> NonZeroU16 {
        NonZeroU16::new(p).unwrap_or(NonZeroU16::MIN)
    }
}

impl EntropyModel<PRECISION> for Bit {
    type Symbol = bool;
    type Probability = u16;
}

impl EncoderModel<PRECISION> for Bit {
    #[inline]
    fn left_cumulative_and_probability(
        &self,
        symbol: impl std::borrow::Borrow<bool>,
    ) -> Option<(u16, NonZeroU16)> {
        Some(if *symbol.borrow() {
            (self.p, Bit::nonzero(ONE - self.p))
        } else {
            (0, Bit::nonzero(self.p))
        })
    }
}

/// One coded bit: written by the encoder, read by the decoder.
pub trait BitIo {
    /// Codes `bit` (a writer) or returns the next bit (a reader, which ignores `bit`)
    /// under `model`, then adapts the model.
    fn code(&mut self, model: &mut Bit, bit: bool) -> Result<bool, String>;

    /// Codes the `n` low bits of `v` (a reader: returns them), most significant first,
    /// each under the node of the binary tree `tree` (`2^n − 1` models, the root first)
    /// that its higher bits lead to.
    fn tree(&mut self, tree: &mut [Bit], n: u32, v: u32) -> Result<u32, String> {
        let mut node = 1usize;
        for i in (0..n).rev() {
            let bit = self.code(&mut tree[node - 1], (v >> i) & 1 == 1)?;
            node = 2 * node + usize::from(bit);
        }
        Ok(node as u32 - (1 << n))
    }

    /// Codes `bit` (a reader: returns the next bit) with the probability `p_one` (in
    /// `1/4096`, clamped to `1..=4095`) that it is 1: a prediction made elsewhere, such
    /// as a [`crate::mixing::Mixer`]'s.
    #[inline]
    fn code_probability(&mut self, p_one: u16, bit: bool) -> Result<bool, String> {
        let mut fixed = Bit {
            p: ONE - p_one.clamp(1, ONE - 1),
        };
        self.code(&mut fixed, bit)
    }

    /// Codes the `n` low bits of `v` as equally likely bits.
    fn raw(&mut self, n: u32, v: u32) -> Result<u32, String> {
        let mut out = 0;
        for i in (0..n).rev() {
            let mut even = Bit::default();
            out = out << 1 | u32::from(self.code(&mut even, (v >> i) & 1 == 1)?);
        }
        Ok(out)
    }
}

/// Adaptive models of an Elias-gamma code of integers `v ≥ 0`: `e = ⌊log₂(v + 1)⌋` in
/// unary, each bit under its own model, then the `e` bits of `v + 1` below its leading
/// one, the highest under a model of its `e`, the rest equally likely.
#[derive(Clone, Debug)]
pub struct Gamma {
    exponent: [Bit; 64],
    top: [Bit; 64],
}

impl Default for Gamma {
    fn default() -> Self {
        Gamma {
            exponent: [Bit::default(); 64],
            top: [Bit::default(); 64],
        }
    }
}

impl Gamma {
    /// Codes `v` (a reader: returns the next value; `v` is ignored). Values up to
    /// `2⁶³ − 2`; a reader refuses exponents of 63 and more.
    pub fn code<I: BitIo>(&mut self, io: &mut I, v: u64) -> Result<u64, String> {
        let n = v.saturating_add(1);
        let e = n.ilog2() as usize;
        let mut got = 0;
        while io.code(&mut self.exponent[got.min(63)], got < e)? {
            got += 1;
            if got >= 63 {
                return Err("an integer's code runs past 63 bits".to_string());
            }
        }
        if got == 0 {
            return Ok(0);
        }
        let top = io.code(&mut self.top[got], (n >> (got - 1)) & 1 == 1)?;
        let mut out = 2 | u64::from(top);
        for i in (0..got - 1).rev() {
            let mut even = Bit::default();
            out = out << 1 | u64::from(io.code(&mut even, (n >> i) & 1 == 1)?);
        }
        Ok(out - 1)
    }
}

/// Writes bits; [`BitWriter::finish`] gives the coded bytes (whole little-endian words).
#[derive(Debug, Default)]
pub struct BitWriter(DefaultRangeEncoder);

impl BitWriter {
    pub fn new() -> Self {
        BitWriter(DefaultRangeEncoder::new())
    }

    /// The coded bytes.
    pub fn finish(self) -> Result<Vec<u8>, String> {
        let words = self
            .0
            .into_compressed()
            .map_err(|e| format!("range coder: {e:?}"))?;
        Ok(words.iter().flat_map(|w| w.to_le_bytes()).collect())
    }
}

impl BitIo for BitWriter {
    #[inline]
    fn code(&mut self, model: &mut Bit, bit: bool) -> Result<bool, String> {
        self.0
            .encode_symbol(bit, *model)
            .map_err(|e| format!("range coder: {e}"))?;
        model.update(bit);
        Ok(bit)
    }
}

/// Word `i` of `bytes` (little-endian), if the bytes hold it whole.
#[inline]
fn word_at(bytes: &[u8], i: usize) -> Option<u32> {
    let w = bytes.get(4 * i..4 * i + 4)?;
    Some(u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
}

/// Reads the bits a [`BitWriter`] wrote. Past the end of its bytes it reads on as if
/// they went on with zeros; callers bound what they read.
///
/// This is `constriction`'s range decoder (32-bit words, 64-bit state) for a two-symbol
/// alphabet, written out so that a bit costs a multiplication where the general decoder
/// divides: with `s = ⌊range/2¹²⌋` and `x = point − lower` (wrapping), the general decoder
/// takes the quantile `q = ⌊x/s⌋` and reads a 0 where `q < p₀`; for integers,
/// `⌊x/s⌋ < p₀ ⟺ x < p₀·s`, so comparing `x` with `p₀·s` reads the same bit, and the state
/// then moves exactly as the general decoder's does. The residual's value coder decodes
/// millions of bits a frame, and the division was a sixth of its time. A test decodes the
/// same streams with both and compares every bit and the errors on garbage.
///
/// It reads its words in place from the bytes it is given (no copy: a hash volume's
/// streams are tens of MB at production sizes).
#[derive(Debug)]
pub struct BitReader<'a> {
    /// The stream, whole little-endian 32-bit words.
    bytes: &'a [u8],
    /// The next word to read.
    next: usize,
    lower: u64,
    range: u64,
    /// Invariant: `point − lower < range` (wrapping), for a stream the encoder wrote.
    point: u64,
}

impl<'a> BitReader<'a> {
    /// A reader of `bytes` (whole words, as [`BitWriter::finish`] gives them).
    pub fn new(bytes: &'a [u8]) -> Result<Self, String> {
        if !bytes.len().is_multiple_of(4) {
            return Err(format!(
                "its {} range-coded bytes are not whole words",
                bytes.len()
            ));
        }
        // The first two words, the first one high; missing words read as zeros.
        let word = |i: usize| u64::from(word_at(bytes, i).unwrap_or(0));
        let point = word(0) << 32 | word(1);
        Ok(BitReader {
            next: (bytes.len() / 4).min(2),
            bytes,
            lower: 0,
            range: u64::MAX,
            point,
        })
    }

    /// Reads the next bit, a 0 with probability `p0` (in `1/4096`, within `1..=4095`).
    #[inline]
    fn bit(&mut self, p0: u16) -> Result<bool, String> {
        let scale = self.range >> PRECISION;
        let x = self.point.wrapping_sub(self.lower);
        if x >= scale << PRECISION {
            return Err("range coder: invalid compressed data".to_string());
        }
        let cut = scale * u64::from(p0);
        let bit = x >= cut;
        if bit {
            self.lower = self.lower.wrapping_add(cut);
            self.range = scale * u64::from(ONE - p0);
        } else {
            self.range = cut;
        }
        if self.range < 1 << 32 {
            self.lower <<= 32;
            self.range <<= 32;
            self.point <<= 32;
            if let Some(w) = word_at(self.bytes, self.next) {
                self.point |= u64::from(w);
                self.next += 1;
            }
        }
        Ok(bit)
    }
}

impl BitIo for BitReader<'_> {
    #[inline]
    fn code(&mut self, model: &mut Bit, _: bool) -> Result<bool, String> {
        let bit = self.bit(model.p.max(1))?;
        model.update(bit);
        Ok(bit)
    }

    #[inline]
    fn code_probability(&mut self, p_one: u16, _: bool) -> Result<bool, String> {
        self.bit(ONE - p_one.clamp(1, ONE - 1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use constriction::stream::Decode;
    use constriction::stream::model::DecoderModel;
    use constriction::stream::queue::DefaultRangeDecoder;

    /// `constriction`'s general decoder reads a [`Bit`] by its quantile function; the
    /// twin the test compares [`BitReader`] with.
    impl DecoderModel<PRECISION> for Bit {
        #[inline]
        fn quantile_function(&self, quantile: u16) -> (bool, u16, NonZeroU16) {
            if quantile < self.p {
                (false, 0, Bit::nonzero(self.p))
            } else {
                (true, self.p, Bit::nonzero(ONE - self.p))
            }
        }
    }

    /// `BitReader` reads what `constriction`'s own decoder reads, bit for bit: streams of
    /// bits under probabilities from 1/4096 to 4095/4096 (mixed predictions and adaptive
    /// models), streams of 0, 1 and 3 words, and garbage, where both must give the same
    /// bits up to the same first error.
    #[test]
    fn the_reader_reads_what_the_general_decoder_reads() {
        let p_of = |i: u32| {
            let h = i.wrapping_mul(2_654_435_761) >> 8;
            match h % 5 {
                0 => 1 + (h % 3) as u16,
                1 => 4095 - (h % 3) as u16,
                _ => 1 + (h % 4095) as u16,
            }
        };
        let twin = |bytes: &[u8], n: u32| {
            let words: Vec<u32> = bytes
                .chunks_exact(4)
                .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
                .collect();
            let mut general = DefaultRangeDecoder::from_compressed(words).unwrap();
            let mut ours = BitReader::new(bytes).unwrap();
            for i in 0..n {
                let p0 = p_of(i);
                let want = general.decode_symbol(Bit { p: p0 }).map_err(|_| ());
                let got = ours.code_probability(ONE - p0, false).map_err(|_| ());
                assert_eq!(got, want, "bit {i}");
                if want.is_err() {
                    return i;
                }
            }
            n
        };
        for n in [0u32, 1, 5, 40, 20_000] {
            let mut w = BitWriter::new();
            let bits: Vec<bool> = (0..n)
                .map(|i| (i.wrapping_mul(2_246_822_519) >> 9) % 4096 >= u32::from(p_of(i)))
                .collect();
            for (i, &b) in bits.iter().enumerate() {
                w.code_probability(ONE - p_of(i as u32), b).unwrap();
            }
            let bytes = w.finish().unwrap();
            let mut r = BitReader::new(&bytes).unwrap();
            for (i, &b) in bits.iter().enumerate() {
                assert_eq!(r.code_probability(ONE - p_of(i as u32), false).unwrap(), b);
            }
            assert_eq!(
                twin(&bytes, n + 100),
                n + 100,
                "{n} bits read on past the end"
            );
        }
        for len in [0usize, 4, 12, 4096] {
            let garbage: Vec<u8> = (0..len as u32)
                .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
                .collect();
            twin(&garbage, 50_000);
        }
        // A point past the range from the first word on: both refuse the first bit.
        assert_eq!(twin(&[0xff; 8], 10), 0);
    }

    /// Bits and trees come back as written, and a skewed source costs what its entropy
    /// says (the adaptive model's price: within 10 % for 20 000 bits at p = 0.05).
    #[test]
    fn bits_round_trip_and_cost_their_entropy() {
        let p1 = 0.05f64;
        let bits: Vec<bool> = (0..20_000u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 7) % 1000 < (p1 * 1000.0) as u32)
            .collect();
        let mut w = BitWriter::new();
        let mut m = Bit::default();
        let mut tree = [Bit::default(); 15];
        for (i, &b) in bits.iter().enumerate() {
            w.code(&mut m, b).unwrap();
            w.tree(&mut tree, 4, (i % 16) as u32).unwrap();
            w.raw(3, (i % 8) as u32).unwrap();
        }
        let bytes = w.finish().unwrap();
        let mut r = BitReader::new(&bytes).unwrap();
        let (mut m, mut tree) = (Bit::default(), [Bit::default(); 15]);
        for (i, &b) in bits.iter().enumerate() {
            assert_eq!(r.code(&mut m, false).unwrap(), b);
            assert_eq!(r.tree(&mut tree, 4, 0).unwrap(), (i % 16) as u32);
            assert_eq!(r.raw(3, 0).unwrap(), (i % 8) as u32);
        }
        // The skewed bits alone.
        let mut w = BitWriter::new();
        let mut m = Bit::default();
        for &b in &bits {
            w.code(&mut m, b).unwrap();
        }
        let coded = 8.0 * w.finish().unwrap().len() as f64;
        let ones = bits.iter().filter(|&&b| b).count() as f64 / bits.len() as f64;
        let h = -(ones * ones.log2() + (1.0 - ones) * (1.0 - ones).log2());
        let ideal = h * bits.len() as f64;
        assert!(
            coded < 1.1 * ideal && coded > 0.95 * ideal,
            "{coded} bits for {ideal:.0} of entropy"
        );
    }

    /// Integers from 0 to the largest round-trip through the gamma code.
    #[test]
    fn gamma_codes_round_trip() {
        let values = [
            0u64,
            1,
            2,
            3,
            7,
            8,
            1000,
            1 << 32,
            (1 << 62) + 12345,
            (1 << 63) - 2,
        ];
        let mut w = BitWriter::new();
        let mut g = Gamma::default();
        for &v in &values {
            assert_eq!(g.code(&mut w, v).unwrap(), v);
        }
        let bytes = w.finish().unwrap();
        let mut r = BitReader::new(&bytes).unwrap();
        let mut g = Gamma::default();
        for &v in &values {
            assert_eq!(g.code(&mut r, 0).unwrap(), v);
        }
    }

    /// A long run of the likelier bit costs no less than LEAST_BITS a bit, and the model's
    /// bound is where its steps vanish.
    #[test]
    fn a_bit_costs_at_least_the_least() {
        let least = -(4065.0f64 / 4096.0).log2();
        assert!(LEAST_BITS <= least && least - LEAST_BITS < 1e-5);
        let n = 200_000;
        let mut w = BitWriter::new();
        let mut m = Bit::default();
        for _ in 0..n {
            w.code(&mut m, false).unwrap();
        }
        let bits = 8.0 * w.finish().unwrap().len() as f64;
        assert!(bits + 64.0 >= LEAST_BITS * n as f64, "{bits} bits for {n}");
        assert!(
            bits <= 1.2 * LEAST_BITS * n as f64 + 200.0,
            "{bits} bits for {n}"
        );
    }

    /// A model never makes a bit impossible, however long the run against it.
    #[test]
    fn a_long_run_leaves_the_other_bit_possible() {
        let mut m = Bit::default();
        for _ in 0..10_000 {
            m.update(false);
        }
        assert!(ONE - m.p >= 31, "{}", m.p);
        let mut w = BitWriter::new();
        w.code(&mut m, true).unwrap();
        let mut m = Bit::default();
        for _ in 0..10_000 {
            m.update(true);
        }
        assert!(m.p >= 31, "{}", m.p);
    }
}
