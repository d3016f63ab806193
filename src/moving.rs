//! Moving virtual surfaces on fixed integration points (re-cutting without remeshing).
//!
//! A free cut may move during a run ([`SurfaceMotion`]: a translation or a normal offset
//! following a load curve; the wear loop moves surfaces by its own law). Every host cell the
//! surface may visit (its *band*, derived from the motion when the model is built) gets the
//! fixed points of [`band_rule`] once; each surface update re-embeds the surface, re-cuts the
//! host ([`cut_mesh`]) and refits the weights of the band cells by moment fitting on those
//! points ([`band_weights`]). Nothing else changes: the element table, the point and state
//! layout, the multiplier rows and therefore `SimState` keep their sizes and order for the
//! whole run.
//!
//! What a re-cut refits (Sudhakar & Wall, CMAME 258 (2013) 39, moment fitting; non-negative
//! weights by Lawson-Hanson NNLS):
//! * bodies without history ([`BandPoints::Any`]): nothing is stored at the points, so a cut
//!   band cell takes the exact sub-triangulation rule of its material in its fixed slots
//!   (padded with zero weights); only where that rule needs more slots than the cell has, its
//!   fixed points get moment-fitted weights with every point allowed (the vertices among them
//!   keep areas and first moments exact, second moments where a non-negative fit exists);
//! * bodies with history ([`BandPoints::Material`]): only points inside the material carry
//!   weight; points left in the void get weight zero and keep their last values (the kernel
//!   skips them). For slivers below about 25 % of a cell, exact first moments are generally not
//!   reachable with non-negative weights on the points inside; the fit then falls back to
//!   degree 0 (the area, spread over the material points in proportion to their uncut weights
//!   rather than on the one or two points NNLS would pick), and the ghost penalty keeps such
//!   cells stable.
//!
//! Host nodes whose support keeps less than [`SMALL_FRACTION`] of its area are switched off:
//! their DOFs leave the unknowns and keep their last value (held, not prescribed), and come
//! back when material returns. The ghost penalty and the contact rows of pairs whose other
//! side is the moving surface are rebuilt at every update.

use crate::cut::{band_rule, band_weights, BandPoints, CellAdjacency, CellCut, SMALL_FRACTION};
use crate::fem::element::ReferenceElement;
use crate::mesh::Mesh2;
use crate::surface::{cell_polygon, embed, BoxIndex, Embedding, VirtualSurface};
use nalgebra::{Point2, Vector2};

/// Prescribed motion of a free cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SurfaceMotion {
    /// Every vertex moves by `factor(t) * direction`.
    Translation { direction: Vector2<f64>, curve: usize },
    /// Every segment moves along its inward normal (into the material) by `factor(t) *
    /// distance`; vertices are mitred so that segments stay parallel to themselves.
    NormalOffset { distance: f64, curve: usize },
}

impl SurfaceMotion {
    pub fn curve(&self) -> usize {
        match *self {
            SurfaceMotion::Translation { curve, .. } | SurfaceMotion::NormalOffset { curve, .. } => curve,
        }
    }
    /// Largest distance a vertex moves per unit factor.
    fn reach(&self, base: &VirtualSurface) -> f64 {
        match *self {
            SurfaceMotion::Translation { direction, .. } => direction.norm(),
            SurfaceMotion::NormalOffset { distance, .. } => {
                mitre_vectors(base).iter().map(|m| m.norm()).fold(0.0, f64::max) * distance.abs()
            }
        }
    }
    /// Vertices of `base` moved by factor `f`.
    pub fn place(&self, base: &VirtualSurface, f: f64) -> Vec<Point2<f64>> {
        match *self {
            SurfaceMotion::Translation { direction, .. } => base.vertices.iter().map(|p| p + direction * f).collect(),
            SurfaceMotion::NormalOffset { distance, .. } => {
                let m = mitre_vectors(base);
                base.vertices.iter().zip(&m).map(|(p, m)| p + m * (distance * f)).collect()
            }
        }
    }
}

