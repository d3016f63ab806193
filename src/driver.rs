//! The run driver: every run, resume and wear loop goes through [`run`].
//!
//! ```text
//! for each remaining output step k (time t_k, cycle c, increment i):
//!     move the virtual surfaces to their position at t_k and re-cut (fixed points)
//!     solve the step (condensed interface solve for contact, Newton otherwise);
//!     finite sliding: in the pairing of the step's own end configuration (a fixed point,
//!     see `solve_paired_step`)
//!     hand the converged state and the step's discretisation to the observer (output)
//! ```
//!
//! A model whose discretisation never changes (no moving surface, no finite sliding) sets its
//! solver up once: pattern, symbolic and numeric factorisations are reused for the whole run
//! and a resume replays the interface log so that the continuation is bit for bit the
//! uninterrupted run. Otherwise the step's model is derived from the immutable base model
//! and the state alone (surface positions from the time, pairings from `u`), so a resume from
//! any checkpoint needs nothing else.

use crate::analysis::{AnalysisError, PreparedRows, StaticAnalysis, StepReport};
use crate::contact::FrictionStatus;
use crate::model::{Discretisation, Model};
use crate::state::SimState;
use crate::wear::{accumulate_step_wear, apply_cycle_wear, cycle_plasticity, plastic_snapshot, JumpScheme};

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

/// Where a wear run spent its time (seconds; the observer's time, e.g. output, not included).
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
    /// Wear: step integrals, cycle update with its jump, surface move, re-cut and re-pairing.
    pub wear: f64,
    /// Condensed solver set-ups, and how many of them reused the previous model's pattern and
    /// symbolic factorisation (numeric refactorisation only).
    pub setups: usize,
    pub reused_setups: usize,
}

impl RunTimings {
    fn add(&mut self, o: &RunTimings) {
        self.setup += o.setup;
        self.repairing += o.repairing;
        self.pairings += o.pairings;
        self.solve += o.solve;
        self.wear += o.wear;
        self.setups += o.setups;
        self.reused_setups += o.reused_setups;
    }
    fn count_setup(&mut self, analysis: &StaticAnalysis) {
        self.setups += 1;
        self.reused_setups += usize::from(analysis.structure_reused());
    }
}

/// Runs every remaining output step of `model` from `state` (a fresh initial state or a
/// checkpoint), calling `observer` with each converged step, its state, the model and the
/// step's discretisation (current surfaces, pairing and DOF map). An observer error stops the
/// run.
pub fn run<F>(model: &Model, state: &mut SimState, options: RunOptions, observer: F) -> Result<(), AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), String>,
{
    run_timed(model, state, options, observer).map(|_| ())
}

/// [`run`], returning where the time went (filled in for wear runs).
pub fn run_timed<F>(
    model: &Model,
    state: &mut SimState,
    options: RunOptions,
    mut observer: F,
) -> Result<RunTimings, AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), String>,
{
    if !model.wear.is_empty() {
        return run_wear(model, state, options, observer);
    }
    if !model.has_moving_surfaces() && !model.has_finite_sliding() {
        let mut analysis = StaticAnalysis::new(model)?;
        analysis.set_parallel(options.parallel);
        analysis.resume(state)?;
        return analysis.run(state, |r, s| observer(r, s, model, model.initial())).map(|_| RunTimings::default());
    }
    let mut current = model.initial().clone();
    let mut reuse = None;
    let mut backup = StepStart::default();
    let first = state.step;
    for (k, &t) in model.times.iter().enumerate().skip(first) {
        let step = k + 1;
        if model.has_moving_surfaces() {
            let recut =
                current.place_surfaces(model, t).map_err(|source| AnalysisError::Surface { step, time: t, source })?;
            current.sync_ghost_births(model, &mut state.ghost, &state.u, &state.history);
            tracing::debug!(step, moved = recut.moved, cut_by_degree = ?recut.cut_cells_by_degree, held = recut.held_dofs, "surfaces re-cut");
        }
        if model.has_finite_sliding() {
            // Without moving surfaces every step has the bulk the first one set up.
            let at_rest = !model.has_moving_surfaces();
            let (same_bulk, mut timings) = (at_rest && k > first, RunTimings::default());
            solve_paired_step(
                model,
                &current,
                (state, &mut backup),
                &mut reuse,
                same_bulk,
                at_rest,
                PairingStart::default(),
                step,
                t,
                options,
                &mut timings,
                |d, _, s, r, _| observer(&r, s, model, d).map_err(|msg| AnalysisError::Observer { step, msg }),
            )?;
            continue;
        }
        let mut analysis = StaticAnalysis::with_reuse(model, &current, reuse.take())?;
        analysis.set_parallel(options.parallel);
        let report = analysis.advance_to(state, step, t)?;
        reuse = analysis.into_reuse();
        // The interface log of a per-step operator means nothing to the next step.
        state.interface_log.clear();
        observer(&report, state, model, &current).map_err(|msg| AnalysisError::Observer { step, msg })?;
    }
    Ok(RunTimings::default())
}

