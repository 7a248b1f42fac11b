//! The tables the tests read (golden, readers, fuzz, tables, scenes, shards, slurm, mitsuba), built
//! once per build of the code: both presets (paper, default) and, as
//! pipeline/tables/golden/make.sh builds them, the sub-domain tables of
//! examples/scenes/merl_nickel.toml (all seven of the default preset) and its material folder
//! scene-merl_nickel/nickel; the zh_lobe of
//! pipeline/tables/golden/broad_lobe.toml; the plastics of examples/scenes/plastic.toml. Built into
//! target/tmp/shared-tables by the first test binary that asks; builds are
//! incremental (a table is rebuilt when the twoscale executable changed), so
//! the next binaries find them up to date at once. Read only: a test that
//! edits tables copies them first. The material folders of the runtimes' test
//! materials (runtimes/testing/test_materials.toml) are built on their own
//! (`test_materials`), into the same root under the same lock.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The sub-domain tables of examples/scenes/merl_nickel.toml in the build root: every table of
/// the default preset.
pub const SCENE_TABLES: [&str; 7] =
    ["epd_g1", "epd_norm", "kcorr_renorm", "zh_convolution", "zh_lobe", "epd_albedo", "epd_albedo_avg"];

/// The folders of the build root every one of whose tables has golden vectors (the plastics' folders
/// have them for interface_albedo, the table only plastic and subsurface materials have).
pub const FOLDERS: [&str; 4] = ["paper", "scene-merl_nickel", "scene-merl_nickel/nickel", "scene-broad_lobe"];

/// The build root, built (or found up to date) on first use.
pub fn shared_tables() -> &'static Path {
    static ROOT: OnceLock<PathBuf> = OnceLock::new();
    ROOT.get_or_init(|| {
        let repo = super::repo_root();
        let root = root();
        let _lock = lock(&root);
        let scene = repo.join("examples/scenes/merl_nickel.toml");
        let broad = repo.join("pipeline/tables/golden/broad_lobe.toml");
        let plastic = repo.join("examples/scenes/plastic.toml");
        let scene_tables: Vec<&str> = SCENE_TABLES.iter().flat_map(|t| ["--table", t]).collect();
        let builds: [(&[&str], Option<&Path>); 6] = [
            (&["--preset", "paper"], None),
            (&["--preset", "default"], None),
            (&scene_tables, Some(&scene)),
            (&[], Some(&scene)),
            (&["--table", "zh_lobe"], Some(&broad)),
            (&[], Some(&plastic)),
        ];
        for (args, scene) in builds {
            build(&root, args, scene);
        }
        root
    })
}

/// The build root's scene-test_materials/ (one material folder per material of
/// runtimes/testing/test_materials.toml), built (or found up to date) on first use.
pub fn test_materials() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = root();
        let _lock = lock(&root);
        build(&root, &[], Some(&super::repo_root().join("runtimes/testing/test_materials.toml")));
        root.join("scene-test_materials")
    })
}

fn root() -> PathBuf {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shared-tables");
    std::fs::create_dir_all(&root).unwrap();
    root
}

/// Test binaries run side by side build one at a time (the lock is released on drop).
fn lock(root: &Path) -> std::fs::File {
    let lock = std::fs::File::create(root.with_extension("lock")).unwrap();
    lock.lock().unwrap();
    lock
}

/// `twoscale build --quiet --out ROOT ARGS [--scene SCENE]`, which must succeed (incremental).
fn build(root: &Path, args: &[&str], scene: Option<&Path>) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_twoscale"));
    cmd.args(["build", "--quiet", "--out"]).arg(root).args(args);
    if let Some(scene) = scene {
        cmd.arg("--scene").arg(scene);
    }
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "build {args:?} {scene:?}: {}", String::from_utf8_lossy(&out.stderr));
}
