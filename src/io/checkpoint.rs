//! Checkpoints: the whole [`SimState`] of a converged output step, stored in the result file so
//! a run resumes from any of its steps bit for bit (`mortex run --restart`).
//!
//! Layout, under `/steps/NNNNNN/checkpoint/` of a result file (also of a `.h5.partial` left by
//! a run that stopped): attributes `step`, `time`, `load_factor`, `dissipation`; datasets `u`,
//! `f_int`, `multipliers`, `slip_increment`, `accumulated_slip` `(n)`, `friction_status` `(n)` u8,
//! `history` `(s, 9)` (`eps_p[4]`, `back[4]`, `alpha` per stateful point), `stress` `(p, 4)`, and
//! the interface-condensation log `interface_rows` / `interface_batches` (u64): the multiplier
//! rows the condensed operator grew by, batch by batch; where yielding bodies are re-cut, the
//! ghost-penalty faces born during the run (`ghost_faces`, `ghost_counts`, `ghost_dofs`,
//! `ghost_forces`); a wear run's wear state in the subgroup `wear` (see [`write_wear`]) and a
//! run with fatigue points their state in `fatigue` (see [`write_fatigue`]). Replaying the
//! interface log makes the restarted solver do the same arithmetic as the uninterrupted run,
//! which is what "bit for bit" needs (the log holds only the rows grown on a geometry that
//! holds still: a finite-sliding step's operator is its own, and its log is empty).
//!
//! A checkpoint group carries the attribute `complete = 1`, written after its last dataset;
//! groups without it (a run killed while writing) are not offered for a restart.
//!
//! Every value is stored as the f64 it is in memory (HDF5 native doubles), so reading a
//! checkpoint gives back the identical state.

use crate::contact::FrictionStatus;
use crate::fem::material::{PlasticState, Stress4};
use crate::model::Model;
use crate::state::{FieldKind, FieldKindMismatch, FieldRef, FieldValue, SimState};
use ndarray::Array1;
use std::path::{Path, PathBuf};

/// Errors of reading a checkpoint: the file, the step and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{path}: cannot read checkpoint: {msg}")]
    Read { path: String, msg: String },
    #[error("{path}: no checkpoint at step {step} (steps with one: {available:?})")]
    NoSuchStep { path: String, step: usize, available: Vec<usize> },
    #[error("{path}: the checkpoint of step {step} does not fit this case: {what} has {found} entries, the model {expected}")]
    SizeMismatch { path: String, step: usize, what: String, found: usize, expected: usize },
    #[error(
        "{path}: the checkpoint of step {step} was written at time {found}, but the case's output step {step} is at \
         time {expected} (the case's output times changed before that step)"
    )]
    TimeMismatch { path: String, step: usize, found: f64, expected: f64 },
    #[error("{path}: the checkpoint is at step {step}, but the case has only {steps} output steps")]
    BeyondCase { path: String, step: usize, steps: usize },
    #[error(
        "{path}: the run was stopped before its first checkpoint{}: there is nothing to resume from; start it \
         again (without --restart)",
        reached.map(|k| format!(", at output step {k}")).unwrap_or_default()
    )]
    StoppedBeforeCheckpoint { path: String, reached: Option<usize> },
    #[error(
        "{path}: the checkpoint of step {step} was written on another path: the case's {key} changed since; a \
         restart continues the run it was written by (restore {key}, or start the changed case again without \
         --restart)"
    )]
    PathChanged { path: String, step: usize, key: &'static str },
    /// The checkpoint reader asked for a field as another kind than its type's (a defect).
    #[error("checkpoint reader: {0}")]
    FieldKind(#[from] FieldKindMismatch),
}

const HISTORY_COLS: usize = 9;

/// The inputs that fix the path a wear run follows, as checkpoint attributes (`path_*`, each
/// a count or a hash of a list of numbers): a restart under a case that changed one of them
/// would continue another run from this one's state (its cycle's wear, pairing guesses and
/// jump history belong to the old path). `[steps] cycles` is not among them (a restart may
/// extend a run). Runs without wear check their output times instead and may change their
/// load path after the checkpoint: none.
fn path_keys(model: &Model) -> Vec<(&'static str, u64)> {
    if model.wear.is_empty() || model.cycle.is_none() {
        return vec![];
    }
    let hash = |values: &mut dyn Iterator<Item = f64>| {
        // FNV-1a over the values' bits: any change of a value or of the count changes it.
        values.fold(0xcbf2_9ce4_8422_2325_u64, |h, v| (h ^ v.to_bits()).wrapping_mul(0x0100_0000_01b3))
    };
    let points = |p: &crate::model::LoadPath| p.points.iter().flat_map(|&(t, f)| [t, f]).collect::<Vec<_>>();
    let mut keys = vec![
        ("path_steps", hash(&mut points(&model.load_path).into_iter())),
        ("path_curves", hash(&mut model.curves.iter().flat_map(points))),
        (
            "path_loads",
            hash(
                &mut model
                    .prescribed
                    .iter()
                    .flat_map(|&(d, v)| [d as f64, v])
                    .chain(model.prescribed_curve.iter().map(|&c| c as f64))
                    .chain(model.f_ext.iter().copied())
                    .chain(model.f_ext_curves.iter().flatten().copied()),
            ),
        ),
    ];
    if let Some(c) = &model.cycle {
        keys.push(("path_increments", c.increments as u64));
        keys.push(("path_ramp_increments", c.ramp_increments as u64));
        keys.push(("path_cycle", hash(&mut [c.start, c.period].into_iter())));
    }
    keys
}

/// The case key a `path_*` attribute stands for.
fn path_key_name(key: &str) -> &'static str {
    match key {
        "path_steps" => "[steps] path",
        "path_curves" => "[[curves]]",
        "path_loads" => "[[loads]] / [[bcs]]",
        "path_increments" => "[steps] increments",
        "path_ramp_increments" => "[steps] ramp_increments",
        _ => "[steps] cycle",
    }
}

