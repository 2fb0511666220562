//! The particle emitter (paper B §6, after Reeves 1983): particles born at a point at
//! `rate` a second (the `k`-th at `k/rate`), each on the parabola
//! `x(τ) = origin + v·τ + ½·g·τ²` of its age `τ` — `v` the initial velocity plus an
//! isotropic Gaussian spread of standard deviation `spread·|v|`, `g` the constant
//! acceleration — until it dies at age `lifetime`. One Gaussian per particle; the paper
//! lets the lifetime set size and density, "the longer the particle lives, the smaller
//! its scale `a` and amplitude `c`": here `a` halves and `c` falls to zero linearly over
//! the lifetime, i.e. radius `r₀/(1 − ½τ/L)` and weight `w₀·(1 − τ/L)` (the paper gives
//! no law). The emitter runs while the button is held and can be moved meanwhile
//! ([`Emitter::move_to`]: the cursor drags it along a path, each particle starting where
//! the emitter was at its birth); when the stroke ends its living particles freeze into
//! Gaussians.

use super::{Draft, normal_deviate};
use crate::vec3::{Vec3, axpy, norm};
use haze_core::number::shown;
use haze_gaussians::Gaussian;
use haze_gaussians::cloud::Uniform;

/// The emitter's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitParams {
    /// Particles per second.
    pub rate: f64,
    /// Initial velocity (world units per second).
    pub velocity: Vec3,
    /// Spread of the initial velocity, relative to its length.
    pub spread: f64,
    /// Constant acceleration.
    pub acceleration: Vec3,
    /// Seconds a particle lives.
    pub lifetime: f64,
    /// A newborn particle's radius and weight.
    pub radius: f64,
    pub weight: f64,
    pub seed: u64,
}

impl EmitParams {
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [
            ("rate", self.rate),
            ("lifetime", self.lifetime),
            ("radius", self.radius),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("emitter {name} {} must be positive", shown(v)));
            }
        }
        for (name, v) in [("spread", self.spread), ("weight", self.weight)] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!("emitter {name} {} must not be negative", shown(v)));
            }
        }
        if !self
            .velocity
            .iter()
            .chain(&self.acceleration)
            .all(|x| x.is_finite())
        {
            return Err("emitter velocity and acceleration must be finite".into());
        }
        Ok(())
    }

    /// The Gaussian of a particle of age `age` (in `[0, lifetime)`) at `position`.
    pub fn gaussian(&self, position: Vec3, age: f64) -> Gaussian {
        let f = (age / self.lifetime).clamp(0.0, 1.0);
        Gaussian {
            center: position,
            radius: self.radius / (1.0 - 0.5 * f),
            weight: self.weight * (1.0 - f),
        }
    }
}

/// A particle: its birth time and place and initial velocity.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Particle {
    born: f64,
    origin: Vec3,
    velocity: Vec3,
}

/// A running emitter.
#[derive(Clone, Debug)]
pub struct Emitter {
    params: EmitParams,
    origin: Vec3,
    rng: Uniform,
    /// Seconds since the emitter started.
    time: f64,
    /// Particles born so far (alive or dead).
    born: u64,
    alive: Vec<Particle>,
}

impl Emitter {
    /// An emitter at `origin`, started (its first particle born) at time 0.
    pub fn new(params: EmitParams, origin: Vec3) -> Result<Emitter, String> {
        params.check()?;
        if !origin.iter().all(|x| x.is_finite()) {
            return Err("the emitter's position must be finite".into());
        }
        let mut e = Emitter {
            params,
            origin,
            rng: Uniform::new(params.seed),
            time: 0.0,
            born: 0,
            alive: Vec::new(),
        };
        e.advance(0.0);
        Ok(e)
    }

    /// Runs the emitter `dt` seconds on: particles due are born, those older than their
    /// lifetime die.
    pub fn advance(&mut self, dt: f64) {
        if !(dt >= 0.0 && dt.is_finite()) {
            return;
        }
        self.time += dt;
        let p = self.params;
        loop {
            let born = self.born as f64 / p.rate;
            if born > self.time {
                break;
            }
            let s = p.spread * norm(p.velocity);
            let kick = [0; 3].map(|_| s * normal_deviate(&mut self.rng));
            self.alive.push(Particle {
                born,
                origin: self.origin,
                velocity: axpy(kick, 1.0, p.velocity),
            });
            self.born += 1;
        }
        let now = self.time;
        self.alive.retain(|q| now - q.born < p.lifetime);
    }

