//! Cut-cell integration on fixed points.
//!
//! For each host cell, the material part left by an embedded surface (material on the left of
//! the surface) is found exactly: the surface pieces inside the cell, plus the stretches of the
//! cell boundary that lie in the material. Walking the cell boundary counter-clockwise, the
//! stretch after a point where the surface *leaves* the cell is material, the stretch after a
//! point where it *enters* is void. The material loops give exact polynomial moments by Green's
//! theorem (`int_A x^p y^q dA = oint x^{p+1} y^q / (p+1) n_x ds`, Gauss-Legendre exact per edge)
//! and an exact sub-triangulation (ear clipping).
//!
//! Integration points are fixed material points:
//! * a cell cut when the model is built gets points from the sub-triangulation of its material
//!   (degree-2 rule per triangle: exact for the `Quad4` stiffness on parallelograms); no state
//!   exists yet, so creating points then transfers nothing;
//! * cells a moving surface may visit (its band) carry the richer [`band_rule`] from the start;
//!   when the surface moves, points of bodies with history stay and get new non-negative
//!   weights by moment fitting ([`fit_weights`], Lawson-Hanson NNLS on the monomials up to
//!   degree 2, falling back to degree 1 and 0), points left outside the material get weight
//!   zero; bodies without history take the exact sub-triangulation rule in the cell's slots
//!   ([`band_exact_rule`]). See `crate::moving`.
//! * Small cut fractions: a node whose support keeps less than [`SMALL_FRACTION`] of its area
//!   has its DOFs switched off (held at their value) by the model; void cells get no points.

use crate::fem::element::MappedElement;
use crate::fem::quadrature::{collapsed_triangle_rule, gauss_legendre, quad_gauss, triangle_rule, QuadratureRule};
use crate::mesh::{CellKind, Mesh2};
use crate::surface::{cell_polygon, cell_size, Embedding, Piece, SurfaceError, SNAP};
use nalgebra::{DMatrix, DVector, Point2, Vector2};
use std::collections::HashMap;

/// Support fraction below which a host node is deactivated.
pub const SMALL_FRACTION: f64 = 1e-8;
/// Material fraction below which a cut cell counts as void, above `1 - CUT_TOL` as full.
pub const CUT_TOL: f64 = 1e-12;

#[derive(Debug, Clone, PartialEq)]
pub enum CellCut {
    Material,
    Void,
    /// Material loops (CCW polygons) and their area.
    Cut {
        loops: Vec<Vec<Point2<f64>>>,
        area: f64,
    },
}

#[derive(Debug, Clone)]
pub struct CutMesh {
    pub cells: Vec<CellCut>,
    /// Material fraction of each cell.
    pub cell_fraction: Vec<f64>,
    /// Material fraction of each node's support.
    pub node_fraction: Vec<f64>,
}

fn cross(u: Vector2<f64>, v: Vector2<f64>) -> f64 {
    u.x * v.y - u.y * v.x
}

/// Perimeter parameter (`k + s` on edge `k`) of a point on the boundary of a polygon, with its
/// distance to the boundary.
fn perimeter_param(poly: &[Point2<f64>], p: Point2<f64>) -> (f64, f64) {
    let n = poly.len();
    let mut best = (0.0, f64::INFINITY);
    for k in 0..n {
        let (a, b) = (poly[k], poly[(k + 1) % n]);
        let e = b - a;
        let s = ((p - a).dot(&e) / e.norm_squared()).clamp(0.0, 1.0);
        let d = (a + e * s - p).norm();
        if d < best.1 {
            best = (k as f64 + s, d);
        }
    }
    best
}

/// Exact moments `int x^p y^q dA` (`p + q <= degree`) of the region bounded by CCW loops,
/// of the coordinates `(x - origin)/h` (scaled for conditioning), physical measure `dA`,, ordered `(0,0), (1,0), (0,1), (2,0), (1,1), (0,2)...`.
pub fn loop_moments(loops: &[Vec<Point2<f64>>], degree: usize, origin: Point2<f64>, h: f64) -> Vec<f64> {
    let exps = monomials(degree);
    let (gx, gw) = gauss_legendre(degree / 2 + 2);
    let mut m = vec![0.0; exps.len()];
    for lp in loops {
        let n = lp.len();
        for k in 0..n {
            let a = (lp[k] - origin) / h;
            let b = (lp[(k + 1) % n] - origin) / h;
            let d = b - a;
            // n_x ds = dy along a CCW boundary.
            for (x, w) in gx.iter().zip(&gw) {
                let s = 0.5 * (x + 1.0);
                let pt = a + d * s;
                for (i, &(p, q)) in exps.iter().enumerate() {
                    m[i] += 0.5 * w * pt.x.powi(p as i32 + 1) / (p as f64 + 1.0) * pt.y.powi(q as i32) * d.y;
                }
            }
        }
    }
    // Green's theorem ran in scaled coordinates: back to the physical measure.
    for v in m.iter_mut() {
        *v *= h * h;
    }
    m
}

