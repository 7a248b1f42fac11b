//! The published analytic fits of the 100 MERL materials, the numbers a new fit is compared against:
//! ABC (Löw, Andersson, Ynnerman and Unger 2012) and SGD (Bagher, Soler and Holzschuch 2012) at their
//! authors' parameters, from `abc.json` and `sgd.json`: the copies carried in the binary
//! (pipeline/fit/data/published-fits, with their source) or a folder's. With h = normalize(wi + wo), ci = wi.z, co = wo.z, ch = h.z and
//! cd = wi.h clamped to [0, 1], rho is 0 unless both directions are above the surface, else per channel
//!
//! - ABC: rho = kd / pi + F(cd) D(ch) G / (pi ci co), D = A / (1 + B (1 - ch))^C (A per channel),
//!   F the unpolarised dielectric Fresnel factor of index `ior`, G = min(1, 2 ch ci / cd, 2 ch co / cd)
//!   (Cook-Torrance's V-grooves);
//! - SGD: rho = (rhoD + rhoS F(cd) D(ch) G1(wi) G1(wo) / (ci co)) / pi, D = kap exp(-x) / (pi x^p ch^4)
//!   with x = alpha + tan^2 theta_h / alpha, F = f0 - cd f1 + (1 - cd)^5 (1 - f0),
//!   G1(w) = clamp(1 + lambda (1 - exp(c max(0, theta_w - theta0)^k)), 0, 1).
//!
//! These are the forms the parameters were fitted in; where another source writes a model otherwise,
//! these hold.

use anyhow::{anyhow, bail, Context, Result};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::Path;

/// An ABC fit: per channel kd and A, B, C and the index shared.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
pub struct Abc {
    /// The Lambertian albedo (rho adds kd / pi).
    #[serde(rename = "kD")]
    pub kd: [f64; 3],
    /// D's scale.
    #[serde(rename = "A")]
    pub a: [f64; 3],
    /// D's width and falloff.
    #[serde(rename = "B")]
    pub b: f64,
    #[serde(rename = "C")]
    pub c: f64,
    /// The Fresnel factor's (real) index.
    pub ior: f64,
}

/// An SGD fit, every parameter per channel.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Sgd {
    pub rho_d: [f64; 3],
    pub rho_s: [f64; 3],
    /// D's shape.
    pub alpha: [f64; 3],
    pub p: [f64; 3],
    pub kap: [f64; 3],
    /// F's.
    pub f0: [f64; 3],
    pub f1: [f64; 3],
    /// G1's.
    pub lambda: [f64; 3],
    pub c: [f64; 3],
    pub k: [f64; 3],
    pub theta0: [f64; 3],
    /// The authors' own fitting error (rho does not use it).
    pub error: [f64; 3],
}

/// The angles of a pair of directions both above the surface.
struct Geometry {
    ci: f64,
    co: f64,
    ch: f64,
    /// 1 - ch and tan^2 theta_h from h's components (1 - ch as a difference loses the digits near the
    /// normal, where the sharpest lobes are).
    one_minus_ch: f64,
    tan2_h: f64,
    cd: f64,
}

impl Geometry {
    fn new(wi: [f64; 3], wo: [f64; 3]) -> Option<Geometry> {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return None;
        }
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let (side2, len) = (h[0] * h[0] + h[1] * h[1], (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt());
        Some(Geometry {
            ci: wi[2],
            co: wo[2],
            ch: h[2] / len,
            // 1 - hz / |h| = (|h|^2 - hz^2) / (|h| (|h| + hz))
            one_minus_ch: side2 / (len * (len + h[2])),
            tan2_h: side2 / (h[2] * h[2]),
            cd: ((wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]) / len).clamp(0.0, 1.0),
        })
    }
}

/// The angle of w to the normal (atan2 keeps the digits acos loses near 0).
fn theta(w: [f64; 3]) -> f64 {
    w[0].hypot(w[1]).atan2(w[2])
}

/// The unpolarised Fresnel factor of a dielectric of index n at cos theta_d = c (Cook and Torrance 1982).
pub(crate) fn dielectric_fresnel(c: f64, n: f64) -> f64 {
    let g2 = n * n + c * c - 1.0;
    if g2 <= 0.0 {
        // total internal reflection (n < 1, which no published fit has)
        return 1.0;
    }
    let g = g2.sqrt();
    let (a, b) = ((g - c) / (g + c), (c * (g + c) - 1.0) / (c * (g - c) + 1.0));
    0.5 * a * a * (1.0 + b * b)
}

