//! `mortex check`: a case read and validated, and what it defines printed (bodies, materials,
//! contacts, loads, steps, free rigid-body modes), nothing run.

use super::run::plural;
use mortex::case;
use std::path::PathBuf;

/// A material as a user writes it: `elastic, E = 200 GPa, nu = 0.3`.
pub(crate) fn describe_material(m: &mortex::fem::material::Material, units: case::Units) -> String {
    use mortex::fem::material::Material;
    let e = m.elastic();
    let elastic = format!("E = {}, nu = {}", units.stress(e.young), e.poisson);
    match m {
        Material::Elastic(_) => format!("elastic, {elastic}"),
        Material::J2Plastic(p) => format!(
            "J2 plastic, {elastic}, yield stress {}, isotropic hardening {}, kinematic hardening {}",
            units.stress(p.yield_stress),
            units.stress(p.isotropic_hardening),
            units.stress(p.kinematic_hardening)
        ),
    }
}

/// The output steps a run will compute: all of them, or with cycle jumps the range the jump
/// policy allows (the adaptive jump decides during the run).
pub(crate) fn computed_steps(m: &mortex::model::Model) -> String {
    use mortex::wear::JumpPolicy;
    let (Some(cy), false) = (m.cycle, m.wear.is_empty()) else {
        return format!("{} output steps", m.times.len());
    };
    let ramp = m.times.len().saturating_sub(cy.count * cy.increments);
    let steps = |cycles: usize| cycles * cy.increments + ramp;
    match m.wear.jump {
        JumpPolicy::Fixed(1) => format!("{} output steps", m.times.len()),
        JumpPolicy::Fixed(n) => {
            let cycles = cy.count.div_ceil(n as usize);
            format!("{} output steps ({cycles} computed cycles, jumps of {n})", steps(cycles))
        }
        JumpPolicy::Adaptive { max_jump, .. } => {
            let fewest = cy.count.div_ceil(max_jump.max(1) as usize);
            let range = if fewest > 1 { format!("between {} and", steps(fewest)) } else { "at most".into() };
            format!(
                "{range} {} output steps: the adaptive cycle jump computes a part of the {} cycles, decided during \
                 the run",
                m.times.len(),
                cy.count
            )
        }
    }
}

pub(crate) fn check(path: PathBuf) -> anyhow::Result<()> {
    let c = case::load(&path)?;
    let m = &c.model;
    println!("case '{}' ({}): valid", c.name, path.display());
    let hypothesis = match m.hypothesis {
        mortex::fem::material::PlaneHypothesis::PlaneStrain => "plane strain",
        mortex::fem::material::PlaneHypothesis::PlaneStress => "plane stress",
    };
    println!(
        "  hypothesis: {hypothesis}; numbers read as given, labelled in {} ([problem] units)",
        if c.units == case::Units::Metre { "m, N, Pa" } else { "mm, N, MPa" }
    );
    for free in m.free_mode_descriptions(false) {
        println!("  {free}: no boundary condition fixes it, only contact and friction hold it");
    }
    for (i, mat) in m.materials.iter().enumerate() {
        println!("  material '{}': {}", m.material_names[i], describe_material(mat, c.units));
    }
    for b in &m.bodies {
        let nq = b.mesh.cells.iter().filter(|c| c.kind == mortex::mesh::CellKind::Quad4).count();
        println!(
            "  body '{}': {} nodes, {} cells ({} Quad4, {} Tri3), {:?}, material '{}'",
            b.name,
            b.mesh.num_nodes(),
            b.mesh.num_cells(),
            nq,
            b.mesh.num_cells() - nq,
            b.formulation,
            m.material_names[b.material]
        );
        for (name, v) in &b.mesh.node_sets {
            println!("    node set '{name}': {}", plural(v.len(), "node"));
        }
        for (name, v) in &b.mesh.edge_sets {
            println!("    edge set '{name}': {}", plural(v.len(), "edge"));
        }
        for (name, v) in &b.mesh.cell_sets {
            println!("    cell set '{name}': {} cells", v.len());
        }
    }
    for t in &m.ties {
        println!(
            "  tie '{}': patch '{}' in host '{}', {:?} multipliers: {} nodes in {} chains",
            t.name,
            m.bodies[t.patch].name,
            m.bodies[t.host].name,
            t.space,
            t.multipliers.num_nodes,
            t.multipliers.chains.len()
        );
    }
    let disc = m.initial();
    for (b, cut) in disc.cuts.iter().enumerate() {
        if let Some(c) = cut {
            let n_cut = c.cells.iter().filter(|x| matches!(x, mortex::cut::CellCut::Cut { .. })).count();
            let n_void = c.cells.iter().filter(|x| matches!(x, mortex::cut::CellCut::Void)).count();
            println!(
                "  body '{}' is cut: {} cut cells, {} void cells, {} DOFs switched off{}",
                m.bodies[b].name,
                n_cut,
                n_void,
                disc.held[b].len(),
                match &m.bands[b] {
                    Some(band) =>
                        format!(", a band of {} cells with fixed points for its moving surface", band.cells.len()),
                    None => String::new(),
                }
            );
        }
    }
    println!("  DOFs: {} total, {} free, {} prescribed", m.num_dofs(), disc.dofs.num_free, m.prescribed.len());
    println!("  integration points: {} ({} with history)", m.elements.num_points(), m.elements.num_states());
    println!(
        "  steps: to t = {}, {}; {}",
        m.end_time(),
        if m.is_linear() { "linear (one factorisation)" } else { "nonlinear (Newton)" },
        computed_steps(m)
    );
    if let Some(cy) = &m.cycle {
        println!(
            "  cycles: {} x [{}, {}] with {} increments per cycle ({} before the first)",
            cy.count,
            cy.start,
            cy.start + cy.period,
            cy.increments,
            if cy.start > m.load_path.points[0].0 { cy.ramp_increments } else { 0 }
        );
    }
    for s in disc.surfaces.iter().filter(|s| s.motion.is_some()) {
        println!("  moving surface '{}' in body '{}': {:?}", s.name, m.bodies[s.body].name, s.motion);
    }
    for ci in &disc.contact.pairs {
        let source = if c.sliding_set.contains(&ci.name) {
            "set by the case's contacts.sliding"
        } else {
            "the default: finite for a wearing pair whose stroke exceeds half its element, small otherwise"
        };
        println!(
            "  contact '{}': mortar '{}', {:?} multipliers ({}), mu = {}, {:?} sliding ({source})",
            ci.name,
            m.bodies[ci.mortar].name,
            ci.space,
            plural(ci.multipliers.num_nodes, "node"),
            ci.mu,
            ci.sliding
        );
    }
    if c.fields_every > 1 {
        println!("  full fields every {} steps (contact and surface series every step)", c.fields_every);
    }
    let every = match c.checkpoint_every {
        0 => "no checkpoints".to_string(),
        1 => "a checkpoint every step".to_string(),
        n => format!("a checkpoint every {n} steps"),
    };
    println!("  output: {} ({every})", c.output.display());
    Ok(())
}
