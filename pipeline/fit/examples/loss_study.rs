//! The loss measured by the render (docs/fit.md "The loss"): each file fitted with the three two-scale
//! models under a loss given on the command line, each fit rendered on `render`'s sphere against the
//! file's render (each candidate of both passes), and the model `--model auto` writes (`kept_by_render`, then
//! `richer_renders_better`); a MERL material's
//! published ABC and SGD fits rendered beside it; with `--compare` the comparison models fitted too.
//!
//!     cargo run --release -p twoscale-fit --example loss_study -- TABLES_DIR PUBLISHED_DIR [OPTIONS] FILE...
//!
//! TABLES_DIR holds the default preset's general tables (tables-out/default), PUBLISHED_DIR the published
//! fits (shared/data/published-fits). OPTIONS set the loss (`loss::Loss`), default `Loss::FIT`'s:
//! `--low` (Löw et al.'s), `--offset X` (e relative to the channel's mean; `--offset none`: e = 1),
//! `--measure P`, `--projected yes|no`, `--share S`, `--max-theta-d DEGREES`, and `--samples N` (the
//! fit subsample). One line per file and model, then the summary: for the MERL files, the written fit's
//! SMAPE against ABC's (median ratio, at or below, within 1.5 times); for the RGL files, against the best
//! comparison model; the seconds of the three fits.

use std::path::{Path, PathBuf};
use std::time::Instant;
use twoscale_fit::compare::{comparison_rho, fit_comparison, Comparison};
use twoscale_fit::fit::{candidate_rho, fit, kept_by_render, richer_renders_better, FitOptions, Samples, REFINED};
use twoscale_fit::loss::Loss;
use twoscale_fit::measured::{self, File};
use twoscale_fit::model::GeneralTables;
use twoscale_fit::params::Model;
use twoscale_fit::published::PublishedFits;
use twoscale_fit::render::{smape, Sphere, RESOLUTION};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(args.len() >= 3, "usage: loss_study TABLES_DIR PUBLISHED_DIR [OPTIONS] FILE...");
    let tables = GeneralTables::open(Path::new(&args.remove(0)))?;
    let published = PublishedFits::read(Path::new(&args.remove(0)))?;
    let (mut loss, mut samples, mut compare, mut files) = (Loss::FIT, 10_000, false, Vec::new());
    let mut it = args.into_iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or_else(|| anyhow::anyhow!("{a} takes a value"));
        match a.as_str() {
            "--low" => loss = Loss::LOW,
            "--offset" => {
                loss.offset = match value()?.as_str() {
                    "none" => None,
                    x => Some(x.parse().map_err(|e| anyhow::anyhow!("--offset {x}: {e} (a number, or none)"))?),
                }
            }
            "--measure" => loss.measure_power = value()?.parse()?,
            "--projected" => {
                loss.projected = match value()?.as_str() {
                    "yes" => true,
                    "no" => false,
                    x => anyhow::bail!("--projected {x}: yes or no"),
                }
            }
            "--share" => loss.sample_share = value()?.parse()?,
            "--max-theta-d" => loss.max_theta_d = value()?.parse::<f64>()?.to_radians(),
            "--samples" => samples = value()?.parse()?,
            "--compare" => compare = true,
            x if x.starts_with("--") => anyhow::bail!("{x}: no such option (see the file's header)"),
            _ => files.push(PathBuf::from(a)),
        }
    }
    println!("loss {loss:?}, {samples} samples");
    let sphere = Sphere::new(RESOLUTION);
    let pairs = sphere.data();
    let (mut merl_ratios, mut rgl_beaten, mut rgl_count, mut seconds) = (Vec::new(), 0, 0, Vec::new());
    for file in &files {
        let m = measured::read(file)?;
        let name = file.file_stem().unwrap_or_default().to_string_lossy().to_string();
        let target = sphere.render_file(&m.file);
        let subsamples = Samples::new(&m, &loss, Some(samples));
        let clock = Instant::now();
        let mut fits = Vec::new();
        for model in [Model::Plastic, Model::Subsurface, Model::Conductor] {
            let options = FitOptions {
                model,
                lambdas: [0.65, 0.55, 0.45],
                b_over_lambda: (0.1, 30.0),
                refined_starts: REFINED,
                rival: None,
            };
            let f = fit(&tables, &subsamples, &options, |_| {});
            let smapes: Vec<f64> = f
                .candidates
                .iter()
                .map(|c| smape(&sphere.render(&candidate_rho(&tables, &pairs, &f.domain, c)), &target))
                .collect();
            let s = smapes[kept_by_render(&f, &smapes)];
            let each: Vec<String> = f
                .candidates
                .iter()
                .zip(&smapes)
                .map(|(c, s)| {
                    format!("{:?}/{}:{s:.4}", c.weighting, if c.diffraction { "diffraction" } else { "plain" })
                })
                .collect();
            println!("{name} {} SMAPE {s:.4} candidates {}", model.name(), each.join(" "));
            fits.push(s);
        }
        seconds.push(clock.elapsed().as_secs_f64());
        let written = fits[1..].iter().fold(fits[0], |best, &s| if richer_renders_better(best, s) { s } else { best });
        let mut best_comparison = f64::INFINITY;
        if compare {
            for model in Comparison::ALL {
                let c = fit_comparison(&tables, &subsamples, model, [0.65, 0.55, 0.45], |_| {});
                let s = smape(&sphere.render(&comparison_rho(&tables, &pairs, &c.params)), &target);
                println!("{name} {} SMAPE {s:.4}", model.name());
                best_comparison = best_comparison.min(s);
            }
        }
        let mut line = format!("{name} written SMAPE {written:.4}");
        if let (File::Merl(_), Some(found)) = (&m.file, published.find(&name)) {
            let abc = found.abc.map(|a| smape(&sphere.render_fn(|wi, wo| a.rho(wi, wo)), &target));
            let sgd = found.sgd.map(|a| smape(&sphere.render_fn(|wi, wo| a.rho(wi, wo)), &target));
            if let Some(abc) = abc {
                merl_ratios.push(written / abc);
                line += &format!(" ABC {abc:.4} ratio {:.2}", written / abc);
            }
            if let Some(sgd) = sgd {
                line += &format!(" SGD {sgd:.4}");
            }
        }
        if compare && matches!(m.file, File::Rgl(_)) {
            rgl_count += 1;
            rgl_beaten += usize::from(written <= best_comparison);
            line += &format!(" best comparison {best_comparison:.4}");
        }
        println!("{line} ({:.1} s)", seconds.last().unwrap());
    }
    let n = merl_ratios.len();
    println!(
        "MERL: {n} files, median SMAPE / ABC's {:.3}, at or below ABC {}, within 1.5 times {}; RGL: at or below the \
         best comparison model {rgl_beaten} of {rgl_count}; seconds of the three fits: median {:.1}, most {:.1}",
        median(merl_ratios.clone()),
        merl_ratios.iter().filter(|r| **r <= 1.0).count(),
        merl_ratios.iter().filter(|r| **r <= 1.5).count(),
        median(seconds.clone()),
        seconds.iter().copied().fold(0.0, f64::max)
    );
    Ok(())
}
