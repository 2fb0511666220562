//! The line integral of one Gaussian in closed form (paper B, appendix A, eq. 31).
//!
//! For `f(x) = c·exp(−a²|x − b|²)` along `o + t·d` (unit `d`), `t ∈ [0, L]`: with
//! `b′ = b − o`, `m = b′·d` (the foot of the perpendicular) and `h² = |b′ − m·d|²` (the
//! squared distance of `b` from the line, computed from the vector itself rather than
//! through `sin ξ`, which loses everything near the axis),
//!
//! `∫₀^L f dt = c·e^{−a²h²}·(√π/2a)·[erf(a(L − m)) − erf(−a·m)]`,
//!
//! the difference taken by [`crate::erf::erf_diff`] (exact in the tails and for short
//! segments). `L` may be `+∞`.

use crate::erf::{erf_diff, erf_diff_from, erfc};
use haze_core::vec3::{Vec3, axpy, dot, sub};
use std::f64::consts::PI;

/// Lines farther from the centre than `√FAR` radii count as missing it: they pick up at
/// most `e^{−40} ≈ 4·10⁻¹⁸` of the depth through the centre (the WGSL twin's cut too).
pub const FAR: f64 = 40.0;

/// `∫₀^len c·exp(−a²|o + t·d − b|²) dt` for unit `d` (module docs); 0 for `len ≤ 0` and
/// for lines beyond [`FAR`].
pub fn gaussian(c: f64, a: f64, b: Vec3, o: Vec3, d: Vec3, len: f64) -> f64 {
    if len <= 0.0 {
        return 0.0;
    }
    match foot(c, a, b, o, d, FAR) {
        Some((scale, m, _)) => scale * erf_diff(-a * m, a * (len - m)),
        None => 0.0,
    }
}

/// [`gaussian`] for a caller that drops `δ` of depth, `far` = [`far_for`]`(c, a, δ)`:
/// lines farther than `√far` radii from the centre count as missing it, and an end of a
/// line at `a²h² = q` that lies more than `x = √(far − q)` (in units of `1/a`) from the
/// foot is taken at its tail's limit, `erf(±x) = ±1`: a line with both ends there takes
/// the whole line's depth (ends on either side) or none (one side) with no error
/// function, a line with one end there one `erfc` (of the other end) instead of two. Each
/// end's tail is `scale·erfc(x) < scale·e^{−x²} = δ/2` (as `scale = (c√π/2a)e^{−q}` and
/// `e^{far} = c√π/(aδ)`; when `far` is capped at [`FAR`], at most `e^{−40}` of the depth
/// through the centre), so the line is off by less than `δ`.
pub fn gaussian_within(c: f64, a: f64, b: Vec3, o: Vec3, d: Vec3, len: f64, far: f64) -> f64 {
    if len <= 0.0 {
        return 0.0;
    }
    let Some((m, q)) = foot_of(a, b, o, d, far).filter(|_| c != 0.0) else {
        return 0.0;
    };
    let (x0, x1) = (-a * m, a * (len - m));
    let cut2 = far - q;
    let (beyond0, beyond1) = (x0 * x0 >= cut2, x1 * x1 >= cut2);
    // Both ends on one side of the foot, the nearer past the cut: none of the depth.
    if (x1 <= 0.0 && beyond1) || (x0 >= 0.0 && beyond0) {
        return 0.0;
    }
    // Otherwise an end past the cut lies on its own side of the foot (x0 < 0 < x1).
    let diff = match (beyond0, beyond1) {
        (true, true) => 2.0,
        (false, true) => erfc(x0),
        (true, false) => erfc(-x1),
        (false, false) => erf_diff(x0, x1),
    };
    scale_of(c, a, q) * diff
}

