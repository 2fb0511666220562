//! Ray integrals against an independent computation: the fog evaluated pointwise from
//! its coefficients with the truncated-power form of the B-splines, integrated by
//! Gauss–Legendre quadrature between the points where the ray crosses grid lines (inside
//! each piece the integrand is a polynomial of degree ≤ 4 times `e^{−kz}`, which 8 nodes
//! integrate to rounding for the small exponents used here).

use haze_wavelet::lod::{Fog, FogError, Mode, Settings};
use haze_wavelet::{Basis, Decomposition, Grid, Placement};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// `B_d(x)`, right-continuous, by truncated powers.
fn bspline(d: usize, x: f64) -> f64 {
    if !(0.0..(d + 1) as f64).contains(&x) {
        return 0.0;
    }
    let fact = [1.0, 1.0, 2.0][d];
    let mut sum = 0.0;
    let mut binom = 1.0;
    for k in 0..=d + 1 {
        let t = x - k as f64;
        if t >= 0.0 {
            sum += if k % 2 == 0 { 1.0 } else { -1.0 } * binom * t.powi(d as i32);
        }
        binom = binom * (d + 1 - k) as f64 / (k + 1) as f64;
    }
    sum / fact
}

/// The spline of `g` (on a grid whose cells are `scale` finest cells) at finest `(u, v)`.
fn spline(g: &Grid, d: usize, scale: f64, u: f64, v: f64) -> f64 {
    let (y, x) = (v / scale, u / scale);
    let mut sum = 0.0;
    for j in (y.floor() as i64 - d as i64)..=y.floor() as i64 {
        for i in (x.floor() as i64 - d as i64)..=x.floor() as i64 {
            let c = g.get(i, j);
            if c != 0.0 {
                sum += c * bspline(d, x - i as f64) * bspline(d, y - j as f64);
            }
        }
    }
    sum
}

