//! Convergence of `Quad4` against Lamé's thick cylinder under internal pressure (plane strain).
//! Exact (Timoshenko & Goodier, *Theory of Elasticity*, sec. 33):
//! `sigma_r = A - B/r^2`, `sigma_t = A + B/r^2`, `A = p a^2/(b^2 - a^2)`, `B = p a^2 b^2/(b^2 - a^2)`,
//! `u_r = ((1+nu)/E) [ (1 - 2 nu) A r + B / r ]`.
//! Sketch: quarter annulus a = 1 mm, b = 2 mm, symmetry (u_y = 0 on y = 0, u_x = 0 on x = 0),
//! pressure p = 100 MPa on r = a. Meshes 4x6, 8x12, 16x24, 32x48 (radial x angular).
//! Expected orders for bilinear elements: 2 in L2 displacement, 1 in energy norm; the target asks
//! for >= 1.9 and >= 0.9 (the polygonal boundary adds an O(h^2) geometric error only).

mod common;
use common::{for_each_point, solve};
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, Material, PlaneHypothesis, Strain4};
use mortex::mesh::generate;
use mortex::model::{Model, ModelBuilder};

const A_IN: f64 = 1.0;
const B_OUT: f64 = 2.0;
/// The quarter annulus of the Lame problem.
const QUARTER: generate::Sector =
    generate::Sector { r_in: A_IN, r_out: B_OUT, theta0: 0.0, theta1: std::f64::consts::FRAC_PI_2 };
const P: f64 = 100.0;
const E: f64 = 210_000.0;
const NU: f64 = 0.3;

fn lame(x: f64, y: f64) -> ([f64; 2], [f64; 4]) {
    let (a2, b2) = (A_IN * A_IN, B_OUT * B_OUT);
    let ca = P * a2 / (b2 - a2);
    let cb = P * a2 * b2 / (b2 - a2);
    let r = (x * x + y * y).sqrt();
    let (c, s) = (x / r, y / r);
    let ur = (1.0 + NU) / E * ((1.0 - 2.0 * NU) * ca * r + cb / r);
    let sr = ca - cb / (r * r);
    let st = ca + cb / (r * r);
    let sz = NU * (sr + st);
    let sxx = sr * c * c + st * s * s;
    let syy = sr * s * s + st * c * c;
    let sxy = (sr - st) * s * c;
    ([ur * c, ur * s], [sxx, syy, sz, sxy])
}

fn model(nr: usize, nt: usize) -> Model {
    let mesh = generate::annulus_sector(QUARTER, nr, nt, 1.0).unwrap();
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
    let body = b.add_body("cylinder", mesh, mi, Formulation::Standard, 1.0);
    b.fix(body, "start", 1, 0.0).unwrap();
    b.fix(body, "end", 0, 0.0).unwrap();
    b.pressure(body, "inner", P).unwrap();
    common::build_one_step(b)
}

/// Relative L2 displacement error and relative energy-norm error.
fn errors(nr: usize, nt: usize) -> (f64, f64) {
    let m = model(nr, nt);
    let s = solve(&m);
    let el = Elastic { young: E, poisson: NU, hypothesis: PlaneHypothesis::PlaneStrain };
    let d = el.tangent();
    let c = d.try_inverse().unwrap();
    let (mut l2e, mut l2u, mut ene, mut enu) = (0.0, 0.0, 0.0, 0.0);
    for_each_point(&m, &s.u, 3, |x, uh, g, dv, _| {
        let (u, sig) = lame(x.x, x.y);
        l2e += ((uh[0] - u[0]).powi(2) + (uh[1] - u[1]).powi(2)) * dv;
        l2u += (u[0] * u[0] + u[1] * u[1]) * dv;
        let eps_ex = c * nalgebra::Vector4::new(sig[0], sig[1], sig[2], sig[3]);
        let eps_h = Strain4::new(g[0][0], g[1][1], 0.0, g[0][1] + g[1][0]);
        let de = eps_ex - eps_h;
        ene += de.dot(&(d * de)) * dv;
        enu += eps_ex.dot(&(d * eps_ex)) * dv;
    });
    ((l2e / l2u).sqrt(), (ene / enu).sqrt())
}

#[test]
fn quad4_converges_at_optimal_rates_on_lame_cylinder() {
    let meshes = [(4, 6), (8, 12), (16, 24), (32, 48)];
    let errs: Vec<(f64, f64)> = meshes.iter().map(|&(nr, nt)| errors(nr, nt)).collect();
    for (k, w) in errs.windows(2).enumerate() {
        let p_l2 = (w[0].0 / w[1].0).log2();
        let p_en = (w[0].1 / w[1].1).log2();
        eprintln!(
            "refinement {k}: L2 {:.3e} -> {:.3e} (order {p_l2:.3}), energy {:.3e} -> {:.3e} (order {p_en:.3})",
            w[0].0, w[1].0, w[0].1, w[1].1
        );
        assert!(p_l2 >= 1.9, "L2 order {p_l2} < 1.9 at refinement {k}");
        assert!(p_en >= 0.9, "energy order {p_en} < 0.9 at refinement {k}");
    }
    // The finest mesh is accurate in absolute terms too (h = 1/32: L2 error well under 0.1%).
    assert!(errs[3].0 < 1e-3, "finest L2 error {}", errs[3].0);
}

/// Radial displacement of the inner wall on the finest mesh against Lamé: the quantity a user
/// reads first. Tolerance 0.1%: O(h^2) with h = 1/32 and the chord error of 48 angular segments.
#[test]
fn inner_wall_displacement_matches_lame() {
    let m = model(32, 48);
    let s = solve(&m);
    let body = &m.bodies[0];
    for &n in &body.mesh.node_sets["inner"] {
        let p = m.coords[n];
        let (u, _) = lame(p.x, p.y);
        let ur_h = (s.u[2 * n] * p.x + s.u[2 * n + 1] * p.y) / p.coords.norm();
        let ur = (u[0] * p.x + u[1] * p.y) / p.coords.norm();
        assert!((ur_h - ur).abs() / ur < 1e-3, "node {n}: u_r {ur_h} vs {ur}");
    }
}