/// Writes the checkpoint of `state` into the step group `g`, field after field of the state's
/// one declaration ([`SimState::fields`]), each by its kind: counts and numbers as attributes
/// under the field's name, per-entry values as datasets, the interface log as `interface_rows`
/// and `interface_batches`, the wear and fatigue states in their groups (written only where the
/// run has them), born ghost faces as `ghost_*` datasets (only if any).
pub(super) fn write(g: &hdf5::Group, state: &SimState, model: &Model) -> hdf5::Result<()> {
    let c = g.create_group("checkpoint")?;
    for (key, value) in path_keys(model) {
        super::write_attr(&c, key, &value)?;
    }
    for (name, field) in state.fields() {
        write_field(&c, name, field, model)?;
    }
    // Written last: a checkpoint without it was cut short (a killed run) and is not offered.
    super::write_attr(&c, "complete", &1u8)?;
    Ok(())
}

/// Writes one state field into the checkpoint group `c`. Sparse datasets (a third or more
/// zeros: the plastic history of elastic bodies, slips of open rows) are compressed
/// (lossless); dense ones stored as they are.
fn write_field(c: &hdf5::Group, name: &str, field: FieldRef<'_>, model: &Model) -> hdf5::Result<()> {
    match field {
        FieldRef::Count(n) => super::write_attr(c, name, &(n as u64)),
        FieldRef::Scalar(x) => super::write_attr(c, name, &x),
        FieldRef::Values(v) => super::put(c, name, &Array1::from(v.to_vec())),
        FieldRef::Codes(v) => super::put(c, name, &Array1::from(v.to_vec())),
        FieldRef::History(history) => {
            let h: Vec<f64> = history
                .iter()
                .flat_map(|p| p.eps_p.iter().chain(p.back.iter()).copied().chain(std::iter::once(p.alpha)))
                .collect();
            super::put(c, name, &super::array2(history.len(), HISTORY_COLS, h))
        }
        FieldRef::Stress(stress) => {
            let s: Vec<f64> = stress.iter().flat_map(|s| [s[0], s[1], s[2], s[3]]).collect();
            c.new_dataset_builder().with_data(&super::array2(stress.len(), 4, s)).create(name)?;
            Ok(())
        }
        FieldRef::Batches(log) => {
            let (rows_name, batches_name) = batch_names(name);
            let rows: Vec<u64> = log.iter().flatten().map(|&r| r as u64).collect();
            let batches: Vec<u64> = log.iter().map(|b| b.len() as u64).collect();
            c.new_dataset_builder().with_data(&Array1::from(rows)).create(rows_name.as_str())?;
            c.new_dataset_builder().with_data(&Array1::from(batches)).create(batches_name.as_str())?;
            Ok(())
        }
        FieldRef::Wear(wear) if !wear.vertices.is_empty() => write_wear(c, wear),
        FieldRef::Ghost(ghost) if !ghost.faces.is_empty() => write_ghost(c, ghost),
        FieldRef::Fatigue(fatigue) if model.fatigue.is_some() => write_fatigue(c, fatigue),
        FieldRef::Wear(_) | FieldRef::Ghost(_) | FieldRef::Fatigue(_) => Ok(()),
    }
}

/// The datasets a batch log `name` is stored in: its rows and its batch lengths
/// (`interface_log`: `interface_rows`, `interface_batches`).
fn batch_names(name: &str) -> (String, String) {
    let stem = name.strip_suffix("_log").unwrap_or(name);
    (format!("{stem}_rows"), format!("{stem}_batches"))
}

/// The fatigue state under `checkpoint/fatigue`: `history` (the computed cycle's records so
/// far), `damage` and `retired` (u8) per point, the last computed cycle's `swt`, `angle`,
/// `life`, and once a point's damage reached 1 the attributes `initiation_cycle`,
/// `initiation_point`, `initiation_angle`, `initiation_depth`.
fn write_fatigue(c: &hdf5::Group, f: &crate::fatigue::FatigueState) -> hdf5::Result<()> {
    let crate::fatigue::FatigueState { history, damage, last, retired, initiation } = f;
    let crate::fatigue::CycleFatigue { swt, angle, life } = last;
    let g = c.create_group("fatigue")?;
    for (name, v) in [("history", history), ("damage", damage), ("swt", swt), ("angle", angle), ("life", life)] {
        g.new_dataset_builder().with_data(&Array1::from(v.clone())).create(name)?;
    }
    let retired: Vec<u8> = retired.iter().map(|&r| u8::from(r)).collect();
    g.new_dataset_builder().with_data(&Array1::from(retired)).create("retired")?;
    if let Some(i) = initiation {
        super::write_attr(&g, "initiation_cycle", &i.cycle)?;
        super::write_attr(&g, "initiation_point", &(i.point as u64))?;
        super::write_attr(&g, "initiation_angle", &i.angle)?;
        super::write_attr(&g, "initiation_depth", &i.depth)?;
    }
    Ok(())
}

