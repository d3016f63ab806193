//! Solving one step: [`StepSolver::solve`] takes the state and a [`StepRequest`] (output step,
//! time, where the contact iteration and the pairing start) and returns a [`SolvedStep`], the
//! converged state written into the state and everything a caller reads afterwards.
//!
//! ```text
//! solve(step k to time t):
//!     small sliding: the analysis set up on the geometry of the moment (kept while the
//!         geometry holds still: its factor and grown interface rows serve the next steps)
//!         advance to t (load stepping with cut-backs; condensed active-set iteration for
//!         contact between elastic bodies, monolithic Newton otherwise)
//!     finite sliding: a fixed point on the pairing (see `pairing`): pair the surfaces at a
//!         guess of the step's end, solve, re-pair at the solution, until the pressures settle
//! ```
//!
//! The solver owns the geometry of the moment ([`Discretisation`]): moving it
//! ([`StepSolver::geometry_mut`]) ends what was set up on it. Nothing outside this room needs
//! to know that a factor is kept, an interface set grown or a pairing prepared ahead.
//!
//! Files: `analysis` (set-up, load stepping, commit), `analysis/newton` (monolithic Newton),
//! `analysis/active_set` (condensed active-set iteration), `analysis/condensed` (the
//! interface operator), `pairing` (finite sliding's fixed point), `increment` (a wear
//! increment solved whole or cut into sub-steps), `start` (a step's start, saved for
//! re-pairings and cuts).

pub use crate::contact::ContactSets;
use crate::model::{Discretisation, Model};
use crate::state::SimState;
use std::sync::Arc;

mod analysis;
mod increment;
mod pairing;
mod start;

pub use analysis::{
    AnalysisError, FrictionStatus, GapSensitivity, NewtonSystem, ObserverError, PreparedRows, SolverReuse,
    StaticAnalysis, StepReport,
};
pub use increment::{SolvedIncrement, SubStep};
pub use pairing::{MAX_PAIRINGS, PAIRING_TOLERANCE};

/// Options of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunOptions {
    /// Parallel element loop (bit-identical to the serial one).
    pub parallel: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions { parallel: true }
    }
}

/// Where a run spent its time (seconds; the observer's time, e.g. output, not included).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunTimings {
    /// Solver set-up per surface position: assembly, factorisation, interface operator.
    pub setup: f64,
    /// Finite sliding: the pairings of each increment (its own, and the one at its solution
    /// that estimates whether it settled) and the interface operator of each pairing on a
    /// bulk already factored.
    pub repairing: f64,
    /// The pairings alone (the geometry: mortar integrals of the rows), part of `repairing`.
    pub pairings: f64,
    /// Contact solves of the increments.
    pub solve: f64,
    /// Wear: step integrals, cycle update with its jump, surface move, re-cut and re-pairing
    /// (filled in by the wear loop).
    pub wear: f64,
    /// Condensed solver set-ups, and how many of them reused the previous set-up's pattern and
    /// symbolic factorisation (numeric refactorisation only).
    pub setups: usize,
    pub reused_setups: usize,
}

impl RunTimings {
    fn count_setup(&mut self, analysis: &StaticAnalysis) {
        self.setups += 1;
        self.reused_setups += usize::from(analysis.structure_reused());
    }
}

/// What to solve: output step `step` to time `time`, and where the iterations start.
#[derive(Debug, Clone, Default)]
pub struct StepRequest<'a> {
    pub step: usize,
    pub time: f64,
    /// Contact sets the first interface iteration starts from (`None`: the augmented-Lagrangian
    /// prediction from the start of the step).
    pub start_sets: Option<ContactSets>,
    /// Finite sliding: the surfaces are paired first at this guess of the step's end
    /// displacements (`None`: at its start).
    pub pairing_guess: Option<&'a [f64]>,
    /// Finite sliding: the next step's guess; its first pairing (and interface rows) are formed
    /// beside this step's if this step settles at its first solution.
    pub next_guess: Option<&'a [f64]>,
    /// Finite sliding: solve in the geometry's own pairing instead of the step's end
    /// configuration (the ramp of a wear run, which presses the surfaces together before they
    /// slide).
    pub fixed_pairing: bool,
    /// Whether the caller reads the interface sensitivity of the converged step.
    pub sensitivity: bool,
    /// The geometry moves after this step: the interface rows it grew end with it and leave the
    /// state (a checkpoint of it must not replay them on the next geometry).
    pub last_on_geometry: bool,
}

