//! Hertz line contact, frictionless, plane strain (Johnson, *Contact Mechanics*, Cambridge,
//! 1985, sec. 4.3): cylinder R = 10 mm on a block 40 x 20 mm, both E = 210000 MPa, nu = 0.3,
//! load P = 100 N/mm: E* = 115384.6 MPa, a = sqrt(4 P R / (pi E*)) = 0.105046 mm,
//! p0 = 2 P / (pi a) = 606.04 MPa, p(x) = p0 sqrt(1 - x^2 / a^2).
//!
//!        ___
//!       /   \      half-disc, refined toward its lowest point; load P on its flat top
//!       \___/
//!   +-----o-----+  block refined toward the middle of its top; bottom fixed
//!   |           |
//!   +-----------+
//!
//! Small sliding: the pairing and normals come from the reference geometry (a/R = 1%).
//! Groundwork for the contact validation (not the validation itself): real surfaces only, one mesh. The
//! half-space formulas hold to a fraction of a percent for these finite bodies.
//! Note `half_disc`'s radial grading argument is centre/rim spacing (150: rim 150x finer).

mod common;
use common::solve;
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, Material, PlaneHypothesis};
use mortex::mesh::{generate, CellKind};
use mortex::model::{ContactOther, ModelBuilder};
use mortex::mortar::MultiplierSpace;
use nalgebra::{Point2, Vector2};

const E: f64 = 210_000.0;
const NU: f64 = 0.3;
const R: f64 = 10.0;
const LOAD: f64 = 100.0;

struct HertzResult {
    p0: f64,
    a: f64,
    l2: f64,
    dofs: usize,
}

fn hertz(nx: usize, ny: usize, nr: usize, nt: usize, grading_t: f64, grading_x: f64, virtual_top: bool) -> HertzResult {
    let gx = generate::graded_to_centre(nx, grading_x);
    let gy = generate::graded(ny, 1.0 / 300.0);
    let rs = generate::graded(nr, 1.0 / 150.0);
    let ts = generate::graded_to_centre(nt, grading_t);
    hertz_on(&gx, &gy, &rs, &ts, virtual_top)
}

