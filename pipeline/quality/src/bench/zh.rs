//! `zh_convolution` in `twoscale bench`: the zonal-harmonic degree L on the
//! paper grid (whole builds: coefficients, synthesis, fits), and the published
//! generator's method as the baseline: coefficients by a midpoint rule with N
//! samples in t = cos(theta) and fits by compass search.

use super::{timed, timed_both, BenchOptions, Panel, Row, TableBench, SEED};
use ndarray::Array2;
use rayon::prelude::*;
use std::f64::consts::PI;
use twoscale_generate::accuracy::random_points;
use twoscale_generate::numerics::legendre::legendre_all;
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_generate::progress::Progress;
use twoscale_generate::tables::zh::ZH_CONVOLUTION;
use twoscale_generate::tables::zh_fit::{cost, fit, initial_guess};
use twoscale_generate::tables::zh_grid::{comparison_samples, fit_value, grid, Grid, EXACT_REL_TOL, PAPER_DEGREE};
use twoscale_generate::tables::zh_math::{
    coefficients, d_lobe, exact_convolution, lobe_error, s_lobe, samples, ThetaRule, SAMPLES,
};
use twoscale_generate::tables::Range;
use twoscale_generate::tables::{restrict, BuildOptions, Built, Method, Preset, SceneTarget};
use twoscale_tables::axis::Axis;
use twoscale_tables::lobe::LobeParams;
use twoscale_tables::table::Table;

const NODE_MEASURE: &str = "median over reference nodes (the 16 corners of the paper grid, where the sharpest lobes \
                            are, and random nodes) and 24 angles of |C_L - C| / max C, C by the direct 2-D integral \
                            (the data each fit is fitted to, before fitting); the max over nodes is in the note (the sharpest corner, where \
                            L = 100 truncates by ~90 %)";
const INTERP_MEASURE: &str = "max over random off-grid points (u, c anywhere, p and beta at nodes; the default \
                              preset: the build's 24 random points) and 24 angles of |plain lobe from the \
                              interpolated (s, g) - C| / max C, C by the direct 2-D integral";

/// Most compass-search steps per fit (as the published generator).
pub const COMPASS_STEPS: usize = 4096;

/// The coefficient rows (F of S(u, c), G of D(p, beta)) of `nodes` with a rule.
type Rows = (Array2<f64>, Array2<f64>);

fn gauss_rows(nodes: &[LobeParams], degree: usize) -> Rows {
    let rule = ThetaRule::standard(degree);
    let w = rule.weighted_legendre(degree);
    let s: Vec<_> = nodes.iter().map(|n| move |s2: f64, c2: f64| s_lobe(s2, c2, n.u, n.c)).collect();
    let d: Vec<_> = nodes.iter().map(|n| move |s2: f64, c2: f64| d_lobe(s2, c2, n.p, n.beta)).collect();
    (coefficients(&rule, &w, &s), coefficients(&rule, &w, &d))
}

/// int_0^1 f(t) P_l(t) dt for l < degree by the midpoint rule with `n` samples.
pub fn midpoint_coefficients(f: impl Fn(f64, f64) -> f64, degree: usize, n: usize) -> Vec<f64> {
    let mut out = vec![0.0; degree];
    let mut p = vec![0.0; degree];
    for i in 0..n {
        let t = (i as f64 + 0.5) / n as f64;
        let v = f(1.0 - t * t, t * t) / n as f64;
        legendre_all(t, &mut p);
        for (o, pl) in out.iter_mut().zip(&p) {
            *o += v * pl;
        }
    }
    out
}

fn midpoint_rows(nodes: &[LobeParams], degree: usize, n: usize) -> Rows {
    let rows = |lobe: &(dyn Fn(&LobeParams, f64, f64) -> f64 + Sync)| {
        let v: Vec<Vec<f64>> =
            nodes.par_iter().map(|node| midpoint_coefficients(|s2, c2| lobe(node, s2, c2), degree, n)).collect();
        Array2::from_shape_fn((nodes.len(), degree), |(i, l)| v[i][l])
    };
    (rows(&|nd, s2, c2| s_lobe(s2, c2, nd.u, nd.c)), rows(&|nd, s2, c2| d_lobe(s2, c2, nd.p, nd.beta)))
}

