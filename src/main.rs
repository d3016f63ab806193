//! `mortex` command line: run, check, plot, bench and study (each a module of `cli/`).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// The binary's commands: `run`, `check`, `plot`, `bench` (timings) and `study` (sweeps and
/// the studies of convergence, speed against accuracy, stability and relocation).
mod cli {
    pub mod bench;
    pub mod check;
    pub mod convergence;
    pub mod life;
    pub mod pareto;
    pub mod plot;
    pub mod relocation;
    pub mod run;
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
    /// Fretting-fatigue life against stroke amplitude, with wear and without (a file: `case`
    /// with `[fatigue]`, `stroke = { key, values }`, `without_wear = [{ key, value }]`): the
    /// engine's partial-to-gross-slip transition beside the lives, `<output>/life.csv`, `.md`
    /// and `life.png`.
    Life {
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
// columns, factor workspaces) no longer fault in fresh pages from the system each time
// (measured in docs/performance.md, "Threads and memory of the process").
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// mimalloc's `mi_option_purge_delay` (`mimalloc.h`, v2 and v3).
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

fn main() -> ExitCode {
    // mimalloc returns freed pages to the system 10 ms after they were freed; a wear run frees
    // and takes again its per-step buffers far more often, and every purge came back as page
    // faults (see docs/performance.md). Kept a second, they are reused; the
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
        Command::Run { case, output, quiet, restart, from_step } => {
            cli::run::run(case, output, quiet, restart, from_step)
        }
        Command::Check { case } => cli::check::check(case),
        Command::Study { study: StudyCommand::Sweep { file, runs } } => {
            cli::study::study_sweep(&file, study_execution(runs))
        }
        Command::Study { study: StudyCommand::Convergence { file, runs } } => {
            cli::convergence::study_convergence(&file, study_execution(runs))
        }
        Command::Study { study: StudyCommand::Pareto { file, runs } } => {
            cli::pareto::study_pareto(&file, study_execution(runs))
        }
        Command::Study { study: StudyCommand::Life { file, runs } } => {
            cli::life::study_life(&file, study_execution(runs))
        }
        Command::Study { study: StudyCommand::Gather { file } } => study_gather(&file),
        Command::Study { study: StudyCommand::Stability { output } } => cli::stability::stability(&output)
            .map(|md| println!("stability: table {}", md.display()))
            .map_err(anyhow::Error::from),
        Command::Study { study: StudyCommand::Relocation { file } } => cli::relocation::relocation(&file)
            .map(|md| println!("{}: table {}", file.display(), md.display()))
            .map_err(anyhow::Error::from),
        Command::Study { study: StudyCommand::Task { runs, index } } => cli::study::study_task(&runs, index),
        Command::Plot { result, wear: true, output, .. } => {
            let out = output.unwrap_or_else(|| {
                let stem = result.file_stem().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
                result.with_file_name(format!("{stem}_wear.png"))
            });
            mortex::io::plot::write_wear_png(&result, &out)
                .map(|n| println!("{} worn surface(s) -> {}", n, out.display()))
                .map_err(anyhow::Error::from)
        }
        Command::Plot { result, plastic: true, body, step, output, .. } => {
            let out = output.unwrap_or_else(|| {
                let stem = result.file_stem().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
                result.with_file_name(format!("{stem}_eqps.png"))
            });
            mortex::io::plot_field::write_plastic_png(&result, body.as_deref(), step, &out)
                .map(|(step, top)| println!("step {step}: largest cell plastic strain {top:.3e} -> {}", out.display()))
                .map_err(anyhow::Error::from)
        }
        Command::Plot { result, cycle: Some(cycle), reference, pair, output, .. } => {
            let out = output.unwrap_or_else(|| {
                let stem = result.file_stem().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
                result.with_file_name(format!("{stem}_cycle{cycle}.png"))
            });
            mortex::io::plot::write_cycle_png(&result, cycle, reference.as_deref(), pair.as_deref(), &out)
                .map(|(found, n)| println!("cycle {found}: {n} increments -> {}", out.display()))
                .map_err(anyhow::Error::from)
        }
        Command::Plot { result, step, pair, output, xlim, .. } => cli::plot::plot(result, step, pair, output, xlim),
        Command::Bench { wear: true, case, at, .. } => {
            cli::bench::bench_wear(case.unwrap_or_else(|| PathBuf::from("wear_cases/mccoll_fretting.toml")), &at)
        }
        Command::Bench { hertz: true, repeat, .. } => cli::bench::bench_hertz(repeat),
        Command::Bench { output: Some(steps), .. } => cli::bench::bench_output(steps),
        Command::Bench { recut: true, n, repeat, .. } => cli::bench::bench_recut(n, repeat),
        Command::Bench { n, repeat, serial, embed, .. } => match embed {
            Some(segments) => cli::bench::bench_embed(n, segments, repeat),
            None => cli::bench::bench(n, repeat, serial),
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

/// Where a study's runs go, from its command-line options (local: as many at once as cores).
fn study_execution(runs: StudyRuns) -> cli::study::Execution {
    if runs.slurm {
        return cli::study::Execution::Slurm { submit: !runs.no_submit, sbatch: runs.sbatch };
    }
    let parallel = runs.parallel.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    cli::study::Execution::Local { parallel }
}

/// `mortex study gather`: the study kind from its file (`[[knob]]`: convergence; `stroke`:
/// life; `reference`: Pareto; else a sweep), gathered without running anything.
fn study_gather(file: &std::path::Path) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(file).map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    let table: toml::Table =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {}", file.display(), e.message()))?;
    let exec = cli::study::Execution::Gather;
    if table.contains_key("knob") {
        cli::convergence::study_convergence(file, exec)
    } else if table.contains_key("stroke") {
        cli::life::study_life(file, exec)
    } else if table.contains_key("reference") {
        cli::pareto::study_pareto(file, exec)
    } else {
        cli::study::study_sweep(file, exec)
    }
}
