//! Local element kernel for small-strain 2D solids: internal force `f_e = int B^T sigma dV`
//! and tangent `K_e = int B^T D B dV` (thickness `t` for plane stress, 1 for plane strain).
//!
//! `BBar` is Hughes' mean-dilatation B-bar (Hughes, IJNME 15 (1980) 1413): the volumetric
//! part of the strain is replaced by its element average, `eps_bar = eps + 1/3 m (theta_bar -
//! theta)` with `m = [1, 1, 1, 0]` (so `e_zz = (theta_bar - theta)/3` in plane strain). It removes
//! volumetric locking of `Quad4` for near-incompressible elasticity and isochoric plastic flow,
//! and passes the patch test.

use crate::fem::element::{MappedElement, ShapeEval};
use crate::fem::material::{Material, PlasticState, Strain4, Stress4, Tangent4};
use crate::fem::quadrature::QuadratureRule;
use crate::mesh::CellKind;
use nalgebra::Point2;

/// Strain-displacement formulation of an element.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Formulation {
    Standard,
    BBar,
}

/// What the kernel reads.
pub struct ElementInput<'a> {
    pub kind: CellKind,
    pub coords: [Point2<f64>; 4],
    /// Element displacements `[u_x0, u_y0, u_x1, ...]`.
    pub u: [f64; 8],
    pub rule: &'a QuadratureRule,
    pub formulation: Formulation,
    pub material: &'a Material,
    pub thickness: f64,
    /// Converged history of the element's points (empty for materials without state).
    pub state_old: &'a [PlasticState],
    /// The mapped geometry at each point of the rule, if the caller keeps it (identical to
    /// evaluating `MappedElement::eval` there: the element's geometry does not change between
    /// assemblies of one model, so it is computed once).
    pub geometry: Option<&'a [ShapeEval]>,
    /// The element's stiffness from a pass whose every point stayed elastic, if the caller
    /// keeps it (same geometry, rule and material): used as `ke` when every point stays
    /// elastic again (it is then the same numbers), so that the tangent of a yielding run is
    /// integrated only where the material yields.
    pub elastic_ke: Option<&'a [f64; 64]>,
    /// A linear elastic element with `elastic_ke` takes its force as `K_e u_e` and writes no
    /// stress (the caller asks [`element_stresses`] for it when it reads stresses): the
    /// elastic remainder of a yielding run then costs a matrix-vector product per pass.
    pub elastic_force_from_ke: bool,
}

/// The mapped geometry of an element at every point of its rule (what `ElementInput::geometry`
/// holds).
pub fn point_geometry(kind: CellKind, coords: [Point2<f64>; 4], rule: &QuadratureRule, out: &mut [ShapeEval]) {
    let mapped = MappedElement::new(kind, coords);
    for (xi, ev) in rule.points.iter().zip(out.iter_mut()) {
        mapped.eval(*xi, ev);
    }
}

/// Caller-owned output buffers of one element (`ke` row-major 8x8, `fe` of length 8).
pub struct ElementOutput<'a> {
    pub ke: Option<&'a mut [f64; 64]>,
    pub fe: &'a mut [f64; 8],
    /// Stress at each point of the rule.
    pub stress: &'a mut [Stress4],
    /// Trial history at each point (same length as `state_old`).
    pub state_new: &'a mut [PlasticState],
    /// Set by the kernel: every point stayed elastic (no plastic flow), so `ke` (if asked)
    /// is the element's elastic stiffness.
    pub elastic: bool,
}

/// Builds the 4 x 2n strain-displacement rows at one point.
#[inline]
fn b_matrix(ev: &ShapeEval, nn: usize, bbar_vol: Option<&[f64; 8]>, b: &mut [[f64; 8]; 4]) {
    for row in b.iter_mut() {
        *row = [0.0; 8];
    }
    for k in 0..nn {
        let (gx, gy) = (ev.grad[k][0], ev.grad[k][1]);
        b[0][2 * k] = gx;
        b[1][2 * k + 1] = gy;
        b[3][2 * k] = gy;
        b[3][2 * k + 1] = gx;
    }
    if let Some(bv) = bbar_vol {
        for k in 0..nn {
            let d = [(bv[2 * k] - ev.grad[k][0]) / 3.0, (bv[2 * k + 1] - ev.grad[k][1]) / 3.0];
            for row in b.iter_mut().take(3) {
                row[2 * k] += d[0];
                row[2 * k + 1] += d[1];
            }
        }
    }
}

/// Evaluates one element. Returns the element measure (area times thickness; 0 where the
/// force came from the kept stiffness, see `ElementInput::elastic_force_from_ke`).
pub fn element_kernel(inp: &ElementInput, out: &mut ElementOutput) -> f64 {
    if let (Some(kept), true, Material::Elastic(_)) = (inp.elastic_ke, inp.elastic_force_from_ke, inp.material) {
        let ndof = 2 * inp.kind.num_nodes();
        for i in 0..ndof {
            out.fe[i] = (0..ndof).map(|j| kept[i * 8 + j] * inp.u[j]).sum();
        }
        for v in out.fe.iter_mut().skip(ndof) {
            *v = 0.0;
        }
        if let Some(ke) = out.ke.as_deref_mut() {
            *ke = *kept;
        }
        out.elastic = true;
        return 0.0;
    }
    if let (Some(cached), true) = (inp.elastic_ke, out.ke.is_some()) {
        // Stress and force first; the tangent only where a point yields (a second pass from
        // the same history: the same numbers).
        let ke = out.ke.take();
        let measure = kernel_pass(inp, out);
        out.ke = ke;
        if out.elastic {
            if let Some(ke) = out.ke.as_deref_mut() {
                *ke = *cached;
            }
            return measure;
        }
    }
    kernel_pass(inp, out)
}

