//! `mortex study life`: fretting-fatigue life against slip amplitude, with wear and without.
//!
//! A fretting case with `[fatigue]` (and `stop_at_initiation`) is run at every stroke
//! amplitude of the study, once as it is and once with the settings of `without_wear` (wear
//! coefficients made negligible: the same contact, no scar). Each run's life is the cycle at
//! which its first point reaches Miner damage 1 (`/wear/fatigue` attribute
//! `initiation_cycle`), or a run-out past the cycles it reached. Whether the stroke is partial
//! or gross slip is the engine's own answer: the fewest nodes sticking, as a fraction of those in
//! contact, over the first computed cycle of the run without wear (0: at some increment every
//! node in contact slips, gross slip).
//!
//! ```toml
//! case = "../mccoll_fretting.toml"
//! stroke = { key = "bcs[1].ux", values = [0.0005, 0.001, 0.002, 0.004] }
//! without_wear = [{ key = "wear[0].coefficient", value = 2.9e-14 }]
//! [set]
//! fatigue = { body = "flat", sigma_f = 1758.0, b = -0.0977, eps_f = 2.12, c = -0.774, stop_at_initiation = true }
//! ```
//!
//! The trend it shows is the one of Madge, Leen, McColl & Shipway (Wear 262 (2007) 1159):
//! without wear the life falls as the slip grows; with wear it falls through partial slip, is
//! lowest near the transition to gross slip, and rises in gross slip, where wear carries the
//! damaged material away. Runs `2 i` (with wear) and `2 i + 1` (without) of stroke `i` live in
//! `<output>/run_<k>/` (resumable, local or Slurm, as a sweep); the table is
//! `<output>/life.csv` and `.md`, the chart `life.png`.

use super::study::{execute, read_study, result_path, run_ok, write_cases, Executed, Execution, Outcome, StudyError};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LifeFile {
    case: PathBuf,
    output: Option<PathBuf>,
    set: Option<toml::Table>,
    stroke: Stroke,
    without_wear: Vec<Setting>,
    /// The contact pair whose stick and slip are read (default: the case's first).
    pair: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Stroke {
    key: String,
    values: Vec<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Setting {
    key: String,
    value: toml::Value,
}

/// A run's fatigue life: crack initiation at a cycle, no initiation by the cycles it reached,
/// or no figure (the run failed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Life {
    Initiated(f64),
    RunOut(f64),
    Unknown,
}

impl Life {
    /// The life as a lower bound: a run-out counts as the cycles it reached.
    fn at_least(self) -> Option<f64> {
        match self {
            Life::Initiated(n) | Life::RunOut(n) => Some(n),
            Life::Unknown => None,
        }
    }
}

impl std::fmt::Display for Life {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Life::Initiated(n) => write!(f, "{n:e}"),
            Life::RunOut(n) => write!(f, "> {n:e} (no initiation)"),
            Life::Unknown => write!(f, "- (run failed)"),
        }
    }
}

/// One stroke of the study: its amplitude, the engine's slip figures of the unworn first
/// cycle, and the lives with and without wear.
#[derive(Debug, Clone)]
pub struct LifePoint {
    pub stroke: f64,
    /// Fewest nodes sticking over the first computed cycle, as a fraction of those in contact.
    pub stick_fraction: Option<f64>,
    /// Largest slip amplitude of a node over that cycle (its summed slip over 4).
    pub slip_amplitude: Option<f64>,
    pub with_wear: Life,
    pub without_wear: Life,
}

pub struct LifeSummary {
    pub runs: usize,
    pub ran: usize,
    pub skipped: usize,
    pub points: Vec<LifePoint>,
    /// The first stroke in gross slip.
    pub transition: Option<usize>,
    /// The stroke of the shortest life with wear.
    pub shortest_with_wear: Option<usize>,
    pub table: PathBuf,
}

/// The first point in gross slip (no node sticking at some increment of the first cycle).
pub fn gross_slip_from(stick_fractions: &[Option<f64>]) -> Option<usize> {
    stick_fractions.iter().position(|s| s.is_some_and(|s| s == 0.0))
}

