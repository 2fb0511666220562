use super::*;
use crate::env::Environment;
use crate::lights::Sun;
use crate::render::crm::VolumeGrids;
use haze_volume::{Bbox, Volume};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn grid(dims: [usize; 3], h: [f64; 3], density: Vec<f64>) -> CoarseGrid {
    CoarseGrid {
        dims,
        factor: 1,
        h,
        origin: [0.0; 3],
        density,
    }
}

/// A line of cells with a step source and uniform escape `p` against the closed form of
/// `κ'L'' − σ D L + S = 0` with zero flux at both ends (no neighbours there):
/// `L = (S/σD)(1 − cosh(kx)/(2 cosh(kW/2)))` on the lit half, `(S/σD) cosh(k(W − x))/
/// (2 cosh(kW/2))` on the other, `k² = σD/κ'`, `κ' = (1 − p)/(3σtr D)`, `σ = σa + σs p`.
#[test]
fn line_matches_the_closed_form() {
    let medium = Medium::new(2.0, 0.6, 0.3).unwrap();
    let (n, w, d, p, j0) = (200usize, 4.0, 1.5, 0.2, 1.0);
    let h = w / n as f64;
    // Wide cells across the line: no neighbours there, so the system is one-dimensional.
    let g = grid([n, 1, 1], [h, 7.0, 3.0], vec![d; n]);
    let mut src = Sources::zeros(n);
    for l in 0..n / 2 {
        src.j0[l] = [j0, 0.5 * j0, 0.0];
    }
    let sys = FvSystem::new(&g, &medium, &src, &vec![p; n]).unwrap();
    let sol = solve(
        &sys,
        None,
        &GridSolveOptions {
            max_iterations: 5000,
            tolerance: 1e-12,
        },
    );
    let (st, ss, sa) = (2.0, 1.2, 0.8);
    let str_ = (1.0 - 0.6 * 0.3) * st;
    let sink = (sa + ss * p) * d;
    let kappa = (1.0 - p) / (3.0 * str_ * d);
    let k = (sink / kappa).sqrt();
    let s = st * d * (1.0 - p) * j0;
    let c = (k * w / 2.0).cosh();
    for (l, v) in sol.l0.iter().enumerate() {
        let x = (l as f64 + 0.5) * h;
        let exact = if x < w / 2.0 {
            s / sink * (1.0 - (k * x).cosh() / (2.0 * c))
        } else {
            s / sink * (k * (w - x)).cosh() / (2.0 * c)
        };
        assert!(
            (v[0] - exact).abs() < 2e-3 * s / sink,
            "cell {l}: {} vs {exact}",
            v[0]
        );
        assert!((v[1] - 0.5 * v[0]).abs() < 1e-9 * s / sink);
        assert_eq!(v[2], 0.0);
    }
}

/// The conjugate gradient against a dense LU solve of the same operator, on a small grid
/// of random densities, sources, fluxes and escape probabilities.
#[test]
fn cg_matches_a_dense_solve() {
    let mut rng = Pcg64::seed_from_u64(7);
    let mut rnd = || rng.random::<f64>();
    let dims = [5, 4, 3];
    let n = 60;
    let density: Vec<f64> = (0..n)
        .map(|_| if rnd() < 0.2 { 0.0 } else { 2.0 * rnd() })
        .collect();
    let g = grid(dims, [0.3, 0.25, 0.4], density);
    let mut src = Sources::zeros(n);
    for l in 0..n {
        src.j0[l] = [rnd(), rnd(), rnd()];
        src.j1[l] = [[rnd() - 0.5, rnd() - 0.5, rnd() - 0.5]; 3];
    }
    let esc: Vec<f64> = (0..n).map(|_| 0.05 + 0.9 * rnd()).collect();
    let medium = Medium::new(3.0, 0.95, 0.5).unwrap();
    let sys = FvSystem::new(&g, &medium, &src, &esc).unwrap();
    let m = sys.n();
    let mut dense = nalgebra::DMatrix::zeros(m, m);
    let mut e = vec![[0.0; 3]; m];
    let mut col = vec![[0.0; 3]; m];
    for k in 0..m {
        e[k] = [1.0; 3];
        sys.apply(&e, &mut col);
        for r in 0..m {
            dense[(r, k)] = col[r][0];
        }
        e[k] = [0.0; 3];
    }
    assert!(
        (dense.clone() - dense.transpose()).abs().max() < 1e-12,
        "not symmetric"
    );
    let lu = dense.lu();
    let sol = solve(
        &sys,
        None,
        &GridSolveOptions {
            max_iterations: 1000,
            tolerance: 1e-12,
        },
    );
    for c in 0..3 {
        let b = nalgebra::DVector::from_fn(m, |k, _| sys.b[k][c]);
        let x = lu.solve(&b).unwrap();
        for k in 0..m {
            assert!((sol.l0[k][c] - x[k]).abs() < 1e-8 * x.amax(), "{k} {c}");
        }
    }
}