/// Block grid lines `gx`, `gy` (fractions of 40 x 20 mm), cylinder rings `rs` and angles `ts`.
fn hertz_on(gx: &[f64], gy: &[f64], rs: &[f64], ts: &[f64], virtual_top: bool) -> HertzResult {
    let (nx, ny, nr, nt) = (gx.len() - 1, gy.len() - 1, rs.len() - 1, ts.len() - 1);
    let hyp = PlaneHypothesis::PlaneStrain;
    let e_star = E / (2.0 * (1.0 - NU * NU));
    let a_exact = (4.0 * LOAD * R / (std::f64::consts::PI * e_star)).sqrt();
    let p0_exact = 2.0 * LOAD / (std::f64::consts::PI * a_exact);
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
    // Virtual variant: the host block reaches 0.013 mm above the contact surface y = 0, which is
    // a virtual line cutting its top cells (host material kept below).
    let top = if virtual_top { 0.013 } else { 0.0 };
    let block = generate::rectangle_from_divisions(
        nalgebra::Point2::new(-20.0, -20.0),
        nalgebra::Vector2::new(40.0, 20.0 + top),
        gx,
        gy,
        CellKind::Quad4,
    )
    .unwrap();
    let cyl = generate::half_disc_from_divisions(Point2::new(0.0, R), R, rs, ts).unwrap();
    let bl = b.add_body("block", block, mi, Formulation::Standard, 1.0);
    let cy = b.add_body("cylinder", cyl, mi, Formulation::Standard, 1.0);
    b.fix(bl, "bottom", 0, 0.0).unwrap();
    b.fix(bl, "bottom", 1, 0.0).unwrap();
    b.fix(cy, "centre", 0, 0.0).unwrap();
    b.traction(cy, "top", Vector2::new(0.0, -LOAD / (2.0 * R))).unwrap();
    let other = if virtual_top {
        b.add_cut("surface", bl, vec![Point2::new(-21.0, 0.0), Point2::new(21.0, 0.0)], false, false).unwrap();
        ContactOther::Cut("surface".into())
    } else {
        ContactOther::Edges(b.global_edges(bl, &["top".to_string()]).unwrap())
    };
    b.add_contact("hertz", cy, &["arc".to_string()], bl, other, Default::default()).unwrap();
    let newton = mortex::solver::newton::NewtonParams { max_iterations: 60, ..Default::default() };
    let model = b
        .build(
            mortex::model::LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)]).unwrap(),
            vec![1.0],
            newton,
            Default::default(),
        )
        .unwrap();
    let s = solve(&model);
    let c = &model.initial().contact.pairs[0];
    let nt0 = model.constraints.len();
    let pts: Vec<(f64, f64)> = (0..c.multipliers.num_nodes)
        .map(|l| (c.multipliers.points[l].x, -s.multipliers[nt0 + c.first_row + l]))
        .collect();
    let p0 = pts.iter().map(|p| p.1).fold(0.0, f64::max);
    // Half-width from the load balance of a Hertzian profile fitted through the peak:
    // P = pi a p0 / 2 with the computed total force, and the outermost loaded node as a check.
    let total: f64 = {
        let mut v: Vec<(f64, f64)> = pts.clone();
        v.sort_by(|x, y| x.0.total_cmp(&y.0));
        v.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum()
    };
    let a_fit = 2.0 * total / (std::f64::consts::PI * p0);
    let exact = |x: f64| if x.abs() < a_exact { p0_exact * (1.0 - x * x / (a_exact * a_exact)).sqrt() } else { 0.0 };
    // L2 error over [-2a, 2a] of the piecewise-linear multiplier field (interpolated between the
    // multiplier nodes) against Hertz, 40 sub-samples per interval (the exact field has a square-
    // root edge that a node-only trapezoid rule would misjudge).
    let (mut num, mut den) = (0.0, 0.0);
    let mut v: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.0.abs() <= 2.5 * a_exact).collect();
    v.sort_by(|x, y| x.0.total_cmp(&y.0));
    for w in v.windows(2) {
        let (x0, x1) = (w[0].0, w[1].0);
        let k = 40;
        for i in 0..k {
            let x = x0 + (x1 - x0) * (i as f64 + 0.5) / k as f64;
            if x.abs() > 2.0 * a_exact {
                continue;
            }
            let ph = w[0].1 + (w[1].1 - w[0].1) * (x - x0) / (x1 - x0);
            let dx = (x1 - x0) / k as f64;
            num += (ph - exact(x)).powi(2) * dx;
            den += exact(x).powi(2) * dx;
        }
    }
    eprintln!(
        "Hertz {nx}x{ny} / {nr}x{nt} (virtual block surface: {virtual_top}): {} DOFs, p0 {p0:.2} ({:.3}%), a {a_fit:.5} ({:.3}%), load {total:.3}, pressure L2 {:.3}%",
        model.num_dofs(),
        100.0 * (p0 / p0_exact - 1.0),
        100.0 * (a_fit / a_exact - 1.0),
        100.0 * (num / den).sqrt()
    );
    HertzResult { p0: p0 / p0_exact - 1.0, a: a_fit / a_exact - 1.0, l2: (num / den).sqrt(), dofs: model.num_dofs() }
}

/// Peak pressure and half-width against Hertz (target tolerances: 1% and 2%). The pressure L2
/// error over [-2a, 2a] is reported, not asserted: these graded meshes coarsen to about a/5 at the
/// contact edge and give 4.9% (target 1% on a fine mesh: not reached yet).
#[test]
fn hertz_peak_pressure_and_half_width() {
    let r = hertz(120, 60, 60, 120, 300.0, 400.0, false);
    assert!(r.p0.abs() < 0.01, "p0 error {:.3}%", 100.0 * r.p0);
    assert!(r.a.abs() < 0.02, "half-width error {:.3}%", 100.0 * r.a);
    assert!(r.dofs > 20_000);
    eprintln!("pressure L2 error {:.2}% (reported)", 100.0 * r.l2);
}

/// The same with the block's surface virtual (MorteX): a line cutting the host's top cells.
#[test]
fn hertz_on_a_virtual_block_surface() {
    let r = hertz(120, 60, 60, 120, 300.0, 400.0, true);
    assert!(r.p0.abs() < 0.01, "p0 error {:.3}%", 100.0 * r.p0);
    assert!(r.a.abs() < 0.02, "half-width error {:.3}%", 100.0 * r.a);
    eprintln!("pressure L2 error {:.2}% (reported)", 100.0 * r.l2);
}

