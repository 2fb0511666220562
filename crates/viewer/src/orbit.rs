//! The viewer's orbit camera: a pinhole camera on a sphere around a target (the smoke's
//! center), Z up. Dragging turns it around the target (azimuth) and over it (elevation,
//! kept short of the poles so that "up" stays defined); scrolling moves it closer or
//! farther by a constant factor per step.

use haze_view::Camera;
use haze_volume::Bbox;
use std::f64::consts::PI;

/// Highest elevation above (or below) the target's horizontal plane, radians (89°).
const MAX_ELEVATION: f64 = 89.0 * PI / 180.0;

/// Radians of turn per pixel dragged.
pub const RADIANS_PER_PIXEL: f64 = 0.01;

/// A camera orbiting `target` at `distance`: the eye is at
/// `target + distance·(cos e cos a, cos e sin a, sin e)` for azimuth `a` (from +X towards
/// +Y) and elevation `e`, looking at the target with Z up.
#[derive(Clone, Debug, PartialEq)]
pub struct Orbit {
    pub target: [f64; 3],
    pub distance: f64,
    pub azimuth: f64,
    pub elevation: f64,
    /// Vertical field of view, degrees.
    pub fov: f64,
    /// The range `distance` is kept in (zooming stops there).
    min_distance: f64,
    max_distance: f64,
}

impl Orbit {
    /// The orbit of [`Camera::framing`]'s view of `bbox` (the whole box in view, from the
    /// front-right and a little above): the same eye and target. Zooming is allowed from
    /// 1/50 to 20 times that distance.
    pub fn framing(bbox: &Bbox, fov: f64, width: usize, height: usize) -> Result<Orbit, String> {
        let camera = Camera::framing(bbox.min, bbox.max, fov, width, height)?;
        let target = [0, 1, 2].map(|a| 0.5 * (bbox.min[a] + bbox.max[a]));
        Orbit::looking(camera.eye, target, fov)
            .map_err(|_| format!("cannot frame a box of size {:?}", bbox.size()))
    }

    /// The orbit whose camera stands at `eye` looking at `target` (a scene file's camera,
    /// with Z up). Zooming is allowed from 1/50 to 20 times that distance.
    pub fn looking(eye: [f64; 3], target: [f64; 3], fov: f64) -> Result<Orbit, String> {
        let d = [0, 1, 2].map(|a| eye[a] - target[a]);
        let distance = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !(distance > 0.0 && distance.is_finite()) {
            return Err(format!("the eye {eye:?} is at the target {target:?}"));
        }
        Ok(Orbit {
            target,
            distance,
            azimuth: d[1].atan2(d[0]),
            elevation: (d[2] / distance).clamp(-1.0, 1.0).asin(),
            fov,
            min_distance: distance / 50.0,
            max_distance: distance * 20.0,
        })
    }

    /// The eye position.
    pub fn eye(&self) -> [f64; 3] {
        let (se, ce) = self.elevation.sin_cos();
        let (sa, ca) = self.azimuth.sin_cos();
        let t = self.target;
        let r = self.distance;
        [t[0] + r * ce * ca, t[1] + r * ce * sa, t[2] + r * se]
    }

    /// The camera for a `width × height` image.
    pub fn camera(&self, width: usize, height: usize) -> Result<Camera, String> {
        Camera::new(
            self.eye(),
            self.target,
            [0.0, 0.0, 1.0],
            self.fov,
            width,
            height,
        )
    }

    /// Turns the camera by a drag of `(dx, dy)` pixels, as if dragging the smoke: right
    /// turns it to the right (the eye goes left, azimuth decreases), down tips its top
    /// towards the viewer (the eye rises); elevation stays within ±89°, azimuth within
    /// [0, 2π).
    pub fn drag(&mut self, dx: f64, dy: f64) {
        self.azimuth = (self.azimuth - dx * RADIANS_PER_PIXEL).rem_euclid(2.0 * PI);
        self.elevation =
            (self.elevation + dy * RADIANS_PER_PIXEL).clamp(-MAX_ELEVATION, MAX_ELEVATION);
    }

