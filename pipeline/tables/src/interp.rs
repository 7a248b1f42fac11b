//! Interpolation in encoded coordinates (see `axis`): multilinear (every table but a few), or
//! tensor-product cubic on uniform axes (manifest `interpolation`, docs/file_contract.md).

use crate::axis::{Axis, DomainError};
use ndarray::ArrayViewD;
use serde::{Deserialize, Serialize};

/// How a table's values are interpolated between nodes (manifest and file contract `interpolation`;
/// absent means multilinear).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// The 2^N corners of the cell, weights prod (t or 1 - t).
    #[default]
    Multilinear,
    /// 4-point Lagrange along each axis (4^N nodes), the stencil shifted inwards in the end
    /// cells (`cubic_weights`). Every axis uniform in its encoding, with at least 4 nodes.
    Cubic,
}

impl Interpolation {
    pub fn is_multilinear(&self) -> bool {
        *self == Interpolation::Multilinear
    }
}

/// Interpolates `values` (shape = axis lengths, C order) at `point`
/// (physical coordinates, one per axis): the weighted sum of the 2^N corners
/// of the cell, weights from `Axis::locate`, in f64.
pub fn interpolate(axes: &[Axis], values: &ArrayViewD<f32>, point: &[f64]) -> Result<f64, DomainError> {
    Ok(interpolate_all(axes, std::slice::from_ref(values), point)?[0])
}

/// `interpolate` of several datasets over the same axes at one point: the
/// cell and weights are found once.
pub fn interpolate_all(axes: &[Axis], values: &[ArrayViewD<f32>], point: &[f64]) -> Result<Vec<f64>, DomainError> {
    assert_eq!(axes.len(), point.len(), "one coordinate per axis");
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    assert!(values.iter().all(|v| v.shape() == shape), "one axis per dimension, as long as the axis");
    let data: Vec<&[f32]> = values.iter().map(|v| v.as_slice().expect("values in C order")).collect();
    let cells: Vec<(usize, f64)> = axes.iter().zip(point).map(|(axis, &x)| axis.locate(x)).collect::<Result<_, _>>()?;
    let mut sums = vec![0.0; values.len()];
    corners(&cells, &strides(&shape), |offset, w| {
        for (sum, v) in sums.iter_mut().zip(&data) {
            *sum += w * v[offset] as f64;
        }
    });
    Ok(sums)
}

/// C-order strides of `shape`: the flat offset of an index is sum_d index_d stride_d.
pub fn strides(shape: &[usize]) -> Vec<usize> {
    let mut strides = vec![1usize; shape.len()];
    for d in (0..shape.len().saturating_sub(1)).rev() {
        strides[d] = strides[d + 1] * shape[d + 1];
    }
    strides
}

/// Scratch space for `n` values: on the stack up to `STACK` (every table the pipeline builds has
/// at most 5 axes and 5 stored values), else on the heap. A fit makes millions of lookups, where
/// the allocations took a third of the time.
pub(crate) enum Scratch<T> {
    Stack([T; STACK], usize),
    Heap(Vec<T>),
}

const STACK: usize = 8;

impl<T: Copy> Scratch<T> {
    pub(crate) fn new(fill: T, n: usize) -> Scratch<T> {
        if n <= STACK {
            Scratch::Stack([fill; STACK], n)
        } else {
            Scratch::Heap(vec![fill; n])
        }
    }
}

impl<T> std::ops::Deref for Scratch<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        match self {
            Scratch::Stack(a, n) => &a[..*n],
            Scratch::Heap(v) => v,
        }
    }
}

impl<T> std::ops::DerefMut for Scratch<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        match self {
            Scratch::Stack(a, n) => &mut a[..*n],
            Scratch::Heap(v) => v,
        }
    }
}