impl Abc {
    /// The BRDF (1/sr) for the directions to the light `wi` and to the viewer `wo` (unit vectors, z the
    /// normal); 0 where one is at or below the horizon.
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        let Some(g) = Geometry::new(wi, wo) else { return [0.0; 3] };
        let masking = (2.0 * g.ch * g.ci / g.cd).min(2.0 * g.ch * g.co / g.cd).min(1.0);
        // F G / (pi ci co) and D / A, shared by the channels
        let shared = dielectric_fresnel(g.cd, self.ior) * masking / (PI * g.ci * g.co);
        let lobe = (1.0 + self.b * g.one_minus_ch).powf(-self.c);
        [0, 1, 2].map(|ch| self.kd[ch] / PI + self.a[ch] * lobe * shared)
    }
}

impl Sgd {
    /// The BRDF (1/sr) for the directions to the light `wi` and to the viewer `wo` (unit vectors, z the
    /// normal); 0 where one is at or below the horizon.
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        let Some(g) = Geometry::new(wi, wo) else { return [0.0; 3] };
        let (theta_i, theta_o) = (theta(wi), theta(wo));
        [0, 1, 2].map(|ch| {
            let x = self.alpha[ch] + g.tan2_h / self.alpha[ch];
            let d = self.kap[ch] * (-x).exp() / (PI * x.powf(self.p[ch]) * g.ch.powi(4));
            let f = self.f0[ch] - g.cd * self.f1[ch] + (1.0 - g.cd).powi(5) * (1.0 - self.f0[ch]);
            // 1 - exp(y) as -expm1(y): no cancellation where y is tiny (c down to 3e-8), which lambda (up
            // to 1.5e7) would multiply
            let g1 = |theta: f64| {
                let y = self.c[ch] * (theta - self.theta0[ch]).max(0.0).powf(self.k[ch]);
                (1.0 - self.lambda[ch] * y.exp_m1()).clamp(0.0, 1.0)
            };
            (self.rho_d[ch] + self.rho_s[ch] * f * d * g1(theta_i) * g1(theta_o) / (g.ci * g.co)) / PI
        })
    }
}

/// Where the carried copies of the published fits are, in the repository.
pub const CARRIED: &str = "pipeline/fit/data/published-fits";

/// A material's ABC fit as abc.json lists it.
#[derive(Clone, Debug, Deserialize)]
pub struct AbcEntry {
    pub material: String,
    #[serde(flatten)]
    pub fit: Abc,
}

/// A material's SGD fit as sgd.json lists it.
#[derive(Clone, Debug, Deserialize)]
pub struct SgdEntry {
    pub material: String,
    /// The name some tables use ("" for none).
    pub other_name: String,
    #[serde(flatten)]
    pub fit: Sgd,
}

/// A material's published fits, found by `PublishedFits::find`.
#[derive(Clone, Copy, Debug)]
pub struct Found<'a> {
    /// Its name in the files (`material`).
    pub material: &'a str,
    pub abc: Option<&'a Abc>,
    pub sgd: Option<&'a Sgd>,
}

/// The published fits, in the files' order.
#[derive(Clone, Debug)]
pub struct PublishedFits {
    pub abc: Vec<AbcEntry>,
    pub sgd: Vec<SgdEntry>,
}

/// A name as `find` compares it: a file stem may write `_` for `-`, or capitals.
fn normalise(name: &str) -> String {
    name.replace('_', "-").to_lowercase()
}

/// The entries of `path`, a JSON list; an error names the file, and the entry that is wrong.
fn entries<T: DeserializeOwned>(path: &Path, bytes: &[u8]) -> Result<Vec<T>> {
    let list: Vec<serde_json::Value> =
        serde_json::from_slice(bytes).with_context(|| format!("{}: not a JSON list", path.display()))?;
    list.iter()
        .enumerate()
        .map(|(i, v)| {
            let name = v.get("material").and_then(|m| m.as_str()).map(|m| format!(" ({m})")).unwrap_or_default();
            T::deserialize(v).map_err(|e| anyhow!("{}: entry {i}{name}: {e}", path.display()))
        })
        .collect()
}

