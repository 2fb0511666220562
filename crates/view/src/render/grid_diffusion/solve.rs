//! Finite volumes for the diffusion on the coarse grid, and the preconditioned conjugate
//! gradient that solves them (module docs of [`super`] for the face fluxes).

use super::CoarseGrid;
use crate::diffusion::Sources;
use crate::medium::Medium;
use rayon::prelude::*;

/// No neighbour (a face to a cell without smoke, or the box's face).
const NONE: u32 = u32::MAX;

/// Cells thinner than this (optical thickness `σtr·D·h` in transport mean free paths)
/// are left out: their light is the first collision's alone (`super` module docs), and
/// their near-zero density (often the residual's noise) would make the system stiff.
pub const THIN: f64 = 1e-2;

/// Stopping rule of the solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSolveOptions {
    /// Most CG iterations.
    pub max_iterations: u32,
    /// Target relative residual `‖A L⁰ − b‖ / ‖b‖` per channel.
    pub tolerance: f64,
}

impl Default for GridSolveOptions {
    fn default() -> Self {
        GridSolveOptions {
            max_iterations: 2000,
            tolerance: 1e-5,
        }
    }
}

/// The symmetric positive definite system `A L⁰ = b` on the cells with smoke.
#[derive(Clone, Debug)]
pub struct FvSystem {
    /// Grid index of each unknown.
    pub cells: Vec<usize>,
    /// Unknown of each grid cell (`NONE`: left out).
    slot: Vec<u32>,
    diag: Vec<f64>,
    /// Faces −x, +x, −y, +y, −z, +z: the neighbouring unknown (or `NONE`) and the
    /// conductance `G` of the face.
    nbr: Vec<[u32; 6]>,
    cond: Vec<[f64; 6]>,
    /// The source's own flux out of each face, per channel.
    drive: Vec<[[f64; 3]; 6]>,
    pub b: Vec<[f64; 3]>,
}

/// `(σt, σs, σa, σtr)`, `None` when the medium does not scatter (`σt = 0`, `Ω = 0`) or
/// is invalid.
fn coefficients(m: &Medium) -> Option<(f64, f64, f64, f64)> {
    let sigma_tr = (1.0 - m.albedo * m.g) * m.sigma_t;
    let sigma_a = (1.0 - m.albedo) * m.sigma_t;
    let ok = m.albedo > 0.0 && sigma_tr > 0.0 && sigma_tr.is_finite() && sigma_a.is_finite();
    ok.then_some((m.sigma_t, m.albedo * m.sigma_t, sigma_a, sigma_tr))
}

fn finite(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}

