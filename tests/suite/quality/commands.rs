//! The quality commands: `twoscale stress`, `plot` and `bench --quick`.

use crate::common;

use common::shared_tables::shared_tables;

use common::{assert_input_error, assert_ok, run, tempdir};
use std::path::Path;

#[test]
fn stress_cases_at_the_domain_edges_all_pass() {
    let out = run(&["stress", "--quick", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["cases"].as_u64().unwrap() > 5000, "{v}");
    assert_eq!(v["failures"], 0, "{}", v["failed"]);
    assert!(out.status.success());
}

/// Width and height from a PNG's IHDR chunk (None if the signature is wrong).
fn png_size(path: &Path) -> Option<(u32, u32)> {
    let bytes = std::fs::read(path).ok()?;
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (bytes.len() > 24 && bytes[..8] == *b"\x89PNG\r\n\x1a\n" && &bytes[12..16] == b"IHDR").then(|| (be(16), be(20)))
}

#[test]
fn plot_draws_every_table_with_its_error() {
    let out = tempdir();
    let dir = shared_tables().to_str().unwrap();
    for (table, width) in [("epd_norm", 1240), ("epd_g1", 1240), ("kcorr_renorm", 1240), ("zh_convolution", 1860)] {
        let png = out.path().join(format!("{table}.png"));
        let res = run(&["plot", table, "--preset", "paper", "--tables", dir, "--out", png.to_str().unwrap()]);
        assert!(res.status.success(), "{table}: {}", String::from_utf8_lossy(&res.stderr));
        let stdout = String::from_utf8_lossy(&res.stdout);
        assert!(stdout.starts_with(&format!("{table}: worst")), "{stdout}");
        assert_eq!(
            png_size(&png),
            Some((width, if width == 1240 && table == "epd_norm" { 560 } else { 600 })),
            "{table}"
        );
    }
    // The error shown for epd_g1 is the paper grid's interpolation error (the manifest's 5.3e-3 order).
    let res = run(&[
        "plot",
        "epd_g1",
        "--preset",
        "paper",
        "--tables",
        dir,
        "--out",
        out.path().join("g.png").to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&res.stdout);
    let worst: f64 = text.split("shown ").nth(1).unwrap().split_whitespace().next().unwrap().parse().unwrap();
    assert!(worst > 1e-4 && worst < 2e-2, "{text}");
    // Bad input: unknown table (2), no such preset directory (1), not a .png (2); nothing written.
    assert_input_error(&run(&["plot", "nope", "--tables", dir]), "unknown table");
    let missing = run(&[
        "plot",
        "epd_g1",
        "--preset",
        "scene-none",
        "--tables",
        dir,
        "--out",
        out.path().join("m.png").to_str().unwrap(),
    ]);
    assert_eq!(missing.status.code(), Some(1));
    assert_eq!(String::from_utf8_lossy(&missing.stderr).trim().lines().count(), 1);
    assert_input_error(
        &run(&[
            "plot",
            "epd_g1",
            "--preset",
            "paper",
            "--tables",
            dir,
            "--out",
            out.path().join("x.jpg").to_str().unwrap(),
        ]),
        ".png",
    );
    assert!(!out.path().join("m.png").exists() && !out.path().join("x.jpg").exists());
}

/// One bench CSV as (header, rows of fields); fields may be quoted.
fn read_csv(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let split = |line: &str| {
        let (mut fields, mut cur, mut quoted) = (Vec::new(), String::new(), false);
        for ch in line.chars() {
            match ch {
                '"' => quoted = !quoted,
                ',' if !quoted => fields.push(std::mem::take(&mut cur)),
                _ => cur.push(ch),
            }
        }
        fields.push(cur);
        fields
    };
    let mut lines = text.lines();
    let header = split(lines.next().unwrap());
    lines.map(|l| header.iter().cloned().zip(split(l)).collect()).collect()
}

#[test]
fn quick_bench_measures_every_table_against_its_baseline() {
    let out = tempdir();
    let res = run(&["bench", "--quick", "--quiet", "--out", out.path().to_str().unwrap()]);
    assert_ok(&res);
    let stdout = String::from_utf8_lossy(&res.stdout);
    // The profile: the unit of work of every stage, counted, and the whole paper preset timed.
    let profile: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.path().join("profile.json")).unwrap()).unwrap();
    let stages = profile["stages"].as_array().unwrap();
    let names: Vec<String> =
        stages.iter().map(|s| format!("{} {}", s["table"].as_str().unwrap(), s["stage"].as_str().unwrap())).collect();
    assert_eq!(names, ["epd_g1 values", "kcorr_renorm values", "zh_convolution fits", "zh_convolution synthesis"]);
    let units = |i: usize| stages[i]["units_per_paper_table"].as_f64().unwrap();
    // Adaptive G7/K15: at least one 15-point panel for most of the 100,000 entries.
    assert!(units(0) > 15.0 * 50_000.0 && units(1) > 15.0 * 50_000.0, "{profile}");
    // 236,500 fits of at least 2 passes over 1000 samples; the synthesis GEMM is 2 x 473 x 100 x 1000 x 250 flops.
    assert!(units(2) >= 2.0 * 236_500.0 * 1000.0, "{profile}");
    assert_eq!(units(3), 2.0 * 473.0 * 100.0 * 1000.0 * 250.0);
    assert!(profile["whole_preset_seconds_2_threads"]["paper"].as_f64().unwrap() > 0.0);
    assert!(stdout.contains("whole paper preset:"), "{stdout}");
    // zh_lobe: grid sizes against zh_convolution's fitted lobes, same measure, same points.
    assert_eq!(png_size(&out.path().join("zh_lobe.png")), Some((1600, 700)));
    let rows = read_csv(&out.path().join("zh_lobe.csv"));
    let num = |r: &std::collections::HashMap<String, String>, k: &str| r[k].parse::<f64>().unwrap();
    let series = |prefix: &str| rows.iter().filter(|r| r["series"].starts_with(prefix)).collect::<Vec<_>>();
    let (sizes, attribution, fitted) = (series("twoscale"), series("attribution"), series("paper"));
    assert!(sizes.len() >= 2 && attribution.len() == 5 && fitted.len() == 2, "{rows:?}");
    assert!(
        sizes.windows(2).all(|w| num(w[1], "megabytes") > num(w[0], "megabytes")
            && num(w[1], "interp_error") < num(w[0], "interp_error")),
        "{sizes:?}"
    );
    // Measured (p >= 4.6): p99 0.056 and 0.029 for the two grids, 14 and 46 for the cos and plain fitted lobes.
    let largest = num(sizes.last().unwrap(), "interp_error");
    assert!(largest < 0.1 && fitted.iter().all(|r| num(r, "interp_error") > 10.0 * largest), "{rows:?}");
    // The largest grid's error, one parameter axis off-grid at a time; the angle
    // axis alone gives a fraction of it (measured 0.0017 against 0.029; p alone 0.0021, c alone 0.033).
    let alone = |name: &str| num(attribution.iter().find(|r| r["setting"] == name).unwrap(), "interp_error");
    assert!(
        alone("theta_h only") < 0.5 * largest
            && ["u", "c", "p", "beta"].iter().all(|a| alone(a) > alone("theta_h only")),
        "{attribution:?}"
    );
    assert!(
        attribution
            .iter()
            .all(|r| r["megabytes"] == sizes.last().unwrap()["megabytes"] && r["pareto_interp"] == "false"),
        "{attribution:?}"
    );
    // epd_albedo: the rule against 0.10.0's on the same nodes (both timed, the ratio printed; the
    // speed goal lives in the bench, not here), more accurate, and the shipped grid's cubic lookup
    // within the target.
    let rows = read_csv(&out.path().join("epd_albedo.csv"));
    let row = |setting: &str, series: &str| {
        rows.iter()
            .find(|r| r["setting"] == setting && r["series"].starts_with(series))
            .unwrap_or_else(|| panic!("{rows:?}"))
    };
    let (old, new) = (row("0.10.0", "0.10.0 rule"), row("shipped", "shared-column rule"));
    assert!(
        old["baseline"] == "true" && num(new, "seconds_2_threads") > 0.0 && num(old, "seconds_2_threads") > 0.0,
        "{rows:?}"
    );
    assert!(num(new, "node_error") < num(old, "node_error"), "{rows:?}");
    assert!(num(row("cells x 1", "cubic"), "interp_error") <= 1e-4, "{rows:?}");
    assert!(stdout.contains("epd_albedo: baseline 0.10.0"), "{stdout}");
    // Per-material tables: larger grids, smaller errors, for both materials.
    let rows = read_csv(&out.path().join("material_tables.csv"));
    for material in ["nickel", "narrow_diffraction"] {
        let sizes: Vec<_> =
            rows.iter().filter(|r| r["grid"] == material && r["series"].starts_with("per-material")).collect();
        assert!(sizes.len() >= 2, "{rows:?}");
        assert!(
            sizes.windows(2).all(|w| num(w[1], "megabytes") > num(w[0], "megabytes")
                && num(w[1], "interp_error") < num(w[0], "interp_error")),
            "{sizes:?}"
        );
    }
    for table in ["epd_g1", "kcorr_renorm", "zh_convolution"] {
        assert_eq!(png_size(&out.path().join(format!("{table}.png"))), Some((1600, 700)), "{table}");
        let rows = read_csv(&out.path().join(format!("{table}.csv")));
        let num = |r: &std::collections::HashMap<String, String>, k: &str| r[k].parse::<f64>().unwrap();
        for r in &rows {
            assert!(num(r, "seconds_2_threads") > 0.0 && num(r, "seconds_1_thread") > 0.0, "{table}: {r:?}");
            assert!(num(r, "node_error").is_finite(), "{table}: {r:?}");
        }
        let (base, ours): (Vec<_>, Vec<_>) = rows.iter().partition(|r| r["baseline"] == "true");
        assert!(base.len() >= 2 && ours.len() >= 3, "{table}");
        assert!(
            rows.iter().any(|r| r["pareto_node"] == "true") && rows.iter().any(|r| r["pareto_interp"] == "true"),
            "{table}"
        );
        // The baselines converge as they are given more work.
        let errors: Vec<f64> = base.iter().map(|r| num(r, "node_error")).collect();
        assert!(errors.windows(2).all(|w| w[1] < w[0]), "{table} baseline errors {errors:?}");
        // A speed ratio is printed for every baseline setting.
        assert_eq!(
            stdout.lines().filter(|l| l.trim_start().starts_with(&format!("{table}: baseline"))).count(),
            base.len(),
            "{stdout}"
        );
        let shipped = |setting: &str| ours.iter().find(|r| r["setting"] == setting).map(|r| num(r, "node_error"));
        match table {
            // Stored values exact to the f32 digit: error below f32 rounding of values <= 1.
            "epd_g1" => assert!(shipped("rel_tol=1e-10").unwrap() < 1.2e-7, "{rows:?}"),
            "kcorr_renorm" => assert!(shipped("rel_tol=1e-11").unwrap() < 1.2e-7, "{rows:?}"),
            // Truncation falls as L grows.
            _ => {
                let e: Vec<f64> = ["L=50", "L=100", "L=200"].iter().map(|s| shipped(s).unwrap()).collect();
                assert!(e[0] > e[1] && e[1] > e[2], "{e:?}");
            }
        }
    }
}
