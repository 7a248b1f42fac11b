//! Corrupt table files and manifests (the paper preset, a scene's tables and
//! one of its material folders), run through every reader: `verify`,
//! `lookup`, `export` (C header and .npy) and the Python reader. A reader may
//! refuse (one line on stderr, a non-zero exit status, no file written) or
//! succeed with exactly the intact table's output; it never ends by a signal
//! and never hangs. The fixture of a file that crashed HDF5
//! (tests/fixtures/corrupt-epd_g1) is always one of the cases, and must be
//! refused with exit status 1 by every reader.
//!
//! TWOSCALE_FUZZ_SEED (default 1) and TWOSCALE_FUZZ_CASES (default 320) vary
//! the run; the counts are printed (`cargo test --release --test suite verify::fuzz -- --nocapture`).
//! Signed bundles, flipped anywhere in the bundle or its signature: `verify::signature`.
//! The RGL-EPFL reader of `twoscale fit` (twoscale_fit::rgl), on corrupt copies of a measured file:
//! `corrupt_rgl_files_are_refused_cleanly_or_read`.

use crate::common;

use common::shared_tables::shared_tables;
use common::{python, repo_root, tempdir, BIN};
use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_tables::lookup::Lookup;

/// A reader that has not answered after this long hangs.
const TIMEOUT: Duration = Duration::from_secs(10);

/// How a process ended.
#[derive(Debug)]
enum Ending {
    Exit(i32, String, String),
    Signal(i32),
    Hang,
}

fn run(cmd: &mut Command) -> Ending {
    use std::os::unix::process::ExitStatusExt;
    let out_dir = tempdir();
    let (out, err) = (out_dir.path().join("out"), out_dir.path().join("err"));
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Ending::Hang;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let read = |p: &Path| String::from_utf8_lossy(&std::fs::read(p).unwrap()).into_owned();
    match status.code() {
        Some(code) => Ending::Exit(code, read(&out), read(&err)),
        None => Ending::Signal(status.signal().unwrap_or(0)),
    }
}

/// One table of a built directory: where it is, and a point inside its domain.
struct Target {
    /// `paper`, `scene-<name>` or `scene-<name>/<material>`: the folder under the output root.
    preset: String,
    table: String,
    point: Vec<(String, f64)>,
}

/// What every reader prints for the intact table.
struct Intact {
    lookup: String,
    python: String,
    npy: Vec<(String, Vec<u8>)>,
    header: String,
}

/// The command-line readers, run on the table `t` of `root/<preset>/`, exports into `out`.
fn readers(root: &Path, t: &Target, out: &Path) -> Vec<(&'static str, Command)> {
    let dir = root.join(&t.preset);
    let mut verify = Command::new(BIN);
    verify.arg("verify").arg(&dir);
    let mut lookup = Command::new(BIN);
    lookup.args(["lookup", &t.table, "--json", "--dir"]).arg(&dir);
    for a in at(t) {
        lookup.arg("--at").arg(a);
    }
    let export = |format: &str, sub: &str| {
        let mut c = Command::new(BIN);
        c.args(["export", "--format", format, "--table", &t.table, "--dir"]).arg(&dir);
        c.arg("--out").arg(out.join(sub));
        c
    };
    vec![
        ("verify", verify),
        ("lookup", lookup),
        ("export-npy", export("npy", "npy")),
        ("export-c", export("c-header", "c")),
    ]
}

fn at(t: &Target) -> Vec<String> {
    t.point.iter().map(|(n, x)| format!("{n}={x:e}")).collect()
}

