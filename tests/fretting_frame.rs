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

use mortex::analysis::StaticAnalysis;
use mortex::driver::{run, RunOptions};
use std::path::Path;

/// Pressures of the cylinder's multiplier nodes (multiplier order) at every output step of one
/// gross-slip cycle at `increments` per cycle, finite sliding, no wear; `virtual_flat`: the
/// flat's top is a virtual surface (a cut through its host's top row, the host extended above).
fn cycle_pressures(increments: usize, virtual_flat: bool) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string("wear_cases/mccoll_fretting.toml").expect("shipped case");
    let mut text = text[..text.find("[[wear]]").expect("wear section")].to_string();
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

/// Final wear state of a run: flat depths, cylinder depths, worn areas, wear works, coefficients.
type WearEnd = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// Final wear state of the shipped McColl case at `cycles` cycles, finite sliding, `increments`
/// per cycle.
fn finite_sliding_wear(cycles: usize, increments: usize) -> WearEnd {
    let text = std::fs::read_to_string("wear_cases/mccoll_fretting.toml")
        .expect("shipped case")
        .replace("cycles = 18000", &format!("cycles = {cycles}"))
        .replace("increments = 4", &format!("increments = {increments}"))
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
