//! Values of a residual brick packed at one width into `u32` words.
//!
//! Value `k` of a brick at width `w` (2, 4, 8, 16 or 32 bits, each dividing 32) occupies
//! bits `[(k·w) mod 32, (k·w) mod 32 + w)` of word `⌊k·w/32⌋` of the brick, low bits first,
//! in two's complement; a brick starts on a word. At 32 bits the word is an `f32`'s bits
//! (a lossless frame). A brick takes the narrowest width holding all of its values, so
//! thin smoke, whose quantized residual is mostly −1, 0 or 1, costs 2 bits a voxel.

/// A stored value width.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Width {
    W2,
    W4,
    W8,
    W16,
    /// `f32` bit patterns (lossless frames).
    F32,
}

impl Width {
    /// Every width, narrowest first.
    pub const ALL: [Width; 5] = [Width::W2, Width::W4, Width::W8, Width::W16, Width::F32];

    /// Bits per value.
    pub fn bits(self) -> u32 {
        match self {
            Width::W2 => 2,
            Width::W4 => 4,
            Width::W8 => 8,
            Width::W16 => 16,
            Width::F32 => 32,
        }
    }

    /// The code stored in a brick's payload.
    pub fn code(self) -> u32 {
        match self {
            Width::W2 => 0,
            Width::W4 => 1,
            Width::W8 => 2,
            Width::W16 => 3,
            Width::F32 => 4,
        }
    }

    pub fn from_code(c: u32) -> Option<Width> {
        Width::ALL.get(c as usize).copied()
    }

    /// Whether `q` fits this width (two's complement; any `i32` at 32 bits).
    pub fn holds(self, q: i32) -> bool {
        let b = self.bits();
        b == 32 || (-(1i64 << (b - 1))..(1i64 << (b - 1))).contains(&i64::from(q))
    }

    /// The narrowest integer width holding every value (16 bits at most: quantized values
    /// never exceed `2^15 − 1`).
    pub fn narrowest(values: &[i32]) -> Width {
        let (lo, hi) = values
            .iter()
            .fold((0, 0), |(lo, hi), &q| (q.min(lo), q.max(hi)));
        [Width::W2, Width::W4, Width::W8]
            .into_iter()
            .find(|w| w.holds(lo) && w.holds(hi))
            .unwrap_or(Width::W16)
    }

    /// Words taken by a brick of `n` values.
    pub fn words(self, n: usize) -> usize {
        (n * self.bits() as usize).div_ceil(32)
    }
}

/// Appends `values` packed at `width` to `out` (whole words; the last one zero-padded).
pub fn pack_into(values: &[i32], width: Width, out: &mut Vec<u32>) {
    let w = width.bits() as usize;
    let start = out.len();
    out.resize(start + width.words(values.len()), 0);
    let mask = if w == 32 { u32::MAX } else { (1u32 << w) - 1 };
    for (k, &q) in values.iter().enumerate() {
        let bit = k * w;
        out[start + bit / 32] |= (q as u32 & mask) << (bit % 32);
    }
}

/// Value `k` of the brick starting at word `word` (sign-extended).
#[inline]
pub fn get(data: &[u32], word: usize, width: Width, k: usize) -> i32 {
    let w = width.bits() as usize;
    let bit = k * w;
    let v = data[word + bit / 32] >> (bit % 32);
    if w == 32 {
        v as i32
    } else {
        // Move the value's sign bit to bit 31, then shift back arithmetically.
        ((v << (32 - w)) as i32) >> (32 - w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_at_every_width_and_its_limits() {
        for width in Width::ALL {
            let b = width.bits();
            let (lo, hi) = if b == 32 {
                (i32::MIN, i32::MAX)
            } else {
                (-(1 << (b - 1)), (1 << (b - 1)) - 1)
            };
            assert!(width.holds(lo) && width.holds(hi));
            if b < 32 {
                assert!(!width.holds(lo - 1) && !width.holds(hi + 1));
            }
            // 64 values (a 4³ brick) and 27 (a 3-wide odd count: padding), with the extremes.
            for n in [64usize, 27, 1] {
                let values: Vec<i32> = (0..n)
                    .map(|k| match k % 5 {
                        0 => lo,
                        1 => hi,
                        2 => 0,
                        3 => -1,
                        _ => (k as i32 % 3) - 1,
                    })
                    .collect();
                let mut data = vec![0xdead_beef];
                pack_into(&values, width, &mut data);
                assert_eq!(data.len(), 1 + width.words(n));
                for (k, &q) in values.iter().enumerate() {
                    assert_eq!(get(&data, 1, width, k), q, "{width:?} value {k}");
                }
                assert_eq!(data[0], 0xdead_beef, "the brick starts on its own word");
            }
        }
    }

    #[test]
    fn narrowest_width() {
        assert_eq!(Width::narrowest(&[0, 0]), Width::W2);
        assert_eq!(Width::narrowest(&[-2, 1]), Width::W2);
        assert_eq!(Width::narrowest(&[2]), Width::W4);
        assert_eq!(Width::narrowest(&[-8, 7]), Width::W4);
        assert_eq!(Width::narrowest(&[-9]), Width::W8);
        assert_eq!(Width::narrowest(&[127, -128]), Width::W8);
        assert_eq!(Width::narrowest(&[128]), Width::W16);
        assert_eq!(Width::narrowest(&[-32767]), Width::W16);
        for c in 0..5 {
            assert_eq!(Width::from_code(c).unwrap().code(), c);
        }
        assert_eq!(Width::from_code(5), None);
    }
}
