//! J2 plasticity checks.
//!
//! 1. Thick-walled cylinder, elastic-perfectly-plastic, plane strain (Hill, *The Mathematical
//!    Theory of Plasticity*, Oxford, 1950, ch. V): plastic zone `a <= r <= c` with
//!    `p = (sigma_y / sqrt 3) [2 ln(c/a) + 1 - c^2/b^2]`. Sketch: quarter annulus a = 1, b = 2 mm,
//!    40 x 10 B-bar Quad4, symmetry on both straight edges, pressure on r = a.
//!    nu = 0.49 because Hill's solution assumes `sigma_z = (sigma_r + sigma_t)/2` (exact only
//!    for incompressibility). Tolerance: 2% on the plastic radius.
//! 2. Single material point: radial return against the closed-form response to pure shear
//!    (monotonic, and a full kinematic-hardening cycle), to round-off.

mod common;
use common::solve;
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{
    von_mises, Elastic, J2Plastic, Material, PlaneHypothesis, PlasticState, Strain4, Stress4, Tangent4,
};
use mortex::mesh::generate;
use mortex::model::{LoadPath, ModelBuilder};
use mortex::solver::linear::LinearSolverKind;
use mortex::solver::newton::NewtonParams;

const A_IN: f64 = 1.0;
const B_OUT: f64 = 2.0;
/// The quarter annulus of the Lame problem.
const QUARTER: generate::Sector =
    generate::Sector { r_in: A_IN, r_out: B_OUT, theta0: 0.0, theta1: std::f64::consts::FRAC_PI_2 };
const SY: f64 = 250.0;

fn hill_pressure(c: f64) -> f64 {
    SY / 3f64.sqrt() * (2.0 * (c / A_IN).ln() + 1.0 - c * c / (B_OUT * B_OUT))
}

#[test]
fn thick_cylinder_plastic_radius_matches_hill() {
    let hyp = PlaneHypothesis::PlaneStrain;
    let mat = J2Plastic {
        elastic: Elastic { young: 210_000.0, poisson: 0.49, hypothesis: hyp },
        yield_stress: SY,
        isotropic_hardening: 0.0,
        kinematic_hardening: 0.0,
    };
    let mesh = generate::annulus_sector(QUARTER, 40, 10, 1.0).unwrap();
    let h = (B_OUT - A_IN) / 40.0;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::J2Plastic(mat));
    let body = b.add_body("cylinder", mesh, mi, Formulation::BBar, 1.0);
    b.fix(body, "start", 1, 0.0).unwrap();
    b.fix(body, "end", 0, 0.0).unwrap();
    b.pressure(body, "inner", 1.0).unwrap();
    let targets = [1.2, 1.4, 1.6, 1.8];
    let p_targets: Vec<f64> = targets.iter().map(|&c| hill_pressure(c)).collect();
    // 30 increments up to the last target, plus the target pressures themselves.
    let p_max = p_targets[3];
    let mut times: Vec<f64> = (1..=30).map(|i| p_max * i as f64 / 30.0).collect();
    times.extend_from_slice(&p_targets);
    times.sort_by(f64::total_cmp);
    times.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    let model = b
        .build(
            LoadPath::new(vec![(0.0, 0.0), (p_max, p_max)]).unwrap(),
            times.clone(),
            NewtonParams::default(),
            LinearSolverKind::Cholesky,
        )
        .unwrap();
    let mut an = mortex::solve::StaticAnalysis::new(&model).unwrap();
    let mut s = an.initial_state();
    let pts = model.initial().point_coords(&model);
    let mut checked = 0;
    an.run(&mut s, |rep, st| {
        let Some(k) = p_targets.iter().position(|&p| (p - rep.time).abs() < 1e-9) else {
            return Ok(());
        };
        // Plastic radius estimate: in the elastic zone sigma_eq = sigma_y (c/r)^2 (Lame with the
        // yield condition at r = c), so each elastic point in the first elastic ring gives c.
        let r: Vec<f64> = pts.iter().map(|p| p.coords.norm()).collect();
        let r_el_min =
            (0..pts.len()).filter(|&q| st.history[q].alpha == 0.0).map(|q| r[q]).fold(f64::INFINITY, f64::min);
        let ring: Vec<f64> = (0..pts.len())
            .filter(|&q| st.history[q].alpha == 0.0 && r[q] < r_el_min + 0.25 * h)
            .map(|q| r[q] * (von_mises(&st.stress[q]) / SY).sqrt())
            .collect();
        let c_fe = ring.iter().sum::<f64>() / ring.len() as f64;
        let err = (c_fe - targets[k]).abs() / targets[k];
        eprintln!(
            "p = {:.3} MPa: Hill c = {:.4}, FE c = {:.4} ({} points), error {:.3}%",
            rep.time,
            targets[k],
            c_fe,
            ring.len(),
            100.0 * err
        );
        assert!(err < 0.02, "plastic radius error {err} at p = {}", rep.time);
        checked += 1;
        Ok(())
    })
    .unwrap();
    assert_eq!(checked, targets.len());
}

