//! The C reference BRDF pipeline/contract/c/twoscale_brdf.h over the material folders of
//! examples/mitsuba/test_materials.toml (examples/mitsuba/test_c_brdf.py): it compiles as C99 and
//! C++ without a warning; mitsuba.chi2 accepts its sample() against its pdf() at the 13 chi-square
//! cases; eval() against the brute-force reference.py; the white furnace. Needs `make pyenv` and
//! libLLVM 19 (`make test` does both).

mod common;

use common::shared_tables::test_materials;
use common::{python, repo_root, BIN};
use std::path::Path;
use std::process::Command;

const LIBLLVM: &str = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so";

#[test]
fn c_brdf_passes_its_tests() {
    let materials = test_materials();
    let mut cmd = Command::new(python());
    cmd.arg(repo_root().join("examples/mitsuba/test_c_brdf.py"))
        .arg("--materials")
        .arg(materials)
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
    assert_eq!(passed("ok    compile:"), 4, "the compile checks did not all run");
    assert_eq!(passed("ok    brute:"), 3, "the brute-force checks did not all run");
    assert_eq!(passed("ok    furnace:"), 18, "the furnace checks did not all run");
}
