//! Interface condensation for contact between linear elastic bodies (issue 4, scope 3).
//!
//! The saddle-point system of one semi-smooth Newton iteration is
//! `K du + C^T dlambda = r_u`, plus one law row per multiplier (gap rows `C_a du = -w_a` for
//! ties, active normals and sticking nodes; multiplier rows `dlambda_a = ...` for open nodes and
//! `dlambda_t + mu s dlambda_n = ...` for slipping ones). `K` alone is singular when a body is held
//! only by contact (a loaded cylinder), so it is regularised exactly: with
//! `K_rho = K + rho C^T C` (`C` the live multiplier rows) and `dw = C du`,
//!
//! `K_rho du = r_u - C^T dlambda + rho C^T dw`  =>  `du = z + Y (rho dw - dlambda)`,
//! `z = K_rho^{-1} r_u`, `Y = K_rho^{-1} C^T`, and `dw = C z + D (rho dw - dlambda)` with the
//! Delassus operator `D = C K_rho^{-1} C^T` (L x L, L = live multipliers).
//!
//! `K_rho` is factored once (Cholesky) and `D` computed once per model; every load step costs
//! two solves with the factor and two internal-force evaluations, and every active-set
//! iteration one dense L x L solve in (`dlambda` of gap rows, `dw` of multiplier rows). The
//! iterates are those of the monolithic Newton (the same linear systems, rearranged), so both
//! agree to round-off (tested). Live rows: ties, paired contact normals, friction rows.

use crate::assembly::{Assembler, AssemblyInput, AssemblyOutput, SparsityPattern, CONSTRAINED};
use crate::fem::material::{PlasticState, Stress4};
use crate::model::Model;
use crate::solver::linear::{LinearSolverError, LinearSolverKind, SparseSolver};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Columns solved at a time when forming `D` (bounds the dense right-hand-side block).
const RHS_BLOCK: usize = 32;

pub(super) struct Condensed {
    /// Multipliers in the condensed set (indices in the model's multiplier order): ties, and the
    /// contact rows that may touch. Grows when a row outside it would penetrate (never shrinks).
    pub live: Vec<usize>,
    /// Position of each multiplier in the set.
    pub live_of: Vec<Option<usize>>,
    /// Set rows over free equations `(eq, coef)`.
    pub rows_free: Vec<Vec<(usize, f64)>>,
    /// Regularisation weight of each set row (`rho` on the rows of the initial set, whose
    /// `rho C^T C` is in the factored matrix; 0 on rows added later).
    pub rho: Vec<f64>,
    /// Delassus operator of `K_rho` on the set.
    pub d: DMatrix<f64>,
    /// Rows added after setup, batch by batch (a checkpoint stores it; replaying it on a restart
    /// rebuilds the identical `d`).
    pub log: Vec<Vec<usize>>,
}

/// Whether a model is solved by condensation: contact present and every body linear elastic.
pub(super) fn applies(m: &Model) -> bool {
    !m.contact.rows.is_empty() && m.materials.iter().all(|mat| !mat.has_state())
}

/// Paired contact rows (normal `k`) whose weighted gap `g / int Phi` is within `margin` times
/// their own `int Phi` (about the local segment length) of the smallest: contact candidates.
pub(super) fn near_rows(m: &Model, gaps: &[f64], margin: f64, g_min: f64) -> Vec<usize> {
    (0..m.contact.rows.len())
        .filter(|&k| m.contact.phi[k] > 0.0 && gaps[k] / m.contact.phi[k] <= g_min + margin * m.contact.phi[k])
        .collect()
}

/// Multipliers of normal rows `ks` and of their friction rows (model order).
pub(super) fn with_friction(m: &Model, ks: &[usize]) -> Vec<usize> {
    let (nt, nc) = (m.constraints.len(), m.contact.rows.len());
    let mut v: Vec<usize> = ks.iter().map(|&k| nt + k).collect();
    v.extend(m.contact.friction_normal.iter().enumerate().filter(|(_, k)| ks.contains(k)).map(|(j, _)| nt + nc + j));
    v
}

/// Margin of the candidate sets in units of the local segment length.
pub(super) const CANDIDATE_MARGIN: f64 = 0.5;

