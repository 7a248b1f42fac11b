//! Other runtimes read the tables the same way: the C reader (the checked-in
//! pipeline/tables/c/twoscale_tables.h with an exported data header) and the
//! Python reader (the package twoscale_tables, pipeline/tables/python) agree
//! with `twoscale lookup` and the Rust `Lookup`, the golden vectors hold in C,
//! and the .npy export holds the same data. Needs `make pyenv` (done by `make test`).

use crate::common;

use common::c_lookup::{c_lookup, cc, run_c_test};
use common::shared_tables::shared_tables;
use common::{python, repo_root, tempdir, BIN};
use std::collections::BTreeMap;
use std::f64::consts::FRAC_PI_2;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use twoscale_generate::accuracy::random_points;
use twoscale_generate::tables::{of_preset, Preset};
use twoscale_tables::{open_table, Lookup};

/// The build root of the reader tests (`shared_tables`): the paper preset, merl_nickel's sub-domain tables and material folders, broad_lobe's zh_lobe.
fn tables() -> &'static Path {
    shared_tables()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1.0)
}

fn cli_lookup(table: &str, names: &[String], pt: &[f64]) -> serde_json::Value {
    let mut cmd = Command::new(BIN);
    cmd.args(["lookup", table, "--preset", "paper", "--tables", tables().to_str().unwrap(), "--json"]);
    for (n, x) in names.iter().zip(pt) {
        cmd.arg("--at").arg(format!("{n}={x:e}"));
    }
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `folder` of the build root (the golden vectors' `tables`), holding `table`.
fn built(folder: &str, table: &str) -> PathBuf {
    let dir = tables().join(folder);
    assert!(dir.join(format!("{table}.h5")).is_file(), "the reader tables have no {folder}/{table}");
    dir
}

/// `twoscale export --format c-header` of `table` in `dir` into `out`: the
/// data header and the name of the table it defines (its file stem).
fn export_c(dir: &Path, table: &str, out: &Path) -> (PathBuf, String) {
    let o = Command::new(BIN)
        .args(["export", "--format", "c-header", "--table", table, "--dir"])
        .arg(dir)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let header = PathBuf::from(String::from_utf8(o.stdout).unwrap().trim());
    let prefix = header.file_stem().unwrap().to_str().unwrap().to_string();
    (header, prefix)
}

/// Within 1e-12 relative (or 1e-300 absolute), as every reader of the golden vectors.
fn agree(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs() || (a - b).abs() <= 1e-300
}

/// The C reader (the checked-in twoscale_tables.h and the exported data
/// header) agrees with the Rust reader at `points` (physical coordinates) to
/// 1e-12 relative, "outside" where it is, and with the CLI at a few points.
fn c_reader_agrees(dir: &Path, table: &str, points: &[Vec<f64>], work: &Path) {
    let rust = Lookup::open(dir, table).unwrap();
    let (header, prefix) = export_c(dir, table, work);
    let lines = c_lookup(&header, &prefix, points, work);
    let names = rust.coordinates();
    for (k, (pt, line)) in points.iter().zip(&lines).enumerate() {
        let Ok(expected) = rust.decode(pt) else {
            assert_eq!(*line, "outside", "{prefix}: {pt:?}");
            continue;
        };
        let got: Vec<f64> = line
            .split(' ')
            .map(|x| x.parse().unwrap_or_else(|_| panic!("{prefix}: C says {line:?} at {pt:?}")))
            .collect();
        assert_eq!(got.len(), expected.len(), "{prefix}: one number per output");
        for (g, e) in got.iter().zip(&expected) {
            assert!(agree(*g, *e), "{prefix}: C {g} vs Rust {e} at {pt:?}");
        }
        // And against the CLI itself, at a few points.
        if k % 80 == 0 {
            let mut cmd = Command::new(BIN);
            cmd.args(["lookup", table, "--json", "--dir"]).arg(dir);
            for (n, x) in names.iter().zip(pt) {
                cmd.arg("--at").arg(format!("{n}={x:e}"));
            }
            let out = cmd.output().unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            let cli: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            for (vname, g) in rust.outputs().iter().zip(&got) {
                let c = cli["values"][vname].as_f64().unwrap();
                assert!(agree(*g, c), "{prefix}: C {g} vs CLI {c} at {pt:?}");
            }
        }
    }
}

#[test]
fn c_header_lookups_agree_with_the_cli() {
    let work = tempdir();
    for def in of_preset(Preset::Paper) {
        let (_, axes, _) = open_table(&tables().join("paper"), def.name).unwrap();
        // Random points, the corners of the domain, and one outside.
        let mut points = random_points(&axes, 400, 11);
        points.push(axes.iter().map(|a| a.nodes[0]).collect());
        points.push(axes.iter().map(|a| a.nodes[a.len() - 1]).collect());
        let mut outside: Vec<f64> = points[0].clone();
        outside[0] = axes[0].max() * 2.0 + 1.0;
        points.push(outside);
        c_reader_agrees(&tables().join("paper"), def.name, &points, work.path());
    }
}

#[test]
fn c_header_interpolates_cubic_tables_as_the_cli() {
    // The merl_nickel scene's sub-domain epd_albedo (3 axes) and epd_albedo_avg (2): 4^N nodes a lookup.
    let work = tempdir();
    let dir = tables().join("scene-merl_nickel");
    for table in ["epd_albedo", "epd_albedo_avg"] {
        let (m, axes, _) = open_table(&dir, table).unwrap();
        assert_eq!(m.interpolation, twoscale_tables::interp::Interpolation::Cubic);
        let mut points = random_points(&axes, 300, 5);
        points.push(axes.iter().map(|a| a.min()).collect());
        points.push(axes.iter().map(|a| a.max()).collect());
        let mut outside = points[0].clone();
        outside[1] = axes[1].max() * 2.0;
        points.push(outside);
        c_reader_agrees(&dir, table, &points, work.path());
    }
}

#[test]
fn c_header_decodes_zh_lobe_control_variates_as_rust() {
    // The merl_nickel scene's sub-domain zh_lobe: ln with the four control
    // variates, theta_h derived into v_theta (anchored lobe angle).
    let dir = built("scene-merl_nickel", "zh_lobe");
    let (_, axes, _) = open_table(&dir, "zh_lobe").unwrap();
    let mut points: Vec<Vec<f64>> = random_points(&axes[..4], 400, 13)
        .into_iter()
        .enumerate()
        .map(|(k, mut p)| {
            // theta_h from 0 to pi/2, both ends included.
            p.push(FRAC_PI_2 * (k % 101) as f64 / 100.0);
            p
        })
        .collect();
    points.push(axes[..4].iter().map(|a| a.nodes[0]).chain([0.0]).collect());
    points.push(axes[..4].iter().map(|a| a.nodes[a.len() - 1]).chain([FRAC_PI_2]).collect());
    let mut outside = points[1].clone();
    outside[4] = 1.6; // theta_h beyond pi/2
    points.push(outside);
    let mut nan = points[1].clone();
    nan[2] = f64::NAN;
    points.push(nan);
    c_reader_agrees(&dir, "zh_lobe", &points, tempdir().path());
}

#[test]
fn the_c_header_compiles_alone() {
    // The checked-in lookup code with no table, with every warning an error.
    let work = tempdir();
    let src = work.path().join("bare.c");
    std::fs::write(&src, "#include \"twoscale_tables.h\"\n").unwrap();
    let out = cc().arg("-c").arg(&src).arg("-o").arg(work.path().join("bare.o")).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn c_cubic_interpolation_reproduces_cubics() {
    // tests/c/cubic.c: hand-written cubic tables (3 and 4 axes) holding polynomials of degree 3 in
    // each encoded coordinate: nodes exact, points to 1e-6, edge cells, refusals; multilinear unchanged.
    let text = run_c_test("cubic");
    assert!(text.contains(" 0 failed"), "{text}");
}

/// The golden vectors (pipeline/tables/golden/vectors.json) through the C
/// reader: the tables they name are built and exported, and tests/c/golden.c
/// checks every vector to 1e-12 relative (or 1e-300 absolute).
fn c_golden(vectors: &Path) -> String {
    let golden: serde_json::Value = serde_json::from_slice(&std::fs::read(vectors).unwrap()).unwrap();
    assert_eq!(golden["format"], "twoscale-golden/1");
    let vectors = golden["vectors"].as_array().unwrap();
    assert!(!vectors.is_empty());
    let work = tempdir();
    // Every (folder, table) once, exported into `work`; golden_tables.h lists them.
    let mut exported = BTreeMap::new();
    let mut list = String::new();
    // One line per vector: folder table n (name value)*n m (name value)*m.
    let mut input = String::new();
    for v in vectors {
        let (folder, table) = (v["tables"].as_str().unwrap(), v["table"].as_str().unwrap());
        if !exported.contains_key(&(folder, table)) {
            let (header, prefix) = export_c(&built(folder, table), table, work.path());
            let _ = writeln!(list, "#include \"{}\"", header.file_name().unwrap().to_str().unwrap());
            let _ = writeln!(list, "#define GOLDEN_{} X(\"{folder}\", {prefix})", exported.len());
            exported.insert((folder, table), prefix);
        }
        let pairs = |m: &serde_json::Value| {
            let m = m.as_object().unwrap();
            // A number, or a string such as "inf" (JSON has no infinity).
            let num = |x: &serde_json::Value| {
                x.as_f64().or_else(|| x.as_str()?.parse().ok()).unwrap_or_else(|| panic!("not a number: {x}"))
            };
            let text: String = m.iter().map(|(n, x)| format!(" {n} {:e}", num(x))).collect();
            format!("{}{text}", m.len())
        };
        let _ = writeln!(input, "{folder} {table} {} {}", pairs(&v["point"]), pairs(&v["values"]));
    }
    let all: String = (0..exported.len()).map(|i| format!(" GOLDEN_{i}")).collect();
    let _ = writeln!(list, "#define GOLDEN_TABLES{all}");
    std::fs::write(work.path().join("golden_tables.h"), list).unwrap();
    let exe = work.path().join("golden");
    let out = cc()
        .arg("-I")
        .arg(work.path())
        .args(["-include", "golden_tables.h"])
        .arg(repo_root().join("tests/c/golden.c"))
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut child = Command::new(&exe).stdin(Stdio::piped()).stdout(Stdio::piped()).spawn().unwrap();
    child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{text}");
    assert!(text.contains(&format!("checked {} vectors", vectors.len())), "{text}");
    text
}

#[test]
fn golden_vectors_hold_in_c() {
    c_golden(&repo_root().join("pipeline/tables/golden/vectors.json"));
}

#[test]
fn python_reader_agrees_with_the_cli_and_checks_checksums() {
    let py = python();
    for def in of_preset(Preset::Paper) {
        let h5 = tables().join("paper").join(format!("{}.h5", def.name));
        let (_, axes, _) = open_table(&tables().join("paper"), def.name).unwrap();
        let names: Vec<String> = axes.iter().map(|a| a.name.clone()).collect();
        for pt in random_points(&axes, 6, 23) {
            let mut cmd = Command::new(&py);
            cmd.args(["-m", "twoscale_tables", "lookup"]).arg(&h5);
            for (n, x) in names.iter().zip(&pt) {
                cmd.arg(format!("{n}={x:e}"));
            }
            let out = cmd.output().unwrap();
            assert!(out.status.success(), "{}: {}", def.name, String::from_utf8_lossy(&out.stderr));
            let got: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            let cli = cli_lookup(def.name, &names, &pt);
            assert_eq!(got["table"], cli["table"]);
            for (vname, c) in cli["values"].as_object().unwrap() {
                let (g, c) = (got["values"][vname].as_f64().unwrap(), c.as_f64().unwrap());
                assert!(close(g, c), "{}: Python {g} vs CLI {c} at {pt:?}", def.name);
            }
        }
    }
    // A corrupted value is caught by the checksum check (exit 1); a bad point is exit 2.
    let work = tempdir();
    for f in ["epd_norm.h5", "epd_norm.manifest.json"] {
        std::fs::copy(tables().join("paper").join(f), work.path().join(f)).unwrap();
    }
    let h5 = work.path().join("epd_norm.h5");
    let run = |args: &[&str]| {
        Command::new(&py).args(["-m", "twoscale_tables", "lookup"]).arg(&h5).args(args).output().unwrap()
    };
    assert_eq!(run(&["p=9"]).status.code(), Some(2));
    let mut bytes = std::fs::read(&h5).unwrap();
    let n = bytes.len();
    bytes[n - 100] ^= 0x40;
    std::fs::write(&h5, &bytes).unwrap();
    let out = run(&["p=1"]);
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("checksum"));
}

/// The Python package decodes as the Rust `Lookup`: zh_lobe with control
/// variates (two scene sub-domains, one where every term carries weight), a
/// material's zh_lobe (plain ln, material lobe angle) and a sub-domain epd_g1
/// (a reaching inf), and the cubic sub-domain epd_albedo and epd_albedo_avg, at random points over every stored axis (a derived axis:
/// its coordinate's range), through `lookup_arrays` in one process; the same
/// outputs (no control-variate values), each within 1e-12 relative.
#[test]
fn python_reader_decodes_as_the_rust_lookup() {
    let code = "import sys, json, numpy as np\n\
                from twoscale_tables import Table\n\
                a = json.load(sys.stdin); t = Table.open(a['file'])\n\
                out = t.lookup_arrays({k: np.array(v, dtype=float) for k, v in a['coords'].items()})\n\
                print(json.dumps({'outputs': t.outputs(), 'values': [out[n].tolist() for n in t.outputs()]}))";
    let cases = [
        ("scene-merl_nickel", "zh_lobe"),
        ("scene-broad_lobe", "zh_lobe"),
        ("scene-merl_nickel/nickel", "zh_lobe"),
        ("scene-merl_nickel", "epd_g1"),
        ("scene-merl_nickel", "epd_albedo"),
        ("scene-merl_nickel", "epd_albedo_avg"),
    ];
    for (folder, table) in cases {
        let dir = tables().join(folder);
        let lookup = Lookup::open(&dir, table).unwrap();
        let names = lookup.coordinates();
        let mut points: Vec<Vec<f64>> = random_points(&lookup.axes, 300, 17)
            .into_iter()
            .map(|pt| {
                pt.iter()
                    .zip(&lookup.axes)
                    .map(|(&x, axis)| {
                        lookup
                            .derived_axes
                            .iter()
                            .find(|d| d.axis == axis.name)
                            .map_or(x, |d| d.min + (d.max - d.min) * x)
                    })
                    .collect()
            })
            .collect();
        points.push(lookup.axes.iter().map(|a| a.min()).collect());
        points.push(
            lookup
                .axes
                .iter()
                .zip(&names)
                .map(|(a, n)| if n == "theta_h" { std::f64::consts::FRAC_PI_2 } else { a.max() })
                .collect(),
        );
        let rust: Vec<Vec<f64>> = points.iter().map(|pt| lookup.decode(pt).unwrap()).collect();
        let coords: serde_json::Map<String, serde_json::Value> = names
            .iter()
            .enumerate()
            .map(|(i, n)| {
                (
                    n.clone(),
                    points
                        .iter()
                        .map(|p| if p[i] == f64::INFINITY { serde_json::json!("inf") } else { serde_json::json!(p[i]) })
                        .collect(),
                )
            })
            .collect();
        let input = serde_json::json!({"file": dir.join(format!("{table}.h5")), "coords": coords}).to_string();
        let mut child = Command::new(python())
            .args(["-c", code])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success(), "{folder}/{table}: {}", String::from_utf8_lossy(&out.stderr));
        let got: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(got["outputs"], serde_json::json!(lookup.outputs()), "{folder}/{table}");
        for (v, column) in got["values"].as_array().unwrap().iter().enumerate() {
            for (k, p) in column.as_array().unwrap().iter().enumerate() {
                let (p, r) = (p.as_f64().unwrap(), rust[k][v]);
                assert!(
                    (p - r).abs() <= (1e-12 * r.abs()).max(1e-300),
                    "{folder}/{table}: Python {p} vs Rust {r} at {:?}",
                    points[k]
                );
            }
        }
    }
}

#[test]
fn npy_export_holds_the_same_data() {
    let work = tempdir();
    let def = "zh_convolution";
    let out = Command::new(BIN)
        .args(["export", "--format", "npy", "--table", def, "--preset", "paper"])
        .args(["--tables", tables().to_str().unwrap(), "--out", work.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (manifest, _, _) = open_table(&tables().join("paper"), def).unwrap();
    // numpy reads each file; the canonical SHA-256 of what it reads matches the manifest.
    for (name, sum) in manifest.data_checksums() {
        let (kind, short) = name.split_once('/').unwrap();
        let file = work.path().join(format!("{def}.{}.{short}.npy", if kind == "axes" { "axis" } else { "value" }));
        let code = "import sys, hashlib, numpy as np; a = np.load(sys.argv[1]); \
                    print(hashlib.sha256(np.ascontiguousarray(a, dtype=a.dtype.newbyteorder('<')).tobytes()).hexdigest())";
        let out = Command::new(python()).args(["-c", code]).arg(&file).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), sum, "{name}");
    }
}
