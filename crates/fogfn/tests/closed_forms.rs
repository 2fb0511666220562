//! Every closed-form line integral of paper D's families against adaptive Gauss–Kronrod
//! quadrature of the same fog's density, to ≤ 10⁻⁶ relative (f64): random rays, rays
//! parallel to a function's axis or wave fronts, very long rays (10⁴), zero-length rays,
//! rays through and grazing blobs, and the same under wind at a later time.
//!
//! **Quadrature.** The ray is cut at every kink of the integrand — polynomial cell
//! borders, sphere crossings — and at the closest approach to each blob, then into pieces
//! no longer than a quarter of the shortest wavelength or cell; each piece is integrated by
//! adaptive Gauss–Kronrod 7/15 to 10⁻¹¹ of each piece. The closed forms are exact to
//! ~10⁻¹⁴ and the quadrature reaches ~10⁻¹¹, so 10⁻⁶ leaves room for the long rays'
//! rounding (10⁴ pieces) with a margin of 10⁴ and fails on any real error. A signed term's
//! error is taken relative to `∫|w γ|`, which equals the integral for positive terms.

use haze_fogfn::blob::Shape;
use haze_fogfn::vec3::{Vec3, axpy, dot, norm2, normalize, sub};
use haze_fogfn::{Family, Fog, spec};
use serde_json::json;

const GK_X: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const GK_WK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_2,
    0.140_653_259_715_525_9,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_728,
];
const G_W: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// Adaptive Gauss–Kronrod 7/15 of `f` on `[a, b]` to the absolute error `tol` or 10⁻¹³
/// of the piece's own value, whichever is larger (the phases of a long ray carry rounding
/// noise of ~10⁻¹¹ at 10⁴ from the origin).
fn gk(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64, depth: u32) -> f64 {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut k = GK_WK[7] * f(c);
    let mut g = G_W[3] * f(c);
    for i in 0..7 {
        let (fl, fr) = (f(c - h * GK_X[i]), f(c + h * GK_X[i]));
        k += GK_WK[i] * (fl + fr);
        if i % 2 == 1 {
            g += G_W[i / 2] * (fl + fr);
        }
    }
    let (k, g) = (k * h, g * h);
    if (k - g).abs() <= tol.max(1e-11 * k.abs()) || depth > 20 {
        k
    } else {
        gk(f, a, c, 0.5 * tol, depth + 1) + gk(f, c, b, 0.5 * tol, depth + 1)
    }
}

/// Where the integrand of `fog` along the ray may kink, and the longest smooth piece.
fn breaks(fog: &Fog, o: Vec3, w: Vec3, len: f64, t: f64) -> (Vec<f64>, f64) {
    let mut cuts = vec![0.0, len];
    let mut piece = len.max(1e-300);
    for term in &fog.terms {
        let oo = fog.shifted(term, o, t);
        match &term.family {
            Family::Cosine(c) => {
                for wave in &c.waves {
                    let k = norm2(wave.q).sqrt();
                    if k > 0.0 {
                        piece = piece.min(0.25 * std::f64::consts::TAU / k);
                    }
                }
            }
            Family::Polynomial(p) => {
                piece = piece.min(0.5 * p.half);
                let s0 = p.coords(oo);
                for (j, a) in p.axes.iter().enumerate() {
                    let ds = dot(*a, w);
                    if ds == 0.0 {
                        continue;
                    }
                    let s1 = s0[j] + ds * len;
                    let (lo, hi) = (s0[j].min(s1), s0[j].max(s1));
                    let mut m = ((lo + p.half) / (2.0 * p.half)).floor();
                    loop {
                        let border = m * 2.0 * p.half - p.half;
                        if border > hi {
                            break;
                        }
                        if border >= lo {
                            cuts.push((border - s0[j]) / ds);
                        }
                        m += 1.0;
                    }
                }
            }
            Family::Blob(b) => {
                let (center, radius) = match b.shape {
                    Shape::Point { center } => (center, 0.0),
                    Shape::Line { point, .. } => (point, 0.0),
                    Shape::Sphere { center, radius } => (center, radius),
                };
                let e = sub(oo, center);
                let tc = -dot(e, w);
                cuts.push(tc);
                let h2 = norm2(e) - tc * tc;
                if radius * radius > h2 {
                    let s = (radius * radius - h2).sqrt();
                    cuts.extend([tc - s, tc + s]);
                }
                // The blob's width: 1/(c + d r²) halves at r = √(c/d).
                piece = piece.min((b.c / b.d.max(1e-300)).sqrt().max(1e-3));
            }
            Family::Height(h) => {
                if h.falloff != 0.0 {
                    piece = piece.min(1.0 / h.falloff.abs());
                }
            }
            Family::Constant => {}
        }
    }
    cuts.retain(|&c| (0.0..=len).contains(&c));
    cuts.sort_by(f64::total_cmp);
    (cuts, piece)
}

