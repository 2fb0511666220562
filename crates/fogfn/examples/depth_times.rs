//! Prints the time of one frame of per-pixel optical depths (paper D's fog texture) at
//! 800 × 600 and 1920 × 1080 for fogs of 1, 10 and 100 terms, on the CPU (one thread,
//! f64 closed forms) and on the GPU (`DepthKernel`: upload, pass, read-back).
//! `cargo run --release -p haze-fogfn --example depth_times`

use haze_fogfn::gpu::DepthKernel;
use haze_fogfn::{Fog, spec};
use haze_gpu::GpuContext;
use serde_json::json;
use std::time::Instant;

/// `n` terms cycling through the families (a constant keeps the sum positive).
fn fog(n: usize) -> Fog {
    let mut terms = vec![json!({"type": "constant", "weight": 1.0 + n as f64})];
    for i in 0..n.saturating_sub(1) {
        let f = i as f64;
        terms.push(match i % 5 {
            0 => json!({"type": "cosine", "weight": 0.3, "k": 1.0 + f, "direction": [1, 0.1 * f, 0.2]}),
            1 => json!({"type": "polynomial", "axes": [[0, 1, 0]], "half_width": 2.0, "coefficients": [1.0, 0.1, -0.05]}),
            2 => json!({"type": "blob", "shape": "point", "center": [f, 5.0, 1.0], "c": 0.5, "d": 2.0}),
            3 => json!({"type": "blob", "shape": "sphere", "center": [-f, 8.0, 1.0], "radius": 1.0, "c": 0.5, "d": 2.0}),
            _ => json!({"type": "height", "weight": 0.5, "falloff": 0.7}),
        });
    }
    spec::fog([0.3, 0.1, 0.0], &terms).unwrap()
}

fn main() {
    let ctx = GpuContext::new().ok();
    let kernel = ctx.as_ref().map(|c| DepthKernel::new(c).unwrap());
    if let Some(c) = &ctx {
        println!("GPU: {}", c.adapter_name());
    }
    let eye = [0.0, -10.0, 1.5];
    for (w, h) in [(800usize, 600usize), (1920, 1080)] {
        let rays: Vec<([f64; 3], f64)> = (0..w * h)
            .map(|i| {
                let (x, y) = (
                    (i % w) as f64 / w as f64 - 0.5,
                    0.5 - (i / w) as f64 / h as f64,
                );
                let d = [x, 1.0, y * 0.75];
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                (d.map(|c| c / n), 30.0)
            })
            .collect();
        // One term: the constant alone.
        for n in [1, 10, 100] {
            let f = fog(n);
            let t = Instant::now();
            let cpu: f64 = rays
                .iter()
                .map(|&(d, l)| f.optical_depth(eye, d, l, 2.0))
                .sum();
            let cpu_s = t.elapsed().as_secs_f64();
            let gpu_s = match (&ctx, &kernel) {
                (Some(c), Some(k)) => {
                    k.run(c, &f, eye, 2.0, &rays).unwrap();
                    let t = Instant::now();
                    k.run(c, &f, eye, 2.0, &rays).unwrap();
                    format!("{:.3} s", t.elapsed().as_secs_f64())
                }
                _ => "no GPU".to_string(),
            };
            println!("{w}×{h}, {n:>3} terms: CPU {cpu_s:.3} s (checksum {cpu:.3e}), GPU {gpu_s}");
        }
    }
}
