//! The golden vectors (pipeline/tables/golden/vectors.json, made by
//! pipeline/tables/golden/make.sh from points.json): on tables built by this
//! code (tests/suite/common/shared_tables.rs, the build make.sh runs), `twoscale
//! lookup --json`, the Rust `Lookup` and the Python package reproduce every
//! vector within the file's tolerance (1e-12 relative, or 1e-300 absolute).
//! The vectors cover every table of the build root, every axis encoding of the
//! contract, both derived-axis kinds and both value decodings (plain ln, ln
//! with control variates), at nodes, inside cells and at domain edges. The
//! Python part also runs the package's own checks
//! (pipeline/tables/python/tests/test_reader.py). Needs `make pyenv` (done
//! by `make test`).

use crate::common;

use common::shared_tables::{shared_tables, FOLDERS};
use common::{repo_root, BIN};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use twoscale_tables::file::read_manifest;
use twoscale_tables::lookup::Lookup;

fn golden_dir() -> PathBuf {
    repo_root().join("pipeline/tables/golden")
}

fn read_json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One vector: the folder under the build root, the table, the point (physical coordinates) and the values.
struct Vector {
    tables: String,
    table: String,
    point: BTreeMap<String, f64>,
    values: BTreeMap<String, f64>,
}

impl Vector {
    fn name(&self) -> String {
        format!("{}/{} at {:?}", self.tables, self.table, self.point)
    }
}

/// A coordinate of a point: a number, or "inf".
fn coordinate(x: &Value) -> f64 {
    match x {
        Value::String(s) if s == "inf" => f64::INFINITY,
        _ => x.as_f64().expect("a number or \"inf\""),
    }
}

fn vectors() -> Vec<Vector> {
    let golden = read_json(&golden_dir().join("vectors.json"));
    assert_eq!(golden["format"], "twoscale-golden/1");
    assert_eq!(golden["tolerance"], serde_json::json!({"relative": 1e-12, "absolute": 1e-300}));
    golden["vectors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| Vector {
            tables: v["tables"].as_str().unwrap().into(),
            table: v["table"].as_str().unwrap().into(),
            point: v["point"].as_object().unwrap().iter().map(|(k, x)| (k.clone(), coordinate(x))).collect(),
            values: v["values"].as_object().unwrap().iter().map(|(k, x)| (k.clone(), x.as_f64().unwrap())).collect(),
        })
        .collect()
}

fn within(got: f64, want: f64) -> bool {
    (got - want).abs() <= (1e-12 * want.abs()).max(1e-300)
}

/// The failures of `got` against the vector's values.
fn compare(v: &Vector, got: &BTreeMap<String, f64>, reader: &str) -> Vec<String> {
    if got.keys().ne(v.values.keys()) {
        return vec![format!("{reader}: {}: values {:?}, expected {:?}", v.name(), got.keys(), v.values.keys())];
    }
    v.values
        .iter()
        .filter(|(k, want)| !within(got[*k], **want))
        .map(|(k, want)| format!("{reader}: {}: {k} = {:e}, expected {want:e}", v.name(), got[k]))
        .collect()
}

