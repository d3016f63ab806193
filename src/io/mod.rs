//! Output: HDF5 result files with an XDMF companion for ParaView.
//!
//! Layout of `<name>.h5` (all arrays row-major, f64 unless noted):
//! * `/` attributes: `format` ("mortex-results"), `version`, `case`, `hypothesis`, `completed`
//!   (1 when the run finished), `num_steps`.
//! * `/mesh/<body>/nodes` `(n, 2)`, `/mesh/<body>/cells` `(c, 4)` i64 node ids (-1 pads a
//!   triangle), `/mesh/<body>/topology` i64 XDMF mixed topology, `/mesh/points` `(p, 2)`
//!   integration-point coordinates (all bodies, point order).
//! * `/steps/NNNNNN/` attributes `time`, `load_factor`, `iterations`, `cutbacks`,
//!   `residual`; per body `displacement` `(n, 3)` (z = 0, for ParaView's warp), `stress` `(n, 4)`
//!   nodal `[xx, yy, zz, xy]` (lumped L2 projection), `von_mises` `(n)`, `eqps` `(n)`,
//!   `reaction` `(n, 2)`, `cell_stress` `(c, 4)`, `cell_eqps` `(c)`; `/steps/NNNNNN/points/stress`
//!   `(p, 4)` and `eqps` `(p)` at the integration points.
//! * `/time`, `/load_factor` `(steps)`: written when the file is closed.
//! * Cut host bodies: `/mesh/<body>/material_fraction` `(c)`. Ties: `/mesh/ties/<tie>/points`,
//!   `normals` `(l, 2)` of the multiplier nodes (outward normal of the patch) and per step
//!   `/steps/NNNNNN/ties/<tie>/traction` `(l, 2)`: the traction on the patch, `t = sigma n = -lambda`.
//! * Contacts: `/mesh/contacts/<pair>/points` `(l, 2)` (attribute `mu`) and per step
//!   `/steps/NNNNNN/contacts/<pair>/pressure` `(l)` (`p = -lambda_n >= 0`), `position` `(l, 2)`
//!   (current position of the multiplier nodes); with friction also
//!   `shear` (`lambda_t` along `t = n` turned +90 degrees), `slip` (slip of the step),
//!   `accumulated_slip` and `status` (0 open, 1 stick, 2 slip); `/steps/NNNNNN/contacts/
//!   dissipation` (frictional energy dissipated so far, per unit thickness).
//!
//! * Checkpoints (every output step by default): `/steps/NNNNNN/checkpoint/`, the whole
//!   simulation state (see [`checkpoint`]); `restarted_from`, `restart_step` root attributes on
//!   a run that resumed from one.
//!
//! The file is written as `<name>.h5.partial` and renamed when closed, so an earlier result is
//! never replaced by a half-written file; the XDMF is rewritten after every step.

pub mod checkpoint;
pub mod plot;

