//! A point light in the smoke, as the viewer shows it: whether the picture near it is
//! approximate.
//!
//! The grids carry a point light's `1/r²` and its multiple scattering cell by cell; the
//! view pass adds what they cannot follow within four voxels of it, but the multiple
//! scattering near a light surrounded by smoke stays approximate
//! ([`haze_view::render::near_light`]: 8–22 % off the path tracer where 3–41 % of the
//! light's first scattering happens within 1.5 voxels of it). `haze render` warns above
//! [`near_light::NEAR_SHARE_WARNING`]; the viewer says the same in its panel and its log,
//! per picture: the share depends on the frame's density, σt and the light's position,
//! so each frame is measured once per σt and set of lights (a few milliseconds: 256
//! shadow marches a light) on the density the asset reconstructs (RBFs plus residual),
//! the one evaluation the thick voxels' measure takes too (`thick::FrameDensity`).

use super::thick::FrameDensity;
use haze_view::lights::PointLight;
use haze_view::render::near_light;
use std::collections::HashMap;

/// The share of each point light's first scattering near it, for one picture.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lamps {
    /// Each light's position and [`near_light::near_share`].
    shares: Vec<([f64; 3], f64)>,
}

impl Lamps {
    /// The warnings, one per light above [`near_light::NEAR_SHARE_WARNING`] with its
    /// position (none without such a light).
    pub fn warnings(&self) -> Vec<([f64; 3], String)> {
        self.shares
            .iter()
            .zip(self.lines())
            .filter_map(|(&(at, _), (w, warn))| warn.then_some((at, w)))
            .collect()
    }

    /// What the panel says of every light, warnings or not ([`near_light::describe`]).
    pub fn lines(&self) -> impl Iterator<Item = (String, bool)> + '_ {
        self.shares
            .iter()
            .enumerate()
            .map(|(i, &(at, share))| near_light::describe(i + 1, at, share))
    }
}

/// What one frame's shares were measured at: σt's bits and the lights' positions.
type Key = (u64, Vec<[u64; 3]>);

/// Measures the shares of each frame's point lights (module docs); owned by the render
/// thread.
#[derive(Debug, Default)]
pub struct LampCheck {
    /// The shares measured so far, by the frame's index in the asset, with their key.
    measured: HashMap<usize, (Key, Lamps)>,
}

impl LampCheck {
    /// The shares of `lights` in the frame of `density` at `sigma_t`: none without
    /// point lights. Errors: a damaged frame.
    pub fn check(
        &mut self,
        density: &mut FrameDensity<'_>,
        sigma_t: f64,
        lights: &[PointLight],
    ) -> Result<Lamps, String> {
        if lights.is_empty() {
            return Ok(Lamps::default());
        }
        let key: Key = (
            sigma_t.to_bits(),
            lights
                .iter()
                .map(|l| l.position.map(f64::to_bits))
                .collect(),
        );
        if let Some((k, lamps)) = self.measured.get(&density.index())
            && *k == key
        {
            return Ok(lamps.clone());
        }
        let volume = density.get()?;
        let lamps = Lamps {
            shares: lights
                .iter()
                .map(|l| {
                    let share = near_light::near_share(volume, sigma_t, l.position);
                    (l.position, share)
                })
                .collect(),
        };
        self.measured.insert(density.index(), (key, lamps.clone()));
        Ok(lamps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_view::stream::StreamFrame;
    use haze_volume::{Bbox, Rbf};

    /// One dense Gaussian puff of radius 0.25 in the unit box.
    fn frame(index: usize) -> StreamFrame {
        StreamFrame {
            index,
            number: 7,
            rbfs: vec![Rbf {
                center: [0.5, 0.5, 0.5],
                radius: 0.25,
                weight: 8.0,
            }],
            residual: None,
        }
    }

    fn lamp(position: [f64; 3]) -> PointLight {
        PointLight {
            position,
            intensity: [1.0; 3],
        }
    }

    /// A lamp in the puff's core is warned about and one outside the box is not; the
    /// shares are those of `near_share` on the density the frame reconstructs, kept per
    /// frame and measured again for a new σt or a moved light.
    #[test]
    fn a_lamp_in_the_smoke_is_warned_about_and_one_outside_is_not() {
        let (dims, bbox) = ([24, 24, 24], Bbox::new([0.0; 3], [1.0; 3]));
        let f = frame(3);
        let inside = lamp([0.5, 0.5, 0.5]);
        let outside = lamp([0.5, 0.5, 3.0]);
        let mut check = LampCheck::default();
        let lamps = check
            .check(
                &mut FrameDensity::new(&f, dims, bbox),
                20.0,
                &[inside.clone(), outside.clone()],
            )
            .unwrap();
        let lines: Vec<_> = lamps.lines().collect();
        assert_eq!(lines.len(), 2);
        assert!(
            lines[0].1
                && lines[0]
                    .0
                    .starts_with("point light 1 at (0.5, 0.5, 0.5) sits in the smoke"),
            "{lines:?}"
        );
        assert!(!lines[1].1, "{lines:?}");
        assert_eq!(
            lamps.warnings(),
            vec![(inside.position, lines[0].0.clone())]
        );
        // The measure itself, on the density the frame reconstructs.
        let mut d = FrameDensity::new(&f, dims, bbox);
        let share = near_light::near_share(d.get().unwrap(), 20.0, inside.position);
        assert!(share > near_light::NEAR_SHARE_WARNING, "{share}");
        assert_eq!(lamps.shares[0].1, share);
        assert_eq!(lamps.shares[1].1, 0.0, "its rays meet no smoke");
        // Thinner smoke scatters less of the lamp's light near it; a moved lamp is
        // measured where it is.
        let thin = check
            .check(
                &mut FrameDensity::new(&f, dims, bbox),
                0.5,
                std::slice::from_ref(&inside),
            )
            .unwrap();
        assert!(thin.shares[0].1 < share, "{thin:?}");
        let moved = check
            .check(
                &mut FrameDensity::new(&f, dims, bbox),
                20.0,
                std::slice::from_ref(&outside),
            )
            .unwrap();
        assert!(moved.warnings().is_empty() && moved.shares[0].0 == outside.position);
    }

    /// No point light: nothing measured, nothing said; no smoke: no warning.
    #[test]
    fn no_lamp_or_no_smoke_says_nothing() {
        let (dims, bbox) = ([8, 8, 8], Bbox::new([0.0; 3], [1.0; 3]));
        let mut check = LampCheck::default();
        let f = frame(0);
        let mut d = FrameDensity::new(&f, dims, bbox);
        let none = check.check(&mut d, 4.0, &[]).unwrap();
        assert_eq!(none, Lamps::default());
        assert!(!d.evaluated(), "nothing to measure");
        let mut empty = frame(1);
        empty.rbfs[0].weight = 0.0;
        let dark = check
            .check(
                &mut FrameDensity::new(&empty, dims, bbox),
                4.0,
                &[lamp([0.5; 3])],
            )
            .unwrap();
        assert!(dark.warnings().is_empty());
        assert_eq!(dark.shares[0].1, 0.0);
    }
}
