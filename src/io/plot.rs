//! Contact profiles as PNG images (`mortex plot`): pressure, shear traction and the Coulomb
//! bound `mu p`, stick/slip status, the slip of the step and the accumulated slip along the
//! interface, read back from a result file for any output step.
//!
//! Drawn with plotters' bitmap backend (study charts also as SVG); the labels use the DejaVu
//! Sans shipped in `src/io/fonts/` (or the TrueType file `MORTEX_FONT` names).

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("{path}: {msg}")]
    Input { path: String, msg: String },
    #[error("no usable TrueType font for the plot labels ({tried:?}): set MORTEX_FONT to a readable .ttf file, or unset it for the shipped DejaVu Sans")]
    NoFont { tried: Vec<String> },
    #[error("{path}: drawing the plot: {msg}")]
    Draw { path: String, msg: String },
}

/// One contact pair's profile at one output step (multiplier nodes sorted by x).
#[derive(Debug, Clone)]
pub struct ContactProfile {
    pub pair: String,
    pub step: usize,
    pub time: f64,
    pub x: Vec<f64>,
    /// The nodal traction (each node's contact force over its hat's measure; files written
    /// before it was stored: the multiplier's values).
    pub pressure: Vec<f64>,
    /// The multiplier's nodal values `-lambda_n` where they differ from `pressure` (drawn as
    /// points: they undershoot beside a load concentrated between two nodes).
    pub multiplier_pressure: Option<Vec<f64>>,
    /// Friction only: shear (nodal traction, as `pressure`), slip of the step, accumulated
    /// slip, status (0/1/2).
    pub shear: Option<Vec<f64>>,
    pub slip: Option<Vec<f64>>,
    pub accumulated_slip: Option<Vec<f64>>,
    pub status: Option<Vec<u8>>,
    /// Friction coefficient (files written before it was stored: unknown).
    pub mu: Option<f64>,
    /// The case's analytical solution for this pair (`[reference]`), if it gave one.
    pub reference: Option<crate::post::AnalyticContact>,
}

/// The analytical reference a result file holds for `pair` (`/reference`), if any.
fn read_reference(file: &hdf5::File, pair: &str) -> Option<crate::post::AnalyticContact> {
    let g = file.group("reference").ok()?;
    let name: hdf5::types::VarLenUnicode = g.attr("pair").ok()?.read_scalar().ok()?;
    if name.as_str() != pair {
        return None;
    }
    let get = |n: &str| g.attr(n).ok().and_then(|a| a.read_scalar::<f64>().ok());
    Some(crate::post::AnalyticContact {
        p0: get("p0")?,
        a: get("a")?,
        x0: get("x0")?,
        mu: get("mu")?,
        c: get("c"),
        // Files written before the offset and the automatic centre: none, the centre given.
        e: get("e").unwrap_or(0.0),
        centre_from_profile: get("centre_from_profile").is_some_and(|v| v != 0.0),
    })
}

/// The pressure centroid `int p x / int p` of a profile (trapezoidal; `None` without load).
fn pressure_centroid(x: &[f64], p: &[f64]) -> Option<f64> {
    let (mut moment, mut load) = (0.0, 0.0);
    for i in 1..x.len().min(p.len()) {
        let dx = x[i] - x[i - 1];
        load += 0.5 * dx * (p[i] + p[i - 1]);
        moment += 0.5 * dx * (p[i] * x[i] + p[i - 1] * x[i - 1]);
    }
    (load > 0.0).then(|| moment / load)
}

/// Relative L2 deviation of the computed profile from its reference over `|x - x0| < a`
/// (trapezoidal over the nodes): the pressure's, and the shear's magnitude for
/// Cattaneo-Mindlin.
pub fn reference_errors(p: &ContactProfile, r: &crate::post::AnalyticContact) -> (f64, Option<f64>) {
    let inside: Vec<usize> = (0..p.x.len()).filter(|&i| (p.x[i] - r.x0).abs() < r.a).collect();
    let l2 = |computed: &dyn Fn(usize) -> f64, exact: &dyn Fn(f64) -> f64| {
        let (mut num, mut den) = (0.0, 0.0);
        for w in inside.windows(2) {
            let dx = p.x[w[1]] - p.x[w[0]];
            for &i in w {
                num += 0.5 * dx * (computed(i) - exact(p.x[i])).powi(2);
                den += 0.5 * dx * exact(p.x[i]).powi(2);
            }
        }
        if den > 0.0 {
            (num / den).sqrt()
        } else {
            f64::NAN
        }
    };
    let pressure = l2(&|i| p.pressure[i], &|x| r.pressure(x));
    let shear = match (&p.shear, r.c) {
        (Some(q), Some(_)) => Some(l2(&|i| q[i].abs(), &|x| r.shear(x).unwrap_or(0.0))),
        _ => None,
    };
    (pressure, shear)
}

