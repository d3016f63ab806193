//! `Model`: the immutable problem data of a static analysis (bodies, materials, element
//! table, prescribed displacements, unit external loads, load curves, ties, contact and wear
//! declarations). Built once by [`ModelBuilder`] and never changed afterwards.
//!
//! Three kinds of data, three types:
//! * [`Model`]: what the user declared, and what is fixed for the whole run (element and point
//!   layout, multiplier layout, the bands of fixed points moving surfaces may visit);
//! * [`Discretisation`]: where the free surfaces are now and what follows from it (cut states,
//!   quadrature weights, ghost penalty, held DOFs and DOF map, contact rows). It is derived
//!   from the model, the time and the wear state; the driver owns the one of the moment. The
//!   model keeps the one its builder made ([`Model::initial`]);
//! * `SimState`: the solution and its history, the one thing a checkpoint saves.
//!
//! Loading: every prescribed displacement and every external force is scaled by the factor of
//! its load curve, a piecewise-linear function of pseudo-time: curve 0 is the model's load path
//! (`lambda(t)`), further curves let loads follow their own histories (normal load held, then a
//! cyclic tangential load: fretting).

use crate::assembly::{DofMap, ElementTable};
pub use crate::contact::{ContactInfo, ContactSet, PairedSide, Sliding};
use crate::cut::{cut_mesh, subtriangulation_rule, CellCut, CutMesh};
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
use crate::moving::{held_dofs, Band, FreeSurface, SurfaceMotion};
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
    #[error("body '{body}': edge set '{set}' has zero length: a total force cannot be spread over it")]
    DegenerateSet { body: String, set: String },
    #[error("fatigue of body '{body}': {msg}")]
    Fatigue { body: String, msg: String },
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
    /// A rigid set whose nodes are prescribed different displacements.
    #[error("rigid set '{set}' of body '{body}': {msg}")]
    RigidSet { body: String, set: String, msg: String },
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
mod discretisation;
mod load;

pub use builder::ModelBuilder;
pub use discretisation::Discretisation;
pub use load::{Cycle, LoadPath};

/// A part of the model (nodes joined by elements, ties and rigid sets) and the plane rigid
/// modes its prescribed DOFs leave free: what only contact (and friction) can hold.
#[derive(Debug, Clone)]
pub struct RigidPart {
    /// Its nodes, in order.
    pub nodes: Vec<usize>,
    /// Centroid of its nodes and their largest distance from it.
    pub centre: nalgebra::Vector2<f64>,
    pub size: f64,
    /// Modes `(x, y, rotation)` (unit vectors, rotation scaled by `size`) the prescribed DOFs
    /// leave free: the null space of the modes' Gram matrix over them.
    pub free_modes: Vec<nalgebra::Vector3<f64>>,
    /// Those that the constraint rows leave free too (a rigid set moves as one translation:
    /// it keeps its part from turning): what only contact and friction hold.
    pub unrestrained_modes: Vec<nalgebra::Vector3<f64>>,
}

