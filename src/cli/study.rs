//! `mortex study sweep`: one case run over a grid of its inputs, each run a `mortex run`
//! process of its own, as many at once as asked (default: the cores), resumable, and gathered
//! into one table.
//!
//! A sweep file names the case and the inputs to vary, each by its key path in the case:
//!
//! ```toml
//! case = "wear_cases/uniform_wear.toml"   # relative to the sweep file
//! output = "results/uniform_sweep"        # default: results/<sweep file stem>
//! [[vary]]
//! key = "wear[0].coefficient"            # `section.key`, `array[index].key`
//! values = [1e-3, 2e-3, 4e-3]
//! [[vary]]
//! key = "steps.cycles"
//! values = [5, 10]
//! ```
//!
//! Every run's case is written and validated before the first run starts (a bad value is an
//! error naming the run and the key, and nothing is run). Run `i` lives in
//! `<output>/run_<i>/`: `case.toml`, `result.h5`, `run.log`, and `figures.csv` once it ended
//! (its status, wall time and, per wearing surface, the largest depth and the worn area at the
//! end). A sweep started again skips the runs that have `figures.csv`: a killed sweep resumes.
//! The table of all runs is `<output>/sweep.csv` and `sweep.md`.
//!
//! Every study runs locally (a process per run, as many at once as asked) or on a Slurm
//! cluster ([`Execution::Slurm`]): one job array, a task per run not done yet, each task
//! `mortex study task <output>/slurm/runs.txt <index>`, which runs the case exactly as the local
//! runner does and writes its `figures.csv`; `mortex study gather <study file>` then builds the
//! table and chart once the tasks ended. Scaling past one machine is the scheduler's job.

use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Most runs a sweep may ask for.
pub const MAX_RUNS: usize = 10_000;

/// A sweep that cannot start or finish: the file, the key and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("{file}: {key}: {msg}")]
    Input { file: String, key: String, msg: String },
    #[error("{path}: {msg}")]
    Io { path: String, msg: String },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SweepFile {
    pub(super) case: PathBuf,
    pub(super) output: Option<PathBuf>,
    /// Keys set in every run (`"steps.cycles" = 1000`): the study's base case.
    pub(super) set: Option<toml::Table>,
    /// `"grid"` (default: every combination of the `values`) or `"latin_hypercube"` (`samples`
    /// runs over the `range`s, seeded by `seed`).
    pub(super) sampling: Option<String>,
    pub(super) samples: Option<usize>,
    pub(super) seed: Option<u64>,
    pub(super) vary: Vec<Vary>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Vary {
    pub(super) key: String,
    /// Grid: the values.
    values: Option<Vec<toml::Value>>,
    /// Latin hypercube: the interval, sampled uniformly (`scale = "log"`: uniformly in its
    /// logarithm, for quantities that scatter by factors, as wear coefficients do).
    range: Option<[f64; 2]>,
    scale: Option<String>,
}

/// What a sweep did: runs in all, run now, found done, failed; the table's path.
#[derive(Debug)]
pub struct SweepSummary {
    pub runs: usize,
    pub ran: usize,
    pub skipped: usize,
    pub failed: usize,
    pub table: PathBuf,
}

pub(super) fn io_err(path: &Path) -> impl Fn(std::io::Error) -> StudyError + '_ {
    move |e| StudyError::Io { path: path.display().to_string(), msg: e.to_string() }
}

/// A study's base case and where its runs go.
pub(super) struct Base {
    /// The case as a TOML table, and the folder its relative paths start from.
    pub(super) table: toml::Table,
    pub(super) case_dir: PathBuf,
    pub(super) out: PathBuf,
}

