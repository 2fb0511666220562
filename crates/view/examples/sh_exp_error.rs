//! Accuracy and speed of SH exponentiation on smoke-like exponents (paper A §5.3).
//!
//! For orders 2..=6 and a range of `‖f̂‖`, exponents `f = −σt·T` where `T` is a random
//! sum of Gaussian-RBF optical-depth lobes (`sh::random_optical_depth`, seeds disjoint
//! from those `ShExp::new` fits on) and σt is chosen to give the norm. Prints, per cell,
//! the mean and worst relative L2 error `‖exp* − exp_reference‖/‖exp_reference‖` of the
//! optimal linear approximation and of scaling-and-squaring with `k` halvings, and the
//! µs per call. Run with `cargo run --release -p haze-view --example sh_exp_error`.

use std::time::Instant;

use haze_view::sh::{
    ExpMethod, ShExp, TripleProduct, exp_reference, halvings_for, random_optical_depth,
};

const FUNCTIONS: u64 = 12;

fn rel_err(a: &[f64], r: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(r).map(|(a, r)| (a - r) * (a - r)).sum();
    let n: f64 = r.iter().map(|r| r * r).sum();
    (d / n).sqrt()
}

/// Mean µs per call of `f` over `inputs`, repeated until at least 50 ms have passed.
fn micros(inputs: &[Vec<f64>], mut f: impl FnMut(&[f64]) -> Vec<f64>) -> f64 {
    let mut calls = 0usize;
    let start = Instant::now();
    let mut sink = 0.0;
    while start.elapsed().as_secs_f64() < 0.05 {
        for x in inputs {
            sink += f(x)[0];
            calls += 1;
        }
    }
    assert!(sink.is_finite() || sink.is_nan());
    start.elapsed().as_secs_f64() * 1e6 / calls as f64
}

fn main() {
    // 96 is inside the optimal-linear table (NORM_MAX = 100), 200 beyond it.
    let norms = [0.1, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 96.0, 200.0];
    println!(
        "| order | ‖f̂‖ | OL mean | OL max | OL µs | SS k | SS mean | SS max | SS µs | SS k+3 mean | SS k+3 µs |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for order in 2..=6 {
        let table = ShExp::new(order);
        let tp = TripleProduct::new(order);
        for &nu in &norms {
            let inputs: Vec<Vec<f64>> = (0..)
                .map(|i| random_optical_depth(order, 10_000 + i))
                .filter_map(|t| {
                    let hat = t[1..].iter().map(|v| v * v).sum::<f64>().sqrt();
                    (hat > 1e-6 * t[0].abs()).then(|| t.iter().map(|v| -nu / hat * v).collect())
                })
                .take(FUNCTIONS as usize)
                .collect();
            let refs: Vec<Vec<f64>> = inputs.iter().map(|f| exp_reference(order, f)).collect();
            let k = halvings_for(nu);
            let methods = [
                ExpMethod::OptimalLinear,
                ExpMethod::ScaleSquare { halvings: k },
                ExpMethod::ScaleSquare { halvings: k + 3 },
            ];
            let mut row = format!("| {order} | {nu} |");
            for (mi, m) in methods.iter().enumerate() {
                let errs: Vec<f64> = inputs
                    .iter()
                    .zip(&refs)
                    .map(|(f, r)| rel_err(&table.exp(f, *m, &tp), r))
                    .collect();
                let mean = errs.iter().sum::<f64>() / errs.len() as f64;
                let max = errs.iter().copied().fold(0.0, f64::max);
                let us = micros(&inputs, |f| table.exp(f, *m, &tp));
                match mi {
                    0 => row += &format!(" {mean:.2e} | {max:.2e} | {us:.2} |"),
                    1 => row += &format!(" {k} | {mean:.2e} | {max:.2e} | {us:.1} |"),
                    _ => row += &format!(" {mean:.2e} | {us:.1} |"),
                }
            }
            println!("{row}");
        }
    }
}
