//! The C reference BRDF pipeline/tables/c/twoscale_brdf.h over the material folders of
//! examples/mitsuba/test_materials.toml (examples/mitsuba/test_c_brdf.py): it compiles as C99 and
//! C++ without a warning; mitsuba.chi2 accepts its sample() against its pdf() at the 13 chi-square
//! cases; eval() against the brute-force reference.py; the white furnace. Needs `make pyenv` and
//! libLLVM 19 (`make test` does both).

use crate::common;

use common::shared_tables::test_materials;
use common::c_lookup::{cc, run_c_test};
use common::{assert_input_error, mitsuba_script, passed, run, tempdir};
use std::path::Path;

#[test]
fn c_brdf_passes_its_tests() {
    let stdout = mitsuba_script("test_c_brdf.py", &["--materials".as_ref(), test_materials().as_os_str()]);
    assert_eq!(passed(&stdout, "ok    chi2:"), 13, "not every chi-square test passed");
    assert_eq!(passed(&stdout, "ok    compile:"), 4, "the compile checks did not all run");
    assert_eq!(passed(&stdout, "ok    brute:"), 3, "the brute-force checks did not all run");
    assert_eq!(passed(&stdout, "ok    furnace:"), 18, "the furnace checks did not all run");
    assert_eq!(passed(&stdout, "ok    chi2 (compensated):"), 13, "not every compensated chi-square test passed");
    assert_eq!(passed(&stdout, "ok    energy:"), 3, "the energy checks did not all run (furnace, conductor, reciprocity)");
}

/// tests/c/log_exp.c: eval's inline ln within 1 ulp + 2.3e-16 of libm's, its exp within 1 ulp, over
/// 4 million arguments each, and their special values.
#[test]
fn inline_log_and_exp_match_libm() {
    let text = run_c_test("log_exp");
    assert!(text.starts_with("log: worst"), "{text}");
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
    // The whole folder: the seven data headers and the material's.
    let o = export(&chi5);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 8);
    assert!(out.join("twoscale_material_scene_test_materials_chi5.h").is_file());
}

/// twoscale_brdf_init over a material whose table claims cubic interpolation (per-material tables
/// are multilinear, and the BRDF reads them bilinearly): one line, and the intact material inits.
#[test]
fn c_brdf_init_refuses_a_cubic_table() {
    let work = tempdir();
    let out = work.path().join("out");
    let o = run(&["export", "--format", "c-header", "--dir", test_materials().join("chi5").to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let program = work.path().join("cubic_init.c");
    std::fs::write(
        &program,
        "#include <stdio.h>\n#include \"twoscale_material_scene_test_materials_chi5.h\"\n\
         int main(void) {\n    twoscale_brdf b;\n    twoscale_material m = twoscale_material_scene_test_materials_chi5;\n\
             twoscale_table g1 = *m.epd_g1;\n    const char *err = twoscale_brdf_init(&b, &m, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE);\n\
             if (err) { printf(\"intact: %s\\n\", err); return 1; }\n    g1.interpolation = TWOSCALE_CUBIC;\n    m.epd_g1 = &g1;\n\
             err = twoscale_brdf_init(&b, &m, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE);\n    printf(\"%s\\n\", err ? err : \"accepted\");\n\
             return 0;\n}\n",
    )
    .unwrap();
    let exe = work.path().join("cubic_init");
    let o = cc().arg("-I").arg(&out).arg(&program).arg("-o").arg(&exe).arg("-lm").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = std::process::Command::new(&exe).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}");
    assert_eq!(text.trim(), "twoscale_brdf_init: a table is not multilinear (per-material tables are; this BRDF reads them bilinearly)");
}
