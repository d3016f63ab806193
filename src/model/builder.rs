//! The builder's declarations: bodies, materials, sets, loads, ties, cuts, contact and wear.

use super::*;
use nalgebra::Matrix2;

pub(super) struct ContactSpec {
    pub(super) name: String,
    pub(super) mortar: usize,
    /// The mortar side: real edges, or (when `mortar_cut` names a free cut) filled in at build.
    pub(super) side: MortarSide,
    pub(super) mortar_cut: Option<String>,
    pub(super) other: ContactOther,
    pub(super) young: f64,
    pub(super) params: ContactParams,
}

pub(super) struct TieSpec {
    pub(super) name: String,
    /// Host body (virtual surface) or, with `other_edges`, the other real body.
    pub(super) host: usize,
    pub(super) patch: usize,
    pub(super) side: MortarSide,
    pub(super) space: MultiplierSpace,
    /// Real-real tie: the other side's edges (global node ids).
    pub(super) other_edges: Option<Vec<[usize; 2]>>,
}

/// Orders oriented edges into one polyline: open (from the node without incoming edge) or closed.
pub(super) fn edge_chain(edges: &[[usize; 2]]) -> Result<(Vec<usize>, bool), String> {
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

/// Builds a [`Model`] body by body, then boundary conditions and loads by set name.
pub struct ModelBuilder {
    pub(super) hypothesis: PlaneHypothesis,
    pub(super) bodies: Vec<Body>,
    pub(super) materials: Vec<Material>,
    pub(super) material_names: Vec<String>,
    /// `(dof, value, curve)`.
    pub(super) prescribed: Vec<(usize, f64, usize)>,
    /// Unit external force per load curve (0: the model's load path).
    pub(super) f_curves: Vec<Vec<f64>>,
    pub(super) curves: Vec<LoadPath>,
    /// Curve that loads and prescribed values added now follow.
    pub(super) curve: usize,
    pub(super) ties: Vec<TieSpec>,
    /// Free virtual surfaces: (name, body, surface with the material on its left, motion).
    pub(super) free_cuts: Vec<(String, usize, VirtualSurface, Option<SurfaceMotion>)>,
    /// Per free cut: the polyline was reversed to keep the material on its left.
    pub(super) reversed_cuts: Vec<bool>,
    pub(super) cycle: Option<Cycle>,
    /// Wearing cuts: (name, law, coefficient, deepest wear), and the cycle-jump policy.
    pub(super) wear_cuts: Vec<(String, crate::wear::WearLaw, f64, f64)>,
    pub(super) wear_jump: crate::wear::JumpPolicy,
    pub(super) wear_scheme: crate::wear::JumpScheme,
    pub(super) wear_smoothing: f64,
    pub(super) wear_min_fraction: f64,
    pub(super) ratcheting_tolerance: f64,
    pub(super) ghost_penalty: f64,
    pub(super) contacts: Vec<ContactSpec>,
    /// Multi-point constraints `u(node) - u(master) = 0` (rigid sets), global DOFs, each with
    /// its set's `(body, set)` names.
    pub(super) rigid_rows: Vec<(ConstraintRow, (usize, String))>,
    pub(super) fatigue: Option<crate::fatigue::FatigueModel>,
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
            wear_min_fraction: crate::wear::DEFAULT_MIN_FRACTION,
            ratcheting_tolerance: crate::wear::DEFAULT_RATCHETING_TOLERANCE,
            fatigue: None,
        }
    }

    /// Follows fatigue at the Gauss points of `body`'s cells inside `region` (`[min, max]`;
    /// `None`: all), with the strain-life constants `life` (see [`crate::fatigue`]; its `young`
    /// is replaced by the body's); the run ends at crack initiation if `stop_at_initiation`. Elastic bodies only: a yielding body's strain needs its
    /// plastic history on these points.
    pub fn set_fatigue(
        &mut self,
        body: usize,
        life: crate::fatigue::StrainLife,
        region: Option<[Point2<f64>; 2]>,
        stop_at_initiation: bool,
    ) -> Result<(), ModelError> {
        let b = &self.bodies[body];
        let Material::Elastic(elastic) = self.materials[b.material] else {
            return Err(ModelError::Fatigue {
                body: b.name.clone(),
                msg: "its material yields; fatigue is followed on elastic bodies only".into(),
            });
        };
        let life = crate::fatigue::StrainLife { young: elastic.young, ..life };
        let model = crate::fatigue::FatigueModel::new(&b.name, &b.mesh, b.node_offset, elastic, life, region)
            .map_err(|e| ModelError::Fatigue { body: b.name.clone(), msg: e.to_string() })?;
        self.fatigue = Some(crate::fatigue::FatigueModel { body_index: body, stop_at_initiation, ..model });
        Ok(())
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
            return Err(err("coefficient", format!("must be finite and >= 0, got {}", super::Num(coefficient))));
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

    /// Smallest fraction of a cycle's wear one update may apply (see
    /// [`crate::wear::WearModel::min_fraction`]; 1: whole cycles only).
    pub fn set_wear_min_fraction(&mut self, fraction: f64) {
        self.wear_min_fraction = fraction;
    }

    /// Largest net plastic strain a cycle jump may drop at a point (see
    /// [`crate::wear::WearModel::ratcheting_tolerance`]).
    pub fn set_ratcheting_tolerance(&mut self, tolerance: f64) {
        self.ratcheting_tolerance = tolerance;
    }

    /// Makes a free cut move during the run (re-cut on fixed points, see
    /// [`crate::moving`]). Its band of fixed points is derived from the motion's
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
        self.push_contact(name, MortarDecl { body: mortar, side, cut: None }, other_body, other, params)
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
        let cut = Some(mortar_cut.to_string());
        self.push_contact(name, MortarDecl { body: mortar, side, cut }, other_body, other, params)
    }

    /// Checks the friction coefficient and records a contact pair.
    fn push_contact(
        &mut self,
        name: &str,
        mortar: MortarDecl,
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
        let MortarDecl { body: mortar, side, cut: mortar_cut } = mortar;
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

    /// Resultant force `f` on a node or edge set. On a rigid set (declared before, with
    /// [`Self::rigid_set`]) or a single node it acts at the set's first node (the platen's
    /// master); otherwise it is spread, as a uniform traction `f / L` over the length `L` of an
    /// edge set's edges, or in equal parts over the nodes of a node set: a resultant put on one
    /// corner of a deformable face would tip the body.
    pub fn total_load(&mut self, body: usize, set: &str, f: Vector2<f64>) -> Result<(), ModelError> {
        let nodes = self.node_set_or_edges(body, set)?;
        let Some(&first) = nodes.first() else { return Err(self.unknown_set(body, set)) };
        let rigid = self.rigid_rows.iter().any(|(_, (b, s))| *b == body && s == set);
        let mut add = |n: usize, fx: Vector2<f64>| {
            self.f_curves[self.curve][2 * n] += fx.x;
            self.f_curves[self.curve][2 * n + 1] += fx.y;
        };
        let b = &self.bodies[body];
        match b.mesh.edge_sets.get(set) {
            _ if rigid || nodes.len() == 1 => add(first, f),
            Some(edges) => {
                let length = |e: &[usize; 2]| (b.mesh.nodes[e[1]] - b.mesh.nodes[e[0]]).norm();
                let total: f64 = edges.iter().map(length).sum();
                if total <= 0.0 || total.is_nan() {
                    return Err(ModelError::DegenerateSet { body: b.name.clone(), set: set.to_string() });
                }
                let (edges, off) = (edges.clone(), b.node_offset);
                for e in &edges {
                    let half = f * (0.5 * length(e) / total);
                    add(e[0] + off, half);
                    add(e[1] + off, half);
                }
            }
            None => {
                let share = f / nodes.len() as f64;
                for &n in &nodes {
                    add(n, share);
                }
            }
        }
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
                self.rigid_rows.push((vec![(2 * n + c, 1.0), (2 * master + c, -1.0)], (body, set.to_string())));
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
        self.linear_traction(body, set, tr, Matrix2::zeros())
    }

    /// Traction varying linearly in space on an edge set, `t(x) = t0 + G x` (force per unit
    /// length; `G` per unit length, `x` the reference position): consistent nodal forces,
    /// exact on straight edges, `f_a = L (2 t_a + t_b) / 6`, `f_b = L (t_a + 2 t_b) / 6`.
    pub fn linear_traction(
        &mut self,
        body: usize,
        set: &str,
        t0: Vector2<f64>,
        gradient: Matrix2<f64>,
    ) -> Result<(), ModelError> {
        let b = &self.bodies[body];
        let edges = self.edge_set(body, set, "traction")?;
        let (off, t) = (b.node_offset, b.thickness);
        for e in edges {
            let (pa, pb) = (b.mesh.nodes[e[0]], b.mesh.nodes[e[1]]);
            let len = Seg2 { a: pa, b: pb }.length();
            let (ta, tb) = (t0 + gradient * pa.coords, t0 + gradient * pb.coords);
            // Uniform traction: both nodes get exactly half (no rounding of thirds and sixths).
            let (fa, fb) = if ta == tb {
                let f = ta * len * t * 0.5;
                (f, f)
            } else {
                ((2.0 * ta + tb) * len * t / 6.0, (ta + 2.0 * tb) * len * t / 6.0)
            };
            for (a, f) in [(e[0], fa), (e[1], fb)] {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::Elastic;
    use crate::mesh::generate;

    type TestResult = Result<(), Box<dyn std::error::Error>>;

    /// A graded 4-cell top (widths differ): the resultant spread as a uniform traction gives
    /// each node half the length of its edges times `f / L`, summing to `f` (exact up to the
    /// round-off of the lengths, 1e-12); on a rigid set it stays whole on the first node.
    #[test]
    fn a_total_force_is_spread_over_a_deformable_set_and_kept_on_a_platen() -> TestResult {
        let hyp = PlaneHypothesis::PlaneStrain;
        let elastic = Material::Elastic(Elastic { young: 1.0e3, poisson: 0.3, hypothesis: hyp });
        let f = Vector2::new(2.0, -8.0);
        for rigid in [false, true] {
            let mut b = ModelBuilder::new(hyp);
            let mat = b.add_material("m", elastic);
            let mesh = generate::rectangle(0.0, 0.0, 2.0, 1.0, 4, 2, 3.0, 1.0, CellKind::Quad4)?;
            let body = b.add_body("block", mesh, mat, Formulation::Standard, 1.0);
            if rigid {
                b.rigid_set(body, "top")?;
            }
            b.total_load(body, "top", f)?;
            let loads = &b.f_curves[b.curve];
            let mesh = &b.bodies[body].mesh;
            let top = b.node_set_or_edges(body, "top")?;
            let sum = top.iter().fold(Vector2::zeros(), |s, &n| s + Vector2::new(loads[2 * n], loads[2 * n + 1]));
            assert!((sum - f).norm() < 1e-12 * f.norm(), "resultant {sum:?} against {f:?}");
            let loaded = top.iter().filter(|&&n| loads[2 * n + 1] != 0.0).count();
            if rigid {
                assert_eq!(loaded, 1, "a platen's force acts at its master alone");
                assert_eq!(loads[2 * top[0] + 1], f.y);
            } else {
                assert_eq!(loaded, top.len(), "every node of the top carries its share");
                // The first node's share: half its one edge's length over the top's 2 mm.
                let edges = &mesh.edge_sets["top"];
                let (first, width) = edges
                    .iter()
                    .find(|e| e.contains(&top[0]))
                    .map(|e| (top[0], (mesh.nodes[e[1]] - mesh.nodes[e[0]]).norm()))
                    .ok_or("no edge at the top's first node")?;
                assert!((loads[2 * first + 1] - f.y * 0.5 * width / 2.0).abs() < 1e-12 * f.norm());
            }
        }
        Ok(())
    }
}

/// The mortar side of a contact being declared: its body, the side (edges or points; empty for
/// a cut's polyline, known once the model is built) and the free cut it lies on, if any.
struct MortarDecl {
    body: usize,
    side: MortarSide,
    cut: Option<String>,
}
