//! Checkpoint and restart: a run resumes from any checkpoint, bit for bit.
//!
//! Each test runs a model to its end, writing a result file with a checkpoint per output step,
//! then reads the checkpoint of a middle step back, resumes a fresh analysis from it and runs to
//! the end again. Reference: the uninterrupted run itself; tolerance: none (every f64 of every
//! later state compared by its bits). Scenes: a J2-plastic cylinder (history on the points,
//! monolithic Newton) and a frictional two-cylinder contact under a stepped normal load then a
//! fretting cycle (interface condensation whose operator grows during the run, stick/slip,
//! accumulated slip and dissipation).

mod common;
use common::{CylinderPair, ResultFiles};
use mortex::io::checkpoint::{self, CheckpointError};
use mortex::io::ResultWriter;
use mortex::model::Model;
use mortex::solve::StaticAnalysis;
use mortex::state::SimState;
use std::path::Path;

fn tmpfile(name: &str) -> ResultFiles {
    ResultFiles::in_scratch("restart", name)
}

/// Runs `model` to the end writing `path` (checkpoint every step); returns every state.
fn run_all(model: &Model, path: &Path) -> Vec<SimState> {
    let mut a = StaticAnalysis::new(model).unwrap();
    let mut s = a.initial_state();
    let mut w = ResultWriter::create(path, model, "restart-test").unwrap();
    let mut states = vec![];
    a.run(&mut s, |r, st| {
        w.write_step(model, model.initial(), r, st).map_err(|e| e.to_string())?;
        states.push(st.clone());
        Ok(())
    })
    .unwrap();
    w.finish(true).unwrap();
    states
}