/// Meshes uniformly fine over |x| <= 0.25 mm (about 2.4 a): block plateau spacing 0.5 mm / n,
/// cylinder 1.5x finer, geometric growth outside.
fn hertz_plateau(n_fine: usize, virtual_top: bool) -> HertzResult {
    let gx = generate::plateau_graded(n_fine, 0.5 / 40.0, 40);
    let h = 0.5 / n_fine as f64;
    let ny = 70;
    // Top spacing about h: geometric growth downward over 20 mm.
    let gy = {
        let (mut lo, mut hi) = (1.0001f64, 2.0f64);
        for _ in 0..200 {
            let q = 0.5 * (lo + hi);
            let total: f64 = (0..ny).map(|i| h * q.powi(i as i32)).sum();
            if total < 20.0 {
                lo = q
            } else {
                hi = q
            }
        }
        let q = 0.5 * (lo + hi);
        let mut ys: Vec<f64> = (0..=ny).map(|j| (0..j).map(|i| h * q.powi(i as i32)).sum::<f64>()).collect();
        let top = ys[ny];
        ys.iter_mut().for_each(|y| *y = 1.0 - *y / top);
        ys.reverse();
        ys
    };
    let rs = generate::graded(80, 1.0 / 200.0);
    let ts = generate::plateau_graded(3 * n_fine / 2, (0.5 / R) / std::f64::consts::PI, 40);
    hertz_on(&gx, &gy, &rs, &ts, virtual_top)
}

/// The accuracy targets on a mesh uniformly fine over the contact (block 0.0025 mm,
/// cylinder 0.0017 mm over |x| <= 0.25 mm; 101k DOFs): p0 within 1%, a within 2%, pressure L2
/// over [-2a, 2a] within 1%, with the block surface real and virtual. Measured: real p0 +0.09%,
/// a -0.09%, L2 0.51%; virtual +0.12%, -0.12%, 0.71%. (`hertz_plateau_table` prints the
/// refinement: L2 4.7% / 1.4% / 0.5% at 44k / 63k / 101k DOFs.)
#[test]
fn hertz_pressure_on_a_fine_contact_mesh() {
    for virtual_top in [false, true] {
        let r = hertz_plateau(200, virtual_top);
        assert!(r.p0.abs() < 0.01, "virtual {virtual_top}: p0 error {:.3}%", 100.0 * r.p0);
        assert!(r.a.abs() < 0.02, "virtual {virtual_top}: half-width error {:.3}%", 100.0 * r.a);
        assert!(r.l2 < 0.01, "virtual {virtual_top}: pressure L2 error {:.3}%", 100.0 * r.l2);
    }
}

#[test]
#[ignore]
fn hertz_plateau_table() {
    for n in [50, 100, 200] {
        hertz_plateau(n, false);
        hertz_plateau(n, true);
    }
}

#[test]
#[ignore]
fn hertz_explore() {
    for (nx, ny, nr, nt, gt, gx) in [(120, 60, 60, 120, 300.0, 400.0), (200, 100, 80, 200, 100.0, 100.0)] {
        hertz(nx, ny, nr, nt, gt, gx, false);
        hertz(nx, ny, nr, nt, gt, gx, true);
    }
}

/// Max deviation of the nodal pressure from Hertz over the nodes with |x| <= `frac` a, over p0,
/// for a cylinder `refine` times finer than the block (block core elements `h`).
fn density_deviation(
    h: f64,
    refine: f64,
    virtual_top: bool,
    space: mortex::mortar::MultiplierSpace,
    frac: f64,
) -> (f64, usize) {
    let f = mortex::scenes::hertz_density_deviation(h, refine, virtual_top, space, frac).expect("Hertz scene");
    (f.deviation, f.multipliers)
}

