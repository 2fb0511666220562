//! The scene's pinhole camera (DESIGN.md "Conventions"): `eye`, `target`, `up`, vertical
//! field of view in degrees; image row 0 is the top; rays through pixel centers.

use crate::vec3::{Vec3, axpy, cross, normalize, sub};

/// A pinhole camera with its image size.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// `tan(fov/2)`.
    tan_half: f64,
    pub width: usize,
    pub height: usize,
}

impl Camera {
    /// Refuses a target at the eye, an `up` parallel to the view, a field of view outside
    /// (0°, 180°) and an empty image.
    pub fn new(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_degrees: f64,
        width: usize,
        height: usize,
    ) -> Result<Camera, String> {
        if width == 0 || height == 0 {
            return Err(format!("image of {width}×{height} pixels is empty"));
        }
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            return Err(format!(
                "fov {fov_degrees} must be between 0 and 180 degrees"
            ));
        }
        let forward = normalize(sub(target, eye)).ok_or("the target is at the eye")?;
        let right =
            normalize(cross(forward, up)).ok_or("up is parallel to the viewing direction")?;
        Ok(Camera {
            eye,
            forward,
            right,
            up: cross(right, forward),
            tan_half: (fov_degrees.to_radians() / 2.0).tan(),
            width,
            height,
        })
    }

    /// The same camera with another image size.
    pub fn with_size(mut self, width: usize, height: usize) -> Result<Camera, String> {
        if width == 0 || height == 0 {
            return Err(format!("image of {width}×{height} pixels is empty"));
        }
        self.width = width;
        self.height = height;
        Ok(self)
    }

    /// Unit direction of the ray through image point `(px, py)` in pixels (`(0.5, 0.5)` is
    /// the center of the top-left pixel).
    pub fn ray(&self, px: f64, py: f64) -> Vec3 {
        let aspect = self.width as f64 / self.height as f64;
        let sx = (2.0 * px / self.width as f64 - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - 2.0 * py / self.height as f64) * self.tan_half;
        let d = axpy(axpy(self.forward, sx, self.right), sy, self.up);
        normalize(d).unwrap_or(self.forward)
    }

    /// The ray through the center of pixel `(x, y)`.
    pub fn pixel_ray(&self, x: usize, y: usize) -> Vec3 {
        self.ray(x as f64 + 0.5, y as f64 + 0.5)
    }

    /// Half the angle a pixel subtends at the image center (radians): the radius of the
    /// disc a pixel's rays cover, used to bound the airlight's `1/γ` peak at a light.
    pub fn pixel_radius(&self) -> f64 {
        (self.tan_half / self.height as f64).atan()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vec3::dot;

    #[test]
    fn rays_follow_the_conventions() {
        let c = Camera::new([0.0; 3], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], 90.0, 4, 2).unwrap();
        // The image center looks at the target; row 0 is the top, column 0 the left.
        let d = c.ray(2.0, 1.0);
        assert!((d[1] - 1.0).abs() < 1e-15);
        assert!(c.pixel_ray(0, 0)[2] > 0.0 && c.pixel_ray(0, 0)[0] < 0.0);
        // fov 90°: the top edge of the image is 45° up.
        let top = c.ray(2.0, 0.0);
        assert!((dot(top, [0.0, 0.0, 1.0]) - (0.5f64).sqrt()).abs() < 1e-12);
        assert!(Camera::new([0.0; 3], [0.0; 3], [0.0, 0.0, 1.0], 40.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 40.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 180.0, 4, 4).is_err());
    }
}
