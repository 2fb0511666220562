//! Checks of the assembled system and the solver against computations that share none of
//! their code: finite differences of the continuous fields built with `Rbf::eval`, closed
//! forms of 1-D diffusion, and quadrature of the phase integral.

use super::*;
use crate::medium::sample_hg_cos;
use haze_volume::Rbf;
use nalgebra::DVector;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// Uniform numbers from the crate's seeded PCG.
struct Rng(Pcg64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(Pcg64::seed_from_u64(seed))
    }

    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.0.random::<f64>()
    }
}

fn random_rbfs(rng: &mut Rng, n: usize, extent: f64, r: (f64, f64), w: (f64, f64)) -> Vec<Rbf> {
    (0..n)
        .map(|_| {
            let c = [0; 3].map(|_| rng.uniform(0.0, extent));
            Rbf::new(c, rng.uniform(r.0, r.1), rng.uniform(w.0, w.1))
        })
        .collect()
}

fn random_sources(rng: &mut Rng, n: usize) -> Sources {
    Sources {
        j0: (0..n)
            .map(|_| [0; 3].map(|_| rng.uniform(0.0, 2.0)))
            .collect(),
        j1: (0..n)
            .map(|_| [0; 3].map(|_| [0; 3].map(|_| rng.uniform(-1.0, 1.0))))
            .collect(),
        escape: (0..n).map(|_| rng.uniform(0.0, 0.9)).collect(),
    }
}

fn density(rbfs: &[Rbf], p: [f64; 3]) -> f64 {
    rbfs.iter().map(|b| b.eval(p)).sum()
}

/// The interpolated field `Σ w B(p) F_l / D̃(p)` (eq. 12).
fn interp(rbfs: &[Rbf], f: &[f64], p: [f64; 3]) -> f64 {
    rbfs.iter().zip(f).map(|(b, v)| b.eval(p) * v).sum::<f64>() / density(rbfs, p)
}

fn shifted(p: [f64; 3], axis: usize, by: f64) -> [f64; 3] {
    let mut q = p;
    q[axis] += by;
    q
}

/// No center within `margin·r` of another RBF's cut-off sphere, so that finite differences
/// at the centers see the smooth Gaussians.
fn clear_of_cutoffs(rbfs: &[Rbf], margin: f64) -> bool {
    rbfs.iter().all(|h| {
        rbfs.iter().all(|l| {
            let d: f64 = (0..3).map(|a| (h.center[a] - l.center[a]).powi(2)).sum();
            (d.sqrt() / l.radius - 3.0).abs() > margin
        })
    })
}

/// Overlapping random sets (40 RBFs, radii 0.05–0.15 in a box of 0.5) clear of cut-offs.
fn overlapping_sets(count: usize) -> Vec<Vec<Rbf>> {
    let mut rng = Rng::new(7);
    let mut out = Vec::new();
    while out.len() < count {
        let rbfs = random_rbfs(&mut rng, 40, 0.5, (0.05, 0.15), (0.1, 1.0));
        if clear_of_cutoffs(&rbfs, 1e-2) {
            out.push(rbfs);
        }
    }
    out
}

const MEDIUM: Medium = Medium {
    sigma_t: 7.0,
    albedo: 0.6,
    g: 0.4,
};

