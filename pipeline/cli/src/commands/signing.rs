//! What the signing commands share: the secret key from its file and TWOSCALE_KEY_PASSWORD (a bad file or
//! a wrong password is an input error, exit status 2), versions.lock as this binary's checkout has it, and
//! removing a signature that a rewritten file outgrew.

use crate::glue::input_error;
use anyhow::{Context, Result};
use std::path::Path;
use twoscale_generate::ship::signing::{SecretKey, PASSWORD_VAR};

/// manifests/versions.lock of this checkout: the data digest recorded for each version, which a bundle's
/// signature names (docs/file_contract.md "Signatures").
pub(crate) const VERSIONS_LOCK: &str = include_str!("../../../../manifests/versions.lock");

/// The password for a secret key, if the environment gives one.
pub(crate) fn password() -> Option<String> {
    std::env::var(PASSWORD_VAR).ok().filter(|p| !p.is_empty())
}

/// Reads and decrypts the secret key at `path` (before anything is written).
pub(crate) fn secret_key(path: &Path) -> Result<SecretKey> {
    SecretKey::load(path, password()).map_err(|e| input_error(format!("{e:#}")))
}

/// The SHA-256 of `version`'s versions.lock line, or an error saying the version has none.
pub(crate) fn lock_entry(version: &str) -> Result<String> {
    twoscale_tables::signature::versions_lock_entry_sha256(VERSIONS_LOCK, version)
        .ok_or_else(|| anyhow::anyhow!("version {version} has no line in this twoscale's manifests/versions.lock"))
}

/// Removes `file`'s signature left from an earlier run: it signed other bytes.
pub(crate) fn remove_stale_signature(file: &std::path::Path) -> Result<()> {
    let sig = twoscale_tables::signature::signature_path(file);
    match std::fs::remove_file(&sig) {
        Ok(()) => tracing::info!("removed {}: it signed an earlier {}", sig.display(), file.display()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e).with_context(|| format!("cannot remove the stale {}", sig.display())),
    }
    Ok(())
}