/// The Python reader's `python -m twoscale_tables lookup FILE.h5 NAME=VALUE...`
/// on each (root, table), every one in its own process forked from one
/// interpreter (tests/fuzz/python_reader.py), so that numpy and h5py load once.
fn python_reader(cases: &[(PathBuf, &Target)]) -> Vec<Ending> {
    let mut child = Command::new(python())
        .arg(repo_root().join("tests/fuzz/python_reader.py"))
        .arg(TIMEOUT.as_secs().to_string())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let input: String = cases
        .iter()
        .map(|(root, t)| {
            let file = root.join(&t.preset).join(format!("{}.h5", t.table));
            let args: Vec<String> =
                ["lookup".to_string(), file.to_str().unwrap().to_string()].into_iter().chain(at(t)).collect();
            serde_json::to_string(&args).unwrap() + "\n"
        })
        .collect();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || std::io::Write::write_all(&mut stdin, input.as_bytes()).unwrap());
    let output = child.wait_with_output().unwrap();
    writer.join().unwrap();
    assert!(output.status.success(), "tests/fuzz/python_reader.py failed");
    let endings: Vec<Ending> = String::from_utf8(output.stdout)
        .unwrap()
        .lines()
        .map(|line| {
            let r: Value = serde_json::from_str(line).unwrap();
            let text = |k: &str| r[k].as_str().unwrap().to_string();
            match (r["code"].as_i64(), r["signal"].as_i64(), r["hang"].as_bool()) {
                (_, _, Some(true)) => Ending::Hang,
                (Some(code), ..) => Ending::Exit(code as i32, text("stdout"), text("stderr")),
                (None, signal, _) => Ending::Signal(signal.unwrap_or(0) as i32),
            }
        })
        .collect();
    assert_eq!(endings.len(), cases.len(), "one result per case");
    endings
}

/// The files an export wrote into `dir`, sorted by name.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .map(|e| e.unwrap())
            .map(|e| (e.file_name().into_string().unwrap(), std::fs::read(e.path()).unwrap()))
            .collect(),
        Err(_) => Vec::new(),
    };
    out.sort();
    out
}

/// A C header's declarations and code: what follows its leading comment,
/// which quotes the manifest's free text.
fn header_body(files: &[(String, Vec<u8>)]) -> String {
    let [(_, bytes)] = files else { return format!("{} files", files.len()) };
    let text = String::from_utf8_lossy(bytes);
    text.split_once("*/").map_or(text.to_string(), |(_, body)| body.to_string())
}

/// Byte-level corruptions of a table file.
fn corrupt_file(bytes: &mut Vec<u8>, rng: &mut SplitMix64, other: &[u8]) -> String {
    let n = bytes.len();
    let mut pick = |m: usize| (rng.next_u64() % m.max(1) as u64) as usize;
    match pick(8) {
        0 => {
            let k = 1 + pick(8);
            for _ in 0..k {
                let i = pick(n);
                bytes[i] ^= 1 << pick(8);
            }
            format!("{k} bit flips")
        }
        1 => {
            let k = 1 + pick(16);
            for _ in 0..k {
                let i = pick(n);
                bytes[i] = pick(256) as u8;
            }
            format!("{k} random bytes")
        }
        2 => {
            let (at, len) = (pick(n), 1 + pick(4096));
            let end = (at + len).min(n);
            bytes[at..end].fill(0);
            format!("zeroed {at}..{end}")
        }
        3 => {
            let len = pick(n);
            bytes.truncate(len);
            format!("truncated to {len} bytes")
        }
        4 => {
            let k = 1 + pick(1024);
            bytes.extend((0..k).map(|_| pick(256) as u8));
            format!("{k} bytes appended")
        }
        5 => {
            // The header and superblock: where HDF5 reads first.
            let k = 1 + pick(4);
            for _ in 0..k {
                let i = pick(n.min(4096));
                bytes[i] = pick(256) as u8;
            }
            format!("{k} bytes of the first 4 KiB")
        }
        6 => {
            bytes.clear();
            "empty".into()
        }
        _ => {
            *bytes = other.to_vec();
            "another table's file".into()
        }
    }
}

/// The `i`-th checksum-bearing entry of a manifest (file, axes, values), as a JSON pointer.
fn checksum_pointers(m: &Value) -> Vec<String> {
    let mut out = vec!["/file/sha256".to_string()];
    for key in ["axes", "values"] {
        for i in 0..m[key].as_array().map_or(0, Vec::len) {
            out.push(format!("/{key}/{i}/sha256"));
        }
    }
    out
}

