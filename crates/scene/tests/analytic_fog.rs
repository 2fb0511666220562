//! Paper D's fog in a scene: the composite `τ C_in + (1 − τ) C_fog` against the transport
//! equation integrated independently (midpoint rule on the fog's density, constant source
//! `C_fog`), the wind through `Scene::at_time`, and bad media refused by name.

use haze_scene::analytic;
use haze_scene::file;
use haze_scene::media::analytic::AnalyticMedium;
use haze_scene::render::Analytic;

const SCENE: &str = r#"{
    "camera": {"eye": [0, -6, 1.5], "target": [0, 0, 0.5], "fov": 50, "width": 16, "height": 12},
    "environment": [0.3, 0.35, 0.4],
    "lights": [{"type": "point", "position": [1, -1, 3], "intensity": [8, 8, 8]}],
    "media": [{"type": "analytic", "sigma_t": [0.3, 0.4, 0.5], "albedo": 0.8, "colour": [0.7, 0.6, 0.5],
        "wind": [0.5, 0, 0], "far": 50,
        "terms": [{"type": "constant", "weight": 0.4},
                  {"type": "cosine", "weight": 0.3, "k": 2.0, "direction": [1, 0.5, 0]},
                  {"type": "blob", "shape": "point", "center": [0, 0, 1], "c": 0.5, "d": 2.0},
                  {"type": "height", "weight": 0.5, "falloff": 1.0}]}],
    "surfaces": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {"diffuse": [0.5, 0.5, 0.5]}}]
}"#;

#[test]
fn composite_solves_the_transport_equation_with_a_constant_source() {
    let scene = file::parse(SCENE).unwrap().at_time(1.7);
    let m: &AnalyticMedium = scene.analytic_media().next().unwrap();
    assert_eq!(m.time, 1.7);
    let colours = analytic::fog_colours(&scene);
    let c_in = [0.2, 0.9, 0.4];
    let eye = scene.camera.eye;
    for (x, y) in [(0, 0), (8, 6), (15, 11), (3, 9)] {
        let dir = scene.camera.pixel_ray(x, y);
        let t_end = scene
            .intersect(eye, dir, 0.0, f64::INFINITY)
            .map_or(m.far, |h| h.t.min(m.far));
        let got = analytic::composite(&scene, &colours, dir, t_end, c_in);
        // L = ∫₀^T τ(s) σK(s) C_fog ds + τ(T) C_in, midpoint rule on 2·10⁵ steps
        // (error ~ (T/n)²·max|K''|/24 relative: below 10⁻⁸).
        let n = 200_000;
        let h = t_end / n as f64;
        for c in 0..3 {
            let sigma = m.sigma_t[c];
            let (mut depth, mut l) = (0.0, 0.0);
            for i in 0..n {
                let s = (i as f64 + 0.5) * h;
                let x = [0, 1, 2].map(|a| eye[a] + s * dir[a]);
                let k = sigma * m.fog.density(x, m.time);
                l += (-(depth + 0.5 * k * h)).exp() * k * h * colours[0].1[c];
                depth += k * h;
            }
            l += (-depth).exp() * c_in[c];
            assert!(
                (got[c] - l).abs() < 1e-6 * l,
                "pixel {x},{y} channel {c}: {} vs {l}",
                got[c]
            );
        }
    }
}

#[test]
fn the_render_dims_surfaces_and_the_wind_moves_the_fog() {
    let scene = file::parse(SCENE).unwrap();
    let model = Analytic::new(&scene);
    let lim = Default::default();
    let clear = haze_scene::render::render(&scene, &model, &lim, &|_| {});
    let at0 = analytic::render(&scene, &model, &lim, &|_| {});
    let at3 = analytic::render(&scene.at_time(3.0), &model, &lim, &|_| {});
    assert_ne!(at0.pixels, clear.pixels);
    assert_ne!(at0.pixels, at3.pixels);
    assert!(
        at0.pixels
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
}

#[test]
fn bad_analytic_media_are_named() {
    for (from, to, want) in [
        (
            r#""far": 50,"#,
            r#""far": 50, "density": 2,"#,
            "unknown field `density`",
        ),
        (
            r#""c": 0.5,"#,
            r#""c": 0.5, "e": 1,"#,
            "media[0]: terms[2]: unknown field `e`",
        ),
        (
            r#""weight": 0.4}"#,
            r#""weight": 0.1}"#,
            "media[0]: the terms can sum to a negative extinction",
        ),
        (
            r#""albedo": 0.8"#,
            r#""albedo": 1.8"#,
            "albedo [1.8, 1.8, 1.8] must be in [0, 1]",
        ),
    ] {
        let text = SCENE.replace(from, to);
        assert_ne!(text, SCENE);
        let e = file::parse(&text).unwrap_err();
        assert!(e.contains(want), "{e}");
    }
}
