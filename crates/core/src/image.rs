//! Rendered images: linear RGB radiance per pixel (row 0 is the top), the relative RMS
//! image error of docs/conventions.md (`rel_rms`), and writing as OpenEXR (linear `f32`)
//! or PNG (tone-mapped).
//! Both writers go through a temporary file beside the destination that is renamed into
//! place, so a reader never sees a half-written image.

use crate::ToneMap;
use rayon::prelude::*;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Linear RGB radiance, `width × height` pixels, row-major from the top row.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 3]>,
}

/// Why an image could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {problem}")]
pub struct ImageError {
    pub path: String,
    pub problem: String,
}

/// A rendered picture that holds NaN or infinite values ([`Image::check_finite`]).
#[derive(Debug)]
pub struct NonFinite {
    pub stage: String,
    pub values: usize,
    pub total: usize,
    /// The first such pixel, `(x, y)` with row 0 on top.
    pub first: (usize, usize),
}

impl std::fmt::Display for NonFinite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} made {} of {} values NaN or infinite (the first at pixel {}, {}); no picture written",
            self.stage, self.values, self.total, self.first.0, self.first.1
        )
    }
}

impl std::error::Error for NonFinite {}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize) -> Image {
        Image {
            width,
            height,
            pixels: vec![[0.0; 3]; width * height],
        }
    }

    /// The `width × height` image of `pixel(x, y)` (linear radiance in `f64`, kept in
    /// `f32`), its rows computed in parallel; `progress` hears how many rows are done
    /// each time one finishes (in any order).
    pub fn by_rows(
        width: usize,
        height: usize,
        progress: &(dyn Fn(usize) + Sync),
        pixel: impl Fn(usize, usize) -> [f64; 3] + Sync,
    ) -> Image {
        let done = AtomicUsize::new(0);
        let rows: Vec<Vec<[f32; 3]>> = (0..height)
            .into_par_iter()
            .map(|y| {
                let row = (0..width).map(|x| pixel(x, y).map(|c| c as f32)).collect();
                progress(done.fetch_add(1, Ordering::Relaxed) + 1);
                row
            })
            .collect();
        Image {
            width,
            height,
            pixels: rows.into_iter().flatten().collect(),
        }
    }

    /// Pixel `(x, y)`, `y = 0` being the top row.
    pub fn get(&self, x: usize, y: usize) -> [f32; 3] {
        self.pixels[y * self.width + x]
    }

    /// The image error of docs/conventions.md: the RMS over pixels of the linear radiance difference (all
    /// three channels) divided by the RMS of `reference`,
    /// `sqrt(Σ|self − ref|²) / sqrt(Σ|ref|²)`. A black reference gives 0 for an identical
    /// image and `+∞` otherwise.
    ///
    /// # Panics
    /// If the two images differ in size.
    pub fn rel_rms(&self, reference: &Image) -> f64 {
        assert_eq!(
            (self.width, self.height),
            (reference.width, reference.height),
            "rel_rms of images of different sizes"
        );
        let (mut diff, mut norm) = (0.0f64, 0.0f64);
        for (a, b) in self.pixels.iter().zip(&reference.pixels) {
            for c in 0..3 {
                let (a, b) = (f64::from(a[c]), f64::from(b[c]));
                diff += (a - b) * (a - b);
                norm += b * b;
            }
        }
        if norm > 0.0 {
            (diff / norm).sqrt()
        } else if diff == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    }

    /// Refuses a picture holding a NaN or an infinite value: the error names `stage`, the
    /// renderer that made it, how many values are not finite and the first pixel (row 0
    /// on top). Called before any image is written, so no NaN ever reaches a file.
    pub fn check_finite(&self, stage: &str) -> Result<(), NonFinite> {
        let bad = self
            .pixels
            .iter()
            .map(|p| p.iter().filter(|c| !c.is_finite()).count())
            .sum::<usize>();
        if bad == 0 {
            return Ok(());
        }
        let first = self
            .pixels
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
            .unwrap_or(0);
        Err(NonFinite {
            stage: stage.to_string(),
            values: bad,
            total: 3 * self.pixels.len(),
            first: (first % self.width.max(1), first / self.width.max(1)),
        })
    }

    /// The writers' last guard: a picture with a non-finite value is not written (the
    /// renderers check first, naming their stage).
    fn writable(&self, path: &Path) -> Result<(), ImageError> {
        self.check_finite("the renderer").map_err(|e| ImageError {
            path: path.display().to_string(),
            problem: e.to_string(),
        })
    }

    /// Reads an RGB OpenEXR image (the first layer; alpha ignored, a missing channel 0),
    /// such as [`Image::write_exr`] writes.
    pub fn read_exr(path: &Path) -> Result<Image, ImageError> {
        use exr::prelude::read_first_rgba_layer_from_file;
        let read = read_first_rgba_layer_from_file(
            path,
            |size, _| Image::new(size.width(), size.height()),
            |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let i = pos.y() * img.width + pos.x();
                img.pixels[i] = [r, g, b];
            },
        )
        .map_err(|e| ImageError {
            path: path.display().to_string(),
            problem: format!("cannot read OpenEXR ({e})"),
        })?;
        Ok(read.layer_data.channel_data.pixels)
    }

    /// Writes linear RGB `f32` OpenEXR.
    pub fn write_exr(&self, path: &Path) -> Result<(), ImageError> {
        use exr::prelude::{Image as ExrImage, SpecificChannels, Vec2, WritableImage};
        let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let p = self.get(x, y);
            (p[0], p[1], p[2])
        });
        let image = ExrImage::from_channels((self.width, self.height), channels);
        self.writable(path)?;
        write_atomically(path, |out| {
            image
                .write()
                .to_buffered(out)
                .map_err(|e| format!("cannot encode OpenEXR ({e})"))
        })
    }

    /// The 8-bit sRGB encoding of the image, three bytes per pixel in pixel order: each
    /// linear channel is multiplied by `exposure`, taken through the tone curve `tone`
    /// ([`ToneMap`]: with [`ToneMap::Clip`] a linear value `1/exposure` is white) and
    /// encoded with the sRGB transfer function. What [`Image::write_png`] writes and the
    /// viewer shows; pixels are converted in parallel.
    pub fn to_srgb8(&self, exposure: f64, tone: ToneMap) -> Vec<u8> {
        let mut bytes = vec![0u8; 3 * self.pixels.len()];
        bytes
            .par_chunks_mut(3)
            .zip(self.pixels.par_iter())
            .for_each(|(out, p)| {
                for (o, c) in out.iter_mut().zip(p) {
                    *o = srgb8(tone.apply(f64::from(*c) * exposure));
                }
            });
        bytes
    }

    /// Writes an 8-bit sRGB PNG of [`Image::to_srgb8`].
    pub fn write_png(&self, path: &Path, exposure: f64, tone: ToneMap) -> Result<(), ImageError> {
        self.writable(path)?;
        if !(exposure.is_finite() && exposure > 0.0) {
            return Err(ImageError {
                path: path.display().to_string(),
                problem: format!("exposure {exposure} must be a finite number > 0"),
            });
        }
        let bytes = self.to_srgb8(exposure, tone);
        let (w, h) = (self.width, self.height);
        write_atomically(path, |out| {
            let size = |n: usize| u32::try_from(n).map_err(|_| format!("{n} pixels is too wide"));
            let mut enc = png::Encoder::new(out, size(w)?, size(h)?);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
            let mut writer = enc
                .write_header()
                .map_err(|e| format!("cannot encode PNG ({e})"))?;
            writer
                .write_image_data(&bytes)
                .and_then(|()| writer.finish())
                .map_err(|e| format!("cannot encode PNG ({e})"))
        })
    }
}

