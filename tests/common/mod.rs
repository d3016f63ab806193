//! Helpers shared by the integration tests.
#![allow(dead_code)]

use mortex::fem::element::{MappedElement, ShapeEval};
use mortex::model::Model;
use mortex::solve::StaticAnalysis;
use mortex::state::SimState;
use nalgebra::Point2;

/// A result file `<name>` in this process's scratch directory `mortex-<kind>-<pid>` of the temp
/// dir; when dropped it removes the file, its XDMF and contact CSV, and the directory once
/// empty (a shipped case writes up to 800 MB: repeated test runs must not fill the disk).
pub struct ResultFiles(pub std::path::PathBuf);

impl ResultFiles {
    pub fn in_scratch(kind: &str, name: &str) -> Self {
        let d = std::env::temp_dir().join(format!("mortex-{kind}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        ResultFiles(d.join(name))
    }
}

impl std::ops::Deref for ResultFiles {
    type Target = std::path::PathBuf;
    fn deref(&self) -> &std::path::PathBuf {
        &self.0
    }
}

impl AsRef<std::path::Path> for ResultFiles {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for ResultFiles {
    fn drop(&mut self) {
        let stem = self.0.with_extension("");
        let csv = std::path::PathBuf::from(format!("{}_contact.csv", stem.display()));
        for f in [self.0.clone(), self.0.with_extension("xdmf"), csv] {
            let _ = std::fs::remove_file(f);
        }
        if let Some(dir) = self.0.parent() {
            let _ = std::fs::remove_dir(dir);
        }
    }
}

/// A scratch directory `mortex-<kind>-<name>-<pid>` in the temp dir, emptied when made and
/// removed when dropped, unless the test is failing (then it stays, to look at).
pub struct ScratchDir(pub std::path::PathBuf);

impl ScratchDir {
    pub fn new(kind: &str, name: &str) -> Self {
        let d = std::env::temp_dir().join(format!("mortex-{kind}-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        ScratchDir(d)
    }
}

impl std::ops::Deref for ScratchDir {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for ScratchDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

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

/// Two cylinders (R = 10 mm each, half discs), both steel (E = 210000 MPa, nu = 0.3), plane
/// strain, touching at the origin: the Hertz / Cattaneo-Mindlin scene of the contact validation (the seed's
/// example; the point symmetry of the pair keeps the normal and tangential problems uncoupled,
/// which a cylinder on a shear-loaded block does not quite do). Each mesh is uniformly fine over
/// |x| <= `core` and as deep (upper: 2 core / (1.5 n_fine), lower: 2 core / n_fine) and coarse
/// away from the contact. The upper cylinder's flat top is a rigid platen (no rotation)
/// loaded at its master node: normal force `-P` on curve 0 (the load path), tangential force
/// `Q` on curve 1; the lower cylinder's flat bottom is fixed. `virtual_lower`: the lower cylinder
/// is a circle cut out of a rectangular host mesh (21 x 10 mm, fine under the contact) by a
/// virtual surface (MorteX); otherwise its own half-disc mesh (classical mortar).
pub struct CylinderPair {
    /// Divisions of the lower body over the uniformly fine zone |x| <= `core` (the upper one
    /// has 1.5x as many).
    pub n_fine: usize,
    /// Half-width (and depth) of the uniformly fine zone, mm.
    pub core: f64,
    pub virtual_lower: bool,
    /// Coarse-grained contact multipliers (else classical).
    pub coarse_grained: bool,
    pub mu: f64,
    pub normal_load: f64,
    /// `(time, factor)` of the normal force (factor 1 = `normal_load`).
    pub normal_path: Vec<(f64, f64)>,
    /// `(time, Q)` of the tangential force on the platen (N/mm).
    pub tangential_path: Vec<(f64, f64)>,
    pub times: Vec<f64>,
}

pub const CYL_E: f64 = 210_000.0;
pub const CYL_NU: f64 = 0.3;
pub const CYL_R: f64 = 10.0;

impl CylinderPair {
    pub fn build(&self) -> Model {
        use mortex::fem::kernel::Formulation;
        use mortex::fem::material::{Elastic, Material, PlaneHypothesis};
        use mortex::mesh::{generate, CellKind};
        use mortex::model::{ContactOther, LoadPath, ModelBuilder};
        use nalgebra::Vector2;
        use std::f64::consts::PI;
        let hyp = PlaneHypothesis::PlaneStrain;
        let mut b = ModelBuilder::new(hyp);
        let mi = b.add_material("steel", Material::Elastic(Elastic { young: CYL_E, poisson: CYL_NU, hypothesis: hyp }));
        let w = self.core;
        // Rings: uniform over the outer `w` of the radius (square cells under the contact).
        let rings = |n_arc: usize| generate::end_plateau((n_arc / 2).max(1), w / CYL_R, 40);
        let arc_grid = |n: usize| generate::plateau_graded(n, (2.0 * w / CYL_R) / PI, 40);
        let n_up = 3 * self.n_fine / 2;
        let upper = generate::half_disc_from_divisions(Point2::new(0.0, CYL_R), CYL_R, &rings(n_up), &arc_grid(n_up))
            .expect("cylinder mesh");
        let lower = if self.virtual_lower {
            let gx = generate::plateau_graded(self.n_fine, 2.0 * w / 21.0, 40);
            let height = CYL_R + 0.013;
            let gy = generate::end_plateau((self.n_fine / 2).max(1), (w + 0.013) / height, 40);
            generate::rectangle_from_divisions(
                nalgebra::Point2::new(-10.5, -CYL_R),
                nalgebra::Vector2::new(21.0, height),
                &gx,
                &gy,
                CellKind::Quad4,
            )
            .expect("host mesh")
        } else {
            // The upper half disc turned by 180 degrees (a rotation keeps the cells' orientation).
            let mut m = generate::half_disc_from_divisions(
                Point2::new(0.0, CYL_R),
                CYL_R,
                &rings(self.n_fine),
                &arc_grid(self.n_fine),
            )
            .expect("cylinder mesh");
            m.nodes.iter_mut().for_each(|p| *p = Point2::new(-p.x, -p.y));
            m
        };
        let lo = b.add_body("lower", lower, mi, Formulation::Standard, 1.0);
        let up = b.add_body("upper", upper, mi, Formulation::Standard, 1.0);
        let base = if self.virtual_lower { "bottom" } else { "top" };
        b.fix(lo, base, 0, 0.0).expect("set");
        b.fix(lo, base, 1, 0.0).expect("set");
        let master = b.rigid_set(up, "top").expect("set");
        b.point_load_node(up, master, Vector2::new(0.0, -self.normal_load));
        let tc = b.add_curve(LoadPath::new(self.tangential_path.clone()).expect("path"));
        b.use_curve(tc);
        b.point_load_node(up, master, Vector2::new(1.0, 0.0));
        b.use_curve(0);
        let other = if self.virtual_lower {
            // Left end to right end over the top (the circle's inside on the right), leaving the
            // host through its bottom along vertical tangents (no vertex on the host boundary).
            let arc: Vec<Point2<f64>> = arc_grid(2 * self.n_fine)
                .iter()
                .map(|t| PI * (t - 0.5))
                .filter(|th| th.cos() > 0.05)
                .map(|th| Point2::new(CYL_R * th.sin(), -CYL_R + CYL_R * th.cos()))
                .collect();
            let mut v = vec![Point2::new(arc[0].x, -CYL_R - 1.0)];
            v.extend(arc.iter().copied());
            v.push(Point2::new(arc[arc.len() - 1].x, -CYL_R - 1.0));
            b.add_cut("surface", lo, v, false, false).expect("cut");
            ContactOther::Cut("surface".into())
        } else {
            ContactOther::Edges(b.global_edges(lo, &["arc".to_string()]).expect("set"))
        };
        let multipliers = if self.coarse_grained {
            mortex::mortar::MultiplierSpace::CoarseGrained
        } else {
            mortex::mortar::MultiplierSpace::Classical
        };
        let params = mortex::model::ContactParams { friction: self.mu, multipliers, ..Default::default() };
        b.add_contact("c", up, &["arc".to_string()], lo, other, params).expect("contact");
        let newton = mortex::solver::newton::NewtonParams { max_iterations: 60, ..Default::default() };
        b.build(LoadPath::new(self.normal_path.clone()).expect("path"), self.times.clone(), newton, Default::default())
            .expect("model")
    }
}

/// Hertz half-width and peak pressure of the pair (R_eff = R / 2) for a normal load `p`.
pub fn hertz_a_p0(p: f64) -> (f64, f64) {
    let e_star = CYL_E / (2.0 * (1.0 - CYL_NU * CYL_NU));
    let a = (4.0 * p * (CYL_R / 2.0) / (std::f64::consts::PI * e_star)).sqrt();
    (a, 2.0 * p / (std::f64::consts::PI * a))
}

/// `(x, p, q, status)` at each multiplier node of contact 0, sorted by x (see
/// `mortex::post::contact_profile`).
pub fn contact_profile(model: &Model, s: &SimState) -> Vec<(f64, f64, f64, u8)> {
    mortex::post::contact_profile(model.initial(), s, 0)
        .iter()
        .map(|n| (n.x.x, n.pressure, n.shear, n.status))
        .collect()
}

#[allow(unused_imports)]
pub use mortex::post::relative_l2_error as l2_error;
