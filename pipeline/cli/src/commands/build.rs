//! `twoscale build`, and the stage binaries.

use super::plan::scene_plan;
use crate::flags::{BuildArgs, Common};
use crate::glue::input_error;
use anyhow::Result;
use twoscale_generate::build::build_table;
use twoscale_generate::progress::Progress;
use twoscale_generate::scene::Scene;
use twoscale_generate::shard::build_shard;
use twoscale_generate::tables::{self, BuildOptions, Preset, TableDef};

/// Builds the requested tables among `allowed` (all of them when none is named).
pub fn run_build(args: &BuildArgs, common: &Common, allowed: &[&'static TableDef]) -> Result<()> {
    let mut selected: Vec<&'static TableDef> = Vec::new();
    for name in &args.tables {
        let def = tables::find(name).map_err(input_error)?;
        if !allowed.iter().any(|d| d.name == def.name) {
            let names: Vec<&str> = allowed.iter().map(|d| d.name).collect();
            return Err(input_error(format!(
                "table {name:?} is not built here (this command builds: {})",
                names.join(", ")
            )));
        }
        if !def.presets.contains(&args.preset) {
            return Err(input_error(format!("table {name:?} is not in the {} preset", args.preset)));
        }
        if !selected.iter().any(|d| d.name == def.name) {
            selected.push(def);
        }
    }
    if selected.is_empty() {
        selected = allowed.iter().copied().filter(|d| d.presets.contains(&args.preset)).collect();
    }
    if (args.degree.is_some() || args.method.is_some()) && !selected.iter().any(|d| d.name == "zh_convolution") {
        return Err(input_error("--degree and --method apply to zh_convolution only"));
    }
    let mut options = BuildOptions {
        progress: Progress { quiet: common.quiet },
        degree: args.degree.map(|d| d as usize),
        method: args.method,
        force: args.force,
        scene: None,
        // zh_convolution and zh_lobe share the coefficient rows of their common nodes.
        context: Some(Default::default()),
    };
    if let Some(file) = &args.scene {
        if args.preset != Preset::Default {
            return Err(input_error("--scene builds on the default preset's grids: drop --preset"));
        }
        // Alone, --scene builds each material's tables (docs/maths.md section 8); with
        // --table or --shard, the default preset's tables over the scene's sub-domain.
        if args.shard.is_none() && args.tables.is_empty() {
            let scene = Scene::load(file).map_err(|e| input_error(format!("{e:#}")))?;
            return twoscale_generate::scene_tables::build_scene(&scene, &args.out, &options);
        }
        let (target, needed) = scene_plan(file, &selected)?;
        if needed.is_empty() {
            tracing::info!("scene {} needs none of the tables this command builds: nothing to do", target.name);
        }
        options.scene = Some(target);
        selected = needed.into_iter().map(|(def, _, _)| def).collect();
    }
    for def in selected {
        match args.shard {
            Some(spec) => build_shard(def, args.preset, &args.out, &options, spec)?,
            None => build_table(def, args.preset, &args.out, &options).map(|_| ())?,
        }
    }
    Ok(())
}
