//! `haze inspect MAP.exr|MAP.hdr`: what an environment map holds and how the renderers will
//! light with it — its size and format, its brightest texel and power, and the suns its
//! concentrated light is split into ([`haze_view::lights::decompose`], as `haze render
//! --env MAP` does) — so a user sees before a render whether the sun was found. A picture
//! that is not lat-long (a rendered image, a texture) is described as an image: its size,
//! format, brightest pixel and mean.

use crate::lights::{MapPlacement, decomposition_lines, is_lat_long, note_map};
use anyhow::{Result, bail};
use haze_view::LatLong;
use haze_view::lights::decompose::{DecomposeOptions, decompose, luminance, map_power};
use serde::Serialize;
use std::f64::consts::PI;
use std::path::Path;

/// One sun split off the map.
#[derive(Debug, Serialize)]
pub struct SunReport {
    pub elevation_degrees: f64,
    pub azimuth_degrees: f64,
    /// Apparent (apex) angle of its disk.
    pub angle_degrees: f64,
    /// Its share of the map's power (luminance).
    pub share: f64,
}

/// An environment map described (module docs).
#[derive(Debug, Serialize)]
pub struct MapReport {
    pub kind: &'static str,
    pub path: String,
    /// "OpenEXR" or "Radiance HDR".
    pub format: &'static str,
    pub width: usize,
    pub height: usize,
    /// The largest channel value of any texel.
    pub max_radiance: f64,
    /// The luminance of `∫L dω` over the sphere.
    pub power: f64,
    /// `power / 4π`: the luminance of a uniform sky of the same power.
    pub mean_radiance: f64,
    pub suns: Vec<SunReport>,
    /// The suns' share of the power together.
    pub sun_share: f64,
    /// The report in words, as `text` prints it.
    #[serde(skip)]
    lines: Vec<String>,
}

/// Whether `haze inspect` takes `path` for an environment map: an `.exr` or `.hdr` name
/// (no volume format uses either).
pub fn is_map(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    ["exr", "hdr"].contains(&ext.to_ascii_lowercase().as_str())
}

/// An image that is not a lat-long map described: what `haze inspect` says of a rendered
/// picture rather than refusing it as a map.
#[derive(Debug, Serialize)]
pub struct ImageReport {
    pub kind: &'static str,
    pub path: String,
    /// "OpenEXR" or "Radiance HDR".
    pub format: &'static str,
    pub width: usize,
    pub height: usize,
    /// The largest channel value of any pixel.
    pub max_value: f64,
    /// Each channel's mean over the pixels (linear RGB).
    pub mean_rgb: [f64; 3],
    #[serde(skip)]
    lines: Vec<String>,
}

/// What `haze inspect` reports of an `.exr` or `.hdr` file.
#[derive(Debug, Serialize)]
#[serde(untagged)]
pub enum PictureReport {
    /// A lat-long environment map (`kind` "environment-map").
    Map(MapReport),
    /// Any other picture (`kind` "image").
    Image(ImageReport),
}

impl PictureReport {
    /// The report as lines of text.
    pub fn text(&self) -> String {
        let lines = match self {
            PictureReport::Map(m) => &m.lines,
            PictureReport::Image(i) => &i.lines,
        };
        lines.iter().map(|l| format!("{l}\n")).collect()
    }
}

/// Reads the picture at `path` (opened once); decomposes it, placed by `placement`, when
/// it is a lat-long map (the same checks and errors as `--env`), else describes it as an
/// image — refused when `placement` is not the default, since only a map is placed
/// ([`MapPlacement`], as `haze render` places it, so the suns reported are the render's).
pub fn inspect_map(path: &Path, placement: MapPlacement) -> Result<PictureReport> {
    let name = path.display().to_string();
    if !path.exists() {
        bail!("{name}: no such file or directory");
    }
    let (map, format) = LatLong::load_with_format(path)?;
    let format = format.name();
    let brightest = |map: &LatLong| {
        map.texels
            .iter()
            .flatten()
            .fold(0.0f64, |m, &c| m.max(f64::from(c)))
    };
    if !is_lat_long(map.width, map.height) {
        if placement != MapPlacement::default() {
            bail!(
                "{name}: a {}×{} picture is not a lat-long map (twice as wide as it is tall), so --env-layout, --env-rotate and --env-strength do not apply",
                map.width,
                map.height
            );
        }
        let max_value = brightest(&map);
        return Ok(PictureReport::Image(image_report(
            name, format, &map, max_value,
        )));
    }
    let map = placement.apply(&map, &name)?;
    let max_value = brightest(&map);
    note_map(&name, &map);
    let found = decompose(&map, &DecomposeOptions::default());
    let power = luminance(map_power(&map));
    let suns: Vec<SunReport> = found
        .suns
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (theta, phi) = haze_view::distant::angles(s.direction);
            SunReport {
                elevation_degrees: 90.0 - theta.to_degrees(),
                azimuth_degrees: phi.to_degrees(),
                angle_degrees: s.angle.to_degrees(),
                share: found.share(k),
            }
        })
        .collect();
    let mut lines = vec![
        format!(
            "{name}: environment map ({format}), {} × {}, lat-long",
            map.width, map.height
        ),
        format!(
            "radiance: brightest texel {max_value:.4}, power {power:.4} (luminance of ∫L dω), a uniform sky of {:.4}",
            power / (4.0 * PI)
        ),
    ];
    lines.extend(decomposition_lines("light", &found));
    Ok(PictureReport::Map(MapReport {
        kind: "environment-map",
        path: name,
        format,
        width: map.width,
        height: map.height,
        max_radiance: max_value,
        power,
        mean_radiance: power / (4.0 * PI),
        sun_share: suns.iter().map(|s| s.share).sum(),
        suns,
        lines,
    }))
}

/// A picture that is not lat-long: its size, brightest value and mean colour.
fn image_report(name: String, format: &'static str, map: &LatLong, max_value: f64) -> ImageReport {
    let mut sum = [0.0f64; 3];
    for t in &map.texels {
        for (s, &c) in sum.iter_mut().zip(t) {
            *s += f64::from(c);
        }
    }
    // `LatLong::load` refuses empty pictures: at least one pixel.
    let n = map.texels.len() as f64;
    let mean_rgb = sum.map(|s| s / n);
    let lines = vec![
        format!(
            "{name}: image ({format}), {} × {}, not a lat-long environment map (a lat-long map is twice as wide as it is tall)",
            map.width, map.height
        ),
        format!(
            "values: brightest {max_value:.4}, mean RGB ({:.4}, {:.4}, {:.4})",
            mean_rgb[0], mean_rgb[1], mean_rgb[2]
        ),
    ];
    ImageReport {
        kind: "image",
        path: name,
        format,
        width: map.width,
        height: map.height,
        max_value,
        mean_rgb,
        lines,
    }
}
