//! zh_lobe (docs/maths.md section 4b): the reference against the direct integral, the table
//! against the reference (never against its own output), every reader
//! against the CLI, bad coordinates, and determinism across thread counts.

use crate::common;

use common::c_lookup::c_lookup;
use common::{assert_ok, build, python, run, run_env, tempdir, BIN};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use twoscale_generate::accuracy::random_points;
use twoscale_generate::tables::zh_grid::DEFAULT_DEGREE;
use twoscale_generate::tables::zh_lobe::{lobe_errors, reference};
use twoscale_generate::tables::zh_math::{exact_convolution, ThetaRule};
use twoscale_tables::lobe::LobeParams;
use twoscale_tables::lookup::Lookup;

/// A scene whose zh_lobe sub-domain is small (u 0..1.6, p ~ 1.5, beta ~ 0.1: 5,760 entries).
const SCENE: &str =
    "[[material]]\nname = \"probe\"\nbeta = 0.1\np = 1.5\nsigma_s = 0.004\nb = 0.8\nc = 2.2\nwavelengths = [0.55]\n";

/// (output dir, scene file): the scene's zh_lobe, built once.
fn scene_build() -> &'static (tempfile::TempDir, PathBuf) {
    static DIR: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempdir();
        let scene = dir.path().join("lobe.toml");
        std::fs::write(&scene, SCENE).unwrap();
        build(dir.path(), &["--table", "zh_lobe", "--scene", scene.to_str().unwrap()]);
        (dir, scene)
    })
}

fn tables() -> &'static Path {
    scene_build().0.path()
}

fn cli_lookup(pt: &[f64]) -> Output {
    let names = ["u", "c", "p", "beta", "theta_h"];
    let mut args = vec![
        "lookup".to_string(),
        "zh_lobe".into(),
        "--preset".into(),
        "scene-lobe".into(),
        "--tables".into(),
        tables().to_str().unwrap().into(),
        "--json".into(),
    ];
    for (n, x) in names.iter().zip(pt) {
        args.push("--at".into());
        args.push(format!("{n}={x:e}"));
    }
    Command::new(BIN).args(&args).output().unwrap()
}

fn cli_value(pt: &[f64]) -> f64 {
    let out = cli_lookup(pt);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["values"]["c_lobe"].as_f64().unwrap()
}

#[test]
fn reference_agrees_with_the_direct_integral() {
    // The converged zonal-harmonic sum the accuracy is measured against, at spot points
    // spanning the domain (broad, sharpest, grazing-peaked), against the direct 2-D integral.
    let points = vec![
        vec![0.0, 2.0, 1.0, 0.1],
        vec![100.0, 3.02, 5.0, 0.005],
        vec![5.0, 1.5, 0.2, 0.5],
        vec![30.0, 1.02, 2.0, 0.05],
    ];
    let rule = ThetaRule::standard(DEFAULT_DEGREE);
    let r = reference(&points, &rule, DEFAULT_DEGREE);
    for (i, pt) in points.iter().enumerate() {
        let max = r.row(i).iter().fold(0.0f64, |m, x| m.max(*x));
        for k in (0..1000).step_by(37).chain([999]) {
            let theta = (1.0 - k as f64 / 1000.0).asin();
            let exact = exact_convolution(theta, &LobeParams { u: pt[0], c: pt[1], p: pt[2], beta: pt[3] }, 1e-10);
            let scale = exact.max(1e-4 * max);
            assert!(
                (r[[i, k]] - exact).abs() <= 2e-3 * scale,
                "{pt:?} theta {theta}: reference {} vs direct {exact}",
                r[[i, k]]
            );
        }
    }
}

