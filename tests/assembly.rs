//! Assembly checks: the pattern + scatter assembly equals an independent dense assembly of the
//! same element matrices, and serial and parallel element loops give bit-identical matrices.

mod common;
use common::Lcg;
use mortex::assembly::{Assembler, AssemblyInput, AssemblyOutput, SparsityPattern, CONSTRAINED};
use mortex::fem::kernel::{element_kernel, ElementInput, ElementOutput, Formulation};
use mortex::fem::material::{Elastic, J2Plastic, Material, PlaneHypothesis, PlasticState, Stress4};
use mortex::mesh::{generate, CellKind};
use mortex::model::{Discretisation, Model, ModelBuilder};
use nalgebra::Point2;

/// Two bodies (Quad4 plastic, Tri3 elastic), random displacements so plastic points yield.
fn mixed_model() -> (Model, Vec<f64>) {
    let hyp = PlaneHypothesis::PlaneStrain;
    let el = Elastic { young: 200_000.0, poisson: 0.3, hypothesis: hyp };
    let mut b = ModelBuilder::new(hyp);
    let m0 = b.add_material(
        "pl",
        Material::J2Plastic(J2Plastic {
            elastic: el,
            yield_stress: 200.0,
            isotropic_hardening: 500.0,
            kinematic_hardening: 500.0,
        }),
    );
    let m1 = b.add_material("el", Material::Elastic(el));
    let q = generate::rectangle(0.0, 0.0, 3.0, 2.0, 30, 20, 2.0, 1.0, CellKind::Quad4).unwrap();
    let t = generate::rectangle(4.0, 0.0, 2.0, 2.0, 15, 15, 1.0, 1.0, CellKind::Tri3).unwrap();
    let bq = b.add_body("q", q, m0, Formulation::BBar, 1.0);
    let bt = b.add_body("t", t, m1, Formulation::Standard, 1.0);
    b.fix(bq, "left", 0, 0.0).unwrap();
    b.fix(bq, "left", 1, 0.0).unwrap();
    b.fix(bt, "bottom", 1, 0.0).unwrap();
    b.fix(bt, "bottom_left", 0, 0.0).unwrap();
    let model = common::build_one_step(b);
    let mut rng = Lcg(3);
    let u: Vec<f64> = (0..model.num_dofs()).map(|_| 5e-3 * rng.next()).collect();
    (model, u)
}

fn assemble(
    model: &Model,
    disc: &Discretisation,
    u: &[f64],
    parallel: bool,
) -> (Vec<f64>, Vec<f64>, Vec<PlasticState>, Assembler) {
    let pattern = SparsityPattern::new(model.num_nodes(), &model.elements, &disc.dofs);
    let mut asm = Assembler::new(pattern, &model.elements);
    let (values, f, new) = assemble_with(&mut asm, model, disc, u, parallel);
    (values, f, new, asm)
}

/// One assembly with `asm` from the virgin state: matrix values, internal force, trial history.
fn assemble_with(
    asm: &mut Assembler,
    model: &Model,
    disc: &Discretisation,
    u: &[f64],
    parallel: bool,
) -> (Vec<f64>, Vec<f64>, Vec<PlasticState>) {
    let old = vec![PlasticState::default(); model.elements.num_states()];
    assemble_from(asm, (model, disc), u, &old, true, parallel)
}

/// One assembly with `asm` from the history `old`: matrix values (if `with_k`), internal
/// force, trial history.
fn assemble_from(
    asm: &mut Assembler,
    (model, disc): (&Model, &Discretisation),
    u: &[f64],
    old: &[PlasticState],
    with_k: bool,
    parallel: bool,
) -> (Vec<f64>, Vec<f64>, Vec<PlasticState>) {
    let mut values = vec![0.0; asm.pattern.nnz()];
    let mut f = vec![0.0; model.num_dofs()];
    let mut stress = vec![Stress4::zeros(); model.elements.num_points()];
    let mut new = old.to_vec();
    asm.assemble(
        &AssemblyInput {
            coords: &model.coords,
            elements: &model.elements,
            materials: &model.materials,
            rules: &disc.rules,
            u,
            state_old: old,
        },
        AssemblyOutput {
            values: if with_k { Some(&mut values) } else { None },
            f_int: &mut f,
            stress: &mut stress,
            state_new: &mut new,
        },
        parallel,
    );
    (values, f, new)
}