/// The wear loop (see [`crate::wear`]):
///
/// ```text
/// ramp steps (before the cycle window): as any run, their wear applied once at the end
/// while cycles done < cycles:
///     for each increment of the cycle:
///         solve the step (finite sliding: in its own end configuration's pairing)
///         add its wear, swept along the step, on every wearing surface
///     jump dN = controller(wear rates); depth += dN * rate; move vertices inward; cycles += dN
///     place the worn surfaces (re-cut on fixed points, re-pair)
/// ```
///
/// Within a computed cycle the surfaces hold still, so an elastic small-sliding scene keeps
/// one condensed solver for the whole cycle (a resume mid-cycle replays its interface log). A
/// jump moves the state to the end of the jumped cycle: the load history is periodic, the
/// state is the one the computed cycle ended with.
fn run_wear<F>(
    model: &Model,
    state: &mut SimState,
    options: RunOptions,
    observer: F,
) -> Result<RunTimings, AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), String>,
{
    let Some(cycle) = model.cycle else {
        let (surface, msg) = (model.wear.surfaces[0].name.clone(), "wear needs a cyclic load ([steps] cycle)".into());
        return Err(crate::wear::WearError { cycle: 0, surface, msg }.into());
    };
    let current = model.initial().clone();
    let backup = StepStart::default();
    let mut run = WearRun { model, current, reuse: None, backup, options, timings: RunTimings::default(), observer };
    run.place_surfaces(state)?;
    let ramp_steps = model.times.len() - cycle.count * cycle.increments;
    if state.step < ramp_steps {
        run.ramp(state, ramp_steps, cycle.count as u64)?;
        run.place_surfaces(state)?;
    }
    let stops_at_initiation = model.fatigue.as_ref().is_some_and(|f| f.stop_at_initiation);
    while state.wear.cycle < cycle.count as u64 {
        if stops_at_initiation && state.fatigue.initiation.is_some() {
            break;
        }
        run.compute_cycle(state, cycle)?;
        run.place_surfaces(state)?;
    }
    Ok(run.timings)
}

/// A wear run in progress: the model, the discretisation of the current surface positions, the
/// solver structure handed from one position to the next, where the time went, and the
/// observer.
struct WearRun<'m, F> {
    model: &'m Model,
    current: Discretisation,
    reuse: Option<crate::analysis::SolverReuse>,
    /// A finite-sliding step's start (kept between steps: refilled, not reallocated).
    backup: StepStart,
    options: RunOptions,
    timings: RunTimings,
    observer: F,
}

