//! Derived output fields: nodal stresses recovered from the integration points, von Mises
//! stress, equivalent plastic strain, cell averages. Pure functions of the model and a state.
//!
//! **Nodal recovery.** Each whole cell (every point of its rule carries material, and the rule
//! covers the reference cell) fits its points' values by weighted least squares in the
//! complete bilinear (`Quad4`: `1, xi, eta, xi eta`) or linear (`Tri3`) basis of its reference
//! coordinates and evaluates the fit at its nodes: for the 2 x 2 Gauss rule this is the usual
//! extrapolation of the Gauss values to the nodes, and any field linear in `x, y` is recovered
//! exactly. A node takes the mean of its cells' values weighted by `int N_i dV`. Cut cells
//! (partial integration) and cells whose points do not determine the fit keep the lumped L2
//! projection `sigma_i = int N_i sigma dV / int N_i dV` (extrapolating a part of a cell onto
//! its void side would amplify). At a surface where a stress varies at first order in depth
//! the lumped projection reads the mean over the cells (Nowell-Hills' surface `sigma_xx`: 5.3%
//! from the half-plane solution), the extrapolation reads the surface (3.8%).

use crate::fem::element::{MappedElement, ReferenceElement, ShapeEval};
use crate::fem::material::{von_mises, Stress4};
use crate::fem::quadrature::QuadratureRule;
use crate::mesh::CellKind;
use crate::model::{Discretisation, Model};
use crate::state::SimState;
use nalgebra::Point2;

#[derive(Debug, Clone)]
pub struct NodalFields {
    /// `[s_xx, s_yy, s_zz, s_xy]` per node.
    pub stress: Vec<[f64; 4]>,
    pub von_mises: Vec<f64>,
    pub eqps: Vec<f64>,
    /// Per cell: average stress and equivalent plastic strain.
    pub cell_stress: Vec<[f64; 4]>,
    pub cell_eqps: Vec<f64>,
}

pub fn nodal_fields(model: &Model, disc: &Discretisation, state: &SimState) -> NodalFields {
    let n = model.num_nodes();
    let el = &model.elements;
    let mut wsum = vec![0.0; n];
    // Per node: sum of weight times value, `[s_xx, s_yy, s_zz, s_xy, eqps]`.
    let mut acc = vec![[0.0; 5]; n];
    let mut cell_stress = vec![[0.0; 4]; el.len()];
    let mut cell_eqps = vec![0.0; el.len()];
    let mut ev = ShapeEval::default();
    let mut values: Vec<[f64; 5]> = vec![];
    for e in 0..el.len() {
        let kind = el.kind[e];
        let nn = kind.num_nodes();
        let mut c = [Point2::origin(); 4];
        for k in 0..nn {
            c[k] = model.coords[el.nodes[e][k]];
        }
        let mapped = MappedElement::new(kind, c);
        let rule = &disc.rules[el.rule[e]];
        let stateful = el.state_offset[e + 1] > el.state_offset[e];
        values.clear();
        values.extend((0..rule.len()).map(|q| {
            let sig: Stress4 = state.stress[el.point_offset[e] + q];
            let alpha = if stateful { state.history[el.state_offset[e] + q].alpha } else { 0.0 };
            [sig[0], sig[1], sig[2], sig[3], alpha]
        }));
        let mut vol = 0.0;
        let mut lumped = [[0.0; 5]; 4];
        let mut node_weight = [0.0; 4];
        for (q, (xi, w)) in rule.points.iter().zip(&rule.weights).enumerate() {
            mapped.eval(*xi, &mut ev);
            let dv = w * ev.det_j;
            vol += dv;
            for comp in 0..4 {
                cell_stress[e][comp] += values[q][comp] * dv;
            }
            cell_eqps[e] += values[q][4] * dv;
            for k in 0..nn {
                let wk = ev.n[k] * dv;
                node_weight[k] += wk;
                for comp in 0..5 {
                    lumped[k][comp] += wk * values[q][comp];
                }
            }
        }
        let fitted = whole_cell_fit(kind, rule, &values);
        for k in 0..nn {
            let node = el.nodes[e][k];
            wsum[node] += node_weight[k];
            for comp in 0..5 {
                acc[node][comp] += fitted.map_or(lumped[k][comp], |f| node_weight[k] * f[k][comp]);
            }
        }
        // A void cell (no material, or a band cell whose points all lie in the void) keeps
        // zeros, not 0/0.
        if vol > 0.0 {
            for comp in 0..4 {
                cell_stress[e][comp] /= vol;
            }
            cell_eqps[e] /= vol;
        }
    }
    let mut s = vec![[0.0; 4]; n];
    let mut a = vec![0.0; n];
    for i in 0..n {
        if wsum[i] > 0.0 {
            for comp in 0..4 {
                s[i][comp] = acc[i][comp] / wsum[i];
            }
            a[i] = acc[i][4] / wsum[i];
        }
    }
    let vm = s.iter().map(|x| von_mises(&Stress4::new(x[0], x[1], x[2], x[3]))).collect();
    NodalFields { stress: s, von_mises: vm, eqps: a, cell_stress, cell_eqps }
}

