//! Fretting in the sliding frame: a curved contact slid by finite steps keeps its static
//! pressure.
//!
//! ```text
//!          rigid platen, P = 18.5 N/mm, u_x = 0
//!        .-~~~~~~~~~~~~-.
//!       (  cylinder R 6  )      steel on steel, E = 200 GPa, nu = 0.3, plane strain,
//!        '-.__________.-'       mu = 0.9: gross slip over the whole stroke
//!   ==========[ flat 3 x 2 ]=========>  u_x = +-25 um (0 -> + -> - -> 0 per cycle)
//! ```
//!
//! The McColl, Ding & Leen (Wear 256, 2004, 1114) fretting scene of
//! `wear_cases/mccoll_fretting.toml` without wear, one gross-slip cycle with `sliding =
//! "finite"`. Reference (exact for this scene): both bodies have the same elastic constants, so
//! the normal problem does not couple to the shear (Dundurs' beta = 0, Johnson, Contact
//! Mechanics, 1985, sec. 7.1), and the cylinder is held: in the cylinder's frame the pressure at
//! every increment is the static profile of the end of the normal load (step 1). The stroke
//! increment at 4 increments per cycle (25 um) is about the whole contact width (2a ~ 25 um)
//! and ten elements of the flat: a step paired where it started reads the flat's indentation
//! where it no longer is (its peak pressure rose fourfold before each step was paired in its
//! own end configuration).

use mortex::driver::{run, RunOptions};
use mortex::solve::StaticAnalysis;
use std::path::Path;

/// Pressures of the cylinder's multiplier nodes (multiplier order) at every output step of one
/// gross-slip cycle at `increments` per cycle, finite sliding, no wear; `virtual_flat`: the
/// flat's top is a virtual surface (a cut through its host's top row, the host extended above).
fn cycle_pressures(increments: usize, virtual_flat: bool) -> Vec<Vec<f64>> {
    cycle_pressures_on(increments, virtual_flat, 1)
}

/// As [`cycle_pressures`], with both contact meshes `refine` times finer along the contact
/// (the cylinder's angular and the flat's horizontal divisions; gradings kept).
fn cycle_pressures_on(increments: usize, virtual_flat: bool, refine: usize) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string("wear_cases/mccoll_fretting.toml").expect("shipped case");
    let mut text = text[..text.find("[[wear]]").expect("wear section")].to_string();
    text = text.replace("divisions = [30, 160]", &format!("divisions = [30, {}]", 160 * refine));
    text = text.replace("divisions = [120, 30]", &format!("divisions = [{}, 30]", 120 * refine));
    text = text.replace("friction = 0.9", "friction = 0.9\nsliding = \"finite\"");
    if virtual_flat {
        // The flat's host reaches 4 um above the cut y = 0 that is its surface.
        text = text.replace("size = [3.0, 2.0]", "size = [3.0, 2.004]");
        text = text.replace("other_surface = [\"top\"]", "other_cut = \"worn_top\"");
        text.push_str("\n[[cuts]]\nname = \"worn_top\"\nbody = \"flat\"\npoints = [[1.6, 0.0], [-1.6, 0.0]]\n");
    }
    text.push_str(&format!(
        "\n[steps]\npath = [[0.0, 0.0], [1.0, 1.0], [2.0, 1.0]]\ncycle = [1.0, 2.0]\ncycles = 1\nincrements = {increments}\n"
    ));
    let case = mortex::case::parse(&text, "mccoll_no_wear", Path::new("wear_cases"), "mccoll_no_wear")
        .unwrap_or_else(|e| panic!("{e}"));
    let model = case.model;
    let mut state = StaticAnalysis::initial_state_of(&model);
    let mut out = vec![];
    run(&model, &mut state, RunOptions::default(), |_, st, _, d| {
        let f = mortex::contact::contact_field(&d.contact, &st.contact_unknowns(), 0);
        out.push(f.iter().map(|n| n.pressure).collect());
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.len(), 1 + increments);
    out
}

