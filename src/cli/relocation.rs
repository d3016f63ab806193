//! `mortex study relocation`: node relocation (the ALE practice of commercial wear codes)
//! against the MorteX virtual surface on one wear case (see [`mortex::relocation`]).
//!
//! ```toml
//! case = "../sliding_wear_deep.toml"   # a case wearing a real boundary (relative to this file)
//! output = "results/relocation"        # default: results/<study file stem>
//! cycles_per_update = 1                # the explicit jump of both runs (default 1)
//! layers = [1, 4]                      # relocation domains besides the whole body (cell layers)
//! ```
//!
//! Writes `<output>/relocation.csv` (per method and wear update: depth, its error against the
//! virtual surface, profile error, worn area, peak pressure, mesh quality), `relocation.md`
//! (per method: time, where it failed, where it first parts from the virtual surface by 2% and
//! 10%) and `relocation.png`.

use super::study::{io_err, StudyError};
use mortex::relocation::{run_relocated, run_virtual, RelocationCase, RelocationParams, WearSnapshot};
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RelocationFile {
    case: PathBuf,
    output: Option<PathBuf>,
    cycles_per_update: Option<u64>,
    #[serde(default)]
    layers: Vec<usize>,
}

/// One method's run: its label, snapshots, failure and wall time.
struct MethodRun {
    label: String,
    snapshots: Vec<WearSnapshot>,
    failure: Option<String>,
    seconds: f64,
}

fn max_depth(s: &WearSnapshot) -> f64 {
    s.depth.iter().copied().fold(0.0, f64::max)
}

/// Relative L2 difference of two depth profiles over the same vertices.
fn profile_error(a: &WearSnapshot, reference: &WearSnapshot) -> f64 {
    let num: f64 = a.depth.iter().zip(&reference.depth).map(|(x, y)| (x - y).powi(2)).sum();
    let den: f64 = reference.depth.iter().map(|y| y * y).sum();
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        0.0
    }
}

/// Relative L2 difference of two pressure profiles over the same contact rows.
fn pressure_error(a: &WearSnapshot, reference: &WearSnapshot) -> f64 {
    let num: f64 = a.pressure.iter().zip(&reference.pressure).map(|(x, y)| (x - y).powi(2)).sum();
    let den: f64 = reference.pressure.iter().map(|y| y * y).sum();
    if den > 0.0 && a.pressure.len() == reference.pressure.len() {
        (num / den).sqrt()
    } else {
        f64::NAN
    }
}

/// Runs the study; returns the path of its Markdown table.
pub fn relocation(file: &Path) -> Result<PathBuf, StudyError> {
    let name = file.display().to_string();
    let input = |key: &str, msg: String| StudyError::Input { file: name.clone(), key: key.into(), msg };
    let text = std::fs::read_to_string(file).map_err(io_err(file))?;
    let spec: RelocationFile = toml::from_str(&text).map_err(|e| input("toml", e.to_string()))?;
    let dir = file.parent().unwrap_or(Path::new("."));
    let case_path = dir.join(&spec.case);
    let dn = spec.cycles_per_update.unwrap_or(1);
    if dn == 0 {
        return Err(input("cycles_per_update", "must be at least 1".into()));
    }
    if let Some(&l) = spec.layers.iter().find(|&&l| l == 0) {
        return Err(input("layers", format!("{l}: a relocation domain has at least one cell layer")));
    }
    let case_text = std::fs::read_to_string(&case_path).map_err(io_err(&case_path))?;
    let case_name = case_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let case_dir = case_path.parent().unwrap_or(Path::new("."));
    let case = RelocationCase::new(&case_text, &case_path.display().to_string(), case_dir, &case_name)
        .map_err(|e| input("case", e.to_string()))?;
    let out = spec.output.clone().unwrap_or_else(|| {
        PathBuf::from("results").join(file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default())
    });
    std::fs::create_dir_all(&out).map_err(io_err(&out))?;

    // Runs ended, out of the virtual surface and each relocation domain (on a terminal only).
    let bar = indicatif::ProgressBar::new(1 + 1 + spec.layers.len() as u64);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} run {pos}/{len} {msg}")
    {
        bar.set_style(style);
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar.set_message("virtual surface");
    let run_err = |e: mortex::relocation::RelocationError| StudyError::Io {
        path: case_path.display().to_string(),
        msg: e.to_string(),
    };
    let t = Instant::now();
    let reference = run_virtual(&case, RelocationParams { cycles_per_update: dn, layers: None }).map_err(run_err)?;
    let mut runs = vec![MethodRun {
        label: "virtual surface".into(),
        snapshots: reference,
        failure: None,
        seconds: t.elapsed().as_secs_f64(),
    }];
    tracing::info!(seconds = runs[0].seconds, "virtual surface run done");
    let domains: Vec<Option<usize>> = std::iter::once(None).chain(spec.layers.iter().map(|&l| Some(l))).collect();
    for layers in domains {
        bar.inc(1);
        bar.set_message(format!("relocation, {}", layers.map_or("whole body".into(), |l| format!("{l} layers"))));
        let t = Instant::now();
        let (snapshots, failure) =
            run_relocated(&case, RelocationParams { cycles_per_update: dn, layers }).map_err(run_err)?;
        let label = match layers {
            None => "relocation (whole body)".to_string(),
            Some(l) => format!("relocation ({l} layer{})", if l == 1 { "" } else { "s" }),
        };
        tracing::info!(%label, seconds = t.elapsed().as_secs_f64(), ?failure, "relocation run done");
        runs.push(MethodRun { label, snapshots, failure, seconds: t.elapsed().as_secs_f64() });
    }
    bar.finish_and_clear();
    write_csv(&out, &runs)?;
    chart(&out, &runs);
    write_summary(&out, file, &case_path, case.cell_size(), &runs)
}

