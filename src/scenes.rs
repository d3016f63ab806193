//! Model scenes shared by the tests, the criterion benches and `mortex bench`: an `n x n`
//! `Quad4` plane-strain block pressed on top, the Hertz cylinder-on-block scene (with its check
//! against Hertz' solution), a fretting-like pair of blocks, and the scenes where classical
//! multipliers fail under density contrast (a tied inclusion, Hertz contact with a finer
//! cylinder) that the tests and `mortex study stability` share. Nothing in the library uses
//! them; the timings of `mortex bench` live in the binary.

use crate::fem::kernel::Formulation;
use crate::fem::material::{Elastic, Material, PlaneHypothesis};
use crate::mesh::{generate, CellKind};
use crate::model::{LoadPath, Model, ModelBuilder};
use crate::solver::linear::LinearSolverKind;
use crate::solver::newton::NewtonParams;
use std::time::Instant;

/// What a stability scene measures of one multiplier space: the traction's deviation from its
/// reference (relative), and the number of multiplier nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiplierFigure {
    pub deviation: f64,
    pub multipliers: usize,
}

/// Why a scene could not be built or solved.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    #[error(transparent)]
    Analysis(#[from] crate::solve::AnalysisError),
    /// The least-squares Fourier fit of the tie tractions has a singular normal matrix.
    #[error("singular Fourier fit of {nodes} tie tractions with {harmonics} harmonics")]
    SingularFit { nodes: usize, harmonics: usize },
}

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
    let materials = HertzMaterials { cylinder: STEEL, block: STEEL };
    hertz_model_materials(h_core, cylinder_refinement, cylinder_core, virtual_top, multipliers, materials)
}

/// An isotropic elastic material: Young's modulus and Poisson's ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Isotropic {
    pub young: f64,
    pub poisson: f64,
}

/// Steel: E = 210 GPa, nu = 0.3 (MPa).
pub const STEEL: Isotropic = Isotropic { young: 210_000.0, poisson: 0.3 };
/// Aluminium: E = 70 GPa, nu = 0.33 (MPa).
pub const ALUMINIUM: Isotropic = Isotropic { young: 70_000.0, poisson: 0.33 };

/// The materials of the Hertz scene's two bodies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HertzMaterials {
    pub cylinder: Isotropic,
    pub block: Isotropic,
}

