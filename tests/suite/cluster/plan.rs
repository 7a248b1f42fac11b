//! `twoscale plan` reads nothing relative to the current directory but its
//! arguments: from the repository, from `/` and from an empty directory it
//! prints the same plan, with the committed manifests' measured times.

use crate::common;

use common::{example_scene, repo_root, tempdir, BIN};
use std::path::Path;
use std::process::Command;

fn plan_in(cwd: &Path, args: &[&str]) -> String {
    let out = Command::new(BIN).arg("plan").args(args).current_dir(cwd).output().unwrap();
    assert!(out.status.success(), "plan {args:?} in {}: {}", cwd.display(), String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn plan_is_the_same_from_any_current_directory() {
    let root = repo_root();
    let scene = example_scene("merl_nickel.toml");
    let scene = scene.to_str().unwrap();
    let empty = tempdir();
    for args in [
        &["--preset", "default", "--json"][..],
        &["--preset", "paper", "--shards", "4"],
        &["--scene", scene],
        &["--scene", scene, "--shards", "3", "--json"],
    ] {
        let here = plan_in(&root, args);
        for cwd in [Path::new("/"), empty.path()] {
            assert_eq!(plan_in(cwd, args), here, "plan {args:?} in {}", cwd.display());
        }
    }
    // A relative scene path is relative to the current directory, as any argument.
    assert_eq!(
        plan_in(&root.join("examples/scenes"), &["--scene", "merl_nickel.toml"]),
        plan_in(&root, &["--scene", scene])
    );
    // The measured times are there: compiled in from manifests/, not read from the current directory.
    let v: serde_json::Value =
        serde_json::from_str(&plan_in(Path::new("/"), &["--preset", "default", "--json"])).unwrap();
    let tables = v["tables"].as_array().unwrap();
    assert!(!tables.is_empty() && tables.iter().all(|t| t["full_preset_seconds"].as_f64().is_some()), "{v}");
}
