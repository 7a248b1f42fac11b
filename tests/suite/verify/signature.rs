//! Signed bundles and exports (docs/file_contract.md "Signatures"): `twoscale keygen`, `bundle --sign`,
//! `verify --key`, `export --sign`, checked both ways against Debian's minisign 0.11 (`make test`'s `deps`
//! installs it), every forgery of the contract refused with one line and exit status 1 before anything of the
//! bundle is read, bad keys and passwords with exit status 2, and random byte flips of a signed bundle or its
//! signature always refused (TWOSCALE_FUZZ_SEED varies them).

use crate::common;

use common::shared_tables::test_materials;
use common::{assert_input_error, assert_ok, run, run_env, tempdir};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_tables::checksum::sha256_bytes;

const PASSWORD: (&str, &str) = ("TWOSCALE_KEY_PASSWORD", "correct horse");
const VERSION: &str = env!("CARGO_PKG_VERSION");

fn minisign(args: &[&str], dir: &Path) -> Output {
    let out = Command::new("minisign").args(args).current_dir(dir).stdin(std::process::Stdio::null()).output();
    out.expect("minisign is missing: run `make test` (its deps step installs Debian's minisign)")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A material folder's bundle in `dir` (small: chi2 has no diffraction tables), and its path.
fn bundle(dir: &Path, sign: Option<&Path>) -> PathBuf {
    let folder = test_materials().join("chi2");
    let mut args = vec!["bundle", "--quiet", "--dir", s(&folder), "--out", s(dir)];
    if let Some(key) = sign {
        args.extend(["--sign", s(key)]);
    }
    let out = run_env(&args, &[PASSWORD]);
    assert_ok(&out);
    PathBuf::from(String::from_utf8_lossy(&out.stdout).trim())
}

/// `verify BUNDLE --key PUB` refused: exit status 1, one line naming `needle`, and no table read (no "ok").
#[track_caller]
fn assert_refused(bundle: &Path, key: &Path, needle: &str) {
    let out = run(&["verify", s(bundle), "--key", s(key)]);
    let (stdout, err) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(1), "{needle}: stdout {stdout} stderr {err}");
    assert_eq!(err.lines().filter(|l| l.contains("error")).count(), 1, "{err}");
    assert!(err.contains(needle), "{needle:?} not in {err:?}");
    assert!(!stdout.contains("ok "), "the bundle was read: {stdout}");
}

/// The trusted comment twoscale writes for chi2's bundle, with this versions.lock hash.
fn comment(bundle: &Path, lock_sha256: &str) -> String {
    let file = bundle.file_name().unwrap().to_str().unwrap();
    format!("twoscale-bundle/1 file={file} version={VERSION} preset=scene-test_materials/chi2 versions_lock_sha256={lock_sha256}")
}

/// The versions.lock hash of this version, from a signature twoscale wrote.
fn lock_hash(sig: &Path) -> String {
    let text = std::fs::read_to_string(sig).unwrap();
    text.split("versions_lock_sha256=").nth(1).unwrap()[..64].to_string()
}

