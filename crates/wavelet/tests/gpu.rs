//! The GPU renderer against its CPU twin, by values: optical depths of chosen rays (every
//! basis, several levels and µ, rays grazing the layer's top and bottom, rays along cell
//! edges and through grid corners, from inside the fog) and whole images.
//!
//! The tests need a GPU device (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail, not skip, without one.
//!
//! Tolerances: the GPU computes in `f32` (unit roundoff `ε = 6e-8`) what the CPU computes
//! in `f64`. Along a ray of length `T` the grid-line crossings `t` are off by about `ε·T`,
//! which moves integrand between neighbouring cells (a continuous integrand barely
//! notices; Haar's jumps shift by `|Δc|·ε·T`), and each cell's sum of products of pieces
//! and moments is off by a few `ε` of its magnitude; the relative errors add up over the
//! cells crossed, so the optical depth is off by a small multiple of
//! `ε · density · max|A_l| · T`. The tests allow `3e-6 · density · (1 + T)` (`max|A_l|` is
//! about 1.3 here): some 50 `ε`, 25 times the worst error measured (`1.2e-7`, printed by
//! the first test). Rays along cell edges start exactly on a grid line in both precisions
//! (the coordinates are exact in binary), so both sides take the same row of cells.

use haze_camera::LookAt;
use haze_gpu::GpuContext;
use haze_wavelet::gpu::fog::{FogRenderer, RayQuery};
use haze_wavelet::lod::{Fog, Mode, Settings};
use haze_wavelet::render::{self, Scene, SmokeSample};
use haze_wavelet::{Basis, Grid, Placement};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// The GPU device; panics with the reason when there is none, so the tests fail.
fn context() -> GpuContext {
    match GpuContext::new() {
        Ok(ctx) => {
            println!("GPU adapter: {} ({})", ctx.adapter_name(), ctx.backend());
            ctx
        }
        Err(e) => panic!("{e}"),
    }
}

/// A 12 × 10 fogmap: random values, a clear band and a sharp-edged block (so that linear
/// and quadratic approximations dip below zero and the floors matter).
fn fogmap() -> Grid {
    let mut rng = Pcg64::seed_from_u64(19);
    let (nx, ny) = (12, 10);
    let mut g = Grid::zeros(0, 0, nx, ny);
    for y in 0..ny {
        for x in 0..nx {
            let v = if y == 3 {
                0.0
            } else if (7..10).contains(&x) && (5..8).contains(&y) {
                1.0
            } else {
                rng.random_range(0.0..0.6)
            };
            g.data[y * nx + x] = v;
        }
    }
    g
}

const PLACEMENT: Placement = Placement {
    origin: [-7.0, 4.0],
    cell: 1.5,
    density: 0.4,
    bottom: 0.5,
    top: 4.0,
    falloff: 0.3,
};

fn fog(basis: Basis, levels: usize, mu: f64, placement: Placement, min_t: f64) -> Fog {
    let settings = Settings {
        mu,
        mode: Mode::Deconstructed,
        min_transmittance: min_t,
    };
    Fog::new(&fogmap(), basis, levels, placement, settings).unwrap()
}

/// World x (or y, with `axis` 1) of finest grid line `k` for degree `d`.
fn grid_line(p: &Placement, d: usize, axis: usize, k: f64) -> f64 {
    p.origin[axis] + (k - d as f64 / 2.0) * p.cell
}