/// The values of a whole cell's points fitted by weighted least squares in the complete
/// polynomial of its reference coordinates (`Quad4`: `1, xi, eta, xi eta`; `Tri3`: `1, xi,
/// eta`) and evaluated at its nodes; `None` for a cut cell (a point without material, or
/// weights that do not cover the reference cell) or points that do not determine the fit
/// (the normal matrix's smallest eigenvalue below 1e-8 of its largest).
fn whole_cell_fit(kind: CellKind, rule: &QuadratureRule, values: &[[f64; 5]]) -> Option<[[f64; 5]; 4]> {
    let (terms, area) = match kind {
        CellKind::Quad4 => (4, 4.0),
        CellKind::Tri3 => (3, 0.5),
    };
    let covered: f64 = rule.weights.iter().sum();
    if rule.len() < terms || rule.weights.iter().any(|&w| w <= 0.0) || (covered - area).abs() > 1e-9 * area {
        return None;
    }
    let basis = |xi: [f64; 2]| -> [f64; 4] { [1.0, xi[0], xi[1], if terms == 4 { xi[0] * xi[1] } else { 0.0 }] };
    let mut normal = nalgebra::Matrix4::<f64>::zeros();
    let mut rhs = nalgebra::SMatrix::<f64, 4, 5>::zeros();
    for (q, (xi, &w)) in rule.points.iter().zip(&rule.weights).enumerate() {
        let phi = basis(*xi);
        for i in 0..terms {
            for j in 0..terms {
                normal[(i, j)] += w * phi[i] * phi[j];
            }
            for comp in 0..5 {
                rhs[(i, comp)] += w * phi[i] * values[q][comp];
            }
        }
    }
    if terms == 3 {
        normal[(3, 3)] = 1.0;
    }
    let eigen = normal.symmetric_eigenvalues();
    let (lo, hi) = (eigen.min(), eigen.max());
    if !(lo > 1e-8 * hi) {
        return None;
    }
    let coefficients = normal.cholesky()?.solve(&rhs);
    let mut at_nodes = [[0.0; 5]; 4];
    for (k, xi) in kind.node_coords().iter().enumerate() {
        let phi = basis(*xi);
        for comp in 0..5 {
            at_nodes[k][comp] = (0..terms).map(|i| phi[i] * coefficients[(i, comp)]).sum();
        }
    }
    Some(at_nodes)
}

/// One multiplier node of a contact pair, in a state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactNode {
    /// Reference position of the node on the mortar surface.
    pub x: Point2<f64>,
    /// Contact pressure `-lambda_n` (>= 0).
    pub pressure: f64,
    /// Shear `lambda_t` along the interface tangent (0 when frictionless).
    pub shear: f64,
    /// 0 open, 1 stick, 2 slip (frictionless nodes: 0).
    pub status: u8,
}

/// The multiplier nodes of contact pair `pair`, sorted by their x coordinate.
pub fn contact_profile(disc: &Discretisation, state: &SimState, pair: usize) -> Vec<ContactNode> {
    let mut v: Vec<ContactNode> = crate::contact::contact_field(&disc.contact, &state.contact_unknowns(), pair)
        .iter()
        .map(|n| ContactNode { x: n.reference, pressure: n.pressure, shear: n.shear, status: n.status.code() })
        .collect();
    v.sort_by(|a, b| a.x.x.total_cmp(&b.x.x));
    v
}

