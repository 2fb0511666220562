//! The per-frame solve: assemble, then CGLS per colour channel from a warm start.

use super::basis::{Neighbours, active};
use super::{Operators, Sources, System, cgls};
use crate::Medium;
use haze_volume::Rbf;
use nalgebra::DVector;
use rayon::prelude::*;

/// Stopping rule of the solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveOptions {
    /// Most CGLS iterations per channel.
    pub max_iterations: u32,
    /// Target relative residual `‖A L⁰ − b‖ / ‖b‖` per channel.
    pub tolerance: f64,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            max_iterations: 500,
            tolerance: 1e-6,
        }
    }
}

/// `L⁰` at the centers (the interpolation coefficients `L⁰_l` of eq. 12), per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    pub l0: Vec<[f64; 3]>,
    /// Most CGLS iterations among the three channels.
    pub iterations: u32,
    /// Largest relative residual `‖A L⁰ − b‖ / ‖b‖` among the channels (0 where `b = 0`).
    pub residual: f64,
    /// Every channel converged (see [`super::Cgls::converged`]).
    pub converged: bool,
}

/// Solves `system` per channel (in parallel) from `start`.
///
/// # Panics
/// If `start` does not hold one entry per unknown.
pub fn solve_system(system: &System, start: &[[f64; 3]], opts: &SolveOptions) -> Solution {
    let n = system.a.n();
    assert_eq!(
        start.len(),
        n,
        "start values for {} of {n} centers",
        start.len()
    );
    let runs: Vec<_> = (0..3)
        .into_par_iter()
        .map(|c| {
            let x0 = DVector::from_fn(n, |l, _| start[l][c]);
            cgls(
                &system.a,
                &system.b[c],
                x0,
                opts.max_iterations,
                opts.tolerance,
            )
        })
        .collect();
    Solution {
        l0: (0..n).map(|l| [0, 1, 2].map(|c| runs[c].x[l])).collect(),
        iterations: runs.iter().map(|r| r.iterations).max().unwrap_or(0),
        residual: runs.iter().map(|r| r.residual).fold(0.0, f64::max),
        converged: runs.iter().all(|r| r.converged),
    }
}

/// Solves frame after frame, each from the previous frame's solution.
#[derive(Clone, Debug, Default)]
pub struct DiffusionSolver {
    previous: Option<(Vec<Rbf>, Vec<[f64; 3]>)>,
}

impl DiffusionSolver {
    pub fn new() -> DiffusionSolver {
        DiffusionSolver::default()
    }

    /// Forgets the previous solution: the next solve starts from zero.
    pub fn reset(&mut self) {
        self.previous = None;
    }

    /// Assembles and solves one frame, then keeps its solution for the next.
    ///
    /// The start is the previous solution when the RBF count is unchanged (the same set,
    /// refitted); else the previous frame's `L⁰` field interpolated at the new centers
    /// (see `warm_start` below); else zero.
    pub fn solve(
        &mut self,
        rbfs: &[Rbf],
        medium: &Medium,
        sources: &Sources,
        opts: &SolveOptions,
    ) -> Solution {
        self.solve_with(&Operators::new(rbfs), rbfs, medium, sources, opts)
    }

    /// [`DiffusionSolver::solve`] with the operators of `rbfs` already computed (the
    /// caller keeps them for [`Operators::ms_source_sh`]).
    ///
    /// # Panics
    /// If `ops` or `sources` are not for as many centers as `rbfs`.
    pub fn solve_with(
        &mut self,
        ops: &Operators,
        rbfs: &[Rbf],
        medium: &Medium,
        sources: &Sources,
        opts: &SolveOptions,
    ) -> Solution {
        assert_eq!(ops.n(), rbfs.len(), "operators for another set of RBFs");
        let system = ops.system(medium, sources);
        let start = match &self.previous {
            Some((_, l0)) if l0.len() == rbfs.len() => l0.clone(),
            Some((prev_rbfs, l0)) => warm_start(prev_rbfs, l0, rbfs),
            None => vec![[0.0; 3]; rbfs.len()],
        };
        let solution = solve_system(&system, &start, opts);
        self.previous = Some((rbfs.to_vec(), solution.l0.clone()));
        solution
    }
}

/// Start values at the centers of `rbfs` from the previous frame's solution: its field
/// `L⁰(x) = Σ v_l(x) L⁰_l / D̃(x)` (the Gaussian-weighted previous centers, eq. 12) where the
/// previous RBFs cover `x`, else the value of the nearest previous center; zero when the
/// previous frame had no active RBF.
fn warm_start(prev: &[Rbf], l0: &[[f64; 3]], rbfs: &[Rbf]) -> Vec<[f64; 3]> {
    let act = active(prev);
    let nb = Neighbours::new(prev, &act);
    let live: Vec<usize> = (0..prev.len()).filter(|&l| act[l]).collect();
    rbfs.iter()
        .map(|b| {
            let (mut sum, mut weight) = ([0.0; 3], 0.0);
            for l in nb.candidates(b.center) {
                let v = prev[l].eval(b.center);
                weight += v;
                (0..3).for_each(|c| sum[c] += v * l0[l][c]);
            }
            if weight > 0.0 {
                return sum.map(|s| s / weight);
            }
            let dist2 = |l: usize| -> f64 {
                (0..3)
                    .map(|a| (prev[l].center[a] - b.center[a]).powi(2))
                    .sum()
            };
            live.iter()
                .copied()
                .min_by(|&i, &j| dist2(i).total_cmp(&dist2(j)))
                .map_or([0.0; 3], |l| l0[l])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warm_start_interpolates_inside_and_takes_the_nearest_outside() {
        let prev = [
            Rbf::new([0.0; 3], 1.0, 1.0),
            Rbf::new([1.0, 0.0, 0.0], 1.0, 3.0),
            Rbf::new([50.0, 0.0, 0.0], 1.0, 0.0), // inactive: never used
        ];
        let l0 = [[1.0, 2.0, 3.0], [5.0, 6.0, 7.0], [100.0; 3]];
        let at = |p: [f64; 3]| warm_start(&prev, &l0, &[Rbf::new(p, 0.1, 1.0)])[0];
        // Midway both Gaussians are equal: the weights are 1 : 3.
        let mid = at([0.5, 0.0, 0.0]);
        assert!((mid[0] - (1.0 + 3.0 * 5.0) / 4.0).abs() < 1e-12, "{mid:?}");
        assert_eq!(at([-10.0, 0.0, 0.0]), [1.0, 2.0, 3.0]);
        assert_eq!(at([40.0, 0.0, 0.0]), [5.0, 6.0, 7.0]);
        assert_eq!(
            warm_start(&[], &[], &[Rbf::new([0.0; 3], 1.0, 1.0)]),
            [[0.0; 3]]
        );
    }
}
