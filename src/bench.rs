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

/// Wall times of embedding a closed polyline in a host mesh and cutting the host.
#[derive(Debug, Clone, Copy, Default)]
pub struct EmbedTimes {
    pub cells: usize,
    pub segments: usize,
    pub cut_cells: usize,
    /// Built once per host mesh: BVH over cells and cell adjacency.
    pub index: f64,
    /// Embedding the surface (clipping against BVH candidates).
    pub embed: f64,
    /// Classification, material loops and node fractions.
    pub cut: f64,
    /// Moment-fitted weights on the band rule, per cut cell (seconds per cell).
    pub fit_per_cell: f64,
    /// Sub-triangulation rule, per cut cell (seconds per cell).
    pub subtri_per_cell: f64,
}

/// A circle of `segments` segments (radius 0.3, centre slightly off the grid) in an `n x n`
/// `Quad4` unit square.
pub fn time_embedding(n: usize, segments: usize) -> Result<EmbedTimes, crate::surface::SurfaceError> {
    use crate::cut::{band_rule, cut_mesh, fit_weights, rule_points, subtriangulation_rule, CellAdjacency, CellCut};
    use crate::surface::{embed, BoxIndex, VirtualSurface};
    let host = match generate::rectangle(0.0, 0.0, 1.0, 1.0, n, n, 1.0, 1.0, CellKind::Quad4) {
        Ok(m) => m,
        Err(e) => unreachable!("a unit square with n >= 1 divisions is valid: {e}"),
    };
    let mut t = EmbedTimes { cells: host.num_cells(), segments, ..Default::default() };
    // Clockwise circle: host material outside.
    let vertices: Vec<nalgebra::Point2<f64>> = (0..segments)
        .map(|i| {
            let a = -std::f64::consts::TAU * i as f64 / segments as f64;
            nalgebra::Point2::new(0.5013 + 0.3 * a.cos(), 0.4987 + 0.3 * a.sin())
        })
        .collect();
    let surface = VirtualSurface { vertices, closed: true };
    surface.validate()?;
    let t0 = Instant::now();
    let index = BoxIndex::over_cells(&host);
    let adjacency = CellAdjacency::new(&host);
    t.index = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let emb = embed(&surface, &host, &index)?;
    t.embed = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let cut = cut_mesh(&host, &adjacency, &[&emb])?;
    t.cut = t0.elapsed().as_secs_f64();
    let cut_cells: Vec<usize> =
        (0..host.num_cells()).filter(|&c| matches!(cut.cells[c], CellCut::Cut { .. })).collect();
    t.cut_cells = cut_cells.len();
    let rule = band_rule(CellKind::Quad4);
    let t0 = Instant::now();
    for &c in &cut_cells {
        if let CellCut::Cut { loops, .. } = &cut.cells[c] {
            let x = rule_points(&host, c, &rule);
            let inside: Vec<bool> = x.iter().map(|p| loops.iter().any(|l| crate::cut::point_in_loop(l, *p))).collect();
            std::hint::black_box(fit_weights(&x, &inside, loops));
        }
    }
    t.fit_per_cell = t0.elapsed().as_secs_f64() / cut_cells.len().max(1) as f64;
    let t0 = Instant::now();
    for &c in &cut_cells {
        if let CellCut::Cut { loops, .. } = &cut.cells[c] {
            std::hint::black_box(subtriangulation_rule(&host, c, loops));
        }
    }
    t.subtri_per_cell = t0.elapsed().as_secs_f64() / cut_cells.len().max(1) as f64;
    Ok(t)
}