fn shear_material(k_iso: f64, h_kin: f64) -> J2Plastic {
    J2Plastic {
        elastic: Elastic { young: 200_000.0, poisson: 0.3, hypothesis: PlaneHypothesis::PlaneStrain },
        yield_stress: SY,
        isotropic_hardening: k_iso,
        kinematic_hardening: h_kin,
    }
}

/// Pure shear `g_xy = gamma`: the 3D return reduces to the 1D law `tau = mu (gamma - gamma_p)`,
/// `|tau - b| <= tau_y`, `b = H gamma_p / 3`, `tau_y = (sigma_y + K alpha)/sqrt 3`, `alpha =
/// |gamma_p|_acc / sqrt 3`; on monotonic loading past `gamma_y = tau_y / mu`:
/// `tau = tau_y + E_t (gamma - gamma_y)` with `E_t = mu c/(mu + c)`, `c = (H + K)/3`.
fn tau_monotonic(m: &J2Plastic, gamma: f64) -> f64 {
    let mu = m.elastic.shear_modulus();
    let ty = SY / 3f64.sqrt();
    let c = (m.isotropic_hardening + m.kinematic_hardening) / 3.0;
    let gy = ty / mu;
    if gamma <= gy {
        mu * gamma
    } else {
        ty + mu * c / (mu + c) * (gamma - gy)
    }
}

#[test]
fn radial_return_matches_closed_form_in_one_step_and_many() {
    let m = shear_material(1500.0, 2500.0);
    let mu = m.elastic.shear_modulus();
    let gy = SY / 3f64.sqrt() / mu;
    for &g in &[0.5 * gy, 1.5 * gy, 4.0 * gy, 40.0 * gy] {
        let exact = tau_monotonic(&m, g);
        // One step from the virgin state.
        let (mut s, mut d, mut st) = (Stress4::zeros(), Tangent4::zeros(), PlasticState::default());
        m.update(&Strain4::new(0.0, 0.0, 0.0, g), &PlasticState::default(), &mut st, &mut s, &mut d);
        // Round-off: 1e-12 relative to the stress.
        assert!((s[3] - exact).abs() < 1e-12 * exact, "one step, gamma = {g}: {} vs {exact}", s[3]);
        assert!(s[0].abs() < 1e-12 * exact && s[1].abs() < 1e-12 * exact && s[2].abs() < 1e-12 * exact);
        // 50 steps.
        let mut old = PlasticState::default();
        for i in 1..=50 {
            let mut new = PlasticState::default();
            m.update(&Strain4::new(0.0, 0.0, 0.0, g * i as f64 / 50.0), &old, &mut new, &mut s, &mut d);
            old = new;
        }
        assert!((s[3] - exact).abs() < 1e-12 * exact, "50 steps, gamma = {g}: {} vs {exact}", s[3]);
        // Equivalent plastic strain: alpha = gamma_p / sqrt 3 with gamma_p = gamma - tau/mu.
        let alpha = (g - exact / mu) / 3f64.sqrt();
        assert!((old.alpha - alpha).abs() < 1e-12 * (alpha.abs() + gy), "alpha {} vs {alpha}", old.alpha);
    }
}

