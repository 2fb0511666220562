//! Multiple scattering by diffusion: assembly of `A L⁰ = b` and its CGLS solve (three
//! channels), cold and warm, for realistic RBF sets: uniform random centers in the unit
//! box, radii 0.03–0.09, weights 0.1–1, σt = 7 (optical depth up to ~7 across, as in
//! paper A fig. 6), Ω = 0.6, g = 0.4. The sparse and dense products of one CGLS iteration
//! are timed side by side (the reason the matrix is sparse).

use criterion::{Criterion, criterion_group, criterion_main};
use haze_view::Medium;
use haze_view::diffusion::{DiffusionSolver, SolveOptions, Sources, assemble, solve_system};
use haze_volume::Rbf;
use nalgebra::DVector;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::hint::black_box;

/// Uniform numbers from a seeded PCG.
struct Uniform(Pcg64);

impl Uniform {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.0.random::<f64>()
    }
}

fn frame(n: usize, seed: u64) -> (Vec<Rbf>, Sources) {
    let mut rng = Uniform(Pcg64::seed_from_u64(seed));
    let rbfs = (0..n)
        .map(|_| {
            let c = [0; 3].map(|_| rng.uniform(0.0, 1.0));
            Rbf::new(c, rng.uniform(0.03, 0.09), rng.uniform(0.1, 1.0))
        })
        .collect();
    let sources = Sources {
        j0: (0..n)
            .map(|_| [0; 3].map(|_| rng.uniform(0.0, 2.0)))
            .collect(),
        j1: (0..n)
            .map(|_| [0; 3].map(|_| [0; 3].map(|_| rng.uniform(-1.0, 1.0))))
            .collect(),
        escape: Vec::new(),
    };
    (rbfs, sources)
}

fn bench(c: &mut Criterion) {
    let medium = Medium::new(7.0, 0.6, 0.4).unwrap();
    let opts = SolveOptions {
        max_iterations: 5000,
        tolerance: 1e-4,
    };
    let mut group = c.benchmark_group("diffusion");
    group.sample_size(10);
    for n in [300, 1000] {
        let (rbfs, sources) = frame(n, 1);
        group.bench_function(format!("assemble_{n}"), |b| {
            b.iter(|| assemble(black_box(&rbfs), &medium, &sources))
        });
        let system = assemble(&rbfs, &medium, &sources);
        let zero = vec![[0.0; 3]; n];
        group.bench_function(format!("solve_cold_{n}"), |b| {
            b.iter(|| solve_system(black_box(&system), &zero, &opts))
        });
        // The next frame: sources changed by 1 %, solved from this frame's solution.
        let mut next = sources.clone();
        next.j0.iter_mut().flatten().for_each(|v| *v *= 1.01);
        let mut solver = DiffusionSolver::new();
        solver.solve(&rbfs, &medium, &sources, &opts);
        group.bench_function(format!("assemble_and_solve_warm_{n}"), |b| {
            b.iter_batched(
                || solver.clone(),
                |mut s| s.solve(black_box(&rbfs), &medium, &next, &opts),
                criterion::BatchSize::SmallInput,
            )
        });
        let x = DVector::from_element(n, 1.0);
        group.bench_function(format!("product_sparse_{n}"), |b| {
            b.iter(|| (system.a.mul(black_box(&x)), system.a.tr_mul(&x)))
        });
        let dense = system.a.to_dense();
        group.bench_function(format!("product_dense_{n}"), |b| {
            b.iter(|| (&dense * black_box(&x), dense.tr_mul(&x)))
        });
    }
    group.finish();
    // The figures BENCHMARKS.md quotes beside the times.
    for n in [300, 1000] {
        let (rbfs, sources) = frame(n, 1);
        let system = assemble(&rbfs, &medium, &sources);
        let cold = solve_system(&system, &vec![[0.0; 3]; n], &opts);
        let mut solver = DiffusionSolver::new();
        solver.solve(&rbfs, &medium, &sources, &opts);
        let mut next = sources.clone();
        next.j0.iter_mut().flatten().for_each(|v| *v *= 1.01);
        let warm = solver.solve(&rbfs, &medium, &next, &opts);
        eprintln!(
            "n = {n}: {} non-zeros ({:.1} per row); cold {} iterations (residual {:.1e}), warm {} ({:.1e})",
            system.a.nnz(),
            system.a.nnz() as f64 / n as f64,
            cold.iterations,
            cold.residual,
            warm.iterations,
            warm.residual
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