/// One pass of [`element_kernel`] over the element's points (the tangent if `out.ke` asks).
fn kernel_pass(inp: &ElementInput, out: &mut ElementOutput) -> f64 {
    out.elastic = true;
    let nn = inp.kind.num_nodes();
    let ndof = 2 * nn;
    if inp.rule.weights.iter().all(|&w| w == 0.0) {
        // A void cell (all material cut away, or a band cell whose points all lie in the void):
        // no contribution; its points keep their last values.
        out.state_new.copy_from_slice(inp.state_old);
        *out.fe = [0.0; 8];
        if let Some(ke) = out.ke.as_deref_mut() {
            *ke = [0.0; 64];
        }
        return 0.0;
    }
    let mapped = MappedElement::new(inp.kind, inp.coords);
    let eval = |q: usize, xi: &[f64; 2], ev: &mut ShapeEval| match inp.geometry {
        Some(g) => *ev = g[q],
        None => mapped.eval(*xi, ev),
    };
    let mut ev = ShapeEval::default();
    // B-bar: element-average volumetric row.
    let bbar = if inp.formulation == Formulation::BBar {
        let mut bv = [0.0; 8];
        let mut vol = 0.0;
        for (q, (xi, w)) in inp.rule.points.iter().zip(&inp.rule.weights).enumerate() {
            eval(q, xi, &mut ev);
            let dv = w * ev.det_j;
            vol += dv;
            for k in 0..nn {
                bv[2 * k] += ev.grad[k][0] * dv;
                bv[2 * k + 1] += ev.grad[k][1] * dv;
            }
        }
        for v in bv.iter_mut() {
            *v /= vol;
        }
        Some(bv)
    } else {
        None
    };
    *out.fe = [0.0; 8];
    if let Some(ke) = out.ke.as_deref_mut() {
        *ke = [0.0; 64];
    }
    let mut b = [[0.0; 8]; 4];
    let mut sigma = Stress4::zeros();
    let mut d = Tangent4::zeros();
    let mut measure = 0.0;
    let elastic_d = match inp.material {
        Material::Elastic(e) => Some(e.tangent()),
        _ => None,
    };
    for (q, (xi, w)) in inp.rule.points.iter().zip(&inp.rule.weights).enumerate() {
        if *w == 0.0 {
            // A fixed point without material (moving surfaces): it keeps its last values and
            // its history does not advance.
            if let (Some(new), Some(old)) = (out.state_new.get_mut(q), inp.state_old.get(q)) {
                *new = *old;
            }
            continue;
        }
        eval(q, xi, &mut ev);
        let dv = w * ev.det_j * inp.thickness;
        measure += dv;
        b_matrix(&ev, nn, bbar.as_ref(), &mut b);
        let mut eps = Strain4::zeros();
        for a in 0..4 {
            let mut s = 0.0;
            for j in 0..ndof {
                s += b[a][j] * inp.u[j];
            }
            eps[a] = s;
        }
        match (inp.material, elastic_d.as_ref()) {
            (Material::Elastic(_), Some(de)) => {
                d = *de;
                sigma = d * eps;
            }
            (Material::J2Plastic(p), _) => {
                let flows = p.update(&eps, &inp.state_old[q], &mut out.state_new[q], &mut sigma, &mut d);
                out.elastic &= !flows;
            }
            (Material::Elastic(e), None) => {
                d = e.tangent();
                sigma = d * eps;
            }
        }
        out.stress[q] = sigma;
        for j in 0..ndof {
            let mut s = 0.0;
            for a in 0..4 {
                s += b[a][j] * sigma[a];
            }
            out.fe[j] += s * dv;
        }
        if let Some(ke) = out.ke.as_deref_mut() {
            // DB = D * B (4 x ndof), then K += B^T DB dv.
            let mut db = [[0.0; 8]; 4];
            for a in 0..4 {
                for j in 0..ndof {
                    let mut s = 0.0;
                    for c in 0..4 {
                        s += d[(a, c)] * b[c][j];
                    }
                    db[a][j] = s;
                }
            }
            for i in 0..ndof {
                for j in 0..ndof {
                    let mut s = 0.0;
                    for a in 0..4 {
                        s += b[a][i] * db[a][j];
                    }
                    ke[i * 8 + j] += s * dv;
                }
            }
        }
    }
    measure
}

/// The stress at each point of a linear elastic element (`sigma = D B u`, B-bar where the
/// element uses it), into `stress`; other materials are left alone. What
/// `ElementInput::elastic_force_from_ke` skipped.
pub fn element_stresses(inp: &ElementInput, stress: &mut [Stress4]) {
    if !matches!(inp.material, Material::Elastic(_)) {
        return;
    }
    let mut fe = [0.0; 8];
    let mut out = ElementOutput { ke: None, fe: &mut fe, stress, state_new: &mut [], elastic: true };
    let plain = ElementInput { state_old: &[], elastic_ke: None, elastic_force_from_ke: false, ..*inp };
    kernel_pass(&plain, &mut out);
}
