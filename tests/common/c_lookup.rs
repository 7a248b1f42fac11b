//! The exported C header's lookup, compiled and run: tests/c/lookup_cli.c
//! with `-include <header>`, fed points on stdin.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// Compiles `header` (whose names start with `prefix`, DIMS axes, NV values)
/// into `work` and returns one output line per point: NV numbers or "outside".
pub fn c_lookup(header: &Path, prefix: &str, dims: usize, nv: usize, points: &[Vec<f64>], work: &Path) -> Vec<String> {
    let exe = work.join(prefix);
    let cc = Command::new("cc")
        .args(["-std=c99", "-O1", "-Wall", "-Werror", "-include"])
        .arg(header)
        .arg(format!("-DLOOKUP={prefix}_lookup"))
        .arg(format!("-DDIMS={dims}"))
        .arg(format!("-DNV={nv}"))
        .arg(super::repo_root().join("tests/c/lookup_cli.c"))
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .unwrap();
    assert!(cc.status.success(), "{prefix}: {}", String::from_utf8_lossy(&cc.stderr));
    let input: String = points.iter().map(|p| p.iter().map(|x| format!("{x:e} ")).collect::<String>() + "\n").collect();
    let mut child = Command::new(&exe).stdin(Stdio::piped()).stdout(Stdio::piped()).spawn().unwrap();
    child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    let stdout = String::from_utf8(child.wait_with_output().unwrap().stdout).unwrap();
    let lines: Vec<String> = stdout.lines().map(str::to_string).collect();
    assert_eq!(lines.len(), points.len(), "{prefix}: one line per point");
    lines
}
