//! Output: HDF5 result files with an XDMF companion for ParaView.
//!
//! Layout of `<name>.h5` (all arrays row-major, f64 unless noted):
//! * `/` attributes: `format` ("mortex-results"), `version`, `case`, `hypothesis`, `completed`
//!   (1 when the run finished), `num_steps`.
//! * `/mesh/<body>/nodes` `(n, 2)`, `/mesh/<body>/cells` `(c, 4)` i64 node ids (-1 pads a
//!   triangle), `/mesh/<body>/topology` i64 XDMF mixed topology, `/mesh/points` `(p, 2)`
//!   integration-point coordinates (all bodies, point order).
//! * `/series/` (every output step, one row each, extendable chunked datasets): `step`,
//!   `cycle`, `increment`, `iterations`, `newton_iterations` (u64: contact active-set and bulk
//!   Newton iterations), `sub_steps` (u64: the pieces a finite-sliding wear increment was
//!   solved in, 1 if whole), `time`, `load_factor`, `residual`;
//!   `/series/contacts/<pair>/{pressure, shear, slip, accumulated_slip, nodal_pressure,
//!   nodal_shear}` `(steps, l)`, `status` u8 `(steps, l)`, `position` `(steps, l, 2)`,
//!   `/series/contacts/dissipation`;
//!   `/series/surfaces/<cut>/vertices` `(steps, v, 2)` of moving surfaces.
//! * `/steps/NNNNNN/` (snapshot steps only: full fields, or a checkpoint) attributes `time`,
//!   `load_factor`, `iterations`, `cutbacks`,
//!   `residual`; per body `displacement` `(n, 3)` (z = 0, for ParaView's warp), `stress` `(n, 4)`
//!   nodal `[xx, yy, zz, xy]` (recovered from the points, see [`crate::post`]) and `stress_tensor` `(n, 6)` (the same as
//!   XDMF's symmetric `[xx, xy, xz, yy, yz, zz]`), `von_mises` `(n)`, `eqps` `(n)`,
//!   `reaction` `(n, 2)`, `cell_stress` `(c, 4)`, `cell_stress_tensor` `(c, 6)`, `cell_eqps` `(c)`; `/steps/NNNNNN/points/stress`
//!   `(p, 4)` and `eqps` `(p)` at the integration points (with moving surfaces also their
//!   `coordinates` `(p, 2)`: cut band cells of bodies without history take exact rules).
//! * `/time`, `/load_factor` `(steps)`: written when the file is closed.
//! * Cut host bodies: `/mesh/<body>/material_fraction` `(c)`. Ties: `/mesh/ties/<tie>/points`,
//!   `normals` `(l, 2)` of the multiplier nodes (outward normal of the patch) and per step
//!   `/steps/NNNNNN/ties/<tie>/traction` `(l, 2)`: the traction on the patch, `t = sigma n = -lambda`.
//! * Contacts: `/mesh/contacts/<pair>/points` `(l, 2)`, `segments` `(l - 1, 2)` i64 (attributes
//!   `mu`, `sliding`) and per step
//!   `/steps/NNNNNN/contacts/<pair>/pressure` `(l)` (`p = -lambda_n >= 0`, the multiplier's
//!   nodal coefficients), `nodal_pressure` (each node's contact force over its hat's measure:
//!   what the node transmits, see `Multipliers::nodal_traction`), `position` `(l, 2)`
//!   (current position of the multiplier nodes); with friction also
//!   `shear` (`lambda_t` along `t = n` turned +90 degrees), `nodal_shear`, `slip` (slip of the step),
//!   `accumulated_slip` and `status` (0 open, 1 stick, 2 slip); `/steps/NNNNNN/contacts/
//!   dissipation` (frictional energy dissipated so far, per unit thickness).
//!
//! * Checkpoints (every output step by default): `/steps/NNNNNN/checkpoint/`, the whole
//!   simulation state (see [`checkpoint`]); `restarted_from`, `restart_step` root attributes on
//!   a run that resumed from one.
//!
//! * Steps carry `cycle` and `increment` attributes (cycle 0: before the cycles, or a
//!   non-cyclic case). Moving surfaces: per step `/steps/NNNNNN/surfaces/<cut>/vertices`
//!   `(v, 2)` and `/steps/NNNNNN/<body>/material_fraction` `(c)` of their host.
//!
//! Output that scales to long runs: full fields (nodal, cell and point fields) every
//! `fields_every` steps and at the last step, contact and surface series every step,
//! checkpoints every `checkpoint_every` steps; mostly-zero datasets of 256 entries or more are
//! chunked and deflate-compressed (with shuffle; see [`put`]). The file is written as
//! `<name>.h5.partial` and renamed when closed, so an earlier result is never replaced by a
//! half-written file; a run that stops on an error keeps its `.h5.partial` when a result of
//! that name already exists. The XDMF (see [`ResultWriter::finish`]: bodies with the fields of
//! the latest step that holds them, contact and worn surfaces as polylines) is written once,
//! when the file is renamed into place, so it never describes another file. A wear run always
//! writes full fields at its last step. The contact CSV is written as
//! the run goes (`<name>_contact.csv.partial`, renamed at the end).
//!
//! HDF5 has no journal: a process killed while the library updates the file's metadata can
//! leave `<name>.h5.partial` unreadable. So each checkpoint is also written, alone, to
//! `<name>.h5.partial.checkpoint` (a fresh file renamed into place: always whole), which
//! [`checkpoint::read`] falls back to when the partial file cannot be read. It is removed when
//! the partial file becomes the result.

pub mod checkpoint;
pub mod plot;
pub mod plot_field;

use crate::model::{Discretisation, Model};
use crate::post::nodal_fields;
use crate::solve::StepReport;
use crate::state::SimState;
use hdf5::types::VarLenUnicode;
use ndarray::{Array1, Array2};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: HDF5 error while {what}: {msg}")]
    Hdf5 { path: String, what: String, msg: String },
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
}

pub struct ResultWriter {
    file: Option<hdf5::File>,
    final_path: PathBuf,
    partial_path: PathBuf,
    xdmf_path: PathBuf,
    /// `(step, time, load factor, has full fields)`.
    steps: Vec<(usize, f64, f64, bool)>,
    body_meta: Vec<(String, usize, usize, usize)>, // name, nodes, cells, topology length
    cut_bodies: Vec<String>,
    /// Bodies whose material fraction changes (moving surfaces): written per step.
    moving_bodies: Vec<String>,
    /// Contact pairs: name, multiplier nodes, with friction (XDMF polylines).
    contact_meta: Vec<(String, usize, bool)>,
    /// Contact profiles (CSV rows), streamed to `<name>_contact.csv.partial` step by step.
    contact_csv: Option<(std::io::BufWriter<std::fs::File>, PathBuf, PathBuf)>,
    /// A checkpoint every this many output steps (0: none).
    checkpoint_every: usize,
    /// The last this many checkpoints are kept (0: all), and the steps of those written.
    keep_checkpoints: usize,
    checkpoints: std::collections::VecDeque<usize>,
    /// Full fields every this many output steps (and at the last); a cycled wear run counts
    /// the schedule's steps, see [`Output::schedule_position`].
    fields_every: usize,
    /// The furthest schedule position a step has reached, and the step of the last full
    /// fields (the step before the first written, at the start of a run or a continuation).
    fields_position: Option<(usize, usize)>,
    last_step: usize,
    last_flush: std::time::Instant,
    /// Per-step series (every step): extendable datasets, one row per step.
    series: Series,
}

/// Extendable per-step datasets under `/series` (one row per output step).
struct Series {
    /// `(dataset, row width)`: scalars have width 0.
    scalars: Vec<hdf5::Dataset>,
    /// Per contact pair: pressure, shear, slip, accumulated slip `(steps, l)`, status u8
    /// `(steps, l)`, position `(steps, l, 2)`.
    contacts: Vec<[hdf5::Dataset; 8]>,
    dissipation: Option<hdf5::Dataset>,
    /// Moving surfaces: vertices `(steps, v, 2)`.
    surfaces: Vec<hdf5::Dataset>,
    rows: usize,
    /// Wear runs: `/wear` rows at cycle boundaries (see [`WearSeries`]).
    wear: Option<WearSeries>,
}

