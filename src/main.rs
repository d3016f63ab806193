//! `mortex` command line: run, check and bench.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use mortex::case;
use mortex::io::ResultWriter;
use std::path::PathBuf;
use std::process::ExitCode;

/// The binary's own modules: the timings of `mortex bench`, the studies of `mortex study`.
mod cli {
    pub mod bench;
    pub mod convergence;
    pub mod pareto;
    pub mod relocation;
    pub mod stability;
    pub mod study;
}

#[derive(Parser)]
#[command(name = "mortex", version, about = "MorteX wear simulation engine (2D FE, mortar, X-FEM surfaces)")]
struct Cli {
    /// More log output (-v info, -vv debug); RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case and write <output>.h5 + .xdmf.
    Run {
        case: PathBuf,
        /// Output file (default: the case's [output] file, else results/<case>.h5).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Resume from a checkpoint in this result file (a finished `.h5`, or the `.h5.partial`
        /// of a run that stopped); the continuation goes to a new file (default
        /// `<file>_from<step>.h5`) holding the steps after the checkpoint.
        #[arg(long)]
        restart: Option<PathBuf>,
        /// Output step of the checkpoint to resume from (default: the last one in the file).
        #[arg(long, requires = "restart")]
        from_step: Option<usize>,
    },
    /// Draw a contact profile (pressure, shear, mu p, stick/slip, slips) of one output step of a
    /// result file as a PNG.
    Plot {
        result: PathBuf,
        /// Output step (default: the last).
        #[arg(long)]
        step: Option<usize>,
        /// Contact pair (default: the only one).
        #[arg(long)]
        pair: Option<String>,
        /// PNG file (default: <result>_<pair>_step<k>.png beside the result).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// x range to draw (default: the contact zone widened by half its width each side).
        #[arg(long, num_args = 2, value_names = ["X_MIN", "X_MAX"], allow_negative_numbers = true)]
        xlim: Option<Vec<f64>>,
        /// Instead: the wear history of a wear run (scar profiles at six cycles, largest depth
        /// and worn area against cycles); PNG default <result>_wear.png.
        #[arg(long, conflicts_with_all = ["step", "pair", "xlim"])]
        wear: bool,
        /// Instead: the pressure at every increment (stroke position) of the recorded cycle
        /// nearest to this one, a panel each; PNG default <result>_cycle<N>.png.
        #[arg(long, conflicts_with_all = ["step", "xlim", "wear"])]
        cycle: Option<u64>,
        /// With --cycle: a reference run (e.g. without cycle jumps) drawn in each panel.
        #[arg(long, requires = "cycle")]
        reference: Option<PathBuf>,
        /// Instead: the equivalent plastic strain of a body (cell averages around the plastic
        /// zone, the worn surface on top) at a full-field step (--step, default the last); PNG
        /// default <result>_eqps.png.
        #[arg(long, conflicts_with_all = ["pair", "xlim", "wear", "cycle"])]
        plastic: bool,
        /// With --plastic: the body (default: the one with the largest plastic strain).
        #[arg(long, requires = "plastic")]
        body: Option<String>,
    },
    /// Validate a case without running it and summarise what it defines.
    Check { case: PathBuf },
    /// Run a study: many runs of one case, gathered into one table.
    Study {
        #[command(subcommand)]
        study: StudyCommand,
    },
    /// Time assembly, factorisation and solve of an n x n Quad4 plane-strain block.
    #[command(group(clap::ArgGroup::new("mode").args(["embed", "hertz", "output", "recut", "wear"]).multiple(false)))]
    Bench {
        /// Cells per side (300 gives about 181k DOFs).
        #[arg(short, long, default_value_t = 300)]
        n: usize,
        /// Repetitions (the best time of each phase is reported).
        #[arg(short, long, default_value_t = 3)]
        repeat: usize,
        /// Serial element loop.
        #[arg(long)]
        serial: bool,
        /// Instead: time embedding and cutting a closed surface of this many segments in an
        /// n x n host (e.g. `--embed 10000 -n 450`: 10k segments, 202,500 cells).
        #[arg(long)]
        embed: Option<usize>,
        /// Instead: the Hertz contact benchmark (block core elements 0.02, 0.01,
        /// 0.005 mm), real and virtual block surface.
        #[arg(long)]
        hertz: bool,
        /// Instead: output cost of a many-step run (this many steps of a 19k-DOF fretting
        /// scene; full fields every 100 steps, without and with a checkpoint every 100).
        #[arg(long)]
        output: Option<usize>,
        /// Instead: re-cut + refit after a surface move in an n x n host (e.g. `--recut -n 450`).
        #[arg(long)]
        recut: bool,
        /// Instead: a wear case run to its end (default wear_cases/mccoll_fretting.toml), with
        /// its scar at chosen cycles and where the time went.
        #[arg(long)]
        wear: bool,
        /// Wear case for `--wear`.
        #[arg(long, requires = "wear")]
        case: Option<PathBuf>,
        /// Cycles at which `--wear` reports the scar.
        #[arg(long, requires = "wear", value_delimiter = ',', default_value = "1000,5000,10000,18000")]
        at: Vec<u64>,
    },
}

