//! Paper D's analytic fog as a medium of a scene (`{"type": "analytic", …}`, README
//! "Analytic fog"): the extinction `σt·K(x, t)` with `K` a sum of [`haze_fogfn`]'s
//! functions, its optical depth in closed form, carried by its wind. It ends `far` from
//! the eye along any ray (paper D §4.2's viewing threshold), so that rays to an
//! environment at `∞` and the suns' shadow rays have a finite depth. [`crate::analytic`]
//! renders it as paper D does; [`crate::march`] lights it like every medium.

use super::{Aabb, Heterogeneous};
use crate::vec3::Vec3;
use haze_core::Rgb;
use haze_core::number::shown;
use haze_fogfn::Fog;
use serde::Deserialize;
use serde_json::Value;

/// One analytic medium, frozen at `time`.
#[derive(Clone, Debug, PartialEq)]
pub struct AnalyticMedium {
    pub fog: Fog,
    /// Extinction per unit of `K`, per channel.
    pub sigma_t: Rgb,
    pub albedo: Rgb,
    pub g: f64,
    /// `C_fog` when given (module docs).
    pub colour: Option<Rgb>,
    /// Where the fog ends along a ray (world units from the ray's origin).
    pub far: f64,
    /// Seconds since the start of the wind.
    pub time: f64,
}

impl AnalyticMedium {
    /// The same medium at time `t`.
    pub fn at(&self, t: f64) -> AnalyticMedium {
        AnalyticMedium {
            time: t,
            ..self.clone()
        }
    }

    /// `∫₀^{min(len, far)} K(o + s d, time) ds` (unit `d`), in closed form.
    pub fn depth(&self, o: Vec3, d: Vec3, len: f64) -> f64 {
        self.fog.optical_depth(o, d, len.min(self.far), self.time)
    }
}

impl Heterogeneous for AnalyticMedium {
    fn name(&self) -> String {
        format!("analytic fog of {} terms", self.fog.terms.len())
    }
    fn sigma_t(&self, x: Vec3) -> Rgb {
        let k = self.fog.density(x, self.time);
        self.sigma_t.map(|s| s * k)
    }
    fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> Rgb {
        if len <= 0.0 {
            return [0.0; 3];
        }
        let k = self.depth(o, d, len);
        self.sigma_t.map(|s| s * k)
    }
    fn albedo(&self) -> Rgb {
        self.albedo
    }
    fn g(&self) -> f64 {
        self.g
    }
    fn bounds(&self) -> Option<Aabb> {
        None
    }
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Channels {
    One(f64),
    Rgb(Rgb),
}

impl Channels {
    fn rgb(&self) -> Rgb {
        match *self {
            Channels::One(v) => [v; 3],
            Channels::Rgb(c) => c,
        }
    }
}

fn default_far() -> f64 {
    1000.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AnalyticSpec {
    #[allow(dead_code)]
    r#type: String,
    sigma_t: Channels,
    #[serde(default = "Default::default")]
    albedo: Option<Channels>,
    #[serde(default)]
    g: f64,
    #[serde(default)]
    colour: Option<Rgb>,
    #[serde(default = "default_far")]
    far: f64,
    #[serde(default)]
    wind: Vec3,
    terms: Vec<Value>,
}

/// Reads an `"analytic"` medium of the scene file.
pub fn parse(v: &Value) -> Result<AnalyticMedium, String> {
    let s = AnalyticSpec::deserialize(v).map_err(|e| e.to_string())?;
    let sigma_t = s.sigma_t.rgb();
    crate::media::check_sigma_t(&sigma_t)?;
    let albedo = s.albedo.map_or([1.0; 3], |a| a.rgb());
    if !albedo.iter().all(|a| (0.0..=1.0).contains(a)) {
        return Err(format!("albedo {albedo:?} must be in [0, 1]"));
    }
    if !(s.g > -1.0 && s.g < 1.0) {
        return Err(format!("g = {} must be in (−1, 1)", shown(s.g)));
    }
    if let Some(c) = s.colour
        && !c.iter().all(|x| x.is_finite() && *x >= 0.0)
    {
        return Err(format!("colour {c:?} must be finite and not negative"));
    }
    if !(s.far > 0.0 && s.far.is_finite()) {
        return Err(format!("far {} must be positive and finite", shown(s.far)));
    }
    if s.terms.is_empty() {
        return Err("an analytic medium needs at least one term".to_string());
    }
    let fog = haze_fogfn::spec::fog(s.wind, &s.terms)?;
    Ok(AnalyticMedium {
        fog,
        sigma_t,
        albedo,
        g: s.g,
        colour: s.colour,
        far: s.far,
        time: 0.0,
    })
}
