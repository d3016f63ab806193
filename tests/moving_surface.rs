//! Virtual surfaces that move through their host mesh during a run, re-cut on fixed
//! integration points (src/discretisation.rs).
//!
//! Sketch (patch test, Moës, Dolbow & Belytschko, IJNME 46 (1999) 131, on a moving cut):
//!
//!   y = 2.2 + x tan(10 deg)  ____----   the cut at t = 0 (material kept below it)
//!   +------------____----------------+
//!   |   ____----                     |  host 4 x 3 mm, 8 x 6 Quad4 or Tri3 (h = 0.5 mm)
//!   |                                |  the cut moves down by 1.6 mm (3.2 layers) in 30 steps
//!   +--------------------------------+  left, right, bottom nodes: u = eps x (exact)
//!
//! Uniaxial stress along the cut, `sigma = S0 t (x) t`, is traction-free on the cut wherever
//! it is, so the exact solution never changes while the surface moves: every point with weight
//! must carry `sigma` to 1e-8 relative at every step (round-off of the solve: the fitted rules
//! match areas and first moments to 1e-12, which is all a linear field needs on parallelograms).

mod common;
use mortex::cut::{loop_moments, CellCut};
use mortex::driver::{run, RunOptions};
use mortex::fem::element::MappedElement;
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, J2Plastic, Material, PlaneHypothesis};
use mortex::mesh::{generate, CellKind};
use mortex::model::{ContactOther, ContactParams, Discretisation, LoadPath, Model, ModelBuilder, Sliding};
use mortex::moving::SurfaceMotion;
use mortex::solve::StaticAnalysis;
use mortex::solver::linear::LinearSolverKind;
use mortex::solver::newton::NewtonParams;
use nalgebra::{Matrix2, Point2, Vector2};

const E: f64 = 210_000.0;
const NU: f64 = 0.3;
const S0: f64 = 100.0;
const ANGLE_DEG: f64 = 10.0;
const TRAVEL: f64 = 1.6;
const STEPS: usize = 30;
/// Pressure on the upper block of the contact scenes.
const CONTACT_P: f64 = 50.0;

fn cut_line() -> [Point2<f64>; 2] {
    let s = ANGLE_DEG.to_radians().tan();
    [Point2::new(-1.0, 2.2 - s), Point2::new(5.0, 2.2 + 5.0 * s)]
}

/// The block with its moving cut; `material` is elastic or J2; BCs follow curve 0 (`bc_path`),
/// the motion curve 1 (`motion_path`).
fn block_model(
    kind: CellKind,
    material: Material,
    bc_path: Vec<(f64, f64)>,
    motion_path: Vec<(f64, f64)>,
    times: Vec<f64>,
) -> (Model, Matrix2<f64>) {
    let hyp = PlaneHypothesis::PlaneStrain;
    let mesh = generate::rectangle(0.0, 0.0, 4.0, 3.0, 8, 6, 1.0, 1.0, kind).unwrap();
    let boundary: Vec<usize> = ["left", "right", "bottom"].iter().flat_map(|s| mesh.node_sets[*s].clone()).collect();
    let nodes = mesh.nodes.clone();
    let line = cut_line();
    let t = (line[1] - line[0]).normalize();
    let sigma = Matrix2::new(t.x * t.x, t.x * t.y, t.x * t.y, t.y * t.y) * S0;
    let eps = (sigma - Matrix2::identity() * (NU * sigma.trace())) * ((1.0 + NU) / E);
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("m", material);
    let body = b.add_body("block", mesh, mi, Formulation::Standard, 1.0);
    for &n in &boundary {
        let u = eps * nodes[n].coords;
        b.fix_node(body, n, 0, u.x);
        b.fix_node(body, n, 1, u.y);
    }
    let motion_curve = b.add_curve(LoadPath::new(motion_path).unwrap());
    b.add_cut("surface", body, line.to_vec(), false, false).unwrap();
    b.set_cut_motion(
        "surface",
        SurfaceMotion::Translation { direction: Vector2::new(0.0, -TRAVEL), curve: motion_curve },
    )
    .unwrap();
    let model =
        b.build(LoadPath::new(bc_path).unwrap(), times, NewtonParams::default(), LinearSolverKind::Cholesky).unwrap();
    (model, sigma)
}

