//! The equivalent plastic strain of a body as a PNG image (`mortex plot --plastic`): its cells
//! around the plastic zone in the reference configuration, each filled by the colour of its
//! cell average (`/steps/NNNNNN/<body>/cell_eqps`), cells the worn surface has cut away left
//! blank, the worn surface of the step on top, and a colour bar.

use super::plot::{register_font, PlotError};
use plotters::prelude::*;
use std::path::Path;

/// Viridis at five stops, interpolated linearly.
fn colour(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] =
        [(68.0, 1.0, 84.0), (59.0, 82.0, 139.0), (33.0, 145.0, 140.0), (94.0, 201.0, 98.0), (253.0, 231.0, 37.0)];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let s = t * (STOPS.len() - 1) as f64;
    let i = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    let mix = |a: f64, b: f64| (a + f * (b - a)).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// What the picture shows, read from the result file.
struct PlasticField {
    body: String,
    step: usize,
    nodes: Vec<(f64, f64)>,
    cells: Vec<Vec<usize>>,
    eqps: Vec<f64>,
    fraction: Vec<f64>,
    /// The body's worn surfaces at the step's wear row (reference configuration).
    surfaces: Vec<Vec<(f64, f64)>>,
}

fn read_field(path: &Path, body: Option<&str>, step: Option<usize>) -> Result<PlasticField, PlotError> {
    let err = |msg: String| PlotError::Input { path: path.display().to_string(), msg };
    let file = hdf5::File::open(path).map_err(|e| err(format!("cannot open: {e}")))?;
    let steps = file.group("steps").map_err(|_| err("no full-field steps (/steps)".into()))?;
    let mut names: Vec<String> = steps.member_names().map_err(|e| err(e.to_string()))?;
    names.sort();
    let name = match step {
        Some(k) => format!("{k:06}"),
        None => names.last().cloned().ok_or_else(|| err("no full-field steps (/steps)".into()))?,
    };
    let g =
        steps.group(&name).map_err(|_| err(format!("step {name} has no full fields (steps with them: {names:?})")))?;
    let read_eqps = |b: &str| g.dataset(&format!("{b}/cell_eqps")).and_then(|d| d.read_raw::<f64>());
    let mesh = file.group("mesh").map_err(|e| err(e.to_string()))?;
    let bodies: Vec<String> = mesh
        .groups()
        .map_err(|e| err(e.to_string()))?
        .iter()
        .map(|b| b.name().rsplit('/').next().unwrap_or_default().to_string())
        .filter(|b| g.dataset(&format!("{b}/cell_eqps")).is_ok())
        .collect();
    let body = match body {
        Some(b) if bodies.iter().any(|x| x == b) => b.to_string(),
        Some(b) => return Err(err(format!("no body '{b}' with cell_eqps at step {name} (bodies: {bodies:?})"))),
        // The body that yielded most.
        None => bodies
            .iter()
            .map(|b| (b, read_eqps(b).map(|v| v.iter().fold(0.0_f64, |a, &x| a.max(x))).unwrap_or(0.0)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(b, _)| b.clone())
            .ok_or_else(|| err(format!("no body with cell_eqps at step {name}")))?,
    };
    let eqps = read_eqps(&body).map_err(|e| err(format!("{body}/cell_eqps: {e}")))?;
    let fraction: Vec<f64> = g
        .dataset(&format!("{body}/material_fraction"))
        .and_then(|d| d.read_raw())
        .unwrap_or_else(|_| vec![1.0; eqps.len()]);
    let xy: ndarray::Array2<f64> =
        mesh.dataset(&format!("{body}/nodes")).and_then(|d| d.read_2d()).map_err(|e| err(e.to_string()))?;
    let cells: ndarray::Array2<i64> =
        mesh.dataset(&format!("{body}/cells")).and_then(|d| d.read_2d()).map_err(|e| err(e.to_string()))?;
    if cells.nrows() != eqps.len() || fraction.len() != eqps.len() {
        return Err(err(format!("{body}: {} cells but {} cell values", cells.nrows(), eqps.len())));
    }
    let nodes: Vec<(f64, f64)> = xy.rows().into_iter().map(|r| (r[0], r[1])).collect();
    let cells: Vec<Vec<usize>> = cells
        .rows()
        .into_iter()
        .map(|r| r.iter().filter(|&&n| n >= 0 && (n as usize) < nodes.len()).map(|&n| n as usize).collect())
        .collect();
    let step: usize = name.parse().map_err(|_| err(format!("step group {name} is not a step number")))?;
    let surfaces = worn_surfaces(&file, &body, step);
    Ok(PlasticField { body, step, nodes, cells, eqps, fraction, surfaces })
}

/// The worn surfaces of `body` (wear groups named `<body>.<surface>`) at the last wear row
/// written at or before `step` (none in a run without wear).
fn worn_surfaces(file: &hdf5::File, body: &str, step: usize) -> Vec<Vec<(f64, f64)>> {
    let Ok(wear) = file.group("wear") else {
        return vec![];
    };
    let rows: Vec<u64> = wear.dataset("step").and_then(|d| d.read_raw()).unwrap_or_default();
    let Some(row) = rows.iter().rposition(|&s| s as usize <= step) else {
        return vec![];
    };
    let prefix = format!("{body}.");
    let names: Vec<String> = wear.member_names().unwrap_or_default();
    names
        .iter()
        .filter(|n| n.starts_with(&prefix))
        .filter_map(|n| wear.dataset(&format!("{n}/vertices")).and_then(|d| d.read::<f64, ndarray::Ix3>()).ok())
        .filter(|v| row < v.shape()[0])
        .map(|v| (0..v.shape()[1]).map(|i| (v[[row, i, 0]], v[[row, i, 1]])).collect())
        .collect()
}

/// Draws the picture; returns the step drawn and the largest cell value.
pub fn write_plastic_png(
    path: &Path,
    body: Option<&str>,
    step: Option<usize>,
    out: &Path,
) -> Result<(usize, f64), PlotError> {
    register_font()?;
    let f = read_field(path, body, step)?;
    let top = f.eqps.iter().fold(0.0_f64, |a, &b| a.max(b));
    if top <= 0.0 || !top.is_finite() {
        return Err(PlotError::Input {
            path: path.display().to_string(),
            msg: format!("body '{}' has no plastic strain at step {}", f.body, f.step),
        });
    }
    // Window: the cells above 2% of the largest value, widened by half their size each way.
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for (c, &e) in f.cells.iter().zip(&f.eqps) {
        if e >= 0.02 * top {
            for &n in c {
                let (x, y) = f.nodes[n];
                (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
            }
        }
    }
    let (w, h) = ((x1 - x0).max(1e-12), (y1 - y0).max(1e-12));
    let (x0, x1, y0, y1) = (x0 - 0.5 * w, x1 + 0.5 * w, y0 - 0.5 * h, y1 + 0.25 * h);
    let height = ((900.0 * (y1 - y0) / (x1 - x0)).round() as u32).clamp(300, 900);
    let de = |e: &dyn std::fmt::Display| PlotError::Draw { path: out.display().to_string(), msg: e.to_string() };
    let root = BitMapBackend::new(out, (1100, height + 80)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| de(&e))?;
    let (left, right) = root.split_horizontally(960);
    let mut ch = ChartBuilder::on(&left)
        .caption(format!("equivalent plastic strain of '{}', step {}", f.body, f.step), ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(72)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| de(&e))?;
    ch.configure_mesh().x_desc("x (mm, reference)").y_desc("y (mm)").disable_mesh().draw().map_err(|e| de(&e))?;
    let inside =
        |c: &Vec<usize>| c.iter().any(|&n| (x0..=x1).contains(&f.nodes[n].0) && (y0..=y1).contains(&f.nodes[n].1));
    let shown = f.cells.iter().zip(f.eqps.iter().zip(&f.fraction)).filter(|(c, (_, &m))| m > 0.0 && inside(c));
    ch.draw_series(
        shown.map(|(c, (&e, _))| {
            Polygon::new(c.iter().map(|&n| f.nodes[n]).collect::<Vec<_>>(), colour(e / top).filled())
        }),
    )
    .map_err(|e| de(&e))?;
    for s in &f.surfaces {
        ch.draw_series(LineSeries::new(s.iter().copied(), RED.stroke_width(2))).map_err(|e| de(&e))?;
    }
    // Colour bar.
    let mut bar = ChartBuilder::on(&right)
        .margin_top(44)
        .margin_bottom(48)
        .margin_right(8)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..1.0, 0.0..top)
        .map_err(|e| de(&e))?;
    bar.configure_mesh()
        .disable_x_axis()
        .disable_mesh()
        .y_label_style(("sans-serif", 13))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .draw()
        .map_err(|e| de(&e))?;
    let n = 100;
    bar.draw_series((0..n).map(|k| {
        let (a, b) = (top * k as f64 / n as f64, top * (k + 1) as f64 / n as f64);
        Rectangle::new([(0.0, a), (1.0, b)], colour((k as f64 + 0.5) / n as f64).filled())
    }))
    .map_err(|e| de(&e))?;
    root.present().map_err(|e| de(&e))?;
    Ok((f.step, top))
}
