//! What the pipeline knows of a table: its name, stage, definition, axes per preset and job.

use super::job::{Built, Job, Units};
use super::options::BuildOptions;
use super::preset::Preset;
use anyhow::Result;
use twoscale_tables::axis::Axis;

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
