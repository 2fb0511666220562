//! A render's estimate of its own error (`haze render --check N`): the fast picture
//! compared, on `N` of its smoke pixels, with the reference renderer at a few samples each
//! — lit by the environment as given (a map whole), so the estimate also covers what
//! splitting the map into suns changed.
//!
//! With `f_p` the fast renderer's pixel, `r_p` the reference's mean of `S` samples and `v_p`
//! the variance of that mean (per channel), `E[(f − r)²] = (f − μ)² + v`, so
//! `e² = (Σ (f_p − r_p)² − Σ v_p) / Σ r_p²` estimates docs/conventions.md's `rel_rms` of the
//! picture over those pixels without the reference's noise (clamped at 0); the noise left
//! in the estimate, `√(Σ v_p / Σ r_p²)`, is printed beside it. The pixels are every k-th of
//! those where the smoke blocks at least 2 % of the light behind it (the exact
//! transmittance along each pixel's ray), so they spread over the smoke.
//!
//! **Its spread.** With Gaussian sample noise `ε` of variance `v` on each of the `M`
//! channel values and `δ = f − μ`, `Var[(δ − ε)²] = 4δ²v + 2v²`; for noise spread evenly
//! over the terms, `σ(e²) ≈ √((2·noise⁴ + 4e²·noise²)/M)`, and `e` is reported as
//! `e ± σ_e` with `σ_e = √(e² + σ(e²)) − e` (which stays finite at `e = 0`). A render warns
//! that its target is missed only when `e − 2σ_e` is above it, and that it may be missed
//! when `e` alone is.

use haze_view::reference::{self, RefOptions};
use haze_view::{Camera, Environment, Image, Medium};
use haze_volume::Volume;
use std::time::Instant;

/// Samples per checked pixel. The reference's noise is discounted from the estimate (its
/// mean), not from its spread: with `N` pixels the estimate of `e²` wanders by about
/// `noise²·√(2/3N)`: about ±0.1 % on an error of 3 % at 128 samples (noise ≈ 3.5 %) and
/// 256 pixels.
pub const CHECK_SAMPLES: u32 = 128;

/// What [`estimate`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorEstimate {
    /// Estimated `rel_rms` of the picture over the checked pixels, noise discounted.
    pub error: f64,
    /// The reference's noise left in the estimate (same units).
    pub noise: f64,
    /// Pixels checked.
    pub pixels: usize,
    /// Reference samples per pixel.
    pub samples: u32,
    pub seconds: f64,
    /// One standard deviation of `error` from the reference's noise (module docs).
    pub spread: f64,
}

impl ErrorEstimate {
    /// Whether the error is above `target` beyond two spreads (`Some(true)`), within
    /// them (`Some(false)`: it may be), or below it (`None`).
    pub fn above(&self, target: f64) -> Option<bool> {
        (self.error > target).then_some(self.error - 2.0 * self.spread > target)
    }
}

impl std::fmt::Display for ErrorEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "estimated error {:.1} % ± {:.1} % ({} pixels × {} reference samples, their noise {:.1} % discounted, {:.1} s)",
            100.0 * self.error,
            100.0 * self.spread,
            self.pixels,
            self.samples,
            100.0 * self.noise,
            self.seconds
        )
    }
}

/// The error of `image` (rendered of `density` with `medium` through `camera`, `multiple`
/// scattering or single) on up to `n` of its smoke pixels against the reference lit by
/// `env` (the environment as given) over the same `ground`, if any. `None` when no pixel
/// shows smoke or `n` is 0.
#[allow(clippy::too_many_arguments)]
pub fn estimate(
    image: &Image,
    density: &Volume,
    medium: &Medium,
    env: &Environment,
    ground: Option<haze_view::ground::Ground>,
    camera: &Camera,
    multiple: bool,
    n: usize,
    samples: u32,
) -> Option<ErrorEstimate> {
    let start = Instant::now();
    let pixels = smoke_pixels(density, medium, camera, n);
    if pixels.is_empty() {
        return None;
    }
    let opts = RefOptions {
        spp: samples.max(2),
        multiple,
        seed: 0x636b_6563,
        ground,
        ..RefOptions::default()
    };
    let reference = reference::render_pixels(density, medium, env, camera, &pixels, &opts);
    let mut terms = Vec::with_capacity(3 * pixels.len());
    for (&(x, y), (r, v)) in pixels.iter().zip(&reference) {
        let f = image.pixels[y * camera.width + x];
        for c in 0..3 {
            terms.push((f64::from(f[c]), r[c], v[c]));
        }
    }
    let (error, noise, spread) = from_terms(&terms)?;
    Some(ErrorEstimate {
        error,
        noise,
        pixels: pixels.len(),
        samples: opts.spp,
        seconds: start.elapsed().as_secs_f64(),
        spread,
    })
}

