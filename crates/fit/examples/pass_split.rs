//! Where one objective pass spends its time on a real frame at fitted radii: fits the frame
//! from scratch (the first-frame fit of `haze bake`), then times, interleaved and best of
//! `--repeat` (default 30, robust to other load on the machine): the cost alone (tables,
//! residual on the voxels the RBFs reach, `ΣR²`), the cost and gradient (one L-BFGS-B
//! pass), and for scale a copy of the whole grid and a sum of its squares (what a pass
//! that touched every voxel paid on top). Prints the RBF·voxel pairs inside the `3r`
//! spheres and the share of the grid the RBFs' bounding boxes reach.
//!
//! cargo run --release -p haze-fit --example pass_split -- VOLUME [--rbfs N] [--repeat K]

use haze_fit::objective::{PARAMS_PER_RBF, Scratch, cost_and_gradient_with, cost_with};
use haze_fit::{FitGrid, FitOptions, fit_first_frame};
use haze_volume::{ImportOptions, import};
use std::hint::black_box;
use std::time::Instant;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(2)
}

fn value<T: std::str::FromStr>(args: &[String], flag: &str, default: T) -> T {
    match args.iter().position(|a| a == flag) {
        None => default,
        Some(i) => args
            .get(i + 1)
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| fail(format!("{flag} needs a valid value"))),
    }
}

/// Best of `times` in milliseconds.
fn best(times: &[f64]) -> f64 {
    times.iter().copied().fold(f64::INFINITY, f64::min) * 1e3
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        fail("usage: pass_split VOLUME [--rbfs N] [--repeat K]")
    };
    let rbfs: usize = value(&args, "--rbfs", 300);
    let repeat: usize = value(&args, "--repeat", 30);
    let v = import::import(std::path::Path::new(path), &ImportOptions::default())
        .unwrap_or_else(|e| fail(format!("{path}: {e}")));
    let g = FitGrid::from_volume(&v).unwrap_or_else(|e| fail(format!("{path}: {e}")));
    let (params, _) = fit_first_frame(&g, rbfs, &FitOptions::default());
    // RBF·voxel pairs inside the spheres and voxels in the bounding boxes, counted per RBF.
    let (mut pairs, mut boxed) = (0u64, 0u64);
    for p in params.chunks(PARAMS_PER_RBF) {
        let s = 3.0 * p[3];
        let span = |a: usize| {
            let lo = (((p[a] - s) / g.h[a] - 0.5).ceil().max(0.0)) as usize;
            let hi = (((p[a] + s) / g.h[a] - 0.5).floor()).min(g.dims[a] as f64 - 1.0);
            (lo, hi.max(-1.0) as isize)
        };
        let spans = [span(0), span(1), span(2)];
        if spans.iter().any(|&(lo, hi)| hi < lo as isize) {
            continue;
        }
        let [(x0, x1), (y0, y1), (z0, z1)] = spans.map(|(lo, hi)| (lo, hi as usize));
        boxed += ((x1 + 1 - x0) * (y1 + 1 - y0) * (z1 + 1 - z0)) as u64;
        for z in z0..=z1 {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let c = g.center(g.index(x, y, z));
                    let d2: f64 = (0..3).map(|a| (c[a] - p[a]).powi(2)).sum();
                    pairs += u64::from(d2 < s * s);
                }
            }
        }
    }
    let mut scratch = Scratch::default();
    let mut grad = vec![0.0; params.len()];
    let (mut t_cost, mut t_grad, mut t_copy) = (vec![], vec![], vec![]);
    for _ in 0..repeat {
        let t = Instant::now();
        black_box(cost_with(&g, black_box(&params), &mut scratch));
        t_cost.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        black_box(cost_and_gradient_with(
            &g,
            black_box(&params),
            &mut grad,
            &mut scratch,
        ));
        t_grad.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let copy = black_box(g.density.clone());
        black_box(copy.iter().map(|d| d * d).sum::<f64>());
        t_copy.push(t.elapsed().as_secs_f64());
    }
    let d = g.dims;
    println!(
        "{path}: {} × {} × {} ({} voxels), {} RBFs, {pairs} RBF·voxel pairs, bounding boxes {boxed} voxels ({:.1} % of the grid)",
        d[0],
        d[1],
        d[2],
        g.len(),
        params.len() / PARAMS_PER_RBF,
        100.0 * boxed as f64 / g.len() as f64
    );
    println!(
        "best of {repeat}: cost {:.2} ms, cost + gradient {:.2} ms, whole-grid copy + Σ² {:.2} ms ({} threads)",
        best(&t_cost),
        best(&t_grad),
        best(&t_copy),
        rayon::current_num_threads()
    );
}