/// Reads the profile of `pair` (the only pair if `None`) at output step `step` (the last one
/// if `None`) from a result file.
pub fn read_profile(path: &Path, step: Option<usize>, pair: Option<&str>) -> Result<ContactProfile, PlotError> {
    let err = |msg: String| PlotError::Input { path: path.display().to_string(), msg };
    let file = hdf5::File::open(path).map_err(|e| err(format!("cannot open: {e}")))?;
    let pairs_group =
        file.group("mesh/contacts").map_err(|_| err("the result holds no contact pair (no /mesh/contacts)".into()))?;
    let pairs = pairs_group.member_names().map_err(|e| err(e.to_string()))?;
    let pair = match pair {
        Some(p) if pairs.iter().any(|q| q == p) => p.to_string(),
        Some(p) => return Err(err(format!("no contact pair '{p}' (pairs: {pairs:?})"))),
        None if pairs.len() == 1 => pairs[0].clone(),
        None => return Err(err(format!("several contact pairs, choose one with --pair: {pairs:?}"))),
    };
    // Every step's contact series is under /series (one row per step).
    let series = file.group("series").map_err(|e| err(format!("no /series group: {e}")))?;
    let steps: Vec<u64> = series.dataset("step").and_then(|d| d.read_raw()).map_err(|e| err(e.to_string()))?;
    let row = match step {
        Some(s) => steps.iter().position(|&k| k as usize == s),
        None => steps.len().checked_sub(1),
    };
    let Some(row) = row else {
        return match step {
            Some(s) => Err(err(match (steps.first(), steps.last()) {
                (Some(a), Some(b)) => format!("no output step {s} (the result holds steps {a} to {b})"),
                _ => format!("no output step {s} (the result holds no step)"),
            })),
            None => Err(err("the result holds no step".into())),
        };
    };
    let step = steps[row] as usize;
    let pg = pairs_group.group(&pair).map_err(|e| err(e.to_string()))?;
    let points: Vec<f64> = pg.dataset("points").and_then(|d| d.read_raw()).map_err(|e| err(e.to_string()))?;
    let mu = pg.attr("mu").and_then(|a| a.read_scalar::<f64>()).ok();
    let times: Vec<f64> = series.dataset("time").and_then(|d| d.read_raw()).map_err(|e| err(e.to_string()))?;
    let time = times.get(row).copied().ok_or_else(|| err("series/time is shorter than series/step".into()))?;
    let cg = series.group(&format!("contacts/{pair}")).map_err(|e| err(format!("no series of pair '{pair}': {e}")))?;
    let row_of = |name: &str| -> Option<Vec<f64>> {
        let d = cg.dataset(name).ok()?;
        let a: ndarray::Array2<f64> = d.read_slice(ndarray::s![row..row + 1, ..]).ok()?;
        Some(a.iter().copied().collect())
    };
    let f64s = row_of;
    let multiplier = f64s("pressure").ok_or_else(|| err(format!("step {step}: no pressure of pair '{pair}'")))?;
    let nodal = f64s("nodal_pressure").filter(|v| v.len() == multiplier.len());
    let (pressure, multiplier) = match nodal {
        Some(p) => (p, Some(multiplier)),
        None => (multiplier, None),
    };
    // Current positions (they move under finite sliding).
    let position: Option<Vec<f64>> = cg
        .dataset("position")
        .ok()
        .and_then(|d| d.read_slice::<f64, _, ndarray::Ix3>(ndarray::s![row..row + 1, .., ..]).ok())
        .map(|a| a.iter().copied().collect());
    let points = position.filter(|p| p.len() == points.len()).unwrap_or(points);
    let n = pressure.len();
    if points.len() != 2 * n {
        return Err(err(format!("pair '{pair}': {} points for {n} pressures", points.len() / 2)));
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| points[2 * a].total_cmp(&points[2 * b]));
    let sorted = |v: Vec<f64>| -> Vec<f64> { order.iter().map(|&i| v[i]).collect() };
    let status: Option<Vec<u8>> = cg
        .dataset("status")
        .ok()
        .and_then(|d| d.read_slice::<u8, _, ndarray::Ix2>(ndarray::s![row..row + 1, ..]).ok())
        .map(|a| a.iter().copied().collect());
    // Frictionless pairs: the shear and slip series are zeros; draw them only with friction.
    let frictional = mu.is_some_and(|m| m > 0.0);
    let x: Vec<f64> = order.iter().map(|&i| points[2 * i]).collect();
    let pressure = sorted(pressure);
    let reference = read_reference(&file, &pair).map(|r| match pressure_centroid(&x, &pressure) {
        Some(x0) if r.centre_from_profile => crate::post::AnalyticContact { x0, ..r },
        _ => r,
    });
    Ok(ContactProfile {
        reference,
        pair,
        step,
        time,
        x,
        pressure,
        multiplier_pressure: multiplier.map(sorted),
        shear: f64s("nodal_shear").or_else(|| f64s("shear")).filter(|_| frictional).map(sorted),
        slip: f64s("slip").filter(|_| frictional).map(sorted),
        accumulated_slip: f64s("accumulated_slip").filter(|_| frictional).map(sorted),
        status: status.filter(|_| frictional).map(|s| order.iter().map(|&i| s[i]).collect()),
        mu,
    })
}

