//! Interface condensation for contact between elastic bodies (and yielding ones: each
//! Newton iteration on their consistent tangent, see [`Condensed::refactor`]).
//!
//! The saddle-point system of one semi-smooth Newton iteration is
//! `K du + C^T dlambda = r_u`, plus one law row per multiplier (gap rows `C_a du = -w_a` for
//! ties, active normals and sticking nodes; multiplier rows `dlambda_a = ...` for open nodes and
//! `dlambda_t + mu s dlambda_n = ...` for slipping ones). `K` alone is singular when a body is held
//! only by contact (a loaded cylinder), so it is regularised exactly: with
//! `K_rho = K + rho C^T C` over some of the live rows `C` (ties and rigid sets, and grounding
//! rows with multiplier 0 on bodies that only contact holds, see [`ground_rows`]; never a
//! contact row, so the pattern of `K_rho` does not move with the surfaces) and `dw = C du`,
//!
//! `K_rho du = r_u - C^T dlambda + rho C^T dw`  =>  `du = z + Y (rho dw - dlambda)`,
//! `z = K_rho^{-1} r_u`, `Y = K_rho^{-1} C^T`, and `dw = C z + D (rho dw - dlambda)` with the
//! Delassus operator `D = C K_rho^{-1} C^T` (L x L, L = live multipliers).
//!
//! `K_rho` is factored once (Cholesky) and `D` computed once per set-up (the next set-up of a
//! run keeps the pattern and symbolic factorisation, see [`SolverReuse`]); every load step costs
//! two solves with the factor and two internal-force evaluations, and every active-set
//! iteration one dense L x L solve in (`dlambda` of gap rows, `dw` of multiplier rows). The
//! iterates are those of the monolithic Newton (the same linear systems, rearranged), so both
//! agree to round-off (tested). Live rows: ties, paired contact normals, friction rows.

use crate::assembly::{Assembler, AssemblyInput, AssemblyOutput, DofMap, SparsityPattern, CONSTRAINED};
use crate::contact::{row_laws, FrictionStatus, RowLaw};
use crate::fem::material::{PlasticState, Stress4};
use crate::model::{Discretisation, Model};
use crate::solver::dense::DenseLu;
use crate::solver::linear::{Factor, LinearSolverError, LinearSolverKind, SparseSolver};
use crate::wear::GapSensitivity;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Columns solved at a time when forming `D` (bounds the dense right-hand-side block).
const RHS_BLOCK: usize = 32;

pub(super) struct Condensed {
    /// Rows in the condensed set: indices in the model's multiplier order (ties, and the
    /// contact rows that may touch; grows when a row outside it would penetrate, never
    /// shrinks), and from `grounds` on the artificial grounding rows (see [`ground_rows`]).
    pub live: Vec<usize>,
    /// Position of each model multiplier in the set.
    pub live_of: Vec<Option<usize>>,
    /// Set rows over free equations `(eq, coef)`.
    pub rows_free: Vec<Vec<(usize, f64)>>,
    /// Regularisation weight of each set row (`rho` on the rows whose `rho C^T C` is in the
    /// factored matrix: ties and grounding rows; 0 on contact rows).
    pub rho: Vec<f64>,
    /// Delassus operator of `K_rho` on the set.
    pub d: DMatrix<f64>,
    /// The leading rows of the set that depend on the bulk alone (grounding rows and ties): the
    /// solver keeps their share of the operator from one pairing to the next.
    pub fixed: usize,
    /// Rows added after setup, batch by batch (a checkpoint stores it; replaying it on a restart
    /// rebuilds the identical `d`).
    pub log: Vec<Vec<usize>>,
    /// Number of model multipliers: set entries `i >= grounds` are grounding rows.
    pub grounds: usize,
    /// Equations of `K_rho`: every DOF that is not prescribed. Switched-off DOFs (the model's
    /// `held`, constrained in its DOF map) stay equations here, decoupled with a diagonal `E`
    /// and a zero right-hand side (so they keep their value exactly): a surface passing a row
    /// of nodes then leaves the pattern as it is.
    pub equations: DofMap,
    /// Finite sliding: the compliance of every equation a row of the model can touch, from
    /// which the operator of any pairing is a small dense product (see [`Compliance`]).
    pub compliance: Option<Compliance>,
    /// The factor and `d` hold a consistent tangent of yielding bodies instead of the elastic
    /// `K_rho` (see [`Condensed::refactor`]); the next set-up then assembles its own.
    pub tangent: bool,
    /// The grounding rows and the regularisation weights (with `equations`: what a re-pairing on
    /// the same bulk keeps, see [`BulkRows`]).
    pub ground_rows: Vec<Vec<(usize, f64)>>,
    pub rho_tie: f64,
    pub rho_ground: f64,
    /// While a tangent is factored: the elastic `K_rho`'s factor, put back instead of
    /// refactoring it (the same numbers: a factorisation of the same values); and the storage
    /// of the last tangent factor, for the next.
    pub elastic_factor: Option<Factor>,
    spare_factor: Option<Factor>,
}

/// The surface compliance `F = S K_rho^{-1} S^T` over a fixed, sorted set of equations `S`: every
/// equation a contact row of the model can touch at any pairing (both sides of every pair:
/// mortar vertices or their host nodes, the other side's edge nodes or its cut cells' nodes),
/// and those of the tie and grounding rows. Formed once per surface position (the bulk),
/// the Delassus operator of a re-pairing is then `D = C_S F C_S^T`, a product over the rows'
/// few coefficients, instead of a substitution through the factor per row. The set depends on
/// the geometry alone, so a restart forms the same `F`, bit for bit.
pub(super) struct Compliance {
    eqs: Vec<usize>,
    /// Position of each equation of `K_rho` in `eqs`.
    pos: Vec<Option<u32>>,
    f: DMatrix<f64>,
}

/// Largest compliance set formed (a dense `n x n` block; beyond it the operator is formed by
/// substitution per row).
const MAX_COMPLIANCE: usize = 4000;

