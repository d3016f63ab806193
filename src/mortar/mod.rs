//! Mortar integrals between a real surface (mesh edges, the *mortar side*, which carries the
//! Lagrange multipliers) and a virtual surface embedded in a host mesh ([`OtherSide::Embedded`],
//! MorteX) or another real surface ([`OtherSide::Edges`], classical mortar for comparisons).
//!
//! Tying constraint per multiplier node `l` and component `c` (Wohlmuth; MorteX: Akula,
//! Vignollet, Yastrebov, arXiv 1902.04003):
//! `g_lc = int_Gamma Phi_l (u_c^mortar - u_c^host) dS = sum_j D_lj u_jc - sum_k M_lk u_kc = 0`,
//! `D_lj = int Phi_l N_j dS` (mortar edge shape functions), `M_lk = int Phi_l N_k(xi(x)) dS`
//! with the host shape functions evaluated at the true host reference coordinates of each
//! quadrature point (the virtual surface is straight in physical space, so `xi` is not linear
//! along it). Segment-to-segment: the end points of every embedded piece are projected onto
//! the mortar segment, the overlap is integrated with 4 Gauss points (exact for `Phi N^host`:
//! linear times quadratic on a straight line through a parallelogram).
//!
//! Which side carries the multipliers: the mortar (real, mesh-conforming) side, as in the
//! MorteX papers: its edges are the integration segments, and the host side (the cut
//! "blending" elements) is interpolated. The traction on the mortar body is `t = -lambda`.
//!
//! Multiplier spaces ([`MultiplierSpace`]), built per *chain* (the mortar polyline split at
//! corners sharper than [`CORNER_ANGLE_DEG`], where the traction may jump):
//! * `Classical`: a hat function at every mortar vertex;
//! * both with the crosspoint modification at chain ends (see `build_multipliers`);
//! * `CoarseGrained`: hats only at a subset of vertices, end vertices always kept, spaced like
//!   the host (blending) cells along the chain: `n = max(1, round(L_chain / h_host))` intervals,
//!   `h_host` the mean size of the cut host cells (geometry only, no material data); the
//!   traction is interpolated linearly in arc length between consecutive multiplier nodes,
//!   across several segments.

use crate::fem::element::{MappedElement, ReferenceElement};
use crate::fem::quadrature::gauss_legendre;
use crate::mesh::Mesh2;
use crate::surface::{BoxIndex, Embedding};
use nalgebra::{Point2, Vector2};
use std::collections::BTreeMap;

/// Corner threshold: the mortar polyline is split into chains at turns sharper than this.
pub const CORNER_ANGLE_DEG: f64 = 20.0;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MultiplierSpace {
    Classical,
    #[default]
    CoarseGrained,
}

/// A closed or open polyline of mesh nodes (global ids and coordinates), mortar-body on its left.
#[derive(Debug, Clone)]
pub struct MortarSide {
    pub nodes: Vec<usize>,
    pub points: Vec<Point2<f64>>,
    pub closed: bool,
}

impl MortarSide {
    pub fn num_segments(&self) -> usize {
        if self.closed {
            self.points.len()
        } else {
            self.points.len() - 1
        }
    }
}

/// Multiplier nodes of one chain: vertex indices of the mortar side (consecutive, possibly
/// wrapping) and which of them carry a multiplier.
#[derive(Debug, Clone)]
pub struct Chain {
    /// Mortar vertex indices along the chain (first and last are corners or ends).
    pub vertices: Vec<usize>,
    /// Arc length at each chain vertex.
    pub arc: Vec<f64>,
    /// Positions (indices into `vertices`) of the multiplier nodes.
    pub lm_at: Vec<usize>,
    /// Global index of the chain's first multiplier node.
    pub first_lm: usize,
    /// A closed chain without corners: the last multiplier node interpolates back to the
    /// first one across vertex 0.
    pub periodic: bool,
}

/// The multiplier space of one interface.
#[derive(Debug, Clone)]
pub struct Multipliers {
    pub chains: Vec<Chain>,
    pub num_nodes: usize,
    /// Position and outward normal of the mortar body at each multiplier node.
    pub points: Vec<Point2<f64>>,
    pub normals: Vec<Vector2<f64>>,
}

fn right_normal(a: Point2<f64>, b: Point2<f64>) -> Vector2<f64> {
    let t = (b - a).normalize();
    Vector2::new(t.y, -t.x)
}

/// Contact pairs a mortar segment with an other-side segment only if their outward normals are
/// opposed by more than this angle's supplement: `n . n_other < -cos(60 deg)`, so the pairing
/// direction (their averaged normal) is within 30 degrees of each. Where two smooth surfaces
/// touch their normals are opposed (180 degrees), and the segments near a contact point of a
/// mesh that resolves the curvature are within a few degrees of it; segments meeting at a
/// steeper angle are a surface's flank seen across open space. Paired anyway (normals opposed
/// by just over 90 degrees, as for a rounded punch's near-vertical edge over a worn plate), the
/// averaged normal is tilted 45 degrees and the flank's rows read gaps of a third of a
/// millimetre as closing under sliding: a 60 um deep groove's pairing then flipped between
/// two states, one with a flank row carrying a third of the load, in any sub-step however short.
const FACING_COS: f64 = 0.5;

/// Whether mortar segment `pa pb` and other-side segment `a b` face each other closely enough
/// for contact (see [`FACING_COS`]).
fn facing_for_contact(pa: Point2<f64>, pb: Point2<f64>, a: Point2<f64>, b: Point2<f64>) -> bool {
    right_normal(pa, pb).dot(&right_normal(a, b)) < -FACING_COS
}