/// `(e, noise, σ_e)` of the module docs from `(f, r, v)` per channel value: the fast
/// renderer's value, the reference's mean and the variance of that mean. `None` when the
/// reference is black or not finite.
fn from_terms(terms: &[(f64, f64, f64)]) -> Option<(f64, f64, f64)> {
    let (mut diff, mut var, mut norm) = (0.0f64, 0.0f64, 0.0f64);
    for &(f, r, v) in terms {
        diff += (f - r).powi(2);
        var += v;
        norm += r * r;
    }
    if !(norm > 0.0 && norm.is_finite()) {
        return None;
    }
    let e2 = (diff - var).max(0.0) / norm;
    let noise2 = var / norm;
    let m = terms.len().max(1) as f64;
    let spread2 = ((2.0 * noise2 * noise2 + 4.0 * e2 * noise2) / m).sqrt();
    let e = e2.sqrt();
    Some((e, noise2.sqrt(), (e2 + spread2).sqrt() - e))
}

/// Up to `n` pixels, every k-th in scan order of those whose ray's transmittance through
/// `density` is below 0.98.
fn smoke_pixels(
    density: &Volume,
    medium: &Medium,
    camera: &Camera,
    n: usize,
) -> Vec<(usize, usize)> {
    if n == 0 {
        return Vec::new();
    }
    // Transmittance only: no scattering, a white environment, one exact sample.
    let absorbing = Medium::new(medium.sigma_t, 0.0, 0.0).expect("an absorbing medium is valid");
    let white = Environment::constant([1.0; 3]);
    let t = reference::render(
        density,
        &absorbing,
        &white,
        camera,
        &RefOptions {
            spp: 1,
            multiple: false,
            ..RefOptions::default()
        },
    );
    let smoke: Vec<(usize, usize)> = t
        .pixels
        .iter()
        .enumerate()
        .filter(|(_, p)| p[0] < 0.98)
        .map(|(i, _)| (i % camera.width, i / camera.width))
        .collect();
    let step = smoke.len().div_ceil(n).max(1);
    smoke.into_iter().step_by(step).take(n).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_view::Sky;
    use haze_volume::Bbox;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn ball() -> Volume {
        let n = 12;
        let data = (0..n * n * n)
            .map(|i| {
                let p =
                    [i % n, (i / n) % n, i / (n * n)].map(|k| (k as f64 + 0.5) / n as f64 - 0.5);
                (1.0 - 4.0 * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2])).max(0.0) as f32
            })
            .collect();
        Volume::new([n; 3], Bbox::new([-1.0; 3], [1.0; 3]), data).unwrap()
    }

    /// The spread against the estimator's scatter over many independent noisy references
    /// (Gaussian noise from a fixed Box–Muller stream): with a true error the reported
    /// `σ_e` is the sample standard deviation of `e` within 20 % (400 trials: the sample
    /// deviation's own relative error is ~4 %) and `e` is unbiased; without one it is
    /// cautious.
    #[test]
    fn the_spread_is_the_estimates_scatter() {
        let mut rng = Pcg64::seed_from_u64(11);
        // In (0, 1]: the logarithm below needs it above 0.
        let mut uniform = move || 1.0 - rng.random::<f64>();
        let mut normal = move || {
            let (a, b) = (uniform(), uniform());
            (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
        };
        let m = 600;
        let mu: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 * 0.1).collect();
        for bias in [0.0, 0.03] {
            let v = 0.035f64.powi(2) * 0.8;
            let (mut es, mut spreads) = (Vec::new(), Vec::new());
            for _ in 0..400 {
                let terms: Vec<(f64, f64, f64)> = mu
                    .iter()
                    .map(|&u| {
                        (
                            u * (1.0 + bias),
                            u + (v * u * u).sqrt() * normal(),
                            v * u * u,
                        )
                    })
                    .collect();
                let (e, _, s) = from_terms(&terms).unwrap();
                es.push(e);
                spreads.push(s);
            }
            let mean = es.iter().sum::<f64>() / es.len() as f64;
            let sd =
                (es.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (es.len() - 1) as f64).sqrt();
            let reported = spreads.iter().sum::<f64>() / spreads.len() as f64;
            if bias > 0.0 {
                assert!(
                    (reported / sd - 1.0).abs() < 0.2,
                    "bias {bias}: {reported} vs {sd}"
                );
                assert!((mean - bias).abs() < 2.0 * sd, "{mean} vs {bias}");
            } else {
                // At no error, e = √max(X, 0) of a centred X: the spread is cautious there
                // (σ_e = √σ(e²) against the scatter's ≈ 0.48√σ(e²)), never smaller.
                assert!(reported >= sd && reported < 2.5 * sd, "{reported} vs {sd}");
            }
        }
        // A black or non-finite reference gives nothing.
        assert!(from_terms(&[(1.0, 0.0, 0.0)]).is_none());
        assert!(from_terms(&[(1.0, f64::NAN, 0.0)]).is_none());
        // Above beyond two spreads, within them, below.
        let est = |error, spread| ErrorEstimate {
            error,
            noise: 0.03,
            pixels: 10,
            samples: 128,
            seconds: 0.0,
            spread,
        };
        assert_eq!(est(0.05, 0.005).above(0.02), Some(true));
        assert_eq!(est(0.025, 0.005).above(0.02), Some(false));
        assert_eq!(est(0.01, 0.005).above(0.02), None);
    }

    #[test]
    fn the_estimate_finds_a_known_error_and_none_in_the_reference_itself() {
        let v = ball();
        let m = Medium::new(3.0, 0.8, 0.3).unwrap();
        let env = Environment::sky(Sky::default());
        let cam = Camera::new([0.0, -4.0, 0.3], [0.0; 3], [0.0, 0.0, 1.0], 35.0, 24, 18).unwrap();
        // A converged reference picture: its error is only the reference's noise.
        let truth = reference::render(
            &v,
            &m,
            &env,
            &cam,
            &RefOptions {
                spp: 2048,
                multiple: false,
                ..RefOptions::default()
            },
        );
        let e = estimate(&truth, &v, &m, &env, None, &cam, false, 64, 256).expect("smoke");
        assert!(e.pixels > 16 && e.pixels <= 64, "{e}");
        // The truth's own noise at 2048 samples is about a third of the check's at 256.
        assert!(e.error < 0.02 + 2.0 * e.noise, "{e}");
        // The same picture 10 % too bright everywhere: an error of 10 %.
        let mut bright = truth.clone();
        for p in &mut bright.pixels {
            *p = p.map(|c| 1.1 * c);
        }
        let e = estimate(&bright, &v, &m, &env, None, &cam, false, 64, 256).expect("smoke");
        assert!((e.error - 0.1).abs() < 0.02 + 2.0 * e.noise, "{e}");
        // Nothing to check.
        assert!(estimate(&truth, &v, &m, &env, None, &cam, false, 0, 64).is_none());
        let away = Camera::new(
            [0.0, -4.0, 0.3],
            [0.0, -8.0, 0.3],
            [0.0, 0.0, 1.0],
            35.0,
            8,
            6,
        )
        .unwrap();
        assert!(estimate(&truth, &v, &m, &env, None, &away, false, 16, 8).is_none());
    }
}