/// curved-surface density contrast: a finely meshed cylinder (8x finer than the
/// block's 0.005 mm flat segments under the contact) carries the multipliers. Classical
/// multipliers (one per cylinder node, 8 per block segment) over-constrain the coarse side and
/// the pressure oscillates; coarse-grained ones (spaced like the block's segments) remove it.
/// Deviation = max over the multiplier nodes with |x| <= 0.9 a of |p - p_Hertz| / p0 (the band
/// 0.9 a < |x| < a, where Hertz' profile has an infinite slope, is left out: there every space
/// shows the edge's interpolation error, 5-6% at this block size). Target: coarse-grained
/// <= 2% of p0; classical reported (measured 5.06%) and asserted to exceed 2% (the failure the
/// stabilised space exists for is real here).
#[test]
fn coarse_grained_contact_multipliers_remove_density_oscillation() {
    use mortex::mortar::MultiplierSpace::*;
    let (classical, _) = density_deviation(0.005, 8.0, false, Classical, 0.9);
    let (coarse, n) = density_deviation(0.005, 8.0, false, CoarseGrained, 0.9);
    eprintln!(
        "cylinder 8x finer than the block: max pressure deviation classical {:.2}%, coarse-grained {:.2}% of p0 ({n} multipliers)",
        100.0 * classical,
        100.0 * coarse
    );
    assert!(coarse <= 0.02, "coarse-grained deviation {:.2}% of p0", 100.0 * coarse);
    assert!(classical > 0.02, "classical deviation {:.2}% of p0: no oscillation to remove?", 100.0 * classical);
}

#[test]
#[ignore]
fn density_explore() {
    use mortex::mortar::MultiplierSpace::*;
    let h: f64 = std::env::var("DH").ok().and_then(|s| s.parse().ok()).unwrap_or(0.005);
    for refine in [1.5, 8.0] {
        for space in [Classical, CoarseGrained] {
            for frac in [1.0, 0.9] {
                let (d, n) = density_deviation(h, refine, false, space, frac);
                eprintln!(
                    "refine {refine}, {space:?}, |x| <= {frac} a: max deviation {:.2}% of p0 ({n} multipliers)",
                    100.0 * d
                );
            }
        }
    }
}

/// Stability where the classical space fails, on a curved contact: the cylinder (which carries
/// the multipliers) 1, 2, 4, 8 and 12 times finer than the block's 0.005 mm segments under the
/// contact; largest deviation of the nodal pressure from Hertz over |x| <= 0.9 a, over p0, for
/// both multiplier spaces (the table and chart: `mortex study stability`).
/// Checks what the chart shows: the classical deviation grows with every step of contrast
/// (0.7% to 5.7% of p0); the coarse-grained one does not grow (at 12x within 10% of its 2x
/// value) and is below half the classical one from 4x on. (It stays near 2% of p0 at 2x and
/// 12x, 2.07% and 2.09%: the 2% the 8x test asks for is missed there by a hair.)
#[test]
#[ignore]
fn stability_density_contrast_curved_contact() {
    let mut classical = Vec::new();
    let mut coarse = Vec::new();
    for refine in [1.0, 2.0, 4.0, 8.0, 12.0] {
        let (c, _) = density_deviation(0.005, refine, false, MultiplierSpace::Classical, 0.9);
        let (g, _) = density_deviation(0.005, refine, false, MultiplierSpace::CoarseGrained, 0.9);
        classical.push((refine, 100.0 * c));
        coarse.push((refine, 100.0 * g));
    }
    assert!(classical.windows(2).all(|w| w[1].1 > w[0].1), "classical should grow: {classical:?}");
    assert!(coarse[4].1 <= 1.1 * coarse[1].1, "coarse-grained grows: {coarse:?}");
    for k in 2..5 {
        assert!(coarse[k].1 < 0.5 * classical[k].1, "at {}x: {coarse:?} against {classical:?}", coarse[k].0);
    }
}

