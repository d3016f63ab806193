//! # mortex
//!
//! A 2D finite-element engine for contact mechanics and wear, built around the MorteX method
//! (mortar coupling of real and embedded/virtual surfaces). This crate currently holds the FE
//! core: meshes ([`mesh`]), elements and materials ([`fem`]), parallel assembly
//! ([`assembly`]), faer-based solvers ([`solver`]), the static load-stepping analysis
//! ([`analysis`]), case files ([`case`]) and HDF5/XDMF output ([`io`]).
//!
//! Data flows one way: case -> [`model::Model`] -> [`analysis::StaticAnalysis`] ->
//! [`state::SimState`] -> output. Physics modules never print or touch files.

pub mod analysis;
pub mod assembly;
pub mod bench;
pub mod case;
pub mod contact;
pub mod cut;
pub mod discretisation;
pub mod driver;
pub mod fem;
pub mod io;
pub mod mesh;
pub mod model;
pub mod mortar;
pub mod post;
pub mod solver;
pub mod state;
pub mod surface;
pub mod wear;