/// Monomial exponents of total degree `<= degree`.
pub fn monomials(degree: usize) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    for d in 0..=degree {
        for q in 0..=d {
            v.push((d - q, q));
        }
    }
    v
}

/// Signed area of a polygon.
pub fn polygon_area(p: &[Point2<f64>]) -> f64 {
    let mut a = 0.0;
    for i in 0..p.len() {
        let (u, v) = (p[i], p[(i + 1) % p.len()]);
        a += u.x * v.y - v.x * u.y;
    }
    0.5 * a
}

/// Ear-clipping triangulation of a simple CCW polygon.
pub fn triangulate(poly: &[Point2<f64>]) -> Vec<[Point2<f64>; 3]> {
    let mut idx: Vec<usize> = (0..poly.len()).collect();
    // Drop repeated points.
    idx.dedup_by(|a, b| (poly[*a] - poly[*b]).norm() == 0.0);
    let mut tris = Vec::new();
    let scale = poly.iter().map(|p| p.coords.norm()).fold(0.0, f64::max).max(1.0);
    let mut guard = 0;
    while idx.len() > 3 && guard < 10 * poly.len() * poly.len() + 10 {
        guard += 1;
        let n = idx.len();
        let mut clipped = false;
        for i in 0..n {
            let (ia, ib, ic) = (idx[(i + n - 1) % n], idx[i], idx[(i + 1) % n]);
            let (a, b, c) = (poly[ia], poly[ib], poly[ic]);
            let area2 = cross(b - a, c - a);
            if area2 <= 1e-14 * scale * scale {
                if area2.abs() <= 1e-14 * scale * scale {
                    // Collinear vertex: drop it, it carries no area.
                    idx.remove(i);
                    clipped = true;
                    break;
                }
                continue;
            }
            let inside = idx.iter().any(|&j| {
                if j == ia || j == ib || j == ic {
                    return false;
                }
                let p = poly[j];
                cross(b - a, p - a) >= 0.0 && cross(c - b, p - b) >= 0.0 && cross(a - c, p - c) >= 0.0
            });
            if !inside {
                tris.push([a, b, c]);
                idx.remove(i);
                clipped = true;
                break;
            }
        }
        if !clipped {
            break;
        }
    }
    if idx.len() == 3 {
        let (a, b, c) = (poly[idx[0]], poly[idx[1]], poly[idx[2]]);
        if cross(b - a, c - a) > 0.0 {
            tris.push([a, b, c]);
        }
    }
    tris
}

/// A chain of surface pieces through a cell and the perimeter parameters of its start and end
/// where they lie on the cell boundary (`None`: inside the cell).
type Chain = (Vec<Point2<f64>>, (Option<f64>, Option<f64>));

/// Material loops of one cell from its surface pieces: the chains the pieces form, closed
/// inside the cell or walked along the cell boundary from each exit to the next entry.
fn cell_loops(mesh: &Mesh2, c: usize, pieces: &[Piece]) -> Result<Vec<Vec<Point2<f64>>>, SurfaceError> {
    let poly = cell_polygon(mesh, c);
    let on_tol = 1e3 * SNAP * cell_size(&poly);
    let (chains, chain_ends): (Vec<_>, Vec<_>) = surface_chains(&poly, c, pieces, on_tol)?.into_iter().unzip();
    let mut loops = Vec::new();
    // Chains without boundary events are closed loops inside the cell.
    let mut events: Vec<(f64, bool, usize)> = Vec::new(); // (sigma, is_exit, chain)
    let mut interior_loops_area = 0.0;
    for (i, e) in chain_ends.iter().enumerate() {
        match e {
            (Some(s0), Some(s1)) => {
                events.push((*s0, false, i));
                events.push((*s1, true, i));
            }
            (None, None) => {
                let mut lp = chains[i].clone();
                if (lp[0] - lp[lp.len() - 1]).norm() <= on_tol {
                    lp.pop();
                }
                interior_loops_area += polygon_area(&lp);
                loops.push(lp);
            }
            _ => {
                return Err(SurfaceError::Inconsistent {
                    cell: c,
                    msg: "an open surface ends inside this cell: it must start and end on or outside the host boundary"
                        .into(),
                })
            }
        }
    }
    if events.is_empty() {
        // Whole boundary material iff the interior loops are holes (clockwise).
        if interior_loops_area < 0.0 || loops.is_empty() {
            loops.push(poly.clone());
        }
        return Ok(loops);
    }
    loops.extend(boundary_loops(&poly, c, &chains, events, on_tol)?);
    Ok(loops)
}

