//! `twoscale fit`: a MERL file in, a scene file and the fit's JSON out (docs/fit.md).

use crate::flags::{BuildArgs, Common, FitArgs};
use crate::glue::input_error;
use anyhow::{Context, Result};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;
use twoscale_fit::compare::{fit_comparison, Compared, Comparison};
use twoscale_fit::fit::{fit, richer_fits_better, Fit, FitOptions, Samples, REFINED};
use twoscale_fit::layer::Beneath;
use twoscale_fit::loss::Loss;
use twoscale_fit::measured;
use twoscale_fit::model::{GeneralTables, TABLES};
use twoscale_fit::params::{Model, Under};
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
    tracing::info!("{}: {}", args.file.display(), measured::describe(&measured));
    let preset_dir = ensure_tables(&args.tables, common)?;
    let tables = GeneralTables::open(&preset_dir)?;
    let models = match args.model.as_deref() {
        Some("plastic") => vec![Model::Plastic],
        Some("subsurface") => vec![Model::Subsurface],
        Some("auto") => vec![Model::Conductor, Model::Plastic, Model::Subsurface],
        None if args.compare => vec![Model::Conductor, Model::Plastic, Model::Subsurface],
        _ => vec![Model::Conductor],
    };
    // The same samples for every model (the comparison's too).
    let samples = Samples::new(&measured, &Loss::LOW, args.samples.0, 4000);
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
            let c = fit_comparison(&tables, &samples, model, |line| tracing::info!("{}: {line}", model.name()));
            compared.push((c, start.elapsed().as_secs_f64()));
        }
    }
    // The model that fits best, the simplest first (a plastic's layer has 4 parameters, a medium 5, a
    // conductor's index 6): a richer one is taken where it fits better over every valid sample.
    let mut order: Vec<&Fit> = fits.iter().map(|(f, _)| f).collect();
    order.sort_by_key(|f| [Model::Plastic, Model::Subsurface, Model::Conductor].iter().position(|m| *m == f.model));
    let mut best = order[0];
    for f in &order[1..] {
        if richer_fits_better(best.agreement.log_rms.powi(2), f.agreement.log_rms.powi(2)) {
            best = f;
        }
    }
    let result = best.clone();
    let mut table = String::new();
    let models: Vec<_> = fits
        .iter()
        .map(|(f, _)| {
            json!({"model": f.model.name(), "relative_rms": f.agreement.relative_rms, "log_rms": f.agreement.log_rms})
        })
        .collect();
    let mut summary = summary(args, &name, &result, models, clock.elapsed().as_secs_f64());
    if args.compare {
        let rows = comparison(&fits, &compared);
        summary["comparison"] = json!(rows.iter().map(Row::json).collect::<Vec<_>>());
        let mut each = serde_json::Map::new();
        for (f, _) in &fits {
            let (material, channels) = material_json(&name, f);
            each.insert(format!("twoscale_{}", f.model.name()), json!({"material": material, "channels": channels}));
        }
        for (c, _) in &compared {
            each.insert(c.params.model.name().into(), comparison_json(c, args.wavelengths.0));
        }
        summary["compared"] = serde_json::Value::Object(each);
        if !args.json {
            table = render_table(&rows, &format!("twoscale_{}", result.model.name()));
        }
    }
    let scene = scene_toml(args, &name, &result, &json_path);
    // The JSON, then the scene file, each atomically; a scene that cannot be written takes its JSON away.
    write_bytes_atomic(&json_path, (serde_json::to_string_pretty(&summary)? + "\n").as_bytes())
        .with_context(|| format!("{}: cannot write", json_path.display()))?;
    if let Err(e) = write_bytes_atomic(&out, scene.as_bytes()) {
        let _ = std::fs::remove_file(&json_path);
        return Err(e.context(format!("{}: cannot write", out.display())));
    }
    tracing::info!(
        "relative RMS of rho cos theta_i over {} samples: {:.4}; wrote {} and {} in {:.1} s",
        result.agreement.samples,
        result.agreement.relative_rms,
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
    models: Vec<serde_json::Value>,
    seconds: f64,
) -> serde_json::Value {
    let model = result.model.name();
    let (material, channels) = material_json(name, result);
    let candidates: Vec<_> = result
        .candidates
        .iter()
        .map(|c| {
            json!({"model": model, "diffraction": c.diffraction, "loss": c.loss, "termination": c.termination, "at_bounds": c.at_ends})
        })
        .collect();
    json!({
        "file": args.file.display().to_string(),
        "model": model,
        "models": models,
        "material": material,
        "channels": channels,
        "error": {
            "relative_rms": result.agreement.relative_rms,
            "relative_rms_per_channel": result.agreement.relative_rms_per_channel,
            "log_rms": result.agreement.log_rms,
            "samples": result.agreement.samples,
            "fit_samples": result.fit_samples,
            "what": "over every valid sample: relative_rms = sqrt(sum (f - t)^2 / sum t^2), f and t the fitted and measured rho cos theta_i (the model from the general tables); log_rms the RMS of the fit's residuals ln(1 + cos_i rho_fit) - ln(1 + cos_i rho_measured)",
        },
        "loss": "ln(1 + cos_i rho_fit) - ln(1 + cos_i rho_measured) per sample and channel (Loew et al. 2012; BBM's lowLog)",
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

/// A comparison model's fit in the shape of a two-scale one's: its lobe in `material`, eta, k and
/// kd per channel.
fn comparison_json(c: &Compared, lambdas: [f64; 3]) -> serde_json::Value {
    let a = &c.params;
    let mut material = json!({"model": a.model.name()});
    for (name, v) in a.model.lobe_names().iter().zip(a.lobe) {
        material[*name] = json!(v);
    }
    let channels: Vec<_> = (0..3)
        .map(|ch| json!({"channel": CHANNELS[ch], "wavelength": lambdas[ch], "eta": a.eta[ch], "k": a.k[ch], "kd": a.kd[ch]}))
        .collect();
    json!({"material": material, "channels": channels, "loss": c.loss, "termination": c.termination})
}

/// One model of the comparison.
struct Row {
    model: String,
    parameters: usize,
    log_rms: f64,
    relative_rms: f64,
    seconds: f64,
}

impl Row {
    fn json(&self) -> serde_json::Value {
        json!({"model": self.model, "parameters": self.parameters, "log_rms": self.log_rms, "relative_rms": self.relative_rms, "seconds": self.seconds})
    }
}

/// The two-scale fits (the candidate each keeps) and the comparison models, each with its seconds.
fn comparison(fits: &[(Fit, f64)], compared: &[(Compared, f64)]) -> Vec<Row> {
    let twoscale = fits.iter().map(|(f, seconds)| Row {
        model: format!("twoscale_{}", f.model.name()),
        parameters: f.model.parameters(f.best.diffraction),
        log_rms: f.agreement.log_rms,
        relative_rms: f.agreement.relative_rms,
        seconds: *seconds,
    });
    let others = compared.iter().map(|(c, seconds)| Row {
        model: c.params.model.name().into(),
        parameters: c.params.model.parameters(),
        log_rms: c.agreement.log_rms,
        relative_rms: c.agreement.relative_rms,
        seconds: *seconds,
    });
    twoscale.chain(others).collect()
}

/// The comparison as a table for the terminal, `chosen` (the model written) marked.
fn render_table(rows: &[Row], chosen: &str) -> String {
    let mut t =
        format!("{:<22} {:>10} {:>9} {:>12} {:>8}\n", "model", "parameters", "log RMS", "relative RMS", "seconds");
    for r in rows {
        let mark = if r.model == chosen { "  (written)" } else { "" };
        t += &format!(
            "{:<22} {:>10} {:>9.4} {:>12.4} {:>8.1}{mark}\n",
            r.model, r.parameters, r.log_rms, r.relative_rms, r.seconds
        );
    }
    t
}

/// The scene file: the fitted material; a conductor's index per channel in comments (the
/// renderer's Fresnel factor, which a scene file does not hold).
fn scene_toml(args: &FitArgs, name: &str, result: &Fit, json_path: &Path) -> String {
    let p = &result.best.params;
    let s = &p.surface;
    let mut t = format!(
        "# Fitted by `twoscale fit {}` ({} model): relative RMS of rho cos theta_i {:.4} over {} samples.\n",
        args.file.display(),
        result.model.name(),
        result.agreement.relative_rms,
        result.agreement.samples
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