/// Pressure L2 error at block core h = 0.005 mm against the cylinder's refinement (README):
/// refining only the multiplier side does not lower it (1:3 oscillates, classical multipliers).
#[test]
#[ignore]
fn hertz_cylinder_refinement_table() {
    let e_star = E / (2.0 * (1.0 - NU * NU));
    let a = (4.0 * LOAD * R / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * LOAD / (std::f64::consts::PI * a);
    let exact = |x: f64| if x.abs() < a { p0 * (1.0 - x * x / (a * a)).sqrt() } else { 0.0 };
    for (h, refine) in [(0.005, 1.0), (0.005, 1.5), (0.005, 3.0), (0.0033333, 1.0), (0.0025, 1.5)] {
        let space = mortex::mortar::MultiplierSpace::Classical;
        let model = mortex::scenes::hertz_model_with(h, refine, 0.5, false, space).expect("model");
        let s = solve(&model);
        let prof: Vec<(f64, f64)> =
            mortex::post::contact_profile(model.initial(), &s, 0).iter().map(|n| (n.x.x, n.pressure)).collect();
        let l2 = mortex::post::relative_l2_error(&prof, exact, -2.0 * a, 2.0 * a);
        eprintln!("h {h} refine {refine} {space:?}: {} dofs, L2 {:.3}%", model.num_dofs(), 100.0 * l2);
    }
}

/// The dissimilar-materials scene: steel cylinder (R = 10 mm, E = 210 GPa, nu = 0.3) on an
/// aluminium block (E = 70 GPa, nu = 0.33), P = 100 N/mm, frictionless; the cylinder's core
/// `refine` times finer than the block's (block core h); multipliers on the cylinder in `space`.
/// Returns (p0 error, pressure L2 over [-2a, 2a]) against Hertz with
/// `1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`.
fn dissimilar(h: f64, refine: f64, space: MultiplierSpace) -> (f64, f64) {
    use mortex::scenes::{hertz_model_materials, HertzMaterials, ALUMINIUM, STEEL};
    let materials = HertzMaterials { cylinder: STEEL, block: ALUMINIUM };
    let model = hertz_model_materials(h, refine, 0.5, false, space, materials).unwrap();
    let s = solve(&model);
    let e_star = 1.0
        / ((1.0 - STEEL.poisson * STEEL.poisson) / STEEL.young
            + (1.0 - ALUMINIUM.poisson * ALUMINIUM.poisson) / ALUMINIUM.young);
    let a = (4.0 * 100.0 * 10.0 / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * 100.0 / (std::f64::consts::PI * a);
    let prof: Vec<(f64, f64)> =
        mortex::post::contact_profile(model.initial(), &s, 0).iter().map(|n| (n.x.x, n.pressure)).collect();
    let peak = prof.iter().map(|p| p.1).fold(0.0, f64::max);
    let exact = |x: f64| if x.abs() < a { p0 * (1.0 - x * x / (a * a)).sqrt() } else { 0.0 };
    (peak / p0 - 1.0, mortex::post::relative_l2_error(&prof, exact, -2.0 * a, 2.0 * a))
}

/// Steel cylinder (3x finer than the block at the contact) on an aluminium block, with the
/// case-file default multipliers (coarse-grained on the cylinder): p0 within 1% of Hertz and
/// the pressure L2 error decreasing under two refinements (block h = 0.02, 0.01, 0.005 mm;
/// a = 0.147 mm). Measured: p0 +0.26 / +0.02 / -0.02%, L2 5.5 / 3.0 / 1.18%. Classical
/// multipliers on the same meshes: p0 +14 / +7.1 / +3.5% (they oscillate on the finer side).
#[test]
fn dissimilar_hertz_default_multipliers_converge() {
    let space = mortex::case::DEFAULT_CONTACT_MULTIPLIERS;
    let runs: Vec<(f64, f64)> = [0.02, 0.01, 0.005].iter().map(|&h| dissimilar(h, 3.0, space)).collect();
    for (h, (e0, l2)) in [0.02, 0.01, 0.005].iter().zip(&runs) {
        eprintln!("h {h}: p0 {:+.3}%, L2 {:.3}%", 100.0 * e0, 100.0 * l2);
        assert!(e0.abs() < 0.01, "h {h}: p0 error {e0:e}");
    }
    assert!(runs[1].1 < runs[0].1 && runs[2].1 < runs[1].1, "L2 must decrease: {runs:?}");
}

#[test]
#[ignore]
fn dissimilar_explore() {
    for refine in [1.5, 3.0] {
        for space in [MultiplierSpace::Classical, MultiplierSpace::CoarseGrained] {
            for h in [0.02, 0.01, 0.005] {
                let (e0, l2) = dissimilar(h, refine, space);
                eprintln!("refine {refine} {space:?} h {h}: p0 {:+.3}%, L2 {:.3}%", 100.0 * e0, 100.0 * l2);
            }
        }
    }
}

/// One output step: interface iterations, cut-backs, pressure profile `(x, p)` sorted by x.
type StepProfile = (usize, usize, Vec<(f64, f64)>);

/// Runs the shipped `hertz` case on a mesh four times finer in the contact (cylinder 800
/// angular divisions, block 1,280) along the load `path`, one increment per segment: per output
/// step, the interface iterations, the cut-backs and the pressure profile `(x, p)` sorted by x.
fn fine_hertz_path(path: &str, increments: usize) -> Vec<StepProfile> {
    let text = std::fs::read_to_string("wear_cases/hertz.toml")
        .expect("shipped case")
        .replace("divisions = [40, 200]", "divisions = [40, 800]")
        .replace("divisions = [160, 40]", "divisions = [1280, 40]")
        .replace("path = [[0.0, 0.0], [1.0, 1.0]]", &format!("path = {path}"))
        .replace("increments = 1", &format!("increments = {increments}"));
    let case = mortex::case::parse(&text, "hertz", std::path::Path::new("wear_cases"), "hertz")
        .unwrap_or_else(|e| panic!("{e}"));
    let model = case.model;
    let mut analysis = mortex::solve::StaticAnalysis::new(&model).expect("set-up");
    let mut state = analysis.initial_state();
    let mut steps = vec![];
    analysis
        .run(&mut state, |report, st| {
            let f = mortex::contact::contact_field(&model.initial().contact, &st.contact_unknowns(), 0);
            let mut prof: Vec<(f64, f64)> = f.iter().map(|n| (n.position.x, n.pressure)).collect();
            prof.sort_by(|u, v| u.0.total_cmp(&v.0));
            steps.push((report.iterations, report.cutbacks, prof));
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    steps
}

/// Unloading a fine Hertz contact in one increment, from `P` to `P / 16`: the half-width falls
/// from `a` to `a / 4`. The interface iterations start from the loaded contact set (153
/// multiplier nodes), four times too wide, and release it a node or two per side and iteration
/// (the outermost node in contact takes the tension): 28 iterations here, more than the Newton
/// limit (25). They are bounded by the number of live contact rows instead, so the increment
/// settles without a cut-back (before: one cut-back; under friction with every node slipping
/// one way, a false "gross sliding" error, which stopped the McColl case on a mesh four times
/// finer).
/// - Frictionless elasticity does not depend on the path: the unloaded pressure equals the one
///   loaded directly to `P / 16` at every multiplier node, within 1e-6 of the peak (both
///   solves stop at a relative force residual of 1e-9, and the pressures of two such solves
///   may differ by the interface operator's conditioning times that; measured 3.5e-8).
/// - It is Hertz's at `P / 16` (peak `p0 / 4`, half-width `a / 4` from the load and the peak)
///   within 2%: 55 nodes in contact now against 153 at the full load, whose peak is within
///   0.14% (measured -0.96% and +0.94% unloaded).
#[test]
fn hertz_unloading_in_one_increment_settles_without_cut_back() {
    let unloaded = fine_hertz_path("[[0.0, 0.0], [1.0, 1.0], [2.0, 0.0625]]", 2);
    let direct = fine_hertz_path("[[0.0, 0.0], [1.0, 0.0625]]", 1);
    let e_star = E / (2.0 * (1.0 - NU * NU));
    for (step, (iterations, cutbacks, prof)) in unloaded.iter().enumerate() {
        let p = LOAD * [1.0, 0.0625][step];
        let a = (4.0 * p * R / (std::f64::consts::PI * e_star)).sqrt();
        let p0 = 2.0 * p / (std::f64::consts::PI * a);
        let load: f64 = prof.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum();
        let peak = prof.iter().map(|q| q.1).fold(0.0, f64::max);
        let a_fit = 2.0 * load / (std::f64::consts::PI * peak);
        let in_contact = prof.iter().filter(|q| q.1 > 0.0).count();
        eprintln!(
            "step {}: {iterations} interface iterations, {cutbacks} cut-backs; {in_contact} nodes in contact; p_max {peak:.2} against {p0:.2} ({:+.2}%), a {a_fit:.5} against {a:.5} ({:+.2}%), load {:+.3}%",
            step + 1,
            100.0 * (peak / p0 - 1.0),
            100.0 * (a_fit / a - 1.0),
            100.0 * (load / p - 1.0)
        );
        assert_eq!(*cutbacks, 0, "step {}: cut back", step + 1);
        assert!((peak / p0 - 1.0).abs() < 0.02, "step {}: p_max {peak} against {p0}", step + 1);
        assert!((a_fit / a - 1.0).abs() < 0.02, "step {}: a {a_fit} against {a}", step + 1);
    }
    let (u, d) = (&unloaded[1].2, &direct[0].2);
    let peak = d.iter().map(|q| q.1).fold(0.0, f64::max);
    let worst = u.iter().zip(d).map(|(a, b)| (a.1 - b.1).abs()).fold(0.0, f64::max) / peak;
    eprintln!("unloaded against loaded directly: {worst:.2e} of the peak");
    assert!(worst < 1e-6, "unloaded against loaded directly: {worst:.2e}");
}
