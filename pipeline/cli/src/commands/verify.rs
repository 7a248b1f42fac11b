//! `twoscale verify`.

use crate::flags::VerifyArgs;
use anyhow::{bail, Context, Result};

fn tempfile_dir() -> Result<tempfile::TempDir> {
    tempfile::tempdir().context("cannot create a temporary directory")
}

/// Prints one line per table; an error naming every table that fails.
pub fn run_verify(args: &VerifyArgs) -> Result<()> {
    let unpacked = tempfile_dir()?;
    let dir = if args.path.is_file() {
        twoscale_generate::bundle::unpack_bundle(&args.path, unpacked.path())?
    } else {
        args.path.clone()
    };
    let verdicts = twoscale_tables::verify::verify_tree(&dir)?;
    let mut failed = Vec::new();
    for v in &verdicts {
        match &v.result {
            Ok(()) => println!("ok      {}", v.table),
            Err(e) => {
                println!("FAILED  {}: {}", v.table, format!("{e:#}").replace('\n', " "));
                failed.push(v.table.clone());
            }
        }
    }
    if !failed.is_empty() {
        bail!("{} of {} tables failed verification: {}", failed.len(), verdicts.len(), failed.join(", "));
    }
    Ok(())
}