/// Area and first moments of every cut cell's fitted rule against the exact moments of its
/// material (Green's theorem); returns the largest relative deviation.
fn moment_error(m: &Model, d: &Discretisation) -> f64 {
    let mesh = &m.bodies[0].mesh;
    let cut = d.cuts[0].as_ref().unwrap();
    let mut worst: f64 = 0.0;
    for c in 0..mesh.num_cells() {
        let CellCut::Cut { loops, .. } = &cut.cells[c] else { continue };
        let poly = mortex::surface::cell_polygon(mesh, c);
        let h = mortex::surface::cell_size(&poly);
        let origin = poly[0];
        let exact = loop_moments(loops, 1, origin, h);
        let rule = &d.rules[m.elements.rule[c]];
        let mapped = MappedElement::new(mesh.cells[c].kind, mesh.cell_coords(c));
        let mut got = [0.0; 3];
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            let x = (mapped.map(*xi) - origin) / h;
            let dv = w * mapped.jacobian(*xi).determinant();
            got[0] += dv;
            got[1] += dv * x.x;
            got[2] += dv * x.y;
        }
        let scale = mortex::cut::polygon_area(&poly);
        for k in 0..3 {
            worst = worst.max((got[k] - exact[k]).abs() / scale);
        }
    }
    worst
}

fn check_uniform(m: &Model, d: &Discretisation, s: &mortex::state::SimState, sigma: &Matrix2<f64>) -> f64 {
    let el = &m.elements;
    let mut worst: f64 = 0.0;
    for e in 0..el.len() {
        let w = &d.rules[el.rule[e]].weights;
        for (q, &wq) in w.iter().enumerate() {
            if wq == 0.0 {
                continue;
            }
            let st = s.stress[el.point_offset[e] + q];
            let d = [(st[0] - sigma[(0, 0)]).abs(), (st[1] - sigma[(1, 1)]).abs(), (st[3] - sigma[(0, 1)]).abs()];
            worst = worst.max(d.into_iter().fold(0.0, f64::max) / S0);
        }
    }
    worst
}

/// Elastic block, surface moved 3.2 element layers in 30 steps: uniform stress to 1e-8 at
/// every step, areas and first moments of every cut cell exact to 1e-12, state layout fixed.
#[test]
fn moving_surface_patch_test_quad4_and_tri3() {
    for kind in [CellKind::Quad4, CellKind::Tri3] {
        let hyp = PlaneHypothesis::PlaneStrain;
        let mat = Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp });
        let times: Vec<f64> = (1..=STEPS).map(|i| i as f64 / STEPS as f64).collect();
        let (model, sigma) = block_model(kind, mat, vec![(0.0, 1.0), (1.0, 1.0)], vec![(0.0, 0.0), (1.0, 1.0)], times);
        let mut s = StaticAnalysis::initial_state_of(&model);
        let (np, nd) = (s.stress.len(), s.u.len());
        let mut steps = 0;
        let mut worst_stress: f64 = 0.0;
        let mut worst_moment: f64 = 0.0;
        run(&model, &mut s, RunOptions::default(), |_, st, m, d| {
            assert_eq!((st.stress.len(), st.u.len()), (np, nd), "state layout changed");
            worst_stress = worst_stress.max(check_uniform(m, d, st, &sigma));
            worst_moment = worst_moment.max(moment_error(m, d));
            steps += 1;
            Ok(())
        })
        .unwrap();
        assert_eq!(steps, STEPS);
        eprintln!("{kind:?}: max stress deviation {worst_stress:.2e} S0, max moment deviation {worst_moment:.2e}");
        assert!(worst_stress < 1e-8, "{kind:?}: stress deviation {worst_stress:e} S0");
        assert!(worst_moment < 1e-12, "{kind:?}: moment deviation {worst_moment:e}");
    }
}

