//! twoscale: precomputed tables for the two-scale reflectance model of
//! Holzschuch and Pacanowski (2017). See SPEC.md for the definitions.
//!
//! Layout: `numerics` (quadrature, special functions), `grid` (axes and
//! encodings), `interp` (multilinear interpolation), `table` and `manifest`
//! (files and checksums), `accuracy` (measured errors), `tables` (one module
//! per table), `build` and `cli` (the binaries' logic), `verify`, `bundle`
//! and `export` (for other runtimes), `bench` (time against error), `plot`
//! and `slices` (pictures).
//!
//! Reading a table from Rust: open it (which checks its data against the
//! manifest's checksums), then interpolate as `twoscale lookup` does.
//!
//! ```no_run
//! use std::path::Path;
//!
//! # fn main() -> anyhow::Result<()> {
//! // Every table of a preset directory against its manifest (file and data checksums).
//! for verdict in twoscale::verify_dir(Path::new("tables-out/default"))? {
//!     verdict.result?;
//! }
//! // One table: the axes (with their encodings) and the values, checksums verified.
//! let (manifest, axes, values) = twoscale::open_table(Path::new("tables-out/default"), "epd_g1")?;
//! let (name, g1) = &values[0];
//! let at = [1.5, 0.7]; // p, a, in the order of `axes`
//! let g = twoscale::interpolate(&axes, &g1.view(), &at)?;
//! println!("{} {name}({at:?}) = {g}", manifest.table);
//! # Ok(())
//! # }
//! ```

pub mod accuracy;
pub mod bench;
pub mod build;
pub mod bundle;
pub mod cli;
pub mod derived;
pub mod export;
pub mod grid;
pub mod interp;
pub mod lookup;
pub mod manifest;
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

pub use table::open_table;
pub use interp::interpolate;
pub use verify::verify_dir;
