//! twoscale: builds the tables of the two-scale reflectance model of
//! Holzschuch and Pacanowski (2017), defined in docs/maths.md. The file
//! contract and the reader (axes, interpolation, manifests, checksums,
//! `Lookup`) are the crate `twoscale-tables`, which this one depends on.
//!
//! Layout: `numerics` (quadrature, special functions), `tables` (one module
//! per table, its maths beside it), `material` (per-material tables),
//! `accuracy` (measured errors), `build`, `shard` and `scene` (what a build
//! computes, and where), `table` (writing files), `verify`, `bundle` and
//! `export` (for other runtimes), `bench`, `stress`, `plot` and `slices`
//! (quality), `cli` (the binaries' logic).

pub mod accuracy;
pub mod bench;
pub mod build;
pub mod bundle;
pub mod cli;
pub mod export;
pub mod material;
pub mod numerics;
pub mod plot;
pub mod progress;
pub mod scene;
pub mod shard;
pub mod slices;
pub mod stress;
pub mod table;
pub mod tabulate;
pub mod tables;
pub mod verify;

pub use verify::verify_dir;
