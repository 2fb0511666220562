//! The scene file (docs/formats.md "Scene file"): one JSON object read into a [`Scene`].
//!
//! Every object refuses keys it does not know; every problem — a missing file, bad JSON,
//! an unknown key, a wrong type, a negative radius, a zero normal, a type not supported
//! yet — is one line naming the file, the place in it and the problem.

use crate::Camera;
use crate::media::HeteroMedium;
use crate::mesh::Mesh;
use crate::mesh::model;
use crate::scene::{Environment, Light, Material, Medium, Rgb, Scene, Shape, Surface};
use crate::vec3::{Vec3, normalize};
use haze_view::LatLong;
use haze_view::distant::Layout;
use serde::Deserialize;
use serde::de::DeserializeOwned;
use serde_json::Value;
use std::path::Path;
use std::sync::Arc;

/// Why a scene could not be read: `file: problem`, on one line.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct SceneError {
    pub file: String,
    pub problem: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    camera: CameraSpec,
    #[serde(default)]
    environment: Value,
    #[serde(default)]
    environment_distance: Option<f64>,
    #[serde(default)]
    lights: Vec<Value>,
    #[serde(default)]
    media: Vec<Value>,
    #[serde(default)]
    surfaces: Vec<Value>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSpec {
    eye: Vec3,
    target: Vec3,
    #[serde(default = "default_up")]
    up: Vec3,
    #[serde(default = "default_fov")]
    fov: f64,
    #[serde(default = "default_width")]
    width: usize,
    #[serde(default = "default_height")]
    height: usize,
}