/// DejaVu Sans, shipped with the engine (`src/io/fonts/`, Bitstream Vera licence): charts
/// need no system font.
const SHIPPED_FONT: &[u8] = include_bytes!("fonts/DejaVuSans.ttf");

/// Font for the labels, registered once per process: the TrueType file `MORTEX_FONT` names if
/// set, the shipped DejaVu Sans otherwise.
pub(crate) fn register_font() -> Result<(), PlotError> {
    static FONT: OnceLock<Result<(), Vec<String>>> = OnceLock::new();
    FONT.get_or_init(|| {
        let bytes: &'static [u8] = match std::env::var_os("MORTEX_FONT").map(PathBuf::from) {
            Some(path) => match std::fs::read(&path) {
                // plotters keeps the font for the whole process.
                Ok(bytes) => Box::leak(bytes.into_boxed_slice()),
                Err(_) => return Err(vec![path.display().to_string()]),
            },
            None => SHIPPED_FONT,
        };
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| vec![std::env::var("MORTEX_FONT").unwrap_or_else(|_| "the shipped DejaVu Sans".into())])
    })
    .clone()
    .map_err(|tried| PlotError::NoFont { tried })
}

/// Range of x to draw: the contact zone (nodes pressed or sticking/slipping) widened by half
/// its width on each side, or every node if nothing is in contact.
pub fn default_xlim(p: &ContactProfile) -> (f64, f64) {
    let in_contact: Vec<f64> =
        p.x.iter()
            .enumerate()
            .filter(|&(i, _)| p.pressure[i] > 0.0 || p.status.as_ref().is_some_and(|s| s[i] != 0))
            .map(|(_, &x)| x)
            .collect();
    let (lo, hi) = match (in_contact.first(), in_contact.last()) {
        (Some(&a), Some(&b)) if b > a => (a, b),
        _ => (p.x.first().copied().unwrap_or(-1.0), p.x.last().copied().unwrap_or(1.0)),
    };
    let w = (hi - lo).max(1e-12);
    (lo - 0.5 * w, hi + 0.5 * w)
}

fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.filter(|v| v.is_finite()).fold((0.0f64, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let pad = 0.08 * (hi - lo).max(1e-30);
    (lo - pad, hi + pad)
}

/// The legend box of a panel (upper right).
fn legend<'a, DB: DrawingBackend + 'a>(
    ch: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
) -> Result<(), String> {
    ch.configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| e.to_string())
}