/// Reads a study file as `T` and its base case (`case`, relative to the study file, with the
/// study's `set` keys applied); `output` defaults to `results/<study file stem>`.
pub(super) fn read_study<T: serde::de::DeserializeOwned>(
    file: &Path,
    input: &dyn Fn(&str, String) -> StudyError,
    case_output_set: impl Fn(&T) -> (PathBuf, Option<PathBuf>, Option<toml::Table>),
) -> Result<(T, Base), StudyError> {
    let text = std::fs::read_to_string(file).map_err(io_err(file))?;
    let spec: T = toml::from_str(&text).map_err(|e| input("(file)", e.message().to_string()))?;
    let (case, output, set) = case_output_set(&spec);
    let dir = file.parent().unwrap_or(Path::new("."));
    let case_path = dir.join(case);
    let case_text =
        std::fs::read_to_string(&case_path).map_err(|e| input("case", format!("{}: {e}", case_path.display())))?;
    let mut table: toml::Table =
        toml::from_str(&case_text).map_err(|e| input("case", format!("{}: {}", case_path.display(), e.message())))?;
    for (key, value) in set.unwrap_or_default() {
        set_key(&mut table, &key, value).map_err(|msg| input(&format!("set.{key}"), msg))?;
    }
    let stem = file.file_stem().map_or("study".into(), |s| s.to_string_lossy().to_string());
    let out = output.map_or_else(|| PathBuf::from("results").join(&stem), |o| dir.join(o));
    let case_dir = case_path.parent().unwrap_or(Path::new(".")).to_path_buf();
    Ok((spec, Base { table, case_dir, out }))
}

/// Every run's case (the base with `(key, value)` set), validated before anything runs, then
/// written to `<out>/run_<i>/case.toml`.
pub(super) fn write_cases(
    base: &Base,
    runs: &[Vec<(String, toml::Value)>],
    input: &dyn Fn(&str, String) -> StudyError,
) -> Result<Vec<(PathBuf, String)>, StudyError> {
    let mut cases = Vec::with_capacity(runs.len());
    for (i, values) in runs.iter().enumerate() {
        let mut table = base.table.clone();
        for (key, value) in values {
            set_key(&mut table, key, value.clone()).map_err(|msg| input(key, msg))?;
        }
        absolute_mesh_files(&mut table, &base.case_dir);
        let text = toml::to_string(&table).map_err(|e| input("case", e.to_string()))?;
        let run_case = run_dir(&base.out, i).join("case.toml");
        let name = format!("run_{i:04}");
        mortex::case::parse(&text, &run_case.display().to_string(), &base.case_dir, &name).map_err(|e| {
            let at: Vec<String> = values.iter().map(|(k, x)| format!("{k} = {x}")).collect();
            input("vary", format!("run {i} ({}) is not a valid case: {e}", at.join(", ")))
        })?;
        cases.push((run_case, text));
    }
    for (path, text) in &cases {
        let d = path.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(d).map_err(io_err(d))?;
        std::fs::write(path, text).map_err(io_err(path))?;
    }
    Ok(cases)
}

/// Runs the sweep in `file` with `parallel` runs at once, `exe` the `mortex` binary.
pub fn sweep(file: &Path, exec: &Execution, exe: &Path) -> Result<Outcome<SweepSummary>, StudyError> {
    let name = file.display().to_string();
    let input = |key: &str, msg: String| StudyError::Input { file: name.clone(), key: key.into(), msg };
    let (spec, base) = read_study(file, &input, |s: &SweepFile| (s.case.clone(), s.output.clone(), s.set.clone()))?;
    let runs = grid(&spec, &base.table, &input)?;
    let keyed: Vec<Vec<(String, toml::Value)>> =
        runs.iter().map(|r| spec.vary.iter().map(|v| v.key.clone()).zip(r.iter().cloned()).collect()).collect();
    let cases = write_cases(&base, &keyed, &input)?;
    let (ran, skipped) = match execute(&cases, exec, exe, &base.out, file)? {
        Executed::Ran { ran, skipped } => (ran, skipped),
        Executed::Submitted(job) => return Ok(Outcome::Submitted(job)),
    };
    let table = gather(&base.out, &spec.vary, &runs)?;
    let failed = (0..runs.len()).filter(|&i| !run_ok(&base.out, i)).count();
    Ok(Outcome::Gathered(SweepSummary { runs: runs.len(), ran, skipped, failed, table }))
}