/// The rays of the comparison, in world space, for a fog of degree `d` and `levels`.
fn rays(p: &Placement, d: usize, levels: usize) -> Vec<RayQuery> {
    let mut rng = Pcg64::seed_from_u64(7);
    let mut out = Vec::new();
    let (x0, x1) = (p.origin[0], p.origin[0] + 12.0 * p.cell);
    let (y0, y1) = (p.origin[1], p.origin[1] + 10.0 * p.cell);
    // From above and outside: to random ground points and sky rays through the layer.
    for _ in 0..24 {
        let from = [
            rng.random_range(x0 - 10.0..x1 + 10.0),
            rng.random_range(y0 - 10.0..y1 + 10.0),
            rng.random_range(p.top + 0.5..p.top + 8.0),
        ];
        let to = [
            rng.random_range(x0 - 2.0..x1 + 2.0),
            rng.random_range(y0 - 2.0..y1 + 2.0),
            0.0,
        ];
        out.push(RayQuery::Segment { from, to });
        let dir = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-0.6..-0.05),
        ];
        out.push(RayQuery::ToExit { from, dir });
    }
    // A camera inside the fog: segments and rays to the fog's exit in every direction.
    let inside = [x0 + 7.3, y0 + 6.1, p.bottom + 1.7];
    for _ in 0..16 {
        let dir = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-0.5..0.5),
        ];
        out.push(RayQuery::ToExit { from: inside, dir });
        let to = [
            inside[0] + 8.0 * dir[0],
            inside[1] + 8.0 * dir[1],
            inside[2] + 8.0 * dir[2],
        ];
        out.push(RayQuery::Segment { from: inside, to });
    }
    // Grazing the top and the bottom: horizontal on them, and shallow through them.
    for z in [p.top, p.bottom, p.top - 1e-3, p.bottom + 1e-3] {
        let from = [x0 - 5.0, y0 + 4.2, z];
        out.push(RayQuery::ToExit {
            from,
            dir: [1.0, 0.3, 0.0],
        });
    }
    out.push(RayQuery::ToExit {
        from: [x0 - 5.0, y0 + 5.3, p.top + 0.02],
        dir: [1.0, 0.1, -0.004],
    });
    out.push(RayQuery::Segment {
        from: [x0 - 5.0, y0 + 5.3, p.bottom - 0.02],
        to: [x1 + 5.0, y0 + 6.1, p.bottom + 0.03],
    });
    // Along cell edges of the coarsest level (so of every level), which are exact in
    // binary: horizontal and sloping down, along x and along y.
    let step = f64::from(1u32 << levels);
    for k in [1.0, 2.0, 3.0] {
        let y = grid_line(p, d, 1, k * step);
        let x = grid_line(p, d, 0, k * step);
        let z = p.bottom + 1.0;
        out.push(RayQuery::ToExit {
            from: [x0 - 4.0, y, z],
            dir: [1.0, 0.0, 0.0],
        });
        out.push(RayQuery::ToExit {
            from: [x, y1 + 3.0, p.top + 1.0],
            dir: [0.0, -1.0, -0.25],
        });
    }
    // Through grid corners diagonally (both crossings at once).
    let (cx, cy) = (grid_line(p, d, 0, 0.0), grid_line(p, d, 1, 0.0));
    out.push(RayQuery::ToExit {
        from: [cx, cy, p.bottom + 2.0],
        dir: [1.0, 1.0, 0.0],
    });
    // Degenerate: zero length, zero direction, outside the fog entirely.
    out.push(RayQuery::Segment {
        from: [0.0, 9.0, 1.0],
        to: [0.0, 9.0, 1.0],
    });
    out.push(RayQuery::ToExit {
        from: [0.0, 9.0, 1.0],
        dir: [0.0; 3],
    });
    out.push(RayQuery::ToExit {
        from: [x1 + 3.0, y0, 2.0],
        dir: [1.0, 0.0, 0.0],
    });
    out
}

fn cpu_depth(fog: &Fog, r: &RayQuery) -> f64 {
    match *r {
        RayQuery::Segment { from, to } => fog.optical_depth(from, to),
        RayQuery::ToExit { from, dir } => fog.optical_depth_ray(from, dir),
    }
}

/// `∫|f| h` along a ray, in coefficient units: the tolerance's scale (the same fog with
/// the absolute value of every coefficient is not needed: the path length bounds it).
fn path_length(r: &RayQuery) -> f64 {
    let (from, far) = match *r {
        RayQuery::Segment { from, to } => (from, to),
        RayQuery::ToExit { from, dir } => (
            from,
            [
                from[0] + 60.0 * dir[0],
                from[1] + 60.0 * dir[1],
                from[2] + 60.0 * dir[2],
            ],
        ),
    };
    let v = [far[0] - from[0], far[1] - from[1], far[2] - from[2]];
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    len.min(60.0)
}