#[test]
fn keygen_writes_minisign_keys_and_refuses_bad_input() {
    let dir = tempdir();
    let name = dir.path().join("release");
    let out = run_env(&["keygen", "--out", s(&name)], &[PASSWORD]);
    assert_ok(&out);
    let (sk, pk) = (dir.path().join("release.key"), dir.path().join("release.pub"));
    use std::os::unix::fs::PermissionsExt;
    assert_eq!(std::fs::metadata(&sk).unwrap().permissions().mode() & 0o777, 0o600);
    let key_text = std::fs::read(&sk).unwrap();
    assert!(
        String::from_utf8_lossy(&key_text).lines().nth(1).unwrap().starts_with("RWRTY0Iy"),
        "an Ed key, scrypt (Sc), BLAKE2b (B2)"
    );
    // never overwritten; a password is needed unless --unencrypted; nothing partial left
    assert_input_error(&run_env(&["keygen", "--out", s(&name)], &[PASSWORD]), "never overwritten");
    assert_eq!(std::fs::read(&sk).unwrap(), key_text);
    assert_input_error(&run(&["keygen", "--out", s(&dir.path().join("other"))]), "TWOSCALE_KEY_PASSWORD");
    assert_input_error(
        &run_env(&["keygen", "--out", s(&dir.path().join("no/such/dir/k"))], &[PASSWORD]),
        "cannot write",
    );
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left.len(), 2, "files left: {left:?}");
    // a name ending in .key names the secret key itself: x.key and x.pub, not x.key.key
    let named = tempdir();
    let out = run(&["keygen", "--unencrypted", "--out", s(&named.path().join("x.key"))]);
    assert_ok(&out);
    let mut files: Vec<_> = std::fs::read_dir(named.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    files.sort();
    assert_eq!(files, ["x.key", "x.pub"], "keygen --out x.key wrote {files:?}");
    let printed = String::from_utf8_lossy(&out.stdout);
    assert!(printed.lines().next().unwrap().ends_with("/x.key") && printed.contains("/x.pub\n"), "{printed}");
    // signing: a wrong password, no password, a corrupt key file: exit 2, no bundle written
    let out_dir = dir.path().join("bundles");
    let folder = test_materials().join("chi2");
    let sign = |key: &Path, env: &[(&str, &str)]| {
        run_env(&["bundle", "--quiet", "--dir", s(&folder), "--out", s(&out_dir), "--sign", s(key)], env)
    };
    assert_input_error(&sign(&sk, &[("TWOSCALE_KEY_PASSWORD", "wrong")]), "Wrong password");
    assert_input_error(&sign(&sk, &[]), "encrypted: set TWOSCALE_KEY_PASSWORD");
    let corrupt = dir.path().join("corrupt.key");
    std::fs::write(&corrupt, "untrusted comment: x\nnot a key\n").unwrap();
    assert_input_error(&sign(&corrupt, &[PASSWORD]), "corrupt.key");
    assert!(!out_dir.exists(), "a bundle was written with a bad key");
    // the key signs, and minisign verifies with its public half
    let b = bundle(&out_dir, Some(&sk));
    assert_ok(&minisign(&["-Vm", s(&b), "-p", s(&pk)], dir.path()));
    assert_ok(&run(&["verify", s(&b), "--key", s(&pk)]));
}

