//! Sparse direct solvers (faer): Cholesky `L L^T` for SPD systems, LU for indefinite ones.
//! The symbolic factorisation (ordering + elimination tree) is computed once per sparsity
//! pattern; each Newton iteration only refactors numerically.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, Lu, SymbolicLlt, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{MatMut, Side};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinearSolverKind {
    /// Sparse Cholesky: symmetric positive definite systems (the default for solids).
    #[default]
    Cholesky,
    /// Sparse LU with partial pivoting: indefinite or non-symmetric systems.
    Lu,
}

#[derive(Debug, thiserror::Error)]
pub enum LinearSolverError {
    #[error("symbolic factorisation failed for a {n} x {n} matrix with {nnz} non-zeros: {msg}")]
    Symbolic { n: usize, nnz: usize, msg: String },
    #[error("numeric {kind:?} factorisation failed ({msg}): the matrix is singular or not positive definite (insufficient supports, or a material that lost stiffness)")]
    Numeric { kind: LinearSolverKind, msg: String },
    #[error("solve called before a successful numeric factorisation")]
    NotFactored,
}

enum Numeric {
    None,
    Llt(Llt<usize, f64>),
    Lu(Lu<usize, f64>),
}

/// A direct solver bound to one sparsity pattern.
pub struct SparseSolver {
    kind: LinearSolverKind,
    pattern: SymbolicSparseColMat<usize>,
    llt_symbolic: Option<SymbolicLlt<usize>>,
    lu_symbolic: Option<SymbolicLu<usize>>,
    numeric: Numeric,
}

impl SparseSolver {
    /// Symbolic factorisation of `pattern` (full pattern; Cholesky reads the lower triangle).
    pub fn new(pattern: &SymbolicSparseColMat<usize>, kind: LinearSolverKind) -> Result<Self, LinearSolverError> {
        let n = pattern.nrows();
        let nnz = pattern.row_idx().len();
        let err = |e: faer::sparse::FaerError| LinearSolverError::Symbolic { n, nnz, msg: format!("{e:?}") };
        let (llt_symbolic, lu_symbolic) = match kind {
            LinearSolverKind::Cholesky => {
                (Some(SymbolicLlt::try_new(pattern.as_ref(), Side::Lower).map_err(err)?), None)
            }
            LinearSolverKind::Lu => (None, Some(SymbolicLu::try_new(pattern.as_ref()).map_err(err)?)),
        };
        Ok(SparseSolver { kind, pattern: pattern.clone(), llt_symbolic, lu_symbolic, numeric: Numeric::None })
    }

    pub fn kind(&self) -> LinearSolverKind {
        self.kind
    }

    /// Numeric factorisation of the matrix with this pattern and `values`.
    pub fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolverError> {
        let mat = SparseColMatRef::new(self.pattern.as_ref(), values);
        self.numeric = Numeric::None;
        self.numeric = match (&self.llt_symbolic, &self.lu_symbolic) {
            (Some(s), _) => Numeric::Llt(
                Llt::try_new_with_symbolic(s.clone(), mat, Side::Lower)
                    .map_err(|e| LinearSolverError::Numeric { kind: self.kind, msg: format!("{e:?}") })?,
            ),
            (None, Some(s)) => Numeric::Lu(
                Lu::try_new_with_symbolic(s.clone(), mat)
                    .map_err(|e| LinearSolverError::Numeric { kind: self.kind, msg: format!("{e:?}") })?,
            ),
            (None, None) => return Err(LinearSolverError::NotFactored),
        };
        Ok(())
    }

    /// Solves in place: `rhs <- A^{-1} rhs`.
    pub fn solve(&self, rhs: &mut [f64]) -> Result<(), LinearSolverError> {
        self.solve_many(rhs, 1)
    }

    /// Solves for `ncols` right-hand sides stored column after column in `rhs`.
    pub fn solve_many(&self, rhs: &mut [f64], ncols: usize) -> Result<(), LinearSolverError> {
        let n = rhs.len() / ncols.max(1);
        let b = MatMut::from_column_major_slice_mut(rhs, n, ncols);
        match &self.numeric {
            Numeric::Llt(f) => f.solve_in_place(b),
            Numeric::Lu(f) => f.solve_in_place(b),
            Numeric::None => return Err(LinearSolverError::NotFactored),
        }
        Ok(())
    }
}

/// `y = A x` for a CSC matrix with both triangles stored.
pub fn spmv(pattern: &SymbolicSparseColMat<usize>, values: &[f64], x: &[f64], y: &mut [f64]) {
    y.iter_mut().for_each(|v| *v = 0.0);
    let cp = pattern.col_ptr();
    let ri = pattern.row_idx();
    for j in 0..pattern.ncols() {
        let xj = x[j];
        for p in cp[j]..cp[j + 1] {
            y[ri[p]] += values[p] * xj;
        }
    }
}