#[test]
fn optical_depths_match_the_cpu_for_every_basis_level_and_mu() {
    let ctx = context();
    let gpu = FogRenderer::new(&ctx).unwrap();
    let mut worst = (0.0, String::new());
    let mut nonzero = 0;
    for basis in [Basis::Haar, Basis::Linear, Basis::Quadratic] {
        for (levels, mu) in [(0, 1.0), (2, 1.0), (2, 0.6), (4, 0.75), (4, 0.0), (3, 0.3)] {
            for falloff in [0.3, 0.0] {
                let p = Placement {
                    falloff,
                    ..PLACEMENT
                };
                let fog = fog(basis, levels, mu, p, 0.0);
                let up = gpu.upload(&ctx, &fog).unwrap();
                let queries = rays(&p, basis.degree(), levels);
                let got = gpu.optical_depths(&ctx, &up, &queries).unwrap();
                assert_eq!(got.len(), queries.len());
                for (q, g) in queries.iter().zip(&got) {
                    let want = cpu_depth(&fog, q);
                    let scale = p.density * (1.0 + path_length(q));
                    let err = (g - want).abs() / scale;
                    if err > worst.0 {
                        worst = (
                            err,
                            format!(
                                "{basis} L={levels} µ={mu} k={falloff} {q:?}: GPU {g} CPU {want}"
                            ),
                        );
                    }
                    nonzero += usize::from(want.abs() > 1e-3);
                }
            }
        }
    }
    println!(
        "worst |GPU − CPU| / (density·(1 + length)): {:e} at {}",
        worst.0, worst.1
    );
    assert!(worst.0 <= 3e-6, "{}: {:e}", worst.1, worst.0);
    // Most rays do cross fog: the comparison is not of zeros.
    assert!(nonzero > 3 * 6 * 2 * 60, "{nonzero} rays with fog");
}

#[test]
fn early_exit_stops_like_the_cpu() {
    let ctx = context();
    let gpu = FogRenderer::new(&ctx).unwrap();
    let min_t: f64 = 1.0 / 1024.0;
    let dense = Placement {
        density: 6.0,
        falloff: 0.0,
        ..PLACEMENT
    };
    let stop = -min_t.ln();
    let (mut stopped, mut same, mut total) = (0, 0, 0);
    for basis in [Basis::Haar, Basis::Linear, Basis::Quadratic] {
        let full = fog(basis, 3, 0.8, dense, 0.0);
        let early = fog(basis, 3, 0.8, dense, min_t);
        let up = gpu.upload(&ctx, &early).unwrap();
        let queries = rays(&dense, basis.degree(), 3);
        let got = gpu.optical_depths(&ctx, &up, &queries).unwrap();
        for (q, g) in queries.iter().zip(&got) {
            let exact = cpu_depth(&full, q);
            let cpu = cpu_depth(&early, q);
            let tol = 3e-6 * dense.density * (1.0 + path_length(q));
            if exact < stop * (1.0 - 1e-4) {
                // Never below the threshold: no early exit on either side.
                assert!((g - exact).abs() <= tol, "{basis} {q:?}: {g} vs {exact}");
                continue;
            }
            // Stopped or not, both went on until the transmittance was below the threshold.
            assert!(*g >= stop * (1.0 - 1e-5), "{basis} {q:?}: {g}");
            assert!(cpu >= stop * (1.0 - 1e-9), "{basis} {q:?}: {cpu}");
            // Both stop in the first cell where the sum crosses the goal: the same one,
            // unless f32 puts that crossing in the next cell.
            total += 1;
            same += usize::from((g - cpu).abs() <= tol);
            stopped += usize::from(*g < 0.8 * exact);
        }
    }
    assert!(stopped > 20, "{stopped} rays stopped early");
    assert!(
        same * 10 >= total * 9,
        "{same} of {total} stopped in the same cell"
    );
}

/// CPU transmittance of pixel `(x, y)`, as [`render::shade`] computes it.
fn cpu_pixel_tau(
    fog: &Fog,
    cam: &LookAt,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
) -> (f64, Option<[f64; 2]>) {
    let dir = cam.camera(w, h).unwrap().pixel_ray(x, y);
    let eye = cam.eye;
    if eye[2] > 0.0 && dir[2] < 0.0 {
        let t = -eye[2] / dir[2];
        let p = [eye[0] + t * dir[0], eye[1] + t * dir[1], 0.0];
        ((-fog.optical_depth(eye, p)).exp(), Some([p[0], p[1]]))
    } else {
        ((-fog.optical_depth_ray(eye, dir)).exp(), None)
    }
}

