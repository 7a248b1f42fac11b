//! A table as a renderer reads it: physical coordinates in, physical values
//! out. Derived axes are computed from the physical coordinates, the stored
//! values interpolated multilinearly (`interp`), then decoded (`derived`;
//! zh_lobe's control variates enter the interpolation, `lobe`).

use crate::axis::{Axis, DomainError};
use crate::derived::{DerivedAxis, EncodedValue, ValueEncoding as Encoding};
use crate::file::open_table;
use crate::interp::interpolate;
use crate::lobe::decode_lobe;
use anyhow::Result;
use ndarray::ArrayD;
use std::path::Path;

pub struct Lookup {
    pub table: String,
    pub axes: Vec<Axis>,
    pub values: Vec<(String, ArrayD<f32>)>,
    pub derived_axes: Vec<DerivedAxis>,
    pub value_encoding: Vec<EncodedValue>,
}

impl Lookup {
    /// Opens `table` in `dir` (checksums verified).
    pub fn open(dir: &Path, table: &str) -> Result<Lookup> {
        let (manifest, axes, values) = open_table(dir, table)?;
        Ok(Lookup {
            table: manifest.table,
            axes,
            values,
            derived_axes: manifest.derived_axes,
            value_encoding: manifest.value_encoding,
        })
    }

    /// The physical coordinates a lookup takes, in order: each stored axis,
    /// or the physical coordinate a derived axis is computed from.
    pub fn coordinates(&self) -> Vec<String> {
        self.axes
            .iter()
            .map(|a| self.derived(&a.name).map_or_else(|| a.name.clone(), |d| d.coordinate.clone()))
            .collect()
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

    /// Every value at the physical `point`, decoded.
    pub fn at(&self, point: &[f64]) -> Result<Vec<(String, f64)>, DomainError> {
        // Physical coordinates outside their axes are reported before derivation.
        for (axis, &x) in self.axes.iter().zip(point) {
            if self.derived(&axis.name).is_none() {
                axis.locate(x)?;
            }
        }
        let stored = self.stored_point(point)?;
        self.values
            .iter()
            .map(|(name, data)| {
                let decoded = match self.value_encoding.iter().find(|e| &e.value == name).map(|e| e.encoding) {
                    None => interpolate(&self.axes, &data.view(), &stored)?,
                    Some(Encoding::Ln) => interpolate(&self.axes, &data.view(), &stored)?.exp(),
                    Some(kind @ (Encoding::LnControlVariates | Encoding::LnControlVariatesTails | Encoding::LnControlVariatesEpd)) => {
                        let derivation = &self.derived(&self.axes[4].name).expect("checked by open_table").derivation;
                        decode_lobe(&self.axes, data, derivation, kind, &point[..4], point[4])?
                    }
                };
                Ok((name.clone(), decoded))
            })
            .collect()
    }
}
