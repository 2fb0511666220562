//! The lighting flags `haze render` and `haze view` share: the environment (built-in sky or
//! a lat-long map, whose concentrated light is split off into suns lit exactly unless
//! told not to), and suns and point lights given on the command line.

use haze_render::lights::{Lights, MapPlacement};
use haze_view::distant::Layout;
use haze_view::{PointLight, Sun};

#[derive(Debug, Clone, clap::Args)]
pub struct LightArgs {
    /// Distant lighting: `sky`, the built-in clear sky with a low sun (25° up, from the
    /// left of the default camera and a little behind the smoke, lit exactly; a --sun
    /// given replaces it); `glow`, the same sky without its sun; or a lat-long OpenEXR
    /// or Radiance .hdr map (Z up, row 0 the zenith, twice as wide as tall; a 1 × 1 map is the same
    /// radiance from every direction). The map's concentrated light
    /// (a sharp or soft sun, several suns, a bright window or cloud edge) is split off
    /// into up to 8 suns lit exactly, like --sun; -v lists them. The smooth rest stays in
    /// the map. The reference renderer (--reference) lights with the map whole.
    #[arg(long, default_value = "sky", value_name = "sky|glow|ENV.exr|ENV.hdr")]
    pub env: String,
    /// Keep an environment map whole: no suns are split off it (its light is integrated
    /// over the environment pass's directions and the spherical harmonics only).
    #[arg(long)]
    pub no_sun_extraction: bool,
    #[command(flatten)]
    pub placement: PlacementArgs,
    /// A sun, lit exactly (sharp shadows, the phase function at its true direction):
    /// the direction towards it, the radiance of its disk (RGB) and the disk's apparent
    /// diameter in degrees (default 0.53, the real sun's). An angle of 0 makes a
    /// point-like sun whose RGB is its irradiance. Each of R, G, B at most 1e30 (pictures
    /// are f32). Repeatable.
    #[arg(long, value_name = "X,Y,Z,R,G,B[,ANGLE]", value_parser = parse_sun, allow_hyphen_values = true)]
    pub sun: Vec<Sun>,
    /// A point light, lit exactly: position and radiant intensity (RGB; irradiance
    /// I/d² at distance d, unshadowed), each of R, G, B at most 1e30. Repeatable.
    #[arg(long, value_name = "X,Y,Z,R,G,B", value_parser = parse_point, allow_hyphen_values = true)]
    pub light: Vec<PointLight>,
}

impl LightArgs {
    /// Each flag with whether it differs from `defaults` ([`crate::unused_flags`]).
    pub fn given(&self, defaults: &LightArgs) -> [(&'static str, bool); 7] {
        [
            (
                "--env",
                crate::unused_flags::differs(&self.env, &defaults.env),
            ),
            ("--no-sun-extraction", self.no_sun_extraction),
            (
                "--env-layout",
                self.placement.env_layout != defaults.placement.env_layout,
            ),
            (
                "--env-rotate",
                self.placement.env_rotate != defaults.placement.env_rotate,
            ),
            (
                "--env-strength",
                self.placement.env_strength != defaults.placement.env_strength,
            ),
            ("--sun", !self.sun.is_empty()),
            ("--light", !self.light.is_empty()),
        ]
    }
}

impl From<LightArgs> for Lights {
    fn from(a: LightArgs) -> Lights {
        Lights {
            env: a.env,
            no_sun_extraction: a.no_sun_extraction,
            placement: a.placement.placement(),
            sun: a.sun,
            light: a.light,
        }
    }
}

/// How a lat-long map is placed: `haze render`, `haze view`, `haze tradeoff` and `haze
/// inspect` take the same three flags.
#[derive(Debug, Clone, clap::Args)]
pub struct PlacementArgs {
    /// How a map's columns map to directions: `haze`, column u at azimuth 360°·u from +X
    /// towards +Y (pbrt's layout); `blender`, as Blender's World reads an Environment
    /// Texture (its centre column facing +X, azimuth falling with u). The same file read
    /// with the other layout lights the smoke mirrored (x → −x).
    #[arg(long, value_enum, default_value = "haze", value_name = "LAYOUT")]
    pub env_layout: EnvLayout,
    /// Turn the map about the vertical (+Z) by DEG degrees, counter-clockwise seen from
    /// above: what it shows at azimuth φ then lights from φ + DEG (its suns too).
    #[arg(long, default_value_t = 0.0, value_name = "DEG", allow_hyphen_values = true, value_parser = parse_degrees)]
    pub env_rotate: f64,
    /// Multiply the map's radiance by S (as Blender's Background Strength does); the
    /// suns split off it follow. --sun and --light are not scaled.
    #[arg(long, default_value_t = 1.0, value_name = "S", value_parser = parse_strength)]
    pub env_strength: f64,
}

impl PlacementArgs {
    /// The placement the flags say.
    pub fn placement(&self) -> MapPlacement {
        MapPlacement {
            layout: match self.env_layout {
                EnvLayout::Haze => Layout::Haze,
                EnvLayout::Blender => Layout::Blender,
            },
            turn_degrees: self.env_rotate,
            strength: self.env_strength,
        }
    }
}

/// `--env-layout`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum EnvLayout {
    /// Column u at azimuth 360°·u from +X towards +Y.
    Haze,
    /// As Blender's World reads an Environment Texture.
    Blender,
}