/// The `far` (squared distance in radii, `a²h²`) beyond which a whole line picks up less
/// than `delta` of the Gaussian's depth: `ln(c√π/(a·δ))` (the squared
/// [`negligible_radius`] in radii), at most [`FAR`]; 0 when even the centre line does.
pub fn far_for(c: f64, a: f64, delta: f64) -> f64 {
    (c * PI.sqrt() / (a * delta)).ln().clamp(0.0, FAR)
}

/// The line's ray-constant parts: `c·e^{−a²h²}·√π/2a`, the foot `m` and `q = a²h²`;
/// `None` for a zero Gaussian or a line beyond `√far` radii.
fn foot(c: f64, a: f64, b: Vec3, o: Vec3, d: Vec3, far: f64) -> Option<(f64, f64, f64)> {
    if c == 0.0 {
        return None;
    }
    foot_of(a, b, o, d, far).map(|(m, q)| (scale_of(c, a, q), m, q))
}

/// The foot `m` of `b` on the line `o + t·d` and `q = a²h²`; `None` beyond `√far` radii.
fn foot_of(a: f64, b: Vec3, o: Vec3, d: Vec3, far: f64) -> Option<(f64, f64)> {
    let bp = sub(b, o);
    let m = dot(bp, d);
    let perp = axpy(bp, -m, d);
    let q = a * a * dot(perp, perp);
    // A NaN input stays NaN (the comparison lets it through).
    (q <= far || q.is_nan()).then_some((m, q))
}

/// Half the whole line's depth at `a²h² = q`: `c·e^{−q}·√π/2a`.
fn scale_of(c: f64, a: f64, q: f64) -> f64 {
    c * (-q).exp() * PI.sqrt() / (2.0 * a)
}

/// One Gaussian's depth along a fixed ray `o + t·d` from `0` up to any end `t`:
/// [`gaussian`] with its ray-constant parts — `c·e^{−a²h²}·√π/2a`, the foot `m` and the
/// start's tail `erfc(a·|m|)` — taken once, so each end costs one error function
/// ([`crate::erf::erf_diff_from`]). What an integrated pair asks at every node of a ray.
#[derive(Clone, Copy, Debug, Default)]
pub struct AlongRay {
    /// `c·e^{−a²h²}·√π/2a`; 0 for a line beyond [`FAR`] or a zero Gaussian.
    scale: f64,
    a: f64,
    m: f64,
    tail0: f64,
    /// Past `a(t − m) > cut` the depth is taken whole (`full`), below `−cut` as 0.
    cut: f64,
    /// The whole ray's depth, `scale·erfc(−a·m)`.
    full: f64,
}

impl AlongRay {
    /// The Gaussian `c·exp(−a²|x − b|²)` along `o + t·d` (unit `d`).
    pub fn new(c: f64, a: f64, b: Vec3, o: Vec3, d: Vec3) -> AlongRay {
        AlongRay::cut(c, a, b, o, d, FAR, f64::INFINITY)
    }

    /// [`AlongRay::new`] for a caller that drops `δ` of depth, `far` =
    /// [`far_for`]`(c, a, δ)` (as [`gaussian_within`]): the ray misses the Gaussian beyond
    /// `√far` radii, and an end more than `x = √(far − q − ln 2) = √ln(scale/δ)` of the foot
    /// away, in units of `1/a`, takes the depth whole (past it) or as none (before it), off
    /// by `scale·erfc(x) < scale·e^{−x²} = δ` at most: no error function there.
    pub fn within(c: f64, a: f64, b: Vec3, o: Vec3, d: Vec3, far: f64) -> AlongRay {
        match foot(c, a, b, o, d, far) {
            Some((_, _, q)) => {
                let x = (far - q - std::f64::consts::LN_2).max(0.0).sqrt();
                AlongRay::cut(c, a, b, o, d, far, x)
            }
            None => AlongRay::default(),
        }
    }

