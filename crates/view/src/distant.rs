//! Distant radiance `L(ω)`: a lat-long map or the built-in sky (what [`crate::env`] lights
//! with, beside its suns and point lights).
//!
//! Lat-long convention (docs/conventions.md), Z up: pixel column `u ∈ [0,1)` → azimuth `φ = 2πu`
//! from +X towards +Y; row `v ∈ [0,1]` → polar angle `θ = πv` from +Z (row 0 is the
//! zenith). Values are linear RGB radiance, looked up bilinearly between pixel centers
//! (wrapping in azimuth, clamped at the poles).

use std::f64::consts::PI;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

pub use haze_core::Rgb;
pub use turn::Layout;

mod turn;

/// Unit direction of polar angle `theta` (from +Z) and azimuth `phi` (from +X to +Y).
pub fn direction(theta: f64, phi: f64) -> [f64; 3] {
    let s = theta.sin();
    [s * phi.cos(), s * phi.sin(), theta.cos()]
}

/// `(θ, φ)` of a direction (need not be normalized; the zero vector gives the zenith).
pub fn angles(d: [f64; 3]) -> (f64, f64) {
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if n <= 0.0 || !n.is_finite() {
        return (0.0, 0.0);
    }
    let theta = (d[2] / n).clamp(-1.0, 1.0).acos();
    let mut phi = d[1].atan2(d[0]);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    (theta, phi)
}

/// The file formats a lat-long map is read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapFormat {
    /// OpenEXR (`.exr`).
    OpenExr,
    /// Radiance RGBE (`.hdr`).
    RadianceHdr,
}

impl MapFormat {
    /// The format's name as users know it.
    pub fn name(self) -> &'static str {
        match self {
            MapFormat::OpenExr => "OpenEXR",
            MapFormat::RadianceHdr => "Radiance HDR",
        }
    }

    /// The format of the file `reader` reads (at its start, nothing consumed): Radiance
    /// files begin `#?`, anything else is taken for OpenEXR (whose reader names what is
    /// wrong with it).
    pub fn sniff(path: &Path, reader: &mut BufReader<File>) -> Result<MapFormat, EnvError> {
        Ok(if peek(path, reader, 2)?.starts_with(b"#?") {
            MapFormat::RadianceHdr
        } else {
            MapFormat::OpenExr
        })
    }
}

fn cannot_read(path: &Path, e: std::io::Error) -> EnvError {
    EnvError {
        path: path.display().to_string(),
        problem: format!("cannot read it ({e})"),
    }
}

fn open_map(path: &Path) -> Result<BufReader<File>, EnvError> {
    File::open(path)
        .map(BufReader::new)
        .map_err(|e| cannot_read(path, e))
}

/// Up to `n` of the reader's next bytes, left unconsumed (fewer at the end of the file).
fn peek<'r>(path: &Path, reader: &'r mut BufReader<File>, n: usize) -> Result<&'r [u8], EnvError> {
    let buf = reader.fill_buf().map_err(|e| cannot_read(path, e))?;
    Ok(&buf[..n.min(buf.len())])
}

/// The most texels [`LatLong::load_hdr`] reads (2²⁸, 3 GiB of RGB f32): a header that
/// claims more is refused before anything is allocated.
pub const MAX_HDR_TEXELS: usize = 1 << 28;

/// The largest texel value a map may hold. A sky is far below it (the sun's disk is about
/// `1.6·10⁹` cd/m²), and it leaves eight orders of magnitude under `f32::MAX` (`3.4·10³⁸`)
/// for the renderer's `f32` sums of texels times phase, solid angle and transmittance: a
/// map of texels near `f32::MAX` made pictures of NaN.
pub const MAX_RADIANCE: f32 = 1e30;

/// A lat-long environment map.
#[derive(Clone, Debug, PartialEq)]
pub struct LatLong {
    pub width: usize,
    pub height: usize,
    /// Row-major from the top row (the zenith), `width × height` texels.
    pub texels: Vec<[f32; 3]>,
}

/// Why an environment map cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {problem}")]
pub struct EnvError {
    pub path: String,
    pub problem: String,
}

