//! Measures tables of paper C's special function against quadrature, for BENCHMARKS.md:
//! the largest relative error of `H(u, w)` over `htable::measurement_grid` (every `u ≥ 0`
//! the renderer queries, `w` up to `π/2 − 10⁻⁸`) for three parameterizations and several
//! sizes.
//!
//! `cargo run --release -p haze-scene --example table_error`

use haze_scene::paper_c::hfunc::{f_exact, h_oracle, k_exact};
use haze_scene::paper_c::htable::{HTable, measurement_grid};
use haze_scene::paper_c::table::Table2;
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_2;

fn main() {
    let grid = measurement_grid();
    let truth: Vec<f64> = grid.par_iter().map(|&(u, w)| h_oracle(u, w)).collect();
    let worst = |h: &(dyn Fn(f64, f64) -> f64 + Sync), keep: &(dyn Fn(f64, f64) -> bool + Sync)| {
        grid.par_iter()
            .zip(&truth)
            .filter(|((u, w), _)| keep(*u, *w))
            .map(|(&(u, w), &o)| {
                if o > 0.0 {
                    ((h(u, w) - o) / o).abs()
                } else {
                    0.0
                }
            })
            .reduce(|| 0.0, f64::max)
    };
    println!(
        "| side | KiB (f32) | K on (√(ρ/(1+ρ)), 2w/π) | H on (u/(1+u), 2w/π) | paper: F on u ∈ [0,10], H from it (u ≤ 10, w ≤ π/4) | paper: F itself (u ≤ 10) |"
    );
    println!("|---|---|---|---|---|---|");
    for n in [32, 64, 128, 256, 512] {
        let k = HTable::new(n);
        let e_k = worst(&|u, w| k.h(u, w), &|_, _| true);
        // H itself on u/(1+u): the u = ∞ column is 0.
        let h_tab = Table2::build(n, n, |x, y| {
            let w = FRAC_PI_2 * y;
            if x >= 1.0 {
                0.0
            } else {
                let u = x / (1.0 - x);
                let d = FRAC_PI_2 - w;
                if d.sin() <= 0.0 {
                    0.0
                } else {
                    let rho = u / d.sin();
                    d * k_exact(rho, d) / (1.0 + rho)
                }
            }
        });
        let e_h = worst(&|u, w| h_tab.at(u / (1.0 + u), w / FRAC_PI_2), &|_, _| true);
        // The paper's F on a box, and H = e^{u·tan w}·(F(u, π/2) − F(u, w)) from it.
        let umax = 10.0;
        let f_tab = Table2::build(n, n, |x, y| f_exact(umax * x, FRAC_PI_2 * y));
        let f_of = |u: f64, v: f64| f_tab.at(u / umax, v / FRAC_PI_2);
        let e_f = worst(
            &|u, w| {
                let t = w.tan();
                if !t.is_finite() {
                    return 0.0;
                }
                (u * t).exp() * (f_of(u, FRAC_PI_2) - f_of(u, w))
            },
            &|u, w| u <= umax && w <= std::f64::consts::FRAC_PI_4,
        );
        let f_grid: Vec<(f64, f64)> = grid.iter().copied().filter(|&(u, _)| u <= umax).collect();
        let e_f_itself = f_grid
            .par_iter()
            .map(|&(u, v)| {
                let o = f_exact(u, v);
                if o > 0.0 {
                    ((f_of(u, v) - o) / o).abs()
                } else {
                    0.0
                }
            })
            .reduce(|| 0.0, f64::max);
        println!(
            "| {n}² | {} | {e_k:.2e} | {e_h:.2e} | {e_f:.2e} | {e_f_itself:.2e} |",
            k.bytes() / 1024
        );
    }
}