/// The fatigue state of a checkpoint (see [`write_fatigue`]): sizes checked against the
/// model's fatigue points.
fn read_fatigue(c: &hdf5::Group, model: &Model) -> Result<crate::fatigue::FatigueState, String> {
    let Some(fm) = &model.fatigue else { return Ok(Default::default()) };
    let g =
        c.group("fatigue").map_err(|_| "no fatigue group: the checkpoint was written without [fatigue]".to_string())?;
    let read = |name: &str| {
        g.dataset(name).and_then(|d| d.read_raw::<f64>()).map_err(|e| format!("fatigue dataset {name}: {e}"))
    };
    let np = fm.points.len();
    let (history, damage) = (read("history")?, read("damage")?);
    let last = crate::fatigue::CycleFatigue { swt: read("swt")?, angle: read("angle")?, life: read("life")? };
    let retired =
        g.dataset("retired").and_then(|d| d.read_raw::<u8>()).map_err(|e| format!("fatigue dataset retired: {e}"))?;
    let per_point = [damage.len(), last.swt.len(), last.angle.len(), last.life.len(), retired.len()];
    if history.len() % (crate::fatigue::RECORD * np) != 0 || per_point.iter().any(|&n| n != 0 && n != np) {
        return Err(format!("fatigue datasets do not match the model's {np} fatigue points"));
    }
    let retired = retired.iter().map(|&r| r != 0).collect();
    let initiation = match g.attr("initiation_cycle").and_then(|a| a.read_scalar::<f64>()) {
        Err(_) => None,
        Ok(cycle) => {
            let f64_attr = |name: &str| {
                g.attr(name).and_then(|a| a.read_scalar::<f64>()).map_err(|e| format!("fatigue attribute {name}: {e}"))
            };
            let point = g
                .attr("initiation_point")
                .and_then(|a| a.read_scalar::<u64>())
                .map_err(|e| format!("fatigue attribute initiation_point: {e}"))? as usize;
            if point >= np {
                return Err(format!(
                    "fatigue attribute initiation_point is {point}, the model has {np} fatigue points"
                ));
            }
            Some(crate::fatigue::Initiation {
                cycle,
                point,
                angle: f64_attr("initiation_angle")?,
                depth: f64_attr("initiation_depth")?,
            })
        }
    };
    Ok(crate::fatigue::FatigueState { history, damage, last, retired, initiation })
}

/// The ghost-penalty births: `ghost_faces` `(n, 3)` (body, cell, neighbour), `ghost_counts`
/// `(n)` (entries per face), `ghost_dofs` and `ghost_forces` (the entries, face after face).
fn write_ghost(c: &hdf5::Group, ghost: &crate::state::GhostBirths) -> hdf5::Result<()> {
    let keys: Vec<u64> = ghost.faces.iter().flat_map(|((b, c, n), _)| [*b as u64, *c as u64, *n as u64]).collect();
    let counts: Vec<u64> = ghost.faces.iter().map(|(_, f)| f.len() as u64).collect();
    let dofs: Vec<u64> = ghost.faces.iter().flat_map(|(_, f)| f.iter().map(|e| e.0 as u64)).collect();
    let forces: Vec<f64> = ghost.faces.iter().flat_map(|(_, f)| f.iter().map(|e| e.1)).collect();
    let keys = ndarray::Array2::from_shape_vec((ghost.faces.len(), 3), keys)
        .map_err(|e| hdf5::Error::from(e.to_string().as_str()))?;
    c.new_dataset_builder().with_data(&keys).create("ghost_faces")?;
    c.new_dataset_builder().with_data(&Array1::from(counts)).create("ghost_counts")?;
    c.new_dataset_builder().with_data(&Array1::from(dofs)).create("ghost_dofs")?;
    c.new_dataset_builder().with_data(&Array1::from(forces)).create("ghost_forces")?;
    Ok(())
}

/// The ghost-penalty births of a checkpoint (none where it has no `ghost_faces`: no re-cut
/// yielding body, or a file written before births were kept).
fn read_ghost(c: &hdf5::Group, num_dofs: usize) -> Result<crate::state::GhostBirths, String> {
    if c.dataset("ghost_faces").is_err() {
        return Ok(Default::default());
    }
    let u64s =
        |name: &str| c.dataset(name).and_then(|d| d.read_raw::<u64>()).map_err(|e| format!("dataset {name}: {e}"));
    let (keys, counts, dofs) = (u64s("ghost_faces")?, u64s("ghost_counts")?, u64s("ghost_dofs")?);
    let forces = c
        .dataset("ghost_forces")
        .and_then(|d| d.read_raw::<f64>())
        .map_err(|e| format!("dataset ghost_forces: {e}"))?;
    if keys.len() != 3 * counts.len()
        || counts.iter().sum::<u64>() != dofs.len() as u64
        || forces.len() != dofs.len()
        || dofs.iter().any(|&d| d as usize >= num_dofs)
        || forces.iter().any(|f| !f.is_finite())
    {
        return Err("ghost-penalty births inconsistent (sizes, DOFs or non-finite forces)".into());
    }
    let mut faces = Vec::with_capacity(counts.len());
    let mut at = 0;
    for (k, &n) in keys.chunks_exact(3).zip(&counts) {
        let n = n as usize;
        let entries = dofs[at..at + n].iter().zip(&forces[at..at + n]).map(|(&d, &f)| (d as usize, f)).collect();
        faces.push(((k[0] as usize, k[1] as usize, k[2] as usize), entries));
        at += n;
    }
    Ok(crate::state::GhostBirths { faces })
}

