//! `mortex study pareto`: a case over a grid of discretisations (a sweep), each run's error
//! against one converged run and its wall time, and the Pareto front of the two: the runs no
//! other run beats in both. A user picks the cheapest setting that reaches the accuracy asked.
//!
//! ```toml
//! case = "mccoll_1000.toml"
//! output = "results/mccoll_pareto"
//! reference = [{ key = "steps.increments", value = 32 }]   # the converged setting
//! [[vary]]
//! key = "steps.increments"
//! values = [4, 8, 16]
//! [[vary]]
//! key = "cycle_jump.pressure_change"
//! values = [0.05, 0.1, 0.2]
//! ```
//!
//! The error of a run is the largest relative error of its wearing surfaces' largest depths
//! against the reference run's. Run 0 is the reference, runs 1.. the grid (folders and resume
//! as a sweep); the table is `<output>/pareto.csv` and `.md`, the chart `pareto.png`.

use super::study::{
    execute, figures_path, grid, read_figures, read_study, write_cases, Executed, Execution, Outcome, StudyError,
    SweepFile, Vary,
};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParetoFile {
    case: PathBuf,
    output: Option<PathBuf>,
    /// Keys set in every run (the study's base case).
    set: Option<toml::Table>,
    reference: Vec<Setting>,
    vary: Vec<Vary>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Setting {
    key: String,
    value: toml::Value,
}

/// One run of the grid: its settings, wall time, error against the reference, and whether
/// it is on the Pareto front.
#[derive(Debug, Clone)]
pub struct Point {
    pub run: usize,
    pub settings: String,
    pub wall_s: Option<f64>,
    pub error: Option<f64>,
    pub front: bool,
}

/// What a Pareto study did.
pub struct ParetoSummary {
    pub runs: usize,
    pub ran: usize,
    pub skipped: usize,
    pub points: Vec<Point>,
    pub reference_wall_s: Option<f64>,
    pub table: PathBuf,
}

/// The Pareto front of `(cost, error)` pairs: index `i` is on it when no other point has both
/// a cost and an error at most its own, one of them strictly lower.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    points.iter().map(|&(c, e)| !points.iter().any(|&(c2, e2)| c2 <= c && e2 <= e && (c2 < c || e2 < e))).collect()
}

/// Runs the Pareto study in `file`, `parallel` runs at once.
pub fn pareto(file: &Path, exec: &Execution, exe: &Path) -> Result<Outcome<ParetoSummary>, StudyError> {
    let name = file.display().to_string();
    let input = |key: &str, msg: String| StudyError::Input { file: name.clone(), key: key.into(), msg };
    let (spec, base) = read_study(file, &input, |s: &ParetoFile| (s.case.clone(), s.output.clone(), s.set.clone()))?;
    if spec.reference.is_empty() {
        return Err(input("reference", "give the converged setting: [{ key = ..., value = ... }]".into()));
    }
    let sweep = SweepFile {
        case: spec.case,
        output: spec.output,
        set: None,
        sampling: None,
        samples: None,
        seed: None,
        vary: spec.vary,
    };
    let grid_runs = grid(&sweep, &base.table, &input)?;
    let mut runs: Vec<Vec<(String, toml::Value)>> =
        vec![spec.reference.iter().map(|s| (s.key.clone(), s.value.clone())).collect()];
    runs.extend(grid_runs.iter().map(|r| sweep.vary.iter().map(|v| v.key.clone()).zip(r.iter().cloned()).collect()));
    let cases = write_cases(&base, &runs, &input)?;
    let (ran, skipped) = match execute(&cases, exec, exe, &base.out, file)? {
        Executed::Ran { ran, skipped } => (ran, skipped),
        Executed::Submitted(job) => return Ok(Outcome::Submitted(job)),
    };
    let figures: Vec<Vec<(String, String)>> =
        (0..runs.len()).map(|i| read_figures(&figures_path(&base.out, i)).unwrap_or_default()).collect();
    let number =
        |f: &[(String, String)], n: &str| f.iter().find(|(k, _)| k == n).and_then(|(_, v)| v.parse::<f64>().ok());
    let depths: Vec<(String, f64)> = figures[0]
        .iter()
        .filter(|(k, _)| k.ends_with("max_depth"))
        .filter_map(|(k, v)| v.parse::<f64>().ok().map(|x| (k.clone(), x)))
        .collect();
    let mut points: Vec<Point> = (1..runs.len())
        .map(|i| {
            let error = (!depths.is_empty())
                .then(|| {
                    depths
                        .iter()
                        .map(|(k, r)| number(&figures[i], k).map(|x| ((x - r) / r).abs()))
                        .try_fold(0.0_f64, |a, e| e.map(|e| a.max(e)))
                })
                .flatten();
            let settings: Vec<String> = runs[i].iter().map(|(k, v)| format!("{k} = {v}")).collect();
            Point { run: i, settings: settings.join("; "), wall_s: number(&figures[i], "wall_s"), error, front: false }
        })
        .collect();
    let measured: Vec<usize> =
        (0..points.len()).filter(|&i| points[i].wall_s.is_some() && points[i].error.is_some()).collect();
    let pairs: Vec<(f64, f64)> =
        measured.iter().map(|&i| (points[i].wall_s.unwrap_or_default(), points[i].error.unwrap_or_default())).collect();
    for (&i, on) in measured.iter().zip(pareto_front(&pairs)) {
        points[i].front = on;
    }
    let table = write_table(&base.out, &points)?;
    chart(&base.out, &points);
    let reference_wall_s = number(&figures[0], "wall_s");
    Ok(Outcome::Gathered(ParetoSummary { runs: runs.len(), ran, skipped, points, reference_wall_s, table }))
}