impl<F> WearRun<'_, F>
where
    F: FnMut(&StepReport, &SimState, &Model, &Discretisation) -> Result<(), String>,
{
    /// The worn surfaces where the state has them, re-cut and re-paired (small sliding: in the
    /// reference geometry, with the pairing reach extended by the wear depth allowed).
    fn place_surfaces(&mut self, state: &mut SimState) -> Result<(), AnalysisError> {
        let t0 = std::time::Instant::now();
        self.current.place_worn_surfaces(self.model, &state.wear).map_err(|source| AnalysisError::Surface {
            step: state.step,
            time: state.time,
            source,
        })?;
        self.current.sync_ghost_births(self.model, &mut state.ghost, &state.u, &state.history);
        self.timings.wear += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// The steps before the cycle window, as any run; their wear (sliding under the rising
    /// load) is applied once, at the ramp's end.
    fn ramp(&mut self, state: &mut SimState, ramp_steps: usize, count: u64) -> Result<(), AnalysisError> {
        let (m, disc) = (self.model, &self.current);
        let mut analysis = StaticAnalysis::with_reuse(m, disc, self.reuse.take())?;
        analysis.set_parallel(self.options.parallel);
        analysis.resume(state)?;
        self.timings.count_setup(&analysis);
        for k in state.step..ramp_steps {
            let u_prev = state.u.clone();
            let report = analysis.advance_to(state, k + 1, m.times[k])?;
            let scene = disc.wear_scene(m);
            accumulate_step_wear(&scene, &mut state.wear, (&u_prev, &state.u), (None, &state.multipliers), None);
            if k + 1 == ramp_steps {
                apply_cycle_wear(&scene, &mut state.wear, count, false)?;
                if m.has_plasticity() {
                    state.wear.plastic_start = plastic_snapshot(&state.history);
                }
                state.interface_log.clear();
            }
            (self.observer)(&report, state, m, disc).map_err(|msg| AnalysisError::Observer { step: k + 1, msg })?;
        }
        self.reuse = analysis.into_reuse();
        Ok(())
    }

    /// The remaining increments of the current computed cycle, each solved and its wear
    /// integrated; the last one applies the cycle's wear with its jump.
    fn compute_cycle(&mut self, state: &mut SimState, cycle: crate::model::Cycle) -> Result<(), AnalysisError> {
        let n = state.wear.cycle;
        let step_time = |i: usize| cycle.start + cycle.period * (n as f64 + (i + 1) as f64 / cycle.increments as f64);
        let first = state.wear.increment;
        if self.model.has_finite_sliding() {
            state.wear.pairing_guess.resize(cycle.increments, vec![]);
            state.wear.start_sets.resize(cycle.increments, Default::default());
            // The first pairing of the next increment, formed beside this one's check, and
            // its interface rows, formed beside this one's wear and output.
            let mut ahead: Option<(Discretisation, Option<PreparedRows>)> = None;
            for i in first..cycle.increments {
                let (step, end, bulk_set_up) = (state.step + 1, step_time(i), i > first);
                let inc = Increment { i, n, increments: cycle.increments, step, end, bulk_set_up };
                self.finite_increment(state, &inc, &mut ahead)?;
            }
            return Ok(());
        }
        let Self { model, current, reuse, options, timings, observer, .. } = self;
        let model: &Model = model;
        let t0 = std::time::Instant::now();
        let mut analysis = StaticAnalysis::with_reuse(model, current, reuse.take())?;
        analysis.set_parallel(options.parallel);
        analysis.resume(state)?;
        timings.setup += t0.elapsed().as_secs_f64();
        timings.count_setup(&analysis);
        state.wear.start_sets.resize(cycle.increments, Default::default());
        for i in first..cycle.increments {
            let (u_prev, lambda_prev) = (state.u.clone(), state.multipliers.clone());
            let t1 = std::time::Instant::now();
            analysis.start_from_sets(std::mem::take(&mut state.wear.start_sets[i]));
            let report = analysis.advance_to(state, state.step + 1, step_time(i))?;
            state.wear.start_sets[i] = analysis.converged_sets().cloned().unwrap_or_default();
            timings.solve += t1.elapsed().as_secs_f64();
            let start = (u_prev.as_slice(), lambda_prev.as_slice());
            let (step, end) = (report.step, step_time(i));
            let inc = Increment { i, n, increments: cycle.increments, step, end, bulk_set_up: true };
            let report = integrate_step_wear((model, current), &analysis, state, start, report, &inc, timings)?;
            if i + 1 == cycle.increments {
                state.interface_log.clear();
            }
            observer(&report, state, model, current)
                .map_err(|msg| AnalysisError::Observer { step: report.step, msg })?;
        }
        *reuse = analysis.into_reuse();
        Ok(())
    }

    /// Increment `inc` of a finite-sliding computed cycle: solved whole, paired first where the
    /// last computed cycle ended it; if that solve fails in a way a shorter step can avoid, or
    /// its sweep cannot be trusted (see [`crate::wear::sweep_check`]), solved again from its
    /// start in sub-steps (see [`Self::sub_stepped_increment`]).
    fn finite_increment(
        &mut self,
        state: &mut SimState,
        inc: &Increment,
        ahead: &mut Option<(Discretisation, Option<PreparedRows>)>,
    ) -> Result<(), AnalysisError> {
        let i = inc.i;
        // First paired where the last computed cycle ended this increment: a cycle later (or
        // a jump later) the surfaces meet almost there.
        let guess = std::mem::take(&mut state.wear.pairing_guess[i]);
        let guess = (guess.len() == state.u.len()).then_some(guess);
        let sets = std::mem::take(&mut state.wear.start_sets[i]);
        // The next increment's guess (the surfaces hold still until the cycle's end).
        let next_guess = state.wear.pairing_guess.get(i + 1).filter(|g| g.len() == state.u.len()).cloned();
        let pairing_start = PairingStart {
            guess: guess.as_deref(),
            sets,
            first_pairing: ahead.take().filter(|_| guess.is_some()),
            next_guess: next_guess.as_deref(),
            ahead: Some(&mut *ahead),
        };
        let t_start = state.time;
        // The surfaces moved before the cycle's first increment: its set-up refactors.
        let piece = Piece { end: inc.end, last: true, check_sweep: true, pieces: 1, same_bulk: inc.bulk_set_up };
        let cause = match self.solve_piece(state, inc, piece, pairing_start) {
            Ok(Trial::Accepted) => return Ok(()),
            Ok(Trial::Cut(check)) => StepCut::Sweep(check),
            Err(e) if e.shorter_step_may_help() => StepCut::Failed(e),
            Err(e) => return Err(e),
        };
        // The whole increment's solve is dropped, with the pairing it formed for the next one;
        // a converged one tells how fast the displacements move along it.
        let whole_u = matches!(cause, StepCut::Sweep(_)).then(|| state.u.clone());
        self.backup.restore(state);
        *ahead = None;
        let length = inc.end - t_start;
        let rate = whole_u.map(|end| end.iter().zip(&state.u).map(|(e, s)| (e - s) / length).collect());
        self.sub_stepped_increment(state, inc, t_start, cause, rate)
    }

    /// Increment `inc` solved from its start (time `t_start`) in sub-steps, each re-paired
    /// from where the last one ended (first at the end the displacements' `rate`, per unit of
    /// time, predicts) and its wear swept and added to the cycle's. A sweep that
    /// cannot be trusted splits the increment evenly into pieces sliding at most
    /// [`crate::wear::SWEEP_WIDTH_FRACTION`] of the contact's width; a failure a shorter step
    /// may avoid halves the piece (down to `1 /` [`crate::wear::MAX_SUB_STEPS`] of the
    /// increment), and an accepted piece after a failure lets the next be twice as long, up
    /// to the split's length. Only the increment's end is handed to the observer (it is what
    /// the case records).
    fn sub_stepped_increment(
        &mut self,
        state: &mut SimState,
        inc: &Increment,
        t_start: f64,
        cause: StepCut,
        mut rate: Option<Vec<f64>>,
    ) -> Result<(), AnalysisError> {
        let length = inc.end - t_start;
        let shortest = length / crate::wear::MAX_SUB_STEPS as f64;
        tracing::debug!(step = inc.step, cycle = inc.n + 1, increment = inc.i + 1, cause = %cause, "increment cut into sub-steps");
        let split = match &cause {
            StepCut::Sweep(check) => check.pieces().clamp(2, crate::wear::MAX_SUB_STEPS),
            StepCut::Failed(_) => 2,
        };
        let longest = length / split as f64;
        // Pieces sized by the sweep are not checked again (their slide is the split's).
        let check_sweep = matches!(cause, StepCut::Failed(_));
        let (mut t, mut dt, mut pieces, mut cut) = (t_start, longest, 0usize, cause);
        while t < inc.end {
            dt = dt.min(inc.end - t);
            // A piece ending within a millionth of the increment of its end is its end (at a
            // time of 2.4e5 the pieces' sums leave remainders of 1e-10, whose solve is all
            // round-off: a run of 10^6 cycles once failed on one).
            let last = t + dt >= inc.end - SUB_STEP_MERGE * length;
            let end = if last { inc.end } else { t + dt };
            let may_cut = dt > shortest * (1.0 + 1e-9);
            // The whole increment was tried on this bulk: a structure handed on is its.
            let piece = Piece { end, last, check_sweep: check_sweep && may_cut, pieces: pieces + 1, same_bulk: true };
            // Paired first where the displacements, moving as fast as over the last piece (or
            // the whole increment's solve), would end this one: a sliding contact's pairing
            // then settles in one or two re-pairings instead of three or four.
            let guess: Option<Vec<f64>> =
                rate.as_ref().map(|r| state.u.iter().zip(r).map(|(u, r)| u + r * (end - t)).collect());
            let u_start = rate.is_some().then(|| state.u.clone());
            let pairing_start = PairingStart { guess: guess.as_deref(), ..PairingStart::default() };
            match self.solve_piece(state, inc, piece, pairing_start) {
                Ok(Trial::Accepted) => {
                    if let Some(u0) = u_start {
                        rate = Some(state.u.iter().zip(&u0).map(|(u, u0)| (u - u0) / (end - t)).collect());
                    }
                    (t, pieces) = (end, pieces + 1);
                    dt = (2.0 * dt).min(longest);
                    continue;
                }
                Ok(Trial::Cut(check)) => cut = StepCut::Sweep(check),
                Err(e) if e.shorter_step_may_help() && may_cut => cut = StepCut::Failed(e),
                Err(e) => {
                    return Err(AnalysisError::IncrementCut {
                        step: inc.step,
                        time: end,
                        pieces: pieces + 1,
                        length: dt,
                        source: Box::new(e),
                    })
                }
            }
            tracing::debug!(step = inc.step, time = end, cause = %cut, "sub-step halved");
            self.backup.restore(state);
            dt *= 0.5;
        }
        if pieces > 1 {
            tracing::info!(
                step = inc.step,
                cycle = inc.n + 1,
                increment = inc.i + 1,
                sub_steps = pieces,
                cause = %cut,
                "increment solved in sub-steps"
            );
        }
        Ok(())
    }

    /// Solves one piece of increment `inc` (the whole or a sub-step) from the state; hands
    /// the increment's end to the wear integration and the observer, or adds a sub-step's
    /// wear to the cycle's, unless the piece's sweep cannot be trusted and it may be cut.
    fn solve_piece(
        &mut self,
        state: &mut SimState,
        inc: &Increment,
        piece: Piece,
        pairing_start: PairingStart,
    ) -> Result<Trial, AnalysisError> {
        let Self { model, current, reuse, backup, options, timings, observer } = self;
        let model: &Model = model;
        let mut solve_timings = RunTimings::default();
        let out = solve_paired_step(
            model,
            current,
            (state, backup),
            reuse,
            piece.same_bulk,
            false,
            pairing_start,
            inc.step,
            piece.end,
            *options,
            &mut solve_timings,
            |disc, analysis, state, mut report, start| {
                if piece.check_sweep {
                    let check = crate::wear::sweep_check(
                        &disc.contact,
                        (&start.u, &state.u),
                        (&start.multipliers, &state.multipliers),
                    );
                    if let Some(check) = check.filter(|c| !c.acceptable()) {
                        return Ok(Trial::Cut(check));
                    }
                }
                let begin = (start.u.as_slice(), start.multipliers.as_slice());
                if !piece.last {
                    let t1 = std::time::Instant::now();
                    accumulate_sub_step_wear((model, disc), analysis, state, begin);
                    timings.wear += t1.elapsed().as_secs_f64();
                    return Ok(Trial::Accepted);
                }
                state.wear.pairing_guess[inc.i].clone_from(&state.u);
                state.wear.start_sets[inc.i] = analysis.converged_sets().cloned().unwrap_or_default();
                report.sub_steps = piece.pieces;
                let report = integrate_step_wear((model, disc), analysis, state, begin, report, inc, timings)?;
                observer(&report, state, model, disc)
                    .map_err(|msg| AnalysisError::Observer { step: report.step, msg })?;
                Ok(Trial::Accepted)
            },
        );
        timings.add(&solve_timings);
        out
    }
}

/// One increment of a computed cycle: its index `i` in cycle `n` (of `increments`), the
/// output step it records, its end time, and whether an increment before it in this pass set
/// the bulk up on the current surfaces.
struct Increment {
    i: usize,
    n: u64,
    increments: usize,
    step: usize,
    end: f64,
    bulk_set_up: bool,
}

/// Share of an increment below which what is left of it after a piece joins that piece.
const SUB_STEP_MERGE: f64 = 1e-6;

/// A piece of an increment being solved: where it ends, whether that is the increment's end,
/// whether its sweep is checked, its number among the pieces, and whether a solve before it
/// set the bulk up on the current surfaces.
#[derive(Clone, Copy)]
struct Piece {
    end: f64,
    last: bool,
    /// Whether a sweep that cannot be trusted cuts the piece.
    check_sweep: bool,
    pieces: usize,
    same_bulk: bool,
}

/// What the solve of a piece came to.
enum Trial {
    Accepted,
    /// Converged, but its sweep cannot be trusted: the piece is to be cut.
    Cut(crate::wear::SweepCheck),
}

/// Why an increment was cut.
enum StepCut {
    Sweep(crate::wear::SweepCheck),
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

/// The wear of increment `inc` that just converged (from the displacements and multipliers
/// `start`), and at the cycle's last increment the cycle's wear applied with its jump.
fn integrate_step_wear(
    (m, disc): (&Model, &Discretisation),
    analysis: &StaticAnalysis,
    state: &mut SimState,
    start: (&[f64], &[f64]),
    mut report: StepReport,
    inc: &Increment,
    timings: &mut RunTimings,
) -> Result<StepReport, AnalysisError> {
    let t1 = std::time::Instant::now();
    let Increment { i, n, increments, .. } = *inc;
    report.cycle = n as usize + 1;
    report.increment = i + 1;
    accumulate_sub_step_wear((m, disc), analysis, state, start);
    if let Some(fatigue) = &m.fatigue {
        fatigue.record(&state.u, &mut state.fatigue.history);
    }
    let scene = disc.wear_scene(m);
    state.wear.increment = i + 1;
    if i + 1 == increments {
        let count = m.cycle.map_or(1, |c| c.count as u64);
        if m.has_plasticity() {
            (state.wear.cycle_ratcheting, state.wear.cycle_plastic_strain) =
                cycle_plasticity(&state.wear.plastic_start, &state.history);
        }
        apply_cycle_wear(&scene, &mut state.wear, count, true)?;
        if let Some(fatigue) = &m.fatigue {
            let f = &mut state.fatigue;
            let history = std::mem::take(&mut f.history);
            let (dn, before) = (state.wear.jump, state.wear.cycle.saturating_sub(state.wear.jump));
            let initiated = f.initiation.is_some();
            f.last = fatigue
                .cycle_damage(&history, before, dn, f)
                .map_err(|source| AnalysisError::Fatigue { cycle: state.wear.cycle, source })?;
            // The points the worn surfaces of the body have passed retire (after the jump's
            // damage: a point passed within the jump is counted through it).
            let worn: Vec<&[[f64; 2]]> = m
                .wear
                .surfaces
                .iter()
                .zip(&state.wear.vertices)
                .filter(|(ws, _)| disc.surfaces[ws.surface].body == fatigue.body_index)
                .map(|(_, v)| v.as_slice())
                .collect();
            if let Some(first) = f.initiation.as_mut().filter(|_| !initiated) {
                first.depth = crate::fatigue::distance_to_polylines(&worn, fatigue.points[first.point].position);
                let x = fatigue.points[first.point].position;
                tracing::info!(
                    cycle = first.cycle,
                    x = x.x,
                    y = x.y,
                    depth = first.depth,
                    "fatigue: crack initiation (D = 1)"
                );
            }
            fatigue.retire_cut_away(&worn, &mut f.retired);
        }
        if m.has_plasticity() {
            state.wear.plastic_start = plastic_snapshot(&state.history);
        }
        if let Some(c) = m.cycle {
            state.time = c.start + c.period * state.wear.cycle as f64;
        }
    }
    timings.wear += t1.elapsed().as_secs_f64();
    Ok(report)
}

/// Adds the wear of a converged step (from the displacements and multipliers `start`) to the
/// cycle's, with its linearisation for the implicit jump.
fn accumulate_sub_step_wear(
    (m, disc): (&Model, &Discretisation),
    analysis: &StaticAnalysis,
    state: &mut SimState,
    start: (&[f64], &[f64]),
) {
    let scene = disc.wear_scene(m);
    let sensitivity = match m.wear.scheme {
        JumpScheme::Implicit => analysis.gap_sensitivity_with_open_rows(),
        JumpScheme::Explicit => None,
    };
    accumulate_step_wear(
        &scene,
        &mut state.wear,
        (start.0, &state.u),
        (Some(start.1), &state.multipliers),
        sensitivity,
    );
}

/// Re-pairings of one finite-sliding step at most before it is refused (the pairing of a step
/// that slides within the element size settles in two or three).
pub const MAX_PAIRINGS: usize = 12;

/// A re-pairing has settled when the estimated pressure error of the pairing is below this
/// fraction of the largest pressure (0.1%: far below the discretisation error of the tractions).
pub const PAIRING_TOLERANCE: f64 = 1e-3;

/// Factor on the linearised pressure change of a re-pairing (see [`linear_pairing_change`])
/// before it may settle a step: it leaves out the shear and the contact set, and on the McColl
/// scene the change a second solve found was 0.6 to 45 times the linear estimate (6 at the 90th
/// percentile); with this factor 80% of the steps settle at their first pairing there, and the
/// largest change a second solve found among those was 3.7e-3 (estimate 4e-4 against the
/// tolerance 1e-3).
const LINEAR_PAIRING_SAFETY: f64 = 10.0;

/// Contraction of the pairing fixed point assumed at least (measured 0.003-0.06 per re-pairing
/// on the McColl scene at 4 increments per cycle).
const PAIRING_CONTRACTION_FLOOR: f64 = 0.1;

/// Solves output step `step` (to time `t`) of a finite-sliding model in the pairing of the
/// step's own end configuration, a fixed point on the pairing:
///
/// ```text
/// u_pair = u_start
/// repeat: pair the surfaces in X + u_pair (slips measured from u_start);
///         solve the step from the start state -> u, p;  u_pair = u
/// until the error estimate of p, |dp| rho / (1 - rho), is at most PAIRING_TOLERANCE p_max
/// ```
///
/// (`dp` the change of the pressures from the last solve, `rho` the observed contraction
/// `|dp_k| / |dp_k-1|`, at least [`PAIRING_CONTRACTION_FLOOR`]; 1 until two changes are known),
/// so that the end of a step does not depend on how far it slid (the pairing of the step's
/// start lags the stroke by the whole increment: on a curved contact a step sliding several
/// elements then reads the counter-surface's indentation where it no longer is). Between
/// re-pairings only the contact rows change: `K_rho` keeps its factorisation. `same_bulk`: the
/// structure handed in `reuse` was set up on `current`'s bulk; `surface_compliance`: see
/// [`StaticAnalysis::for_pairings`] (on for runs whose surfaces stay where they are, where one
/// bulk serves every step). `start` receives the step's start (a buffer kept by the caller).
/// `then` gets the step's discretisation (`current` re-paired),
/// its analysis, the converged state and the report; its result is returned.
#[allow(clippy::too_many_arguments)]
fn solve_paired_step<R>(
    model: &Model,
    current: &Discretisation,
    (state, start): (&mut SimState, &mut StepStart),
    reuse: &mut Option<crate::analysis::SolverReuse>,
    same_bulk: bool,
    surface_compliance: bool,
    pairing_start: PairingStart,
    step: usize,
    t: f64,
    options: RunOptions,
    timings: &mut RunTimings,
    then: impl FnOnce(&Discretisation, &StaticAnalysis, &mut SimState, StepReport, &StepStart) -> Result<R, AnalysisError>,
) -> Result<R, AnalysisError> {
    let PairingStart { guess, sets, first_pairing, next_guess, ahead } = pairing_start;
    let (first_pairing, mut prepared_rows) = first_pairing.map_or((None, None), |(d, rows)| (Some(d), rows));
    start.save(state);
    let mut u_pair = guess.map_or_else(|| state.u.clone(), <[f64]>::to_vec);
    let mut last_pressure: Option<Vec<f64>> = None;
    let (mut change, mut last_change, mut estimate) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let mut iterations = 0;
    let mut prepared: Option<Discretisation> = first_pairing;
    // The next step's first pairing, formed beside this step's check at its first solution.
    let mut upcoming: Option<Discretisation> = None;
    // Each solve starts from the sets the last one converged to (the first: those handed in).
    let mut start_sets = Some(sets);
    for pairing in 1..=MAX_PAIRINGS {
        let t0 = std::time::Instant::now();
        let paired = prepared.take().unwrap_or_else(|| current.repaired_at(model, &u_pair, &start.u));
        let pairing_time = t0.elapsed().as_secs_f64();
        timings.repairing += pairing_time;
        timings.pairings += pairing_time;
        let kept_bulk = same_bulk || pairing > 1;
        let bulk = (kept_bulk, prepared_rows.take(), surface_compliance);
        let mut analysis = pairing_analysis(model, &paired, reuse, bulk, start_sets.take(), options, timings)?;
        if pairing > 1 {
            start.restore(state);
        }
        let t1 = std::time::Instant::now();
        let mut report = analysis.advance_to(state, step, t)?;
        timings.solve += t1.elapsed().as_secs_f64();
        iterations += report.iterations;
        let nt = model.constraints.len();
        let pressure: Vec<f64> =
            (0..paired.contact.rows.len()).map(|k| (-state.multipliers[nt + k]).max(0.0)).collect();
        if let Some(last) = &last_pressure {
            let p_max = pressure.iter().fold(0.0_f64, |a, &b| a.max(b)).max(f64::MIN_POSITIVE);
            change = pressure.iter().zip(last).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / p_max;
            let rho = if last_change.is_finite() {
                Some((change / last_change).max(PAIRING_CONTRACTION_FLOOR))
            } else {
                // Paired first at a guess of the end: the second pairing's change is already
                // the fixed point's last one; its contraction is taken at the floor (measured
                // below it).
                guess.map(|_| PAIRING_CONTRACTION_FLOOR)
            };
            if let Some(rho) = rho {
                estimate = if rho < 1.0 { change * rho / (1.0 - rho) } else { f64::INFINITY };
            }
            last_change = change;
        }
        // Paired first at a guess: the pairing at the solution is formed (the next pairing
        // needs it anyway) and its pressure change estimated from the interface stiffness; a
        // change below the tolerance settles the step without a second solve.
        if pairing == 1 && guess.is_some() {
            let t0 = std::time::Instant::now();
            let next;
            (next, upcoming) =
                paired_at_solution(model, current, (&state.u, &start.u), next_guess.filter(|_| ahead.is_some()));
            timings.pairings += t0.elapsed().as_secs_f64();
            if let Some(linear) = linear_pairing_change(model, (&paired, &next), &analysis, state) {
                change = linear;
                let floor = PAIRING_CONTRACTION_FLOOR;
                estimate = LINEAR_PAIRING_SAFETY * linear * floor / (1.0 - floor);
            }
            prepared = Some(next);
            timings.repairing += t0.elapsed().as_secs_f64();
        }
        tracing::debug!(
            step,
            pairing,
            change,
            estimate,
            iterations = report.iterations,
            "finite sliding: step solved in its pairing"
        );
        let at_rest = pairing == 1 && guess.is_none() && !state_slid(&paired, state, &start.u);
        if estimate <= PAIRING_TOLERANCE || (pairing > 1 && change == 0.0) || at_rest {
            if let Err(e) = check_on_counter_surface(model, (current, &paired), state, step, t) {
                start.restore(state);
                return Err(e);
            }
            report.iterations = iterations;
            let next = ahead.zip(upcoming).filter(|_| pairing == 1);
            let out = settled(&analysis, next, || then(&paired, &analysis, state, report, start));
            *reuse = analysis.into_reuse();
            // The interface log of a per-step operator means nothing to the next step.
            state.interface_log.clear();
            return out;
        }
        // The next pairing's solve starts from this one's sets.
        start_sets = analysis.converged_sets().cloned();
        *reuse = analysis.into_reuse();
        last_pressure = Some(pressure);
        u_pair.clone_from(&state.u);
    }
    start.restore(state);
    Err(AnalysisError::PairingNotSettled { step, time: t, pairings: MAX_PAIRINGS, change })
}

/// The analysis of one pairing of a finite-sliding step, its solve starting from `sets`. On
/// a bulk already factored (`kept_bulk`) only the pairing's interface rows and operator are
/// formed, or taken as `rows` if they were prepared on it beforehand.
fn pairing_analysis<'m>(
    model: &'m Model,
    paired: &'m Discretisation,
    reuse: &mut Option<crate::analysis::SolverReuse>,
    (kept_bulk, rows, surface_compliance): (bool, Option<PreparedRows>, bool),
    sets: Option<(Vec<bool>, Vec<FrictionStatus>)>,
    options: RunOptions,
    timings: &mut RunTimings,
) -> Result<StaticAnalysis<'m>, AnalysisError> {
    let t0 = std::time::Instant::now();
    let handed = reuse.take().map(|r| match (kept_bulk, rows) {
        (true, Some(rows)) => r.with_same_bulk().with_prepared(rows),
        (true, None) => r.with_same_bulk(),
        (false, _) => r,
    });
    let mut analysis = StaticAnalysis::for_pairings(model, paired, handed, surface_compliance)?;
    analysis.set_parallel(options.parallel);
    if let Some(sets) = sets {
        analysis.start_from_sets(sets);
    }
    *(if kept_bulk { &mut timings.repairing } else { &mut timings.setup }) += t0.elapsed().as_secs_f64();
    timings.count_setup(&analysis);
    Ok(analysis)
}