/// The runs' values: the grid of the `vary` lists (every combination, the last varying
/// fastest), or a Latin hypercube over their ranges.
pub(super) fn grid(
    spec: &SweepFile,
    base: &toml::Table,
    input: &dyn Fn(&str, String) -> StudyError,
) -> Result<Vec<Vec<toml::Value>>, StudyError> {
    let vary = &spec.vary;
    if vary.is_empty() {
        return Err(input("vary", "nothing to vary: give at least one [[vary]] with a key and values".into()));
    }
    let lhs = match spec.sampling.as_deref() {
        None | Some("grid") => false,
        Some("latin_hypercube") => true,
        Some(other) => return Err(input("sampling", format!("'{other}': use \"grid\" or \"latin_hypercube\""))),
    };
    if lhs {
        return latin_hypercube(spec, base, input);
    }
    if spec.samples.is_some() || spec.seed.is_some() {
        return Err(input("samples", "samples and seed belong to sampling = \"latin_hypercube\"".into()));
    }
    let mut count = 1usize;
    for (i, v) in vary.iter().enumerate() {
        let Some(values) = v.values.as_ref().filter(|x| !x.is_empty()) else {
            return Err(input(&format!("vary[{i}].values"), "empty or missing: give at least one value".into()));
        };
        if v.range.is_some() || v.scale.is_some() {
            return Err(input(
                &format!("vary[{i}].range"),
                "range and scale belong to sampling = \"latin_hypercube\"".into(),
            ));
        }
        let mut probe = base.clone();
        set_key(&mut probe, &v.key, values[0].clone()).map_err(|msg| input(&format!("vary[{i}].key"), msg))?;
        count = count.saturating_mul(values.len());
    }
    if count > MAX_RUNS {
        return Err(input("vary", format!("{count} runs: more than {MAX_RUNS}")));
    }
    let mut runs = vec![vec![]];
    for v in vary {
        let values = v.values.as_deref().unwrap_or_default();
        runs =
            runs.into_iter().flat_map(|r| values.iter().map(move |x| [r.clone(), vec![x.clone()]].concat())).collect();
    }
    Ok(runs)
}

/// SplitMix64 (Steele, Lea & Flood 2014): a seeded stream that gives the same sample on every
/// machine and version.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `samples` runs, each key's range cut into `samples` equal strata (in the logarithm for
/// `scale = "log"`) and every stratum used by exactly one run, at a uniform point inside it;
/// strata shuffled independently per key. A key whose case value is an integer gets the
/// sample rounded.
fn latin_hypercube(
    spec: &SweepFile,
    base: &toml::Table,
    input: &dyn Fn(&str, String) -> StudyError,
) -> Result<Vec<Vec<toml::Value>>, StudyError> {
    let n =
        spec.samples.ok_or_else(|| input("samples", "latin_hypercube needs samples (the number of runs)".into()))?;
    if n == 0 || n > MAX_RUNS {
        return Err(input("samples", format!("{n}: give 1 to {MAX_RUNS} runs")));
    }
    let mut rng = SplitMix64(spec.seed.unwrap_or(1));
    let mut columns: Vec<Vec<toml::Value>> = Vec::with_capacity(spec.vary.len());
    for (i, v) in spec.vary.iter().enumerate() {
        let key = |k: &str| format!("vary[{i}].{k}");
        if v.values.is_some() {
            return Err(input(&key("values"), "latin_hypercube samples a range: give range = [low, high]".into()));
        }
        let [lo, hi] = v.range.ok_or_else(|| input(&key("range"), "missing: give range = [low, high]".into()))?;
        let log = match v.scale.as_deref() {
            None | Some("linear") => false,
            Some("log") => true,
            Some(other) => return Err(input(&key("scale"), format!("'{other}': use \"linear\" or \"log\""))),
        };
        if !(lo.is_finite() && hi.is_finite() && lo < hi) || (log && lo <= 0.0) {
            return Err(input(
                &key("range"),
                format!("[{lo}, {hi}]: give finite low < high (> 0 for scale = \"log\")"),
            ));
        }
        let integer = key_is_integer(base, &v.key);
        let probe = if integer { toml::Value::Integer(lo.round() as i64) } else { toml::Value::Float(lo) };
        set_key(&mut base.clone(), &v.key, probe).map_err(|msg| input(&key("key"), msg))?;
        let (a, b) = if log { (lo.ln(), hi.ln()) } else { (lo, hi) };
        let mut strata: Vec<usize> = (0..n).collect();
        for k in (1..n).rev() {
            strata.swap(k, (rng.next() % (k as u64 + 1)) as usize);
        }
        columns.push(
            strata
                .iter()
                .map(|&s| {
                    let t = a + (s as f64 + rng.unit()) / n as f64 * (b - a);
                    let x = if log { t.exp() } else { t };
                    if integer {
                        toml::Value::Integer(x.round() as i64)
                    } else {
                        toml::Value::Float(x)
                    }
                })
                .collect(),
        );
    }
    Ok((0..n).map(|r| columns.iter().map(|c| c[r].clone()).collect()).collect())
}

