//! Finite sliding: a step solved in the pairing of its own end configuration, a fixed point on
//! the pairing (see [`StepSolver::solve_paired`]), and the checks of a settled pairing.

use super::{
    Ahead, AnalysisError, ContactSets, PreparedRows, SolvedStep, StaticAnalysis, StepReport, StepRequest, StepSolver,
};
use crate::model::{Discretisation, Model};
use crate::state::SimState;
use std::sync::Arc;

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

/// Relaxation of a pairing fixed point that stopped contracting (a re-pairing's pressure change
/// at least the last one's: a punch resting on a rounded corner rocks between two rests, each
/// pairing undoing the last): the next pairing is formed at `u_pair + w (u - u_pair)`, `w`
/// halved at each such re-pairing down to this floor. The fixed point is the same one; only
/// the path to it changes. Re-pairings of a relaxed step may run to twice [`MAX_PAIRINGS`].
const PAIRING_RELAXATION_FLOOR: f64 = 0.125;

/// Contraction of the pairing fixed point assumed at least (measured 0.003-0.06 per re-pairing
/// on the McColl scene at 4 increments per cycle).
const PAIRING_CONTRACTION_FLOOR: f64 = 0.1;

impl<'m> StepSolver<'m> {
    /// Solves output step `request.step` (to time `request.time`) of a finite-sliding model in
    /// the pairing of the step's own end configuration, a fixed point on the pairing:
    ///
    /// ```text
    /// u_pair = guess of the step's end (or its start)
    /// repeat: pair the surfaces in X + u_pair (slips measured from u_start);
    ///         solve the step from the start state -> u, p;  u_pair = u
    /// until the error estimate of p, |dp| rho / (1 - rho), is at most PAIRING_TOLERANCE p_max
    /// ```
    ///
    /// (`dp` the change of the pressures from the last solve, `rho` the observed contraction
    /// `|dp_k| / |dp_k-1|`, at least [`PAIRING_CONTRACTION_FLOOR`]; 1 until two changes are
    /// known), so that the end of a step does not depend on how far it slid (the pairing of the
    /// step's start lags the stroke by the whole increment: on a curved contact a step sliding
    /// several elements then reads the counter-surface's indentation where it no longer is).
    /// Between re-pairings only the contact rows change: `K_rho` keeps its factorisation. Paired
    /// first at a guess, the pairing at the solution is formed (the next pairing needs it
    /// anyway) and its pressure change estimated from the interface stiffness: a change below
    /// the tolerance settles the step without a second solve. A failure leaves the state at the
    /// step's start.
    pub(super) fn solve_paired(
        &mut self,
        state: &mut SimState,
        request: StepRequest,
    ) -> Result<SolvedStep, AnalysisError> {
        self.start.save(state);
        let out = self.pairing_fixed_point(state, &request);
        if out.is_err() {
            self.start.restore(state);
        }
        out
    }

