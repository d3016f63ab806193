//! # mortex
//!
//! A 2D finite-element engine for contact mechanics and wear, built around the MorteX method:
//! mortar coupling of real and embedded (virtual) surfaces that cut through their host mesh.
//! One engine ties overlapping meshes, solves frictional contact (monolithic augmented
//! Lagrangian Newton) and runs Archard-type wear, moving the worn virtual surface inside its
//! host mesh without remeshing.
//!
//! The rooms, from the bottom of the stack up (each uses only the rooms below it; the test
//! `tests/layering.rs` checks it):
//! * [`mesh`], [`solver`]: meshes (generators, Gmsh reader); faer sparse solvers, interface
//!   operator, Newton parameters.
//! * [`fem`]: reference and mapped elements, quadrature, materials, element kernels.
//! * [`assembly`], [`surface`]: DOF map, sparsity pattern and parallel assembly; virtual
//!   polylines embedded in their host mesh.
//! * [`cut`]: cut cells and their quadrature (partial integration, moment fitting).
//! * [`moving`], [`mortar`]: moving virtual surfaces on fixed points; multiplier
//!   spaces and mortar integrals (tying and contact rows).
//! * [`contact`]: contact law (normal and Coulomb), pairs, per-node contact field.
//! * [`wear`]: wear laws, swept wear along the stroke, rate filter, cycle jump; [`fatigue`]:
//!   the SWT critical plane of a point's stress-strain history and its strain-life.
//! * [`state`]: [`state::SimState`], the one mutable struct (what a checkpoint holds).
//! * [`model`]: [`model::Model`], the immutable problem data, and its builder;
//!   [`model::Discretisation`], a placement of the surfaces and what follows from it (cuts,
//!   DOF map, contact rows), with its read-only queries; the model keeps its builder's one.
//! * [`geometry`]: the moving geometry: what derives another discretisation as surfaces move,
//!   wear and re-pair (re-embedding, re-cutting on the fixed points, re-pairing).
//! * [`solve`]: the solve of one step ([`solve::StepSolver`]): load stepping with cut-backs,
//!   monolithic Newton and condensed active-set iteration, finite sliding's pairing fixed
//!   point; it owns the geometry of the moment and returns a [`solve::SolvedStep`].
//! * [`driver`]: runs a case: load steps, or the wear loop around the contact solve.
//! * [`post`], [`io`], [`case`]: derived fields; HDF5/XDMF output, checkpoints, plots; case
//!   files (TOML) into a validated model.
//! * [`scenes`]: model scenes shared by the tests, benches and `mortex bench` (nothing in the
//!   library uses them).
//!
//! Physics modules never print or touch files; logging goes through `tracing`.

pub mod assembly;
pub mod case;
pub mod contact;
pub mod cut;
pub mod driver;
pub mod fatigue;
pub mod fem;
pub mod geometry;
pub mod io;
pub mod mesh;
pub mod model;
pub mod mortar;
pub mod moving;
pub mod post;
pub mod relocation;
pub mod scenes;
pub mod solve;
pub mod solver;
pub mod state;
pub mod surface;
pub mod wear;
