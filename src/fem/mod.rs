//! Finite-element building blocks: quadrature, reference/mapped/surface elements, materials
//! and the local element kernel. Knows nothing of assembly, contact or wear.

pub mod element;
pub mod kernel;
pub mod material;
pub mod quadrature;
