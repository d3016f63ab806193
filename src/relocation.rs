//! The node-relocation baseline: a wear case run the way commercial codes run it, for
//! comparison with the MorteX virtual surface.
//!
//! The case wears a real boundary (`[[wear]] body`, `surface`). The MorteX run ([`run_virtual`])
//! moves a virtual copy of that boundary into the host mesh, which never changes. The baseline
//! ([`run_relocated`]) instead moves the mesh: after each wear update (one computed cycle
//! standing for `dN`), the boundary's nodes move by the depth just worn along their inward
//! vertex normals, the interior nodes follow by the harmonic extension of that motion
//! ([`crate::mesh::relocate`]), and the model is built again on the moved mesh, so every update
//! starts with the worn surface on the mesh boundary. The displacement and the multipliers stay
//! on their nodes (the elastic remap of an ALE step: the solution is the next step's starting
//! point only, since the bodies are elastic; a yielding body would need its history remapped
//! between points, which this baseline does not do and refuses).
//!
//! Both runs use the same case, the same contact and wear law and the same explicit jump of
//! `dN` cycles per computed cycle, so where the depth is small against the cells the two agree
//! to the discretisation of the surface; they part where the relocated cells distort.

use crate::case::{parse_with_nodes, CaseError};
use crate::driver::{run, RunOptions};
use crate::mesh::relocate::{harmonic_extension, quality, MeshQuality};
use crate::model::{Discretisation, Model};
use crate::solve::{AnalysisError, StaticAnalysis};
use crate::state::SimState;
use nalgebra::{Point2, Vector2};
use std::path::Path;

/// How the baseline moves the mesh and how often.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelocationParams {
    /// Cycles each computed cycle stands for (the explicit jump of both runs).
    pub cycles_per_update: u64,
    /// Cell layers under the surface whose nodes move (`None`: the whole body).
    pub layers: Option<usize>,
}

impl Default for RelocationParams {
    fn default() -> Self {
        RelocationParams { cycles_per_update: 1, layers: None }
    }
}

/// The worn surface at the end of a wear update.
#[derive(Debug, Clone, PartialEq)]
pub struct WearSnapshot {
    /// Cycles done.
    pub cycle: u64,
    /// Per vertex of the worn boundary (in the order of the boundary's first position): its
    /// reference position before any wear and its accumulated depth.
    pub origin: Vec<Point2<f64>>,
    pub depth: Vec<f64>,
    /// Worn area so far (per unit thickness).
    pub worn_area: f64,
    /// Peak nodal pressure over the increments of the computed cycle.
    pub peak_pressure: f64,
    /// Nodal pressure `-lambda_n / phi` of every contact row at the cycle's last increment
    /// (the stroke back at its centre).
    pub pressure: Vec<f64>,
    /// The relocated mesh's quality after the update (the baseline only).
    pub quality: Option<MeshQuality>,
}

#[derive(Debug, thiserror::Error)]
pub enum RelocationError {
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error("{path}: {key}: {msg}")]
    Input { path: String, key: String, msg: String },
    #[error("cycle {cycle}: {source}")]
    Analysis {
        cycle: u64,
        #[source]
        source: AnalysisError,
    },
}

/// The case text with the run's cycles and its explicit fixed jump set.
fn with_cycles(table: &toml::Table, cycles: u64, jump: u64) -> String {
    let mut t = table.clone();
    let steps = t.entry("steps").or_insert_with(|| toml::Value::Table(Default::default()));
    if let Some(s) = steps.as_table_mut() {
        s.insert("cycles".into(), toml::Value::Integer(cycles as i64));
    }
    let mut j = toml::Table::new();
    j.insert("fixed".into(), toml::Value::Integer(jump as i64));
    j.insert("scheme".into(), toml::Value::String("explicit".into()));
    if let Some(toml::Value::Table(old)) = t.get("cycle_jump") {
        if let Some(s) = old.get("smoothing") {
            j.insert("smoothing".into(), s.clone());
        }
    }
    t.insert("cycle_jump".into(), toml::Value::Table(j));
    t.to_string()
}

