//! Criterion bench: the Hertz contact (cylinder on block, frictionless, condensed solve),
//! whole process (mesh, model, factorisation, Delassus operator, active set) and the solve
//! alone on a built model. `MORTEX_BENCH_H` sets the block core element (default 0.01 mm; the
//! CLI's `mortex bench --hertz` runs the three target sizes). And the condensed solver's set-up
//! on the McColl fretting model (wear_cases/mccoll_fretting.toml, 17k DOFs): built afresh
//! (pattern, symbolic and numeric factorisation, interface operator) against handed on from the
//! previous model of a run (numeric factorisation and interface operator only).

use criterion::{criterion_group, criterion_main, Criterion};
use mortex::solve::StaticAnalysis;
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let h: f64 = std::env::var("MORTEX_BENCH_H").ok().and_then(|s| s.parse().ok()).unwrap_or(0.01);
    let mut g = c.benchmark_group(format!("hertz_h{h}"));
    g.sample_size(10);
    for virtual_top in [false, true] {
        let name = if virtual_top { "virtual" } else { "real" };
        g.bench_function(format!("whole_process_{name}"), |b| {
            b.iter(|| black_box(mortex::scenes::run_hertz(h, virtual_top).map(|r| r.l2_error)))
        });
        let model = match mortex::scenes::hertz_model(h, virtual_top) {
            Ok(m) => m,
            Err(e) => panic!("Hertz model: {e}"),
        };
        g.bench_function(format!("factor_and_solve_{name}"), |b| {
            b.iter(|| {
                let mut a = match StaticAnalysis::new(&model) {
                    Ok(a) => a,
                    Err(e) => panic!("setup: {e}"),
                };
                let mut s = a.initial_state();
                black_box(a.run(&mut s, |_, _| Ok(())).is_ok())
            })
        });
    }
    g.finish();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/mccoll_fretting.toml");
    let model = match mortex::case::load(&path) {
        Ok(c) => c.model,
        Err(e) => panic!("McColl case: {e}"),
    };
    let mut g = c.benchmark_group("mccoll_condensed_setup");
    g.sample_size(10);
    g.bench_function("fresh", |b| b.iter(|| black_box(StaticAnalysis::new(&model).is_ok())));
    let mut reuse = StaticAnalysis::new(&model).ok().and_then(|a| a.into_reuse());
    g.bench_function("reused_structure", |b| {
        b.iter(|| {
            let a = match StaticAnalysis::with_reuse(&model, model.initial_shared(), reuse.take()) {
                Ok(a) => a,
                Err(e) => panic!("setup: {e}"),
            };
            assert!(a.structure_reused());
            reuse = a.into_reuse();
        })
    });
    g.finish();
}

criterion_group!(contact, benches);
criterion_main!(contact);
