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

use flags::{parse_args, Cli, Command, StageCli};
use glue::{init, report};
use std::process::ExitCode;
use twoscale_generate::tables::{self, TableDef};

/// Entry point of `twoscale`.
pub fn main_twoscale() -> ExitCode {
    let cli: Cli = match parse_args("twoscale") {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    if !matches!(cli.command, Command::View(_)) {
        quiet_on_a_closed_pipe();
    }
    init(&cli.common);
    report("twoscale", commands::run(&cli.command, &cli.common))
}

/// Output cut short (`twoscale verify ... | head -1`) ends the process quietly, as it does a Unix tool:
/// SIGPIPE's default action, where Rust's runtime ignores it and `println!` panics on the broken pipe.
/// Not for `twoscale view`, whose server must see a client that went away as a write error.
fn quiet_on_a_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: called before any thread starts; SIG_DFL is a valid disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Entry point of a stage binary building the tables whose `stage` is `stage`.
pub fn main_stage(stage: &'static str) -> ExitCode {
    let cli: StageCli = match parse_args(stage) {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    quiet_on_a_closed_pipe();
    init(&cli.common);
    let own: Vec<&'static TableDef> = tables::TABLES.iter().filter(|t| t.stage == stage).collect();
    report(stage, commands::run_build(&cli.build, &cli.common, &own))
}