impl FvSystem {
    /// The finite-volume system (`super` module docs) of `grid` for `medium`, the
    /// per-cell sources `sources` and escape probabilities `escape` (one entry per grid
    /// cell each); `None` when there is nothing to solve (no cell thicker than [`THIN`],
    /// or a medium that does not scatter).
    ///
    /// # Panics
    /// If `sources` or `escape` do not hold one entry per cell.
    pub fn new(
        grid: &CoarseGrid,
        medium: &Medium,
        sources: &Sources,
        escape: &[f64],
    ) -> Option<FvSystem> {
        let n = grid.len();
        assert!(sources.j0.len() == n && sources.j1.len() == n && escape.len() == n);
        let (sigma_t, sigma_s, sigma_a, sigma_tr) = coefficients(medium)?;
        let hmin = grid.h[0].min(grid.h[1]).min(grid.h[2]);
        let mut slot = vec![NONE; n];
        let mut cells = Vec::new();
        for (i, &d) in grid.density.iter().enumerate() {
            if sigma_tr * d * hmin > THIN {
                slot[i] = cells.len() as u32;
                cells.push(i);
            }
        }
        if cells.is_empty() {
            return None;
        }
        let v = grid.volume();
        let p = |k: usize| {
            let e = escape[k];
            if e.is_finite() {
                e.clamp(0.0, 1.0)
            } else {
                1.0
            }
        };
        // (1 − P) J¹, the flux the source keeps.
        let kept_j1 = |k: usize| sources.j1[k].map(|ch| ch.map(|x| (1.0 - p(k)) * finite(x)));
        let rows: Vec<_> = cells
            .par_iter()
            .map(|&i| {
                let c = grid.coords(i);
                let di = grid.density[i];
                let (mut nbr, mut cond, mut drive) = ([NONE; 6], [0.0; 6], [[0.0; 3]; 6]);
                let mut diag = v * (sigma_a + sigma_s * p(i)) * di;
                let mut b =
                    [0, 1, 2].map(|ch| v * sigma_t * di * (1.0 - p(i)) * finite(sources.j0[i][ch]));
                for f in 0..6 {
                    let (a, up) = (f / 2, f % 2 == 1);
                    let mut cj = c;
                    let inside = if up {
                        cj[a] += 1;
                        cj[a] < grid.dims[a]
                    } else if c[a] > 0 {
                        cj[a] -= 1;
                        true
                    } else {
                        false
                    };
                    let Some(j) = inside.then(|| grid.index(cj)).filter(|&j| slot[j] != NONE)
                    else {
                        continue;
                    };
                    let h = grid.h[a];
                    let area = v / h;
                    let n = if up { 1.0 } else { -1.0 };
                    let df = 0.5 * (di + grid.density[j]);
                    let kept = 1.0 - 0.5 * (p(i) + p(j));
                    let g = finite(area * kept / (3.0 * sigma_tr * df * h));
                    let (ji, jj) = (kept_j1(i), kept_j1(j));
                    diag += g;
                    cond[f] = g;
                    nbr[f] = slot[j];
                    for ch in 0..3 {
                        let flux = 0.5 * (ji[ch][a] + jj[ch][a]) * n;
                        drive[f][ch] = finite(area * sigma_t / (3.0 * sigma_tr) * flux);
                        b[ch] -= drive[f][ch];
                    }
                }
                (diag, nbr, cond, drive, b)
            })
            .collect();
        let mut sys = FvSystem {
            cells,
            slot,
            diag: Vec::with_capacity(rows.len()),
            nbr: Vec::with_capacity(rows.len()),
            cond: Vec::with_capacity(rows.len()),
            drive: Vec::with_capacity(rows.len()),
            b: Vec::with_capacity(rows.len()),
        };
        for (d, n, c, dr, b) in rows {
            sys.diag.push(d);
            sys.nbr.push(n);
            sys.cond.push(c);
            sys.drive.push(dr);
            sys.b.push(b);
        }
        Some(sys)
    }

    /// Number of unknowns.
    pub fn n(&self) -> usize {
        self.cells.len()
    }

    /// The unknown of grid cell `i`, if it has smoke.
    pub fn unknown(&self, i: usize) -> Option<usize> {
        let s = self.slot[i];
        (s != NONE).then_some(s as usize)
    }

    /// `y = A x` per channel.
    pub fn apply(&self, x: &[[f64; 3]], y: &mut [[f64; 3]]) {
        let min = min_len(y.len());
        y.par_iter_mut()
            .with_min_len(min)
            .enumerate()
            .for_each(|(k, yk)| {
                let mut s = [0, 1, 2].map(|ch| self.diag[k] * x[k][ch]);
                for f in 0..6 {
                    let j = self.nbr[k][f];
                    if j != NONE {
                        for ch in 0..3 {
                            s[ch] -= self.cond[k][f] * x[j as usize][ch];
                        }
                    }
                }
                *yk = s;
            });
    }

    /// The flux density of `L¹/3` through each axis at unknown `k` (mean of the two faces,
    /// each the outward flux `G(L_k − L_j) + drive` over its area; none through a face
    /// to a cell left out), times 3: `L¹` per channel, `[channel][axis]`.
    pub fn flux_moment(&self, grid: &CoarseGrid, l0: &[[f64; 3]], k: usize) -> [[f64; 3]; 3] {
        let v = grid.volume();
        let mut l1 = [[0.0; 3]; 3];
        for f in 0..6 {
            let (a, up) = (f / 2, f % 2 == 1);
            let area = v / grid.h[a];
            let j = self.nbr[k][f];
            for ch in 0..3 {
                if j == NONE {
                    continue;
                }
                let lj = l0[j as usize][ch];
                let q = self.cond[k][f] * (l0[k][ch] - lj) + self.drive[k][f][ch];
                // Outward through +a counts along +a, through −a against it.
                let s = if up { 1.0 } else { -1.0 };
                l1[ch][a] += 1.5 * s * q / area;
            }
        }
        l1
    }
}

/// The solution on the unknowns, with how the solve ended.
#[derive(Clone, Debug)]
pub struct GridSolution {
    pub l0: Vec<[f64; 3]>,
    pub iterations: u32,
    /// Largest relative residual among the channels (0 where `b = 0`).
    pub residual: f64,
}

