//! The lights of a smoke render or the viewer: the environment (built-in sky or a lat-long
//! map, whose concentrated light is split off into suns lit exactly unless told not to),
//! and suns and point lights.

use anyhow::{Result, bail};
use haze_view::lights::decompose::{DecomposeOptions, Decomposition, decompose, map_power};
use haze_view::{Distant, Environment, LatLong, PointLight, Sky, Sun};
use std::path::Path;

#[derive(Debug, Clone)]
pub struct Lights {
    /// Distant lighting: `"sky"` (the built-in sky) or the path of a lat-long OpenEXR map
    /// (Z up, row 0 the zenith), whose concentrated light (suns, bright lobes) is split
    /// off into suns lit exactly.
    pub env: String,
    /// Keep an environment map whole: no suns are split off it.
    pub no_sun_extraction: bool,
    /// Suns, lit exactly.
    pub sun: Vec<Sun>,
    /// Point lights, lit exactly.
    pub light: Vec<PointLight>,
}

impl Lights {
    /// The environment the fast renderers light with: a map's concentrated light split
    /// off into suns lit exactly ([`haze_view::lights::decompose`]; what was found is
    /// logged at `-v`), unless [`Lights::no_sun_extraction`]; then the given suns and
    /// point lights. A map that is not there, not a readable RGB OpenEXR, not lat-long
    /// (twice as wide as tall, or one texel), or without finite non-negative radiance is
    /// a one-line error naming it.
    pub fn environment(&self) -> Result<Environment> {
        let env = self.build(!self.no_sun_extraction)?;
        if self.no_sun_extraction
            && let Distant::Map(map) = &env.distant
        {
            // Kept whole, concentrated light is blurred by SH and the direction rule (an
            // 8° sun: single scattering 88 % off, BENCHMARKS "Skies of every shape").
            let found = decompose(map, &DecomposeOptions::default());
            let share: f64 = (0..found.suns.len()).map(|k| found.share(k)).sum();
            if share > 0.05 {
                tracing::warn!(
                    "{}: {:.0} % of the map's light is concentrated (suns); kept whole by --no-sun-extraction it is blurred, the picture can be far off",
                    self.env,
                    100.0 * share
                );
            }
        }
        Ok(env)
    }

    /// The environment as given: a map whole, as the reference renders it (the map is
    /// the truth; the suns split off it are the fast renderers' approximation of it).
    pub fn environment_whole(&self) -> Result<Environment> {
        self.build(false)
    }

    fn build(&self, split: bool) -> Result<Environment> {
        let mut env = if self.env == "sky" {
            Environment::sky(Sky::default())
        } else {
            let map = self.load_map()?;
            if split {
                let (env, found) = Environment::map_decomposed(&map, &DecomposeOptions::default());
                log_decomposition(&self.env, &found);
                env
            } else {
                Environment::map(map)
            }
        };
        env.suns.extend(self.sun.iter().cloned());
        env.points.extend(self.light.iter().cloned());
        Ok(env)
    }

    fn load_map(&self) -> Result<LatLong> {
        let path = Path::new(&self.env);
        if !path.exists() {
            bail!(
                "{}: no such environment map (use 'sky' or a lat-long .exr)",
                self.env
            );
        }
        let map = LatLong::load_exr(path)?;
        let (w, h) = (map.width, map.height);
        if (w, h) != (1, 1) && w != 2 * h {
            bail!(
                "{}: a {w}×{h} map is not lat-long (a lat-long map is twice as wide as it is tall)",
                self.env
            );
        }
        if map_power(&map).iter().all(|&p| p <= 0.0) {
            tracing::warn!("{}: the map is black: no distant light", self.env);
        }
        Ok(map)
    }

    /// The light in words ("the built-in sky and 1 sun"), as a choice's reasons name it.
    pub fn describe(&self) -> String {
        let mut s = if self.env == "sky" {
            "the built-in sky".to_string()
        } else {
            format!("the map {}", self.env)
        };
        let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
        if !self.sun.is_empty() {
            s += &format!(" and {}", plural(self.sun.len(), "sun"));
        }
        if !self.light.is_empty() {
            s += &format!(" and {}", plural(self.light.len(), "point light"));
        }
        s
    }
}

/// Logs what the decomposition of the map at `path` found (`-v`).
fn log_decomposition(path: &str, d: &Decomposition) {
    if d.suns.is_empty() {
        tracing::info!("{path}: no concentrated light found, the map is lit whole");
        return;
    }
    let carried: f64 = (0..d.suns.len()).map(|k| d.share(k)).sum();
    tracing::info!(
        "{path}: {} sun{} split off, {:.1} % of the map's power; the rest stays in the map",
        d.suns.len(),
        if d.suns.len() == 1 { "" } else { "s" },
        100.0 * carried
    );
    for (k, sun) in d.suns.iter().enumerate() {
        let (theta, phi) = haze_view::distant::angles(sun.direction);
        tracing::info!(
            "  sun {}: elevation {:.1}°, azimuth {:.1}°, {:.2}° wide, {:.1} % of the power",
            k + 1,
            90.0 - theta.to_degrees(),
            phi.to_degrees(),
            sun.angle.to_degrees(),
            100.0 * d.share(k)
        );
    }
}
