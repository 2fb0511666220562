//! Detail noise (paper B §5.5): the view ray used for a Gaussian's `Tᵢ(v, p)` is
//! perturbed by tileable 3D Perlin noise indexed at the centre's projection `bᵢʳ` (plus an
//! animatable offset), scaled by `rᵢ/|v − bᵢ|` and a user gain, the noise vector taken in
//! view space; the integration length `dr` is unchanged.
//!
//! [`Perlin`] is Perlin's improved gradient noise (2002): a seeded permutation of
//! `0..256` (Fisher–Yates driven by SplitMix64), the 12 cube-edge gradients, the quintic
//! fade `6t⁵ − 15t⁴ + 10t³`; it is 0 at lattice points, lies within `[−1, 1]`, and repeats
//! with period 256 in every axis (tileable). A vector of three values reads the same field
//! at three fixed offsets.

use haze_core::vec3::{Vec3, axpy, norm};

/// `a/|a|` by a division per component (not [`haze_core::vec3::normalize`]'s product with
/// `1/|a|`, which rounds differently), `None` for a zero or non-finite vector.
fn normalize(a: Vec3) -> Option<Vec3> {
    let n = norm(a);
    (n > 0.0 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

/// Seeded, tileable 3D gradient noise.
#[derive(Clone, Debug)]
pub struct Perlin {
    perm: [u8; 512],
}

fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// The dot product of the hashed cube-edge gradient with `(x, y, z)`.
fn grad(hash: u8, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

impl Perlin {
    pub fn new(seed: u64) -> Perlin {
        let mut p: [u8; 256] = std::array::from_fn(|i| i as u8);
        let mut s = seed;
        for i in (1..256).rev() {
            let j = (splitmix(&mut s) % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        Perlin {
            perm: std::array::from_fn(|i| p[i & 255]),
        }
    }

    /// The permutation, doubled (`perm[i] = perm[i + 256]`), that hashes the lattice
    /// cells: what a twin of [`Perlin::value`] needs to read the same field.
    pub fn permutation(&self) -> &[u8; 512] {
        &self.perm
    }

    /// The noise at `x` (lattice units).
    pub fn value(&self, x: Vec3) -> f64 {
        let fl = x.map(f64::floor);
        let cell = fl.map(|f| (f.rem_euclid(256.0)) as usize);
        let f = [x[0] - fl[0], x[1] - fl[1], x[2] - fl[2]];
        let (u, v, w) = (fade(f[0]), fade(f[1]), fade(f[2]));
        let p = &self.perm;
        let (xi, yi, zi) = (cell[0], cell[1], cell[2]);
        let a = p[xi] as usize + yi;
        let (aa, ab) = (p[a] as usize + zi, p[a + 1] as usize + zi);
        let b = p[xi + 1] as usize + yi;
        let (ba, bb) = (p[b] as usize + zi, p[b + 1] as usize + zi);
        let (x, y, z) = (f[0], f[1], f[2]);
        lerp(
            w,
            lerp(
                v,
                lerp(u, grad(p[aa], x, y, z), grad(p[ba], x - 1.0, y, z)),
                lerp(
                    u,
                    grad(p[ab], x, y - 1.0, z),
                    grad(p[bb], x - 1.0, y - 1.0, z),
                ),
            ),
            lerp(
                v,
                lerp(
                    u,
                    grad(p[aa + 1], x, y, z - 1.0),
                    grad(p[ba + 1], x - 1.0, y, z - 1.0),
                ),
                lerp(
                    u,
                    grad(p[ab + 1], x, y - 1.0, z - 1.0),
                    grad(p[bb + 1], x - 1.0, y - 1.0, z - 1.0),
                ),
            ),
        )
    }

    /// The offsets of [`Perlin::vector`]'s three lookups.
    pub const VECTOR_OFFSETS: [Vec3; 3] =
        [[0.0; 3], [31.416, 47.853, 12.793], [73.156, 5.412, 91.737]];

    /// Three values of the field at fixed offsets: a noise vector.
    pub fn vector(&self, x: Vec3) -> Vec3 {
        Perlin::VECTOR_OFFSETS.map(|o| self.value([x[0] + o[0], x[1] + o[1], x[2] + o[2]]))
    }
}

/// The scene file's noise settings and their noise.
#[derive(Clone, Debug)]
pub struct Noise {
    pub perlin: Perlin,
    /// Strength of the perturbation (the paper's user scale).
    pub gain: f64,
    /// Lattice cells per world unit.
    pub frequency: f64,
    /// Added to the lookup point (world units; animate it to make the noise drift).
    pub offset: Vec3,
}

impl Noise {
    /// The perturbed view direction for Gaussian `i` of radius `radius` at distance
    /// `dist` from the eye, the noise looked up at `br` and taken in the view frame
    /// `(right, up, forward)` (module docs); the direction itself when the perturbed one
    /// degenerates.
    pub fn perturb(&self, dir: Vec3, br: Vec3, radius: f64, dist: f64, frame: [Vec3; 3]) -> Vec3 {
        if self.gain == 0.0 || dist <= 0.0 {
            return dir;
        }
        let q = [0, 1, 2].map(|k| (br[k] + self.offset[k]) * self.frequency);
        let n = self.perlin.vector(q);
        let s = self.gain * radius / dist;
        let mut d = dir;
        for k in 0..3 {
            d = axpy(d, s * n[k], frame[k]);
        }
        normalize(d).unwrap_or(dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perlin_is_seeded_bounded_tileable_and_zero_on_the_lattice() {
        let (a, b) = (Perlin::new(1), Perlin::new(2));
        let mut differ = 0;
        let mut max: f64 = 0.0;
        for i in 0..2000 {
            let t = i as f64 * 0.137;
            let x = [t.sin() * 9.3, t * 0.71, (t * 1.3).cos() * 5.1 - 2.0];
            let va = a.value(x);
            assert_eq!(va, Perlin::new(1).value(x));
            max = max.max(va.abs());
            if (va - b.value(x)).abs() > 1e-6 {
                differ += 1;
            }
            // Period 256 in every axis.
            let shifted = a.value([x[0] + 256.0, x[1] - 512.0, x[2] + 256.0]);
            assert!((va - shifted).abs() < 1e-9, "{va} {shifted}");
            let l = x.map(f64::round);
            assert!(a.value(l).abs() < 1e-12);
        }
        assert!(max <= 1.0 && max > 0.3, "{max}");
        assert!(differ > 1500, "{differ}");
        // Continuity: neighbouring points differ little (the gradient is bounded).
        let x = [1.3, 2.7, -0.4];
        assert!((a.value(x) - a.value([1.3 + 1e-6, 2.7, -0.4])).abs() < 1e-5);
    }

    #[test]
    fn perturbation_scales_with_gain_and_distance() {
        let n = |gain| Noise {
            perlin: Perlin::new(5),
            gain,
            frequency: 2.0,
            offset: [0.0; 3],
        };
        let frame = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]];
        let dir = [0.0, 1.0, 0.0];
        let br = [0.3, 1.1, 0.77];
        assert_eq!(n(0.0).perturb(dir, br, 0.5, 4.0, frame), dir);
        let small = n(0.1).perturb(dir, br, 0.5, 4.0, frame);
        let large = n(0.1).perturb(dir, br, 0.5, 1.0, frame);
        let angle = |d: Vec3| (d[0] * d[0] + d[2] * d[2]).sqrt().atan2(d[1]);
        // Closer Gaussians (larger r/|v − b|) are perturbed more; the result is unit.
        assert!(angle(large) > 3.0 * angle(small) && angle(small) > 0.0);
        for d in [small, large] {
            assert!(((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 1.0).abs() < 1e-12);
        }
    }
}