#[test]
fn serial_and_parallel_assembly_are_bit_identical() {
    let (model, u) = mixed_model();
    let (vs, fs, hs, _) = assemble(&model, model.initial(), &u, false);
    let (vp, fp, hp, _) = assemble(&model, model.initial(), &u, true);
    assert!(hs.iter().any(|h| h.alpha > 0.0), "the random state must yield somewhere");
    assert_eq!(vs, vp);
    assert_eq!(fs, fp);
    assert_eq!(hs, hp);
}

#[test]
fn sparse_assembly_equals_dense_reference() {
    let (model, u) = mixed_model();
    let (values, f, _, asm) = assemble(&model, model.initial(), &u, true);
    let n = model.initial().dofs.num_free;
    // Dense reference: K[eq_i][eq_j] += ke[i][j] straight from the kernel, no pattern.
    let mut dense = vec![0.0; n * n];
    let mut fref = vec![0.0; model.num_dofs()];
    let el = &model.elements;
    let old = vec![PlasticState::default(); 4];
    for e in 0..el.len() {
        let nn = el.kind[e].num_nodes();
        let mut coords = [Point2::origin(); 4];
        let mut ue = [0.0; 8];
        for a in 0..nn {
            coords[a] = model.coords[el.nodes[e][a]];
            ue[2 * a] = u[2 * el.nodes[e][a]];
            ue[2 * a + 1] = u[2 * el.nodes[e][a] + 1];
        }
        let ns = el.state_offset[e + 1] - el.state_offset[e];
        let mut ke = [0.0; 64];
        let mut fe = [0.0; 8];
        let mut st = [Stress4::zeros(); 4];
        let mut hn = [PlasticState::default(); 4];
        element_kernel(
            &ElementInput {
                kind: el.kind[e],
                coords,
                u: ue,
                rule: &model.initial().rules[el.rule[e]],
                formulation: el.formulation[e],
                material: &model.materials[el.material[e]],
                thickness: 1.0,
                state_old: &old[..ns],
                geometry: None,
                elastic_ke: None,
                elastic_force_from_ke: false,
            },
            &mut ElementOutput {
                ke: Some(&mut ke),
                fe: &mut fe,
                stress: &mut st[..el.point_offset[e + 1] - el.point_offset[e]],
                state_new: &mut hn[..ns],
                elastic: false,
            },
        );
        for i in 0..2 * nn {
            let gi = 2 * el.nodes[e][i / 2] + i % 2;
            fref[gi] += fe[i];
            for j in 0..2 * nn {
                let gj = 2 * el.nodes[e][j / 2] + j % 2;
                let (ri, cj) = (model.initial().dofs.eq[gi], model.initial().dofs.eq[gj]);
                if ri != CONSTRAINED && cj != CONSTRAINED {
                    dense[ri * n + cj] += ke[i * 8 + j];
                }
            }
        }
    }
    let sym = &asm.pattern.symbolic;
    let mut from_sparse = vec![0.0; n * n];
    for j in 0..n {
        for p in sym.col_ptr()[j]..sym.col_ptr()[j + 1] {
            from_sparse[sym.row_idx()[p] * n + j] = values[p];
        }
    }
    let kmax = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = dense.iter().zip(&from_sparse).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    // Same sums in a different order: round-off only (1e-13 relative).
    assert!(diff <= 1e-13 * kmax, "max |K_sparse - K_dense| = {diff:e} (|K| = {kmax:e})");
    let fmax = fref.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let fdiff = fref.iter().zip(&f).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(fdiff <= 1e-13 * fmax);
    // Symmetric tangent (associative J2 with the consistent tangent; elasticity).
    let asym = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .fold(0.0f64, |m, (i, j)| m.max((from_sparse[i * n + j] - from_sparse[j * n + i]).abs()));
    assert!(asym <= 1e-10 * kmax, "asymmetry {asym:e}");
}

