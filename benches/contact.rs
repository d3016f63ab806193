//! Criterion bench: issue 4's Hertz contact (cylinder on block, frictionless, condensed solve),
//! whole process (mesh, model, factorisation, Delassus operator, active set) and the solve
//! alone on a built model. `MORTEX_BENCH_H` sets the block core element (default 0.01 mm; the
//! CLI's `mortex bench --hertz` runs the three sizes).

use criterion::{criterion_group, criterion_main, Criterion};
use mortex::analysis::StaticAnalysis;
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let h: f64 = std::env::var("MORTEX_BENCH_H").ok().and_then(|s| s.parse().ok()).unwrap_or(0.01);
    let mut g = c.benchmark_group(format!("hertz_h{h}"));
    g.sample_size(10);
    for virtual_top in [false, true] {
        let name = if virtual_top { "virtual" } else { "real" };
        g.bench_function(format!("whole_process_{name}"), |b| {
            b.iter(|| black_box(mortex::bench::run_hertz(h, virtual_top).map(|r| r.l2_error)))
        });
        let model = match mortex::bench::hertz_model(h, virtual_top) {
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
}

criterion_group!(contact, benches);
criterion_main!(contact);