/// `A` applied to values `L⁰_l` equals `(1 − P_h)∇·(κ∇L⁰) − (σa + σs P_h) D̃ L⁰` at every
/// center `h` (random escape probabilities `P`), with
/// `L⁰(x)` and `κ(x) = 1/(3σtr D̃(x))` evaluated by `Rbf::eval` and the divergence by nested
/// central differences, step `h = 1e-3·r_min`. Truncation is `O((h/r)²) ≈ 1e-6` of the
/// terms (`~|L|/r²`), rounding `~ε|L|/h² ≈ 1e-10` of them: tolerance `1e-5` of
/// `Σ_l |A_hl L_l|`. The worst error seen is printed.
#[test]
fn operator_rows_match_finite_differences_of_the_field() {
    let (sigma_tr, sigma_a) = (7.0 * (1.0 - 0.6 * 0.4), 7.0 * 0.4);
    let mut rng = Rng::new(99);
    let mut worst = 0.0f64;
    for rbfs in overlapping_sets(3) {
        let n = rbfs.len();
        // Escape probabilities: the flux of row h is kept in the proportion 1 − P_h and the
        // sink grows by σs P_h (module docs of `diffusion`).
        let escape: Vec<f64> = (0..n).map(|_| rng.uniform(0.0, 0.9)).collect();
        let src = Sources {
            escape: escape.clone(),
            ..Sources::zeros(n)
        };
        let sys = assemble(&rbfs, &MEDIUM, &src);
        let a = sys.a.to_dense();
        let vals: Vec<f64> = (0..n).map(|_| rng.uniform(0.5, 2.0)).collect();
        let applied = &a * DVector::from_column_slice(&vals);
        let h = 1e-3 * rbfs.iter().map(|b| b.radius).fold(f64::INFINITY, f64::min);
        let l0 = |p| interp(&rbfs, &vals, p);
        let kappa = |p| 1.0 / (3.0 * sigma_tr * density(&rbfs, p));
        for (i, b) in rbfs.iter().enumerate() {
            let x = b.center;
            let div: f64 = (0..3)
                .map(|ax| {
                    let up = kappa(shifted(x, ax, h / 2.0)) * (l0(shifted(x, ax, h)) - l0(x));
                    let down = kappa(shifted(x, ax, -h / 2.0)) * (l0(x) - l0(shifted(x, ax, -h)));
                    (up - down) / (h * h)
                })
                .sum();
            let sink = sigma_a + 7.0 * 0.6 * escape[i];
            let fd = (1.0 - escape[i]) * div - sink * density(&rbfs, x) * l0(x);
            let scale: f64 = (0..n).map(|l| (a[(i, l)] * vals[l]).abs()).sum();
            let err = (applied[i] - fd).abs() / scale;
            worst = worst.max(err);
            assert!(err < 1e-5, "center {i}: A·L {} vs FD {fd}", applied[i]);
        }
    }
    eprintln!("operator check: worst relative error {worst:.2e}");
}

/// `b = −S` with `S(x) = σt D̃ J⁰(x) − (σt/(3σtr)) ∇·J¹(x)`, the interpolated
/// `(1 − P_l) J⁰_l`, `(1 − P_l) J¹_l`
/// built by `Rbf::eval` and the divergence by central differences (`h = 1e-4·r_min`:
/// truncation `~1e-8`, rounding `~1e-12/1e-4·r`). Tolerance `1e-6` of the terms' scale.
#[test]
fn source_matches_finite_differences_of_the_field() {
    let sigma_tr = 7.0 * (1.0 - 0.6 * 0.4);
    let mut rng = Rng::new(5);
    let mut worst = 0.0f64;
    for rbfs in overlapping_sets(3) {
        let n = rbfs.len();
        let src = random_sources(&mut rng, n);
        let sys = assemble(&rbfs, &MEDIUM, &src);
        let h = 1e-4 * rbfs.iter().map(|b| b.radius).fold(f64::INFINITY, f64::min);
        for (i, b) in rbfs.iter().enumerate() {
            let x = b.center;
            for c in 0..3 {
                // The sources are kept in the proportion 1 − P_l at their centers.
                let kept = |l: usize| 1.0 - src.escape[l];
                let j0: Vec<f64> = (0..n).map(|l| kept(l) * src.j0[l][c]).collect();
                let div: f64 = (0..3)
                    .map(|ax| {
                        let j1: Vec<f64> = (0..n).map(|l| kept(l) * src.j1[l][c][ax]).collect();
                        let f = |p| interp(&rbfs, &j1, p);
                        (f(shifted(x, ax, h)) - f(shifted(x, ax, -h))) / (2.0 * h)
                    })
                    .sum();
                let d_j0 = density(&rbfs, x) * interp(&rbfs, &j0, x);
                let s = 7.0 * d_j0 - 7.0 / (3.0 * sigma_tr) * div;
                let scale = 7.0 * d_j0.abs() + 7.0 / (3.0 * sigma_tr) * div.abs() + 1.0;
                let err = (sys.b[c][i] + s).abs() / scale;
                worst = worst.max(err);
                assert!(
                    err < 1e-6,
                    "center {i} channel {c}: b {} vs −S {}",
                    sys.b[c][i],
                    -s
                );
            }
        }
    }
    eprintln!("source check: worst relative error {worst:.2e}");
}

