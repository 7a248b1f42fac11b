//! Shared numerics: quadrature, special functions, random probes.

pub mod legendre;
pub mod quadrature;
pub mod sampling;
pub mod special;
pub mod vector_math;