/// Corruptions of a manifest: malformed JSON, wrong sizes, swapped checksums,
/// unsafe or foreign names, edited encodings or interpolation, and harmless edits. Returns
/// the description and the new bytes (byte edits may leave invalid UTF-8).
fn corrupt_manifest(text: &str, rng: &mut SplitMix64, other: &Value) -> (String, Vec<u8>) {
    let mut pick = |m: usize| (rng.next_u64() % m.max(1) as u64) as usize;
    let mut m: Value = serde_json::from_str(text).unwrap();
    let n = text.len();
    let edit = |m: &mut Value, pointer: &str, f: &dyn Fn(&Value) -> Value| {
        let old = m.pointer(pointer).cloned().unwrap_or(Value::Null);
        if let Some(slot) = m.pointer_mut(pointer) {
            *slot = f(&old);
        }
    };
    let naxes = m["axes"].as_array().unwrap().len();
    let what = match pick(21) {
        0 => {
            let len = pick(n);
            return (format!("truncated to {len} bytes"), text.as_bytes()[..len].to_vec());
        }
        1 => {
            let i = pick(n);
            let mut t = text.as_bytes().to_vec();
            t.remove(i);
            return (format!("byte {i} deleted"), t);
        }
        2 => {
            let (i, c) = (pick(n), b"{}[],:\"0 e-x\\\xff"[pick(14)]);
            let mut t = text.as_bytes().to_vec();
            t.insert(i, c);
            return (format!("byte {c:#04x} inserted at {i}"), t);
        }
        3 => return ("empty".into(), Vec::new()),
        4 => {
            let off = [-1i64, 1, 4096][pick(3)];
            edit(&mut m, "/file/bytes", &|v| Value::from(v.as_i64().unwrap() + off));
            "file.bytes off".into()
        }
        5 => {
            let i = pick(naxes);
            edit(&mut m, &format!("/axes/{i}/size"), &|v| Value::from(v.as_i64().unwrap() + 1));
            format!("axes[{i}].size + 1")
        }
        6 => {
            edit(&mut m, "/values/0/shape/0", &|v| Value::from(v.as_i64().unwrap() - 1));
            "values[0].shape[0] - 1".into()
        }
        7 | 8 => {
            let sums = checksum_pointers(&m);
            let (a, b) = (pick(sums.len()), pick(sums.len() - 1));
            let b = if b >= a { b + 1 } else { b };
            let (va, vb) = (m.pointer(&sums[a]).unwrap().clone(), m.pointer(&sums[b]).unwrap().clone());
            *m.pointer_mut(&sums[a]).unwrap() = vb;
            *m.pointer_mut(&sums[b]).unwrap() = va;
            format!("checksums {} and {} swapped", sums[a], sums[b])
        }
        9 => {
            let p = ["/file/sha256", "/file/bytes", "/axes/0/sha256"][pick(3)];
            *m.pointer_mut(p).unwrap() = other.pointer(p).unwrap().clone();
            format!("{p} of another table")
        }
        10 => {
            let bad = ["../../../etc/passwd", "/etc/passwd", "", "x/../epd_g1.h5", ".hidden.h5"][pick(5)];
            m["file"]["path"] = Value::from(bad);
            format!("file.path {bad:?}")
        }
        11 => {
            m["table"] = other["table"].clone();
            "the table name of another table".into()
        }
        12 => {
            if naxes >= 2 {
                m["axes"].as_array_mut().unwrap().swap(0, 1);
            }
            "axes 0 and 1 swapped".into()
        }
        13 => {
            let i = pick(naxes);
            m["axes"][i]["encoding"] = serde_json::json!({"kind": "cubic"});
            format!("axes[{i}].encoding unknown")
        }
        14 => {
            // A parameter of an encoding, a derived axis or a value encoding: no checksum covers it.
            let i = pick(naxes);
            let targets: Vec<String> = m["axes"][i]["encoding"]
                .as_object()
                .unwrap()
                .iter()
                .filter(|(_, v)| v.is_number())
                .map(|(k, _)| format!("/axes/{i}/encoding/{k}"))
                .chain(m["derived_axes"].as_array().into_iter().flatten().flat_map(|d| {
                    d.as_object()
                        .unwrap()
                        .iter()
                        .filter(|(_, v)| v.is_number())
                        .map(|(k, _)| format!("/derived_axes/0/{k}"))
                        .collect::<Vec<_>>()
                }))
                .collect();
            if targets.is_empty() {
                m["axes"][i]["encoding"] = serde_json::json!({"kind": "log"});
                format!("axes[{i}].encoding log")
            } else {
                let t = &targets[pick(targets.len())];
                edit(&mut m, t, &|v| Value::from(v.as_f64().unwrap() * 1.01 + 0.001));
                format!("{t} edited")
            }
        }
        15 => {
            let key = ["format", "axes", "values", "file", "table"][pick(5)];
            m.as_object_mut().unwrap().remove(key);
            format!("{key} removed")
        }
        16 => {
            let p = ["/axes", "/values/0/shape", "/file/bytes", "/axes/0/encoding", "/file"][pick(5)];
            *m.pointer_mut(p).unwrap() = Value::from("x");
            format!("{p} is a string")
        }
        17 => {
            if m.get("value_encoding").is_some() {
                m["value_encoding"][0]["kind"] = Value::from("ln");
                "value encoding ln".into()
            } else {
                m["value_encoding"] =
                    serde_json::json!([{"value": m["values"][0]["name"], "kind": "ln", "formula": "x"}]);
                "value encoding added".into()
            }
        }
        18 => {
            // The interpolation kind: no checksum covers it (the file's `contract` attribute does).
            if m.get("interpolation").is_some() {
                m.as_object_mut().unwrap().remove("interpolation");
                "interpolation removed".into()
            } else {
                let kind = ["cubic", "bicubic"][pick(2)];
                m["interpolation"] = Value::from(kind);
                format!("interpolation {kind}")
            }
        }
        // Harmless edits: a reader must still give the intact values.
        19 => {
            m["timing"] = serde_json::json!({"compute_seconds": 1e9});
            m["accuracy"] = Value::from("edited");
            "timing and accuracy edited".into()
        }
        _ => return ("reformatted compactly".into(), serde_json::to_vec(&m).unwrap()),
    };
    (what, serde_json::to_vec_pretty(&m).unwrap())
}