/// Realistic RBFs: 200 in the unit box, radii 0.03–0.09, weights 0.1–1.
fn realistic(seed: u64, n: usize) -> Vec<Rbf> {
    random_rbfs(&mut Rng::new(seed), n, 1.0, (0.03, 0.09), (0.1, 1.0))
}

/// Manufactured solution: `b = A L` for chosen `L`; CGLS recovers `L` from zero, and from a
/// start perturbed by 1e-3 in fewer iterations. The recovery error is bounded by the
/// residual tolerance times the condition number of the equilibrated system.
#[test]
fn manufactured_solution_is_recovered_and_warm_start_is_faster() {
    let rbfs = realistic(3, 200);
    let n = rbfs.len();
    let mut rng = Rng::new(11);
    let truth: Vec<[f64; 3]> = (0..n)
        .map(|_| [0; 3].map(|_| rng.uniform(0.2, 3.0)))
        .collect();
    let mut sys = assemble(&rbfs, &MEDIUM, &Sources::zeros(n));
    for (c, b) in sys.b.iter_mut().enumerate() {
        *b = sys.a.mul(&DVector::from_fn(n, |l, _| truth[l][c]));
    }
    let opts = SolveOptions {
        max_iterations: 2000,
        tolerance: 1e-10,
    };
    let err = |s: &Solution| {
        let num: f64 = (0..n)
            .flat_map(|l| (0..3).map(move |c| (l, c)))
            .map(|(l, c)| (s.l0[l][c] - truth[l][c]).powi(2))
            .sum();
        let den: f64 = truth.iter().flatten().map(|v| v * v).sum();
        (num / den).sqrt()
    };
    let cold = solve_system(&sys, &vec![[0.0; 3]; n], &opts);
    assert!(cold.converged && cold.residual <= 1e-10, "{cold:?}");
    assert!(err(&cold) < 1e-7, "cold error {:e}", err(&cold));
    let start: Vec<[f64; 3]> = truth
        .iter()
        .map(|t| t.map(|v| v * (1.0 + rng.uniform(-1e-3, 1e-3))))
        .collect();
    let warm = solve_system(&sys, &start, &opts);
    assert!(warm.converged && err(&warm) < 1e-7, "{warm:?}");
    assert!(warm.iterations < cold.iterations);
    eprintln!(
        "manufactured n={n}: cold {} iterations (error {:.1e}), warm {} ({:.1e})",
        cold.iterations,
        err(&cold),
        warm.iterations,
        err(&warm)
    );
}

/// Uniform sources on any geometry: `L⁰ ≡ J⁰/(1 − Ω)` is exact, since a constant field
/// has no flux and a constant `J¹` no divergence (the infinite-medium value: the RBF
/// basis has no leaking boundary).
#[test]
fn uniform_source_gives_the_infinite_medium_value() {
    let rbfs = realistic(21, 150);
    let n = rbfs.len();
    let src = Sources {
        j0: vec![[1.0, 2.0, 0.5]; n],
        j1: vec![[[0.3, -0.2, 0.1], [0.0, 1.0, 0.0], [-0.5, 0.5, 0.5]]; n],
        escape: Vec::new(),
    };
    let medium = Medium::new(3.0, 0.7, 0.5).unwrap();
    let s = DiffusionSolver::new().solve(&rbfs, &medium, &src, &SolveOptions::default());
    assert!(s.converged, "{s:?}");
    for l in &s.l0 {
        for c in 0..3 {
            let expect = src.j0[0][c] / 0.3;
            assert!((l[c] - expect).abs() < 1e-4 * expect, "{l:?} vs {expect}");
        }
    }
}

