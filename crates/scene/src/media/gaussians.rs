//! The scene file's `{"type": "gaussians", ...}` medium (paper B): read, validated and
//! seen by every renderer as a [`Heterogeneous`] medium with exact optical depths (the
//! closed-form line integrals of `haze_gaussians`).
//!
//! Keys: `sigma_t` (σt, world units⁻¹), `albedo` (default 1), `g` (0: paper B is
//! isotropic), `gaussians` (a list of `{"center": [x,y,z], "radius": r, "weight": w}`,
//! extinction `σt·w·exp(−|x − center|²/r²)`), `background` (default 0: `σt·b` everywhere),
//! and `noise` (optional, paper B §5.5: `{"seed": n, "gain": g, "frequency": f,
//! "offset": [x,y,z]}` — a rendering perturbation of paper B's renderer, not part of the
//! medium: the reference ignores it).
//!
//! A baked smoke frame is a Gaussian medium too (its RBFs are Gaussians, paper A §5.1):
//! `"asset": "SMOKE.haze"` (relative to the scene file), `"frame": n` (the source frame
//! number `haze inspect` lists; default the first), `"offset": [x,y,z]` (added to the
//! centres) add the frame's RBFs — centre, radius and weight in world units, the weight
//! the smoke's density — to the listed `gaussians`. The RBFs' 3r cut-off of paper A is
//! not applied (it drops at most `w·e⁻⁹` of density); the residual is not used.

use super::{Aabb, Heterogeneous};
use crate::vec3::Vec3;
use haze_core::Rgb;
use haze_core::number::shown;
use haze_gaussians::noise::{Noise, Perlin};
use haze_gaussians::{Gaussian, GaussianMedium};
use serde::Deserialize;
use serde_json::Value;
use std::path::Path;

/// A Gaussian medium of a scene with its optional detail noise.
#[derive(Debug)]
pub struct GaussianMediumOf {
    pub medium: GaussianMedium,
    pub noise: Option<Noise>,
}

