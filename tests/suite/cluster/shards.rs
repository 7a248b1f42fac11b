//! Sharded builds through the `twoscale` binary: shards built in any order, in parallel processes,
//! merge to the single build's table (data, file, accuracy) for several N and every table of a
//! scene's sub-domain; finished shards are not rebuilt; every bad shard (missing, duplicated,
//! corrupt, foreign) is one line naming it, and nothing is written.

use crate::common;

use common::shared_tables::{shared_tables, SCENE_TABLES};
use common::{assert_ok, example_scene, ok, read_manifest, run, tempdir, BIN};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Merged and single-build manifests agree on everything but the timing.
fn assert_same_table(merged: &Path, single: &Path, table: &str) {
    let (m, s) = (
        read_manifest(&merged.join(format!("{table}.manifest.json"))),
        read_manifest(&single.join(format!("{table}.manifest.json"))),
    );
    assert_eq!(m.data_checksums(), s.data_checksums(), "{table}: data checksums");
    assert_eq!(m.file, s.file, "{table}: file");
    assert_eq!(
        (&m.accuracy, &m.settings, &m.inputs),
        (&s.accuracy, &s.settings, &s.inputs),
        "{table}: accuracy, settings, inputs"
    );
}

#[test]
fn shards_in_any_order_and_in_parallel_merge_to_the_single_build() {
    let dir = tempdir();
    let d = |name: &str| dir.path().join(name).display().to_string();
    let scene = example_scene("merl_nickel.toml");
    let scene = scene.to_str().unwrap();
    // The single builds: the shared root's merl_nickel sub-domain (every default table: zh_convolution
    // with its fits and error budget, zh_lobe, the cubic epd_albedo) and its paper epd_g1. A scene
    // build with --shard and no --table shards every one of them.
    let single = shared_tables();

    // N = 4 in parallel processes, started in a shuffled order.
    let children: Vec<_> = [2, 0, 3, 1]
        .iter()
        .map(|k| {
            Command::new(BIN)
                .args([
                    "build",
                    "--quiet",
                    "--threads",
                    "1",
                    "--scene",
                    scene,
                    "--out",
                    &d("four"),
                    "--shard",
                    &format!("{k}/4"),
                ])
                .spawn()
                .unwrap()
        })
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    ok(run(&["merge", &d("four"), "--preset", "scene-merl_nickel", "--quiet"]));
    // N = 7 (more shards than some tables' p nodes), one after the other, last first.
    let out = d("n7");
    for k in (0..7).rev() {
        ok(run(&["build", "--quiet", "--scene", scene, "--out", &out, "--shard", &format!("{k}/7")]));
    }
    ok(run(&["merge", &out, "--preset", "scene-merl_nickel", "--quiet"]));
    for name in ["four", "n7"] {
        for table in SCENE_TABLES {
            assert_same_table(
                &dir.path().join(name).join("scene-merl_nickel"),
                &single.join("scene-merl_nickel"),
                table,
            );
        }
    }
    // Paper epd_g1 in 5 parts, and in 1 (N = 1: a table's whole domain in one shard).
    for (n, order) in [(5, &[4, 1, 3, 0, 2][..]), (1, &[0][..])] {
        let out = d(&format!("paper{n}"));
        for k in order {
            let shard = format!("{k}/{n}");
            ok(run(&["build", "--quiet", "--preset", "paper", "--table", "epd_g1", "--out", &out, "--shard", &shard]));
        }
        ok(run(&["merge", &out, "--preset", "paper", "--table", "epd_g1", "--quiet"]));
        assert_same_table(&dir.path().join(format!("paper{n}/paper")), &single.join("paper"), "epd_g1");
        let m = read_manifest(&dir.path().join(format!("paper{n}/paper/epd_g1.manifest.json")));
        assert_eq!(m.timing["shards"]["count"], n);
    }
}

#[test]
fn a_finished_shard_is_not_recomputed_and_merge_keeps_an_up_to_date_table() {
    let dir = tempdir();
    let out = dir.path().to_str().unwrap();
    let shard = |k: usize, force: bool| {
        let mut args = vec!["build", "--preset", "paper", "--table", "epd_norm", "--out", out];
        let part = format!("{k}/2");
        args.extend(["--shard", &part]);
        if force {
            args.push("--force");
        }
        ok(run(&args))
    };
    assert!(shard(0, false).contains("building"));
    let json = dir.path().join("paper/shards/epd_norm.shard-0-of-2.json");
    let before = std::fs::read_to_string(&json).unwrap();
    let again = shard(0, false);
    assert!(again.contains("up to date") && !again.contains("building"), "{again}");
    assert_eq!(std::fs::read_to_string(&json).unwrap(), before);
    assert!(shard(0, true).contains("building"));
    shard(1, false);
    assert!(ok(run(&["merge", out, "--preset", "paper"])).contains("merging"));
    let second = ok(run(&["merge", out, "--preset", "paper"]));
    assert!(second.contains("up to date") && !second.contains("merging"), "{second}");
}

/// A fresh set of 3 shards of paper epd_norm in `out`.
fn three_shards(out: &Path) -> PathBuf {
    for k in 0..3 {
        ok(run(&[
            "build",
            "--quiet",
            "--preset",
            "paper",
            "--table",
            "epd_norm",
            "--out",
            out.to_str().unwrap(),
            "--shard",
            &format!("{k}/3"),
        ]));
    }
    out.join("paper/shards")
}