/// Calls `f(offset, weight)` for each of the 2^N corners of the cell with
/// nonzero weight: `cells` holds (lower node index, t) per axis (`Axis::locate`).
/// The weights and offsets are built axis by axis (corner bit d: the upper
/// node along axis d), 2^(N+1) products instead of N 2^N.
pub fn corners(cells: &[(usize, f64)], strides: &[usize], mut f: impl FnMut(usize, f64)) {
    let n = 1 << cells.len();
    // On the stack up to 5 axes (every table the pipeline builds), else on the heap.
    let (mut stack_w, mut stack_o) = ([0.0f64; 32], [0usize; 32]);
    let (mut heap_w, mut heap_o) = (Vec::new(), Vec::new());
    let (weight, offset): (&mut [f64], &mut [usize]) = if n <= 32 {
        (&mut stack_w[..n], &mut stack_o[..n])
    } else {
        heap_w.resize(n, 0.0);
        heap_o.resize(n, 0);
        (&mut heap_w, &mut heap_o)
    };
    weight[0] = 1.0;
    offset[0] = cells.iter().zip(strides).map(|(c, s)| c.0 * s).sum();
    for (d, &(_, t)) in cells.iter().enumerate() {
        let half = 1 << d;
        for k in 0..half {
            weight[k + half] = weight[k] * t;
            offset[k + half] = offset[k] + strides[d];
            weight[k] *= 1.0 - t;
        }
    }
    for (&w, &o) in weight.iter().zip(offset.iter()) {
        if w != 0.0 {
            f(o, w);
        }
    }
}

/// The cubic stencil of cell `i` (weight `t` of its upper node, `Axis::locate`) on an axis of `n`
/// uniform nodes: the first node s of the four s..s+3, s = clamp(i, 1, n - 3) - 1, and their
/// Lagrange weights at tau = t + i - s - 1, the position from node s + 1 in node spacings
/// (nodes at tau = -1, 0, 1, 2). Exactly 0 and 1 at a node.
pub fn cubic_weights(i: usize, t: f64, n: usize) -> (usize, [f64; 4]) {
    assert!(n >= 4, "a cubic axis has at least 4 nodes");
    let s = i.clamp(1, n - 3) - 1;
    let tau = t + (i - s) as f64 - 1.0;
    let w = [
        -tau * (tau - 1.0) * (tau - 2.0) / 6.0,
        (tau + 1.0) * (tau - 1.0) * (tau - 2.0) / 2.0,
        -(tau + 1.0) * tau * (tau - 2.0) / 2.0,
        (tau + 1.0) * tau * (tau - 1.0) / 6.0,
    ];
    (s, w)
}

/// Calls `f(offset, weight)` for each of the 4^N nodes of the cubic stencil with nonzero weight:
/// `cells` holds (lower node index, t) per axis (`Axis::locate`), `lens` the axes' lengths.
pub fn cubic_nodes(cells: &[(usize, f64)], lens: &[usize], strides: &[usize], mut f: impl FnMut(usize, f64)) {
    let mut stencils = Scratch::new((0usize, [0.0f64; 4]), cells.len());
    for (out, (&(i, t), &n)) in stencils.iter_mut().zip(cells.iter().zip(lens)) {
        *out = cubic_weights(i, t, n);
    }
    let base: usize = stencils.iter().zip(strides).map(|((s, _), stride)| s * stride).sum();
    // Node k of the 4^N in C order (axis 0 slowest): digit N - 1 - d of k in base 4 is the node along axis d.
    let n = cells.len();
    for k in 0..1usize << (2 * n) {
        let (mut w, mut offset) = (1.0, base);
        for (d, ((_, wd), stride)) in stencils.iter().zip(strides).enumerate() {
            let a = (k >> (2 * (n - 1 - d))) & 3;
            w *= wd[a];
            offset += a * stride;
        }
        if w != 0.0 {
            f(offset, w);
        }
    }
}

