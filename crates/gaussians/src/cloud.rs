//! Deterministic clouds of Gaussians for examples, tests and bundled scenes: centres
//! uniform in a ball, radii uniform in a range, each weight set so the Gaussian's peak
//! optical depth through its centre, `σt·w·√π·r`, is a chosen value (paper B's
//! factorization is accurate below about 0.2, see [`crate::airlight`]).

use crate::medium::Gaussian;
use haze_core::vec3::Vec3;
use std::f64::consts::PI;

/// A SplitMix64 stream of uniform numbers in `[0, 1)`.
#[derive(Clone, Debug)]
pub struct Uniform(u64);

impl Uniform {
    pub fn new(seed: u64) -> Uniform {
        Uniform(seed)
    }

    pub fn sample(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` Gaussians, centres uniform in the ball `(centre, spread)`, radii uniform in
/// `radii`, weights giving each the peak optical depth `tau` for extinction scale
/// `sigma_t`.
pub fn ball(
    n: usize,
    seed: u64,
    centre: Vec3,
    spread: f64,
    radii: (f64, f64),
    tau: f64,
    sigma_t: f64,
) -> Vec<Gaussian> {
    let mut u = Uniform::new(seed);
    (0..n)
        .map(|_| {
            // Rejection sampling of the unit ball.
            let p = loop {
                let p = [0, 1, 2].map(|_| 2.0 * u.sample() - 1.0);
                if p[0] * p[0] + p[1] * p[1] + p[2] * p[2] <= 1.0 {
                    break p;
                }
            };
            let radius = radii.0 + (radii.1 - radii.0) * u.sample();
            Gaussian {
                center: [0, 1, 2].map(|k| centre[k] + spread * p[k]),
                radius,
                weight: tau / (sigma_t * PI.sqrt() * radius),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ball_is_deterministic_inside_and_at_the_chosen_depth() {
        let a = ball(200, 9, [1.0, 2.0, 3.0], 0.5, (0.1, 0.2), 0.1, 2.0);
        assert_eq!(a, ball(200, 9, [1.0, 2.0, 3.0], 0.5, (0.1, 0.2), 0.1, 2.0));
        assert_ne!(a, ball(200, 10, [1.0, 2.0, 3.0], 0.5, (0.1, 0.2), 0.1, 2.0));
        for g in &a {
            let d: f64 = (0..3)
                .map(|k| (g.center[k] - [1.0, 2.0, 3.0][k]).powi(2))
                .sum();
            assert!(d.sqrt() <= 0.5 && (0.1..=0.2).contains(&g.radius));
            // Through the centre: σt·w·√π·r (the line integral of the Gaussian).
            let through = crate::line::gaussian(
                2.0 * g.weight,
                1.0 / g.radius,
                g.center,
                [g.center[0] - 10.0, g.center[1], g.center[2]],
                [1.0, 0.0, 0.0],
                20.0,
            );
            assert!((through - 0.1).abs() < 1e-12, "{through}");
        }
    }
}
