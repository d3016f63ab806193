//! Benchmark problems shared by `mortex bench` and the criterion benches: an `n x n` `Quad4`
//! plane-strain block (1 x 1 mm, steel), clamped at the bottom, pressed on top.

use crate::assembly::{Assembler, AssemblyInput, AssemblyOutput, SparsityPattern};
use crate::fem::kernel::Formulation;
use crate::fem::material::{Elastic, Material, PlaneHypothesis, PlasticState, Stress4};
use crate::mesh::{generate, CellKind};
use crate::model::{LoadPath, Model, ModelBuilder};
use crate::solver::linear::{LinearSolverError, LinearSolverKind, SparseSolver};
use crate::solver::newton::NewtonParams;
use std::time::Instant;

/// The `n x n` block model.
pub fn block_model(n: usize) -> Model {
    let mesh = match generate::rectangle(0.0, 0.0, 1.0, 1.0, n, n, 1.0, 1.0, CellKind::Quad4) {
        Ok(m) => m,
        Err(e) => unreachable!("a unit square with n >= 1 divisions is valid: {e}"),
    };
    let mut b = ModelBuilder::new(PlaneHypothesis::PlaneStrain);
    let m = b.add_material(
        "steel",
        Material::Elastic(Elastic { young: 210_000.0, poisson: 0.3, hypothesis: PlaneHypothesis::PlaneStrain }),
    );
    let body = b.add_body("block", mesh, m, Formulation::Standard, 1.0);
    let setup = (|| {
        b.fix(body, "bottom", 0, 0.0)?;
        b.fix(body, "bottom", 1, 0.0)?;
        b.pressure(body, "top", 100.0)?;
        let path = LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)])?;
        b.build(path, vec![1.0], NewtonParams::default(), LinearSolverKind::Cholesky)
    })();
    match setup {
        Ok(model) => model,
        Err(e) => unreachable!("the generated block has the sets used here: {e}"),
    }
}

/// Wall times in seconds of the pieces of one linear solve.
#[derive(Debug, Clone, Copy, Default)]
pub struct LinearSolveTimes {
    pub dofs: usize,
    pub nnz: usize,
    pub pattern: f64,
    pub assembly: f64,
    pub symbolic: f64,
    pub numeric: f64,
    pub solve: f64,
    /// Second assembly into the existing pattern (values refilled).
    pub refill: f64,
    pub refactor: f64,
    /// Relative residual `|K u - f| / |f|` of the solution.
    pub residual: f64,
}

impl LinearSolveTimes {
    /// pattern + assembly + symbolic + numeric + solve.
    pub fn whole(&self) -> f64 {
        self.pattern + self.assembly + self.symbolic + self.numeric + self.solve
    }
}

/// Times one linear solve of the `n x n` block, then a refill and a refactorisation.
pub fn time_linear_solve(n: usize, parallel: bool) -> Result<LinearSolveTimes, LinearSolverError> {
    let model = block_model(n);
    let mut t = LinearSolveTimes { dofs: model.dofs.num_dofs, ..Default::default() };
    let el = &model.elements;
    let t0 = Instant::now();
    let pattern = SparsityPattern::new(model.num_nodes(), el, &model.dofs);
    t.pattern = t0.elapsed().as_secs_f64();
    t.nnz = pattern.nnz();
    let t0 = Instant::now();
    let mut solver = SparseSolver::new(&pattern.symbolic, LinearSolverKind::Cholesky)?;
    t.symbolic = t0.elapsed().as_secs_f64();
    let mut asm = Assembler::new(pattern, el);
    let mut values = vec![0.0; asm.pattern.nnz()];
    let mut f_int = vec![0.0; model.dofs.num_dofs];
    let mut stress = vec![Stress4::zeros(); el.num_points()];
    let mut hist: Vec<PlasticState> = vec![];
    let u = vec![0.0; model.dofs.num_dofs];
    let mut assemble = |values: &mut [f64], f_int: &mut [f64]| {
        asm.assemble(
            &AssemblyInput {
                coords: &model.coords,
                elements: el,
                materials: &model.materials,
                rules: &model.rules,
                u: &u,
                state_old: &[],
            },
            AssemblyOutput { values: Some(values), f_int, stress: &mut stress, state_new: &mut hist },
            parallel,
        )
    };
    let t0 = Instant::now();
    assemble(&mut values, &mut f_int);
    t.assembly = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    solver.factor(&values)?;
    t.numeric = t0.elapsed().as_secs_f64();
    let rhs: Vec<f64> = model.dofs.free.iter().map(|&g| model.f_ext[g]).collect();
    let mut x = rhs.clone();
    let t0 = Instant::now();
    solver.solve(&mut x)?;
    t.solve = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    assemble(&mut values, &mut f_int);
    t.refill = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    solver.factor(&values)?;
    t.refactor = t0.elapsed().as_secs_f64();
    let mut kx = vec![0.0; x.len()];
    crate::solver::linear::spmv(&asm.pattern.symbolic, &values, &x, &mut kx);
    let num: f64 = kx.iter().zip(&rhs).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    let den: f64 = rhs.iter().map(|b| b * b).sum::<f64>().sqrt();
    t.residual = num / den;
    Ok(t)
}