/// A settled step handed on (`hand_on`: its wear integration and output). If the next step
/// starts where it settled (`next`: its slot and its first pairing), the next step's interface
/// rows and operator are formed on this step's factor beside it, and both go into the slot.
fn settled<R>(
    analysis: &StaticAnalysis,
    next: Option<(&mut Option<(Discretisation, Option<PreparedRows>)>, Discretisation)>,
    hand_on: impl FnOnce() -> R,
) -> R {
    match next {
        Some((slot, next)) => {
            let mut rows = None;
            let out = rayon::in_place_scope(|s| {
                s.spawn(|_| rows = analysis.prepare_rows(&next));
                hand_on()
            });
            *slot = Some((next, rows));
            out
        }
        None => hand_on(),
    }
}

/// The pairing of `current` at a step's solution `u` (slips from the step's start `u_start`)
/// and, side by side with it, the next step's first pairing at its guess `next_guess` (slips
/// from `u`: the next step starts where this one ends if it settles here).
fn paired_at_solution(
    model: &Model,
    current: &Discretisation,
    (u, u_start): (&[f64], &[f64]),
    next_guess: Option<&[f64]>,
) -> (Discretisation, Option<Discretisation>) {
    match next_guess {
        Some(g) => {
            let (at_solution, after) =
                rayon::join(|| current.repaired_at(model, u, u_start), || current.repaired_at(model, g, u));
            (at_solution, Some(after))
        }
        None => (current.repaired_at(model, u, u_start), None),
    }
}

