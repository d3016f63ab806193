//! `SimState`: the one mutable struct of a simulation, everything a checkpoint must hold to
//! resume bit for bit. All problem data (meshes, materials, loads) lives in the immutable
//! `Model`. History advances only from converged steps: the analysis computes trial values in
//! its own buffers and commits them here when a step converges.

use crate::contact::ContactUnknowns;
use crate::fem::material::{PlasticState, Stress4};
pub use crate::wear::WearState;

#[derive(Debug, Clone, PartialEq)]
pub struct SimState {
    /// Index of the last converged output step (0: initial state).
    pub step: usize,
    pub time: f64,
    pub load_factor: f64,
    /// Global displacements, two per node.
    pub u: Vec<f64>,
    /// History of every stateful integration point (fixed material points).
    pub history: Vec<PlasticState>,
    /// Stress at every integration point (derived from `u` and `history`, kept for output).
    pub stress: Vec<Stress4>,
    /// Internal force at every DOF (reactions at constrained DOFs).
    pub f_int: Vec<f64>,
    /// Lagrange multipliers: tying rows, contact normals (`lambda_n`), contact tangents
    /// (`lambda_t`), in the model's multiplier order.
    pub multipliers: Vec<f64>,
    /// Per friction row: Coulomb status of the last converged increment (0 open, 1 stick, 2 slip).
    pub friction_status: Vec<u8>,
    /// Per friction row: weighted slip `int Phi ds_t` of the last converged increment (0 for
    /// nodes open at its end).
    pub slip_increment: Vec<f64>,
    /// Per friction row: accumulated `|int Phi ds_t|` over the increments that ended in contact
    /// (Archard wear reads it).
    pub accumulated_slip: Vec<f64>,
    /// Frictional energy dissipated so far, `sum lambda_t . int Phi ds_t` (per unit thickness).
    pub dissipation: f64,
    /// Solver memory a bit-for-bit restart needs: the multiplier rows the interface-condensation
    /// operator grew by, batch by batch, up to this state (empty without condensation).
    pub interface_log: Vec<Vec<usize>>,
    /// Wear state (empty without wearing surfaces).
    pub wear: WearState,
    /// Ghost-penalty faces born after the start on re-cut bodies of path-dependent material.
    pub ghost: GhostBirths,
    /// Fatigue points followed through the cycles (empty without `[fatigue]`).
    pub fatigue: crate::fatigue::FatigueState,
}

/// The ghost-penalty faces of re-cut bodies whose material has a history (J2), each with its
/// force at birth. The penalty of such a face acts on the displacement since it was born,
/// `f_F = K_F (u - u_birth)`, the element-birth rule of history-dependent analyses: a face a
/// moving or worn surface brings into the penalty would otherwise load the body at once with
/// `K_F u`, the jump of the normal derivative of a field that is already plastically deformed
/// (a load no increment cut-back can reduce). Faces that appear in material that has not
/// yielded, and all faces of elastic bodies, keep the penalty on the total displacement:
/// there the solution depends only on the current cut.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GhostBirths {
    /// Per face `(body, cell, neighbour)`, sorted: `K_F u_birth` as `(dof, force)`, sorted by DOF
    /// (empty for faces on the total displacement: there from the start, or born elastic).
    pub faces: Vec<((usize, usize, usize), Vec<(usize, f64)>)>,
}

impl GhostBirths {
    /// The birth forces summed per DOF (sorted, zeros left out).
    pub fn offset(&self) -> Vec<(usize, f64)> {
        let mut all: Vec<(usize, f64)> =
            self.faces.iter().flat_map(|(_, f)| f.iter().copied()).filter(|e| e.1 != 0.0).collect();
        all.sort_by_key(|e| e.0);
        let mut out: Vec<(usize, f64)> = Vec::with_capacity(all.len());
        for (d, f) in all {
            match out.last_mut() {
                Some(last) if last.0 == d => last.1 += f,
                _ => out.push((d, f)),
            }
        }
        out
    }
}

impl SimState {
    /// The contact unknowns of this state (what the per-node contact field reads).
    pub fn contact_unknowns(&self) -> ContactUnknowns<'_> {
        ContactUnknowns {
            u: &self.u,
            multipliers: &self.multipliers,
            friction_status: &self.friction_status,
            slip_increment: &self.slip_increment,
            accumulated_slip: &self.accumulated_slip,
        }
    }
}
