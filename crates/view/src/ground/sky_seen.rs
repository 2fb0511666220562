//! How much of the sky the smoke leaves to the ground: the sky's irradiance on a point
//! `x` of the ground through the smoke, as a share of the open sky's,
//!
//! ```text
//! V_c(x) = ∫_{ω_z > 0} L_c(ω)·ω_z·T(x, ω, ∞) dω  /  ∫_{ω_z > 0} L_c(ω)·ω_z dω
//! ```
//!
//! per channel `c`, with `T` the smoke's transmittance from `x` along `ω` (the ground's
//! shadow rays, [`crate::ground`]). Under the bundled plume at its default extinction
//! only 41 % of the sky reaches the ground at the plume's foot and 86 % one unit from its
//! axis: a ground lit by the open sky there is up to 2.4× too bright in the smoke's
//! shadow, where the sky is all that lights it.
//!
//! **The directions** ([`SkyDirections`]): `rings × sectors` directions stratified for the
//! cosine — ring `i` at `sin²θ = (i + ½)/rings`, sector `j` at azimuth
//! `2π(j + ½ + ½·(i mod 2))/sectors` (odd rings half a sector on) — so that each carries
//! the same `ω_z dω` (`π/K` of `K` directions); direction `k` weighs `L_c(ω_k)/Σ_k L_c(ω_k)`,
//! which sums to 1 (to `1/K` each where a channel of the sky is black). Then
//! `V_c(x) = Σ_k w_{k,c}·T(x, ω_k, ∞)`: 1 (to rounding) where nothing is in the way.
//!
//! **Where it is taken** ([`SkyGrid`]): the fast renderers take `V` at the nodes of a
//! square grid on the ground, [`NODES`]² nodes over the smoke's box's footprint widened by
//! [`MARGIN`] times the box's height above the ground on every side, and bilinearly
//! between them; outside the grid `V = 1` (there the smoke stands lower than 27° above
//! the horizon, and holds at most a few per cent of the sky). Its directions are
//! [`RINGS`] × [`SECTORS`], its shadow rays the ground's ([`crate::render::ground_shadow`];
//! `ground_sky.wgsl` is the GPU's twin). The reference renderer estimates `V` at every
//! point of the ground it sees by Monte Carlo ([`sampled`]): directions jittered in the
//! same strata, at least [`SAMPLED_MIN`], its exact transmittance, the light the smoke
//! takes away counted against the open sky's exact irradiance
//! (`V = 1 − π/N·Σ L(ω_k)(1 − T_k)/E_sky`, unbiased, and exactly 1 where nothing is in
//! the way).

use crate::Rgb;
use crate::distant::Distant;
use haze_volume::Bbox;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Rings of the fast renderers' directions.
pub const RINGS: usize = 6;
/// Sectors of azimuth of the fast renderers' directions.
pub const SECTORS: usize = 16;
/// The fewest directions the reference renderer's estimate of `V` takes at a point
/// ([`sampled`]; more at more samples per pixel).
pub const SAMPLED_MIN: usize = 64;
/// Nodes of [`SkyGrid`] per side.
pub const NODES: usize = 40;
/// How far [`SkyGrid`] reaches past the smoke's footprint, in the box's heights above
/// the ground.
pub const MARGIN: f64 = 2.0;

/// The sky's directions over the upper hemisphere and their weights (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyDirections {
    /// Unit directions, `z > 0`.
    pub directions: Vec<[f64; 3]>,
    /// Per direction and channel, its share of the sky's irradiance.
    pub weights: Vec<Rgb>,
}