/// Resumes from the checkpoint of step `k` in `path`; returns the states after it.
fn resume_from(model: &Model, path: &Path, k: usize) -> Vec<SimState> {
    let mut s = checkpoint::read(path, Some(k), model).unwrap();
    let mut a = StaticAnalysis::new(model).unwrap();
    a.resume(&s).unwrap();
    let mut states = vec![];
    a.run(&mut s, |_, st| {
        states.push(st.clone());
        Ok(())
    })
    .unwrap();
    states
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Every field of two states, bit for bit.
fn assert_bitwise_equal(a: &SimState, b: &SimState) {
    let tag = format!("step {}", a.step);
    assert_eq!(
        (a.step, a.time.to_bits(), a.load_factor.to_bits()),
        (b.step, b.time.to_bits(), b.load_factor.to_bits())
    );
    assert_eq!(bits(&a.u), bits(&b.u), "{tag}: u");
    assert_eq!(bits(&a.f_int), bits(&b.f_int), "{tag}: f_int");
    assert_eq!(bits(&a.multipliers), bits(&b.multipliers), "{tag}: multipliers");
    assert_eq!(bits(&a.slip_increment), bits(&b.slip_increment), "{tag}: slip");
    assert_eq!(bits(&a.accumulated_slip), bits(&b.accumulated_slip), "{tag}: accumulated slip");
    assert_eq!(a.friction_status, b.friction_status, "{tag}: status");
    assert_eq!(a.dissipation.to_bits(), b.dissipation.to_bits(), "{tag}: dissipation");
    assert_eq!(a.interface_log, b.interface_log, "{tag}: interface log");
    let stress = |s: &SimState| s.stress.iter().flat_map(|x| x.iter().map(|v| v.to_bits())).collect::<Vec<_>>();
    assert_eq!(stress(a), stress(b), "{tag}: stress");
    let hist = |s: &SimState| {
        s.history
            .iter()
            .flat_map(|h| h.eps_p.iter().chain(&h.back).chain(std::iter::once(&h.alpha)).map(|v| v.to_bits()))
            .collect::<Vec<_>>()
    };
    assert_eq!(hist(a), hist(b), "{tag}: history");
}

#[test]
fn plastic_run_resumes_bit_for_bit() {
    let case = mortex::case::load(std::path::Path::new("wear_cases/plastic_cylinder.toml")).unwrap();
    let model = &case.model;
    let path = tmpfile("plastic.h5");
    let full = run_all(model, &path);
    assert!(full.len() >= 20, "the case has {} steps", full.len());
    let k = full.len() / 2;
    // The checkpoint reads back as the state it was written from.
    assert_bitwise_equal(&checkpoint::read(&path, Some(k), model).unwrap(), &full[k - 1]);
    assert!(full[k - 1].history.iter().any(|h| h.alpha > 0.0), "plastic history at the restart step");
    let resumed = resume_from(model, &path, k);
    assert_eq!(resumed.len(), full.len() - k);
    for (a, b) in full[k..].iter().zip(&resumed) {
        assert_bitwise_equal(a, b);
    }
}

#[test]
fn frictional_contact_run_resumes_bit_for_bit() {
    // Normal load in four steps, then Q = +-0.5 mu P. The load (a = 0.235 mm) makes the contact
    // outgrow the initial candidate rows (gap within half a segment length, |x| < 0.2 mm here),
    // so the condensed operator grows during the run.
    let (p, mu) = (1000.0, 0.3);
    let q = 0.5 * mu * p;
    let scene = CylinderPair {
        n_fine: 60,
        core: 0.25,
        virtual_lower: true,
        coarse_grained: false,
        mu,
        normal_load: p,
        normal_path: vec![(0.0, 0.0), (1.0, 1.0)],
        tangential_path: vec![(0.0, 0.0), (1.0, 0.0), (2.0, q), (3.0, -q), (4.0, q)],
        times: vec![0.05, 0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0],
    };
    let model = scene.build();
    let path = tmpfile("fretting.h5");
    let full = run_all(&model, &path);
    let last = full.last().unwrap();
    assert!(!last.interface_log.is_empty(), "the condensed operator should grow in this run");
    assert!(last.dissipation > 0.0 && last.friction_status.contains(&2));
    // Resume before the set grew, after it, and in the fretting cycle.
    let grew_at = full.iter().position(|s| !s.interface_log.is_empty()).unwrap() + 1;
    for k in [1, grew_at, 7] {
        let resumed = resume_from(&model, &path, k);
        assert_eq!(resumed.len(), full.len() - k);
        for (a, b) in full[k..].iter().zip(&resumed) {
            assert_bitwise_equal(a, b);
        }
    }
}

#[test]
fn checkpoint_that_does_not_fit_the_case_is_a_clear_error() {
    let plastic = mortex::case::load(std::path::Path::new("wear_cases/plastic_cylinder.toml")).unwrap();
    let path = tmpfile("fit.h5");
    let full = run_all(&plastic.model, &path);
    // Missing step: the error lists the steps that have one.
    match checkpoint::read(&path, Some(full.len() + 5), &plastic.model) {
        Err(CheckpointError::NoSuchStep { step, available, .. }) => {
            assert_eq!(step, full.len() + 5);
            assert_eq!(available.len(), full.len());
        }
        other => panic!("expected NoSuchStep, got {other:?}"),
    }
    // Another model (the elastic Lamé cylinder): sizes differ.
    let lame = mortex::case::load(std::path::Path::new("wear_cases/lame_cylinder.toml")).unwrap();
    let e = checkpoint::read(&path, Some(1), &lame.model).unwrap_err();
    assert!(matches!(e, CheckpointError::SizeMismatch { .. } | CheckpointError::TimeMismatch { .. }), "got {e}");
    assert!(e.to_string().contains("fit.h5"), "the message names the file: {e}");
    // Not a result file at all.
    let junk = tmpfile("junk.h5");
    std::fs::write(&junk, b"not hdf5").unwrap();
    let e = checkpoint::read(&junk, None, &plastic.model).unwrap_err();
    assert!(matches!(e, CheckpointError::Read { .. }) && e.to_string().contains("junk.h5"), "got {e}");
}
