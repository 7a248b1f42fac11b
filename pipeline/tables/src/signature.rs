//! Minisign signatures (docs/file_contract.md "Signatures"): public keys, signature files, and verifying a
//! file against them. Ed25519 (ed25519-dalek) over the file's BLAKE2b-512 (algorithm `ED`, minisign's
//! default) or over the file itself (`Ed`, minisign's legacy mode, which browsers can check without BLAKE2b);
//! the global signature covers the signature and its trusted comment. The signer is twoscale-generate's
//! `signing`; this is the reader's half.

use anyhow::{bail, ensure, Context, Result};
use base64::{engine::general_purpose::STANDARD, Engine};
use blake2::{Blake2b512, Digest};
use ed25519_dalek::{Signature as Ed25519, VerifyingKey};
use std::io::{Read, Write};
use std::path::Path;

/// Which bytes the Ed25519 signature covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Algorithm {
    /// `ED`: the file's BLAKE2b-512 (bundles).
    Prehashed,
    /// `Ed`: the file's bytes (an export's SHA256SUMS).
    Legacy,
}

impl Algorithm {
    pub fn tag(self) -> &'static [u8; 2] {
        match self {
            Algorithm::Prehashed => b"ED",
            Algorithm::Legacy => b"Ed",
        }
    }

    /// The message signed for `file`'s bytes: their BLAKE2b-512, or themselves.
    pub fn message(self, mut file: impl Read) -> std::io::Result<Vec<u8>> {
        match self {
            Algorithm::Prehashed => {
                let (mut h, mut buf) = (Blake2b512::new(), vec![0u8; 1 << 20]);
                loop {
                    let n = file.read(&mut buf)?;
                    if n == 0 {
                        return Ok(h.finalize().to_vec());
                    }
                    h.update(&buf[..n]);
                }
            }
            Algorithm::Legacy => {
                let mut v = Vec::new();
                file.read_to_end(&mut v)?;
                Ok(v)
            }
        }
    }
}

/// A key id as minisign prints it: the 8 bytes as a little-endian u64, upper-case hex.
pub fn key_id_hex(id: &[u8; 8]) -> String {
    format!("{:016X}", u64::from_le_bytes(*id))
}

/// A minisign public key: `Ed`, the key id (8 bytes) and the Ed25519 key (32), base64 in a `.pub` file.
#[derive(Debug, Clone)]
pub struct PublicKey {
    pub id: [u8; 8],
    key: VerifyingKey,
}

impl PublicKey {
    /// From the base64 line alone (`--key-string`).
    pub fn from_base64(line: &str) -> Result<PublicKey> {
        let bytes = STANDARD.decode(line.trim()).context("not base64")?;
        ensure!(bytes.len() == 42, "{} bytes, a minisign public key has 42", bytes.len());
        ensure!(
            &bytes[..2] == b"Ed",
            "not an Ed25519 minisign key (algorithm {:?})",
            String::from_utf8_lossy(&bytes[..2])
        );
        let key =
            VerifyingKey::from_bytes(bytes[10..].try_into().expect("32 bytes")).context("not an Ed25519 public key")?;
        Ok(PublicKey { id: bytes[2..10].try_into().expect("8 bytes"), key })
    }

    /// From a `.pub` file's text (its untrusted comment line, then the base64 line), or the base64 line alone.
    pub fn from_text(text: &str) -> Result<PublicKey> {
        let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
        match lines.as_slice() {
            [line] => PublicKey::from_base64(line),
            [comment, line] if comment.starts_with("untrusted comment:") => PublicKey::from_base64(line),
            _ => bail!("not a minisign public key (an untrusted comment line, then one base64 line)"),
        }
    }

    pub fn from_file(path: &Path) -> Result<PublicKey> {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        PublicKey::from_text(&text).with_context(|| format!("{}", path.display()))
    }

