//! The run driver: every run, resume and wear loop goes through [`run`].
//!
//! ```text
//! for each remaining output step k (time t_k, cycle c, increment i):
//!     move the virtual surfaces to their position at t_k and re-cut (fixed points)
//!     solve the step (condensed interface solve for elastic contact, Newton otherwise);
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

use crate::analysis::{AnalysisError, GapSensitivity, StaticAnalysis, StepReport};
use crate::model::Model;
use crate::state::SimState;
use crate::wear::{JumpPolicy, JumpScheme, RateFilter, WearLaw};

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
    /// Solver set-up per computed cycle: assembly, factorisation, interface operator.
    pub setup: f64,
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
/// checkpoint), calling `observer` with each converged step, its state and the model of the
/// step (current surfaces, pairing and DOF map). An observer error stops the run.
pub fn run<F>(model: &Model, state: &mut SimState, options: RunOptions, observer: F) -> Result<(), AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model) -> Result<(), String>,
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
    F: FnMut(&StepReport, &SimState, &Model) -> Result<(), String>,
{
    if !model.wear.is_empty() {
        return run_wear(model, state, options, observer);
    }
    if !model.has_moving_surfaces() && !model.has_finite_sliding() {
        let mut analysis = StaticAnalysis::new(model)?;
        analysis.set_parallel(options.parallel);
        analysis.resume(state)?;
        return analysis.run(state, |r, s| observer(r, s, model)).map(|_| RunTimings::default());
    }
    let mut current = model.clone();
    let mut reuse = None;
    let first = state.step;
    for (k, &t) in model.times.iter().enumerate().skip(first) {
        let step = k + 1;
        if current.has_moving_surfaces() {
            let recut = current.place_surfaces(t).map_err(|source| AnalysisError::Surface { step, time: t, source })?;
            tracing::debug!(step, moved = recut.moved, cut_by_degree = ?recut.cut_cells_by_degree, held = recut.held_dofs, "surfaces re-cut");
        }
        if current.has_finite_sliding() {
            // Without moving surfaces every step has the bulk the first one set up.
            let at_rest = !current.has_moving_surfaces();
            let (same_bulk, mut timings) = (at_rest && k > first, RunTimings::default());
            solve_paired_step(
                &current,
                state,
                &mut reuse,
                same_bulk,
                at_rest,
                step,
                t,
                options,
                &mut timings,
                |m, _, s, r, _| observer(&r, s, m).map_err(|msg| AnalysisError::Observer { step, msg }),
            )?;
            continue;
        }
        let mut analysis = StaticAnalysis::with_reuse(&current, reuse.take())?;
        analysis.set_parallel(options.parallel);
        let report = analysis.advance_to(state, step, t)?;
        reuse = analysis.into_reuse();
        // The interface log of a per-step operator means nothing to the next step.
        state.interface_log.clear();
        observer(&report, state, &current).map_err(|msg| AnalysisError::Observer { step, msg })?;
    }
    Ok(RunTimings::default())
}

