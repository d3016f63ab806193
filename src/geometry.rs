//! The moving geometry: what moves a [`Discretisation`] during a run.
//!
//! A discretisation is derived from the [`Model`], the time (prescribed surface motions) and
//! the wear state (worn surfaces); finite sliding re-pairs it every step. Moving a surface
//! re-embeds it, re-cuts its host on the band's fixed points (see [`crate::moving`]), and
//! rebuilds what the cut decides: quadrature weights of band cells, ghost penalty, switched-off
//! nodes and the DOF map, and the contact rows of pairs with a side on the surface. Re-pairing
//! recomputes the finite-sliding pairs' mortar rows in a displaced configuration. The element
//! table, the point layout and the multiplier layout belong to the model and never change, so
//! `SimState` keeps its sizes for the whole run.
//!
//! The type and its read-only queries are the model's ([`crate::model::Discretisation`]: the
//! model keeps the one its builder made, immutable); everything that derives another one from
//! it lives here, above the model, and the step solver ([`crate::solve::StepSolver`]) owns the
//! one of the moment.

use crate::assembly::DofMap;
use crate::cut::{cut_mesh, CellCut};
use crate::model::{surface_through, Discretisation, Model, ModelError, PairedSide, Sliding};
use crate::moving::{band_cell_rule, held_dofs, RecutReport};
use crate::surface::{embed, Embedding, VirtualSurface};
use nalgebra::{Point2, Vector2};

impl Discretisation {
    /// Puts the wearing surfaces where `wear` has them (re-cut, re-paired).
    pub fn place_worn_surfaces(
        &mut self,
        model: &Model,
        wear: &crate::state::WearState,
    ) -> Result<RecutReport, ModelError> {
        let positions: Vec<(usize, Vec<Point2<f64>>)> = model
            .wear
            .surfaces
            .iter()
            .zip(&wear.vertices)
            .map(|(w, v)| (w.surface, v.iter().map(|p| Point2::new(p[0], p[1])).collect()))
            .collect();
        self.move_surfaces(model, &positions)
    }

    /// Vertices of free surface `i` at time `t` (its reference vertices when it does not move).
    pub fn surface_vertices_at(&self, model: &Model, i: usize, t: f64) -> Vec<Point2<f64>> {
        let s = &self.surfaces[i];
        match &s.motion {
            // A motion is a process over the whole run: its curve is read at the absolute time,
            // never wrapped into the load cycle.
            Some(m) => m.place(&s.base, model.curve_factor_absolute(m.curve(), t)),
            None => s.base.vertices.clone(),
        }
    }

    /// Moves every moving surface to its position at time `t` and re-cuts (see the module
    /// documentation). The state layout does not change.
    pub fn place_surfaces(&mut self, model: &Model, t: f64) -> Result<RecutReport, ModelError> {
        let positions: Vec<(usize, Vec<Point2<f64>>)> = (0..self.surfaces.len())
            .filter(|&i| self.surfaces[i].motion.is_some())
            .map(|i| (i, self.surface_vertices_at(model, i, t)))
            .collect();
        self.move_surfaces(model, &positions)
    }