/// A host node whose support keeps only a corner sliver of material (area fraction ~1e-11,
/// below the switch-off threshold 1e-8) but which the ghost penalty reaches stays free, and the
/// uniform-stress patch test on that cut holds to 1e-8 (round-off). The cut `y = x - 1 + d`
/// (material below, d = 5e-6 mm) clips the lower-right corner of the support of node (2, 2).
/// Switched off and held at its initial zero, the node anchored the sliver's ghost faces with
/// the full ghost stiffness and the stress near it left the exact field.
#[test]
fn sliver_node_under_the_ghost_penalty_stays_free() {
    const D: f64 = 5e-6;
    let hyp = PlaneHypothesis::PlaneStrain;
    let mesh = generate::rectangle(0.0, 0.0, 4.0, 3.0, 8, 6, 1.0, 1.0, CellKind::Quad4).unwrap();
    let boundary: Vec<usize> = ["left", "right", "bottom"].iter().flat_map(|s| mesh.node_sets[*s].clone()).collect();
    let nodes = mesh.nodes.clone();
    let sliver_node = nodes.iter().position(|p| (p - Point2::new(2.0, 2.0)).norm() < 1e-12).unwrap();
    let line = [Point2::new(0.5, -0.5 + D), Point2::new(4.5, 3.5 + D)];
    let t = (line[1] - line[0]).normalize();
    let sigma = Matrix2::new(t.x * t.x, t.x * t.y, t.x * t.y, t.y * t.y) * S0;
    let eps = (sigma - Matrix2::identity() * (NU * sigma.trace())) * ((1.0 + NU) / E);
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("m", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
    let body = b.add_body("block", mesh, mi, Formulation::Standard, 1.0);
    for &n in &boundary {
        let u = eps * nodes[n].coords;
        b.fix_node(body, n, 0, u.x);
        b.fix_node(body, n, 1, u.y);
    }
    b.add_cut("surface", body, line.to_vec(), false, false).unwrap();
    let model = b
        .build(
            LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)]).unwrap(),
            vec![1.0],
            NewtonParams::default(),
            LinearSolverKind::Cholesky,
        )
        .unwrap();
    let fraction = model.initial().cuts[0].as_ref().unwrap().node_fraction[sliver_node];
    assert!(fraction > 0.0 && fraction < mortex::cut::SMALL_FRACTION, "support fraction {fraction:e}");
    assert!(!model.initial().held[0].contains(&(2 * sliver_node)), "the sliver node was switched off");
    assert!(!model.initial().held[0].is_empty(), "nodes with no material at all are still switched off");
    let mut s = StaticAnalysis::initial_state_of(&model);
    let mut worst: f64 = 0.0;
    run(&model, &mut s, RunOptions::default(), |_, st, m, d| {
        worst = worst.max(check_uniform(m, d, st, &sigma));
        Ok(())
    })
    .unwrap();
    assert!(worst < 1e-8, "stress deviation {worst:e} S0");
}