/// Per vertex, the displacement that moves every adjacent segment by a unit distance along its
/// left (material-side) normal: `(n_a + n_b) / (1 + n_a . n_b)`.
fn mitre_vectors(s: &VirtualSurface) -> Vec<Vector2<f64>> {
    let nv = s.vertices.len();
    let ns = s.num_segments();
    let normal = |i: usize| {
        let (a, b) = s.segment(i);
        let t = (b - a).normalize();
        Vector2::new(-t.y, t.x)
    };
    (0..nv)
        .map(|i| {
            let before = if i > 0 {
                Some(i - 1)
            } else if s.closed {
                Some(ns - 1)
            } else {
                None
            };
            let after = if i < ns { Some(i) } else { None };
            match (before, after) {
                (Some(a), Some(b)) => {
                    let (na, nb) = (normal(a), normal(b));
                    (na + nb) / (1.0 + na.dot(&nb)).max(1e-3)
                }
                (Some(a), None) => normal(a),
                (None, Some(b)) => normal(b),
                (None, None) => Vector2::zeros(),
            }
        })
        .collect()
}

/// A free virtual surface (traction-free boundary, or the other side of a contact) of a body.
#[derive(Debug, Clone)]
pub struct FreeSurface {
    pub name: String,
    pub body: usize,
    /// Polyline at its reference position, material on its left.
    pub base: VirtualSurface,
    pub motion: Option<SurfaceMotion>,
    /// Where it is now (the model's current discretisation).
    pub vertices: Vec<Point2<f64>>,
    pub embedding: Embedding,
    /// The polyline runs against the order the user gave (reversed to keep the material on
    /// its left): output reverses it back.
    pub reversed: bool,
}

impl FreeSurface {
    /// Current vertices in the order the user gave them.
    pub fn user_vertices(&self) -> Vec<Point2<f64>> {
        let mut v = self.vertices.clone();
        if self.reversed {
            v.reverse();
        }
        v
    }
}

/// The fixed-point band of a body with a moving surface.
#[derive(Debug, Clone)]
pub struct Band {
    /// Band cells (sorted) and the rule index of each (one rule per band cell: the points are
    /// fixed, the weights refitted).
    pub cells: Vec<usize>,
    pub rules: Vec<usize>,
    pub points: BandPoints,
    pub adjacency: CellAdjacency,
    /// BVH over the host's cells (built once).
    pub index: std::sync::Arc<BoxIndex>,
    /// Surfaces embedded in the body that never move (tie boundaries).
    pub fixed_embeddings: Vec<Embedding>,
}

/// What one surface update did (for logs and tests).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecutReport {
    /// Surfaces that moved.
    pub moved: usize,
    /// Band cells refitted, by moment degree reached: `[area only, first, second]`; cells cut
    /// where no weight could be fitted at all.
    pub cut_cells_by_degree: [usize; 3],
    pub unfitted_cells: usize,
    /// Host DOFs switched off after the update.
    pub held_dofs: usize,
}

