//! `twoscale fit`: a measured file (MERL or RGL-EPFL) in, a scene file and the fit's JSON out (docs/fit.md);
//! `report` draws `--compare --report DIR`'s page.

mod report;

use crate::flags::{BuildArgs, Common, FitArgs};
use crate::glue::input_error;
use anyhow::Result;
use rayon::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;
use twoscale_fit::compare::{comparison_rho, fit_comparison, Compared, Comparison};
use twoscale_fit::fit::{
    agreement_of, candidate_rho, fit, kept_by_render, richer_renders_better, Agreement, Fit, FitOptions, Samples,
    REFINED,
};
use twoscale_fit::layer::Beneath;
use twoscale_fit::loss::Loss;
use twoscale_fit::measured;
use twoscale_fit::model::{GeneralTables, TABLES};
use twoscale_fit::params::{Model, Under};
use twoscale_fit::published::PublishedFits;
use twoscale_fit::render::{self, Sphere, RESOLUTION};
use twoscale_generate::scene;
use twoscale_generate::tables::{self, Preset};
use twoscale_tables::table::write_bytes_atomic;

pub fn run_fit(args: &FitArgs, common: &Common) -> Result<()> {
    let clock = Instant::now();
    let measured = measured::read(&args.file).map_err(|e| input_error(format!("{e:#}")))?;
    let name = match &args.name {
        Some(n) => n.clone(),
        None => args.file.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default(),
    };
    let name: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    if name.is_empty() {
        return Err(input_error("fit: an empty material name (give --name)"));
    }
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from(format!("{name}.toml")));
    let json_path = out.with_extension("fit.json");
    let folder = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !folder.is_dir() {
        return Err(input_error(format!("fit: --out {}: no such directory {}", out.display(), folder.display())));
    }
    if let Some(png) = &args.render {
        let folder = png.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if !folder.is_dir() {
            return Err(input_error(format!(
                "fit: --render {}: no such directory {}",
                png.display(),
                folder.display()
            )));
        }
        if png.is_dir() || *png == out || *png == json_path {
            return Err(input_error(format!(
                "fit: --render {}: a directory, or the scene or JSON file the fit writes: give a PNG's path",
                png.display()
            )));
        }
    }
    if let Some(dir) = &args.report {
        report::check(dir).map_err(|e| input_error(format!("{e:#}")))?;
    }
    // The published fits of the material, where it is one of the 100 MERL materials (an RGL file is not).
    let published = match (&measured.file, args.compare) {
        (measured::File::Merl(_), true) => {
            let found = PublishedFits::carried().find(&name).map(|found| (found.abc.copied(), found.sgd.copied()));
            match found {
                Some(_) => tracing::info!("{name}: its published ABC and SGD fits are compared too"),
                None => tracing::info!(
                    "{name}: not one of the 100 MERL materials by name, no published fits compared (give --name)"
                ),
            }
            found
        }
        _ => None,
    };
    tracing::info!("{}: {}", args.file.display(), measured::describe(&measured));
    let preset_dir = ensure_tables(&args.tables, common)?;
    // The tables are read and verified while the file's samples are drawn (the same samples for every model,
    // the comparison's too).
    let (tables, samples) =
        rayon::join(|| GeneralTables::open(&preset_dir), || Samples::new(&measured, &Loss::FIT, args.samples.0));
    let tables = tables?;
    let models = match args.model.as_str() {
        "conductor" => vec![Model::Conductor],
        "plastic" => vec![Model::Plastic],
        "subsurface" => vec![Model::Subsurface],
        _ => vec![Model::Conductor, Model::Plastic, Model::Subsurface],
    };
    let mut fits: Vec<(Fit, f64)> = Vec::new();
    for model in models {
        let options = FitOptions {
            model,
            lambdas: args.wavelengths.0,
            b_over_lambda: (scene::MIN_B_OVER_LAMBDA, scene::MAX_B_OVER_LAMBDA),
            refined_starts: REFINED,
            rival: fits.iter().map(|(f, _)| f.mean_squared_residual()).min_by(f64::total_cmp),
        };
        tracing::info!("fitting the {} model", model.name());
        let start = Instant::now();
        let f = fit(&tables, &samples, &options, |line| tracing::info!("{}: {line}", model.name()));
        fits.push((f, start.elapsed().as_secs_f64()));
    }
    let mut compared: Vec<(Compared, f64)> = Vec::new();
    if args.compare {
        for model in Comparison::ALL {
            tracing::info!("fitting the comparison model {}", model.name());
            let start = Instant::now();
            let log = |line: &str| tracing::info!("{}: {line}", model.name());
            let c = fit_comparison(&tables, &samples, model, args.wavelengths.0, log);
            compared.push((c, start.elapsed().as_secs_f64()));
        }
    }
    // Each model as a viewer sees it: the file's sphere and each fit's, SMAPE between them (render.rs).
    let clock_render = Instant::now();
    let sphere = Sphere::new(RESOLUTION);
    let pairs = sphere.data();
    let target = sphere.render_file(&measured.file);
    let images: Vec<Vec<Vec<[f64; 3]>>> = fits
        .par_iter()
        .map(|(f, _)| {
            f.candidates.par_iter().map(|c| sphere.render(&candidate_rho(&tables, &pairs, &f.domain, c))).collect()
        })
        .collect();
    let smapes: Vec<Vec<f64>> =
        images.iter().map(|each| each.iter().map(|image| render::smape(image, &target)).collect()).collect();
    let compared_images: Vec<Vec<[f64; 3]>> =
        compared.iter().map(|(c, _)| sphere.render(&comparison_rho(&tables, &pairs, &c.params))).collect();
    let compared_smape: Vec<f64> = compared_images.iter().map(|image| render::smape(image, &target)).collect();
    // The published fits, not fitted: their errors and renders at the authors' parameters.
    let mut published_fits: Vec<Published> = Vec::new();
    if let Some((abc, sgd)) = published {
        if let Some(a) = abc {
            // kd and A per channel, B, C and the index
            let rho = Box::new(move |wi, wo| a.rho(wi, wo));
            published_fits.push(Published { model: "abc_published", parameters: 9, values: json!(a), rho });
        }
        if let Some(s) = sgd {
            // 11 per channel
            let rho = Box::new(move |wi, wo| s.rho(wi, wo));
            published_fits.push(Published { model: "sgd_published", parameters: 33, values: json!(s), rho });
        }
    }
    let published_images: Vec<Vec<[f64; 3]>> = published_fits.iter().map(|p| sphere.render_fn(&p.rho)).collect();
    let published_rows: Vec<Row> = published_fits
        .iter()
        .zip(&published_images)
        .map(|(p, image)| {
            let a = agreement_of(&samples, &p.rho);
            let (log_rms, relative_rms) = (a.log_rms, a.relative_rms);
            let render_smape = render::smape(image, &target);
            Row { model: p.model.into(), parameters: p.parameters, log_rms, relative_rms, render_smape, seconds: 0.0 }
        })
        .collect();
    tracing::info!("renders: {:.1} s", clock_render.elapsed().as_secs_f64());
    // Each fit's kept candidate, of either pass (`kept_by_render`), and its render's SMAPE.
    let kept_at: Vec<usize> = fits.iter().zip(&smapes).map(|((f, _), s)| kept_by_render(f, s)).collect();
    for ((f, _), &k) in fits.iter_mut().zip(&kept_at) {
        f.best = f.candidates[k].clone();
    }
    let kept = |k: usize| smapes[k][kept_at[k]];
    // The model written renders best, the simplest first (a plastic's layer has 4 parameters, a medium 5, a
    // conductor's index 6): a richer one is taken where its render's SMAPE is lower by `richer_renders_better`.
    let mut order: Vec<usize> = (0..fits.len()).collect();
    order.sort_by_key(|&k| {
        [Model::Plastic, Model::Subsurface, Model::Conductor].iter().position(|m| *m == fits[k].0.model)
    });
    let mut written = order[0];
    for &k in &order[1..] {
        if richer_renders_better(kept(written), kept(k)) {
            written = k;
        }
    }
    let result = fits[written].0.clone();
    // Each model's error over every valid sample: the written one's, and every model's with --compare.
    let agreements: Vec<Option<Agreement>> = fits
        .iter()
        .enumerate()
        .map(|(k, (f, _))| (k == written || args.compare).then(|| f.agreement(&tables, &samples)))
        .collect();
    let agreement = agreements[written].clone().expect("the written model's agreement");
    if agreement.relative_rms > 1.0 {
        // The loss is relative, and sum t^2 is mostly the few largest samples' (the grazing mirror direction,
        // where cos_i rho reaches tens): a model outside its family overshoots them while fitting the rest.
        tracing::info!(
            "relative RMS {:.3}: worse than rho = 0 on the largest samples (the grazing mirror directions), though \
             log RMS {:.3} against {:.3} for rho = 0",
            agreement.relative_rms,
            agreement.log_rms,
            agreement.log_rms_of_zero
        );
    }
    let mut table = String::new();
    let models: Vec<_> = fits
        .iter()
        .enumerate()
        .map(|(k, (f, _))| json!({"model": f.model.name(), "loss": f.mean_squared_residual(), "render_smape": kept(k)}))
        .collect();
    let mut summary =
        summary(args, &name, &result, &agreement, models, &smapes[written], clock.elapsed().as_secs_f64());
    summary["format"] = json!(measured.file.format());
    summary["render_smape"] = json!(kept(written));
    summary["render"] = json!(render::SCENE);
    let mut rows = Vec::new();
    if args.compare {
        let kept_smape: Vec<f64> = (0..fits.len()).map(kept).collect();
        rows = comparison(&fits, &agreements, &compared, &kept_smape, &compared_smape);
        rows.extend(published_rows);
        summary["comparison"] = json!(rows.iter().map(Row::json).collect::<Vec<_>>());
        let mut each = serde_json::Map::new();
        for (f, _) in &fits {
            let (material, channels) = material_json(&name, f);
            each.insert(format!("twoscale_{}", f.model.name()), json!({"material": material, "channels": channels}));
        }
        for (c, _) in &compared {
            each.insert(c.params.model().name().into(), comparison_json(c, args.wavelengths.0));
        }
        summary["compared"] = serde_json::Value::Object(each);
        if !args.json {
            table = render_table(&rows, &format!("twoscale_{}", result.model.name()));
        }
    }
    let picture = match &args.render {
        Some(_) => Some(picture(&tables, &measured.file, &fits[written].0)),
        None => None,
    };
    let scene = scene_toml(args, &name, &result, &agreement, &json_path);
    // The picture, the JSON, then the scene file, each atomically; one that cannot be written takes the
    // ones before it away, so that a failed fit leaves nothing.
    let mut files: Vec<(&Path, Vec<u8>)> = Vec::new();
    if let (Some(path), Some(png)) = (&args.render, picture) {
        files.push((path, png));
    }
    files.push((&json_path, (serde_json::to_string_pretty(&summary)? + "\n").into_bytes()));
    files.push((&out, scene.into_bytes()));
    for (k, (path, bytes)) in files.iter().enumerate() {
        if let Err(e) = write_bytes_atomic(path, bytes) {
            for (written, _) in &files[..k] {
                let _ = std::fs::remove_file(written);
            }
            return Err(e.context(format!("{}: cannot write", path.display())));
        }
    }
    if let Some(dir) = &args.report {
        let clock_report = Instant::now();
        let slices = report::Slices::new(&measured.file);
        let slice_data = slices.data();
        let file_slices: Vec<[f64; 3]> =
            slices.points.iter().map(|(_, _, wi, wo)| measured.file.rho(*wi, *wo)).collect();
        // The rows in `comparison`'s order: the two-scale fits, the comparison models, the published fits.
        let mut evaluated: Vec<(serde_json::Value, Vec<[f64; 3]>, Vec<[f64; 3]>)> = Vec::new();
        for (k, (f, _)) in fits.iter().enumerate() {
            let c = &f.candidates[kept_at[k]];
            let (material, channels) = material_json(&name, f);
            let slices = candidate_rho(&tables, &slice_data, &f.domain, c);
            evaluated.push((
                json!({"material": material, "channels": channels}),
                images[k][kept_at[k]].clone(),
                slices,
            ));
        }
        for ((c, _), image) in compared.iter().zip(&compared_images) {
            let slices = comparison_rho(&tables, &slice_data, &c.params);
            evaluated.push((comparison_json(c, args.wavelengths.0), image.clone(), slices));
        }
        for (p, image) in published_fits.iter().zip(&published_images) {
            let slices = slices.lines.iter().map(|(_, _, wi, wo)| (p.rho)(*wi, *wo)).collect();
            evaluated.push((p.values.clone(), image.clone(), slices));
        }
        assert_eq!(rows.len(), evaluated.len(), "a report entry per comparison row");
        let entries: Vec<report::Entry> = rows
            .iter()
            .zip(evaluated)
            .map(|(r, (parameters, image, slices))| report::Entry {
                model: r.model.clone(),
                parameters,
                count: r.parameters,
                log_rms: r.log_rms,
                relative_rms: r.relative_rms,
                render_smape: r.render_smape,
                seconds: r.seconds,
                image,
                slices,
            })
            .collect();
        let written = format!("twoscale_{}", result.model.name());
        let page = report::Page {
            name: &name,
            file: &args.file,
            format: measured.file.format(),
            written: &written,
            loss: LOSS,
        };
        if let Err(e) = report::write(dir, &page, &sphere, &target, &file_slices, &slices, &entries) {
            for (path, _) in &files {
                let _ = std::fs::remove_file(path);
            }
            return Err(e.context(format!("{}: cannot write the report", dir.display())));
        }
        tracing::info!(
            "wrote the report {} in {:.1} s",
            dir.join("index.html").display(),
            clock_report.elapsed().as_secs_f64()
        );
    }
    tracing::info!(
        "{} model: render SMAPE {:.4} (docs/fit.md \"The render\"), relative RMS of rho cos theta_i over {} samples {:.4}; wrote {} and {} in {:.1} s",
        result.model.name(),
        kept(written),
        agreement.samples,
        agreement.relative_rms,
        out.display(),
        json_path.display(),
        clock.elapsed().as_secs_f64()
    );
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        print!("{table}");
        println!("{}\n{}", out.display(), json_path.display());
    }
    Ok(())
}