#[derive(Subcommand)]
enum StudyCommand {
    /// Run a case over a grid of its inputs (a sweep file: `case`, `output`, `[[vary]]` with
    /// `key` and `values`), each run a process of its own; finished runs are skipped when the
    /// sweep is started again; the table goes to `<output>/sweep.csv` and `sweep.md`.
    Sweep {
        file: PathBuf,
        #[command(flatten)]
        runs: StudyRuns,
    },
    /// Refine a case one knob at a time (a file: `case`, `output`, `[[knob]]` with `key`,
    /// `values` coarse to fine and `size`): errors against each knob's finest run, observed
    /// orders, table `<output>/convergence.csv` and `.md`, chart `convergence.png`.
    Convergence {
        file: PathBuf,
        #[command(flatten)]
        runs: StudyRuns,
    },
    /// Error against wall time over a grid of discretisations (a sweep file with
    /// `reference = [{ key, value }]`, the converged setting), with the Pareto front:
    /// `<output>/pareto.csv`, `.md` and `pareto.png`.
    Pareto {
        file: PathBuf,
        #[command(flatten)]
        runs: StudyRuns,
    },
    /// Node relocation (the ALE practice of commercial wear codes) against the virtual surface on
    /// a case wearing a real boundary (a file: `case`, `output`, `cycles_per_update`, `layers`):
    /// `<output>/relocation.csv`, `.md` and `relocation.png`.
    Relocation { file: PathBuf },
    /// Classical against coarse-grained multipliers at growing mesh-density contrast (a tied
    /// inclusion, Hertz contact with a finer cylinder): `<output>/stability.csv`, `.md`,
    /// `tying.png` and `curved_contact.png`.
    Stability {
        #[arg(short, long, default_value = "results/stability")]
        output: PathBuf,
    },
    /// Gather a study whose runs ran elsewhere (a Slurm job array written by `--slurm`): its
    /// table and chart, as the local study writes them; runs not done yet are an error.
    Gather { file: PathBuf },
    /// One task of a study's Slurm job array: run `index` of a `runs.txt` list.
    #[command(hide = true)]
    Task { runs: PathBuf, index: usize },
}

/// Where a study's runs go: local processes, or a Slurm job array.
#[derive(clap::Args)]
struct StudyRuns {
    /// Runs at once on this machine (default: the cores; 1 gives wall times free of each
    /// other's load).
    #[arg(long, conflicts_with = "slurm")]
    parallel: Option<usize>,
    /// Instead: write one Slurm job array (a task per run not done yet) to
    /// `<output>/slurm/array.sbatch` and submit it with `sbatch`; gather the results with
    /// `mortex study gather <file>` when the tasks ended.
    #[arg(long)]
    slurm: bool,
    /// With --slurm: write the job script without submitting it.
    #[arg(long, requires = "slurm")]
    no_submit: bool,
    /// With --slurm: an extra `#SBATCH` option for the job script (repeatable), e.g.
    /// `--sbatch=--partition=short --sbatch=--time=01:00:00`.
    #[arg(long, requires = "slurm", allow_hyphen_values = true)]
    sbatch: Vec<String>,
}

// mimalloc keeps freed pages for reuse: the large short-lived buffers of set-up (Delassus
// columns, factor workspaces) no longer fault in fresh pages from the system each time (the
// Hertz benchmark at 174k DOFs: 568k page faults and 2.8 s of system time with the system
// allocator; whole process 25% faster).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// mimalloc's `mi_option_purge_delay` (`mimalloc.h`, v2 and v3).
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

