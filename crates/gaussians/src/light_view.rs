//! The Gaussians' cull spheres as seen from a point light: which of them a segment that
//! ends at the light crosses, found from one bin of directions instead of a walk of the
//! hierarchy.
//!
//! A segment from `p` to the light `s` (`L = |p − s|`, `ŵ = (p − s)/L` as seen from the
//! light) crosses a sphere `(c, r)` that does not hold the light only if the ray from `s`
//! along `ŵ` meets it, i.e. `∠(ŵ, û) ≤ θ = asin(r/D)` (`D = |c − s|`, `û = (c − s)/D`), and
//! only if the sphere's nearest point to the light is within reach, `D − r ≤ L`. So each
//! sphere is listed in the bins of directions its cap `∠(ŵ, û) ≤ θ` overlaps, every bin
//! sorted by `D − r`; a query reads its direction's bin up to `D − r > L` and tests each
//! candidate exactly (the hierarchy's test, [`crate::bvh`]). Spheres that hold the light
//! are candidates of every query.
//!
//! The bins split the sphere of directions into [`ROWS`] bands of equal `z = ŵ_z` and
//! [`COLUMNS`] sectors of equal azimuth `φ`: cells of equal solid angle, `4π/(ROWS·COLUMNS)`.
//! A cap of centre `(θc, φc)` (polar angle, azimuth) and radius `θ` spans the polar angles
//! `[θc − θ, θc + θ]` and, when it holds neither pole, the azimuths `φc ± asin(sin θ/sin θc)`
//! (the great circle through the pole tangent to the cap); a cap over a pole spans every
//! azimuth. Both ranges are widened by [`SLACK`] radians, so rounding never drops a
//! candidate the exact test would keep.

use crate::airlight::{Blob, cull_radius, depth_of_found};
use haze_core::vec3::{Vec3, axpy, dot, norm, sub};
use std::f64::consts::PI;

/// Bands of equal `z` in the direction bins.
pub const ROWS: usize = 64;
/// Sectors of equal azimuth in the direction bins.
pub const COLUMNS: usize = 128;
/// Widening of every cap's angular ranges (radians): far above the rounding of the
/// `acos`, `atan2` and `asin` that place it, far below a bin (`> 0.02` rad).
const SLACK: f64 = 1e-7;

/// One candidate of a bin: the Gaussian and the distance from the light to its cull
/// sphere's nearest point (rounded down, so the bin's cut-off never drops it).
#[derive(Clone, Copy, Debug)]
struct Entry {
    near: f32,
    id: u32,
}

/// The cull spheres of a [`crate::airlight::GaussianSet`]'s Gaussians binned by direction
/// from one point light (module docs).
#[derive(Clone, Debug)]
pub struct LightView {
    light: Vec3,
    /// Per Gaussian: its centre and its cull radius (`0`: never a candidate).
    spheres: Vec<(Vec3, f64)>,
    /// The Gaussians whose cull sphere holds the light.
    around: Vec<u32>,
    /// Bin `k`'s candidates: `entries[starts[k]..starts[k + 1]]`, by `near`.
    starts: Vec<u32>,
    entries: Vec<Entry>,
}

impl LightView {
    /// Bins `blobs`' cull spheres as seen from the point light at `light`.
    pub fn new(blobs: &[Blob], light: Vec3) -> LightView {
        let spheres: Vec<(Vec3, f64)> = blobs.iter().map(|b| (b.center, cull_radius(b))).collect();
        let mut around = Vec::new();
        let mut caps = Vec::new();
        for (i, &(c, r)) in spheres.iter().enumerate() {
            if r <= 0.0 || !r.is_finite() {
                continue;
            }
            let v = sub(c, light);
            let dist = norm(v);
            if dist <= r * (1.0 + 1e-9) {
                around.push(i as u32);
                continue;
            }
            caps.push((i as u32, Cap::new(v, dist, r)));
        }
        let mut counts = vec![0u32; ROWS * COLUMNS + 1];
        for (_, cap) in &caps {
            cap.each_bin(|k| counts[k] += 1);
        }
        let mut starts = Vec::with_capacity(counts.len());
        let mut total = 0u32;
        for c in &counts {
            starts.push(total);
            total += c;
        }
        let mut fill: Vec<u32> = starts.clone();
        let mut entries = vec![Entry { near: 0.0, id: 0 }; total as usize];
        for &(id, ref cap) in &caps {
            cap.each_bin(|k| {
                entries[fill[k] as usize] = Entry { near: cap.near, id };
                fill[k] += 1;
            });
        }
        for k in 0..ROWS * COLUMNS {
            entries[starts[k] as usize..starts[k + 1] as usize]
                .sort_unstable_by(|a, b| a.near.total_cmp(&b.near));
        }
        LightView {
            light,
            spheres,
            around,
            starts,
            entries,
        }
    }

