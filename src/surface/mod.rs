//! Virtual surfaces: polylines that cut through a host mesh (X-FEM partial integration).
//!
//! Convention: the host's **material lies on the left** of the oriented polyline, so the right
//! normal `(t_y, -t_x)` of a segment is the outward normal of the host material (the same
//! convention as mesh edge sets, whose cell lies on the left).
//!
//! Embedding (`embed`): every segment is clipped (Cyrus-Beck) against the host cells that a
//! bounding-volume hierarchy (parry `Bvh`) returns for its bounding box, never against all
//! cells. The clipped pieces tile the segment, each inside one host cell; their end points are
//! kept in host reference coordinates, so the current position of any point on the surface
//! follows from the host interpolation `x = X + sum N_j(xi) u_j` (not linear along a piece).
//!
//! Snapping: a surface vertex within `SNAP_VERTEX = 1e-6` cell sizes of a host node is moved
//! onto the node, else within that distance of a host edge onto the edge (the moved geometry
//! is what the surface then is). Geometric tolerance: `SNAP = 1e-9` times the host cell size. A point within it of a cell
//! boundary counts as on the boundary; pieces shorter than `1e3 SNAP` (a surface touching a cell
//! at a corner) are dropped; a segment running along a host edge yields a piece in both cells
//! (for cut classification) and is assigned, for mortar integration, to the cell on the material
//! side. A surface through a host node therefore needs no special case.

use crate::fem::element::MappedElement;
use crate::mesh::Mesh2;
use nalgebra::Point2;
use parry2d_f64::bounding_volume::Aabb;
use parry2d_f64::math::Vector as PVec;
use parry2d_f64::partitioning::{Bvh, BvhBuildStrategy};

/// Relative geometric tolerance (times the local host cell size).
pub const SNAP: f64 = 1e-9;
/// Surface vertices closer than this (times the cell size) to a host node are moved onto it;
/// otherwise, closer than this to a host edge, onto the edge. Removes slivers of relative size
/// below 1e-6 (a surface meant to run along grid lines or through nodes, up to round-off).
pub const SNAP_VERTEX: f64 = 1e-6;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SurfaceError {
    #[error("virtual surface needs at least two vertices (three if closed), got {0}")]
    TooFewVertices(usize),
    #[error("virtual surface segment {segment} has zero length")]
    ZeroLength { segment: usize },
    #[error("virtual surface crosses itself: segments {a} and {b} intersect near ({x:.6}, {y:.6})")]
    SelfIntersection { a: usize, b: usize, x: f64, y: f64 },
    #[error("virtual surface leaves the host mesh: segment {segment} near ({x:.6}, {y:.6}) lies in no host cell (a closed surface must lie inside the host; an open one must cross it once, starting and ending outside)")]
    OutsideHost { segment: usize, x: f64, y: f64 },
    #[error("virtual surface is inconsistent in host cell {cell}: {msg}")]
    Inconsistent { cell: usize, msg: String },
}

/// A bounding-volume hierarchy over axis-aligned boxes (host cells or surface segments).
#[derive(Debug, Clone)]
pub struct BoxIndex {
    bvh: Bvh,
}

fn aabb(lo: Point2<f64>, hi: Point2<f64>) -> Aabb {
    Aabb::new(PVec::new(lo.x, lo.y), PVec::new(hi.x, hi.y))
}

impl BoxIndex {
    /// Boxes as `(min, max)` corners; leaf `i` is box `i`.
    pub fn new(boxes: &[(Point2<f64>, Point2<f64>)]) -> Self {
        let leaves: Vec<Aabb> = boxes.iter().map(|&(lo, hi)| aabb(lo, hi)).collect();
        BoxIndex { bvh: Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves) }
    }

    /// Indices of the boxes that intersect `[lo, hi]`.
    pub fn query(&self, lo: Point2<f64>, hi: Point2<f64>, out: &mut Vec<usize>) {
        out.clear();
        let q = aabb(lo, hi);
        out.extend(self.bvh.intersect_aabb(&q).map(|i| i as usize));
    }

    /// [`Self::query`] without the boxes inside a tree node's box (`min`, `max` corners) that
    /// `wanted` refuses: whole subtrees are skipped, the others come in the same order.
    pub fn query_where(
        &self,
        lo: Point2<f64>,
        hi: Point2<f64>,
        wanted: impl Fn(Point2<f64>, Point2<f64>) -> bool,
        out: &mut Vec<usize>,
    ) {
        out.clear();
        let q = parry2d_f64::partitioning::BvhNode::leaf(aabb(lo, hi), 0);
        let check = |node: &parry2d_f64::partitioning::BvhNode| {
            let (a, b) = (node.mins(), node.maxs());
            node.intersects(&q) && wanted(Point2::new(a.x, a.y), Point2::new(b.x, b.y))
        };
        out.extend(self.bvh.leaves(check).map(|i| i as usize));
    }

    /// Index over the cells of a mesh.
    pub fn over_cells(mesh: &Mesh2) -> Self {
        let boxes: Vec<_> = mesh
            .cells
            .iter()
            .map(|c| {
                let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
                let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
                for &n in c.nodes() {
                    let p = mesh.nodes[n];
                    lo = Point2::new(lo.x.min(p.x), lo.y.min(p.y));
                    hi = Point2::new(hi.x.max(p.x), hi.y.max(p.y));
                }
                (lo, hi)
            })
            .collect();
        Self::new(&boxes)
    }
}

