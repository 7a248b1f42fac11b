//! `twoscale export`.

use crate::flags::ExportArgs;
use crate::glue::{input_error, table_name};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use twoscale_generate::tables;
use twoscale_tables::file::{manifest_path, open_table, read_manifest};
use twoscale_tables::table::write_bytes_atomic;

pub fn run_export(args: &ExportArgs) -> Result<()> {
    let Some(table) = &args.table else {
        let dir = args.folder.as_ref().ok_or_else(|| {
            input_error("export: give --table, or --dir with a material folder to export all its tables")
        })?;
        return export_material(args, dir);
    };
    let (dir, name) = match &args.folder {
        Some(dir) => (dir.clone(), table_name(table)?),
        None => (args.dir.join(&args.preset), tables::find(table).map_err(input_error)?.name),
    };
    let (manifest, axes, values) = open_table(&dir, name)?;
    if args.format == "npy" {
        return print_paths(twoscale_generate::export::export_npy(name, &axes, &values, &args.out)?);
    }
    let header = (
        format!("{}.h", twoscale_generate::export::c_prefix(&manifest)),
        twoscale_generate::export::c_header(&manifest, &axes, &values)?,
    );
    print_paths(write_all(&args.out, vec![header])?)
}

/// Every table of the material folder `dir`, and with c-header the material's
/// header: all read and generated before anything is written.
fn export_material(args: &ExportArgs, dir: &Path) -> Result<()> {
    let first = "epd_g1";
    if !manifest_path(dir, first).is_file() {
        return Err(input_error(format!("{} is not a material folder (no {first}.manifest.json)", dir.display())));
    }
    let manifest = read_manifest(dir, first)?;
    let material = manifest.material.clone().ok_or_else(|| {
        input_error(format!("{} is not a material folder ({first}'s manifest has no material section)", dir.display()))
    })?;
    let names = twoscale_generate::material::Material::from_section(&material)
        .map_err(|e| input_error(format!("{}: {e:#}", dir.display())))?
        .table_names();
    if let Some(missing) = names.iter().find(|t| !manifest_path(dir, t).is_file()) {
        return Err(input_error(format!(
            "{}: material {} lacks its table {missing} ({missing}.manifest.json)",
            dir.display(),
            manifest.preset
        )));
    }
    let mut headers = Vec::new();
    let mut prefixes = Vec::new();
    let mut npy = Vec::new();
    for name in names {
        let (m, axes, values) = open_table(dir, name)?;
        if m.preset != manifest.preset || m.material.as_ref() != Some(&material) {
            return Err(input_error(format!(
                "{}: {name} is of another material than {first} (preset {}, not {})",
                dir.display(),
                m.preset,
                manifest.preset
            )));
        }
        if args.format == "npy" {
            npy.push((name, axes, values));
        } else {
            let prefix = twoscale_generate::export::c_prefix(&m);
            headers.push((format!("{prefix}.h"), twoscale_generate::export::c_header(&m, &axes, &values)?));
            prefixes.push((name, prefix));
        }
    }
    if args.format == "npy" {
        let mut paths = Vec::new();
        for (name, axes, values) in npy {
            paths.extend(twoscale_generate::export::export_npy(name, &axes, &values, &args.out)?);
        }
        return print_paths(paths);
    }
    let stem = twoscale_generate::export::c_material_prefix(&manifest.preset);
    headers.push((format!("{stem}.h"), twoscale_generate::export::c_material_header(&manifest, &prefixes)?));
    print_paths(write_all(&args.out, headers)?)
}

/// Writes each (file name, text) into `out`, each file atomically.
fn write_all(out: &Path, files: Vec<(String, String)>) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create output directory {}", out.display()))?;
    let mut paths = Vec::new();
    for (name, text) in files {
        let path = out.join(name);
        write_bytes_atomic(&path, text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))?;
        paths.push(path);
    }
    Ok(paths)
}

fn print_paths(paths: Vec<PathBuf>) -> Result<()> {
    for path in paths {
        println!("{}", path.display());
    }
    Ok(())
}
