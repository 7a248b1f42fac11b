//! The tables: one module per stage, and the registry the CLI builds from.

pub mod epd;
pub mod epd_math;
pub mod kcorr;
pub mod kcorr_math;
pub mod zh;
pub mod zh_fit;
pub mod zh_lobe;
pub mod zh_math;

use crate::grid::Axis;
use crate::progress::Progress;
use crate::scene::Range;
use std::ops::RangeInclusive;
use crate::table::Table;
use anyhow::Result;
use serde_json::Value;
use std::fmt;
use std::str::FromStr;

/// The presets of SPEC section 5.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// The grids of the published reference tables.
    Paper,
    /// This project's grids, sized for the accuracy targets after interpolation.
    Default,
}

impl Preset {
    pub const ALL: [Preset; 2] = [Preset::Paper, Preset::Default];

    pub fn name(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
            Preset::Default => "default",
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Preset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Preset::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| format!("unknown preset {s:?} (known: paper, default)"))
    }
}

/// What a table build returns besides the data.
pub struct Built {
    pub table: Table,
    pub accuracy: Value,
    pub settings: Value,
    /// Seconds spent computing the values (excluding the accuracy measurement).
    pub compute_seconds: f64,
    pub accuracy_seconds: f64,
    /// Optional breakdown of `compute_seconds` by stage (JSON object or null).
    pub stages: Value,
    /// Derived axes and encoded values, stated in the manifest.
    pub derived: crate::derived::Derived,
}

/// How `zh_convolution` computes C (SPEC section 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The zonal-harmonic sum C_L.
    Zh,
    /// The direct 2-D integral (slow: for small grids and checks).
    Exact,
    /// C_L where its estimated truncation error is below a tolerance, C elsewhere.
    Auto,
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "zh" => Ok(Method::Zh),
            "exact" => Ok(Method::Exact),
            "auto" => Ok(Method::Auto),
            _ => Err(format!("unknown method {s:?} (known: zh, exact, auto)")),
        }
    }
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Zh => "zh",
            Method::Exact => "exact",
            Method::Auto => "auto",
        }
    }
}

/// Options that change how a table is computed (not its grid).
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    pub progress: Progress,
    /// Zonal-harmonic degree L (zh_convolution; default from the preset).
    pub degree: Option<usize>,
    /// zh_convolution method (default from the preset).
    pub method: Option<Method>,
    /// Rebuild even when an existing table has the same inputs.
    pub force: bool,
    /// Build for a scene: the default grids keep only the nodes covering its ranges.
    pub scene: Option<SceneTarget>,
}

/// A scene build: its name (the output directory is `scene-<name>`), the
/// scene file's SHA-256, and the ranges each axis needs.
#[derive(Clone, Debug)]
pub struct SceneTarget {
    pub name: String,
    pub sha256: String,
    pub ranges: Vec<(&'static str, Range)>,
}

/// The axes restricted to the options' sub-domain, with the kept index range of each.
pub fn restrict(axes: Vec<Axis>, options: &BuildOptions) -> Result<(Vec<Axis>, Vec<RangeInclusive<usize>>)> {
    let mut kept = Vec::new();
    let mut out = Vec::new();
    for axis in axes {
        let range = match options.scene.as_ref().and_then(|s| s.ranges.iter().find(|(name, _)| *name == axis.name)) {
            Some((_, r)) => axis
                .covering(r.lo, r.hi)
                .map_err(|e| anyhow::anyhow!("the scene needs {e} (the default preset's domain)"))?,
            None => 0..=axis.len() - 1,
        };
        out.push(axis.slice(range.clone()));
        kept.push(range);
    }
    Ok((out, kept))
}

/// A table the pipeline knows how to build.
pub struct TableDef {
    pub name: &'static str,
    /// The stage binary that builds it.
    pub stage: &'static str,
    pub definition: &'static str,
    /// The full grid's axes of a preset.
    pub axes: fn(Preset) -> Vec<Axis>,
    /// Whether a scene needs the table (epd tables always, diffraction ones
    /// only with a diffraction part).
    pub diffraction: bool,
    pub build: fn(Preset, &BuildOptions) -> Result<Built>,
    /// The presets that have this table.
    pub presets: &'static [Preset],
}

pub const TABLES: &[TableDef] =
    &[epd::EPD_G1, epd::EPD_NORM, kcorr::KCORR_RENORM, zh::ZH_CONVOLUTION, zh_lobe::ZH_LOBE];

/// The tables a preset has.
pub fn of_preset(preset: Preset) -> impl Iterator<Item = &'static TableDef> {
    TABLES.iter().filter(move |t| t.presets.contains(&preset))
}

pub fn find(name: &str) -> Result<&'static TableDef, String> {
    TABLES.iter().find(|t| t.name == name).ok_or_else(|| {
        let known: Vec<&str> = TABLES.iter().map(|t| t.name).collect();
        format!("unknown table {name:?} (known: {})", known.join(", "))
    })
}