/// Where a finite-sliding step's fixed point on the pairing starts.
#[derive(Default)]
struct PairingStart<'a> {
    /// Paired first at this guess of the step's end (`None`: at its start).
    guess: Option<&'a [f64]>,
    /// Contact and friction sets the first solve starts from.
    sets: (Vec<bool>, Vec<FrictionStatus>),
    /// The first pairing (at `guess`), already formed beside the last step's check, with its
    /// interface rows if they were formed too.
    first_pairing: Option<(Discretisation, Option<PreparedRows>)>,
    /// The next step's guess: its first pairing is formed beside this step's check and left
    /// in `ahead` if this step settles at its first solution (the next one starts there).
    next_guess: Option<&'a [f64]>,
    ahead: Option<&'a mut Option<(Discretisation, Option<PreparedRows>)>>,
}

/// What the solve of a finite-sliding step changes in the state, saved at the step's start so
/// that a re-pairing solves again from there (and a refused step leaves its step, time,
/// displacements, multipliers, friction fields and history where they started). The stresses
/// are left out: derived from the displacements and the history, every solve writes them
/// wherever there is material (points without material keep theirs, which no solve changes),
/// so a re-pairing's solve gives the same bits; after a refused step they are its last
/// solve's. So is the wear state, which the solve does not touch. Its buffers are refilled
/// step after step, not reallocated.
#[derive(Default)]
struct StepStart {
    step: usize,
    time: f64,
    load_factor: f64,
    u: Vec<f64>,
    history: Vec<crate::fem::material::PlasticState>,
    f_int: Vec<f64>,
    multipliers: Vec<f64>,
    friction_status: Vec<u8>,
    slip_increment: Vec<f64>,
    accumulated_slip: Vec<f64>,
    dissipation: f64,
    interface_log: Vec<Vec<usize>>,
}