/// The wear state under `checkpoint/wear`: counters as attributes, per surface `i` the datasets
/// `vertices_i` `(n, 2)`, `depth_i`, `cycle_volume_i` `(n)`, per surface `cycle_work`,
/// `worn_area`, `work`, and the jump controller (`last_rate`, `last_change`, `predicted`, `predicted_area_rate`, attributes
/// `last_jump`, `jump_before`, `decay`, `last_fraction`, `fraction_scale`; `cycle_fraction`), per increment `j` of the cycle where the next computed
/// cycle starts: the finite-sliding pairing guess `pairing_guess_j` and the sets its step
/// starts from, `start_active_j` and `start_status_j` (see [`read_start_sets`]; attributes
/// `pairing_guesses`, `start_sets`: their counts), and the implicit jump's linearisation of each
/// increment of the current cycle (group `increment_jumps`, see [`write_increment_jumps`]).
fn write_wear(c: &hdf5::Group, w: &crate::state::WearState) -> hdf5::Result<()> {
    let crate::state::WearState {
        cycle,
        computed_cycles,
        increment,
        jump,
        cycle_fraction,
        vertices,
        depth,
        cycle_volume,
        cycle_work,
        cycle_jumps,
        cycle_steps,
        worn_area,
        work,
        controller,
        pairing_guess,
        start_sets,
        plastic_start,
        cycle_ratcheting,
        cycle_plastic_strain,
    } = w;
    let crate::wear::ControllerState {
        last_rate,
        last_change,
        last_jump,
        jump_before,
        decay,
        predicted,
        predicted_area_rate,
        last_fraction,
        fraction_scale,
    } = controller;
    let g = c.create_group("wear")?;
    for (name, v) in [
        ("cycle", *cycle),
        ("computed_cycles", *computed_cycles),
        ("increment", *increment as u64),
        ("jump", *jump),
        ("cycle_steps", *cycle_steps as u64),
    ] {
        super::write_attr(&g, name, &v)?;
    }
    let vec1 = |name: &str, v: &[f64]| super::put(&g, name, &Array1::from(v.to_vec()));
    for (i, verts) in vertices.iter().enumerate() {
        let flat: Vec<f64> = verts.iter().flat_map(|p| [p[0], p[1]]).collect();
        g.new_dataset_builder()
            .with_data(&super::array2(verts.len(), 2, flat))
            .create(format!("vertices_{i}").as_str())?;
        vec1(&format!("depth_{i}"), &depth[i])?;
        vec1(&format!("cycle_volume_{i}"), &cycle_volume[i])?;
    }
    vec1("cycle_work", cycle_work)?;
    vec1("worn_area", worn_area)?;
    vec1("work", work)?;
    vec1("last_rate", last_rate)?;
    vec1("last_change", last_change)?;
    vec1("predicted", predicted)?;
    vec1("predicted_area_rate", predicted_area_rate)?;
    super::write_attr(&g, "last_jump", last_jump)?;
    super::write_attr(&g, "jump_before", jump_before)?;
    super::write_attr(&g, "decay", decay)?;
    super::write_attr(&g, "cycle_fraction", cycle_fraction)?;
    super::write_attr(&g, "last_fraction", last_fraction)?;
    super::write_attr(&g, "fraction_scale", fraction_scale)?;
    super::write_attr(&g, "pairing_guesses", &(pairing_guess.len() as u64))?;
    for (j, u) in pairing_guess.iter().enumerate() {
        vec1(&format!("pairing_guess_{j}"), u)?;
    }
    super::write_attr(&g, "start_sets", &(start_sets.len() as u64))?;
    for (j, crate::contact::ContactSets { active, status }) in start_sets.iter().enumerate() {
        let active: Vec<u8> = active.iter().map(|&a| u8::from(a)).collect();
        let status: Vec<u8> = status.iter().map(|&s| s.signed_code()).collect();
        g.new_dataset_builder().with_data(&Array1::from(active)).create(format!("start_active_{j}").as_str())?;
        g.new_dataset_builder().with_data(&Array1::from(status)).create(format!("start_status_{j}").as_str())?;
    }
    vec1("plastic_start", plastic_start)?;
    super::write_attr(&g, "cycle_ratcheting", cycle_ratcheting)?;
    super::write_attr(&g, "cycle_plastic_strain", cycle_plastic_strain)?;
    write_increment_jumps(&g, cycle_jumps)
}

/// The implicit jump's linearisation of the current cycle's increments (see
/// `IncrementJump`): group `increment_jumps` with attribute `count`, one group `j` per
/// increment holding `rows`, `closed` (0/1), `stiffness` (`(na, na)`, row-major), `pressure`,
/// `gap`, `weight`, `all_pressure`, attribute `increment_end` (0/1), and per wearing surface `b`: `entry_vertex_b`,
/// `entry_row_b`, `entry_g_b`, `phi_b`, `work_b`, `work_per_pressure_b`.
fn write_increment_jumps(g: &hdf5::Group, jumps: &[crate::wear::IncrementJump]) -> hdf5::Result<()> {
    let top = g.create_group("increment_jumps")?;
    super::write_attr(&top, "count", &(jumps.len() as u64))?;
    for (i, j) in jumps.iter().enumerate() {
        let jg = top.create_group(&i.to_string())?;
        let f64s = |name: &str, v: &[f64]| jg.new_dataset_builder().with_data(&Array1::from(v.to_vec())).create(name);
        let u64s = |name: &str, v: Vec<u64>| jg.new_dataset_builder().with_data(&Array1::from(v)).create(name);
        let sens = &j.sensitivity;
        u64s("rows", sens.rows.iter().map(|&k| k as u64).collect())?;
        u64s("closed", sens.closed.iter().map(|&c| u64::from(c)).collect())?;
        let na = sens.rows.len();
        let stiffness: Vec<f64> = (0..na * na).map(|e| sens.dlambda_dgap[(e / na, e % na)]).collect();
        f64s("stiffness", &stiffness)?;
        f64s("pressure", &j.pressure)?;
        f64s("gap", &j.gap)?;
        f64s("weight", &j.weight)?;
        f64s("all_pressure", &j.all_pressure)?;
        super::write_attr(&jg, "increment_end", &u64::from(j.increment_end))?;
        for (b, sf) in j.surfaces.iter().enumerate() {
            u64s(&format!("entry_vertex_{b}"), sf.entries.iter().map(|e| e.0 as u64).collect())?;
            u64s(&format!("entry_row_{b}"), sf.entries.iter().map(|e| e.1 as u64).collect())?;
            f64s(&format!("entry_g_{b}"), &sf.entries.iter().map(|e| e.2).collect::<Vec<_>>())?;
            f64s(&format!("phi_{b}"), &sf.phi)?;
            f64s(&format!("work_{b}"), &sf.work)?;
            f64s(&format!("work_per_pressure_{b}"), &sf.work_per_pressure)?;
        }
    }
    Ok(())
}