/// At every increment of the cycle, at 4, 8 and 16 increments per cycle, real and virtual
/// flat: peak pressure within 1% of the static one and the profile within 2% in L2, and no
/// node without pressure between two that carry it. What remains is independent of the
/// increment size (measured 0.1-0.15% and 1.3-1.4% at 4, 8 and 16 increments): the bodies are
/// not half-spaces, so the shear couples weakly to the normal problem, and the contact moves
/// over the flat's graded mesh. Before each step was paired in its own end configuration, 4
/// increments gave a peak of 1,292 MPa and nine zero-pressure nodes inside the contact.
#[test]
fn finite_sliding_keeps_the_static_pressure_at_any_increment() {
    for virtual_flat in [false, true] {
        for increments in [4, 8, 16] {
            let p = cycle_pressures(increments, virtual_flat);
            let p0 = &p[0];
            let p0_max = p0.iter().fold(0.0_f64, |a, &b| a.max(b));
            let norm0 = p0.iter().map(|v| v * v).sum::<f64>().sqrt();
            let (mut worst_max, mut worst_l2) = (0.0_f64, 0.0_f64);
            for (k, pk) in p.iter().enumerate().skip(1) {
                let pk_max = pk.iter().fold(0.0_f64, |a, &b| a.max(b));
                let l2 = pk.iter().zip(p0).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt() / norm0;
                worst_max = worst_max.max((pk_max / p0_max - 1.0).abs());
                worst_l2 = worst_l2.max(l2);
                let carrying: Vec<usize> = (0..pk.len()).filter(|&i| pk[i] > 1e-6 * pk_max).collect();
                let (first, last) = (carrying[0], carrying[carrying.len() - 1]);
                let holes = (first..=last).filter(|i| !carrying.contains(i)).count();
                assert_eq!(
                    holes,
                    0,
                    "virtual {virtual_flat}, {increments} increments, step {}: zero-pressure nodes inside",
                    k + 1
                );
            }
            eprintln!(
                "virtual {virtual_flat}, {increments} increments: static p_max {p0_max:.1} MPa; worst p_max error {worst_max:.2e}, L2 {worst_l2:.2e}"
            );
            assert!(worst_max < 0.01, "virtual {virtual_flat}, {increments} increments: p_max error {worst_max:.3e}");
            assert!(worst_l2 < 0.02, "virtual {virtual_flat}, {increments} increments: L2 error {worst_l2:.3e}");
        }
    }
}

/// The same scene with contact meshes eight times finer (segments of 0.37-0.5 um, 136k DOFs),
/// at 4 increments per cycle: the static pressure is kept as on the shipped meshes. Each step
/// is solved on the interface rows near the contact in its pairing, chosen from the gaps of
/// the undeformed surfaces within 0.2 segments of the smallest; on these segments that margin
/// (0.07-0.1 um) is below the undeformed gap the load closes (`a^2 / 2R` = 0.11 um at the
/// edge of the static contact), so rows that carry the load at the start of a step can lie
/// outside it. They join the set; left out, their multipliers were zeroed after the solve and
/// the first stroke increment stopped with a false "gross sliding" error (checked).
#[test]
fn finite_sliding_keeps_the_static_pressure_on_a_mesh_eight_times_finer() {
    let p = cycle_pressures_on(4, false, 8);
    let p0 = &p[0];
    let p0_max = p0.iter().fold(0.0_f64, |a, &b| a.max(b));
    let norm0 = p0.iter().map(|v| v * v).sum::<f64>().sqrt();
    for (k, pk) in p.iter().enumerate().skip(1) {
        let pk_max = pk.iter().fold(0.0_f64, |a, &b| a.max(b));
        let l2 = pk.iter().zip(p0).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt() / norm0;
        let carrying: Vec<usize> = (0..pk.len()).filter(|&i| pk[i] > 1e-6 * pk_max).collect();
        let (first, last) = (carrying[0], carrying[carrying.len() - 1]);
        let holes = (first..=last).filter(|i| !carrying.contains(i)).count();
        eprintln!("step {}: p_max {pk_max:.1} (static {p0_max:.1}) MPa, L2 {l2:.2e}, holes {holes}", k + 1);
        // The tolerances of the shipped meshes (1% in p_max, 2% in L2, no hole).
        assert_eq!(holes, 0, "step {}: zero-pressure nodes inside the contact", k + 1);
        assert!((pk_max / p0_max - 1.0).abs() < 0.01, "step {}: p_max {pk_max} against {p0_max}", k + 1);
        assert!(l2 < 0.02, "step {}: L2 {l2:.3e}", k + 1);
    }
}

/// Final wear state of a run: flat depths, cylinder depths, worn areas, wear works, coefficients.
type WearEnd = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// Final wear state of the shipped McColl case at `cycles` cycles, finite sliding, `increments`
/// per cycle.
fn finite_sliding_wear(cycles: usize, increments: usize) -> WearEnd {
    let text = std::fs::read_to_string("wear_cases/mccoll_fretting.toml")
        .expect("shipped case")
        .replace("cycles = 18000", &format!("cycles = {cycles}"))
        .replace("increments = 8", &format!("increments = {increments}"))
        .replace("friction = 0.9", "friction = 0.9\nsliding = \"finite\"");
    let case =
        mortex::case::parse(&text, "mccoll", Path::new("wear_cases"), "mccoll").unwrap_or_else(|e| panic!("{e}"));
    let model = case.model;
    let mut state = StaticAnalysis::initial_state_of(&model);
    run(&model, &mut state, RunOptions::default(), |_, _, _, _| Ok(())).unwrap_or_else(|e| panic!("{e}"));
    let k = model.wear.surfaces.iter().map(|w| w.coefficient).collect();
    let w = state.wear;
    (w.depth[0].clone(), w.depth[1].clone(), w.worn_area, w.work, k)
}

