//! Scene files: the materials a renderer needs tables for (TOML, one
//! `[[material]]` per material; lengths in micrometres), and the sub-domain
//! of each table they need.

use crate::material::{Material, Model};
use crate::tables::Range;
use anyhow::{bail, Result};
use serde::Deserialize;
use std::path::Path;
use twoscale_tables::checksum::sha256_bytes;
use twoscale_tables::spectrum::Spectrum;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    material: Vec<MaterialEntry>,
}

/// One `[[material]]` as written: EPD width `beta` and kurtosis `p`; with `sigma_s` > 0 also a
/// diffraction part (K-correlation `b`, `c` and the wavelengths). `Scene::load` checks it and
/// resolves it into a `Material`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialEntry {
    name: String,
    beta: Option<f64>,
    p: Option<f64>,
    sigma_s: Option<f64>,
    b: Option<f64>,
    c: Option<f64>,
    wavelengths: Option<Vec<f64>>,
    wavelength_range: Option<[f64; 2]>,
    /// "conductor" (the default), "plastic" with `ior` and `diffuse` (docs/maths.md section 10), or
    /// "subsurface" with `ior`, `albedo` (and `mfp`) or `absorption` and `scattering`, and `g` (section 11).
    model: Option<String>,
    ior: Option<f64>,
    diffuse: Option<Spectrum>,
    albedo: Option<Spectrum>,
    mfp: Option<f64>,
    absorption: Option<Spectrum>,
    scattering: Option<Spectrum>,
    g: Option<f64>,
}

/// A validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub sha256: String,
    pub materials: Vec<Material>,
}

impl MaterialEntry {
    fn has_diffraction(&self) -> bool {
        self.sigma_s.is_some_and(|s| s > 0.0)
    }

    /// (smallest, largest) wavelength.
    fn wavelength_span(&self) -> (f64, f64) {
        match (&self.wavelengths, self.wavelength_range) {
            (Some(w), _) => (w.iter().copied().fold(f64::INFINITY, f64::min), w.iter().copied().fold(0.0, f64::max)),
            (None, Some([lo, hi])) => (lo, hi),
            (None, None) => unreachable!("validated"),
        }
    }

