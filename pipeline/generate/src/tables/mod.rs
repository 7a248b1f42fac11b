//! The tables: one module per stage, and the registry the CLI builds from.

pub mod context;
pub mod epd;
pub mod epd_albedo;
pub mod epd_albedo_column;
pub mod epd_albedo_math;
pub mod epd_math;
pub mod kcorr;
pub mod kcorr_math;
pub mod lambda_table;
pub mod nodewise;
pub mod zh;
mod zh_budget;
pub mod zh_fit;
pub mod zh_lobe;
pub mod zh_math;

use context::BuildContext;
use std::sync::Arc;
use twoscale_tables::axis::Axis;
use crate::progress::Progress;
use crate::scene::Range;
use std::ops::RangeInclusive;
use crate::table::Table;
use anyhow::Result;
use serde_json::Value;
use std::fmt;
use std::str::FromStr;

/// The presets of docs/maths.md section 5.
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
#[derive(Debug)]
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
    pub derived: twoscale_tables::derived::Derived,
}

/// How `zh_convolution` computes C (docs/maths.md section 4).
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
    /// What the jobs of one build share (none: each job computes from cold).
    pub context: Option<Arc<BuildContext>>,
}

/// A scene build: its name (the output directory is `scene-<name>`), the
/// scene file's SHA-256, and the ranges each axis needs.
#[derive(Clone, Debug)]
pub struct SceneTarget {
    pub name: String,
    pub sha256: String,
    pub ranges: Vec<(String, Range)>,
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

/// The axes restricted to the options' sub-domain (`restrict`); for a cubic table also widened
/// by a node on either side, to at least 4 nodes, so that every point of the sub-domain reads the
/// stencil it reads in the whole table.
pub fn sub_domain(axes: Vec<Axis>, cubic: bool, options: &BuildOptions) -> Result<Vec<Axis>> {
    let (restricted, kept) = restrict(axes.clone(), options)?;
    if !cubic {
        return Ok(restricted);
    }
    Ok(axes
        .iter()
        .zip(kept)
        .map(|(axis, range)| {
            let last = axis.len() - 1;
            let (mut lo, mut hi) = (range.start().saturating_sub(1), (range.end() + 1).min(last));
            while hi - lo < 3 {
                if lo > 0 { lo -= 1 } else { hi += 1 }
            }
            axis.slice(lo..=hi)
        })
        .collect())
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
    /// Interpolated cubically: a scene's sub-domain keeps a node beyond each end (`sub_domain`).
    pub cubic: bool,
    /// The build's work for a preset and options, in units that can be
    /// computed apart (shards) and finished together.
    pub job: fn(Preset, &BuildOptions) -> Result<Box<dyn Job>>,
    /// The presets that have this table.
    pub presets: &'static [Preset],
}

impl TableDef {
    /// The whole table in this process: every unit, then the finish.
    pub fn build(&self, preset: Preset, options: &BuildOptions) -> Result<Built> {
        let job = (self.job)(preset, options)?;
        let part = job.compute(Units::all(job.units()), options.progress);
        Ok(job.finish(part))
    }
}

/// A table's build split into units of work that do not depend on one
/// another (nodes, or zh_convolution's (p, beta) pairs): any set of units can
/// be computed on its own, and the finish (assembly, accuracy) sees them all.
pub trait Job: Sync {
    /// How many units there are.
    fn units(&self) -> usize;
    /// Entries per unit in every column of a `Part`.
    fn unit_len(&self) -> usize;
    /// What one unit is, for the shard manifest.
    fn unit_name(&self) -> &'static str;
    /// Computes `units`; each column holds `unit_len` entries per unit, in the order of `units`.
    fn compute(&self, units: Units, progress: Progress) -> Part;
    /// The table, its accuracy and settings from the part of every unit (in unit order).
    fn finish(&self, whole: Part) -> Built;
}

/// A set of units: `start`, `start + step`, ... (`count` of them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Units {
    pub start: usize,
    pub step: usize,
    pub count: usize,
}

impl Units {
    pub fn all(total: usize) -> Units {
        Units { start: 0, step: 1, count: total }
    }

    /// Shard k of n: the units i with i mod n = k. Round-robin rather than
    /// contiguous ranges because neighbouring units cost alike (epd_g1's cost
    /// grows as p falls, zh's with the sharpness of the lobe), so every shard
    /// gets the same mix; counts differ by at most one.
    pub fn shard(total: usize, k: usize, n: usize) -> Units {
        Units { start: k, step: n, count: if k < total { (total - k).div_ceil(n) } else { 0 } }
    }

    pub fn get(&self, j: usize) -> usize {
        self.start + j * self.step
    }

    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.count).map(|j| self.get(j))
    }
}

/// What computing a set of units yields: columns of `unit_len` entries per
/// unit, in the order of the units.
#[derive(Clone, Debug, Default)]
pub struct Part {
    /// The stored values (f32, as in the table).
    pub values: Vec<(String, Vec<f32>)>,
    /// Per-node data that the finish needs and the table does not store (fit
    /// residuals, iteration counts, flags: counts and flags as exact f64).
    pub extras: Vec<(String, Vec<f64>)>,
    /// Wall seconds of the computation.
    pub compute_seconds: f64,
    /// Seconds of `compute_seconds` that any set of units costs (work every shard repeats).
    pub setup_seconds: f64,
    /// Breakdown of `compute_seconds` by stage (JSON object of seconds, summed over parts) or null.
    pub stages: Value,
}

pub const TABLES: &[TableDef] =
    &[epd::EPD_G1, epd::EPD_NORM, kcorr::KCORR_RENORM, zh::ZH_CONVOLUTION, zh_lobe::ZH_LOBE, epd_albedo::EPD_ALBEDO, epd_albedo::EPD_ALBEDO_AVG];

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
