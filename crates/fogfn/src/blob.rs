//! Equipotential ("blob") functions (paper D §3.2.3, eq. 9): `γ(x) = 1/(c + d r²)` around a
//! virtual point, line or sphere, `c > 0`, `d ≥ 0`; added or subtracted by the sign of the
//! term's weight.
//!
//! The paper's `r` is "the distance between the segment OP and the virtual object", which
//! makes the ray's contribution a function of the whole segment, not the integral of a
//! density. We take the density reading instead — `r` the distance from the point `x` to
//! the object — so that blobs add to the other families as extinction and their line
//! integral is exact:
//! - point `p`: `r² = |x − p|²`; along `o + t w` (unit `w`), with `e = o − p`,
//!   `r² = t² + 2(e·w)t + |e|²`;
//! - line through `p` along the unit `ℓ`: `r² = |e⊥ + t w⊥|²`, `⊥` the parts
//!   perpendicular to `ℓ`: `A t² + 2B t + |e⊥|²` with `A = |w⊥|²`, `B = w⊥·e⊥`; a ray
//!   parallel to the line (`A = 0`) sees the constant `1/(c + d|e⊥|²)`;
//! - sphere of center `b`, radius `R`: the power distance `r² = max(0, |x − b|² − R²)` (the
//!   paper gives no integral for a sphere, and `(|x − b| − R)²` has no elementary one):
//!   `1/c` inside, outside the point's form with `c → c − dR²`; the ray is split where it
//!   crosses the sphere.
//!
//! Each piece is `(1/d)·∫ dt/(A t² + 2B t + C′ + c/d)` ([`crate::quadratic::inv_quadratic`])
//! with the discriminant `A(C′ + c/d) − B² = A c/d + |w⊥ × e⊥|²` (Lagrange's identity)
//! computed as that sum, never as a difference: positive for points and lines (`c > 0`), so
//! a ray through the center (`h = 0`) is regular.

use crate::quadratic::inv_quadratic;
use crate::vec3::{Vec3, cross, dot, norm2, perp, sub};

#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Point { center: Vec3 },
    Line { point: Vec3, direction: Vec3 },
    Sphere { center: Vec3, radius: f64 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Blob {
    pub shape: Shape,
    pub c: f64,
    pub d: f64,
}

impl Blob {
    /// `r²` of the point `x` (module docs).
    pub fn r2(&self, x: Vec3) -> f64 {
        match self.shape {
            Shape::Point { center } => norm2(sub(x, center)),
            Shape::Line { point, direction } => norm2(perp(sub(x, point), direction)),
            Shape::Sphere { center, radius } => (norm2(sub(x, center)) - radius * radius).max(0.0),
        }
    }

    pub fn value(&self, x: Vec3) -> f64 {
        1.0 / (self.c + self.d * self.r2(x))
    }

    /// `∫₀^len γ(o + t w) dt` (module docs).
    pub fn integral(&self, o: Vec3, w: Vec3, len: f64) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        let (c, d) = (self.c, self.d);
        if d == 0.0 {
            return len / c;
        }
        match self.shape {
            Shape::Point { center } => {
                let e = sub(o, center);
                let disc = c / d + norm2(cross(w, e));
                inv_quadratic(1.0, dot(e, w), disc, 0.0, len) / d
            }
            Shape::Line { point, direction } => {
                let (e, wp) = (perp(sub(o, point), direction), perp(w, direction));
                let a = norm2(wp);
                if a == 0.0 {
                    return len / (c + d * norm2(e));
                }
                let disc = a * c / d + norm2(cross(wp, e));
                inv_quadratic(a, dot(wp, e), disc, 0.0, len) / d
            }
            Shape::Sphere { center, radius } => {
                let e = sub(o, center);
                let b = dot(e, w);
                let h2 = norm2(cross(w, e));
                let r2 = radius * radius;
                let disc = (c - d * r2) / d + h2;
                let outside = |t0: f64, t1: f64| inv_quadratic(1.0, b, disc, t0, t1) / d;
                let chord2 = r2 - h2;
                if chord2 <= 0.0 {
                    return outside(0.0, len);
                }
                // The crossings t = −b ± √(R² − h²).
                let (t_in, t_out) = (-b - chord2.sqrt(), -b + chord2.sqrt());
                let (i0, i1) = (t_in.clamp(0.0, len), t_out.clamp(0.0, len));
                outside(0.0, i0) + (i1 - i0) / c + outside(i1, len)
            }
        }
    }

    /// `γ ∈ (0, 1/c]`.
    pub fn max_value(&self) -> f64 {
        1.0 / self.c
    }
}
