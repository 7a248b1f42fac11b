//! Evaluating a function at every node of a tensor grid, in parallel.

use crate::grid::Axis;
use crate::progress::Progress;
use indicatif::ParallelProgressIterator;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;

/// f at every node (C order over `axes`), rounded to f32. Each entry is
/// computed independently, so the result does not depend on the thread count.
pub fn tabulate(axes: &[Axis], label: &str, progress: Progress, f: impl Fn(&[f64]) -> f64 + Sync) -> ArrayD<f32> {
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    let n: usize = shape.iter().product();
    let bar = progress.bar(label, n as u64);
    let data: Vec<f32> = (0..n)
        .into_par_iter()
        .progress_with(bar.clone())
        .map_init(
            || vec![0.0; axes.len()],
            |point, k| {
                let mut rem = k;
                for d in (0..axes.len()).rev() {
                    point[d] = axes[d].nodes[rem % shape[d]];
                    rem /= shape[d];
                }
                f(point) as f32
            },
        )
        .collect();
    bar.finish_and_clear();
    ArrayD::from_shape_vec(IxDyn(&shape), data).expect("shape matches the axes")
}
