//! Fatigue points: material points fixed in a body's host mesh, where the stress-strain
//! history of every computed cycle is read and Miner damage is summed.
//!
//! The points are the Gauss points of the host cells' full (uncut) stiffness rule, in a box
//! the case names (or the whole body). They never move: a worn surface that cuts a cell leaves
//! them where they are, so damage needs no remap. The strain at a point is the small strain of
//! the host cell's displacement interpolation, `eps = sym(sum_a u_a (x) grad N_a)`, with
//! `eps_zz = 0` (plane strain) or `eps_zz = -nu / (1 - nu) (eps_xx + eps_yy)` (plane stress),
//! and the stress Hooke's `sigma = lambda tr(eps) I + 2 G eps` (elastic bodies). A point the worn
//! surface has cut away keeps the strain its cell's held nodes froze at: its cycles carry no
//! range and no more damage.
//!
//! **Damage.** Per computed cycle, the SWT critical plane of each point's history (see
//! [`super::critical_plane`]) gives a life `N_f` (see [`super::StrainLife::life`]), and the
//! computed cycle with the jump after it, `dN` cycles in all, adds `dN / N_f` (Miner's rule,
//! the jumped cycles taken as repeats of the computed one, as the wear jump takes them).

use super::{critical_plane, FatigueError, StrainLife};
use crate::fem::element::{MappedElement, Quad4, ReferenceElement, ShapeEval, Tri3};
use crate::fem::material::{Elastic, PlaneHypothesis, Stress4};
use crate::mesh::{CellKind, Mesh2};
use nalgebra::Point2;
use rayon::prelude::*;

/// Values a point records per instant of a cycle: stress then strain, `[xx, yy, zz, xy]` each.
pub const RECORD: usize = 8;

/// One fatigue point: the global nodes of its host cell and the shape-function gradients there.
#[derive(Debug, Clone, PartialEq)]
pub struct FatiguePoint {
    pub nodes: [usize; 4],
    pub count: usize,
    pub grad: [[f64; 2]; 4],
    pub position: Point2<f64>,
}

/// The fatigue scene of a run: the body whose points are followed, its elasticity, its
/// strain-life constants and the points.
#[derive(Debug, Clone, PartialEq)]
pub struct FatigueModel {
    pub body: String,
    /// The body's index in the model.
    pub body_index: usize,
    pub elastic: Elastic,
    pub life: StrainLife,
    pub points: Vec<FatiguePoint>,
    /// The run ends after the computed cycle in which a point's damage reaches 1.
    pub stop_at_initiation: bool,
}

/// The fatigue of the last computed cycle at every point: SWT value, critical plane angle
/// (radians from `x`), life `N_f` (infinite below the endurance limit).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CycleFatigue {
    pub swt: Vec<f64>,
    pub angle: Vec<f64>,
    pub life: Vec<f64>,
}

/// What a run carries for fatigue (part of the state and its checkpoints): the history of the
/// computed cycle so far ([`RECORD`] values per point and recorded instant), the Miner damage
/// of every point, and the last computed cycle's planes and lives.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FatigueState {
    pub history: Vec<f64>,
    pub damage: Vec<f64>,
    pub last: CycleFatigue,
    /// Points a worn surface has cut away: their damage is kept and reported, no more added.
    pub retired: Vec<bool>,
    /// The first point whose damage reached 1, when (see [`Initiation`]).
    pub initiation: Option<Initiation>,
}

/// Crack initiation: the first point whose Miner damage reached 1, at `cycle` (interpolated
/// within the computed cycle and its jump at the cycle's damage rate), on the plane at `angle`
/// (radians from x), `depth` below the worn surface then (its distance to the nearest worn
/// polyline; the distance to the nearest one when the body has none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Initiation {
    pub cycle: f64,
    pub point: usize,
    pub angle: f64,
    pub depth: f64,
}

