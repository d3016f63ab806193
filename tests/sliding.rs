//! Finite sliding: a block dragged over a longer block for three times its own width, the
//! contact paired in each step's own end configuration (`Sliding::Finite`: a fixed point,
//! re-paired until the estimated pressure change is below 1e-3 of the largest pressure).
//!
//!            P (total force on a rigid top)
//!            |   u_x(t): 0 -> 3 mm
//!         +--v--+ -->
//!         |upper|  1 x 0.5 mm, 10 x 5 Quad4 (h 0.1)
//!   +-----+-----+-----------------------------+
//!   |  lower: 10 x 1 mm, 90 x 10 Quad4 (h 0.111, non-matching), bottom fixed  |
//!   +----------------------------------------------------------------------+
//!
//! Reference (exact, Coulomb's law and equilibrium): once the whole contact slides, the
//! tangential force on the rigid top is mu P, the contact pressures add up to P, every node in
//! contact slips, and nothing penetrates. Lower surface real (classical mortar) and virtual (a
//! horizontal line cutting the lower host's top row of cells, MorteX). The same drag under
//! small sliding (pairing from the reference) stops with the typed `SlidingBeyondPairing` error.

mod common;
use mortex::contact::FrictionStatus;
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, Material, PlaneHypothesis};
use mortex::mesh::{generate, CellKind};
use mortex::model::{ContactOther, ContactParams, LoadPath, Model, ModelBuilder, Sliding};
use mortex::solve::{AnalysisError, StaticAnalysis};
use nalgebra::{Point2, Vector2};

const E: f64 = 210_000.0;
const NU: f64 = 0.3;
const P: f64 = 50.0;
const MU: f64 = 0.3;
const STROKE: f64 = 3.0;

/// Returns the model and the rigid master's global node.
fn drag_model(virtual_lower: bool, sliding: Sliding, increments: usize) -> (Model, usize) {
    drag_model_with(virtual_lower, sliding, increments, false)
}

/// `j2`: both blocks J2-plastic with a yield stress they never reach (the same elastic
/// solution, solved by the monolithic saddle-point Newton instead of interface condensation).
fn drag_model_with(virtual_lower: bool, sliding: Sliding, increments: usize, j2: bool) -> (Model, usize) {
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let elastic = Elastic { young: E, poisson: NU, hypothesis: hyp };
    let material = if j2 {
        Material::J2Plastic(mortex::fem::material::J2Plastic {
            elastic,
            yield_stress: 1e9,
            isotropic_hardening: 0.0,
            kinematic_hardening: 0.0,
        })
    } else {
        Material::Elastic(elastic)
    };
    let mi = b.add_material("steel", material);
    let top = if virtual_lower { 0.037 } else { 0.0 };
    let lower =
        generate::rectangle(-5.0, -1.0, 10.0, 1.0 + top, 90, 10, 1.0, 1.0, CellKind::Quad4).expect("lower mesh");
    let upper = generate::rectangle(-0.5, 0.0, 1.0, 0.5, 10, 5, 1.0, 1.0, CellKind::Quad4).expect("upper mesh");
    let lo = b.add_body("lower", lower, mi, Formulation::Standard, 1.0);
    let up = b.add_body("upper", upper, mi, Formulation::Standard, 1.0);
    b.fix(lo, "bottom", 0, 0.0).unwrap();
    b.fix(lo, "bottom", 1, 0.0).unwrap();
    let master = b.rigid_set(up, "top").unwrap();
    b.point_load_node(up, master, Vector2::new(0.0, -P));
    let stroke = b.add_curve(LoadPath::new(vec![(0.0, 0.0), (1.0, 0.0), (4.0, STROKE)]).unwrap());
    b.use_curve(stroke);
    b.fix_node(up, master, 0, 1.0);
    b.use_curve(0);
    let other = if virtual_lower {
        b.add_cut("surface", lo, vec![Point2::new(-5.5, 0.0), Point2::new(5.5, 0.0)], false, false).unwrap();
        ContactOther::Cut("surface".into())
    } else {
        ContactOther::Edges(b.global_edges(lo, &["top".to_string()]).unwrap())
    };
    let params = ContactParams { friction: MU, sliding, ..Default::default() };
    b.add_contact("c", up, &["bottom".to_string()], lo, other, params).unwrap();
    let mut times = vec![0.5, 1.0];
    times.extend((1..=increments).map(|i| 1.0 + 3.0 * i as f64 / increments as f64));
    let model = b
        .build(
            LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0), (4.0, 1.0)]).unwrap(),
            times,
            Default::default(),
            Default::default(),
        )
        .unwrap();
    let master_global = model.bodies[up].node_offset + master;
    (model, master_global)
}

