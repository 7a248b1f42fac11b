//! `twoscale merge`.

use crate::flags::{Common, MergeArgs};
use crate::glue::input_error;
use anyhow::Result;
use twoscale_generate::progress::Progress;
use twoscale_generate::shard::merge;
use twoscale_generate::tables::{self, BuildOptions, TableDef};

/// Merges the shards of the named tables (all by default) of one preset directory.
pub fn run_merge(args: &MergeArgs, common: &Common) -> Result<()> {
    let mut selected: Vec<&'static TableDef> = Vec::new();
    for name in &args.tables {
        selected.push(tables::find(name).map_err(input_error)?);
    }
    if selected.is_empty() {
        selected = tables::TABLES.iter().collect();
    }
    let options =
        BuildOptions { progress: Progress { quiet: common.quiet }, force: args.force, ..BuildOptions::default() };
    merge(&args.dir, &args.preset, &selected, &options)
}
