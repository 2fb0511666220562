//! Mallat's fast wavelet transform in 2-D, non-standard decomposition (paper E §3.2,
//! §4.2).
//!
//! Each step filters the current approximation along x then along y (module
//! [`crate::basis`] gives the filters), giving a coarser approximation `φφ` and three
//! detail bases on the same coarse grid: `φψ` (φ along x, ψ along y), `ψφ` and `ψψ` —
//! the four families of eq. 10. Only the approximation is decomposed further. This is the
//! *non-standard* decomposition: every basis function is a product of two 1-D functions
//! of the same level, so each level is one grid that a ray can traverse cell by cell
//! (the standard decomposition transforms all rows fully, then all columns, and mixes
//! levels, `ψ_j(x)ψ_k(y)` with `j ≠ k`, which no single grid carries).
//!
//! # Sizes that are not powers of two
//!
//! A fogmap of `w × h` pixels is the spline `Σ c_ij φ(u − i) φ(v − j)` over the whole
//! plane with every coefficient outside the image zero: the fog is clear air around its
//! map. The transform acts on that infinite sequence, which has finitely many non-zero
//! terms at every level because all four filters are finite; each level stores the
//! window of indices that can be non-zero ([`Grid`]). Any size — odd, prime, `1 × n` —
//! decomposes and reconstructs exactly, with no padding to a power of two and no
//! boundary filters; a window of `n` fine coefficients gives about `n/2 + 2` coarse ones.

use crate::basis::{Basis, Filter, Filters};

/// A window of a level's coefficients on the integer lattice: indices
/// `x0 … x0 + nx − 1` by `y0 … y0 + ny − 1`, x fastest; zero outside.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// First x index.
    pub x0: i64,
    /// First y index.
    pub y0: i64,
    /// Width.
    pub nx: usize,
    /// Height.
    pub ny: usize,
    /// `nx · ny` coefficients, x fastest.
    pub data: Vec<f64>,
}

impl Grid {
    /// A zero grid over a window.
    pub fn zeros(x0: i64, y0: i64, nx: usize, ny: usize) -> Grid {
        Grid {
            x0,
            y0,
            nx,
            ny,
            data: vec![0.0; nx * ny],
        }
    }

    /// The coefficient at `(i, j)`, zero outside the window.
    pub fn get(&self, i: i64, j: i64) -> f64 {
        let (x, y) = (i - self.x0, j - self.y0);
        if x < 0 || y < 0 || x >= self.nx as i64 || y >= self.ny as i64 {
            return 0.0;
        }
        self.data[y as usize * self.nx + x as usize]
    }

    /// Smallest coefficient (0 for an empty window).
    pub fn min(&self) -> f64 {
        self.data.iter().copied().fold(0.0_f64, f64::min)
    }

    /// Largest absolute coefficient.
    pub fn max_abs(&self) -> f64 {
        self.data.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
    }
}

/// The detail bases of one level (eq. 10): coefficients `β` of `φψ`, `δ` of `ψφ`, `γ` of
/// `ψψ`, all on the same window of the level's grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Details {
    /// `φ(x)ψ(y)`.
    pub phi_psi: Grid,
    /// `ψ(x)φ(y)`.
    pub psi_phi: Grid,
    /// `ψ(x)ψ(y)`.
    pub psi_psi: Grid,
}

/// A fogmap after `L` decomposition steps: level 0 is the coarsest approximation, level
/// `L` the fogmap; `details[n]` lives on the grid of level `n` and, with the
/// approximation of level `n`, synthesizes level `n + 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct Decomposition {
    /// Basis of every level.
    pub basis: Basis,
    /// `α`: the approximation of level 0.
    pub approx: Grid,
    /// Details of levels `0 … L − 1`.
    pub details: Vec<Details>,
    /// Window of the approximation of each level `0 … L` (the last is the fogmap's).
    pub windows: Vec<[i64; 4]>,
}

