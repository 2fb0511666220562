//! The eraser (paper B §6): lowers the density of the Gaussians it covers and deletes
//! those that reach zero. The brush is a disk of `radius` pixels on the screen; it covers
//! the Gaussians whose centres project inside it (at any depth in front of the eye). Along
//! a stroke it dabs every `radius/2` pixels (the first dab where the stroke starts), each
//! dab taking `strength` off the weight of every Gaussian it covers.

use super::Draft;
use crate::Camera;
use haze_core::number::shown;
use haze_gaussians::Gaussian;

/// The eraser's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EraseParams {
    /// The brush's radius in pixels.
    pub radius: f64,
    /// Weight taken off each covered Gaussian per dab.
    pub strength: f64,
}

impl EraseParams {
    pub fn check(&self) -> Result<(), String> {
        if !(self.radius > 0.0 && self.radius.is_finite()) {
            return Err(format!(
                "eraser radius {} must be positive",
                shown(self.radius)
            ));
        }
        if !(self.strength > 0.0 && self.strength.is_finite()) {
            return Err(format!(
                "eraser strength {} must be positive",
                shown(self.strength)
            ));
        }
        Ok(())
    }
}

/// One stroke of the eraser.
#[derive(Clone, Debug)]
pub struct Eraser {
    params: EraseParams,
    /// The last dab and the screen distance travelled since.
    last: Option<(f64, f64)>,
    since: f64,
}

impl Eraser {
    pub fn new(params: EraseParams) -> Result<Eraser, String> {
        params.check()?;
        Ok(Eraser {
            params,
            last: None,
            since: 0.0,
        })
    }

    /// Moves the brush to image point `(px, py)` of `camera`, dabbing along the way.
    pub fn stroke_to(&mut self, camera: &Camera, px: f64, py: f64, draft: &mut Draft) {
        let step = 0.5 * self.params.radius;
        let Some((x0, y0)) = self.last else {
            self.dab(camera, px, py, draft);
            self.last = Some((px, py));
            return;
        };
        let len = (px - x0).hypot(py - y0);
        if !(len > 0.0 && len.is_finite()) {
            return;
        }
        let mut at = step - self.since;
        let mut last_at = None;
        while at <= len {
            let f = at / len;
            self.dab(camera, x0 + f * (px - x0), y0 + f * (py - y0), draft);
            last_at = Some(at);
            at += step;
        }
        self.since = last_at.map_or(self.since + len, |l| len - l);
        self.last = Some((px, py));
    }

    /// One dab at `(px, py)`.
    fn dab(&self, camera: &Camera, px: f64, py: f64, draft: &mut Draft) {
        let hits: Vec<(usize, Gaussian)> = draft
            .existing()
            .filter(|(_, g)| covers(camera, g, px, py, self.params.radius))
            .collect();
        for (i, g) in hits {
            let weight = g.weight - self.params.strength;
            draft.set(i, (weight > 0.0).then_some(Gaussian { weight, ..g }));
        }
    }
}

/// Whether the disk of `radius` pixels at `(px, py)` covers `g`'s centre.
pub fn covers(camera: &Camera, g: &Gaussian, px: f64, py: f64, radius: f64) -> bool {
    camera
        .project(g.center)
        .is_some_and(|(x, y)| (x - px).hypot(y - py) <= radius)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::Document;

    /// A row of Gaussians at pixels `x = 10, 20, …, 190` of row 50 (5 in front of the
    /// eye), and one behind the eye; a stroke along the row from x = 43 to 103 with an
    /// 11.7-pixel brush dabs at 43, 48.85, …, 101.5 (11 dabs; no Gaussian lies exactly on
    /// the brush's rim): the Gaussian at x is covered by the dabs within 11.7 pixels.
    /// Weights fall by 0.1 per dab; those reaching zero go.
    #[test]
    fn the_stroke_lowers_and_deletes_what_it_covers_and_undo_brings_it_back() {
        let cam = Camera::new([0.0; 3], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], 60.0, 200, 100).unwrap();
        let mut gs: Vec<Gaussian> = (1..20)
            .map(|k| {
                let d = cam.ray(10.0 * k as f64, 50.0);
                Gaussian {
                    center: d.map(|x| 5.0 * x),
                    radius: 0.2,
                    weight: 0.05 * k as f64 + 0.013,
                }
            })
            .collect();
        gs.push(Gaussian {
            center: [0.0, -3.0, 0.0],
            radius: 0.2,
            weight: 1.0,
        });
        let mut doc = Document::new(gs.clone());
        let mut d = doc.draft();
        let mut e = Eraser::new(EraseParams {
            radius: 11.7,
            strength: 0.1,
        })
        .unwrap();
        for k in 0..=10 {
            e.stroke_to(&cam, 43.0 + 6.0 * k as f64, 50.0, &mut d);
        }
        let dabs: Vec<f64> = (0..=10).map(|k| 43.0 + 5.85 * k as f64).collect();
        let mut expect = Vec::new();
        for (k, g) in gs.iter().enumerate() {
            let x = 10.0 * (k + 1) as f64;
            let n = if k < 19 {
                dabs.iter().filter(|&&c| (c - x).abs() <= 11.7).count()
            } else {
                0
            };
            let w = g.weight - 0.1 * n as f64;
            if n == 0 {
                expect.push(*g);
            } else if w > 0.0 {
                expect.push(Gaussian { weight: w, ..*g });
            }
        }
        let got = d.gaussians();
        assert_eq!(got.len(), expect.len());
        assert!(expect.len() < gs.len(), "some deleted");
        for (a, b) in got.iter().zip(&expect) {
            assert_eq!((a.center, a.radius), (b.center, b.radius));
            assert!((a.weight - b.weight).abs() < 1e-12);
        }
        assert!(doc.commit(d.into_edit()));
        assert!(doc.undo());
        assert_eq!(doc.gaussians(), gs.as_slice());
        assert!(
            EraseParams {
                radius: 0.0,
                strength: 1.0
            }
            .check()
            .is_err()
        );
    }
}
