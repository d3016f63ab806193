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
use crate::discretisation::{band_cell_rule, held_dofs, Band, FreeSurface, RecutReport, SurfaceMotion};
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

/// Piecewise-linear load factor `lambda(t)`; constant beyond its ends.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadPath {
    pub points: Vec<(f64, f64)>,
}

impl LoadPath {
    pub fn new(points: Vec<(f64, f64)>) -> Result<Self, ModelError> {
        if points.is_empty() {
            return Err(ModelError::LoadPath("needs at least one (time, factor) point".into()));
        }
        for w in points.windows(2) {
            if w[1].0 <= w[0].0 {
                return Err(ModelError::LoadPath(format!("times must increase strictly ({} then {})", w[0].0, w[1].0)));
            }
        }
        if points.iter().any(|p| !p.0.is_finite() || !p.1.is_finite()) {
            return Err(ModelError::LoadPath("times and factors must be finite".into()));
        }
        Ok(LoadPath { points })
    }
    pub fn factor(&self, t: f64) -> f64 {
        let p = &self.points;
        if t <= p[0].0 {
            return p[0].1;
        }
        for w in p.windows(2) {
            if t <= w[1].0 {
                let s = (t - w[0].0) / (w[1].0 - w[0].0);
                return w[0].1 + s * (w[1].1 - w[0].1);
            }
        }
        p[p.len() - 1].1
    }
    pub fn end_time(&self) -> f64 {
        self.points[self.points.len() - 1].0
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

/// A load history declared as one cycle repeated: every curve is evaluated at
/// `start + (t - start) mod period` beyond `start` (the part before it, e.g. the normal load,
/// runs once). Output steps carry `(cycle, increment)`: cycle 0 is the part before the window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cycle {
    pub start: f64,
    pub period: f64,
    pub count: usize,
    /// Output steps per cycle, and before the window.
    pub increments: usize,
    pub ramp_increments: usize,
}

impl Cycle {
    /// Pseudo-time inside the first cycle that the curves see at time `t`.
    pub fn local_time(&self, t: f64) -> f64 {
        if t <= self.start + self.period {
            t
        } else {
            let r = (t - self.start).rem_euclid(self.period);
            // The end of a cycle is the end of the window, not its start (same factors for a
            // periodic history, but the window's last point is where the cycle ends).
            if r == 0.0 {
                self.start + self.period
            } else {
                self.start + r
            }
        }
    }
    /// Output times: `ramp_increments` steps up to `start`, then `increments` per cycle.
    pub fn times(&self, t0: f64) -> Vec<f64> {
        let mut v = Vec::with_capacity(self.ramp_increments + self.count * self.increments);
        if self.start > t0 {
            for i in 1..=self.ramp_increments {
                v.push(t0 + (self.start - t0) * i as f64 / self.ramp_increments as f64);
            }
        }
        for c in 0..self.count {
            for i in 1..=self.increments {
                v.push(self.start + self.period * (c as f64 + i as f64 / self.increments as f64));
            }
        }
        v
    }
    /// `(cycle, increment)` of output step `step` (1-based; cycle 0 is the part before the window).
    pub fn label(&self, step: usize, has_ramp: bool) -> (usize, usize) {
        let ramp = if has_ramp { self.ramp_increments } else { 0 };
        if step <= ramp {
            (0, step)
        } else {
            let k = step - ramp - 1;
            (k / self.increments + 1, k % self.increments + 1)
        }
    }
}

/// The other surface of a contact pair.
#[derive(Debug, Clone)]
pub enum ContactOther {
    /// Real edges of a body (global node ids).
    Edges(Vec<[usize; 2]>),
    /// The virtual surface of a named free cut.
    Cut(String),
}

struct ContactSpec {
    name: String,
    mortar: usize,
    /// The mortar side: real edges, or (when `mortar_cut` names a free cut) filled in at build.
    side: MortarSide,
    mortar_cut: Option<String>,
    other: ContactOther,
    young: f64,
    params: ContactParams,
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

struct TieSpec {
    name: String,
    /// Host body (virtual surface) or, with `other_edges`, the other real body.
    host: usize,
    patch: usize,
    side: MortarSide,
    space: MultiplierSpace,
    /// Real-real tie: the other side's edges (global node ids).
    other_edges: Option<Vec<[usize; 2]>>,
}

/// Orders oriented edges into one polyline: open (from the node without incoming edge) or closed.
fn edge_chain(edges: &[[usize; 2]]) -> Result<(Vec<usize>, bool), String> {
    let mut next: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
    let mut has_in: std::collections::HashSet<usize> = std::collections::HashSet::new();
    for e in edges {
        if next.insert(e[0], e[1]).is_some() {
            return Err(format!("node {} starts two edges: the sets do not form one simple polyline", e[0]));
        }
        has_in.insert(e[1]);
    }
    let starts: Vec<usize> = edges.iter().map(|e| e[0]).filter(|n| !has_in.contains(n)).collect();
    let (start, closed) = match starts.as_slice() {
        [] => (edges[0][0], true),
        [s] => (*s, false),
        _ => return Err(format!("the edges form {} separate pieces: give one polyline", starts.len())),
    };
    let mut chain = vec![start];
    let mut cur = start;
    while let Some(&nx) = next.get(&cur) {
        if nx == start {
            break;
        }
        chain.push(nx);
        cur = nx;
        if chain.len() > edges.len() + 1 {
            return Err("the edges do not form one polyline".into());
        }
    }
    let used = if closed { chain.len() } else { chain.len() - 1 };
    if used != edges.len() {
        return Err(format!(
            "the sets hold {} edges but the polyline through them has {used}: give one connected polyline",
            edges.len()
        ));
    }
    Ok((chain, closed))
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

/// The first segment of a closed tie boundary that lies along the host's outer boundary (an
/// edge of a cell without a neighbour), with its end points: such an edge has host material on
/// one side only, so tying it couples the patch to nothing and cuts nothing.
fn edge_on_outer_boundary(host: &Mesh2, side: &MortarSide) -> Option<(usize, Point2<f64>, Point2<f64>)> {
    if !side.closed {
        return None;
    }
    let adjacency = crate::cut::CellAdjacency::new(host);
    let mut outer: Vec<(Point2<f64>, Point2<f64>)> = Vec::new();
    for (c, cell) in host.cells.iter().enumerate() {
        let ns = cell.nodes();
        for k in 0..ns.len() {
            if adjacency.neighbour(c, k).is_none() {
                outer.push((host.nodes[ns[k]], host.nodes[ns[(k + 1) % ns.len()]]));
            }
        }
    }
    let index = BoxIndex::new(
        &outer
            .iter()
            .map(|(a, b)| (Point2::new(a.x.min(b.x), a.y.min(b.y)), Point2::new(a.x.max(b.x), a.y.max(b.y))))
            .collect::<Vec<_>>(),
    );
    let mut cand = Vec::new();
    for i in 0..side.num_segments() {
        let (p, q) = (side.points[i], side.points[(i + 1) % side.points.len()]);
        let len = (q - p).norm();
        let tol = 1e-6 * len;
        let mid = Point2::from((p.coords + q.coords) * 0.5);
        index.query(Point2::new(mid.x - tol, mid.y - tol), Point2::new(mid.x + tol, mid.y + tol), &mut cand);
        for &e in &cand {
            let (a, b) = outer[e];
            let d = b - a;
            let dist = |x: Point2<f64>| ((x - a).x * d.y - (x - a).y * d.x).abs() / d.norm();
            // The segment's midpoint on the edge and the segment parallel to it.
            if dist(mid) <= tol && dist(p) <= 10.0 * tol && dist(q) <= 10.0 * tol {
                return Some((i, p, q));
            }
        }
    }
    None
}

/// Factor of builder curve `c` (0: the load path) at `t`.
fn curve_value(curves: &[LoadPath], load_path: &LoadPath, c: usize, t: f64) -> f64 {
    if c == 0 {
        load_path.factor(t)
    } else {
        curves[c - 1].factor(t)
    }
}

/// Smallest and largest factor of curve `c` (piecewise linear: extremes at its points).
fn curve_range(curves: &[LoadPath], load_path: &LoadPath, c: usize) -> (f64, f64) {
    let pts = if c == 0 { &load_path.points } else { &curves[c - 1].points };
    pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)))
}

/// Reference coordinates of a global node.
fn coords_of(bodies: &[Body], n: usize) -> Point2<f64> {
    let b = bodies.iter().rfind(|b| b.node_offset <= n).unwrap_or(&bodies[0]);
    b.mesh.nodes[n - b.node_offset]
}

/// Per body, what cutting it gives: its cut state (`None`: not cut), the band of fixed points
/// of its moving and wearing surfaces (`None`: nothing moves in it), its ghost-penalty entries.
struct CutHosts {
    cuts: Vec<Option<CutMesh>>,
    bands: Vec<Option<Band>>,
    penalty_parts: Vec<Vec<(usize, usize, f64)>>,
}

/// Quadrature rules, node coordinates (bodies concatenated) and the element table.
struct Elements {
    rules: Vec<QuadratureRule>,
    coords: Vec<Point2<f64>>,
    table: ElementTable,
}

