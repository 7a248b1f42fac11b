//! `twoscale lookup`: interpolated JSON, and bad points refused with status 2.

use crate::common;

use common::shared_tables::shared_tables;

use common::{assert_input_error, assert_ok, run};
use std::process::Output;
use twoscale_generate::tables::epd_math::g1;

fn lookup(args: &[&str]) -> Output {
    let dir = shared_tables().to_str().unwrap().to_string();
    let mut all = vec!["lookup", "--tables", dir.as_str()];
    all.extend_from_slice(args);
    run(&all)
}

#[test]
fn lookup_prints_interpolated_json() {
    let out = lookup(&["epd_g1", "--preset", "paper", "--at", "p=1", "--at", "a=0.7", "--json"]);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["table"], "epd_g1");
    let got = v["values"]["g1"].as_f64().unwrap();
    assert!((got - g1(1.0, 0.7)).abs() < 1e-3, "{got} vs {}", g1(1.0, 0.7));
    let out = lookup(&["epd_norm", "--at", "p=1", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!((v["values"]["n"].as_f64().unwrap() - 1.0 / std::f64::consts::PI).abs() < 1e-4);
    let out = lookup(&["epd_g1", "--at", "p=2", "--at", "a=inf", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["values"]["g1"].as_f64(), Some(0.0));
}

#[test]
fn lookup_rejects_bad_points_with_status_2() {
    assert_input_error(&lookup(&["epd_g1", "--at", "p=9", "--at", "a=1"]), "outside the table's domain");
    assert_input_error(&lookup(&["epd_g1", "--at", "p=NaN", "--at", "a=1"]), "NaN");
    assert_input_error(&lookup(&["epd_g1", "--at", "p=1"]), "missing --at a=VALUE");
    assert_input_error(&lookup(&["epd_g1", "--at", "p=1", "--at", "q=1"]), "unknown axis");
    assert_input_error(&lookup(&["epd_g1", "--at", "p=1", "--at", "a=x"]), "not a number");
    assert_input_error(&lookup(&["nope", "--at", "p=1"]), "unknown table");
    assert_input_error(&lookup(&["epd_g1", "--preset", "huge", "--at", "p=1"]), "unknown preset");
    // Below the paper grid's first a node (1.6e-17) is outside its domain.
    assert_input_error(&lookup(&["epd_g1", "--preset", "paper", "--at", "p=1", "--at", "a=0"]), "outside");
}
