//! Per-material tables (docs/maths.md section 8). Within one material of a scene
//! (beta, p, sigma_s, b, c fixed; wavelengths in [lambda_min, lambda_max])
//! every table depends on one or two free coordinates: a 1-D or 2-D grid,
//! uniform in its encoding, read by plain multilinear interpolation (plus exp
//! of a stored ln, or the derived angle of zh_lobe), as a texture unit reads it.
//!
//! `twoscale build --scene S.toml` writes each material's tables into
//! `DIR/scene-<scene>/<material>/` (`build_scene`); a material whose tables are
//! up to date (same parameters, same generator, intact files) is not rebuilt.

pub mod albedo;
pub mod epd;
pub mod kcorr;
pub mod lobe;

use crate::build::{generator_identity, up_to_date, write_built};
use twoscale_tables::derived::Derived;
use twoscale_tables::axis::Axis;
use crate::scene::Scene;
use crate::table::{write_bytes_atomic, Table};
use twoscale_tables::file::read_manifest;
use crate::tables::epd_math::norm;
use crate::tables::{BuildOptions, Built};
use anyhow::{Context, Result};
use ndarray::ArrayD;
use serde_json::{json, Value};
use std::path::Path;
use std::time::Instant;
use tracing::info;

/// One material, validated (`scene::Material::check`).
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub beta: f64,
    pub p: f64,
    pub sigma_s: f64,
    pub b: Option<f64>,
    pub c: Option<f64>,
    /// [lambda_min, lambda_max] in micrometres (diffracting materials).
    pub wavelengths: Option<(f64, f64)>,
}

impl Material {
    pub fn has_diffraction(&self) -> bool {
        self.sigma_s > 0.0
    }

    /// [b / lambda_max, b / lambda_min].
    pub fn b_over_lambda(&self) -> (f64, f64) {
        let (lo, hi) = self.wavelengths.expect("a diffracting material");
        let b = self.b.expect("a diffracting material");
        (b / hi, b / lo)
    }

    /// The tables this material has, in build order.
    pub fn tables(&self) -> &'static [&'static str] {
        if self.has_diffraction() {
            &["epd_g1", "epd_sampling", "kcorr_renorm", "zh_lobe", "zh_lobe_sampling", "zh_convolution", "albedo"]
        } else {
            &["epd_g1", "epd_sampling", "albedo"]
        }
    }

    /// The material of a manifest's `material` section.
    pub fn from_section(section: &Value) -> Result<Material> {
        let number = |k: &str| section[k].as_f64().with_context(|| format!("material section: no number {k}"));
        let optional = |k: &str| section[k].as_f64();
        Ok(Material {
            name: section["name"].as_str().context("material section: no name")?.to_string(),
            beta: number("beta")?,
            p: number("p")?,
            sigma_s: number("sigma_s")?,
            b: optional("b"),
            c: optional("c"),
            wavelengths: optional("wavelength_min").zip(optional("wavelength_max")),
        })
    }

    /// What the tables depend on: every parameter, exactly.
    fn parameters(&self) -> Value {
        json!({
            "name": self.name,
            "beta": self.beta,
            "p": self.p,
            "sigma_s": self.sigma_s,
            "b": self.b,
            "c": self.c,
            "wavelength_min": self.wavelengths.map(|w| w.0),
            "wavelength_max": self.wavelengths.map(|w| w.1),
        })
    }
}

/// How every per-material table is read, which its manifest's definition ends with.
pub const DECODING: &str = "; read by plain multilinear interpolation in the encoded coordinates (axes[].encoding, \
    derived_axes), then value_encoding (exp of a stored ln) where stated: no control variates, no Gamma function at lookup time";

