//! The Mitsuba 3 BSDF (examples/mitsuba/twoscale_bsdf.py) on the material folders of
//! examples/mitsuba/test_materials.toml: mitsuba.chi2 of sample() against pdf() at the 13 cases,
//! eval() against the brute-force docs/maths.md section 7 (and the numpy model on the default
//! preset), the C reference BRDF against it, the white furnace and section 7's limit, symbolic and
//! scalar renders, gradients against finite differences, corrupt input and a real bundle
//! (examples/mitsuba/test_twoscale.py). Needs `make pyenv` and libLLVM 19 (`make test` does both).

mod common;

use common::shared_tables::{shared_tables, test_materials};

use common::{python, repo_root, tempdir, BIN};
use std::path::Path;
use std::process::Command;

const LIBLLVM: &str = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so";

#[test]
fn mitsuba_bsdf_passes_its_tests() {
    let materials = test_materials();
    let presets = shared_tables(); // the default preset: the reader's lookup and the numpy model
    let work = tempdir();
    let out = Command::new(BIN).args(["bundle", "--quiet", "--dir"]).arg(materials).arg("--out").arg(work.path()).output().unwrap();
    assert!(out.status.success(), "bundle: {}", String::from_utf8_lossy(&out.stderr));
    let bundle = std::fs::read_dir(work.path()).unwrap().map(|e| e.unwrap().path()).find(|p| p.to_string_lossy().ends_with(".tar.gz")).unwrap();

    let mut cmd = Command::new(python());
    cmd.arg(repo_root().join("examples/mitsuba/test_twoscale.py"))
        .arg("--materials")
        .arg(materials)
        .arg("--bundle")
        .arg(&bundle)
        .arg("--tables")
        .arg(presets.join("default"))
        .arg("--cache")
        .arg(Path::new(env!("CARGO_TARGET_TMPDIR")).join("c-brdf-cache"))
        .env("TWOSCALE_BIN", BIN);
    if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
        assert!(Path::new(LIBLLVM).exists(), "{LIBLLVM} is missing: run `make test` (its `deps` step installs libllvm19)");
        cmd.env("DRJIT_LIBLLVM_PATH", LIBLLVM);
    }
    let out = cmd.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let passed = |prefix: &str| stdout.lines().filter(|l| l.starts_with(prefix)).count();
    assert_eq!(passed("ok    chi2:"), 13, "not every chi-square test passed");
    assert_eq!(passed("ok    brute:"), 5, "the brute-force checks did not all run");
    assert_eq!(passed("ok    c:"), 2, "the C checks did not all run");
    assert_eq!(passed("ok    grad:"), 4, "the gradient checks did not all run");
    assert_eq!(passed("ok    render:"), 4, "the render checks did not all run");
}