    /// Zooms by `steps` (positive: closer): the distance is divided by `1.1^steps`,
    /// within the orbit's range.
    pub fn zoom(&mut self, steps: f64) {
        self.distance =
            (self.distance / 1.1f64.powf(steps)).clamp(self.min_distance, self.max_distance);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
    }

    #[test]
    fn framing_is_the_camera_of_haze_render() {
        let b = Bbox::new([-1.0, 2.0, 0.0], [1.0, 3.5, 4.0]);
        let o = Orbit::framing(&b, 40.0, 400, 300).unwrap();
        let want = Camera::framing(b.min, b.max, 40.0, 400, 300).unwrap();
        let got = o.camera(400, 300).unwrap();
        assert!(
            close(got.eye, want.eye, 1e-12),
            "{:?} {:?}",
            got.eye,
            want.eye
        );
        assert!(close(got.forward(), want.forward(), 1e-12));
        assert!(close(got.up(), want.up(), 1e-12));
        assert_eq!(o.target, [0.0, 2.75, 2.0]);
    }

    #[test]
    fn dragging_turns_around_the_target_at_a_constant_distance() {
        let b = Bbox::new([0.0; 3], [2.0; 3]);
        let mut o = Orbit::framing(&b, 40.0, 400, 300).unwrap();
        let (a0, e0, start) = (o.azimuth, o.elevation, o.eye());
        // A quarter turn to the right: the eye moves a quarter circle clockwise seen
        // from above (azimuth − π/2), at the same height and distance.
        let quarter = (PI / 2.0) / RADIANS_PER_PIXEL;
        o.drag(quarter, 0.0);
        let (sa, ca) = (a0 - PI / 2.0).sin_cos();
        let r = o.distance * e0.cos();
        let want = [1.0 + r * ca, 1.0 + r * sa, start[2]];
        assert!(close(o.eye(), want, 1e-9), "{:?} {want:?}", o.eye());
        // The rest of the full turn brings it back.
        o.drag(3.0 * quarter, 0.0);
        assert!(close(o.eye(), start, 1e-9));
        // Dragging far up or down stops short of the poles; the camera stays valid.
        o.drag(0.0, 1e6);
        assert!((o.elevation - MAX_ELEVATION).abs() < 1e-15);
        let c = o.camera(10, 10).unwrap();
        assert!(c.forward()[2] < -0.99, "looking down: {:?}", c.forward());
        o.drag(0.0, -1e6);
        assert!((o.elevation + MAX_ELEVATION).abs() < 1e-15);
        assert!(o.camera(10, 10).is_ok());
        let d: f64 = o
            .eye()
            .iter()
            .zip(o.target)
            .map(|(e, t)| (e - t).powi(2))
            .sum();
        assert!((d.sqrt() - o.distance).abs() < 1e-12);
    }

    #[test]
    fn zooming_scales_the_distance_within_its_range() {
        let b = Bbox::new([0.0; 3], [1.0; 3]);
        let mut o = Orbit::framing(&b, 40.0, 400, 300).unwrap();
        let d0 = o.distance;
        let dir0 = o.camera(4, 4).unwrap().forward();
        o.zoom(2.0);
        assert!((o.distance - d0 / 1.21).abs() < 1e-12);
        assert!(close(o.camera(4, 4).unwrap().forward(), dir0, 1e-12));
        o.zoom(-2.0);
        assert!((o.distance - d0).abs() < 1e-12);
        o.zoom(1000.0);
        assert!((o.distance - d0 / 50.0).abs() < 1e-12);
        o.zoom(-1000.0);
        assert!((o.distance - d0 * 20.0).abs() < 1e-9);
        assert!(Orbit::framing(&Bbox::new([0.0; 3], [0.0; 3]), 40.0, 4, 4).is_err());
    }
}