    /// The light's position.
    pub fn light(&self) -> Vec3 {
        self.light
    }

    /// Calls `f(i)` for every Gaussian whose cull sphere the segment `o + t·d`,
    /// `t ∈ [0, len]`, crosses, where the segment ends at the light (`o + len·d = light`,
    /// unit `d`): the same Gaussians as [`crate::bvh::SphereBvh::segment`] over the cull
    /// spheres, in another order.
    pub fn segment(&self, o: Vec3, d: Vec3, len: f64, mut f: impl FnMut(usize)) {
        if len.is_nan() || len < 0.0 {
            return;
        }
        let mut test = |i: usize| {
            let (c, r) = self.spheres[i];
            let bp = sub(c, o);
            let t = dot(bp, d).clamp(0.0, len);
            let x = axpy(bp, -t, d);
            if dot(x, x) <= r * r {
                f(i);
            }
        };
        for &i in &self.around {
            test(i as usize);
        }
        let k = bin(d.map(|x| -x));
        let reach = len as f32;
        for e in &self.entries[self.starts[k] as usize..self.starts[k + 1] as usize] {
            if e.near > reach {
                break;
            }
            test(e.id as usize);
        }
    }

    /// The Gaussians' optical depth along a segment that ends at the light and its
    /// scattering part `Σ αᵢTᵢ`, each Gaussian where the segment crosses its cull sphere,
    /// leaving out `skip`: [`crate::airlight::GaussianSet::cull_depth`] for such segments.
    pub fn cull_depth(
        &self,
        blobs: &[Blob],
        o: Vec3,
        d: Vec3,
        len: f64,
        skip: Option<usize>,
    ) -> (f64, f64) {
        depth_of_found(blobs, o, d, len, skip, |f| self.segment(o, d, len, f))
    }
}

/// The bin of the unit direction `w` (module docs).
fn bin(w: Vec3) -> usize {
    let row = (((w[2] + 1.0) * 0.5 * ROWS as f64) as usize).min(ROWS - 1);
    let column = azimuth_cell(w[1].atan2(w[0]));
    row * COLUMNS + column.min(COLUMNS - 1)
}

/// The sector of azimuth `φ ∈ [−π, π]`, unclamped (`φ = π` gives [`COLUMNS`]).
fn azimuth_cell(phi: f64) -> usize {
    ((phi + PI) / (2.0 * PI) * COLUMNS as f64).max(0.0) as usize
}

/// A sphere's cap of directions from the light, as bin ranges.
struct Cap {
    /// The distance from the light to the sphere's nearest point, rounded down.
    near: f32,
    rows: (usize, usize),
    /// Sectors `first..=last`, wrapping past the last; `None`: every sector.
    columns: Option<(i64, i64)>,
}

impl Cap {
    /// The cap of the sphere at `v` from the light (`dist = |v| > r`) of radius `r`.
    fn new(v: Vec3, dist: f64, r: f64) -> Cap {
        let theta = (r / dist).min(1.0).asin() + SLACK;
        let polar = (v[2] / dist).clamp(-1.0, 1.0).acos();
        let (lo, hi) = (polar - theta, polar + theta);
        // z falls as the polar angle grows: the top of the cap is the lowest polar angle.
        let z_top = if lo <= 0.0 { 1.0 } else { lo.cos() };
        let z_bottom = if hi >= PI { -1.0 } else { hi.cos() };
        let row = |z: f64| (((z + 1.0) * 0.5 * ROWS as f64).max(0.0) as usize).min(ROWS - 1);
        let columns = if lo <= 0.0 || hi >= PI {
            None
        } else {
            let spread = (theta.sin() / polar.sin()).min(1.0).asin() + SLACK;
            let centre = v[1].atan2(v[0]);
            let cell = |phi: f64| ((phi + PI) / (2.0 * PI) * COLUMNS as f64).floor() as i64;
            let (first, last) = (cell(centre - spread), cell(centre + spread));
            (last - first < COLUMNS as i64 - 1).then_some((first, last))
        };
        let near = (dist - r).max(0.0);
        let mut rounded = near as f32;
        if f64::from(rounded) > near {
            // The next f32 below (positive, as `near > rounded ≥ 0` is impossible here).
            rounded = f32::from_bits(rounded.to_bits() - 1);
        }
        Cap {
            near: rounded,
            rows: (row(z_bottom), row(z_top)),
            columns,
        }
    }

