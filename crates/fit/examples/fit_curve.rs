//! Prints the speed/accuracy curve of first-frame fits: rel_l2, rms_over_max and seconds
//! for several RBF counts, with and without teleportation, for both optimizers.
//!
//! cargo run --release -p haze-fit --example fit_curve -- VOLUME [N ...]

use haze_fit::{FitGrid, FitOptions, Optimizer, fit_first_frame, sequence::errors};
use haze_volume::{ImportOptions, import};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: fit_curve VOLUME [N ...]");
        std::process::exit(2);
    };
    let counts: Vec<usize> = args.filter_map(|a| a.parse().ok()).collect();
    let counts = if counts.is_empty() {
        vec![100, 200, 400, 800, 1600]
    } else {
        counts
    };
    let v = match import::import(std::path::Path::new(&path), &ImportOptions::default()) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let g = match FitGrid::from_volume(&v) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {path}: {e}");
            std::process::exit(1);
        }
    };
    println!(
        "| RBFs | optimizer | teleport | rel_l2 | rms_over_max | iterations | teleports | seconds |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for &n in &counts {
        for (optimizer, teleport) in [
            (Optimizer::Lbfgsb, false),
            (Optimizer::Lbfgsb, true),
            (Optimizer::LbfgsReparam, false),
            (Optimizer::LbfgsReparam, true),
        ] {
            let opts = FitOptions {
                optimizer,
                teleport,
                ..FitOptions::default()
            };
            let t = Instant::now();
            let (p, s) = fit_first_frame(&g, n, &opts);
            let secs = t.elapsed().as_secs_f64();
            let (rel, rms) = errors(&g, &p);
            println!(
                "| {n} | {optimizer:?} | {teleport} | {rel:.4} | {:.2} % | {} | {} | {secs:.2} |",
                rms * 100.0,
                s.iterations,
                s.teleports
            );
        }
    }
}