#[test]
fn images_match_the_cpu_renderer() {
    let ctx = context();
    let gpu = FogRenderer::new(&ctx).unwrap();
    let scene = Scene::default();
    let min_t = 1.0 / 1024.0;
    let (w, h) = (40, 30);
    for basis in [Basis::Haar, Basis::Linear, Basis::Quadratic] {
        let fog = fog(basis, 2, 0.6, PLACEMENT, min_t);
        let up = gpu.upload(&ctx, &fog).unwrap();
        let inside = LookAt {
            eye: [2.0, 6.0, 1.6],
            target: [3.0, 20.0, 1.2],
            up: [0.0, 0.0, 1.0],
            fov_deg: 70.0,
        };
        for cam in [render::framing(&fog), inside] {
            let want = render::render(&fog, &cam.camera(w, h).unwrap(), &scene, &|| {});
            let got = gpu.render(&ctx, &up, &cam, &scene, w, h).unwrap();
            assert_eq!(got.len(), w * h);
            let mut foggy = 0;
            for y in 0..h {
                for x in 0..w {
                    let i = y * w + x;
                    let (tau, ground) = cpu_pixel_tau(&fog, &cam, x, y, w, h);
                    let g = got[i];
                    let gt = f64::from(g[3]);
                    // Below the threshold a ray may stop early (on either side): only the
                    // threshold is promised there.
                    if tau < 2.0 * min_t {
                        assert!(gt < 4.0 * min_t, "{basis} ({x}, {y}): τ {gt} vs {tau}");
                    } else {
                        assert!(
                            (gt - tau).abs() <= 1e-5,
                            "{basis} ({x}, {y}): τ {gt} vs {tau}"
                        );
                    }
                    foggy += usize::from(tau < 0.95);
                    // A ground point within f32 rounding of a checker line may take the
                    // other tone: its colour is not compared.
                    let on_line = ground.is_some_and(|p| {
                        p.iter().any(|c| {
                            let r = c / scene.checker;
                            (r - r.round()).abs() < 1e-4
                        })
                    });
                    if on_line {
                        continue;
                    }
                    for c in 0..3 {
                        let e = (f64::from(g[c]) - f64::from(want[i][c])).abs();
                        assert!(
                            e <= 2.0 * min_t + 1e-5,
                            "{basis} ({x}, {y}) channel {c}: {e}"
                        );
                    }
                }
            }
            assert!(foggy > w * h / 10, "{basis}: {foggy} foggy pixels");
        }
    }
}

