//! `mortex run`: a case run (or resumed from a checkpoint) with its result file, progress bar
//! or periodic progress lines, and the summary of what it computed.

use indicatif::{ProgressBar, ProgressStyle};
use mortex::case;
use mortex::io::ResultWriter;
use std::path::PathBuf;

pub(crate) fn run(
    path: PathBuf,
    output: Option<PathBuf>,
    quiet: bool,
    restart: Option<PathBuf>,
    from_step: Option<usize>,
) -> anyhow::Result<()> {
    let c = case::load(&path)?;
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
        return Err(anyhow::anyhow!("nothing to run: the checkpoint is at the case's last output step {}", state.step));
    }
    let mut writer = ResultWriter::create(&out, model, &c.name)?;
    writer.set_checkpoint_every(c.checkpoint_every);
    writer.set_keep_checkpoints(c.keep_checkpoints);
    writer.set_fields_every(c.fields_every);
    if let Some(file) = &restart {
        writer.set_restart_origin(file, state.step)?;
    }
    if let Some((pair, r)) = &c.reference {
        writer.write_reference(pair, r)?;
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
         -> Result<(), mortex::driver::ObserverError> {
            tally.add(r);
            writer.write_step(step_model, disc, r, s)?;
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
    let file = writer.finish(completed)?;
    match res {
        Ok(()) => {
            let wall = started.elapsed().as_secs_f64();
            print_run_summary(&c, &state, &tally, state.step - first_step, wall, &file);
            Ok(())
        }
        Err(e) => Err(anyhow::anyhow!("{e} (converged steps up to {} kept in {})", state.step, file.display())),
    }
}

/// What a run's steps add up to, for its summary.
#[derive(Default)]
pub(crate) struct RunTally {
    /// Active-set (and Newton) iterations in all.
    iterations: usize,
    /// Finite-sliding wear increments solved in sub-steps, and the sub-steps in all.
    cut_increments: usize,
    sub_steps: usize,
    /// Steps whose Newton had to cut back, and the halvings in all.
    cut_back_steps: usize,
    cutbacks: usize,
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
        if r.cutbacks > 0 {
            self.cut_back_steps += 1;
            self.cutbacks += r.cutbacks;
        }
        *self.bulk_iterations.entry(r.newton_iterations).or_default() += 1;
    }
}

/// The progress line of step `r` (the bar's message): a wear run's cycle, jump and deepest
/// wear (`wear`: the run's cycles and the case's units), or a load step's time and residual;
/// moves the bar.
pub(crate) fn progress_message(
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
pub(crate) fn print_run_summary(
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
    if tally.cut_back_steps > 0 {
        println!(
            "{}: {} cut back ({} in all; `-v` logs each step's count)",
            c.name,
            plural(tally.cut_back_steps, "step"),
            plural(tally.cutbacks, "halving")
        );
    }
}

/// `n` things, in the singular for one (`1 node`, `3 nodes`).
pub(crate) fn plural(n: usize, thing: &str) -> String {
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
pub(crate) fn starting_state(
    c: &case::Case,
    output: Option<PathBuf>,
    restart: Option<&std::path::Path>,
    from_step: Option<usize>,
) -> anyhow::Result<(mortex::state::SimState, PathBuf)> {
    let Some(file) = restart else {
        return Ok((
            mortex::solve::StaticAnalysis::initial_state_of(&c.model),
            output.unwrap_or_else(|| c.output.clone()),
        ));
    };
    let cp = mortex::io::checkpoint::read(file, from_step, &c.model)?;
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
        return Err(anyhow::anyhow!(
            "--restart {}: the continuation would overwrite the file it resumes from; choose another --output",
            file.display()
        ));
    }
    tracing::info!(file = %file.display(), step = cp.step, time = cp.time, "resuming from checkpoint");
    Ok((cp, out))
}

/// The run's progress bar: wear runs count cycles (jumps included), other runs output steps.
pub(crate) fn progress_bar(
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
pub(crate) fn scar_summary(
    model: &mortex::model::Model,
    state: &mortex::state::SimState,
    units: case::Units,
) -> String {
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
pub(crate) fn fatigue_summary(
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
