//! Node relocation (the ALE practice of commercial wear codes: move the worn boundary's nodes,
//! smooth the interior) against the MorteX virtual surface, and the mesh motion it uses.
//!
//! Scene (`wear_cases/sliding_wear_boundary.toml`): a rigid-topped 1 x 0.5 mm steel punch,
//! P = 50 N/mm, slides +-1.5 mm over a 10 x 1 mm steel block whose top edge wears
//! (Archard, k = 2e-5 /MPa, frictionless, cells 0.111 x 0.05 mm):
//!
//! ```text
//!            P
//!        +---+---+  <- +-1.5 mm
//!        | punch |
//!   =====+=======+=====================  <- block top (worn edge), y = 0
//!   |            block 10 x 1 mm        |
//!   +-----------------------------------+  fixed
//! ```

use mortex::mesh::generate;
use mortex::mesh::relocate::{harmonic_extension, quality};
use mortex::mesh::CellKind;
use mortex::relocation::{run_relocated, run_virtual, RelocationCase, RelocationParams, WearSnapshot};
use nalgebra::{Point2, Vector2};

/// Load P (N/mm) and wear coefficient k (1/MPa) of the shipped case.
const LOAD: f64 = 50.0;
const WEAR_COEFFICIENT: f64 = 2e-5;
/// The top cells' height (mm): the depth scale of the relocated mesh.
const CELL_HEIGHT: f64 = 0.05;

fn shipped_case(cycles: u64) -> RelocationCase {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/sliding_wear_boundary.toml");
    let text = std::fs::read_to_string(&path).unwrap().replace("cycles = 280", &format!("cycles = {cycles}"));
    RelocationCase::new(&text, &path.display().to_string(), path.parent().unwrap(), "sliding_wear_boundary").unwrap()
}

fn max_depth(s: &WearSnapshot) -> f64 {
    s.depth.iter().copied().fold(0.0, f64::max)
}

fn relative_l2(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    (num / b.iter().map(|y| y * y).sum::<f64>()).sqrt()
}

/// The uniform graph Laplacian of a uniform structured grid is exact for linear fields: the
/// boundary moved by a linear field moves every interior node by it, to the solver's 1e-13.
#[test]
fn harmonic_extension_reproduces_a_linear_motion() {
    let mesh = generate::rectangle(0.0, 0.0, 2.0, 1.0, 12, 7, 1.0, 1.0, CellKind::Quad4).unwrap();
    let field = |p: Point2<f64>| Vector2::new(0.01 + 0.02 * p.x - 0.03 * p.y, -0.015 * p.x + 0.025 * p.y);
    let boundary = mortex::mesh::relocate::boundary_nodes(&mesh);
    let moved: Vec<(usize, Vector2<f64>)> =
        (0..mesh.num_nodes()).filter(|&n| boundary[n]).map(|n| (n, field(mesh.nodes[n]))).collect();
    let d = harmonic_extension(&mesh, &moved, None);
    let err = (0..mesh.num_nodes()).map(|n| (d[n] - field(mesh.nodes[n])).norm()).fold(0.0, f64::max);
    // CG to a relative residual of 1e-13 on a 66-node system: 1e-12 of the unit field.
    assert!(err < 1e-12, "largest deviation from the linear field {err:e}");
}

/// The Jacobian ratio is exact for a squash (top row to half its height: 0.5 in its cells) and
/// an inverted cell is counted.
#[test]
fn mesh_quality_measures_squash_and_inversion() {
    let mesh = generate::rectangle(0.0, 0.0, 1.0, 1.0, 4, 4, 1.0, 1.0, CellKind::Quad4).unwrap();
    let top: Vec<usize> = mesh.node_sets["top"].clone();
    let mut squashed = mesh.nodes.clone();
    top.iter().for_each(|&n| squashed[n].y -= 0.125);
    let q = quality(&mesh, &squashed);
    assert!((q.min_jacobian_ratio - 0.5).abs() < 1e-14, "ratio {}", q.min_jacobian_ratio);
    assert!((q.min_scaled_jacobian - 1.0).abs() < 1e-14 && q.inverted == 0);
    let mut inverted = mesh.nodes.clone();
    inverted[top[1]].y -= 0.3; // past the row below (0.25 mm cells)
    let q = quality(&mesh, &inverted);
    assert!(q.inverted >= 1 && q.min_jacobian_ratio < 0.0, "{q:?}");
}

