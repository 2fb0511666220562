//! zstd-coded parts of the asset (its header's JSON, a residual block's lossless values,
//! the RBF blocks of format 3): coded at one level, and decoded only when the frame's
//! declared size is plausible, so a damaged block cannot make a reader allocate gigabytes.

/// zstd's level for coded blocks: its strongest regular level (decoding speed does not
/// depend on it; a 27-frame hash volume of 128³ frames codes in well under a second).
pub const LEVEL: i32 = 19;

/// The largest ratio of plain to coded bytes a block may claim (no real data comes near
/// it: JSON headers code at about 3:1, lossless residual values at 1–2:1).
pub const RATIO: u64 = 1024;

/// `plain`, coded as one zstd frame that records its size.
pub fn deflate(plain: &[u8]) -> Vec<u8> {
    deflate_with(plain, &[])
}

/// `plain`, coded as one zstd frame that records its size, against `dictionary` (zstd's
/// raw-content dictionary: bytes the frame may refer back to as if they came before it;
/// empty for none). The same dictionary must be given to [`inflate_with`].
pub fn deflate_with(plain: &[u8], dictionary: &[u8]) -> Vec<u8> {
    zstd::bulk::Compressor::with_dictionary(LEVEL, dictionary)
        .and_then(|mut c| c.compress(plain))
        .expect("zstd codes any bytes at a valid level")
}

/// The zstd frame `coded`, decoded: its declared size must be known, at most `most` and
/// within [`RATIO`]× the coded bytes (plus 4 KiB), else the frame is refused unread.
pub fn inflate(coded: &[u8], most: usize) -> Result<Vec<u8>, String> {
    inflate_with(coded, most, &[])
}

/// [`inflate`] of a frame [`deflate_with`] coded against `dictionary`.
pub fn inflate_with(coded: &[u8], most: usize, dictionary: &[u8]) -> Result<Vec<u8>, String> {
    let size = zstd::zstd_safe::get_frame_content_size(coded)
        .ok()
        .flatten()
        .ok_or("its coded part has no zstd frame size")?;
    let cap = (most as u64).min(RATIO * coded.len() as u64 + 4096);
    if size > cap {
        return Err(format!(
            "its coded part claims {size} bytes (at most {cap})"
        ));
    }
    zstd::bulk::Decompressor::with_dictionary(dictionary)
        .and_then(|mut d| d.decompress(coded, size as usize))
        .map_err(|e| format!("its coded part does not decompress ({e})"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round trips; a frame claiming more than the caller allows, or more than RATIO× its
    /// bytes (a megabyte of zeros codes to a few dozen bytes), is refused before any
    /// allocation; a cut frame is refused. (Flipped bits inside a frame are the asset's
    /// per-block CRC-32's to catch: zstd frames carry no checksum here.)
    #[test]
    fn frames_round_trip_and_implausible_sizes_are_refused() {
        let plain: Vec<u8> = (0..5000u32).map(|i| (i * 7 % 251) as u8).collect();
        let coded = deflate(&plain);
        assert_eq!(inflate(&coded, plain.len()).unwrap(), plain);
        assert!(
            inflate(&coded, plain.len() - 1)
                .unwrap_err()
                .contains("claims")
        );
        let zeros = deflate(&vec![0u8; 1 << 20]);
        assert!(zeros.len() < 1024);
        assert!(inflate(&zeros, usize::MAX).unwrap_err().contains("at most"));
        assert!(inflate(&coded[..4], plain.len()).is_err());
        assert!(inflate(&coded[..coded.len() - 3], plain.len()).is_err());
        assert!(inflate(&[], 10).is_err());
    }

    /// A dictionary that shares the text's words shrinks it, and the frame reads back only
    /// with that dictionary.
    #[test]
    fn dictionaries_shrink_what_they_share() {
        let dictionary = br#"{"generator":"haze","settings":{"fit":{"rbfs":300,"seed":1}}}"#;
        let plain = br#"{"generator":"haze","settings":{"fit":{"rbfs":450,"seed":1}}}"#;
        let with = deflate_with(plain, dictionary);
        assert!(with.len() < deflate(plain).len(), "{} bytes", with.len());
        assert_eq!(inflate_with(&with, plain.len(), dictionary).unwrap(), plain);
        assert_ne!(
            inflate(&with, plain.len()).ok().as_deref(),
            Some(&plain[..])
        );
    }
}