/// The vacuum correction with a uniform escape probability `P`: the constant field is
/// still exact, now `L⁰ = (1 − P) J⁰/(1 − Ω(1 − P))`, and it stays finite and solvable at
/// Ω = 1 (where the uncorrected system is singular).
#[test]
fn uniform_escape_gives_the_escape_balance() {
    let rbfs = realistic(21, 150);
    let n = rbfs.len();
    for (albedo, p) in [(0.7, 0.3), (1.0, 0.25), (0.9, 1.0)] {
        let src = Sources {
            j0: vec![[1.0, 2.0, 0.5]; n],
            j1: vec![[[0.3, -0.2, 0.1], [0.0, 1.0, 0.0], [-0.5, 0.5, 0.5]]; n],
            escape: vec![p; n],
        };
        let medium = Medium::new(3.0, albedo, 0.5).unwrap();
        let s = DiffusionSolver::new().solve(&rbfs, &medium, &src, &SolveOptions::default());
        assert!(s.converged, "Ω {albedo}, P {p}: {s:?}");
        for l in &s.l0 {
            for c in 0..3 {
                let expect = (1.0 - p) * src.j0[0][c] / (1.0 - albedo * (1.0 - p));
                let tol = 1e-4 * src.j0[0][c];
                assert!(
                    (l[c] - expect).abs() < tol,
                    "Ω {albedo}, P {p}: {l:?} vs {expect}"
                );
            }
        }
    }
}

