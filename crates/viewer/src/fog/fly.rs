//! The fog viewer's fly camera: a pinhole camera at `eye` heading along
//! `(cos p cos y, cos p sin y, sin p)` for yaw `y` (from +X towards +Y) and pitch `p`
//! (above the horizontal, kept within ±89° so that "up", +Z, stays defined). It moves in
//! its own frame — ahead along the heading, aside along the horizontal right
//! `(sin y, −cos y, 0)`, up along +Z — and dragging the mouse turns it.

use haze_camera::LookAt;
use std::f64::consts::PI;

/// Highest pitch above (or below) the horizontal, radians (89°).
const MAX_PITCH: f64 = 89.0 * PI / 180.0;

/// Radians of turn per pixel dragged.
pub const RADIANS_PER_PIXEL: f64 = 0.005;

#[derive(Clone, Debug, PartialEq)]
pub struct Fly {
    pub eye: [f64; 3],
    pub yaw: f64,
    pub pitch: f64,
    /// Vertical field of view, degrees.
    pub fov: f64,
}

impl Fly {
    /// The fly camera standing at `look`'s eye and heading at its target (Z up; a view
    /// steeper than 89° is levelled to 89°).
    pub fn looking(look: &LookAt) -> Result<Fly, String> {
        let d = [0, 1, 2].map(|a| look.target[a] - look.eye[a]);
        let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !(length > 0.0 && length.is_finite()) {
            return Err(format!(
                "the eye {:?} is at the target {:?}",
                look.eye, look.target
            ));
        }
        Ok(Fly {
            eye: look.eye,
            yaw: d[1].atan2(d[0]),
            pitch: (d[2] / length)
                .clamp(-1.0, 1.0)
                .asin()
                .clamp(-MAX_PITCH, MAX_PITCH),
            fov: look.fov_deg,
        })
    }

    /// The unit heading.
    pub fn forward(&self) -> [f64; 3] {
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        [cp * cy, cp * sy, sp]
    }

    /// The unit horizontal direction to the right of the heading.
    pub fn right(&self) -> [f64; 3] {
        let (sy, cy) = self.yaw.sin_cos();
        [sy, -cy, 0.0]
    }

    /// The view: from the eye one unit along the heading, Z up.
    pub fn look_at(&self) -> LookAt {
        let f = self.forward();
        LookAt {
            eye: self.eye,
            target: [0, 1, 2].map(|a| self.eye[a] + f[a]),
            up: [0.0, 0.0, 1.0],
            fov_deg: self.fov,
        }
    }

    /// Moves `ahead` along the heading, `aside` to the right and `rise` up (world units).
    pub fn fly(&mut self, ahead: f64, aside: f64, rise: f64) {
        let (f, r) = (self.forward(), self.right());
        for a in 0..3 {
            self.eye[a] += ahead * f[a] + aside * r[a];
        }
        self.eye[2] += rise;
    }

    /// Turns by a mouse drag of `dx, dy` pixels: dragging right turns right, dragging
    /// down looks down.
    pub fn turn(&mut self, dx: f64, dy: f64) {
        self.yaw = (self.yaw - dx * RADIANS_PER_PIXEL).rem_euclid(2.0 * PI);
        self.pitch = (self.pitch - dy * RADIANS_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
    }

    /// The fly camera made from a view renders that view: the shared camera built from
    /// both has the same eye, forward, right and up.
    #[test]
    fn it_starts_at_the_view_it_was_given() {
        let look = LookAt {
            eye: [3.0, -40.0, 20.0],
            target: [-5.0, 25.0, 0.0],
            up: [0.0, 0.0, 1.0],
            fov_deg: 50.0,
        };
        let fly = Fly::looking(&look).unwrap();
        let (a, b) = (
            look.camera(80, 60).unwrap(),
            fly.look_at().camera(80, 60).unwrap(),
        );
        assert_eq!(a.eye, b.eye);
        assert!(close(a.forward(), b.forward(), 1e-12));
        assert!(close(a.right(), b.right(), 1e-12));
        assert!(close(a.up(), b.up(), 1e-12));
        assert!(close(fly.right(), a.right(), 1e-12));
        assert!((a.tan_half() - b.tan_half()).abs() < 1e-15);
        assert!(
            Fly::looking(&LookAt {
                target: look.eye,
                ..look
            })
            .is_err()
        );
    }

    /// Moving is along the camera's own axes: the displacement is `ahead·forward +
    /// aside·right + rise·Z` of the shared camera, and distances add up.
    #[test]
    fn it_moves_along_its_own_axes() {
        let mut fly = Fly {
            eye: [1.0, 2.0, 3.0],
            yaw: 0.7,
            pitch: -0.3,
            fov: 40.0,
        };
        let cam = fly.look_at().camera(10, 10).unwrap();
        let (f, r) = (cam.forward(), cam.right());
        fly.fly(5.0, -2.0, 1.5);
        let want = [0, 1, 2]
            .map(|a| [1.0, 2.0, 3.0][a] + 5.0 * f[a] - 2.0 * r[a] + if a == 2 { 1.5 } else { 0.0 });
        assert!(close(fly.eye, want, 1e-12), "{:?} {want:?}", fly.eye);
        // Flying ahead then back again returns to where it was.
        fly.fly(-5.0, 2.0, -1.5);
        assert!(close(fly.eye, [1.0, 2.0, 3.0], 1e-12));
    }

    /// Turning: right drags turn right (the heading moves towards the old right), and the
    /// pitch stops short of the poles however far the mouse is dragged.
    #[test]
    fn it_turns_and_never_looks_straight_up_or_down() {
        let mut fly = Fly {
            eye: [0.0; 3],
            yaw: 0.0,
            pitch: 0.0,
            fov: 50.0,
        };
        let right = fly.right();
        fly.turn(10.0, 0.0);
        let f = fly.forward();
        assert!(f[0] * right[0] + f[1] * right[1] > 0.0);
        fly.turn(0.0, 1e6);
        assert_eq!(fly.pitch, -MAX_PITCH);
        fly.turn(0.0, -1e7);
        assert_eq!(fly.pitch, MAX_PITCH);
        assert!(fly.look_at().camera(4, 4).is_ok());
        // A view straight down is levelled to 89° and still makes a camera.
        let down = Fly::looking(&LookAt {
            eye: [0.0, 0.0, 10.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            fov_deg: 50.0,
        })
        .unwrap();
        assert_eq!(down.pitch, -MAX_PITCH);
        assert!(down.look_at().camera(4, 4).is_ok());
    }
}