/// `/wear`, one row per wear update (each computed cycle's end, and the end of the ramp):
/// `step`, `cycle` (cycles done, jumps included), `computed_cycles`, `jump` (u64), and per
/// wearing surface `/wear/<cut>/{vertices (rows, v, 2), depth (rows, v), worn_area, work,
/// max_depth}` and `segments` `(v - 1, 2)` i64 (`v` rows when closed), vertices in the order
/// the case gave them. With yielding bodies also `ratcheting` and `plastic_strain`: the
/// largest net and accumulated equivalent plastic strain of a point over the last computed
/// cycle (see `wear::cycle_plasticity`). With `[fatigue]`, `/wear/fatigue`: the points'
/// `position` `(np, 2)` (written once), `max_damage` per row, and the latest row's `damage`,
/// `swt`, `angle` (critical plane, radians from x), `life` (cycles; inf below the endurance
/// limit) and `retired` (u8: cut away by the worn surface, its damage kept) per point,
/// overwritten row after row, and once a point's damage reaches 1 the attributes
/// `initiation_cycle`, `initiation_point`, `initiation_angle`, `initiation_depth` (see
/// [`crate::fatigue`]).
struct WearSeries {
    scalars: [hdf5::Dataset; 4],
    plastic: Option<[hdf5::Dataset; 2]>,
    fatigue: Option<([hdf5::Dataset; 5], hdf5::Dataset, hdf5::Group)>,
    surfaces: Vec<[hdf5::Dataset; 5]>,
    rows: usize,
    /// Per surface: name and vertex count (XDMF polylines); per row: its output step.
    meta: Vec<(String, usize, usize)>,
    row_steps: Vec<usize>,
}

impl WearSeries {
    fn create(file: &hdf5::File, model: &Model) -> hdf5::Result<WearSeries> {
        let g = file.create_group("wear")?;
        let u = |name: &str| g.new_dataset::<u64>().chunk(SERIES_CHUNK).shape(0..).create(name);
        let scalars = [u("step")?, u("cycle")?, u("computed_cycles")?, u("jump")?];
        let f = |name: &str| g.new_dataset::<f64>().chunk(SERIES_CHUNK).shape(0..).create(name);
        let plastic = if model.has_plasticity() { Some([f("ratcheting")?, f("plastic_strain")?]) } else { None };
        let fatigue = match &model.fatigue {
            Some(fm) => {
                let fg = g.create_group("fatigue")?;
                let np = fm.points.len();
                let xy: Vec<f64> = fm.points.iter().flat_map(|p| [p.position.x, p.position.y]).collect();
                put(&fg, "position", &array2(np, 2, xy))?;
                let per_point = |name: &str| fg.new_dataset::<f64>().shape(np).create(name);
                let max = fg.new_dataset::<f64>().chunk(SERIES_CHUNK).shape(0..).create("max_damage")?;
                let retired = fg.new_dataset::<u8>().shape(np).create("retired")?;
                let datasets = [max, per_point("damage")?, per_point("swt")?, per_point("angle")?, per_point("life")?];
                Some((datasets, retired, fg))
            }
            None => None,
        };
        let mut surfaces = vec![];
        let mut meta = vec![];
        for w in &model.wear.surfaces {
            let surface = &model.initial().surfaces[w.surface];
            let v = surface.vertices.len();
            let sg = g.create_group(&w.name)?;
            // The polyline's segments (vertex pairs, in the order of `vertices`): ParaView's
            // topology of the worn surface.
            let segs = segments(v, surface.base.closed);
            meta.push((w.name.clone(), v, segs.nrows()));
            put(&sg, "segments", &segs)?;
            let f = |name: &str| sg.new_dataset::<f64>().chunk(SERIES_CHUNK).shape(0..).create(name);
            surfaces.push([
                sg.new_dataset::<f64>().chunk((SERIES_CHUNK, v, 2)).shape((0.., v, 2)).create("vertices")?,
                sg.new_dataset::<f64>().chunk((SERIES_CHUNK, v)).shape((0.., v)).create("depth")?,
                f("worn_area")?,
                f("work")?,
                f("max_depth")?,
            ]);
        }
        Ok(WearSeries { scalars, plastic, fatigue, surfaces, rows: 0, meta, row_steps: vec![] })
    }

    fn append(&mut self, model: &Model, report: &StepReport, state: &SimState) -> hdf5::Result<()> {
        use ndarray::s;
        let k = self.rows;
        let w = &state.wear;
        for (ds, v) in self.scalars.iter().zip([report.step as u64, w.cycle, w.computed_cycles, w.jump]) {
            ds.resize(k + 1)?;
            ds.write_slice(&[v], s![k..k + 1])?;
        }
        for (ds, v) in self.plastic.iter().flatten().zip([w.cycle_ratcheting, w.cycle_plastic_strain]) {
            ds.resize(k + 1)?;
            ds.write_slice(&[v], s![k..k + 1])?;
        }
        if let Some(([max, rest @ ..], retired, group)) = &self.fatigue {
            let f = &state.fatigue;
            max.resize(k + 1)?;
            max.write_slice(&[f.damage.iter().fold(0.0_f64, |a, &b| a.max(b))], s![k..k + 1])?;
            for (ds, v) in rest.iter().zip([&f.damage, &f.last.swt, &f.last.angle, &f.last.life]) {
                // Before the first computed cycle (the ramp's row) nothing is known yet.
                if v.len() == ds.size() {
                    ds.write_raw(v)?;
                }
            }
            if f.retired.len() == retired.size() {
                retired.write_raw(&f.retired.iter().map(|&r| u8::from(r)).collect::<Vec<u8>>())?;
            }
            if let Some(i) = f.initiation.filter(|_| group.attr("initiation_cycle").is_err()) {
                write_attr(group, "initiation_cycle", &i.cycle)?;
                write_attr(group, "initiation_point", &(i.point as u64))?;
                write_attr(group, "initiation_angle", &i.angle)?;
                write_attr(group, "initiation_depth", &i.depth)?;
            }
        }
        for (i, (ds, ws)) in self.surfaces.iter().zip(&model.wear.surfaces).enumerate() {
            let reversed = model.initial().surfaces[ws.surface].reversed;
            let mut verts = w.vertices[i].clone();
            let mut depth = w.depth[i].clone();
            if reversed {
                verts.reverse();
                depth.reverse();
            }
            let v = verts.len();
            let xy: Vec<f64> = verts.iter().flat_map(|p| [p[0], p[1]]).collect();
            ds[0].resize((k + 1, v, 2))?;
            let xy =
                ndarray::Array3::from_shape_vec((1, v, 2), xy).unwrap_or_else(|_| ndarray::Array3::zeros((1, v, 2)));
            ds[0].write_slice(&xy, s![k..k + 1, .., ..])?;
            let deepest = depth.iter().fold(0.0_f64, |a, &b| a.max(b));
            ds[1].resize((k + 1, v))?;
            ds[1].write_slice(
                &Array2::from_shape_vec((1, v), depth).unwrap_or_else(|_| Array2::zeros((1, v))),
                s![k..k + 1, ..],
            )?;
            for (d, val) in ds[2..].iter().zip([w.worn_area[i], w.work[i], deepest]) {
                d.resize(k + 1)?;
                d.write_slice(&[val], s![k..k + 1])?;
            }
        }
        self.rows += 1;
        self.row_steps.push(report.step);
        Ok(())
    }
}

/// A stress `[xx, yy, zz, xy]` as XDMF's symmetric `Tensor6` `[xx, xy, xz, yy, yz, zz]`.
fn tensor6(s: &[f64; 4]) -> [f64; 6] {
    [s[0], s[3], 0.0, s[1], 0.0, s[2]]
}

