//! The airbrush (paper B §6): an emitter whose particles live for ever and bounce off the
//! scene's surfaces, diffusing at random inside the open regions the surfaces bound; when
//! the stroke ends every particle freezes into a Gaussian.
//!
//! While the button is held, `rate` particles a second are sprayed from the point
//! `start` along the cursor's ray (the first at once), with the ray's direction times
//! `speed` plus an isotropic Gaussian spread of standard deviation `spread·speed`. Each
//! step of `dt` a particle's velocity takes a random kick of standard deviation
//! `diffusion·√dt` per axis (Brownian), then it moves in a straight line, reflected
//! specularly (`v − 2(v·n)n`) where the path meets a surface — up to eight times a step,
//! restarting a hair (`10⁻⁶` along the normal) off the surface.

use super::{Draft, normal_deviate};
use crate::scene::Scene;
use crate::vec3::{Vec3, axpy, dot, norm, scale};
use haze_core::number::shown;
use haze_gaussians::Gaussian;
use haze_gaussians::cloud::Uniform;

/// Bounces followed within one step.
const MAX_BOUNCES: usize = 8;
/// How far off a surface a bounced particle restarts.
const SURFACE_GAP: f64 = 1e-6;

/// The airbrush's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirParams {
    /// Particles sprayed per second.
    pub rate: f64,
    /// Speed along the cursor ray (world units per second).
    pub speed: f64,
    /// Spread of the initial velocity, relative to `speed`.
    pub spread: f64,
    /// Random-walk strength (world units per second per √second).
    pub diffusion: f64,
    /// Distance from the eye along the ray where particles appear.
    pub start: f64,
    /// Radius and weight of each frozen particle's Gaussian.
    pub radius: f64,
    pub weight: f64,
    pub seed: u64,
}

impl AirParams {
    pub fn check(&self) -> Result<(), String> {
        let positive = [("rate", self.rate), ("radius", self.radius)];
        for (name, v) in positive {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("airbrush {name} {} must be positive", shown(v)));
            }
        }
        let non_negative = [
            ("speed", self.speed),
            ("spread", self.spread),
            ("diffusion", self.diffusion),
            ("start", self.start),
            ("weight", self.weight),
        ];
        for (name, v) in non_negative {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!("airbrush {name} {} must not be negative", shown(v)));
            }
        }
        Ok(())
    }
}

/// A particle: position and velocity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Particle {
    pub position: Vec3,
    pub velocity: Vec3,
}

/// One stroke of the airbrush.
#[derive(Clone, Debug)]
pub struct Airbrush {
    params: AirParams,
    rng: Uniform,
    particles: Vec<Particle>,
    /// Particles due but not yet sprayed (fractional).
    due: f64,
}

impl Airbrush {
    pub fn new(params: AirParams) -> Result<Airbrush, String> {
        params.check()?;
        Ok(Airbrush {
            params,
            rng: Uniform::new(params.seed),
            particles: Vec::new(),
            due: 1.0,
        })
    }

    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    /// Advances the stroke by `dt` seconds with the cursor's ray from `eye` along unit
    /// `dir`: the particles due are sprayed, then every particle moves.
    pub fn step(&mut self, scene: &Scene, eye: Vec3, dir: Vec3, dt: f64) {
        if !(dt >= 0.0 && dt.is_finite()) {
            return;
        }
        let p = self.params;
        while self.due >= 1.0 {
            self.due -= 1.0;
            let kick = [0; 3].map(|_| p.spread * p.speed * normal_deviate(&mut self.rng));
            let velocity = axpy(kick, p.speed, dir);
            self.particles.push(Particle {
                position: axpy(eye, p.start, dir),
                velocity,
            });
        }
        let sd = p.diffusion * dt.sqrt();
        for k in 0..self.particles.len() {
            let mut q = self.particles[k];
            if sd > 0.0 {
                for a in 0..3 {
                    q.velocity[a] += sd * normal_deviate(&mut self.rng);
                }
            }
            self.particles[k] = advance(scene, q, dt);
        }
        self.due += p.rate * dt;
    }

    /// Ends the stroke: the particles, frozen, become Gaussians of `draft`.
    pub fn finish(self, draft: &mut Draft) {
        for g in self.gaussians() {
            draft.add(g);
        }
    }

    /// The particles as Gaussians (to show while spraying).
    pub fn gaussians(&self) -> Vec<Gaussian> {
        self.particles
            .iter()
            .map(|q| Gaussian {
                center: q.position,
                radius: self.params.radius,
                weight: self.params.weight,
            })
            .collect()
    }
}

