//! Other runtimes read the tables the same way: the exported C header and the
//! Python reader (the package twoscale_tables, pipeline/contract/python) agree
//! with `twoscale lookup` and the Rust `Lookup`, and the .npy export holds the
//! same data. Needs `make pyenv` (done by `make test`).

mod common;

use common::c_lookup::c_lookup;
use common::reader_tables::reader_tables;
use common::{assert_ok, python, tempdir, BIN};
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use twoscale::accuracy::random_points;
use twoscale_tables::open_table;
use twoscale_tables::interp::interpolate;
use twoscale_tables::lookup::Lookup;
use twoscale::tables::{of_preset, Preset};

/// The directory holding the paper preset (and the scene tables of `reader_tables`).
fn tables() -> &'static Path {
    reader_tables()
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
    assert_ok(&out);
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn c_header_lookups_agree_with_the_cli() {
    let work = tempdir();
    for def in of_preset(Preset::Paper) {
        let (_, axes, values) = open_table(&tables().join("paper"), def.name).unwrap();
        let out = Command::new(BIN)
            .args(["export", "--format", "c-header", "--table", def.name, "--preset", "paper"])
            .args(["--tables", tables().to_str().unwrap(), "--out", work.path().to_str().unwrap()])
            .output()
            .unwrap();
        assert_ok(&out);
        let prefix = format!("twoscale_{}_paper", def.name);
        // Random points, the corners of the domain, and one outside.
        let mut points = random_points(&axes, 400, 11);
        points.push(axes.iter().map(|a| a.nodes[0]).collect());
        points.push(axes.iter().map(|a| a.nodes[a.len() - 1]).collect());
        let mut outside: Vec<f64> = points[0].clone();
        outside[0] = axes[0].max() * 2.0 + 1.0;
        points.push(outside);
        let lines = c_lookup(&work.path().join(format!("{prefix}.h")), &prefix, axes.len(), values.len(), &points, work.path());
        let names: Vec<String> = axes.iter().map(|a| a.name.clone()).collect();
        for (k, (pt, line)) in points.iter().zip(&lines).enumerate() {
            let expected: Option<Vec<f64>> =
                values.iter().map(|(_, v)| interpolate(&axes, &v.view(), pt).ok()).collect();
            match expected {
                None => assert_eq!(*line, "outside", "{}: {pt:?}", def.name),
                Some(exp) => {
                    let got: Vec<f64> = line.split(' ').map(|x| x.parse().unwrap()).collect();
                    for (g, e) in got.iter().zip(&exp) {
                        assert!(close(*g, *e), "{}: C {g} vs library {e} at {pt:?}", def.name);
                    }
                    // And against the CLI itself, at a few points.
                    if k % 80 == 0 {
                        let cli = cli_lookup(def.name, &names, pt);
                        for ((vname, _), g) in values.iter().zip(&got) {
                            let c = cli["values"][vname].as_f64().unwrap();
                            assert!(close(*g, c), "{}: C {g} vs CLI {c} at {pt:?}", def.name);
                        }
                    }
                }
            }
        }
    }
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
    let run = |args: &[&str]| Command::new(&py).args(["-m", "twoscale_tables", "lookup"]).arg(&h5).args(args).output().unwrap();
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
/// (a reaching inf), at random points over every stored axis (a derived axis:
/// its coordinate's range), through `lookup_arrays` in one process; the same
/// outputs (no control-variate values), each within 1e-12 relative.
#[test]
fn python_reader_decodes_as_the_rust_lookup() {
    let code = "import sys, json, numpy as np\n\
                from twoscale_tables import Table\n\
                a = json.load(sys.stdin); t = Table.open(a['file'])\n\
                out = t.lookup_arrays({k: np.array(v, dtype=float) for k, v in a['coords'].items()})\n\
                print(json.dumps({'outputs': t.outputs(), 'values': [out[n].tolist() for n in t.outputs()]}))";
    for (folder, table) in [("scene-merl_nickel", "zh_lobe"), ("scene-broad_lobe", "zh_lobe"), ("scene-merl_nickel/nickel", "zh_lobe"), ("scene-merl_nickel", "epd_g1")] {
        let dir = tables().join(folder);
        let lookup = Lookup::open(&dir, table).unwrap();
        let names = lookup.coordinates();
        let mut points: Vec<Vec<f64>> = random_points(&lookup.axes, 300, 17)
            .into_iter()
            .map(|pt| {
                pt.iter()
                    .zip(&lookup.axes)
                    .map(|(&x, axis)| lookup.derived_axes.iter().find(|d| d.axis == axis.name).map_or(x, |d| d.min + (d.max - d.min) * x))
                    .collect()
            })
            .collect();
        points.push(lookup.axes.iter().map(|a| a.min()).collect());
        points.push(lookup.axes.iter().zip(&names).map(|(a, n)| if n == "theta_h" { std::f64::consts::FRAC_PI_2 } else { a.max() }).collect());
        let rust: Vec<Vec<f64>> = points.iter().map(|pt| lookup.decode(pt).unwrap()).collect();
        let coords: serde_json::Map<String, serde_json::Value> = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), points.iter().map(|p| if p[i] == f64::INFINITY { serde_json::json!("inf") } else { serde_json::json!(p[i]) }).collect()))
            .collect();
        let input = serde_json::json!({"file": dir.join(format!("{table}.h5")), "coords": coords}).to_string();
        let mut child = Command::new(python()).args(["-c", code]).stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success(), "{folder}/{table}: {}", String::from_utf8_lossy(&out.stderr));
        let got: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(got["outputs"], serde_json::json!(lookup.outputs()), "{folder}/{table}");
        for (v, column) in got["values"].as_array().unwrap().iter().enumerate() {
            for (k, p) in column.as_array().unwrap().iter().enumerate() {
                let (p, r) = (p.as_f64().unwrap(), rust[k][v]);
                assert!((p - r).abs() <= (1e-12 * r.abs()).max(1e-300), "{folder}/{table}: Python {p} vs Rust {r} at {:?}", points[k]);
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
    assert_ok(&out);
    let (manifest, _, _) = open_table(&tables().join("paper"), def).unwrap();
    // numpy reads each file; the canonical SHA-256 of what it reads matches the manifest.
    for (name, sum) in manifest.data_checksums() {
        let (kind, short) = name.split_once('/').unwrap();
        let file = work.path().join(format!("{def}.{}.{short}.npy", if kind == "axes" { "axis" } else { "value" }));
        let code = "import sys, hashlib, numpy as np; a = np.load(sys.argv[1]); \
                    print(hashlib.sha256(np.ascontiguousarray(a, dtype=a.dtype.newbyteorder('<')).tobytes()).hexdigest())";
        let out = Command::new(python()).args(["-c", code]).arg(&file).output().unwrap();
        assert_ok(&out);
        assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), sum, "{name}");
    }
}
