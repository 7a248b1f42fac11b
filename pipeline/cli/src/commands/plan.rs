//! `twoscale plan`, and the scene plan `build --scene` checks first.

use crate::flags::PlanArgs;
use crate::glue::input_error;
use anyhow::Result;
use std::path::Path;
use twoscale_generate::scene::Scene;
use twoscale_generate::tables::{self, BuildOptions, Preset, SceneTarget, TableDef};
use twoscale_tables::axis::Axis;
use twoscale_tables::manifest::Manifest;

/// A scene's target and, per table it needs (among `candidates`), the
/// restricted axes and the full grid's entry count. Every input error (the
/// file, a material's field, a range outside the default domain) is found
/// here, before anything is built.
type ScenePlan = (SceneTarget, Vec<(&'static TableDef, Vec<Axis>, usize)>);

pub(super) fn scene_plan(file: &Path, candidates: &[&'static TableDef]) -> Result<ScenePlan> {
    let scene = Scene::load(file).map_err(|e| input_error(format!("{e:#}")))?;
    let ranges = scene.ranges().into_iter().map(|(a, r)| (a.to_string(), r)).collect();
    let target = SceneTarget { name: scene.name.clone(), sha256: scene.sha256.clone(), ranges };
    let options = BuildOptions { scene: Some(target.clone()), ..Default::default() };
    let mut needed = Vec::new();
    for &def in candidates.iter().filter(|d| !d.diffraction || scene.has_diffraction()) {
        let full = (def.axes)(Preset::Default);
        let entries = full.iter().map(Axis::len).product();
        let axes = tables::sub_domain(full, def.cubic, &options)
            .map_err(|e| input_error(format!("{}: {}: {e:#}", file.display(), def.name)))?;
        needed.push((def, axes, entries));
    }
    Ok((target, needed))
}

/// The committed manifests (manifests/<preset>/<table>.manifest.json) as
/// (preset, table, text), compiled in by pipeline/cli/embed_manifests.rs: the plan reads
/// no file but its scene, whatever the current directory.
const COMMITTED_MANIFESTS: &[(&str, &str, &str)] = include!(concat!(env!("OUT_DIR"), "/committed_manifests.rs"));

/// The build time a committed manifest of `preset` measured for `table`.
fn committed_timing(preset: Preset, table: &str) -> Option<serde_json::Value> {
    let (_, _, text) = COMMITTED_MANIFESTS.iter().find(|(p, t, _)| *p == preset.name() && *t == table)?;
    serde_json::from_str::<Manifest>(text).ok().map(|m| m.timing)
}

pub fn run_plan(args: &PlanArgs) -> Result<()> {
    let all: Vec<&'static TableDef> = tables::TABLES.iter().collect();
    let (name, output, preset, scene, needed) = match &args.scene {
        Some(file) => {
            let (target, needed) = scene_plan(file, &all)?;
            (target.name.clone(), format!("scene-{}", target.name), Preset::Default, Some(target.sha256), needed)
        }
        None => {
            let needed = all.iter().filter(|def| def.presets.contains(&args.preset)).map(|&def| {
                let axes = (def.axes)(args.preset);
                let entries = axes.iter().map(Axis::len).product();
                (def, axes, entries)
            });
            (args.preset.name().to_string(), args.preset.name().to_string(), args.preset, None, needed.collect())
        }
    };
    let shards = args.shards as f64;
    let mut rows = Vec::new();
    for (def, axes, full_entries) in &needed {
        let entries: usize = axes.iter().map(Axis::len).product();
        // Scale the preset's measured build time (committed manifest), when there is one.
        let timing = committed_timing(preset, def.name);
        let full_seconds = timing.as_ref().and_then(|t| t["compute_seconds"].as_f64());
        let scale = entries as f64 / *full_entries as f64;
        let estimated = full_seconds.map(|t| t * scale);
        // Every shard repeats the setup (zh: the F coefficients), and shares the rest.
        let setup = timing.as_ref().and_then(|t| t["setup_seconds"].as_f64()).unwrap_or(0.0) * scale;
        let per_shard = estimated.map(|t| setup.min(t) + (t - setup.min(t)) / shards);
        let sub: Vec<serde_json::Value> = axes
            .iter()
            .map(|a| serde_json::json!({ "axis": a.name, "nodes": a.len(), "min": twoscale_generate::accuracy::json_f64(a.min()), "max": twoscale_generate::accuracy::json_f64(a.max()) }))
            .collect();
        rows.push(serde_json::json!({
            "table": def.name,
            "sub_domain": sub,
            "entries": entries,
            "full_preset_entries": full_entries,
            "estimated_seconds": estimated,
            "shards": args.shards,
            "estimated_seconds_per_shard": per_shard,
            "estimate": "the preset's measured compute time (manifests/, 2 cores) scaled by the entry count; per shard: \
                         the setup every shard repeats (zh coefficients F) plus 1/N of the rest (process start and merge not included)",
            "full_preset_seconds": full_seconds,
        }));
    }
    // What `build --scene` writes: each material's own tables; the rows above are its `--table` sub-domain builds.
    let materials: Vec<serde_json::Value> = match &args.scene {
        Some(file) => Scene::load(file)
            .map_err(|e| input_error(format!("{e:#}")))?
            .materials
            .iter()
            .map(|m| serde_json::json!({ "material": m.name, "output": format!("{output}/{}", m.name), "tables": m.table_names() }))
            .collect(),
        None => Vec::new(),
    };
    let plan = serde_json::json!({ "scene": args.scene.as_ref().map(|_| &name), "preset": preset.name(), "sha256": scene, "output": output, "materials": materials, "tables": rows });
    if args.json {
        println!("{plan}");
    } else {
        for m in &materials {
            let tables: Vec<&str> = m["tables"].as_array().into_iter().flatten().filter_map(|t| t.as_str()).collect();
            println!(
                "material {} -> tables-out/{}/: {}",
                m["material"].as_str().unwrap_or(""),
                m["output"].as_str().unwrap_or(""),
                tables.join(", ")
            );
        }
        if args.scene.is_some() {
            println!("with --table T (the default preset's tables over the scene's sub-domain):");
        }
        println!(
            "{} -> tables-out/{output}/",
            if args.scene.is_some() { format!("scene {name}") } else { format!("preset {name}") }
        );
        for r in &rows {
            let secs =
                |key: &str, digits: usize| r[key].as_f64().map_or("?".to_string(), |t| format!("{t:.digits$} s"));
            let sharded = if args.shards > 1 {
                format!(", {} per shard of {}", secs("estimated_seconds_per_shard", 3), args.shards)
            } else {
                String::new()
            };
            println!(
                "  {:<15} {:>9} entries (full {}: {:>9}), about {}{sharded} (full: {})",
                r["table"].as_str().unwrap_or(""),
                r["entries"],
                preset.name(),
                r["full_preset_entries"],
                secs("estimated_seconds", 3),
                secs("full_preset_seconds", 1)
            );
            for a in r["sub_domain"].as_array().into_iter().flatten().filter(|_| args.scene.is_some()) {
                println!(
                    "      {:<19} {:>5} nodes  [{}, {}]",
                    a["axis"].as_str().unwrap_or(""),
                    a["nodes"],
                    a["min"],
                    a["max"]
                );
            }
        }
    }
    Ok(())
}