fn main() -> ExitCode {
    // mimalloc returns freed pages to the system 10 ms after they were freed; a wear run frees
    // and takes again its per-step buffers far more often, and every purge came back as page
    // faults (1-3 s of system time in a 12 s McColl run). Kept a second, they are reused; the
    // peak memory stays as it was. `MIMALLOC_PURGE_DELAY` still decides where it is set.
    if std::env::var_os("MIMALLOC_PURGE_DELAY").is_none() {
        // SAFETY: sets one of mimalloc's integer options; no memory is touched.
        unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, 1000) };
    }
    let cli = Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    // Colour only on a terminal: a redirected log keeps no escape codes.
    use std::io::IsTerminal;
    let ansi = std::io::stderr().is_terminal();
    tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_ansi(ansi).init();
    // The work runs on a worker of the pool, not beside it: on a machine with as many cores as
    // workers, the idle workers' spinning would otherwise compete with the serial parts.
    let dispatch = move || match cli.command {
        Command::Run { case, output, quiet, restart, from_step } => run(case, output, quiet, restart, from_step),
        Command::Check { case } => check(case),
        Command::Study { study: StudyCommand::Sweep { file, runs } } => study_sweep(&file, study_execution(runs)),
        Command::Study { study: StudyCommand::Convergence { file, runs } } => {
            study_convergence(&file, study_execution(runs))
        }
        Command::Study { study: StudyCommand::Pareto { file, runs } } => study_pareto(&file, study_execution(runs)),
        Command::Study { study: StudyCommand::Gather { file } } => study_gather(&file),
        Command::Study { study: StudyCommand::Stability { output } } => cli::stability::stability(&output)
            .map(|md| println!("stability: table {}", md.display()))
            .map_err(|e| e.to_string()),
        Command::Study { study: StudyCommand::Relocation { file } } => cli::relocation::relocation(&file)
            .map(|md| println!("{}: table {}", file.display(), md.display()))
            .map_err(|e| e.to_string()),
        Command::Study { study: StudyCommand::Task { runs, index } } => study_task(&runs, index),
        Command::Plot { result, wear: true, output, .. } => {
            let out = output.unwrap_or_else(|| {
                let stem = result.file_stem().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
                result.with_file_name(format!("{stem}_wear.png"))
            });
            mortex::io::plot::write_wear_png(&result, &out)
                .map(|n| println!("{} worn surface(s) -> {}", n, out.display()))
                .map_err(|e| e.to_string())
        }
        Command::Plot { result, plastic: true, body, step, output, .. } => {
            let out = output.unwrap_or_else(|| {
                let stem = result.file_stem().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
                result.with_file_name(format!("{stem}_eqps.png"))
            });
            mortex::io::plot_field::write_plastic_png(&result, body.as_deref(), step, &out)
                .map(|(step, top)| println!("step {step}: largest cell plastic strain {top:.3e} -> {}", out.display()))
                .map_err(|e| e.to_string())
        }
        Command::Plot { result, cycle: Some(cycle), reference, pair, output, .. } => {
            let out = output.unwrap_or_else(|| {
                let stem = result.file_stem().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
                result.with_file_name(format!("{stem}_cycle{cycle}.png"))
            });
            mortex::io::plot::write_cycle_png(&result, cycle, reference.as_deref(), pair.as_deref(), &out)
                .map(|(found, n)| println!("cycle {found}: {n} increments -> {}", out.display()))
                .map_err(|e| e.to_string())
        }
        Command::Plot { result, step, pair, output, xlim, .. } => plot(result, step, pair, output, xlim),
        Command::Bench { wear: true, case, at, .. } => {
            bench_wear(case.unwrap_or_else(|| PathBuf::from("wear_cases/mccoll_fretting.toml")), &at)
        }
        Command::Bench { hertz: true, repeat, .. } => bench_hertz(repeat),
        Command::Bench { output: Some(steps), .. } => bench_output(steps),
        Command::Bench { recut: true, n, repeat, .. } => bench_recut(n, repeat),
        Command::Bench { n, repeat, serial, embed, .. } => match embed {
            Some(segments) => bench_embed(n, segments, repeat),
            None => bench(n, repeat, serial),
        },
    };
    // The main thread's stack size (8 MiB) for the worker that runs the command.
    let result = match rayon::ThreadPoolBuilder::new().stack_size(8 << 20).build() {
        Ok(pool) => pool.install(dispatch),
        Err(_) => dispatch(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}

/// `bench --wear`: the case run to its end with its output (fields, checkpoints as the case
/// says), then per chosen cycle the scar of every wearing surface and the wear balance, and
/// the time split.
fn bench_wear(path: PathBuf, at: &[u64]) -> Result<(), String> {
    let c = case::load(&path).map_err(|e| e.to_string())?;
    let model = &c.model;
    let out = std::env::temp_dir().join(format!("mortex-bench-wear-{}.h5", std::process::id()));
    let started = std::time::Instant::now();
    let mut writer = ResultWriter::create(&out, model, &c.name).map_err(|e| e.to_string())?;
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
            writer.write_step(m, d, r, s).map_err(|e| e.to_string())?;
            output += t0.elapsed().as_secs_f64();
            Ok(())
        },
    )
    .map_err(|e| e.to_string())?;
    let t0 = std::time::Instant::now();
    let file = writer.finish(true).map_err(|e| e.to_string())?;
    output += t0.elapsed().as_secs_f64();
    let wall = started.elapsed().as_secs_f64();
    let size = std::fs::metadata(&file).map(|m| m.len()).unwrap_or(0);
    let table = mortex::io::wear_table(&file, model, at).map_err(|e| e.to_string())?;
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

/// A material as a user writes it: `elastic, E = 200 GPa, nu = 0.3`.
fn describe_material(m: &mortex::fem::material::Material, units: case::Units) -> String {
    use mortex::fem::material::Material;
    let e = m.elastic();
    let elastic = format!("E = {}, nu = {}", units.stress(e.young), e.poisson);
    match m {
        Material::Elastic(_) => format!("elastic, {elastic}"),
        Material::J2Plastic(p) => format!(
            "J2 plastic, {elastic}, yield stress {}, isotropic hardening {}, kinematic hardening {}",
            units.stress(p.yield_stress),
            units.stress(p.isotropic_hardening),
            units.stress(p.kinematic_hardening)
        ),
    }
}

/// The output steps a run will compute: all of them, or with cycle jumps the range the jump
/// policy allows (the adaptive jump decides during the run).
fn computed_steps(m: &mortex::model::Model) -> String {
    use mortex::wear::JumpPolicy;
    let (Some(cy), false) = (m.cycle, m.wear.is_empty()) else {
        return format!("{} output steps", m.times.len());
    };
    let ramp = m.times.len().saturating_sub(cy.count * cy.increments);
    let steps = |cycles: usize| cycles * cy.increments + ramp;
    match m.wear.jump {
        JumpPolicy::Fixed(1) => format!("{} output steps", m.times.len()),
        JumpPolicy::Fixed(n) => {
            let cycles = cy.count.div_ceil(n as usize);
            format!("{} output steps ({cycles} computed cycles, jumps of {n})", steps(cycles))
        }
        JumpPolicy::Adaptive { max_jump, .. } => {
            let fewest = cy.count.div_ceil(max_jump.max(1) as usize);
            let range = if fewest > 1 { format!("between {} and", steps(fewest)) } else { "at most".into() };
            format!(
                "{range} {} output steps: the adaptive cycle jump computes a part of the {} cycles, decided during \
                 the run",
                m.times.len(),
                cy.count
            )
        }
    }
}