/// `B^T K^{-1} B` of sparse rows `B` over `n` equations, one solve per column.
fn operator_by_column_solves(
    solver: &mortex::solver::linear::SparseSolver,
    rows: &[Vec<(usize, f64)>],
    n: usize,
) -> Vec<Vec<f64>> {
    let mut reference = vec![vec![0.0; rows.len()]; rows.len()];
    for (j, row) in rows.iter().enumerate() {
        let mut x = vec![0.0; n];
        for &(e, c) in row {
            x[e] += c;
        }
        solver.solve(&mut x).unwrap();
        for (i, r) in rows.iter().enumerate() {
            reference[i][j] = r.iter().map(|&(e, c)| c * x[e]).sum();
        }
    }
    reference
}

/// The interface operator `B^T K^{-1} B` of sparse rows `B` by forward substitution on the
/// elimination-tree ancestors only (`SparseSolver::congruence`) against one full solve per
/// column: a clamped elastic block (120 x 80 Quad4, 19k DOFs: faer picks a supernodal factor),
/// 60 rows of 3 random free equations each. The same factor, two summation orders: they
/// agree to round-off (5e-16 of the largest entry measured; 1e-13 allows for other
/// orderings and BLAS kernels).
#[test]
fn interface_operator_by_forward_substitution_equals_column_solves() {
    use mortex::solver::linear::{LinearSolverKind, SparseSolver};
    let hyp = PlaneHypothesis::PlaneStrain;
    let mut b = ModelBuilder::new(hyp);
    let m = b.add_material("el", Material::Elastic(Elastic { young: 200_000.0, poisson: 0.3, hypothesis: hyp }));
    let q = generate::rectangle(0.0, 0.0, 3.0, 2.0, 120, 80, 4.0, 1.0, CellKind::Quad4).unwrap();
    let body = b.add_body("q", q, m, Formulation::Standard, 1.0);
    b.fix(body, "left", 0, 0.0).unwrap();
    b.fix(body, "left", 1, 0.0).unwrap();
    let model = common::build_one_step(b);
    let u = vec![0.0; model.num_dofs()];
    let (values, _, _, asm) = assemble(&model, model.initial(), &u, true);
    let mut solver = SparseSolver::new(&asm.pattern.symbolic, LinearSolverKind::Cholesky).unwrap();
    solver.factor(&values).unwrap();
    let n = model.initial().dofs.num_free;
    let mut rng = Lcg(11);
    let rows: Vec<Vec<(usize, f64)>> = (0..60)
        .map(|_| (0..3).map(|_| (((rng.next() * 0.5 + 0.5) * n as f64) as usize % n, rng.next())).collect())
        .collect();
    let reference = operator_by_column_solves(&solver, &rows, n);
    let scale = reference.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
    for from in [0, 25] {
        let d = solver.congruence(&rows, from, 0).expect("a supernodal Cholesky factor");
        assert_eq!((d.nrows(), d.ncols()), (rows.len(), rows.len() - from));
        for i in 0..rows.len() {
            for j in from..rows.len() {
                let err = (d[(i, j - from)] - reference[i][j]).abs();
                assert!(
                    err <= 1e-13 * scale,
                    "D[{i}][{j}]: {} vs {} ({:.1e})",
                    d[(i, j - from)],
                    reference[i][j],
                    err / scale
                );
            }
        }
    }
}

/// The assembler keeps the mapped geometry of every point between assemblies; when the rule
/// points change under it (a re-cut moves a band cell's points), it must see the change: the
/// same assembler after the change gives bit for bit what a fresh one gives, also when the
/// tables are shared with it (it keeps their hashes).
#[test]
fn assembler_geometry_follows_changed_rule_points() {
    let (model, u) = mixed_model();
    let (_, _, _, mut asm) = assemble(&model, model.initial(), &u, true);
    let r = model.elements.rule[0];
    let mut disc = model.initial().clone();
    std::sync::Arc::make_mut(&mut disc.rules)[r].points[0][0] *= 0.5;
    let reused = assemble_with(&mut asm, &model, &disc, &u, true);
    let (values, f, new, _) = assemble(&model, &disc, &u, true);
    assert_eq!(reused, (values, f, new));
    // The same through shared tables (the assembler keeps a shared table's hashes): the
    // changed table is another table, and an assembly from a table other than the shared one
    // is hashed as before.
    let (_, _, _, mut shared) = assemble(&model, model.initial(), &u, true);
    shared.share_rules(&model.initial().rules);
    let before = assemble_with(&mut shared, &model, model.initial(), &u, true);
    assert_eq!(before, assemble_with(&mut shared, &model, model.initial(), &u, true));
    let mut changed = model.initial().clone();
    std::sync::Arc::make_mut(&mut changed.rules)[r].points[0][0] *= 0.5;
    shared.share_rules(&changed.rules);
    assert_eq!(assemble_with(&mut shared, &model, &changed, &u, true), reused);
    assert_eq!(assemble_with(&mut shared, &model, model.initial(), &u, true), before);
    // A table its sole owner changes in place (as a re-cut does): the assembler's link is cut.
    let mut owned = model.initial().clone();
    owned.rules = std::sync::Arc::new(model.initial().rules.as_ref().clone());
    shared.share_rules(&owned.rules);
    assert_eq!(assemble_with(&mut shared, &model, &owned, &u, true), before);
    std::sync::Arc::make_mut(&mut owned.rules)[r].points[0][0] *= 0.5;
    assert_eq!(assemble_with(&mut shared, &model, &owned, &u, true), reused);
}