/// The contact pairs' multiplier nodes (with their polyline segments, friction coefficient and
/// sliding model) and the ties' multiplier nodes and normals under `/mesh`.
fn write_contact_and_tie_meshes(mesh: &hdf5::Group, model: &Model) -> hdf5::Result<()> {
    if !model.initial().contact.pairs.is_empty() {
        let cg = mesh.create_group("contacts")?;
        for c in &model.initial().contact.pairs {
            let m = &c.multipliers;
            let xy: Vec<f64> = m.points.iter().flat_map(|p| [p.x, p.y]).collect();
            let pg = cg.create_group(&c.name)?;
            pg.new_dataset_builder().with_data(&array2(m.num_nodes, 2, xy)).create("points")?;
            // Multiplier nodes run along the mortar side: consecutive nodes make the
            // contact surface's polyline in ParaView.
            pg.new_dataset_builder().with_data(&segments(m.num_nodes, false)).create("segments")?;
            write_attr(&pg, "mu", &c.mu)?;
            let sliding = match c.sliding {
                crate::contact::Sliding::Small => "small",
                crate::contact::Sliding::Finite => "finite",
            };
            write_str_attr(&pg, "sliding", sliding)?;
        }
    }
    if !model.ties.is_empty() {
        let tg = mesh.create_group("ties")?;
        for t in &model.ties {
            let g = tg.create_group(&t.name)?;
            let m = &t.multipliers;
            let xy: Vec<f64> = m.points.iter().flat_map(|p| [p.x, p.y]).collect();
            g.new_dataset_builder().with_data(&array2(m.num_nodes, 2, xy)).create("points")?;
            let nrm: Vec<f64> = m.normals.iter().flat_map(|p| [p.x, p.y]).collect();
            g.new_dataset_builder().with_data(&array2(m.num_nodes, 2, nrm)).create("normals")?;
            write_str_attr(&g, "multipliers", &format!("{:?}", t.space))?;
        }
    }
    Ok(())
}

/// Whether `state` is the last step of a wear run: its last cycle's wear has been applied (the
/// step count of a run with cycle jumps is not known in advance).
fn wear_run_ends(model: &Model, state: &SimState) -> bool {
    !model.wear.is_empty()
        && state.wear.increment == 0
        && model.cycle.is_some_and(|c| state.wear.cycle >= c.count as u64)
}

/// Segments `(i, i + 1)` of a polyline of `n` vertices (and `(n - 1, 0)` when closed), i64.
fn segments(n: usize, closed: bool) -> Array2<i64> {
    let m = if closed { n } else { n.saturating_sub(1) };
    let ids: Vec<i64> = (0..m).flat_map(|i| [i as i64, ((i + 1) % n.max(1)) as i64]).collect();
    Array2::from_shape_vec((m, 2), ids).unwrap_or_else(|_| Array2::zeros((0, 2)))
}

/// Rows of a series chunk (a chunk holds this many steps).
const SERIES_CHUNK: usize = 64;

impl Series {
    fn create(file: &hdf5::File, model: &Model) -> hdf5::Result<Series> {
        let g = file.create_group("series")?;
        let mut scalars = vec![];
        for name in ["step", "cycle", "increment", "iterations", "newton_iterations", "sub_steps"] {
            scalars.push(g.new_dataset::<u64>().chunk(SERIES_CHUNK * 16).shape(0..).create(name)?);
        }
        for name in ["time", "load_factor", "residual"] {
            scalars.push(g.new_dataset::<f64>().chunk(SERIES_CHUNK * 16).shape(0..).create(name)?);
        }
        let mut contacts = vec![];
        let mut dissipation = None;
        if !model.initial().contact.pairs.is_empty() {
            let cg = g.create_group("contacts")?;
            for c in &model.initial().contact.pairs {
                let l = c.multipliers.num_nodes.max(1);
                let pg = cg.create_group(&c.name)?;
                let f = |name: &str| pg.new_dataset::<f64>().chunk((SERIES_CHUNK, l)).shape((0.., l)).create(name);
                contacts.push([
                    f("pressure")?,
                    f("shear")?,
                    f("slip")?,
                    f("accumulated_slip")?,
                    pg.new_dataset::<u8>().chunk((SERIES_CHUNK, l)).shape((0.., l)).create("status")?,
                    pg.new_dataset::<f64>().chunk((SERIES_CHUNK, l, 2)).shape((0.., l, 2)).create("position")?,
                    f("nodal_pressure")?,
                    f("nodal_shear")?,
                ]);
            }
            dissipation = Some(cg.new_dataset::<f64>().chunk(SERIES_CHUNK * 16).shape(0..).create("dissipation")?);
        }
        let mut surfaces = vec![];
        if model.initial().surfaces.iter().any(|s| s.motion.is_some()) {
            let sg = g.create_group("surfaces")?;
            for s in model.initial().surfaces.iter().filter(|s| s.motion.is_some()) {
                let v = s.vertices.len();
                surfaces.push(
                    sg.create_group(&s.name)?
                        .new_dataset::<f64>()
                        .chunk((SERIES_CHUNK, v, 2))
                        .shape((0.., v, 2))
                        .create("vertices")?,
                );
            }
        }
        let wear = if model.wear.is_empty() { None } else { Some(WearSeries::create(file, model)?) };
        Ok(Series { scalars, contacts, dissipation, surfaces, rows: 0, wear })
    }

    fn append(
        &mut self,
        model: &Model,
        disc: &Discretisation,
        report: &StepReport,
        state: &SimState,
        fields: &[Vec<crate::contact::ContactNodeState>],
    ) -> hdf5::Result<()> {
        use ndarray::s;
        let k = self.rows;
        let ints = [
            report.step as u64,
            report.cycle as u64,
            report.increment as u64,
            report.iterations as u64,
            report.newton_iterations as u64,
            report.sub_steps as u64,
        ];
        for (ds, v) in self.scalars.iter().zip(ints) {
            ds.resize(k + 1)?;
            ds.write_slice(&[v], s![k..k + 1])?;
        }
        for (ds, v) in self.scalars[ints.len()..].iter().zip([report.time, report.load_factor, report.residual]) {
            ds.resize(k + 1)?;
            ds.write_slice(&[v], s![k..k + 1])?;
        }
        for (ds, field) in self.contacts.iter().zip(fields) {
            let l = field.len();
            // The float columns: datasets 0-3 and 6-7 (4 is the status, 5 the positions).
            let cols: [(usize, Vec<f64>); 6] = [
                (0, field.iter().map(|n| n.pressure).collect()),
                (1, field.iter().map(|n| n.shear).collect()),
                (2, field.iter().map(|n| n.slip).collect()),
                (3, field.iter().map(|n| n.accumulated_slip).collect()),
                (6, field.iter().map(|n| n.nodal_pressure).collect()),
                (7, field.iter().map(|n| n.nodal_shear).collect()),
            ];
            for (i, col) in cols {
                let d = &ds[i];
                d.resize((k + 1, l))?;
                d.write_slice(
                    &Array2::from_shape_vec((1, l), col).unwrap_or_else(|_| Array2::zeros((1, l))),
                    s![k..k + 1, ..],
                )?;
            }
            let status: Vec<u8> = field.iter().map(|n| n.status.code()).collect();
            ds[4].resize((k + 1, l))?;
            ds[4].write_slice(
                &Array2::from_shape_vec((1, l), status).unwrap_or_else(|_| Array2::zeros((1, l))),
                s![k..k + 1, ..],
            )?;
            let xy: Vec<f64> = field.iter().flat_map(|n| [n.position.x, n.position.y]).collect();
            ds[5].resize((k + 1, l, 2))?;
            let xy =
                ndarray::Array3::from_shape_vec((1, l, 2), xy).unwrap_or_else(|_| ndarray::Array3::zeros((1, l, 2)));
            ds[5].write_slice(&xy, s![k..k + 1, .., ..])?;
        }
        if let Some(d) = &self.dissipation {
            d.resize(k + 1)?;
            d.write_slice(&[state.dissipation], s![k..k + 1])?;
        }
        for (d, surf) in self.surfaces.iter().zip(disc.surfaces.iter().filter(|s| s.motion.is_some())) {
            let v = surf.vertices.len();
            let xy: Vec<f64> = surf.user_vertices().iter().flat_map(|p| [p.x, p.y]).collect();
            d.resize((k + 1, v, 2))?;
            let xy =
                ndarray::Array3::from_shape_vec((1, v, 2), xy).unwrap_or_else(|_| ndarray::Array3::zeros((1, v, 2)));
            d.write_slice(&xy, s![k..k + 1, .., ..])?;
        }
        if let Some(w) = &mut self.wear {
            // A wear update has just been applied (cycle boundary).
            if state.wear.increment == 0 {
                w.append(model, report, state)?;
            }
        }
        self.rows += 1;
        Ok(())
    }
}

