//! Multilinear interpolation in encoded coordinates (see `axis`).

use crate::axis::{Axis, DomainError};
use ndarray::ArrayViewD;

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
    let cells: Vec<(usize, f64)> =
        axes.iter().zip(point).map(|(axis, &x)| axis.locate(x)).collect::<Result<_, _>>()?;
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
            assert_eq!(both, [interpolate(&axes, &a.view(), &pt).unwrap(), interpolate(&axes, &b.view(), &pt).unwrap()]);
        }
        // Bilinear in (ln x, y): the corners of the cell at [1.5, 0.25] are (0,0), (1,0), (0,1), (1,1).
        let t = (1.5f64.ln() - 0.0) / 2f64.ln();
        let want = (1.0 - t) * 0.5 * (0.0 + 1.0) + t * 0.5 * (3.0 + 4.0);
        assert!((interpolate(&axes, &a.view(), &[1.5, 0.25]).unwrap() - want).abs() < 1e-12);
    }
}
