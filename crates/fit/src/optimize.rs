//! Local minimization of the objective: L-BFGS-B with exact bounds (the paper's choice,
//! basin's port of L-BFGS-B 3.0), or unconstrained L-BFGS on a smooth reparameterization
//! `x = lo + (hi − lo)·σ(u)` of the box (σ the logistic function), which never pins a
//! parameter exactly on a bound.
//!
//! Two convergence tests, either of which stops a run: the per-iteration one of L-BFGS-B
//! (`f_{k−1} − f_k ≤ relative_reduction · max(f_k, 1)`, absolute for our `f < 1`), and a
//! windowed relative one for warm starts and polishes (`f_{k−W} − f_k ≤ window_gain · f_k`).
//! The first stops a warm start too early (one small step after an insertion gains less
//! than 1e-6 in absolute terms) or too late; the window measures the gain that matters
//! against the frame's own error.

use crate::bounds::Bounds;
use crate::grid::FitGrid;
use crate::objective::{self, PARAMS_PER_RBF, Scratch};
use basin::{
    ApplicationStop, BoxBounds, ConstraintDescription, ConstraintSet, Constraints, CostFunction,
    Executor, FirstOrderState, Gradient, Lbfgs, State,
};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::sync::Mutex;

/// Which local minimizer to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Optimizer {
    /// L-BFGS-B with the box bounds (paper A).
    #[default]
    Lbfgsb,
    /// L-BFGS on `u` with `x = lo + (hi − lo)·σ(u)`.
    LbfgsReparam,
}

/// Stopping rule of one minimization.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stop {
    /// Most iterations.
    pub max_iterations: u64,
    /// Stop when an iteration lowers the objective `f = rel_l2²` by less than
    /// `relative_reduction · max(f, 1)`: L-BFGS-B's own test, which for `f ≤ 1` (every
    /// useful fit) is an absolute one: 1e-6 stops a fit at rel_l2 0.07 once an iteration
    /// gains less than 2e-4 of `f`. 0 turns it off (the windowed test then decides).
    pub relative_reduction: f64,
    /// Iterations of the windowed test (0: off).
    pub window: u64,
    /// Stop when the last `window` iterations together lowered the objective by less than
    /// this fraction of it.
    pub window_gain: f64,
}

impl Default for Stop {
    fn default() -> Self {
        Stop {
            max_iterations: 200,
            relative_reduction: 1e-6,
            window: 0,
            window_gain: 0.0,
        }
    }
}

impl Stop {
    /// The windowed test as a stopping rule on the costs of successive iterations.
    fn window_test(&self) -> impl FnMut(f64) -> bool + 'static {
        let (w, gain) = (self.window as usize, self.window_gain);
        let mut costs: VecDeque<f64> = VecDeque::with_capacity(w + 1);
        move |cost: f64| {
            if w == 0 || !cost.is_finite() {
                return false;
            }
            costs.push_back(cost);
            if costs.len() <= w {
                return false;
            }
            let old = costs.pop_front().unwrap_or(cost);
            // f ≥ 0; a zero cost is converged whatever the window says.
            old - cost <= gain * cost.max(0.0)
        }
    }
}

/// What one minimization did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Minimized {
    pub iterations: u64,
    /// Objective passes (cost, or cost and gradient).
    pub passes: u64,
    pub cost: f64,
    /// Stopped by its convergence test rather than by the iteration limit.
    pub converged: bool,
}

/// The problem in scaled variables `y = x / scale` (see [`scales`]); bounds are scaled too.
struct Bounded<'a> {
    grid: &'a FitGrid,
    scratch: Mutex<Scratch>,
    scale: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Bounded<'_> {
    fn unscale(&self, y: &[f64]) -> Vec<f64> {
        y.iter().zip(&self.scale).map(|(y, s)| y * s).collect()
    }
}

/// Per-parameter scales that make the problem well conditioned for a quasi-Newton start:
/// the curvature of `f` along a center or radius is about `4w²/r²` times that along the
/// weight, so lengths are measured in units of the typical radius `r₀` and weights as is.
fn scales(n: usize, length: f64) -> Vec<f64> {
    [length, length, length, length, 1.0].repeat(n)
}

impl CostFunction for Bounded<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    type Error = Infallible;
    fn cost(&self, y: &Vec<f64>) -> Result<f64, Infallible> {
        let mut scratch = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        Ok(objective::cost_with(
            self.grid,
            &self.unscale(y),
            &mut scratch,
        ))
    }
}