/// The chains of a cell's surface pieces: consecutive pieces joined at points inside the cell.
fn surface_chains(poly: &[Point2<f64>], c: usize, pieces: &[Piece], on_tol: f64) -> Result<Vec<Chain>, SurfaceError> {
    let mut chains: Vec<Vec<Point2<f64>>> = Vec::new();
    let mut chain_ends: Vec<(Option<f64>, Option<f64>)> = Vec::new(); // perimeter params of start/end if on boundary
    for p in pieces {
        let (sa, da) = perimeter_param(&poly, p.a);
        let (sb, db) = perimeter_param(&poly, p.b);
        let start_on = da <= on_tol;
        let end_on = db <= on_tol;
        // A piece starting where the previous one (in polyline order) ended continues its
        // chain, even on the cell boundary: the surface touches the boundary and goes on.
        let continues = chains.last().map(|ch| (ch[ch.len() - 1] - p.a).norm() <= on_tol).unwrap_or(false);
        if continues {
            let ch = chains.last_mut().ok_or(SurfaceError::Inconsistent { cell: c, msg: "empty chain".into() })?;
            ch.push(p.b);
            if let Some(e) = chain_ends.last_mut() {
                e.1 = if end_on { Some(sb) } else { None };
            }
        } else {
            chains.push(vec![p.a, p.b]);
            chain_ends.push((if start_on { Some(sa) } else { None }, if end_on { Some(sb) } else { None }));
        }
    }
    // A closed polyline wraps around: join the last chain into the first if they meet inside.
    if chains.len() > 1 {
        let k = chains.len() - 1;
        if (chains[k][chains[k].len() - 1] - chains[0][0]).norm() <= on_tol {
            let last = chains.pop().unwrap_or_default();
            let le = chain_ends.pop().unwrap_or((None, None));
            let mut joined = last;
            joined.extend_from_slice(&chains[0][1..]);
            chains[0] = joined;
            chain_ends[0].0 = le.0;
        }
    }
    Ok(chains.into_iter().zip(chain_ends).collect())
}

/// The material loops that run along the cell boundary: from each exit event of a chain,
/// counter-clockwise along the boundary to the next entry, then along that chain.
fn boundary_loops(
    poly: &[Point2<f64>],
    c: usize,
    chains: &[Vec<Point2<f64>>],
    mut events: Vec<(f64, bool, usize)>,
    on_tol: f64,
) -> Result<Vec<Vec<Point2<f64>>>, SurfaceError> {
    let n = poly.len();
    let mut loops = Vec::new();
    events.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
    let ne = events.len();
    let mut used = vec![false; ne];
    for start in 0..ne {
        if used[start] || !events[start].1 {
            continue;
        }
        let mut lp: Vec<Point2<f64>> = Vec::new();
        let mut k = start;
        let mut guard = 0;
        loop {
            guard += 1;
            if guard > 4 * ne + 4 {
                return Err(SurfaceError::Inconsistent { cell: c, msg: "cannot close a material loop".into() });
            }
            used[k] = true;
            // From exit event k, walk the boundary CCW to the next event (an entry).
            let s_from = events[k].0;
            let next = (k + 1) % ne;
            let s_to = events[next].0 + if next <= k { n as f64 } else { 0.0 };
            if events[next].1 {
                return Err(SurfaceError::Inconsistent {
                    cell: c,
                    msg: "two exits in a row along the cell boundary (surface orientation?)".into(),
                });
            }
            let mut corner = s_from.floor() + 1.0;
            while corner < s_to - 1e-12 {
                lp.push(poly[(corner as usize) % n]);
                corner += 1.0;
            }
            used[next] = true;
            let ch = &chains[events[next].2];
            lp.extend_from_slice(ch);
            // The chain ends at its exit event.
            k = events
                .iter()
                .position(|e| e.1 && e.2 == events[next].2)
                .ok_or(SurfaceError::Inconsistent { cell: c, msg: "chain without exit".into() })?;
            if k == start {
                break;
            }
        }
        lp.dedup_by(|a, b| (*a - *b).norm() <= on_tol);
        if lp.len() > 2 && (lp[0] - lp[lp.len() - 1]).norm() <= on_tol {
            lp.pop();
        }
        if lp.len() >= 3 {
            loops.push(lp);
        }
    }
    Ok(loops)
}

/// Edge neighbours of every cell (`usize::MAX`: boundary edge), built once per host mesh.
#[derive(Debug, Clone)]
pub struct CellAdjacency {
    neighbours: Vec<[usize; 4]>,
}

