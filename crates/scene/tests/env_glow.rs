//! The environment's light through the medium (paper C §6.4): the SH glow
//! (`envglow::EnvGlow`) and its sphere-quadrature reference (`envref::EnvReference`)
//! against closed forms and against each other.
//!
//! Oracle for a constant environment `c` (independent of both): a point at distance `x`
//! from the centre of the source sphere of radius `D` receives
//! `∫ e^{−βd}/d² dω′ = 2π/(Dx)·[E₁(β(D − x)) − E₁(β(D + x))]` (with `d² = D² + x² −
//! 2Dxμ`, `dμ = −d·dd/(Dx)`), so the airlight along `[0, t]` is
//! `c·D·σs/2·∫₀^t e^{−βx}·[E₁(β(D − x)) − E₁(β(D + x))]/x dx` — a 1D integral done here by
//! adaptive quadrature.

use haze_scene::paper_c::envglow::{DEFAULT_ORDER, EnvGlow, lobe_factors};
use haze_scene::paper_c::envref::EnvReference;
use haze_scene::paper_c::htable::HTable;
use haze_scene::paper_c::quad::adaptive_pieces;
use haze_scene::paper_c::special::exp_e1;
use haze_scene::scene::{Environment, Material, Medium, Scene};
use haze_scene::{Camera, file};
use std::f64::consts::PI;
use std::sync::OnceLock;

fn h() -> &'static HTable {
    static H: OnceLock<HTable> = OnceLock::new();
    H.get_or_init(HTable::default)
}

fn e1(x: f64) -> f64 {
    if x <= 0.0 {
        f64::INFINITY
    } else {
        (-x).exp() * exp_e1(x)
    }
}

/// The oracle of the module docs for `c = 1`.
fn constant_airlight(d: f64, t: f64, beta: f64, ss: f64) -> f64 {
    let f = |x: f64| {
        if x <= 0.0 {
            // x → 0: [E₁(β(D−x)) − E₁(β(D+x))]/x → 2e^{−βD}/D.
            return 2.0 * (-beta * d).exp() / d;
        }
        (-beta * x).exp() * (e1(beta * (d - x)) - e1(beta * (d + x))) / x
    };
    // Breakpoints graded towards x = D, where E₁ has its logarithmic singularity.
    let mut pts = vec![0.0];
    for k in (1..12).rev() {
        let x = d * (1.0 - 0.5f64.powi(k * 2));
        if x > 0.0 && x < t {
            pts.push(x);
        }
    }
    pts.push(t);
    d * ss / 2.0 * adaptive_pieces(f, &pts, 1e-11)
}

