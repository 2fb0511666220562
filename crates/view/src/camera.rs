//! The pinhole camera of `haze render` (DESIGN.md): `eye`, `target`, `up`, vertical field
//! of view in degrees; image row 0 is the top; rays through pixel centers.

use haze_volume::Bbox;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (n > 0.0 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

/// A pinhole camera with its image size.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: [f64; 3],
    /// Unit vectors: viewing direction, image right, image up.
    forward: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    /// `tan(fov/2)`.
    tan_half: f64,
    pub width: usize,
    pub height: usize,
}

impl Camera {
    /// Refuses a target at the eye, an `up` parallel to the view, a field of view outside
    /// (0°, 180°) and an empty image.
    pub fn new(
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        fov_degrees: f64,
        width: usize,
        height: usize,
    ) -> Result<Camera, String> {
        if width == 0 || height == 0 {
            return Err(format!("image of {width}×{height} pixels is empty"));
        }
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            return Err(format!(
                "field of view {fov_degrees}° must be between 0 and 180 degrees"
            ));
        }
        let forward = normalize(sub(target, eye)).ok_or("the camera target is at the eye")?;
        let right = normalize(cross(forward, up))
            .filter(|r| r.iter().all(|c| c.is_finite()))
            .ok_or("the up vector is parallel to the viewing direction")?;
        let up = cross(right, forward);
        Ok(Camera {
            eye,
            forward,
            right,
            up,
            tan_half: (fov_degrees.to_radians() / 2.0).tan(),
            width,
            height,
        })
    }

    /// A view of `bbox` from the front-right and a little above (Z up), far enough that
    /// the whole box fits the vertical field of view `fov_degrees`.
    pub fn framing(
        bbox: &Bbox,
        fov_degrees: f64,
        width: usize,
        height: usize,
    ) -> Result<Camera, String> {
        let c = [0, 1, 2].map(|a| 0.5 * (bbox.min[a] + bbox.max[a]));
        let s = bbox.size();
        let radius = 0.5 * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let half = (fov_degrees.clamp(1.0, 179.0).to_radians() / 2.0)
            .tan()
            .atan();
        let aspect = (width as f64 / height.max(1) as f64).min(1.0);
        let dist = radius / (half.sin() * aspect).max(1e-6) * 1.05;
        let dir = normalize([0.0, -1.0, 0.25]).unwrap_or([0.0, -1.0, 0.0]);
        let eye = [
            c[0] + dist * dir[0],
            c[1] + dist * dir[1],
            c[2] + dist * dir[2],
        ];
        Camera::new(eye, c, [0.0, 0.0, 1.0], fov_degrees, width, height)
    }

    /// Unit direction of the ray through image point `(px, py)` in pixels (`(0.5, 0.5)` is
    /// the center of the top-left pixel).
    pub fn ray(&self, px: f64, py: f64) -> [f64; 3] {
        let aspect = self.width as f64 / self.height as f64;
        let sx = (2.0 * px / self.width as f64 - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - 2.0 * py / self.height as f64) * self.tan_half;
        let d = [0, 1, 2].map(|a| self.forward[a] + sx * self.right[a] + sy * self.up[a]);
        normalize(d).unwrap_or(self.forward)
    }

    /// The ray through the center of pixel `(x, y)`.
    pub fn pixel_ray(&self, x: usize, y: usize) -> [f64; 3] {
        self.ray(x as f64 + 0.5, y as f64 + 0.5)
    }

    pub fn forward(&self) -> [f64; 3] {
        self.forward
    }

    /// Unit vector of the image's right, `forward × up` normalized.
    pub fn right(&self) -> [f64; 3] {
        self.right
    }

    /// Unit vector of the image's up, `right × forward`.
    pub fn up(&self) -> [f64; 3] {
        self.up
    }

    /// `tan(fov/2)`: the image's top edge is at `forward + tan_half·up`.
    pub fn tan_half(&self) -> f64 {
        self.tan_half
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn center_ray_looks_at_the_target_and_row_zero_is_the_top() {
        let c = Camera::new([0.0, -5.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 60.0, 101, 51).unwrap();
        let d = c.pixel_ray(50, 25);
        assert!((d[1] - 1.0).abs() < 1e-12, "{d:?}");
        assert!(c.pixel_ray(50, 0)[2] > 0.0);
        assert!(
            c.pixel_ray(100, 25)[0] > 0.0,
            "right is +X when looking along +Y"
        );
        // The top edge of the image is fov/2 above the axis.
        let top = c.ray(50.5, 0.0);
        assert!((top[2].atan2(top[1]).to_degrees() - 30.0).abs() < 1e-9);
    }

    #[test]
    fn degenerate_cameras_are_refused() {
        let up = [0.0, 0.0, 1.0];
        assert!(Camera::new([0.0; 3], [0.0; 3], up, 45.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [0.0, 0.0, 1.0], up, 45.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [1.0, 0.0, 0.0], up, 0.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [1.0, 0.0, 0.0], up, 45.0, 0, 4).is_err());
    }

    #[test]
    fn framing_sees_every_corner_of_the_box() {
        let b = Bbox::new([-1.5, -1.5, 0.0], [1.5, 1.5, 4.0]);
        let c = Camera::framing(&b, 40.0, 400, 300).unwrap();
        for i in 0..8 {
            let p = [0, 1, 2].map(|a| if i >> a & 1 == 1 { b.max[a] } else { b.min[a] });
            let d = normalize(sub(p, c.eye)).unwrap();
            let f = d[0] * c.forward[0] + d[1] * c.forward[1] + d[2] * c.forward[2];
            let x = (d[0] * c.right[0] + d[1] * c.right[1] + d[2] * c.right[2]) / f;
            let y = (d[0] * c.up[0] + d[1] * c.up[1] + d[2] * c.up[2]) / f;
            assert!(f > 0.0 && y.abs() <= c.tan_half && x.abs() <= c.tan_half * 4.0 / 3.0);
        }
    }
}