/// The DOF map, the prescribed DOFs it constrains (`(dof, value, curve)`, one each, sorted) and
/// the held DOFs of each body.
struct Dofs {
    map: DofMap,
    prescribed: Vec<(usize, f64, usize)>,
    held: Vec<Vec<usize>>,
}

/// One entry per prescribed DOF, the last one given, sorted by DOF.
fn last_prescribed(prescribed: Vec<(usize, f64, usize)>) -> Vec<(usize, f64, usize)> {
    let mut seen = std::collections::HashMap::new();
    for (i, (d, _, _)) in prescribed.iter().enumerate() {
        seen.insert(*d, i);
    }
    let mut keep: Vec<usize> = seen.into_values().collect();
    keep.sort_unstable();
    let mut last: Vec<(usize, f64, usize)> = keep.into_iter().map(|i| prescribed[i]).collect();
    last.sort_by_key(|p| p.0);
    last
}

/// The first of the named surfaces whose embedding runs through the host cell where a cut was
/// found inconsistent (`None` for another error, or when none does).
fn surface_through<'a>(
    mut named: impl Iterator<Item = (&'a String, &'a Embedding)>,
    e: &SurfaceError,
) -> Option<String> {
    let SurfaceError::Inconsistent { cell, .. } = e else { return None };
    named.find(|(_, emb)| emb.cell_pieces.iter().any(|p| p.cell == *cell)).map(|(name, _)| name.clone())
}

/// Builds a [`Model`] body by body, then boundary conditions and loads by set name.
pub struct ModelBuilder {
    hypothesis: PlaneHypothesis,
    bodies: Vec<Body>,
    materials: Vec<Material>,
    material_names: Vec<String>,
    /// `(dof, value, curve)`.
    prescribed: Vec<(usize, f64, usize)>,
    /// Unit external force per load curve (0: the model's load path).
    f_curves: Vec<Vec<f64>>,
    curves: Vec<LoadPath>,
    /// Curve that loads and prescribed values added now follow.
    curve: usize,
    ties: Vec<TieSpec>,
    /// Free virtual surfaces: (name, body, surface with the material on its left, motion).
    free_cuts: Vec<(String, usize, VirtualSurface, Option<SurfaceMotion>)>,
    /// Per free cut: the polyline was reversed to keep the material on its left.
    reversed_cuts: Vec<bool>,
    cycle: Option<Cycle>,
    /// Wearing cuts: (name, law, coefficient, deepest wear), and the cycle-jump policy.
    wear_cuts: Vec<(String, crate::wear::WearLaw, f64, f64)>,
    wear_jump: crate::wear::JumpPolicy,
    wear_scheme: crate::wear::JumpScheme,
    wear_smoothing: f64,
    ghost_penalty: f64,
    contacts: Vec<ContactSpec>,
    /// Multi-point constraints `u(node) - u(master) = 0` (rigid sets), global DOFs.
    rigid_rows: Vec<ConstraintRow>,
}

impl ModelBuilder {
    pub fn new(hypothesis: PlaneHypothesis) -> Self {
        ModelBuilder {
            hypothesis,
            bodies: vec![],
            materials: vec![],
            material_names: vec![],
            prescribed: vec![],
            f_curves: vec![vec![]],
            curves: vec![],
            curve: 0,
            ties: vec![],
            free_cuts: vec![],
            ghost_penalty: DEFAULT_GHOST_PENALTY,
            contacts: vec![],
            rigid_rows: vec![],
            reversed_cuts: vec![],
            cycle: None,
            wear_cuts: vec![],
            wear_jump: crate::wear::JumpPolicy::default(),
            wear_scheme: crate::wear::JumpScheme::default(),
            wear_smoothing: crate::wear::DEFAULT_SMOOTHING,
        }
    }

    /// Makes the load history cyclic (see [`Cycle`]); the output times given to
    /// [`Self::build`] should be [`Cycle::times`].
    pub fn set_cycle(&mut self, cycle: Cycle) {
        self.cycle = Some(cycle);
    }

    /// Makes a free cut wear (see [`crate::wear`]): it must be the other side of a contact
    /// pair; its host gets fixed points down to `max_depth` below it. Its polyline gets a
    /// vertex wherever it crosses a host cell edge (its wear resolution).
    pub fn set_cut_wear(
        &mut self,
        name: &str,
        law: crate::wear::WearLaw,
        coefficient: f64,
        max_depth: f64,
    ) -> Result<(), ModelError> {
        let err = |key: &'static str, msg: String| ModelError::Wear { surface: name.to_string(), key, msg };
        if !(coefficient.is_finite() && coefficient >= 0.0) {
            return Err(err("coefficient", format!("must be finite and >= 0, got {coefficient}")));
        }
        if !(max_depth.is_finite() && max_depth > 0.0) {
            return Err(err("max_depth", format!("must be finite and > 0, got {max_depth}")));
        }
        let Some(f) = self.free_cuts.iter().find(|f| f.0 == name) else {
            return Err(err("cut", format!("no cut named '{name}'")));
        };
        if f.3.is_some() {
            return Err(err("cut", "a cut with a prescribed motion cannot also wear".into()));
        }
        if self.wear_cuts.iter().any(|w| w.0 == name) {
            return Err(err("cut", "wear is given twice for this cut".into()));
        }
        self.wear_cuts.push((name.to_string(), law, coefficient, max_depth));
        Ok(())
    }

    /// Cycle-jump policy of wear runs.
    pub fn set_wear_jump(&mut self, policy: crate::wear::JumpPolicy) {
        self.wear_jump = policy;
    }

    /// How jumps extrapolate a computed cycle's wear (see [`crate::wear::JumpScheme`]).
    pub fn set_wear_scheme(&mut self, scheme: crate::wear::JumpScheme) {
        self.wear_scheme = scheme;
    }

    /// Wear-rate smoothing length in segments (see [`crate::wear::smooth_rate`]; 0: none).
    pub fn set_wear_smoothing(&mut self, segments: f64) {
        self.wear_smoothing = segments;
    }

    /// Makes a free cut move during the run (re-cut on fixed points, see
    /// [`crate::discretisation`]). Its band of fixed points is derived from the motion's
    /// factor range when the model is built.
    pub fn set_cut_motion(&mut self, name: &str, motion: SurfaceMotion) -> Result<(), ModelError> {
        let err = |msg: String| ModelError::MovingSurface { surface: name.to_string(), msg };
        let c = motion.curve();
        if c > self.curves.len() {
            return Err(err(format!("load curve {c} does not exist")));
        }
        let ok = match motion {
            SurfaceMotion::Translation { direction, .. } => direction.x.is_finite() && direction.y.is_finite(),
            SurfaceMotion::NormalOffset { distance, .. } => distance.is_finite(),
        };
        if !ok {
            return Err(err("the motion must be finite".into()));
        }
        let Some(f) = self.free_cuts.iter_mut().find(|f| f.0 == name) else {
            return Err(err(format!("no cut named '{name}'")));
        };
        if self.ties.iter().any(|t| t.host == f.1 && t.other_edges.is_none()) {
            return Err(err("a moving surface cannot share its host with a tie boundary yet".into()));
        }
        f.3 = Some(motion);
        Ok(())
    }

    /// Mortar contact (small sliding, fixed pairing from the reference geometry), frictionless
    /// when `mu = 0` (no tangential unknowns) or Coulomb with coefficient `mu`:
    /// the mortar surface (edge sets of `mortar`, one polyline) carries the multipliers; the
    /// other surface is the edge sets of `other_body` or the virtual surface of a free cut.
    pub fn add_contact(
        &mut self,
        name: &str,
        mortar: usize,
        mortar_sets: &[String],
        other_body: usize,
        other: ContactOther,
        params: ContactParams,
    ) -> Result<(), ModelError> {
        let side = self.mortar_side(mortar, mortar_sets, "contact surface", |msg| ModelError::Contact {
            contact: name.to_string(),
            key: "mortar_surface",
            msg,
        })?;
        self.push_contact(name, mortar, side, None, other_body, other, params)
    }

    /// Mortar contact whose mortar side is the virtual surface of free cut `mortar_cut` (in its
    /// host body): the multipliers live on that polyline (see
    /// [`crate::contact::VirtualMortar`]). A worn real boundary becomes such a cut.
    pub fn add_contact_on_cut(
        &mut self,
        name: &str,
        mortar_cut: &str,
        other_body: usize,
        other: ContactOther,
        params: ContactParams,
    ) -> Result<(), ModelError> {
        let Some(f) = self.free_cuts.iter().find(|f| f.0 == mortar_cut) else {
            return Err(ModelError::Contact {
                contact: name.to_string(),
                key: "mortar_cut",
                msg: format!("no cut named '{mortar_cut}'"),
            });
        };
        let mortar = f.1;
        // The side is the cut's polyline, known once the model is built.
        let side = MortarSide { nodes: vec![], points: vec![], closed: false };
        self.push_contact(name, mortar, side, Some(mortar_cut.to_string()), other_body, other, params)
    }

