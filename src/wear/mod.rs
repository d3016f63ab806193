//! Wear: Archard-type laws integrated with the mortar contact quantities, the move of worn
//! virtual surfaces through their host, and the cycle-jump controller.
//!
//! **Laws** (Archard, Proc. R. Soc. A 236 (1956); energy form: Fouvry et al., Wear 255 (2003)
//! 287). Per mortar multiplier node `j` and converged step, with `lambda_n,j = -p_j` the nodal
//! pressure, `lambda_t,j` the nodal shear and `ds_j = T_j . du` the weighted slip increment
//! (`T_j` the pair's tangential row), the weighted wear work is
//! `W_j = p_j |ds_j|` (Archard) or `W_j = |lambda_t,j ds_j|` (energy). With the traction field
//! `p(x) = sum_j p_j Phi_j(x)`, `sum_j W_j = int p |ds|` exactly wherever the slip keeps its sign
//! over a hat's support.
//!
//! **Where the wear goes** (MorteX wear, DESIGN.md sec. 1): the wearing surface is the pair's
//! virtual other side. The work is spread over the pair's mortar integration points as the
//! density `q(x) = sum_j W_j Phi_j(x) / int Phi_j` and collected on the wearing polyline's own
//! vertices through its hat functions `N_i` at the paired point: the wear volume of a step is
//! `V_i = k sum_points wt q N_i(x_other)`, and the nodal depth `w_i = V_i / int N_i`, the
//! integral over the part of the polyline inside its host. Since the hats sum to one,
//! `sum_i V_i = k sum_j W_j`: the worn area balances the wear work exactly, on every body.
//!
//! **Cycles and jumps.** Wear accumulates over the increments of a computed cycle with the
//! surface held; at the cycle's end it is applied `dN` times (the cycle jump, explicit Euler
//! in cycles), the vertices move along their inward vertex normals in the host's reference
//! configuration, and the host is re-cut on its fixed points. For a flat punch on a Winkler
//! foundation the pressure deviation is multiplied by `1 - a dN` per jump (`a = kappa k dS`),
//! so a jump beyond `2 / a` diverges. The adaptive controller ([`next_jump`]) estimates `a`
//! from the change of the wear rates between computed cycles (no stiffness is given to it),
//! keeps `a dN <= 1`, bounds the depth added per jump by a fraction of the surface's
//! resolution, and doubles `dN` at most per jump while the rates are steady.

use crate::contact::{ContactSet, PairedSide};
use crate::discretisation::FreeSurface;
use crate::mesh::Mesh2;
use crate::state::ControllerState;
use nalgebra::{Point2, Vector2};

/// Wear law of a surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WearLaw {
    /// `dw = k p |ds|` (`k` in 1/pressure).
    #[default]
    Archard,
    /// `dw = alpha |q ds|` (dissipated energy; `alpha` in 1/pressure).
    Energy,
}

/// A wearing virtual surface of the model.
#[derive(Debug, Clone, PartialEq)]
pub struct WearingSurface {
    /// The cut's name, its index among the model's free surfaces and the contact pair whose
    /// other side it is.
    pub name: String,
    pub surface: usize,
    pub contact: usize,
    /// The surface is the pair's (virtual) mortar side, not its other side.
    pub on_mortar_side: bool,
    pub coefficient: f64,
    pub law: WearLaw,
    /// Deepest wear the host was prepared for (its band of fixed points).
    pub max_depth: f64,
}

/// How many cycles one computed cycle stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JumpPolicy {
    /// Always `dN` cycles (the last jump shortened to the run's end).
    Fixed(u64),
    /// Adaptive (see the module documentation): depth per jump at most `depth_fraction` of the
    /// surface's smallest segment in contact, `dN <= max_jump`.
    Adaptive { depth_fraction: f64, max_jump: u64 },
}

impl Default for JumpPolicy {
    fn default() -> Self {
        JumpPolicy::Adaptive { depth_fraction: 0.1, max_jump: 1_000_000 }
    }
}

/// The wear part of a model.
#[derive(Debug, Clone, PartialEq)]
pub struct WearModel {
    pub surfaces: Vec<WearingSurface>,
    pub jump: JumpPolicy,
    /// Filter length of the wear-rate smoothing in segments (see [`smooth_rate`]; 0: none).
    pub smoothing: f64,
}

/// Default wear-rate smoothing: one segment.
pub const DEFAULT_SMOOTHING: f64 = 1.0;