/// Drags the block; returns the deepest penetration (normalised weighted gap) of the final
/// configuration re-paired.
fn drag(virtual_lower: bool, increments: usize) -> f64 {
    {
        let (model, master) = drag_model(virtual_lower, Sliding::Finite, increments);
        let mut s = StaticAnalysis::new(&model).unwrap().initial_state();
        let mut checked = 0;
        let mut worst_q: f64 = 0.0;
        mortex::driver::run(&model, &mut s, mortex::driver::RunOptions::default(), |r, st, paired, disc| {
            // `paired`: the pairing this step was solved on (its own end configuration).
            if r.time <= 1.0 + 1e-9 {
                return Ok(());
            }
            // Equilibrium of the upper body through the step's contact rows: their y-force is P
            // and their x-force the reaction at the rigid top (1e-8: Newton tolerance 1e-9).
            let nt = paired.constraints.len();
            let first_upper = 2 * paired.bodies[1].node_offset;
            let mut force = [0.0; 2];
            for (row, lam) in disc.multiplier_rows(paired).zip(&st.multipliers).skip(nt) {
                for &(d, c) in row.iter().filter(|(d, _)| *d >= first_upper) {
                    force[d % 2] += lam * c;
                }
            }
            let reactions = disc.reactions(paired, st);
            if (force[1].abs() / P - 1.0).abs() > 1e-8
                || (force[0].abs() / reactions[2 * master].abs() - 1.0).abs() > 1e-8
            {
                return Err(format!(
                    "t {}: contact force {force:?} vs P {P}, reaction {}",
                    r.time,
                    reactions[2 * master]
                )
                .into());
            }
            // Tangential force on the rigid top (the prescribed DOF's reaction): mu P. Not to
            // round-off: each step is paired on its deformed end configuration, whose surface
            // segments are tilted by the elastic deformation (rotations of the order of the
            // strain, P / (E w) ~ 3e-4), and the Coulomb law holds in that frame. Tolerance 1e-3.
            let q = reactions[2 * master].abs();
            worst_q = worst_q.max((q / (MU * P) - 1.0).abs());
            if (q / (MU * P) - 1.0).abs() > 1e-3 {
                return Err(format!("t {}: tangential force {q} vs mu P {}", r.time, MU * P).into());
            }
            let c = &model.initial().contact.pairs[0];
            let nt = model.constraints.len();
            let pressures: Vec<f64> =
                (0..c.multipliers.num_nodes).map(|l| -st.multipliers[nt + c.first_row + l]).collect();
            if pressures.iter().any(|&p| p < -1e-9 * P) {
                return Err(format!("t {}: tensile contact pressure", r.time).into());
            }
            // Every node carrying pressure slips, with |lambda_t| = mu p (Coulomb, in the pairing
            // frame: exact to the Newton tolerance, 1e-9 of mu p0 here).
            let nc = model.initial().contact.rows.len();
            let p_max = pressures.iter().cloned().fold(0.0, f64::max);
            for (l, &p) in pressures.iter().enumerate() {
                if p > 1e-6 * P {
                    let j = c.friction_row[l].ok_or("friction row")?;
                    if st.friction_status[j] != 2 {
                        return Err(format!("t {}: node {l} in contact does not slip", r.time).into());
                    }
                    let lt = st.multipliers[nt + nc + j];
                    if (lt.abs() - MU * p).abs() > 1e-9 * MU * p_max {
                        return Err(
                            format!("t {}: node {l}: |lambda_t| {} vs mu p {}", r.time, lt.abs(), MU * p).into()
                        );
                    }
                }
            }
            // The upper block moved with the stroke.
            let ux = st.u[2 * master];
            let expected = STROKE * (r.time - 1.0) / 3.0;
            if (ux - expected).abs() > 1e-12 * STROKE {
                return Err(format!("t {}: stroke {ux} vs {expected}", r.time).into());
            }
            checked += 1;
            Ok(())
        })
        .unwrap_or_else(|e| panic!("virtual {virtual_lower}: {e}"));
        assert_eq!(checked, increments);
        eprintln!("virtual {virtual_lower}: max |Q / (mu P) - 1| over the drag {worst_q:.2e}");
        // Final configuration re-paired: its deepest penetration (the pairing lag of the last
        // step, checked by the caller) and the block's footprint x in [2.5, 3.5].
        let current = model.initial().repaired(&model, &s.u);
        let mut deepest: f64 = 0.0;
        for k in 0..current.contact.rows.len() {
            let g = current.contact.g0[k] + current.contact.rows[k].iter().map(|&(d, c)| c * s.u[d]).sum::<f64>();
            if current.contact.phi[k] > 0.0 {
                deepest = deepest.max(-g / current.contact.phi[k]);
            }
        }
        let footprint: Vec<f64> =
            current.contact.pairs[0].multipliers.points.iter().map(|p| p.x + s.u[2 * master]).collect();
        assert!(footprint.iter().all(|&x| (2.5 - 1e-9..=3.5 + 1e-9).contains(&x)), "{footprint:?}");
        eprintln!("virtual {virtual_lower}, {increments} increments: deepest re-paired penetration {deepest:.2e} mm");
        deepest
    }
}