/// An assembler keeps the stiffness of every element whose points all stayed elastic and
/// reuses it while they stay elastic (the tangent of a yielding run is integrated only where
/// the material flows). Bit for bit the tangent of a fresh assembler: J2 B-bar Quad4 and
/// elastic Tri3 bent so that part of the points flow, assembled after an elastic assembly
/// (every stiffness kept), then at the reversed bend from the plastic state; a re-cut weight
/// (changed rule) drops what its elements kept, and only theirs.
#[test]
fn kept_elastic_stiffnesses_give_the_fresh_tangent_bit_for_bit() {
    let (model, _) = mixed_model();
    let disc = model.initial();
    let bend = |c: f64| -> Vec<f64> {
        (0..model.num_dofs())
            .map(|d| {
                let p = model.coords[d / 2];
                c * if d % 2 == 0 { p.x * p.y } else { -0.5 * p.x * p.x }
            })
            .collect()
    };
    let fresh = |d: &mortex::model::Discretisation, u: &[f64], old: &[PlasticState]| {
        let pattern = SparsityPattern::new(model.num_nodes(), &model.elements, &d.dofs);
        let mut asm = Assembler::new(pattern, &model.elements);
        assemble_from(&mut asm, (&model, d), u, old, true, true)
    };
    let pattern = SparsityPattern::new(model.num_nodes(), &model.elements, &disc.dofs);
    let mut kept = Assembler::new(pattern, &model.elements);
    let virgin = vec![PlasticState::default(); model.elements.num_states()];
    // Elastic everywhere (strain 1e-5): every element's stiffness is kept.
    let elastic = bend(1e-5);
    assert_eq!(assemble_from(&mut kept, (&model, disc), &elastic, &virgin, true, true), fresh(disc, &elastic, &virgin));
    // Twice the yield strain at the top: part of the points flow.
    let bent = bend(1e-3);
    let at_bent = assemble_from(&mut kept, (&model, disc), &bent, &virgin, true, true);
    let flowing = at_bent.2.iter().zip(&virgin).filter(|(a, b)| a.alpha > b.alpha).count();
    assert!(flowing > 0 && flowing < virgin.len(), "{flowing} of {} points flow", virgin.len());
    assert_eq!(at_bent, fresh(disc, &bent, &virgin));
    let reversed: Vec<f64> = bent.iter().map(|v| -0.6 * v).collect();
    assert_eq!(
        assemble_from(&mut kept, (&model, disc), &reversed, &at_bent.2, true, true),
        fresh(disc, &reversed, &at_bent.2)
    );
    let mut recut = disc.clone();
    let r = model.elements.rule[0];
    std::sync::Arc::make_mut(&mut recut.rules)[r].weights[0] *= 0.5;
    assert_eq!(
        assemble_from(&mut kept, (&model, &recut), &elastic, &virgin, true, true),
        fresh(&recut, &elastic, &virgin)
    );
    // Kept per element: back to the first rules, the elements of rule `r` are integrated
    // again and the others keep what they kept; bit for bit the fresh tangent either way.
    assert_eq!(assemble_from(&mut kept, (&model, disc), &elastic, &virgin, true, true), fresh(disc, &elastic, &virgin));
    assert_eq!(
        assemble_from(&mut kept, (&model, &recut), &elastic, &virgin, true, true),
        fresh(&recut, &elastic, &virgin)
    );
}