impl FatigueModel {
    /// The Gauss points of the cells of `mesh` (global node ids from `node_offset`) whose
    /// points fall in the box `region` (`[min, max]`; `None`: every cell).
    pub fn new(
        body: &str,
        mesh: &Mesh2,
        node_offset: usize,
        elastic: Elastic,
        life: StrainLife,
        region: Option<[Point2<f64>; 2]>,
    ) -> Result<Self, FatigueError> {
        life.life(0.0)?;
        let inside = |x: &Point2<f64>| {
            region.is_none_or(|[lo, hi]| (lo.x..=hi.x).contains(&x.x) && (lo.y..=hi.y).contains(&x.y))
        };
        let mut points = vec![];
        let mut eval = ShapeEval::default();
        for cell in &mesh.cells {
            let conn = cell.nodes();
            let mut coords = [Point2::origin(); 4];
            let mut nodes = [0; 4];
            for (k, &n) in conn.iter().enumerate() {
                coords[k] = mesh.nodes[n];
                nodes[k] = n + node_offset;
            }
            let rule = match cell.kind {
                CellKind::Tri3 => Tri3.stiffness_rule(),
                CellKind::Quad4 => Quad4.stiffness_rule(),
            };
            for &xi in &rule.points {
                match cell.kind {
                    CellKind::Tri3 => MappedElement::new(Tri3, coords).eval(xi, &mut eval),
                    CellKind::Quad4 => MappedElement::new(Quad4, coords).eval(xi, &mut eval),
                }
                if inside(&eval.x) {
                    points.push(FatiguePoint { nodes, count: conn.len(), grad: eval.grad, position: eval.x });
                }
            }
        }
        if points.is_empty() {
            return Err(FatigueError::NoPoints { body: body.to_string() });
        }
        Ok(FatigueModel { body: body.to_string(), body_index: 0, elastic, life, points, stop_at_initiation: false })
    }

    /// Stress and strain at point `p` for the displacements `u` (all DOFs of the model).
    pub fn stress_strain(&self, u: &[f64], p: usize) -> (Stress4, Stress4) {
        let fp = &self.points[p];
        let (mut exx, mut eyy, mut exy) = (0.0, 0.0, 0.0);
        for k in 0..fp.count {
            let (ux, uy) = (u[2 * fp.nodes[k]], u[2 * fp.nodes[k] + 1]);
            let [gx, gy] = fp.grad[k];
            exx += ux * gx;
            eyy += uy * gy;
            exy += 0.5 * (ux * gy + uy * gx);
        }
        let Elastic { young, poisson: nu, hypothesis } = self.elastic;
        let ezz = match hypothesis {
            PlaneHypothesis::PlaneStrain => 0.0,
            PlaneHypothesis::PlaneStress => -nu / (1.0 - nu) * (exx + eyy),
        };
        let g = young / (2.0 * (1.0 + nu));
        let lambda = young * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let tr = exx + eyy + ezz;
        let stress = Stress4::new(
            lambda * tr + 2.0 * g * exx,
            lambda * tr + 2.0 * g * eyy,
            lambda * tr + 2.0 * g * ezz,
            2.0 * g * exy,
        );
        (stress, Stress4::new(exx, eyy, ezz, exy))
    }

    /// Appends the stress and strain of every point at `u` to a cycle's history ([`RECORD`]
    /// values per point, points in order).
    pub fn record(&self, u: &[f64], history: &mut Vec<f64>) {
        for p in 0..self.points.len() {
            let (s, e) = self.stress_strain(u, p);
            history.extend(s.iter().chain(e.iter()));
        }
    }

    /// The critical plane and life of every point over a cycle's `history` (instants recorded
    /// by [`Self::record`]), and Miner's `dn / N_f` added to `damage`.
    /// A point whose damage crosses 1 records the [`Initiation`] (the earliest crossing, cycles
    /// counted from `cycles_before`, the cycles done before this computed cycle), its depth
    /// left at 0 for the caller, who knows the worn surfaces.
    pub fn cycle_damage(
        &self,
        history: &[f64],
        cycles_before: f64,
        dn: f64,
        state: &mut FatigueState,
    ) -> Result<CycleFatigue, FatigueError> {
        let np = self.points.len();
        let instants = history.len() / (RECORD * np).max(1);
        if instants == 0 || history.len() != instants * RECORD * np {
            return Err(FatigueError::History { stress: history.len(), strain: RECORD * np });
        }
        let planes: Vec<Result<(f64, f64, f64), FatigueError>> = (0..np)
            .into_par_iter()
            .map(|p| {
                let at = |k: usize, o: usize| {
                    let b = (k * np + p) * RECORD + o;
                    Stress4::new(history[b], history[b + 1], history[b + 2], history[b + 3])
                };
                let stress: Vec<Stress4> = (0..instants).map(|k| at(k, 0)).collect();
                let strain: Vec<Stress4> = (0..instants).map(|k| at(k, 4)).collect();
                let cp = critical_plane(&stress, &strain)?;
                // A plane that never opens (largest normal stress <= 0) takes no SWT damage.
                let swt = cp.swt.max(0.0);
                Ok((swt, cp.angle, self.life.life(swt)?))
            })
            .collect();
        state.damage.resize(np, 0.0);
        state.retired.resize(np, false);
        let mut out = CycleFatigue::default();
        for (p, r) in planes.into_iter().enumerate() {
            let (swt, angle, life) = r?;
            if !state.retired[p] {
                let before = state.damage[p];
                state.damage[p] += dn / life;
                if before < 1.0 && state.damage[p] >= 1.0 {
                    let cycle = cycles_before + (1.0 - before) * life;
                    let first = state.initiation.is_none_or(|i| cycle < i.cycle);
                    if first {
                        state.initiation = Some(Initiation { cycle, point: p, angle, depth: 0.0 });
                    }
                }
            }
            out.swt.push(swt);
            out.angle.push(angle);
            out.life.push(life);
        }
        Ok(out)
    }