/// Splits the mortar side into chains at corners and places multiplier nodes.
/// `h_host` is the characteristic size of the host cells along the interface.
pub fn build_multipliers(side: &MortarSide, space: MultiplierSpace, h_host: f64) -> Multipliers {
    build_multipliers_with(side, |vs, arc| match space {
        MultiplierSpace::Classical => (0..vs.len()).collect(),
        MultiplierSpace::CoarseGrained => {
            let nseg = vs.len() - 1;
            let total = arc[nseg];
            let m = ((total / h_host).round() as usize).clamp(1, nseg);
            // Vertex closest in arc length to each equally spaced target.
            let mut v: Vec<usize> = (0..=m)
                .map(|i| {
                    let target = total * i as f64 / m as f64;
                    (0..=nseg).min_by(|&a, &b| (arc[a] - target).abs().total_cmp(&(arc[b] - target).abs())).unwrap_or(0)
                })
                .collect();
            v.dedup();
            v
        }
    })
}

/// Coarse-grained multipliers with a local spacing (contact along graded surfaces): walking
/// along each chain, the next multiplier node is the vertex whose arc distance from the last
/// one comes closest to `spacing[v]` (the size of the other side's elements near vertex `v`;
/// where the mortar side is coarser every vertex is kept). Chain ends are always kept.
pub fn build_multipliers_local(side: &MortarSide, spacing: &[f64]) -> Multipliers {
    build_multipliers_with(side, |vs, arc| {
        let nseg = vs.len() - 1;
        let mut keep = vec![0];
        let mut last = arc[0];
        for k in 1..nseg {
            let target = last + spacing[vs[k]];
            // Keep k when the next vertex would overshoot the target at least as much as k
            // falls short. Ties (within 1e-9 of the spacing, e.g. the other side exactly 1.5x
            // coarser) keep the vertex whatever the round-off: the space equals the classical
            // one while the other side is at most 1.5x coarser, and is coarser beyond.
            if arc[k + 1] - target >= target - arc[k] - 1e-9 * spacing[vs[k]] {
                keep.push(k);
                last = arc[k];
            }
        }
        // The end node; drop the previous one if it sits closer than half a spacing.
        if keep.len() > 1 && arc[nseg] - last < 0.5 * spacing[vs[nseg]] {
            keep.pop();
        }
        keep.push(nseg);
        keep
    })
}

/// Places multiplier nodes on the chains of `side`: `select(chain vertices, arc lengths)`
/// returns the chain-local indices of the multiplier vertices (increasing, ends included).
fn build_multipliers_with(side: &MortarSide, select: impl Fn(&[usize], &[f64]) -> Vec<usize>) -> Multipliers {
    let n = side.points.len();
    let seg = |i: usize| (side.points[i % n], side.points[(i + 1) % n]);
    let is_corner = |v: usize| -> bool {
        if !side.closed && (v == 0 || v == n - 1) {
            return true;
        }
        let (a, b) = seg((v + n - 1) % n);
        let (_, c) = seg(v);
        let (t0, t1) = ((b - a).normalize(), (c - b).normalize());
        let ang = (t0.x * t1.y - t0.y * t1.x).atan2(t0.dot(&t1)).abs();
        ang > CORNER_ANGLE_DEG.to_radians()
    };
    let corners: Vec<usize> = (0..n).filter(|&v| is_corner(v)).collect();
    // Chains from corner to corner (a closed side without corners is one closed chain from 0).
    let mut spans: Vec<Vec<usize>> = Vec::new();
    if corners.is_empty() {
        spans.push((0..=n).map(|v| v % n).collect());
    } else if !side.closed {
        for w in corners.windows(2) {
            spans.push((w[0]..=w[1]).collect());
        }
    } else {
        for (i, &c0) in corners.iter().enumerate() {
            let c1 = corners[(i + 1) % corners.len()];
            let len = if c1 > c0 { c1 - c0 } else { c1 + n - c0 };
            spans.push((0..=len).map(|k| (c0 + k) % n).collect());
        }
    }
    let mut chains = Vec::new();
    let mut points = Vec::new();
    let mut normals = Vec::new();
    let mut next_lm = 0;
    for vs in spans {
        let mut arc = vec![0.0];
        for k in 1..vs.len() {
            let d = (side.points[vs[k]] - side.points[vs[k - 1]]).norm();
            arc.push(arc[k - 1] + d);
        }
        let nseg = vs.len() - 1;
        let lm_at = select(&vs, &arc);
        // A closed chain without corners is periodic: vertex 0 (= vertex nseg) is an ordinary
        // multiplier node.
        let periodic = corners.is_empty();
        // Crosspoint modification (Wohlmuth 2000; Puso & Laursen): the nodes at the ends of an
        // open chain carry no multiplier of their own; the traction on the stretch between an
        // end and the first interior multiplier node is the linear extrapolation of the first
        // interval (see `Chain::hats`), so linear tractions stay exactly representable.
        // Without it the multipliers at a corner outnumber the trace space of the mortar side
        // and the saddle point is singular when the host trace nests in the mortar trace.
        let lm_at: Vec<usize> = if periodic {
            lm_at[..lm_at.len() - 1].to_vec()
        } else if lm_at.len() > 2 {
            lm_at[1..lm_at.len() - 1].to_vec()
        } else {
            vec![lm_at[0]]
        };
        for &k in &lm_at {
            let v = vs[k];
            points.push(side.points[v]);
            let mut nrm = Vector2::zeros();
            if k > 0 {
                nrm += right_normal(side.points[vs[k - 1]], side.points[v]);
            } else if periodic {
                nrm += right_normal(side.points[vs[nseg - 1]], side.points[v]);
            }
            if k < nseg {
                nrm += right_normal(side.points[v], side.points[vs[k + 1]]);
            }
            normals.push(nrm.normalize());
        }
        let count = lm_at.len();
        chains.push(Chain { vertices: vs, arc, lm_at, first_lm: next_lm, periodic });
        next_lm += count;
    }
    Multipliers { chains, num_nodes: next_lm, points, normals }
}

