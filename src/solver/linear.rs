//! Sparse direct solvers (faer): Cholesky `L L^T` for SPD systems, LU for indefinite ones.
//! The symbolic factorisation (ordering + elimination tree) is computed once per sparsity
//! pattern; each Newton iteration only refactors numerically.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Accum, Conj, Mat, MatMut, Par, Side};
use nalgebra::DMatrix;
use rayon::prelude::*;

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
    /// Values of the Cholesky factor `L` (layout of the symbolic factorisation).
    Llt(Vec<f64>),
    /// Per independent block of the matrix, its Cholesky factor (see [`Block`]).
    Blocks(Vec<BlockFactor>),
    Lu(Box<Lu<usize, f64>>),
}

/// Equations coupled to no others (independent bodies: contact couples them only through the
/// multipliers, which condensation keeps out of the matrix) form blocks factored apart. A
/// block whose values did not change keeps its factor: a yielding body's tangent changes every
/// Newton pass, an elastic body's stiffness does not.
struct Block {
    /// The block's equations (sorted) in the whole matrix.
    eqs: Vec<usize>,
    /// Position in the whole matrix's values of each of the block's entries (its pattern order).
    positions: Vec<usize>,
    pattern: SymbolicSparseColMat<usize>,
    symbolic: SymbolicCholesky<usize>,
}

/// Blocks of fewer equations than this are factored together with the other small ones (one
/// block of several components is still block-diagonal): a split pays only for large bodies.
const MIN_BLOCK_EQUATIONS: usize = 1000;

/// The Cholesky factor of one [`Block`], the values it was factored from, and its share of the
/// last interface operator ([`SparseSolver::congruence`]) with the columns it came from.
struct BlockFactor {
    values: Vec<f64>,
    l: Vec<f64>,
    gram: std::sync::Mutex<Option<BlockGram>>,
    fixed: std::sync::Mutex<Option<FixedShare>>,
    /// Buffers of its substitutions, kept from one interface operator to the next.
    scratch: std::sync::Mutex<Scratch>,
}

/// A dense column-major matrix on a buffer that is kept and refilled (a re-pairing forms
/// hundreds of small products: fresh matrices cost more to allocate and clear than to fill).
#[derive(Default)]
struct Dense {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl Dense {
    /// `rows x cols` zeros in the buffer's storage.
    fn zeroed(&mut self, rows: usize, cols: usize) {
        self.rows = rows;
        self.cols = cols;
        self.data.clear();
        self.data.resize(rows * cols, 0.0);
    }

    fn at(&self, i: usize, j: usize) -> f64 {
        self.data[i + j * self.rows]
    }

    fn add(&mut self, i: usize, j: usize, v: f64) {
        self.data[i + j * self.rows] += v;
    }

    fn as_mut(&mut self) -> MatMut<'_, f64> {
        MatMut::from_column_major_slice_mut(&mut self.data, self.rows, self.cols)
    }
}

/// Work buffers of [`substitute`] and its products.
#[derive(Default)]
struct Scratch {
    /// `W`'s blocks of a substitution that is not kept.
    w: Vec<f64>,
    /// A supernode's update of the rows below it.
    update: Vec<f64>,
    /// A supernode's Gram product, a cross product, the other columns' share.
    gram: Dense,
    cross: Dense,
    others: Dense,
}

/// A block's fixed columns (see [`SparseSolver::congruence`]) with their `W` by supernode and
/// their own `W^T W`, kept while the block's factor is.
struct FixedShare {
    cols: Vec<(usize, Vec<(usize, f64)>)>,
    w: Substitution,
    gram: Dense,
}

/// `W = L^{-1} P B` of some columns of `B`, by supernode: the columns non-zero on each (sorted,
/// local indices) and the block of `W` over its rows and those columns, column-major at
/// `offset[s]` of one buffer (`size[s]` rows; not reached: no columns).
struct Substitution {
    cols_of: Vec<Vec<usize>>,
    offset: Vec<usize>,
    size: Vec<usize>,
    w: Vec<f64>,
}