/// A finite angle in degrees.
fn parse_degrees(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(d) if d.is_finite() => Ok(d),
        _ => Err(format!("'{s}' is not a finite angle in degrees")),
    }
}

/// A finite, non-negative factor.
fn parse_strength(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(k) if k.is_finite() && k >= 0.0 => Ok(k),
        _ => Err(format!("'{s}' is not a finite factor of at least 0")),
    }
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum LightingArg {
    /// The GPU, or the CPU when the adapter is a CPU.
    Auto,
    /// The CPU, in f64: every stage before the view pass, the grids then uploaded.
    Cpu,
    /// The GPU, in f32.
    Gpu,
}

impl From<LightingArg> for haze_view::gpu::renderer::LightingOn {
    fn from(a: LightingArg) -> Self {
        match a {
            LightingArg::Auto => Self::Auto,
            LightingArg::Cpu => Self::Cpu,
            LightingArg::Gpu => Self::Gpu,
        }
    }
}

/// Comma-separated finite numbers.
fn numbers(s: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("'{p}' is not a finite number"))
        })
        .collect()
}

fn parse_sun(s: &str) -> Result<Sun, String> {
    let v = numbers(s)?;
    if !(6..=7).contains(&v.len()) {
        return Err(format!(
            "expected X,Y,Z,R,G,B[,ANGLE] (6 or 7 numbers), got '{s}'"
        ));
    }
    let angle = v.get(6).copied().unwrap_or(0.53);
    Sun::from_radiance([v[0], v[1], v[2]], [v[3], v[4], v[5]], angle)
}

fn parse_point(s: &str) -> Result<PointLight, String> {
    let v = numbers(s)?;
    if v.len() != 6 {
        return Err(format!("expected X,Y,Z,R,G,B (6 numbers), got '{s}'"));
    }
    PointLight::new([v[0], v[1], v[2]], [v[3], v[4], v[5]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suns_and_lights_parse_and_bad_ones_are_refused() {
        let s = parse_sun("0,0,2,10,10,10").unwrap();
        assert_eq!(s.direction, [0.0, 0.0, 1.0]);
        assert!((s.angle.to_degrees() - 0.53).abs() < 1e-12);
        let s = parse_sun("1,0,0, 2,3,4, 0").unwrap();
        assert_eq!(s.irradiance, [2.0, 3.0, 4.0]);
        assert!(parse_sun("1,0,0,1,1").is_err());
        assert!(parse_sun("0,0,0,1,1,1").is_err());
        assert!(parse_sun("0,0,1,1,1,1,200").is_err());
        assert!(parse_sun("0,0,1,1,x,1").is_err());
        let p = parse_point("-1,2,3,5,5,5").unwrap();
        assert_eq!(p.position, [-1.0, 2.0, 3.0]);
        assert!(parse_point("1,2,3,-1,0,0").is_err());
        assert!(parse_point("1,2,3").is_err());
    }
}
