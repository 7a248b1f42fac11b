//! Canonical checksums (docs/file_contract.md): SHA-256 of a file's bytes,
//! and of a dataset's numbers as little-endian bytes in C order.

use anyhow::{Context, Result};
use sha2::{Digest, Sha256};
use std::path::Path;

/// SHA-256 of a stream of little-endian numbers, hashed 64 KiB at a time
/// (one `update` per number costs more than the hash itself).
fn sha256_le<const N: usize>(data: impl Iterator<Item = [u8; N]>) -> String {
    const BLOCK: usize = 1 << 16;
    let mut h = Sha256::new();
    let mut buf = Vec::with_capacity(BLOCK + N);
    for bytes in data {
        buf.extend_from_slice(&bytes);
        if buf.len() >= BLOCK {
            h.update(&buf);
            buf.clear();
        }
    }
    h.update(&buf);
    hex(&h.finalize())
}

/// SHA-256 of little-endian f64 in the given order.
pub fn sha256_f64(data: &[f64]) -> String {
    sha256_le(data.iter().map(|x| x.to_le_bytes()))
}

/// SHA-256 of little-endian f32 in the given order (an array's: C order).
pub fn sha256_f32<'a>(data: impl IntoIterator<Item = &'a f32>) -> String {
    sha256_le(data.into_iter().map(|x| x.to_le_bytes()))
}

pub fn sha256_bytes(data: &[u8]) -> String {
    hex(&Sha256::digest(data))
}

/// SHA-256 of a file's bytes, read 1 MiB at a time.
pub fn sha256_file(path: &Path) -> Result<String> {
    let mut file = std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut h = Sha256::new();
    std::io::copy(&mut file, &mut h).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(hex(&h.finalize()))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