/// A TOML number (float or integer) as f64.
pub(super) fn toml_number(v: &toml::Value) -> Option<f64> {
    v.as_float().or_else(|| v.as_integer().map(|n| n as f64))
}

/// Whether the case's value at `key` is an integer (an integer may replace it, a float not).
fn key_is_integer(base: &toml::Table, key: &str) -> bool {
    set_key(&mut base.clone(), key, toml::Value::Integer(0)).is_ok()
        && set_key(&mut base.clone(), key, toml::Value::Float(0.5)).is_err()
}

/// Sets `key` (`a.b`, `a[2].b`) of a case to `value`. A key the case sets keeps its type (an
/// integer where a float is expected is taken as a float); a key it leaves out is added (the
/// case reader then checks it); array elements must exist.
fn set_key(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let mut root = toml::Value::Table(std::mem::take(table));
    let result = set_in(&mut root, key.split('.').collect::<Vec<_>>().as_slice(), value);
    if let toml::Value::Table(t) = root {
        *table = t;
    }
    result
}

fn set_in(node: &mut toml::Value, parts: &[&str], value: toml::Value) -> Result<(), String> {
    let Some((part, rest)) = parts.split_first() else { return Err("empty key".into()) };
    let (name, index) = match part.split_once('[') {
        Some((n, tail)) => {
            let i = tail.strip_suffix(']').and_then(|s| s.parse::<usize>().ok());
            (n, Some(i.ok_or(format!("'{part}' is not `name[index]`"))?))
        }
        None => (*part, None),
    };
    let table = node.as_table_mut().ok_or(format!("'{name}' is under a value, not a table"))?;
    if !table.contains_key(name) && index.is_none() {
        // A key the case leaves at its default (a `[cycle_jump]` setting, say): added, and
        // checked with the rest of the run's case by the case reader.
        let fresh = if rest.is_empty() { value.clone() } else { toml::Value::Table(toml::Table::new()) };
        table.insert(name.to_string(), fresh);
        if rest.is_empty() {
            return Ok(());
        }
    }
    let child = table.get_mut(name).ok_or(format!("the case has no '{name}' there"))?;
    let child = match index {
        Some(i) => child
            .as_array_mut()
            .ok_or(format!("'{name}' is not an array"))?
            .get_mut(i)
            .ok_or(format!("'{name}' has no element {i}"))?,
        None => child,
    };
    if !rest.is_empty() {
        return set_in(child, rest, value);
    }
    *child = match (&*child, value) {
        (toml::Value::Float(_), toml::Value::Integer(n)) => toml::Value::Float(n as f64),
        (old, new) if std::mem::discriminant(old) == std::mem::discriminant(&new) => new,
        (old, new) => {
            return Err(format!(
                "{new} is of type {}, where the case has {old} of type {}",
                new.type_str(),
                old.type_str()
            ))
        }
    };
    Ok(())
}

/// Mesh files of the case (`bodies[i].mesh.file`) made absolute: the run's case lives in the
/// sweep's output, not beside the original.
fn absolute_mesh_files(table: &mut toml::Table, case_dir: &Path) {
    let Some(bodies) = table.get_mut("bodies").and_then(|b| b.as_array_mut()) else { return };
    for body in bodies {
        let Some(file) = body.get_mut("mesh").and_then(|m| m.get_mut("file")) else { continue };
        if let Some(f) = file.as_str().map(PathBuf::from).filter(|f| f.is_relative()) {
            let joined = case_dir.join(f);
            let full = joined.canonicalize().unwrap_or(joined);
            *file = toml::Value::String(full.display().to_string());
        }
    }
}

fn run_dir(out: &Path, i: usize) -> PathBuf {
    out.join(format!("run_{i:04}"))
}

/// The result file of run `i` of a study.
pub(super) fn result_path(out: &Path, i: usize) -> PathBuf {
    run_dir(out, i).join("result.h5")
}

pub(super) fn figures_path(out: &Path, i: usize) -> PathBuf {
    run_dir(out, i).join("figures.csv")
}

pub(super) fn run_ok(out: &Path, i: usize) -> bool {
    read_figures(&figures_path(out, i)).is_some_and(|f| f.first().is_some_and(|(k, v)| k == "status" && v == "ok"))
}

