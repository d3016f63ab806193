//! The timings of `mortex bench`: assembly, factorisation and solve of a block, embedding and
//! cutting, output writing and re-cutting, on the scenes of [`mortex::scenes`].

use mortex::assembly::{Assembler, AssemblyInput, AssemblyOutput, SparsityPattern};
use mortex::case;
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, Material, PlaneHypothesis, PlasticState, Stress4};
use mortex::io::ResultWriter;
use mortex::mesh::{generate, CellKind};
use mortex::model::{LoadPath, ModelBuilder};
use mortex::scenes::{block_model, fretting_blocks_model};
use mortex::solver::linear::{LinearSolverError, LinearSolverKind, SparseSolver};
use mortex::solver::newton::NewtonParams;
use std::path::PathBuf;
use std::time::Instant;

/// Wall times in seconds of the pieces of one linear solve.
#[derive(Debug, Clone, Copy, Default)]
pub struct LinearSolveTimes {
    pub dofs: usize,
    pub nnz: usize,
    pub pattern: f64,
    pub assembly: f64,
    pub symbolic: f64,
    pub numeric: f64,
    pub solve: f64,
    /// Second assembly into the existing pattern (values refilled).
    pub refill: f64,
    pub refactor: f64,
    /// Relative residual `|K u - f| / |f|` of the solution.
    pub residual: f64,
}

impl LinearSolveTimes {
    /// pattern + assembly + symbolic + numeric + solve.
    pub fn whole(&self) -> f64 {
        self.pattern + self.assembly + self.symbolic + self.numeric + self.solve
    }
}

/// Times one linear solve of the `n x n` block, then a refill and a refactorisation.
pub fn time_linear_solve(n: usize, parallel: bool) -> Result<LinearSolveTimes, LinearSolverError> {
    let model = block_model(n);
    let mut t = LinearSolveTimes { dofs: model.num_dofs(), ..Default::default() };
    let el = &model.elements;
    let t0 = Instant::now();
    let pattern = SparsityPattern::new(model.num_nodes(), el, &model.initial().dofs);
    t.pattern = t0.elapsed().as_secs_f64();
    t.nnz = pattern.nnz();
    let t0 = Instant::now();
    let mut solver = SparseSolver::new(&pattern.symbolic, LinearSolverKind::Cholesky)?;
    t.symbolic = t0.elapsed().as_secs_f64();
    let mut asm = Assembler::new(pattern, el);
    let mut values = vec![0.0; asm.pattern.nnz()];
    let mut f_int = vec![0.0; model.num_dofs()];
    let mut stress = vec![Stress4::zeros(); el.num_points()];
    let mut hist: Vec<PlasticState> = vec![];
    let u = vec![0.0; model.num_dofs()];
    let mut assemble = |values: &mut [f64], f_int: &mut [f64]| {
        asm.assemble(
            &AssemblyInput {
                coords: &model.coords,
                elements: el,
                materials: &model.materials,
                rules: &model.initial().rules,
                u: &u,
                state_old: &[],
            },
            AssemblyOutput { values: Some(values), f_int, stress: &mut stress, state_new: &mut hist },
            parallel,
        )
    };
    let t0 = Instant::now();
    assemble(&mut values, &mut f_int);
    t.assembly = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    solver.factor(&values)?;
    t.numeric = t0.elapsed().as_secs_f64();
    let rhs: Vec<f64> = model.initial().dofs.free.iter().map(|&g| model.f_ext[g]).collect();
    let mut x = rhs.clone();
    let t0 = Instant::now();
    solver.solve(&mut x)?;
    t.solve = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    assemble(&mut values, &mut f_int);
    t.refill = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    solver.factor(&values)?;
    t.refactor = t0.elapsed().as_secs_f64();
    let mut kx = vec![0.0; x.len()];
    mortex::solver::linear::spmv(&asm.pattern.symbolic, &values, &x, &mut kx);
    let num: f64 = kx.iter().zip(&rhs).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    let den: f64 = rhs.iter().map(|b| b * b).sum::<f64>().sqrt();
    t.residual = num / den;
    Ok(t)
}