/// The assembled tangent is the derivative of the assembled internal force (the consistent
/// tangent of the J2 return mapping, Simo & Taylor, CMAME 48 (1985) 101, through B-bar Quad4 and
/// elastic Tri3): `K v` against central differences `(f(u + h v) - f(u - h v)) / 2h` along
/// random directions `v`, at a bent state where part of the points yield from the virgin state,
/// and at the reversed bend from that plastic state (elastic unloading at some points, reverse
/// yield at others). Tolerance 1e-6 of `|K v|`: central differences with h = 1e-9 (strain
/// perturbations about 1e-8) carry round-off about 1e-9 relative and truncation below it, unless
/// a point crosses the yield surface within +-h (measured 7e-10 with 840 of 2,400 points
/// flowing, 4e-10 with 435 reverse-flowing).
#[test]
fn assembled_tangent_is_the_derivative_of_the_internal_force_across_yield() {
    let (model, _) = mixed_model();
    let disc = model.initial();
    let pattern = SparsityPattern::new(model.num_nodes(), &model.elements, &disc.dofs);
    let mut asm = Assembler::new(pattern, &model.elements);
    let n = disc.dofs.num_free;
    // Bending, strain c y (c = 1e-3 /mm over the 2 mm height: twice the yield strain at the
    // top), with a little noise.
    let mut rng = Lcg(5);
    let u: Vec<f64> = (0..model.num_dofs())
        .map(|d| {
            let p = model.coords[d / 2];
            let smooth = if d % 2 == 0 { 1e-3 * p.x * p.y } else { -0.5e-3 * p.x * p.x };
            smooth + 1e-6 * rng.next()
        })
        .collect();
    let virgin = vec![PlasticState::default(); model.elements.num_states()];
    // A plastic history to reverse from: the state at u.
    let (_, _, at_u) = assemble_with(&mut asm, &model, disc, &u, false);
    let reversed: Vec<f64> = u.iter().map(|v| -0.6 * v).collect();
    for (name, old, at) in [("from the virgin state", &virgin, &u), ("reversed from a plastic state", &at_u, &reversed)]
    {
        let force =
            |asm: &mut Assembler, x: &[f64], with_k: bool| assemble_from(asm, (&model, disc), x, old, with_k, false);
        let (values, _, new) = force(&mut asm, at, true);
        let plastic = new.iter().zip(old.iter()).filter(|(a, b)| a.alpha > b.alpha).count();
        assert!(plastic > 0 && plastic < new.len(), "{name}: {plastic} of {} points flow", new.len());
        let sym = asm.pattern.symbolic.clone();
        let mut rng = Lcg(11);
        for trial in 0..3 {
            let v: Vec<f64> =
                (0..model.num_dofs()).map(|d| if disc.dofs.eq[d] != CONSTRAINED { rng.next() } else { 0.0 }).collect();
            let mut vf = vec![0.0; n];
            for (d, &e) in disc.dofs.eq.iter().enumerate() {
                if e != CONSTRAINED {
                    vf[e] = v[d];
                }
            }
            let mut kv = vec![0.0; n];
            for (j, vj) in vf.iter().enumerate() {
                for p in sym.col_ptr()[j]..sym.col_ptr()[j + 1] {
                    kv[sym.row_idx()[p]] += values[p] * vj;
                }
            }
            let h = 1e-9;
            let shifted = |s: f64| at.iter().zip(&v).map(|(a, b)| a + s * b).collect::<Vec<f64>>();
            let (_, fp, _) = force(&mut asm, &shifted(h), false);
            let (_, fm, _) = force(&mut asm, &shifted(-h), false);
            let mut fd = vec![0.0; n];
            for (d, &e) in disc.dofs.eq.iter().enumerate() {
                if e != CONSTRAINED {
                    fd[e] = (fp[d] - fm[d]) / (2.0 * h);
                }
            }
            let norm = kv.iter().map(|x| x * x).sum::<f64>().sqrt();
            let err = kv.iter().zip(&fd).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt() / norm;
            eprintln!("{name} ({plastic} points flowing), direction {trial}: |K v - FD| / |K v| = {err:.1e}");
            assert!(err < 1e-6, "{name}, direction {trial}: {err:.2e}");
        }
    }
}