impl Compliance {
    /// The equations of the compliance set of `m` (see [`Compliance`]).
    fn equations_of(m: &Model, disc: &Discretisation, equations: &DofMap, grounds: &[Vec<(usize, f64)>]) -> Vec<usize> {
        let mut nodes: Vec<usize> = Vec::new();
        for c in &disc.contact.pairs {
            for &n in &c.side.nodes {
                match &c.virtual_mortar {
                    Some(vm) if n >= vm.base => nodes.extend(vm.interpolation[n - vm.base].iter().map(|&(g, _)| g)),
                    _ => nodes.push(n),
                }
            }
            match &c.other {
                crate::contact::PairedSide::Edges(edges) => nodes.extend(edges.iter().flatten()),
                crate::contact::PairedSide::Embedded { host, embedding } => {
                    let body = &m.bodies[*host];
                    for piece in &embedding.pieces {
                        nodes.extend(body.mesh.cells[piece.cell].nodes().iter().map(|&a| a + body.node_offset));
                    }
                }
            }
        }
        let mut dofs: Vec<usize> = nodes.iter().flat_map(|&n| [2 * n, 2 * n + 1]).collect();
        for row in m.constraints.iter().chain(grounds) {
            dofs.extend(row.iter().map(|&(d, _)| d));
        }
        let mut eqs: Vec<usize> =
            dofs.into_iter().filter(|&d| disc.dofs.eq[d] != CONSTRAINED).map(|d| equations.eq[d]).collect();
        eqs.sort_unstable();
        eqs.dedup();
        eqs
    }

    /// Forms `F` over `eqs` with the factor of `K_rho`.
    fn new(solver: &SparseSolver, eqs: Vec<usize>, num_equations: usize) -> Result<Self, LinearSolverError> {
        let rows: Vec<Vec<(usize, f64)>> = eqs.iter().map(|&e| vec![(e, 1.0)]).collect();
        let f = operator_columns(solver, &rows, 0, 0, num_equations)?;
        let mut pos = vec![None; num_equations];
        for (i, &e) in eqs.iter().enumerate() {
            pos[e] = Some(i as u32);
        }
        Ok(Compliance { eqs, pos, f })
    }

    /// Columns `old..` of `C F C^T` for the rows `rows` (all set rows), or `None` if a row
    /// touches an equation outside the set.
    fn columns(&self, rows: &[Vec<(usize, f64)>], old: usize) -> Option<DMatrix<f64>> {
        let local: Vec<Vec<(usize, f64)>> = rows
            .iter()
            .map(|r| r.iter().map(|&(e, c)| self.pos.get(e).copied().flatten().map(|i| (i as usize, c))).collect())
            .collect::<Option<_>>()?;
        let (nl, ns) = (rows.len(), self.eqs.len());
        let mut out = DMatrix::zeros(nl, nl - old);
        let mut fr = vec![0.0; ns];
        for b in old..nl {
            fr.iter_mut().for_each(|v| *v = 0.0);
            for &(j, c) in &local[b] {
                for (v, f) in fr.iter_mut().zip(self.f.column(j).iter()) {
                    *v += c * f;
                }
            }
            for (a, row) in local.iter().enumerate() {
                out[(a, b - old)] = row.iter().map(|&(i, c)| c * fr[i]).sum();
            }
        }
        Some(out)
    }
}

/// Columns `old..` of the operator `B K_rho^{-1} B^T` for the rows `rows` of `B` (over the
/// equations of `K_rho`): an `n x (n - old)` block. Supernodal substitution where the factor
/// allows it (the first `fixed` rows the same while the factor is, see
/// [`SparseSolver::congruence`]), else solves with the factor, `RHS_BLOCK` rows at a time on the
/// rayon threads.
fn operator_columns(
    solver: &SparseSolver,
    rows: &[Vec<(usize, f64)>],
    old: usize,
    fixed: usize,
    nf: usize,
) -> Result<DMatrix<f64>, LinearSolverError> {
    let nl = rows.len();
    if let Some(block) = solver.congruence(rows, old, fixed) {
        return Ok(block);
    }
    let mut out = DMatrix::zeros(nl, nl - old);
    let starts: Vec<usize> = (old..nl).step_by(RHS_BLOCK).collect();
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
                for &(e, c) in &rows[start + b] {
                    rhs[b * nf + e] += c;
                }
            }
            solver.solve_many(&mut rhs, nb)?;
            Ok((0..nb)
                .map(|b| {
                    let col = &rhs[b * nf..(b + 1) * nf];
                    rows.iter().map(|row| row.iter().map(|&(e, c)| c * col[e]).sum()).collect()
                })
                .collect())
        })
        .collect();
    faer::set_global_parallelism(par);
    for (&start, block) in starts.iter().zip(cols) {
        for (b, col) in block?.into_iter().enumerate() {
            for (a, v) in col.into_iter().enumerate() {
                out[(a, start - old + b)] = v;
            }
        }
    }
    Ok(out)
}

/// Whether a model is solved by condensation: contact present (yielding bodies too: their
/// Newton steps run on the consistent tangent, see `StaticAnalysis::tangent_at`).
pub(super) fn applies(disc: &Discretisation) -> bool {
    !disc.contact.rows.is_empty()
}

/// Paired contact rows (normal `k`) whose weighted gap `g / int Phi` is within `margin` times
/// their own `int Phi` (about the local segment length) of the smallest: contact candidates.
pub(super) fn near_rows(disc: &Discretisation, gaps: &[f64], margin: f64, g_min: f64) -> Vec<usize> {
    (0..disc.contact.rows.len())
        .filter(|&k| disc.contact.phi[k] > 0.0 && gaps[k] / disc.contact.phi[k] <= g_min + margin * disc.contact.phi[k])
        .collect()
}

/// Multipliers of normal rows `ks` and of their friction rows (model order).
pub(super) fn with_friction(m: &Model, disc: &Discretisation, ks: &[usize]) -> Vec<usize> {
    let (nt, nc) = (m.constraints.len(), disc.contact.rows.len());
    let mut v: Vec<usize> = ks.iter().map(|&k| nt + k).collect();
    v.extend(disc.contact.friction_normal.iter().enumerate().filter(|(_, k)| ks.contains(k)).map(|(j, _)| nt + nc + j));
    v
}

/// Margin of the candidate sets in units of the local segment length (a set too narrow for
/// the contact grows: by the rows that carry a multiplier at the start of a step, and where a
/// row outside it would penetrate; a wider one costs a denser Delassus operator: 0.5 instead
/// of 0.2 made the McColl run 10-13% slower for the same figures).
pub(super) const CANDIDATE_MARGIN: f64 = 0.2;