impl LatLong {
    /// A map from texels (row 0 = zenith); refuses empty maps and non-finite, negative or
    /// over [`MAX_RADIANCE`] radiance.
    pub fn new(width: usize, height: usize, texels: Vec<[f32; 3]>) -> Result<Self, String> {
        if width == 0 || height == 0 {
            return Err(format!(
                "environment map of {width}×{height} texels is empty"
            ));
        }
        if texels.len() != width * height {
            return Err(format!(
                "{} texels for a {width}×{height} map",
                texels.len()
            ));
        }
        if let Some(i) = texels
            .iter()
            .position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0))
        {
            return Err(format!(
                "texel ({}, {}) is {:?}: radiance must be finite and non-negative",
                i % width,
                i / width,
                texels[i]
            ));
        }
        if let Some(i) = texels
            .iter()
            .position(|t| t.iter().any(|c| *c > MAX_RADIANCE))
        {
            return Err(format!(
                "texel ({}, {}) is {:?}: radiance above {MAX_RADIANCE:e} is beyond any sky and past what the renderer's sums hold (scale the map down)",
                i % width,
                i / width,
                texels[i]
            ));
        }
        Ok(LatLong {
            width,
            height,
            texels,
        })
    }

    /// Reads a lat-long map from an OpenEXR file ([`LatLong::load_exr`]) or a Radiance
    /// `.hdr` (RGBE) file ([`LatLong::load_hdr`]), told apart by their first bytes
    /// ([`MapFormat::sniff`]; the name's extension is not trusted: downloaded maps are often
    /// renamed). The file is opened once.
    pub fn load(path: &Path) -> Result<Self, EnvError> {
        Ok(Self::load_with_format(path)?.0)
    }

    /// [`LatLong::load`], and the format the file was read as.
    pub fn load_with_format(path: &Path) -> Result<(Self, MapFormat), EnvError> {
        let mut reader = open_map(path)?;
        let format = MapFormat::sniff(path, &mut reader)?;
        let map = match format {
            MapFormat::RadianceHdr => Self::read_hdr(path, reader),
            MapFormat::OpenExr => Self::read_exr(path, reader),
        }?;
        Ok((map, format))
    }

    /// Reads a Radiance `.hdr` (RGBE, `FORMAT=32-bit_rle_rgbe`) file through the `image`
    /// crate: the texels as stored, `c·2^(e−136)` per channel (an `EXPOSURE` line is not
    /// applied; `-v` says when one is there). Files signed `#?RGBE` instead of
    /// `#?RADIANCE` are read too; XYZE files and orientations other than the standard
    /// `-Y H +X W` (row 0 at the top) are refused.
    pub fn load_hdr(path: &Path) -> Result<Self, EnvError> {
        Self::read_hdr(path, open_map(path)?)
    }

    fn read_hdr(path: &Path, mut reader: BufReader<File>) -> Result<Self, EnvError> {
        use image::ImageDecoder;
        use image::codecs::hdr::{HdrDecoder, SIGNATURE};
        let err = |problem: String| EnvError {
            path: path.display().to_string(),
            problem,
        };
        // The standard signature is checked strictly; `#?RGBE` and others leniently.
        let strict = peek(path, &mut reader, SIGNATURE.len())?.starts_with(SIGNATURE);
        let bad = |e: image::ImageError| err(format!("not a readable Radiance .hdr image ({e})"));
        let decoder = HdrDecoder::with_strictness(reader, strict).map_err(bad)?;
        let meta = decoder.metadata();
        if let Some(k) = meta.exposure.filter(|&k| k != 1.0) {
            tracing::info!(
                "{}: EXPOSURE={k} in its header is not applied (texels read as stored)",
                path.display()
            );
        }
        let (w, h) = (meta.width as usize, meta.height as usize);
        if w.saturating_mul(h) > MAX_HDR_TEXELS {
            return Err(err(format!(
                "a {w}×{h} map is over the {MAX_HDR_TEXELS} texels read (a 16k map has 134 M)"
            )));
        }
        // Decoded straight into the texels: RGB f32 in native byte order.
        let mut texels = vec![[0.0f32; 3]; w * h];
        decoder
            .read_image(bytemuck::cast_slice_mut(&mut texels))
            .map_err(bad)?;
        LatLong::new(w, h, texels).map_err(err)
    }

    /// Reads the first RGB(A) layer of an OpenEXR file.
    pub fn load_exr(path: &Path) -> Result<Self, EnvError> {
        Self::read_exr(path, open_map(path)?)
    }

    fn read_exr(path: &Path, reader: BufReader<File>) -> Result<Self, EnvError> {
        use exr::prelude::*;
        let err = |problem: String| EnvError {
            path: path.display().to_string(),
            problem,
        };
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .rgba_channels(
                |res, _| {
                    let (w, h) = (res.width(), res.height());
                    (w, h, vec![[0.0f32; 3]; w * h])
                },
                |(w, _, px): &mut (usize, usize, Vec<[f32; 3]>),
                 pos,
                 (r, g, b, _a): (f32, f32, f32, f32)| {
                    px[pos.y() * *w + pos.x()] = [r, g, b];
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(reader)
            .map_err(|e| err(format!("not a readable RGB OpenEXR image ({e})")))?;
        let (w, h, px) = image.layer_data.channel_data.pixels;
        LatLong::new(w, h, px).map_err(err)
    }

    fn texel(&self, x: usize, y: usize) -> Rgb {
        let t = self.texels[y * self.width + x];
        [f64::from(t[0]), f64::from(t[1]), f64::from(t[2])]
    }

    /// Radiance arriving from direction `d` (bilinear between pixel centers).
    pub fn radiance(&self, d: [f64; 3]) -> Rgb {
        let (theta, phi) = angles(d);
        let (w, h) = (self.width as f64, self.height as f64);
        // Continuous texel coordinates with centers at integers.
        bilinear(
            self.width,
            self.height,
            phi / (2.0 * PI) * w - 0.5,
            theta / PI * h - 0.5,
            |x, y| self.texel(x, y),
        )
    }

    /// Direction through the center of texel `(x, y)` and the texel's solid angle.
    pub fn texel_direction(&self, x: usize, y: usize) -> ([f64; 3], f64) {
        let (w, h) = (self.width as f64, self.height as f64);
        let phi = 2.0 * PI * (x as f64 + 0.5) / w;
        let (t0, t1) = (PI * y as f64 / h, PI * (y as f64 + 1.0) / h);
        let solid = (2.0 * PI / w) * (t0.cos() - t1.cos());
        (direction(0.5 * (t0 + t1), phi), solid)
    }
}

/// The bilinear interpolation between the centers of a `width × height` lat-long grid at
/// continuous texel coordinates `(fx, fy)` (centers at integers), wrapping in azimuth and
/// clamped at the poles; `texel(x, y)` gives a texel's value.
pub fn bilinear(
    width: usize,
    height: usize,
    fx: f64,
    fy: f64,
    texel: impl Fn(usize, usize) -> Rgb,
) -> Rgb {
    let (w, h) = (width as f64, height as f64);
    let fy = fy.clamp(0.0, h - 1.0);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let xi = |x: f64| (x.rem_euclid(w) as usize).min(width - 1);
    let (xa, xb) = (xi(x0), xi(x0 + 1.0));
    let ya = y0 as usize;
    let yb = (ya + 1).min(height - 1);
    let mut out = [0.0; 3];
    for (x, y, wgt) in [
        (xa, ya, (1.0 - tx) * (1.0 - ty)),
        (xb, ya, tx * (1.0 - ty)),
        (xa, yb, (1.0 - tx) * ty),
        (xb, yb, tx * ty),
    ] {
        let t = texel(x, y);
        for c in 0..3 {
            out[c] += wgt * t[c];
        }
    }
    out
}

/// The built-in sky: a smooth, band-limited-looking sky that SH of low order represent
/// well, so that it serves both the viewer and accuracy comparisons. Above the horizon it
/// blends `horizon` to `zenith` with `cos θ`, plus a broad sun glow
/// `sun · max(0, ω·s)^sharpness` (the sky's aureole); below, a constant `ground`, which
/// the glow does not reach (an earth: a low sun's glow lit a fifth of the sky's light
/// from below the horizon, 3.6 % at the built-in sun's 25°).
#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    pub zenith: Rgb,
    pub horizon: Rgb,
    pub ground: Rgb,
    /// Unit direction towards the sun.
    pub sun_direction: [f64; 3],
    pub sun: Rgb,
    pub sharpness: f64,
}

