//! Whether the fit's starts find the best basin on a file (docs/fit.md "Files outside the model's
//! family"): each two-scale model fitted as `twoscale fit` does (the best `REFINED` scored starts
//! refined on the scout subsample) and with every start of the grid refined, the losses side by side, under
//! the loss and the subsample size `twoscale fit` uses.
//!
//!     cargo run --release -p twoscale-fit --example starts -- TABLES_DIR FILE.binary...
//!
//! TABLES_DIR holds the default preset's general tables (tables-out/default). The B = b / lambda range
//! is a scene file's, [0.1, 30], as `twoscale fit` uses.

use std::path::PathBuf;
use std::time::Instant;
use twoscale_fit::fit::{fit, FitOptions, Samples, REFINED};
use twoscale_fit::loss::Loss;
use twoscale_fit::measured;
use twoscale_fit::model::GeneralTables;
use twoscale_fit::params::Model;

fn main() -> anyhow::Result<()> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    anyhow::ensure!(args.len() >= 2, "usage: starts TABLES_DIR FILE.binary...");
    let tables = GeneralTables::open(&args[0])?;
    println!("| file | model | loss, {REFINED} starts refined | loss, every start refined | ratio | seconds |");
    println!("|---|---|---|---|---|---|");
    for file in &args[1..] {
        let samples = Samples::new(&measured::read(file)?, &Loss::FIT, Some(10_000));
        for model in [Model::Conductor, Model::Plastic, Model::Subsurface] {
            let mut row = Vec::new();
            for refined_starts in [REFINED, usize::MAX] {
                let (lambdas, b_over_lambda) = ([0.65, 0.55, 0.45], (0.1, 30.0));
                let options = FitOptions { model, lambdas, b_over_lambda, refined_starts, rival: None };
                let clock = Instant::now();
                let f = fit(&tables, &samples, &options, |_| {});
                row.push((f.best.loss, clock.elapsed().as_secs_f64()));
            }
            let name = file.file_stem().unwrap_or_default().to_string_lossy();
            let ((few, s0), (all, s1)) = (row[0], row[1]);
            println!("| {name} | {} | {few:.5e} | {all:.5e} | {:.4} | {s0:.1} / {s1:.1} |", model.name(), few / all);
        }
    }
    Ok(())
}
