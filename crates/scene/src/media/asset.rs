//! A baked smoke asset placed in a scene (docs/formats.md "Scene file", media type `"asset"`):
//! one frame of a `.haze` file, its density `D = max(D̃ + R, 0)` — the frame's RBFs
//! (paper A §5) evaluated at the asset's voxel centers plus its dequantized residual
//! (§5.3), exactly as `haze render` reconstructs a frame — resampled once into a
//! [`VoxelGrid`] placed at `offset + scale·x` and scaled to extinction `σt·D`. The scene's
//! renderers then light it by its point lights and suns, and its optical depth shadows
//! the surfaces (paper A §6, smoke → surfaces).

use super::voxel_grid::VoxelGrid;
use super::{Aabb, Heterogeneous};
use crate::vec3::Vec3;
use haze_asset::Asset;
use haze_core::Rgb;
use haze_core::number::shown;
use haze_view::stream::{FrameDecoder, StreamFrame};
use haze_volume::{Bbox, rbf};
use serde::Deserialize;
use serde_json::Value;
use std::path::Path;
use std::sync::Arc;

/// A smoke asset's frame as a medium.
#[derive(Debug)]
pub struct AssetMedium {
    name: String,
    grid: VoxelGrid,
    albedo: Rgb,
    g: f64,
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
struct AssetSpec {
    #[serde(rename = "type")]
    _kind: String,
    path: String,
    #[serde(default)]
    frame: Option<i64>,
    #[serde(default = "one")]
    sigma_t: Scalar3,
    #[serde(default = "default_albedo")]
    albedo: f64,
    #[serde(default)]
    g: f64,
    #[serde(default)]
    offset: Vec3,
    #[serde(default = "unit")]
    scale: f64,
}

fn one() -> Scalar3 {
    Scalar3::One(1.0)
}
fn default_albedo() -> f64 {
    0.9
}
fn unit() -> f64 {
    1.0
}

/// The density of frame `frame` (a source frame number; `None`: the first) of the asset
/// at `path` on the asset's grid — `D = max(Σ RBFs + R, 0)` at every voxel center — with
/// the grid's dims and box; errors are one line naming the file.
pub fn frame_density(
    path: &Path,
    frame: Option<i64>,
) -> Result<(Vec<f32>, [usize; 3], Bbox), String> {
    let asset = Asset::open(path).map_err(|e| e.to_string())?;
    let numbers = asset.header().source.frame_numbers.clone();
    let k = match frame {
        None if numbers.is_empty() => {
            return Err(format!("{}: the asset has no frames", path.display()));
        }
        None => 0,
        Some(f) => numbers.iter().position(|&n| n == f).ok_or_else(|| {
            format!(
                "{}: frame {f} is not in the asset (frames {}..{})",
                path.display(),
                numbers.first().copied().unwrap_or(0),
                numbers.last().copied().unwrap_or(0)
            )
        })?,
    };
    let mut decoder = FrameDecoder::new(Arc::new(asset));
    let f: StreamFrame = decoder.decode(k).map_err(|e| e.to_string())?;
    let g = &decoder.asset().header().grid;
    let dims = g.dims.map(|d| d as usize);
    let bbox = Bbox::new(g.bbox_min, g.bbox_max);
    if dims.contains(&0)
        || (0..3)
            .any(|a| bbox.max[a].partial_cmp(&bbox.min[a]) != Some(std::cmp::Ordering::Greater))
    {
        return Err(format!(
            "{}: the asset's grid {dims:?} over {:?}..{:?} is empty",
            path.display(),
            bbox.min,
            bbox.max
        ));
    }
    let approx = rbf::evaluate_on_grid(dims, &bbox, &f.rbfs);
    let residual = match &f.residual {
        Some(slot) => slot.dense(),
        None => vec![0.0; approx.len()],
    };
    let data = approx
        .iter()
        .zip(&residual)
        .map(|(a, r)| (a + f64::from(*r)).max(0.0) as f32)
        .collect();
    Ok((data, dims, bbox))
}

impl AssetMedium {
    /// The medium of a scene file's `{"type": "asset", ...}` object, its path relative to
    /// `base` (the scene file's folder).
    pub fn from_json(v: &Value, base: &Path) -> Result<AssetMedium, String> {
        let s = AssetSpec::deserialize(v).map_err(|e| e.to_string())?;
        let sigma = match s.sigma_t {
            Scalar3::One(x) => [x; 3],
            Scalar3::Rgb(c) => c,
        };
        if !sigma.iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err(format!("sigma_t {sigma:?} must not be negative"));
        }
        if !(0.0..=1.0).contains(&s.albedo) {
            return Err(format!("albedo {} must be in [0, 1]", shown(s.albedo)));
        }
        if !(s.g > -1.0 && s.g < 1.0) {
            return Err(format!("g {} must be in (-1, 1)", shown(s.g)));
        }
        if !s.offset.iter().all(|x| x.is_finite()) {
            return Err("offset must be finite".into());
        }
        if !(s.scale > 0.0 && s.scale.is_finite()) {
            return Err(format!("scale {} must be positive", shown(s.scale)));
        }
        let path = base.join(&s.path);
        let (data, dims, bbox) = frame_density(&path, s.frame)?;
        let size = bbox.size();
        let grid = VoxelGrid {
            dims,
            min: [0, 1, 2].map(|a| s.offset[a] + s.scale * bbox.min[a]),
            voxel: [0, 1, 2].map(|a| s.scale * size[a] / dims[a] as f64),
            data,
            scale: sigma,
        }
        .cropped();
        let frame = s.frame.map_or(String::new(), |f| format!(" frame {f}"));
        Ok(AssetMedium {
            name: format!("asset {}{frame}", s.path),
            grid,
            albedo: [s.albedo; 3],
            g: s.g,
        })
    }

    /// The resampled extinction.
    pub fn grid(&self) -> &VoxelGrid {
        &self.grid
    }
}

impl Heterogeneous for AssetMedium {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn sigma_t(&self, x: Vec3) -> Rgb {
        self.grid.sigma_t(x)
    }
    fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> Rgb {
        self.grid.optical_depth(o, d, len)
    }
    fn albedo(&self) -> Rgb {
        self.albedo
    }
    fn g(&self) -> f64 {
        self.g
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(self.grid.bounds())
    }
    fn occupies(&self, b: &Aabb) -> bool {
        self.grid.occupies(b)
    }
}
