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

/// The Hertz benchmark: cylinder R = 10 mm (half disc) on a block 40 x 20 mm, both steel,
/// plane strain, frictionless, P = 100 N/mm on the cylinder's flat top (its centre held in x),
/// block bottom fixed. The block's core (|x| <= 0.5 mm, 0.5 mm deep) has square elements of
/// size `h_core`, the cylinder's core (same extent along the rim) is 1.5x finer; 20 divisions
/// grow geometrically to the far boundaries. `virtual_top`: the block's contact surface is a
/// virtual line cutting its host 0.013 mm below the host's top (MorteX).
pub fn hertz_model(h_core: f64, virtual_top: bool) -> Result<Model, crate::model::ModelError> {
    hertz_model_with(h_core, 1.5, 0.5, virtual_top, crate::mortar::MultiplierSpace::Classical)
}

/// [`hertz_model`] with the cylinder `cylinder_refinement` times finer than the block over
/// |x| <= `cylinder_core` (and as deep), and the given contact multiplier space (the
/// curved-surface density-contrast test).
pub fn hertz_model_with(
    h_core: f64,
    cylinder_refinement: f64,
    cylinder_core: f64,
    virtual_top: bool,
    multipliers: crate::mortar::MultiplierSpace,
) -> Result<Model, crate::model::ModelError> {
    hertz_model_materials(h_core, cylinder_refinement, cylinder_core, virtual_top, multipliers, STEEL, STEEL)
}

/// Steel: E = 210 GPa, nu = 0.3 (MPa).
pub const STEEL: (f64, f64) = (210_000.0, 0.3);
/// Aluminium: E = 70 GPa, nu = 0.33 (MPa).
pub const ALUMINIUM: (f64, f64) = (70_000.0, 0.33);

/// [`hertz_model_with`] with the cylinder's and the block's `(E, nu)`.
pub fn hertz_model_materials(
    h_core: f64,
    cylinder_refinement: f64,
    cylinder_core: f64,
    virtual_top: bool,
    multipliers: crate::mortar::MultiplierSpace,
    cylinder_material: (f64, f64),
    block_material: (f64, f64),
) -> Result<Model, crate::model::ModelError> {
    use crate::model::ContactOther;
    use nalgebra::{Point2, Vector2};
    const R: f64 = 10.0;
    const CORE: f64 = 0.5;
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let elastic = |(young, poisson): (f64, f64)| Material::Elastic(Elastic { young, poisson, hypothesis: hyp });
    let mi_cyl = b.add_material("cylinder", elastic(cylinder_material));
    let mi = b.add_material("block", elastic(block_material));
    let n_core = (2.0 * CORE / h_core).round().max(2.0) as usize;
    let n_depth = (CORE / h_core).round().max(1.0) as usize;
    let top = if virtual_top { 0.013 } else { 0.0 };
    let gx = generate::plateau_graded(n_core, 2.0 * CORE / 40.0, 20);
    let gy = generate::end_plateau(n_depth, CORE / (20.0 + top), 20);
    let mesh_err =
        |e: crate::mesh::MeshError| crate::model::ModelError::Mesh { body: "hertz".into(), msg: e.to_string() };
    let block = generate::rectangle_from_divisions(-20.0, -20.0, 40.0, 20.0 + top, &gx, &gy, CellKind::Quad4)
        .map_err(mesh_err)?;
    let n_cyl = |core: f64| ((core / h_core * cylinder_refinement).round() as usize).max(1);
    let rs = generate::end_plateau(n_cyl(cylinder_core), cylinder_core / R, 20);
    let ts = generate::plateau_graded(n_cyl(2.0 * cylinder_core), (2.0 * cylinder_core / R) / std::f64::consts::PI, 20);
    let cyl = generate::half_disc_from_divisions(Point2::new(0.0, R), R, &rs, &ts).map_err(mesh_err)?;
    let bl = b.add_body("block", block, mi, Formulation::Standard, 1.0);
    let cy = b.add_body("cylinder", cyl, mi_cyl, Formulation::Standard, 1.0);
    b.fix(bl, "bottom", 0, 0.0)?;
    b.fix(bl, "bottom", 1, 0.0)?;
    b.fix(cy, "centre", 0, 0.0)?;
    b.traction(cy, "top", Vector2::new(0.0, -100.0 / (2.0 * R)))?;
    let other = if virtual_top {
        b.add_cut("surface", bl, vec![Point2::new(-21.0, 0.0), Point2::new(21.0, 0.0)], false, false)?;
        ContactOther::Cut("surface".into())
    } else {
        ContactOther::Edges(b.global_edges(bl, &["top".to_string()])?)
    };
    b.add_contact(
        "hertz",
        cy,
        &["arc".to_string()],
        bl,
        other,
        crate::model::ContactParams { friction: 0.0, multipliers, ..Default::default() },
    )?;
    let newton = NewtonParams { max_iterations: 60, ..Default::default() };
    b.build(LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)])?, vec![1.0], newton, LinearSolverKind::Cholesky)
}