/// Grounding rows of the bodies that only contact holds (global DOFs, unit coefficients):
/// `K` is singular on their rigid modes. Nodes are joined into parts by elements, ties and
/// rigid sets; a part whose prescribed DOFs do not fix all three plane rigid modes (their Gram
/// matrix is rank-deficient) gets a statically determinate support: `u_x`, `u_y` at the free
/// node `A` farthest from its centroid and the displacement normal to `AB` at the free node `B`
/// farthest from `A`, both outside any band of moving surfaces (never switched off). In the
/// condensed set these rows carry the law `dlambda = 0`: the springs `rho G^T G` they put in
/// `K_rho` only regularise it, the solution is that of `K` (exact, like `rho C^T C` on ties).
/// Their couplings are node-local, so the pattern of `K_rho` does not depend on which contact
/// rows are near (it did when contact rows were the regularisation).
pub(super) fn ground_rows(m: &Model, disc: &Discretisation) -> Vec<Vec<(usize, f64)>> {
    let nn = m.coords.len();
    let mut in_band = vec![false; nn];
    for (b, body) in m.bodies.iter().enumerate() {
        let Some(band) = &m.bands[b] else { continue };
        for &c in &band.cells {
            for &a in body.mesh.cells[c].nodes() {
                in_band[a + body.node_offset] = true;
            }
        }
    }
    let mut rows = Vec::new();
    for part in m.rigid_parts().into_iter().filter(|p| !p.free_modes.is_empty()) {
        let (nodes, centre) = (&part.nodes, part.centre);
        let free = |a: &usize| disc.dofs.eq[2 * a] != CONSTRAINED && disc.dofs.eq[2 * a + 1] != CONSTRAINED;
        let mut cand: Vec<usize> = nodes.iter().copied().filter(|a| free(a) && !in_band[*a]).collect();
        if cand.len() < 2 {
            cand = nodes.iter().copied().filter(free).collect();
        }
        // Candidate farthest from `from` (the first in node order on ties).
        let farthest = |from: nalgebra::Vector2<f64>| {
            cand.iter().copied().fold(None, |best: Option<(usize, f64)>, a| {
                let dist = (m.coords[a].coords - from).norm();
                match best {
                    Some((_, bd)) if bd >= dist => best,
                    _ => Some((a, dist)),
                }
            })
        };
        // Far apart (a well-conditioned support), and chosen from what a run does not change
        // (a surface update keeps them, and so the pattern of `K_rho`).
        let Some((a, _)) = farthest(centre) else { continue };
        let Some((b, _)) = farthest(m.coords[a].coords) else { continue };
        let dist = (m.coords[b].coords - m.coords[a].coords).norm();
        rows.push(vec![(2 * a, 1.0)]);
        rows.push(vec![(2 * a + 1, 1.0)]);
        if dist > 0.0 {
            let t = (m.coords[b].coords - m.coords[a].coords) / dist;
            rows.push(vec![(2 * b, -t.y), (2 * b + 1, t.x)]);
        }
    }
    rows
}

/// A row over global DOFs as a row over the equations of `K_rho` (without the model's
/// constrained DOFs: prescribed and switched off).
fn free_row(disc: &Discretisation, equations: &DofMap, row: &[(usize, f64)]) -> Vec<(usize, f64)> {
    row.iter().filter(|&&(d, _)| disc.dofs.eq[d] != CONSTRAINED).map(|&(d, c)| (equations.eq[d], c)).collect()
}

/// The equations of `K_rho`: all DOFs but the prescribed ones.
fn solver_equations(m: &Model) -> DofMap {
    let prescribed: Vec<usize> = m.prescribed.iter().map(|p| p.0).collect();
    DofMap::new(m.num_nodes(), &prescribed)
}

/// The solver structure of one condensed set-up, kept for the next set-up of the same run (the
/// wear loop's surface updates, finite sliding's re-pairings, prescribed surface motions): the
/// pattern of `K_rho` is a function of the mesh, the DOF map and the structural couplings
/// (ghost-penalty reach, ties, grounding rows), none of which depend on where the moving
/// surfaces are; when they are the same the pattern, its scatter tables and the symbolic
/// factorisation are reused and `K_rho` is refactored numerically only. Reuse gives the same
/// arithmetic as building afresh (same pattern, same ordering), so a restarted run, which
/// builds afresh, stays bit for bit on the uninterrupted one.
pub struct SolverReuse {
    key: ReuseKey,
    assembler: Assembler,
    solver: SparseSolver,
    /// The factored values of `K_rho`, and whether the caller vouches that the next set-up has
    /// the same bulk (mesh, cuts, rules, ghost penalty, supports: only contact rows re-paired):
    /// then the numeric factorisation is kept too, and only the interface operator is formed.
    values: Vec<f64>,
    same_bulk: bool,
    /// The surface compliance on that bulk (finite sliding).
    compliance: Option<Compliance>,
    /// What the set-up derived from the bulk alone (a re-pairing on it skips that work).
    pub(super) bulk: Option<BulkRows>,
    /// The analysis's trial buffers (history, stresses, internal force), refilled by the next
    /// analysis instead of allocated: a finite-sliding run sets up an analysis per pairing.
    pub(super) buffers: Option<TrialBuffers>,
    /// The trial stresses of `buffers` at points without material equal the state's.
    pub(super) void_stresses_synced: bool,
    /// The next set-up's interface rows with their operator, formed on this bulk beforehand
    /// (see [`crate::solve::StaticAnalysis::prepare_rows`]); used on the same bulk only.
    prepared: Option<Condensed>,
}

/// A next pairing's interface rows and operator, formed on a bulk already factored while the
/// analysis of the last pairing is still at work (see [`SolverReuse::with_prepared`]).
pub struct PreparedRows(pub(super) Condensed);

/// The rows and equations of a condensed set-up that depend on the bulk alone: the grounding
/// rows, the regularisation weights of ties and grounding rows, the equations of `K_rho`.
pub(super) struct BulkRows {
    pub grounds: Vec<Vec<(usize, f64)>>,
    pub rho_tie: f64,
    pub rho_ground: f64,
    pub equations: DofMap,
}

/// Trial buffers of an analysis (see [`SolverReuse`]).
pub(super) type TrialBuffers = (Vec<PlasticState>, Vec<Stress4>, Vec<f64>);

/// What the pattern of `K_rho` is built from.
#[derive(PartialEq)]
pub(super) struct ReuseKey {
    eq: Vec<usize>,
    elements: usize,
    pairs: Vec<(usize, usize)>,
}

