//! `mortex study convergence`: a case refined one knob at a time (the increments per cycle, a
//! mesh's divisions, the cycle jump's depth fraction, ...), each knob's finest value the
//! reference of its runs; the errors of each surface's largest depth and worn area, the
//! relative L2 distance of its final depth profile from the reference's (interpolated at the
//! run's vertices, so meshes may differ), that of the contact pressure at the stroke positions
//! of the last cycle (a cyclic run with one contact pair), their observed orders, and a log-log
//! chart.
//!
//! ```toml
//! case = "wear_cases/mccoll_fretting.toml"
//! output = "results/mccoll_convergence"
//! [[knob]]
//! key = "steps.increments"
//! values = [4, 8, 16, 32]     # coarse to fine: the last is the reference
//! size = "inverse"            # the step size h ~ 1 / value; "direct": h ~ value
//! ```
//!
//! The runs are those of a sweep (`<output>/run_<i>/`, a process each, resumable); the table
//! is `<output>/convergence.csv` and `.md`, the chart `convergence.png`. The observed order
//! between two runs `a`, `b` is `ln(e_a / e_b) / ln(h_a / h_b)`.

use super::study::{
    execute, figures_path, read_figures, read_study, write_cases, Executed, Execution, Outcome, StudyError,
};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ConvergenceFile {
    case: PathBuf,
    output: Option<PathBuf>,
    /// Keys set in every run (the study's base case).
    set: Option<toml::Table>,
    knob: Vec<Knob>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Knob {
    key: String,
    values: Vec<toml::Value>,
    size: Option<String>,
}

/// One row of the table: a knob's value, its step size, a figure, its result, its error
/// against the knob's finest run and the order observed from the previous value.
#[derive(Debug, Clone)]
pub struct Row {
    pub knob: String,
    pub value: String,
    pub h: f64,
    pub figure: String,
    pub result: Option<f64>,
    pub error: Option<f64>,
    pub order: Option<f64>,
}

/// What a convergence study did: runs, run now, found done; its rows; the table's path.
pub struct ConvergenceSummary {
    pub runs: usize,
    pub ran: usize,
    pub skipped: usize,
    pub rows: Vec<Row>,
    pub table: PathBuf,
}

/// Observed order between errors `e_a` at step size `h_a` and `e_b` at `h_b`.
pub fn observed_order(e_a: f64, h_a: f64, e_b: f64, h_b: f64) -> Option<f64> {
    (e_a > 0.0 && e_b > 0.0 && h_a > 0.0 && h_b > 0.0 && h_a != h_b).then(|| (e_a / e_b).ln() / (h_a / h_b).ln())
}

/// Runs the convergence study in `file`, `parallel` runs at once.
pub fn convergence(file: &Path, exec: &Execution, exe: &Path) -> Result<Outcome<ConvergenceSummary>, StudyError> {
    let name = file.display().to_string();
    let input = |key: &str, msg: String| StudyError::Input { file: name.clone(), key: key.into(), msg };
    let (spec, base) =
        read_study(file, &input, |s: &ConvergenceFile| (s.case.clone(), s.output.clone(), s.set.clone()))?;
    if spec.knob.is_empty() {
        return Err(input("knob", "nothing to refine: give at least one [[knob]] with a key and values".into()));
    }
    // Step sizes per knob, coarse to fine.
    let mut sizes: Vec<Vec<f64>> = Vec::with_capacity(spec.knob.len());
    let mut runs: Vec<Vec<(String, toml::Value)>> = Vec::new();
    for (j, k) in spec.knob.iter().enumerate() {
        let key = |s: &str| format!("knob[{j}].{s}");
        let inverse = match k.size.as_deref() {
            None | Some("inverse") => true,
            Some("direct") => false,
            Some(other) => return Err(input(&key("size"), format!("'{other}': use \"inverse\" or \"direct\""))),
        };
        let numbers: Option<Vec<f64>> = k.values.iter().map(super::study::toml_number).collect();
        let Some(numbers) = numbers.filter(|v| v.len() >= 2) else {
            return Err(input(&key("values"), "give at least two numbers, coarse to fine".into()));
        };
        let h: Vec<f64> = numbers.iter().map(|&v| if inverse { 1.0 / v } else { v }).collect();
        if h.iter().any(|x| !x.is_finite() || *x <= 0.0) || h.windows(2).any(|w| w[1] >= w[0]) {
            return Err(input(
                &key("values"),
                format!(
                    "{numbers:?}: the step sizes must be positive and shrink from coarse to fine (size = {})",
                    if inverse { "inverse" } else { "direct" }
                ),
            ));
        }
        sizes.push(h);
        runs.extend(k.values.iter().map(|v| vec![(k.key.clone(), v.clone())]));
    }
    let cases = write_cases(&base, &runs, &input)?;
    let (ran, skipped) = match execute(&cases, exec, exe, &base.out, file)? {
        Executed::Ran { ran, skipped } => (ran, skipped),
        Executed::Submitted(job) => return Ok(Outcome::Submitted(job)),
    };
    let figures: Vec<Vec<(String, String)>> =
        (0..runs.len()).map(|i| read_figures(&figures_path(&base.out, i)).unwrap_or_default()).collect();
    let mut rows = rows(&spec.knob, &sizes, &figures);
    let results: Vec<PathBuf> =
        (0..runs.len()).map(|i| figures_path(&base.out, i).with_file_name("result.h5")).collect();
    rows.extend(profile_rows(&spec.knob, &sizes, &results));
    rows.extend(pressure_rows(&spec.knob, &sizes, &results));
    let table = write_table(&base.out, &rows)?;
    chart(&base.out, &spec.knob, &rows);
    Ok(Outcome::Gathered(ConvergenceSummary { runs: runs.len(), ran, skipped, rows, table }))
}

/// The table's rows: per knob, per figure (largest depth and worn area of each surface), per
/// value; the knob's last value is its reference. The depth profiles' rows follow
/// ([`profile_rows`]).
fn rows(knobs: &[Knob], sizes: &[Vec<f64>], figures: &[Vec<(String, String)>]) -> Vec<Row> {
    let mut names: Vec<String> = Vec::new();
    for f in figures {
        for (n, _) in f.iter().filter(|(n, _)| n.ends_with("max_depth") || n.ends_with("worn_area")) {
            if !names.contains(n) {
                names.push(n.clone());
            }
        }
    }
    let mut out = Vec::new();
    let mut first = 0;
    for (k, h) in knobs.iter().zip(sizes) {
        let runs = &figures[first..first + h.len()];
        first += h.len();
        for name in &names {
            let result =
                |f: &[(String, String)]| f.iter().find(|(n, _)| n == name).and_then(|(_, v)| v.parse::<f64>().ok());
            let reference = runs.last().and_then(|f| result(f));
            let per_run: Vec<(Option<f64>, Option<f64>)> = runs
                .iter()
                .map(|f| {
                    let r = result(f);
                    let error = match (r, reference) {
                        (Some(a), Some(b)) if b != 0.0 => Some(((a - b) / b).abs()),
                        _ => None,
                    };
                    (r, error)
                })
                .collect();
            out.extend(knob_rows(k, h, name, &per_run));
        }
    }
    out
}

/// A wearing surface's name, the reference x of its vertices (sorted) and their depths.
type Profile = (String, Vec<f64>, Vec<f64>);

/// Each wearing surface's last depth profile in a result file: reference x of its vertices and
/// depth, in x order (`None` without a wear series).
fn depth_profiles(result: &Path) -> Option<Vec<Profile>> {
    let file = hdf5::File::open(result).ok()?;
    let wear = file.group("wear").ok()?;
    let mut out = Vec::new();
    for g in wear.groups().ok()? {
        let name = g.name().rsplit('/').next().unwrap_or_default().to_string();
        let depth: ndarray::Array2<f64> = g.dataset("depth").and_then(|d| d.read_2d()).ok()?;
        let verts: ndarray::Array3<f64> = g.dataset("vertices").and_then(|d| d.read()).ok()?;
        let last = depth.nrows().checked_sub(1)?;
        let mut pts: Vec<(f64, f64)> = (0..depth.ncols()).map(|i| (verts[[0, i, 0]], depth[[last, i]])).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        out.push((name, pts.iter().map(|p| p.0).collect(), pts.iter().map(|p| p.1).collect()));
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    Some(out)
}

/// Linear interpolation of `(x, y)` (x sorted) at `at`, constant beyond the ends.
fn interpolate(x: &[f64], y: &[f64], at: f64) -> f64 {
    let k = x.partition_point(|&v| v < at);
    if k == 0 {
        return y[0];
    }
    if k == x.len() {
        return y[x.len() - 1];
    }
    if x[k] == at {
        return y[k];
    }
    let t = (at - x[k - 1]) / (x[k] - x[k - 1]);
    y[k - 1] + t * (y[k] - y[k - 1])
}

/// Relative L2 distance (trapezoidal in x) of a depth profile from the reference profile,
/// the reference interpolated at the profile's vertices; and the profile's own L2 norm.
fn profile_distance(x: &[f64], d: &[f64], rx: &[f64], rd: &[f64]) -> (f64, f64) {
    let (mut diff, mut norm, mut own) = (0.0, 0.0, 0.0);
    for i in 0..x.len() {
        let w = 0.5 * (x[(i + 1).min(x.len() - 1)] - x[i.saturating_sub(1)]);
        let r = interpolate(rx, rd, x[i]);
        diff += w * (d[i] - r).powi(2);
        norm += w * r * r;
        own += w * d[i] * d[i];
    }
    ((diff / norm.max(f64::MIN_POSITIVE)).sqrt(), own.sqrt())
}

/// Rows of the depth profiles (`<surface> depth_profile`): per knob, each run's relative L2
/// distance from the knob's finest run (result: the profile's own L2 norm).
fn profile_rows(knobs: &[Knob], sizes: &[Vec<f64>], results: &[PathBuf]) -> Vec<Row> {
    let mut out = Vec::new();
    let mut first = 0;
    for (k, h) in knobs.iter().zip(sizes) {
        let profiles: Vec<Option<Vec<Profile>>> =
            results[first..first + h.len()].iter().map(|r| depth_profiles(r)).collect();
        first += h.len();
        let Some(Some(reference)) = profiles.last() else { continue };
        for (name, rx, rd) in reference {
            let per_run: Vec<(Option<f64>, Option<f64>)> = profiles
                .iter()
                .map(|p| match p.as_ref().and_then(|p| p.iter().find(|(n, _, _)| n == name)) {
                    Some((_, x, d)) => {
                        let (e, own) = profile_distance(x, d, rx, rd);
                        (Some(own), Some(e))
                    }
                    None => (None, None),
                })
                .collect();
            out.extend(knob_rows(k, h, &format!("{name} depth_profile"), &per_run));
        }
    }
    out
}

/// A pressure profile at one stroke position: its fraction of the cycle, x and pressure.
type StrokePressure = (f64, Vec<f64>, Vec<f64>);

/// The contact pressure of a cyclic run's last recorded cycle (its only contact pair): per
/// increment, its position in the cycle (increment / increments), x and pressure in x order.
/// `None` for a run that is not cyclic, has several pairs, or cannot be read.
fn last_cycle_pressure(result: &Path) -> Option<Vec<StrokePressure>> {
    let (_, profiles) = mortex::io::plot::read_cycle_pressure(result, u64::MAX, None).ok()?;
    let n = profiles.len() as f64;
    Some(profiles.into_iter().map(|(inc, x, p)| (inc as f64 / n, x, p)).collect())
}

/// Rows of the contact pressure (`pressure_profile`): per knob, each run's largest relative L2
/// distance from the knob's finest run over the stroke positions of the last cycle that both
/// record (the same fraction of the cycle; every position of the coarsest increments), the
/// finest run's profile interpolated at the run's multiplier nodes (result: the run's largest
/// pressure over the cycle).
fn pressure_rows(knobs: &[Knob], sizes: &[Vec<f64>], results: &[PathBuf]) -> Vec<Row> {
    let mut out = Vec::new();
    let mut first = 0;
    for (k, h) in knobs.iter().zip(sizes) {
        let cycles: Vec<Option<Vec<StrokePressure>>> =
            results[first..first + h.len()].iter().map(|r| last_cycle_pressure(r)).collect();
        first += h.len();
        let Some(Some(reference)) = cycles.last() else { continue };
        let per_run: Vec<(Option<f64>, Option<f64>)> = cycles
            .iter()
            .map(|c| {
                let c = c.as_ref()?;
                let peak = c.iter().flat_map(|(_, _, p)| p.iter()).fold(0.0_f64, |a, &b| a.max(b));
                let errors: Vec<f64> = c
                    .iter()
                    .filter_map(|(f, x, p)| {
                        let (_, rx, rp) = reference.iter().find(|(rf, _, _)| (rf - f).abs() < 1e-9)?;
                        Some(profile_distance(x, p, rx, rp).0)
                    })
                    .collect();
                let error = (!errors.is_empty()).then(|| errors.iter().fold(0.0_f64, |a, &b| a.max(b)));
                Some((Some(peak), error))
            })
            .map(|r| r.unwrap_or((None, None)))
            .collect();
        out.extend(knob_rows(k, h, "pressure_profile", &per_run));
    }
    out
}

/// The rows of one knob and figure from each run's `(result, error against the reference)`,
/// the last run the reference (error 0 where it has a result), with the order observed from
/// the previous run that had an error.
fn knob_rows(k: &Knob, h: &[f64], figure: &str, per_run: &[(Option<f64>, Option<f64>)]) -> Vec<Row> {
    let mut out = Vec::with_capacity(per_run.len());
    let mut previous: Option<(f64, f64)> = None;
    for (i, &(result, error)) in per_run.iter().enumerate() {
        let is_reference = i + 1 == per_run.len();
        let order = match (previous, error) {
            (Some((e0, h0)), Some(e)) if !is_reference => observed_order(e0, h0, e, h[i]),
            _ => None,
        };
        if let Some(e) = error.filter(|_| !is_reference) {
            previous = Some((e, h[i]));
        }
        out.push(Row {
            knob: k.key.clone(),
            value: k.values[i].to_string(),
            h: h[i],
            figure: figure.to_string(),
            result,
            error: if is_reference { result.map(|_| 0.0) } else { error },
            order,
        });
    }
    out
}

fn write_table(out: &Path, rows: &[Row]) -> Result<PathBuf, StudyError> {
    let opt = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or_else(|| "-".to_string(), f);
    let line = |r: &Row| {
        vec![
            r.knob.clone(),
            r.value.clone(),
            format!("{:e}", r.h),
            r.figure.clone(),
            opt(r.result, &|x| format!("{x:e}")),
            opt(r.error, &|x| format!("{x:.3e}")),
            opt(r.order, &|x| format!("{x:.2}")),
        ]
    };
    let header: Vec<String> =
        ["knob", "value", "h", "figure", "result", "error", "order"].iter().map(|h| h.to_string()).collect();
    let rows: Vec<Vec<String>> = rows.iter().map(line).collect();
    super::study::write_table(out, "convergence", &header, &rows)
}

/// `convergence.png`: per knob, log10 of each figure's error against log10 h (the reference
/// left out: its error is zero).
fn chart(out: &Path, knobs: &[Knob], rows: &[Row]) {
    use mortex::io::plot::{write_xy_png, Series};
    let mut panels = Vec::new();
    for k in knobs {
        let mut series: Vec<Series> = Vec::new();
        for r in rows.iter().filter(|r| r.knob == k.key) {
            let Some(e) = r.error.filter(|e| *e > 0.0) else { continue };
            let point = (r.h.log10(), e.log10());
            match series.iter_mut().find(|s| s.label == r.figure) {
                Some(s) => s.points.push(point),
                None => series.push(Series { label: r.figure.clone(), points: vec![point], joined: true }),
            }
        }
        if !series.is_empty() {
            panels.push((
                format!("error against {}", k.key),
                "log10 h".to_string(),
                "log10 relative error".to_string(),
                series,
            ));
        }
    }
    if panels.is_empty() {
        return;
    }
    if let Err(e) = write_xy_png(&panels, &out.join("convergence.png")) {
        tracing::warn!(error = %e, "convergence chart not drawn");
    }
}

pub(crate) fn study_convergence(file: &std::path::Path, exec: super::study::Execution) -> anyhow::Result<()> {
    let s = match convergence(file, &exec, &super::study::study_exe()?)? {
        super::study::Outcome::Gathered(s) => s,
        super::study::Outcome::Submitted(job) => {
            super::study::report_submitted(file, &job);
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
        return Err(anyhow::anyhow!("{missing} figures missing: a run failed (see its run.log)"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::observed_order;

    /// Errors `C h^2` give order 2, `C h` order 1 (exact up to round-off).
    #[test]
    fn observed_order_of_power_laws() {
        let e = |h: f64, p: f64| 0.3 * h.powf(p);
        for p in [1.0, 2.0, 0.5] {
            let Some(o) = observed_order(e(0.1, p), 0.1, e(0.05, p), 0.05) else { panic!("no order for {p}") };
            assert!((o - p).abs() < 1e-12, "order {o} for {p}");
        }
        assert!(observed_order(0.0, 0.1, 1e-3, 0.05).is_none());
    }
}
