//! The tables: one module per stage, and the registry the CLI builds from.

pub mod epd;
pub mod epd_math;
pub mod kcorr;
pub mod kcorr_math;
pub mod zh;
pub mod zh_fit;
pub mod zh_math;

use crate::progress::Progress;
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
#[derive(Clone, Copy, Debug, Default)]
pub struct BuildOptions {
    pub progress: Progress,
    /// Zonal-harmonic degree L (zh_convolution; default from the preset).
    pub degree: Option<usize>,
    /// zh_convolution method (default from the preset).
    pub method: Option<Method>,
    /// Rebuild even when an existing table has the same inputs.
    pub force: bool,
}

/// A table the pipeline knows how to build.
pub struct TableDef {
    pub name: &'static str,
    /// The stage binary that builds it.
    pub stage: &'static str,
    pub definition: &'static str,
    pub build: fn(Preset, &BuildOptions) -> Result<Built>,
}

pub const TABLES: &[TableDef] = &[epd::EPD_G1, epd::EPD_NORM, kcorr::KCORR_RENORM, zh::ZH_CONVOLUTION];

pub fn find(name: &str) -> Result<&'static TableDef, String> {
    TABLES.iter().find(|t| t.name == name).ok_or_else(|| {
        let known: Vec<&str> = TABLES.iter().map(|t| t.name).collect();
        format!("unknown table {name:?} (known: {})", known.join(", "))
    })
}