    /// The base64 line of the `.pub` file.
    pub fn to_base64(&self) -> String {
        let mut bytes = b"Ed".to_vec();
        bytes.extend_from_slice(&self.id);
        bytes.extend_from_slice(self.key.as_bytes());
        STANDARD.encode(bytes)
    }

    pub fn from_parts(id: [u8; 8], key: [u8; 32]) -> Result<PublicKey> {
        Ok(PublicKey { id, key: VerifyingKey::from_bytes(&key).context("not an Ed25519 public key")? })
    }
}

/// A `.minisig` file: its four lines.
#[derive(Debug, Clone)]
pub struct Signature {
    pub untrusted_comment: String,
    pub algorithm: Algorithm,
    pub key_id: [u8; 8],
    pub signature: [u8; 64],
    pub trusted_comment: String,
    pub global_signature: [u8; 64],
}

const UNTRUSTED: &str = "untrusted comment: ";
const TRUSTED: &str = "trusted comment: ";
/// The untrusted comments accepted: twoscale's and minisign's defaults. The comment is not signed, so a
/// reader that took any text would leave bytes of the file unchecked; with these two, every byte is.
pub const UNTRUSTED_TWOSCALE: &str = "signature from twoscale secret key";
const UNTRUSTED_MINISIGN: &str = "signature from minisign secret key";

impl Signature {
    /// Exactly four lines (the last newline optional); anything else, a truncated file among them, is refused.
    pub fn parse(text: &str) -> Result<Signature> {
        ensure!(!text.contains('\r'), "CR line endings: a minisign signature's lines end with LF alone");
        let lines: Vec<&str> = text.strip_suffix('\n').unwrap_or(text).split('\n').collect();
        let [untrusted, sig, trusted, global] = lines.as_slice() else {
            bail!("the file has {} line(s), a minisign signature 4 (truncated?)", lines.len());
        };
        let untrusted = untrusted.strip_prefix(UNTRUSTED).context("line 1 is not an untrusted comment")?;
        ensure!(
            [UNTRUSTED_TWOSCALE, UNTRUSTED_MINISIGN].contains(&untrusted),
            "untrusted comment {untrusted:?} is neither twoscale's nor minisign's default (it is not signed: only those are read)"
        );
        let trusted = trusted.strip_prefix(TRUSTED).context("line 3 is not a trusted comment")?;
        let sig = STANDARD.decode(sig).context("line 2 is not base64")?;
        ensure!(sig.len() == 74, "line 2 holds {} bytes, a minisign signature 74", sig.len());
        let algorithm = match &sig[..2] {
            b"ED" => Algorithm::Prehashed,
            b"Ed" => Algorithm::Legacy,
            other => bail!("signature algorithm {:?}, not ED or Ed", String::from_utf8_lossy(other)),
        };
        let global = STANDARD.decode(global).context("line 4 is not base64")?;
        ensure!(global.len() == 64, "line 4 holds {} bytes, a global signature 64", global.len());
        Ok(Signature {
            untrusted_comment: untrusted.to_string(),
            algorithm,
            key_id: sig[2..10].try_into().expect("8 bytes"),
            signature: sig[10..].try_into().expect("64 bytes"),
            trusted_comment: trusted.to_string(),
            global_signature: global.try_into().expect("64 bytes"),
        })
    }

    pub fn to_text(&self) -> String {
        let mut sig = self.algorithm.tag().to_vec();
        sig.extend_from_slice(&self.key_id);
        sig.extend_from_slice(&self.signature);
        format!(
            "{UNTRUSTED}{}\n{}\n{TRUSTED}{}\n{}\n",
            self.untrusted_comment,
            STANDARD.encode(sig),
            self.trusted_comment,
            STANDARD.encode(self.global_signature)
        )
    }

    /// What the global signature covers: the signature's 64 bytes, then the trusted comment's text.
    pub fn global_message(signature: &[u8; 64], trusted_comment: &str) -> Vec<u8> {
        [signature.as_slice(), trusted_comment.as_bytes()].concat()
    }