    /// Retires the points on the removed side of the worn `polylines` (current vertices,
    /// material on their left, see [`crate::cut`]) of this body's wearing surfaces; returns how
    /// many it retired. A point's side is that of its nearest point on a polyline (at a vertex:
    /// the mean of both segments' normals, so a point below a groove's corner reads right).
    pub fn retire_cut_away(&self, polylines: &[&[[f64; 2]]], retired: &mut Vec<bool>) -> usize {
        retired.resize(self.points.len(), false);
        self.points
            .par_iter()
            .zip(retired.par_iter_mut())
            .filter(|(_, r)| !**r)
            .map(|(fp, r)| {
                *r = polylines.iter().any(|line| on_removed_side(line, fp.position));
                usize::from(*r)
            })
            .sum()
    }
}

/// The point of the polyline `line` nearest to `x`: its distance and the left normal there
/// (at an inner vertex, the mean of both segments' normals, so a point below a groove's corner
/// reads right).
fn nearest_on_polyline(line: &[[f64; 2]], x: Point2<f64>) -> Option<(f64, nalgebra::Vector2<f64>, Point2<f64>)> {
    let pt = |v: [f64; 2]| Point2::new(v[0], v[1]);
    let left_normal = |a: Point2<f64>, b: Point2<f64>| {
        let d = b - a;
        nalgebra::Vector2::new(-d.y, d.x).normalize()
    };
    let mut best: Option<(f64, nalgebra::Vector2<f64>, Point2<f64>)> = None;
    for (i, w) in line.windows(2).enumerate() {
        let (a, b) = (pt(w[0]), pt(w[1]));
        let d = b - a;
        let len2 = d.norm_squared();
        if len2 == 0.0 {
            continue;
        }
        let t = ((x - a).dot(&d) / len2).clamp(0.0, 1.0);
        let q = a + t * d;
        let dist = (x - q).norm();
        let mut n = left_normal(a, b);
        if t == 0.0 && i > 0 {
            n = (n + left_normal(pt(line[i - 1]), a)).normalize();
        } else if t == 1.0 && i + 2 < line.len() {
            n = (n + left_normal(b, pt(line[i + 2]))).normalize();
        }
        if best.is_none_or(|(bd, _, _)| dist < bd) {
            best = Some((dist, n, q));
        }
    }
    best
}

/// Whether `x` lies right of the polyline `line` (material on its left), judged at the
/// polyline's point nearest to `x`.
fn on_removed_side(line: &[[f64; 2]], x: Point2<f64>) -> bool {
    nearest_on_polyline(line, x).is_some_and(|(_, n, q)| (x - q).dot(&n) < 0.0)
}

impl FatigueModel {
    /// The end of a computed cycle: its damage, and the jump's (`jump` cycles of it, the run at
    /// `cycles_done` after it; less than one where the pass applied part of a cycle's wear, see
    /// [`crate::wear::fractional_update`]), added to every point; the first initiation located below the
    /// `worn` surfaces of the body; the points those surfaces passed retired (after the jump's
    /// damage: a point passed within the jump is counted through it). The cycle's history is
    /// consumed.
    pub fn close_cycle(
        &self,
        state: &mut FatigueState,
        cycles_done: f64,
        jump: f64,
        worn: &[&[[f64; 2]]],
    ) -> Result<(), FatigueError> {
        let history = std::mem::take(&mut state.history);
        let initiated = state.initiation.is_some();
        state.last = self.cycle_damage(&history, (cycles_done - jump).max(0.0), jump, state)?;
        if let Some(first) = state.initiation.as_mut().filter(|_| !initiated) {
            let x = self.points[first.point].position;
            first.depth = distance_to_polylines(worn, x);
            tracing::info!(
                cycle = first.cycle,
                x = x.x,
                y = x.y,
                depth = first.depth,
                "fatigue: crack initiation (D = 1)"
            );
        }
        self.retire_cut_away(worn, &mut state.retired);
        Ok(())
    }
}