impl Substitution {
    /// Supernode `s`'s block of `W` (`None`: not reached).
    fn block(&self, s: usize) -> Option<faer::MatRef<'_, f64>> {
        let (rows, cols) = (self.size[s], self.cols_of[s].len());
        (cols > 0).then(|| {
            let at = self.offset[s];
            faer::MatRef::from_column_major_slice(&self.w[at..at + rows * cols], rows, cols)
        })
    }
}

/// A block's share of `B^T A^{-1} B[:, from..]`: the columns of `B` that touch the block
/// (global index, entries in block numbering) and `W_b^T W_b` over them.
struct BlockGram {
    from: usize,
    /// The fixed columns it was formed with (the split's shares may differ in round-off).
    fixed: usize,
    cols: Vec<(usize, Vec<(usize, f64)>)>,
    gram: Dense,
}

/// Factors with fewer non-zeros than this are factored and solved on one thread: below it the
/// threads' synchronisation costs more than the work they share (measured up to 18.5M
/// non-zeros, 181k DOFs: see docs/performance.md, "Threads and memory of the process").
const PARALLEL_FACTOR_NNZ: usize = 20_000_000;

fn parallelism(s: &SymbolicCholesky<usize>) -> Par {
    if s.len_val() < PARALLEL_FACTOR_NNZ {
        Par::Seq
    } else {
        faer::get_global_parallelism()
    }
}

/// A numeric factor taken out of its [`SparseSolver`] (to be put back into the same solver):
/// a caller that alternates two matrices on one pattern keeps both factors instead of
/// refactoring.
pub struct Factor(Numeric);

/// A direct solver bound to one sparsity pattern.
pub struct SparseSolver {
    kind: LinearSolverKind,
    pattern: SymbolicSparseColMat<usize>,
    llt_symbolic: Option<SymbolicCholesky<usize>>,
    lu_symbolic: Option<SymbolicLu<usize>>,
    /// Independent blocks (Cholesky of a matrix with two or more large ones; else empty and the
    /// matrix is factored whole).
    blocks: Vec<Block>,
    numeric: Numeric,
}