fn scene(env: Environment, sigma_t: f64, albedo: f64, distance: f64) -> Scene {
    Scene {
        camera: Camera::new(
            [0.0, -5.0, 1.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
            50.0,
            8,
            6,
        )
        .unwrap(),
        environment: env,
        environment_distance: distance,
        lights: Vec::new(),
        medium: Medium {
            sigma_t: [sigma_t; 3],
            albedo: [albedo; 3],
        },
        hetero: Vec::new(),
        surfaces: Vec::new(),
    }
}

fn lambert(rho: f64) -> Material {
    Material {
        diffuse: [rho; 3],
        specular: [0.0; 3],
        shininess: 0.0,
    }
}

#[test]
fn lobe_factors_are_the_clamped_cosine_and_phong_closed_forms() {
    // Lambert: 2π∫₀¹ μ P_l = π, 2π/3, π/4, 0, −π/24, 0, π/64.
    let a = lobe_factors(7, 1.0);
    let want = [
        PI,
        2.0 * PI / 3.0,
        PI / 4.0,
        0.0,
        -PI / 24.0,
        0.0,
        PI / 64.0,
    ];
    for (l, (a, w)) in a.iter().zip(want).enumerate() {
        assert!((a - w).abs() < 1e-12, "a_{l} = {a}, want {w}");
    }
    // Phong, band 0 and 1: 2π/(m + 1), 2π/(m + 2).
    for m in [0.5, 20.0, 77.0] {
        let p = lobe_factors(2, m);
        // μ^0.5 is not smooth at 0: composite Gauss–Legendre gets it to ~1e-7.
        assert!(
            (p[0] - 2.0 * PI / (m + 1.0)).abs() < 1e-6 * p[0],
            "{m}: {p:?}"
        );
        assert!(
            (p[1] - 2.0 * PI / (m + 2.0)).abs() < 1e-6 * p[1],
            "{m}: {p:?}"
        );
    }
}

#[test]
fn constant_environment_glow_matches_the_closed_form() {
    let (d, beta, albedo) = (10.0, 0.15, 0.8);
    let s = scene(Environment::Constant([1.0, 2.0, 0.5]), beta, albedo, d);
    let g = EnvGlow::new(&s, h(), DEFAULT_ORDER, &[]).unwrap();
    let r = EnvReference::new(&s).unwrap();
    let dir = [0.3, -0.5, 0.81];
    // At a node of the λ table (t = D), between nodes, close to the eye.
    for t in [d, 0.37 * d, 0.02 * d] {
        let want = constant_airlight(d, t, beta, albedo * beta);
        let a = g.view(dir, t);
        let b = r.view(dir, t);
        for (c, k) in [1.0, 2.0, 0.5].iter().enumerate() {
            let w = k * want;
            // SH: the K table (≤ 6e-4) and the λ table read linearly in t (tested at
            // 0.37·D, mid-cell); the reference: quadrature.
            assert!((a[c] - w).abs() < 2e-3 * w, "SH t = {t}: {} vs {w}", a[c]);
            assert!(
                (b[c] - w).abs() < 1e-5 * w,
                "reference t = {t}: {} vs {w}",
                b[c]
            );
        }
    }
}

#[test]
fn a_white_lambert_surface_in_a_clear_constant_environment_reflects_it() {
    // β = 0 (and D = ∞): L_in = c, ρ/π·∫c·cos = ρc, whatever the normal.
    for distance in [f64::INFINITY, 7.0] {
        let s = scene(Environment::Constant([0.4, 0.5, 0.6]), 0.0, 0.0, distance);
        let g = EnvGlow::new(&s, h(), DEFAULT_ORDER, &[]).unwrap();
        let r = EnvReference::new(&s).unwrap();
        let n = [0.0, 0.6, 0.8];
        let m = lambert(0.7);
        for (c, v) in [0.4, 0.5, 0.6].iter().enumerate() {
            let a = g.surface(n, [0.0, 0.0, 1.0], &m)[c];
            let b = r.surface(n, [0.0, 0.0, 1.0], &m)[c];
            // The constant is stored as an f32 texel: 1e-7.
            assert!((a - 0.7 * v).abs() < 1e-7, "{a}");
            assert!((b - 0.7 * v).abs() < 1e-9, "{b}");
            assert_eq!(g.view(n, 3.0)[c], 0.0);
        }
    }
}

#[test]
fn fogged_constant_environment_lights_surfaces_by_its_attenuation_and_glow() {
    // ρ·c·(e^{−βD} + λ_0(D)), λ_0(D) = the airlight of the whole sphere seen to D.
    let (d, beta, albedo) = (6.0, 0.3, 0.9);
    let s = scene(Environment::Constant([1.0; 3]), beta, albedo, d);
    let want = 0.5 * ((-beta * d).exp() + constant_airlight(d, d, beta, albedo * beta));
    let g = EnvGlow::new(&s, h(), DEFAULT_ORDER, &[]).unwrap();
    let r = EnvReference::new(&s).unwrap();
    let m = lambert(0.5);
    let a = g.surface([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], &m)[0];
    let b = r.surface([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], &m)[0];
    assert!((a - want).abs() < 1e-3 * want, "SH {a} vs {want}");
    assert!((b - want).abs() < 1e-4 * want, "reference {b} vs {want}");
}

#[test]
fn glow_vanishes_continuously_as_the_medium_clears_and_without_a_distance() {
    let env = Environment::Sky;
    let thin = scene(env.clone(), 1e-7, 1.0, 20.0);
    let g = EnvGlow::new(&thin, h(), DEFAULT_ORDER, &[]).unwrap();
    let v = g.view([0.0, 1.0, 0.2], 20.0);
    // σs → 0: the glow is O(σs·D) of the sky (~1): below 1e-5.
    assert!(
        v.iter().all(|x| x.is_finite() && *x >= 0.0 && *x < 1e-5),
        "{v:?}"
    );
    // A medium and the environment at ∞: no light from it at all.
    let far = scene(env, 0.2, 0.9, f64::INFINITY);
    let g = EnvGlow::new(&far, h(), DEFAULT_ORDER, &[]).unwrap();
    assert!(!g.glows);
    assert_eq!(g.view([0.0, 1.0, 0.0], f64::INFINITY), [0.0; 3]);
    assert_eq!(
        g.surface([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], &lambert(1.0)),
        [0.0; 3]
    );
    // Black: nothing to build.
    assert!(EnvGlow::new(&scene(Environment::Black, 0.2, 0.9, 5.0), h(), 4, &[]).is_none());
}

/// The SH glow against the reference on the sky, direction by direction: the view glow at
/// the environment (`t = D`) and halfway, and a specular surface. The sky is smooth apart
/// from the horizon, so order 16 is within a per cent.
#[test]
fn sh_glow_of_the_sky_is_close_to_the_reference() {
    let s = scene(Environment::Sky, 0.2, 0.9, 8.0);
    let g = EnvGlow::new(&s, h(), DEFAULT_ORDER, &[20.0]).unwrap();
    let r = EnvReference::new(&s).unwrap();
    let (mut num, mut den) = (0.0, 0.0);
    let m = Material {
        diffuse: [0.5; 3],
        specular: [0.3; 3],
        shininess: 20.0,
    };
    for k in 0..24 {
        let z = -0.9 + 1.8 * (k as f64 + 0.5) / 24.0;
        let phi = 2.4 * k as f64;
        let rho = (1.0 - z * z).sqrt();
        let dir = [rho * phi.cos(), rho * phi.sin(), z];
        // The mirror direction 37° off the normal (a lobe well above the horizon).
        let t = [-phi.sin(), phi.cos(), 0.0];
        let refl = [0, 1, 2].map(|k| 0.8 * dir[k] + 0.6 * t[k]);
        let pairs = [
            (g.view(dir, 8.0), r.view(dir, 8.0)),
            (g.view(dir, 4.0), r.view(dir, 4.0)),
            (g.surface(dir, refl, &m), r.surface(dir, refl, &m)),
        ];
        for (a, b) in pairs {
            for c in 0..3 {
                num += (a[c] - b[c]) * (a[c] - b[c]);
                den += b[c] * b[c];
            }
        }
    }
    let err = (num / den).sqrt();
    println!("SH order {DEFAULT_ORDER} vs reference on the sky: rel RMS {err:.2e}");
    assert!(err < 0.01, "{err}");
    assert!(den > 0.0);
}

#[test]
fn scene_files_read_exr_environments_and_name_bad_ones() {
    let dir = tempfile::tempdir().unwrap();
    let map = haze_view::Image {
        width: 4,
        height: 2,
        pixels: (0..8).map(|i| [i as f32, 1.0, 0.5]).collect(),
    };
    map.write_exr(&dir.path().join("env.exr")).unwrap();
    std::fs::write(dir.path().join("bad.exr"), b"not an exr").unwrap();
    let text = |env: &str| {
        format!(
            r#"{{"camera": {{"eye": [0, 0, 0], "target": [1, 0, 0]}}, "environment": "{env}"}}"#
        )
    };
    let path = dir.path().join("scene.json");
    std::fs::write(&path, text("env.exr")).unwrap();
    let s = haze_scene::load(&path).unwrap();
    match &s.environment {
        Environment::Map(m) => {
            assert_eq!((m.width, m.height, m.texels[5]), (4, 2, [5.0, 1.0, 0.5]))
        }
        other => panic!("{other:?}"),
    }
    for (env, needle) in [
        (
            "missing.exr",
            "environment \"missing.exr\": no such environment map",
        ),
        (
            "bad.exr",
            "environment \"bad.exr\": not a readable RGB OpenEXR image",
        ),
    ] {
        std::fs::write(&path, text(env)).unwrap();
        let e = haze_scene::load(&path).unwrap_err().to_string();
        assert!(e.contains("scene.json: ") && e.contains(needle), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
    // Relative to the scene file, not the working directory.
    assert!(file::parse(&text("env.exr")).is_err());
}

/// The glow kept between frames (`envglow::Cache`) is `EnvGlow::new`'s to the bit, and it
/// projects the environment again only for another environment or order: a camera move,
/// a light or a surface leave both the projection and the glow; the medium and the
/// environment distance rebuild the glow (from the kept projection); the exponents too.
#[test]
fn the_kept_glow_is_rebuilt_only_when_its_inputs_change() {
    use haze_scene::paper_c::envglow::Cache;
    let cache = Cache::default();
    let mut s = scene(Environment::Sky, 0.2, 0.9, 8.0);
    let fresh = |s: &Scene, e: &[f64]| EnvGlow::new(s, h(), 4, e).unwrap();
    assert_eq!(cache.glow(&s, h(), 4, &[]).unwrap(), fresh(&s, &[]));
    assert_eq!(cache.builds(), (1, 1));
    s.camera = Camera::new([3.0, 1.0, 2.0], [0.0; 3], [0.0, 0.0, 1.0], 40.0, 8, 6).unwrap();
    s.surfaces.push(haze_scene::Surface {
        shape: haze_scene::Shape::Sphere {
            center: [0.0, 0.0, 1.0],
            radius: 0.5,
        },
        material: lambert(0.5),
    });
    assert_eq!(cache.glow(&s, h(), 4, &[]).unwrap(), fresh(&s, &[]));
    assert_eq!(cache.builds(), (1, 1));
    // The medium and the distance: a new glow, the same projection.
    s.medium.albedo = [0.5; 3];
    assert_eq!(cache.glow(&s, h(), 4, &[]).unwrap(), fresh(&s, &[]));
    assert_eq!(cache.builds(), (1, 2));
    s.environment_distance = 20.0;
    assert_eq!(cache.glow(&s, h(), 4, &[]).unwrap(), fresh(&s, &[]));
    assert_eq!(cache.builds(), (1, 3));
    assert_eq!(cache.glow(&s, h(), 4, &[20.0]).unwrap(), fresh(&s, &[20.0]));
    assert_eq!(cache.builds(), (1, 4));
    // Another environment or order: projected again.
    s.environment = Environment::Constant([0.3, 0.2, 0.1]);
    assert_eq!(cache.glow(&s, h(), 4, &[20.0]).unwrap(), fresh(&s, &[20.0]));
    assert_eq!(cache.builds(), (2, 5));
    assert_eq!(
        cache.glow(&s, h(), 3, &[20.0]).unwrap(),
        EnvGlow::new(&s, h(), 3, &[20.0]).unwrap()
    );
    assert_eq!(cache.builds(), (3, 6));
    // Black: nothing to build, nothing counted.
    s.environment = Environment::Black;
    assert!(cache.glow(&s, h(), 3, &[20.0]).is_none());
    assert_eq!(cache.builds(), (3, 6));
}