#[test]
fn signed_bundles_interoperate_with_minisign_both_ways() {
    let dir = tempdir();
    // twoscale's unencrypted key, signature checked by minisign (prehashed: minisign -H demands it)
    let ours = dir.path().join("ours");
    assert_ok(&run(&["keygen", "--out", s(&ours), "--unencrypted"]));
    let b = bundle(dir.path(), Some(&dir.path().join("ours.key")));
    let sig = PathBuf::from(format!("{}.minisig", b.display()));
    let out = minisign(&["-Vm", s(&b), "-p", "ours.pub", "-H"], dir.path());
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains(&comment(&b, &lock_hash(&sig))));
    // minisign's key and signature, checked by twoscale (--key and --key-string)
    assert_ok(&minisign(&["-G", "-W", "-p", "theirs.pub", "-s", "theirs.key"], dir.path()));
    let lock = lock_hash(&sig);
    std::fs::remove_file(&sig).unwrap();
    assert_ok(&minisign(&["-S", "-s", "theirs.key", "-m", s(&b), "-t", &comment(&b, &lock)], dir.path()));
    let out = run(&["verify", s(&b), "--key", s(&dir.path().join("theirs.pub"))]);
    assert_ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.lines().next().unwrap().starts_with("signed  by key") && stdout.contains("ok      epd_g1"),
        "{stdout}"
    );
    let line = std::fs::read_to_string(dir.path().join("theirs.pub")).unwrap().lines().nth(1).unwrap().to_string();
    assert_ok(&run(&["verify", s(&b), "--key-string", &line]));
    // plain `minisign -Sm` (its default trusted comment): accepted, saying what it does not bind, and still
    // over every byte of the bundle
    std::fs::remove_file(&sig).unwrap();
    assert_ok(&minisign(&["-S", "-s", "theirs.key", "-m", s(&b)], dir.path()));
    assert!(!std::fs::read_to_string(&sig).unwrap().contains("twoscale-bundle/"));
    let out = run(&["verify", s(&b), "--key", s(&dir.path().join("theirs.pub"))]);
    assert_ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let first = stdout.lines().next().unwrap();
    assert!(
        first.starts_with("signed  by key") && first.contains("does not bind the bundle's name or version"),
        "{stdout}"
    );
    assert!(stdout.contains("ok      epd_g1"), "{stdout}");
    let tampered = dir.path().join("tampered.tar.gz");
    let mut bytes = std::fs::read(&b).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&tampered, bytes).unwrap();
    std::fs::copy(&sig, dir.path().join("tampered.tar.gz.minisig")).unwrap();
    assert_refused(&tampered, &dir.path().join("theirs.pub"), "does not match the file");
    // without a key: said, then the checksums as before
    let out = run(&["verify", s(&b)]);
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("signed, not verified:"));
    std::fs::remove_file(&sig).unwrap();
    let out = run(&["verify", s(&b)]);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("unsigned:"));
    // a key with no signature is refused
    assert_refused(&b, &dir.path().join("theirs.pub"), "no signature");
}