#[test]
fn scene_table_is_within_its_measured_error_of_the_reference() {
    let table = Lookup::open(&tables().join("scene-lobe"), "zh_lobe").unwrap();
    let points = random_points(&table.axes[..4], 40, 77);
    let r = reference(&points, &ThetaRule::standard(DEFAULT_DEGREE), DEFAULT_DEGREE);
    let errors = lobe_errors(&r, |i, th| {
        let p = &points[i];
        table.at(&[p[0], p[1], p[2], p[3], th]).unwrap()[0].1
    });
    let mut pooled = errors.pooled.clone();
    pooled.sort_by(f64::total_cmp);
    let (median, p99) = (pooled[pooled.len() / 2], pooled[pooled.len() * 99 / 100]);
    let l2 = errors.per_point.iter().map(|e| e.1).fold(0.0, f64::max);
    // Measured here (u < 1.6, p ~ 1.5, beta ~ 0.1): median 7.3e-3, p99 5.7e-2, relative L2 7.6e-3;
    // the whole default preset's figures are in its manifest (docs/maths.md section 4b's 1 % is not met yet).
    assert!(median < 1e-2 && p99 < 6e-2 && l2 < 2e-2, "median {median}, p99 {p99}, relative L2 max {l2}");
}

#[test]
fn readers_agree_with_the_cli() {
    let dir = tables().join("scene-lobe");
    let table = Lookup::open(&dir, "zh_lobe").unwrap();
    let mut points: Vec<Vec<f64>> = random_points(&table.axes[..4], 30, 5)
        .into_iter()
        .enumerate()
        .map(|(k, mut p)| {
            p.push(std::f64::consts::FRAC_PI_2 * k as f64 / 29.0);
            p
        })
        .collect();
    points.push(vec![0.5, 2.0, 1.55, 0.1, 2.0]); // theta_h outside [0, pi/2]
    let expected: Vec<Option<f64>> = points.iter().map(|p| table.at(p).ok().map(|v| v[0].1)).collect();
    assert!(expected[..30].iter().all(|e| e.is_some()) && expected[30].is_none());
    for (p, e) in points.iter().zip(&expected).step_by(6) {
        if let Some(e) = e {
            let g = cli_value(p); // the CLI reads the point as printed ({:e}, shortest round trip)
            assert!((g - e).abs() <= 1e-12 * e.abs(), "CLI {g} vs library {e} at {p:?}");
        }
    }
    // Python reader.
    let py = python();
    for (p, e) in points.iter().zip(&expected).step_by(5) {
        let mut cmd = Command::new(&py);
        cmd.args(["-m", "twoscale_tables", "lookup"]).arg(dir.join("zh_lobe.h5"));
        for (n, x) in ["u", "c", "p", "beta", "theta_h"].iter().zip(p) {
            cmd.arg(format!("{n}={x:e}"));
        }
        let out = cmd.output().unwrap();
        match e {
            Some(e) => {
                assert_ok(&out);
                let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
                let g = v["values"]["c_lobe"].as_f64().unwrap();
                assert!((g - e).abs() <= 1e-12 * e.abs(), "Python {g} vs library {e} at {p:?}");
            }
            None => assert_eq!(out.status.code(), Some(2)),
        }
    }
    // C header.
    let work = tempdir();
    let out = run(&[
        "export",
        "--format",
        "c-header",
        "--table",
        "zh_lobe",
        "--preset",
        "scene-lobe",
        "--tables",
        tables().to_str().unwrap(),
        "--out",
        work.path().to_str().unwrap(),
    ]);
    assert_ok(&out);
    let prefix = "twoscale_zh_lobe_scene_lobe";
    let lines = c_lookup(&work.path().join(format!("{prefix}.h")), prefix, &points, work.path());
    for ((line, e), p) in lines.iter().zip(&expected).zip(&points) {
        match e {
            Some(e) => {
                let g: f64 = line.parse().unwrap();
                assert!((g - e).abs() <= 1e-12 * e.abs(), "C {g} vs library {e} at {p:?}");
            }
            None => assert_eq!(line, "outside"),
        }
    }
}

