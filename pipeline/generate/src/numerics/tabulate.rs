//! Evaluating a function at every node of a tensor grid, in parallel.

use crate::progress::Progress;
use indicatif::ParallelProgressIterator;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use twoscale_tables::axis::Axis;

/// f at every node (C order over `axes`), rounded to f32. Each entry is
/// computed independently, so the result does not depend on the thread count.
pub fn tabulate(axes: &[Axis], label: &str, progress: Progress, f: impl Fn(&[f64]) -> f64 + Sync) -> ArrayD<f32> {
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    let data = tabulate_nodes(axes, shape.iter().product(), |j| j, label, progress, f);
    ArrayD::from_shape_vec(IxDyn(&shape), data).expect("shape matches the axes")
}

/// f at `count` nodes, the j-th at flat C-order index `node(j)` over `axes`, rounded to f32.
pub fn tabulate_nodes(
    axes: &[Axis],
    count: usize,
    node: impl Fn(usize) -> usize + Sync,
    label: &str,
    progress: Progress,
    f: impl Fn(&[f64]) -> f64 + Sync,
) -> Vec<f32> {
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    let bar = progress.bar(label, count as u64);
    let data: Vec<f32> = (0..count)
        .into_par_iter()
        .progress_with(bar.clone())
        .map_init(
            || vec![0.0; axes.len()],
            |point, j| {
                let mut rem = node(j);
                for d in (0..axes.len()).rev() {
                    point[d] = axes[d].nodes[rem % shape[d]];
                    rem /= shape[d];
                }
                f(point) as f32
            },
        )
        .collect();
    bar.finish_and_clear();
    data
}