/// The point of the shortest life (run-outs count as the cycles they reached); none if a
/// point's life is unknown.
pub fn shortest(lives: &[Life]) -> Option<usize> {
    let at_least: Option<Vec<f64>> = lives.iter().map(|l| l.at_least()).collect();
    let at_least = at_least?;
    (0..at_least.len()).min_by(|&a, &b| at_least[a].total_cmp(&at_least[b]))
}

/// Runs the life study in `file`.
pub fn life(file: &Path, exec: &Execution, exe: &Path) -> Result<Outcome<LifeSummary>, StudyError> {
    let name = file.display().to_string();
    let input = |key: &str, msg: String| StudyError::Input { file: name.clone(), key: key.into(), msg };
    let (spec, base) = read_study(file, &input, |s: &LifeFile| (s.case.clone(), s.output.clone(), s.set.clone()))?;
    if spec.stroke.values.is_empty() || spec.stroke.values.iter().any(|v| !v.is_finite()) {
        return Err(input("stroke.values", "give the stroke amplitudes, finite numbers".into()));
    }
    if spec.without_wear.is_empty() {
        return Err(input("without_wear", "give the settings of the runs without wear: [{ key, value }]".into()));
    }
    if !base.table.contains_key("fatigue") {
        return Err(input("case", "the case has no [fatigue] (set it in the study's [set])".into()));
    }
    let (start, end) = first_cycle(&base.table).ok_or_else(|| input("case", "the case has no [steps] cycle".into()))?;
    let mut runs: Vec<Vec<(String, toml::Value)>> = Vec::new();
    for &s in &spec.stroke.values {
        let stroke = (spec.stroke.key.clone(), toml::Value::Float(s));
        runs.push(vec![stroke.clone()]);
        let mut dry = vec![stroke];
        dry.extend(spec.without_wear.iter().map(|w| (w.key.clone(), w.value.clone())));
        runs.push(dry);
    }
    let cases = write_cases(&base, &runs, &input)?;
    let (ran, skipped) = match execute(&cases, exec, exe, &base.out, file)? {
        Executed::Ran { ran, skipped } => (ran, skipped),
        Executed::Submitted(job) => return Ok(Outcome::Submitted(job)),
    };
    let points: Vec<LifePoint> = spec
        .stroke
        .values
        .iter()
        .enumerate()
        .map(|(i, &stroke)| {
            let worn = result_path(&base.out, 2 * i);
            let dry = result_path(&base.out, 2 * i + 1);
            let (stick_fraction, slip_amplitude) = first_cycle_slip(&dry, spec.pair.as_deref(), start, end)
                .map_or((None, None), |(a, b)| (Some(a), Some(b)));
            LifePoint {
                stroke,
                stick_fraction,
                slip_amplitude,
                // A failed run has no life, whatever its file holds.
                with_wear: if run_ok(&base.out, 2 * i) { read_life(&worn) } else { Life::Unknown },
                without_wear: if run_ok(&base.out, 2 * i + 1) { read_life(&dry) } else { Life::Unknown },
            }
        })
        .collect();
    let transition = gross_slip_from(&points.iter().map(|p| p.stick_fraction).collect::<Vec<_>>());
    let shortest_with_wear = shortest(&points.iter().map(|p| p.with_wear).collect::<Vec<_>>());
    let table = write_table(&base.out, &spec.stroke.key, &points)?;
    chart(&base.out, &spec.stroke.key, &points, transition);
    Ok(Outcome::Gathered(LifeSummary { runs: runs.len(), ran, skipped, points, transition, shortest_with_wear, table }))
}

/// The first computed cycle's time interval: `[steps] cycle = [start, end]`.
fn first_cycle(case: &toml::Table) -> Option<(f64, f64)> {
    let c = case.get("steps")?.get("cycle")?.as_array()?;
    let num = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
    Some((num(c.first()?)?, num(c.get(1)?)?))
}

