//! One module per command; each `run` returns what `glue::report` turns into
//! the exit status.

mod bench;
mod build;
mod bundle;
mod export;
mod fit;
mod keygen;
mod lookup;
mod merge;
mod plan;
mod plot;
mod signing;
mod stress;
mod verify;
mod view;

use crate::flags::{Command, Common};
use anyhow::Result;
use twoscale_generate::tables::{self, TableDef};

pub(crate) use build::run_build;

/// Runs a `twoscale` subcommand.
pub(crate) fn run(command: &Command, common: &Common) -> Result<()> {
    match command {
        Command::Build(args) => {
            let all: Vec<&'static TableDef> = tables::TABLES.iter().collect();
            run_build(args, common, &all)
        }
        Command::Merge(args) => merge::run_merge(args, common),
        Command::Lookup(args) => lookup::run_lookup(args),
        Command::Verify(args) => verify::run_verify(args),
        Command::Keygen(args) => keygen::run_keygen(args),
        Command::Export(args) => export::run_export(args),
        Command::View(args) => view::run_view(args),
        Command::Fit(args) => fit::run_fit(args, common),
        Command::Plan(args) => plan::run_plan(args),
        Command::Stress(args) => stress::run_stress(args),
        Command::Bench(args) => bench::run_bench(args, common),
        Command::Plot(args) => plot::run_plot(args),
        Command::Bundle(args) => bundle::run_bundle(args).map(|path| println!("{}", path.display())),
    }
}