/// DIR/default, with the general tables the fit reads (the missing ones built first, as `make tables` would).
fn ensure_tables(dir: &Path, common: &Common) -> Result<PathBuf> {
    let preset_dir = dir.join(Preset::Default.name());
    let missing: Vec<String> =
        TABLES.iter().filter(|t| !preset_dir.join(format!("{t}.h5")).exists()).map(|t| t.to_string()).collect();
    if !missing.is_empty() {
        tracing::info!("building the general tables the fit reads: {}", missing.join(", "));
        let build = BuildArgs {
            preset: Preset::Default,
            tables: missing,
            out: dir.to_path_buf(),
            degree: None,
            method: None,
            force: false,
            scene: None,
            shard: None,
        };
        let all: Vec<&'static tables::TableDef> = tables::TABLES.iter().collect();
        super::run_build(&build, common, &all)?;
    }
    Ok(preset_dir)
}

/// The result as `--json` prints it and <stem>.fit.json keeps it.
fn summary(
    args: &FitArgs,
    name: &str,
    result: &Fit,
    agreement: &Agreement,
    models: Vec<serde_json::Value>,
    smapes: &[f64],
    seconds: f64,
) -> serde_json::Value {
    let model = result.model.name();
    let (material, channels) = material_json(name, result);
    let candidates: Vec<_> = result
        .candidates
        .iter()
        .zip(smapes)
        .map(|(c, smape)| {
            json!({"model": model, "diffraction": c.diffraction, "weighting": c.weighting, "loss": c.loss, "termination": c.termination, "at_bounds": c.at_ends,
                   "render_smape": smape})
        })
        .collect();
    json!({
        "file": args.file.display().to_string(),
        "model": model,
        "models": models,
        "material": material,
        "channels": channels,
        "error": {
            "relative_rms": agreement.relative_rms,
            "relative_rms_per_channel": agreement.relative_rms_per_channel,
            "log_rms": agreement.log_rms,
            "samples": agreement.samples,
            "fit_samples": result.fit_samples,
            "what": "over every valid sample: relative_rms = sqrt(sum (f - t)^2 / sum t^2), f and t the fitted and measured rho cos theta_i (the model from the general tables); log_rms the RMS of ln(1 + cos_i rho_fit) - ln(1 + cos_i rho_measured), Loew et al.'s E2 metric, not the fit's loss (docs/fit.md \"The loss\")",
        },
        "loss": LOSS,
        "candidates": candidates,
        "at_bounds": result.best.at_ends,
        "seconds": seconds,
    })
}