/// Unknowns below which each step of the solve runs unsplit on one thread: there a step
/// is a few microseconds of work, less than handing halves between threads (on held-out
/// plume-e at detail 0.43, 535 unknowns and 62 iterations took 13–16 ms split, most of
/// it the threads' hand-offs; BENCHMARKS.md, "The coarse grid's solve on one thread").
pub const SPLIT_FROM: usize = 1 << 13;

/// The least items a worker takes in a step over `n` unknowns ([`SPLIT_FROM`]).
fn min_len(n: usize) -> usize {
    if n < SPLIT_FROM { n.max(1) } else { 1 }
}

fn dot3(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    a.par_iter()
        .with_min_len(min_len(a.len()))
        .zip(b)
        .map(|(x, y)| [x[0] * y[0], x[1] * y[1], x[2] * y[2]])
        .reduce(|| [0.0; 3], |s, t| [s[0] + t[0], s[1] + t[1], s[2] + t[2]])
}

/// Conjugate gradient with the Jacobi preconditioner, the three channels side by side
/// (each its own step lengths), from `start` (zero when `None`). It runs on the thread
/// pool (one hand-off for the whole solve rather than one a step), each step split
/// between the workers from [`SPLIT_FROM`] unknowns.
pub fn solve(sys: &FvSystem, start: Option<&[[f64; 3]]>, opts: &GridSolveOptions) -> GridSolution {
    rayon::scope(|_| conjugate_gradient(sys, start, opts))
}

/// [`solve`]'s iterations, on the calling thread's pool.
fn conjugate_gradient(
    sys: &FvSystem,
    start: Option<&[[f64; 3]]>,
    opts: &GridSolveOptions,
) -> GridSolution {
    let n = sys.n();
    let min = min_len(n);
    let mut x = match start {
        Some(s) if s.len() == n => s.to_vec(),
        _ => vec![[0.0; 3]; n],
    };
    let mut ax = vec![[0.0; 3]; n];
    sys.apply(&x, &mut ax);
    let mut r: Vec<[f64; 3]> = (0..n)
        .map(|k| [0, 1, 2].map(|c| sys.b[k][c] - ax[k][c]))
        .collect();
    let bn = dot3(&sys.b, &sys.b).map(f64::sqrt);
    let precond = |r: &[[f64; 3]]| -> Vec<[f64; 3]> {
        r.par_iter()
            .with_min_len(min)
            .zip(&sys.diag)
            .map(|(rk, d)| rk.map(|v| v / d))
            .collect()
    };
    let rel = |r: &[[f64; 3]]| -> [f64; 3] {
        let rn = dot3(r, r).map(f64::sqrt);
        [0, 1, 2].map(|c| if bn[c] > 0.0 { rn[c] / bn[c] } else { 0.0 })
    };
    let mut z = precond(&r);
    let mut p = z.clone();
    let mut rz = dot3(&r, &z);
    let mut it = 0;
    let mut res = rel(&r);
    while it < opts.max_iterations && res.iter().any(|&e| e > opts.tolerance) {
        sys.apply(&p, &mut ax);
        let pap = dot3(&p, &ax);
        let alpha = [0, 1, 2].map(|c| {
            if res[c] > opts.tolerance && pap[c] > 0.0 {
                rz[c] / pap[c]
            } else {
                0.0
            }
        });
        x.par_iter_mut()
            .with_min_len(min)
            .zip(r.par_iter_mut())
            .zip(p.par_iter().zip(&ax))
            .for_each(|((xk, rk), (pk, ak))| {
                for c in 0..3 {
                    xk[c] += alpha[c] * pk[c];
                    rk[c] -= alpha[c] * ak[c];
                }
            });
        it += 1;
        res = rel(&r);
        z = precond(&r);
        let rz_new = dot3(&r, &z);
        let beta = [0, 1, 2].map(|c| if rz[c] > 0.0 { rz_new[c] / rz[c] } else { 0.0 });
        rz = rz_new;
        p.par_iter_mut()
            .with_min_len(min)
            .zip(&z)
            .for_each(|(pk, zk)| {
                for c in 0..3 {
                    pk[c] = zk[c] + beta[c] * pk[c];
                }
            });
    }
    GridSolution {
        l0: x,
        iterations: it,
        residual: res.into_iter().fold(0.0, f64::max),
    }
}