/// Where a study's runs go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Execution {
    /// Processes on this machine, `parallel` at a time.
    Local { parallel: usize },
    /// One Slurm job array, a task per run not done yet, written to `<output>/slurm/` and
    /// submitted with `sbatch` (`submit` false: written only); `sbatch` holds extra
    /// `#SBATCH` options (`--partition=...`, `--time=...`).
    Slurm { submit: bool, sbatch: Vec<String> },
    /// No run: the runs' figures gathered (after a Slurm array ended); runs not done are an
    /// error naming them.
    Gather,
}

/// A study gathered, or its runs handed to Slurm.
#[derive(Debug)]
pub enum Outcome<T> {
    Gathered(T),
    Submitted(SlurmJob),
}

/// A job array written (and submitted, with its job id) for a study's runs.
#[derive(Debug)]
pub struct SlurmJob {
    pub script: PathBuf,
    /// Array tasks: the runs not done yet.
    pub tasks: usize,
    pub job_id: Option<String>,
}

/// What [`execute`] did: ran (or found done) the runs, or submitted them.
pub(super) enum Executed {
    Ran { ran: usize, skipped: usize },
    Submitted(SlurmJob),
}

/// The runs of `cases` (those without `figures.csv`) as `exec` says; `out` the study's output
/// folder, `file` the study file (named in the job script).
pub(super) fn execute(
    cases: &[(PathBuf, String)],
    exec: &Execution,
    exe: &Path,
    out: &Path,
    file: &Path,
) -> Result<Executed, StudyError> {
    match exec {
        Execution::Local { parallel } => {
            let (ran, skipped) = run_all(cases, (*parallel).max(1), exe)?;
            Ok(Executed::Ran { ran, skipped })
        }
        Execution::Slurm { submit, sbatch } => {
            slurm_array(cases, exe, out, file, *submit, sbatch).map(Executed::Submitted)
        }
        Execution::Gather => {
            let missing: Vec<usize> =
                (0..cases.len()).filter(|&i| !cases[i].0.with_file_name("figures.csv").exists()).collect();
            if let Some(&first) = missing.first() {
                let shown: Vec<String> = missing.iter().take(8).map(|i| format!("run_{i:04}")).collect();
                return Err(StudyError::Io {
                    path: out.display().to_string(),
                    msg: format!(
                        "{} of {} runs not done yet ({}{}): their tasks are queued, running or were killed \
                         (see {}); gather again when they ended, or run the study again to finish them",
                        missing.len(),
                        cases.len(),
                        shown.join(", "),
                        if missing.len() > shown.len() { ", ..." } else { "" },
                        slurm_dir(out).join(format!("task_{first}.log")).display()
                    ),
                });
            }
            Ok(Executed::Ran { ran: 0, skipped: cases.len() })
        }
    }
}

fn slurm_dir(out: &Path) -> PathBuf {
    out.join("slurm")
}

/// Array indices as Slurm's range list (`0-3,5,7-9`).
pub fn array_ranges(indices: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut k = 0;
    while k < indices.len() {
        let start = indices[k];
        let mut end = start;
        while k + 1 < indices.len() && indices[k + 1] == end + 1 {
            k += 1;
            end += 1;
        }
        parts.push(if end > start { format!("{start}-{end}") } else { format!("{start}") });
        k += 1;
    }
    parts.join(",")
}

