//! `SimState`: the one mutable struct of a simulation, everything a checkpoint must hold to
//! resume bit for bit. All problem data (meshes, materials, loads) lives in the immutable
//! `Model`. History advances only from converged steps: the analysis computes trial values in
//! its own buffers and commits them here when a step converges.

use crate::contact::ContactUnknowns;
use crate::fem::material::{PlasticState, Stress4};
use crate::wear::ControllerState;

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
}

/// Everything a wear run carries from cycle to cycle: where the worn surfaces are, how much
/// each lost, the cycle counters and the cycle-jump controller's memory. Per wearing surface
/// (in the model's wear order), per vertex of its polyline.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WearState {
    /// Cycles done, the jumped ones included (the cycle being computed is `cycle`).
    pub cycle: u64,
    /// Cycles actually computed.
    pub computed_cycles: u64,
    /// Increments of the current cycle that have converged.
    pub increment: usize,
    /// Jump `dN` the current cycle's wear is applied with.
    pub jump: u64,
    /// Current vertices (reference configuration of the host).
    pub vertices: Vec<Vec<[f64; 2]>>,
    /// Accumulated wear depth per vertex.
    pub depth: Vec<Vec<f64>>,
    /// Wear volume `k int N_i p |ds|` (per unit thickness) per vertex over the current cycle.
    pub cycle_volume: Vec<Vec<f64>>,
    /// `int p |ds|` (Archard) or `int |q ds|` (energy) of the current cycle, per surface.
    pub cycle_work: Vec<f64>,
    /// Per surface, per multiplier node of its contact pair: the wear work `W_j` and the
    /// weighted slip `sum |ds_j|` of the current cycle (the implicit jump's linearisation).
    pub cycle_row_work: Vec<Vec<f64>>,
    pub cycle_row_slip: Vec<Vec<f64>>,
    /// Worn area (`sum_i depth_i int N_i`) and the time integral of the wear work, per surface
    /// (jumps included): `worn_area = k * work` is the wear balance.
    pub worn_area: Vec<f64>,
    pub work: Vec<f64>,
    /// Jump controller memory (see `wear::next_jump`).
    pub controller: ControllerState,
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