/// `(∫ K, ∫ |K|)` along the ray by quadrature.
fn quadrature(fog: &Fog, o: Vec3, w: Vec3, len: f64, t: f64) -> (f64, f64) {
    let (cuts, piece) = breaks(fog, o, w, len, t);
    let f = |s: f64| fog.density(axpy(o, s, w), t);
    let g = |s: f64| f(s).abs();
    // A non-negative fog is its own absolute value (and |K| has kinks to resolve).
    let signed = fog.lower_bound() < 0.0;
    let (mut total, mut abs) = (0.0, 0.0);
    for pair in cuts.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if b <= a {
            continue;
        }
        let n = ((b - a) / piece).ceil().max(1.0) as usize;
        let h = (b - a) / n as f64;
        for i in 0..n {
            let (x0, x1) = (a + i as f64 * h, a + (i + 1) as f64 * h);
            total += gk(&f, x0, x1, 1e-11 * h, 0);
            if signed {
                abs += gk(&g, x0, x1, 1e-11 * h, 0);
            }
        }
    }
    (total, if signed { abs } else { total })
}

fn unit(v: Vec3) -> Vec3 {
    normalize(v).unwrap()
}

/// Checks `fog` along each ray at each time; returns the worst relative error.
fn check(name: &str, fog: &Fog, rays: &[(Vec3, Vec3, f64)], times: &[f64]) -> f64 {
    let mut worst: f64 = 0.0;
    for &t in times {
        for &(o, w, len) in rays {
            let w = unit(w);
            let got = fog.optical_depth(o, w, len, t);
            let (want, abs) = quadrature(fog, o, w, len, t);
            if abs == 0.0 {
                assert_eq!(got, 0.0, "{name}: {o:?} {w:?} {len} t {t}");
                continue;
            }
            let rel = (got - want).abs() / abs;
            assert!(
                rel <= 1e-6,
                "{name}: ray {o:?} {w:?} len {len} t {t}: closed form {got}, quadrature {want} (rel {rel:.2e})"
            );
            worst = worst.max(rel);
        }
    }
    println!("{name}: worst relative error {worst:.2e}");
    worst
}

fn fog(wind: Vec3, terms: serde_json::Value) -> Fog {
    spec::fog(wind, terms.as_array().unwrap()).unwrap()
}

/// Generic rays plus the given special ones.
fn rays(special: &[(Vec3, Vec3, f64)]) -> Vec<(Vec3, Vec3, f64)> {
    let mut r = vec![
        ([0.3, -2.0, 0.5], [0.2, 1.0, 0.1], 6.0),
        ([-1.0, 0.7, 2.0], [0.6, -0.3, -0.7], 3.5),
        ([4.0, 4.0, -1.0], [-1.0, -0.9, 0.4], 11.0),
        ([0.0, 0.0, 0.0], [1.0, 2.0, 3.0], 0.0),
        ([1.0, 2.0, 3.0], [0.0, 0.0, 1.0], 1e-9),
    ];
    r.extend_from_slice(special);
    r
}

const TIMES: [f64; 2] = [0.0, 2.7];
const WIND: Vec3 = [0.8, -0.3, 0.1];

