//! A table as a renderer reads it: physical coordinates in, physical values
//! out. Derived axes are computed from the physical coordinates, every stored
//! value interpolated multilinearly with the same cell weights (`interp`),
//! then decoded (`derived::ValueEncoding`; zh_lobe's control variates, `lobe`).

use crate::axis::{Axis, DomainError};
use crate::derived::{DerivedAxis, EncodedValue};
use crate::file::open_table;
use crate::interp::{corners, strides};
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
    /// Per axis: the derived axis computing it and the indices of its inputs among the coordinates.
    derivations: Vec<Option<(usize, Vec<usize>)>>,
    /// Per output: its index in `values` and how it is decoded.
    outputs: Vec<(usize, Decoding)>,
    strides: Vec<usize>,
}

/// How an output is decoded from its interpolated stored value.
enum Decoding {
    Plain,
    Ln,
    /// ln with zh_lobe's control variates: the indices in `values` of `Term::ALL`'s values.
    LnControlVariates([usize; 4]),
}

impl Lookup {
    /// Opens `table` in `dir` (checksums verified).
    pub fn open(dir: &Path, table: &str) -> Result<Lookup> {
        let (manifest, axes, values) = open_table(dir, table)?;
        Ok(Lookup::new(manifest.table, axes, values, manifest.derived_axes, manifest.value_encoding))
    }

    /// A lookup on a table in memory, as `open_table` checks it: every
    /// encoded value and control variate names one of `values`, a derived
    /// axis's inputs are coordinates, control variates come four, with the
    /// coordinates u, c, p, beta, theta_h.
    pub fn new(table: String, axes: Vec<Axis>, values: Vec<(String, ArrayD<f32>)>, derived_axes: Vec<DerivedAxis>, value_encoding: Vec<EncodedValue>) -> Lookup {
        let index = |name: &str| values.iter().position(|(n, _)| n == name).expect("encoded values are stored values");
        let coordinates: Vec<&str> =
            axes.iter().map(|a| derived_axes.iter().find(|d| d.axis == a.name).map_or(a.name.as_str(), |d| d.coordinate.as_str())).collect();
        let derivations = axes
            .iter()
            .map(|a| {
                let j = derived_axes.iter().position(|d| d.axis == a.name)?;
                let inputs = derived_axes[j].inputs.iter().map(|n| coordinates.iter().position(|c| c == n).expect("derived inputs are coordinates")).collect();
                Some((j, inputs))
            })
            .collect();
        let control: Vec<usize> = value_encoding.iter().flat_map(|e| e.control_variates.iter().map(|cv| index(&cv.values))).collect();
        let outputs = (0..values.len())
            .filter(|i| !control.contains(i))
            .map(|i| {
                let decoding = match value_encoding.iter().find(|e| e.value == values[i].0) {
                    None => Decoding::Plain,
                    Some(e) if e.control_variates.is_empty() => Decoding::Ln,
                    Some(e) => Decoding::LnControlVariates(std::array::from_fn(|j| index(&e.control_variates[j].values))),
                };
                (i, decoding)
            })
            .collect();
        let strides = strides(&axes.iter().map(Axis::len).collect::<Vec<_>>());
        Lookup { table, axes, values, derived_axes, value_encoding, derivations, outputs, strides }
    }

    /// The physical coordinates a lookup takes, in order: each stored axis,
    /// or the physical coordinate a derived axis is computed from.
    pub fn coordinates(&self) -> Vec<String> {
        self.axes
            .iter()
            .zip(&self.derivations)
            .map(|(a, d)| d.as_ref().map_or_else(|| a.name.clone(), |(j, _)| self.derived_axes[*j].coordinate.clone()))
            .collect()
    }

    /// The names of the values a lookup returns, in order: every stored value
    /// but those holding control variates.
    pub fn outputs(&self) -> Vec<&str> {
        self.outputs.iter().map(|(i, _)| self.values[*i].0.as_str()).collect()
    }

    /// The point in stored coordinates of the physical `point` (order of `coordinates`).
    pub fn stored_point(&self, point: &[f64]) -> Result<Vec<f64>, DomainError> {
        let mut stored = point.to_vec();
        for (i, derivation) in self.derivations.iter().enumerate() {
            let Some((j, inputs)) = derivation else { continue };
            let d = &self.derived_axes[*j];
            let x = point[i];
            if x.is_nan() || x < d.min || x > d.max {
                return Err(DomainError { axis: d.coordinate.clone(), value: x, min: d.min, max: d.max });
            }
            let mut args = [0.0; 3];
            for (a, &k) in args.iter_mut().zip(inputs) {
                *a = point[k];
            }
            stored[i] = d.derivation.forward(x, &args[..inputs.len()]);
        }
        Ok(stored)
    }

    /// Every output at the physical `point`, decoded, in the order of `outputs`.
    pub fn decode(&self, point: &[f64]) -> Result<Vec<f64>, DomainError> {
        assert_eq!(point.len(), self.axes.len(), "one coordinate per axis");
        // Physical coordinates outside their axes are reported before derivation.
        let mut cells = vec![(0, 0.0); self.axes.len()];
        for ((cell, axis), (&x, d)) in cells.iter_mut().zip(&self.axes).zip(point.iter().zip(&self.derivations)) {
            if d.is_none() {
                *cell = axis.locate(x)?;
            }
        }
        let stored = self.stored_point(point)?;
        for ((cell, axis), (&x, d)) in cells.iter_mut().zip(&self.axes).zip(stored.iter().zip(&self.derivations)) {
            if d.is_some() {
                *cell = axis.locate(x)?;
            }
        }
        let data: Vec<&[f32]> = self.values.iter().map(|(_, v)| v.as_slice().expect("values in C order")).collect();
        let mut sums = vec![0.0; data.len()];
        corners(&cells, &self.strides, |offset, w| {
            for (sum, v) in sums.iter_mut().zip(&data) {
                *sum += w * v[offset] as f64;
            }
        });
        let decoded = self.outputs.iter().map(|(i, decoding)| match decoding {
            Decoding::Plain => sums[*i],
            Decoding::Ln => sums[*i].exp(),
            Decoding::LnControlVariates(cvs) => {
                // Checked by `open_table`: coordinates u, c, p, beta, theta_h (derived, stored as v).
                let lobe = LobeParams { u: point[0], c: point[1], p: point[2], beta: point[3] };
                (sums[*i] + correction(point[4], &lobe, stored[4], cvs.map(|k| sums[k]))).exp()
            }
        });
        Ok(decoded.collect())
    }

    /// Every output at the physical `point`, decoded, with its name.
    pub fn at(&self, point: &[f64]) -> Result<Vec<(String, f64)>, DomainError> {
        Ok(self.outputs().into_iter().map(String::from).zip(self.decode(point)?).collect())
    }
}
