//! `epd_albedo` in `twoscale bench`: grid spacing against the error after interpolation, cubic (the
//! shipped kind) and multilinear (every other table's, and the albedo tables renderers ship), at the
//! same random points. A grid's error at a point needs E only at the nodes its lookup reads, so each
//! grid is measured without building it; its time is the rule's cost per node, measured on sampled
//! nodes, times its nodes.

use super::{sample_nodes, timed_both, BenchOptions, Panel, Row, TableBench, SEED};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use twoscale::accuracy::random_points;
use twoscale::tables::epd_albedo::{albedo_axes, TARGET};
use twoscale::tables::epd_albedo_math::{albedo, albedo_reference, LambdaCurve};
use twoscale::tables::Preset;
use twoscale_tables::axis::Axis;
use twoscale_tables::interp::{nodes_of, strides, Interpolation};

const NODE_MEASURE: &str = "max |E by the table's half-vector rule - E by nested adaptive Gauss-Kronrod with Lambda by its own quadrature| at sampled nodes";
const INTERP_MEASURE: &str = "max |interpolated f32 E - E by the rule| at random points (half at cell centres of the shipped grid): p on a few values, (beta, theta_i) random";

/// The shipped grid with every axis' cells scaled by `f` (nodes - 1 -> (nodes - 1) f).
fn scaled(f: f64) -> Vec<Axis> {
    albedo_axes(Preset::Default)
        .iter()
        .map(|a| {
            let n = (((a.len() - 1) as f64 * f).round() as usize).max(3) + 1;
            Axis::uniform(&a.name, a.encoding, a.nodes[0], a.nodes[a.len() - 1], n)
        })
        .collect()
}

/// Lambda curves by p, built once each.
#[derive(Default)]
struct Curves(Mutex<HashMap<u64, Arc<LambdaCurve>>>);

impl Curves {
    fn get(&self, p: f64) -> Arc<LambdaCurve> {
        if let Some(c) = self.0.lock().expect("not poisoned").get(&p.to_bits()) {
            return c.clone();
        }
        let c = Arc::new(LambdaCurve::new(p));
        self.0.lock().expect("not poisoned").insert(p.to_bits(), c.clone());
        c
    }
}

/// The lookup of a grid at `pt` by `kind`, from E (rounded to f32) at the nodes it reads.
fn lookup(axes: &[Axis], kind: Interpolation, pt: &[f64], curves: &Curves) -> f64 {
    let lens: Vec<usize> = axes.iter().map(Axis::len).collect();
    let st = strides(&lens);
    let cells: Vec<(usize, f64)> = axes.iter().zip(pt).map(|(a, &x)| a.locate(x).expect("inside")).collect();
    let mut sum = 0.0;
    nodes_of(kind, &cells, &lens, &st, |offset, w| {
        let idx: Vec<usize> = st.iter().zip(&lens).map(|(s, n)| offset / s % n).collect();
        let e = albedo(&curves.get(axes[0].nodes[idx[0]]), axes[1].nodes[idx[1]], axes[2].nodes[idx[2]]);
        sum += w * e as f32 as f64;
    });
    sum
}

pub fn bench(options: BenchOptions) -> TableBench {
    let quick = options.quick;
    let shipped = albedo_axes(Preset::Default);
    let (n_p, per_p, fractions): (usize, usize, &[f64]) = if quick { (4, 12, &[0.5, 1.0]) } else { (10, 40, &[0.25, 0.5, 1.0, 2.0]) };
    let bar = options.progress.bar("bench epd_albedo", 0);
    // Probes: a few p values (the Lambda curve of each costs ~0.1 s), (beta, theta_i) random.
    let ps: Vec<f64> = random_points(&shipped[..1], n_p, SEED).into_iter().map(|pt| pt[0]).collect();
    let probes: Vec<Vec<f64>> =
        ps.iter().enumerate().flat_map(|(k, &p)| random_points(&shipped[1..], per_p, SEED + k as u64).into_iter().map(move |bt| vec![p, bt[0], bt[1]])).collect();
    let curves = Curves::default();
    let exact: Vec<f64> = probes.par_iter().map(|pt| albedo(&curves.get(pt[0]), pt[1], pt[2])).collect();
    // The rule's cost per node (its Lambda curve shared by the p's nodes, as in the build) and its error.
    let nodes = sample_nodes(&shipped, if quick { 8 } else { 24 }, SEED);
    nodes.iter().for_each(|(_, pt)| drop(curves.get(pt[0])));
    let (_, seconds_2, seconds_1) = timed_both(|| nodes.par_iter().map(|(_, pt)| albedo(&curves.get(pt[0]), pt[1], pt[2])).sum::<f64>());
    let node_error = nodes
        .par_iter()
        .map(|(_, pt)| (albedo(&curves.get(pt[0]), pt[1], pt[2]) - albedo_reference(pt[0], pt[1], pt[2], 1e-8)).abs())
        .reduce(|| 0.0, f64::max);
    let mut rows = Vec::new();
    for &f in fractions {
        let axes = scaled(f);
        let entries: usize = axes.iter().map(Axis::len).product();
        let grid = axes.iter().map(|a| a.len().to_string()).collect::<Vec<_>>().join(" x ");
        for (kind, series) in [(Interpolation::Cubic, "cubic (4-point Lagrange per axis)"), (Interpolation::Multilinear, "multilinear")] {
            let err = probes.par_iter().zip(&exact).map(|(pt, e)| (lookup(&axes, kind, pt, &curves) - e).abs()).reduce(|| 0.0, f64::max);
            bar.inc(1);
            let shipped_grid = f == 1.0 && kind == Interpolation::Cubic;
            rows.push(Row {
                entries_timed: nodes.len(),
                entries_table: entries,
                seconds_2: seconds_2 * entries as f64 / nodes.len() as f64,
                seconds_1: seconds_1 * entries as f64 / nodes.len() as f64,
                node_error,
                node_points: nodes.len(),
                interp_error: Some(err),
                interp_points: probes.len(),
                megabytes: Some(entries as f64 * 4.0 / 1e6),
                note: format!("{}target {TARGET:e} after interpolation{}", if err <= TARGET { "meets the " } else { "misses the " }, if shipped_grid { "; the shipped table" } else { "" }),
                ..Row::new(series, format!("cells x {f}"), grid.clone(), Panel::Interpolation)
            });
        }
    }
    bar.finish_and_clear();
    TableBench { table: "epd_albedo", node_measure: NODE_MEASURE, interp_measure: INTERP_MEASURE, rows }
}