impl Default for WearModel {
    fn default() -> Self {
        WearModel { surfaces: vec![], jump: JumpPolicy::default(), smoothing: DEFAULT_SMOOTHING }
    }
}

impl WearModel {
    pub fn is_empty(&self) -> bool {
        self.surfaces.is_empty()
    }
}

/// Wear of one converged step on one wearing surface: per vertex of the polyline the wear
/// volume `V_i` (per unit thickness), and the step's wear work `int p |ds|` (or `int |q ds|`).
/// `u_prev`, `u`: displacements at the start and end of the step; `x` places nodes where the
/// pair is paired for the step: the reference geometry under small sliding (the material
/// points that meet stay paired, as in its mechanics), the configuration halfway through the
/// step under finite sliding (the wear lands on the material that slid under the point).
pub fn step_wear(
    set: &ContactSet,
    hosts: &[(&Mesh2, usize)],
    ws: &WearingSurface,
    surface: &FreeSurface,
    u_prev: &[f64],
    u: &[f64],
    multipliers: &[f64],
    x: &dyn Fn(usize) -> Point2<f64>,
) -> (Vec<f64>, f64) {
    let c = &set.pairs[ws.contact];
    let (nt, nn) = (set.first_multiplier, set.rows.len());
    let n_lm = c.multipliers.num_nodes;
    let mut work = vec![0.0; n_lm];
    for (l, w) in work.iter_mut().enumerate() {
        let k = c.first_row + l;
        if set.phi[k] <= 0.0 {
            continue;
        }
        let ds: f64 = set.tangents[k].iter().map(|&(d, v)| v * (u[d] - u_prev[d])).sum();
        *w = match ws.law {
            WearLaw::Archard => (-multipliers[nt + k]).max(0.0) * ds.abs(),
            WearLaw::Energy => c.friction_row[l].map_or(0.0, |j| (multipliers[nt + nn + j] * ds).abs()),
        };
    }
    let nv = surface.vertices.len();
    let mut volume = vec![0.0; nv];
    if work.iter().all(|&w| w == 0.0) {
        return (volume, 0.0);
    }
    let embedding = match &c.other {
        PairedSide::Embedded { embedding, .. } => Some(embedding),
        PairedSide::Edges(_) => None,
    };
    if !ws.on_mortar_side && embedding.is_none() {
        return (volume, 0.0);
    }
    // Paired where the surfaces meet during the step (the wear lands on the material that is
    // under the point then), weighted by the reference length (small strain).
    let mut points = crate::contact::paired_points(hosts, c, x);
    let ns = c.side.points.len();
    for p in points.iter_mut() {
        let reference = (c.side.points[p.vb % ns] - c.side.points[p.va % ns]).norm();
        if p.segment_length > 0.0 {
            p.wt *= reference / p.segment_length;
        }
    }
    // Normalise the hats by the same points (so the density integrates to sum W exactly).
    let mut phi = vec![0.0; n_lm];
    for p in &points {
        for (l, v) in p.hats {
            phi[l] += p.wt * v;
        }
    }
    let mut total = 0.0;
    for p in &points {
        let q: f64 =
            p.hats.iter().filter(|(l, v)| *v != 0.0 && phi[*l] > 0.0).map(|&(l, v)| work[l] * v / phi[l]).sum();
        if q == 0.0 {
            continue;
        }
        // The point on the wearing surface: the mortar point (side vertices are the polyline's
        // vertices) or its partner on the other side's piece.
        let (a, b, tau) = match embedding {
            Some(e) if !ws.on_mortar_side => {
                let piece = &e.pieces[p.other];
                (piece.segment, (piece.segment + 1) % nv, piece.t0 + p.sigma * (piece.t1 - piece.t0))
            }
            _ => (p.va % nv, p.vb % nv, p.tau),
        };
        let dv = p.wt * q;
        total += dv;
        volume[a] += ws.coefficient * dv * (1.0 - tau);
        volume[b] += ws.coefficient * dv * tau;
    }
    (volume, total)
}