/// A line of RBFs is an exact 1-D problem on its axis (the transverse Gaussian factor is
/// common to every `v_l` and cancels in `v_l/D̃`): `κ L'' − σa D̃ L + S = 0` with uniform
/// `D̃ = √π r/s` (spacing `s = r/2`), whose diffusion length is
/// `Ld = √(κ/(σa D̃)) = 1/(σt D̃ √(3(1 − Ωg)(1 − Ω)))`, here 5 r.
///
/// - A source step `J⁰ = 1` for `x < 0`: `L = L∞(1 − ½e^{x/Ld})` left, `½L∞ e^{−x/Ld}`
///   right, `L∞ = 1/(1 − Ω)`.
/// - A step of `J¹_x = a` for `x < 0` (its divergence `−a δ(x)`): `L = q Ld/(2κ) e^{−|x|/Ld}`
///   with `q = σt a/(3σtr)`, i.e. `a/(2√(3(1 − Ωg)(1 − Ω))) · e^{−|x|/Ld}`.
///
/// The interpolated steps are smoothed over `~r`, which shifts the profiles by
/// `~σ²/(2Ld²) ≈ 1 %` away from the step; tolerance 3 % of `L∞` (a factor 3 in `κ`, or
/// `σt/σtr` instead of `σt/(3σtr)`, changes them by 30 % or more).
#[test]
fn line_of_rbfs_matches_one_dimensional_diffusion() {
    let (r, s) = (1.0, 0.5);
    let rbfs: Vec<Rbf> = (-80..=80)
        .map(|i| Rbf::new([i as f64 * s, 0.0, 0.0], r, 1.0))
        .collect();
    let n = rbfs.len();
    let d = PI.sqrt() * r / s;
    let (albedo, g, ld): (f64, f64, f64) = (0.5, 0.5, 5.0 * r);
    let sigma_t = 1.0 / (ld * d * (3.0 * (1.0 - albedo * g) * (1.0 - albedo)).sqrt());
    let medium = Medium::new(sigma_t, albedo, g).unwrap();
    let opts = SolveOptions {
        max_iterations: 5000,
        tolerance: 1e-9,
    };
    let a = 0.8;
    let mut src = Sources::zeros(n);
    for (l, b) in rbfs.iter().enumerate() {
        // Centers at x = 0 take half of each step.
        let left = if b.center[0] < 0.0 {
            1.0
        } else if b.center[0] == 0.0 {
            0.5
        } else {
            0.0
        };
        src.j0[l] = [left, 0.0, 0.0];
        src.j1[l][1] = [a * left, 0.0, 0.0];
    }
    let sol = DiffusionSolver::new().solve(&rbfs, &medium, &src, &opts);
    assert!(sol.converged, "{sol:?}");
    let l_inf = 1.0 / (1.0 - albedo);
    let peak = a / (2.0 * (3.0 * (1.0 - albedo * g) * (1.0 - albedo)).sqrt());
    let (mut worst0, mut worst1) = (0.0f64, 0.0f64);
    for b in rbfs.iter().filter(|b| b.center[0].abs() <= 20.0) {
        let x = b.center[0];
        let field = |c: usize| {
            let v: Vec<f64> = sol.l0.iter().map(|l| l[c]).collect();
            interp(&rbfs, &v, b.center)
        };
        let step = if x < 0.0 {
            l_inf * (1.0 - 0.5 * (x / ld).exp())
        } else {
            0.5 * l_inf * (-x / ld).exp()
        };
        worst0 = worst0.max((field(0) - step).abs() / l_inf);
        assert!(
            (field(0) - step).abs() < 0.03 * l_inf,
            "x {x}: {} vs {step}",
            field(0)
        );
        assert!(field(2).abs() < 1e-9);
        if x.abs() >= 1.5 * ld {
            let expect = peak * (-x.abs() / ld).exp();
            worst1 = worst1.max((field(1) - expect).abs() / peak);
            assert!(
                (field(1) - expect).abs() < 0.03 * peak,
                "x {x}: {} vs {expect}",
                field(1)
            );
        }
    }
    eprintln!("1-D diffusion: worst error {worst0:.2e} (J⁰ step), {worst1:.2e} (J¹ step)");
}

/// `J_ms` from the SH coefficients equals `(Ω/4π)∫ p(ω·ω') (L⁰ + L¹·ω') dω'` by quadrature
/// (4000 × 16 nodes about `ω`: midpoints of the phase's CDF in `μ`, which `medium`'s tests
/// check, and of `φ`, where the integrand is linear in `cos φ`, `sin φ`),
/// with `L¹ = (σt D̃ J¹ − ∇L⁰)/(σtr D̃)` and `∇L⁰` by central differences of the field.
#[test]
fn ms_source_sh_matches_the_phase_integral() {
    let rbfs = overlapping_sets(1).remove(0);
    let n = rbfs.len();
    let mut rng = Rng::new(17);
    let src = random_sources(&mut rng, n);
    let l0: Vec<[f64; 3]> = (0..n)
        .map(|_| [0; 3].map(|_| rng.uniform(0.0, 2.0)))
        .collect();
    for g in [-0.95, -0.3, 0.0, 0.6, 0.95] {
        let medium = Medium::new(4.0, 0.8, g).unwrap();
        let sigma_tr = 4.0 * (1.0 - 0.8 * g);
        let sh = ms_source_sh(&rbfs, &medium, &src, &l0);
        for h in [0, 7, 19] {
            let x = rbfs[h].center;
            let dens = density(&rbfs, x);
            for c in 0..3 {
                let vals: Vec<f64> = l0.iter().map(|l| l[c]).collect();
                let step = 1e-5;
                let grad = [0, 1, 2].map(|ax| {
                    let f = |p| interp(&rbfs, &vals, p);
                    (f(shifted(x, ax, step)) - f(shifted(x, ax, -step))) / (2.0 * step)
                });
                let kept = 1.0 - src.escape[h];
                let l1 = [0, 1, 2].map(|ax| {
                    (4.0 * dens * kept * src.j1[h][c][ax] - grad[ax]) / (sigma_tr * dens)
                });
                let y = sh[h][c];
                for w in [[0.0, 0.0, 1.0], [0.6, -0.8, 0.0], [-0.48, 0.36, -0.8]] {
                    let quad = phase_integral(g, w, l0[h][c], l1) * 0.8;
                    let k = (3.0 / (4.0 * PI)).sqrt();
                    let eval =
                        y[0] / (2.0 * PI.sqrt()) + k * (y[1] * w[1] + y[2] * w[2] + y[3] * w[0]);
                    let scale = l0[h][c].abs() + l1.iter().map(|v| v.abs()).sum::<f64>();
                    assert!(
                        (quad - eval).abs() < 1e-4 * scale,
                        "g {g}: {quad} vs {eval}"
                    );
                }
            }
        }
    }
}

