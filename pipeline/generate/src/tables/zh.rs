//! Stage `zh-convolution`: the table `zh_convolution` (docs/maths.md section 4). The
//! diffraction lobe S(u, c) convolved by the NDF D(beta, p), computed as the
//! zonal-harmonic sum C_L (or the direct integral where C_L is not accurate
//! enough), sampled at the 1000 angles of docs/maths.md section 4 and fitted by a
//! K-correlation lobe, plain (s, g) and times cos^2 (s_cos, g_cos).

use super::zh_fit::{fit, initial_guess, Fit};
use super::zh_math::{coefficients, d_lobe, exact_convolution, s_lobe, samples, synthesis_matrix, ThetaRule};
use super::context::BuildContext;
use super::{restrict, BuildOptions, Built, Job, Method, Part, Preset, TableDef, Units};
use std::sync::Arc;
use twoscale_tables::lobe::LobeParams;
use twoscale_tables::axis::{Axis, AxisEncoding};
use crate::progress::Progress;
use crate::table::Table;
use anyhow::Result;
use indicatif::ParallelProgressIterator;
use ndarray::{Array2, ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::json;
use std::f64::consts::PI;
use std::time::Instant;
use tracing::info;

pub const ZH_CONVOLUTION: TableDef = TableDef {
    name: "zh_convolution",
    stage: "zh-convolution",
    definition: "docs/maths.md section 4: C(theta_h) = int S(h.m) D(n.m) dm with S(t) = (1 + 4u^2(1-t^2))^(-(c+1)/2) t^2 \
                 and D(t) = exp(-((1-t^2)/(t^2 beta^2))^p) / t^4, fitted over sin(theta_k) = 1 - k/1000 by \
                 s (1 + 4 g^2 sin^2)^(-(c+1)/2) (values s, g) and by the same times cos^2 (values s_cos, g_cos)",
    axes: |preset| grid(preset).axes,
    diffraction: true,
    cubic: false,
    job,
    presets: &Preset::ALL,
};

/// beta_max(p) of the paper's grid, for p = 5.0, 4.8, ..., 0.2.
pub const PAPER_BETA_MAX: [f64; 25] = [
    0.058, 0.060, 0.062, 0.064, 0.066, 0.068, 0.071, 0.074, 0.078, 0.083, 0.085, 0.087, 0.090, 0.093, 0.098, 0.104,
    0.113, 0.127, 0.153, 0.211, 0.348, 0.461, 0.448, 0.261, 0.015,
];
pub const PAPER_DEGREE: usize = 100;
/// Default degree (the most `auto` uses): measured against the direct
/// integral, C_L for the sharpest lobe of the default domain (u = 100,
/// beta = 0.005, p = 5) is within 1.6e-3 of C at L = 1000 and 2.5e-7 at L = 2000.
pub const DEFAULT_DEGREE: usize = 2000;
/// `auto`: a node's sum stops at the first multiple of 16 past which the
/// remaining terms sum (in absolute value, |P_l| <= 1) below AUTO_TAIL of
/// C(0); the node is computed by the direct integral when what the last
/// quarter of the L terms contributes at the 1000 angles is not below
/// AUTO_TOLERANCE of max C (the series has not converged by L).
pub const AUTO_TAIL: f64 = 1e-6;
pub const AUTO_TOLERANCE: f64 = 1e-4;
/// Tolerance of the direct integral.
pub const EXACT_REL_TOL: f64 = 1e-9;

/// The 24 fit samples where C_L and fitted lobes are compared with the exact
/// C: k = 999 - round(999 (i/23)^2), dense near theta = 0 where the lobes peak.
pub fn comparison_samples() -> Vec<usize> {
    (0..24).map(|i| 999 - (999.0 * (i as f64 / 23.0).powi(2)).round() as usize).collect()
}

/// zh_convolution's axes and its values (s, g, s_cos, g_cos).
pub type Fits = (Vec<Axis>, Vec<(String, ArrayD<f32>)>);

/// The axes and fitted values of zh_convolution on the default preset's whole
/// domain, for `zh_lobe` to measure the fitted lobes at its own probe points:
/// those this build made (`context`) when it made them, else built now
/// (quietly, with the same degree and method), so that zh_lobe's manifest
/// does not depend on which tables were built with it (`--table zh_lobe`
/// alone, an incremental build, a cluster merge).
pub fn default_fits(context: &Arc<BuildContext>, degree: Option<usize>, method: Option<Method>) -> Result<Fits> {
    let whole = |axes: &[Axis]| axes.iter().zip(&grid(Preset::Default).axes).all(|(a, b)| a.min() == b.min() && a.max() == b.max());
    if let Some(fits) = context.fits().filter(|(axes, _)| whole(axes)) {
        return Ok(fits);
    }
    info!("zh_lobe's accuracy compares the fitted lobes: building zh_convolution (default preset) in this process");
    let options = BuildOptions { progress: Progress { quiet: true }, degree, method, context: Some(context.clone()), ..Default::default() };
    let built = ZH_CONVOLUTION.build(Preset::Default, &options)?;
    Ok((built.table.axes, built.table.values))
}

/// The grid: axes, and the physical beta at each (p index, beta index).
pub struct Grid {
    pub axes: Vec<Axis>,
    pub beta: Array2<f64>,
}

pub fn grid(preset: Preset) -> Grid {
    match preset {
        Preset::Paper => {
            let u: Vec<f64> = (0..=20)
                .map(|i| i as f64 / 20.0)
                .chain((2..=10).map(f64::from))
                .chain((3..=10).map(|i| 5.0 * i as f64))
                .chain((6..=10).map(|i| 10.0 * i as f64))
                .collect();
            let c: Vec<f64> = (0..11).map(|j| (302.0 - 20.0 * j as f64) / 100.0).collect();
            let p: Vec<f64> = (0..25).map(|k| (50.0 - 2.0 * k as f64) / 10.0).collect();
            let frac: Vec<f64> = (0..10).map(|m| (m as f64 + 0.5) / 10.0).collect();
            let beta = Array2::from_shape_fn((25, 10), |(k, m)| frac[m] * PAPER_BETA_MAX[k]);
            Grid {
                axes: vec![
                    Axis::new("u", u, AxisEncoding::Linear),
                    Axis::new("c", c, AxisEncoding::Linear),
                    Axis::new("p", p, AxisEncoding::Linear),
                    Axis::new("beta_over_beta_max", frac, AxisEncoding::Linear),
                ],
                beta,
            }
        }
        Preset::Default => {
            let axes = vec![
                Axis::uniform("u", AxisEncoding::ShiftedLog { shift: -1.0 }, 0.0, 100.0, 33),
                Axis::uniform("c", AxisEncoding::Linear, 1.02, 3.02, 11),
                Axis::uniform("p", AxisEncoding::Log, 0.2, 5.0, 17),
                Axis::uniform("beta", AxisEncoding::Log, 0.005, 0.5, 17),
            ];
            let beta = Array2::from_shape_fn((axes[2].len(), axes[3].len()), |(_, m)| axes[3].nodes[m]);
            Grid { axes, beta }
        }
    }
}

/// What each node yields.
#[derive(Clone, Copy, Debug)]
pub(super) struct NodeFit {
    pub(super) plain: Fit,
    pub(super) cos: Fit,
    /// Computed by the direct integral.
    pub(super) exact: bool,
}

/// The fit samples as the fit needs them.
pub(super) struct Samples {
    sin2: Vec<f64>,
    cos2: Vec<f64>,
    ones: Vec<f64>,
    pub(super) theta: Vec<f64>,
}

impl Samples {
    fn new() -> Samples {
        let smp = samples();
        Samples {
            sin2: smp.iter().map(|x| x.0).collect(),
            cos2: smp.iter().map(|x| x.1).collect(),
            ones: vec![1.0; smp.len()],
            theta: smp.iter().map(|x| x.0.sqrt().asin()).collect(),
        }
    }
}

/// Fits both variants to `data`, warm-started from `previous` (the neighbouring
/// node), falling back to the data's own initial guess if that fails.
fn fit_both(smp: &Samples, data: &[f64], c: f64, previous: Option<&NodeFit>) -> (Fit, Fit) {
    let one = |weight: &[f64], warm: Option<Fit>| {
        // A neighbour on the bound s = 0 is no start: g is undetermined there.
        let warm = warm.filter(|w| w.s > 0.0 && w.converged);
        let guess = || initial_guess(&smp.sin2, weight, data, c);
        let first = fit(&smp.sin2, weight, data, c, warm.map_or_else(guess, |w| (w.s, w.g)));
        if first.converged || warm.is_none() {
            first
        } else {
            fit(&smp.sin2, weight, data, c, guess())
        }
    };
    (one(&smp.ones, previous.map(|p| p.plain)), one(&smp.cos2, previous.map(|p| p.cos)))
}

/// The plain and cos fits of a lobe given at the fit samples of docs/maths.md section 4
/// (`data`), warm-started from a neighbouring node's fits when given (a material's `zh_convolution`).
pub fn fit_lobe(data: &[f64], c: f64, previous: Option<(Fit, Fit)>) -> (Fit, Fit) {
    let previous = previous.map(|(plain, cos)| NodeFit { plain, cos, exact: false });
    fit_both(&Samples::new(), data, c, previous.as_ref())
}

/// Coefficient tables: F for every (u, c), G for every (p, beta), to degree `n`.
pub fn all_coefficients(grid: &Grid, rule: &ThetaRule, n: usize) -> (Array2<f64>, Array2<f64>) {
    let w = rule.weighted_legendre(n);
    let (us, cs) = (&grid.axes[0].nodes, &grid.axes[1].nodes);
    let uc: Vec<(f64, f64)> = us.iter().flat_map(|&u| cs.iter().map(move |&c| (u, c))).collect();
    let ps = &grid.axes[2].nodes;
    let pb: Vec<(f64, f64)> = grid.beta.indexed_iter().map(|((k, _), &b)| (ps[k], b)).collect();
    (s_coefficients(rule, &w, &uc), d_coefficients(rule, &w, &pb))
}

/// F_l of the lobes S(u, c), one row per (u, c) of `uc`; `w` the rule's
/// weighted Legendre matrix. A row does not depend on the other rows.
pub fn s_coefficients(rule: &ThetaRule, w: &Array2<f64>, uc: &[(f64, f64)]) -> Array2<f64> {
    let lobes: Vec<_> = uc.iter().map(|&(u, c)| move |s2: f64, c2: f64| s_lobe(s2, c2, u, c)).collect();
    coefficients(rule, w, &lobes)
}

/// G_l of the lobes D(beta, p), one row per (p, beta) of `pb` (see `s_coefficients`).
pub fn d_coefficients(rule: &ThetaRule, w: &Array2<f64>, pb: &[(f64, f64)]) -> Array2<f64> {
    let lobes: Vec<_> = pb.iter().map(|&(p, b)| move |s2: f64, c2: f64| d_lobe(s2, c2, p, b)).collect();
    coefficients(rule, w, &lobes)
}

/// `auto`: the degree one node needs, from its terms h_l = F_l G_l and
/// weights pi (2l + 1): C(0) = sum_l w_l h_l at the peak, and the terms past a
/// degree bound the truncation (|P_l| <= 1).
pub fn auto_degree(h: &[f64], weight: &[f64]) -> usize {
    let c0: f64 = h.iter().zip(weight).map(|(h, w)| h * w).sum::<f64>().abs();
    let mut tail = 0.0;
    let mut needed = h.len();
    for l in (0..h.len()).rev() {
        tail += (h[l] * weight[l]).abs();
        if tail > AUTO_TAIL * c0 {
            break;
        }
        needed = l;
    }
    (needed.div_ceil(16).max(1) * 16).min(h.len())
}

fn job(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    let full = grid(preset);
    let (axes, kept) = restrict(full.axes, options)?;
    let beta = full.beta.slice(ndarray::s![kept[2].clone(), kept[3].clone()]).to_owned();
    let degree = options.degree.unwrap_or(match preset {
        Preset::Paper => PAPER_DEGREE,
        Preset::Default => DEFAULT_DEGREE,
    });
    let method = options.method.unwrap_or(match preset {
        Preset::Paper => Method::Zh,
        Preset::Default => Method::Auto,
    });
    Ok(Box::new(ZhJob { grid: Grid { axes, beta }, preset, degree, method, context: options.context.clone() }))
}

/// One unit per (p, beta) pair (flat index ip * n_beta + ib): C for every
/// (u, c) in one matrix product, then the fits along u for each c (warm
/// starts run along u, inside the unit, so they do not depend on how the
/// pairs are shared out).
struct ZhJob {
    grid: Grid,
    preset: Preset,
    degree: usize,
    method: Method,
    /// The build's shared coefficient rows and fits (none: every compute from cold).
    context: Option<Arc<BuildContext>>,
}

/// The per-node fit diagnostics a part carries besides the values, per variant.
const FIT_EXTRAS: [&str; 5] = ["rel_l2", "rel_max", "converged", "iterations", "evaluations"];

fn fit_extras(fit: &Fit) -> [f64; 5] {
    [fit.rel_l2, fit.rel_max, f64::from(u8::from(fit.converged)), fit.iterations as f64, fit.evaluations as f64]
}

fn fit_from(s: f32, g: f32, extras: [f64; 5]) -> Fit {
    let [rel_l2, rel_max, converged, iterations, evaluations] = extras;
    Fit {
        s: f64::from(s),
        g: f64::from(g),
        rel_l2,
        rel_max,
        converged: converged != 0.0,
        iterations: iterations as usize,
        evaluations: evaluations as usize,
    }
}

impl ZhJob {
    fn shape(&self) -> Vec<usize> {
        self.grid.axes.iter().map(Axis::len).collect()
    }
}

impl Job for ZhJob {
    fn units(&self) -> usize {
        self.grid.axes[2].len() * self.grid.axes[3].len()
    }

    fn unit_len(&self) -> usize {
        self.grid.axes[0].len() * self.grid.axes[1].len()
    }

    fn unit_name(&self) -> &'static str {
        "(p, beta) pair (ip * n_beta + ib), nodes in (c, u) order"
    }

    fn compute(&self, units: Units, progress: Progress) -> Part {
        let (grid, degree, method) = (&self.grid, self.degree, self.method);
        let axes = &grid.axes;
        let shape = self.shape();
        let (n_u, n_c, n_b) = (shape[0], shape[1], shape[3]);
        let smp = Samples::new();
        let pairs: Vec<(usize, usize)> = units.iter().map(|k| (k / n_b, k % n_b)).collect();

        // F for every (u, c) is what any set of pairs costs; G for these pairs only.
        let start = Instant::now();
        let mut setup_seconds = 0.0;
        let (f, g) = if method == Method::Exact {
            (Array2::zeros((0, 0)), Array2::zeros((0, 0)))
        } else {
            let uc: Vec<(f64, f64)> = axes[0].nodes.iter().flat_map(|&u| axes[1].nodes.iter().map(move |&c| (u, c))).collect();
            let context = self.context.clone().unwrap_or_default();
            let f = context.s_coefficients(degree, &uc);
            setup_seconds = start.elapsed().as_secs_f64();
            let pb: Vec<(f64, f64)> = pairs.iter().map(|&(ip, ib)| (axes[2].nodes[ip], grid.beta[[ip, ib]])).collect();
            (f, context.d_coefficients(degree, &pb))
        };
        let coefficient_seconds = start.elapsed().as_secs_f64();
        let q = synthesis_matrix(degree);
        let weight: Vec<f64> = (0..degree).map(|l| PI * (2 * l + 1) as f64).collect();

        let start = Instant::now();
        let bar = progress.bar("zh_convolution", pairs.len() as u64);
        // Per task: the nodes, and CPU seconds in synthesis, direct integrals and fits.
        let results: Vec<(Vec<NodeFit>, [f64; 3])> = pairs
            .par_iter()
            .enumerate()
            .progress_with(bar.clone())
            .map(|(j, &(ip, ib))| {
                let mut cpu = [0.0; 3];
                let clock = Instant::now();
                let (p, beta) = (axes[2].nodes[ip], grid.beta[[ip, ib]]);
                // Rows iu * n_c + ic: the terms F_l G_l, the degree each row needs,
                // and (auto) whether the last quarter of the terms still matters.
                let curves = (method != Method::Exact).then(|| {
                    let gl = g.row(j);
                    let h = Array2::from_shape_fn((n_u * n_c, degree), |(r, l)| f[[r, l]] * gl[l]);
                    let plan: Vec<usize> = h
                        .rows()
                        .into_iter()
                        .map(|row| if method == Method::Auto { auto_degree(&row.to_vec(), &weight) } else { degree })
                        .collect();
                    let needed = plan.iter().copied().max().unwrap_or(1);
                    let cl = h.slice(ndarray::s![.., ..needed]).dot(&q.slice(ndarray::s![..needed, ..]));
                    let last = degree - degree / 4;
                    let converged: Vec<bool> = (0..n_u * n_c)
                        .map(|r| {
                            if method != Method::Auto || plan[r] <= last {
                                return true;
                            }
                            let tail = h.slice(ndarray::s![r, last..]).dot(&q.slice(ndarray::s![last.., ..]));
                            let max_c = cl.row(r).iter().fold(0.0f64, |m, x| m.max(x.abs()));
                            tail.iter().fold(0.0f64, |m, x| m.max(x.abs())) <= AUTO_TOLERANCE * max_c
                        })
                        .collect();
                    (cl, converged)
                });
                cpu[0] += clock.elapsed().as_secs_f64();
                let mut out: Vec<NodeFit> = Vec::with_capacity(n_u * n_c);
                for ic in 0..n_c {
                    let c = axes[1].nodes[ic];
                    let mut previous: Option<NodeFit> = None;
                    for iu in 0..n_u {
                        let u = axes[0].nodes[iu];
                        let zh_row = curves.as_ref().and_then(|(cl, converged)| {
                            let r = iu * n_c + ic;
                            converged[r].then(|| cl.row(r).to_vec())
                        });
                        let needs_exact = zh_row.is_none();
                        let clock = Instant::now();
                        let data = match zh_row {
                            Some(row) => row,
                            None => smp.theta.iter().map(|&th| exact_convolution(th, &LobeParams { u, c, p, beta }, EXACT_REL_TOL)).collect(),
                        };
                        cpu[1] += clock.elapsed().as_secs_f64();
                        let clock = Instant::now();
                        let (plain, cos) = fit_both(&smp, &data, c, previous.as_ref());
                        cpu[2] += clock.elapsed().as_secs_f64();
                        let r = NodeFit { plain, cos, exact: needs_exact };
                        previous = Some(r);
                        out.push(r);
                    }
                }
                (out, cpu)
            })
            .collect();
        bar.finish_and_clear();
        let compute_seconds = coefficient_seconds + start.elapsed().as_secs_f64();
        let cpu = results.iter().fold([0.0; 3], |acc, (_, c)| [acc[0] + c[0], acc[1] + c[1], acc[2] + c[2]]);
        let stages = json!({
            "coefficients_seconds": coefficient_seconds,
            "synthesis_cpu_seconds": cpu[0],
            "direct_integral_cpu_seconds": cpu[1],
            "fits_cpu_seconds": cpu[2],
        });

        let nodes = || results.iter().flat_map(|(block, _)| block);
        let value = |name: &str, pick: fn(&NodeFit) -> f64| (name.to_string(), nodes().map(|r| pick(r) as f32).collect());
        let values = vec![
            value("s", |r| r.plain.s),
            value("g", |r| r.plain.g),
            value("s_cos", |r| r.cos.s),
            value("g_cos", |r| r.cos.g),
        ];
        let mut extras = Vec::new();
        for (variant, pick) in [("plain", (|r: &NodeFit| r.plain) as fn(&NodeFit) -> Fit), ("cos", |r: &NodeFit| r.cos)] {
            for (i, name) in FIT_EXTRAS.iter().enumerate() {
                extras.push((format!("{variant}_{name}"), nodes().map(|r| fit_extras(&pick(r))[i]).collect()));
            }
        }
        extras.push(("exact".to_string(), nodes().map(|r| f64::from(u8::from(r.exact))).collect()));
        Part { values, extras, compute_seconds, setup_seconds, stages }
    }

    fn finish(&self, whole: Part) -> Built {
        let (grid, preset, degree, method) = (&self.grid, self.preset, self.degree, self.method);
        let shape = self.shape();
        let (n_u, n_c, n_p, n_b) = (shape[0], shape[1], shape[2], shape[3]);
        let column = |name: &str| -> &[f64] { &whole.extras.iter().find(|(n, _)| n == name).expect("zh part column").1 };
        let fit_at = |variant: &str, s: &[f32], g: &[f32], j: usize| {
            let extras = FIT_EXTRAS.map(|name| column(&format!("{variant}_{name}"))[j]);
            fit_from(s[j], g[j], extras)
        };
        let value = |i: usize| -> &[f32] { &whole.values[i].1 };
        let exact = column("exact");

        // Scatter the units' (c, u)-ordered nodes into (u, c, p, beta) order.
        let mut node = vec![None; n_u * n_c * n_p * n_b];
        for j in 0..node.len() {
            let (pair, k) = (j / (n_u * n_c), j % (n_u * n_c));
            let (ip, ib, ic, iu) = (pair / n_b, pair % n_b, k / n_u, k % n_u);
            node[((iu * n_c + ic) * n_p + ip) * n_b + ib] = Some(NodeFit {
                plain: fit_at("plain", value(0), value(1), j),
                cos: fit_at("cos", value(2), value(3), j),
                exact: exact[j] != 0.0,
            });
        }
        let node: Vec<NodeFit> = node.into_iter().map(|r| r.expect("every node fitted")).collect();
        let array = |pick: fn(&NodeFit) -> f64| {
            ArrayD::from_shape_vec(IxDyn(&shape), node.iter().map(|r| pick(r) as f32).collect()).expect("shape")
        };
        let values = vec![
            ("s".to_string(), array(|r| r.plain.s)),
            ("g".to_string(), array(|r| r.plain.g)),
            ("s_cos".to_string(), array(|r| r.cos.s)),
            ("g_cos".to_string(), array(|r| r.cos.g)),
        ];

        let start = Instant::now();
        let rule = ThetaRule::standard(degree);
        let accuracy = super::zh_budget::error_budget(grid, preset, degree, method, &rule, &node, &values, &Samples::new());
        let accuracy_seconds = start.elapsed().as_secs_f64();
        let axes = &grid.axes;
        let mut settings = json!({
            "degree": degree,
            "method": method.name(),
            "auto_tolerance": AUTO_TOLERANCE,
            "auto_tail": AUTO_TAIL,
            "exact_rel_tol": EXACT_REL_TOL,
            "coefficients": format!("composite Gauss-Legendre in theta, {} nodes (24 per panel, geometric ratio 1.2 \
                                     from 1e-7 towards both ends, uniform panels <= min(0.02, 10/L) between), to degree {degree}", rule.len()),
            "fit": "damped Newton (Levenberg-Marquardt damping on the full Hessian), analytic derivatives, s, g >= 0, warm-started along u",
        });
        if preset == Preset::Paper {
            settings["beta_max"] = json!({ "p": axes[2].nodes, "beta_max": PAPER_BETA_MAX,
                "beta": "beta = beta_over_beta_max * beta_max(p) (the paper's grid: beta depends on p)" });
        }
        if let (Preset::Default, Some(context)) = (preset, &self.context) {
            context.remember_fits((grid.axes.clone(), values.clone()));
        }
        let table = Table { name: ZH_CONVOLUTION.name.into(), preset: preset.name().into(), axes: grid.axes.clone(), values };
        Built { table, accuracy, settings, compute_seconds: whole.compute_seconds, accuracy_seconds, stages: whole.stages, derived: Default::default() }
    }
}