/// [`hertz_model_with`] with the cylinder's and the block's materials.
pub fn hertz_model_materials(
    h_core: f64,
    cylinder_refinement: f64,
    cylinder_core: f64,
    virtual_top: bool,
    multipliers: crate::mortar::MultiplierSpace,
    materials: HertzMaterials,
) -> Result<Model, crate::model::ModelError> {
    use crate::model::ContactOther;
    use nalgebra::{Point2, Vector2};
    const R: f64 = 10.0;
    const CORE: f64 = 0.5;
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let elastic = |m: Isotropic| Material::Elastic(Elastic { young: m.young, poisson: m.poisson, hypothesis: hyp });
    let mi_cyl = b.add_material("cylinder", elastic(materials.cylinder));
    let mi = b.add_material("block", elastic(materials.block));
    let n_core = (2.0 * CORE / h_core).round().max(2.0) as usize;
    let n_depth = (CORE / h_core).round().max(1.0) as usize;
    let top = if virtual_top { 0.013 } else { 0.0 };
    let gx = generate::plateau_graded(n_core, 2.0 * CORE / 40.0, 20);
    let gy = generate::end_plateau(n_depth, CORE / (20.0 + top), 20);
    let mesh_err =
        |e: crate::mesh::MeshError| crate::model::ModelError::Mesh { body: "hertz".into(), msg: e.to_string() };
    let (origin, size) = (Point2::new(-20.0, -20.0), Vector2::new(40.0, 20.0 + top));
    let block = generate::rectangle_from_divisions(origin, size, &gx, &gy, CellKind::Quad4).map_err(mesh_err)?;
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

pub fn run_hertz(h_core: f64, virtual_top: bool) -> Result<HertzRun, SceneError> {
    let start = Instant::now();
    let model = hertz_model(h_core, virtual_top)?;
    let mut analysis = crate::solve::StaticAnalysis::new(&model)?;
    let mut state = analysis.initial_state();
    let mut iterations = 0;
    analysis.run(&mut state, |r, _| {
        iterations += r.iterations;
        Ok(())
    })?;
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

/// Solves a one-step model to its end.
fn solve_to_end(model: &Model) -> Result<crate::state::SimState, SceneError> {
    let mut analysis = crate::solve::StaticAnalysis::new(model)?;
    let mut state = analysis.initial_state();
    analysis.run(&mut state, |_, _| Ok(()))?;
    Ok(state)
}

/// Remote load of the tied-inclusion scene ([`tied_inclusion_oscillation`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InclusionLoad {
    /// Uniform tension 100 MPa.
    Tension,
    /// Bending `sigma_xx = 20 (y - 5)` MPa.
    Bending,
}

/// Host modulus of the stability scenes (steel, MPa) and Poisson's ratio.
pub const STABILITY_E: f64 = 210_000.0;
pub const STABILITY_NU: f64 = 0.3;

/// A circular patch (radius 3 mm, `ratio` times finer than the host) tied into a 10 x 10 mm host
/// (20 x 20 cells) under remote tension or bending, plane strain, patch modulus `e_patch`: the
/// traction oscillation along the tie, `max abs(t - t_ref) / mean abs(t_ref)` over the
/// multiplier nodes, and their count. The reference `t_ref` is the least-squares Fourier series
/// of the computed traction up to the 4th harmonic (for an infinite host, Eshelby's inclusion
/// has first harmonics only: Eshelby, Proc. R. Soc. A 241 (1957); the finite host adds smooth
/// higher ones).
pub fn tied_inclusion_oscillation(
    ratio: usize,
    space: crate::mortar::MultiplierSpace,
    e_patch: f64,
    load: InclusionLoad,
) -> Result<MultiplierFigure, SceneError> {
    use nalgebra::{Point2, Vector2};
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let elastic = |young| Material::Elastic(Elastic { young, poisson: STABILITY_NU, hypothesis: hyp });
    let mh = b.add_material("host", elastic(STABILITY_E));
    let mp = b.add_material("patch", elastic(e_patch));
    let nh: usize = 20;
    let hh = 10.0 / nh as f64;
    let host = generate::rectangle(0.0, 0.0, 10.0, 10.0, nh, nh, 1.0, 1.0, CellKind::Quad4)?;
    let nodes = host.nodes.clone();
    let (right, left) = (host.edge_sets["right"].clone(), host.edge_sets["left"].clone());
    let h = b.add_body("host", host, mh, Formulation::Standard, 1.0);
    let (radius, c) = (3.0_f64, Point2::new(5.13, 4.91));
    let nt = ((std::f64::consts::TAU * radius) * ratio as f64 / hh).round() as usize;
    let nr = (radius * ratio as f64 / hh).round().max(2.0) as usize;
    let patch = generate::disc(c, radius, nr, nt)?;
    let p = b.add_body("patch", patch, mp, Formulation::Standard, 1.0);
    // Consistent nodal loads of the linear traction on the host's left and right edges.
    let stress = |y: f64| match load {
        InclusionLoad::Tension => 100.0,
        InclusionLoad::Bending => 20.0 * (y - 5.0),
    };
    for (edges, sign) in [(&left, -1.0), (&right, 1.0)] {
        for e in edges.iter() {
            let (ya, yb) = (nodes[e[0]].y, nodes[e[1]].y);
            let (len, sa, sb) = ((yb - ya).abs(), stress(ya), stress(yb));
            b.point_load_node(h, e[0], Vector2::new(sign * len * (2.0 * sa + sb) / 6.0, 0.0));
            b.point_load_node(h, e[1], Vector2::new(sign * len * (sa + 2.0 * sb) / 6.0, 0.0));
        }
    }
    // Nodes (0, 5) and (10, 5): on the mid-plane, where u_x = 0 in bending.
    let (n_l, n_r) = ((nh / 2) * (nh + 1), (nh / 2) * (nh + 1) + nh);
    b.fix_node(h, n_l, 1, 0.0);
    b.fix_node(h, n_l, 0, 0.0);
    b.fix_node(h, n_r, if load == InclusionLoad::Tension { 1 } else { 0 }, 0.0);
    b.add_tie("t", h, p, &["arc".to_string()], space)?;
    let model = b.build(
        LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)])?,
        vec![1.0],
        NewtonParams::default(),
        LinearSolverKind::Cholesky,
    )?;
    let s = solve_to_end(&model)?;
    let tie = &model.ties[0];
    let nl = tie.multipliers.num_nodes;
    let theta: Vec<f64> = tie.multipliers.points.iter().map(|x| (x.y - c.y).atan2(x.x - c.x)).collect();
    let harmonics = 4;
    let basis = |t: f64| {
        let mut v = vec![1.0];
        for k in 1..=harmonics {
            v.extend([(k as f64 * t).cos(), (k as f64 * t).sin()]);
        }
        v
    };
    let a = nalgebra::DMatrix::from_fn(nl, 2 * harmonics + 1, |i, j| basis(theta[i])[j]);
    let traction = |i: usize, comp: usize| -s.multipliers[tie.first_row + 2 * i + comp];
    let mut refs = vec![[0.0; 2]; nl];
    for comp in 0..2 {
        let t = nalgebra::DVector::from_fn(nl, |i, _| traction(i, comp));
        let coef = (a.transpose() * &a)
            .lu()
            .solve(&(a.transpose() * &t))
            .ok_or(SceneError::SingularFit { nodes: nl, harmonics })?;
        let fit = &a * coef;
        refs.iter_mut().zip(fit.iter()).for_each(|(r, f)| r[comp] = *f);
    }
    let (mut worst, mut mean) = (0.0f64, 0.0);
    for (i, r) in refs.iter().enumerate() {
        worst = worst.max(((traction(i, 0) - r[0]).powi(2) + (traction(i, 1) - r[1]).powi(2)).sqrt());
        mean += (r[0].powi(2) + r[1].powi(2)).sqrt() / nl as f64;
    }
    Ok(MultiplierFigure { deviation: worst / mean, multipliers: nl })
}

/// Hertz contact of [`hertz_model_with`] (block core elements `h`, cylinder `refine` times
/// finer, multipliers on the cylinder in `space`): the largest deviation of the nodal pressure
/// from Hertz over the nodes with `abs(x) <= frac a`, over p0, and the multiplier count.
pub fn hertz_density_deviation(
    h: f64,
    refine: f64,
    virtual_top: bool,
    space: crate::mortar::MultiplierSpace,
    frac: f64,
) -> Result<MultiplierFigure, SceneError> {
    let model = hertz_model_with(h, refine, 0.15, virtual_top, space)?;
    let s = solve_to_end(&model)?;
    let r = crate::post::AnalyticContact::hertz(100.0, 10.0, STABILITY_E / (2.0 * (1.0 - STABILITY_NU.powi(2))), 0.0);
    let prof = crate::post::contact_profile(model.initial(), &s, 0);
    let dev = prof
        .iter()
        .filter(|n| n.x.x.abs() <= frac * r.a)
        .map(|n| (n.pressure - r.pressure(n.x.x)).abs())
        .fold(0.0, f64::max)
        / r.p0;
    Ok(MultiplierFigure { deviation: dev, multipliers: model.initial().contact.pairs[0].multipliers.num_nodes })
}
