//! `twoscale bench`.

use crate::flags::{BenchArgs, Common};
use anyhow::Result;
use twoscale_generate::progress::Progress;

/// Runs the sweeps, then prints each table's files and speed ratios.
pub fn run_bench(args: &BenchArgs, common: &Common) -> Result<()> {
    let options =
        twoscale_quality::bench::BenchOptions { quick: args.quick, progress: Progress { quiet: common.quiet } };
    let start = std::time::Instant::now();
    let (benches, profile) = twoscale_quality::bench::run(options, &args.out, &args.tables)?;
    for bench in benches {
        println!(
            "{}: {} settings -> {}",
            bench.table,
            bench.rows.len(),
            args.out.join(format!("{}.{{csv,png}}", bench.table)).display()
        );
        for line in twoscale_quality::bench::speed_ratios(&bench) {
            println!("  {line}");
        }
    }
    if let Some(profile) = profile {
        println!("profile (paper tables, 1 thread) -> {}", args.out.join("profile.json").display());
        for line in twoscale_quality::bench::profile::summary(&profile) {
            println!("  {line}");
        }
    }
    println!("bench took {:.0} s", start.elapsed().as_secs_f64());
    Ok(())
}
