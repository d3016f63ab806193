//! The discretisation of a model: where the free surfaces are, and the cut, weights, DOF map
//! and contact rows that follow, with its read-only queries.
//!
//! The model keeps the one its builder made ([`Model::initial`]), immutable like the rest of
//! the model. What derives another one as surfaces move, wear or re-pair lives above the
//! model, in [`crate::geometry`]; the step solver owns the one of the moment. The element
//! table, the point layout and the multiplier layout belong to the model and never change, so
//! `SimState` keeps its sizes for the whole run.

use super::*;

/// Where the free surfaces are now, and the cut, weights, DOF map and contact rows that follow.
/// The step solver owns the one of the moment; a checkpoint does not save it: a restart derives it
/// again from the model and the checkpointed state (time and wear state).
#[derive(Debug, Clone)]
pub struct Discretisation {
    /// Quadrature rule table (band cells: fixed points, weights of the current cut). Shared
    /// with the re-pairings of a surface position (a re-pairing changes the contact rows only).
    pub rules: std::sync::Arc<Vec<QuadratureRule>>,
    /// Free and constrained DOFs: prescribed ones, and nodes switched off for lack of material.
    /// This and the ghost-penalty and held-DOF tables below are shared, like the rules, with
    /// the re-pairings of a surface position.
    pub dofs: std::sync::Arc<DofMap>,
    /// Cut state of each body's cells (`None`: not cut by any surface).
    pub cuts: std::sync::Arc<Vec<Option<CutMesh>>>,
    /// Per body: DOFs switched off (no material in their support), held at their last value.
    pub held: std::sync::Arc<Vec<Vec<usize>>>,
    /// Ghost-penalty entries per body; `penalty` is their concatenation.
    pub penalty_parts: std::sync::Arc<Vec<Vec<(usize, usize, f64)>>>,
    /// Constant extra stiffness `(dof_i, dof_j, value)`: ghost penalty on cut bodies.
    pub penalty: std::sync::Arc<Vec<(usize, usize, f64)>>,
    /// Mortar contact: pairs, their weighted-gap and slip rows (multipliers after the ties).
    pub contact: ContactSet,
    /// Free virtual surfaces (cuts), where they are now.
    pub surfaces: Vec<FreeSurface>,
}

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
            .map(|w| self.initial.surfaces[w.surface].vertices.iter().map(|p| [p.x, p.y]).collect())
            .collect();
        crate::state::WearState {
            depth: verts.iter().map(|v| vec![0.0; v.len()]).collect(),
            cycle_volume: verts.iter().map(|v| vec![0.0; v.len()]).collect(),
            vertices: verts,
            cycle_work: vec![0.0; n],
            worn_area: vec![0.0; n],
            work: vec![0.0; n],
            ..Default::default()
        }
    }

    /// The discretisation the builder made: every surface where it starts, nothing worn. A
    /// run derives its own from it ([`Discretisation::place_surfaces`],
    /// [`Discretisation::place_worn_surfaces`], [`Discretisation::repaired_at`]).
    pub fn initial(&self) -> &Discretisation {
        &self.initial
    }

    /// [`Model::initial`], shared (a solver set up on it holds it).
    pub fn initial_shared(&self) -> std::sync::Arc<Discretisation> {
        std::sync::Arc::clone(&self.initial)
    }

    /// Whether any surface of the model moves during the run.
    pub fn has_moving_surfaces(&self) -> bool {
        self.initial.surfaces.iter().any(|s| s.motion.is_some())
    }

    /// Every DOF pair `(i, j)` (both orders) the ghost penalty can couple during the run: on
    /// a body with moving surfaces, the same component of the nodes of any two band cells (or
    /// a band cell and its neighbour) across a shared face, whether or not the face is next to
    /// a cut cell now; on other bodies the entries it has. A solver pattern holding these does
    /// not change when the surfaces move (see `solve::analysis::condensed`).
    pub fn ghost_reach(&self) -> &[(usize, usize)] {
        self.ghost_reach_cache.get_or_init(|| self.form_ghost_reach())
    }

    /// [`Model::ghost_reach`] formed from the bands (sorted, without repeats).
    fn form_ghost_reach(&self) -> Vec<(usize, usize)> {
        let mut v: Vec<(usize, usize)> = Vec::new();
        for (b, body) in self.bodies.iter().enumerate() {
            let Some(band) = &self.bands[b] else {
                v.extend(self.initial.penalty_parts[b].iter().map(|&(i, j, _)| (i, j)));
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
}

impl Discretisation {
    /// Host DOFs switched off because their support has (almost) no material.
    pub fn deactivated_dofs(&self) -> usize {
        self.held.iter().map(|h| h.len()).sum()
    }

    /// Every multiplier's row over the DOFs, in multiplier order: the model's ties, contact
    /// normals, friction.
    pub fn multiplier_rows<'a>(&'a self, model: &'a Model) -> impl Iterator<Item = &'a ConstraintRow> {
        model.constraints.iter().chain(self.contact.rows.iter()).chain(self.contact.friction_rows.iter())
    }

    /// Area of body `b`'s material (per unit thickness): its cells, times their material
    /// fraction where the body is cut.
    pub fn material_area(&self, model: &Model, b: usize) -> f64 {
        let mesh = &model.bodies[b].mesh;
        (0..mesh.num_cells())
            .map(|c| {
                let a = crate::surface::cell_size(&crate::surface::cell_polygon(mesh, c)).powi(2);
                self.cuts[b].as_ref().map_or(a, |cm| a * cm.cell_fraction[c])
            })
            .sum()
    }

    /// What the wear update reads of this discretisation.
    pub fn wear_scene<'a>(&'a self, model: &'a Model) -> crate::wear::WearScene<'a> {
        crate::wear::WearScene {
            contact: &self.contact,
            hosts: model.hosts(),
            surfaces: &self.surfaces,
            coords: &model.coords,
            model: &model.wear,
            increments: model.cycle.map_or(0, |c| c.increments),
        }
    }

    /// Reactions `f_int + C^T mu - lambda f_ext` at constrained DOFs of a state, zero elsewhere.
    pub fn reactions(&self, model: &Model, state: &crate::state::SimState) -> Vec<f64> {
        let mut r = state.f_int.clone();
        let mut f = vec![0.0; r.len()];
        model.external_force(state.time, &mut f);
        for (v, f) in r.iter_mut().zip(&f) {
            *v -= f;
        }
        for (k, row) in self.multiplier_rows(model).enumerate() {
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

    /// Physical coordinates of every integration point, in point order (band cells of bodies
    /// without history take the exact rule of their cut: their points move with the surface).
    pub fn point_coords(&self, model: &Model) -> Vec<Point2<f64>> {
        let el = &model.elements;
        let mut out = Vec::with_capacity(el.num_points());
        for e in 0..el.len() {
            let mut c = [Point2::origin(); 4];
            for a in 0..el.kind[e].num_nodes() {
                c[a] = model.coords[el.nodes[e][a]];
            }
            let m = crate::fem::element::MappedElement::new(el.kind[e], c);
            for xi in &self.rules[el.rule[e]].points {
                out.push(m.map(*xi));
            }
        }
        out
    }
}