/// A run's life from its result file.
fn read_life(result: &Path) -> Life {
    let read = || -> hdf5::Result<Life> {
        let f = hdf5::File::open(result)?;
        let g = f.group("wear/fatigue")?;
        if let Ok(a) = g.attr("initiation_cycle") {
            return Ok(Life::Initiated(a.read_scalar::<f64>()?));
        }
        let cycles = f.dataset("wear/cycle")?.read_raw::<u64>()?;
        Ok(cycles.last().map_or(Life::Unknown, |&n| Life::RunOut(n as f64)))
    };
    read().unwrap_or(Life::Unknown)
}

/// Over the first computed cycle (times in `(start, end]`) of a result file's contact `pair`:
/// the fewest nodes sticking as a fraction of those in contact, and the largest slip amplitude
/// of a node (its slips summed over the cycle, over 4).
fn first_cycle_slip(result: &Path, pair: Option<&str>, start: f64, end: f64) -> Option<(f64, f64)> {
    let f = hdf5::File::open(result).ok()?;
    let contacts = f.group("series/contacts").ok()?;
    let name = match pair {
        Some(p) => p.to_string(),
        // The first pair: a group (`dissipation` beside them is a dataset).
        None => contacts.member_names().ok()?.into_iter().find(|n| contacts.group(n).is_ok())?,
    };
    let g = contacts.group(&name).ok()?;
    let time = f.dataset("series/time").ok()?.read_raw::<f64>().ok()?;
    let status = g.dataset("status").ok()?.read_2d::<u8>().ok()?;
    let slip = g.dataset("slip").ok()?.read_2d::<f64>().ok()?;
    let tol = 1e-9 * (end - start).abs();
    let steps: Vec<usize> = (0..time.len()).filter(|&k| time[k] > start + tol && time[k] <= end + tol).collect();
    if steps.is_empty() {
        return None;
    }
    let mut fewest = f64::INFINITY;
    let mut summed = vec![0.0; slip.ncols()];
    for &k in &steps {
        let row = status.row(k);
        let stick = row.iter().filter(|&&s| s == 1).count();
        let slipping = row.iter().filter(|&&s| s == 2).count();
        if stick + slipping > 0 {
            fewest = fewest.min(stick as f64 / (stick + slipping) as f64);
        }
        for (acc, s) in summed.iter_mut().zip(slip.row(k)) {
            if s.is_finite() {
                *acc += s.abs();
            }
        }
    }
    let amplitude = summed.iter().fold(0.0_f64, |a, &b| a.max(b)) / 4.0;
    fewest.is_finite().then_some((fewest, amplitude))
}

fn write_table(out: &Path, key: &str, points: &[LifePoint]) -> Result<PathBuf, StudyError> {
    let opt = |v: Option<f64>, p: usize| v.map_or_else(|| "-".to_string(), |x| format!("{x:.p$}"));
    let header: Vec<String> =
        [key, "slip amplitude", "fewest sticking", "regime", "life with wear", "life without wear"]
            .iter()
            .map(|h| h.to_string())
            .collect();
    let rows: Vec<Vec<String>> = points
        .iter()
        .map(|p| {
            vec![
                format!("{}", p.stroke),
                p.slip_amplitude.map_or_else(|| "-".into(), |x| format!("{x:.3e}")),
                opt(p.stick_fraction, 3),
                match p.stick_fraction {
                    Some(s) if s == 0.0 => "gross slip".into(),
                    Some(_) => "partial slip".into(),
                    None => "-".into(),
                },
                p.with_wear.to_string(),
                p.without_wear.to_string(),
            ]
        })
        .collect();
    super::study::write_table(out, "life", &header, &rows)
}

