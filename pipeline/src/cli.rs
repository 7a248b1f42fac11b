//! Command-line front ends: `twoscale` and the stage binaries share these.

use crate::build::build_table;
use twoscale_tables::axis::Axis;
use twoscale_tables::manifest::Manifest;
use crate::progress::Progress;
use crate::table::write_bytes_atomic;
use twoscale_tables::file::{manifest_path, open_table};
use crate::scene::Scene;
use crate::shard::{build_shard, merge, ShardSpec};
use crate::tables::{self, BuildOptions, Method, Preset, SceneTarget, TableDef};
use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Options every command shares.
#[derive(Args, Debug, Clone)]
pub struct Common {
    /// Print only warnings and errors (no progress bars, no info logs).
    #[arg(long, global = true)]
    pub quiet: bool,
    /// Worker threads (default: all cores; also RAYON_NUM_THREADS).
    #[arg(long, global = true, value_name = "N")]
    pub threads: Option<usize>,
}

#[derive(Args, Debug, Clone)]
pub struct BuildArgs {
    /// Preset whose grids to build (paper, default).
    #[arg(long, default_value = "default", value_parser = parse_preset)]
    pub preset: Preset,
    /// Table to build (repeatable; default: every table of this command).
    #[arg(long = "table", value_name = "T")]
    pub tables: Vec<String>,
    /// Output directory; files go to DIR/<preset>/.
    #[arg(long, default_value = "tables-out", value_name = "DIR")]
    pub out: PathBuf,
    /// Zonal-harmonic degree L for zh_convolution (default: 100 for paper, the preset's for default).
    #[arg(long, value_name = "L", value_parser = clap::value_parser!(u32).range(1..=20000))]
    pub degree: Option<u32>,
    /// How zh_convolution computes the convolution: zh, exact or auto.
    #[arg(long, value_parser = parse_method)]
    pub method: Option<Method>,
    /// Rebuild tables that are up to date (same inputs, intact files).
    #[arg(long)]
    pub force: bool,
    /// Build each material's tables of this scene (TOML; see README) into DIR/scene-<name>/<material>/;
    /// with --table or --shard, the default preset's tables over the scene's sub-domain into DIR/scene-<name>/.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Compute only part K of N (0 <= K < N) of each table, into DIR/<preset>/shards/; `twoscale merge` joins them.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    pub shard: Option<ShardSpec>,
}

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// The output directory the shards were built into (their --out).
    #[arg(default_value = "tables-out", value_name = "DIR")]
    pub dir: PathBuf,
    /// Preset directory whose shards to merge: paper, default, or scene-<name>.
    #[arg(long, default_value = "default", value_parser = parse_target)]
    pub preset: String,
    /// Table to merge (repeatable; default: every table with shards there).
    #[arg(long = "table", value_name = "T")]
    pub tables: Vec<String>,
    /// Rewrite tables that are up to date.
    #[arg(long)]
    pub force: bool,
}

#[derive(Args, Debug, Clone)]
pub struct PlanArgs {
    /// The scene file (default: the whole preset).
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Preset to plan when there is no scene (paper, default).
    #[arg(long, default_value = "default", value_parser = parse_preset)]
    pub preset: Preset,
    /// Estimate the time per shard of a build split into N shards.
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub shards: u32,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug, Clone)]
pub struct LookupArgs {
    /// Table name (e.g. epd_g1).
    pub table: String,
    /// Read PATH/<table>.h5 of any folder (a material folder, an unpacked bundle, a preset directory) instead of --tables/--preset.
    #[arg(long = "dir", value_name = "PATH", conflicts_with_all = ["preset", "dir"])]
    pub folder: Option<PathBuf>,
    /// Preset directory to read from: paper, default, or scene-<name> (a scene build).
    #[arg(long, default_value = "default", value_parser = parse_target)]
    pub preset: String,
    /// Directory holding <preset>/<table>.h5 and its manifest.
    #[arg(long = "tables", default_value = "tables-out", value_name = "DIR")]
    pub dir: PathBuf,
    /// Coordinate NAME=VALUE, one per axis (VALUE may be inf).
    #[arg(long = "at", value_name = "NAME=VALUE", required = true)]
    pub at: Vec<String>,
    /// Print JSON: {"table": ..., "values": {...}}.
    #[arg(long)]
    pub json: bool,
}

