//! The C reader, compiled and run: the checked-in lookup code
//! pipeline/tables/c/twoscale_tables.h, an exported data header and
//! tests/c/lookup_cli.c, fed points on stdin.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// The flags every C test compiles with: C99, every warning an error.
pub const C_FLAGS: [&str; 6] = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O1"];

/// `cc` with `C_FLAGS` and the checked-in headers' folders on the include path: the C reader's
/// (pipeline/tables/c) and the C BRDF's (runtimes/c).
pub fn cc() -> Command {
    let root = super::repo_root();
    let mut cmd = Command::new("cc");
    cmd.args(C_FLAGS).arg("-I").arg(root.join("pipeline/tables/c")).arg("-I").arg(root.join("runtimes/c"));
    cmd
}

/// Compiles the self-checking C program tests/c/`name`.c with `cc` and runs it; its stdout, after
/// asserting that both steps succeeded (the program exits non-zero on a failed check).
pub fn run_c_test(name: &str) -> String {
    let work = super::tempdir();
    let exe = work.path().join(name);
    let out =
        cc().arg(super::repo_root().join(format!("tests/c/{name}.c"))).arg("-o").arg(&exe).arg("-lm").output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let run = Command::new(&exe).output().unwrap();
    let text = String::from_utf8_lossy(&run.stdout).into_owned();
    assert!(run.status.success(), "tests/c/{name}.c: {text}");
    text
}

/// Compiles `header` (the data header of table `prefix`) into `work` and
/// returns one output line per point (physical coordinates, the lookup's
/// order): its outputs' numbers, or "outside".
pub fn c_lookup(header: &Path, prefix: &str, points: &[Vec<f64>], work: &Path) -> Vec<String> {
    let exe = work.join(prefix);
    let out = cc()
        .arg("-include")
        .arg(header)
        .arg(format!("-DTABLE={prefix}"))
        .arg(super::repo_root().join("tests/c/lookup_cli.c"))
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .unwrap();
    assert!(out.status.success(), "{prefix}: {}", String::from_utf8_lossy(&out.stderr));
    let input: String = points.iter().map(|p| p.iter().map(|x| format!("{x:e} ")).collect::<String>() + "\n").collect();
    let mut child = Command::new(&exe).stdin(Stdio::piped()).stdout(Stdio::piped()).spawn().unwrap();
    child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    let stdout = String::from_utf8(child.wait_with_output().unwrap().stdout).unwrap();
    let lines: Vec<String> = stdout.lines().map(str::to_string).collect();
    assert_eq!(lines.len(), points.len(), "{prefix}: one line per point");
    lines
}