    /// Checks this signature of the bytes `file` gives with `key`: the algorithm expected, the key id, the
    /// signature, then the global signature (so its trusted comment is the signer's).
    pub fn verify(&self, file: impl Read, key: &PublicKey, expected: Algorithm) -> Result<()> {
        ensure!(
            self.algorithm == expected,
            "signature algorithm {}, expected {}",
            String::from_utf8_lossy(self.algorithm.tag()),
            String::from_utf8_lossy(expected.tag())
        );
        ensure!(
            self.key_id == key.id,
            "signed by key {}, not by the key given ({})",
            key_id_hex(&self.key_id),
            key_id_hex(&key.id)
        );
        let message = self.algorithm.message(file).context("cannot read the signed file")?;
        key.key
            .verify_strict(&message, &Ed25519::from_bytes(&self.signature))
            .map_err(|_| anyhow::anyhow!("the signature does not match the file (changed since it was signed)"))?;
        key.key
            .verify_strict(
                &Signature::global_message(&self.signature, &self.trusted_comment),
                &Ed25519::from_bytes(&self.global_signature),
            )
            .map_err(|_| anyhow::anyhow!("the trusted comment's signature does not match (the comment was changed)"))?;
        Ok(())
    }
}

/// What a bundle's trusted comment says (docs/file_contract.md "Signatures"):
/// `twoscale-bundle/1 file=F version=V preset=P|scene=S versions_lock_sha256=H`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BundleClaim {
    pub file: String,
    pub version: String,
    /// ("preset", name) or ("scene", name).
    pub target: (String, String),
    pub versions_lock_sha256: String,
}

impl BundleClaim {
    pub fn to_comment(&self) -> String {
        format!(
            "twoscale-bundle/1 file={} version={} {}={} versions_lock_sha256={}",
            self.file, self.version, self.target.0, self.target.1, self.versions_lock_sha256
        )
    }

    pub fn parse(comment: &str) -> Result<BundleClaim> {
        let bad = || format!("trusted comment {comment:?} is not a twoscale bundle's");
        let words: Vec<&str> = comment.split(' ').collect();
        let ["twoscale-bundle/1", file, version, target, lock] = words.as_slice() else { bail!(bad()) };
        let field = |w: &str, key: &str| w.strip_prefix(key).and_then(|v| v.strip_prefix('=')).map(str::to_string);
        let target = match (field(target, "preset"), field(target, "scene")) {
            (Some(p), None) => ("preset".to_string(), p),
            (None, Some(s)) => ("scene".to_string(), s),
            _ => bail!(bad()),
        };
        let claim = BundleClaim {
            file: field(file, "file").with_context(bad)?,
            version: field(version, "version").with_context(bad)?,
            target,
            versions_lock_sha256: field(lock, "versions_lock_sha256").with_context(bad)?,
        };
        ensure!(
            claim.versions_lock_sha256.len() == 64 && claim.versions_lock_sha256.bytes().all(|b| b.is_ascii_hexdigit()),
            bad()
        );
        Ok(claim)
    }
}

/// The SHA-256 of `version`'s line in versions.lock's text (`<version> <digest>`, without its newline), or None.
pub fn versions_lock_entry_sha256(lock: &str, version: &str) -> Option<String> {
    lock.lines()
        .find(|l| l.split_once(' ').is_some_and(|(v, _)| v == version))
        .map(|l| crate::checksum::sha256_bytes(l.trim_end().as_bytes()))
}

/// A bundle's signature file: `BUNDLE.minisig` beside it.
pub fn signature_path(bundle: &Path) -> std::path::PathBuf {
    let mut name = bundle.as_os_str().to_owned();
    name.push(".minisig");
    name.into()
}

/// A reader that writes what it reads to `out`: the bytes hashed are the bytes copied.
struct Tee<R, W> {
    inner: R,
    out: W,
}

impl<R: Read, W: std::io::Write> Read for Tee<R, W> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.out.write_all(&buf[..n])?;
        Ok(n)
    }
}