/// The analytical solution `r`, dashed and sampled finely over `xlim`: the pressure, and the
/// Cattaneo-Mindlin shear times `shear_sign` when given.
fn draw_reference<'a, DB: DrawingBackend + 'a>(
    ch: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    r: &crate::post::AnalyticContact,
    xlim: (f64, f64),
    shear_sign: Option<f64>,
) -> Result<(), String> {
    let xs: Vec<f64> = (0..=400).map(|k| xlim.0 + (xlim.1 - xlim.0) * k as f64 / 400.0).collect();
    let name = if r.c.is_some() { "Cattaneo-Mindlin" } else { "Hertz" };
    // (label, colour, points) of each curve.
    type Curve = (String, RGBColor, Vec<(f64, f64)>);
    let mut curves: Vec<Curve> =
        vec![(format!("{name} pressure"), RGBColor(0, 0, 120), xs.iter().map(|&x| (x, r.pressure(x))).collect())];
    if let (Some(sign), Some(_)) = (shear_sign, r.c) {
        let q = xs.iter().map(|&x| (x, sign * r.shear(x).unwrap_or(0.0))).collect();
        curves.push((format!("{name} shear"), RGBColor(140, 0, 0), q));
    }
    for (label, colour, points) in curves {
        ch.draw_series(DashedLineSeries::new(points, 6, 4, colour.stroke_width(1)))
            .map_err(|e| e.to_string())?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    Ok(())
}

/// Draws the profile into a PNG at `out` (1000 x 700; with friction a second panel of slips).
pub fn write_png(p: &ContactProfile, xlim: (f64, f64), out: &Path) -> Result<(), PlotError> {
    register_font()?;
    let draw_err = |e: String| PlotError::Draw { path: out.display().to_string(), msg: e };
    let de = |e: &dyn std::fmt::Display| draw_err(e.to_string());
    let inside: Vec<usize> = (0..p.x.len()).filter(|&i| p.x[i] >= xlim.0 && p.x[i] <= xlim.1).collect();
    let root = BitMapBackend::new(out, (1000, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| de(&e))?;
    let friction = p.shear.is_some();
    let (top, bottom) = if friction { root.split_vertically(430) } else { (root.clone(), root.clone()) };
    let title = format!("contact '{}', step {}, t = {:.6}", p.pair, p.step, p.time);
    // Top panel: pressure, shear, +-mu p.
    let mu_p: Vec<f64> = match p.mu {
        Some(mu) if friction => inside.iter().map(|&i| mu * p.pressure[i]).collect(),
        _ => vec![],
    };
    let shear = p.shear.as_deref().unwrap_or(&[]);
    let yr = span(
        inside
            .iter()
            .map(|&i| p.pressure[i])
            .chain(inside.iter().filter_map(|&i| p.multiplier_pressure.as_ref().map(|m| m[i])))
            .chain(inside.iter().filter_map(|&i| shear.get(i).copied()))
            .chain(mu_p.iter().flat_map(|&v| [v, -v])),
    );
    let mut ch = ChartBuilder::on(&top)
        .caption(&title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(xlim.0..xlim.1, yr.0..yr.1)
        .map_err(|e| de(&e))?;
    ch.configure_mesh().x_desc("x (mm, current)").y_desc("traction (MPa)").draw().map_err(|e| de(&e))?;
    let line = |v: &[f64]| -> Vec<(f64, f64)> { inside.iter().map(|&i| (p.x[i], v[i])).collect() };
    ch.draw_series(LineSeries::new(line(&p.pressure), BLUE.stroke_width(2)))
        .map_err(|e| de(&e))?
        .label("pressure p (nodal traction)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(2)));
    if let Some(m) = &p.multiplier_pressure {
        let dots = inside.iter().map(|&i| Circle::new((p.x[i], m[i]), 2, BLUE.filled()));
        ch.draw_series(dots)
            .map_err(|e| de(&e))?
            .label("multiplier -lambda_n")
            .legend(|(x, y)| Circle::new((x + 10, y), 2, BLUE.filled()));
    }
    if let Some(r) = &p.reference {
        // The computed shear's sign: the reference shear drawn on the same side.
        let shear_sign = friction.then(|| if shear.iter().sum::<f64>() < 0.0 { -1.0 } else { 1.0 });
        draw_reference(&mut ch, r, xlim, shear_sign).map_err(draw_err)?;
    }
    if friction {
        ch.draw_series(LineSeries::new(line(shear), RED.stroke_width(2)))
            .map_err(|e| de(&e))?
            .label("shear q")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
        if !mu_p.is_empty() {
            let grey = RGBColor(120, 120, 120);
            for sign in [1.0, -1.0] {
                let s = ch
                    .draw_series(LineSeries::new(
                        inside.iter().zip(&mu_p).map(|(&i, &m)| (p.x[i], sign * m)),
                        grey.stroke_width(1),
                    ))
                    .map_err(|e| de(&e))?;
                if sign > 0.0 {
                    s.label("+- mu p").legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey));
                }
            }
        }
        if let Some(status) = &p.status {
            let green = RGBColor(0, 150, 0);
            ch.draw_series(
                inside.iter().filter(|&&i| status[i] == 1).map(|&i| Circle::new((p.x[i], shear[i]), 3, green.filled())),
            )
            .map_err(|e| de(&e))?
            .label("stick")
            .legend(move |(x, y)| Circle::new((x + 10, y), 3, green.filled()));
            ch.draw_series(
                inside
                    .iter()
                    .filter(|&&i| status[i] == 2)
                    .map(|&i| TriangleMarker::new((p.x[i], shear[i]), 4, RED.filled())),
            )
            .map_err(|e| de(&e))?
            .label("slip")
            .legend(|(x, y)| TriangleMarker::new((x + 10, y), 4, RED.filled()));
        }
    }
    legend(&mut ch).map_err(|e| de(&e))?;
    // Bottom panel: slip of the step and accumulated slip.
    if let (Some(slip), Some(acc)) = (&p.slip, &p.accumulated_slip) {
        let yr = span(inside.iter().flat_map(|&i| [slip[i], acc[i]]));
        let mut ch = ChartBuilder::on(&bottom)
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .build_cartesian_2d(xlim.0..xlim.1, yr.0..yr.1)
            .map_err(|e| de(&e))?;
        ch.configure_mesh()
            .x_desc("x (mm, current)")
            .y_desc("slip (mm)")
            .y_label_formatter(&|v| if v.abs() < 1e-9 * (yr.1 - yr.0) { "0".into() } else { format!("{v:.1e}") })
            .draw()
            .map_err(|e| de(&e))?;
        ch.draw_series(LineSeries::new(line(slip), MAGENTA.stroke_width(2)))
            .map_err(|e| de(&e))?
            .label("slip of the step")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MAGENTA.stroke_width(2)));
        ch.draw_series(LineSeries::new(line(acc), BLACK.stroke_width(2)))
            .map_err(|e| de(&e))?
            .label("accumulated slip")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        legend(&mut ch).map_err(|e| de(&e))?;
    }
    root.present().map_err(|e| de(&e))?;
    Ok(())
}