/// Relative L2 error over `[lo, hi]` of the piecewise-linear interpolant of nodal samples
/// `(x, value)` (sorted by x) against `exact`, integrated with 40 midpoint samples per interval
/// (exact contact fields have square-root edges that a node-only rule would misjudge).
pub fn relative_l2_error(samples: &[(f64, f64)], exact: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    const SUB: usize = 40;
    let (mut num, mut den) = (0.0, 0.0);
    for w in samples.windows(2) {
        let (x0, x1) = (w[0].0, w[1].0);
        let dx = (x1 - x0) / SUB as f64;
        for i in 0..SUB {
            let x = x0 + (i as f64 + 0.5) * dx;
            if x < lo || x > hi {
                continue;
            }
            let v = w[0].1 + (w[1].1 - w[0].1) * (x - x0) / (x1 - x0);
            let e = exact(x);
            num += (v - e) * (v - e) * dx;
            den += e * e * dx;
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        num.sqrt()
    }
}

/// An analytical line-contact solution drawn and measured beside a computed profile (Johnson,
/// *Contact Mechanics*, 1985, sec. 4.3 and 7.1): the Hertz pressure
/// `p(x) = p0 sqrt(1 - (x - x0)^2 / a^2)` with `a = sqrt(4 P R / (pi E*))`, `p0 = 2 P / (pi a)`,
/// and under a tangential force `Q < mu P` the Cattaneo-Mindlin shear
/// `q(x) = mu p0 [sqrt(1 - (x - x0)^2 / a^2) - (c / a) sqrt(1 - (x - x0)^2 / c^2)]` with a stick
/// zone `|x - x0 - e| <= c = a sqrt(1 - Q / (mu P))` (the second term inside it only), offset
/// by `e = sign(Q) sigma a / (4 mu p0)` under a bulk stress `sigma` in the lower body in phase
/// with `Q` (Nowell & Hills; Hills & Nowell, *Mechanics of Fretting Fatigue*, 1994, ch. 5),
/// valid while `|e| + c <= a`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalyticContact {
    pub p0: f64,
    pub a: f64,
    pub x0: f64,
    /// Cattaneo-Mindlin: the friction coefficient, the stick zone's half-width and offset.
    pub mu: f64,
    pub c: Option<f64>,
    pub e: f64,
    /// The centre `x0` is the computed contact's (its pressure centroid, found where the
    /// profile is read: profiles are in the current configuration, which a bulk strain moves).
    pub centre_from_profile: bool,
}

impl AnalyticContact {
    /// Hertz line contact under `load` per unit thickness, effective radius `radius`, contact
    /// modulus `e_star`, centred at `x0`.
    pub fn hertz(load: f64, radius: f64, e_star: f64, x0: f64) -> Self {
        let a = (4.0 * load * radius / (std::f64::consts::PI * e_star)).sqrt();
        AnalyticContact {
            p0: 2.0 * load / (std::f64::consts::PI * a),
            a,
            x0,
            mu: 0.0,
            c: None,
            e: 0.0,
            centre_from_profile: false,
        }
    }

    /// The same contact under a tangential force `tangential` (same units as the load
    /// `load`) with friction `mu`; `None` in gross slip (`|Q| >= mu P`: no stick zone).
    pub fn with_tangential(self, load: f64, tangential: f64, mu: f64) -> Option<Self> {
        let ratio = tangential.abs() / (mu * load);
        (mu > 0.0 && ratio < 1.0).then(|| AnalyticContact { mu, c: Some(self.a * (1.0 - ratio).sqrt()), ..self })
    }

    /// The stick zone offset by a bulk stress `bulk` in the lower body in phase with the
    /// tangential force `tangential` (Nowell-Hills); `None` where the offset stick zone would
    /// leave the contact (`|e| + c > a`) or without a stick zone.
    pub fn with_bulk_stress(self, bulk: f64, tangential: f64) -> Option<Self> {
        let c = self.c?;
        let e = tangential.signum() * bulk * self.a / (4.0 * self.mu * self.p0);
        (e.abs() + c <= self.a).then_some(AnalyticContact { e, ..self })
    }

    pub fn pressure(&self, x: f64) -> f64 {
        let s = (x - self.x0) / self.a;
        if s.abs() < 1.0 {
            self.p0 * (1.0 - s * s).sqrt()
        } else {
            0.0
        }
    }

    /// Magnitude of the Cattaneo-Mindlin shear (`None` without a stick zone).
    pub fn shear(&self, x: f64) -> Option<f64> {
        let c = self.c?;
        let s = (x - self.x0 - self.e) / c;
        let stick = if s.abs() < 1.0 { c / self.a * (1.0 - s * s).sqrt() } else { 0.0 };
        Some(self.mu * (self.pressure(x) - self.p0 * stick))
    }
}