    /// Checks the friction coefficient and records a contact pair.
    #[allow(clippy::too_many_arguments)]
    fn push_contact(
        &mut self,
        name: &str,
        mortar: usize,
        side: MortarSide,
        mortar_cut: Option<String>,
        other_body: usize,
        other: ContactOther,
        params: ContactParams,
    ) -> Result<(), ModelError> {
        let mu = params.friction;
        if !(mu.is_finite() && mu >= 0.0) {
            return Err(ModelError::Contact {
                contact: name.to_string(),
                key: "friction",
                msg: format!("the friction coefficient must be finite and >= 0 (got {mu})"),
            });
        }
        let young = self.materials[self.bodies[mortar].material]
            .elastic()
            .young
            .max(self.materials[self.bodies[other_body].material].elastic().young);
        self.contacts.push(ContactSpec { name: name.to_string(), mortar, side, mortar_cut, other, young, params });
        Ok(())
    }

    /// Oriented edges of a body's edge sets, in global node ids (for [`ContactOther::Edges`]).
    pub fn global_edges(&self, body: usize, sets: &[String]) -> Result<Vec<[usize; 2]>, ModelError> {
        let off = self.bodies[body].node_offset;
        let mut v = Vec::new();
        for set in sets {
            v.extend(self.edge_set(body, set, "contact surface")?.into_iter().map(|e| [e[0] + off, e[1] + off]));
        }
        Ok(v)
    }

    /// Smallest edge length of a body's edge sets (a contact surface's element size).
    pub fn smallest_edge(&self, body: usize, sets: &[String]) -> Result<f64, ModelError> {
        let mesh = &self.bodies[body].mesh;
        let mut h = f64::INFINITY;
        for set in sets {
            for e in self.edge_set(body, set, "contact surface")? {
                h = h.min((mesh.nodes[e[1]] - mesh.nodes[e[0]]).norm());
            }
        }
        Ok(h)
    }

    /// Resultant force at the first node of a node or edge set (the master of a rigid set).
    pub fn total_load(&mut self, body: usize, set: &str, f: Vector2<f64>) -> Result<(), ModelError> {
        let nodes = self.node_set_or_edges(body, set)?;
        let Some(&n) = nodes.first() else { return Err(self.unknown_set(body, set)) };
        self.f_curves[self.curve][2 * n] += f.x;
        self.f_curves[self.curve][2 * n + 1] += f.y;
        Ok(())
    }

    /// Makes the nodes of a set move as one rigid translation (a rigid platen): constraint rows
    /// `u(n) - u(master) = 0` for both components, the master being the set's first node.
    /// Returns the master's body-local node index (load it with [`Self::point_load_node`]).
    pub fn rigid_set(&mut self, body: usize, set: &str) -> Result<usize, ModelError> {
        let nodes = self.node_set_or_edges(body, set)?;
        let Some(&master) = nodes.first() else {
            return Err(self.unknown_set(body, set));
        };
        for &n in &nodes[1..] {
            for c in 0..2 {
                self.rigid_rows.push(vec![(2 * n + c, 1.0), (2 * master + c, -1.0)]);
            }
        }
        Ok(master - self.bodies[body].node_offset)
    }

    /// Global nodes of a node set, or of the edges of an edge set (sorted).
    fn node_set_or_edges(&self, body: usize, set: &str) -> Result<Vec<usize>, ModelError> {
        let b = &self.bodies[body];
        if let Some(edges) = b.mesh.edge_sets.get(set) {
            let mut v: Vec<usize> = edges.iter().flat_map(|e| [e[0], e[1]]).map(|n| n + b.node_offset).collect();
            v.sort_unstable();
            v.dedup();
            return Ok(v);
        }
        self.node_set(body, set)
    }

    /// Ghost-penalty factor `gamma` on cut bodies (0 switches it off).
    pub fn set_ghost_penalty(&mut self, gamma: f64) {
        self.ghost_penalty = gamma;
    }

    /// Turns a real boundary (edge sets of `body`) into a free cut named `name` that coincides
    /// with it: a boundary that wears moves into its body as a virtual surface. An open
    /// boundary is extended past its ends along its end segments (a cut starts and ends outside
    /// its host); the material side comes from the cell along the first edge.
    pub fn add_boundary_cut(&mut self, name: &str, body: usize, sets: &[String]) -> Result<(), ModelError> {
        let err = |msg: String| ModelError::Cut { cut: name.to_string(), msg };
        let side = self.mortar_side(body, sets, "worn surface", err)?;
        let mut pts = side.points.clone();
        let b = &self.bodies[body];
        let local: Vec<usize> = side.nodes.iter().map(|&n| n - b.node_offset).collect();
        // Which side of the first edge the body lies on.
        let (n0, n1) = (local[0], local[1]);
        let Some(cell) = b.mesh.cells.iter().find(|c| c.nodes().contains(&n0) && c.nodes().contains(&n1)) else {
            return Err(err("the first edge belongs to no cell".into()));
        };
        let centroid =
            cell.nodes().iter().fold(Vector2::zeros(), |s, &n| s + b.mesh.nodes[n].coords) / cell.nodes().len() as f64;
        let (a, e) = (pts[0], pts[1] - pts[0]);
        let keep_left = e.x * (centroid.y - a.y) - e.y * (centroid.x - a.x) > 0.0;
        if !side.closed {
            // The end vertices move out along the end segments (doubling them), so that every
            // segment keeps a part inside the host.
            let n = pts.len();
            let (d0, d1) = (pts[0] - pts[1], pts[n - 1] - pts[n - 2]);
            pts[0] += d0;
            pts[n - 1] += d1;
        }
        self.add_cut(name, body, pts, side.closed, keep_left)
    }

    /// Cuts a body with a free virtual surface (a traction-free boundary inside its mesh): an open
    /// polyline crossing the body once (starting and ending outside it) or a closed one inside
    /// it. The body's material is kept on the left of the polyline (`keep_left`) or on its right.
    pub fn add_cut(
        &mut self,
        name: &str,
        body: usize,
        mut vertices: Vec<Point2<f64>>,
        closed: bool,
        keep_left: bool,
    ) -> Result<(), ModelError> {
        // Validated as given, so that segment indices in errors are the user's.
        let given = VirtualSurface { vertices: vertices.clone(), closed };
        given.validate().map_err(|e| ModelError::Cut { cut: name.to_string(), msg: e.to_string() })?;
        if !keep_left {
            vertices.reverse();
        }
        let surf = VirtualSurface { vertices, closed };
        self.free_cuts.push((name.to_string(), body, surf, None));
        self.reversed_cuts.push(!keep_left);
        Ok(())
    }

    /// The polyline (one open or closed chain) formed by a body's edge sets, as a mortar side;
    /// `err` names its owner in the error when the edges form no such chain.
    fn mortar_side(
        &self,
        body: usize,
        sets: &[String],
        what: &str,
        err: impl Fn(String) -> ModelError,
    ) -> Result<MortarSide, ModelError> {
        let mut edges: Vec<[usize; 2]> = Vec::new();
        for set in sets {
            edges.extend(self.edge_set(body, set, what)?);
        }
        if edges.is_empty() {
            return Err(err(format!("the {what} has no edges")));
        }
        let (chain, closed) = edge_chain(&edges).map_err(err)?;
        let b = &self.bodies[body];
        Ok(MortarSide {
            nodes: chain.iter().map(|&n| n + b.node_offset).collect(),
            points: chain.iter().map(|&n| b.mesh.nodes[n]).collect(),
            closed,
        })
    }

    /// Ties a patch body into a host body: the patch boundary (the listed edge sets of the patch,
    /// forming one closed loop inside the host, or one open polyline crossing the host, whose
    /// ends lie on or outside the host boundary) is embedded in the host as a virtual surface, the
    /// host material on the patch side of it is cut away, and the two are tied by mortar with
    /// multipliers on the patch side.
    pub fn add_tie(
        &mut self,
        name: &str,
        host: usize,
        patch: usize,
        boundary_sets: &[String],
        space: MultiplierSpace,
    ) -> Result<(), ModelError> {
        let err = |msg: String| ModelError::Tie { tie: name.to_string(), msg };
        if host == patch {
            return Err(err("host and patch must be different bodies".into()));
        }
        let side = self.mortar_side(patch, boundary_sets, "tie boundary", err)?;
        self.ties.push(TieSpec { name: name.to_string(), host, patch, side, space, other_edges: None });
        Ok(())
    }

    /// Classical mortar tie between two real surfaces (mesh edges of two bodies that coincide
    /// geometrically, with non-matching nodes). The first body is the mortar side and carries the
    /// multipliers; each side's edge sets must form one polyline.
    pub fn add_surface_tie(
        &mut self,
        name: &str,
        mortar: usize,
        mortar_sets: &[String],
        other: usize,
        other_sets: &[String],
        space: MultiplierSpace,
    ) -> Result<(), ModelError> {
        let err = |msg: String| ModelError::Tie { tie: name.to_string(), msg };
        if mortar == other {
            return Err(err("the two surfaces must belong to different bodies".into()));
        }
        let side = self.mortar_side(mortar, mortar_sets, "tie surface", err)?;
        let mut oe: Vec<[usize; 2]> = Vec::new();
        for set in other_sets {
            oe.extend(self.edge_set(other, set, "tie surface")?);
        }
        if oe.is_empty() {
            return Err(err("the other surface has no edges".into()));
        }
        let off = self.bodies[other].node_offset;
        let oe = oe.into_iter().map(|e| [e[0] + off, e[1] + off]).collect();
        self.ties.push(TieSpec {
            name: name.to_string(),
            host: other,
            patch: mortar,
            side,
            space,
            other_edges: Some(oe),
        });
        Ok(())
    }