impl CellAdjacency {
    pub fn new(mesh: &Mesh2) -> Self {
        let mut owner: HashMap<(usize, usize), (usize, usize)> = HashMap::with_capacity(2 * mesh.num_cells());
        let mut neighbours = vec![[usize::MAX; 4]; mesh.num_cells()];
        for (c, cell) in mesh.cells.iter().enumerate() {
            for (k, [a, b]) in cell.edges().enumerate() {
                match owner.remove(&(a.min(b), a.max(b))) {
                    Some((o, ko)) => {
                        neighbours[c][k] = o;
                        neighbours[o][ko] = c;
                    }
                    None => {
                        owner.insert((a.min(b), a.max(b)), (c, k));
                    }
                }
            }
        }
        CellAdjacency { neighbours }
    }
    pub fn neighbour(&self, c: usize, k: usize) -> Option<usize> {
        let n = self.neighbours[c][k];
        (n != usize::MAX).then_some(n)
    }
}

/// Classifies every host cell and computes material loops of the cut ones.
pub fn cut_mesh(mesh: &Mesh2, adjacency: &CellAdjacency, embeddings: &[&Embedding]) -> Result<CutMesh, SurfaceError> {
    let nc = mesh.num_cells();
    // An open surface must separate the host: its embedded part starts and ends on the host's
    // outer boundary (edges without a neighbour).
    for emb in embeddings.iter().filter(|e| !e.closed) {
        let (Some(first), Some(last)) = (emb.pieces.first(), emb.pieces.last()) else { continue };
        for (cell, p) in [(first.cell, first.a), (last.cell, last.b)] {
            let poly = cell_polygon(mesh, cell);
            let tol = 1e3 * SNAP * cell_size(&poly);
            let n = poly.len();
            let on_outer =
                emb.cell_pieces.iter().filter(|q| (q.a - p).norm() <= tol || (q.b - p).norm() <= tol).any(|q| {
                    let poly = cell_polygon(mesh, q.cell);
                    (0..n.min(poly.len())).any(|k| {
                        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                        let e = b - a;
                        let s = ((p - a).dot(&e) / e.norm_squared()).clamp(0.0, 1.0);
                        (a + e * s - p).norm() <= tol && adjacency.neighbour(q.cell, k).is_none()
                    })
                });
            if !on_outer {
                return Err(SurfaceError::Inconsistent {
                    cell,
                    msg: format!("an open surface ends inside the host at ({:.6}, {:.6}): it must start and end on or outside the host boundary", p.x, p.y),
                });
            }
        }
    }
    let mut per_cell: HashMap<usize, Vec<Piece>> = HashMap::new();
    for emb in embeddings {
        for p in &emb.cell_pieces {
            per_cell.entry(p.cell).or_default().push(*p);
        }
    }
    let mut cells: Vec<Option<CellCut>> = vec![None; nc];
    let mut fraction = vec![f64::NAN; nc];
    // Status of each (cell, edge) stretch next to a cut cell: Some(true) material.
    let mut edge_status: Vec<(usize, usize, bool)> = Vec::new();
    let mut keys: Vec<usize> = per_cell.keys().copied().collect();
    keys.sort_unstable();
    for c in keys {
        let pieces = &per_cell[&c];
        let loops = cell_loops(mesh, c, pieces)?;
        let poly = cell_polygon(mesh, c);
        let full = polygon_area(&poly);
        let area: f64 = loops.iter().map(|l| polygon_area(l)).sum();
        let f = area / full;
        // Checked with the areas about the cell's first corner: far from the origin, in a
        // fine mesh, the absolute shoelace sums lose (|x| / h)^2 ulps and the fraction of a
        // whole cell can read 1 + 1e-9 (a 4000 x 5000 mesh of a few mm did).
        let about = |p: &[Point2<f64>]| polygon_area(&p.iter().map(|q| Point2::from(q - poly[0])).collect::<Vec<_>>());
        let f_local = loops.iter().map(|l| about(l)).sum::<f64>() / about(&poly);
        if !(-1e-9..=1.0 + 1e-9).contains(&f_local) {
            return Err(SurfaceError::Inconsistent {
                cell: c,
                msg: format!("material fraction {f_local:.3e} outside [0, 1]"),
            });
        }
        fraction[c] = f.clamp(0.0, 1.0);
        cells[c] = Some(if f <= CUT_TOL {
            CellCut::Void
        } else if f >= 1.0 - CUT_TOL {
            CellCut::Material
        } else {
            CellCut::Cut { loops: loops.clone(), area }
        });
        // Edge stretches for flood fill: the midpoint of each cell edge, material if inside a loop.
        let n = poly.len();
        for k in 0..n {
            let mid = Point2::from((poly[k].coords + poly[(k + 1) % n].coords) * 0.5);
            let inside = loops.iter().any(|l| point_on_loop_boundary(l, mid, 1e-9 * cell_size(&poly)));
            edge_status.push((c, k, inside));
        }
    }
    // Flood fill uncut cells across edges (adjacency built once per host mesh).
    let mut queue: std::collections::VecDeque<(usize, bool)> = std::collections::VecDeque::new();
    for &(c, k, mat) in &edge_status {
        if let Some(nb) = adjacency.neighbour(c, k) {
            if cells[nb].is_none() {
                queue.push_back((nb, mat));
            }
        }
    }
    while let Some((c, mat)) = queue.pop_front() {
        if cells[c].is_some() {
            continue;
        }
        cells[c] = Some(if mat { CellCut::Material } else { CellCut::Void });
        fraction[c] = if mat { 1.0 } else { 0.0 };
        for k in 0..mesh.cells[c].nodes().len() {
            if let Some(nb) = adjacency.neighbour(c, k) {
                if cells[nb].is_none() {
                    queue.push_back((nb, mat));
                }
            }
        }
    }
    let cells: Vec<CellCut> = cells.into_iter().map(|c| c.unwrap_or(CellCut::Material)).collect();
    for (c, f) in fraction.iter_mut().enumerate() {
        if f.is_nan() {
            *f = if cells[c] == CellCut::Void { 0.0 } else { 1.0 };
        }
    }
    let mut num = vec![0.0; mesh.num_nodes()];
    let mut den = vec![0.0; mesh.num_nodes()];
    for (c, cell) in mesh.cells.iter().enumerate() {
        let a = polygon_area(&cell_polygon(mesh, c));
        for &nd in cell.nodes() {
            num[nd] += fraction[c] * a;
            den[nd] += a;
        }
    }
    let node_fraction = num.iter().zip(&den).map(|(a, b)| if *b > 0.0 { a / b } else { 0.0 }).collect();
    Ok(CutMesh { cells, cell_fraction: fraction, node_fraction })
}

