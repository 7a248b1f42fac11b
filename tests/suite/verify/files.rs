//! `twoscale verify` and bundles: corrupt tables are one clear error, each bad table is named,
//! bundles are reproducible and verified.

use crate::common;

use common::shared_tables::shared_tables;

use common::{assert_ok, run, tempdir};
use twoscale_generate::tables::{of_preset, Preset};

#[test]
fn corrupt_table_is_a_clear_error() {
    let dir = tempdir();
    let src = shared_tables().join("paper");
    let dst = dir.path().join("paper");
    std::fs::create_dir_all(&dst).unwrap();
    for f in ["epd_norm.h5", "epd_norm.manifest.json"] {
        std::fs::copy(src.join(f), dst.join(f)).unwrap();
    }
    let h5 = dst.join("epd_norm.h5");
    let lookup_here =
        || run(&["lookup", "epd_norm", "--preset", "paper", "--tables", dir.path().to_str().unwrap(), "--at", "p=1"]);
    // A flipped value byte: caught by the file checksum, before HDF5 opens the file.
    let mut bytes = std::fs::read(&h5).unwrap();
    let n = bytes.len();
    bytes[n - 100] ^= 0x40;
    std::fs::write(&h5, &bytes).unwrap();
    let out = lookup_here();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("file checksum differs from the manifest") && err.trim_end().lines().count() == 1, "{err}");
    // Truncated: its size is not the manifest's.
    std::fs::write(&h5, &bytes[..n / 2]).unwrap();
    let out = lookup_here();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("has {} bytes, the manifest says {n}", n / 2)) && err.trim_end().lines().count() == 1,
        "{err}"
    );
}

#[test]
fn verify_accepts_good_tables_and_names_each_bad_one() {
    let dir = tempdir();
    let dst = dir.path().join("paper");
    std::fs::create_dir_all(&dst).unwrap();
    for entry in std::fs::read_dir(shared_tables().join("paper")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dst.join(path.file_name().unwrap())).unwrap();
    }
    let verify = || run(&["verify", dst.to_str().unwrap()]);
    let out = verify();
    assert_ok(&out);
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().filter(|l| l.starts_with("ok")).count(),
        of_preset(Preset::Paper).count()
    );
    // A flipped byte in each table in turn, then a truncated file, then not HDF5 at all.
    for def in of_preset(Preset::Paper) {
        let h5 = dst.join(format!("{}.h5", def.name));
        let good = std::fs::read(&h5).unwrap();
        let n = good.len();
        let mut flipped = good.clone();
        flipped[n - 64] ^= 0x01;
        for bad in [flipped, good[..n / 3].to_vec(), b"not an HDF5 file".to_vec()] {
            std::fs::write(&h5, &bad).unwrap();
            let out = verify();
            assert_eq!(out.status.code(), Some(1), "{}", def.name);
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert!(stdout.contains(&format!("FAILED  {}", def.name)), "{stdout}");
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(stderr.contains("1 of") && stderr.contains(def.name), "{stderr}");
        }
        std::fs::write(&h5, &good).unwrap();
    }
    assert!(verify().status.success());
    // A directory without manifests is an error, not a pass.
    let empty = tempdir();
    let out = run(&["verify", empty.path().to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no *.manifest.json"));
}

#[test]
fn bundles_are_reproducible_and_verified() {
    let tables = shared_tables().to_str().unwrap().to_string();
    let (a, b) = (tempdir(), tempdir());
    for out in [&a, &b] {
        let o = run(&[
            "bundle",
            "--quiet",
            "--preset",
            "paper",
            "--tables",
            &tables,
            "--out",
            out.path().to_str().unwrap(),
        ]);
        assert_ok(&o);
    }
    let name = format!("twoscale-tables-{}-paper.tar.gz", env!("CARGO_PKG_VERSION"));
    let (fa, fb) = (a.path().join(&name), b.path().join(&name));
    let bytes = std::fs::read(&fa).unwrap();
    assert!(bytes == std::fs::read(&fb).unwrap(), "bundle bytes differ between two runs");
    assert!(run(&["verify", fa.to_str().unwrap()]).status.success());
    // Corrupted or truncated bundles are clear errors, never a pass.
    let mut flipped = bytes.clone();
    let n = flipped.len();
    flipped[n / 2] ^= 0x10;
    for bad in [flipped, bytes[..n / 2].to_vec()] {
        std::fs::write(&fb, &bad).unwrap();
        let out = run(&["verify", fb.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
}

/// Output cut short (`twoscale verify DIR | head -1`, `| true`): the reader has gone before the first line,
/// and the command ends quietly (SIGPIPE's default action: no panic, no message), as a Unix tool does.
/// The pipe's read end is closed before twoscale starts, so every write meets the broken pipe.
#[test]
fn output_cut_short_ends_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let paper = shared_tables().join("paper");
    let cases: [&[&str]; 3] =
        [&["verify", paper.to_str().unwrap()], &["plan", "--preset", "default"], &["verify", "--help"]];
    for args in cases {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = std::process::Command::new(common::BIN).args(args).stdout(writer).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{args:?}: {err}");
        assert!(
            out.status.success() || out.status.signal() == Some(libc::SIGPIPE),
            "{args:?}: {:?}, {err}",
            out.status
        );
    }
}
