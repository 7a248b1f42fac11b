//! Each command's arguments.

use super::values::{parse_method, parse_preset, parse_sample_count, parse_shard, parse_target, parse_wavelengths};
pub use super::values::{SampleCount, Wavelengths};
use clap::Args;
use std::path::PathBuf;
use twoscale_generate::shard::ShardSpec;
use twoscale_generate::tables::{Method, Preset};

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
    /// c-header, npy, or webgl (GPU textures: a material folder's <table>.bin and material.json; without --dir, the
    /// default preset's general tables, <table>.bin and tables.json: runtimes/webgl/README.md).
    #[arg(long, value_parser = ["c-header", "npy", "webgl"])]
    pub format: String,
    /// Table to export (not with webgl). Without it, --dir names a material folder and every table of it is exported
    /// (with c-header, also twoscale_material_<preset>.h: the material for runtimes/c/twoscale_brdf.h; with webgl,
    /// --dir may also be a scene directory, each material into OUT/<material>/).
    #[arg(long)]
    pub table: Option<String>,
    /// Export PATH/<table>.h5 of any folder (a material folder, an unpacked bundle) instead of --tables/--preset.
    #[arg(long = "dir", value_name = "PATH", conflicts_with_all = ["preset", "dir"])]
    pub folder: Option<PathBuf>,
    /// Preset directory to export from: paper, default, or scene-<name>.
    #[arg(long, default_value = "default", value_parser = parse_target)]
    pub preset: String,
    /// Directory holding <preset>/ with the built tables.
    #[arg(long = "tables", default_value = "tables-out", value_name = "DIR")]
    pub dir: PathBuf,
    /// Output directory (twoscale_<table>_<preset>.h, or <table>.axis.<a>.npy and <table>.value.<v>.npy; for a whole material, each table's and twoscale_material_<preset>.h; with webgl, material.json and <table>.bin).
    #[arg(long, default_value = "tables-out/export", value_name = "DIR")]
    pub out: PathBuf,
    /// With webgl: sign each export's SHA256SUMS with this secret key (SHA256SUMS.minisig, minisign's legacy
    /// algorithm, which browsers verify with Ed25519 alone).
    #[arg(long, value_name = "NAME.key")]
    pub sign: Option<PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// A material folder (e.g. tables-out/scene-materials/nickel), or a default-preset folder (e.g.
    /// tables-out/default): its general tables, every parameter a slider. Without it, --preset.
    pub folder: Option<PathBuf>,
    /// With no folder: the preset whose general tables are served (default).
    #[arg(long, value_parser = ["default"])]
    pub preset: Option<String>,
    /// Directory holding <preset>/ with the built tables (with --preset).
    #[arg(long = "tables", default_value = "tables-out", value_name = "DIR")]
    pub tables: PathBuf,
    /// General tables: start from a material of this scene file (.toml), or of a fit's .fit.json.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// With --scene: the material's name (default: the scene's first).
    #[arg(long, requires = "scene")]
    pub material: Option<String>,
    /// Port on 127.0.0.1 (0: any free port).
    #[arg(long, default_value_t = 0)]
    pub port: u16,
}

#[derive(Args, Debug, Clone)]
pub struct VerifyArgs {
    /// A preset directory (e.g. tables-out/paper), a material folder, a scene directory of material folders, or a bundle file (.tar.gz).
    pub path: PathBuf,
    /// A bundle's public key (NAME.pub, minisign's format): its signature BUNDLE.minisig is checked before
    /// anything of it is read, and a bundle without one is refused (docs/file_contract.md "Signatures").
    #[arg(long, value_name = "NAME.pub", conflicts_with = "key_string")]
    pub key: Option<PathBuf>,
    /// The public key as the base64 line of its .pub file.
    #[arg(long, value_name = "BASE64")]
    pub key_string: Option<String>,
}

