//! `epd_albedo` in `twoscale bench`:
//! - the rule (`epd_albedo_column`) against the 0.10.0 rule (`rule_0_10`, below), run side by side in
//!   this process on the same sampled (p, beta) nodes, every theta_i node of each, with each rule's
//!   set-up per p (a Lambda curve or table); both projected to the whole table, and both against
//!   the adaptive reference with Lambda by quadrature at random points;
//! - grid spacing against the error after interpolation, cubic (the shipped kind) and multilinear,
//!   at the same random points. A grid's error at a point needs E only at the nodes its lookup
//!   reads, so each grid is measured without building it; its time is the rule's cost per node
//!   times its nodes.

use super::{timed_both, BenchOptions, Panel, Row, TableBench, SEED};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use twoscale_generate::accuracy::grouped_points;
use twoscale_generate::numerics::legendre::{composite_rule, gauss_legendre};
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_generate::tables::epd_albedo::{albedo_axes, TARGET};
use twoscale_generate::tables::epd_albedo_column::albedo_column;
use twoscale_generate::tables::epd_albedo_math::{albedo_reference, Incidence, LambdaCurve};
use twoscale_generate::tables::epd_math::norm;
use twoscale_generate::tables::lambda_table::LambdaTable;
use twoscale_generate::tables::Preset;
use twoscale_tables::axis::Axis;
use twoscale_tables::interp::{nodes_of, strides, Interpolation};

const NODE_MEASURE: &str =
    "max |E by the rule - E by nested adaptive Gauss-Kronrod (relative tolerance 1e-9) with Lambda by its own \
    quadrature| at random points (in groups sharing p)";
const INTERP_MEASURE: &str =
    "max |interpolated f32 E - E by the rule| at random points (half at cell centres of the shipped grid), in groups \
    sharing p";

/// The Lambda curve of the 0.10.0 rule: 16,001 nodes uniform in ln a.
const CURVE_NODES_0_10: usize = 16_001;

/// The 0.10.0 rule, node by node (the baseline): the same half-vector geometry with 0.10.0's
/// panels (`Incidence::breaks`: 0.5 wide from ln(1e-4 beta), doubling beyond x = 2), 8 Gauss-Legendre
/// nodes per panel and 12 in phi, theta_h from atan and libm's trigonometry at every node, and
/// Lambda from a curve uniform in ln a (a ln per direction).
pub fn rule_0_10(curve: &LambdaCurve, beta: f64, theta_i: f64) -> f64 {
    let p = curve.p;
    let (sin_i, mu) = theta_i.sin_cos();
    let inc = Incidence::new(mu);
    let lambda_i = curve.at(beta * sin_i / mu);
    let n = norm(p) / (beta * beta);
    let (xs, xw) = composite_rule(&inc.breaks(beta, p), 8);
    let (px, pw) = gauss_legendre(12);
    let mut sum = 0.0;
    for (&x, &wx) in xs.iter().zip(&xw) {
        let tan_h = x.exp();
        let theta_h = tan_h.atan();
        let phi_max = inc.phi_max(theta_h);
        let (st, ct) = theta_h.sin_cos();
        let d = n * (-(tan_h * tan_h / (beta * beta)).powf(p)).exp() / (ct * ct * ct * ct);
        let w_theta = 2.0 * wx * st * ct * st * 0.5 * phi_max;
        for (&t, &wt) in px.iter().zip(&pw) {
            let Some((o, jacobian)) = inc.reflect(theta_h, 0.5 * phi_max * (t + 1.0)) else { continue };
            let g2 = 1.0 / (1.0 + lambda_i + curve.at(beta * o[0].hypot(o[1]) / o[2]));
            sum += w_theta * wt * d * g2 * jacobian / (4.0 * mu);
        }
    }
    sum
}

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

/// Lambda tables by p, built once each.
#[derive(Default)]
struct Tables(Mutex<HashMap<u64, Arc<LambdaTable>>>);

impl Tables {
    fn get(&self, p: f64) -> Arc<LambdaTable> {
        if let Some(t) = self.0.lock().expect("not poisoned").get(&p.to_bits()) {
            return t.clone();
        }
        let t = Arc::new(LambdaTable::new(p));
        self.0.lock().expect("not poisoned").insert(p.to_bits(), t.clone());
        t
    }
}

