//! The environment's light on smoke (`env_smoke`): the march with the precomputed SH grid
//! against the march whose environment term is integrated by direct quadrature at every
//! sample (no SH, no grid), and the scenes the environment does not light.
//!
//! **Tolerance.** `cargo run --release -p haze-scene --example env_smoke_error` measures
//! the grid's error of the environment's contribution at 1–2 % (relative RMS over the
//! image) on this scene at the default settings, the order-4 truncation and the grid's
//! interpolation of the smoke's self-shadowing; here on a coarser image the bound is 5 %
//! of the contribution, a margin of more than two, and any pixel may not be off by more
//! than a quarter of the largest contribution.

use haze_scene::Scene;
use haze_scene::march::env_smoke::{Direct, EnvGrid, EnvLight, EnvOptions};
use haze_scene::march::render;
use haze_scene::march::{march_options, march_steps};
use haze_scene::paper_c::airlight::Limits;
use std::path::Path;
use std::sync::Arc;

fn scene(environment: &str, fog: &str) -> Scene {
    let text = format!(
        r#"{{"camera": {{"eye": [0.3, -4.0, 1.5], "target": [0, 0, 0.8], "fov": 30,
                        "width": 12, "height": 9}},
            "environment": {environment},
            "lights": [],
            "media": [{{"type": "asset", "path": "plume.haze", "frame": 24, "sigma_t": 8,
                        "albedo": 0.9, "g": 0.5, "offset": [-0.75, -0.75, 0.1], "scale": 0.5}}
                      {fog}],
            "surfaces": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                          "material": {{"diffuse": [0.6, 0.58, 0.55]}}}}]}}"#
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes");
    haze_scene::file::parse_in(&text, &base).unwrap()
}

#[test]
fn the_grid_matches_direct_quadrature() {
    let s = scene(r#""sky""#, "");
    let mut opt = march_options(&s, false);
    assert!(
        matches!(opt.env, EnvLight::Grid(_)),
        "the sky lights the plume"
    );
    let grid = render(&s, &Limits::default(), &opt, &|_| {});
    opt.env = EnvLight::Direct(Arc::new(Direct::new(24)));
    let direct = render(&s, &Limits::default(), &opt, &|_| {});
    opt.env = EnvLight::None;
    let none = render(&s, &Limits::default(), &opt, &|_| {});
    let (mut err, mut term, mut peak, mut worst) = (0.0, 0.0, 0.0f64, 0.0f64);
    for ((a, b), z) in grid.pixels.iter().zip(&direct.pixels).zip(&none.pixels) {
        for c in 0..3 {
            let (a, b, z) = (f64::from(a[c]), f64::from(b[c]), f64::from(z[c]));
            err += (a - b) * (a - b);
            term += (b - z) * (b - z);
            peak = peak.max(b - z);
            worst = worst.max((a - b).abs());
        }
    }
    let rel = (err / term).sqrt();
    println!("environment term: rel RMS {rel:.3}, worst pixel {worst:.3e} of peak {peak:.3e}");
    assert!(
        peak > 0.01,
        "the environment's contribution is visible: {peak}"
    );
    assert!(rel < 0.05, "relative RMS {rel}");
    assert!(worst < 0.25 * peak, "worst pixel {worst} of {peak}");
}

#[test]
fn a_constant_environment_through_clear_space_is_its_integral() {
    // At a node no smoke lies above, the transmittance is 1 above the ground and 0 below
    // (the plane), so a constant L gives E_00 = L·2π·Y_00 and E_10 = L·π·√(3/4π)
    // (∫ over the upper hemisphere of Y_10 = √(3/4π)·z).
    let s = scene("[0.5, 0.5, 0.5]", "");
    let g = EnvGrid::build(
        &s,
        &EnvOptions {
            nodes: 4,
            order: 2,
            theta: 16,
        },
    )
    .unwrap();
    // The top corner node (x, y, z maximal): above every voxel with density, since the
    // grid is cropped to the density and the box's top is its last voxel's end.
    let k = 3 * 4;
    let corner = g.coeffs.len() / k - 1;
    let e = &g.coeffs[corner * k..(corner + 1) * k];
    let y00 = 0.5 / std::f64::consts::PI.sqrt();
    let y10 = (3.0 / (4.0 * std::f64::consts::PI)).sqrt();
    // The Gauss–Legendre rule integrates the hemisphere's step in z only to ~1/n².
    let e00 = 0.5 * 2.0 * std::f64::consts::PI * y00;
    let e10 = 0.5 * std::f64::consts::PI * y10;
    println!("E_00 {} vs {e00}, E_10 {} vs {e10}", e[0], e[3 * 2]);
    assert!((f64::from(e[0]) - e00).abs() < 0.02 * e00);
    assert!((f64::from(e[3 * 2]) - e10).abs() < 0.02 * e10);
}

#[test]
fn a_black_or_hidden_environment_lights_nothing() {
    // Black: the march is the one without the term, exactly.
    assert_eq!(march_options(&scene("null", ""), false).env, EnvLight::None);
    // Fog with the environment at ∞ hides it.
    let fog = r#", {"type": "homogeneous", "sigma_t": 0.2, "albedo": 0.8}"#;
    assert_eq!(
        march_options(&scene("[1, 1, 1]", fog), false).env,
        EnvLight::None
    );
    let s = scene("null", "");
    assert_eq!(march_options(&s, false), march_steps(&s, false));
}

#[test]
fn fog_dims_the_environment_by_its_distance() {
    // A homogeneous fog between the smoke and an environment `D` away multiplies every
    // coefficient by e^{−σt·D} (env_smoke's model), the smoke's own shadowing unchanged.
    let opt = EnvOptions {
        nodes: 2,
        order: 2,
        theta: 4,
    };
    let clear = EnvGrid::build(&scene("[1, 1, 1]", ""), &opt).unwrap();
    let fog = r#", {"type": "homogeneous", "sigma_t": [0.2, 0.3, 0.4], "albedo": 0.8}"#;
    let mut s = scene("[1, 1, 1]", fog);
    s.environment_distance = 3.0;
    let dimmed = EnvGrid::build(&s, &opt).unwrap();
    for (i, (a, b)) in clear.coeffs.iter().zip(&dimmed.coeffs).enumerate() {
        let f = (-[0.2, 0.3, 0.4][i % 3] * 3.0f64).exp();
        let want = f64::from(*a) * f;
        assert!(
            (f64::from(*b) - want).abs() <= 1e-6 * (1.0 + want.abs()),
            "{b} vs {want}"
        );
    }
}