/// `int N_i` of every vertex hat of the surface over its part inside the host.
pub fn vertex_measure(surface: &FreeSurface) -> Vec<f64> {
    let v = &surface.vertices;
    let nv = v.len();
    let mut m = vec![0.0; nv];
    for piece in &surface.embedding.pieces {
        let (a, b) = (piece.segment, (piece.segment + 1) % nv);
        let len = (v[b] - v[a]).norm();
        let (t0, t1) = (piece.t0.min(piece.t1), piece.t0.max(piece.t1));
        let second = 0.5 * (t1 * t1 - t0 * t0);
        m[a] += len * ((t1 - t0) - second);
        m[b] += len * second;
    }
    m
}

/// Inward unit normal at each vertex (average of the adjacent segments' left normals: the
/// material is on the polyline's left).
pub fn vertex_normals(v: &[Point2<f64>], closed: bool) -> Vec<Vector2<f64>> {
    let n = v.len();
    let left = |a: Point2<f64>, b: Point2<f64>| {
        let t = (b - a).normalize();
        Vector2::new(-t.y, t.x)
    };
    (0..n)
        .map(|i| {
            let mut s = Vector2::zeros();
            if i > 0 || closed {
                s += left(v[(i + n - 1) % n], v[i]);
            }
            if i + 1 < n || closed {
                s += left(v[i], v[(i + 1) % n]);
            }
            s.normalize()
        })
        .collect()
}

/// Depth added at each vertex by `dn` cycles of `rate` (depth per cycle); vertices outside the
/// host (`measure == 0`) take the nearest inside vertex's depth so the polyline leaves the host
/// parallel to itself.
pub fn depth_increment(rate: &[f64], measure: &[f64], dn: u64) -> Vec<f64> {
    let n = rate.len();
    let inside: Vec<usize> = (0..n).filter(|&i| measure[i] > 0.0).collect();
    (0..n)
        .map(|i| {
            let j = if measure[i] > 0.0 {
                i
            } else {
                match inside.iter().min_by_key(|&&j| j.abs_diff(i)) {
                    Some(&j) => j,
                    None => return 0.0,
                }
            };
            rate[j] * dn as f64
        })
        .collect()
}

/// Volume-conserving smoothing of a wear rate along an open polyline (a Helmholtz filter):
/// `(M + K_s) r_s = M r` with `M = diag(int N_i)` (the vertices' measures inside the host) and
/// `K_s` the 1D stiffness `(s l)^2 / l` per segment of length `l` (both ends inside the host
/// and wearing: the filter acts within the scar and never spreads wear beyond it),
/// `s` the filter length in units of the local segment length. Constants pass unchanged
/// (`K_s 1 = 0`) and `sum M r_s = sum M r` exactly (`1^T K_s = 0`): the worn area is kept.
/// Modes of wavelength `lambda` are damped by `1 / (1 + (2 pi s l / lambda)^2)`: element-scale
/// roughness (which sets the explicit jump's stability bound through its high contact
/// stiffness, see the module documentation) is removed, a scar many segments wide is not.
/// `s = 0`, or a closed polyline: no smoothing.
pub fn smooth_rate(v: &[Point2<f64>], closed: bool, measure: &[f64], rate: &[f64], s: f64) -> Vec<f64> {
    let n = rate.len();
    if s <= 0.0 || closed || n < 3 {
        return rate.to_vec();
    }
    // Tridiagonal system: lower a, diagonal b, upper c.
    let (mut a, mut b, mut c) = (vec![0.0; n], measure.to_vec(), vec![0.0; n]);
    let mut d: Vec<f64> = measure.iter().zip(rate).map(|(m, r)| m * r).collect();
    // Only between vertices that wear: the filter never spreads wear where there is none (a
    // stick zone, the unworn surface beyond the scar). Round-off rates (a sticking node's slip
    // is zero to about 1e-17) do not count as wear.
    let floor = 1e-12 * rate.iter().fold(0.0_f64, |m, r| m.max(r.abs()));
    let wears = |r: f64| r.abs() > floor;
    for i in 0..n - 1 {
        if measure[i] > 0.0 && measure[i + 1] > 0.0 && wears(rate[i]) && wears(rate[i + 1]) {
            let l = (v[i + 1] - v[i]).norm();
            let k = s * s * l;
            b[i] += k;
            b[i + 1] += k;
            c[i] -= k;
            a[i + 1] -= k;
        }
    }
    // Vertices outside the host keep their (zero) rate.
    for i in 0..n {
        if b[i] == 0.0 {
            b[i] = 1.0;
            d[i] = rate[i];
        }
    }
    // Thomas algorithm (the matrix is diagonally dominant: M + a weighted graph Laplacian).
    for i in 1..n {
        let w = a[i] / b[i - 1];
        b[i] -= w * c[i - 1];
        d[i] -= w * d[i - 1];
    }
    let mut x = vec![0.0; n];
    x[n - 1] = d[n - 1] / b[n - 1];
    for i in (0..n - 1).rev() {
        x[i] = (d[i] - c[i] * x[i + 1]) / b[i];
    }
    x
}

