//! The command line's definitions (clap): `Cli` (`twoscale` and its
//! subcommands), `StageCli` (a stage binary), the options every command
//! shares, and how a usage error is reported. Each command's own arguments
//! are in `args`, the parsers of their values in `values`.

mod args;
mod values;

pub use args::*;
use clap::{Args, Parser, Subcommand};
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
    /// Check a preset directory or a bundle against its manifests (file and data checksums), and a bundle's signature (--key).
    Verify(VerifyArgs),
    /// Make a key pair for signing bundles and exports (minisign's formats): NAME.key and NAME.pub.
    Keygen(KeygenArgs),
    /// Pack a preset's tables into a reproducible, versioned .tar.gz bundle.
    Bundle(BundleArgs),
    /// Write a table for other runtimes: a self-contained C header, .npy files, or a material as WebGL textures.
    Export(ExportArgs),
    /// Open a material folder in the BRDF explorer: export it for WebGL, serve it on 127.0.0.1 and print the URL.
    View(ViewArgs),
    /// Fit the two-scale model to a measured BRDF (a MERL file) with the general tables: a scene file and the fit's JSON.
    Fit(FitArgs),
    /// Show which tables and sub-domains a scene (or preset) needs, their size and an estimated time (per shard with --shards).
    Plan(PlanArgs),
    /// Check the invariants of docs/maths.md at and beyond every domain edge (exit 1 on any failure).
    Stress(StressArgs),
    /// Time against error for every table (each setting on 2 threads and on 1): sweeps, published-method baselines, profile.
    Bench(BenchArgs),
    /// Picture of a built table: a slice as heat maps, with the error after interpolation.
    Plot(PlotArgs),
}

/// A stage binary: `build` for its own tables only.
#[derive(Parser, Debug)]
pub struct StageCli {
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub build: BuildArgs,
}

/// Parses the command line; a usage error is one line on stderr and exit status 2.
pub fn parse_args<T: Parser>(program: &str) -> Result<T, ExitCode> {
    T::try_parse().map_err(|e| {
        use clap::error::ErrorKind::{DisplayHelp, DisplayHelpOnMissingArgumentOrSubcommand, DisplayVersion};
        if matches!(e.kind(), DisplayHelp | DisplayVersion | DisplayHelpOnMissingArgumentOrSubcommand) {
            let _ = e.print();
            return if e.kind() == DisplayHelpOnMissingArgumentOrSubcommand {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
        // clap's first line, and the list it ends with a colon for (the missing arguments), on one line
        let text = e.to_string();
        let mut lines = text.lines().skip_while(|l| l.trim().is_empty());
        let mut line = lines.next().unwrap_or("invalid arguments").trim().to_string();
        if line.ends_with(':') {
            let listed: Vec<&str> = lines.take_while(|l| !l.trim().is_empty()).map(str::trim).collect();
            line = format!("{line} {}", listed.join(", "));
        }
        eprintln!("{program}: {line} (see --help)");
        ExitCode::from(2)
    })
}