/// Wall times of embedding a closed polyline in a host mesh and cutting the host.
#[derive(Debug, Clone, Copy, Default)]
pub struct EmbedTimes {
    pub cells: usize,
    pub segments: usize,
    pub cut_cells: usize,
    /// Built once per host mesh: BVH over cells and cell adjacency.
    pub index: f64,
    /// Embedding the surface (clipping against BVH candidates).
    pub embed: f64,
    /// Classification, material loops and node fractions.
    pub cut: f64,
    /// Moment-fitted weights on the band rule, per cut cell (seconds per cell).
    pub fit_per_cell: f64,
    /// Sub-triangulation rule, per cut cell (seconds per cell).
    pub subtri_per_cell: f64,
}

/// A circle of `segments` segments (radius 0.3, centre slightly off the grid) in an `n x n`
/// `Quad4` unit square.
pub fn time_embedding(n: usize, segments: usize) -> Result<EmbedTimes, mortex::surface::SurfaceError> {
    use mortex::cut::{band_rule, cut_mesh, fit_weights, rule_points, subtriangulation_rule, CellAdjacency, CellCut};
    use mortex::surface::{embed, BoxIndex, VirtualSurface};
    let host = match generate::rectangle(0.0, 0.0, 1.0, 1.0, n, n, 1.0, 1.0, CellKind::Quad4) {
        Ok(m) => m,
        Err(e) => unreachable!("a unit square with n >= 1 divisions is valid: {e}"),
    };
    let mut t = EmbedTimes { cells: host.num_cells(), segments, ..Default::default() };
    // Clockwise circle: host material outside.
    let vertices: Vec<nalgebra::Point2<f64>> = (0..segments)
        .map(|i| {
            let a = -std::f64::consts::TAU * i as f64 / segments as f64;
            nalgebra::Point2::new(0.5013 + 0.3 * a.cos(), 0.4987 + 0.3 * a.sin())
        })
        .collect();
    let surface = VirtualSurface { vertices, closed: true };
    surface.validate()?;
    let t0 = Instant::now();
    let index = BoxIndex::over_cells(&host);
    let adjacency = CellAdjacency::new(&host);
    t.index = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let emb = embed(&surface, &host, &index)?;
    t.embed = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let cut = cut_mesh(&host, &adjacency, &[&emb])?;
    t.cut = t0.elapsed().as_secs_f64();
    let cut_cells: Vec<usize> =
        (0..host.num_cells()).filter(|&c| matches!(cut.cells[c], CellCut::Cut { .. })).collect();
    t.cut_cells = cut_cells.len();
    let rule = band_rule(CellKind::Quad4);
    let t0 = Instant::now();
    for &c in &cut_cells {
        if let CellCut::Cut { loops, .. } = &cut.cells[c] {
            let x = rule_points(&host, c, &rule);
            let inside: Vec<bool> = x.iter().map(|p| loops.iter().any(|l| mortex::cut::point_in_loop(l, *p))).collect();
            std::hint::black_box(fit_weights(&x, &inside, loops));
        }
    }
    t.fit_per_cell = t0.elapsed().as_secs_f64() / cut_cells.len().max(1) as f64;
    let t0 = Instant::now();
    for &c in &cut_cells {
        if let CellCut::Cut { loops, .. } = &cut.cells[c] {
            std::hint::black_box(subtriangulation_rule(&host, c, loops));
        }
    }
    t.subtri_per_cell = t0.elapsed().as_secs_f64() / cut_cells.len().max(1) as f64;
    Ok(t)
}

/// Figures of the output benchmark: a many-step contact run, solve and output timed apart.
#[derive(Debug, Clone, Copy)]
pub struct OutputRun {
    pub dofs: usize,
    /// Seconds in the solver (driver minus observer) and in the result writer.
    pub solve: f64,
    pub output: f64,
    /// Size of the result file and of the contact CSV, bytes.
    pub h5_bytes: u64,
    pub csv_bytes: u64,
}

/// Runs [`fretting_blocks_model`] for `steps` steps writing `out` (full fields every
/// `fields_every` steps, a checkpoint every `checkpoint_every`, 0: none).
pub fn run_output_bench(
    steps: usize,
    fields_every: usize,
    checkpoint_every: usize,
    out: &std::path::Path,
) -> anyhow::Result<OutputRun> {
    let model = fretting_blocks_model(steps)?;
    let mut state = mortex::solve::StaticAnalysis::initial_state_of(&model);
    let mut writer = mortex::io::ResultWriter::create(out, &model, "output-bench")?;
    writer.set_fields_every(fields_every);
    writer.set_checkpoint_every(checkpoint_every);
    let mut output = 0.0;
    let start = Instant::now();
    mortex::driver::run(&model, &mut state, mortex::driver::RunOptions::default(), |r, s, m, d| {
        let t0 = Instant::now();
        writer.write_step(m, d, r, s)?;
        output += t0.elapsed().as_secs_f64();
        Ok(())
    })?;
    let t0 = Instant::now();
    let file = writer.finish(true)?;
    output += t0.elapsed().as_secs_f64();
    let total = start.elapsed().as_secs_f64();
    let size = |p: &std::path::Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    let csv = std::path::PathBuf::from(format!("{}_contact.csv", file.with_extension("").display()));
    Ok(OutputRun {
        dofs: model.num_dofs(),
        solve: total - output,
        output,
        h5_bytes: size(&file),
        csv_bytes: size(&csv),
    })
}