/// Refuses a file in which two entries share a name (normalised): `find` would be ambiguous.
fn check_names<'a>(dir: &Path, file: &str, names: impl Iterator<Item = (usize, &'a str)>) -> Result<()> {
    let mut seen: Vec<(String, usize)> = Vec::new();
    for (entry, name) in names.filter(|(_, name)| !name.is_empty()) {
        let key = normalise(name);
        match seen.iter().find(|(k, _)| *k == key) {
            Some(&(_, first)) if first != entry => {
                bail!(
                    "{}: entries {first} and {entry} are both named {key:?} (`_` read as `-`, any case)",
                    dir.join(file).display()
                )
            }
            Some(_) => {}
            None => seen.push((key, entry)),
        }
    }
    Ok(())
}

impl PublishedFits {
    /// Reads `dir`'s abc.json and sgd.json.
    pub fn read(dir: &Path) -> Result<PublishedFits> {
        let read = |file: &str| {
            let path = dir.join(file);
            std::fs::read(&path).with_context(|| format!("{}: cannot read", path.display()))
        };
        PublishedFits::parse(dir, &read("abc.json")?, &read("sgd.json")?)
    }

    /// The copies carried in the binary (pipeline/fit/data/published-fits, whose README gives their source).
    pub fn carried() -> PublishedFits {
        let dir = Path::new(CARRIED);
        PublishedFits::parse(
            dir,
            include_bytes!("../data/published-fits/abc.json"),
            include_bytes!("../data/published-fits/sgd.json"),
        )
        .expect("the carried published fits are read by the tests")
    }

    fn parse(dir: &Path, abc: &[u8], sgd: &[u8]) -> Result<PublishedFits> {
        let fits =
            PublishedFits { abc: entries(&dir.join("abc.json"), abc)?, sgd: entries(&dir.join("sgd.json"), sgd)? };
        check_names(dir, "abc.json", fits.abc.iter().map(|e| e.material.as_str()).enumerate())?;
        let sgd_names =
            fits.sgd.iter().enumerate().flat_map(|(i, e)| [(i, e.material.as_str()), (i, e.other_name.as_str())]);
        check_names(dir, "sgd.json", sgd_names)?;
        Ok(fits)
    }

    /// A material's fits by its `material` name, else by SGD's `other_name`, compared after `_` is
    /// read as `-` and capitals as small letters (a file stem: `Gold_Metallic_Paint3`); nothing
    /// fuzzier.
    pub fn find(&self, name: &str) -> Option<Found<'_>> {
        let key = normalise(name);
        let named = |n: &str| !n.is_empty() && normalise(n) == key;
        let by_material =
            self.abc.iter().map(|e| &e.material).chain(self.sgd.iter().map(|e| &e.material)).find(|m| named(m));
        let material = by_material.or_else(|| self.sgd.iter().find(|e| named(&e.other_name)).map(|e| &e.material))?;
        let key = normalise(material);
        Some(Found {
            material,
            abc: self.abc.iter().find(|e| normalise(&e.material) == key).map(|e| &e.fit),
            sgd: self.sgd.iter().find(|e| normalise(&e.material) == key).map(|e| &e.fit),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NORMAL: [f64; 3] = [0.0, 0.0, 1.0];

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= 1e-14 * y.abs())
    }

    fn sgd(theta0: f64) -> Sgd {
        Sgd {
            rho_d: [0.1, 0.2, 0.3],
            rho_s: [0.5, 1.0, 2.0],
            alpha: [0.01, 0.1, 0.5],
            p: [0.5, 1.0, 1.5],
            kap: [100.0, 10.0, 1.0],
            f0: [0.9, 0.5, 0.04],
            f1: [0.1, 0.2, -0.5],
            lambda: [0.25; 3],
            // exp(c (-theta0)^2) = 2 where theta_w = 0
            c: [4.0 * 2f64.ln(); 3],
            k: [2.0; 3],
            theta0: [theta0; 3],
            error: [0.0; 3],
        }
    }

    /// At wi = wo = n: h = n, ch = cd = 1, G = 1, D = A and F = ((n - 1) / (n + 1))^2 for ABC; for SGD
    /// x = alpha, D = kap exp(-alpha) / (pi alpha^p), F = f0 - f1, G1 = 1 for theta0 >= 0 and
    /// 1 + lambda (1 - 2) = 3/4 for theta0 = -1/2 by the choice of c.
    #[test]
    fn normal_incidence_and_reflection() {
        let abc = Abc { kd: [0.1, 0.2, 0.3], a: [10.0, 20.0, 30.0], b: 1000.0, c: 1.5, ior: 1.5 };
        let want = [0, 1, 2].map(|ch| (abc.kd[ch] + 0.04 * abc.a[ch]) / PI);
        assert!(close(abc.rho(NORMAL, NORMAL), want), "{:?} against {want:?}", abc.rho(NORMAL, NORMAL));
        for (theta0, g1) in [(0.0, 1.0), (0.3, 1.0), (-0.5, 0.75)] {
            let s = sgd(theta0);
            let want = [0, 1, 2].map(|ch| {
                let d = s.kap[ch] * (-s.alpha[ch]).exp() / (PI * s.alpha[ch].powf(s.p[ch]));
                (s.rho_d[ch] + s.rho_s[ch] * (s.f0[ch] - s.f1[ch]) * d * g1 * g1) / PI
            });
            assert!(
                close(s.rho(NORMAL, NORMAL), want),
                "theta0 {theta0}: {:?} against {want:?}",
                s.rho(NORMAL, NORMAL)
            );
        }
    }