impl Multipliers {
    /// The same multiplier layout (chains, nodes) on a side whose vertices moved (a wearing
    /// virtual mortar side): arc lengths, node positions and normals follow the vertices; the
    /// number and order of multipliers never change.
    pub fn with_geometry(&self, side: &MortarSide) -> Multipliers {
        let mut out = self.clone();
        out.points.clear();
        out.normals.clear();
        for ch in out.chains.iter_mut() {
            let vs = &ch.vertices;
            let nseg = vs.len() - 1;
            for k in 1..vs.len() {
                ch.arc[k] = ch.arc[k - 1] + (side.points[vs[k]] - side.points[vs[k - 1]]).norm();
            }
            for &k in &ch.lm_at {
                let v = vs[k];
                out.points.push(side.points[v]);
                let mut nrm = Vector2::zeros();
                if k > 0 {
                    nrm += right_normal(side.points[vs[k - 1]], side.points[v]);
                } else if ch.periodic {
                    nrm += right_normal(side.points[vs[nseg - 1]], side.points[v]);
                }
                if k < nseg {
                    nrm += right_normal(side.points[v], side.points[vs[k + 1]]);
                }
                out.normals.push(nrm.normalize());
            }
        }
        out
    }
}

impl Multipliers {
    /// The nodal traction of a multiplier field `values` (one per node, e.g. the pressures
    /// `-lambda_n`): each node's contact force over its hat's measure,
    /// `t_i = int Phi_i (sum_j v_j Phi_j) / int Phi_i` (hats linear in arc length between the
    /// chain's multiplier nodes), the traction a node transmits, as dual multipliers give it
    /// directly (Wohlmuth, SIAM J. Numer. Anal. 38 (2000) 989) and nodal-force codes report it.
    /// Where the traction concentrates between two nodes (a worn contact's edge riding on a
    /// kink of the other surface), the coefficients `v` of the standard hats undershoot at the
    /// next node, down to an open row beside loaded ones; the nodal traction stays what the
    /// field transmits there. It is a local average over one element on each side: on a smooth
    /// field it differs from `v` by `h^2 v'' / 6`.
    pub fn nodal_traction(&self, values: &[f64]) -> Vec<f64> {
        debug_assert_eq!(values.len(), self.num_nodes);
        let mut force = vec![0.0; self.num_nodes];
        let mut measure = vec![0.0; self.num_nodes];
        // Two-point Gauss per interval between breakpoints (chain ends and multiplier nodes):
        // exact for the products of the hats, linear (or extrapolated linearly) on each.
        let gauss = [0.5 - 0.5 / 3f64.sqrt(), 0.5 + 0.5 / 3f64.sqrt()];
        for ch in &self.chains {
            let mut breaks: Vec<f64> = ch.lm_at.iter().map(|&k| ch.arc[k]).collect();
            breaks.push(ch.arc[0]);
            breaks.push(ch.arc[ch.arc.len() - 1]);
            breaks.sort_by(f64::total_cmp);
            breaks.dedup();
            for w in breaks.windows(2) {
                let h = w[1] - w[0];
                for g in gauss {
                    let hats = ch.hats(w[0] + g * h);
                    let field: f64 = hats.iter().map(|&(j, phi)| phi * values[ch.first_lm + j]).sum();
                    for (j, phi) in hats {
                        force[ch.first_lm + j] += 0.5 * h * phi * field;
                        measure[ch.first_lm + j] += 0.5 * h * phi;
                    }
                }
            }
        }
        (0..self.num_nodes).map(|i| if measure[i] > 0.0 { force[i] / measure[i] } else { values[i] }).collect()
    }
}

impl Chain {
    /// Multiplier hats at arc length `s`: `(local lm index, value)` pairs (two at most). Open
    /// chains: linear extrapolation of the first (last) interval between a chain end and the
    /// nearest multiplier node (values outside [0, 1] there, still a partition of unity);
    /// periodic chains wrap from the last node to the first; a single node is constant.
    pub fn hats(&self, s: f64) -> [(usize, f64); 2] {
        let mut bisect = usize::MAX;
        self.hats_from(s, &mut bisect)
    }

    /// [`Self::hats`], searching for the interval of `s` from `hint` (the interval found for
    /// the last arc length, updated): the mortar points of a chain come in arc order, so the
    /// search is a step or two instead of a bisection. The interval, hence the result, is that
    /// of [`Self::hats`] whatever the hint.
    pub fn hats_from(&self, s: f64, hint: &mut usize) -> [(usize, f64); 2] {
        let m = self.lm_at.len();
        let at = |j: usize| self.arc[self.lm_at[j]];
        if m == 1 {
            return [(0, 1.0), (0, 0.0)];
        }
        if self.periodic && s >= at(m - 1) {
            let (s0, s1) = (at(m - 1), self.arc[self.arc.len() - 1]);
            let phi = ((s1 - s) / (s1 - s0)).clamp(0.0, 1.0);
            return [(m - 1, phi), (0, 1.0 - phi)];
        }
        // Interval j (nodes j, j + 1) holding s; the end intervals extend to the chain ends.
        // The first j with s <= at(j + 1) (the arc grows along the chain), else the last.
        let ends = &self.lm_at[1..];
        let below = |i: usize| self.arc[ends[i]] < s;
        let j = if *hint < ends.len() {
            // The partition point of `below` (true on a prefix), walked to from the hint.
            let mut i = *hint;
            if below(i) {
                while i < ends.len() && below(i) {
                    i += 1;
                }
            } else {
                while i > 0 && !below(i - 1) {
                    i -= 1;
                }
            }
            i
        } else {
            ends.partition_point(|&v| self.arc[v] < s)
        };
        *hint = j.min(ends.len().saturating_sub(1));
        let j = j.min(m - 2);
        let (s0, s1) = (at(j), at(j + 1));
        let mut phi = (s1 - s) / (s1 - s0);
        if j > 0 && j < m - 2 {
            phi = phi.clamp(0.0, 1.0);
        } else if j == 0 && m > 2 {
            phi = phi.max(0.0);
        } else if j == m - 2 && m > 2 {
            phi = phi.min(1.0);
        }
        [(j, phi), (j + 1, 1.0 - phi)]
    }
}

