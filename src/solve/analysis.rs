//! Quasi-static analysis with load stepping and Newton-Raphson (the deal.II step-41 shape:
//! `run()` reads like the algorithm).
//!
//! For each output time `t_n`: set the load factor `lambda(t_n)`, impose the prescribed
//! displacements, iterate `K du = lambda f_ext - f_int(u)` on the free DOFs until the residual
//! converges, then commit `u` and the point history. A step that fails is retried from the last
//! converged state with half the increment (cut-back). When every material is linear the
//! stiffness is assembled and factored once for the whole run, and each step is one solve plus
//! one residual check.

use crate::assembly::{Assembler, AssemblyInput, AssemblyOutput, SparsityPattern, CONSTRAINED};
use crate::fem::material::{Material, PlasticState, Stress4};
use crate::model::{Discretisation, Model};
use crate::solver::dense::DenseLu;
use crate::solver::linear::{LinearSolverError, SparseSolver};
use crate::solver::newton::NewtonError;
use crate::state::SimState;
use nalgebra::DMatrix;
use std::sync::Arc;

pub use crate::contact::FrictionStatus;
use crate::contact::{
    activate_closest, friction_couplings, given_sets, gross_sliding, row_laws, slide_from_pairing, update_sets,
    zero_open_multipliers, ContactSet, ContactSets, RowLaw, SetValues,
};

mod active_set;
mod condensed;
mod newton;
pub use crate::wear::GapSensitivity;
pub use condensed::{PreparedRows, SolverReuse};

/// How one Newton solve of a load increment ended (the caller cuts back when not converged).
#[derive(Debug, Clone, Copy, PartialEq)]
enum StepOutcome {
    /// Converged, the state committed; `bulk`: the Newton iterations of the bulk (solves with a
    /// bulk operator), of which `iterations` counts the contact active-set iterations too.
    Converged { iterations: usize, bulk: usize, residual: f64 },
    /// Diverged, ran out of iterations or lost the tangent; the state untouched.
    NotConverged { iterations: usize, residual: f64 },
}

/// One monolithic Newton system ([`StaticAnalysis::newton_system`]).
#[derive(Debug, Clone)]
pub struct NewtonSystem {
    /// Right-hand side: the free equations' force residual, then one entry per multiplier.
    pub rhs: Vec<f64>,
    /// The matrix Newton factors (bulk tangent, contact rows by their laws), dense.
    pub matrix: DMatrix<f64>,
    /// Scale of the multiplier unknowns (`mu = alpha x_mu`).
    pub alpha: f64,
    pub num_free: usize,
    /// The contact sets the laws were chosen from (frozen by a later call).
    sets: SetIterate,
}

impl NewtonSystem {
    /// Counts of (active normal rows, sticking rows, slipping rows).
    pub fn contact_sets(&self) -> (usize, usize, usize) {
        let active = self.sets.active.iter().filter(|&&a| a).count();
        let stick = self.sets.status.iter().filter(|&&s| s == FrictionStatus::Stick).count();
        let slip = self.sets.status.iter().filter(|s| matches!(s, FrictionStatus::Slip(_))).count();
        (active, stick, slip)
    }
}

/// The contact sets of a Newton iteration (semi-smooth Newton on the Alart-Curnier conditions):
/// normal row `k` is active when `lambda_k + eps_n g_k / int Phi_k <= 0`, each friction row has
/// its Coulomb status; with the weighted gaps and slips they were decided from. Slip is the
/// increment of the weighted tangential relative displacement since the last converged state
/// (objective under cyclic loading).
#[derive(Debug, Clone)]
struct SetIterate {
    active: Vec<bool>,
    status: Vec<FrictionStatus>,
    prev_active: Option<Vec<bool>>,
    prev_status: Vec<FrictionStatus>,
    gaps: Vec<f64>,
    slip: Vec<f64>,
}

impl SetIterate {
    fn new(normal_rows: usize, friction_rows: usize) -> Self {
        SetIterate {
            active: vec![false; normal_rows],
            status: vec![FrictionStatus::Open; friction_rows],
            prev_active: None,
            prev_status: Vec::new(),
            gaps: vec![0.0; normal_rows],
            slip: vec![0.0; friction_rows],
        }
    }

