//! The pinhole camera of every haze renderer (docs/conventions.md "Camera"): `eye`, `target`,
//! `up` (default `0,0,1`, need not be orthogonal to the view), vertical field of view in
//! degrees; image row 0 is the top, column 0 the left; rays through pixel centers.
//!
//! The camera's frame is orthonormal: `forward = normalize(target − eye)`,
//! `right = normalize(forward × up)`, `up' = right × forward`. The ray through image
//! point `(px, py)` (pixels, `(0.5, 0.5)` the center of the top-left pixel) has direction
//! `normalize(forward + sx·right + sy·up')` with
//! `sx = (2·px/W − 1)·tan(fov/2)·W/H` and `sy = (1 − 2·py/H)·tan(fov/2)`.

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n > 0.0 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

/// Where a camera stands and what it looks at, without an image size: the keys of the
/// command line and of the scene file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LookAt {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
}

impl LookAt {
    /// The camera for a `width × height` image (see [`Camera::new`]).
    pub fn camera(&self, width: usize, height: usize) -> Result<Camera, String> {
        Camera::new(self.eye, self.target, self.up, self.fov_deg, width, height)
    }
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
    /// Refuses a non-finite eye, target or up, a target at the eye, an `up` parallel to the
    /// view, a field of view outside (0°, 180°) and an empty image.
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
        if !eye.iter().chain(&target).chain(&up).all(|v| v.is_finite()) {
            return Err("the camera's eye, target and up must be finite".to_string());
        }
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            // As typed, or in scientific notation beyond 10¹⁶ (1e30, not 31 digits).
            let shown = if fov_degrees.abs() < 1e16 {
                format!("{fov_degrees}")
            } else {
                format!("{fov_degrees:e}")
            };
            return Err(format!(
                "field of view {shown}° must be between 0 and 180 degrees"
            ));
        }
        let forward = normalize(sub(target, eye))
            .ok_or("the target is at the eye (eye and target coincide)")?;
        let right = normalize(cross(forward, up))
            .ok_or("the up vector is parallel to the viewing direction")?;
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

    /// A view of the box `[min, max]` from the front-right and a little above (Z up), far
    /// enough that the whole box fits the vertical field of view `fov_degrees`: the eye is
    /// on `(0, −1, 0.25)` from the box's center at the distance where the bounding sphere
    /// fits the narrower image extent, plus 5 %.
    pub fn framing(
        min: [f64; 3],
        max: [f64; 3],
        fov_degrees: f64,
        width: usize,
        height: usize,
    ) -> Result<Camera, String> {
        let c = [0, 1, 2].map(|a| 0.5 * (min[a] + max[a]));
        let s = sub(max, min);
        let radius = 0.5 * dot(s, s).sqrt();
        let half = (fov_degrees.clamp(1.0, 179.0).to_radians() / 2.0)
            .tan()
            .atan();
        let aspect = (width as f64 / height.max(1) as f64).min(1.0);
        let dist = radius / (half.sin() * aspect).max(1e-6) * 1.05;
        let dir = normalize([0.0, -1.0, 0.25]).unwrap_or([0.0, -1.0, 0.0]);
        let eye = [0, 1, 2].map(|a| c[a] + dist * dir[a]);
        Camera::new(eye, c, [0.0, 0.0, 1.0], fov_degrees, width, height)
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

    /// The image point `(px, py)` in pixels where world point `p` appears, the inverse of
    /// [`Camera::ray`]; `None` for a point at or behind the eye's plane.
    pub fn project(&self, p: [f64; 3]) -> Option<(f64, f64)> {
        let d = sub(p, self.eye);
        let f = dot(d, self.forward);
        if f.is_nan() || f <= 0.0 {
            return None;
        }
        let aspect = self.width as f64 / self.height as f64;
        let sx = dot(d, self.right) / f / (self.tan_half * aspect);
        let sy = dot(d, self.up) / f / self.tan_half;
        Some((
            0.5 * (sx + 1.0) * self.width as f64,
            0.5 * (1.0 - sy) * self.height as f64,
        ))
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

    /// Half the angle a pixel subtends at the image center (radians): the radius of the
    /// disc a pixel's rays cover.
    pub fn pixel_radius(&self) -> f64 {
        (self.tan_half / self.height as f64).atan()
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
        assert!(c.pixel_ray(0, 25)[0] < 0.0);
        // The top edge of the image is fov/2 above the axis.
        let top = c.ray(50.5, 0.0);
        assert!((top[2].atan2(top[1]).to_degrees() - 30.0).abs() < 1e-9);
        // The left edge is atan(tan(fov/2)·W/H) to the side.
        let left = c.ray(0.0, 25.5);
        let want = ((30f64).to_radians().tan() * 101.0 / 51.0).atan();
        assert!(((-left[0]).atan2(left[1]) - want).abs() < 1e-12);
    }

    #[test]
    fn degenerate_cameras_are_refused() {
        let up = [0.0, 0.0, 1.0];
        let e = Camera::new([0.0; 3], [0.0; 3], up, 45.0, 4, 4).unwrap_err();
        assert!(
            e.contains("the target is at the eye") && e.contains("coincide"),
            "{e}"
        );
        assert!(Camera::new([0.0; 3], [0.0, 0.0, 1.0], up, 45.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [1.0, 0.0, 0.0], up, 0.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [1.0, 0.0, 0.0], up, 180.0, 4, 4).is_err());
        assert!(Camera::new([0.0; 3], [1.0, 0.0, 0.0], up, 45.0, 0, 4).is_err());
        assert!(Camera::new([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], up, 45.0, 4, 4).is_err());
        assert!(
            Camera::new(
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, f64::INFINITY, 1.0],
                45.0,
                4,
                4
            )
            .is_err()
        );
        let c = Camera::new([0.0; 3], [1.0, 0.0, 0.0], up, 45.0, 4, 4).unwrap();
        assert!(c.clone().with_size(0, 3).is_err());
        assert_eq!(c.with_size(8, 3).unwrap().width, 8);
    }

    #[test]
    fn an_up_off_the_perpendicular_is_made_orthonormal() {
        let c = Camera::new(
            [1.0, 2.0, 3.0],
            [4.0, -1.0, 0.5],
            [0.3, 0.2, 1.0],
            35.0,
            8,
            6,
        )
        .unwrap();
        let (f, r, u) = (c.forward(), c.right(), c.up());
        for (a, b) in [(f, r), (f, u), (r, u)] {
            assert!(dot(a, b).abs() < 1e-14);
        }
        for v in [f, r, u] {
            assert!((dot(v, v) - 1.0).abs() < 1e-14);
        }
        // The given up and the image's up lie on the same side of the view.
        assert!(dot(u, [0.3, 0.2, 1.0]) > 0.0);
    }

    #[test]
    fn project_inverts_ray() {
        let c = Camera::new(
            [1.0, -4.0, 2.0],
            [0.2, 0.5, 0.7],
            [0.0, 0.0, 1.0],
            50.0,
            40,
            30,
        )
        .unwrap();
        for (px, py) in [(0.5, 0.5), (39.5, 0.5), (20.0, 15.0), (3.25, 28.75)] {
            let d = c.ray(px, py);
            let p = [0, 1, 2].map(|a| c.eye[a] + 7.3 * d[a]);
            let (qx, qy) = c.project(p).unwrap();
            assert!(
                (qx - px).abs() < 1e-9 && (qy - py).abs() < 1e-9,
                "{px},{py} → {qx},{qy}"
            );
        }
        let behind = [0, 1, 2].map(|a| c.eye[a] - c.forward()[a]);
        assert!(c.project(behind).is_none());
        assert!(c.project(c.eye).is_none());
    }

    #[test]
    fn framing_sees_every_corner_of_the_box() {
        let (min, max) = ([-1.5, -1.5, 0.0], [1.5, 1.5, 4.0]);
        let c = Camera::framing(min, max, 40.0, 400, 300).unwrap();
        for i in 0..8 {
            let p = [0, 1, 2].map(|a| if i >> a & 1 == 1 { max[a] } else { min[a] });
            let (x, y) = c.project(p).unwrap();
            assert!(
                (0.0..=400.0).contains(&x) && (0.0..=300.0).contains(&y),
                "{p:?}: {x},{y}"
            );
        }
    }

    #[test]
    fn pixel_radius_is_the_angle_of_half_a_pixel_at_the_center() {
        let c = Camera::new([0.0; 3], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], 70.0, 9, 7).unwrap();
        let center = c.ray(4.5, 3.5);
        let half_up = c.ray(4.5, 3.0);
        assert!((dot(center, half_up).acos() - c.pixel_radius()).abs() < 1e-12);
    }
}