/// The wear loop (see [`crate::wear`]):
///
/// ```text
/// ramp steps (before the cycle window): as any run
/// while cycles done < cycles:
///     place the worn surfaces (re-cut on fixed points, re-pair)
///     for each increment of the cycle:
///         solve the step; add its wear volumes and work on every wearing surface
///     jump dN = controller(wear rates); depth += dN * rate; move vertices inward; cycles += dN
/// ```
///
/// Within a computed cycle the surfaces hold still, so an elastic scene keeps one condensed
/// solver for the whole cycle (a resume mid-cycle replays its interface log). A jump moves the
/// state to the end of the jumped cycle: the load history is periodic, the state is the one
/// the computed cycle ended with.
fn run_wear<F>(
    model: &Model,
    state: &mut SimState,
    options: RunOptions,
    mut observer: F,
) -> Result<RunTimings, AnalysisError>
where
    F: FnMut(&StepReport, &SimState, &Model) -> Result<(), String>,
{
    let mut timings = RunTimings::default();
    let clock = std::time::Instant::now;
    let Some(cycle) = model.cycle else {
        let surface = model.wear.surfaces[0].name.clone();
        return Err(AnalysisError::Wear { cycle: 0, surface, msg: "wear needs a cyclic load ([steps] cycle)".into() });
    };
    let ramp_steps = model.times.len() - cycle.count * cycle.increments;
    let mut current = model.clone();
    // The condensed solver's structure, handed from one surface position to the next.
    let mut reuse = None;
    // Surfaces where the state has them, re-cut and re-paired (small sliding: in the reference
    // geometry, with the pairing reach extended by the wear depth allowed).
    let place = |m: &mut Model, state: &SimState| {
        m.place_worn_surfaces(&state.wear).map(|_| ()).map_err(|source| AnalysisError::Surface {
            step: state.step,
            time: state.time,
            source,
        })
    };
    let t0 = clock();
    place(&mut current, state)?;
    timings.wear += t0.elapsed().as_secs_f64();
    if state.step < ramp_steps {
        let mut analysis = StaticAnalysis::with_reuse(&current, reuse.take())?;
        analysis.set_parallel(options.parallel);
        analysis.resume(state)?;
        timings.count_setup(&analysis);
        for k in state.step..ramp_steps {
            let u_prev = state.u.clone();
            let report = analysis.advance_to(state, k + 1, model.times[k])?;
            accumulate_step_wear(&current, state, &u_prev, None);
            if k + 1 == ramp_steps {
                // The ramp's wear (sliding under the rising load) counts, applied once.
                apply_wear(&current, state, cycle.count as u64, false, None)?;
                state.interface_log.clear();
            }
            observer(&report, state, &current).map_err(|msg| AnalysisError::Observer { step: k + 1, msg })?;
        }
        reuse = analysis.into_reuse();
        let t0 = clock();
        place(&mut current, state)?;
        timings.wear += t0.elapsed().as_secs_f64();
    }
    while state.wear.cycle < cycle.count as u64 {
        let n = state.wear.cycle;
        let step_time = |i: usize| cycle.start + cycle.period * (n as f64 + (i + 1) as f64 / cycle.increments as f64);
        if current.has_finite_sliding() {
            let first = state.wear.increment;
            for i in first..cycle.increments {
                let step = state.step + 1;
                // The surfaces moved before the cycle's first increment: its set-up refactors.
                let same_bulk = i > first;
                let mut solve_timings = RunTimings::default();
                solve_paired_step(
                    &current,
                    state,
                    &mut reuse,
                    same_bulk,
                    false,
                    step,
                    step_time(i),
                    options,
                    &mut solve_timings,
                    |m, analysis, state, report, start| {
                        let report = integrate_step_wear(
                            m,
                            analysis,
                            state,
                            (&start.u, &start.multipliers),
                            report,
                            i,
                            n,
                            cycle.increments,
                            &mut timings,
                        )?;
                        observer(&report, state, m).map_err(|msg| AnalysisError::Observer { step: report.step, msg })
                    },
                )?;
                timings.add(&solve_timings);
            }
        } else {
            let t0 = clock();
            let mut analysis = StaticAnalysis::with_reuse(&current, reuse.take())?;
            analysis.set_parallel(options.parallel);
            analysis.resume(state)?;
            timings.setup += t0.elapsed().as_secs_f64();
            timings.count_setup(&analysis);
            for i in state.wear.increment..cycle.increments {
                let report =
                    wear_step(&current, &mut analysis, state, i, step_time(i), n, cycle.increments, &mut timings)?;
                if i + 1 == cycle.increments {
                    state.interface_log.clear();
                }
                observer(&report, state, &current).map_err(|msg| AnalysisError::Observer { step: report.step, msg })?;
            }
            reuse = analysis.into_reuse();
        }
        let t0 = clock();
        place(&mut current, state)?;
        timings.wear += t0.elapsed().as_secs_f64();
    }
    Ok(timings)
}