/// The increments' linearisations of a checkpoint (none where it has no `increment_jumps`:
/// written before they were kept, the cycle's jump is then explicit), every index and length
/// checked against the model.
fn read_increment_jumps(g: &hdf5::Group, model: &Model) -> Result<Vec<crate::wear::IncrementJump>, String> {
    let Ok(top) = g.group("increment_jumps") else {
        return Ok(vec![]);
    };
    let count = top
        .attr("count")
        .and_then(|a| a.read_scalar::<u64>())
        .map_err(|e| format!("wear increment_jumps attribute count: {e}"))? as usize;
    // One per solved step: at most the cycle's increments, each cut into sub-steps.
    let most = model.cycle.map_or(0, |c| c.increments) * crate::wear::MAX_SUB_STEPS;
    if count > most {
        return Err(format!("wear increment_jumps count is {count}, the cycle has at most {most} steps"));
    }
    let contact_rows = model.initial().contact.rows.len();
    let vertices: Vec<usize> =
        model.wear.surfaces.iter().map(|w| model.initial().surfaces[w.surface].vertices.len()).collect();
    (0..count)
        .map(|i| {
            let jg = top.group(&i.to_string()).map_err(|e| format!("wear increment_jumps/{i}: {e}"))?;
            let err = |name: &str, e: String| format!("wear dataset increment_jumps/{i}/{name}: {e}");
            let f64s =
                |name: &str| jg.dataset(name).and_then(|d| d.read_raw::<f64>()).map_err(|e| err(name, e.to_string()));
            let idx = |name: &str, bound: usize| -> Result<Vec<usize>, String> {
                let v = jg.dataset(name).and_then(|d| d.read_raw::<u64>()).map_err(|e| err(name, e.to_string()))?;
                v.into_iter()
                    .map(|x| {
                        if (x as usize) < bound {
                            Ok(x as usize)
                        } else {
                            Err(err(name, format!("index {x} not below {bound}")))
                        }
                    })
                    .collect()
            };
            let rows = idx("rows", contact_rows)?;
            let na = rows.len();
            let closed: Vec<bool> = idx("closed", 2)?.into_iter().map(|c| c == 1).collect();
            let stiffness = f64s("stiffness")?;
            let (pressure, gap, weight, all_pressure) =
                (f64s("pressure")?, f64s("gap")?, f64s("weight")?, f64s("all_pressure")?);
            let per_row = [closed.len(), pressure.len(), gap.len(), weight.len()];
            if per_row.iter().any(|&n| n != na) || stiffness.len() != na * na || all_pressure.len() != contact_rows {
                return Err(err(
                    "*",
                    format!("lengths do not match its {na} rows and the model's {contact_rows} contact rows"),
                ));
            }
            let surfaces = vertices
                .iter()
                .enumerate()
                .map(|(b, &nv)| {
                    let (vertex, row) = (idx(&format!("entry_vertex_{b}"), nv)?, idx(&format!("entry_row_{b}"), na)?);
                    let gs = f64s(&format!("entry_g_{b}"))?;
                    let (phi, work, wpp) = (
                        f64s(&format!("phi_{b}"))?,
                        f64s(&format!("work_{b}"))?,
                        f64s(&format!("work_per_pressure_{b}"))?,
                    );
                    if row.len() != vertex.len()
                        || gs.len() != vertex.len()
                        || [phi.len(), work.len(), wpp.len()] != [na; 3]
                    {
                        return Err(err(&format!("surface {b}"), "lengths do not match".into()));
                    }
                    let entries = vertex.into_iter().zip(row).zip(gs).map(|((v, r), g)| (v, r, g)).collect();
                    Ok(crate::wear::IncrementSurface { entries, phi, work, work_per_pressure: wpp })
                })
                .collect::<Result<Vec<_>, String>>()?;
            let dlambda_dgap = nalgebra::DMatrix::from_row_slice(na, na, &stiffness);
            let sensitivity = crate::wear::GapSensitivity { rows, closed, dlambda_dgap };
            // Written before sub-steps were told from increment ends: each was an end.
            let increment_end = jg.attr("increment_end").and_then(|a| a.read_scalar::<u64>()).map_or(true, |v| v != 0);
            Ok(crate::wear::IncrementJump { sensitivity, pressure, gap, weight, all_pressure, surfaces, increment_end })
        })
        .collect()
}

/// The finite-sliding pairing guesses (see `WearState::pairing_guess`): each empty or one
/// value per DOF. A checkpoint written before they were kept has none.
fn read_pairing_guess(g: &hdf5::Group, model: &Model) -> Result<Vec<Vec<f64>>, String> {
    let Ok(count) = g.attr("pairing_guesses").and_then(|a| a.read_scalar::<u64>()) else {
        return Ok(vec![]);
    };
    let increments = model.cycle.map_or(0, |c| c.increments);
    if count as usize > increments {
        return Err(format!("wear attribute pairing_guesses is {count}, the cycle has {increments} increments"));
    }
    (0..count)
        .map(|j| {
            let name = format!("pairing_guess_{j}");
            let u =
                g.dataset(&name).and_then(|d| d.read_raw::<f64>()).map_err(|e| format!("wear dataset {name}: {e}"))?;
            if !u.is_empty() && u.len() != model.num_dofs() {
                return Err(format!("wear dataset {name} has {} values, the model {} DOFs", u.len(), model.num_dofs()));
            }
            Ok(u)
        })
        .collect()
}

