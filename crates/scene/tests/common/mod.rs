//! What the GPU-against-CPU tests share: the device, and the per-pixel comparison of two
//! pictures of the same scene.

// Each test file is its own crate and uses only some of these.
#![allow(dead_code)]

use haze_gpu::GpuContext;
use haze_scene::render::Image;
use std::sync::OnceLock;

/// The GPU device, opened once per test binary (a CPU one will do: Mesa's lavapipe, which
/// `scripts/test.sh` installs); panics with the reason when there is none, so the tests
/// fail, not skip.
pub fn context() -> &'static GpuContext {
    static C: OnceLock<GpuContext> = OnceLock::new();
    C.get_or_init(|| match GpuContext::new() {
        Ok(ctx) => {
            println!("GPU adapter: {} ({})", ctx.adapter_name(), ctx.backend());
            ctx
        }
        Err(e) => panic!("{e}"),
    })
}

/// Per pixel and channel `k`: `|L_gpu − L_cpu| ≤ rel·|L_cpu| + floor·L̄ + extra[k]`, with
/// `L̄` the CPU picture's mean; at most `outliers` of the pixels may break it (pixels
/// where `f32` and `f64` take different discrete decisions). Each test file states why
/// its values hold.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    pub rel: f64,
    pub floor: f64,
    pub extra: [f64; 3],
    pub outliers: f64,
}

impl Tolerance {
    pub fn new(rel: f64, floor: f64, outliers: f64) -> Tolerance {
        Tolerance {
            rel,
            floor,
            extra: [0.0; 3],
            outliers,
        }
    }
}

/// How two pictures agreed: the share of pixels outside the tolerance, and the worst
/// relative error `|L_gpu − L_cpu| / (|L_cpu| + floor·L̄)` of the pixels inside it.
#[derive(Clone, Copy, Debug)]
pub struct Agreement {
    pub outliers: f64,
    pub worst: f64,
}

/// Compares the GPU picture with the CPU's under `tol`: same size, the GPU's values finite
/// and non-negative, the CPU's picture not black (it would test nothing), at most
/// `tol.outliers` of the pixels outside; prints the figures under `name`.
pub fn assert_agree(name: &str, gpu: &Image, cpu: &Image, tol: Tolerance) -> Agreement {
    assert_eq!((gpu.width, gpu.height), (cpu.width, cpu.height), "{name}");
    let n = cpu.pixels.len();
    let mean = cpu
        .pixels
        .iter()
        .flat_map(|p| p.iter().map(|&v| f64::from(v).abs()))
        .sum::<f64>()
        / (3 * n).max(1) as f64;
    assert!(mean > 0.0, "{name}: a black image tests nothing");
    let (mut outside, mut worst, mut worst_at, mut worst_out) = (0usize, 0.0f64, 0, 0.0f64);
    for (i, (g, c)) in gpu.pixels.iter().zip(&cpu.pixels).enumerate() {
        assert!(
            g.iter().all(|v| v.is_finite() && *v >= 0.0),
            "{name}: pixel {i} is {g:?}"
        );
        let mut out = false;
        for k in 0..3 {
            let (g, c) = (f64::from(g[k]), f64::from(c[k]));
            let d = (g - c).abs();
            let r = d / (c.abs() + tol.floor * mean);
            if d > tol.rel * c.abs() + tol.floor * mean + tol.extra[k] {
                out = true;
                worst_out = worst_out.max(r);
            } else if r > worst {
                worst = r;
                worst_at = i;
            }
        }
        outside += usize::from(out);
    }
    let share = outside as f64 / n.max(1) as f64;
    println!(
        "{name}: {outside} of {n} pixels outside (worst {worst_out:.2e}), worst relative error of the others {worst:.2e} (pixel {worst_at}), mean {mean:.3e}"
    );
    assert!(
        share <= tol.outliers,
        "{name}: {outside} of {n} pixels outside the tolerance (worst {worst_out:.2e})"
    );
    Agreement {
        outliers: share,
        worst,
    }
}