/// Figures of one Hertz run: size, whole-process wall time (mesh, model, factorisation, solve),
/// active-set iterations and the errors against Hertz (P = 100 N/mm, E* = E / (2 (1 - nu^2))).
#[derive(Debug, Clone, Copy)]
pub struct HertzRun {
    pub dofs: usize,
    pub seconds: f64,
    pub iterations: usize,
    /// Relative errors of the peak pressure and of the fitted half-width (P = pi a p0 / 2 with
    /// the computed load), and the relative L2 error of the pressure over [-2a, 2a].
    pub p0_error: f64,
    pub a_error: f64,
    pub l2_error: f64,
}

pub fn run_hertz(h_core: f64, virtual_top: bool) -> Result<HertzRun, String> {
    let start = Instant::now();
    let model = hertz_model(h_core, virtual_top).map_err(|e| e.to_string())?;
    let mut analysis = crate::analysis::StaticAnalysis::new(&model).map_err(|e| e.to_string())?;
    let mut state = analysis.initial_state();
    let mut iterations = 0;
    analysis
        .run(&mut state, |r, _| {
            iterations += r.iterations;
            Ok(())
        })
        .map_err(|e| e.to_string())?;
    let seconds = start.elapsed().as_secs_f64();
    let e_star = 210_000.0 / (2.0 * (1.0 - 0.09));
    let a = (4.0 * 100.0 * 10.0 / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * 100.0 / (std::f64::consts::PI * a);
    let prof: Vec<(f64, f64)> =
        crate::post::contact_profile(&model, &state, 0).iter().map(|n| (n.x.x, n.pressure)).collect();
    let peak = prof.iter().map(|p| p.1).fold(0.0, f64::max);
    let load: f64 = prof.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum();
    let a_fit = 2.0 * load / (std::f64::consts::PI * peak);
    let exact = |x: f64| if x.abs() < a { p0 * (1.0 - x * x / (a * a)).sqrt() } else { 0.0 };
    Ok(HertzRun {
        dofs: model.dofs.num_dofs,
        seconds,
        iterations,
        p0_error: peak / p0 - 1.0,
        a_error: a_fit / a - 1.0,
        l2_error: crate::post::relative_l2_error(&prof, exact, -2.0 * a, 2.0 * a),
    })
}

/// Figures of the output benchmark: a many-step contact run, solve and output timed apart.
#[derive(Debug, Clone, Copy)]
pub struct OutputRun {
    pub steps: usize,
    pub dofs: usize,
    /// Seconds in the solver (driver minus observer) and in the result writer.
    pub solve: f64,
    pub output: f64,
    /// Size of the result file and of the contact CSV, bytes.
    pub h5_bytes: u64,
    pub csv_bytes: u64,
}

/// A fretting-like scene of about 19k DOFs for output benchmarks: a 4 x 1 mm block (70 x 25
/// Quad4) pressed (50 MPa) on a 4 x 3 mm block (100 x 75 Quad4), mu = 0.3, with a tangential
/// traction cycling between +-5 MPa (10 increments per cycle) after one loading step.
pub fn fretting_blocks_model(steps: usize) -> Result<Model, crate::model::ModelError> {
    use crate::model::{ContactOther, ContactParams, Cycle};
    use nalgebra::Vector2;
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: 210_000.0, poisson: 0.3, hypothesis: hyp }));
    let mesh_err = |e: crate::mesh::MeshError| crate::model::ModelError::Mesh {
        body: "fretting blocks".into(),
        msg: e.to_string(),
    };
    let lower = generate::rectangle(0.0, 0.0, 4.0, 3.0, 100, 75, 1.0, 1.0, CellKind::Quad4).map_err(mesh_err)?;
    let upper = generate::rectangle(0.0, 3.0, 4.0, 1.0, 70, 25, 1.0, 1.0, CellKind::Quad4).map_err(mesh_err)?;
    let lo = b.add_body("lower", lower, mi, Formulation::Standard, 1.0);
    let up = b.add_body("upper", upper, mi, Formulation::Standard, 1.0);
    b.fix(lo, "bottom", 0, 0.0)?;
    b.fix(lo, "bottom", 1, 0.0)?;
    b.fix(up, "top_left", 0, 0.0)?;
    b.pressure(up, "top", 50.0)?;
    let shear = b.add_curve(LoadPath::new(vec![(0.0, 0.0), (1.0, 0.0), (1.25, 1.0), (1.75, -1.0), (2.0, 0.0)])?);
    b.use_curve(shear);
    b.traction(up, "top", Vector2::new(5.0, 0.0))?;
    b.use_curve(0);
    let other = ContactOther::Edges(b.global_edges(lo, &["top".to_string()])?);
    b.add_contact("pair", up, &["bottom".to_string()], lo, other, ContactParams::friction(0.3))?;
    let cycles = steps.saturating_sub(1).div_ceil(10).max(1);
    let cycle = Cycle { start: 1.0, period: 1.0, count: cycles, increments: 10, ramp_increments: 1 };
    b.set_cycle(cycle);
    let mut times = cycle.times(0.0);
    times.truncate(steps.max(1));
    b.build(
        LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0), (2.0, 1.0)])?,
        times,
        NewtonParams::default(),
        LinearSolverKind::Cholesky,
    )
}