#[test]
fn bad_coordinates_are_one_line_errors() {
    for (pt, needle) in [
        ([0.5, 2.2, 1.55, 0.1, 1.6], "theta_h = 1.6 is outside"),
        ([0.5, 2.2, 1.55, 0.1, -0.1], "theta_h = -0.1 is outside"),
        ([0.5, 2.2, 1.55, 0.1, f64::NAN], "theta_h is NaN"),
        ([0.5, 2.2, 9.0, 0.1, 0.1], "p = 9 is outside"),
    ] {
        let out = cli_lookup(&pt);
        assert_eq!(out.status.code(), Some(2), "{pt:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{err}");
    }
}

#[test]
fn control_variates_without_their_coordinates_are_refused() {
    // A manifest whose value encoding with control variates lost its derived theta_h:
    // it differs from the file's own contract, and the CLI (lookup, export) and
    // the Python reader refuse it in one line.
    let src = tables().join("scene-lobe");
    let dir = tempdir();
    let bad = dir.path().join("scene-lobe");
    std::fs::create_dir_all(&bad).unwrap();
    std::fs::copy(src.join("zh_lobe.h5"), bad.join("zh_lobe.h5")).unwrap();
    let mut manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(src.join("zh_lobe.manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["value_encoding"][0]["control_variates"].as_array().map(Vec::len), Some(4));
    manifest["derived_axes"] = serde_json::json!([]);
    std::fs::write(bad.join("zh_lobe.manifest.json"), serde_json::to_vec(&manifest).unwrap()).unwrap();
    let dir_arg = dir.path().to_str().unwrap();
    let at = ["--at", "u=0.5", "--at", "c=2.2", "--at", "p=1.55", "--at", "beta=0.1", "--at", "v_theta=0.3"];
    let lookup = [&["lookup", "zh_lobe", "--preset", "scene-lobe", "--tables", dir_arg][..], &at[..]].concat();
    let export = [
        "export",
        "--format",
        "c-header",
        "--table",
        "zh_lobe",
        "--preset",
        "scene-lobe",
        "--tables",
        dir_arg,
        "--out",
        dir_arg,
    ];
    for args in [&lookup[..], &export[..]] {
        let out = run(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success()
                && err.lines().count() == 1
                && err.contains("the contract")
                && err.contains("differs from the file"),
            "{args:?}: {err}"
        );
    }
    let py = python();
    let out = Command::new(py)
        .args(["-m", "twoscale_tables", "lookup"])
        .arg(bad.join("zh_lobe.h5"))
        .args(["u=0.5", "c=2.2", "p=1.55", "beta=0.1", "v_theta=0.3"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(1)
            && err.lines().count() == 1
            && err.contains("the contract")
            && err.contains("differs from the file"),
        "{err}"
    );
}

#[test]
fn same_bytes_with_one_thread() {
    let (dir, scene) = scene_build();
    let one = tempdir();
    let out = run_env(
        &[
            "build",
            "--quiet",
            "--table",
            "zh_lobe",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            one.path().to_str().unwrap(),
        ],
        &[("RAYON_NUM_THREADS", "1")],
    );
    assert_ok(&out);
    let a = std::fs::read(one.path().join("scene-lobe/zh_lobe.h5")).unwrap();
    let b = std::fs::read(dir.path().join("scene-lobe/zh_lobe.h5")).unwrap();
    assert!(a == b, "zh_lobe bytes differ between 1 thread and all threads");
}

#[test]
fn plot_shows_a_slice_and_its_error() {
    let out = tempdir();
    let png = out.path().join("lobe.png");
    let o = run(&[
        "plot",
        "zh_lobe",
        "--preset",
        "scene-lobe",
        "--tables",
        tables().to_str().unwrap(),
        "--out",
        png.to_str().unwrap(),
    ]);
    assert_ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    let worst: f64 = text
        .split("C_L ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|x| x.parse().ok())
        .expect("worst error printed");
    // The lookup against the zonal-harmonic sum at the slice's cell centres (measured: 1.5e-2 here).
    assert!(worst > 0.0 && worst < 0.1, "{text}");
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
}