/// Cells a moving surface visits over the factor range `[f_min, f_max]` of its curve: the cells
/// cut at sampled positions (a quarter of the smallest cell edge apart) and their edge
/// neighbours (a surface clipping a corner between two samples).
pub fn band_cells(
    mesh: &Mesh2,
    adjacency: &CellAdjacency,
    base: &VirtualSurface,
    motion: &SurfaceMotion,
    f_range: (f64, f64),
) -> Result<Vec<usize>, crate::surface::SurfaceError> {
    let index = BoxIndex::over_cells(mesh);
    let h_min = (0..mesh.num_cells())
        .map(|c| {
            let p = cell_polygon(mesh, c);
            (0..p.len()).map(|k| (p[(k + 1) % p.len()] - p[k]).norm()).fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min);
    let travel = (f_range.1 - f_range.0) * motion.reach(base);
    let samples = ((travel / (0.25 * h_min)).ceil() as usize).clamp(1, 100_000);
    let mut mark = vec![false; mesh.num_cells()];
    for s in 0..=samples {
        let f = f_range.0 + (f_range.1 - f_range.0) * s as f64 / samples as f64;
        let surf = VirtualSurface { vertices: motion.place(base, f), closed: base.closed };
        let emb = embed(&surf, mesh, &index)?;
        for p in &emb.cell_pieces {
            mark[p.cell] = true;
        }
    }
    let core: Vec<usize> = (0..mesh.num_cells()).filter(|&c| mark[c]).collect();
    for &c in &core {
        for k in 0..mesh.cells[c].nodes().len() {
            if let Some(nb) = adjacency.neighbour(c, k) {
                mark[nb] = true;
            }
        }
    }
    Ok((0..mesh.num_cells()).filter(|&c| mark[c]).collect())
}

/// DOFs of the nodes of a cut body whose support keeps less than [`SMALL_FRACTION`] of its
/// area and that the ghost penalty `ghost` (entries `(dof_i, dof_j, value)`) does not reach
/// (except those already prescribed): switched off, held at their last value. A node of a
/// sliver cell stays free: the ghost penalty extends the displacement of its neighbours to it.
/// Held there, it would anchor the sliver's faces at its last position with the full ghost
/// stiffness `gamma E h` and drag the surface it borders (a computed cycle of the McColl scene
/// lost 27% of its slip that way when such a node was switched off).
pub fn held_dofs(
    cm: &crate::cut::CutMesh,
    node_offset: usize,
    prescribed: &[(usize, f64)],
    ghost: &[(usize, usize, f64)],
) -> Vec<usize> {
    let mut stabilised = std::collections::HashSet::new();
    for &(i, j, v) in ghost {
        if i == j && v > 0.0 {
            stabilised.insert(i);
        }
    }
    let mut v = Vec::new();
    for (n, &f) in cm.node_fraction.iter().enumerate() {
        if f < SMALL_FRACTION {
            for c in 0..2 {
                let d = 2 * (n + node_offset) + c;
                if prescribed.binary_search_by_key(&d, |p| p.0).is_err() && !stabilised.contains(&d) {
                    v.push(d);
                }
            }
        }
    }
    v
}

/// The rule of a band cell in its current cut state, on the cell's fixed slots (see
/// [`BandPoints`]): the uncut band rule for a material cell, zero weights for a void one; a cut
/// cell of a body without history takes its exact sub-triangulation rule when it fits the slots,
/// otherwise (and for bodies with history) the fixed points with moment-fitted weights. Returns
/// the rule and the moment degree it integrates exactly (2 for the exact rule, `usize::MAX`
/// for an uncut cell). The model builder and every re-cut use this one function.
pub fn band_cell_rule(
    mesh: &Mesh2,
    c: usize,
    state: &CellCut,
    which: BandPoints,
) -> (crate::fem::quadrature::QuadratureRule, Option<usize>) {
    let kind = mesh.cells[c].kind;
    let mut rule = band_rule(kind);
    if which == BandPoints::Any {
        if matches!(state, CellCut::Material) {
            // Nothing stored at the points: an uncut cell takes the rule of every other cell of
            // its body in its first slots (the 8 x 8 rule would cost 16 times the work at every
            // internal-force evaluation for the same integral on affine cells).
            let mut standard = kind.stiffness_rule();
            let slots = rule.len();
            let centre = standard.points[0];
            while standard.len() < slots {
                standard.points.push(centre);
                standard.weights.push(0.0);
            }
            return (standard, Some(usize::MAX));
        }
        if let Some(exact) = crate::cut::band_exact_rule(mesh, c, rule.len(), state) {
            return (exact, Some(2));
        }
    }
    let full = rule.weights.clone();
    let (w, degree) = band_weights(mesh, c, &rule, &full, state, which);
    rule.weights = w;
    (rule, degree)
}

/// The polyline with a vertex added wherever it enters or leaves a host cell (the piece ends
/// of its embedding): a wearing surface wears at its own vertices, so they resolve the host.
pub fn refined_at_crossings(surf: &VirtualSurface, emb: &Embedding) -> VirtualSurface {
    let nseg = if surf.closed { surf.vertices.len() } else { surf.vertices.len() - 1 };
    let mut ends: Vec<Vec<f64>> = vec![vec![]; nseg];
    for p in &emb.pieces {
        for t in [p.t0, p.t1] {
            if t > 1e-9 && t < 1.0 - 1e-9 {
                ends[p.segment].push(t);
            }
        }
    }
    let n = surf.vertices.len();
    let mut v = Vec::new();
    for (s, ts) in ends.iter_mut().enumerate() {
        ts.sort_by(f64::total_cmp);
        // A crossing between two cells ends one piece and starts the next; where the polyline
        // enters or leaves the host a piece ends alone (no vertex there: every segment must
        // keep a part inside the host).
        let mut inner = Vec::new();
        let mut k = 0;
        while k < ts.len() {
            let mut m = k + 1;
            while m < ts.len() && ts[m] - ts[k] < 1e-9 {
                m += 1;
            }
            if m - k >= 2 {
                inner.push(ts[k]);
            }
            k = m;
        }
        let (a, b) = (surf.vertices[s], surf.vertices[(s + 1) % n]);
        v.push(a);
        v.extend(inner.iter().map(|&t| a + (b - a) * t));
    }
    if !surf.closed {
        v.push(surf.vertices[n - 1]);
    }
    VirtualSurface { vertices: v, closed: surf.closed }
}