/// The sRGB electro-optical transfer function: the linear value of an encoded one (the
/// inverse of `1.055·v^(1/2.4) − 0.055`, linear `12.92·v` below `0.0031308`).
fn srgb_decode(e: f64) -> f64 {
    if e <= 0.040_45 {
        e / 12.92
    } else {
        ((e + 0.055) / 1.055).powf(2.4)
    }
}

/// The linear values where the 8-bit code steps up: code `k` (1–255) from
/// `decode((k − ½)/255)` on, where the encoded value rounded to 8 bits reaches `k`.
fn srgb8_steps() -> &'static [f64; 255] {
    static STEPS: std::sync::OnceLock<[f64; 255]> = std::sync::OnceLock::new();
    STEPS.get_or_init(|| std::array::from_fn(|k| srgb_decode((k as f64 + 0.5) / 255.0)))
}

/// The 8-bit sRGB code of a linear value, clipped to [0, 1] (NaN gives 0): the number
/// of steps ([`srgb8_steps`]) at or below `v`, found by bisection (no `powf` per value:
/// a 1920 × 1080 picture encodes in 27 ms on two cores instead of 130).
fn srgb8(v: f64) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    srgb8_steps().partition_point(|&step| step <= v) as u8
}

/// The 8-bit code [`Image::to_srgb8`] gives the stored (`f32`) linear value `x` at
/// `exposure` under `tone`.
pub fn srgb8_code(x: f32, exposure: f64, tone: ToneMap) -> u8 {
    srgb8(tone.apply(f64::from(x) * exposure))
}

