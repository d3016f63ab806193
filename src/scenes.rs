//! Model scenes shared by the tests, the criterion benches and `mortex bench`: an `n x n`
//! `Quad4` plane-strain block pressed on top, the Hertz cylinder-on-block scene (with its check
//! against Hertz' solution), and a fretting-like pair of blocks. Nothing in the library uses
//! them; the timings of `mortex bench` live in the binary.

use crate::fem::kernel::Formulation;
use crate::fem::material::{Elastic, Material, PlaneHypothesis};
use crate::mesh::{generate, CellKind};
use crate::model::{LoadPath, Model, ModelBuilder};
use crate::solver::linear::LinearSolverKind;
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
        crate::post::contact_profile(model.initial(), &state, 0).iter().map(|n| (n.x.x, n.pressure)).collect();
    let peak = prof.iter().map(|p| p.1).fold(0.0, f64::max);
    let load: f64 = prof.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum();
    let a_fit = 2.0 * load / (std::f64::consts::PI * peak);
    let exact = |x: f64| if x.abs() < a { p0 * (1.0 - x * x / (a * a)).sqrt() } else { 0.0 };
    Ok(HertzRun {
        dofs: model.num_dofs(),
        seconds,
        iterations,
        p0_error: peak / p0 - 1.0,
        a_error: a_fit / a - 1.0,
        l2_error: crate::post::relative_l2_error(&prof, exact, -2.0 * a, 2.0 * a),
    })
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
