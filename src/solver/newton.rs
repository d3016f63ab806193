//! Newton-Raphson parameters and errors for the load-stepping driver (see `analysis`).
//!
//! Convergence: `|r_free| <= rtol * max(|lambda f_ext|, |f_int|)`, with `f_int` over all DOFs so
//! that displacement-driven problems (no external force) are measured against their reactions.
//! A step that does not converge in `max_iterations`, or whose residual grows by
//! `divergence_factor` or becomes non-finite, is cut back (the increment halved) from the last
//! converged state, at most `max_cutbacks` times. Under interface condensation the contact
//! active-set iterations of each solve have their own limit, `max_set_iterations`.

use crate::solver::linear::LinearSolverError;

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NewtonParams {
    pub max_iterations: usize,
    pub rtol: f64,
    pub max_cutbacks: usize,
    pub divergence_factor: f64,
    /// Contact active-set iterations of one interface solve (condensed contact); `None`: one per
    /// contact row that may touch, at least `max_iterations` (a contact set that starts too wide
    /// is released a node or two per side and iteration).
    pub max_set_iterations: Option<usize>,
}

impl Default for NewtonParams {
    fn default() -> Self {
        NewtonParams {
            max_iterations: 25,
            rtol: 1e-9,
            max_cutbacks: 8,
            divergence_factor: 1e8,
            max_set_iterations: None,
        }
    }
}

/// The residual of a failed step for messages: infinite means the contact active set was still
/// changing when the iterations ran out (no residual of a settled set exists).
fn residual_text(r: f64) -> String {
    if r.is_finite() {
        format!("relative residual {r:.3e}")
    } else {
        "contact active set still changing".to_string()
    }
}

#[derive(Debug, thiserror::Error)]
pub enum NewtonError {
    #[error("Newton did not converge in step {step} (time {time}, load factor {load_factor}) after {cutbacks} cut-backs: iteration {iteration}, {res} (tolerance {rtol:.1e}), {active_contact_nodes} active contact nodes", res = residual_text(*.residual))]
    NotConverged {
        step: usize,
        time: f64,
        load_factor: f64,
        iteration: usize,
        residual: f64,
        rtol: f64,
        cutbacks: usize,
        /// Contact multiplier nodes in the active set at the last iteration (0 without contact).
        active_contact_nodes: usize,
    },
    #[error("linear solve failed in step {step}, iteration {iteration}: {source}")]
    Linear { step: usize, iteration: usize, source: LinearSolverError },
}