/// C_L of node i at the fit samples `ks`: sum_l pi (2l + 1) F_l G_l P_l(cos theta_k).
fn synthesis(rows: &Rows, i: usize, ks: &[usize]) -> Vec<f64> {
    let degree = rows.0.ncols();
    let smp = samples();
    let mut p = vec![0.0; degree];
    ks.iter()
        .map(|&k| {
            legendre_all(smp[k].1.sqrt(), &mut p);
            (0..degree).map(|l| PI * (2 * l + 1) as f64 * rows.0[[i, l]] * rows.1[[i, l]] * p[l]).sum()
        })
        .collect()
}

/// Median and max over nodes of max_k |C_L - C| / max C.
fn truncation_error(rows: &Rows, exact: &[Vec<f64>], ks: &[usize]) -> (f64, f64) {
    let mut errors: Vec<f64> = exact
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let max_c = e.iter().fold(0.0f64, |m, x| m.max(*x));
            synthesis(rows, i, ks).iter().zip(e).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / max_c
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    (errors[errors.len() / 2], errors[errors.len() - 1])
}

/// The published fit: compass search on (s, g) >= 0 from the data's initial
/// guess; each step polls +-step along s and g and moves to the first
/// improvement, or halves the steps; at most COMPASS_STEPS steps. Returns the cost.
pub fn compass_fit(sin2: &[f64], weight: &[f64], data: &[f64], c: f64) -> (f64, f64, f64) {
    let start = initial_guess(sin2, weight, data, c);
    let mut x = [start.0, start.1];
    let mut step = [0.5 * x[0].max(1e-300), 0.5 * x[1].max(1e-3)];
    let mut best = cost(x[0], x[1], sin2, weight, data, c);
    for _ in 0..COMPASS_STEPS {
        let mut moved = false;
        'poll: for d in 0..2 {
            for sign in [1.0, -1.0] {
                let mut y = x;
                y[d] = (y[d] + sign * step[d]).max(0.0);
                let f = cost(y[0], y[1], sin2, weight, data, c);
                if f < best {
                    (x, best, moved) = (y, f, true);
                    break 'poll;
                }
            }
        }
        if !moved {
            step = step.map(|s| 0.5 * s);
            if step[0] <= 1e-12 * x[0] && step[1] <= 1e-12 * x[1].max(1e-6) {
                break;
            }
        }
    }
    (x[0], x[1], best)
}