/// A smoke layer composited by depth: the GPU's pixels are the CPU's
/// (`render::render_over`), for random smoke radiances, transmittances and depths (in
/// front of the fog, inside it, behind the ground), every basis, µ < 1 (whose bands are
/// the whole ray's on both sides of the split), from above and from inside the fog.
#[test]
fn smoke_composited_by_depth_matches_the_cpu() {
    let ctx = context();
    let gpu = FogRenderer::new(&ctx).unwrap();
    let scene = Scene::default();
    let min_t = 1.0 / 1024.0;
    let (w, h) = (40, 30);
    let mut rng = Pcg64::seed_from_u64(41);
    let smoke: Vec<SmokeSample> = (0..w * h)
        .map(|i| SmokeSample {
            radiance: [0; 3].map(|_| rng.random_range(0.0..0.6)),
            // Every fourth pixel has no smoke.
            transmittance: if i % 4 == 0 {
                1.0
            } else {
                rng.random_range(0.0..1.0)
            },
            depth: rng.random_range(0.0..40.0),
        })
        .collect();
    for basis in [Basis::Haar, Basis::Linear, Basis::Quadratic] {
        let fog = fog(basis, 2, 0.6, PLACEMENT, min_t);
        let up = gpu.upload(&ctx, &fog).unwrap();
        let inside = LookAt {
            eye: [2.0, 6.0, 1.6],
            target: [3.0, 20.0, 1.2],
            up: [0.0, 0.0, 1.0],
            fov_deg: 70.0,
        };
        for cam in [render::framing(&fog), inside] {
            let camera = cam.camera(w, h).unwrap();
            let want = render::render_over(&fog, &camera, &scene, &smoke, &|| {});
            let got = gpu
                .render_over(&ctx, &up, &cam, &scene, &smoke, w, h)
                .unwrap();
            let mut split = 0;
            for y in 0..h {
                for x in 0..w {
                    let i = y * w + x;
                    let (_, ground) = cpu_pixel_tau(&fog, &cam, x, y, w, h);
                    let on_line = ground.is_some_and(|p| {
                        p.iter().any(|c| {
                            let r = c / scene.checker;
                            (r - r.round()).abs() < 1e-4
                        })
                    });
                    if on_line {
                        continue;
                    }
                    let d = camera.pixel_ray(x, y);
                    let len = render::ground_distance(camera.eye, d)
                        .unwrap_or_else(|| fog.exit_distance(camera.eye, d));
                    let s = f64::from(smoke[i].depth);
                    split += usize::from(
                        s < len && fog.optical_depth_span(camera.eye, d, len, 0.0, s) > 0.01,
                    );
                    for c in 0..3 {
                        let e = (f64::from(got[i][c]) - f64::from(want[i][c])).abs();
                        assert!(
                            e <= 2.0 * min_t + 1e-5,
                            "{basis} ({x}, {y}) channel {c}: {} vs {}",
                            got[i][c],
                            want[i][c]
                        );
                    }
                }
            }
            assert!(
                split > w * h / 10,
                "{basis}: {split} pixels split inside fog"
            );
        }
    }
    // A layer of another size is refused.
    let fog = fog(Basis::Linear, 1, 1.0, PLACEMENT, min_t);
    let up = gpu.upload(&ctx, &fog).unwrap();
    let e = gpu
        .render_over(&ctx, &up, &render::framing(&fog), &scene, &smoke, w + 1, h)
        .unwrap_err();
    assert!(e.to_string().contains("smoke layer"), "{e}");
}

#[test]
fn a_fog_moved_on_the_gpu_matches_the_cpu_without_a_new_upload() {
    let ctx = context();
    let gpu = FogRenderer::new(&ctx).unwrap();
    let by = [5.25, -3.5];
    let moved_p = Placement {
        origin: [PLACEMENT.origin[0] + by[0], PLACEMENT.origin[1] + by[1]],
        ..PLACEMENT
    };
    let (w, h) = (32, 24);
    for basis in [Basis::Haar, Basis::Linear, Basis::Quadratic] {
        let mut cpu = fog(basis, 2, 0.7, PLACEMENT, 0.0);
        let still = cpu.clone();
        let mut up = gpu.upload(&ctx, &cpu).unwrap();
        cpu.translate(by);
        up.translate(by);
        let queries = rays(&moved_p, basis.degree(), 2);
        let got = gpu.optical_depths(&ctx, &up, &queries).unwrap();
        let mut moved = 0;
        for (q, g) in queries.iter().zip(&got) {
            let want = cpu_depth(&cpu, q);
            let tol = 3e-6 * PLACEMENT.density * (1.0 + path_length(q));
            assert!((g - want).abs() <= tol, "{basis} {q:?}: GPU {g} CPU {want}");
            moved += usize::from((cpu_depth(&still, q) - want).abs() > 1e-2);
        }
        assert!(moved > queries.len() / 4, "{basis}: the fog did not move");
        // The image too: the ground's checker stays, the fog moves over it.
        let cam = render::framing(&cpu);
        let want = render::render(&cpu, &cam.camera(w, h).unwrap(), &Scene::default(), &|| {});
        let img = gpu
            .render(&ctx, &up, &cam, &Scene::default(), w, h)
            .unwrap();
        let mut other_tone = 0;
        for y in 0..h {
            for x in 0..w {
                let (tau, _) = cpu_pixel_tau(&cpu, &cam, x, y, w, h);
                let g = img[y * w + x];
                assert!((f64::from(g[3]) - tau).abs() <= 1e-5, "{basis} ({x}, {y})");
                let e = (0..3)
                    .map(|c| (g[c] - want[y * w + x][c]).abs())
                    .fold(0.0, f32::max);
                // Checker-line pixels may take the other tone (0.05 apart at most).
                if e > 1e-5 {
                    assert!(e < 0.05, "{basis} ({x}, {y}): {e}");
                    other_tone += 1;
                }
            }
        }
        assert!(
            other_tone <= w * h / 100,
            "{basis}: {other_tone} pixels differ"
        );
    }
}