fn check(path: PathBuf) -> Result<(), String> {
    let c = case::load(&path).map_err(|e| e.to_string())?;
    let m = &c.model;
    println!("case '{}' ({}): valid", c.name, path.display());
    let hypothesis = match m.hypothesis {
        mortex::fem::material::PlaneHypothesis::PlaneStrain => "plane strain",
        mortex::fem::material::PlaneHypothesis::PlaneStress => "plane stress",
    };
    println!(
        "  hypothesis: {hypothesis}; numbers read as given, labelled in {} ([problem] units)",
        if c.units == case::Units::Metre { "m, N, Pa" } else { "mm, N, MPa" }
    );
    for free in m.free_mode_descriptions(false) {
        println!("  {free}: no boundary condition fixes it, only contact and friction hold it");
    }
    for (i, mat) in m.materials.iter().enumerate() {
        println!("  material '{}': {}", m.material_names[i], describe_material(mat, c.units));
    }
    for b in &m.bodies {
        let nq = b.mesh.cells.iter().filter(|c| c.kind == mortex::mesh::CellKind::Quad4).count();
        println!(
            "  body '{}': {} nodes, {} cells ({} Quad4, {} Tri3), {:?}, material '{}'",
            b.name,
            b.mesh.num_nodes(),
            b.mesh.num_cells(),
            nq,
            b.mesh.num_cells() - nq,
            b.formulation,
            m.material_names[b.material]
        );
        for (name, v) in &b.mesh.node_sets {
            println!("    node set '{name}': {}", plural(v.len(), "node"));
        }
        for (name, v) in &b.mesh.edge_sets {
            println!("    edge set '{name}': {}", plural(v.len(), "edge"));
        }
        for (name, v) in &b.mesh.cell_sets {
            println!("    cell set '{name}': {} cells", v.len());
        }
    }
    for t in &m.ties {
        println!(
            "  tie '{}': patch '{}' in host '{}', {:?} multipliers: {} nodes in {} chains",
            t.name,
            m.bodies[t.patch].name,
            m.bodies[t.host].name,
            t.space,
            t.multipliers.num_nodes,
            t.multipliers.chains.len()
        );
    }
    let disc = m.initial();
    for (b, cut) in disc.cuts.iter().enumerate() {
        if let Some(c) = cut {
            let n_cut = c.cells.iter().filter(|x| matches!(x, mortex::cut::CellCut::Cut { .. })).count();
            let n_void = c.cells.iter().filter(|x| matches!(x, mortex::cut::CellCut::Void)).count();
            println!(
                "  body '{}' is cut: {} cut cells, {} void cells, {} DOFs switched off{}",
                m.bodies[b].name,
                n_cut,
                n_void,
                disc.held[b].len(),
                match &m.bands[b] {
                    Some(band) =>
                        format!(", a band of {} cells with fixed points for its moving surface", band.cells.len()),
                    None => String::new(),
                }
            );
        }
    }
    println!("  DOFs: {} total, {} free, {} prescribed", m.num_dofs(), disc.dofs.num_free, m.prescribed.len());
    println!("  integration points: {} ({} with history)", m.elements.num_points(), m.elements.num_states());
    println!(
        "  steps: to t = {}, {}; {}",
        m.end_time(),
        if m.is_linear() { "linear (one factorisation)" } else { "nonlinear (Newton)" },
        computed_steps(m)
    );
    if let Some(cy) = &m.cycle {
        println!(
            "  cycles: {} x [{}, {}] with {} increments per cycle ({} before the first)",
            cy.count,
            cy.start,
            cy.start + cy.period,
            cy.increments,
            if cy.start > m.load_path.points[0].0 { cy.ramp_increments } else { 0 }
        );
    }
    for s in disc.surfaces.iter().filter(|s| s.motion.is_some()) {
        println!("  moving surface '{}' in body '{}': {:?}", s.name, m.bodies[s.body].name, s.motion);
    }
    for ci in &disc.contact.pairs {
        let source = if c.sliding_set.contains(&ci.name) {
            "set by the case's contacts.sliding"
        } else {
            "the default: finite for a wearing pair whose stroke exceeds half its element, small otherwise"
        };
        println!(
            "  contact '{}': mortar '{}', {:?} multipliers ({}), mu = {}, {:?} sliding ({source})",
            ci.name,
            m.bodies[ci.mortar].name,
            ci.space,
            plural(ci.multipliers.num_nodes, "node"),
            ci.mu,
            ci.sliding
        );
    }
    if c.fields_every > 1 {
        println!("  full fields every {} steps (contact and surface series every step)", c.fields_every);
    }
    let every = match c.checkpoint_every {
        0 => "no checkpoints".to_string(),
        1 => "a checkpoint every step".to_string(),
        n => format!("a checkpoint every {n} steps"),
    };
    println!("  output: {} ({every})", c.output.display());
    Ok(())
}

