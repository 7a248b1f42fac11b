//! The Mitsuba 3 plugin (examples/mitsuba) on the default preset: lookup_arrays against lookup,
//! mitsuba.chi2 of sample() against pdf(), eval() against a brute-force docs/maths.md section 7, the white
//! furnace and docs/maths.md section 7's limit, a render, corrupt tables and a real bundle
//! (examples/mitsuba/test_twoscale.py). Needs `make pyenv` and libLLVM 19 (`make test` does both).

mod common;

use common::shared_tables::shared_tables;

use common::{python, repo_root, tempdir, BIN};
use std::path::Path;
use std::process::Command;

const LIBLLVM: &str = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so";

#[test]
fn mitsuba_plugin_passes_its_tests() {
    let root = repo_root();
    let py = python();
    // The default preset, built by this code (`shared_tables`).
    let out_dir = shared_tables();
    let work = tempdir();
    let out = Command::new(BIN)
        .args(["bundle", "--quiet", "--preset", "default", "--tables"])
        .arg(&out_dir)
        .arg("--out")
        .arg(work.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "bundle: {}", String::from_utf8_lossy(&out.stderr));
    let bundle = std::fs::read_dir(work.path()).unwrap().map(|e| e.unwrap().path()).find(|p| p.to_string_lossy().ends_with(".tar.gz")).unwrap();

    let mut cmd = Command::new(&py);
    cmd.arg(root.join("examples/mitsuba/test_twoscale.py")).arg("--tables").arg(out_dir.join("default")).arg("--bundle").arg(&bundle);
    if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
        assert!(Path::new(LIBLLVM).exists(), "{LIBLLVM} is missing: run `make test` (its `deps` step installs libllvm19)");
        cmd.env("DRJIT_LIBLLVM_PATH", LIBLLVM);
    }
    let out = cmd.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.lines().filter(|l| l.starts_with("ok    chi2:")).count() >= 12, "fewer than 12 chi-square tests passed");
}