    // `!(x > 0.0)` on purpose: it also rejects NaN.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn check(&self, file: &Path) -> Result<()> {
        let err = |field: &str, why: &str| -> Result<()> {
            bail!("{}: material {:?}: field `{field}`: {why}", file.display(), self.name)
        };
        let positive = |v: Option<f64>, field: &str| -> Result<()> {
            match v {
                None => err(field, "missing"),
                Some(x) if !(x > 0.0) || !x.is_finite() => err(field, &format!("must be a positive number, got {x}")),
                Some(_) => Ok(()),
            }
        };
        // The name is a folder of the scene's output: a plain name, nothing that leaves the folder.
        let plain = !self.name.is_empty()
            && !self.name.starts_with('.')
            && self.name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if !plain {
            return err("name", "must be a plain folder name (letters, digits, _, - and ., not starting with .)");
        }
        positive(self.beta, "beta")?;
        positive(self.p, "p")?;
        let within = |v: Option<f64>, field: &str, lo: f64, hi: f64| -> Result<()> {
            match v {
                Some(x) if !(lo..=hi).contains(&x) => {
                    err(field, &format!("{x} is outside what the tables support, [{lo}, {hi}]"))
                }
                _ => Ok(()),
            }
        };
        within(self.beta, "beta", 0.005, 0.5)?;
        within(self.p, "p", 0.2, 5.0)?;
        self.check_model(file)?;
        match self.sigma_s {
            Some(s) if s < 0.0 || !s.is_finite() => return err("sigma_s", &format!("must be >= 0, got {s}")),
            Some(s) if s > 0.0 => {}
            _ => {
                for (field, given) in
                    [("b", self.b.is_some()), ("c", self.c.is_some()), ("wavelengths", self.wavelengths.is_some())]
                {
                    if given {
                        return err(field, "given without sigma_s > 0 (no diffraction part)");
                    }
                }
                return Ok(());
            }
        }
        positive(self.b, "b")?;
        match self.c {
            None => return err("c", "missing (sigma_s > 0 needs b, c and wavelengths)"),
            Some(c) if !(c > 1.0) || !c.is_finite() => return err("c", &format!("must be > 1, got {c}")),
            Some(_) => {}
        }
        within(self.c, "c", 1.02, 3.02)?;
        match (&self.wavelengths, self.wavelength_range) {
            (Some(_), Some(_)) => err("wavelength_range", "give either wavelengths or wavelength_range"),
            (None, None) => err("wavelengths", "missing (or wavelength_range = [min, max])"),
            (Some(w), None) if w.is_empty() => err("wavelengths", "empty list"),
            (Some(w), None) if w.iter().any(|x| !(*x > 0.0) || !x.is_finite()) => {
                err("wavelengths", "must all be positive")
            }
            (None, Some([lo, hi])) if !(lo > 0.0 && hi >= lo && hi.is_finite()) => {
                err("wavelength_range", &format!("needs 0 < min <= max, got [{lo}, {hi}]"))
            }
            _ => {
                let (lo, hi) = self.wavelength_span();
                let b = self.b.unwrap_or(0.0);
                if b / lo > MAX_B_OVER_LAMBDA || b / hi < MIN_B_OVER_LAMBDA {
                    return err("b", &format!("b / lambda spans [{}, {}], outside what the tables support, [{MIN_B_OVER_LAMBDA}, {MAX_B_OVER_LAMBDA}]", b / hi, b / lo));
                }
                Ok(())
            }
        }
    }

    /// `model` and its parameters: a plastic needs `ior` in [MIN_IOR, MAX_IOR] and `diffuse` in [0, 1]
    /// (a number or a spectrum); a subsurface material `ior`, the reduced albedo `albedo` in [0, 1] (with an
    /// optional `mfp` > 0) or `absorption` and `scattering` >= 0 (1/mm, on the same wavelengths), and `g` in
    /// [-MAX_G, MAX_G] (0 when absent); a conductor takes none of them.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn check_model(&self, file: &Path) -> Result<()> {
        let err = |field: &str, why: &str| -> Result<()> {
            bail!("{}: material {:?}: field `{field}`: {why}", file.display(), self.name)
        };
        let model = self.model.as_deref().unwrap_or("conductor");
        let keys = [
            ("ior", self.ior.is_some(), ["plastic", "subsurface"].as_slice()),
            ("diffuse", self.diffuse.is_some(), &["plastic"]),
            ("albedo", self.albedo.is_some(), &["subsurface"]),
            ("absorption", self.absorption.is_some(), &["subsurface"]),
            ("scattering", self.scattering.is_some(), &["subsurface"]),
            ("mfp", self.mfp.is_some(), &["subsurface"]),
            ("g", self.g.is_some(), &["subsurface"]),
        ];
        if !["conductor", "plastic", "subsurface"].contains(&model) {
            return err("model", &format!("unknown model {model:?} (conductor, plastic or subsurface)"));
        }
        if let Some((field, _, models)) = keys.iter().find(|(_, given, models)| *given && !models.contains(&model)) {
            return err(field, &format!("given for a {model} (it belongs to model = \"{}\")", models[0]));
        }
        if model == "conductor" {
            return Ok(());
        }
        match self.ior {
            None => {
                return err("ior", &format!("missing (a {model} needs the interface's real index, e.g. ior = 1.5)"))
            }
            Some(x) if !(MIN_IOR..=MAX_IOR).contains(&x) => {
                return err("ior", &format!("must be in [{MIN_IOR}, {MAX_IOR}], got {x}"))
            }
            Some(_) => {}
        }
        let fraction = |field: &str, s: &Spectrum| -> Result<()> {
            if let Some(why) = s.malformed() {
                return err(field, &why);
            }
            match s.values().iter().find(|x| !(0.0..=1.0).contains(*x)) {
                Some(x) => err(field, &format!("albedo must be in [0, 1], got {x}")),
                None => Ok(()),
            }
        };
        if model == "plastic" {
            let Some(d) = &self.diffuse else {
                return err(
                    "diffuse",
                    "missing (the diffuse layer's albedo in [0, 1], a number or { wavelengths, values })",
                );
            };
            return fraction("diffuse", d);
        }
        match self.g {
            Some(g) if !(-MAX_G..=MAX_G).contains(&g) => {
                return err("g", &format!("must be in [-{MAX_G}, {MAX_G}], got {g}"))
            }
            _ => {}
        }
        match (&self.albedo, &self.absorption, &self.scattering) {
            (Some(a), None, None) => {
                if let Some(mfp) = self.mfp.filter(|x| !(*x > 0.0 && x.is_finite())) {
                    return err("mfp", &format!("must be a positive length (mm), got {mfp}"));
                }
                fraction("albedo", a)
            }
            (None, Some(sa), Some(ss)) => {
                if self.mfp.is_some() {
                    return err("mfp", "given with absorption and scattering (they fix it: give albedo and mfp instead)");
                }
                for (field, s) in [("absorption", sa), ("scattering", ss)] {
                    if let Some(why) = s.malformed() {
                        return err(field, &why);
                    }
                    if let Some(x) = s.values().iter().find(|x| !(**x >= 0.0 && x.is_finite())) {
                        return err(field, &format!("must be >= 0 (1/mm), got {x}"));
                    }
                }
                let same_wavelengths = match (sa, ss) {
                    (Spectrum::Constant(_), Spectrum::Constant(_)) => true,
                    (Spectrum::Sampled { wavelengths: a, .. }, Spectrum::Sampled { wavelengths: b, .. }) => a == b,
                    _ => false,
                };
                if !same_wavelengths {
                    return err("scattering", "give absorption and scattering both as numbers, or on the same wavelengths");
                }
                match sa.values().iter().zip(ss.values()).find(|(a, s)| !(**a + **s > 0.0)) {
                    Some(_) => err("scattering", "absorption + scattering must be > 0 (an extinction)"),
                    None => Ok(()),
                }
            }
            (None, None, None) => err(
                "albedo",
                "missing (the reduced scattering albedo in [0, 1], with an optional mfp; or absorption and scattering in 1/mm)",
            ),
            (Some(_), _, _) => err("albedo", "give either albedo (and mfp) or absorption and scattering"),
            (None, Some(_), None) => err("scattering", "missing (absorption needs the reduced scattering coefficient)"),
            (None, None, Some(_)) => err("absorption", "missing (scattering needs the absorption coefficient)"),
        }
    }

    /// The material's model as validated.
    fn model(&self) -> Model {
        match self.model.as_deref().unwrap_or("conductor") {
            "plastic" => {
                Model::Plastic { ior: self.ior.expect("validated"), diffuse: self.diffuse.clone().expect("validated") }
            }
            "subsurface" => {
                let coefficients = self.absorption.clone().zip(self.scattering.clone());
                // alpha' = sigma_s' / (sigma_a + sigma_s'), sample by sample
                let albedo = match (&self.albedo, &coefficients) {
                    (Some(a), _) => a.clone(),
                    (None, Some((Spectrum::Constant(a), Spectrum::Constant(s)))) => Spectrum::Constant(s / (a + s)),
                    (
                        None,
                        Some((Spectrum::Sampled { wavelengths, values: a }, Spectrum::Sampled { values: s, .. })),
                    ) => Spectrum::Sampled {
                        wavelengths: wavelengths.clone(),
                        values: a.iter().zip(s).map(|(a, s)| s / (a + s)).collect(),
                    },
                    _ => unreachable!("validated"),
                };
                Model::Subsurface {
                    ior: self.ior.expect("validated"),
                    albedo,
                    g: self.g.unwrap_or(0.0),
                    coefficients,
                    mfp: self.mfp,
                }
            }
            _ => Model::Conductor,
        }
    }

    /// The material as the per-material tables take it.
    fn resolved(&self) -> Material {
        Material {
            name: self.name.clone(),
            beta: self.beta.expect("validated"),
            p: self.p.expect("validated"),
            sigma_s: self.sigma_s.unwrap_or(0.0),
            b: self.b.filter(|_| self.has_diffraction()),
            c: self.c.filter(|_| self.has_diffraction()),
            wavelengths: self.has_diffraction().then(|| self.wavelength_span()),
            model: self.model(),
        }
    }
}