fn run(
    path: PathBuf,
    output: Option<PathBuf>,
    quiet: bool,
    restart: Option<PathBuf>,
    from_step: Option<usize>,
) -> Result<(), String> {
    let c = case::load(&path).map_err(|e| e.to_string())?;
    let model = &c.model;
    let (mut state, out) = starting_state(&c, output, restart.as_deref(), from_step)?;
    // Modes beyond the contact normal: held by friction, or by how the contact pressure is
    // spread (a roller turns freely, a pad may rock).
    for free in c.model.free_mode_descriptions(true) {
        tracing::warn!("{free}: no boundary condition fixes it, only contact and friction hold it");
    }
    let units = c.units;
    let wear_cycles = match (model.wear.is_empty(), model.cycle) {
        (false, Some(cy)) => Some(cy.count as u64),
        _ => None,
    };
    let done = match wear_cycles {
        Some(n) => state.wear.cycle >= n,
        None => state.step >= model.times.len(),
    };
    if done {
        return Err(format!("nothing to run: the checkpoint is at the case's last output step {}", state.step));
    }
    let mut writer = ResultWriter::create(&out, model, &c.name).map_err(|e| e.to_string())?;
    writer.set_checkpoint_every(c.checkpoint_every);
    writer.set_keep_checkpoints(c.keep_checkpoints);
    writer.set_fields_every(c.fields_every);
    if let Some(file) = &restart {
        writer.set_restart_origin(file, state.step).map_err(|e| e.to_string())?;
    }
    if let Some((pair, r)) = &c.reference {
        writer.write_reference(pair, r).map_err(|e| e.to_string())?;
    }
    let first_step = state.step;
    let bar = progress_bar(quiet, wear_cycles, model, &state);
    let started = std::time::Instant::now();
    let log_lines = !quiet && !std::io::IsTerminal::is_terminal(&std::io::stderr());
    let mut last_line = started;
    let mut tally = RunTally::default();
    let res = {
        let observer = |r: &mortex::solve::StepReport,
                        s: &mortex::state::SimState,
                        step_model: &mortex::model::Model,
                        disc: &mortex::model::Discretisation|
         -> Result<(), String> {
            tally.add(r);
            writer.write_step(step_model, disc, r, s).map_err(|e| e.to_string())?;
            let message = progress_message(r, s, step_model, wear_cycles.map(|n| (n, units)), &bar);
            // Off a terminal the bar draws nothing: a line every PROGRESS_LINE_SECONDS instead.
            if log_lines && last_line.elapsed().as_secs_f64() >= PROGRESS_LINE_SECONDS {
                eprintln!("{}: {message} ({:.0} s)", c.name, started.elapsed().as_secs_f64());
                last_line = std::time::Instant::now();
            }
            bar.set_message(message);
            Ok(())
        };
        mortex::driver::run(model, &mut state, mortex::driver::RunOptions { parallel: !c.serial }, observer)
    };
    bar.finish_and_clear();
    let completed = res.is_ok();
    let file = writer.finish(completed).map_err(|e| e.to_string())?;
    match res {
        Ok(()) => {
            let wall = started.elapsed().as_secs_f64();
            print_run_summary(&c, &state, &tally, state.step - first_step, wall, &file);
            Ok(())
        }
        Err(e) => Err(format!("{e} (converged steps up to {} kept in {})", state.step, file.display())),
    }
}

/// What a run's steps add up to, for its summary.
#[derive(Default)]
struct RunTally {
    /// Active-set (and Newton) iterations in all.
    iterations: usize,
    /// Finite-sliding wear increments solved in sub-steps, and the sub-steps in all.
    cut_increments: usize,
    sub_steps: usize,
    /// How many steps took each number of bulk Newton iterations.
    bulk_iterations: std::collections::BTreeMap<usize, usize>,
}

impl RunTally {
    fn add(&mut self, r: &mortex::solve::StepReport) {
        self.iterations += r.iterations;
        if r.sub_steps > 1 {
            self.cut_increments += 1;
            self.sub_steps += r.sub_steps;
        }
        *self.bulk_iterations.entry(r.newton_iterations).or_default() += 1;
    }
}

/// The progress line of step `r` (the bar's message): a wear run's cycle, jump and deepest
/// wear (`wear`: the run's cycles and the case's units), or a load step's time and residual;
/// moves the bar.
fn progress_message(
    r: &mortex::solve::StepReport,
    s: &mortex::state::SimState,
    model: &mortex::model::Model,
    wear: Option<(u64, case::Units)>,
    bar: &ProgressBar,
) -> String {
    if let Some((n, units)) = wear {
        let w = &s.wear;
        let deepest = w.depth.iter().flatten().fold(0.0_f64, |a, &b| a.max(b));
        bar.set_position(w.cycle);
        return format!(
            "cycle {}/{n}: computed {}, jump {}, inc {}, max wear depth {}, {} it",
            w.cycle,
            w.computed_cycles,
            w.jump,
            r.increment,
            units.length(deepest),
            r.iterations
        );
    }
    bar.inc(1);
    let cycle = if model.cycle.is_some() { format!("cycle {} inc {}, ", r.cycle, r.increment) } else { String::new() };
    format!(
        "step {}/{}: {cycle}t = {:.4}, lambda = {:.4}, {} it, res {:.1e}",
        r.step,
        model.times.len(),
        r.time,
        r.load_factor,
        r.iterations,
        r.residual
    )
}

/// The lines a finished run prints: scars, bulk Newton iterations of yielding bodies, steps,
/// solves and wall time (`steps` run in `wall` seconds), the result files, cut increments.
fn print_run_summary(
    c: &case::Case,
    state: &mortex::state::SimState,
    tally: &RunTally,
    steps: usize,
    wall: f64,
    file: &std::path::Path,
) {
    let model = &c.model;
    let wear_run = !model.wear.is_empty() && model.cycle.is_some();
    if wear_run {
        println!("{}: {}", c.name, scar_summary(model, state, c.units));
    }
    if model.has_plasticity() {
        let counts: Vec<String> = tally.bulk_iterations.iter().map(|(n, k)| format!("{n}: {k}")).collect();
        println!("{}: bulk Newton iterations per step (iterations: steps) {}", c.name, counts.join(", "));
        if wear_run {
            println!(
                "{}: last computed cycle: net plastic strain {:.3e} (ratcheting), accumulated {:.3e}",
                c.name, state.wear.cycle_ratcheting, state.wear.cycle_plastic_strain
            );
        }
    }
    // Condensed contact: one bulk solve per pass (per Newton iteration of yielding bodies),
    // several active-set iterations each; monolithic: Newton iterations.
    let bulk: usize = tally.bulk_iterations.iter().map(|(its, steps)| its * steps).sum();
    println!(
        "{}: {} steps, {} bulk solves, {} iterations (contact active set, Newton), {:.2} s -> {} (+ {})",
        c.name,
        steps,
        bulk,
        tally.iterations,
        wall,
        file.display(),
        file.with_extension("xdmf").display()
    );
    if tally.cut_increments > 0 {
        println!(
            "{}: {} increments solved in sub-steps ({} sub-steps in all; /series/sub_steps per step)",
            c.name, tally.cut_increments, tally.sub_steps
        );
    }
}

/// `n` things, in the singular for one (`1 node`, `3 nodes`).
fn plural(n: usize, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}

