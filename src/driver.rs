//! The run driver: every run, resume and wear loop goes through [`run`].
//!
//! ```text
//! for each remaining output step k (time t_k):
//!     moving surfaces: move them to their position at t_k and re-cut (fixed points)
//!     solve the step (see crate::solve)
//!     hand the converged state and the step's discretisation to the observer (output)
//! ```
//!
//! A wear run ([`WearRun`]) goes through the cycles instead (see [`crate::wear`]). The solver
//! ([`StepSolver`]) owns the geometry of the moment and whatever it keeps between steps; a
//! resume needs nothing but the model and the checkpointed state: surface positions follow
//! from the time and the wear state, pairings from `u`, and the interface rows grown on the
//! geometry of the moment are replayed from the state's interface log, so that the
//! continuation is bit for bit the uninterrupted run.

use crate::model::{Discretisation, Model};
use crate::solve::{AnalysisError, SolvedIncrement, SolvedStep, StepReport, StepRequest, StepSolver};
use crate::state::{SimState, WearState};
use crate::wear::{accumulate_step_wear, apply_cycle_wear, cycle_plasticity, plastic_snapshot, JumpScheme, StepPath};

pub use crate::solve::{ObserverError, RunOptions, RunTimings};

/// Runs every remaining output step of `model` from `state` (a fresh initial state or a
/// checkpoint), calling `observer` with each converged step, its state, the model and the
/// step's discretisation (current surfaces, pairing and DOF map). An observer error stops the
/// run.
pub fn run<F>(model: &Model, state: &mut SimState, options: RunOptions, observer: F) -> Result<(), AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), ObserverError>,
{
    run_timed(model, state, options, observer).map(|_| ())
}

/// [`run`], returning where the time went.
pub fn run_timed<F>(
    model: &Model,
    state: &mut SimState,
    options: RunOptions,
    mut observer: F,
) -> Result<RunTimings, AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), ObserverError>,
{
    let solver = StepSolver::new(model, options);
    if !model.wear.is_empty() {
        let mut run = WearRun { model, solver, wear_time: 0.0, observer };
        run.run(state)?;
        return Ok(RunTimings { wear: run.wear_time, ..run.solver.timings() });
    }
    let mut solver = solver;
    let moving = model.has_moving_surfaces();
    for (k, &time) in model.times.iter().enumerate().skip(state.step) {
        let step = k + 1;
        if moving {
            let recut = solver.geometry_mut().place_surfaces(model, time).map_err(|source| AnalysisError::Surface {
                step,
                time,
                source,
            })?;
            solver.geometry().sync_ghost_births(model, &mut state.ghost, &state.u, &state.history);
            tracing::debug!(step, moved = recut.moved, cut_by_degree = ?recut.cut_cells_by_degree, held = recut.held_dofs, "surfaces re-cut");
        }
        let solved = solver.solve(state, StepRequest { step, time, last_on_geometry: moving, ..Default::default() })?;
        observe(&mut observer, &solved.report, state, model, &solved.disc)?;
    }
    Ok(solver.timings())
}

/// Hands a converged step to the observer; its error stops the run.
fn observe<F>(
    observer: &mut F,
    report: &StepReport,
    state: &SimState,
    model: &Model,
    disc: &Discretisation,
) -> Result<(), AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), ObserverError>,
{
    observer(report, state, model, disc).map_err(|source| AnalysisError::Observer { step: report.step, source })
}

/// A wear run in progress: the model, the step solver (which owns the geometry of the
/// moment), the time spent on wear, and the observer.
struct WearRun<'m, F> {
    model: &'m Model,
    solver: StepSolver<'m>,
    wear_time: f64,
    observer: F,
}

impl<F> WearRun<'_, F>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), ObserverError>,
{
    /// The wear loop (see [`crate::wear`]):
    ///
    /// ```text
    /// ramp steps (before the cycle window): as any run, their wear applied once at the end
    /// while cycles done < cycles:
    ///     for each increment of the cycle:
    ///         solve the step; add its wear, swept along the step, on every wearing surface
    ///     jump dN = controller(wear rates); depth += dN * rate; move vertices inward; cycles += dN
    ///     place the worn surfaces (re-cut on fixed points, re-pair)
    /// ```
    ///
    /// Within a computed cycle the surfaces hold still, so an elastic small-sliding scene keeps
    /// one condensed solver for the whole cycle. A jump moves the state to the end of the
    /// jumped cycle: the load history is periodic, the state is the one the computed cycle
    /// ended with.
    fn run(&mut self, state: &mut SimState) -> Result<(), AnalysisError> {
        let Some(cycle) = self.model.cycle else {
            let (surface, msg) =
                (self.model.wear.surfaces[0].name.clone(), "wear needs a cyclic load ([steps] cycle)".into());
            return Err(crate::wear::WearError { cycle: 0, surface, msg }.into());
        };
        self.place_surfaces(state)?;
        let ramp_steps = self.model.times.len() - cycle.count * cycle.increments;
        if state.step < ramp_steps {
            self.ramp(state, ramp_steps, cycle.count as u64)?;
            self.place_surfaces(state)?;
        }
        let stops_at_initiation = self.model.fatigue.as_ref().is_some_and(|f| f.stop_at_initiation);
        while state.wear.cycle < cycle.count as u64 {
            if stops_at_initiation && state.fatigue.initiation.is_some() {
                break;
            }
            self.compute_cycle(state, cycle)?;
            self.place_surfaces(state)?;
        }
        Ok(())
    }