/// A Coulomb status as stored in `start_status_j`: 0 open, 1 stick, 2 slip in the positive
/// tangent direction, 3 in the negative one.
/// The sets each increment's step starts from (see `WearState::start_sets`): per increment
/// `j`, `start_active_j` (0/1 per contact row) and `start_status_j` (see [`FrictionStatus::signed_code`]). A
/// checkpoint written before they were kept has none (the steps then start from the
/// prediction: the same solution).
fn read_start_sets(g: &hdf5::Group, model: &Model) -> Result<Vec<crate::contact::ContactSets>, String> {
    let Ok(count) = g.attr("start_sets").and_then(|a| a.read_scalar::<u64>()) else {
        return Ok(vec![]);
    };
    let increments = model.cycle.map_or(0, |c| c.increments);
    if count as usize > increments {
        return Err(format!("wear attribute start_sets is {count}, the cycle has {increments} increments"));
    }
    let codes = |name: String| {
        g.dataset(&name).and_then(|d| d.read_raw::<u8>()).map_err(|e| format!("wear dataset {name}: {e}"))
    };
    (0..count)
        .map(|j| {
            let active = codes(format!("start_active_{j}"))?;
            let status = codes(format!("start_status_{j}"))?;
            let active = active
                .iter()
                .map(|&a| match a {
                    0 | 1 => Ok(a == 1),
                    _ => Err(format!("wear dataset start_active_{j}: value {a}, expected 0 or 1")),
                })
                .collect::<Result<Vec<bool>, String>>()?;
            let status = status
                .iter()
                .map(|&c| {
                    FrictionStatus::from_signed_code(c)
                        .ok_or_else(|| format!("wear dataset start_status_{j}: value {c}, expected 0 to 3"))
                })
                .collect::<Result<Vec<FrictionStatus>, String>>()?;
            Ok(crate::contact::ContactSets { active, status })
        })
        .collect()
}

/// The plastic strain at the start of the computed cycle (see `WearState::plastic_start`):
/// empty, or five values per history point. A checkpoint written before it was kept has none.
fn read_plastic_start(g: &hdf5::Group, model: &Model) -> Result<Vec<f64>, String> {
    let Ok(d) = g.dataset("plastic_start") else {
        return Ok(vec![]);
    };
    let v = d.read_raw::<f64>().map_err(|e| format!("wear dataset plastic_start: {e}"))?;
    let expected = 5 * model.elements.num_states();
    if !v.is_empty() && v.len() != expected {
        return Err(format!(
            "wear dataset plastic_start has {} values, the model's history points {expected}",
            v.len()
        ));
    }
    Ok(v)
}

fn read_wear(c: &hdf5::Group, model: &Model) -> Result<crate::state::WearState, String> {
    let g = c.group("wear").map_err(|e| format!("no wear group ({e}): the checkpoint is not of a wear run"))?;
    let attr_u64 = |name: &str| {
        g.attr(name).and_then(|a| a.read_scalar::<u64>()).map_err(|e| format!("wear attribute {name}: {e}"))
    };
    let vec_f64 =
        |name: &str| g.dataset(name).and_then(|d| d.read_raw::<f64>()).map_err(|e| format!("wear dataset {name}: {e}"));
    let fresh = model.initial_wear_state();
    let n = fresh.vertices.len();
    let (mut vertices, mut depth, mut cycle_volume) =
        (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    for (i, expected) in fresh.vertices.iter().enumerate() {
        let flat = vec_f64(&format!("vertices_{i}"))?;
        let d = vec_f64(&format!("depth_{i}"))?;
        let vol = vec_f64(&format!("cycle_volume_{i}"))?;
        if flat.len() != 2 * expected.len() || d.len() != expected.len() || vol.len() != expected.len() {
            return Err(format!(
                "wear surface {i} has {} vertices in the checkpoint, the model {}",
                flat.len() / 2,
                expected.len()
            ));
        }
        vertices.push(flat.chunks_exact(2).map(|p| [p[0], p[1]]).collect());
        depth.push(d);
        cycle_volume.push(vol);
    }
    let (cycle_work, worn_area, work) = (vec_f64("cycle_work")?, vec_f64("worn_area")?, vec_f64("work")?);
    if cycle_work.len() != n || worn_area.len() != n || work.len() != n {
        return Err(format!("the checkpoint has wear sums for another number of surfaces than the model's {n}"));
    }
    let predicted = vec_f64("predicted")?;
    let (rows, increments) = (model.initial().contact.rows.len(), model.cycle.map_or(1, |c| c.increments));
    // One block of rows per step of the cycle: an increment solved in sub-steps has more.
    if !predicted.is_empty() && (rows == 0 || predicted.len() % rows != 0 || predicted.len() < rows * increments) {
        return Err(format!(
            "wear dataset predicted has {} values, the model {rows} contact rows at {increments} increments or more",
            predicted.len(),
        ));
    }
    let predicted_area_rate = vec_f64("predicted_area_rate")?;
    if !predicted_area_rate.is_empty() && predicted_area_rate.len() != n {
        return Err(format!(
            "wear dataset predicted_area_rate has {} values, the model {n} wearing surfaces",
            predicted_area_rate.len()
        ));
    }
    let controller = crate::wear::ControllerState {
        last_rate: vec_f64("last_rate")?,
        last_change: vec_f64("last_change")?,
        last_jump: attr_u64("last_jump")?,
        jump_before: attr_u64("jump_before")?,
        decay: g
            .attr("decay")
            .and_then(|a| a.read_scalar::<f64>())
            .map_err(|e| format!("wear attribute decay: {e}"))?,
        predicted,
        predicted_area_rate,
        // (A checkpoint written before cycles' wear was applied in parts: whole cycles.)
        last_fraction: g.attr("last_fraction").and_then(|a| a.read_scalar::<f64>()).unwrap_or(0.0),
        fraction_scale: g.attr("fraction_scale").and_then(|a| a.read_scalar::<f64>()).unwrap_or(0.0),
    };
    let increment = attr_u64("increment")? as usize;
    // A full literal: a new wear-state field does not compile until it is read here.
    let w = crate::state::WearState {
        cycle: attr_u64("cycle")?,
        computed_cycles: attr_u64("computed_cycles")?,
        increment,
        jump: attr_u64("jump")?,
        cycle_fraction: g.attr("cycle_fraction").and_then(|a| a.read_scalar::<f64>()).unwrap_or(0.0),
        vertices,
        depth,
        cycle_volume,
        cycle_work,
        cycle_jumps: read_increment_jumps(&g, model)?,
        // (A checkpoint written before increments were cut into sub-steps: one step each.)
        cycle_steps: g.attr("cycle_steps").and_then(|a| a.read_scalar::<u64>()).map_or(increment, |n| n as usize),
        worn_area,
        work,
        controller,
        pairing_guess: read_pairing_guess(&g, model)?,
        start_sets: read_start_sets(&g, model)?,
        plastic_start: read_plastic_start(&g, model)?,
        // (A checkpoint written before they were kept: zero, as for elastic bodies.)
        cycle_ratcheting: g.attr("cycle_ratcheting").and_then(|a| a.read_scalar::<f64>()).unwrap_or(0.0),
        cycle_plastic_strain: g.attr("cycle_plastic_strain").and_then(|a| a.read_scalar::<f64>()).unwrap_or(0.0),
    };
    let finite = w
        .vertices
        .iter()
        .flatten()
        .flatten()
        .chain(w.depth.iter().flatten())
        .chain(&w.worn_area)
        .all(|v| v.is_finite());
    if !finite {
        return Err("non-finite wear state".into());
    }
    Ok(w)
}

/// The side copy of the latest checkpoint beside a run's `.h5.partial` (see [`super`]).
pub fn side_path(partial: &Path) -> PathBuf {
    PathBuf::from(format!("{}.checkpoint", partial.display()))
}

/// Where the checkpoints of `path` can be read: `path` itself, or, if it cannot be read (a run
/// killed while HDF5 updated its metadata), the side copy of its latest checkpoint.
fn readable_source(path: &Path) -> Result<(PathBuf, Vec<usize>), CheckpointError> {
    let stopped_early =
        || CheckpointError::StoppedBeforeCheckpoint { path: path.display().to_string(), reached: steps_reached(path) };
    match steps_in(path) {
        Ok(steps) if steps.is_empty() && is_partial(path) => Err(stopped_early()),
        Ok(steps) => Ok((path.to_path_buf(), steps)),
        Err(e) => {
            let side = side_path(path);
            match side.exists().then(|| steps_in(&side)) {
                Some(Ok(steps)) if !steps.is_empty() => {
                    tracing::warn!(file = %path.display(), side = %side.display(), error = %e, "damaged file: resuming from the side copy of its last checkpoint");
                    Ok((side, steps))
                }
                // A run killed before its first checkpoint leaves a partial file HDF5 may not
                // open, and no side copy.
                _ if is_partial(path) => Err(stopped_early()),
                _ => Err(e),
            }
        }
    }
}

/// Whether `path` is a run's partial result (`<name>.h5.partial`).
fn is_partial(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "partial")
}