/// The virtual surface's snapshot at `cycle`.
fn reference_at(runs: &[MethodRun], cycle: u64) -> Option<&WearSnapshot> {
    runs[0].snapshots.iter().find(|s| s.cycle == cycle)
}

fn write_csv(out: &Path, runs: &[MethodRun]) -> Result<(), StudyError> {
    let mut csv = String::from(
        "method,cycle,max_depth,depth_error,profile_error,pressure_error,worn_area,peak_pressure,min_scaled_jacobian,min_jacobian_ratio\n",
    );
    for r in runs {
        for s in &r.snapshots {
            let (de, pe, qe) = reference_at(runs, s.cycle)
                .map(|v| (max_depth(s) / max_depth(v) - 1.0, profile_error(s, v), pressure_error(s, v)))
                .unwrap_or((f64::NAN, f64::NAN, f64::NAN));
            let (qs, qr) = s.quality.map_or((String::new(), String::new()), |q| {
                (format!("{:.6}", q.min_scaled_jacobian), format!("{:.6}", q.min_jacobian_ratio))
            });
            let _ = writeln!(
                csv,
                "{},{},{:.9e},{:.6e},{:.6e},{:.6e},{:.9e},{:.6e},{qs},{qr}",
                r.label,
                s.cycle,
                max_depth(s),
                de,
                pe,
                qe,
                s.worn_area,
                s.peak_pressure
            );
        }
    }
    let path = out.join("relocation.csv");
    std::fs::write(&path, csv).map_err(io_err(&path))
}

/// First snapshot of a relocation run whose depth or profile parts from the virtual surface's
/// by more than `tol`.
fn first_parting(r: &MethodRun, runs: &[MethodRun], tol: f64) -> Option<(u64, f64)> {
    r.snapshots.iter().find_map(|s| {
        let v = reference_at(runs, s.cycle)?;
        let e = (max_depth(s) / max_depth(v) - 1.0).abs().max(profile_error(s, v));
        (e > tol).then_some((s.cycle, max_depth(v)))
    })
}

