//! Criterion bench: embedding a 10k-segment closed surface in a 450 x 450 (202,500-cell) host
//! and re-cutting it (what every wear update will do). `MORTEX_BENCH_N` overrides the host size.

use criterion::{criterion_group, criterion_main, Criterion};
use mortex::cut::{cut_mesh, CellAdjacency};
use mortex::mesh::{generate, CellKind};
use mortex::surface::{embed, BoxIndex, VirtualSurface};
use nalgebra::Point2;
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let n: usize = std::env::var("MORTEX_BENCH_N").ok().and_then(|s| s.parse().ok()).unwrap_or(450);
    let host = match generate::rectangle(0.0, 0.0, 1.0, 1.0, n, n, 1.0, 1.0, CellKind::Quad4) {
        Ok(m) => m,
        Err(e) => panic!("host mesh: {e}"),
    };
    let segments = 10_000;
    let vertices = (0..segments)
        .map(|i| {
            let a = -std::f64::consts::TAU * i as f64 / segments as f64;
            Point2::new(0.5013 + 0.3 * a.cos(), 0.4987 + 0.3 * a.sin())
        })
        .collect();
    let surface = VirtualSurface { vertices, closed: true };
    let index = BoxIndex::over_cells(&host);
    let adjacency = CellAdjacency::new(&host);
    let mut g = c.benchmark_group(format!("embed_10k_in_{n}x{n}"));
    g.sample_size(20);
    g.bench_function("embed", |b| b.iter(|| black_box(embed(&surface, &host, &index).is_ok())));
    let emb = match embed(&surface, &host, &index) {
        Ok(e) => e,
        Err(e) => panic!("embedding: {e}"),
    };
    g.bench_function("cut", |b| b.iter(|| black_box(cut_mesh(&host, &adjacency, &[&emb]).is_ok())));
    g.bench_function("embed_and_cut", |b| {
        b.iter(|| {
            let e = embed(&surface, &host, &index);
            black_box(e.map(|e| cut_mesh(&host, &adjacency, &[&e]).is_ok()).is_ok())
        })
    });
    g.finish();
}

criterion_group!(embedding, benches);
criterion_main!(embedding);
