//! The Mitsuba 3 BSDF (examples/mitsuba/twoscale_bsdf.py) on the material folders of
//! examples/mitsuba/test_materials.toml: mitsuba.chi2 of sample() against pdf() at the 13 cases,
//! eval() against the brute-force docs/maths.md section 7 (and the numpy model on the default
//! preset), the C reference BRDF against it, the white furnace and section 7's limit, symbolic and
//! scalar renders, gradients against finite differences, corrupt input and a real bundle
//! (examples/mitsuba/test_twoscale.py). Needs `make pyenv` and libLLVM 19 (`make test` does both).

use crate::common;

use common::shared_tables::{shared_tables, test_materials};

use common::{mitsuba_script, passed, tempdir, BIN};
use std::ffi::OsStr;
use std::process::Command;

#[test]
fn mitsuba_bsdf_passes_its_tests() {
    let materials = test_materials();
    let presets = shared_tables().join("default"); // the reader's lookup and the numpy model read it
    let work = tempdir();
    let out = Command::new(BIN).args(["bundle", "--quiet", "--dir"]).arg(materials).arg("--out").arg(work.path()).output().unwrap();
    assert!(out.status.success(), "bundle: {}", String::from_utf8_lossy(&out.stderr));
    let bundle = std::fs::read_dir(work.path()).unwrap().map(|e| e.unwrap().path()).find(|p| p.to_string_lossy().ends_with(".tar.gz")).unwrap();

    let args: [&OsStr; 6] = ["--materials".as_ref(), materials.as_os_str(), "--bundle".as_ref(), bundle.as_os_str(), "--tables".as_ref(), presets.as_os_str()];
    let stdout = mitsuba_script("test_twoscale.py", &args);
    assert_eq!(passed(&stdout, "ok    chi2:"), 26, "not every chi-square test passed (13 single, 13 compensated)");
    assert_eq!(passed(&stdout, "ok    brute:"), 5, "the brute-force checks did not all run");
    assert_eq!(passed(&stdout, "ok    c:"), 4, "the C checks did not all run (single and compensated)");
    assert_eq!(passed(&stdout, "ok    energy:"), 21, "the energy checks did not all run (18 materials' sample() means, furnace, conductor, reciprocity)");
    assert_eq!(passed(&stdout, "ok    grad:"), 8, "the gradient checks did not all run");
    assert_eq!(passed(&stdout, "ok    render:"), 8, "the render checks did not all run");
}
