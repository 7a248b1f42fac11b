//! Verifying a directory of tables against its manifests: the file checksum
//! and every data checksum recomputed from the HDF5 content (what `twoscale
//! verify`, bundles and incremental builds rely on).

use crate::file::open_table;
use anyhow::{bail, Context, Result};
use std::path::Path;

/// One table's verdict.
pub struct Verdict {
    pub table: String,
    pub result: Result<()>,
}

/// Checks one table of `dir` (named by its manifest): file size and SHA-256,
/// then the data checksums (which also proves the file is a readable table).
pub fn verify_table(dir: &Path, table: &str) -> Result<()> {
    open_table(dir, table).map(|_| ())
}

/// Verdicts for every `<table>.manifest.json` in `dir`, in name order.
pub fn verify_dir(dir: &Path) -> Result<Vec<Verdict>> {
    Ok(table_names(dir)?.into_iter().map(|table| Verdict { result: verify_table(dir, &table), table }).collect())
}

/// The tables of `dir`, by their `<table>.manifest.json`, in name order.
pub fn table_names(dir: &Path) -> Result<Vec<String>> {
    let mut tables: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read directory {}", dir.display()))?
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().to_str().and_then(|n| n.strip_suffix(".manifest.json")).map(str::to_string))
        .collect();
    tables.sort();
    if tables.is_empty() {
        bail!("{} holds no *.manifest.json: not a table directory", dir.display());
    }
    Ok(tables)
}

/// Verdicts for a table directory, or for a scene's material folders (each
/// table named `<material>/<table>`) when `dir` holds no manifest itself.
pub fn verify_tree(dir: &Path) -> Result<Vec<Verdict>> {
    if holds_manifests(dir)? {
        return verify_dir(dir);
    }
    let mut verdicts = Vec::new();
    for material in material_folders(dir)? {
        for v in verify_dir(&dir.join(&material))? {
            verdicts.push(Verdict { table: format!("{material}/{}", v.table), result: v.result });
        }
    }
    Ok(verdicts)
}

/// Whether `dir` holds a `*.manifest.json` (a table directory) rather than folders of them.
pub fn holds_manifests(dir: &Path) -> Result<bool> {
    Ok(std::fs::read_dir(dir)
        .with_context(|| format!("cannot read directory {}", dir.display()))?
        .filter_map(|e| e.ok())
        .any(|e| e.file_name().to_string_lossy().ends_with(".manifest.json")))
}

/// The subfolders of `dir` that hold table manifests (a scene's material folders), in name order.
pub fn material_folders(dir: &Path) -> Result<Vec<String>> {
    let mut out: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read directory {}", dir.display()))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .filter(|name| holds_manifests(&dir.join(name)).unwrap_or(false))
        .collect();
    out.sort();
    if out.is_empty() {
        bail!("{} holds no *.manifest.json and no folder of them: not a table directory", dir.display());
    }
    Ok(out)
}