impl SkyDirections {
    /// `rings × sectors` directions of `distant`'s sky (module docs); at least one of each.
    pub fn new(distant: &Distant, rings: usize, sectors: usize) -> SkyDirections {
        let (rings, sectors) = (rings.max(1), sectors.max(1));
        let mut directions = Vec::with_capacity(rings * sectors);
        for i in 0..rings {
            let s2 = (i as f64 + 0.5) / rings as f64;
            let (s, c) = (s2.sqrt(), (1.0 - s2).sqrt());
            let shift = 0.5 * (i % 2) as f64;
            for j in 0..sectors {
                let phi = 2.0 * PI * (j as f64 + 0.5 + shift) / sectors as f64;
                directions.push([s * phi.cos(), s * phi.sin(), c]);
            }
        }
        let radiance: Vec<Rgb> = directions.iter().map(|&d| distant.radiance(d)).collect();
        let k = directions.len() as f64;
        let mut weights = vec![[1.0 / k; 3]; directions.len()];
        for c in 0..3 {
            let sum: f64 = radiance.iter().map(|l| l[c].max(0.0)).sum();
            if sum > 0.0 && sum.is_finite() {
                for (w, l) in weights.iter_mut().zip(&radiance) {
                    w[c] = l[c].max(0.0) / sum;
                }
            }
        }
        SkyDirections {
            directions,
            weights,
        }
    }

    /// `V(x)` with the smoke's transmittance `transmittance(x, ω, r)` (module docs).
    pub fn seen_from(
        &self,
        x: [f64; 3],
        transmittance: impl Fn([f64; 3], [f64; 3], f64) -> f64,
    ) -> Rgb {
        let mut out = [0.0; 3];
        for (&d, w) in self.directions.iter().zip(&self.weights) {
            let t = transmittance(x, d, f64::INFINITY);
            if t > 0.0 {
                for c in 0..3 {
                    out[c] += w[c] * t;
                }
            }
        }
        out.map(|v| v.clamp(0.0, 1.0))
    }
}

/// `V` at the nodes of a square grid on the ground, bilinear between them, 1 outside
/// (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyGrid {
    /// The node `(0, 0)`, world `x, y`.
    pub origin: [f64; 2],
    /// The nodes' spacing, world units.
    pub cell: f64,
    /// Nodes per side.
    pub nodes: usize,
    /// `V` per node, `x` fastest.
    pub values: Vec<Rgb>,
}

impl SkyGrid {
    /// Where the grid lies for a smoke in `bbox` over the ground at `height`: its origin
    /// and spacing ([`NODES`] a side; module docs). `None` where the box has no height
    /// above the ground or no extent (no smoke can hide the sky).
    pub fn placed(bbox: &Bbox, height: f64) -> Option<([f64; 2], f64)> {
        let above = bbox.max[2] - height;
        let wide = (bbox.max[0] - bbox.min[0]).max(bbox.max[1] - bbox.min[1]);
        if !(above > 0.0 && wide > 0.0 && above.is_finite() && wide.is_finite()) {
            return None;
        }
        let side = wide + 2.0 * MARGIN * above;
        let centre = [0, 1].map(|a| 0.5 * (bbox.min[a] + bbox.max[a]));
        let cell = side / (NODES - 1) as f64;
        Some((centre.map(|c| c - 0.5 * side), cell))
    }

    /// `V` at every node of the grid [`SkyGrid::placed`] puts on the ground at `height`
    /// under the smoke in `bbox`, by `directions` and the shadow rays `transmittance`;
    /// `None` where it puts none.
    pub fn compute(
        directions: &SkyDirections,
        bbox: &Bbox,
        height: f64,
        transmittance: impl Fn([f64; 3], [f64; 3], f64) -> f64 + Sync,
    ) -> Option<SkyGrid> {
        let (origin, cell) = SkyGrid::placed(bbox, height)?;
        let values = (0..NODES * NODES)
            .into_par_iter()
            .map(|k| {
                let x = [
                    origin[0] + (k % NODES) as f64 * cell,
                    origin[1] + (k / NODES) as f64 * cell,
                    height,
                ];
                directions.seen_from(x, &transmittance)
            })
            .collect();
        Some(SkyGrid {
            origin,
            cell,
            nodes: NODES,
            values,
        })
    }