/// The wear history of a wear run's result file: per worn surface its depth profile along x at
/// up to six recorded cycles (evenly spread over the run), then two panels with the largest
/// depth and the worn area of every surface against the cycles. Returns the number of surfaces
/// drawn.
pub fn write_wear_png(path: &Path, out: &Path) -> Result<usize, PlotError> {
    register_font()?;
    let err = |msg: String| PlotError::Input { path: path.display().to_string(), msg };
    let file = hdf5::File::open(path).map_err(|e| err(format!("cannot open: {e}")))?;
    let wear = file.group("wear").map_err(|_| err("not a wear run (no /wear group)".into()))?;
    let cycles: Vec<u64> = wear.dataset("cycle").and_then(|d| d.read_raw()).map_err(|e| err(e.to_string()))?;
    let mut names: Vec<String> = wear.groups().map_err(|e| err(e.to_string()))?.iter().map(|g| g.name()).collect();
    names.sort();
    let names: Vec<String> = names.iter().map(|n| n.rsplit('/').next().unwrap_or(n).to_string()).collect();
    if cycles.is_empty() || names.is_empty() {
        return Err(err("the wear series is empty".into()));
    }
    let draw_err = |e: String| PlotError::Draw { path: out.display().to_string(), msg: e };
    let de = |e: &dyn std::fmt::Display| draw_err(e.to_string());
    let root = BitMapBackend::new(out, (1000, 350 * (names.len() as u32 + 2))).into_drawing_area();
    root.fill(&WHITE).map_err(|e| de(&e))?;
    let panels = root.split_evenly((names.len() + 2, 1));
    let rows: Vec<usize> = {
        let n = cycles.len();
        let mut r: Vec<usize> = (1..=6).map(|k| ((n - 1) * k) / 6).collect();
        r.dedup();
        r
    };
    let palette = PALETTE;
    let mut histories = vec![];
    for (name, panel) in names.iter().zip(panels.iter()) {
        let g = wear.group(name).map_err(|e| err(e.to_string()))?;
        let depth: ndarray::Array2<f64> =
            g.dataset("depth").and_then(|d| d.read_2d()).map_err(|e| err(e.to_string()))?;
        let verts: ndarray::Array3<f64> =
            g.dataset("vertices").and_then(|d| d.read()).map_err(|e| err(e.to_string()))?;
        let read = |key: &str| -> Result<Vec<f64>, PlotError> {
            g.dataset(key).and_then(|d| d.read_raw()).map_err(|e| err(format!("wear/{name}/{key}: {e}")))
        };
        histories.push((name.clone(), read("max_depth")?, read("worn_area")?));
        let last = depth.nrows() - 1;
        let dmax = depth.row(last).iter().fold(0.0_f64, |a, &b| a.max(b)).max(f64::MIN_POSITIVE);
        // x range: where the last profile is at least 0.1% of its maximum, widened by a quarter.
        let xs: Vec<f64> =
            (0..depth.ncols()).filter(|&i| depth[[last, i]] >= 1e-3 * dmax).map(|i| verts[[last, i, 0]]).collect();
        let (x0, x1) = xs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        let pad = 0.25 * (x1 - x0).max(1e-12);
        let mut ch = ChartBuilder::on(panel)
            .caption(format!("wear of '{name}'"), ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(72)
            .build_cartesian_2d((x0 - pad)..(x1 + pad), 0.0..dmax * 1.1 * 1e3)
            .map_err(|e| de(&e))?;
        ch.configure_mesh().x_desc("x (mm, reference)").y_desc("wear depth (um)").draw().map_err(|e| de(&e))?;
        for (k, &r) in rows.iter().enumerate() {
            let color = palette[k % palette.len()];
            let mut pts: Vec<(f64, f64)> =
                (0..depth.ncols()).map(|i| (verts[[r, i, 0]], depth[[r, i]] * 1e3)).collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            ch.draw_series(LineSeries::new(pts, color.stroke_width(2)))
                .map_err(|e| de(&e))?
                .label(format!("cycle {}", cycles[r]))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        }
        legend(&mut ch).map_err(|e| de(&e))?;
    }
    // Last panels: largest depth (um) and worn area (um^2) of each surface against the cycles.
    let nmax = *cycles.last().unwrap_or(&1) as f64;
    for (k, (title, y_desc, scale)) in
        [("largest wear depth", "max depth (um)", 1e3), ("worn area", "worn area (um^2)", 1e6)].into_iter().enumerate()
    {
        fn value(h: &(String, Vec<f64>, Vec<f64>), k: usize) -> &[f64] {
            if k == 0 {
                &h.1
            } else {
                &h.2
            }
        }
        let top = histories.iter().flat_map(|h| value(h, k)).fold(0.0_f64, |a, &b| a.max(b)).max(f64::MIN_POSITIVE);
        let mut ch = ChartBuilder::on(&panels[names.len() + k])
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(72)
            .build_cartesian_2d(0.0..nmax.max(1.0), 0.0..top * 1.1 * scale)
            .map_err(|e| de(&e))?;
        ch.configure_mesh().x_desc("cycles").y_desc(y_desc).draw().map_err(|e| de(&e))?;
        for (j, h) in histories.iter().enumerate() {
            let color = palette[j % palette.len()];
            ch.draw_series(LineSeries::new(
                cycles.iter().zip(value(h, k)).map(|(&c, &d)| (c as f64, d * scale)),
                color.stroke_width(2),
            ))
            .map_err(|e| de(&e))?
            .label(h.0.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        }
        legend(&mut ch).map_err(|e| de(&e))?;
    }
    root.present().map_err(|e| de(&e))?;
    Ok(names.len())
}

/// Series colours, in order (eight, so that a convergence chart's figures stay apart).
const PALETTE: [RGBColor; 8] = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK, RGBColor(255, 140, 0), RGBColor(139, 69, 19)];

/// One curve of an XY chart: its label and its points.
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    /// Points joined in x order (a curve), or points only (a scatter).
    pub joined: bool,
}

