//! Stage `zh-convolution`: the table `zh_convolution` (docs/maths.md section 4). The
//! diffraction lobe S(u, c) convolved by the NDF D(beta, p), computed as the
//! zonal-harmonic sum C_L (or the direct integral where C_L is not accurate
//! enough), sampled at the 1000 angles of docs/maths.md section 4 and fitted by a
//! K-correlation lobe, plain (s, g) and times cos^2 (s_cos, g_cos).

use super::context::BuildContext;
use super::job::{Built, Job, Part, Units};
use super::options::{BuildOptions, Method};
use super::preset::Preset;
use super::sub_domain::restrict;
use super::table_def::TableDef;
use super::zh_fit::Fit;
use super::zh_grid::{
    auto_degree, fit_both, grid, Fits, Grid, NodeFit, Samples, AUTO_TAIL, AUTO_TOLERANCE, DEFAULT_DEGREE,
    EXACT_REL_TOL, LN_VALUES, PAPER_BETA_MAX, PAPER_DEGREE,
};
use super::zh_math::{exact_convolution, synthesis_matrix, ThetaRule};
use crate::progress::Progress;
use anyhow::Result;
use indicatif::ParallelProgressIterator;
use ndarray::{Array2, ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::json;
use std::f64::consts::PI;
use std::sync::Arc;
use std::time::Instant;
use tracing::info;
use twoscale_tables::axis::Axis;
use twoscale_tables::derived::{Derived, EncodedValue, ValueEncoding};
use twoscale_tables::lobe::LobeParams;
use twoscale_tables::table::Table;

pub const ZH_CONVOLUTION: TableDef = TableDef {
    name: "zh_convolution",
    stage: "zh-convolution",
    definition:
        "docs/maths.md section 4: C(theta_h) = int S(h.m) D(n.m) dm with S(t) = (1 + 4u^2(1-t^2))^(-(c+1)/2) t^2 \
                 and D(t) = exp(-((1-t^2)/(t^2 beta^2))^p) / t^4, fitted over sin(theta_k) = 1 - k/1000 by \
                 s (1 + 4 g^2 sin^2)^(-(c+1)/2) (values s, g) and by the same times cos^2 (values s_cos, g_cos); \
                 s and s_cos stored as their ln",
    axes: |preset| grid(preset).axes,
    diffraction: true,
    cubic: false,
    job,
    presets: &Preset::ALL,
};

/// The axes and fitted values of zh_convolution on the default preset's whole
/// domain, for `zh_lobe` to measure the fitted lobes at its own probe points:
/// those this build made (`context`) when it made them, else built now
/// (quietly, with the same degree and method), so that zh_lobe's manifest
/// does not depend on which tables were built with it (`--table zh_lobe`
/// alone, an incremental build, a cluster merge).
pub fn default_fits(context: &Arc<BuildContext>, degree: Option<usize>, method: Option<Method>) -> Result<Fits> {
    let whole = |axes: &[Axis]| {
        axes.iter().zip(&grid(Preset::Default).axes).all(|(a, b)| a.min() == b.min() && a.max() == b.max())
    };
    if let Some(fits) = context.fits().filter(|(axes, _)| whole(axes)) {
        return Ok(fits);
    }
    info!("zh_lobe's accuracy compares the fitted lobes: building zh_convolution (default preset) in this process");
    let options = BuildOptions {
        progress: Progress { quiet: true },
        degree,
        method,
        context: Some(context.clone()),
        ..Default::default()
    };
    let built = ZH_CONVOLUTION.build(Preset::Default, &options)?;
    Ok((built.table.axes, built.table.values))
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
            let uc: Vec<(f64, f64)> =
                axes[0].nodes.iter().flat_map(|&u| axes[1].nodes.iter().map(move |&c| (u, c))).collect();
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
                            None => smp
                                .theta
                                .iter()
                                .map(|&th| exact_convolution(th, &LobeParams { u, c, p, beta }, EXACT_REL_TOL))
                                .collect(),
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
        let value =
            |name: &str, pick: fn(&NodeFit) -> f64| (name.to_string(), nodes().map(|r| pick(r) as f32).collect());
        let values = vec![
            value("s", |r| r.plain.s),
            value("g", |r| r.plain.g),
            value("s_cos", |r| r.cos.s),
            value("g_cos", |r| r.cos.g),
        ];
        let mut extras = Vec::new();
        for (variant, pick) in [("plain", (|r: &NodeFit| r.plain) as fn(&NodeFit) -> Fit), ("cos", |r: &NodeFit| r.cos)]
        {
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
        let column =
            |name: &str| -> &[f64] { &whole.extras.iter().find(|(n, _)| n == name).expect("zh part column").1 };
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
        // s and s_cos as their ln (LN_VALUES): the fits keep s > 0.
        let values = vec![
            ("s".to_string(), array(|r| r.plain.s.ln())),
            ("g".to_string(), array(|r| r.plain.g)),
            ("s_cos".to_string(), array(|r| r.cos.s.ln())),
            ("g_cos".to_string(), array(|r| r.cos.g)),
        ];
        let derived = Derived {
            values: LN_VALUES
                .iter()
                .map(|&name| EncodedValue {
                    value: name.into(),
                    encoding: ValueEncoding::Ln,
                    control_variates: vec![],
                    formula: format!("{name} = exp(stored): the stored value is ln {name}, interpolated multilinearly"),
                })
                .collect(),
            ..Derived::default()
        };

        let start = Instant::now();
        let rule = ThetaRule::standard(degree);
        let accuracy =
            super::zh_budget::error_budget(grid, preset, degree, method, &rule, &node, &values, &Samples::new());
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
        let table =
            Table { name: ZH_CONVOLUTION.name.into(), preset: preset.name().into(), axes: grid.axes.clone(), values };
        Built {
            table,
            accuracy,
            settings,
            compute_seconds: whole.compute_seconds,
            accuracy_seconds,
            stages: whole.stages,
            derived,
        }
    }
}
