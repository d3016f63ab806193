//! Dense LU with partial pivoting (faer's blocked kernels) for the small interface systems:
//! the condensed active-set iterations solve one `L x L` system per iteration (L ~ 300 live
//! multipliers on a worn fretting scar), where an unblocked LU was the largest single cost.
//!
//! Always sequential: the systems are small, and a fixed operation order keeps runs and
//! restarts bit-identical whatever the thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::perm::PermRef;
use faer::{Conj, MatMut, MatRef, Par};
use nalgebra::{DMatrix, DVector};

/// `P A = L U` of a square matrix, `L` unit lower and `U` upper stored in one matrix.
pub struct DenseLu {
    n: usize,
    lu: Vec<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
}

impl DenseLu {
    /// Factors `a`; `None` when a pivot is exactly zero or not finite (a singular system, the
    /// same condition as `nalgebra`'s `LU::solve` returning `None`).
    pub fn new(a: DMatrix<f64>) -> Option<Self> {
        let n = a.nrows();
        assert_eq!(n, a.ncols(), "DenseLu needs a square matrix");
        let mut lu: Vec<f64> = a.data.into();
        let mut perm = vec![0usize; n];
        let mut perm_inv = vec![0usize; n];
        {
            let mat = MatMut::from_column_major_slice_mut(lu.as_mut_slice(), n, n);
            let req = factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, Default::default());
            let mut buf = MemBuffer::new(req);
            factor::lu_in_place(mat, &mut perm, &mut perm_inv, Par::Seq, MemStack::new(&mut buf), Default::default());
        }
        if (0..n).any(|i| {
            let d = lu[i * n + i];
            d == 0.0 || !d.is_finite()
        }) {
            return None;
        }
        Some(DenseLu { n, lu, perm, perm_inv })
    }

    /// `A^{-1} B` for the columns of `B`; `None` if the result is not finite.
    pub fn solve_columns(&self, b: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        assert_eq!(b.nrows(), self.n, "right-hand side rows");
        let mut x = b.clone();
        let (n, k) = (self.n, b.ncols());
        let lu = MatRef::from_column_major_slice(self.lu.as_slice(), n, n);
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let req = solve::solve_in_place_scratch::<usize, f64>(n, k, Par::Seq);
        let mut buf = MemBuffer::new(req);
        let rhs = MatMut::from_column_major_slice_mut(x.as_mut_slice(), n, k);
        solve::solve_in_place_with_conj(lu, lu, perm, Conj::No, rhs, Par::Seq, MemStack::new(&mut buf));
        x.iter().all(|v| v.is_finite()).then_some(x)
    }

    /// `A^{-1} b`; `None` if the result is not finite.
    pub fn solve(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        assert_eq!(b.len(), self.n, "right-hand side length");
        let mut x = b.clone();
        let n = self.n;
        let lu = MatRef::from_column_major_slice(self.lu.as_slice(), n, n);
        // SAFETY-free: `perm`/`perm_inv` come from `lu_in_place`, so they are inverse permutations.
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let req = solve::solve_in_place_scratch::<usize, f64>(n, 1, Par::Seq);
        let mut buf = MemBuffer::new(req);
        let rhs = MatMut::from_column_major_slice_mut(x.as_mut_slice(), n, 1);
        solve::solve_in_place_with_conj(lu, lu, perm, Conj::No, rhs, Par::Seq, MemStack::new(&mut buf));
        x.iter().all(|v| v.is_finite()).then_some(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against nalgebra's LU on a non-symmetric system that needs pivoting (zero leading
    /// entry): both solve it to round-off (1e-13 relative for a condition number ~10).
    #[test]
    fn solves_a_pivoted_system_like_nalgebra() {
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 2.0, 1.0, 3.0, -1.0, 2.0, 1.0, 1.0, 4.0]);
        let b = DVector::from_column_slice(&[1.0, -2.0, 0.5]);
        let x = DenseLu::new(a.clone()).expect("regular").solve(&b).expect("finite");
        let y = a.clone().lu().solve(&b).expect("regular");
        assert!((&x - &y).norm() <= 1e-13 * y.norm());
        assert!((&a * &x - &b).norm() <= 1e-13 * b.norm());
    }

    #[test]
    fn singular_matrix_gives_none() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
        assert!(DenseLu::new(a).is_none());
    }
}
