//! The lights of a smoke render or the viewer: the environment (built-in sky or a lat-long
//! map, whose concentrated light is split off into suns lit exactly unless told not to),
//! and suns and point lights; and the ground under the smoke ([`GroundChoice`]).
//!
//! **The built-in sky** (`--env sky`, the default) is a clear day with a low sun: the sky
//! of [`Sky::default`]'s colours with its glow around [`SUN_DIRECTION`] (25° above the
//! horizon, from the left of the default camera and a little behind the smoke, so the
//! smoke shows a lit and a shaded side and casts its shadow towards the camera's right),
//! and that sun lit exactly ([`SUN_IRRADIANCE`], the real sun's 0.53°). A `--sun` given
//! replaces it; `--env glow` is the same sky with its glow only, no sun.

use anyhow::{Result, anyhow, bail};
use haze_view::distant::Layout;
use haze_view::ground::Ground;
use haze_view::lights::decompose::{DecomposeOptions, Decomposition, decompose, map_power};
use haze_view::{Environment, LatLong, PointLight, Sky, Sun};
use std::path::Path;
use std::sync::Arc;

/// The built-in sky's sun, towards it: azimuth 150° from +X towards +Y, elevation 25°
/// (module docs).
pub const SUN_DIRECTION: [f64; 3] = [
    -0.784_885_567_221_395_8,
    0.453_153_893_518_324_9,
    0.422_618_261_740_699_4,
];

/// The built-in sky's sun: irradiance on a surface facing it, a warm white about 2.5×
/// the sky's own irradiance on the ground, so its shadow is clear.
pub const SUN_IRRADIANCE: [f64; 3] = [12.0, 10.8, 9.0];

/// The built-in sky's sun's apparent diameter, degrees (the real sun's).
pub const SUN_ANGLE_DEGREES: f64 = 0.53;

/// The built-in sky of `--env sky` without its sun: [`Sky::default`]'s colours, its glow
/// around [`SUN_DIRECTION`].
pub fn builtin_sky() -> Sky {
    Sky {
        sun_direction: SUN_DIRECTION,
        ..Sky::default()
    }
}

/// The sun of `--env sky`.
pub fn builtin_sun() -> Sun {
    Sun {
        direction: SUN_DIRECTION,
        irradiance: SUN_IRRADIANCE,
        angle: SUN_ANGLE_DEGREES.to_radians(),
    }
}

/// Whether a smoke render shows a ground under the smoke ([`haze_view::ground`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GroundChoice {
    /// Under the built-in sky (`sky`, `glow`); not under a map, which has a ground of
    /// its own below its horizon.
    #[default]
    Auto,
    On,
    Off,
}

impl GroundChoice {
    /// The ground at the floor `floor` (the lowest `z` of the volume's box) under `lights`,
    /// or none.
    pub fn ground(self, lights: &Lights, floor: f64) -> Option<Ground> {
        let on = match self {
            GroundChoice::Auto => lights.builtin(),
            GroundChoice::On => true,
            GroundChoice::Off => false,
        };
        (on && floor.is_finite()).then(|| Ground::at(floor))
    }
}

impl std::str::FromStr for GroundChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<GroundChoice, String> {
        match s {
            "auto" => Ok(GroundChoice::Auto),
            "on" => Ok(GroundChoice::On),
            "off" => Ok(GroundChoice::Off),
            _ => Err(format!("{s}: expected auto, on or off")),
        }
    }
}

#[derive(Debug, Clone)]
pub struct Lights {
    /// Distant lighting: `"sky"` (the built-in sky) or the path of a lat-long OpenEXR or
    /// Radiance `.hdr` map (Z up, row 0 the zenith), whose concentrated light (suns, bright lobes) is split
    /// off into suns lit exactly.
    pub env: String,
    /// Keep an environment map whole: no suns are split off it.
    pub no_sun_extraction: bool,
    /// How the map is laid out, turned and scaled ([`MapPlacement`]).
    pub placement: MapPlacement,
    /// Suns, lit exactly.
    pub sun: Vec<Sun>,
    /// Point lights, lit exactly.
    pub light: Vec<PointLight>,
}

impl Default for Lights {
    /// `--env sky` as the command line's defaults give it: the built-in sky and its sun,
    /// nothing added.
    fn default() -> Lights {
        Lights {
            env: "sky".into(),
            no_sun_extraction: false,
            placement: MapPlacement::default(),
            sun: Vec::new(),
            light: Vec::new(),
        }
    }
}

