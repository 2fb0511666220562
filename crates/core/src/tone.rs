//! Tone curves: how linear radiance, times the exposure, becomes a display value in
//! `[0, 1]` before the sRGB encoding of a PNG or the viewer's picture.
//!
//! - [`ToneMap::Filmic`] (the default): Narkowicz's rational fit of the ACES filmic
//!   reference rendering transform, per channel,
//!   `f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`, clipped to `[0, 1]`. It has a toe
//!   (`f(x) ≈ 0.21x` near 0), maps mid-grey `0.18` to `0.27` and `1` to `0.80`, and rolls
//!   the highlights off to white at `x ≈ 7.24` instead of clipping them at 1: a sunlit
//!   smoke edge or a bright sky keeps its gradation. `f` is increasing for `x ≥ 0`: the
//!   numerator of `f'` is `1.408x² + 0.7028x + 0.0042 > 0`.
//! - [`ToneMap::Clip`]: the linear value clipped to `[0, 1]`, so `1/exposure` is white:
//!   pixel values a user can read back.
//!
//! EXR outputs are never tone-mapped: they hold the linear radiance.

/// A tone curve (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToneMap {
    #[default]
    Filmic,
    Clip,
}

impl ToneMap {
    /// The display value in `[0, 1]` of the linear value `x` (exposure applied); NaN and
    /// negative values give 0, `+∞` gives 1.
    pub fn apply(self, x: f64) -> f64 {
        if x.is_nan() || x <= 0.0 {
            return 0.0;
        }
        match self {
            ToneMap::Clip => x.min(1.0),
            ToneMap::Filmic if x >= WHITE => 1.0,
            ToneMap::Filmic => {
                (x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
            }
        }
    }
}

/// Where the filmic curve reaches 1 (the positive root of `0.08x² − 0.56x − 0.14`), and
/// beyond which it is 1 without evaluating it (`∞/∞` is NaN).
const WHITE: f64 = 7.241_657_386_773_942;

impl std::str::FromStr for ToneMap {
    type Err = String;
    fn from_str(s: &str) -> Result<ToneMap, String> {
        match s {
            "filmic" => Ok(ToneMap::Filmic),
            "clip" => Ok(ToneMap::Clip),
            _ => Err(format!("{s}: expected filmic or clip")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The curve against its closed form at hand-computed points, its root, its
    /// monotonicity on a fine grid, and its extremes.
    #[test]
    fn the_filmic_curve_rolls_off_and_is_monotone() {
        let f = |x| ToneMap::Filmic.apply(x);
        // 1·2.54 / 3.16 and 0.18·0.4818 / (0.18·1.0274 + 0.14).
        assert!((f(1.0) - 2.54 / 3.16).abs() < 1e-15);
        assert!((f(0.18) - 0.18 * 0.4818 / (0.18 * 1.0274 + 0.14)).abs() < 1e-15);
        // The root of 0.08x² − 0.56x − 0.14: the curve reaches 1 there.
        let root = (0.56 + (0.56f64 * 0.56 + 4.0 * 0.08 * 0.14).sqrt()) / 0.16;
        assert!((root - WHITE).abs() < 1e-12, "{root}");
        assert!((f(root - 1e-9) - 1.0).abs() < 1e-6);
        let mut last = 0.0;
        for i in 1..=100_000 {
            let y = f(i as f64 * 1e-4);
            assert!(y >= last, "not monotone at {}", i as f64 * 1e-4);
            last = y;
        }
        assert_eq!(f(0.0), 0.0);
        assert_eq!(f(-3.0), 0.0);
        assert_eq!(f(f64::NAN), 0.0);
        assert_eq!(f(f64::INFINITY), 1.0);
        assert_eq!(f(1e300), 1.0);
        // Near 0 the toe's slope is 0.03 / 0.14.
        assert!((f(1e-9) / 1e-9 - 0.03 / 0.14).abs() < 1e-6);
    }

    #[test]
    fn clip_keeps_linear_values_and_names_parse() {
        assert_eq!(ToneMap::Clip.apply(0.25), 0.25);
        assert_eq!(ToneMap::Clip.apply(7.0), 1.0);
        assert_eq!(ToneMap::Clip.apply(f64::NAN), 0.0);
        assert_eq!("filmic".parse(), Ok(ToneMap::Filmic));
        assert_eq!("clip".parse(), Ok(ToneMap::Clip));
        assert!(
            "aces"
                .parse::<ToneMap>()
                .unwrap_err()
                .contains("filmic or clip")
        );
    }
}