    /// The worn surfaces where the state has them, re-cut and re-paired (small sliding: in the
    /// reference geometry, with the pairing reach extended by the wear depth allowed).
    fn place_surfaces(&mut self, state: &mut SimState) -> Result<(), AnalysisError> {
        let t0 = std::time::Instant::now();
        let (step, time) = (state.step, state.time);
        self.solver
            .geometry_mut()
            .place_worn_surfaces(self.model, &state.wear)
            .map_err(|source| AnalysisError::Surface { step, time, source })?;
        self.solver.geometry().sync_ghost_births(self.model, &mut state.ghost, &state.u, &state.history);
        self.wear_time += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// The steps before the cycle window, as any run (in the geometry's own pairing: the
    /// surfaces press together before they slide); their wear (sliding under the rising load)
    /// is applied once, at the ramp's end.
    fn ramp(&mut self, state: &mut SimState, ramp_steps: usize, count: u64) -> Result<(), AnalysisError> {
        let m = self.model;
        for k in state.step..ramp_steps {
            let last = k + 1 == ramp_steps;
            let request = StepRequest {
                step: k + 1,
                time: m.times[k],
                fixed_pairing: true,
                last_on_geometry: last,
                ..Default::default()
            };
            let solved = self.solver.solve(state, request)?;
            let scene = solved.disc.wear_scene(m);
            let path =
                StepPath { u_prev: &solved.start_u, u: &state.u, lambda_prev: None, multipliers: &state.multipliers };
            accumulate_step_wear(&scene, &mut state.wear, path, None);
            if last {
                apply_cycle_wear(&scene, &mut state.wear, count, false)?;
                if m.has_plasticity() {
                    state.wear.plastic_start = plastic_snapshot(&state.history);
                }
            }
            observe(&mut self.observer, &solved.report, state, m, &solved.disc)?;
        }
        Ok(())
    }

    /// The remaining increments of the current computed cycle, each solved and its wear
    /// integrated; the last one applies the cycle's wear with its jump.
    fn compute_cycle(&mut self, state: &mut SimState, cycle: crate::model::Cycle) -> Result<(), AnalysisError> {
        let n = state.wear.cycle;
        let increments = cycle.increments;
        state.wear.start_sets.resize(increments, Default::default());
        let finite = self.model.has_finite_sliding();
        if finite {
            state.wear.pairing_guess.resize(increments, vec![]);
        }
        for i in state.wear.increment..increments {
            let end = cycle.start + cycle.period * (n as f64 + (i + 1) as f64 / increments as f64);
            let inc = Increment { i, n, increments, step: state.step + 1, end };
            if finite {
                self.finite_increment(state, &inc)?;
            } else {
                let request = StepRequest {
                    start_sets: Some(std::mem::take(&mut state.wear.start_sets[i])),
                    last_on_geometry: i + 1 == increments,
                    ..self.request(&inc, inc.end)
                };
                let solved = self.solver.solve(state, request)?;
                state.wear.start_sets[i] = solved.sets.clone().unwrap_or_default();
                self.finish_increment(state, solved, &inc)?;
            }
        }
        Ok(())
    }

    /// The request of a piece of increment `inc` ending at `end`.
    fn request(&self, inc: &Increment, end: f64) -> StepRequest<'static> {
        let sensitivity = self.model.wear.scheme == JumpScheme::Implicit;
        StepRequest { step: inc.step, time: end, sensitivity, ..Default::default() }
    }

