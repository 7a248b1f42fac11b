//! The C reference BRDF pipeline/contract/c/twoscale_brdf.h over the material folders of
//! examples/mitsuba/test_materials.toml (examples/mitsuba/test_c_brdf.py): it compiles as C99 and
//! C++ without a warning; mitsuba.chi2 accepts its sample() against its pdf() at the 13 chi-square
//! cases; eval() against the brute-force reference.py; the white furnace. Needs `make pyenv` and
//! libLLVM 19 (`make test` does both).

mod common;

use common::shared_tables::test_materials;
use common::{assert_input_error, python, repo_root, run, tempdir, BIN};
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

/// `export --dir` without `--table` of a folder that is not a material folder, or of one that lacks a
/// table: one line, exit status 2, nothing written.
#[test]
fn material_export_refuses_bad_folders() {
    let work = tempdir();
    let out = work.path().join("out");
    let chi5 = test_materials().join("chi5");
    let partial = work.path().join("partial");
    std::fs::create_dir(&partial).unwrap();
    for f in std::fs::read_dir(&chi5).unwrap().map(|e| e.unwrap().path()) {
        if !f.file_name().unwrap().to_string_lossy().starts_with("zh_lobe.") {
            std::fs::copy(&f, partial.join(f.file_name().unwrap())).unwrap();
        }
    }
    let export = |dir: &Path| run(&["export", "--format", "c-header", "--dir", dir.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_input_error(&export(test_materials()), "is not a material folder");
    assert_input_error(&export(&partial), "lacks its table zh_lobe");
    assert!(!out.exists(), "an export that failed wrote {}", out.display());
    // The whole folder: the six data headers and the material's.
    let o = export(&chi5);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 7);
    assert!(out.join("twoscale_material_scene_test_materials_chi5.h").is_file());
}
