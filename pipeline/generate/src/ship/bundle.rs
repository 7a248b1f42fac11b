//! Versioned table bundles: `twoscale-tables-<version>-<preset>.tar.gz`
//! holding the tables, their manifests, `bundle.json` and `SHA256SUMS`
//! (`sha256sum -c` accepts it), with reproducible bytes: entries in name
//! order, mtime 0, uid/gid 0, mode 0644, gzip header without time or name.

use crate::build::{GENERATOR, VERSION};
use anyhow::{bail, Context, Result};
use flate2::{read::GzDecoder, Compression, GzBuilder};
use serde_json::json;
use std::path::{Path, PathBuf};
use twoscale_tables::checksum::sha256_bytes;
use twoscale_tables::manifest::Manifest;
use twoscale_tables::table::write_atomic;
use twoscale_tables::verify::{material_folders, verify_dir};

/// `twoscale-tables-<version>-<preset>`; a material folder's target `scene-<scene>/<material>` gives `scene-<scene>-<material>`.
pub fn bundle_name(preset: &str) -> String {
    format!("twoscale-tables-{VERSION}-{}", preset.replace('/', "-"))
}

/// The files of the table folder `dir` (verified first; every manifest for
/// `preset`), named under `prefix`, and their entries in bundle.json.
fn folder_entries(dir: &Path, preset: &str, prefix: &str) -> Result<(Vec<(String, Vec<u8>)>, Vec<serde_json::Value>)> {
    let verdicts = verify_dir(dir)?;
    let bad: Vec<&str> = verdicts.iter().filter(|v| v.result.is_err()).map(|v| v.table.as_str()).collect();
    if !bad.is_empty() {
        bail!("not bundling {}: tables fail verification: {} (see `twoscale verify`)", dir.display(), bad.join(", "));
    }
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let mut tables = Vec::new();
    for v in &verdicts {
        let mpath = dir.join(format!("{}.manifest.json", v.table));
        let mtext = std::fs::read(&mpath)?;
        let manifest: Manifest = serde_json::from_slice(&mtext)?;
        if manifest.preset != preset {
            bail!("{} is for preset {}, not {preset}", mpath.display(), manifest.preset);
        }
        let data = std::fs::read(dir.join(&manifest.file.path))?;
        tables.push(json!({
            "table": manifest.table,
            "file": format!("{prefix}{}", manifest.file.path),
            "file_sha256": manifest.file.sha256,
            "manifest": format!("{prefix}{}.manifest.json", v.table),
            "manifest_sha256": sha256_bytes(&mtext),
            "data_sha256": manifest.data_checksums().into_iter().map(|(k, v)| (k, json!(v))).collect::<serde_json::Map<_, _>>(),
            "settings": manifest.settings,
            "bundle_version": manifest.bundle_version,
        }));
        files.push((format!("{prefix}{}", manifest.file.path), data));
        files.push((format!("{prefix}{}.manifest.json", v.table), mtext));
    }
    Ok((files, tables))
}

/// Writes the bundle of the tables in `dir` (a preset directory or a
/// material folder, verified first) into `out`, and returns its path.
pub fn write_bundle(dir: &Path, preset: &str, out: &Path) -> Result<PathBuf> {
    let (files, tables) = folder_entries(dir, preset, "")?;
    pack(&bundle_name(preset), files, bundle_info(json!({ "preset": preset, "tables": tables })), out)
}

/// Writes the bundle of a scene's material folders (`dir` = `scene-<name>`,
/// each subfolder verified first) into `out`: `<material>/<table>.h5` and its
/// manifest for every material, one bundle.json and one SHA256SUMS.
pub fn write_scene_bundle(dir: &Path, out: &Path) -> Result<PathBuf> {
    let scene = dir.file_name().and_then(|n| n.to_str()).context("a scene directory has a name")?.to_string();
    let mut files = Vec::new();
    let mut materials = Vec::new();
    for material in material_folders(dir)? {
        let (mut f, tables) =
            folder_entries(&dir.join(&material), &format!("{scene}/{material}"), &format!("{material}/"))?;
        files.append(&mut f);
        materials.push(json!({ "material": material, "tables": tables }));
    }
    pack(&bundle_name(&scene), files, bundle_info(json!({ "scene": scene, "materials": materials })), out)
}