/// One scalar constraint row: `sum coef * u[dof] = 0`.
pub type ConstraintRow = Vec<(usize, f64)>;

/// Size of the other side's elements near each mortar vertex (the nearest segment within
/// `reach`: a real edge's length, or the size of the host cell holding a virtual piece), or the
/// mortar side's own adjacent segment length where nothing is near.
pub fn other_side_spacing(side: &MortarSide, other: &OtherSide, reach: f64) -> Vec<f64> {
    let (segs, index) = other.indexed_segments();
    let n = side.points.len();
    let mut cand = Vec::new();
    (0..n)
        .map(|v| {
            let p = side.points[v];
            let own = if v + 1 < n || side.closed {
                (side.points[(v + 1) % n] - p).norm()
            } else {
                (p - side.points[v - 1]).norm()
            };
            index.query(Point2::new(p.x - reach, p.y - reach), Point2::new(p.x + reach, p.y + reach), &mut cand);
            let nearest = cand.iter().copied().min_by(|&i, &j| {
                let d = |k: usize| nrm_dist_segment(segs[k].0, segs[k].1, p);
                d(i).total_cmp(&d(j))
            });
            match nearest {
                None => own,
                Some(i) => match other {
                    OtherSide::Edges { points, .. } => (points[i][1] - points[i][0]).norm(),
                    // The host cell's extent along the piece: what the edge's length is to a
                    // real surface (the same rule whether or not a surface is virtual).
                    OtherSide::Embedded { host, embedding, .. } => {
                        let piece = &embedding.pieces[i];
                        let poly = crate::surface::cell_polygon(host, piece.cell);
                        cell_extent_along(&poly, piece.b - piece.a).unwrap_or_else(|| crate::surface::cell_size(&poly))
                    }
                },
            }
        })
        .collect()
}

/// Width of a cell's polygon projected on direction `d` (`None` for a degenerate `d`).
fn cell_extent_along(poly: &[Point2<f64>], d: nalgebra::Vector2<f64>) -> Option<f64> {
    let n = d.norm();
    if n <= 0.0 || !n.is_finite() {
        return None;
    }
    let t = d / n;
    let (lo, hi) = poly
        .iter()
        .map(|p| p.coords.dot(&t))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| (lo.min(s), hi.max(s)));
    Some(hi - lo)
}

/// Distance from `p` to the segment `a b`.
fn nrm_dist_segment(a: Point2<f64>, b: Point2<f64>, p: Point2<f64>) -> f64 {
    let d = b - a;
    let t = ((p - a).dot(&d) / d.norm_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    (a + d * t - p).norm()
}

/// Straight segments by their end points.
type Segments = Vec<(Point2<f64>, Point2<f64>)>;

/// The non-mortar side of an interface: straight segments whose points interpolate
/// displacements from either a host cell (virtual surface) or a real edge.
pub enum OtherSide<'a> {
    /// Virtual surface pieces inside host cells (`host_offset` maps host node ids to global).
    /// `coords`: where the host's nodes are (its own nodes in the reference configuration).
    Embedded { host: &'a Mesh2, coords: &'a [Point2<f64>], host_offset: usize, embedding: &'a Embedding },
    /// Real mesh edges: global node ids and their end coordinates.
    Edges { nodes: &'a [[usize; 2]], points: &'a [[Point2<f64>; 2]] },
}

impl OtherSide<'_> {
    /// The segments and a BVH over their bounding boxes (for pairing queries).
    fn indexed_segments(&self) -> (Segments, BoxIndex) {
        let segs = self.segments();
        let boxes: Vec<_> = segs
            .iter()
            .map(|(a, b)| (Point2::new(a.x.min(b.x), a.y.min(b.y)), Point2::new(a.x.max(b.x), a.y.max(b.y))))
            .collect();
        let index = BoxIndex::new(&boxes);
        (segs, index)
    }

    fn segments(&self) -> Segments {
        match self {
            OtherSide::Embedded { embedding, .. } => embedding.pieces.iter().map(|p| (p.a, p.b)).collect(),
            OtherSide::Edges { points, .. } => points.iter().map(|p| (p[0], p[1])).collect(),
        }
    }

    /// Global nodes and shape values at point `x` (parameter `sigma` along segment `i`).
    fn shape_at(&self, i: usize, x: Point2<f64>, sigma: f64, out: &mut Vec<(usize, f64)>) {
        out.clear();
        match self {
            OtherSide::Embedded { host, coords, host_offset, embedding } => {
                let p = &embedding.pieces[i];
                let mapped = MappedElement::new(host.cells[p.cell].kind, cell_coords_at(host, coords, p.cell));
                let xi = mapped.inverse_map(x).unwrap_or(p.xi_a);
                let mut nh = [0.0; 4];
                host.cells[p.cell].kind.shape(xi, &mut nh);
                for (q, &hn) in host.cells[p.cell].nodes().iter().enumerate() {
                    out.push((hn + host_offset, nh[q]));
                }
            }
            OtherSide::Edges { nodes, .. } => {
                out.push((nodes[i][0], 1.0 - sigma));
                out.push((nodes[i][1], sigma));
            }
        }
    }
}

/// Corner coordinates of cell `c` of `host` with its nodes at `coords` (unused slots of a
/// `Tri3` zero, as [`Mesh2::cell_coords`]).
pub fn cell_coords_at(host: &Mesh2, coords: &[Point2<f64>], c: usize) -> [Point2<f64>; 4] {
    let mut x = [Point2::origin(); 4];
    for (k, &n) in host.cells[c].nodes().iter().enumerate() {
        x[k] = coords[n];
    }
    x
}

