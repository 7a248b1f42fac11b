//! A table's build as a job: units of work that any process computes apart (shards), the part
//! they yield, and the finish that assembles the table and measures its accuracy.

use crate::progress::Progress;
use serde_json::Value;
use twoscale_tables::table::Table;

/// What a table build returns besides the data.
#[derive(Clone, Debug)]
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
