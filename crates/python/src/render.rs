//! `haze.render` and `haze.render_scene`: `haze render`'s renderers, the image returned
//! as a float32 `(height, width, 3)` NumPy array of linear radiance.

use crate::{to_py, warnings};
use haze_core::Image;
use haze_render::lights::MapPlacement;
use haze_render::output::Outputs;
use haze_render::scene::SceneJob;
use haze_render::smoke::{RenderOptions, Supersample, render_image};
use haze_view::{PointLight, Sun};
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3};
use pyo3::prelude::*;
use std::path::PathBuf;

/// `image` as a `(height, width, 3)` array, moved into NumPy without a copy.
fn to_array(py: Python<'_>, image: Image) -> PyResult<Bound<'_, PyArray3<f32>>> {
    let (w, h) = (image.width, image.height);
    let flat: Vec<f32> = image.pixels.into_iter().flatten().collect();
    let a = Array3::from_shape_vec((h, w, 3), flat)
        .map_err(|e| to_py(anyhow::anyhow!("image shape: {e}")))?;
    Ok(a.into_pyarray(py))
}

/// The suns `(x, y, z, r, g, b[, angle])` as `--sun` takes them.
fn suns(given: Vec<Vec<f64>>) -> anyhow::Result<Vec<Sun>> {
    given
        .into_iter()
        .map(|v| {
            if !(6..=7).contains(&v.len()) {
                anyhow::bail!("suns: expected (x, y, z, r, g, b[, angle]), got {v:?}");
            }
            let angle = v.get(6).copied().unwrap_or(0.53);
            Sun::from_radiance([v[0], v[1], v[2]], [v[3], v[4], v[5]], angle)
                .map_err(|e| anyhow::anyhow!("suns: {e}"))
        })
        .collect()
}

/// The point lights `(x, y, z, r, g, b)` as `--light` takes them.
fn lights(given: Vec<Vec<f64>>) -> anyhow::Result<Vec<PointLight>> {
    given
        .into_iter()
        .map(|v| {
            if v.len() != 6 {
                anyhow::bail!("lights: expected (x, y, z, r, g, b), got {v:?}");
            }
            PointLight::new([v[0], v[1], v[2]], [v[3], v[4], v[5]])
                .map_err(|e| anyhow::anyhow!("lights: {e}"))
        })
        .collect()
}

/// `supersample`: `"auto"` or 1..4.
fn supersample(given: &Bound<'_, PyAny>) -> PyResult<Supersample> {
    let text = match given.extract::<usize>() {
        Ok(n) => n.to_string(),
        Err(_) => given.extract::<String>()?,
    };
    text.parse()
        .map_err(|e: String| to_py(anyhow::anyhow!("supersample: {e}")))
}

/// The keywords `env_layout`, `env_rotate` and `env_strength` checked, as `haze render`'s
/// `--env-layout`, `--env-rotate` and `--env-strength` are.
pub(crate) fn placement(layout: &str, rotate: f64, strength: f64) -> PyResult<MapPlacement> {
    let layout = match layout {
        "haze" => haze_view::distant::Layout::Haze,
        "blender" => haze_view::distant::Layout::Blender,
        other => {
            return Err(to_py(anyhow::anyhow!(
                "env_layout: '{other}' is not 'haze' or 'blender'"
            )));
        }
    };
    if !rotate.is_finite() {
        return Err(to_py(anyhow::anyhow!(
            "env_rotate: {rotate} is not a finite angle in degrees"
        )));
    }
    if !(strength.is_finite() && strength >= 0.0) {
        return Err(to_py(anyhow::anyhow!(
            "env_strength: {strength} is not a finite factor of at least 0"
        )));
    }
    Ok(MapPlacement {
        layout,
        turn_degrees: rotate,
        strength,
    })
}

/// One frame of an asset or a volume, rendered (`haze render`'s options; the Python
/// half documents them).
#[pyfunction]
#[pyo3(signature = (
    input, frame=None, width=400, height=300, eye=None, target=None, up=[0.0, 0.0, 1.0],
    fov=40.0, env="sky".to_string(), suns_=Vec::new(), lights_=Vec::new(), sigma_t=4.0,
    albedo=0.8, g=0.3, multiple=true, residual=true, sh_order=4, gpu=false,
    reference=false, spp=64, check=0, supersample_=None, ground="auto".to_string(),
    env_layout="haze".to_string(), env_rotate=0.0, env_strength=1.0
))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    input: PathBuf,
    frame: Option<i64>,
    width: usize,
    height: usize,
    eye: Option<[f64; 3]>,
    target: Option<[f64; 3]>,
    up: [f64; 3],
    fov: f64,
    env: String,
    suns_: Vec<Vec<f64>>,
    lights_: Vec<Vec<f64>>,
    sigma_t: f64,
    albedo: f64,
    g: f64,
    multiple: bool,
    residual: bool,
    sh_order: usize,
    gpu: bool,
    reference: bool,
    spp: u32,
    check: usize,
    supersample_: Option<Bound<'py, PyAny>>,
    ground: String,
    env_layout: String,
    env_rotate: f64,
    env_strength: f64,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let mut a = RenderOptions::new(&input, "haze.render");
    a.frame = frame;
    (a.width, a.height) = (width, height);
    (a.eye, a.target, a.up, a.fov) = (eye, target, up, fov);
    a.env.env = env;
    a.env.placement = placement(&env_layout, env_rotate, env_strength)?;
    a.env.sun = suns(suns_).map_err(to_py)?;
    a.env.light = lights(lights_).map_err(to_py)?;
    (a.sigma_t, a.albedo, a.g) = (sigma_t, albedo, g);
    (a.multiple, a.residual, a.sh_order) = (multiple, residual, sh_order);
    (a.gpu, a.reference, a.spp, a.check) = (gpu, reference, spp, check);
    if let Some(s) = supersample_ {
        a.supersample = supersample(&s)?;
    }
    a.ground = ground
        .parse()
        .map_err(|e: String| to_py(anyhow::anyhow!("ground: {e}")))?;
    let rendered = py.detach(|| render_image(&a));
    warnings::flush(py)?;
    let rendered = rendered.map_err(to_py)?;
    to_array(py, rendered.image)
}

/// A scene file rendered (`haze render --scene`), through a temporary OpenEXR image.
#[pyfunction]
#[pyo3(signature = (scene, width=None, height=None, gpu=false, reference=false, time=0.0))]
pub fn render_scene<'py>(
    py: Python<'py>,
    scene: PathBuf,
    width: Option<usize>,
    height: Option<usize>,
    gpu: bool,
    reference: bool,
    time: f64,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let image = py.detach(|| -> anyhow::Result<Image> {
        let dir = tempfile::tempdir()?;
        let out = dir.path().join("scene.exr");
        Outputs::new().input(&scene).output("out", &out).check()?;
        haze_render::scene::render_scene(SceneJob {
            scene: scene.clone(),
            out: out.clone(),
            width,
            height,
            reference,
            gpu,
            exposure: 1.0,
            tone: haze_core::ToneMap::Filmic,
            time,
            march: false,
            exact_per_pair: None,
            pair_reuse: haze_render::scene::DEFAULT_PAIR_REUSE,
            sky_shadow: true,
        })?;
        Ok(Image::read_exr(&out)?)
    });
    warnings::flush(py)?;
    let image = image.map_err(to_py)?;
    to_array(py, image)
}