impl StepStart {
    fn save(&mut self, s: &SimState) {
        // Every field named: a new state field must be placed on one side or the other.
        let SimState {
            step,
            time,
            load_factor,
            u,
            history,
            stress: _,
            f_int,
            multipliers,
            friction_status,
            slip_increment,
            accumulated_slip,
            dissipation,
            interface_log,
            wear: _,
            ghost: _,
            fatigue: _,
        } = s;
        (self.step, self.time, self.load_factor, self.dissipation) = (*step, *time, *load_factor, *dissipation);
        self.u.clone_from(u);
        self.history.clone_from(history);
        self.f_int.clone_from(f_int);
        self.multipliers.clone_from(multipliers);
        self.friction_status.clone_from(friction_status);
        self.slip_increment.clone_from(slip_increment);
        self.accumulated_slip.clone_from(accumulated_slip);
        self.interface_log.clone_from(interface_log);
    }

    fn restore(&self, s: &mut SimState) {
        (s.step, s.time, s.load_factor, s.dissipation) = (self.step, self.time, self.load_factor, self.dissipation);
        s.u.clone_from(&self.u);
        s.history.clone_from(&self.history);
        s.f_int.clone_from(&self.f_int);
        s.multipliers.clone_from(&self.multipliers);
        s.friction_status.clone_from(&self.friction_status);
        s.slip_increment.clone_from(&self.slip_increment);
        s.accumulated_slip.clone_from(&self.accumulated_slip);
        s.interface_log.clone_from(&self.interface_log);
    }
}

