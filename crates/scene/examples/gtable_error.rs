//! Measures the `G0`/`Gn` tables against quadrature with exact `H`, for BENCHMARKS.md:
//! the largest relative error over `T ∈ [0, 20]` and `θ ∈ [0, π]` between the nodes, and
//! the time to build each table (rayon on every core; the median of 3 builds).
//!
//! `cargo run --release -p haze-scene --example gtable_error`

use haze_scene::paper_c::gtable::{GTable, g_quadrature};
use haze_scene::paper_c::hfunc::h_exact;
use haze_scene::paper_c::htable::HTable;
use rayon::prelude::*;
use std::f64::consts::PI;

fn main() {
    let h = HTable::default();
    let points: Vec<(f64, f64)> = (0..41)
        .flat_map(|i| {
            let t = 20.0 * (i as f64 / 40.0).powi(2) + 0.0071;
            (0..37).map(move |j| (t, PI * (j as f64 + 0.29) / 37.0))
        })
        .collect();
    println!("| exponent | T × θ samples | KiB | max rel. error | where (T, θ) | build ms |");
    println!("|---|---|---|---|---|---|");
    for n in [1.0, 20.0, 100.0] {
        let exact: Vec<f64> = points
            .par_iter()
            .map(|&(t, th)| g_quadrature(h_exact, t, th, n, 1e-9))
            .collect();
        for size in [(64, 64), (128, 128), (128, 256), (256, 256)] {
            let mut ms: Vec<f64> = (0..3)
                .map(|_| {
                    let start = std::time::Instant::now();
                    std::hint::black_box(GTable::new(&h, n, size));
                    start.elapsed().as_secs_f64() * 1e3
                })
                .collect();
            ms.sort_by(f64::total_cmp);
            let table = GTable::new(&h, n, size);
            let (worst, at) = points
                .iter()
                .zip(&exact)
                .map(|(&(t, th), &e)| ((table.g(t, th) - e).abs() / e, (t, th)))
                .fold((0.0, (0.0, 0.0)), |a, b| if b.0 > a.0 { b } else { a });
            println!(
                "| {n} | {} × {} | {} | {worst:.2e} | ({:.2}, {:.2}) | {:.0} |",
                size.0,
                size.1,
                table.bytes() / 1024,
                at.0,
                at.1,
                ms[1]
            );
        }
    }
}