/// Seconds between progress lines of a run whose stderr is not a terminal (a log file).
const PROGRESS_LINE_SECONDS: f64 = 30.0;

/// The state a run starts from and its output file: the initial state, or a checkpoint of
/// `restart` (whose continuation never overwrites the file it resumes from).
fn starting_state(
    c: &case::Case,
    output: Option<PathBuf>,
    restart: Option<&std::path::Path>,
    from_step: Option<usize>,
) -> Result<(mortex::state::SimState, PathBuf), String> {
    let Some(file) = restart else {
        return Ok((
            mortex::solve::StaticAnalysis::initial_state_of(&c.model),
            output.unwrap_or_else(|| c.output.clone()),
        ));
    };
    let cp = mortex::io::checkpoint::read(file, from_step, &c.model).map_err(|e| e.to_string())?;
    let out = output.unwrap_or_else(|| {
        let name = file.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        let stem = name.trim_end_matches(".partial").trim_end_matches(".h5");
        // Never over an earlier continuation (finished or not) of the same file and step.
        let taken = |p: &PathBuf| p.exists() || PathBuf::from(format!("{}.partial", p.display())).exists();
        (1..)
            .map(|k| match k {
                1 => file.with_file_name(format!("{stem}_from{}.h5", cp.step)),
                _ => file.with_file_name(format!("{stem}_from{}_{k}.h5", cp.step)),
            })
            .find(|p| !taken(p))
            .unwrap_or_else(|| file.with_file_name(format!("{stem}_from{}.h5", cp.step)))
    });
    let same = |a: &std::path::Path, b: &std::path::Path| {
        a == b || matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
    };
    let partial_of_out = PathBuf::from(format!("{}.partial", out.display()));
    if same(&out, file) || same(&partial_of_out, file) {
        return Err(format!(
            "--restart {}: the continuation would overwrite the file it resumes from; choose another --output",
            file.display()
        ));
    }
    tracing::info!(file = %file.display(), step = cp.step, time = cp.time, "resuming from checkpoint");
    Ok((cp, out))
}

/// The run's progress bar: wear runs count cycles (jumps included), other runs output steps.
fn progress_bar(
    quiet: bool,
    wear_cycles: Option<u64>,
    model: &mortex::model::Model,
    state: &mortex::state::SimState,
) -> ProgressBar {
    let bar = match (quiet, wear_cycles) {
        (true, _) => ProgressBar::hidden(),
        (false, Some(n)) => ProgressBar::new(n),
        (false, None) => ProgressBar::new(model.times.len() as u64),
    };
    bar.set_position(if wear_cycles.is_some() { state.wear.cycle } else { state.step as u64 });
    let template = if wear_cycles.is_some() {
        "{spinner} [{elapsed_precise}] {bar:40} (eta {eta}) {msg}"
    } else {
        "{spinner} [{elapsed_precise}] {bar:40} {msg}"
    };
    bar.set_style(ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()));
    bar
}

/// The scars at the end of a wear run: cycles, and per wearing surface its deepest point and
/// worn area, in the case's units.
fn scar_summary(model: &mortex::model::Model, state: &mortex::state::SimState, units: case::Units) -> String {
    let w = &state.wear;
    let area_unit = if units == case::Units::Metre { "m²" } else { "mm²" };
    let scars: Vec<String> = model
        .wear
        .surfaces
        .iter()
        .zip(&w.depth)
        .zip(&w.worn_area)
        .map(|((s, d), area)| {
            let deepest = d.iter().fold(0.0_f64, |a, &b| a.max(b));
            format!("{}: max depth {}, worn area {area:.4e} {area_unit}", s.name, units.length(deepest))
        })
        .collect();
    let fatigue = fatigue_summary(model, state, units).map(|f| format!("; {f}")).unwrap_or_default();
    format!("{} cycles ({} computed); {}{fatigue}", w.cycle, w.computed_cycles, scars.join("; "))
}

/// The most damaged fatigue point at the end of a wear run (see [`mortex::fatigue`]).
fn fatigue_summary(
    model: &mortex::model::Model,
    state: &mortex::state::SimState,
    units: case::Units,
) -> Option<String> {
    let fm = model.fatigue.as_ref()?;
    let f = &state.fatigue;
    let alive = |p: &usize| !f.retired.get(*p).copied().unwrap_or(false);
    let (p, &d) = f.damage.iter().enumerate().filter(|(p, _)| alive(p)).max_by(|a, b| a.1.total_cmp(b.1))?;
    let cut: Vec<f64> = f.damage.iter().enumerate().filter(|(p, _)| !alive(p)).map(|(_, &d)| d).collect();
    let cut_away = match cut.iter().copied().reduce(f64::max) {
        Some(worst) => format!("; {} points cut away by wear (largest damage {worst:.4e})", cut.len()),
        None => String::new(),
    };
    let x = fm.points[p].position;
    let (angle, life) = (f.last.angle.get(p)?, f.last.life.get(p)?);
    let verdict = match f.initiation {
        Some(i) => {
            let x = fm.points[i.point].position;
            format!(
                " (crack initiation, D = 1, at cycle {:.0}: ({}, {}), {} below the worn surface, plane {:.1} deg)",
                i.cycle,
                units.length(x.x),
                units.length(x.y),
                units.length(i.depth),
                i.angle.to_degrees()
            )
        }
        None => String::new(),
    };
    // Planes are normals in [0, 180) degrees: one just below 180 is the one at 0.
    let degrees = angle.to_degrees();
    let degrees = if degrees >= 179.95 { degrees - 180.0 } else { degrees };
    Some(format!(
        "fatigue of '{}': largest Miner damage {d:.4e}{verdict} at ({}, {}), critical plane {:.1} deg, life {life:.4e} cycles at the last computed cycle{cut_away}",
        fm.body,
        units.length(x.x),
        units.length(x.y),
        degrees
    ))
}