/// A wear case to compare: its text as a table, where it is, and its worn body.
pub struct RelocationCase {
    table: toml::Table,
    path: String,
    base: std::path::PathBuf,
    name: String,
    /// The worn body's name and its total cycles.
    body: String,
    cycles: u64,
    cell_size: f64,
}

impl RelocationCase {
    /// Reads a case whose only wearing surface is a real boundary of an elastic body.
    pub fn new(text: &str, path: &str, base: &Path, name: &str) -> Result<Self, RelocationError> {
        let input =
            |key: &str, msg: &str| RelocationError::Input { path: path.into(), key: key.into(), msg: msg.into() };
        let table: toml::Table =
            toml::from_str(text).map_err(|e| CaseError::Toml { path: path.into(), message: e.to_string() })?;
        let case = crate::case::parse(text, path, base, name)?;
        let model = &case.model;
        if model.wear.surfaces.len() != 1 {
            return Err(input("wear", "the comparison needs exactly one wearing surface"));
        }
        let wear = table.get("wear").and_then(|w| w.as_array()).and_then(|w| w.first());
        let Some(body) = wear.and_then(|w| w.get("body")).and_then(|b| b.as_str()).map(str::to_string) else {
            return Err(input(
                "wear[0].body",
                "node relocation moves a real boundary: give body and surface, not a cut",
            ));
        };
        if model.has_plasticity() {
            let msg = "node relocation here remaps no plastic history: elastic bodies only";
            return Err(input("materials", msg));
        }
        let Some(cycle) = model.cycle else {
            return Err(input("steps.cycles", "wear runs are cyclic"));
        };
        let b = model.bodies.iter().position(|b| b.name == body).unwrap_or(0);
        let mesh = &model.bodies[b].mesh;
        let on = surface_nodes(mesh, &vertices(&model.initial_wear_state()));
        let touches = |c: &crate::mesh::Cell| c.nodes().iter().any(|n| on.iter().any(|o| o.0 == *n));
        let cell_size = mesh
            .cells
            .iter()
            .filter(|c| touches(c))
            .flat_map(|c| c.edges().map(|[a, b]| (mesh.nodes[b] - mesh.nodes[a]).norm()).collect::<Vec<_>>())
            .fold(f64::INFINITY, f64::min);
        Ok(RelocationCase {
            cell_size,
            table,
            path: path.into(),
            base: base.to_path_buf(),
            name: name.into(),
            body,
            cycles: cycle.count as u64,
        })
    }

    /// Smallest edge of the cells along the worn boundary: the depth scale at which relocated
    /// cells distort.
    pub fn cell_size(&self) -> f64 {
        self.cell_size
    }

    /// Total cycles of the case.
    pub fn cycles(&self) -> u64 {
        self.cycles
    }

    fn build(&self, cycles: u64, jump: u64, nodes: &[(String, Vec<Point2<f64>>)]) -> Result<Model, RelocationError> {
        let text = with_cycles(&self.table, cycles, jump);
        Ok(parse_with_nodes(&text, &self.path, &self.base, &self.name, nodes)?.model)
    }
}

/// Nodal pressure `-lambda_n / phi` of every contact row of a converged step (0 off contact).
fn pressures(state: &SimState, disc: &Discretisation) -> Vec<f64> {
    let set = &disc.contact;
    (0..set.rows.len())
        .map(|k| if set.phi[k] > 0.0 { -state.multipliers[set.first_multiplier + k] / set.phi[k] } else { 0.0 })
        .collect()
}

fn peak(p: &[f64]) -> f64 {
    p.iter().copied().fold(0.0, f64::max)
}