    /// Calls `f(k)` for every bin the cap overlaps.
    fn each_bin(&self, mut f: impl FnMut(usize)) {
        for row in self.rows.0..=self.rows.1 {
            match self.columns {
                None => (0..COLUMNS).for_each(|c| f(row * COLUMNS + c)),
                Some((first, last)) => {
                    for c in first..=last {
                        f(row * COLUMNS + c.rem_euclid(COLUMNS as i64) as usize);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::airlight::GaussianSet;
    use crate::cloud::Uniform;
    use crate::medium::{Gaussian, GaussianMedium};
    use haze_core::vec3::normalize;

    /// A crowd of Gaussians of varied sizes and weights, some at the poles of the lights
    /// below, one of zero weight.
    fn crowd(s: &mut Uniform) -> GaussianSet {
        let mut gaussians: Vec<Gaussian> = (0..400)
            .map(|i| Gaussian {
                center: [0, 1, 2].map(|_| s.sample() * 4.0 - 2.0),
                radius: 0.02 + 0.3 * s.sample(),
                weight: if i == 7 { 0.0 } else { 0.2 + 4.0 * s.sample() },
            })
            .collect();
        for z in [0.9, -1.3] {
            gaussians.push(Gaussian {
                center: [0.1, -0.2, z],
                radius: 0.2,
                weight: 1.0,
            });
        }
        let m = GaussianMedium::new(2.0, 0.8, 0.0, gaussians).unwrap();
        GaussianSet::new(&[&m])
    }

    #[test]
    fn segments_to_the_light_find_what_the_hierarchy_finds() {
        let mut s = Uniform::new(11);
        let set = crowd(&mut s);
        // Lights inside the crowd, inside a Gaussian, right under a pole sphere, outside.
        let lights = [
            [0.1, -0.2, 0.1],
            set.blobs()[3].center,
            [0.3, 0.2, -0.4],
            [5.0, 4.0, 3.0],
        ];
        for light in lights {
            let view = LightView::new(set.blobs(), light);
            for q in 0..400 {
                // Ends everywhere: in the crowd, far out, on the poles' axis, at the light.
                let p = match q % 8 {
                    0 => [light[0], light[1], light[2] + 3.0 * (s.sample() - 0.5)],
                    1 => light,
                    _ => [0, 1, 2].map(|_| s.sample() * 8.0 - 4.0),
                };
                let v = sub(light, p);
                let len = norm(v);
                let d = normalize(v).unwrap_or([1.0, 0.0, 0.0]);
                let skip = (q % 3 == 0).then_some(q % set.blobs().len());
                let mut got = Vec::new();
                view.segment(p, d, len, |i| got.push(i));
                got.sort_unstable();
                let mut want = Vec::new();
                set.on_segment(p, d, len, |i| want.push(i));
                want.sort_unstable();
                assert_eq!(got, want, "light {light:?}, from {p:?}");
                let (t, a) = view.cull_depth(set.blobs(), p, d, len, skip);
                let (t0, a0) = set.cull_depth(p, d, len, skip);
                assert!((t - t0).abs() <= 1e-12 * (1.0 + t0), "{t} vs {t0}");
                assert!((a - a0).abs() <= 1e-12 * (1.0 + a0), "{a} vs {a0}");
            }
        }
    }

    #[test]
    fn bins_cover_the_sphere_of_directions_evenly() {
        // Every direction lands in a bin, and the bins' shares of directions spread
        // uniformly over the sphere are equal: each band of z and sector of φ has the
        // same solid angle (Archimedes), so counts differ by sampling noise only.
        let mut s = Uniform::new(5);
        let mut counts = vec![0usize; ROWS * COLUMNS];
        let n = 400 * ROWS * COLUMNS;
        for _ in 0..n {
            let z = 2.0 * s.sample() - 1.0;
            let phi = 2.0 * PI * s.sample() - PI;
            let h = (1.0 - z * z).max(0.0).sqrt();
            counts[bin([h * phi.cos(), h * phi.sin(), z])] += 1;
        }
        // 400 expected per bin, standard deviation 20: 7 σ either way.
        assert!(
            counts.iter().all(|&c| (260..=540).contains(&c)),
            "{:?}",
            counts.iter().min()
        );
        // The extremes of the direction space map inside the grid.
        for w in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [-1.0, -0.0, 0.0],
            [-1.0, 0.0, 0.0],
        ] {
            assert!(bin(w) < ROWS * COLUMNS);
        }
    }
}
