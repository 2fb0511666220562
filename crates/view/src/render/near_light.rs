//! A point light in the smoke: what the grids cannot follow.
//!
//! The lights pass gives each voxel centre `u` a point light's `I/(|u − s|² + a²/3)`
//! ([`super::lights_pass`]) and the view pass interpolates between the centres, so the
//! light's `1/r²` peak within a voxel or so of its position `s` is smoothed away: a view
//! ray passing at `h ≪` a voxel from the light should gather `∫ dt/(h² + t²) = π/h` there
//! and gathers what the neighbouring centres hold. The multiple scattering's cells
//! ([`super::grid_diffusion`]) smooth it over a cell. Where smoke surrounds the light,
//! much of its first scattering happens in that neighbourhood, and the picture around
//! the light's image comes out dark.
//!
//! **The measure.** [`near_share`]: the light's first scatterings within
//! [`NEAR_VOXELS`] smallest voxel sides of it, as a share of all its first scatterings.
//! Along a direction `ω` from the light, a first scattering happens before distance `r`
//! with probability `1 − e^{−τ(r)}`, `τ` the optical depth `σt∫₀^r D(s + tω)dt` (the
//! shadow march of [`super::lights_pass::optical_depth`]); a point light sends the same
//! power every way, so the share is `Σ_ω (1 − e^{−τ_ω(R)}) / Σ_ω (1 − e^{−τ_ω(∞)})` over
//! [`DIRECTIONS`] Fibonacci directions (`R` the radius, `τ(∞)` to the box's face). 0 for
//! a light whose rays meet no smoke.
//!
//! **Measured** (the bundled sample's first frame, σt 4, albedo 0.8, g 0.3, 80 × 60, no
//! environment, against `--reference`; BENCHMARKS "A point light in the smoke"): a light
//! in the stem, share 0.30, single scattering 36 % RMS off the path tracer (0.89× its
//! mean), the final image 34 % (0.82×), most of it around the light's image; a light in
//! the cap, share 0.06: 4.2 % (the reference's noise 3.3 %). [`describe`] warns above
//! [`NEAR_SHARE_WARNING`].

use super::grid_diffusion::fibonacci_directions;
use super::lights_pass::optical_depth;
use super::occupancy::Occupancy;
use haze_volume::Volume;
use rayon::prelude::*;

/// The radius, in smallest voxel sides, within which the grids smooth a point light's
/// `1/r²` away (a voxel's interpolation on each side of the light, and half a voxel of
/// the lights pass's ball).
pub const NEAR_VOXELS: f64 = 1.5;

/// Directions from the light the share is summed over.
pub const DIRECTIONS: usize = 256;

/// The share of a point light's first scattering near it above which the renderers warn
/// ([`describe`]).
pub const NEAR_SHARE_WARNING: f64 = 0.01;

