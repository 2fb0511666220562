//! The picture size argument `WxH` that `haze view` and `haze render` take.

/// The longest side of a picture, in pixels.
pub(crate) const MAX_SIDE: usize = 8192;

/// Parses a render size `WxH` (or `W×H`), each side 1..=[`MAX_SIDE`] pixels.
pub(crate) fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("'{s}' is not a size WxH (e.g. 800x600)");
    let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let side = |t: &str| {
        t.trim()
            .parse::<usize>()
            .ok()
            .filter(|n| (1..=MAX_SIDE).contains(n))
    };
    match (side(w), side(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("{}: sides must be 1 to {MAX_SIDE} pixels", bad())),
    }
}

/// Parses one side (`--width`, `--height`): 1..=[`MAX_SIDE`] pixels.
pub(crate) fn parse_side(s: &str) -> Result<usize, String> {
    s.trim()
        .parse::<usize>()
        .ok()
        .filter(|n| (1..=MAX_SIDE).contains(n))
        .ok_or_else(|| format!("'{s}' is not a side of 1 to {MAX_SIDE} pixels"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_bad_ones_say_why() {
        assert_eq!(parse_size("800x600"), Ok((800, 600)));
        assert_eq!(parse_size("64×48"), Ok((64, 48)));
        assert_eq!(parse_size(" 3 X 2 "), Ok((3, 2)));
        for bad in ["800", "0x600", "800x", "x600", "9000x10", "-1x5", "axb"] {
            let e = parse_size(bad).unwrap_err();
            assert!(e.contains(bad) && e.contains("WxH"), "{bad}: {e}");
        }
        assert_eq!(parse_side("1"), Ok(1));
        assert_eq!(parse_side("8192"), Ok(8192));
        for bad in ["0", "8193", "-3", "1.5", ""] {
            let e = parse_side(bad).unwrap_err();
            assert!(
                e.contains(&format!("'{bad}'")) && e.contains("8192"),
                "{bad}: {e}"
            );
        }
    }
}
