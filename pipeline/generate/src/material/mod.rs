//! Per-material tables (docs/maths.md section 8). Within one material of a scene
//! (beta, p, sigma_s, b, c fixed; wavelengths in [lambda_min, lambda_max])
//! every table depends on one or two free coordinates: a 1-D or 2-D grid,
//! uniform in its encoding, read by plain multilinear interpolation (plus exp
//! of a stored ln, or the derived angle of zh_lobe), as a texture unit reads it.
//!
//! `MATERIAL_TABLES` lists them, with their definitions and builders;
//! `scene_tables::build_scene` builds a scene's materials from it.

pub mod albedo;
pub mod epd;
pub mod kcorr;
pub mod lobe;
pub mod subsurface;

use crate::tables::context::BuildContext;
use crate::tables::Built;
use anyhow::{Context, Result};
use ndarray::ArrayD;
use serde_json::{json, Value};
use std::path::Path;
use twoscale_tables::axis::Axis;
use twoscale_tables::derived::Derived;
use twoscale_tables::spectrum::Spectrum;
use twoscale_tables::table::Table;

/// One material, validated (`scene::Scene::load`), or read back from a manifest (`from_section`).
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
    pub model: Model,
}

/// What lies under the two-scale surface (docs/maths.md section 10).
#[derive(Clone, Debug, PartialEq)]
pub enum Model {
    /// The paper's material: the surface alone, with a conductor's Fresnel factor.
    Conductor,
    /// A dielectric interface of real index `ior` over a Lambertian layer of albedo `diffuse`.
    Plastic { ior: f64, diffuse: Spectrum },
    /// A dielectric interface over a scattering medium (docs/maths.md section 11): reduced albedo `albedo`
    /// (given, or from `coefficients` = (absorption, reduced scattering) in 1/mm), Henyey-Greenstein `g`;
    /// `mfp` (mm) recorded when given (a BRDF has no length scale).
    Subsurface { ior: f64, albedo: Spectrum, g: f64, coefficients: Option<(Spectrum, Spectrum)>, mfp: Option<f64> },
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

    /// The interface's real index, for a model with a dielectric interface.
    pub fn ior(&self) -> Option<f64> {
        match &self.model {
            Model::Conductor => None,
            Model::Plastic { ior, .. } | Model::Subsurface { ior, .. } => Some(*ior),
        }
    }

    /// The tables this material has, in build order.
    pub fn tables(&self) -> impl Iterator<Item = &'static MaterialTableDef> + '_ {
        MATERIAL_TABLES
            .iter()
            .filter(|t| !t.diffraction || self.has_diffraction())
            .filter(|t| !t.dielectric || self.ior().is_some())
    }

    /// Their names.
    pub fn table_names(&self) -> Vec<&'static str> {
        self.tables().map(|t| t.name).collect()
    }

    /// The material of a manifest's `material` section.
    pub fn from_section(section: &Value) -> Result<Material> {
        let number = |k: &str| section[k].as_f64().with_context(|| format!("material section: no number {k}"));
        let optional = |k: &str| section[k].as_f64();
        let spectrum = |k: &str| -> Result<Spectrum> {
            serde_json::from_value(section[k].clone())
                .with_context(|| format!("material section: {k} is not a number or a spectrum"))
        };
        Ok(Material {
            name: section["name"].as_str().context("material section: no name")?.to_string(),
            beta: number("beta")?,
            p: number("p")?,
            sigma_s: number("sigma_s")?,
            b: optional("b"),
            c: optional("c"),
            wavelengths: optional("wavelength_min").zip(optional("wavelength_max")),
            model: match section.get("model").and_then(Value::as_str) {
                None | Some("conductor") => Model::Conductor,
                Some("plastic") => Model::Plastic { ior: number("ior")?, diffuse: spectrum("diffuse")? },
                Some("subsurface") => Model::Subsurface {
                    ior: number("ior")?,
                    albedo: spectrum("albedo")?,
                    g: number("g")?,
                    coefficients: match (section.get("absorption"), section.get("scattering")) {
                        (Some(_), Some(_)) => Some((spectrum("absorption")?, spectrum("scattering")?)),
                        _ => None,
                    },
                    mfp: optional("mfp"),
                },
                Some(other) => anyhow::bail!("material section: unknown model {other:?}"),
            },
        })
    }

    /// What the tables depend on: every parameter, exactly. A conductor's section is as before
    /// models existed (no `model` key: its tables' inputs and manifests are unchanged).
    pub fn parameters(&self) -> Value {
        let mut section = json!({
            "name": self.name,
            "beta": self.beta,
            "p": self.p,
            "sigma_s": self.sigma_s,
            "b": self.b,
            "c": self.c,
            "wavelength_min": self.wavelengths.map(|w| w.0),
            "wavelength_max": self.wavelengths.map(|w| w.1),
        });
        match &self.model {
            Model::Conductor => {}
            Model::Plastic { ior, diffuse } => {
                section["model"] = json!("plastic");
                section["ior"] = json!(ior);
                section["diffuse"] = json!(diffuse);
            }
            Model::Subsurface { ior, albedo, g, coefficients, mfp } => {
                section["model"] = json!("subsurface");
                section["ior"] = json!(ior);
                section["albedo"] = json!(albedo);
                section["g"] = json!(g);
                if let Some((absorption, scattering)) = coefficients {
                    section["absorption"] = json!(absorption);
                    section["scattering"] = json!(scattering);
                }
                if let Some(mfp) = mfp {
                    section["mfp"] = json!(mfp);
                }
            }
        }
        section
    }
}