impl Model {
    /// The parts of the model and their free rigid modes (parts of one node are left out).
    /// In words, per body, see [`Model::free_mode_descriptions`].
    pub fn rigid_parts(&self) -> Vec<RigidPart> {
        let nn = self.coords.len();
        let mut parent: Vec<usize> = (0..nn).collect();
        fn root(p: &mut [usize], mut a: usize) -> usize {
            while p[a] != a {
                p[a] = p[p[a]];
                a = p[a];
            }
            a
        }
        let join = |p: &mut Vec<usize>, a: usize, b: usize| {
            let (ra, rb) = (root(p, a), root(p, b));
            if ra != rb {
                p[ra.max(rb)] = ra.min(rb);
            }
        };
        for (e, nodes) in self.elements.nodes.iter().enumerate() {
            let nn_e = self.elements.kind[e].num_nodes();
            for &b in &nodes[1..nn_e] {
                join(&mut parent, nodes[0], b);
            }
        }
        for row in &self.constraints {
            for w in row.windows(2) {
                join(&mut parent, w[0].0 / 2, w[1].0 / 2);
            }
        }
        let roots: Vec<usize> = (0..nn).map(|a| root(&mut parent, a)).collect();
        // Nodes of each part, parts in order of their smallest node.
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); nn];
        for (a, &r) in roots.iter().enumerate() {
            members[r].push(a);
        }
        let mut prescribed_of: Vec<Vec<usize>> = vec![Vec::new(); nn];
        for &(d, _) in &self.prescribed {
            prescribed_of[roots[d / 2]].push(d);
        }
        let mut parts = Vec::new();
        for (part, nodes) in members.into_iter().enumerate().filter(|(_, v)| v.len() > 1) {
            let centre =
                nodes.iter().fold(nalgebra::Vector2::zeros(), |s, &a| s + self.coords[a].coords) / nodes.len() as f64;
            let size = nodes.iter().map(|&a| (self.coords[a].coords - centre).norm()).fold(0.0, f64::max);
            if size <= 0.0 {
                continue;
            }
            // Gram matrix of the rigid modes (x, y, rotation) over the part's prescribed DOFs.
            let mut gram = nalgebra::Matrix3::<f64>::zeros();
            for &d in &prescribed_of[part] {
                let r = (self.coords[d / 2].coords - centre) / size;
                let mode = if d % 2 == 0 {
                    nalgebra::Vector3::new(1.0, 0.0, -r.y)
                } else {
                    nalgebra::Vector3::new(0.0, 1.0, r.x)
                };
                gram += mode * mode.transpose();
            }
            let null_space = |gram: nalgebra::Matrix3<f64>| -> Vec<nalgebra::Vector3<f64>> {
                let eig = gram.symmetric_eigen();
                let top = eig.eigenvalues.max().max(1.0);
                (0..3)
                    .filter(|&i| eig.eigenvalues[i] <= 1e-8 * top)
                    .map(|i| eig.eigenvectors.column(i).into_owned())
                    .collect()
            };
            let free_modes = null_space(gram);
            // Each constraint row of the part, evaluated on the three modes.
            let mut with_rows = gram;
            if !free_modes.is_empty() {
                for row in self.constraints.iter().filter(|r| r.first().is_some_and(|&(d, _)| roots[d / 2] == part)) {
                    let mut on_modes = nalgebra::Vector3::<f64>::zeros();
                    for &(d, c) in row {
                        let r = (self.coords[d / 2].coords - centre) / size;
                        on_modes += c * if d % 2 == 0 {
                            nalgebra::Vector3::new(1.0, 0.0, -r.y)
                        } else {
                            nalgebra::Vector3::new(0.0, 1.0, r.x)
                        };
                    }
                    let n = on_modes.norm();
                    if n > 0.0 {
                        let unit = on_modes / n;
                        with_rows += unit * unit.transpose();
                    }
                }
            }
            let unrestrained_modes = if free_modes.is_empty() { vec![] } else { null_space(with_rows) };
            parts.push(RigidPart { nodes, centre, size, free_modes, unrestrained_modes });
        }
        parts
    }

    /// Each part's rigid modes that neither boundary conditions nor constraint rows fix, in
    /// words (`body 'pin': free to turn about (0, 2)`, `... free along (0, 1)`): only contact,
    /// and friction along the contact, hold them. With `beyond_normal`, a translation along
    /// the body's contact normal (held by the contact pressure, as a force-loaded punch is) is
    /// left out: what remains is held by friction or by how the pressure is spread.
    pub fn free_mode_descriptions(&self, beyond_normal: bool) -> Vec<String> {
        let normal = self.contact_normal_sums();
        let round = |x: f64, scale: f64| if x.abs() < 1e-9 * scale { 0.0 } else { (x * 1e6).round() / 1e6 };
        let mut out = vec![];
        for part in self.rigid_parts().into_iter().filter(|p| !p.unrestrained_modes.is_empty()) {
            let Some(b) = part.nodes.first().and_then(|&n| self.body_of_node(n)) else { continue };
            let n = normal[b].try_normalize(0.0);
            let modes: Vec<String> = part
                .unrestrained_modes
                .iter()
                .filter_map(|v| {
                    if v[2].abs() > 1e-6 {
                        // The point a mode (vx, vy, w) leaves in place: centre + size (-vy, vx) / w.
                        let c = part.centre + part.size * nalgebra::Vector2::new(-v[1], v[0]) / v[2];
                        Some(format!("to turn about ({}, {})", round(c.x, part.size), round(c.y, part.size)))
                    } else {
                        let mut d = nalgebra::Vector2::new(v[0], v[1]).normalize();
                        if beyond_normal && n.is_some_and(|n| d.dot(&n).abs() > 0.99) {
                            return None;
                        }
                        if d.x < -1e-9 || (d.x.abs() <= 1e-9 && d.y < 0.0) {
                            d = -d;
                        }
                        Some(format!("along ({}, {})", round(d.x, 1.0), round(d.y, 1.0)))
                    }
                })
                .collect();
            if !modes.is_empty() {
                out.push(format!("body '{}': free {}", self.bodies[b].name, modes.join(" and ")));
            }
        }
        out
    }
}