/// Writes `<out>/slurm/runs.txt` (run `i`'s case on line `i`) and `<out>/slurm/array.sbatch`
/// (a task per run not done, each `mortex study task`), and submits it with `sbatch --parsable`
/// when `submit`.
fn slurm_array(
    cases: &[(PathBuf, String)],
    exe: &Path,
    out: &Path,
    file: &Path,
    submit: bool,
    sbatch: &[String],
) -> Result<SlurmJob, StudyError> {
    let dir = slurm_dir(out);
    std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let list: String = cases.iter().map(|(c, _)| format!("{}\n", absolute(c).display())).collect();
    let runs = dir.join("runs.txt");
    std::fs::write(&runs, list).map_err(io_err(&runs))?;
    let todo: Vec<usize> = (0..cases.len()).filter(|&i| !cases[i].0.with_file_name("figures.csv").exists()).collect();
    let script = dir.join("array.sbatch");
    if todo.is_empty() {
        return Ok(SlurmJob { script, tasks: 0, job_id: None });
    }
    let name = file.file_stem().map_or("study".into(), |s| s.to_string_lossy().to_string());
    let mut text = format!(
        "#!/bin/bash\n# Written by `mortex study ... --slurm` for {}: one task per run not done yet;\n\
         # each runs one case as the local runner does. Gather with: mortex study gather {}\n\
         #SBATCH --job-name=mortex-{name}\n#SBATCH --array={}\n#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=1\n\
         #SBATCH --output={}/task_%a.log\n",
        file.display(),
        file.display(),
        array_ranges(&todo),
        absolute(&dir).display()
    );
    for option in sbatch {
        text.push_str(&format!("#SBATCH {option}\n"));
    }
    text.push_str(&format!(
        "exec {:?} study task {:?} \"$SLURM_ARRAY_TASK_ID\"\n",
        absolute(exe).display().to_string(),
        absolute(&runs).display().to_string()
    ));
    std::fs::write(&script, text).map_err(io_err(&script))?;
    if !submit {
        return Ok(SlurmJob { script, tasks: todo.len(), job_id: None });
    }
    let output =
        std::process::Command::new("sbatch").arg("--parsable").arg(&script).output().map_err(|e| StudyError::Io {
            path: script.display().to_string(),
            msg: format!("cannot run sbatch ({e}): is Slurm installed here? (--no-submit writes the script only)"),
        })?;
    if !output.status.success() {
        return Err(StudyError::Io {
            path: script.display().to_string(),
            msg: format!("sbatch refused the job array: {}", String::from_utf8_lossy(&output.stderr).trim()),
        });
    }
    let id = String::from_utf8_lossy(&output.stdout).trim().split(';').next().unwrap_or("").to_string();
    Ok(SlurmJob { script, tasks: todo.len(), job_id: Some(id) })
}

/// One Slurm array task: run `index` of the list `runs` (a `runs.txt` of [`Execution::Slurm`]),
/// run as the local runner runs it, its `figures.csv` written.
pub fn task(runs: &Path, index: usize, exe: &Path) -> Result<(), StudyError> {
    let text = std::fs::read_to_string(runs).map_err(io_err(runs))?;
    let Some(case) = text.lines().nth(index) else {
        return Err(StudyError::Input {
            file: runs.display().to_string(),
            key: "index".into(),
            msg: format!("no run {index}: the list has {} runs", text.lines().count()),
        });
    };
    let case = PathBuf::from(case);
    let t0 = Instant::now();
    let status = run_process(&case, exe, 1)?.wait().map_err(io_err(exe))?;
    let dir = case.parent().unwrap_or(Path::new(".")).to_path_buf();
    write_figures(&dir, status, t0.elapsed().as_secs_f64())
}

/// `mortex run --quiet <case> -o result.h5` next to the case, its output in `run.log`. With
/// `parallel` runs at once each takes its share of the cores as threads (unless
/// `RAYON_NUM_THREADS` says otherwise): more threads than cores spin against each other.
fn run_process(case: &Path, exe: &Path, parallel: usize) -> Result<std::process::Child, StudyError> {
    let dir = case.parent().unwrap_or(Path::new("."));
    let log_path = dir.join("run.log");
    let log = std::fs::File::create(&log_path).map_err(io_err(&log_path))?;
    let err = log.try_clone().map_err(io_err(&log_path))?;
    let mut command = std::process::Command::new(exe);
    if parallel > 1 && std::env::var_os("RAYON_NUM_THREADS").is_none() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        command.env("RAYON_NUM_THREADS", (cores / parallel).max(1).to_string());
    }
    command
        .arg("run")
        .arg("--quiet")
        .arg(case)
        .arg("-o")
        .arg(dir.join("result.h5"))
        .stdout(log)
        .stderr(err)
        .spawn()
        .map_err(io_err(exe))
}

