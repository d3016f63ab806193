//! X-FEM patch test on a free virtual surface (Moës, Dolbow, Belytschko, IJNME 46 (1999) 131:
//! partial integration of cut elements reproduces any linear field).
//!
//! Sketch: host rectangle 10 x 4 mm (20 x 8 Quad4 or Tri3) cut by a slanted open polyline from
//! (-1, 1) to (11, 3) (it starts and ends outside the host); material kept below it. Uniaxial
//! stress along the cut, `sigma = sigma_0 t (x) t`, is traction-free on the cut, so the exact
//! solution is the linear field `u = eps x` (eps from sigma, plane strain), prescribed on the
//! boundary nodes of the left, right and bottom edges. Every integration point (cut cells
//! included) must carry `sigma` to 1e-8 relative, and the kept area must be exact.

mod common;
use common::solve;
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, Material, PlaneHypothesis};
use mortex::mesh::{generate, CellKind};
use mortex::model::ModelBuilder;
use nalgebra::{Matrix2, Point2};

const E: f64 = 210_000.0;
const NU: f64 = 0.3;
const S0: f64 = 100.0;

fn run(kind: CellKind, cut: &[Point2<f64>]) {
    let hyp = PlaneHypothesis::PlaneStrain;
    let mesh = generate::rectangle(0.0, 0.0, 10.0, 4.0, 20, 8, 1.0, 1.0, kind).unwrap();
    let boundary: Vec<usize> = ["left", "right", "bottom"].iter().flat_map(|s| mesh.node_sets[*s].clone()).collect();
    let nodes = mesh.nodes.clone();
    let t = (cut[1] - cut[0]).normalize();
    let sigma = Matrix2::new(t.x * t.x, t.x * t.y, t.x * t.y, t.y * t.y) * S0;
    // Plane-strain compliance: eps = (1 + nu)/E (sigma - nu tr(sigma) I) (in-plane trace).
    let eps = (sigma - Matrix2::identity() * (NU * sigma.trace())) * ((1.0 + NU) / E);
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
    let body = b.add_body("block", mesh, mi, Formulation::Standard, 1.0);
    for &n in &boundary {
        let u = eps * nodes[n].coords;
        b.fix_node(body, n, 0, u.x);
        b.fix_node(body, n, 1, u.y);
    }
    b.add_cut("slant", body, cut.to_vec(), false, false).unwrap();
    let model = common::build_one_step(b);
    let s = solve(&model);
    for (q, st) in s.stress.iter().enumerate() {
        let e = [(st[0] - sigma[(0, 0)]).abs(), (st[1] - sigma[(1, 1)]).abs(), (st[3] - sigma[(0, 1)]).abs()]
            .into_iter()
            .fold(0.0, f64::max);
        assert!(e < 1e-8 * S0, "{kind:?}: point {q}: stress {st:?} vs {sigma:?}");
    }
    // Kept area: the host below the line y = 1 + (x + 1)/6 between x = 0 and 10.
    let cut_mesh = model.initial().cuts[0].as_ref().unwrap();
    let area: f64 = (0..model.bodies[0].mesh.num_cells())
        .map(|c| {
            cut_mesh.cell_fraction[c]
                * mortex::cut::polygon_area(&mortex::surface::cell_polygon(&model.bodies[0].mesh, c))
        })
        .sum();
    let y = |x: f64| (cut[0].y + (x - cut[0].x) * (cut[1].y - cut[0].y) / (cut[1].x - cut[0].x)).min(4.0);
    let exact = 0.5 * (y(0.0) + y(10.0)) * 10.0;
    assert!((area - exact).abs() < 1e-12 * exact, "{kind:?}: kept area {area} vs {exact}");
}

#[test]
fn free_cut_patch_test_quad4_and_tri3() {
    let cut = [Point2::new(-1.0, 1.0), Point2::new(11.0, 3.0)];
    run(CellKind::Quad4, &cut);
    run(CellKind::Tri3, &cut);
    // A cut through host nodes: y = 1.5 + x / 4 passes (0, 1.5), (2, 2), ..., (10, 4) on the
    // 0.5 mm grid, leaving the host through its top-right corner node.
    run(CellKind::Quad4, &[Point2::new(-2.0, 1.0), Point2::new(12.0, 4.5)]);
    run(CellKind::Tri3, &[Point2::new(-2.0, 1.0), Point2::new(12.0, 4.5)]);
}