impl Gradient for Bounded<'_> {
    type Gradient = Vec<f64>;
    fn gradient(&self, y: &Vec<f64>) -> Result<Vec<f64>, Infallible> {
        Ok(self.cost_and_gradient(y)?.1)
    }
    fn cost_and_gradient(&self, y: &Vec<f64>) -> Result<(f64, Vec<f64>), Infallible> {
        let mut g = vec![0.0; y.len()];
        let c = self.cost_and_gradient_into(y, &mut g)?;
        Ok((c, g))
    }
    fn cost_and_gradient_into(&self, y: &Vec<f64>, g: &mut Vec<f64>) -> Result<f64, Infallible> {
        g.resize(y.len(), 0.0);
        let mut scratch = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let c = objective::cost_and_gradient_with(self.grid, &self.unscale(y), g, &mut scratch);
        for (gk, s) in g.iter_mut().zip(&self.scale) {
            *gk *= s;
        }
        Ok(c)
    }
}

impl Constraints for Bounded<'_> {
    type Set = ConstraintSet<BoxBounds<Vec<f64>>>;
    fn constraints(&self) -> <Self::Set as ConstraintDescription>::Borrowed<'_> {
        ConstraintSet::new().with_bounds(BoxBounds::new(Some(&self.lower), Some(&self.upper)))
    }
}

/// The box mapped through the logistic function.
struct Reparam<'a> {
    grid: &'a FitGrid,
    scratch: Mutex<Scratch>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

fn sigmoid(u: f64) -> f64 {
    1.0 / (1.0 + (-u).exp())
}

impl Reparam<'_> {
    fn to_x(&self, u: &[f64]) -> Vec<f64> {
        u.iter()
            .zip(self.lower.iter().zip(&self.upper))
            .map(|(&u, (&lo, &hi))| lo + (hi - lo) * sigmoid(u))
            .collect()
    }

    fn to_u(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.lower.iter().zip(&self.upper))
            .map(|(&x, (&lo, &hi))| {
                let span = hi - lo;
                if span <= 0.0 {
                    return 0.0;
                }
                // Keep σ⁻¹ finite: a parameter on a bound starts a hair inside it.
                let t = ((x - lo) / span).clamp(1e-6, 1.0 - 1e-6);
                (t / (1.0 - t)).ln()
            })
            .collect()
    }
}

impl CostFunction for Reparam<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    type Error = Infallible;
    fn cost(&self, u: &Vec<f64>) -> Result<f64, Infallible> {
        let mut scratch = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        Ok(objective::cost_with(self.grid, &self.to_x(u), &mut scratch))
    }
}

impl Gradient for Reparam<'_> {
    type Gradient = Vec<f64>;
    fn gradient(&self, u: &Vec<f64>) -> Result<Vec<f64>, Infallible> {
        Ok(self.cost_and_gradient(u)?.1)
    }
    fn cost_and_gradient(&self, u: &Vec<f64>) -> Result<(f64, Vec<f64>), Infallible> {
        let x = self.to_x(u);
        let mut g = vec![0.0; x.len()];
        let mut scratch = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let c = objective::cost_and_gradient_with(self.grid, &x, &mut g, &mut scratch);
        // dx/du = (hi − lo)·σ(u)·(1 − σ(u)).
        for (k, gk) in g.iter_mut().enumerate() {
            let s = sigmoid(u[k]);
            *gk *= (self.upper[k] - self.lower[k]) * s * (1.0 - s);
        }
        Ok((c, g))
    }
}