/// A two-scale fit's material and channels, as the JSON has them.
fn material_json(name: &str, result: &Fit) -> (serde_json::Value, Vec<serde_json::Value>) {
    let p = &result.best.params;
    let s = &p.surface;
    // Without diffraction sigma_s is 0 and b, c are null (nothing depends on them).
    let mut material = json!({"name": name, "model": result.model.name(), "beta": s.beta, "p": s.p, "sigma_s": 0.0, "b": null, "c": null});
    if result.best.diffraction {
        material["sigma_s"] = json!(s.sigma_s);
        material["b"] = json!(s.b);
        material["c"] = json!(s.c);
    }
    let channels: Vec<_> = (0..3)
        .map(|ch| {
            let colour = CHANNELS[ch];
            match p.under {
                Under::Conductor { eta, k } => {
                    json!({"channel": colour, "wavelength": p.lambdas[ch], "eta": eta[ch], "k": k[ch]})
                }
                // eta, k: the interface's index, a dielectric's
                Under::Layered { ior, beneath: Beneath::Diffuse { diffuse } } => {
                    json!({"channel": colour, "wavelength": p.lambdas[ch], "eta": ior, "k": 0.0, "diffuse": diffuse[ch]})
                }
                Under::Layered { ior, beneath: Beneath::Medium { albedo, .. } } => {
                    json!({"channel": colour, "wavelength": p.lambdas[ch], "eta": ior, "k": 0.0, "albedo": albedo[ch]})
                }
            }
        })
        .collect();
    if let Under::Layered { ior, beneath } = p.under {
        material["ior"] = json!(ior);
        if let Beneath::Medium { g, .. } = beneath {
            material["g"] = json!(g);
        }
    }
    (material, channels)
}

