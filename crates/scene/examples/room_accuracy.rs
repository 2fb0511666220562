//! Paper C against its quadrature reference on a scene, for BENCHMARKS.md: rel. RMS of
//! the whole image and of the airlight alone (surfaces made black), and the times.
//!
//! `cargo run --release -p haze-scene --example room_accuracy -- data/scenes/room.json 160 120`

use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Reference, render};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("data/scenes/room.json", String::as_str);
    let w: usize = args.get(2).map_or(160, |s| s.parse().unwrap());
    let h: usize = args.get(3).map_or(120, |s| s.parse().unwrap());
    let mut scene = haze_scene::load(std::path::Path::new(path)).unwrap();
    scene.camera = scene.camera.clone().with_size(w, h).unwrap();
    let lim = Limits::default();
    for airlight_only in [true, false] {
        let mut s = scene.clone();
        if airlight_only {
            for surf in &mut s.surfaces {
                surf.material.diffuse = [0.0; 3];
                surf.material.specular = [0.0; 3];
            }
        }
        let t = Instant::now();
        let model = Analytic::new(&s);
        let tables = t.elapsed().as_secs_f64();
        let a = render(&s, &model, &lim, &|_| {});
        let ta = t.elapsed().as_secs_f64() - tables;
        let t = Instant::now();
        let r = render(&s, &Reference::default(), &lim, &|_| {});
        let tr = t.elapsed().as_secs_f64();
        println!(
            "{} {w}×{h}: rel RMS {:.2e}; analytic {ta:.2} s (+ tables {tables:.2} s), reference {tr:.1} s",
            if airlight_only {
                "airlight alone"
            } else {
                "whole image"
            },
            a.rel_rms(&r)
        );
    }
}