    /// `V` at the ground point `x`: bilinear between the nodes, 1 outside the grid.
    pub fn at(&self, x: [f64; 3]) -> Rgb {
        let n = self.nodes;
        let f = [0, 1].map(|a| (x[a] - self.origin[a]) / self.cell);
        let top = (n.max(2) - 1) as f64;
        if n < 2 || !f.iter().all(|&v| (0.0..=top).contains(&v)) {
            return [1.0; 3];
        }
        let i0 = f.map(|v| (v.floor() as usize).min(n - 2));
        let t = [0, 1].map(|a| f[a] - i0[a] as f64);
        let v = |i: usize, j: usize| self.values[(i0[0] + i) + n * (i0[1] + j)];
        let (a, b, c, d) = (v(0, 0), v(1, 0), v(0, 1), v(1, 1));
        [0, 1, 2].map(|k| {
            (1.0 - t[1]) * ((1.0 - t[0]) * a[k] + t[0] * b[k])
                + t[1] * ((1.0 - t[0]) * c[k] + t[0] * d[k])
        })
    }
}

/// How a [`super::GroundLight`] takes the sky's share that reaches the ground.
#[derive(Clone, Debug, PartialEq)]
pub enum SkySeen {
    /// The open sky: nothing in the way (no smoke, or none yet known).
    Open,
    /// The fast renderers' grid.
    Grid(SkyGrid),
}

impl SkySeen {
    /// `V(x)`.
    pub fn at(&self, x: [f64; 3]) -> Rgb {
        match self {
            SkySeen::Open => [1.0; 3],
            SkySeen::Grid(g) => g.at(x),
        }
    }
}

