//! Tables computed node by node (`epd_g1`, `epd_norm`, `kcorr_renorm`): one
//! unit of work per node of the flat C-order grid.

use super::job::{Built, Job, Part, Units};
use crate::numerics::tabulate::tabulate_nodes;
use crate::progress::Progress;
use ndarray::{ArrayD, IxDyn};
use serde_json::Value;
use std::time::Instant;
use twoscale_tables::axis::Axis;
use twoscale_tables::table::Table;

/// f at every node, then the accuracy of the whole table.
pub struct Nodewise {
    pub table: &'static str,
    pub preset: &'static str,
    pub axes: Vec<Axis>,
    pub value: &'static str,
    pub f: fn(&[f64]) -> f64,
    /// The accuracy section and the settings, from the axes and the whole table.
    pub measure: fn(&[Axis], &ArrayD<f32>) -> (Value, Value),
}

impl Job for Nodewise {
    fn units(&self) -> usize {
        self.axes.iter().map(Axis::len).product()
    }

    fn unit_len(&self) -> usize {
        1
    }

    fn unit_name(&self) -> &'static str {
        "node (flat C-order index)"
    }

    fn compute(&self, units: Units, progress: Progress) -> Part {
        let start = Instant::now();
        let data = tabulate_nodes(&self.axes, units.count, |j| units.get(j), self.table, progress, self.f);
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
