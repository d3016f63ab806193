//! Moving surfaces at run time: re-cut on the fixed band points, re-paired.

use super::*;

/// Moving surfaces (see [`crate::moving`]): the model re-cut on its fixed band points.
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
