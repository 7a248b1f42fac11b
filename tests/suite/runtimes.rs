//! The runtimes: the Mitsuba BSDF (runtimes/mitsuba), the C reference BRDF (runtimes/c) and the GLSL one (runtimes/webgl), by their
//! pytest suites over the material folders of runtimes/testing/test_materials.toml (chi-square,
//! brute force against docs/maths.md section 7, white furnace, energy compensation, renders,
//! gradients, corrupt input), and the C BRDF's own checks: its inline ln and exp, its exports, its
//! refusals. Needs `make pyenv`, libLLVM 19 and Chromium (`make test` installs them).

// The GPU export and `twoscale view` (runtimes/webgl); the page's own tests run in a browser.
mod webgl;

use crate::common;

use common::c_lookup::{cc, run_c_test};
use common::shared_tables::{shared_tables, test_materials};
use common::{assert_input_error, pytest_runtime, run, tempdir};
use std::path::Path;

/// runtimes/mitsuba/tests: 8 lookups, 50 chi-square cases (13 conductors, 6 plastics, 6 subsurface materials;
/// 2 energy modes), brute force, the C BRDF (2), the furnace, energy (3), renders (2), variants (2 x 2),
/// gradients (2), corrupt input (2 variants), a bundle; the layered models (test_layered.py): furnace (2),
/// reciprocity (2), brute force (2), the C BRDF (4), gradients (2); general mode (test_general.py): agreement
/// (2 lobes), texels, 20 chi-square cases (6 compensated), gradients (2 materials, a texel), the furnace, refusals.
#[test]
fn mitsuba_bsdf_passes_its_tests() {
    pytest_runtime("mitsuba", Some(&shared_tables().join("default")), 118);
}

/// runtimes/c/tests: the compile checks (3 materials), 50 chi-square cases, brute force, the furnace, energy;
/// the layered models' furnace and reciprocity.
#[test]
fn c_brdf_passes_its_tests() {
    pytest_runtime("c", None, 58);
}

/// runtimes/webgl/tests, in headless Chromium (SwiftShader's WebGL2): the shader against the C BRDF (eval at 8
/// materials x 4 modes, 65,537 points, sample and pdf, a bundle's export) and the Mitsuba BSDF, loadMaterial's
/// refusals; the explorer page draws (3 materials), logs nothing, integrates a white plastic's albedo to 1,
/// redraws when a control changes, shows a broken export's error (4 cases), and runs under `twoscale view`; the
/// general export (test_general_export.py, numpy): size, checksums and determinism, zh_lobe's float16 residual
/// decoded against the table, the other tables' values; loadTables and evalPoints on it (test_general_webgl.py):
/// 1,000 points of their own parameters against the numpy model, 6 materials against their own exports, sample, pdf
/// and eval (both energies) against the Mitsuba BSDF's general mode, the refusals; the general explorer's sliders
/// (test_webgl_page.py).
#[test]
fn webgl_runtime_passes_its_tests() {
    pytest_runtime("webgl", Some(&shared_tables().join("default")), 45);
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
    let export = |dir: &Path| {
        run(&["export", "--format", "c-header", "--dir", dir.to_str().unwrap(), "--out", out.to_str().unwrap()])
    };
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
    let o = run(&[
        "export",
        "--format",
        "c-header",
        "--dir",
        test_materials().join("chi5").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
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
    assert_eq!(
        text.trim(),
        "twoscale_brdf_init: a table is not multilinear (per-material tables are; this BRDF reads them bilinearly)"
    );
}