/// A polyline in reference coordinates, host material on its left.
#[derive(Debug, Clone, PartialEq)]
pub struct VirtualSurface {
    pub vertices: Vec<Point2<f64>>,
    pub closed: bool,
}

impl VirtualSurface {
    pub fn num_segments(&self) -> usize {
        if self.closed {
            self.vertices.len()
        } else {
            self.vertices.len().saturating_sub(1)
        }
    }
    pub fn segment(&self, i: usize) -> (Point2<f64>, Point2<f64>) {
        (self.vertices[i], self.vertices[(i + 1) % self.vertices.len()])
    }

    /// Checks vertex count, zero-length segments and self-intersection (BVH over segments).
    pub fn validate(&self) -> Result<(), SurfaceError> {
        let nv = self.vertices.len();
        if nv < 2 || (self.closed && nv < 3) {
            return Err(SurfaceError::TooFewVertices(nv));
        }
        let ns = self.num_segments();
        let mut boxes = Vec::with_capacity(ns);
        for i in 0..ns {
            let (a, b) = self.segment(i);
            if (b - a).norm() == 0.0 {
                return Err(SurfaceError::ZeroLength { segment: i });
            }
            boxes.push((Point2::new(a.x.min(b.x), a.y.min(b.y)), Point2::new(a.x.max(b.x), a.y.max(b.y))));
        }
        let index = BoxIndex::new(&boxes);
        let mut cand = Vec::new();
        for i in 0..ns {
            index.query(boxes[i].0, boxes[i].1, &mut cand);
            for &j in &cand {
                if j <= i {
                    continue;
                }
                let adjacent = j == i + 1 || (self.closed && i == 0 && j == ns - 1);
                let (a, b) = self.segment(i);
                let (c, d) = self.segment(j);
                if let Some(p) = segments_cross(a, b, c, d, adjacent) {
                    return Err(SurfaceError::SelfIntersection { a: i, b: j, x: p.x, y: p.y });
                }
            }
        }
        Ok(())
    }
}

fn cross(u: nalgebra::Vector2<f64>, v: nalgebra::Vector2<f64>) -> f64 {
    u.x * v.y - u.y * v.x
}

/// Proper intersection of two segments (shared end points of adjacent segments excluded).
fn segments_cross(
    a: Point2<f64>,
    b: Point2<f64>,
    c: Point2<f64>,
    d: Point2<f64>,
    adjacent: bool,
) -> Option<Point2<f64>> {
    let r = b - a;
    let s = d - c;
    let den = cross(r, s);
    let scale = r.norm() * s.norm();
    if den.abs() <= 1e-14 * scale {
        // Parallel: overlapping collinear segments are a self-intersection unless adjacent.
        if cross(c - a, r).abs() > 1e-12 * r.norm_squared() || adjacent {
            return None;
        }
        let rr = r.norm_squared();
        let (t0, t1) = ((c - a).dot(&r) / rr, (d - a).dot(&r) / rr);
        let (lo, hi) = (t0.min(t1), t0.max(t1));
        return if hi > 1e-12 && lo < 1.0 - 1e-12 { Some(a + r * lo.max(0.0)) } else { None };
    }
    let t = cross(c - a, s) / den;
    let u = cross(c - a, r) / den;
    let e = if adjacent { 1e-9 } else { -1e-12 };
    if t > e && t < 1.0 - e && u > e && u < 1.0 - e {
        Some(a + r * t)
    } else {
        None
    }
}

