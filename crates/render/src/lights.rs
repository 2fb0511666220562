//! The lights of a smoke render or the viewer: the environment (built-in sky or a lat-long
//! map, whose sun is split off and lit exactly unless told not to), and suns and point
//! lights.

use anyhow::{Result, bail};
use haze_view::{Environment, LatLong, PointLight, Sky, Sun};
use std::path::Path;

#[derive(Debug, Clone)]
pub struct Lights {
    /// Distant lighting: `"sky"` (the built-in sky) or the path of a lat-long OpenEXR map
    /// (Z up, row 0 the zenith), whose sun (its brightest compact region) is split off
    /// and lit exactly.
    pub env: String,
    /// Keep an environment map whole: its sun stays in the spherical harmonics.
    pub no_sun_extraction: bool,
    /// Suns, lit exactly.
    pub sun: Vec<Sun>,
    /// Point lights, lit exactly.
    pub light: Vec<PointLight>,
}

impl Lights {
    /// The environment these lights describe. A map that is not there, or not a readable
    /// RGB OpenEXR, is a one-line error naming it.
    pub fn environment(&self) -> Result<Environment> {
        let mut env = if self.env == "sky" {
            Environment::sky(Sky::default())
        } else {
            let path = Path::new(&self.env);
            if !path.exists() {
                bail!(
                    "{}: no such environment map (use 'sky' or a lat-long .exr)",
                    self.env
                );
            }
            let map = LatLong::load_exr(path)?;
            if self.no_sun_extraction {
                Environment::map(map)
            } else {
                let env = Environment::map_with_sun_extracted(map);
                match env.suns.first() {
                    Some(sun) => {
                        let (theta, phi) = haze_view::distant::angles(sun.direction);
                        tracing::info!(
                            "{}: sun split off at elevation {:.1}°, azimuth {:.1}°, {:.2}° wide, irradiance {:.3?}",
                            self.env,
                            90.0 - theta.to_degrees(),
                            phi.to_degrees(),
                            sun.angle.to_degrees(),
                            sun.irradiance
                        );
                    }
                    None => tracing::info!("{}: no sun found, the map is lit whole", self.env),
                }
                env
            }
        };
        env.suns.extend(self.sun.iter().cloned());
        env.points.extend(self.light.iter().cloned());
        Ok(env)
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