/// The output steps a stopped run reached: the rows of its per-step series, or, when HDF5
/// cannot open its partial file, the last row of the contact CSV it streams beside it.
fn steps_reached(path: &Path) -> Option<usize> {
    if let Ok(n) = hdf5::File::open(path).and_then(|f| f.dataset("series/step")).map(|d| d.size()) {
        return Some(n);
    }
    let name = path.to_str()?.strip_suffix(".h5.partial")?;
    let csv = std::fs::read_to_string(format!("{name}_contact.csv.partial")).ok()?;
    csv.lines().filter_map(|l| l.split(',').next()?.parse::<usize>().ok()).next_back()
}

/// Steps that hold a checkpoint, in increasing order: those of `path`, or of the side copy of
/// its latest checkpoint if `path` cannot be read (see [`super`]).
pub fn available_steps(path: &Path) -> Result<Vec<usize>, CheckpointError> {
    readable_source(path).map(|(_, steps)| steps)
}

fn steps_in(path: &Path) -> Result<Vec<usize>, CheckpointError> {
    let read = |msg: String| CheckpointError::Read { path: path.display().to_string(), msg };
    let file = hdf5::File::open(path).map_err(|e| read(e.to_string()))?;
    let steps = file.group("steps").map_err(|e| read(format!("no /steps group ({e}); not a mortex result file?")))?;
    let mut out = vec![];
    for name in steps.member_names().map_err(|e| read(e.to_string()))? {
        let Ok(k) = name.parse::<usize>() else { continue };
        let complete = steps
            .group(&name)
            .and_then(|g| g.group("checkpoint"))
            .map(|c| c.attr("complete").and_then(|a| a.read_scalar::<u8>()).map(|v| v == 1).unwrap_or(false))
            .unwrap_or(false);
        if complete {
            out.push(k);
        }
    }
    out.sort_unstable();
    Ok(out)
}

/// Reads the checkpoint of output step `step` (the last one with a checkpoint if `None`) from
/// `path` and checks that it fits `model`: array sizes, and the step's time against the case's
/// output times (bit for bit, as the run will continue from them).
pub fn read(path: &Path, step: Option<usize>, model: &Model) -> Result<SimState, CheckpointError> {
    let (source, available) = readable_source(path)?;
    let path = source.as_path();
    let p = path.display().to_string();
    let step = match step.or(available.last().copied()) {
        Some(s) if available.contains(&s) => s,
        Some(s) => return Err(CheckpointError::NoSuchStep { path: p, step: s, available }),
        None => return Err(CheckpointError::NoSuchStep { path: p, step: 0, available }),
    };
    let read_err = |msg: String| CheckpointError::Read { path: p.clone(), msg: format!("step {step}: {msg}") };
    let file = hdf5::File::open(path).map_err(|e| read_err(e.to_string()))?;
    let c = file.group(&format!("steps/{step:06}/checkpoint")).map_err(|e| read_err(e.to_string()))?;
    let attr_f64 = |name: &str| -> Result<f64, CheckpointError> {
        c.attr(name).and_then(|a| a.read_scalar::<f64>()).map_err(|e| read_err(format!("attribute {name}: {e}")))
    };
    let time = attr_f64("time")?;
    // (A checkpoint written before the path was recorded has none of these attributes.)
    for (key, expected) in path_keys(model) {
        if let Ok(found) = c.attr(key).and_then(|a| a.read_scalar::<u64>()) {
            if found != expected {
                return Err(CheckpointError::PathChanged { path: p.clone(), step, key: path_key_name(key) });
            }
        }
    }
    // Wear runs jump cycles: their steps are not the case's output times one for one.
    if model.wear.is_empty() {
        if step > model.times.len() {
            return Err(CheckpointError::BeyondCase { path: p.clone(), step, steps: model.times.len() });
        }
        let expected = model.times[step - 1];
        if time.to_bits() != expected.to_bits() {
            return Err(CheckpointError::TimeMismatch { path: p.clone(), step, found: time, expected });
        }
    }
    let reader = FieldReader { c: &c, model, path: &p, step };
    let state = SimState::from_fields(|name, kind| reader.read(name, kind))?;
    if !state.u.iter().chain(&state.multipliers).all(|v| v.is_finite()) {
        return Err(read_err("non-finite displacement or multiplier".into()));
    }
    Ok(state)
}