    fn pairing_fixed_point(
        &mut self,
        state: &mut SimState,
        request: &StepRequest,
    ) -> Result<SolvedStep, AnalysisError> {
        let (model, step, t, guess) = (self.model, request.step, request.time, request.pairing_guess);
        // The first pairing, formed beside the last step's check, serves a step paired at a guess.
        let (mut prepared, mut prepared_rows) =
            self.ahead.take().filter(|_| guess.is_some()).map_or((None, None), |a| (Some(a.pairing), a.rows));
        let mut u_pair = guess.map_or_else(|| state.u.clone(), <[f64]>::to_vec);
        let mut last_pressure: Option<Vec<f64>> = None;
        let mut fixed_point = FixedPoint::default();
        let mut iterations = 0;
        // The next step's first pairing, formed beside this step's check at its first solution.
        let mut upcoming: Option<Discretisation> = None;
        // Each solve starts from the sets the last one converged to (the first: those asked).
        let mut start_sets = Some(request.start_sets.clone().unwrap_or_default());
        let mut relaxation: f64 = 1.0;
        let mut pairing = 0;
        while pairing < if relaxation < 1.0 { 2 * MAX_PAIRINGS } else { MAX_PAIRINGS } {
            pairing += 1;
            let t0 = std::time::Instant::now();
            let paired = prepared.take().unwrap_or_else(|| self.geometry.repaired_at(model, &u_pair, &self.start.u));
            let pairing_time = t0.elapsed().as_secs_f64();
            self.timings.repairing += pairing_time;
            self.timings.pairings += pairing_time;
            let kept_bulk = self.bulk_set_up || pairing > 1;
            let paired = Arc::new(paired);
            let mut analysis = self.pairing_analysis(&paired, kept_bulk, prepared_rows.take(), start_sets.take())?;
            if pairing > 1 {
                self.start.restore(state);
            }
            let t1 = std::time::Instant::now();
            let mut report = analysis.advance_to(state, step, t)?;
            self.timings.solve += t1.elapsed().as_secs_f64();
            iterations += report.iterations;
            let nt = model.constraints.len();
            let pressure: Vec<f64> =
                (0..paired.contact.rows.len()).map(|k| (-state.multipliers[nt + k]).max(0.0)).collect();
            if let Some(last) = &last_pressure {
                fixed_point.observe(&pressure, last, guess.is_some());
            }
            if pairing == 1 && guess.is_some() {
                let t0 = std::time::Instant::now();
                let next_guess = request.next_guess;
                let next;
                (next, upcoming) = paired_at_solution(model, &self.geometry, &state.u, &self.start.u, next_guess);
                self.timings.pairings += t0.elapsed().as_secs_f64();
                if let Some(linear) = linear_pairing_change(model, &paired, &next, &analysis, state) {
                    fixed_point.linear(linear);
                }
                prepared = Some(next);
                self.timings.repairing += t0.elapsed().as_secs_f64();
            }
            let FixedPoint { change, estimate, .. } = fixed_point;
            tracing::debug!(
                step,
                pairing,
                change,
                estimate,
                iterations = report.iterations,
                "finite sliding: step solved in its pairing"
            );
            let at_rest = pairing == 1 && guess.is_none() && !state_slid(&paired, state, &self.start.u);
            if estimate <= PAIRING_TOLERANCE || (pairing > 1 && change == 0.0) || at_rest {
                check_on_counter_surface(model, &self.geometry, &paired, state, step, t)?;
                report.iterations = iterations;
                let next = upcoming.take().filter(|_| pairing == 1);
                let solved = self.settled(&analysis, paired, next, report, request.sensitivity);
                self.reuse = analysis.into_reuse();
                // The interface log of a per-step operator means nothing to the next step.
                state.interface_log.clear();
                return Ok(solved);
            }
            // The next pairing's solve starts from this one's sets.
            start_sets = analysis.converged_sets().cloned();
            self.reuse = analysis.into_reuse();
            last_pressure = Some(pressure);
            if pairing > 2 && fixed_point.contraction >= 1.0 {
                relaxation = (0.5 * relaxation).max(PAIRING_RELAXATION_FLOOR);
                tracing::debug!(step, pairing, relaxation, "finite sliding: the pairing does not contract; relaxed");
            }
            if relaxation < 1.0 {
                for (p, &u) in u_pair.iter_mut().zip(&state.u) {
                    *p += relaxation * (u - *p);
                }
            } else {
                u_pair.clone_from(&state.u);
            }
        }
        Err(AnalysisError::PairingNotSettled { step, time: t, pairings: pairing, change: fixed_point.change })
    }