const CHANNELS: [&str; 3] = ["red", "green", "blue"];

/// What the fit minimised (loss.rs, `Loss::FIT`, and the by-measure pass's), for the JSON.
const LOSS: &str = "w (ln(e_ch + cos_i rho_fit) - ln(e_ch + cos_i rho_measured)) per sample and channel: e_ch 0.1 times \
    the channel's mean of cos_i rho over solid angle, w^2 the sample's share of the loss (its solid angle times the \
    projected area (cos_i + cos_o) / 2, relative to the mean, 70 %, and an equal share per sample, 30 %); a second pass \
    weighs by the measure alone (100 %, on half the samples), and is kept where its render is closer by more than 1 % \
    and 0.005 of SMAPE (docs/fit.md \"The method\")";

/// A comparison model's fit in the shape of a two-scale one's: the parameters shared by the channels in
/// `material`, each channel's (eta, k and kd, or the model's own) in `channels`.
fn comparison_json(c: &Compared, lambdas: [f64; 3]) -> serde_json::Value {
    let (shared, channels) = c.params.named();
    let mut material = json!({"model": c.params.model().name()});
    for (name, v) in shared {
        material[name] = json!(v);
    }
    let channels: Vec<_> = (0..3)
        .map(|ch| {
            let mut entry = json!({"channel": CHANNELS[ch], "wavelength": lambdas[ch]});
            for (name, v) in &channels[ch] {
                entry[*name] = json!(v);
            }
            entry
        })
        .collect();
    json!({"material": material, "channels": channels, "loss": c.loss, "termination": c.termination})
}

