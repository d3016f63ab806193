//! `SimState`: the one mutable struct of a simulation, everything a checkpoint must hold to
//! resume bit for bit. All problem data (meshes, materials, loads) lives in the immutable
//! `Model`. History advances only from converged steps: the analysis computes trial values in
//! its own buffers and commits them here when a step converges.
//!
//! The state's fields are declared once, in the `sim_state!` invocation below: it makes the struct
//! and its field visitor ([`SimState::fields`], [`SimState::from_fields`]), which is what the
//! checkpoint writes and reads. A field added there is checkpointed by the kind of its type
//! ([`StateField`]), with no other list to update.

use crate::contact::ContactUnknowns;
use crate::fatigue::FatigueState;
use crate::fem::material::{PlasticState, Stress4};
pub use crate::wear::WearState;

/// How a checkpoint stores a state field: one kind per Rust type (see [`StateField`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldKind {
    /// A count (`u64` attribute).
    Count,
    /// A number (`f64` attribute).
    Scalar,
    /// One `f64` per entry.
    Values,
    /// One `u8` code per entry.
    Codes,
    /// Plastic history per stateful point.
    History,
    /// Stress per integration point.
    Stress,
    /// Batches of row indices (the interface-condensation log).
    Batches,
    /// The wear state (its own group).
    Wear,
    /// Ghost-penalty faces born during the run.
    Ghost,
    /// The fatigue state (its own group).
    Fatigue,
}

/// A state field, borrowed, as the checkpoint writes it.
#[derive(Debug, Clone, Copy)]
pub enum FieldRef<'a> {
    Count(usize),
    Scalar(f64),
    Values(&'a [f64]),
    Codes(&'a [u8]),
    History(&'a [PlasticState]),
    Stress(&'a [Stress4]),
    Batches(&'a [Vec<usize>]),
    Wear(&'a WearState),
    Ghost(&'a GhostBirths),
    Fatigue(&'a FatigueState),
}

/// A state field, owned, as the checkpoint reads it back.
#[derive(Debug, Clone)]
pub enum FieldValue {
    Count(usize),
    Scalar(f64),
    Values(Vec<f64>),
    Codes(Vec<u8>),
    History(Vec<PlasticState>),
    Stress(Vec<Stress4>),
    Batches(Vec<Vec<usize>>),
    Wear(WearState),
    Ghost(GhostBirths),
    Fatigue(FatigueState),
}

impl FieldValue {
    /// The kind this value is of.
    pub fn kind(&self) -> FieldKind {
        match self {
            FieldValue::Count(_) => FieldKind::Count,
            FieldValue::Scalar(_) => FieldKind::Scalar,
            FieldValue::Values(_) => FieldKind::Values,
            FieldValue::Codes(_) => FieldKind::Codes,
            FieldValue::History(_) => FieldKind::History,
            FieldValue::Stress(_) => FieldKind::Stress,
            FieldValue::Batches(_) => FieldKind::Batches,
            FieldValue::Wear(_) => FieldKind::Wear,
            FieldValue::Ghost(_) => FieldKind::Ghost,
            FieldValue::Fatigue(_) => FieldKind::Fatigue,
        }
    }
}

/// A type a state field may have, with the kind the checkpoint stores it as.
pub trait StateField: Sized {
    const KIND: FieldKind;
    fn as_field(&self) -> FieldRef<'_>;
    /// The field back from a value of its kind (`None`: a value of another kind).
    fn from_value(value: FieldValue) -> Option<Self>;
}

/// `StateField` for a type stored as variant `$kind`, borrowed by `$borrow`.
macro_rules! state_field {
    ($ty:ty, $kind:ident, |$v:ident| $borrow:expr) => {
        impl StateField for $ty {
            const KIND: FieldKind = FieldKind::$kind;
            fn as_field(&self) -> FieldRef<'_> {
                let $v = self;
                FieldRef::$kind($borrow)
            }
            fn from_value(value: FieldValue) -> Option<Self> {
                match value {
                    FieldValue::$kind(v) => Some(v),
                    _ => None,
                }
            }
        }
    };
}

state_field!(usize, Count, |v| *v);
state_field!(f64, Scalar, |v| *v);
state_field!(Vec<f64>, Values, |v| v.as_slice());
state_field!(Vec<u8>, Codes, |v| v.as_slice());
state_field!(Vec<PlasticState>, History, |v| v.as_slice());
state_field!(Vec<Stress4>, Stress, |v| v.as_slice());
state_field!(Vec<Vec<usize>>, Batches, |v| v.as_slice());
state_field!(WearState, Wear, |v| v);
state_field!(GhostBirths, Ghost, |v| v);
state_field!(FatigueState, Fatigue, |v| v);

/// A field read back as a value of another kind than its type's (a reader's defect).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("state field {field}: read as {found:?}, stored as {expected:?}")]
pub struct FieldKindMismatch {
    pub field: &'static str,
    pub expected: FieldKind,
    pub found: FieldKind,
}

/// Declares [`SimState`] once: the struct, and the visitor the checkpoint writes and reads it
/// by, field after field in declaration order.
macro_rules! sim_state {
    ($(#[$meta:meta])* pub struct SimState { $($(#[$field_meta:meta])* pub $field:ident: $ty:ty,)* }) => {
        $(#[$meta])*
        pub struct SimState {
            $($(#[$field_meta])* pub $field: $ty,)*
        }

        impl SimState {
            /// Every field with its name, in declaration order.
            pub fn fields(&self) -> Vec<(&'static str, FieldRef<'_>)> {
                vec![$((stringify!($field), StateField::as_field(&self.$field)),)*]
            }

            /// The state from its fields, each read by `read(name, kind)` in declaration order.
            pub fn from_fields<E: From<FieldKindMismatch>>(
                mut read: impl FnMut(&'static str, FieldKind) -> Result<FieldValue, E>,
            ) -> Result<SimState, E> {
                Ok(SimState {
                    $($field: {
                        let expected = <$ty as StateField>::KIND;
                        let value = read(stringify!($field), expected)?;
                        let found = value.kind();
                        <$ty as StateField>::from_value(value)
                            .ok_or(FieldKindMismatch { field: stringify!($field), expected, found })?
                    },)*
                })
            }
        }
    };
}

sim_state! {
/// Everything a run changes: the converged output step's fields, each checkpointed by its kind.
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
    pub fatigue: FatigueState,
}
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