/// The outcome of one reader on one case: None when it behaved, else what went wrong.
fn judge(reader: &str, ending: &Ending, intact: &Intact, out: &Path) -> Option<String> {
    match ending {
        Ending::Signal(s) => Some(format!("killed by signal {s}")),
        Ending::Hang => Some(format!("no answer in {} s", TIMEOUT.as_secs())),
        Ending::Exit(0, stdout, _) => {
            let same = match reader {
                "verify" => stdout.starts_with("ok"),
                "lookup" => *stdout == intact.lookup,
                "python" => *stdout == intact.python,
                "export-npy" => files(&out.join("npy")) == intact.npy,
                _ => header_body(&files(&out.join("c"))) == intact.header,
            };
            (!same).then(|| format!("succeeded with other output: {stdout:?}"))
        }
        Ending::Exit(_, stdout, stderr) => {
            let lines = stderr.lines().filter(|l| !l.trim().is_empty()).count();
            if lines != 1 {
                return Some(format!("refused with {lines} lines on stderr: {stderr:?}"));
            }
            if reader != "verify" && !stdout.is_empty() {
                return Some(format!("refused but printed {stdout:?}"));
            }
            let written = files(&out.join("npy")).len() + files(&out.join("c")).len();
            (written > 0).then(|| format!("refused but wrote {written} files"))
        }
    }
}

fn copy(from: &Path, to: &Path) {
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::write(to, std::fs::read(from).unwrap()).unwrap();
}