#[test]
fn every_bad_shard_is_one_line_naming_it_and_nothing_is_written() {
    type Spoil = fn(&Path, &Path);
    let cases: Vec<(&str, &str, Spoil)> = vec![
        ("missing", "shard 2/3 of epd_norm", |s, _| {
            std::fs::remove_file(s.join("epd_norm.shard-2-of-3.json")).unwrap()
        }),
        ("is a duplicate", "shard 2/3 of epd_norm", |s, _| {
            std::fs::copy(s.join("epd_norm.shard-1-of-3.json"), s.join("epd_norm.shard-2-of-3.json")).unwrap();
        }),
        ("is corrupt", "shard 0/3 of epd_norm", |s, _| {
            let h5 = s.join("epd_norm.shard-0-of-3.h5");
            let mut bytes = std::fs::read(&h5).unwrap();
            let n = bytes.len();
            bytes[n - 100] ^= 0xff;
            std::fs::write(h5, bytes).unwrap();
        }),
        ("is corrupt", "shard 1/3 of epd_norm", |s, _| {
            std::fs::write(s.join("epd_norm.shard-1-of-3.json"), "{ truncated").unwrap()
        }),
        ("is corrupt", "shard 1/3 of epd_norm", |s, _| {
            // A manifest whose column checksum is not the data's.
            let path = s.join("epd_norm.shard-1-of-3.json");
            let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
            v["columns"][0]["sha256"] = serde_json::json!("0".repeat(64));
            std::fs::write(path, serde_json::to_string(&v).unwrap()).unwrap();
        }),
        ("is foreign: the other shards of epd_norm are parts of 3", "shard 1/4 of epd_norm", |_, out| {
            ok(run(&[
                "build",
                "--quiet",
                "--preset",
                "paper",
                "--table",
                "epd_norm",
                "--out",
                out.to_str().unwrap(),
                "--shard",
                "1/4",
            ]));
        }),
        ("is foreign: built by another generator", "shard 2/3 of epd_norm", |s, _| {
            let path = s.join("epd_norm.shard-2-of-3.json");
            let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
            v["inputs"]["what"]["generator"]["executable_sha256"] = serde_json::json!("0".repeat(64));
            std::fs::write(path, serde_json::to_string(&v).unwrap()).unwrap();
        }),
        ("is foreign: other inputs than shard 0/3", "shard 1/3 of epd_norm", |s, _| {
            let path = s.join("epd_norm.shard-1-of-3.json");
            let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
            v["inputs"]["sha256"] = serde_json::json!("0".repeat(64));
            v["inputs"]["what"]["degree"] = serde_json::json!(50);
            std::fs::write(path, serde_json::to_string(&v).unwrap()).unwrap();
        }),
        ("is foreign: it belongs to default, not paper", "shard 0/3 of epd_norm", |s, out| {
            let o = out.to_str().unwrap();
            ok(run(&["build", "--quiet", "--preset", "default", "--table", "epd_norm", "--out", o, "--shard", "0/3"]));
            std::fs::copy(out.join("default/shards/epd_norm.shard-0-of-3.json"), s.join("epd_norm.shard-0-of-3.json"))
                .unwrap();
            std::fs::copy(out.join("default/shards/epd_norm.shard-0-of-3.h5"), s.join("epd_norm.shard-0-of-3.h5"))
                .unwrap();
        }),
    ];
    for (what, names, spoil) in cases {
        let dir = tempdir();
        let shards = three_shards(dir.path());
        spoil(&shards, dir.path());
        let out = run(&["merge", dir.path().to_str().unwrap(), "--preset", "paper"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{what}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{what}: {err}");
        assert!(err.contains(what) && err.contains(names) && err.contains(".json"), "{what}: {err}");
        let written: Vec<_> =
            std::fs::read_dir(dir.path().join("paper")).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(written, ["shards"], "{what}: something was written");
    }
    // No shards at all, and a bad part.
    let dir = tempdir();
    let out = run(&["merge", dir.path().to_str().unwrap(), "--preset", "paper"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("no shards to merge"));
    for bad in ["3/3", "1/0", "-1/2", "1", "a/b"] {
        let out = run(&["build", "--table", "epd_norm", "--out", dir.path().to_str().unwrap(), "--shard", bad]);
        assert_eq!(out.status.code(), Some(2), "--shard {bad}");
    }
}

#[test]
fn plan_estimates_the_time_per_shard() {
    let plan = |n: &str| {
        let out = Command::new(BIN).args(["plan", "--preset", "default", "--json", "--shards", n]).output().unwrap();
        assert_ok(&out);
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let (one, eight) = (plan("1"), plan("8"));
    for (a, b) in one["tables"].as_array().unwrap().iter().zip(eight["tables"].as_array().unwrap()) {
        let total = a["estimated_seconds"].as_f64().unwrap();
        let (t1, t8) =
            (a["estimated_seconds_per_shard"].as_f64().unwrap(), b["estimated_seconds_per_shard"].as_f64().unwrap());
        assert_eq!(t1, total, "{}", a["table"]);
        assert!(t8 >= total / 8.0 && t8 < total, "{}: {t8} of {total}", a["table"]);
    }
}