    /// Adds a load curve (its id, >= 1; curve 0 is the load path given to [`Self::build`]).
    pub fn add_curve(&mut self, path: LoadPath) -> usize {
        self.curves.push(path);
        let n = self.f_curves[0].len();
        self.f_curves.push(vec![0.0; n]);
        self.curves.len()
    }
    /// Last time of the extra curves (`-inf` without any).
    pub fn curves(&self) -> &[LoadPath] {
        &self.curves
    }
    pub fn curves_end_time(&self) -> f64 {
        self.curves.iter().map(|c| c.end_time()).fold(f64::NEG_INFINITY, f64::max)
    }
    /// Loads and prescribed displacements added from now on follow curve `c` (0: the load path).
    pub fn use_curve(&mut self, c: usize) {
        assert!(c <= self.curves.len(), "curve {c} does not exist");
        self.curve = c;
    }

    pub fn add_material(&mut self, name: &str, m: Material) -> usize {
        self.materials.push(m);
        self.material_names.push(name.to_string());
        self.materials.len() - 1
    }

    pub fn add_body(
        &mut self,
        name: &str,
        mesh: Mesh2,
        material: usize,
        formulation: Formulation,
        thickness: f64,
    ) -> usize {
        let node_offset = self.bodies.last().map(|b| b.node_offset + b.mesh.num_nodes()).unwrap_or(0);
        let element_offset = self.bodies.last().map(|b| b.element_offset + b.mesh.num_cells()).unwrap_or(0);
        for f in &mut self.f_curves {
            f.resize(2 * (node_offset + mesh.num_nodes()), 0.0);
        }
        self.bodies.push(Body {
            name: name.to_string(),
            mesh,
            material,
            formulation,
            thickness,
            node_offset,
            element_offset,
        });
        self.bodies.len() - 1
    }

    pub fn body_index(&self, name: &str) -> Result<usize, ModelError> {
        self.bodies.iter().position(|b| b.name == name).ok_or_else(|| ModelError::UnknownBody(name.to_string()))
    }

    fn node_set(&self, body: usize, set: &str) -> Result<Vec<usize>, ModelError> {
        let b = &self.bodies[body];
        if let Some(v) = b.mesh.node_sets.get(set) {
            return Ok(v.iter().map(|n| n + b.node_offset).collect());
        }
        if let Some(cells) = b.mesh.cell_sets.get(set) {
            let mut v: Vec<usize> =
                cells.iter().flat_map(|&c| b.mesh.cells[c].nodes().to_vec()).map(|n| n + b.node_offset).collect();
            v.sort_unstable();
            v.dedup();
            return Ok(v);
        }
        Err(self.unknown_set(body, set))
    }

    fn unknown_set(&self, body: usize, set: &str) -> ModelError {
        let b = &self.bodies[body];
        ModelError::UnknownSet { body: b.name.clone(), set: set.to_string(), available: b.mesh.set_names().join(", ") }
    }

    fn edge_set(&self, body: usize, set: &str, what: &str) -> Result<Vec<[usize; 2]>, ModelError> {
        let b = &self.bodies[body];
        match b.mesh.edge_sets.get(set) {
            Some(v) => Ok(v.clone()),
            None if b.mesh.node_sets.contains_key(set) => {
                Err(ModelError::NotAnEdgeSet { body: b.name.clone(), set: set.to_string(), what: what.to_string() })
            }
            None => Err(self.unknown_set(body, set)),
        }
    }

    /// Prescribes displacement component `comp` (0 = x, 1 = y) to `value` on a node set.
    pub fn fix(&mut self, body: usize, set: &str, comp: usize, value: f64) -> Result<(), ModelError> {
        for n in self.node_set(body, set)? {
            self.prescribed.push((2 * n + comp, value, self.curve));
        }
        Ok(())
    }

    /// Prescribes component `comp` of one node (body-local index) to `value`.
    pub fn fix_node(&mut self, body: usize, node: usize, comp: usize, value: f64) {
        let off = self.bodies[body].node_offset;
        self.prescribed.push((2 * (node + off) + comp, value, self.curve));
    }

    /// Point force at one node (body-local index).
    pub fn point_load_node(&mut self, body: usize, node: usize, f: Vector2<f64>) {
        let off = self.bodies[body].node_offset;
        self.f_curves[self.curve][2 * (node + off)] += f.x;
        self.f_curves[self.curve][2 * (node + off) + 1] += f.y;
    }

    /// Uniform pressure `p` (positive pushes into the body: traction `-p n`) on an edge set.
    pub fn pressure(&mut self, body: usize, set: &str, p: f64) -> Result<(), ModelError> {
        let b = &self.bodies[body];
        let edges = self.edge_set(body, set, "pressure")?;
        let (off, t) = (b.node_offset, b.thickness);
        for e in edges {
            let (n, len) = b.mesh.edge_normal(e);
            let f = -p * n * len * t * 0.5;
            for &a in &e {
                self.f_curves[self.curve][2 * (a + off)] += f.x;
                self.f_curves[self.curve][2 * (a + off) + 1] += f.y;
            }
        }
        Ok(())
    }

    /// Uniform traction vector (force per unit length) on an edge set.
    pub fn traction(&mut self, body: usize, set: &str, tr: Vector2<f64>) -> Result<(), ModelError> {
        let b = &self.bodies[body];
        let edges = self.edge_set(body, set, "traction")?;
        let (off, t) = (b.node_offset, b.thickness);
        for e in edges {
            let seg = Seg2 { a: b.mesh.nodes[e[0]], b: b.mesh.nodes[e[1]] };
            let f = tr * seg.length() * t * 0.5;
            for &a in &e {
                self.f_curves[self.curve][2 * (a + off)] += f.x;
                self.f_curves[self.curve][2 * (a + off) + 1] += f.y;
            }
        }
        Ok(())
    }

    /// Point force applied at every node of a node set.
    pub fn point_load(&mut self, body: usize, set: &str, f: Vector2<f64>) -> Result<(), ModelError> {
        for n in self.node_set(body, set)? {
            self.f_curves[self.curve][2 * n] += f.x;
            self.f_curves[self.curve][2 * n + 1] += f.y;
        }
        Ok(())
    }

    /// Finishes the model: tie surfaces embedded (patch boundaries snapped with them), free
    /// cuts placed, hosts cut, element table (one fixed rule per element kind and per cut or
    /// band cell), tying rows, DOF map, contact pairs, free surfaces, wear. A DOF prescribed
    /// twice keeps its last value.
    pub fn build(
        mut self,
        load_path: LoadPath,
        times: Vec<f64>,
        newton: NewtonParams,
        linear_solver: LinearSolverKind,
    ) -> Result<Model, ModelError> {
        let tie_embeddings = self.embed_ties()?;
        let cut_embeddings = self.place_free_cuts(&load_path)?;
        let mut hosts = self.cut_hosts(&tie_embeddings, &cut_embeddings, &load_path)?;
        let elements = self.element_table(&hosts.cuts, &mut hosts.bands);
        let (mut constraints, ties) = self.tie_constraints(&tie_embeddings);
        constraints.extend(self.rigid_rows.iter().cloned());
        let prescribed = std::mem::take(&mut self.prescribed);
        let dofs = self.dof_map(prescribed, &hosts, elements.coords.len())?;
        let contact = self.contact_set(&cut_embeddings, elements.coords.len(), constraints.len())?;
        let surfaces = self.free_surfaces(cut_embeddings, &load_path);
        let wear = self.wear_model()?;
        let mut f_ext_curves = std::mem::take(&mut self.f_curves);
        let f_ext = f_ext_curves.remove(0);
        let linear_solver =
            if constraints.is_empty() && contact.rows.is_empty() { linear_solver } else { LinearSolverKind::Lu };
        Ok(Model {
            hypothesis: self.hypothesis,
            bodies: self.bodies,
            materials: self.materials,
            material_names: self.material_names,
            coords: elements.coords,
            elements: elements.table,
            rules: elements.rules,
            dofs: dofs.map,
            prescribed: dofs.prescribed.iter().map(|p| (p.0, p.1)).collect(),
            prescribed_curve: dofs.prescribed.iter().map(|p| p.2).collect(),
            f_ext,
            load_path,
            curves: self.curves,
            f_ext_curves,
            times,
            newton,
            linear_solver,
            constraints,
            ties,
            cuts: hosts.cuts,
            deactivated_dofs: dofs.held.iter().map(|h| h.len()).sum(),
            penalty: hosts.penalty_parts.iter().flatten().copied().collect(),
            contact,
            surfaces,
            bands: hosts.bands,
            penalty_parts: hosts.penalty_parts,
            ghost_penalty: self.ghost_penalty,
            held: dofs.held,
            cycle: self.cycle,
            wear,
            ghost_reach_cache: Default::default(),
        })
    }

