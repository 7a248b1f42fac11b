//! The sweep of a table whose entries are independent evaluations f(point)
//! (`epd_g1`, `kcorr_renorm`): quadrature tolerance on the paper grid, grid
//! size with the default encodings, and a baseline rule at sampled nodes.

use super::{max_scaled_error, sample_nodes, timed_both, BenchOptions, Panel, Row, TableBench, SEED};
use ndarray::ArrayD;
use rayon::prelude::*;
use twoscale_generate::accuracy::random_points;
use twoscale_generate::numerics::tabulate::tabulate;
use twoscale_generate::progress::Progress;
use twoscale_tables::axis::Axis;
use twoscale_tables::interp::interpolate;

/// What a pointwise table's sweep needs.
pub struct Pointwise {
    pub table: &'static str,
    pub node_measure: &'static str,
    pub interp_measure: &'static str,
    /// Errors are |value - reference| / scale(reference).
    pub scale: fn(f64) -> f64,
    /// The production evaluation at a quadrature tolerance.
    pub at_tolerance: fn(&[f64], f64) -> f64,
    pub shipped_tolerance: f64,
    pub reference_tolerance: f64,
    /// Tolerances swept (full run; `--quick` keeps the first, the middle one and the shipped one).
    pub tolerances: &'static [f64],
    /// The paper grid, and the subset timed by `--quick` (with its label).
    pub paper: Vec<Axis>,
    pub quick_paper: (Vec<Axis>, &'static str),
    /// The default grid with its node counts scaled by a fraction.
    pub default_axes: fn(f64) -> Vec<Axis>,
    pub fractions: &'static [f64],
    pub quick_fractions: &'static [f64],
    /// The baseline (the published generator's kind of rule) with a size parameter.
    pub baseline: fn(&[f64], usize) -> f64,
    pub baseline_series: &'static str,
    pub baseline_unit: &'static str,
    pub baseline_sizes: &'static [usize],
    pub quick_baseline_sizes: &'static [usize],
}

/// Largest scaled error of `values` interpolated at `probes` against `exact` there.
fn max_interpolation_error(
    axes: &[Axis],
    values: &ArrayD<f32>,
    probes: &[Vec<f64>],
    exact: &[f64],
    scale: fn(f64) -> f64,
) -> f64 {
    let got: Vec<f64> =
        probes.par_iter().map(|pt| interpolate(axes, &values.view(), pt).expect("probe inside")).collect();
    max_scaled_error(&got, exact, scale)
}

/// Stored values at sampled nodes.
fn at_nodes(values: &ArrayD<f32>, nodes: &[(Vec<usize>, Vec<f64>)]) -> Vec<f64> {
    nodes.iter().map(|(idx, _)| values[idx.as_slice()] as f64).collect()
}

fn entries(axes: &[Axis]) -> usize {
    axes.iter().map(Axis::len).product()
}

pub fn run(t: Pointwise, options: BenchOptions) -> TableBench {
    let quick = options.quick;
    let quiet = Progress { quiet: true };
    let paper_entries = entries(&t.paper);
    let (axes, grid) = if quick { t.quick_paper.clone() } else { (t.paper.clone(), "paper") };
    let timed_entries = entries(&axes);
    let scale_time = |s: f64| s * paper_entries as f64 / timed_entries as f64;
    let (n_nodes, n_probes) = if quick { (400, 400) } else { (2000, 4000) };
    let reference = |nodes: &[(Vec<usize>, Vec<f64>)]| -> Vec<f64> {
        nodes.par_iter().map(|(_, pt)| (t.at_tolerance)(pt, t.reference_tolerance)).collect()
    };
    let exact_at = |probes: &[Vec<f64>]| -> Vec<f64> {
        probes.par_iter().map(|pt| (t.at_tolerance)(pt, t.shipped_tolerance)).collect()
    };
    let nodes = sample_nodes(&axes, n_nodes, SEED);
    let node_reference = reference(&nodes);
    let probes = random_points(&axes, n_probes, SEED);
    let probe_exact = exact_at(&probes);
    let bar = options.progress.bar(&format!("bench {}", t.table), 0);
    let mut rows = Vec::new();

    let tolerances: Vec<f64> = if quick {
        vec![t.tolerances[0], t.tolerances[t.tolerances.len() / 2], t.shipped_tolerance]
    } else {
        t.tolerances.iter().copied().chain([t.shipped_tolerance]).collect()
    };
    let fractions = if quick { t.quick_fractions } else { t.fractions };
    let sizes = if quick { t.quick_baseline_sizes } else { t.baseline_sizes };
    bar.set_length((tolerances.len() + fractions.len() + sizes.len()) as u64);

    for &tol in &tolerances {
        let (values, two, one) = timed_both(|| tabulate(&axes, t.table, quiet, |pt| (t.at_tolerance)(pt, tol)));
        tracing::info!("bench {}: rel_tol {tol:e} on {grid}: {two:.2} s on 2 threads", t.table);
        rows.push(Row {
            entries_timed: timed_entries,
            entries_table: paper_entries,
            seconds_2: scale_time(two),
            seconds_1: scale_time(one),
            node_error: max_scaled_error(&at_nodes(&values, &nodes), &node_reference, t.scale),
            node_points: nodes.len(),
            interp_error: Some(max_interpolation_error(&axes, &values, &probes, &probe_exact, t.scale)),
            interp_points: probes.len(),
            note: if tol == t.shipped_tolerance { "shipped setting".into() } else { String::new() },
            ..Row::new("twoscale: quadrature tolerance", format!("rel_tol={tol:e}"), grid.into(), Panel::Node)
        });
        bar.inc(1);
    }

    // Grid size: probes over the whole default domain, shared by every size.
    let probes = random_points(&(t.default_axes)(1.0), n_probes, SEED);
    let probe_exact = exact_at(&probes);
    for &f in fractions {
        let axes = (t.default_axes)(f);
        let size: Vec<String> = axes.iter().map(|a| a.len().to_string()).collect();
        let (values, two, one) =
            timed_both(|| tabulate(&axes, t.table, quiet, |pt| (t.at_tolerance)(pt, t.shipped_tolerance)));
        tracing::info!("bench {}: default x{f} ({}): {two:.2} s on 2 threads", t.table, size.join(" x "));
        let grid_nodes = sample_nodes(&axes, n_nodes / 4, SEED);
        rows.push(Row {
            entries_timed: entries(&axes),
            entries_table: entries(&axes),
            seconds_2: two,
            seconds_1: one,
            node_error: max_scaled_error(&at_nodes(&values, &grid_nodes), &reference(&grid_nodes), t.scale),
            node_points: grid_nodes.len(),
            interp_error: Some(max_interpolation_error(&axes, &values, &probes, &probe_exact, t.scale)),
            interp_points: probes.len(),
            note: if f == 1.0 { "shipped default grid".into() } else { String::new() },
            ..Row::new(
                "twoscale: grid size (default encodings)",
                size.join(" x "),
                format!("default x{f}"),
                Panel::Interpolation,
            )
        });
        bar.inc(1);
    }

    // The baseline at the sampled nodes, timed there and scaled to the paper grid.
    let per_node = paper_entries as f64 / nodes.len() as f64;
    for &n in sizes {
        let (values, two, one) =
            timed_both(|| nodes.par_iter().map(|(_, pt)| (t.baseline)(pt, n) as f32 as f64).collect::<Vec<f64>>());
        tracing::info!(
            "bench {}: baseline {n} {}: {:.1} s on 2 threads (scaled)",
            t.table,
            t.baseline_unit,
            two * per_node
        );
        rows.push(Row {
            baseline: true,
            entries_timed: nodes.len(),
            entries_table: paper_entries,
            seconds_2: two * per_node,
            seconds_1: one * per_node,
            node_error: max_scaled_error(&values, &node_reference, t.scale),
            node_points: nodes.len(),
            note: "computed at the sampled nodes only; time scaled to the paper grid".into(),
            ..Row::new(
                t.baseline_series,
                format!("{n} {}", t.baseline_unit),
                format!("{grid} (sampled nodes)"),
                Panel::Node,
            )
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    TableBench { table: t.table, node_measure: t.node_measure, interp_measure: t.interp_measure, rows }
}
