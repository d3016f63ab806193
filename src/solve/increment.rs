//! Step control of a finite-sliding increment of a wear cycle: solved whole, or, if that solve
//! fails in a way a shorter step can avoid or its sweep cannot be trusted (see
//! [`crate::wear::sweep_check`]), solved again from its start in sub-steps, each re-paired.
//! The increment is what the case records; how it was cut is the solver's business (reported
//! in the log and the step's `sub_steps`).

use super::{AnalysisError, SolvedStep, StepRequest, StepSolver};
use crate::state::SimState;
use crate::wear::{SweepCheck, MAX_SUB_STEPS};

/// A finite-sliding increment solved: the sub-steps before its end (none when solved whole),
/// each with the displacements and multipliers it ended at, then its end (which the state holds).
pub struct SolvedIncrement {
    pub sub_steps: Vec<SubStep>,
    pub last: SolvedStep,
}

/// A sub-step of an increment and where it ended.
pub struct SubStep {
    pub solved: SolvedStep,
    pub u: Vec<f64>,
    pub multipliers: Vec<f64>,
}

/// Share of an increment below which what is left of it after a piece joins that piece.
const SUB_STEP_MERGE: f64 = 1e-6;

/// What the solve of a piece came to.
enum Trial {
    Accepted(Box<SolvedStep>),
    /// Converged, but its sweep cannot be trusted: the piece is to be cut.
    Cut(SweepCheck),
}

/// Why an increment was cut.
enum StepCut {
    Sweep(SweepCheck),
    Failed(AnalysisError),
}

impl std::fmt::Display for StepCut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepCut::Sweep(c) => write!(
                f,
                "the pressure field changed by {:.0}% of the load while sliding {:.3e}, {:.1} contact widths",
                100.0 * c.change,
                c.slide,
                c.slide / c.width.max(f64::MIN_POSITIVE)
            ),
            StepCut::Failed(e) => write!(f, "{e}"),
        }
    }
}