/// The pressure change that re-pairing a converged finite-sliding step would cause, relative
/// to the largest pressure, linearised: the weighted gaps of the active rows at the solution
/// in the pairing `next` (formed at the solution) against those in the step's pairing
/// `paired`, times the interface stiffness of the converged state. `None` without the
/// stiffness (no interface condensation) or when a row open in `model` would penetrate in
/// `next` (the contact set would change: only a solve tells).
fn linear_pairing_change(
    model: &Model,
    (paired, next): (&Discretisation, &Discretisation),
    analysis: &StaticAnalysis,
    state: &SimState,
) -> Option<f64> {
    let gap = |d: &Discretisation, k: usize| {
        d.contact.g0[k] + d.contact.rows[k].iter().map(|&(dof, c)| c * state.u[dof]).sum::<f64>()
    };
    let (rows, dlambda) = analysis.gap_response(&|k| gap(next, k) - gap(paired, k))?;
    let mut in_contact = vec![false; paired.contact.rows.len()];
    for &k in &rows {
        in_contact[k] = true;
    }
    let penetrates =
        (0..paired.contact.rows.len()).any(|k| !in_contact[k] && next.contact.phi[k] > 0.0 && gap(next, k) < 0.0);
    if penetrates {
        return None;
    }
    let nt = model.constraints.len();
    let p_max = (0..paired.contact.rows.len()).map(|k| -state.multipliers[nt + k]).fold(0.0_f64, f64::max);
    (p_max > 0.0).then(|| dlambda.iter().fold(0.0_f64, |a, d| a.max(d.abs())) / p_max)
}