impl Default for Sky {
    fn default() -> Self {
        let s: [f64; 3] = [0.5, 0.3, 0.8];
        let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        Sky {
            zenith: [0.25, 0.45, 0.9],
            horizon: [0.8, 0.85, 0.9],
            ground: [0.25, 0.22, 0.2],
            sun_direction: [s[0] / n, s[1] / n, s[2] / n],
            sun: [4.0, 3.6, 3.0],
            sharpness: 8.0,
        }
    }
}

impl Sky {
    pub fn radiance(&self, d: [f64; 3]) -> Rgb {
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if n <= 0.0 || !n.is_finite() {
            return self.zenith;
        }
        let d = [d[0] / n, d[1] / n, d[2] / n];
        if d[2] < 0.0 {
            return self.ground;
        }
        let t = d[2];
        let mut out = [0, 1, 2].map(|c| self.horizon[c] * (1.0 - t) + self.zenith[c] * t);
        let s = self.sun_direction;
        let c = (d[0] * s[0] + d[1] * s[1] + d[2] * s[2]).max(0.0);
        let glow = c.powf(self.sharpness);
        for (o, s) in out.iter_mut().zip(self.sun) {
            *o += s * glow;
        }
        out
    }
}

/// Distant radiance: what a ray sees where it leaves the scene, apart from the suns.
#[derive(Clone, Debug, PartialEq)]
pub enum Distant {
    Sky(Sky),
    Map(LatLong),
}