#[allow(clippy::too_many_arguments)]
/// Increment `i` of computed cycle `n` (0-based): solve, add the step's wear, and at the
/// cycle's last increment apply the cycle's wear with its jump.
fn wear_step(
    m: &Model,
    analysis: &mut StaticAnalysis,
    state: &mut SimState,
    i: usize,
    t: f64,
    n: u64,
    increments: usize,
    timings: &mut RunTimings,
) -> Result<StepReport, AnalysisError> {
    let (u_prev, lambda_prev) = (state.u.clone(), state.multipliers.clone());
    let t0 = std::time::Instant::now();
    let report = analysis.advance_to(state, state.step + 1, t)?;
    timings.solve += t0.elapsed().as_secs_f64();
    integrate_step_wear(m, analysis, state, (&u_prev, &lambda_prev), report, i, n, increments, timings)
}

#[allow(clippy::too_many_arguments)]
/// The wear of increment `i` of computed cycle `n` that just converged (from the displacements
/// and multipliers `start`), and at the cycle's last increment the cycle's wear applied with
/// its jump.
fn integrate_step_wear(
    m: &Model,
    analysis: &StaticAnalysis,
    state: &mut SimState,
    start: (&[f64], &[f64]),
    mut report: StepReport,
    i: usize,
    n: u64,
    increments: usize,
    timings: &mut RunTimings,
) -> Result<StepReport, AnalysisError> {
    let t1 = std::time::Instant::now();
    report.cycle = n as usize + 1;
    report.increment = i + 1;
    accumulate_step_wear(m, state, start.0, Some(start.1));
    state.wear.increment = i + 1;
    if i + 1 == increments {
        let count = m.cycle.map_or(1, |c| c.count as u64);
        let sensitivity = match m.wear.scheme {
            JumpScheme::Implicit => analysis.gap_sensitivity(),
            JumpScheme::Explicit => None,
        };
        apply_wear(m, state, count, true, sensitivity.as_ref())?;
        if let Some(c) = m.cycle {
            state.time = c.start + c.period * state.wear.cycle as f64;
        }
    }
    timings.wear += t1.elapsed().as_secs_f64();
    Ok(report)
}

/// Re-pairings of one finite-sliding step at most before it is refused (the pairing of a step
/// that slides within the element size settles in two or three).
pub const MAX_PAIRINGS: usize = 12;

/// A re-pairing has settled when the estimated pressure error of the pairing is below this
/// fraction of the largest pressure (0.1%: far below the discretisation error of the tractions).
pub const PAIRING_TOLERANCE: f64 = 1e-3;

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
/// bulk serves every step). `then` gets the step's model,
/// its analysis, the converged state and the report; its result is returned.
#[allow(clippy::too_many_arguments)]
fn solve_paired_step<R>(
    current: &Model,
    state: &mut SimState,
    reuse: &mut Option<crate::analysis::SolverReuse>,
    same_bulk: bool,
    surface_compliance: bool,
    step: usize,
    t: f64,
    options: RunOptions,
    timings: &mut RunTimings,
    then: impl FnOnce(&Model, &StaticAnalysis, &mut SimState, StepReport, &SimState) -> Result<R, AnalysisError>,
) -> Result<R, AnalysisError> {
    let start = state.clone();
    let mut u_pair = state.u.clone();
    let mut last_pressure: Option<Vec<f64>> = None;
    let (mut change, mut last_change, mut estimate) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let mut iterations = 0;
    for pairing in 1..=MAX_PAIRINGS {
        let t0 = std::time::Instant::now();
        let model = current.repaired_at(&u_pair, &start.u);
        let handed = reuse.take().map(|r| if same_bulk || pairing > 1 { r.with_same_bulk() } else { r });
        let mut analysis = StaticAnalysis::for_pairings(&model, handed, surface_compliance)?;
        analysis.set_parallel(options.parallel);
        timings.setup += t0.elapsed().as_secs_f64();
        timings.count_setup(&analysis);
        if pairing > 1 {
            *state = start.clone();
        }
        let t1 = std::time::Instant::now();
        let mut report = analysis.advance_to(state, step, t)?;
        timings.solve += t1.elapsed().as_secs_f64();
        iterations += report.iterations;
        let nt = model.constraints.len();
        let pressure: Vec<f64> = (0..model.contact.rows.len()).map(|k| (-state.multipliers[nt + k]).max(0.0)).collect();
        if let Some(last) = &last_pressure {
            let p_max = pressure.iter().fold(0.0_f64, |a, &b| a.max(b)).max(f64::MIN_POSITIVE);
            change = pressure.iter().zip(last).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / p_max;
            if last_change.is_finite() {
                let rho = (change / last_change).max(PAIRING_CONTRACTION_FLOOR);
                estimate = if rho < 1.0 { change * rho / (1.0 - rho) } else { f64::INFINITY };
            }
            last_change = change;
        }
        tracing::debug!(step, pairing, change, estimate, "finite sliding: step solved in its pairing");
        if change == 0.0 || estimate <= PAIRING_TOLERANCE || (pairing == 1 && !state_slid(&model, state, &start.u)) {
            if let Err(e) = check_on_counter_surface(current, &model, state, step, t) {
                *state = start;
                return Err(e);
            }
            report.iterations = iterations;
            let out = then(&model, &analysis, state, report, &start);
            *reuse = analysis.into_reuse();
            // The interface log of a per-step operator means nothing to the next step.
            state.interface_log.clear();
            return out;
        }
        *reuse = analysis.into_reuse();
        last_pressure = Some(pressure);
        u_pair.clone_from(&state.u);
    }
    *state = start;
    Err(AnalysisError::PairingNotSettled { step, time: t, pairings: MAX_PAIRINGS, change })
}