impl Heterogeneous for GaussianMediumOf {
    fn name(&self) -> String {
        format!("{} gaussians", self.medium.gaussians().len())
    }
    fn sigma_t(&self, x: Vec3) -> Rgb {
        [self.medium.extinction(x); 3]
    }
    fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> Rgb {
        [self.medium.optical_depth(o, d, len); 3]
    }
    fn albedo(&self) -> Rgb {
        [self.medium.albedo; 3]
    }
    fn bounds(&self) -> Option<Aabb> {
        self.medium.bounds().map(|(min, max)| Aabb { min, max })
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GaussianSpec {
    center: Vec3,
    radius: f64,
    weight: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct NoiseSpec {
    #[serde(default)]
    seed: u64,
    gain: f64,
    #[serde(default = "default_frequency")]
    frequency: f64,
    #[serde(default)]
    offset: Vec3,
}

fn default_frequency() -> f64 {
    1.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MediumSpec {
    #[serde(rename = "type")]
    _kind: String,
    sigma_t: f64,
    #[serde(default = "default_albedo")]
    albedo: f64,
    #[serde(default)]
    g: f64,
    #[serde(default)]
    gaussians: Vec<GaussianSpec>,
    #[serde(default)]
    background: f64,
    #[serde(default)]
    noise: Option<NoiseSpec>,
    #[serde(default)]
    asset: Option<String>,
    #[serde(default)]
    frame: Option<i64>,
    #[serde(default)]
    offset: Option<Vec3>,
}

fn default_albedo() -> f64 {
    1.0
}

/// The RBFs of frame `frame` (source number; the first when `None`) of the asset at
/// `path`, moved by `offset`, as Gaussians.
fn asset_gaussians(path: &Path, frame: Option<i64>, offset: Vec3) -> Result<Vec<Gaussian>, String> {
    let asset = haze_asset::Asset::open(path).map_err(|e| e.to_string())?;
    let numbers = &asset.header().source.frame_numbers;
    let k = match frame {
        Some(f) => numbers
            .iter()
            .position(|&n| n == f)
            .ok_or_else(|| format!("{}: frame {f} is not in the asset", path.display()))?,
        None if numbers.is_empty() => {
            return Err(format!("{}: the asset has no frames", path.display()));
        }
        None => 0,
    };
    let blocks = asset.frame(k).map_err(|e| e.to_string())?;
    let block = blocks.find(haze_asset::BlockKind::Rbfs).ok_or_else(|| {
        format!(
            "{}: frame {} has no RBF block (not a baked asset?)",
            path.display(),
            numbers[k]
        )
    })?;
    let rbfs = haze_asset::decode_rbfs(block.bytes)
        .map_err(|e| asset.block_error(&block, e).to_string())?;
    Ok(rbfs
        .into_iter()
        .map(|r| Gaussian {
            center: [0, 1, 2].map(|a| r.center[a] + offset[a]),
            radius: r.radius,
            weight: r.weight,
        })
        .collect())
}

/// The most Gaussians one medium may hold, 2²⁰: past it a picture's preparation (each
/// Gaussian's exponents per light through its neighbours) takes minutes and memory in
/// gigabytes. 100 000 Gaussians filling a 6 × 6 × 3 box with a lamp among them take 15 s
/// and 130 MB at 80 × 60 on two cores (11 s of it the preparation).
pub const MAX_GAUSSIANS: usize = 1 << 20;

/// Refuses a medium of more than [`MAX_GAUSSIANS`].
fn check_count(n: usize) -> Result<(), String> {
    if n > MAX_GAUSSIANS {
        return Err(format!(
            "{n} Gaussians; at most {MAX_GAUSSIANS} (paper B's cost grows with their number)"
        ));
    }
    Ok(())
}

/// Reads a `"gaussians"` medium, its asset (if any) relative to `base`; the error is one
/// line naming the key.
pub fn parse(v: &Value, base: &Path) -> Result<GaussianMediumOf, String> {
    let s: MediumSpec = MediumSpec::deserialize(v).map_err(|e| e.to_string())?;
    if s.g != 0.0 {
        return Err(format!(
            "g = {}: paper B's Gaussian media scatter isotropically (g = 0)",
            s.g
        ));
    }
    let mut gaussians: Vec<Gaussian> = s
        .gaussians
        .into_iter()
        .map(|g| Gaussian {
            center: g.center,
            radius: g.radius,
            weight: g.weight,
        })
        .collect();
    match (&s.asset, s.frame, s.offset) {
        (Some(a), frame, offset) => {
            let offset = offset.unwrap_or([0.0; 3]);
            if !offset.iter().all(|x| x.is_finite()) {
                return Err("offset must be finite".to_string());
            }
            gaussians.extend(asset_gaussians(&base.join(a), frame, offset)?);
        }
        (None, Some(_), _) => return Err("\"frame\" needs \"asset\"".to_string()),
        (None, _, Some(_)) => return Err("\"offset\" needs \"asset\"".to_string()),
        (None, None, None) => {}
    }
    crate::media::check_sigma_t(&[s.sigma_t])?;
    check_count(gaussians.len())?;
    let medium = GaussianMedium::new(s.sigma_t, s.albedo, s.background, gaussians)?;
    let noise = match s.noise {
        None => None,
        Some(n) => {
            if !(n.gain.is_finite() && n.gain >= 0.0) {
                return Err(format!(
                    "noise.gain {} must be finite and not negative",
                    shown(n.gain)
                ));
            }
            if !(n.frequency.is_finite() && n.frequency > 0.0) {
                return Err(format!(
                    "noise.frequency {} must be positive",
                    shown(n.frequency)
                ));
            }
            if !n.offset.iter().all(|x| x.is_finite()) {
                return Err("noise.offset must be finite".to_string());
            }
            Some(Noise {
                perlin: Perlin::new(n.seed),
                gain: n.gain,
                frequency: n.frequency,
                offset: n.offset,
            })
        }
    };
    Ok(GaussianMediumOf { medium, noise })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<GaussianMediumOf, String> {
        parse(&serde_json::from_str(s).unwrap(), Path::new(""))
    }

    #[test]
    fn a_medium_holds_up_to_its_cap() {
        assert!(check_count(0).is_ok());
        assert!(check_count(100_000).is_ok());
        assert!(check_count(MAX_GAUSSIANS).is_ok());
        let e = check_count(MAX_GAUSSIANS + 1).unwrap_err();
        assert_eq!(
            e,
            "1048577 Gaussians; at most 1048576 (paper B's cost grows with their number)"
        );
    }

    #[test]
    fn reads_the_keys_and_refuses_bad_ones() {
        let m = parse_str(
            r#"{"type": "gaussians", "sigma_t": 2, "albedo": 0.5, "background": 0.1,
                "gaussians": [{"center": [0, 0, 1], "radius": 0.5, "weight": 0.8}],
                "noise": {"seed": 3, "gain": 0.4}}"#,
        )
        .unwrap();
        assert_eq!(m.medium.gaussians().len(), 1);
        assert_eq!(m.medium.beta0(), 0.2);
        assert_eq!(m.sigma_t([0.0, 0.0, 1.0]), [2.0 * 0.8 + 0.2; 3]);
        assert!(m.bounds().is_none());
        assert_eq!(m.noise.as_ref().unwrap().frequency, 1.0);
        for (text, want) in [
            (
                r#"{"type": "gaussians", "sigma_t": 1, "g": 0.3}"#,
                "g = 0.3",
            ),
            (
                r#"{"type": "gaussians", "sigma_t": 1, "colour": 1}"#,
                "unknown field `colour`",
            ),
            (
                r#"{"type": "gaussians", "sigma_t": 1, "gaussians": [{"center": [0,0,0], "radius": -1, "weight": 1}]}"#,
                "gaussians[0].radius -1 must be positive",
            ),
            (
                r#"{"type": "gaussians", "sigma_t": 1, "gaussians": [{"center": [0,0,0], "radius": 1e300, "weight": 1}]}"#,
                "gaussians[0].radius 1e300 must be positive and at most 1e9",
            ),
            (
                r#"{"type": "gaussians", "sigma_t": 1, "gaussians": [{"center": [0,0,0], "radius": 1, "weight": -1e300}]}"#,
                "gaussians[0].weight -1e300 must be finite",
            ),
            (
                r#"{"type": "gaussians", "sigma_t": 1, "noise": {"gain": -1}}"#,
                "noise.gain -1",
            ),
            (
                r#"{"type": "gaussians", "sigma_t": 1, "noise": {"gain": 1, "frequency": 0}}"#,
                "noise.frequency 0",
            ),
        ] {
            let e = parse_str(text).unwrap_err();
            assert!(e.contains(want), "{e}");
        }
    }
}
