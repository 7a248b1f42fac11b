//! The integration tests of the package `twoscale-cli`, pipeline/cli, one test binary: one link of the
//! workspace instead of one per file, and the tests of every file run side by side (the Python and
//! C runtimes' tests wait on their interpreters while the others build and read tables). A new file
//! goes in the folder of what it tests (presets, read, verify, scenes, cluster, quality, runtimes) as
//! a module; `common/` holds the shared helpers and the table cache (`common::shared_tables`).
//! `cargo test --test suite NAME` runs the tests whose path contains NAME, e.g. `read::` or
//! `runtimes::`.

mod common;

// Grouped by what a user does.
mod cluster;
mod fit;
mod house;
mod presets;
mod quality;
mod read;
mod runtimes;
mod scenes;
mod verify;
