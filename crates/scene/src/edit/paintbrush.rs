//! The paintbrush (paper B §6): Gaussians of a chosen radius `r = 1/a` and weight laid
//! along a stroke projected onto a plane or onto the surface under the cursor, one every
//! `spacing` of arc length (the paper's default `0.75/a`), the first at the stroke's
//! start. Each centre is moved by a random vector in the plane perpendicular to the stroke
//! (spanned by the target's normal, made perpendicular to the stroke, and their cross
//! product), uniform over the disk of radius `jitter·r` — shorter than `1/a` as the paper
//! asks, for `jitter ≤ 1` — and lifted by `lift` along the target's normal (0: the centres
//! lie on the plane or surface).

use super::{Draft, Target};
use crate::Camera;
use crate::scene::Scene;
use crate::vec3::{Vec3, axpy, cross, dot, norm, normalize, perpendicular, scale, sub};
use haze_core::number::shown;
use haze_gaussians::Gaussian;
use haze_gaussians::cloud::Uniform;

/// The paintbrush's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaintParams {
    /// Each Gaussian's radius `r = 1/a` (world units).
    pub radius: f64,
    /// Each Gaussian's weight (times the medium's `σt`: its peak extinction `c`).
    pub weight: f64,
    /// Arc length between two Gaussians (world units).
    pub spacing: f64,
    /// The largest jitter of a centre, as a fraction of `r`, in `[0, 1]`.
    pub jitter: f64,
    /// Height of the centres above the target along its normal (world units).
    pub lift: f64,
    pub seed: u64,
}

impl PaintParams {
    /// Gaussians of radius `radius` and weight `weight`, the paper's spacing `0.75·r`,
    /// jitter `0.5·r`, on the target, seed 1.
    pub fn new(radius: f64, weight: f64) -> PaintParams {
        PaintParams {
            radius,
            weight,
            spacing: 0.75 * radius,
            jitter: 0.5,
            lift: 0.0,
            seed: 1,
        }
    }

    /// The error naming the first bad setting.
    pub fn check(&self) -> Result<(), String> {
        if !(self.radius > 0.0 && self.radius.is_finite()) {
            return Err(format!(
                "paintbrush radius {} must be positive",
                shown(self.radius)
            ));
        }
        if !(self.weight >= 0.0 && self.weight.is_finite()) {
            return Err(format!(
                "paintbrush weight {} must not be negative",
                shown(self.weight)
            ));
        }
        if !(self.spacing > 0.0 && self.spacing.is_finite()) {
            return Err(format!(
                "paintbrush spacing {} must be positive",
                shown(self.spacing)
            ));
        }
        if !(0.0..=1.0).contains(&self.jitter) {
            return Err(format!(
                "paintbrush jitter {} must be in [0, 1]",
                shown(self.jitter)
            ));
        }
        if !self.lift.is_finite() {
            return Err("paintbrush lift must be finite".into());
        }
        Ok(())
    }
}

/// One stroke of the paintbrush.
#[derive(Clone, Debug)]
pub struct Paintbrush {
    params: PaintParams,
    target: Target,
    rng: Uniform,
    /// The stroke's last point and the target's normal there.
    last: Option<(Vec3, Vec3)>,
    /// Arc length since the last Gaussian (`spacing` before the first: one is due).
    since: f64,
    placed: usize,
}

impl Paintbrush {
    pub fn new(params: PaintParams, target: Target) -> Result<Paintbrush, String> {
        params.check()?;
        Ok(Paintbrush {
            params,
            target,
            rng: Uniform::new(params.seed),
            last: None,
            since: params.spacing,
            placed: 0,
        })
    }

    /// Extends the stroke to image point `(px, py)` of `camera`, projected on the target
    /// (a point that misses it is skipped), adding the Gaussians it passes to `draft`.
    pub fn stroke_to(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        px: f64,
        py: f64,
        draft: &mut Draft,
    ) {
        if let Some((p, n)) = self.target.hit(scene, camera, px, py) {
            self.to_point(p, n, draft);
        }
    }

    /// Extends the stroke to world point `p` where the target's normal is `n`.
    pub fn to_point(&mut self, p: Vec3, n: Vec3, draft: &mut Draft) {
        let Some((a, _)) = self.last else {
            self.last = Some((p, n));
            return;
        };
        let d = sub(p, a);
        let len = norm(d);
        let Some(t) = normalize(d).filter(|_| len > 0.0 && len.is_finite()) else {
            return;
        };
        let s = self.params.spacing;
        let mut at = s - self.since;
        let mut last_at = None;
        while at <= len {
            self.place(axpy(a, at, t), t, n, draft);
            last_at = Some(at);
            at += s;
        }
        self.since = match last_at {
            Some(l) => len - l,
            None => self.since + len,
        };
        self.last = Some((p, n));
    }

    /// Ends the stroke: a click that did not move places one Gaussian at its point.
    pub fn finish(&mut self, draft: &mut Draft) {
        if let (0, Some((p, n))) = (self.placed, self.last) {
            self.place(p, perpendicular(n), n, draft);
        }
    }