/// A strain cycle 0 -> +g_max -> -g_max -> +g_max with pure kinematic hardening: reverse
/// yielding starts at `tau_max - 2 tau_y` (Bauschinger effect) and the loop closes after one
/// cycle. Every step is compared with the closed-form piecewise-linear loop.
#[test]
fn kinematic_hardening_loop() {
    let m = shear_material(0.0, 20_000.0);
    let mu = m.elastic.shear_modulus();
    let ty = SY / 3f64.sqrt();
    let c = m.kinematic_hardening / 3.0;
    let et = mu * c / (mu + c);
    let gy = ty / mu;
    let gmax = 5.0 * gy;
    let tmax = ty + et * (gmax - gy);
    // Closed form of the branches.
    let down = |g: f64| {
        let t_el = tmax - mu * (gmax - g);
        let t_rev = tmax - 2.0 * ty;
        if t_el >= t_rev {
            t_el
        } else {
            let g_rev = gmax - 2.0 * ty / mu;
            t_rev - et * (g_rev - g)
        }
    };
    let tmin = down(-gmax);
    assert!((tmin + tmax).abs() < 1e-9 * tmax, "symmetric loop expected: {tmin} vs {tmax}");
    let up = |g: f64| {
        let t_el = tmin + mu * (g + gmax);
        let t_rev = tmin + 2.0 * ty;
        if t_el <= t_rev {
            t_el
        } else {
            let g_rev = -gmax + 2.0 * ty / mu;
            t_rev + et * (g - g_rev)
        }
    };
    let n = 40;
    let mut path: Vec<(f64, f64)> = vec![];
    for i in 1..=n {
        let g = gmax * i as f64 / n as f64;
        path.push((g, tau_monotonic(&m, g)));
    }
    for i in 1..=2 * n {
        let g = gmax - 2.0 * gmax * i as f64 / (2 * n) as f64;
        path.push((g, down(g)));
    }
    for i in 1..=2 * n {
        let g = -gmax + 2.0 * gmax * i as f64 / (2 * n) as f64;
        path.push((g, up(g)));
    }
    let mut old = PlasticState::default();
    let (mut s, mut d) = (Stress4::zeros(), Tangent4::zeros());
    let mut dissipation = 0.0;
    let mut prev = (0.0, 0.0);
    for (k, &(g, exact)) in path.iter().enumerate() {
        let mut new = PlasticState::default();
        m.update(&Strain4::new(0.0, 0.0, 0.0, g), &old, &mut new, &mut s, &mut d);
        // Round-off: 1e-11 relative to tau_max over 200 accumulated steps.
        assert!((s[3] - exact).abs() < 1e-11 * tmax, "step {k}, gamma {g:.4e}: tau {} vs {exact}", s[3]);
        if k >= n {
            dissipation += 0.5 * (s[3] + prev.1) * (g - prev.0);
        }
        prev = (g, s[3]);
        old = new;
    }
    assert!((s[3] - tmax).abs() < 1e-11 * tmax, "the loop closes at (g_max, tau_max)");
    // Loop area (energy dissipated per cycle and unit volume) from the closed-form corners.
    let g_rev = gmax - 2.0 * ty / mu;
    let area_corners = {
        // Shoelace over the loop corners: (gmax, tmax) -> (g_rev, tmax-2ty) -> (-gmax, -tmax) -> (-g_rev, -tmax+2ty).
        let pts = [(gmax, tmax), (g_rev, tmax - 2.0 * ty), (-gmax, -tmax), (-g_rev, -tmax + 2.0 * ty)];
        let mut a = 0.0;
        for i in 0..4 {
            let (p, q) = (pts[i], pts[(i + 1) % 4]);
            a += p.0 * q.1 - q.0 * p.1;
        }
        0.5 * a.abs()
    };
    // The trapezoid sum is exact on each linear piece; the two steps that straddle a corner
    // carry an O(dg^2) error: tolerance 2% of the loop area.
    assert!(
        (dissipation.abs() - area_corners).abs() < 0.02 * area_corners,
        "dissipation {dissipation} vs loop area {area_corners}"
    );
}

