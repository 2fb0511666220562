//! The environment a frame is lit by: the distant radiance ([`crate::distant`]) and the
//! lights taken out of it or added to it, suns and point lights ([`crate::lights`]), lit
//! exactly.

use crate::distant::{Distant, LatLong, Rgb, Sky};
use crate::lights::decompose::{DecomposeOptions, Decomposition, decompose};
use crate::lights::{PointLight, Sun};

/// What lights the smoke: distant radiance (projected on SH by the fast renderer), and
/// lights evaluated exactly — suns (distant disks) and point lights ([`crate::lights`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    pub distant: Distant,
    pub suns: Vec<Sun>,
    pub points: Vec<PointLight>,
    /// Where a map's light was split into suns ([`Environment::map_decomposed`]): the map
    /// as given, which a ray leaving the scene sees ([`Environment::radiance`]).
    pub backdrop: Option<Backdrop>,
}

/// What a camera ray sees of a map split into suns: the map itself. The suns split off it
/// are uniform disks that stand for its concentrated light in the lighting; seen
/// directly, a soft sun's lobe as a cluster of flat disks is a different picture (through
/// thin smoke in front of it, a back-lit plume's single scattering was 4.5 % off in
/// that light alone).
#[derive(Clone, Debug, PartialEq)]
pub struct Backdrop {
    /// The map as given.
    pub map: LatLong,
    /// How many of [`Environment::suns`], from the first, came out of `map` (seen in it,
    /// with no disks of their own); suns after them (`--sun`) keep their disks.
    pub suns: usize,
}

impl Environment {
    /// The built-in sky, no lights.
    pub fn sky(sky: Sky) -> Environment {
        Environment::from(Distant::Sky(sky))
    }

    /// A lat-long map as it is (see [`Environment::map_decomposed`]), no lights.
    pub fn map(map: LatLong) -> Environment {
        Environment::from(Distant::Map(map))
    }

    /// A lat-long map whose concentrated light is split off into suns lit exactly
    /// ([`crate::lights::decompose`]); the smooth rest stays the distant map. Returns the
    /// decomposition too (what was found, for the user).
    pub fn map_decomposed(map: &LatLong, opts: &DecomposeOptions) -> (Environment, Decomposition) {
        let d = decompose(map, opts);
        let env = Environment {
            distant: Distant::Map(d.rest.clone()),
            suns: d.suns.clone(),
            points: Vec::new(),
            backdrop: (!d.suns.is_empty()).then(|| Backdrop {
                map: map.clone(),
                suns: d.suns.len(),
            }),
        };
        (env, d)
    }

    /// Radiance a ray sees where it leaves the scene in direction `d`: the distant
    /// radiance plus the disks of the suns; where a map was split into suns, the map as
    /// given ([`Backdrop`]) plus the disks of the suns that did not come out of it.
    pub fn radiance(&self, d: [f64; 3]) -> Rgb {
        let (mut out, own) = match &self.backdrop {
            Some(b) => (b.map.radiance(d), b.suns.min(self.suns.len())),
            None => (self.distant.radiance(d), 0),
        };
        for sun in &self.suns[own..] {
            if sun.covers(d) {
                let l = sun.radiance();
                for c in 0..3 {
                    out[c] += l[c];
                }
            }
        }
        out
    }

    /// True when there are suns or point lights.
    pub fn has_lights(&self) -> bool {
        !self.suns.is_empty() || !self.points.is_empty()
    }

    /// A constant environment (every direction `c`), handy for tests: `Map` of one texel.
    pub fn constant(c: Rgb) -> Environment {
        let t = [c[0] as f32, c[1] as f32, c[2] as f32];
        Environment::map(LatLong {
            width: 1,
            height: 1,
            texels: vec![t],
        })
    }
}

impl From<Distant> for Environment {
    fn from(distant: Distant) -> Environment {
        Environment {
            distant,
            suns: Vec::new(),
            points: Vec::new(),
            backdrop: None,
        }
    }
}