/// Reads the fields of one checkpoint group, each by its kind, and checks each against the
/// model's sizes.
struct FieldReader<'a> {
    c: &'a hdf5::Group,
    model: &'a Model,
    path: &'a str,
    step: usize,
}

impl FieldReader<'_> {
    fn err(&self, msg: String) -> CheckpointError {
        CheckpointError::Read { path: self.path.to_string(), msg: format!("step {}: {msg}", self.step) }
    }

    /// The number of entries the model gives the per-entry field `name`.
    fn expected_len(&self, name: &str) -> Result<usize, CheckpointError> {
        let m = self.model;
        let friction_rows = m.initial().contact.friction_rows.len();
        match name {
            "u" | "f_int" => Ok(m.num_dofs()),
            "multipliers" => Ok(m.num_multipliers()),
            "friction_status" | "slip_increment" | "accumulated_slip" => Ok(friction_rows),
            "history" => Ok(m.elements.num_states()),
            "stress" => Ok(m.elements.num_points()),
            _ => Err(self.err(format!("no size is known for the state field {name}"))),
        }
    }

    fn sized<T>(&self, name: &str, v: Vec<T>, per_entry: usize) -> Result<Vec<T>, CheckpointError> {
        let (found, expected) = (v.len() / per_entry, self.expected_len(name)?);
        if found != expected {
            return Err(CheckpointError::SizeMismatch {
                path: self.path.to_string(),
                step: self.step,
                what: name.into(),
                found,
                expected,
            });
        }
        Ok(v)
    }

    fn dataset<T: hdf5::H5Type>(&self, name: &str) -> Result<Vec<T>, CheckpointError> {
        self.c.dataset(name).and_then(|d| d.read_raw::<T>()).map_err(|e| self.err(format!("dataset {name}: {e}")))
    }

    fn read(&self, name: &'static str, kind: FieldKind) -> Result<FieldValue, CheckpointError> {
        let attr = |name: &str| self.c.attr(name).map_err(|e| self.err(format!("attribute {name}: {e}")));
        Ok(match kind {
            // The step is the one of the group read (its attribute holds the same).
            FieldKind::Count if name == "step" => FieldValue::Count(self.step),
            FieldKind::Count => FieldValue::Count(
                attr(name)?.read_scalar::<u64>().map_err(|e| self.err(format!("attribute {name}: {e}")))? as usize,
            ),
            FieldKind::Scalar => FieldValue::Scalar(
                attr(name)?.read_scalar::<f64>().map_err(|e| self.err(format!("attribute {name}: {e}")))?,
            ),
            FieldKind::Values => FieldValue::Values(self.sized(name, self.dataset::<f64>(name)?, 1)?),
            FieldKind::Codes => FieldValue::Codes(self.sized(name, self.dataset::<u8>(name)?, 1)?),
            FieldKind::History => {
                let h = self.sized(name, self.dataset::<f64>(name)?, HISTORY_COLS)?;
                FieldValue::History(
                    h.chunks_exact(HISTORY_COLS)
                        .map(|r| PlasticState {
                            eps_p: [r[0], r[1], r[2], r[3]],
                            back: [r[4], r[5], r[6], r[7]],
                            alpha: r[8],
                        })
                        .collect(),
                )
            }
            FieldKind::Stress => {
                let s = self.sized(name, self.dataset::<f64>(name)?, 4)?;
                FieldValue::Stress(s.chunks_exact(4).map(|r| Stress4::new(r[0], r[1], r[2], r[3])).collect())
            }
            FieldKind::Batches => {
                let (rows_name, batches_name) = batch_names(name);
                let rows = self.dataset::<u64>(&rows_name)?;
                let batches = self.dataset::<u64>(&batches_name)?;
                let num_rows = self.model.num_multipliers() as u64;
                if batches.iter().sum::<u64>() != rows.len() as u64 || rows.iter().any(|&r| r >= num_rows) {
                    return Err(self.err(format!("{name} inconsistent with the multipliers")));
                }
                let mut log = Vec::with_capacity(batches.len());
                let mut at = 0;
                for &b in &batches {
                    log.push(rows[at..at + b as usize].iter().map(|&r| r as usize).collect());
                    at += b as usize;
                }
                FieldValue::Batches(log)
            }
            FieldKind::Wear if self.model.wear.is_empty() => FieldValue::Wear(Default::default()),
            FieldKind::Wear => FieldValue::Wear(read_wear(self.c, self.model).map_err(|m| self.err(m))?),
            FieldKind::Ghost => FieldValue::Ghost(read_ghost(self.c, self.model.num_dofs()).map_err(|m| self.err(m))?),
            FieldKind::Fatigue => FieldValue::Fatigue(read_fatigue(self.c, self.model).map_err(|m| self.err(m))?),
        })
    }
}