impl SolverReuse {
    pub(super) fn new(
        key: ReuseKey,
        assembler: Assembler,
        solver: SparseSolver,
        values: Vec<f64>,
        compliance: Option<Compliance>,
    ) -> Self {
        SolverReuse {
            key,
            assembler,
            solver,
            values,
            same_bulk: false,
            compliance,
            bulk: None,
            buffers: None,
            void_stresses_synced: false,
            prepared: None,
        }
    }

    /// The next set-up's interface rows, formed beforehand on this bulk by
    /// [`crate::solve::StaticAnalysis::prepare_rows`] for exactly that model (its pairing):
    /// the set-up takes them instead of forming them (the same arithmetic: the same bits).
    pub fn with_prepared(mut self, rows: PreparedRows) -> Self {
        self.prepared = Some(rows.0);
        self
    }

    /// Whether the next analysis may take the trial stresses at points without material as
    /// they are: the same bulk (so the same points without material) and synced buffers.
    pub(super) fn keeps_void_stresses(&self) -> bool {
        self.same_bulk && self.void_stresses_synced && self.buffers.is_some()
    }

    /// For a next set-up that differs from this one only in its contact rows (a re-pairing of
    /// finite sliding within one surface position): `K_rho` is the same matrix, so its numeric
    /// factorisation is kept. Assembling and factoring it afresh gives the same bits (the
    /// assembly is deterministic), so a restart, which builds afresh, stays bit for bit.
    pub fn with_same_bulk(mut self) -> Self {
        self.same_bulk = true;
        self
    }

    /// The structure alone: the next set-up assembles and factors its own values.
    pub(super) fn without_values(mut self) -> Self {
        self.values = vec![];
        self
    }
}

/// The sorted union of `sorted` (sorted, no repeats: the ghost-penalty reach) and `extra`
/// (the regularisation's few entries), without repeats.
fn merged_pairs(sorted: &[(usize, usize)], mut extra: Vec<(usize, usize)>) -> Vec<(usize, usize)> {
    extra.sort_unstable();
    extra.dedup();
    let mut out = Vec::with_capacity(sorted.len() + extra.len());
    let (mut i, mut j) = (0, 0);
    while i < sorted.len() || j < extra.len() {
        let next = match (sorted.get(i), extra.get(j)) {
            (Some(a), Some(b)) if a < b => {
                i += 1;
                *a
            }
            (Some(a), Some(b)) if a > b => {
                j += 1;
                *b
            }
            (Some(a), Some(_)) => {
                i += 1;
                j += 1;
                *a
            }
            (Some(a), None) => {
                i += 1;
                *a
            }
            (None, Some(b)) => {
                j += 1;
                *b
            }
            (None, None) => break,
        };
        out.push(next);
    }
    out
}

/// Pattern, assembler and Cholesky factor of `K_rho`, and the condensed operator on the initial
/// set: ties, grounding rows and the contact rows near the smallest initial gap (see
/// [`near_rows`]). `reuse`: the structure of the previous set-up of the run, if any.
#[allow(clippy::type_complexity)]
pub(super) fn setup(
    m: &Model,
    disc: &Discretisation,
    parallel: bool,
    reuse: Option<SolverReuse>,
    surface_compliance: bool,
) -> Result<(Assembler, SparseSolver, Vec<f64>, Condensed, ReuseKey, bool), LinearSolverError> {
    let nt = m.constraints.len();
    let all: Vec<&Vec<(usize, f64)>> = disc.multiplier_rows(m).collect();
    let e_max = m.materials.iter().map(|mat| mat.elastic().young).fold(0.0, f64::max);
    let t0 = std::time::Instant::now();
    let mut prepared = None;
    let (bulk, key, (assembler, solver, kept, reused)) = match reuse {
        // A re-pairing on the same bulk: the grounding rows, the regularisation, the equations
        // and the structure key are functions of the bulk alone, kept with it.
        Some(SolverReuse {
            key,
            assembler,
            solver,
            values,
            same_bulk: true,
            compliance,
            bulk: Some(bulk),
            prepared: rows,
            ..
        }) => {
            prepared = rows;
            (bulk, key, (assembler, solver, Some((values, compliance)), true))
        }
        reuse => {
            let grounds = ground_rows(m, disc);
            let (regularisation, rho_tie, rho_ground) = regularisation(&all[..nt], &grounds, e_max);
            let pairs = merged_pairs(m.ghost_reach(), regularisation.iter().map(|&(i, j, _)| (i, j)).collect());
            let equations = solver_equations(m);
            let key = ReuseKey { eq: equations.eq.clone(), elements: m.elements.len(), pairs };
            let mut penalty = disc.penalty.to_vec();
            penalty.extend_from_slice(&regularisation);
            let structure = bulk_structure(m, reuse, &key, &equations, &penalty)?;
            (BulkRows { grounds, rho_tie, rho_ground, equations }, key, structure)
        }
    };
    let BulkRows { grounds, rho_tie, rho_ground, equations } = bulk;
    let (mut assembler, mut solver) = (assembler, solver);
    assembler.share_rules(&disc.rules);
    let (kept_values, mut kept_compliance) = kept.map_or((None, None), |(v, c)| (Some(v), c));
    let ts = t0.elapsed().as_secs_f64();
    let (values, t1, t2, bulk_kept) = match kept_values {
        Some(values) if values.len() == assembler.pattern.nnz() => (values, ts, ts, true),
        _ => {
            kept_compliance = None;
            let mut values = bulk_stiffness(m, disc, &mut assembler, parallel);
            decouple_held(disc, &assembler.pattern, &equations, e_max, &mut values);
            solver.factor(&values)?;
            let (t1, t2) = (ts, t0.elapsed().as_secs_f64());
            (values, t1, t2, false)
        }
    };
    // Many re-pairings on the same bulk (finite sliding, surfaces at rest): the operator of
    // each pairing from the compliance of the surfaces (formed on the first, kept while the
    // bulk is). It costs about twenty substitutions of the operator, so a wear cycle of a few
    // increments does without.
    // (Not with yielding bodies: their operator is re-formed on each tangent.)
    let compliance = if surface_compliance && m.has_finite_sliding() && !m.has_plasticity() {
        let eqs = Compliance::equations_of(m, disc, &equations, &grounds);
        match kept_compliance {
            Some(c) if c.eqs == eqs => Some(c),
            _ if eqs.len() <= MAX_COMPLIANCE => Some(Compliance::new(&solver, eqs, equations.num_free)?),
            _ => None,
        }
    } else {
        None
    };
    let t3 = t0.elapsed().as_secs_f64();
    let n_grounds = grounds.len();
    let bulk = BulkRows { grounds, rho_tie, rho_ground, equations };
    // Rows formed beforehand on this very factor (the bulk kept, no surface compliance).
    let cd = match prepared {
        Some(cd) if bulk_kept && compliance.is_none() => cd,
        _ => interface_rows(m, disc, bulk, compliance, &solver)?,
    };
    tracing::info!(
        set = cd.live.len(),
        grounds = n_grounds,
        points = m.elements.num_points(),
        elements = m.elements.len(),
        rho_tie,
        reused,
        pattern_symbolic_s = ts,
        bulk_kept,
        assembly_and_factor_s = t2 - t1,
        compliance_s = t3 - t2,
        delassus_s = t0.elapsed().as_secs_f64() - t3,
        "interface condensation: K_rho factored, Delassus operator formed"
    );
    Ok((assembler, solver, values, cd, key, reused))
}

