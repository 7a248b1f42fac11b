//! Signing bundles and exports (docs/file_contract.md "Signatures"): minisign key pairs (the `minisign`
//! crate writes and decrypts its formats, scrypt included), and signatures made with ed25519-dalek over the
//! file's BLAKE2b-512 (`ED`, bundles) or the file itself (`Ed`, an export's SHA256SUMS: browsers have no
//! BLAKE2b). twoscale-tables' `signature` reads and verifies them.

use anyhow::{anyhow, bail, ensure, Context, Result};
use ed25519_dalek::{Signer, SigningKey};
use std::io::Write;
use std::path::{Path, PathBuf};
use twoscale_tables::signature::{Algorithm, PublicKey, Signature, UNTRUSTED_TWOSCALE};

/// The environment variable holding the secret key's password, for keygen and signing.
pub const PASSWORD_VAR: &str = "TWOSCALE_KEY_PASSWORD";

/// `path` with `suffix` appended to its file name.
fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(suffix);
    s.into()
}

/// The secret and public keys' paths of the key pair `name`: NAME.key and NAME.pub, or, where `name` ends
/// in `.key`, `name` itself and the same stem's `.pub` (`keygen --out x.key` writes x.key and x.pub, not
/// x.key.key).
pub fn key_paths(name: &Path) -> (PathBuf, PathBuf) {
    if name.extension().is_some_and(|e| e == "key") {
        (name.to_path_buf(), name.with_extension("pub"))
    } else {
        (with_suffix(name, ".key"), with_suffix(name, ".pub"))
    }
}

/// Writes `bytes` to `path`, which must not exist, with `mode`: a temporary file beside it, linked to the
/// name (which fails if the name exists: never overwritten, never partial), then removed.
fn write_new(path: &Path, bytes: &[u8], mode: u32) -> Result<()> {
    let tmp = with_suffix(path, &format!(".tmp{}", std::process::id()));
    let written = (|| -> std::io::Result<()> {
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, mode);
        let mut f = options.open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::hard_link(&tmp, path)
    })();
    let _ = std::fs::remove_file(&tmp);
    written.with_context(|| format!("cannot write {}", path.display()))
}

/// Writes a new key pair `NAME.key` (mode 0600) and `NAME.pub` (`key_paths`) in minisign's formats, the secret key
/// encrypted with `password` (scrypt, minisign's parameters) or, with None, unencrypted as `minisign -G -W`.
/// Neither file may exist; on failure neither is left. Returns the public key.
pub fn keygen(name: &Path, password: Option<String>) -> Result<PublicKey> {
    let (sk_path, pk_path) = key_paths(name);
    for p in [&sk_path, &pk_path] {
        ensure!(!p.exists(), "{} exists: a key is never overwritten", p.display());
    }
    let pair = match password {
        Some(p) => minisign::KeyPair::generate_encrypted_keypair(Some(p)),
        None => minisign::KeyPair::generate_unencrypted_keypair(),
    }
    .map_err(|e| anyhow!("cannot generate a key pair: {e}"))?;
    let sk_text = pair.sk.to_box(None).map_err(|e| anyhow!("{e}"))?.to_string();
    let pk_box = pair.pk.to_box().map_err(|e| anyhow!("{e}"))?;
    let public = PublicKey::from_text(&pk_box.to_string())?;
    write_new(&sk_path, sk_text.as_bytes(), 0o600)?;
    if let Err(e) = write_new(&pk_path, pk_box.to_string().as_bytes(), 0o644) {
        let _ = std::fs::remove_file(&sk_path);
        return Err(e);
    }
    Ok(public)
}

/// A secret key, decrypted: its key id and Ed25519 signing key.
pub struct SecretKey {
    id: [u8; 8],
    key: SigningKey,
}

impl SecretKey {
    /// Reads `path` (minisign's secret key format): unencrypted, or encrypted and decrypted with `password`
    /// (None: an encrypted key is refused, naming PASSWORD_VAR). A wrong password or a corrupt file is an
    /// error naming the file.
    pub fn load(path: &Path, password: Option<String>) -> Result<SecretKey> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read the secret key {}", path.display()))?;
        let bad = |e: minisign::PError| anyhow!("{}: {e}", path.display());
        let sk_box = minisign::SecretKeyBox::from_string(&text).map_err(bad)?;
        // the key's line holds sig_alg, then kdf_alg: `Sc` (scrypt) or two zero bytes (unencrypted)
        let line = text.lines().nth(1).unwrap_or_default();
        let kdf = base64::Engine::decode(&base64::engine::general_purpose::STANDARD, line.trim()).unwrap_or_default();
        ensure!(
            kdf.len() == 158,
            "{}: not a minisign secret key (its second line is not 158 bytes of base64)",
            path.display()
        );
        let sk = if &kdf[2..4] == b"Sc" {
            let Some(password) = password else {
                bail!("{}: the secret key is encrypted: set {PASSWORD_VAR} to its password", path.display());
            };
            sk_box.into_secret_key(Some(password)).map_err(bad)?
        } else {
            sk_box.into_unencrypted_secret_key().map_err(bad)?
        };
        // minisign's layout: sig_alg, kdf_alg, chk_alg (2 each), salt (32), opslimit, memlimit, key id (8 each),
        // then the secret key (64: the Ed25519 seed, then the public key) and its checksum.
        let bytes = sk.to_bytes();
        ensure!(bytes.len() == 158 && &bytes[..2] == b"Ed", "{}: not an Ed25519 minisign secret key", path.display());
        let key = SigningKey::from_bytes(bytes[62..94].try_into().expect("32 bytes"));
        ensure!(
            key.verifying_key().as_bytes() == &bytes[94..126],
            "{}: its public half does not match its seed",
            path.display()
        );
        Ok(SecretKey { id: bytes[54..62].try_into().expect("8 bytes"), key })
    }

    pub fn public(&self) -> PublicKey {
        PublicKey::from_parts(self.id, self.key.verifying_key().to_bytes()).expect("a dalek key is a valid key")
    }

    /// The signature of `file`'s bytes with this trusted comment.
    pub fn sign(&self, file: impl std::io::Read, algorithm: Algorithm, trusted_comment: &str) -> Result<Signature> {
        ensure!(!trusted_comment.contains('\n'), "a trusted comment is one line");
        let message = algorithm.message(file).context("cannot read the file to sign")?;
        let signature = self.key.sign(&message).to_bytes();
        let global_signature = self.key.sign(&Signature::global_message(&signature, trusted_comment)).to_bytes();
        Ok(Signature {
            untrusted_comment: UNTRUSTED_TWOSCALE.to_string(),
            algorithm,
            key_id: self.id,
            signature,
            trusted_comment: trusted_comment.to_string(),
            global_signature,
        })
    }

    /// Signs `file` into `FILE.minisig` (written to a temporary name, then renamed over any old one) and
    /// checks the result with the public half; returns its path.
    pub fn sign_file(&self, file: &Path, algorithm: Algorithm, trusted_comment: &str) -> Result<PathBuf> {
        let open = || std::fs::File::open(file).with_context(|| format!("cannot read {}", file.display()));
        let sig = self.sign(std::io::BufReader::new(open()?), algorithm, trusted_comment)?;
        sig.verify(std::io::BufReader::new(open()?), &self.public(), algorithm)?;
        let out = twoscale_tables::signature::signature_path(file);
        twoscale_tables::table::write_bytes_atomic(&out, sig.to_text().as_bytes())
            .with_context(|| format!("cannot write {}", out.display()))?;
        Ok(out)
    }
}
