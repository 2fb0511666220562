//! A 2-D table of `f32` samples on a uniform grid over the unit square, read by bilinear
//! interpolation — what a GPU's filtered texture does, so the CPU and a shader twin agree.

use rayon::prelude::*;

/// `nx × ny` samples at `x = i/(nx−1)`, `y = j/(ny−1)`, x fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct Table2 {
    pub nx: usize,
    pub ny: usize,
    pub data: Vec<f32>,
}

impl Table2 {
    /// Samples `f(x, y)` at every node (in parallel).
    ///
    /// # Panics
    /// If a side has fewer than 2 nodes.
    pub fn build(nx: usize, ny: usize, f: impl Fn(f64, f64) -> f64 + Sync) -> Table2 {
        assert!(nx >= 2 && ny >= 2, "a table needs 2 nodes per side");
        let data = (0..nx * ny)
            .into_par_iter()
            .map(|k| {
                let (i, j) = (k % nx, k / nx);
                f(i as f64 / (nx - 1) as f64, j as f64 / (ny - 1) as f64) as f32
            })
            .collect();
        Table2 { nx, ny, data }
    }

    /// Bilinear interpolation at `(x, y)`, clamped to the unit square (NaN reads as 0).
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let (i, tx) = cell(x, self.nx);
        let (j, ty) = cell(y, self.ny);
        let v = |i: usize, j: usize| f64::from(self.data[j * self.nx + i]);
        let a = v(i, j) + tx * (v(i + 1, j) - v(i, j));
        let b = v(i, j + 1) + tx * (v(i + 1, j + 1) - v(i, j + 1));
        a + ty * (b - a)
    }

    /// Bytes of the samples.
    pub fn bytes(&self) -> usize {
        self.data.len() * std::mem::size_of::<f32>()
    }
}

/// The cell `i ∈ [0, n−2]` holding `x ∈ [0, 1]` and the fraction `t ∈ [0, 1]` within it.
fn cell(x: f64, n: usize) -> (usize, f64) {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let f = x * (n - 1) as f64;
    let i = (f.floor() as usize).min(n - 2);
    (i, f - i as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_is_exact_on_bilinear_functions_and_clamps() {
        let t = Table2::build(5, 3, |x, y| 1.0 + 2.0 * x - 3.0 * y + 4.0 * x * y);
        for &(x, y) in &[(0.0, 0.0), (0.3, 0.7), (1.0, 1.0), (0.999, 0.01)] {
            let e = 1.0 + 2.0 * x - 3.0 * y + 4.0 * x * y;
            assert!((t.at(x, y) - e).abs() < 1e-6, "{x} {y}");
        }
        assert_eq!(t.at(-1.0, 2.0), t.at(0.0, 1.0));
        assert_eq!(t.at(f64::NAN, 0.0), t.at(0.0, 0.0));
        assert_eq!(t.bytes(), 60);
    }
}