/// The interface rows of `disc` on a bulk already factored (`solver`, with its grounding rows,
/// regularisation and equations `bulk`): the grounding rows, the ties and the contact rows near
/// contact (with their friction rows), and their operator.
pub(super) fn interface_rows(
    m: &Model,
    disc: &Discretisation,
    bulk: BulkRows,
    compliance: Option<Compliance>,
    solver: &SparseSolver,
) -> Result<Condensed, LinearSolverError> {
    let nt = m.constraints.len();
    let n_rows = disc.multiplier_rows(m).count();
    let g0 = &disc.contact.g0;
    let g_min = (0..g0.len())
        .filter(|&k| disc.contact.phi[k] > 0.0)
        .map(|k| g0[k] / disc.contact.phi[k])
        .fold(f64::INFINITY, f64::min);
    let BulkRows { grounds, rho_tie, rho_ground, equations } = bulk;
    let mut cd = Condensed {
        live: vec![],
        live_of: vec![None; n_rows],
        rows_free: vec![],
        rho: vec![],
        d: DMatrix::zeros(0, 0),
        fixed: 0,
        log: vec![],
        grounds: n_rows,
        equations,
        compliance,
        tangent: false,
        ground_rows: vec![],
        rho_tie,
        rho_ground,
        elastic_factor: None,
        spare_factor: None,
    };
    for (g, row) in grounds.iter().enumerate() {
        cd.live.push(n_rows + g);
        cd.rows_free.push(free_row(disc, &cd.equations, row));
        cd.rho.push(rho_ground);
    }
    let ties: Vec<usize> = (0..nt).collect();
    cd.push(m, disc, &ties, rho_tie);
    cd.fixed = cd.live.len();
    cd.push(m, disc, &with_friction(m, disc, &near_rows(disc, g0, CANDIDATE_MARGIN, g_min)), 0.0);
    cd.extend_operator(solver, 0)?;
    cd.ground_rows = grounds;
    Ok(cd)
}

/// The pattern, assembler and symbolic factorisation of `K_rho`: those handed in `reuse` when
/// the structure key matches (with the numeric values and surface compliance when the bulk is
/// the same), otherwise built afresh; rebuilt when a penalty entry falls outside the
/// structural couplings. Returns them with the kept values and compliance, and whether the
/// structure was reused.
#[allow(clippy::type_complexity)]
fn bulk_structure(
    m: &Model,
    reuse: Option<SolverReuse>,
    key: &ReuseKey,
    equations: &DofMap,
    penalty: &[(usize, usize, f64)],
) -> Result<(Assembler, SparseSolver, Option<(Vec<f64>, Option<Compliance>)>, bool), LinearSolverError> {
    let build = |pairs: &[(usize, usize)]| {
        let structure: Vec<(usize, usize, f64)> = pairs.iter().map(|&(i, j)| (i, j, 0.0)).collect();
        SparsityPattern::with_constraints(
            m.num_nodes(),
            &m.elements,
            equations,
            crate::assembly::SaddleRows { penalty: &structure, ..Default::default() },
        )
    };
    let mut reused = false;
    let mut kept = None;
    let (mut assembler, mut solver) = match reuse {
        Some(r) if r.key == *key => {
            reused = true;
            if r.same_bulk {
                kept = Some((r.values, r.compliance));
            }
            (r.assembler, r.solver)
        }
        _ => {
            let pattern = build(&key.pairs);
            let solver = SparseSolver::new(&pattern.symbolic, LinearSolverKind::Cholesky)?;
            (Assembler::new(pattern, &m.elements), solver)
        }
    };
    if !assembler.pattern.set_penalty(equations, penalty) {
        // A ghost entry outside the structural couplings (a band body without its reach):
        // the pattern of this model's own entries, built afresh.
        tracing::debug!("penalty entries outside the structural pattern: pattern rebuilt");
        let mut own: Vec<(usize, usize)> = key.pairs.clone();
        own.extend(penalty.iter().map(|&(i, j, _)| (i, j)));
        own.sort_unstable();
        own.dedup();
        let mut pattern = build(&own);
        pattern.set_penalty(equations, penalty);
        solver = SparseSolver::new(&pattern.symbolic, LinearSolverKind::Cholesky)?;
        assembler = Assembler::new(pattern, &m.elements);
        reused = false;
    }
    Ok((assembler, solver, kept, reused))
}

/// The regularisation of `K_rho`: `rho C_r^T C_r` of every tie row (`rho |C|^2` about a tenth
/// of the bulk stiffness E keeps `K_rho` well conditioned) and grounding row (springs of
/// stiffness E per unit thickness: the rigid-mode compliance they add, 1/E, stays of the order
/// of the contact's own, so `I - rho D` keeps its digits). Returns the entries, `rho_tie` and
/// `rho_ground`.
fn regularisation(
    ties: &[&Vec<(usize, f64)>],
    grounds: &[Vec<(usize, f64)>],
    e_max: f64,
) -> (Vec<(usize, usize, f64)>, f64, f64) {
    let n_coef = ties.iter().map(|r| r.len()).sum::<usize>().max(1);
    let mean_coef = ties.iter().flat_map(|r| r.iter()).map(|(_, c)| c.abs()).sum::<f64>() / n_coef as f64;
    let rho_tie = if mean_coef > 0.0 { 0.1 * e_max / (mean_coef * mean_coef) } else { 0.0 };
    let rho_ground = e_max;
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    for (row, rho) in ties.iter().map(|r| (*r, rho_tie)).chain(grounds.iter().map(|r| (r, rho_ground))) {
        for &(d1, c1) in row {
            for &(d2, c2) in row {
                entries.push((d1, d2, rho * c1 * c2));
            }
        }
    }
    (entries, rho_tie, rho_ground)
}