/// The connected components of the pattern's graph, as sorted equation lists: the large ones
/// apart, the small ones merged into one (order: by first equation).
fn independent_blocks(pattern: &SymbolicSparseColMat<usize>) -> Vec<Vec<usize>> {
    let n = pattern.nrows();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    for j in 0..n {
        for &i in &ri[cp[j]..cp[j + 1]] {
            let (a, b) = (root(&mut parent, i), root(&mut parent, j));
            if a != b {
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        let r = root(&mut parent, i);
        members[r].push(i);
    }
    let mut blocks = Vec::new();
    let mut small = Vec::new();
    for m in members.into_iter().filter(|m| !m.is_empty()) {
        if m.len() >= MIN_BLOCK_EQUATIONS {
            blocks.push(m);
        } else {
            small.extend(m);
        }
    }
    if !small.is_empty() {
        small.sort_unstable();
        blocks.push(small);
    }
    blocks.sort_by_key(|b| b[0]);
    blocks
}

/// The sub-pattern of `eqs` (sorted, closed under coupling) in block numbering, with the
/// position of each of its entries in the whole pattern.
fn block_pattern(
    pattern: &SymbolicSparseColMat<usize>,
    eqs: &[usize],
    local: &mut [usize],
) -> (SymbolicSparseColMat<usize>, Vec<usize>) {
    for (k, &e) in eqs.iter().enumerate() {
        local[e] = k;
    }
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    let mut col_ptr = vec![0usize];
    let (mut row_idx, mut positions) = (Vec::new(), Vec::new());
    for &j in eqs {
        for p in cp[j]..cp[j + 1] {
            row_idx.push(local[ri[p]]);
            positions.push(p);
        }
        col_ptr.push(row_idx.len());
    }
    (SymbolicSparseColMat::new_checked(eqs.len(), eqs.len(), col_ptr, None, row_idx), positions)
}

/// Numeric Cholesky of `mat` into `l_values` (resized).
fn factor_llt(
    s: &SymbolicCholesky<usize>,
    mat: SparseColMatRef<usize, f64>,
    l_values: &mut Vec<f64>,
) -> Result<(), LinearSolverError> {
    let numeric_err = |msg: String| LinearSolverError::Numeric { kind: LinearSolverKind::Cholesky, msg };
    l_values.resize(s.len_val(), 0.0);
    let par = parallelism(s);
    let mut buf = MemBuffer::try_new(s.factorize_numeric_llt_scratch::<f64>(par, Default::default()))
        .map_err(|e| numeric_err(format!("{e:?}")))?;
    s.factorize_numeric_llt(
        l_values,
        mat,
        Side::Lower,
        Default::default(),
        par,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .map_err(|e| numeric_err(format!("{e:?}")))?;
    Ok(())
}

/// Solves `L L^T x = b` in place for the columns of `b`.
fn solve_llt(s: &SymbolicCholesky<usize>, l_values: &[f64], b: MatMut<f64>) {
    let par = parallelism(s);
    let mut buf = MemBuffer::new(s.solve_in_place_scratch::<f64>(b.ncols(), par));
    LltRef::new(s, l_values).solve_in_place_with_conj(Conj::No, b, par, MemStack::new(&mut buf));
}

impl SparseSolver {
    /// Symbolic factorisation of `pattern` (full pattern; Cholesky reads the lower triangle).
    pub fn new(pattern: &SymbolicSparseColMat<usize>, kind: LinearSolverKind) -> Result<Self, LinearSolverError> {
        let n = pattern.nrows();
        let nnz = pattern.row_idx().len();
        let err = |e: faer::sparse::FaerError| LinearSolverError::Symbolic { n, nnz, msg: format!("{e:?}") };
        let (llt_symbolic, lu_symbolic) = match kind {
            LinearSolverKind::Cholesky => (
                Some(
                    factorize_symbolic_cholesky(pattern.as_ref(), Side::Lower, Default::default(), Default::default())
                        .map_err(err)?,
                ),
                None,
            ),
            LinearSolverKind::Lu => (None, Some(SymbolicLu::try_new(pattern.as_ref()).map_err(err)?)),
        };
        if let Some(s) = &llt_symbolic {
            tracing::debug!(
                n,
                nnz,
                factor_nnz = s.len_val(),
                supernodal = matches!(s.raw(), SymbolicCholeskyRaw::Supernodal(_)),
                "symbolic Cholesky"
            );
        }
        let mut blocks = Vec::new();
        if kind == LinearSolverKind::Cholesky {
            let parts = independent_blocks(pattern);
            if parts.len() > 1 {
                let mut local = vec![0usize; n];
                for eqs in parts {
                    let (sub, positions) = block_pattern(pattern, &eqs, &mut local);
                    let symbolic =
                        factorize_symbolic_cholesky(sub.as_ref(), Side::Lower, Default::default(), Default::default())
                            .map_err(err)?;
                    blocks.push(Block { eqs, positions, pattern: sub, symbolic });
                }
                tracing::debug!(blocks = blocks.len(), sizes = ?blocks.iter().map(|b| b.eqs.len()).collect::<Vec<_>>(), "independent blocks");
            }
        }
        Ok(SparseSolver { kind, pattern: pattern.clone(), llt_symbolic, lu_symbolic, blocks, numeric: Numeric::None })
    }

    pub fn kind(&self) -> LinearSolverKind {
        self.kind
    }

    /// Numeric factorisation of the matrix with this pattern and `values`.
    pub fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolverError> {
        let mat = SparseColMatRef::new(self.pattern.as_ref(), values);
        let kind = self.kind;
        let numeric_err = |msg: String| LinearSolverError::Numeric { kind, msg };
        let previous = std::mem::replace(&mut self.numeric, Numeric::None);
        if !self.blocks.is_empty() {
            // Block by block; a block whose values are those of its last factor keeps it.
            let mut kept: Vec<Option<BlockFactor>> = match previous {
                Numeric::Blocks(f) => f.into_iter().map(Some).collect(),
                _ => (0..self.blocks.len()).map(|_| None).collect(),
            };
            // The blocks are independent: factored side by side (each by the same sequential
            // kernels as alone, so the factors do not depend on the thread count).
            let factors = self
                .blocks
                .par_iter()
                .zip(kept.par_iter_mut())
                .map(|(b, old)| {
                    let v: Vec<f64> = b.positions.iter().map(|&p| values[p]).collect();
                    match old.take() {
                        Some(f) if f.values == v => Ok(f),
                        old => {
                            let (mut l, scratch) = old.map(|f| (f.l, f.scratch)).unwrap_or_default();
                            let sub = SparseColMatRef::new(b.pattern.as_ref(), &v);
                            factor_llt(&b.symbolic, sub, &mut l)?;
                            Ok(BlockFactor {
                                values: v,
                                l,
                                gram: std::sync::Mutex::new(None),
                                fixed: std::sync::Mutex::new(None),
                                scratch,
                            })
                        }
                    }
                })
                .collect::<Result<Vec<_>, LinearSolverError>>()?;
            self.numeric = Numeric::Blocks(factors);
            return Ok(());
        }
        self.numeric = match (&self.llt_symbolic, &self.lu_symbolic) {
            (Some(s), _) => {
                // The factor's storage is reused from the previous factorisation.
                let mut l_values = match previous {
                    Numeric::Llt(v) => v,
                    _ => Vec::new(),
                };
                factor_llt(s, mat, &mut l_values)?;
                Numeric::Llt(l_values)
            }
            (None, Some(s)) => Numeric::Lu(Box::new(
                Lu::try_new_with_symbolic(s.clone(), mat).map_err(|e| numeric_err(format!("{e:?}")))?,
            )),
            (None, None) => return Err(LinearSolverError::NotFactored),
        };
        Ok(())
    }

    /// Takes the numeric factor out; the solver is unfactored until [`Self::factor`] or
    /// [`Self::put_factor`].
    pub fn take_factor(&mut self) -> Factor {
        Factor(std::mem::replace(&mut self.numeric, Numeric::None))
    }

    /// Puts back a factor [`Self::take_factor`] took from this solver (its storage is reused by
    /// the next [`Self::factor`]).
    pub fn put_factor(&mut self, factor: Factor) {
        self.numeric = factor.0;
    }

    /// Solves in place: `rhs <- A^{-1} rhs`.
    pub fn solve(&self, rhs: &mut [f64]) -> Result<(), LinearSolverError> {
        self.solve_many(rhs, 1)
    }

    /// Solves for `ncols` right-hand sides stored column after column in `rhs`.
    pub fn solve_many(&self, rhs: &mut [f64], ncols: usize) -> Result<(), LinearSolverError> {
        let n = rhs.len() / ncols.max(1);
        let mut b = MatMut::from_column_major_slice_mut(rhs, n, ncols);
        match (&self.numeric, &self.llt_symbolic) {
            (Numeric::Blocks(factors), _) => {
                // Independent blocks, solved side by side (sequential kernels in each).
                let rhs = b.as_ref();
                let solved: Vec<Mat<f64>> = self
                    .blocks
                    .par_iter()
                    .zip(factors)
                    .map(|(block, f)| {
                        let mut x = Mat::<f64>::from_fn(block.eqs.len(), ncols, |i, j| rhs[(block.eqs[i], j)]);
                        solve_llt(&block.symbolic, &f.l, x.as_mut());
                        x
                    })
                    .collect();
                for (block, x) in self.blocks.iter().zip(&solved) {
                    for j in 0..ncols {
                        for (i, &e) in block.eqs.iter().enumerate() {
                            b[(e, j)] = x[(i, j)];
                        }
                    }
                }
            }
            (Numeric::Llt(values), Some(s)) => solve_llt(s, values, b),
            (Numeric::Lu(f), _) => f.solve_in_place(b),
            _ => return Err(LinearSolverError::NotFactored),
        }
        Ok(())
    }

    /// `B^T A^{-1} B[:, from..]` for sparse columns `cols` of `B` (entries `(equation, coef)`),
    /// by forward substitution only: with `P A P^T = L L^T` and `W = L^{-1} P B`,
    /// `B^T A^{-1} B = W^T W`. `W` is non-zero only on the elimination-tree ancestors of the
    /// equations `B` touches (for interface rows of a 2D mesh: the leaves at the surface and
    /// the separators above them), so the substitution runs over those supernodes alone, all
    /// columns at once. The operation order is fixed (sequential kernels): bit-identical
    /// results on any thread count. `None` for an LU or a simplicial Cholesky factor (the
    /// caller then solves column by column).
    ///
    /// Factored by blocks, it is the sum of the blocks' shares, each over the columns touching
    /// it (a simplicial block's by column solves); a block whose factor and columns are those
    /// of the last call adds its kept share. The first `fixed` columns are the same from call
    /// to call while the factor is (the caller's ties and grounding rows before its contact
    /// rows): a block keeps their `W` and their share, and a call forms only the other columns'
    /// `W` and share and the cross products (the whole operator, `from = 0`, only). The fixed
    /// columns are substituted on their own, so the result does not depend on the calls before.
    pub fn congruence(&self, cols: &[Vec<(usize, f64)>], from: usize, fixed: usize) -> Option<DMatrix<f64>> {
        let nb = cols.len();
        let out = match (&self.numeric, &self.llt_symbolic) {
            (Numeric::Blocks(factors), _) => {
                // Each block's share on its own (side by side: independent, sequential kernels
                // in each), then summed in block order: the same sums on any thread count.
                self.blocks.par_iter().zip(factors).try_for_each(|(block, f)| -> Option<()> {
                    // The block's equations are sorted: a column entry's position in it.
                    let touching: Vec<(usize, Vec<(usize, f64)>)> = cols
                        .iter()
                        .enumerate()
                        .filter_map(|(j, col)| {
                            let c: Vec<(usize, f64)> = col
                                .iter()
                                .filter_map(|&(e, c)| block.eqs.binary_search(&e).ok().map(|k| (k, c)))
                                .collect();
                            (!c.is_empty()).then_some((j, c))
                        })
                        .collect();
                    let mut kept = f.gram.lock().ok()?;
                    let fresh =
                        !matches!(kept.as_ref(), Some(g) if g.from == from && g.fixed == fixed && g.cols == touching);
                    tracing::trace!(block = block.eqs[0], kept = !fresh, "interface operator share");
                    if fresh {
                        let mut scratch = f.scratch.lock().ok()?;
                        // The last share's storage is refilled.
                        let mut gram = kept.take().map(|g| g.gram).unwrap_or_default();
                        let k0 = touching.partition_point(|(j, _)| *j < from);
                        let nf = touching.partition_point(|(j, _)| *j < fixed);
                        let local_cols: Vec<Vec<(usize, f64)>> = touching.iter().map(|(_, c)| c.clone()).collect();
                        let split = from == 0 && nf > 0 && nf < touching.len();
                        let formed = split
                            && with_fixed_columns(
                                &block.symbolic,
                                &f.l,
                                FixedColumns { cols: &touching, local: &local_cols, nf },
                                &f.fixed,
                                &mut scratch,
                                &mut gram,
                            )
                            .is_some();
                        if !formed
                            && supernodal_congruence(&block.symbolic, &f.l, &local_cols, k0, &mut scratch, &mut gram)
                                .is_none()
                        {
                            solved_congruence(&block.symbolic, &f.l, &local_cols, k0, block.eqs.len(), &mut gram);
                        }
                        *kept = Some(BlockGram { from, fixed, cols: touching, gram });
                    }
                    Some(())
                })?;
                let mut out = DMatrix::<f64>::zeros(nb, nb - from);
                let sums = out.as_mut_slice();
                for f in factors {
                    let kept = f.gram.lock().ok()?;
                    let g = kept.as_ref()?;
                    let k0 = g.cols.partition_point(|(j, _)| *j < from);
                    for (b, (jb, _)) in g.cols[k0..].iter().enumerate() {
                        let column = &mut sums[(jb - from) * nb..(jb - from + 1) * nb];
                        for (a, (ja, _)) in g.cols.iter().enumerate() {
                            column[*ja] += g.gram.at(a, b);
                        }
                    }
                }
                out
            }
            (Numeric::Llt(values), Some(symbolic)) => {
                let mut out = Dense::default();
                supernodal_congruence(symbolic, values, cols, from, &mut Scratch::default(), &mut out)?;
                DMatrix::from_column_slice(nb, nb - from, &out.data)
            }
            _ => return None,
        };
        Some(out)
    }
}

/// `B^T A^{-1} B[:, from..]` by one solve per column (a simplicial factor of `n` equations),
/// into `out`.
fn solved_congruence(
    symbolic: &SymbolicCholesky<usize>,
    l: &[f64],
    cols: &[Vec<(usize, f64)>],
    from: usize,
    n: usize,
    out: &mut Dense,
) {
    let mut x = Mat::<f64>::zeros(n, cols.len() - from);
    for (b, col) in cols[from..].iter().enumerate() {
        for &(e, c) in col {
            x[(e, b)] += c;
        }
    }
    solve_llt(symbolic, l, x.as_mut());
    out.zeroed(cols.len(), cols.len() - from);
    for b in 0..cols.len() - from {
        for (a, col) in cols.iter().enumerate() {
            out.add(a, b, col.iter().map(|&(e, c)| c * x[(e, b)]).sum());
        }
    }
}

/// [`SparseSolver::congruence`] with one supernodal Cholesky factor, into `out` (`None` if
/// simplicial).
fn supernodal_congruence(
    symbolic: &SymbolicCholesky<usize>,
    values: &[f64],
    cols: &[Vec<(usize, f64)>],
    from: usize,
    scratch: &mut Scratch,
    out: &mut Dense,
) -> Option<()> {
    out.zeroed(cols.len(), cols.len() - from);
    let Scratch { w, update, gram, .. } = scratch;
    let sub = substitute(symbolic, values, cols, std::mem::take(w), update, |block, js| {
        accumulate_gram(out, gram, block, js, from)
    })?;
    *w = sub.w;
    Some(())
}

/// The columns of a block's share whose first `nf` are fixed: each with its global index and
/// local entries (`cols`), and the local entries alone (`local`).
struct FixedColumns<'a> {
    cols: &'a [(usize, Vec<(usize, f64)>)],
    local: &'a [Vec<(usize, f64)>],
    nf: usize,
}

/// The share `W^T W` of a block whose first `nf` columns are fixed, into `out`: theirs kept in
/// `fixed` (formed on their own when absent or different), the others' formed here, and the
/// cross products over the supernodes both reach. `None` if the factor is simplicial.
fn with_fixed_columns(
    symbolic: &SymbolicCholesky<usize>,
    values: &[f64],
    columns: FixedColumns<'_>,
    fixed: &std::sync::Mutex<Option<FixedShare>>,
    scratch: &mut Scratch,
    out: &mut Dense,
) -> Option<()> {
    let FixedColumns { cols, local, nf } = columns;
    let Scratch { w: w_buffer, update, gram: product, cross, others } = scratch;
    let mut kept = fixed.lock().ok()?;
    if !matches!(kept.as_ref(), Some(k) if k.cols[..] == cols[..nf]) {
        let mut gram = Dense::default();
        gram.zeroed(nf, nf);
        let w = substitute(symbolic, values, &local[..nf], Vec::new(), update, |block, js| {
            accumulate_gram(&mut gram, product, block, js, 0)
        })?;
        *kept = Some(FixedShare { cols: cols[..nf].to_vec(), w, gram });
    }
    let share = kept.as_ref()?;
    let n = cols.len();
    others.zeroed(n - nf, n - nf);
    let w = substitute(symbolic, values, &local[nf..], std::mem::take(w_buffer), update, |block, js| {
        accumulate_gram(others, product, block, js, 0)
    })?;
    out.zeroed(n, n);
    for j in 0..nf {
        out.data[j * n..j * n + nf].copy_from_slice(&share.gram.data[j * nf..(j + 1) * nf]);
    }
    for j in 0..n - nf {
        out.data[(nf + j) * n + nf..(nf + j + 1) * n].copy_from_slice(&others.data[j * (n - nf)..(j + 1) * (n - nf)]);
    }
    // Cross products on the supernodes both sets reach (the separators above both surfaces).
    for s in 0..w.cols_of.len() {
        let (Some(b), Some(a)) = (w.block(s), share.w.block(s)) else { continue };
        cross.zeroed(a.ncols(), b.ncols());
        matmul(cross.as_mut(), Accum::Replace, a.transpose(), b, 1.0, Par::Seq);
        for (jb, &cb) in w.cols_of[s].iter().enumerate() {
            for (ja, &ca) in share.w.cols_of[s].iter().enumerate() {
                let c = cross.at(ja, jb);
                out.add(ca, nf + cb, c);
                out.add(nf + cb, ca, c);
            }
        }
    }
    *w_buffer = w.w;
    Some(())
}

/// `W = L^{-1} P B` for sparse columns `cols` of `B`, by forward substitution over the
/// supernodes the columns reach: `W` is non-zero only on the elimination-tree ancestors of the
/// equations `B` touches (for interface rows of a 2D mesh: the leaves at the surface and the
/// separators above them), so the substitution runs over those supernodes alone, all columns
/// at once. `final_block(block, js)` gets each supernode's block of `W` (its rows, its columns
/// `js`) as soon as it is final, in elimination order. `W` is formed in the storage of `w`
/// (a buffer handed back by the caller: a re-pairing forms one per body) and returned in it;
/// `update` is scratch. `None` for a simplicial factor.
fn substitute(
    symbolic: &SymbolicCholesky<usize>,
    values: &[f64],
    cols: &[Vec<(usize, f64)>],
    mut w: Vec<f64>,
    update: &mut Vec<f64>,
    mut final_block: impl FnMut(faer::MatRef<f64>, &[usize]),
) -> Option<Substitution> {
    let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else { return None };
    let n = sym.nrows();
    let nb = cols.len();
    let factor = SupernodalLltRef::new(sym, values);
    let inv: Vec<usize> = match symbolic.perm() {
        Some(p) => p.arrays().1.to_vec(),
        None => (0..n).collect(),
    };
    let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
    let ns = sym.n_supernodes();
    let mut super_of = vec![0usize; n];
    for s in 0..ns {
        super_of[begin[s]..end[s]].iter_mut().for_each(|v| *v = s);
    }
    // Columns of W non-zero on each supernode: those touching it or any descendant
    // (W(:, j) is non-zero on the elimination-tree ancestors of column j's equations). In
    // elimination order a supernode's set is complete before it passes it to its parent,
    // the supernode of its first below-diagonal row.
    let mut cols_of: Vec<Vec<usize>> = vec![Vec::new(); ns];
    for (j, col) in cols.iter().enumerate() {
        for &(e, _) in col {
            cols_of[super_of[inv[e]]].push(j);
        }
    }
    for s in 0..ns {
        if cols_of[s].is_empty() {
            continue;
        }
        cols_of[s].sort_unstable();
        cols_of[s].dedup();
        if let Some(&r) = factor.supernode(s).pattern().first() {
            let own = std::mem::take(&mut cols_of[s]);
            cols_of[super_of[r]].extend_from_slice(&own);
            cols_of[s] = own;
        }
    }
    // W by supernode blocks: rows of the supernode, its own columns only (a column reaches
    // a few dozen of the supernodes, so a dense `reached rows x columns` W would be mostly
    // zeros to clear and carry).
    let size: Vec<usize> = (0..ns).map(|s| end[s] - begin[s]).collect();
    let mut offset = vec![0usize; ns];
    let mut m = 0;
    let mut total = 0;
    for s in 0..ns {
        offset[s] = total;
        if !cols_of[s].is_empty() {
            total += size[s] * cols_of[s].len();
            m += size[s];
        }
    }
    w.clear();
    w.resize(total, 0.0);
    for (j, col) in cols.iter().enumerate() {
        for &(e, c) in col {
            let r = inv[e];
            let t = super_of[r];
            // Every supernode a column touches has it in its set, and is reached.
            if let Ok(k) = cols_of[t].binary_search(&j) {
                w[offset[t] + k * size[t] + r - begin[t]] += c;
            }
        }
    }
    // Per supernode: solved with the diagonal block, pushed to the rows below by one
    // product, scattered into the blocks of the supernodes those rows belong to. Its rows
    // of W are then final (every descendant has pushed its update), so a Gram product
    // `W^T W` is accumulated supernode by supernode over its own columns only (the dense
    // product did eight times the work).
    let mut position = Vec::new();
    for s in 0..ns {
        let js = &cols_of[s];
        if js.is_empty() {
            continue;
        }
        let node = factor.supernode(s);
        let (rows, at) = (size[s], offset[s]);
        let (l_top, l_bot) = node.val().split_at_row(rows);
        let span = at..at + rows * js.len();
        solve_lower_triangular_in_place(
            l_top,
            MatMut::from_column_major_slice_mut(&mut w[span.clone()], rows, js.len()),
            Par::Seq,
        );
        let block = faer::MatRef::from_column_major_slice(&w[span], rows, js.len());
        final_block(block, js);
        let pattern = node.pattern();
        if !pattern.is_empty() {
            update.clear();
            update.resize(pattern.len() * js.len(), 0.0);
            let product = MatMut::from_column_major_slice_mut(update, pattern.len(), js.len());
            matmul(product, Accum::Replace, l_bot, block, 1.0, Par::Seq);
            let targets = TargetBlocks { super_of: &super_of, begin, cols_of: &cols_of, offset: &offset, size: &size };
            scatter_update(update, pattern, js, &targets, &mut w, &mut position);
        }
    }
    tracing::debug!(
        n,
        rows = nb,
        reached_equations = m,
        supernodes = ns,
        reached_supernodes = cols_of.iter().filter(|c| !c.is_empty()).count(),
        column_visits = cols_of.iter().map(|c| c.len()).sum::<usize>(),
        "interface operator by forward substitution"
    );
    Some(Substitution { cols_of, offset, size, w })
}

/// Adds the supernode block's share of `W^T W` (its own columns `js`, sorted) to the columns
/// `from..` of `out`: the lower half only when `from = 0` (the operator is symmetric).
/// `gram` is scratch.
fn accumulate_gram(out: &mut Dense, gram: &mut Dense, block: faer::MatRef<f64>, js: &[usize], from: usize) {
    let k0 = js.partition_point(|&j| j < from);
    if from == 0 {
        gram.zeroed(js.len(), js.len());
        triangular::matmul(
            gram.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            block.transpose(),
            BlockStructure::Rectangular,
            block,
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        for (b, &jb) in js.iter().enumerate() {
            out.add(jb, jb, gram.at(b, b));
            for (a, &ja) in js.iter().enumerate().skip(b + 1) {
                let g = gram.at(a, b);
                out.add(ja, jb, g);
                out.add(jb, ja, g);
            }
        }
    } else if k0 < js.len() {
        gram.zeroed(js.len(), js.len() - k0);
        matmul(gram.as_mut(), Accum::Replace, block.transpose(), block.subcols(k0, js.len() - k0), 1.0, Par::Seq);
        for (b, &jb) in js[k0..].iter().enumerate() {
            for (a, &ja) in js.iter().enumerate() {
                out.add(ja, jb - from, gram.at(a, b));
            }
        }
    }
}

/// Where the rows of `W` go: the supernode of each row (`super_of`) and each supernode's first
/// row (`begin`); the block of `W` of each supernode: its sorted columns (`cols_of`), where it
/// starts in `w` (`offset`) and its row count (`size`).
struct TargetBlocks<'a> {
    super_of: &'a [usize],
    begin: &'a [usize],
    cols_of: &'a [Vec<usize>],
    offset: &'a [usize],
    size: &'a [usize],
}

/// Subtracts a supernode's `update` (column-major; rows: its below-diagonal `pattern`, sorted;
/// columns: its own `js`) from the blocks of `W` (in `w`, laid out by `targets`) of the
/// supernodes those rows belong to. The rows come supernode by supernode; the
/// positions of `js` in each target's sorted column set are merged once per target (an
/// ancestor's set holds its descendants' columns).
fn scatter_update(
    update: &[f64],
    pattern: &[usize],
    js: &[usize],
    targets: &TargetBlocks<'_>,
    w: &mut [f64],
    position: &mut Vec<usize>,
) {
    let TargetBlocks { super_of, begin, cols_of, offset, size } = *targets;
    let below = pattern.len();
    let mut p = 0;
    while p < below {
        let t = super_of[pattern[p]];
        let q = p + pattern[p..].iter().take_while(|&&r| super_of[r] == t).count();
        let targets = &cols_of[t];
        position.clear();
        let mut i = 0;
        for &j in js {
            while i + 1 < targets.len() && targets[i] < j {
                i += 1;
            }
            position.push(i);
        }
        if !targets.is_empty() {
            let (rows, first) = (size[t], begin[t]);
            for (k, &pos) in position.iter().enumerate() {
                let target = &mut w[offset[t] + pos * rows..offset[t] + (pos + 1) * rows];
                for (&r, &u) in pattern[p..q].iter().zip(&update[k * below + p..k * below + q]) {
                    target[r - first] -= u;
                }
            }
        }
        p = q;
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
