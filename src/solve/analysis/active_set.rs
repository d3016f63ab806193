//! The condensed active-set iteration of a load step (see `condensed` for the operator): per
//! refinement pass, the bulk predictor `z = K_rho^{-1} r_u`, the semi-smooth active-set
//! iterations on the live interface rows, the recovery of `u` and the multipliers (growing the
//! interface set where a row outside it would penetrate or is loaded), and the equilibrium
//! check of the recovered state; a line search for yielding bodies.

use super::*;

impl StaticAnalysis<'_> {
    /// One load step by interface condensation (see [`condensed`]): the active-set iterations
    /// run on the L live multipliers only; the bulk is touched by two solves with the constant
    /// factor of `K_rho` and two internal-force evaluations.
    pub(super) fn newton_condensed(
        &mut self,
        state: &mut SimState,
        step: usize,
        t: f64,
    ) -> Result<StepOutcome, AnalysisError> {
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
    pub(super) fn condensed_step(
        &mut self,
        cd: &mut condensed::Condensed,
        state: &mut SimState,
        step: usize,
        t: f64,
    ) -> Result<StepOutcome, AnalysisError> {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
            self.pass_operator(cd, &state.u, &u, &history, PassAt { pass, step, iterations })?;
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
            let mut sets = SetIterate::new(nc, nfr);
            let mut mu = loop {
                let predictor = Predictor { z: &z, start: &start, lam0: &lam0 };
                let (dlam, dw) = match self.interface_iterations(cd, predictor, &mut sets, step, t)? {
                    InterfaceSolve::Solved { dlam, dw, iterations: its } => {
                        iterations += its;
                        (dlam, dw)
                    }
                    InterfaceSolve::Failed(outcome) => {
                        self.last_gross_sliding = self.unrestrained_gross_sliding(&sets.status);
                        return Ok(outcome);
                    }
                };
                self.recover_displacement(cd, InterfaceChange { z: &z, dlam: &dlam, dw: &dw }, &start.u_start, &mut u)
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
            let force = ForceScale { f_ext: &f_ext, scale0 };
            let mut res = self.residual_at(&u, &mu, &history, force, plastic);
            if self.line_search && pass > 0 && res > last_res {
                let line_start = LineStart { u: &start.u_start, lambda: &lam0 };
                res = self.backtrack(line_start, &mut u, &mut mu, &history, force, last_res);
            }
            last_res = res;
            tracing::debug!(step, t, iterations, residual = res, "condensed step");
            if res.is_finite() && res <= p.rtol {
                check_small_sliding(disc, &u, &sets.status, step, t)?;
                self.commit(state, u, mu, t, &sets.status, &sets.slip);
                self.last_sets = Some(ContactSets { active: sets.active, status: sets.status });
                return Ok(StepOutcome::Converged { iterations, bulk: pass + 1, residual: res });
            }
            let first = *first_res.get_or_insert(res);
            let progress = PassProgress { pass, passes, first_residual: first, residual: res };
            if self.gives_up(&sets.status, progress, step, t)? {
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
    pub(super) fn force_scale(&self, state: &SimState, f_ext: &[f64]) -> f64 {
        let mut ct = vec![0.0; self.disc.dofs.num_dofs];
        constraint_forces(self.model, &self.disc, &state.multipliers, &mut ct);
        norm(f_ext).max(norm(&state.f_int)).max(norm(&ct))
    }

    /// Relative equilibrium residual of `(u, mu)` on the free equations (the step's force scale
    /// `scale0` or the forces there, whichever is larger); leaves force, stresses, trial
    /// history (and with `tangent` the tangent) of `u` in the trial buffers.
    pub(super) fn residual_at(
        &mut self,
        u: &[f64],
        mu: &[f64],
        history: &[PlasticState],
        force: ForceScale,
        tangent: bool,
    ) -> f64 {
        let ForceScale { f_ext, scale0 } = force;
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
    pub(super) fn backtrack(
        &mut self,
        line_start: LineStart,
        u: &mut [f64],
        mu: &mut [f64],
        history: &[PlasticState],
        force: ForceScale,
        last: f64,
    ) -> f64 {
        let LineStart { u: u_start, lambda: lam_start } = line_start;
        let (u_full, mu_full) = (u.to_vec(), mu.to_vec());
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
    pub(super) fn pulled_off_contact(&self, t: f64) -> Option<(String, char, f64)> {
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
    pub(super) fn unrestrained_gross_sliding(&self, status: &[FrictionStatus]) -> Option<usize> {
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
    pub(super) fn gives_up(
        &mut self,
        status: &[FrictionStatus],
        progress: PassProgress,
        step: usize,
        t: f64,
    ) -> Result<bool, AnalysisError> {
        let PassProgress { pass, passes, first_residual: first, residual: res } = progress;
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
    pub(super) fn pass_operator(
        &mut self,
        cd: &mut condensed::Condensed,
        u_conv: &[f64],
        u: &[f64],
        history: &[PlasticState],
        at: PassAt,
    ) -> Result<(), AnalysisError> {
        let PassAt { pass, step, iterations } = at;
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
    pub(super) fn predictor_force(&mut self, u_conv: &[f64], u0: &[f64], history: &[PlasticState]) {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
    pub(super) fn elastic_operator(&mut self, cd: &mut condensed::Condensed, step: usize) -> Result<(), AnalysisError> {
        if !cd.tangent {
            return Ok(());
        }
        let linear = |source| NewtonError::Linear { step, iteration: 0, source };
        cd.refactor(self.model, &self.disc, &self.assembler.pattern, &mut self.solver, &mut self.values, false)
            .map_err(linear)?;
        Ok(())
    }

    /// Yielding bodies: puts into the factor and the interface operator the consistent tangent
    /// the last assembly left (at `u`, from the converged `history`) where a point yields there;
    /// the elastic `K_rho` where none does (kept when it is already that).
    pub(super) fn tangent_at(
        &mut self,
        cd: &mut condensed::Condensed,
        history: &[PlasticState],
        step: usize,
        iteration: usize,
    ) -> Result<(), AnalysisError> {
        let yielding = self.trial_history.iter().zip(history).any(|(a, b)| a != b);
        let linear = |source| NewtonError::Linear { step, iteration, source };
        if yielding {
            let (m, shared) = (self.model, Arc::clone(&self.disc));
            let disc: &Discretisation = &shared;
            cd.refactor(m, disc, &self.assembler.pattern, &mut self.solver, &mut self.tangent_values, true)
                .map_err(linear)?;
        } else if cd.tangent {
            self.elastic_operator(cd, step)?;
        }
        Ok(())
    }

    /// The active-set iterations on the live interface rows for the bulk predictor `z` (see
    /// [`Self::interface_iterations_from`]), from the sets handed to
    /// [`Self::start_from_sets`] if any: should those fail, again from the prediction (a start
    /// far from the answer must not change the path), and should the prediction's sets cycle,
    /// again with the augmentation scaled by each of [`CYCLE_BREAKING_AUGMENTATION`] before the
    /// caller cuts back.
    ///
    /// Why the scaled retries: the next set of a primal-dual active-set (semi-smooth Newton)
    /// iteration depends on the augmentation `eps`, its fixed points do not (Hintermüller, Ito &
    /// Kunisch, SIAM J Optim 13 (2002) 865: the complementarity function's constant changes the
    /// path, not the solution). A rounded corner resting on one to three nodes with friction
    /// sends the iteration round a cycle of a dozen sets at every increment size, so cutting
    /// back does not help (a free punch at mu 0.3 stopped in its seventh cycle at 1/256 of an
    /// increment); another `eps` leaves the cycle and reaches the same law's solution.
    pub(super) fn interface_iterations(
        &mut self,
        cd: &condensed::Condensed,
        predictor: Predictor,
        sets: &mut SetIterate,
        step: usize,
        t: f64,
    ) -> Result<InterfaceSolve, AnalysisError> {
        // Sets of another row layout (another pairing's model) are no start.
        let (nc, nfr) = (self.disc.contact.rows.len(), self.disc.contact.friction_rows.len());
        let given = self.start_sets.take().filter(|g| g.active.len() == nc && g.status.len() == nfr);
        let predicted = std::iter::once(1.0)
            .chain(CYCLE_BREAKING_AUGMENTATION)
            .map(|augmentation| SetStart::Predicted { augmentation })
            .chain(std::iter::once(SetStart::Restrained));
        // Iterations of the failed starts (added to a solve's count), and of the last one (the
        // count a failure reports: each start has the whole iteration limit).
        let (mut spent, mut last) = (0, 0);
        for start in given.map(SetStart::Given).into_iter().chain(predicted) {
            let from = start.describe();
            match self.interface_iterations_from(cd, predictor, sets, start, step, t)? {
                InterfaceSolve::Solved { dlam, dw, iterations } => {
                    return Ok(InterfaceSolve::Solved { dlam, dw, iterations: iterations + spent });
                }
                InterfaceSolve::Failed(StepOutcome::NotConverged { iterations, .. }) => {
                    spent += iterations;
                    last = iterations;
                    tracing::debug!(
                        step,
                        t,
                        iterations,
                        from,
                        "active-set iterations failed: again from another start"
                    );
                }
                failed => return Ok(failed),
            }
        }
        Ok(InterfaceSolve::Failed(StepOutcome::NotConverged { iterations: last, residual: f64::INFINITY }))
    }

    /// The active-set iterations on the live interface rows for the bulk predictor `z`: each
    /// iteration updates the sets from the current interface values (the first from the
    /// given sets of `start_sets`, else the augmented-Lagrangian prediction from the step's
    /// start; every prediction with its augmentation factor), then solves the dense interface
    /// system of their laws for the multiplier and row-value changes `dlam`, `dw`. Stops when
    /// the sets repeat; fails (the caller tries another start, then cuts back) when they cycle,
    /// do not settle within `max_set_iterations` (default: one per live contact row, at least
    /// the Newton limit), or the interface system is singular.
    pub(super) fn interface_iterations_from(
        &mut self,
        cd: &condensed::Condensed,
        predictor: Predictor,
        sets: &mut SetIterate,
        start_sets: SetStart,
        step: usize,
        t: f64,
    ) -> Result<InterfaceSolve, AnalysisError> {
        let restrained = matches!(start_sets, SetStart::Restrained);
        let (mut given, augmentation) = match start_sets {
            SetStart::Given(sets) => (Some(sets), 1.0),
            SetStart::Predicted { augmentation } => (None, augmentation),
            SetStart::Restrained => (None, 1.0),
        };
        let Predictor { z, start, lam0 } = predictor;
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
        let mut seen: Vec<ContactSets> = vec![];
        let mut ran_away = false;
        let size = if restrained { model_size(m) } else { f64::INFINITY };
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
                Some(given) => given_sets(&disc.contact, &given, &mut sets.active, &mut sets.status),
                // The last set left a body a mechanism (see `ran_away`): the same rows in
                // contact, those slipping stuck, so that the next solve is restrained; Coulomb's
                // law decides their status again from its answer.
                None if ran_away => {
                    for st in sets.status.iter_mut().filter(|st| matches!(st, FrictionStatus::Slip(_))) {
                        *st = FrictionStatus::Stick;
                    }
                }
                None => update_sets(
                    &disc.contact,
                    SetValues { mult: &mult, gaps: &sets.gaps, slip: &sets.slip, augmentation },
                    it == 0,
                    Some(&live_rows),
                    &mut sets.active,
                    &mut sets.status,
                ),
            }
            self.last_active = sets.active.iter().filter(|&&a| a).count();
            keep_to_live_rows(&disc.contact, cd, nt, it == 0, &live_rows, sets);
            if let Some(ContactSets { active: pa, status: ps }) = seen.last() {
                if pa == &sets.active && ps == &sets.status {
                    break;
                }
            }
            let cycling = seen.iter().any(|s| s.active == sets.active && s.status == sets.status);
            if cycling || it == max_iterations {
                if tracing::enabled!(tracing::Level::DEBUG) {
                    let sets = visited_sets(&seen, sets, nc);
                    tracing::debug!(step, t, it, cycling, sets, "interface active set does not settle");
                }
                return failed(it);
            }
            seen.push(ContactSets { active: sets.active.clone(), status: sets.status.clone() });
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
            // A set that leaves a body a mechanism (a free punch on one slipping node) runs away
            // on the grounding rows (gaps of 6e8 on a 5 mm model); its update cycles back to it.
            if restrained {
                let worst = (0..nc).filter_map(|k| cd.live_of[nt + k].map(|a| dw[a].abs())).fold(0.0, f64::max);
                ran_away = worst > size && sets.status.iter().any(|st| matches!(st, FrictionStatus::Slip(_)));
                tracing::debug!(step, t, it, worst, ran_away, "restrained start: largest row change");
            }
        }
        Ok(InterfaceSolve::Solved { dlam, dw, iterations })
    }

    /// A row outside the interface set that would penetrate at `u` joins it (with its
    /// neighbours within the candidate margin); returns whether the set grew (the step's
    /// interface problem is then solved again).
    pub(super) fn grow_where_penetrating(
        &self,
        cd: &mut condensed::Condensed,
        u: &[f64],
        step: usize,
        t: f64,
        iterations: usize,
    ) -> Result<bool, AnalysisError> {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
    pub(super) fn recover_displacement(
        &self,
        cd: &condensed::Condensed,
        change: InterfaceChange,
        u_start: &[f64],
        u: &mut Vec<f64>,
    ) -> Result<(), crate::solver::linear::LinearSolverError> {
        let InterfaceChange { z, dlam, dw } = change;
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
    pub(super) fn grow_where_loaded(
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
    pub(super) fn grow_set(
        &self,
        cd: &mut condensed::Condensed,
        rows: &[usize],
        step: usize,
        iterations: usize,
    ) -> Result<(), AnalysisError> {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
        let batch = condensed::with_friction(m, disc, rows);
        cd.grow(m, disc, &self.solver, &batch, 0.0).map_err(|source| NewtonError::Linear {
            step,
            iteration: iterations,
            source,
        })?;
        cd.log.push(batch);
        Ok(())
    }
}

/// The sets an interface iteration visited, in order and ending with the current one: each as
/// its active rows, then the statuses of the rows in contact (what a debug log of a cycle shows:
/// a punch rocking between its edges reads `[57][Slip(false)] -> [8, 9, 10, 11, 12, 57][..]`).
fn visited_sets(seen: &[ContactSets], current: &SetIterate, nc: usize) -> String {
    let one = |active: &[bool], status: &[FrictionStatus]| {
        let on: Vec<usize> = (0..nc).filter(|&k| active[k]).collect();
        let st: Vec<String> = status.iter().filter(|x| **x != FrictionStatus::Open).map(|x| format!("{x:?}")).collect();
        format!("{on:?}{st:?}")
    };
    seen.iter()
        .map(|s| one(&s.active, &s.status))
        .chain(std::iter::once(one(&current.active, &current.status)))
        .collect::<Vec<_>>()
        .join(" -> ")
}

/// Rows outside the condensed set `cd` stay open (checked after the solve). Given sets whose
/// rows this set lacks leave nothing active in the `first` iteration: then the rows where the
/// bodies touch first start active (sticking), as the prediction does (else a body that only
/// contact holds floats on the grounding springs and its solve runs away).
fn keep_to_live_rows(
    contact: &ContactSet,
    cd: &condensed::Condensed,
    nt: usize,
    first: bool,
    live_rows: &[bool],
    sets: &mut SetIterate,
) {
    let nc = contact.rows.len();
    for k in (0..nc).filter(|&k| cd.live_of[nt + k].is_none()) {
        sets.active[k] = false;
    }
    for j in (0..contact.friction_rows.len()).filter(|&j| cd.live_of[nt + nc + j].is_none()) {
        sets.status[j] = FrictionStatus::Open;
    }
    if first && !sets.active.iter().any(|&a| a) {
        activate_closest(contact, &sets.gaps, Some(live_rows), &mut sets.active);
        for (j, st) in sets.status.iter_mut().enumerate() {
            if sets.active[contact.friction_normal[j]] && cd.live_of[nt + nc + j].is_some() {
                *st = FrictionStatus::Stick;
            }
        }
    }
}

/// The diagonal of the model's bounding box: no increment moves a row by more.
fn model_size(m: &Model) -> f64 {
    use parry2d_f64::{bounding_volume::Aabb, math::Vector};
    Aabb::from_points(m.coords.iter().map(|p| Vector::new(p.x, p.y))).extents().length()
}

/// Factors on the contact's augmentation for the retries of a step's active-set iterations
/// after the predicted sets cycled (see [`StaticAnalysis::interface_iterations`]): each tried
/// in turn, smaller and larger, a decade and then two from the contact's own.
const CYCLE_BREAKING_AUGMENTATION: [f64; 4] = [0.1, 10.0, 0.01, 100.0];

/// Where a step's active-set iterations start: from given sets (a step's first solve, the
/// last computed cycle at the same increment), or from the augmented-Lagrangian prediction
/// with the contact's augmentation scaled by `augmentation` (1: its own).
pub(super) enum SetStart {
    Given(ContactSets),
    Predicted {
        augmentation: f64,
    },
    /// The prediction, where a set that leaves a body a mechanism (its solve runs away on the
    /// grounding rows) is followed by the same set with its slipping rows stuck: the last start.
    Restrained,
}

impl SetStart {
    fn describe(&self) -> String {
        match self {
            SetStart::Given(_) => "the given sets".to_string(),
            SetStart::Predicted { augmentation } => format!("the prediction, augmentation x{augmentation}"),
            SetStart::Restrained => "the prediction, mechanisms restrained".to_string(),
        }
    }
}

/// The bulk predictor of a refinement pass that the interface iterations start from: `z =
/// K_rho^{-1} r_u`, the interface values at the step's start, and the multipliers at the
/// pass's start.
#[derive(Clone, Copy)]
pub(super) struct Predictor<'a> {
    pub(super) z: &'a [f64],
    pub(super) start: &'a InterfaceStart,
    pub(super) lam0: &'a [f64],
}

/// Where a condensed step's refinement passes stand: pass `pass` of at most `passes`, the first
/// pass's residual and the current one.
#[derive(Clone, Copy)]
pub(super) struct PassProgress {
    pub(super) pass: usize,
    pub(super) passes: usize,
    pub(super) first_residual: f64,
    pub(super) residual: f64,
}

/// The step's external force and its force scale (the residual is measured against the larger
/// of the scale and the forces at the point).
#[derive(Clone, Copy)]
pub(super) struct ForceScale<'a> {
    pub(super) f_ext: &'a [f64],
    pub(super) scale0: f64,
}

/// A refinement pass of a condensed step: its index, the output step and the iterations spent
/// (for the errors it may report).
#[derive(Clone, Copy)]
pub(super) struct PassAt {
    pub(super) pass: usize,
    pub(super) step: usize,
    pub(super) iterations: usize,
}

/// The solution of the interface system: the bulk predictor `z`, the multiplier changes
/// `dlam` and the row-value changes `dw` of the live rows.
#[derive(Clone, Copy)]
pub(super) struct InterfaceChange<'a> {
    pub(super) z: &'a [f64],
    pub(super) dlam: &'a [f64],
    pub(super) dw: &'a [f64],
}

/// Where a line search starts: the displacements and multipliers of the pass's start.
#[derive(Clone, Copy)]
pub(super) struct LineStart<'a> {
    pub(super) u: &'a [f64],
    pub(super) lambda: &'a [f64],
}
