//! `twoscale bundle`.

use crate::flags::BundleArgs;
use anyhow::Result;
use std::path::PathBuf;

/// A preset's bundle, or a folder's: named for its tables' target (a material folder's `scene-<scene>/<material>`).
pub fn run_bundle(args: &BundleArgs) -> Result<PathBuf> {
    let Some(dir) = &args.folder else {
        return twoscale_generate::bundle::write_bundle(
            &args.dir.join(args.preset.name()),
            args.preset.name(),
            &args.out,
        );
    };
    if !twoscale_tables::verify::holds_manifests(dir)? {
        return twoscale_generate::bundle::write_scene_bundle(dir, &args.out);
    }
    // The folder's target, from its first manifest; write_bundle verifies every table.
    let first = twoscale_tables::verify::table_names(dir)?.remove(0);
    let target = twoscale_tables::file::read_manifest(dir, &first)?.preset;
    twoscale_generate::bundle::write_bundle(dir, &target, &args.out)
}