#[test]
fn the_cli_reproduces_every_vector() {
    let root = shared_tables();
    let mut failures = Vec::new();
    for v in vectors() {
        let mut cmd = Command::new(BIN);
        cmd.args(["lookup", "--json", "--dir"]).arg(root.join(&v.tables)).arg(&v.table);
        for (n, x) in &v.point {
            cmd.arg("--at").arg(format!("{n}={x:?}")); // shortest round trip, or inf
        }
        let out = cmd.output().unwrap();
        assert!(out.status.success(), "{}: {}", v.name(), String::from_utf8_lossy(&out.stderr));
        let printed: Value = serde_json::from_slice(&out.stdout).unwrap();
        let got =
            printed["values"].as_object().unwrap().iter().map(|(k, x)| (k.clone(), x.as_f64().unwrap())).collect();
        failures.extend(compare(&v, &got, "CLI"));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_rust_lookup_reproduces_every_vector() {
    let root = shared_tables();
    let mut tables: BTreeMap<(String, String), Lookup> = BTreeMap::new();
    let mut failures = Vec::new();
    for v in vectors() {
        let lookup = tables
            .entry((v.tables.clone(), v.table.clone()))
            .or_insert_with(|| Lookup::open(&root.join(&v.tables), &v.table).unwrap());
        let names = lookup.coordinates();
        assert_eq!(names.iter().collect::<BTreeSet<_>>(), v.point.keys().collect::<BTreeSet<_>>(), "{}", v.name());
        let point: Vec<f64> = names.iter().map(|n| v.point[n]).collect();
        let got = lookup.at(&point).unwrap_or_else(|e| panic!("{}: {e}", v.name())).into_iter().collect();
        failures.extend(compare(&v, &got, "Rust Lookup"));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_python_package_reproduces_every_vector() {
    let root = repo_root();
    let py = common::python();
    assert!(py.exists(), "{} is missing: run `make pyenv` (done by `make test`)", py.display());
    // The package must be this checkout's (an editable install by `make pyenv`).
    let out = Command::new(&py)
        .args(["-c", "import twoscale_tables, os; print(os.path.realpath(twoscale_tables.__file__))"])
        .output()
        .unwrap();
    let from = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let here = root.join("pipeline/tables/python/twoscale_tables/__init__.py").canonicalize().unwrap();
    assert!(
        out.status.success() && Path::new(&from) == here,
        "twoscale_tables is not this checkout's ({from:?}; {}): run `make pyenv`",
        String::from_utf8_lossy(&out.stderr).trim()
    );
    // The vectors (test_golden.py), then the package's own checks (test_reader.py) on the same tables.
    let (tables, vectors) = (shared_tables(), golden_dir().join("vectors.json"));
    let args = ["--build-root".as_ref(), tables.as_os_str(), "--vectors".as_ref(), vectors.as_os_str()];
    common::pytest("pipeline/tables/python/tests", &args, 24);
}

/// Every axis encoding of the contract (`AxisEncoding`'s kinds).
const ENCODINGS: [&str; 12] = [
    "linear",
    "log",
    "reciprocal",
    "exp_neg_power",
    "bounded_log",
    "shifted_reciprocal",
    "shifted_log",
    "log_gap",
    "log_plus_log_log1p_sq",
    "log1p_sq",
    "bounded_log_tan",
    "asin_sqrt",
];

#[test]
fn the_vectors_are_the_points_and_cover_every_table_encoding_and_decoding() {
    let vectors = vectors();
    let points = read_json(&golden_dir().join("points.json"));
    let points = points["points"].as_array().unwrap();
    assert_eq!(
        points.len(),
        vectors.len(),
        "vectors.json is not made from points.json: run pipeline/tables/golden/make.sh"
    );
    for (p, v) in points.iter().zip(&vectors) {
        let point: BTreeMap<String, f64> =
            p["point"].as_object().unwrap().iter().map(|(k, x)| (k.clone(), coordinate(x))).collect();
        assert!(
            p["tables"] == v.tables.as_str() && p["table"] == v.table.as_str() && point == v.point,
            "{} is not in points.json's order: run make.sh",
            v.name()
        );
    }
    let root = shared_tables();
    let (mut encodings, mut derived, mut decodings) = (BTreeSet::new(), BTreeSet::new(), BTreeSet::new());
    for folder in FOLDERS {
        let mut names: Vec<String> = std::fs::read_dir(root.join(folder))
            .unwrap()
            .filter_map(|e| {
                e.unwrap().file_name().into_string().unwrap().strip_suffix(".manifest.json").map(str::to_string)
            })
            .collect();
        names.sort();
        for table in names {
            let mine: Vec<&Vector> = vectors.iter().filter(|v| v.tables == folder && v.table == table).collect();
            assert!(
                !mine.is_empty(),
                "no golden vector for {folder}/{table}: add points to points.json and run make.sh"
            );
            let lookup = Lookup::open(&root.join(folder), &table).unwrap();
            let manifest = read_manifest(&root.join(folder), &table).unwrap();
            // Each coordinate's range (a derived axis: its physical coordinate's) and nodes.
            let ranges: Vec<(String, f64, f64, &[f64])> = lookup
                .coordinates()
                .into_iter()
                .zip(&lookup.axes)
                .map(|(name, axis)| match lookup.derived_axes.iter().find(|d| d.axis == axis.name) {
                    Some(d) => (name, d.min, d.max, &[][..]),
                    None => (name, axis.min(), axis.max(), &axis.nodes[..]),
                })
                .collect();
            let at_edge = |v: &Vector| ranges.iter().any(|(n, lo, hi, _)| v.point[n] == *lo || v.point[n] == *hi);
            let inside = |v: &Vector| {
                ranges
                    .iter()
                    .any(|(n, lo, hi, nodes)| v.point[n] > *lo && v.point[n] < *hi && !nodes.contains(&v.point[n]))
            };
            assert!(mine.iter().any(|v| at_edge(v)), "{folder}/{table}: no vector at a domain edge");
            assert!(mine.iter().any(|v| inside(v)), "{folder}/{table}: no vector inside a cell");
            for (n, _, hi, _) in &ranges {
                if *hi == f64::INFINITY {
                    assert!(
                        mine.iter().any(|v| v.point[n] == f64::INFINITY),
                        "{folder}/{table}: {n} reaches inf, no vector there"
                    );
                }
            }
            for axis in &manifest.axes {
                let tagged = serde_json::to_value(axis.encoding).unwrap();
                encodings.insert(tagged["kind"].as_str().unwrap().to_string());
            }
            for d in &manifest.derived_axes {
                derived.insert(serde_json::to_value(d).unwrap()["kind"].as_str().unwrap().to_string());
            }
            for e in &manifest.value_encoding {
                decodings.insert(if e.control_variates.is_empty() { "ln" } else { "ln with control variates" });
            }
            if manifest.value_encoding.is_empty() {
                decodings.insert("plain");
            }
        }
    }
    assert_eq!(
        encodings,
        ENCODINGS.iter().map(|s| s.to_string()).collect::<BTreeSet<_>>(),
        "axis encodings of the golden tables"
    );
    assert_eq!(
        derived,
        ["anchored_lobe_angle", "material_lobe_angle"].iter().map(|s| s.to_string()).collect::<BTreeSet<_>>()
    );
    assert_eq!(decodings, ["ln", "ln with control variates", "plain"].into_iter().collect::<BTreeSet<_>>());
}