fn plot(
    result: PathBuf,
    step: Option<usize>,
    pair: Option<String>,
    output: Option<PathBuf>,
    xlim: Option<Vec<f64>>,
) -> Result<(), String> {
    use mortex::io::plot;
    let profile = plot::read_profile(&result, step, pair.as_deref()).map_err(|e| e.to_string())?;
    let xlim = match xlim.as_deref() {
        Some(&[a, b]) if a.is_finite() && b.is_finite() && b > a => (a, b),
        Some(v) => return Err(format!("--xlim {v:?}: give two finite values, X_MIN < X_MAX")),
        None => plot::default_xlim(&profile),
    };
    let out = output.unwrap_or_else(|| {
        let name = result.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        let stem = name.trim_end_matches(".partial").trim_end_matches(".h5");
        result.with_file_name(format!("{stem}_{}_step{}.png", profile.pair, profile.step))
    });
    plot::write_png(&profile, xlim, &out).map_err(|e| e.to_string())?;
    println!("contact '{}', step {}: {}", profile.pair, profile.step, out.display());
    if let Some(r) = &profile.reference {
        let (p, q) = plot::reference_errors(&profile, r);
        let name = match (r.c, r.e) {
            (None, _) => "Hertz",
            (Some(_), e) if e == 0.0 => "Cattaneo-Mindlin",
            _ => "Cattaneo-Mindlin with Nowell-Hills' offset",
        };
        let centre = if r.centre_from_profile { "the computed contact's centre" } else { "the case's" };
        println!(
            "  against {name} (p0 = {:.4}, a = {:.5}{}{}, x0 = {:.5}, {centre}): pressure L2 over |x - x0| < a {:.2}%{}",
            r.p0,
            r.a,
            r.c.map_or(String::new(), |c| format!(", c = {c:.5}")),
            if r.e != 0.0 { format!(", e = {:.5}", r.e) } else { String::new() },
            r.x0,
            100.0 * p,
            q.map_or(String::new(), |q| format!(", shear L2 {:.2}%", 100.0 * q))
        );
    }
    Ok(())
}