/// The loaded cylinder above is also the serial/parallel check for a nonlinear assembly.
#[test]
fn serial_and_parallel_plastic_runs_are_identical() {
    let hyp = PlaneHypothesis::PlaneStrain;
    let mat = shear_material(1000.0, 1000.0);
    let mesh = generate::annulus_sector(QUARTER, 12, 30, 1.0).unwrap();
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::J2Plastic(mat));
    let body = b.add_body("cylinder", mesh, mi, Formulation::BBar, 1.0);
    b.fix(body, "start", 1, 0.0).unwrap();
    b.fix(body, "end", 0, 0.0).unwrap();
    b.pressure(body, "inner", 160.0).unwrap();
    let model = b
        .build(
            LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)]).unwrap(),
            vec![0.5, 0.75, 1.0],
            NewtonParams::default(),
            LinearSolverKind::Cholesky,
        )
        .unwrap();
    let par = solve(&model);
    let mut an = mortex::solve::StaticAnalysis::new(&model).unwrap();
    an.set_parallel(false);
    let mut ser = an.initial_state();
    an.run(&mut ser, |_, _| Ok(())).unwrap();
    assert!(par.history.iter().any(|h| h.alpha > 0.0), "the test must yield");
    // Bit-identical: the scatter order never depends on threads.
    assert_eq!(par, ser);
}

/// Scene of [`algorithmic_tangent_of_contact_and_j2_equals_finite_differences`]: an elastic
/// block (Tri3) pressed by 50 MPa onto the virtual surface `y = 2.13` cut through a J2 host
/// (Quad4 B-bar, yield 20 MPa, so it yields under the normal load), then sheared by a
/// prescribed `ux` of its top (0 -> 20 um over `t = 1 .. 2`) under mu = 0.3. Monolithic
/// augmented Lagrangian (no condensation), small sliding.
///
/// ```text
///     ->  [ block ]   <- p = 50 MPa, top moved by ux
///   ______________    <- virtual surface (MorteX) inside the host
///  |   J2 host    |
///  |______________|   clamped
/// ```
const TANGENT_SCENE: &str = r#"
[problem]
hypothesis = "plane_strain"

[[materials]]
name = "steel"
model = "elastic"
young = 210000.0
poisson = 0.3

[[materials]]
name = "soft"
model = "j2_plastic"
young = 210000.0
poisson = 0.3
yield_stress = 20.0
isotropic_hardening = 2000.0

[[bodies]]
name = "host"
material = "soft"
formulation = "b_bar"
mesh = { type = "rectangle", size = [4.0, 3.0], divisions = [8, 6] }

[[bodies]]
name = "block"
material = "steel"
mesh = { type = "rectangle", origin = [0.5, 2.13], size = [3.0, 1.0], divisions = [7, 3], cell = "tri3" }

[[cuts]]
name = "surface"
body = "host"
points = [[-1.0, 2.13], [5.0, 2.13]]
keep = "right"

[[contacts]]
name = "interface"
mortar = "block"
mortar_surface = ["bottom"]
other = "host"
other_cut = "surface"
friction = 0.3
sliding = "small"

[[curves]]
name = "shear"
path = [[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]]

[[bcs]]
body = "host"
set = "bottom"
ux = 0.0
uy = 0.0

[[bcs]]
body = "block"
set = "top"
ux = 0.02
curve = "shear"

[[loads]]
body = "block"
set = "top"
pressure = 50.0