pub fn bench(options: BenchOptions) -> TableBench {
    let quick = options.quick;
    let full = grid(Preset::Paper);
    let shape: Vec<usize> = full.axes.iter().map(Axis::len).collect();
    let paper_entries: usize = shape.iter().product();
    let lobe_rows = shape[0] * shape[1] + shape[2] * shape[3];

    // Reference nodes: the 16 corners and random nodes of the paper grid.
    let mut rng = SplitMix64::new(SEED);
    let mut index: Vec<Vec<usize>> = (0..16)
        .map(|corner: usize| (0..4).map(|d| if corner >> d & 1 == 1 { shape[d] - 1 } else { 0 }).collect())
        .collect();
    let random = if quick { 4 } else { 16 };
    index
        .extend((0..random).map(|_| shape.iter().map(|&n| ((rng.uniform() * n as f64) as usize).min(n - 1)).collect()));
    let nodes: Vec<LobeParams> = index
        .iter()
        .map(|i| LobeParams {
            u: full.axes[0].nodes[i[0]],
            c: full.axes[1].nodes[i[1]],
            p: full.axes[2].nodes[i[2]],
            beta: full.beta[[i[2], i[3]]],
        })
        .collect();
    let ks = comparison_samples();
    let theta: Vec<f64> = ks.iter().map(|&k| (1.0 - k as f64 / SAMPLES as f64).asin()).collect();
    let exact: Vec<Vec<f64>> =
        nodes.par_iter().map(|n| theta.iter().map(|&th| exact_convolution(th, n, EXACT_REL_TOL)).collect()).collect();

    // --quick times the builds on part of the grid.
    let scene = quick.then(sharp_corner);
    let grid_label = if quick { "paper (p >= 4.6)" } else { "paper" };
    let probes = off_grid_probes(&full, &scene, if quick { 24 } else { 96 });
    let probe_exact: Vec<Vec<f64>> = probes
        .par_iter()
        .map(|(pt, beta)| {
            theta
                .iter()
                .map(|&th| {
                    exact_convolution(th, &LobeParams { u: pt[0], c: pt[1], p: pt[2], beta: *beta }, EXACT_REL_TOL)
                })
                .collect()
        })
        .collect();
    let degrees: &[usize] = if quick { &[50, 100, 200] } else { &[25, 50, 100, 200, 400] };
    let sizes: &[usize] = if quick { &[6_000, 60_000] } else { &[6_000, 60_000, 600_000] };
    let bar = options.progress.bar("bench zh_convolution", (degrees.len() + sizes.len()) as u64);
    let mut rows = Vec::new();
    for &degree in degrees {
        let build_options = BuildOptions {
            progress: Progress { quiet: true },
            degree: Some(degree),
            method: Some(Method::Zh),
            force: true,
            scene: scene.clone(),
            context: None,
        };
        let (one, two) = build_on_1_and_2_threads(Preset::Paper, &build_options);
        let timed_entries = two.table.values[0].1.len();
        let scale = |s: f64| s * paper_entries as f64 / timed_entries as f64;
        let fits = &two.accuracy["fit_residual"];
        tracing::info!("bench zh_convolution: L = {degree}: {:.2} s on 2 threads", two.compute_seconds);
        let (median, max) = truncation_error(&gauss_rows(&nodes, degree), &exact, &ks);
        rows.push(Row {
            entries_timed: timed_entries,
            entries_table: paper_entries,
            seconds_2: scale(two.compute_seconds),
            seconds_1: scale(one.compute_seconds),
            node_error: median,
            node_points: nodes.len() * ks.len(),
            interp_error: Some(interpolated_lobe_error(&two.table, &probes, &probe_exact, &ks)),
            interp_points: probes.len(),
            note: format!(
                "max over nodes {max:.3e}; fit residual (plain, relative L2) median {:.3} max {:.3}; {:.1} iterations per fit{}",
                fits["plain_rel_l2"]["median"].as_f64().unwrap_or(f64::NAN),
                fits["plain_rel_l2"]["max"].as_f64().unwrap_or(f64::NAN),
                fits["mean_iterations"].as_f64().unwrap_or(f64::NAN),
                if degree == PAPER_DEGREE { "; the paper's setting" } else { "" }
            ),
            ..Row::new(
                "twoscale: zonal-harmonic degree (Gauss-Legendre coefficients, Newton fits)",
                format!("L={degree}"),
                grid_label.into(),
                Panel::Node,
            )
        });
        bar.inc(1);
    }

    // Baseline fits: compass search against Newton on the same data (C_L, L = 100) at the reference nodes.
    let smp = samples();
    let sin2: Vec<f64> = smp.iter().map(|s| s.0).collect();
    let cos2: Vec<f64> = smp.iter().map(|s| s.1).collect();
    let ones = vec![1.0; SAMPLES];
    let all: Vec<usize> = (0..SAMPLES).collect();
    let gauss = gauss_rows(&nodes, PAPER_DEGREE);
    let problems: Vec<(Vec<f64>, &[f64], f64)> = (0..nodes.len())
        .flat_map(|i| {
            let data = synthesis(&gauss, i, &all);
            [(data.clone(), ones.as_slice(), nodes[i].c), (data, cos2.as_slice(), nodes[i].c)]
        })
        .collect();
    let (compass, compass_2, compass_1) =
        timed_both(|| problems.par_iter().map(|(d, w, c)| compass_fit(&sin2, w, d, *c).2).collect::<Vec<f64>>());
    let newton: Vec<f64> = problems
        .iter()
        .map(|(d, w, c)| {
            let f = fit(&sin2, w, d, *c, initial_guess(&sin2, w, d, *c));
            cost(f.s, f.g, &sin2, w, d, *c)
        })
        .collect();
    let no_worse = newton.iter().zip(&compass).filter(|(n, c)| **n <= **c * (1.0 + 1e-12)).count();
    let excess = newton.iter().zip(&compass).map(|(n, c)| n / c - 1.0).fold(0.0, f64::max);
    let per_fit = |s: f64| s / problems.len() as f64 * 2.0 * paper_entries as f64;
    tracing::info!(
        "bench zh_convolution: Newton's fit cost <= compass search's at {no_worse} of {} fits, above it by at most {excess:.1e} relative",
        problems.len()
    );
    for &n in sizes {
        let (coeffs, two, one) = timed_both(|| midpoint_rows(&nodes, PAPER_DEGREE, n));
        let (median, max) = truncation_error(&coeffs, &exact, &ks);
        let per_row = |s: f64| s / (2 * nodes.len()) as f64 * lobe_rows as f64;
        tracing::info!(
            "bench zh_convolution: midpoint {n} samples: {:.0} s on 2 threads (scaled)",
            per_row(two) + per_fit(compass_2)
        );
        rows.push(Row {
            baseline: true,
            entries_timed: nodes.len(),
            entries_table: paper_entries,
            seconds_2: per_row(two) + per_fit(compass_2),
            seconds_1: per_row(one) + per_fit(compass_1),
            node_error: median,
            node_points: nodes.len() * ks.len(),
            note: format!(
                "max over nodes {max:.3e}; coefficients for {} lobe rows and compass search (<= {COMPASS_STEPS} steps) for {} fits, scaled from \
                 the reference nodes; Newton's fit cost <= compass search's at {no_worse} of {} fits, above it by at most {excess:.1e} relative",
                lobe_rows,
                2 * paper_entries,
                problems.len()
            ),
            ..Row::new(
                "baseline: N-sample midpoint-rule coefficients (L = 100) + compass-search fits",
                format!("N={n}"),
                "paper (reference nodes)".into(),
                Panel::Node,
            )
        });
        bar.inc(1);
    }
    if !quick {
        rows.push(default_preset_row(&nodes, &exact, &ks));
    }
    bar.finish_and_clear();
    TableBench { table: "zh_convolution", node_measure: NODE_MEASURE, interp_measure: INTERP_MEASURE, rows }
}