    /// Embeds every tie's surface in its host (one embedding per tie without other edges, in
    /// tie order), snapped onto the host grid, and moves the patch boundary with it.
    fn embed_ties(&mut self) -> Result<Vec<(usize, Embedding)>, ModelError> {
        let mut embeddings: Vec<(usize, Embedding)> = Vec::new();
        for t in self.ties.iter().filter(|t| t.other_edges.is_none()) {
            let host = &self.bodies[t.host];
            if let Some((i, a, b)) = edge_on_outer_boundary(&host.mesh, &t.side) {
                return Err(ModelError::Tie {
                    tie: t.name.clone(),
                    msg: format!(
                        "patch boundary edge {i} from ({:.6}, {:.6}) to ({:.6}, {:.6}) lies on the host's outer boundary, \
                         where it couples nothing: list only the patch edges inside the host (an open boundary, e.g. \
                         [\"left\", \"bottom\", \"right\"])",
                        a.x, a.y, b.x, b.y
                    ),
                });
            }
            let terr = |e: SurfaceError| ModelError::Tie { tie: t.name.clone(), msg: e.to_string() };
            // Validated in the patch boundary's own order, so that segment numbers in errors
            // follow the patch's edges (the embedded loop is its reverse).
            VirtualSurface { vertices: t.side.points.clone(), closed: t.side.closed }.validate().map_err(terr)?;
            let mut v = t.side.points.clone();
            v.reverse(); // host material outside the patch = on the left of the reversed loop
            let surf = VirtualSurface { vertices: v, closed: t.side.closed };
            let index = BoxIndex::over_cells(&host.mesh);
            embeddings.push((t.host, embed(&surf, &host.mesh, &index).map_err(terr)?));
        }
        // The interface is one geometric entity: snapping moved the virtual surface onto host
        // nodes or edges, so move the patch boundary nodes (the mortar side) with it.
        for (t, (_, emb)) in self.ties.iter_mut().filter(|t| t.other_edges.is_none()).zip(&embeddings) {
            let n = t.side.points.len();
            let off = self.bodies[t.patch].node_offset;
            for i in 0..n {
                let snapped = emb.vertices[n - 1 - i];
                t.side.points[i] = snapped;
                self.bodies[t.patch].mesh.nodes[t.side.nodes[i] - off] = snapped;
            }
            self.bodies[t.patch].mesh.validate().map_err(|e| ModelError::Tie {
                tie: t.name.clone(),
                msg: format!("after snapping the interface onto the host grid: {e}"),
            })?;
        }
        Ok(embeddings)
    }

    /// Gives every wearing polyline a vertex at each host edge crossing, then embeds every free
    /// cut in its host where it is at the start of the load path (one embedding per cut).
    fn place_free_cuts(&mut self, load_path: &LoadPath) -> Result<Vec<(usize, Embedding)>, ModelError> {
        let cut_err = |name: &String, e: SurfaceError| ModelError::Cut { cut: name.clone(), msg: e.to_string() };
        // A wearing polyline wears at its own vertices: give it one at every host edge crossing.
        for (name, body, surf, _) in self.free_cuts.iter_mut() {
            if !self.wear_cuts.iter().any(|w| &w.0 == name) {
                continue;
            }
            let index = BoxIndex::over_cells(&self.bodies[*body].mesh);
            let emb = embed(surf, &self.bodies[*body].mesh, &index).map_err(|e| cut_err(name, e))?;
            *surf = crate::discretisation::refined_at_crossings(surf, &emb);
        }
        let mut cut_embeddings: Vec<(usize, Embedding)> = Vec::new();
        for (name, body, surf, motion) in &self.free_cuts {
            let index = BoxIndex::over_cells(&self.bodies[*body].mesh);
            // A moving surface starts where its motion puts it at the start of the load path.
            let placed =
                VirtualSurface { vertices: self.start_vertices(surf, motion.as_ref(), load_path), closed: surf.closed };
            let emb = embed(&placed, &self.bodies[*body].mesh, &index).map_err(|e| cut_err(name, e))?;
            cut_embeddings.push((*body, emb));
        }
        Ok(cut_embeddings)
    }

    /// Vertices of a free cut at the start of the load path (where its motion, if any, puts it).
    fn start_vertices(
        &self,
        surf: &VirtualSurface,
        motion: Option<&SurfaceMotion>,
        load_path: &LoadPath,
    ) -> Vec<Point2<f64>> {
        match motion {
            Some(m) => m.place(surf, curve_value(&self.curves, load_path, m.curve(), load_path.points[0].0)),
            None => surf.vertices.clone(),
        }
    }

    /// Cuts every body some surface is embedded in: its cut state, its band of fixed points
    /// (moving and wearing surfaces) and its ghost-penalty entries.
    fn cut_hosts(
        &self,
        tie_embeddings: &[(usize, Embedding)],
        cut_embeddings: &[(usize, Embedding)],
        load_path: &LoadPath,
    ) -> Result<CutHosts, ModelError> {
        let n = self.bodies.len();
        let mut hosts = CutHosts { cuts: vec![None; n], bands: vec![None; n], penalty_parts: vec![vec![]; n] };
        for (b, body) in self.bodies.iter().enumerate() {
            let embs: Vec<&Embedding> =
                tie_embeddings.iter().chain(cut_embeddings).filter(|(h, _)| *h == b).map(|(_, e)| e).collect();
            if embs.is_empty() {
                continue;
            }
            let adjacency = crate::cut::CellAdjacency::new(&body.mesh);
            let c = cut_mesh(&body.mesh, &adjacency, &embs).map_err(|e| {
                // Name the surface that runs through the failing cell.
                let names = self
                    .ties
                    .iter()
                    .filter(|t| t.other_edges.is_none())
                    .map(|t| &t.name)
                    .zip(tie_embeddings)
                    .chain(self.free_cuts.iter().map(|c| &c.0).zip(cut_embeddings))
                    .filter(|(_, (h, _))| *h == b)
                    .map(|(name, (_, emb))| (name, emb));
                ModelError::CutMesh { body: body.name.clone(), surface: surface_through(names, &e), msg: e.to_string() }
            })?;
            hosts.bands[b] = self.band(b, &adjacency, tie_embeddings, load_path)?;
            if self.ghost_penalty > 0.0 {
                let young = self.materials[body.material].elastic().young;
                hosts.penalty_parts[b].extend(crate::cut::ghost_penalty(
                    &body.mesh,
                    &adjacency,
                    &c,
                    body.node_offset,
                    young,
                    self.ghost_penalty,
                ));
            }
            hosts.cuts[b] = Some(c);
        }
        Ok(hosts)
    }

    /// The band of fixed points of body `b`: the cells its moving surfaces may visit over their
    /// motion's factor range and those its wearing surfaces may wear into (`None`: no such cell).
    /// Its rules are filled in with the element table.
    fn band(
        &self,
        b: usize,
        adjacency: &crate::cut::CellAdjacency,
        tie_embeddings: &[(usize, Embedding)],
        load_path: &LoadPath,
    ) -> Result<Option<Band>, ModelError> {
        let body = &self.bodies[b];
        let mut band_cells_b: Vec<usize> = Vec::new();
        for (name, cb, surf, motion) in self.free_cuts.iter() {
            let (Some(motion), true) = (motion, *cb == b) else { continue };
            let range = curve_range(&self.curves, load_path, motion.curve());
            let cells = crate::discretisation::band_cells(&body.mesh, adjacency, surf, motion, range)
                .map_err(|e| ModelError::MovingSurface { surface: name.clone(), msg: e.to_string() })?;
            band_cells_b.extend(cells);
        }
        for (name, cb, surf, _) in self.free_cuts.iter() {
            let Some(w) = self.wear_cuts.iter().find(|w| &w.0 == name) else { continue };
            if *cb != b {
                continue;
            }
            let reach = SurfaceMotion::NormalOffset { distance: w.3, curve: 0 };
            let cells =
                crate::discretisation::band_cells(&body.mesh, adjacency, surf, &reach, (0.0, 1.0)).map_err(|e| {
                    ModelError::Wear {
                        surface: name.clone(),
                        key: "max_depth",
                        msg: format!("its band of fixed points, max_depth = {} deep: {e}", w.3),
                    }
                })?;
            band_cells_b.extend(cells);
        }
        if band_cells_b.is_empty() {
            return Ok(None);
        }
        band_cells_b.sort_unstable();
        band_cells_b.dedup();
        let fixed_embeddings = tie_embeddings.iter().filter(|(h, _)| *h == b).map(|(_, e)| e.clone()).collect();
        let points = if self.materials[body.material].has_state() {
            crate::cut::BandPoints::Material
        } else {
            crate::cut::BandPoints::Any
        };
        Ok(Some(Band {
            cells: band_cells_b,
            rules: vec![],
            points,
            adjacency: adjacency.clone(),
            index: std::sync::Arc::new(BoxIndex::over_cells(&body.mesh)),
            fixed_embeddings,
        }))
    }

