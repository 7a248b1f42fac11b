//! twoscale-generate: builds the tables of the two-scale reflectance model of
//! Holzschuch and Pacanowski (2017), defined in docs/maths.md. The file
//! contract and the reader (axes, interpolation, manifests, checksums,
//! `Lookup`) are the crate `twoscale-tables`, which this one depends on.
//!
//! Layout: `numerics` (quadrature, special functions, `tabulate`), `tables` (one module
//! per table, its maths beside it, and the registry), `material` (the
//! per-material tables), `accuracy` (measured errors), `build`, `shard`,
//! `scene` and `scene_tables` (what a build computes, and where), and `ship`
//! (export, WebGL files, bundles, signing: carries built tables to other
//! runtimes and builds none; no builder imports it). Files are written through
//! `twoscale_tables::table`. Quality (bench, stress, plots) is the crate
//! `twoscale-quality`, the binaries' code the package `twoscale-cli`; both
//! depend on this one, never the reverse.

pub mod accuracy;
pub mod build;
pub mod material;
pub mod numerics;
pub mod progress;
pub mod scene;
pub mod scene_tables;
pub mod shard;
pub mod ship;
pub mod tables;
