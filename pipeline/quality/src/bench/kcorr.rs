//! `kcorr_renorm` in `twoscale bench`: the ring quadrature's tolerance on the
//! paper grid, the default grid's size, and a midpoint-rule baseline for the ring.

use super::pointwise::{self, Pointwise};
use super::{BenchOptions, TableBench};
use std::f64::consts::PI;
use twoscale_generate::tables::kcorr::{axes, default_axes, DEFAULT_N, REFERENCE_REL_TOL};
use twoscale_generate::tables::kcorr_math::{renorm_tol, REL_TOL};
use twoscale_generate::tables::Preset;
use twoscale_tables::axis::Axis;

const NODE_MEASURE: &str = "max |stored f32 R - R at quadrature tolerance 1e-14| / max(R, 1e-3) (relative for \
                            R >= 1e-3) over random nodes";
const INTERP_MEASURE: &str = "max |interpolated R - direct R| / max(R, 1e-3) at random points (half at cell \
                              centres) of the grid's domain (the default preset's target is 1e-3)";

/// The baseline, the published generator's kind of rule: the closed-form mass
/// inside |g| = 1 - s plus the ring 1 - s <= |g| <= 1 + s by a midpoint rule
/// with `cells` cells in f = |g|:
///   ring = (c-1) B^2 / pi int_{1-s}^{1+s} acos((f^2 - 1 + s^2) / (2 s f)) f (1 + B^2 f^2)^(-(c+1)/2) df.
/// The arc angle has square-root ends at f = 1 -+ s, which limit the rule to O(cells^-1.5).
pub fn midpoint_renorm(s: f64, b: f64, c: f64, cells: usize) -> f64 {
    let inner = -(0.5 * (1.0 - c) * (b * b * (1.0 - s) * (1.0 - s)).ln_1p()).exp_m1();
    if s == 0.0 {
        return inner;
    }
    let h = 2.0 * s / cells as f64;
    let ring: f64 = (0..cells)
        .map(|i| {
            let f = 1.0 - s + (i as f64 + 0.5) * h;
            let arc = ((f * f - 1.0 + s * s) / (2.0 * s * f)).clamp(-1.0, 1.0).acos();
            arc * f * (-0.5 * (c + 1.0) * (b * b * f * f).ln_1p()).exp()
        })
        .sum();
    (inner + (c - 1.0) * b * b / PI * ring * h).min(1.0)
}

pub fn bench(options: BenchOptions) -> TableBench {
    let paper = axes(Preset::Paper);
    // --quick: every 4th s and every 2nd c of the paper grid.
    let every = |a: &Axis, k: usize| Axis::new(&a.name, a.nodes.iter().step_by(k).copied().collect(), a.encoding);
    let quick_paper = vec![every(&paper[0], 4), paper[1].clone(), every(&paper[2], 2)];
    pointwise::run(
        Pointwise {
            table: "kcorr_renorm",
            node_measure: NODE_MEASURE,
            interp_measure: INTERP_MEASURE,
            scale: |r| r.max(1e-3),
            at_tolerance: |pt, tol| renorm_tol(pt[0], pt[1], pt[2], tol),
            shipped_tolerance: REL_TOL,
            reference_tolerance: REFERENCE_REL_TOL,
            tolerances: &[1e-3, 1e-5, 1e-7, 1e-9],
            paper,
            quick_paper: (quick_paper, "paper (every 4th s, 2nd c)"),
            default_axes: |f| default_axes(DEFAULT_N.map(|n| ((n as f64 * f).round() as usize).max(2))),
            fractions: &[0.125, 0.25, 0.5, 0.75, 1.0],
            quick_fractions: &[0.125, 0.25],
            baseline: |pt, n| midpoint_renorm(pt[0], pt[1], pt[2], n),
            baseline_series: "baseline: closed-form inner disk + midpoint rule over the ring",
            baseline_unit: "cells",
            baseline_sizes: &[100, 400, 1600, 6400, 25600],
            quick_baseline_sizes: &[400, 6400],
        },
        options,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use twoscale_generate::tables::kcorr_math::renorm;

    #[test]
    fn midpoint_baseline_converges_to_r() {
        for &(s, b, c) in &[(0.3, 1.0, 2.0), (0.5, 3.0, 1.5), (0.9, 0.5, 10.0)] {
            let exact = renorm(s, b, c);
            let coarse = (midpoint_renorm(s, b, c, 100) - exact).abs();
            let fine = (midpoint_renorm(s, b, c, 10_000) - exact).abs();
            assert!(fine < 1e-6 && fine < coarse / 100.0, "s={s} B={b} c={c}: {coarse:e} -> {fine:e}");
        }
    }
}