/// Datasets at least this long are chunked and compressed.
const COMPRESS_MIN: usize = 256;

/// Writes a dataset, shuffled and deflate-compressed (level 1, automatic chunks) when it is
/// long enough, at least a third of its values are zero (plastic strain of elastic bodies,
/// the z column of displacements, statuses) and the HDF5 library has deflate (lossless). Dense
/// floating-point fields are stored as they are: deflate saved 23% of a fretting run's file at
/// six times its output time (measured with `mortex bench --output`).
fn put<T: hdf5::H5Type + Default + PartialEq, D: ndarray::Dimension>(
    g: &hdf5::Group,
    name: &str,
    data: &ndarray::Array<T, D>,
) -> hdf5::Result<()> {
    let zero = T::default();
    let sparse = || 3 * data.iter().filter(|v| **v == zero).count() >= data.len();
    if data.len() >= COMPRESS_MIN && sparse() && hdf5::filters::deflate_available() {
        g.new_dataset_builder().shuffle().deflate(1).with_data(data).create(name)?;
    } else {
        g.new_dataset_builder().with_data(data).create(name)?;
    }
    Ok(())
}

fn h5err<E: std::fmt::Display>(path: &Path, what: &str) -> impl FnOnce(E) -> OutputError {
    let (path, what) = (path.display().to_string(), what.to_string());
    move |e| OutputError::Hdf5 { path, what, msg: e.to_string() }
}

fn write_str_attr(loc: &hdf5::Location, name: &str, value: &str) -> hdf5::Result<()> {
    let v: VarLenUnicode =
        value.parse().map_err(|e: hdf5::types::StringError| hdf5::Error::from(e.to_string().as_str()))?;
    loc.new_attr::<VarLenUnicode>().create(name)?.write_scalar(&v)
}

fn write_attr<T: hdf5::H5Type>(loc: &hdf5::Location, name: &str, value: &T) -> hdf5::Result<()> {
    loc.new_attr::<T>().create(name)?.write_scalar(value)
}

fn array2(rows: usize, cols: usize, data: Vec<f64>) -> Array2<f64> {
    // Shapes are constructed from matching lengths below.
    Array2::from_shape_vec((rows, cols), data).unwrap_or_else(|_| Array2::zeros((rows, cols)))
}

impl ResultWriter {
    /// Creates `<path>.partial` and writes the mesh.
    pub fn create(path: &Path, model: &Model, case_name: &str) -> Result<Self, OutputError> {
        if let Some(dir) = path.parent() {
            if !dir.as_os_str().is_empty() {
                std::fs::create_dir_all(dir)
                    .map_err(|e| OutputError::Io { path: dir.display().to_string(), source: e })?;
            }
        }
        let partial_path = PathBuf::from(format!("{}.partial", path.display()));
        let xdmf_path = path.with_extension("xdmf");
        let file = hdf5::File::create(&partial_path).map_err(h5err(&partial_path, "creating the file"))?;
        let contact_csv = if model.initial().contact.pairs.is_empty() {
            None
        } else {
            let stem = path.with_extension("");
            let csv = PathBuf::from(format!("{}_contact.csv", stem.display()));
            let partial = PathBuf::from(format!("{}.partial", csv.display()));
            let f = std::fs::File::create(&partial)
                .map_err(|e| OutputError::Io { path: partial.display().to_string(), source: e })?;
            let mut bw = std::io::BufWriter::new(f);
            use std::io::Write as _;
            bw.write_all(b"step,time,pair,x,y,pressure,shear,slip,accumulated_slip,status,cycle,increment,nodal_pressure,nodal_shear\n")
                .map_err(|e| OutputError::Io { path: partial.display().to_string(), source: e })?;
            Some((bw, partial, csv))
        };
        let mut w = ResultWriter {
            file: None,
            final_path: path.to_path_buf(),
            partial_path: partial_path.clone(),
            xdmf_path,
            steps: vec![],
            body_meta: vec![],
            cut_bodies: vec![],
            moving_bodies: vec![],
            contact_meta: model
                .initial()
                .contact
                .pairs
                .iter()
                .filter(|c| c.multipliers.num_nodes > 0)
                .map(|c| (c.name.clone(), c.multipliers.num_nodes, c.mu > 0.0))
                .collect(),
            contact_csv,
            checkpoint_every: 1,
            keep_checkpoints: 0,
            checkpoints: Default::default(),
            fields_every: 1,
            fields_position: None,
            last_step: model.times.len(),
            last_flush: std::time::Instant::now(),
            series: Series {
                scalars: vec![],
                contacts: vec![],
                dissipation: None,
                surfaces: vec![],
                rows: 0,
                wear: None,
            },
        };
        let res: hdf5::Result<()> = (|| {
            write_str_attr(&file, "format", "mortex-results")?;
            write_str_attr(&file, "version", env!("CARGO_PKG_VERSION"))?;
            write_str_attr(&file, "case", case_name)?;
            write_str_attr(&file, "hypothesis", &format!("{:?}", model.hypothesis))?;
            write_attr(&file, "completed", &0u8)?;
            let mesh = file.create_group("mesh")?;
            w.write_bodies(&mesh, model)?;
            write_contact_and_tie_meshes(&mesh, model)?;
            let pts = model.initial().point_coords(model);
            let xy: Vec<f64> = pts.iter().flat_map(|p| [p.x, p.y]).collect();
            put(&mesh, "points", &array2(pts.len(), 2, xy))?;
            file.create_group("steps")?;
            Ok(())
        })();
        res.map_err(h5err(&partial_path, "writing the mesh"))?;
        w.series = Series::create(&file, model).map_err(h5err(&partial_path, "creating the series"))?;
        w.file = Some(file);
        Ok(w)
    }

    /// Per body under `/mesh`: nodes, cells, XDMF topology and the material fraction of cut
    /// hosts; remembers what the XDMF needs of each.
    fn write_bodies(&mut self, mesh: &hdf5::Group, model: &Model) -> hdf5::Result<()> {
        for b in &model.bodies {
            let g = mesh.create_group(&b.name)?;
            let n = b.mesh.num_nodes();
            let xy: Vec<f64> = b.mesh.nodes.iter().flat_map(|p| [p.x, p.y]).collect();
            g.new_dataset_builder().with_data(&array2(n, 2, xy)).create("nodes")?;
            let mut cells = Vec::with_capacity(4 * b.mesh.num_cells());
            let mut topo: Vec<i64> = Vec::new();
            for c in &b.mesh.cells {
                let ns = c.nodes();
                for k in 0..4 {
                    cells.push(ns.get(k).map(|&v| v as i64).unwrap_or(-1));
                }
                topo.push(if ns.len() == 3 { 4 } else { 5 });
                topo.extend(ns.iter().map(|&v| v as i64));
            }
            let cells =
                Array2::from_shape_vec((b.mesh.num_cells(), 4), cells).unwrap_or_else(|_| Array2::zeros((0, 4)));
            g.new_dataset_builder().with_data(&cells).create("cells")?;
            g.new_dataset_builder().with_data(&Array1::from(topo.clone())).create("topology")?;
            self.body_meta.push((b.name.clone(), n, b.mesh.num_cells(), topo.len()));
            let bi = model.bodies.iter().position(|x| x.name == b.name).unwrap_or(0);
            if let Some(cut) = &model.initial().cuts[bi] {
                put(&g, "material_fraction", &Array1::from(cut.cell_fraction.clone()))?;
                self.cut_bodies.push(b.name.clone());
                if model.bands[bi].is_some() {
                    self.moving_bodies.push(b.name.clone());
                }
            }
        }
        Ok(())
    }