    /// Moves the emitter to `origin` (a finite point; others are ignored): particles born
    /// from now on start there.
    pub fn move_to(&mut self, origin: Vec3) {
        if origin.iter().all(|x| x.is_finite()) {
            self.origin = origin;
        }
    }

    /// The living particles as Gaussians, oldest first.
    pub fn gaussians(&self) -> Vec<Gaussian> {
        let p = &self.params;
        self.alive
            .iter()
            .map(|q| {
                let age = self.time - q.born;
                let x = [0, 1, 2].map(|k| {
                    q.origin[k] + q.velocity[k] * age + 0.5 * p.acceleration[k] * age * age
                });
                p.gaussian(x, age)
            })
            .collect()
    }

    /// Ends the stroke: the living particles freeze into Gaussians of `draft`.
    pub fn finish(self, draft: &mut Draft) {
        for g in self.gaussians() {
            draft.add(g);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 10 particles a second living 0.75 s, thrown up at (1, 0, 3) under gravity: after
    /// 2.03 s (in uneven steps) the living ones are those born at k/10 s with
    /// 2.03 − k/10 < 0.75, i.e. k = 13…20, each on its parabola with the size and
    /// density of its age.
    #[test]
    fn particles_follow_their_parabolas_and_age() {
        let p = EmitParams {
            rate: 10.0,
            velocity: [1.0, 0.0, 3.0],
            spread: 0.0,
            acceleration: [0.0, 0.0, -9.81],
            lifetime: 0.75,
            radius: 0.1,
            weight: 0.8,
            seed: 4,
        };
        let origin = [0.5, -1.0, 0.25];
        let mut e = Emitter::new(p, origin).unwrap();
        assert_eq!(e.gaussians().len(), 1, "the first is born at once");
        for dt in [0.3, 0.01, 0.52, 0.7, 0.5] {
            e.advance(dt);
        }
        let gs = e.gaussians();
        assert_eq!(gs.len(), 8);
        for (g, k) in gs.iter().zip(13..) {
            let age = 2.03 - k as f64 / 10.0;
            let want = [0.5 + age, -1.0, 0.25 + 3.0 * age - 0.5 * 9.81 * age * age];
            for (x, w) in g.center.iter().zip(want) {
                assert!((x - w).abs() < 1e-9, "{k}: {g:?}");
            }
            assert!((g.radius - 0.1 / (1.0 - 0.5 * age / 0.75)).abs() < 1e-12);
            assert!((g.weight - 0.8 * (1.0 - age / 0.75)).abs() < 1e-12);
        }
        // Moved at 2.03 s then run 0.25 s on: the particles born since (k = 21, 22)
        // start at the new place, the others keep their parabolas.
        let mut moved = e.clone();
        let to = [2.0, 2.0, 1.0];
        moved.move_to(to);
        moved.advance(0.25);
        let after = moved.gaussians();
        assert_eq!(after.len(), 7, "k = 16…22");
        for (g, k) in after.iter().zip(16..) {
            let age = 2.28 - k as f64 / 10.0;
            let from = if k >= 21 { to } else { origin };
            let want = [
                from[0] + age,
                from[1],
                from[2] + 3.0 * age - 0.5 * 9.81 * age * age,
            ];
            for (x, w) in g.center.iter().zip(want) {
                assert!((x - w).abs() < 1e-9, "{k}: {g:?}");
            }
        }
        // Older particles are larger and fainter.
        assert!(gs[0].radius > gs[7].radius && gs[0].weight < gs[7].weight);
        let mut d = Draft::new(&[]);
        e.finish(&mut d);
        assert_eq!(d.added(), gs.as_slice());
        // With spread, seeded: the same every time, different from another seed.
        let spray = |seed| {
            let mut e = Emitter::new(
                EmitParams {
                    spread: 0.3,
                    seed,
                    ..p
                },
                origin,
            )
            .unwrap();
            e.advance(0.5);
            e.gaussians()
        };
        assert_eq!(spray(1), spray(1));
        assert_ne!(spray(1), spray(2));
        assert!(EmitParams { lifetime: 0.0, ..p }.check().is_err());
    }
}