/// One quadrature point of a mortar segment paired with an other-side segment.
struct MortarPoint {
    /// Mortar vertices of the segment and the point's parameter on it.
    va: usize,
    vb: usize,
    tau: f64,
    /// Quadrature weight (mortar-side measure).
    wt: f64,
    /// Pairing direction: the averaged normal of the two segments, pointing out of the mortar
    /// body (the mortar segment's outward normal when the segments are parallel).
    n: Vector2<f64>,
    /// The point on the mortar side and its partner on the other side.
    xm: Point2<f64>,
    xo: Point2<f64>,
    /// Other-side segment and parameter on it.
    other: usize,
    sigma: f64,
    /// Multiplier hats at the point: (global multiplier node, value).
    hats: [(usize, f64); 2],
}

/// Segment-to-segment pairing shared by tying and contact: every other-side segment found by
/// the BVH within `reach` of a mortar segment and accepted by `accept(pa, pb, a, b)` is projected
/// onto it along the pair's averaged normal `(n - n_other) / |n - n_other|` (orthogonally when the
/// segments are parallel, as in tying); the overlap is integrated with 4 Gauss points and `f` is
/// called at each. Between curved surfaces the averaged normal is the direction in which the
/// initial gap closes (exactly for a symmetric pair, and for elastically similar bodies the
/// interface normal): pairing along the mortar normal alone would pair points that never meet
/// and read the closing of the gap as tangential slip.
fn for_each_mortar_point(
    side: &MortarSide,
    lm: &Multipliers,
    other: &OtherSide,
    reach: f64,
    accept: impl Fn(Point2<f64>, Point2<f64>, Point2<f64>, Point2<f64>) -> bool,
    rows: Option<&[bool]>,
    mut f: impl FnMut(&MortarPoint),
) {
    let (segs, index) = other.indexed_segments();
    let (gx, gw) = gauss_legendre(4);
    let mut cand = Vec::new();
    for ch in &lm.chains {
        let mut hint = 0;
        for k in 0..ch.vertices.len() - 1 {
            let (va, vb) = (ch.vertices[k], ch.vertices[k + 1]);
            let (a, b) = (side.points[va], side.points[vb]);
            let d = b - a;
            let len = d.norm();
            // Only the segments some asked-for row's hat covers: the multiplier nodes around
            // the hats' parameter at both ends of the segment (its points take theirs from
            // `arc[k] + tau len`, between the two).
            if let Some(rows) = rows {
                let [(a0, _), (a1, _)] = ch.hats_from(ch.arc[k], &mut hint);
                let [(b0, _), (b1, _)] = ch.hats_from(ch.arc[k] + len, &mut hint);
                if ![a0, a1, b0, b1].iter().any(|&l| rows[ch.first_lm + l]) {
                    continue;
                }
            }
            let r = reach.max(1e-6 * len);
            let n = right_normal(a, b);
            // Tree nodes whose boxes lie beside the segment are skipped whole (their segments
            // would all be dropped below): the reach gathers hundreds on fine meshes.
            index.query_where(
                Point2::new(a.x.min(b.x) - r, a.y.min(b.y) - r),
                Point2::new(a.x.max(b.x) + r, a.y.max(b.y) + r),
                |lo, hi| !box_beside(a, d, len, n, lo, hi),
                &mut cand,
            );
            for &pi in &cand {
                let (pa, pb) = segs[pi];
                if beside(a, d, len, n, pa, pb) || !accept(pa, pb, a, b) {
                    continue;
                }
                let n_other = right_normal(pa, pb);
                let q = (n - n_other).try_normalize(1e-12).unwrap_or(n);
                let cross = |u: Vector2<f64>, v: Vector2<f64>| u.x * v.y - u.y * v.x;
                // Parameter on the mortar segment of a point projected along q.
                let dq = cross(d, q);
                let q = if dq.abs() < 0.5 * len { n } else { q };
                let dq = cross(d, q);
                let ta = cross(pa - a, q) / dq;
                let tb = cross(pb - a, q) / dq;
                if (tb - ta).abs() < 1e-14 {
                    continue;
                }
                let lo = ta.min(tb).max(0.0);
                let hi = ta.max(tb).min(1.0);
                if hi - lo <= 1e-12 {
                    continue;
                }
                for (x, w) in gx.iter().zip(&gw) {
                    let tau = lo + 0.5 * (x + 1.0) * (hi - lo);
                    let sigma = (tau - ta) / (tb - ta);
                    let local = ch.hats_from(ch.arc[k] + tau * len, &mut hint);
                    f(&MortarPoint {
                        va,
                        vb,
                        tau,
                        wt: 0.5 * w * (hi - lo) * len,
                        n: q,
                        xm: a + d * tau,
                        xo: pa + (pb - pa) * sigma,
                        other: pi,
                        sigma,
                        hats: [(ch.first_lm + local[0].0, local[0].1), (ch.first_lm + local[1].0, local[1].1)],
                    });
                }
            }
        }
    }
}

/// Whether the other-side segment `pa pb` certainly projects outside the mortar segment
/// `a, a + d` (length `len`, unit normal `n`) along any pairing direction
/// [`for_each_mortar_point`] may take: a cheap test before the projection, since the pairing
/// reach gathers dozens of candidates per segment. A point `p = a + s d + e len n` projects
/// along a direction `q` at an angle `phi` to `n` to the parameter `s + e tan phi`, and
/// `cos phi >= 1/2` there (else `q = n`), so `tan phi < 2`; with a margin far above round-off,
/// both ends beyond the same end of `[0, 1]` leave no overlap.
fn beside(a: Point2<f64>, d: Vector2<f64>, len: f64, n: Vector2<f64>, pa: Point2<f64>, pb: Point2<f64>) -> bool {
    let ((lo_a, hi_a), (lo_b, hi_b)) =
        (projection_range(a, d, len, n, pa, 1e-9), projection_range(a, d, len, n, pb, 1e-9));
    hi_a.max(hi_b) < 0.0 || lo_a.min(lo_b) > 1.0
}