/// Range of `k` for which `Σ_i h_{i−2k} c_i` can be non-zero when `c` is non-zero on
/// `lo … hi`.
fn coarse_range(h: &Filter, lo: i64, hi: i64) -> (i64, i64) {
    // 2k ≥ lo − last and 2k ≤ hi − first.
    (
        (lo - h.last() + 1).div_euclid(2),
        (hi - h.first).div_euclid(2),
    )
}

/// One analysis step on a 1-D window: returns the first coarse index and the coarse and
/// detail coefficients over a common window.
pub fn analyze_1d(f: &Filters, lo: i64, c: &[f64]) -> (i64, Vec<f64>, Vec<f64>) {
    let hi = lo + c.len() as i64 - 1;
    let (sa, sb) = coarse_range(&f.a, lo, hi);
    let (da, db) = coarse_range(&f.b, lo, hi);
    let (k0, k1) = (sa.min(da), sb.max(db));
    let n = (k1 - k0 + 1).max(0) as usize;
    let apply = |h: &Filter, k: i64| -> f64 {
        let mut sum = 0.0;
        for (t, w) in h.taps.iter().enumerate() {
            let i = 2 * k + h.first + t as i64;
            if (lo..=hi).contains(&i) {
                sum += w * c[(i - lo) as usize];
            }
        }
        sum
    };
    let s = (0..n).map(|j| apply(&f.a, k0 + j as i64)).collect();
    let d = (0..n).map(|j| apply(&f.b, k0 + j as i64)).collect();
    (k0, s, d)
}

/// One synthesis step in 1-D: `c_i = Σ_k s_k p_{i−2k} + d_k q_{i−2k}` for
/// `i = lo … lo + n − 1`.
pub fn synthesize_1d(f: &Filters, k0: i64, s: &[f64], d: &[f64], lo: i64, n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n];
    let hi = lo + n as i64 - 1;
    for (j, (&sk, &dk)) in s.iter().zip(d).enumerate() {
        let k = k0 + j as i64;
        for (h, coef) in [(&f.p, sk), (&f.q, dk)] {
            if coef == 0.0 {
                continue;
            }
            for (t, w) in h.taps.iter().enumerate() {
                let i = 2 * k + h.first + t as i64;
                if (lo..=hi).contains(&i) {
                    out[(i - lo) as usize] += w * coef;
                }
            }
        }
    }
    out
}

/// Splits every row (`along_x`) or column of `g` into its coarse and detail halves.
fn analyze_axis(f: &Filters, g: &Grid, along_x: bool) -> (Grid, Grid) {
    let (len, lines, lo) = if along_x {
        (g.nx, g.ny, g.x0)
    } else {
        (g.ny, g.nx, g.y0)
    };
    let mut low: Option<Grid> = None;
    let mut high: Option<Grid> = None;
    let mut line = vec![0.0; len];
    for l in 0..lines {
        for (i, v) in line.iter_mut().enumerate() {
            *v = if along_x {
                g.data[l * g.nx + i]
            } else {
                g.data[i * g.nx + l]
            };
        }
        let (k0, s, d) = analyze_1d(f, lo, &line);
        let n = s.len();
        let make = || {
            if along_x {
                Grid::zeros(k0, g.y0, n, g.ny)
            } else {
                Grid::zeros(g.x0, k0, g.nx, n)
            }
        };
        let lg = low.get_or_insert_with(make);
        let hg = high.get_or_insert_with(make);
        for k in 0..n {
            let at = if along_x { l * n + k } else { k * g.nx + l };
            lg.data[at] = s[k];
            hg.data[at] = d[k];
        }
    }
    let empty = || Grid::zeros(g.x0, g.y0, 0, 0);
    (low.unwrap_or_else(empty), high.unwrap_or_else(empty))
}