    /// Off the normal, in the plane of incidence at the mirror direction (theta_i = theta_o = t, so
    /// h = n, cd = cos t): ABC's F and G by hand (G = min(1, 2) = 1).
    #[test]
    fn mirror_direction_off_the_normal() {
        let t: f64 = 0.6;
        let (wi, wo) = ([t.sin(), 0.0, t.cos()], [-t.sin(), 0.0, t.cos()]);
        let abc = Abc { kd: [0.0; 3], a: [1.0; 3], b: 50.0, c: 2.0, ior: 2.0 };
        let (c, n) = (t.cos(), 2.0f64);
        let g = (n * n + c * c - 1.0).sqrt();
        let f = 0.5 * ((g - c) / (g + c)).powi(2) * (1.0 + ((c * (g + c) - 1.0) / (c * (g - c) + 1.0)).powi(2));
        let want = [f / (PI * c * c); 3];
        assert!(close(abc.rho(wi, wo), want), "{:?} against {want:?}", abc.rho(wi, wo));
    }

    #[test]
    fn at_or_below_the_horizon_rho_is_zero() {
        let abc = Abc { kd: [0.5; 3], a: [1.0; 3], b: 10.0, c: 1.0, ior: 1.5 };
        for w in [[1.0, 0.0, 0.0], [0.6, 0.0, -0.8]] {
            assert_eq!(abc.rho(w, NORMAL), [0.0; 3]);
            assert_eq!(sgd(0.0).rho(NORMAL, w), [0.0; 3]);
        }
    }

    #[test]
    fn find_matches_names_exactly_after_normalising() {
        let abc = |material: &str, kd| AbcEntry {
            material: material.into(),
            fit: Abc { kd: [kd; 3], a: [1.0; 3], b: 1.0, c: 1.0, ior: 1.5 },
        };
        let sgd = |material: &str, other: &str| SgdEntry {
            material: material.into(),
            other_name: other.into(),
            fit: sgd(0.0),
        };
        let fits = PublishedFits {
            abc: vec![abc("gold-metallic-paint", 1.0), abc("gold-metallic-paint3", 3.0), abc("only-abc", 4.0)],
            sgd: vec![
                sgd("gold-metallic-paint", "metallic-gold"),
                sgd("gold-metallic-paint3", "ch-ball-gold-metallic"),
                sgd("white-marble", ""),
            ],
        };
        let kd = |name: &str| fits.find(name).and_then(|f| f.abc).map(|a| a.kd[0]);
        assert_eq!(kd("gold-metallic-paint3"), Some(3.0));
        assert_eq!(kd("gold_metallic_paint3"), Some(3.0));
        assert_eq!(kd("Gold_Metallic-PAINT3"), Some(3.0));
        assert_eq!(kd("gold-metallic-paint"), Some(1.0));
        // by SGD's other name: the material's ABC fit too
        let found = fits.find("CH_BALL_GOLD_METALLIC").unwrap();
        assert_eq!(
            (found.material, found.abc.map(|a| a.kd[0]), found.sgd.is_some()),
            ("gold-metallic-paint3", Some(3.0), true)
        );
        // in one file only
        let found = fits.find("only-abc").unwrap();
        assert!(found.abc.is_some() && found.sgd.is_none());
        let found = fits.find("white_marble").unwrap();
        assert!(found.abc.is_none() && found.sgd.is_some());
        // nothing fuzzier: no prefix, suffix, space or extension; "" is nobody's other name
        for name in [
            "gold-metallic-paint2",
            "gold-metallic",
            "gold metallic paint3",
            " gold-metallic-paint3",
            "gold-metallic-paint3.binary",
            "goldmetallicpaint3",
            "",
        ] {
            assert!(fits.find(name).is_none(), "{name:?} found");
        }
    }
}