[steps]
path = [[0.0, 0.0], [1.0, 1.0], [2.0, 1.0]]
times = [0.25, 0.5, 0.75, 1.0]
"#;

/// The algorithmic tangent of the monolithic contact + J2 system (bulk consistent tangent,
/// contact rows, Coulomb rows by their laws) against central finite differences of the
/// residual, all unknowns (displacements and multipliers), with the contact laws held as the
/// semi-smooth update chose them at the converged state and the history of the start of the
/// increment (so the yielding points are in plastic loading). Checked at three converged
/// states: the end of the normal load (contact sticking), part-way into the shear (stick and
/// slip), and gross slip. Bound 1e-6 relative in the Frobenius norm of the whole matrix (the
/// target's): the return mapping is smooth inside each yield branch, so central differences
/// of step `h = 1e-7` times the displacement scale err by `O(h^2)` plus the round-off
/// `eps |r| / h`, about 1e-8 here.
#[test]
fn algorithmic_tangent_of_contact_and_j2_equals_finite_differences() {
    use mortex::solve::StaticAnalysis;
    let model = mortex::case::parse(TANGENT_SCENE, "tangent", std::path::Path::new("."), "tangent").unwrap().model;
    let disc = model.initial();
    let mut analysis = StaticAnalysis::with_condensation(&model, model.initial_shared(), false).unwrap();
    let mut state = analysis.initial_state();
    // The normal load in 4 increments, the shear in 20 (small enough for no cut-back).
    let times: Vec<f64> = (1..=4).map(|k| 0.25 * k as f64).chain((1..=20).map(|k| 1.0 + 0.05 * k as f64)).collect();
    let checked = [1.0, 1.3, 2.0];
    let mut seen = (false, false, false);
    for (step, &t) in times.iter().enumerate() {
        let start = state.clone();
        let report = analysis.advance_to(&mut state, step + 1, t).unwrap();
        if !checked.iter().any(|c| (c - t).abs() < 1e-12) {
            continue;
        }
        assert_eq!(report.cutbacks, 0, "t = {t}: the check needs the increment's start state");
        let (u, mu) = (state.u.clone(), state.multipliers.clone());
        let sys = analysis.newton_system(&start, t, &u, &mu, None).unwrap();
        let (active, stick, slip) = sys.contact_sets();
        assert!(active > 0, "t = {t}: no contact");
        let yielding = analysis_yielding_points(&start, &state);
        let nf = sys.num_free;
        let n = sys.rhs.len();
        let u_scale = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = 1e-7 * u_scale;
        let mut fd = nalgebra::DMatrix::<f64>::zeros(n, n);
        for k in 0..n {
            let mut at = |s: f64| {
                let (mut up, mut mp) = (u.clone(), mu.clone());
                if k < nf {
                    up[disc.dofs.free[k]] += s * h;
                } else {
                    mp[k - nf] += s * h * sys.alpha;
                }
                analysis.newton_system(&start, t, &up, &mp, Some(&sys)).unwrap().rhs
            };
            let (plus, minus) = (at(1.0), at(-1.0));
            for i in 0..n {
                fd[(i, k)] = -(plus[i] - minus[i]) / (2.0 * h);
            }
        }
        let err = (&fd - &sys.matrix).norm() / sys.matrix.norm();
        println!("t = {t}: {active} active, {stick} stick, {slip} slip, {yielding} yielding points: {err:.2e}");
        assert!(err <= 1e-6, "t = {t}: tangent against finite differences {err:.2e}");
        seen = (seen.0 || (stick > 0 && yielding > 0), seen.1 || slip > 0, seen.2 || (slip > 0 && stick > 0));
    }
    assert!(seen.0 && seen.1, "the checks must see stick with yielding points, and slip: {seen:?}");
}

/// Points whose history the increment from `start` to `end` advanced (they yielded).
fn analysis_yielding_points(start: &mortex::state::SimState, end: &mortex::state::SimState) -> usize {
    start.history.iter().zip(&end.history).filter(|(a, b)| a != b).count()
}