#[test]
fn cosines_and_their_products() {
    let f = fog(
        WIND,
        json!([
            {"type": "constant", "weight": 1.0},
            {"type": "cosine", "weight": 0.5, "k": 15.707963, "direction": [0, 1, 0], "phase": 0.3, "omega": 0.7},
            {"type": "cosine", "weight": -0.2, "k": 21.991148, "direction": [0.1, 1, 0]},
            {"type": "cosine_product", "weight": 0.1, "k": [3.0, 1.5], "directions": [[1, 0, 0], [0, 0, 1]], "phase": [0.2, -0.4], "wind": false}
        ]),
    );
    let rays = rays(&[
        // Parallel to the first wave's fronts (δ = 0) and along its axis.
        ([0.0, 0.2, 0.0], [1.0, 0.0, 0.0], 7.0),
        ([0.0, 0.2, 0.0], [0.0, 1.0, 0.0], 5.0),
        // Very long.
        ([0.5, -3.0, 1.0], [0.3, 0.9, 0.2], 1e4),
        ([0.5, -3.0, 1.0], [0.0, 0.0, 1.0], 1e4),
    ]);
    check("cosines", &f, &rays, &TIMES);
    // Each signed term alone (no constant), relative to ∫|γ|.
    for i in 1..f.terms.len() {
        let single = Fog {
            terms: vec![f.terms[i].clone()],
            wind: WIND,
        };
        // The signed terms' |γ| kinks at every zero: the long rays are left to the sum.
        check(&format!("cosine term {i}"), &single, &rays[..7], &TIMES);
    }
}

#[test]
fn polynomials_periodic_and_clipped_in_one_to_three_axes() {
    // Paper D Fig. 7's 1D polynomial 0.8 − x + x⁴ (continuous at ±C needs an even part
    // only at the borders: here P(−C) ≠ P(C), which the closed form must follow too).
    let one = json!({"type": "polynomial", "weight": 1.0, "axes": [[1, 0, 0]], "center": [0.3, 0, 0], "half_width": 1.0,
        "coefficients": [0.8, -1.0, 0.0, 0.0, 1.0]});
    let two = json!({"type": "polynomial", "weight": 0.7, "axes": [[1, 0, 0], [0, 0, 1]], "half_width": 0.8,
        "monomials": [[1.0, 0, 0], [0.5, 1, 1], [-0.3, 2, 0], [0.2, 0, 3]]});
    let three = json!({"type": "polynomial", "weight": 0.4, "axes": [[1, 0, 0], [0, 1, 0], [0.3, 0.3, 1]], "half_width": 1.5,
        "outside": "zero", "monomials": [[1.0, 0, 0, 0], [0.1, 1, 1, 1], [-0.2, 0, 2, 0], [0.05, 2, 0, 3]]});
    let three_periodic = {
        let mut v = three.clone();
        v["outside"] = json!("periodic");
        v
    };
    let one_zero = {
        let mut v = one.clone();
        v["outside"] = json!("zero");
        v
    };
    let special = [
        // Perpendicular to the x axis (s constant), nearly so (within one cell: the walk).
        ([0.1, -2.0, 0.3], [0.0, 1.0, 0.0], 9.0),
        ([0.1, -2.0, 0.3], [1e-7, 1.0, 0.0], 9.0),
        ([0.1, -2.0, 0.3], [0.05, 1.0, 0.0], 9.0),
        // Along the axis, very long (Φ in O(1)).
        ([0.1, 0.0, 0.0], [1.0, 0.0, 0.0], 1e4),
        ([0.1, 0.0, 0.0], [-1.0, 0.0, 0.0], 1e4),
        // Starting exactly on a border.
        ([1.3, 0.0, 0.0], [1.0, 0.5, 0.0], 4.0),
    ];
    let long = [([0.2, 0.1, -0.3], [0.4, 0.5, 0.6], 300.0)];
    for (name, term, extra) in [
        ("polynomial 1D periodic", one.clone(), &special[..]),
        ("polynomial 1D zero outside", one_zero, &special[..3]),
        ("polynomial 2D periodic", two, &long[..]),
        ("polynomial 3D zero outside", three, &special[..3]),
        ("polynomial 3D periodic", three_periodic, &long[..]),
    ] {
        let f = fog(WIND, json!([{"type": "constant", "weight": 3.0}, term]));
        let single = Fog {
            terms: vec![f.terms[1].clone()],
            wind: WIND,
        };
        check(name, &single, &rays(extra), &TIMES);
    }
}