/// Wear swept along the stroke: the McColl case at 1,000 cycles with finite sliding at 4, 8
/// and 16 increments per cycle gives both bodies' largest depths within 1% of the 32-increment
/// run, the profiles at 8 and 16 increments within 1% in L2 (over the largest value), and worn
/// areas that balance the wear work to 1e-10 (they do by construction: the swept sub-positions
/// share the step's work exactly). Measured: 4 increments +0.2% (flat) and +0.5% (cylinder) in
/// depth. The 4-increment profiles miss the 1% L2 target: 1.5% (flat) and 0.8% (cylinder),
/// at the scar edges, where the pressure changes within a step faster than linearly.
/// Sampling one position per increment at the end-of-step pressure put the flat 16% too deep at
/// 4 increments; sweeping at the end-of-step pressure, 2.2%. About 2.5 minutes: ignored, run
/// with `cargo test --release --test fretting_frame -- --ignored`.
#[test]
#[ignore]
fn swept_wear_converges_in_the_increments_per_cycle() {
    let reference = finite_sliding_wear(1000, 32);
    let max = |v: &[f64]| v.iter().fold(0.0_f64, |a, &b| a.max(b));
    for increments in [4, 8, 16] {
        let run = finite_sliding_wear(1000, increments);
        for (body, (d, d_ref)) in [(&run.0, &reference.0), (&run.1, &reference.1)].into_iter().enumerate() {
            let depth_error = (max(d) / max(d_ref) - 1.0).abs();
            let l2 = d.iter().zip(d_ref).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt()
                / d_ref.iter().map(|b| b * b).sum::<f64>().sqrt();
            eprintln!(
                "{increments} increments, body {body}: depth {:.4} um, error {depth_error:.2e}, L2 {l2:.2e}",
                1e3 * max(d)
            );
            assert!(depth_error < 0.01, "{increments} increments, body {body}: depth {depth_error:.2e}");
            if increments > 4 {
                assert!(l2 < 0.01, "{increments} increments, body {body}: L2 {l2:.2e}");
            }
        }
        for i in 0..2 {
            let balance = (run.2[i] - run.4[i] * run.3[i]).abs() / run.2[i];
            assert!(balance < 1e-10, "{increments} increments, surface {i}: balance {balance:.1e}");
        }
    }
}

#[path = "common/halfplane.rs"]
mod halfplane;
use halfplane::{HalfPlaneFretting, Profile};

/// The McColl scene as half-planes (see `common/halfplane.rs`): E* = E / (2 (1 - nu^2)).
fn mccoll_half_planes(increments: usize, panel: f64) -> HalfPlaneFretting {
    HalfPlaneFretting {
        radius: 6.0,
        load: 18.5,
        e_star: 200_000.0 / (2.0 * (1.0 - 0.3 * 0.3)),
        stroke: 0.025,
        k_flat: 2.9e-8,
        k_cylinder: 1.9e-8,
        panel,
        window: 0.14,
        increments,
        substeps: 8,
    }
}

/// Largest depth, width where the depth is at least 1% of it, and area of a profile.
fn scar(x: &[f64], d: &[f64]) -> (f64, f64, f64) {
    let max = d.iter().fold(0.0_f64, |a, &b| a.max(b));
    let on: Vec<f64> = x.iter().zip(d).filter(|(_, &v)| v >= 0.01 * max).map(|(&x, _)| x).collect();
    let width = on.iter().cloned().fold(f64::MIN, f64::max) - on.iter().cloned().fold(f64::MAX, f64::min);
    let mut o: Vec<(f64, f64)> = x.iter().cloned().zip(d.iter().cloned()).collect();
    o.sort_by(|a, b| a.0.total_cmp(&b.0));
    let area = o.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum();
    (max, width, area)
}

/// The shipped McColl case at 1,000 cycles (its defaults): the depth profiles of both bodies
/// (x of each vertex, depth), worn areas, and the pressure profiles (x, p) of the multiplier
/// nodes at the four stroke positions of the last computed cycle (+25, 0, -25, 0 um).
struct EngineRun {
    flat: (Vec<f64>, Vec<f64>),
    cylinder: (Vec<f64>, Vec<f64>),
    worn_area: Vec<f64>,
    /// Multiplier node positions, pressures `-lambda_n` and nodal tractions at the four stroke
    /// positions of the last cycle.
    last_cycle: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)>,
}

fn mccoll_engine(cycles: usize) -> EngineRun {
    mccoll_engine_with(cycles, &|text| text)
}

/// [`mccoll_engine`] on the shipped case edited by `edit`.
fn mccoll_engine_with(cycles: usize, edit: &dyn Fn(String) -> String) -> EngineRun {
    let text = edit(std::fs::read_to_string("wear_cases/mccoll_fretting.toml").expect("shipped case"))
        .replace("cycles = 18000", &format!("cycles = {cycles}"));
    engine_run_of(&text)
}

