//! twoscale-quality: how good and how fast the tables of the crate `twoscale-generate`
//! are. `bench` (time against error for every table, against published-method
//! baselines, and a profile), `stress` (the invariants of docs/maths.md at and
//! beyond every domain edge), `plot` (drawing) and `slices` (a built table's
//! slice with its error after interpolation). The criterion benches are in
//! benches/ (`cargo bench -p twoscale-quality`).
//!
//! Imports go one way: the CLI uses this crate; this crate uses `twoscale`
//! (building) and `twoscale-tables` (the file contract), never the reverse.

pub mod bench;
pub mod plot;
pub mod slices;
pub mod stress;