    /// Gaps and slips at `u` (slips from `u_start`), then the sets; whether they changed since
    /// the previous iteration (the first iteration counts as a change when there is contact).
    fn update(&mut self, c: &ContactSet, u: &[f64], u_start: &[f64], mu: &[f64], first: bool) -> bool {
        self.measure(c, u, u_start);
        let values = SetValues { mult: mu, gaps: &self.gaps, slip: &self.slip, augmentation: 1.0 };
        update_sets(c, values, first, None, &mut self.active, &mut self.status);
        let changed = self.prev_active.as_ref().map(|pa| pa != &self.active).unwrap_or(!self.active.is_empty())
            || self.prev_status != self.status;
        self.prev_status.clone_from(&self.status);
        self.prev_active = Some(self.active.clone());
        changed
    }

    /// Gaps and slips at `u` (slips from `u_start`), the sets unchanged.
    fn measure(&mut self, c: &ContactSet, u: &[f64], u_start: &[f64]) {
        for (k, gap) in self.gaps.iter_mut().enumerate() {
            *gap = c.g0[k] + c.rows[k].iter().map(|&(d, v)| v * u[d]).sum::<f64>();
        }
        for (j, slip) in self.slip.iter_mut().enumerate() {
            *slip = c.friction_rows[j].iter().map(|&(d, v)| v * (u[d] - u_start[d])).sum();
        }
    }

    fn log(&self, step: usize, it: usize, changed: bool) {
        if !self.active.is_empty() {
            tracing::debug!(
                step,
                it,
                active = self.active.iter().filter(|&&a| a).count(),
                stick = self.status.iter().filter(|&&s| s == FrictionStatus::Stick).count(),
                changed,
                "contact active set"
            );
        }
    }
}

/// Where a condensed step's interface iterations start: the displacements with the step's
/// prescribed values, the weighted gaps (minus `g0`) and the slips there.
struct InterfaceStart {
    u_start: Vec<f64>,
    w_start: Vec<f64>,
    slip0: Vec<f64>,
}

/// The end of a condensed step's interface iterations: the multiplier and row-value changes of
/// the live rows and the iterations they took, or the step's outcome when they failed.
enum InterfaceSolve {
    Solved { dlam: Vec<f64>, dw: Vec<f64>, iterations: usize },
    Failed(StepOutcome),
}

/// The parts of a Newton residual: the relative residual the tolerance applies to, and the
/// absolute force, gap and free-multiplier norms.
struct ResidualNorms {
    residual: f64,
    forces: f64,
    gaps: f64,
    free_multipliers: f64,
}

impl ResidualNorms {
    /// Exactly nothing left (a step that changes nothing converges at once).
    fn all_zero(&self) -> bool {
        self.forces == 0.0 && self.gaps == 0.0 && self.free_multipliers == 0.0
    }
}

/// What one converged output step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    pub step: usize,
    /// Cycle and increment within it (cycle 0: before the cycles, or a non-cyclic case).
    pub cycle: usize,
    pub increment: usize,
    pub time: f64,
    pub load_factor: f64,
    /// Newton iterations summed over sub-steps (by condensation: the contact active-set
    /// iterations of every bulk solve).
    pub iterations: usize,
    /// Newton iterations of the bulk summed over sub-steps: solves with a bulk operator (the
    /// consistent tangent of yielding bodies; one per step for elastic bodies by condensation).
    pub newton_iterations: usize,
    pub cutbacks: usize,
    /// Pieces the step was solved in by the wear loop (1: whole; more: an increment of a
    /// finite-sliding cycle cut into sub-steps, each re-paired).
    pub sub_steps: usize,
    /// Final relative residual.
    pub residual: f64,
}

/// What an observer of converged steps (output, a post-processor, a test) reports when it
/// fails: any error; the run stops with it as the source of [`AnalysisError::Observer`].
pub type ObserverError = Box<dyn std::error::Error + Send + Sync>;

