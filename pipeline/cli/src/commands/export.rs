//! `twoscale export`.

use super::signing::{remove_stale_signature, secret_key};
use crate::flags::ExportArgs;
use crate::glue::{input_error, table_name};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use twoscale_generate::tables;
use twoscale_tables::file::{manifest_path, open_table, read_manifest, TableData};
use twoscale_tables::manifest::Manifest;
use twoscale_tables::signature::Algorithm;
use twoscale_tables::table::write_bytes_atomic;

pub fn run_export(args: &ExportArgs) -> Result<()> {
    if args.format == "webgl" {
        if args.table.is_some() {
            return Err(input_error("export: --format webgl exports a whole material folder: give --dir, not --table"));
        }
        let key = args.sign.as_deref().map(secret_key).transpose()?;
        let exports = match &args.folder {
            Some(dir) => export_webgl(dir, &args.out)?,
            None => {
                vec![(args.out.clone(), "preset=default".to_string(), general_webgl_files(&args.dir, &args.preset)?)]
            }
        };
        let mut paths = Vec::new();
        for (folder, what, files) in exports {
            paths.extend(write_all(&folder, files)?);
            remove_stale_signature(&folder.join("SHA256SUMS"))?;
            if let Some(key) = &key {
                // SHA256SUMS covers every file; Ed (legacy): a browser verifies it without BLAKE2b
                let comment = format!("twoscale-export/1 version={} {what}", twoscale_generate::build::VERSION);
                paths.push(key.sign_file(&folder.join("SHA256SUMS"), Algorithm::Legacy, &comment)?);
            }
        }
        return print_paths(paths);
    }
    if args.sign.is_some() {
        return Err(input_error("export: --sign signs a webgl export's SHA256SUMS; the other formats have none"));
    }
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
        return print_paths(twoscale_generate::ship::export::export_npy(name, &axes, &values, &args.out)?);
    }
    let header = (
        format!("{}.h", twoscale_generate::ship::export::c_prefix(&manifest)),
        twoscale_generate::ship::export::c_header(&manifest, &axes, &values)?.into_bytes(),
    );
    print_paths(write_all(&args.out, vec![header])?)
}

/// Every table of the material folder `dir`, and with c-header the material's
/// header: all read and generated before anything is written.
fn export_material(args: &ExportArgs, dir: &Path) -> Result<()> {
    let (manifest, tables) = read_material(dir)?;
    if args.format == "npy" {
        let mut paths = Vec::new();
        for (name, (_, axes, values)) in tables {
            paths.extend(twoscale_generate::ship::export::export_npy(name, &axes, &values, &args.out)?);
        }
        return print_paths(paths);
    }
    let mut headers = Vec::new();
    let mut prefixes = Vec::new();
    for (name, (m, axes, values)) in &tables {
        let prefix = twoscale_generate::ship::export::c_prefix(m);
        headers.push((format!("{prefix}.h"), twoscale_generate::ship::export::c_header(m, axes, values)?));
        prefixes.push((*name, prefix));
    }
    let stem = twoscale_generate::ship::export::c_material_prefix(&manifest.preset);
    headers.push((format!("{stem}.h"), twoscale_generate::ship::export::c_material_header(&manifest, &prefixes)?));
    print_paths(write_all(&args.out, headers.into_iter().map(|(n, t)| (n, t.into_bytes())).collect())?)
}

/// The tables of the material folder `dir` (its first manifest, then each table as read, in the
/// material's order), each checked to be of the same material; an input error for a folder that is
/// not a material's or lacks one of its tables.
pub(crate) fn read_material(dir: &Path) -> Result<(Manifest, Vec<(&'static str, TableData)>)> {
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
    let mut tables = Vec::new();
    for name in names {
        let table = open_table(dir, name)?;
        let m = &table.0;
        if m.preset != manifest.preset || m.material.as_ref() != Some(&material) {
            return Err(input_error(format!(
                "{}: {name} is of another material than {first} (preset {}, not {})",
                dir.display(),
                m.preset,
                manifest.preset
            )));
        }
        tables.push((name, table));
    }
    Ok((manifest, tables))
}

/// The GPU export's files of the material folder `dir` (runtimes/webgl/README.md), in the order to
/// write them.
pub(crate) fn webgl_files(dir: &Path) -> Result<Vec<(String, Vec<u8>)>> {
    let (_, tables) = read_material(dir)?;
    let tables: Vec<TableData> = tables.into_iter().map(|(_, t)| t).collect();
    // A table the GPU runtime cannot read is the folder's fault: a usage error (exit 2), like a missing table.
    twoscale_generate::ship::webgl::export_files(&tables)
        .map_err(|e| input_error(format!("{}: cannot export for WebGL: {e:#}", dir.display())))
}

/// The general GPU export of `preset` in `dir` (runtimes/webgl/README.md "The general export"): the
/// default preset's tables, each verified as it is read.
fn general_webgl_files(dir: &Path, preset: &str) -> Result<Vec<(String, Vec<u8>)>> {
    if preset != "default" {
        return Err(input_error(format!(
            "export: --format webgl without --dir exports the default preset's general tables, not {preset}"
        )));
    }
    general_webgl_folder(&dir.join(preset))
}

/// The general GPU export of the default-preset folder `folder`.
pub(crate) fn general_webgl_folder(folder: &Path) -> Result<Vec<(String, Vec<u8>)>> {
    use twoscale_generate::ship::webgl_general::{export_files, TABLES};
    let dir = folder.parent().unwrap_or(Path::new("."));
    if let Some(missing) = TABLES.iter().find(|t| !manifest_path(folder, t).is_file()) {
        return Err(input_error(format!(
            "{}: no {missing}.manifest.json (build the preset: twoscale build --preset default --out {})",
            folder.display(),
            dir.display()
        )));
    }
    let tables = TABLES.iter().map(|t| open_table(folder, t)).collect::<Result<Vec<_>>>()?;
    export_files(tables).map_err(|e| input_error(format!("{}: cannot export for WebGL: {e:#}", folder.display())))
}

/// `--format webgl`: a material folder into `out`, or each material folder of a scene directory
/// into `out/<material>/`, as (folder, `material=<name>`, files); every material read and generated before
/// anything is written.
fn export_webgl(dir: &Path, out: &Path) -> Result<Vec<(PathBuf, String, Vec<(String, Vec<u8>)>)>> {
    if !dir.is_dir() {
        return Err(input_error(format!("{} is not a material folder or a scene directory", dir.display())));
    }
    let name_of = |d: &Path| format!("material={}", d.file_name().and_then(|n| n.to_str()).unwrap_or_default());
    if twoscale_tables::verify::holds_manifests(dir)? {
        return Ok(vec![(out.to_path_buf(), name_of(dir), webgl_files(dir)?)]);
    }
    let materials = twoscale_tables::verify::material_folders(dir).map_err(|_| {
        input_error(format!("{} is not a material folder or a scene directory of them (no manifest)", dir.display()))
    })?;
    let mut exports = Vec::new();
    for name in materials {
        let folder = dir.join(&name);
        exports.push((out.join(&name), name_of(&folder), webgl_files(&folder)?));
    }
    Ok(exports)
}

/// Writes each (file name, bytes) into `out` in order, each file atomically.
pub(crate) fn write_all(out: &Path, files: Vec<(String, Vec<u8>)>) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create output directory {}", out.display()))?;
    let mut paths = Vec::new();
    for (name, bytes) in files {
        let path = out.join(name);
        write_bytes_atomic(&path, &bytes).with_context(|| format!("cannot write {}", path.display()))?;
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