/// Moves particle `q` for `dt` seconds in a straight line, reflected off the surfaces of
/// `scene` it meets.
pub fn advance(scene: &Scene, mut q: Particle, dt: f64) -> Particle {
    let speed = norm(q.velocity);
    if !(speed > 0.0 && speed.is_finite()) {
        return q;
    }
    let mut left = speed * dt;
    for _ in 0..MAX_BOUNCES {
        let d = scale(q.velocity, 1.0 / norm(q.velocity));
        // A surface within the gap past the path's end bounces the particle too, so that
        // no step ends on a surface (whence the next would slip through it).
        match scene.intersect(q.position, d, 0.0, left + SURFACE_GAP) {
            Some(hit) => {
                // `hit.normal` faces the particle.
                q.position = axpy(hit.point, SURFACE_GAP, hit.normal);
                q.velocity = axpy(q.velocity, -2.0 * dot(q.velocity, hit.normal), hit.normal);
                left -= hit.t;
                if left <= 0.0 {
                    return q;
                }
            }
            None => {
                q.position = axpy(q.position, left, d);
                return q;
            }
        }
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vec3::sub;

    fn scene(surfaces: &str) -> Scene {
        crate::file::parse(&format!(
            r#"{{"camera": {{"eye": [0, -5, 2], "target": [0, 0, 0]}}, "surfaces": [{surfaces}]}}"#
        ))
        .unwrap()
    }

    /// A particle thrown at the floor `z = 0` from height 1 (velocity (0.3, 0, −2)):
    /// elastic bounces give `z(t) = |1 − 2t|` until it rises again, `x = 0.3t` — to the
    /// surface gap. Without diffusion and spread, a spray of `rate·T` particles all moves
    /// that way.
    #[test]
    fn particles_bounce_off_the_floor_where_the_mirror_path_says() {
        let s = scene(
            r#"{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {"diffuse": [1, 1, 1]}}"#,
        );
        let q = Particle {
            position: [0.0, 0.0, 1.0],
            velocity: [0.3, 0.0, -2.0],
        };
        for t in [0.25, 0.6, 0.75, 1.4] {
            // One call and the same time in ten steps.
            let mut stepped = q;
            for _ in 0..10 {
                stepped = advance(&s, stepped, t / 10.0);
            }
            for got in [advance(&s, q, t), stepped] {
                let want = [0.3 * t, 0.0, (1.0f64 - 2.0 * t).abs()];
                assert!(norm(sub(got.position, want)) < 1e-5, "{t}: {got:?}");
                assert!(got.position[2] > 0.0);
                let vz = if t > 0.5 { 2.0 } else { -2.0 };
                assert!((got.velocity[2] - vz).abs() < 1e-12);
            }
        }
        let params = AirParams {
            rate: 40.0,
            speed: 2.0,
            spread: 0.0,
            diffusion: 0.0,
            start: 0.0,
            radius: 0.05,
            weight: 0.3,
            seed: 3,
        };
        let mut brush = Airbrush::new(params).unwrap();
        let eye = [0.0, 0.0, 1.0];
        for _ in 0..30 {
            brush.step(&s, eye, [0.0, 0.0, -1.0], 0.025);
        }
        // Sprayed at t = 0, 0.025, …: 40/s for 0.75 s.
        assert_eq!(brush.particles().len(), 30);
        for (k, q) in brush.particles().iter().enumerate() {
            let age = 0.025 * (30 - k) as f64;
            assert!(
                (q.position[2] - (1.0f64 - 2.0 * age).abs()).abs() < 1e-5,
                "{k}"
            );
        }
        let mut d = Draft::new(&[]);
        let frozen = brush.gaussians();
        brush.finish(&mut d);
        assert_eq!(d.added(), frozen.as_slice());
        assert!(frozen.iter().all(|g| g.radius == 0.05 && g.weight == 0.3));
    }

    /// Sprayed inside a hollow sphere with spread and diffusion, no particle escapes it,
    /// however long it diffuses; and the spray is the same for the same seed.
    #[test]
    fn diffusing_particles_stay_in_the_region_the_surfaces_close() {
        let s = scene(
            r#"{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"diffuse": [1, 1, 1]}}"#,
        );
        let params = AirParams {
            rate: 200.0,
            speed: 3.0,
            spread: 0.5,
            diffusion: 4.0,
            start: 0.0,
            radius: 0.05,
            weight: 0.3,
            seed: 5,
        };
        let run = || {
            let mut brush = Airbrush::new(params).unwrap();
            for _ in 0..100 {
                brush.step(&s, [0.0, 0.0, 0.2], [1.0, 0.0, 0.0], 0.01);
            }
            brush
        };
        let brush = run();
        // Born at k/200 s for the steps' starts 0, 0.01, …, 0.99: k ≤ 198.
        assert_eq!(brush.particles().len(), 199);
        let far = brush
            .particles()
            .iter()
            .map(|q| norm(q.position))
            .fold(0.0, f64::max);
        assert!(far < 1.0 && far > 0.5, "{far}");
        assert_eq!(brush.particles(), run().particles());
        assert!(
            Airbrush::new(AirParams {
                rate: 0.0,
                ..params
            })
            .is_err()
        );
    }
}