fn write_summary(out: &Path, file: &Path, case: &Path, h: f64, runs: &[MethodRun]) -> Result<PathBuf, StudyError> {
    let mut md = format!(
        "# Node relocation against the virtual surface\n\nStudy `{}` on case `{}`; h = {h:.4} (the smallest \
         edge of the cells along the worn boundary). Errors are against the virtual surface at the same \
         cycle: largest depth, depth profile (relative L2) and the pressure at the end of the cycle \
         (relative L2).\n\n\
         | method | wall time (s) | cycles | max depth (mm) | depth / h | largest depth, profile, pressure error while depth < 0.1 h | depth or profile parts by 2% at | by 10% at | pressure error at the end | min Jacobian ratio | failure |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
        file.display(),
        case.display()
    );
    for r in runs {
        let last = r.snapshots.last();
        let pairs: Vec<(&WearSnapshot, &WearSnapshot)> =
            r.snapshots.iter().filter_map(|s| reference_at(runs, s.cycle).map(|v| (s, v))).collect();
        let shallow = pairs.iter().filter(|(_, v)| max_depth(v) < 0.1 * h);
        let worst = |f: &dyn Fn(&WearSnapshot, &WearSnapshot) -> f64| {
            shallow.clone().map(|(s, v)| f(s, v)).filter(|e| e.is_finite()).fold(0.0, f64::max)
        };
        let relocated = r.snapshots.first().is_some_and(|s| s.quality.is_some());
        let shallow_errors = if relocated {
            format!(
                "{:.2}%, {:.2}%, {:.2}%",
                100.0 * worst(&|s, v| (max_depth(s) / max_depth(v) - 1.0).abs()),
                100.0 * worst(&|s, v| profile_error(s, v)),
                100.0 * worst(&|s, v| pressure_error(s, v))
            )
        } else {
            "-".into()
        };
        let at = |tol: f64| {
            if !relocated {
                return "-".to_string();
            }
            first_parting(r, runs, tol).map_or("never".into(), |(c, d)| format!("cycle {c} ({d:.4} mm)"))
        };
        let end_pressure = match pairs.last() {
            Some((s, v)) if relocated => format!("{:.1}%", 100.0 * pressure_error(s, v)),
            _ => "-".into(),
        };
        let quality = last.and_then(|s| s.quality).map_or("-".to_string(), |q| format!("{:.3}", q.min_jacobian_ratio));
        let _ = writeln!(
            md,
            "| {} | {:.2} | {} | {:.4} | {:.2} | {shallow_errors} | {} | {} | {end_pressure} | {quality} | {} |",
            r.label,
            r.seconds,
            last.map_or(0, |s| s.cycle),
            last.map_or(0.0, max_depth),
            last.map_or(0.0, max_depth) / h,
            at(0.02),
            at(0.10),
            r.failure.as_deref().unwrap_or("none"),
        );
    }
    let path = out.join("relocation.md");
    std::fs::write(&path, md).map_err(io_err(&path))?;
    Ok(path)
}

/// `relocation.png`: largest depth against cycles; against the depth, the relocated runs' depth
/// error, pressure error and smallest Jacobian ratio.
fn chart(out: &Path, runs: &[MethodRun]) {
    use mortex::io::plot::{write_xy_png, Series};
    let series = |f: &dyn Fn(&WearSnapshot) -> Option<(f64, f64)>, all: bool| -> Vec<Series> {
        runs.iter()
            .filter(|r| all || r.snapshots.first().is_some_and(|s| s.quality.is_some()))
            .map(|r| Series {
                label: r.label.clone(),
                points: r.snapshots.iter().filter_map(f).collect(),
                joined: true,
            })
            .collect()
    };
    // The virtual surface last, so that each relocation run keeps its colour in every panel.
    let mut depth = series(&|s| Some((s.cycle as f64, 1e3 * max_depth(s))), true);
    depth.rotate_left(1);
    let error = series(
        &|s| reference_at(runs, s.cycle).map(|v| (1e3 * max_depth(v), 100.0 * (max_depth(s) / max_depth(v) - 1.0))),
        false,
    );
    let pressure =
        series(&|s| reference_at(runs, s.cycle).map(|v| (1e3 * max_depth(v), 100.0 * pressure_error(s, v))), false);
    let ratio = series(&|s| s.quality.map(|q| (1e3 * max_depth(s), q.min_jacobian_ratio)), false);
    let panels = vec![
        ("largest wear depth".to_string(), "cycles".to_string(), "depth (um)".to_string(), depth),
        (
            "relocated depth against the virtual surface".to_string(),
            "virtual-surface depth (um)".to_string(),
            "depth error (%)".to_string(),
            error,
        ),
        (
            "relocated pressure at the end of each cycle against the virtual surface".to_string(),
            "virtual-surface depth (um)".to_string(),
            "pressure error, relative L2 (%)".to_string(),
            pressure,
        ),
        (
            "relocated mesh: smallest corner Jacobian / its initial value".to_string(),
            "depth (um)".to_string(),
            "Jacobian ratio".to_string(),
            ratio,
        ),
    ];
    if let Err(e) = write_xy_png(&panels, &out.join("relocation.png")) {
        tracing::warn!(error = %e, "relocation chart not drawn");
    }
}