/// An XY chart of several series, one panel per `(title, x label, y label, series)`: the chart
/// of a study, written as `out` (PNG) and beside it with the extension `.svg`. Non-finite
/// points are left out.
pub fn write_xy_png(panels: &[(String, String, String, Vec<Series>)], out: &Path) -> Result<(), PlotError> {
    register_font()?;
    let size = (900, 380 * panels.len().max(1) as u32);
    draw_xy(BitMapBackend::new(out, size).into_drawing_area(), panels, out)?;
    let svg = out.with_extension("svg");
    draw_xy(SVGBackend::new(&svg, size).into_drawing_area(), panels, &svg)
}

/// [`write_xy_png`] on any plotters backend.
fn draw_xy<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    panels: &[(String, String, String, Vec<Series>)],
    out: &Path,
) -> Result<(), PlotError> {
    let draw_err = |e: &dyn std::fmt::Display| PlotError::Draw { path: out.display().to_string(), msg: e.to_string() };
    root.fill(&WHITE).map_err(|e| draw_err(&e))?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    let palette = PALETTE;
    for ((title, x_desc, y_desc, series), area) in panels.iter().zip(areas.iter()) {
        let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
        let all: Vec<(f64, f64)> = series.iter().flat_map(|s| s.points.iter().filter(finite).copied()).collect();
        let (x0, x1) = all.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.0), b.max(p.0)));
        let (y0, y1) = all.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
        if !(x0.is_finite() && y0.is_finite()) {
            continue;
        }
        let pad = |a: f64, b: f64| 0.05 * (b - a).abs().max(1e-12 * a.abs().max(1e-300));
        let (px, py) = (pad(x0, x1), pad(y0, y1));
        let mut ch = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(80)
            .build_cartesian_2d((x0 - px)..(x1 + px), (y0 - py)..(y1 + py))
            .map_err(|e| draw_err(&e))?;
        ch.configure_mesh().x_desc(x_desc.as_str()).y_desc(y_desc.as_str()).draw().map_err(|e| draw_err(&e))?;
        for (k, s) in series.iter().enumerate() {
            let color = palette[k % palette.len()];
            let mut pts: Vec<(f64, f64)> = s.points.iter().filter(finite).copied().collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let line = if s.joined { pts.clone() } else { vec![] };
            ch.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled()))).map_err(|e| draw_err(&e))?;
            ch.draw_series(LineSeries::new(line, color.stroke_width(1)))
                .map_err(|e| draw_err(&e))?
                .label(s.label.clone())
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
        }
        legend(&mut ch).map_err(|e| draw_err(&e))?;
    }
    root.present().map_err(|e| draw_err(&e))
}

