//! Frictionless mortar contact (small sliding) — groundwork for the contact validation, not the validation itself.
//!
//! Contact patch test (Taylor & Papadopoulos, IJNME 31 (1991) 1203; Puso & Laursen 2004):
//! two blocks of the same material with non-matching meshes, the upper one pressed onto the
//! lower one by a uniform pressure p on its top. The exact solution is uniform sigma_yy = -p in
//! both blocks and a uniform contact pressure p; mortar contact passes it to round-off.
//!
//!   +-----------------+   upper: 4 x 1 mm, 7 x 3 Tri3 (or Quad4), pressure p on top
//!   |                 |
//!   +=================+   contact: mortar = upper bottom edge (multipliers)
//!   |                 |   lower: 4 x 2 mm, 8 x 4 Quad4; real top edge, or a virtual surface
//!   +-----------------+          (free cut) through a taller host

mod common;
use common::solve;
use mortex::fem::kernel::Formulation;
use mortex::fem::material::{Elastic, Material, PlaneHypothesis};
use mortex::mesh::{generate, CellKind};
use mortex::model::{ContactOther, ModelBuilder};
use nalgebra::Point2;

const E: f64 = 210_000.0;
const NU: f64 = 0.3;
const P: f64 = 50.0;

fn run(virtual_lower: Option<f64>, upper_kind: CellKind, gap: f64) {
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let mi = b.add_material("steel", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
    let y_int = virtual_lower.unwrap_or(2.0);
    let lower = generate::rectangle(
        0.0,
        0.0,
        4.0,
        if virtual_lower.is_some() { 3.0 } else { 2.0 },
        8,
        if virtual_lower.is_some() { 6 } else { 4 },
        1.0,
        1.0,
        CellKind::Quad4,
    )
    .unwrap();
    let upper = generate::rectangle(0.0, y_int + gap, 4.0, 1.0, 7, 3, 1.0, 1.0, upper_kind).unwrap();
    let lo = b.add_body("lower", lower, mi, Formulation::Standard, 1.0);
    let up = b.add_body("upper", upper, mi, Formulation::Standard, 1.0);
    b.fix(lo, "bottom", 1, 0.0).unwrap();
    b.fix(lo, "bottom_left", 0, 0.0).unwrap();
    // Frictionless: the upper block's horizontal rigid motion is held at its top-left corner,
    // where the exact lateral displacement (Poisson expansion from x = 0) is zero.
    b.fix(up, "top_left", 0, 0.0).unwrap();
    b.pressure(up, "top", P).unwrap();
    let other = match virtual_lower {
        None => ContactOther::Edges(b.global_edges(lo, &["top".to_string()]).unwrap()),
        Some(y) => {
            b.add_cut("worn_top", lo, vec![Point2::new(-1.0, y), Point2::new(5.0, y)], false, false).unwrap();
            ContactOther::Cut("worn_top".into())
        }
    };
    b.add_contact("c", up, &["bottom".to_string()], lo, other, Default::default()).unwrap();
    let model = common::build_one_step(b);
    let s = solve(&model);
    for (q, st) in s.stress.iter().enumerate() {
        let e = [st[0].abs(), (st[1] + P).abs(), st[3].abs()].into_iter().fold(0.0, f64::max);
        assert!(e < 1e-8 * P, "{virtual_lower:?} {upper_kind:?} gap {gap}: point {q}: stress {st:?}");
    }
    let c = &model.initial().contact.pairs[0];
    let nt = model.constraints.len();
    for l in 0..c.multipliers.num_nodes {
        let pressure = -s.multipliers[nt + c.first_row + l];
        assert!((pressure - P).abs() < 1e-8 * P, "{virtual_lower:?}: node {l}: contact pressure {pressure}");
    }
}

#[test]
fn contact_patch_test_real_surfaces() {
    run(None, CellKind::Tri3, 0.0);
    run(None, CellKind::Quad4, 0.0);
}

#[test]
fn contact_patch_test_virtual_lower_surface() {
    // The lower block's contact surface is a virtual line through its host cells (y = 2.13),
    // or along a host grid line (y = 2).
    run(Some(2.13), CellKind::Tri3, 0.0);
    run(Some(2.0), CellKind::Quad4, 0.0);
}

/// An initial gap of 1 um closes under load (load control): the same uniform state results,
/// shifted; stresses and contact pressure unchanged.
#[test]
fn contact_closes_an_initial_gap() {
    run(None, CellKind::Quad4, 1e-3);
}
/// Displacement control through the upper block's top edge: pressed down by delta the two
/// blocks (heights 2 + 1 mm, same material, laterally free) are in uniaxial stress
/// `sigma_yy = -E' delta / 3` (`E' = E / (1 - nu^2)`, plane strain), which is the contact
/// pressure; lifted by delta the contact opens: zero pressure, zero stress (active set both ways).
#[test]
fn contact_opens_and_closes_under_displacement_control() {
    for delta in [-1e-3, 1e-3] {
        let hyp = PlaneHypothesis::PlaneStrain;
        let mut b = ModelBuilder::new(hyp);
        let mi = b.add_material("steel", Material::Elastic(Elastic { young: E, poisson: NU, hypothesis: hyp }));
        let lower = generate::rectangle(0.0, 0.0, 4.0, 2.0, 8, 4, 1.0, 1.0, CellKind::Quad4).unwrap();
        let upper = generate::rectangle(0.0, 2.0, 4.0, 1.0, 7, 3, 1.0, 1.0, CellKind::Tri3).unwrap();
        let lo = b.add_body("lower", lower, mi, Formulation::Standard, 1.0);
        let up = b.add_body("upper", upper, mi, Formulation::Standard, 1.0);
        b.fix(lo, "bottom", 1, 0.0).unwrap();
        b.fix(lo, "bottom_left", 0, 0.0).unwrap();
        b.fix(up, "top_left", 0, 0.0).unwrap();
        b.fix(up, "top", 1, delta).unwrap();
        let other = ContactOther::Edges(b.global_edges(lo, &["top".to_string()]).unwrap());
        b.add_contact("c", up, &["bottom".to_string()], lo, other, Default::default()).unwrap();
        let model = common::build_one_step(b);
        let s = solve(&model);
        let e_plane = E / (1.0 - NU * NU);
        let sigma = if delta < 0.0 { e_plane * delta / 3.0 } else { 0.0 };
        for (q, st) in s.stress.iter().enumerate() {
            let e = [st[0].abs(), (st[1] - sigma).abs(), st[3].abs()].into_iter().fold(0.0, f64::max);
            assert!(e < 1e-8 * e_plane * 1e-3, "delta {delta}: point {q}: stress {st:?} vs sigma_yy {sigma}");
        }
        let c = &model.initial().contact.pairs[0];
        let nt = model.constraints.len();
        for l in 0..c.multipliers.num_nodes {
            let pressure = -s.multipliers[nt + c.first_row + l];
            assert!(
                (pressure + sigma).abs() < 1e-8 * e_plane * 1e-3,
                "delta {delta}: node {l}: pressure {pressure} vs {}",
                -sigma
            );
        }
    }
}
