//! Tables computed node by node (`epd_g1`, `epd_norm`, `epd_quantile`): one unit of work per node
//! of the flat C-order grid; or row by row (`kcorr_renorm`, whose rule shares work across a row): one
//! unit per node of the first axis.

use super::job::{Built, Job, Part, Units};
use crate::numerics::tabulate::tabulate_nodes;
use crate::progress::Progress;
use indicatif::ParallelProgressIterator;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::Value;
use std::time::Instant;
use twoscale_tables::axis::Axis;
use twoscale_tables::table::Table;

/// How a table's values are computed.
pub enum Values {
    /// f at each node.
    Node(fn(&[f64]) -> f64),
    /// f(x, the other axes): every node whose first coordinate is x, in C order over the other axes.
    Row(fn(f64, &[Axis]) -> Vec<f64>),
}

/// The values at every node, then the accuracy of the whole table.
pub struct Nodewise {
    pub table: &'static str,
    pub preset: &'static str,
    pub axes: Vec<Axis>,
    pub value: &'static str,
    pub values: Values,
    /// The accuracy section and the settings, from the axes and the whole table.
    pub measure: fn(&[Axis], &ArrayD<f32>) -> (Value, Value),
}

impl Job for Nodewise {
    fn units(&self) -> usize {
        match self.values {
            Values::Node(_) => self.axes.iter().map(Axis::len).product(),
            Values::Row(_) => self.axes[0].len(),
        }
    }

    fn unit_len(&self) -> usize {
        match self.values {
            Values::Node(_) => 1,
            Values::Row(_) => self.axes[1..].iter().map(Axis::len).product(),
        }
    }

    fn unit_name(&self) -> &'static str {
        match self.values {
            Values::Node(_) => "node (flat C-order index)",
            Values::Row(_) => "node of the first axis",
        }
    }

    fn compute(&self, units: Units, progress: Progress) -> Part {
        let start = Instant::now();
        let data = match self.values {
            Values::Node(f) => tabulate_nodes(&self.axes, units.count, |j| units.get(j), self.table, progress, f),
            Values::Row(f) => {
                let bar = progress.bar(self.table, units.count as u64);
                let rows: Vec<Vec<f32>> = (0..units.count)
                    .into_par_iter()
                    .progress_with(bar.clone())
                    .map(|j| f(self.axes[0].nodes[units.get(j)], &self.axes[1..]).iter().map(|&v| v as f32).collect())
                    .collect();
                bar.finish_and_clear();
                rows.concat()
            }
        };
        Part {
            values: vec![(self.value.to_string(), data)],
            compute_seconds: start.elapsed().as_secs_f64(),
            ..Part::default()
        }
    }

    fn finish(&self, whole: Part) -> Built {
        let shape: Vec<usize> = self.axes.iter().map(Axis::len).collect();
        let data = whole.values.into_iter().next().expect("one value").1;
        let values = ArrayD::from_shape_vec(IxDyn(&shape), data).expect("one entry per node");
        let start = Instant::now();
        let (accuracy, settings) = (self.measure)(&self.axes, &values);
        let accuracy_seconds = start.elapsed().as_secs_f64();
        let table = Table {
            name: self.table.into(),
            preset: self.preset.into(),
            axes: self.axes.clone(),
            values: vec![(self.value.into(), values)],
        };
        Built {
            table,
            accuracy,
            settings,
            compute_seconds: whole.compute_seconds,
            accuracy_seconds,
            stages: whole.stages,
            derived: Default::default(),
        }
    }
}
