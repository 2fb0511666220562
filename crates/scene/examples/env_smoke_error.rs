//! The error of the environment's light on smoke ([`haze_scene::march::env_smoke`]): the march
//! with the precomputed SH grid against the same march whose environment term is
//! integrated by direct quadrature over 2·32² directions at every sample (no SH, no grid),
//! on a small image of the bundled plume under the sky over a ground plane, for several
//! SH orders, grid sizes and phases. Prints the relative RMS over the image of the
//! environment's contribution (the image minus the image without it) and of the whole
//! image, and the grid's precomputation time.
//!
//! `cargo run --release -p haze-scene --example env_smoke_error`

use haze_scene::march::env_smoke::{Direct, EnvGrid, EnvLight, EnvOptions};
use haze_scene::march::march_options;
use haze_scene::march::{MarchOptions, render};
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::Image;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

fn scene(g: f64) -> haze_scene::Scene {
    let text = format!(
        r#"{{"camera": {{"eye": [0.3, -4.0, 1.5], "target": [0, 0, 0.8], "fov": 30,
                        "width": 24, "height": 18}},
            "environment": "sky",
            "lights": [{{"type": "sun", "direction": [0.7, -0.35, 0.62], "radiance": [2.2, 2.1, 1.9], "angle": 0}}],
            "media": [{{"type": "asset", "path": "plume.haze", "frame": 24, "sigma_t": 8,
                        "albedo": 0.9, "g": {g}, "offset": [-0.75, -0.75, 0.1], "scale": 0.5}}],
            "surfaces": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                          "material": {{"diffuse": [0.6, 0.58, 0.55]}}}}]}}"#
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes");
    haze_scene::file::parse_in(&text, &base).unwrap()
}

fn image(s: &haze_scene::Scene, opt: &MarchOptions) -> Image {
    render(s, &Limits::default(), opt, &|_| {})
}

/// RMS of `a − b` over RMS of `b − none` (the environment term) and over RMS of `b`.
fn errors(a: &Image, b: &Image, none: &Image) -> (f64, f64) {
    let (mut e, mut t, mut whole) = (0.0, 0.0, 0.0);
    for ((x, y), z) in a.pixels.iter().zip(&b.pixels).zip(&none.pixels) {
        for c in 0..3 {
            let (x, y, z) = (f64::from(x[c]), f64::from(y[c]), f64::from(z[c]));
            e += (x - y) * (x - y);
            t += (y - z) * (y - z);
            whole += y * y;
        }
    }
    ((e / t).sqrt(), (e / whole).sqrt())
}

fn main() {
    for g in [0.3, 0.7] {
        let s = scene(g);
        let mut opt = march_options(&s, false);
        opt.env = EnvLight::None;
        let none = image(&s, &opt);
        opt.env = EnvLight::Direct(Arc::new(Direct::new(32)));
        let t = Instant::now();
        let reference = image(&s, &opt);
        println!(
            "g = {g}: reference {:.1} s ({} directions per sample)",
            t.elapsed().as_secs_f64(),
            2 * 32 * 32
        );
        println!("  nodes order theta   env-term rel RMS   image rel RMS   build s");
        for (nodes, order, theta) in [
            (16, 1, 12),
            (16, 2, 12),
            (16, 3, 12),
            (16, 4, 12),
            (8, 4, 12),
            (24, 4, 12),
            (32, 4, 12),
            (16, 4, 8),
            (16, 4, 16),
            (24, 4, 8),
            (24, 3, 8),
            (24, 6, 8),
        ] {
            let t = Instant::now();
            let grid = EnvGrid::build(
                &s,
                &EnvOptions {
                    nodes,
                    order,
                    theta,
                },
            )
            .expect("the sky lights the plume");
            let build = t.elapsed().as_secs_f64();
            opt.env = EnvLight::Grid(Arc::new(grid));
            let (term, whole) = errors(&image(&s, &opt), &reference, &none);
            println!(
                "  {nodes:5} {order:5} {theta:5}   {:15.2} %   {:11.2} %   {build:7.2}",
                100.0 * term,
                100.0 * whole
            );
        }
    }
}