/// The McColl scene of case text `text` run to its end: depths, worn areas and the last
/// computed cycle's stroke positions.
fn engine_run_of(text: &str) -> EngineRun {
    let case = mortex::case::parse(text, "mccoll", Path::new("wear_cases"), "mccoll").unwrap_or_else(|e| panic!("{e}"));
    let model = case.model;
    let increments = model.cycle.expect("a cyclic case").increments;
    let mut state = StaticAnalysis::initial_state_of(&model);
    let mut profiles = vec![];
    run(&model, &mut state, RunOptions::default(), |_, st, _, d| {
        let f = mortex::contact::contact_field(&d.contact, &st.contact_unknowns(), 0);
        profiles.push((
            f.iter().map(|n| n.position.x).collect(),
            f.iter().map(|n| n.pressure).collect(),
            f.iter().map(|n| n.nodal_pressure).collect(),
        ));
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let w = state.wear;
    let xs = |i: usize| w.vertices[i].iter().map(|v| v[0]).collect::<Vec<f64>>();
    EngineRun {
        flat: (xs(0), w.depth[0].clone()),
        cylinder: (xs(1), w.depth[1].clone()),
        worn_area: w.worn_area.clone(),
        // The four stroke positions (+25, 0, -25, 0 um) of the last cycle.
        last_cycle: profiles
            .split_off(profiles.len() - increments)
            .into_iter()
            .skip(increments / 4 - 1)
            .step_by(increments / 4)
            .collect(),
    }
}

/// Writes the half-plane pressures of cycle 1,000 (one profile per eighth of the cycle,
/// increments 1-8 as the engine numbers them at its default 8 increments) in the layout of a
/// result file's `/series`, so that
/// `mortex plot <run.h5> --cycle 1000 --reference <this>` draws the engine against it.
fn write_reference(path: &Path, x: &[f64], profiles: &[Vec<f64>]) {
    let f = hdf5::File::create(path).unwrap();
    let series = f.create_group("series").unwrap();
    let n = profiles.len();
    series.new_dataset_builder().with_data(&vec![1000u64; n]).create("cycle").unwrap();
    series.new_dataset_builder().with_data(&(1..=n as u64).collect::<Vec<u64>>()).create("increment").unwrap();
    let pair = series.create_group("contacts").unwrap().create_group("pair").unwrap();
    let pressure = ndarray::Array2::from_shape_fn((n, x.len()), |(s, i)| profiles[s][i]);
    let position = ndarray::Array3::from_shape_fn((n, x.len(), 2), |(_, i, c)| if c == 0 { x[i] } else { 0.0 });
    pair.new_dataset_builder().with_data(&pressure).create("pressure").unwrap();
    pair.new_dataset_builder().with_data(&position).create("position").unwrap();
}

/// L2 difference of a profile (x, v) from a reference on a uniform grid, over the reference's
/// L2 norm (the profile interpolated linearly onto the grid, 0 outside it).
fn l2_against(x: &[f64], v: &[f64], xr: &[f64], vr: &[f64]) -> f64 {
    let profile = Profile::new(x, v);
    let num: f64 = xr.iter().zip(vr).map(|(&t, &r)| (profile.at(t) - r).powi(2)).sum();
    let den: f64 = vr.iter().map(|r| r * r).sum();
    (num / den).sqrt()
}

/// An independent reference (`common/halfplane.rs`): both bodies as elastic half-planes with
/// panel pressures, both worn by Archard's law, the flat swept under the held cylinder, 16
/// increments per cycle, 1 um panels, no cycle jump (converged: 8 to 64 increments and 2 or
/// 1 um panels give the same depths to 0.1%). The shipped case at 1,000 cycles (defaults):
/// - raw, the engine's depths are 1.95% (flat) and 2.96% (cylinder) below the half-planes',
///   tolerance 3%: the finite bodies' elastic tangential compliance takes up part of each
///   stroke before the contact slips again (the half-planes slip over the whole stroke). The
///   engine's worn areas measure what is left, exactly (`k P S N`, the balance holds to
///   round-off): 96.9% of the stroke, bound [95%, 100%] (the line-load compliance of the
///   half-planes, with the load points 2 mm and 6 mm deep, estimates 1.7%);
/// - given the engine's slip (its stroke scaled by that ratio), the half-planes' largest
///   depths are within 1% (measured 0.33%, 0.46%): the figure the bodies' finite size leaves
///   is the tilt of the surface under the shear, of order (a / thickness)^2;
/// - the profiles within 4% in L2 (measured 1.96%, 1.68%): the flanks of the scars, where the
///   cylinder's edge rides at the stroke ends, are resolved by 8-9 um segments (flat) while the
///   depth there falls from 190 to 5 nm over 40 um; the scar widths (1% of the largest depth)
///   within two segments, 18 um (measured +15.6 um flat, -5.6 um cylinder).
///
/// The pressure is printed, not asserted (known fault, docs/validation.md): at the stroke ends
/// the engine's differs from the half-planes' by 32% in L2 (p_max 330 against 334 MPa), at the
/// centre by 15% (p_max 170 against 116 MPa): the interior follows the reference, the
/// outermost node at the scar's edge carries a spike (with the jump linearised at one stroke
/// position, 4 increments: 44% and 19-22%). The half-plane model given the engine's worn
/// profiles finds its kind of pressure (p_max 384 MPa at the stroke end; 503 MPa before):
/// element-scale roughness of the worn geometry, well under a nanometre, not the contact
/// solve, makes the difference.
#[test]
fn mccoll_against_half_planes() {
    let engine = mccoll_engine(1000);
    let cmp = against_half_planes(&engine);
    assert!((0.95..1.0).contains(&cmp.slip_ratio), "slip ratio {}", cmp.slip_ratio);
    let segment = 0.009;
    for b in &cmp.bodies {
        let name = b.name;
        assert!(b.raw.abs() < 0.03, "{name}: depth against the full-stroke half-planes {:+.3e}", b.raw);
        assert!(b.depth.abs() < 0.01, "{name}: depth {:+.3e}", b.depth);
        assert!(b.profile_l2 < 0.04, "{name}: profile L2 {:.3e}", b.profile_l2);
        assert!((b.width - b.width_ref).abs() < 2.0 * segment, "{name}: width {} against {}", b.width, b.width_ref);
    }
    // The nodal traction (each node's force over its hat) is what the nodes transmit; it is
    // closer to the reference than the multiplier's values at every stroke position (measured
    // 28.6% / 9.2% against 31.9% / 14.8%): the undershoot beside the rim's spike is gone.
    for (k, (t, p)) in cmp.nodal_l2.iter().zip(&cmp.pressure_l2).enumerate() {
        assert!(t < p, "stroke position {k}: nodal traction L2 {t:.3} against the multiplier's {p:.3}");
    }
    if let Ok(path) = std::env::var("MORTEX_HALFPLANE_H5") {
        write_reference(Path::new(&path), &cmp.x, &cmp.reference_pressure);
    }
    let calibrated = cmp.calibrated;
    let worn = calibrated.state_with(
        &Profile::new(&engine.cylinder.0, &engine.cylinder.1),
        &Profile::new(&engine.flat.0, &engine.flat.1),
    );
    let p = calibrated.pressure_at(&worn, calibrated.stroke);
    eprintln!(
        "the engine's worn profiles in the half-plane model at the stroke end: p_max {:.0} MPa",
        p.iter().fold(0.0_f64, |a, &b| a.max(b))
    );
}

/// The McColl scene on contact meshes four times finer (cylinder 640 angular divisions, flat
/// 480: segments of 0.7-2.3 um over the scars, against 3-9 um shipped; 67k DOFs), defaults
/// otherwise, at 1,000 cycles against the half-plane reference (as
/// [`mccoll_against_half_planes`]).
/// - It runs through: before the interface iterations were bounded by the live contact rows, the first
///   increment after the jump to cycle 707 needed 26 active-set iterations against a limit of
///   25 and stopped with a false "gross sliding" error (every node slides one way in gross
///   slip; the cylinder is held).
/// - The scars converge in the mesh: largest depths within 1% given the engine's slip (as on
///   the shipped mesh: the bodies' finite size); profiles within 1% in L2, a quarter of the
///   shipped mesh's bound with a quarter of its segments on the flanks (measured 0.41% / 0.41%,
///   shipped 1.96% / 1.68%); widths within two segments, 4.6 um (measured +2.3 / +0.5 um).
/// - The pressure at the stroke ends within 25% in L2 (shipped mesh: 32%; measured 21-22%):
///   what is left is the scar's rim, where the reference rises from 0 to 330 MPa within 5 um
///   and the engine's contact ends one node (2.2 um) inside it. With jumps of at most 10 cycles
///   the same mesh gives 12.6% at the stroke ends and 11.3% at the centre (docs/validation.md).
#[test]
fn mccoll_on_a_mesh_four_times_finer() {
    let engine = mccoll_engine_with(1000, &|text| {
        text.replace("divisions = [30, 160]", "divisions = [30, 640]")
            .replace("divisions = [120, 30]", "divisions = [480, 30]")
    });
    let cmp = against_half_planes(&engine);
    let segment = 0.0023;
    for b in &cmp.bodies {
        let name = b.name;
        assert!(b.depth.abs() < 0.01, "{name}: depth {:+.3e}", b.depth);
        assert!(b.profile_l2 < 0.01, "{name}: profile L2 {:.3e}", b.profile_l2);
        assert!((b.width - b.width_ref).abs() < 2.0 * segment, "{name}: width {} against {}", b.width, b.width_ref);
    }
    for k in [0, 2] {
        assert!(cmp.pressure_l2[k] < 0.25, "stroke end {k}: pressure L2 {:.3}", cmp.pressure_l2[k]);
    }
    // The nodal traction closer to the reference at every stroke position (measured 18.4% /
    // 10.3% against 20.9-22.1% / 14.3-14.6%).
    for (k, (t, p)) in cmp.nodal_l2.iter().zip(&cmp.pressure_l2).enumerate() {
        assert!(t < p, "stroke position {k}: nodal traction L2 {t:.3} against the multiplier's {p:.3}");
    }
}

/// Output steps of the shipped McColl run (18,000 cycles, defaults) in which a node between the
/// first and the last loaded node of the contact reads zero: `(nodal traction, multiplier)`.
/// The worn contact's edge rides at the stroke ends on the kink of the flat's scar rim, which
/// lies between two of the cylinder's multiplier nodes on the shipped mesh (10-16 um segments
/// there): the multiplier's coefficients put the spike on the nearer node and undershoot to an
/// open row beside it (a half-plane model of the same worn geometry carries 200 MPa there).
/// The nodal traction is what each node transmits, its force over its hat; it reads zero at no
/// node inside the contact throughout the run (tolerance none: a count), while the multiplier's
/// coefficients do in about a fifth of the steps from cycle 3,300 on (printed).
#[test]
fn shipped_fretting_run_transmits_pressure_at_every_node_inside_the_contact() {
    let text = std::fs::read_to_string("wear_cases/mccoll_fretting.toml").expect("shipped case");
    let case =
        mortex::case::parse(&text, "mccoll", Path::new("wear_cases"), "mccoll").unwrap_or_else(|e| panic!("{e}"));
    let model = case.model;
    let mut state = StaticAnalysis::initial_state_of(&model);
    // A node inside the contact reading zero: between the first and the last positive one.
    let hole = |v: &[(f64, f64)]| {
        let loaded: Vec<usize> = (0..v.len()).filter(|&i| v[i].1 > 0.0).collect();
        match (loaded.first(), loaded.last()) {
            (Some(&a), Some(&b)) => (a..=b).any(|i| v[i].1 <= 0.0),
            _ => false,
        }
    };
    let (mut steps, mut nodal_holes, mut multiplier_holes) = (0, 0, 0);
    run(&model, &mut state, RunOptions::default(), |_, st, _, d| {
        let f = mortex::contact::contact_field(&d.contact, &st.contact_unknowns(), 0);
        let sorted = |g: &dyn Fn(&mortex::contact::ContactNodeState) -> f64| {
            let mut v: Vec<(f64, f64)> = f.iter().map(|n| (n.position.x, g(n))).collect();
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            v
        };
        steps += 1;
        nodal_holes += usize::from(hole(&sorted(&|n| n.nodal_pressure)));
        multiplier_holes += usize::from(hole(&sorted(&|n| n.pressure)));
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e}"));
    eprintln!("{steps} steps; a zero inside the contact: nodal traction {nodal_holes}, multiplier {multiplier_holes}");
    assert!(steps > 500, "the run recorded {steps} steps");
    assert_eq!(nodal_holes, 0, "steps with a node inside the contact transmitting no pressure");
}

/// The shipped tractions case (`wear_cases/mccoll_tractions.toml`: contact meshes eight times
/// finer, jumps of at most 10 cycles, 1,000 cycles, about 9 minutes; ignored) against the
/// half-plane reference: at the stroke ends and the centre of the stroke the nodal traction
/// within the 10% target in L2 and its largest value within 10% of the reference's (measured
/// 9.5-9.6% / 7.8%, p_max 351 / 121-122 against 334 / 116 MPa); depth profiles within 1%
/// (measured 0.25% / 0.22%). The engine's last computed cycle is 996 (jumps of up to 10
/// cycles), 0.4% of the wear short of the reference's 1,000.
#[test]
#[ignore]
fn tractions_case_against_half_planes() {
    let text = std::fs::read_to_string("wear_cases/mccoll_tractions.toml").expect("shipped case");
    let cmp = against_half_planes(&engine_run_of(&text));
    for b in &cmp.bodies {
        assert!(b.profile_l2 < 0.01, "{}: profile L2 {:.3e}", b.name, b.profile_l2);
    }
    for k in 0..4 {
        let (l2, pm, pr) = (cmp.nodal_l2[k], cmp.nodal_max[k], cmp.reference_max[k]);
        assert!(l2 < 0.10, "stroke position {k}: nodal traction L2 {l2:.3}");
        assert!((pm / pr - 1.0).abs() < 0.10, "stroke position {k}: p_max {pm:.0} against {pr:.0} MPa");
    }
}

/// One body's scar against the half-plane reference at the same cycle.
struct ScarComparison {
    name: &'static str,
    /// Largest depth relative to the reference's given the engine's slip, and to the
    /// full-stroke reference's; profile L2; scar widths (1% of the largest depth), mm.
    depth: f64,
    raw: f64,
    profile_l2: f64,
    width: f64,
    width_ref: f64,
}

/// An engine run at 1,000 cycles against the half-plane reference given its slip.
struct HalfPlaneComparison {
    slip_ratio: f64,
    bodies: Vec<ScarComparison>,
    /// Pressure L2 at the four stroke positions of cycle 1,000: the multiplier's values and the
    /// nodal traction; the nodal traction's largest value and the reference's.
    pressure_l2: Vec<f64>,
    nodal_l2: Vec<f64>,
    nodal_max: Vec<f64>,
    reference_max: Vec<f64>,
    /// The reference's panel centres, its pressure at every eighth of cycle 1,000, and the
    /// model whose stroke is the engine's slip.
    x: Vec<f64>,
    reference_pressure: Vec<Vec<f64>>,
    calibrated: HalfPlaneFretting,
}

/// Compares `engine` (1,000 cycles) with the half-plane model (16 increments, 1 um panels),
/// its stroke scaled to the engine's slip (the worn area over `k P 4 delta N`); prints the figures.
fn against_half_planes(engine: &EngineRun) -> HalfPlaneComparison {
    let (k_flat, load, cycles, stroke) = (2.9e-8, 18.5, 1000.0, 0.025);
    let reference = mccoll_half_planes(16, 0.001);
    let rigid = reference.run(1000, |_, _, _, _| {});
    let slip_ratio = engine.worn_area[0] / (k_flat * load * cycles * 4.0 * stroke);
    let mut calibrated = reference.clone();
    calibrated.stroke *= slip_ratio;
    let mut ref_p = vec![];
    let end = calibrated.run(1000, |c, i, _, st| {
        // Every eighth of the cycle (the engine's 8 increments); every other one is a stroke
        // position the comparison uses.
        if c == 1000 && i % 2 == 0 {
            ref_p.push(st.pressure.clone());
        }
    });
    eprintln!("engine slip over the stroke: {slip_ratio:.4}");
    let mut bodies = vec![];
    for (name, (x, d), (xr, dr), dr_rigid) in [
        ("flat", &engine.flat, (&end.flat_x, &end.flat_depth), &rigid.flat_depth),
        ("cylinder", &engine.cylinder, (&end.x, &end.cylinder_depth), &rigid.cylinder_depth),
    ] {
        let (e, r) = (scar(x, d), scar(xr, dr));
        let b = ScarComparison {
            name,
            depth: e.0 / r.0 - 1.0,
            raw: e.0 / dr_rigid.iter().fold(0.0_f64, |a, &b| a.max(b)) - 1.0,
            profile_l2: l2_against(x, d, xr, dr),
            width: e.1,
            width_ref: r.1,
        };
        eprintln!(
            "{name}: depth {:.4} um, half-planes {:.4} um ({:+.2}%; full stroke {:+.2}%), width {:.1} / {:.1} um, profile L2 {:.2}%",
            1e3 * e.0,
            1e3 * r.0,
            100.0 * b.depth,
            100.0 * b.raw,
            1e3 * e.1,
            1e3 * r.1,
            100.0 * b.profile_l2
        );
        bodies.push(b);
    }
    let mut pressure_l2 = vec![];
    let (mut nodal_l2, mut nodal_max, mut reference_max) = (vec![], vec![], vec![]);
    for (k, ((x, p, t), pr)) in engine.last_cycle.iter().zip(ref_p.iter().skip(1).step_by(2)).enumerate() {
        let max = |v: &[f64]| v.iter().fold(0.0_f64, |a, &b| a.max(b));
        let (l2, l2_nodal) = (l2_against(x, p, &end.x, pr), l2_against(x, t, &end.x, pr));
        eprintln!(
            "cycle 1000, increment {}: p_max {:.0} (nodal traction {:.0}), half-planes {:.0} MPa; pressure L2 {:.1}% \
             (nodal traction {:.1}%)",
            k + 1,
            max(p),
            max(t),
            max(pr),
            100.0 * l2,
            100.0 * l2_nodal
        );
        pressure_l2.push(l2);
        nodal_l2.push(l2_nodal);
        nodal_max.push(max(t));
        reference_max.push(max(pr));
    }
    HalfPlaneComparison {
        slip_ratio,
        bodies,
        pressure_l2,
        nodal_l2,
        nodal_max,
        reference_max,
        x: end.x,
        reference_pressure: ref_p,
        calibrated,
    }
}

/// One output step of a wear run: its cycle and increment labels, the pressure of every contact
/// row and the rows' `int Phi` (the pairing of that increment), and, after a cycle's last
/// increment, what its jump predicted for the pressure at every increment of the next one.
struct RecordedStep {
    cycle: usize,
    increment: usize,
    pressure: Vec<f64>,
    phi: Vec<f64>,
    predicted: Vec<f64>,
    jump: u64,
}

/// Relative L2 of `found` against `expected`, weighted by `phi`.
fn weighted_l2(found: &[f64], expected: &[f64], phi: &[f64]) -> f64 {
    let (mut diff, mut norm) = (0.0, 0.0);
    for ((f, e), w) in found.iter().zip(expected).zip(phi) {
        diff += w * (f - e) * (f - e);
        norm += w * f * f;
    }
    (diff / norm).sqrt()
}

/// The implicit jump linearised at every stroke position (the shipped McColl case, finite
/// sliding, defaults, 1,000 cycles): each jump predicts the pressure at the end of its cycles
/// at each of the eight increments of the cycle, from the interface stiffness and the pairing
/// of each. The next computed cycle is the reference (the engine's own solve of the jumped
/// geometry): its pressure at every increment within 5% in the weighted L2 of the prediction
/// (the controller's own bound, `PRESSURE_PREDICTION_TOLERANCE`: the linearisation's error is
/// second order in the jump). Measured: at most 0.6%, while the pressure at the stroke ends
/// moves by up to 30% per jump (printed: assuming it unchanged, as a jump linearised at the
/// cycle's last increment only does there, would miss it by that much).
#[test]
fn implicit_jump_predicts_the_pressure_at_every_stroke_position() {
    let text = std::fs::read_to_string("wear_cases/mccoll_fretting.toml")
        .expect("shipped case")
        .replace("cycles = 18000", "cycles = 1000");
    let case =
        mortex::case::parse(&text, "mccoll", Path::new("wear_cases"), "mccoll").unwrap_or_else(|e| panic!("{e}"));
    let model = case.model;
    let increments = model.cycle.expect("a cyclic case").increments;
    let mut state = StaticAnalysis::initial_state_of(&model);
    let mut steps: Vec<RecordedStep> = vec![];
    run(&model, &mut state, RunOptions::default(), |report, st, _, d| {
        let nt = d.contact.first_multiplier;
        let pressure = (0..d.contact.rows.len()).map(|k| (-st.multipliers[nt + k]).max(0.0)).collect();
        steps.push(RecordedStep {
            cycle: report.cycle,
            increment: report.increment,
            pressure,
            phi: d.contact.phi.clone(),
            predicted: st.wear.controller.predicted.clone(),
            jump: st.wear.jump,
        });
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let (mut worst, mut worst_held, mut checked) = (0.0_f64, 0.0_f64, 0);
    for (s, step) in steps.iter().enumerate() {
        // The last increment of a computed cycle whose jump predicted the next one.
        if step.increment != increments || step.predicted.is_empty() || step.cycle == 0 {
            continue;
        }
        let next = &steps[s + 1..];
        if next.len() < increments {
            break;
        }
        let rows = step.pressure.len();
        assert_eq!(step.predicted.len(), rows * increments, "a prediction per row and increment");
        for (i, found) in next[..increments].iter().enumerate() {
            assert_eq!(found.increment, i + 1);
            let predicted = &step.predicted[i * rows..(i + 1) * rows];
            let error = weighted_l2(&found.pressure, predicted, &found.phi);
            let held = weighted_l2(&found.pressure, &steps[s + 1 + i - increments].pressure, &found.phi);
            worst = worst.max(error);
            worst_held = worst_held.max(held);
            checked += 1;
            assert!(
                error < 0.05,
                "cycle {} (after a jump of {}), increment {}: predicted pressure off by {:.2}% (unchanged: {:.1}%)",
                found.cycle,
                step.jump,
                i + 1,
                100.0 * error,
                100.0 * held
            );
        }
    }
    eprintln!(
        "{checked} predictions: worst {:.2}% (the pressure assumed unchanged over the jump: worst {:.1}%)",
        100.0 * worst,
        100.0 * worst_held
    );
    assert!(checked >= increments * 10, "at least ten jumps checked ({checked} predictions)");
}

/// `wear_cases/mccoll_tractions.toml` (the scene set up for its tractions, see its header and
/// docs/validation.md) is the shipped McColl case with only the contact meshes refined 8x,
/// 1,000 cycles and jumps of at most 10 cycles: every other key equal, so that the tractions
/// documented for it are those of the main case's scene.
#[test]
fn tractions_case_is_the_main_scene_refined() {
    let keys = |text: &str| -> Vec<String> {
        text.lines().map(|l| l.split('#').next().unwrap_or("").trim().to_string()).filter(|l| !l.is_empty()).collect()
    };
    let main = std::fs::read_to_string("wear_cases/mccoll_fretting.toml").expect("shipped case");
    let refined = main
        .replace("divisions = [30, 160]", "divisions = [30, 1280]")
        .replace("divisions = [120, 30]", "divisions = [960, 30]")
        .replace("cycles = 18000", "cycles = 1000")
        .replace("[output]", "[cycle_jump]\nmax_jump = 10\n\n[output]");
    let tractions = std::fs::read_to_string("wear_cases/mccoll_tractions.toml").expect("shipped case");
    assert_eq!(keys(&tractions), keys(&refined));
    let case = mortex::case::parse(&tractions, "mccoll_tractions", Path::new("wear_cases"), "mccoll_tractions")
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(case.model.cycle.expect("cyclic").increments, 8);
}
