//! `twoscale bundle`.

use super::signing::{lock_entry, remove_stale_signature, secret_key};
use crate::flags::BundleArgs;
use anyhow::{ensure, Result};
use std::path::PathBuf;
use std::time::Instant;
use twoscale_generate::build::VERSION;
use twoscale_tables::signature::{Algorithm, BundleClaim};

/// A preset's bundle, or a folder's: named for its tables' target (a material folder's `scene-<scene>/<material>`);
/// with --sign, its signature beside it (the key and the version's versions.lock entry read first, so that a
/// bad one writes nothing); a signature left from an earlier bundle is removed.
pub fn run_bundle(args: &BundleArgs) -> Result<PathBuf> {
    let key = args.sign.as_deref().map(secret_key).transpose()?;
    let lock = key.as_ref().map(|_| lock_entry(VERSION)).transpose()?;
    let (path, target) = write(args)?;
    remove_stale_signature(&path)?;
    if let (Some(key), Some(lock)) = (key, lock) {
        let file = path.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string();
        let claim = BundleClaim { file, version: VERSION.to_string(), target, versions_lock_sha256: lock };
        // a name with a space or '=' would not read back as this claim
        ensure!(
            BundleClaim::parse(&claim.to_comment()).ok().as_ref() == Some(&claim),
            "cannot sign: {:?} is not one word each",
            claim
        );
        let t0 = Instant::now();
        let sig = key.sign_file(&path, Algorithm::Prehashed, &claim.to_comment())?;
        tracing::info!("signed {} in {:.2} s: {}", path.display(), t0.elapsed().as_secs_f64(), sig.display());
    }
    Ok(path)
}

/// Writes the bundle; returns its path and what bundle.json names it for: ("preset", name) or ("scene", name).
fn write(args: &BundleArgs) -> Result<(PathBuf, (String, String))> {
    let Some(dir) = &args.folder else {
        let preset = args.preset.name();
        let path = twoscale_generate::ship::bundle::write_bundle(&args.dir.join(preset), preset, &args.out)?;
        return Ok((path, ("preset".into(), preset.into())));
    };
    if !twoscale_tables::verify::holds_manifests(dir)? {
        let path = twoscale_generate::ship::bundle::write_scene_bundle(dir, &args.out)?;
        let scene = dir.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string();
        return Ok((path, ("scene".into(), scene)));
    }
    // The folder's target, from its first manifest; write_bundle verifies every table.
    let first = twoscale_tables::verify::table_names(dir)?.remove(0);
    let target = twoscale_tables::file::read_manifest(dir, &first)?.preset;
    Ok((twoscale_generate::ship::bundle::write_bundle(dir, &target, &args.out)?, ("preset".into(), target)))
}
