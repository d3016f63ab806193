//! Derived output fields: nodal projection of point stresses (lumped L2 projection,
//! `sigma_i = int N_i sigma dV / int N_i dV`), von Mises stress, equivalent plastic strain,
//! cell averages. Pure functions of the model and a state.

use crate::fem::element::{MappedElement, ShapeEval};
use crate::fem::material::{von_mises, Stress4};
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
    let mut s = vec![[0.0; 4]; n];
    let mut a = vec![0.0; n];
    let mut cell_stress = vec![[0.0; 4]; el.len()];
    let mut cell_eqps = vec![0.0; el.len()];
    let mut ev = ShapeEval::default();
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
        let mut vol = 0.0;
        for (q, (xi, w)) in rule.points.iter().zip(&rule.weights).enumerate() {
            mapped.eval(*xi, &mut ev);
            let dv = w * ev.det_j;
            vol += dv;
            let sig: Stress4 = state.stress[el.point_offset[e] + q];
            let alpha = if stateful { state.history[el.state_offset[e] + q].alpha } else { 0.0 };
            for comp in 0..4 {
                cell_stress[e][comp] += sig[comp] * dv;
            }
            cell_eqps[e] += alpha * dv;
            for k in 0..nn {
                let node = el.nodes[e][k];
                let wk = ev.n[k] * dv;
                wsum[node] += wk;
                for comp in 0..4 {
                    s[node][comp] += wk * sig[comp];
                }
                a[node] += wk * alpha;
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
    for i in 0..n {
        if wsum[i] > 0.0 {
            for comp in 0..4 {
                s[i][comp] /= wsum[i];
            }
            a[i] /= wsum[i];
        }
    }
    let vm = s.iter().map(|x| von_mises(&Stress4::new(x[0], x[1], x[2], x[3]))).collect();
    NodalFields { stress: s, von_mises: vm, eqps: a, cell_stress, cell_eqps }
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
