//! The environment glow in SH (`envglow`) against its sphere-quadrature reference
//! (`envref`) on a scene, for BENCHMARKS.md: the scene's point and sun lights removed, so
//! the image is the environment's light alone (its airlight, what it lights on surfaces,
//! itself attenuated); rel. RMS per SH order, and the times.
//!
//! `cargo run --release -p haze-scene --example glow_error -- data/scenes/glow.json 80 60 4,6,8,10`

use haze_scene::paper_c::airlight::Limits;
use haze_scene::paper_c::envglow::EnvGlow;
use haze_scene::render::{Analytic, EnvLight, Model, Reference, render};
use haze_scene::scene::{Material, Scene};
use haze_scene::vec3::Vec3;
use std::time::Instant;

/// Paper C's analytic model with the environment in SH of a chosen order.
struct AtOrder<'a> {
    analytic: &'a Analytic,
    order: usize,
}

impl Model for AtOrder<'_> {
    fn airlight(&self, e: Vec3, d: Vec3, t: f64, l: Vec3, b: f64, s: f64) -> f64 {
        self.analytic.airlight(e, d, t, l, b, s)
    }
    fn surface(
        &self,
        p: Vec3,
        n: Vec3,
        r: Vec3,
        l: Vec3,
        b: f64,
        s: f64,
        m: &Material,
        c: usize,
    ) -> f64 {
        self.analytic.surface(p, n, r, l, b, s, m, c)
    }
    fn name(&self) -> String {
        format!("SH order {}", self.order)
    }
    fn environment(&self, scene: &Scene) -> Option<Box<dyn EnvLight>> {
        let exps = self.analytic.exponents();
        EnvGlow::new(scene, &self.analytic.h, self.order, &exps)
            .map(|g| Box::new(g) as Box<dyn EnvLight>)
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("data/scenes/glow.json", String::as_str);
    let w: usize = args.get(2).map_or(80, |s| s.parse().unwrap());
    let h: usize = args.get(3).map_or(60, |s| s.parse().unwrap());
    let orders: Vec<usize> = args
        .get(4)
        .map_or("4,6,8,10", String::as_str)
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let mut scene = haze_scene::load(std::path::Path::new(path)).unwrap();
    scene.camera = scene.camera.clone().with_size(w, h).unwrap();
    scene.lights.clear();
    let lim = Limits::default();
    let t = Instant::now();
    let r = render(&scene, &Reference::default(), &lim, &|_| {});
    println!("reference {w}×{h}: {:.1} s", t.elapsed().as_secs_f64());
    let analytic = Analytic::new(&scene);
    for order in orders {
        let t = Instant::now();
        let a = render(
            &scene,
            &AtOrder {
                analytic: &analytic,
                order,
            },
            &lim,
            &|_| {},
        );
        println!(
            "SH order {order}: rel RMS {:.2e}, {:.2} s",
            a.rel_rms(&r),
            t.elapsed().as_secs_f64()
        );
    }
}