/// The polyline moved inward by `depth` at each vertex (along the vertex normals).
pub fn worn_vertices(v: &[Point2<f64>], closed: bool, depth: &[f64]) -> Vec<Point2<f64>> {
    let normals = vertex_normals(v, closed);
    v.iter().zip(&normals).zip(depth).map(|((p, n), &d)| if d != 0.0 { p + n * d } else { *p }).collect()
}

/// Smallest segment length next to a vertex that wears (`rate > 0`): the surface's resolution
/// where it wears.
pub fn wearing_resolution(v: &[Point2<f64>], rate: &[f64]) -> f64 {
    let mut h = f64::INFINITY;
    for i in 0..v.len().saturating_sub(1) {
        if rate[i] > 0.0 || rate[i + 1] > 0.0 {
            h = h.min((v[i + 1] - v[i]).norm());
        }
    }
    h
}

/// Largest `a * dN` the adaptive controller allows (`1 - a dN >= 0`: the deviation from the
/// steady wear state decays without changing sign; the explicit jump diverges beyond 2).
pub const JUMP_SAFETY: f64 = 1.0;

/// The jump `dN` to apply to a computed cycle whose wear rates (depth per cycle, all wearing
/// surfaces' vertices in one vector) are `rate`; `resolution` is the smallest wearing segment,
/// `remaining` the cycles left. Updates the controller memory `c`.
pub fn next_jump(policy: JumpPolicy, c: &mut ControllerState, rate: &[f64], resolution: f64, remaining: u64) -> u64 {
    let dn = match policy {
        JumpPolicy::Fixed(n) => n,
        JumpPolicy::Adaptive { depth_fraction, max_jump } => {
            let mut dn = if c.last_jump == 0 { 1 } else { c.last_jump.saturating_mul(2) };
            let rmax = rate.iter().fold(0.0_f64, |m, r| m.max(r.abs()));
            if rmax > 0.0 && resolution.is_finite() {
                dn = dn.min(((depth_fraction * resolution / rmax).floor() as u64).max(1));
            }
            if c.last_rate.len() == rate.len() {
                let change: Vec<f64> = rate.iter().zip(&c.last_rate).map(|(r, p)| r - p).collect();
                let norm_r = rate.iter().map(|r| r * r).sum::<f64>().sqrt();
                let cc: f64 = c.last_change.iter().map(|v| v * v).sum();
                if c.last_change.len() == rate.len() && c.jump_before > 0 && cc.sqrt() > 1e-9 * norm_r {
                    // change_n = (J_{n-1} / J_{n-2}) (1 - a J_{n-2}) change_{n-1}
                    let rho = change.iter().zip(&c.last_change).map(|(a, b)| a * b).sum::<f64>() / cc;
                    let (j1, j2) = (c.last_jump as f64, c.jump_before as f64);
                    let a = (1.0 - rho * j2 / j1) / j2;
                    // Follow a larger estimate at once, a smaller one only by halves.
                    c.decay = if a >= c.decay { a } else { (0.5 * c.decay).max(a.max(0.0)) };
                }
                c.last_change = change;
            }
            c.last_rate = rate.to_vec();
            if c.decay > 0.0 {
                dn = dn.min(((JUMP_SAFETY / c.decay).floor() as u64).max(1));
            }
            dn.min(max_jump)
        }
    };
    let dn = dn.min(remaining).max(1);
    c.jump_before = c.last_jump;
    c.last_jump = dn;
    dn
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_normals_point_into_the_material() {
        // Material on the left of a left-to-right line: above it.
        let v = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.0), Point2::new(2.0, 0.0)];
        for n in vertex_normals(&v, false) {
            assert!((n - Vector2::new(0.0, 1.0)).norm() < 1e-15);
        }
    }

    #[test]
    fn fixed_jump_is_shortened_at_the_end() {
        let mut c = ControllerState::default();
        assert_eq!(next_jump(JumpPolicy::Fixed(10), &mut c, &[1.0], 1.0, 4), 4);
    }
}