    /// Quadrature rules (one per element kind, an empty one for void cells, one per cut or band
    /// cell), node coordinates and the element table; each band records its cells' rules.
    fn element_table(&self, cuts: &[Option<CutMesh>], bands: &mut [Option<Band>]) -> Elements {
        let mut rules = vec![
            CellKind::Tri3.stiffness_rule(),
            CellKind::Quad4.stiffness_rule(),
            QuadratureRule { points: vec![], weights: vec![] },
        ];
        let rule_of = |k: CellKind| match k {
            CellKind::Tri3 => 0,
            CellKind::Quad4 => 1,
        };
        let mut el = ElementTable::default();
        el.point_offset.push(0);
        el.state_offset.push(0);
        let mut coords = Vec::new();
        for (bi, b) in self.bodies.iter().enumerate() {
            coords.extend_from_slice(&b.mesh.nodes);
            let stateful = self.materials[b.material].has_state();
            let cut = cuts[bi].as_ref();
            for (ci, c) in b.mesh.cells.iter().enumerate() {
                // A Tri3 leaves its fourth entry at usize::MAX, the padding of its mesh cell.
                let mut nodes = [usize::MAX; 4];
                for (k, &n) in c.nodes().iter().enumerate() {
                    nodes[k] = n + b.node_offset;
                }
                let in_band = bands[bi].as_ref().is_some_and(|band| band.cells.binary_search(&ci).is_ok());
                let r = match cut.map(|cm| &cm.cells[ci]) {
                    Some(state) if in_band => {
                        let which = bands[bi].as_ref().map_or(crate::cut::BandPoints::Material, |band| band.points);
                        rules.push(crate::discretisation::band_cell_rule(&b.mesh, ci, state, which).0);
                        if let Some(band) = bands[bi].as_mut() {
                            band.rules.push(rules.len() - 1);
                        }
                        rules.len() - 1
                    }
                    None | Some(CellCut::Material) => rule_of(c.kind),
                    Some(CellCut::Void) => 2,
                    Some(CellCut::Cut { loops, .. }) => {
                        rules.push(subtriangulation_rule(&b.mesh, ci, loops));
                        rules.len() - 1
                    }
                };
                let np = rules[r].len();
                el.kind.push(c.kind);
                el.nodes.push(nodes);
                el.material.push(b.material);
                // B-bar on a triangle is the identity (constant strain): keep it standard.
                el.formulation.push(if c.kind == CellKind::Tri3 { Formulation::Standard } else { b.formulation });
                el.thickness.push(b.thickness);
                el.rule.push(r);
                let p = el.point_offset[el.point_offset.len() - 1];
                el.point_offset.push(p + np);
                let s = el.state_offset[el.state_offset.len() - 1];
                el.state_offset.push(s + if stateful { np } else { 0 });
            }
        }
        Elements { rules, coords, table: el }
    }

    /// Mortar tying: every tie's multipliers and constraint rows (from the embeddings of the
    /// ties with a virtual surface, in tie order).
    fn tie_constraints(&self, tie_embeddings: &[(usize, Embedding)]) -> (Vec<ConstraintRow>, Vec<TieInfo>) {
        let mut constraints = Vec::new();
        let mut ties = Vec::new();
        let mut embedded = tie_embeddings.iter();
        for t in &self.ties {
            let (multipliers, rows) = match &t.other_edges {
                None => {
                    let Some((_, emb)) = embedded.next() else { continue };
                    let host = &self.bodies[t.host];
                    let mut cells: Vec<usize> = emb.cell_pieces.iter().map(|p| p.cell).collect();
                    cells.sort_unstable();
                    cells.dedup();
                    let h_host = cells.iter().map(|&c| cell_size(&cell_polygon(&host.mesh, c))).sum::<f64>()
                        / cells.len().max(1) as f64;
                    let multipliers = build_multipliers(&t.side, t.space, h_host);
                    let rows = tying_rows(
                        &t.side,
                        &multipliers,
                        &OtherSide::Embedded { host: &host.mesh, host_offset: host.node_offset, embedding: emb },
                    );
                    (multipliers, rows)
                }
                Some(edges) => {
                    let pts: Vec<[Point2<f64>; 2]> =
                        edges.iter().map(|e| [coords_of(&self.bodies, e[0]), coords_of(&self.bodies, e[1])]).collect();
                    let h_other = pts.iter().map(|p| (p[1] - p[0]).norm()).sum::<f64>() / pts.len() as f64;
                    let multipliers = build_multipliers(&t.side, t.space, h_other);
                    let rows = tying_rows(&t.side, &multipliers, &OtherSide::Edges { nodes: edges, points: &pts });
                    (multipliers, rows)
                }
            };
            ties.push(TieInfo {
                name: t.name.clone(),
                host: t.host,
                patch: t.patch,
                space: t.space,
                first_row: constraints.len(),
                multipliers,
            });
            constraints.extend(rows);
        }
        (constraints, ties)
    }

    /// The DOF map: prescribed DOFs (one entry each, the last given), DOFs held because their
    /// support keeps (almost) no material, the rest free.
    fn dof_map(
        &self,
        prescribed: Vec<(usize, f64, usize)>,
        hosts: &CutHosts,
        num_nodes: usize,
    ) -> Result<Dofs, ModelError> {
        let prescribed = last_prescribed(prescribed);
        // Switch off host nodes whose support keeps (almost) no material: their DOFs leave the
        // unknowns and keep their value (zero until a surface moves).
        let prescribed_pairs: Vec<(usize, f64)> = prescribed.iter().map(|p| (p.0, p.1)).collect();
        let held: Vec<Vec<usize>> = hosts
            .cuts
            .iter()
            .enumerate()
            .map(|(b, cut)| {
                cut.as_ref().map_or(vec![], |cm| {
                    held_dofs(cm, self.bodies[b].node_offset, &prescribed_pairs, &hosts.penalty_parts[b])
                })
            })
            .collect();
        let mut constrained: Vec<usize> = prescribed.iter().map(|p| p.0).collect();
        constrained.extend(held.iter().flatten().copied());
        let map = DofMap::new(num_nodes, &constrained);
        if map.num_free == 0 {
            return Err(ModelError::NoFreeDofs);
        }
        Ok(Dofs { map, prescribed, held })
    }

    /// Contact pairs and their weighted-gap (and slip) rows from the reference geometry; their
    /// multipliers follow the first `first_multiplier` (ties, rigid sets).
    fn contact_set(
        &self,
        cut_embeddings: &[(usize, Embedding)],
        num_nodes: usize,
        first_multiplier: usize,
    ) -> Result<ContactSet, ModelError> {
        let mut set = ContactSet { first_multiplier, ..Default::default() };
        let hosts: Vec<(&Mesh2, usize)> = self.bodies.iter().map(|b| (&b.mesh, b.node_offset)).collect();
        for c in &self.contacts {
            let (mut info, h) = self.contact_pair(c, cut_embeddings, num_nodes)?;
            info.first_row = set.rows.len();
            // The reference pairing, by the same routine as every re-pairing.
            let rows = crate::contact::pair_rows(&hosts, &info, &|n| coords_of(&self.bodies, n));
            for r in rows {
                set.tangents.push(r.tangent.clone());
                // Every node of a frictional pair gets a friction row, paired or not (pairings
                // come and go under finite sliding and moving surfaces): the multiplier layout
                // is fixed for the run.
                info.friction_row.push(if c.params.friction > 0.0 {
                    set.friction_rows.push(r.tangent);
                    set.friction_normal.push(set.rows.len());
                    Some(set.friction_rows.len() - 1)
                } else {
                    None
                });
                set.rows.push(r.normal);
                set.g0.push(r.g0);
                set.phi.push(r.phi);
                // Augmentation from the local bulk stiffness: E / h.
                set.eps.push(c.young / h);
                set.mu.push(c.params.friction);
            }
            set.pairs.push(info);
        }
        set.friction_s0 = vec![0.0; set.friction_rows.len()];
        Ok(set)
    }