    /// Increment `inc` of a finite-sliding computed cycle, paired first where the last computed
    /// cycle ended it (a cycle later, or a jump later, the surfaces meet almost there; the next
    /// increment's guess lets the solver pair it ahead: the surfaces hold still until the
    /// cycle's end), solved whole or in sub-steps (see [`StepSolver::solve_increment`]); the
    /// wear of every sub-step is swept and added to the cycle's.
    fn finite_increment(&mut self, state: &mut SimState, inc: &Increment) -> Result<(), AnalysisError> {
        let i = inc.i;
        let guess = std::mem::take(&mut state.wear.pairing_guess[i]);
        let guess = (guess.len() == state.u.len()).then_some(guess);
        let next_guess = state.wear.pairing_guess.get(i + 1).filter(|g| g.len() == state.u.len()).cloned();
        let request = StepRequest {
            start_sets: Some(std::mem::take(&mut state.wear.start_sets[i])),
            pairing_guess: guess.as_deref(),
            next_guess: next_guess.as_deref(),
            ..self.request(inc, inc.end)
        };
        let SolvedIncrement { sub_steps, last } = self.solver.solve_increment(state, request)?;
        let t1 = std::time::Instant::now();
        for mut sub in sub_steps {
            accumulate_solved_wear(self.model, &mut sub.solved, &sub.u, &sub.multipliers, &mut state.wear);
        }
        self.wear_time += t1.elapsed().as_secs_f64();
        state.wear.pairing_guess[i].clone_from(&state.u);
        state.wear.start_sets[i] = last.sets.clone().unwrap_or_default();
        self.finish_increment(state, last, inc)
    }

    /// The wear of increment `inc` that just converged, and at the cycle's last increment the
    /// cycle's wear applied with its jump; then the observer.
    fn finish_increment(
        &mut self,
        state: &mut SimState,
        mut solved: SolvedStep,
        inc: &Increment,
    ) -> Result<(), AnalysisError> {
        let t1 = std::time::Instant::now();
        let m = self.model;
        solved.report.cycle = inc.n as usize + 1;
        solved.report.increment = inc.i + 1;
        accumulate_solved_wear(m, &mut solved, &state.u, &state.multipliers, &mut state.wear);
        let wear = &mut state.wear;
        if wear.cycle_jumps.len() == wear.cycle_steps {
            if let Some(last) = wear.cycle_jumps.last_mut() {
                last.increment_end = true;
            }
        }
        if let Some(fatigue) = &m.fatigue {
            fatigue.record(&state.u, &mut state.fatigue.history);
        }
        state.wear.increment = inc.i + 1;
        if inc.i + 1 == inc.increments {
            close_cycle(m, &solved.disc, state)?;
        }
        self.wear_time += t1.elapsed().as_secs_f64();
        observe(&mut self.observer, &solved.report, state, m, &solved.disc)
    }
}

/// The end of a computed cycle: its wear applied with its jump, and the fatigue damage of the
/// cycle and the jump (see [`crate::fatigue::FatigueModel::close_cycle`]).
fn close_cycle(m: &Model, disc: &Discretisation, state: &mut SimState) -> Result<(), AnalysisError> {
    let count = m.cycle.map_or(1, |c| c.count as u64);
    if m.has_plasticity() {
        (state.wear.cycle_ratcheting, state.wear.cycle_plastic_strain) =
            cycle_plasticity(&state.wear.plastic_start, &state.history);
    }
    let done_before = state.wear.cycle as f64 + state.wear.cycle_fraction;
    apply_cycle_wear(&disc.wear_scene(m), &mut state.wear, count, true)?;
    if let Some(fatigue) = &m.fatigue {
        // The worn surfaces of the fatigue body.
        let worn: Vec<&[[f64; 2]]> = m
            .wear
            .surfaces
            .iter()
            .zip(&state.wear.vertices)
            .filter(|(ws, _)| disc.surfaces[ws.surface].body == fatigue.body_index)
            .map(|(_, v)| v.as_slice())
            .collect();
        // Cycles of damage: the jump's, or the part of a cycle whose wear this pass applied.
        let done = state.wear.cycle as f64 + state.wear.cycle_fraction;
        fatigue
            .close_cycle(&mut state.fatigue, done, done - done_before, &worn)
            .map_err(|source| AnalysisError::Fatigue { cycle: state.wear.cycle, source })?;
    }
    if m.has_plasticity() {
        state.wear.plastic_start = plastic_snapshot(&state.history);
    }
    if let Some(c) = m.cycle {
        state.time = c.start + c.period * state.wear.cycle as f64;
    }
    Ok(())
}

/// Adds the wear of a solved step (from its start to the displacements `u` and multipliers
/// `multipliers` it ended at) to the cycle's, with its linearisation for the implicit update.
fn accumulate_solved_wear(m: &Model, solved: &mut SolvedStep, u: &[f64], multipliers: &[f64], wear: &mut WearState) {
    let scene = solved.disc.wear_scene(m);
    let path = StepPath { u_prev: &solved.start_u, u, lambda_prev: Some(&solved.start_multipliers), multipliers };
    accumulate_step_wear(&scene, wear, path, solved.sensitivity.take());
}

/// One increment of a computed cycle: its index `i` in cycle `n` (of `increments`), the
/// output step it records and its end time.
struct Increment {
    i: usize,
    n: u64,
    increments: usize,
    step: usize,
    end: f64,
}