/// The reference renderer's estimate of `V(x)` (module docs): `n` directions or more
/// (at least [`SAMPLED_MIN`]), one jittered by `uniform` (numbers in `[0, 1)`) in each
/// cell of `rings × 2·rings` strata of equal `ω_z dω`, the smoke's transmittance
/// `transmittance(x, ω, r)`, `distant`'s radiance, `irradiance` the open sky's `E_sky`
/// per channel: `1 − π/N·Σ_k L(ω_k)(1 − T_k)/E_sky`, floored at 0 (1 for a black channel).
pub fn sampled(
    distant: &Distant,
    irradiance: Rgb,
    x: [f64; 3],
    n: usize,
    uniform: &mut dyn FnMut() -> f64,
    transmittance: impl Fn([f64; 3], [f64; 3], f64) -> f64,
) -> Rgb {
    let rings = ((n.max(SAMPLED_MIN) as f64 / 2.0).sqrt().ceil() as usize).max(1);
    let sectors = 2 * rings;
    let mut lost = [0.0; 3];
    for i in 0..rings {
        for j in 0..sectors {
            let s2 = (i as f64 + uniform()) / rings as f64;
            let phi = 2.0 * PI * (j as f64 + uniform()) / sectors as f64;
            let (s, c) = (s2.sqrt(), (1.0 - s2).max(0.0).sqrt());
            let w = [s * phi.cos(), s * phi.sin(), c];
            let t = transmittance(x, w, f64::INFINITY);
            if t < 1.0 {
                let l = distant.radiance(w);
                for k in 0..3 {
                    lost[k] += l[k] * (1.0 - t);
                }
            }
        }
    }
    let count = (rings * sectors) as f64;
    [0, 1, 2].map(|k| {
        if irradiance[k] > 0.0 && irradiance[k].is_finite() {
            (1.0 - PI * lost[k] / (count * irradiance[k])).max(0.0)
        } else {
            1.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distant::{LatLong, Sky};

    /// `2·E₃(τ) = 2∫₀¹ μ e^{−τ/μ} dμ`, the sky's share under an infinite slab of optical
    /// depth `τ` over a uniform sky, by a fine midpoint rule (10⁵ cells).
    fn slab_share(tau: f64) -> f64 {
        let n = 100_000;
        (0..n)
            .map(|i| {
                let mu = (i as f64 + 0.5) / n as f64;
                2.0 * mu * (-tau / mu).exp() / n as f64
            })
            .sum()
    }

    /// Under an infinite slab of uniform smoke over a uniform sky, `V = 2E₃(τ)`: the fast
    /// renderers' 6 × 16 directions within 1 % of it (measured 0.8 % at most, the
    /// midpoint rule in `sin²θ` on 6 rings; the integrand's slope grows without bound at
    /// the horizon); the reference's estimate within 0.005 at 2048 directions, its mean
    /// over many estimates within 0.002 (it is unbiased); nothing in the way leaves 1 (to
    /// rounding for the grid's weights, exactly for the estimate), an opaque slab 0.
    #[test]
    fn under_a_slab_the_share_is_twice_e3() {
        let sky = Distant::Sky(Sky {
            zenith: [0.5; 3],
            horizon: [0.5; 3],
            ground: [0.1; 3],
            sun: [0.0; 3],
            ..Sky::default()
        });
        let fast = SkyDirections::new(&sky, RINGS, SECTORS);
        let e = crate::ground::sky_irradiance(&sky);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            // SplitMix64, for numbers in [0, 1).
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            (z ^ (z >> 31)) as f64 / 2f64.powi(64)
        };
        for tau in [0.05, 0.5, 1.0, 3.0] {
            let slab = |_: [f64; 3], w: [f64; 3], _: f64| (-tau / w[2]).exp();
            let want = slab_share(tau);
            let f = fast.seen_from([0.0; 3], slab);
            // The reference's estimate, of the light taken away: within 0.005 of the
            // sky's whole at 2048 directions, and its mean over 400 estimates of 64
            // within 0.002 (unbiased).
            let one = sampled(&sky, e, [0.0; 3], 2048, &mut uniform, slab);
            let mean = (0..400)
                .map(|_| sampled(&sky, e, [0.0; 3], 64, &mut uniform, slab)[0])
                .sum::<f64>()
                / 400.0;
            assert!((mean - want).abs() < 0.002, "τ {tau}: {mean} vs {want}");
            for c in 0..3 {
                assert!(
                    (f[c] / want - 1.0).abs() < 0.01,
                    "τ {tau}: {} vs {want}",
                    f[c]
                );
                assert!(
                    (one[c] - want).abs() < 0.005,
                    "τ {tau}: {} vs {want}",
                    one[c]
                );
            }
        }
        // With nothing in the way the estimate is 1 exactly; behind an opaque slab 0.
        assert_eq!(
            sampled(&sky, e, [0.0; 3], 64, &mut uniform, |_, _, _| 1.0),
            [1.0; 3]
        );
        // A black sky (no irradiance to take a share of) leaves 1, not 0/0.
        let none = sampled(
            &sky,
            [0.0, f64::NAN, 0.0],
            [0.0; 3],
            64,
            &mut uniform,
            |_, _, _| 0.0,
        );
        assert_eq!(none, [1.0; 3]);
        let dark = sampled(&sky, e, [0.0; 3], 64, &mut uniform, |_, _, _| 0.0);
        assert!(dark.iter().all(|v| v.abs() < 0.05), "{dark:?}");
        let open = fast.seen_from([0.0; 3], |_, _, _| 1.0);
        assert!(open.iter().all(|v| (v - 1.0).abs() < 1e-12), "{open:?}");
        assert_eq!(fast.seen_from([0.0; 3], |_, _, _| 0.0), [0.0; 3]);
    }

    /// The weights are each direction's share of the sky: `1/K` under a uniform sky, and
    /// summing to 1 per channel under the built-in one, whose irradiance the directions'
    /// mean radiance times π gives within 2 % (they carry equal `ω_z dω`); a black sky
    /// weighs every direction alike.
    #[test]
    fn the_weights_are_the_skys_shares() {
        let uniform = SkyDirections::new(
            &Distant::Map(LatLong::new(1, 1, vec![[2.0; 3]]).unwrap()),
            3,
            5,
        );
        assert_eq!(uniform.directions.len(), 15);
        for w in &uniform.weights {
            assert!(w.iter().all(|&k| (k - 1.0 / 15.0).abs() < 1e-15));
        }
        for d in &uniform.directions {
            let n = d.iter().map(|c| c * c).sum::<f64>();
            assert!((n - 1.0).abs() < 1e-12 && d[2] > 0.0);
        }
        let sky = Distant::Sky(Sky::default());
        let dirs = SkyDirections::new(&sky, RINGS, SECTORS);
        let exact = crate::ground::sky_irradiance(&sky);
        for c in 0..3 {
            let total: f64 = dirs.weights.iter().map(|w| w[c]).sum();
            assert!((total - 1.0).abs() < 1e-12, "{total}");
            let mean: f64 = dirs
                .directions
                .iter()
                .map(|&d| sky.radiance(d)[c])
                .sum::<f64>()
                / dirs.directions.len() as f64;
            assert!(
                (PI * mean / exact[c] - 1.0).abs() < 0.02,
                "{} vs {}",
                PI * mean,
                exact[c]
            );
        }
        let black = SkyDirections::new(
            &Distant::Map(LatLong::new(1, 1, vec![[0.0; 3]]).unwrap()),
            2,
            2,
        );
        assert!(black.weights.iter().all(|w| *w == [0.25; 3]));
    }

    /// The grid lies over the footprint widened by twice the box's height on each side;
    /// reads its nodes where they are, the mean of two halfway between, 1 outside; none
    /// for a box wholly below the ground; a box of air leaves every node at 1.
    #[test]
    fn the_grid_is_placed_and_read_bilinearly() {
        let bbox = Bbox::new([0.0, 0.0, 1.0], [2.0, 1.0, 3.0]);
        let (origin, cell) = SkyGrid::placed(&bbox, 1.0).unwrap();
        // Height above the ground 2: side 2 + 2·2·2 = 10 around the centre (1, 0.5).
        assert!((origin[0] + 4.0).abs() < 1e-12 && (origin[1] + 4.5).abs() < 1e-12);
        assert!((cell * (NODES - 1) as f64 - 10.0).abs() < 1e-12);
        assert!(SkyGrid::placed(&bbox, 3.0).is_none());
        assert!(SkyGrid::placed(&bbox, f64::NAN).is_none());
        let dirs = SkyDirections::new(
            &Distant::Map(LatLong::new(1, 1, vec![[1.0; 3]]).unwrap()),
            2,
            4,
        );
        let air = SkyGrid::compute(&dirs, &bbox, 1.0, |_, _, _| 1.0).unwrap();
        assert!(air.values.iter().all(|v| *v == [1.0; 3]));
        let ramp = SkyGrid {
            values: (0..NODES * NODES)
                .map(|k| [(k % NODES) as f64 / 100.0, 0.5, (k / NODES) as f64 / 100.0])
                .collect(),
            ..air
        };
        let node = |i: f64, j: f64| [origin[0] + i * cell, origin[1] + j * cell, 1.0];
        let at = ramp.at(node(3.0, 7.0));
        assert!(
            (at[0] - 0.03).abs() < 1e-12 && (at[2] - 0.07).abs() < 1e-12,
            "{at:?}"
        );
        let half = ramp.at(node(3.5, 7.5));
        assert!((half[0] - 0.035).abs() < 1e-12 && (half[2] - 0.075).abs() < 1e-12);
        let last = (NODES - 1) as f64;
        assert!((ramp.at(node(last, last))[0] - last / 100.0).abs() < 1e-12);
        assert_eq!(ramp.at(node(-0.01, 3.0)), [1.0; 3]);
        assert_eq!(ramp.at(node(3.0, last + 0.01)), [1.0; 3]);
        assert_eq!(ramp.at([f64::NAN, 0.0, 1.0]), [1.0; 3]);
    }
}
