//! Compiles the committed manifests (manifests/<preset>/<table>.manifest.json)
//! into the binaries, so that `twoscale plan` scales their measured build
//! times from any current directory (and on a machine without the sources).
//! Writes OUT_DIR/committed_manifests.rs: a slice of (preset, table, text).

use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    let dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo")).join("../../manifests");
    println!("cargo:rerun-if-changed={}", dir.display());
    let mut entries = Vec::new();
    for preset in
        std::fs::read_dir(&dir).expect("manifests/ is readable").map(|e| e.expect("manifests/ is readable").path())
    {
        if !preset.is_dir() {
            continue;
        }
        for file in
            std::fs::read_dir(&preset).expect("a preset folder of manifests/ is readable").map(|e| e.unwrap().path())
        {
            let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if let Some(table) = name.strip_suffix(".manifest.json") {
                let preset = preset.file_name().and_then(|n| n.to_str()).expect("a UTF-8 preset name");
                entries.push((preset.to_string(), table.to_string(), file.to_str().expect("a UTF-8 path").to_string()));
            }
        }
    }
    entries.sort();
    let mut code = String::from("&[\n");
    for (preset, table, path) in &entries {
        writeln!(code, "    ({preset:?}, {table:?}, include_str!({path:?})),").unwrap();
    }
    code.push(']');
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("set by cargo")).join("committed_manifests.rs");
    std::fs::write(out, code).expect("OUT_DIR is writable");
}