/// Moving a surface in 30 steps to its final position vs building the model with the cut
/// already there, under a non-linear field (bottom and left sides fixed, right side pushed
/// down as `-0.01 (y / 3)^2` mm); nodes with at least half of their support in the material.
/// * Elastic body: a cut band cell takes the exact sub-triangulation of its material in its
///   fixed slots (nothing is stored at its points), as the built model does: equal to
///   round-off (1e-12).
/// * J2 body (yield stress high enough to stay elastic): the points are fixed material points
///   with moment-fitted weights, the built model integrates its cut cells exactly: the two
///   differ by the fit's quadrature error (degree 2 where the material points allow it, less
///   in slivers), not by round-off. Reported against h.
#[test]
fn moved_vs_built_there() {
    let hyp = PlaneHypothesis::PlaneStrain;
    let elastic = Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp });
    let j2 = Material::J2Plastic(J2Plastic {
        elastic: Elastic { young: E, poisson: NU, hypothesis: hyp },
        yield_stress: 1e9,
        isotropic_hardening: 0.0,
        kinematic_hardening: 0.0,
    });
    let solve = |mat: Material, refine: usize, moving: bool| -> (Model, Vec<f64>) {
        let mesh = generate::rectangle(0.0, 0.0, 4.0, 3.0, 8 * refine, 6 * refine, 1.0, 1.0, CellKind::Quad4).unwrap();
        let mut b = ModelBuilder::new(hyp);
        let mi = b.add_material("m", mat);
        let nodes = mesh.nodes.clone();
        let (left, right, bottom) =
            (mesh.node_sets["left"].clone(), mesh.node_sets["right"].clone(), mesh.node_sets["bottom"].clone());
        let body = b.add_body("block", mesh, mi, Formulation::Standard, 1.0);
        for &n in left.iter().chain(&bottom) {
            b.fix_node(body, n, 0, 0.0);
            b.fix_node(body, n, 1, 0.0);
        }
        for &n in &right {
            b.fix_node(body, n, 0, 0.0);
            b.fix_node(body, n, 1, -0.01 * (nodes[n].y / 3.0).powi(2));
        }
        let line = cut_line();
        let curve = b.add_curve(LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)]).unwrap());
        let times: Vec<f64>;
        if moving {
            b.add_cut("surface", body, line.to_vec(), false, false).unwrap();
            b.set_cut_motion("surface", SurfaceMotion::Translation { direction: Vector2::new(0.0, -TRAVEL), curve })
                .unwrap();
            times = (1..=STEPS).map(|i| i as f64 / STEPS as f64).collect();
        } else {
            let moved: Vec<Point2<f64>> = line.iter().map(|p| p + Vector2::new(0.0, -TRAVEL)).collect();
            b.add_cut("surface", body, moved, false, false).unwrap();
            times = vec![1.0];
        }
        let model = b
            .build(
                LoadPath::new(vec![(0.0, 1.0), (1.0, 1.0)]).unwrap(),
                times,
                NewtonParams::default(),
                LinearSolverKind::Cholesky,
            )
            .unwrap();
        let mut s = StaticAnalysis::initial_state_of(&model);
        run(&model, &mut s, RunOptions::default(), |_, _, _, _| Ok(())).unwrap();
        (model, s.u)
    };
    const MIN_FRACTION: f64 = 0.5;
    for (name, mat) in [("elastic", elastic), ("J2", j2)] {
        let mut diffs = vec![];
        for refine in [1, 2, 4] {
            let (_, u_moved) = solve(mat, refine, true);
            let (m_built, u_built) = solve(mat, refine, false);
            let frac = &m_built.initial().cuts[0].as_ref().unwrap().node_fraction;
            let (mut du, mut umax) = (0.0f64, 0.0f64);
            for (n, &f) in frac.iter().enumerate() {
                if f >= MIN_FRACTION {
                    for c in 0..2 {
                        du = du.max((u_moved[2 * n + c] - u_built[2 * n + c]).abs());
                        umax = umax.max(u_built[2 * n + c].abs());
                    }
                }
            }
            eprintln!(
                "{name}, h = {}: moved vs built there: max |du| / max |u| = {:.3e}",
                0.5 / refine as f64,
                du / umax
            );
            diffs.push(du / umax);
        }
        if name == "elastic" {
            assert!(diffs.iter().all(|d| *d < 1e-12), "elastic: moved vs built there: {diffs:?}");
        } else {
            // Bounded by the quadrature error of the fitted rules (measured 2.6e-6 .. 2.6e-4).
            assert!(diffs.iter().all(|d| *d < 1e-3), "J2: moved vs built there: {diffs:?}");
        }
    }
}