/// The contact pressure of one recorded cycle of a cyclic run: `pair`'s profile (the only pair
/// if `None`) at each increment of the recorded cycle nearest to `cycle`, in x order.
/// Returns the cycle found and `(increment, x, pressure)` per increment.
#[allow(clippy::type_complexity)]
pub fn read_cycle_pressure(
    path: &Path,
    cycle: u64,
    pair: Option<&str>,
) -> Result<(u64, Vec<(u64, Vec<f64>, Vec<f64>)>), PlotError> {
    let err = |msg: String| PlotError::Input { path: path.display().to_string(), msg };
    let file = hdf5::File::open(path).map_err(|e| err(format!("cannot open: {e}")))?;
    let series = file.group("series").map_err(|_| err("no /series group: not a result file".into()))?;
    let read_u64 = |name: &str| -> Result<Vec<u64>, PlotError> {
        series.dataset(name).and_then(|d| d.read_raw()).map_err(|e| err(format!("series/{name}: {e}")))
    };
    let (cycles, increments) = (read_u64("cycle")?, read_u64("increment")?);
    let contacts = series.group("contacts").map_err(|_| err("no contact pair in the series".into()))?;
    // Pairs are the groups (a friction run also keeps its dissipation there).
    let names: Vec<String> = contacts
        .groups()
        .map_err(|e| err(e.to_string()))?
        .iter()
        .map(|g| g.name().rsplit('/').next().unwrap_or_default().to_string())
        .collect();
    let name = match pair {
        Some(p) if names.iter().any(|n| n == p) => p.to_string(),
        Some(p) => return Err(err(format!("no contact pair '{p}' (pairs: {})", names.join(", ")))),
        None if names.len() == 1 => names[0].clone(),
        None => return Err(err(format!("several contact pairs: choose one with --pair ({})", names.join(", ")))),
    };
    let g = contacts.group(&name).map_err(|e| err(e.to_string()))?;
    // The nodal traction where the file has it (files written before: the multiplier's values).
    let pressure: ndarray::Array2<f64> = g
        .dataset("nodal_pressure")
        .or_else(|_| g.dataset("pressure"))
        .and_then(|d| d.read_2d())
        .map_err(|e| err(e.to_string()))?;
    let position: ndarray::Array3<f64> =
        g.dataset("position").and_then(|d| d.read()).map_err(|e| err(e.to_string()))?;
    let found = cycles
        .iter()
        .filter(|&&c| c > 0)
        .min_by_key(|&&c| c.abs_diff(cycle))
        .copied()
        .ok_or_else(|| err("no cycle recorded: not a cyclic run".into()))?;
    let mut out = Vec::new();
    for s in (0..cycles.len()).filter(|&s| cycles[s] == found && s < pressure.nrows()) {
        let mut nodes: Vec<(f64, f64)> =
            (0..pressure.ncols()).map(|l| (position[[s, l, 0]], pressure[[s, l]])).collect();
        nodes.sort_by(|a, b| a.0.total_cmp(&b.0));
        out.push((increments[s], nodes.iter().map(|n| n.0).collect(), nodes.iter().map(|n| n.1).collect()));
    }
    Ok((found, out))
}