/// Off-grid probes of the paper grid (restricted to `scene`): u and c random
/// (half at cell centres), p and beta at random nodes (the paper's beta axis
/// is relative to beta_max(p), known only at p nodes); with the physical beta.
fn off_grid_probes(full: &Grid, scene: &Option<SceneTarget>, count: usize) -> Vec<(Vec<f64>, f64)> {
    let options = BuildOptions { scene: scene.clone(), ..BuildOptions::default() };
    let (axes, kept) = restrict(full.axes.clone(), &options).expect("the sub-grid lies inside the paper grid");
    let mut rng = SplitMix64::new(SEED ^ 0x7a68);
    let pick = |rng: &mut SplitMix64, n: usize| ((rng.uniform() * n as f64) as usize).min(n - 1);
    random_points(&axes[..2], count, SEED)
        .into_iter()
        .map(|mut pt| {
            let (ip, ib) = (pick(&mut rng, axes[2].len()), pick(&mut rng, axes[3].len()));
            pt.extend([axes[2].nodes[ip], axes[3].nodes[ib]]);
            (pt, full.beta[[kept[2].start() + ip, kept[3].start() + ib]])
        })
        .collect()
}

/// Max over the probes of the plain lobe's error (`lobe_error`) with (s, g)
/// interpolated from `table`, against the exact C there.
fn interpolated_lobe_error(table: &Table, probes: &[(Vec<f64>, f64)], exact: &[Vec<f64>], ks: &[usize]) -> f64 {
    let value =
        |name: &str, pt: &[f64]| fit_value(&table.axes, &table.values, name, pt).expect("probe inside the table");
    probes
        .iter()
        .zip(exact)
        .map(|((pt, _), e)| lobe_error(value("s", pt), value("g", pt), pt[1], false, ks, e))
        .fold(0.0, f64::max)
}

