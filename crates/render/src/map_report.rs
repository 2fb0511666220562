//! `haze inspect MAP.exr|MAP.hdr`: what an environment map holds and how the renderers will
//! light with it — its size and format, its brightest texel and power, and the suns its
//! concentrated light is split into ([`haze_view::lights::decompose`], as `haze render
//! --env MAP` does) — so a user sees before a render whether the sun was found.

use crate::lights::{Lights, decomposition_lines};
use anyhow::Result;
use haze_view::distant::MapFormat;
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

impl MapReport {
    /// The report as lines of text.
    pub fn text(&self) -> String {
        self.lines.iter().map(|l| format!("{l}\n")).collect()
    }
}

/// Whether `haze inspect` takes `path` for an environment map: an `.exr` or `.hdr` name
/// (no volume format uses either).
pub fn is_map(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    ["exr", "hdr"].contains(&ext.to_ascii_lowercase().as_str())
}

/// Reads, checks and decomposes the map at `path` (the same checks and errors as `--env`).
pub fn inspect_map(path: &Path) -> Result<MapReport> {
    let name = path.display().to_string();
    let lights = Lights {
        env: name.clone(),
        no_sun_extraction: false,
        sun: Vec::new(),
        light: Vec::new(),
    };
    let map = lights.load_map()?;
    let format = MapFormat::of(path)?.name();
    let found = decompose(&map, &DecomposeOptions::default());
    let power = luminance(map_power(&map));
    let max_radiance = map
        .texels
        .iter()
        .flatten()
        .fold(0.0f64, |m, &c| m.max(f64::from(c)));
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
            "radiance: brightest texel {max_radiance:.4}, power {power:.4} (luminance of ∫L dω), a uniform sky of {:.4}",
            power / (4.0 * PI)
        ),
    ];
    lines.extend(decomposition_lines("light", &found));
    Ok(MapReport {
        kind: "environment-map",
        path: name,
        format,
        width: map.width,
        height: map.height,
        max_radiance,
        power,
        mean_radiance: power / (4.0 * PI),
        sun_share: suns.iter().map(|s| s.share).sum(),
        suns,
        lines,
    })
}