#[test]
fn blobs_through_grazing_and_far() {
    let f = fog(
        WIND,
        json!([
            {"type": "blob", "weight": 2.0, "shape": "point", "center": [1, 2, 0.5], "c": 0.5, "d": 4.0},
            {"type": "blob", "weight": -0.3, "shape": "point", "center": [1.2, 2, 0.5], "c": 2.0, "d": 1.0},
            {"type": "blob", "weight": 1.0, "shape": "line", "center": [0, 0, 1], "direction": [0, 1, 0.2], "c": 0.3, "d": 2.0},
            {"type": "blob", "weight": 1.5, "shape": "sphere", "center": [-1, 1, 0], "radius": 0.8, "c": 0.4, "d": 3.0, "wind": false},
            {"type": "constant", "weight": 0.15}
        ]),
    );
    let [a, b, c, d] = [0, 1, 2, 3].map(|i| Fog {
        terms: vec![f.terms[i].clone()],
        wind: WIND,
    });
    let shift = |p: Vec3, t: f64| axpy(p, t, WIND);
    for t in TIMES {
        // Point blob: through the center (h = 0), from the center, far and long.
        let p = shift([1.0, 2.0, 0.5], t);
        check(
            "point blob",
            &a,
            &rays(&[
                (sub(p, [3.0, 0.0, 0.0]), [1.0, 0.0, 0.0], 6.0),
                (p, [0.0, 0.0, 1.0], 2.0),
                (sub(p, [0.0, 500.0, 0.0]), [0.0, 1.0, 0.01], 1e4),
                (sub(p, [0.0, 5.0, 1e-6]), [0.0, 1.0, 0.0], 10.0),
            ]),
            &[t],
        );
        check("negative point blob", &b, &rays(&[]), &[t]);
        // Line blob: a ray parallel to the line (A = 0), nearly parallel, crossing it.
        let q = shift([0.0, 0.0, 1.0], t);
        let l = unit([0.0, 1.0, 0.2]);
        check(
            "line blob",
            &c,
            &rays(&[
                (axpy(q, 0.5, [1.0, 0.0, 0.0]), l, 20.0),
                (axpy(q, 0.5, [1.0, 0.0, 0.0]), [1e-6, l[1], l[2]], 1e4),
                (sub(q, [2.0, 0.0, 0.0]), [1.0, 0.0, 0.0], 4.0),
                (sub(q, [2.0, 0.0, 0.0]), [1.0, 0.0, 0.0], 1e4),
            ]),
            &[t],
        );
    }
    // Sphere blob (still): crossing through the center, off-center, tangent (grazing),
    // passing just outside, starting inside, long.
    let s = [-1.0, 1.0, 0.0];
    check(
        "sphere blob",
        &d,
        &rays(&[
            (sub(s, [3.0, 0.0, 0.0]), [1.0, 0.0, 0.0], 6.0),
            (sub(s, [3.0, 0.0, -0.5]), [1.0, 0.0, 0.0], 6.0),
            (sub(s, [3.0, 0.0, -0.8]), [1.0, 0.0, 0.0], 6.0),
            (sub(s, [3.0, 0.0, -0.80001]), [1.0, 0.0, 0.0], 6.0),
            (s, [0.3, 0.4, 0.5], 5.0),
            (sub(s, [0.0, 1e3, 0.1]), [0.0, 1.0, 0.0], 1e4),
        ]),
        &TIMES,
    );
    check("blobs together", &f, &rays(&[]), &TIMES);
}