/// bundle.json: the format, the version and the generator, and `fields`.
fn bundle_info(fields: serde_json::Value) -> serde_json::Value {
    let mut info = json!({ "format": "twoscale-bundle/1", "version": VERSION, "generator": { "name": GENERATOR, "version": VERSION } });
    if let (Some(info), serde_json::Value::Object(fields)) = (info.as_object_mut(), fields) {
        info.extend(fields);
    }
    info
}

/// The reproducible .tar.gz of `files` under `name/`, with bundle.json and SHA256SUMS.
fn pack(name: &str, mut files: Vec<(String, Vec<u8>)>, info: serde_json::Value, out: &Path) -> Result<PathBuf> {
    files.push(("bundle.json".into(), (serde_json::to_string_pretty(&info)? + "\n").into_bytes()));
    files.sort_by(|a, b| a.0.cmp(&b.0));
    let sums: String = files.iter().map(|(name, bytes)| format!("{}  {name}\n", sha256_bytes(bytes))).collect();
    files.push(("SHA256SUMS".into(), sums.into_bytes()));

    std::fs::create_dir_all(out).with_context(|| format!("cannot create output directory {}", out.display()))?;
    let path = out.join(format!("{name}.tar.gz"));
    write_atomic(&path, |tmp| {
        let gz = GzBuilder::new().mtime(0).write(std::fs::File::create(tmp)?, Compression::new(9));
        let mut tar = tar::Builder::new(gz);
        tar.mode(tar::HeaderMode::Deterministic);
        for (file, bytes) in &files {
            let mut header = tar::Header::new_gnu();
            header.set_size(bytes.len() as u64);
            header.set_mode(0o644);
            header.set_mtime(0);
            header.set_uid(0);
            header.set_gid(0);
            header.set_cksum();
            tar.append_data(&mut header, format!("{name}/{file}"), bytes.as_slice())?;
        }
        tar.into_inner()?.finish()?;
        Ok(())
    })
    .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

/// Unpacks a bundle into `into`, checks its SHA256SUMS, and returns the
/// directory holding the tables.
pub fn unpack_bundle(file: &Path, into: &Path) -> Result<PathBuf> {
    unpack_bundle_as(file, file, into)
}

/// `unpack_bundle` of `copy`, a private copy of the bundle `file` (verified against its signature), its
/// errors naming `file`.
pub fn unpack_bundle_as(copy: &Path, file: &Path, into: &Path) -> Result<PathBuf> {
    let ctx = || format!("{}: not a readable twoscale bundle", file.display());
    let f = std::fs::File::open(copy).with_context(ctx)?;
    tar::Archive::new(GzDecoder::new(f)).unpack(into).with_context(ctx)?;
    let dirs: Vec<PathBuf> =
        std::fs::read_dir(into)?.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.is_dir()).collect();
    let [dir] = dirs.as_slice() else { bail!("{}: expected one top-level directory", file.display()) };
    let sums = std::fs::read_to_string(dir.join("SHA256SUMS")).with_context(ctx)?;
    for line in sums.lines() {
        let (sum, name) =
            line.split_once("  ").with_context(|| format!("{}: malformed SHA256SUMS line {line:?}", file.display()))?;
        // A file, or a material folder's file (a scene bundle): plain names only.
        let plain = |part: &str| !part.is_empty() && !part.starts_with('.') && !part.contains('\\');
        if name.split('/').count() > 2 || !name.split('/').all(plain) {
            bail!("{}: SHA256SUMS names {name:?}, not a plain file name", file.display());
        }
        let bytes = std::fs::read(dir.join(name)).with_context(|| format!("{}: {name} is missing", file.display()))?;
        if sha256_bytes(&bytes) != sum {
            bail!("{}: {name} does not match SHA256SUMS", file.display());
        }
    }
    Ok(dir.clone())
}