/// A J2 block loaded past yield, unloaded half way (every point well inside the yield
/// surface), then its surface moved 3 layers: the state layout never changes; the history of
/// every point outside the band the surface visits is bit-identical before and after each
/// update; points left in the void carry weight zero and keep their values. (In band cells
/// with slivers the material-point fit may fall back to the area only, which perturbs the
/// stress locally; the count of band points whose history moved is reported.)
#[test]
fn j2_history_stays_on_its_points() {
    let hyp = PlaneHypothesis::PlaneStrain;
    // Yield at 60 MPa: the 100 MPa uniaxial state is past yield at full load.
    let mat = Material::J2Plastic(J2Plastic {
        elastic: Elastic { young: E, poisson: NU, hypothesis: hyp },
        yield_stress: 60.0,
        isotropic_hardening: 1000.0,
        kinematic_hardening: 0.0,
    });
    let times: Vec<f64> = (1..=24).map(|i| i as f64 / 8.0).collect();
    let (model, _) = block_model(
        CellKind::Quad4,
        mat,
        vec![(0.0, 0.0), (1.0, 1.0), (2.0, 0.5), (3.0, 0.5)],
        vec![(0.0, 0.0), (2.0, 0.0), (3.0, 1.0)],
        times,
    );
    let mut s = StaticAnalysis::initial_state_of(&model);
    let layout = (s.history.len(), s.stress.len(), s.u.len(), s.multipliers.len());
    let mut frozen: Option<Vec<mortex::fem::material::PlasticState>> = None;
    let mut max_eqps: f64 = 0.0;
    let mut zero_weight_points = 0;
    let mut band_points_changed = 0;
    run(&model, &mut s, RunOptions::default(), |r, st, m, d| {
        assert_eq!((st.history.len(), st.stress.len(), st.u.len(), st.multipliers.len()), layout);
        max_eqps = max_eqps.max(st.history.iter().map(|h| h.alpha).fold(0.0, f64::max));
        if r.time >= 2.0 - 1e-12 {
            let el = &m.elements;
            let band = &m.bands[0].as_ref().unwrap().cells;
            match &frozen {
                None => frozen = Some(st.history.clone()),
                Some(h0) => {
                    for e in 0..el.len() {
                        let in_band = band.binary_search(&e).is_ok();
                        for q in el.state_offset[e]..el.state_offset[e + 1] {
                            let (a, b) = (&h0[q], &st.history[q]);
                            if in_band {
                                band_points_changed += (a != b) as usize;
                            } else {
                                assert!(a == b, "step {}: history of point {q} changed: {a:?} -> {b:?}", r.step);
                            }
                        }
                    }
                }
            }
            let el = &m.elements;
            zero_weight_points = (0..el.len())
                .flat_map(|e| d.rules[el.rule[e]].weights.iter().filter(|w| **w == 0.0).map(move |_| e))
                .count();
        }
        Ok(())
    })
    .unwrap();
    assert!(max_eqps > 1e-4, "the block must have yielded (eqps {max_eqps:e})");
    assert!(zero_weight_points > 0, "points must have lost their material");
    eprintln!("J2 block: {zero_weight_points} points without material at the end; band point-steps whose history moved: {band_points_changed}");
}

/// Contact patch test on a moving lower virtual surface: the upper block (4 x 1 mm, 7 x 3
/// Tri3), pressed by p = 50 MPa, follows the lower block's virtual top surface as it moves
/// down; the contact pressure is p at every multiplier node and the stress uniform after every
/// move, to 1e-8 (round-off). Small sliding (reference pairing, the surface moves 1 mm < the
/// pairing reach) and finite sliding (re-paired every step, 1.5 mm).
/// The contact patch scene below: the upper block pressed on the lower block's virtual top
/// surface, which moves down by `travel` over `steps` steps after the load.
fn moving_contact_model(sliding: Sliding, travel: f64, steps: usize) -> Model {
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
    let lower = generate::rectangle(0.0, 0.0, 4.0, 3.0, 8, 6, 1.0, 1.0, CellKind::Quad4).unwrap();
    let upper = generate::rectangle(0.0, 2.63, 4.0, 1.0, 7, 3, 1.0, 1.0, CellKind::Tri3).unwrap();
    let lo = b.add_body("lower", lower, mi, Formulation::Standard, 1.0);
    let up = b.add_body("upper", upper, mi, Formulation::Standard, 1.0);
    b.fix(lo, "bottom", 1, 0.0).unwrap();
    b.fix(lo, "bottom_left", 0, 0.0).unwrap();
    b.fix(up, "top_left", 0, 0.0).unwrap();
    b.pressure(up, "top", CONTACT_P).unwrap();
    let motion = b.add_curve(LoadPath::new(vec![(0.0, 0.0), (1.0, 0.0), (2.0, 1.0)]).unwrap());
    b.add_cut("worn_top", lo, vec![Point2::new(-1.0, 2.63), Point2::new(5.0, 2.63)], false, false).unwrap();
    b.set_cut_motion("worn_top", SurfaceMotion::NormalOffset { distance: travel, curve: motion }).unwrap();
    let params = ContactParams { sliding, ..Default::default() };
    b.add_contact("c", up, &["bottom".to_string()], lo, ContactOther::Cut("worn_top".into()), params).unwrap();
    let times: Vec<f64> = std::iter::once(1.0).chain((1..=steps).map(|i| 1.0 + i as f64 / steps as f64)).collect();
    b.build(
        LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0), (2.0, 1.0)]).unwrap(),
        times,
        NewtonParams::default(),
        LinearSolverKind::Cholesky,
    )
    .unwrap()
}