/// `mortex plot --cycle`: the pressure at every increment (stroke position) of the recorded
/// cycle nearest to `cycle`, one panel per increment, with the same increments of a
/// `reference` run (e.g. one without cycle jumps) at its recorded cycle nearest to the one
/// found. Returns the cycle drawn and the panels.
pub fn write_cycle_png(
    path: &Path,
    cycle: u64,
    reference: Option<&Path>,
    pair: Option<&str>,
    out: &Path,
) -> Result<(u64, usize), PlotError> {
    let (found, profiles) = read_cycle_pressure(path, cycle, pair)?;
    let reference = match reference {
        Some(r) => Some(read_cycle_pressure(r, found, pair)?),
        None => None,
    };
    // x range: where any drawn profile carries pressure, widened by half its width each side.
    let all = profiles.iter().chain(reference.iter().flat_map(|r| r.1.iter()));
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, x, p)| {
        let p_max = p.iter().fold(0.0_f64, |a, &b| a.max(b));
        x.iter().zip(p).filter(|(_, &v)| v > 1e-9 * p_max).fold((lo, hi), |(lo, hi), (&x, _)| (lo.min(x), hi.max(x)))
    });
    let pad = 0.5 * (hi - lo).max(f64::MIN_POSITIVE);
    let points = |x: &[f64], p: &[f64]| {
        x.iter().copied().zip(p.iter().copied()).filter(|(x, _)| *x >= lo - pad && *x <= hi + pad).collect::<Vec<_>>()
    };
    let panels: Vec<(String, String, String, Vec<Series>)> = profiles
        .iter()
        .map(|(inc, x, p)| {
            let mut series = vec![Series { label: format!("cycle {found}"), points: points(x, p), joined: true }];
            if let Some((rc, rp)) = &reference {
                if let Some((_, rx, rpp)) = rp.iter().find(|(i, _, _)| i == inc) {
                    series.push(Series {
                        label: format!("reference, cycle {rc}"),
                        points: points(rx, rpp),
                        joined: true,
                    });
                }
            }
            (format!("increment {inc} of cycle {found}"), "x (mm, current)".into(), "pressure (MPa)".into(), series)
        })
        .collect();
    if panels.is_empty() {
        return Err(PlotError::Input { path: path.display().to_string(), msg: format!("cycle {found} has no step") });
    }
    write_xy_png(&panels, out)?;
    Ok((found, panels.len()))
}
