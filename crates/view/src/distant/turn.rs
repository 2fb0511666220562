//! A lat-long map laid out by another convention, or turned about the vertical.
//!
//! haze reads column `u` of a map as the azimuth `φ = 2πu`, from +X towards +Y
//! (docs/conventions.md). Blender's World (an Environment Texture, equirectangular, no
//! Mapping node) reads the same file the other way round: Cycles'
//! `direction_to_equirectangular` gives `u = ½ − φ/2π`, so its centre column faces +X and
//! its azimuth falls with `u`. The same map lit in both is mirrored (`x → −x`) unless it
//! is laid out as Blender reads it ([`Layout::Blender`]). A turn by `R` moves what the
//! map shows at azimuth `φ` to `φ + R` (counter-clockwise seen from above).
//!
//! [`LatLong::turned`] resamples each row: the texel whose centre lies at azimuth `φ`
//! takes the file's row at `u = (φ − R)/2π` (haze's layout) or `u = ½ − (φ − R)/2π`
//! (Blender's), linear between the file's texel centres and wrapping in azimuth. A
//! layout alone, or a turn by a whole number of texels, copies texels exactly; any turn
//! keeps each row's sum (each source texel's two weights sum to one), so the map's power
//! and its suns' are unchanged. [`LatLong::scaled`] multiplies its radiance.

use super::LatLong;

/// How a file's columns map to azimuths (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layout {
    /// Column `u` at azimuth `2πu` from +X towards +Y (docs/conventions.md).
    #[default]
    Haze,
    /// As Blender's World reads it: column `u` at azimuth `π − 2πu`.
    Blender,
}

impl LatLong {
    /// This map, read as laid out by `layout`, then turned by `degrees` about +Z (module
    /// docs). The same map for [`Layout::Haze`] and a whole number of turns.
    pub fn turned(&self, layout: Layout, degrees: f64) -> LatLong {
        let turn = (degrees / 360.0).rem_euclid(1.0);
        if layout == Layout::Haze && turn == 0.0 || self.width < 2 {
            return self.clone();
        }
        let w = self.width as f64;
        // Source column (in texels, centres at k + ½) for destination column `x`.
        let source = |x: usize| {
            let u = (x as f64 + 0.5) / w - turn;
            let u = match layout {
                Layout::Haze => u,
                Layout::Blender => 0.5 - u,
            };
            (u * w - 0.5).rem_euclid(w)
        };
        let columns: Vec<(usize, usize, f32)> = (0..self.width)
            .map(|x| {
                let p = source(x);
                let lo = (p.floor() as usize).min(self.width - 1);
                let t = p - lo as f64;
                // A weight within 1e-9 of a texel is that texel (a layout or a turn by
                // whole texels copies exactly).
                let t = if t < 1e-9 {
                    0.0
                } else if t > 1.0 - 1e-9 {
                    1.0
                } else {
                    t
                };
                (lo, (lo + 1) % self.width, t as f32)
            })
            .collect();
        let mut texels = Vec::with_capacity(self.texels.len());
        for row in self.texels.chunks(self.width) {
            for &(a, b, t) in &columns {
                let (ta, tb) = (row[a], row[b]);
                texels.push(if t == 0.0 {
                    ta
                } else if t == 1.0 {
                    tb
                } else {
                    [0, 1, 2].map(|c| ta[c] * (1.0 - t) + tb[c] * t)
                });
            }
        }
        LatLong {
            width: self.width,
            height: self.height,
            texels,
        }
    }
}