/// Re-cut after a surface move: a straight open surface crossing an `n x n` `Quad4` unit square
/// host, moving one cell down; returns (cells, band cells, cut cells, seconds per move: embed,
/// re-cut, refit, ghost penalty, DOF map, averaged over `moves` moves).
pub fn time_recut(n: usize, moves: usize) -> anyhow::Result<(usize, usize, usize, f64)> {
    use mortex::moving::SurfaceMotion;
    use nalgebra::{Point2, Vector2};
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: 210_000.0, poisson: 0.3, hypothesis: hyp }));
    let host = generate::rectangle(0.0, 0.0, 1.0, 1.0, n, n, 1.0, 1.0, CellKind::Quad4)?;
    let body = b.add_body("host", host, mi, Formulation::Standard, 1.0);
    let h = 1.0 / n as f64;
    let y0 = 0.5 + 0.37 * h;
    b.add_cut("surface", body, vec![Point2::new(-0.1, y0), Point2::new(1.1, y0 + 0.013)], false, false)?;
    let curve = b.add_curve(LoadPath::new(vec![(0.0, 0.0), (1.0, 1.0)])?);
    b.set_cut_motion("surface", SurfaceMotion::Translation { direction: Vector2::new(0.0, -h), curve })?;
    b.fix(body, "bottom", 0, 0.0)?;
    b.fix(body, "bottom", 1, 0.0)?;
    let model = b.build(
        LoadPath::new(vec![(0.0, 1.0), (1.0, 1.0)])?,
        vec![1.0],
        NewtonParams::default(),
        LinearSolverKind::Cholesky,
    )?;
    let band = model.bands[body].as_ref().map_or(0, |b| b.cells.len());
    let mut disc = model.initial().clone();
    let start = Instant::now();
    let mut cut = 0;
    for k in 1..=moves {
        let r = disc.place_surfaces(&model, k as f64 / moves as f64)?;
        cut = r.cut_cells_by_degree.iter().sum::<usize>() + r.unfitted_cells;
    }
    Ok((n * n, band, cut, start.elapsed().as_secs_f64() / moves as f64))
}

