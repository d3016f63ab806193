//! Linear solvers and the Newton driver's parameters and errors.

pub mod dense;
pub mod linear;
pub mod newton;