/// One piece of a surface segment inside one host cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    pub segment: usize,
    pub cell: usize,
    /// Parameters on the segment (`0..1`).
    pub t0: f64,
    pub t1: f64,
    pub a: Point2<f64>,
    pub b: Point2<f64>,
    /// Host reference coordinates of the end points.
    pub xi_a: [f64; 2],
    pub xi_b: [f64; 2],
}

/// A surface embedded in a host mesh.
#[derive(Debug, Clone)]
pub struct Embedding {
    /// Every clipped piece, per cell (a piece along a shared host edge appears for both cells).
    pub cell_pieces: Vec<Piece>,
    /// The surface once, in order, each piece assigned to one cell (for mortar integrals).
    pub pieces: Vec<Piece>,
    /// The surface vertices after snapping (the geometry actually embedded).
    pub vertices: Vec<Point2<f64>>,
    pub closed: bool,
}

/// Host cell corner coordinates as a CCW polygon.
pub fn cell_polygon(mesh: &Mesh2, c: usize) -> Vec<Point2<f64>> {
    mesh.cells[c].nodes().iter().map(|&n| mesh.nodes[n]).collect()
}

/// Characteristic size of a cell (square root of its area).
pub fn cell_size(poly: &[Point2<f64>]) -> f64 {
    let mut a = 0.0;
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        a += p.x * q.y - q.x * p.y;
    }
    (0.5 * a).abs().sqrt()
}