/// Pattern, assembler and Cholesky factor of `K_rho`, and the condensed operator on the initial
/// set: ties and the contact rows near the smallest initial gap (see [`near_rows`]).
pub(super) fn setup(
    m: &Model,
    parallel: bool,
) -> Result<(Assembler, SparseSolver, Vec<f64>, Condensed), LinearSolverError> {
    let nt = m.constraints.len();
    let all: Vec<&Vec<(usize, f64)>> = m.multiplier_rows().collect();
    let g0: Vec<f64> = m.contact.g0.clone();
    let g_min = (0..g0.len())
        .filter(|&k| m.contact.phi[k] > 0.0)
        .map(|k| g0[k] / m.contact.phi[k])
        .fold(f64::INFINITY, f64::min);
    let mut initial: Vec<usize> = (0..nt).collect();
    initial.extend(with_friction(m, &near_rows(m, &g0, CANDIDATE_MARGIN, g_min)));
    // rho |C|^2 about a tenth of the bulk stiffness E: K_rho stays well conditioned and the
    // floating modes of contact-held bodies are fixed.
    let n_coef = initial.iter().map(|&i| all[i].len()).sum::<usize>().max(1);
    let mean_coef = initial.iter().flat_map(|&i| all[i].iter()).map(|(_, c)| c.abs()).sum::<f64>() / n_coef as f64;
    let e_max = m.materials.iter().map(|mat| mat.elastic().young).fold(0.0, f64::max);
    let rho = if mean_coef > 0.0 { 0.1 * e_max / (mean_coef * mean_coef) } else { 0.0 };
    let mut penalty = m.penalty.clone();
    for &i in &initial {
        for &(d1, c1) in all[i] {
            for &(d2, c2) in all[i] {
                penalty.push((d1, d2, rho * c1 * c2));
            }
        }
    }
    let t0 = std::time::Instant::now();
    let pattern = SparsityPattern::with_constraints(m.num_nodes(), &m.elements, &m.dofs, &[], &penalty, 0, &[]);
    let mut solver = SparseSolver::new(&pattern.symbolic, LinearSolverKind::Cholesky)?;
    let mut values = vec![0.0; pattern.nnz()];
    let mut assembler = Assembler::new(pattern, &m.elements);
    let u = vec![0.0; m.dofs.num_dofs];
    let history = vec![PlasticState::default(); m.elements.num_states()];
    let mut history_new = history.clone();
    let mut stress = vec![Stress4::zeros(); m.elements.num_points()];
    let mut f_int = vec![0.0; m.dofs.num_dofs];
    assembler.assemble(
        &AssemblyInput {
            coords: &m.coords,
            elements: &m.elements,
            materials: &m.materials,
            rules: &m.rules,
            u: &u,
            state_old: &history,
        },
        AssemblyOutput {
            values: Some(&mut values),
            f_int: &mut f_int,
            stress: &mut stress,
            state_new: &mut history_new,
        },
        parallel,
    );
    let t1 = t0.elapsed().as_secs_f64();
    solver.factor(&values)?;
    let t2 = t0.elapsed().as_secs_f64();
    let mut cd = Condensed {
        live: vec![],
        live_of: vec![None; all.len()],
        rows_free: vec![],
        rho: vec![],
        d: DMatrix::zeros(0, 0),
        log: vec![],
    };
    cd.grow(m, &solver, &initial, rho)?;
    tracing::info!(
        set = cd.live.len(),
        rho,
        assembly_s = t1,
        factor_s = t2 - t1,
        delassus_s = t0.elapsed().as_secs_f64() - t2,
        "interface condensation: K_rho factored, Delassus operator formed"
    );
    Ok((assembler, solver, values, cd))
}

impl Condensed {
    /// Adds multipliers `new` (model order, not yet in the set) with regularisation weight
    /// `rho` (non-zero only for rows whose `rho C^T C` is in the factored matrix): one solve
    /// with the factor per new row, `RHS_BLOCK` at a time.
    pub fn grow(&mut self, m: &Model, solver: &SparseSolver, new: &[usize], rho: f64) -> Result<(), LinearSolverError> {
        let all: Vec<&Vec<(usize, f64)>> = m.multiplier_rows().collect();
        let old = self.live.len();
        for &i in new {
            debug_assert!(self.live_of[i].is_none());
            self.live_of[i] = Some(self.live.len());
            self.live.push(i);
            self.rows_free.push(
                all[i].iter().filter(|&&(d, _)| m.dofs.eq[d] != CONSTRAINED).map(|&(d, c)| (m.dofs.eq[d], c)).collect(),
            );
            self.rho.push(rho);
        }
        let nl = self.live.len();
        let mut d = DMatrix::zeros(nl, nl);
        d.view_mut((0, 0), (old, old)).copy_from(&self.d);
        let nf = m.dofs.num_free;
        // Blocks of RHS_BLOCK new rows, solved on the rayon threads (the triangular solves of
        // one block run on one core); each returns its columns of D over all set rows.
        let starts: Vec<usize> = (old..nl).step_by(RHS_BLOCK).collect();
        let rows_free = &self.rows_free;
        // The blocks already use the threads: faer's own parallelism inside each block's
        // triangular solves only adds synchronisation (futex/yield storms), so it is switched
        // off for the duration.
        let par = faer::get_global_parallelism();
        faer::set_global_parallelism(faer::Par::Seq);
        let cols: Vec<Result<Vec<Vec<f64>>, LinearSolverError>> = starts
            .par_iter()
            .map(|&start| {
                let nb = RHS_BLOCK.min(nl - start);
                let mut rhs = vec![0.0; nf * nb];
                for b in 0..nb {
                    for &(e, c) in &rows_free[start + b] {
                        rhs[b * nf + e] += c;
                    }
                }
                solver.solve_many(&mut rhs, nb)?;
                Ok((0..nb)
                    .map(|b| {
                        let col = &rhs[b * nf..(b + 1) * nf];
                        rows_free.iter().map(|row| row.iter().map(|&(e, c)| c * col[e]).sum()).collect()
                    })
                    .collect())
            })
            .collect();
        faer::set_global_parallelism(par);
        for (&start, block) in starts.iter().zip(cols) {
            for (b, col) in block?.into_iter().enumerate() {
                for (a, v) in col.into_iter().enumerate() {
                    d[(a, start + b)] = v;
                    if a < old {
                        d[(start + b, a)] = v;
                    }
                }
            }
        }
        self.d = d;
        Ok(())
    }
}