/// `P` at the center of a box filled uniformly against a fine quadrature of
/// `exp(−σt D ℓ(ω))`, `ℓ` the exact distance to the box's face.
#[test]
fn escape_matches_quadrature() {
    let (dims, h, d, st) = ([9, 9, 9], [0.1; 3], 1.3, 2.0);
    let g = grid(dims, h, vec![d; 729]);
    let p = escape(&g, st, &fibonacci_directions(2048));
    let x = g.center([4, 4, 4]);
    let (nt, np) = (400, 800);
    let mut q = 0.0;
    for it in 0..nt {
        let th = (it as f64 + 0.5) * std::f64::consts::PI / nt as f64;
        for ip in 0..np {
            let ph = (ip as f64 + 0.5) * 2.0 * std::f64::consts::PI / np as f64;
            let w = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            let len = (0..3)
                .filter(|&a| w[a] != 0.0)
                .map(|a| {
                    if w[a] > 0.0 {
                        (0.9 - x[a]) / w[a]
                    } else {
                        -x[a] / w[a]
                    }
                })
                .fold(f64::INFINITY, f64::min);
            q += (-st * d * len).exp() * th.sin();
        }
    }
    q *= (std::f64::consts::PI / nt as f64) * (2.0 * std::f64::consts::PI / np as f64)
        / (4.0 * std::f64::consts::PI);
    let c = g.index([4, 4, 4]);
    assert!((p[c] - q).abs() < 2e-3 * q, "{} vs {q}", p[c]);
    // Empty cells and σt = 0.
    let e = escape(
        &grid([2, 2, 2], h, vec![0.0; 8]),
        st,
        &fibonacci_directions(8),
    );
    assert_eq!(e, vec![1.0; 8]);
    assert!(
        escape(&g, 0.0, &fibonacci_directions(8))
            .iter()
            .all(|&v| v == 1.0)
    );
}

/// Deep inside a thick uniform box the solution is the local balance
/// `(1 − P) J⁰ / (1 − Ω (1 − P)) → J⁰/(1 − Ω)` (`P → 0`), also at Ω = 1 where it grows
/// without bound in the size but stays finite.
#[test]
fn thick_smoke_reaches_the_local_balance() {
    let n = 11;
    let g = grid([n, n, n], [0.1; 3], vec![1.0; n * n * n]);
    let mut src = Sources::zeros(n * n * n);
    src.j0 = vec![[1.0, 2.0, 0.0]; n * n * n];
    for (albedo, sigma_t) in [(0.8, 400.0), (1.0, 400.0), (0.8, 1e9)] {
        let medium = Medium::new(sigma_t, albedo, 0.4).unwrap();
        let p = escape(&g, medium.sigma_t, &fibonacci_directions(DIRECTIONS));
        let ms = media_radiance(g.clone(), &medium, &src, &p, &GridSolveOptions::default());
        let center = ms.l0[g.index([5, 5, 5])];
        assert!(ms.l0.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        if albedo < 1.0 {
            let balance = 1.0 / (1.0 - albedo);
            assert!((center[0] - balance).abs() < 1e-3 * balance, "{center:?}");
            assert!((center[1] - 2.0 * balance).abs() < 1e-3 * balance);
        } else {
            assert!(center[0] > 50.0, "{center:?}");
        }
        assert_eq!(center[2], 0.0);
    }
}

/// A volume grid of one blob lit by a sun, the sky of radiance `sky`.
pub(super) fn blob(sky: [f64; 3]) -> (VolumeGrids, Environment) {
    let n = 12;
    let bbox = Bbox::new([0.0; 3], [1.0; 3]);
    let data: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let c = [i % n, i / n % n, i / (n * n)].map(|a| (a as f64 + 0.5) / n as f64 - 0.5);
            (1.0 - 6.0 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2])).max(0.0) as f32
        })
        .collect();
    let grids = VolumeGrids {
        density: Volume::new([n; 3], bbox, data).unwrap(),
        radiance: vec![[0.0; 3]; n * n * n],
        eye_peak: 0.0,
    };
    let mut env = Environment::constant(sky);
    env.suns.push(Sun {
        direction: [0.0, 0.6, 0.8],
        irradiance: [3.0, 2.0, 1.0],
        angle: 0.01,
    });
    (grids, env)
}