#[test]
fn height_falloff_in_every_direction() {
    let f = fog(
        WIND,
        json!([{"type": "height", "weight": 0.6, "falloff": 1.5, "normal": [0, 0.1, 1], "base": 0.2}]),
    );
    check(
        "height",
        &f,
        &rays(&[
            // Horizontal (n·w = 0), straight up, straight down, long down and far above.
            ([0.0, 0.0, 1.0], [1.0, -0.1, 0.0], 8.0),
            ([0.0, 0.0, -1.0], [0.0, 0.1, 1.0], 1e4),
            ([0.0, 0.0, 3.0], [0.0, 0.0, -1.0], 5.0),
            ([0.0, 0.0, 300.0], [0.0, 0.0, -1.0], 310.0),
            ([0.0, 0.0, 500.0], [1.0, 0.0, 0.0], 1e4),
        ]),
        &TIMES,
    );
}

#[test]
fn paper_d_fig6_fog_under_wind() {
    // Fig. 6: K = 1 ± ½cos(5πy) ± ⅕cos(7π(y ± 0.1x)) ± ⅕cos(5π(y ± 0.05x))
    // ± ⅒cos(πx)cos(πz/2) (signs lost in the text: these are one choice).
    let pi = std::f64::consts::PI;
    let f = fog(
        WIND,
        json!([
            {"type": "constant", "weight": 1.0},
            {"type": "cosine", "weight": 0.5, "k": 5.0 * pi, "direction": [0, 1, 0]},
            {"type": "cosine", "weight": -0.2, "k": 7.0 * pi * (1.01f64).sqrt(), "direction": [0.1, 1, 0]},
            {"type": "cosine", "weight": 0.2, "k": 5.0 * pi * (1.0025f64).sqrt(), "direction": [-0.05, 1, 0]},
            {"type": "cosine_product", "weight": 0.1, "k": [pi, 0.5 * pi], "directions": [[1, 0, 0], [0, 0, 1]]}
        ]),
    );
    assert!(f.lower_bound() >= -1e-12);
    check(
        "Fig. 6 fog",
        &f,
        &rays(&[([0.0, -5.0, 1.0], [0.1, 1.0, 0.0], 1e3)]),
        &[0.0, 1.0, 40.0],
    );
}

#[test]
fn wind_carries_each_family() {
    let f = fog(
        WIND,
        json!([
            {"type": "constant", "weight": 2.0},
            {"type": "cosine", "weight": 0.5, "k": 3.0, "direction": [1, 1, 0]},
            {"type": "polynomial", "axes": [[0, 0, 1]], "half_width": 1.0, "coefficients": [1.0, 0.3, -0.2]},
            {"type": "blob", "shape": "point", "center": [1, 0, 0], "c": 1.0, "d": 2.0},
            {"type": "height", "weight": 0.2, "falloff": 0.5}
        ]),
    );
    // The field at time t is the field at 0 moved by v·t: K(x + vt, t) = K(x, 0), and the
    // integral along a ray moved by vt equals the integral along the ray at time 0.
    let (x, t) = ([0.3, -0.2, 0.7], 3.3);
    let moved = axpy(x, t, WIND);
    assert!((f.density(moved, t) - f.density(x, 0.0)).abs() < 1e-12);
    let w = unit([0.3, 0.2, -0.5]);
    let a = f.optical_depth(moved, w, 4.0, t);
    let b = f.optical_depth(x, w, 4.0, 0.0);
    assert!((a - b).abs() < 1e-12 * b, "{a} vs {b}");
    // And the field does move: at a fixed point it changes with time.
    assert!((f.density(x, t) - f.density(x, 0.0)).abs() > 1e-3);
}