/// `bench --wear`: the case run to its end with its output (fields, checkpoints as the case
/// says), then per chosen cycle the scar of every wearing surface and the wear balance, and
/// the time split.
pub(crate) fn bench_wear(path: PathBuf, at: &[u64]) -> anyhow::Result<()> {
    let c = case::load(&path)?;
    let model = &c.model;
    let out = std::env::temp_dir().join(format!("mortex-bench-wear-{}.h5", std::process::id()));
    let started = std::time::Instant::now();
    let mut writer = ResultWriter::create(&out, model, &c.name)?;
    writer.set_checkpoint_every(c.checkpoint_every);
    writer.set_keep_checkpoints(c.keep_checkpoints);
    writer.set_fields_every(c.fields_every);
    let mut state = mortex::solve::StaticAnalysis::initial_state_of(model);
    let mut output = 0.0;
    let timings = mortex::driver::run_timed(
        model,
        &mut state,
        mortex::driver::RunOptions { parallel: !c.serial },
        |r, s, m, d| {
            let t0 = std::time::Instant::now();
            writer.write_step(m, d, r, s)?;
            output += t0.elapsed().as_secs_f64();
            Ok(())
        },
    )?;
    let t0 = std::time::Instant::now();
    let file = writer.finish(true)?;
    output += t0.elapsed().as_secs_f64();
    let wall = started.elapsed().as_secs_f64();
    let size = std::fs::metadata(&file).map(|m| m.len()).unwrap_or(0);
    let table = mortex::io::wear_table(&file, model, at)?;
    println!(
        "{}: {} cycles, {} computed, {} steps, {} DOFs",
        c.name,
        state.wear.cycle,
        state.wear.computed_cycles,
        state.step,
        model.num_dofs()
    );
    println!("{table}");
    let rest = wall - timings.setup - timings.repairing - timings.solve - timings.wear - output;
    println!(
        "wall {wall:.1} s: contact solves {:.1} s, re-pairing {:.1} s (pairings {:.1} s, their interface operators {:.1} s), solver set-up {:.1} s (per surface position), wear update + re-cut {:.1} s, output {:.1} s ({:.1}%), other {:.1} s; result file {:.1} MB",
        timings.solve,
        timings.repairing,
        timings.pairings,
        timings.repairing - timings.pairings,
        timings.setup,
        timings.wear,
        output,
        100.0 * output / wall,
        rest,
        size as f64 / 1e6
    );
    println!(
        "per computed cycle: {:.3} s (contact {:.3}, re-pairing {:.3}, set-up {:.3}, wear {:.3}, output {:.3})",
        wall / state.wear.computed_cycles.max(1) as f64,
        timings.solve / state.wear.computed_cycles.max(1) as f64,
        timings.repairing / state.wear.computed_cycles.max(1) as f64,
        timings.setup / state.wear.computed_cycles.max(1) as f64,
        timings.wear / state.wear.computed_cycles.max(1) as f64,
        output / state.wear.computed_cycles.max(1) as f64
    );
    if timings.setups > 0 {
        println!(
            "solver set-ups: {}, {} of them numeric only (pattern and symbolic factorisation of the previous surface position kept)",
            timings.setups, timings.reused_setups
        );
    }
    let _ = std::fs::remove_file(&file);
    let _ = std::fs::remove_file(file.with_extension("xdmf"));
    let _ = std::fs::remove_file(format!("{}_contact.csv", file.with_extension("").display()));
    Ok(())
}

pub(crate) fn bench(n: usize, repeat: usize, serial: bool) -> anyhow::Result<()> {
    if n == 0 || repeat == 0 {
        return Err(anyhow::anyhow!("bench: n and repeat must be at least 1"));
    }
    let mut best: Option<crate::cli::bench::LinearSolveTimes> = None;
    for _ in 0..repeat {
        let t = crate::cli::bench::time_linear_solve(n, !serial)?;
        best = Some(match best {
            None => t,
            Some(b) => crate::cli::bench::LinearSolveTimes {
                pattern: b.pattern.min(t.pattern),
                assembly: b.assembly.min(t.assembly),
                symbolic: b.symbolic.min(t.symbolic),
                numeric: b.numeric.min(t.numeric),
                solve: b.solve.min(t.solve),
                refill: b.refill.min(t.refill),
                refactor: b.refactor.min(t.refactor),
                ..t
            },
        });
    }
    let Some(t) = best else {
        return Err(anyhow::anyhow!("no repetition ran"));
    };
    println!("{n} x {n} Quad4 plane-strain block: {} DOFs, {} non-zeros (best of {repeat}, {} element loop, {} rayon threads)", t.dofs, t.nnz, if serial { "serial" } else { "parallel" }, rayon::current_num_threads());
    println!("  sparsity pattern      {:8.4} s", t.pattern);
    println!("  assembly              {:8.4} s", t.assembly);
    println!("  symbolic Cholesky     {:8.4} s", t.symbolic);
    println!("  numeric Cholesky      {:8.4} s", t.numeric);
    println!("  solve                 {:8.4} s", t.solve);
    println!("  whole linear solve    {:8.4} s  (pattern + assembly + symbolic + numeric + solve)", t.whole());
    println!("  refill + refactor     {:8.4} s  ({:.4} + {:.4})", t.refill + t.refactor, t.refill, t.refactor);
    println!("  relative residual     {:8.1e}", t.residual);
    Ok(())
}