    fn cut(c: f64, a: f64, b: Vec3, o: Vec3, d: Vec3, far: f64, cut: f64) -> AlongRay {
        match foot(c, a, b, o, d, far) {
            Some((scale, m, _)) => {
                let tail0 = erfc((a * m).abs());
                // erfc(−a·m): the tail when the foot lies behind the start, 2 − it ahead.
                let whole = if m <= 0.0 { tail0 } else { 2.0 - tail0 };
                AlongRay {
                    scale,
                    a,
                    m,
                    tail0,
                    cut,
                    full: scale * whole,
                }
            }
            None => AlongRay::default(),
        }
    }

    /// `∫₀^len c·exp(−a²|o + t·d − b|²) dt`, as [`gaussian`] gives it (within `δ` for
    /// [`AlongRay::within`]).
    pub fn to(&self, len: f64) -> f64 {
        if len <= 0.0 || self.scale == 0.0 {
            return 0.0;
        }
        let x1 = self.a * (len - self.m);
        if x1 > self.cut {
            return self.full;
        }
        if x1 < -self.cut {
            return 0.0;
        }
        self.scale * erf_diff_from(-self.a * self.m, self.tail0, x1)
    }
}

/// The most a Gaussian of peak `c` and inverse radius `a` can add to the optical depth of
/// a line passing at distance `h` from its centre: `c·√π/a·e^{−a²h²}` (the whole line).
pub fn line_bound(c: f64, a: f64, h: f64) -> f64 {
    c * PI.sqrt() / a * (-a * a * h * h).exp()
}