/// The lookup of a grid at `pt` by `kind`, from E (rounded to f32) at the nodes it reads.
fn lookup(axes: &[Axis], kind: Interpolation, pt: &[f64], tables: &Tables) -> f64 {
    let lens: Vec<usize> = axes.iter().map(Axis::len).collect();
    let st = strides(&lens);
    let cells: Vec<(usize, f64)> = axes.iter().zip(pt).map(|(a, &x)| a.locate(x).expect("inside")).collect();
    let mut sum = 0.0;
    nodes_of(kind, &cells, &lens, &st, |offset, w| {
        let idx: Vec<usize> = st.iter().zip(&lens).map(|(s, n)| offset / s % n).collect();
        let e = albedo_column(&tables.get(axes[0].nodes[idx[0]]), axes[1].nodes[idx[1]], &[axes[2].nodes[idx[2]]])[0];
        sum += w * e as f32 as f64;
    });
    sum
}

/// `n_p` random p nodes and `n_beta` random beta nodes for each (deterministic).
fn sampled_columns(axes: &[Axis], n_p: usize, n_beta: usize) -> Vec<(f64, Vec<f64>)> {
    let mut rng = SplitMix64::new(SEED);
    let mut pick = |a: &Axis| a.nodes[((rng.uniform() * a.len() as f64) as usize).min(a.len() - 1)];
    (0..n_p).map(|_| (pick(&axes[0]), (0..n_beta).map(|_| pick(&axes[1])).collect())).collect()
}

/// Seconds of a rule over `columns` (every theta_i node of each), one set-up per p: the whole
/// table projected (set-up per p node, columns per (p, beta) node), on 2 threads and on 1.
fn projected<S: Send + Sync>(
    axes: &[Axis],
    columns: &[(f64, Vec<f64>)],
    setup: impl Fn(f64) -> S + Sync,
    column: impl Fn(&S, f64, &[f64]) -> f64 + Sync,
) -> (f64, f64) {
    let thetas = &axes[2].nodes;
    let (_, setup_2, setup_1) = timed_both(|| columns.par_iter().map(|(p, _)| setup(*p)).collect::<Vec<S>>());
    let set: Vec<S> = columns.iter().map(|(p, _)| setup(*p)).collect();
    let work = || {
        set.par_iter()
            .zip(columns)
            .map(|(s, (_, betas))| betas.par_iter().map(|&b| column(s, b, thetas)).sum::<f64>())
            .sum::<f64>()
    };
    let (_, work_2, work_1) = timed_both(work);
    let n_columns: usize = columns.iter().map(|(_, b)| b.len()).sum();
    let (n_p, n_beta) = (axes[0].len() as f64, axes[1].len() as f64);
    let whole = |setup: f64, work: f64| setup / columns.len() as f64 * n_p + work / n_columns as f64 * n_p * n_beta;
    (whole(setup_2, work_2), whole(setup_1, work_1))
}