/// The stored values where [`srgb8_code`] at `exposure` and `tone` steps up: entry `k`
/// (0–254) is the smallest `f32` `x ≥ 0` whose code is above `k` (`+∞` where no finite
/// one is), so the code of any `x` is the number of entries at or below it — exactly, in
/// `f32` comparisons (a NaN or negative `x` is below every entry: code 0, as
/// [`srgb8_code`]'s; `+∞` is at or above every one: 255). The code is non-decreasing in
/// `x` (the tone curve and the sRGB steps both are), so each entry is found by bisection
/// on the bits of the non-negative `f32`s, whose order is theirs. For a GPU to encode a
/// picture with one table a frame ([`Image::to_srgb8`] per pixel without the host).
pub fn srgb8_thresholds(exposure: f64, tone: ToneMap) -> [f32; 255] {
    let top = f32::MAX.to_bits();
    std::array::from_fn(|k| {
        let above = |bits: u32| srgb8_code(f32::from_bits(bits), exposure, tone) as usize > k;
        if !above(top) {
            return f32::INFINITY;
        }
        // The smallest bit pattern in [0, top] whose code is above k.
        let (mut lo, mut hi) = (0u32, top);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if above(mid) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        f32::from_bits(lo)
    })
}

/// Runs `encode` on a temporary file in the destination's folder, then renames it to
/// `path`.
fn write_atomically(
    path: &Path,
    encode: impl FnOnce(&mut BufWriter<&mut std::fs::File>) -> Result<(), String>,
) -> Result<(), ImageError> {
    let err = |problem: String| ImageError {
        path: path.display().to_string(),
        problem,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut tmp = crate::temp_output::temp_output(dir)
        .map_err(|e| err(format!("cannot create a temporary file ({e})")))?;
    {
        let mut out = BufWriter::new(tmp.as_file_mut());
        encode(&mut out).map_err(err)?;
        out.flush()
            .map_err(|e| err(format!("cannot write ({e})")))?;
    }
    tmp.persist(path)
        .map_err(|e| err(format!("cannot rename the temporary file ({})", e.error)))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient() -> Image {
        let mut im = Image::new(5, 3);
        for (i, p) in im.pixels.iter_mut().enumerate() {
            *p = [i as f32 * 0.25, 1.0, 0.5 / (1.0 + i as f32)];
        }
        im
    }

    #[test]
    fn rows_land_in_order_and_every_row_is_heard() {
        // Pixel (x, y) at index y·width + x with its f64 value rounded to f32; the
        // progress calls count 1..=height once each, whatever order the rows end in.
        let heard = std::sync::Mutex::new(Vec::new());
        let im = Image::by_rows(7, 5, &|n| heard.lock().unwrap().push(n), |x, y| {
            [x as f64, y as f64, 0.1 + (x * 10 + y) as f64]
        });
        assert_eq!((im.width, im.height, im.pixels.len()), (7, 5, 35));
        for y in 0..5 {
            for x in 0..7 {
                let want = [x as f32, y as f32, (0.1 + (x * 10 + y) as f64) as f32];
                assert_eq!(im.get(x, y), want, "({x}, {y})");
            }
        }
        let mut heard = heard.into_inner().unwrap();
        heard.sort_unstable();
        assert_eq!(heard, vec![1, 2, 3, 4, 5]);
        let empty = Image::by_rows(0, 3, &|_| {}, |_, _| [1.0; 3]);
        assert!(empty.pixels.is_empty());
    }

    #[test]
    fn rel_rms_matches_its_definition_and_guards_a_black_reference() {
        let r = gradient();
        let mut a = r.clone();
        a.pixels[7][1] += 0.5;
        a.pixels[2][0] -= 0.25;
        let norm: f64 = r
            .pixels
            .iter()
            .flat_map(|p| p.map(|c| f64::from(c) * f64::from(c)))
            .sum();
        let want = ((0.5f64 * 0.5 + 0.25 * 0.25) / norm).sqrt();
        assert!((a.rel_rms(&r) - want).abs() < 1e-7 * want);
        assert_eq!(r.rel_rms(&r), 0.0);
        let black = Image::new(5, 3);
        assert_eq!(black.rel_rms(&black), 0.0);
        assert_eq!(r.rel_rms(&black), f64::INFINITY);
    }

    /// What `write_exr` writes, `read_exr` reads back bit for bit (a non-square image, so
    /// rows and columns cannot be swapped unseen); a file that is not OpenEXR is named.
    #[test]
    fn an_exr_reads_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.exr");
        let im = gradient();
        im.write_exr(&path).unwrap();
        assert_eq!(Image::read_exr(&path).unwrap(), im);
        let bad = dir.path().join("bad.exr");
        std::fs::write(&bad, b"not an image").unwrap();
        let e = Image::read_exr(&bad).unwrap_err().to_string();
        assert!(
            e.starts_with(&bad.display().to_string()) && e.contains("OpenEXR"),
            "{e}"
        );
    }

    #[test]
    fn a_picture_with_nan_or_infinity_is_refused_by_stage_and_pixel() {
        let mut im = gradient();
        assert!(im.check_finite("test").is_ok());
        im.pixels[7][2] = f32::NAN;
        im.pixels[9] = [f32::INFINITY, f32::NEG_INFINITY, 0.0];
        let e = im.check_finite("paper C's airlight").unwrap_err();
        // Pixel 7 of a 5-wide image is (2, 1); three values of 45 are not finite.
        assert_eq!((e.values, e.total, e.first), (3, 45, (2, 1)));
        let msg = e.to_string();
        assert!(
            msg.starts_with("paper C's airlight made 3 of 45 values"),
            "{msg}"
        );
        // The largest finite f32 is a value like any other.
        im.pixels[7][2] = f32::MAX;
        im.pixels[9] = [f32::MIN_POSITIVE, -f32::MAX, 0.0];
        assert!(im.check_finite("test").is_ok());
    }

    /// Images are created 0644 less the umask, as the JSON outputs are (not 0600).
    #[cfg(unix)]
    #[test]
    fn images_have_the_mode_of_other_outputs() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        gradient().write_exr(&path).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        // Group and others may read unless the umask forbids it; never write.
        assert_eq!(mode & 0o600, 0o600, "{mode:o}");
        assert_eq!(mode & 0o133, 0, "{mode:o}");
        assert_ne!(mode & 0o044, 0, "{mode:o} (umask 077?)");
    }

    /// The steps' bisection gives the code the transfer function rounds to: on a sweep of
    /// a million values over [0, 1] (denser at the dark end, where codes are closest),
    /// every code, and values within 1e-12 of a step (where the two roundings may part by
    /// an ulp of the step itself) off by at most one.
    #[test]
    fn srgb8_thresholds_reproduce_every_code() {
        // Against the per-value encoding on values around each threshold, at several
        // exposures and both curves, and at the extremes.
        for tone in [ToneMap::Filmic, ToneMap::Clip] {
            for exposure in [1.0, 0.37, 5.5, 1e-6, 3e5] {
                let t = srgb8_thresholds(exposure, tone);
                let code = |x: f32| t.iter().filter(|&&s| s <= x).count();
                assert!(t.windows(2).all(|w| w[0] <= w[1]), "{exposure} {tone:?}");
                for (k, &s) in t.iter().enumerate() {
                    if s.is_finite() {
                        let below = f32::from_bits(s.to_bits().saturating_sub(1));
                        assert!(srgb8_code(s, exposure, tone) as usize > k);
                        assert!(srgb8_code(below, exposure, tone) as usize <= k || s == 0.0);
                    }
                }
                let mut x = 1e-9f32;
                while x < 1e9 {
                    assert_eq!(code(x), srgb8_code(x, exposure, tone) as usize, "{x}");
                    x *= 1.013;
                }
                for x in [
                    0.0,
                    -1.0,
                    f32::NAN,
                    f32::INFINITY,
                    f32::MAX,
                    f32::MIN_POSITIVE,
                ] {
                    assert_eq!(code(x), srgb8_code(x, exposure, tone) as usize, "{x}");
                }
            }
        }
        // A tiny exposure never reaches the top codes with a finite value.
        let t = srgb8_thresholds(1e-40, ToneMap::Clip);
        assert!(t[254].is_infinite());
    }

    #[test]
    fn srgb8_steps_round_as_the_transfer_function() {
        // The sRGB opto-electronic transfer function, rounded to 8 bits.
        let direct = |v: f64| {
            let e = if v <= 0.003_130_8 {
                12.92 * v
            } else {
                1.055 * v.powf(1.0 / 2.4) - 0.055
            };
            (e * 255.0).round() as u8
        };
        let steps = srgb8_steps();
        let mut seen = [false; 256];
        let n = 1_000_000;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            for v in [t, t * t * t] {
                let (a, b) = (srgb8(v), direct(v));
                seen[usize::from(a)] = true;
                let near_step = steps.iter().any(|s| (s - v).abs() <= 1e-12);
                if near_step {
                    assert!(a.abs_diff(b) <= 1, "{v}: {a} vs {b}");
                } else {
                    assert_eq!(a, b, "{v}");
                }
            }
        }
        assert!(seen.iter().all(|s| *s), "a code never reached");
        // Each step itself and the value just below it.
        for (k, s) in steps.iter().enumerate() {
            assert_eq!(usize::from(srgb8(*s)), k + 1);
            assert_eq!(usize::from(srgb8(s.next_down())), k);
        }
    }

    #[test]
    fn png_is_srgb_encoded_and_written_in_place() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(7.0), 255);
        assert_eq!(srgb8(f64::NAN), 0);
        // 255 · (1.055 · 0.18^(1/2.4) − 0.055) = 117.65.
        assert_eq!(srgb8(0.18), 118);
        // The whole image, pixel by pixel and channel by channel, exposure applied.
        let im = gradient();
        let bytes = im.to_srgb8(2.0, ToneMap::Clip);
        assert_eq!(bytes.len(), 3 * 15);
        let filmic = im.to_srgb8(2.0, ToneMap::Filmic);
        for (i, p) in im.pixels.iter().enumerate() {
            for c in 0..3 {
                let x = 2.0 * f64::from(p[c]);
                assert_eq!(bytes[3 * i + c], srgb8(x), "pixel {i}");
                assert_eq!(
                    filmic[3 * i + c],
                    srgb8(ToneMap::Filmic.apply(x)),
                    "pixel {i}"
                );
            }
        }
        assert_eq!(&bytes[3..6], &[srgb8(0.5), 255, srgb8(0.5)]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        gradient().write_png(&path, 1.0, ToneMap::Filmic).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        let missing = dir.path().join("no/such/dir/a.png");
        let e = gradient()
            .write_png(&missing, 1.0, ToneMap::Filmic)
            .unwrap_err();
        assert!(e.to_string().contains("no/such/dir"), "{e}");
    }
}
