//! Sharded builds for clusters: `build --shard K/N` computes the K-th of N
//! parts of a table's units of work (see `tables::Job`) into
//! `DIR/<target>/shards/<table>.shard-K-of-N.{h5,json}`; `merge` checks that
//! the N parts are all there, intact and from the same inputs, puts the units
//! back in order and finishes the table as a single build does (same data,
//! same accuracy section), so the merged checksums do not depend on N.
//!
//! A shard's HDF5 file holds its columns as 1-D datasets (`/values/<name>`
//! float32, `/extras/<name>` float64: `unit_len` entries per unit, units in
//! increasing order); its JSON manifest names the table, target, options
//! (exactly, to rebuild the job), inputs (the table's, with their hash),
//! generator, part, the SHA-256 of each column and of the file, and timing.

use crate::build::{generator, generator_identity, inputs, target_name, up_to_date, write_table, VERSION};
use crate::tables::Range;
use crate::tables::{self, BuildOptions, Job, Method, Part, Preset, SceneTarget, TableDef, Units};
use anyhow::{anyhow, bail, Context, Result};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Instant;
use tracing::info;
use twoscale_tables::checksum::{sha256_f32, sha256_f64, sha256_file};
use twoscale_tables::manifest::{FileEntry, Generator};
use twoscale_tables::table::{str_attr, write_atomic, write_json_atomic};

pub const FORMAT: &str = "twoscale-shard/1";

/// Part K of N (0 <= K < N).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct ShardSpec {
    pub index: usize,
    pub count: usize,
}

impl FromStr for ShardSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("{s:?} is not K/N with 0 <= K < N (e.g. 0/4)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) =
            (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if index >= count {
            return Err(bad());
        }
        Ok(ShardSpec { index, count })
    }
}

impl fmt::Display for ShardSpec {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The options of a build, recorded exactly (f64 as bit patterns) so that
/// `merge` rebuilds the same job.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ShardOptions {
    pub degree: Option<usize>,
    pub method: Option<String>,
    pub scene: Option<SceneOptions>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SceneOptions {
    pub name: String,
    pub sha256: String,
    /// (axis, lo bits, hi bits), the f64 bits in hexadecimal.
    pub ranges: Vec<(String, String, String)>,
}

impl ShardOptions {
    fn of(preset: Preset, options: &BuildOptions) -> (String, ShardOptions) {
        let scene = options.scene.as_ref().map(|s| SceneOptions {
            name: s.name.clone(),
            sha256: s.sha256.clone(),
            ranges: s
                .ranges
                .iter()
                .map(|(a, r)| (a.clone(), format!("{:016x}", r.lo.to_bits()), format!("{:016x}", r.hi.to_bits())))
                .collect(),
        });
        let recorded =
            ShardOptions { degree: options.degree, method: options.method.map(|m| m.name().to_string()), scene };
        (preset.name().to_string(), recorded)
    }