impl Lights {
    /// The environment the fast renderers light with: a map's concentrated light split
    /// off into suns lit exactly ([`haze_view::lights::decompose`]; what was found is
    /// logged at `-v`), unless [`Lights::no_sun_extraction`]; then the given suns and
    /// point lights. A map that is not there, not a readable RGB OpenEXR or Radiance
    /// `.hdr`, not lat-long (twice as wide as tall, or one texel), or without finite
    /// non-negative radiance is a one-line error naming it.
    pub fn environment(&self) -> Result<Environment> {
        match self.turnable()? {
            Some(map) => map.as_given(),
            None => Ok(self.sky()),
        }
    }

    /// The environment as given: a map whole, as the reference renders it (the map is
    /// the truth; the suns split off it are the fast renderers' approximation of it).
    pub fn environment_whole(&self) -> Result<Environment> {
        match self.turnable()? {
            Some(map) => {
                let placed = map.placed(self.placement.turn_degrees)?;
                note_map(&self.env, &placed);
                Ok(self.around(placed, false, false))
            }
            None => Ok(self.sky()),
        }
    }

    /// The environment is one of the built-in skies (`sky`, `glow`), not a map.
    pub fn builtin(&self) -> bool {
        self.env == "sky" || self.env == "glow"
    }

    /// The built-in sky (module docs), then the given suns and point lights.
    fn sky(&self) -> Environment {
        let mut env = Environment::sky(builtin_sky());
        if self.env == "sky" && self.sun.is_empty() {
            env.suns.push(builtin_sun());
        }
        env.suns.extend(self.sun.iter().cloned());
        env.points.extend(self.light.iter().cloned());
        env
    }

    /// The environment of the placed `map`: split into suns when `split` (what was found
    /// logged at `-v` when `log`), then the given suns and point lights.
    fn around(&self, map: LatLong, split: bool, log: bool) -> Environment {
        let mut env = if split {
            let (env, found) = Environment::map_decomposed(&map, &DecomposeOptions::default());
            if log {
                log_decomposition(&self.env, &found);
            }
            env
        } else {
            Environment::map(map)
        };
        env.suns.extend(self.sun.iter().cloned());
        env.points.extend(self.light.iter().cloned());
        env
    }

    /// The map [`Lights::env`] names, read and checked as it is on disk (module docs of
    /// [`Lights`]), not yet placed ([`MapPlacement`]).
    fn read_map(&self) -> Result<LatLong> {
        let path = Path::new(&self.env);
        if !path.exists() {
            bail!(
                "{}: no such environment map (use 'sky', 'glow' or a lat-long .exr or .hdr)",
                self.env
            );
        }
        let map = LatLong::load(path)?;
        let (w, h) = (map.width, map.height);
        if !is_lat_long(w, h) {
            bail!(
                "{}: a {w}×{h} map is not lat-long (a lat-long map is twice as wide as it is tall)",
                self.env
            );
        }
        Ok(map)
    }

    /// The map to turn live (the viewer's "map turn" slider) when [`Lights::env`] is a
    /// map, read once; `None` under the built-in skies.
    pub fn turnable(&self) -> Result<Option<TurnableMap>> {
        if self.builtin() {
            return Ok(None);
        }
        Ok(Some(TurnableMap {
            read: Arc::new(self.read_map()?),
            lights: self.clone(),
        }))
    }

