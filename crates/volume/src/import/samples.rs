//! The sample types a raw or NumPy volume may hold, and how each becomes a density.
//!
//! Floats (16, 32 and 64 bits) are read as they are. Unsigned 8- and 16-bit integers are
//! read as fractions of their largest value (`v / 255`, `v / 65535`), as image tools read
//! normalized integer formats: an 8-bit export of a density in `[0, 1]` comes back in
//! `[0, 1]` (to within half a step, `1/510`), so the extinction a user sets means the same
//! for it as for the float original. Signed integers and wider ones are refused: their
//! scale is not known.

/// A supported sample type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleType {
    F16,
    F32,
    F64,
    U8,
    U16,
}

/// The supported types in words, for errors.
pub const SUPPORTED: &str =
    "float16, float32, float64, uint8 or uint16 (the integers read as fractions of 255 / 65535)";

impl SampleType {
    /// Bytes a sample.
    pub fn size(self) -> usize {
        match self {
            SampleType::U8 => 1,
            SampleType::F16 | SampleType::U16 => 2,
            SampleType::F32 => 4,
            SampleType::F64 => 8,
        }
    }

    /// NumPy's name of the type.
    pub fn name(self) -> &'static str {
        match self {
            SampleType::F16 => "float16",
            SampleType::F32 => "float32",
            SampleType::F64 => "float64",
            SampleType::U8 => "uint8",
            SampleType::U16 => "uint16",
        }
    }

    /// How samples of this type become densities, in words (`inspect`).
    pub fn reading(self) -> &'static str {
        match self {
            SampleType::F16 => "float16",
            SampleType::F32 => "float32",
            SampleType::F64 => "float64, read as float32",
            SampleType::U8 => "uint8, read as fractions of 255",
            SampleType::U16 => "uint16, read as fractions of 65535",
        }
    }

    /// The type a sidecar's `dtype` names, little-endian: NumPy's codes (`<f4`, `f4`,
    /// `|u1`, `<u2`, `<f2`, `<f8`) or words (`float32`, `"float32 little-endian"`,
    /// `uint8`, `uint16`, `float16`, `half`, `float64`, `double`). `None` for anything
    /// else, big-endian included.
    pub fn from_sidecar(dtype: &str) -> Option<SampleType> {
        let d = dtype.trim().to_ascii_lowercase();
        if d.starts_with('>') || d.contains("big") {
            return None;
        }
        const NAMES: [(SampleType, &[&str]); 5] = [
            (SampleType::F16, &["f2", "float16", "half"]),
            (SampleType::F32, &["f4", "float32", "float", "single"]),
            (SampleType::F64, &["f8", "float64", "double"]),
            (SampleType::U8, &["u1", "uint8", "u8"]),
            (SampleType::U16, &["u2", "uint16", "u16"]),
        ];
        d.split(|c: char| !c.is_ascii_alphanumeric())
            .filter(|t| !t.is_empty())
            .find_map(|t| {
                NAMES
                    .iter()
                    .find(|(_, names)| names.contains(&t))
                    .map(|&(ty, _)| ty)
            })
    }

    /// The densities of little-endian samples (`bytes.len()` a multiple of
    /// [`SampleType::size`]; a trailing part sample is ignored).
    pub fn decode_le(self, bytes: &[u8]) -> Vec<f32> {
        match self {
            SampleType::F16 => bytes
                .chunks_exact(2)
                .map(|c| half::f16::from_le_bytes([c[0], c[1]]).to_f32())
                .collect(),
            SampleType::F32 => bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
            SampleType::F64 => bytes
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f32)
                .collect(),
            SampleType::U8 => bytes.iter().map(|&v| unorm8(v)).collect(),
            SampleType::U16 => bytes
                .chunks_exact(2)
                .map(|c| unorm16(u16::from_le_bytes([c[0], c[1]])))
                .collect(),
        }
    }
}

/// An 8-bit sample as a fraction of 255.
pub fn unorm8(v: u8) -> f32 {
    f32::from(v) / 255.0
}

/// A 16-bit sample as a fraction of 65535.
pub fn unorm16(v: u16) -> f32 {
    f32::from(v) / 65535.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sidecar_names() {
        for (d, want) in [
            ("<f4", Some(SampleType::F32)),
            ("f4", Some(SampleType::F32)),
            ("float32 little-endian", Some(SampleType::F32)),
            ("Float32", Some(SampleType::F32)),
            ("|u1", Some(SampleType::U8)),
            ("uint8", Some(SampleType::U8)),
            ("<u2", Some(SampleType::U16)),
            ("uint16 little-endian", Some(SampleType::U16)),
            ("<f2", Some(SampleType::F16)),
            ("half", Some(SampleType::F16)),
            ("<f8", Some(SampleType::F64)),
            (">f4", None),
            ("float32 big-endian", None),
            ("<i4", None),
            ("int16", None),
            ("", None),
        ] {
            assert_eq!(SampleType::from_sidecar(d), want, "{d:?}");
        }
    }

    /// Each type's decoding against values written independently (`to_le_bytes`, the
    /// IEEE half-precision bit patterns of 1, −2 and 65504), the integers' ends included.
    #[test]
    fn decodes_little_endian_samples() {
        let f32s: Vec<u8> = [0.5f32, -3.25, 1e30]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(SampleType::F32.decode_le(&f32s), vec![0.5, -3.25, 1e30]);
        let f64s: Vec<u8> = [0.125f64, 2.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(SampleType::F64.decode_le(&f64s), vec![0.125, 2.0]);
        let halves: Vec<u8> = [0x3c00u16, 0xc000, 0x7bff]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(SampleType::F16.decode_le(&halves), vec![1.0, -2.0, 65504.0]);
        assert_eq!(SampleType::U8.decode_le(&[0, 51, 255]), vec![0.0, 0.2, 1.0]);
        let u16s: Vec<u8> = [0u16, 13107, 65535]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(SampleType::U16.decode_le(&u16s), vec![0.0, 0.2, 1.0]);
    }
}