    /// One contact pair before pairing (no rows yet, `first_row` 0) and the mean segment length
    /// `h` of its mortar side; its gap reach is `2 h` plus the depth its wearing sides may sink.
    fn contact_pair(
        &self,
        c: &ContactSpec,
        cut_embeddings: &[(usize, Embedding)],
        num_nodes: usize,
    ) -> Result<(ContactInfo, f64), ModelError> {
        let (side, virtual_mortar) = self.contact_mortar_side(c, cut_embeddings, num_nodes)?;
        let nseg = side.num_segments();
        let h = (0..nseg).map(|i| (side.points[(i + 1) % side.points.len()] - side.points[i]).norm()).sum::<f64>()
            / nseg as f64;
        // Wearing sides sink by up to their max_depth: they stay within reach.
        let depth_of = |cut: &String| self.wear_cuts.iter().find(|w| &w.0 == cut).map_or(0.0, |w| w.3);
        let wear_reach = match &c.other {
            ContactOther::Cut(cut) => depth_of(cut),
            _ => 0.0,
        } + c.mortar_cut.as_ref().map_or(0.0, depth_of);
        let max_gap = 2.0 * h + wear_reach;
        let pts: Vec<[Point2<f64>; 2]>;
        let mut other_surface = None;
        let (other, paired) = match &c.other {
            ContactOther::Edges(edges) => {
                pts = edges.iter().map(|e| [coords_of(&self.bodies, e[0]), coords_of(&self.bodies, e[1])]).collect();
                (OtherSide::Edges { nodes: edges, points: &pts }, PairedSide::Edges(edges.clone()))
            }
            ContactOther::Cut(cut) => {
                let Some(i) = self.free_cut_index(cut) else {
                    return Err(ModelError::Contact {
                        contact: c.name.clone(),
                        key: "other_cut",
                        msg: format!("no cut named '{cut}'"),
                    });
                };
                other_surface = Some(i);
                let (b, emb) = &cut_embeddings[i];
                let host = &self.bodies[*b];
                (
                    OtherSide::Embedded { host: &host.mesh, host_offset: host.node_offset, embedding: emb },
                    PairedSide::Embedded { host: *b, embedding: emb.clone() },
                )
            }
        };
        let multipliers = match c.params.multipliers {
            MultiplierSpace::Classical => build_multipliers(&side, MultiplierSpace::Classical, 1.0),
            MultiplierSpace::CoarseGrained => {
                build_multipliers_local(&side, &other_side_spacing(&side, &other, max_gap))
            }
        };
        let info = ContactInfo {
            name: c.name.clone(),
            mortar: c.mortar,
            mu: c.params.friction,
            space: c.params.multipliers,
            first_row: 0,
            friction_row: vec![],
            multipliers,
            sliding: c.params.sliding,
            side,
            other: paired,
            max_gap,
            other_surface,
            virtual_mortar,
        };
        Ok((info, h))
    }

    /// A contact pair's mortar side: its real edges, or the polyline of its mortar cut, whose
    /// vertices stand in for nodes numbered from `base` (interpolated in the cut's host).
    fn contact_mortar_side(
        &self,
        c: &ContactSpec,
        cut_embeddings: &[(usize, Embedding)],
        base: usize,
    ) -> Result<(MortarSide, Option<crate::contact::VirtualMortar>), ModelError> {
        let Some(cut) = &c.mortar_cut else { return Ok((c.side.clone(), None)) };
        let Some(si) = self.free_cut_index(cut) else {
            return Err(ModelError::Contact {
                contact: c.name.clone(),
                key: "mortar_cut",
                msg: format!("no cut named '{cut}'"),
            });
        };
        let (body, emb) = &cut_embeddings[si];
        let surf = &self.free_cuts[si].2;
        let host = &self.bodies[*body];
        let virtual_mortar = crate::contact::VirtualMortar {
            surface: si,
            host: *body,
            base,
            interpolation: crate::contact::VirtualMortar::interpolation(
                &host.mesh,
                host.node_offset,
                emb,
                &surf.vertices,
                surf.closed,
            ),
        };
        let side = MortarSide {
            nodes: (base..base + surf.vertices.len()).collect(),
            points: surf.vertices.clone(),
            closed: surf.closed,
        };
        Ok((side, Some(virtual_mortar)))
    }

    /// Index of the free cut named `name`.
    fn free_cut_index(&self, name: &str) -> Option<usize> {
        self.free_cuts.iter().position(|f| f.0 == name)
    }

    /// The free surfaces where the load path starts, with their embeddings (one per cut).
    fn free_surfaces(&self, cut_embeddings: Vec<(usize, Embedding)>, load_path: &LoadPath) -> Vec<FreeSurface> {
        self.free_cuts
            .iter()
            .zip(cut_embeddings)
            .zip(&self.reversed_cuts)
            .map(|(((name, body, surf, motion), (_, embedding)), &reversed)| FreeSurface {
                reversed,
                name: name.clone(),
                body: *body,
                base: surf.clone(),
                motion: *motion,
                vertices: self.start_vertices(surf, motion.as_ref(), load_path),
                embedding,
            })
            .collect()
    }

    /// The wearing surfaces, each with the contact pair it wears in, and the cycle-jump policy.
    fn wear_model(&self) -> Result<crate::wear::WearModel, ModelError> {
        let mut wear = crate::wear::WearModel {
            surfaces: vec![],
            jump: self.wear_jump,
            scheme: self.wear_scheme,
            smoothing: self.wear_smoothing,
        };
        for (name, law, coefficient, max_depth) in &self.wear_cuts {
            let Some(surface) = self.free_cut_index(name) else {
                return Err(ModelError::Wear {
                    surface: name.clone(),
                    key: "cut",
                    msg: format!("no cut named '{name}'"),
                });
            };
            let as_other = self.contacts.iter().position(|c| matches!(&c.other, ContactOther::Cut(n) if n == name));
            let as_mortar = self.contacts.iter().position(|c| c.mortar_cut.as_ref() == Some(name));
            let Some(contact) = as_other.or(as_mortar) else {
                return Err(ModelError::Wear {
                    surface: name.clone(),
                    key: "cut",
                    msg: "the surface is not in contact with anything (no contact pair has it as a side)".into(),
                });
            };
            wear.surfaces.push(crate::wear::WearingSurface {
                name: name.clone(),
                surface,
                contact,
                on_mortar_side: as_other.is_none(),
                coefficient: *coefficient,
                law: *law,
                max_depth: *max_depth,
            });
        }
        Ok(wear)
    }
}

/// Moving surfaces (see [`crate::discretisation`]): the model re-cut on its fixed band points.
impl Model {
    /// The wear state before any wear: surfaces where the model put them, nothing worn.
    pub fn initial_wear_state(&self) -> crate::state::WearState {
        let n = self.wear.surfaces.len();
        if n == 0 {
            return crate::state::WearState::default();
        }
        let verts: Vec<Vec<[f64; 2]>> = self
            .wear
            .surfaces
            .iter()
            .map(|w| self.surfaces[w.surface].vertices.iter().map(|p| [p.x, p.y]).collect())
            .collect();
        crate::state::WearState {
            depth: verts.iter().map(|v| vec![0.0; v.len()]).collect(),
            cycle_volume: verts.iter().map(|v| vec![0.0; v.len()]).collect(),
            vertices: verts,
            cycle_work: vec![0.0; n],
            cycle_row_work: self
                .wear
                .surfaces
                .iter()
                .map(|w| vec![0.0; self.contact.pairs[w.contact].multipliers.num_nodes])
                .collect(),
            cycle_row_slip: self
                .wear
                .surfaces
                .iter()
                .map(|w| vec![0.0; self.contact.pairs[w.contact].multipliers.num_nodes])
                .collect(),
            worn_area: vec![0.0; n],
            work: vec![0.0; n],
            ..Default::default()
        }
    }

    /// Area of body `b`'s material (per unit thickness): its cells, times their material
    /// fraction where the body is cut.
    pub fn material_area(&self, b: usize) -> f64 {
        let mesh = &self.bodies[b].mesh;
        (0..mesh.num_cells())
            .map(|c| {
                let a = crate::surface::cell_size(&crate::surface::cell_polygon(mesh, c)).powi(2);
                self.cuts[b].as_ref().map_or(a, |cm| a * cm.cell_fraction[c])
            })
            .sum()
    }

    /// Puts the wearing surfaces where `wear` has them (re-cut, re-paired).
    pub fn place_worn_surfaces(&mut self, wear: &crate::state::WearState) -> Result<RecutReport, ModelError> {
        let positions: Vec<(usize, Vec<Point2<f64>>)> = self
            .wear
            .surfaces
            .iter()
            .zip(&wear.vertices)
            .map(|(w, v)| (w.surface, v.iter().map(|p| Point2::new(p[0], p[1])).collect()))
            .collect();
        self.move_surfaces(&positions)
    }

    /// Vertices of free surface `i` at time `t` (its reference vertices when it does not move).
    pub fn surface_vertices_at(&self, i: usize, t: f64) -> Vec<Point2<f64>> {
        let s = &self.surfaces[i];
        match &s.motion {
            // A motion is a process over the whole run: its curve is read at the absolute time,
            // never wrapped into the load cycle.
            Some(m) => m.place(&s.base, self.curve_factor_absolute(m.curve(), t)),
            None => s.base.vertices.clone(),
        }
    }

