//! `Model`: the immutable problem data of a static analysis (bodies, materials, element and
//! rule tables, DOF map, prescribed displacements, unit external load, load path).
//! Built once by [`ModelBuilder`]; the mutable part of a run lives in `SimState`.
//!
//! Loading: every prescribed displacement and every external force is scaled by the factor of
//! its load curve, a piecewise-linear function of pseudo-time: curve 0 is the model's load path
//! (`lambda(t)`), further curves let loads follow their own histories (normal load held, then a
//! cyclic tangential load: fretting).

use crate::assembly::{DofMap, ElementTable};
pub use crate::contact::{ContactInfo, ContactSet, PairedSide, Sliding};
use crate::cut::{cut_mesh, subtriangulation_rule, CellCut, CutMesh};
use crate::moving::{band_cell_rule, held_dofs, Band, FreeSurface, RecutReport, SurfaceMotion};
use crate::fem::element::ReferenceElement;
use crate::fem::element::Seg2;
use crate::fem::kernel::Formulation;
use crate::fem::material::{Material, PlaneHypothesis};
use crate::fem::quadrature::QuadratureRule;
use crate::mesh::{CellKind, Mesh2};
use crate::mortar::{
    build_multipliers, build_multipliers_local, other_side_spacing, tying_rows, ConstraintRow, MortarSide,
    MultiplierSpace, Multipliers, OtherSide,
};
use crate::solver::linear::LinearSolverKind;
use crate::solver::newton::NewtonParams;
use crate::surface::{cell_polygon, cell_size, embed, BoxIndex, Embedding, SurfaceError, VirtualSurface};
use nalgebra::{Point2, Vector2};

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModelError {
    #[error("body '{body}' has no set named '{set}' (available: {available})")]
    UnknownSet { body: String, set: String, available: String },
    #[error("body '{body}': set '{set}' is a node set; '{what}' needs an edge set")]
    NotAnEdgeSet { body: String, set: String, what: String },
    #[error("no body named '{0}'")]
    UnknownBody(String),
    #[error("load path: {0}")]
    LoadPath(String),
    #[error("the model has no free degree of freedom")]
    NoFreeDofs,
    /// A body's mesh could not be built or checked.
    #[error("mesh of body '{body}': {msg}")]
    Mesh { body: String, msg: String },
    /// A tie's definition, its embedding in the host or its snapping onto the host grid.
    #[error("interface '{tie}': {msg}")]
    Tie { tie: String, msg: String },
    /// A free cut's definition (its polyline, or the real boundary it replaces) or its
    /// embedding in its host.
    #[error("cut '{cut}': {msg}")]
    Cut { cut: String, msg: String },
    /// A moving surface: its motion, the band of cells it may visit, or a move during the run
    /// (wearing surfaces move too).
    #[error("moving surface '{surface}': {msg}")]
    MovingSurface { surface: String, msg: String },
    /// Cutting a body with the surfaces embedded in it failed; `surface` is the one running
    /// through the failing cell, when known.
    #[error("cutting body '{body}'{}: {msg}", .surface.as_ref().map_or(String::new(), |s| format!(" along '{s}'")))]
    CutMesh { body: String, surface: Option<String>, msg: String },
    /// A wearing surface; `key` names the case key (`coefficient`, `max_depth`, `cut`).
    #[error("wear of '{surface}': {msg}")]
    Wear { surface: String, key: &'static str, msg: String },
    /// A contact pair's definition; `key` names the case key (`friction`, `mortar_surface`,
    /// `mortar_cut`, `other_cut`).
    #[error("contact '{contact}': {msg}")]
    Contact { contact: String, key: &'static str, msg: String },
}

/// One body: its mesh and where its nodes and elements sit in the global numbering.
#[derive(Debug, Clone)]
pub struct Body {
    pub name: String,
    pub mesh: Mesh2,
    pub material: usize,
    pub formulation: Formulation,
    pub thickness: f64,
    pub node_offset: usize,
    pub element_offset: usize,
}

mod build;
mod builder;
mod load;
mod moving;

pub use builder::ModelBuilder;
pub use load::{Cycle, LoadPath};

#[derive(Debug, Clone)]
pub struct Model {
    pub hypothesis: PlaneHypothesis,
    pub bodies: Vec<Body>,
    pub materials: Vec<Material>,
    pub material_names: Vec<String>,
    /// Reference coordinates of all nodes (bodies concatenated).
    pub coords: Vec<Point2<f64>>,
    pub elements: ElementTable,
    pub rules: Vec<QuadratureRule>,
    pub dofs: DofMap,
    /// `(global dof, value at unit load factor)`.
    pub prescribed: Vec<(usize, f64)>,
    /// Load curve of each prescribed DOF (0: `load_path`, `c >= 1`: `curves[c - 1]`).
    pub prescribed_curve: Vec<usize>,
    /// External force of curve 0 at unit factor, over all DOFs.
    pub f_ext: Vec<f64>,
    pub load_path: LoadPath,
    /// Further load curves and the unit external force each scales.
    pub curves: Vec<LoadPath>,
    pub f_ext_curves: Vec<Vec<f64>>,
    /// Output times (each a converged step).
    pub times: Vec<f64>,
    pub newton: NewtonParams,
    pub linear_solver: LinearSolverKind,
    /// Linear constraints `sum coef u[dof] = 0` (mortar tying), one multiplier each.
    pub constraints: Vec<ConstraintRow>,
    pub ties: Vec<TieInfo>,
    /// Cut state of each body's cells (`None`: not cut by any surface).
    pub cuts: Vec<Option<CutMesh>>,
    /// Host DOFs deactivated because their support has (almost) no material.
    pub deactivated_dofs: usize,
    /// Constant extra stiffness `(dof_i, dof_j, value)`: ghost penalty on cut bodies.
    pub penalty: Vec<(usize, usize, f64)>,
    /// Mortar contact: pairs, their weighted-gap and slip rows (multipliers after the ties).
    pub contact: ContactSet,
    /// Free virtual surfaces (cuts), where they are now.
    pub surfaces: Vec<FreeSurface>,
    /// Per body: the band of fixed points of its moving surfaces (`None`: nothing moves in it).
    pub bands: Vec<Option<Band>>,
    /// Ghost-penalty entries per body (`penalty` is their concatenation) and its factor.
    pub penalty_parts: Vec<Vec<(usize, usize, f64)>>,
    pub ghost_penalty: f64,
    /// Per body: DOFs switched off (no material in their support), held at their last value.
    pub held: Vec<Vec<usize>>,
    /// The repeated window of the load history, if the case is cyclic.
    pub cycle: Option<Cycle>,
    /// Wearing surfaces and the cycle-jump policy (empty: no wear).
    pub wear: crate::wear::WearModel,
    /// [`Model::ghost_reach`], formed on first use and shared by the run's later models (moved
    /// surfaces and re-pairings change neither the bands nor the penalty of unbanded bodies).
    ghost_reach_cache: std::sync::Arc<std::sync::OnceLock<Vec<(usize, usize)>>>,
}

/// The other surface of a contact pair.
#[derive(Debug, Clone)]
pub enum ContactOther {
    /// Real edges of a body (global node ids).
    Edges(Vec<[usize; 2]>),
    /// The virtual surface of a named free cut.
    Cut(String),
}

/// Parameters of a contact pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// Coulomb coefficient (0: frictionless, no tangential unknowns).
    pub friction: f64,
    /// Multiplier space on the mortar surface. Classical: one multiplier per vertex.
    /// Coarse-grained: spaced like the other side's elements near each vertex (removes the
    /// traction oscillation of a mortar side finer than the other side's elements).
    pub multipliers: MultiplierSpace,
    /// Small sliding: mortar pairing once, from the reference geometry. Finite: every step
    /// paired in its own end configuration (see [`Model::repaired_at`] and the driver).
    pub sliding: Sliding,
}

impl Default for ContactParams {
    fn default() -> Self {
        ContactParams { friction: 0.0, multipliers: MultiplierSpace::Classical, sliding: Sliding::Small }
    }
}

impl ContactParams {
    pub fn friction(mu: f64) -> Self {
        ContactParams { friction: mu, ..Default::default() }
    }
}

/// A mortar tie between a patch (mortar side, multipliers) and a host (virtual surface).
#[derive(Debug, Clone)]
pub struct TieInfo {
    pub name: String,
    pub host: usize,
    pub patch: usize,
    pub space: MultiplierSpace,
    /// Index of the tie's first constraint row (rows `2 l + c`).
    pub first_row: usize,
    pub multipliers: Multipliers,
}

impl Model {
    /// Whether any contact pair is re-paired every step (finite sliding).
    pub fn has_finite_sliding(&self) -> bool {
        self.contact.pairs.iter().any(|c| c.sliding == Sliding::Finite)
    }

    /// This model with the finite-sliding contact pairs re-paired in the configuration
    /// `x = X + u` (a virtual surface moves with its host: its pieces keep their host reference
    /// coordinates), slips measured from `u` (see [`Model::repaired_at`]).
    pub fn repaired(&self, u: &[f64]) -> Model {
        self.repaired_at(u, u)
    }

    /// This model with the finite-sliding contact pairs re-paired in the configuration
    /// `x = X + u_pair`: the mortar integrals, normals and tangents are recomputed on the
    /// displaced surfaces, and the rows are shifted so that they stay linear in the total
    /// displacement, `g(u') = g_x + C_x (u' - u_pair)`, i.e. `g0 = g_x - C_x u_pair`; slips of
    /// the step are measured from the step's start, `friction_s0 = T_x u_start`. The driver
    /// pairs a step in its own end configuration (a fixed point on `u_pair`, see
    /// [`crate::driver`]). Multiplier nodes, their number and order do not change, so the state
    /// carries over. Small-sliding pairs keep their reference rows.
    pub fn repaired_at(&self, u_pair: &[f64], u_start: &[f64]) -> Model {
        let mut m = self.clone();
        let x = |n: usize| self.coords[n] + Vector2::new(u_pair[2 * n], u_pair[2 * n + 1]);
        let hosts = self.hosts();
        for (pair, c) in self.contact.pairs.iter().enumerate().filter(|(_, c)| c.sliding == Sliding::Finite) {
            let rows = crate::contact::pair_rows(&hosts, c, &x);
            crate::contact::install_rows(&mut m.contact, pair, rows, u_pair, u_start);
        }
        m
    }

    /// Each body's mesh and node offset (the hosts of virtual surfaces, for contact pairing).
    pub fn hosts(&self) -> Vec<(&Mesh2, usize)> {
        self.bodies.iter().map(|b| (&b.mesh, b.node_offset)).collect()
    }

    /// True when every material is linear: the stiffness is then factored once for the whole run.
    pub fn is_linear(&self) -> bool {
        self.materials.iter().all(|m| !m.has_state()) && self.contact.rows.is_empty()
    }
    pub fn num_nodes(&self) -> usize {
        self.coords.len()
    }
    /// Physical coordinates of every integration point, in point order.
    pub fn point_coords(&self) -> Vec<Point2<f64>> {
        let el = &self.elements;
        let mut out = Vec::with_capacity(el.num_points());
        for e in 0..el.len() {
            let mut c = [Point2::origin(); 4];
            for a in 0..el.kind[e].num_nodes() {
                c[a] = self.coords[el.nodes[e][a]];
            }
            let m = crate::fem::element::MappedElement::new(el.kind[e], c);
            for xi in &self.rules[el.rule[e]].points {
                out.push(m.map(*xi));
            }
        }
        out
    }
    /// Reactions `f_int + C^T mu - lambda f_ext` at constrained DOFs of a state, zero elsewhere.
    pub fn reactions(&self, state: &crate::state::SimState) -> Vec<f64> {
        let mut r = state.f_int.clone();
        let mut f = vec![0.0; r.len()];
        self.external_force(state.time, &mut f);
        for (v, f) in r.iter_mut().zip(&f) {
            *v -= f;
        }
        for (k, row) in self.multiplier_rows().enumerate() {
            for &(d, c) in row {
                r[d] += c * state.multipliers[k];
            }
        }
        for (d, v) in r.iter_mut().enumerate() {
            if self.dofs.eq[d] != crate::assembly::CONSTRAINED {
                *v = 0.0;
            }
        }
        r
    }

    /// `(cycle, increment)` of output step `step` (1-based); `(0, step)` for a non-cyclic case.
    pub fn step_label(&self, step: usize) -> (usize, usize) {
        match &self.cycle {
            Some(c) => c.label(step, c.start > self.load_path.points[0].0),
            None => (0, step),
        }
    }

    /// Factor of load curve `c` at time `t` (inside the cycle window for a cyclic case).
    pub fn curve_factor(&self, c: usize, t: f64) -> f64 {
        self.curve_factor_absolute(c, self.cycle.map_or(t, |cy| cy.local_time(t)))
    }
    /// Factor of load curve `c` at time `t`, read as given (surface motions).
    pub fn curve_factor_absolute(&self, c: usize, t: f64) -> f64 {
        if c == 0 {
            self.load_path.factor(t)
        } else {
            self.curves[c - 1].factor(t)
        }
    }
    /// External force at time `t` over all DOFs.
    pub fn external_force(&self, t: f64, out: &mut [f64]) {
        let t = self.cycle.map_or(t, |cy| cy.local_time(t));
        let l0 = self.load_path.factor(t);
        for (o, f) in out.iter_mut().zip(&self.f_ext) {
            *o = l0 * f;
        }
        for (c, f) in self.curves.iter().zip(&self.f_ext_curves) {
            let l = c.factor(t);
            for (o, f) in out.iter_mut().zip(f) {
                *o += l * f;
            }
        }
    }
    /// `(dof, value)` of every prescribed DOF at time `t`.
    pub fn prescribed_at(&self, t: f64) -> impl Iterator<Item = (usize, f64)> + '_ {
        let factors: Vec<f64> = (0..=self.curves.len()).map(|c| self.curve_factor(c, t)).collect();
        self.prescribed.iter().zip(&self.prescribed_curve).map(move |(&(d, v), &c)| (d, factors[c] * v))
    }
    /// Last time of any load curve (of the whole run, for a cyclic case).
    pub fn end_time(&self) -> f64 {
        if let Some(c) = &self.cycle {
            return c.start + c.period * c.count as f64;
        }
        self.curves.iter().map(|c| c.end_time()).fold(self.load_path.end_time(), f64::max)
    }

    /// Every multiplier's row over the DOFs, in multiplier order: ties, contact normals, friction.
    pub fn multiplier_rows(&self) -> impl Iterator<Item = &ConstraintRow> {
        self.constraints.iter().chain(self.contact.rows.iter()).chain(self.contact.friction_rows.iter())
    }
    pub fn num_multipliers(&self) -> usize {
        self.constraints.len() + self.contact.rows.len() + self.contact.friction_rows.len()
    }

    /// Body index of a global element.
    pub fn body_of_element(&self, e: usize) -> usize {
        self.bodies.iter().rposition(|b| b.element_offset <= e).unwrap_or(0)
    }
}

/// Default ghost-penalty factor (dimensionless, times `E h` per edge).
pub const DEFAULT_GHOST_PENALTY: f64 = 0.05;

/// The first of the named surfaces whose embedding runs through the host cell where a cut was
/// found inconsistent (`None` for another error, or when none does).
pub(super) fn surface_through<'a>(
    mut named: impl Iterator<Item = (&'a String, &'a Embedding)>,
    e: &SurfaceError,
) -> Option<String> {
    let SurfaceError::Inconsistent { cell, .. } = e else { return None };
    named.find(|(_, emb)| emb.cell_pieces.iter().any(|p| p.cell == *cell)).map(|(name, _)| name.clone())
}