/// Assembles `K_rho` (the bulk stiffness, its ghost penalty and regularisation) into the
/// assembler's pattern, at zero displacement; the caller decouples the switched-off DOFs
/// ([`decouple_held`]) and factors it.
fn bulk_stiffness(m: &Model, disc: &Discretisation, assembler: &mut Assembler, parallel: bool) -> Vec<f64> {
    let mut values = vec![0.0; assembler.pattern.nnz()];
    let u = vec![0.0; disc.dofs.num_dofs];
    let history = vec![PlasticState::default(); m.elements.num_states()];
    let mut history_new = history.clone();
    let mut stress = vec![Stress4::zeros(); m.elements.num_points()];
    let mut f_int = vec![0.0; disc.dofs.num_dofs];
    // Only the matrix is wanted (at zero displacement): elastic elements whose stiffness is
    // kept copy it instead of integrating their stresses.
    let from_kept = assembler.elastic_force_from_kept();
    assembler.set_elastic_force_from_kept(true);
    assembler.assemble(
        &AssemblyInput {
            coords: &m.coords,
            elements: &m.elements,
            materials: &m.materials,
            rules: &disc.rules,
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
    assembler.set_elastic_force_from_kept(from_kept);
    values
}

/// Switched-off DOFs exactly decoupled (a support below the material threshold may still
/// carry a sliver of element stiffness): the other equations are those of the model's own DOF
/// map, the held ones keep `du = 0`.
fn decouple_held(disc: &Discretisation, pattern: &SparsityPattern, equations: &DofMap, e_max: f64, values: &mut [f64]) {
    let (col_ptr, row_idx) = (pattern.symbolic.col_ptr(), pattern.symbolic.row_idx());
    for &d in disc.held.iter().flatten() {
        let e = equations.eq[d];
        for p in col_ptr[e]..col_ptr[e + 1] {
            let r = row_idx[p];
            values[p] = if r == e { e_max } else { 0.0 };
            if r != e {
                if let Ok(q) = row_idx[col_ptr[r]..col_ptr[r + 1]].binary_search(&e) {
                    values[col_ptr[r] + q] = 0.0;
                }
            }
        }
    }
}

/// What a live row imposes in one active-set iteration: a gap row (`dw` known, `dlambda`
/// unknown) or a multiplier row (`dlambda` known, or tied to its normal's, `dw` unknown).
pub(super) enum Law {
    Gap(f64),
    Fixed(f64),
    Slip { normal: usize, s: f64, rest: f64 },
}

impl Law {
    /// The row-value and multiplier changes `dw`, `dlam` of the live rows from the solution
    /// `x` of their laws' system (per row: the unknown the law leaves free).
    pub(super) fn unpack(laws: &[Law], x: &DVector<f64>, dlam: &mut [f64], dw: &mut [f64]) {
        for (a, law) in laws.iter().enumerate() {
            (dw[a], dlam[a]) = match *law {
                Law::Gap(b) => (b, x[a]),
                Law::Fixed(l) => (x[a], l),
                Law::Slip { normal, s, rest } => (x[a], s * x[normal] + rest),
            };
        }
    }
}

impl Condensed {
    /// Per live row, its law for the sets `row_law`; `w0` the live rows' values at the start of
    /// the step, `lam0` the multipliers there, `slip0` the friction rows' slips so far.
    pub fn laws(
        &self,
        m: &Model,
        disc: &Discretisation,
        row_law: &[RowLaw],
        w0: &[f64],
        lam0: &[f64],
        slip0: &[f64],
    ) -> Vec<Law> {
        let (nt, nc) = (m.constraints.len(), disc.contact.rows.len());
        self.live
            .iter()
            .enumerate()
            .map(|(a, &i)| match row_law.get(i).copied().unwrap_or(RowLaw::Free) {
                // Grounding rows only regularise: their multiplier stays 0.
                _ if i >= self.grounds => Law::Fixed(0.0),
                // The row's value at the start of the step is known; its target is 0.
                RowLaw::Constraint if i < nt => Law::Gap(-w0[a]),
                RowLaw::Constraint if i < nt + nc => Law::Gap(-(disc.contact.g0[i - nt] + w0[a])),
                RowLaw::Constraint => Law::Gap(-slip0[i - nt - nc]),
                RowLaw::Free => Law::Fixed(-lam0[i]),
                RowLaw::Slip { normal, coef } => Law::Slip {
                    normal: self.live_of[normal].unwrap_or(a),
                    s: coef,
                    rest: -(lam0[i] - coef * lam0[normal]),
                },
            })
            .collect()
    }

    /// Matrix of `(I - rho D) dw + D dlambda = C z` in the unknowns `x_a` (`dlambda_a` of gap
    /// rows, `dw_a` of the others).
    pub fn law_matrix(&self, laws: &[Law]) -> DMatrix<f64> {
        let nl = self.live.len();
        let mut a_mat = DMatrix::<f64>::zeros(nl, nl);
        for (a, law) in laws.iter().enumerate() {
            let dcol = self.d.column(a);
            let unit = |e: usize| if e == a { 1.0 } else { 0.0 };
            match *law {
                Law::Gap(_) => {
                    for e in 0..nl {
                        a_mat[(e, a)] += dcol[e];
                    }
                }
                Law::Fixed(_) => {
                    for e in 0..nl {
                        a_mat[(e, a)] += unit(e) - self.rho[a] * dcol[e];
                    }
                }
                Law::Slip { normal, s, .. } => {
                    for e in 0..nl {
                        a_mat[(e, a)] += unit(e) - self.rho[a] * dcol[e];
                        a_mat[(e, normal)] += dcol[e] * s;
                    }
                }
            }
        }
        a_mat
    }

    /// Right-hand side of [`Self::law_matrix`]'s system: `C z` minus the known terms.
    pub fn law_rhs(&self, laws: &[Law], cz: &[f64]) -> DVector<f64> {
        let nl = self.live.len();
        let mut rhs = DVector::<f64>::from_column_slice(cz);
        for (a, law) in laws.iter().enumerate() {
            let dcol = self.d.column(a);
            match *law {
                Law::Gap(b) => {
                    for e in 0..nl {
                        let ima = if e == a { 1.0 } else { 0.0 } - self.rho[a] * dcol[e];
                        rhs[e] -= ima * b;
                    }
                }
                Law::Fixed(l) => {
                    for e in 0..nl {
                        rhs[e] -= dcol[e] * l;
                    }
                }
                Law::Slip { rest, .. } => {
                    for e in 0..nl {
                        rhs[e] -= dcol[e] * rest;
                    }
                }
            }
        }
        rhs
    }

    /// The interface stiffness of a converged state with sets `active` / `status` (see
    /// [`GapSensitivity`]): the step's interface system solved for every held normal row at
    /// once (one factor, a column per row), the gap row's `dw_a = -dg_a` moved to the
    /// right-hand side. Held rows: the active ones, and with `open_rows` also every inactive
    /// candidate row of the interface set that is paired (`int Phi > 0`), held at its gap.
    pub fn gap_sensitivity(
        &self,
        m: &Model,
        disc: &Discretisation,
        active: &[bool],
        status: &[FrictionStatus],
        open_rows: bool,
    ) -> Option<GapSensitivity> {
        let nt = m.constraints.len();
        let (lu, cols) = self.held_system(m, disc, active, status, open_rows)?;
        let x = lu.solve_columns(&self.gap_columns(&cols, &vec![1.0; cols.len()], true))?;
        let out = DMatrix::from_fn(cols.len(), cols.len(), |r, c| x[(cols[r], c)]);
        let rows: Vec<usize> = cols.iter().map(|&a| self.live[a] - nt).collect();
        let closed = rows.iter().map(|&k| active[k]).collect();
        Some(GapSensitivity { rows, closed, dlambda_dgap: out })
    }

    /// The multiplier change of the rows in contact (`active`, held at their gap) for gap
    /// changes `dg(k)` of those rows: [`Self::gap_sensitivity`] times `dg` in one solve.
    /// Returns the rows (model contact rows) and their `dlambda`.
    pub fn gap_response(
        &self,
        m: &Model,
        disc: &Discretisation,
        active: &[bool],
        status: &[FrictionStatus],
        dg: &dyn Fn(usize) -> f64,
    ) -> Option<(Vec<usize>, Vec<f64>)> {
        let nt = m.constraints.len();
        let (lu, cols) = self.held_system(m, disc, active, status, false)?;
        let rows: Vec<usize> = cols.iter().map(|&a| self.live[a] - nt).collect();
        let weights: Vec<f64> = rows.iter().map(|&k| dg(k)).collect();
        let x = lu.solve_columns(&self.gap_columns(&cols, &weights, false))?;
        Some((rows, cols.iter().map(|&a| x[(a, 0)]).collect()))
    }

    /// The factored interface law of a converged state with the rows `held` (the active ones,
    /// and with `open_rows` every paired candidate row of the set) at their gap, slipping
    /// rows free of shear, and the live positions of the held normal rows.
    fn held_system(
        &self,
        m: &Model,
        disc: &Discretisation,
        active: &[bool],
        status: &[FrictionStatus],
        open_rows: bool,
    ) -> Option<(DenseLu, Vec<usize>)> {
        let nt = m.constraints.len();
        let nl = self.live.len();
        let mut held = active.to_vec();
        if open_rows {
            for &i in &self.live {
                if i >= nt && i < nt + held.len() && disc.contact.phi[i - nt] > 0.0 {
                    held[i - nt] = true;
                }
            }
        }
        let row_law = row_laws(&disc.contact, &held, status);
        let zeros = vec![0.0; row_law.len().max(nl)];
        // Slipping rows keep their shear (the normal-only interface stiffness: symmetric
        // positive definite, so the implicit jump's operator has no negative mode; the
        // slip coupling is a second-order effect between like materials).
        let row_law: Vec<RowLaw> =
            row_law.into_iter().map(|r| if matches!(r, RowLaw::Slip { .. }) { RowLaw::Free } else { r }).collect();
        let laws = self.laws(m, disc, &row_law, &zeros[..nl], &zeros, &zeros);
        let lu = DenseLu::new(self.law_matrix(&laws))?;
        let cols: Vec<usize> = (0..nl)
            .filter(|&a| {
                let i = self.live[a];
                i >= nt && i < nt + held.len() && held[i - nt] && matches!(laws[a], Law::Gap(_))
            })
            .collect();
        Some((lu, cols))
    }

    /// Right-hand sides of held gap rows `cols` (live positions) with weights `w`: the gap
    /// row's `dw_a = -dg_a` moved to the right, `e_a - rho_a D[:, a]`; one column per row
    /// (`separate`) or their weighted sum.
    fn gap_columns(&self, cols: &[usize], w: &[f64], separate: bool) -> DMatrix<f64> {
        let nl = self.live.len();
        let mut rhs = DMatrix::zeros(nl, if separate { cols.len() } else { 1 });
        for (c, (&a, &wa)) in cols.iter().zip(w).enumerate() {
            let mut col = rhs.column_mut(if separate { c } else { 0 });
            col[a] += wa;
            col.axpy(-wa * self.rho[a], &self.d.column(a), 1.0);
        }
        rhs
    }

    /// Adds multipliers `new` (model order, not yet in the set) with regularisation weight
    /// `rho` (non-zero only for rows whose `rho C^T C` is in the factored matrix): one solve
    /// with the factor per new row, `RHS_BLOCK` at a time.
    pub fn grow(
        &mut self,
        m: &Model,
        disc: &Discretisation,
        solver: &SparseSolver,
        new: &[usize],
        rho: f64,
    ) -> Result<(), LinearSolverError> {
        let old = self.live.len();
        self.push(m, disc, new, rho);
        self.extend_operator(solver, old)
    }

    /// Factors `values` (`K_rho` with the bulk's consistent tangent in place of its elastic
    /// stiffness, as assembled by the caller; `tangent`: whether it is one) and forms `d` anew
    /// on the whole set, by substitution. The elastic factor is kept aside while tangents are
    /// factored and put back when `values` is the elastic `K_rho` again (no refactorisation).
    pub fn refactor(
        &mut self,
        m: &Model,
        disc: &Discretisation,
        pattern: &SparsityPattern,
        solver: &mut SparseSolver,
        values: &mut [f64],
        tangent: bool,
    ) -> Result<(), LinearSolverError> {
        let e_max = m.materials.iter().map(|mat| mat.elastic().young).fold(0.0, f64::max);
        decouple_held(disc, pattern, &self.equations, e_max, values);
        match (tangent, self.tangent, self.elastic_factor.take()) {
            // Elastic -> tangent: the elastic factor is kept aside.
            (true, false, _) => {
                self.elastic_factor = Some(solver.take_factor());
                if let Some(spare) = self.spare_factor.take() {
                    solver.put_factor(spare);
                }
                if let Err(e) = solver.factor(values) {
                    // The elastic factor goes back: the solver stays usable for a cut-back.
                    if let Some(elastic) = self.elastic_factor.take() {
                        solver.put_factor(elastic);
                    }
                    return Err(e);
                }
            }
            // Tangent -> elastic: the kept factor is put back.
            (false, true, Some(elastic)) => {
                self.spare_factor = Some(solver.take_factor());
                solver.put_factor(elastic);
            }
            (_, _, kept) => {
                self.elastic_factor = kept;
                solver.factor(values)?;
            }
        }
        self.compliance = None;
        self.d = DMatrix::zeros(0, 0);
        self.tangent = tangent;
        self.extend_operator(solver, 0)
    }

    /// Appends model multipliers `new` to the set (the operator not yet extended).
    fn push(&mut self, m: &Model, disc: &Discretisation, new: &[usize], rho: f64) {
        let all: Vec<&Vec<(usize, f64)>> = disc.multiplier_rows(m).collect();
        for &i in new {
            debug_assert!(self.live_of[i].is_none());
            self.live_of[i] = Some(self.live.len());
            self.live.push(i);
            self.rows_free.push(free_row(disc, &self.equations, all[i]));
            self.rho.push(rho);
        }
    }

    /// Multipliers of the set that are model multipliers: `(position in the set, model index)`.
    pub fn model_rows(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.live.iter().copied().enumerate().filter(move |&(_, i)| i < self.grounds)
    }

    /// Columns `old..` of `D` (and their transposes), for the rows appended since: from the
    /// compliance where it holds every row, else by substitution through the factor.
    fn extend_operator(&mut self, solver: &SparseSolver, old: usize) -> Result<(), LinearSolverError> {
        let nl = self.live.len();
        if nl == old {
            return Ok(());
        }
        let block = match self.compliance.as_ref().and_then(|c| c.columns(&self.rows_free, old)) {
            Some(block) => block,
            None => operator_columns(solver, &self.rows_free, old, self.fixed, self.equations.num_free)?,
        };
        let mut d = DMatrix::zeros(nl, nl);
        d.view_mut((0, 0), (old, old)).copy_from(&self.d);
        for b in 0..nl - old {
            for a in 0..nl {
                d[(a, old + b)] = block[(a, b)];
                if a < old {
                    d[(old + b, a)] = block[(a, b)];
                }
            }
        }
        self.d = d;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::ground_rows;
    use crate::fem::kernel::Formulation;
    use crate::fem::material::{Elastic, Material, PlaneHypothesis};
    use crate::mesh::{generate, CellKind};
    use crate::model::{ContactOther, LoadPath, Model, ModelBuilder};
    use crate::solver::linear::LinearSolverKind;
    use crate::solver::newton::NewtonParams;

    /// Two blocks in contact (the lower one on rollers with a pin, the upper one pressed), with
    /// the upper block's own supports `upper_fix` (set, component).
    type TestResult<T> = Result<T, Box<dyn std::error::Error>>;

    fn blocks(upper_fix: &[(&str, usize)]) -> TestResult<(Model, std::ops::Range<usize>)> {
        let hyp = PlaneHypothesis::PlaneStrain;
        let mut b = ModelBuilder::new(hyp);
        let mi = b.add_material("steel", Material::Elastic(Elastic { young: 210e3, poisson: 0.3, hypothesis: hyp }));
        let lower = generate::rectangle(0.0, 0.0, 4.0, 2.0, 8, 4, 1.0, 1.0, CellKind::Quad4)?;
        let upper = generate::rectangle(0.0, 2.0, 4.0, 1.0, 7, 3, 1.0, 1.0, CellKind::Quad4)?;
        let n_lower = lower.nodes.len();
        let n_upper = upper.nodes.len();
        let lo = b.add_body("lower", lower, mi, Formulation::Standard, 1.0);
        let up = b.add_body("upper", upper, mi, Formulation::Standard, 1.0);
        b.fix(lo, "bottom", 1, 0.0)?;
        b.fix(lo, "bottom_left", 0, 0.0)?;
        for &(set, comp) in upper_fix {
            b.fix(up, set, comp, 0.0)?;
        }
        b.pressure(up, "top", 10.0)?;
        let other = ContactOther::Edges(b.global_edges(lo, &["top".to_string()])?);
        b.add_contact("c", up, &["bottom".to_string()], lo, other, Default::default())?;
        let model = b.build(
            LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)])?,
            vec![1.0],
            NewtonParams::default(),
            LinearSolverKind::Cholesky,
        )?;
        Ok((model, n_lower..n_lower + n_upper))
    }

    /// A body that only contact holds (or that its supports leave a rigid mode) gets three
    /// grounding rows on two of its own free nodes; a body whose supports fix all three rigid
    /// modes (rollers along the bottom plus a pin) gets none.
    #[test]
    fn grounding_rows_on_the_bodies_contact_holds() -> TestResult<()> {
        for fix in [vec![], vec![("top_left", 0)], vec![("top", 0)]] {
            let (model, upper_nodes) = blocks(&fix)?;
            let rows = ground_rows(&model, model.initial());
            assert_eq!(rows.len(), 3, "upper supports {fix:?}");
            let mut nodes: Vec<usize> = rows.iter().flatten().map(|&(d, _)| d / 2).collect();
            nodes.dedup();
            assert_eq!(nodes.len(), 2, "{fix:?}: two support nodes");
            for &(d, _) in rows.iter().flatten() {
                assert!(upper_nodes.contains(&(d / 2)), "{fix:?}: DOF {d} not on the upper block");
                assert!(!model.prescribed.iter().any(|p| p.0 == d), "{fix:?}: DOF {d} is prescribed");
            }
        }
        // Rollers (u_y) along the upper block's top and a pin (u_x) at a corner: supported.
        let (model, _) = blocks(&[("top", 1), ("top_left", 0)])?;
        assert!(ground_rows(&model, model.initial()).is_empty());
        Ok(())
    }
}