impl Distant {
    /// Radiance arriving from direction `d` (pointing away from the scene).
    pub fn radiance(&self, d: [f64; 3]) -> Rgb {
        match self {
            Distant::Sky(s) => s.radiance(d),
            Distant::Map(m) => m.radiance(d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_invert_direction() {
        for &(t, p) in &[(0.3, 0.1), (1.5, 3.0), (2.9, 6.0), (PI / 2.0, PI)] {
            let (t2, p2) = angles(direction(t, p));
            assert!((t - t2).abs() < 1e-12 && (p - p2).abs() < 1e-12, "{t} {p}");
        }
        assert_eq!(angles([0.0, 0.0, 0.0]), (0.0, 0.0));
    }

    #[test]
    fn texel_centers_return_their_texel_and_solid_angles_sum_to_4pi() {
        let (w, h) = (8, 4);
        let texels: Vec<[f32; 3]> = (0..w * h).map(|i| [i as f32, 0.0, 1.0]).collect();
        let m = LatLong::new(w, h, texels).unwrap();
        let mut total = 0.0;
        for y in 0..h {
            for x in 0..w {
                let (d, s) = m.texel_direction(x, y);
                total += s;
                let r = m.radiance(d);
                assert!((r[0] - (y * w + x) as f64).abs() < 1e-9, "{x} {y} {r:?}");
            }
        }
        assert!((total - 4.0 * PI).abs() < 1e-12);
        // Halfway between two texel centers of a row: their mean (wrapping at φ = 0).
        let r = m.radiance(direction(PI * 0.375, 0.0));
        assert!((r[0] - 0.5 * (8.0 + 15.0)).abs() < 1e-9, "{r:?}");
    }

    #[test]
    fn bad_maps_are_refused() {
        assert!(LatLong::new(0, 4, vec![]).is_err());
        assert!(LatLong::new(1, 1, vec![[f32::NAN, 0.0, 0.0]]).is_err());
        assert!(LatLong::new(1, 1, vec![[-1.0, 0.0, 0.0]]).is_err());
        assert!(LatLong::new(2, 1, vec![[1.0, 0.0, 0.0]]).is_err());
        // The largest radiance is the limit itself; the next value up is refused, naming
        // its texel.
        assert!(LatLong::new(1, 1, vec![[MAX_RADIANCE; 3]]).is_ok());
        let over = f32::from_bits(MAX_RADIANCE.to_bits() + 1);
        let e = LatLong::new(2, 1, vec![[1.0; 3], [0.0, over, 0.0]]).unwrap_err();
        assert!(e.starts_with("texel (1, 0)") && e.contains("1e30"), "{e}");
    }

    #[test]
    fn sky_is_continuous_at_the_horizon_from_above_and_positive() {
        let s = Sky::default();
        let up = s.radiance([1.0, 0.0, 1e-9]);
        assert!(up.iter().all(|v| *v > 0.0));
        let z = s.radiance([0.0, 0.0, 1.0]);
        assert!(z[2] > z[0], "{z:?}");
        assert_eq!(s.radiance([0.0; 3]), s.zenith);
    }

    /// A Radiance file of `texels` (RGBE, flat scanlines) under `signature` with the
    /// header lines `extra`.
    fn write_rgbe(path: &Path, signature: &str, extra: &str, w: usize, texels: &[[u8; 4]]) {
        let mut bytes = format!(
            "{signature}\nFORMAT=32-bit_rle_rgbe\n{extra}\n-Y {} +X {w}\n",
            texels.len() / w
        )
        .into_bytes();
        bytes.extend(texels.iter().flatten());
        std::fs::write(path, bytes).unwrap();
    }

    /// RGBE texels decode to `c·2^(e−136)` (values chosen exact in both), under either
    /// signature, with an EXPOSURE line left unapplied; `load` tells the formats apart by
    /// their bytes, not their names; a broken header is one message naming the format.
    #[test]
    fn radiance_hdr_maps_read_as_stored() {
        let dir = tempfile::tempdir().unwrap();
        let texels = [
            [128, 64, 32, 129],  // 1, 0.5, 0.25
            [192, 0, 255, 130],  // 3, 0, 3.984375
            [80, 112, 160, 128], // 0.3125, 0.4375, 0.625
            [0, 0, 0, 0],        // e = 0 is black
        ];
        let want = [
            [1.0, 0.5, 0.25],
            [3.0, 0.0, 3.984375],
            [0.3125, 0.4375, 0.625],
            [0.0; 3],
        ];
        for (signature, extra) in [("#?RADIANCE", ""), ("#?RGBE", "EXPOSURE=2.5\n")] {
            let path = dir.path().join("sky.hdr");
            write_rgbe(&path, signature, extra, 2, &texels);
            let map = LatLong::load(&path).unwrap();
            assert_eq!((map.width, map.height), (2, 2), "{signature}");
            assert_eq!(map.texels, want, "{signature}");
        }
        // An OpenEXR file named .hdr is still read as OpenEXR.
        let renamed = dir.path().join("renamed.hdr");
        let mut im = crate::Image::new(2, 1);
        im.pixels = vec![[0.5, 1.5, 2.5], [3.0, 0.0, 1.0]];
        im.write_exr(&renamed).unwrap();
        assert_eq!(LatLong::load(&renamed).unwrap().texels, im.pixels);
        let broken = dir.path().join("broken.hdr");
        std::fs::write(&broken, "#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 2\n").unwrap();
        let e = LatLong::load(&broken).unwrap_err();
        assert!(
            e.to_string()
                .contains("broken.hdr: not a readable Radiance .hdr image"),
            "{e}"
        );
        let huge = dir.path().join("huge.hdr");
        std::fs::write(
            &huge,
            "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16384 +X 32768\n",
        )
        .unwrap();
        let e = LatLong::load(&huge).unwrap_err();
        assert!(
            e.to_string().contains("a 32768×16384 map is over the"),
            "{e}"
        );
        let missing = LatLong::load(&dir.path().join("none.hdr")).unwrap_err();
        assert!(
            missing.to_string().contains("none.hdr: cannot read it"),
            "{missing}"
        );
    }

    #[test]
    fn exr_round_trips_linear_values_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let mut im = crate::Image::new(5, 3);
        for (i, p) in im.pixels.iter_mut().enumerate() {
            *p = [i as f32 * 0.25, 1.0, 0.5 / (1.0 + i as f32)];
        }
        im.write_exr(&path).unwrap();
        let back = LatLong::load_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (5, 3));
        assert_eq!(back.texels, im.pixels);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temp file left"
        );
    }
}