/// Minimizes the objective from `params` (clamped into the box first), in place.
pub fn minimize(
    grid: &FitGrid,
    params: &mut Vec<f64>,
    bounds: &Bounds,
    optimizer: Optimizer,
    stop: Stop,
) -> Minimized {
    let n = params.len() / PARAMS_PER_RBF;
    for p in params.chunks_mut(PARAMS_PER_RBF) {
        bounds.clamp(grid, p);
    }
    if n == 0 || stop.max_iterations == 0 {
        return Minimized {
            iterations: 0,
            passes: 1,
            cost: objective::cost(grid, params),
            converged: true,
        };
    }
    let (lower, upper) = bounds.vectors(grid, n);
    // The typical radius of this set of RBFs sets the length scale.
    let length_scale = params.chunks(PARAMS_PER_RBF).map(|p| p[3]).sum::<f64>() / n as f64;
    match optimizer {
        Optimizer::Lbfgsb => {
            let scale = scales(n, length_scale);
            let div =
                |v: &[f64]| -> Vec<f64> { v.iter().zip(&scale).map(|(v, s)| v / s).collect() };
            let y0 = div(params);
            let problem = Bounded {
                grid,
                scratch: Mutex::default(),
                lower: div(&lower),
                upper: div(&upper),
                scale: scale.clone(),
            };
            let solver = Lbfgs::new()
                .with_absolute_projected_gradient_tolerance(1e-12)
                .with_relative_cost_reduction_tolerance(stop.relative_reduction);
            let mut window = stop.window_test();
            let run = Executor::new(problem, solver, FirstOrderState::new(y0))
                .max_iter(stop.max_iterations)
                .stop_when(move |s: &FirstOrderState<Vec<f64>>| {
                    (s.iter() > 0 && window(s.cost())).then(|| ApplicationStop::new("window"))
                })
                .run();
            match run {
                Ok(r) => {
                    tracing::trace!(
                        "L-BFGS-B: {} iterations, {} cost and {} gradient evaluations",
                        r.iter(),
                        r.counts.cost_evals,
                        r.counts.gradient_evals
                    );
                    let converged = matches!(
                        r.report.termination,
                        basin::Termination::Converged(_) | basin::Termination::Application(_)
                    );
                    let iterations = r.iter();
                    let passes = r.counts.cost_evals.max(r.counts.gradient_evals);
                    let cost = r.best_cost();
                    *params = r
                        .best_param()
                        .iter()
                        .zip(&scale)
                        .map(|(y, s)| y * s)
                        .collect();
                    Minimized {
                        iterations,
                        passes,
                        cost,
                        converged,
                    }
                }
                Err(e) => {
                    tracing::debug!("L-BFGS-B stopped: {e}");
                    Minimized {
                        iterations: 0,
                        passes: 1,
                        cost: objective::cost(grid, params),
                        converged: true,
                    }
                }
            }
        }
        Optimizer::LbfgsReparam => {
            let map = Reparam {
                grid,
                scratch: Mutex::default(),
                lower: lower.clone(),
                upper: upper.clone(),
            };
            let problem = Reparam {
                grid,
                scratch: Mutex::default(),
                lower,
                upper,
            };
            let u0 = map.to_u(params);
            let solver = Lbfgs::new()
                .unbounded()
                .with_relative_cost_change_tolerance(stop.relative_reduction);
            let mut window = stop.window_test();
            let run = Executor::new(problem, solver, FirstOrderState::new(u0))
                .max_iter(stop.max_iterations)
                .stop_when(move |s: &FirstOrderState<Vec<f64>>| {
                    (s.iter() > 0 && window(s.cost())).then(|| ApplicationStop::new("window"))
                })
                .run();
            match run {
                Ok(r) => {
                    let converged = matches!(
                        r.report.termination,
                        basin::Termination::Converged(_) | basin::Termination::Application(_)
                    );
                    *params = map.to_x(r.best_param());
                    Minimized {
                        iterations: r.iter(),
                        passes: r.counts.cost_evals.max(r.counts.gradient_evals),
                        cost: r.best_cost(),
                        converged,
                    }
                }
                Err(never) => match never {},
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Stop;

    /// The windowed test fires exactly when the last `window` iterations together gained
    /// less than `window_gain` of the cost, and never before `window + 1` costs are seen.
    #[test]
    fn window_test_compares_costs_window_iterations_apart() {
        let stop = Stop {
            window: 3,
            window_gain: 0.01,
            ..Stop::default()
        };
        let mut test = stop.window_test();
        // 1.0 → 0.9 → 0.85 → 0.84: over 3 iterations a gain of 0.16, far above 1 %.
        for c in [1.0, 0.9, 0.85, 0.84] {
            assert!(!test(c));
        }
        // 0.9 → 0.835 over the window: still above; then a flat tail stops it.
        assert!(!test(0.835));
        assert!(!test(0.834));
        assert!(test(0.8339), "0.84 → 0.8339 gains 0.7 %");
        // Off: never fires.
        let mut off = Stop::default().window_test();
        assert!((0..50).all(|_| !off(1.0)));
    }
}