    /// Writes a checkpoint (see [`checkpoint`]) every `every` output steps (0: never; default 1).
    pub fn set_checkpoint_every(&mut self, every: usize) {
        self.checkpoint_every = every;
    }

    /// Keeps the last `keep` checkpoints (0, the default: all): an older one is removed when a
    /// new one is written, and HDF5 reuses its space for the next (the file of a long run
    /// stays bounded).
    pub fn set_keep_checkpoints(&mut self, keep: usize) {
        self.keep_checkpoints = keep;
    }

    /// Writes the full fields every `every` output steps (>= 1; default 1) and at the last step.
    pub fn set_fields_every(&mut self, every: usize) {
        self.fields_every = every.max(1);
    }

    /// Records the case's analytical solution for contact pair `pair` under `/reference`
    /// (attributes `pair`, `p0`, `a`, `x0`, `mu` and, for Cattaneo-Mindlin, `c`), which
    /// `mortex plot` draws beside the profile.
    pub fn write_reference(&self, pair: &str, r: &crate::post::AnalyticContact) -> Result<(), OutputError> {
        let Some(file) = self.file.as_ref() else { return Ok(()) };
        let res: hdf5::Result<()> = (|| {
            let g = file.create_group("reference")?;
            write_str_attr(&g, "pair", pair)?;
            let auto = f64::from(u8::from(r.centre_from_profile));
            for (name, v) in
                [("p0", r.p0), ("a", r.a), ("x0", r.x0), ("mu", r.mu), ("e", r.e), ("centre_from_profile", auto)]
            {
                write_attr(&g, name, &v)?;
            }
            if let Some(c) = r.c {
                write_attr(&g, "c", &c)?;
            }
            Ok(())
        })();
        res.map_err(h5err(&self.partial_path, "writing the analytical reference"))
    }

    /// Records in the file that this run resumed from step `step` of `origin`.
    pub fn set_restart_origin(&self, origin: &Path, step: usize) -> Result<(), OutputError> {
        let Some(file) = self.file.as_ref() else { return Ok(()) };
        let res: hdf5::Result<()> = (|| {
            write_str_attr(file, "restarted_from", &origin.display().to_string())?;
            write_attr(file, "restart_step", &(step as u64))
        })();
        res.map_err(h5err(&self.partial_path, "writing the restart origin"))
    }

    /// Where `report`'s step stands in the case's schedule: its step number, or, in a cycled
    /// wear run, the ramp's steps plus `increments` per cycle before its cycle plus its
    /// increment. Fractions of a cycle compute a cycle again and jumps skip cycles, so the
    /// step numbers of such a run count computed steps, not the path: full fields are written
    /// where this position first passes a multiple of `fields_every` and at least
    /// `fields_every` computed steps after the last fields, so a cycle computed again writes
    /// none twice and a run with jumps no more than its computed steps ask.
    fn schedule_position(model: &Model, report: &StepReport) -> usize {
        match model.cycle {
            Some(c) if !model.wear.is_empty() && report.cycle > 0 => {
                let ramp = model.times.len().saturating_sub(c.count * c.increments);
                ramp + (report.cycle - 1) * c.increments + report.increment
            }
            _ => report.step,
        }
    }

    /// Whether `report`'s step writes full fields (see [`Output::schedule_position`]), and the
    /// record of it.
    fn fields_due(&mut self, model: &Model, report: &StepReport, state: &SimState) -> bool {
        // A cycled wear run's step count is not the schedule's: jumps skip cycles and fractions
        // of a cycle compute one again, so only its wear state says where it ends.
        let cycled_wear = !model.wear.is_empty() && model.cycle.is_some();
        let position = Self::schedule_position(model, report);
        // The first step written (of a run or a continuation) counts as one past the last.
        let start = (position.saturating_sub(1), report.step.saturating_sub(1));
        let (reached, last_fields) = self.fields_position.unwrap_or(start);
        let every = self.fields_every;
        let full = (position / every > reached / every && report.step - last_fields >= every)
            || (!cycled_wear && report.step >= self.last_step)
            || wear_run_ends(model, state);
        self.fields_position = Some((reached.max(position), if full { report.step } else { last_fields }));
        full
    }

    /// Appends one converged step (and its checkpoint when the step is a multiple of the
    /// checkpoint interval).
    pub fn write_step(
        &mut self,
        model: &Model,
        disc: &Discretisation,
        report: &StepReport,
        state: &SimState,
    ) -> Result<(), OutputError> {
        let full = self.fields_due(model, report, state);
        let Some(file) = self.file.as_ref() else {
            return Ok(());
        };
        let checkpoint = self.checkpoint_every > 0 && report.step % self.checkpoint_every == 0;
        let fields: Vec<Vec<crate::contact::ContactNodeState>> = (0..disc.contact.pairs.len())
            .map(|pair| crate::contact::contact_field(&disc.contact, &state.contact_unknowns(), pair))
            .collect();
        let series = &mut self.series;
        let moving_bodies = &self.moving_bodies;
        let res: hdf5::Result<()> = (|| {
            series.append(model, disc, report, state, &fields)?;
            // A step group only where there is a snapshot: full fields or a checkpoint.
            if !(full || checkpoint) {
                return Ok(());
            }
            let g = file.group("steps")?.create_group(&format!("{:06}", report.step))?;
            write_attr(&g, "time", &report.time)?;
            write_attr(&g, "load_factor", &report.load_factor)?;
            write_attr(&g, "iterations", &(report.iterations as u64))?;
            write_attr(&g, "cutbacks", &(report.cutbacks as u64))?;
            write_attr(&g, "residual", &report.residual)?;
            write_attr(&g, "cycle", &(report.cycle as u64))?;
            write_attr(&g, "increment", &(report.increment as u64))?;
            if full {
                Self::write_fields(&g, model, disc, state, &disc.reactions(model, state))?;
            }
            for (bi, b) in model.bodies.iter().enumerate() {
                if let (Some(cut), true) = (&disc.cuts[bi], moving_bodies.contains(&b.name)) {
                    let bg = match g.group(&b.name) {
                        Ok(bg) => bg,
                        Err(_) => g.create_group(&b.name)?,
                    };
                    put(&bg, "material_fraction", &Array1::from(cut.cell_fraction.clone()))?;
                }
            }
            if disc.surfaces.iter().any(|s| s.motion.is_some()) {
                let sg = g.create_group("surfaces")?;
                for s in disc.surfaces.iter().filter(|s| s.motion.is_some()) {
                    let xy: Vec<f64> = s.user_vertices().iter().flat_map(|p| [p.x, p.y]).collect();
                    sg.create_group(&s.name)?
                        .new_dataset_builder()
                        .with_data(&array2(s.vertices.len(), 2, xy))
                        .create("vertices")?;
                }
            }
            if !model.ties.is_empty() {
                let tg = g.create_group("ties")?;
                for t in &model.ties {
                    let nl = t.multipliers.num_nodes;
                    let tr: Vec<f64> = (0..2 * nl).map(|k| -state.multipliers[t.first_row + k]).collect();
                    put(&tg.create_group(&t.name)?, "traction", &array2(nl, 2, tr))?;
                }
            }
            if !disc.contact.pairs.is_empty() {
                let cg = g.create_group("contacts")?;
                for (c, field) in disc.contact.pairs.iter().zip(&fields) {
                    let nl = field.len();
                    let col = |f: &dyn Fn(&crate::contact::ContactNodeState) -> f64| -> Array1<f64> {
                        field.iter().map(f).collect()
                    };
                    let pg = cg.create_group(&c.name)?;
                    put(&pg, "pressure", &col(&|n| n.pressure))?;
                    put(&pg, "nodal_pressure", &col(&|n| n.nodal_pressure))?;
                    // Current position of the multiplier nodes (they slide under finite sliding).
                    let xy: Vec<f64> = field.iter().flat_map(|n| [n.position.x, n.position.y]).collect();
                    put(&pg, "position", &array2(nl, 2, xy))?;
                    if c.mu > 0.0 {
                        // Shear lambda_t, slip of the step and accumulated slip (lengths), status
                        // 0 open / 1 stick / 2 slip.
                        put(&pg, "shear", &col(&|n| n.shear))?;
                        put(&pg, "nodal_shear", &col(&|n| n.nodal_shear))?;
                        put(&pg, "slip", &col(&|n| n.slip))?;
                        put(&pg, "accumulated_slip", &col(&|n| n.accumulated_slip))?;
                        let status: Array1<u8> = field.iter().map(|n| n.status.code()).collect();
                        put(&pg, "status", &status)?;
                    }
                }
                cg.new_dataset_builder().with_data(&Array1::from(vec![state.dissipation])).create("dissipation")?;
            }
            if checkpoint {
                // The oldest kept checkpoint goes first: the new one can take its space.
                if self.keep_checkpoints > 0 && self.checkpoints.len() >= self.keep_checkpoints {
                    if let Some(old) = self.checkpoints.pop_front() {
                        file.unlink(&format!("steps/{old:06}/checkpoint"))?;
                    }
                }
                checkpoint::write(&g, state, model)?;
                self.checkpoints.push_back(report.step);
            }
            Ok(())
        })();
        res.map_err(h5err(&self.partial_path, &format!("writing step {}", report.step)))?;
        // Flushed to disk with every checkpoint and full-field step (a killed run keeps them),
        // and at least once a second: flushing every short step would dominate long runs.
        if checkpoint || full || self.last_flush.elapsed().as_secs_f64() >= 1.0 {
            file.flush().map_err(h5err(&self.partial_path, &format!("flushing step {}", report.step)))?;
            self.last_flush = std::time::Instant::now();
        }
        if checkpoint {
            self.write_side_checkpoint(report, state, model)?;
        }
        self.append_contact_rows(model, &fields, report)?;
        self.steps.push((report.step, report.time, report.load_factor, full));
        Ok(())
    }

