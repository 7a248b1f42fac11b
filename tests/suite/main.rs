//! The integration tests of the package `twoscale-cli`, pipeline/cli, one test binary: one link of the
//! workspace instead of one per file, and the tests of every file run side by side (the Python and
//! C runtimes' tests wait on their interpreters while the others build and read tables). A new file
//! here is a module: add it below; `common/` holds the shared helpers and the table cache
//! (`common::shared_tables`). `cargo test --test suite NAME` runs the tests whose path contains NAME,
//! e.g. `readers::` or `mitsuba`.

mod common;

mod albedo;
mod brdf_c;
mod epd_known_answers;
mod fuzz;
mod golden;
mod kcorr_known_answers;
mod materials;
mod mitsuba;
mod plan;
mod readers;
mod release;
mod scenes;
mod shards;
mod slurm;
mod stress_properties;
mod tables;
mod zh_known_answers;
mod zh_lobe;
