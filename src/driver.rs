//! The run driver: every run, resume and (next) wear loop goes through [`run`].
//!
//! ```text
//! for each remaining output step k (time t_k, cycle c, increment i):
//!     move the virtual surfaces to their position at t_k and re-cut (fixed points)
//!     re-pair finite-sliding contact pairs in the converged configuration
//!     solve the step (condensed interface solve for elastic contact, Newton otherwise)
//!     hand the converged state and the step's discretisation to the observer (output)
//! ```
//!
//! A model whose discretisation never changes (no moving surface, no finite sliding) sets its
//! solver up once: pattern, symbolic and numeric factorisations are reused for the whole run
//! and a resume replays the interface log so that the continuation is bit for bit the
//! uninterrupted run. Otherwise the step's model is derived from the immutable base model
//! and the state alone (surface positions from the time, pairings from `u`), so a resume from
//! any checkpoint needs nothing else.

use crate::analysis::{AnalysisError, StaticAnalysis, StepReport};
use crate::model::Model;
use crate::state::SimState;

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

/// Runs every remaining output step of `model` from `state` (a fresh initial state or a
/// checkpoint), calling `observer` with each converged step, its state and the model of the
/// step (current surfaces, pairing and DOF map). An observer error stops the run.
pub fn run<F>(model: &Model, state: &mut SimState, options: RunOptions, mut observer: F) -> Result<(), AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model) -> Result<(), String>,
{
    if !model.has_moving_surfaces() && !model.has_finite_sliding() {
        let mut analysis = StaticAnalysis::new(model)?;
        analysis.set_parallel(options.parallel);
        analysis.resume(state)?;
        return analysis.run(state, |r, s| observer(r, s, model));
    }
    let mut current = model.clone();
    for (k, &t) in model.times.iter().enumerate().skip(state.step) {
        let step = k + 1;
        if current.has_moving_surfaces() {
            let recut = current.place_surfaces(t).map_err(|source| AnalysisError::Surface { step, time: t, source })?;
            tracing::debug!(step, moved = recut.moved, cut_by_degree = ?recut.cut_cells_by_degree, held = recut.held_dofs, "surfaces re-cut");
        }
        let repaired;
        let step_model = if current.has_finite_sliding() {
            repaired = current.repaired(&state.u);
            &repaired
        } else {
            &current
        };
        let mut analysis = StaticAnalysis::new(step_model)?;
        analysis.set_parallel(options.parallel);
        let report = analysis.advance_to(state, step, t)?;
        // The interface log of a per-step operator means nothing to the next step.
        state.interface_log.clear();
        observer(&report, state, step_model).map_err(|msg| AnalysisError::Observer { step, msg })?;
    }
    Ok(())
}