/// Runs every case whose run has no `figures.csv` yet, `parallel` at a time. Returns the runs
/// started and the runs found done.
fn run_all(cases: &[(PathBuf, String)], parallel: usize, exe: &Path) -> Result<(usize, usize), StudyError> {
    let mut todo: Vec<usize> =
        (0..cases.len()).filter(|&i| !cases[i].0.with_file_name("figures.csv").exists()).collect();
    let skipped = cases.len() - todo.len();
    let started = todo.len();
    todo.reverse();
    // Runs ended, out of those to run (drawn on a terminal only).
    let bar = indicatif::ProgressBar::new(started as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:40} run {pos}/{len} (eta {eta}) {msg}",
    ) {
        bar.set_style(style);
    }
    let mut running: Vec<(usize, std::process::Child, Instant)> = Vec::new();
    while !todo.is_empty() || !running.is_empty() {
        while running.len() < parallel {
            let Some(i) = todo.pop() else { break };
            let child = run_process(&cases[i].0, exe, parallel)?;
            tracing::info!(run = i, case = %cases[i].0.display(), "sweep run started");
            running.push((i, child, Instant::now()));
        }
        let mut k = 0;
        while k < running.len() {
            let status = running[k].1.try_wait().map_err(io_err(exe))?;
            let Some(status) = status else {
                k += 1;
                continue;
            };
            let (i, _, t0) = running.swap_remove(k);
            let dir = cases[i].0.parent().unwrap_or(Path::new(".")).to_path_buf();
            write_figures(&dir, status, t0.elapsed().as_secs_f64())?;
            bar.set_message(format!("run {i} {}", if status.success() { "done" } else { "failed" }));
            bar.inc(1);
        }
        if !running.is_empty() {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    bar.finish_and_clear();
    Ok((started, skipped))
}

/// `figures.csv` of an ended run: its status (`ok`, or the exit and the log's last line), wall
/// time, and per wearing surface its largest depth and worn area at the end.
fn write_figures(dir: &Path, status: std::process::ExitStatus, seconds: f64) -> Result<(), StudyError> {
    let mut rows: Vec<(String, String)> = Vec::new();
    if status.success() {
        rows.push(("status".into(), "ok".into()));
    } else {
        let log = std::fs::read_to_string(dir.join("run.log")).unwrap_or_default();
        let last = log.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").replace(',', ";");
        rows.push(("status".into(), format!("failed ({status}): {last}")));
    }
    rows.push(("wall_s".into(), format!("{seconds:.3}")));
    if status.success() {
        rows.extend(wear_figures(&dir.join("result.h5")));
    }
    let text: String = rows.iter().map(|(k, v)| format!("{k},{v}\n")).collect();
    let path = dir.join("figures.csv");
    std::fs::write(&path, text).map_err(io_err(&path))
}

/// Per wearing surface of a result file: its largest depth and worn area at the last wear
/// update (none for a run without wear).
fn wear_figures(result: &Path) -> Vec<(String, String)> {
    let Ok(file) = hdf5::File::open(result) else { return vec![] };
    let Ok(wear) = file.group("wear") else { return vec![] };
    let mut out = Vec::new();
    for name in wear.member_names().unwrap_or_default() {
        let Ok(g) = wear.group(&name) else { continue };
        for what in ["max_depth", "worn_area"] {
            if let Some(v) = g.dataset(what).and_then(|d| d.read_raw::<f64>()).ok().and_then(|v| v.last().copied()) {
                out.push((format!("{name} {what}"), format!("{v:e}")));
            }
        }
    }
    out
}

pub(super) fn read_figures(path: &Path) -> Option<Vec<(String, String)>> {
    let text = std::fs::read_to_string(path).ok()?;
    Some(text.lines().filter_map(|l| l.split_once(',')).map(|(k, v)| (k.to_string(), v.to_string())).collect())
}

/// `sweep.csv` and `sweep.md` of every run: its index, the varied values, its figures.
fn gather(out: &Path, vary: &[Vary], runs: &[Vec<toml::Value>]) -> Result<PathBuf, StudyError> {
    let figures: Vec<Vec<(String, String)>> =
        (0..runs.len()).map(|i| read_figures(&figures_path(out, i)).unwrap_or_default()).collect();
    let mut columns: Vec<String> = Vec::new();
    for f in &figures {
        for (k, _) in f.iter().filter(|(k, _)| k != "status") {
            if !columns.contains(k) {
                columns.push(k.clone());
            }
        }
    }
    let header: Vec<String> = ["run".to_string()]
        .into_iter()
        .chain(vary.iter().map(|v| v.key.clone()))
        .chain(columns.iter().cloned())
        .chain(["status".to_string()])
        .collect();
    let mut rows: Vec<Vec<String>> = Vec::new();
    for (i, (values, f)) in runs.iter().zip(&figures).enumerate() {
        let get = |k: &str| f.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
        let mut row = vec![i.to_string()];
        row.extend(values.iter().map(|v| v.to_string()));
        // A missing figure stays empty: never a number the run did not produce.
        row.extend(columns.iter().map(|c| get(c).unwrap_or_default()));
        row.push(get("status").unwrap_or_else(|| "missing".into()));
        rows.push(row);
    }
    let csv_path = write_table(out, "sweep", &header, &rows)?;
    chart(out, vary, runs, &columns, &figures);
    Ok(csv_path)
}

/// A study's table as `<out>/<stem>.csv` and `<stem>.md`; returns the CSV's path.
pub(super) fn write_table(
    out: &Path,
    stem: &str,
    header: &[String],
    rows: &[Vec<String>],
) -> Result<PathBuf, StudyError> {
    let csv: String =
        std::iter::once(header).chain(rows.iter().map(|r| r.as_slice())).map(|r| r.join(",") + "\n").collect();
    let md: String = std::iter::once(format!("| {} |\n", header.join(" | ")))
        .chain(std::iter::once(format!("|{}\n", "---|".repeat(header.len()))))
        .chain(rows.iter().map(|r| format!("| {} |\n", r.join(" | "))))
        .collect();
    let csv_path = out.join(format!("{stem}.csv"));
    std::fs::write(&csv_path, csv).map_err(io_err(&csv_path))?;
    let md_path = out.join(format!("{stem}.md"));
    std::fs::write(&md_path, md).map_err(io_err(&md_path))?;
    Ok(csv_path)
}

/// `sweep.png`: per numeric key varied, each surface's largest depth against it. A chart that
/// cannot be drawn (no font) is reported in the log, not as a failed sweep: the table holds
/// the figures.
fn chart(out: &Path, vary: &[Vary], runs: &[Vec<toml::Value>], columns: &[String], figures: &[Vec<(String, String)>]) {
    use mortex::io::plot::{write_xy_png, Series};
    let number = toml_number;
    let depths: Vec<&String> = columns.iter().filter(|c| c.ends_with("max_depth")).collect();
    if depths.is_empty() {
        return;
    }
    let mut panels = Vec::new();
    for (k, v) in vary.iter().enumerate() {
        if runs.first().and_then(|r| number(&r[k])).is_none() {
            continue;
        }
        let series: Vec<Series> = depths
            .iter()
            .map(|c| Series {
                label: c.trim_end_matches(" max_depth").to_string(),
                // One key varied: a curve; several: each panel is a projection, points only.
                joined: vary.len() == 1,
                points: runs
                    .iter()
                    .zip(figures)
                    .filter_map(|(r, f)| {
                        let y = f.iter().find(|(n, _)| n == *c).and_then(|(_, y)| y.parse::<f64>().ok())?;
                        Some((number(&r[k])?, y))
                    })
                    .collect(),
            })
            .collect();
        panels.push((
            format!("largest wear depth against {}", v.key),
            v.key.clone(),
            "max depth (mm)".to_string(),
            series,
        ));
    }
    let path = out.join("sweep.png");
    if let Err(e) = write_xy_png(&panels, &path) {
        tracing::warn!(error = %e, "sweep chart not drawn");
    }
}

/// The `mortex` binary each study run starts.
pub(crate) fn study_exe() -> anyhow::Result<PathBuf> {
    std::env::current_exe().map_err(|e| anyhow::anyhow!("the mortex binary: {e}"))
}

/// The study's runs handed to Slurm: what was written and submitted, and how to gather.
pub(crate) fn report_submitted(file: &std::path::Path, job: &crate::cli::study::SlurmJob) {
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

pub(crate) fn study_task(runs: &std::path::Path, index: usize) -> anyhow::Result<()> {
    crate::cli::study::task(runs, index, &study_exe()?).map_err(anyhow::Error::from)
}

pub(crate) fn study_sweep(file: &std::path::Path, exec: crate::cli::study::Execution) -> anyhow::Result<()> {
    let s = match crate::cli::study::sweep(file, &exec, &study_exe()?)? {
        crate::cli::study::Outcome::Gathered(s) => s,
        crate::cli::study::Outcome::Submitted(job) => {
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
        return Err(anyhow::anyhow!("{} of {} runs failed: see their run.log and the status column", s.failed, s.runs));
    }
    Ok(())
}