/// Inverse of [`analyze_axis`], onto the window `lo … lo + n − 1` of that axis.
fn synthesize_axis(f: &Filters, low: &Grid, high: &Grid, along_x: bool, lo: i64, n: usize) -> Grid {
    debug_assert_eq!(
        (low.x0, low.y0, low.nx, low.ny),
        (high.x0, high.y0, high.nx, high.ny)
    );
    let mut out = if along_x {
        Grid::zeros(lo, low.y0, n, low.ny)
    } else {
        Grid::zeros(low.x0, lo, low.nx, n)
    };
    let (len, lines, k0) = if along_x {
        (low.nx, low.ny, low.x0)
    } else {
        (low.ny, low.nx, low.y0)
    };
    let (mut s, mut d) = (vec![0.0; len], vec![0.0; len]);
    for l in 0..lines {
        for k in 0..len {
            let at = if along_x { l * len + k } else { k * low.nx + l };
            s[k] = low.data[at];
            d[k] = high.data[at];
        }
        let c = synthesize_1d(f, k0, &s, &d, lo, n);
        for (i, v) in c.into_iter().enumerate() {
            let at = if along_x { l * n + i } else { i * out.nx + l };
            out.data[at] = v;
        }
    }
    out
}

/// One 2-D non-standard analysis step: `(φφ, details)` of an approximation.
pub fn analyze_2d(f: &Filters, g: &Grid) -> (Grid, Details) {
    let (low_x, high_x) = analyze_axis(f, g, true);
    let (phi_phi, phi_psi) = analyze_axis(f, &low_x, false);
    let (psi_phi, psi_psi) = analyze_axis(f, &high_x, false);
    (
        phi_phi,
        Details {
            phi_psi,
            psi_phi,
            psi_psi,
        },
    )
}

/// One 2-D synthesis step onto the window `[x0, y0, nx, ny]` of the finer level.
pub fn synthesize_2d(f: &Filters, approx: &Grid, det: &Details, window: [i64; 4]) -> Grid {
    let [x0, y0, nx, ny] = window;
    // Columns first (inverse order of analysis): rebuild the x-lowpass and x-highpass
    // rows on the fine y window, then the rows on the fine x window.
    let low_x = synthesize_axis(f, approx, &det.phi_psi, false, y0, ny as usize);
    let high_x = synthesize_axis(f, &det.psi_phi, &det.psi_psi, false, y0, ny as usize);
    synthesize_axis(f, &low_x, &high_x, true, x0, nx as usize)
}

impl Decomposition {
    /// Decomposes a fogmap's coefficients (`levels` steps).
    pub fn new(basis: Basis, fine: &Grid, levels: usize) -> Decomposition {
        let f = basis.filters();
        let mut windows = vec![[fine.x0, fine.y0, fine.nx as i64, fine.ny as i64]];
        let mut details = Vec::with_capacity(levels);
        let mut approx = fine.clone();
        for _ in 0..levels {
            let (coarse, det) = analyze_2d(&f, &approx);
            windows.push([coarse.x0, coarse.y0, coarse.nx as i64, coarse.ny as i64]);
            details.push(det);
            approx = coarse;
        }
        windows.reverse();
        details.reverse();
        Decomposition {
            basis,
            approx,
            details,
            windows,
        }
    }

    /// Number of decomposition steps `L`.
    pub fn levels(&self) -> usize {
        self.details.len()
    }

    /// Deconstruction (paper E §4.4): the details of every level re-synthesized into
    /// scaling functions of the next finer level with the two-scale relations and merged
    /// with the approximation, giving each level `l = 0 … L` as one scaling basis `A_l`
    /// (`A_0 = α`, `A_L` = the fogmap).
    pub fn deconstruct(&self) -> Vec<Grid> {
        let f = self.basis.filters();
        let mut levels = vec![self.approx.clone()];
        for (n, det) in self.details.iter().enumerate() {
            let next = synthesize_2d(&f, &levels[n], det, self.windows[n + 1]);
            levels.push(next);
        }
        levels
    }