use crate::analysis::StepReport;
use crate::model::Model;
use crate::post::nodal_fields;
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
    steps: Vec<(usize, f64, f64)>,
    body_meta: Vec<(String, usize, usize, usize)>, // name, nodes, cells, topology length
    cut_bodies: Vec<String>,
    /// Contact profiles of every step (CSV rows), written beside the HDF5 file on `finish`.
    contact_csv: String,
    /// A checkpoint every this many output steps (0: none).
    checkpoint_every: usize,
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
        let mut w = ResultWriter {
            file: None,
            final_path: path.to_path_buf(),
            partial_path: partial_path.clone(),
            xdmf_path,
            steps: vec![],
            body_meta: vec![],
            cut_bodies: vec![],
            contact_csv: String::new(),
            checkpoint_every: 1,
        };
        let res: hdf5::Result<()> = (|| {
            write_str_attr(&file, "format", "mortex-results")?;
            write_str_attr(&file, "version", env!("CARGO_PKG_VERSION"))?;
            write_str_attr(&file, "case", case_name)?;
            write_str_attr(&file, "hypothesis", &format!("{:?}", model.hypothesis))?;
            write_attr(&file, "completed", &0u8)?;
            let mesh = file.create_group("mesh")?;
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
                w.body_meta.push((b.name.clone(), n, b.mesh.num_cells(), topo.len()));
                let bi = model.bodies.iter().position(|x| x.name == b.name).unwrap_or(0);
                if let Some(cut) = &model.cuts[bi] {
                    g.new_dataset_builder()
                        .with_data(&Array1::from(cut.cell_fraction.clone()))
                        .create("material_fraction")?;
                    w.cut_bodies.push(b.name.clone());
                }
            }
            if !model.contacts.is_empty() {
                let cg = mesh.create_group("contacts")?;
                for c in &model.contacts {
                    let m = &c.multipliers;
                    let xy: Vec<f64> = m.points.iter().flat_map(|p| [p.x, p.y]).collect();
                    let pg = cg.create_group(&c.name)?;
                    pg.new_dataset_builder().with_data(&array2(m.num_nodes, 2, xy)).create("points")?;
                    write_attr(&pg, "mu", &c.mu)?;
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
            let pts = model.point_coords();
            let xy: Vec<f64> = pts.iter().flat_map(|p| [p.x, p.y]).collect();
            mesh.new_dataset_builder().with_data(&array2(pts.len(), 2, xy)).create("points")?;
            file.create_group("steps")?;
            Ok(())
        })();
        res.map_err(h5err(&partial_path, "writing the mesh"))?;
        w.file = Some(file);
        Ok(w)
    }

    /// Writes a checkpoint (see [`checkpoint`]) every `every` output steps (0: never; default 1).
    pub fn set_checkpoint_every(&mut self, every: usize) {
        self.checkpoint_every = every;
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

    /// Appends one converged step (and its checkpoint when the step is a multiple of the
    /// checkpoint interval).
    pub fn write_step(
        &mut self,
        model: &Model,
        report: &StepReport,
        state: &SimState,
        reactions: &[f64],
    ) -> Result<(), OutputError> {
        let Some(file) = self.file.as_ref() else {
            return Ok(());
        };
        let fields = nodal_fields(model, state);
        let res: hdf5::Result<()> = (|| {
            let g = file.group("steps")?.create_group(&format!("{:06}", report.step))?;
            write_attr(&g, "time", &report.time)?;
            write_attr(&g, "load_factor", &report.load_factor)?;
            write_attr(&g, "iterations", &(report.iterations as u64))?;
            write_attr(&g, "cutbacks", &(report.cutbacks as u64))?;
            write_attr(&g, "residual", &report.residual)?;
            for b in &model.bodies {
                let bg = g.create_group(&b.name)?;
                let (n0, n) = (b.node_offset, b.mesh.num_nodes());
                let (c0, nc) = (b.element_offset, b.mesh.num_cells());
                let disp: Vec<f64> = (n0..n0 + n).flat_map(|i| [state.u[2 * i], state.u[2 * i + 1], 0.0]).collect();
                bg.new_dataset_builder().with_data(&array2(n, 3, disp)).create("displacement")?;
                let s: Vec<f64> = fields.stress[n0..n0 + n].iter().flat_map(|s| *s).collect();
                bg.new_dataset_builder().with_data(&array2(n, 4, s)).create("stress")?;
                bg.new_dataset_builder()
                    .with_data(&Array1::from(fields.von_mises[n0..n0 + n].to_vec()))
                    .create("von_mises")?;
                bg.new_dataset_builder().with_data(&Array1::from(fields.eqps[n0..n0 + n].to_vec())).create("eqps")?;
                let r: Vec<f64> = reactions[2 * n0..2 * (n0 + n)].to_vec();
                bg.new_dataset_builder().with_data(&array2(n, 2, r)).create("reaction")?;
                let cs: Vec<f64> = fields.cell_stress[c0..c0 + nc].iter().flat_map(|s| *s).collect();
                bg.new_dataset_builder().with_data(&array2(nc, 4, cs)).create("cell_stress")?;
                bg.new_dataset_builder()
                    .with_data(&Array1::from(fields.cell_eqps[c0..c0 + nc].to_vec()))
                    .create("cell_eqps")?;
            }
            if !model.ties.is_empty() {
                let tg = g.create_group("ties")?;
                for t in &model.ties {
                    let nl = t.multipliers.num_nodes;
                    let tr: Vec<f64> = (0..2 * nl).map(|k| -state.multipliers[t.first_row + k]).collect();
                    tg.create_group(&t.name)?.new_dataset_builder().with_data(&array2(nl, 2, tr)).create("traction")?;
                }
            }
            if !model.contacts.is_empty() {
                let cg = g.create_group("contacts")?;
                let nt = model.constraints.len();
                let nn = model.contact_rows.len();
                for c in &model.contacts {
                    let nl = c.multipliers.num_nodes;
                    let p: Vec<f64> = (0..nl).map(|l| -state.multipliers[nt + c.first_row + l]).collect();
                    let pg = cg.create_group(&c.name)?;
                    pg.new_dataset_builder().with_data(&Array1::from(p)).create("pressure")?;
                    // Current position of the multiplier nodes (they slide under finite sliding).
                    let xy: Vec<f64> = c
                        .multiplier_nodes()
                        .iter()
                        .zip(&c.multipliers.points)
                        .flat_map(|(&n, x)| [x.x + state.u[2 * n], x.y + state.u[2 * n + 1]])
                        .collect();
                    pg.new_dataset_builder().with_data(&array2(nl, 2, xy)).create("position")?;
                    if c.mu > 0.0 {
                        // Per node: shear lambda_t, slip of the step and accumulated slip (weighted
                        // slips divided by int Phi: lengths), status 0 open / 1 stick / 2 slip.
                        let at = |f: &dyn Fn(usize) -> f64| -> Vec<f64> {
                            c.friction_row.iter().map(|r| r.map_or(0.0, f)).collect()
                        };
                        let phi = |j: usize| model.contact_phi[model.friction_normal[j]];
                        let shear = at(&|j| state.multipliers[nt + nn + j]);
                        let slip = at(&|j| state.slip_increment[j] / phi(j));
                        let acc = at(&|j| state.accumulated_slip[j] / phi(j));
                        let status: Vec<u8> =
                            c.friction_row.iter().map(|r| r.map_or(0, |j| state.friction_status[j])).collect();
                        pg.new_dataset_builder().with_data(&Array1::from(shear)).create("shear")?;
                        pg.new_dataset_builder().with_data(&Array1::from(slip)).create("slip")?;
                        pg.new_dataset_builder().with_data(&Array1::from(acc)).create("accumulated_slip")?;
                        pg.new_dataset_builder().with_data(&Array1::from(status)).create("status")?;
                    }
                }
                cg.new_dataset_builder().with_data(&Array1::from(vec![state.dissipation])).create("dissipation")?;
            }
            let pg = g.create_group("points")?;
            let np = state.stress.len();
            let s: Vec<f64> = state.stress.iter().flat_map(|s| [s[0], s[1], s[2], s[3]]).collect();
            pg.new_dataset_builder().with_data(&array2(np, 4, s)).create("stress")?;
            let el = &model.elements;
            let mut eqps = vec![0.0; np];
            for e in 0..el.len() {
                if el.state_offset[e + 1] > el.state_offset[e] {
                    for q in 0..el.point_offset[e + 1] - el.point_offset[e] {
                        eqps[el.point_offset[e] + q] = state.history[el.state_offset[e] + q].alpha;
                    }
                }
            }
            pg.new_dataset_builder().with_data(&Array1::from(eqps)).create("eqps")?;
            if self.checkpoint_every > 0 && report.step % self.checkpoint_every == 0 {
                checkpoint::write(&g, state)?;
            }
            file.flush()?;
            Ok(())
        })();
        res.map_err(h5err(&self.partial_path, &format!("writing step {}", report.step)))?;
        self.append_contact_rows(model, state, report);
        self.steps.push((report.step, report.time, report.load_factor));
        self.write_xdmf()
    }

    /// Contact profile rows of one step: every multiplier node of every pair.
    fn append_contact_rows(&mut self, model: &Model, state: &SimState, report: &StepReport) {
        if model.contacts.is_empty() {
            return;
        }
        if self.contact_csv.is_empty() {
            self.contact_csv.push_str("step,time,pair,x,y,pressure,shear,slip,accumulated_slip,status\n");
        }
        let (nt, nn) = (model.constraints.len(), model.contact_rows.len());
        for c in &model.contacts {
            let nodes = c.multiplier_nodes();
            for l in 0..c.multipliers.num_nodes {
                let (p0, n) = (c.multipliers.points[l], nodes[l]);
                let x = nalgebra::Point2::new(p0.x + state.u[2 * n], p0.y + state.u[2 * n + 1]);
                let p = -state.multipliers[nt + c.first_row + l];
                let (q, ds, acc, st) = c.friction_row[l].map_or((0.0, 0.0, 0.0, 0), |j| {
                    let phi = model.contact_phi[model.friction_normal[j]];
                    (
                        state.multipliers[nt + nn + j],
                        state.slip_increment[j] / phi,
                        state.accumulated_slip[j] / phi,
                        state.friction_status[j],
                    )
                });
                let _ = writeln!(
                    self.contact_csv,
                    "{},{:e},{},{:e},{:e},{:e},{:e},{:e},{:e},{}",
                    report.step, report.time, c.name, x.x, x.y, p, q, ds, acc, st
                );
            }
        }
    }

    /// Closes the file and renames it into place; `completed` records whether the run finished.
    /// Contact profiles go to `<name>_contact.csv` beside it (step, time, pair, current node position,
    /// pressure, shear, slip of the step, accumulated slip, status 0 open / 1 stick / 2 slip).
    pub fn finish(mut self, completed: bool) -> Result<PathBuf, OutputError> {
        if !self.contact_csv.is_empty() {
            let stem = self.final_path.with_extension("");
            let csv = PathBuf::from(format!("{}_contact.csv", stem.display()));
            let partial = PathBuf::from(format!("{}.partial", csv.display()));
            let io = |p: &Path| {
                let p = p.display().to_string();
                move |e| OutputError::Io { path: p, source: e }
            };
            std::fs::write(&partial, &self.contact_csv).map_err(io(&partial))?;
            std::fs::rename(&partial, &csv).map_err(io(&csv))?;
        }
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
        std::fs::rename(&self.partial_path, &self.final_path)
            .map_err(|e| OutputError::Io { path: self.final_path.display().to_string(), source: e })?;
        self.write_xdmf()?;
        Ok(self.final_path.clone())
    }

    fn write_xdmf(&self) -> Result<(), OutputError> {
        let h5name = self.final_path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let mut x = String::new();
        let _ = writeln!(x, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n  <Grid Name=\"series\" GridType=\"Collection\" CollectionType=\"Temporal\">");
        let item = |dims: String, ty: &str, path: String| {
            format!("<DataItem Dimensions=\"{dims}\" NumberType=\"{ty}\" Precision=\"8\" Format=\"HDF\">{h5name}:{path}</DataItem>")
        };
        for &(step, time, _) in &self.steps {
            let _ = writeln!(x, "   <Grid Name=\"step_{step}\" GridType=\"Collection\" CollectionType=\"Spatial\">\n    <Time Value=\"{time:e}\"/>");
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
                for (attr, kind, comps, centre, count) in [
                    ("displacement", "Vector", 3, "Node", n),
                    ("stress", "Vector", 4, "Node", n),
                    ("von_mises", "Scalar", 1, "Node", n),
                    ("eqps", "Scalar", 1, "Node", n),
                    ("reaction", "Vector", 2, "Node", n),
                    ("cell_stress", "Vector", 4, "Cell", nc),
                    ("cell_eqps", "Scalar", 1, "Cell", nc),
                ] {
                    let dims = if comps == 1 { format!("{count}") } else { format!("{count} {comps}") };
                    let _ = writeln!(
                        x,
                        "     <Attribute Name=\"{attr}\" AttributeType=\"{kind}\" Center=\"{centre}\">{}</Attribute>",
                        item(dims, "Float", format!("{sg}/{attr}"))
                    );
                }
                if self.cut_bodies.contains(name) {
                    let _ = writeln!(x, "     <Attribute Name=\"material_fraction\" AttributeType=\"Scalar\" Center=\"Cell\">{}</Attribute>", item(format!("{nc}"), "Float", format!("/mesh/{name}/material_fraction")));
                }
                let _ = writeln!(x, "    </Grid>");
            }
            let _ = writeln!(x, "   </Grid>");
        }
        let _ = writeln!(x, "  </Grid>\n </Domain>\n</Xdmf>");
        std::fs::write(&self.xdmf_path, x)
            .map_err(|e| OutputError::Io { path: self.xdmf_path.display().to_string(), source: e })
    }
}