/// The MorteX run: the case with its virtual surface moving through the fixed mesh, one
/// snapshot per wear update.
pub fn run_virtual(case: &RelocationCase, params: RelocationParams) -> Result<Vec<WearSnapshot>, RelocationError> {
    let model = case.build(case.cycles, params.cycles_per_update, &[])?;
    let mut state = StaticAnalysis::initial_state_of(&model);
    let origin: Vec<Point2<f64>> = vertices(&state.wear);
    let mut out = vec![];
    let (mut high, mut last, mut pressure) = (0.0_f64, 0u64, vec![]);
    let snapshot = |s: &SimState, high: f64, pressure: &[f64]| WearSnapshot {
        cycle: s.wear.cycle,
        origin: origin.clone(),
        depth: s.wear.depth[0].clone(),
        worn_area: s.wear.worn_area[0],
        peak_pressure: high,
        pressure: pressure.to_vec(),
        quality: None,
    };
    run(&model, &mut state, RunOptions::default(), |_, s, _, d| {
        pressure = pressures(s, d);
        high = high.max(peak(&pressure));
        // A computed cycle's last increment: its wear is applied.
        if s.wear.cycle > last {
            out.push(snapshot(s, high, &pressure));
            (high, last) = (0.0, s.wear.cycle);
        }
        Ok(())
    })
    .map_err(|source| RelocationError::Analysis { cycle: last, source })?;
    if out.last().is_none_or(|o| o.cycle < state.wear.cycle) {
        out.push(snapshot(&state, high, &pressure));
    }
    Ok(out)
}

/// Every boundary node of `mesh` on the polyline `v`, with the segment it lies on and where on
/// it (a worn boundary's end vertices lie beyond the body: its end segments are doubled).
fn surface_nodes(mesh: &crate::mesh::Mesh2, v: &[Point2<f64>]) -> Vec<(usize, usize, f64)> {
    let scale = v.windows(2).map(|w| (w[1] - w[0]).norm()).fold(f64::INFINITY, f64::min);
    crate::mesh::relocate::boundary_nodes(mesh)
        .iter()
        .enumerate()
        .filter(|&(_, &on)| on)
        .filter_map(|(n, _)| {
            let x = mesh.nodes[n];
            v.windows(2).enumerate().find_map(|(i, w)| {
                let e = w[1] - w[0];
                let t = ((x - w[0]).dot(&e) / e.norm_squared()).clamp(0.0, 1.0);
                ((w[0] + e * t - x).norm() <= 1e-9 * scale).then_some((n, i, t))
            })
        })
        .collect()
}

/// The first wearing surface's vertices in a wear state.
fn vertices(wear: &crate::state::WearState) -> Vec<Point2<f64>> {
    wear.vertices[0].iter().map(|p| Point2::new(p[0], p[1])).collect()
}