    /// The fogmap, reconstructed from the decomposition.
    pub fn reconstruct(&self) -> Grid {
        self.deconstruct()
            .pop()
            .unwrap_or_else(|| self.approx.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn pseudo_random(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = Pcg64::seed_from_u64(seed);
        (0..n).map(|_| rng.random()).collect()
    }

    #[test]
    fn one_dimensional_round_trip_any_length() {
        for basis in Basis::ALL {
            let f = basis.filters();
            for n in [1usize, 2, 3, 5, 8, 13, 64] {
                let c = pseudo_random(n, n as u64);
                let (k0, s, d) = analyze_1d(&f, -3, &c);
                let back = synthesize_1d(&f, k0, &s, &d, -3, n);
                for (x, y) in c.iter().zip(&back) {
                    assert!((x - y).abs() < 1e-14, "{basis} n={n}");
                }
                // Outside the original window the synthesis is zero.
                let wide = synthesize_1d(&f, k0, &s, &d, -13, n + 20);
                assert!(
                    wide[..10]
                        .iter()
                        .chain(&wide[10 + n..])
                        .all(|v| v.abs() < 1e-14)
                );
            }
        }
    }

    fn random_grid(nx: usize, ny: usize, seed: u64) -> Grid {
        Grid {
            x0: 0,
            y0: 0,
            nx,
            ny,
            data: pseudo_random(nx * ny, seed),
        }
    }

    fn rel_err(a: &Grid, b: &Grid) -> f64 {
        assert_eq!((a.x0, a.y0, a.nx, a.ny), (b.x0, b.y0, b.nx, b.ny));
        let num: f64 = a
            .data
            .iter()
            .zip(&b.data)
            .map(|(x, y)| (x - y).powi(2))
            .sum();
        let den: f64 = a.data.iter().map(|x| x * x).sum();
        (num / den).sqrt()
    }

    #[test]
    fn perfect_reconstruction_2d_odd_sizes_several_levels() {
        for basis in Basis::ALL {
            for (nx, ny, levels) in [
                (1, 1, 1),
                (7, 5, 2),
                (13, 31, 4),
                (64, 64, 6),
                (33, 17, 5),
                (1, 9, 3),
            ] {
                let g = random_grid(nx, ny, (nx * 100 + ny) as u64);
                let dec = Decomposition::new(basis, &g, levels);
                assert_eq!(dec.levels(), levels);
                let back = dec.reconstruct();
                let err = rel_err(&g, &back);
                assert!(err < 1e-12, "{basis} {nx}x{ny} L={levels}: {err}");
            }
        }
    }

    #[test]
    fn deconstructed_levels_are_the_analysis_approximations() {
        for basis in Basis::ALL {
            let g = random_grid(23, 18, 7);
            let f = basis.filters();
            let dec = Decomposition::new(basis, &g, 3);
            let levels = dec.deconstruct();
            assert_eq!(levels.len(), 4);
            // Independent path: the approximations of successive analysis steps.
            let mut approx = vec![g.clone()];
            for _ in 0..3 {
                let (c, _) = analyze_2d(&f, approx.last().unwrap());
                approx.push(c);
            }
            approx.reverse();
            for (l, (a, b)) in levels.iter().zip(&approx).enumerate() {
                assert!(rel_err(b, a) < 1e-12, "{basis} level {l}");
            }
        }
    }

    #[test]
    fn constant_fog_keeps_its_density_and_has_no_interior_details() {
        for basis in Basis::ALL {
            let mut g = Grid::zeros(0, 0, 32, 32);
            g.data.iter_mut().for_each(|v| *v = 0.7);
            let dec = Decomposition::new(basis, &g, 2);
            // Away from the map's edges the coarse coefficients stay 0.7 (Σ a = 1) and the
            // details vanish (zero-mean wavelets).
            let a = &dec.approx;
            assert!(
                (a.get(4, 4) - 0.7).abs() < 1e-14,
                "{basis}: {}",
                a.get(4, 4)
            );
            let d = &dec.details[1];
            for grid in [&d.phi_psi, &d.psi_phi, &d.psi_psi] {
                assert!(grid.get(8, 8).abs() < 1e-14, "{basis}");
            }
        }
    }
}