#[test]
fn forged_and_broken_signatures_are_refused() {
    let dir = tempdir();
    let d = dir.path();
    assert_ok(&run(&["keygen", "--out", s(&d.join("k")), "--unencrypted"]));
    assert_ok(&run(&["keygen", "--out", s(&d.join("other")), "--unencrypted"]));
    let (key, other_key) = (d.join("k.pub"), d.join("other.pub"));
    let b = bundle(d, Some(&d.join("k.key")));
    let sig = PathBuf::from(format!("{}.minisig", b.display()));
    let good = std::fs::read(&sig).unwrap();
    let lock = lock_hash(&sig);
    assert_ok(&run(&["verify", s(&b), "--key", s(&key)]));
    let restore = || std::fs::write(&sig, &good).unwrap();

    // a table changed and its manifest's SHA-256, bundle.json and SHA256SUMS rewritten to match
    let work = d.join("work");
    std::fs::create_dir(&work).unwrap();
    assert!(Command::new("tar").args(["xzf", s(&b), "-C", s(&work)]).status().unwrap().success());
    let top = std::fs::read_dir(&work).unwrap().next().unwrap().unwrap().path();
    let h5 = top.join("epd_g1.h5");
    let mut bytes = std::fs::read(&h5).unwrap();
    let old = sha256_bytes(&bytes);
    let n = bytes.len();
    bytes[n - 9] ^= 1;
    std::fs::write(&h5, &bytes).unwrap();
    let new = sha256_bytes(&bytes);
    for f in ["epd_g1.manifest.json", "bundle.json", "SHA256SUMS"] {
        let text = std::fs::read_to_string(top.join(f)).unwrap();
        std::fs::write(top.join(f), text.replace(&old, &new)).unwrap();
    }
    let manifest_sum = sha256_bytes(&std::fs::read(top.join("epd_g1.manifest.json")).unwrap());
    let sums = std::fs::read_to_string(top.join("SHA256SUMS")).unwrap();
    let sums: String = sums
        .lines()
        .map(|l| {
            if l.ends_with("epd_g1.manifest.json") {
                format!("{manifest_sum}  epd_g1.manifest.json\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    std::fs::write(top.join("SHA256SUMS"), sums).unwrap();
    let forged = d.join("forged").join(b.file_name().unwrap());
    std::fs::create_dir(forged.parent().unwrap()).unwrap();
    let top_name = top.file_name().unwrap().to_str().unwrap();
    assert!(Command::new("tar").args(["czf", s(&forged), "-C", s(&work), top_name]).status().unwrap().success());
    std::fs::copy(&sig, format!("{}.minisig", forged.display())).unwrap();
    let out = run(&["verify", s(&forged)]);
    assert_eq!(out.status.code(), Some(1), "the forgery must still fail its data checksum without a key");
    assert_refused(&forged, &key, "the signature does not match the file");

    // a versions.lock entry changed: signed (by minisign, with our key's format) over another entry
    assert_ok(&minisign(&["-G", "-W", "-p", "m.pub", "-s", "m.key"], d));
    let zero = "0".repeat(64);
    assert_ok(&minisign(&["-S", "-s", "m.key", "-m", s(&b), "-t", &comment(&b, &zero), "-x", "m.sig"], d));
    std::fs::copy(d.join("m.sig"), &sig).unwrap();
    assert_refused(&b, &d.join("m.pub"), "versions.lock entry");
    // the right entry passes (the refusal above is the entry's, not minisign's)
    assert_ok(&minisign(&["-S", "-s", "m.key", "-m", s(&b), "-t", &comment(&b, &lock), "-x", "m.sig"], d));
    std::fs::copy(d.join("m.sig"), &sig).unwrap();
    assert_ok(&run(&["verify", s(&b), "--key", s(&d.join("m.pub"))]));
    restore();

    // a signature from another key
    assert_refused(&b, &other_key, "not by the key given");
    // a signature of another bundle: its comment names that file; the same bytes under another name
    let renamed = d.join("renamed.tar.gz");
    std::fs::copy(&b, &renamed).unwrap();
    std::fs::copy(&sig, d.join("renamed.tar.gz.minisig")).unwrap();
    assert_refused(&renamed, &key, "not of this file");
    // a truncated signature file
    std::fs::write(&sig, &good[..good.len() / 2]).unwrap();
    assert_refused(&b, &key, "truncated");
    // an algorithm line other than ED: minisign's legacy Ed, and a made-up one
    assert_ok(&minisign(&["-S", "-l", "-s", "m.key", "-m", s(&b), "-t", &comment(&b, &lock), "-x", "m.sig"], d));
    std::fs::copy(d.join("m.sig"), &sig).unwrap();
    assert_refused(&b, &d.join("m.pub"), "signature algorithm Ed, expected ED");
    let text = String::from_utf8(good.clone()).unwrap();
    let line2 = text.lines().nth(1).unwrap();
    std::fs::write(&sig, text.replace(line2, &format!("RX{}", &line2[2..]))).unwrap();
    assert_refused(&b, &key, "signature algorithm");
    restore();
    // a public key file of the wrong length
    let pub_text = std::fs::read_to_string(&key).unwrap();
    let short = d.join("short.pub");
    std::fs::write(
        &short,
        pub_text.replace(pub_text.lines().nth(1).unwrap(), "RWQAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA="),
    )
    .unwrap();
    assert_refused(&b, &short, "38 bytes, a minisign public key has 42");
    assert_ok(&run(&["verify", s(&b), "--key", s(&key)]));
}

#[test]
fn export_sign_writes_a_legacy_signature_minisign_accepts() {
    let dir = tempdir();
    let d = dir.path();
    assert_ok(&run(&["keygen", "--out", s(&d.join("k")), "--unencrypted"]));
    let folder = test_materials().join("chi2");
    let out = d.join("export");
    let key = d.join("k.key");
    assert_ok(&run(&["export", "--format", "webgl", "--dir", s(&folder), "--out", s(&out), "--sign", s(&key)]));
    let sig = std::fs::read_to_string(out.join("SHA256SUMS.minisig")).unwrap();
    assert!(sig.contains(&format!("trusted comment: twoscale-export/1 version={VERSION} material=chi2\n")), "{sig}");
    // minisign 0.11 verifies the legacy (Ed) signature by default, and -H (prehashed only) refuses it
    assert_ok(&minisign(&["-Vm", s(&out.join("SHA256SUMS")), "-p", "k.pub"], d));
    assert!(!minisign(&["-Vm", s(&out.join("SHA256SUMS")), "-p", "k.pub", "-H"], d).status.success());
    let npy = run(&["export", "--format", "npy", "--dir", s(&folder), "--out", s(&d.join("npy")), "--sign", s(&key)]);
    assert_input_error(&npy, "--sign signs a webgl export");
}

#[test]
fn random_byte_flips_of_a_signed_bundle_are_always_refused() {
    let dir = tempdir();
    let d = dir.path();
    assert_ok(&run(&["keygen", "--out", s(&d.join("k")), "--unencrypted"]));
    let b = bundle(d, Some(&d.join("k.key")));
    let sig = PathBuf::from(format!("{}.minisig", b.display()));
    let (bundle_bytes, sig_bytes) = (std::fs::read(&b).unwrap(), std::fs::read(&sig).unwrap());
    let seed = std::env::var("TWOSCALE_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(1u64);
    let mut rng = SplitMix64::new(seed ^ 0x5167);
    let (mut refused, cases) = (0, 120);
    for case in 0..cases {
        let in_sig = case % 2 == 1;
        let (target, original) = if in_sig { (&sig, &sig_bytes) } else { (&b, &bundle_bytes) };
        let mut bytes = original.clone();
        let i = (rng.next_u64() % bytes.len() as u64) as usize;
        bytes[i] ^= 1 << (rng.next_u64() % 8);
        std::fs::write(target, &bytes).unwrap();
        let out = run(&["verify", s(&b), "--key", s(&d.join("k.pub"))]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(
            out.status.code(),
            Some(1),
            "seed {seed} case {case}: byte {i} of the {} flipped was not refused: {err}",
            if in_sig { "signature" } else { "bundle" }
        );
        assert!(!String::from_utf8_lossy(&out.stdout).contains("ok "), "seed {seed} case {case}: the bundle was read");
        refused += 1;
        std::fs::write(target, original).unwrap();
    }
    println!("signed bundle fuzz (seed {seed}): {refused} of {cases} flips refused (half in the bundle, half in its signature), 0 crashes");
    assert_ok(&run(&["verify", s(&b), "--key", s(&d.join("k.pub"))]));
}

#[test]
fn a_signed_scene_bundle_names_its_scene_and_verifies() {
    let dir = tempdir();
    let d = dir.path();
    // a scene directory of two small material folders (no diffraction tables), as `build --scene` names them
    let scene = d.join("scene-test_materials");
    for m in ["chi2", "chi4"] {
        let (from, to) = (test_materials().join(m), scene.join(m));
        std::fs::create_dir_all(&to).unwrap();
        for f in std::fs::read_dir(&from).unwrap() {
            let f = f.unwrap().path();
            std::fs::copy(&f, to.join(f.file_name().unwrap())).unwrap();
        }
    }
    assert_ok(&run(&["keygen", "--out", s(&d.join("k")), "--unencrypted"]));
    let out = run(&["bundle", "--quiet", "--dir", s(&scene), "--out", s(d), "--sign", s(&d.join("k.key"))]);
    assert_ok(&out);
    let b = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    let verified = run(&["verify", s(&b), "--key", s(&d.join("k.pub"))]);
    assert_ok(&verified);
    let stdout = String::from_utf8_lossy(&verified.stdout);
    let first = stdout.lines().next().unwrap();
    assert!(first.contains(&format!("version={VERSION} scene=scene-test_materials ")), "{first}");
    assert!(stdout.contains("ok      chi2/epd_g1") && stdout.contains("ok      chi4/epd_g1"), "{stdout}");
    assert_ok(&minisign(&["-Vm", s(&b), "-p", "k.pub"], d));
}
