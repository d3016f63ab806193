//! Helpers shared by the integration tests.
#![allow(dead_code)]

use mortex::analysis::StaticAnalysis;
use mortex::fem::element::{MappedElement, ShapeEval};
use mortex::model::Model;
use mortex::state::SimState;
use nalgebra::Point2;

/// Deterministic pseudo-random numbers in [-1, 1] (no external RNG needed).
pub struct Lcg(pub u64);
impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// Runs every step of a model and returns the final state.
pub fn solve(model: &Model) -> SimState {
    let mut a = StaticAnalysis::new(model).expect("solver setup");
    let mut s = a.initial_state();
    a.run(&mut s, |_, _| Ok(())).expect("analysis");
    s
}

/// Calls `f(x, shape_eval, u_h, grad_u_h, dv, element)` at every point of a `n x n` Gauss rule
/// of every element (for error norms).
pub fn for_each_point<F: FnMut(Point2<f64>, [f64; 2], [[f64; 2]; 2], f64, usize)>(
    model: &Model,
    u: &[f64],
    order: usize,
    mut f: F,
) {
    let el = &model.elements;
    let quad = mortex::fem::quadrature::quad_gauss(order);
    let tri = mortex::fem::quadrature::triangle_rule(2 * order - 1);
    let mut ev = ShapeEval::default();
    for e in 0..el.len() {
        let kind = el.kind[e];
        let nn = kind.num_nodes();
        let mut c = [Point2::origin(); 4];
        for k in 0..nn {
            c[k] = model.coords[el.nodes[e][k]];
        }
        let m = MappedElement::new(kind, c);
        let rule = if nn == 4 { &quad } else { &tri };
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            m.eval(*xi, &mut ev);
            let mut uh = [0.0; 2];
            let mut g = [[0.0; 2]; 2];
            for k in 0..nn {
                let node = el.nodes[e][k];
                for i in 0..2 {
                    uh[i] += ev.n[k] * u[2 * node + i];
                    for j in 0..2 {
                        g[i][j] += ev.grad[k][j] * u[2 * node + i];
                    }
                }
            }
            f(ev.x, uh, g, w * ev.det_j, e);
        }
    }
}

/// Finishes a one-step linear-ramp model (load factor 0 -> 1, one output step).
pub fn build_one_step(b: mortex::model::ModelBuilder) -> Model {
    b.build(
        mortex::model::LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)]).expect("valid path"),
        vec![1.0],
        mortex::solver::newton::NewtonParams::default(),
        mortex::solver::linear::LinearSolverKind::Cholesky,
    )
    .expect("valid model")
}