/// Even-odd point-in-polygon test for a material loop.
pub fn point_in_loop(l: &[Point2<f64>], p: Point2<f64>) -> bool {
    let mut inside = false;
    let n = l.len();
    for i in 0..n {
        let (a, b) = (l[i], l[(i + 1) % n]);
        if (a.y > p.y) != (b.y > p.y) {
            let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
            if p.x < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Is `p` on the boundary or inside loop `l` (edge midpoints of the cell are either on a
/// material loop's boundary or outside every loop)?
fn point_on_loop_boundary(l: &[Point2<f64>], p: Point2<f64>, tol: f64) -> bool {
    let n = l.len();
    for k in 0..n {
        let (a, b) = (l[k], l[(k + 1) % n]);
        let e = b - a;
        let s = ((p - a).dot(&e) / e.norm_squared()).clamp(0.0, 1.0);
        if (a + e * s - p).norm() <= tol {
            return true;
        }
    }
    false
}

/// Fixed rule of a cell cut when the model is built: degree-2 triangle rule on every triangle of
/// the material sub-triangulation, mapped to the host cell's reference coordinates.
pub fn subtriangulation_rule(mesh: &Mesh2, c: usize, loops: &[Vec<Point2<f64>>]) -> QuadratureRule {
    let tri = triangle_rule(2);
    let mapped = MappedElement::new(mesh.cells[c].kind, mesh.cell_coords(c));
    let mut rule = QuadratureRule { points: vec![], weights: vec![] };
    for lp in loops {
        for t in triangulate(lp) {
            let area2 = cross(t[1] - t[0], t[2] - t[0]);
            for (xi, w) in tri.points.iter().zip(&tri.weights) {
                let x = t[0] + (t[1] - t[0]) * xi[0] + (t[2] - t[0]) * xi[1];
                if let Some(r) = mapped.inverse_map(x) {
                    let det = mapped.jacobian(r).determinant();
                    rule.points.push(r);
                    rule.weights.push(w * area2 / det);
                }
            }
        }
    }
    rule
}

/// The richer fixed rule of a cell that a moving surface may visit (its band): 8 x 8 Gauss on
/// `Quad4`, a 64-point collapsed Gauss rule on `Tri3`, plus the cell's vertices and edge
/// midpoints with weight zero. The weights are those of the uncut cell (exact to degree 15 /
/// 14); a cut refits them ([`band_weights`]). The boundary points put every material
/// centroid inside the convex hull of the points, so first moments can always be fitted when
/// every point may carry weight.
pub fn band_rule(kind: CellKind) -> QuadratureRule {
    let (mut rule, extra): (QuadratureRule, &[[f64; 2]]) = match kind {
        CellKind::Quad4 => (
            quad_gauss(8),
            &[[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]],
        ),
        CellKind::Tri3 => {
            (collapsed_triangle_rule(14), &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])
        }
    };
    for p in extra {
        rule.points.push(*p);
        rule.weights.push(0.0);
    }
    rule
}

/// How a cut band cell is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BandPoints {
    /// Bodies with history: only the fixed points inside the material carry weight (a point in
    /// the void keeps its last values and weight zero); weights by moment fitting.
    Material,
    /// Bodies without history: nothing is stored at the points, so a cut cell takes the exact
    /// sub-triangulation rule of its material in its fixed slots ([`band_exact_rule`]); where
    /// that rule needs more slots than the cell has, moment fitting on every point of the cell.
    Any,
}

/// Reference weights of a band cell's fixed `rule` (from [`band_rule`]) for its current cut
/// state: the uncut weights for a material cell, zeros for a void one, moment-fitted weights
/// ([`fit_weights`]) for a cut one. Returns the weights and the moment degree matched
/// (`None`: not even the area; `Some(usize::MAX)` for an uncut cell).
pub fn band_weights(
    mesh: &Mesh2,
    c: usize,
    rule: &QuadratureRule,
    full_weights: &[f64],
    state: &CellCut,
    which: BandPoints,
) -> (Vec<f64>, Option<usize>) {
    match state {
        CellCut::Material => (full_weights.to_vec(), Some(usize::MAX)),
        CellCut::Void => (vec![0.0; rule.len()], Some(usize::MAX)),
        CellCut::Cut { .. } => {
            let (w, degree) = band_fit(mesh, c, rule, state, which);
            (w, degree)
        }
    }
}

/// Where a band cell of a body without history is cut: the exact sub-triangulation rule of its
/// material, in the cell's fixed slots (padded with zero weights), when it fits them. Nothing
/// is stored at such points, so moving them transfers nothing; the integral is then exact to
/// degree 2 on every cut, slivers included. `None` for other cells or a rule that does not fit.
pub fn band_exact_rule(mesh: &Mesh2, c: usize, slots: usize, state: &CellCut) -> Option<QuadratureRule> {
    let CellCut::Cut { loops, .. } = state else { return None };
    let mut rule = subtriangulation_rule(mesh, c, loops);
    if rule.is_empty() || rule.len() > slots {
        return None;
    }
    let centre = match mesh.cells[c].kind {
        CellKind::Quad4 => [0.0, 0.0],
        CellKind::Tri3 => [1.0 / 3.0, 1.0 / 3.0],
    };
    while rule.len() < slots {
        rule.points.push(centre);
        rule.weights.push(0.0);
    }
    Some(rule)
}

/// Moment-fitted weights of a cut band cell on its fixed points.
fn band_fit(
    mesh: &Mesh2,
    c: usize,
    rule: &QuadratureRule,
    state: &CellCut,
    which: BandPoints,
) -> (Vec<f64>, Option<usize>) {
    match state {
        CellCut::Material | CellCut::Void => (vec![0.0; rule.len()], None),
        CellCut::Cut { loops, .. } => {
            let mapped = MappedElement::new(mesh.cells[c].kind, mesh.cell_coords(c));
            let x: Vec<Point2<f64>> = rule.points.iter().map(|xi| mapped.map(*xi)).collect();
            let h = cell_size(&cell_polygon(mesh, c));
            let material: Vec<bool> = x
                .iter()
                .map(|p| loops.iter().any(|l| point_in_loop(l, *p) || point_on_loop_boundary(l, *p, 1e-12 * h)))
                .collect();
            let (mut w, mut degree) = fit_weights(&x, &material, loops);
            // Bodies without history: where the material points cannot carry second moments,
            // every point of the cell may (a higher degree wins; at equal degree the local fit
            // on the material points is kept).
            if which == BandPoints::Any && degree.is_none_or(|d| d < 2) {
                let (w_any, d_any) = fit_weights(&x, &vec![true; x.len()], loops);
                if d_any.unwrap_or(0) > degree.unwrap_or(0) || (degree.is_none() && d_any.is_some()) {
                    (w, degree) = (w_any, d_any);
                }
            }
            let mut w_ref: Vec<f64> =
                w.iter().zip(&rule.points).map(|(w, xi)| w / mapped.jacobian(*xi).determinant()).collect();
            // Only the area could be matched (a sliver): NNLS would put it on one or two points,
            // a rank-deficient rule. Spread it over every material point in proportion to its
            // uncut weight instead (the truncated Gauss rule, scaled to the exact area).
            if degree == Some(0) {
                let area = loop_moments(loops, 0, loops[0][0], 1.0)[0];
                let base: Vec<f64> = rule
                    .weights
                    .iter()
                    .zip(&rule.points)
                    .zip(&material)
                    .map(|((w, xi), &m)| if m { w * mapped.jacobian(*xi).determinant() } else { 0.0 })
                    .collect();
                let total: f64 = base.iter().sum();
                if total > 0.0 {
                    w_ref = base
                        .iter()
                        .zip(&rule.points)
                        .map(|(b, xi)| area * b / total / mapped.jacobian(*xi).determinant())
                        .collect();
                }
            }
            (w_ref, degree)
        }
    }
}

/// Lawson-Hanson non-negative least squares: `min |A w - b|`, `w >= 0`.
pub fn nnls(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let n = a.ncols();
    let mut w = DVector::zeros(n);
    let mut passive = vec![false; n];
    let tol = 1e-14 * a.amax().max(1e-300) * b.amax().max(1e-300);
    for _outer in 0..3 * n + 10 {
        let grad = a.transpose() * (b - a * &w);
        let cand = (0..n).filter(|&j| !passive[j]).max_by(|&i, &j| grad[i].total_cmp(&grad[j]));
        let Some(j) = cand else { break };
        if grad[j] <= tol {
            break;
        }
        passive[j] = true;
        for _inner in 0..3 * n + 10 {
            let idx: Vec<usize> = (0..n).filter(|&k| passive[k]).collect();
            let ap = DMatrix::from_fn(a.nrows(), idx.len(), |r, c| a[(r, idx[c])]);
            let z = match ap.clone().svd(true, true).solve(b, 1e-14) {
                Ok(z) => z,
                Err(_) => break,
            };
            if z.iter().all(|&v| v > 0.0) {
                for (c, &k) in idx.iter().enumerate() {
                    w[k] = z[c];
                }
                break;
            }
            let mut alpha = f64::INFINITY;
            for (c, &k) in idx.iter().enumerate() {
                if z[c] <= 0.0 {
                    alpha = alpha.min(w[k] / (w[k] - z[c]));
                }
            }
            for (c, &k) in idx.iter().enumerate() {
                w[k] += alpha * (z[c] - w[k]);
                if w[k] <= 1e-15 * w.amax().max(1e-300) {
                    w[k] = 0.0;
                    passive[k] = false;
                }
            }
        }
    }
    w
}

/// Moment-fitted non-negative weights (physical measure) for fixed points `x` (physical
/// coordinates) of a cell whose material is bounded by `loops`. Points outside the material get
/// weight zero. Tries degree 2, then 1, then 0; returns the weights and the degree reached
/// (moments matched to `1e-12` relative), or `None` if not even the area can be matched.
pub fn fit_weights(x: &[Point2<f64>], inside: &[bool], loops: &[Vec<Point2<f64>>]) -> (Vec<f64>, Option<usize>) {
    let all: Vec<Point2<f64>> = loops.iter().flatten().copied().collect();
    let k = all.len().max(1) as f64;
    let origin = Point2::from(all.iter().fold(Vector2::zeros(), |a, p| a + p.coords) / k);
    let h = all.iter().map(|p| (p - origin).norm()).fold(0.0, f64::max).max(1e-300);
    let active: Vec<usize> = (0..x.len()).filter(|&i| inside[i]).collect();
    for degree in [2usize, 1, 0] {
        let exps = monomials(degree);
        let m = DVector::from_vec(loop_moments(loops, degree, origin, h));
        let a = DMatrix::from_fn(exps.len(), active.len(), |r, c| {
            let p = (x[active[c]] - origin) / h;
            p.x.powi(exps[r].0 as i32) * p.y.powi(exps[r].1 as i32)
        });
        let w = nnls(&a, &m);
        let res = (&a * &w - &m).amax();
        if res <= 1e-12 * m[0].abs() && m[0] > 0.0 {
            let mut full = vec![0.0; x.len()];
            for (c, &i) in active.iter().enumerate() {
                full[i] = w[c];
            }
            return (full, Some(degree));
        }
    }
    (vec![0.0; x.len()], None)
}

/// Physical points and reference weights of a rule in a cell (for fitting).
pub fn rule_points(mesh: &Mesh2, c: usize, rule: &QuadratureRule) -> Vec<Point2<f64>> {
    let m = MappedElement::new(mesh.cells[c].kind, mesh.cell_coords(c));
    rule.points.iter().map(|xi| m.map(*xi)).collect()
}

/// One face of the ghost penalty: the host edge between `cut_cell` and its `neighbour`, and its
/// contributions `(dof_i, dof_j, value)` to the penalty matrix in the order they are summed
/// (Gauss point by Gauss point, so that [`ghost_penalty`] adds them as it always did).
#[derive(Debug, Clone, PartialEq)]
pub struct GhostFace {
    pub cut_cell: usize,
    pub neighbour: usize,
    pub entries: Vec<(usize, usize, f64)>,
}

impl GhostFace {
    /// The face's penalty force `K_F u` at `u`, summed per DOF (sorted by DOF).
    pub fn force(&self, u: &[f64]) -> Vec<(usize, f64)> {
        let mut f: Vec<(usize, f64)> = vec![];
        for &(i, j, v) in &self.entries {
            match f.iter_mut().find(|(d, _)| *d == i) {
                Some(e) => e.1 += v * u[j],
                None => f.push((i, v * u[j])),
            }
        }
        f.sort_by_key(|e| e.0);
        f
    }
}

/// Ghost-penalty stabilisation of cut cells (Burman, C. R. Acad. Sci. Paris I 348 (2010) 1217;
/// Burman & Hansbo 2012): on every interior host edge next to a cut cell, with material on both
/// sides, `G(u, v) = gamma E h int_F [d_n u] . [d_n v] ds` (jump of the normal derivative of each
/// displacement component, `h` the edge length, 2 Gauss points). It vanishes for linear fields,
/// so patch tests stay exact, and it gives nodes with a tiny material support the stiffness of
/// their neighbours. Returns `(dof_i, dof_j, value)` entries of a constant symmetric matrix in
/// global DOFs: the sum of the faces' entries ([`ghost_faces`]).
pub fn ghost_penalty(faces: Vec<GhostFace>) -> Vec<(usize, usize, f64)> {
    let mut acc: HashMap<(usize, usize), f64> = HashMap::new();
    for face in faces {
        for (i, j, x) in face.entries {
            *acc.entry((i, j)).or_insert(0.0) += x;
        }
    }
    let mut v: Vec<(usize, usize, f64)> = acc.into_iter().map(|((i, j), x)| (i, j, x)).filter(|t| t.2 != 0.0).collect();
    v.sort_by(|x, y| (x.0, x.1).cmp(&(y.0, y.1)));
    v
}

/// The faces of the ghost penalty (see [`ghost_penalty`]), each once, in cell order;
/// `node_offset` maps the mesh's nodes to global ones.
pub fn ghost_faces(
    mesh: &Mesh2,
    adjacency: &CellAdjacency,
    cut: &CutMesh,
    node_offset: usize,
    young: f64,
    gamma: f64,
) -> Vec<GhostFace> {
    use crate::fem::element::ShapeEval;
    let mut faces = vec![];
    let (gx, gw) = gauss_legendre(2);
    let mut ev = ShapeEval::default();
    for c in 0..mesh.num_cells() {
        if !matches!(cut.cells[c], CellCut::Cut { .. }) {
            continue;
        }
        for k in 0..mesh.cells[c].nodes().len() {
            let Some(nb) = adjacency.neighbour(c, k) else { continue };
            if cut.cell_fraction[nb] <= 0.0 {
                continue;
            }
            // Each face once: skip when the neighbour is also cut and has the smaller index.
            if matches!(cut.cells[nb], CellCut::Cut { .. }) && nb < c {
                continue;
            }
            let ns = mesh.cells[c].nodes();
            let (a, b) = (mesh.nodes[ns[k]], mesh.nodes[ns[(k + 1) % ns.len()]]);
            let e = b - a;
            let h = e.norm();
            let n = Vector2::new(e.y, -e.x) / h;
            let m1 = MappedElement::new(mesh.cells[c].kind, mesh.cell_coords(c));
            let m2 = MappedElement::new(mesh.cells[nb].kind, mesh.cell_coords(nb));
            let mut entries = vec![];
            for (x, w) in gx.iter().zip(&gw) {
                let p = a + e * (0.5 * (x + 1.0));
                let mut g: Vec<(usize, f64)> = Vec::with_capacity(8);
                for (m, cell, sign) in [(&m1, c, 1.0), (&m2, nb, -1.0)] {
                    let Some(xi) = m.inverse_map(p) else { continue };
                    m.eval(xi, &mut ev);
                    for (q, &node) in mesh.cells[cell].nodes().iter().enumerate() {
                        let d = sign * (ev.grad[q][0] * n.x + ev.grad[q][1] * n.y);
                        match g.iter_mut().find(|(nd, _)| *nd == node) {
                            Some(entry) => entry.1 += d,
                            None => g.push((node, d)),
                        }
                    }
                }
                let scale = gamma * young * h * 0.5 * w * h;
                for &(p_node, gp) in &g {
                    for &(q_node, gq) in &g {
                        for comp in 0..2 {
                            let (i, j) = (2 * (p_node + node_offset) + comp, 2 * (q_node + node_offset) + comp);
                            entries.push((i, j, scale * gp * gq));
                        }
                    }
                }
            }
            faces.push(GhostFace { cut_cell: c, neighbour: nb, entries });
        }
    }
    faces
}
