//! What the renderer's tests share: the device, a small RBF scene in the unit cube and the
//! camera that frames it.

// Each test file is its own crate and uses only some of these.
#![allow(dead_code)]

use haze_gpu::GpuContext;
use haze_view::Camera;
use haze_volume::{Bbox, Rbf};

/// The GPU device (a CPU one will do: Mesa's lavapipe, which `scripts/test.sh`
/// installs); panics with the reason when there is none, so the tests fail, not skip.
pub fn context() -> GpuContext {
    match GpuContext::new() {
        Ok(ctx) => {
            println!("GPU adapter: {} ({})", ctx.adapter_name(), ctx.backend());
            ctx
        }
        Err(e) => panic!("{e}"),
    }
}

/// A small smoke-like cluster of Gaussians in the unit cube, mapped into `bbox`.
pub fn cluster(bbox: &Bbox) -> Vec<Rbf> {
    let s = bbox.size();
    let scale = s[0].min(s[1]).min(s[2]);
    [
        ([0.50, 0.50, 0.40], 0.14, 1.0),
        ([0.62, 0.45, 0.55], 0.10, 0.8),
        ([0.40, 0.58, 0.60], 0.11, 0.7),
        ([0.52, 0.50, 0.75], 0.08, 0.9),
        ([0.35, 0.40, 0.45], 0.07, 1.2),
        ([0.66, 0.62, 0.35], 0.09, 0.6),
    ]
    .into_iter()
    .map(|(c, r, w)| {
        let c = [0, 1, 2].map(|a| bbox.min[a] + c[a] * s[a]);
        Rbf::new(c, r * scale, w)
    })
    .collect()
}

/// The unit cube.
pub fn unit_box() -> Bbox {
    Bbox::new([0.0; 3], [1.0; 3])
}

/// The unit box seen from the front, slightly from above, 40° vertical field of view.
pub fn front_camera(width: usize, height: usize) -> Camera {
    Camera::new(
        [0.5, -1.3, 0.85],
        [0.5, 0.5, 0.52],
        [0.0, 0.0, 1.0],
        40.0,
        width,
        height,
    )
    .unwrap()
}
