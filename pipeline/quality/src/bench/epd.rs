//! `epd_g1` in `twoscale bench`: the Lambda quadrature's tolerance on the
//! paper grid, the default grid's size, and a midpoint-rule baseline.

use super::pointwise::{self, Pointwise};
use super::{BenchOptions, TableBench};
use twoscale_generate::tables::epd::{default_axes, g1_axes, DEFAULT_SIZE, REFERENCE_REL_TOL};
use twoscale_generate::tables::epd_math::{g1_tol, norm, LAMBDA_REL_TOL};
use twoscale_generate::tables::Preset;
use twoscale_tables::axis::Axis;

const NODE_MEASURE: &str = "max |stored f32 G1 - G1 at quadrature tolerance 1e-14| (absolute) over random nodes";
const INTERP_MEASURE: &str =
    "max |interpolated G1 - direct G1| (absolute) at random points (half at cell centres) of the grid's domain";

/// The baseline: Lambda by midpoint rules, as the published generator does it
/// (its known weak spots: p -> 0.05 needs t = rho^(2p), p >= 5 a split at rho = 1):
/// `cells`/2 cells in rho on [mu, max(mu, 1)] and `cells`/2 in t = rho^(2p) up to
/// the adaptive quadrature's range end, max(mu^(2p), k) + 50 + 8 sqrt(k) with k = 3/(2p) - 1, of
///   Lambda = 2 N(p) int_mu^inf (sqrt(rho^2 - mu^2)/mu - acos(mu/rho)) exp(-rho^(2p)) rho drho.
pub fn midpoint_g1(p: f64, a: f64, cells: usize) -> f64 {
    if a == 0.0 {
        return 1.0;
    }
    if a.is_infinite() {
        return 0.0;
    }
    let (mu, two_p) = (1.0 / a, 2.0 * p);
    let kernel = |rho: f64| (rho * rho - mu * mu).max(0.0).sqrt() / mu - (mu / rho).min(1.0).acos();
    let half = (cells / 2).max(1);
    let midpoints = |lo: f64, hi: f64, f: &dyn Fn(f64) -> f64| {
        let h = (hi - lo) / half as f64;
        (0..half).map(|i| f(lo + (i as f64 + 0.5) * h)).sum::<f64>() * h
    };
    let split = mu.max(1.0);
    let inner = midpoints(mu, split, &|rho| kernel(rho) * (-rho.powf(two_p)).exp() * rho);
    let t0 = split.powf(two_p);
    let k = (1.5 / p - 1.0).max(0.0);
    let outer = midpoints(t0, t0.max(k) + 50.0 + 8.0 * k.sqrt(), &|t| {
        let rho = t.powf(1.0 / two_p);
        kernel(rho) * (-t).exp() * rho * rho / (two_p * t)
    });
    1.0 / (1.0 + 2.0 * norm(p) * (inner + outer))
}

pub fn bench(options: BenchOptions) -> TableBench {
    let paper = g1_axes(Preset::Paper);
    let p = &paper[0];
    let quick_paper = vec![Axis::new("p", p.nodes.iter().step_by(4).copied().collect(), p.encoding), paper[1].clone()];
    pointwise::run(
        Pointwise {
            table: "epd_g1",
            node_measure: NODE_MEASURE,
            interp_measure: INTERP_MEASURE,
            scale: |_| 1.0,
            at_tolerance: |pt, tol| g1_tol(pt[0], pt[1], tol),
            shipped_tolerance: LAMBDA_REL_TOL,
            reference_tolerance: REFERENCE_REL_TOL,
            tolerances: &[1e-2, 1e-4, 1e-6, 1e-8],
            paper,
            quick_paper: (quick_paper, "paper (every 4th p)"),
            default_axes: |f| {
                let n = DEFAULT_SIZE.map(|n| ((n as f64 * f).round() as usize).max(2));
                default_axes(n[0], n[1])
            },
            fractions: &[0.0625, 0.125, 0.25, 0.5, 1.0],
            quick_fractions: &[0.0625, 0.125, 0.25],
            baseline: |pt, cells| midpoint_g1(pt[0], pt[1], cells),
            baseline_series: "baseline: midpoint rules (in rho below 1, in t = rho^(2p) above)",
            baseline_unit: "cells",
            baseline_sizes: &[250, 1000, 4000, 16000],
            quick_baseline_sizes: &[1000, 4000],
        },
        options,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use twoscale_generate::tables::epd_math::g1;

    #[test]
    fn midpoint_baseline_converges_to_g1() {
        // The baseline must be a fair one: it converges to the same G1.
        for &(p, a) in &[(1.0, 0.7), (0.2, 3.0), (4.0, 1.2)] {
            let exact = g1(p, a);
            let coarse = (midpoint_g1(p, a, 500) - exact).abs();
            let fine = (midpoint_g1(p, a, 50_000) - exact).abs();
            assert!(fine < 1e-6 && fine < coarse / 50.0, "p={p} a={a}: {coarse:e} -> {fine:e}");
        }
        assert_eq!(midpoint_g1(1.0, 0.0, 10), 1.0);
        assert_eq!(midpoint_g1(1.0, f64::INFINITY, 10), 0.0);
    }
}