#[derive(Parser, Debug)]
#[command(name = "twoscale", version, about = "Precompute and query the tables of the two-scale reflectance model")]
pub struct Cli {
    #[command(flatten)]
    pub common: Common,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Build tables of a preset into DIR/<preset>/ (HDF5 + manifest), or one shard of them (--shard K/N).
    Build(BuildArgs),
    /// Check the N shards of each table in DIR/<preset>/shards/ and write the tables as a single build would.
    Merge(MergeArgs),
    /// Interpolate a table at a point, as a renderer should.
    Lookup(LookupArgs),
    /// Check a preset directory or a bundle against its manifests (file and data checksums).
    Verify(VerifyArgs),
    /// Pack a preset's tables into a reproducible, versioned .tar.gz bundle.
    Bundle(BundleArgs),
    /// Write a table for other runtimes: a self-contained C header, or .npy files.
    Export(ExportArgs),
    /// Show which tables and sub-domains a scene (or preset) needs, their size and an estimated time (per shard with --shards).
    Plan(PlanArgs),
    /// Check the invariants of SPEC at and beyond every domain edge (exit 1 on any failure).
    Stress(StressArgs),
    /// Time against error for every table (each setting on 2 threads and on 1): sweeps, published-method baselines, profile.
    Bench(BenchArgs),
    /// Picture of a built table: a slice as heat maps, with the error after interpolation.
    Plot(PlotArgs),
}

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Smaller sweeps and samples (under two minutes on 2 cores).
    #[arg(long)]
    pub quick: bool,
    /// Output directory for <table>.csv, <table>.png and profile.json.
    #[arg(long, default_value = "tables-out/bench", value_name = "DIR")]
    pub out: PathBuf,
    /// Only this table's sweep (repeatable; default: every table, then the profile).
    #[arg(long = "table", value_name = "NAME")]
    pub tables: Vec<String>,
}