/// Paired share of a pressed node's support below which the contact has reached the end of its
/// counter-surface (a node inside a long counter-surface is paired over all of it, up to the
/// stretch of the surfaces, about the strain).
const END_OF_SURFACE_SHARE: f64 = 0.9;

/// Warnings of a partly paired pressed node away from the counter-surface's ends per process.
const PARTIAL_SHARE_WARNINGS: usize = 3;

/// A converged finite-sliding step whose contact reached the end of the counter-surface: a node
/// carrying pressure is paired over less of its support (`int Phi` of the step's pairing in
/// `paired`) than in the pairing `base` the step started from. The body then rests on the other's last
/// corner, which no stroke of a fretting or sliding-wear test means: a typed error.
fn check_on_counter_surface(
    model: &Model,
    (base, paired): (&Discretisation, &Discretisation),
    state: &SimState,
    step: usize,
    t: f64,
) -> Result<(), AnalysisError> {
    let nt = model.constraints.len();
    for c in paired.contact.pairs.iter().filter(|c| c.sliding == crate::contact::Sliding::Finite) {
        let rows = c.first_row..c.first_row + c.multipliers.num_nodes;
        let p_max = rows.clone().map(|k| -state.multipliers[nt + k]).fold(0.0_f64, f64::max);
        let mut ends: Option<Vec<usize>> = None;
        for k in rows {
            let (phi_ref, phi) = (base.contact.phi[k], paired.contact.phi[k]);
            if -state.multipliers[nt + k] > 1e-6 * p_max && phi_ref > 0.0 && phi < END_OF_SURFACE_SHARE * phi_ref {
                // The end of the counter-surface is the cause only where the row is paired to
                // it (its row couples the DOFs of an end segment); elsewhere (a steep wall
                // of a deep groove facing part of the support beyond the pairing's reach) the
                // row is solved on the share it has.
                let ends = ends.get_or_insert_with(|| counter_surface_end_dofs(model, c));
                if !paired.contact.rows[k].iter().any(|&(d, v)| v != 0.0 && ends.binary_search(&d).is_ok()) {
                    // Said a few times per process (it recurs step after step in a deep groove).
                    static SAID: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
                    if SAID.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= PARTIAL_SHARE_WARNINGS {
                        tracing::debug!(step, pair = %c.name, row = k - c.first_row, "partly paired row");
                        continue;
                    }
                    tracing::warn!(
                        step,
                        time = t,
                        pair = %c.name,
                        row = k - c.first_row,
                        percent = 100.0 * phi / phi_ref,
                        "a node carrying pressure is paired over part of its support away from the ends of its \
                         counter-surface (a steep wall beyond the pairing's reach?); solved on that share (said \
                         {PARTIAL_SHARE_WARNINGS} times at most, then at debug level)"
                    );
                    continue;
                }
                return Err(AnalysisError::OffCounterSurface {
                    step,
                    time: t,
                    pair: c.name.clone(),
                    percent: 100.0 * phi / phi_ref,
                });
            }
        }
    }
    Ok(())
}

/// The DOFs (sorted) of the end segments of contact `c`'s counter-surface: the end nodes of an
/// open chain of real edges, the host cells' nodes of an open virtual surface's first and last
/// pieces (none for a closed surface).
fn counter_surface_end_dofs(model: &Model, c: &crate::contact::ContactInfo) -> Vec<usize> {
    let mut nodes: Vec<usize> = match &c.other {
        crate::contact::PairedSide::Edges(edges) => {
            let mut count = std::collections::BTreeMap::<usize, usize>::new();
            for &n in edges.iter().flatten() {
                *count.entry(n).or_default() += 1;
            }
            count.into_iter().filter(|&(_, k)| k == 1).map(|(n, _)| n).collect()
        }
        crate::contact::PairedSide::Embedded { host, embedding } if !embedding.closed => {
            let body = &model.bodies[*host];
            [embedding.pieces.first(), embedding.pieces.last()]
                .into_iter()
                .flatten()
                .flat_map(|p| body.mesh.cells[p.cell].nodes().iter().map(|&n| body.node_offset + n).collect::<Vec<_>>())
                .collect()
        }
        crate::contact::PairedSide::Embedded { .. } => vec![],
    };
    nodes.sort_unstable();
    nodes.dedup();
    nodes.iter().flat_map(|&n| [2 * n, 2 * n + 1]).collect()
}

/// Whether a converged step moved the paired surfaces at all from the start state (a step at
/// rest, as the ramp of a held stroke, keeps its pairing: no re-pairing needed).
fn state_slid(paired: &Discretisation, state: &SimState, u_start: &[f64]) -> bool {
    paired.contact.rows.iter().flatten().any(|&(d, _)| state.u[d] != u_start[d])
}