pub(crate) fn bench_embed(n: usize, segments: usize, repeat: usize) -> anyhow::Result<()> {
    if n == 0 || repeat == 0 || segments < 3 {
        return Err(anyhow::anyhow!("bench --embed: n and repeat must be at least 1, segments at least 3"));
    }
    let mut best: Option<crate::cli::bench::EmbedTimes> = None;
    for _ in 0..repeat {
        let t = crate::cli::bench::time_embedding(n, segments)?;
        best = Some(match best {
            None => t,
            Some(b) => crate::cli::bench::EmbedTimes {
                index: b.index.min(t.index),
                embed: b.embed.min(t.embed),
                cut: b.cut.min(t.cut),
                fit_per_cell: b.fit_per_cell.min(t.fit_per_cell),
                subtri_per_cell: b.subtri_per_cell.min(t.subtri_per_cell),
                ..t
            },
        });
    }
    let Some(t) = best else { return Err(anyhow::anyhow!("no repetition ran")) };
    println!(
        "closed surface of {} segments in a {n} x {n} Quad4 host ({} cells): {} cut cells (best of {repeat})",
        t.segments, t.cells, t.cut_cells
    );
    println!("  host BVH + adjacency (once per host)   {:8.4} s", t.index);
    println!("  embed (clip against BVH candidates)    {:8.4} s", t.embed);
    println!("  cut (classify, loops, node fractions)  {:8.4} s", t.cut);
    println!("  embed + re-cut                         {:8.4} s", t.embed + t.cut);
    println!("  moment fit per cut cell (8x8 points)   {:8.2} us", 1e6 * t.fit_per_cell);
    println!("  sub-triangulation rule per cut cell    {:8.2} us", 1e6 * t.subtri_per_cell);
    Ok(())
}

pub(crate) fn bench_hertz(repeat: usize) -> anyhow::Result<()> {
    if repeat == 0 {
        return Err(anyhow::anyhow!("bench --hertz: repeat must be at least 1"));
    }
    println!(
        "Hertz, cylinder R = 10 on block 40 x 20, P = 100 N/mm, frictionless (best of {repeat}, {} rayon threads)",
        rayon::current_num_threads()
    );
    println!("  block h    surface   DOFs      whole s  iterations  p0 err    a err     pressure L2");
    for h in [0.02, 0.01, 0.005] {
        for virtual_top in [false, true] {
            let mut best: Option<mortex::scenes::HertzRun> = None;
            for _ in 0..repeat {
                let r = mortex::scenes::run_hertz(h, virtual_top)?;
                if best.is_none_or(|b| r.seconds < b.seconds) {
                    best = Some(r);
                }
            }
            let Some(r) = best else { return Err(anyhow::anyhow!("no repetition ran")) };
            println!(
                "  {h:<9}  {:<8}  {:<8}  {:7.3}  {:10}  {:+7.3}%  {:+7.3}%  {:7.3}%",
                if virtual_top { "virtual" } else { "real" },
                r.dofs,
                r.seconds,
                r.iterations,
                100.0 * r.p0_error,
                100.0 * r.a_error,
                100.0 * r.l2_error
            );
        }
    }
    Ok(())
}

pub(crate) fn bench_output(steps: usize) -> anyhow::Result<()> {
    if steps == 0 {
        return Err(anyhow::anyhow!("bench --output: give at least 1 step"));
    }
    let dir = std::env::temp_dir().join(format!("mortex-bench-output-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    println!("output benchmark: {steps} steps of a fretting scene (contact series every step)");
    println!("  fields  checkpoints  DOFs     solve s   output s  output share  h5 MB    csv MB");
    for (fields, checkpoints) in [(100, 0), (100, 100), (1, 1)] {
        if fields == 1 && steps > 2000 {
            continue;
        }
        let out = dir.join(format!("bench_{fields}_{checkpoints}.h5"));
        let r = crate::cli::bench::run_output_bench(steps, fields, checkpoints, &out)?;
        println!(
            "  {fields:<6}  {checkpoints:<11}  {:<7}  {:8.2}  {:8.2}  {:10.1}%  {:7.1}  {:7.1}",
            r.dofs,
            r.solve,
            r.output,
            100.0 * r.output / (r.solve + r.output),
            r.h5_bytes as f64 / 1e6,
            r.csv_bytes as f64 / 1e6
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

pub(crate) fn bench_recut(n: usize, repeat: usize) -> anyhow::Result<()> {
    if n < 2 || repeat == 0 {
        return Err(anyhow::anyhow!("bench --recut: n >= 2 and repeat >= 1"));
    }
    let (cells, band, cut, secs) = crate::cli::bench::time_recut(n, repeat.max(4))?;
    println!(
        "re-cut after a surface move: {cells} host cells, band of {band} cells, {cut} cut cells: {:.1} ms per move \
         (embed + cut + refit + ghost penalty + DOF map)",
        1e3 * secs
    );
    Ok(())
}