fn write_table(out: &Path, points: &[Point]) -> Result<PathBuf, StudyError> {
    let opt = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or_else(|| "-".to_string(), f);
    let line = |p: &Point| {
        vec![
            p.run.to_string(),
            p.settings.clone(),
            opt(p.wall_s, &|x| format!("{x:.2}")),
            opt(p.error, &|x| format!("{x:.3e}")),
            if p.front { "yes".into() } else { String::new() },
        ]
    };
    let header: Vec<String> = ["run", "settings", "wall_s", "error", "front"].iter().map(|h| h.to_string()).collect();
    let rows: Vec<Vec<String>> = points.iter().map(line).collect();
    super::study::write_table(out, "pareto", &header, &rows)
}

/// `pareto.png`: log10 error against wall time, every run, the front joined.
fn chart(out: &Path, points: &[Point]) {
    use mortex::io::plot::{write_xy_png, Series};
    let xy = |p: &Point| Some((p.wall_s?, p.error.filter(|e| *e > 0.0)?.log10()));
    let all: Vec<(f64, f64)> = points.iter().filter_map(xy).collect();
    let front: Vec<(f64, f64)> = points.iter().filter(|p| p.front).filter_map(xy).collect();
    if all.is_empty() {
        return;
    }
    let series = vec![
        Series { label: "runs".into(), points: all, joined: false },
        Series { label: "Pareto front".into(), points: front, joined: true },
    ];
    let panel = (
        "error against wall time".to_string(),
        "wall time (s)".to_string(),
        "log10 relative error of the largest depth".to_string(),
        series,
    );
    if let Err(e) = write_xy_png(&[panel], &out.join("pareto.png")) {
        tracing::warn!(error = %e, "Pareto chart not drawn");
    }
}

pub(crate) fn study_pareto(file: &std::path::Path, exec: super::study::Execution) -> anyhow::Result<()> {
    let s = match pareto(file, &exec, &super::study::study_exe()?)? {
        super::study::Outcome::Gathered(s) => s,
        super::study::Outcome::Submitted(job) => {
            super::study::report_submitted(file, &job);
            return Ok(());
        }
    };
    println!("{}: {} runs: {} run now, {} done before", file.display(), s.runs, s.ran, s.skipped);
    if let Some(w) = s.reference_wall_s {
        println!("  reference: {w:.2} s");
    }
    let mut front: Vec<&Point> = s.points.iter().filter(|p| p.front).collect();
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
        return Err(anyhow::anyhow!("{missing} runs without an error: a run failed (see its run.log)"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::pareto_front;

    /// The front of a small set by hand: (1, 0.5) and (2, 0.1) and (4, 0.01) are on it; (3, 0.2)
    /// is beaten by (2, 0.1); (4, 0.5) by (1, 0.5).
    #[test]
    fn pareto_front_by_hand() {
        let pts = [(1.0, 0.5), (2.0, 0.1), (3.0, 0.2), (4.0, 0.01), (4.0, 0.5)];
        assert_eq!(pareto_front(&pts), vec![true, true, false, true, false]);
    }
}
