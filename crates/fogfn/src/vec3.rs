//! Three-vectors of `f64` as arrays.

pub type Vec3 = [f64; 3];

pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn scale(a: Vec3, s: f64) -> Vec3 {
    a.map(|x| x * s)
}

/// `a + s·b`.
pub fn axpy(a: Vec3, s: f64, b: Vec3) -> Vec3 {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm2(a: Vec3) -> f64 {
    dot(a, a)
}

/// `a/|a|`, `None` for a zero or non-finite vector.
pub fn normalize(a: Vec3) -> Option<Vec3> {
    let n = norm2(a).sqrt();
    (n > 0.0 && n.is_finite()).then(|| scale(a, 1.0 / n))
}

/// The part of `a` perpendicular to the unit vector `u`.
pub fn perp(a: Vec3, u: Vec3) -> Vec3 {
    axpy(a, -dot(a, u), u)
}