impl LatLong {
    /// This map's radiance times `strength` (`--env-strength`, Blender's Background
    /// Strength): the same map for 1; an error, as [`LatLong::new`]'s, where a texel would
    /// pass [`super::MAX_RADIANCE`] or `strength` is negative or not finite.
    pub fn scaled(&self, strength: f64) -> Result<LatLong, String> {
        if !(strength.is_finite() && strength >= 0.0) {
            return Err(format!(
                "strength {strength} must be finite and non-negative"
            ));
        }
        if strength == 1.0 {
            return Ok(self.clone());
        }
        let s = strength as f32;
        let texels = self.texels.iter().map(|t| t.map(|c| c * s)).collect();
        LatLong::new(self.width, self.height, texels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// A 2w × w map with one bright texel at column `x`, row `y`.
    fn spot(w: usize, x: usize, y: usize) -> LatLong {
        let mut texels = vec![[0.1f32, 0.2, 0.3]; 2 * w * w];
        texels[y * 2 * w + x] = [50.0, 40.0, 30.0];
        LatLong::new(2 * w, w, texels).unwrap()
    }

    /// Blender's layout puts the texel where Cycles' `equirectangular_to_direction`
    /// (`φ = π − 2πu`, `θ = πv` from the top) sees it, at every column, and copies
    /// texels exactly.
    #[test]
    fn blenders_layout_puts_each_texel_where_blender_sees_it() {
        let w = 8;
        for x in 0..2 * w {
            let m = spot(w, x, 3);
            let turned = m.turned(Layout::Blender, 0.0);
            let u = (x as f64 + 0.5) / (2 * w) as f64;
            let (theta, phi) = (std::f64::consts::PI * 3.5 / w as f64, 0.5 * TAU - TAU * u);
            let d = [
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ];
            // Bilinear at the texel's centre: the texel, to rounding.
            let got = turned.radiance(d);
            for (g, want) in got.iter().zip([50.0, 40.0, 30.0]) {
                assert!((g - want).abs() < 1e-9 * want, "column {x}: {got:?}");
            }
            let mut a = m.texels.clone();
            let mut b = turned.texels.clone();
            let key = |t: &[f32; 3]| t.map(f32::to_bits);
            a.sort_by_key(key);
            b.sort_by_key(key);
            assert_eq!(a, b, "the same texels, moved");
        }
    }

    /// A turn by whole texels moves columns exactly; any turn keeps every row's sum; a
    /// full turn and a turn back give the map again.
    #[test]
    fn turns_move_columns_and_keep_the_power() {
        let w = 8;
        let m = spot(w, 2, 5);
        let quarter = m.turned(Layout::Haze, 90.0);
        assert_eq!(quarter.texels[5 * 2 * w + 2 + w / 2], [50.0, 40.0, 30.0]);
        assert_eq!(m.turned(Layout::Haze, 360.0), m);
        assert_eq!(m.turned(Layout::Haze, -90.0).turned(Layout::Haze, 90.0), m);
        for degrees in [7.3, 100.0, -33.3] {
            let t = m.turned(Layout::Haze, degrees);
            for (a, b) in m.texels.chunks(2 * w).zip(t.texels.chunks(2 * w)) {
                for c in 0..3 {
                    let sa: f64 = a.iter().map(|p| f64::from(p[c])).sum();
                    let sb: f64 = b.iter().map(|p| f64::from(p[c])).sum();
                    assert!((sa - sb).abs() < 1e-5 * sa, "{degrees}: {sa} vs {sb}");
                }
            }
        }
        // Strength: exact doubling, the limit and bad factors refused.
        let twice = m.scaled(2.0).unwrap();
        assert!(
            twice
                .texels
                .iter()
                .zip(&m.texels)
                .all(|(a, b)| *a == b.map(|c| 2.0 * c))
        );
        assert_eq!(m.scaled(1.0).unwrap(), m);
        assert!(
            m.scaled(0.0)
                .unwrap()
                .texels
                .iter()
                .flatten()
                .all(|&c| c == 0.0)
        );
        assert!(m.scaled(1e29).unwrap_err().contains("radiance above"));
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            assert!(
                m.scaled(bad).unwrap_err().contains("must be finite"),
                "{bad}"
            );
        }
        // A one-texel map is the same from every direction.
        let one = LatLong::new(1, 1, vec![[1.0; 3]]).unwrap();
        assert_eq!(one.turned(Layout::Blender, 45.0), one);
    }
}