impl StepSolver<'_> {
    /// Solves the increment `request` (to `request.time`) of a finite-sliding wear cycle from
    /// the state (see the module documentation). A sweep that cannot be trusted splits the
    /// increment evenly into pieces sliding at most [`crate::wear::SWEEP_WIDTH_FRACTION`] of
    /// the contact's width; a failure a shorter step may avoid halves the piece (down to `1 /`
    /// [`MAX_SUB_STEPS`] of the increment), and an accepted piece after a failure lets the next
    /// be twice as long, up to the split's length. Each sub-step is paired first where the
    /// displacements, moving as fast as over the last piece (or the whole increment's solve),
    /// would end it: a sliding contact's pairing then settles in one or two re-pairings
    /// instead of three or four.
    pub fn solve_increment(
        &mut self,
        state: &mut SimState,
        request: StepRequest,
    ) -> Result<SolvedIncrement, AnalysisError> {
        let (step, end, sensitivity) = (request.step, request.time, request.sensitivity);
        let t_start = state.time;
        let cause = match self.solve_piece(state, request, true) {
            Ok(Trial::Accepted(last)) => return Ok(SolvedIncrement { sub_steps: vec![], last: *last }),
            Ok(Trial::Cut(check)) => StepCut::Sweep(check),
            Err(e) if e.shorter_step_may_help() => StepCut::Failed(e),
            Err(e) => return Err(e),
        };
        // The whole increment's solve is dropped; a converged one tells how fast the
        // displacements move along it.
        let whole_u = matches!(cause, StepCut::Sweep(_)).then(|| state.u.clone());
        self.undo(state);
        let length = end - t_start;
        let rate = whole_u.map(|e| e.iter().zip(&state.u).map(|(e, s)| (e - s) / length).collect());
        tracing::debug!(step, time = end, cause = %cause, "increment cut into sub-steps");
        let base = StepRequest { step, time: end, sensitivity, ..Default::default() };
        self.sub_stepped(state, base, t_start, cause, rate)
    }

    /// The increment `base` (to `base.time`) solved from its start (time `t_start`) in
    /// sub-steps (see [`Self::solve_increment`]).
    fn sub_stepped(
        &mut self,
        state: &mut SimState,
        base: StepRequest,
        t_start: f64,
        cause: StepCut,
        mut rate: Option<Vec<f64>>,
    ) -> Result<SolvedIncrement, AnalysisError> {
        let (step, t_end) = (base.step, base.time);
        let length = t_end - t_start;
        let shortest = length / MAX_SUB_STEPS as f64;
        let split = match &cause {
            StepCut::Sweep(check) => check.pieces().clamp(2, MAX_SUB_STEPS),
            StepCut::Failed(_) => 2,
        };
        let longest = length / split as f64;
        // Pieces sized by the sweep are not checked again (their slide is the split's).
        let check_sweep = matches!(cause, StepCut::Failed(_));
        let (mut t, mut dt, mut cut) = (t_start, longest, cause);
        let mut sub_steps: Vec<SubStep> = vec![];
        loop {
            dt = dt.min(t_end - t);
            // A piece ending within a millionth of the increment of its end is its end (at a
            // time of 2.4e5 the pieces' sums leave remainders of 1e-10, whose solve is all
            // round-off: a run of 10^6 cycles once failed on one).
            let last = t + dt >= t_end - SUB_STEP_MERGE * length;
            let end = if last { t_end } else { t + dt };
            let may_cut = dt > shortest * (1.0 + 1e-9);
            let guess: Option<Vec<f64>> =
                rate.as_ref().map(|r| state.u.iter().zip(r).map(|(u, r)| u + r * (end - t)).collect());
            let u_start = rate.is_some().then(|| state.u.clone());
            let request = StepRequest { time: end, pairing_guess: guess.as_deref(), ..base.clone() };
            match self.solve_piece(state, request, check_sweep && may_cut) {
                Ok(Trial::Accepted(mut solved)) => {
                    if let Some(u0) = u_start {
                        rate = Some(state.u.iter().zip(&u0).map(|(u, u0)| (u - u0) / (end - t)).collect());
                    }
                    t = end;
                    dt = (2.0 * dt).min(longest);
                    if last {
                        let pieces = sub_steps.len() + 1;
                        solved.report.sub_steps = pieces;
                        if pieces > 1 {
                            tracing::info!(step, time = t_end, sub_steps = pieces, cause = %cut, "increment solved in sub-steps");
                        }
                        return Ok(SolvedIncrement { sub_steps, last: *solved });
                    }
                    let (u, multipliers) = (state.u.clone(), state.multipliers.clone());
                    sub_steps.push(SubStep { solved: *solved, u, multipliers });
                    continue;
                }
                Ok(Trial::Cut(check)) => cut = StepCut::Sweep(check),
                Err(e) if e.shorter_step_may_help() && may_cut => cut = StepCut::Failed(e),
                Err(e) => {
                    let (pieces, source) = (sub_steps.len() + 1, Box::new(e));
                    return Err(AnalysisError::IncrementCut { step, time: end, pieces, length: dt, source });
                }
            }
            tracing::debug!(step, time = end, cause = %cut, "sub-step halved");
            self.undo(state);
            dt *= 0.5;
        }
    }

    /// Solves one piece of an increment (the whole or a sub-step) from the state; with
    /// `check_sweep`, a converged piece whose sweep cannot be trusted is left to be cut.
    fn solve_piece(
        &mut self,
        state: &mut SimState,
        request: StepRequest,
        check_sweep: bool,
    ) -> Result<Trial, AnalysisError> {
        let solved = self.solve(state, request)?;
        if check_sweep {
            let path = crate::wear::StepPath {
                u_prev: &solved.start_u,
                u: &state.u,
                lambda_prev: Some(&solved.start_multipliers),
                multipliers: &state.multipliers,
            };
            if let Some(check) = crate::wear::sweep_check(&solved.disc.contact, path).filter(|c| !c.acceptable()) {
                return Ok(Trial::Cut(check));
            }
        }
        Ok(Trial::Accepted(Box::new(solved)))
    }
}