/// The definition each per-material table's manifest states (before `DECODING`).
pub fn definition(table: &str) -> &'static str {
    match table {
        "epd_g1" => "docs/maths.md section 8: g1 = G1(p, beta tan theta) (section 2) over theta in [0, pi/2], at the material's p and beta",
        "epd_sampling" => "docs/maths.md section 8: theta_m = the quantile at xi of D(m) cos theta_m (section 1) in theta_m, at the material's p and beta",
        "kcorr_renorm" => "docs/maths.md section 8: r = R(s, B, c) (section 3) over s = sin theta_i in [0, 1] and B = b / lambda in [b / lambda_max, b / lambda_min], stored as ln R, at the material's c",
        "zh_lobe" => "docs/maths.md section 8: c_lobe = C(theta_h; u, c, p, beta) (section 4b) over u in [0, b / lambda_min] and theta_h in [0, pi/2] (derived axis v_theta), stored as ln C, at the material's c, p and beta",
        "zh_convolution" => "docs/maths.md section 8: s, g (plain) and s_cos, g_cos (cos variant): the K-correlation lobes fitted to C (section 4) over u in [0, b / lambda_min], at the material's c, p and beta",
        "zh_lobe_sampling" => "docs/maths.md section 8: theta_h = for each u, the quantile at xi in theta_h of the half-vector density proportional to C(theta_h; u) in solid angle (manifest settings: target_density, sampled_density)",
        "albedo" => "docs/maths.md section 9: e = E(cos theta_i, lambda) = int_{o_z > 0} rho(i, o) cos theta_o do with F = 1 over theta_i in \
                     [0, acos(mu_min)] and lambda in [lambda_min, lambda_max] (no lambda axis without diffraction), rho the BRDF of docs/runtimes.md eval \
                     from this material's tables (lobe exact); e_avg = E_avg(lambda) = 2 int_0^1 E(mu) mu dmu of the stored e's interpolant \
                     (clamped beyond acos(mu_min)), the same at every theta_i node",
        _ => unreachable!("a per-material table"),
    }
}

/// The target of every quantile table: |F(quantile(xi)) - xi| at most this.
pub const QUANTILE_TARGET: f64 = 1e-4;

/// The density a renderer samples with `epd_sampling` (plain interpolation), stated exactly for pdf().
pub const SAMPLED_DENSITY_1D: &str = "theta(xi) = (1 - f) q_j + f q_(j+1), with e = asin(sqrt(xi)) the encoded xi, h = (pi/2) / (n - 1) \
    the node spacing in e, j = floor(e / h) (at most n - 2), f = e / h - j and q the stored values: on [q_j, q_(j+1)] the density \
    of theta is sin(2 e(theta)) h / (q_(j+1) - q_j), with e(theta) = (j + (theta - q_j) / (q_(j+1) - q_j)) h (xi = sin^2 e); \
    the density of the direction (phi uniform) is that over 2 pi sin theta";

/// The same for `zh_lobe_sampling`, where the row is first interpolated in u.
pub const SAMPLED_DENSITY_2D: &str = "at u (weight t between its nodes i and i + 1 in the encoded u) the row q_j = (1 - t) Q[i][j] + \
    t Q[i + 1][j] (bilinear interpolation); theta_h(xi) and its density from that row as for epd_sampling: with e = asin(sqrt(xi)), \
    h = (pi/2) / (n - 1), on [q_j, q_(j+1)] the density of theta_h is sin(2 e(theta_h)) h / (q_(j+1) - q_j), \
    e(theta_h) = (j + (theta_h - q_j) / (q_(j+1) - q_j)) h; the half vector's density in solid angle (phi uniform) is that \
    over 2 pi sin theta_h";

pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// The accuracy section of a quantile table from (xi, |F(quantile(xi)) - xi|) pairs.
pub fn quantile_accuracy(errors: &[(f64, f64)], what: &str) -> Value {
    let e: Vec<f64> = errors.iter().map(|x| x.1).collect();
    let (max, worst) = e.iter().enumerate().fold((0.0f64, 0), |b, (i, &x)| if x > b.0 { (x, i) } else { b });
    json!({
        "what": what,
        "probes": errors.len(),
        "target": QUANTILE_TARGET,
        "max": max,
        "median": median(&e),
        "worst_xi": errors.get(worst).map(|x| x.0),
    })
}