/// Paired share of a pressed node's support below which the contact has reached the end of its
/// counter-surface (a node inside a long counter-surface is paired over all of it, up to the
/// stretch of the surfaces, about the strain).
const END_OF_SURFACE_SHARE: f64 = 0.9;

/// A converged finite-sliding step whose contact reached the end of the counter-surface: a node
/// carrying pressure is paired over less of its support (`int Phi` of the step's pairing in
/// `paired`) than in the reference pairing of `base`. The body then rests on the other's last
/// corner, which no stroke of a fretting or sliding-wear test means: a typed error.
fn check_on_counter_surface(
    base: &Model,
    paired: &Model,
    state: &SimState,
    step: usize,
    t: f64,
) -> Result<(), AnalysisError> {
    let nt = paired.constraints.len();
    for c in paired.contact.pairs.iter().filter(|c| c.sliding == crate::contact::Sliding::Finite) {
        let rows = c.first_row..c.first_row + c.multipliers.num_nodes;
        let p_max = rows.clone().map(|k| -state.multipliers[nt + k]).fold(0.0_f64, f64::max);
        for k in rows {
            let (phi_ref, phi) = (base.contact.phi[k], paired.contact.phi[k]);
            if -state.multipliers[nt + k] > 1e-6 * p_max && phi_ref > 0.0 && phi < END_OF_SURFACE_SHARE * phi_ref {
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

/// Whether a converged step moved the paired surfaces at all from the start state (a step at
/// rest, as the ramp of a held stroke, keeps its pairing: no re-pairing needed).
fn state_slid(m: &Model, state: &SimState, u_start: &[f64]) -> bool {
    m.contact.rows.iter().flatten().any(|&(d, _)| state.u[d] != u_start[d])
}

/// Adds the wear of the step that just converged (from `u_prev` to `state.u`; tractions from
/// `lambda_prev` at its start, if given) to the cycle's volumes and work (see
/// [`crate::wear::swept_step_wear`]).
fn accumulate_step_wear(m: &Model, state: &mut SimState, u_prev: &[f64], lambda_prev: Option<&[f64]>) {
    let hosts = m.hosts();
    for (w, ws) in m.wear.surfaces.iter().enumerate() {
        let sw = crate::wear::swept_step_wear(
            &m.contact,
            &hosts,
            ws,
            &m.surfaces[ws.surface],
            &m.coords,
            (u_prev, &state.u),
            (lambda_prev, &state.multipliers),
        );
        let wear = &mut state.wear;
        for (a, v) in wear.cycle_volume[w].iter_mut().zip(&sw.volume) {
            *a += v;
        }
        for (a, v) in wear.cycle_row_work[w].iter_mut().zip(&sw.row_work) {
            *a += v;
        }
        for (a, v) in wear.cycle_row_slip[w].iter_mut().zip(&sw.row_slip) {
            *a += v;
        }
        wear.cycle_work[w] += sw.work;
    }
}

/// Applies the current cycle's wear: the jump `dN` (the controller's, or 1 for the ramp when
/// `jump` is false), depths, vertices, sums and counters. With the implicit scheme and the
/// interface stiffness `sensitivity` of the cycle's last increment, the cycle's wear is taken
/// at the end-of-jump pressure (see [`crate::wear::implicit_pressure_change`]).
fn apply_wear(
    m: &Model,
    state: &mut SimState,
    count: u64,
    jump: bool,
    sensitivity: Option<&GapSensitivity>,
) -> Result<(), AnalysisError> {
    let measures: Vec<Vec<f64>> =
        m.wear.surfaces.iter().map(|ws| crate::wear::vertex_measure(&m.surfaces[ws.surface])).collect();
    let per_measure = |vol: &[f64], mea: &[f64]| -> Vec<f64> {
        vol.iter().zip(mea).map(|(v, a)| if *a > 0.0 { v / a } else { 0.0 }).collect()
    };
    let raw: Vec<Vec<f64>> = state.wear.cycle_volume.iter().zip(&measures).map(|(v, a)| per_measure(v, a)).collect();
    let filters: Vec<RateFilter> = m
        .wear
        .surfaces
        .iter()
        .enumerate()
        .map(|(k, ws)| {
            let s = &m.surfaces[ws.surface];
            RateFilter::new(&s.vertices, s.base.closed, &measures[k], &raw[k], m.wear.smoothing)
        })
        .collect();
    let rates: Vec<Vec<f64>> = filters.iter().zip(&raw).map(|(f, r)| f.apply(r)).collect();
    let sensitivity = sensitivity.filter(|s| jump && m.wear.scheme == JumpScheme::Implicit && !s.rows.is_empty());
    let scheme = if sensitivity.is_some() { JumpScheme::Implicit } else { JumpScheme::Explicit };
    let mut dn = if jump {
        let resolution = m
            .wear
            .surfaces
            .iter()
            .zip(&rates)
            .map(|(ws, r)| crate::wear::wearing_resolution(&m.surfaces[ws.surface].vertices, r))
            .fold(f64::INFINITY, f64::min);
        let flat: Vec<f64> = rates.iter().flatten().copied().collect();
        let remaining = count.saturating_sub(state.wear.cycle);
        crate::wear::next_jump(m.wear.jump, scheme, &mut state.wear.controller, &flat, resolution, remaining)
    } else {
        1
    };
    // Nothing wears if the whole run at the first cycle's rate stays below round-off of the
    // surface's resolution (a zero stroke leaves slips of order 1e-17).
    let rmax = rates.iter().flatten().fold(0.0_f64, |a, &b| a.max(b.abs()));
    let h_min = m
        .wear
        .surfaces
        .iter()
        .map(|ws| {
            crate::wear::wearing_resolution(
                &m.surfaces[ws.surface].vertices,
                &vec![1.0; m.surfaces[ws.surface].vertices.len()],
            )
        })
        .fold(f64::INFINITY, f64::min);
    if jump && state.wear.computed_cycles == 0 && rmax * count as f64 <= 1e-9 * h_min {
        return Err(AnalysisError::Wear {
            cycle: 1,
            surface: m.wear.surfaces.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", "),
            msg: format!(
                "no wear in the first cycle: the wearing surfaces never slid under pressure at the {} increments \
                 of the cycle (zero stroke, not in contact, or too few steps.increments to sample the stroke); \
                 nothing would ever wear",
                m.cycle.map_or(0, |c| c.increments)
            ),
        });
    }
    // The cycle's wear volumes and work as applied: the computed ones, or (implicit) those at
    // the end-of-jump pressure.
    let (volumes, works, rates) = match sensitivity {
        Some(sens) => match implicit_correction(m, state, sens, &measures, &filters, &rates, &mut dn) {
            Some((volumes, works)) => {
                let rates: Vec<Vec<f64>> = filters
                    .iter()
                    .zip(&volumes)
                    .zip(&measures)
                    .map(|((f, v), a)| f.apply(&per_measure(v, a)))
                    .collect();
                // What the next computed cycle should find (checked by `prediction_cap`).
                state.wear.controller.predicted_area_rate = volumes.iter().map(|v| v.iter().sum()).collect();
                (volumes, works, rates)
            }
            None => {
                tracing::warn!(cycle = state.wear.cycle, "implicit wear jump: singular system; one explicit cycle");
                dn = 1;
                state.wear.controller.last_jump = 1;
                state.wear.controller.forget_prediction();
                (state.wear.cycle_volume.clone(), state.wear.cycle_work.clone(), rates)
            }
        },
        None => {
            state.wear.controller.forget_prediction();
            (state.wear.cycle_volume.clone(), state.wear.cycle_work.clone(), rates)
        }
    };
    let w = &mut state.wear;
    for (k, ws) in m.wear.surfaces.iter().enumerate() {
        let inc = crate::wear::depth_increment(&rates[k], &measures[k], dn);
        let verts: Vec<nalgebra::Point2<f64>> =
            w.vertices[k].iter().map(|p| nalgebra::Point2::new(p[0], p[1])).collect();
        let moved = crate::wear::worn_vertices(&verts, m.surfaces[ws.surface].base.closed, &inc);
        for (d, (i, a)) in w.depth[k].iter_mut().zip(inc.iter().zip(&measures[k])) {
            if *a > 0.0 {
                *d += i;
            }
        }
        let deepest = w.depth[k].iter().fold(0.0_f64, |a, &b| a.max(b));
        if !deepest.is_finite() || deepest > ws.max_depth {
            return Err(AnalysisError::Wear {
                cycle: w.cycle + dn,
                surface: ws.name.clone(),
                msg: format!(
                    "wear depth {deepest:.6e} passes max_depth = {} (the band of fixed points prepared for it): \
                     raise [[wear]] max_depth",
                    ws.max_depth
                ),
            });
        }
        w.vertices[k] = moved.iter().map(|p| [p.x, p.y]).collect();
        w.worn_area[k] += dn as f64 * volumes[k].iter().sum::<f64>();
        w.work[k] += dn as f64 * works[k];
        w.cycle_volume[k].iter_mut().for_each(|v| *v = 0.0);
        w.cycle_row_work[k].iter_mut().for_each(|v| *v = 0.0);
        w.cycle_row_slip[k].iter_mut().for_each(|v| *v = 0.0);
        w.cycle_work[k] = 0.0;
    }
    if jump {
        w.cycle += dn;
        w.computed_cycles += 1;
        w.jump = dn;
        w.increment = 0;
    }
    Ok(())
}

/// The implicit jump's cycle volumes and works per surface (the computed cycle's, each row's
/// work moved by its change at the end-of-jump pressure, never below zero: the wear balance
/// holds exactly), and the jump after the controller's pressure-change bound. `None` if the
/// linearised system is singular.
fn implicit_correction(
    m: &Model,
    state: &mut SimState,
    sens: &GapSensitivity,
    measures: &[Vec<f64>],
    filters: &[RateFilter],
    rates: &[Vec<f64>],
    dn: &mut u64,
) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
    let hosts = m.hosts();
    let nt = m.constraints.len();
    let na = sens.rows.len();
    let mut pos_of = vec![None; m.contact.rows.len()];
    for (r, &k) in sens.rows.iter().enumerate() {
        pos_of[k] = Some(r);
    }
    let w = &state.wear;
    let mut couplings = Vec::with_capacity(m.wear.surfaces.len());
    let mut surfaces = Vec::with_capacity(m.wear.surfaces.len());
    for (b, ws) in m.wear.surfaces.iter().enumerate() {
        let x = crate::wear::pairing_position(&m.contact, ws, &m.coords, &state.u, &state.u);
        let coupling = crate::wear::wear_coupling(&m.contact, &hosts, ws, &m.surfaces[ws.surface], &x)?;
        let c = &m.contact.pairs[ws.contact];
        let nv = measures[b].len();
        let mut g = nalgebra::DMatrix::zeros(na, nv);
        let (mut phi, mut work_per_pressure) = (vec![0.0; na], vec![0.0; na]);
        for &(i, l, v) in &coupling.entries {
            if let Some(r) = pos_of[c.first_row + l] {
                g[(r, i)] += v;
            }
        }
        for l in 0..c.multipliers.num_nodes {
            let k = c.first_row + l;
            let Some(r) = pos_of[k] else { continue };
            phi[r] = coupling.phi[l];
            let per_pressure = match ws.law {
                WearLaw::Archard => 1.0,
                WearLaw::Energy => c.friction_row[l].map_or(0.0, |_| m.contact.mu[k]),
            };
            work_per_pressure[r] = if phi[r] > 0.0 { per_pressure * w.cycle_row_slip[b][l] } else { 0.0 };
        }
        surfaces.push(crate::wear::JumpSurface {
            coupling: g,
            phi,
            measure: &measures[b],
            coefficient: ws.coefficient,
            work_per_pressure,
            rate: &rates[b],
            filter: &filters[b],
        });
        couplings.push(coupling);
    }
    let pressure: Vec<f64> = sens.rows.iter().map(|&k| -state.multipliers[nt + k]).collect();
    let weights: Vec<f64> = sens.rows.iter().map(|&k| m.contact.phi[k]).collect();
    let solve = |n: u64| crate::wear::implicit_pressure_change(&sens.dlambda_dgap, &surfaces, n);
    let mut controller = state.wear.controller.clone();
    // The last jump's prediction against this cycle: the pressure of every contact row, the
    // worn-area rate of each surface.
    let all_pressure: Vec<f64> = (0..m.contact.rows.len()).map(|k| (-state.multipliers[nt + k]).max(0.0)).collect();
    if let JumpPolicy::Adaptive { prediction_tolerance, .. } = m.wear.jump {
        use crate::wear::{prediction_cap, PRESSURE_PREDICTION_TOLERANCE};
        let area_rate: Vec<f64> = state.wear.cycle_volume.iter().map(|v| v.iter().sum()).collect();
        let (last, ones) = (controller.last_jump, vec![1.0; area_rate.len()]);
        let pressure_check = prediction_cap(
            &controller.predicted,
            &all_pressure,
            &m.contact.phi,
            last,
            PRESSURE_PREDICTION_TOLERANCE,
            2,
        );
        let area_check =
            prediction_cap(&controller.predicted_area_rate, &area_rate, &ones, last, prediction_tolerance, 1);
        for (what, check) in [("pressure", pressure_check), ("area rate", area_check)] {
            if let Some((error, cap)) = check {
                tracing::debug!(
                    cycle = state.wear.cycle,
                    what,
                    error,
                    cap,
                    proposed = *dn,
                    "implicit jump: last prediction"
                );
                *dn = (*dn).min(cap);
            }
        }
    }
    let (n, dp) = crate::wear::bounded_implicit_jump(m.wear.jump, &mut controller, *dn, &pressure, &weights, &solve)?;
    controller.predicted = all_pressure;
    for (r, &k) in sens.rows.iter().enumerate() {
        controller.predicted[k] += dp[r];
    }
    let w = &mut state.wear;
    w.controller = controller;
    tracing::debug!(
        cycle = w.cycle,
        proposed = *dn,
        jump = n,
        pressure_change = (dp.iter().zip(&weights).map(|(d, w)| w * d * d).sum::<f64>()
            / pressure.iter().zip(&weights).map(|(p, w)| w * p * p).sum::<f64>())
        .sqrt(),
        rows = na,
        "implicit wear jump"
    );
    *dn = n;
    let mut volumes = Vec::with_capacity(surfaces.len());
    let mut works = Vec::with_capacity(surfaces.len());
    for (b, ws) in m.wear.surfaces.iter().enumerate() {
        let c = &m.contact.pairs[ws.contact];
        let mut dw = vec![0.0; c.multipliers.num_nodes];
        for (l, d) in dw.iter_mut().enumerate() {
            if let Some(r) = pos_of[c.first_row + l] {
                // W_end = W + c dp >= 0.
                *d = (surfaces[b].work_per_pressure[r] * dp[r]).max(-w.cycle_row_work[b][l]);
            }
        }
        let nv = measures[b].len();
        let extra = couplings[b].volumes(ws.coefficient, &dw, nv);
        volumes.push(w.cycle_volume[b].iter().zip(&extra).map(|(a, e)| a + e).collect());
        works.push(w.cycle_work[b] + dw.iter().sum::<f64>());
    }
    Some((volumes, works))
}