    /// Adds the Gaussian of the stroke point `p` (tangent `t`, target normal `n`).
    fn place(&mut self, p: Vec3, t: Vec3, n: Vec3, draft: &mut Draft) {
        let u = normalize(axpy(n, -dot(n, t), t)).unwrap_or_else(|| perpendicular(t));
        let v = cross(t, u);
        let rho = self.params.jitter * self.params.radius * self.rng.sample().sqrt();
        let phi = std::f64::consts::TAU * self.rng.sample();
        let offset = axpy(scale(u, rho * phi.cos()), rho * phi.sin(), v);
        let base = axpy(p, self.params.lift, n);
        draft.add(Gaussian {
            center: [0, 1, 2].map(|k| base[k] + offset[k]),
            radius: self.params.radius,
            weight: self.params.weight,
        });
        self.placed += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::plane;

    /// A camera 5 above the origin looking straight down (+Y up in the picture), 200×100
    /// pixels, 60° field: pixel `(px, py)` sees the floor `z = 0` at
    /// `x = (2px/200 − 1)·tan 30°·2·5`, `y = (1 − 2py/100)·tan 30°·5`.
    fn scene() -> Scene {
        crate::file::parse(
            r#"{"camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0],
                "fov": 60, "width": 200, "height": 100},
                "surfaces": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                "material": {"diffuse": [0.5, 0.5, 0.5]}}]}"#,
        )
        .unwrap()
    }

    fn floor_point(px: f64, py: f64) -> Vec3 {
        let t = (30f64).to_radians().tan();
        [
            (2.0 * px / 200.0 - 1.0) * t * 2.0 * 5.0,
            (1.0 - 2.0 * py / 100.0) * t * 5.0,
            0.0,
        ]
    }

    fn stroke(target: Target, p: PaintParams) -> Vec<Gaussian> {
        let s = scene();
        let mut brush = Paintbrush::new(p, target).unwrap();
        let mut d = Draft::new(&[]);
        // A scripted drag in 25 mouse moves from (40, 60) to (160, 30).
        for k in 0..=25 {
            let f = k as f64 / 25.0;
            brush.stroke_to(&s, &s.camera, 40.0 + 120.0 * f, 60.0 - 30.0 * f, &mut d);
        }
        brush.finish(&mut d);
        d.added().to_vec()
    }

    /// The stroke's Gaussians: one every `spacing` of its length from its start (the
    /// count `⌊L/spacing⌋ + 1`), each offset perpendicular to the stroke by less than
    /// `jitter·r`, so within that of the plane; the same seed gives the same stroke, the
    /// surface under the cursor (the floor) the same as the floor's plane.
    #[test]
    fn gaussians_follow_the_stroke_on_the_plane_at_the_spacing() {
        let mut p = PaintParams::new(0.1, 0.4);
        p.jitter = 0.8;
        let floor = plane([0.0; 3], [0.0, 0.0, 2.0]).unwrap();
        let gs = stroke(floor, p);
        let (a, b) = (floor_point(40.0, 60.0), floor_point(160.0, 30.0));
        let len = norm(sub(b, a));
        let t = normalize(sub(b, a)).unwrap();
        assert_eq!(
            gs.len(),
            (len / p.spacing).floor() as usize + 1,
            "length {len}"
        );
        let mut largest: f64 = 0.0;
        for (k, g) in gs.iter().enumerate() {
            let rel = sub(g.center, a);
            // Along the stroke: exactly k spacings (the offset is perpendicular to it).
            assert!((dot(rel, t) - k as f64 * p.spacing).abs() < 1e-9, "{k}");
            let off = norm(axpy(rel, -dot(rel, t), t));
            assert!(off < p.jitter * p.radius, "{k}: {off}");
            assert!(g.center[2].abs() < p.jitter * p.radius);
            assert_eq!((g.radius, g.weight), (0.1, 0.4));
            largest = largest.max(off);
        }
        assert!(largest > 0.5 * p.jitter * p.radius, "jittered: {largest}");
        assert_eq!(gs, stroke(floor, p));
        assert_eq!(gs, stroke(Target::Surface, p));
        assert_ne!(gs, stroke(floor, PaintParams { seed: 2, ..p }));
        // Lifted, without jitter: on the line at height `lift`.
        let lifted = stroke(
            floor,
            PaintParams {
                jitter: 0.0,
                lift: 0.3,
                ..p
            },
        );
        assert_eq!(lifted.len(), gs.len());
        for (k, g) in lifted.iter().enumerate() {
            let want = axpy(axpy(a, k as f64 * p.spacing, t), 0.3, [0.0, 0.0, 1.0]);
            assert!(norm(sub(g.center, want)) < 1e-9, "{k}");
        }
        // A click places one Gaussian at its point; a point off the target adds nothing.
        let s = scene();
        let mut brush = Paintbrush::new(PaintParams { jitter: 0.0, ..p }, floor).unwrap();
        let mut d = Draft::new(&[]);
        brush.stroke_to(&s, &s.camera, 100.0, 50.0, &mut d);
        let sky = plane([0.0, 0.0, 10.0], [0.0, 0.0, 1.0]).unwrap();
        assert!(sky.hit(&s, &s.camera, 3.0, 3.0).is_none(), "behind the eye");
        brush.finish(&mut d);
        assert_eq!(d.added().len(), 1);
        assert!(norm(d.added()[0].center) < 1e-12);
        assert!(Paintbrush::new(PaintParams { jitter: 1.5, ..p }, floor).is_err());
    }
}