/// A published fit of the material: its row's name and count, its parameters, its BRDF.
struct Published {
    model: &'static str,
    parameters: usize,
    values: serde_json::Value,
    rho: Box<dyn Fn([f64; 3], [f64; 3]) -> [f64; 3] + Sync>,
}

/// One model of the comparison.
struct Row {
    model: String,
    parameters: usize,
    log_rms: f64,
    relative_rms: f64,
    render_smape: f64,
    seconds: f64,
}

impl Row {
    fn json(&self) -> serde_json::Value {
        json!({"model": self.model, "parameters": self.parameters, "log_rms": self.log_rms, "relative_rms": self.relative_rms,
               "render_smape": self.render_smape, "seconds": self.seconds})
    }
}

/// The two-scale fits (the candidate each keeps) and the comparison models, each with its render's SMAPE
/// and its seconds.
fn comparison(
    fits: &[(Fit, f64)],
    agreements: &[Option<Agreement>],
    compared: &[(Compared, f64)],
    smape: &[f64],
    compared_smape: &[f64],
) -> Vec<Row> {
    let twoscale = fits.iter().zip(agreements).zip(smape).map(|(((f, seconds), a), &render_smape)| Row {
        model: format!("twoscale_{}", f.model.name()),
        parameters: f.model.parameters(f.best.diffraction),
        log_rms: a.as_ref().expect("every model's agreement with --compare").log_rms,
        relative_rms: a.as_ref().expect("every model's agreement with --compare").relative_rms,
        render_smape,
        seconds: *seconds,
    });
    let others = compared.iter().zip(compared_smape).map(|((c, seconds), &render_smape)| Row {
        model: c.params.model().name().into(),
        parameters: c.params.model().parameters(),
        log_rms: c.agreement.log_rms,
        relative_rms: c.agreement.relative_rms,
        render_smape,
        seconds: *seconds,
    });
    twoscale.chain(others).collect()
}

