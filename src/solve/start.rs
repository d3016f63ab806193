//! The start of a step, saved so that a re-pairing or a cut solves again from there (history
//! advances only from converged steps).

use crate::state::SimState;

/// What the solve of a finite-sliding step changes in the state, saved at the step's start so
/// that a re-pairing solves again from there (and a refused step leaves its step, time,
/// displacements, multipliers, friction fields and history where they started). The stresses
/// are left out: derived from the displacements and the history, every solve writes them
/// wherever there is material (points without material keep theirs, which no solve changes),
/// so a re-pairing's solve gives the same bits; after a refused step they are its last
/// solve's. So is the wear state, which the solve does not touch. Its buffers are refilled
/// step after step, not reallocated.
#[derive(Default)]
pub(super) struct StepStart {
    pub(super) step: usize,
    pub(super) time: f64,
    pub(super) load_factor: f64,
    pub(super) u: Vec<f64>,
    pub(super) history: Vec<crate::fem::material::PlasticState>,
    pub(super) f_int: Vec<f64>,
    pub(super) multipliers: Vec<f64>,
    pub(super) friction_status: Vec<u8>,
    pub(super) slip_increment: Vec<f64>,
    pub(super) accumulated_slip: Vec<f64>,
    pub(super) dissipation: f64,
    pub(super) interface_log: Vec<Vec<usize>>,
}

impl StepStart {
    pub(super) fn save(&mut self, s: &SimState) {
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

    pub(super) fn restore(&self, s: &mut SimState) {
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