#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    #[error(transparent)]
    Newton(#[from] NewtonError),
    #[error("setting up the linear solver: {0}")]
    Setup(#[from] LinearSolverError),
    #[error("step {step}: {source}")]
    Observer { step: usize, source: ObserverError },
    #[error("resuming from a checkpoint: interface-log batch {batch} names multiplier rows that are already live or do not exist in this model")]
    ResumeLog { batch: usize },
    #[error(
        "step {step} (time {time}): gross sliding: all {slipping} contact nodes in contact slip in one direction and \
         nothing else restrains the body (the tangential load exceeds mu times the normal load?)"
    )]
    GrossSliding { step: usize, time: f64, slipping: usize },
    #[error(
        "step {step} (time {time}): body '{body}' is held along {axis} by contact alone (nothing of it is \
         prescribed along {axis}) and its load along {axis}, {load:.4e} in all, pulls it away from its contacts: \
         nothing holds it; prescribe its {axis} displacement somewhere, or reverse the load"
    )]
    PulledOffContact { step: usize, time: f64, body: String, axis: char, load: f64 },
    #[error(
        "step {step} (time {time}): contact nodes slid {slide:.3e} from their pairing, more than the contact \
         width {width:.3e}: beyond small sliding (use sliding = \"finite\" on the pair, smaller increments, or \
         check for a tangential load above mu times the normal load)"
    )]
    SlidingBeyondPairing { step: usize, time: f64, slide: f64, width: f64 },
    #[error(
        "step {step} (time {time}): finite sliding: the pairing of the step did not settle in {pairings} \
         re-pairings (last pressure change {change:.2e} of the largest): each pairing moved the pressure the \
         next one read; more [steps] increments or a finer counter-surface may let it settle"
    )]
    PairingNotSettled { step: usize, time: f64, pairings: usize, change: f64 },
    #[error(
        "step {step} (time {time}): contact '{pair}': a node carrying pressure is paired over only {percent:.0}% \
         of its support: the contact reached the end of the counter-surface (the prescribed stroke slides a \
         body off the other); shorten the stroke ([[bcs]]) or extend the surface"
    )]
    OffCounterSurface { step: usize, time: f64, pair: String, percent: f64 },
    #[error(
        "step {step}: the increment was cut into sub-steps and sub-step {pieces} (to time {time}, length \
         {length:.3e}) failed: {source}"
    )]
    IncrementCut { step: usize, time: f64, pieces: usize, length: f64, source: Box<AnalysisError> },
    #[error("step {step} (time {time}): moving the virtual surfaces: {source}")]
    Surface { step: usize, time: f64, source: crate::model::ModelError },
    #[error(transparent)]
    Wear(#[from] crate::wear::WearError),
    #[error("cycle {cycle}: fatigue: {source}")]
    Fatigue { cycle: u64, source: crate::fatigue::FatigueError },
}

impl AnalysisError {
    /// The failure of a solve that a shorter step may avoid: Newton not converging, the
    /// pairing of a finite-sliding step not settling, a contact leaving its counter-surface
    /// (the check sees the pairing of the step's end: a step sliding far reads it where the
    /// other body no longer is).
    pub fn shorter_step_may_help(&self) -> bool {
        matches!(
            self,
            AnalysisError::Newton(_)
                | AnalysisError::PairingNotSettled { .. }
                | AnalysisError::OffCounterSurface { .. }
        )
    }
}

pub struct StaticAnalysis<'m> {
    model: &'m Model,
    /// The discretisation of the moment (surfaces, cuts, contact rows) the analysis solves on.
    disc: Arc<Discretisation>,
    assembler: Assembler,
    solver: SparseSolver,
    values: Vec<f64>,
    /// Scale of the constraint rows in the matrix.
    alpha: f64,
    /// Linear models: has the constant stiffness been factored?
    factored: bool,
    parallel: bool,
    // Trial buffers (committed into SimState only on convergence).
    trial_history: Vec<PlasticState>,
    trial_stress: Vec<Stress4>,
    trial_f_int: Vec<f64>,
    /// Interface condensation (contact; yielding bodies on their consistent tangent).
    condensed: Option<condensed::Condensed>,
    /// Condensation of yielding bodies: the consistent tangent `K_rho` last assembled (`values`
    /// keeps the elastic one).
    tangent_values: Vec<f64>,
    /// Active contact nodes in the last Newton iteration (reported when a step fails).
    last_active: usize,
    /// Gross sliding (every node in contact slipping one way) seen by the last failed Newton
    /// solve: reported if the cut-backs run out.
    last_gross_sliding: Option<usize>,
    /// Contact and friction sets of the last converged condensed step (for the interface
    /// stiffness the implicit wear jump needs).
    last_sets: Option<ContactSets>,
    /// The trial stresses at points without material equal the state's: copied at the first
    /// step on this rule table, and kept so since no solve writes those points and a commit
    /// swaps the two buffers. Handed on with the buffers to a re-pairing on the same bulk.
    void_stresses_synced: bool,
    /// Contact and friction sets the next condensed step's first interface iteration starts
    /// from instead of the augmented-Lagrangian prediction (see [`Self::start_from_sets`]).
    start_sets: Option<ContactSets>,
    /// What the condensed pattern was built from (handed on with [`Self::into_reuse`]).
    reuse_key: Option<condensed::ReuseKey>,
    /// Whether the set-up reused the previous set-up's pattern and symbolic factorisation.
    reused: bool,
    /// The increment is being retried with the line search (see [`Self::backtrack`]).
    line_search: bool,
    /// Birth forces of ghost-penalty faces (`(dof, K_F u_birth)` summed, from the state at the
    /// start of each step; see [`crate::state::GhostBirths`]).
    ghost_offset: Vec<(usize, f64)>,
}