/// `life.png`: log10 life against log10 stroke (the strokes span decades), with wear and without (run-outs at the cycles
/// they reached, as points of their own), and the first stroke in gross slip.
fn chart(out: &Path, key: &str, points: &[LifePoint], transition: Option<usize>) {
    use mortex::io::plot::{write_xy_png, Series};
    let initiated = |pick: fn(&LifePoint) -> Life| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter_map(|p| if let Life::Initiated(n) = pick(p) { Some((p.stroke.log10(), n.log10())) } else { None })
            .collect()
    };
    let run_out = |pick: fn(&LifePoint) -> Life| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter_map(|p| if let Life::RunOut(n) = pick(p) { Some((p.stroke.log10(), n.log10())) } else { None })
            .collect()
    };
    let with = |p: &LifePoint| p.with_wear;
    let without = |p: &LifePoint| p.without_wear;
    let mut series = vec![
        Series { label: "with wear".into(), points: initiated(with), joined: true },
        Series { label: "without wear".into(), points: initiated(without), joined: true },
        Series { label: "with wear: no initiation by then".into(), points: run_out(with), joined: false },
        Series { label: "without wear: no initiation by then".into(), points: run_out(without), joined: false },
    ];
    let all: Vec<f64> =
        points.iter().flat_map(|p| [p.with_wear, p.without_wear]).filter_map(|l| l.at_least()).collect();
    if let (Some(t), false) = (transition, all.is_empty()) {
        let lo = all.iter().fold(f64::INFINITY, |a, &b| a.min(b)).log10();
        let hi = all.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b)).log10();
        let x = points[t].stroke.log10();
        series.push(Series {
            label: "first stroke in gross slip".into(),
            points: vec![(x, lo), (x, hi)],
            joined: true,
        });
    }
    let panel = (
        "fretting-fatigue life against stroke amplitude".to_string(),
        format!("log10 {key}"),
        "log10 cycles to crack initiation (SWT, Miner)".to_string(),
        series,
    );
    if let Err(e) = write_xy_png(&[panel], &out.join("life.png")) {
        tracing::warn!(error = %e, "life chart not drawn");
    }
}

pub(crate) fn study_life(file: &Path, exec: Execution) -> anyhow::Result<()> {
    let s = match life(file, &exec, &super::study::study_exe()?)? {
        Outcome::Gathered(s) => s,
        Outcome::Submitted(job) => {
            super::study::report_submitted(file, &job);
            return Ok(());
        }
    };
    println!("{}: {} runs: {} run now, {} done before", file.display(), s.runs, s.ran, s.skipped);
    for p in &s.points {
        println!("  stroke {}: life with wear {}, without {}", p.stroke, p.with_wear, p.without_wear);
    }
    match s.transition {
        Some(t) => println!("  gross slip from stroke {}", s.points[t].stroke),
        None => println!("  partial slip at every stroke"),
    }
    if let Some(i) = s.shortest_with_wear {
        println!("  shortest life with wear at stroke {}", s.points[i].stroke);
    }
    println!("-> {} (+ life.md, life.png)", s.table.display());
    let failed = s.points.iter().filter(|p| p.with_wear == Life::Unknown || p.without_wear == Life::Unknown).count();
    if failed > 0 {
        return Err(anyhow::anyhow!("{failed} strokes without a life: a run failed (see its run.log)"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{gross_slip_from, shortest, Life};

    /// Gross slip starts at the first stroke where no node sticks at some increment.
    #[test]
    fn gross_slip_starts_at_the_first_stroke_without_a_sticking_node() {
        assert_eq!(gross_slip_from(&[Some(0.5), Some(0.1), Some(0.0), Some(0.0)]), Some(2));
        assert_eq!(gross_slip_from(&[Some(0.5), None, Some(0.2)]), None);
    }

    /// Run-outs count as the cycles they reached: a run-out at 1e6 is longer than a life of
    /// 5e5; an unknown life leaves no answer.
    #[test]
    fn the_shortest_life_counts_run_outs_as_lower_bounds() {
        let lives = [Life::Initiated(7e5), Life::Initiated(5e5), Life::RunOut(1e6)];
        assert_eq!(shortest(&lives), Some(1));
        assert_eq!(shortest(&[Life::Initiated(7e5), Life::Unknown]), None);
    }
}