#[test]
fn bad_terms_are_refused_by_name() {
    let cases = [
        (
            json!([{"type": "cosine", "k": 1.0, "direction": [1, 0, 0], "amplitude": 2}]),
            "unknown field `amplitude`",
        ),
        (
            json!([{"type": "cosine", "k": 1.0, "direction": [0, 0, 0]}]),
            "terms[0]: direction must not be zero",
        ),
        (
            json!([{"type": "constant", "weight": 0.5}, {"type": "cosine", "weight": 0.6, "k": 1, "direction": [1, 0, 0]}]),
            "negative extinction",
        ),
        (
            json!([{"type": "blob", "shape": "point", "center": [0, 0, 0], "c": 0, "d": 1}]),
            "terms[0]: c = 0 must be positive",
        ),
        (
            json!([{"type": "blob", "shape": "torus", "center": [0, 0, 0], "c": 1, "d": 1}]),
            "unknown blob shape \"torus\"",
        ),
        (
            json!([{"type": "polynomial", "axes": [[1, 0, 0]], "half_width": 1, "coefficients": [0.5, -1]}]),
            "negative extinction",
        ),
        (
            json!([{"type": "polynomial", "axes": [[1, 0, 0], [0, 1, 0]], "half_width": 1, "monomials": [[1, 10, 0]]}]),
            "power 10",
        ),
        (
            json!([{"type": "fractal"}]),
            "unknown term type \"fractal\"",
        ),
        (
            json!([{"type": "height", "weight": -1, "falloff": 1}]),
            "must not be negative",
        ),
    ];
    for (terms, want) in cases {
        let e = spec::fog([0.0; 3], terms.as_array().unwrap()).unwrap_err();
        assert!(e.contains(want), "{e} lacks {want}");
        assert!(!e.contains('\n'));
    }
    // 0.8 − x + x⁴ on [−1, 1] has its minimum 0.8 − 0.75·0.63 > 0: accepted.
    let ok = json!([{"type": "polynomial", "axes": [[1, 0, 0]], "half_width": 1, "coefficients": [0.8, -1, 0, 0, 1]}]);
    assert!(spec::fog([0.0; 3], ok.as_array().unwrap()).is_ok());
}

#[test]
fn polynomial_lower_bound_is_a_bound_and_tight() {
    let f = fog(
        [0.0; 3],
        json!([{"type": "constant"}, {"type": "polynomial", "axes": [[1, 0, 0], [0, 1, 0]], "half_width": 1.2,
            "monomials": [[1.0, 0, 0], [-0.4, 1, 1], [0.3, 3, 0], [-0.2, 0, 2]]}]),
    );
    let Family::Polynomial(p) = &f.terms[1].family else {
        unreachable!()
    };
    let lb = p.lower_bound();
    // Brute force on a 2001² grid.
    let mut least = f64::INFINITY;
    for i in 0..=2000 {
        for j in 0..=2000 {
            let s = [
                -1.2 + 2.4 * i as f64 / 2000.0,
                -1.2 + 2.4 * j as f64 / 2000.0,
                0.0,
            ];
            least = least.min(p.eval(s));
        }
    }
    assert!(lb <= least && least - lb < 0.05, "{lb} vs {least}");
}

/// `Fog::feature_size` (the march's step) against each family's length read off its
/// parameters by hand: a wave's 1/|k|, a polynomial's half width over its degree, a
/// blob's √(c/d), a height layer's 1/b; a constant has none, a zero weight counts not.
#[test]
fn feature_sizes_are_the_families_lengths() {
    let one = |term: serde_json::Value| {
        fog([0.0; 3], json!([{"type": "constant", "weight": 5.0}, term])).feature_size()
    };
    assert!(
        fog([0.0; 3], json!([{"type": "constant", "weight": 1.0}]))
            .feature_size()
            .is_infinite()
    );
    let cases = [
        (
            json!({"type": "cosine", "weight": 0.5, "k": 2.5, "direction": [0, 3, 4]}),
            0.4,
        ),
        (
            json!({"type": "polynomial", "axes": [[1, 0, 0]], "half_width": 3.0, "coefficients": [1.0, 0.0, -0.1]}),
            1.5,
        ),
        (
            json!({"type": "blob", "weight": 1.0, "shape": "point", "center": [0, 0, 0], "c": 0.5, "d": 2.0}),
            0.5,
        ),
        (
            json!({"type": "height", "weight": 1.0, "falloff": 4.0, "base": 0.0}),
            0.25,
        ),
        (
            json!({"type": "blob", "weight": 0.0, "shape": "point", "center": [0, 0, 0], "c": 0.5, "d": 2.0}),
            f64::INFINITY,
        ),
    ];
    for (term, want) in cases {
        let got = one(term.clone());
        assert!(
            got == want || (got - want).abs() < 1e-12 * want,
            "{term}: {got} vs {want}"
        );
    }
}