    /// The analysis of one pairing of a finite-sliding step, its solve starting from `sets`. On
    /// a bulk already factored (`kept_bulk`) only the pairing's interface rows and operator are
    /// formed, or taken as `rows` if they were prepared on it beforehand. Runs without wear or
    /// moving surfaces keep one bulk for every step and form each pairing's operator from the
    /// surfaces' compliance (see [`StaticAnalysis::for_pairings`]: the choice depends on the
    /// case alone, so that a restart makes the same).
    fn pairing_analysis(
        &mut self,
        paired: &Arc<Discretisation>,
        kept_bulk: bool,
        rows: Option<PreparedRows>,
        sets: Option<ContactSets>,
    ) -> Result<StaticAnalysis<'m>, AnalysisError> {
        let t0 = std::time::Instant::now();
        let handed = self.reuse.take().map(|r| match (kept_bulk, rows) {
            (true, Some(rows)) => r.with_same_bulk().with_prepared(rows),
            (true, None) => r.with_same_bulk(),
            (false, _) => r,
        });
        let surface_compliance = self.model.wear.is_empty() && !self.model.has_moving_surfaces();
        let mut analysis = StaticAnalysis::for_pairings(self.model, Arc::clone(paired), handed, surface_compliance)?;
        self.bulk_set_up = true;
        analysis.set_parallel(self.options.parallel);
        if let Some(sets) = sets {
            analysis.start_from_sets(sets);
        }
        *(if kept_bulk { &mut self.timings.repairing } else { &mut self.timings.setup }) += t0.elapsed().as_secs_f64();
        self.timings.count_setup(&analysis);
        Ok(analysis)
    }

    /// The solved step of a settled pairing. If the next step starts where it settled (`next`:
    /// its first pairing), the next step's interface rows and operator are formed on this
    /// step's factor beside the interface sensitivity, and kept for it.
    fn settled(
        &mut self,
        analysis: &StaticAnalysis,
        paired: Arc<Discretisation>,
        next: Option<Discretisation>,
        report: StepReport,
        sensitivity: bool,
    ) -> SolvedStep {
        let sensitivity_of = || if sensitivity { analysis.gap_sensitivity_with_open_rows() } else { None };
        let sensitivity = match next {
            Some(next) => {
                let (rows, sensitivity) = rayon::join(|| analysis.prepare_rows(&next), sensitivity_of);
                self.ahead = Some(Ahead { pairing: next, rows });
                sensitivity
            }
            None => sensitivity_of(),
        };
        SolvedStep {
            report,
            disc: paired,
            start_u: self.start.u.clone(),
            start_multipliers: self.start.multipliers.clone(),
            sets: analysis.converged_sets().cloned(),
            sensitivity,
        }
    }
}

/// The error estimate of the pairing fixed point: the last pressure change (relative to the
/// largest pressure), the one before, and the estimate of the remaining error.
#[derive(Clone, Copy)]
struct FixedPoint {
    change: f64,
    last_change: f64,
    estimate: f64,
    /// The last observed ratio of successive changes (infinite until two are known).
    contraction: f64,
}

impl Default for FixedPoint {
    fn default() -> Self {
        let inf = f64::INFINITY;
        FixedPoint { change: inf, last_change: inf, estimate: inf, contraction: inf }
    }
}

impl FixedPoint {
    /// A solve's pressures against the last one's; `guessed`: the step was paired first at a
    /// guess of its end.
    fn observe(&mut self, pressure: &[f64], last: &[f64], guessed: bool) {
        let p_max = pressure.iter().fold(0.0_f64, |a, &b| a.max(b)).max(f64::MIN_POSITIVE);
        self.change = pressure.iter().zip(last).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / p_max;
        if self.last_change.is_finite() {
            self.contraction = self.change / self.last_change.max(f64::MIN_POSITIVE);
        }
        let rho = if self.last_change.is_finite() {
            Some((self.change / self.last_change).max(PAIRING_CONTRACTION_FLOOR))
        } else {
            // Paired first at a guess of the end: the second pairing's change is already the
            // fixed point's last one; its contraction is taken at the floor (measured below it).
            guessed.then_some(PAIRING_CONTRACTION_FLOOR)
        };
        if let Some(rho) = rho {
            self.estimate = if rho < 1.0 { self.change * rho / (1.0 - rho) } else { f64::INFINITY };
        }
        self.last_change = self.change;
    }

    /// The linearised pressure change of a re-pairing at the first solution (see
    /// [`linear_pairing_change`]).
    fn linear(&mut self, linear: f64) {
        self.change = linear;
        let floor = PAIRING_CONTRACTION_FLOOR;
        self.estimate = LINEAR_PAIRING_SAFETY * linear * floor / (1.0 - floor);
    }
}

/// The pairing of `current` at a step's solution `u` (slips from the step's start `u_start`)
/// and, side by side with it, the next step's first pairing at its guess `next_guess` (slips
/// from `u`: the next step starts where this one ends if it settles here).
fn paired_at_solution(
    model: &Model,
    current: &Discretisation,
    u: &[f64],
    u_start: &[f64],
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
/// The pressure change that re-pairing a converged finite-sliding step would cause, relative
/// to the largest pressure, linearised: the weighted gaps of the active rows at the solution
/// in the pairing `next` (formed at the solution) against those in the step's pairing
/// `paired`, times the interface stiffness of the converged state. `None` without the
/// stiffness (no interface condensation) or when a row open in `model` would penetrate in
/// `next` (the contact set would change: only a solve tells).
fn linear_pairing_change(
    model: &Model,
    paired: &Discretisation,
    next: &Discretisation,
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
    base: &Discretisation,
    paired: &Discretisation,
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