/// The parameters on the mortar segment `a, a + d` that point `p` may project to (see
/// [`beside`]), widened by `margin`.
fn projection_range(
    a: Point2<f64>,
    d: Vector2<f64>,
    len: f64,
    n: Vector2<f64>,
    p: Point2<f64>,
    margin: f64,
) -> (f64, f64) {
    let r = p - a;
    let (s, e) = (r.dot(&d) / (len * len), 2.0 * r.dot(&n).abs() / len);
    (s - e - margin, s + e + margin)
}

/// [`beside`] for every segment inside the box `[lo, hi]`: the lower end of a point's range is
/// concave in the point and the upper end convex, so their extremes over the box are at its
/// corners (a wider margin than [`beside`]'s covers the round-off between corner and point).
fn box_beside(a: Point2<f64>, d: Vector2<f64>, len: f64, n: Vector2<f64>, lo: Point2<f64>, hi: Point2<f64>) -> bool {
    let corners = [lo, Point2::new(hi.x, lo.y), hi, Point2::new(lo.x, hi.y)];
    let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
    for c in corners {
        let (l, h) = projection_range(a, d, len, n, c, 2e-9);
        low = low.min(l);
        high = high.max(h);
    }
    high < 0.0 || low > 1.0
}

/// Assembles the tying rows (two per multiplier node, x then y): segment-to-segment mortar
/// between the mortar side and the other side, which must coincide geometrically (tying).
pub fn tying_rows(side: &MortarSide, lm: &Multipliers, other: &OtherSide) -> Vec<ConstraintRow> {
    let mut rows: Vec<BTreeMap<usize, f64>> = vec![BTreeMap::new(); 2 * lm.num_nodes];
    let mut shape = Vec::new();
    let n = side.points.len();
    // Only segments lying on the mortar segment (snapped pieces may sit 1e-6 off it).
    let on_segment = |pa: Point2<f64>, pb: Point2<f64>, a: Point2<f64>, b: Point2<f64>| {
        let d = b - a;
        nrm_dist(a, d, pa).max(nrm_dist(a, d, pb)) <= 1e-6 * d.norm()
    };
    for_each_mortar_point(side, lm, other, 0.0, on_segment, None, |p| {
        other.shape_at(p.other, p.xo, p.sigma, &mut shape);
        let nm = [1.0 - p.tau, p.tau];
        for (l, phi) in p.hats {
            if phi == 0.0 {
                continue;
            }
            for c in 0..2 {
                let row = &mut rows[2 * l + c];
                for (q, &v) in [p.va, p.vb].iter().enumerate() {
                    *row.entry(2 * side.nodes[v % n] + c).or_insert(0.0) += p.wt * phi * nm[q];
                }
                for &(node, nv) in shape.iter() {
                    *row.entry(2 * node + c).or_insert(0.0) -= p.wt * phi * nv;
                }
            }
        }
    });
    rows.into_iter().map(|r| r.into_iter().filter(|(_, v)| *v != 0.0).collect()).collect()
}

/// The mortar integrals of one contact multiplier node `l` (small sliding, reference geometry).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactRow {
    /// `g_l = int Phi_l (x_other - x_mortar) . n dS = g0 + normal . u`.
    pub normal: ConstraintRow,
    pub g0: f64,
    /// `s_l = int Phi_l (x_other - x_mortar) . t dS = s0 + tangent . u`, `t` the averaged normal
    /// `(n - n_other) / |n - n_other|` turned +90 deg;
    /// only its increments matter (the Coulomb slip increment of a step).
    pub tangent: ConstraintRow,
    /// `int Phi_l dS` over the paired part of the hat (0: the node sees no other side).
    pub phi: f64,
}

/// Weighted normal gaps and tangential relative displacements for contact (small sliding): per
/// multiplier node `l`, `g_l = int Phi_l (x_other - x_mortar) . n dS`, with `n` the outward
/// normal of the mortar body on each mortar segment (right normal, the body being on the left)
/// and `t` the averaged interface normal turned +90 degrees (see below). Other-side segments are paired by orthogonal projection onto the
/// mortar segment; only those facing it (normals opposed) and within `max_gap` of it (either
/// side: penetration counts) contribute.
pub fn weighted_gaps(side: &MortarSide, lm: &Multipliers, other: &OtherSide, max_gap: f64) -> Vec<ContactRow> {
    // Each row's contributions in the order they come, summed per DOF at the end in that order
    // (what a map accumulating them would give, bit for bit, without its per-entry search).
    let mut normal: Vec<Vec<(usize, f64)>> = vec![Vec::new(); lm.num_nodes];
    let mut tangent: Vec<Vec<(usize, f64)>> = vec![Vec::new(); lm.num_nodes];
    let mut g0 = vec![0.0; lm.num_nodes];
    let mut phi_int = vec![0.0; lm.num_nodes];
    let mut shape = Vec::new();
    let n_pts = side.points.len();
    for_each_mortar_point(side, lm, other, max_gap, facing_for_contact, None, |p| {
        let gap = (p.xo - p.xm).dot(&p.n);
        if gap.abs() > max_gap {
            return;
        }
        // Tangent of the interface: the pairing direction (averaged normal) turned +90 deg.
        let t = Vector2::new(-p.n.y, p.n.x);
        other.shape_at(p.other, p.xo, p.sigma, &mut shape);
        let nm = [1.0 - p.tau, p.tau];
        for (l, phi) in p.hats {
            if phi == 0.0 {
                continue;
            }
            g0[l] += p.wt * phi * gap;
            phi_int[l] += p.wt * phi;
            for (rows, dir) in [(&mut normal[l], p.n), (&mut tangent[l], t)] {
                for c in 0..2 {
                    for (q, &v) in [p.va, p.vb].iter().enumerate() {
                        rows.push((2 * side.nodes[v % n_pts] + c, -(p.wt * phi * nm[q] * dir[c])));
                    }
                    for &(node, nv) in shape.iter() {
                        rows.push((2 * node + c, p.wt * phi * nv * dir[c]));
                    }
                }
            }
        }
    });
    let mut slot = Vec::new();
    let mut clean = |r: &[(usize, f64)]| -> ConstraintRow {
        summed_by_dof(r, &mut slot).into_iter().filter(|(_, v)| *v != 0.0).collect()
    };
    let mut out = Vec::with_capacity(lm.num_nodes);
    for ((n, t), (g0, phi)) in normal.iter().zip(&tangent).zip(g0.into_iter().zip(phi_int)) {
        out.push(ContactRow { normal: clean(n), g0, tangent: clean(t), phi });
    }
    out
}

