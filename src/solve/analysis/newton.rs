//! The monolithic Newton solve of a load step: the saddle point of the bulk tangent and the
//! constraint rows (ties, contact normals, friction) by their semi-smooth laws (Alart-Curnier
//! conditions, see `src/contact`), multipliers scaled by `alpha` so that both blocks keep the
//! same magnitude in the LU factorisation. Used where interface condensation does not apply
//! (no contact rows, or a forced monolithic solve); the condensed path iterates the same
//! linear systems rearranged (see `active_set`).

use super::*;

impl StaticAnalysis<'_> {
    /// One Newton solve from the converged `state` to time `t`. Converged: commits `state`;
    /// not converged: leaves it untouched so the caller can cut back. Linear-solver failures are
    /// errors.
    pub(super) fn newton(&mut self, state: &mut SimState, step: usize, t: f64) -> Result<StepOutcome, AnalysisError> {
        if self.condensed.is_some() {
            return self.newton_condensed(state, step, t);
        }
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
        let mut sets = SetIterate::new(disc.contact.rows.len(), disc.contact.friction_rows.len());
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
            let iterate = Iterate { u: &u, mu: &mu, sets: &sets };
            let out = ResidualBuffers { r: &mut r, ct_mu: &mut ct_mu };
            let scales = self.monolithic_residual(iterate, &state.history, &f_ext, need_tangent, out);
            // 4. Norms: forces, gaps, free multipliers, each against its own scale.
            let parts = ResidualParts { r: &r, f_ext: &f_ext, ct_mu: &ct_mu, mu: &mu, sets: &sets };
            let norms = self.residual_norms(parts, scales, &mut step_scale);
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
        u: &[f64],
        mu: &[f64],
        frozen: Option<&NewtonSystem>,
    ) -> Option<NewtonSystem> {
        if self.condensed.is_some() {
            return None;
        }
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
                let mut sets = SetIterate::new(nc, nfr);
                sets.update(&disc.contact, u, &state.u, mu, false);
                sets
            }
        };
        let mut f_ext = vec![0.0; disc.dofs.num_dofs];
        m.external_force(t, &mut f_ext);
        let mut rhs = vec![0.0; nf + nm];
        let mut ct_mu = vec![0.0; disc.dofs.num_dofs];
        let iterate = Iterate { u, mu, sets: &sets };
        let out = ResidualBuffers { r: &mut rhs, ct_mu: &mut ct_mu };
        self.monolithic_residual(iterate, &state.history, &f_ext, true, out);
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
    pub(super) fn monolithic_residual(
        &mut self,
        iterate: Iterate,
        history: &[PlasticState],
        f_ext: &[f64],
        tangent: bool,
        out: ResidualBuffers,
    ) -> ConstraintScales {
        let (Iterate { u, mu, sets }, ResidualBuffers { r, ct_mu }) = (iterate, out);
        let shared = Arc::clone(&self.disc);
        let disc: &Discretisation = &shared;
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
    pub(super) fn constraint_residual(
        &self,
        u: &[f64],
        mu: &[f64],
        sets: &SetIterate,
        laws: &[RowLaw],
        r: &mut [f64],
        ct_mu: &mut [f64],
    ) -> ConstraintScales {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
        ConstraintScales { gap_scale_sq: g_scale, slip_residual: slip_res }
    }

    /// The contact rows' entries of the tangent for the current laws: `C` and `C^T` where a row
    /// is a constraint, the identity where it is free, `-coef` coupling a slip row to its normal.
    pub(super) fn scatter_contact_tangent(&mut self, laws: &[RowLaw]) {
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
    pub(super) fn residual_norms(
        &self,
        parts: ResidualParts,
        scales: ConstraintScales,
        step_scale: &mut f64,
    ) -> ResidualNorms {
        let ResidualParts { r, f_ext, ct_mu, mu, sets } = parts;
        let ConstraintScales { gap_scale_sq: g_scale, slip_residual: slip_res } = scales;
        let (m, shared) = (self.model, Arc::clone(&self.disc));
        let disc: &Discretisation = &shared;
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
}

/// The scales of the constraint rows' residual: the squared scale `sum (|C| |u|)^2` of the gap
/// rows and the largest slip-law residual.
#[derive(Clone, Copy)]
pub(super) struct ConstraintScales {
    pub(super) gap_scale_sq: f64,
    pub(super) slip_residual: f64,
}

/// The parts of a monolithic Newton residual that its norms read: the right-hand side `r`, the
/// external and constraint forces, the multipliers and the contact sets of the iterate.
pub(super) struct ResidualParts<'a> {
    pub(super) r: &'a [f64],
    pub(super) f_ext: &'a [f64],
    pub(super) ct_mu: &'a [f64],
    pub(super) mu: &'a [f64],
    pub(super) sets: &'a SetIterate,
}

/// A monolithic Newton iterate: displacements, multipliers and the contact sets of its laws.
#[derive(Clone, Copy)]
pub(super) struct Iterate<'a> {
    pub(super) u: &'a [f64],
    pub(super) mu: &'a [f64],
    pub(super) sets: &'a SetIterate,
}

/// Where a monolithic residual is written: the right-hand side `r` and the constraint forces
/// `C^T mu`.
pub(super) struct ResidualBuffers<'a> {
    pub(super) r: &'a mut [f64],
    pub(super) ct_mu: &'a mut [f64],
}