/// `(1/4π)∫ p(ω·ω') (a + b·ω') dω'` by quadrature in a frame about `ω`.
fn phase_integral(g: f64, w: [f64; 3], a: f64, b: [f64; 3]) -> f64 {
    let w = nalgebra::Vector3::from(w);
    let e1 = w.cross(&nalgebra::Vector3::new(0.3, 0.5, 0.7)).normalize();
    let e2 = w.cross(&e1);
    let b = nalgebra::Vector3::from(b);
    let (nm, nf) = (4000, 16);
    let mut sum = 0.0;
    for i in 0..nm {
        // (1/4π)∫p dω' = ∫₀¹ du with μ = F⁻¹(u): midpoints in u resolve the peak of p.
        let mu = sample_hg_cos(g, (i as f64 + 0.5) / nm as f64);
        let st = (1.0 - mu * mu).sqrt();
        for j in 0..nf {
            let phi = (j as f64 + 0.5) * 2.0 * PI / nf as f64;
            let dir = w * mu + (e1 * phi.cos() + e2 * phi.sin()) * st;
            sum += a + b.dot(&dir);
        }
    }
    sum / (nm * nf) as f64
}

fn all_finite(s: &Solution) -> bool {
    s.l0.iter().flatten().all(|v| v.is_finite()) && s.residual.is_finite()
}

/// Degenerate inputs never give NaN or infinity.
#[test]
fn extremes_stay_finite() {
    let mut rbfs = realistic(4, 60);
    rbfs.push(rbfs[0]); // coincident, identical
    rbfs.push(Rbf::new(rbfs[1].center, rbfs[1].radius * 0.5, 0.3)); // coincident, narrower
    rbfs.push(Rbf::new([0.5; 3], 0.05, 0.0)); // zero weight
    rbfs.push(Rbf::new([0.5, 0.5, 0.52], 0.05, 1e-300)); // negligible weight beside it
    rbfs.push(Rbf::new([0.2; 3], 0.0, 1.0)); // no radius
    rbfs.push(Rbf::new([0.3; 3], 1e-300, 1.0)); // vanishing radius
    rbfs.push(Rbf::new([0.4; 3], 0.05, -1.0)); // negative weight
    let n = rbfs.len();
    let mut src = random_sources(&mut Rng::new(8), n);
    src.j0[5][1] = f64::NAN;
    src.j1[6][2][0] = f64::INFINITY;
    let opts = SolveOptions {
        max_iterations: 300,
        tolerance: 1e-8,
    };
    for (sigma_t, albedo, g) in [
        (5.0, 0.5, 0.0),
        (0.0, 0.5, 0.3),
        (5.0, 0.0, 0.95),
        (5.0, 1.0, -0.95),
        (5.0, 1.0, 0.95),
        (1e4, 0.9, 0.95),
    ] {
        let medium = Medium::new(sigma_t, albedo, g).unwrap();
        let sol = DiffusionSolver::new().solve(&rbfs, &medium, &src, &opts);
        assert!(all_finite(&sol), "{medium:?}: {sol:?}");
        assert!(sol.iterations <= 300);
        for l in n - 5..n {
            assert_eq!(sol.l0[l], [0.0; 3], "inactive RBF {l} lit");
        }
        if sigma_t == 0.0 {
            assert!(sol.l0.iter().flatten().all(|&v| v == 0.0) && sol.converged);
        }
        let sh = ms_source_sh(&rbfs, &medium, &src, &sol.l0);
        assert!(sh.iter().flatten().flatten().all(|v| v.is_finite()));
    }
    // Albedo 0 and no source: nothing to diffuse.
    let medium = Medium::new(5.0, 0.0, 0.0).unwrap();
    let sol = DiffusionSolver::new().solve(&rbfs, &medium, &Sources::zeros(n), &opts);
    assert!(sol.converged && sol.l0.iter().flatten().all(|&v| v == 0.0));
    // No RBFs at all.
    let sol = DiffusionSolver::new().solve(&[], &medium, &Sources::zeros(0), &opts);
    assert!(sol.l0.is_empty() && sol.converged && sol.residual == 0.0);
    assert!(ms_source_sh(&[], &medium, &Sources::zeros(0), &[]).is_empty());
}

