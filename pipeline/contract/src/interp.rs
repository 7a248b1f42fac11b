//! Multilinear interpolation in encoded coordinates (see `axis`).

use crate::axis::{Axis, DomainError};
use ndarray::ArrayViewD;

/// Interpolates `values` (shape = axis lengths, C order) at `point`
/// (physical coordinates, one per axis): the weighted sum of the 2^N corners
/// of the cell, weights from `Axis::locate`, in f64.
pub fn interpolate(axes: &[Axis], values: &ArrayViewD<f32>, point: &[f64]) -> Result<f64, DomainError> {
    interpolate_with(axes, values, point, |_| |_| 0.0)
}

/// `interpolate` of the stored values plus an adjustment at each corner: the
/// interpolation of (stored - g) at the nodes for a closed-form g (a control
/// variate; see `lobe`), without a table of g. `prepare(cell)`,
/// called once with the cell's lower node index per axis, returns the
/// adjustment by corner (bit d set: the upper node along axis d), so that
/// terms shared by corners are computed once.
pub fn interpolate_with<F: Fn(usize) -> f64>(
    axes: &[Axis],
    values: &ArrayViewD<f32>,
    point: &[f64],
    prepare: impl FnOnce(&[usize]) -> F,
) -> Result<f64, DomainError> {
    assert_eq!(axes.len(), point.len(), "one coordinate per axis");
    assert_eq!(axes.len(), values.ndim(), "one axis per dimension");
    let cells: Vec<(usize, f64)> =
        axes.iter().zip(point).map(|(axis, &x)| axis.locate(x)).collect::<Result<_, _>>()?;
    let lower: Vec<usize> = cells.iter().map(|c| c.0).collect();
    let adjust = prepare(&lower);
    let mut sum = 0.0;
    let mut index = vec![0usize; axes.len()];
    for corner in 0..(1usize << axes.len()) {
        let mut w = 1.0;
        for (d, &(i, t)) in cells.iter().enumerate() {
            let upper = (corner >> d) & 1 == 1;
            index[d] = i + upper as usize;
            w *= if upper { t } else { 1.0 - t };
        }
        if w != 0.0 {
            sum += w * (values[index.as_slice()] as f64 + adjust(corner));
        }
    }
    Ok(sum)
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
    fn a_control_variate_removes_the_interpolation_error_of_its_own_term() {
        // Stored f + g with f bilinear in the encoded axes and g curved: the
        // interpolation of (stored - g) plus g at the point is f + g exactly,
        // while plain interpolation misses g's curvature.
        let x = Axis::new("x", vec![1.0, 2.0, 4.0, 8.0], Encoding::Log);
        let y = Axis::new("y", vec![0.0, 0.5, 1.0], Encoding::Linear);
        let f = |x: f64, y: f64| 3.0 + 2.0 * x.ln() - y + 0.5 * x.ln() * y;
        let g = |x: f64, y: f64| (x * y).sin() + x.sqrt();
        let axes = [x.clone(), y.clone()];
        let v = Array2::from_shape_fn((4, 3), |(i, j)| (f(x.nodes[i], y.nodes[j]) + g(x.nodes[i], y.nodes[j])) as f32).into_dyn();
        for &(px, py) in &[(1.5, 0.25), (3.0, 0.75), (6.0, 0.1)] {
            let want = f(px, py) + g(px, py);
            let plain = interpolate(&axes, &v.view(), &[px, py]).unwrap();
            let at_corner = |cell: &[usize]| {
                let (i, j) = (cell[0], cell[1]);
                let (x, y) = (&x.nodes, &y.nodes);
                move |corner: usize| -g(x[i + (corner & 1)], y[j + (corner >> 1 & 1)])
            };
            let with = interpolate_with(&axes, &v.view(), &[px, py], at_corner).unwrap() + g(px, py);
            assert!((with - want).abs() < 1e-5, "({px},{py}): {with} vs {want}");
            assert!((plain - want).abs() > 1e-3, "({px},{py}): plain interpolation is already exact: {plain} vs {want}");
        }
    }
}