    /// The latest checkpoint alone in `<partial>.checkpoint`: written to a temporary file, then
    /// renamed over the previous one (atomic), so a kill at any moment leaves a whole one.
    fn write_side_checkpoint(&self, report: &StepReport, state: &SimState, model: &Model) -> Result<(), OutputError> {
        let side = checkpoint::side_path(&self.partial_path);
        let tmp = PathBuf::from(format!("{}.tmp", side.display()));
        let res: hdf5::Result<()> = (|| {
            let f = hdf5::File::create(&tmp)?;
            let g = f.create_group("steps")?.create_group(&format!("{:06}", report.step))?;
            write_attr(&g, "time", &report.time)?;
            write_attr(&g, "load_factor", &report.load_factor)?;
            checkpoint::write(&g, state, model)?;
            f.flush()
        })();
        res.map_err(h5err(&tmp, &format!("writing the checkpoint of step {}", report.step)))?;
        std::fs::rename(&tmp, &side).map_err(|e| OutputError::Io { path: side.display().to_string(), source: e })
    }

    /// Nodal, cell and point fields of a step.
    fn write_fields(
        g: &hdf5::Group,
        model: &Model,
        disc: &Discretisation,
        state: &SimState,
        reactions: &[f64],
    ) -> hdf5::Result<()> {
        let fields = nodal_fields(model, disc, state);
        for b in &model.bodies {
            let bg = g.create_group(&b.name)?;
            let (n0, n) = (b.node_offset, b.mesh.num_nodes());
            let (c0, nc) = (b.element_offset, b.mesh.num_cells());
            let disp: Vec<f64> = (n0..n0 + n).flat_map(|i| [state.u[2 * i], state.u[2 * i + 1], 0.0]).collect();
            put(&bg, "displacement", &array2(n, 3, disp))?;
            let s: Vec<f64> = fields.stress[n0..n0 + n].iter().flat_map(|s| *s).collect();
            put(&bg, "stress", &array2(n, 4, s))?;
            let t: Vec<f64> = fields.stress[n0..n0 + n].iter().flat_map(tensor6).collect();
            put(&bg, "stress_tensor", &array2(n, 6, t))?;
            put(&bg, "von_mises", &Array1::from(fields.von_mises[n0..n0 + n].to_vec()))?;
            put(&bg, "eqps", &Array1::from(fields.eqps[n0..n0 + n].to_vec()))?;
            put(&bg, "reaction", &array2(n, 2, reactions[2 * n0..2 * (n0 + n)].to_vec()))?;
            let cs: Vec<f64> = fields.cell_stress[c0..c0 + nc].iter().flat_map(|s| *s).collect();
            put(&bg, "cell_stress", &array2(nc, 4, cs))?;
            let ct: Vec<f64> = fields.cell_stress[c0..c0 + nc].iter().flat_map(tensor6).collect();
            put(&bg, "cell_stress_tensor", &array2(nc, 6, ct))?;
            put(&bg, "cell_eqps", &Array1::from(fields.cell_eqps[c0..c0 + nc].to_vec()))?;
        }
        let pg = g.create_group("points")?;
        let np = state.stress.len();
        let s: Vec<f64> = state.stress.iter().flat_map(|s| [s[0], s[1], s[2], s[3]]).collect();
        put(&pg, "stress", &array2(np, 4, s))?;
        if model.bands.iter().any(|b| b.is_some()) {
            // Cut band cells of bodies without history take exact rules: their points move.
            let xy: Vec<f64> = disc.point_coords(model).iter().flat_map(|p| [p.x, p.y]).collect();
            put(&pg, "coordinates", &array2(np, 2, xy))?;
        }
        let el = &model.elements;
        let mut eqps = vec![0.0; np];
        for e in 0..el.len() {
            if el.state_offset[e + 1] > el.state_offset[e] {
                for q in 0..el.point_offset[e + 1] - el.point_offset[e] {
                    eqps[el.point_offset[e] + q] = state.history[el.state_offset[e] + q].alpha;
                }
            }
        }
        put(&pg, "eqps", &Array1::from(eqps))
    }

    /// Contact profile rows of one step, appended to the CSV (flushed: a crashed run keeps them).
    fn append_contact_rows(
        &mut self,
        model: &Model,
        fields: &[Vec<crate::contact::ContactNodeState>],
        report: &StepReport,
    ) -> Result<(), OutputError> {
        let Some((out, partial, _)) = self.contact_csv.as_mut() else { return Ok(()) };
        let mut rows = String::new();
        for (c, field) in model.initial().contact.pairs.iter().zip(fields) {
            for n in field {
                let _ = writeln!(
                    rows,
                    "{},{:e},{},{:e},{:e},{:e},{:e},{:e},{:e},{},{},{},{:e},{:e}",
                    report.step,
                    report.time,
                    c.name,
                    n.position.x,
                    n.position.y,
                    n.pressure,
                    n.shear,
                    n.slip,
                    n.accumulated_slip,
                    n.status.code(),
                    report.cycle,
                    report.increment,
                    n.nodal_pressure,
                    n.nodal_shear
                );
            }
        }
        use std::io::Write as _;
        out.write_all(rows.as_bytes())
            .and_then(|_| out.flush())
            .map_err(|e| OutputError::Io { path: partial.display().to_string(), source: e })
    }

