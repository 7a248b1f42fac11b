//! twoscale: precomputed tables for the two-scale reflectance model of
//! Holzschuch and Pacanowski (2017). See SPEC.md for the definitions.
//!
//! Layout: `numerics` (quadrature, special functions), `grid` (axes and
//! encodings), `interp` (multilinear interpolation), `table` and `manifest`
//! (files and checksums), `accuracy` (measured errors), `tables` (one module
//! per table), `build` and `cli` (the binaries' logic).

pub mod accuracy;
pub mod build;
pub mod cli;
pub mod grid;
pub mod interp;
pub mod manifest;
pub mod numerics;
pub mod progress;
pub mod table;
pub mod tabulate;
pub mod tables;