/// Runs [`fretting_blocks_model`] for `steps` steps writing `out` (full fields every
/// `fields_every` steps, a checkpoint every `checkpoint_every`, 0: none).
pub fn run_output_bench(
    steps: usize,
    fields_every: usize,
    checkpoint_every: usize,
    out: &std::path::Path,
) -> Result<OutputRun, String> {
    let model = fretting_blocks_model(steps).map_err(|e| e.to_string())?;
    let mut state = crate::analysis::StaticAnalysis::initial_state_of(&model);
    let mut writer = crate::io::ResultWriter::create(out, &model, "output-bench").map_err(|e| e.to_string())?;
    writer.set_fields_every(fields_every);
    writer.set_checkpoint_every(checkpoint_every);
    let mut output = 0.0;
    let start = Instant::now();
    crate::driver::run(&model, &mut state, crate::driver::RunOptions::default(), |r, s, m| {
        let t0 = Instant::now();
        writer.write_step(m, r, s).map_err(|e| e.to_string())?;
        output += t0.elapsed().as_secs_f64();
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    let t0 = Instant::now();
    let file = writer.finish(true).map_err(|e| e.to_string())?;
    output += t0.elapsed().as_secs_f64();
    let total = start.elapsed().as_secs_f64();
    let size = |p: &std::path::Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    let csv = std::path::PathBuf::from(format!("{}_contact.csv", file.with_extension("").display()));
    Ok(OutputRun {
        steps: model.times.len(),
        dofs: model.dofs.num_dofs,
        solve: total - output,
        output,
        h5_bytes: size(&file),
        csv_bytes: size(&csv),
    })
}

/// Re-cut after a surface move: a straight open surface crossing an `n x n` `Quad4` unit square
/// host, moving one cell down; returns (cells, band cells, cut cells, seconds per move: embed,
/// re-cut, refit, ghost penalty, DOF map, averaged over `moves` moves).
pub fn time_recut(n: usize, moves: usize) -> Result<(usize, usize, usize, f64), String> {
    use crate::discretisation::SurfaceMotion;
    use nalgebra::{Point2, Vector2};
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: 210_000.0, poisson: 0.3, hypothesis: hyp }));
    let host = generate::rectangle(0.0, 0.0, 1.0, 1.0, n, n, 1.0, 1.0, CellKind::Quad4).map_err(|e| e.to_string())?;
    let body = b.add_body("host", host, mi, Formulation::Standard, 1.0);
    let h = 1.0 / n as f64;
    let y0 = 0.5 + 0.37 * h;
    b.add_cut("surface", body, vec![Point2::new(-0.1, y0), Point2::new(1.1, y0 + 0.013)], false, false)
        .map_err(|e| e.to_string())?;
    let curve = b.add_curve(LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)]).map_err(|e| e.to_string())?);
    b.set_cut_motion("surface", SurfaceMotion::Translation { direction: Vector2::new(0.0, -h), curve })
        .map_err(|e| e.to_string())?;
    b.fix(body, "bottom", 0, 0.0).map_err(|e| e.to_string())?;
    b.fix(body, "bottom", 1, 0.0).map_err(|e| e.to_string())?;
    let mut model = b
        .build(
            LoadPath::new(vec![(0.0, 1.0), (1.0, 1.0)]).map_err(|e| e.to_string())?,
            vec![1.0],
            NewtonParams::default(),
            LinearSolverKind::Cholesky,
        )
        .map_err(|e| e.to_string())?;
    let band = model.bands[body].as_ref().map_or(0, |b| b.cells.len());
    let start = Instant::now();
    let mut cut = 0;
    for k in 1..=moves {
        let r = model.place_surfaces(k as f64 / moves as f64).map_err(|e| e.to_string())?;
        cut = r.cut_cells_by_degree.iter().sum::<usize>() + r.unfitted_cells;
    }
    Ok((n * n, band, cut, start.elapsed().as_secs_f64() / moves as f64))
}