/// The extremes every multiple-scattering model of `grids` must meet, `run` giving its
/// radiance per cell or voxel for a medium: light where the smoke is lit; nothing
/// without albedo, extinction or smoke; finite and non-negative at σt = 1e12.
pub(super) fn check_extremes<T: Copy + Into<f64>>(
    grids: &VolumeGrids,
    run: impl Fn(&VolumeGrids, &Medium) -> Vec<[T; 3]>,
) {
    let values = |grids: &VolumeGrids, m: &Medium| -> Vec<f64> {
        run(grids, m)
            .into_iter()
            .flatten()
            .map(Into::into)
            .collect()
    };
    let lit = values(grids, &Medium::new(8.0, 0.9, 0.5).unwrap());
    assert!(lit.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(lit.iter().any(|&v| v > 0.0));
    for m in [
        Medium::new(8.0, 0.0, 0.5).unwrap(),
        Medium::new(0.0, 0.9, 0.5).unwrap(),
    ] {
        assert!(values(grids, &m).iter().all(|&v| v == 0.0));
    }
    let huge = values(grids, &Medium::new(1e12, 1.0, 0.9).unwrap());
    assert!(huge.iter().all(|v| v.is_finite() && *v >= 0.0));
    let mut empty = grids.clone();
    empty.density.data_mut().iter_mut().for_each(|v| *v = 0.0);
    assert!(
        values(&empty, &Medium::new(8.0, 0.9, 0.5).unwrap())
            .iter()
            .all(|&v| v == 0.0)
    );
}

/// Extremes: no smoke, no albedo and no extinction add nothing; huge σt stays finite.
#[test]
fn extremes_stay_finite() {
    let (grids, env) = blob([0.0; 3]);
    let eye = [0.5, -3.0, 0.5];
    let run = |grids: &VolumeGrids, medium: &Medium| {
        let n = grids.radiance.len();
        let mut g = grids.clone();
        let ms = frame_media_radiance(
            &g,
            &[],
            &Sources::zeros(0),
            &env,
            medium,
            2,
            &GridSolveOptions::default(),
        );
        add_to_grids(&mut g, &ms, medium, eye);
        assert_eq!(g.radiance.len(), n);
        g.radiance
    };
    check_extremes(&grids, run);
}

/// A 16 × 16 × 20 grid with smoke (density 1) in every third voxel: far within the
/// gathers' budget even on cells of one voxel.
fn sparse_smoke() -> Volume {
    Volume::new(
        [16, 16, 20],
        Bbox::new([0.0; 3], [1.0; 3]),
        (0..16 * 16 * 20)
            .map(|i| if i % 3 == 0 { 1.0 } else { 0.0 })
            .collect(),
    )
    .unwrap()
}

/// The automatic cell size: 2 for a small plume; for a 128³ box full of smoke the
/// smallest F whose work `⌈128/F⌉³ · ⌈128/F⌉` (every cell has smoke, the box is the
/// grid) is within the budget, counted here independently of `gather_work`; and the
/// gathered orders on it keep that factor.
#[test]
fn the_automatic_cell_size_follows_the_amount_of_smoke() {
    let small = sparse_smoke();
    assert_eq!(auto_grid(&small, 1.0, 0.0).factor, 2);
    let n = 128usize;
    let full = Volume::new([n; 3], Bbox::new([0.0; 3], [1.0; 3]), vec![0.5; n * n * n]).unwrap();
    let expected = (2..=8)
        .find(|&f| (n.div_ceil(f) as f64).powi(4) <= GATHER_BUDGET)
        .unwrap_or(8);
    assert!(expected > 2, "the test needs a volume over the budget");
    let grid = auto_grid(&full, 1.0, 0.0);
    assert_eq!(grid.factor, expected);
    assert_eq!(gather_work(&grid), (n.div_ceil(expected) as f64).powi(4));
    // No smoke: no work, the default size.
    let empty = Volume::new([8; 3], Bbox::new([0.0; 3], [1.0; 3]), vec![0.0; 512]).unwrap();
    assert_eq!(gather_work(&CoarseGrid::new(&empty, 2)), 0.0);
    assert_eq!(auto_grid(&empty, 1.0, 0.0).factor, 2);
    // A lower detail: at least ⌈2/detail⌉ voxels a side, and the budget times detail⁴.
    assert_eq!(auto_grid(&small, 0.5, 0.0).factor, 4);
    assert_eq!(auto_grid(&small, 0.3, 0.0).factor, 7);
    assert_eq!(auto_grid(&small, 1e-6, 0.0).factor, 8);
    let half = (4..=8)
        .find(|&f| (n.div_ceil(f) as f64).powi(4) <= GATHER_BUDGET / 16.0)
        .unwrap_or(8);
    assert!(half > expected, "{half} {expected}");
    assert_eq!(auto_grid(&full, 0.5, 0.0).factor, half);
    // An invalid detail lights as detail 1.
    for bad in [0.0, -1.0, 2.0, f64::NAN, f64::INFINITY] {
        assert_eq!(auto_grid(&full, bad, 0.0).factor, expected, "{bad}");
    }
}

/// Below full detail the orders fall with it, rounded up, never under four nor over those
/// asked; full detail and an invalid one keep them all.
#[test]
fn a_lower_detail_gathers_fewer_orders() {
    assert_eq!(orders_at_detail(6, 1.0), 6);
    assert_eq!(orders_at_detail(6, 0.75), 5);
    // 6 × 0.5 is 3 exactly: not rounded up past it, then raised to the least.
    assert_eq!(orders_at_detail(6, 0.5), MIN_DETAIL_ORDERS);
    assert_eq!(orders_at_detail(6, 0.43), MIN_DETAIL_ORDERS);
    assert_eq!(orders_at_detail(8, 0.6), 5);
    assert_eq!(orders_at_detail(8, 0.9), 8);
    // Fewer asked than the least: kept.
    assert_eq!(orders_at_detail(2, 0.25), 2);
    assert_eq!(orders_at_detail(1, 0.5), 1);
    for bad in [0.0, -1.0, 2.0, f64::NAN, f64::INFINITY] {
        assert_eq!(orders_at_detail(6, bad), 6, "{bad}");
    }
}

/// Thick smoke: cells of one voxel at full detail where cells of two would be more than
/// `MAX_ORDERS_CELL_TAU` across (voxels over 1/3 optical depth) and their work is within
/// the budget; cells of 2 at the edge and below it, for a NaN thickness and at a lower
/// detail; the budget's cells where one voxel would cost more.
#[test]
fn thick_smoke_takes_cells_of_one_voxel_within_the_budget() {
    let small = sparse_smoke();
    let edge = MAX_ORDERS_CELL_TAU / 2.0;
    for (tau, want) in [
        (0.0, 2),
        (edge, 2),
        (edge * 1.001, 1),
        (0.42, 1),
        (f64::INFINITY, 1),
        (f64::NAN, 2),
        (-1.0, 2),
    ] {
        assert_eq!(auto_grid(&small, 1.0, tau).factor, want, "tau {tau}");
    }
    assert!(gather_work(&CoarseGrid::new(&small, 1)) <= GATHER_BUDGET);
    assert_eq!(auto_grid(&small, 0.5, 0.42).factor, 4);
    // Over the budget at one voxel: the thin smoke's choice.
    let n = 128usize;
    let full = Volume::new([n; 3], Bbox::new([0.0; 3], [1.0; 3]), vec![0.5; n * n * n]).unwrap();
    assert!(gather_work(&CoarseGrid::new(&full, 1)) > GATHER_BUDGET);
    assert_eq!(
        auto_grid(&full, 1.0, 0.42).factor,
        auto_grid(&full, 1.0, 0.0).factor
    );
    // Between: one voxel over the budget, two within it.
    let mid = 48usize;
    let middle = Volume::new(
        [mid; 3],
        Bbox::new([0.0; 3], [1.0; 3]),
        vec![0.5; mid.pow(3)],
    )
    .unwrap();
    assert!(gather_work(&CoarseGrid::new(&middle, 1)) > GATHER_BUDGET);
    assert!(gather_work(&CoarseGrid::new(&middle, 2)) <= GATHER_BUDGET);
    assert_eq!(auto_grid(&middle, 1.0, 0.42).factor, 2);
}

/// `density` refined `n` times per axis by repeating each voxel (`n³` copies).
fn repeated(density: &Volume, n: usize) -> Volume {
    let d = density.dims();
    let fine = d.map(|a| a * n);
    let mut data = Vec::with_capacity(fine.iter().product());
    for z in 0..fine[2] {
        for y in 0..fine[1] {
            for x in 0..fine[0] {
                data.push(density.get(x / n, y / n, z / n));
            }
        }
    }
    Volume::new(fine, *density.bbox(), data).unwrap()
}

/// The GPU's rule ([`one_voxel_cells`]) agrees with [`auto_grid`]'s choice of one voxel
/// at full detail: on the grid itself, and on a grid refined 2× (each voxel repeated, so
/// the refined grid's own work, counted by `auto_grid`, is exactly 16× the coarse one's)
/// whose one-voxel cells go over the budget where the coarse grid's did not.
#[test]
fn the_gpu_rule_takes_one_voxel_where_the_cpu_does() {
    let n = 32usize;
    let middle = Volume::new(
        [n; 3],
        Bbox::new([0.0; 3], [1.0; 3]),
        (0..n.pow(3))
            .map(|i| if i % 3 == 0 { 0.5 } else { 0.0 })
            .collect(),
    )
    .unwrap();
    let small = sparse_smoke();
    let edge = MAX_ORDERS_CELL_TAU / 2.0;
    for density in [&small, &middle] {
        for tau in [0.0, edge, edge * 1.001, 0.42, f64::INFINITY, f64::NAN, -1.0] {
            assert_eq!(
                one_voxel_cells(density, 1, tau),
                auto_grid(density, 1.0, tau).factor == 1,
                "{:?} tau {tau}",
                density.dims()
            );
            let fine = repeated(density, 2);
            assert_eq!(
                one_voxel_cells(density, 2, tau),
                auto_grid(&fine, 1.0, tau).factor == 1,
                "{:?} refined, tau {tau}",
                density.dims()
            );
        }
    }
    // The cases the test needs: within the budget on the grid, over it refined.
    assert!(one_voxel_cells(&middle, 1, 0.42));
    assert!(!one_voxel_cells(&middle, 2, 0.42));
}

#[test]
fn the_first_orders_rule_follows_the_phase_functions_peak() {
    use crate::medium::hg_half_width;
    let spacing = |theta: usize| std::f64::consts::FRAC_PI_2 / theta as f64;
    // The rule's spacing within `SPACING_PER_WIDTH` of HG's full width, and one latitude
    // fewer not, between the bounds.
    let mut last = GATHER_THETA;
    for k in 0..=99 {
        let g = 0.01 * k as f64;
        let theta = gather_theta(g);
        assert!(
            (GATHER_THETA..=GATHER_THETA_MAX).contains(&theta),
            "g {g}: {theta}"
        );
        assert!(theta >= last, "g {g}: {theta} after {last}");
        last = theta;
        let Some(half) = hg_half_width(g) else {
            assert_eq!(theta, GATHER_THETA, "g {g}");
            continue;
        };
        let allowed = SPACING_PER_WIDTH * 2.0 * half;
        if theta < GATHER_THETA_MAX {
            assert!(spacing(theta) <= allowed + 1e-12, "g {g}: {theta}");
        }
        if theta > GATHER_THETA {
            assert!(spacing(theta - 1) > allowed, "g {g}: {theta}");
        }
    }
    // The values the docs give: 72 directions up to g ≈ 0.74, 128 at 0.8, 288 from 0.85.
    for (g, theta) in [
        (0.5, 3),
        (0.7, 3),
        (0.74, 3),
        (0.76, 4),
        (0.8, 4),
        (0.85, 6),
    ] {
        assert_eq!(gather_theta(g), theta, "g {g}");
    }
    for g in [0.0, -0.8, f64::NAN, f64::NEG_INFINITY] {
        assert_eq!(gather_theta(g), GATHER_THETA, "g {g}");
    }
    for g in [0.95, 0.999, 1.0, f64::INFINITY] {
        assert_eq!(gather_theta(g), GATHER_THETA_MAX, "g {g}");
    }
}

/// Below full detail the first order takes the environment pass's rule at that detail
/// (32 directions at 2/3 and below) unless HG's peak asks for more; never more than at
/// full detail, and the peak's criterion holds wherever the rule is below its cap.
#[test]
fn the_first_orders_rule_at_a_lower_detail() {
    use crate::medium::hg_half_width;
    let spacing = |theta: usize| std::f64::consts::FRAC_PI_2 / theta as f64;
    for k in 0..=99 {
        let g = 0.01 * k as f64;
        assert_eq!(first_theta(g, 1.0), gather_theta(g), "g {g}");
        for detail in [0.2, 0.43, 0.5, 0.6, 0.7, 0.9] {
            let theta = first_theta(g, detail);
            assert!(theta <= gather_theta(g), "g {g}, detail {detail}: {theta}");
            let env = if detail <= 2.0 / 3.0 { 2 } else { 3 };
            assert!(theta >= env, "g {g}, detail {detail}: {theta}");
            if let Some(half) = hg_half_width(g)
                && theta < GATHER_THETA_MAX
            {
                let allowed = SPACING_PER_WIDTH * 2.0 * half;
                assert!(spacing(theta) <= allowed + 1e-12, "g {g}, detail {detail}");
            }
        }
    }
    for (g, detail, theta) in [
        (0.3, 0.43, 2),
        (0.5, 0.5, 2),
        (0.3, 0.7, 3),
        (0.7, 0.43, 3),
        (0.8, 0.43, 4),
        (0.9, 0.25, GATHER_THETA_MAX),
        (0.3, f64::NAN, GATHER_THETA),
        (0.3, 0.0, GATHER_THETA),
        (f64::NAN, 0.43, GATHER_LATER_THETA),
    ] {
        assert_eq!(first_theta(g, detail), theta, "g {g}, detail {detail}");
    }
}

/// `corners` reproduces a linear function of the cell centers at every point between the
/// first and last centers (trilinear interpolation is exact on linear functions), takes
/// the nearest centers' value in the outer half cells, and answers `None` outside the
/// box; `corners_at` of the cell coordinates a march steps gives the same cells and
/// weights.
#[test]
fn the_corners_interpolate_a_linear_field() {
    let g = CoarseGrid {
        dims: [5, 3, 4],
        factor: 2,
        h: [0.5, 0.25, 1.0],
        origin: [-1.0, 2.0, 0.5],
        density: vec![1.0; 60],
    };
    let f = |p: [f64; 3]| 0.3 + 1.7 * p[0] - 2.1 * p[1] + 0.6 * p[2];
    let mut rng = Pcg64::seed_from_u64(11);
    for _ in 0..500 {
        let u: [f64; 3] = std::array::from_fn(|_| rng.random_range(-0.05..1.05));
        let p = [0, 1, 2].map(|a| g.origin[a] + u[a] * g.h[a] * g.dims[a] as f64);
        let corners = g.corners(p);
        if u.iter().any(|&u| !(0.0..=1.0).contains(&u)) {
            assert!(corners.is_none(), "{p:?} is outside the box");
            continue;
        }
        let corners = corners.unwrap();
        // The point clamped to the centers' hull: the outer half cells are constant.
        let lo = g.center([0, 0, 0]);
        let hi = g.center([4, 2, 3]);
        let q = [0, 1, 2].map(|a| p[a].clamp(lo[a], hi[a]));
        let sum: f64 = corners.iter().map(|&(_, w)| w).sum();
        let value: f64 = corners
            .iter()
            .map(|&(i, w)| w * f(g.center(g.coords(i))))
            .sum();
        assert!((sum - 1.0).abs() < 1e-12, "weights sum to {sum}");
        assert!((value - f(q)).abs() < 1e-12, "{value} against {}", f(q));
        let c = [0, 1, 2].map(|a| (p[a] - g.origin[a]) / g.h[a] - 0.5);
        assert_eq!(g.corners_at(c), Some(corners));
    }
}