fn default_up() -> Vec3 {
    [0.0, 0.0, 1.0]
}
fn default_fov() -> f64 {
    40.0
}
fn default_width() -> usize {
    320
}
fn default_height() -> usize {
    240
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PointSpec {
    #[serde(rename = "type")]
    _kind: String,
    position: Vec3,
    intensity: Rgb,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SunSpec {
    #[serde(rename = "type")]
    _kind: String,
    direction: Vec3,
    radiance: Rgb,
    #[serde(default = "default_sun_angle")]
    angle: f64,
}

fn default_sun_angle() -> f64 {
    0.53
}

/// `σt` as one number or one per channel.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Scalar3 {
    One(f64),
    Rgb(Rgb),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct HomogeneousSpec {
    #[serde(rename = "type")]
    _kind: String,
    sigma_t: Scalar3,
    #[serde(default = "default_albedo")]
    albedo: f64,
    #[serde(default)]
    g: f64,
}

fn default_albedo() -> f64 {
    1.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialSpec {
    diffuse: Rgb,
    #[serde(default)]
    specular: Rgb,
    #[serde(default)]
    shininess: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlaneSpec {
    #[serde(rename = "type")]
    _kind: String,
    point: Vec3,
    normal: Vec3,
    material: MaterialSpec,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereSpec {
    #[serde(rename = "type")]
    _kind: String,
    center: Vec3,
    radius: f64,
    material: MaterialSpec,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshSpec {
    #[serde(rename = "type")]
    _kind: String,
    path: String,
    #[serde(default)]
    transform: TransformSpec,
    #[serde(default)]
    material: Option<MaterialSpec>,
}

/// `x ↦ translate + R(axis, degrees)·(scale ∘ x)`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformSpec {
    #[serde(default)]
    translate: Vec3,
    /// `[ax, ay, az, degrees]`.
    #[serde(default)]
    rotate: Option<[f64; 4]>,
    #[serde(default)]
    scale: Option<Scalar3>,
}

/// A JSON error in words: serde reports an array with one number too many (an `eye` of
/// four numbers) as "trailing characters", as it does text after the JSON; the text
/// parsing as JSON tells the two apart.
fn json_error(text: &str, e: &serde_json::Error) -> String {
    let msg = e.to_string();
    match msg.strip_prefix("trailing characters") {
        Some(at) if serde_json::from_str::<Value>(text).is_ok() => {
            format!("an array has more numbers than its key takes (X,Y,Z and R,G,B take 3){at}")
        }
        _ => msg,
    }
}

/// Reads and validates the scene file at `path`.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let err = |problem: String| SceneError {
        file: file.clone(),
        problem,
    };
    let text = std::fs::read_to_string(path).map_err(|e| {
        err(match e.kind() {
            std::io::ErrorKind::NotFound => "no such scene file".to_string(),
            _ => format!("cannot read ({e})"),
        })
    })?;
    parse_in(&text, path.parent().unwrap_or(Path::new("."))).map_err(err)
}

/// [`parse_in`] with paths relative to the working directory.
pub fn parse(text: &str) -> Result<Scene, String> {
    parse_in(text, Path::new(""))
}

/// Parses and validates a scene from JSON text, its files (models) relative to `base`;
/// the error is the problem alone (the caller names the scene file).
pub fn parse_in(text: &str, base: &Path) -> Result<Scene, String> {
    haze_core::json::unique_keys(text).map_err(|e| json_error(text, &e))?;
    let spec: FileSpec = serde_json::from_str(text).map_err(|e| json_error(text, &e))?;
    let c = &spec.camera;
    for (name, v) in [("eye", c.eye), ("target", c.target), ("up", c.up)] {
        finite(&format!("camera.{name}"), &v)?;
    }
    let camera = Camera::new(c.eye, c.target, c.up, c.fov, c.width, c.height)
        .map_err(|e| format!("camera: {e}"))?;
    let environment = environment(&spec.environment, base)?;
    let environment_distance = match spec.environment_distance {
        None => f64::INFINITY,
        Some(d) if d > 0.0 => d,
        Some(d) => {
            return Err(format!(
                "environment_distance {} must be positive",
                haze_core::number::shown(d)
            ));
        }
    };
    let lights = spec
        .lights
        .iter()
        .enumerate()
        .map(|(i, v)| light(v).map_err(|e| format!("lights[{i}]: {e}")))
        .collect::<Result<Vec<_>, _>>()?;
    let mut medium = Medium::NONE;
    let mut sigma_s = [0.0; 3];
    let mut hetero = Vec::new();
    for (i, v) in spec.media.iter().enumerate() {
        let k = kind(v).map_err(|e| format!("media[{i}]: {e}"))?;
        // A smoke asset's density ([`crate::media::asset`]).
        if k == "asset" {
            let m = crate::media::asset::AssetMedium::from_json(v, base)
                .map_err(|e| format!("media[{i}]: {e}"))?;
            hetero.push(HeteroMedium::Asset(Arc::new(m)));
            continue;
        }
        // Paper B's Gaussian media ([`crate::media::gaussians`]).
        if k == "gaussians" {
            let m =
                crate::media::gaussians::parse(v, base).map_err(|e| format!("media[{i}]: {e}"))?;
            hetero.push(HeteroMedium::Gaussians(Arc::new(m)));
            continue;
        }
        // Paper D's analytic fog ([`crate::media::analytic`]).
        if k == "analytic" {
            let m = crate::media::analytic::parse(v).map_err(|e| format!("media[{i}]: {e}"))?;
            hetero.push(HeteroMedium::Analytic(Arc::new(m)));
            continue;
        }
        let (st, ss) = homogeneous(v).map_err(|e| format!("media[{i}]: {e}"))?;
        for c in 0..3 {
            medium.sigma_t[c] += st[c];
            sigma_s[c] += ss[c];
        }
    }
    medium.albedo = [0, 1, 2].map(|c| {
        if medium.sigma_t[c] > 0.0 {
            (sigma_s[c] / medium.sigma_t[c]).clamp(0.0, 1.0)
        } else {
            0.0
        }
    });
    let mut surfaces = Vec::new();
    for (i, v) in spec.surfaces.iter().enumerate() {
        surfaces.extend(surface(v, base).map_err(|e| format!("surfaces[{i}]: {e}"))?);
    }
    Ok(Scene {
        camera,
        environment,
        environment_distance,
        lights,
        medium,
        hetero,
        surfaces,
    })
}

/// The `"type"` of an object in a list.
fn kind(v: &Value) -> Result<&str, String> {
    match v.get("type") {
        Some(Value::String(s)) => Ok(s),
        Some(other) => Err(format!("\"type\" must be a string, not {other}")),
        None if v.is_object() => Err("missing \"type\"".to_string()),
        None => Err(format!("expected an object, found {v}")),
    }
}

fn typed<T: DeserializeOwned>(v: &Value) -> Result<T, String> {
    T::deserialize(v).map_err(|e| e.to_string())
}

fn finite(what: &str, v: &[f64]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite"))
    }
}

fn non_negative(what: &str, v: &[f64]) -> Result<(), String> {
    finite(what, v)?;
    if v.iter().all(|&x| x >= 0.0) {
        Ok(())
    } else {
        Err(format!("{what} {v:?} must not be negative"))
    }
}

/// A map with how to read it: `{"map": "ENV.exr", "layout": "haze" | "blender",
/// "rotate": degrees, "strength": s}` (`haze render --env-layout`, `--env-rotate`,
/// `--env-strength`; docs/conventions.md).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MapSpec {
    map: String,
    #[serde(default)]
    layout: Option<String>,
    #[serde(default)]
    rotate: f64,
    #[serde(default = "one")]
    strength: f64,
}

fn one() -> f64 {
    1.0
}

/// `null`, `"sky"`, `[r, g, b]`, a lat-long `.exr` or `.hdr` map, its path relative to
/// `base` (read by crates/view's [`LatLong::load`]), or a map with its layout, turn and
/// strength ([`MapSpec`]); `[0, 0, 0]` is black, as `null` (no environment terms
/// computed, no warning about them).
fn environment(v: &Value, base: &Path) -> Result<Environment, String> {
    match v {
        Value::Null => Ok(Environment::Black),
        Value::String(s) if s == "sky" => Ok(Environment::Sky),
        Value::String(s)
            if [".exr", ".hdr"]
                .iter()
                .any(|e| s.to_ascii_lowercase().ends_with(e)) =>
        {
            load_map(s, base).map(|m| Environment::Map(Arc::new(m)))
        }
        Value::Object(_) => {
            let spec: MapSpec = typed(v).map_err(|e| format!("environment: {e}"))?;
            let layout = match spec.layout.as_deref() {
                None | Some("haze") => Layout::Haze,
                Some("blender") => Layout::Blender,
                Some(other) => {
                    return Err(format!(
                        "environment: layout \"{other}\" must be \"haze\" or \"blender\""
                    ));
                }
            };
            if !spec.rotate.is_finite() {
                return Err(format!(
                    "environment: rotate {} must be finite",
                    spec.rotate
                ));
            }
            load_map(&spec.map, base)?
                .turned(layout, spec.rotate)
                .scaled(spec.strength)
                .map(|m| Environment::Map(Arc::new(m)))
                .map_err(|e| format!("environment \"{}\": {e}", spec.map))
        }
        Value::String(s) => Err(format!(
            "environment \"{s}\" must be \"sky\", an .exr or .hdr map, {{\"map\": …}}, [r, g, b] or null"
        )),
        _ => {
            let c: Rgb = typed(v).map_err(|e| format!("environment: {e}"))?;
            haze_view::lights::check_light("environment", &c)?;
            Ok(if c == [0.0; 3] {
                Environment::Black
            } else {
                Environment::Constant(c)
            })
        }
    }
}

/// The lat-long map at `name`, relative to `base`.
fn load_map(name: &str, base: &Path) -> Result<LatLong, String> {
    let path = base.join(name);
    if !path.is_file() {
        return Err(format!(
            "environment \"{name}\": no such environment map {}",
            path.display()
        ));
    }
    LatLong::load(&path).map_err(|e| format!("environment \"{name}\": {}", e.problem))
}

fn light(v: &Value) -> Result<Light, String> {
    match kind(v)? {
        "point" => {
            let p: PointSpec = typed(v)?;
            finite("position", &p.position)?;
            haze_view::lights::check_light("intensity", &p.intensity)?;
            Ok(Light::Point {
                position: p.position,
                intensity: p.intensity,
            })
        }
        "sun" => {
            let s: SunSpec = typed(v)?;
            finite("direction", &s.direction)?;
            haze_view::lights::check_light("radiance", &s.radiance)?;
            let direction = normalize(s.direction).ok_or("direction must not be zero")?;
            if !(0.0..180.0).contains(&s.angle) {
                return Err(format!(
                    "angle {} must be in [0, 180) degrees",
                    haze_core::number::shown(s.angle)
                ));
            }
            Ok(Light::Sun {
                direction,
                radiance: s.radiance,
                angle: s.angle.to_radians(),
            })
        }
        other => Err(format!(
            "unknown light type \"{other}\" (known: \"point\", \"sun\")"
        )),
    }
}

/// A homogeneous medium's `σt` and `σs` per channel.
fn homogeneous(v: &Value) -> Result<(Rgb, Rgb), String> {
    match kind(v)? {
        "homogeneous" => {
            let h: HomogeneousSpec = typed(v)?;
            let st = match h.sigma_t {
                Scalar3::One(s) => [s; 3],
                Scalar3::Rgb(c) => c,
            };
            crate::media::check_sigma_t(&st)?;
            if !(0.0..=1.0).contains(&h.albedo) {
                return Err(format!(
                    "albedo {} must be in [0, 1]",
                    haze_core::number::shown(h.albedo)
                ));
            }
            if h.g != 0.0 {
                return Err(format!(
                    "g = {}: only isotropic scattering (g = 0) is supported in homogeneous media yet (paper C's analytic model)",
                    h.g
                ));
            }
            Ok((st, st.map(|s| s * h.albedo)))
        }
        t @ "fogmap" => Err(format!("media type \"{t}\" is not supported yet")),
        other => Err(format!(
            "unknown media type \"{other}\" (known: \"homogeneous\", \"asset\", \"gaussians\", \"analytic\"; \"fogmap\" to come)"
        )),
    }
}

/// The highest Phong exponent a material takes: paper C's `G` tables are held to
/// quadrature up to it (`paper_c::gtable`'s lobe test), and their lobe rule's panels grow
/// as its square root (10⁹ took minutes a render).
pub const MAX_SHININESS: f64 = 1e5;

fn material(m: MaterialSpec) -> Result<Material, String> {
    non_negative("material.diffuse", &m.diffuse)?;
    non_negative("material.specular", &m.specular)?;
    non_negative("material.shininess", &[m.shininess])?;
    if m.shininess > MAX_SHININESS {
        return Err(format!(
            "material.shininess {} must be at most {MAX_SHININESS:e}: a lobe that narrow is a mirror",
            haze_core::number::shown(m.shininess)
        ));
    }
    Ok(Material {
        diffuse: m.diffuse,
        specular: m.specular,
        shininess: m.shininess,
    })
}

/// A surface of the file: one, or for a mesh without a material one per material of the
/// model.
fn surface(v: &Value, base: &Path) -> Result<Vec<Surface>, String> {
    match kind(v)? {
        "plane" => {
            let p: PlaneSpec = typed(v)?;
            finite("point", &p.point)?;
            finite("normal", &p.normal)?;
            let normal = normalize(p.normal).ok_or("normal must not be zero")?;
            Ok(vec![Surface {
                shape: Shape::Plane {
                    point: p.point,
                    normal,
                },
                material: material(p.material)?,
            }])
        }
        "sphere" => {
            let s: SphereSpec = typed(v)?;
            finite("center", &s.center)?;
            if !(s.radius > 0.0 && s.radius.is_finite()) {
                return Err(format!(
                    "radius {} must be positive",
                    haze_core::number::shown(s.radius)
                ));
            }
            Ok(vec![Surface {
                shape: Shape::Sphere {
                    center: s.center,
                    radius: s.radius,
                },
                material: material(s.material)?,
            }])
        }
        "mesh" => {
            let m: MeshSpec = typed(v)?;
            let t = &m.transform;
            finite("transform.translate", &t.translate)?;
            let [ax, ay, az, deg] = t.rotate.unwrap_or([0.0, 0.0, 1.0, 0.0]);
            finite("transform.rotate", &[ax, ay, az, deg])?;
            let scale = match t.scale {
                None => [1.0; 3],
                Some(Scalar3::One(s)) => [s; 3],
                Some(Scalar3::Rgb(s)) => s,
            };
            finite("transform.scale", &scale)?;
            if scale.contains(&0.0) {
                return Err(format!("transform.scale {scale:?} must not be zero"));
            }
            let transform = model::trs(t.translate, [ax, ay, az], deg, scale)
                .ok_or("transform.rotate: the axis must not be zero")?;
            let own = m.material.map(material).transpose()?;
            let parts = model::load(&base.join(&m.path), &transform)?;
            let surface = |material: Material, triangles| Surface {
                shape: Shape::Mesh(Arc::new(Mesh::new(triangles))),
                material,
            };
            Ok(match own {
                Some(mat) => vec![surface(
                    mat,
                    parts.into_iter().flat_map(|p| p.triangles).collect(),
                )],
                None => parts
                    .into_iter()
                    .map(|p| {
                        let mat = Material {
                            diffuse: p.base_color.map(|c| c.clamp(0.0, 1.0)),
                            specular: [0.0; 3],
                            shininess: 0.0,
                        };
                        surface(mat, p.triangles)
                    })
                    .collect(),
            })
        }
        other => Err(format!(
            "unknown surface type \"{other}\" (known: \"plane\", \"sphere\", \"mesh\")"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map with its layout, turn and strength is the plain map read so (`LatLong::turned`,
    /// then scaled); a bad layout, a non-finite turn, a negative strength and an unknown
    /// key are named.
    #[test]
    fn a_map_takes_its_layout_turn_and_strength() {
        let dir = tempfile::tempdir().unwrap();
        let image = haze_view::Image {
            width: 8,
            height: 4,
            pixels: (0..32).map(|i| [i as f32, 1.0, 0.5]).collect(),
        };
        image.write_exr(&dir.path().join("env.exr")).unwrap();
        let read = |v: Value| environment(&v, dir.path());
        let Ok(Environment::Map(plain)) = read(serde_json::json!("env.exr")) else {
            panic!("the plain map")
        };
        let spec =
            serde_json::json!({"map": "env.exr", "layout": "blender", "rotate": 45, "strength": 2});
        let Ok(Environment::Map(read_so)) = read(spec) else {
            panic!("the map read so")
        };
        let want = plain.turned(Layout::Blender, 45.0);
        let doubled: Vec<[f32; 3]> = want.texels.iter().map(|t| t.map(|c| 2.0 * c)).collect();
        assert_eq!(read_so.texels, doubled);
        let Ok(Environment::Map(same)) = read(serde_json::json!({"map": "env.exr"})) else {
            panic!("defaults")
        };
        assert_eq!(*same, *plain);
        for (bad, needle) in [
            (
                serde_json::json!({"map": "env.exr", "layout": "maya"}),
                "layout \"maya\" must be",
            ),
            (
                serde_json::json!({"map": "env.exr", "strength": -1}),
                "strength -1 must be",
            ),
            (
                serde_json::json!({"map": "env.exr", "turn": 3}),
                "unknown field `turn`",
            ),
            (
                serde_json::json!({"map": "gone.exr"}),
                "no such environment map",
            ),
        ] {
            let e = read(bad).unwrap_err();
            assert!(e.contains(needle), "{e}");
        }
    }

    const GOOD: &str = r#"{
        "camera": {"eye": [0, -5, 1], "target": [0, 0, 1], "fov": 50, "width": 8, "height": 6},
        "environment": "sky",
        "lights": [
            {"type": "point", "position": [1, 0, 2], "intensity": [10, 9, 8]},
            {"type": "sun", "direction": [0, 0, 2], "radiance": [1, 1, 1], "angle": 0}
        ],
        "media": [
            {"type": "homogeneous", "sigma_t": 0.1, "albedo": 0.8, "g": 0},
            {"type": "homogeneous", "sigma_t": [0.1, 0.2, 0.3]}
        ],
        "surfaces": [
            {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 3], "material": {"diffuse": [0.5, 0.5, 0.5]}},
            {"type": "sphere", "center": [0, 0, 1], "radius": 0.5,
             "material": {"diffuse": [0.8, 0.2, 0.2], "specular": [0.2, 0.2, 0.2], "shininess": 20}}
        ]
    }"#;

    /// A repeated key is refused by name and line; an array one number too long is said
    /// in words, and text after the JSON keeps serde's own message.
    #[test]
    fn repeated_keys_and_long_arrays_are_named() {
        let twice = GOOD.replace(r#""albedo": 0.8,"#, r#""albedo": 0.8, "albedo": 0.1,"#);
        let e = parse(&twice).unwrap_err();
        assert!(e.starts_with("duplicate key \"albedo\" at line 9"), "{e}");
        let long = GOOD.replace("[0, -5, 1]", "[0, -5, 1, 7]");
        let e = parse(&long).unwrap_err();
        assert!(
            e.starts_with("an array has more numbers than its key takes"),
            "{e}"
        );
        assert!(e.contains("at line 2"), "{e}");
        let e = parse(&format!("{GOOD} x")).unwrap_err();
        assert!(e.starts_with("trailing characters"), "{e}");
    }

    #[test]
    fn reads_every_supported_key() {
        let s = parse(GOOD).unwrap();
        assert_eq!((s.camera.width, s.camera.height), (8, 6));
        assert_eq!(s.environment, Environment::Sky);
        assert_eq!(s.lights.len(), 2);
        assert_eq!(
            s.lights[1],
            Light::Sun {
                direction: [0.0, 0.0, 1.0],
                radiance: [1.0; 3],
                angle: 0.0
            }
        );
        // Media add: σt = 0.1 + (0.1, 0.2, 0.3); σs = 0.08 + (0.1, 0.2, 0.3).
        assert!((s.medium.sigma_t[2] - 0.4).abs() < 1e-15);
        assert!((s.medium.albedo[0] - 0.18 / 0.2).abs() < 1e-15);
        assert_eq!(s.surfaces.len(), 2);
        assert_eq!(s.surfaces[1].material.shininess, 20.0);
        assert!(s.environment_distance.is_infinite());
        // A minimal scene: only a camera.
        let m = parse(r#"{"camera": {"eye": [0, 0, 0], "target": [1, 0, 0]}}"#).unwrap();
        assert_eq!((m.camera.width, m.camera.height), (320, 240));
        assert_eq!(m.environment, Environment::Black);
        // A black constant is no environment.
        let text =
            r#"{"camera": {"eye": [0, 0, 0], "target": [1, 0, 0]}, "environment": [0, 0, 0]}"#;
        assert_eq!(parse(text).unwrap().environment, Environment::Black);
        let text = text.replace("[0, 0, 0]", "[0, 0, 0.5]");
        assert_eq!(
            parse(&text).unwrap().environment,
            Environment::Constant([0.0, 0.0, 0.5])
        );
    }

    fn problem(edit: (&str, &str)) -> String {
        let text = GOOD.replacen(edit.0, edit.1, 1);
        assert_ne!(text, GOOD, "{edit:?} changes nothing");
        let e = parse(&text).unwrap_err();
        assert!(!e.contains('\n'), "not one line: {e}");
        e
    }

    #[test]
    fn problems_are_named() {
        let cases = [
            (
                ("\"fov\": 50", "\"fov\": 50, \"zoom\": 2"),
                "unknown field `zoom`",
            ),
            (
                ("\"radius\": 0.5", "\"radius\": -0.5"),
                "surfaces[1]: radius -0.5 must be positive",
            ),
            (
                ("\"normal\": [0, 0, 3]", "\"normal\": [0, 0, 0]"),
                "surfaces[0]: normal must not be zero",
            ),
            (
                ("\"intensity\": [10, 9, 8]", "\"intensity\": \"bright\""),
                "lights[0]: invalid type",
            ),
            (
                ("\"g\": 0", "\"g\": 0.3"),
                "media[0]: g = 0.3: only isotropic",
            ),
            (
                (
                    "\"type\": \"homogeneous\", \"sigma_t\": 0.1",
                    "\"type\": \"fogmap\", \"sigma_t\": 0.1",
                ),
                "media[0]: media type \"fogmap\" is not supported yet",
            ),
            (
                ("\"type\": \"plane\"", "\"type\": \"cone\""),
                "surfaces[0]: unknown surface type \"cone\"",
            ),
            (
                (
                    "\"environment\": \"sky\"",
                    "\"environment\": \"studio.exr\"",
                ),
                "environment \"studio.exr\": no such environment map studio.exr",
            ),
            (
                ("\"type\": \"sun\"", "\"type\": \"spot\""),
                "lights[1]: unknown light type \"spot\"",
            ),
            (
                ("\"albedo\": 0.8", "\"albedo\": 1.5"),
                "albedo 1.5 must be in [0, 1]",
            ),
            (
                ("\"shininess\": 20", "\"shininess\": 20, \"roughness\": 1"),
                "surfaces[1]: unknown field `roughness`",
            ),
            (
                ("\"shininess\": 20", "\"shininess\": 1e9"),
                "material.shininess 1000000000 must be at most 1e5",
            ),
            (
                ("\"intensity\": [10, 9, 8]", "\"intensity\": [10, 9, 1e31]"),
                "lights[0]: intensity 1e31 is above 1e30",
            ),
            (
                ("\"intensity\": [10, 9, 8]", "\"intensity\": [10, -9, 8]"),
                "lights[0]: intensity -9 must be finite and non-negative",
            ),
            (
                ("\"radiance\": [1, 1, 1]", "\"radiance\": [1, 1e45, 1]"),
                "lights[1]: radiance 1e45 is above 1e30",
            ),
            (
                ("\"environment\": \"sky\"", "\"environment\": [1, 1, 1e40]"),
                "environment 1e40 is above 1e30",
            ),
            (
                ("\"target\": [0, 0, 1]", "\"target\": [0, -5, 1]"),
                "camera: the target is at the eye",
            ),
        ];
        for (edit, needle) in cases {
            let e = problem(edit);
            assert!(e.contains(needle), "{edit:?}: {e}");
        }
    }

    #[test]
    fn load_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.json");
        let e = load(&path).unwrap_err().to_string();
        assert!(e.contains("scene.json: no such scene file"), "{e}");
        std::fs::write(&path, GOOD.replacen("\"fov\": 50", "\"fovy\": 50", 1)).unwrap();
        let e = load(&path).unwrap_err().to_string();
        assert!(e.contains("scene.json: unknown field `fovy`"), "{e}");
        std::fs::write(&path, "{ not json").unwrap();
        assert!(
            load(&path)
                .unwrap_err()
                .to_string()
                .contains("scene.json: ")
        );
        std::fs::write(&path, GOOD).unwrap();
        assert!(load(&path).is_ok());
    }
}
