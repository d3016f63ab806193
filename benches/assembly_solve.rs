//! Criterion benches of the FE core on the 300 x 300 Quad4 plane-strain block (181k DOFs):
//! sparsity pattern, assembly (serial and parallel), symbolic and numeric Cholesky, solve, and
//! the interface operator of the top edge's rows (forward substitution vs column solves).
//! `MORTEX_BENCH_N` overrides the size.

use criterion::{criterion_group, criterion_main, Criterion};
use mortex::assembly::{Assembler, AssemblyInput, AssemblyOutput, SparsityPattern};
use mortex::fem::material::{PlasticState, Stress4};
use mortex::scenes::block_model;
use mortex::solver::linear::{LinearSolverKind, SparseSolver};
use std::hint::black_box;

fn size() -> usize {
    std::env::var("MORTEX_BENCH_N").ok().and_then(|s| s.parse().ok()).unwrap_or(300)
}

fn benches(c: &mut Criterion) {
    let n = size();
    let model = block_model(n);
    let el = &model.elements;
    let mut g = c.benchmark_group(format!("block_{n}x{n}"));
    g.sample_size(10);
    g.bench_function("sparsity_pattern", |b| {
        b.iter(|| black_box(SparsityPattern::new(model.num_nodes(), el, &model.initial().dofs)))
    });
    let pattern = SparsityPattern::new(model.num_nodes(), el, &model.initial().dofs);
    g.bench_function("symbolic_cholesky", |b| {
        b.iter(|| black_box(SparseSolver::new(&pattern.symbolic, LinearSolverKind::Cholesky).ok()))
    });
    let mut solver = match SparseSolver::new(&pattern.symbolic, LinearSolverKind::Cholesky) {
        Ok(s) => s,
        Err(e) => panic!("symbolic factorisation: {e}"),
    };
    let mut asm = Assembler::new(pattern, el);
    let mut values = vec![0.0; asm.pattern.nnz()];
    let mut f = vec![0.0; model.num_dofs()];
    let mut stress = vec![Stress4::zeros(); el.num_points()];
    let mut hist: Vec<PlasticState> = vec![];
    let u = vec![0.0; model.num_dofs()];
    let input = AssemblyInput {
        coords: &model.coords,
        elements: el,
        materials: &model.materials,
        rules: &model.initial().rules,
        u: &u,
        state_old: &[],
    };
    for (name, parallel) in [("assembly_parallel", true), ("assembly_serial", false)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                asm.assemble(
                    &input,
                    AssemblyOutput {
                        values: Some(&mut values),
                        f_int: &mut f,
                        stress: &mut stress,
                        state_new: &mut hist,
                    },
                    parallel,
                )
            })
        });
    }
    g.bench_function("numeric_cholesky", |b| b.iter(|| solver.factor(&values).is_ok()));
    let rhs: Vec<f64> = model.initial().dofs.free.iter().map(|&d| model.f_ext[d]).collect();
    g.bench_function("solve", |b| {
        b.iter(|| {
            let mut x = rhs.clone();
            solver.solve(&mut x).is_ok()
        })
    });
    // Interface operator `C K^{-1} C^T` of mortar-like rows on the top edge (each row couples
    // the vertical DOFs of two neighbouring nodes): forward substitution over the reached
    // supernodes (what the condensed contact solve uses) against one full solve per row.
    asm.assemble(
        &input,
        AssemblyOutput { values: Some(&mut values), f_int: &mut f, stress: &mut stress, state_new: &mut hist },
        true,
    );
    if let Err(e) = solver.factor(&values) {
        panic!("numeric factorisation: {e}");
    }
    let top = &model.bodies[0].mesh.node_sets["top"];
    let rows: Vec<Vec<(usize, f64)>> =
        top.windows(2).map(|w| w.iter().map(|&n| (model.initial().dofs.eq[2 * n + 1], 0.5)).collect()).collect();
    // faer factors small matrices simplicially; forward substitution needs supernodes.
    if solver.congruence(&rows, 0, 0).is_some() {
        g.bench_function(format!("interface_operator_forward_substitution_{}_rows", rows.len()), |b| {
            b.iter(|| black_box(solver.congruence(&rows, 0, 0).map(|d| d[(0, 0)])))
        });
    } else {
        eprintln!("simplicial factor at this size: no forward-substitution bench");
    }
    g.bench_function(format!("interface_operator_column_solves_{}_rows", rows.len()), |b| {
        b.iter(|| {
            let nf = model.initial().dofs.num_free;
            let mut x = vec![0.0; nf * rows.len()];
            for (j, row) in rows.iter().enumerate() {
                for &(e, c) in row {
                    x[j * nf + e] += c;
                }
            }
            black_box(solver.solve_many(&mut x, rows.len()).map(|_| x[0]).expect("a factor"))
        })
    });
    g.finish();
}

criterion_group!(fe_core, benches);
criterion_main!(fe_core);