pub fn bench(options: BenchOptions) -> TableBench {
    let quick = options.quick;
    let shipped = albedo_axes(Preset::Default);
    let entries: usize = shipped.iter().map(Axis::len).product();
    let bar = options.progress.bar("bench epd_albedo", 0);

    // The two rules side by side: the same columns, old then new, best of `rounds`.
    let (n_p, n_beta, rounds) = if quick { (3, 2, 1) } else { (8, 6, 2) };
    let columns = sampled_columns(&shipped, n_p, n_beta);
    let best = |a: (f64, f64), b: (f64, f64)| (a.0.min(b.0), a.1.min(b.1));
    let (mut old, mut new) = ((f64::INFINITY, f64::INFINITY), (f64::INFINITY, f64::INFINITY));
    for _ in 0..rounds {
        old = best(
            old,
            projected(
                &shipped,
                &columns,
                |p| LambdaCurve::new(p, CURVE_NODES_0_10),
                |c, b, ts| ts.iter().map(|&t| rule_0_10(c, b, t)).sum(),
            ),
        );
        new =
            best(new, projected(&shipped, &columns, LambdaTable::new, |t, b, ts| albedo_column(t, b, ts).iter().sum()));
        bar.inc(1);
    }

    // Both rules against the adaptive reference, and the probes of the grid sweep, at random points
    // in groups sharing p (each group's Lambda curve and table built once).
    let (groups, per_group) = if quick { (3, 8) } else { (10, 40) };
    let probes = grouped_points(&shipped, groups, per_group, SEED);
    let tables = Tables::default();
    let curves: HashMap<u64, LambdaCurve> = probes
        .iter()
        .step_by(per_group)
        .map(|pt| (pt[0].to_bits(), LambdaCurve::new(pt[0], CURVE_NODES_0_10)))
        .collect();
    let exact: Vec<f64> = probes.par_iter().map(|pt| albedo_column(&tables.get(pt[0]), pt[1], &[pt[2]])[0]).collect();
    let (old_error, new_error) = probes
        .par_iter()
        .zip(&exact)
        .map(|(pt, e)| {
            let reference = albedo_reference(pt[0], pt[1], pt[2], 1e-9);
            ((rule_0_10(&curves[&pt[0].to_bits()], pt[1], pt[2]) - reference).abs(), (e - reference).abs())
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0.max(b.0), a.1.max(b.1)));
    bar.inc(1);

    let grid = shipped.iter().map(|a| a.len().to_string()).collect::<Vec<_>>().join(" x ");
    let timed_on = |name: &str| {
        format!(
            "{name}, timed on {} (p, beta) columns of {} theta_i nodes ({} p nodes), projected",
            n_p * n_beta,
            shipped[2].len(),
            n_p
        )
    };
    let mut rows = vec![
        Row {
            baseline: true,
            entries_timed: n_p * n_beta * shipped[2].len(),
            entries_table: entries,
            seconds_2: old.0,
            seconds_1: old.1,
            node_error: old_error,
            node_points: probes.len(),
            note: timed_on("node by node, Lambda curve uniform in ln a"),
            ..Row::new("0.10.0 rule", "0.10.0".into(), grid.clone(), Panel::Node)
        },
        Row {
            entries_timed: n_p * n_beta * shipped[2].len(),
            entries_table: entries,
            seconds_2: new.0,
            seconds_1: new.1,
            node_error: new_error,
            node_points: probes.len(),
            note: timed_on("a column per (p, beta), Lambda table in a^2's float bits"),
            ..Row::new("shared-column rule", "shipped".into(), grid.clone(), Panel::Node)
        },
    ];

    // Grid spacing against the error after interpolation (against the rule).
    let per_node = (new.0 / entries as f64, new.1 / entries as f64);
    let fractions: &[f64] = if quick { &[0.5, 1.0] } else { &[0.25, 0.5, 1.0, 2.0] };
    for &f in fractions {
        let axes = scaled(f);
        let entries: usize = axes.iter().map(Axis::len).product();
        let grid = axes.iter().map(|a| a.len().to_string()).collect::<Vec<_>>().join(" x ");
        for (kind, series) in
            [(Interpolation::Cubic, "cubic (4-point Lagrange per axis)"), (Interpolation::Multilinear, "multilinear")]
        {
            let err = probes
                .par_iter()
                .zip(&exact)
                .map(|(pt, e)| (lookup(&axes, kind, pt, &tables) - e).abs())
                .reduce(|| 0.0, f64::max);
            bar.inc(1);
            let shipped_grid = f == 1.0 && kind == Interpolation::Cubic;
            rows.push(Row {
                entries_timed: n_p * n_beta * shipped[2].len(),
                entries_table: entries,
                seconds_2: per_node.0 * entries as f64,
                seconds_1: per_node.1 * entries as f64,
                node_error: new_error,
                node_points: probes.len(),
                interp_error: Some(err),
                interp_points: probes.len(),
                megabytes: Some(entries as f64 * 4.0 / 1e6),
                note: format!(
                    "{}target {TARGET:e} after interpolation{}",
                    if err <= TARGET { "meets the " } else { "misses the " },
                    if shipped_grid { "; the shipped table" } else { "" }
                ),
                ..Row::new(series, format!("cells x {f}"), grid.clone(), Panel::Interpolation)
            });
        }
    }
    bar.finish_and_clear();
    TableBench { table: "epd_albedo", node_measure: NODE_MEASURE, interp_measure: INTERP_MEASURE, rows }
}