/// The baseline: the case run with its worn boundary's nodes relocated at every wear update
/// (see the module documentation). Stops at the first update whose moved mesh inverts a cell
/// (no remeshing: the method cannot go on), returning the snapshots so far, the last one with
/// the inverted mesh's quality, and that failure's message.
pub fn run_relocated(
    case: &RelocationCase,
    params: RelocationParams,
) -> Result<(Vec<WearSnapshot>, Option<String>), RelocationError> {
    let first = case.build(case.cycles.min(params.cycles_per_update), params.cycles_per_update, &[])?;
    let b = first.bodies.iter().position(|b| b.name == case.body).unwrap_or(0);
    let mesh = first.bodies[b].mesh.clone();
    let mut nodes = mesh.nodes.clone();
    let origin = vertices(&first.initial_wear_state());
    let on_surface = surface_nodes(&mesh, &origin);
    if on_surface.len() < 2 {
        let msg = format!("the worn boundary of body '{}' holds fewer than two of its nodes", case.body);
        return Err(RelocationError::Input { path: case.path.clone(), key: "wear[0].surface".into(), msg });
    }
    let mut depth = vec![0.0; origin.len()];
    let (mut worn_area, mut out) = (0.0, vec![]);
    let mut state: Option<SimState> = None;
    let mut cycle = 0;
    while cycle < case.cycles {
        let dn = params.cycles_per_update.min(case.cycles - cycle);
        let model = case.build(cycle + dn, dn, &[(case.body.clone(), nodes.clone())])?;
        let mut s = StaticAnalysis::initial_state_of(&model);
        if let Some(prev) = state.take() {
            carry_over(&prev, &mut s);
        }
        let (mut high, mut pressure) = (0.0_f64, vec![]);
        run(&model, &mut s, RunOptions::default(), |_, st, _, d| {
            pressure = pressures(st, d);
            high = high.max(peak(&pressure));
            Ok(())
        })
        .map_err(|source| RelocationError::Analysis { cycle, source })?;
        // The depth of this update, per vertex of this model's boundary (the same points of
        // the same nodes' edges, in the same order).
        let v = vertices(&model.initial_wear_state());
        let worn = crate::wear::worn_vertices(&v, false, &s.wear.depth[0]);
        let moved: Vec<(usize, Vector2<f64>)> = on_surface
            .iter()
            .map(|&(n, i, t)| (n, (worn[i] - v[i]) * (1.0 - t) + (worn[i + 1] - v[i + 1]) * t))
            .collect();
        let d = harmonic_extension(&mesh, &moved, params.layers);
        nodes.iter_mut().zip(&d).for_each(|(p, d)| *p += d);
        depth.iter_mut().zip(&s.wear.depth[0]).for_each(|(a, d)| *a += d);
        worn_area += s.wear.worn_area[0];
        cycle = s.wear.cycle;
        let q = quality(&mesh, &nodes);
        out.push(WearSnapshot {
            cycle,
            origin: origin.clone(),
            depth: depth.clone(),
            worn_area,
            peak_pressure: high,
            pressure,
            quality: Some(q),
        });
        if q.inverted > 0 {
            let msg = format!(
                "the relocated mesh inverts cell {} (corner Jacobian ratio {:.3}) after cycle {cycle}",
                q.worst_ratio_cell, q.min_jacobian_ratio
            );
            return Ok((out, Some(msg)));
        }
        state = Some(s);
    }
    Ok((out, None))
}

/// What the next model's state keeps of the last one's: time, nodal displacements and forces,
/// multipliers and friction memory, and the wear run's count of cycles (its surface starts
/// unworn on the moved boundary). Point fields are the next model's own (elastic bodies: they
/// follow from the displacement at the next converged step).
fn carry_over(prev: &SimState, s: &mut SimState) {
    // Every state field named: a new one must be carried over or left out here on purpose.
    let SimState {
        step,
        time,
        load_factor,
        u,
        history: _,
        stress,
        f_int,
        multipliers,
        friction_status,
        slip_increment,
        accumulated_slip,
        dissipation,
        // The next model's operator is its own.
        interface_log: _,
        wear,
        // Relocated bodies are not cut: no ghost faces.
        ghost: _,
        // The baseline follows no fatigue points.
        fatigue: _,
    } = prev;
    (s.step, s.time, s.load_factor, s.dissipation) = (*step, *time, *load_factor, *dissipation);
    s.u.clone_from(u);
    s.f_int.clone_from(f_int);
    s.multipliers.clone_from(multipliers);
    s.friction_status.clone_from(friction_status);
    s.slip_increment.clone_from(slip_increment);
    s.accumulated_slip.clone_from(accumulated_slip);
    s.wear.cycle = wear.cycle;
    s.wear.computed_cycles = wear.computed_cycles;
    s.wear.pairing_guess.clone_from(&wear.pairing_guess);
    s.wear.start_sets.clone_from(&wear.start_sets);
    if s.stress.len() == stress.len() {
        s.stress.clone_from(stress);
    }
}
