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

pub use crate::contact::FrictionStatus;
use crate::contact::{
    activate_closest, friction_couplings, given_sets, gross_sliding, row_laws, slide_from_pairing, update_sets,
    zero_open_multipliers, ContactSet, RowLaw,
};

mod condensed;
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
    sets: ContactSets,
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
struct ContactSets {
    active: Vec<bool>,
    status: Vec<FrictionStatus>,
    prev_active: Option<Vec<bool>>,
    prev_status: Vec<FrictionStatus>,
    gaps: Vec<f64>,
    slip: Vec<f64>,
}

impl ContactSets {
    fn new(normal_rows: usize, friction_rows: usize) -> Self {
        ContactSets {
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
        update_sets(c, (mu, &self.gaps, &self.slip), first, None, &mut self.active, &mut self.status);
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

#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    #[error(transparent)]
    Newton(#[from] NewtonError),
    #[error("setting up the linear solver: {0}")]
    Setup(#[from] LinearSolverError),
    #[error("step {step}: {msg}")]
    Observer { step: usize, msg: String },
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
         re-pairings (last pressure change {change:.2e} of the largest): the step slides too far for the \
         re-pairing to follow; raise [steps] increments"
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
    disc: &'m Discretisation,
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
    last_sets: Option<(Vec<bool>, Vec<FrictionStatus>)>,
    /// The trial stresses at points without material equal the state's: copied at the first
    /// step on this rule table, and kept so since no solve writes those points and a commit
    /// swaps the two buffers. Handed on with the buffers to a re-pairing on the same bulk.
    void_stresses_synced: bool,
    /// Contact and friction sets the next condensed step's first interface iteration starts
    /// from instead of the augmented-Lagrangian prediction (see [`Self::start_from_sets`]).
    start_sets: Option<(Vec<bool>, Vec<FrictionStatus>)>,
    /// What the condensed pattern was built from (handed on with [`Self::into_reuse`]).
    reuse_key: Option<condensed::ReuseKey>,
    /// Whether the set-up reused the previous model's pattern and symbolic factorisation.
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
        Self::on(model, model.initial())
    }

    /// As [`Self::new`], on a discretisation of the model other than the one it was built with
    /// (moved or worn surfaces, re-paired contact).
    pub fn on(model: &'m Model, disc: &'m Discretisation) -> Result<Self, AnalysisError> {
        Self::with_condensation(model, disc, condensed::applies(disc))
    }

    /// As [`Self::new`] for the next model of a run (moved surfaces, re-paired contact): the
    /// condensed solver's pattern and symbolic factorisation of the previous model are reused
    /// when its structure is the same (see [`SolverReuse`]).
    pub fn with_reuse(
        model: &'m Model,
        disc: &'m Discretisation,
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
        disc: &'m Discretisation,
        reuse: Option<SolverReuse>,
        surface_compliance: bool,
    ) -> Result<Self, AnalysisError> {
        if condensed::applies(disc) {
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

    /// The solver structure this analysis can hand to the next model's (condensed only).
    pub fn into_reuse(self) -> Option<SolverReuse> {
        let key = self.reuse_key?;
        let mut solver = self.solver;
        // A factor of a tangent is no next model's K_rho: the elastic one is factored back (the
        // values kept are always its), or if that fails the next model assembles its own.
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

    /// Whether this analysis was set up on the previous model's pattern and symbolic
    /// factorisation (numeric refactorisation only).
    pub fn structure_reused(&self) -> bool {
        self.reused
    }

    fn condensed(
        model: &'m Model,
        disc: &'m Discretisation,
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
        let (mut assembler, solver, values, cd, key, reused) = condensed::setup(model, disc, true, reuse, compliance)?;
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
        disc: &'m Discretisation,
        condense: bool,
    ) -> Result<Self, AnalysisError> {
        if condense && condensed::applies(disc) {
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
        let pattern = SparsityPattern::with_constraints(
            model.num_nodes(),
            &model.elements,
            &disc.dofs,
            &scaled,
            &disc.penalty,
            model.constraints.len(),
            &friction_couplings(&disc.contact),
        );
        let solver = SparseSolver::new(&pattern.symbolic, model.linear_solver)?;
        let nnz = pattern.nnz();
        tracing::info!(
            dofs = disc.dofs.num_dofs,
            free = disc.dofs.num_free,
            nnz,
            "sparsity pattern and symbolic factorisation ready"
        );
        Ok(StaticAnalysis {
            model,
            disc,
            assembler: {
                let mut assembler = Assembler::new(pattern, &model.elements);
                assembler.set_elastic_force_from_kept(model.has_plasticity());
                assembler.share_rules(&disc.rules);
                assembler
            },
            solver,
            values: vec![0.0; nnz],
            alpha,
            factored: false,
            parallel: true,
            trial_history: vec![PlasticState::default(); model.elements.num_states()],
            trial_stress: vec![Stress4::zeros(); model.elements.num_points()],
            trial_f_int: vec![0.0; disc.dofs.num_dofs],
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
        let (m, disc) = (self.model, self.disc);
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
        F: FnMut(&StepReport, &SimState) -> Result<(), String>,
    {
        let times = self.model.times.clone();
        for (k, &t) in times.iter().enumerate().skip(state.step) {
            let report = self.advance_to(state, k + 1, t)?;
            observer(&report, state).map_err(|msg| AnalysisError::Observer { step: k + 1, msg })?;
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
                    tracing::warn!(step, time = t_try, residual = res, "Newton failed; cutting the increment in half");
                    dt *= 0.5;
                }
            }
        }
        state.step = step;
        report.load_factor = state.load_factor;
        Ok(report)
    }

    /// One Newton solve from the converged `state` to time `t`. Converged: commits `state`;
    /// not converged: leaves it untouched so the caller can cut back. Linear-solver failures are
    /// errors.
    fn newton(&mut self, state: &mut SimState, step: usize, t: f64) -> Result<StepOutcome, AnalysisError> {
        if self.condensed.is_some() {
            return self.newton_condensed(state, step, t);
        }
        let (m, disc) = (self.model, self.disc);
        let p = m.newton;
        let mut u = state.u.clone();
        for (d, v) in m.prescribed_at(t) {
            u[d] = v;
        }
        let mut f_ext = vec![0.0; disc.dofs.num_dofs];
        m.external_force(t, &mut f_ext);
        let linear = m.is_linear();
        let nf = disc.dofs.num_free;
        let nm = m.constraints.len() + disc.contact.rows.len() + disc.contact.friction_rows.len();
        let mut mu = state.multipliers.clone();
        let mut sets = ContactSets::new(disc.contact.rows.len(), disc.contact.friction_rows.len());
        let mut r = vec![0.0; nf + nm];
        let mut ct_mu = vec![0.0; disc.dofs.num_dofs];
        let mut first_res = f64::NAN;
        let mut res = f64::INFINITY;
        let mut step_scale = 0.0f64;
        for it in 0..=p.max_iterations {
            let need_tangent = !linear || !self.factored;
            // 1. Active set: gaps and slips at u, semi-smooth update of the contact sets.
            let set_changed = sets.update(&disc.contact, &u, &state.u, &mu, it == 0);
            self.last_active = sets.active.iter().filter(|&&a| a).count();
            sets.log(step, it, set_changed);
            // 2. Bulk: internal force (and tangent) at u.
            // 3. Constraint rows by their laws, their forces C^T mu, and their tangent entries.
            let (g_scale, slip_res) = self.monolithic_residual(
                (&u, &mu),
                &state.history,
                (&sets, &f_ext),
                need_tangent,
                (&mut r, &mut ct_mu),
            );
            // 4. Norms: forces, gaps, free multipliers, each against its own scale.
            let norms = self.residual_norms(&r, &f_ext, &ct_mu, &mu, &sets, g_scale, slip_res, &mut step_scale);
            res = norms.residual;
            if it == 0 {
                first_res = res;
            }
            tracing::debug!(step, t, it, residual = res, "Newton iteration");
            // A diverging iteration cuts the increment back (also when every node slips one way:
            // under a prescribed stroke that is ordinary gross slip, not a missing equilibrium;
            // if the cut-backs run out so, it is reported as gross sliding).
            if !res.is_finite() || (it > 0 && res > p.divergence_factor * first_res.max(p.rtol)) {
                self.last_gross_sliding = self.unrestrained_gross_sliding(&sets.status);
                return Ok(StepOutcome::NotConverged { iterations: it, residual: res });
            }
            if !set_changed && (res <= p.rtol || norms.all_zero()) {
                check_small_sliding(disc, &u, &sets.status, step, t)?;
                self.commit(state, u, mu, t, &sets.status, &sets.slip);
                return Ok(StepOutcome::Converged { iterations: it, bulk: it, residual: res });
            }
            if it == p.max_iterations {
                break;
            }
            // 5. Solve for the Newton step and update u and the multipliers.
            if need_tangent {
                match self.solver.factor(&self.values) {
                    Ok(()) => self.factored = true,
                    // A nonlinear tangent can lose definiteness when the trial state is beyond a
                    // limit load: retry with a smaller increment. A linear model's stiffness
                    // never changes, so there the failure is final (insufficient supports).
                    Err(e) if !linear => {
                        tracing::warn!(step, t, it, error = %e, "tangent factorisation failed");
                        self.last_gross_sliding = self.unrestrained_gross_sliding(&sets.status);
                        return Ok(StepOutcome::NotConverged { iterations: it, residual: res });
                    }
                    Err(source) => return Err(NewtonError::Linear { step, iteration: it, source }.into()),
                }
            }
            self.solver.solve(&mut r).map_err(|source| NewtonError::Linear { step, iteration: it, source })?;
            for (i, &g) in disc.dofs.free.iter().enumerate() {
                u[g] += r[i];
            }
            for k in 0..nm {
                mu[k] += self.alpha * r[nf + k];
            }
            // The open-node equation lambda = 0 is linear: its Newton step is exact.
            zero_open_multipliers(&disc.contact, &mut mu, &sets.active, &sets.status);
        }
        self.last_gross_sliding = self.unrestrained_gross_sliding(&sets.status);
        Ok(StepOutcome::NotConverged { iterations: p.max_iterations, residual: res })
    }

    /// The monolithic Newton system at `(u, mu)` from the converged `state` (its history and
    /// start-of-step displacements) at time `t`: the right-hand side `r` that Newton solves
    /// `K dx = r` for (then `u += dx_u` on the free equations, `mu += alpha dx_mu`) and the
    /// matrix `K`, dense. The contact laws are those of `frozen` (an earlier system) or, without
    /// it, the semi-smooth update's at `(u, mu)`. With the laws fixed, `K = -dr/dx` for
    /// `x = (u_free, mu / alpha)`: what a finite-difference check of the algorithmic tangent
    /// (bulk, contact and friction rows together) compares. `None` for a condensed analysis,
    /// whose matrix holds no contact rows.
    pub fn newton_system(
        &mut self,
        state: &SimState,
        t: f64,
        (u, mu): (&[f64], &[f64]),
        frozen: Option<&NewtonSystem>,
    ) -> Option<NewtonSystem> {
        if self.condensed.is_some() {
            return None;
        }
        let (m, disc) = (self.model, self.disc);
        let (nc, nfr) = (disc.contact.rows.len(), disc.contact.friction_rows.len());
        let nf = disc.dofs.num_free;
        let nm = m.constraints.len() + nc + nfr;
        self.ghost_offset = state.ghost.offset();
        let sets = match frozen {
            Some(f) => {
                let mut sets = f.sets.clone();
                sets.measure(&disc.contact, u, &state.u);
                sets
            }
            None => {
                let mut sets = ContactSets::new(nc, nfr);
                sets.update(&disc.contact, u, &state.u, mu, false);
                sets
            }
        };
        let mut f_ext = vec![0.0; disc.dofs.num_dofs];
        m.external_force(t, &mut f_ext);
        let mut rhs = vec![0.0; nf + nm];
        let mut ct_mu = vec![0.0; disc.dofs.num_dofs];
        self.monolithic_residual((u, mu), &state.history, (&sets, &f_ext), true, (&mut rhs, &mut ct_mu));
        let pattern = &self.assembler.pattern.symbolic;
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        let mut matrix = DMatrix::zeros(nf + nm, nf + nm);
        for j in 0..nf + nm {
            for p in cp[j]..cp[j + 1] {
                matrix[(ri[p], j)] = self.values[p];
            }
        }
        Some(NewtonSystem { rhs, matrix, alpha: self.alpha, num_free: nf, sets })
    }

    /// The monolithic Newton right-hand side at `(u, mu)` from the converged `history` for the
    /// contact sets `sets`: the free equations' force residual `f_ext - f_int - C^T mu`, then
    /// the constraint rows by their laws, into `r`; `C^T mu` into `ct_mu`. With `tangent`, the
    /// matrix too (bulk tangent, contact entries by the laws). Returns what
    /// [`Self::constraint_residual`] returns.
    fn monolithic_residual(
        &mut self,
        (u, mu): (&[f64], &[f64]),
        history: &[PlasticState],
        (sets, f_ext): (&ContactSets, &[f64]),
        tangent: bool,
        (r, ct_mu): (&mut [f64], &mut [f64]),
    ) -> (f64, f64) {
        let disc = self.disc;
        let nf = disc.dofs.num_free;
        self.assemble_trial(u, history, tangent);
        let laws = row_laws(&disc.contact, &sets.active, &sets.status);
        let scales = self.constraint_residual(u, mu, sets, &laws, &mut r[nf..], ct_mu);
        if tangent && !disc.contact.rows.is_empty() {
            self.scatter_contact_tangent(&laws);
        }
        for (i, &g) in disc.dofs.free.iter().enumerate() {
            r[i] = f_ext[g] - self.trial_f_int[g] - ct_mu[g];
        }
        scales
    }

    /// Residual of the constraint rows into `r` (one entry per multiplier: ties and active
    /// contact rows `-alpha g`, stick rows `-alpha ds`, free rows `-lambda / alpha`, slip rows
    /// `-(lambda_t - coef lambda_n) / alpha`, by the laws of `src/contact`), and the constraint
    /// forces `C^T mu` into `ct_mu`. Returns the squared scale `sum (|C| |u|)^2` of the gap rows
    /// and the largest slip-law residual.
    fn constraint_residual(
        &self,
        u: &[f64],
        mu: &[f64],
        sets: &ContactSets,
        laws: &[RowLaw],
        r: &mut [f64],
        ct_mu: &mut [f64],
    ) -> (f64, f64) {
        let (m, disc) = (self.model, self.disc);
        let (nt, nc) = (m.constraints.len(), disc.contact.rows.len());
        ct_mu.iter_mut().for_each(|v| *v = 0.0);
        let mut g_scale = 0.0;
        for (k, row) in m.constraints.iter().enumerate() {
            let (mut g, mut gs) = (0.0, 0.0);
            for &(d, c) in row {
                ct_mu[d] += c * mu[k];
                g += c * u[d];
                gs += (c * u[d]).abs();
            }
            r[k] = -self.alpha * g;
            g_scale += gs * gs;
        }
        let mut slip_res = 0.0f64;
        for i in nt..r.len() {
            let row = if i < nt + nc { &disc.contact.rows[i - nt] } else { &disc.contact.friction_rows[i - nt - nc] };
            for &(d, c) in row {
                ct_mu[d] += c * mu[i];
            }
            r[i] = match laws[i] {
                RowLaw::Constraint => {
                    let (value, offset) = if i < nt + nc {
                        (sets.gaps[i - nt], disc.contact.g0[i - nt].abs())
                    } else {
                        (sets.slip[i - nt - nc], 0.0)
                    };
                    let gs: f64 = offset + row.iter().map(|&(d, c)| (c * u[d]).abs()).sum::<f64>();
                    g_scale += gs * gs;
                    -self.alpha * value
                }
                RowLaw::Free => -mu[i] / self.alpha,
                RowLaw::Slip { normal, coef } => {
                    let res = mu[i] - coef * mu[normal];
                    slip_res = slip_res.max(res.abs());
                    -res / self.alpha
                }
            };
        }
        (g_scale, slip_res)
    }

    /// The contact rows' entries of the tangent for the current laws: `C` and `C^T` where a row
    /// is a constraint, the identity where it is free, `-coef` coupling a slip row to its normal.
    fn scatter_contact_tangent(&mut self, laws: &[RowLaw]) {
        let (m, disc) = (self.model, self.disc);
        let (nt, nc) = (m.constraints.len(), disc.contact.rows.len());
        let pat = &self.assembler.pattern;
        for &(row, p1, p2, coef) in &pat.constraint_scatter {
            if row >= nt {
                self.values[p2] += coef;
                if laws[row] == RowLaw::Constraint {
                    self.values[p1] += coef;
                }
            }
        }
        for (k, &pd) in pat.diag_scatter.iter().enumerate() {
            self.values[pd] = if laws[nt + k] == RowLaw::Constraint { 0.0 } else { 1.0 };
        }
        for (j, &pc) in pat.coupling_scatter.iter().enumerate() {
            self.values[pc] = match laws[nt + nc + j] {
                RowLaw::Slip { coef, .. } => -coef,
                _ => 0.0,
            };
        }
    }

    /// The Newton residual's parts, each against its own scale: forces against the largest of
    /// the external, internal and constraint forces (never below what the step has seen,
    /// `step_scale`); gap rows against `|C| |u|`; free multipliers and slip laws against the
    /// largest contact multiplier.
    #[allow(clippy::too_many_arguments)]
    fn residual_norms(
        &self,
        r: &[f64],
        f_ext: &[f64],
        ct_mu: &[f64],
        mu: &[f64],
        sets: &ContactSets,
        g_scale: f64,
        slip_res: f64,
        step_scale: &mut f64,
    ) -> ResidualNorms {
        let (m, disc) = (self.model, self.disc);
        let nf = disc.dofs.num_free;
        let (nt, nc, nfr) = (m.constraints.len(), disc.contact.rows.len(), disc.contact.friction_rows.len());
        let f_ext_norm = norm(f_ext);
        // Force scale: never below what this step has seen (a contact that opens can leave a
        // body unloaded, where the current forces are all round-off).
        let scale = f_ext_norm.max(norm(&self.trial_f_int)).max(norm(ct_mu)).max(*step_scale);
        *step_scale = scale;
        let rn = norm(&r[..nf]);
        // Gap residuals (ties, active contact rows) against |C| |u|; inactive contact rows
        // (lambda = 0) against the largest contact multiplier.
        let gap_rows = (0..nt)
            .chain((0..nc).filter(|&k| sets.active[k]).map(|k| nt + k))
            .chain((0..nfr).filter(|&j| sets.status[j] == FrictionStatus::Stick).map(|j| nt + nc + j));
        let gn = gap_rows.map(|k| r[nf + k] * r[nf + k]).sum::<f64>().sqrt() / self.alpha;
        // Multiplier scale: the largest contact multiplier or the force scale spread over the
        // paired contact length.
        let contact_len: f64 = disc.contact.phi.iter().sum();
        let mu_ref = mu[nt..].iter().fold(0.0f64, |a, v| a.max(v.abs())).max(if contact_len > 0.0 {
            scale / contact_len
        } else {
            0.0
        });
        let free_mu = (0..nc)
            .filter(|&k| !sets.active[k])
            .map(|k| nt + k)
            .chain((0..nfr).filter(|&j| sets.status[j] == FrictionStatus::Open).map(|j| nt + nc + j))
            .fold(slip_res, |a, i| a.max(mu[i].abs()));
        let res_u = if scale > 0.0 { rn / scale } else { rn };
        let res_g = if gn == 0.0 { 0.0 } else { gn / g_scale.sqrt().max(f64::MIN_POSITIVE) };
        let res_mu = if free_mu == 0.0 { 0.0 } else { free_mu / mu_ref.max(f64::MIN_POSITIVE) };
        tracing::trace!(res_u, res_g, res_mu, rn, scale, "residual parts");
        ResidualNorms { residual: res_u.max(res_g).max(res_mu), forces: rn, gaps: gn, free_multipliers: free_mu }
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
        let (m, disc) = (self.model, self.disc);
        let first_t = m.constraints.len() + disc.contact.rows.len();
        for (j, st) in status.iter().enumerate() {
            state.friction_status[j] = match st {
                FrictionStatus::Open => 0,
                FrictionStatus::Stick => 1,
                FrictionStatus::Slip(_) => 2,
            };
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
        let (m, disc) = (self.model, self.disc);
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

    /// One load step by interface condensation (see [`condensed`]): the active-set iterations
    /// run on the L live multipliers only; the bulk is touched by two solves with the constant
    /// factor of `K_rho` and two internal-force evaluations.
    fn newton_condensed(&mut self, state: &mut SimState, step: usize, t: f64) -> Result<StepOutcome, AnalysisError> {
        let Some(mut cd) = self.condensed.take() else {
            return Ok(StepOutcome::NotConverged { iterations: 0, residual: f64::INFINITY });
        };
        let result = self.condensed_step(&mut cd, state, step, t);
        if matches!(result, Ok(StepOutcome::Converged { .. })) && state.interface_log.len() != cd.log.len() {
            state.interface_log.clone_from(&cd.log);
        }
        self.condensed = Some(cd);
        result
    }

    /// One load step by interface condensation: per refinement pass, the bulk predictor
    /// `z = K_rho^{-1} r_u`, the active-set iterations on the interface, the recovery of `u`
    /// and the multipliers (growing the interface set where a row outside it would
    /// penetrate), and the equilibrium check of the recovered state.
    fn condensed_step(
        &mut self,
        cd: &mut condensed::Condensed,
        state: &mut SimState,
        step: usize,
        t: f64,
    ) -> Result<StepOutcome, AnalysisError> {
        let (m, disc) = (self.model, self.disc);
        let p = m.newton;
        let (nc, nfr) = (disc.contact.rows.len(), disc.contact.friction_rows.len());
        let mut u = state.u.clone();
        for (d, v) in m.prescribed_at(t) {
            u[d] = v;
        }
        let mut f_ext = vec![0.0; disc.dofs.num_dofs];
        m.external_force(t, &mut f_ext);
        let mut lam0 = state.multipliers.clone();
        let mut iterations = 0;
        let history = state.history.clone();
        // Elastic bodies: iterative refinement. The interface problem is linear for fixed sets,
        // so a pass that misses the tolerance only by round-off (K_rho's regularisation of
        // floating bodies costs digits) is repeated from its own result, the sets then unchanged.
        // Yielding bodies: each pass is a Newton step of the bulk whose contact problem is solved
        // exactly on the interface (the first from the elastic predictor, see below).
        let plastic = m.has_plasticity();
        let passes = if plastic { p.max_iterations.max(MAX_REFINEMENTS) } else { MAX_REFINEMENTS };
        let mut first_res: Option<f64> = None;
        let mut last_res = f64::INFINITY;
        // Yielding bodies: one force scale for every pass, the converged start's (see
        // `force_scale`).
        let start_scale = plastic.then(|| self.force_scale(state, &f_ext));
        self.grow_where_loaded(cd, &lam0, step, t)?;
        for pass in 0..passes {
            // r_u = f - f_int(u0) - C^T lambda0 on the free equations, z = K_rho^{-1} r_u.
            self.pass_operator(cd, (&state.u, &u), &history, pass, step, iterations)?;
            let mut ct = vec![0.0; disc.dofs.num_dofs];
            constraint_forces(m, disc, &lam0, &mut ct);
            // Force scale of the step: what the start of the step has seen too (a contact that opens
            // leaves the bodies unloaded, where the final forces are all round-off).
            let scale0 = start_scale.unwrap_or_else(|| norm(&f_ext).max(norm(&self.trial_f_int)).max(norm(&ct)));
            // Over the equations of K_rho; switched-off DOFs take no load (they stay where they are).
            let mut z: Vec<f64> = cd
                .equations
                .free
                .iter()
                .map(|&g| if disc.dofs.eq[g] == CONSTRAINED { 0.0 } else { f_ext[g] - self.trial_f_int[g] - ct[g] })
                .collect();
            self.solver.solve(&mut z).map_err(|source| NewtonError::Linear { step, iteration: 0, source })?;
            let start = InterfaceStart {
                slip0: (0..nfr)
                    .map(|j| disc.contact.friction_rows[j].iter().map(|&(d, c)| c * (u[d] - state.u[d])).sum())
                    .collect(),
                // Weighted gaps minus g0 of every contact row at the start of the step.
                w_start: disc.contact.rows.iter().map(|r| r.iter().map(|&(d, c)| c * u[d]).sum()).collect(),
                u_start: u.clone(),
            };
            let mut sets = ContactSets::new(nc, nfr);
            let mut mu = loop {
                let (dlam, dw) = match self.interface_iterations(cd, &z, &start, &lam0, &mut sets, step, t)? {
                    InterfaceSolve::Solved { dlam, dw, iterations: its } => {
                        iterations += its;
                        (dlam, dw)
                    }
                    InterfaceSolve::Failed(outcome) => {
                        self.last_gross_sliding = self.unrestrained_gross_sliding(&sets.status);
                        return Ok(outcome);
                    }
                };
                self.recover_displacement(cd, (&z, &dlam, &dw), &start.u_start, &mut u)
                    .map_err(|source| NewtonError::Linear { step, iteration: iterations, source })?;
                let mut mu = lam0.clone();
                for (a, i) in cd.model_rows() {
                    mu[i] += dlam[a];
                }
                if !self.grow_where_penetrating(cd, &u, step, t, iterations)? {
                    break mu;
                }
            };
            // Exact zeros where the law says so (open nodes).
            zero_open_multipliers(&disc.contact, &mut mu, &sets.active, &sets.status);
            // Check: the equilibrium residual of the recovered state (yielding bodies: with the
            // tangent there, for the next pass).
            let mut res = self.residual_at(&u, &mu, &history, (&f_ext, scale0), plastic);
            if self.line_search && pass > 0 && res > last_res {
                res = self.backtrack((&start.u_start, &lam0), (&mut u, &mut mu), &history, (&f_ext, scale0), last_res);
            }
            last_res = res;
            tracing::debug!(step, t, iterations, residual = res, "condensed step");
            if res.is_finite() && res <= p.rtol {
                check_small_sliding(disc, &u, &sets.status, step, t)?;
                self.commit(state, u, mu, t, &sets.status, &sets.slip);
                self.last_sets = Some((sets.active, sets.status));
                return Ok(StepOutcome::Converged { iterations, bulk: pass + 1, residual: res });
            }
            let first = *first_res.get_or_insert(res);
            if self.gives_up(&sets.status, (pass, passes), (first, res), step, t)? {
                return Ok(StepOutcome::NotConverged { iterations, residual: res });
            }
            tracing::debug!(step, t, pass, residual = res, "condensed step: refining");
            lam0 = mu;
        }
        Ok(StepOutcome::NotConverged { iterations, residual: f64::INFINITY })
    }

    /// The force scale of the converged `state`: the largest of the external force `f_ext`,
    /// the internal and the constraint forces there. A yielding step measures every pass
    /// against it: the first pass's own start, the elastic predictor, holds the reaction to the
    /// whole prescribed increment, a scale about 100 times larger than the passes after it see,
    /// against which converging Newton looked divergent.
    fn force_scale(&self, state: &SimState, f_ext: &[f64]) -> f64 {
        let mut ct = vec![0.0; self.disc.dofs.num_dofs];
        constraint_forces(self.model, self.disc, &state.multipliers, &mut ct);
        norm(f_ext).max(norm(&state.f_int)).max(norm(&ct))
    }

    /// Relative equilibrium residual of `(u, mu)` on the free equations (the step's force scale
    /// `scale0` or the forces there, whichever is larger); leaves force, stresses, trial
    /// history (and with `tangent` the tangent) of `u` in the trial buffers.
    fn residual_at(
        &mut self,
        u: &[f64],
        mu: &[f64],
        history: &[PlasticState],
        (f_ext, scale0): (&[f64], f64),
        tangent: bool,
    ) -> f64 {
        let (m, disc) = (self.model, self.disc);
        self.assemble_trial(u, history, tangent);
        let mut ct = vec![0.0; disc.dofs.num_dofs];
        constraint_forces(m, disc, mu, &mut ct);
        let r: Vec<f64> = disc.dofs.free.iter().map(|&g| f_ext[g] - self.trial_f_int[g] - ct[g]).collect();
        let scale = scale0.max(norm(&self.trial_f_int)).max(norm(&ct));
        if scale > 0.0 {
            norm(&r) / scale
        } else {
            norm(&r)
        }
    }

    /// Yielding bodies, in an increment whose plain Newton failed or diverged (retried before
    /// it is cut back; converging increments are left to plain Newton, which may raise the
    /// residual for a pass while its plastic and contact sets change and still converge
    /// quadratically after it): a pass that raised the residual above the last one's (`last`) is
    /// cut back along its direction, `(u, mu) = start + s (full - start)` for `s = 1/2, 1/4,
    /// ...`, to the first that lowers it (or the smallest tried). The consistent tangent of a
    /// layer that yielded under the normal load is much softer than its elastic unloading at
    /// the onset of slip: a full step overshoots into the plastic branch. Returns the residual
    /// of the accepted point, whose force and tangent are in the trial buffers.
    fn backtrack(
        &mut self,
        (u_start, lam_start): (&[f64], &[f64]),
        (u, mu): (&mut Vec<f64>, &mut Vec<f64>),
        history: &[PlasticState],
        force: (&[f64], f64),
        last: f64,
    ) -> f64 {
        let (u_full, mu_full) = (u.clone(), mu.clone());
        let mut res = f64::INFINITY;
        let mut s = 1.0;
        for _ in 0..LINE_SEARCH_CUTS {
            s *= 0.5;
            for ((x, a), b) in u.iter_mut().zip(u_start).zip(&u_full) {
                *x = a + s * (b - a);
            }
            for ((x, a), b) in mu.iter_mut().zip(lam_start).zip(&mu_full) {
                *x = a + s * (b - a);
            }
            res = self.residual_at(u, mu, history, force, true);
            tracing::debug!(s, residual = res, last, "condensed step: line search");
            if res < last {
                break;
            }
        }
        res
    }

    /// A body that only contact holds along `x` or `y` (no prescribed DOF of it along the axis,
    /// no constraint row coupling it to another body) while its load along that axis pulls it
    /// away from its contacts (against the sum of their outward normals): `(body, axis, net
    /// load)`. Checked where a step failed: no contact can hold such a body.
    fn pulled_off_contact(&self, t: f64) -> Option<(String, char, f64)> {
        let m = self.model;
        let mut f = vec![0.0; m.num_dofs()];
        m.external_force(t, &mut f);
        let scale = f.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        if scale == 0.0 {
            return None;
        }
        let normals = m.contact_normal_sums();
        for (b, body) in m.bodies.iter().enumerate() {
            let in_body = |d: usize| m.body_of_node(d / 2) == Some(b);
            let coupled = m
                .constraints
                .iter()
                .any(|row| row.iter().any(|&(d, _)| in_body(d)) && row.iter().any(|&(d, _)| !in_body(d)));
            if coupled {
                continue;
            }
            let normal = normals[b];
            for (axis, name) in [(0, 'x'), (1, 'y')] {
                if m.prescribed.iter().any(|&(d, _)| d % 2 == axis && in_body(d)) {
                    continue;
                }
                let load: f64 = (0..body.mesh.nodes.len()).map(|n| f[2 * (body.node_offset + n) + axis]).sum();
                if load.abs() > 1e-9 * scale && load * normal[axis] < 0.0 {
                    return Some((body.name.clone(), name, load));
                }
            }
        }
        None
    }

    /// Gross sliding that a free body explains: every contact node in contact slips one way
    /// ([`gross_sliding`]) and a body those friction rows act on has no prescribed displacement
    /// along the slip (a component of at least 0.3 of the slip direction). Where every such
    /// body is held along it (a prescribed stroke), slipping everywhere is the stroke's doing
    /// and says nothing about why a step failed: `None`, and the failure reports its facts.
    fn unrestrained_gross_sliding(&self, status: &[FrictionStatus]) -> Option<usize> {
        let slipping = gross_sliding(status)?;
        let rows = &self.disc.contact.friction_rows;
        let (mut along, mut dofs) = ([0.0_f64; 2], vec![]);
        for (j, _) in status.iter().enumerate().filter(|(_, s)| matches!(s, FrictionStatus::Slip(_))) {
            for &(d, v) in rows.get(j).into_iter().flatten() {
                along[d % 2] += v.abs();
                dofs.push(d);
            }
        }
        let norm = along[0].hypot(along[1]);
        if norm <= 0.0 {
            return Some(slipping);
        }
        let body_of = |dof: usize| self.model.body_of_node(dof / 2);
        let bodies: std::collections::BTreeSet<usize> = dofs.iter().filter_map(|&d| body_of(d)).collect();
        let held =
            |b: usize| self.model.prescribed.iter().any(|&(d, _)| along[d % 2] >= 0.3 * norm && body_of(d) == Some(b));
        bodies.iter().any(|&b| !held(b)).then_some(slipping)
    }

    /// Whether a condensed step that missed the tolerance after `pass` of `passes` stops here
    /// (the caller cuts back). Elastic bodies: a pass repeats only to refine round-off, so gross
    /// sliding (every node slipping one way) is an error at once. Yielding bodies: Newton goes
    /// on until it runs out of iterations or has not got below the first residual in
    /// `STALLED_AFTER`; gross sliding under a prescribed stroke is ordinary there and is
    /// reported only if the cut-backs run out.
    fn gives_up(
        &mut self,
        status: &[FrictionStatus],
        (pass, passes): (usize, usize),
        (first, res): (f64, f64),
        step: usize,
        t: f64,
    ) -> Result<bool, AnalysisError> {
        let out_of_passes = !res.is_finite() || pass + 1 == passes;
        if !self.model.has_plasticity() {
            if let Some(slipping) = self.unrestrained_gross_sliding(status) {
                return Err(AnalysisError::GrossSliding { step, time: t, slipping });
            }
            return Ok(out_of_passes);
        }
        // Plain Newton that multiplies the predictor's residual by DIVERGED has left its basin:
        // the increment is retried with the line search at once.
        let diverged = !self.line_search && res > DIVERGED * first;
        let stalled = diverged || (pass >= STALLED_AFTER && res > first);
        if out_of_passes || stalled {
            self.last_gross_sliding = self.unrestrained_gross_sliding(status);
            return Ok(true);
        }
        Ok(false)
    }

    /// The internal force at the start of a condensed pass into `trial_f_int`, and the bulk
    /// operator in the factor. Elastic bodies: the force at `u`. Yielding bodies: the first
    /// pass is the elastic predictor from the converged state `u_conv` (the prescribed
    /// increment spread by the elastic operator, the contact solved exactly on it); later
    /// passes are Newton steps on the consistent tangent at `u` (the check of the last pass
    /// assembled force and tangent there).
    fn pass_operator(
        &mut self,
        cd: &mut condensed::Condensed,
        (u_conv, u): (&[f64], &[f64]),
        history: &[PlasticState],
        pass: usize,
        step: usize,
        iterations: usize,
    ) -> Result<(), AnalysisError> {
        if !self.model.has_plasticity() {
            self.internal_force(u, history);
        } else if pass > 0 {
            self.tangent_at(cd, history, step, iterations)?;
        } else {
            self.predictor_force(u_conv, u, history);
            self.elastic_operator(cd, step)?;
        }
        Ok(())
    }

    /// The internal force of the elastic predictor into `trial_f_int`: `f_int(u_conv) + K (u0 -
    /// u_conv)` with the elastic `K` (and the ghost penalty). Evaluating the material at `u0`
    /// itself would shear the elements along prescribed boundaries by the whole increment
    /// (the prescribed values jump, the nodes next to them do not) and yield them spuriously:
    /// the Newton steps from that state overshoot and cycle.
    fn predictor_force(&mut self, u_conv: &[f64], u0: &[f64], history: &[PlasticState]) {
        let (m, disc) = (self.model, self.disc);
        let du: Vec<f64> = u0.iter().zip(u_conv).map(|(a, b)| a - b).collect();
        let elastic: Vec<Material> = m.materials.iter().map(|mat| Material::Elastic(*mat.elastic())).collect();
        let mut f_du = vec![0.0; disc.dofs.num_dofs];
        // The trial stress and history serve as scratch: the internal force below rewrites
        // them at every point the elastic assembly wrote. The yielding bodies' elements stand
        // in here as elastic ones: their kept stiffnesses exist or not depending on the passes
        // since the last re-cut, which a restart does not repeat, so the force is integrated
        // (the same bits however the run got here).
        let from_kept = self.assembler.elastic_force_from_kept();
        self.assembler.set_elastic_force_from_kept(false);
        self.assembler.assemble(
            &AssemblyInput {
                coords: &m.coords,
                elements: &m.elements,
                materials: &elastic,
                rules: &disc.rules,
                u: &du,
                state_old: history,
            },
            AssemblyOutput {
                values: None,
                f_int: &mut f_du,
                stress: &mut self.trial_stress,
                state_new: &mut self.trial_history,
            },
            self.parallel,
        );
        self.assembler.set_elastic_force_from_kept(from_kept);
        self.internal_force(u_conv, history);
        for (f, v) in self.trial_f_int.iter_mut().zip(&f_du) {
            *f += v;
        }
        for &(i, j, v) in disc.penalty.iter() {
            self.trial_f_int[i] += v * du[j];
        }
    }

    /// Yielding bodies: the elastic `K_rho` (the tangent at the converged state) in the factor
    /// and the interface operator, factored back if a tangent is there.
    fn elastic_operator(&mut self, cd: &mut condensed::Condensed, step: usize) -> Result<(), AnalysisError> {
        if !cd.tangent {
            return Ok(());
        }
        let linear = |source| NewtonError::Linear { step, iteration: 0, source };
        cd.refactor(self.model, self.disc, &self.assembler.pattern, &mut self.solver, &mut self.values, false)
            .map_err(linear)?;
        Ok(())
    }

    /// Yielding bodies: puts into the factor and the interface operator the consistent tangent
    /// the last assembly left (at `u`, from the converged `history`) where a point yields there;
    /// the elastic `K_rho` where none does (kept when it is already that).
    fn tangent_at(
        &mut self,
        cd: &mut condensed::Condensed,
        history: &[PlasticState],
        step: usize,
        iteration: usize,
    ) -> Result<(), AnalysisError> {
        let yielding = self.trial_history.iter().zip(history).any(|(a, b)| a != b);
        let linear = |source| NewtonError::Linear { step, iteration, source };
        if yielding {
            let (m, disc) = (self.model, self.disc);
            cd.refactor(m, disc, &self.assembler.pattern, &mut self.solver, &mut self.tangent_values, true)
                .map_err(linear)?;
        } else if cd.tangent {
            self.elastic_operator(cd, step)?;
        }
        Ok(())
    }

    /// The active-set iterations on the live interface rows for the bulk predictor `z` (see
    /// [`Self::interface_iterations_from`]), from the sets handed to
    /// [`Self::start_from_sets`] if any: should those fail, once more from the prediction
    /// before the caller cuts back (a start far from the answer must not change the path).
    #[allow(clippy::too_many_arguments)]
    fn interface_iterations(
        &mut self,
        cd: &condensed::Condensed,
        z: &[f64],
        start: &InterfaceStart,
        lam0: &[f64],
        sets: &mut ContactSets,
        step: usize,
        t: f64,
    ) -> Result<InterfaceSolve, AnalysisError> {
        // Sets of another row layout (another pairing's model) are no start.
        let (nc, nfr) = (self.disc.contact.rows.len(), self.disc.contact.friction_rows.len());
        let given = self.start_sets.take().filter(|(a, s)| a.len() == nc && s.len() == nfr);
        let warm = given.is_some();
        let solve = self.interface_iterations_from(cd, (z, start, lam0), sets, given, step, t)?;
        let InterfaceSolve::Failed(StepOutcome::NotConverged { iterations: spent, .. }) = solve else {
            return Ok(solve);
        };
        if !warm {
            return Ok(solve);
        }
        tracing::debug!(step, t, spent, "active-set iterations from the given sets failed: again from the prediction");
        Ok(match self.interface_iterations_from(cd, (z, start, lam0), sets, None, step, t)? {
            InterfaceSolve::Solved { dlam, dw, iterations } => {
                InterfaceSolve::Solved { dlam, dw, iterations: iterations + spent }
            }
            failed => failed,
        })
    }

    /// The active-set iterations on the live interface rows for the bulk predictor `z`: each
    /// iteration updates the sets from the current interface values (the first from `given`
    /// if any, else the augmented-Lagrangian prediction from the step's start), then solves
    /// the dense interface system of their laws for the multiplier and row-value changes
    /// `dlam`, `dw`. Stops when the sets repeat; fails (the caller cuts back) when they cycle,
    /// do not settle within `max_set_iterations` (default: one per live contact row, at least
    /// the Newton limit), or the interface system is singular.
    #[allow(clippy::too_many_arguments)]
    fn interface_iterations_from(
        &mut self,
        cd: &condensed::Condensed,
        (z, start, lam0): (&[f64], &InterfaceStart, &[f64]),
        sets: &mut ContactSets,
        given: Option<(Vec<bool>, Vec<FrictionStatus>)>,
        step: usize,
        t: f64,
    ) -> Result<InterfaceSolve, AnalysisError> {
        let mut given = given;
        let (m, disc) = (self.model, self.disc);
        let p = m.newton;
        let (nt, nc, nfr) = (m.constraints.len(), disc.contact.rows.len(), disc.contact.friction_rows.len());
        let all: Vec<&Vec<(usize, f64)>> = disc.multiplier_rows(m).collect();
        let nl = cd.live.len();
        let cz: Vec<f64> = cd.rows_free.iter().map(|r| r.iter().map(|&(e, c)| c * z[e]).sum()).collect();
        // Row values at u0: w0 = C u0; the law's targets per live row.
        // (Grounding rows: 0, their law does not read it.)
        let w0: Vec<f64> = cd
            .live
            .iter()
            .map(|&i| all.get(i).map_or(0.0, |r| r.iter().map(|&(d, c)| c * start.u_start[d]).sum()))
            .collect();
        let mut dlam = vec![0.0; nl];
        let mut dw = vec![0.0; nl];
        let live_rows: Vec<bool> = (0..nc).map(|k| cd.live_of[nt + k].is_some()).collect();
        // Every set visited: the next set is a function of the current one alone (the laws of
        // a set fix the solve), so a set seen before the last one is a cycle that never settles.
        let mut seen: Vec<(Vec<bool>, Vec<FrictionStatus>)> = vec![];
        let mut mult = lam0.to_vec();
        let mut iterations = 0;
        // A set that never settles cuts the increment back (the caller reports gross sliding,
        // every node slipping one way, if the cut-backs run out so): under a prescribed stroke
        // a smaller increment is what settles it, and a body held only by friction under a
        // load beyond mu P fails at every size.
        let failed = |it: usize| {
            Ok(InterfaceSolve::Failed(StepOutcome::NotConverged { iterations: it, residual: f64::INFINITY }))
        };
        // The sets of a contact zone that starts too wide shrink by a node or two per side and
        // iteration (the outermost node in contact takes the tension): allow one iteration per
        // live contact row (normal or friction; tie rows never change their law), at least the
        // Newton limit, unless the case sets its own.
        let contact_rows = cd.live.iter().filter(|&&i| (nt..nt + nc + nfr).contains(&i)).count();
        let max_iterations = p.max_set_iterations.unwrap_or(p.max_iterations.max(contact_rows));
        for it in 0..=max_iterations {
            for k in 0..nc {
                sets.gaps[k] = disc.contact.g0[k] + cd.live_of[nt + k].map_or(start.w_start[k], |a| w0[a] + dw[a]);
            }
            for j in 0..nfr {
                sets.slip[j] = start.slip0[j] + cd.live_of[nt + nc + j].map_or(0.0, |a| dw[a]);
            }
            for (a, i) in cd.model_rows() {
                mult[i] = lam0[i] + dlam[a];
            }
            let given = if it == 0 { given.take() } else { None };
            match given {
                Some((active, status)) => {
                    given_sets(&disc.contact, (&active, &status), &mut sets.active, &mut sets.status)
                }
                None => update_sets(
                    &disc.contact,
                    (&mult, &sets.gaps, &sets.slip),
                    it == 0,
                    Some(&live_rows),
                    &mut sets.active,
                    &mut sets.status,
                ),
            }
            self.last_active = sets.active.iter().filter(|&&a| a).count();
            // Rows outside the set stay open (checked after the solve).
            for k in (0..nc).filter(|&k| cd.live_of[nt + k].is_none()) {
                sets.active[k] = false;
            }
            for j in (0..nfr).filter(|&j| cd.live_of[nt + nc + j].is_none()) {
                sets.status[j] = FrictionStatus::Open;
            }
            // Given sets whose rows this set lacks leave nothing active: start where the
            // bodies touch first, as the prediction does (else a body that only contact holds
            // floats on the grounding springs and its solve runs away).
            if it == 0 && !sets.active.iter().any(|&a| a) {
                activate_closest(&disc.contact, &sets.gaps, Some(&live_rows), &mut sets.active);
                for (j, st) in sets.status.iter_mut().enumerate() {
                    if sets.active[disc.contact.friction_normal[j]] && cd.live_of[nt + nc + j].is_some() {
                        *st = FrictionStatus::Stick;
                    }
                }
            }
            if let Some((pa, ps)) = seen.last() {
                if pa == &sets.active && ps == &sets.status {
                    break;
                }
            }
            let cycling = seen.iter().any(|(pa, ps)| pa == &sets.active && ps == &sets.status);
            if cycling || it == max_iterations {
                tracing::debug!(step, t, it, cycling, "interface active set does not settle");
                return failed(it);
            }
            seen.push((sets.active.clone(), sets.status.clone()));
            iterations += 1;
            let row_law = row_laws(&disc.contact, &sets.active, &sets.status);
            let laws = cd.laws(m, disc, &row_law, &w0, lam0, &start.slip0);
            let a_mat = cd.law_matrix(&laws);
            let rhs = cd.law_rhs(&laws, &cz);
            let Some(x) = DenseLu::new(a_mat).and_then(|lu| lu.solve(&rhs)) else {
                tracing::warn!(step, t, it, "condensed interface system is singular");
                return failed(it);
            };
            condensed::Law::unpack(&laws, &x, &mut dlam, &mut dw);
        }
        Ok(InterfaceSolve::Solved { dlam, dw, iterations })
    }

    /// A row outside the interface set that would penetrate at `u` joins it (with its
    /// neighbours within the candidate margin); returns whether the set grew (the step's
    /// interface problem is then solved again).
    fn grow_where_penetrating(
        &self,
        cd: &mut condensed::Condensed,
        u: &[f64],
        step: usize,
        t: f64,
        iterations: usize,
    ) -> Result<bool, AnalysisError> {
        let (m, disc) = (self.model, self.disc);
        let (nt, nc) = (m.constraints.len(), disc.contact.rows.len());
        let gaps_u: Vec<f64> = (0..nc)
            .map(|k| disc.contact.g0[k] + disc.contact.rows[k].iter().map(|&(d, c)| c * u[d]).sum::<f64>())
            .collect();
        let penetrates = (0..nc).any(|k| cd.live_of[nt + k].is_none() && disc.contact.phi[k] > 0.0 && gaps_u[k] < 0.0);
        if !penetrates {
            return Ok(false);
        }
        let add: Vec<usize> = condensed::near_rows(disc, &gaps_u, condensed::CANDIDATE_MARGIN, 0.0)
            .into_iter()
            .filter(|&k| cd.live_of[nt + k].is_none())
            .collect();
        tracing::debug!(step, t, added = add.len(), "condensed set grows");
        self.grow_set(cd, &add, step, iterations)?;
        Ok(true)
    }

    /// The displacement after an interface solve: `u = u_start + du`,
    /// `du = z + K_rho^{-1} C^T (rho dw - dlambda)` (see [`condensed`]).
    fn recover_displacement(
        &self,
        cd: &condensed::Condensed,
        (z, dlam, dw): (&[f64], &[f64], &[f64]),
        u_start: &[f64],
        u: &mut Vec<f64>,
    ) -> Result<(), crate::solver::linear::LinearSolverError> {
        let mut y = vec![0.0; cd.equations.num_free];
        for (a, row) in cd.rows_free.iter().enumerate() {
            let v = cd.rho[a] * dw[a] - dlam[a];
            for &(e, c) in row {
                y[e] += c * v;
            }
        }
        self.solver.solve(&mut y)?;
        u.clear();
        u.extend_from_slice(u_start);
        for (i, &g) in cd.equations.free.iter().enumerate() {
            if self.disc.dofs.eq[g] != CONSTRAINED {
                u[g] += z[i] + y[i];
            }
        }
        Ok(())
    }

    /// Rows that carry a multiplier at the start of the step (`lambda0`: in contact at the last
    /// converged state) join the set whatever their gap in this pairing: the set is chosen from
    /// the gaps of the undeformed surfaces, and a row left outside would have its multiplier
    /// zeroed after the solve, unbalancing it.
    fn grow_where_loaded(
        &self,
        cd: &mut condensed::Condensed,
        lambda0: &[f64],
        step: usize,
        t: f64,
    ) -> Result<(), AnalysisError> {
        let (nt, nc) = (self.model.constraints.len(), self.disc.contact.rows.len());
        let loaded: Vec<usize> = (0..nc).filter(|&k| cd.live_of[nt + k].is_none() && lambda0[nt + k] != 0.0).collect();
        if loaded.is_empty() {
            return Ok(());
        }
        tracing::debug!(step, t, added = loaded.len(), "condensed set grows by the rows in contact at the start");
        self.grow_set(cd, &loaded, step, 0)
    }

    /// Adds the contact normal rows `rows` (not in the set) and their friction rows to the
    /// interface set, logged for a restart.
    fn grow_set(
        &self,
        cd: &mut condensed::Condensed,
        rows: &[usize],
        step: usize,
        iterations: usize,
    ) -> Result<(), AnalysisError> {
        let (m, disc) = (self.model, self.disc);
        let batch = condensed::with_friction(m, disc, rows);
        cd.grow(m, disc, &self.solver, &batch, 0.0).map_err(|source| NewtonError::Linear {
            step,
            iteration: iterations,
            source,
        })?;
        cd.log.push(batch);
        Ok(())
    }

    /// The contact and friction sets of the last converged condensed step, if any.
    pub fn converged_sets(&self) -> Option<&(Vec<bool>, Vec<FrictionStatus>)> {
        self.last_sets.as_ref()
    }

    /// The next condensed step's active-set iterations start from `sets` (contact rows in
    /// contact, friction status per friction row; rows this pairing leaves unpaired start open)
    /// instead of the augmented-Lagrangian prediction from the start of the step. For a step
    /// solved again in a nearby pairing (finite sliding): its first solve's converged sets are
    /// all but the answer, where the prediction from the step's start moves the contact edge a
    /// node or two per iteration. The iterations end at a set that reproduces itself, and its
    /// solve is the same arithmetic whichever set they started from.
    pub fn start_from_sets(&mut self, sets: (Vec<bool>, Vec<FrictionStatus>)) {
        self.start_sets = Some(sets);
    }

    /// Interface stiffness of the last converged step (see [`GapSensitivity`]); `None` without
    /// interface condensation or before a step converged.
    pub fn gap_sensitivity(&self) -> Option<GapSensitivity> {
        let (active, status) = self.last_sets.as_ref()?;
        self.condensed.as_ref()?.gap_sensitivity(self.model, self.disc, active, status, false)
    }

    /// [`Self::gap_sensitivity`] times the gap changes `dg(k)` of the rows in contact, in one
    /// solve: those rows and their multiplier change. `None` as [`Self::gap_sensitivity`].
    pub fn gap_response(&self, dg: &dyn Fn(usize) -> f64) -> Option<(Vec<usize>, Vec<f64>)> {
        let (active, status) = self.last_sets.as_ref()?;
        self.condensed.as_ref()?.gap_response(self.model, self.disc, active, status, dg)
    }

    /// [`Self::gap_sensitivity`] on the rows in contact and the open candidate rows around
    /// them, each held at its gap (what a wear jump needs to let the contact set change).
    pub fn gap_sensitivity_with_open_rows(&self) -> Option<GapSensitivity> {
        let (active, status) = self.last_sets.as_ref()?;
        self.condensed.as_ref()?.gap_sensitivity(self.model, self.disc, active, status, true)
    }

    /// Reactions at constrained DOFs of the current state, zero elsewhere.
    pub fn reactions(&self, state: &SimState) -> Vec<f64> {
        self.disc.reactions(self.model, state)
    }
}
