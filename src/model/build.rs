//! [`ModelBuilder::build`] in named phases.

use super::builder::ContactSpec;
use super::*;

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

impl ModelBuilder {
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
        let prescribed = std::mem::take(&mut self.prescribed);
        let dofs = self.dof_map(prescribed, &hosts, elements.coords.len())?;
        constraints.extend(self.rigid_constraints(&dofs.prescribed)?);
        let contact = self.contact_set(&cut_embeddings, elements.coords.len(), constraints.len())?;
        let surfaces = self.free_surfaces(cut_embeddings, &load_path);
        let wear = self.wear_model()?;
        let mut f_ext_curves = std::mem::take(&mut self.f_curves);
        let f_ext = f_ext_curves.remove(0);
        let linear_solver =
            if constraints.is_empty() && contact.rows.is_empty() { linear_solver } else { LinearSolverKind::Lu };
        let initial = Discretisation {
            rules: std::sync::Arc::new(elements.rules),
            dofs: std::sync::Arc::new(dofs.map),
            cuts: std::sync::Arc::new(hosts.cuts),
            held: std::sync::Arc::new(dofs.held),
            penalty: std::sync::Arc::new(hosts.penalty_parts.iter().flatten().copied().collect()),
            penalty_parts: std::sync::Arc::new(hosts.penalty_parts),
            contact,
            surfaces,
        };
        Ok(Model {
            hypothesis: self.hypothesis,
            bodies: self.bodies,
            materials: self.materials,
            material_names: self.material_names,
            coords: elements.coords,
            elements: elements.table,
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
            bands: hosts.bands,
            ghost_penalty: self.ghost_penalty,
            cycle: self.cycle,
            wear,
            fatigue: self.fatigue,
            ghost_reach_cache: Default::default(),
            initial: std::sync::Arc::new(initial),
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
            *surf = crate::moving::refined_at_crossings(surf, &emb);
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
                let faces =
                    crate::cut::ghost_faces(&body.mesh, &adjacency, &c, body.node_offset, young, self.ghost_penalty);
                hosts.penalty_parts[b].extend(crate::cut::ghost_penalty(faces));
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
            let cells = crate::moving::band_cells(&body.mesh, adjacency, surf, motion, range)
                .map_err(|e| ModelError::MovingSurface { surface: name.clone(), msg: e.to_string() })?;
            band_cells_b.extend(cells);
        }
        for (name, cb, surf, _) in self.free_cuts.iter() {
            let Some(w) = self.wear_cuts.iter().find(|w| &w.0 == name) else { continue };
            if *cb != b {
                continue;
            }
            let reach = SurfaceMotion::NormalOffset { distance: w.3, curve: 0 };
            let cells = crate::moving::band_cells(&body.mesh, adjacency, surf, &reach, (0.0, 1.0)).map_err(|e| {
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
                        rules.push(crate::moving::band_cell_rule(&b.mesh, ci, state, which).0);
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
                        &OtherSide::Embedded {
                            host: &host.mesh,
                            coords: &host.mesh.nodes,
                            host_offset: host.node_offset,
                            embedding: emb,
                        },
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

    /// The rows of the rigid sets, without those whose two DOFs are both prescribed: a
    /// displacement prescribed alike on every node of a platen (the same value and curve) makes
    /// its rows empty on the unknowns, a singular system; prescribed differently it is a
    /// contradiction, refused with the nodes and values named.
    fn rigid_constraints(&self, prescribed: &[(usize, f64, usize)]) -> Result<Vec<ConstraintRow>, ModelError> {
        let given =
            |d: usize| prescribed.binary_search_by_key(&d, |p| p.0).ok().map(|i| (prescribed[i].1, prescribed[i].2));
        let mut rows = Vec::with_capacity(self.rigid_rows.len());
        for (row, (body, set)) in &self.rigid_rows {
            let (node, master) = (row[0].0, row[1].0);
            match (given(node), given(master)) {
                (Some(a), Some(b)) if a == b => {}
                (Some((value, _)), Some((master_value, _))) => {
                    let b = &self.bodies[*body];
                    let local = |d: usize| d / 2 - b.node_offset;
                    return Err(ModelError::RigidSet {
                        body: b.name.clone(),
                        set: set.clone(),
                        msg: format!(
                            "node {} has {} = {} prescribed and the set's master node {} {} = {} (or another curve): \
                             a rigid set moves as one translation, so prescribe it on one node",
                            local(node),
                            ["ux", "uy"][node % 2],
                            super::Num(value),
                            local(master),
                            ["ux", "uy"][master % 2],
                            super::Num(master_value)
                        ),
                    });
                }
                _ => rows.push(row.clone()),
            }
        }
        Ok(rows)
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
                    OtherSide::Embedded {
                        host: &host.mesh,
                        coords: &host.mesh.nodes,
                        host_offset: host.node_offset,
                        embedding: emb,
                    },
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
            ratcheting_tolerance: self.ratcheting_tolerance,
            // A repeated pass over a cycle would advance a yielding body's history.
            min_fraction: if self.materials.iter().any(|m| m.has_state()) { 1.0 } else { self.wear_min_fraction },
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