/// The plastic's interface index: a dielectric denser than its surroundings (1 would have no interface),
/// up to 10 (F0 = 0.67): brighter than any common dielectric, as `twoscale fit` may find a coat of a
/// measured file to be (docs/fit.md "Files outside the model's family"); the interface tables are
/// built at the material's index and meet their accuracy targets there.
pub const MIN_IOR: f64 = 1.01;
pub const MAX_IOR: f64 = 10.0;
/// The subsurface model's Henyey-Greenstein asymmetry: |g| at most this (its single-scattering bound's
/// quadrature resolves the phase function's peak there).
pub const MAX_G: f64 = 0.9;

/// The b / lambda the diffraction tables support: kcorr_renorm's default B
/// axis starts at 0.1; the per-material lobe's series converges to degree
/// 2000 up to u = b / lambda_min = 30 (the sharpest EPD, beta = 0.005, p = 5).
pub const MIN_B_OVER_LAMBDA: f64 = 0.1;
pub const MAX_B_OVER_LAMBDA: f64 = 30.0;

impl Scene {
    /// Reads and validates a scene; every error names the file, the material and the field.
    pub fn load(path: &Path) -> Result<Scene> {
        let text =
            std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: cannot read scene: {e}", path.display()))?;
        let file: SceneFile = toml::from_str(&text)
            .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.message().replace('\n', " ")))?;
        if file.material.is_empty() {
            bail!("{}: no [[material]] in the scene", path.display());
        }
        for (i, m) in file.material.iter().enumerate() {
            m.check(path)?;
            if file.material[..i].iter().any(|o| o.name == m.name) {
                bail!("{}: two materials are named {:?}: each has its own folder", path.display(), m.name);
            }
        }
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string();
        let materials = file.material.iter().map(MaterialEntry::resolved).collect();
        Ok(Scene { name, sha256: sha256_bytes(text.as_bytes()), materials })
    }

    pub fn has_diffraction(&self) -> bool {
        self.materials.iter().any(Material::has_diffraction)
    }

    /// The values each axis needs: p and beta over all materials; c, B = b/lambda
    /// and u in [0, max b/lambda] over the diffracting ones.
    pub fn ranges(&self) -> Vec<(&'static str, Range)> {
        let all = &self.materials;
        let diff: Vec<&Material> = all.iter().filter(|m| m.has_diffraction()).collect();
        let mut r = vec![
            ("p", Range::of(all.iter().map(|m| m.p)).expect("a scene has a material")),
            ("beta", Range::of(all.iter().map(|m| m.beta)).expect("a scene has a material")),
        ];
        if let (Some(c), Some(b_lo), Some(b_hi)) = (
            Range::of(diff.iter().map(|m| m.c.expect("a diffracting material"))),
            Range::of(diff.iter().map(|m| m.b_over_lambda().0)),
            Range::of(diff.iter().map(|m| m.b_over_lambda().1)),
        ) {
            r.push(("c", c));
            r.push(("b_over_lambda", Range { lo: b_lo.lo, hi: b_hi.hi }));
            r.push(("u", Range { lo: 0.0, hi: b_hi.hi }));
        }
        r
    }
}