/// Distance from `x` to the nearest of the `polylines` (infinite without any).
pub fn distance_to_polylines(polylines: &[&[[f64; 2]]], x: Point2<f64>) -> f64 {
    polylines.iter().filter_map(|l| nearest_on_polyline(l, x)).map(|(d, _, _)| d).fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    const LIFE: StrainLife = StrainLife { young: 1.0, sigma_f: 1000.0, b: -0.1, eps_f: 0.5, c: -0.6 };

    fn model() -> Result<FatigueModel, Box<dyn std::error::Error>> {
        let mesh = generate::rectangle(0.0, 0.0, 4.0, 2.0, 4, 2, 1.0, 1.0, CellKind::Quad4)?;
        let elastic = Elastic { young: 1000.0, poisson: 0.25, hypothesis: PlaneHypothesis::PlaneStrain };
        Ok(FatigueModel::new("block", &mesh, 0, elastic, LIFE, None)?)
    }

    /// A V-groove worn into the top (material on the left of the polyline running right to
    /// left): exactly the Gauss points above it retire, judged at their nearest polyline
    /// point, the groove's bottom vertex included; a second call retires nothing more.
    #[test]
    fn the_points_a_worn_groove_passes_retire() -> Result<(), Box<dyn std::error::Error>> {
        let m = model()?;
        // Top at y = 2 (right to left: the body below is on the left); groove to y = 1.5 at x = 2.
        let line = [[5.0, 2.0], [3.0, 2.0], [2.0, 1.5], [1.0, 2.0], [-1.0, 2.0]];
        let mut retired = vec![];
        let count = m.retire_cut_away(&[&line[..]], &mut retired);
        let groove_y = |x: f64| if (1.0..=3.0).contains(&x) { 1.5 + 0.5 * (x - 2.0).abs() } else { 2.0 };
        let expected: Vec<bool> = m.points.iter().map(|p| p.position.y > groove_y(p.position.x)).collect();
        assert_eq!(retired, expected);
        assert!(count > 0 && count == expected.iter().filter(|&&r| r).count());
        assert_eq!(m.retire_cut_away(&[&line[..]], &mut retired), 0);
        Ok(())
    }

    /// A uniform strain `eps` (displacements `u = eps x`) is read back exactly at every point,
    /// with Hooke's stress (plane strain: `sigma_zz = nu (sigma_xx + sigma_yy)`), to 1e-12.
    #[test]
    fn a_uniform_strain_is_read_back_at_every_point() -> Result<(), Box<dyn std::error::Error>> {
        let m = model()?;
        let mesh = generate::rectangle(0.0, 0.0, 4.0, 2.0, 4, 2, 1.0, 1.0, CellKind::Quad4)?;
        let (exx, eyy, exy) = (1e-3, -4e-4, 2.5e-4);
        let u: Vec<f64> = mesh.nodes.iter().flat_map(|x| [exx * x.x + exy * x.y, exy * x.x + eyy * x.y]).collect();
        let (e, nu) = (1000.0, 0.25);
        let (lambda, g) = (e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu)));
        for p in 0..m.points.len() {
            let (stress, strain) = m.stress_strain(&u, p);
            assert!((strain - Stress4::new(exx, eyy, 0.0, exy)).norm() < 1e-12 * exx);
            let expected = Stress4::new(
                lambda * (exx + eyy) + 2.0 * g * exx,
                lambda * (exx + eyy) + 2.0 * g * eyy,
                lambda * (exx + eyy),
                2.0 * g * exy,
            );
            assert!((stress - expected).norm() < 1e-12 * expected.norm(), "point {p}");
            assert!((stress[2] - nu * (stress[0] + stress[1])).abs() < 1e-12 * expected.norm());
        }
        Ok(())
    }
}
