//! A square sparse matrix in compressed-row form: the diffusion operator couples a center
//! only to the RBFs whose `3r` support holds it, a few percent of all pairs (see
//! BENCHMARKS.md, "Multiple scattering (diffusion)", for the dense/sparse comparison).

use nalgebra::{DMatrix, DVector};

/// `n × n` matrix stored by rows: row `i` holds `col[start[i]..start[i + 1]]`, `val[...]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Csr {
    start: Vec<usize>,
    col: Vec<usize>,
    val: Vec<f64>,
}

impl Csr {
    /// From the `(column, value)` entries of each row; every column must be `< rows.len()`.
    pub fn from_rows(rows: Vec<Vec<(usize, f64)>>) -> Csr {
        let n = rows.len();
        let mut start = Vec::with_capacity(n + 1);
        start.push(0);
        let nnz = rows.iter().map(Vec::len).sum();
        let (mut col, mut val) = (Vec::with_capacity(nnz), Vec::with_capacity(nnz));
        for row in rows {
            for (j, v) in row {
                assert!(j < n, "column {j} out of range for {n} × {n}");
                col.push(j);
                val.push(v);
            }
            start.push(col.len());
        }
        Csr { start, col, val }
    }

    /// Number of rows (= columns).
    pub fn n(&self) -> usize {
        self.start.len() - 1
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.val.len()
    }

    /// The stored `(column, value)` entries of row `i`.
    pub fn row(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = self.start[i]..self.start[i + 1];
        self.col[r.clone()]
            .iter()
            .copied()
            .zip(self.val[r].iter().copied())
    }

    /// `A x`.
    pub fn mul(&self, x: &DVector<f64>) -> DVector<f64> {
        DVector::from_fn(self.n(), |i, _| self.row(i).map(|(j, v)| v * x[j]).sum())
    }

    /// `Aᵀ y`.
    pub fn tr_mul(&self, y: &DVector<f64>) -> DVector<f64> {
        let mut out = DVector::zeros(self.n());
        for i in 0..self.n() {
            for (j, v) in self.row(i) {
                out[j] += v * y[i];
            }
        }
        out
    }

    /// The dense matrix (for checks and small systems).
    pub fn to_dense(&self) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(self.n(), self.n());
        for i in 0..self.n() {
            for (j, v) in self.row(i) {
                m[(i, j)] += v;
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_match_the_dense_matrix() {
        let a = Csr::from_rows(vec![
            vec![(0, 2.0), (2, -1.0)],
            vec![],
            vec![(1, 3.0), (2, 0.5), (1, 1.0)],
        ]);
        assert_eq!((a.n(), a.nnz()), (3, 5));
        let d = a.to_dense();
        assert_eq!(d[(2, 1)], 4.0);
        let x = DVector::from_vec(vec![1.0, -2.0, 4.0]);
        assert_eq!(a.mul(&x), &d * &x);
        assert_eq!(a.tr_mul(&x), d.transpose() * &x);
        assert_eq!(Csr::from_rows(vec![]).mul(&DVector::zeros(0)).len(), 0);
    }
}