/// The comparison as a table for the terminal, `chosen` (the model written) marked.
fn render_table(rows: &[Row], chosen: &str) -> String {
    let mut t = format!(
        "{:<22} {:>10} {:>9} {:>12} {:>12} {:>8}\n",
        "model", "parameters", "log RMS", "relative RMS", "render SMAPE", "seconds"
    );
    for r in rows {
        let mark = if r.model == chosen { "  (written)" } else { "" };
        t += &format!(
            "{:<22} {:>10} {:>9.4} {:>12.4} {:>12.4} {:>8.1}{mark}\n",
            r.model, r.parameters, r.log_rms, r.relative_rms, r.render_smape, r.seconds
        );
    }
    t
}

/// The scene file: the fitted material; a conductor's index per channel in comments (the
/// renderer's Fresnel factor, which a scene file does not hold).
fn scene_toml(args: &FitArgs, name: &str, result: &Fit, agreement: &Agreement, json_path: &Path) -> String {
    let p = &result.best.params;
    let s = &p.surface;
    let mut t = format!(
        "# Fitted by `twoscale fit {}` ({} model): relative RMS of rho cos theta_i {:.4} over {} samples.\n",
        args.file.display(),
        result.model.name(),
        agreement.relative_rms,
        agreement.samples
    );
    // The channels in increasing wavelength, as a scene's spectra list them.
    let mut order = [0, 1, 2];
    order.sort_by(|&a, &b| p.lambdas[a].total_cmp(&p.lambdas[b]));
    let list = |v: [f64; 3]| order.map(|ch| v[ch].to_string()).join(", ");
    if let Under::Conductor { eta, k } = p.under {
        t += &format!(
            "# The conductor's index per channel (the renderer's Fresnel factor; also in {}):\n",
            json_path.display()
        );
        for ch in 0..3 {
            let colour = ["red", "green", "blue"][ch];
            t += &format!("#   {colour} at {} um: eta = {:.6}, k = {:.6}\n", p.lambdas[ch], eta[ch], k[ch]);
        }
    }
    t += &format!("[[material]]\nname = \"{name}\"\nbeta = {}\np = {}\n", s.beta, s.p);
    if result.best.diffraction {
        t += &format!("sigma_s = {}\nb = {}\nc = {}\nwavelengths = [{}]\n", s.sigma_s, s.b, s.c, list(p.lambdas));
    }
    match p.under {
        Under::Conductor { .. } => {}
        Under::Layered { ior, beneath: Beneath::Diffuse { diffuse } } => {
            t += &format!(
                "model = \"plastic\"\nior = {ior}\ndiffuse = {{ wavelengths = [{}], values = [{}] }}\n",
                list(p.lambdas),
                list(diffuse)
            )
        }
        Under::Layered { ior, beneath: Beneath::Medium { albedo, g } } => {
            t += &format!(
                "model = \"subsurface\"\nior = {ior}\nalbedo = {{ wavelengths = [{}], values = [{}] }}\ng = {g}\n",
                list(p.lambdas),
                list(albedo)
            )
        }
    }
    t
}

/// The file's sphere beside the written fit's, 128 pixels square each, as a PNG: linear radiance scaled so
/// that the file's 99th percentile is white (both alike), then sRGB-encoded.
fn picture(tables: &GeneralTables, file: &measured::File, fit: &Fit) -> Vec<u8> {
    const SIZE: usize = 128;
    const GAP: usize = 4;
    let sphere = Sphere::new(SIZE);
    let data = sphere.picture(SIZE, &sphere.render_file(file));
    let fitted = sphere.picture(SIZE, &sphere.render(&candidate_rho(tables, &sphere.data(), &fit.domain, &fit.best)));
    let srgb = render::srgb_exposure(&data);
    let width = 2 * SIZE + GAP;
    let mut rgb = vec![255u8; 3 * width * SIZE];
    for row in 0..SIZE {
        for (x0, image) in [(0, &data), (SIZE + GAP, &fitted)] {
            for col in 0..SIZE {
                let at = 3 * (row * width + x0 + col);
                let p = image[row * SIZE + col];
                rgb[at..at + 3].copy_from_slice(&p.map(&srgb));
            }
        }
    }
    twoscale_quality::plot::rgb_png(&rgb, (width as u32, SIZE as u32))
}
