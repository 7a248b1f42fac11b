//! Shared numerics: quadrature, special functions, random probes, evaluation over a grid.

pub mod legendre;
pub mod quadrature;
pub mod sampling;
pub mod special;
pub mod tabulate;
pub mod vector_math;