fn bench(n: usize, repeat: usize, serial: bool) -> Result<(), String> {
    if n == 0 || repeat == 0 {
        return Err("bench: n and repeat must be at least 1".into());
    }
    let mut best: Option<cli::bench::LinearSolveTimes> = None;
    for _ in 0..repeat {
        let t = cli::bench::time_linear_solve(n, !serial).map_err(|e| e.to_string())?;
        best = Some(match best {
            None => t,
            Some(b) => cli::bench::LinearSolveTimes {
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
        return Err("no repetition ran".into());
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

fn bench_embed(n: usize, segments: usize, repeat: usize) -> Result<(), String> {
    if n == 0 || repeat == 0 || segments < 3 {
        return Err("bench --embed: n and repeat must be at least 1, segments at least 3".into());
    }
    let mut best: Option<cli::bench::EmbedTimes> = None;
    for _ in 0..repeat {
        let t = cli::bench::time_embedding(n, segments).map_err(|e| e.to_string())?;
        best = Some(match best {
            None => t,
            Some(b) => cli::bench::EmbedTimes {
                index: b.index.min(t.index),
                embed: b.embed.min(t.embed),
                cut: b.cut.min(t.cut),
                fit_per_cell: b.fit_per_cell.min(t.fit_per_cell),
                subtri_per_cell: b.subtri_per_cell.min(t.subtri_per_cell),
                ..t
            },
        });
    }
    let Some(t) = best else { return Err("no repetition ran".into()) };
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

fn bench_hertz(repeat: usize) -> Result<(), String> {
    if repeat == 0 {
        return Err("bench --hertz: repeat must be at least 1".into());
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
            let Some(r) = best else { return Err("no repetition ran".into()) };
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

/// The `mortex` binary each study run starts.
fn study_exe() -> Result<PathBuf, String> {
    std::env::current_exe().map_err(|e| format!("the mortex binary: {e}"))
}

/// Where a study's runs go, from its command-line options (local: as many at once as cores).
fn study_execution(runs: StudyRuns) -> cli::study::Execution {
    if runs.slurm {
        return cli::study::Execution::Slurm { submit: !runs.no_submit, sbatch: runs.sbatch };
    }
    let parallel = runs.parallel.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    cli::study::Execution::Local { parallel }
}

/// The study's runs handed to Slurm: what was written and submitted, and how to gather.
fn report_submitted(file: &std::path::Path, job: &cli::study::SlurmJob) {
    match (&job.job_id, job.tasks) {
        (_, 0) => {
            println!("{}: every run is done: gather with `mortex study gather {}`", file.display(), file.display())
        }
        (Some(id), n) => println!(
            "{}: job array {id} submitted, {n} tasks ({}); when they ended: mortex study gather {}",
            file.display(),
            job.script.display(),
            file.display()
        ),
        (None, n) => println!(
            "{}: {n} tasks written to {} (not submitted: sbatch it); when they ended: mortex study gather {}",
            file.display(),
            job.script.display(),
            file.display()
        ),
    }
}

/// `mortex study gather`: the study kind from its file (`[[knob]]`: convergence; `reference`:
/// Pareto; else a sweep), gathered without running anything.
fn study_gather(file: &std::path::Path) -> Result<(), String> {
    let text = std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| format!("{}: {}", file.display(), e.message()))?;
    let exec = cli::study::Execution::Gather;
    if table.contains_key("knob") {
        study_convergence(file, exec)
    } else if table.contains_key("reference") {
        study_pareto(file, exec)
    } else {
        study_sweep(file, exec)
    }
}

fn study_task(runs: &std::path::Path, index: usize) -> Result<(), String> {
    cli::study::task(runs, index, &study_exe()?).map_err(|e| e.to_string())
}

fn study_sweep(file: &std::path::Path, exec: cli::study::Execution) -> Result<(), String> {
    let s = match cli::study::sweep(file, &exec, &study_exe()?).map_err(|e| e.to_string())? {
        cli::study::Outcome::Gathered(s) => s,
        cli::study::Outcome::Submitted(job) => {
            report_submitted(file, &job);
            return Ok(());
        }
    };
    println!(
        "{}: {} runs: {} run now, {} done before, {} failed -> {} (+ sweep.md)",
        file.display(),
        s.runs,
        s.ran,
        s.skipped,
        s.failed,
        s.table.display()
    );
    if s.failed > 0 {
        return Err(format!("{} of {} runs failed: see their run.log and the status column", s.failed, s.runs));
    }
    Ok(())
}

fn study_convergence(file: &std::path::Path, exec: cli::study::Execution) -> Result<(), String> {
    let s = match cli::convergence::convergence(file, &exec, &study_exe()?).map_err(|e| e.to_string())? {
        cli::study::Outcome::Gathered(s) => s,
        cli::study::Outcome::Submitted(job) => {
            report_submitted(file, &job);
            return Ok(());
        }
    };
    println!("{}: {} runs: {} run now, {} done before", file.display(), s.runs, s.ran, s.skipped);
    // The finest observed order of each knob and figure.
    let mut last: Vec<(&str, &str, f64)> = Vec::new();
    for r in &s.rows {
        if let Some(o) = r.order {
            match last.iter_mut().find(|(k, f, _)| *k == r.knob && *f == r.figure) {
                Some(entry) => entry.2 = o,
                None => last.push((&r.knob, &r.figure, o)),
            }
        }
    }
    for (knob, figure, order) in last {
        println!("  {knob}: {figure}: observed order {order:.2}");
    }
    println!("-> {} (+ convergence.md, convergence.png)", s.table.display());
    let missing = s.rows.iter().filter(|r| r.result.is_none()).count();
    if missing > 0 {
        return Err(format!("{missing} figures missing: a run failed (see its run.log)"));
    }
    Ok(())
}

fn study_pareto(file: &std::path::Path, exec: cli::study::Execution) -> Result<(), String> {
    let s = match cli::pareto::pareto(file, &exec, &study_exe()?).map_err(|e| e.to_string())? {
        cli::study::Outcome::Gathered(s) => s,
        cli::study::Outcome::Submitted(job) => {
            report_submitted(file, &job);
            return Ok(());
        }
    };
    println!("{}: {} runs: {} run now, {} done before", file.display(), s.runs, s.ran, s.skipped);
    if let Some(w) = s.reference_wall_s {
        println!("  reference: {w:.2} s");
    }
    let mut front: Vec<&cli::pareto::Point> = s.points.iter().filter(|p| p.front).collect();
    front.sort_by(|a, b| a.wall_s.unwrap_or(f64::INFINITY).total_cmp(&b.wall_s.unwrap_or(f64::INFINITY)));
    for p in front {
        println!(
            "  front: {} s, error {}: {}",
            p.wall_s.map_or("-".into(), |w| format!("{w:.2}")),
            p.error.map_or("-".into(), |e| format!("{e:.2e}")),
            p.settings
        );
    }
    for tol in [0.01, 0.05] {
        let cheapest = s
            .points
            .iter()
            .filter(|p| p.error.is_some_and(|e| e <= tol))
            .min_by(|a, b| a.wall_s.unwrap_or(f64::INFINITY).total_cmp(&b.wall_s.unwrap_or(f64::INFINITY)));
        match cheapest {
            Some(p) => {
                println!("  cheapest within {}%: {} ({:.2} s)", tol * 100.0, p.settings, p.wall_s.unwrap_or(f64::NAN))
            }
            None => println!("  none within {}%", tol * 100.0),
        }
    }
    println!("-> {} (+ pareto.md, pareto.png)", s.table.display());
    let missing = s.points.iter().filter(|p| p.error.is_none()).count();
    if missing > 0 {
        return Err(format!("{missing} runs without an error: a run failed (see its run.log)"));
    }
    Ok(())
}

fn bench_output(steps: usize) -> Result<(), String> {
    if steps == 0 {
        return Err("bench --output: give at least 1 step".into());
    }
    let dir = std::env::temp_dir().join(format!("mortex-bench-output-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    println!("output benchmark: {steps} steps of a fretting scene (contact series every step)");
    println!("  fields  checkpoints  DOFs     solve s   output s  output share  h5 MB    csv MB");
    for (fields, checkpoints) in [(100, 0), (100, 100), (1, 1)] {
        if fields == 1 && steps > 2000 {
            continue;
        }
        let out = dir.join(format!("bench_{fields}_{checkpoints}.h5"));
        let r = cli::bench::run_output_bench(steps, fields, checkpoints, &out)?;
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

fn bench_recut(n: usize, repeat: usize) -> Result<(), String> {
    if n < 2 || repeat == 0 {
        return Err("bench --recut: n >= 2 and repeat >= 1".into());
    }
    let (cells, band, cut, secs) = cli::bench::time_recut(n, repeat.max(4))?;
    println!(
        "re-cut after a surface move: {cells} host cells, band of {band} cells, {cut} cut cells: {:.1} ms per move \
         (embed + cut + refit + ghost penalty + DOF map)",
        1e3 * secs
    );
    Ok(())
}