    /// What the wear update reads of this model's current discretisation.
    pub fn wear_scene(&self) -> crate::wear::WearScene<'_> {
        crate::wear::WearScene {
            contact: &self.contact,
            hosts: self.hosts(),
            surfaces: &self.surfaces,
            coords: &self.coords,
            model: &self.wear,
            increments: self.cycle.map_or(0, |c| c.increments),
        }
    }

    /// Whether any surface of the model moves during the run.
    pub fn has_moving_surfaces(&self) -> bool {
        self.surfaces.iter().any(|s| s.motion.is_some())
    }

    /// Moves every moving surface to its position at time `t` and re-cuts (see the module
    /// documentation). The state layout does not change.
    pub fn place_surfaces(&mut self, t: f64) -> Result<RecutReport, ModelError> {
        let positions: Vec<(usize, Vec<Point2<f64>>)> = (0..self.surfaces.len())
            .filter(|&i| self.surfaces[i].motion.is_some())
            .map(|i| (i, self.surface_vertices_at(i, t)))
            .collect();
        self.move_surfaces(&positions)
    }

    /// Moves free surfaces to new vertex positions (`(surface index, vertices)`, same vertex
    /// count) and re-cuts their hosts on the fixed band points.
    pub fn move_surfaces(&mut self, positions: &[(usize, Vec<Point2<f64>>)]) -> Result<RecutReport, ModelError> {
        let mut report = RecutReport::default();
        let mut bodies: Vec<usize> = Vec::new();
        let mut moved: Vec<usize> = Vec::new();
        for (i, v) in positions {
            let s = &self.surfaces[*i];
            let err = |msg: String| ModelError::MovingSurface { surface: s.name.clone(), msg };
            if v.len() != s.base.vertices.len() {
                return Err(err(format!(
                    "a move gave {} vertices, the surface has {}",
                    v.len(),
                    s.base.vertices.len()
                )));
            }
            if *v == s.vertices {
                continue;
            }
            if self.bands[s.body].is_none() {
                return Err(err("the surface was not declared moving: its host has no band of fixed points".into()));
            }
            if v.iter().any(|p| !p.x.is_finite() || !p.y.is_finite()) {
                return Err(err("a move gave a non-finite vertex".into()));
            }
            let surf = VirtualSurface { vertices: v.clone(), closed: s.base.closed };
            surf.validate().map_err(|e| err(e.to_string()))?;
            let mesh = &self.bodies[s.body].mesh;
            let Some(band) = self.bands[s.body].as_ref() else { continue };
            let emb = embed(&surf, mesh, &band.index).map_err(|e| err(e.to_string()))?;
            let body = s.body;
            self.surfaces[*i].vertices = v.clone();
            self.surfaces[*i].embedding = emb;
            moved.push(*i);
            if !bodies.contains(&body) {
                bodies.push(body);
            }
        }
        report.moved = moved.len();
        for &b in &bodies {
            self.recut_body(b, &mut report)?;
        }
        if !moved.is_empty() {
            self.refresh_contact_rows(&moved);
            self.penalty = self.penalty_parts.iter().flatten().copied().collect();
            let mut constrained: Vec<usize> = self.prescribed.iter().map(|p| p.0).collect();
            constrained.extend(self.held.iter().flatten().copied());
            self.dofs = DofMap::new(self.coords.len(), &constrained);
            if self.dofs.num_free == 0 {
                return Err(ModelError::NoFreeDofs);
            }
        }
        report.held_dofs = self.held.iter().map(|h| h.len()).sum();
        self.deactivated_dofs = report.held_dofs;
        Ok(report)
    }

    /// Every DOF pair `(i, j)` (both orders) the ghost penalty can couple during the run: on
    /// a body with moving surfaces, the same component of the nodes of any two band cells (or
    /// a band cell and its neighbour) across a shared face, whether or not the face is next to
    /// a cut cell now; on other bodies the entries it has. A solver pattern holding these does
    /// not change when the surfaces move (see `analysis::condensed`).
    pub fn ghost_reach(&self) -> &[(usize, usize)] {
        self.ghost_reach_cache.get_or_init(|| self.form_ghost_reach())
    }

    /// [`Model::ghost_reach`] formed from the bands (sorted, without repeats).
    fn form_ghost_reach(&self) -> Vec<(usize, usize)> {
        let mut v: Vec<(usize, usize)> = Vec::new();
        for (b, body) in self.bodies.iter().enumerate() {
            let Some(band) = &self.bands[b] else {
                v.extend(self.penalty_parts[b].iter().map(|&(i, j, _)| (i, j)));
                continue;
            };
            if self.ghost_penalty <= 0.0 {
                continue;
            }
            let cells = &body.mesh.cells;
            for &c in &band.cells {
                let own = cells[c].nodes();
                for k in 0..own.len() {
                    let Some(nb) = band.adjacency.neighbour(c, k) else { continue };
                    let other = cells[nb].nodes();
                    // Pairs inside one cell are element couplings already.
                    for &p in own.iter().filter(|p| !other.contains(p)) {
                        for &q in other.iter().filter(|q| !own.contains(q)) {
                            let (gp, gq) = (p + body.node_offset, q + body.node_offset);
                            for comp in 0..2 {
                                v.push((2 * gp + comp, 2 * gq + comp));
                                v.push((2 * gq + comp, 2 * gp + comp));
                            }
                        }
                    }
                }
            }
        }
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Re-cuts body `b` with its current surfaces: cut state, band weights, ghost penalty and
    /// switched-off nodes.
    fn recut_body(&mut self, b: usize, report: &mut RecutReport) -> Result<(), ModelError> {
        let Some(band) = self.bands[b].as_ref() else { return Ok(()) };
        let body = &self.bodies[b];
        let mut embs: Vec<&Embedding> = band.fixed_embeddings.iter().collect();
        embs.extend(self.surfaces.iter().filter(|s| s.body == b).map(|s| &s.embedding));
        let named = || self.surfaces.iter().filter(|s| s.body == b).map(|s| (&s.name, &s.embedding));
        let cm = cut_mesh(&body.mesh, &band.adjacency, &embs).map_err(|e| ModelError::CutMesh {
            body: body.name.clone(),
            surface: surface_through(named(), &e),
            msg: e.to_string(),
        })?;
        // Outside the band nothing may change: its cells have fixed rules.
        if let Some(old) = &self.cuts[b] {
            for c in 0..body.mesh.num_cells() {
                if cm.cells[c] != old.cells[c] && band.cells.binary_search(&c).is_err() {
                    // The surface now in the cell, else (it left the cell) the body's first.
                    let surface = named()
                        .find(|(_, emb)| emb.cell_pieces.iter().any(|p| p.cell == c))
                        .or_else(|| named().next())
                        .map_or_else(String::new, |(name, _)| name.clone());
                    return Err(ModelError::MovingSurface {
                        surface,
                        msg: format!(
                            "the surface reached host cell {c}, outside the band of fixed points prepared for its motion"
                        ),
                    });
                }
            }
        }
        for (&c, &r) in band.cells.iter().zip(&band.rules) {
            let (rule, degree) = band_cell_rule(&body.mesh, c, &cm.cells[c], band.points);
            if matches!(cm.cells[c], CellCut::Cut { .. }) {
                match degree {
                    Some(d) if d <= 2 => report.cut_cells_by_degree[d] += 1,
                    _ => report.unfitted_cells += 1,
                }
            }
            self.rules[r] = rule;
        }
        self.penalty_parts[b] = if self.ghost_penalty > 0.0 {
            let young = self.materials[body.material].elastic().young;
            crate::cut::ghost_penalty(&body.mesh, &band.adjacency, &cm, body.node_offset, young, self.ghost_penalty)
        } else {
            vec![]
        };
        self.held[b] = held_dofs(&cm, body.node_offset, &self.prescribed, &self.penalty_parts[b]);
        self.cuts[b] = Some(cm);
        Ok(())
    }

    /// Rebuilds the weighted-gap rows of contact pairs with a side on a moved surface (small
    /// sliding: from the reference geometry; finite sliding re-pairs every step anyway). A
    /// virtual mortar side keeps its multiplier layout; its geometry follows the vertices.
    fn refresh_contact_rows(&mut self, moved: &[usize]) {
        for pair in 0..self.contact.pairs.len() {
            let other_moved = self.contact.pairs[pair].other_surface.filter(|si| moved.contains(si));
            let mortar_moved =
                self.contact.pairs[pair].virtual_mortar.as_ref().map(|v| v.surface).filter(|si| moved.contains(si));
            if other_moved.is_none() && mortar_moved.is_none() {
                continue;
            }
            if let Some(si) = other_moved {
                let s = &self.surfaces[si];
                self.contact.pairs[pair].other = PairedSide::Embedded { host: s.body, embedding: s.embedding.clone() };
            }
            if let Some(si) = mortar_moved {
                let s = &self.surfaces[si];
                let (mesh, off) = (&self.bodies[s.body].mesh, self.bodies[s.body].node_offset);
                let interpolation =
                    crate::contact::VirtualMortar::interpolation(mesh, off, &s.embedding, &s.vertices, s.base.closed);
                let c = &mut self.contact.pairs[pair];
                c.side.points = s.vertices.clone();
                c.multipliers = c.multipliers.with_geometry(&c.side);
                if let Some(vm) = c.virtual_mortar.as_mut() {
                    vm.interpolation = interpolation;
                }
            }
            let coords = &self.coords;
            let rows = crate::contact::pair_rows(&self.hosts(), &self.contact.pairs[pair], &|n| coords[n]);
            let zero = vec![0.0; self.dofs.num_dofs];
            crate::contact::install_rows(&mut self.contact, pair, rows, &zero, &zero);
        }
    }
}