/// A converged step: the state holds its end; this holds what a caller reads besides.
pub struct SolvedStep {
    pub report: StepReport,
    /// The discretisation the step was solved on (finite sliding: the pairing of its end).
    pub disc: Arc<Discretisation>,
    /// Displacements and multipliers at the step's start.
    pub start_u: Vec<f64>,
    pub start_multipliers: Vec<f64>,
    /// Converged contact and friction sets (condensed solves).
    pub sets: Option<ContactSets>,
    /// The interface sensitivity `dp/dg` of the converged step (when asked for and the solve
    /// condenses the interface).
    pub sensitivity: Option<GapSensitivity>,
}

/// The solver of a run's steps (see the module documentation).
pub struct StepSolver<'m> {
    model: &'m Model,
    options: RunOptions,
    /// The geometry of the moment.
    geometry: Arc<Discretisation>,
    /// Small sliding: the analysis set up on `geometry`, kept while it holds still.
    live: Option<StaticAnalysis<'m>>,
    /// The solver structure handed from one set-up to the next.
    reuse: Option<SolverReuse>,
    /// Whether a solve on the current geometry set its bulk up (a re-pairing keeps it).
    bulk_set_up: bool,
    /// A finite-sliding step's start (refilled step after step, not reallocated).
    start: start::StepStart,
    /// Finite sliding: the next step's first pairing, formed beside the last step's check, with
    /// its interface rows when they could be formed on the last step's factor.
    ahead: Option<Ahead>,
    timings: RunTimings,
}

impl<'m> StepSolver<'m> {
    /// A solver on the model's initial geometry.
    pub fn new(model: &'m Model, options: RunOptions) -> Self {
        StepSolver {
            model,
            options,
            geometry: model.initial_shared(),
            live: None,
            reuse: None,
            bulk_set_up: false,
            start: Default::default(),
            ahead: None,
            timings: RunTimings::default(),
        }
    }

    /// The geometry of the moment.
    pub fn geometry(&self) -> &Discretisation {
        &self.geometry
    }

    /// The geometry, to move its surfaces: what was set up on it ends here (its structure is
    /// handed to the next set-up).
    pub fn geometry_mut(&mut self) -> &mut Discretisation {
        self.release();
        self.bulk_set_up = false;
        Arc::make_mut(&mut self.geometry)
    }

    /// Where the solves spent their time.
    pub fn timings(&self) -> RunTimings {
        self.timings
    }

    /// Hands the live analysis's structure on to the next set-up.
    fn release(&mut self) {
        if let Some(analysis) = self.live.take() {
            self.reuse = analysis.into_reuse();
        }
    }

    /// Solves `request` from the state (see the module documentation). On success the state
    /// holds the step's end; a finite-sliding step that fails leaves the state at its start.
    pub fn solve(&mut self, state: &mut SimState, request: StepRequest) -> Result<SolvedStep, AnalysisError> {
        if self.model.has_finite_sliding() && !request.fixed_pairing {
            return self.solve_paired(state, request);
        }
        let t0 = std::time::Instant::now();
        let analysis = match self.live.take() {
            Some(analysis) => analysis,
            None => {
                let mut analysis =
                    StaticAnalysis::with_reuse(self.model, Arc::clone(&self.geometry), self.reuse.take())?;
                analysis.set_parallel(self.options.parallel);
                analysis.resume(state)?;
                self.timings.setup += t0.elapsed().as_secs_f64();
                self.timings.count_setup(&analysis);
                analysis
            }
        };
        let analysis = self.live.insert(analysis);
        let (start_u, start_multipliers) = (state.u.clone(), state.multipliers.clone());
        if let Some(sets) = request.start_sets {
            analysis.start_from_sets(sets);
        }
        let t1 = std::time::Instant::now();
        let report = analysis.advance_to(state, request.step, request.time)?;
        self.timings.solve += t1.elapsed().as_secs_f64();
        let sensitivity = if request.sensitivity { analysis.gap_sensitivity_with_open_rows() } else { None };
        let sets = analysis.converged_sets().cloned();
        if request.last_on_geometry {
            state.interface_log.clear();
        }
        let disc = Arc::clone(&self.geometry);
        Ok(SolvedStep { report, disc, start_u, start_multipliers, sets, sensitivity })
    }

    /// Puts the state back where the last solve started and drops what was formed ahead for
    /// the step after it (finite sliding: a step the caller does not take, e.g. to cut it).
    pub fn undo(&mut self, state: &mut SimState) {
        self.start.restore(state);
        self.ahead = None;
    }
}

/// Finite sliding: the next step's first pairing, formed beside the last step's check, and its
/// interface rows when they could be formed on the last step's factor.
struct Ahead {
    pairing: Discretisation,
    rows: Option<PreparedRows>,
}