const GL_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// `∫ K_t` from `o` over `[t0, t1]` along unit `dir` of the spline `g`, the integrand
/// split at every finest grid line, every slab boundary and the extra `cuts`.
fn quadrature(
    g: &Grid,
    d: usize,
    scale: f64,
    p: &Placement,
    (o, dir): ([f64; 3], [f64; 3]),
    (t0, t1): (f64, f64),
) -> f64 {
    if t1 <= t0 {
        return 0.0;
    }
    let mut cuts = vec![t0, t1];
    let shift = d as f64 / 2.0;
    for axis in 0..2 {
        if dir[axis] == 0.0 {
            continue;
        }
        let at = |t: f64| (o[axis] + t * dir[axis] - p.origin[axis]) / p.cell + shift;
        let (a, b) = (at(t0), at(t1));
        let (lo, hi) = (a.min(b).floor() as i64, a.max(b).ceil() as i64);
        for k in lo..=hi {
            let t = ((k as f64 - shift) * p.cell + p.origin[axis] - o[axis]) / dir[axis];
            if t > t0 && t < t1 {
                cuts.push(t);
            }
        }
    }
    if dir[2] != 0.0 {
        for z in [p.bottom, p.top] {
            let t = (z - o[2]) / dir[2];
            if t > t0 && t < t1 {
                cuts.push(t);
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    let f = |t: f64| {
        let q = [o[0] + t * dir[0], o[1] + t * dir[1], o[2] + t * dir[2]];
        let [u, v] = p.to_grid(d, q[0], q[1]);
        p.density * p.vertical(q[2]) * spline(g, d, scale, u, v)
    };
    let mut sum = 0.0;
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (m, r) = ((a + b) / 2.0, (b - a) / 2.0);
        for (x, wt) in GL_X.iter().zip(GL_W) {
            sum += wt * r * (f(m - r * x) + f(m + r * x));
        }
    }
    sum
}

fn random_fogmap(nx: usize, ny: usize, rng: &mut Pcg64) -> Grid {
    // Non-negative with clear gaps, so coarse levels of the splines have sharp edges.
    let data = (0..nx * ny)
        .map(|_| {
            let v: f64 = rng.random();
            if v < 0.3 { 0.0 } else { v }
        })
        .collect();
    Grid {
        x0: 0,
        y0: 0,
        nx,
        ny,
        data,
    }
}

fn placement() -> Placement {
    Placement {
        origin: [-3.0, 2.0],
        cell: 0.7,
        density: 0.8,
        bottom: -0.5,
        top: 2.5,
        falloff: 0.3,
    }
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / n)
}

/// Segments `(o, p)`: random ones plus every awkward case.
fn segments(p: &Placement, nx: usize, ny: usize, rng: &mut Pcg64) -> Vec<([f64; 3], [f64; 3])> {
    let (w, h) = (nx as f64 * p.cell, ny as f64 * p.cell);
    let [x0, y0] = p.origin;
    let mut out = Vec::new();
    for _ in 0..60 {
        let mut pt = || {
            [
                x0 - 0.5 * w + 2.0 * w * rng.random::<f64>(),
                y0 - 0.5 * h + 2.0 * h * rng.random::<f64>(),
                p.bottom - 1.0 + (p.top - p.bottom + 2.0) * rng.random::<f64>(),
            ]
        };
        out.push((pt(), pt()));
    }
    let mid = [x0 + w / 2.0, y0 + h / 2.0, 1.0];
    // Starting inside the fog, ending inside.
    out.push((mid, [x0 + 0.2 * w, y0 + 0.9 * h, 0.0]));
    // Zero length.
    out.push((mid, mid));
    // Parallel to the x and y grid lines, horizontal, inside the slab.
    out.push(([x0 - 1.0, mid[1], 0.3], [x0 + w + 1.0, mid[1], 0.3]));
    out.push(([mid[0], y0 + h + 1.0, 0.3], [mid[0], y0 - 1.0, 0.3]));
    // Exactly on grid lines of every basis (U integer for d = 0, 2 at x0 + k·cell; for
    // d = 1 at half cells).
    for k in [0.0, 3.0, 4.5, 5.0] {
        let x = x0 + k * p.cell;
        out.push(([x, y0 - 1.0, 0.1], [x, y0 + h + 1.0, 1.2]));
        out.push((
            [x0 - 1.0, y0 + k * p.cell, 0.1],
            [x0 + w + 1.0, y0 + k * p.cell, -0.2],
        ));
    }
    // Grazing: along the slab's top, just under it, and barely descending.
    out.push((
        [x0 - 1.0, y0 + 0.3 * h, p.top],
        [x0 + w, y0 + 0.8 * h, p.top],
    ));
    out.push(([x0, y0, p.top - 1e-9], [x0 + w, y0 + h, p.top - 1e-9]));
    out.push(([x0, y0 + 0.1, 1.0], [x0 + w, y0 + h, 1.0 - 1e-10]));
    // Vertical, through the slab and inside it.
    out.push((
        [mid[0], mid[1], p.top + 3.0],
        [mid[0], mid[1], p.bottom - 1.0],
    ));
    out.push(([mid[0] + 0.1, mid[1], 0.0], [mid[0] + 0.1, mid[1], 0.5]));
    // Diagonal through a grid corner.
    out.push(([x0, y0, 0.5], [x0 + 4.0 * p.cell, y0 + 4.0 * p.cell, 0.5]));
    // Entirely outside: above the slab, and beside the map.
    out.push(([mid[0], mid[1], p.top + 1.0], [x0, y0, p.top + 2.0]));
    out.push(([x0 - 10.0, y0, 0.5], [x0 - 10.0, y0 + h, 0.5]));
    out
}

fn close(got: f64, want: f64, scale: f64) -> bool {
    (got - want).abs() <= 1e-9 * (want.abs() + scale)
}

#[test]
fn full_integral_matches_quadrature_of_the_fogmap() {
    let mut rng = Pcg64::seed_from_u64(1);
    let p = placement();
    for basis in Basis::ALL {
        let d = basis.degree();
        for (nx, ny) in [(13, 11), (8, 8), (1, 5)] {
            let fogmap = random_fogmap(nx, ny, &mut rng);
            for levels in [0, 1, 2] {
                for mode in [Mode::Direct, Mode::Deconstructed] {
                    let settings = Settings {
                        mu: 1.0,
                        mode,
                        min_transmittance: 0.0,
                    };
                    let Ok(fog) = Fog::new(&fogmap, basis, levels, p, settings) else {
                        assert!(
                            levels > 0 && nx.max(ny) < 1 << levels,
                            "{basis} {nx}x{ny} L={levels}"
                        );
                        continue;
                    };
                    for (o, q) in segments(&p, nx, ny, &mut rng) {
                        let got = fog.optical_depth(o, q);
                        let v = [q[0] - o[0], q[1] - o[1], q[2] - o[2]];
                        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                        let want = if len > 0.0 {
                            quadrature(&fogmap, d, 1.0, &p, (o, unit(v)), (0.0, len))
                        } else {
                            0.0
                        };
                        assert!(
                            close(got, want, 1e-3),
                            "{basis} {nx}x{ny} L={levels} {mode:?} {o:?}->{q:?}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn reconstructed_function_has_the_same_integrals() {
    // The spline rebuilt from the decomposition, integrated by quadrature, against the
    // fog's exact integral of the decomposed levels (µ = 1): lossless end to end.
    let mut rng = Pcg64::seed_from_u64(2);
    let p = placement();
    for basis in Basis::ALL {
        let fogmap = random_fogmap(21, 17, &mut rng);
        let rebuilt = Decomposition::new(basis, &fogmap, 3).reconstruct();
        let fog = Fog::new(
            &fogmap,
            basis,
            3,
            p,
            Settings {
                mode: Mode::Direct,
                min_transmittance: 0.0,
                ..Settings::default()
            },
        )
        .unwrap();
        for (o, q) in segments(&p, 21, 17, &mut rng) {
            let v = [q[0] - o[0], q[1] - o[1], q[2] - o[2]];
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if len == 0.0 {
                continue;
            }
            let want = quadrature(&rebuilt, basis.degree(), 1.0, &p, (o, unit(v)), (0.0, len));
            let got = fog.optical_depth(o, q);
            assert!(close(got, want, 1e-3), "{basis}: {got} vs {want}");
        }
    }
}

/// `Σ_l ∫_{band l} A_l` by quadrature, bands from `d_max,l = |OP|·µ^l`.
fn banded_reference(dec: &Decomposition, p: &Placement, mu: f64, o: [f64; 3], q: [f64; 3]) -> f64 {
    banded_span_reference(dec, p, mu, o, q, (0.0, f64::INFINITY))
}

/// [`banded_reference`] over the part `t ∈ span` of the segment only (the bands are the
/// whole segment's).
fn banded_span_reference(
    dec: &Decomposition,
    p: &Placement,
    mu: f64,
    o: [f64; 3],
    q: [f64; 3],
    span: (f64, f64),
) -> f64 {
    let v = [q[0] - o[0], q[1] - o[1], q[2] - o[2]];
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if len == 0.0 {
        return 0.0;
    }
    let big_l = dec.levels();
    let levels = dec.deconstruct();
    let dmax = |l: usize| len * mu.powi(l as i32);
    (0..=big_l)
        .map(|l| {
            let lo = if l == big_l { 0.0 } else { dmax(l + 1) };
            let scale = f64::from(1u32 << (big_l - l));
            quadrature(
                &levels[l],
                dec.basis.degree(),
                scale,
                p,
                (o, unit(v)),
                (lo.max(span.0), dmax(l).min(span.1)),
            )
        })
        .sum()
}

/// A ray split at any point `s` integrates the fog exactly on both sides: each span matches
/// the banded quadrature over it (the µ bands of the whole ray), and the two add up to
/// the whole ray's depth to rounding (the split cuts one cell per level into two exact
/// integrals). This is what compositing another medium at a depth relies on.
#[test]
fn a_ray_split_anywhere_integrates_both_spans_exactly() {
    let mut rng = Pcg64::seed_from_u64(23);
    let p = placement();
    for basis in Basis::ALL {
        let fogmap = random_fogmap(16, 12, &mut rng);
        let dec = Decomposition::new(basis, &fogmap, 2);
        for mu in [0.4, 1.0] {
            for mode in [Mode::Direct, Mode::Deconstructed] {
                let settings = Settings {
                    mu,
                    mode,
                    min_transmittance: 0.0,
                };
                let fog = Fog::new(&fogmap, basis, 2, p, settings).unwrap();
                let mut split = 0;
                for (o, q) in segments(&p, 16, 12, &mut rng) {
                    let v = [q[0] - o[0], q[1] - o[1], q[2] - o[2]];
                    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    if len == 0.0 {
                        assert_eq!(
                            fog.optical_depth_span(o, [1.0, 0.0, 0.0], 0.0, 0.0, 1.0),
                            0.0
                        );
                        continue;
                    }
                    let d = unit(v);
                    let whole = fog.optical_depth(o, q);
                    for f in [0.0, 0.13, 0.5, 0.871, 1.0] {
                        let s = f * len;
                        let front = fog.optical_depth_span(o, d, len, 0.0, s);
                        let back = fog.optical_depth_span(o, d, len, s, len);
                        let scale = p.density * len;
                        assert!(
                            (front + back - whole).abs() <= 1e-12 * (whole.abs() + scale),
                            "{basis} µ={mu} {mode:?} s={s}: {front} + {back} vs {whole}"
                        );
                        let want = banded_span_reference(&dec, &p, mu, o, q, (0.0, s));
                        assert!(
                            close(front, want, scale),
                            "{basis} µ={mu} {mode:?} s={s}: {front} vs {want}"
                        );
                        split += usize::from(front > 1e-3 * whole && back > 1e-3 * whole);
                    }
                }
                assert!(split > 40, "{basis}: {split} rays had fog on both sides");
            }
        }
    }
}

#[test]
fn mu_bands_match_quadrature_in_both_modes() {
    let mut rng = Pcg64::seed_from_u64(3);
    let p = placement();
    for basis in Basis::ALL {
        let fogmap = random_fogmap(16, 12, &mut rng);
        let dec = Decomposition::new(basis, &fogmap, 3);
        for mu in [0.0, 0.3, 0.75, 1.0] {
            let fogs = [Mode::Direct, Mode::Deconstructed].map(|mode| {
                Fog::new(
                    &fogmap,
                    basis,
                    3,
                    p,
                    Settings {
                        mu,
                        mode,
                        min_transmittance: 0.0,
                    },
                )
                .unwrap()
            });
            for (o, q) in segments(&p, 16, 12, &mut rng) {
                let want = banded_reference(&dec, &p, mu, o, q);
                for fog in &fogs {
                    let got = fog.optical_depth(o, q);
                    assert!(
                        close(got, want, 1e-3),
                        "{basis} µ={mu} {:?}: {got} vs {want}",
                        fog.settings().mode
                    );
                }
            }
        }
    }
}

#[test]
fn mu_one_is_the_full_integral_and_mu_zero_the_coarsest_level() {
    let mut rng = Pcg64::seed_from_u64(4);
    let p = placement();
    for basis in Basis::ALL {
        let fogmap = random_fogmap(16, 16, &mut rng);
        let build = |levels: usize, mu: f64| {
            Fog::new(
                &fogmap,
                basis,
                levels,
                p,
                Settings {
                    mu,
                    mode: Mode::Deconstructed,
                    min_transmittance: 0.0,
                },
            )
            .unwrap()
        };
        let full = build(0, 1.0);
        let dec = Decomposition::new(basis, &fogmap, 2);
        // The coarsest level alone, as its own undecomposed fogmap on a 4× coarser grid.
        let mut coarse_p = p;
        coarse_p.cell = 4.0 * p.cell;
        let d = basis.degree() as f64;
        // Level-0 units are U/4; a placement with cell' = 4·cell has
        // U' = (x − o')/cell' + d/2 = U/4 − x0 when o' = o + (3d/8 + x0)·cell'.
        coarse_p.origin = [
            p.origin[0] + 1.5 * d * p.cell,
            p.origin[1] + 1.5 * d * p.cell,
        ];
        let a0 = &dec.approx;
        let mut shifted = a0.clone();
        shifted.x0 = 0;
        shifted.y0 = 0;
        coarse_p.origin[0] += a0.x0 as f64 * coarse_p.cell;
        coarse_p.origin[1] += a0.y0 as f64 * coarse_p.cell;
        for (o, q) in segments(&p, 16, 16, &mut rng) {
            let exact = full.optical_depth(o, q);
            let at_one = build(2, 1.0).optical_depth(o, q);
            assert!(
                close(at_one, exact, 1e-3),
                "{basis}: µ=1 {at_one} vs {exact}"
            );
            let at_zero = build(2, 0.0).optical_depth(o, q);
            let v = [q[0] - o[0], q[1] - o[1], q[2] - o[2]];
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let coarse = if len > 0.0 {
                quadrature(
                    &shifted,
                    basis.degree(),
                    1.0,
                    &coarse_p,
                    (o, unit(v)),
                    (0.0, len),
                )
            } else {
                0.0
            };
            // Coarse coefficients can be negative near edges; compare with the map's
            // scale so tiny sums are not held to a relative bound.
            assert!(
                close(at_zero, coarse, 1e-3),
                "{basis}: µ=0 {at_zero} vs {coarse}"
            );
        }
    }
}

#[test]
fn early_termination_stays_within_its_threshold() {
    let mut rng = Pcg64::seed_from_u64(5);
    let mut p = placement();
    p.density = 6.0;
    for basis in Basis::ALL {
        let fogmap = random_fogmap(16, 16, &mut rng);
        for mu in [1.0, 0.5] {
            let build = |min_transmittance| {
                Fog::new(
                    &fogmap,
                    basis,
                    2,
                    p,
                    Settings {
                        mu,
                        mode: Mode::Deconstructed,
                        min_transmittance,
                    },
                )
                .unwrap()
            };
            let (exact, early) = (build(0.0), build(1e-3));
            let mut stopped = 0;
            for (o, q) in segments(&p, 16, 16, &mut rng) {
                let (te, tq) = (exact.transmittance(o, q), early.transmittance(o, q));
                assert!((te - tq).abs() <= 1e-3, "{basis}: {te} vs {tq}");
                if te != tq {
                    assert!(
                        te <= 1e-3 && tq <= 1e-3,
                        "{basis}: stopped at {tq}, exact {te}"
                    );
                    stopped += 1;
                }
            }
            assert!(
                stopped > 0,
                "{basis}: no ray stopped early; the test is too thin"
            );
        }
    }
}

#[test]
fn sky_rays_end_where_they_leave_the_fog() {
    let mut rng = Pcg64::seed_from_u64(6);
    let p = placement();
    let fogmap = random_fogmap(10, 10, &mut rng);
    let fog = Fog::new(&fogmap, Basis::Linear, 1, p, Settings::default()).unwrap();
    let o = [p.origin[0] + 3.0, p.origin[1] - 2.0, 1.0];
    for dir in [
        [0.1, 1.0, 0.0],
        [0.3, 1.0, 0.2],
        [0.0, 0.0, 1.0],
        [0.0, 1.0, -0.01],
    ] {
        let ray = fog.optical_depth_ray(o, dir);
        let far = [
            o[0] + 1e4 * dir[0],
            o[1] + 1e4 * dir[1],
            o[2] + 1e4 * dir[2],
        ];
        // Beyond the fog the integrand is zero: the long segment has the same integral
        // as long as µ = 1.
        let seg = fog.optical_depth(o, far);
        assert!(close(ray, seg, 1e-3), "{dir:?}: {ray} vs {seg}");
        assert!(ray.is_finite() && ray >= 0.0);
    }
    assert_eq!(fog.optical_depth_ray(o, [0.0, 0.0, 0.0]), 0.0);
}

#[test]
fn extremes_give_finite_transmittances_or_clear_errors() {
    let mut rng = Pcg64::seed_from_u64(7);
    let mut p = placement();
    let fogmap = random_fogmap(8, 8, &mut rng);
    p.density = 1e30;
    let fog = Fog::new(&fogmap, Basis::Quadratic, 2, p, Settings::default()).unwrap();
    for (o, q) in segments(&p, 8, 8, &mut rng) {
        let t = fog.transmittance(o, q);
        assert!((0.0..=1.0).contains(&t), "{t}");
    }
    p.density = 1e305;
    let err = Fog::new(&fogmap, Basis::Quadratic, 2, p, Settings::default()).unwrap_err();
    assert!(matches!(err, FogError::Overflow { .. }), "{err}");
    assert!(err.to_string().contains("too large"));
    // An all-zero (clear) map is valid and clear.
    let clear = Grid::zeros(0, 0, 5, 5);
    p.density = 1.0;
    let fog = Fog::new(&clear, Basis::Linear, 2, p, Settings::default()).unwrap();
    assert_eq!(
        fog.transmittance([-10.0, -10.0, 0.0], [10.0, 10.0, 1.0]),
        1.0
    );
    // Empty, NaN, too many levels, bad µ.
    let empty = Grid::zeros(0, 0, 0, 4);
    assert_eq!(
        Fog::new(&empty, Basis::Haar, 0, p, Settings::default()).unwrap_err(),
        FogError::Empty
    );
    let mut nan = Grid::zeros(0, 0, 3, 3);
    nan.data[4] = f64::NAN;
    let e = Fog::new(&nan, Basis::Haar, 0, p, Settings::default()).unwrap_err();
    assert!(e.to_string().contains("(1, 1) is NaN"), "{e}");
    let e = Fog::new(&fogmap, Basis::Haar, 4, p, Settings::default()).unwrap_err();
    assert!(e.to_string().contains("at most 3"), "{e}");
    let e = Fog::new(
        &fogmap,
        Basis::Haar,
        1,
        p,
        Settings {
            mu: 1.5,
            ..Settings::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("µ = 1.5"), "{e}");
}

#[test]
fn deconstructed_bases_are_non_negative_where_the_input_is() {
    let mut rng = Pcg64::seed_from_u64(8);
    for basis in Basis::ALL {
        // The finest deconstructed level is the (non-negative) fogmap itself.
        let sharp = random_fogmap(19, 14, &mut rng);
        let levels = Decomposition::new(basis, &sharp, 3).deconstruct();
        let finest = levels.last().unwrap();
        for (a, b) in finest.data.iter().zip(&sharp.data) {
            assert!((a - b).abs() < 1e-12 && *a >= -1e-12);
        }
        // Haar approximations are averages: non-negative at every level, any input (up to
        // the rounding of a synthesis, a few ulps of the largest coefficient).
        if basis == Basis::Haar {
            assert!(levels.iter().all(|g| g.min() >= -1e-14), "{basis}");
        }
        // Smooth positive fog: every level of every basis is positive inside the map.
        let mut smooth = Grid::zeros(0, 0, 32, 24);
        for j in 0..24 {
            for i in 0..32 {
                smooth.data[j * 32 + i] =
                    1.0 + 0.5 * (0.3 * i as f64).sin() * (0.2 * j as f64).cos();
            }
        }
        let dec = Decomposition::new(basis, &smooth, 3);
        for (l, g) in dec.deconstruct().iter().enumerate() {
            let s = 1i64 << (3 - l);
            // Coefficients that depend only on pixels inside the map: `l` analysis steps
            // reach fine indices `s·k − (s − 1) … s·k + 3(s − 1)` at most (the linear `a`
            // spans −1 … 3), `s = 2^{L−l}`.
            let inside = |k: i64, n: i64| s * k - s >= 0 && s * k + 3 * s < n;
            for j in 0..g.ny as i64 {
                for i in 0..g.nx as i64 {
                    let (x, y) = (g.x0 + i, g.y0 + j);
                    if inside(x, 32) && inside(y, 24) {
                        assert!(g.get(x, y) > 0.0, "{basis} level {l} ({x}, {y})");
                    }
                }
            }
        }
    }
}

#[test]
fn a_translated_fog_is_the_fog_placed_there() {
    let mut rng = Pcg64::seed_from_u64(31);
    let g = random_fogmap(9, 7, &mut rng);
    let p = placement();
    let by = [3.75, -2.25];
    let moved_p = Placement {
        origin: [p.origin[0] + by[0], p.origin[1] + by[1]],
        ..p
    };
    for basis in Basis::ALL {
        let settings = Settings {
            mu: 0.7,
            ..Settings::default()
        };
        let mut moved = Fog::new(&g, basis, 2, p, settings).unwrap();
        let still = moved.clone();
        moved.translate(by);
        let placed = Fog::new(&g, basis, 2, moved_p, settings).unwrap();
        assert_eq!(moved.placement(), placed.placement());
        for (o, q) in segments(&moved_p, 9, 7, &mut rng) {
            let got = moved.optical_depth(o, q);
            let want = placed.optical_depth(o, q);
            assert!(close(got, want, 1.0), "{basis}: {got} vs {want}");
            // The same as the unmoved fog seen from points moved back.
            let back = |a: [f64; 3]| [a[0] - by[0], a[1] - by[1], a[2]];
            let before = still.optical_depth(back(o), back(q));
            assert!(close(got, before, 1.0), "{basis}: {got} vs {before}");
        }
    }
}
