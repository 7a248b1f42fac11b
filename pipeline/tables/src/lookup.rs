//! A table as a renderer reads it: physical coordinates in, physical values
//! out. Derived axes are computed from the physical coordinates, every stored
//! value interpolated (multilinear or cubic) with the same node weights (`interp`),
//! then decoded (`derived::ValueEncoding`; zh_lobe's control variates, `lobe`).

use crate::axis::{Axis, DomainError};
use crate::derived::{DerivedAxis, EncodedValue};
use crate::file::open_table;
use crate::interp::{nodes_of, strides, Interpolation, Scratch};
use crate::lobe::{correction, LobeParams};
use anyhow::Result;
use ndarray::{ArrayD, ArrayViewD, IxDyn, ShapeBuilder};
use std::path::Path;

pub struct Lookup {
    pub table: String,
    pub axes: Vec<Axis>,
    /// The stored values' names, in the file's order.
    names: Vec<String>,
    /// Every stored value interleaved, node by node (`names.len()` per node):
    /// a lookup reads each corner's values from one cache line instead of
    /// one per dataset (zh_lobe: 1.9 -> 1.1 us on the 310 MB default table).
    interleaved: Vec<f32>,
    pub derived_axes: Vec<DerivedAxis>,
    pub value_encoding: Vec<EncodedValue>,
    /// Per axis: the derived axis computing it and the indices of its inputs among the coordinates.
    derivations: Vec<Option<(usize, Vec<usize>)>>,
    /// Per output: its index in `values` and how it is decoded.
    outputs: Vec<(usize, Decoding)>,
    pub interpolation: Interpolation,
    shape: Vec<usize>,
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
        Ok(Lookup::new(
            manifest.table,
            axes,
            values,
            manifest.derived_axes,
            manifest.value_encoding,
            manifest.interpolation,
        ))
    }

    /// A lookup on a table in memory, as `open_table` checks it: every
    /// encoded value and control variate names one of `values`, a derived
    /// axis's inputs are coordinates, control variates come four, with the
    /// coordinates u, c, p, beta, theta_h; a cubic table has uniform axes of at least 4 nodes.
    pub fn new(
        table: String,
        axes: Vec<Axis>,
        values: Vec<(String, ArrayD<f32>)>,
        derived_axes: Vec<DerivedAxis>,
        value_encoding: Vec<EncodedValue>,
        interpolation: Interpolation,
    ) -> Lookup {
        let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
        assert!(values.iter().all(|(_, v)| v.shape() == shape), "one axis per dimension, as long as the axis");
        assert!(
            interpolation.is_multilinear() || axes.iter().all(|a| a.len() >= 4 && a.is_uniform()),
            "cubic interpolation on uniform axes of at least 4 nodes"
        );
        let index = |name: &str| values.iter().position(|(n, _)| n == name).expect("encoded values are stored values");
        let coordinates: Vec<&str> = axes
            .iter()
            .map(|a| derived_axes.iter().find(|d| d.axis == a.name).map_or(a.name.as_str(), |d| d.coordinate.as_str()))
            .collect();
        let derivations = axes
            .iter()
            .map(|a| {
                let j = derived_axes.iter().position(|d| d.axis == a.name)?;
                let inputs = derived_axes[j]
                    .inputs
                    .iter()
                    .map(|n| coordinates.iter().position(|c| c == n).expect("derived inputs are coordinates"))
                    .collect();
                Some((j, inputs))
            })
            .collect();
        let control: Vec<usize> =
            value_encoding.iter().flat_map(|e| e.control_variates.iter().map(|cv| index(&cv.values))).collect();
        let outputs = (0..values.len())
            .filter(|i| !control.contains(i))
            .map(|i| {
                let decoding = match value_encoding.iter().find(|e| e.value == values[i].0) {
                    None => Decoding::Plain,
                    Some(e) if e.control_variates.is_empty() => Decoding::Ln,
                    Some(e) => {
                        Decoding::LnControlVariates(std::array::from_fn(|j| index(&e.control_variates[j].values)))
                    }
                };
                (i, decoding)
            })
            .collect();
        let strides = strides(&shape);
        let nodes: usize = shape.iter().product();
        let mut interleaved = vec![0.0f32; nodes * values.len()];
        for (k, (_, v)) in values.iter().enumerate() {
            let slots = interleaved.iter_mut().skip(k).step_by(values.len());
            // A slice where the array is in C order (a table as read): ndarray's iterator took 0.2 s on zh_lobe.
            match v.as_slice() {
                Some(flat) => slots.zip(flat).for_each(|(slot, &x)| *slot = x),
                None => slots.zip(v.iter()).for_each(|(slot, &x)| *slot = x),
            }
        }
        let names = values.into_iter().map(|(n, _)| n).collect();
        Lookup {
            table,
            axes,
            names,
            interleaved,
            derived_axes,
            value_encoding,
            derivations,
            outputs,
            interpolation,
            shape,
            strides,
        }
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
        self.outputs.iter().map(|(i, _)| self.names[*i].as_str()).collect()
    }

    /// The names of every stored value, in the file's order.
    pub fn value_names(&self) -> &[String] {
        &self.names
    }

    /// The nodes of the table (entries per stored value).
    pub fn nodes(&self) -> usize {
        self.interleaved.len() / self.names.len().max(1)
    }

    /// The stored value `name` at the nodes (a strided view of the interleaved values).
    pub fn value(&self, name: &str) -> Option<ArrayViewD<'_, f32>> {
        let k = self.names.iter().position(|n| n == name)?;
        let shape: Vec<usize> = self.axes.iter().map(Axis::len).collect();
        let strides: Vec<usize> = self.strides.iter().map(|s| s * self.names.len()).collect();
        Some(
            ArrayViewD::from_shape(IxDyn(&shape).strides(IxDyn(&strides)), &self.interleaved[k..])
                .expect("strides within the interleaved values"),
        )
    }

    /// The point in stored coordinates of the physical `point` (order of `coordinates`).
    pub fn stored_point(&self, point: &[f64]) -> Result<Vec<f64>, DomainError> {
        let mut stored = point.to_vec();
        self.store(point, &mut stored)?;
        Ok(stored)
    }

    /// `stored_point` into `stored`, which holds `point`.
    fn store(&self, point: &[f64], stored: &mut [f64]) -> Result<(), DomainError> {
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
        Ok(())
    }

    /// Every output at the physical `point`, decoded, in the order of `outputs`.
    pub fn decode(&self, point: &[f64]) -> Result<Vec<f64>, DomainError> {
        let mut out = vec![0.0; self.outputs.len()];
        self.decode_into(point, &mut out)?;
        Ok(out)
    }

    /// The first output at the physical `point`, decoded (a table of one output: its value).
    pub fn decode_first(&self, point: &[f64]) -> Result<f64, DomainError> {
        let mut out = Scratch::new(0.0, self.outputs.len());
        self.decode_into(point, &mut out)?;
        Ok(out[0])
    }

    /// `decode` into `out` (one slot per output), without allocating: a fit makes millions of
    /// lookups, where the allocations took a third of the time.
    pub fn decode_into(&self, point: &[f64], out: &mut [f64]) -> Result<(), DomainError> {
        assert_eq!(point.len(), self.axes.len(), "one coordinate per axis");
        assert_eq!(out.len(), self.outputs.len(), "one slot per output");
        // Physical coordinates outside their axes are reported before derivation.
        let mut cells = Scratch::new((0, 0.0), self.axes.len());
        for ((cell, axis), (&x, d)) in cells.iter_mut().zip(&self.axes).zip(point.iter().zip(&self.derivations)) {
            if d.is_none() {
                *cell = axis.locate(x)?;
            }
        }
        let mut stored = Scratch::new(0.0, point.len());
        stored.copy_from_slice(point);
        self.store(point, &mut stored)?;
        for ((cell, axis), (&x, d)) in cells.iter_mut().zip(&self.axes).zip(stored.iter().zip(&self.derivations)) {
            if d.is_some() {
                *cell = axis.locate(x)?;
            }
        }
        let nv = self.names.len();
        let mut sums = Scratch::new(0.0, nv);
        nodes_of(self.interpolation, &cells, &self.shape, &self.strides, |offset, w| {
            for (sum, &v) in sums.iter_mut().zip(&self.interleaved[offset * nv..(offset + 1) * nv]) {
                *sum += w * v as f64;
            }
        });
        for (slot, (i, decoding)) in out.iter_mut().zip(&self.outputs) {
            *slot = match decoding {
                Decoding::Plain => sums[*i],
                Decoding::Ln => sums[*i].exp(),
                Decoding::LnControlVariates(cvs) => {
                    // Checked by `open_table`: coordinates u, c, p, beta, theta_h (derived, stored as v).
                    let lobe = LobeParams { u: point[0], c: point[1], p: point[2], beta: point[3] };
                    (sums[*i] + correction(point[4], &lobe, stored[4], cvs.map(|k| sums[k]))).exp()
                }
            };
        }
        Ok(())
    }

    /// Every output at the physical `point`, decoded, with its name.
    pub fn at(&self, point: &[f64]) -> Result<Vec<(String, f64)>, DomainError> {
        Ok(self.outputs().into_iter().map(String::from).zip(self.decode(point)?).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::AxisEncoding;
    use crate::interp::interpolate;
    use ndarray::Array2;

    #[test]
    fn interleaved_values_read_back_and_interpolate_as_each_dataset() {
        let axes = vec![
            Axis::new("x", vec![1.0, 2.0, 4.0], AxisEncoding::Log),
            Axis::new("y", vec![0.0, 0.5, 1.0, 2.0], AxisEncoding::Linear),
        ];
        let a = Array2::from_shape_fn((3, 4), |(i, j)| (10 * i + j) as f32).into_dyn();
        let b = Array2::from_shape_fn((3, 4), |(i, j)| ((i as f32) - 0.3 * j as f32).sin()).into_dyn();
        let lookup = Lookup::new(
            "t".into(),
            axes.clone(),
            vec![("a".into(), a.clone()), ("b".into(), b.clone())],
            vec![],
            vec![],
            Interpolation::Multilinear,
        );
        assert_eq!(lookup.value("a").unwrap(), a.view());
        assert_eq!(lookup.value("b").unwrap(), b.view());
        assert!(lookup.value("c").is_none());
        assert_eq!((lookup.nodes(), lookup.outputs()), (12, vec!["a", "b"]));
        for pt in [[1.5, 0.25], [4.0, 2.0], [1.0, 0.0], [3.0, 1.7]] {
            let want = [interpolate(&axes, &a.view(), &pt).unwrap(), interpolate(&axes, &b.view(), &pt).unwrap()];
            assert_eq!(lookup.decode(&pt).unwrap(), want, "{pt:?}");
        }
        assert!(lookup.decode(&[0.5, 0.0]).is_err());
    }
}