/// `cells` interpolated in `data` (C order over axes of lengths `lens`) by `kind`: calls
/// `f(offset, weight)` for every node with nonzero weight.
pub fn nodes_of(
    kind: Interpolation,
    cells: &[(usize, f64)],
    lens: &[usize],
    strides: &[usize],
    f: impl FnMut(usize, f64),
) {
    match kind {
        Interpolation::Multilinear => corners(cells, strides, f),
        Interpolation::Cubic => cubic_nodes(cells, lens, strides, f),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::AxisEncoding as Encoding;
    use ndarray::{Array2, IxDyn};

    #[test]
    fn bilinear_is_exact_for_bilinear_functions_in_encoded_coordinates() {
        let x = Axis::new("x", vec![1.0, 2.0, 4.0, 8.0], Encoding::Log);
        let y = Axis::new("y", vec![0.0, 0.5, 1.0], Encoding::Linear);
        let f = |x: f64, y: f64| 3.0 + 2.0 * x.ln() - y + 0.5 * x.ln() * y;
        let v = Array2::from_shape_fn((4, 3), |(i, j)| f(x.nodes[i], y.nodes[j]) as f32).into_dyn();
        for &(px, py) in &[(1.0, 0.0), (3.0, 0.25), (8.0, 1.0), (5.5, 0.9)] {
            let got = interpolate(&[x.clone(), y.clone()], &v.view(), &[px, py]).unwrap();
            assert!((got - f(px, py)).abs() < 1e-5, "({px},{py}): {got} vs {}", f(px, py));
        }
        assert!(interpolate(&[x.clone(), y.clone()], &v.view(), &[0.5, 0.5]).is_err());
        let v1 = v.into_shape_with_order(IxDyn(&[12])).unwrap();
        assert!(std::panic::catch_unwind(|| interpolate(&[x.clone(), y.clone()], &v1.view(), &[1.0, 0.0])).is_err());
    }

    #[test]
    fn several_datasets_interpolate_as_each_alone() {
        let x = Axis::new("x", vec![1.0, 2.0, 4.0, 8.0], Encoding::Log);
        let y = Axis::new("y", vec![0.0, 0.5, 1.0], Encoding::Linear);
        let axes = [x, y];
        let a = Array2::from_shape_fn((4, 3), |(i, j)| (i * 3 + j) as f32).into_dyn();
        let b = Array2::from_shape_fn((4, 3), |(i, j)| ((i as f32) - 2.0 * j as f32).sin()).into_dyn();
        for pt in [[1.5, 0.25], [8.0, 1.0], [3.0, 0.0]] {
            let both = interpolate_all(&axes, &[a.view(), b.view()], &pt).unwrap();
            assert_eq!(
                both,
                [interpolate(&axes, &a.view(), &pt).unwrap(), interpolate(&axes, &b.view(), &pt).unwrap()]
            );
        }
        // Bilinear in (ln x, y): the corners of the cell at [1.5, 0.25] are (0,0), (1,0), (0,1), (1,1).
        let t = (1.5f64.ln() - 0.0) / 2f64.ln();
        let want = (1.0 - t) * 0.5 * (0.0 + 1.0) + t * 0.5 * (3.0 + 4.0);
        assert!((interpolate(&axes, &a.view(), &[1.5, 0.25]).unwrap() - want).abs() < 1e-12);
    }

    #[test]
    fn cubic_reproduces_cubics_in_encoded_coordinates_and_nodes_exactly() {
        // Uniform in each encoding; f cubic in (1/x, ln y) with a mixed term.
        let x = Axis::uniform("x", Encoding::Reciprocal, 5.0, 0.05, 7);
        let y = Axis::uniform("y", Encoding::Log, 0.005, 0.5, 5);
        let f = |x: f64, y: f64| {
            let (u, v) = (1.0 / x, y.ln());
            0.3 + 0.02 * u.powi(3) - 0.1 * u * u + v.powi(3) / 50.0 + 0.01 * u * v * v
        };
        let lens = [x.len(), y.len()];
        let v = Array2::from_shape_fn((7, 5), |(i, j)| f(x.nodes[i], y.nodes[j])).into_dyn();
        let st = strides(&lens);
        let data = v.as_slice().unwrap();
        let at = |px: f64, py: f64| {
            let cells = [x.locate(px).unwrap(), y.locate(py).unwrap()];
            let mut sum = 0.0;
            cubic_nodes(&cells, &lens, &st, |o, w| sum += w * data[o]);
            sum
        };
        // Nodes: exactly the stored value (weights 0 and 1).
        for (i, j) in [(0, 0), (3, 2), (6, 4), (1, 3)] {
            assert_eq!(at(x.nodes[i], y.nodes[j]), data[i * 5 + j]);
        }
        // First, interior and last cells on both axes.
        for &(px, py) in &[(4.0, 0.006), (0.3, 0.05), (0.06, 0.45), (1.1, 0.4), (0.051, 0.0051)] {
            let want = f(px, py);
            assert!((at(px, py) - want).abs() < 1e-12 * want.abs().max(1.0), "({px},{py}): {} vs {want}", at(px, py));
        }
        // Weights sum to 1 and place the stencil inside the axis.
        for (i, t, n) in [(0, 0.3, 4), (2, 0.9, 4), (5, 0.5, 9), (7, 1.0, 9)] {
            let (s, w) = cubic_weights(i, t, n);
            assert!(s + 3 < n && (w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        }
    }
}
