//! `twoscale verify`.

use super::signing::VERSIONS_LOCK;
use crate::flags::VerifyArgs;
use anyhow::{bail, ensure, Context, Result};
use std::path::Path;
use std::time::Instant;
use twoscale_tables::signature::{
    key_id_hex, signature_path, verify_bundle, versions_lock_entry_sha256, BundleClaim, PublicKey,
};

fn tempfile_dir() -> Result<tempfile::TempDir> {
    tempfile::tempdir().context("cannot create a temporary directory")
}

/// Prints one line per table (a bundle's signature first); an error naming every table that fails.
pub fn run_verify(args: &VerifyArgs) -> Result<()> {
    let key = match (&args.key, &args.key_string) {
        (Some(path), _) => Some(PublicKey::from_file(path)?),
        (None, Some(line)) => Some(PublicKey::from_base64(line).context("--key-string")?),
        (None, None) => None,
    };
    let unpacked = tempfile_dir()?;
    let dir = if args.path.is_file() {
        // signed: unpack the copy the signature was checked over, not the path again
        let copy = unpacked.path().join("verified.tar.gz");
        // with a key the signature was verified over the copy (or refused): unpack that
        let claim = check_signature(&args.path, key.as_ref(), &copy)?;
        let from = if key.is_some() { copy.as_path() } else { args.path.as_path() };
        let dir = twoscale_generate::ship::bundle::unpack_bundle_as(from, &args.path, &unpacked.path().join("bundle"))?;
        if let Some(claim) = claim {
            check_bundle_json(&args.path, &dir, &claim)?;
        }
        dir
    } else {
        ensure!(
            key.is_none(),
            "{}: --key verifies a bundle file's signature, and this is a folder",
            args.path.display()
        );
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

/// A bundle's signature, before anything of it is read: with a key, verified into `copy`, and where its
/// trusted comment is twoscale's, its versions.lock entry held to this binary's and its claim returned;
/// without a key, its presence said.
fn check_signature(bundle: &Path, key: Option<&PublicKey>, copy: &Path) -> Result<Option<BundleClaim>> {
    let Some(key) = key else {
        let sig = signature_path(bundle);
        match sig.exists() {
            true => println!("signed, not verified: {} (give --key to verify it)", sig.display()),
            false => println!("unsigned: no {}", sig.display()),
        }
        return Ok(None);
    };
    let t0 = Instant::now();
    let Some(claim) = verify_bundle(bundle, key, copy)? else {
        println!(
            "signed  by key {}: every byte of the bundle, but its trusted comment is not twoscale's, so the signature does \
             not bind the bundle's name or version",
            key_id_hex(&key.id)
        );
        return Ok(None);
    };
    let Some(lock) = versions_lock_entry_sha256(VERSIONS_LOCK, &claim.version) else {
        bail!(
            "{}: signed for version {}, which this twoscale's versions.lock does not record: verify it with twoscale {} or newer",
            bundle.display(),
            claim.version,
            claim.version
        );
    };
    ensure!(
        lock == claim.versions_lock_sha256,
        "{}: the signature names versions.lock entry {} for version {}, but {} is recorded: signed over other data",
        bundle.display(),
        claim.versions_lock_sha256,
        claim.version,
        lock
    );
    tracing::info!("signature verified in {:.2} s", t0.elapsed().as_secs_f64());
    println!("signed  by key {}: {}", key_id_hex(&key.id), claim.to_comment());
    Ok(Some(claim))
}

/// The unpacked bundle.json must be for the version and preset or scene its signature names.
fn check_bundle_json(bundle: &Path, dir: &Path, claim: &BundleClaim) -> Result<()> {
    let text = std::fs::read_to_string(dir.join("bundle.json"))
        .with_context(|| format!("{}: no bundle.json", bundle.display()))?;
    let info: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: bundle.json", bundle.display()))?;
    let (key, name) = &claim.target;
    ensure!(
        info["version"].as_str() == Some(claim.version.as_str()) && info[key].as_str() == Some(name.as_str()),
        "{}: bundle.json is for version {} {key} {}, its signature for {} {key} {name}",
        bundle.display(),
        info["version"],
        info[key],
        claim.version
    );
    Ok(())
}