/// While the groove is shallow (below a tenth of the top cells) node relocation over the whole
/// block and the virtual surface are the same method up to the surface's discretisation: the
/// target is 2% in depth, profile and pressure (measured: 0.01%, 0.06%, 0.5%). The first cycle
/// is exact for Archard's law whatever the pressure: the middle of the track wears 2 k P, and
/// the worn area is k P times the 6 mm slid per cycle.
#[test]
fn node_relocation_agrees_with_the_virtual_surface_while_the_wear_is_shallow() {
    let case = shipped_case(3);
    assert!((case.cell_size() - CELL_HEIGHT).abs() < 1e-12);
    let params = RelocationParams::default();
    let virtual_run = run_virtual(&case, params).unwrap();
    let (relocated, failure) = run_relocated(&case, params).unwrap();
    assert!(failure.is_none(), "{failure:?}");
    assert_eq!(virtual_run.len(), 3);
    assert_eq!(relocated.len(), 3);
    // First cycle: exact value, resolved to the punch's 0.1 mm cells at its ends (0.1%).
    let first = &virtual_run[0];
    let middle = first.origin.iter().position(|p| p.x.abs() < 1e-9).unwrap();
    let exact = 2.0 * WEAR_COEFFICIENT * LOAD;
    assert!((first.depth[middle] / exact - 1.0).abs() < 1e-3, "middle depth {} against {exact}", first.depth[middle]);
    // The worn area balances the wear work to round-off; the work is k P 6 mm while the track
    // is flat, to the punch's elastic slip under load (1e-4).
    for (c, s) in virtual_run.iter().enumerate() {
        let area = WEAR_COEFFICIENT * LOAD * 6.0 * (c + 1) as f64;
        assert!((s.worn_area / area - 1.0).abs() < 1e-4, "cycle {}: worn area {} against {area}", s.cycle, s.worn_area);
    }
    let mut compared = 0;
    for (v, r) in virtual_run.iter().zip(&relocated) {
        assert_eq!(v.cycle, r.cycle);
        if max_depth(v) >= 0.1 * CELL_HEIGHT {
            continue;
        }
        compared += 1;
        let depth = (max_depth(r) / max_depth(v) - 1.0).abs();
        let profile = relative_l2(&r.depth, &v.depth);
        let pressure = relative_l2(&r.pressure, &v.pressure);
        assert!(
            depth < 0.02 && profile < 0.02 && pressure < 0.02,
            "cycle {}: {depth:e} {profile:e} {pressure:e}",
            v.cycle
        );
        assert!(r.quality.unwrap().inverted == 0);
    }
    assert_eq!(compared, 2, "cycles 1 and 2 are below a tenth of the cells (2 and 3.9 um)");
}

/// Moving the surface nodes alone (a relocation domain of one cell layer) inverts the top cells
/// when the groove passes their height: the run stops there with the failure named, the last
/// depth past the cell height and the one before it short of it.
#[test]
fn one_layer_relocation_fails_when_the_wear_passes_the_top_cells() {
    let case = shipped_case(40);
    let (relocated, failure) =
        run_relocated(&case, RelocationParams { cycles_per_update: 1, layers: Some(1) }).unwrap();
    let message = failure.expect("one cell layer cannot absorb 40 cycles (about 1.2 cell heights)");
    assert!(message.contains("inverts cell"), "{message}");
    let (last, before) = (&relocated[relocated.len() - 1], &relocated[relocated.len() - 2]);
    assert!(last.quality.unwrap().inverted > 0 && before.quality.unwrap().inverted == 0);
    assert!(
        max_depth(last) > CELL_HEIGHT && max_depth(before) < CELL_HEIGHT,
        "{} {}",
        max_depth(before),
        max_depth(last)
    );
}

/// A case the baseline cannot run is an error naming the key: a worn cut (not a real boundary)
/// has no nodes to move.
#[test]
fn a_case_wearing_a_cut_is_refused_with_the_key() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/sliding_wear.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let err = match RelocationCase::new(&text, "sliding_wear.toml", path.parent().unwrap(), "sliding_wear") {
        Ok(_) => panic!("a worn cut was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("sliding_wear.toml") && err.contains("wear[0].body"), "{err}");
}