/// The trusted comments that claim to be twoscale's (`BundleClaim`): any other (minisign's default,
/// `timestamp:... file:...`, or the signer's own) binds nothing but itself.
pub const CLAIM_PREFIX: &str = "twoscale-bundle/";

/// Verifies `bundle`'s signature (beside it) with `key` before anything of it is read: the four lines, `ED`,
/// the key id, the signature over the file's BLAKE2b-512, the trusted comment's, and, where the comment is
/// twoscale's (`CLAIM_PREFIX`), its fields with `file` the bundle's own name. The bundle is read once,
/// copied to `copy` (a private path) as it is hashed: the caller unpacks that copy, which is exactly what
/// was verified whatever happens to `bundle` meanwhile. Returns what a twoscale comment says, for the
/// caller to hold the unpacked bundle.json to; None for another comment (as plain `minisign -Sm` writes),
/// which minisign accepts too: the signature still covers every byte of the bundle, but binds neither its
/// name nor its version.
pub fn verify_bundle(bundle: &Path, key: &PublicKey, copy: &Path) -> Result<Option<BundleClaim>> {
    let sig_path = signature_path(bundle);
    let text = match std::fs::read(&sig_path) {
        Ok(bytes) => String::from_utf8(bytes).with_context(|| format!("{}: not text", sig_path.display()))?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("{}: no signature ({} is missing) but a key was given", bundle.display(), sig_path.display())
        }
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", sig_path.display())),
    };
    let sig = Signature::parse(&text).with_context(|| format!("{}", sig_path.display()))?;
    let file = std::fs::File::open(bundle).with_context(|| format!("cannot read {}", bundle.display()))?;
    let out = std::fs::File::create(copy).with_context(|| format!("cannot write {}", copy.display()))?;
    let mut tee = Tee { inner: std::io::BufReader::new(file), out: std::io::BufWriter::new(out) };
    sig.verify(&mut tee, key, Algorithm::Prehashed)
        .with_context(|| format!("{}: signature refused", bundle.display()))?;
    tee.out.flush().with_context(|| format!("cannot write {}", copy.display()))?;
    if !sig.trusted_comment.starts_with(CLAIM_PREFIX) {
        return Ok(None);
    }
    let claim = BundleClaim::parse(&sig.trusted_comment).with_context(|| format!("{}", sig_path.display()))?;
    let name = bundle.file_name().and_then(|n| n.to_str()).unwrap_or("");
    ensure!(
        claim.file == name,
        "{}: the signature is of {}, not of this file (a signature moved from another bundle)",
        bundle.display(),
        claim.file
    );
    Ok(Some(claim))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn claims_round_trip_and_refuse_other_comments() {
        let c = BundleClaim {
            file: "twoscale-tables-0.13.0-default.tar.gz".into(),
            version: "0.13.0".into(),
            target: ("preset".into(), "default".into()),
            versions_lock_sha256: "ab".repeat(32),
        };
        assert_eq!(BundleClaim::parse(&c.to_comment()).unwrap(), c);
        for bad in [
            "timestamp:1700000000\tfile:x.tar.gz",
            &c.to_comment().replace("preset=", "presets="),
            &c.to_comment().replace(&"ab".repeat(32), "abc"),
            &format!("{} extra=1", c.to_comment()),
        ] {
            assert!(BundleClaim::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_signature_file_has_four_lines() {
        let text = format!("untrusted comment: {UNTRUSTED_TWOSCALE}\nRUQAAAAA\ntrusted comment: y\nAAAA\n"); // line 2: 6 bytes
        assert!(Signature::parse(&text).unwrap_err().to_string().contains("74"));
        assert!(Signature::parse(&text.replace("twoscale", "twoscalf")).unwrap_err().to_string().contains("default"));
        assert!(Signature::parse("untrusted comment: x\n").unwrap_err().to_string().contains("1 line(s)"));
    }
}