/// Frame to frame, at a tolerance matched to rendering (1e-4): the same set with sources
/// changed by 1 %, and a set that lost 10 RBFs, moved the rest by up to 0.002 and gained 5,
/// both start from the previous frame and need fewer iterations than from zero.
#[test]
fn solver_warm_starts_from_the_previous_frame() {
    let rbfs = realistic(31, 300);
    let n = rbfs.len();
    let mut rng = Rng::new(2);
    let src = random_sources(&mut rng, n);
    let opts = SolveOptions {
        max_iterations: 3000,
        tolerance: 1e-4,
    };
    let mut solver = DiffusionSolver::new();
    let first = solver.solve(&rbfs, &MEDIUM, &src, &opts);
    assert!(first.converged, "{first:?}");

    let mut next = src.clone();
    next.j0
        .iter_mut()
        .flatten()
        .for_each(|v| *v *= 1.0 + rng.uniform(-0.01, 0.01));
    let cold_same = DiffusionSolver::new().solve(&rbfs, &MEDIUM, &next, &opts);
    let warm_same = solver.solve(&rbfs, &MEDIUM, &next, &opts);
    assert!(warm_same.converged && cold_same.converged);
    assert!(
        warm_same.iterations < cold_same.iterations,
        "{warm_same:?} {cold_same:?} {first:?}"
    );

    let mut moved: Vec<Rbf> = rbfs[10..]
        .iter()
        .map(|b| {
            let c = b.center.map(|c| c + rng.uniform(-0.002, 0.002));
            Rbf::new(c, b.radius, b.weight)
        })
        .collect();
    moved.extend(realistic(77, 5));
    let extra = random_sources(&mut rng, 5);
    let moved_src = Sources {
        j0: [&next.j0[10..], &extra.j0[..]].concat(),
        j1: [&next.j1[10..], &extra.j1[..]].concat(),
        escape: [&next.escape[10..], &extra.escape[..]].concat(),
    };
    let cold = DiffusionSolver::new().solve(&moved, &MEDIUM, &moved_src, &opts);
    let warm = solver.solve(&moved, &MEDIUM, &moved_src, &opts);
    assert!(warm.converged && cold.converged);
    assert!(warm.iterations < cold.iterations);
    eprintln!(
        "warm start (tolerance 1e-4): same set {} vs cold {}; changed set {} vs cold {}",
        warm_same.iterations, cold_same.iterations, warm.iterations, cold.iterations
    );
}