/// A yielding run's elastic elements take their force from their kept stiffness (`K_e u_e`)
/// and leave their stresses to `elastic_stresses`: against a fresh assembly at the same
/// displacement, the force agrees to round-off (the same integral summed in another order:
/// 1e-12 of the largest entry), the yielding body's stresses and history are bit for bit
/// the same, and `elastic_stresses` writes the elastic points' stresses bit for bit.
#[test]
fn elastic_force_from_kept_stiffness_equals_the_integrated_force() {
    let (model, u) = mixed_model();
    let disc = model.initial();
    let pattern = SparsityPattern::new(model.num_nodes(), &model.elements, &disc.dofs);
    let mut asm = Assembler::new(pattern, &model.elements);
    asm.set_elastic_force_from_kept(true);
    let old = vec![PlasticState::default(); model.elements.num_states()];
    // The first tangent assembly keeps the elastic stiffnesses; the second reads them.
    assemble_from(&mut asm, (&model, disc), &u, &old, true, true);
    let u2: Vec<f64> = u.iter().map(|v| -0.7 * v).collect();
    let mut stress = vec![Stress4::repeat(f64::NAN); model.elements.num_points()];
    let mut f = vec![0.0; model.num_dofs()];
    let mut new = old.clone();
    let input = AssemblyInput {
        coords: &model.coords,
        elements: &model.elements,
        materials: &model.materials,
        rules: &disc.rules,
        u: &u2,
        state_old: &old,
    };
    asm.assemble(
        &input,
        AssemblyOutput { values: None, f_int: &mut f, stress: &mut stress, state_new: &mut new },
        true,
    );
    let (_, f_ref, new_ref, mut fresh) = assemble(&model, disc, &u2, true);
    let scale = f_ref.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = f.iter().zip(&f_ref).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!("force from kept stiffnesses: {:.1e} of the largest entry", err / scale);
    assert!(err <= 1e-12 * scale, "force {:.2e} of {scale:.3e}", err / scale);
    assert_eq!(new, new_ref);
    let mut stress_ref = vec![Stress4::zeros(); model.elements.num_points()];
    let mut f2 = vec![0.0; model.num_dofs()];
    let mut new2 = old.clone();
    fresh.assemble(
        &input,
        AssemblyOutput { values: None, f_int: &mut f2, stress: &mut stress_ref, state_new: &mut new2 },
        true,
    );
    let el = &model.elements;
    let elastic_points: Vec<usize> = (0..el.len())
        .filter(|&e| matches!(model.materials[el.material[e]], Material::Elastic(_)))
        .flat_map(|e| el.point_offset[e]..el.point_offset[e + 1])
        .collect();
    assert!(!elastic_points.is_empty());
    for p in 0..stress.len() {
        if elastic_points.binary_search(&p).is_ok() {
            assert!(stress[p][0].is_nan(), "point {p}: an elastic point's stress was written");
        } else {
            assert_eq!(stress[p], stress_ref[p], "point {p}");
        }
    }
    asm.elastic_stresses(&input, &mut stress);
    assert_eq!(stress, stress_ref);
}

