//! Table data is versioned: a version's data never changes once recorded in
//! manifests/versions.lock, and every recorded version has a CHANGELOG entry.

use crate::common;

use common::{read_manifest, repo_root};
use sha2::{Digest, Sha256};

/// SHA-256 over the sorted "preset/table/dataset sha256" lines of every committed manifest.
fn data_digest() -> String {
    let mut lines = Vec::new();
    for preset in std::fs::read_dir(repo_root().join("manifests")).unwrap().filter_map(|e| e.ok()) {
        if !preset.path().is_dir() {
            continue;
        }
        for file in std::fs::read_dir(preset.path()).unwrap().filter_map(|e| e.ok()) {
            let m = read_manifest(&file.path());
            for (name, sum) in m.data_checksums() {
                lines.push(format!("{}/{}/{name} {sum}\n", m.preset, m.table));
            }
        }
    }
    lines.sort();
    Sha256::digest(lines.concat().as_bytes()).iter().map(|b| format!("{b:02x}")).collect()
}

#[test]
fn data_changes_come_with_a_version_bump_and_a_changelog_entry() {
    let version = env!("CARGO_PKG_VERSION");
    let digest = data_digest();
    let lock = std::fs::read_to_string(repo_root().join("manifests/versions.lock")).unwrap();
    let changelog = std::fs::read_to_string(repo_root().join("CHANGELOG.md")).unwrap();
    let recorded: Vec<(&str, &str)> = lock
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| l.split_once(' ').expect("lines are `<version> <digest>`"))
        .collect();
    for (v, _) in &recorded {
        assert!(changelog.contains(&format!("## {v}")), "CHANGELOG.md has no `## {v}` entry");
    }
    match recorded.iter().find(|(v, _)| *v == version) {
        Some((_, d)) => assert_eq!(
            *d, digest,
            "table data changed, but version {version} was released with other data: bump the version in \
             Cargo.toml, add a CHANGELOG.md entry and the line `<new version> {digest}` to manifests/versions.lock"
        ),
        None => panic!("version {version} is not in manifests/versions.lock: add the line `{version} {digest}` and a CHANGELOG.md entry"),
    }
}