    /// The light in words ("the built-in sky and 1 sun"), as a choice's reasons name it.
    pub fn describe(&self) -> String {
        let mut s = if self.env == "sky" && self.sun.is_empty() {
            "the built-in sky and its sun".to_string()
        } else if self.builtin() {
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

/// A map's light that turns live: the map as read, once, and the lights given with it.
/// Each turn is the map placed as `--env-rotate DEG` places it and split as
/// [`Lights::environment`] splits it, so the viewer's picture at a turn is `haze render
/// --env-rotate DEG`'s (the map, its suns and the background turn together).
#[derive(Debug, Clone)]
pub struct TurnableMap {
    read: Arc<LatLong>,
    lights: Lights,
}

impl TurnableMap {
    /// The turn the lights were given (`--env-rotate`), degrees.
    pub fn given_turn(&self) -> f64 {
        self.lights.placement.turn_degrees
    }

    /// The environment with the map turned `degrees` about +Z (counter-clockwise seen from
    /// above) in place of the given turn.
    pub fn environment(&self, degrees: f64) -> Result<Environment> {
        let l = &self.lights;
        Ok(l.around(self.placed(degrees)?, !l.no_sun_extraction, false))
    }

    /// [`Lights::environment`]: the map at its given turn, what was found logged at `-v`,
    /// a warning where a map kept whole (`--no-sun-extraction`) holds concentrated light.
    pub fn as_given(&self) -> Result<Environment> {
        let l = &self.lights;
        let map = self.placed(l.placement.turn_degrees)?;
        note_map(&l.env, &map);
        if l.no_sun_extraction {
            // Kept whole, concentrated light is blurred by SH and the direction rule (an
            // 8° sun: single scattering 88 % off, BENCHMARKS "Skies of every shape").
            let found = decompose(&map, &DecomposeOptions::default());
            let share: f64 = (0..found.suns.len()).map(|k| found.share(k)).sum();
            if share > 0.05 {
                tracing::warn!(
                    "{}: {:.0} % of the map's light is concentrated (suns); kept whole by --no-sun-extraction it is blurred, the picture can be far off",
                    l.env,
                    100.0 * share
                );
            }
        }
        Ok(l.around(map, !l.no_sun_extraction, true))
    }

    /// The map placed with the given layout and strength, turned `degrees`.
    fn placed(&self, degrees: f64) -> Result<LatLong> {
        let l = &self.lights;
        let turned = MapPlacement {
            turn_degrees: degrees,
            ..l.placement
        };
        turned.apply(&self.read, &l.env)
    }
}

/// Whether a `w × h` map is lat-long: twice as wide as it is tall, or one texel (the same
/// radiance from every direction).
pub(crate) fn is_lat_long(w: usize, h: usize) -> bool {
    (w, h) == (1, 1) || w == 2 * h
}

/// Says what is unusual about a lat-long map named `name`: one texel (`-v`), or black (a
/// warning).
pub(crate) fn note_map(name: &str, map: &LatLong) {
    if (map.width, map.height) == (1, 1) {
        tracing::info!("{name}: a 1×1 map: the same radiance from every direction");
    }
    if map_power(map).iter().all(|&p| p <= 0.0) {
        tracing::warn!("{name}: the map is black: no distant light");
    }
}

/// Logs what the decomposition of the map at `path` found (`-v`).
fn log_decomposition(path: &str, d: &Decomposition) {
    for line in decomposition_lines(path, d) {
        tracing::info!("{line}");
    }
}

/// What the decomposition of the map at `path` found, in lines: the suns' count and share
/// of the map's power, then each sun's direction, width and share.
pub(crate) fn decomposition_lines(path: &str, d: &Decomposition) -> Vec<String> {
    if d.suns.is_empty() {
        return vec![format!(
            "{path}: no concentrated light found, the map is lit whole"
        )];
    }
    let carried: f64 = (0..d.suns.len()).map(|k| d.share(k)).sum();
    let mut lines = vec![format!(
        "{path}: {} sun{} split off, {:.1} % of the map's power; the rest stays in the map",
        d.suns.len(),
        if d.suns.len() == 1 { "" } else { "s" },
        100.0 * carried
    )];
    for (k, sun) in d.suns.iter().enumerate() {
        let (theta, phi) = haze_view::distant::angles(sun.direction);
        lines.push(format!(
            "  sun {}: elevation {:.1}°, azimuth {:.1}°, {:.2}° wide, {:.1} % of the power",
            k + 1,
            90.0 - theta.to_degrees(),
            phi.to_degrees(),
            sun.angle.to_degrees(),
            100.0 * d.share(k)
        ));
    }
    lines
}

/// How a lat-long map is placed (`--env-layout`, `--env-rotate`, `--env-strength`, a
/// scene file's `"layout"`, `"rotate"`, `"strength"`): its columns read in `layout`,
/// turned `turn_degrees` about +Z (counter-clockwise seen from above), its radiance times
/// `strength` ([`LatLong::turned`], [`LatLong::scaled`]). What `haze render --env` lights
/// with, the viewer turns and `haze inspect` splits into suns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPlacement {
    pub layout: Layout,
    /// Degrees about +Z, counter-clockwise seen from above.
    pub turn_degrees: f64,
    /// The radiance's factor (Blender's Background Strength).
    pub strength: f64,
}

impl Default for MapPlacement {
    /// The map as given: haze's layout, not turned, strength 1.
    fn default() -> MapPlacement {
        MapPlacement {
            layout: Layout::Haze,
            turn_degrees: 0.0,
            strength: 1.0,
        }
    }
}

impl MapPlacement {
    /// The lat-long `map` (read from `name`) placed; a one-line error naming it where
    /// the strength takes a texel past what a map holds.
    pub fn apply(&self, map: &LatLong, name: &str) -> Result<LatLong> {
        map.turned(self.layout, self.turn_degrees)
            .scaled(self.strength)
            .map_err(|e| anyhow!("{name}: times --env-strength: {e}"))
    }

    /// A one-line error when `self` is not the default for `path`, which is not a map
    /// (a volume, a sequence, an asset): the flags place maps only.
    pub fn only_for_maps(&self, path: &Path) -> Result<()> {
        if *self != MapPlacement::default() {
            bail!(
                "{}: not an environment map (.exr, .hdr), so --env-layout, --env-rotate and --env-strength do not apply",
                path.display()
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lights(env: &str, sun: Vec<Sun>) -> Lights {
        Lights {
            env: env.into(),
            sun,
            ..Lights::default()
        }
    }

    /// The built-in sun is at azimuth 150°, elevation 25°, a unit vector; the sky's glow
    /// is around it; `--env sky` has it, `glow` not, and a given sun replaces it.
    #[test]
    fn the_builtin_sky_has_its_low_sun() {
        let (a, e) = (150f64.to_radians(), 25f64.to_radians());
        let want = [a.cos() * e.cos(), a.sin() * e.cos(), e.sin()];
        for c in 0..3 {
            assert!((SUN_DIRECTION[c] - want[c]).abs() < 1e-15, "{c}");
        }
        assert_eq!(builtin_sky().sun_direction, SUN_DIRECTION);
        let env = lights("sky", Vec::new()).environment().unwrap();
        assert_eq!(env.suns, vec![builtin_sun()]);
        assert!(
            lights("glow", Vec::new())
                .environment()
                .unwrap()
                .suns
                .is_empty()
        );
        let mine = Sun {
            direction: [0.0, 0.0, 1.0],
            irradiance: [1.0; 3],
            angle: 0.0,
        };
        let env = lights("sky", vec![mine.clone()]).environment().unwrap();
        assert_eq!(env.suns, vec![mine]);
        assert_eq!(
            lights("sky", Vec::new()).describe(),
            "the built-in sky and its sun"
        );
    }

    /// The ground is under the built-in skies by default, not under a map; on and off
    /// force it; a non-finite floor has none.
    #[test]
    fn the_ground_follows_the_choice() {
        let sky = lights("sky", Vec::new());
        let map = lights("x.exr", Vec::new());
        assert_eq!(
            GroundChoice::Auto.ground(&sky, -1.0),
            Some(Ground::at(-1.0))
        );
        assert_eq!(
            GroundChoice::Auto.ground(&lights("glow", Vec::new()), 0.0),
            Some(Ground::at(0.0))
        );
        assert_eq!(GroundChoice::Auto.ground(&map, 0.0), None);
        assert_eq!(GroundChoice::On.ground(&map, 2.0), Some(Ground::at(2.0)));
        assert_eq!(GroundChoice::Off.ground(&sky, 0.0), None);
        assert_eq!(GroundChoice::On.ground(&sky, f64::NAN), None);
        assert_eq!("on".parse(), Ok(GroundChoice::On));
        assert!("yes".parse::<GroundChoice>().is_err());
    }

    /// A map turned live is the map given that turn on the command line, to the bit: its
    /// rest, its suns, its background, the lights given beside it; whole or split; in
    /// either layout, at whole-texel and in-between turns.
    #[test]
    fn a_map_turned_live_is_the_map_given_that_turn() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sun.exr");
        // A sky brighter towards the zenith and a sun at column 11, 20° up.
        exr::prelude::write_rgb_file(&path, 64, 32, |x, y| {
            if (x, y) == (11, 12) {
                (900.0f32, 850.0, 800.0)
            } else {
                let up = 1.0 - y as f32 / 32.0;
                (0.2 + 0.3 * up, 0.3 + 0.3 * up, 0.5 + 0.4 * up)
            }
        })
        .unwrap();
        let point = PointLight::new([0.0, 0.0, 1.0], [5.0, 5.0, 5.0]).unwrap();
        let mut given = lights(path.to_str().unwrap(), vec![builtin_sun()]);
        given.light.push(point);
        assert!(lights("sky", Vec::new()).turnable().unwrap().is_none());
        for (layout, whole) in [
            (Layout::Haze, false),
            (Layout::Blender, false),
            (Layout::Blender, true),
        ] {
            given.placement.layout = layout;
            given.no_sun_extraction = whole;
            given.placement.turn_degrees = 15.0;
            let turnable = given.turnable().unwrap().unwrap();
            assert_eq!(turnable.given_turn(), 15.0);
            for degrees in [0.0, 15.0, 22.5, -97.3, 400.0] {
                let live = turnable.environment(degrees).unwrap();
                given.placement.turn_degrees = degrees;
                assert_eq!(
                    live,
                    given.environment().unwrap(),
                    "{layout:?} {whole} {degrees}"
                );
                assert_eq!(live.suns.len(), if whole { 1 } else { 2 });
            }
        }
        let missing = lights("nowhere.exr", Vec::new());
        let e = missing.turnable().unwrap_err().to_string();
        assert!(e.starts_with("nowhere.exr: no such environment map"), "{e}");
    }
}
