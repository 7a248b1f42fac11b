//! `twoscale plot`.

use crate::flags::PlotArgs;
use crate::glue::{input_error, table_name};
use anyhow::{bail, Context, Result};
use twoscale_generate::tables;
use twoscale_tables::file::manifest_path;

pub fn run_plot(args: &PlotArgs) -> Result<()> {
    let (dir, name, label) = match &args.folder {
        Some(dir) => {
            let label = dir.file_name().map_or_else(|| "folder".into(), |n| n.to_string_lossy().into_owned());
            (dir.clone(), table_name(&args.table)?, label)
        }
        None => {
            (args.dir.join(&args.preset), tables::find(&args.table).map_err(input_error)?.name, args.preset.clone())
        }
    };
    if !manifest_path(&dir, name).exists() {
        bail!("no {name} table in {} (build it with `twoscale build`)", dir.display());
    }
    let out = args.out.clone().unwrap_or_else(|| args.dir.join("plots").join(format!("{name}-{label}.png")));
    if out.extension().and_then(|e| e.to_str()) != Some("png") {
        return Err(input_error(format!("--out {} must end in .png", out.display())));
    }
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    let summary = twoscale_quality::slices::plot_table(&dir, name, &out)?;
    println!("{summary}\n{}", out.display());
    Ok(())
}