#[test]
fn block_dragged_three_widths_with_finite_sliding() {
    for virtual_lower in [false, true] {
        // Each step is paired in its own end configuration (fixed point on the pairing, until
        // the estimated pressure change is below 1e-3 of the largest): the re-paired end state
        // has no pairing lag. A step paired where it started would leave the stroke increment
        // (0.1 mm) times the slope of the dented surface (dent ~ p w / E = 2.4e-4 mm over
        // ~0.2 mm: ~1e-3), about 1e-4 mm. Bound: 2e-8 mm at either increment size, a tenth of
        // what the pairing tolerance alone would leave (1e-3 x 2.4e-4 mm); the fixed point
        // contracts fast enough that its settled pairing leaves far less (3e-12 to 8e-12 mm
        // measured).
        for increments in [30, 60] {
            let deepest = drag(virtual_lower, increments);
            assert!(deepest < 2e-8, "virtual {virtual_lower}, {increments} increments: penetration {deepest:e} mm");
        }
    }
}

#[test]
fn the_same_drag_under_small_sliding_is_a_typed_error() {
    let (model, _) = drag_model(false, Sliding::Small, 30);
    let mut a = StaticAnalysis::new(&model).unwrap();
    let mut s = a.initial_state();
    let e = a.run(&mut s, |_, _| Ok(())).unwrap_err();
    assert!(matches!(e, AnalysisError::SlidingBeyondPairing { .. }), "got {e}");
    assert!(s.time > 1.0, "the converged steps before are kept (t = {})", s.time);
}

/// Restart under finite sliding: the pairing of a step is a function of the state it starts
/// from, so resuming from any converged state repeats the run bit for bit (every f64 of the
/// later states compared by its bits; the HDF5 round trip of a state is exact, tests/restart.rs).
#[test]
fn finite_sliding_resumes_bit_for_bit() {
    let (model, _) = drag_model(true, Sliding::Finite, 12);
    let mut s = StaticAnalysis::new(&model).unwrap().initial_state();
    let mut full = vec![];
    mortex::driver::run(&model, &mut s, mortex::driver::RunOptions::default(), |_, st, _, _| {
        full.push(st.clone());
        Ok(())
    })
    .unwrap();
    let bits = |st: &mortex::state::SimState| -> Vec<u64> {
        st.u.iter().chain(&st.multipliers).chain(&st.accumulated_slip).map(|v| v.to_bits()).collect()
    };
    for k in [2, 7] {
        let mut resumed = full[k - 1].clone();
        let mut later = vec![];
        mortex::driver::run(&model, &mut resumed, mortex::driver::RunOptions::default(), |_, st, _, _| {
            later.push(st.clone());
            Ok(())
        })
        .unwrap();
        assert_eq!(later.len(), full.len() - k);
        for (a, b) in full[k..].iter().zip(&later) {
            assert_eq!(bits(a), bits(b), "resumed from step {k}: step {} differs", a.step);
            assert_eq!(a.friction_status, b.friction_status);
        }
    }
}