/// Contributions `(dof, value)` summed per DOF, in increasing DOF order; each DOF's sum starts
/// at 0 and adds its contributions in the order given (what a map accumulating them gives, bit
/// for bit). `slot` is scratch over the DOFs (`usize::MAX` where free; left so).
pub(crate) fn summed_by_dof(entries: &[(usize, f64)], slot: &mut Vec<usize>) -> Vec<(usize, f64)> {
    let mut out: Vec<(usize, f64)> = Vec::new();
    for &(d, v) in entries {
        if d >= slot.len() {
            slot.resize(d + 1, usize::MAX);
        }
        match slot[d] {
            // From 0 as a map's new entry (a lone -0.0 reads 0.0 there too).
            usize::MAX => {
                slot[d] = out.len();
                out.push((d, 0.0 + v));
            }
            i => out[i].1 += v,
        }
    }
    for &(d, _) in &out {
        slot[d] = usize::MAX;
    }
    out.sort_unstable_by_key(|e| e.0);
    out
}

/// One mortar integration point of a contact pair, as wear reads it: weight (mortar-side
/// measure), multiplier hats, and the partner point on the other side (segment and parameter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairedPoint {
    /// Mortar-side segment (its vertices), the parameter on it and its length where paired.
    pub va: usize,
    pub vb: usize,
    pub tau: f64,
    pub segment_length: f64,
    pub wt: f64,
    pub hats: [(usize, f64); 2],
    pub xm: Point2<f64>,
    pub xo: Point2<f64>,
    pub other: usize,
    pub sigma: f64,
}

/// The integration points [`weighted_gaps`] integrates over (same pairing, same filter), so
/// that `sum wt * Phi_l` over them is the row's `phi`. `rows`: only on the segments where a row
/// with `rows[l]` has its hat (those rows' points all, in the same order; `None`: every row).
pub fn paired_points(
    side: &MortarSide,
    lm: &Multipliers,
    other: &OtherSide,
    max_gap: f64,
    rows: Option<&[bool]>,
) -> Vec<PairedPoint> {
    let mut v = Vec::new();
    let n = side.points.len();
    for_each_mortar_point(side, lm, other, max_gap, facing_for_contact, rows, |p| {
        if (p.xo - p.xm).dot(&p.n).abs() > max_gap {
            return;
        }
        let segment_length = (side.points[p.vb % n] - side.points[p.va % n]).norm();
        v.push(PairedPoint {
            va: p.va,
            vb: p.vb,
            tau: p.tau,
            segment_length,
            wt: p.wt,
            hats: p.hats,
            xm: p.xm,
            xo: p.xo,
            other: p.other,
            sigma: p.sigma,
        });
    });
    v
}