#[test]
fn contact_patch_test_on_a_moving_surface() {
    const P: f64 = CONTACT_P;
    for (sliding, travel, steps) in [(Sliding::Small, 1.0, 8), (Sliding::Finite, 1.5, 12)] {
        let model = moving_contact_model(sliding, travel, steps);
        let mut s = StaticAnalysis::initial_state_of(&model);
        let mut count = 0;
        run(&model, &mut s, RunOptions::default(), |r, st, m, d| {
            let el = &m.elements;
            for e in 0..el.len() {
                for (q, &w) in d.rules[el.rule[e]].weights.iter().enumerate() {
                    if w == 0.0 {
                        continue;
                    }
                    let stq = st.stress[el.point_offset[e] + q];
                    let d = [stq[0].abs(), (stq[1] + P).abs(), stq[3].abs()].into_iter().fold(0.0, f64::max);
                    assert!(d < 1e-8 * P, "{sliding:?} step {}: element {e} point {q}: stress {stq:?}", r.step);
                }
            }
            let c = &d.contact.pairs[0];
            let nt = m.constraints.len();
            // Finite sliding integrates on the deformed surfaces: its multiplier is a force per
            // deformed length, stretched by the lateral strain eps_xx = nu (1 + nu) p / E of
            // the uniaxial plane-strain state (exact).
            // Every step is paired in its own end configuration, the first one included.
            let expected = match sliding {
                Sliding::Finite => P / (1.0 + NU * (1.0 + NU) * P / E),
                _ => P,
            };
            for l in 0..c.multipliers.num_nodes {
                let p = -st.multipliers[nt + c.first_row + l];
                assert!(
                    (p - expected).abs() < 1e-8 * P,
                    "{sliding:?} step {}: node {l}: pressure {p} vs {expected}",
                    r.step
                );
            }
            count += 1;
            Ok(())
        })
        .unwrap();
        assert_eq!(count, steps + 1);
    }
}

/// The condensed solver's structure handed from one surface position to the next (what a
/// run does) gives, bit for bit, what a solver built afresh for the moved surface gives (what
/// a restart does), and it is actually reused: the surface crosses cells, the ghost penalty
/// and the contact rows move, and the pattern of `K_rho` stays (grounding rows regularise the
/// upper block, which only contact holds vertically), also when the model's DOF map changes
/// (the surface passing a row of nodes switches them off: twice in this 1 mm descent through
/// 0.5 mm cells; they stay decoupled equations of `K_rho`).
#[test]
fn reused_solver_structure_equals_a_fresh_set_up_bit_for_bit() {
    let steps = 8;
    let model = moving_contact_model(Sliding::Small, 1.0, steps);
    let mut current = model.initial().clone();
    let mut state = StaticAnalysis::initial_state_of(&model);
    let mut reuse = None;
    let mut dof_map_changes = 0;
    let mut previous_dofs: Option<Vec<usize>> = None;
    for (k, &t) in model.times.iter().enumerate() {
        current.place_surfaces(&model, t).unwrap();
        let mut fresh_state = state.clone();
        let mut handed =
            StaticAnalysis::with_reuse(&model, std::sync::Arc::new(current.clone()), reuse.take()).unwrap();
        handed.advance_to(&mut state, k + 1, t).unwrap();
        assert_eq!(handed.structure_reused(), k > 0, "step {}: every set-up after the first reuses", k + 1);
        if previous_dofs.as_ref().is_some_and(|p| p != &current.dofs.eq) {
            dof_map_changes += 1;
        }
        previous_dofs = Some(current.dofs.eq.clone());
        reuse = handed.into_reuse();
        let mut fresh = StaticAnalysis::on(&model, std::sync::Arc::new(current.clone())).unwrap();
        assert!(!fresh.structure_reused());
        fresh.advance_to(&mut fresh_state, k + 1, t).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&state.u), bits(&fresh_state.u), "step {}: displacements", k + 1);
        assert_eq!(bits(&state.multipliers), bits(&fresh_state.multipliers), "step {}: multipliers", k + 1);
    }
    // Two rows of nodes passed, and their switching off did not cost a new pattern.
    assert_eq!(dof_map_changes, 2, "DOF map changes");
}