    /// Moves free surfaces to new vertex positions (`(surface index, vertices)`, same vertex
    /// count) and re-cuts their hosts on the fixed band points.
    pub fn move_surfaces(
        &mut self,
        model: &Model,
        positions: &[(usize, Vec<Point2<f64>>)],
    ) -> Result<RecutReport, ModelError> {
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
            if model.bands[s.body].is_none() {
                return Err(err("the surface was not declared moving: its host has no band of fixed points".into()));
            }
            if v.iter().any(|p| !p.x.is_finite() || !p.y.is_finite()) {
                return Err(err("a move gave a non-finite vertex".into()));
            }
            let surf = VirtualSurface { vertices: v.clone(), closed: s.base.closed };
            surf.validate().map_err(|e| err(e.to_string()))?;
            let mesh = &model.bodies[s.body].mesh;
            let Some(band) = model.bands[s.body].as_ref() else { continue };
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
            self.recut_body(model, b, &mut report)?;
        }
        if !moved.is_empty() {
            self.refresh_contact_rows(model, &moved);
            self.penalty = std::sync::Arc::new(self.penalty_parts.iter().flatten().copied().collect());
            let mut constrained: Vec<usize> = model.prescribed.iter().map(|p| p.0).collect();
            constrained.extend(self.held.iter().flatten().copied());
            self.dofs = std::sync::Arc::new(DofMap::new(model.num_nodes(), &constrained));
            if self.dofs.num_free == 0 {
                return Err(ModelError::NoFreeDofs);
            }
        }
        report.held_dofs = self.held.iter().map(|h| h.len()).sum();
        Ok(report)
    }

    /// Brings `births` to this discretisation's ghost-penalty faces on re-cut bodies whose
    /// material has a history: a face that appeared next to a cell with yielded points is born
    /// at `u` (its force `K_F u` kept), one that appeared in elastic material acts on the total
    /// displacement as in an elastic body (no force kept), a face that left is dropped, the
    /// others keep theirs. Elastic bodies are not tracked (see [`crate::state::GhostBirths`]).
    /// Called after every re-cut, with the converged state the next step starts from.
    pub fn sync_ghost_births(
        &self,
        model: &Model,
        births: &mut crate::state::GhostBirths,
        u: &[f64],
        history: &[crate::fem::material::PlasticState],
    ) {
        let yielded = |b: usize, c: usize| {
            let e = model.bodies[b].element_offset + c;
            let el = &model.elements;
            history[el.state_offset[e]..el.state_offset[e + 1]].iter().any(|h| h.alpha > 0.0 || h.eps_p != [0.0; 4])
        };
        let mut next = Vec::with_capacity(births.faces.len());
        for (b, body) in model.bodies.iter().enumerate() {
            let material = &model.materials[body.material];
            let (Some(band), Some(cut)) = (model.bands[b].as_ref(), self.cuts[b].as_ref()) else { continue };
            if !material.has_state() || model.ghost_penalty <= 0.0 {
                continue;
            }
            let young = material.elastic().young;
            for face in
                crate::cut::ghost_faces(&body.mesh, &band.adjacency, cut, body.node_offset, young, model.ghost_penalty)
            {
                let key = (b, face.cut_cell, face.neighbour);
                let force = match births.faces.binary_search_by(|e| e.0.cmp(&key)) {
                    Ok(k) => std::mem::take(&mut births.faces[k].1),
                    Err(_) if yielded(b, face.cut_cell) || yielded(b, face.neighbour) => face.force(u),
                    Err(_) => vec![],
                };
                next.push((key, force));
            }
        }
        next.sort_by(|x, y| x.0.cmp(&y.0));
        births.faces = next;
    }

    /// Re-cuts body `b` with its current surfaces: cut state, band weights, ghost penalty and
    /// switched-off nodes.
    fn recut_body(&mut self, model: &Model, b: usize, report: &mut RecutReport) -> Result<(), ModelError> {
        let Some(band) = model.bands[b].as_ref() else { return Ok(()) };
        let body = &model.bodies[b];
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
            std::sync::Arc::make_mut(&mut self.rules)[r] = rule;
        }
        std::sync::Arc::make_mut(&mut self.penalty_parts)[b] = if model.ghost_penalty > 0.0 {
            let young = model.materials[body.material].elastic().young;
            let faces =
                crate::cut::ghost_faces(&body.mesh, &band.adjacency, &cm, body.node_offset, young, model.ghost_penalty);
            crate::cut::ghost_penalty(faces)
        } else {
            vec![]
        };
        let held = held_dofs(&cm, body.node_offset, &model.prescribed, &self.penalty_parts[b]);
        std::sync::Arc::make_mut(&mut self.held)[b] = held;
        std::sync::Arc::make_mut(&mut self.cuts)[b] = Some(cm);
        Ok(())
    }

    /// Rebuilds the weighted-gap rows of contact pairs with a side on a moved surface (small
    /// sliding: from the reference geometry; finite sliding re-pairs every step anyway). A
    /// virtual mortar side keeps its multiplier layout; its geometry follows the vertices.
    fn refresh_contact_rows(&mut self, model: &Model, moved: &[usize]) {
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
                let (mesh, off) = (&model.bodies[s.body].mesh, model.bodies[s.body].node_offset);
                let interpolation =
                    crate::contact::VirtualMortar::interpolation(mesh, off, &s.embedding, &s.vertices, s.base.closed);
                let c = &mut self.contact.pairs[pair];
                c.side.points = s.vertices.clone();
                c.multipliers = c.multipliers.with_geometry(&c.side);
                if let Some(vm) = c.virtual_mortar.as_mut() {
                    vm.interpolation = interpolation;
                }
            }
            let coords = &model.coords;
            let rows = crate::contact::pair_rows(&model.hosts(), &self.contact.pairs[pair], &|n| coords[n]);
            let zero = vec![0.0; model.num_dofs()];
            crate::contact::install_rows(&mut self.contact, pair, rows, &zero, &zero);
        }
    }

    /// This discretisation with the finite-sliding contact pairs re-paired in the configuration
    /// `x = X + u` (a virtual surface moves with its host: its pieces keep their host reference
    /// coordinates), slips measured from `u` (see [`Discretisation::repaired_at`]).
    pub fn repaired(&self, model: &Model, u: &[f64]) -> Discretisation {
        self.repaired_at(model, u, u)
    }

    /// This discretisation with the finite-sliding contact pairs re-paired in the configuration
    /// `x = X + u_pair`: the mortar integrals, normals and tangents are recomputed on the
    /// displaced surfaces, and the rows are shifted so that they stay linear in the total
    /// displacement, `g(u') = g_x + C_x (u' - u_pair)`, i.e. `g0 = g_x - C_x u_pair`; slips of
    /// the step are measured from the step's start, `friction_s0 = T_x u_start`. The driver
    /// pairs a step in its own end configuration (a fixed point on `u_pair`, see
    /// [`crate::driver`]). Multiplier nodes, their number and order do not change, so the state
    /// carries over. Small-sliding pairs keep their reference rows.
    pub fn repaired_at(&self, model: &Model, u_pair: &[f64], u_start: &[f64]) -> Discretisation {
        let mut m = self.clone();
        let x = |n: usize| model.coords[n] + Vector2::new(u_pair[2 * n], u_pair[2 * n + 1]);
        let hosts = model.hosts();
        for (pair, c) in self.contact.pairs.iter().enumerate().filter(|(_, c)| c.sliding == Sliding::Finite) {
            let rows = crate::contact::pair_rows(&hosts, c, &x);
            crate::contact::install_rows(&mut m.contact, pair, rows, u_pair, u_start);
        }
        m
    }
}
