//! `twoscale export`.

use crate::flags::ExportArgs;
use crate::glue::{input_error, table_name};
use anyhow::{Context, Result};
use twoscale::table::write_bytes_atomic;
use twoscale::tables;
use twoscale_tables::file::open_table;

pub fn run_export(args: &ExportArgs) -> Result<()> {
    let (dir, name) = match &args.folder {
        Some(dir) => (dir.clone(), table_name(&args.table)?),
        None => (args.dir.join(&args.preset), tables::find(&args.table).map_err(input_error)?.name),
    };
    let (manifest, axes, values) = open_table(&dir, name)?;
    if args.format == "npy" {
        for path in twoscale::export::export_npy(name, &axes, &values, &args.out)? {
            println!("{}", path.display());
        }
        return Ok(());
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let path = args.out.join(format!("{}.h", twoscale::export::c_prefix(&manifest)));
    let text = twoscale::export::c_header(&manifest, &axes, &values)?;
    write_bytes_atomic(&path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    println!("{}", path.display());
    Ok(())
}