    /// Closes the file; `completed` records whether the run finished. A finished run (or a
    /// stopped one whose name is free) is renamed into place and gets its XDMF; a stopped run
    /// never replaces an existing result: it stays `<name>.h5.partial` (returned), which
    /// `--restart` reads. Contact profiles go to `<name>_contact.csv` (step, time, pair, current
    /// node position, pressure, shear, slip of the step, accumulated slip, status 0 open / 1
    /// stick / 2 slip, cycle, increment, nodal pressure, nodal shear).
    pub fn finish(mut self, completed: bool) -> Result<PathBuf, OutputError> {
        if let Some(file) = self.file.take() {
            let res: hdf5::Result<()> = (|| {
                let t: Vec<f64> = self.steps.iter().map(|s| s.1).collect();
                let l: Vec<f64> = self.steps.iter().map(|s| s.2).collect();
                file.new_dataset_builder().with_data(&Array1::from(t)).create("time")?;
                file.new_dataset_builder().with_data(&Array1::from(l)).create("load_factor")?;
                file.attr("completed")?.write_scalar(&(completed as u8))?;
                write_attr(&file, "num_steps", &(self.steps.len() as u64))?;
                file.flush()?;
                Ok(())
            })();
            res.map_err(h5err(&self.partial_path, "closing the file"))?;
            drop(file);
        }
        let io = |p: &Path| {
            let p = p.display().to_string();
            move |e| OutputError::Io { path: p, source: e }
        };
        let keep_partial = !completed && self.final_path.exists();
        if let Some((mut out, partial, csv)) = self.contact_csv.take() {
            use std::io::Write as _;
            out.flush().map_err(io(&partial))?;
            drop(out);
            if !keep_partial {
                std::fs::rename(&partial, &csv).map_err(io(&csv))?;
            }
        }
        if keep_partial {
            return Ok(self.partial_path.clone());
        }
        // The result holds every checkpoint: the side copy of the last one has done its job.
        let side = checkpoint::side_path(&self.partial_path);
        if side.exists() {
            std::fs::remove_file(&side).map_err(io(&side))?;
        }
        // XDMF first to its own partial, then both renamed: the XDMF beside a result always
        // describes that result.
        let xdmf_partial = PathBuf::from(format!("{}.partial", self.xdmf_path.display()));
        std::fs::write(&xdmf_partial, self.xdmf_text()).map_err(io(&xdmf_partial))?;
        std::fs::rename(&self.partial_path, &self.final_path).map_err(io(&self.final_path))?;
        std::fs::rename(&xdmf_partial, &self.xdmf_path).map_err(io(&self.xdmf_path))?;
        Ok(self.final_path.clone())
    }

    /// The XDMF companion: one temporal collection over the output steps (every step up to
    /// [`XDMF_MAX_STEPS`], otherwise evenly picked ones plus every step with full fields and
    /// every wear update). At each time ParaView shows the bodies with the fields of the latest
    /// step that holds them (displacement, stress as a symmetric tensor, von Mises, plastic
    /// strain, reactions, material fraction of cut cells), each contact's multiplier nodes as a
    /// polyline with that step's pressure, shear, slip and status, and each wearing surface as
    /// it stands after the latest wear update, with its depth.
    fn xdmf_text(&self) -> String {
        let h5 = self.final_path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let mut x = String::new();
        let _ = writeln!(x, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>");
        let _ = writeln!(x, "  <Grid Name=\"run\" GridType=\"Collection\" CollectionType=\"Temporal\">");
        let rows = self.steps.len();
        let wear = self.series.wear.as_ref().filter(|w| w.rows > 0);
        let wear_steps: &[usize] = wear.map(|w| w.row_steps.as_slice()).unwrap_or(&[]);
        let every = rows.div_ceil(XDMF_MAX_STEPS).max(1);
        let (mut fields_step, mut wear_row) = (None, None);
        for (k, &(step, time, _, full)) in self.steps.iter().enumerate() {
            if full {
                fields_step = Some(step);
            }
            let updated = wear_steps.binary_search(&step).ok();
            if updated.is_some() {
                wear_row = updated;
            }
            if !(k % every == 0 || k + 1 == rows || full || updated.is_some()) {
                continue;
            }
            let _ = writeln!(x, "   <Grid Name=\"step_{step}\" GridType=\"Collection\" CollectionType=\"Spatial\">\n    <Time Value=\"{time:e}\"/>");
            if let Some(f) = fields_step {
                self.xdmf_bodies(&mut x, &h5, f);
            }
            for (name, l, friction) in &self.contact_meta {
                let series = format!("/series/contacts/{name}");
                let mut attrs = vec![("pressure", "Float", 8), ("nodal_pressure", "Float", 8)];
                if *friction {
                    attrs.extend([
                        ("shear", "Float", 8),
                        ("nodal_shear", "Float", 8),
                        ("slip", "Float", 8),
                        ("accumulated_slip", "Float", 8),
                        ("status", "UChar", 1),
                    ]);
                }
                let attrs: Vec<(&str, String)> = attrs
                    .into_iter()
                    .map(|(a, ty, precision)| {
                        let path = format!("{series}/{a}");
                        (a, slab(&XdmfDataset { h5: &h5, path, rows, rest: &[*l], ty, precision }, k))
                    })
                    .collect();
                let geometry = slab(&XdmfDataset::floats(&h5, format!("{series}/position"), rows, &[*l, 2]), k);
                let grid = PolylineGrid {
                    name,
                    segments_path: &format!("/mesh/contacts/{name}/segments"),
                    segments: l.saturating_sub(1),
                    geometry: &geometry,
                    attrs: &attrs,
                };
                polyline_grid(&mut x, &h5, grid);
            }
            if let (Some(w), Some(r)) = (wear, wear_row) {
                for (name, v, segments) in &w.meta {
                    let geometry =
                        slab(&XdmfDataset::floats(&h5, format!("/wear/{name}/vertices"), w.rows, &[*v, 2]), r);
                    let depth = slab(&XdmfDataset::floats(&h5, format!("/wear/{name}/depth"), w.rows, &[*v]), r);
                    let grid = PolylineGrid {
                        name,
                        segments_path: &format!("/wear/{name}/segments"),
                        segments: *segments,
                        geometry: &geometry,
                        attrs: &[("depth", depth)],
                    };
                    polyline_grid(&mut x, &h5, grid);
                }
            }
            if k + 1 == rows {
                if let Some((_, retired, _)) = wear.and_then(|w| w.fatigue.as_ref()) {
                    fatigue_points_grid(&mut x, &h5, retired.size());
                }
            }
            let _ = writeln!(x, "   </Grid>");
        }
        let _ = writeln!(x, "  </Grid>\n </Domain>\n</Xdmf>");
        x
    }

    /// The bodies' grids of one step with full fields.
    fn xdmf_bodies(&self, x: &mut String, h5: &str, step: usize) {
        let item = |dims: String, ty: &str, path: String| {
            format!("<DataItem Dimensions=\"{dims}\" NumberType=\"{ty}\" Precision=\"8\" Format=\"HDF\">{h5}:{path}</DataItem>")
        };
        for (name, n, nc, tl) in &self.body_meta {
            let sg = format!("/steps/{step:06}/{name}");
            let _ = writeln!(x, "    <Grid Name=\"{name}\" GridType=\"Uniform\">");
            let _ = writeln!(
                x,
                "     <Topology TopologyType=\"Mixed\" NumberOfElements=\"{nc}\">{}</Topology>",
                item(format!("{tl}"), "Int", format!("/mesh/{name}/topology"))
            );
            let _ = writeln!(
                x,
                "     <Geometry GeometryType=\"XY\">{}</Geometry>",
                item(format!("{n} 2"), "Float", format!("/mesh/{name}/nodes"))
            );
            for (attr, data, kind, comps, centre, count) in [
                ("displacement", "displacement", "Vector", 3, "Node", n),
                ("stress", "stress_tensor", "Tensor6", 6, "Node", n),
                ("von_mises", "von_mises", "Scalar", 1, "Node", n),
                ("eqps", "eqps", "Scalar", 1, "Node", n),
                ("reaction", "reaction", "Vector", 2, "Node", n),
                ("cell_stress", "cell_stress_tensor", "Tensor6", 6, "Cell", nc),
                ("cell_eqps", "cell_eqps", "Scalar", 1, "Cell", nc),
            ] {
                let dims = if comps == 1 { format!("{count}") } else { format!("{count} {comps}") };
                let _ = writeln!(
                    x,
                    "     <Attribute Name=\"{attr}\" AttributeType=\"{kind}\" Center=\"{centre}\">{}</Attribute>",
                    item(dims, "Float", format!("{sg}/{data}"))
                );
            }
            if self.cut_bodies.contains(name) {
                let at = if self.moving_bodies.contains(name) {
                    format!("{sg}/material_fraction")
                } else {
                    format!("/mesh/{name}/material_fraction")
                };
                let _ = writeln!(x, "     <Attribute Name=\"material_fraction\" AttributeType=\"Scalar\" Center=\"Cell\">{}</Attribute>", item(format!("{nc}"), "Float", at));
            }
            let _ = writeln!(x, "    </Grid>");
        }
    }
}

/// Largest number of evenly picked output steps the XDMF lists (each is a few kilobytes of
/// XML); steps with full fields and wear updates are always listed.
const XDMF_MAX_STEPS: usize = 2000;

/// An XDMF hyperslab: row `row` of a series.
/// A dataset of shape `(rows, rest...)` in the result file `h5`, of XDMF number type `ty` and
/// `precision` bytes.
struct XdmfDataset<'a> {
    h5: &'a str,
    path: String,
    rows: usize,
    rest: &'a [usize],
    ty: &'a str,
    precision: usize,
}