/// A per-material table as `Built`.
#[allow(clippy::too_many_arguments)]
pub fn built(
    m: &Material,
    table: &str,
    axes: Vec<Axis>,
    values: Vec<(&str, ArrayD<f32>)>,
    accuracy: Value,
    settings: Value,
    compute_seconds: f64,
    accuracy_seconds: f64,
    derived: Derived,
) -> Built {
    let values = values.into_iter().map(|(n, v)| (n.to_string(), v)).collect();
    Built {
        table: Table { name: table.into(), preset: m.name.clone(), axes, values },
        accuracy,
        settings,
        compute_seconds,
        accuracy_seconds,
        stages: Value::Null,
        derived,
    }
}

/// The manifest's `material` section.
fn material_section(m: &Material, scene: &Scene) -> Value {
    let mut section = m.parameters();
    section["n_p"] = json!(norm(m.p));
    section["n_p_formula"] = json!("N(p) = p / (pi Gamma(1/p)) (docs/maths.md section 1): D(m) = N(p) / beta^2 exp(-(tan^2 theta_m / beta^2)^p) / cos^4 theta_m");
    section["scene"] = json!({ "name": scene.name, "sha256": scene.sha256 });
    section
}

/// The inputs of one table of a material: the table, every parameter and the generator.
fn inputs(m: &Material, table: &str) -> Result<Value> {
    let what = json!({ "table": table, "material": m.parameters(), "generator": generator_identity()? });
    Ok(json!({ "sha256": twoscale_tables::checksum::sha256_bytes(what.to_string().as_bytes()), "what": what }))
}

/// Builds the tables of every material of `scene` into `out/scene-<scene>/<material>/`.
pub fn build_scene(scene: &Scene, out: &Path, options: &BuildOptions) -> Result<()> {
    let root = out.join(format!("scene-{}", scene.name));
    let context = options.context.clone().unwrap_or_default();
    for m in scene.materials() {
        let dir = root.join(&m.name);
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
        let target = format!("scene-{}/{}", scene.name, m.name);
        let section = material_section(&m, scene);
        let mut stale = Vec::new();
        for &table in m.tables() {
            let inputs = inputs(&m, table)?;
            match (!options.force).then(|| up_to_date(&dir, table, &inputs["sha256"])).flatten() {
                Some(existing) => {
                    // Same data: only the scene file (another material changed) may differ.
                    if existing.material.as_ref() != Some(&section) {
                        let mut manifest = read_manifest(&dir, table)?;
                        manifest.material = Some(section.clone());
                        let path = twoscale_tables::file::manifest_path(&dir, table);
                        write_bytes_atomic(&path, (serde_json::to_string_pretty(&manifest)? + "\n").as_bytes())?;
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
        let mut done: Vec<(&str, Built)> = Vec::new();
        let needs = |t: &str| stale.iter().any(|(s, _)| *s == t);
        if needs("epd_g1") {
            done.push(("epd_g1", epd::g1_table(&m)));
        }
        if needs("epd_sampling") {
            done.push(("epd_sampling", epd::sampling_table(&m)));
        }
        if needs("kcorr_renorm") {
            done.push(("kcorr_renorm", kcorr::table(&m)));
        }
        if needs("zh_lobe") || needs("zh_lobe_sampling") {
            let (lobe, sampling) = lobe::tables(&context, &m)?;
            done.extend([("zh_lobe", lobe), ("zh_lobe_sampling", sampling)]);
        }
        if needs("zh_convolution") {
            done.push(("zh_convolution", lobe::fits_table(&context, &m)?));
        }
        let write = |table: &str, b: Built| -> Result<()> {
            let Some((_, inputs)) = stale.iter().find(|(s, _)| *s == table) else { return Ok(()) };
            let timing = json!({ "compute_seconds": b.compute_seconds, "accuracy_seconds": b.accuracy_seconds, "threads": rayon::current_num_threads() });
            let definition = format!("{}{DECODING}", definition(table));
            write_built(table, &definition, &dir, &target, b, inputs.clone(), timing, Some(section.clone()))?;
            Ok(())
        };
        for (table, b) in done {
            write(table, b)?;
        }
        // The albedo integrates the BRDF of the tables just written (or kept), read back as a runtime reads them.
        if needs("albedo") {
            write("albedo", albedo::table(&m, &dir)?)?;
        }
        info!(material = m.name, seconds = format!("{:.2}", start.elapsed().as_secs_f64()), "wrote {}", dir.display());
    }
    Ok(())
}