#[derive(Args, Debug, Clone)]
pub struct KeygenArgs {
    /// Writes NAME.key (the secret key, mode 0600) and NAME.pub, in minisign's formats; neither may exist. A NAME
    /// ending in .key names the secret key itself (x.key and x.pub).
    #[arg(long, value_name = "NAME")]
    pub out: PathBuf,
    /// Leave the secret key unencrypted (as `minisign -G -W`); by default it is encrypted (scrypt) with the
    /// password in the environment variable TWOSCALE_KEY_PASSWORD.
    #[arg(long)]
    pub unencrypted: bool,
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
    /// Sign the bundle with this secret key (`twoscale keygen`; an encrypted one reads its password from
    /// TWOSCALE_KEY_PASSWORD): writes BUNDLE.tar.gz.minisig beside it.
    #[arg(long, value_name = "NAME.key")]
    pub sign: Option<PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub struct FitArgs {
    /// A measured isotropic BRDF: a MERL file (90 x 90 x 180 bins, float64 RGB) or an RGL-EPFL RGB file (*_rgb.bsdf,
    /// Mitsuba's `measured` format), told apart by their first bytes (docs/fit.md "The files").
    pub file: PathBuf,
    /// The scene file to write (`twoscale build --scene` takes it); the fit's result, with the conductor's eta and k
    /// per channel, goes beside it as <stem>.fit.json. Default: <file stem>.toml in the current directory.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The wavelengths (micrometres) the red, green and blue channels are evaluated at.
    #[arg(long, default_value = "0.65,0.55,0.45", value_parser = parse_wavelengths)]
    pub wavelengths: Wavelengths,
    /// The material model fitted: conductor (docs/maths.md section 7), plastic (section 10), subsurface (section 11),
    /// or auto, the default (all three; the simplest whose render a richer one's does not beat, by render SMAPE
    /// lower by 1 % and 0.005, is written; each one's loss and render SMAPE reported under "models").
    #[arg(long, default_value = "auto", value_parser = ["conductor", "plastic", "subsurface", "auto"])]
    pub model: String,
    /// Also fit, on the same samples and with the same loss, the comparison models ggx_lambert, beckmann_lambert and
    /// epd_lambert (a microfacet coat of conductor Fresnel over a Lambertian base), low_smooth and abc (Loew et al.
    /// 2012), sgd (Bagher et al. 2012) and he (He et al. 1991), docs/fit.md "Comparing models", and print a table of
    /// every model's error; --json adds "comparison" and "compared". A file of one of the 100 MERL materials (by
    /// --name or the file's stem) adds the published fits' rows, abc_published and sgd_published (not fitted).
    #[arg(long)]
    pub compare: bool,
    /// With --compare: also write a report into DIR (a new or empty folder): index.html with the spheres' renders
    /// and error maps, slices in the plane of incidence and every model's parameters and errors (docs/fit.md "The
    /// report").
    #[arg(long, value_name = "DIR", requires = "compare")]
    pub report: Option<PathBuf>,
    /// Directory holding default/ with the general tables (epd_g1, epd_norm, kcorr_renorm, zh_lobe): the missing
    /// ones are built there first.
    #[arg(long = "tables", default_value = "tables-out", value_name = "DIR")]
    pub tables: PathBuf,
    /// Samples Levenberg-Marquardt fits, drawn by a hash of the sample with a probability that follows its weight in
    /// the loss, or `all` (every valid sample; slower, docs/fit.md has what each costs). The error is always measured
    /// over every valid sample.
    #[arg(long, default_value = "10000", value_parser = parse_sample_count, value_name = "N|all")]
    pub samples: SampleCount,
    /// Also write a PNG: the file's sphere beside the written fit's (docs/fit.md "The render", at 128 x 128, the
    /// same exposure for both).
    #[arg(long, value_name = "PNG")]
    pub render: Option<PathBuf>,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// The material's name in the scene file (default: the file's stem).
    #[arg(long)]
    pub name: Option<String>,
}