#[derive(Args, Debug, Clone)]
pub struct PlotArgs {
    /// Table name (e.g. epd_g1).
    pub table: String,
    /// Preset directory to read from: paper, default, or scene-<name>.
    #[arg(long, default_value = "default", value_parser = parse_target)]
    pub preset: String,
    /// Directory holding <preset>/<table>.h5 and its manifest.
    #[arg(long = "tables", default_value = "tables-out", value_name = "DIR")]
    pub dir: PathBuf,
    /// Output PNG (default: tables-out/plots/<table>-<preset>.png).
    #[arg(long, value_name = "FILE.png")]
    pub out: Option<PathBuf>,
    /// Plot PATH/<table>.h5 of any folder (a material folder) instead of --tables/--preset.
    #[arg(long = "dir", value_name = "PATH", conflicts_with_all = ["preset", "dir"])]
    pub folder: Option<PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub struct StressArgs {
    /// The short version (what `make test` runs).
    #[arg(long)]
    pub quick: bool,
    /// Print {"cases": N, "failures": F, ...} with the failing cases.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug, Clone)]
pub struct ExportArgs {
    /// c-header or npy.
    #[arg(long, value_parser = ["c-header", "npy"])]
    pub format: String,
    /// Table to export.
    #[arg(long)]
    pub table: String,
    /// Export PATH/<table>.h5 of any folder (a material folder, an unpacked bundle) instead of --tables/--preset.
    #[arg(long = "dir", value_name = "PATH", conflicts_with_all = ["preset", "dir"])]
    pub folder: Option<PathBuf>,
    /// Preset directory to export from: paper, default, or scene-<name>.
    #[arg(long, default_value = "default", value_parser = parse_target)]
    pub preset: String,
    /// Directory holding <preset>/ with the built tables.
    #[arg(long = "tables", default_value = "tables-out", value_name = "DIR")]
    pub dir: PathBuf,
    /// Output directory (twoscale_<table>_<preset>.h, or <table>.axis.<a>.npy and <table>.value.<v>.npy).
    #[arg(long, default_value = "tables-out/export", value_name = "DIR")]
    pub out: PathBuf,
}

#[derive(Args, Debug, Clone)]
pub struct VerifyArgs {
    /// A preset directory (e.g. tables-out/paper), a material folder, a scene directory of material folders, or a bundle file (.tar.gz).
    pub path: PathBuf,
}

#[derive(Args, Debug, Clone)]
pub struct BundleArgs {
    /// Preset to bundle.
    #[arg(long, default_value = "default", value_parser = parse_preset)]
    pub preset: Preset,
    /// Bundle the tables of this folder (a material folder), or every material folder of a scene directory, instead of --tables/--preset.
    #[arg(long = "dir", value_name = "PATH", conflicts_with_all = ["preset", "dir"])]
    pub folder: Option<PathBuf>,
    /// Directory holding <preset>/ with the built tables.
    #[arg(long = "tables", default_value = "tables-out", value_name = "DIR")]
    pub dir: PathBuf,
    /// Where to write the bundle.
    #[arg(long, default_value = "tables-out/bundles", value_name = "DIR")]
    pub out: PathBuf,
}

/// A stage binary: `build` for its own tables only.
#[derive(Parser, Debug)]
pub struct StageCli {
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub build: BuildArgs,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse()
}

/// A preset name, or the `scene-<name>` directory of a scene build.
fn parse_target(s: &str) -> Result<String, String> {
    if s.strip_prefix("scene-").is_some_and(|n| !n.is_empty() && !n.contains(['/', '\\'])) {
        return Ok(s.to_string());
    }
    parse_preset(s).map(|p| p.name().to_string()).map_err(|e| format!("{e}, or scene-<name>"))
}

fn parse_shard(s: &str) -> Result<ShardSpec, String> {
    s.parse()
}

fn parse_method(s: &str) -> Result<Method, String> {
    s.parse()
}

/// An error that is the user's input (exit status 2) rather than a failure (1).
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

fn input_error(msg: impl Into<String>) -> anyhow::Error {
    InputError(msg.into()).into()
}

pub fn init(common: &Common) {
    let level = if common.quiet { "warn" } else { "info" };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_target(false)
        .try_init();
    if let Some(n) = common.threads {
        let _ = rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build_global();
    }
}

/// Prints the error on one line and maps it to the exit status.
pub fn report(program: &str, result: Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let line = format!("{e:#}").replace('\n', " ");
            eprintln!("{program}: error: {line}");
            if e.downcast_ref::<InputError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}

/// Builds the requested tables among `allowed` (all of them when none is named).
pub fn run_build(args: &BuildArgs, common: &Common, allowed: &[&'static TableDef]) -> Result<()> {
    let mut selected: Vec<&'static TableDef> = Vec::new();
    for name in &args.tables {
        let def = tables::find(name).map_err(input_error)?;
        if !allowed.iter().any(|d| d.name == def.name) {
            let names: Vec<&str> = allowed.iter().map(|d| d.name).collect();
            return Err(input_error(format!("table {name:?} is not built here (this command builds: {})", names.join(", "))));
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
    };
    if let Some(file) = &args.scene {
        if args.preset != Preset::Default {
            return Err(input_error("--scene builds on the default preset's grids: drop --preset"));
        }
        // Alone, --scene builds each material's tables (SPEC section 8); with
        // --table or --shard, the default preset's tables over the scene's sub-domain.
        if args.shard.is_none() && args.tables.is_empty() {
            let scene = Scene::load(file).map_err(|e| input_error(format!("{e:#}")))?;
            return crate::material::build_scene(&scene, &args.out, &options);
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

/// Merges the shards of the named tables (all by default) of one preset directory.
pub fn run_merge(args: &MergeArgs, common: &Common) -> Result<()> {
    let mut selected: Vec<&'static TableDef> = Vec::new();
    for name in &args.tables {
        selected.push(tables::find(name).map_err(input_error)?);
    }
    if selected.is_empty() {
        selected = tables::TABLES.iter().collect();
    }
    let options = BuildOptions { progress: Progress { quiet: common.quiet }, force: args.force, ..BuildOptions::default() };
    merge(&args.dir, &args.preset, &selected, &options)
}

fn parse_point(at: &[String], axes: &[String]) -> Result<Vec<f64>> {
    let mut point = vec![None; axes.len()];
    for item in at {
        let (name, value) =
            item.split_once('=').ok_or_else(|| input_error(format!("--at {item:?}: expected NAME=VALUE")))?;
        let idx = axes
            .iter()
            .position(|a| a == name)
            .ok_or_else(|| input_error(format!("--at {item:?}: unknown axis {name:?} (axes: {})", axes.join(", "))))?;
        let x: f64 = value
            .trim()
            .parse()
            .map_err(|_| input_error(format!("--at {item:?}: {value:?} is not a number")))?;
        if x.is_nan() {
            return Err(input_error(format!("--at {item:?}: {name} is NaN")));
        }
        if point[idx].replace(x).is_some() {
            return Err(input_error(format!("--at: axis {name:?} given twice")));
        }
    }
    point
        .into_iter()
        .zip(axes)
        .map(|(x, name)| x.ok_or_else(|| input_error(format!("missing --at {name}=VALUE"))))
        .collect()
}

/// A table name as a file stem: a plain name of letters, digits and _.
fn table_name(name: &str) -> Result<&str> {
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_') {
        return Err(input_error(format!("{name:?} is not a table name (lowercase letters, digits and _)")));
    }
    Ok(name)
}

pub fn run_lookup(args: &LookupArgs) -> Result<()> {
    if let Some(dir) = &args.folder {
        let name = table_name(&args.table)?;
        if !manifest_path(dir, name).exists() {
            bail!("no table {name} in {} (no {name}.manifest.json there)", dir.display());
        }
        return print_lookup(&twoscale_tables::lookup::Lookup::open(dir, name)?, name, &args.at, args.json);
    }
    let def = tables::find(&args.table).map_err(input_error)?;
    let dir = args.dir.join(&args.preset);
    if !manifest_path(&dir, def.name).exists() {
        bail!(
            "no {} table for preset {} in {} (build it with `twoscale build --preset {} --table {}`)",
            def.name,
            args.preset,
            args.dir.display(),
            args.preset,
            def.name
        );
    }
    print_lookup(&twoscale_tables::lookup::Lookup::open(&dir, def.name)?, def.name, &args.at, args.json)
}

/// Interpolates `table` at the `--at` coordinates and prints the values.
fn print_lookup(table: &twoscale_tables::lookup::Lookup, name: &str, at: &[String], json: bool) -> Result<()> {
    let point = parse_point(at, &table.coordinates())?;
    let mut out = serde_json::Map::new();
    for (value, v) in table.at(&point).map_err(|e| input_error(e.to_string()))? {
        out.insert(value, serde_json::json!(v));
    }
    if json {
        println!("{}", serde_json::json!({ "table": name, "values": out }));
    } else {
        for (name, v) in &out {
            println!("{name} = {v}");
        }
    }
    Ok(())
}

/// Parses the command line; a usage error is one line on stderr and exit status 2.
fn parse_args<T: Parser>(program: &str) -> Result<T, ExitCode> {
    T::try_parse().map_err(|e| {
        use clap::error::ErrorKind::{DisplayHelp, DisplayHelpOnMissingArgumentOrSubcommand, DisplayVersion};
        if matches!(e.kind(), DisplayHelp | DisplayVersion | DisplayHelpOnMissingArgumentOrSubcommand) {
            let _ = e.print();
            return if e.kind() == DisplayHelpOnMissingArgumentOrSubcommand { ExitCode::from(2) } else { ExitCode::SUCCESS };
        }
        let text = e.to_string();
        let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("invalid arguments");
        eprintln!("{program}: {} (see --help)", first.trim());
        ExitCode::from(2)
    })
}

pub fn run_export(args: &ExportArgs) -> Result<()> {
    let (dir, name) = match &args.folder {
        Some(dir) => (dir.clone(), table_name(&args.table)?),
        None => (args.dir.join(&args.preset), tables::find(&args.table).map_err(input_error)?.name),
    };
    let (manifest, axes, values) = open_table(&dir, name)?;
    if args.format == "npy" {
        for path in crate::export::export_npy(name, &axes, &values, &args.out)? {
            println!("{}", path.display());
        }
        return Ok(());
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let path = args.out.join(format!("{}.h", crate::export::c_prefix(&manifest)));
    let text = crate::export::c_header(&manifest, &axes, &values)?;
    write_bytes_atomic(&path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    println!("{}", path.display());
    Ok(())
}

/// A scene's target and, per table it needs (among `candidates`), the
/// restricted axes and the full grid's entry count. Every input error (the
/// file, a material's field, a range outside the default domain) is found
/// here, before anything is built.
type ScenePlan = (SceneTarget, Vec<(&'static TableDef, Vec<Axis>, usize)>);

fn scene_plan(file: &Path, candidates: &[&'static TableDef]) -> Result<ScenePlan> {
    let scene = Scene::load(file).map_err(|e| input_error(format!("{e:#}")))?;
    let ranges = scene.ranges().into_iter().map(|(a, r)| (a.to_string(), r)).collect();
    let target = SceneTarget { name: scene.name.clone(), sha256: scene.sha256.clone(), ranges };
    let options = BuildOptions { scene: Some(target.clone()), ..Default::default() };
    let mut needed = Vec::new();
    for &def in candidates.iter().filter(|d| !d.diffraction || scene.has_diffraction()) {
        let full = (def.axes)(Preset::Default);
        let entries = full.iter().map(Axis::len).product();
        let (axes, _) = tables::restrict(full, &options)
            .map_err(|e| input_error(format!("{}: {}: {e:#}", file.display(), def.name)))?;
        needed.push((def, axes, entries));
    }
    Ok((target, needed))
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
        let timing = std::fs::read_to_string(Path::new("manifests").join(preset.name()).join(format!("{}.manifest.json", def.name)))
            .ok()
            .and_then(|t| serde_json::from_str::<Manifest>(&t).ok())
            .map(|m| m.timing);
        let full_seconds = timing.as_ref().and_then(|t| t["compute_seconds"].as_f64());
        let scale = entries as f64 / *full_entries as f64;
        let estimated = full_seconds.map(|t| t * scale);
        // Every shard repeats the setup (zh: the F coefficients), and shares the rest.
        let setup = timing.as_ref().and_then(|t| t["setup_seconds"].as_f64()).unwrap_or(0.0) * scale;
        let per_shard = estimated.map(|t| setup.min(t) + (t - setup.min(t)) / shards);
        let sub: Vec<serde_json::Value> = axes
            .iter()
            .map(|a| serde_json::json!({ "axis": a.name, "nodes": a.len(), "min": crate::accuracy::json_f64(a.min()), "max": crate::accuracy::json_f64(a.max()) }))
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
            .materials()
            .iter()
            .map(|m| serde_json::json!({ "material": m.name, "output": format!("{output}/{}", m.name), "tables": m.tables() }))
            .collect(),
        None => Vec::new(),
    };
    let plan = serde_json::json!({ "scene": args.scene.as_ref().map(|_| &name), "preset": preset.name(), "sha256": scene, "output": output, "materials": materials, "tables": rows });
    if args.json {
        println!("{plan}");
    } else {
        for m in &materials {
            let tables: Vec<&str> = m["tables"].as_array().into_iter().flatten().filter_map(|t| t.as_str()).collect();
            println!("material {} -> tables-out/{}/: {}", m["material"].as_str().unwrap_or(""), m["output"].as_str().unwrap_or(""), tables.join(", "));
        }
        if args.scene.is_some() {
            println!("with --table T (the default preset's tables over the scene's sub-domain):");
        }
        println!("{} -> tables-out/{output}/", if args.scene.is_some() { format!("scene {name}") } else { format!("preset {name}") });
        for r in &rows {
            let secs = |key: &str, digits: usize| r[key].as_f64().map_or("?".to_string(), |t| format!("{t:.digits$} s"));
            let sharded = if args.shards > 1 { format!(", {} per shard of {}", secs("estimated_seconds_per_shard", 3), args.shards) } else { String::new() };
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
                println!("      {:<19} {:>5} nodes  [{}, {}]", a["axis"].as_str().unwrap_or(""), a["nodes"], a["min"], a["max"]);
            }
        }
    }
    Ok(())
}

pub fn run_stress(args: &StressArgs) -> Result<()> {
    let report = crate::stress::run(args.quick);
    if args.json {
        println!("{report}");
    } else {
        println!("{} cases, {} failures", report["cases"], report["failures"]);
        for f in report["failed"].as_array().into_iter().flatten() {
            println!("  {} at {}: {}", f["check"].as_str().unwrap_or(""), f["at"], f["detail"].as_str().unwrap_or(""));
        }
    }
    if report["failures"] != 0 {
        bail!("{} stress cases failed", report["failures"]);
    }
    Ok(())
}

/// Runs the sweeps, then prints each table's files and speed ratios.
pub fn run_bench(args: &BenchArgs, common: &Common) -> Result<()> {
    let options = crate::bench::BenchOptions { quick: args.quick, progress: Progress { quiet: common.quiet } };
    let start = std::time::Instant::now();
    let (benches, profile) = crate::bench::run(options, &args.out, &args.tables)?;
    for bench in benches {
        println!("{}: {} settings -> {}", bench.table, bench.rows.len(), args.out.join(format!("{}.{{csv,png}}", bench.table)).display());
        for line in crate::bench::speed_ratios(&bench) {
            println!("  {line}");
        }
    }
    if let Some(profile) = profile {
        println!("profile (paper tables, 1 thread) -> {}", args.out.join("profile.json").display());
        for line in crate::bench::profile::summary(&profile) {
            println!("  {line}");
        }
    }
    println!("bench took {:.0} s", start.elapsed().as_secs_f64());
    Ok(())
}

pub fn run_plot(args: &PlotArgs) -> Result<()> {
    let (dir, name, label) = match &args.folder {
        Some(dir) => {
            let label = dir.file_name().map_or_else(|| "folder".into(), |n| n.to_string_lossy().into_owned());
            (dir.clone(), table_name(&args.table)?, label)
        }
        None => (args.dir.join(&args.preset), tables::find(&args.table).map_err(input_error)?.name, args.preset.clone()),
    };
    if !manifest_path(&dir, name).exists() {
        bail!("no {name} table in {} (build it with `twoscale build`)", dir.display());
    }
    let out = args.out.clone().unwrap_or_else(|| args.dir.join("plots").join(format!("{name}-{label}.png")));
    if out.extension().and_then(|e| e.to_str()) != Some("png") {
        return Err(input_error(format!("--out {} must end in .png", out.display())));
    }
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    let summary = crate::slices::plot_table(&dir, name, &out)?;
    println!("{summary}\n{}", out.display());
    Ok(())
}

/// A preset's bundle, or a folder's: named for its tables' target (a material folder's `scene-<scene>/<material>`).
fn run_bundle(args: &BundleArgs) -> Result<PathBuf> {
    let Some(dir) = &args.folder else {
        return crate::bundle::write_bundle(&args.dir.join(args.preset.name()), args.preset.name(), &args.out);
    };
    if !crate::verify::holds_manifests(dir)? {
        return crate::bundle::write_scene_bundle(dir, &args.out);
    }
    // The folder's target, from its first manifest; write_bundle verifies every table.
    let first = crate::verify::table_names(dir)?.remove(0);
    let target = twoscale_tables::file::read_manifest(dir, &first)?.preset;
    crate::bundle::write_bundle(dir, &target, &args.out)
}

fn tempfile_dir() -> Result<tempfile::TempDir> {
    tempfile::tempdir().context("cannot create a temporary directory")
}

/// Prints one line per table; an error naming every table that fails.
pub fn run_verify(args: &VerifyArgs) -> Result<()> {
    let unpacked = tempfile_dir()?;
    let dir = if args.path.is_file() { crate::bundle::unpack_bundle(&args.path, unpacked.path())? } else { args.path.clone() };
    let verdicts = crate::verify::verify_tree(&dir)?;
    let mut failed = Vec::new();
    for v in &verdicts {
        match &v.result {
            Ok(()) => println!("ok      {}", v.table),
            Err(e) => {
                println!("FAILED  {}: {}", v.table, format!("{e:#}").replace('\n', " "));
                failed.push(v.table.clone());
            }
        }
    }
    if !failed.is_empty() {
        bail!("{} of {} tables failed verification: {}", failed.len(), verdicts.len(), failed.join(", "));
    }
    Ok(())
}

pub fn main_twoscale() -> ExitCode {
    let cli: Cli = match parse_args("twoscale") {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    init(&cli.common);
    let result = match &cli.command {
        Command::Build(args) => {
            let all: Vec<&'static TableDef> = tables::TABLES.iter().collect();
            run_build(args, &cli.common, &all)
        }
        Command::Merge(args) => run_merge(args, &cli.common),
        Command::Lookup(args) => run_lookup(args),
        Command::Verify(args) => run_verify(args),
        Command::Export(args) => run_export(args),
        Command::Plan(args) => run_plan(args),
        Command::Stress(args) => run_stress(args),
        Command::Bench(args) => run_bench(args, &cli.common),
        Command::Plot(args) => run_plot(args),
        Command::Bundle(args) => run_bundle(args).map(|path| println!("{}", path.display())),
    };
    report("twoscale", result)
}

/// Entry point of a stage binary building the tables whose `stage` is `stage`.
pub fn main_stage(stage: &'static str) -> ExitCode {
    let cli: StageCli = match parse_args(stage) {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    init(&cli.common);
    let own: Vec<&'static TableDef> = tables::TABLES.iter().filter(|t| t.stage == stage).collect();
    report(stage, run_build(&cli.build, &cli.common, &own))
}