#[test]
fn corrupt_files_and_manifests_are_refused_cleanly_or_read_right() {
    let env = |k: &str, default: u64| std::env::var(k).ok().map_or(default, |v| v.parse().expect("a number"));
    let (seed, cases) = (env("TWOSCALE_FUZZ_SEED", 1), env("TWOSCALE_FUZZ_CASES", 320) as usize);
    python();

    // The paper preset, a scene's sub-domain tables and its material folder:
    // the shared reader tables (tests/suite/common/shared_tables.rs), copied.
    let built = tempdir();
    let folders = ["paper", "scene-merl_nickel", "scene-merl_nickel/nickel"];
    for preset in folders {
        for entry in std::fs::read_dir(shared_tables().join(preset)).unwrap() {
            let path = entry.unwrap().path();
            if path.is_file() {
                copy(&path, &built.path().join(preset).join(path.file_name().unwrap()));
            }
        }
    }
    // The manifests' timing, the one part that differs from run to run, made
    // fixed: a seed then gives the same cases byte for byte.
    for preset in folders {
        for entry in std::fs::read_dir(built.path().join(preset)).unwrap() {
            let path = entry.unwrap().path();
            if path.to_str().unwrap().ends_with(".manifest.json") {
                let mut m: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
                m["timing"] = serde_json::json!({});
                std::fs::write(&path, serde_json::to_string_pretty(&m).unwrap() + "\n").unwrap();
            }
        }
    }
    let mut targets = Vec::new();
    for preset in folders {
        let mut names: Vec<String> = std::fs::read_dir(built.path().join(preset))
            .unwrap()
            .filter_map(|e| {
                e.unwrap().file_name().into_string().unwrap().strip_suffix(".manifest.json").map(str::to_string)
            })
            .collect();
        names.sort();
        for table in names {
            let lookup = Lookup::open(&built.path().join(preset), &table).unwrap();
            // The middle of a middle cell (a derived coordinate: the middle of its range).
            let point = lookup
                .coordinates()
                .into_iter()
                .zip(&lookup.axes)
                .map(|(name, axis)| {
                    let x = match lookup.derived_axes.iter().find(|d| d.coordinate == name) {
                        Some(d) => 0.5 * (d.min + d.max),
                        None => 0.5 * (axis.nodes[(axis.len() - 1) / 2] + axis.nodes[(axis.len() - 1) / 2 + 1]),
                    };
                    (name, x)
                })
                .collect();
            targets.push(Target { preset: preset.into(), table, point });
        }
    }
    assert!(targets.len() >= 14, "paper (4 tables), the scene's sub-domain (4) and its material (6)");

    let scratch = tempdir();
    let pythons = python_reader(&targets.iter().map(|t| (built.path().to_path_buf(), t)).collect::<Vec<_>>());
    let intact: Vec<Intact> = targets
        .iter()
        .zip(pythons)
        .map(|(t, python)| {
            let out = scratch.path().join(format!("intact-{}-{}", t.preset, t.table));
            let ok = |ending: Ending| match ending {
                Ending::Exit(0, stdout, _) => stdout,
                other => panic!("{} {}: the intact table fails: {other:?}", t.preset, t.table),
            };
            let stdouts: Vec<String> =
                readers(built.path(), t, &out).into_iter().map(|(_, mut c)| ok(run(&mut c))).collect();
            Intact {
                lookup: stdouts[1].clone(),
                python: ok(python),
                npy: files(&out.join("npy")),
                header: header_body(&files(&out.join("c"))),
            }
        })
        .collect();

    // The cases: the fixture, then tables in turn, file and manifest in turn.
    let fixture = repo_root().join("tests/fixtures/corrupt-epd_g1");
    let mut rng = SplitMix64::new(seed);
    let mut plans: Vec<(usize, String)> = Vec::new();
    let case_dir = |k: usize| scratch.path().join(format!("case-{k}"));
    let epd_g1 = targets.iter().position(|t| t.preset == "paper" && t.table == "epd_g1").unwrap();
    for f in ["epd_g1.h5", "epd_g1.manifest.json"] {
        copy(&fixture.join(f), &case_dir(0).join("paper").join(f));
    }
    plans.push((epd_g1, "the fixture tests/fixtures/corrupt-epd_g1".into()));
    for k in 1..=cases {
        let ti = (k - 1) % targets.len();
        let t = &targets[ti];
        let other = &targets[(ti + 1 + (rng.next_u64() as usize) % (targets.len() - 1)) % targets.len()];
        let (src, dst) = (built.path().join(&t.preset), case_dir(k).join(&t.preset));
        let (h5, manifest) = (format!("{}.h5", t.table), format!("{}.manifest.json", t.table));
        copy(&src.join(&h5), &dst.join(&h5));
        copy(&src.join(&manifest), &dst.join(&manifest));
        let what = if ((k - 1) / targets.len()) % 2 == 0 {
            let mut bytes = std::fs::read(dst.join(&h5)).unwrap();
            let other_bytes =
                std::fs::read(built.path().join(&other.preset).join(format!("{}.h5", other.table))).unwrap();
            let what = corrupt_file(&mut bytes, &mut rng, &other_bytes);
            std::fs::write(dst.join(&h5), bytes).unwrap();
            format!("{h5}: {what}")
        } else {
            let other_manifest: Value = serde_json::from_str(
                &std::fs::read_to_string(
                    built.path().join(&other.preset).join(format!("{}.manifest.json", other.table)),
                )
                .unwrap(),
            )
            .unwrap();
            let (what, text) =
                corrupt_manifest(&std::fs::read_to_string(dst.join(&manifest)).unwrap(), &mut rng, &other_manifest);
            std::fs::write(dst.join(&manifest), text).unwrap();
            format!("{manifest}: {what}")
        };
        plans.push((ti, what));
    }

    // Every case through every reader: the command-line ones two cases at a
    // time, the Python reader beside them.
    let python_cases: Vec<(PathBuf, &Target)> =
        plans.iter().enumerate().map(|(k, (ti, _))| (case_dir(k), &targets[*ti])).collect();
    let (results, pythons) = rayon::join(
        || {
            use rayon::prelude::*;
            plans
                .par_iter()
                .enumerate()
                .map(|(k, (ti, _))| {
                    let out = scratch.path().join(format!("out-{k}"));
                    readers(&case_dir(k), &targets[*ti], &out)
                        .into_iter()
                        .map(|(reader, mut cmd)| {
                            let ending = run(&mut cmd);
                            let verdict = judge(reader, &ending, &intact[*ti], &out);
                            (reader, ending, verdict)
                        })
                        .collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        },
        || python_reader(&python_cases),
    );
    let results: Vec<Vec<(&'static str, Ending, Option<String>)>> = results
        .into_iter()
        .zip(pythons)
        .zip(&plans)
        .map(|((mut runs, python), (ti, _))| {
            let verdict = judge("python", &python, &intact[*ti], Path::new("/nonexistent"));
            runs.push(("python", python, verdict));
            runs
        })
        .collect();

    let (mut refused, mut read, mut failures) = (0, 0, Vec::new());
    for (k, ((ti, what), runs)) in plans.iter().zip(&results).enumerate() {
        for (reader, ending, verdict) in runs {
            match ending {
                Ending::Exit(0, ..) => read += 1,
                _ => refused += 1,
            }
            if k == 0 && !matches!(ending, Ending::Exit(1, ..)) {
                failures.push(format!(
                    "case 0 ({what}), {reader}: the fixture must be refused with exit status 1: {ending:?}"
                ));
            }
            if let Some(v) = verdict {
                failures
                    .push(format!("case {k} ({}/{}, {what}), {reader}: {v}", targets[*ti].preset, targets[*ti].table));
            }
        }
    }
    // The fixture through the other commands that read a table: plot and bundle.
    let fixture_dir = case_dir(0).join("paper");
    for args in [
        vec!["plot", "epd_g1", "--dir", fixture_dir.to_str().unwrap(), "--out"],
        vec!["bundle", "--quiet", "--dir", fixture_dir.to_str().unwrap(), "--out"],
    ] {
        let out = scratch.path().join(format!("fixture-{}", args[0]));
        let target = if args[0] == "plot" { out.join("f.png") } else { out.clone() };
        let ending = run(Command::new(BIN).args(&args).arg(&target));
        let one_line = matches!(&ending, Ending::Exit(1, _, err) if err.trim_end().lines().count() == 1);
        if !one_line || !files(&out).is_empty() {
            failures.push(format!("the fixture through {}: {ending:?}, files {:?}", args[0], files(&out).len()));
        }
        refused += 1;
    }
    // Written to stderr directly: the test harness captures println!, and `make test` shows this line.
    let _ = writeln!(
        std::io::stderr(),
        "fuzz: seed {seed}, {} cases ({} corrupt files, {} corrupt manifests, the fixture), {} reader runs: {refused} refused, {read} read the intact values, {} failures",
        plans.len(),
        plans.iter().skip(1).filter(|(_, w)| w.contains(".h5:")).count(),
        plans.iter().skip(1).filter(|(_, w)| w.contains(".manifest.json:")).count(),
        refused + read,
        failures.len()
    );
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}

/// The RGL reader (twoscale_fit::rgl::parse) on corrupt copies of a real file of the shared data's
/// rgl/ (chm_mint, the glossiest): every truncation of its header and field table (its first 512
/// bytes), then `corrupt_file`'s corruptions (the whole file, another RGL file's bytes among them)
/// alternating with random bytes in the field table. Each parse runs in a thread of this process (no
/// command reads RGL files on its own) and must end within TIMEOUT in a one-line error, or in a file
/// whose `samples` and `rho` (at fixed pairs) run and give finite values; never in a panic.
#[test]
fn corrupt_rgl_files_are_refused_cleanly_or_read() {
    use std::sync::mpsc;
    let env = |k: &str, default: u64| std::env::var(k).ok().map_or(default, |v| v.parse().expect("a number"));
    let (seed, cases) = (env("TWOSCALE_FUZZ_SEED", 1), env("TWOSCALE_FUZZ_CASES", 320) as usize);
    let dir = common::shared_data().join("rgl");
    let read =
        |name: &str| std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(name).display()));
    let (good, other) = (read("chm_mint_rgb.bsdf"), read("satin_rosaline_rgb.bsdf"));
    twoscale_fit::rgl::parse(&good).expect("the intact file reads");
    let table = 512.min(good.len());
    let mut rng = SplitMix64::new(seed);
    let mut plans: Vec<(String, Vec<u8>)> =
        (0..=table).map(|len| (format!("truncated to {len} bytes"), good[..len].to_vec())).collect();
    for k in 0..cases {
        let mut bytes = good.clone();
        let what = if k % 2 == 0 {
            corrupt_file(&mut bytes, &mut rng, &other)
        } else {
            let n = 1 + (rng.next_u64() % 4) as usize;
            for _ in 0..n {
                let i = (rng.next_u64() % table as u64) as usize;
                bytes[i] = rng.next_u64() as u8;
            }
            format!("{n} random bytes of the first {table}")
        };
        plans.push((what, bytes));
    }
    let pairs = [
        ([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
        ([0.6, 0.0, 0.8], [-0.6, 0.0, 0.8]),
        ([0.3, -0.4, 0.866_025_403_784_438_6], [-0.5, 0.1, 0.860_232_526_704_262_7]),
        ([0.999, 0.0, 0.044_710_177_812_216], [0.0, 0.999, 0.044_710_177_812_216]),
    ];
    let outcomes: Vec<Result<Result<(), String>, String>> = {
        use rayon::prelude::*;
        plans
            .par_iter()
            .map(|(_, bytes)| {
                let (tx, rx) = mpsc::channel();
                let bytes = bytes.clone();
                std::thread::spawn(move || {
                    let outcome = match twoscale_fit::rgl::parse(&bytes) {
                        Err(e) => Err(format!("{e:#}")),
                        Ok(file) => {
                            let finite = file.samples().iter().all(|s| s.rho.iter().all(|v| v.is_finite()))
                                && pairs.iter().all(|(wi, wo)| file.rho(*wi, *wo).iter().all(|v| v.is_finite()));
                            if finite {
                                Ok(())
                            } else {
                                Err("read, but a sample or rho is not finite\n".to_string())
                            }
                        }
                    };
                    let _ = tx.send(outcome);
                });
                match rx.recv_timeout(TIMEOUT) {
                    Ok(outcome) => Ok(outcome),
                    Err(mpsc::RecvTimeoutError::Timeout) => Err(format!("no answer in {} s", TIMEOUT.as_secs())),
                    Err(mpsc::RecvTimeoutError::Disconnected) => Err("panicked".to_string()),
                }
            })
            .collect()
    };
    let (mut refused, mut read_ok, mut failures) = (0, 0, Vec::new());
    for ((what, _), outcome) in plans.iter().zip(&outcomes) {
        match outcome {
            Ok(Ok(())) => read_ok += 1,
            Ok(Err(message)) if !message.is_empty() && !message.contains('\n') => refused += 1,
            Ok(Err(message)) => failures.push(format!("{what}: refused with {message:?}, not one line")),
            Err(why) => failures.push(format!("{what}: {why}")),
        }
    }
    let _ = writeln!(
        std::io::stderr(),
        "fuzz (RGL reader): seed {seed}, {} cases ({} truncations, {cases} corruptions): {refused} refused, {read_ok} read, {} failures",
        plans.len(),
        table + 1,
        failures.len()
    );
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}