/// Small sliding pairs from the reference geometry: a converged state whose nodes in contact
/// slid further from their partners than the whole contact is wide has left the model's range.
fn check_small_sliding(
    disc: &Discretisation,
    u: &[f64],
    status: &[FrictionStatus],
    step: usize,
    t: f64,
) -> Result<(), AnalysisError> {
    match slide_from_pairing(&disc.contact, u, status) {
        Some((slide, width)) if slide > width => {
            Err(AnalysisError::SlidingBeyondPairing { step, time: t, slide, width })
        }
        _ => Ok(()),
    }
}

/// Passes of iterative refinement of one condensed step.
const MAX_REFINEMENTS: usize = 3;

/// Yielding bodies: a Newton solve whose residual is still above the elastic predictor's after
/// this many iterations is cut back (converging solves take 2-8).
const STALLED_AFTER: usize = 10;

/// Halvings a yielding body's Newton pass may be cut back by when it raises the residual.
const LINE_SEARCH_CUTS: usize = 6;

/// Growth of the residual over the elastic predictor's at which a yielding body's plain Newton
/// is taken to diverge (and the increment retried with the line search).
const DIVERGED: f64 = 100.0;

/// `C^T lambda` over all DOFs.
fn constraint_forces(m: &Model, disc: &Discretisation, mult: &[f64], out: &mut [f64]) {
    out.iter_mut().for_each(|v| *v = 0.0);
    for (row, l) in disc.multiplier_rows(m).zip(mult) {
        for &(d, c) in row {
            out[d] += c * l;
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl<'m> StaticAnalysis<'m> {
    /// Builds the sparsity pattern and the symbolic factorisation (once per topology). Contact
    /// between linear elastic bodies is solved by interface condensation, anything else by the
    /// monolithic saddle-point Newton.
    pub fn new(model: &'m Model) -> Result<Self, AnalysisError> {
        Self::on(model, model.initial_shared())
    }

    /// As [`Self::new`], on a discretisation of the model other than the one it was built with
    /// (moved or worn surfaces, re-paired contact).
    pub fn on(model: &'m Model, disc: Arc<Discretisation>) -> Result<Self, AnalysisError> {
        let condense = condensed::applies(&disc);
        Self::with_condensation(model, disc, condense)
    }

    /// As [`Self::new`] for the next set-up of a run (moved surfaces, re-paired contact): the
    /// condensed solver's pattern and symbolic factorisation of the previous set-up are reused
    /// when its structure is the same (see [`SolverReuse`]).
    pub fn with_reuse(
        model: &'m Model,
        disc: Arc<Discretisation>,
        reuse: Option<SolverReuse>,
    ) -> Result<Self, AnalysisError> {
        Self::for_pairings(model, disc, reuse, false)
    }

    /// As [`Self::with_reuse`]; `surface_compliance`: the bulk will serve many pairings of a
    /// finite-sliding model (a run without moving surfaces), so the interface operator of each
    /// is formed from the surfaces' compliance, itself formed once per bulk (see the
    /// `condensed` module). The choice must depend on the case alone: both operators are exact
    /// but differ in round-off, and a restart must make the same choice.
    pub fn for_pairings(
        model: &'m Model,
        disc: Arc<Discretisation>,
        reuse: Option<SolverReuse>,
        surface_compliance: bool,
    ) -> Result<Self, AnalysisError> {
        if condensed::applies(&disc) {
            Self::condensed(model, disc, reuse, surface_compliance)
        } else {
            Self::with_condensation(model, disc, false)
        }
    }

    /// The interface rows and operator of `disc`, this analysis's model re-paired (the next
    /// step of finite sliding on the same bulk), formed on this analysis's factor while it is
    /// still read (the step's wear integration and output): handed to the next analysis with
    /// [`SolverReuse::with_prepared`], whose set-up would form the same. `None` where that
    /// set-up forms them otherwise (yielding bodies, a tangent factor, surface compliance) or
    /// if forming them fails (the next set-up then meets the failure itself).
    pub fn prepare_rows(&self, disc: &Discretisation) -> Option<PreparedRows> {
        let c = self.condensed.as_ref()?;
        if self.model.has_plasticity() || c.tangent || c.compliance.is_some() {
            return None;
        }
        let bulk = condensed::BulkRows {
            grounds: c.ground_rows.clone(),
            rho_tie: c.rho_tie,
            rho_ground: c.rho_ground,
            equations: c.equations.clone(),
        };
        condensed::interface_rows(self.model, disc, bulk, None, &self.solver).ok().map(PreparedRows)
    }

    /// The solver structure this analysis can hand to the next set-up (condensed only).
    pub fn into_reuse(self) -> Option<SolverReuse> {
        let key = self.reuse_key?;
        let mut solver = self.solver;
        // A factor of a tangent is no next set-up's K_rho: the elastic one is factored back (the
        // values kept are always its), or if that fails the next set-up assembles its own.
        let mut condensed = self.condensed;
        let tangent = condensed.as_ref().is_some_and(|c| c.tangent);
        let lost = tangent
            && match condensed.as_mut().and_then(|c| c.elastic_factor.take()) {
                Some(elastic) => {
                    solver.put_factor(elastic);
                    false
                }
                None => solver.factor(&self.values).is_err(),
            };
        let (compliance, bulk) = match condensed {
            Some(c) => {
                let bulk = condensed::BulkRows {
                    grounds: c.ground_rows,
                    rho_tie: c.rho_tie,
                    rho_ground: c.rho_ground,
                    equations: c.equations,
                };
                (c.compliance, Some(bulk))
            }
            None => (None, None),
        };
        let mut reuse = SolverReuse::new(key, self.assembler, solver, self.values, compliance);
        reuse.bulk = bulk;
        reuse.buffers = Some((self.trial_history, self.trial_stress, self.trial_f_int));
        reuse.void_stresses_synced = self.void_stresses_synced;
        Some(if lost { reuse.without_values() } else { reuse })
    }

    /// Whether this analysis was set up on the previous set-up's pattern and symbolic
    /// factorisation (numeric refactorisation only).
    pub fn structure_reused(&self) -> bool {
        self.reused
    }

    fn condensed(
        model: &'m Model,
        disc: Arc<Discretisation>,
        reuse: Option<SolverReuse>,
        compliance: bool,
    ) -> Result<Self, AnalysisError> {
        let mut reuse = reuse;
        let void_stresses_synced = reuse.as_ref().is_some_and(|r| r.keeps_void_stresses());
        let (mut trial_history, mut trial_stress, mut trial_f_int) =
            reuse.as_mut().and_then(|r| r.buffers.take()).unwrap_or_default();
        // As allocated afresh, except the stresses: every step starts them from the state's.
        trial_history.clear();
        trial_history.resize(model.elements.num_states(), PlasticState::default());
        trial_stress.resize(model.elements.num_points(), Stress4::zeros());
        trial_f_int.clear();
        trial_f_int.resize(disc.dofs.num_dofs, 0.0);
        let (mut assembler, solver, values, cd, key, reused) = condensed::setup(model, &disc, true, reuse, compliance)?;
        // A yielding run's elastic bodies: force from their kept stiffness (stresses at commit).
        assembler.set_elastic_force_from_kept(model.has_plasticity());
        Ok(StaticAnalysis {
            model,
            disc,
            assembler,
            solver,
            values,
            alpha: 1.0,
            factored: true,
            parallel: true,
            trial_history,
            trial_stress,
            trial_f_int,
            condensed: Some(cd),
            tangent_values: vec![],
            last_active: 0,
            ghost_offset: vec![],
            line_search: false,
            last_gross_sliding: None,
            last_sets: None,
            start_sets: None,
            void_stresses_synced,
            reuse_key: Some(key),
            reused,
        })
    }

    /// As [`Self::new`], choosing condensation (`true`: only valid where it applies) or the
    /// monolithic saddle-point solve.
    pub fn with_condensation(
        model: &'m Model,
        disc: Arc<Discretisation>,
        condense: bool,
    ) -> Result<Self, AnalysisError> {
        if condense && condensed::applies(&disc) {
            return Self::condensed(model, disc, None, false);
        }
        // Constraint rows are scaled by `alpha ~ E / |C|` in the matrix so that both blocks of the
        // saddle point have the same magnitude: the LU factorisation then keeps its accuracy.
        let all_rows: Vec<&Vec<(usize, f64)>> = disc.multiplier_rows(model).collect();
        let n_coef = all_rows.iter().map(|r| r.len()).sum::<usize>().max(1);
        let mean_coef = all_rows.iter().flat_map(|r| r.iter()).map(|(_, c)| c.abs()).sum::<f64>() / n_coef as f64;
        let e_max = model.materials.iter().map(|m| m.elastic().young).fold(0.0, f64::max);
        let alpha = if mean_coef > 0.0 && e_max > 0.0 { e_max / mean_coef } else { 1.0 };
        let scaled: Vec<Vec<(usize, f64)>> =
            all_rows.iter().map(|r| r.iter().map(|&(d, c)| (d, alpha * c)).collect()).collect();
        let couplings = friction_couplings(&disc.contact);
        let rows = crate::assembly::SaddleRows {
            constraints: &scaled,
            penalty: &disc.penalty,
            fixed_rows: model.constraints.len(),
            couplings: &couplings,
        };
        let pattern = SparsityPattern::with_constraints(model.num_nodes(), &model.elements, &disc.dofs, rows);
        let solver = SparseSolver::new(&pattern.symbolic, model.linear_solver)?;
        let nnz = pattern.nnz();
        tracing::info!(
            dofs = disc.dofs.num_dofs,
            free = disc.dofs.num_free,
            nnz,
            "sparsity pattern and symbolic factorisation ready"
        );
        let mut assembler = Assembler::new(pattern, &model.elements);
        assembler.set_elastic_force_from_kept(model.has_plasticity());
        assembler.share_rules(&disc.rules);
        let num_dofs = disc.dofs.num_dofs;
        Ok(StaticAnalysis {
            model,
            disc,
            assembler,
            solver,
            values: vec![0.0; nnz],
            alpha,
            factored: false,
            parallel: true,
            trial_history: vec![PlasticState::default(); model.elements.num_states()],
            trial_stress: vec![Stress4::zeros(); model.elements.num_points()],
            trial_f_int: vec![0.0; num_dofs],
            condensed: None,
            tangent_values: vec![],
            last_active: 0,
            ghost_offset: vec![],
            line_search: false,
            last_gross_sliding: None,
            last_sets: None,
            start_sets: None,
            void_stresses_synced: false,
            reuse_key: None,
            reused: false,
        })
    }

    /// Serial element loop (for testing that serial and parallel runs agree).
    pub fn set_parallel(&mut self, parallel: bool) {
        self.parallel = parallel;
    }

    /// Prepares a fresh analysis to continue from a checkpointed state: replays the state's
    /// interface log so the condensed operator is the one the interrupted run had (same rows,
    /// same order, same arithmetic: the continuation is bit for bit the uninterrupted run).
    pub fn resume(&mut self, state: &SimState) -> Result<(), AnalysisError> {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
        let Some(mut cd) = self.condensed.take() else {
            return Ok(());
        };
        let mut result = Ok(());
        for (k, batch) in state.interface_log.iter().skip(cd.log.len()).enumerate() {
            if batch.iter().any(|&i| i >= cd.live_of.len() || cd.live_of[i].is_some()) {
                result = Err(AnalysisError::ResumeLog { batch: k });
                break;
            }
            if let Err(e) = cd.grow(m, disc, &self.solver, batch, 0.0) {
                result = Err(e.into());
                break;
            }
            cd.log.push(batch.clone());
        }
        self.condensed = Some(cd);
        result
    }

    /// The unloaded, virgin state.
    pub fn initial_state(&self) -> SimState {
        Self::initial_state_of(self.model)
    }

    /// The unloaded, virgin state of `m` (no solver set up).
    pub fn initial_state_of(m: &Model) -> SimState {
        // The state's layout is the model's: every discretisation of it has these sizes.
        let friction_rows = m.initial().contact.friction_rows.len();
        SimState {
            step: 0,
            time: m.load_path.points[0].0,
            load_factor: m.load_path.factor(m.load_path.points[0].0),
            u: vec![0.0; m.num_dofs()],
            history: vec![PlasticState::default(); m.elements.num_states()],
            stress: vec![Stress4::zeros(); m.elements.num_points()],
            f_int: vec![0.0; m.num_dofs()],
            multipliers: vec![0.0; m.num_multipliers()],
            friction_status: vec![0; friction_rows],
            slip_increment: vec![0.0; friction_rows],
            accumulated_slip: vec![0.0; friction_rows],
            dissipation: 0.0,
            interface_log: vec![],
            wear: m.initial_wear_state(),
            ghost: Default::default(),
            fatigue: Default::default(),
        }
    }

    /// Runs every remaining output step of the model, calling `observer` after each.
    pub fn run<F>(&mut self, state: &mut SimState, mut observer: F) -> Result<(), AnalysisError>
    where
        F: FnMut(&StepReport, &SimState) -> Result<(), ObserverError>,
    {
        let times = self.model.times.clone();
        for (k, &t) in times.iter().enumerate().skip(state.step) {
            let report = self.advance_to(state, k + 1, t)?;
            observer(&report, state).map_err(|source| AnalysisError::Observer { step: k + 1, source })?;
        }
        Ok(())
    }

    /// Advances `state` to time `t_end` (output step `step`), with cut-backs if needed.
    pub fn advance_to(&mut self, state: &mut SimState, step: usize, t_end: f64) -> Result<StepReport, AnalysisError> {
        let params = self.model.newton;
        let (cycle, increment) = self.model.step_label(step);
        let mut report = StepReport {
            step,
            cycle,
            increment,
            time: t_end,
            load_factor: 0.0,
            iterations: 0,
            newton_iterations: 0,
            cutbacks: 0,
            sub_steps: 1,
            residual: 0.0,
        };
        let mut dt = t_end - state.time;
        // Points without material (moving surfaces) are skipped by the kernel and keep the
        // stress they had: the trial buffer takes the converged values there, once per rule
        // table (see `void_stresses_synced`). The kernel writes every other point at the first
        // assembly, unless elastic elements take their force from kept stiffnesses (yielding
        // runs): then all of them are copied at every step.
        if self.assembler.elastic_force_from_kept() {
            self.trial_stress.copy_from_slice(&state.stress);
        } else if !self.void_stresses_synced {
            self.void_stresses_synced = true;
            let (el, rules) = (&self.model.elements, &self.disc.rules);
            for e in 0..el.len() {
                let points = el.point_offset[e]..el.point_offset[e + 1];
                for (p, &w) in points.zip(&rules[el.rule[e]].weights) {
                    if w == 0.0 {
                        self.trial_stress[p] = state.stress[p];
                    }
                }
            }
        }
        self.ghost_offset = state.ghost.offset();
        self.line_search = false;
        while state.time < t_end || dt == 0.0 {
            let t_try = if state.time + dt >= t_end { t_end } else { state.time + dt };
            match self.newton(state, step, t_try)? {
                StepOutcome::Converged { iterations: its, bulk, residual: res } => {
                    report.iterations += its;
                    report.newton_iterations += bulk;
                    report.residual = res;
                    if dt == 0.0 || t_try >= t_end {
                        break;
                    }
                }
                StepOutcome::NotConverged { iterations: its, residual: res } => {
                    report.iterations += its;
                    if self.model.has_plasticity() && self.condensed.is_some() && !self.line_search {
                        // Yielding bodies (condensed step): the same increment once more, globalised.
                        tracing::info!(step, time = t_try, residual = res, "Newton failed; retried with a line search");
                        self.line_search = true;
                        continue;
                    }
                    report.cutbacks += 1;
                    if report.cutbacks > params.max_cutbacks {
                        if let Some(slipping) = self.last_gross_sliding {
                            return Err(AnalysisError::GrossSliding { step, time: t_try, slipping });
                        }
                        if let Some((body, axis, load)) = self.pulled_off_contact(t_try) {
                            return Err(AnalysisError::PulledOffContact { step, time: t_try, body, axis, load });
                        }
                        return Err(NewtonError::NotConverged {
                            step,
                            time: t_try,
                            load_factor: self.model.curve_factor(0, t_try),
                            iteration: its,
                            residual: res,
                            rtol: params.rtol,
                            cutbacks: report.cutbacks - 1,
                            active_contact_nodes: self.last_active,
                        }
                        .into());
                    }
                    // One line per halving only at debug level: a run that cuts a lot would print
                    // thousands; the step's count follows at its end, the run's in its summary.
                    tracing::debug!(step, time = t_try, residual = res, "Newton failed; cutting the increment in half");
                    dt *= 0.5;
                }
            }
        }
        if report.cutbacks > 0 {
            tracing::info!(step, time = t_end, cutbacks = report.cutbacks, "step converged after cutting back");
        }
        state.step = step;
        report.load_factor = state.load_factor;
        Ok(report)
    }

    /// Commits a converged trial state (history advances only here).
    fn commit(
        &mut self,
        state: &mut SimState,
        u: Vec<f64>,
        mu: Vec<f64>,
        t: f64,
        status: &[FrictionStatus],
        slip: &[f64],
    ) {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
        let first_t = m.constraints.len() + disc.contact.rows.len();
        for (j, st) in status.iter().enumerate() {
            state.friction_status[j] = st.code();
            // Slip exists only in contact: an open node's relative tangential motion is not slip
            // (and must not count in the accumulated slip that Archard wear reads).
            let ds = if matches!(st, FrictionStatus::Open) { 0.0 } else { slip[j] };
            state.slip_increment[j] = ds;
            state.accumulated_slip[j] += ds.abs();
            state.dissipation += mu[first_t + j] * ds;
        }
        state.u = u;
        state.multipliers = mu;
        state.time = t;
        state.load_factor = m.curve_factor(0, t);
        std::mem::swap(&mut state.history, &mut self.trial_history);
        self.trial_history.copy_from_slice(&state.history);
        if m.has_plasticity() {
            // The elastic elements' stresses, which the Newton passes left unwritten.
            let input = AssemblyInput {
                coords: &m.coords,
                elements: &m.elements,
                materials: &m.materials,
                rules: &disc.rules,
                u: &state.u,
                state_old: &state.history,
            };
            self.assembler.elastic_stresses(&input, &mut self.trial_stress);
        }
        // Swapped, not copied: the next step starts its trial stresses from the state's (the
        // points a step does not write keep their values in both buffers).
        std::mem::swap(&mut state.stress, &mut self.trial_stress);
        state.f_int.copy_from_slice(&self.trial_f_int);
    }

    /// Internal force (with the ghost-penalty force) at `u` into `trial_f_int`, no tangent.
    fn internal_force(&mut self, u: &[f64], history: &[PlasticState]) {
        self.assemble_trial(u, history, false);
    }

    /// Element loop at `u` from the converged `history`: internal force, stresses and trial
    /// history into the trial buffers, the tangent into `values` when asked; the constant
    /// penalty stiffness (ghost penalty) adds its force to the internal force.
    fn assemble_trial(&mut self, u: &[f64], history: &[PlasticState], with_tangent: bool) {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
        // By condensation `values` keeps the factored elastic K_rho; a tangent goes beside it.
        let condensed = self.reuse_key.is_some();
        if with_tangent && condensed {
            self.tangent_values.resize(self.values.len(), 0.0);
        }
        let values = match (with_tangent, condensed) {
            (false, _) => None,
            (true, true) => Some(self.tangent_values.as_mut_slice()),
            (true, false) => Some(self.values.as_mut_slice()),
        };
        self.assembler.assemble(
            &AssemblyInput {
                coords: &m.coords,
                elements: &m.elements,
                materials: &m.materials,
                rules: &disc.rules,
                u,
                state_old: history,
            },
            AssemblyOutput {
                values,
                f_int: &mut self.trial_f_int,
                stress: &mut self.trial_stress,
                state_new: &mut self.trial_history,
            },
            self.parallel,
        );
        for &(i, j, v) in disc.penalty.iter() {
            self.trial_f_int[i] += v * u[j];
        }
        for &(i, f) in &self.ghost_offset {
            self.trial_f_int[i] -= f;
        }
    }

    /// The contact and friction sets of the last converged condensed step, if any.
    pub fn converged_sets(&self) -> Option<&ContactSets> {
        self.last_sets.as_ref()
    }

    /// The next condensed step's active-set iterations start from `sets` (contact rows in
    /// contact, friction status per friction row; rows this pairing leaves unpaired start open)
    /// instead of the augmented-Lagrangian prediction from the start of the step. For a step
    /// solved again in a nearby pairing (finite sliding): its first solve's converged sets are
    /// all but the answer, where the prediction from the step's start moves the contact edge a
    /// node or two per iteration. The iterations end at a set that reproduces itself, and its
    /// solve is the same arithmetic whichever set they started from.
    pub fn start_from_sets(&mut self, sets: ContactSets) {
        self.start_sets = Some(sets);
    }

    /// Interface stiffness of the last converged step (see [`GapSensitivity`]); `None` without
    /// interface condensation or before a step converged.
    pub fn gap_sensitivity(&self) -> Option<GapSensitivity> {
        let ContactSets { active, status } = self.last_sets.as_ref()?;
        self.condensed.as_ref()?.gap_sensitivity(self.model, &self.disc, active, status, false)
    }

    /// [`Self::gap_sensitivity`] times the gap changes `dg(k)` of the rows in contact, in one
    /// solve: those rows and their multiplier change. `None` as [`Self::gap_sensitivity`].
    pub fn gap_response(&self, dg: &dyn Fn(usize) -> f64) -> Option<(Vec<usize>, Vec<f64>)> {
        let ContactSets { active, status } = self.last_sets.as_ref()?;
        self.condensed.as_ref()?.gap_response(self.model, &self.disc, active, status, dg)
    }

    /// [`Self::gap_sensitivity`] on the rows in contact and the open candidate rows around
    /// them, each held at its gap (what a wear jump needs to let the contact set change).
    pub fn gap_sensitivity_with_open_rows(&self) -> Option<GapSensitivity> {
        let ContactSets { active, status } = self.last_sets.as_ref()?;
        self.condensed.as_ref()?.gap_sensitivity(self.model, &self.disc, active, status, true)
    }

    /// Reactions at constrained DOFs of the current state, zero elsewhere.
    pub fn reactions(&self, state: &SimState) -> Vec<f64> {
        self.disc.reactions(self.model, state)
    }
}