/// Finite sliding through the monolithic Newton (bodies with plastic state, here never yielding)
/// equals the condensed solve of the same drag: displacements and multipliers to 1e-9 relative
/// (both converged to the Newton tolerance 1e-9; condensed and monolithic agree to 1e-10 on
/// fixed pairings in tests/mindlin.rs).
#[test]
fn finite_sliding_monolithic_equals_condensed() {
    let run = |j2: bool| {
        let (model, _) = drag_model_with(true, Sliding::Finite, 12, j2);
        let mut s = StaticAnalysis::new(&model).unwrap().initial_state();
        mortex::driver::run(&model, &mut s, mortex::driver::RunOptions::default(), |_, _, _, _| Ok(())).unwrap();
        s
    };
    let (c, m) = (run(false), run(true));
    let rel = |a: &[f64], b: &[f64]| {
        let n = a.iter().map(|v| v * v).sum::<f64>().sqrt();
        a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt() / n
    };
    let (du, dl) = (rel(&c.u, &m.u), rel(&c.multipliers, &m.multipliers));
    assert!(du < 1e-9 && dl < 1e-9, "u {du:.2e}, lambda {dl:.2e}");
    assert_eq!(c.friction_status, m.friction_status);
}

/// A re-pairing solves its step again from the sets its first solve converged to
/// (`StaticAnalysis::start_from_sets`): on the same pairing those sets are the answer, so the
/// active-set iterations take one interface solve per pass, and the state is the first solve's
/// bit for bit (the iterations end at a set that reproduces itself; its solve is the same
/// arithmetic whichever set they started from). The drag's first sliding step: every row goes
/// from stick (after the load) to slip.
#[test]
fn a_step_started_from_its_converged_sets_is_one_iteration_and_the_same_bits() {
    let (model, _) = drag_model_with(false, Sliding::Small, 12, false);
    let mut analysis = StaticAnalysis::new(&model).unwrap();
    let mut state = analysis.initial_state();
    for k in 0..2 {
        analysis.advance_to(&mut state, k + 1, model.times[k]).unwrap();
    }
    let start = state.clone();
    let first = analysis.advance_to(&mut state, 3, model.times[2]).unwrap();
    let sets = analysis.converged_sets().cloned().unwrap();
    let sets_len = (sets.active.len(), sets.status.len());
    let slip = sets.status.iter().filter(|s| matches!(s, FrictionStatus::Slip(_))).count();
    assert!(slip > 0, "the step slides: {slip} slip rows");
    let mut again = start.clone();
    analysis.start_from_sets(sets);
    let warm = analysis.advance_to(&mut again, 3, model.times[2]).unwrap();
    assert!(first.iterations > warm.iterations, "{} iterations cold, {} warm", first.iterations, warm.iterations);
    assert_eq!(warm.iterations, warm.newton_iterations, "one interface solve per pass");
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&state.u), bits(&again.u));
    assert_eq!(bits(&state.multipliers), bits(&again.multipliers));
    assert_eq!(state.friction_status, again.friction_status);
    // Sets far from the answer (every row in contact and sticking, every row open): the
    // iterations still end at the same solution, bit for bit.
    let (nc, nfr) = (sets_len.0, sets_len.1);
    for (active, status) in
        [(vec![true; nc], vec![FrictionStatus::Stick; nfr]), (vec![false; nc], vec![FrictionStatus::Open; nfr])]
    {
        let wrong = mortex::contact::ContactSets { active, status };
        let mut from_wrong = start.clone();
        analysis.start_from_sets(wrong);
        analysis.advance_to(&mut from_wrong, 3, model.times[2]).unwrap();
        assert_eq!(bits(&state.u), bits(&from_wrong.u));
        assert_eq!(bits(&state.multipliers), bits(&from_wrong.multipliers));
    }
}