impl<'a> XdmfDataset<'a> {
    /// A dataset of f64 values.
    fn floats(h5: &'a str, path: String, rows: usize, rest: &'a [usize]) -> Self {
        XdmfDataset { h5, path, rows, rest, ty: "Float", precision: 8 }
    }
}

fn slab(data: &XdmfDataset<'_>, row: usize) -> String {
    let XdmfDataset { h5, ref path, rows, rest, ty, precision } = *data;
    let dims: Vec<String> = rest.iter().map(|d| d.to_string()).collect();
    let dims = dims.join(" ");
    let rank = rest.len() + 1;
    let zeros = " 0".repeat(rest.len());
    let ones = " 1".repeat(rest.len());
    format!(
        "<DataItem ItemType=\"HyperSlab\" Dimensions=\"{dims}\" Type=\"HyperSlab\"><DataItem Dimensions=\"3 {rank}\" \
         Format=\"XML\">{row}{zeros} 1{ones} 1 {dims}</DataItem><DataItem Dimensions=\"{rows} {dims}\" NumberType=\"{ty}\" \
         Precision=\"{precision}\" Format=\"HDF\">{h5}:{path}</DataItem></DataItem>"
    )
}

/// The fatigue points of the run's end (`/wear/fatigue`, the latest values) as a point cloud:
/// damage, SWT, critical plane angle (degrees from x in ParaView: radians stored), life and
/// whether the wear cut them away.
fn fatigue_points_grid(x: &mut String, h5: &str, np: usize) {
    let item = |path: &str, dims: &str, ty: &str, precision: usize| {
        format!("<DataItem Dimensions=\"{dims}\" NumberType=\"{ty}\" Precision=\"{precision}\" Format=\"HDF\">{h5}:/wear/fatigue/{path}</DataItem>")
    };
    let _ = writeln!(x, "    <Grid Name=\"fatigue\" GridType=\"Uniform\">");
    let _ = writeln!(x, "     <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{np}\" NodesPerElement=\"1\"/>");
    let _ = writeln!(
        x,
        "     <Geometry GeometryType=\"XY\">{}</Geometry>",
        item("position", &format!("{np} 2"), "Float", 8)
    );
    for (name, ty, precision) in [
        ("damage", "Float", 8),
        ("swt", "Float", 8),
        ("angle", "Float", 8),
        ("life", "Float", 8),
        ("retired", "UChar", 1),
    ] {
        let data = item(name, &np.to_string(), ty, precision);
        let _ =
            writeln!(x, "     <Attribute Name=\"{name}\" AttributeType=\"Scalar\" Center=\"Node\">{data}</Attribute>");
    }
    let _ = writeln!(x, "    </Grid>");
}

/// A polyline grid of the XDMF: its segments (`segments` of them, at `segments_path`), its
/// geometry and node attributes as data items.
struct PolylineGrid<'a> {
    name: &'a str,
    segments_path: &'a str,
    segments: usize,
    geometry: &'a str,
    attrs: &'a [(&'a str, String)],
}

/// Writes a polyline grid of the result file `h5` into `x`.
fn polyline_grid(x: &mut String, h5: &str, grid: PolylineGrid<'_>) {
    let PolylineGrid { name, segments_path, segments, geometry, attrs } = grid;
    let _ = writeln!(x, "    <Grid Name=\"{name}\" GridType=\"Uniform\">");
    let _ = writeln!(
        x,
        "     <Topology TopologyType=\"Polyline\" NodesPerElement=\"2\" NumberOfElements=\"{segments}\"><DataItem Dimensions=\"{segments} 2\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">{h5}:{segments_path}</DataItem></Topology>"
    );
    let _ = writeln!(x, "     <Geometry GeometryType=\"XY\">{geometry}</Geometry>");
    for (attr, item) in attrs {
        let _ =
            writeln!(x, "     <Attribute Name=\"{attr}\" AttributeType=\"Scalar\" Center=\"Node\">{item}</Attribute>");
    }
    let _ = writeln!(x, "    </Grid>");
}

/// The scar of every wearing surface of a wear run's result file at the first wear update at
/// or after each of the cycles `at` (a text table): max depth, scar width (where the depth is at
/// least 1% of its maximum), worn area, and the wear balance `|worn area - k work| / worn area`.
pub fn wear_table(path: &Path, model: &Model, at: &[u64]) -> Result<String, OutputError> {
    use std::fmt::Write as _;
    let err = |e: hdf5::Error| OutputError::Hdf5 {
        path: path.display().to_string(),
        what: "reading /wear".into(),
        msg: e.to_string(),
    };
    let f = hdf5::File::open(path).map_err(err)?;
    let cycles = f.dataset("wear/cycle").and_then(|d| d.read_raw::<u64>()).map_err(err)?;
    let mut t = String::new();
    let _ = writeln!(t, "| cycle | surface | max depth (um) | scar width (um) | worn area (um^2) | balance |");
    let _ = writeln!(t, "|---|---|---|---|---|---|");
    for &n in at {
        let Some(row) = cycles.iter().position(|&c| c >= n) else { continue };
        for ws in &model.wear.surfaces {
            let g = |name: &str| format!("wear/{}/{name}", ws.name);
            let depth = f
                .dataset(&g("depth"))
                .and_then(|d| d.read_slice_2d::<f64, _>(ndarray::s![row..row + 1, ..]))
                .map_err(err)?;
            let verts = f
                .dataset(&g("vertices"))
                .and_then(|d| d.read_slice::<f64, _, ndarray::Ix3>(ndarray::s![row..row + 1, .., ..]))
                .map_err(err)?;
            let area = f.dataset(&g("worn_area")).and_then(|d| d.read_raw::<f64>()).map_err(err)?[row];
            let work = f.dataset(&g("work")).and_then(|d| d.read_raw::<f64>()).map_err(err)?[row];
            let d: Vec<f64> = depth.iter().copied().collect();
            let max = d.iter().fold(0.0_f64, |a, &b| a.max(b));
            // Arc length of the stretch whose depth is at least 1% of the maximum.
            let mut width = 0.0;
            for i in 0..d.len().saturating_sub(1) {
                if d[i] >= 0.01 * max && d[i + 1] >= 0.01 * max {
                    let (dx, dy) = (verts[[0, i + 1, 0]] - verts[[0, i, 0]], verts[[0, i + 1, 1]] - verts[[0, i, 1]]);
                    width += (dx * dx + dy * dy).sqrt();
                }
            }
            let balance = if area > 0.0 { (area - ws.coefficient * work).abs() / area } else { 0.0 };
            let _ = writeln!(
                t,
                "| {} | {} | {:.4} | {:.1} | {:.2} | {:.1e} |",
                cycles[row],
                ws.name,
                max * 1e3,
                width * 1e3,
                area * 1e6,
                balance
            );
        }
    }
    Ok(t)
}