/// Cyrus-Beck clipping of `a + t (b - a)`, `t in [0, 1]`, against a convex CCW polygon, with a
/// distance tolerance. Returns the parameter interval.
pub fn clip_segment(poly: &[Point2<f64>], a: Point2<f64>, b: Point2<f64>, tol: f64) -> Option<(f64, f64)> {
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let n = poly.len();
    for k in 0..n {
        let e = poly[(k + 1) % n] - poly[k];
        let inward = nalgebra::Vector2::new(-e.y, e.x) / e.norm();
        let f0 = inward.dot(&(a - poly[k])) + tol;
        let fd = inward.dot(&d);
        if fd.abs() < 1e-300 {
            if f0 < 0.0 {
                return None;
            }
        } else {
            let t = -f0 / fd;
            if fd > 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}

fn inverse_map(mesh: &Mesh2, c: usize, x: Point2<f64>) -> [f64; 2] {
    let m = MappedElement::new(mesh.cells[c].kind, mesh.cell_coords(c));
    m.inverse_map(x).unwrap_or([0.0, 0.0])
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum OpenState {
    Before,
    Inside,
    After,
}

/// Moves a point onto a host node or edge within `SNAP_VERTEX` cell sizes of it.
pub fn snap_point(p: Point2<f64>, mesh: &Mesh2, index: &BoxIndex, cand: &mut Vec<usize>) -> Point2<f64> {
    index.query(p, p, cand);
    let mut best_edge: Option<(f64, Point2<f64>)> = None;
    for &c in cand.iter() {
        let poly = cell_polygon(mesh, c);
        let tol = SNAP_VERTEX * cell_size(&poly);
        for q in &poly {
            if (q - p).norm() <= tol {
                return *q;
            }
        }
        let n = poly.len();
        for k in 0..n {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            let e = b - a;
            let s = ((p - a).dot(&e) / e.norm_squared()).clamp(0.0, 1.0);
            let q = a + e * s;
            let d = (q - p).norm();
            if d <= tol && best_edge.map(|(bd, _)| d < bd).unwrap_or(true) {
                best_edge = Some((d, q));
            }
        }
    }
    best_edge.map(|(_, q)| q).unwrap_or(p)
}

/// Embeds a validated surface into a host mesh (vertices snapped first, see [`snap_point`]).
pub fn embed(surface: &VirtualSurface, mesh: &Mesh2, index: &BoxIndex) -> Result<Embedding, SurfaceError> {
    let mut cand = Vec::new();
    let snapped = VirtualSurface {
        vertices: surface.vertices.iter().map(|&v| snap_point(v, mesh, index, &mut cand)).collect(),
        closed: surface.closed,
    };
    let surface = &snapped;
    let ns = surface.num_segments();
    let mut state = OpenState::Before;
    let mut cell_pieces = Vec::new();
    let mut pieces: Vec<Piece> = Vec::new();
    let mut found: Vec<(usize, f64, f64)> = Vec::new();
    for s in 0..ns {
        let (a, b) = surface.segment(s);
        let len = (b - a).norm();
        index.query(Point2::new(a.x.min(b.x), a.y.min(b.y)), Point2::new(a.x.max(b.x), a.y.max(b.y)), &mut cand);
        found.clear();
        for &c in &cand {
            let poly = cell_polygon(mesh, c);
            let h = cell_size(&poly);
            if let Some((t0, t1)) = clip_segment(&poly, a, b, SNAP * h) {
                if (t1 - t0) * len > 1e3 * SNAP * h {
                    // The tolerance decides membership; the end points come from the exact
                    // clip when it exists, so that pieces never overhang their cell.
                    let (u0, u1) = clip_segment(&poly, a, b, 0.0).unwrap_or((t0, t1));
                    let (t0, t1) = if u1 > u0 { (u0, u1) } else { (t0, t1) };
                    found.push((c, t0, t1));
                }
            }
        }
        found.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
        // Coverage: merged intervals of the pieces. A closed surface lies inside the host; an
        // open one may start and end outside it (it then separates the host), but may not
        // leave and re-enter.
        let mut merged: Vec<(f64, f64)> = Vec::new();
        for &(_, t0, t1) in &found {
            match merged.last_mut() {
                Some(m) if t0 <= m.1 + 1e-6 => m.1 = m.1.max(t1),
                _ => merged.push((t0, t1)),
            }
        }
        let outside_at = |t: f64| {
            let p = a + (b - a) * t;
            SurfaceError::OutsideHost { segment: s, x: p.x, y: p.y }
        };
        if surface.closed {
            match merged.as_slice() {
                [(lo, hi)] if *lo <= 1e-9 && *hi >= 1.0 - 1e-9 => {}
                [] => return Err(outside_at(0.0)),
                [(lo, hi), ..] => return Err(outside_at(if *lo > 1e-9 { 0.0 } else { *hi })),
            }
        } else {
            let full = |m: &(f64, f64)| m.0 <= 1e-9 && m.1 >= 1.0 - 1e-9;
            match (state, merged.as_slice()) {
                (_, [_, second, ..]) => return Err(outside_at(second.0)),
                (OpenState::Before, []) | (OpenState::After, []) => {}
                (OpenState::Before, [m]) => {
                    state = if m.1 >= 1.0 - 1e-9 { OpenState::Inside } else { OpenState::After }
                }
                (OpenState::Inside, [m]) if full(m) => {}
                (OpenState::Inside, [m]) if m.0 <= 1e-9 => state = OpenState::After,
                (OpenState::Inside, [m]) => return Err(outside_at(0.5 * m.0)),
                (OpenState::Inside, []) => return Err(outside_at(0.0)),
                (OpenState::After, [m]) => return Err(outside_at(m.0)),
            }
        }
        let mut last_t1 = 0.0f64;
        for &(c, t0, t1) in &found {
            let (t0c, t1c) = (t0.max(0.0), t1.min(1.0));
            let (pa, pb) = (a + (b - a) * t0c, a + (b - a) * t1c);
            let piece = Piece {
                segment: s,
                cell: c,
                t0: t0c,
                t1: t1c,
                a: pa,
                b: pb,
                xi_a: inverse_map(mesh, c, pa),
                xi_b: inverse_map(mesh, c, pb),
            };
            cell_pieces.push(piece);
            // Mortar pieces tile the segment once. An edge-aligned piece appears in both cells
            // with (nearly) the same interval: keep the cell on the material (left) side.
            if let Some(prev) = pieces.last_mut() {
                let dup = prev.segment == s
                    && (prev.t0 - t0c).abs() * len < 1e-6 * len
                    && (prev.t1 - t1c).abs() * len < 1e-6 * len;
                if dup {
                    let centre = |cc: usize| {
                        let poly = cell_polygon(mesh, cc);
                        let k = poly.len() as f64;
                        Point2::from(poly.iter().fold(nalgebra::Vector2::zeros(), |acc, p| acc + p.coords) / k)
                    };
                    if cross(b - a, centre(c) - a) > cross(b - a, centre(prev.cell) - a) {
                        *prev = piece;
                    }
                    continue;
                }
            }
            if t1c <= last_t1 + 1e-12 {
                continue;
            }
            let start = t0c.max(last_t1);
            let mut p = piece;
            if start > t0c {
                p.t0 = start;
                p.a = a + (b - a) * start;
                p.xi_a = inverse_map(mesh, c, p.a);
            }
            last_t1 = t1c;
            pieces.push(p);
        }
    }
    if !surface.closed && state == OpenState::Before {
        let p = surface.vertices[0];
        return Err(SurfaceError::OutsideHost { segment: 0, x: p.x, y: p.y });
    }
    Ok(Embedding { cell_pieces, pieces, vertices: snapped.vertices.clone(), closed: surface.closed })
}