fn nrm_dist(a: Point2<f64>, d: Vector2<f64>, p: Point2<f64>) -> f64 {
    let len = d.norm();
    ((p - a).x * d.y - (p - a).y * d.x).abs() / len
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The hinted interval search gives the bisection's hats bit for bit, from any hint and
        /// for arc lengths in any order (a graded open chain, coarse-grained multipliers: several
        /// segments per interval; points beyond both ends).
        #[test]
        fn hats_from_any_hint_are_the_bisections(
            grading in 1.0f64..3.0,
            coarse in 1.0f64..4.0,
            s in proptest::collection::vec(-0.2f64..1.2, 1..40),
            hint in 0usize..40,
        ) {
            let n = 24;
            let xs: Vec<f64> = (0..n).map(|i| (i as f64 / (n - 1) as f64).powf(grading)).collect();
            let side = MortarSide { nodes: (0..n).collect(), points: xs.iter().map(|&x| Point2::new(x, 0.0)).collect(), closed: false };
            let lm = build_multipliers(&side, MultiplierSpace::CoarseGrained, coarse / n as f64);
            let ch = &lm.chains[0];
            let total = ch.arc[ch.arc.len() - 1];
            let mut h = hint;
            for &f in &s {
                let (a, b) = (ch.hats(f * total), ch.hats_from(f * total, &mut h));
                prop_assert_eq!((a[0].0, a[1].0), (b[0].0, b[1].0));
                prop_assert_eq!((a[0].1.to_bits(), a[1].1.to_bits()), (b[0].1.to_bits(), b[1].1.to_bits()));
            }
        }
    }

    /// Mortar side: the top of a lower body along y = 0, x in [0, 4] (5 nodes, ids 0..4, body
    /// below so the polyline runs right-to-left). Other side: the bottom of an upper body along
    /// `y = d + s x` (3 edges, non-matching, ids 10..13, running left-to-right).
    fn scene(d: f64, slope: f64, space: MultiplierSpace) -> (Vec<ContactRow>, Multipliers) {
        let xs = [4.0, 3.0, 2.0, 1.0, 0.0];
        let side = MortarSide {
            nodes: (0..5).collect(),
            points: xs.iter().map(|&x| Point2::new(x, 0.0)).collect(),
            closed: false,
        };
        let ox = [-0.5, 1.3, 2.9, 4.5];
        let pts: Vec<[Point2<f64>; 2]> = (0..3)
            .map(|i| [Point2::new(ox[i], d + slope * ox[i]), Point2::new(ox[i + 1], d + slope * ox[i + 1])])
            .collect();
        let nodes: Vec<[usize; 2]> = (0..3).map(|i| [10 + i, 11 + i]).collect();
        let lm = build_multipliers(&side, space, 1.0);
        (weighted_gaps(&side, &lm, &OtherSide::Edges { nodes: &nodes, points: &pts }, 1.0), lm)
    }

    /// The nodal traction of a linear field is the field at the nodes whose hats are whole
    /// (the hat average of a linear function), of a constant everywhere (the hats sum to one);
    /// a load on one node spreads a sixth of it per unit length to each neighbour
    /// (`M_ij / int Phi_i`) and to no other node.
    /// Round-off only.
    #[test]
    fn nodal_traction_averages_the_field_over_each_hat() {
        let side = MortarSide {
            nodes: (0..9).collect(),
            points: (0..9).map(|i| Point2::new(8.0 - i as f64, 0.0)).collect(),
            closed: false,
        };
        let lm = build_multipliers(&side, MultiplierSpace::Classical, 1.0);
        let n = lm.num_nodes;
        let arc: Vec<f64> = lm.chains[0].lm_at.iter().map(|&k| lm.chains[0].arc[k]).collect();
        let linear: Vec<f64> = arc.iter().map(|s| 2.0 + 3.0 * s).collect();
        let t = lm.nodal_traction(&linear);
        for i in 2..n - 2 {
            assert!((t[i] - linear[i]).abs() < 1e-13, "node {i}: {} against {}", t[i], linear[i]);
        }
        assert!(lm.nodal_traction(&vec![7.0; n]).iter().all(|&v| (v - 7.0).abs() < 1e-13));
        let mid = n / 2;
        let mut load = vec![0.0; n];
        load[mid] = 6.0;
        let t = lm.nodal_traction(&load);
        assert!((t[mid] - 4.0).abs() < 1e-13 && (t[mid - 1] - 1.0).abs() < 1e-13 && (t[mid + 1] - 1.0).abs() < 1e-13);
        assert!(t.iter().enumerate().all(|(i, v)| i.abs_diff(mid) <= 1 || v.abs() < 1e-13), "{t:?}");
    }

    #[test]
    fn weighted_gaps_integrate_linear_gaps_exactly() {
        for space in [MultiplierSpace::Classical, MultiplierSpace::CoarseGrained] {
            // Hats sum to one over the chain. The gap is measured along the averaged normal
            // q = (n - n_o)/|.|, n = (0, 1), n_o = (s, -1)/sqrt(1 + s^2): from (x, 0) the line
            // y = d + s x is reached after (d + s x) / (q_y - s q_x), so
            // sum_l g0_l = (4 d + 8 s) / (q_y - s q_x).
            for (d, s) in [(0.01, 0.0), (0.02, 0.003), (-0.005, 0.002)] {
                let (rows, _) = scene(d, s, space);
                let total: f64 = rows.iter().map(|r| r.g0).sum();
                let q = (Vector2::new(0.0, 1.0) - Vector2::new(s, -1.0) / (1.0 + s * s).sqrt()).normalize();
                let exact = (4.0 * d + 8.0 * s) / (q.y - s * q.x);
                // Gauss rules exact for linear gaps: round-off only.
                assert!((total - exact).abs() < 1e-14, "{space:?}: sum of weighted gaps {total} vs {exact}");
            }
        }
    }

    #[test]
    fn gap_rows_are_consistent_with_rigid_motions() {
        // Moving the upper body up by delta changes every g_l by delta int Phi_l; a common
        // translation of both bodies changes nothing.
        let (rows, _) = scene(0.01, 0.0, MultiplierSpace::Classical);
        for r in &rows {
            let (row, g0, phi) = (&r.normal, &r.g0, &r.phi);
            assert!((g0 - 0.01 * phi).abs() < 1e-15, "uniform gap: g0 = d int Phi");
            let up_other: f64 = row.iter().filter(|(dof, _)| *dof >= 20 && dof % 2 == 1).map(|(_, c)| c).sum();
            let up_mortar: f64 = row.iter().filter(|(dof, _)| *dof < 20 && dof % 2 == 1).map(|(_, c)| c).sum();
            // int Phi_l = g0_l / d for a uniform gap d.
            assert!((up_other - g0 / 0.01).abs() < 1e-13 && (up_mortar + g0 / 0.01).abs() < 1e-13);
            let sideways: f64 = row.iter().filter(|(dof, _)| dof % 2 == 0).map(|(_, c)| c).sum();
            // Tangent t = n turned +90 deg = (-1, 0): sliding the other body by +delta in x
            // changes s_l by -delta int Phi_l; a vertical move leaves it alone.
            let t_other_x: f64 = r.tangent.iter().filter(|(dof, _)| *dof >= 20 && dof % 2 == 0).map(|(_, c)| c).sum();
            let t_up: f64 = r.tangent.iter().filter(|(dof, _)| dof % 2 == 1).map(|(_, c)| c).sum();
            assert!((t_other_x + phi).abs() < 1e-13 && t_up.abs() < 1e-14, "tangent row {t_other_x} vs {phi}");
            assert!(sideways.abs() < 1e-14, "a tangential translation must not change a normal gap");
        }
    }
}
