//! Patch tests (Irons; Zienkiewicz & Taylor, *The Finite Element Method* vol. 1, sec. 9.3):
//! a linear displacement field, imposed on the boundary of a mesh of distorted cells, must be
//! reproduced exactly at every interior node and give the exact constant stress at every point.
//! Sketch: rectangle 2 x 1 mm, 5 x 4 cells, interior nodes moved by up to 30% of the cell size.
//!
//!   +---+---+--+----+
//!   |  /    |   \   |     u_x = a0 + a1 x + a2 y
//!   +-+----+-----+--+     u_y = b0 + b1 x + b2 y  on every boundary node
//!   |  \   |    /   |
//!   +---+--+---+----+
//!
//! Tolerance: relative error 1e-10: the exact field lies in the FE space, so only
//! round-off of a direct solve on a ~100-DOF system remains (~1e-14 expected).

mod common;
use common::{solve, Lcg};
use mortex::fem::element::{MappedElement, ShapeEval};
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, Material, PlaneHypothesis, Strain4, Stress4};
use mortex::mesh::{generate, CellKind, Mesh2};
use mortex::model::ModelBuilder;
use nalgebra::{Point2, Vector2};

const A: [f64; 3] = [1e-3, 2e-3, -1.5e-3];
const B: [f64; 3] = [-2e-3, 0.5e-3, 3e-3];
const E: f64 = 210_000.0;
const NU: f64 = 0.3;
const TOL: f64 = 1e-10;

fn exact_u(x: f64, y: f64) -> [f64; 2] {
    [A[0] + A[1] * x + A[2] * y, B[0] + B[1] * x + B[2] * y]
}

fn distorted_mesh(kind: CellKind, seed: u64) -> Mesh2 {
    let mut m = generate::rectangle(0.0, 0.0, 2.0, 1.0, 5, 4, 1.0, 1.0, kind).unwrap();
    let boundary: std::collections::HashSet<usize> = m.node_sets.values().flatten().copied().collect();
    let mut rng = Lcg(seed);
    let (hx, hy) = (2.0 / 5.0, 1.0 / 4.0);
    for (i, p) in m.nodes.iter_mut().enumerate() {
        if !boundary.contains(&i) {
            p.x += 0.3 * hx * rng.next();
            p.y += 0.3 * hy * rng.next();
        }
    }
    m.validate().expect("distortion keeps cells valid");
    m
}

