//! `twoscale lookup`.

use crate::flags::LookupArgs;
use crate::glue::{input_error, table_name};
use anyhow::{bail, Result};
use twoscale_generate::tables;
use twoscale_tables::file::manifest_path;

pub fn run_lookup(args: &LookupArgs) -> Result<()> {
    if let Some(dir) = &args.folder {
        let name = table_name(&args.table)?;
        if !manifest_path(dir, name).exists() {
            bail!("no table {name} in {} (no {name}.manifest.json there)", dir.display());
        }
        return print_lookup(&twoscale_tables::lookup::Lookup::open(dir, name)?, name, &args.at, args.json);
    }
    let def = tables::find(&args.table).map_err(input_error)?;
    let dir = args.dir.join(&args.preset);
    if !manifest_path(&dir, def.name).exists() {
        bail!(
            "no {} table for preset {} in {} (build it with `twoscale build --preset {} --table {}`)",
            def.name,
            args.preset,
            args.dir.display(),
            args.preset,
            def.name
        );
    }
    print_lookup(&twoscale_tables::lookup::Lookup::open(&dir, def.name)?, def.name, &args.at, args.json)
}

/// Interpolates `table` at the `--at` coordinates and prints the values.
fn print_lookup(table: &twoscale_tables::lookup::Lookup, name: &str, at: &[String], json: bool) -> Result<()> {
    let point = parse_point(at, &table.coordinates())?;
    let mut out = serde_json::Map::new();
    for (value, v) in table.at(&point).map_err(|e| input_error(e.to_string()))? {
        out.insert(value, serde_json::json!(v));
    }
    if json {
        println!("{}", serde_json::json!({ "table": name, "values": out }));
    } else {
        for (name, v) in &out {
            println!("{name} = {v}");
        }
    }
    Ok(())
}

fn parse_point(at: &[String], axes: &[String]) -> Result<Vec<f64>> {
    let mut point = vec![None; axes.len()];
    for item in at {
        let (name, value) =
            item.split_once('=').ok_or_else(|| input_error(format!("--at {item:?}: expected NAME=VALUE")))?;
        let idx = axes
            .iter()
            .position(|a| a == name)
            .ok_or_else(|| input_error(format!("--at {item:?}: unknown axis {name:?} (axes: {})", axes.join(", "))))?;
        let x: f64 =
            value.trim().parse().map_err(|_| input_error(format!("--at {item:?}: {value:?} is not a number")))?;
        if x.is_nan() {
            return Err(input_error(format!("--at {item:?}: {name} is NaN")));
        }
        if point[idx].replace(x).is_some() {
            return Err(input_error(format!("--at: axis {name:?} given twice")));
        }
    }
    point
        .into_iter()
        .zip(axes)
        .map(|(x, name)| x.ok_or_else(|| input_error(format!("missing --at {name}=VALUE"))))
        .collect()
}