/// The paper grid's p >= 4.6 (3 of the 25 p nodes, where the sharpest lobes
/// are): what `--quick` and the profile build, as a scene sub-domain.
pub fn sharp_corner() -> SceneTarget {
    SceneTarget { name: "bench".into(), sha256: String::new(), ranges: vec![("p".into(), Range { lo: 4.6, hi: 5.0 })] }
}

/// The table built on 1 thread, then on 2 (its manifest timings are per build).
fn build_on_1_and_2_threads(preset: Preset, options: &BuildOptions) -> (Built, Built) {
    let build = || ZH_CONVOLUTION.build(preset, options).expect("zh_convolution build");
    (timed(1, build).0, timed(2, build).0)
}

/// The whole default preset (method auto, L <= 2000): time, and the error after
/// interpolation its build measures against the exact C.
fn default_preset_row(nodes: &[LobeParams], exact: &[Vec<f64>], ks: &[usize]) -> Row {
    let options = BuildOptions { progress: Progress { quiet: true }, force: true, ..BuildOptions::default() };
    let (one, two) = build_on_1_and_2_threads(Preset::Default, &options);
    let entries = two.table.values[0].1.len();
    let interp = &two.accuracy["interpolated_vs_exact"]["plain"];
    let degree = two.settings["degree"].as_u64().unwrap_or(0) as usize;
    let (median, max) = truncation_error(&gauss_rows(nodes, degree), exact, ks);
    tracing::info!("bench zh_convolution: default preset: {:.2} s on 2 threads", two.compute_seconds);
    Row {
        entries_timed: entries,
        entries_table: entries,
        seconds_2: two.compute_seconds,
        seconds_1: one.compute_seconds,
        node_error: median,
        node_points: nodes.len() * ks.len(),
        interp_error: interp["max"].as_f64(),
        interp_points: 24,
        note: format!(
            "node error at the paper grid's reference nodes with L = {degree} (max {max:.3e}); interpolation error: \
             the build's 24 random off-grid points, median {:.3}",
            interp["median"].as_f64().unwrap_or(f64::NAN)
        ),
        ..Row::new(
            "twoscale: default preset (auto, L <= 2000)",
            "default".into(),
            "default".into(),
            Panel::Interpolation,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn midpoint_coefficients_converge_to_gauss_legendre() {
        let node = [LobeParams { u: 2.0, c: 2.0, p: 1.0, beta: 0.3 }];
        let gauss = gauss_rows(&node, 20);
        let mid = midpoint_rows(&node, 20, 20_000);
        for l in 0..20 {
            assert!((mid.0[[0, l]] - gauss.0[[0, l]]).abs() < 1e-6 * gauss.0[[0, 0]].abs(), "F_{l}");
            assert!((mid.1[[0, l]] - gauss.1[[0, l]]).abs() < 1e-6 * gauss.1[[0, 0]].abs(), "G_{l}");
        }
    }

    #[test]
    fn compass_search_finds_a_known_lobe() {
        let smp = samples();
        let sin2: Vec<f64> = smp.iter().map(|s| s.0).collect();
        let ones = vec![1.0; sin2.len()];
        let data: Vec<f64> = sin2.iter().map(|x| 0.7 * (1.0 + 4.0 * 0.09 * x).powf(-1.5)).collect();
        let (s, g, c) = compass_fit(&sin2, &ones, &data, 2.0);
        assert!((s - 0.7).abs() < 1e-6 && (g - 0.3).abs() < 1e-6 && c < 1e-12, "{s} {g} {c}");
    }
}
