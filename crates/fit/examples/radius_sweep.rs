//! Cold first-frame fits of one volume for several RBF counts and radius lower bounds:
//! rel_l2, iterations, seconds, and where the fitted radii sit (how many on the lower
//! bound, the median radius, both in voxels of the grid's finest axis). Measures whether
//! `--radius-min` is what limits the error per RBF (0: the grid's Nyquist radius, the
//! default; other values are raised to it).
//!
//! cargo run --release -p haze-fit --example radius_sweep -- VOLUME --rbfs N,.. --radius-min R,..

use haze_fit::{FitGrid, FitOptions, fit_first_frame, sequence::errors};
use haze_volume::{ImportOptions, import};
use std::time::Instant;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(2)
}

fn list<T: std::str::FromStr>(args: &[String], flag: &str) -> Vec<T> {
    let Some(i) = args.iter().position(|a| a == flag) else {
        fail(format!("{flag} is required"))
    };
    args.get(i + 1)
        .map(|v| v.split(',').map(|s| s.parse::<T>().ok()).collect())
        .and_then(|v: Option<Vec<T>>| v)
        .unwrap_or_else(|| fail(format!("{flag} needs a comma-separated list")))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        fail("usage: radius_sweep VOLUME --rbfs N,.. --radius-min R,..")
    };
    let counts: Vec<usize> = list(&args, "--rbfs");
    let mins: Vec<f64> = list(&args, "--radius-min");
    let v = import::import(std::path::Path::new(path), &ImportOptions::default())
        .unwrap_or_else(|e| fail(format!("{path}: {e}")));
    let g = FitGrid::from_volume(&v).unwrap_or_else(|e| fail(format!("{path}: {e}")));
    let h = g.h.iter().copied().fold(f64::INFINITY, f64::min);
    println!("{path}: {:?} voxels, voxel {h:.5} of the unit cube", g.dims);
    println!(
        "| RBFs | radius-min (voxels) | rel_l2 | iterations (coarse) | at radius-min | median r (voxels) | seconds |"
    );
    println!("|---|---|---|---|---|---|---|");
    for &n in &counts {
        for &lo in &mins {
            let mut opts = FitOptions::default();
            opts.bounds.radius.0 = lo;
            let lo = opts.bounds.radius_on(&g).0;
            let t = Instant::now();
            let (p, s) = fit_first_frame(&g, n, &opts);
            let secs = t.elapsed().as_secs_f64();
            let (rel, _) = errors(&g, &p);
            let mut radii: Vec<f64> = p.chunks(5).map(|q| q[3]).collect();
            radii.sort_by(f64::total_cmp);
            let at = radii.iter().filter(|&&r| r <= lo * (1.0 + 1e-6)).count();
            println!(
                "| {n} | {lo:.5} ({:.2}) | {rel:.4} | {} ({}) | {at} | {:.2} | {secs:.1} |",
                lo / h,
                s.iterations,
                s.coarse_iterations,
                radii.get(radii.len() / 2).copied().unwrap_or(f64::NAN) / h
            );
        }
    }
}
