//! A table as a renderer reads it: physical coordinates in, physical values
//! out. Derived axes are computed from the physical coordinates, every stored
//! value interpolated multilinearly with the same cell weights (`interp`),
//! then decoded (`derived::ValueEncoding`; zh_lobe's control variates, `lobe`).

use crate::axis::{Axis, DomainError};
use crate::derived::{DerivedAxis, EncodedValue};
use crate::file::open_table;
use crate::interp::interpolate_all;
use crate::lobe::{correction, LobeParams};
use anyhow::Result;
use ndarray::ArrayD;
use std::path::Path;

pub struct Lookup {
    pub table: String,
    pub axes: Vec<Axis>,
    pub values: Vec<(String, ArrayD<f32>)>,
    pub derived_axes: Vec<DerivedAxis>,
    pub value_encoding: Vec<EncodedValue>,
    /// Per output: its index in `values`, and the indices of its control variates' values.
    outputs: Vec<(usize, Vec<usize>)>,
}

impl Lookup {
    /// Opens `table` in `dir` (checksums verified).
    pub fn open(dir: &Path, table: &str) -> Result<Lookup> {
        let (manifest, axes, values) = open_table(dir, table)?;
        Ok(Lookup::new(manifest.table, axes, values, manifest.derived_axes, manifest.value_encoding))
    }

    /// A lookup on a table in memory (as `open_table` checks it: every encoded
    /// value and control variate names one of `values`).
    pub fn new(table: String, axes: Vec<Axis>, values: Vec<(String, ArrayD<f32>)>, derived_axes: Vec<DerivedAxis>, value_encoding: Vec<EncodedValue>) -> Lookup {
        let index = |name: &str| values.iter().position(|(n, _)| n == name).expect("encoded values are stored values");
        let control: Vec<usize> = value_encoding.iter().flat_map(|e| e.control_variates.iter().map(|cv| index(&cv.values))).collect();
        let outputs = (0..values.len())
            .filter(|i| !control.contains(i))
            .map(|i| {
                let cvs = value_encoding.iter().find(|e| e.value == values[i].0).map_or_else(Vec::new, |e| e.control_variates.iter().map(|cv| index(&cv.values)).collect());
                (i, cvs)
            })
            .collect();
        Lookup { table, axes, values, derived_axes, value_encoding, outputs }
    }

    /// The physical coordinates a lookup takes, in order: each stored axis,
    /// or the physical coordinate a derived axis is computed from.
    pub fn coordinates(&self) -> Vec<String> {
        self.axes
            .iter()
            .map(|a| self.derived(&a.name).map_or_else(|| a.name.clone(), |d| d.coordinate.clone()))
            .collect()
    }

    /// The names of the values a lookup returns, in order: every stored value
    /// but those holding control variates.
    pub fn outputs(&self) -> Vec<&str> {
        self.outputs.iter().map(|(i, _)| self.values[*i].0.as_str()).collect()
    }

    fn derived(&self, axis: &str) -> Option<&DerivedAxis> {
        self.derived_axes.iter().find(|d| d.axis == axis)
    }

    /// The point in stored coordinates of the physical `point` (order of `coordinates`).
    pub fn stored_point(&self, point: &[f64]) -> Result<Vec<f64>, DomainError> {
        let names = self.coordinates();
        let mut stored = point.to_vec();
        for (i, axis) in self.axes.iter().enumerate() {
            let Some(d) = self.derived(&axis.name) else { continue };
            let x = point[i];
            if x.is_nan() || x < d.min || x > d.max {
                return Err(DomainError { axis: d.coordinate.clone(), value: x, min: d.min, max: d.max });
            }
            let inputs: Vec<f64> = d
                .inputs
                .iter()
                .map(|n| point[names.iter().position(|m| m == n).expect("derived inputs are coordinates")])
                .collect();
            stored[i] = d.derivation.forward(x, &inputs);
        }
        Ok(stored)
    }

    /// Every output at the physical `point`, decoded, in the order of `outputs`.
    pub fn decode(&self, point: &[f64]) -> Result<Vec<f64>, DomainError> {
        // Physical coordinates outside their axes are reported before derivation.
        for (axis, &x) in self.axes.iter().zip(point) {
            if self.derived(&axis.name).is_none() {
                axis.locate(x)?;
            }
        }
        let stored = self.stored_point(point)?;
        let views: Vec<_> = self.values.iter().map(|(_, v)| v.view()).collect();
        let interpolated = interpolate_all(&self.axes, &views, &stored)?;
        let decoded = self.outputs.iter().map(|(i, cvs)| {
            let name = &self.values[*i].0;
            let x = interpolated[*i];
            if !self.value_encoding.iter().any(|e| &e.value == name) {
                return x;
            }
            if cvs.is_empty() {
                return x.exp();
            }
            // Checked by `open_table`: coordinates u, c, p, beta, theta_h (derived, stored as v).
            let lobe = LobeParams { u: point[0], c: point[1], p: point[2], beta: point[3] };
            (x + correction(point[4], &lobe, stored[4], std::array::from_fn(|j| interpolated[cvs[j]]))).exp()
        });
        Ok(decoded.collect())
    }

    /// Every output at the physical `point`, decoded, with its name.
    pub fn at(&self, point: &[f64]) -> Result<Vec<(String, f64)>, DomainError> {
        Ok(self.outputs().into_iter().map(String::from).zip(self.decode(point)?).collect())
    }
}
