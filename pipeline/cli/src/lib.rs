//! The code of the twoscale binaries (the package `twoscale-cli`, pipeline/cli):
//! `flags` holds the clap definitions, `commands` one module per command,
//! `glue` what they share (input errors and exit statuses, logging). The
//! binaries are `main.rs` (`twoscale`) and `bin/` (the stage binaries
//! `epd-g1`, `epd-albedo`, `kcorr-renorm` and `zh-convolution`, each building its own tables).
//!
//! Imports go one way: this crate uses `twoscale-quality`, `twoscale` and
//! `twoscale-tables`; none of them uses it.

mod commands;
mod flags;
mod glue;

use flags::{parse_args, Cli, StageCli};
use glue::{init, report};
use std::process::ExitCode;
use twoscale_generate::tables::{self, TableDef};

/// Entry point of `twoscale`.
pub fn main_twoscale() -> ExitCode {
    let cli: Cli = match parse_args("twoscale") {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    init(&cli.common);
    report("twoscale", commands::run(&cli.command, &cli.common))
}

/// Entry point of a stage binary building the tables whose `stage` is `stage`.
pub fn main_stage(stage: &'static str) -> ExitCode {
    let cli: StageCli = match parse_args(stage) {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    init(&cli.common);
    let own: Vec<&'static TableDef> = tables::TABLES.iter().filter(|t| t.stage == stage).collect();
    report(stage, commands::run_build(&cli.build, &cli.common, &own))
}