#[test]
fn extremes_give_finite_pixels_like_the_cpu() {
    let ctx = context();
    let gpu = FogRenderer::new(&ctx).unwrap();
    let scene = Scene::default();
    let (w, h) = (24, 18);
    let far = LookAt {
        eye: [-3.0e4, -4.0e4, 9.0e3],
        target: [2.0, 10.0, 0.0],
        up: [0.0, 0.0, 1.0],
        fov_deg: 0.05,
    };
    for (density, falloff, cam) in [
        // Opaque: every ray through fog stops at once, τ underflows to 0.
        (1e30, 0.3, None),
        // Almost clear: τ = 1 to f32 precision, the stop depth beyond f32's range.
        (1e-30, 0.3, None),
        // A steep profile: the moments' exponent `k·|Δz|` is large in every cell.
        (0.4, 20.0, None),
        // Seen from 50 000 units away through a narrow lens.
        (0.4, 0.3, Some(far)),
    ] {
        let p = Placement {
            density,
            falloff,
            ..PLACEMENT
        };
        let fog = fog(Basis::Quadratic, 2, 0.8, p, 1.0 / 1024.0);
        let cam = cam.unwrap_or_else(|| render::framing(&fog));
        let up = gpu.upload(&ctx, &fog).unwrap();
        let got = gpu.render(&ctx, &up, &cam, &scene, w, h).unwrap();
        let mut foggy = 0;
        for y in 0..h {
            for x in 0..w {
                let g = got[y * w + x];
                assert!(
                    g.iter().all(|v| v.is_finite()),
                    "{density} {falloff}: {g:?}"
                );
                let (tau, _) = cpu_pixel_tau(&fog, &cam, x, y, w, h);
                let gt = f64::from(g[3]);
                // f32 positions 50 000 units out are off by ~0.004 units: τ within 1e-3.
                let tol = if cam == far { 1e-3 } else { 1e-5 };
                assert!(
                    (gt - tau).abs() <= tol || (tau < 2e-3 && gt < 4e-3),
                    "{density} {falloff} ({x}, {y}): τ {gt} vs {tau}"
                );
                foggy += usize::from(tau < 0.99);
            }
        }
        if density > 1e-3 {
            assert!(foggy > 0, "{density} {falloff}: no fog in view");
        }
    }
    // A density beyond f32 is refused rather than turned into infinity.
    let p = Placement {
        density: 1e39,
        ..PLACEMENT
    };
    let e = gpu
        .upload(&ctx, &fog(Basis::Linear, 1, 1.0, p, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("beyond the GPU's 32-bit floats"), "{e}");
}

#[test]
fn bad_inputs_are_errors() {
    let ctx = context();
    let gpu = FogRenderer::new(&ctx).unwrap();
    let direct = Fog::new(
        &fogmap(),
        Basis::Linear,
        2,
        PLACEMENT,
        Settings {
            mode: Mode::Direct,
            ..Settings::default()
        },
    )
    .unwrap();
    let e = gpu.upload(&ctx, &direct).unwrap_err().to_string();
    assert!(e.contains("deconstructed"), "{e}");
    let f = fog(Basis::Linear, 1, 1.0, PLACEMENT, 0.0);
    let up = gpu.upload(&ctx, &f).unwrap();
    let cam = LookAt {
        eye: [0.0, 0.0, 5.0],
        target: [0.0, 0.0, 5.0],
        up: [0.0, 0.0, 1.0],
        fov_deg: 50.0,
    };
    let e = gpu
        .render(&ctx, &up, &cam, &Scene::default(), 8, 8)
        .unwrap_err()
        .to_string();
    assert!(e.contains("coincide"), "{e}");
    let e = gpu
        .render(&ctx, &up, &render::framing(&f), &Scene::default(), 0, 8)
        .unwrap_err()
        .to_string();
    assert!(e.contains("0 × 8"), "{e}");
    assert!(gpu.optical_depths(&ctx, &up, &[]).unwrap().is_empty());
}