/// The share of the first scatterings of a point light at `light` that happen within
/// [`NEAR_VOXELS`] smallest voxel sides of it, through `density` at extinction
/// `sigma_t` (module docs). 0 for an empty grid, a zero or non-finite `σt` or a light
/// whose rays meet no smoke.
pub fn near_share(density: &Volume, sigma_t: f64, light: [f64; 3]) -> f64 {
    if !(sigma_t.is_finite() && sigma_t > 0.0) || light.iter().any(|c| !c.is_finite()) {
        return 0.0;
    }
    if Occupancy::new(density).is_none() {
        return 0.0;
    }
    let vs = density.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let radius = NEAR_VOXELS * h0;
    // The march's step: half a voxel, so the near part takes three samples at least.
    let step = 0.5 * h0;
    let (near, all) = fibonacci_directions(DIRECTIONS)
        .par_iter()
        .map(|&w| {
            let scattered =
                |len: f64| -(-optical_depth(density, sigma_t, light, w, len, step)).exp_m1();
            (scattered(radius), scattered(f64::INFINITY))
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    // Below a millionth of the light scattered at all (per direction, on average) the
    // smoke is not lit by it: nothing to smooth.
    if all <= 1e-6 * DIRECTIONS as f64 {
        0.0
    } else {
        (near / all).clamp(0.0, 1.0)
    }
}

/// What `-v` says of point light number `index` (from 1) at `light` whose
/// [`near_share`] is `share`, and whether it is a warning (above
/// [`NEAR_SHARE_WARNING`]).
pub fn describe(index: usize, light: [f64; 3], share: f64) -> (String, bool) {
    let at = format!(
        "point light {index} at ({}, {}, {})",
        haze_core::number::shown(light[0]),
        haze_core::number::shown(light[1]),
        haze_core::number::shown(light[2])
    );
    let percent = 100.0 * share;
    if share > NEAR_SHARE_WARNING {
        (
            format!(
                "{at} sits in the smoke: {percent:.0} % of its first scattering happens within {NEAR_VOXELS} voxels of it, where the fast renderer's grids smooth its 1/r² peak, so the smoke around its image comes out too dark (a light with 30 % there: 34 % off the path tracer); --reference renders it exactly"
            ),
            true,
        )
    } else {
        (
            format!(
                "{at}: {percent:.1} % of its first scattering within {NEAR_VOXELS} voxels of it"
            ),
            false,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::Bbox;

    /// A cube of `n³` unit voxels of density `d`.
    fn cube(n: usize, d: f32) -> Volume {
        let side = n as f64;
        Volume::new([n; 3], Bbox::new([0.0; 3], [side; 3]), vec![d; n * n * n]).unwrap()
    }

    /// In uniform smoke deep enough that every direction's march reaches the cut-off, the
    /// share is the closed form `1 − e^{−μR}` (`μ = σt·D`, `R` = 1.5 voxels: three
    /// midpoint steps of a constant density, exact).
    #[test]
    fn uniform_smoke_gives_the_closed_form() {
        let v = cube(40, 1.0);
        for mu in [0.5f64, 1.0, 3.0] {
            let share = near_share(&v, mu, [20.0; 3]);
            let exact = -(-mu * NEAR_VOXELS).exp_m1();
            // Each direction's far sum is 1 − e^{−τ}, τ past the cut-off (20) or, at
            // μ = 0.5, the 20–35 voxels to the faces (τ ≥ 10): within 5·10⁻⁵ of 1.
            assert!(
                (share - exact).abs() < 5e-5 * exact,
                "μ {mu}: {share} vs {exact}"
            );
        }
    }

    /// A light outside the smoke, or no smoke, or no extinction: nothing near it.
    #[test]
    fn lights_away_from_smoke_and_degenerate_input_give_zero() {
        let mut data = vec![0.0f32; 32 * 32 * 32];
        // A slab of smoke at x ∈ [20, 24).
        for z in 0..32 {
            for y in 0..32 {
                for x in 20..24 {
                    data[(z * 32 + y) * 32 + x] = 2.0;
                }
            }
        }
        let slab = Volume::new([32; 3], Bbox::new([0.0; 3], [32.0; 3]), data).unwrap();
        assert_eq!(near_share(&slab, 1.0, [5.0, 16.0, 16.0]), 0.0);
        // Beside the slab's face (its trilinear density reaches half a voxel out) and
        // inside it.
        let beside = near_share(&slab, 1.0, [18.5, 16.0, 16.0]);
        let inside = near_share(&slab, 1.0, [22.0, 16.0, 16.0]);
        assert!(
            0.0 < beside && beside < inside && inside < 1.0,
            "{beside} {inside}"
        );
        assert_eq!(near_share(&cube(8, 0.0), 1.0, [4.0; 3]), 0.0);
        for sigma_t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(near_share(&cube(8, 1.0), sigma_t, [4.0; 3]), 0.0);
        }
        assert_eq!(near_share(&cube(8, 1.0), 1.0, [f64::NAN, 4.0, 4.0]), 0.0);
        // A light far outside the box, on a line through it.
        assert_eq!(near_share(&cube(8, 1.0), 1.0, [1e300, 4.0, 4.0]), 0.0);
    }

    #[test]
    fn the_warning_names_the_light_and_its_share() {
        let (w, warn) = describe(2, [1.5, 1.5, 1.2], 0.37);
        assert!(warn);
        assert!(
            w.starts_with("point light 2 at (1.5, 1.5, 1.2) sits in the smoke: 37 %"),
            "{w}"
        );
        let (said, warn) = describe(1, [0.0, 1e300, -3.0], 0.004);
        assert!(!warn);
        assert_eq!(
            said,
            "point light 1 at (0, 1e300, -3): 0.4 % of its first scattering within 1.5 voxels of it"
        );
    }
}