/// Two independent bodies factor as two blocks (`SparseSolver` splits the matrix where it is
/// block-diagonal and refactors only a block whose values changed; each block keeps its share
/// of the interface operator while its factor and columns stay). Against the unsplit LU of
/// the same matrix: solves and the operator `B^T K^{-1} B` of 40 random rows spanning both
/// bodies agree to 1e-12 of the largest value (two different factorisations, LU and
/// Cholesky, of a stiffness of condition about 1e5; measured 1-2e-13), after changing either
/// body's stiffness in turn; calling it again with the same rows gives the same bits. With its
/// first 10 rows fixed (each block keeps their substitution and share), the operator of other
/// rows after them is within the same bound and bit for bit what a fresh solver gives.
#[test]
fn block_factor_of_independent_bodies_equals_the_whole_factor() {
    use mortex::solver::linear::{LinearSolverKind, SparseSolver};
    let hyp = PlaneHypothesis::PlaneStrain;
    let two_blocks = |e0: f64, e1: f64| {
        let mut b = ModelBuilder::new(hyp);
        let m0 = b.add_material("a", Material::Elastic(Elastic { young: e0, poisson: 0.3, hypothesis: hyp }));
        let m1 = b.add_material("b", Material::Elastic(Elastic { young: e1, poisson: 0.3, hypothesis: hyp }));
        let q0 = generate::rectangle(0.0, 0.0, 3.0, 2.0, 30, 20, 2.0, 1.0, CellKind::Quad4).unwrap();
        let q1 = generate::rectangle(4.0, 0.0, 2.0, 2.0, 25, 25, 1.0, 1.0, CellKind::Quad4).unwrap();
        let b0 = b.add_body("a", q0, m0, Formulation::Standard, 1.0);
        let b1 = b.add_body("b", q1, m1, Formulation::Standard, 1.0);
        for body in [b0, b1] {
            b.fix(body, "left", 0, 0.0).unwrap();
            b.fix(body, "left", 1, 0.0).unwrap();
        }
        common::build_one_step(b)
    };
    let model = two_blocks(200_000.0, 70_000.0);
    let n = model.initial().dofs.num_free;
    let mut rng = Lcg(5);
    let rows: Vec<Vec<(usize, f64)>> = (0..40)
        .map(|_| (0..3).map(|_| (((rng.next() * 0.5 + 0.5) * n as f64) as usize % n, rng.next())).collect())
        .collect();
    let (_, _, _, asm) = assemble(&model, model.initial(), &vec![0.0; model.num_dofs()], true);
    let mut split = SparseSolver::new(&asm.pattern.symbolic, LinearSolverKind::Cholesky).unwrap();
    let mut whole = SparseSolver::new(&asm.pattern.symbolic, LinearSolverKind::Lu).unwrap();
    for (e0, e1) in [(200_000.0, 70_000.0), (50_000.0, 70_000.0), (50_000.0, 300_000.0)] {
        let m = two_blocks(e0, e1);
        let (values, _, _, _) = assemble(&m, m.initial(), &vec![0.0; m.num_dofs()], true);
        split.factor(&values).unwrap();
        whole.factor(&values).unwrap();
        let rhs: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        let (mut x, mut x_ref) = (rhs.clone(), rhs);
        split.solve(&mut x).unwrap();
        whole.solve(&mut x_ref).unwrap();
        let x_scale = x_ref.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let err = x.iter().zip(&x_ref).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(err <= 1e-12 * x_scale, "solve: {:.1e}", err / x_scale);
        let reference = operator_by_column_solves(&whole, &rows, n);
        let scale = reference.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
        let mut worst = 0.0f64;
        let check = |d: &nalgebra::DMatrix<f64>, reference: &[Vec<f64>], from: usize, worst: &mut f64| {
            for i in 0..rows.len() {
                for j in from..rows.len() {
                    let err = (d[(i, j - from)] - reference[i][j]).abs();
                    *worst = worst.max(err / scale);
                    assert!(err <= 1e-12 * scale, "E = ({e0}, {e1}), D[{i}][{j}]: {:.1e}", err / scale);
                }
            }
        };
        // (from, fixed): the whole operator, its last columns, and the whole with its first
        // rows fixed (their share kept by each block from the first such call).
        for (from, fixed) in [(0, 0), (15, 0), (15, 0), (0, 10), (0, 10)] {
            let d = split.congruence(&rows, from, fixed).expect("block factors");
            check(&d, &reference, from, &mut worst);
            assert_eq!(d, split.congruence(&rows, from, fixed).unwrap());
        }
        // Other rows after the fixed ones: the kept share serves them, and the result is what a
        // solver that never saw the first rows gives, bit for bit (a restart forms it so).
        let mut moved = rows.clone();
        for row in moved.iter_mut().skip(10) {
            for entry in row.iter_mut() {
                entry.0 = (entry.0 + 7) % n;
            }
        }
        let moved_reference = operator_by_column_solves(&whole, &moved, n);
        let d = split.congruence(&moved, 0, 10).expect("block factors");
        check(&d, &moved_reference, 0, &mut worst);
        let mut fresh = SparseSolver::new(&asm.pattern.symbolic, LinearSolverKind::Cholesky).unwrap();
        fresh.factor(&values).unwrap();
        assert_eq!(d, fresh.congruence(&moved, 0, 10).unwrap(), "E = ({e0}, {e1}): kept share");
        println!("E = ({e0}, {e1}): solve {:.1e}, operator {worst:.1e}", err / x_scale);
    }
}