    fn build_options(&self, base: &BuildOptions) -> Result<BuildOptions> {
        let bits =
            |h: &str| u64::from_str_radix(h, 16).map(f64::from_bits).map_err(|_| anyhow!("bad range bits {h:?}"));
        let scene = match &self.scene {
            None => None,
            Some(s) => Some(SceneTarget {
                name: s.name.clone(),
                sha256: s.sha256.clone(),
                ranges: s
                    .ranges
                    .iter()
                    .map(|(a, lo, hi)| Ok((a.clone(), Range { lo: bits(lo)?, hi: bits(hi)? })))
                    .collect::<Result<_>>()?,
            }),
        };
        let method = self.method.as_deref().map(Method::from_str).transpose().map_err(|e| anyhow!(e))?;
        Ok(BuildOptions { degree: self.degree, method, scene, ..base.clone() })
    }
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Column {
    pub name: String,
    /// "value" (float32, a stored value) or "extra" (float64, for the finish only).
    pub kind: String,
    pub len: usize,
    pub sha256: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PartEntry {
    pub index: usize,
    pub count: usize,
    /// Units of the whole table, and those of this part (index, index + count, ...).
    pub units_total: usize,
    pub units: usize,
    pub unit: String,
    pub unit_len: usize,
}

/// `<table>.shard-K-of-N.json`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ShardManifest {
    pub format: String,
    pub table: String,
    pub preset: String,
    pub target: String,
    pub part: PartEntry,
    pub generator: Generator,
    pub options: ShardOptions,
    /// The table's inputs (as in its manifest), whose hash every part of one table shares.
    pub inputs: Value,
    pub columns: Vec<Column>,
    pub file: FileEntry,
    pub timing: Value,
}

/// `DIR/<target>/shards/`.
pub fn shards_dir(out: &Path, target: &str) -> PathBuf {
    out.join(target).join("shards")
}

fn shard_stem(table: &str, spec: ShardSpec) -> String {
    format!("{table}.shard-{}-of-{}", spec.index, spec.count)
}

/// (table, spec) from a shard manifest's file name.
fn parse_stem(file_name: &str) -> Option<(String, ShardSpec)> {
    let stem = file_name.strip_suffix(".json")?;
    let (table, part) = stem.split_once(".shard-")?;
    let (k, n) = part.split_once("-of-")?;
    let spec = ShardSpec { index: k.parse().ok()?, count: n.parse().ok()? };
    (spec.index < spec.count).then(|| (table.to_string(), spec))
}

fn columns(part: &Part) -> Vec<Column> {
    let values = part.values.iter().map(|(n, v)| Column {
        name: n.clone(),
        kind: "value".into(),
        len: v.len(),
        sha256: sha256_f32(v),
    });
    let extras = part.extras.iter().map(|(n, v)| Column {
        name: n.clone(),
        kind: "extra".into(),
        len: v.len(),
        sha256: sha256_f64(v),
    });
    values.chain(extras).collect()
}

/// The part's columns as a shard file (atomically, no timestamps).
fn write_part(path: &Path, manifest: &ShardManifest, part: &Part) -> Result<()> {
    write_atomic(path, |tmp| {
        let file = hdf5::File::with_options().with_fcpl(|p| p.obj_track_times(false)).create(tmp)?;
        str_attr(&file, "format", FORMAT)?;
        str_attr(&file, "table", &manifest.table)?;
        str_attr(&file, "target", &manifest.target)?;
        str_attr(&file, "part", &format!("{}/{}", manifest.part.index, manifest.part.count))?;
        str_attr(&file, "generator_version", VERSION)?;
        let values = file.create_group_builder().obj_track_times(false).create("values")?;
        for (name, data) in &part.values {
            values.new_dataset_builder().with_data(data.as_slice()).create(name.as_str())?;
        }
        let extras = file.create_group_builder().obj_track_times(false).create("extras")?;
        for (name, data) in &part.extras {
            extras.new_dataset_builder().with_data(data.as_slice()).create(name.as_str())?;
        }
        file.close()?;
        Ok(())
    })
}

/// Reads the shard file `dir/<stem>.h5` and checks its columns against its
/// manifest, after its size and SHA-256: HDF5 never sees unverified bytes.
fn read_part(dir: &Path, stem: &str, manifest: &ShardManifest) -> Result<Part> {
    if manifest.file.path != format!("{stem}.h5") {
        bail!("its manifest names the file {:?}, not {stem:?}.h5", manifest.file.path);
    }
    let path = &dir.join(&manifest.file.path);
    let bytes = std::fs::metadata(path).with_context(|| format!("cannot read {}", path.display()))?.len();
    if bytes != manifest.file.bytes || sha256_file(path)? != manifest.file.sha256 {
        bail!("{} does not match the checksum in its manifest", path.display());
    }
    let file = hdf5::File::open(path).with_context(|| format!("{}: not a readable shard", path.display()))?;
    let mut part = Part::default();
    let expected = manifest.part.units * manifest.part.unit_len;
    for col in &manifest.columns {
        let (len, sha) = match col.kind.as_str() {
            "value" => {
                let data = file.dataset(&format!("values/{}", col.name))?.read_raw::<f32>()?;
                let found = (data.len(), sha256_f32(&data));
                part.values.push((col.name.clone(), data));
                found
            }
            "extra" => {
                let data = file.dataset(&format!("extras/{}", col.name))?.read_raw::<f64>()?;
                let found = (data.len(), sha256_f64(&data));
                part.extras.push((col.name.clone(), data));
                found
            }
            other => bail!("column {} has unknown kind {other:?}", col.name),
        };
        if len != expected || col.len != expected {
            bail!("column {} has {len} entries, {expected} expected", col.name);
        }
        if sha != col.sha256 {
            bail!("column {} does not match its checksum", col.name);
        }
    }
    Ok(part)
}

/// Whether the shard is finished with these inputs (all of them, not only
/// their hash) and its file verifies: then there is nothing to compute.
fn shard_up_to_date(dir: &Path, table: &str, spec: ShardSpec, inputs: &Value) -> bool {
    let stem = shard_stem(table, spec);
    let Ok(text) = std::fs::read_to_string(dir.join(format!("{stem}.json"))) else { return false };
    let Ok(manifest) = serde_json::from_str::<ShardManifest>(&text) else { return false };
    manifest.inputs == *inputs
        && manifest.generator == generator()
        && (manifest.part.index, manifest.part.count) == (spec.index, spec.count)
        && read_part(dir, &stem, &manifest).is_ok()
}

/// Computes part `spec` of a table into `out/<target>/shards/`; a finished
/// part with the same inputs (and an intact file) is kept.
pub fn build_shard(def: &TableDef, preset: Preset, out: &Path, options: &BuildOptions, spec: ShardSpec) -> Result<()> {
    let target = target_name(preset, options);
    let dir = shards_dir(out, &target);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
    let inputs = inputs(def, preset, options)?;
    if !options.force && shard_up_to_date(&dir, def.name, spec, &inputs) {
        info!(table = def.name, target, shard = %spec, "up to date");
        return Ok(());
    }
    let job = (def.job)(preset, options)?;
    let units = Units::shard(job.units(), spec.index, spec.count);
    info!(table = def.name, target, shard = %spec, units = units.count, of = job.units(), "building");
    let part = job.compute(units, options.progress);
    let stem = shard_stem(def.name, spec);
    let h5 = dir.join(format!("{stem}.h5"));
    let (preset_name, recorded) = ShardOptions::of(preset, options);
    let mut manifest = ShardManifest {
        format: FORMAT.into(),
        table: def.name.into(),
        preset: preset_name,
        target: target.clone(),
        part: PartEntry {
            index: spec.index,
            count: spec.count,
            units_total: job.units(),
            units: units.count,
            unit: job.unit_name().into(),
            unit_len: job.unit_len(),
        },
        generator: generator(),
        options: recorded,
        inputs,
        columns: columns(&part),
        file: FileEntry { path: format!("{stem}.h5"), bytes: 0, sha256: String::new() },
        timing: json!({
            "compute_seconds": part.compute_seconds,
            "setup_seconds": part.setup_seconds,
            "threads": rayon::current_num_threads(),
            "stages": part.stages,
        }),
    };
    write_part(&h5, &manifest, &part).with_context(|| format!("cannot write {}", h5.display()))?;
    manifest.file.bytes = std::fs::metadata(&h5).with_context(|| format!("cannot read back {}", h5.display()))?.len();
    manifest.file.sha256 = sha256_file(&h5)?;
    let path = dir.join(format!("{stem}.json"));
    write_json_atomic(&path, &manifest)?;
    info!(table = def.name, target, shard = %spec, compute_s = format!("{:.3}", part.compute_seconds), "wrote {}", h5.display());
    Ok(())
}

/// Every part of one table, checked, with the job that finishes it.
struct Checked {
    def: &'static TableDef,
    inputs: Value,
    job: Box<dyn Job>,
    parts: Vec<(ShardManifest, Part)>,
}

/// A check failure: the one line names the shard and its file.
fn shard_error(table: &str, spec: ShardSpec, path: &Path, what: impl fmt::Display) -> anyhow::Error {
    anyhow!("shard {spec} of {table} ({}) {what}", path.display())
}

/// Checks the N parts of `table` found in `dir` (`files`: spec -> manifest path).
fn check_table(
    dir: &Path,
    target: &str,
    def: &'static TableDef,
    files: &BTreeMap<ShardSpec, PathBuf>,
    base: &BuildOptions,
) -> Result<Checked> {
    // N is what most files say; a file of another N is foreign to this set.
    let mut counts: BTreeMap<usize, usize> = BTreeMap::new();
    for spec in files.keys() {
        *counts.entry(spec.count).or_default() += 1;
    }
    let n = counts.iter().max_by_key(|(n, c)| (**c, **n)).map(|(n, _)| *n).expect("at least one shard");
    if let Some((spec, path)) = files.iter().find(|(s, _)| s.count != n) {
        return Err(shard_error(
            def.name,
            *spec,
            path,
            format!("is foreign: the other shards of {} are parts of {n}", def.name),
        ));
    }
    let mut parts = Vec::new();
    let mut first: Option<(ShardSpec, Value)> = None;
    let mut checked: Option<(Value, Box<dyn Job>)> = None;
    for index in 0..n {
        let spec = ShardSpec { index, count: n };
        let path = dir.join(format!("{}.json", shard_stem(def.name, spec)));
        let Some(path) = files.get(&spec) else {
            return Err(shard_error(def.name, spec, &path, "is missing (build it with --shard; the others are there)"));
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| shard_error(def.name, spec, path, format!("cannot be read: {e}")))?;
        let manifest: ShardManifest = serde_json::from_str(&text)
            .map_err(|e| shard_error(def.name, spec, path, format!("is corrupt: malformed manifest ({e})")))?;
        if manifest.format != FORMAT || manifest.table != def.name {
            return Err(shard_error(
                def.name,
                spec,
                path,
                format!("is foreign: format {:?}, table {:?}", manifest.format, manifest.table),
            ));
        }
        if (manifest.part.index, manifest.part.count) != (index, n) {
            return Err(shard_error(
                def.name,
                spec,
                path,
                format!("is a duplicate: it holds part {}/{}", manifest.part.index, manifest.part.count),
            ));
        }
        if manifest.target != target {
            return Err(shard_error(
                def.name,
                spec,
                path,
                format!("is foreign: it belongs to {}, not {target}", manifest.target),
            ));
        }
        if manifest.generator != generator() || manifest.inputs["what"]["generator"] != generator_identity()? {
            return Err(shard_error(
                def.name,
                spec,
                path,
                format!(
                    "is foreign: built by another generator ({} {}, executable sha256 {}) than this twoscale",
                    manifest.generator.name,
                    manifest.generator.version,
                    manifest.inputs["what"]["generator"]["executable_sha256"]
                ),
            ));
        }
        match &first {
            None => first = Some((spec, manifest.inputs.clone())),
            Some((spec0, inputs0)) if inputs0["sha256"] != manifest.inputs["sha256"] => {
                let differs: Vec<String> = inputs0["what"]
                    .as_object()
                    .into_iter()
                    .flatten()
                    .filter(|(k, v)| manifest.inputs["what"][k.as_str()] != **v)
                    .map(|(k, v)| format!("{k} {} vs {v}", manifest.inputs["what"][k.as_str()]))
                    .collect();
                return Err(shard_error(
                    def.name,
                    spec,
                    path,
                    format!("is foreign: other inputs than shard {spec0} ({})", differs.join(", ")),
                ));
            }
            Some(_) => {}
        }
        if checked.is_none() {
            let preset: Preset = manifest
                .preset
                .parse()
                .map_err(|e: String| shard_error(def.name, spec, path, format!("is corrupt: {e}")))?;
            let options = manifest
                .options
                .build_options(base)
                .map_err(|e| shard_error(def.name, spec, path, format!("is corrupt: {e}")))?;
            let expected = inputs(def, preset, &options)?;
            if expected["sha256"] != manifest.inputs["sha256"] || target_name(preset, &options) != target {
                return Err(shard_error(def.name, spec, path, "is foreign: its options do not give its inputs"));
            }
            let job = (def.job)(preset, &options)
                .map_err(|e| shard_error(def.name, spec, path, format!("cannot be merged: {e:#}")))?;
            checked = Some((expected, job));
        }
        let job = &checked.as_ref().expect("set above").1;
        let units = Units::shard(job.units(), index, n);
        if (manifest.part.units_total, manifest.part.units, manifest.part.unit_len)
            != (job.units(), units.count, job.unit_len())
        {
            return Err(shard_error(def.name, spec, path, "is corrupt: its unit counts do not match the table's"));
        }
        let part = read_part(dir, &shard_stem(def.name, spec), &manifest)
            .map_err(|e| shard_error(def.name, spec, path, format!("is corrupt: {e:#}")))?;
        parts.push((manifest, part));
    }
    let (inputs, job) = checked.expect("n >= 1");
    Ok(Checked { def, inputs, job, parts })
}

/// The parts' columns with every unit back in its place.
fn assemble(job: &dyn Job, parts: &[(ShardManifest, Part)]) -> Part {
    let (n, len, total) = (parts.len(), job.unit_len(), job.units());
    fn interleave<T: Copy + Default>(columns: Vec<&[T]>, len: usize, total: usize) -> Vec<T> {
        let mut out = vec![T::default(); total * len];
        for (k, col) in columns.iter().enumerate() {
            for (j, unit) in Units::shard(total, k, columns.len()).iter().enumerate() {
                out[unit * len..(unit + 1) * len].copy_from_slice(&col[j * len..(j + 1) * len]);
            }
        }
        out
    }
    let first = &parts[0].1;
    let values = (first.values.iter().enumerate())
        .map(|(i, (name, _))| {
            (name.clone(), interleave(parts.iter().map(|(_, p)| p.values[i].1.as_slice()).collect(), len, total))
        })
        .collect();
    let extras = (first.extras.iter().enumerate())
        .map(|(i, (name, _))| {
            (name.clone(), interleave(parts.iter().map(|(_, p)| p.extras[i].1.as_slice()).collect(), len, total))
        })
        .collect();
    let timing = |key: &str| parts.iter().map(|(m, _)| m.timing[key].as_f64().unwrap_or(0.0)).sum::<f64>();
    // Stages: each key summed over the parts.
    let mut stages = serde_json::Map::new();
    for (m, _) in parts {
        for (k, v) in m.timing["stages"].as_object().into_iter().flatten() {
            let sum = stages.get(k).and_then(Value::as_f64).unwrap_or(0.0) + v.as_f64().unwrap_or(0.0);
            stages.insert(k.clone(), json!(sum));
        }
    }
    Part {
        values,
        extras,
        compute_seconds: timing("compute_seconds"),
        setup_seconds: timing("setup_seconds") / n as f64,
        stages: if stages.is_empty() { Value::Null } else { Value::Object(stages) },
    }
}

/// Checks the shards of every table in `out/<target>/shards/` (or of
/// `tables` only), then writes each table and its manifest into
/// `out/<target>/` as a single build would. Any bad shard is an error before
/// anything is written; an up-to-date table is kept unless `base.force`.
pub fn merge(out: &Path, target: &str, tables: &[&'static TableDef], base: &BuildOptions) -> Result<()> {
    let dir = shards_dir(out, target);
    let entries =
        std::fs::read_dir(&dir).with_context(|| format!("no shards to merge: cannot read {}", dir.display()))?;
    let mut found: BTreeMap<&'static str, BTreeMap<ShardSpec, PathBuf>> = BTreeMap::new();
    for entry in entries {
        let name = entry?.file_name().to_string_lossy().into_owned();
        let Some((table, spec)) = parse_stem(&name) else { continue };
        let def = tables::find(&table).map_err(|e| anyhow!("{}: foreign shard: {e}", dir.join(&name).display()))?;
        if tables.iter().any(|d| d.name == def.name) {
            found.entry(def.name).or_default().insert(spec, dir.join(&name));
        }
    }
    if found.is_empty() {
        bail!("no shards to merge in {}", dir.display());
    }
    let mut checked = Vec::new();
    for (table, files) in &found {
        let def = tables::find(table).map_err(|e| anyhow!(e))?;
        checked.push(check_table(&dir, target, def, files, base)?);
    }
    let table_dir = out.join(target);
    for c in checked {
        if !base.force {
            if let Some(_existing) = up_to_date(&table_dir, c.def.name, &c.inputs["sha256"]) {
                info!(table = c.def.name, target, "up to date");
                continue;
            }
        }
        let start = Instant::now();
        info!(table = c.def.name, target, shards = c.parts.len(), "merging");
        let whole = assemble(c.job.as_ref(), &c.parts);
        let setup_seconds = whole.setup_seconds;
        let built = c.job.finish(whole);
        let per_shard = |key: &str| c.parts.iter().map(|(m, _)| m.timing[key].clone()).collect::<Vec<Value>>();
        let mut timing = crate::build::timing(&built, setup_seconds);
        timing["shards"] = json!({
            "count": c.parts.len(),
            "compute_seconds": per_shard("compute_seconds"),
            "threads": per_shard("threads"),
            "merge_seconds": start.elapsed().as_secs_f64(),
        });
        write_table(c.def, &table_dir, target, built, c.inputs, timing)?;
    }
    Ok(())
}
