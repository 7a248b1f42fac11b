//! Helpers shared by the integration tests (`tests/suite/`, one binary): a module there reaches
//! them with `use crate::common;`.

pub mod c_lookup;
pub mod shared_tables;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tempfile::TempDir;
use twoscale_tables::manifest::Manifest;

/// The `twoscale` binary of this build.
pub const BIN: &str = env!("CARGO_BIN_EXE_twoscale");

/// The repository's root (two folders above pipeline/cli, the tests' package).
pub fn repo_root() -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).canonicalize().expect("the repository's root exists")
}

/// examples/scenes/`name`.
pub fn example_scene(name: &str) -> PathBuf {
    repo_root().join("examples/scenes").join(name)
}

/// The shared data (published fits, measured files): $TWOSCALE_DATA if set, else `<repo>/../shared/data`
/// if it exists, else, where the repository's origin is a local directory, that directory's
/// `../shared/data`.
#[track_caller]
pub fn shared_data() -> PathBuf {
    if let Some(dir) = std::env::var_os("TWOSCALE_DATA") {
        return PathBuf::from(dir);
    }
    let root = repo_root();
    let beside = root.join("../shared/data");
    if beside.exists() {
        return beside;
    }
    let origin = Command::new("git").arg("-C").arg(&root).args(["config", "remote.origin.url"]).output();
    match origin.map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim())) {
        Ok(origin) if origin.is_dir() => origin.join("../shared/data"),
        _ => panic!("no {} and no local origin: set TWOSCALE_DATA to the shared data folder", beside.display()),
    }
}

/// The project's Python (.venv, with numpy, h5py and the readers' needs).
#[track_caller]
pub fn python() -> PathBuf {
    let py = repo_root().join(".venv/bin/python");
    assert!(
        py.exists(),
        "{} is missing: run `make test` (its `pyenv` step installs numpy, h5py, scipy, mitsuba)",
        py.display()
    );
    py
}

/// Runs pytest on `dir` (a folder of the repository) with `args`, this build's `twoscale` and
/// Mitsuba's LLVM (libLLVM 19; `make test` installs it). Asserts that exactly `expected` tests ran
/// and passed (none failed, errored, was skipped or deselected; warnings are shown, not fatal), and
/// prints pytest's report with every test's measured figures (-rP).
#[track_caller]
pub fn pytest(dir: &str, args: &[&std::ffi::OsStr], expected: usize) {
    const LIBLLVM: &str = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so";
    let root = repo_root();
    let mut cmd = Command::new(python());
    cmd.current_dir(&root)
        .args(["-m", "pytest", "-q", "-rP", "--color=no", "-p", "no:cacheprovider", dir])
        .args(args)
        .env("TWOSCALE_BIN", BIN);
    if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
        assert!(
            Path::new(LIBLLVM).exists(),
            "{LIBLLVM} is missing: run `make test` (its `deps` step installs libllvm19)"
        );
        cmd.env("DRJIT_LIBLLVM_PATH", LIBLLVM);
    }
    let out = cmd.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    println!("{stdout}");
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    // The last line is pytest's summary, e.g. "51 passed, 1 warning in 300.12s (0:05:00)".
    let summary = stdout.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("");
    let counts = summary.trim_matches(|c: char| c == '=' || c.is_whitespace()).split(" in ").next().unwrap_or("");
    let mut kinds = counts.split(", ").map(|part| part.split_once(' ').unwrap_or(("", part)));
    assert!(
        kinds.next() == Some((expected.to_string().as_str(), "passed"))
            && kinds.all(|(_, kind)| kind == "warning" || kind == "warnings"),
        "{dir}: expected \"{expected} passed\" and nothing else but warnings, got {summary:?}"
    );
}

/// Runs the pytest suite of runtimes/`runtime` (runtimes/pytest.ini) on the shared test materials and,
/// when given, the default preset's `tables`, with the C BRDF's compile cache in the target folder.
#[track_caller]
pub fn pytest_runtime(runtime: &str, tables: Option<&Path>, expected: usize) {
    let root = repo_root();
    let (ini, cache) = (root.join("runtimes/pytest.ini"), Path::new(env!("CARGO_TARGET_TMPDIR")).join("c-brdf-cache"));
    let mut args: Vec<&std::ffi::OsStr> = vec!["-c".as_ref(), ini.as_os_str(), "--c-cache".as_ref(), cache.as_os_str()];
    args.extend(["--materials".as_ref(), shared_tables::test_materials().as_os_str()]);
    if let Some(t) = tables {
        args.extend(["--tables".as_ref(), t.as_os_str()]);
    }
    pytest(&format!("runtimes/{runtime}"), &args, expected);
}

/// A fresh temporary directory, removed when dropped.
pub fn tempdir() -> TempDir {
    tempfile::tempdir().expect("a temporary directory")
}

/// `twoscale ARGS`.
pub fn run(args: &[&str]) -> Output {
    run_env(args, &[])
}

/// `twoscale ARGS` with these environment variables.
pub fn run_env(args: &[&str], envs: &[(&str, &str)]) -> Output {
    Command::new(BIN).args(args).envs(envs.iter().copied()).output().expect("run twoscale")
}

/// Asserts that the command succeeded (else shows its stderr).
#[track_caller]
pub fn assert_ok(out: &Output) {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// Asserts that the command succeeded, and returns its log (stderr).
#[track_caller]
pub fn ok(out: Output) -> String {
    assert_ok(&out);
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts a usage error: exit status 2, one line on stderr holding `needle`, nothing on stdout.
#[track_caller]
pub fn assert_input_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
    assert!(err.contains(needle), "{needle:?} not in {err:?}");
    assert!(out.stdout.is_empty());
}

/// `twoscale build --quiet --out OUT ARGS`, which must succeed.
#[track_caller]
pub fn build(out: &Path, args: &[&str]) {
    let o = Command::new(BIN).args(["build", "--quiet", "--out"]).arg(out).args(args).output().expect("run twoscale");
    assert!(o.status.success(), "build {args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// A temporary directory holding `twoscale build --quiet ARGS` (e.g. a preset: `--preset paper`).
#[track_caller]
pub fn build_temp(args: &[&str]) -> TempDir {
    let dir = tempdir();
    build(dir.path(), args);
    dir
}

/// A manifest file.
#[track_caller]
pub fn read_manifest(path: &Path) -> Manifest {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}
