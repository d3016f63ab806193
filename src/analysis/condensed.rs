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

/// Columns solved at a time when forming `D` (bounds the dense right-hand-side block).
const RHS_BLOCK: usize = 32;

pub(super) struct Condensed {
    /// Live multipliers (indices in the model's multiplier order).
    pub live: Vec<usize>,
    /// Position of each multiplier among the live ones.
    pub live_of: Vec<Option<usize>>,
    /// Live rows over free equations `(eq, coef)`.
    pub rows_free: Vec<Vec<(usize, f64)>>,
    /// Delassus operator of `K_rho`.
    pub d: DMatrix<f64>,
    pub rho: f64,
}

/// Whether a model is solved by condensation: contact present and every body linear elastic.
pub(super) fn applies(m: &Model) -> bool {
    !m.contact_rows.is_empty() && m.materials.iter().all(|mat| !mat.has_state())
}

/// Pattern, assembler and Cholesky factor of `K_rho`, and the condensed operator.
pub(super) fn setup(
    m: &Model,
    parallel: bool,
) -> Result<(Assembler, SparseSolver, Vec<f64>, Condensed), LinearSolverError> {
    let (nt, nc) = (m.constraints.len(), m.contact_rows.len());
    let all: Vec<&Vec<(usize, f64)>> = m.multiplier_rows().collect();
    let live: Vec<usize> = (0..all.len()).filter(|&i| i < nt || i >= nt + nc || m.contact_phi[i - nt] > 0.0).collect();
    let mut live_of = vec![None; all.len()];
    for (a, &i) in live.iter().enumerate() {
        live_of[i] = Some(a);
    }
    let rows_free: Vec<Vec<(usize, f64)>> = live
        .iter()
        .map(|&i| {
            all[i].iter().filter(|&&(d, _)| m.dofs.eq[d] != CONSTRAINED).map(|&(d, c)| (m.dofs.eq[d], c)).collect()
        })
        .collect();
    // rho |C|^2 about a tenth of the bulk stiffness E: K_rho stays well conditioned and the
    // floating modes of contact-held bodies are fixed.
    let n_coef = live.iter().map(|&i| all[i].len()).sum::<usize>().max(1);
    let mean_coef = live.iter().flat_map(|&i| all[i].iter()).map(|(_, c)| c.abs()).sum::<f64>() / n_coef as f64;
    let e_max = m.materials.iter().map(|mat| mat.elastic().young).fold(0.0, f64::max);
    let rho = if mean_coef > 0.0 { 0.1 * e_max / (mean_coef * mean_coef) } else { 0.0 };
    let mut penalty = m.penalty.clone();
    for &i in &live {
        for &(d1, c1) in all[i] {
            for &(d2, c2) in all[i] {
                penalty.push((d1, d2, rho * c1 * c2));
            }
        }
    }
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
    solver.factor(&values)?;
    // D = C K_rho^{-1} C^T, RHS_BLOCK columns at a time.
    let (nf, nl) = (m.dofs.num_free, live.len());
    let mut d = DMatrix::zeros(nl, nl);
    let mut block = vec![0.0; nf * RHS_BLOCK];
    for start in (0..nl).step_by(RHS_BLOCK) {
        let nb = RHS_BLOCK.min(nl - start);
        let rhs = &mut block[..nf * nb];
        rhs.iter_mut().for_each(|v| *v = 0.0);
        for b in 0..nb {
            for &(e, c) in &rows_free[start + b] {
                rhs[b * nf + e] += c;
            }
        }
        solver.solve_many(rhs, nb)?;
        for b in 0..nb {
            let col = &rhs[b * nf..(b + 1) * nf];
            for (a, row) in rows_free.iter().enumerate() {
                d[(a, start + b)] = row.iter().map(|&(e, c)| c * col[e]).sum();
            }
        }
    }
    tracing::info!(live = nl, rho, "interface condensation: K_rho factored, Delassus operator formed");
    Ok((assembler, solver, values, Condensed { live, live_of, rows_free, d, rho }))
}