/// How every per-material table is read, which its manifest's definition ends with.
pub const DECODING: &str = "; read by plain multilinear interpolation in the encoded coordinates (axes[].encoding, \
    derived_axes), then value_encoding (exp of a stored ln) where stated: no control variates, no Gamma function at lookup time";

/// A per-material table: its manifest's definition (before `DECODING`), whether only materials
/// with a diffraction part have it, whether only those with a dielectric interface do, and its builder. A builder may yield several tables computed
/// together (zh_lobe and its sampling table); `dir` holds the material's tables already written,
/// in registry order (the albedo reads them back as a runtime does).
pub struct MaterialTableDef {
    pub name: &'static str,
    pub definition: &'static str,
    pub diffraction: bool,
    pub dielectric: bool,
    pub build: fn(&Material, &BuildContext, &Path) -> Result<Vec<Built>>,
}

fn build_epd_g1(m: &Material, _: &BuildContext, _: &Path) -> Result<Vec<Built>> {
    Ok(vec![epd::g1_table(m)])
}

fn build_epd_sampling(m: &Material, _: &BuildContext, _: &Path) -> Result<Vec<Built>> {
    Ok(vec![epd::sampling_table(m)])
}

fn build_kcorr(m: &Material, _: &BuildContext, _: &Path) -> Result<Vec<Built>> {
    Ok(vec![kcorr::table(m)])
}

fn build_lobe(m: &Material, context: &BuildContext, _: &Path) -> Result<Vec<Built>> {
    let (lobe, sampling) = lobe::tables(context, m)?;
    Ok(vec![lobe, sampling])
}

fn build_fits(m: &Material, context: &BuildContext, _: &Path) -> Result<Vec<Built>> {
    Ok(vec![lobe::fits_table(context, m)?])
}

fn build_albedo(m: &Material, _: &BuildContext, dir: &Path) -> Result<Vec<Built>> {
    albedo::tables(m, dir)
}

/// The per-material tables, in build order.
pub const MATERIAL_TABLES: &[MaterialTableDef] = &[
    MaterialTableDef {
        name: "epd_g1",
        definition: "docs/maths.md section 8: g1 = G1(p, beta tan theta) (section 2) over theta in [0, pi/2], at the material's p and beta",
        diffraction: false,
        dielectric: false,
        build: build_epd_g1,
    },
    MaterialTableDef {
        name: "epd_sampling",
        definition: "docs/maths.md section 8: theta_m = the quantile at xi of D(m) cos theta_m (section 1) in theta_m, at the material's p and beta",
        diffraction: false,
        dielectric: false,
        build: build_epd_sampling,
    },
    MaterialTableDef {
        name: "kcorr_renorm",
        definition: "docs/maths.md section 8: r = R(s, B, c) (section 3) over s = sin theta_i in [0, 1] and B = b / lambda in [b / lambda_max, b / lambda_min], stored as ln R, at the material's c",
        diffraction: true,
        dielectric: false,
        build: build_kcorr,
    },
    MaterialTableDef {
        name: "zh_lobe",
        definition: "docs/maths.md section 8: c_lobe = C(theta_h; u, c, p, beta) (section 4b) over u in [0, b / lambda_min] and theta_h in [0, pi/2] (derived axis v_theta), stored as ln C, at the material's c, p and beta",
        diffraction: true,
        dielectric: false,
        build: build_lobe,
    },
    MaterialTableDef {
        name: "zh_lobe_sampling",
        definition: "docs/maths.md section 8: theta_h = for each u, the quantile at xi in theta_h of the half-vector density proportional to C(theta_h; u) in solid angle (manifest settings: target_density, sampled_density)",
        diffraction: true,
        dielectric: false,
        build: build_lobe,
    },
    MaterialTableDef {
        name: "zh_convolution",
        definition: "docs/maths.md section 8: s, g (plain) and s_cos, g_cos (cos variant): the K-correlation lobes fitted to C (section 4) over u in [0, b / lambda_min], at the material's c, p and beta",
        diffraction: true,
        dielectric: false,
        build: build_fits,
    },
    MaterialTableDef {
        name: "albedo",
        definition: "docs/maths.md section 9: e = E(cos theta_i, lambda) = int_{o_z > 0} rho(i, o) cos theta_o do with F = 1 over theta_i in \
            [0, acos(mu_min)] and lambda in [lambda_min, lambda_max] (no lambda axis without diffraction), rho the BRDF of docs/runtimes.md eval \
            from this material's tables (lobe exact); e_avg = E_avg(lambda) = 2 int_0^1 E(mu) mu dmu of the stored e's interpolant \
            (clamped beyond acos(mu_min)), the same at every theta_i node",
        diffraction: false,
        dielectric: false,
        build: build_albedo,
    },
    MaterialTableDef {
        name: "interface_albedo",
        definition: "docs/maths.md section 10: e_f = E_F(cos theta_i, lambda) = int_{o_z > 0} F_eta(cos theta_d) rho(i, o) cos theta_o do, \
            F_eta the smooth dielectric's Fresnel reflectance at the material's ior, rho as for albedo (lobe exact); e_fc the same of the \
            compensated single scattering f_s + g(mu_i) g(mu_o) f_d_sym (section 9, g from albedo); e_f_avg and e_fc_avg = 2 int_0^1 \
            E(mu) mu dmu of the stored e_f and e_fc as for albedo's e_avg; over albedo's axes",
        diffraction: false,
        dielectric: true,
        build: build_albedo,
    },
];

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