fn run_patch(kind: CellKind, hypothesis: PlaneHypothesis, formulation: Formulation, seed: u64) {
    let mesh = distorted_mesh(kind, seed);
    let boundary: Vec<usize> = {
        let mut v: Vec<usize> =
            ["left", "right", "top", "bottom"].iter().flat_map(|s| mesh.node_sets[*s].clone()).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let mat = Elastic { young: E, poisson: NU, hypothesis };
    let mut b = ModelBuilder::new(hypothesis);
    let mi = b.add_material("m", Material::Elastic(mat));
    let nodes = mesh.nodes.clone();
    let body = b.add_body("patch", mesh, mi, formulation, 1.0);
    for &n in &boundary {
        let u = exact_u(nodes[n].x, nodes[n].y);
        b.fix_node(body, n, 0, u[0]);
        b.fix_node(body, n, 1, u[1]);
    }
    let model = common::build_one_step(b);
    let s = solve(&model);
    let scale = 3e-3 * 2.0;
    for (n, p) in nodes.iter().enumerate() {
        let u = exact_u(p.x, p.y);
        for i in 0..2 {
            let err = (s.u[2 * n + i] - u[i]).abs() / scale;
            assert!(err < TOL, "{kind:?} {hypothesis:?} {formulation:?}: node {n} comp {i} error {err:e}");
        }
    }
    let eps = Strain4::new(A[1], B[2], 0.0, A[2] + B[1]);
    let sig = mat.tangent() * eps;
    let smax = sig.amax();
    for (q, sq) in s.stress.iter().enumerate() {
        let err = (sq - sig).amax() / smax;
        assert!(err < TOL, "{kind:?} {hypothesis:?} {formulation:?}: point {q} stress error {err:e}");
    }
}

#[test]
fn quad4_plane_strain_patch() {
    run_patch(CellKind::Quad4, PlaneHypothesis::PlaneStrain, Formulation::Standard, 7);
}

#[test]
fn quad4_plane_strain_bbar_patch() {
    run_patch(CellKind::Quad4, PlaneHypothesis::PlaneStrain, Formulation::BBar, 11);
}

#[test]
fn quad4_plane_stress_patch() {
    run_patch(CellKind::Quad4, PlaneHypothesis::PlaneStress, Formulation::Standard, 13);
}

#[test]
fn tri3_plane_strain_patch() {
    run_patch(CellKind::Tri3, PlaneHypothesis::PlaneStrain, Formulation::Standard, 17);
}

#[test]
fn tri3_plane_stress_patch() {
    run_patch(CellKind::Tri3, PlaneHypothesis::PlaneStress, Formulation::Standard, 19);
}

/// Traction patch test: a uniform tension `sigma_xx = T` applied as a traction on the right
/// edge of a distorted mesh (left edge on rollers, one node pinned) gives `sigma_xx = T`,
/// `sigma_yy = sigma_xy = 0` at every point: tests the Neumann load integration.
#[test]
fn quad4_traction_patch() {
    const T: f64 = 50.0;
    let mesh = distorted_mesh(CellKind::Quad4, 23);
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("m", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
    let body = b.add_body("patch", mesh, mi, Formulation::Standard, 1.0);
    b.fix(body, "left", 0, 0.0).unwrap();
    b.fix(body, "bottom_left", 1, 0.0).unwrap();
    b.traction(body, "right", Vector2::new(T, 0.0)).unwrap();
    let model = common::build_one_step(b);
    let s = solve(&model);
    for (q, sq) in s.stress.iter().enumerate() {
        let err = [(sq[0] - T).abs(), sq[1].abs(), sq[3].abs()].into_iter().fold(0.0, f64::max) / T;
        assert!(err < TOL, "point {q}: stress {sq:?}, error {err:e}");
    }
    // Plane strain: sigma_zz = nu sigma_xx.
    assert!((s.stress[0][2] - NU * T).abs() < TOL * T);
}

/// A stress field linear in `x, y` at the integration points is recovered exactly at every
/// node of an unstructured quad mesh (the rounded punch's Gmsh mesh, its boundary nodes
/// included; 1e-9 of the field's scale: round-off of the 4 x 4 fits): the bilinear fit of a
/// whole cell reproduces it. The lumped projection missed it at the boundary (a mean over
/// the cells around a node, not the node's value).
#[test]
fn linear_stress_is_recovered_exactly_at_the_nodes() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases");
    let text = r#"
[problem]
hypothesis = "plane_strain"
[[materials]]
name = "steel"
model = "elastic"
young = 210000.0
poisson = 0.3
[[bodies]]
name = "punch"
material = "steel"
mesh = { type = "gmsh", file = "meshes/rounded_punch.msh" }
[[bcs]]
body = "punch"
set = "top"
ux = 0.0
uy = 0.0
[[loads]]
body = "punch"
set = "bottom"
traction = [0.0, 1.0]
[steps]
path = [[0.0, 0.0], [1.0, 1.0]]
increments = 1
"#;
    let model = mortex::case::parse(text, "linear", &dir, "linear").expect("the scene").model;
    let disc = model.initial();
    let mut state = mortex::solve::StaticAnalysis::initial_state_of(&model);
    let field =
        |p: Point2<f64>| [100.0 + 30.0 * p.x - 20.0 * p.y, -50.0 + 10.0 * p.y, 7.0 * p.x, 40.0 * p.x + 5.0 * p.y];
    let el = &model.elements;
    let mut ev = ShapeEval::default();
    for e in 0..el.len() {
        let kind = el.kind[e];
        let mut c = [Point2::origin(); 4];
        for k in 0..kind.num_nodes() {
            c[k] = model.coords[el.nodes[e][k]];
        }
        let mapped = MappedElement::new(kind, c);
        for (q, xi) in disc.rules[el.rule[e]].points.iter().enumerate() {
            mapped.eval(*xi, &mut ev);
            let v = field(ev.x);
            state.stress[el.point_offset[e] + q] = Stress4::new(v[0], v[1], v[2], v[3]);
        }
    }
    let fields = mortex::post::nodal_fields(&model, disc, &state);
    let mut worst: f64 = 0.0;
    for (i, s) in fields.stress.iter().enumerate() {
        let v = field(model.coords[i]);
        for comp in 0..4 {
            worst = worst.max((s[comp] - v[comp]).abs());
        }
    }
    assert!(worst < 1e-9 * 100.0, "largest nodal error {worst}");
}
