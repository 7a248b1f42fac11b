//! A scene's per-material tables: `twoscale build --scene S.toml` writes each material's tables
//! (`material::MATERIAL_TABLES`) into `DIR/scene-<scene>/<material>/`; a material whose tables
//! are up to date (same parameters, same generator, intact files) is not rebuilt, and a table
//! that an earlier material of the same build already computed from the same parameters (materials
//! that share a surface: a coating over several layers) is written from that computation.

use crate::build::{generator_identity, up_to_date, write_built};
use crate::material::subsurface::{single_max, SINGLE_MAX_FORMULA};
use crate::material::{Material, MaterialTableDef, Model, DECODING, MATERIAL_TABLES};
use crate::scene::Scene;
use crate::tables::epd_math::norm;
use crate::tables::BuildOptions;
use crate::tables::Built;
use anyhow::{Context, Result};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;
use tracing::info;
use twoscale_tables::table::write_json_atomic;

/// The manifest's `material` section.
fn material_section(m: &Material, scene: &Scene) -> Value {
    let mut section = m.parameters();
    section["n_p"] = json!(norm(m.p));
    section["n_p_formula"] = json!("N(p) = p / (pi Gamma(1/p)) (docs/maths.md section 1): D(m) = N(p) / beta^2 exp(-(tan^2 theta_m / beta^2)^p) / cos^4 theta_m");
    if let Model::Subsurface { ior, g, .. } = m.model {
        section["single_max"] = json!(single_max(g, ior));
        section["single_max_formula"] = json!(SINGLE_MAX_FORMULA);
    }
    section["scene"] = json!({ "name": scene.name, "sha256": scene.sha256 });
    section
}

/// The inputs of one table of a material: the table, every parameter and the generator.
fn inputs(m: &Material, table: &str) -> Result<Value> {
    let what = json!({ "table": table, "material": m.parameters(), "generator": generator_identity()? });
    Ok(json!({ "sha256": twoscale_tables::checksum::sha256_bytes(what.to_string().as_bytes()), "what": what }))
}

/// What one table's data depend on: the surface (every parameter but the name and what lies beneath
/// the interface), the interface's ior for a table of a dielectric interface, and the generator. Two
/// materials with the same key have the same table, byte for byte.
fn data_key(m: &Material, def: &MaterialTableDef) -> Result<String> {
    let mut what = m.parameters();
    let surface = ["beta", "p", "sigma_s", "b", "c", "wavelength_min", "wavelength_max"];
    what.as_object_mut()
        .expect("an object")
        .retain(|k, _| surface.contains(&k.as_str()) || (def.dielectric && k == "ior"));
    let what = json!({ "table": def.name, "data": what, "generator": generator_identity()? });
    Ok(twoscale_tables::checksum::sha256_bytes(what.to_string().as_bytes()))
}

/// A table computed in this build, kept for the materials after it with the same data key.
struct Computed {
    built: Built,
    material: String,
}

/// Builds the tables of every material of `scene` into `out/scene-<scene>/<material>/`.
pub fn build_scene(scene: &Scene, out: &Path, options: &BuildOptions) -> Result<()> {
    let root = out.join(format!("scene-{}", scene.name));
    let context = options.context.clone().unwrap_or_default();
    let mut computed: HashMap<String, Computed> = HashMap::new();
    // How many materials of the scene have each table's data.
    let mut wanted: HashMap<String, usize> = HashMap::new();
    for m in &scene.materials {
        for def in m.tables() {
            *wanted.entry(data_key(m, def)?).or_default() += 1;
        }
    }
    for m in &scene.materials {
        let dir = root.join(&m.name);
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
        let target = format!("scene-{}/{}", scene.name, m.name);
        let section = material_section(m, scene);
        let mut stale = Vec::new();
        for table in m.table_names() {
            let inputs = inputs(m, table)?;
            match (!options.force).then(|| up_to_date(&dir, table, &inputs["sha256"])).flatten() {
                Some(mut manifest) => {
                    // Same data: only the scene file (another material changed) may differ.
                    if manifest.material.as_ref() != Some(&section) {
                        manifest.material = Some(section.clone());
                        let path = twoscale_tables::file::manifest_path(&dir, table);
                        write_json_atomic(&path, &manifest)?;
                    }
                    info!(material = m.name, table, "up to date");
                }
                None => stale.push((table, inputs)),
            }
        }
        if stale.is_empty() {
            continue;
        }
        info!(material = m.name, tables = stale.len(), "building");
        let start = Instant::now();
        let mut written: Vec<&str> = Vec::new();
        for def in m.tables() {
            // Built when stale and not yet made with an earlier table of the same builder.
            if !stale.iter().any(|(s, _)| *s == def.name) || written.contains(&def.name) {
                continue;
            }
            let key = data_key(m, def)?;
            let tables = match computed.get(&key) {
                Some(c) => vec![(def, key, c.built.clone(), Some(c.material.clone()))],
                None => {
                    let mut tables = Vec::new();
                    for built in (def.build)(m, &context, &dir)? {
                        let table =
                            MATERIAL_TABLES.iter().find(|t| t.name == built.table.name).expect("a per-material table");
                        tables.push((table, data_key(m, table)?, built, None));
                    }
                    tables
                }
            };
            for (table, key, b, computed_for) in tables {
                if written.contains(&table.name) {
                    continue; // albedo again, with interface_albedo: written from an earlier material's
                }
                // Kept while a later material of the scene has the same data.
                let left = wanted.get_mut(&key).map_or(0, |n| {
                    *n = n.saturating_sub(1);
                    *n
                });
                if left == 0 {
                    computed.remove(&key);
                } else if computed_for.is_none() && !computed.contains_key(&key) {
                    computed.insert(key.clone(), Computed { built: b.clone(), material: m.name.clone() });
                }
                let Some((_, inputs)) = stale.iter().find(|(s, _)| *s == table.name) else { continue };
                let mut timing = json!({ "compute_seconds": b.compute_seconds, "accuracy_seconds": b.accuracy_seconds, "threads": rayon::current_num_threads() });
                if let Some(other) = computed_for {
                    info!(
                        material = m.name,
                        table = table.name,
                        "the same data as {other}'s: written from its computation"
                    );
                    timing["computed_for"] = json!(other);
                }
                let definition = format!("{}{DECODING}", table.definition);
                write_built(table.name, &definition, &dir, &target, b, inputs.clone(), timing, Some(section.clone()))?;
                written.push(table.name);
            }
        }
        info!(material = m.name, seconds = format!("{:.2}", start.elapsed().as_secs_f64()), "wrote {}", dir.display());
    }
    Ok(())
}
