//! Building tables into `DIR/<preset>/`: HDF5 file, then manifest.

use crate::tables::{BuildOptions, Built, Preset, TableDef, Units};
use anyhow::{Context, Result};
use serde_json::json;
use std::path::Path;
use tracing::info;
use twoscale_tables::checksum::sha256_bytes;
use twoscale_tables::file::{h5_path, manifest_path};
use twoscale_tables::manifest::{axis_entry, FileEntry, Generator, Manifest, FORMAT};
use twoscale_tables::table::{write_h5, write_json_atomic};

pub const GENERATOR: &str = "twoscale";
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// SHA-256 of the running executable: any change of code changes it, so a
/// table built by other code is never taken as up to date.
fn executable_sha256() -> Result<String> {
    static HASH: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    if let Some(h) = HASH.get() {
        return Ok(h.clone());
    }
    let exe = std::env::current_exe().context("cannot locate the running executable")?;
    let bytes = std::fs::read(&exe).with_context(|| format!("cannot read {}", exe.display()))?;
    Ok(HASH.get_or_init(|| sha256_bytes(&bytes)).clone())
}

/// The generator as the inputs record it: name, version and executable hash.
pub fn generator_identity() -> Result<serde_json::Value> {
    Ok(json!({ "name": GENERATOR, "version": VERSION, "executable_sha256": executable_sha256()? }))
}

/// What a table's data depends on, and the hash of it.
pub fn inputs(def: &TableDef, preset: Preset, options: &BuildOptions) -> Result<serde_json::Value> {
    let scene = options.scene.as_ref().map(|s| {
        let ranges: serde_json::Map<String, serde_json::Value> =
            s.ranges.iter().map(|(a, r)| (a.to_string(), json!([r.lo, r.hi]))).collect();
        json!({ "name": s.name, "sha256": s.sha256, "sub_domain": ranges })
    });
    let what = json!({
        "table": def.name,
        "preset": preset.name(),
        "scene": scene,
        "degree": options.degree,
        "method": options.method.map(|m| m.name()),
        "generator": generator_identity()?,
    });
    Ok(json!({ "sha256": sha256_bytes(what.to_string().as_bytes()), "what": what }))
}

/// The existing manifest of a table in `dir` when its inputs hash to `sha256`
/// and its files verify: then there is nothing to build.
pub fn up_to_date(dir: &Path, table: &str, sha256: &serde_json::Value) -> Option<Manifest> {
    let text = std::fs::read_to_string(manifest_path(dir, table)).ok()?;
    let manifest: Manifest = serde_json::from_str(&text).ok()?;
    (manifest.inputs["sha256"] == *sha256 && twoscale_tables::verify::verify_table(dir, table).is_ok())
        .then_some(manifest)
}

/// The generator as the manifests record it.
pub fn generator() -> Generator {
    Generator { name: GENERATOR.into(), version: VERSION.into() }
}

/// Where a build goes: `<preset>`, or `scene-<name>` for a scene.
pub fn target_name(preset: Preset, options: &BuildOptions) -> String {
    options.scene.as_ref().map_or_else(|| preset.name().to_string(), |s| format!("scene-{}", s.name))
}

/// The manifest's `timing` of a finished build (`setup_seconds`: what every shard repeats).
pub fn timing(built: &Built, setup_seconds: f64) -> serde_json::Value {
    json!({
        "compute_seconds": built.compute_seconds,
        "setup_seconds": setup_seconds,
        "accuracy_seconds": built.accuracy_seconds,
        "threads": rayon::current_num_threads(),
        "stages": built.stages,
    })
}

/// Builds one table into `out/<target>/` and returns its manifest; a table
/// already there with the same inputs (and intact files) is kept.
pub fn build_table(def: &TableDef, preset: Preset, out: &Path, options: &BuildOptions) -> Result<Manifest> {
    let target = target_name(preset, options);
    let dir = out.join(&target);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
    let inputs = inputs(def, preset, options)?;
    if !options.force {
        if let Some(existing) = up_to_date(&dir, def.name, &inputs["sha256"]) {
            info!(table = def.name, target, "up to date");
            return Ok(existing);
        }
    }
    info!(table = def.name, target, "building");
    let job = (def.job)(preset, options)?;
    let part = job.compute(Units::all(job.units()), options.progress);
    let setup_seconds = part.setup_seconds;
    let built = job.finish(part);
    let timing = timing(&built, setup_seconds);
    write_table(def, &dir, &target, built, inputs, timing)
}

/// Writes a built table and its manifest into `dir` (the HDF5 file first,
/// each atomically) and returns the manifest.
pub fn write_table(
    def: &TableDef,
    dir: &Path,
    target: &str,
    built: Built,
    inputs: serde_json::Value,
    timing: serde_json::Value,
) -> Result<Manifest> {
    write_built(def.name, def.definition, dir, target, built, inputs, timing, None)
}

/// `write_table` for any table by name and definition; `material` is the
/// manifest's `material` section of a per-material table (docs/maths.md section 8).
#[allow(clippy::too_many_arguments)]
pub fn write_built(
    name: &str,
    definition: &str,
    dir: &Path,
    target: &str,
    mut built: Built,
    inputs: serde_json::Value,
    timing: serde_json::Value,
    material: Option<serde_json::Value>,
) -> Result<Manifest> {
    built.table.preset = target.to_string();
    let h5 = h5_path(dir, name);
    let contract = built.table.contract(&built.derived);
    write_h5(&built.table, &contract, VERSION, &h5).with_context(|| format!("cannot write {}", h5.display()))?;
    let bytes = std::fs::read(&h5).with_context(|| format!("cannot read back {}", h5.display()))?;
    let manifest = Manifest {
        format: FORMAT.into(),
        table: name.into(),
        preset: target.to_string(),
        bundle_version: VERSION.into(),
        generator: generator(),
        definition: json!(definition),
        axes: built.table.axes.iter().map(axis_entry).collect(),
        values: built.table.value_entries(),
        derived_axes: built.derived.axes,
        value_encoding: built.derived.values,
        interpolation: built.derived.interpolation,
        file: FileEntry { path: format!("{}.h5", name), bytes: bytes.len() as u64, sha256: sha256_bytes(&bytes) },
        accuracy: built.accuracy,
        settings: built.settings,
        timing,
        inputs,
        material,
    };
    let path = manifest_path(dir, name);
    write_json_atomic(&path, &manifest)?;
    info!(
        table = name,
        target,
        entries = built.table.values[0].1.len(),
        bytes = bytes.len(),
        compute_s = format!("{:.3}", built.compute_seconds),
        "wrote {}",
        h5.display()
    );
    Ok(manifest)
}