/// The distance from the centre beyond which a line picks up less than `delta` of the
/// Gaussian's optical depth: `√(ln(c√π/(a·δ)))/a` (0 when even the centre line does).
pub fn negligible_radius(c: f64, a: f64, delta: f64) -> f64 {
    let q = (c * PI.sqrt() / (a * delta)).ln();
    if q > 0.0 { q.sqrt() / a } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_core::vec3::normalize;

    #[test]
    fn lines_beyond_the_cut_drop_less_than_delta() {
        // For Gaussians of line depth 10⁻⁶..10 through the centre and cuts δ = 10⁻¹⁰..10⁻³:
        // a whole line at distance h picks up c√π/a·e^{−a²h²} (line_bound), so beyond
        // √far_for radii the dropped depth is below δ; within it, the ends' tails cut by
        // gaussian_within and AlongRay::within move any segment's depth by at most δ,
        // whichever end lies past the cut (the start, the end, both or neither).
        for &(c, a) in &[(0.01, 2.0), (1.0, 1.0), (5.0, 0.5), (1e-6, 1.0)] {
            for &delta in &[1e-10, 1e-7, 1e-3] {
                let far = far_for(c, a, delta);
                assert!((0.0..=FAR).contains(&far), "{far}");
                for k in 0..40 {
                    let h = 0.2 * k as f64 / a;
                    let o = [-20.0 / a, h, 0.0];
                    let (full, cut) = (
                        gaussian(c, a, [0.0; 3], o, [1.0, 0.0, 0.0], 40.0 / a),
                        gaussian_within(c, a, [0.0; 3], o, [1.0, 0.0, 0.0], 40.0 / a, far),
                    );
                    let along = AlongRay::within(c, a, [0.0; 3], o, [1.0, 0.0, 0.0], far);
                    for &end in &[0.0, 10.0, 19.0, 20.0, 21.0, 22.0, 23.0, 25.0, 30.0, 40.0] {
                        let x = [1.0, 0.0, 0.0];
                        let exact = if a * a * h * h <= far {
                            gaussian(c, a, [0.0; 3], o, x, end / a)
                        } else {
                            0.0
                        };
                        let within = gaussian_within(c, a, [0.0; 3], o, x, end / a, far);
                        let got = along.to(end / a);
                        assert!(
                            (got - exact).abs() <= delta && (within - exact).abs() <= delta,
                            "c {c} a {a} h {h} end {end}: {got}, {within} vs {exact}"
                        );
                    }
                    // Segments from near the foot (start inside the cut) to far past it.
                    for &start in &[-2.0, -0.3, 0.0, 0.7, 3.0] {
                        let o = [start / a, h, 0.0];
                        let x = [1.0, 0.0, 0.0];
                        for &len in &[0.5, 2.0, 4.0, 6.0, 30.0] {
                            let exact = if a * a * h * h <= far {
                                gaussian(c, a, [0.0; 3], o, x, len / a)
                            } else {
                                0.0
                            };
                            let within = gaussian_within(c, a, [0.0; 3], o, x, len / a, far);
                            assert!(
                                (within - exact).abs() <= delta,
                                "c {c} a {a} h {h} from {start} over {len}: {within} vs {exact}"
                            );
                        }
                    }
                    if a * a * h * h <= far {
                        assert!((cut - full).abs() <= delta, "c {c} a {a} h {h}");
                    } else {
                        assert_eq!(cut, 0.0);
                        assert!(full <= delta * (1.0 + 1e-9), "c {c} a {a} h {h}: {full}");
                    }
                }
            }
        }
        // Below δ through the centre: every line is dropped.
        assert_eq!(far_for(1e-9, 1.0, 1e-7), 0.0);
    }

    /// The integral by composite Simpson with a breakpoint at the foot of the
    /// perpendicular (each side smooth; 4000 panels each, error ≪ 1e-12 relative for
    /// `a·L ≤ 50`).
    fn quadrature(c: f64, a: f64, b: Vec3, o: Vec3, d: Vec3, len: f64) -> f64 {
        let f = |t: f64| {
            let x = sub(axpy(o, t, d), b);
            c * (-a * a * dot(x, x)).exp()
        };
        let m = dot(sub(b, o), d).clamp(0.0, len);
        let simpson = |x0: f64, x1: f64| {
            let n = 4000;
            let h = (x1 - x0) / n as f64;
            let mut s = f(x0) + f(x1);
            for i in 1..n {
                s += f(x0 + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
            }
            s * h / 3.0
        };
        simpson(0.0, m) + simpson(m, len)
    }

    #[test]
    fn closed_form_matches_quadrature() {
        let d = normalize([0.3, -0.5, 0.8]).unwrap();
        let o = [0.1, 0.2, -0.3];
        for (c, a, b, len) in [
            (1.0, 1.0, [0.5, 0.0, 0.4], 3.0),
            (2.5, 4.0, [0.0, 0.0, 0.0], 2.0),
            // The centre behind the origin, in front of the end, off to the side.
            (0.7, 2.0, [-0.5, 0.8, -1.0], 1.5),
            (0.7, 2.0, [1.0, -1.0, 3.0], 1.5),
            (0.3, 0.1, [5.0, 1.0, 2.0], 40.0),
            (1.0, 10.0, [0.33, -0.5, 0.52], 1.0),
        ] {
            let want = quadrature(c, a, b, o, d, len);
            let got = gaussian(c, a, b, o, d, len);
            let err = (got - want).abs();
            // Relative 1e-10: the far-off case is a 2e-10 tail, where both lose digits.
            assert!(
                err <= 1e-10 * want,
                "{c} {a} {b:?} {len}: {got:e} vs {want:e}"
            );
        }
    }

    #[test]
    fn along_a_fixed_ray_matches_quadrature_at_every_end() {
        let d = normalize([0.3, -0.5, 0.8]).unwrap();
        let o = [0.1, 0.2, -0.3];
        for (c, a, b) in [
            (1.0, 1.0, [0.5, 0.0, 0.4]),
            (2.5, 4.0, [0.4, -0.4, 0.9]),
            (0.7, 2.0, [-0.5, 0.8, -1.0]),
            (1.0, 10.0, [0.33, -0.5, 0.52]),
        ] {
            let along = AlongRay::new(c, a, b, o, d);
            for len in [0.0, 1e-4, 0.3, 1.0, 1.5, 4.0] {
                let want = if len > 0.0 {
                    quadrature(c, a, b, o, d, len)
                } else {
                    0.0
                };
                let got = along.to(len);
                // Relative 1e-9: the last case's short ends lie 1e-31 deep in the tail,
                // where Simpson's rule itself keeps about 10 digits.
                assert!(
                    (got - want).abs() <= 1e-9 * want + 1e-300,
                    "{c} {a} {b:?} {len}: {got:e} vs {want:e}"
                );
            }
            assert!(
                (along.to(f64::INFINITY) - gaussian(c, a, b, o, d, f64::INFINITY)).abs() < 1e-15
            );
        }
        // Beyond FAR and for a zero Gaussian: nothing, as `gaussian`.
        assert_eq!(
            AlongRay::new(1.0, 10.0, [5.0, 0.0, 0.0], o, d).to(10.0),
            0.0
        );
        assert_eq!(AlongRay::new(0.0, 1.0, o, o, d).to(10.0), 0.0);
    }

    #[test]
    fn infinite_line_and_bounds() {
        // Through the centre, the whole line: c√π/a.
        let g = gaussian(
            2.0,
            3.0,
            [0.0; 3],
            [0.0, 0.0, -100.0],
            [0.0, 0.0, 1.0],
            f64::INFINITY,
        );
        assert!((g - 2.0 * PI.sqrt() / 3.0).abs() < 1e-14);
        assert!((line_bound(2.0, 3.0, 0.0) - g).abs() < 1e-14);
        // Starting at the centre: half of it.
        let half = gaussian(2.0, 3.0, [0.0; 3], [0.0; 3], [1.0, 0.0, 0.0], f64::INFINITY);
        assert!((half - g / 2.0).abs() < 1e-14);
        // Beyond the negligible radius a line picks up less than δ.
        let r = negligible_radius(2.0, 3.0, 1e-10);
        let far = gaussian(
            2.0,
            3.0,
            [0.0, r, 0.0],
            [-50.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            100.0,
        );
        assert!(far <= 1e-10 && far > 0.5e-10, "{far:e}");
        assert_eq!(negligible_radius(1e-12, 1.0, 1e-10), 0.0);
        // Degenerate inputs.
        assert_eq!(
            gaussian(1.0, 1.0, [0.0; 3], [0.0; 3], [1.0, 0.0, 0.0], 0.0),
            0.0
        );
        assert_eq!(
            gaussian(1.0, 1e8, [0.0, 1.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0], 1.0),
            0.0
        );
        // Just inside √FAR radii the line counts (the closed form, against quadrature),
        // just beyond it does not: a step of e⁻⁴⁰ of the centre line's depth.
        let o = [-20.0, 39.9f64.sqrt(), 0.0];
        let near = gaussian(1.0, 1.0, [0.0; 3], o, [1.0, 0.0, 0.0], 40.0);
        let q = quadrature(1.0, 1.0, [0.0; 3], o, [1.0, 0.0, 0.0], 40.0);
        assert!(
            near > 0.0 && (near / q - 1.0).abs() < 1e-8,
            "{near:e} {q:e}"
        );
        let o = [-20.0, 40.1f64.sqrt(), 0.0];
        assert_eq!(gaussian(1.0, 1.0, [0.0; 3], o, [1.0, 0.0, 0.0], 40.0), 0.0);
        assert!(
            gaussian(
                1.0,
                1.0,
                [0.0; 3],
                [0.0, f64::NAN, 0.0],
                [1.0, 0.0, 0.0],
                1.0
            )
            .is_nan()
        );
        // A very wide Gaussian over a short segment: c·L (the short-interval branch).
        let w = gaussian(1.5, 1e-7, [0.0; 3], [0.0; 3], [1.0, 0.0, 0.0], 2.0);
        assert!((w - 3.0).abs() < 1e-12, "{w}");
    }
}