/// A number as a message quotes it: plain where that is short (`0.3`, `-2.5`, `210000`),
/// in exponent form otherwise (`-5e-8`, not `-0.00000005`).
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-3..1e7).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

#[derive(Debug, Clone)]
pub struct Model {
    pub hypothesis: PlaneHypothesis,
    pub bodies: Vec<Body>,
    pub materials: Vec<Material>,
    pub material_names: Vec<String>,
    /// Reference coordinates of all nodes (bodies concatenated).
    pub coords: Vec<Point2<f64>>,
    pub elements: ElementTable,
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
    /// Per body: the band of fixed points of its moving surfaces (`None`: nothing moves in it).
    pub bands: Vec<Option<Band>>,
    /// Factor of the ghost penalty (times `E h` per cut-cell face).
    pub ghost_penalty: f64,
    /// The repeated window of the load history, if the case is cyclic.
    pub cycle: Option<Cycle>,
    /// Wearing surfaces and the cycle-jump policy (empty: no wear).
    pub wear: crate::wear::WearModel,
    /// Fatigue points and constants (`None`: fatigue not followed).
    pub fatigue: Option<crate::fatigue::FatigueModel>,
    /// [`Model::ghost_reach`], formed on first use and shared by the run's later models (moved
    /// surfaces and re-pairings change neither the bands nor the penalty of unbanded bodies).
    ghost_reach_cache: std::sync::Arc<std::sync::OnceLock<Vec<(usize, usize)>>>,
    /// The discretisation the builder made: every surface where it starts, nothing worn.
    initial: std::sync::Arc<Discretisation>,
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
    /// paired in its own end configuration (see [`Discretisation::repaired_at`] and the driver).
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
        self.initial.contact.pairs.iter().any(|c| c.sliding == Sliding::Finite)
    }

    /// Each body's mesh and node offset (the hosts of virtual surfaces, for contact pairing).
    pub fn hosts(&self) -> Vec<(&Mesh2, usize)> {
        self.bodies.iter().map(|b| (&b.mesh, b.node_offset)).collect()
    }

    /// True when every material is linear: the stiffness is then factored once for the whole run.
    pub fn is_linear(&self) -> bool {
        self.materials.iter().all(|m| !m.has_state()) && self.initial.contact.rows.is_empty()
    }
    /// True when a material has a history (elastic-plastic bodies).
    pub fn has_plasticity(&self) -> bool {
        self.materials.iter().any(|m| m.has_state())
    }
    pub fn num_nodes(&self) -> usize {
        self.coords.len()
    }
    /// Number of DOFs, free and constrained (two per node).
    pub fn num_dofs(&self) -> usize {
        2 * self.coords.len()
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

    /// Number of multipliers (ties, contact normals, friction): fixed for the run.
    pub fn num_multipliers(&self) -> usize {
        let c = &self.initial.contact;
        self.constraints.len() + c.rows.len() + c.friction_rows.len()
    }

    /// Body index of a global node (`None` for the stand-in nodes of virtual mortar sides).
    pub fn body_of_node(&self, n: usize) -> Option<usize> {
        self.bodies.iter().position(|b| (b.node_offset..b.node_offset + b.mesh.nodes.len()).contains(&n))
    }

    /// Per body, the outward normals of its contact surfaces summed over the multiplier nodes
    /// of every pair it is in (the mortar side's; the other side's reversed): which way its
    /// contacts push it.
    pub fn contact_normal_sums(&self) -> Vec<nalgebra::Vector2<f64>> {
        let mut normal = vec![nalgebra::Vector2::<f64>::zeros(); self.bodies.len()];
        for c in &self.initial().contact.pairs {
            let other = match &c.other {
                crate::contact::PairedSide::Edges(edges) => edges.first().and_then(|e| self.body_of_node(e[0])),
                crate::contact::PairedSide::Embedded { host, .. } => Some(*host),
            };
            let sum = c.multipliers.normals.iter().fold(nalgebra::Vector2::zeros(), |s, n| s + n);
            normal[c.mortar] += sum;
            if let Some(o) = other {
                normal[o] -= sum;
            }
        }
        normal
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
pub(crate) fn surface_through<'a>(
    mut named: impl Iterator<Item = (&'a String, &'a Embedding)>,
    e: &SurfaceError,
) -> Option<String> {
    let SurfaceError::Inconsistent { cell, .. } = e else { return None };
    named.find(|(_, emb)| emb.cell_pieces.iter().any(|p| p.cell == *cell)).map(|(name, _)| name.clone())
}
