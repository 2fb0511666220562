//! Three-component `f64` vectors as plain arrays, and the few operations the crates need.

/// A point or direction in world space (Z up).
pub type Vec3 = [f64; 3];

pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a + s·b`.
pub fn axpy(a: Vec3, s: f64, b: Vec3) -> Vec3 {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `|a|²`.
pub fn norm2(a: Vec3) -> f64 {
    dot(a, a)
}

pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|`, or `None` for a zero, infinite or NaN vector.
pub fn normalize(a: Vec3) -> Option<Vec3> {
    let n = norm(a);
    (n > 0.0 && n.is_finite()).then(|| scale(a, 1.0 / n))
}

/// The part of `a` perpendicular to the unit vector `u`.
pub fn perp(a: Vec3, u: Vec3) -> Vec3 {
    axpy(a, -dot(a, u), u)
}

/// A unit vector perpendicular to the unit vector `a` (any one).
pub fn perpendicular(a: Vec3) -> Vec3 {
    let helper = if a[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    normalize(cross(a, helper)).unwrap_or([0.0, 0.0, 1.0])
}

/// The angle between two unit vectors, as `(cos γ, sin γ)` with `sin γ = |a × b| ≥ 0`
/// (never `acos`, which loses all precision near 0 and π).
pub fn cos_sin(a: Vec3, b: Vec3) -> (f64, f64) {
    (dot(a, b), norm(cross(a, b)))
}

/// The mirror image of the unit vector `d` about the unit normal `n`: `2(d·n)n − d`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    axpy(scale(d, -1.0), 2.0 * dot(d, n), n)
}
